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

}  // namespace
}  // namespace terrain
