#include "sim/sim_config.hpp"

#include "rig/file_io.hpp"
#include "rig/settings_io.hpp"

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <map>
#include <sstream>

#ifndef TERRAIN_DATA_DIR
#error "TERRAIN_DATA_DIR must be defined by the build"
#endif

namespace terrain::sim {

namespace {

constexpr auto require = io::requireInRange;

// the robot's body in the vehicle frame (scenes/scene_generator.cpp: a chassis box 1 x 0.7 m,
// 0.15-0.55 m up, and a mast of radius 0.04 m up to 1.8 m), which no camera may sit in or face
struct Body {
  Eigen::Vector3d lo, hi;
};
constexpr double kMastRadius = 0.04, kMastTop = 1.8;
const Body kChassis{{-0.5, -0.35, 0.15}, {0.5, 0.35, 0.55}};

bool insideBox(const Eigen::Vector3d& p, const Body& b, double pad) {
  return (p.array() >= b.lo.array() - pad).all() && (p.array() <= b.hi.array() + pad).all();
}

// the optical axis of a camera in the vehicle frame
Eigen::Vector3d opticalAxis(const CameraMount& m) {
  constexpr double r = 3.14159265358979323846 / 180.0;
  const double yaw = m.yaw_deg * r, pitch = m.pitch_deg * r;
  return {std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch)};
}

// whether a camera's optical axis meets the robot's body within 2 m: a camera that looks into the robot
bool facesBody(const CameraMount& m) {
  const Eigen::Vector3d axis = opticalAxis(m);
  for (double t = 0.02; t <= 2.0; t += 0.02) {
    const Eigen::Vector3d p = m.position + t * axis;
    if (insideBox(p, kChassis, 0)) return true;
    if (p.head<2>().norm() <= kMastRadius && p.z() >= 0 && p.z() <= kMastTop) return true;
  }
  return false;
}

void validateCamera(const CameraMount& m, const std::string& field) {
  require(m.width >= 16 && m.width <= 4096, field + ".width", m.width, "[16, 4096] px");
  require(m.height >= 16 && m.height <= 4096, field + ".height", m.height, "[16, 4096] px");
  require(m.fovy_deg > 0 && m.fovy_deg < 180, field + ".fovy_deg", m.fovy_deg, "(0, 180) deg");
  require(m.yaw_deg >= -180 && m.yaw_deg <= 180, field + ".yaw_deg", m.yaw_deg, "[-180, 180] deg");
  require(m.pitch_deg >= -45 && m.pitch_deg <= 45, field + ".pitch_deg", m.pitch_deg, "[-45, 45] deg");
  require(m.roll_deg >= -45 && m.roll_deg <= 45, field + ".roll_deg", m.roll_deg, "[-45, 45] deg");
  for (int i = 0; i < 3; ++i) {
    require(std::isfinite(m.position[i]) && std::abs(m.position[i]) <= 5, field + ".position", m.position[i],
            "[-5, 5] m per axis");
  }
  if (insideBox(m.position, kChassis, 0.01) ||
      (m.position.head<2>().norm() <= kMastRadius + 0.01 && m.position.z() <= kMastTop))
    throw io::InputError(field + ": the camera sits inside the robot's body (chassis or mast)");
  if (facesBody(m)) throw io::InputError(field + ": the camera looks into the robot's body (chassis or mast)");
}

}  // namespace

std::vector<CameraMount> cameraRig(const std::string& name) {
  CameraMount front;  // the defaults: today's forward camera
  if (name == "forward") return {front};
  if (name == "surround") {
    // four cameras around the mast, 0.25 m out, each 91 degrees across: every azimuth in view
    std::vector<CameraMount> rig;
    const std::pair<const char*, double> around[] = {{"front", 0}, {"left", 90}, {"rear", 180}, {"right", -90}};
    for (const auto& [n, yaw] : around) {
      CameraMount m = front;
      m.name = n;
      m.yaw_deg = yaw;
      const double r = yaw * 3.14159265358979323846 / 180.0;
      m.position = {0.25 * std::cos(r), 0.25 * std::sin(r), front.position.z()};
      // the rounding of cos and sin: exactly 0 where it should be
      for (int i = 0; i < 2; ++i) {
        if (std::abs(m.position[i]) < 1e-12) m.position[i] = 0;
      }
      rig.push_back(m);
    }
    return rig;
  }
  throw io::InputError("unknown camera rig '" + name + "' (known: " + kCameraRigs + ")");
}

std::vector<CameraMount> rigCameras(const CameraConfig& c) {
  if (!c.enabled) return {};
  std::vector<CameraMount> rig = c.cameras.empty() ? cameraRig(c.rig) : c.cameras;
  for (auto& m : rig) {
    if (c.width > 0) m.width = c.width;
    if (c.height > 0) m.height = c.height;
    if (!std::isnan(c.fovy_deg)) m.fovy_deg = c.fovy_deg;
    if (!std::isnan(c.pitch_deg)) m.pitch_deg = c.pitch_deg;
  }
  return rig;
}

void validate(const SimConfig& c) {
  require(c.robot.speed > 0 && c.robot.speed <= 30, "robot.speed", c.robot.speed, "(0, 30] m/s");
  require(c.robot.mast_height >= 0.5 && c.robot.mast_height <= 5, "robot.mast_height", c.robot.mast_height,
          "[0.5, 5] m");
  require(c.robot.wheelbase > 0 && c.robot.wheelbase <= 5, "robot.wheelbase", c.robot.wheelbase, "(0, 5] m");
  require(c.robot.track > 0 && c.robot.track <= 5, "robot.track", c.robot.track, "(0, 5] m");
  require(c.lidar.rotation_hz >= 5 && c.lidar.rotation_hz <= 15, "lidar.rotation_hz", c.lidar.rotation_hz,
          "[5, 15] Hz");
  require(c.lidar.firing_rate_hz >= 1000 && c.lidar.firing_rate_hz <= 100000, "lidar.firing_rate_hz",
          c.lidar.firing_rate_hz, "[1000, 100000] Hz");
  require(c.lidar.max_range > 0 && c.lidar.max_range <= 200, "lidar.max_range", c.lidar.max_range, "(0, 200] m");
  require(c.lidar.min_range >= 0 && c.lidar.min_range < c.lidar.max_range, "lidar.min_range", c.lidar.min_range,
          "[0, max_range) m");
  require(c.lidar.range_noise >= 0 && c.lidar.range_noise <= 1, "lidar.range_noise", c.lidar.range_noise, "[0, 1] m");
  require(c.lidar.laser_bias >= 0 && c.lidar.laser_bias <= 1, "lidar.laser_bias", c.lidar.laser_bias, "[0, 1] m");
  require(c.lidar.dropout >= 0 && c.lidar.dropout < 1, "lidar.dropout", c.lidar.dropout, "[0, 1)");
  require(c.lidar.height_cap > -5 && c.lidar.height_cap <= 200, "lidar.height_cap", c.lidar.height_cap, "(-5, 200] m");
  require(c.camera.width == 0 || (c.camera.width >= 16 && c.camera.width <= 4096), "camera.width", c.camera.width,
          "[16, 4096] px");
  require(c.camera.height == 0 || (c.camera.height >= 16 && c.camera.height <= 4096), "camera.height", c.camera.height,
          "[16, 4096] px");
  require(std::isnan(c.camera.fovy_deg) || (c.camera.fovy_deg > 0 && c.camera.fovy_deg < 180), "camera.fovy_deg",
          c.camera.fovy_deg, "(0, 180) deg");
  require(std::isnan(c.camera.pitch_deg) || (c.camera.pitch_deg >= -45 && c.camera.pitch_deg <= 45), "camera.pitch_deg",
          c.camera.pitch_deg, "[-45, 45] deg");
  if (c.camera.enabled) {
    if (c.camera.cameras.empty()) cameraRig(c.camera.rig);  // throws for an unknown name
    const std::vector<CameraMount> rig = rigCameras(c.camera);
    for (std::size_t i = 0; i < rig.size(); ++i) {
      const std::string field = "cameras[" + std::to_string(i) + "] ('" + rig[i].name + "')";
      if (rig[i].name.empty()) throw io::InputError("cameras[" + std::to_string(i) + "]: a camera needs a name");
      for (std::size_t j = 0; j < i; ++j) {
        if (rig[j].name == rig[i].name)
          throw io::InputError("cameras[" + std::to_string(i) + "]: duplicate camera name '" + rig[i].name +
                               "' (also cameras[" + std::to_string(j) + "])");
      }
      validateCamera(rig[i], field);
    }
  }
  require(c.gps.rate_hz > 0 && c.gps.rate_hz <= 100, "gps.rate_hz", c.gps.rate_hz, "(0, 100] Hz");
  require(c.gps.horizontal_sigma >= 0 && c.gps.horizontal_sigma <= 100, "gps.horizontal_sigma", c.gps.horizontal_sigma,
          "[0, 100] m");
  require(c.gps.vertical_sigma >= 0 && c.gps.vertical_sigma <= 100, "gps.vertical_sigma", c.gps.vertical_sigma,
          "[0, 100] m");
  require(c.gyro.rate_hz >= 100 && c.gyro.rate_hz <= 2000, "gyro.rate_hz", c.gyro.rate_hz, "[100, 2000] Hz");
  require(c.gyro.noise_sigma >= 0 && c.gyro.noise_sigma <= 1, "gyro.noise_sigma", c.gyro.noise_sigma, "[0, 1] rad/s");
  require(c.gyro.bias_sigma >= 0 && c.gyro.bias_sigma <= 1, "gyro.bias_sigma", c.gyro.bias_sigma, "[0, 1] rad/s");
  require(c.threads >= 0 && c.threads <= 256, "threads", c.threads, "[0, 256]");
}

namespace {

// The list under `cameras`: a sequence of maps with the CameraMount fields (name required).
template <typename Vec3Setter>
std::vector<CameraMount> camerasFromYaml(const YAML::Node& list, const Vec3Setter& vec3) {
  if (!list.IsSequence()) throw YAML::Exception(list.Mark(), "expected a list of cameras");
  std::vector<CameraMount> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node& item = list[i];
    const std::string where = "camera " + std::to_string(i) + " (line " + std::to_string(item.Mark().line + 1) + ")";
    if (!item.IsMap()) throw YAML::Exception(item.Mark(), where + ": expected a map of camera fields");
    CameraMount m;
    m.name.clear();
    const std::map<std::string, io::Setter> fields{
        {"name", [&m](const YAML::Node& n) { m.name = n.as<std::string>(); }},
        {"position", vec3(m.position)},
        {"yaw_deg", io::numberSetter(m.yaw_deg)},
        {"pitch_deg", io::numberSetter(m.pitch_deg)},
        {"roll_deg", io::numberSetter(m.roll_deg)},
        {"width", io::integerSetter(m.width)},
        {"height", io::integerSetter(m.height)},
        {"fovy_deg", io::numberSetter(m.fovy_deg)},
    };
    for (const auto& kv : item) {
      const std::string key = kv.first.as<std::string>();
      const auto it = fields.find(key);
      if (it == fields.end())
        throw YAML::Exception(kv.first.Mark(), where + ": unknown camera field '" + key +
                                                   "' (known: name, position, yaw_deg, pitch_deg, roll_deg, width, "
                                                   "height, fovy_deg)");
      it->second(kv.second);
    }
    if (m.name.empty()) throw YAML::Exception(item.Mark(), where + ": a camera needs a name");
    out.push_back(m);
  }
  if (out.empty()) throw YAML::Exception(list.Mark(), "the camera list is empty (set camera.enabled: false instead)");
  return out;
}

}  // namespace

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
      {"camera.rig", [&c](const YAML::Node& n) { c.camera.rig = n.as<std::string>(); }},
      {"camera.width", integer(c.camera.width)},
      {"camera.height", integer(c.camera.height)},
      {"camera.fovy_deg", num(c.camera.fovy_deg)},
      {"camera.pitch_deg", num(c.camera.pitch_deg)},
      {"cameras", [&c, vec3](const YAML::Node& n) { c.camera.cameras = camerasFromYaml(n, vec3); }},
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
  j["robot"] = {{"speed", c.robot.speed},
                {"mast_height", c.robot.mast_height},
                {"wheelbase", c.robot.wheelbase},
                {"track", c.robot.track}};
  j["lidar"] = {{"calibration", c.lidar.calibration},       {"rotation_hz", c.lidar.rotation_hz},
                {"firing_rate_hz", c.lidar.firing_rate_hz}, {"max_range", c.lidar.max_range},
                {"min_range", c.lidar.min_range},           {"range_noise", c.lidar.range_noise},
                {"laser_bias", c.lidar.laser_bias},         {"dropout", c.lidar.dropout},
                {"height_cap", c.lidar.height_cap}};
  json cameras = json::array();
  for (const auto& m : rigCameras(c.camera)) {
    cameras.push_back({{"name", m.name},
                       {"position", v3(m.position)},
                       {"yaw_deg", m.yaw_deg},
                       {"pitch_deg", m.pitch_deg},
                       {"roll_deg", m.roll_deg},
                       {"width", m.width},
                       {"height", m.height},
                       {"fovy_deg", m.fovy_deg}});
  }
  j["camera"] = {{"enabled", c.camera.enabled}, {"rig", c.camera.cameras.empty() ? c.camera.rig : "custom"}};
  j["cameras"] = cameras;
  j["gps"] = {{"rate_hz", c.gps.rate_hz},
              {"horizontal_sigma", c.gps.horizontal_sigma},
              {"vertical_sigma", c.gps.vertical_sigma},
              {"antenna", v3(c.gps.antenna)}};
  j["gyro"] = {{"rate_hz", c.gyro.rate_hz}, {"noise_sigma", c.gyro.noise_sigma}, {"bias_sigma", c.gyro.bias_sigma}};
  return j.dump();
}

std::filesystem::path dataPath(const std::string& relative) {
  return std::filesystem::path(TERRAIN_DATA_DIR) / relative;
}

}  // namespace terrain::sim
