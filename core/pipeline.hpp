#pragma once
// The pipeline: pose -> voxel map -> terrain mesh -> ground segmentation -> 2D boundary detection
// -> 3D boundary estimation (and crown samples), one sensor frame at a time; at finish() the whole-map
// segmentation, footprint completion, crown completion, the crowns' visual hull and the sky's ceiling. It reads only
// SensorFrame and the rig calibration; it writes nothing and prints nothing: warnings and timings are kept for the
// caller.

#include "core/boundary_detection.hpp"
#include "core/boundary_estimation.hpp"
#include "core/crown_completion.hpp"
#include "core/crown_hull.hpp"
#include "core/footprint_completion.hpp"
#include "core/free_space.hpp"
#include "core/ground_segmentation.hpp"
#include "core/pose_estimation.hpp"
#include "core/sensor_data.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"

#include <deque>
#include <string>
#include <vector>

namespace terrain {

struct PipelineConfig {
  PoseConfig pose;
  VoxelMapConfig voxel_map;
  GroundSegmentationConfig ground;
  BoundaryDetectionConfig boundary;
  BoundaryEstimationConfig estimation;
  FootprintConfig footprint;
  CrownConfig crown;
  CrownHullConfig hull;
  FreeSpaceConfig free_space;
  int segment_every = 1;  // run ground segmentation every this many frames (and at the end)
};

// Per-frame record: stage times [ms] and sizes.
struct FrameRecord {
  int frame = 0;
  double time = 0;  // [s] sweep start
  double pose_ms = 0, voxel_ms = 0, mesh_ms = 0, segmentation_ms = 0, boundary_ms = 0, estimation_ms = 0, total_ms = 0;
  std::size_t points = 0, new_voxels = 0, voxels = 0;
  int estimated_vertices = 0;
  std::size_t resident_bytes = 0;    // the process's resident memory after the frame (0: unknown)
  Point3 position = Point3::Zero();  // [m] estimated vehicle position at `time`, from the final poses (set by finish())
  Rotation attitude = Rotation::Identity();  // estimated world_from_vehicle rotation at `time`, likewise
};

class Pipeline {
 public:
  Pipeline(const RigCalibration& calibration, const PipelineConfig& config);

  // Processes a frame. Until the initial attitude is known, frames are held back and processed
  // as soon as it is.
  void process(const SensorFrame& frame);
  // Processes held-back frames (with the best pose available) and runs a final segmentation.
  void finish();

  const VoxelMap& map() const { return map_; }
  const TerrainMesh& mesh() const { return mesh_; }
  const SegmentationResult& segmentation() const { return segmentation_; }
  // the building footprints completed at finish() (footprint completion) and their roof cells
  const std::vector<Footprint>& footprints() const { return footprints_; }
  const std::vector<RoofCell>& roofCells() const { return roof_cells_; }
  // what crown completion made of every trunk a frame looked at (by trunk key)
  std::vector<CrownRecord> crownRecords() const { return crowns_.records(); }
  const std::vector<FrameRecord>& records() const { return records_; }
  // vertices the crowns' visual hull raised at finish() (0 after restore())
  int hullRaised() const { return hull_raised_; }
  // the hull's columns and crown voxels (0 after restore())
  std::size_t hullColumns() const { return hull_.columns(); }
  std::size_t hullCrownVoxels() const { return hull_.crownVoxels(config_.hull); }
  // raised vertices the sky's ceiling lowered at finish() (0 after restore())
  int skyLowered() const { return sky_lowered_; }
  const std::vector<std::string>& warnings() const { return warnings_; }
  const PoseEstimator& poses() const { return poses_; }
  const RigCalibration& calibration() const { return calibration_; }
  const PipelineConfig& config() const { return config_; }
  // Replaces the pipeline's final state with a saved one (for scoring a finished run again).
  // Returns false if the voxels or mesh vertices are inconsistent (duplicates, labels not one per
  // voxel, a vertex's top voxel out of range).
  bool restore(std::vector<Voxel> voxels, std::vector<MeshVertex> vertices, SegmentationResult segmentation,
               std::vector<FrameRecord> records, const std::vector<CrownRecord>& crowns = {});

  // The boundary images of the last processed frame that had images, one entry per camera image
  // (in the frame's image order), and that frame's index (-1: none yet).
  struct CameraBoundaries {
    int camera = 0;  // index into calibration().cameras
    BoundaryImages images;
  };
  const std::vector<CameraBoundaries>& lastBoundaries() const { return last_boundaries_; }
  int lastBoundaryFrame() const { return last_boundary_frame_; }

 private:
  void processReady(const SensorFrame& frame);
  void warn(const std::string& message);
  void completeFootprints();

  RigCalibration calibration_;
  PipelineConfig config_;
  PoseEstimator poses_;
  VoxelMap map_;
  TerrainMesh mesh_;
  SegmentationResult segmentation_;    // of the whole map, from finish()
  std::vector<Footprint> footprints_;  // from finish()
  std::vector<RoofCell> roof_cells_;
  CrownSampler crowns_;                        // crown samples, frame by frame
  CrownHull hull_;                             // the crowns' visual hull, frame by frame
  CrownHull sky_guard_;                        // crown completion's sky guard (crown.sky_guard, crown.guard_estimates)
  SkyCeiling ceiling_;                         // the sky's rays, frame by frame
  IncrementalGroundSegmentation incremental_;  // frame by frame
  struct HeldFrame {
    SensorFrame frame;
    double pose_ms;  // time spent adding it to the pose estimator
  };
  std::deque<HeldFrame> held_;
  std::vector<FrameRecord> records_;
  std::vector<std::string> warnings_;
  std::vector<CameraBoundaries> last_boundaries_;
  int last_boundary_frame_ = -1;
  int processed_ = 0;
  int sky_lowered_ = 0;
  int hull_raised_ = 0;
  bool dirty_ = false;  // points added since the last segmentation
};

}  // namespace terrain
