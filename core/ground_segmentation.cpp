#include "core/ground_segmentation.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>

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

namespace {

// A histogram of heights in bins of bin_size whose edges are whole multiples of it, and its peak
// refined to the mean of the heights in the peak bin and its two neighbours. Heights are summed
// in the order they are added; the whole-map and the incremental segmentation add a tile's voxels
// in the same order (the layout's), so they agree to the bit.
class PeakHistogram {
 public:
  // empties the histogram for heights in [lo, hi] [m] (a height outside falls in the end bin, as
  // do heights past 2^20 bins above lo)
  void reset(double lo, double hi, double bin_size) {
    inv_ = 1.0 / bin_size;
    base_ = lo;
    first_ = floorInt(lo * inv_) - 1;
    bins_ = std::clamp(floorInt(hi * inv_) - first_ + 2, 1, 1 << 20);
    count_.assign(kLanes * bins_, 0);
    sum_.assign(kLanes * bins_, 0.0);
  }
  void add(double h) {
    const std::uint32_t bounds[2] = {0, 1};
    addColumns(&h, bounds, 1, 1, 0.0, 0.0);
  }
  // adds, for the columns j = 0, s, 2s, ... < count of a row, the heights h[bounds[j]] ..
  // h[bounds[j + 1] - 1] less the column's offset, offset0 + (j / s) * step: the offset moves by
  // step from one column to the next
  template <class T>
  void addColumns(const T* h, const std::uint32_t* bounds, int count, int s, double offset0, double step) {
    // the bin of h - offset is floor((h - offset) / bin_size) - first_, clamped (NaN to the first);
    // successive heights, mostly in one bin, go to different lanes: no chain of dependent
    // read-modify-writes on one counter
    double shift = offset0 * inv_ + first_, below = offset0 + base_;
    const double shift_step = step * inv_, last = bins_ - 1;
    int lane = lane_;
    for (int j = 0; j < count; j += s, shift += shift_step, below += step) {
      for (std::uint32_t q = bounds[j]; q < bounds[j + 1]; ++q) {
        double x = h[q] * inv_ - shift;
        x = x > 0 ? x : 0;
        x = x < last ? x : last;
        const int b = kLanes * static_cast<int>(x) + lane;
        ++count_[b];
        sum_[b] += h[q] - below;
        lane = (lane + 1) & (kLanes - 1);
      }
    }
    lane_ = lane;
  }
  std::int64_t total() const {
    std::int64_t n = 0;
    for (std::int32_t c : count_) n += c;
    return n;
  }
  // the refined peak [m]; NaN if empty. The lowest bin among equal peaks: ground lies under objects.
  double peak() const {
    int p = 0;
    std::int64_t best = -1;
    for (int b = 0; b < bins_; ++b) {
      const std::int64_t c = count(b);
      if (c > best) best = c, p = b;
    }
    std::int64_t n = 0;
    double sum = 0;
    for (int b = std::max(0, p - 1); b <= std::min(bins_ - 1, p + 1); ++b) {
      for (int l = 0; l < kLanes; ++l) sum += sum_[kLanes * b + l];
      n += count(b);
    }
    return n == 0 ? std::numeric_limits<double>::quiet_NaN() : base_ + sum / static_cast<double>(n);
  }

 private:
  static constexpr int kLanes = 4;
  // floor(x) as an int, x clamped to +-2^30 (and NaN taken as 0)
  static int floorInt(double x) {
    x = x > -1073741824.0 ? (x < 1073741824.0 ? x : 1073741824.0) : (x <= -1073741824.0 ? -1073741824.0 : 0.0);
    const int t = static_cast<int>(x);
    return t - (x < t);
  }
  std::int64_t count(int b) const {
    std::int64_t c = 0;
    for (int l = 0; l < kLanes; ++l) c += count_[kLanes * b + l];
    return c;
  }
  double inv_ = 10, base_ = 0;
  int first_ = 0, bins_ = 0, lane_ = 0;
  std::vector<std::int32_t> count_;
  std::vector<double> sum_;
};

// a tile's histogram takes every histogram_stride-th column unless that leaves fewer voxels than this
constexpr std::int64_t kMinHistogram = 256;

// fixed chunks of nodes, so that sums over them come out the same whatever the thread count
constexpr std::size_t kChunks = 64;

// the arena the parallel loops run in: `threads` workers, or TBB's default for 0
tbb::task_arena arenaFor(int threads) { return tbb::task_arena(threads > 0 ? threads : tbb::task_arena::automatic); }

// 2^(j/32) for j = 0 .. 31, each the double nearest it
constexpr double kExp2Fraction[32] = {
    0x1.0000000000000p+0, 0x1.059b0d3158574p+0, 0x1.0b5586cf9890fp+0, 0x1.11301d0125b51p+0, 0x1.172b83c7d517bp+0,
    0x1.1d4873168b9aap+0, 0x1.2387a6e756238p+0, 0x1.29e9df51fdee1p+0, 0x1.306fe0a31b715p+0, 0x1.371a7373aa9cbp+0,
    0x1.3dea64c123422p+0, 0x1.44e086061892dp+0, 0x1.4bfdad5362a27p+0, 0x1.5342b569d4f82p+0, 0x1.5ab07dd485429p+0,
    0x1.6247eb03a5585p+0, 0x1.6a09e667f3bcdp+0, 0x1.71f75e8ec5f74p+0, 0x1.7a11473eb0187p+0, 0x1.82589994cce13p+0,
    0x1.8ace5422aa0dbp+0, 0x1.93737b0cdc5e5p+0, 0x1.9c49182a3f090p+0, 0x1.a5503b23e255dp+0, 0x1.ae89f995ad3adp+0,
    0x1.b7f76f2fb5e47p+0, 0x1.c199bdd85529cp+0, 0x1.cb720dcef9069p+0, 0x1.d5818dcfba487p+0, 0x1.dfc97337b9b5fp+0,
    0x1.ea4afa2a490dap+0, 0x1.f50765b6e4540p+0,
};

// e^-x for x >= 0 (NaN for NaN), in double. -x / ln 2 = (32 e + j + r) / 32 with whole e and j in
// 0 .. 31 and |r| <= 1/2, and e^-x = 2^e 2^(j/32) 2^(r/32): the first a shift of the exponent, the
// second from the table, the third from its Taylor polynomial of degree 4 (relative error below
// 1.3e-12), so that e^-x rounded to float is correctly rounded but for about one x in a few
// million (then one unit in the last place off). Branch-free and inline: 1.8 M voxels weigh three
// pairs each.
inline double expNegative(float x) {
  double v = x;
  v = v > 700.0 ? 700.0 : v;  // e^-700 is far below the least float; keeps e within the double's exponent range
  const double z = v * -0x1.71547652b82fep+5;  // -x * 32 / ln 2
  // z rounded to a whole number k by adding 1.5 * 2^52: k is then the low bits of the sum's
  // mantissa (two's complement), and the sum less 1.5 * 2^52 is k as a double
  constexpr double kRound = 0x1.8p52;
  const double shifted = z + kRound;
  std::uint64_t bits;
  std::memcpy(&bits, &shifted, sizeof bits);
  const double r = z - (shifted - kRound);
  std::uint64_t scale;
  std::memcpy(&scale, &kExp2Fraction[bits & 31], sizeof scale);
  scale += (bits >> 5) << 52;  // adds e to the exponent (wrapping in two's complement for e < 0)
  double s;
  std::memcpy(&s, &scale, sizeof s);
  // the polynomial by Estrin's scheme: two short chains of operations instead of one long one
  const double r2 = r * r;
  const double p = (1.0 + r * 0x1.62e42fefa39efp-6) +
                   r2 * ((0x1.ebfbdff82c58fp-13 + r * 0x1.c6b08d704a0c0p-20) + r2 * 0x1.3b2ab6fba4e77p-27);
  return s * p;
}

}  // namespace

float pairWeight(const GroundSegmentationConfig& cfg, float a, float b) {
  return static_cast<float>(cfg.beta + cfg.gamma * expNegative(std::abs(a - b)));
}

double histogramPeak(const std::vector<double>& heights, double bin_size) {
  if (heights.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto [lo, hi] = std::minmax_element(heights.begin(), heights.end());
  PeakHistogram histogram;
  histogram.reset(*lo, *hi, bin_size);
  for (double h : heights) histogram.add(h);
  return histogram.peak();
}

void GmrfProblem::resize(std::size_t n) {
  unary_ground.assign(n, 0.0f);
  unary_nonground.assign(n, 0.0f);
  next.assign(3 * n, kNone);
  prev.assign(3 * n, kNone);
  weight.assign(3 * n, 0.0f);
  parity.assign(n, 0);
}

double gmrfEnergy(const GmrfProblem& p, const std::vector<std::uint8_t>& ground) {
  const std::size_t n = ground.size();
  std::vector<double> part(kChunks, 0.0);
  tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
    double e = 0;
    for (std::size_t v = n * c / kChunks; v < n * (c + 1) / kChunks; ++v) {
      e += ground[v] ? p.unary_ground[v] : p.unary_nonground[v];
      for (int a = 0; a < 3; ++a) {
        const std::uint32_t u = p.next[3 * v + a];
        if (u != GmrfProblem::kNone) e += ground[v] == ground[u] ? -p.weight[3 * v + a] : p.weight[3 * v + a];
      }
    }
    part[c] = e;
  });
  double e = 0;
  for (double x : part) e += x;
  return e;
}

namespace {

// throws std::invalid_argument unless the problem's graph is a grid's: every forward link matched
// by its backward one and every backward link by its forward one, and of nodes of two colours
void checkGrid(const GmrfProblem& p, std::size_t n, tbb::task_arena& arena) {
  std::vector<std::size_t> bad(kChunks, n);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
      for (std::size_t v = n * c / kChunks; v < n * (c + 1) / kChunks && bad[c] == n; ++v) {
        for (int a = 0; a < 3; ++a) {
          const std::uint32_t u = p.next[3 * v + a];
          if (u != GmrfProblem::kNone && (u >= n || p.prev[3 * u + a] != v || (p.parity[u] & 1) == (p.parity[v] & 1)))
            bad[c] = v;
          const std::uint32_t w = p.prev[3 * v + a];
          if (w != GmrfProblem::kNone && (w >= n || p.next[3 * w + a] != v)) bad[c] = v;
        }
      }
    });
  });
  for (std::size_t v : bad) {
    if (v != n)
      throw std::invalid_argument("GMRF problem: node " + std::to_string(v) +
                                  " is linked to a node that is missing, linked from another node along the same "
                                  "axis, not linked back, or of the same parity");
  }
}

// ICM on a problem known to be a grid's. The first sweep visits every node; later ones only the
// nodes next to one that changed since they were last visited (the others would keep their label:
// nothing they depend on changed), which gives the labels of full sweeps at a fraction of the cost.
IcmResult icm(const GmrfProblem& p, std::vector<std::uint8_t>& ground, int max_iterations, tbb::task_arena& arena) {
  const std::size_t n = ground.size();
  IcmResult result;
  if (max_iterations <= 0) {
    result.energy_initial = result.energy_final = gmrfEnergy(p, ground);
    return result;
  }
  // per chunk: energy summed in the first sweep, energy change, and the nodes that changed
  std::vector<double> energy(kChunks), delta(kChunks);
  std::vector<std::vector<std::uint32_t>> moved(kChunks);
  std::vector<std::uint32_t> visit;  // the nodes of the colour due next (after the first sweep)
  // the arrays, through pointers that each chunk copies into locals: the compiler then need not
  // read them again after every store of a label (a byte, which may alias anything)
  struct Arrays {
    const float *unary_ground, *unary_nonground, *weight;
    const std::uint32_t *next, *prev;
    const std::uint8_t* parity;
    std::uint8_t* ground;
  };
  const Arrays arrays{p.unary_ground.data(), p.unary_nonground.data(), p.weight.data(), p.next.data(),
                      p.prev.data(),         p.parity.data(),          ground.data()};
  // Updates node v of the given colour, in place; with `first`, adds the energy of the labelling
  // the sweep started from to e: the single-site term of every node, before its update, and each
  // pair once, from its node of colour 0.
  const auto update = [](const Arrays& q, std::uint32_t v, std::uint8_t colour, bool first, double& e, double& d,
                         std::vector<std::uint32_t>& changed) {
    // a neighbour's pair term for ground, -w if it is ground and w if not (a sign from its label,
    // without a branch); that for non-ground is its negative
    const auto term = [&](std::uint32_t u, float w) { return static_cast<double>(w) * (q.ground[u] ? -1.0 : 1.0); };
    double cost_g = q.unary_ground[v], cost_n = q.unary_nonground[v];
    for (int a = 0; a < 3; ++a) {
      const std::uint32_t u = q.next[3 * v + a];
      if (u != GmrfProblem::kNone) {
        const double t = term(u, q.weight[3 * v + a]);
        cost_g += t, cost_n -= t;
      }
      const std::uint32_t b = q.prev[3 * v + a];
      if (b != GmrfProblem::kNone) {
        const double t = term(b, q.weight[3 * b + a]);
        cost_g += t, cost_n -= t;
      }
    }
    if (first)
      e += colour == 0 ? (q.ground[v] ? cost_g : cost_n) : (q.ground[v] ? q.unary_ground[v] : q.unary_nonground[v]);
    const std::uint8_t best = cost_g < cost_n ? 1 : (cost_n < cost_g ? 0 : q.ground[v]);
    if (best != q.ground[v]) {
      d += best ? cost_g - cost_n : cost_n - cost_g;
      q.ground[v] = best;
      changed.push_back(v);
    }
  };
  double change = 0;
  for (int sweep = 0; sweep < max_iterations; ++sweep) {
    bool any = false;
    for (std::uint8_t colour = 0; colour < 2; ++colour) {
      // nodes of one colour have no pair between them: update them all at once, in place
      arena.execute([&] {
        tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
          const Arrays q = arrays;
          std::vector<std::uint32_t>& changed = moved[c];
          double e = 0, d = 0;
          changed.clear();
          if (sweep == 0) {
            const std::size_t lo = n * c / kChunks, hi = n * (c + 1) / kChunks;
            for (std::size_t v = lo; v < hi; ++v) {
              if ((q.parity[v] & 1) == colour) update(q, static_cast<std::uint32_t>(v), colour, true, e, d, changed);
            }
          } else {
            const std::size_t m = visit.size(), lo = m * c / kChunks, hi = m * (c + 1) / kChunks;
            const std::uint32_t* const nodes = visit.data();
            for (std::size_t i = lo; i < hi; ++i) update(q, nodes[i], colour, false, e, d, changed);
          }
          if (sweep == 0) energy[c] += e;
          delta[c] = d;
        });
      });
      // the other colour's nodes next to those that changed are visited next
      visit.clear();
      for (std::size_t c = 0; c < kChunks; ++c) {
        change += delta[c];
        for (std::uint32_t v : moved[c]) {
          any = true;
          for (int a = 0; a < 3; ++a) {
            if (p.next[3 * v + a] != GmrfProblem::kNone) visit.push_back(p.next[3 * v + a]);
            if (p.prev[3 * v + a] != GmrfProblem::kNone) visit.push_back(p.prev[3 * v + a]);
          }
        }
      }
      std::sort(visit.begin(), visit.end());
      visit.erase(std::unique(visit.begin(), visit.end()), visit.end());
    }
    if (!any) break;
    ++result.sweeps;
  }
  for (double e : energy) result.energy_initial += e;
  result.energy_final = result.energy_initial + change;
  return result;
}

}  // namespace

IcmResult solveIcm(const GmrfProblem& p, std::vector<std::uint8_t>& ground, int max_iterations, int threads) {
  tbb::task_arena arena = arenaFor(threads);
  checkGrid(p, ground.size(), arena);
  return icm(p, ground, max_iterations, arena);
}

namespace {

struct Plane {
  double a = 0, b = 0, c = 0;  // z = a x + b y + c
  double at(double x, double y) const { return a * x + b * y + c; }
};

int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
int floorMod(int a, int b) { return a - floorDiv(a, b) * b; }

// floor((a - base) / k) for a fixed k >= 1 and a in [base, base + 2^23): a multiply and a shift
// in place of a division. With 2^l >= k and m = ceil(2^(23 + l) / k), (n m) >> (23 + l) is
// floor(n / k) for every 0 <= n < 2^23 (the rounding up of m adds less than 2^-l <= 1/k to n / k).
// A map's voxel indices span less than 2^21 (VoxelMap keeps them within +-2^20).
class OffsetDivider {
 public:
  OffsetDivider() = default;
  OffsetDivider(int base, int k) : base_(base) {
    int l = 0;
    while ((std::uint64_t{1} << l) < static_cast<std::uint64_t>(k)) ++l;
    shift_ = 23 + l;
    mul_ = ((std::uint64_t{1} << shift_) + static_cast<std::uint64_t>(k) - 1) / static_cast<std::uint64_t>(k);
  }
  int operator()(int a) const {
    return static_cast<int>((static_cast<std::uint64_t>(static_cast<std::uint32_t>(a - base_)) * mul_) >> shift_);
  }

 private:
  int base_ = 0, shift_ = 0;
  std::uint64_t mul_ = 0;
};

// sums of a point set, relative to a reference point near it, for least squares in one pass
struct Moments {
  double n = 0, x = 0, y = 0, z = 0, xx = 0, xy = 0, yy = 0, xz = 0, yz = 0;
  double zmin = std::numeric_limits<double>::infinity();  // the lowest point's z, relative too
  // adds moments taken relative to a reference point s away from this one's
  void add(const Moments& m, const Eigen::Vector3d& s) {
    n += m.n, x += m.x + m.n * s.x(), y += m.y + m.n * s.y(), z += m.z + m.n * s.z();
    xx += m.xx + 2 * s.x() * m.x + m.n * s.x() * s.x();
    xy += m.xy + s.x() * m.y + s.y() * m.x + m.n * s.x() * s.y();
    yy += m.yy + 2 * s.y() * m.y + m.n * s.y() * s.y();
    xz += m.xz + s.x() * m.z + s.z() * m.x + m.n * s.x() * s.z();
    yz += m.yz + s.y() * m.z + s.z() * m.y + m.n * s.y() * s.z();
    zmin = std::min(zmin, m.zmin + s.z());
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
    if (std::hypot(p.a, p.b) > 0.7) p = {0, 0, ref.z() + zmin};
    return p;
  }
};

// The plane-fit candidates of a tile, relative to its reference point (the centre of its first
// column, at the height of its first candidate), in single precision and padded to a multiple of
// four with points that no plane keeps: four lanes of sums run side by side.
struct Candidates {
  static constexpr int kLanes = 4;
  Point3 ref = Point3::Zero();
  std::size_t count = 0;
  std::vector<float> x, y, z;
  Moments all;  // of every candidate, relative to ref

  // The moments of the candidates within 1.0 m of plane p0 and, if p1 is given, within 0.7 m of
  // p1 (both in world coordinates).
  Moments near(const Plane& p0, const Plane* p1) const {
    // four lanes in a vector register (GCC and Clang vector extensions: SSE, NEON); comparisons
    // give all-ones or zero per lane, used as masks
    using F4 = float __attribute__((vector_size(16)));
    using I4 = std::int32_t __attribute__((vector_size(16)));
    static_assert(kLanes == 4);
    const auto local = [&](const Plane& p) {
      return std::array<float, 3>{static_cast<float>(p.a), static_cast<float>(p.b),
                                  static_cast<float>(p.at(ref.x(), ref.y()) - ref.z())};
    };
    const std::array<float, 3> q0 = local(p0), q1 = p1 ? local(*p1) : std::array<float, 3>{0, 0, 0};
    const float tol1 = p1 ? 0.7f : std::numeric_limits<float>::infinity();
    const F4 zero = {0, 0, 0, 0}, one = zero + 1.0f, inf = zero + std::numeric_limits<float>::infinity();
    F4 n = zero, sx = zero, sy = zero, sz = zero, xx = zero, xy = zero, yy = zero, xz = zero, yz = zero, zmin = inf;
    for (std::size_t i = 0; i < x.size(); i += kLanes) {
      F4 px, py, pz;
      std::memcpy(&px, &x[i], sizeof px), std::memcpy(&py, &y[i], sizeof py), std::memcpy(&pz, &z[i], sizeof pz);
      const F4 r0 = pz - (q0[0] * px + q0[1] * py + q0[2]), r1 = pz - (q1[0] * px + q1[1] * py + q1[2]);
      const I4 keep = (r0 < 1.0f) & (r0 > -1.0f) & (r1 < tol1) & (r1 > -tol1);
      const F4 m = reinterpret_cast<F4>(keep & reinterpret_cast<I4>(one));
      n += m, sx += m * px, sy += m * py, sz += m * pz;
      xx += m * px * px, xy += m * px * py, yy += m * py * py, xz += m * px * pz, yz += m * py * pz;
      const F4 kept = reinterpret_cast<F4>((keep & reinterpret_cast<I4>(pz)) | (~keep & reinterpret_cast<I4>(inf)));
      const I4 lower = kept < zmin;
      zmin = reinterpret_cast<F4>((lower & reinterpret_cast<I4>(kept)) | (~lower & reinterpret_cast<I4>(zmin)));
    }
    Moments out;
    for (int l = 0; l < kLanes; ++l) {
      out.n += n[l], out.x += sx[l], out.y += sy[l], out.z += sz[l], out.xx += xx[l], out.xy += xy[l];
      out.yy += yy[l], out.xz += xz[l], out.yz += yz[l], out.zmin = std::min<double>(out.zmin, zmin[l]);
    }
    return out;
  }
};

// Of the moments of each part about its own reference point, the sum about ref.
template <class Part>
Moments sumAbout(const std::vector<const Candidates*>& parts, const Point3& ref, Part&& part) {
  Moments sum;
  for (const auto* c : parts) {
    if (c->count > 0) sum.add(part(*c), c->ref - ref);
  }
  return sum;
}

// least squares in three rounds, each fitted to the points the previous plane left within
// 1.0 m, then 0.7 m; one pass over the points per round, the first one made beforehand. The
// points are the candidates of all the parts.
Plane fitPlane(const std::vector<const Candidates*>& parts) {
  std::size_t n = 0;
  const Candidates* first = nullptr;
  for (const auto* part : parts) {
    if (!first && part->count > 0) first = part;
    n += part->count;
  }
  if (n < 3) return n == 0 ? Plane{} : Plane{0, 0, first->ref.z()};
  const Point3 ref = first->ref;
  const Plane plane0 = sumAbout(parts, ref, [](const Candidates& c) { return c.all; }).plane(ref);
  const Moments near1 = sumAbout(parts, ref, [&](const Candidates& c) { return c.near(plane0, nullptr); });
  if (near1.n < 3) return plane0;
  const Plane plane1 = near1.plane(ref);
  const Moments near2 = sumAbout(parts, ref, [&](const Candidates& c) { return c.near(plane0, &plane1); });
  if (near2.n < 3) return plane1;
  return near2.plane(ref);
}

// The plane-fit candidates of a tile of k x k columns whose first column is (cx, cy), from the
// height of the lowest voxel of each of its columns, given by low(c) for column c (row-major,
// +inf where empty): of those the lowest of every 2 x 2 block of columns, at its column's centre.
// A quarter of the columns fix a plane as well as all of them.
template <class Low>
void candidatesFromLows(Low&& low, int k, int cx, int cy, double cell, Candidates& out) {
  const int blocks = (k + 1) / 2;
  const std::size_t most = static_cast<std::size_t>(blocks) * blocks + Candidates::kLanes;
  out.x.resize(most), out.y.resize(most), out.z.resize(most);
  out.all = Moments{};
  out.ref = Point3((cx + 0.5) * cell, (cy + 0.5) * cell, 0);
  std::size_t n = 0;
  for (int r = 0; r < k; r += 2) {
    const int rows = std::min(2, k - r);
    for (int c = 0; c < k; c += 2) {
      const int cols = std::min(2, k - c);
      float best = std::numeric_limits<float>::infinity();
      int br = 0, bc = 0;
      for (int dr = 0; dr < rows; ++dr) {
        for (int dc = 0; dc < cols; ++dc) {
          const float l = low(static_cast<std::size_t>(r + dr) * k + c + dc);
          if (l < best) best = l, br = r + dr, bc = c + dc;
        }
      }
      if (!std::isfinite(best)) continue;
      if (n == 0) out.ref.z() = best;
      out.x[n] = static_cast<float>(bc * cell);
      out.y[n] = static_cast<float>(br * cell);
      out.z[n] = static_cast<float>(best - out.ref.z());
      ++n;
    }
  }
  out.count = n;
  for (std::size_t i = 0; i < n; ++i) {
    const double px = out.x[i], py = out.y[i], pz = out.z[i];
    auto& m = out.all;
    m.n += 1, m.x += px, m.y += py, m.z += pz, m.xx += px * px, m.xy += px * py, m.yy += py * py;
    m.xz += px * pz, m.yz += py * pz, m.zmin = std::min(m.zmin, pz);
  }
  for (; n % Candidates::kLanes != 0; ++n) out.x[n] = 0, out.y[n] = 0, out.z[n] = std::numeric_limits<float>::max();
  out.x.resize(n), out.y.resize(n), out.z.resize(n);
}

// Eqs. 19-20 for a voxel d [m] above the ground height h1 at its column: its rough class (true: G1)
// and its single-site term V1(f) + V1(h|f) for f = ground. That for non-ground is the negative.
struct Unary {
  bool g1;
  float ground;
};
Unary unary(double d, double delta, double range_margin, double alpha) {
  const bool g1 = std::abs(d) <= delta;
  const bool in_range = std::abs(d) <= range_margin;
  return {g1, static_cast<float>((g1 ? -alpha : alpha) + (in_range ? -alpha : alpha))};
}

// A set of tiles of k x k columns and their voxels, laid out tile by tile, column by column
// (row-major inside the tile) and upwards inside each column: a position numbers a voxel in this
// order. Finding a voxel's neighbours is then a walk along two short sorted columns, and a
// tile's voxels are contiguous. Built again and again in the same memory.
class TileLayout {
 public:
  struct Tile {
    int tx = 0, ty = 0;
  };
  // Every voxel of the map, in the tiles it covers (in row-major tile order). The tiles' extent
  // comes from the map's index extent, so that the voxels are read only to group them.
  void build(const VoxelMap& map, int k) {
    clear(k);
    const std::vector<Voxel>& voxels = map.voxels();
    if (voxels.empty()) return;
    const VoxelIndex& lo = map.lowestIndex();
    const VoxelIndex& hi = map.highestIndex();
    setGrid(floorDiv(lo.x(), k), floorDiv(lo.y(), k), floorDiv(hi.x(), k), floorDiv(hi.y(), k), voxels.size());
    tile_x_ = OffsetDivider(gx0_ * k, k), tile_y_ = OffsetDivider(gy0_ * k, k);
    if (!grid_.empty()) {
      groupDense(voxels);
    } else {
      groupSparse(voxels);
    }
  }

  // The voxels of the given tiles (tile coordinates and voxel ids), in that order.
  void build(const std::vector<Voxel>& voxels, int k, const std::vector<Tile>& tiles,
             const std::vector<const std::vector<std::uint32_t>*>& ids) {
    clear(k);
    tiles_ = tiles;
    if (tiles.empty()) return;
    int x0 = tiles[0].tx, x1 = x0, y0 = tiles[0].ty, y1 = y0;
    for (const auto& t : tiles) {
      x0 = std::min(x0, t.tx), x1 = std::max(x1, t.tx);
      y0 = std::min(y0, t.ty), y1 = std::max(y1, t.ty);
    }
    setGrid(x0, y0, x1, y1, tiles.size());
    first_.push_back(0);
    for (std::size_t t = 0; t < tiles.size(); ++t) {
      setTile(gridCell(tiles[t].tx, tiles[t].ty), t);
      first_.push_back(first_.back() + static_cast<std::uint32_t>(ids[t]->size()));
    }
    resizePositions(first_.back());
    tbb::parallel_for(std::size_t{0}, tiles.size(), [&](std::size_t t) {
      std::uint32_t q = first_[t];
      for (std::uint32_t i : *ids[t]) place(q++, i, voxels[i], tiles[t]);
    });
    sortColumns();
  }

  int k() const { return k_; }
  std::size_t size() const { return ids_.size(); }
  const std::vector<Tile>& tiles() const { return tiles_; }
  // index in tiles() of the tile at (tx, ty), or -1 if it is not in the layout
  std::int64_t tileAt(int tx, int ty) const {
    if (tx < gx0_ || ty < gy0_ || tx >= gx0_ + nx_ || ty >= gy0_ + ny_) return -1;
    if (!grid_.empty()) return grid_[gridCell(tx, ty)];
    const auto it = sparse_.find(gridCell(tx, ty));
    return it == sparse_.end() ? -1 : it->second;
  }

  // first position of column c (row-major, 0..k*k) of tile t; column k*k is the tile's end
  std::uint32_t column(std::size_t t, std::size_t c) const { return columns_[t * (k_ * k_ + 1) + c]; }
  std::uint32_t id(std::size_t pos) const { return ids_[pos]; }
  std::int32_t z(std::size_t pos) const { return z_[pos]; }
  float height(std::size_t pos) const { return height_[pos]; }
  // the same for every position, by position
  const std::uint32_t* ids() const { return ids_.data(); }
  const std::int32_t* zs() const { return z_.data(); }
  const float* heights() const { return height_.data(); }
  // the heights of the lowest and the highest voxel of tile t [m]
  float lowest(std::size_t t) const { return range_[2 * t]; }
  float highest(std::size_t t) const { return range_[2 * t + 1]; }

  // calls f(lx, ly, b, e) for every non-empty column of tile t, in row-major order: the column at
  // (lx, ly) in the tile holds positions b .. e - 1. With a stride s > 1, only the columns whose
  // grid coordinates are both multiples of s.
  template <class F>
  void forEachColumn(std::size_t t, F&& f, int s = 1) const {
    const std::uint32_t* col = columns_.data() + t * (k_ * k_ + 1);
    const int lx0 = floorMod(-tiles_[t].tx * k_, s), ly0 = floorMod(-tiles_[t].ty * k_, s);
    for (int ly = ly0; ly < k_; ly += s) {
      for (int lx = lx0; lx < k_; lx += s) {
        const std::uint32_t* c = col + ly * k_ + lx;
        if (c[0] != c[1]) f(lx, ly, c[0], c[1]);
      }
    }
  }

  // calls f(ly, lx0, bounds) for every row ly of tile t that holds a column whose grid coordinates
  // are both multiples of s; its first such column is lx0, and column lx0 + j holds positions
  // bounds[j] .. bounds[j + 1] - 1 (all rows, with s = 1)
  template <class F>
  void forEachRow(std::size_t t, F&& f, int s = 1) const {
    const std::uint32_t* col = columns_.data() + t * (k_ * k_ + 1);
    const int lx0 = floorMod(-tiles_[t].tx * k_, s), ly0 = floorMod(-tiles_[t].ty * k_, s);
    for (int ly = ly0; ly < k_; ly += s) f(ly, lx0, col + ly * k_ + lx0);
  }

  // the height of the lowest voxel of each column of tile t, in row-major order (+inf where the
  // column is empty), into low[0 .. k*k - 1]
  void columnLows(std::size_t t, float* low) const {
    const std::uint32_t* col = columns_.data() + t * (k_ * k_ + 1);
    std::uint32_t q = col[0];
    for (int c = 0; c < k_ * k_; ++c) {
      float l = std::numeric_limits<float>::infinity();
      for (const std::uint32_t e = col[c + 1]; q < e; ++q) l = std::min(l, height_[q]);
      low[c] = l;
    }
  }

  // Links every voxel of tiles 0 .. count - 1 to its neighbours at +x, +y, +z in those tiles, with
  // their pair weights: sets every voxel's next and weight (kNone and 0 where it has no neighbour)
  // and its neighbours' prev. The prev of a voxel no other links to must be kNone already.
  void linkNeighbours(GmrfProblem& p, const GroundSegmentationConfig& cfg, std::size_t count) const {
    const auto inside = [count](std::int64_t u) { return u >= 0 && static_cast<std::size_t>(u) < count ? u : -1; };
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t t) {
      const std::int64_t east = inside(tileAt(tiles_[t].tx + 1, tiles_[t].ty));
      const std::int64_t north = inside(tileAt(tiles_[t].tx, tiles_[t].ty + 1));
      forEachColumn(t, [&](int lx, int ly, std::uint32_t b, std::uint32_t e) {
        for (std::uint32_t q = b; q < e; ++q) {
          if (q + 1 < e && z_[q + 1] == z_[q] + 1) {
            p.link(q, 2, q + 1, pairWeight(cfg, height_[q], height_[q + 1]));
          } else {
            p.next[3 * q + 2] = GmrfProblem::kNone, p.weight[3 * q + 2] = 0;
          }
        }
        const std::size_t c = static_cast<std::size_t>(ly) * k_ + lx;
        const std::size_t o = static_cast<std::size_t>(ly) * k_;
        if (lx + 1 < k_) {
          linkColumns(p, cfg, b, e, column(t, c + 1), column(t, c + 2), 0);
        } else {
          linkColumns(p, cfg, b, e, east >= 0 ? column(east, o) : 0, east >= 0 ? column(east, o + 1) : 0, 0);
        }
        if (ly + 1 < k_) {
          linkColumns(p, cfg, b, e, column(t, c + k_), column(t, c + k_ + 1), 1);
        } else {
          linkColumns(p, cfg, b, e, north >= 0 ? column(north, lx) : 0, north >= 0 ? column(north, lx + 1) : 0, 1);
        }
      });
    });
  }

 private:
  void clear(int k) {
    k_ = k;
    gx0_ = gy0_ = nx_ = ny_ = 0;
    grid_.clear(), sparse_.clear(), tiles_.clear(), ids_.clear(), first_.clear();
  }

  // voxel ids grouped by tile through a grid over the map's extent (counting sort, in id order
  // inside a tile)
  void groupDense(const std::vector<Voxel>& voxels) {
    const std::size_t n = voxels.size(), cells = grid_.size();
    // a counting sort in chunks of voxels (as many as leave a count per chunk and cell no larger
    // than the voxels): each chunk counts, then places, its voxels in id order after those of
    // the chunks before it
    const std::size_t chunks = std::clamp<std::size_t>(n / cells, 1, kChunks);
    std::vector<std::uint32_t>& offset = scratch_;
    offset.assign(chunks * cells, 0);
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      std::uint32_t* count = offset.data() + c * cells;
      for (std::size_t i = n * c / chunks; i < n * (c + 1) / chunks; ++i) {
        const Tile t = tileOf(voxels[i]);
        ++count[gridCell(t.tx, t.ty)];
      }
    });
    std::uint32_t placed = 0;
    for (std::size_t cell = 0; cell < cells; ++cell) {
      const std::uint32_t start = placed;
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::uint32_t count = offset[c * cells + cell];
        offset[c * cells + cell] = placed;
        placed += count;
      }
      if (placed == start) continue;
      grid_[cell] = static_cast<std::int32_t>(tiles_.size());
      tiles_.push_back({static_cast<int>(cell % nx_) + gx0_, static_cast<int>(cell / nx_) + gy0_});
      first_.push_back(start);
    }
    // each voxel placed with what sortColumns needs of it, read here in id order
    resizePositions(n);
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      std::uint32_t* fill = offset.data() + c * cells;
      for (std::size_t i = n * c / chunks; i < n * (c + 1) / chunks; ++i) {
        const Tile t = tileOf(voxels[i]);
        place(fill[gridCell(t.tx, t.ty)]++, static_cast<std::uint32_t>(i), voxels[i], t);
      }
    });
    first_.push_back(static_cast<std::uint32_t>(n));
    sortColumns();
  }

  // the same, in the same tile order, by sorting the voxels' grid cells: for maps whose extent
  // holds far more tiles than voxels (a few returns far from the rest)
  void groupSparse(const std::vector<Voxel>& voxels) {
    const std::size_t n = voxels.size();
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
      const Tile t = tileOf(voxels[i]);
      keyed[i] = {gridCell(t.tx, t.ty), static_cast<std::uint32_t>(i)};
    });
    std::sort(keyed.begin(), keyed.end());
    resizePositions(n);
    for (std::size_t j = 0; j < n; ++j) {
      const std::uint32_t i = keyed[j].second;
      place(j, i, voxels[i], tileOf(voxels[i]));
      if (j > 0 && keyed[j].first == keyed[j - 1].first) continue;
      const std::uint64_t c = keyed[j].first;
      setTile(c, tiles_.size());
      tiles_.push_back({static_cast<int>(c % nx_) + gx0_, static_cast<int>(c / nx_) + gy0_});
      first_.push_back(static_cast<std::uint32_t>(j));
    }
    first_.push_back(static_cast<std::uint32_t>(n));
    sortColumns();
  }

  // the tile grid over [x0, x1] x [y0, y1]: dense unless it would hold far more cells than the
  // count of voxels or tiles going into it
  void setGrid(int x0, int y0, int x1, int y1, std::size_t count) {
    gx0_ = x0, gy0_ = y0, nx_ = x1 - x0 + 1, ny_ = y1 - y0 + 1;
    const std::uint64_t cells = static_cast<std::uint64_t>(nx_) * static_cast<std::uint64_t>(ny_);
    if (cells <= std::max<std::uint64_t>(std::uint64_t{1} << 20, 8 * static_cast<std::uint64_t>(count)))
      grid_.assign(cells, -1);
  }
  std::uint64_t gridCell(int tx, int ty) const {
    return static_cast<std::uint64_t>(ty - gy0_) * static_cast<std::uint64_t>(nx_) +
           static_cast<std::uint64_t>(tx - gx0_);
  }
  void setTile(std::uint64_t cell, std::size_t t) {
    if (!grid_.empty()) {
      grid_[cell] = static_cast<std::int32_t>(t);
    } else {
      sparse_[cell] = static_cast<std::int32_t>(t);
    }
  }

  // the tile of a voxel of the map being built
  Tile tileOf(const Voxel& v) const { return {gx0_ + tile_x_(v.index.x()), gy0_ + tile_y_(v.index.y())}; }

  void resizePositions(std::size_t n) { ids_.resize(n), z_.resize(n), height_.resize(n), placed_.resize(n); }
  // puts voxel i, of tile t, at position q of its tile's voxels as placed
  void place(std::size_t q, std::uint32_t i, const Voxel& v, const Tile& t) {
    const auto local = static_cast<std::uint32_t>((v.index.y() - t.ty * k_) * k_ + (v.index.x() - t.tx * k_));
    placed_[q] = {i, local, v.index.z(), v.height};
  }

  // lays each tile's voxels as placed (first_[t] .. first_[t + 1]) out by column and z: a counting
  // sort by column, each voxel inserted by z among those of its column already laid out (a column
  // holds few voxels)
  void sortColumns() {
    const std::vector<std::uint32_t>& first = first_;
    const std::size_t kk = static_cast<std::size_t>(k_) * k_;
    columns_.resize(tiles_.size() * (kk + 1));
    range_.resize(2 * tiles_.size());
    tbb::parallel_for(std::size_t{0}, tiles_.size(), [&](std::size_t t) {
      thread_local std::vector<std::uint32_t> fill;
      const std::uint32_t b = first[t], e = first[t + 1];
      const Placed* const placed = placed_.data();
      std::uint32_t* const ids = ids_.data();
      std::int32_t* const zs = z_.data();
      float* const heights = height_.data();
      std::uint32_t* const col = columns_.data() + t * (kk + 1);
      std::fill(col, col + kk + 1, 0);
      for (std::uint32_t q = b; q < e; ++q) ++col[placed[q].local + 1];
      col[0] = b;
      for (std::size_t c = 0; c < kk; ++c) col[c + 1] += col[c];
      fill.assign(col, col + kk);
      std::uint32_t* const next = fill.data();
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      for (std::uint32_t q = b; q < e; ++q) {
        const Placed v = placed[q];
        const std::uint32_t start = col[v.local];
        std::uint32_t r = next[v.local]++;
        for (; r > start && zs[r - 1] > v.z; --r) ids[r] = ids[r - 1], zs[r] = zs[r - 1], heights[r] = heights[r - 1];
        ids[r] = v.id, zs[r] = v.z, heights[r] = v.height;
        lo = std::min(lo, v.height), hi = std::max(hi, v.height);
      }
      range_[2 * t] = lo, range_[2 * t + 1] = hi;
    });
  }

  // links the voxels of column [b, e) to those of the column [nb, ne) next to it along axis
  // (both sorted by z; empty if there is none): a merge. Voxels with no neighbour there get none.
  void linkColumns(GmrfProblem& p, const GroundSegmentationConfig& cfg, std::uint32_t b, std::uint32_t e,
                   std::uint32_t nb, std::uint32_t ne, int axis) const {
    for (; b < e; ++b) {
      while (nb < ne && z_[nb] < z_[b]) ++nb;
      if (nb < ne && z_[nb] == z_[b]) {
        p.link(b, axis, nb, pairWeight(cfg, height_[b], height_[nb]));
        ++nb;
      } else {
        p.next[3 * b + axis] = GmrfProblem::kNone, p.weight[3 * b + axis] = 0;
      }
    }
  }

  int k_ = 1;
  int gx0_ = 0, gy0_ = 0, nx_ = 0, ny_ = 0;                 // the grid of tiles over the layout's extent
  OffsetDivider tile_x_, tile_y_;                           // a voxel index's tile offset in the grid (whole map)
  std::vector<std::int32_t> grid_;                          // per grid cell: index in tiles_, or -1 (empty if sparse)
  std::unordered_map<std::uint64_t, std::int32_t> sparse_;  // grid cell -> index in tiles_, if sparse
  std::vector<Tile> tiles_;
  std::vector<std::uint32_t> columns_;  // k*k + 1 per tile: first position of each column
  std::vector<std::uint32_t> ids_;      // voxel id per position
  std::vector<std::int32_t> z_;         // voxel z index per position
  std::vector<float> height_;           // voxel height per position [m]
  // a voxel as placed in its tile, before its tile's voxels are laid out by column (while grouping)
  struct Placed {
    std::uint32_t id, local;  // voxel id, and its column in its tile (row-major)
    std::int32_t z;           // voxel z index
    float height;             // [m]
  };
  std::vector<Placed> placed_;          // per position as placed
  std::vector<float> range_;            // per tile: its lowest and highest voxel height [m]
  std::vector<std::uint32_t> first_;    // per tile and one past the last: its first position
  std::vector<std::uint32_t> scratch_;  // per chunk of voxels and grid cell: counts, then offsets (while grouping)
};

// The peak of the histogram of heights above a plane over a set of tiles of a layout: the offset
// that lifts the plane to the tiles' ground. One pass over the voxels: the residuals' range is
// bounded beforehand from each tile's lowest and highest voxel and the plane at its corner columns.
double residualPeak(const TileLayout& layout, const std::vector<std::size_t>& tiles, std::size_t centre,
                    const Plane& plane, double cell, double bin_size, int stride, PeakHistogram& histogram) {
  const int k = layout.k();
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t t : tiles) {
    const auto& tile = layout.tiles()[t];
    const double x0 = (tile.tx * k + 0.5) * cell, y0 = (tile.ty * k + 0.5) * cell, span = (k - 1) * cell;
    const double corners[4] = {plane.at(x0, y0), plane.at(x0 + span, y0), plane.at(x0, y0 + span),
                               plane.at(x0 + span, y0 + span)};
    lo = std::min(lo, layout.lowest(t) - *std::max_element(corners, corners + 4));
    hi = std::max(hi, layout.highest(t) - *std::min_element(corners, corners + 4));
  }
  // every stride-th column each way, or every column if that leaves too few voxels
  for (const int s : {stride, 1}) {
    histogram.reset(lo, hi, bin_size);
    for (std::size_t t : tiles) {
      const auto& tile = layout.tiles()[t];
      const int step = t == centre ? 1 : s;
      layout.forEachRow(
          t,
          [&](int ly, int lx0, const std::uint32_t* bounds) {
            const double at = plane.at((tile.tx * k + lx0 + 0.5) * cell, (tile.ty * k + ly + 0.5) * cell);
            histogram.addColumns(layout.heights(), bounds, k - lx0, step, at, plane.a * cell * step);
          },
          step);
    }
    if (histogram.total() >= kMinHistogram) break;
  }
  return histogram.peak();
}

// What a segmentation works in, kept from one call to the next so that its memory is reused.
struct Workspace {
  TileLayout layout;
  std::vector<Candidates> candidates;       // per tile of the layout
  std::vector<Plane> planes;                // per tile segmented
  GmrfProblem problem;                      // over the positions of the tiles segmented
  std::vector<std::uint8_t> rough, labels;  // per position: rough and refined labels
  MinCutSolver mincut;                      // with its flow graph
};

// The ground planes of tiles 0 .. count - 1 of the workspace's layout (h1 as a function of
// position): each fitted through the plane-fit candidates of the tiles of its window that are in
// the layout, and lifted to the peak of the window's heights above it. The whole-map and the
// incremental segmentation both take their planes from here.
void tilePlanes(Workspace& ws, std::size_t count, const GroundSegmentationConfig& cfg, double cell) {
  const TileLayout& layout = ws.layout;
  const int k = layout.k();
  const std::size_t tiles = layout.tiles().size();
  auto& candidates = ws.candidates;
  candidates.resize(tiles);
  tbb::parallel_for(std::size_t{0}, tiles, [&](std::size_t t) {
    // the lowest voxel of each column, in one pass along the tile's columns
    thread_local std::vector<float> lows;
    lows.resize(static_cast<std::size_t>(k) * k);
    layout.columnLows(t, lows.data());
    candidatesFromLows([&](std::size_t c) { return lows[c]; }, k, layout.tiles()[t].tx * k, layout.tiles()[t].ty * k,
                       cell, candidates[t]);
  });
  ws.planes.resize(count);
  tbb::parallel_for(std::size_t{0}, count, [&](std::size_t t) {
    std::vector<std::size_t> window;
    std::vector<const Candidates*> points;
    for (int dy = -cfg.tile_radius; dy <= cfg.tile_radius; ++dy) {
      for (int dx = -cfg.tile_radius; dx <= cfg.tile_radius; ++dx) {
        const std::int64_t u = layout.tileAt(layout.tiles()[t].tx + dx, layout.tiles()[t].ty + dy);
        if (u >= 0) window.push_back(static_cast<std::size_t>(u)), points.push_back(&candidates[u]);
      }
    }
    Plane plane = fitPlane(points);
    PeakHistogram histogram;
    plane.c += residualPeak(layout, window, t, plane, cell, cfg.bin_size, std::max(1, cfg.histogram_stride), histogram);
    ws.planes[t] = plane;
  });
}

// The problem and rough labels over the voxels of tiles 0 .. count - 1 of the workspace's layout
// (its first positions): single-site terms from each tile's ground plane, no backward links (the
// forward ones and the weights are left for linkNeighbours to set). Writes the voxels' ground
// heights and rough classes into out (by voxel id). edge(q, t, lx, ly, h) is called for every
// voxel q of a column on the edge of its tile t, to add the terms of neighbours held fixed.
template <class Edge>
void setUnaries(Workspace& ws, std::size_t count, double cell, const GroundSegmentationConfig& cfg,
                SegmentationResult& out, Edge&& edge) {
  const TileLayout& layout = ws.layout;
  const int k = layout.k();
  const std::size_t m = count < layout.tiles().size() ? layout.column(count, 0) : layout.size();
  // every node's fields are written below or by linkNeighbours: only the vectors' sizes are set here
  GmrfProblem& p = ws.problem;
  p.unary_ground.resize(m), p.unary_nonground.resize(m), p.parity.resize(m);
  p.next.resize(3 * m), p.prev.resize(3 * m), p.weight.resize(3 * m);
  ws.rough.resize(m);
  tbb::parallel_for(std::size_t{0}, count, [&](std::size_t t) {
    // arrays through pointers and settings by value held here: the compiler then need not read
    // them again after every store of a rough class (a byte, which may alias anything)
    float* const unary_ground = p.unary_ground.data();
    float* const unary_nonground = p.unary_nonground.data();
    std::uint8_t* const parity = p.parity.data();
    std::uint32_t* const prev = p.prev.data();
    std::uint8_t* const rough = ws.rough.data();
    float* const ground_height = out.ground_height.data();
    std::uint8_t* const rough_by_id = out.rough.data();
    const std::uint32_t* const ids = layout.ids();
    const std::int32_t* const zs = layout.zs();
    const float* const heights = layout.heights();
    const double delta = cfg.delta, range_margin = cfg.range_margin, alpha = cfg.alpha;
    const float stack_height = static_cast<float>(cfg.stack_height);
    // a stack's next voxel lies at most this many grid steps above the one below it
    const std::int32_t stack_step = 1 + static_cast<std::int32_t>(std::floor(cfg.stack_gap / cell + 1e-6));
    const double depth_below = cfg.depth_below;
    const Plane plane = ws.planes[t];
    const auto& tile = layout.tiles()[t];
    layout.forEachColumn(t, [&](int lx, int ly, std::uint32_t b, std::uint32_t e) {
      const int x = tile.tx * k + lx, y = tile.ty * k + ly;
      const double ground = plane.at((x + 0.5) * cell, (y + 0.5) * cell);
      const bool on_edge = lx == 0 || ly == 0 || lx == k - 1 || ly == k - 1;
      for (auto q = b; q < e; ++q) {
        const float h = heights[q];
        double d = h - ground;
        // the lowest voxel of its column, below the plane: nothing is seen under the ground
        if (q == b && d < -delta && d >= -depth_below) d = 0;
        Unary u = unary(d, delta, range_margin, alpha);
        // the foot of something upright: a stack of the column's voxels (sorted upwards) rises
        // from it, starting right above it and with gaps of at most stack_gap further up
        if (stack_height > 0) {
          for (auto r = q + 1; r < e && zs[r] <= zs[r - 1] + (r == q + 1 ? 1 : stack_step); ++r) {
            if (heights[r] - h > stack_height) {
              u = {false, static_cast<float>(2 * alpha)};
              break;
            }
          }
        }
        unary_ground[q] = u.ground, unary_nonground[q] = -u.ground;
        parity[q] = static_cast<std::uint8_t>((x + y + zs[q]) & 1);
        prev[3 * q] = prev[3 * q + 1] = prev[3 * q + 2] = GmrfProblem::kNone;
        rough[q] = u.g1;
        ground_height[ids[q]] = static_cast<float>(ground);
        rough_by_id[ids[q]] = u.g1;
        if (on_edge) edge(q, t, lx, ly, h);
      }
    });
  });
}

// The refined labels G1' of the workspace's problem, from its rough labels by the configured
// solver; sets the result's energies and ICM sweeps.
void refine(Workspace& ws, const GroundSegmentationConfig& cfg, SegmentationResult& out) {
  ws.labels = ws.rough;
  if (cfg.solver == GroundSegmentationConfig::Solver::MinCut) {
    out.energy_rough = gmrfEnergy(ws.problem, ws.rough);
    ws.mincut.solve(ws.problem, ws.labels);
    out.energy_refined = gmrfEnergy(ws.problem, ws.labels);
    out.iterations = 0;
  } else {
    // the problem is a grid's by construction (linkNeighbours): solved without solveIcm's check
    tbb::task_arena arena = arenaFor(cfg.threads);
#ifndef NDEBUG
    checkGrid(ws.problem, ws.labels.size(), arena);
#endif
    const IcmResult r = icm(ws.problem, ws.labels, cfg.icm_iterations, arena);
    out.energy_rough = r.energy_initial, out.energy_refined = r.energy_final;
    out.iterations = r.sweeps;
  }
}

// Segments every voxel of the map into out, working in ws.
void segmentWhole(const VoxelMap& map, const GroundSegmentationConfig& cfg, Workspace& ws, SegmentationResult& out) {
  const auto& voxels = map.voxels();
  const std::size_t n = voxels.size();
  // every voxel's entries are written below
  out.rough.resize(n);
  out.refined.resize(n);
  out.ground_height.resize(n);
  out.energy_rough = out.energy_refined = 0;
  out.iterations = out.tiles = 0;
  if (n == 0) return;
  const double cell = map.voxelSize();
  const int k = std::max(1, static_cast<int>(std::lround(cfg.tile_size / cell)));
  const bool global = cfg.histogram == GroundSegmentationConfig::Histogram::Global;
  tbb::task_arena arena = arenaFor(cfg.threads);
  arena.execute([&] {
    ws.layout.build(map, k);
    const std::size_t tiles = ws.layout.tiles().size();
    // h1: one plane per tile, fitted through the plane-fit candidates of the tiles in its window
    // and lifted to the peak of the window's heights above it; or one level for the whole map
    if (global) {
      std::vector<double> h(n);
      for (std::size_t i = 0; i < n; ++i) h[i] = voxels[i].height;
      ws.planes.assign(tiles, Plane{0, 0, histogramPeak(h, cfg.bin_size)});
      out.tiles = 1;
    } else {
      tilePlanes(ws, tiles, cfg, cell);
      out.tiles = static_cast<int>(tiles);
    }
    // the problem over positions of the layout
    setUnaries(ws, tiles, cell, cfg, out, [](std::uint32_t, std::size_t, int, int, float) {});
    ws.layout.linkNeighbours(ws.problem, cfg, tiles);
    refine(ws, cfg, out);
    // by chunks, through pointers held in locals (a label is a byte, whose store may alias anything)
    tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
      std::uint8_t* const refined = out.refined.data();
      const std::uint8_t* const labels = ws.labels.data();
      const std::uint32_t* const ids = ws.layout.ids();
      for (std::size_t q = n * c / kChunks, end = n * (c + 1) / kChunks; q < end; ++q) refined[ids[q]] = labels[q];
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
  Workspace ws;
  SegmentationResult out;
  segmentWhole(map, cfg, ws, out);
  return out;
}

struct GroundSegmenter::Work {
  Workspace ws;
};

GroundSegmenter::GroundSegmenter(const GroundSegmentationConfig& config)
    : config_(config), work_(std::make_unique<Work>()) {}

GroundSegmenter::~GroundSegmenter() = default;

const SegmentationResult& GroundSegmenter::segment(const VoxelMap& map) {
  segmentWhole(map, config_, work_->ws, result_);
  return result_;
}

// ---------------------------------------------------------------------------------------------
// incremental

namespace {

std::uint64_t tileKey(int tx, int ty) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(tx)) << 32) | static_cast<std::uint32_t>(ty);
}

// the tile coordinates of a key made by tileKey
std::pair<int, int> keyTile(std::uint64_t key) {
  return {static_cast<int>(static_cast<std::uint32_t>(key >> 32)), static_cast<int>(static_cast<std::uint32_t>(key))};
}

}  // namespace

struct IncrementalGroundSegmentation::State {
  GroundSegmentationConfig cfg;
  double cell = 0;
  int k = 0;     // columns per tile edge
  int base = 0;  // a tile corner's index below every index a map holds (+-2^20)
  struct Tile {
    int tx = 0, ty = 0;
    std::vector<std::uint32_t> ids;  // in id order
    std::size_t pending = 0;         // voxels added since it was last re-segmented
  };
  std::unordered_map<std::uint64_t, Tile> tiles;
  std::unordered_set<std::uint64_t> touched;
  std::size_t taken = 0;             // voxels already placed in tiles
  std::vector<std::uint64_t> fresh;  // the tile of each voxel added since the last update (while taking them in)
  SegmentationResult result;
  Stats stats;
  Workspace work;  // the last update's layout and subproblem, kept so that their memory is reused

  void setCell(double voxel_size) {
    if (cell == voxel_size) return;
    cell = voxel_size;
    k = std::max(1, static_cast<int>(std::lround(cfg.tile_size / cell)));
    base = floorDiv(-(1 << 20), k) * k;
  }

  // appends to out, in key order, the tiles of the map within `radius` tiles of any of these that
  // are not yet in seen (and adds them to it)
  void windows(const std::vector<std::uint64_t>& of, int radius, std::unordered_set<std::uint64_t>& seen,
               std::vector<std::uint64_t>& out) const {
    const std::size_t first = out.size();
    for (std::uint64_t key : of) {
      const auto [tx, ty] = keyTile(key);
      for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
          const std::uint64_t u = tileKey(tx + dx, ty + dy);
          if (tiles.count(u) && seen.insert(u).second) out.push_back(u);
        }
      }
    }
    std::sort(out.begin() + static_cast<std::ptrdiff_t>(first), out.end());
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
  // each chunk of points lists its tiles (successive points mostly fall in one), then the lists
  // go into the set
  const std::size_t n = points.size();
  std::vector<std::vector<std::uint64_t>> keys(kChunks);
  tbb::task_arena arena = arenaFor(st.cfg.threads);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
      std::vector<std::uint64_t>& out = keys[c];
      for (std::size_t i = n * c / kChunks; i < n * (c + 1) / kChunks; ++i) {
        const Point3& p = points[i];
        if (!p.allFinite()) continue;
        const double fx = std::floor(p.x() / st.cell), fy = std::floor(p.y() / st.cell);
        if (std::abs(fx) > 1e9 || std::abs(fy) > 1e9) continue;
        const std::uint64_t key = tileKey(floorDiv(static_cast<int>(fx), st.k), floorDiv(static_cast<int>(fy), st.k));
        if (out.empty() || key != out.back()) out.push_back(key);
      }
    });
  });
  for (const auto& list : keys) st.touched.insert(list.begin(), list.end());
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
  tbb::task_arena arena = arenaFor(cfg.threads);
  // take in the new voxels, run by run of successive voxels in one tile (most runs are long), their
  // tiles found in parallel first. A tile is due once its new voxels make up defer_share of its
  // voxels: a share that only grows as voxels are added, so whether a run made it due is known at
  // the run's end.
  const OffsetDivider divide(st.base, st.k);
  const int first_tile = st.base / st.k;
  std::vector<std::uint64_t>& fresh = st.fresh;
  fresh.resize(n - std::min(n, st.taken));
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, fresh.size(), [&](std::size_t i) {
      const VoxelIndex& index = voxels[st.taken + i].index;
      fresh[i] = tileKey(first_tile + divide(index.x()), first_tile + divide(index.y()));
    });
  });
  for (std::size_t i = 0; i < fresh.size();) {
    const std::uint64_t key = fresh[i];
    std::size_t end = i + 1;
    while (end < fresh.size() && fresh[end] == key) ++end;
    State::Tile& t = st.tiles[key];
    if (t.ids.empty()) std::tie(t.tx, t.ty) = keyTile(key);
    const auto due = [&] {
      return t.pending > 0 && static_cast<double>(t.pending) >= cfg.defer_share * static_cast<double>(t.ids.size());
    };
    const bool was_due = due();
    t.pending += end - i;
    const std::size_t had = t.ids.size();
    t.ids.resize(had + (end - i));
    std::iota(t.ids.begin() + static_cast<std::ptrdiff_t>(had), t.ids.end(), static_cast<std::uint32_t>(st.taken + i));
    if (!was_due && due()) st.touched.insert(key);
    i = end;
  }
  st.taken = n;
  SegmentationResult& out = st.result;
  out.rough.resize(n, 0);
  out.refined.resize(n, 0);
  out.ground_height.resize(n, 0.0f);
  st.stats.touched_tiles = st.touched.size();
  // the tiles whose window reaches a touched tile, in a fixed order
  std::vector<std::uint64_t> keys;
  std::unordered_set<std::uint64_t> seen;
  st.windows(std::vector<std::uint64_t>(st.touched.begin(), st.touched.end()), cfg.tile_radius, seen, keys);
  for (std::uint64_t key : st.touched) {
    auto it = st.tiles.find(key);
    if (it != st.tiles.end()) it->second.pending = 0;
  }
  st.touched.clear();
  st.stats.refitted_tiles = keys.size();
  if (keys.empty()) return;
  // the tiles to refit, then the other tiles of their windows (their voxels enter the planes) and
  // those next to them (their voxels' labels enter the pair terms)
  std::vector<std::uint64_t> context;
  st.windows(keys, std::max(1, cfg.tile_radius), seen, context);
  std::vector<TileLayout::Tile> tiles;
  std::vector<const std::vector<std::uint32_t>*> tile_ids;
  for (const auto* list : {&keys, &context}) {
    for (std::uint64_t key : *list) {
      const State::Tile& t = st.tiles.at(key);
      tiles.push_back({t.tx, t.ty}), tile_ids.push_back(&t.ids);
    }
  }
  const std::size_t count = keys.size();
  const int k = st.k;
  arena.execute([&] {
    Workspace& ws = st.work;
    ws.layout.build(voxels, k, tiles, tile_ids);
    const TileLayout& layout = ws.layout;
    tilePlanes(ws, count, cfg, st.cell);
    // the subproblem: every voxel of the refitted tiles, the first positions of the layout.
    // Neighbours in tiles outside it keep their labels: their pair terms become unary terms. Every
    // tile of the map next to a refitted one is in the layout, so such a neighbour is looked up in
    // its column there; a tile missing from the layout holds no voxel.
    GmrfProblem& p = ws.problem;
    const auto fixed = [&](std::uint32_t q, std::size_t t, int lx, int ly, float h) {
      const TileLayout::Tile& tile = tiles[t];
      static constexpr int kSteps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
      for (const auto& step : kSteps) {
        const int nx = lx + step[0], ny = ly + step[1];
        if (nx >= 0 && nx < k && ny >= 0 && ny < k) continue;
        const std::int64_t u = layout.tileAt(tile.tx + step[0], tile.ty + step[1]);
        if (u < 0 || static_cast<std::size_t>(u) < count) continue;
        const std::size_t c = static_cast<std::size_t>(floorMod(ny, k)) * k + static_cast<std::size_t>(floorMod(nx, k));
        const std::int32_t z = layout.z(q);
        std::uint32_t r = layout.column(u, c);
        const std::uint32_t e = layout.column(u, c + 1);
        while (r < e && layout.z(r) < z) ++r;
        if (r == e || layout.z(r) != z) continue;
        const float w = pairWeight(cfg, h, layout.height(r));
        const bool ground_r = out.refined[layout.id(r)] != 0;
        p.unary_ground[q] += ground_r ? -w : w;
        p.unary_nonground[q] += ground_r ? w : -w;
      }
    };
    setUnaries(ws, count, st.cell, cfg, out, fixed);
    const std::size_t m = ws.rough.size();
    st.stats.voxels = m;
    layout.linkNeighbours(p, cfg, count);
    refine(ws, cfg, out);
    out.tiles = static_cast<int>(st.tiles.size());
    // by chunks, through pointers held in locals (a label is a byte, whose store may alias anything)
    tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
      std::uint8_t* const refined = out.refined.data();
      Voxel* const voxel = voxels.data();
      const std::uint8_t* const labels = ws.labels.data();
      const std::uint32_t* const ids = layout.ids();
      for (std::size_t q = m * c / kChunks, end = m * (c + 1) / kChunks; q < end; ++q) {
        refined[ids[q]] = labels[q];
        voxel[ids[q]].label = labels[q] ? VoxelLabel::Ground : VoxelLabel::NonGround;
      }
    });
  });
}

}  // namespace terrain
