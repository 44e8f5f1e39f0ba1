#include "sim/sim_config.hpp"

#include "rig/file_io.hpp"
#include "rig/settings_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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
  io::writeFileAtomic(
      dir / "sim.yaml",
      "seed: 7\nrobot:\n  speed: 1.5\nlidar:\n  height_cap: 3.0\ncamera:\n  rig: forward\n  width: 320\n", true);
  SimConfig c;
  loadSimConfig(dir / "sim.yaml", c);
  EXPECT_EQ(c.seed, 7u);
  EXPECT_EQ(c.robot.speed, 1.5);
  EXPECT_EQ(c.lidar.height_cap, 3.0);
  EXPECT_EQ(c.camera.rig, "forward");
  EXPECT_EQ(c.lidar.range_noise, 0.02);  // untouched fields keep their defaults
  // the rig-wide width applies to every camera of the named rig
  const std::vector<CameraMount> rig = rigCameras(c.camera);
  ASSERT_EQ(rig.size(), 1u);
  EXPECT_EQ(rig[0].width, 320);
  EXPECT_EQ(rig[0].height, 480);
}

TEST(SimConfigTest, AnExplicitCameraListReplacesTheNamedRig) {
  test::TempDir dir;
  io::writeFileAtomic(
      dir / "sim.yaml",
      "cameras:\n"
      "  - {name: up_front, position: [0.3, 0, 1.7], pitch_deg: 20}\n"
      "  - {name: back, position: [-0.3, 0, 1.7], yaw_deg: 180, roll_deg: 5, width: 320, height: 200, fovy_deg: 60}\n"
      "camera:\n  pitch_deg: 10\n",
      true);
  SimConfig c;
  loadSimConfig(dir / "sim.yaml", c);
  validate(c);
  const std::vector<CameraMount> rig = rigCameras(c.camera);
  ASSERT_EQ(rig.size(), 2u);
  EXPECT_EQ(rig[0].name, "up_front");
  EXPECT_EQ(rig[0].position, Eigen::Vector3d(0.3, 0, 1.7));
  EXPECT_EQ(rig[0].pitch_deg, 10);  // camera.pitch_deg sets every camera's
  EXPECT_EQ(rig[1].name, "back");
  EXPECT_EQ(rig[1].yaw_deg, 180);
  EXPECT_EQ(rig[1].roll_deg, 5);
  EXPECT_EQ(rig[1].width, 320);
  EXPECT_EQ(rig[1].height, 200);
  EXPECT_EQ(rig[1].fovy_deg, 60);
  // the JSON of the settings lists the cameras as they are put on the robot
  const auto j = nlohmann::json::parse(simConfigToJson(c));
  ASSERT_EQ(j["cameras"].size(), 2u);
  EXPECT_EQ(j["cameras"][1]["name"], "back");
  EXPECT_EQ(j["camera"]["rig"], "custom");
}

TEST(SimConfigTest, BadCameraRigsAreNamed) {
  test::TempDir dir;
  EXPECT_NE(errorOf(dir, "camera:\n  rig: panorama\n").find("unknown camera rig 'panorama' (known: surround, forward)"),
            std::string::npos);
  EXPECT_NE(errorOf(dir, "cameras: []\n").find("the camera list is empty"), std::string::npos);
  EXPECT_NE(
      errorOf(
          dir,
          "cameras:\n  - {name: a, position: [0.3, 0, 1.6]}\n  - {name: a, position: [-0.3, 0, 1.6], yaw_deg: 180}\n")
          .find("duplicate camera name 'a'"),
      std::string::npos);
  EXPECT_NE(errorOf(dir, "cameras:\n  - {position: [0.3, 0, 1.6]}\n").find("a camera needs a name"), std::string::npos);
  EXPECT_NE(errorOf(dir, "cameras:\n  - {name: a, zoom: 2}\n").find("unknown camera field 'zoom'"), std::string::npos);
  // inside the chassis, and behind the mast looking at it
  EXPECT_NE(errorOf(dir, "cameras:\n  - {name: low, position: [0, 0.2, 0.4]}\n")
                .find("'low'): the camera sits inside the robot's body"),
            std::string::npos);
  EXPECT_NE(errorOf(dir, "cameras:\n  - {name: back, position: [-0.3, 0, 1.2], pitch_deg: 0}\n")
                .find("'back'): the camera looks into the robot's body"),
            std::string::npos);
  EXPECT_NE(errorOf(dir, "cameras:\n  - {name: down, position: [0.3, 0, 1.6], pitch_deg: -60}\n")
                .find("pitch_deg = -60 is out of range"),
            std::string::npos);
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
  EXPECT_NE(errorOf(dir, "camera:\n  fovy_deg: 200\n")
                .find("sim.yaml:2: camera.fovy_deg = 200 is out of range (allowed: (0, 180) deg)"),
            std::string::npos);
  EXPECT_NE(errorOf(dir, "lidar:\n  max_range: -1\n").find("lidar.max_range"), std::string::npos);
  // a value out of range is refused where it is read, with its line: a camera's field too
  EXPECT_NE(errorOf(dir, "gps:\n  rate_hz: 10\n  antenna: [0, 0, .nan]\n")
                .find("sim.yaml:3: gps.antenna = nan is out of range (allowed: [-5, 5] m per axis)"),
            std::string::npos);
  EXPECT_NE(
      errorOf(dir, "cameras:\n  - name: side\n    roll_deg: 90\n")
          .find("sim.yaml:3: 'cameras' has a bad value (camera 0 (line 2): roll_deg = 90 is out of range (allowed: "
                "[-45, 45] deg))"),
      std::string::npos);
  EXPECT_EQ(errorOf(dir, "camera:\n  width: 0\n"), "");  // 0: each camera's own
  EXPECT_EQ(errorOf(dir, "# all defaults\n"), "");
  // a key given twice (YAML keeps both; which one counts would be a guess)
  EXPECT_NE(errorOf(dir, "robot:\n  speed: 1\n  speed: 2\n")
                .find("sim.yaml:3: 'robot.speed' is given twice (first on line 2)"),
            std::string::npos)
      << errorOf(dir, "robot:\n  speed: 1\n  speed: 2\n");
  EXPECT_NE(errorOf(dir, "seed: 1\nrobot:\n  speed: 1\nseed: 2\n").find("'seed' is given twice"), std::string::npos);
  // keys that are no setting's name: an empty complex key (found by scripts/fuzz's config target,
  // whose YAML exception escaped), a sequence as a key, and one inside a section
  EXPECT_NE(errorOf(dir, "? :\b :").find("sim.yaml:1: a key that is not a setting's name"), std::string::npos)
      << errorOf(dir, "? :\b :");
  EXPECT_NE(errorOf(dir, "? [a, b]\n: 1\n").find("sim.yaml:1: a key that is not"), std::string::npos);
  EXPECT_NE(errorOf(dir, "robot:\n  ? [x]\n  : 1\n").find("sim.yaml:2: a key that is not"), std::string::npos);
}

// Every setting set away from its default in one file: the JSON holds each of them, and the JSON
// read back as a settings file (YAML reads JSON) gives the same settings: the file's names, the
// JSON's and the list's agree for every setting.
TEST(SimConfigTest, EverySettingRoundTripsThroughTheJson) {
  test::TempDir dir;
  io::writeFileAtomic(dir / "sim.yaml",
                      "seed: 9\nthreads: 3\n"
                      "robot: {speed: 1.5, mast_height: 2.0, wheelbase: 1.2, track: 0.8}\n"
                      "lidar: {calibration: my_lasers.yaml, rotation_hz: 12, firing_rate_hz: 20000, max_range: 100,\n"
                      "  min_range: 1.0, range_noise: 0.03, laser_bias: 0.01, dropout: 0.1, height_cap: 2.0}\n"
                      "camera: {rig: forward, width: 320, height: 240, fovy_deg: 60, pitch_deg: 5}\n"
                      "gps: {rate_hz: 5, horizontal_sigma: 0.1, vertical_sigma: 0.2, antenna: [-0.2, 0.1, 2.0]}\n"
                      "gyro: {rate_hz: 100, noise_sigma: 0.001, bias_sigma: 0.0005}\n",
                      true);
  SimConfig a;
  loadSimConfig(dir / "sim.yaml", a);
  validate(a);
  nlohmann::json ja = nlohmann::json::parse(simConfigToJson(a));
  const nlohmann::json defaults = nlohmann::json::parse(simConfigToJson(SimConfig{}));
  // every setting is in the JSON, away from its default (but camera.enabled, on in both)
  std::size_t settings = 0;
  for (const auto& [key, value] : ja.items()) {
    if (key == "cameras") continue;
    if (!value.is_object()) {
      ++settings;
      EXPECT_NE(value, defaults[key]) << key;
      continue;
    }
    for (const auto& [field, v] : value.items()) {
      ++settings;
      if (key + "." + field != "camera.enabled") {
        EXPECT_NE(v, defaults[key][field]) << key << "." << field;
      }
    }
  }
  EXPECT_EQ(settings, 28u);
  EXPECT_EQ(ja["gps"]["antenna"], nlohmann::json::array({-0.2, 0.1, 2.0}));
  // read back (without the cameras as put on the robot, which the rig and its settings give)
  ja.erase("cameras");
  io::writeFileAtomic(dir / "again.yaml", ja.dump(), true);
  SimConfig b;
  loadSimConfig(dir / "again.yaml", b);
  validate(b);
  EXPECT_EQ(simConfigToJson(b), simConfigToJson(a));
}

// A GPS antenna off the robot or not a number: refused by name, as a camera's position is.
TEST(SimConfigTest, AGpsAntennaOffTheRobotIsRefused) {
  test::TempDir dir;
  EXPECT_NE(errorOf(dir, "gps:\n  antenna: [.nan, 0, 1.9]\n")
                .find("gps.antenna = nan is out of range (allowed: [-5, 5] m per axis)"),
            std::string::npos)
      << errorOf(dir, "gps:\n  antenna: [.nan, 0, 1.9]\n");
  EXPECT_NE(errorOf(dir, "gps:\n  antenna: [0, 0, 400]\n").find("gps.antenna = 400 is out of range"),
            std::string::npos);
  EXPECT_EQ(errorOf(dir, "gps:\n  antenna: [-0.3, 0, 1.9]\n"), "");
}

}  // namespace
}  // namespace terrain::sim
