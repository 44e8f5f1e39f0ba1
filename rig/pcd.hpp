#pragma once
// Binary PCD (PCL's point cloud format, v0.7) for lidar sweeps with their per-point truth.
// Fields: x y z intensity ring azimuth time label class, where label is the geom id hit and class
// its scenes::GeomClass (-1 and 0 when there is no truth).

#include "core/sensor_data.hpp"
#include "rig/sensor_source.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace terrain::rig {

// Encodes a sweep as binary PCD. truth may be empty; otherwise it has one entry per point.
// Without truth_fields the file has only x y z intensity ring azimuth time (a real sensor's sweep).
std::string encodePcd(const LidarSweep& sweep, const std::vector<PointTruth>& truth, bool truth_fields = true);

struct DecodedPcd {
  std::vector<LidarPoint> points;
  std::vector<PointTruth> truth;  // empty if the file has no label field
};

// Decodes a binary PCD written by encodePcd, or any binary PCD with at least x y z; missing
// fields read as zero. Throws io::InputError naming origin and the problem.
DecodedPcd decodePcd(const std::string& bytes, const std::string& origin);

}  // namespace terrain::rig
