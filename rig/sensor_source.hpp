#pragma once
// The sensor-rig interface the pipeline reads. Behind it: the simulated rig (sim/), recorded
// datasets (rig/dataset.hpp) and, later, the real Velodyne driver. Ground truth travels beside
// the sensor data, never inside it, so the pipeline can be handed SensorFrame alone.

#include "core/sensor_data.hpp"
#include "rig/velodyne_calibration.hpp"

#include <opencv2/core/mat.hpp>

#include <optional>
#include <string>
#include <vector>

namespace terrain::rig {

// What a lidar return really hit.
struct PointTruth {
  std::int32_t geom = -1;  // MuJoCo geom id
  std::uint8_t cls = 0;    // scenes::GeomClass value
};

struct TimedPose {
  double time = 0;
  Pose world_from_vehicle = Pose::Identity();
};

// What one camera's image really showed.
struct CameraTruth {
  int camera = 0;        // index into RigCalibration::cameras, as the image's
  cv::Mat depth;         // CV_32FC1 [m] along the optical axis, 0 where nothing was hit
  cv::Mat segmentation;  // CV_16UC1 geom id + 1 per pixel, 0 for sky
};

// Ground truth for one frame; only simulated and recorded-from-simulation sources have it.
struct FrameTruth {
  std::vector<PointTruth> points;    // one per LidarSweep point, same order
  std::vector<CameraTruth> cameras;  // one per image of the frame that has truth
  std::vector<TimedPose> poses;      // true vehicle poses in the frame's time window
};

struct RigFrame {
  SensorFrame sensors;
  std::optional<FrameTruth> truth;
};

class SensorSource {
 public:
  virtual ~SensorSource() = default;

  // Geometry of the rig; valid for the whole stream.
  virtual const RigCalibration& calibration() const = 0;
  // The lidar's laser table.
  virtual const LaserCalibration& lasers() const = 0;
  // The next frame, or std::nullopt at the end of the stream.
  virtual std::optional<RigFrame> next() = 0;
  // Number of frames the stream will deliver, or -1 if unknown (live sensors).
  virtual int frameCount() const = 0;
};

}  // namespace terrain::rig
