#pragma once
// Stage 6d, free space from the sky (beyond the paper): every sky pixel of every camera image is a
// ray through free space. An object that stands on the ground up to its top (a building, a wall, a
// trunk) does not reach above a ray that passes over its cell, so the lowest such ray over a cell
// bounds from above the height of a solid object there (the upper surface of a visual hull carved
// by the sky). A crown is no such object: a ray may pass under it to the sky, so the bound holds
// only where the lidar sensed the object from the ground up, its vertices labelled non-ground; the
// ground vertices that crown completion raises keep their height. At the end of the run the bound
// lowers every recovered height of a sensed object that lies above it (an estimate taken from a
// taller object behind). It only lowers, never raises, and never below what the lidar sensed.
//
// Per image column only the lowest sky pixel of each run of sky pixels is cast: the pixels above it
// in the column pass higher over much the same cells. A ray is followed over the ground from
// min_distance to max_distance (horizontally) in steps of half a cell.

#include "core/boundary_estimation.hpp"
#include "core/sensor_data.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"

#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

namespace terrain {

struct FreeSpaceConfig {
  // Off by default. On 60 frames with the surround rig (flat, slope, rough and urban, seeds 3 and 4)
  // it lowered about half the raised object vertices that have a ceiling: the object-cell error
  // went from 10.78 to 11.08 m (mean of the eight runs) and the trees at their real height from 119
  // to 101, for fewer objects too high (31 -> 22) and the same terrain raised by mistake. The
  // vertices the lidar sensed of a tree (its trunk, the underside of its crown) are not solid from
  // the ground up, and rays pass under or beside them. Applied to every vertex (the ground that
  // crown completion raises too), it took the error over the six terrain types from 11.1 to 13.5 m.
  bool enabled = false;
  double min_distance = 1.0;   // [m] horizontally from the camera: nearer cells are the robot's
  double max_distance = 80.0;  // [m] horizontally from the camera: a ray is followed this far
  // [m] a bound is the ray's height plus this margin: a sky pixel's ray passes up to half a pixel
  // above the edge it grazes, and the pose is off by a few centimetres and a few tenths of a degree
  double margin = 0.5;
};

// The lowest free-space ray over each cell of the map's grid, gathered image by image.
class SkyCeiling {
 public:
  // cell_size: the map's voxel size [m]
  explicit SkyCeiling(double cell_size);

  // Casts the sky pixels of one image (rgb CV_8UC3, RGB) taken from world_from_camera. Sky is the
  // sky test of boundary estimation (its sky_blue_margin and sky_min_brightness). Returns the number
  // of rays cast.
  int carve(const cv::Mat& rgb, const CameraIntrinsics& intrinsics, const Pose& world_from_camera,
            const FreeSpaceConfig& config, const BoundaryEstimationConfig& sky);

  // [m] the lowest ray over the cell plus the margin; +infinity where no ray passed over it.
  float ceiling(const CellIndex& cell) const;

  // Sets the ceiling (MeshVertex::ceiling) of every vertex whose top voxel is labelled non-ground
  // from its cell's (the others' stays +inf): a raised vertex whose recovered height lies above it
  // stands at the ceiling (never below its sensed height). Returns the number of raised vertices the
  // ceiling lowers.
  int apply(TerrainMesh& mesh, const VoxelMap& map) const;

  // cells with a finite ceiling
  std::size_t cells() const;

 private:
  static constexpr int kTile = 64;  // cells per tile side
  using Tile = std::vector<float>;  // kTile * kTile ceilings, row-major, +inf where none
  static std::int64_t tileKey(int tx, int ty) {
    return (static_cast<std::int64_t>(tx) << 32) ^ static_cast<std::uint32_t>(ty);
  }
  Tile& tile(int tx, int ty);

  double cell_;
  std::unordered_map<std::int64_t, std::unique_ptr<Tile>> tiles_;
};

}  // namespace terrain
