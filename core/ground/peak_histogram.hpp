#pragma once
// The height histogram of the method (paper Eq. 18) and its peak h1, the ground height.

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

namespace terrain::ground {

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
  // skip_ends: the peak is not in an end bin (those hold the heights outside [lo, hi])
  double peak(bool skip_ends = false) const {
    int p = 0;
    std::int64_t best = -1;
    for (int b = skip_ends ? 1 : 0; b < (skip_ends ? bins_ - 1 : bins_); ++b) {
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

}  // namespace terrain::ground
