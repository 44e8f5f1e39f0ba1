#pragma once
// Stage 1, pose: the vehicle pose from GPS (position) and gyro (rotation), as the paper's robot
// had it, and the de-skewing of lidar points with their own timestamps.
//
// Fusion. Rotation is the integral of the gyro's angular rate from an initial attitude E, which the
// gyro cannot give. A wheeled robot moves along its forward axis, so once it has moved
// heading_baseline metres the GPS course over that stretch fixes heading and pitch: E turns the
// integrated forward axis onto the course. Both are least-squares directions over every fix of the
// stretch against the distance travelled, and the integrated path includes the antenna's own motion
// as the vehicle pitches and rolls under it (a 1.9 m mast rolling by 5 degrees moves the antenna
// 17 cm sideways). Roll, about that axis, comes from a plane fitted to the ground around the robot in
// the first sweep (so a steady cross slope is taken as level: the GPS cannot see it on a straight
// drive). Frames before that are held back by the pipeline. E is not revised later: a map built
// with one slightly wrong E stays consistent, while revising it frame by frame smears far walls
// (measured). GPS height noise dominates the pitch error, hence the 6 m default baseline: on the
// urban scenario (seed 1, 60 frames) ground F1 rises from 0.971 with 2 m to 0.992. The GPS pitch
// is weighed against the pitch that levels the first sweep's ground plane by their variances, so a
// run shorter than the baseline leans on the ground plane. Position is the GPS antenna position (WGS84 -> local ENU
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
  double heading_baseline = 6.0;    // [m] GPS travel needed to fix the initial heading and pitch
  double level_min_range = 3.0;     // [m] ground points for the initial roll/pitch: horizontal range from
  double level_max_range = 15.0;    // [m] ... to
  double level_cell = 1.0;          // [m] lowest point per cell of this size enters the plane fit
  double smoothing_window = 1.5;    // [s] half-width of the GPS smoothing window (0: raw fixes)
  double level_pitch_sigma = 0.05;  // [rad] how far the ground under the robot may tilt from level
                                    // (about 3 degrees): weighs the ground plane's pitch against the GPS's
  double max_speed = 40.0;          // [m/s] a GPS fix farther from the last one kept than this speed
                                    // allows (plus 3 sigma of each fix and 1 m) is dropped as a glitch
};

// What PoseEstimator::add did with a frame's GPS fixes.
struct GpsUpdate {
  // fixes dropped as jumps no vehicle makes from the last fix kept (PoseConfig::max_speed)
  std::size_t dropped = 0;
  // earlier fixes discarded instead: before the heading is known, when more dropped fixes than
  // fixes kept agree with each other, the kept ones were the glitch and the track starts over
  std::size_t discarded = 0;
};

struct TimedRotation {
  double time;
  Rotation world_from_vehicle;
};

class PoseEstimator {
 public:
  PoseEstimator(const RigCalibration& calibration, const PoseConfig& config);

  // Feeds a frame's GPS fixes and gyro samples (and, for the first frame, its sweep for levelling).
  // Returns what became of its GPS fixes.
  GpsUpdate add(const SensorFrame& frame);
  // True once the initial attitude is known; poses are valid from then on.
  bool ready() const { return heading_known_; }
  // At the end of the data: fixes the initial attitude from however far the robot has moved, if at
  // least min_travel metres (a short run). Returns ready().
  bool settle(double min_travel);
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
  Rotation gyroAt(double t) const;  // the gyro integral alone
  // E from the fixes so far; false if they span less than min_travel metres
  bool alignment(Rotation& out, double min_travel) const;
  Vector3 antennaAt(double t) const;

  RigCalibration calibration_;
  PoseConfig config_;
  bool levelled_ = false;
  bool heading_known_ = false;

  Vector3 ground_up_ = Vector3::UnitZ();     // ground normal seen in the vehicle frame, first sweep
  std::vector<TimedRotation> rotations_;     // gyro integral from the identity at the first sample
  Rotation initial_ = Rotation::Identity();  // E: world_from_vehicle at the first gyro sample
  void smoothFrom(std::size_t first);

  std::vector<std::pair<double, Vector3>> raw_;  // GPS antenna positions [m] world ENU, as measured
  double last_sigma_ = 0;                        // [m] stated accuracy of the last fix kept
  struct Fix {
    double time;   // [s]
    Vector3 at;    // antenna position [m], world ENU
    double sigma;  // [m] stated accuracy, 0 if unknown
  };
  std::vector<Fix> jumped_;  // the dropped fixes since the last one kept, if they agree with each other
  // true if a vehicle at most max_speed fast gets from one fix to the other
  bool reachable(const Fix& from, const Fix& to) const;
  std::vector<std::pair<double, Vector3>> antenna_;  // the same, smoothed
};

// Transforms every point of a sweep into the world frame with the pose at its own time.
// Points with non-finite coordinates are dropped; returns how many were dropped in *dropped.
std::vector<Point3> deskewToWorld(const LidarSweep& sweep, const PoseEstimator& poses, const Pose& vehicle_from_lidar,
                                  int* dropped = nullptr);

}  // namespace terrain
