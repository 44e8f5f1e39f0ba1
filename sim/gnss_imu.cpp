#include "sim/gnss_imu.hpp"

#include "core/random.hpp"

namespace terrain::sim {

namespace {

double gaussian(std::uint64_t seed, std::uint64_t stream, std::uint64_t k, std::uint64_t axis) {
  return Random::normalFromBits(hashKeys(seed, stream, k, 2 * axis), hashKeys(seed, stream, k, 2 * axis + 1));
}

}  // namespace

GpsModel::GpsModel(const GeodeticOrigin& origin, const GpsConfig& config, std::uint64_t seed)
    : enu_(origin.latitude_deg, origin.longitude_deg, origin.altitude_m), config_(config), seed_(seed) {}

GpsFix GpsModel::fix(int k, double t, const Pose& world_from_vehicle) const {
  const Vector3 antenna = world_from_vehicle * config_.antenna;
  const Vector3 noisy = antenna + Vector3(config_.horizontal_sigma * gaussian(seed_, 0x6E55, k, 0),
                                          config_.horizontal_sigma * gaussian(seed_, 0x6E55, k, 1),
                                          config_.vertical_sigma * gaussian(seed_, 0x6E55, k, 2));
  GpsFix f;
  f.time = t;
  f.sigma_m = config_.horizontal_sigma;
  enu_.Reverse(noisy.x(), noisy.y(), noisy.z(), f.latitude_deg, f.longitude_deg, f.altitude_m);
  return f;
}

GyroModel::GyroModel(const GyroConfig& config, std::uint64_t seed) : config_(config), seed_(seed) {
  for (int a = 0; a < 3; ++a) bias_[a] = config.bias_sigma * gaussian(seed, 0xB1A5, 0, a);
}

GyroSample GyroModel::sample(int k, double t, const Eigen::Matrix3d& before, const Eigen::Matrix3d& after) const {
  // the rotation over the interval, as a rotation vector in the body frame, divided by its length
  const Eigen::AngleAxisd delta(before.transpose() * after);
  GyroSample s;
  s.time = t;
  s.rate = delta.axis() * delta.angle() / period();
  for (int a = 0; a < 3; ++a) s.rate[a] += bias_[a] + config_.noise_sigma * gaussian(seed_, 0x6790, k, a);
  return s;
}

}  // namespace terrain::sim
