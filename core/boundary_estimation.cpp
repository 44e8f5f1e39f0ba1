#include "core/boundary_estimation.hpp"

#include "core/camera_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace terrain {

namespace {

// mean colour of the few pixels above row `top` on the image of the vertical through px looks like
// daylight sky
bool skyAbove(const cv::Mat& rgb, const Verticals& verticals, const Pixel& px, int top,
              const BoundaryEstimationConfig& cfg) {
  int r = 0, g = 0, b = 0, n = 0;
  for (int row = top - 6; row <= top - 3; ++row) {
    const int u = static_cast<int>(std::floor(verticals.columnAt(px, row + 0.5)));
    if (row < 0 || u < 0 || u >= rgb.cols) continue;
    const auto& p = rgb.at<cv::Vec3b>(row, u);
    r += p[0], g += p[1], b += p[2], ++n;
  }
  if (n == 0) return false;
  const cv::Vec3b mean(static_cast<std::uint8_t>(r / n), static_cast<std::uint8_t>(g / n),
                       static_cast<std::uint8_t>(b / n));
  return looksLikeSky(mean, cfg.sky_blue_margin, cfg.sky_min_brightness);
}

// The topmost boundary pixel on the image of the vertical through each image position, found once
// per line of the pencil through the vertical's vanishing point: the lines are indexed by the column
// at which they cross a reference row (the image row farthest from the vanishing point).
class TopsAlongVerticals {
 public:
  TopsAlongVerticals(const cv::Mat& boundary, const Verticals& verticals) : verticals_(verticals) {
    if (boundary.empty() || boundary.type() != CV_8UC1) return;
    const double vanish = verticals.vanishingRow();
    ref_row_ = vanish < 0.5 * boundary.rows ? boundary.rows - 1 : 0;
    // the lines through the image's corners bound those through the image
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const double u : {0.0, double(boundary.cols)}) {
      for (const double v : {0.0, double(boundary.rows)}) {
        const double c = verticals.columnAt(Pixel(u, v), ref_row_ + 0.5);
        lo = std::min(lo, c), hi = std::max(hi, c);
      }
    }
    // a pencil fanning out from a vanishing point inside the image: too many lines to walk
    if (!(hi - lo <= 8.0 * boundary.cols)) return;
    first_ = static_cast<int>(std::floor(lo)) - 1;
    top_.assign(static_cast<std::size_t>(std::ceil(hi)) - first_ + 2, -1);
    for (std::size_t l = 0; l < top_.size(); ++l) {
      const Pixel at(first_ + static_cast<double>(l) + 0.5, ref_row_ + 0.5);
      for (int row = 0; row < boundary.rows; ++row) {
        const int u = static_cast<int>(std::floor(verticals.columnAt(at, row + 0.5)));
        if (u >= 0 && u < boundary.cols && boundary.at<std::uint8_t>(row, u)) {
          top_[l] = static_cast<std::int16_t>(row);
          break;
        }
      }
    }
  }
  bool empty() const { return top_.empty(); }
  // the topmost boundary row on the vertical through px; -1 if none
  int topAbove(const Pixel& px) const {
    const double l = std::floor(verticals_.columnAt(px, ref_row_ + 0.5)) - first_;
    return l >= 0 && l < static_cast<double>(top_.size()) ? top_[static_cast<std::size_t>(l)] : -1;
  }

 private:
  Verticals verticals_;
  int ref_row_ = 0, first_ = 0;
  std::vector<std::int16_t> top_;
};

bool nonGround(const MeshVertex& m, const VoxelMap& map) {
  return map.voxels()[m.top_voxel].label == VoxelLabel::NonGround;
}

// The cells whose centres may lie in a box [m], one cell generous on every side.
std::pair<CellIndex, CellIndex> cellsCovering(const Eigen::AlignedBox2d& box, double cell) {
  const auto index = [cell](double v, double shift) {
    const double i = std::floor(v / cell - 0.5) + shift;
    return static_cast<int>(std::clamp(i, -2.0e9, 2.0e9));
  };
  return {CellIndex(index(box.min().x(), 0), index(box.min().y(), 0)),
          CellIndex(index(box.max().x(), 1), index(box.max().y(), 1))};
}

// objects wider than this either way [m] carry no crown of their own (foliage_tops)
constexpr double kTrunkWidth = 1.5;

// [px] an object whose own pixels above its vertex end against the sky more than this below the
// topmost boundary on its vertical does not reach that boundary (the sky test reads 3 to 6 px above
// an edge)
constexpr int kEndBelowTop = 6;

// Per object of `objects` for the foliage tops: whether it shows foliage (at least half of its top
// voxels that the camera coloured), and whether it may own a crown's pixel (it shows foliage or is
// trunk-sized).
struct FoliageObjects {
  std::vector<char> leafy, may_own;
};
FoliageObjects foliageObjects(const MeshObjects& objects, const TerrainMesh& mesh, const VoxelMap& map, int margin) {
  const auto& vertices = mesh.vertices();
  const std::size_t n = static_cast<std::size_t>(objects.count);
  std::vector<int> coloured(n, 0), foliage(n, 0);
  std::vector<CellIndex> lo(n, CellIndex::Constant(std::numeric_limits<int>::max())),
      hi(n, CellIndex::Constant(std::numeric_limits<int>::min()));
  for (std::uint32_t j : objects.members) {
    const std::size_t o = static_cast<std::size_t>(objects.of[j]);
    const Voxel& top = map.voxels()[vertices[j].top_voxel];
    if (top.coloured) ++coloured[o], foliage[o] += looksLikeFoliage(cv::Vec3b(top.r, top.g, top.b), margin);
    lo[o] = lo[o].cwiseMin(vertices[j].cell), hi[o] = hi[o].cwiseMax(vertices[j].cell);
  }
  FoliageObjects out;
  out.leafy.resize(n), out.may_own.resize(n);
  for (std::size_t o = 0; o < n; ++o) {
    out.leafy[o] = coloured[o] > 0 && 2 * foliage[o] >= coloured[o];
    const CellIndex extent = hi[o] - lo[o] + CellIndex::Ones();
    out.may_own[o] = out.leafy[o] || extent.cast<double>().maxCoeff() * map.voxelSize() <= kTrunkWidth;
  }
  return out;
}

// The vertex's top voxel stands at least 1 m above the lowest voxel of its column within 8 m below
// it: the lidar saw the ground under it.
bool standsOverGround(const MeshVertex& m, const VoxelMap& map) {
  const Voxel& top = map.voxels()[m.top_voxel];
  const int first = static_cast<int>(std::floor(0.8 / map.voxelSize()));
  const int reach = static_cast<int>(std::ceil(8.0 / map.voxelSize()));
  for (int dz = std::max(1, first); dz <= reach; ++dz) {
    const std::int64_t q = map.find(VoxelIndex(top.index.x(), top.index.y(), top.index.z() - dz));
    if (q >= 0 && top.height - map.voxels()[static_cast<std::size_t>(q)].height >= 1.0f) return true;
  }
  return false;
}

}  // namespace

bool looksLikeSky(const cv::Vec3b& c, int blue_margin, int min_brightness) {
  const int r = c[0], g = c[1], b = c[2];
  return b >= r + blue_margin && b >= g && (r + g + b) / 3 >= min_brightness;
}

bool showsParallax(const std::vector<HeightEstimate>& estimates, double slope, double change, double min_gap,
                   double max_gap, double min_t) {
  if (!(slope > 0) || estimates.size() < kParallaxEstimates) return false;
  double md = 0, mh = 0, rise = 0;
  float lo = estimates.front().distance, hi = lo;
  for (const auto& e : estimates) {
    md += e.distance, mh += e.height, rise += e.height - e.camera_height;
    lo = std::min(lo, e.distance), hi = std::max(hi, e.distance);
  }
  const double n = static_cast<double>(estimates.size());
  md /= n, mh /= n, rise /= n;
  double sdd = 0, sdh = 0;
  for (const auto& e : estimates)
    sdd += (e.distance - md) * (e.distance - md), sdh += (e.distance - md) * (e.height - mh);
  if (!(sdd > 0) || !(rise > 0)) return false;
  const double b = sdh / sdd;
  if (!(std::abs(b) > slope && std::abs(b) * (hi - lo) > change)) return false;
  // the slope must stand out from the scatter about the line (pose noise on rough ground makes steep
  // slopes over a metre or two of driving): at least min_t standard errors
  double scatter = 0;
  for (const auto& e : estimates) {
    const double r = e.height - mh - b * (e.distance - md);
    scatter += r * r;
  }
  if (std::abs(b) < min_t * std::sqrt(scatter / (n - 2) / sdd)) return false;
  // the gap that would give this slope: behind the vertex g / (d + g) = b d / (h - c), in front of
  // it g / (d - g) = -b d / (h - c)
  const double e = std::abs(b) * md / rise;
  if (b > 0 && !(e < 1)) return false;
  const double gap = b > 0 ? e * md / (1 - e) : e * md / (1 + e);
  return gap >= min_gap && gap <= max_gap;
}

int holdBackYoungVertices(TerrainMesh& mesh, const VoxelMap& map, const BoundaryEstimationConfig& cfg) {
  if (!(cfg.parallax_slope > 0)) return 0;
  auto& vertices = mesh.vertices();
  const int ring = static_cast<int>(std::ceil(1.0 / map.voxelSize()));
  // decided from the neighbours as they stand, then applied: the order of the vertices does not matter
  std::vector<std::uint32_t> hold;
  for (std::uint32_t i = 0; i < vertices.size(); ++i) {
    const MeshVertex& m = vertices[i];
    if (!m.estimated() || m.estimates.size() >= kParallaxEstimates || !nonGround(m, map)) continue;
    int held = 0, stand = 0;
    for (int dy = -ring; dy <= ring; ++dy) {
      for (int dx = -ring; dx <= ring; ++dx) {
        const std::int64_t j = mesh.find(m.cell + CellIndex(dx, dy));
        if (j < 0 || vertices[j].estimates.size() < kParallaxEstimates || !nonGround(vertices[j], map)) continue;
        ++(vertices[j].parallax ? held : stand);
      }
    }
    if (held > stand) hold.push_back(i);
  }
  if (cfg.hold_young_crowns) {
    const MeshObjects objects = findMeshObjects(mesh, map);
    const FoliageObjects foliage = foliageObjects(objects, mesh, map, cfg.foliage_margin);
    for (std::uint32_t i : objects.members) {
      const MeshVertex& m = vertices[i];
      if (foliage.leafy[static_cast<std::size_t>(objects.of[i])] && m.estimated() &&
          m.estimates.size() < kParallaxEstimates)
        hold.push_back(i);
    }
  }
  // (a vertex in both lists is counted once)
  std::sort(hold.begin(), hold.end());
  hold.erase(std::unique(hold.begin(), hold.end()), hold.end());
  for (std::uint32_t i : hold) vertices[i].parallax = true;
  return static_cast<int>(hold.size());
}

MeshObjects findMeshObjects(const TerrainMesh& mesh, const VoxelMap& map, const Eigen::AlignedBox2d* region) {
  const auto& vertices = mesh.vertices();
  const double cell = map.voxelSize();
  MeshObjects out;
  out.of.assign(vertices.size(), -1);
  // the non-ground vertices an object may start from, in id order: the whole mesh's, or the region's
  // (the cell test first: it reads only the vertex, the label reads its voxel)
  std::vector<std::uint32_t> seeds;
  if (region) {
    const auto [lo, hi] = cellsCovering(*region, cell);
    mesh.forEachInCells(lo, hi, [&](std::uint32_t i, const CellIndex& c) {
      if (region->contains(Eigen::Vector2d((c.x() + 0.5) * cell, (c.y() + 0.5) * cell)) && nonGround(vertices[i], map))
        seeds.push_back(i);
    });
  } else {
    for (std::uint32_t i = 0; i < vertices.size(); ++i) {
      if (nonGround(vertices[i], map)) seeds.push_back(i);
    }
  }
  for (std::uint32_t i : seeds) {
    if (out.of[i] >= 0) continue;
    const std::int32_t id = out.count++;
    std::size_t q = out.members.size();
    out.members.push_back(i);
    out.of[i] = id;
    for (; q < out.members.size(); ++q) {
      const CellIndex c = vertices[out.members[q]].cell;
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          const std::int64_t j = mesh.find(c + CellIndex(dx, dy));
          if (j < 0 || out.of[j] >= 0 || !nonGround(vertices[j], map)) continue;
          out.of[j] = id;
          out.members.push_back(static_cast<std::uint32_t>(j));
        }
      }
    }
  }
  return out;
}

SkylineOwners::SkylineOwners(const TerrainMesh& mesh, const VoxelMap& map, const Eigen::Vector2d& centre, double reach,
                             double grid_size)
    : SkylineOwners(mesh, map,
                    Eigen::AlignedBox2d(centre - Eigen::Vector2d(reach, reach), centre + Eigen::Vector2d(reach, reach)),
                    grid_size) {}

SkylineOwners::SkylineOwners(const TerrainMesh& mesh, const VoxelMap& map, const Eigen::AlignedBox2d& area,
                             double grid_size)
    : size_(grid_size) {
  const auto& vertices = mesh.vertices();
  // at most 100 km across: a larger area is a caller's mistake, not a grid to allocate
  if (vertices.empty() || area.isEmpty() || !area.min().allFinite() || !area.max().allFinite() ||
      !(area.sizes().maxCoeff() <= 1e5) || !(grid_size > 0))
    return;
  // the grid cells that cover the area, aligned with the mesh's lowest corner
  const double cell = map.voxelSize();
  const CellIndex lo = mesh.cellBounds().first;
  const double ox = lo.x() * cell, oy = lo.y() * cell;
  x0_ = ox + std::floor((area.min().x() - ox) / size_) * size_;
  y0_ = oy + std::floor((area.min().y() - oy) / size_) * size_;
  nx_ = static_cast<int>(std::floor((area.max().x() - x0_) / size_)) + 1;
  ny_ = static_cast<int>(std::floor((area.max().y() - y0_) / size_)) + 1;
  const Eigen::AlignedBox2d grid(Eigen::Vector2d(x0_, y0_), Eigen::Vector2d(x0_ + nx_ * size_, y0_ + ny_ * size_));
  objects_ = findMeshObjects(mesh, map, &grid);
  refreshTops(mesh);
  // which object stands where
  cells_.assign(static_cast<std::size_t>(nx_) * ny_, kEmpty);
  for (std::uint32_t i : objects_.members) {
    const double x = (vertices[i].cell.x() + 0.5) * cell, y = (vertices[i].cell.y() + 0.5) * cell;
    if (x < x0_ || y < y0_ || x >= x0_ + nx_ * size_ || y >= y0_ + ny_ * size_) continue;
    std::int32_t& c = cells_[index(x, y)];
    c = (c == kEmpty || c == objects_.of[i]) ? objects_.of[i] : kMixed;
  }
}

void SkylineOwners::refreshTops(const TerrainMesh& mesh) {
  // each object's known top: its highest recovered height, unknown (+inf) before any estimate
  const auto& vertices = mesh.vertices();
  tops_.assign(objects_.count, -std::numeric_limits<double>::infinity());
  for (std::uint32_t j : objects_.members) {
    if (vertices[j].estimated()) {
      tops_[objects_.of[j]] = std::max(tops_[objects_.of[j]], static_cast<double>(vertices[j].recovered_height));
    }
  }
  for (double& top : tops_) {
    if (!std::isfinite(top)) top = std::numeric_limits<double>::infinity();
  }
}

std::size_t SkylineOwners::index(double x, double y) const {
  const int gx = std::min(nx_ - 1, static_cast<int>((x - x0_) / size_)),
            gy = std::min(ny_ - 1, static_cast<int>((y - y0_) / size_));
  return static_cast<std::size_t>(gy) * nx_ + gx;
}

bool SkylineOwners::otherMayOwn(const Point3& o, const Vector3& dir, double range, std::int32_t own,
                                const Eigen::Vector2d& centre, double radius, double margin,
                                const std::vector<char>* candidates) const {
  if (cells_.empty()) return false;
  const double h = dir.head<2>().norm();
  if (h < 1e-12) return false;
  const int steps = static_cast<int>(range / (0.5 * size_)) + 1;
  for (int i = 0; i <= steps; ++i) {
    const double t = range * i / steps / h;  // ray parameter: horizontal distance range * i / steps
    const Eigen::Vector2d p = o.head<2>() + t * dir.head<2>();
    if ((p - centre).squaredNorm() <= radius * radius) continue;
    if (p.x() < x0_ || p.y() < y0_ || p.x() >= x0_ + nx_ * size_ || p.y() >= y0_ + ny_ * size_) continue;
    const std::int32_t c = cells_[index(p.x(), p.y())];
    if (c == kEmpty || c == own || (candidates && c >= 0 && !(*candidates)[c])) continue;
    if (c == kMixed || !(tops_[c] < o.z() + t * dir.z() - margin)) return true;
  }
  return false;
}

BoundaryEstimationStats estimateBoundaries(TerrainMesh& mesh, const VoxelMap& map, const cv::Mat& boundary,
                                           const CameraIntrinsics& k, const Pose& world_from_camera,
                                           const BoundaryEstimationConfig& cfg, const cv::Mat& rgb,
                                           const SkylineOwners* given_owners) {
  BoundaryEstimationStats stats;
  // the object's top above a vertex: the topmost boundary pixel on the image of the vertical through
  // it, found once per line of the pencil
  const Verticals verticals(k, world_from_camera);
  const TopsAlongVerticals tops(boundary, verticals);
  if (tops.empty()) return stats;
  const Pose camera_from_world = world_from_camera.inverse();
  const Point3 centre = world_from_camera.translation();
  const double cell = map.voxelSize();
  const int cols = boundary.cols;
  const bool sky_test = cfg.require_sky_above && rgb.type() == CV_8UC3 && rgb.cols == cols;
  auto& vertices = mesh.vertices();
  if (vertices.empty() || !centre.allFinite() || !(cfg.max_distance >= 0)) return stats;
  // the objects in view: for the clear-line test and the foliage tops
  const bool foliage_tops = cfg.foliage_tops && rgb.type() == CV_8UC3 && rgb.cols == cols;
  std::optional<SkylineOwners> own_owners;
  const SkylineOwners* in_view = cfg.clear_line || foliage_tops ? given_owners : nullptr;
  // only the vertices in view can be estimated: the cells of the image's sector up to max_distance
  const Eigen::AlignedBox2d view = viewRegion(k, world_from_camera, cfg.max_distance);
  if ((cfg.clear_line || foliage_tops) && !in_view) in_view = &own_owners.emplace(mesh, map, view);
  const SkylineOwners* owners = cfg.clear_line ? in_view : nullptr;
  const FoliageObjects foliage =
      foliage_tops ? foliageObjects(in_view->objects(), mesh, map, cfg.foliage_margin) : FoliageObjects{};
  // the colour at `row` on the vertical through px; nullptr where it leaves the image's sides
  const auto colour_at = [&](const Pixel& px, int row) -> const cv::Vec3b* {
    const int u = static_cast<int>(std::floor(verticals.columnAt(px, row + 0.5)));
    return u >= 0 && u < rgb.cols ? &rgb.at<cv::Vec3b>(row, u) : nullptr;
  };
  const auto foliage_px = [&](const Pixel& px, int row) {
    const cv::Vec3b* c = colour_at(px, row);
    return c && looksLikeFoliage(*c, cfg.foliage_margin);
  };
  const auto sky_px = [&](const Pixel& px, int row) {
    const cv::Vec3b* c = colour_at(px, row);
    return c && looksLikeSky(*c, cfg.sky_blue_margin, cfg.sky_min_brightness);
  };
  const auto [lo, hi] = cellsCovering(view, cell);
  mesh.forEachInCells(lo, hi, [&](std::uint32_t i, const CellIndex& c) {
    // the distance first: it reads only the cell, the label reads the vertex's voxel
    const double x = (c.x() + 0.5) * cell, y = (c.y() + 0.5) * cell;
    const double distance = Eigen::Vector2d(x - centre.x(), y - centre.y()).norm();
    if (distance > cfg.max_distance) return;
    MeshVertex& m = vertices[i];
    if (!nonGround(m, map)) return;
    const Point3 world(x, y, m.sensed_height);
    const auto px = project(k, camera_from_world * world);
    if (!px) return;
    ++stats.projected;
    // the object's top: the topmost boundary pixel on the vertical above the vertex
    const int u = static_cast<int>(px->x()), v = static_cast<int>(px->y());
    if (u >= cols) return;
    int top = tops.topAbove(*px);
    // a crown the lidar saw part of: its top is where the foliage above the vertex ends
    const std::int32_t object = in_view ? in_view->objects().of[i] : -1;
    const bool by_foliage = foliage_tops && object >= 0 && v < rgb.rows && foliage.leafy[object] &&
                            foliage_px(*px, v) && standsOverGround(m, map);
    if (by_foliage) {
      top = v;
      while (top > 0 && foliage_px(*px, top - 1)) --top;
      if (top <= cfg.top_margin) return m.count(EstimateOutcome::CutOff);
    } else {
      if (top < 0 || top > v) return m.count(EstimateOutcome::NoTopBoundary);
      if (top <= cfg.top_margin) return m.count(EstimateOutcome::CutOff);
      if (sky_test && top < rgb.rows && !skyAbove(rgb, verticals, *px, top, cfg)) {
        ++stats.no_sky;
        return m.count(EstimateOutcome::NoSky);
      }
      // going up from the vertex's pixel (not sky), an edge to sky that passes the sky test well
      // below the topmost boundary is where the object ends: that boundary is something else's (a
      // crown overhanging the object or standing behind it)
      if (sky_test && v < rgb.rows && !sky_px(*px, v)) {
        int end = v;
        while (end - kEndBelowTop > top && !(sky_px(*px, end - 1) && skyAbove(rgb, verticals, *px, end, cfg))) --end;
        if (end - kEndBelowTop > top) {
          ++stats.ends_below;
          return m.count(EstimateOutcome::EndsBelow);
        }
      }
    }
    // the ray through the top pixel's row where the vertical through the vertex crosses it
    const Vector3 dir = world_from_camera.linear() * pixelRay(k, Pixel(verticals.columnAt(*px, top + 0.5), top + 0.5));
    const double h = heightAbove(centre, dir, x, y);
    if (!std::isfinite(h) || h <= m.sensed_height || h > m.sensed_height + cfg.max_height)
      return m.count(EstimateOutcome::Implausible);
    if (owners && owners->otherMayOwn(centre, dir, cfg.max_distance, object, Eigen::Vector2d(x, y), 1.0, 1.0,
                                      by_foliage ? &foliage.may_own : nullptr)) {
      ++stats.not_clear;
      return m.count(EstimateOutcome::NotClear);
    }
    m.count(EstimateOutcome::Estimated);
    stats.by_foliage += by_foliage;
    mesh.addEstimate(i, {static_cast<float>(h), static_cast<float>(distance), static_cast<float>(centre.z())},
                     cfg.max_estimates, cfg.fusion_quantile);
    m.parallax = showsParallax(m.estimates, cfg.parallax_slope, cfg.parallax_change, cfg.parallax_min_gap,
                               cfg.parallax_max_gap, cfg.parallax_min_t);
    ++stats.estimated;
  });
  return stats;
}

int spreadEstimates(TerrainMesh& mesh, const VoxelMap& map, const BoundaryEstimationConfig& cfg) {
  auto& vertices = mesh.vertices();
  for (auto& m : vertices) m.spread = false;
  const int max_hops = static_cast<int>(std::floor(cfg.spread_distance / map.voxelSize()));
  if (max_hops <= 0) return 0;
  // multi-source breadth-first walk; sources in id order, so ties go to the lower id
  std::vector<std::int64_t> source(vertices.size(), -1);
  std::vector<int> hops(vertices.size(), 0);
  std::vector<std::uint32_t> queue;
  for (std::uint32_t i = 0; i < vertices.size(); ++i) {
    if (vertices[i].estimated() && nonGround(vertices[i], map)) source[i] = i, queue.push_back(i);
  }
  int spread = 0;
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::uint32_t i = queue[q];
    if (hops[i] >= max_hops) continue;
    const CellIndex c = vertices[i].cell;
    for (const CellIndex& d : {CellIndex(1, 0), CellIndex(-1, 0), CellIndex(0, 1), CellIndex(0, -1)}) {
      const std::int64_t j = mesh.find(c + d);
      if (j < 0 || source[j] >= 0 || !nonGround(vertices[j], map)) continue;
      source[j] = source[i];
      hops[j] = hops[i] + 1;
      MeshVertex& m = vertices[j];
      m.spread = true;
      m.recovered_height = vertices[source[j]].recovered_height;
      ++spread;
      queue.push_back(static_cast<std::uint32_t>(j));
    }
  }
  return spread;
}

}  // namespace terrain
