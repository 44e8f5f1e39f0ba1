#include "sim/scene_import.hpp"

#include "rig/file_io.hpp"
#include "sim/scene_checks.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>

namespace terrain::sim {
namespace {

// A world as a user writes one: no robot, no sky, no light; a library of two touching boxes in one
// body, a dorm turned 30 degrees, an oak (trunk and crown), a lamp post no pattern names and an
// unnamed block
constexpr char kCampus[] = R"(<mujoco model="campus">
  <asset><material name="brick" rgba="0.62 0.5 0.44 1"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="50 50 1"/>
    <body name="library">
      <geom name="library_main" type="box" pos="5 20 8" size="10 5 8" material="brick"/>
      <geom name="library_wing" type="box" pos="18 20 4" size="3 5 4" material="brick"/>
    </body>
    <geom name="dorm" type="box" pos="-15 -20 12" size="5 5 12" euler="0 0 30"/>
    <geom name="oak_trunk" type="cylinder" pos="10 -10 3" size="0.3 3"/>
    <geom name="oak_crown" type="sphere" pos="10 -10 9" size="3.5"/>
    <geom name="lamp_post" type="cylinder" pos="0 4 2" size="0.1 2"/>
    <geom type="box" pos="-30 10 0.5" size="1 1 0.5"/>
  </worldbody>
</mujoco>)";

const scenes::ObjectTruth* object(const scenes::SceneTruth& t, const std::string& id) {
  for (const auto& o : t.objects) {
    if (o.id == id) return &o;
  }
  return nullptr;
}

TEST(SceneImportTest, ACampusWorldGivesItsObjectsClassesAndAPathWithRoom) {
  test::TempDir dir;
  io::writeFileAtomic(dir / "campus.xml", kCampus, true);
  ImportOptions options;
  options.patterns["building"].push_back("library");  // as a --classes file would add
  options.patterns["building"].push_back("dorm");
  const ImportedScene s = importScene(dir / "campus.xml", dir / "scene.xml", options);
  ASSERT_EQ(s.truth.objects.size(), 3u);
  const auto* library = object(s.truth, "library_main");
  ASSERT_TRUE(library);
  EXPECT_EQ(library->object_class, scenes::GeomClass::Building);
  EXPECT_EQ(library->geoms, (std::vector<std::string>{"library_main", "library_wing"}));
  EXPECT_DOUBLE_EQ(library->top_height, 16);
  EXPECT_DOUBLE_EQ(library->base_height, 0);
  ASSERT_EQ(library->footprint.size(), 4u);  // the hull of both boxes: x -5..21, y 15..25
  for (const auto& p : library->footprint) {
    EXPECT_TRUE(p.x() == -5 || p.x() == 21) << p.transpose();
    EXPECT_TRUE(p.y() == 15 || p.y() == 25) << p.transpose();
  }
  // the dorm's corners turned 30 degrees about (-15, -20): (5, 5) turns to (1.83, 6.83)
  const auto* dorm = object(s.truth, "dorm");
  ASSERT_TRUE(dorm);
  EXPECT_DOUBLE_EQ(dorm->top_height, 24);
  ASSERT_EQ(dorm->footprint.size(), 4u);
  EXPECT_TRUE(std::any_of(dorm->footprint.begin(), dorm->footprint.end(), [](const Eigen::Vector2d& p) {
    return (p - Eigen::Vector2d(-13.17, -13.17)).norm() < 0.01;
  }));
  const auto* oak = object(s.truth, "oak_crown");
  ASSERT_TRUE(oak);
  EXPECT_EQ(oak->object_class, scenes::GeomClass::Crown);
  EXPECT_EQ(oak->geoms, (std::vector<std::string>{"oak_crown", "oak_trunk"}));
  EXPECT_DOUBLE_EQ(oak->top_height, 12.5);
  EXPECT_EQ(s.unclassified.size(), 2u);
  EXPECT_EQ(s.unclassified[0], "lamp_post");
  EXPECT_NE(s.unclassified[1].find("unnamed"), std::string::npos);
  // the line along x through the middle: 6.5 m from the library (y 15) and 6.5 from the oak's crown
  ASSERT_EQ(s.truth.path.size(), 2u);
  EXPECT_EQ(s.truth.path[0], Eigen::Vector2d(-45, 0));
  EXPECT_EQ(s.truth.path[1], Eigen::Vector2d(45, 0));
  EXPECT_NEAR(s.path_clearance, 6.5, 1e-9);
  EXPECT_EQ(s.added.size(), 3u);  // a skybox, a light, the robot with its camera

  // the scene loads as the testbed reads it, and its checks find nothing wrong
  io::writeFileAtomic(dir / "scene.xml", s.mjcf, true);
  io::writeFileAtomic(dir / "scene.truth.json", scenes::truthToJson(s.truth), true);
  const World world(dir / "scene.xml");
  const SceneProblems problems = checkScene(world, SimConfig{});
  EXPECT_TRUE(problems.errors.empty());
  EXPECT_TRUE(problems.warnings.empty()) << problems.warnings.front();
  EXPECT_EQ(world.unclassifiedGeoms().size(), 2u);
}

TEST(SceneImportTest, WhatCannotBeImportedIsRefusedWithTheReason) {
  test::TempDir dir;
  // a wall of buildings across the whole terrain leaves no straight path along x
  io::writeFileAtomic(dir / "blocked.xml", R"(<mujoco><worldbody>
    <geom name="ground" type="plane" size="20 20 1"/>
    <geom name="building_wall" type="box" pos="0 0 5" size="1 20 5"/>
  </worldbody></mujoco>)",
                      true);
  try {
    importScene(dir / "blocked.xml", dir / "s.xml", ImportOptions{});
    FAIL() << "no error";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no straight path along x"), std::string::npos) << e.what();
  }
  // no plane or heightfield
  io::writeFileAtomic(dir / "floating.xml",
                      R"(<mujoco><worldbody><geom name="house" type="box" size="1 1 1"/></worldbody></mujoco>)", true);
  EXPECT_THROW(importScene(dir / "floating.xml", dir / "s.xml", ImportOptions{}), io::InputError);
  // a class file with a class that does not exist, and one whose patterns are not a list
  ImportOptions options;
  io::writeFileAtomic(dir / "a.yaml", "building: [hall]\ntree: [oak]\n", true);
  try {
    loadImportPatterns(dir / "a.yaml", options);
    FAIL() << "no error";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("a.yaml:2: unknown class 'tree'"), std::string::npos) << e.what();
  }
  io::writeFileAtomic(dir / "b.yaml", "crown: oak\n", true);
  EXPECT_THROW(loadImportPatterns(dir / "b.yaml", options), io::InputError);
}

}  // namespace
}  // namespace terrain::sim
