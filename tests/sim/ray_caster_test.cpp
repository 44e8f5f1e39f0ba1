#include "sim/ray_caster.hpp"
#include "sim/hfield_ray.hpp"

#include "scenes/scene_generator.hpp"
#include "sim/lidar.hpp"
#include "tests/test_support.hpp"

#include "core/random.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace terrain::sim {
namespace {

TEST(RayCasterTest, WallIsHitAtDistanceOverCosElevation) {
  const double d = 10.0;
  auto world = test::wallWorld(d);
  const RayCaster caster(world->model(), world->data(), world->robotBody());
  const int wall = mj_name2id(world->model(), mjOBJ_GEOM, "wall");
  // beams of an offset-free laser at several elevations, straight ahead from 2 m height
  for (double elev : {0.0, 0.05, -0.05, 0.1, -0.15}) {
    rig::LaserCorrection laser;
    laser.vert_correction = elev;
    Vector3 o, dir;
    rig::laserRay(laser, 0.0, o, dir);
    const RayHit hit = caster.cast(o + Vector3(0, 0, 2), dir);
    ASSERT_EQ(hit.geom, wall) << "elevation " << elev;
    EXPECT_NEAR(hit.distance, d / std::cos(elev), 1e-9);
  }
}

TEST(RayCasterTest, BeamAzimuthIsClockwiseFromForward) {
  rig::LaserCorrection laser;
  Vector3 o, dir;
  rig::laserRay(laser, 0.5 * M_PI, o, dir);  // a quarter turn clockwise seen from above: right
  EXPECT_NEAR(dir.x(), 0.0, 1e-12);
  EXPECT_NEAR(dir.y(), -1.0, 1e-12);
  laser.rot_correction = 0.1;  // the beam lags the encoder by rot_correction
  rig::laserRay(laser, 0.1, o, dir);
  EXPECT_NEAR(dir.x(), 1.0, 1e-12);
  EXPECT_NEAR(dir.y(), 0.0, 1e-12);
}

// the hierarchy must answer exactly as MuJoCo's own mj_ray on a full generated scene
TEST(RayCasterTest, MatchesMjRayOnGeneratedScene) {
  test::TempDir dir;
  for (const char* type : {"urban", "forest"}) {
    scenes::SceneConfig cfg;
    cfg.type = type;
    cfg.seed = 3;
    cfg.extent = 40;
    scenes::writeScene(scenes::generateScene(cfg), dir / (std::string(type) + ".xml"), false);
    const World world(dir / (std::string(type) + ".xml"));
    const RayCaster caster(world.model(), world.data(), world.robotBody());
    Random rng(11);
    int hits = 0;
    for (int i = 0; i < 4000; ++i) {
      const Vector3 p(rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(0.5, 4.0) + world.terrainHeight(0, 0));
      const double az = rng.uniform(0, 2 * M_PI), el = rng.uniform(-0.45, 0.2);
      const Vector3 v(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      const RayHit fast = caster.cast(p, v), ref = caster.castReference(p, v);
      ASSERT_EQ(fast.geom, ref.geom) << type << " ray " << i;
      if (ref.geom >= 0) {
        EXPECT_NEAR(fast.distance, ref.distance, 1e-6);
        ++hits;
      }
    }
    EXPECT_GT(hits, 3000) << type;
  }
}

}  // namespace
}  // namespace terrain::sim

namespace terrain::sim {
namespace {

// the cell walk must give MuJoCo's own heightfield distances on steep, rough terrain
TEST(HfieldRayTest, MatchesMjRayHfieldOnRoughAndSlopedTerrain) {
  test::TempDir dir;
  for (const char* type : {"rough", "slope", "mixed"}) {
    scenes::SceneConfig cfg;
    cfg.type = type;
    cfg.seed = 2;
    cfg.extent = 30;
    cfg.hfield_cell = 0.5;
    scenes::writeScene(scenes::generateScene(cfg), dir / (std::string(type) + ".xml"), false);
    const World world(dir / (std::string(type) + ".xml"));
    const int g = world.terrainGeom();
    Random rng(17);
    int hits = 0;
    for (int i = 0; i < 3000; ++i) {
      const double x = rng.uniform(-28, 28), y = rng.uniform(-28, 28);
      // from just above the ground, and from far outside and above the field
      const bool outside = i % 10 == 0;
      const Vector3 p = outside ? Vector3(rng.uniform(-60, 60), rng.uniform(-60, 60), rng.uniform(-5, 40))
                                : Vector3(x, y, world.terrainHeight(x, y) + rng.uniform(0.3, 3.0));
      const double az = rng.uniform(0, 2 * M_PI), el = outside ? rng.uniform(-1.2, 0.3) : rng.uniform(-0.45, 0.1);
      const Vector3 v(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      const mjtNum pnt[3] = {p.x(), p.y(), p.z()}, vec[3] = {v.x(), v.y(), v.z()};
      const double ref = mj_rayHfield(world.model(), world.data(), g, pnt, vec);
      const double fast = rayHfield(world.model(), world.data(), g, pnt, vec);
      ASSERT_EQ(ref < 0, fast < 0) << type << " ray " << i << ": " << ref << " vs " << fast;
      if (ref >= 0) {
        ASSERT_NEAR(fast, ref, 1e-6) << type << " ray " << i;
        ++hits;
      }
    }
    EXPECT_GT(hits, 1500) << type;
  }
}

}  // namespace
}  // namespace terrain::sim
