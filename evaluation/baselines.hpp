#pragma once
// Baselines scored beside the paper's method, in the same run.
//  Ground (label 1 = ground per point):
//   - fixed band: ground within +-delta of the ground under the robot (sensor height minus mast),
//     the paper's starting point;
//   - PCL's RANSAC plane (pcl::SACSegmentation, plane model): the dominant plane's inliers;
//   - PCL's ProgressiveMorphologicalFilter.
//  Heights: hole filling of the sensed height map by inpainting (OpenCV, Telea), what
//  elevation-mapping tools do.

#include "core/types.hpp"

#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <vector>

namespace terrain::eval {

// Points whose height lies within +-delta of the ground height at the nearest of the given
// ground positions (the vehicle origins along the trajectory).
std::vector<std::uint8_t> groundByFixedBand(const std::vector<Point3>& points,
                                            const std::vector<Point3>& ground_positions, double delta);

// Inliers of the best plane by RANSAC within distance_threshold [m].
std::vector<std::uint8_t> groundByRansacPlane(const std::vector<Point3>& points, double distance_threshold);

struct MorphologicalFilterConfig {
  int max_window_size = 8;        // [cells]: windows 3, 5, 9 (PCL's series 2 * 2^k + 1 up to the first >= 8;
                                  // small, as walls in a voxel map are thin shells)
  float slope = 0.7f;             // terrain slope [m/m]
  float initial_distance = 0.3f;  // [m]
  float max_distance = 2.5f;      // [m]
  float cell_size = 1.0f;         // [m] (PCL's default)
};
// PCL's ProgressiveMorphologicalFilter, with PCL's default exponential windows (base 2). Points
// that lie on a grid of shared x and y coordinates (the columns of a voxel map) are filtered on that
// grid with the same result, far faster: PCL searches its octree once per point and window. Other
// point sets (a raw scan) are bucketed on a fine grid whose boxes are answered from whole cells and
// sorted edge cells, again with PCL's labels. Points with a non-finite coordinate go to PCL itself.
std::vector<std::uint8_t> groundByMorphologicalFilter(const std::vector<Point3>& points,
                                                      const MorphologicalFilterConfig& config);
// The same, always by PCL (the reference the grid is tested against).
std::vector<std::uint8_t> groundByMorphologicalFilterPcl(const std::vector<Point3>& points,
                                                         const MorphologicalFilterConfig& config);

// Fills the NaN cells of a height map (CV_32FC1) that lie within `radius` cells of data.
cv::Mat inpaintHeights(const cv::Mat& heights, int radius);

}  // namespace terrain::eval
