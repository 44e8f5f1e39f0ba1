#pragma once
// Ground segmentation on a single real HDL-64E scan (KITTI, SemanticKITTI labels): the paper's
// method (the scan becomes a voxel map, each point takes its voxel's label) beside the baselines,
// scored per point with vegetation left out.

#include "core/ground_segmentation.hpp"
#include "core/voxel_map.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <vector>

namespace terrain::eval {

// sensor_height: the lidar's height above the road [m] (KITTI: 1.73), for the fixed band.
nlohmann::json scoreKittiScan(const std::vector<Point3>& points, const std::vector<std::uint16_t>& labels,
                              const VoxelMapConfig& voxels, const GroundSegmentationConfig& ground,
                              double sensor_height);

// Per-point ground labels of the paper's method on one scan, and the time it took [ms].
std::vector<std::uint8_t> segmentScan(const std::vector<Point3>& points, const VoxelMapConfig& voxels,
                                      const GroundSegmentationConfig& ground, double* milliseconds = nullptr);

}  // namespace terrain::eval
