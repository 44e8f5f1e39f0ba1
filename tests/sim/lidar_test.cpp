#include "sim/lidar.hpp"

#include "sim/simulated_rig.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace terrain::sim {
namespace {

SimConfig quietConfig() {
  SimConfig c;
  c.lidar.range_noise = 0;
  c.camera.enabled = false;
  c.camera.width = 160;
  c.camera.height = 120;
  return c;
}

TEST(LidarTest, HeightCapRemovesExactlyThePointsAboveIt) {
  auto world = test::wallWorld(12.0);
  SimConfig open = quietConfig();
  open.lidar.height_cap = 200;
  SimConfig capped = open;
  capped.lidar.height_cap = 1.5;
  SimulatedRig a(world, open, 1), b(world, capped, 1);
  const auto fa = a.next(), fb = b.next();
  std::vector<LidarPoint> expected;
  for (const auto& p : fa->sensors.sweep.points) {
    if (p.z <= 1.5f) expected.push_back(p);
  }
  ASSERT_LT(expected.size(), fa->sensors.sweep.points.size()) << "the wall must reach above the cap";
  ASSERT_EQ(fb->sensors.sweep.points.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto& p = fb->sensors.sweep.points[i];
    EXPECT_EQ(p.x, expected[i].x);
    EXPECT_EQ(p.z, expected[i].z);
    EXPECT_EQ(p.ring, expected[i].ring);
    EXPECT_LE(p.z, 1.5f);
  }
}

TEST(LidarTest, EachPointIsLabelledWithTheGeomItHit) {
  auto world = test::wallWorld(12.0);
  SimulatedRig rig(world, quietConfig(), 1);
  const auto frame = rig.next();
  const auto& pts = frame->sensors.sweep.points;
  const auto& truth = frame->truth->points;
  ASSERT_EQ(pts.size(), truth.size());
  const RayCaster caster(world->model(), world->data(), world->robotBody());
  const Pose vehicle_from_lidar = rig.calibration().vehicle_from_lidar;
  const int wall = mj_name2id(world->model(), mjOBJ_GEOM, "wall");
  int walls = 0, grounds = 0;
  for (std::size_t i = 0; i < pts.size(); i += 7) {
    const auto& p = pts[i];
    Vector3 o, dir;
    rig::laserRay(rig.lasers().lasers[p.ring], p.azimuth, o, dir);
    const Pose world_from_lidar = rig.trajectory().worldFromVehicle(p.time) * vehicle_from_lidar;
    const RayHit hit = caster.castReference(world_from_lidar * o, world_from_lidar.linear() * dir);
    ASSERT_EQ(truth[i].geom, hit.geom);
    EXPECT_EQ(truth[i].cls, static_cast<std::uint8_t>(world->geomClass(hit.geom)));
    // with noise off the point lies on the ray at the hit distance
    EXPECT_NEAR((Vector3(p.x, p.y, p.z) - o).norm(), hit.distance, 1e-4);
    walls += hit.geom == wall;
    grounds += world->geomClass(hit.geom) == scenes::GeomClass::Ground;
  }
  EXPECT_GT(walls, 100);
  EXPECT_GT(grounds, 100);
}

TEST(LidarTest, SweepHasTheHdl64eLayoutAndTiming) {
  auto world = test::wallWorld(12.0);
  SimulatedRig rig(world, quietConfig(), 2);
  EXPECT_EQ(rig.lasers().laserCount(), 64);
  rig.next();
  const auto f = rig.next();
  const auto& s = f->sensors.sweep;
  EXPECT_DOUBLE_EQ(s.start_time, 0.1);
  EXPECT_DOUBLE_EQ(s.end_time, 0.2);
  // about 0.17 degrees between firings: 2083 firings per turn at 10 Hz
  double tmin = 1e9, tmax = -1e9;
  for (const auto& p : s.points) {
    tmin = std::min(tmin, p.time);
    tmax = std::max(tmax, p.time);
    EXPECT_GE(p.azimuth, 0.0f);
    EXPECT_LT(p.azimuth, 6.2832f);
  }
  EXPECT_GE(tmin, 0.1);
  EXPECT_LT(tmax, 0.2);
  EXPECT_GT(tmax - tmin, 0.095);  // firings spread over the whole revolution
}

TEST(LidarTest, RangeNoiseHasTheConfiguredSpread) {
  auto world = test::wallWorld(12.0);
  SimConfig noisy = quietConfig();
  noisy.lidar.range_noise = 0.05;
  SimulatedRig clean(world, quietConfig(), 1), rig(world, noisy, 1);
  const auto a = clean.next(), b = rig.next();
  // pair up returns by ring and azimuth, then compare ranges
  std::map<std::pair<int, float>, double> ranges;
  for (const auto& p : a->sensors.sweep.points) ranges[{p.ring, p.azimuth}] = std::hypot(p.x, p.y, p.z - 0.0f);
  double sum = 0, sum2 = 0;
  int n = 0;
  for (const auto& p : b->sensors.sweep.points) {
    auto it = ranges.find({p.ring, p.azimuth});
    if (it == ranges.end() || std::abs(p.z) > 1.0f) continue;  // keep near-horizontal beams: offsets negligible
    const double e = std::hypot(p.x, p.y, p.z) - it->second;
    sum += e;
    sum2 += e * e;
    ++n;
  }
  ASSERT_GT(n, 1000);
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.01);
  EXPECT_NEAR(sd, 0.05, 0.01);
}

}  // namespace
}  // namespace terrain::sim
