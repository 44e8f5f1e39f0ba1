#pragma once
// Stage 1, pose: the vehicle pose from GPS (position) and gyro (rotation), as the paper's robot
// had it, and the de-skewing of lidar points with their own timestamps.
//
// Fusion. Rotation is the integral of the gyro's angular rate from an initial attitude E, which the
// gyro cannot give. A wheeled robot moves along its forward axis, so once it has moved
// heading_baseline metres the GPS course over that stretch fixes heading and pitch: E turns the
// integrated forward axis onto the course. Roll, about that axis, comes from a plane fitted to the
// ground around the robot in the first sweep. Frames before that are held back by the pipeline. Position is the GPS antenna position (WGS84 -> local ENU
// at the rig's geodetic origin) minus the rotated antenna lever arm. GPS noise is independent from
// fix to fix while the vehicle moves smoothly, so each fix is replaced by a quadratic least-squares
// fit (in time) to the fixes within +-smoothing_window of it; positions between fixes are
// interpolated linearly. A frame is therefore processed once the fixes up to smoothing_window
// after it have arrived (a fixed latency). Poses between gyro samples are interpolated (slerp).

#include "core/sensor_data.hpp"
#include "core/types.hpp"

#include <deque>
#include <optional>
#include <vector>

namespace terrain {

struct PoseConfig {
  double heading_baseline = 2.0;     // [m] GPS travel needed to fix the initial heading
  double level_min_range = 3.0;      // [m] ground points for the initial roll/pitch: horizontal range from
  double level_max_range = 15.0;     // [m] ... to
  double level_cell = 1.0;           // [m] lowest point per cell of this size enters the plane fit
  double smoothing_window = 1.5;     // [s] half-width of the GPS smoothing window (0: raw fixes)
};

struct TimedRotation {
  double time;
  Rotation world_from_vehicle;
};

class PoseEstimator {
 public:
  PoseEstimator(const RigCalibration& calibration, const PoseConfig& config);

  // Feeds a frame's GPS fixes and gyro samples (and, for the first frame, its sweep for levelling).
  void add(const SensorFrame& frame);
  // True once the initial attitude is known; poses are valid from then on.
  bool ready() const { return heading_known_; }
  // Time [s] up to which poses are final: later GPS fixes no longer change them.
  double finalUntil() const;
  // Vehicle pose at time t; valid when ready() and t lies within the data received so far
  // (outside, the nearest known value is used).
  Pose worldFromVehicle(double t) const;
  // Local ENU position [m] of a GPS fix.
  Vector3 gpsToWorld(const GpsFix& fix) const;

 private:
  void levelFromSweep(const LidarSweep& sweep);
  Rotation rotationAt(double t) const;
  Vector3 antennaAt(double t) const;

  RigCalibration calibration_;
  PoseConfig config_;
  bool levelled_ = false;
  bool heading_known_ = false;
  void initialiseAttitude();

  Vector3 ground_up_ = Vector3::UnitZ();       // ground normal seen in the vehicle frame, first sweep
  std::vector<TimedRotation> rotations_;       // gyro integral from the identity at the first sample
  Rotation initial_ = Rotation::Identity();    // E: world_from_vehicle at the first sample
  void smoothFrom(std::size_t first);

  std::vector<std::pair<double, Vector3>> raw_;      // GPS antenna positions [m] world ENU, as measured
  std::vector<std::pair<double, Vector3>> antenna_;  // the same, smoothed
};

// Transforms every point of a sweep into the world frame with the pose at its own time.
// Points with non-finite coordinates are dropped; returns how many were dropped in *dropped.
std::vector<Point3> deskewToWorld(const LidarSweep& sweep, const PoseEstimator& poses, const Pose& vehicle_from_lidar,
                                  int* dropped = nullptr);

}  // namespace terrain
