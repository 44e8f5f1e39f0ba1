#include "core/free_space.hpp"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>

namespace terrain {
namespace {

constexpr double kCell = 0.2;          // [m]
const cv::Vec3b kSky(120, 160, 230);   // passes the sky test: blue well above red, not below green, bright
const cv::Vec3b kGrey(100, 100, 100);  // does not

// A level camera 1.6 m up at the origin looking east, 64 x 48 px with fx = fy = 24 (90 degrees
// across): rows 0-23 sky, rows 24-47 grey; columns [block_lo, block_hi) grey all the way up
// (an object filling them).
struct View {
  CameraIntrinsics k;
  Pose world_from_camera = Pose::Identity();
  cv::Mat rgb;
  explicit View(int block_lo = 0, int block_hi = 0) {
    k.width = 64, k.height = 48, k.fx = k.fy = 24, k.cx = 32, k.cy = 24;
    world_from_camera.linear().col(0) = Vector3(0, -1, 0);  // right: south
    world_from_camera.linear().col(1) = Vector3(0, 0, -1);  // down
    world_from_camera.linear().col(2) = Vector3(1, 0, 0);   // forward: east
    world_from_camera.translation() = Vector3(0, 0, 1.6);
    rgb = cv::Mat(48, 64, CV_8UC3, kGrey);
    rgb.rowRange(0, 24).setTo(kSky);
    if (block_hi > block_lo) rgb.colRange(block_lo, block_hi).setTo(kGrey);
  }
};

CellIndex cellAt(double x, double y) {
  return CellIndex(static_cast<int>(std::floor(x / kCell)), static_cast<int>(std::floor(y / kCell)));
}

// the cell x metres east under column 31's ray, which runs half a pixel (0.5 / 24 m per metre) north
// of east: 10 m out the columns' rays lie 0.42 m apart, more than a cell, so one view carves lanes
CellIndex onRay(double x) { return cellAt(x, x * 0.5 / 24); }

// the stage switched on (it is off by default)
FreeSpaceConfig on() {
  FreeSpaceConfig c;
  c.enabled = true;
  return c;
}

TEST(SkyCeilingTest, TheLowestSkyRayBoundsTheCellsItPassesOver) {
  const View view;
  SkyCeiling ceiling(kCell);
  const FreeSpaceConfig cfg = on();
  // one ray per column: the bottom of its single run of sky (row 23)
  EXPECT_EQ(ceiling.carve(view.rgb, view.k, view.world_from_camera, cfg, BoundaryEstimationConfig{}), 64);
  // row 23's centre lies half a pixel above the optical axis: the ray rises 0.5 / 24 m per metre
  // ahead; over a cell [10, 10.2) east the lowest sample lies at its near edge, 10 m out
  const double rise = 0.5 / 24;
  EXPECT_NEAR(ceiling.ceiling(onRay(10.05)), 1.6 + 10.0 * rise + cfg.margin, 0.01);
  EXPECT_NEAR(ceiling.ceiling(onRay(50.05)), 1.6 + 50.0 * rise + cfg.margin, 0.01);
  // behind the camera, nearer than min_distance and past max_distance: no ray
  EXPECT_TRUE(std::isinf(ceiling.ceiling(cellAt(-5.05, 0.05))));
  EXPECT_TRUE(std::isinf(ceiling.ceiling(cellAt(0.55, 0.05))));
  EXPECT_TRUE(std::isinf(ceiling.ceiling(cellAt(cfg.max_distance + 1, 0.05))));
  // outside the view (more than atan(32 / 24) = 53 degrees to the side)
  EXPECT_TRUE(std::isinf(ceiling.ceiling(cellAt(10.05, 15.05))));
  // a second, lower view only lowers the bound: the same camera 1 m lower
  View low;
  low.world_from_camera.translation().z() = 0.6;
  ceiling.carve(low.rgb, low.k, low.world_from_camera, cfg, BoundaryEstimationConfig{});
  EXPECT_NEAR(ceiling.ceiling(onRay(10.05)), 0.6 + 10.0 * rise + cfg.margin, 0.01);
}

TEST(SkyCeilingTest, NoRayPassesOverWhatHidesTheSky) {
  // an object fills columns 24-39, the 16 around the optical axis (+-18 degrees)
  const View view(24, 40);
  SkyCeiling ceiling(kCell);
  EXPECT_EQ(ceiling.carve(view.rgb, view.k, view.world_from_camera, on(), BoundaryEstimationConfig{}), 48);
  EXPECT_TRUE(std::isinf(ceiling.ceiling(onRay(10.05))));
  // the sky beside it is carved: column 50's ray (azimuth atan(18.5 / 24) south of east)
  const double a = std::atan(18.5 / 24);
  EXPECT_TRUE(std::isfinite(ceiling.ceiling(cellAt(10 * std::cos(a), -10 * std::sin(a)))));
}

TEST(SkyCeilingTest, ApplyLowersRaisedObjectVerticesToTheCeilingNeverBelowTheSensedTop) {
  const View view;
  SkyCeiling ceiling(kCell);
  const FreeSpaceConfig cfg = on();
  ceiling.carve(view.rgb, view.k, view.world_from_camera, cfg, BoundaryEstimationConfig{});
  const float bound = ceiling.ceiling(onRay(10.05));
  // voxel 0 a sensed object's (non-ground), voxel 1 ground under a crown
  VoxelMap map(VoxelMapConfig{});
  std::vector<Voxel> voxels(2);
  voxels[0].index = VoxelIndex(0, 0, 0), voxels[0].label = VoxelLabel::NonGround;
  voxels[1].index = VoxelIndex(1, 0, 0), voxels[1].label = VoxelLabel::Ground;
  ASSERT_TRUE(map.restore(voxels));
  std::vector<MeshVertex> v(5);
  for (auto& m : v) m.cell = onRay(10.05);
  // raised far above the bound (lowered), raised below it (kept), sensed above it (kept), not raised
  v[0].sensed_height = 0.5f, v[0].recovered_height = 20.0f, v[0].estimates = {{}};
  v[1].sensed_height = 0.5f, v[1].recovered_height = bound - 0.1f, v[1].estimates = {{}};
  v[2].sensed_height = bound + 1.0f, v[2].recovered_height = 20.0f, v[2].estimates = {{}};
  v[3].sensed_height = 0.5f, v[3].recovered_height = 20.0f;
  // ground raised by crown completion: a ray may pass under a crown, so no bound
  v[4].sensed_height = 0.5f, v[4].recovered_height = 20.0f, v[4].spread = true, v[4].top_voxel = 1;
  for (int i = 1; i < 5; ++i) v[i].cell.x() += i;  // one vertex a cell
  TerrainMesh mesh;
  ASSERT_TRUE(mesh.restore(v));
  EXPECT_EQ(ceiling.apply(mesh, map), 2);  // the first, and the third down to its sensed top
  const auto& out = mesh.vertices();
  EXPECT_NEAR(out[0].height(), bound, 1e-6);
  EXPECT_FLOAT_EQ(out[1].height(), bound - 0.1f);
  EXPECT_FLOAT_EQ(out[2].height(), bound + 1.0f);
  EXPECT_FLOAT_EQ(out[3].height(), 0.5f);
  EXPECT_FLOAT_EQ(out[4].height(), 20.0f);
  EXPECT_TRUE(std::isinf(out[4].ceiling));
}

TEST(SkyCeilingTest, SwitchedOffItCastsNothing) {
  const View view;
  SkyCeiling ceiling(kCell);
  EXPECT_EQ(ceiling.carve(view.rgb, view.k, view.world_from_camera, FreeSpaceConfig{}, BoundaryEstimationConfig{}), 0);
  EXPECT_EQ(ceiling.cells(), 0u);
}

}  // namespace
}  // namespace terrain
