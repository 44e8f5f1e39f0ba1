#pragma once
// GPS fixes and gyro samples from the true motion, with configurable noise. Noise is keyed by
// (seed, sample index), so any sample can be produced on its own and always comes out the same.

#include "core/sensor_data.hpp"
#include "sim/sim_config.hpp"

#include <GeographicLib/LocalCartesian.hpp>

namespace terrain::sim {

class GpsModel {
 public:
  GpsModel(const GeodeticOrigin& origin, const GpsConfig& config, std::uint64_t seed);
  // The fix with index k, taken at time t with the vehicle at world_from_vehicle.
  GpsFix fix(int k, double t, const Pose& world_from_vehicle) const;

 private:
  GeographicLib::LocalCartesian enu_;
  GpsConfig config_;
  std::uint64_t seed_;
};

class GyroModel {
 public:
  GyroModel(const GyroConfig& config, std::uint64_t seed);
  // Sample k: the mean angular rate in the vehicle frame over (t - period, t], where the vehicle
  // turned from orientation before to orientation after.
  GyroSample sample(int k, double t, const Eigen::Matrix3d& before, const Eigen::Matrix3d& after) const;
  double period() const { return 1.0 / config_.rate_hz; }

 private:
  GyroConfig config_;
  Vector3 bias_;
  std::uint64_t seed_;
};

}  // namespace terrain::sim
