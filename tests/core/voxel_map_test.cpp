#include "core/voxel_map.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace terrain {
namespace {

// Each point's voxel id, as insert gives it, is the id that looking its voxel up gives; points
// left out (not finite, beyond the map's +-1 M voxels) have none, and a later insert's ids count on.
TEST(VoxelMapTest, InsertGivesEachPointItsVoxel) {
  VoxelMap map(VoxelMapConfig{0.2});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Point3> first = {Point3(0.05, 0.05, 0.05), Point3(0.15, 0.1, 0.19), Point3(nan, 0, 0),
                                     Point3(-0.05, 3.0, -1.0), Point3(1e9, 0, 0),       Point3(0.0, 0.0, 0.0)};
  std::vector<std::uint32_t> voxel_of;
  EXPECT_EQ(map.insert(first, 0, nullptr, &voxel_of), 2u);
  ASSERT_EQ(voxel_of.size(), first.size());
  EXPECT_EQ(voxel_of[0], 0u);
  EXPECT_EQ(voxel_of[1], 0u);  // the same voxel as the first point
  EXPECT_EQ(voxel_of[2], VoxelMap::kNoVoxel);
  EXPECT_EQ(voxel_of[3], 1u);
  EXPECT_EQ(voxel_of[4], VoxelMap::kNoVoxel);
  EXPECT_EQ(voxel_of[5], 0u);
  const std::vector<Point3> second = {Point3(-0.05, 3.0, -1.0), Point3(5.0, 5.0, 0.3)};
  EXPECT_EQ(map.insert(second, 1, nullptr, &voxel_of), 1u);
  ASSERT_EQ(voxel_of.size(), second.size());
  EXPECT_EQ(voxel_of[0], 1u);
  EXPECT_EQ(voxel_of[1], 2u);
  for (std::size_t i = 0; i < second.size(); ++i)
    EXPECT_EQ(static_cast<std::int64_t>(voxel_of[i]), map.find(map.indexOf(second[i])));
  EXPECT_EQ(map.voxels()[0].hits, 3u);
  EXPECT_EQ(map.voxels()[1].hits, 2u);
}

// The map keeps the extent of its voxels' indices as it grows, and a restored map has the extent of
// what it holds; a restore refuses duplicate voxels and indices insert could not create.
TEST(VoxelMapTest, KeepsTheExtentOfItsIndices) {
  VoxelMap map(VoxelMapConfig{0.5});
  EXPECT_EQ(map.lowestIndex(), VoxelIndex(0, 0, 0));
  EXPECT_EQ(map.highestIndex(), VoxelIndex(0, 0, 0));
  map.insert({Point3(3.2, -1.2, 0.4)}, 0);
  EXPECT_EQ(map.lowestIndex(), VoxelIndex(6, -3, 0));
  EXPECT_EQ(map.highestIndex(), VoxelIndex(6, -3, 0));
  map.insert({Point3(-7.9, 4.0, 2.6), Point3(1e9, 0, 0), Point3(0.1, -9.6, -0.2)}, 1);
  EXPECT_EQ(map.lowestIndex(), VoxelIndex(-16, -20, -1));
  EXPECT_EQ(map.highestIndex(), VoxelIndex(6, 8, 5));

  std::vector<Voxel> voxels(map.voxels());
  VoxelMap copy(VoxelMapConfig{0.5});
  ASSERT_TRUE(copy.restore(voxels));
  EXPECT_EQ(copy.lowestIndex(), map.lowestIndex());
  EXPECT_EQ(copy.highestIndex(), map.highestIndex());
  EXPECT_EQ(copy.find(VoxelIndex(-16, 8, 5)), 1);

  // the most negative index insert creates is -(2^20 - 1), the largest 2^20 - 2
  const double edge = (1 << 20) - 1.0;
  map.insert({Point3(-edge * 0.5 + 0.01, 0, 0), Point3((edge - 1) * 0.5 + 0.01, 0, 0)}, 2);
  EXPECT_EQ(map.lowestIndex().x(), -((1 << 20) - 1));
  EXPECT_EQ(map.highestIndex().x(), (1 << 20) - 2);
  ASSERT_TRUE(copy.restore(map.voxels()));
  EXPECT_EQ(copy.lowestIndex().x(), -((1 << 20) - 1));

  std::vector<Voxel> twice = voxels;
  twice.push_back(voxels[1]);
  EXPECT_FALSE(copy.restore(twice));
  EXPECT_EQ(copy.size(), 0u);
  EXPECT_EQ(copy.lowestIndex(), VoxelIndex(0, 0, 0));
  std::vector<Voxel> far = voxels;
  far[2].index.y() = 1 << 20;
  EXPECT_FALSE(copy.restore(far));
  far[2].index.y() = std::numeric_limits<int>::min();
  EXPECT_FALSE(copy.restore(far));
  EXPECT_EQ(copy.size(), 0u);
}

}  // namespace
}  // namespace terrain
