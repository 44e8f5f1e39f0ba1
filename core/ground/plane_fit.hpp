#pragma once
// The local ground plane of a tile (the local histogram's reference), fitted to the lowest voxel of
// every 2 x 2 block of its columns and its neighbours': by default to their lower envelope (least
// squares moved down to a low quantile of the points, then rounds that keep the points in a band
// reaching less far above the previous plane than below it), or by symmetric least squares in three
// rounds that keep the points near the previous plane.

#include "core/types.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace terrain::ground {

struct Plane {
  double a = 0, b = 0, c = 0;  // z = a x + b y + c
  double at(double x, double y) const { return a * x + b * y + c; }
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

// [m] how far a point may lie below and above a plane to be kept for the next round of a fit
struct Band {
  float below = 0, above = 0;
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

  // The moments of the candidates in band b0 about plane p0 and, if p1 is given, in band b1 about
  // p1 (planes in world coordinates).
  Moments near(const Plane& p0, Band b0, const Plane* p1 = nullptr, Band b1 = {}) const {
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
    const float below0 = b0.below, above0 = b0.above;
    const float below1 = p1 ? b1.below : std::numeric_limits<float>::infinity();
    const float above1 = p1 ? b1.above : std::numeric_limits<float>::infinity();
    const F4 zero = {0, 0, 0, 0}, one = zero + 1.0f, inf = zero + std::numeric_limits<float>::infinity();
    F4 n = zero, sx = zero, sy = zero, sz = zero, xx = zero, xy = zero, yy = zero, xz = zero, yz = zero, zmin = inf;
    for (std::size_t i = 0; i < x.size(); i += kLanes) {
      F4 px, py, pz;
      std::memcpy(&px, &x[i], sizeof px), std::memcpy(&py, &y[i], sizeof py), std::memcpy(&pz, &z[i], sizeof pz);
      const F4 r0 = pz - (q0[0] * px + q0[1] * py + q0[2]), r1 = pz - (q1[0] * px + q1[1] * py + q1[2]);
      const I4 keep = (r0 < above0) & (r0 > -below0) & (r1 < above1) & (r1 > -below1);
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

// The ground lies under everything else the lidar sees, so the plane may follow the candidates'
// lower envelope: least squares over all of them, moved down to their kEnvelopeQuantile of heights
// above it, then three rounds of least squares over the points in a band about the previous plane
// (kEnvelopeBands) that reaches less far above it than below. Symmetric least squares let a low
// flat structure, a wall's foot or bushes among sparse far ground pull the plane up: on the two real
// KITTI scans the ground beside a building's 0.7 m ledge and behind bushes at 35-45 m lay 0.5-2 m
// under it. But rolling ground and a ditch hold the lowest tenth of a window too, and there the
// envelope leaves the rest of the ground above the band (simulated rough ground, 60 frames of seed
// 25: min-cut F1 98.0 -> 95.0 %). So the envelope is taken only where more points lie within
// kSupportBand of it than of the symmetric fit.
constexpr double kEnvelopeQuantile = 0.1;
constexpr Band kEnvelopeBands[3] = {{0.3f, 0.5f}, {0.7f, 0.3f}, {0.5f, 0.2f}};
constexpr Band kSupportBand = {0.2f, 0.2f};

// The plane through the points of all the parts (the candidates of a tile's window): least squares
// in three rounds, each fitted to the points the previous plane left within 1.0 m, then 0.7 m (one
// pass over the points per round, the first one made beforehand); with envelope, their lower
// envelope (above) where it holds more of them.
inline Plane fitPlane(const std::vector<const Candidates*>& parts, bool envelope = true) {
  std::size_t n = 0;
  const Candidates* first = nullptr;
  for (const auto* part : parts) {
    if (!first && part->count > 0) first = part;
    n += part->count;
  }
  if (n < 3) return n == 0 ? Plane{} : Plane{0, 0, first->ref.z()};
  const Point3 ref = first->ref;
  Plane plane = sumAbout(parts, ref, [](const Candidates& c) { return c.all; }).plane(ref);
  const Plane symmetric = [&] {
    const Band within{1.0f, 1.0f};
    const Moments near1 = sumAbout(parts, ref, [&](const Candidates& c) { return c.near(plane, within); });
    if (near1.n < 3) return plane;
    const Plane plane1 = near1.plane(ref);
    const Moments near2 = sumAbout(parts, ref, [&](const Candidates& c) {
      return c.near(plane, within, &plane1, {0.7f, 0.7f});
    });
    return near2.n < 3 ? plane1 : near2.plane(ref);
  }();
  if (!envelope) return symmetric;
  // the points' heights above the plane, and its move down to their low quantile
  std::vector<float> above;
  above.reserve(n);
  for (const auto* part : parts) {
    const float base = static_cast<float>(part->ref.z() - plane.at(part->ref.x(), part->ref.y()));
    for (std::size_t i = 0; i < part->count; ++i)
      above.push_back(part->z[i] + base - static_cast<float>(plane.a * part->x[i] + plane.b * part->y[i]));
  }
  const auto nth = above.begin() + static_cast<std::ptrdiff_t>(kEnvelopeQuantile * static_cast<double>(n - 1));
  std::nth_element(above.begin(), nth, above.end());
  plane.c += *nth;
  for (const Band& band : kEnvelopeBands) {
    const Plane previous = plane;
    const Moments kept = sumAbout(parts, ref, [&](const Candidates& c) { return c.near(previous, band); });
    if (kept.n < 3) break;
    plane = kept.plane(ref);
  }
  // the envelope where it holds more of the points than the symmetric fit
  const auto support = [&](const Plane& p) {
    return sumAbout(parts, ref, [&](const Candidates& c) { return c.near(p, kSupportBand); }).n;
  };
  return support(plane) > support(symmetric) ? plane : symmetric;
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

}  // namespace terrain::ground
