#include "scenes/scene_generator.hpp"

#include "core/random.hpp"
#include "rig/file_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <sstream>

namespace terrain::scenes {

namespace fs = std::filesystem;

namespace {

constexpr double kPi = 3.14159265358979323846;

// parameters that distinguish the terrain types
struct TypeRecipe {
  bool heightfield = true;
  // value-noise octaves: (wavelength [m], amplitude [m])
  std::vector<std::pair<double, double>> octaves;
  double ramp_min_deg = 0, ramp_max_deg = 0;  // slope ramps along x (0: none)
  double cross_slope_deg = 0;                 // constant incline along y
  int buildings_per_100m = 0;                 // first row, both sides together
  bool second_row = false;
  int trees = 0;
  double path_amplitude = 3.0;  // [m] lateral wiggle of the path
};

TypeRecipe recipeFor(const std::string& type) {
  TypeRecipe r;
  if (type == "flat") {
    r.heightfield = false;
    r.buildings_per_100m = 6;
    r.trees = 40;
  } else if (type == "slope") {
    r.ramp_min_deg = 5;
    r.ramp_max_deg = 20;
    r.cross_slope_deg = 2;
    r.octaves = {{20.0, 0.15}};
    r.buildings_per_100m = 4;
    r.trees = 50;
  } else if (type == "rough") {
    r.octaves = {{32.0, 2.0}, {10.0, 0.7}, {3.0, 0.3}};
    r.buildings_per_100m = 2;
    r.trees = 60;
  } else if (type == "urban") {
    r.octaves = {{60.0, 0.4}, {15.0, 0.1}};
    r.buildings_per_100m = 14;
    r.second_row = true;
    r.trees = 90;
    r.path_amplitude = 1.5;
  } else if (type == "forest") {
    r.octaves = {{30.0, 1.0}, {8.0, 0.35}, {3.0, 0.1}};
    r.buildings_per_100m = 1;
    r.trees = 220;
  } else if (type == "mixed") {
    r.ramp_min_deg = 5;
    r.ramp_max_deg = 12;
    r.octaves = {{24.0, 1.0}, {6.0, 0.3}};
    r.buildings_per_100m = 7;
    r.trees = 90;
  }
  return r;
}

double round3(double v) { return std::round(v * 1000.0) / 1000.0; }

// fixed formatting of numbers in MJCF, so output is identical everywhere
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", round3(v) == 0.0 ? 0.0 : round3(v));
  return buf;
}

// smooth 2D value noise with one random value per lattice point
double valueNoise(std::uint64_t seed, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  auto lattice = [&](std::int64_t i, std::int64_t j) {
    return 2.0 * unitFromBits(hashKeys(seed, static_cast<std::uint64_t>(i), static_cast<std::uint64_t>(j))) - 1.0;
  };
  auto smooth = [](double t) { return t * t * t * (t * (6 * t - 15) + 10); };
  const double tx = smooth(x - fx), ty = smooth(y - fy);
  const double a = lattice(ix, iy), b = lattice(ix + 1, iy);
  const double c = lattice(ix, iy + 1), d = lattice(ix + 1, iy + 1);
  return (a + (b - a) * tx) * (1 - ty) + (c + (d - c) * tx) * ty;
}

// terrain height as a continuous function, before sampling into the heightfield
class TerrainFunction {
 public:
  TerrainFunction(const TypeRecipe& recipe, std::uint64_t seed, double extent)
      : recipe_(recipe), seed_(seed), extent_(extent) {
    if (recipe.ramp_max_deg > 0) buildRampProfile();
  }

  double operator()(double x, double y) const {
    double h = 0;
    int octave = 0;
    for (const auto& [wavelength, amplitude] : recipe_.octaves) {
      h += amplitude * valueNoise(hashKeys(seed_, 101, octave++), x / wavelength, y / wavelength);
    }
    h += std::tan(recipe_.cross_slope_deg * kPi / 180.0) * y;
    if (!profile_.empty()) {
      const double u = std::clamp((x + extent_) / kProfileStep, 0.0, profile_.size() - 1.001);
      const auto i = static_cast<std::size_t>(u);
      h += profile_[i] + (profile_[i + 1] - profile_[i]) * (u - i);
    }
    return h;
  }

 private:
  static constexpr double kProfileStep = 0.25;  // [m]

  // ramps along x: inclines alternate up and down, separated by short level stretches; the
  // slope changes smoothly over a few metres so the robot can drive it
  void buildRampProfile() {
    Random rng(hashKeys(seed_, 202));
    const int n = static_cast<int>(2 * extent_ / kProfileStep) + 2;
    std::vector<double> slope(n, 0.0);
    double x = 0;
    double sign = rng.uniform() < 0.5 ? 1.0 : -1.0;
    while (x < 2 * extent_) {
      const double level = rng.uniform(6, 14), ramp = rng.uniform(12, 24);
      const double incline = rng.uniform(recipe_.ramp_min_deg, recipe_.ramp_max_deg);
      const int a = static_cast<int>((x + level) / kProfileStep);
      const int b = std::min(n, static_cast<int>((x + level + ramp) / kProfileStep));
      for (int i = a; i < b; ++i) slope[i] = sign * std::tan(incline * kPi / 180.0);
      sign = -sign;
      x += level + ramp;
    }
    // soften the slope changes with a 3 m box filter, then integrate
    const int half = static_cast<int>(1.5 / kProfileStep);
    profile_.assign(n, 0.0);
    for (int i = 1; i < n; ++i) {
      double s = 0;
      int count = 0;
      for (int k = std::max(0, i - half); k <= std::min(n - 1, i + half); ++k, ++count) s += slope[k];
      profile_[i] = profile_[i - 1] + s / count * kProfileStep;
    }
  }

  TypeRecipe recipe_;
  std::uint64_t seed_;
  double extent_;
  std::vector<double> profile_;
};

// the sampled terrain: heights on the hfield grid (or zero for a plane)
struct TerrainGrid {
  bool plane = true;
  int n = 0;  // samples per side
  double extent = 0, cell = 0;
  std::vector<double> height;  // row-major, row along y

  // bilinear height between samples [m]
  double at(double x, double y) const {
    if (plane) return 0.0;
    const double u = std::clamp((x + extent) / cell, 0.0, n - 1.0001);
    const double v = std::clamp((y + extent) / cell, 0.0, n - 1.0001);
    const int c = static_cast<int>(u), r = static_cast<int>(v);
    const double tu = u - c, tv = v - r;
    const double h00 = height[r * n + c], h01 = height[r * n + c + 1];
    const double h10 = height[(r + 1) * n + c], h11 = height[(r + 1) * n + c + 1];
    return (h00 * (1 - tu) + h01 * tu) * (1 - tv) + (h10 * (1 - tu) + h11 * tu) * tv;
  }
  double minOver(const std::vector<Eigen::Vector2d>& pts) const {
    double m = 1e9;
    for (const auto& p : pts) m = std::min(m, at(p.x(), p.y()));
    return m;
  }
  double maxOver(const std::vector<Eigen::Vector2d>& pts) const {
    double m = -1e9;
    for (const auto& p : pts) m = std::max(m, at(p.x(), p.y()));
    return m;
  }
};

// the closest point of the path polyline to a point, its distance and the path heading there
struct PathQuery {
  double distance;
  double heading;
  Eigen::Vector2d nearest;
};

PathQuery queryPath(const std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& p) {
  PathQuery best{1e18, 0, path.front()};
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector2d a = path[i], ab = path[i + 1] - path[i];
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    const double d = (a + t * ab - p).norm();
    if (d < best.distance) best = {d, std::atan2(ab.y(), ab.x()), a + t * ab};
  }
  return best;
}

// footprint sample points used for terrain queries: corners, edge midpoints, centre
std::vector<Eigen::Vector2d> densify(const std::vector<Eigen::Vector2d>& poly) {
  std::vector<Eigen::Vector2d> pts = poly;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < poly.size(); ++i) {
    pts.push_back(0.5 * (poly[i] + poly[(i + 1) % poly.size()]));
    c += poly[i];
  }
  pts.push_back(c / static_cast<double>(poly.size()));
  return pts;
}

struct Disc {
  Eigen::Vector2d centre;
  double radius;
};

bool overlaps(const std::vector<Disc>& taken, const Disc& d) {
  for (const auto& t : taken) {
    if ((t.centre - d.centre).norm() < t.radius + d.radius) return true;
  }
  return false;
}

class SceneBuilder {
 public:
  SceneBuilder(const SceneConfig& cfg, const TypeRecipe& recipe)
      : cfg_(cfg), recipe_(recipe), rng_(hashKeys(cfg.seed, 7)) {}

  GeneratedScene build() {
    makePath();
    makeTerrain();
    placeBuildings();
    placeTrees();
    GeneratedScene out;
    out.truth = truth_;
    out.mjcf = mjcf();
    out.hfield_bytes = hfieldBytes();
    return out;
  }

 private:
  void makePath() {
    const double amp = recipe_.path_amplitude * rng_.uniform(0.5, 1.0);
    const double phase = rng_.uniform(0, 2 * kPi);
    const double x0 = -0.75 * cfg_.extent, x1 = 0.75 * cfg_.extent;
    const int n = 7;
    for (int i = 0; i < n; ++i) {
      const double x = x0 + (x1 - x0) * i / (n - 1);
      truth_.path.emplace_back(round3(x), round3(amp * std::sin(phase + x / 18.0)));
    }
  }

  void makeTerrain() {
    truth_.type = cfg_.type;
    truth_.seed = cfg_.seed;
    truth_.origin = cfg_.origin;
    truth_.extent = cfg_.extent;
    grid_.extent = cfg_.extent;
    if (!recipe_.heightfield) {
      truth_.terrain.kind = "plane";
      return;
    }
    const TerrainFunction f(recipe_, cfg_.seed, cfg_.extent);
    grid_.plane = false;
    grid_.n = static_cast<int>(std::lround(2 * cfg_.extent / cfg_.hfield_cell)) + 1;
    grid_.cell = 2 * cfg_.extent / (grid_.n - 1);
    grid_.height.resize(static_cast<std::size_t>(grid_.n) * grid_.n);
    for (int r = 0; r < grid_.n; ++r) {
      for (int c = 0; c < grid_.n; ++c) {
        grid_.height[r * grid_.n + c] = f(-cfg_.extent + c * grid_.cell, -cfg_.extent + r * grid_.cell);
      }
    }
    // MuJoCo normalises heightfield data to [0, 1]: store it normalised, and keep the grid's
    // heights equal to what MuJoCo will build (pos.z + size_z * sample)
    const auto [lo, hi] = std::minmax_element(grid_.height.begin(), grid_.height.end());
    const double zmin = round3(*lo), range = std::max(0.001, round3(*hi - zmin));
    TerrainTruth& t = truth_.terrain;
    t.kind = "hfield";
    t.nrow = t.ncol = grid_.n;
    t.pos = {0, 0, zmin};
    t.size = {cfg_.extent, cfg_.extent, range, 1.0};
    t.elevation.resize(grid_.height.size());
    for (std::size_t i = 0; i < grid_.height.size(); ++i) {
      const float e = static_cast<float>(std::clamp((grid_.height[i] - zmin) / range, 0.0, 1.0));
      t.elevation[i] = e;
      grid_.height[i] = zmin + range * static_cast<double>(e);
    }
  }

  // buildings line the path on both sides, a second row further back in towns
  void placeBuildings() {
    const double length = (truth_.path.back() - truth_.path.front()).norm();
    const int count = static_cast<int>(recipe_.buildings_per_100m * length / 100.0);
    int placed = 0;
    for (int attempt = 0; attempt < count * 30 && placed < count; ++attempt) {
      const bool back_row = recipe_.second_row && rng_.uniform() < 0.35;
      const double s = rng_.uniform(-0.95, 0.95) * cfg_.extent;
      const double side = rng_.uniform() < 0.5 ? -1.0 : 1.0;
      const double width = rng_.uniform(8, 22), depth = rng_.uniform(8, 18);
      const double height = rng_.uniform(6, 40);
      const double setback = (back_row ? rng_.uniform(30, 42) : rng_.uniform(8, 14)) + depth / 2;
      const PathQuery q = queryPath(truth_.path, {s, 0});
      const Eigen::Vector2d dir(std::cos(q.heading), std::sin(q.heading));
      const Eigen::Vector2d normal(-dir.y(), dir.x());
      const Eigen::Vector2d centre = q.nearest + side * setback * normal;
      const Disc disc{centre, 0.5 * std::hypot(width, depth) + 1.0};
      if (std::abs(centre.x()) + disc.radius > cfg_.extent || std::abs(centre.y()) + disc.radius > cfg_.extent)
        continue;
      // keep a street corridor of 6 m either side of the path
      if (queryPath(truth_.path, centre).distance < 0.5 * depth + 6.0) continue;
      if (overlaps(taken_, disc)) continue;
      taken_.push_back(disc);
      addBuilding(centre, q.heading, width, depth, height);
      ++placed;
    }
  }

  void addBuilding(const Eigen::Vector2d& c, double yaw, double width, double depth, double height) {
    ObjectTruth o;
    char id[32];
    std::snprintf(id, sizeof id, "building_%03d", building_count_++);
    o.id = id;
    o.object_class = GeomClass::Building;
    const Eigen::Vector2d ex(std::cos(yaw), std::sin(yaw)), ey(-std::sin(yaw), std::cos(yaw));
    for (const auto& [sx, sy] : {std::pair{1, 1}, {-1, 1}, {-1, -1}, {1, -1}}) {
      const Eigen::Vector2d p = c + sx * 0.5 * width * ex + sy * 0.5 * depth * ey;
      o.footprint.emplace_back(round3(p.x()), round3(p.y()));
    }
    const auto samples = densify(o.footprint);
    o.base_height = round3(grid_.minOver(samples));
    o.top_height = round3(grid_.maxOver(samples) + height);
    const double bottom = o.base_height - 0.5;  // sunk into the ground
    const std::string geom = o.id + "_body";
    o.geoms.push_back(geom);
    const int facade = facadeFor(o.id);
    std::ostringstream g;
    g << "    <geom name=\"" << geom << "\" type=\"box\" material=\"facade" << facade << "\" group=\"1\""
      << " pos=\"" << num(c.x()) << " " << num(c.y()) << " " << num(0.5 * (bottom + o.top_height)) << "\""
      << " size=\"" << num(0.5 * width) << " " << num(0.5 * depth) << " " << num(0.5 * (o.top_height - bottom)) << "\""
      << " euler=\"0 0 " << num(yaw * 180.0 / kPi) << "\"/>\n";
    object_geoms_ += g.str();
    truth_.objects.push_back(std::move(o));
  }

  int facadeFor(const std::string& id) const {
    return static_cast<int>(hashKeys(cfg_.seed, std::hash<std::string>{}(id)&0xffff) % 3) + 1;
  }

  // trees avoid the path corridor and the buildings; crowns take one of four shapes
  void placeTrees() {
    int placed = 0;
    for (int attempt = 0; attempt < recipe_.trees * 40 && placed < recipe_.trees; ++attempt) {
      const Eigen::Vector2d p(rng_.uniform(-0.95, 0.95) * cfg_.extent, rng_.uniform(-0.95, 0.95) * cfg_.extent);
      const double height = rng_.uniform(4, 25);
      const int shape = rng_.uniformInt(0, 3);
      double rx = 0, rz = 0;  // crown horizontal radius and vertical half extent
      switch (shape) {
        case 0:
          rx = rz = std::min(0.22 * height, 5.0);
          break;  // round
        case 1:
          rx = 0.16 * height;
          rz = 0.3 * height;
          break;  // tall ellipsoid
        case 2:
          rx = std::min(0.3 * height, 6.0);
          rz = 0.18 * height;
          break;  // wide ellipsoid
        default:
          rx = 0.11 * height;
          rz = 0.35 * height;
          break;  // conifer capsule
      }
      rx = std::max(rx, 0.8);
      const Disc disc{p, rx + 0.5};
      if (queryPath(truth_.path, p).distance < rx + 3.0) continue;
      if (overlaps(taken_, disc)) continue;
      taken_.push_back(disc);
      addTree(p, height, shape, rx, rz);
      ++placed;
    }
  }

  void addTree(const Eigen::Vector2d& p, double height, int shape, double rx, double rz) {
    ObjectTruth o;
    char id[32];
    std::snprintf(id, sizeof id, "tree_%03d", tree_count_++);
    o.id = id;
    o.object_class = GeomClass::Crown;
    for (int k = 0; k < 12; ++k) {
      const double a = 2 * kPi * k / 12;
      o.footprint.emplace_back(round3(p.x() + rx * std::cos(a)), round3(p.y() + rx * std::sin(a)));
    }
    const double ground = grid_.minOver({p, p + Eigen::Vector2d(0.3, 0), p - Eigen::Vector2d(0.3, 0),
                                         p + Eigen::Vector2d(0, 0.3), p - Eigen::Vector2d(0, 0.3)});
    o.base_height = round3(ground);
    o.top_height = round3(ground + height);
    const double crown_centre = o.top_height - rz;
    const double trunk_radius = 0.1 + 0.012 * height;
    const double trunk_bottom = o.base_height - 0.3, trunk_top = crown_centre;
    o.geoms = {o.id + "_trunk", o.id + "_crown"};
    std::ostringstream g;
    g << "    <geom name=\"" << o.geoms[0] << "\" type=\"cylinder\" material=\"bark\" group=\"2\""
      << " pos=\"" << num(p.x()) << " " << num(p.y()) << " " << num(0.5 * (trunk_bottom + trunk_top)) << "\""
      << " size=\"" << num(trunk_radius) << " " << num(0.5 * (trunk_top - trunk_bottom)) << "\"/>\n";
    g << "    <geom name=\"" << o.geoms[1] << "\" material=\"leaves\" group=\"2\""
      << " pos=\"" << num(p.x()) << " " << num(p.y()) << " " << num(crown_centre) << "\"";
    if (shape == 0) {
      g << " type=\"sphere\" size=\"" << num(rx) << "\"";
    } else if (shape == 3) {
      // capsule: radius rx, cylinder half length rz - rx, so its top is rz above the centre
      g << " type=\"capsule\" size=\"" << num(rx) << " " << num(std::max(0.01, rz - rx)) << "\"";
    } else {
      g << " type=\"ellipsoid\" size=\"" << num(rx) << " " << num(rx) << " " << num(rz) << "\"";
    }
    g << "/>\n";
    object_geoms_ += g.str();
    truth_.objects.push_back(std::move(o));
  }

  std::string mjcf() const {
    std::ostringstream x;
    const std::string name = cfg_.type + "_" + std::to_string(cfg_.seed);
    x << "<mujoco model=\"" << name << "\">\n"
      << "  <!-- generated by 'terrain scenes generate --type " << cfg_.type << " --seed " << cfg_.seed
      << "'; ground truth in the .truth.json sidecar -->\n"
      << "  <compiler angle=\"degree\"/>\n"
      << "  <statistic extent=\"100\" center=\"0 0 0\"/>\n"
      << "  <visual>\n"
      << "    <global offwidth=\"640\" offheight=\"480\"/>\n"
      << "    <quality offsamples=\"0\" shadowsize=\"0\"/>\n"
      << "    <map znear=\"0.002\" zfar=\"3\" haze=\"0.15\"/>\n"
      << "    <headlight ambient=\"0.35 0.35 0.35\" diffuse=\"0.4 0.4 0.4\" specular=\"0 0 0\"/>\n"
      << "    <rgba haze=\"0.8 0.87 0.95 1\"/>\n"
      << "  </visual>\n"
      << "  <asset>\n"
      << "    <texture name=\"sky\" type=\"skybox\" builtin=\"gradient\" rgb1=\"0.45 0.62 0.88\" rgb2=\"0.9 0.94 1\" "
         "width=\"256\" height=\"256\"/>\n"
      << "    <texture name=\"grass\" type=\"2d\" builtin=\"flat\" mark=\"random\" random=\"0.25\" rgb1=\"0.33 0.42 "
         "0.22\" markrgb=\"0.45 0.5 0.3\" width=\"256\" height=\"256\"/>\n"
      << "    <material name=\"ground\" texture=\"grass\" texrepeat=\"40 40\"/>\n"
      << "    <texture name=\"facade1\" type=\"cube\" builtin=\"checker\" rgb1=\"0.78 0.74 0.66\" rgb2=\"0.32 0.4 "
         "0.52\" width=\"64\" height=\"64\"/>\n"
      << "    <texture name=\"facade2\" type=\"cube\" builtin=\"checker\" rgb1=\"0.62 0.5 0.44\" rgb2=\"0.25 0.3 "
         "0.36\" width=\"64\" height=\"64\"/>\n"
      << "    <texture name=\"facade3\" type=\"cube\" builtin=\"checker\" rgb1=\"0.85 0.85 0.82\" rgb2=\"0.4 0.5 0.6\" "
         "width=\"64\" height=\"64\"/>\n"
      << "    <material name=\"facade1\" texture=\"facade1\" texrepeat=\"6 6\"/>\n"
      << "    <material name=\"facade2\" texture=\"facade2\" texrepeat=\"6 6\"/>\n"
      << "    <material name=\"facade3\" texture=\"facade3\" texrepeat=\"6 6\"/>\n"
      << "    <texture name=\"bark\" type=\"cube\" builtin=\"flat\" mark=\"random\" random=\"0.3\" rgb1=\"0.36 0.26 "
         "0.17\" rgb2=\"0.36 0.26 0.17\" markrgb=\"0.22 0.16 0.1\" width=\"32\" height=\"32\"/>\n"
      << "    <material name=\"bark\" texture=\"bark\"/>\n"
      << "    <texture name=\"leaves\" type=\"cube\" builtin=\"flat\" mark=\"random\" random=\"0.35\" rgb1=\"0.13 0.38 "
         "0.12\" rgb2=\"0.13 0.38 0.12\" markrgb=\"0.3 0.55 0.2\" width=\"64\" height=\"64\"/>\n"
      << "    <material name=\"leaves\" texture=\"leaves\"/>\n"
      << "    <material name=\"robot\" rgba=\"0.85 0.55 0.1 1\"/>\n";
    const TerrainTruth& t = truth_.terrain;
    if (t.kind == "hfield") {
      x << "    <hfield name=\"terrain\" file=\"" << hfieldFileName() << "\" size=\"" << num(t.size[0]) << " "
        << num(t.size[1]) << " " << num(t.size[2]) << " " << num(t.size[3]) << "\"/>\n";
    }
    x << "  </asset>\n"
      << "  <default>\n"
      << "    <geom contype=\"0\" conaffinity=\"0\"/>\n"
      << "  </default>\n"
      << "  <worldbody>\n"
      << "    <light name=\"sun\" directional=\"true\" castshadow=\"false\" pos=\"0 0 100\" dir=\"-0.3 -0.4 -1\" "
         "diffuse=\"0.7 0.7 0.7\"/>\n";
    if (t.kind == "hfield") {
      x << "    <geom name=\"" << t.geom
        << "\" type=\"hfield\" hfield=\"terrain\" material=\"ground\" group=\"0\" pos=\"" << num(t.pos.x()) << " "
        << num(t.pos.y()) << " " << num(t.pos.z()) << "\"/>\n";
    } else {
      x << "    <geom name=\"" << t.geom << "\" type=\"plane\" material=\"ground\" group=\"0\" size=\""
        << num(cfg_.extent) << " " << num(cfg_.extent) << " 1\"/>\n";
    }
    x << object_geoms_;
    // the robot is a kinematic (mocap) body: the simulator sets its pose; its geoms are in
    // group 3, which the camera does not draw and the lidar excludes
    const Eigen::Vector2d start = truth_.path.front();
    x << "    <body name=\"robot\" mocap=\"true\" pos=\"" << num(start.x()) << " " << num(start.y()) << " 0\">\n"
      << "      <geom name=\"robot_chassis\" type=\"box\" size=\"0.5 0.35 0.2\" pos=\"0 0 0.35\" material=\"robot\" "
         "group=\"3\"/>\n"
      << "      <geom name=\"robot_mast\" type=\"cylinder\" size=\"0.04 0.8\" pos=\"0 0 1\" material=\"robot\" "
         "group=\"3\"/>\n"
      << "      <camera name=\"robot_camera\" pos=\"0.1 0 1.6\" xyaxes=\"0 -1 0 0 0 1\" fovy=\"75\"/>\n"
      << "    </body>\n"
      << "  </worldbody>\n"
      << "</mujoco>\n";
    return x.str();
  }

  std::string hfieldFileName() const { return truth_.terrain.hfield_file; }

  std::string hfieldBytes() const {
    const TerrainTruth& t = truth_.terrain;
    if (t.kind != "hfield") return {};
    // MuJoCo's binary heightfield: int32 nrow, int32 ncol, float32 data (little-endian)
    std::string bytes(8 + 4 * t.elevation.size(), '\0');
    const std::int32_t dims[2] = {t.nrow, t.ncol};
    std::memcpy(bytes.data(), dims, sizeof dims);
    std::memcpy(bytes.data() + 8, t.elevation.data(), 4 * t.elevation.size());
    return bytes;
  }

 public:
  void setHfieldName(const std::string& n) { truth_.terrain.hfield_file = n; }

 private:
  SceneConfig cfg_;
  TypeRecipe recipe_;
  Random rng_;
  SceneTruth truth_;
  TerrainGrid grid_;
  std::vector<Disc> taken_;
  std::string object_geoms_;
  int building_count_ = 0, tree_count_ = 0;
};

}  // namespace

const std::vector<std::string>& sceneTypes() {
  static const std::vector<std::string> types{"flat", "slope", "rough", "urban", "forest", "mixed"};
  return types;
}

GeneratedScene generateScene(const SceneConfig& config) {
  const auto& types = sceneTypes();
  if (std::find(types.begin(), types.end(), config.type) == types.end()) {
    std::string list;
    for (const auto& t : types) list += (list.empty() ? "" : ", ") + t;
    throw io::InputError("unknown scene type '" + config.type + "' (allowed: " + list + ")");
  }
  if (!(config.extent >= 20.0 && config.extent <= 500.0)) {
    throw io::InputError("scene extent " + std::to_string(config.extent) + " m is outside [20, 500]");
  }
  if (!(config.hfield_cell >= 0.1 && config.hfield_cell <= 5.0)) {
    throw io::InputError("heightfield cell " + std::to_string(config.hfield_cell) + " m is outside [0.1, 5]");
  }
  SceneBuilder builder(config, recipeFor(config.type));
  builder.setHfieldName(config.type + "_" + std::to_string(config.seed) + ".hfield");
  return builder.build();
}

void writeScene(const GeneratedScene& scene, const fs::path& xml_path, bool overwrite) {
  // the heightfield is named after the scene file so that several scenes can share a folder
  GeneratedScene s = scene;
  const fs::path hfield_path = fs::path(xml_path).replace_extension(".hfield");
  if (s.truth.terrain.kind == "hfield") {
    const std::string old_name = s.truth.terrain.hfield_file;
    s.truth.terrain.hfield_file = hfield_path.filename().string();
    const std::string from = "file=\"" + old_name + "\"", to = "file=\"" + s.truth.terrain.hfield_file + "\"";
    s.mjcf.replace(s.mjcf.find(from), from.size(), to);
  }
  const fs::path truth_path = truthPathFor(xml_path);
  std::vector<fs::path> outputs{xml_path, truth_path};
  if (!s.hfield_bytes.empty()) outputs.push_back(hfield_path);
  if (!overwrite) {
    for (const auto& p : outputs) {
      if (fs::exists(p)) throw io::InputError(p.string() + ": already exists (pass --force to overwrite)");
    }
  }
  if (xml_path.has_parent_path()) fs::create_directories(xml_path.parent_path());
  if (!s.hfield_bytes.empty()) io::writeFileAtomic(hfield_path, s.hfield_bytes, true);
  io::writeFileAtomic(truth_path, truthToJson(s.truth), true);
  io::writeFileAtomic(xml_path, s.mjcf, true);
}

}  // namespace terrain::scenes
