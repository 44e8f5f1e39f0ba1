#include "sim/sim_config.hpp"

#include "rig/file_io.hpp"
#include "rig/settings_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

namespace terrain::sim {
namespace {

std::string errorOf(const test::TempDir& dir, const std::string& yaml) {
  io::writeFileAtomic(dir / "sim.yaml", yaml, true);
  SimConfig c;
  try {
    loadSimConfig(dir / "sim.yaml", c);
    validate(c);
  } catch (const io::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(SimConfigTest, YamlFillsTheNamedFields) {
  test::TempDir dir;
  io::writeFileAtomic(dir / "sim.yaml", "seed: 7\nrobot:\n  speed: 1.5\nlidar:\n  height_cap: 3.0\ncamera:\n  position: [0.1, 0, 1.5]\n", true);
  SimConfig c;
  loadSimConfig(dir / "sim.yaml", c);
  EXPECT_EQ(c.seed, 7u);
  EXPECT_EQ(c.robot.speed, 1.5);
  EXPECT_EQ(c.lidar.height_cap, 3.0);
  EXPECT_EQ(c.camera.position, Eigen::Vector3d(0.1, 0, 1.5));
  EXPECT_EQ(c.lidar.range_noise, 0.02);  // untouched fields keep their defaults
}

TEST(SimConfigTest, OneCommandLineSettingIsReadAsYaml) {
  double speed = 2.0;
  int seed = 1;
  const std::map<std::string, io::Setter> setters = {{"robot.speed", io::numberSetter(speed)},
                                                     {"seed", io::integerSetter(seed)}};
  io::applySetting("robot.speed=0.75", setters, "--set");
  io::applySetting("seed=9", setters, "--set");
  EXPECT_EQ(speed, 0.75);
  EXPECT_EQ(seed, 9);
  auto error = [&](const std::string& kv) {
    try {
      io::applySetting(kv, setters, "--set");
    } catch (const io::InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error("robot.sped=1"), "--set robot.sped=1: unknown setting 'robot.sped'");
  EXPECT_NE(error("robot.speed=fast").find("--set robot.speed=fast: 'robot.speed' has a bad value"), std::string::npos);
  EXPECT_NE(error("robot.speed").find("expected KEY=VALUE"), std::string::npos);
  EXPECT_NE(error("=1").find("expected KEY=VALUE"), std::string::npos);
  EXPECT_EQ(speed, 0.75);  // a refused setting changes nothing
}

TEST(SimConfigTest, BadFilesAreNamedWithTheLineAndField) {
  test::TempDir dir;
  EXPECT_NE(errorOf(dir, "robot:\n  sped: 1\n").find("sim.yaml:2: unknown setting 'robot.sped'"), std::string::npos);
  EXPECT_NE(errorOf(dir, "lidar:\n  max_range: far\n").find("'lidar.max_range' has a bad value"), std::string::npos);
  EXPECT_NE(errorOf(dir, "lidar: [1, 2\n").find("not valid YAML"), std::string::npos);
  EXPECT_NE(errorOf(dir, "camera:\n  fovy_deg: 200\n").find("camera.fovy_deg = 200 is out of range (allowed: (0, 180) deg)"),
            std::string::npos);
  EXPECT_NE(errorOf(dir, "lidar:\n  max_range: -1\n").find("lidar.max_range"), std::string::npos);
  EXPECT_EQ(errorOf(dir, "# all defaults\n"), "");
}

}  // namespace
}  // namespace terrain::sim
