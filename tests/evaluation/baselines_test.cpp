#include "evaluation/baselines.hpp"

#include "core/random.hpp"
#include "rig/kitti.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace terrain::eval {
namespace {

// the voxels of a small map as the report hands them to the filter: column centres on a 0.2 m
// grid, each voxel at its mean height; rolling ground, a building, a wall, posts and noise
std::vector<Point3> voxelCloud(double cell) {
  std::vector<Point3> out;
  Random rng(3);
  for (int ix = -100; ix < 100; ++ix) {
    for (int iy = -60; iy < 60; ++iy) {
      if (rng.uniform() < 0.15) continue;  // columns the lidar missed
      const double x = (ix + 0.5) * cell, y = (iy + 0.5) * cell;
      const double ground = 0.6 * std::sin(x / 9) + 0.3 * std::cos(y / 5) + 0.05 * x;
      out.emplace_back(x, y, ground + 0.02 * rng.normal());
      int above = 0;
      if (std::abs(x - 10) < 4 && std::abs(y + 5) < 3) above = 40;  // a building's walls and roof
      if (std::abs(x + 12) < 0.3) above = 12;                       // a wall
      if (ix % 37 == 0 && iy % 23 == 0) above = 8;                  // posts
      for (int k = 1; k <= above; ++k) {
        if (above == 40 && k < 38 && std::abs(x - 10) < 3.7 && std::abs(y + 5) < 2.7) continue;  // hollow
        out.emplace_back(x, y, ground + k * cell + 0.01 * rng.normal());
      }
    }
  }
  return out;
}

// On a voxel map's columns the grid computes what PCL's octree computes, point for point, at the
// default windows and at wider ones; on a voxel size whose multiples meet the window's half width
// exactly, too (the inclusive bounds).
TEST(MorphologicalFilterTest, TheGridGivesPclsLabelsOnVoxelColumns) {
  for (const double cell : {0.2, 0.25}) {
    const std::vector<Point3> cloud = voxelCloud(cell);
    for (const int window : {8, 12}) {
      MorphologicalFilterConfig config;
      config.max_window_size = window;
      const std::vector<std::uint8_t> grid = groundByMorphologicalFilter(cloud, config);
      const std::vector<std::uint8_t> pcl = groundByMorphologicalFilterPcl(cloud, config);
      ASSERT_EQ(grid.size(), cloud.size());
      std::size_t differ = 0, ground = 0;
      for (std::size_t i = 0; i < cloud.size(); ++i) differ += grid[i] != pcl[i], ground += grid[i];
      EXPECT_EQ(differ, 0u) << "cell " << cell << ", window " << window;
      // the filter keeps most of the ground and drops the roof
      EXPECT_GT(ground, cloud.size() / 2) << "cell " << cell << ", window " << window;
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        if (std::abs(cloud[i].x() - 10) < 3.5 && std::abs(cloud[i].y() + 5) < 2.5 && cloud[i].z() > 7) {
          EXPECT_EQ(grid[i], 0) << "roof point " << i;
          break;
        }
      }
    }
  }
}

// Counts of labels that differ between two labellings, and of ground in the first.
struct Comparison {
  std::size_t differ = 0, ground = 0;
};
Comparison compare(const std::vector<std::uint8_t>& ours, const std::vector<std::uint8_t>& pcl) {
  Comparison c;
  EXPECT_EQ(ours.size(), pcl.size());
  for (std::size_t i = 0; i < std::min(ours.size(), pcl.size()); ++i)
    c.differ += ours[i] != pcl[i], c.ground += ours[i];
  return c;
}

// Points scattered in x and y (a raw scan) give PCL's labels too, through the bucketed boxes.
TEST(MorphologicalFilterTest, ScatteredPointsGiveTheLabelsOfPcl) {
  Random rng(9);
  std::vector<Point3> cloud;
  for (int i = 0; i < 4000; ++i) {
    const double x = rng.uniform(-20, 20), y = rng.uniform(-20, 20);
    cloud.emplace_back(x, y, 0.1 * x + (std::abs(x) < 3 && std::abs(y) < 3 ? 5.0 : 0.0) + 0.02 * rng.normal());
  }
  const MorphologicalFilterConfig config;
  const Comparison c =
      compare(groundByMorphologicalFilter(cloud, config), groundByMorphologicalFilterPcl(cloud, config));
  EXPECT_EQ(c.differ, 0u);
  EXPECT_GT(c.ground, cloud.size() / 2);
  EXPECT_LT(c.ground, cloud.size() - 50);  // the block's top (about 90 points) is not ground
  EXPECT_TRUE(groundByMorphologicalFilter({}, config).empty());
}

// A scan-like cloud: rings whose density falls with range, cars and a wall on it, and coordinates
// on a 1/64 m lattice spread so wide that no shared grid fits: the boxes' bounds (multiples of
// 1/4 m from each point) fall exactly on other points, where PCL's inclusive bounds count them.
TEST(MorphologicalFilterTest, AScanWithPointsOnTheBoxBoundsGivesPclsLabels) {
  Random rng(21);
  std::vector<Point3> cloud;
  const auto lattice = [](double v) { return std::round(v * 64) / 64; };
  for (int ring = 0; ring < 40; ++ring) {
    const double range = 3 + ring * ring * 0.05;
    const int n = 1200;
    for (int k = 0; k < n; ++k) {
      const double a = 2 * M_PI * (k + rng.uniform()) / n;
      const double x = lattice(range * std::cos(a)), y = lattice(range * std::sin(a));
      double z = 0.02 * x - 1.7 + 0.03 * rng.normal();
      if (x > 6 && x < 10.5 && std::abs(y - 4) < 1) z += 1.4;                   // a car
      if (std::abs(y + 12) < 0.4) z += 2.5 + rng.uniform();                     // a wall
      if (std::abs(x + 20) < 0.5 && std::abs(y) < 0.5) z += 4 * rng.uniform();  // a post
      cloud.emplace_back(x, y, z);
    }
  }
  // pairs of points exactly a half window apart along x, along y and diagonally
  for (int i = 0; i < 300; ++i) {
    const double x = lattice(rng.uniform(-30, 30)), y = lattice(rng.uniform(-30, 30));
    const double half = 0.5 * (i % 3 == 0 ? 3 : i % 3 == 1 ? 5 : 9);
    cloud.emplace_back(x, y, -1.7 + 0.5 * rng.uniform());
    cloud.emplace_back(x + half, y + (i % 2 ? half : 0), -1.7 + 0.5 * rng.uniform());
  }
  for (const int window : {8, 16}) {
    MorphologicalFilterConfig config;
    config.max_window_size = window;
    const Comparison c =
        compare(groundByMorphologicalFilter(cloud, config), groundByMorphologicalFilterPcl(cloud, config));
    EXPECT_EQ(c.differ, 0u) << "window " << window;
    EXPECT_GT(c.ground, cloud.size() / 2) << "window " << window;
    EXPECT_LT(c.ground, cloud.size() - 500) << "window " << window;
  }
}

// Every 8th point of a real KITTI scan: PCL's labels.
TEST(MorphologicalFilterTest, ARealScanGivesPclsLabels) {
  const auto scan =
      rig::readKittiScan(std::filesystem::path(TERRAIN_SOURCE_DIR) / "tests" / "data" / "semantickitti" / "000000.bin");
  std::vector<Point3> cloud;
  for (std::size_t i = 0; i < scan.points.size(); i += 8) cloud.push_back(scan.points[i]);
  const MorphologicalFilterConfig config;
  const Comparison c =
      compare(groundByMorphologicalFilter(cloud, config), groundByMorphologicalFilterPcl(cloud, config));
  EXPECT_EQ(c.differ, 0u);
  EXPECT_GT(c.ground, cloud.size() / 3);
}

}  // namespace
}  // namespace terrain::eval
