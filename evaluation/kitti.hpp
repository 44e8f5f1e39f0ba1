#pragma once
// Ground segmentation on a single real HDL-64E scan (KITTI, SemanticKITTI labels): the paper's
// method (the scan becomes a voxel map, each point takes its voxel's label) beside the baselines,
// scored per point with vegetation left out.

#include "core/ground_segmentation.hpp"
#include "core/voxel_map.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace terrain::eval {

// Where a segmentation of a scan errs: per SemanticKITTI class the points and those labelled
// ground (for a non-ground class, false ground; for a ground class, found ground), and per band of
// horizontal distance from the sensor (0-10, 10-20, 20-30, 30-50, 50+ m) the scored points, false
// ground and missed ground. Vegetation is counted by class but not in the bands.
nlohmann::json kittiConfusion(const std::vector<Point3>& points, const std::vector<std::uint16_t>& labels,
                              const std::vector<std::uint8_t>& ground);

// Scores scan after scan against their labels, each solver's segmenter (ScanSegmenter) kept from one
// scan to the next. sensor_height: the lidar's height above the road [m] (KITTI: 1.73), for the
// fixed band. A scan's report holds every method's scores (kGroundMethods; the GMRF's with
// labelScanPoints' per-point step, and the time its segmentation took), the GMRF's voxel labels
// without that step under "voxel_labels", and, for the configured solver, the confusion
// (kittiConfusion) under "confusion".
class KittiScorer {
 public:
  KittiScorer(const VoxelMapConfig& voxels, const GroundSegmentationConfig& ground, double sensor_height);
  nlohmann::json score(const std::vector<Point3>& points, const std::vector<std::uint16_t>& labels);
  // the configured solver's per-point labels of the last scan scored (1 ground)
  const std::vector<std::uint8_t>& groundOfLastScan() const { return ground_of_last_; }

 private:
  GroundSegmentationConfig ground_;
  double sensor_height_;
  ScanSegmenter icm_, mincut_;
  std::vector<std::uint8_t> ground_of_last_;
};

// One scan as a binary little-endian PLY for a point-cloud viewer: per point x y z (float), the
// class (ushort, readSemanticKittiLabels' learning order), the ground label (uchar) and the verdict
// (uchar: 0 non-ground right, 1 ground right, 2 false ground, 3 missed ground, 4 unscored).
std::string kittiVerdictPly(const std::vector<Point3>& points, const std::vector<std::uint16_t>& labels,
                            const std::vector<std::uint8_t>& ground);

}  // namespace terrain::eval
