#include "core/pipeline.hpp"

#include "evaluation/scoring.hpp"
#include "scenes/scene_generator.hpp"
#include "sim/simulated_rig.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace terrain {
namespace {

std::shared_ptr<sim::World> urbanWorld(const test::TempDir& dir) {
  scenes::SceneConfig cfg;
  cfg.type = "urban";
  cfg.seed = 3;
  cfg.extent = 50;
  scenes::writeScene(scenes::generateScene(cfg), dir / "u.xml", false);
  return std::make_shared<sim::World>(dir / "u.xml");
}

// true if some warning contains the text
bool hasWarning(const Pipeline& pipeline, const std::string& text) {
  for (const auto& w : pipeline.warnings()) {
    if (w.find(text) != std::string::npos) return true;
  }
  return false;
}

sim::SimConfig smallCamera() {
  sim::SimConfig c;
  c.camera.width = 320;
  c.camera.height = 240;
  return c;
}

TEST(PoseEstimationTest, GpsAndGyroFusionTracksTheTruePose) {
  test::TempDir dir;
  auto world = urbanWorld(dir);
  sim::SimulatedRig rig(world, smallCamera(), 40);
  PoseEstimator poses(rig.calibration(), PoseConfig{});
  std::vector<rig::FrameTruth> truths;
  while (auto f = rig.next()) {
    poses.add(f->sensors);
    truths.push_back(*f->truth);
  }
  ASSERT_TRUE(poses.ready());
  double worst_pos = 0, worst_angle = 0;
  for (const auto& t : truths) {
    for (const auto& p : t.poses) {
      if (p.time > poses.finalUntil()) continue;
      const Pose est = poses.worldFromVehicle(p.time);
      worst_pos = std::max(worst_pos, (est.translation() - p.world_from_vehicle.translation()).norm());
      worst_angle =
          std::max(worst_angle, Eigen::AngleAxisd(est.linear().transpose() * p.world_from_vehicle.linear()).angle());
    }
  }
  // GPS sigma 5 cm horizontal, 10 cm vertical, smoothed; heading from a 2 m baseline
  EXPECT_LT(worst_pos, 0.12);
  EXPECT_LT(worst_angle, 3.0 * M_PI / 180);
}

TEST(PipelineTest, FullRunBringsObjectHeightsCloserToTheTruth) {
  test::TempDir dir;
  auto world = urbanWorld(dir);
  sim::SimulatedRig rig(world, smallCamera(), 30);
  Pipeline pipeline(rig.calibration(), PipelineConfig{});
  std::vector<Point3> path;
  while (auto f = rig.next()) {
    for (const auto& p : f->truth->poses) path.push_back(p.world_from_vehicle.translation());
    pipeline.process(f->sensors);
  }
  pipeline.finish();
  ASSERT_EQ(pipeline.records().size(), 30u);
  const auto h = eval::scoreHeights(pipeline.mesh(), pipeline.map(), *world, path);
  ASSERT_GT(h.seen_after.count, 50u);
  EXPECT_LT(h.seen_after.mae, 0.5 * h.seen_before.mae) << h.seen_before.mae << " -> " << h.seen_after.mae;
  EXPECT_LT(h.after.mae, h.before.mae);
  // object cells the camera saw are where the recovery happens: all raised cells are among them or
  // next to them, and their error falls
  const auto& seen = h.by_view.at("in_camera_view");
  ASSERT_GT(seen.first.count, 50u);
  EXPECT_LT(seen.second.mae, seen.first.mae);
  EXPECT_GT(h.raised_by_view.at("in_camera_view"),
            h.raised_by_view.count("never_in_camera_view") ? h.raised_by_view.at("never_in_camera_view") : 0u);
  EXPECT_EQ(seen.first.count +
                (h.by_view.count("never_in_camera_view") ? h.by_view.at("never_in_camera_view").first.count : 0u),
            h.before.count);
  // the segmentation found ground and objects
  std::size_t ground = 0;
  for (auto g : pipeline.segmentation().refined) ground += g;
  EXPECT_GT(ground, pipeline.map().size() / 2);
  EXPECT_LT(ground, pipeline.map().size());
}

// A 20 m block 15 m behind the start of a drive forward, 10 m wide: only the rear camera of the
// surround rig sees it (the side cameras' views end 45.6 degrees either side of their axes). Its
// top, far above the lidar's cap, is recovered with the surround rig and not with the paper's
// forward camera.
const Eigen::Vector3d kBlockCentre(-17, 0, 10), kBlockHalf(2, 5, 10);

// the median height of the mesh vertices on the block's near face (x in [-15.4, -15])
double blockFaceHeight(const std::string& rig) {
  auto world = std::make_shared<sim::World>(test::boxScene("block", kBlockCentre, kBlockHalf, true),
                                            test::boxTruth("block", kBlockCentre, kBlockHalf, {{0, 0}, {12, 0}}));
  sim::SimConfig cfg;
  cfg.camera.rig = rig;
  cfg.camera.width = 320, cfg.camera.height = 240;
  sim::SimulatedRig source(world, cfg, 40);
  Pipeline pipeline(source.calibration(), PipelineConfig{});
  while (auto f = source.next()) pipeline.process(f->sensors);
  pipeline.finish();
  std::vector<double> h;
  const double cell = pipeline.map().voxelSize();
  for (const auto& v : pipeline.mesh().vertices()) {
    const double x = (v.cell.x() + 0.5) * cell, y = (v.cell.y() + 0.5) * cell;
    if (x >= -15.4 && x <= -15.0 && std::abs(y) < 4) h.push_back(v.height());
  }
  if (h.empty()) return std::nan("");
  std::sort(h.begin(), h.end());
  return h[h.size() / 2];
}

TEST(PipelineTest, ABlockOnlyTheRearCameraSeesGetsItsTrueHeight) {
  // the lidar senses the face up to 1.5 m above the sensor; the top is 20 m up
  EXPECT_NEAR(blockFaceHeight("surround"), 20.0, 2.0);
  EXPECT_LT(blockFaceHeight("forward"), 4.0);
}

// A tree 14 m left of a drive 8 m long: its trunk (0.3 m in radius) stands 8 m tall under a
// sphere crown 3 m in radius centred 10 m up, so the lidar (1.8 m up, its highest laser 2 degrees
// above the horizon) senses the trunk to about 2.3 m and never the crown, and the crown's top
// (38 degrees up from the left camera) lies within the cameras' view (up to 45.5 degrees). Crown
// completion raises the ground under the crown from the images alone.
const Eigen::Vector2d kTreeAt(6, 14);
constexpr double kCrownRadius = 3, kCrownCentre = 10, kCrownTop = kCrownCentre + kCrownRadius;

std::shared_ptr<sim::World> roadsideTree() {
  const std::string at = std::to_string(kTreeAt.x()) + " " + std::to_string(kTreeAt.y());
  const std::string scene = R"(<mujoco>
  <statistic extent="100" center="0 0 0"/>
  <visual><global offwidth="320" offheight="240"/><quality offsamples="0"/><map znear="0.002" zfar="3"/></visual>
  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.45 0.65 0.95" rgb2="0.7 0.8 1" width="64" height="64"/>
    <texture name="leaves" type="cube" builtin="flat" mark="random" random="0.35" rgb1="0.13 0.38 0.12" rgb2="0.13 0.38 0.12" markrgb="0.3 0.55 0.2" width="64" height="64"/>
    <material name="leaves" texture="leaves"/>
  </asset>
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <light directional="true" pos="0 0 50" dir="0 0 -1"/>
    <geom name="ground" type="plane" size="60 60 1" rgba="0.45 0.4 0.33 1"/>
    <geom name="tree_trunk" type="cylinder" pos=")" +
                            at + R"( 4" size="0.3 4" rgba="0.4 0.3 0.2 1"/>
    <geom name="tree_crown" type="sphere" material="leaves" pos=")" +
                            at + " " + std::to_string(kCrownCentre) + R"(" size=")" + std::to_string(kCrownRadius) +
                            R"("/>
)" + test::kRobotBody + R"(  </worldbody>
</mujoco>)";
  scenes::SceneTruth t;
  t.type = "test";
  t.extent = 60;
  t.terrain.kind = "plane";
  scenes::ObjectTruth tree;
  tree.id = "tree";
  tree.object_class = scenes::GeomClass::Crown;
  tree.geoms = {"tree_trunk", "tree_crown"};
  for (int i = 0; i < 12; ++i) {
    const double a = i * M_PI / 6;
    tree.footprint.push_back(kTreeAt + kCrownRadius * Eigen::Vector2d(std::cos(a), std::sin(a)));
  }
  tree.top_height = kCrownTop;
  t.objects.push_back(tree);
  t.path = {{0, 0}, {12, 0}};
  t.origin = {37.5585, 126.999, 60.0};
  return std::make_shared<sim::World>(scene, t);
}

TEST(PipelineTest, ATreeBesideThePathHasItsCrownFootprintRaisedToItsTop) {
  auto world = roadsideTree();
  sim::SimulatedRig source(world, smallCamera(), 40);
  Pipeline pipeline(source.calibration(), PipelineConfig{});
  while (auto f = source.next()) pipeline.process(f->sensors);
  pipeline.finish();
  const double cell = pipeline.map().voxelSize();
  int under = 0, outside = 0;
  for (const auto& v : pipeline.mesh().vertices()) {
    const Eigen::Vector2d p((v.cell.x() + 0.5) * cell, (v.cell.y() + 0.5) * cell);
    const double d = (p - kTreeAt).norm();
    if (d <= 2.0) {
      // within 2 m of the trunk: the crown's surface above the cell, to within 10 % of its top
      ++under;
      const double surface = kCrownCentre + std::sqrt(kCrownRadius * kCrownRadius - d * d);
      EXPECT_NEAR(v.height(), surface, 0.1 * kCrownTop)
          << "cell at (" << p.x() << ", " << p.y() << "), " << d << " m from the trunk";
    } else if (d > kCrownRadius + 1.0 && d < 15) {
      // the ground outside the crown left alone
      ++outside;
      EXPECT_FALSE(v.raised()) << "cell at (" << p.x() << ", " << p.y() << "), " << d << " m from the trunk, raised to "
                               << v.height() << " m";
    }
  }
  EXPECT_GT(under, 300);
  EXPECT_GT(outside, 1000);
}

TEST(PipelineTest, BadFramesGiveWarningsNotCrashes) {
  test::TempDir dir;
  auto world = urbanWorld(dir);
  sim::SimulatedRig rig(world, smallCamera(), 30);
  Pipeline pipeline(rig.calibration(), PipelineConfig{});
  int k = 0;
  while (auto f = rig.next()) {
    SensorFrame s = f->sensors;
    if (k == 12) s.sweep.points.clear();               // empty sweep
    if (k == 13) s.sweep.points[5].x = std::nanf("");  // NaN point
    if (k == 14) s.sweep.points[6].z = INFINITY;       // infinite point
    if (k == 15) s.images.clear();                     // no image
    if (k == 16) s.gps.clear();                        // no GPS fix
    if (k == 17) s.images.at(0).rgb = cv::Mat();       // empty image
    if (k == 18) s.gyro.clear();                       // no gyro
    pipeline.process(s);
    ++k;
  }
  pipeline.finish();
  auto has = [&](const std::string& text) { return hasWarning(pipeline, text); };
  EXPECT_TRUE(has("frame 12: empty lidar sweep"));
  EXPECT_TRUE(has("frame 13: 1 lidar points with NaN"));
  EXPECT_TRUE(has("frame 14: 1 lidar points with NaN"));
  EXPECT_TRUE(has("frame 15: no image from camera front"));
  EXPECT_TRUE(has("frame 16: no GPS fix"));
  EXPECT_TRUE(has("frame 17: camera front: image is empty"));
  EXPECT_TRUE(has("frame 18: no gyro samples"));
  EXPECT_EQ(pipeline.records().size(), 30u);
  for (const auto& v : pipeline.map().voxels()) ASSERT_TRUE(std::isfinite(v.height));
}

TEST(PipelineTest, AStandingRobotAndAnEmptyWorldAreReported) {
  // a robot that never moves never learns its heading; a world with only ground has no objects
  auto world = test::wallWorld(500.0);  // the wall is out of range: only ground is seen
  sim::SimConfig c = smallCamera();
  c.robot.speed = 0.001;
  sim::SimulatedRig rig(world, c, 5);
  Pipeline pipeline(rig.calibration(), PipelineConfig{});
  while (auto f = rig.next()) pipeline.process(f->sensors);
  pipeline.finish();
  auto has = [&](const std::string& text) { return hasWarning(pipeline, text); };
  EXPECT_TRUE(has("heading unknown"));
  EXPECT_TRUE(has("the camera sees no non-ground vertex") || has("no objects"));
  EXPECT_EQ(pipeline.records().size(), 5u);
}

}  // namespace
}  // namespace terrain
