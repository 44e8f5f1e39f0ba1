#include "core/boundary_detection.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace terrain {

bool looksLikeFoliage(const cv::Vec3b& c, int margin) {
  const int r = c[0], g = c[1], b = c[2];
  return g >= r + margin && g >= b + margin;
}

cv::Mat foliageMask(const cv::Mat& rgb, int margin) {
  if (rgb.type() != CV_8UC3) throw std::invalid_argument("foliage mask: expected an 8-bit RGB image");
  // in 16-bit signed arithmetic: g - r >= margin and g - b >= margin, whatever the margin's sign
  cv::Mat channels[3], r, g, b;
  cv::split(rgb, channels);
  channels[0].convertTo(r, CV_16S), channels[1].convertTo(g, CV_16S), channels[2].convertTo(b, CV_16S);
  return (g - r >= margin) & (g - b >= margin);
}

namespace {

// The boundary pixels that survive an erosion along a line of erode_width px (erode_height thick)
// sloping at +-1/4, +-1/2 or +-1 rows per column, less those within 2 px of a foliage-coloured
// pixel (an RGB image only).
cv::Mat slopingRuns(const cv::Mat& raw, const cv::Mat& image, const BoundaryDetectionConfig& c) {
  const int n = c.erode_width;
  cv::Mat runs = cv::Mat::zeros(raw.size(), CV_8UC1), part;
  for (const double slope : {0.25, -0.25, 0.5, -0.5, 1.0, -1.0}) {
    // row offset of each of the line's columns from its middle
    std::vector<int> dy(n);
    for (int x = 0; x < n; ++x) dy[x] = static_cast<int>(std::lround(slope * (x - 0.5 * (n - 1))));
    const int lo = *std::min_element(dy.begin(), dy.end()), hi = *std::max_element(dy.begin(), dy.end());
    cv::Mat mask = cv::Mat::zeros(hi - lo + c.erode_height, n, CV_8UC1);
    for (int x = 0; x < n; ++x) mask(cv::Rect(x, dy[x] - lo, 1, c.erode_height)).setTo(1);
    cv::erode(raw, part, mask, cv::Point(n / 2, -lo + c.erode_height / 2));
    runs |= part;
  }
  if (image.type() == CV_8UC3) {
    cv::Mat foliage;
    cv::dilate(foliageMask(image, c.foliage_margin), foliage,
               cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
    runs &= ~foliage;
  }
  return runs;
}

}  // namespace

BoundaryImages detectBoundaries(const cv::Mat& image, const BoundaryDetectionConfig& c) {
  if (image.empty()) throw std::invalid_argument("boundary detection: empty image");
  cv::Mat grey;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
  } else if (image.type() == CV_8UC1) {
    grey = image;
  } else {
    throw std::invalid_argument("boundary detection: expected an 8-bit RGB or grey image");
  }
  cv::Mat p;
  grey.convertTo(p, CV_32F);
  // Figure 6, with image rows growing downwards: Lx = right column - left column,
  // Ly = row above - row below (Eqs. 2 and 3)
  const cv::Mat horizontal = (cv::Mat_<float>(3, 3) << -c.a, 0, c.a, -c.b, 0, c.b, -c.a, 0, c.a);
  const cv::Mat vertical = (cv::Mat_<float>(3, 3) << c.a, c.b, c.a, 0, 0, 0, -c.a, -c.b, -c.a);
  cv::Mat lx, ly;
  cv::filter2D(p, lx, CV_32F, horizontal, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  cv::filter2D(p, ly, CV_32F, vertical, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  BoundaryImages out;
  cv::Mat lx2, ly2;
  cv::multiply(lx, lx, lx2, c.kx);
  cv::multiply(ly, ly, ly2, c.ky);
  cv::sqrt(lx2 + ly2, out.magnitude);
  out.raw = out.magnitude > c.threshold;
  // erosion drops isolated responses, dilation restores the boundaries that survive
  const cv::Mat dilate_mask = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(c.dilate_width, c.dilate_height));
  cv::Mat eroded;
  if (c.erode_all_directions) {
    const int n = c.erode_width;
    eroded = cv::Mat::zeros(out.raw.size(), CV_8UC1);
    cv::Mat line_h = cv::Mat::ones(1, n, CV_8UC1), line_v = cv::Mat::ones(n, 1, CV_8UC1);
    cv::Mat diag = cv::Mat::eye(n, n, CV_8UC1), anti;
    cv::flip(diag, anti, 1);
    cv::Mat opened;
    for (const cv::Mat* mask : {&line_h, &line_v, &diag, &anti}) {
      cv::morphologyEx(out.raw, opened, cv::MORPH_OPEN, *mask);
      eroded |= opened;
    }
  } else {
    cv::erode(out.raw, eroded, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(c.erode_width, c.erode_height)));
    if (c.erode_sloping) eroded |= slopingRuns(out.raw, image, c);
  }
  cv::dilate(eroded, out.cleaned, dilate_mask);
  return out;
}

}  // namespace terrain
