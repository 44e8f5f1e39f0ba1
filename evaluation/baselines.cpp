#include "evaluation/baselines.hpp"

#include <pcl/ModelCoefficients.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/progressive_morphological_filter.h>
#include <pcl/segmentation/sac_segmentation.h>
#include <tbb/parallel_for.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace terrain::eval {

namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr toCloud(const std::vector<Point3>& points) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(points.size());
  for (const auto& p : points)
    cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  return cloud;
}

}  // namespace

std::vector<std::uint8_t> groundByFixedBand(const std::vector<Point3>& points, const std::vector<Point3>& ground,
                                            double delta) {
  std::vector<std::uint8_t> out(points.size(), 0);
  if (ground.empty()) return out;
  // nearest trajectory position on a coarse grid of the trajectory: the trajectory is short, so a
  // linear scan over a thinned copy is enough
  std::vector<Point3> thin;
  for (const auto& g : ground) {
    if (thin.empty() || (g - thin.back()).head<2>().norm() > 0.5) thin.push_back(g);
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    double best = std::numeric_limits<double>::infinity(), z = 0;
    for (const auto& g : thin) {
      const double d = (points[i] - g).head<2>().squaredNorm();
      if (d < best) best = d, z = g.z();
    }
    out[i] = std::abs(points[i].z() - z) <= delta;
  }
  return out;
}

std::vector<std::uint8_t> groundByRansacPlane(const std::vector<Point3>& points, double distance_threshold) {
  std::vector<std::uint8_t> out(points.size(), 0);
  if (points.size() < 3) return out;
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setOptimizeCoefficients(true);
  seg.setModelType(pcl::SACMODEL_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setDistanceThreshold(distance_threshold);
  seg.setMaxIterations(200);
  seg.setInputCloud(toCloud(points));
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coefficients;
  seg.segment(inliers, coefficients);
  for (int i : inliers.indices) out[i] = 1;
  return out;
}

std::vector<std::uint8_t> groundByMorphologicalFilterPcl(const std::vector<Point3>& points,
                                                         const MorphologicalFilterConfig& c) {
  std::vector<std::uint8_t> out(points.size(), 0);
  if (points.empty()) return out;
  pcl::ProgressiveMorphologicalFilter<pcl::PointXYZ> pmf;
  pmf.setInputCloud(toCloud(points));
  pmf.setMaxWindowSize(c.max_window_size);
  pmf.setSlope(c.slope);
  pmf.setInitialDistance(c.initial_distance);
  pmf.setMaxDistance(c.max_distance);
  pmf.setCellSize(c.cell_size);
  std::vector<int> ground;
  pmf.extract(ground);
  for (int i : ground) out[i] = 1;
  return out;
}

namespace {

// Over a row of n values read with a stride, the minimum (or, with `larger`, the maximum) of the
// values lo[i] .. hi[i] for every i, where lo and hi never decrease: a monotone queue.
void slidingExtreme(const float* in, std::size_t stride, int n, const int* lo, const int* hi, float* out,
                    std::size_t out_stride, bool larger, std::vector<int>& queue) {
  queue.resize(static_cast<std::size_t>(n));
  int head = 0, tail = 0, next = 0;
  const auto better = [larger](float a, float b) { return larger ? a >= b : a <= b; };
  for (int i = 0; i < n; ++i) {
    for (; next <= hi[i]; ++next) {
      const float v = in[static_cast<std::size_t>(next) * stride];
      while (tail > head && better(v, in[static_cast<std::size_t>(queue[tail - 1]) * stride])) --tail;
      queue[tail++] = next;
    }
    while (queue[head] < lo[i]) ++head;
    out[static_cast<std::size_t>(i) * out_stride] = in[static_cast<std::size_t>(queue[head]) * stride];
  }
}

// The morphological opening of PCL's applyMorphologicalOperator (MORPH_OPEN) at window
// `resolution`: each point's height becomes the largest, over the points within half the window
// along x and along y (float bounds, inclusive, as PCL's octree box search tests them), of their
// smallest such height. Points that share an (x, y) share the result, so it is computed on the grid
// of the points' distinct x and y coordinates, one sliding window per row and per column. False,
// with nothing computed, if that grid would exceed `max_cells` (points scattered in x and y, as a
// raw scan's are).
bool openOnGrid(const std::vector<float>& x, const std::vector<float>& y, const std::vector<float>& z, float resolution,
                std::size_t max_cells, std::vector<float>& opened) {
  std::vector<float> xs(x), ys(y);
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  std::sort(ys.begin(), ys.end());
  ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
  const std::size_t nx = xs.size(), ny = ys.size();
  if (nx * ny > max_cells) return false;
  const float half = resolution / 2.0f;
  // each coordinate's window: the first and last coordinate c with c >= v - half and c <= v + half
  const auto windows = [half](const std::vector<float>& v, std::vector<int>& lo, std::vector<int>& hi) {
    lo.resize(v.size()), hi.resize(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) {
      const float a = v[i] - half, b = v[i] + half;
      lo[i] = static_cast<int>(std::lower_bound(v.begin(), v.end(), a) - v.begin());
      hi[i] = static_cast<int>(std::upper_bound(v.begin(), v.end(), b) - v.begin()) - 1;
    }
  };
  std::vector<int> xlo, xhi, ylo, yhi;
  windows(xs, xlo, xhi);
  windows(ys, ylo, yhi);
  // the grid, row ix holding the ny cells of x = xs[ix]
  std::vector<std::size_t> cell(x.size());
  constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<float> grid(nx * ny, kInf), pass(nx * ny);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const std::size_t ix = static_cast<std::size_t>(std::lower_bound(xs.begin(), xs.end(), x[i]) - xs.begin());
    const std::size_t iy = static_cast<std::size_t>(std::lower_bound(ys.begin(), ys.end(), y[i]) - ys.begin());
    cell[i] = ix * ny + iy;
    grid[cell[i]] = std::min(grid[cell[i]], z[i]);
  }
  std::vector<int> queue;
  const auto box = [&](bool larger) {
    const int sx = static_cast<int>(nx), sy = static_cast<int>(ny);
    for (std::size_t ix = 0; ix < nx; ++ix)
      slidingExtreme(&grid[ix * ny], 1, sy, ylo.data(), yhi.data(), &pass[ix * ny], 1, larger, queue);
    for (std::size_t iy = 0; iy < ny; ++iy)
      slidingExtreme(&pass[iy], ny, sx, xlo.data(), xhi.data(), &grid[iy], ny, larger, queue);
  };
  // erosion: empty cells hold +inf and never win a minimum
  box(false);
  // dilation of the eroded heights of the occupied cells only: the others hold -inf
  std::vector<std::uint8_t> occupied(nx * ny, 0);
  for (std::size_t c : cell) occupied[c] = 1;
  for (std::size_t c = 0; c < grid.size(); ++c) {
    if (!occupied[c]) grid[c] = -kInf;
  }
  box(true);
  opened.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) opened[i] = grid[cell[i]];
  return true;
}

// The same opening for points in general position (a raw scan), exact as well. The points are
// bucketed on a grid of cells an eighth of the half window wide. A window's box covers whole cells
// in its interior: a point's cell index is a non-decreasing function of its coordinate, so a point
// in a cell strictly between those of the box's two bounds lies strictly between the bounds. Those
// cells are read by rows from a sparse table of the rows' cell extremes. On the box's edge columns
// (rows) only the bound across them is to be tested: the cell's points sorted along x (y) with the
// extreme of every prefix and suffix answer it by one binary search. The four corner cells are
// tested point by point. Far fewer points are touched than PCL's octree visits.
class ScatteredOpening {
 public:
  ScatteredOpening(const std::vector<float>& x, const std::vector<float>& y, float half) : x_(x), y_(y), half_(half) {
    const std::size_t n = x.size();
    const auto [x_lo, x_hi] = std::minmax_element(x.begin(), x.end());
    const auto [y_lo, y_hi] = std::minmax_element(y.begin(), y.end());
    x0_ = *x_lo, y0_ = *y_lo;
    // cells an eighth of the half window, coarser where that would make the grid too large
    const std::size_t max_cells = std::max<std::size_t>(std::size_t{1} << 20, 8 * n);
    cell_ = std::max(static_cast<double>(half) / 8, 1e-6);
    for (;; cell_ *= 2) {
      const double nx = std::floor((static_cast<double>(*x_hi) - x0_) / cell_) + 1;
      const double ny = std::floor((static_cast<double>(*y_hi) - y0_) / cell_) + 1;
      if (nx * ny <= static_cast<double>(max_cells)) {
        nx_ = static_cast<std::size_t>(nx), ny_ = static_cast<std::size_t>(ny);
        break;
      }
    }
    // the points by cell (row-major, y rows), within a cell once along x and once along y
    std::vector<std::size_t> cell_of(n);
    start_.assign(nx_ * ny_ + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
      cell_of[i] = cellY(y[i]) * nx_ + cellX(x[i]);
      ++start_[cell_of[i] + 1];
    }
    std::partial_sum(start_.begin(), start_.end(), start_.begin());
    by_x_.resize(n);
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) by_x_[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
    by_y_ = by_x_;
    for (std::size_t c = 0; c + 1 < start_.size(); ++c) {
      const auto b = start_[c], e = start_[c + 1];
      if (e - b < 2) continue;
      std::sort(by_x_.begin() + b, by_x_.begin() + e,
                [&](std::uint32_t i, std::uint32_t j) { return x[i] < x[j] || (x[i] == x[j] && i < j); });
      std::sort(by_y_.begin() + b, by_y_.begin() + e,
                [&](std::uint32_t i, std::uint32_t j) { return y[i] < y[j] || (y[i] == y[j] && i < j); });
    }
    xs_.resize(n), ys_.resize(n);
    for (std::size_t k = 0; k < n; ++k) xs_[k] = x[by_x_[k]], ys_[k] = y[by_y_[k]];
  }

  // For every point, the smallest (largest, with `larger`) value over the points in its box.
  void extreme(const std::vector<float>& value, bool larger, std::vector<float>& out) {
    const std::size_t n = value.size(), cells = nx_ * ny_;
    const float none = larger ? -std::numeric_limits<float>::infinity() : std::numeric_limits<float>::infinity();
    const auto pick = [larger](float a, float b) { return ScatteredOpening::pick(larger, a, b); };
    // prefix and suffix extremes within each cell, along x and along y
    pre_x_.resize(n), suf_x_.resize(n), pre_y_.resize(n), suf_y_.resize(n);
    table_.assign(1, std::vector<float>(cells, none));
    std::vector<float>& level0 = table_[0];
    for (std::size_t c = 0; c < cells; ++c) {
      const auto b = start_[c], e = start_[c + 1];
      if (b == e) continue;
      float px = none, py = none;
      for (auto k = b; k < e; ++k) {
        px = pre_x_[k] = pick(px, value[by_x_[k]]);
        py = pre_y_[k] = pick(py, value[by_y_[k]]);
      }
      float sx = none, sy = none;
      for (auto k = e; k-- > b;) {
        sx = suf_x_[k] = pick(sx, value[by_x_[k]]);
        sy = suf_y_[k] = pick(sy, value[by_y_[k]]);
      }
      level0[c] = px;
    }
    // sparse table along rows: level j holds the extreme of 2^j cells from each cell on, up to the
    // widest interior a box can have
    const std::size_t widest = std::min(nx_, static_cast<std::size_t>(std::ceil(2.0 * half_ / cell_)) + 2);
    for (std::size_t span = 2; span <= widest; span *= 2) {
      const std::vector<float>& below = table_.back();
      std::vector<float> level(cells, none);
      for (std::size_t r = 0; r < ny_; ++r) {
        for (std::size_t cx = 0; cx + span <= nx_; ++cx)
          level[r * nx_ + cx] = pick(below[r * nx_ + cx], below[r * nx_ + cx + span / 2]);
      }
      table_.push_back(std::move(level));
    }
    out.resize(n);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) { out[i] = query(i, value, larger, none); });
  }

 private:
  // the cell index of coordinate v along an axis starting at `origin` with n cells
  std::size_t cellOf(float v, double origin, std::size_t n) const {
    const double c = std::floor((static_cast<double>(v) - origin) / cell_);
    return c <= 0 ? 0 : std::min(n - 1, static_cast<std::size_t>(c));
  }
  std::size_t cellX(float v) const { return cellOf(v, x0_, nx_); }
  std::size_t cellY(float v) const { return cellOf(v, y0_, ny_); }
  static float pick(bool larger, float a, float b) { return larger ? std::max(a, b) : std::min(a, b); }

  float query(std::size_t i, const std::vector<float>& value, bool larger, float none) const {
    const auto pick = [larger](float a, float b) { return ScatteredOpening::pick(larger, a, b); };
    // PCL's box, in float
    const float ax = x_[i] - half_, bx = x_[i] + half_, ay = y_[i] - half_, by = y_[i] + half_;
    const std::size_t cx0 = cellX(ax), cx1 = cellX(bx), cy0 = cellY(ay), cy1 = cellY(by);
    float best = none;
    const auto scan = [&](std::size_t cx, std::size_t cy) {
      const std::size_t c = cy * nx_ + cx;
      for (auto k = start_[c]; k < start_[c + 1]; ++k) {
        const std::uint32_t j = by_x_[k];
        if (x_[j] >= ax && x_[j] <= bx && y_[j] >= ay && y_[j] <= by) best = pick(best, value[j]);
      }
    };
    if (cx1 - cx0 < 2 || cy1 - cy0 < 2) {
      for (std::size_t cy = cy0; cy <= cy1; ++cy) {
        for (std::size_t cx = cx0; cx <= cx1; ++cx) scan(cx, cy);
      }
      return best;
    }
    // interior rows: whole cells
    const std::size_t width = cx1 - cx0 - 1;
    std::size_t level = 0;
    while ((std::size_t{2} << level) <= width) ++level;
    const std::vector<float>& t = table_[level];
    const std::size_t left = cx0 + 1, right = cx1 - (std::size_t{1} << level);
    for (std::size_t cy = cy0 + 1; cy < cy1; ++cy) best = pick(best, pick(t[cy * nx_ + left], t[cy * nx_ + right]));
    // edge cells: only the bound across them is tested, on their points sorted along it
    const auto from = [&](const std::vector<float>& along, const std::vector<float>& suffix, std::size_t c,
                          float bound) {
      const auto k = std::lower_bound(along.begin() + start_[c], along.begin() + start_[c + 1], bound) - along.begin();
      if (static_cast<std::size_t>(k) < start_[c + 1]) best = pick(best, suffix[k]);
    };
    const auto upTo = [&](const std::vector<float>& along, const std::vector<float>& prefix, std::size_t c,
                          float bound) {
      const auto k = std::upper_bound(along.begin() + start_[c], along.begin() + start_[c + 1], bound) - along.begin();
      if (static_cast<std::size_t>(k) > start_[c]) best = pick(best, prefix[k - 1]);
    };
    for (std::size_t cy = cy0 + 1; cy < cy1; ++cy)
      from(xs_, suf_x_, cy * nx_ + cx0, ax), upTo(xs_, pre_x_, cy * nx_ + cx1, bx);
    for (std::size_t cx = cx0 + 1; cx < cx1; ++cx)
      from(ys_, suf_y_, cy0 * nx_ + cx, ay), upTo(ys_, pre_y_, cy1 * nx_ + cx, by);
    scan(cx0, cy0), scan(cx1, cy0), scan(cx0, cy1), scan(cx1, cy1);
    return best;
  }

  const std::vector<float>& x_;
  const std::vector<float>& y_;
  float half_;
  double x0_ = 0, y0_ = 0, cell_ = 1;
  std::size_t nx_ = 1, ny_ = 1;
  std::vector<std::size_t> start_;          // per cell, its first entry in by_x_ and by_y_
  std::vector<std::uint32_t> by_x_, by_y_;  // point ids by cell, along x / along y within it
  std::vector<float> xs_, ys_;              // their coordinates in that order
  std::vector<float> pre_x_, suf_x_, pre_y_, suf_y_;
  std::vector<std::vector<float>> table_;
};

// PCL's opening (as openOnGrid) of points in general position.
void openScattered(const std::vector<float>& x, const std::vector<float>& y, const std::vector<float>& z,
                   float resolution, std::vector<float>& opened) {
  opened.clear();
  if (x.empty()) return;
  ScatteredOpening boxes(x, y, resolution / 2.0f);
  std::vector<float> eroded;
  boxes.extreme(z, false, eroded);
  boxes.extreme(eroded, true, opened);
}

}  // namespace

std::vector<std::uint8_t> groundByMorphologicalFilter(const std::vector<Point3>& points,
                                                      const MorphologicalFilterConfig& c) {
  std::vector<std::uint8_t> out(points.size(), 0);
  if (points.empty()) return out;
  for (const Point3& p : points) {
    if (!p.cast<float>().allFinite()) return groundByMorphologicalFilterPcl(points, c);
  }
  // PCL's series of windows and height thresholds (exponential windows of base 2), in its float
  // arithmetic
  std::vector<float> windows, thresholds;
  for (int iteration = 0; windows.empty() || windows.back() < c.max_window_size; ++iteration) {
    // (std::pow of a float and an int is taken in double, as in PCL)
    const float window = static_cast<float>(c.cell_size * (2.0f * std::pow(2.0f, iteration) + 1.0f));
    float threshold =
        iteration == 0 ? c.initial_distance : c.slope * (window - windows.back()) * c.cell_size + c.initial_distance;
    threshold = std::min(threshold, c.max_distance);
    windows.push_back(window), thresholds.push_back(threshold);
  }
  // the points still taken for ground, in input order, and their coordinates as PCL holds them
  std::vector<std::size_t> ground(points.size());
  std::iota(ground.begin(), ground.end(), std::size_t{0});
  std::vector<float> x, y, z, opened;
  for (std::size_t i = 0; i < windows.size(); ++i) {
    x.resize(ground.size()), y.resize(ground.size()), z.resize(ground.size());
    for (std::size_t k = 0; k < ground.size(); ++k) {
      const Point3& p = points[ground[k]];
      x[k] = static_cast<float>(p.x()), y[k] = static_cast<float>(p.y()), z[k] = static_cast<float>(p.z());
    }
    if (!openOnGrid(x, y, z, windows[i], std::max<std::size_t>(std::size_t{1} << 22, 16 * points.size()), opened))
      openScattered(x, y, z, windows[i], opened);
    std::vector<std::size_t> kept;
    for (std::size_t k = 0; k < ground.size(); ++k) {
      if (z[k] - opened[k] < thresholds[i]) kept.push_back(ground[k]);
    }
    ground.swap(kept);
  }
  for (std::size_t i : ground) out[i] = 1;
  return out;
}

cv::Mat inpaintHeights(const cv::Mat& heights, int radius) {
  cv::Mat filled = heights.clone(), mask(heights.size(), CV_8UC1, cv::Scalar(0));
  cv::Mat known(heights.size(), CV_8UC1, cv::Scalar(0));
  for (int r = 0; r < heights.rows; ++r) {
    for (int c = 0; c < heights.cols; ++c) {
      const float h = heights.at<float>(r, c);
      if (std::isfinite(h))
        known.at<std::uint8_t>(r, c) = 255;
      else
        filled.at<float>(r, c) = 0.0f;
    }
  }
  // holes near data only: the dilated data mask minus the data
  cv::Mat near;
  cv::dilate(known, near, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius + 1, 2 * radius + 1)));
  mask = near & ~known;
  cv::Mat out;
  cv::inpaint(filled, mask, out, radius, cv::INPAINT_TELEA);
  for (int r = 0; r < out.rows; ++r) {
    for (int c = 0; c < out.cols; ++c) {
      if (!near.at<std::uint8_t>(r, c)) out.at<float>(r, c) = std::numeric_limits<float>::quiet_NaN();
    }
  }
  return out;
}

}  // namespace terrain::eval
