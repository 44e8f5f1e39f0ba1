#pragma once
// Types named by meaning, shared by every stage. Frames and units are described once in README.md:
// world is ENU (x east, y north, z up), vehicle is x forward / y left / z up, lidar follows the
// Velodyne ROS convention (x forward, y left, z up), camera is x right / y down / z forward.
// Lengths in metres, angles in radians, time in seconds.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>

namespace terrain {

using Point3 = Eigen::Vector3d;
using Vector3 = Eigen::Vector3d;
using Rotation = Eigen::Quaterniond;
// rigid transform; "a_from_b" maps coordinates in frame b to frame a
using Pose = Eigen::Isometry3d;
using Timestamp = double;  // seconds

// integer index of a voxel in the map grid
using VoxelIndex = Eigen::Vector3i;
// integer index of a horizontal (x, y) cell of the map grid
using CellIndex = Eigen::Vector2i;

// pixel position in an image, column (u) then row (v), origin at the top-left pixel's corner
using Pixel = Eigen::Vector2d;

}  // namespace terrain
