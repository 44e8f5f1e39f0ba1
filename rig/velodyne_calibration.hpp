#pragma once
// Per-laser geometry of a Velodyne lidar, read from the ROS driver's YAML or Velodyne's db.xml.

#include "core/types.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace terrain::rig {

struct LaserCorrection {
  int id = 0;
  double rot_correction = 0;     // [rad] azimuth offset, subtracted from the encoder angle
  double vert_correction = 0;    // [rad] elevation of the beam
  double dist_correction = 0;    // [m] added to the raw distance
  double dist_correction_x = 0;  // [m] two-point correction, x
  double dist_correction_y = 0;  // [m] two-point correction, y
  double vert_offset = 0;        // [m] height of the beam origin above the sensor origin
  double horiz_offset = 0;       // [m] sideways offset of the beam origin
  double focal_distance = 0;     // [m] intensity correction
  double focal_slope = 0;        // intensity correction
  int min_intensity = 0, max_intensity = 255;
};

struct LaserCalibration {
  double distance_resolution = 0.002;   // [m] one unit of the raw distance
  std::vector<LaserCorrection> lasers;  // index == laser id
  std::string source;                   // file it came from

  int laserCount() const { return static_cast<int>(lasers.size()); }
};

// The ray of laser l at encoder angle a [rad], in the lidar frame (x forward at a = 0, y left,
// z up): the beam leaves origin along the unit vector direction, and a raw distance d [m]
// measures the point origin + (d + dist_correction) * direction. This is the correction model
// of Velodyne's db.xml as PCL's HDLGrabber applies it: the azimuth is a - rot_correction
// (clockwise seen from above), the elevation vert_correction, the vertical offset raises the
// origin, the horizontal offset moves it sideways. The two-point corrections
// (dist_correction_x/_y) and the focal intensity correction are not part of it.
void laserRay(const LaserCorrection& l, double a, Vector3& origin, Vector3& direction);

// Reads a calibration file; the format is taken from the content (YAML or db.xml). Throws
// io::InputError naming the file, the laser and the field for anything missing or out of range.
LaserCalibration loadLaserCalibration(const std::filesystem::path& path);

// Parses calibration text; origin names it in messages.
LaserCalibration parseLaserCalibration(const std::string& text, const std::string& origin);

// Writes the calibration as ROS driver YAML (angles in radians, offsets in metres).
std::string laserCalibrationToYaml(const LaserCalibration& calibration);

}  // namespace terrain::rig
