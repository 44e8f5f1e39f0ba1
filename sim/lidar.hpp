#pragma once
// Simulated Velodyne lidar: every laser of the calibration table fires at each firing of the
// revolution (at encoder positions on the sensor's 0.01 deg grid, rig::velodyne::encoderStep), each firing at its own
// time while the vehicle moves (so sweeps carry real motion skew). Ranges come from the ray caster (mj_ray semantics);
// Gaussian range noise, an optional per-laser bias and dropout are added; returns above the height cap are not
// reported.

#include "core/sensor_data.hpp"
#include "rig/sensor_source.hpp"
#include "rig/velodyne_calibration.hpp"
#include "rig/velodyne_packet.hpp"
#include "sim/ray_caster.hpp"
#include "sim/sim_config.hpp"
#include "sim/trajectory.hpp"
#include "sim/world.hpp"

namespace terrain::sim {

struct SimulatedSweep {
  LidarSweep sweep;
  std::vector<rig::PointTruth> truth;  // one per point
  int rays = 0;                        // rays cast
};

class LidarSimulator {
 public:
  LidarSimulator(const World& world, const RayCaster& caster, rig::LaserCalibration lasers, const LidarConfig& config,
                 const Pose& vehicle_from_lidar, std::uint64_t seed, int threads);

  // The revolution that starts at start_time [s]; sweep_index keys the noise.
  SimulatedSweep simulate(int sweep_index, double start_time, const Trajectory& trajectory) const;

  // Firings per revolution.
  int firingsPerTurn() const { return firings_; }
  const rig::LaserCalibration& lasers() const { return lasers_; }

 private:
  const World& world_;
  const RayCaster& caster_;
  rig::LaserCalibration lasers_;
  LidarConfig config_;
  Pose vehicle_from_lidar_;
  std::uint64_t seed_;
  int threads_;
  int firings_;
  std::vector<double> bias_;  // per laser [m]
};

}  // namespace terrain::sim
