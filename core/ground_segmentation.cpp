#include "core/ground_segmentation.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>

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

struct Plane {
  double a = 0, b = 0, c = 0;  // z = a x + b y + c
  double at(double x, double y) const { return a * x + b * y + c; }
};

int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// sums of a point set, relative to a reference point near it, for least squares in one pass
struct Moments {
  double n = 0, x = 0, y = 0, z = 0, xx = 0, xy = 0, yy = 0, xz = 0, yz = 0;
  double zmin = std::numeric_limits<double>::infinity();
  void add(const Point3& p, const Point3& ref) {
    const double dx = p.x() - ref.x(), dy = p.y() - ref.y(), dz = p.z() - ref.z();
    n += 1, x += dx, y += dy, z += dz, xx += dx * dx, xy += dx * dy, yy += dy * dy, xz += dx * dz, yz += dy * dz;
    zmin = std::min(zmin, p.z());
  }
  // the least-squares plane z = a x + b y + c (normal equations, centred); a steeper plane than
  // 35 degrees is not terrain: level at the lowest point instead
  Plane plane(const Point3& ref) const {
    const double mx = x / n, my = y / n, mz = z / n;
    Eigen::Matrix2d ata;
    ata << xx - n * mx * mx, xy - n * mx * my, xy - n * mx * my, yy - n * my * my;
    const Eigen::Vector2d atb(xz - n * mx * mz, yz - n * my * mz);
    Eigen::Vector2d ab = Eigen::Vector2d::Zero();
    if (std::abs(ata.determinant()) > 1e-9) ab = ata.ldlt().solve(atb);
    Plane p{ab.x(), ab.y(), ref.z() + mz - ab.x() * (ref.x() + mx) - ab.y() * (ref.y() + my)};
    if (std::hypot(p.a, p.b) > 0.7) p = {0, 0, zmin};
    return p;
  }
};

// least squares in three rounds, each fitted to the points the previous plane left within
// 1.0 m, then 0.7 m; one pass over the points per round. The points are the concatenation of
// `parts`, read in place.
Plane fitPlane(const std::vector<const std::vector<Point3>*>& parts) {
  std::size_t n = 0;
  const Point3* first = nullptr;
  for (const auto* part : parts) {
    if (!first && !part->empty()) first = &part->front();
    n += part->size();
  }
  if (n < 3) return n == 0 ? Plane{} : Plane{0, 0, first->z()};
  const Point3 ref = *first;
  Moments all;
  for (const auto* part : parts) {
    for (const auto& p : *part) all.add(p, ref);
  }
  const Plane plane0 = all.plane(ref);
  Moments near1;
  for (const auto* part : parts) {
    for (const auto& p : *part) {
      if (std::abs(p.z() - plane0.at(p.x(), p.y())) < 1.0) near1.add(p, ref);
    }
  }
  if (near1.n < 3) return plane0;
  const Plane plane1 = near1.plane(ref);
  Moments near2;
  for (const auto* part : parts) {
    for (const auto& p : *part) {
      if (std::abs(p.z() - plane0.at(p.x(), p.y())) < 1.0 && std::abs(p.z() - plane1.at(p.x(), p.y())) < 0.7) near2.add(p, ref);
    }
  }
  if (near2.n < 3) return plane1;
  return near2.plane(ref);
}

// The plane-fit candidates of a tile of k x k columns whose first column is (cx, cy) and whose voxels
// are ids[0..n): the lowest voxel of every column, and of those the lowest of every 2 x 2 block of
// columns, at its column's centre. A quarter of the columns fix a plane as well as all of them.
// The whole-map and the incremental segmentation both take a tile's candidates from here.
void tileCandidates(const std::vector<Voxel>& voxels, const std::uint32_t* ids, std::size_t n, int k, int cx, int cy,
                    double cell, std::vector<Point3>& out) {
  std::vector<float> low(static_cast<std::size_t>(k) * k, std::numeric_limits<float>::infinity());
  for (std::size_t j = 0; j < n; ++j) {
    const auto& v = voxels[ids[j]];
    float& l = low[static_cast<std::size_t>(v.index.y() - cy) * k + (v.index.x() - cx)];
    l = std::min(l, v.height);
  }
  out.clear();
  for (int r = 0; r < k; r += 2) {
    for (int c = 0; c < k; c += 2) {
      float best = std::numeric_limits<float>::infinity();
      int br = 0, bc = 0;
      for (int dr = 0; dr < 2 && r + dr < k; ++dr) {
        for (int dc = 0; dc < 2 && c + dc < k; ++dc) {
          const float l = low[static_cast<std::size_t>(r + dr) * k + c + dc];
          if (l < best) best = l, br = r + dr, bc = c + dc;
        }
      }
      if (std::isfinite(best)) out.emplace_back((cx + bc + 0.5) * cell, (cy + br + 0.5) * cell, best);
    }
  }
}

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
    // positions and heights in tile order, so that the window passes below read memory in order
    std::vector<double> px(voxels.size()), py(voxels.size());
    std::vector<float> ph(voxels.size());
    tbb::parallel_for(std::size_t{0}, voxels.size(), [&](std::size_t j) {
      const auto& v = voxels[ids[j]];
      px[j] = (v.index.x() + 0.5) * cell_, py[j] = (v.index.y() + 0.5) * cell_, ph[j] = v.height;
    });
    // the plane-fit candidates of every tile
    std::vector<std::vector<Point3>> lowest(tiles);
    tbb::parallel_for(std::size_t{0}, tiles, [&](std::size_t t) {
      if (start[t] == start[t + 1]) return;
      const int cx = (static_cast<int>(t % nx_) + tx0_) * k_, cy = (static_cast<int>(t / nx_) + ty0_) * k_;
      tileCandidates(voxels, ids.data() + start[t], start[t + 1] - start[t], k_, cx, cy, cell_, lowest[t]);
    });
    // per tile: a plane through the window's plane-fit candidates, then the histogram of heights above it
    planes_.assign(tiles, Plane{});
    has_plane_.assign(tiles, 0);
    tbb::parallel_for(std::size_t{0}, tiles, [&](std::size_t t) {
      if (start[t] == start[t + 1]) return;
      const int tx = static_cast<int>(t % nx_), ty = static_cast<int>(t / nx_);
      std::vector<const std::vector<Point3>*> candidates;
      std::vector<double> residual;
      std::size_t window = 0;
      for (int dy = -cfg.tile_radius; dy <= cfg.tile_radius; ++dy) {
        for (int dx = -cfg.tile_radius; dx <= cfg.tile_radius; ++dx) {
          const int ux = tx + dx, uy = ty + dy;
          if (ux >= 0 && uy >= 0 && ux < nx_ && uy < ny_)
            window +=
                start[static_cast<std::size_t>(uy) * nx_ + ux + 1] - start[static_cast<std::size_t>(uy) * nx_ + ux];
        }
      }
      residual.reserve(window);
      for (int pass = 0; pass < 2; ++pass) {
        for (int dy = -cfg.tile_radius; dy <= cfg.tile_radius; ++dy) {
          for (int dx = -cfg.tile_radius; dx <= cfg.tile_radius; ++dx) {
            const int ux = tx + dx, uy = ty + dy;
            if (ux < 0 || uy < 0 || ux >= nx_ || uy >= ny_) continue;
            const std::size_t u = static_cast<std::size_t>(uy) * nx_ + ux;
            if (pass == 0) {
              candidates.push_back(&lowest[u]);
              continue;
            }
            const Plane& plane = planes_[t];
            for (std::uint32_t j = start[u]; j < start[u + 1]; ++j) residual.push_back(ph[j] - plane.at(px[j], py[j]));
          }
        }
        if (pass == 0) planes_[t] = fitPlane(candidates);
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
  std::size_t tileOf(const VoxelIndex& i) const {
    return static_cast<std::size_t>(floorDiv(i.y(), k_) - ty0_) * nx_ + (floorDiv(i.x(), k_) - tx0_);
  }

  GroundSegmentationConfig cfg_;
  double cell_;
  double global_ = 0;
  int k_ = 1, tx0_ = 0, ty0_ = 0, nx_ = 0, ny_ = 0;
  std::vector<Plane> planes_;
  std::vector<std::uint8_t> has_plane_;
};

// Eqs. 19-20 for voxel i of a problem, from its height above the ground height h1: the rough
// class (true: G1) and the single-site terms
bool setUnary(GmrfProblem& p, std::size_t i, const Voxel& v, double ground, const GroundSegmentationConfig& cfg) {
  const double d = v.height - ground;
  const bool g1 = std::abs(d) <= cfg.delta;
  const bool in_range = std::abs(d) <= cfg.range_margin;
  p.unary_ground[i] = (g1 ? -cfg.alpha : cfg.alpha) + (in_range ? -cfg.alpha : cfg.alpha);
  p.unary_nonground[i] = (g1 ? cfg.alpha : -cfg.alpha) + (in_range ? cfg.alpha : -cfg.alpha);
  p.parity[i] = static_cast<std::uint8_t>((v.index.x() + v.index.y() + v.index.z()) & 1);
  return g1;
}

// the pair-site weight of two neighbouring voxels of heights a and b (Eqs. 21-22)
double pairWeight(const GroundSegmentationConfig& cfg, float a, float b) {
  return cfg.beta + cfg.gamma * std::exp(-std::abs(a - b));
}

// The voxel ids of the map ordered by column (in blocks of 32 x 32 columns) and height, for
// finding the neighbours of every voxel with short, mostly cache-resident scans instead of one
// hash-table probe per neighbour.
class ColumnIndex {
 public:
  explicit ColumnIndex(const std::vector<Voxel>& voxels) {
    const std::size_t n = voxels.size();
    // number the non-empty blocks as they are first met
    block_.resize(n);
    std::uint64_t last_key = ~std::uint64_t{0};
    std::uint32_t last_block = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint64_t k = blockKey(voxels[i].index.x() >> kShift, voxels[i].index.y() >> kShift);
      if (k != last_key) {
        last_key = k;
        last_block = blocks_.try_emplace(k, static_cast<std::uint32_t>(blocks_.size())).first->second;
      }
      block_[i] = last_block;
    }
    // ids by (block, column), then by z inside each column
    const std::size_t cells = blocks_.size() * kColumns;
    start_.assign(cells + 1, 0);
    for (std::size_t i = 0; i < n; ++i) ++start_[slot(i, voxels) + 1];
    for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
    order_.resize(n);
    {
      std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
      for (std::uint32_t i = 0; i < n; ++i) order_[fill[slot(i, voxels)]++] = i;
    }
    z_.resize(n);
    tbb::parallel_for(std::size_t{0}, cells, [&](std::size_t c) {
      const auto b = order_.begin() + start_[c], e = order_.begin() + start_[c + 1];
      if (e - b > 1)
        std::sort(b, e, [&](std::uint32_t a, std::uint32_t d) { return voxels[a].index.z() < voxels[d].index.z(); });
      for (auto k = start_[c]; k < start_[c + 1]; ++k) z_[k] = voxels[order_[k]].index.z();
    });
  }

  // id of the voxel at (x, y, z), or -1; block: the block number of (x, y) if the caller knows it
  std::int64_t find(int x, int y, int z, std::int64_t block = -1) const {
    if (block < 0) {
      const auto it = blocks_.find(blockKey(x >> kShift, y >> kShift));
      if (it == blocks_.end()) return -1;
      block = it->second;
    }
    const std::size_t c = static_cast<std::size_t>(block) * kColumns + local(x, y);
    for (auto k = start_[c]; k < start_[c + 1] && z_[k] <= z; ++k) {
      if (z_[k] == z) return order_[k];
    }
    return -1;
  }
  // the neighbours at +x, +y, +z of every voxel (-1: none), three per voxel id
  std::vector<std::int64_t> forwardNeighbours(const std::vector<Voxel>& voxels, int threads) const {
    std::vector<std::int64_t> next(3 * voxels.size(), -1);
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
      tbb::parallel_for(std::size_t{0}, start_.size() - 1, [&](std::size_t c) {
        for (auto k = start_[c]; k < start_[c + 1]; ++k) {
          const std::uint32_t i = order_[k];
          const VoxelIndex& v = voxels[i].index;
          // +z: the next voxel of the column, if it is right above
          if (k + 1 < start_[c + 1] && z_[k + 1] == v.z() + 1) next[3 * i + 2] = order_[k + 1];
          // +x, +y: in the same block unless the column is on its edge
          constexpr int edge = (1 << kShift) - 1;
          const std::int64_t b = block_[i];
          next[3 * i + 0] = find(v.x() + 1, v.y(), v.z(), (v.x() & edge) != edge ? b : -1);
          next[3 * i + 1] = find(v.x(), v.y() + 1, v.z(), (v.y() & edge) != edge ? b : -1);
        }
      });
    });
    return next;
  }

 private:
  static constexpr int kShift = 5;  // blocks of 32 x 32 columns
  static constexpr std::size_t kColumns = 1u << (2 * kShift);
  static std::uint64_t blockKey(int bx, int by) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(bx)) << 32) | static_cast<std::uint32_t>(by);
  }
  static std::size_t local(int x, int y) {
    constexpr int mask = (1 << kShift) - 1;
    return static_cast<std::size_t>((y & mask) << kShift | (x & mask));
  }
  std::size_t slot(std::size_t i, const std::vector<Voxel>& voxels) const {
    return static_cast<std::size_t>(block_[i]) * kColumns + local(voxels[i].index.x(), voxels[i].index.y());
  }

  std::unordered_map<std::uint64_t, std::uint32_t> blocks_;
  std::vector<std::uint32_t> block_;  // per voxel id
  std::vector<std::uint32_t> start_;  // per (block, column): first position in order_
  std::vector<std::uint32_t> order_;  // voxel ids by block, column, z
  std::vector<std::int32_t> z_;       // z of order_[k]
};

// the pair terms between neighbours at L1 distance 1 (+x, +y, +z of every voxel), in voxel order:
// each voxel's slots found by a prefix sum, then filled in parallel, so the edge list does not
// depend on the thread count
void addPairTerms(GmrfProblem& p, const std::vector<Voxel>& voxels, const GroundSegmentationConfig& cfg,
                  tbb::task_arena& arena) {
  const std::size_t n = voxels.size();
  const std::vector<std::int64_t> next = ColumnIndex(voxels).forwardNeighbours(voxels, cfg.threads);
  std::vector<std::uint32_t> first(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    first[i + 1] = first[i] + (next[3 * i] >= 0) + (next[3 * i + 1] >= 0) + (next[3 * i + 2] >= 0);
  }
  p.edges.resize(first[n]);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
      std::uint32_t e = first[i];
      for (int axis = 0; axis < 3; ++axis) {
        const std::int64_t k = next[3 * i + axis];
        if (k < 0) continue;
        p.edges[e++] = {static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(k),
                        pairWeight(cfg, voxels[i].height, voxels[k].height)};
      }
    });
  });
}

}  // namespace

SegmentationResult segmentGround(VoxelMap& map, const GroundSegmentationConfig& cfg) {
  SegmentationResult out = segmentGroundLabels(map, cfg);
  auto& voxels = map.voxels();
  for (std::size_t i = 0; i < voxels.size(); ++i)
    voxels[i].label = out.refined[i] ? VoxelLabel::Ground : VoxelLabel::NonGround;
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
  tbb::task_arena arena(cfg.threads > 0 ? cfg.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
      const auto& v = voxels[i];
      const double ground = h1.at((v.index.x() + 0.5) * cell, (v.index.y() + 0.5) * cell);
      out.ground_height[i] = static_cast<float>(ground);
      out.rough[i] = setUnary(p, i, v, ground, cfg);
    });
  });
  addPairTerms(p, voxels, cfg, arena);
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

// ---------------------------------------------------------------------------------------------
// incremental

namespace {

std::uint64_t tileKey(int tx, int ty) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(tx)) << 32) | static_cast<std::uint32_t>(ty);
}

}  // namespace

struct IncrementalGroundSegmentation::State {
  GroundSegmentationConfig cfg;
  double cell = 0;
  int k = 0;  // columns per tile edge
  struct Tile {
    int tx = 0, ty = 0;
    std::vector<std::uint32_t> ids;  // in id order
    std::size_t pending = 0;         // voxels added since it was last re-segmented
    std::vector<Point3> lowest;      // its plane-fit candidates (tileCandidates)
    Plane plane;
  };
  std::unordered_map<std::uint64_t, Tile> tiles;
  std::unordered_set<std::uint64_t> touched;
  std::size_t taken = 0;  // voxels already placed in tiles
  SegmentationResult result;
  Stats stats;
  std::vector<std::int32_t> local;  // voxel id -> index in the current subproblem, -1 outside

  void setCell(double voxel_size) {
    if (cell == voxel_size) return;
    cell = voxel_size;
    k = std::max(1, static_cast<int>(std::lround(cfg.tile_size / cell)));
  }
  std::pair<int, int> tileOf(const VoxelIndex& i) const { return {floorDiv(i.x(), k), floorDiv(i.y(), k)}; }

  // a tile's plane-fit candidates, as GroundHeight takes them
  void findLowest(Tile& t, const std::vector<Voxel>& voxels) const {
    tileCandidates(voxels, t.ids.data(), t.ids.size(), k, t.tx * k, t.ty * k, cell, t.lowest);
  }

  // the plane of one tile, as GroundHeight fits it: through the plane-fit candidates of
  // its window, then raised to the peak of the window's heights above it
  Plane windowPlane(const Tile& t, const std::vector<Voxel>& voxels) const {
    std::vector<const Tile*> window;
    for (int dy = -cfg.tile_radius; dy <= cfg.tile_radius; ++dy) {
      for (int dx = -cfg.tile_radius; dx <= cfg.tile_radius; ++dx) {
        auto it = tiles.find(tileKey(t.tx + dx, t.ty + dy));
        if (it != tiles.end()) window.push_back(&it->second);
      }
    }
    std::vector<const std::vector<Point3>*> candidates;
    std::size_t count = 0;
    for (const Tile* u : window) {
      candidates.push_back(&u->lowest);
      count += u->ids.size();
    }
    Plane plane = fitPlane(candidates);
    std::vector<double> residual;
    residual.reserve(count);
    for (const Tile* u : window) {
      for (std::uint32_t id : u->ids) {
        const auto& v = voxels[id];
        residual.push_back(v.height - plane.at((v.index.x() + 0.5) * cell, (v.index.y() + 0.5) * cell));
      }
    }
    plane.c += histogramPeak(residual, cfg.bin_size);
    return plane;
  }
};

IncrementalGroundSegmentation::IncrementalGroundSegmentation(const GroundSegmentationConfig& config)
    : state_(std::make_unique<State>()) {
  state_->cfg = config;
}

IncrementalGroundSegmentation::~IncrementalGroundSegmentation() = default;

const SegmentationResult& IncrementalGroundSegmentation::result() const { return state_->result; }
const IncrementalGroundSegmentation::Stats& IncrementalGroundSegmentation::lastStats() const { return state_->stats; }

void IncrementalGroundSegmentation::touch(const std::vector<Point3>& points, double voxel_size) {
  State& st = *state_;
  st.setCell(voxel_size);
  std::uint64_t last = ~std::uint64_t{0};
  for (const auto& p : points) {
    if (!p.allFinite()) continue;
    const double fx = std::floor(p.x() / st.cell), fy = std::floor(p.y() / st.cell);
    if (std::abs(fx) > 1e9 || std::abs(fy) > 1e9) continue;
    const std::uint64_t key = tileKey(floorDiv(static_cast<int>(fx), st.k), floorDiv(static_cast<int>(fy), st.k));
    if (key != last) st.touched.insert(key), last = key;
  }
}

void IncrementalGroundSegmentation::update(VoxelMap& map) {
  State& st = *state_;
  const auto& cfg = st.cfg;
  st.stats = Stats{};
  if (cfg.histogram == GroundSegmentationConfig::Histogram::Global) {
    st.result = segmentGround(map, cfg);
    st.taken = map.size();
    st.touched.clear();
    st.stats.voxels = map.size();
    return;
  }
  st.setCell(map.voxelSize());
  auto& voxels = map.voxels();
  const std::size_t n = voxels.size();
  // take in the new voxels
  for (std::size_t id = st.taken; id < n; ++id) {
    const auto [tx, ty] = st.tileOf(voxels[id].index);
    const std::uint64_t key = tileKey(tx, ty);
    State::Tile& t = st.tiles[key];
    if (t.ids.empty()) t.tx = tx, t.ty = ty;
    t.ids.push_back(static_cast<std::uint32_t>(id));
    if (static_cast<double>(++t.pending) >= cfg.defer_share * static_cast<double>(t.ids.size())) st.touched.insert(key);
  }
  st.taken = n;
  SegmentationResult& out = st.result;
  out.rough.resize(n, 0);
  out.refined.resize(n, 0);
  out.ground_height.resize(n, 0.0f);
  st.local.resize(n, -1);
  st.stats.touched_tiles = st.touched.size();
  // the tiles whose window reaches a touched tile, in a fixed order
  std::vector<std::uint64_t> keys;
  {
    std::unordered_set<std::uint64_t> seen;
    for (std::uint64_t key : st.touched) {
      const int tx = static_cast<int>(static_cast<std::uint32_t>(key >> 32));
      const int ty = static_cast<int>(static_cast<std::uint32_t>(key & 0xffffffffu));
      for (int dy = -cfg.tile_radius; dy <= cfg.tile_radius; ++dy) {
        for (int dx = -cfg.tile_radius; dx <= cfg.tile_radius; ++dx) {
          const std::uint64_t u = tileKey(tx + dx, ty + dy);
          if (st.tiles.count(u) && seen.insert(u).second) keys.push_back(u);
        }
      }
    }
    std::sort(keys.begin(), keys.end());
  }
  std::vector<State::Tile*> touched;
  for (std::uint64_t key : st.touched) {
    auto it = st.tiles.find(key);
    if (it != st.tiles.end()) touched.push_back(&it->second), it->second.pending = 0;
  }
  st.touched.clear();
  st.stats.refitted_tiles = keys.size();
  if (keys.empty()) return;
  std::vector<State::Tile*> refit;
  for (std::uint64_t key : keys) refit.push_back(&st.tiles.at(key));
  tbb::task_arena arena(cfg.threads > 0 ? cfg.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, touched.size(), [&](std::size_t i) { st.findLowest(*touched[i], voxels); });
  });
  std::vector<Plane> planes(refit.size());
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, refit.size(),
                      [&](std::size_t i) { planes[i] = st.windowPlane(*refit[i], voxels); });
  });
  for (std::size_t i = 0; i < refit.size(); ++i) refit[i]->plane = planes[i];
  // the subproblem: every voxel of the refitted tiles
  std::vector<std::uint32_t> ids;
  std::vector<std::uint32_t> tile_start{0};
  for (const State::Tile* t : refit) {
    ids.insert(ids.end(), t->ids.begin(), t->ids.end());
    tile_start.push_back(static_cast<std::uint32_t>(ids.size()));
  }
  const std::size_t m = ids.size();
  st.stats.voxels = m;
  for (std::size_t i = 0; i < m; ++i) st.local[ids[i]] = static_cast<std::int32_t>(i);
  GmrfProblem p;
  p.unary_ground.resize(m);
  p.unary_nonground.resize(m);
  p.parity.resize(m);
  std::vector<std::uint8_t> rough(m);
  std::vector<Voxel> sub(m);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, refit.size(), [&](std::size_t ti) {
      const State::Tile& tile = *refit[ti];
      const int tx = tile.tx, ty = tile.ty;
      for (std::size_t i = tile_start[ti]; i < tile_start[ti + 1]; ++i) {
        const auto& v = voxels[ids[i]];
        sub[i] = v;
        const double ground = tile.plane.at((v.index.x() + 0.5) * st.cell, (v.index.y() + 0.5) * st.cell);
        out.ground_height[ids[i]] = static_cast<float>(ground);
        rough[i] = out.rough[ids[i]] = setUnary(p, i, v, ground, cfg);
        // neighbours outside the subproblem keep their labels: their pair terms become unary terms
        // (only columns on a tile's edge have neighbours in another tile)
        const int lx = v.index.x() - tx * st.k, ly = v.index.y() - ty * st.k;
        for (const VoxelIndex& d4 :
             {VoxelIndex(1, 0, 0), VoxelIndex(-1, 0, 0), VoxelIndex(0, 1, 0), VoxelIndex(0, -1, 0)}) {
          const int l = d4.x() != 0 ? lx + d4.x() : ly + d4.y();
          if (l >= 0 && l < st.k) continue;
          const std::int64_t j = map.find(v.index + d4);
          if (j < 0 || st.local[j] >= 0) continue;
          const double w = pairWeight(cfg, v.height, voxels[j].height);
          const bool ground_j = out.refined[j] != 0;
          p.unary_ground[i] += ground_j ? -w : w;
          p.unary_nonground[i] += ground_j ? w : -w;
        }
      }
    });
  });
  addPairTerms(p, sub, cfg, arena);
  std::vector<std::uint8_t> labels = rough;
  out.energy_rough = gmrfEnergy(p, rough);
  if (cfg.solver == GroundSegmentationConfig::Solver::MinCut) {
    solveMinCut(p, labels);
    out.iterations = 0;
  } else {
    out.iterations = solveIcm(p, labels, cfg.icm_iterations, cfg.threads);
  }
  out.energy_refined = gmrfEnergy(p, labels);
  out.tiles = static_cast<int>(st.tiles.size());
  for (std::size_t i = 0; i < m; ++i) {
    out.refined[ids[i]] = labels[i];
    voxels[ids[i]].label = labels[i] ? VoxelLabel::Ground : VoxelLabel::NonGround;
    st.local[ids[i]] = -1;
  }
}

}  // namespace terrain
