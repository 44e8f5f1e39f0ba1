#include "core/ground_segmentation.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>

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
  GroundHeight(const VoxelMap& map, const GroundSegmentationConfig& cfg) : cfg_(cfg), cell_(map.voxelSize()) {
    const auto& voxels = map.voxels();
    if (cfg.histogram == GroundSegmentationConfig::Histogram::Global || voxels.empty()) {
      std::vector<double> h;
      h.reserve(voxels.size());
      for (const auto& v : voxels) h.push_back(v.height);
      global_ = histogramPeak(h, cfg.bin_size);
      return;
    }
    // tiles of k x k columns on a dense grid over the map's extent
    k_ = std::max(1, static_cast<int>(std::lround(cfg.tile_size / cell_)));
    int x0 = voxels[0].index.x(), x1 = x0, y0 = voxels[0].index.y(), y1 = y0;
    for (const auto& v : voxels) {
      x0 = std::min(x0, v.index.x()), x1 = std::max(x1, v.index.x());
      y0 = std::min(y0, v.index.y()), y1 = std::max(y1, v.index.y());
    }
    tx0_ = floorDiv(x0, k_), ty0_ = floorDiv(y0, k_);
    nx_ = floorDiv(x1, k_) - tx0_ + 1, ny_ = floorDiv(y1, k_) - ty0_ + 1;
    const std::size_t tiles = static_cast<std::size_t>(nx_) * ny_;
    // voxel ids grouped by tile (counting sort)
    std::vector<std::uint32_t> start(tiles + 1, 0), ids(voxels.size());
    for (const auto& v : voxels) ++start[tileOf(v.index) + 1];
    for (std::size_t t = 0; t < tiles; ++t) start[t + 1] += start[t];
    {
      std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
      for (std::uint32_t i = 0; i < voxels.size(); ++i) ids[fill[tileOf(voxels[i].index)]++] = i;
    }
    // the lowest voxel of every column, per tile
    std::vector<std::vector<Point3>> lowest(tiles);
    tbb::parallel_for(std::size_t{0}, tiles, [&](std::size_t t) {
      if (start[t] == start[t + 1]) return;
      std::vector<float> low(static_cast<std::size_t>(k_) * k_, std::numeric_limits<float>::infinity());
      const int cx = (static_cast<int>(t % nx_) + tx0_) * k_, cy = (static_cast<int>(t / nx_) + ty0_) * k_;
      for (std::uint32_t j = start[t]; j < start[t + 1]; ++j) {
        const auto& v = voxels[ids[j]];
        float& l = low[static_cast<std::size_t>(v.index.y() - cy) * k_ + (v.index.x() - cx)];
        l = std::min(l, v.height);
      }
      for (int r = 0; r < k_; ++r) {
        for (int c = 0; c < k_; ++c) {
          const float l = low[static_cast<std::size_t>(r) * k_ + c];
          if (std::isfinite(l)) lowest[t].emplace_back((cx + c + 0.5) * cell_, (cy + r + 0.5) * cell_, l);
        }
      }
    });
    // per tile: a plane through the window's column minima, then the histogram of heights above it
    planes_.assign(tiles, Plane{});
    has_plane_.assign(tiles, 0);
    tbb::parallel_for(std::size_t{0}, tiles, [&](std::size_t t) {
      if (start[t] == start[t + 1]) return;
      const int tx = static_cast<int>(t % nx_), ty = static_cast<int>(t / nx_);
      std::vector<Point3> candidates;
      std::vector<double> residual;
      for (int pass = 0; pass < 2; ++pass) {
        for (int dy = -cfg.tile_radius; dy <= cfg.tile_radius; ++dy) {
          for (int dx = -cfg.tile_radius; dx <= cfg.tile_radius; ++dx) {
            const int ux = tx + dx, uy = ty + dy;
            if (ux < 0 || uy < 0 || ux >= nx_ || uy >= ny_) continue;
            const std::size_t u = static_cast<std::size_t>(uy) * nx_ + ux;
            if (pass == 0) {
              candidates.insert(candidates.end(), lowest[u].begin(), lowest[u].end());
              continue;
            }
            for (std::uint32_t j = start[u]; j < start[u + 1]; ++j) {
              const auto& v = voxels[ids[j]];
              residual.push_back(v.height - planes_[t].at((v.index.x() + 0.5) * cell_, (v.index.y() + 0.5) * cell_));
            }
          }
        }
        if (pass == 0) planes_[t] = fitPlane(std::move(candidates));
      }
      planes_[t].c += histogramPeak(residual, cfg.bin_size);
      has_plane_[t] = 1;
    });
  }

  double at(double x, double y) const {
    if (planes_.empty()) return global_;
    const int tx = floorDiv(static_cast<int>(std::floor(x / cell_)), k_) - tx0_;
    const int ty = floorDiv(static_cast<int>(std::floor(y / cell_)), k_) - ty0_;
    if (tx < 0 || ty < 0 || tx >= nx_ || ty >= ny_) return global_;
    const std::size_t t = static_cast<std::size_t>(ty) * nx_ + tx;
    return has_plane_[t] ? planes_[t].at(x, y) : global_;
  }
  int tiles() const {
    int n = 0;
    for (auto h : has_plane_) n += h;
    return planes_.empty() ? 1 : n;
  }

 private:
  struct Plane {
    double a = 0, b = 0, c = 0;  // z = a x + b y + c
    double at(double x, double y) const { return a * x + b * y + c; }
  };

  static int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
  std::size_t tileOf(const VoxelIndex& i) const {
    return static_cast<std::size_t>(floorDiv(i.y(), k_) - ty0_) * nx_ + (floorDiv(i.x(), k_) - tx0_);
  }

  // least squares (normal equations, centred) in rounds that drop points far from the plane
  static Plane fitPlane(std::vector<Point3> pts) {
    Plane plane;
    for (int round = 0; round < 3 && pts.size() >= 3; ++round) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const auto& p : pts) mean += p;
      mean /= static_cast<double>(pts.size());
      Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
      Eigen::Vector2d atb = Eigen::Vector2d::Zero();
      double zmin = std::numeric_limits<double>::infinity();
      for (const auto& p : pts) {
        const Eigen::Vector2d d(p.x() - mean.x(), p.y() - mean.y());
        ata += d * d.transpose();
        atb += d * (p.z() - mean.z());
        zmin = std::min(zmin, p.z());
      }
      Eigen::Vector2d ab = Eigen::Vector2d::Zero();
      if (std::abs(ata.determinant()) > 1e-9) ab = ata.ldlt().solve(atb);
      plane = {ab.x(), ab.y(), mean.z() - ab.x() * mean.x() - ab.y() * mean.y()};
      // a steeper plane than 35 degrees is not terrain: fall back to level
      if (std::hypot(plane.a, plane.b) > 0.7) plane = {0, 0, zmin};
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
  double cell_;
  double global_ = 0;
  int k_ = 1, tx0_ = 0, ty0_ = 0, nx_ = 0, ny_ = 0;
  std::vector<Plane> planes_;
  std::vector<std::uint8_t> has_plane_;
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
  // neighbours at L1 distance 1: look up +x, +y, +z of every voxel, each voxel writing its own
  // three slots, so the edge list does not depend on the thread count
  std::vector<std::int64_t> next(3 * n, -1);
  tbb::task_arena arena(cfg.threads > 0 ? cfg.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
      for (int axis = 0; axis < 3; ++axis) {
        VoxelIndex j = voxels[i].index;
        j[axis] += 1;
        next[3 * i + axis] = map.find(j);
      }
    });
  });
  p.edges.reserve(3 * n);
  for (std::uint32_t i = 0; i < n; ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      const std::int64_t k = next[3 * i + axis];
      if (k < 0) continue;
      const double w = cfg.beta + cfg.gamma * std::exp(-std::abs(voxels[i].height - voxels[k].height));
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
