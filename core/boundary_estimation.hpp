#pragma once
// Stage 6, 3D boundary estimation (paper Sec. 4.2): non-ground mesh vertices are projected into
// the camera image; above each, the topmost boundary pixel of the object is searched in the
// boundary image; its inverse projection (Eqs. 7-8) at the vertex's fixed (x, y) gives the true
// height, and the vertex is raised. Estimates from later frames are kept and fused (median), so
// the shape is refined as the robot moves on (paper Fig. 14b).

#include "core/boundary_detection.hpp"
#include "core/sensor_data.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"

namespace terrain {

struct BoundaryEstimationConfig {
  double max_distance = 100.0;   // [m] vertices farther from the camera are not estimated
  double max_height = 60.0;      // [m] above the sensed top: larger estimates are rejected
  int top_margin = 2;            // [px] a boundary this close to the image top may be cut: skipped
  std::size_t max_estimates = 15;  // estimates kept per vertex
  double fusion_quantile = 0.5;    // the fused height is this quantile of the kept estimates (0.5: median)
};

struct BoundaryEstimationStats {
  int projected = 0;  // non-ground vertices that fell inside the image
  int estimated = 0;  // of which received a height estimate
};

// One frame: camera pose world_from_camera at the image time, the cleaned boundary image.
BoundaryEstimationStats estimateBoundaries(TerrainMesh& mesh, const VoxelMap& map, const cv::Mat& boundary,
                                           const CameraIntrinsics& intrinsics, const Pose& world_from_camera,
                                           const BoundaryEstimationConfig& config);

}  // namespace terrain
