#pragma once
// Settings of the simulated robot and its sensors, with defaults and units. YAML files and the
// command line only fill these structs; validate() refuses values outside their allowed range.

#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace terrain::sim {

struct RobotConfig {
  double speed = 2.0;        // [m/s] along the scene's path, in (0, 30]
  double mast_height = 1.8;  // [m] lidar origin above the ground, in [0.5, 5]
  double wheelbase = 1.0;    // [m] front-back distance of the contact points
  double track = 0.7;        // [m] left-right distance of the contact points
};

struct LidarConfig {
  std::string calibration;          // laser table (ROS YAML or db.xml); empty: the shipped HDL-64E S2
  double rotation_hz = 10.0;        // [Hz] spin rate, in [5, 15]
  double firing_rate_hz = 20833.3;  // [Hz] firings of all lasers per second (1.333 M points/s / 64)
  double max_range = 120.0;         // [m] in (0, 200]
  double min_range = 0.9;           // [m] returns closer than this are dropped, in [0, max_range)
  double range_noise = 0.02;        // [m] 1-sigma Gaussian range noise, >= 0
  double laser_bias = 0.0;          // [m] 1-sigma of a fixed per-laser range bias, >= 0
  double dropout = 0.0;             // probability a return is lost, in [0, 1)
  double height_cap = 1.5;          // [m] returns higher than this above the sensor (lidar z) are not reported
};

// One camera of the simulated rig. Its optical axis points at azimuth yaw_deg from the vehicle's
// forward axis (counter-clockwise seen from above: 90 looks left), tilted up by pitch_deg; roll_deg
// turns the camera about its optical axis (positive: the image's top edge to the camera's left).
struct CameraMount {
  std::string name = "front";                // unique within the rig
  Eigen::Vector3d position{0.25, 0.0, 1.6};  // [m] vehicle frame, outside the robot's body
  double yaw_deg = 0.0;                      // [deg] in [-180, 180]
  double pitch_deg = 8.0;                    // [deg] upward tilt of the optical axis, in [-45, 45]
  double roll_deg = 0.0;                     // [deg] in [-45, 45]
  int width = 640, height = 480;             // [px] in [16, 4096]
  double fovy_deg = 75.0;                    // [deg] vertical field of view, in (0, 180)
};

// The named camera rigs: "surround" (front, left, rear and right, 90 degrees apart, 91 degrees
// across each at 640 x 480 and fovy 75: the whole horizon) and "forward" (the paper's single
// forward camera, the surround rig's front camera). Throws io::InputError for another name.
std::vector<CameraMount> cameraRig(const std::string& name);
// the names cameraRig() knows, for messages and --help
inline constexpr const char* kCameraRigs = "surround, forward";

struct CameraConfig {
  bool enabled = true;
  std::string rig = "surround";      // a named rig (cameraRig), used when `cameras` is empty
  std::vector<CameraMount> cameras;  // an explicit rig (YAML list `cameras`); replaces `rig`
  // set on every camera of the rig when given (0 or NaN: each camera's own)
  int width = 0, height = 0;                                    // [px]
  double fovy_deg = std::numeric_limits<double>::quiet_NaN();   // [deg]
  double pitch_deg = std::numeric_limits<double>::quiet_NaN();  // [deg]
};

// The cameras a configuration puts on the robot: the explicit list or the named rig, with the
// rig-wide settings applied; empty when the camera is disabled.
std::vector<CameraMount> rigCameras(const CameraConfig& config);

struct GpsConfig {
  double rate_hz = 10.0;                    // [Hz] in (0, 100]
  double horizontal_sigma = 0.05;           // [m] 1-sigma per horizontal axis, >= 0
  double vertical_sigma = 0.10;             // [m] 1-sigma, >= 0
  Eigen::Vector3d antenna{-0.3, 0.0, 1.9};  // [m] vehicle frame
};

struct GyroConfig {
  double rate_hz = 200.0;      // [Hz] in [100, 2000]
  double noise_sigma = 0.002;  // [rad/s] 1-sigma white noise per axis, >= 0
  double bias_sigma = 0.0;     // [rad/s] 1-sigma of a constant per-axis bias, >= 0
};

struct SimConfig {
  RobotConfig robot;
  LidarConfig lidar;
  CameraConfig camera;
  GpsConfig gps;
  GyroConfig gyro;
  std::uint64_t seed = 1;  // noise seed; the same seed gives the same data
  int threads = 0;         // worker threads for the lidar; 0: all cores. Output does not depend on it.
};

// Throws io::InputError naming the first field outside its range, with the range.
void validate(const SimConfig& config);

// Overlays the keys present in a YAML file onto config (unknown keys are refused).
void loadSimConfig(const std::filesystem::path& path, SimConfig& config);

// The configuration as a JSON object (for dataset manifests and reports).
std::string simConfigToJson(const SimConfig& config);

// Absolute path of a file in the project's data directory.
std::filesystem::path dataPath(const std::string& relative);

}  // namespace terrain::sim
