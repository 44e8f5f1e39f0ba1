#pragma once
// Stage 5, 2D boundary detection (paper Sec. 4.1): the horizontal and vertical kernels of
// Figure 6 with constants a and b give Lx and Ly (Eqs. 2-3); the gradient magnitude
// sqrt(kx Lx^2 + ky Ly^2) (Eq. 4, kx < ky: vertical changes matter more) above a threshold marks
// boundary pixels; erosion then dilation (Eqs. 5-6) removes noise.

#include <opencv2/core/mat.hpp>

namespace terrain {

struct BoundaryDetectionConfig {
  double a = 1.0;                           // kernel corner weight
  double b = 2.0;                           // kernel centre-row/column weight
  double kx = 0.3;                          // weight of horizontal change
  double ky = 1.0;                          // weight of vertical change (> kx)
  double threshold = 60.0;                  // gradient magnitude, grey levels (0-255 image)
  int erode_width = 5, erode_height = 1;    // [px] erosion mask: keeps horizontal runs of 5 px or more, drops specks
  int dilate_width = 3, dilate_height = 3;  // [px] dilation mask
  // Erode along four directions (0, 45, 90 and 135 degrees) with a line of erode_width px, each
  // followed by a dilation with the same line, and keep what survives in any: thin boundaries of
  // every direction that run at least erode_width px (the curved top of a tree crown, a sloping
  // roof line) stay, specks still go. Off: one erosion with the erode_width x erode_height mask,
  // which keeps only near-horizontal boundaries. Off by default: with clear_line on, 30 frames of
  // each terrain type (seed 1) gave a lower height error over the estimated cells on five of six
  // types with it off, though more building cells are raised with it on.
  bool erode_all_directions = false;
  // With the one erosion (erode_all_directions off), also keep what survives an erosion along a
  // line of erode_width px sloping at +-1/4, +-1/2 or +-1 rows per column: a roof line that
  // perspective slopes (a building beside the path, seen obliquely) stays, where the horizontal
  // mask left only dots of it and the topmost boundary above its walls fell on the facade's texture.
  // Sloping runs within 2 px of foliage-coloured pixels (looksLikeFoliage with foliage_margin; RGB
  // images) are left out: kept, the rounded tops of crowns behind a tree became its
  // top. On 60 frames of 12 scenes (urban seeds 1-5, forest 1-2, mixed 1-2, flat, slope, rough)
  // buildings at their real height went from 45 to 50 of 69 (6 gained on flat, mixed 1 and 2,
  // rough, slope and urban 2, one 41 m building lost on mixed 2), none more too high; trees
  // unchanged (123 of 332); the error over estimated cells fell on urban 1-5 (1.43 / 0.79 / 1.90 /
  // 2.31 / 2.43 m to 1.20 / 0.71 / 1.69 / 1.97 / 2.04 m), mixed 1-2 and rough, rose on flat
  // (0.47 -> 0.54 m), slope (0.63 -> 0.93 m) and forest 2 (5.98 -> 6.04 m); terrain cells raised by
  // mistake 895 -> 931. Without the foliage rule, 4 more trees stood too high.
  bool erode_sloping = true;
  int foliage_margin = 10;  // [grey levels] of the foliage colour rule, for erode_sloping
};

// The foliage colour rule for one RGB colour: green at least margin grey levels above both red and
// blue, as leaves in daylight.
bool looksLikeFoliage(const cv::Vec3b& rgb, int margin);
// The same rule over an RGB image (CV_8UC3): CV_8UC1, 255 where a pixel is foliage-coloured.
cv::Mat foliageMask(const cv::Mat& rgb, int margin);

struct BoundaryImages {
  cv::Mat magnitude;  // CV_32FC1 gradient magnitude, Eq. 4
  cv::Mat raw;        // CV_8UC1 255 where magnitude > threshold (paper Fig. 7a, inverted)
  cv::Mat cleaned;    // CV_8UC1 after erosion and dilation (paper Fig. 7b, inverted)
};

// Boundary images of an RGB (CV_8UC3) or grey (CV_8UC1) image. Throws std::invalid_argument for
// an empty image or another pixel type.
BoundaryImages detectBoundaries(const cv::Mat& image, const BoundaryDetectionConfig& config);

}  // namespace terrain
