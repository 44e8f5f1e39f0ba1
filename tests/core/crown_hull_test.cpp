#include "core/crown_hull.hpp"
#include "core/camera_model.hpp"
#include "tests/core/core_test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace terrain {
namespace {

// A tree 10 m north of a straight path along x: the lidar saw its trunk (one cell centred at
// (0.1, 10.1), sensed up to 3 m) and the level ground around it (0 m, 8 m every way); its crown, a
// sphere of radius 2.5 m centred 9 m up (top 11.5 m), stands wholly above the lidar's reach. A
// camera 1.6 m up looking north drives along the path; its images are traced ray by ray: foliage
// where the ray meets the crown, grass-coloured ground where it meets the ground (foliage-coloured
// too: only the horizon tells them apart), sky elsewhere.
struct Roadside {
  VoxelMap map{VoxelMapConfig{0.2}};
  TerrainMesh mesh;
  CameraIntrinsics k = CameraIntrinsics::fromFovy(320, 240, 100 * M_PI / 180);
  const Point3 crown{0.1, 10.1, 9.0};
  const double radius = 2.5;

  Roadside() {
    std::vector<Voxel> voxels;
    std::vector<MeshVertex> vertices;
    for (int x = -40; x <= 40; ++x) {
      for (int y = 10; y <= 90; ++y) {
        const bool trunk = x == 0 && y == 50;
        test::addColumn(voxels, vertices, CellIndex(x, y), trunk ? 15 : 0, trunk ? 3.0f : 0.0f,
                        trunk ? VoxelLabel::NonGround : VoxelLabel::Ground);
      }
    }
    EXPECT_TRUE(map.restore(voxels));
    EXPECT_TRUE(mesh.restore(vertices));
  }
  static Pose camera(double x) {
    Pose p = Pose::Identity();
    p.linear().col(0) = Vector3(1, 0, 0);
    p.linear().col(1) = Vector3(0, 0, -1);
    p.linear().col(2) = Vector3(0, 1, 0);
    p.translation() = Vector3(x, 0, 1.6);
    return p;
  }
  cv::Mat image(const Pose& world_from_camera, bool with_crown = true) const {
    cv::Mat rgb(k.height, k.width, CV_8UC3);
    const Point3 o = world_from_camera.translation();
    for (int v = 0; v < k.height; ++v) {
      for (int u = 0; u < k.width; ++u) {
        const Vector3 d =
            (world_from_camera.linear() * Vector3((u + 0.5 - k.cx) / k.fx, (v + 0.5 - k.cy) / k.fy, 1)).normalized();
        const Vector3 oc = o - crown;
        const double b = oc.dot(d), c = oc.squaredNorm() - radius * radius;
        cv::Vec3b& px = rgb.at<cv::Vec3b>(v, u);
        if (with_crown && b * b - c >= 0 && -b - std::sqrt(b * b - c) > 0) {
          px = cv::Vec3b(40, 110, 30);  // leaves
        } else if (d.z() < 0) {
          px = cv::Vec3b(90, 120, 60);  // grass
        } else {
          px = cv::Vec3b(120, 170, 235);  // sky
        }
      }
    }
    return rgb;
  }
  // carves the images from cameras at each x
  void drive(CrownHull& hull, const std::vector<double>& xs, const CrownHullConfig& cfg, bool with_crown = true) const {
    const CrownConfig crown_cfg;
    const BoundaryEstimationConfig sky;
    for (const double x : xs) {
      const Pose pose = camera(x);
      const SkylineOwners owners(mesh, map, viewRegion(k, pose, 60.0));
      hull.carve(mesh, map, image(pose, with_crown), k, pose, owners, cfg, crown_cfg, sky);
    }
  }
  double distance(const MeshVertex& m) const {
    return std::hypot((m.cell.x() + 0.5) * 0.2 - crown.x(), (m.cell.y() + 0.5) * 0.2 - crown.y());
  }
  const MeshVertex& at(int x, int y) const { return mesh.vertices()[mesh.find(CellIndex(x, y))]; }
};

std::vector<double> along(double from, double to, double step) {
  std::vector<double> xs;
  for (double x = from; x <= to + 1e-9; x += step) xs.push_back(x);
  return xs;
}

TEST(CrownHullTest, ACrownAboveTheLidarsReachBesideThePathRaisesItsFootprintToItsTop) {
  Roadside tree;
  CrownHull hull;
  CrownHullConfig cfg;
  cfg.enabled = true;
  tree.drive(hull, along(-8, 8, 0.5), cfg);
  EXPECT_GT(hull.columns(), 0u);
  EXPECT_GT(hull.crownVoxels(cfg), 0u);
  EXPECT_GT(hull.apply(tree.mesh, tree.map, cfg, CrownConfig{}), 0);
  // under the crown's top: within 10 % of 11.5 m (the trunk's cell and the ground beside it)
  EXPECT_NEAR(tree.at(0, 50).height(), 11.5, 1.15);
  EXPECT_NEAR(tree.at(1, 50).height(), 11.5, 1.15);
  EXPECT_NEAR(tree.at(0, 51).height(), 11.5, 1.15);
  // 1.5 m from the trunk the sphere's top is 9 + 2 = 11 m
  EXPECT_NEAR(tree.at(7, 50).height(), 11.0, 1.1);
  // the ground outside the crown (by more than a hull cell) stays where the lidar saw it
  int raised_inside = 0, inside = 0;
  for (const MeshVertex& m : tree.mesh.vertices()) {
    const double d = tree.distance(m);
    if (d > tree.radius + cfg.cell) {
      EXPECT_FALSE(m.raised()) << "cell " << m.cell.transpose() << " " << d << " m from the trunk";
    } else if (d < tree.radius - cfg.cell) {
      ++inside, raised_inside += m.raised();
    }
  }
  // most of the footprint is raised
  EXPECT_GT(raised_inside, inside * 7 / 10);
}

// From one place a foliage pixel's ray looks alike all along: without views from elsewhere the
// crown's depth is unknown and nothing is raised, however many frames saw it.
TEST(CrownHullTest, ACrownSeenFromOnePlaceOnlyRaisesNothing) {
  Roadside tree;
  CrownHull hull;
  CrownHullConfig cfg;
  cfg.enabled = true;
  tree.drive(hull, std::vector<double>(20, 0.0), cfg);
  EXPECT_GT(hull.columns(), 0u);
  EXPECT_EQ(hull.crownVoxels(cfg), 0u);
  EXPECT_EQ(hull.apply(tree.mesh, tree.map, cfg, CrownConfig{}), 0);
  EXPECT_FALSE(tree.at(0, 50).raised());
}

// Sky over the trunk in every view, and grass below the horizon (foliage-coloured, but seen below
// the sensed ground's horizon): no crown.
TEST(CrownHullTest, SkyAndGrassMakeNoCrown) {
  Roadside tree;
  CrownHull hull;
  CrownHullConfig cfg;
  cfg.enabled = true;
  tree.drive(hull, along(-8, 8, 0.5), cfg, false);
  EXPECT_EQ(hull.crownVoxels(cfg), 0u);
  EXPECT_EQ(hull.apply(tree.mesh, tree.map, cfg, CrownConfig{}), 0);
  for (const MeshVertex& m : tree.mesh.vertices()) EXPECT_FALSE(m.raised());
}

// The hull of crown completion's sky guard (1 m voxels out to where crowns are measured, voted on
// whatever hull.enabled says): the sky shows through the air beside the crown at its height, not
// through the crown, and over its top; nowhere outside the columns.
TEST(CrownHullTest, TheSkyShowsThroughTheAirBesideACrownNotThroughIt) {
  Roadside tree;
  CrownHull hull;
  CrownConfig crown;
  crown.sky_guard = true;
  const BoundaryEstimationConfig estimation;
  const CrownHullConfig cfg = skyGuardHull(crown, estimation);
  EXPECT_TRUE(cfg.enabled);
  EXPECT_EQ(cfg.cell, crown.guard_cell);
  EXPECT_EQ(cfg.layer, crown.guard_cell);
  EXPECT_EQ(cfg.max_radius, crown.max_radius);
  EXPECT_EQ(cfg.max_distance, CrownSampler::ownersReach(crown, estimation));
  // the estimates' guard alone needs only the trunks' own columns
  crown.sky_guard = false;
  crown.guard_estimates = true;
  EXPECT_EQ(skyGuardHull(crown, estimation).max_radius, 0.5 * crown.max_grown_width + crown.guard_cell);
  tree.drive(hull, along(-8, 8, 0.5), cfg);
  EXPECT_GT(hull.columns(), 0u);
  // the crown's column from its equator (9 m) to its top (11.5 m), and half way out
  EXPECT_FALSE(hull.skyThrough(0.1, 10.1, 9.0, 11.5, cfg));
  EXPECT_FALSE(hull.skyThrough(1.35, 10.1, 9.0, 10.5, cfg));
  // 4 m east of the trunk, 1.5 m outside the crown, at the crown's heights
  EXPECT_TRUE(hull.skyThrough(4.1, 10.1, 9.0, 11.5, cfg));
  // over the crown's top (the layer of 13-14 m: the one above lies beyond the cameras' 50 degrees up)
  EXPECT_TRUE(hull.skyThrough(0.1, 10.1, 13.0, 13.9, cfg));
  // outside every column (more than max_radius from the trunk)
  EXPECT_FALSE(hull.skyThrough(12.1, 10.1, 9.0, 11.5, cfg));
}

// How far down the sky shows through a column without a break: over the crown to its top, beside
// it to below its equator; inside the crown, or where no column was voted on, not at all.
TEST(CrownHullTest, TheSkyFloorOverACrownIsItsTop) {
  Roadside tree;
  CrownHull hull;
  CrownConfig crown;
  crown.sky_guard = true;  // columns out to a crown's radius, for the test beside it
  const CrownHullConfig cfg = skyGuardHull(crown, BoundaryEstimationConfig{});
  tree.drive(hull, along(-8, 8, 0.5), cfg);
  // from 13.5 m over the trunk: down to within a layer of the crown's top (11.5 m)
  const double over = hull.skyFloor(0.1, 10.1, 13.5, cfg);
  EXPECT_GE(over, 11.0);
  EXPECT_LE(over, 12.5);
  // from above the column (30 m) or its layers no image saw (past the cameras' 50 degrees up from
  // this short stretch of road): the same
  EXPECT_EQ(hull.skyFloor(0.1, 10.1, 40.0, cfg), over);
  EXPECT_EQ(hull.skyFloor(0.1, 10.1, 20.0, cfg), over);
  EXPECT_EQ(hull.skyFloor(0.1, 10.1, 10.5, cfg), 10.5);   // inside the crown
  EXPECT_LT(hull.skyFloor(4.1, 10.1, 11.0, cfg), 9.0);    // beside it
  EXPECT_EQ(hull.skyFloor(12.1, 10.1, 10.0, cfg), 10.0);  // no column there
}

// A trunk raised tens of metres too high (a top edge of something nearer, taken at its depth) is
// lowered to where the sky shows through its column from above, near its crown's top; a trunk
// raised to its crown's top, and ground raised under the crown, are left as they are.
TEST(CrownHullTest, TheGuardLowersAnEstimateTheSkyShowsThrough) {
  Roadside tree;
  CrownHull hull;
  CrownConfig crown;
  crown.guard_estimates = true;
  const CrownHullConfig cfg = skyGuardHull(crown, BoundaryEstimationConfig{});
  tree.drive(hull, along(-8, 8, 0.5), cfg);
  const auto raise = [&](int x, int y, float h) {
    MeshVertex& m = tree.mesh.vertices()[tree.mesh.find(CellIndex(x, y))];
    m.spread = true;
    m.recovered_height = h;
  };
  raise(0, 50, 40.0f);  // the trunk
  raise(1, 50, 11.5f);  // the ground beside it, under the crown
  EXPECT_EQ(lowerUnderSky(tree.mesh, tree.map, hull, cfg, crown), 1);
  EXPECT_GE(tree.at(0, 50).height(), 11.0);
  EXPECT_LE(tree.at(0, 50).height(), 12.5);
  EXPECT_EQ(tree.at(1, 50).height(), 11.5f);
  // at its crown's top already: within a layer of the floor, left alone
  raise(0, 50, 11.8f);
  EXPECT_EQ(lowerUnderSky(tree.mesh, tree.map, hull, cfg, crown), 0);
  EXPECT_EQ(tree.at(0, 50).height(), 11.8f);
}

TEST(CrownHullTest, OffItTakesNoVote) {
  Roadside tree;
  CrownHull hull;
  CrownHullConfig cfg;
  cfg.enabled = false;
  tree.drive(hull, along(-8, 8, 4), cfg);
  EXPECT_EQ(hull.columns(), 0u);
  EXPECT_EQ(hull.apply(tree.mesh, tree.map, cfg, CrownConfig{}), 0);
}

}  // namespace
}  // namespace terrain
