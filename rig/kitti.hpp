#pragma once
// KITTI velodyne scans (.bin: float32 x, y, z, reflectance per point, sensor frame x forward,
// y left, z up, metres) and SemanticKITTI labels (.label: one uint32 per point, the low 16 bits a
// class in the 19-class learning order, 0 car ... 18 traffic-sign).

#include "core/types.hpp"

#include <cstdint>
#include <filesystem>
#include <vector>

namespace terrain::rig {

struct KittiScan {
  std::vector<Point3> points;
  std::vector<float> reflectance;
};

// Throws io::InputError for a missing file or a size that is not a whole number of points.
KittiScan readKittiScan(const std::filesystem::path& path);
// Throws io::InputError if the file does not hold exactly `points` labels.
std::vector<std::uint16_t> readSemanticKittiLabels(const std::filesystem::path& path, std::size_t points);

// Ground as the common ground-segmentation protocol counts it: road, parking, sidewalk,
// other-ground, terrain.
inline bool isKittiGround(std::uint16_t c) { return c == 8 || c == 9 || c == 10 || c == 11 || c == 16; }
// Vegetation is left out of the score.
inline bool isKittiIgnored(std::uint16_t c) { return c == 14; }

// The name of a class in the 19-class learning order ("unlabelled" past it).
inline const char* kittiClassName(std::uint16_t c) {
  static const char* const names[] = {"car",      "bicycle",      "motorcycle",   "truck",       "other-vehicle",
                                      "person",   "bicyclist",    "motorcyclist", "road",        "parking",
                                      "sidewalk", "other-ground", "building",     "fence",       "vegetation",
                                      "trunk",    "terrain",      "pole",         "traffic-sign"};
  return c < 19 ? names[c] : "unlabelled";
}

}  // namespace terrain::rig
