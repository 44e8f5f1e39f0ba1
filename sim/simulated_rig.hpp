#pragma once
// The simulated rig: a robot driving a generated scene, delivering what the real robot's sensors
// deliver (lidar sweeps, camera images, GPS, gyro) and, beside it, the ground truth.

#include "rig/sensor_source.hpp"
#include "sim/camera.hpp"
#include "sim/gnss_imu.hpp"
#include "sim/lidar.hpp"
#include "sim/ray_caster.hpp"
#include "sim/sim_config.hpp"
#include "sim/trajectory.hpp"
#include "sim/world.hpp"

#include <memory>
#include <vector>

namespace terrain::sim {

class SimulatedRig : public rig::SensorSource {
 public:
  // frames: how many sweeps to deliver. Throws io::InputError for a bad config, scene or
  // calibration file.
  SimulatedRig(std::shared_ptr<const World> world, const SimConfig& config, int frames);
  ~SimulatedRig() override;

  const RigCalibration& calibration() const override { return calibration_; }
  const rig::LaserCalibration& lasers() const override { return lidar_->lasers(); }
  std::optional<rig::RigFrame> next() override;
  int frameCount() const override { return frames_; }

  const World& world() const { return *world_; }
  const Trajectory& trajectory() const { return *trajectory_; }
  // lidar firings per revolution (each at rig::velodyne::encoderStep(j, n))
  int firingsPerTurn() const;
  // rays cast so far
  long long raysCast() const { return rays_; }

  // Rig geometry implied by a configuration.
  static RigCalibration calibrationFor(const SimConfig& config, const GeodeticOrigin& origin);

 private:
  std::shared_ptr<const World> world_;
  SimConfig config_;
  int frames_;
  int next_ = 0;
  long long rays_ = 0;
  RigCalibration calibration_;
  std::unique_ptr<RayCaster> caster_;
  std::unique_ptr<Trajectory> trajectory_;
  std::unique_ptr<LidarSimulator> lidar_;
  std::vector<std::unique_ptr<CameraRenderer>> cameras_;  // one per calibration camera
  GpsModel gps_;
  GyroModel gyro_;
};

}  // namespace terrain::sim
