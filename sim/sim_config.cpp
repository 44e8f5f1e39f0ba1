#include "sim/sim_config.hpp"

#include "rig/file_io.hpp"
#include "rig/settings_io.hpp"

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <map>
#include <sstream>

#ifndef TERRAIN_DATA_DIR
#error "TERRAIN_DATA_DIR must be defined by the build"
#endif

namespace terrain::sim {

namespace {

constexpr auto require = io::requireInRange;

}  // namespace

void validate(const SimConfig& c) {
  require(c.robot.speed > 0 && c.robot.speed <= 30, "robot.speed", c.robot.speed, "(0, 30] m/s");
  require(c.robot.mast_height >= 0.5 && c.robot.mast_height <= 5, "robot.mast_height", c.robot.mast_height, "[0.5, 5] m");
  require(c.robot.wheelbase > 0 && c.robot.wheelbase <= 5, "robot.wheelbase", c.robot.wheelbase, "(0, 5] m");
  require(c.robot.track > 0 && c.robot.track <= 5, "robot.track", c.robot.track, "(0, 5] m");
  require(c.lidar.rotation_hz >= 5 && c.lidar.rotation_hz <= 15, "lidar.rotation_hz", c.lidar.rotation_hz, "[5, 15] Hz");
  require(c.lidar.firing_rate_hz >= 1000 && c.lidar.firing_rate_hz <= 100000, "lidar.firing_rate_hz",
          c.lidar.firing_rate_hz, "[1000, 100000] Hz");
  require(c.lidar.max_range > 0 && c.lidar.max_range <= 200, "lidar.max_range", c.lidar.max_range, "(0, 200] m");
  require(c.lidar.min_range >= 0 && c.lidar.min_range < c.lidar.max_range, "lidar.min_range", c.lidar.min_range,
          "[0, max_range) m");
  require(c.lidar.range_noise >= 0 && c.lidar.range_noise <= 1, "lidar.range_noise", c.lidar.range_noise, "[0, 1] m");
  require(c.lidar.laser_bias >= 0 && c.lidar.laser_bias <= 1, "lidar.laser_bias", c.lidar.laser_bias, "[0, 1] m");
  require(c.lidar.dropout >= 0 && c.lidar.dropout < 1, "lidar.dropout", c.lidar.dropout, "[0, 1)");
  require(c.lidar.height_cap > -5 && c.lidar.height_cap <= 200, "lidar.height_cap", c.lidar.height_cap, "(-5, 200] m");
  require(c.camera.width >= 16 && c.camera.width <= 4096, "camera.width", c.camera.width, "[16, 4096] px");
  require(c.camera.height >= 16 && c.camera.height <= 4096, "camera.height", c.camera.height, "[16, 4096] px");
  require(c.camera.fovy_deg > 0 && c.camera.fovy_deg < 180, "camera.fovy_deg", c.camera.fovy_deg, "(0, 180) deg");
  require(c.camera.pitch_deg >= -45 && c.camera.pitch_deg <= 45, "camera.pitch_deg", c.camera.pitch_deg, "[-45, 45] deg");
  require(c.gps.rate_hz > 0 && c.gps.rate_hz <= 100, "gps.rate_hz", c.gps.rate_hz, "(0, 100] Hz");
  require(c.gps.horizontal_sigma >= 0 && c.gps.horizontal_sigma <= 100, "gps.horizontal_sigma", c.gps.horizontal_sigma, "[0, 100] m");
  require(c.gps.vertical_sigma >= 0 && c.gps.vertical_sigma <= 100, "gps.vertical_sigma", c.gps.vertical_sigma, "[0, 100] m");
  require(c.gyro.rate_hz >= 100 && c.gyro.rate_hz <= 2000, "gyro.rate_hz", c.gyro.rate_hz, "[100, 2000] Hz");
  require(c.gyro.noise_sigma >= 0 && c.gyro.noise_sigma <= 1, "gyro.noise_sigma", c.gyro.noise_sigma, "[0, 1] rad/s");
  require(c.gyro.bias_sigma >= 0 && c.gyro.bias_sigma <= 1, "gyro.bias_sigma", c.gyro.bias_sigma, "[0, 1] rad/s");
  require(c.threads >= 0 && c.threads <= 256, "threads", c.threads, "[0, 256]");
}

void loadSimConfig(const std::filesystem::path& path, SimConfig& c) {
  using io::Setter;
  const auto num = io::numberSetter;
  const auto integer = io::integerSetter;
  auto vec3 = [](Eigen::Vector3d& f) {
    return Setter([&f](const YAML::Node& n) {
      if (!n.IsSequence() || n.size() != 3) throw YAML::Exception(n.Mark(), "expected [x, y, z]");
      f = {n[0].as<double>(), n[1].as<double>(), n[2].as<double>()};
    });
  };
  const std::map<std::string, Setter> fields{
      {"seed", [&c](const YAML::Node& n) { c.seed = n.as<std::uint64_t>(); }},
      {"threads", integer(c.threads)},
      {"robot.speed", num(c.robot.speed)},
      {"robot.mast_height", num(c.robot.mast_height)},
      {"robot.wheelbase", num(c.robot.wheelbase)},
      {"robot.track", num(c.robot.track)},
      {"lidar.calibration", [&c](const YAML::Node& n) { c.lidar.calibration = n.as<std::string>(); }},
      {"lidar.rotation_hz", num(c.lidar.rotation_hz)},
      {"lidar.firing_rate_hz", num(c.lidar.firing_rate_hz)},
      {"lidar.max_range", num(c.lidar.max_range)},
      {"lidar.min_range", num(c.lidar.min_range)},
      {"lidar.range_noise", num(c.lidar.range_noise)},
      {"lidar.laser_bias", num(c.lidar.laser_bias)},
      {"lidar.dropout", num(c.lidar.dropout)},
      {"lidar.height_cap", num(c.lidar.height_cap)},
      {"camera.enabled", [&c](const YAML::Node& n) { c.camera.enabled = n.as<bool>(); }},
      {"camera.width", integer(c.camera.width)},
      {"camera.height", integer(c.camera.height)},
      {"camera.fovy_deg", num(c.camera.fovy_deg)},
      {"camera.pitch_deg", num(c.camera.pitch_deg)},
      {"camera.position", vec3(c.camera.position)},
      {"gps.rate_hz", num(c.gps.rate_hz)},
      {"gps.horizontal_sigma", num(c.gps.horizontal_sigma)},
      {"gps.vertical_sigma", num(c.gps.vertical_sigma)},
      {"gps.antenna", vec3(c.gps.antenna)},
      {"gyro.rate_hz", num(c.gyro.rate_hz)},
      {"gyro.noise_sigma", num(c.gyro.noise_sigma)},
      {"gyro.bias_sigma", num(c.gyro.bias_sigma)},
  };
  io::applySettings(path, fields, "robot, lidar, camera, gps, gyro");
}

std::string simConfigToJson(const SimConfig& c) {
  using nlohmann::json;
  auto v3 = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
  json j;
  j["seed"] = c.seed;
  j["robot"] = {{"speed", c.robot.speed}, {"mast_height", c.robot.mast_height}, {"wheelbase", c.robot.wheelbase},
                {"track", c.robot.track}};
  j["lidar"] = {{"calibration", c.lidar.calibration}, {"rotation_hz", c.lidar.rotation_hz},
                {"firing_rate_hz", c.lidar.firing_rate_hz}, {"max_range", c.lidar.max_range},
                {"min_range", c.lidar.min_range}, {"range_noise", c.lidar.range_noise},
                {"laser_bias", c.lidar.laser_bias}, {"dropout", c.lidar.dropout}, {"height_cap", c.lidar.height_cap}};
  j["camera"] = {{"enabled", c.camera.enabled}, {"width", c.camera.width}, {"height", c.camera.height},
                 {"fovy_deg", c.camera.fovy_deg}, {"pitch_deg", c.camera.pitch_deg}, {"position", v3(c.camera.position)}};
  j["gps"] = {{"rate_hz", c.gps.rate_hz}, {"horizontal_sigma", c.gps.horizontal_sigma},
              {"vertical_sigma", c.gps.vertical_sigma}, {"antenna", v3(c.gps.antenna)}};
  j["gyro"] = {{"rate_hz", c.gyro.rate_hz}, {"noise_sigma", c.gyro.noise_sigma}, {"bias_sigma", c.gyro.bias_sigma}};
  return j.dump();
}

std::filesystem::path dataPath(const std::string& relative) { return std::filesystem::path(TERRAIN_DATA_DIR) / relative; }

}  // namespace terrain::sim
