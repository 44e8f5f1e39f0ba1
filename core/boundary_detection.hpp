#pragma once
// Stage 5, 2D boundary detection (paper Sec. 4.1): the horizontal and vertical kernels of
// Figure 6 with constants a and b give Lx and Ly (Eqs. 2-3); the gradient magnitude
// sqrt(kx Lx^2 + ky Ly^2) (Eq. 4, kx < ky: vertical changes matter more) above a threshold marks
// boundary pixels; erosion then dilation (Eqs. 5-6) removes noise.

#include <opencv2/core/mat.hpp>

namespace terrain {

struct BoundaryDetectionConfig {
  double a = 1.0;           // kernel corner weight
  double b = 2.0;           // kernel centre-row/column weight
  double kx = 0.3;          // weight of horizontal change
  double ky = 1.0;          // weight of vertical change (> kx)
  double threshold = 60.0;  // gradient magnitude, grey levels (0-255 image)
  int erode_width = 5, erode_height = 1;   // [px] erosion mask: keeps horizontal runs of 5 px or more, drops specks
  int dilate_width = 3, dilate_height = 3; // [px] dilation mask
};

struct BoundaryImages {
  cv::Mat magnitude;  // CV_32FC1 gradient magnitude, Eq. 4
  cv::Mat raw;        // CV_8UC1 255 where magnitude > threshold (paper Fig. 7a, inverted)
  cv::Mat cleaned;    // CV_8UC1 after erosion and dilation (paper Fig. 7b, inverted)
};

// Boundary images of an RGB (CV_8UC3) or grey (CV_8UC1) image. Throws std::invalid_argument for
// an empty image or another pixel type.
BoundaryImages detectBoundaries(const cv::Mat& image, const BoundaryDetectionConfig& config);

}  // namespace terrain
