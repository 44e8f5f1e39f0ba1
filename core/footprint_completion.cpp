#include "core/footprint_completion.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>

namespace terrain {

namespace {

// A rectangle by its centre, unit axes and half-extents along them.
struct Rectangle {
  Eigen::Vector2d centre, u, v;
  double a = 0, b = 0;

  // position in the rectangle's frame
  Eigen::Vector2d local(const Eigen::Vector2d& p) const { return {(p - centre).dot(u), (p - centre).dot(v)}; }
  bool contains(const Eigen::Vector2d& p, double inset) const {
    const Eigen::Vector2d q = local(p);
    return std::abs(q.x()) < a - inset && std::abs(q.y()) < b - inset;
  }
  // no deeper inside than `tolerance` (a point outside counts as on the outline)
  bool onOutline(const Eigen::Vector2d& p, double tolerance) const {
    const Eigen::Vector2d q = local(p);
    return std::min(a - std::abs(q.x()), b - std::abs(q.y())) <= tolerance;
  }
  std::array<Eigen::Vector2d, 4> corners() const {
    return {centre - a * u - b * v, centre + a * u - b * v, centre + a * u + b * v, centre - a * u + b * v};
  }
  static Rectangle fromCorners(const std::array<Eigen::Vector2d, 4>& c) {
    Rectangle r;
    r.centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
    r.a = 0.5 * (c[1] - c[0]).norm(), r.b = 0.5 * (c[3] - c[0]).norm();
    r.u = (c[1] - c[0]).normalized(), r.v = (c[3] - c[0]).normalized();
    return r;
  }
};

Eigen::Vector2d centreOf(const CellIndex& c, double cell) { return {(c.x() + 0.5) * cell, (c.y() + 0.5) * cell}; }

// the cells whose centres lie in the axis-aligned box around a rectangle
template <typename F>
void forCellsAround(const Rectangle& r, double cell, F&& f) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& c : r.corners())
    x0 = std::min(x0, c.x()), x1 = std::max(x1, c.x()), y0 = std::min(y0, c.y()), y1 = std::max(y1, c.y());
  for (int cy = static_cast<int>(std::floor(y0 / cell)); cy <= static_cast<int>(std::floor(y1 / cell)); ++cy) {
    for (int cx = static_cast<int>(std::floor(x0 / cell)); cx <= static_cast<int>(std::floor(x1 / cell)); ++cx)
      f(CellIndex(cx, cy));
  }
}

// share of one side of the rectangle (from p to q) that has a cell of `object` within `tolerance`
double sideSupport(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const TerrainMesh& mesh,
                   const MeshObjects& objects, std::int32_t object, double cell, double tolerance) {
  const int samples = std::max(2, static_cast<int>(std::ceil((q - p).norm() / cell)) + 1);
  const int reach = static_cast<int>(std::ceil(tolerance / cell));
  int supported = 0;
  for (int i = 0; i < samples; ++i) {
    const Eigen::Vector2d s = p + (q - p) * (static_cast<double>(i) / (samples - 1));
    const int sx = static_cast<int>(std::floor(s.x() / cell)), sy = static_cast<int>(std::floor(s.y() / cell));
    bool found = false;
    for (int dy = -reach; dy <= reach && !found; ++dy) {
      for (int dx = -reach; dx <= reach && !found; ++dx) {
        const CellIndex c(sx + dx, sy + dy);
        const std::int64_t j = mesh.find(c);
        found = j >= 0 && objects.of[j] == object && (centreOf(c, cell) - s).norm() <= tolerance;
      }
    }
    supported += found;
  }
  return static_cast<double>(supported) / samples;
}

// share of the points within `tolerance` of the rectangle's outline
double outlineShare(const Rectangle& r, const std::vector<Eigen::Vector2d>& points, double tolerance) {
  std::size_t on = 0;
  for (const auto& p : points) on += r.onOutline(p, tolerance);
  return points.empty() ? 0.0 : static_cast<double>(on) / static_cast<double>(points.size());
}

Rectangle outlineRectangle(const std::vector<Eigen::Vector2d>& points, double cell, double tolerance) {
  // hull edge directions, relative to the first point for float precision
  const Eigen::Vector2d ref = points.front();
  std::vector<cv::Point2f> pts, hull;
  pts.reserve(points.size());
  for (const auto& p : points)
    pts.emplace_back(static_cast<float>(p.x() - ref.x()), static_cast<float>(p.y() - ref.y()));
  cv::convexHull(pts, hull);
  std::vector<double> angles{0.0};
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const cv::Point2f d = hull[(i + 1) % hull.size()] - hull[i];
    if (d.x != 0 || d.y != 0) angles.push_back(std::atan2(d.y, d.x));
  }
  Rectangle best;
  double best_share = -1, best_area = 0;
  for (double angle : angles) {
    Rectangle r;
    r.u = Eigen::Vector2d(std::cos(angle), std::sin(angle));
    r.v = Eigen::Vector2d(-r.u.y(), r.u.x());
    double s0 = 1e300, s1 = -1e300, t0 = 1e300, t1 = -1e300;
    for (const auto& p : points) {
      const double s = (p - ref).dot(r.u), t = (p - ref).dot(r.v);
      s0 = std::min(s0, s), s1 = std::max(s1, s), t0 = std::min(t0, t), t1 = std::max(t1, t);
    }
    r.centre = ref + 0.5 * (s0 + s1) * r.u + 0.5 * (t0 + t1) * r.v;
    r.a = 0.5 * (s1 - s0) + 0.5 * cell, r.b = 0.5 * (t1 - t0) + 0.5 * cell;
    const double share = outlineShare(r, points, tolerance), area = r.a * r.b;
    if (share > best_share || (share == best_share && area < best_area)) best = r, best_share = share, best_area = area;
  }
  return best;
}

}  // namespace

std::vector<Footprint> completeFootprints(const TerrainMesh& mesh, const VoxelMap& map, const FootprintConfig& cfg) {
  std::vector<Footprint> out;
  const auto& vertices = mesh.vertices();
  if (!cfg.enabled || vertices.empty()) return out;
  const double cell = map.voxelSize();
  const MeshObjects objects = findMeshObjects(mesh, map);
  std::vector<std::vector<std::uint32_t>> members(objects.count);
  for (std::uint32_t i = 0; i < vertices.size(); ++i) {
    if (objects.of[i] >= 0) members[objects.of[i]].push_back(i);
  }
  for (std::int32_t o = 0; o < objects.count; ++o) {
    const auto& ids = members[o];
    // the roof height: the median of the walls' own estimates
    std::vector<float> raised;
    for (std::uint32_t i : ids) {
      if (vertices[i].estimated()) raised.push_back(vertices[i].recovered_height);
    }
    if (static_cast<int>(raised.size()) < std::max(1, cfg.min_raised) ||
        static_cast<double>(raised.size()) < cfg.min_raised_share * static_cast<double>(ids.size())) {
      continue;
    }
    // the rectangle around the object's cells (grown by half a cell to their outer faces) that puts
    // most of them on its outline, among the orientations of the cells' convex hull edges; the
    // smallest-area one alone is ambiguous for an L of walls (flush with a leg or with the diagonal)
    std::vector<Eigen::Vector2d> centres;
    centres.reserve(ids.size());
    for (std::uint32_t i : ids) centres.push_back(centreOf(vertices[i].cell, cell));
    const Rectangle r = outlineRectangle(centres, cell, cfg.wall_tolerance);
    if (2 * std::min(r.a, r.b) < cfg.min_side) continue;
    // nearly all of the object's cells on the outline: walls, not a solid blob or a scatter
    const double band = std::max(cfg.wall_tolerance, std::min(cfg.wall_band, 0.5 * std::min(r.a, r.b)));
    if (outlineShare(r, centres, band) < cfg.min_wall_share) continue;
    // walls along two adjacent sides: a corner was seen
    const auto c = r.corners();
    std::array<double, 4> support{};
    for (int s = 0; s < 4; ++s)
      support[s] = sideSupport(c[s], c[(s + 1) % 4], mesh, objects, o, cell, cfg.wall_tolerance);
    bool corner = false;
    for (int s = 0; s < 4; ++s)
      corner |= support[s] >= cfg.min_side_support && support[(s + 1) % 4] >= cfg.min_side_support;
    if (!corner) continue;
    // nothing sensed inside: the lidar cannot see into a closed building
    std::size_t inside = 0, sensed = 0;
    forCellsAround(r, cell, [&](const CellIndex& ci) {
      if (!r.contains(centreOf(ci, cell), cfg.wall_tolerance)) return;
      ++inside;
      const std::int64_t j = mesh.find(ci);
      sensed += j >= 0 && objects.of[j] != o;
    });
    if (inside == 0 || static_cast<double>(sensed) > cfg.max_inside_share * static_cast<double>(inside)) continue;
    std::nth_element(raised.begin(), raised.begin() + raised.size() / 2, raised.end());
    Footprint f;
    f.corners = c;
    f.roof_height = raised[raised.size() / 2];
    f.object = o;
    f.wall_vertices = static_cast<int>(ids.size());
    f.raised_vertices = static_cast<int>(raised.size());
    out.push_back(f);
  }
  return out;
}

int roofWalls(TerrainMesh& mesh, const VoxelMap& map, const std::vector<Footprint>& footprints,
              const FootprintConfig& cfg) {
  if (footprints.empty()) return 0;
  const MeshObjects objects = findMeshObjects(mesh, map);
  std::vector<const Footprint*> of_object(objects.count, nullptr);
  for (const auto& f : footprints) {
    if (f.object >= 0 && f.object < objects.count) of_object[f.object] = &f;
  }
  int raised = 0;
  auto& vertices = mesh.vertices();
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    MeshVertex& m = vertices[i];
    if (objects.of[i] < 0 || !of_object[objects.of[i]] || m.estimated()) continue;
    // only the object's cells on the footprint's outline: the rest are not its walls
    const Footprint& f = *of_object[objects.of[i]];
    if (!Rectangle::fromCorners(f.corners).onOutline(centreOf(m.cell, map.voxelSize()), cfg.wall_tolerance)) continue;
    m.spread = true;
    m.recovered_height = f.roof_height;
    ++raised;
  }
  return raised;
}

std::vector<RoofCell> roofCells(const std::vector<Footprint>& footprints, const TerrainMesh& mesh, double cell) {
  std::map<std::pair<int, int>, float> roof;  // (y, x) -> height
  for (const auto& f : footprints) {
    const Rectangle r = Rectangle::fromCorners(f.corners);
    forCellsAround(r, cell, [&](const CellIndex& c) {
      if (!r.contains(centreOf(c, cell), 0.0) || mesh.find(c) >= 0) return;
      auto [it, added] = roof.emplace(std::make_pair(c.y(), c.x()), f.roof_height);
      if (!added) it->second = std::max(it->second, f.roof_height);
    });
  }
  std::vector<RoofCell> out;
  out.reserve(roof.size());
  for (const auto& [yx, h] : roof) out.push_back({CellIndex(yx.second, yx.first), h});
  return out;
}

}  // namespace terrain
