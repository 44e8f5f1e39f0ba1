#include "sim/scene_import.hpp"

#include "rig/file_io.hpp"
#include "sim/hfield_ray.hpp"
#include "sim/scene_checks.hpp"

#include <mujoco/mujoco.h>
#include <tinyxml2.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <set>
#include <sstream>

namespace terrain::sim {

namespace fs = std::filesystem;
using Point2 = Eigen::Vector2d;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// convex hull (counter-clockwise, Andrew's monotone chain)
std::vector<Point2> hull(std::vector<Point2> p) {
  std::sort(p.begin(), p.end(),
            [](const Point2& a, const Point2& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  const auto cross = [](const Point2& o, const Point2& a, const Point2& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::vector<Point2> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
    h[k++] = p[i - 1];
  }
  h.resize(k - 1);
  return h;
}

Point2 centroid(const std::vector<Point2>& poly) {
  Point2 c = Point2::Zero();
  for (const auto& q : poly) c += q;
  return c / static_cast<double>(poly.size());
}

double round3(double v) { return std::round(v * 1000.0) / 1000.0; }

// A geom as the import sees it: its class, outline on the ground and top
struct Geom {
  int id = 0;
  std::string name, cls;
  int body = 0;
  std::vector<Point2> outline;  // [m] world x, y
  double top = 0;               // [m] world z of its highest point
};

}  // namespace

void loadImportPatterns(const fs::path& path, ImportOptions& options) {
  YAML::Node root;
  try {
    root = YAML::Load(io::readFile(path));
  } catch (const YAML::Exception& e) {
    throw io::InputError(path.string() + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!root.IsMap())
    throw io::InputError(path.string() + ": expected a map of class to patterns (building, crown, trunk, terrain)");
  for (const auto& kv : root) {
    const std::string cls = kv.first.as<std::string>();
    const int line = kv.second.Mark().line + 1;
    if (!options.patterns.count(cls)) {
      throw io::InputError(path.string() + ":" + std::to_string(line) + ": unknown class '" + cls +
                           "' (building, crown, trunk, terrain)");
    }
    if (!kv.second.IsSequence() || kv.second.size() == 0) {
      throw io::InputError(path.string() + ":" + std::to_string(line) + ": '" + cls +
                           "' needs a list of name patterns");
    }
    std::vector<std::string> list;
    for (const auto& p : kv.second) {
      if (!p.IsScalar() || p.as<std::string>().empty())
        throw io::InputError(path.string() + ":" + std::to_string(p.Mark().line + 1) +
                             ": a pattern must be a non-empty string");
      list.push_back(lower(p.as<std::string>()));
    }
    options.patterns[cls] = list;
  }
}

ImportedScene importScene(const fs::path& world_path, const fs::path& out, const ImportOptions& options) {
  const std::string where = world_path.string();
  // the world as MuJoCo compiles it, for every geom's place and size
  char error[1000] = "";
  mjModel* m = mj_loadXML(world_path.c_str(), nullptr, error, sizeof error);
  if (!m) throw io::InputError(where + ": MuJoCo could not load it: " + error);
  mjData* d = mj_makeData(m);
  mj_forward(m, d);
  struct Free {
    mjModel* m;
    mjData* d;
    ~Free() { mj_deleteData(d), mj_deleteModel(m); }
  } free_model{m, d};

  ImportedScene out_scene;
  const auto name = [&](int type, int id) {
    const char* n = mj_id2name(m, type, id);
    return n ? std::string(n) : std::string();
  };
  const auto classOf = [&](int g) -> std::string {
    std::vector<std::string> names = {name(mjOBJ_GEOM, g)};
    if (m->geom_matid[g] >= 0) names.push_back(name(mjOBJ_MATERIAL, m->geom_matid[g]));
    names.push_back(name(mjOBJ_BODY, m->geom_bodyid[g]));
    for (const std::string& n : names) {
      const std::string l = lower(n);
      if (l.empty()) continue;
      for (const char* cls : {"trunk", "crown", "building", "terrain"}) {
        for (const auto& p : options.patterns.at(cls)) {
          if (l.find(p) != std::string::npos) return cls;
        }
      }
    }
    return "";
  };
  const int robot = mj_name2id(m, mjOBJ_BODY, "robot");

  // the terrain: the first plane or heightfield (one named as terrain first)
  int terrain = -1;
  for (int pass = 0; pass < 2 && terrain < 0; ++pass) {
    for (int g = 0; g < m->ngeom && terrain < 0; ++g) {
      const bool surface = m->geom_type[g] == mjGEOM_PLANE || m->geom_type[g] == mjGEOM_HFIELD;
      if (surface && (pass == 1 || classOf(g) == "terrain")) terrain = g;
    }
  }
  if (terrain < 0) throw io::InputError(where + ": no plane or heightfield geom to be the terrain");
  if (name(mjOBJ_GEOM, terrain).empty())
    throw io::InputError(where + ": the terrain geom (geom " + std::to_string(terrain) + ") needs a name");
  scenes::SceneTruth& t = out_scene.truth;
  t.type = lower(world_path.stem().string());
  t.seed = 0;
  t.origin = options.origin;
  t.terrain.geom = name(mjOBJ_GEOM, terrain);
  t.terrain.pos = {d->geom_xpos[3 * terrain], d->geom_xpos[3 * terrain + 1], d->geom_xpos[3 * terrain + 2]};
  double half_x = 0, half_y = 0;
  if (m->geom_type[terrain] == mjGEOM_HFIELD) {
    const int h = m->geom_dataid[terrain];
    t.terrain.kind = "hfield";
    t.terrain.nrow = m->hfield_nrow[h], t.terrain.ncol = m->hfield_ncol[h];
    for (int i = 0; i < 4; ++i) t.terrain.size[i] = m->hfield_size[4 * h + i];
    half_x = m->hfield_size[4 * h], half_y = m->hfield_size[4 * h + 1];
  } else {
    t.terrain.kind = "plane";
    half_x = m->geom_size[3 * terrain], half_y = m->geom_size[3 * terrain + 1];
  }
  // the terrain's height at (x, y) (NaN off it)
  const double above = heightAboveGeoms(m, d);
  const auto terrainHeight = [&](double x, double y) { return terrainHeightAt(m, d, terrain, above, x, y); };

  // every other geom outside the robot: its class, outline and top
  std::vector<Geom> geoms;
  for (int g = 0; g < m->ngeom; ++g) {
    if (g == terrain || (robot >= 0 && m->geom_bodyid[g] == robot)) continue;
    const std::string n = name(mjOBJ_GEOM, g);
    const std::string cls = classOf(g);
    if (cls.empty() || cls == "terrain" || n.empty()) {
      out_scene.unclassified.push_back(n.empty()
                                           ? "geom " + std::to_string(g) + " (unnamed, in body '" +
                                                 name(mjOBJ_BODY, m->geom_bodyid[g]) + "': give it a name to class it)"
                                           : n);
      continue;
    }
    const double* s = m->geom_size + 3 * g;
    const double* R = d->geom_xmat + 9 * g;
    const Eigen::Vector3d c(d->geom_xpos[3 * g], d->geom_xpos[3 * g + 1], d->geom_xpos[3 * g + 2]);
    Eigen::Vector3d half;  // half extents in the geom's frame
    bool round = true;
    switch (m->geom_type[g]) {
      case mjGEOM_BOX:
        half = {s[0], s[1], s[2]}, round = false;
        break;
      case mjGEOM_SPHERE:
        half = {s[0], s[0], s[0]};
        break;
      case mjGEOM_CYLINDER:
        half = {s[0], s[0], s[1]};
        break;
      case mjGEOM_CAPSULE:
        half = {s[0], s[0], s[1] + s[0]};
        break;
      case mjGEOM_ELLIPSOID:
        half = {s[0], s[1], s[2]};
        break;
      default:
        half = Eigen::Vector3d::Constant(m->geom_rbound[g]);
        break;  // meshes and the rest: their bounding sphere
    }
    Geom geom{g, n, cls, m->geom_bodyid[g], {}, c.z()};
    for (int i = 0; i < 3; ++i) geom.top += std::abs(R[6 + i]) * half[i];
    // the outline: the box's corners, or a 16-gon round the axes, in world x, y
    const int k = round ? 16 : 4;
    for (int i = 0; i < k; ++i) {
      const double a = round ? 2 * kPi * i / k : 0;
      const Eigen::Vector3d local =
          round ? Eigen::Vector3d(half.x() * std::cos(a), half.y() * std::sin(a), 0)
                : Eigen::Vector3d((i == 0 || i == 3) ? -half.x() : half.x(), i < 2 ? -half.y() : half.y(), 0);
      for (double z : {-half.z(), half.z()}) {
        const Eigen::Vector3d l(local.x(), local.y(), round ? 0.0 : z);
        geom.outline.emplace_back(c.x() + R[0] * l.x() + R[1] * l.y() + R[2] * l.z(),
                                  c.y() + R[3] * l.x() + R[4] * l.y() + R[5] * l.z());
      }
    }
    geom.outline = hull(geom.outline);
    geoms.push_back(std::move(geom));
  }

  // objects: geoms of one class in one body whose outlines touch (within 0.1 m), joined
  std::vector<std::size_t> parent(geoms.size());
  std::iota(parent.begin(), parent.end(), 0);
  const std::function<std::size_t(std::size_t)> root = [&](std::size_t i) {
    return parent[i] == i ? i : parent[i] = root(parent[i]);
  };
  const auto touch = [](const Geom& a, const Geom& b) {
    for (const auto& p : a.outline)
      if (distanceToPolygon(b.outline, p) <= 0.1) return true;
    for (const auto& p : b.outline)
      if (distanceToPolygon(a.outline, p) <= 0.1) return true;
    return false;
  };
  for (std::size_t i = 0; i < geoms.size(); ++i) {
    for (std::size_t j = i + 1; j < geoms.size(); ++j) {
      if (geoms[i].cls == geoms[j].cls && geoms[i].body == geoms[j].body && geoms[i].cls != "trunk" &&
          touch(geoms[i], geoms[j]))
        parent[root(j)] = root(i);
    }
  }
  struct Group {
    std::string cls;
    std::vector<std::size_t> members;
    std::vector<Point2> footprint;
  };
  std::vector<Group> groups;
  std::map<std::size_t, std::size_t> group_of_root;
  for (std::size_t i = 0; i < geoms.size(); ++i) {
    if (geoms[i].cls == "trunk") continue;
    const auto [it, fresh] = group_of_root.emplace(root(i), groups.size());
    if (fresh) groups.push_back({geoms[i].cls, {}, {}});
    groups[it->second].members.push_back(i);
  }
  for (Group& gr : groups) {
    std::vector<Point2> all;
    for (std::size_t i : gr.members) all.insert(all.end(), geoms[i].outline.begin(), geoms[i].outline.end());
    gr.footprint = hull(all);
  }
  // a trunk belongs to the crown over it (the nearest centre), else stands alone
  for (std::size_t i = 0; i < geoms.size(); ++i) {
    if (geoms[i].cls != "trunk") continue;
    const Point2 c = centroid(geoms[i].outline);
    std::size_t best = groups.size();
    double best_d = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < groups.size(); ++k) {
      if (groups[k].cls != "crown" || distanceToPolygon(groups[k].footprint, c) > 0) continue;
      const double dist = (centroid(groups[k].footprint) - c).norm();
      if (dist < best_d) best_d = dist, best = k;
    }
    if (best == groups.size())
      groups.push_back({"trunk", {i}, geoms[i].outline});
    else
      groups[best].members.push_back(i);
  }
  std::map<std::string, int> count;
  std::set<std::string> ids;
  for (const Group& gr : groups) {
    scenes::ObjectTruth o;
    o.object_class = scenes::classFromName(gr.cls);
    // named after its first geom
    std::string id = geoms[gr.members.front()].name;
    while (!ids.insert(id).second) id += "_" + std::to_string(++count[id]);
    o.id = id;
    o.top_height = -std::numeric_limits<double>::infinity();
    for (std::size_t i : gr.members)
      o.geoms.push_back(geoms[i].name), o.top_height = std::max(o.top_height, geoms[i].top);
    for (const auto& p : gr.footprint) o.footprint.emplace_back(round3(p.x()), round3(p.y()));
    const Point2 c = centroid(gr.footprint);
    double base = terrainHeight(c.x(), c.y());
    if (!std::isfinite(base)) base = t.terrain.pos.z();
    o.base_height = round3(base);
    o.top_height = round3(std::max(o.top_height, base));
    t.objects.push_back(std::move(o));
  }

  // the terrain's extent, and the objects' if the plane is infinite (size 0)
  if (half_x <= 0 || half_y <= 0) {
    double r = 20;
    for (const Geom& g : geoms)
      for (const auto& p : g.outline) r = std::max({r, std::abs(p.x()) + 20, std::abs(p.y()) + 20});
    half_x = half_y = r;
  }
  t.extent = round3(std::max(half_x, half_y));
  const Point2 centre = t.terrain.pos.head<2>();
  // room from a point to the nearest footprint
  const auto room = [&](const Point2& p) {
    double r = std::numeric_limits<double>::infinity();
    for (const auto& o : t.objects) r = std::min(r, distanceToPolygon(o.footprint, p));
    return r;
  };
  const double need = kRobotHalfWidth + options.clearance;
  if (!options.path.empty()) {
    t.path = options.path;
  } else {
    // the straight line along x, 90 % of the terrain long, nearest the terrain's middle with 2 m of
    // room more than needed, else the one with the most room
    const double x0 = centre.x() - 0.9 * half_x, x1 = centre.x() + 0.9 * half_x;
    double best = -1, best_y = centre.y();
    bool roomy = false;
    for (double dy = 0; dy <= 0.8 * half_y && !roomy; dy += 0.5) {
      for (double y : {centre.y() + dy, centre.y() - dy}) {
        double r = std::numeric_limits<double>::infinity();
        for (double x = x0; x <= x1; x += 0.5) r = std::min(r, room({x, y}));
        if (r >= need + 2.0) {
          best = r, best_y = y, roomy = true;
          break;
        }
        if (r > best + 1e-9) best = r, best_y = y;
      }
    }
    if (best < need) {
      std::ostringstream msg;
      msg << where << ": no straight path along x with " << need << " m of room (the most: " << best
          << " m at y = " << best_y << "); give --path";
      throw io::InputError(msg.str());
    }
    t.path = {{round3(x0), round3(best_y)}, {round3(x1), round3(best_y)}};
  }
  // the path's room and terrain
  double path_room = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < t.path.size(); ++i) {
    const Point2 a = t.path[i], b = t.path[i + 1];
    if ((b - a).norm() < 1e-6)
      throw io::InputError("--path: points " + std::to_string(i) + " and " + std::to_string(i + 1) + " are the same");
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.5)));
    for (int k = 0; k <= n; ++k) {
      const Point2 p = a + (b - a) * (static_cast<double>(k) / n);
      if (!std::isfinite(terrainHeight(p.x(), p.y()))) {
        std::ostringstream msg;
        msg << "--path: (" << p.x() << ", " << p.y() << ") has no terrain under it";
        throw io::InputError(msg.str());
      }
      path_room = std::min(path_room, room(p));
    }
  }
  out_scene.path_clearance = path_room;

  // the scene: the world's XML, with a skybox and the robot where it has none
  tinyxml2::XMLDocument doc;
  const std::string text = io::readFile(world_path);
  if (doc.Parse(text.c_str(), text.size()) != tinyxml2::XML_SUCCESS)
    throw io::InputError(where + ": " + doc.ErrorStr());
  tinyxml2::XMLElement* top = doc.FirstChildElement("mujoco");
  if (!top) throw io::InputError(where + ": no <mujoco> element");
  // files the world names (heightfields, meshes, textures, includes) are relative to its folder
  const std::function<bool(const tinyxml2::XMLElement*)> namesFiles = [&](const tinyxml2::XMLElement* e) {
    if (e->Attribute("file")) return true;
    for (auto* c = e->FirstChildElement(); c; c = c->NextSiblingElement())
      if (namesFiles(c)) return true;
    return false;
  };
  if (fs::absolute(out).parent_path().lexically_normal() != fs::absolute(world_path).parent_path().lexically_normal() &&
      namesFiles(top)) {
    throw io::InputError(out.string() + ": write the scene beside " + world_path.filename().string() +
                         " (in its folder): the world names files relative to it");
  }
  if (t.terrain.kind == "hfield") {
    for (auto* asset = top->FirstChildElement("asset"); asset; asset = asset->NextSiblingElement("asset")) {
      for (auto* h = asset->FirstChildElement("hfield"); h; h = h->NextSiblingElement("hfield")) {
        const char* file = h->Attribute("file");
        if (file && name(mjOBJ_HFIELD, m->geom_dataid[terrain]) == (h->Attribute("name") ? h->Attribute("name") : ""))
          t.terrain.hfield_file = file;
      }
    }
    if (t.terrain.hfield_file.empty())
      throw io::InputError(where +
                           ": the terrain heightfield must come from a file (file=...) for the truth to name it");
  }
  bool skybox = false;
  for (int i = 0; i < m->ntex; ++i) skybox = skybox || m->tex_type[i] == mjTEXTURE_SKYBOX;
  if (!skybox) {
    tinyxml2::XMLElement* asset = top->FirstChildElement("asset");
    if (!asset) asset = top->InsertNewChildElement("asset");
    auto* sky = asset->InsertNewChildElement("texture");
    sky->SetAttribute("name", "terrain_testbed_sky");
    sky->SetAttribute("type", "skybox");
    sky->SetAttribute("builtin", "gradient");
    sky->SetAttribute("rgb1", "0.45 0.62 0.88");
    sky->SetAttribute("rgb2", "0.9 0.94 1");
    sky->SetAttribute("width", "256");
    sky->SetAttribute("height", "256");
    out_scene.added.push_back("a skybox (a daylight gradient)");
  }
  tinyxml2::XMLElement* body = top->FirstChildElement("worldbody");
  if (!body) throw io::InputError(where + ": no <worldbody>");
  if (m->nlight == 0) {
    auto* sun = body->InsertNewChildElement("light");
    sun->SetAttribute("name", "terrain_testbed_sun");
    sun->SetAttribute("directional", "true");
    sun->SetAttribute("pos", "0 0 100");
    sun->SetAttribute("dir", "-0.3 -0.4 -1");
    out_scene.added.push_back("a directional light (the sun)");
  }
  if (robot < 0) {
    auto* r = body->InsertNewChildElement("body");
    r->SetAttribute("name", "robot");
    r->SetAttribute("mocap", "true");
    std::ostringstream pos;
    pos << t.path.front().x() << " " << t.path.front().y() << " 0";
    r->SetAttribute("pos", pos.str().c_str());
    const auto part = [&](const char* n, const char* type, const char* size, const char* at) {
      auto* g = r->InsertNewChildElement("geom");
      g->SetAttribute("name", n), g->SetAttribute("type", type), g->SetAttribute("size", size),
          g->SetAttribute("pos", at);
      g->SetAttribute("group", "3"), g->SetAttribute("contype", "0"), g->SetAttribute("conaffinity", "0");
      g->SetAttribute("rgba", "0.85 0.55 0.1 1");
    };
    part("robot_chassis", "box", "0.5 0.35 0.2", "0 0 0.35");
    part("robot_mast", "cylinder", "0.04 0.8", "0 0 1");
    out_scene.added.push_back("the robot's body (robot: chassis, mast) and its camera (robot_camera)");
  }
  if (mj_name2id(m, mjOBJ_CAMERA, "robot_camera") < 0) {
    tinyxml2::XMLElement* r = nullptr;
    for (auto* b = body->FirstChildElement("body"); b && !r; b = b->NextSiblingElement("body")) {
      if (b->Attribute("name") && std::string(b->Attribute("name")) == "robot") r = b;
    }
    if (!r) throw io::InputError(where + ": the body 'robot' must be a direct child of <worldbody>");
    auto* cam = r->InsertNewChildElement("camera");
    cam->SetAttribute("name", "robot_camera");
    cam->SetAttribute("pos", "0.1 0 1.6");
    cam->SetAttribute("xyaxes", "0 -1 0 0 0 1");
    cam->SetAttribute("fovy", "75");
    if (robot >= 0) out_scene.added.push_back("the robot's camera (robot_camera)");
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  out_scene.mjcf = printer.CStr();
  return out_scene;
}

}  // namespace terrain::sim
