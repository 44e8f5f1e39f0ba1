#pragma once
// Helpers shared by the tests: scratch directories and tiny inline worlds.

#include "core/pipeline.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"
#include "scenes/scene_truth.hpp"
#include "sim/world.hpp"
#include "tests/cli_support.hpp"
#include "tests/core/core_test_support.hpp"
#include "tests/temp_dir.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <random>
#include <string>

namespace terrain::test {

// The robot's body in a test scene's worldbody: its chassis and mast, which the lidar leaves out.
inline const std::string kRobotBody = R"(    <body name="robot" mocap="true">
      <geom name="robot_chassis" type="box" size="0.5 0.35 0.2" pos="0 0 0.35" group="3"/>
      <geom name="robot_mast" type="cylinder" size="0.04 0.8" pos="0 0 1" group="3"/>
      <camera name="robot_camera" pos="0.1 0 1.6" xyaxes="0 -1 0 0 0 1" fovy="60"/>
    </body>
)";

// A flat plane named "ground", one box geom (class building) named `name` with its centre and half
// sizes [m], and the robot body with its camera, as generated scenes have them; with sky, a
// gradient skybox of daylight blue (the sky test of boundary estimation passes on it).
inline std::string boxScene(const std::string& name, const Eigen::Vector3d& centre, const Eigen::Vector3d& half,
                            bool sky = false) {
  const auto v3 = [](const Eigen::Vector3d& v) {
    return std::to_string(v.x()) + " " + std::to_string(v.y()) + " " + std::to_string(v.z());
  };
  return R"(<mujoco>
  <statistic extent="100" center="0 0 0"/>
  <visual><global offwidth="160" offheight="120"/><quality offsamples="0"/><map znear="0.002" zfar="3"/></visual>
)" +
         std::string(
             sky ? R"(  <asset><texture name="sky" type="skybox" builtin="gradient" rgb1="0.45 0.65 0.95" rgb2="0.7 0.8 1" width="64" height="64"/></asset>
)"
                 : "") +
         R"(  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <light directional="true" pos="0 0 50" dir="0 0 -1"/>
    <geom name="ground" type="plane" size="60 60 1" rgba="0.3 0.5 0.3 1"/>
    <geom name=")" +
         name + R"(" type="box" pos=")" + v3(centre) + R"(" size=")" + v3(half) +
         R"(" rgba="0.7 0.7 0.7 1" group="1"/>
)" + kRobotBody +
         R"(  </worldbody>
</mujoco>)";
}

// The truth of boxScene: the box a building standing on z = 0 up to top_height, the robot driving
// the given path.
inline scenes::SceneTruth boxTruth(const std::string& name, const Eigen::Vector3d& centre, const Eigen::Vector3d& half,
                                   std::vector<Eigen::Vector2d> path) {
  scenes::SceneTruth t;
  t.type = "test";
  t.extent = 60;
  t.terrain.kind = "plane";
  scenes::ObjectTruth box;
  box.id = name;
  box.object_class = scenes::GeomClass::Building;
  box.geoms = {name};
  const double x0 = centre.x() - half.x(), x1 = centre.x() + half.x(), y0 = centre.y() - half.y(),
               y1 = centre.y() + half.y();
  box.footprint = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  box.top_height = centre.z() + half.z();
  t.objects.push_back(box);
  t.path = std::move(path);
  t.origin = {37.5585, 126.999, 60.0};
  return t;
}

// A 20 m wall 1 m thick and 80 m long whose near face is at x = wall_x, the robot at the origin
// facing it.
inline std::string wallScene(double wall_x) { return boxScene("wall", {wall_x + 0.5, 0, 10}, {0.5, 40, 10}); }

inline scenes::SceneTruth wallTruth(double wall_x) {
  return boxTruth("wall", {wall_x + 0.5, 0, 10}, {0.5, 40, 10}, {{0, 0}, {1, 0}});
}

inline std::shared_ptr<sim::World> wallWorld(double wall_x) {
  return std::make_shared<sim::World>(wallScene(wall_x), wallTruth(wall_x));
}

// a pipeline holding two 3 x 3 patches of cells (0.2 m), `apart` cells apart along x
inline std::unique_ptr<Pipeline> twoPatches(int apart) {
  auto p = std::make_unique<Pipeline>(RigCalibration{}, PipelineConfig{});
  std::vector<Voxel> voxels;
  std::vector<MeshVertex> vertices;
  for (const int x0 : {0, apart}) {
    for (int x = x0; x < x0 + 3; ++x) {
      for (int y = 0; y < 3; ++y) addColumn(voxels, vertices, CellIndex(x, y), 5, 1.1f + 0.01f * y, VoxelLabel::Ground);
    }
  }
  SegmentationResult seg;
  seg.rough.assign(voxels.size(), 1);
  seg.refined.assign(voxels.size(), 1);
  seg.ground_height.assign(voxels.size(), 1.1f);
  EXPECT_TRUE(p->restore(voxels, vertices, seg, {}));
  return p;
}

}  // namespace terrain::test
