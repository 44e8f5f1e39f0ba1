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

// The values each field of a camera may take, where a camera list is read and in validate().
const io::Range kCameraSize = io::closed(16, 4096, "px");
const io::Range kCameraFovy = io::openOpen(0, 180, "deg");
const io::Range kCameraYaw = io::closed(-180, 180, "deg");
const io::Range kCameraTilt = io::closed(-45, 45, "deg");  // pitch and roll
const io::Range kCameraOffset = io::closed(-5, 5, "m per axis");

void validateCamera(const CameraMount& m, const std::string& field) {
  const auto check = [&](const io::Range& r, const char* name, double v) {
    require(r.contains(v), field + "." + name, v, r.text());
  };
  check(kCameraSize, "width", m.width);
  check(kCameraSize, "height", m.height);
  check(kCameraFovy, "fovy_deg", m.fovy_deg);
  check(kCameraYaw, "yaw_deg", m.yaw_deg);
  check(kCameraTilt, "pitch_deg", m.pitch_deg);
  check(kCameraTilt, "roll_deg", m.roll_deg);
  for (int i = 0; i < 3; ++i) check(kCameraOffset, "position", m.position[i]);
  if (insideBox(m.position, kChassis, 0.01) ||
      (m.position.head<2>().norm() <= kMastRadius + 0.01 && m.position.z() <= kMastTop))
    throw io::InputError(field + ": the camera sits inside the robot's body (chassis or mast)");
  if (facesBody(m)) throw io::InputError(field + ": the camera looks into the robot's body (chassis or mast)");
}

}  // namespace

namespace {

using io::Range;

// Every setting of the simulation but the camera list, once: its name (section.field, as in the
// YAML file and the JSON), its member and the values it may take. Reading YAML, validate() and the
// JSON are all derived from this list. Relations between settings and the cameras themselves are
// checked in validate().
//  - number / integer: a value in its range;
//  - unset_number / unset_integer: NaN or 0 for "each camera's own", else in its range;
//  - vector: [x, y, z], each in its range;
//  - text, flag, seed: any.
template <class Visit>
void forEachSimSetting(SimConfig& c, Visit&& v) {
  v.seed("seed", c.seed);
  v.integer("threads", c.threads, io::closed(0, 256));
  v.number("robot.speed", c.robot.speed, io::openClosed(0, 30, "m/s"));
  v.number("robot.mast_height", c.robot.mast_height, io::closed(0.5, 5, "m"));
  v.number("robot.wheelbase", c.robot.wheelbase, io::openClosed(0, 5, "m"));
  v.number("robot.track", c.robot.track, io::openClosed(0, 5, "m"));
  v.text("lidar.calibration", c.lidar.calibration);
  v.number("lidar.rotation_hz", c.lidar.rotation_hz, io::closed(5, 15, "Hz"));
  v.number("lidar.firing_rate_hz", c.lidar.firing_rate_hz, io::closed(1000, 100000, "Hz"));
  v.number("lidar.max_range", c.lidar.max_range, io::openClosed(0, 200, "m"));
  v.number("lidar.min_range", c.lidar.min_range, io::closedOpen(0, 200, "m"));
  v.number("lidar.range_noise", c.lidar.range_noise, io::closed(0, 1, "m"));
  v.number("lidar.laser_bias", c.lidar.laser_bias, io::closed(0, 1, "m"));
  v.number("lidar.dropout", c.lidar.dropout, io::closedOpen(0, 1));
  v.number("lidar.height_cap", c.lidar.height_cap, io::openClosed(-5, 200, "m"));
  v.flag("camera.enabled", c.camera.enabled);
  v.text("camera.rig", c.camera.rig);
  v.unset_integer("camera.width", c.camera.width, io::closed(16, 4096, "px"));
  v.unset_integer("camera.height", c.camera.height, io::closed(16, 4096, "px"));
  v.unset_number("camera.fovy_deg", c.camera.fovy_deg, io::openOpen(0, 180, "deg"));
  v.unset_number("camera.pitch_deg", c.camera.pitch_deg, io::closed(-45, 45, "deg"));
  v.number("gps.rate_hz", c.gps.rate_hz, io::openClosed(0, 100, "Hz"));
  v.number("gps.horizontal_sigma", c.gps.horizontal_sigma, io::closed(0, 100, "m"));
  v.number("gps.vertical_sigma", c.gps.vertical_sigma, io::closed(0, 100, "m"));
  v.vector("gps.antenna", c.gps.antenna, io::closed(-5, 5, "m per axis"));
  v.number("gyro.rate_hz", c.gyro.rate_hz, io::closed(100, 2000, "Hz"));
  v.number("gyro.noise_sigma", c.gyro.noise_sigma, io::closed(0, 1, "rad/s"));
  v.number("gyro.bias_sigma", c.gyro.bias_sigma, io::closed(0, 1, "rad/s"));
}

// a YAML [x, y, z] into a vector, each coordinate in range
io::Setter vectorSetter(Eigen::Vector3d& f, const Range& range = {}) {
  return [&f, range](const YAML::Node& n) {
    if (!n.IsSequence() || n.size() != 3) throw YAML::Exception(n.Mark(), "expected [x, y, z]");
    const Eigen::Vector3d v(n[0].as<double>(), n[1].as<double>(), n[2].as<double>());
    for (int i = 0; i < 3; ++i) {
      if (!range.contains(v[i])) throw io::OutOfRange(v[i], range.text());
    }
    f = v;
  };
}

// The YAML setter of each setting.
struct SimSetters {
  std::map<std::string, io::Setter> setters;
  void number(const char* name, double& f, const Range& r) { setters[name] = io::numberSetter(f, r); }
  void unset_number(const char* name, double& f, const Range& r) { setters[name] = io::numberSetter(f, r); }
  void integer(const char* name, int& f, const Range& r) { setters[name] = io::integerSetter(f, r); }
  void unset_integer(const char* name, int& f, Range r) {
    r.off = true;  // 0: unset, as in validate()
    setters[name] = io::integerSetter(f, r);
  }
  void vector(const char* name, Eigen::Vector3d& f, const Range& r) { setters[name] = vectorSetter(f, r); }
  void text(const char* name, std::string& f) {
    setters[name] = [&f](const YAML::Node& n) { f = n.as<std::string>(); };
  }
  void flag(const char* name, bool& f) {
    setters[name] = [&f](const YAML::Node& n) { f = n.as<bool>(); };
  }
  void seed(const char* name, std::uint64_t& f) {
    setters[name] = [&f](const YAML::Node& n) { f = n.as<std::uint64_t>(); };
  }
};

// Throws io::InputError for the first setting outside its range.
struct SimRangeCheck {
  void number(const char* name, double& f, const Range& r) { io::requireInRange(r.contains(f), name, f, r.text()); }
  void unset_number(const char* name, double& f, const Range& r) {
    io::requireInRange(std::isnan(f) || r.contains(f), name, f, r.text());
  }
  void integer(const char* name, int& f, const Range& r) { io::requireInRange(r.contains(f), name, f, r.text()); }
  void unset_integer(const char* name, int& f, const Range& r) {
    io::requireInRange(f == 0 || r.contains(f), name, f, r.text());
  }
  void vector(const char* name, Eigen::Vector3d& f, const Range& r) {
    for (int i = 0; i < 3; ++i) io::requireInRange(r.contains(f[i]), name, f[i], r.text());
  }
  void text(const char*, std::string&) {}
  void flag(const char*, bool&) {}
  void seed(const char*, std::uint64_t&) {}
};

// Each setting under its section in a JSON object; unset ones as null.
struct SimJson {
  nlohmann::json j = nlohmann::json::object();
  nlohmann::json& at(const std::string& name) { return io::settingEntry(j, name); }
  void number(const char* name, double& f, const Range&) { at(name) = f; }
  void unset_number(const char* name, double& f, const Range&) {
    at(name) = std::isnan(f) ? nlohmann::json() : nlohmann::json(f);
  }
  void integer(const char* name, int& f, const Range&) { at(name) = f; }
  void unset_integer(const char* name, int& f, const Range&) {
    at(name) = f == 0 ? nlohmann::json() : nlohmann::json(f);
  }
  void vector(const char* name, Eigen::Vector3d& f, const Range&) { at(name) = {f.x(), f.y(), f.z()}; }
  void text(const char* name, std::string& f) { at(name) = f; }
  void flag(const char* name, bool& f) { at(name) = f; }
  void seed(const char* name, std::uint64_t& f) { at(name) = f; }
};

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
  SimConfig fields = c;
  forEachSimSetting(fields, SimRangeCheck{});
  // relations between settings
  io::requireInRange(c.lidar.min_range < c.lidar.max_range, "lidar.min_range", c.lidar.min_range,
                     "[0, lidar.max_range) m");
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
}

namespace {

// The list under `cameras`: a sequence of maps with the CameraMount fields (name required).
std::vector<CameraMount> camerasFromYaml(const YAML::Node& list) {
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
        {"position", vectorSetter(m.position, kCameraOffset)},
        {"yaw_deg", io::numberSetter(m.yaw_deg, kCameraYaw)},
        {"pitch_deg", io::numberSetter(m.pitch_deg, kCameraTilt)},
        {"roll_deg", io::numberSetter(m.roll_deg, kCameraTilt)},
        {"width", io::integerSetter(m.width, kCameraSize)},
        {"height", io::integerSetter(m.height, kCameraSize)},
        {"fovy_deg", io::numberSetter(m.fovy_deg, kCameraFovy)},
    };
    for (const auto& kv : item) {
      const std::string key = kv.first.as<std::string>();
      const auto it = fields.find(key);
      if (it == fields.end())
        throw YAML::Exception(kv.first.Mark(), where + ": unknown camera field '" + key +
                                                   "' (known: name, position, yaw_deg, pitch_deg, roll_deg, width, "
                                                   "height, fovy_deg)");
      try {
        it->second(kv.second);
      } catch (const io::OutOfRange& e) {
        throw YAML::Exception(kv.second.Mark(), where + ": " + key + " = " + e.what());
      }
    }
    if (m.name.empty()) throw YAML::Exception(item.Mark(), where + ": a camera needs a name");
    out.push_back(m);
  }
  if (out.empty()) throw YAML::Exception(list.Mark(), "the camera list is empty (set camera.enabled: false instead)");
  return out;
}

}  // namespace

void loadSimConfig(const std::filesystem::path& path, SimConfig& c) {
  SimSetters t;
  forEachSimSetting(c, t);
  t.setters["cameras"] = [&c](const YAML::Node& n) { c.camera.cameras = camerasFromYaml(n); };
  io::applySettings(path, t.setters, "robot, lidar, camera, gps, gyro");
}

std::string simConfigToJson(const SimConfig& c) {
  using nlohmann::json;
  SimConfig fields = c;
  SimJson out;
  forEachSimSetting(fields, out);
  // the cameras as they are put on the robot
  json cameras = json::array();
  for (const auto& m : rigCameras(c.camera)) {
    cameras.push_back({{"name", m.name},
                       {"position", {m.position.x(), m.position.y(), m.position.z()}},
                       {"yaw_deg", m.yaw_deg},
                       {"pitch_deg", m.pitch_deg},
                       {"roll_deg", m.roll_deg},
                       {"width", m.width},
                       {"height", m.height},
                       {"fovy_deg", m.fovy_deg}});
  }
  if (!c.camera.cameras.empty()) out.j["camera"]["rig"] = "custom";
  out.j["cameras"] = cameras;
  return out.j.dump();
}

std::filesystem::path dataPath(const std::string& relative) {
  return std::filesystem::path(TERRAIN_DATA_DIR) / relative;
}

}  // namespace terrain::sim
