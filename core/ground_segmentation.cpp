#include "core/ground_segmentation.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_map>

namespace terrain {

bool parseHistogram(const std::string& s, GroundSegmentationConfig::Histogram& out) {
  if (s == "global") return out = GroundSegmentationConfig::Histogram::Global, true;
  if (s == "local") return out = GroundSegmentationConfig::Histogram::Local, true;
  return false;
}

bool parseSolver(const std::string& s, GroundSegmentationConfig::Solver& out) {
  if (s == "icm") return out = GroundSegmentationConfig::Solver::Icm, true;
  if (s == "mincut") return out = GroundSegmentationConfig::Solver::MinCut, true;
  return false;
}

double histogramPeak(const std::vector<double>& heights, double bin_size) {
  if (heights.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto [lo, hi] = std::minmax_element(heights.begin(), heights.end());
  const double base = std::floor(*lo / bin_size) * bin_size;
  const int bins = static_cast<int>((*hi - base) / bin_size) + 1;
  std::vector<int> count(bins, 0);
  for (double h : heights) ++count[std::min(bins - 1, static_cast<int>((h - base) / bin_size))];
  // the lowest bin among equal peaks: ground lies under objects
  const int peak = static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
  double sum = 0;
  int n = 0;
  for (double h : heights) {
    const int b = std::min(bins - 1, static_cast<int>((h - base) / bin_size));
    if (std::abs(b - peak) <= 1) sum += h, ++n;
  }
  return sum / n;
}

double gmrfEnergy(const GmrfProblem& p, const std::vector<std::uint8_t>& ground) {
  double e = 0;
  for (std::size_t v = 0; v < ground.size(); ++v) e += ground[v] ? p.unary_ground[v] : p.unary_nonground[v];
  for (const auto& edge : p.edges) e += ground[edge.u] == ground[edge.v] ? -edge.weight : edge.weight;
  return e;
}

int solveIcm(const GmrfProblem& p, std::vector<std::uint8_t>& ground, int max_iterations, int threads) {
  const std::size_t n = ground.size();
  // adjacency in compressed rows
  std::vector<std::uint32_t> start(n + 1, 0);
  for (const auto& e : p.edges) ++start[e.u + 1], ++start[e.v + 1];
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<std::uint32_t> nbr(start[n]);
  std::vector<double> w(start[n]);
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (const auto& e : p.edges) {
    nbr[fill[e.u]] = e.v, w[fill[e.u]++] = e.weight;
    nbr[fill[e.v]] = e.u, w[fill[e.v]++] = e.weight;
  }
  std::vector<std::uint32_t> colour[2];
  for (std::uint32_t v = 0; v < n; ++v) colour[p.parity[v] & 1].push_back(v);
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  int sweeps = 0;
  for (; sweeps < max_iterations; ++sweeps) {
    bool changed = false;
    for (const auto& nodes : colour) {
      // nodes of one colour have no edges between them: update them all at once
      std::vector<std::uint8_t> flip(nodes.size(), 0);
      arena.execute([&] {
        tbb::parallel_for(std::size_t{0}, nodes.size(), [&](std::size_t k) {
          const std::uint32_t v = nodes[k];
          double cost_g = p.unary_ground[v], cost_n = p.unary_nonground[v];
          for (std::uint32_t j = start[v]; j < start[v + 1]; ++j) {
            const bool other_ground = ground[nbr[j]] != 0;
            cost_g += other_ground ? -w[j] : w[j];
            cost_n += other_ground ? w[j] : -w[j];
          }
          const std::uint8_t best = cost_g < cost_n ? 1 : (cost_n < cost_g ? 0 : ground[v]);
          flip[k] = best != ground[v];
        });
      });
      for (std::size_t k = 0; k < nodes.size(); ++k) {
        if (flip[k]) ground[nodes[k]] ^= 1, changed = true;
      }
    }
    if (!changed) break;
  }
  return sweeps;
}

namespace {

// h1 as a function of position, from one histogram or from tiles
class GroundHeight {
 public:
  GroundHeight(const VoxelMap& map, const GroundSegmentationConfig& cfg) : cfg_(cfg) {
    const auto& voxels = map.voxels();
    if (cfg.histogram == GroundSegmentationConfig::Histogram::Global) {
      std::vector<double> h;
      h.reserve(voxels.size());
      for (const auto& v : voxels) h.push_back(v.height);
      global_ = histogramPeak(h, cfg.bin_size);
      return;
    }
    // lowest voxel per column, and every voxel, grouped by tile
    const double cell = map.voxelSize();
    std::map<std::pair<int, int>, std::vector<std::uint32_t>> tiles;
    std::unordered_map<std::uint64_t, std::uint32_t> lowest;  // column -> voxel id
    for (std::uint32_t i = 0; i < voxels.size(); ++i) {
      const auto& v = voxels[i];
      const double x = (v.index.x() + 0.5) * cell, y = (v.index.y() + 0.5) * cell;
      tiles[tileOf(x, y)].push_back(i);
      const std::uint64_t col = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(v.index.x())) << 32) |
                                static_cast<std::uint32_t>(v.index.y());
      auto it = lowest.find(col);
      if (it == lowest.end() || voxels[it->second].height > v.height) lowest[col] = i;
    }
    std::map<std::pair<int, int>, std::vector<std::uint32_t>> lowest_by_tile;
    for (const auto& [col, id] : lowest) {
      const auto& v = voxels[id];
      lowest_by_tile[tileOf((v.index.x() + 0.5) * cell, (v.index.y() + 0.5) * cell)].push_back(id);
    }
    for (const auto& [tile, ids] : tiles) {
      // the tile's window: itself and its neighbours
      std::vector<Point3> ground_candidates;
      std::vector<std::uint32_t> window;
      for (int dx = -cfg.tile_radius; dx <= cfg.tile_radius; ++dx) {
        for (int dy = -cfg.tile_radius; dy <= cfg.tile_radius; ++dy) {
          const std::pair<int, int> t{tile.first + dx, tile.second + dy};
          if (auto it = lowest_by_tile.find(t); it != lowest_by_tile.end()) {
            for (auto id : it->second) {
              const auto& v = voxels[id];
              ground_candidates.emplace_back((v.index.x() + 0.5) * cell, (v.index.y() + 0.5) * cell, v.height);
            }
          }
          if (auto it = tiles.find(t); it != tiles.end()) window.insert(window.end(), it->second.begin(), it->second.end());
        }
      }
      Plane plane = fitPlane(ground_candidates);
      std::vector<double> residual;
      residual.reserve(window.size());
      for (auto id : window) {
        const auto& v = voxels[id];
        residual.push_back(v.height - plane.at((v.index.x() + 0.5) * cell, (v.index.y() + 0.5) * cell));
      }
      plane.c += histogramPeak(residual, cfg.bin_size);
      planes_[tile] = plane;
    }
  }

  double at(double x, double y) const {
    if (planes_.empty()) return global_;
    auto it = planes_.find(tileOf(x, y));
    return it == planes_.end() ? global_ : it->second.at(x, y);
  }
  int tiles() const { return planes_.empty() ? 1 : static_cast<int>(planes_.size()); }

 private:
  struct Plane {
    double a = 0, b = 0, c = 0;  // z = a x + b y + c
    double at(double x, double y) const { return a * x + b * y + c; }
  };

  std::pair<int, int> tileOf(double x, double y) const {
    return {static_cast<int>(std::floor(x / cfg_.tile_size)), static_cast<int>(std::floor(y / cfg_.tile_size))};
  }

  // least squares with two rounds that drop points far above the plane (objects) and far below
  static Plane fitPlane(std::vector<Point3> pts) {
    Plane plane;
    for (int round = 0; round < 3 && pts.size() >= 3; ++round) {
      Eigen::MatrixXd a(pts.size(), 3);
      Eigen::VectorXd b(pts.size());
      for (std::size_t i = 0; i < pts.size(); ++i) {
        a.row(i) << pts[i].x(), pts[i].y(), 1.0;
        b[i] = pts[i].z();
      }
      const Eigen::Vector3d s = a.colPivHouseholderQr().solve(b);
      plane = {s[0], s[1], s[2]};
      // a steeper plane than 35 degrees is not terrain: fall back to level
      if (std::hypot(plane.a, plane.b) > 0.7) plane = {0, 0, b.minCoeff()};
      std::vector<Point3> kept;
      for (const auto& p : pts) {
        if (std::abs(p.z() - plane.at(p.x(), p.y())) < 1.0 - 0.3 * round) kept.push_back(p);
      }
      if (kept.size() < 3) break;
      pts.swap(kept);
    }
    if (pts.size() < 3 && !pts.empty()) plane = {0, 0, pts.front().z()};
    return plane;
  }

  GroundSegmentationConfig cfg_;
  double global_ = 0;
  std::map<std::pair<int, int>, Plane> planes_;
};

}  // namespace

SegmentationResult segmentGround(VoxelMap& map, const GroundSegmentationConfig& cfg) {
  SegmentationResult out = segmentGroundLabels(map, cfg);
  auto& voxels = map.voxels();
  for (std::size_t i = 0; i < voxels.size(); ++i) voxels[i].label = out.refined[i] ? VoxelLabel::Ground : VoxelLabel::NonGround;
  return out;
}

SegmentationResult segmentGroundLabels(const VoxelMap& map, const GroundSegmentationConfig& cfg) {
  const auto& voxels = map.voxels();
  const std::size_t n = voxels.size();
  SegmentationResult out;
  out.rough.assign(n, 0);
  out.ground_height.assign(n, 0.0f);
  if (n == 0) return out;
  const GroundHeight h1(map, cfg);
  out.tiles = h1.tiles();
  const double cell = map.voxelSize();
  GmrfProblem p;
  p.unary_ground.resize(n);
  p.unary_nonground.resize(n);
  p.parity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& v = voxels[i];
    const double ground = h1.at((v.index.x() + 0.5) * cell, (v.index.y() + 0.5) * cell);
    out.ground_height[i] = static_cast<float>(ground);
    const double d = v.height - ground;
    const bool g1 = std::abs(d) <= cfg.delta;
    const bool in_range = std::abs(d) <= cfg.range_margin;
    out.rough[i] = g1;
    // Eq. 19 (rough class) + Eq. 20 (height range)
    p.unary_ground[i] = (g1 ? -cfg.alpha : cfg.alpha) + (in_range ? -cfg.alpha : cfg.alpha);
    p.unary_nonground[i] = (g1 ? cfg.alpha : -cfg.alpha) + (in_range ? cfg.alpha : -cfg.alpha);
    p.parity[i] = static_cast<std::uint8_t>((v.index.x() + v.index.y() + v.index.z()) & 1);
  }
  // neighbours at L1 distance 1: look up +x, +y, +z of every voxel
  for (std::uint32_t i = 0; i < n; ++i) {
    const auto& v = voxels[i];
    for (int axis = 0; axis < 3; ++axis) {
      VoxelIndex j = v.index;
      j[axis] += 1;
      const std::int64_t k = map.find(j);
      if (k < 0) continue;
      const double w = cfg.beta + cfg.gamma * std::exp(-std::abs(v.height - voxels[k].height));
      p.edges.push_back({i, static_cast<std::uint32_t>(k), w});
    }
  }
  out.refined = out.rough;
  out.energy_rough = gmrfEnergy(p, out.rough);
  if (cfg.solver == GroundSegmentationConfig::Solver::MinCut) {
    solveMinCut(p, out.refined);
  } else {
    out.iterations = solveIcm(p, out.refined, cfg.icm_iterations, cfg.threads);
  }
  out.energy_refined = gmrfEnergy(p, out.refined);
  return out;
}

}  // namespace terrain
