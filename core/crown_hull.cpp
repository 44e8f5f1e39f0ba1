#include "core/crown_hull.hpp"

#include "core/boundary_detection.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>

namespace terrain {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kAzimuthBins = 720;      // horizon bins around the camera
constexpr double kHorizonReuse = 1.0;  // [m] cameras this close share a horizon

int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a - 1) / b) - 1; }

int cellOf(double v, double cell) { return static_cast<int>(std::floor(v / cell)); }

}  // namespace

bool CrownHull::crown(const Votes& v, const CrownHullConfig& cfg) const {
  const double seen = static_cast<double>(v.foliage) + v.other + v.sky;
  return v.foliage >= cfg.min_views && v.foliage >= cfg.min_foliage_share * seen && v.sky <= cfg.max_sky_share * seen &&
         (v.hi - v.lo) * (kPi / 32768) >= cfg.min_parallax;
}

std::size_t CrownHull::crownVoxels(const CrownHullConfig& cfg) const {
  std::size_t n = 0;
  for (const Column& c : columns_)
    n += static_cast<std::size_t>(
        std::count_if(c.layers.begin(), c.layers.end(), [&](const Votes& v) { return crown(v, cfg); }));
  return n;
}

std::size_t CrownHull::carve(const TerrainMesh& mesh, const VoxelMap& map, const cv::Mat& rgb,
                             const CameraIntrinsics& k, const Pose& world_from_camera, const SkylineOwners& owners,
                             const CrownHullConfig& cfg, const CrownConfig& crown_cfg,
                             const BoundaryEstimationConfig& sky_cfg) {
  if (!cfg.enabled || rgb.empty() || rgb.type() != CV_8UC3 || mesh.vertices().empty()) return 0;
  const Point3 origin = world_from_camera.translation();
  const Eigen::Vector2d here = origin.head<2>();
  const int layers = std::max(1, static_cast<int>(std::ceil(cfg.max_height / cfg.layer)));

  // columns around the trunks near enough to be voted on
  const int ring = static_cast<int>(std::ceil(cfg.max_radius / cfg.cell));
  for (const Trunk& t : findTrunks(mesh, map, owners.objects(), crown_cfg.max_trunk_width)) {
    if ((t.centre - here).norm() > cfg.max_distance + cfg.max_radius) continue;
    const int tx = cellOf(t.centre.x(), cfg.cell), ty = cellOf(t.centre.y(), cfg.cell);
    if (seeded_.count(key(tx, ty))) continue;
    const double ground = groundAround(t, mesh, map);
    if (!standsAboveGround(t, ground, crown_cfg.min_trunk_height)) continue;
    seeded_.insert(key(tx, ty));
    const double base = std::isfinite(ground) ? std::min(ground, t.top) : t.top;
    const float bottom = static_cast<float>(std::floor(base / cfg.layer) * cfg.layer);
    for (int dy = -ring; dy <= ring; ++dy) {
      for (int dx = -ring; dx <= ring; ++dx) {
        const int x = tx + dx, y = ty + dy;
        const Eigen::Vector2d p((x + 0.5) * cfg.cell, (y + 0.5) * cfg.cell);
        if ((p - t.centre).norm() > cfg.max_radius) continue;
        const auto [it, added] = index_.emplace(key(x, y), static_cast<std::uint32_t>(columns_.size()));
        if (!added) continue;
        columns_.push_back({x, y, bottom, std::vector<Votes>(static_cast<std::size_t>(layers))});
        tiles_[key(floorDiv(x, kTile), floorDiv(y, kTile))].push_back(it->second);
      }
    }
  }
  if (columns_.empty()) return 0;

  // the horizon of the sensed ground around the camera: per azimuth bin the steepest rise
  // (height over distance) to a ground vertex, computed when a column in the bin is first voted on;
  // the cameras of one frame share it (they stand within kHorizonReuse of each other)
  const auto& vertices = mesh.vertices();
  const double vs = map.voxelSize();
  if (horizon_.empty() || horizon_mesh_ != vertices.size() || (origin - horizon_origin_).norm() > kHorizonReuse) {
    horizon_.assign(kAzimuthBins, std::numeric_limits<float>::quiet_NaN());
    horizon_origin_ = origin, horizon_mesh_ = vertices.size();
  }
  const auto horizonOf = [&](int bin) {
    float& h = horizon_[static_cast<std::size_t>(bin)];
    if (!std::isnan(h)) return h;
    const double a = (bin + 0.5) * 2 * kPi / kAzimuthBins;
    const Eigen::Vector2d dir(std::cos(a), std::sin(a));
    const Eigen::Vector2d from = horizon_origin_.head<2>();
    double best = -std::numeric_limits<double>::infinity();
    // finer near the camera, where a bump rises steeply
    for (double d = vs; d <= cfg.horizon_distance;
         d += d < 20 ? std::max(vs, 0.5 * cfg.cell) : std::max(vs, cfg.cell)) {
      const Eigen::Vector2d p = from + d * dir;
      const std::int64_t j = mesh.find(CellIndex(cellOf(p.x(), vs), cellOf(p.y(), vs)));
      if (j < 0 || map.voxels()[vertices[j].top_voxel].label != VoxelLabel::Ground) continue;
      best = std::max(best, (vertices[j].sensed_height - horizon_origin_.z()) / d);
    }
    return h = static_cast<float>(best);
  };

  const Pose camera_from_world = world_from_camera.inverse();
  const Vector3 up = camera_from_world.linear().col(2) * cfg.layer;  // one layer up, in the camera frame
  const auto column_u = [&](const Point3& p) { return k.fx * p.x() / p.z() + k.cx; };
  const double tile = cfg.cell * kTile;
  const int t0x = cellOf(here.x() - cfg.max_distance, tile), t1x = cellOf(here.x() + cfg.max_distance, tile);
  const int t0y = cellOf(here.y() - cfg.max_distance, tile), t1y = cellOf(here.y() + cfg.max_distance, tile);
  std::size_t voted = 0;
  for (int ty = t0y; ty <= t1y; ++ty) {
    for (int tx = t0x; tx <= t1x; ++tx) {
      const auto found = tiles_.find(key(tx, ty));
      if (found == tiles_.end()) continue;
      for (const std::uint32_t ci : found->second) {
        Column& col = columns_[ci];
        const Eigen::Vector2d p((col.x + 0.5) * cfg.cell, (col.y + 0.5) * cfg.cell);
        const Eigen::Vector2d off = p - here;
        const double dh = off.norm();
        if (dh > cfg.max_distance || dh < cfg.cell) continue;
        const int n = static_cast<int>(col.layers.size());
        const Point3 first = camera_from_world * Point3(p.x(), p.y(), col.bottom + 0.5 * cfg.layer);
        const Point3 last = first + (n - 1) * up;
        // the whole column behind the camera, or beside the image on one side
        if (first.z() <= 0.1 && last.z() <= 0.1) continue;
        if (first.z() > 0.1 && last.z() > 0.1) {
          const double u0 = column_u(first), u1 = column_u(last);
          if ((u0 < 0 && u1 < 0) || (u0 >= rgb.cols && u1 >= rgb.cols)) continue;
        }
        double azimuth = std::atan2(off.y(), off.x());
        if (azimuth < 0) azimuth += 2 * kPi;
        const int bin = std::min(kAzimuthBins - 1, static_cast<int>(azimuth / (2 * kPi) * kAzimuthBins));
        // a foliage vote needs the voxel's ray above the horizon, and above the level: a ray down
        // may meet ground beyond the sensed one (and the lidar sees what stands lower)
        const double rise = dh * (std::max(0.0f, horizonOf(bin)) + cfg.horizon_margin);
        // the camera's bearing from the column, in steps of pi / 32768
        const double back = azimuth > kPi ? azimuth - kPi : azimuth + kPi;  // (0, 2 pi]
        const auto bearing = static_cast<std::uint16_t>(std::lround(back * (32768 / kPi)) & 0xffff);
        for (int j = 0; j < n; ++j) {
          const Point3 q = first + j * up;
          if (!(q.z() > 0.1)) continue;
          const double u = column_u(q), v = k.fy * q.y() / q.z() + k.cy;
          if (!(u >= 0 && v >= 0 && u < rgb.cols && v < rgb.rows)) continue;
          const cv::Vec3b& px = rgb.at<cv::Vec3b>(static_cast<int>(v), static_cast<int>(u));
          Votes& votes = col.layers[static_cast<std::size_t>(j)];
          if (looksLikeSky(px, sky_cfg.sky_blue_margin, sky_cfg.sky_min_brightness)) {
            countUp(votes.sky);
          } else if (!looksLikeFoliage(px, crown_cfg.foliage_margin)) {
            countUp(votes.other);
          } else if (col.bottom + (j + 0.5) * cfg.layer - origin.z() > rise) {
            if (votes.foliage == 0) {
              votes.first = static_cast<std::int16_t>(bearing);
            } else {
              // the offset from the first bearing, wrapped to (-pi, pi]
              const auto d = static_cast<std::int16_t>(
                  static_cast<std::uint16_t>(bearing - static_cast<std::uint16_t>(votes.first)));
              votes.lo = std::min(votes.lo, d), votes.hi = std::max(votes.hi, d);
            }
            countUp(votes.foliage);
          } else {
            continue;  // foliage below the horizon: perhaps grass beyond
          }
          ++voted;
        }
      }
    }
  }
  return voted;
}

CrownHullConfig skyGuardHull(const CrownConfig& crown, const BoundaryEstimationConfig& estimation) {
  CrownHullConfig cfg;
  cfg.enabled = true;
  cfg.cell = cfg.layer = crown.guard_cell;
  // the caps' guard needs the air around each crown; the estimates' only the trunks' own columns
  cfg.max_radius = crown.sky_guard ? crown.max_radius : 0.5 * crown.max_grown_width + crown.guard_cell;
  cfg.max_distance = CrownSampler::ownersReach(crown, estimation);
  return cfg;
}

bool CrownHull::skyThrough(double x, double y, double lo, double hi, const CrownHullConfig& cfg) const {
  const auto it = index_.find(key(cellOf(x, cfg.cell), cellOf(y, cfg.cell)));
  if (it == index_.end()) return false;
  const Column& col = columns_[it->second];
  const int n = static_cast<int>(col.layers.size());
  // the layer holding lo, then every layer whose centre lies at or below hi, within the column
  const int first = std::max(0, static_cast<int>(std::floor((lo - col.bottom) / cfg.layer)));
  const int last = std::min(n - 1, std::max(first, static_cast<int>(std::floor((hi - col.bottom) / cfg.layer - 0.5))));
  if (first > last) return false;
  for (int j = first; j <= last; ++j) {
    const Votes& v = col.layers[static_cast<std::size_t>(j)];
    if (v.sky == 0 || v.foliage > v.sky) return false;
  }
  return true;
}

int lowerUnderSky(TerrainMesh& mesh, const VoxelMap& map, const CrownHull& hull, const CrownHullConfig& cfg,
                  const CrownConfig& crown) {
  if (hull.columns() == 0) return 0;
  // the trunks' vertices: a wall's edge shares a hull column with the air beside it
  const MeshObjects objects = findMeshObjects(mesh, map);
  std::vector<std::uint8_t> trunk(static_cast<std::size_t>(objects.count), 0);
  for (const Trunk& t : findTrunks(mesh, map, objects, std::max(crown.max_trunk_width, crown.max_grown_width)))
    trunk[static_cast<std::size_t>(t.object)] = 1;
  int lowered = 0;
  auto& vertices = mesh.vertices();
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    MeshVertex& m = vertices[i];
    const std::int32_t object = objects.of[i];
    if (!m.raised() || object < 0 || !trunk[static_cast<std::size_t>(object)]) continue;
    const Point3 c = map.centreOf(VoxelIndex(m.cell.x(), m.cell.y(), 0));
    const double floor = hull.skyFloor(c.x(), c.y(), m.recovered_height, cfg);
    if (m.recovered_height - floor > cfg.layer) {
      m.recovered_height = std::max(m.sensed_height, static_cast<float>(floor));
      ++lowered;
    }
  }
  return lowered;
}

double CrownHull::skyFloor(double x, double y, double from, const CrownHullConfig& cfg) const {
  const auto it = index_.find(key(cellOf(x, cfg.cell), cellOf(y, cfg.cell)));
  if (it == index_.end() || columns_[it->second].layers.empty()) return from;
  const Column& col = columns_[it->second];
  // a voxel whose centre two sky pixels' rays passed is free, whatever other rays met before it
  const auto sky = [&](int j) { return col.layers[static_cast<std::size_t>(j)].sky >= 2; };
  int j =
      std::min(static_cast<int>(col.layers.size()) - 1, static_cast<int>(std::floor((from - col.bottom) / cfg.layer)));
  // layers no image saw say nothing: the walk starts at the highest one seen
  const auto unseen = [&](int k) {
    const Votes& v = col.layers[static_cast<std::size_t>(k)];
    return v.sky == 0 && v.foliage == 0 && v.other == 0;
  };
  while (j >= 0 && unseen(j)) --j;
  if (j < 0 || !sky(j)) return from;
  while (j > 0 && sky(j - 1)) --j;
  return std::min(from, col.bottom + j * cfg.layer);
}

int CrownHull::apply(TerrainMesh& mesh, const VoxelMap& map, const CrownHullConfig& cfg,
                     const CrownConfig& crown_cfg) const {
  if (!cfg.enabled || columns_.empty() || mesh.vertices().empty()) return 0;
  const MeshObjects objects = findMeshObjects(mesh, map);
  auto& vertices = mesh.vertices();
  const double vs = map.voxelSize();
  int raised = 0;
  // a trunk the lidar saw grow into its crown's underside is still one up to max_grown_width
  const double width = std::max(crown_cfg.max_trunk_width, crown_cfg.max_grown_width);
  std::vector<Trunk> trunks;
  for (const Trunk& t : findTrunks(mesh, map, objects, width)) {
    if (standsAboveGround(t, groundAround(t, mesh, map), crown_cfg.min_trunk_height)) trunks.push_back(t);
  }
  // a cell belongs to the crown of its nearest trunk: where crowns touch, each keeps its own side
  std::unordered_map<std::int64_t, std::vector<std::size_t>> grid;  // trunks by max_radius cell
  for (std::size_t i = 0; i < trunks.size(); ++i) {
    grid[key(cellOf(trunks[i].centre.x(), cfg.max_radius), cellOf(trunks[i].centre.y(), cfg.max_radius))].push_back(i);
  }
  const auto nearest = [&](const Eigen::Vector2d& p) {
    const int gx = cellOf(p.x(), cfg.max_radius), gy = cellOf(p.y(), cfg.max_radius);
    std::size_t best = trunks.size();
    double best_d = std::numeric_limits<double>::infinity();
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const auto it = grid.find(key(gx + dx, gy + dy));
        if (it == grid.end()) continue;
        for (const std::size_t i : it->second) {
          const double d = (trunks[i].centre - p).squaredNorm();
          if (d < best_d || (d == best_d && i < best)) best = i, best_d = d;
        }
      }
    }
    return best;
  };
  for (std::size_t ti = 0; ti < trunks.size(); ++ti) {
    const Trunk& t = trunks[ti];
    const int tx = cellOf(t.centre.x(), cfg.cell), ty = cellOf(t.centre.y(), cfg.cell);
    // the crown voxels reached from the trunk, flooded from those over its cells up to the gap
    std::unordered_map<std::int64_t, float> top;  // per column reached: its highest crown voxel's top [m]
    std::unordered_set<std::int64_t> seen;        // voxels reached (column key, layer)
    std::deque<std::pair<std::uint32_t, int>> queue;
    const auto voxelKey = [](std::uint32_t c, int j) { return (static_cast<std::int64_t>(c) << 16) | j; };
    const auto visit = [&](std::uint32_t c, int j) {
      if (j < 0 || j >= static_cast<int>(columns_[c].layers.size())) return;
      if (!crown(columns_[c].layers[static_cast<std::size_t>(j)], cfg)) return;
      if (!seen.insert(voxelKey(c, j)).second) return;
      queue.emplace_back(c, j);
    };
    const int tr =
        std::max(1, static_cast<int>(std::ceil(0.5 * ((t.hi - t.lo).array() + 1).maxCoeff() * vs / cfg.cell)));
    for (int dy = -tr; dy <= tr; ++dy) {
      for (int dx = -tr; dx <= tr; ++dx) {
        const auto it = index_.find(key(tx + dx, ty + dy));
        if (it == index_.end()) continue;
        const Column& c = columns_[it->second];
        const int highest = static_cast<int>(std::floor((t.top + crown_cfg.max_trunk_gap - c.bottom) / cfg.layer));
        for (int j = 0; j <= std::min(highest, static_cast<int>(c.layers.size()) - 1); ++j) visit(it->second, j);
      }
    }
    while (!queue.empty()) {
      const auto [c, j] = queue.front();
      queue.pop_front();
      const Column& col = columns_[c];
      const float z = col.bottom + static_cast<float>((j + 1) * cfg.layer);
      float& best = top.try_emplace(key(col.x, col.y), z).first->second;
      best = std::max(best, z);
      visit(c, j - 1), visit(c, j + 1);
      for (const auto& [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const Eigen::Vector2d p((col.x + dx + 0.5) * cfg.cell, (col.y + dy + 0.5) * cfg.cell);
        if ((p - t.centre).norm() > cfg.max_radius) continue;
        const auto it = index_.find(key(col.x + dx, col.y + dy));
        if (it == index_.end()) continue;
        // the neighbour's layers are offset from this column's when another trunk made it
        const Column& other = columns_[it->second];
        const int jn = static_cast<int>(std::floor((col.bottom + (j + 0.5) * cfg.layer - other.bottom) / cfg.layer));
        visit(it->second, jn);
      }
    }
    if (top.empty()) continue;
    // the crown's radius: the median over eight sectors around the trunk of the crown's reach in
    // each. A foliage cone seen from too few places stays long along its rays and narrow across
    // them; a crown is about as wide every way
    std::array<double, 8> reach{};
    for (const auto& [k, z] : top) {
      const Eigen::Vector2d d =
          Eigen::Vector2d(((k >> 32) + 0.5) * cfg.cell, (static_cast<std::int32_t>(k & 0xffffffff) + 0.5) * cfg.cell) -
          t.centre;
      const int sector = std::min(7, static_cast<int>((std::atan2(d.y(), d.x()) + kPi) / (2 * kPi) * 8));
      reach[static_cast<std::size_t>(sector)] =
          std::max(reach[static_cast<std::size_t>(sector)], d.norm() + 0.5 * cfg.cell);
    }
    std::nth_element(reach.begin(), reach.begin() + 3, reach.end());
    const double radius = reach[3];
    if (radius <= 0) continue;
    // raise the ground vertices under the crown (and the trunk's own) to its top in their column
    const int mr = static_cast<int>(std::ceil(cfg.max_radius / vs)) + 1;
    const CellIndex c0(cellOf(t.centre.x(), vs), cellOf(t.centre.y(), vs));
    for (int dy = -mr; dy <= mr; ++dy) {
      for (int dx = -mr; dx <= mr; ++dx) {
        const std::int64_t j = mesh.find(c0 + CellIndex(dx, dy));
        if (j < 0 || (objects.of[j] >= 0 && objects.of[j] != t.object)) continue;
        MeshVertex& m = vertices[j];
        if (m.estimated()) continue;  // its own estimates stand
        const double x = (m.cell.x() + 0.5) * vs, y = (m.cell.y() + 0.5) * vs;
        if ((Eigen::Vector2d(x, y) - t.centre).norm() > radius) continue;
        const auto it = top.find(key(cellOf(x, cfg.cell), cellOf(y, cfg.cell)));
        if (it == top.end() || nearest(Eigen::Vector2d(x, y)) != ti) continue;
        raised += raiseUnderCrown(m, it->second);
      }
    }
  }
  return raised;
}

}  // namespace terrain
