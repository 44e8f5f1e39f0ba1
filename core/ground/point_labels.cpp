// Per-point ground labels of one scan from the labels of its voxels (ground_segmentation.hpp,
// labelScanPoints).

#include "core/ground_segmentation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace terrain {

namespace {

// A dense grid of columns over the map's horizontal extent, one float per column, in storage that
// outlives it (its memory reused from one scan to the next).
class ColumnGrid {
 public:
  ColumnGrid(const VoxelMap& map, float fill, std::vector<float>& storage)
      : x0_(map.lowestIndex().x() - 1),
        y0_(map.lowestIndex().y() - 1),
        nx_(std::int64_t(map.highestIndex().x()) - x0_ + 2),
        ny_(std::int64_t(map.highestIndex().y()) - y0_ + 2),
        cells_(storage) {
    cells_.assign(std::size_t(nx_ * ny_), fill);
  }
  // [0, size()) for a voxel index's column (with a margin of one column each way inside the grid)
  std::size_t at(const VoxelIndex& v) const { return std::size_t((v.y() - y0_) * nx_ + (v.x() - x0_)); }
  std::int64_t stride() const { return nx_; }
  float& operator[](std::size_t i) { return cells_[i]; }
  float operator[](std::size_t i) const { return cells_[i]; }

 private:
  std::int64_t x0_, y0_, nx_, ny_;
  std::vector<float>& cells_;
};

// sorts nine values in place by a 25-comparator network (branch-free: min and max)
void sortNine(std::array<float, 9>& a) {
  static constexpr std::uint8_t kPairs[25][2] = {{0, 1}, {3, 4}, {6, 7}, {1, 2}, {4, 5}, {7, 8}, {0, 1}, {3, 4}, {6, 7},
                                                 {0, 3}, {3, 6}, {0, 3}, {1, 4}, {4, 7}, {1, 4}, {2, 5}, {5, 8}, {2, 5},
                                                 {1, 3}, {5, 7}, {2, 6}, {4, 6}, {2, 4}, {2, 3}, {5, 6}};
  for (const auto& p : kPairs) {
    const float lo = std::min(a[p[0]], a[p[1]]), hi = std::max(a[p[0]], a[p[1]]);
    a[p[0]] = lo, a[p[1]] = hi;
  }
}

}  // namespace

std::int64_t scanColumnCount(const VoxelMap& map) {
  if (map.size() == 0) return 0;
  return (std::int64_t(map.highestIndex().x()) - map.lowestIndex().x() + 3) *
         (std::int64_t(map.highestIndex().y()) - map.lowestIndex().y() + 3);
}

std::vector<std::uint8_t> labelScanPoints(const VoxelMap& map, const std::vector<Point3>& points,
                                          const std::vector<std::uint32_t>& voxel_of,
                                          const std::vector<std::uint8_t>& voxel_ground,
                                          const GroundSegmentationConfig& config) {
  PointLabelBuffers buffers;
  std::vector<std::uint8_t> out;
  labelScanPoints(map, points, voxel_of, voxel_ground, config, buffers, out);
  return out;
}

void labelScanPoints(const VoxelMap& map, const std::vector<Point3>& points, const std::vector<std::uint32_t>& voxel_of,
                     const std::vector<std::uint8_t>& voxel_ground, const GroundSegmentationConfig& config,
                     PointLabelBuffers& buffers, std::vector<std::uint8_t>& out) {
  out.assign(points.size(), 0);
  const auto& voxels = map.voxels();
  // each point takes its voxel's label (0 for a point in none)
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 8192), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      if (voxel_of[i] != VoxelMap::kNoVoxel) out[i] = voxel_ground[voxel_of[i]];
  });
  if (config.point_rise <= 0 || map.size() == 0 || scanColumnCount(map) > kMaxScanColumns) return;

  // the lowest point of each column among those its ground voxels hold
  constexpr float kNone = std::numeric_limits<float>::infinity();
  ColumnGrid lowest(map, kNone, buffers.columns);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!out[i]) continue;
    float& low = lowest[lowest.at(voxels[voxel_of[i]].index)];
    low = std::min(low, static_cast<float>(points[i].z()));
  }

  // the ground's level at each voxel's column: the lower median of the lowest ground points of the
  // column and its eight neighbours (kNone: no ground there); and the highest a ground return may
  // stand there: point_rise above the level, plus what the ground rises across one column, from
  // the mean lowest of the columns on either side along x and along y (where both sides hold ground)
  const std::int64_t stride = lowest.stride();
  const float rise = static_cast<float>(config.point_rise), reach = static_cast<float>(config.point_reach);
  std::vector<float>& level = buffers.level;
  std::vector<float>& ceiling = buffers.ceiling;
  level.assign(voxels.size(), kNone);
  ceiling.assign(voxels.size(), kNone);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, voxels.size(), 4096), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const std::int64_t c = std::int64_t(lowest.at(voxels[v].index));
      // the nine sorted by a network (kNone, +inf, sorts last); n of them hold ground
      std::array<float, 9> a;
      int n = 0;
      for (int dy = -1, k = 0; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx, ++k) {
          a[k] = lowest[std::size_t(c + dy * stride + dx)];
          n += a[k] != kNone;
        }
      if (n == 0) continue;
      // the rise across a column along one axis: half the difference of the sides' means
      const auto across = [&](int k0, int k1, int k2, int j0, int j1, int j2) {
        float lo = 0, hi = 0;
        int nl = 0, nh = 0;
        for (const int k : {k0, k1, k2})
          if (a[k] != kNone) lo += a[k], ++nl;
        for (const int k : {j0, j1, j2})
          if (a[k] != kNone) hi += a[k], ++nh;
        return nl > 0 && nh > 0 ? 0.5f * std::abs(hi / nh - lo / nl) : 0.0f;
      };
      const float slope_rise = across(0, 3, 6, 2, 5, 8) + across(0, 1, 2, 6, 7, 8);
      sortNine(a);
      level[v] = a[(n - 1) / 2];
      ceiling[v] = level[v] + rise + slope_rise;
    }
  });

  // a point of a ground voxel above the ceiling stands on the ground; a point of a non-ground voxel
  // within point_reach of the level continues the ground beside it
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 8192), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      if (voxel_of[i] == VoxelMap::kNoVoxel) continue;
      const float m = level[voxel_of[i]];
      if (m == kNone) continue;
      const float z = static_cast<float>(points[i].z());
      out[i] = out[i] ? z <= ceiling[voxel_of[i]] : std::abs(z - m) <= reach;
    }
  });
}

}  // namespace terrain
