#include "sim/scene_checks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace terrain::sim {

namespace {

std::string metres(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v << " m";
  return s.str();
}

}  // namespace

double distanceToPolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
    const Eigen::Vector2d ab = b - a;
    const double t = ab.squaredNorm() > 0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
    best = std::min(best, (a + t * ab - p).norm());
  }
  return inside ? 0.0 : best;
}

SceneProblems checkScene(const World& world, const SimConfig& config) {
  SceneProblems out;
  const scenes::SceneTruth& truth = world.truth();
  const mjModel* m = world.model();
  // sky
  bool skybox = false;
  for (int t = 0; t < m->ntex; ++t) skybox = skybox || m->tex_type[t] == mjTEXTURE_SKYBOX;
  if (!skybox) {
    out.warnings.push_back(
        "the scene has no skybox texture: the sky renders black, and boundary estimation's sky test "
        "then finds no top (add <texture type=\"skybox\" builtin=\"gradient\" rgb1=\"0.45 0.62 0.88\" "
        "rgb2=\"0.9 0.94 1\" width=\"256\" height=\"256\"/> to its <asset>)");
  }
  // the path, every 0.5 m: terrain under it, and no object within a metre
  std::vector<Eigen::Vector2d> samples;
  for (std::size_t i = 0; i + 1 < truth.path.size(); ++i) {
    const Eigen::Vector2d a = truth.path[i], b = truth.path[i + 1];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.5)));
    for (int k = 0; k < n; ++k) samples.push_back(a + (b - a) * (static_cast<double>(k) / n));
  }
  if (!truth.path.empty()) samples.push_back(truth.path.back());
  int no_terrain = 0;
  for (const Eigen::Vector2d& p : samples) {
    if (!std::isfinite(world.terrainHeight(p.x(), p.y()))) {
      if (no_terrain++ == 0) {
        out.errors.push_back("no terrain under the path at (" + metres(p.x()) + ", " + metres(p.y()) +
                             "): the robot would have nothing to stand on");
      }
    }
  }
  const double half_track = kRobotHalfWidth + kPathClearance;
  for (const auto& o : truth.objects) {
    if (o.footprint.size() < 3) continue;
    double nearest = std::numeric_limits<double>::infinity();
    Eigen::Vector2d where = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& p : samples) {
      const double d = distanceToPolygon(o.footprint, p);
      if (d < nearest) nearest = d, where = p;
    }
    if (nearest < half_track) {
      out.warnings.push_back("the path passes " + (nearest == 0 ? std::string("through") : metres(nearest) + " from") +
                             " object '" + o.id + "' at (" + metres(where.x()) + ", " + metres(where.y()) +
                             "): the robot would touch it, and the lidar loses every return behind it; keep the path " +
                             metres(half_track) + " from every object");
    }
  }
  // something above the lidar's reach
  const double reach = config.robot.mast_height + config.lidar.height_cap;
  const bool tall = std::any_of(truth.objects.begin(), truth.objects.end(),
                                [&](const scenes::ObjectTruth& o) { return o.top_height - o.base_height > reach; });
  if (!truth.objects.empty() && !tall) {
    out.warnings.push_back("no object stands higher than the lidar's reach (" + metres(reach) +
                           " above its base: mast height and height cap): the lidar senses every top, there is "
                           "nothing for height recovery to do");
  }
  return out;
}

}  // namespace terrain::sim
