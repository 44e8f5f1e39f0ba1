#include "rig/velodyne_calibration.hpp"

#include "rig/file_io.hpp"

#include <tinyxml2.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace terrain::rig {

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

[[noreturn]] void fail(const std::string& origin, const std::string& what) {
  throw io::InputError(origin + ": " + what);
}

// checks values a real unit can have; names the laser and field otherwise
void validate(const LaserCalibration& c, const std::string& origin) {
  const int n = c.laserCount();
  if (n == 0) fail(origin, "no lasers");
  if (n != 16 && n != 32 && n != 64) {
    fail(origin, std::to_string(n) + " lasers (allowed: 16, 32 or 64)");
  }
  if (!(c.distance_resolution > 0 && c.distance_resolution <= 0.01)) {
    fail(origin, "distance_resolution must be in (0, 0.01] m");
  }
  for (int i = 0; i < n; ++i) {
    const LaserCorrection& l = c.lasers[i];
    const std::string where = "laser " + std::to_string(i) + ": ";
    if (l.id != i) fail(origin, "laser " + std::to_string(i) + " is missing");
    auto check = [&](double v, double limit, const char* field, const char* unit) {
      if (!std::isfinite(v) || std::abs(v) > limit) {
        std::ostringstream s;
        s << where << field << " = " << v << " is outside [-" << limit << ", " << limit << "] " << unit;
        fail(origin, s.str());
      }
    };
    check(l.rot_correction, 45 * kDegToRad, "rot_correction", "rad");
    check(l.vert_correction, 45 * kDegToRad, "vert_correction", "rad");
    check(l.dist_correction, 5.0, "dist_correction", "m");
    check(l.dist_correction_x, 5.0, "dist_correction_x", "m");
    check(l.dist_correction_y, 5.0, "dist_correction_y", "m");
    check(l.vert_offset, 1.0, "vert_offset_correction", "m");
    check(l.horiz_offset, 1.0, "horiz_offset_correction", "m");
    if (l.min_intensity < 0 || l.max_intensity > 255 || l.min_intensity > l.max_intensity) {
      fail(origin, where + "intensity limits must satisfy 0 <= min <= max <= 255");
    }
  }
}

LaserCalibration readYamlLasers(const YAML::Node& root, const std::string& origin);

LaserCalibration parseYaml(const std::string& text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(origin, "not valid YAML (line " + std::to_string(e.mark.line + 1) + ": " + e.msg + ")");
  }
  if (!root.IsMap() || !root["lasers"] || !root["lasers"].IsSequence()) {
    fail(origin, "expected a map with a 'lasers' list");
  }
  try {
    return readYamlLasers(root, origin);
  } catch (const YAML::Exception& e) {
    // whatever the field-by-field checks did not foresee
    fail(origin, "unexpected YAML structure (line " + std::to_string(e.mark.line + 1) + ": " + e.msg + ")");
  }
}

LaserCalibration readYamlLasers(const YAML::Node& root, const std::string& origin) {
  LaserCalibration c;
  if (root["distance_resolution"]) {
    try {
      c.distance_resolution = root["distance_resolution"].as<double>();
    } catch (const YAML::Exception&) {
      fail(origin, "distance_resolution is not a number");
    }
  }
  const YAML::Node lasers = root["lasers"];
  c.lasers.resize(lasers.size());
  std::vector<bool> seen(lasers.size(), false);
  for (std::size_t k = 0; k < lasers.size(); ++k) {
    const YAML::Node l = lasers[k];
    const std::string where = "lasers[" + std::to_string(k) + "]";
    if (!l.IsMap()) fail(origin, where + ": expected a map of fields");
    auto get = [&](const char* key, bool required, double fallback) {
      if (!l[key]) {
        if (required) fail(origin, where + ": field '" + key + "' is missing");
        return fallback;
      }
      try {
        return l[key].as<double>();
      } catch (const YAML::Exception&) {
        fail(origin, where + ": field '" + key + "' is not a number");
      }
    };
    const double id = get("laser_id", true, 0);
    if (id < 0 || id >= static_cast<double>(lasers.size()) || id != std::floor(id)) {
      fail(origin,
           where + ": laser_id " + std::to_string(id) + " is outside [0, " + std::to_string(lasers.size() - 1) + "]");
    }
    const auto i = static_cast<std::size_t>(id);
    if (seen[i]) fail(origin, where + ": laser_id " + std::to_string(i) + " appears twice");
    seen[i] = true;
    LaserCorrection& out = c.lasers[i];
    out.id = static_cast<int>(i);
    out.rot_correction = get("rot_correction", true, 0);
    out.vert_correction = get("vert_correction", true, 0);
    out.dist_correction = get("dist_correction", false, 0);
    out.dist_correction_x = get("dist_correction_x", false, 0);
    out.dist_correction_y = get("dist_correction_y", false, 0);
    out.vert_offset = get("vert_offset_correction", false, 0);
    out.horiz_offset = get("horiz_offset_correction", false, 0);
    out.focal_distance = get("focal_distance", false, 0);
    out.focal_slope = get("focal_slope", false, 0);
    out.min_intensity = static_cast<int>(get("min_intensity", false, 0));
    out.max_intensity = static_cast<int>(get("max_intensity", false, 255));
  }
  return c;
}

// Velodyne db.xml as written by boost serialization: angles in degrees, lengths in cm
LaserCalibration parseDbXml(const std::string& text, const std::string& origin) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.c_str(), text.size()) != tinyxml2::XML_SUCCESS) {
    fail(origin,
         std::string("not valid XML (line ") + std::to_string(doc.ErrorLineNum()) + ": " + doc.ErrorStr() + ")");
  }
  const tinyxml2::XMLElement* db = doc.FirstChildElement("boost_serialization");
  db = db ? db->FirstChildElement("DB") : nullptr;
  if (!db) fail(origin, "expected <boost_serialization><DB> (Velodyne db.xml)");
  LaserCalibration c;
  if (const auto* lsb = db->FirstChildElement("distLSB_")) c.distance_resolution = lsb->DoubleText(0.2) / 100.0;
  const tinyxml2::XMLElement* points = db->FirstChildElement("points_");
  if (!points) fail(origin, "<points_> is missing");
  std::vector<LaserCorrection> lasers;
  for (const auto* item = points->FirstChildElement("item"); item; item = item->NextSiblingElement("item")) {
    const auto* px = item->FirstChildElement("px");
    const int line = item->GetLineNum();
    if (!px) fail(origin, "line " + std::to_string(line) + ": <item> without <px>");
    auto get = [&](const char* key) {
      const auto* e = px->FirstChildElement(key);
      double v = 0;
      if (!e || e->QueryDoubleText(&v) != tinyxml2::XML_SUCCESS) {
        fail(origin, "line " + std::to_string(line) + ": <" + key + "> is missing or not a number");
      }
      return v;
    };
    LaserCorrection l;
    l.id = static_cast<int>(get("id_"));
    l.rot_correction = get("rotCorrection_") * kDegToRad;
    l.vert_correction = get("vertCorrection_") * kDegToRad;
    l.dist_correction = get("distCorrection_") / 100.0;
    l.dist_correction_x = get("distCorrectionX_") / 100.0;
    l.dist_correction_y = get("distCorrectionY_") / 100.0;
    l.vert_offset = get("vertOffsetCorrection_") / 100.0;
    l.horiz_offset = get("horizOffsetCorrection_") / 100.0;
    l.focal_distance = get("focalDistance_") / 100.0;
    l.focal_slope = get("focalSlope_");
    lasers.push_back(l);
  }
  // db.xml lists 64 entries even for 32-laser units; order by id and require 0..n-1
  c.lasers.assign(lasers.size(), LaserCorrection{});
  std::vector<bool> seen(lasers.size(), false);
  for (const auto& l : lasers) {
    if (l.id < 0 || l.id >= static_cast<int>(lasers.size())) {
      fail(origin, "laser id " + std::to_string(l.id) + " is outside [0, " + std::to_string(lasers.size() - 1) + "]");
    }
    if (seen[l.id]) fail(origin, "laser id " + std::to_string(l.id) + " appears twice");
    seen[l.id] = true;
    c.lasers[l.id] = l;
  }
  return c;
}

}  // namespace

LaserCalibration parseLaserCalibration(const std::string& text, const std::string& origin) {
  const auto first = text.find_first_not_of(" \t\r\n");
  LaserCalibration c =
      (first != std::string::npos && text[first] == '<') ? parseDbXml(text, origin) : parseYaml(text, origin);
  c.source = origin;
  validate(c, origin);
  return c;
}

LaserCalibration loadLaserCalibration(const std::filesystem::path& path) {
  return parseLaserCalibration(io::readFile(path), path.string());
}

std::string laserCalibrationToYaml(const LaserCalibration& c) {
  std::ostringstream y;
  char buf[64];
  auto f = [&](double v) {
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return std::string(buf);
  };
  y << "distance_resolution: " << f(c.distance_resolution) << "\nlasers:\n";
  for (const auto& l : c.lasers) {
    y << "- laser_id: " << l.id << "\n"
      << "  rot_correction: " << f(l.rot_correction) << "\n"
      << "  vert_correction: " << f(l.vert_correction) << "\n"
      << "  dist_correction: " << f(l.dist_correction) << "\n"
      << "  dist_correction_x: " << f(l.dist_correction_x) << "\n"
      << "  dist_correction_y: " << f(l.dist_correction_y) << "\n"
      << "  vert_offset_correction: " << f(l.vert_offset) << "\n"
      << "  horiz_offset_correction: " << f(l.horiz_offset) << "\n"
      << "  focal_distance: " << f(l.focal_distance) << "\n"
      << "  focal_slope: " << f(l.focal_slope) << "\n"
      << "  min_intensity: " << l.min_intensity << "\n"
      << "  max_intensity: " << l.max_intensity << "\n";
  }
  return y.str();
}

void laserRay(const LaserCorrection& l, double a, Vector3& origin, Vector3& direction) {
  const double az = a - l.rot_correction;
  const double ca = std::cos(az), sa = std::sin(az);
  const double cv = std::cos(l.vert_correction), sv = std::sin(l.vert_correction);
  direction = Vector3(cv * ca, -cv * sa, sv);
  origin = Vector3(l.horiz_offset * sa, l.horiz_offset * ca, l.vert_offset);
}

}  // namespace terrain::rig
