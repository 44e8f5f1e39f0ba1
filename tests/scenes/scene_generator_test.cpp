#include "scenes/scene_generator.hpp"

#include "rig/file_io.hpp"
#include "sim/world.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <functional>

namespace terrain::scenes {
namespace {

namespace fs = std::filesystem;

TEST(SceneGeneratorTest, SameTypeAndSeedGiveByteIdenticalFiles) {
  test::TempDir dir;
  for (const auto& type : sceneTypes()) {
    SceneConfig cfg;
    cfg.type = type;
    cfg.seed = 9;
    writeScene(generateScene(cfg), dir / (type + "_a.xml"), false);
    writeScene(generateScene(cfg), dir / (type + "_b.xml"), false);
    EXPECT_EQ(io::readFile(dir / (type + "_a.xml")), [&] {
      // the files name their own heightfield: compare with the name swapped back
      std::string b = io::readFile(dir / (type + "_b.xml"));
      const auto at = b.find(type + "_b.hfield");
      if (at != std::string::npos) b.replace(at, type.size() + 9, type + "_a.hfield");
      return b;
    }()) << type;
    if (fs::exists(dir / (type + "_a.hfield"))) {
      EXPECT_EQ(io::readFile(dir / (type + "_a.hfield")), io::readFile(dir / (type + "_b.hfield"))) << type;
    }
    cfg.seed = 10;
    EXPECT_NE(generateScene(cfg).mjcf, generateScene(SceneConfig{type, 9}).mjcf) << type;
  }
}

// every type loads in MuJoCo, and the sidecar's heights agree with MuJoCo's geometry
TEST(SceneGeneratorTest, TruthAgreesWithTheLoadedScene) {
  test::TempDir dir;
  for (const auto& type : sceneTypes()) {
    SceneConfig cfg;
    cfg.type = type;
    cfg.seed = 1;
    const GeneratedScene scene = generateScene(cfg);
    writeScene(scene, dir / (type + ".xml"), false);
    const sim::World world(dir / (type + ".xml"));
    const SceneTruth& t = world.truth();
    EXPECT_EQ(t.objects.size(), scene.truth.objects.size());
    int buildings = 0, trees = 0;
    for (const auto& o : t.objects) {
      Eigen::Vector2d c = Eigen::Vector2d::Zero();
      for (const auto& p : o.footprint) c += p;
      c /= static_cast<double>(o.footprint.size());
      int geom = -1;
      const double top = world.surfaceHeight(c.x(), c.y(), &geom);
      // the highest surface above the footprint's centre is this object's top
      ASSERT_GE(geom, 0) << o.id;
      EXPECT_NEAR(top, o.top_height, 0.002) << type << " " << o.id;
      EXPECT_EQ(world.geomClass(geom), o.object_class) << o.id;
      // a building's base is the lowest terrain under its footprint; a tree's, the terrain at its trunk
      double base = world.terrainHeight(c.x(), c.y());
      if (o.object_class == GeomClass::Building) {
        for (const auto& p : o.footprint) base = std::min(base, world.terrainHeight(p.x(), p.y()));
      }
      EXPECT_NEAR(base, o.base_height, 0.35) << type << " " << o.id;
      buildings += o.object_class == GeomClass::Building;
      trees += o.object_class == GeomClass::Crown;
      EXPECT_GE(o.top_height - o.base_height, o.object_class == GeomClass::Building ? 6.0 : 4.0) << o.id;
      EXPECT_LE(o.top_height - o.base_height, 45.0) << o.id;
    }
    EXPECT_GT(buildings + trees, 20) << type;
    EXPECT_GT(trees, 0) << type;
  }
}

TEST(SceneGeneratorTest, SlopeTypeHasInclinesBetweenFiveAndTwentyDegrees) {
  SceneConfig cfg;
  cfg.type = "slope";
  test::TempDir dir;
  writeScene(generateScene(cfg), dir / "s.xml", false);
  const sim::World world(dir / "s.xml");
  double steepest = 0;
  for (double x = -70; x < 70; x += 1.0) {
    const double g = (world.terrainHeight(x + 1.0, 0) - world.terrainHeight(x - 1.0, 0)) / 2.0;
    steepest = std::max(steepest, std::atan(std::abs(g)) * 180 / M_PI);
  }
  EXPECT_GT(steepest, 5.0);
  EXPECT_LT(steepest, 24.0);
}

TEST(SceneGeneratorTest, RefusesUnknownTypesAndOverwrites) {
  try {
    generateScene(SceneConfig{"moon", 1});
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("allowed: flat, slope, rough, urban, forest, mixed"), std::string::npos);
  }
  SceneConfig bad;
  bad.extent = 5;
  EXPECT_THROW(generateScene(bad), io::InputError);
  test::TempDir dir;
  writeScene(generateScene(SceneConfig{}), dir / "u.xml", false);
  const std::string before = io::readFile(dir / "u.xml");
  EXPECT_THROW(writeScene(generateScene(SceneConfig{"flat", 1}), dir / "u.xml", false), io::InputError);
  EXPECT_EQ(io::readFile(dir / "u.xml"), before);
}

// A sidecar that is wrong in any of these ways is refused with the file and the field named.
TEST(SceneTruthTest, WrongSidecarsAreRefusedWithTheField) {
  test::TempDir dir;
  const std::string good = truthToJson(generateScene(SceneConfig{"urban", 1}).truth);
  io::writeFileAtomic(dir / "good.truth.json", good, false);
  ASSERT_NO_THROW(loadTruth(dir / "good.truth.json"));
  const auto refused = [&](const std::string& name, const std::function<void(nlohmann::json&)>& edit,
                           const std::string& message) {
    nlohmann::json j = nlohmann::json::parse(good);
    edit(j);
    const fs::path f = dir / (name + ".truth.json");
    io::writeFileAtomic(f, j.dump(1), true);
    try {
      loadTruth(f);
      ADD_FAILURE() << name << " was accepted";
    } catch (const io::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(f.string()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << name << ": " << e.what();
    }
  };
  refused(
      "unknown_top", [](auto& j) { j["colour"] = "red"; }, "field 'colour' is not a field here");
  refused(
      "unknown_object_field", [](auto& j) { j["objects"][0]["heigth"] = 3; },
      "field 'objects[0].heigth' is not a field here");
  refused(
      "two_point_footprint",
      [](auto& j) {
        j["objects"][0]["footprint"] = {{0, 0}, {1, 1}};
      },
      "objects[0].footprint' needs at least 3 points");
  refused(
      "duplicate_id", [](auto& j) { j["objects"][1]["id"] = j["objects"][0]["id"]; },
      "is the id of an earlier object too");
  refused(
      "geom_twice", [](auto& j) { j["objects"][1]["geoms"].push_back(j["objects"][0]["geoms"][0]); },
      "belongs to object");
  refused(
      "geom_not_a_name", [](auto& j) { j["objects"][0]["geoms"] = {7}; }, "must hold geom names");
  refused(
      "repeated_waypoint", [](auto& j) { j["path"]["waypoints"][1] = j["path"]["waypoints"][0]; },
      "are the same (a segment of length 0)");
  refused(
      "terrain_pos_text",
      [](auto& j) {
        j["terrain"]["pos"] = {0, "up", 0};
      },
      "terrain.pos' must hold finite numbers");
}

TEST(WorldTest, MalformedScenesGetMuJoCosMessageWithTheLine) {
  test::TempDir dir;
  writeScene(generateScene(SceneConfig{"flat", 1}), dir / "f.xml", false);
  std::string xml = io::readFile(dir / "f.xml");
  xml.replace(xml.find("type=\"box\""), 10, "type=\"bax\"");
  io::writeFileAtomic(dir / "f.xml", xml, true);
  try {
    sim::World w(dir / "f.xml");
    FAIL();
  } catch (const io::InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("f.xml"), std::string::npos) << m;
    EXPECT_NE(m.find("bax"), std::string::npos) << m;
    EXPECT_NE(m.find("line"), std::string::npos) << m;
  }
  EXPECT_THROW(sim::World(dir / "missing.xml"), io::InputError);
  // a sidecar that is not JSON, or lacks a field
  writeScene(generateScene(SceneConfig{"flat", 2}), dir / "g.xml", false);
  io::writeFileAtomic(dir / "g.truth.json", "{\"format\": \"terrain-scene-truth/1\"}", true);
  try {
    sim::World w(dir / "g.xml");
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'type' missing"), std::string::npos) << e.what();
  }
  io::writeFileAtomic(dir / "g.truth.json", "{ nope", true);
  EXPECT_THROW(sim::World(dir / "g.xml"), io::InputError);
}

}  // namespace
}  // namespace terrain::scenes

namespace terrain::scenes {
namespace {

// the committed scenes are exactly what the generator makes today
TEST(SceneGeneratorTest, CommittedLibraryScenesMatchTheGenerator) {
  const std::filesystem::path library = std::filesystem::path(TERRAIN_SOURCE_DIR) / "scenes" / "library";
  test::TempDir dir;
  for (const char* type : {"urban", "forest", "rough"}) {
    const std::string name = std::string(type) + "_1";
    writeScene(generateScene(SceneConfig{type, 1}), dir / (name + ".xml"), false);
    for (const char* ext : {".xml", ".truth.json", ".hfield"}) {
      EXPECT_TRUE(io::readFile(library / (name + ext)) == io::readFile(dir / (name + ext))) << name << ext;
    }
  }
}

}  // namespace
}  // namespace terrain::scenes
