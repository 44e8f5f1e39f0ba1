#include "core/voxel_map.hpp"

#include <gtest/gtest.h>

#include "core/random.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <map>

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

// Many points at once, across the hash table's growth: every voxel gets the id of its first point
// in insert order, and the hits, mean height, frame and colour of its points, as a plain ordered map
// from index to voxel gives them; points left out anywhere in the stream leave no voxel.
TEST(VoxelMapTest, ManyPointsGiveTheVoxelsOfAPlainMap) {
  VoxelMap map(VoxelMapConfig{0.25});
  std::map<std::array<int, 3>, std::uint32_t> id_of;  // the reference
  std::vector<Voxel> expected;
  Random rng(7);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::uint32_t frame = 0; frame < 3; ++frame) {
    std::vector<Point3> points;
    std::vector<std::array<std::uint8_t, 4>> colours;
    for (int i = 0; i < 60000; ++i) {
      // a clustered cloud: most voxels are hit again, many are new
      Point3 p(30 * rng.uniform() - 15, 30 * rng.uniform() - 15, 2 * rng.normal());
      if (i % 997 == 0) p.x() = nan;
      if (i % 1499 == 0) p.y() = 1e12;
      points.push_back(p);
      colours.push_back(
          {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(frame), 7, static_cast<std::uint8_t>(i % 3)});
    }
    std::vector<std::uint32_t> voxel_of;
    const std::size_t before = expected.size();
    const std::size_t created = map.insert(points, frame, &colours, &voxel_of);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Point3& p = points[i];
      if (!p.allFinite() || std::abs(p.y()) > 1e6) {
        EXPECT_EQ(voxel_of[i], VoxelMap::kNoVoxel) << "point " << i;
        continue;
      }
      const VoxelIndex index = map.indexOf(p);
      const auto [it, is_new] = id_of.emplace(std::array<int, 3>{index.x(), index.y(), index.z()},
                                              static_cast<std::uint32_t>(expected.size()));
      if (is_new) {
        expected.emplace_back();
        expected.back().index = index;
      }
      ASSERT_EQ(voxel_of[i], it->second) << "point " << i << " of frame " << frame;
      Voxel& v = expected[it->second];
      v.hits += 1;
      v.height += static_cast<float>((p.z() - v.height) / v.hits);
      v.frame = frame;
      if (colours[i][3]) v.r = colours[i][0], v.g = colours[i][1], v.b = colours[i][2], v.coloured = true;
    }
    EXPECT_EQ(created, expected.size() - before);
  }
  ASSERT_EQ(map.size(), expected.size());
  // past 131,072 voxels: the table grew three times from its first 65,536 slots
  EXPECT_GT(map.size(), 131072u) << map.size();
  for (std::size_t id = 0; id < expected.size(); ++id) {
    const Voxel& a = map.voxels()[id];
    const Voxel& b = expected[id];
    ASSERT_EQ(a.index, b.index) << "voxel " << id;
    EXPECT_EQ(a.hits, b.hits) << "voxel " << id;
    EXPECT_EQ(a.height, b.height) << "voxel " << id;
    EXPECT_EQ(a.frame, b.frame) << "voxel " << id;
    const std::array<int, 4> colour_a{a.r, a.g, a.b, a.coloured}, colour_b{b.r, b.g, b.b, b.coloured};
    EXPECT_EQ(colour_a, colour_b) << "voxel " << id;
    EXPECT_EQ(map.find(b.index), static_cast<std::int64_t>(id));
  }
}

// A cleared map is empty, with no extent and no new voxels, and takes points in as a fresh map does
// (the same ids, heights and extent), its grown table kept.
TEST(VoxelMapTest, AClearedMapTakesPointsInAsAFreshOne) {
  Random rng(7);
  std::vector<Point3> many(20000), few = {Point3(0.3, -0.1, 0.2), Point3(2.0, 1.0, 0.1), Point3(0.35, -0.05, 0.25)};
  for (Point3& p : many) p = Point3(rng.uniform(-40, 40), rng.uniform(-40, 40), rng.uniform(-2, 8));
  VoxelMap map(VoxelMapConfig{0.2});
  map.insert(many, 0);
  const std::size_t grown = map.memoryBytes();
  map.clear();
  EXPECT_EQ(map.size(), 0u);
  EXPECT_EQ(map.lowestIndex(), VoxelIndex(0, 0, 0));
  EXPECT_EQ(map.highestIndex(), VoxelIndex(0, 0, 0));
  EXPECT_EQ(map.memoryBytes(), grown);
  EXPECT_TRUE(map.takeNewVoxels().empty());
  EXPECT_EQ(map.find(map.indexOf(many[0])), -1);
  VoxelMap fresh(VoxelMapConfig{0.2});
  std::vector<std::uint32_t> kept_of, fresh_of;
  EXPECT_EQ(map.insert(few, 3, nullptr, &kept_of), fresh.insert(few, 3, nullptr, &fresh_of));
  EXPECT_EQ(kept_of, fresh_of);
  EXPECT_EQ(map.size(), 2u);
  EXPECT_EQ(map.voxels()[0].height, fresh.voxels()[0].height);
  EXPECT_EQ(map.lowestIndex(), fresh.lowestIndex());
  EXPECT_EQ(map.highestIndex(), fresh.highestIndex());
  EXPECT_EQ(map.find(map.indexOf(few[1])), 1);
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
