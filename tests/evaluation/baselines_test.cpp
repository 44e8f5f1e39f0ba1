#include "evaluation/baselines.hpp"

#include "core/random.hpp"

#include <gtest/gtest.h>

#include <cmath>

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

// Points scattered in x and y (a raw scan) are filtered by PCL itself: the same labels.
TEST(MorphologicalFilterTest, ScatteredPointsGiveTheLabelsOfPcl) {
  Random rng(9);
  std::vector<Point3> cloud;
  for (int i = 0; i < 4000; ++i) {
    const double x = rng.uniform(-20, 20), y = rng.uniform(-20, 20);
    cloud.emplace_back(x, y, 0.1 * x + (std::abs(x) < 3 && std::abs(y) < 3 ? 5.0 : 0.0) + 0.02 * rng.normal());
  }
  const MorphologicalFilterConfig config;
  EXPECT_EQ(groundByMorphologicalFilter(cloud, config), groundByMorphologicalFilterPcl(cloud, config));
  EXPECT_TRUE(groundByMorphologicalFilter({}, config).empty());
}

}  // namespace
}  // namespace terrain::eval
