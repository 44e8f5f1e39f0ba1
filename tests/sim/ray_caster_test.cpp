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

// rays aimed at the grid's vertices and at points of its cells' edges, at the surface's height
// there and a hair off them (0.1 um to 0.1 mm: exactly on an edge, rounding decides which of the
// triangles that share it, if any, is hit, for MuJoCo as for the walk): hits at the height of the
// highest vertex of the cells around them, which the walk skips when the ray passes above all of
// those vertices
TEST(HfieldRayTest, MatchesMjRayHfieldNextToVerticesAndEdges) {
  test::TempDir dir;
  scenes::SceneConfig cfg;
  cfg.type = "rough";
  cfg.seed = 4;
  cfg.extent = 30;
  cfg.hfield_cell = 0.5;
  scenes::writeScene(scenes::generateScene(cfg), dir / "rough.xml", false);
  const World world(dir / "rough.xml");
  const mjModel* m = world.model();
  const mjData* d = world.data();
  const int g = world.terrainGeom(), h = m->geom_dataid[g];
  const int nrow = m->hfield_nrow[h], ncol = m->hfield_ncol[h];
  const mjtNum* size = m->hfield_size + 4 * h;
  const float* data = m->hfield_data + m->hfield_adr[h];
  const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> mat(d->geom_xmat + 9 * g);
  const Eigen::Map<const Vector3> pos(d->geom_xpos + 3 * g);
  // the world position of grid vertex (r, c), or of a point a share s along the edge to (r, c + 1)
  const auto at = [&](int r, int c, double s) {
    const double dx = 2 * size[0] / (ncol - 1), dy = 2 * size[1] / (nrow - 1);
    const double z = (1 - s) * data[r * ncol + c] + s * data[r * ncol + c + 1];
    return Vector3(pos + mat * Vector3(dx * (c + s) - size[0], dy * r - size[1], z * size[2]));
  };
  Random rng(23);
  int hits = 0;
  for (int i = 0; i < 4000; ++i) {
    const int r = static_cast<int>(rng.uniform(2, nrow - 3)), c = static_cast<int>(rng.uniform(2, ncol - 3));
    const double off = std::pow(10.0, rng.uniform(-7, -4));
    const double dir_off = rng.uniform(0, 2 * M_PI);
    const Vector3 target = at(r, c, i % 2 == 0 ? 0.0 : rng.uniform(0.01, 0.99)) +
                           off * Vector3(std::cos(dir_off), std::sin(dir_off), rng.uniform(-1, 1));
    // from 5 to 40 m away, 0.2 to 6 m above the target: grazing to steep
    const double az = rng.uniform(0, 2 * M_PI), range = rng.uniform(5, 40);
    const Vector3 p = target + Vector3(range * std::cos(az), range * std::sin(az), rng.uniform(0.2, 6.0));
    const Vector3 v = (target - p).normalized();
    const mjtNum pnt[3] = {p.x(), p.y(), p.z()}, vec[3] = {v.x(), v.y(), v.z()};
    const double ref = mj_rayHfield(m, d, g, pnt, vec);
    const double fast = rayHfield(m, d, g, pnt, vec);
    ASSERT_EQ(ref < 0, fast < 0) << "ray " << i << ": " << ref << " vs " << fast;
    if (ref >= 0) {
      ASSERT_NEAR(fast, ref, 1e-6) << "ray " << i;
      hits += std::abs(ref - (target - p).norm()) < 1e-3;
    }
  }
  // most rays end next to their target
  EXPECT_GT(hits, 2000);
}

}  // namespace
}  // namespace terrain::sim
