#pragma once
// What the pipeline reads from a sensor rig: lidar sweeps, camera images, GPS fixes, gyro samples
// and the rig's calibration. Nothing here carries ground truth.

#include "core/types.hpp"

#include <opencv2/core/mat.hpp>

#include <optional>
#include <string>
#include <vector>

namespace terrain {

// One lidar return in the lidar frame at the time it was measured.
struct LidarPoint {
  float x = 0, y = 0, z = 0;  // [m] lidar frame
  float intensity = 0;        // [0, 255]
  std::uint16_t ring = 0;     // laser id as in the calibration file
  float azimuth = 0;          // [rad] encoder rotational position of the firing, in [0, 2*pi)
  double time = 0;            // [s] absolute time of the firing
};

// All returns of one revolution of the lidar.
struct LidarSweep {
  double start_time = 0;  // [s] time of the first firing of the revolution
  double end_time = 0;    // [s] time one revolution after start_time
  std::vector<LidarPoint> points;
};

// One colour image from one of the rig's cameras.
struct CameraImage {
  int camera = 0;   // index into RigCalibration::cameras
  double time = 0;  // [s] exposure time
  cv::Mat rgb;      // CV_8UC3, RGB order, row 0 at the top
};

// One GPS fix (WGS84).
struct GpsFix {
  double time = 0;           // [s]
  double latitude_deg = 0;   // [deg]
  double longitude_deg = 0;  // [deg]
  double altitude_m = 0;     // [m] above the WGS84 ellipsoid
  double sigma_m = 0;        // [m] stated 1-sigma horizontal accuracy of the fix
};

// One gyro sample: the mean angular rate over (time - period, time], in the vehicle frame.
struct GyroSample {
  double time = 0;                 // [s] end of the integration interval
  Vector3 rate = Vector3::Zero();  // [rad/s] vehicle frame
};

// Pinhole camera model, no distortion.
struct CameraIntrinsics {
  int width = 640;        // [px]
  int height = 480;       // [px]
  double fx = 0, fy = 0;  // [px] focal lengths
  double cx = 0, cy = 0;  // [px] principal point

  // Intrinsics of an ideal camera with a vertical field of view fovy [rad] and square pixels.
  static CameraIntrinsics fromFovy(int width, int height, double fovy);
};

// A WGS84 point that serves as the origin of the local ENU world frame.
struct GeodeticOrigin {
  double latitude_deg = 0;
  double longitude_deg = 0;
  double altitude_m = 0;
};

// One camera of the rig: its name, how it images and where it sits on the vehicle.
struct CameraCalibration {
  std::string name;  // unique within the rig; names the camera's images in datasets and reports
  CameraIntrinsics intrinsics;
  Pose vehicle_from_camera = Pose::Identity();  // camera frame: x right, y down, z forward
};

// Geometry of the rig: where each sensor sits on the vehicle and how the cameras image.
struct RigCalibration {
  std::vector<CameraCalibration> cameras;  // any number, none included; images refer to them by index
  Pose vehicle_from_lidar = Pose::Identity();
  Pose vehicle_from_gps = Pose::Identity();  // GPS antenna phase centre
  GeodeticOrigin origin;                     // origin of the world ENU frame
  double gyro_period = 0.005;                // [s] gyro sample interval
};

// The index of the camera named `name` in calibration.cameras, or -1 if there is none.
int cameraIndex(const RigCalibration& calibration, const std::string& name);

// Everything the rig delivered for one lidar revolution. The camera images (at most one per
// camera, in camera order), GPS fixes and gyro samples are those whose time falls in (previous
// sweep end, this sweep end]; any may be missing.
struct SensorFrame {
  int index = 0;
  LidarSweep sweep;
  std::vector<CameraImage> images;
  std::vector<GpsFix> gps;
  std::vector<GyroSample> gyro;
};

}  // namespace terrain
