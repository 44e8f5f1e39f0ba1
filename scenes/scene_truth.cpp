#include "scenes/scene_truth.hpp"

#include "rig/file_io.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

namespace terrain::scenes {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kFormat = "terrain-scene-truth/1";

constexpr std::array<std::pair<GeomClass, const char*>, 6> kClassNames{{
    {GeomClass::None, "none"},
    {GeomClass::Ground, "ground"},
    {GeomClass::Building, "building"},
    {GeomClass::Trunk, "trunk"},
    {GeomClass::Crown, "crown"},
    {GeomClass::Robot, "robot"},
}};

json pointsToJson(const std::vector<Eigen::Vector2d>& pts) {
  json a = json::array();
  for (const auto& p : pts) a.push_back({p.x(), p.y()});
  return a;
}

// field access that names the file and the JSON path on failure
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  static std::string join(const std::string& where, const std::string& key) {
    return where.empty() ? key : where + "." + key;
  }
  const json& at(const json& j, const std::string& key, const std::string& where) const {
    if (!j.is_object() || !j.contains(key)) fail(join(where, key), "missing");
    return j.at(key);
  }
  double number(const json& j, const std::string& key, const std::string& where) const {
    const json& v = at(j, key, where);
    if (!v.is_number()) fail(join(where, key), "must be a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(join(where, key), "must be finite");
    return x;
  }
  std::string string(const json& j, const std::string& key, const std::string& where) const {
    const json& v = at(j, key, where);
    if (!v.is_string()) fail(join(where, key), "must be a string");
    return v.get<std::string>();
  }
  std::vector<Eigen::Vector2d> points(const json& j, const std::string& key, const std::string& where) const {
    const json& v = at(j, key, where);
    if (!v.is_array()) fail(join(where, key), "must be an array of [x, y]");
    std::vector<Eigen::Vector2d> out;
    for (const auto& p : v) {
      if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number()) {
        fail(join(where, key), "every entry must be [x, y]");
      }
      out.emplace_back(p[0].get<double>(), p[1].get<double>());
      if (!out.back().allFinite()) fail(join(where, key), "must hold finite numbers");
    }
    return out;
  }
  // refuses any key of object j that is not in `keys` (a misspelled field would be ignored silently)
  void known(const json& j, const std::string& where, std::initializer_list<const char*> keys) const {
    if (!j.is_object()) fail(where.empty() ? "(top level)" : where, "must be an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (std::none_of(keys.begin(), keys.end(), [&](const char* k) { return it.key() == k; })) {
        std::string list;
        for (const char* k : keys) list += (list.empty() ? "" : ", ") + std::string(k);
        fail(join(where, it.key()), "is not a field here (known: " + list + ")");
      }
    }
  }
  // an array of n numbers
  std::vector<double> numbers(const json& j, const std::string& key, const std::string& where, std::size_t n) const {
    const json& v = at(j, key, where);
    if (!v.is_array() || v.size() != n) fail(join(where, key), "must be an array of " + std::to_string(n) + " numbers");
    std::vector<double> out;
    for (const auto& x : v) {
      if (!x.is_number() || !std::isfinite(x.get<double>())) fail(join(where, key), "must hold finite numbers");
      out.push_back(x.get<double>());
    }
    return out;
  }
  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw io::InputError(file_ + ": field '" + field + "' " + what);
  }

 private:
  std::string file_;
};

}  // namespace

const char* className(GeomClass c) {
  for (const auto& [cls, name] : kClassNames) {
    if (cls == c) return name;
  }
  return "none";
}

GeomClass classFromName(const std::string& name) {
  for (const auto& [cls, n] : kClassNames) {
    if (name == n) return cls;
  }
  return GeomClass::None;
}

std::vector<std::pair<std::string, GeomClass>> SceneTruth::geomClasses() const {
  std::vector<std::pair<std::string, GeomClass>> out;
  out.emplace_back(terrain.geom, GeomClass::Ground);
  for (const auto& o : objects) {
    for (const auto& g : o.geoms) {
      GeomClass c = o.object_class;
      // tree parts: the trunk geom is named *_trunk
      if (g.size() > 6 && g.compare(g.size() - 6, 6, "_trunk") == 0) c = GeomClass::Trunk;
      out.emplace_back(g, c);
    }
  }
  for (const char* g : {"robot_chassis", "robot_mast"}) out.emplace_back(g, GeomClass::Robot);
  return out;
}

std::string truthToJson(const SceneTruth& t) {
  json j;
  j["format"] = kFormat;
  j["type"] = t.type;
  j["seed"] = t.seed;
  j["extent_m"] = t.extent;
  j["geodetic_origin"] = {{"latitude_deg", t.origin.latitude_deg},
                          {"longitude_deg", t.origin.longitude_deg},
                          {"altitude_m", t.origin.altitude_m}};
  json terr = {{"geom", t.terrain.geom}, {"kind", t.terrain.kind}};
  terr["pos"] = {t.terrain.pos.x(), t.terrain.pos.y(), t.terrain.pos.z()};
  if (t.terrain.kind == "hfield") {
    terr["hfield_file"] = t.terrain.hfield_file;
    terr["nrow"] = t.terrain.nrow;
    terr["ncol"] = t.terrain.ncol;
    terr["size"] = {t.terrain.size[0], t.terrain.size[1], t.terrain.size[2], t.terrain.size[3]};
  }
  terr["height_query"] =
      "true terrain height at (x, y): cast a ray straight down (mj_ray) from above the scene "
      "against the terrain geom only; for an hfield: MuJoCo's triangulated grid, row 0 at "
      "y = pos.y - size[1], elevation = pos.z + size[2] * normalised sample";
  j["terrain"] = terr;
  json classes = json::object();
  for (const auto& [cls, name] : kClassNames) classes[name] = static_cast<int>(cls);
  j["classes"] = classes;
  json objs = json::array();
  for (const auto& o : t.objects) {
    objs.push_back({{"id", o.id},
                    {"class", className(o.object_class)},
                    {"geoms", o.geoms},
                    {"footprint", pointsToJson(o.footprint)},
                    {"base_height_m", o.base_height},
                    {"top_height_m", o.top_height}});
  }
  j["objects"] = objs;
  j["path"] = {{"waypoints", pointsToJson(t.path)}};
  return j.dump(1) + "\n";
}

SceneTruth loadTruth(const fs::path& path) {
  const std::string text = io::readFile(path);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw io::InputError(path.string() + ": not valid JSON (" + e.what() + ")");
  }
  Reader r(path.string());
  if (!j.is_object()) r.fail("(top level)", "must be an object");
  r.known(j, "", {"format", "type", "seed", "extent_m", "geodetic_origin", "terrain", "classes", "objects", "path"});
  if (r.string(j, "format", "") != kFormat) r.fail("format", std::string("must be ") + kFormat);
  SceneTruth t;
  t.type = r.string(j, "type", "");
  t.seed = static_cast<std::uint64_t>(r.number(j, "seed", ""));
  t.extent = r.number(j, "extent_m", "");
  const json& o = r.at(j, "geodetic_origin", "");
  r.known(o, "geodetic_origin", {"latitude_deg", "longitude_deg", "altitude_m"});
  t.origin.latitude_deg = r.number(o, "latitude_deg", "geodetic_origin");
  t.origin.longitude_deg = r.number(o, "longitude_deg", "geodetic_origin");
  t.origin.altitude_m = r.number(o, "altitude_m", "geodetic_origin");
  if (std::abs(t.origin.latitude_deg) > 90 || std::abs(t.origin.longitude_deg) > 180) {
    r.fail("geodetic_origin", "is outside latitude [-90, 90] / longitude [-180, 180]");
  }
  const json& terr = r.at(j, "terrain", "");
  r.known(terr, "terrain", {"geom", "kind", "pos", "hfield_file", "nrow", "ncol", "size", "height_query"});
  t.terrain.geom = r.string(terr, "geom", "terrain");
  t.terrain.kind = r.string(terr, "kind", "terrain");
  const std::vector<double> pos = r.numbers(terr, "pos", "terrain", 3);
  t.terrain.pos = {pos[0], pos[1], pos[2]};
  if (t.terrain.kind == "hfield") {
    t.terrain.hfield_file = r.string(terr, "hfield_file", "terrain");
    t.terrain.nrow = static_cast<int>(r.number(terr, "nrow", "terrain"));
    t.terrain.ncol = static_cast<int>(r.number(terr, "ncol", "terrain"));
    const std::vector<double> size = r.numbers(terr, "size", "terrain", 4);
    for (int i = 0; i < 4; ++i) t.terrain.size[i] = size[i];
    if (t.terrain.nrow < 2 || t.terrain.ncol < 2) r.fail("terrain.nrow", "a heightfield needs at least 2 x 2 samples");
  } else if (t.terrain.kind != "plane") {
    r.fail("terrain.kind", "must be \"plane\" or \"hfield\"");
  }
  const json& objs = r.at(j, "objects", "");
  if (!objs.is_array()) r.fail("objects", "must be an array");
  std::map<std::string, std::string> geom_owner;  // geom -> the object it belongs to
  std::set<std::string> ids;
  for (std::size_t i = 0; i < objs.size(); ++i) {
    const std::string where = "objects[" + std::to_string(i) + "]";
    r.known(objs[i], where, {"id", "class", "geoms", "footprint", "base_height_m", "top_height_m"});
    ObjectTruth ob;
    ob.id = r.string(objs[i], "id", where);
    if (!ids.insert(ob.id).second) r.fail(where + ".id", "'" + ob.id + "' is the id of an earlier object too");
    ob.object_class = classFromName(r.string(objs[i], "class", where));
    if (ob.object_class == GeomClass::None) r.fail(where + ".class", "is not a known class");
    const json& geoms = r.at(objs[i], "geoms", where);
    if (!geoms.is_array() || geoms.empty()) r.fail(where + ".geoms", "must be a non-empty array");
    for (const auto& g : geoms) {
      if (!g.is_string() || g.get<std::string>().empty()) r.fail(where + ".geoms", "must hold geom names");
      const std::string name = g.get<std::string>();
      const auto [it, fresh] = geom_owner.emplace(name, ob.id);
      if (!fresh) r.fail(where + ".geoms", "geom '" + name + "' belongs to object '" + it->second + "' already");
      ob.geoms.push_back(name);
    }
    ob.footprint = r.points(objs[i], "footprint", where);
    if (ob.footprint.size() < 3) r.fail(where + ".footprint", "needs at least 3 points (an outline)");
    ob.base_height = r.number(objs[i], "base_height_m", where);
    ob.top_height = r.number(objs[i], "top_height_m", where);
    if (ob.top_height < ob.base_height) r.fail(where + ".top_height_m", "is below base_height_m");
    t.objects.push_back(std::move(ob));
  }
  r.known(r.at(j, "path", ""), "path", {"waypoints"});
  t.path = r.points(r.at(j, "path", ""), "waypoints", "path");
  if (t.path.size() < 2) r.fail("path.waypoints", "needs at least 2 points");
  for (std::size_t k = 1; k < t.path.size(); ++k) {
    if ((t.path[k] - t.path[k - 1]).norm() < 1e-6) {
      r.fail("path.waypoints",
             "points " + std::to_string(k - 1) + " and " + std::to_string(k) + " are the same (a segment of length 0)");
    }
  }
  return t;
}

fs::path truthPathFor(const fs::path& scene_xml) {
  fs::path p = scene_xml;
  p.replace_extension(".truth.json");
  return p;
}

}  // namespace terrain::scenes
