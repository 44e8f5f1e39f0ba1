#pragma once
// Stage 6c, crown completion (beyond the paper): with the lidar capped a little above the sensor, a
// tree is a trunk; the ground under its crown is sensed and labelled ground, so boundary estimation,
// which raises non-ground vertices, never reaches the crown. Each frame, every trunk-sized object
// the camera sees is followed up its image column while the pixels are not sky: the last non-sky
// pixel is the crown's top (unless another sensed object may own it: the clear-line test of boundary
// estimation), and the largest distance from the column to the nearer end of the non-sky run around
// it, row by row while sky bounds the run on both sides, is the crown's radius at the trunk's depth.
// Only crowns against the sky are measured: where a building or another crown stands behind, the
// run does not end in sky (or jumps outwards), and where another trunk stands under the run nearer
// its centre, or the widest run is centred away from the column, the crown is another tree's; the
// frame gives no sample. At the end of the run, a tree with enough samples raises the ground
// vertices within its crown radius to a spherical cap of that radius whose top is the crown's top
// height (the median of the samples).

#include "core/boundary_estimation.hpp"
#include "core/sensor_data.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"

#include <opencv2/core/mat.hpp>

#include <unordered_map>
#include <vector>

namespace terrain {

struct CrownConfig {
  // On 60 frames of 12 scenes (urban seeds 1-5, forest 1-2, mixed 1-2, flat, slope, rough) it raised
  // ground under 6 trees on 4 of them: the error over the tree cells the camera saw went 11.07 ->
  // 8.98 m (urban 1), 13.93 -> 13.75 (urban 2), 11.78 -> 11.45 (urban 5), 15.17 -> 14.99 (forest 1),
  // with one more terrain cell away from any object raised (urban 2). Crowns that touch in the image
  // (most of a forest's) give no sample.
  bool enabled = true;
  double max_trunk_width = 1.2;  // [m] objects wider than this (either way) are not trunks
  double min_radius = 0.6;       // [m] a narrower top is a pole's, not a crown
  double max_radius = 8.0;       // [m] wider runs are not one crown
  int min_samples = 3;           // frames that must have measured a crown
  double max_top_spread = 0.1;   // interquartile range of the crown top samples, share of their median
  double min_baseline = 4.0;     // [m] the samples' camera positions must spread this far: a crown
                                 // behind the column moves against the trunk only with parallax
  int min_height_px = 3;         // [px] non-sky rows needed above the trunk's top
  double max_offcentre = 0.2;    // the widest run's centre may lie this share of its width (+1 px)
                                 // beside the trunk's column; farther, the run is another crown
};

// The crown samples of the trunks, gathered frame by frame.
class CrownSampler {
 public:
  // One frame: rgb (CV_8UC3, RGB), the camera pose at the image time. Sky is judged with the sky
  // test of boundary estimation (its sky_blue_margin and sky_min_brightness); with its clear_line on,
  // a crown top that another sensed object may own (SkylineOwners, up to its max_distance) gives no
  // sample. owners: the mesh's objects around the camera with a reach of at least ownersReach(),
  // their tops up to date (SkylineOwners::refreshTops after this frame's estimates); nullptr: built
  // here. Returns the number of crowns measured.
  int measure(const TerrainMesh& mesh, const VoxelMap& map, const cv::Mat& rgb, const CameraIntrinsics& intrinsics,
              const Pose& world_from_camera, const CrownConfig& config, const BoundaryEstimationConfig& estimation,
              const SkylineOwners* owners = nullptr);
  // [m] the reach of the SkylineOwners that measure() uses: a trunk within max_distance and the far
  // side of its crown
  static double ownersReach(const CrownConfig& config, const BoundaryEstimationConfig& estimation);

  // At the end of the run: raises the ground vertices under each trunk with min_samples samples
  // (MeshVertex::spread, as spreadEstimates does). Returns the number of vertices raised.
  int apply(TerrainMesh& mesh, const VoxelMap& map, const CrownConfig& config) const;

  // trunks with samples
  std::size_t trunks() const { return samples_.size(); }

 private:
  struct Sample {
    float top = 0;           // [m] crown top height
    float radius = 0;        // [m]
    Eigen::Vector2f camera;  // [m] where the camera was (x, y)
  };
  std::unordered_map<std::uint32_t, std::vector<Sample>> samples_;  // by the trunk's lowest vertex id
};

}  // namespace terrain
