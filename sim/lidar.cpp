#include "sim/lidar.hpp"

#include "core/random.hpp"
#include "scenes/scene_truth.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cmath>

namespace terrain::sim {

namespace {

// share of the beam energy a class sends back, for the intensity channel
double reflectivity(scenes::GeomClass c) {
  switch (c) {
    case scenes::GeomClass::Ground:
      return 0.30;
    case scenes::GeomClass::Building:
      return 0.55;
    case scenes::GeomClass::Trunk:
      return 0.35;
    case scenes::GeomClass::Crown:
      return 0.20;
    default:
      return 0.40;
  }
}

}  // namespace

LidarSimulator::LidarSimulator(const World& world, const RayCaster& caster, rig::LaserCalibration lasers,
                               const LidarConfig& config, const Pose& vehicle_from_lidar, std::uint64_t seed,
                               int threads)
    : world_(world),
      caster_(caster),
      lasers_(std::move(lasers)),
      config_(config),
      vehicle_from_lidar_(vehicle_from_lidar),
      seed_(seed),
      threads_(threads),
      firings_(static_cast<int>(std::lround(config.firing_rate_hz / config.rotation_hz))) {
  for (int l = 0; l < lasers_.laserCount(); ++l) {
    bias_.push_back(config_.laser_bias *
                    Random::normalFromBits(hashKeys(seed_, 0xB1A5, l, 1), hashKeys(seed_, 0xB1A5, l, 2)));
  }
}

SimulatedSweep LidarSimulator::simulate(int sweep_index, double start_time, const Trajectory& trajectory) const {
  const int nl = lasers_.laserCount();
  const double period = 1.0 / config_.rotation_hz;
  struct Slot {
    bool valid = false;
    LidarPoint point;
    rig::PointTruth truth;
  };
  std::vector<Slot> slots(static_cast<std::size_t>(firings_) * nl);
  auto fire = [&](const tbb::blocked_range<int>& firings) {
    for (int j = firings.begin(); j < firings.end(); ++j) {
      const double t = start_time + period * j / firings_;
      // the encoder position of this firing, as the sensor reports it (0.01 deg steps)
      const double a = rig::velodyne::stepToRadians(rig::velodyne::encoderStep(j, firings_));
      const Pose world_from_lidar = trajectory.worldFromVehicle(t) * vehicle_from_lidar_;
      for (int l = 0; l < nl; ++l) {
        Vector3 o, dir;
        const rig::LaserCorrection& laser = lasers_.lasers[l];
        rig::laserRay(laser, a, o, dir);
        const RayHit hit = caster_.cast(world_from_lidar * o, world_from_lidar.linear() * dir);
        if (hit.geom < 0 || hit.distance > config_.max_range) continue;
        const std::uint64_t key = hashKeys(seed_, static_cast<std::uint64_t>(sweep_index),
                                           static_cast<std::uint64_t>(j), static_cast<std::uint64_t>(l));
        if (config_.dropout > 0 && unitFromBits(mixBits(key ^ 0xD50F)) < config_.dropout) continue;
        const double noise = config_.range_noise * Random::normalFromBits(mixBits(key ^ 1), mixBits(key ^ 2));
        const double measured = hit.distance + noise + bias_[l];
        if (measured < config_.min_range || measured > config_.max_range) continue;
        // the sensor reports range less its distance correction, never below one unit
        if (measured - laser.dist_correction < lasers_.distance_resolution) continue;
        const Vector3 p = o + measured * dir;
        if (p.z() > config_.height_cap) continue;
        const scenes::GeomClass cls = world_.geomClass(hit.geom);
        const double falloff = 1.0 - 0.5 * measured / config_.max_range;
        const double intensity = 255.0 * reflectivity(cls) * falloff * (0.9 + 0.2 * unitFromBits(mixBits(key ^ 3)));
        Slot& s = slots[static_cast<std::size_t>(j) * nl + l];
        s.valid = true;
        s.point = {static_cast<float>(p.x()),
                   static_cast<float>(p.y()),
                   static_cast<float>(p.z()),
                   static_cast<float>(std::min(255.0, intensity)),
                   static_cast<std::uint16_t>(l),
                   static_cast<float>(a),
                   t};
        s.truth = {hit.geom, static_cast<std::uint8_t>(cls)};
      }
    }
  };
  // each firing writes only its own slots, so the result does not depend on the thread count
  tbb::task_arena arena(threads_ > 0 ? threads_ : tbb::task_arena::automatic);
  arena.execute([&] { tbb::parallel_for(tbb::blocked_range<int>(0, firings_, 16), fire); });
  SimulatedSweep out;
  out.rays = firings_ * nl;
  out.sweep.start_time = start_time;
  out.sweep.end_time = start_time + period;
  for (const Slot& s : slots) {
    if (!s.valid) continue;
    out.sweep.points.push_back(s.point);
    out.truth.push_back(s.truth);
  }
  return out;
}

}  // namespace terrain::sim
