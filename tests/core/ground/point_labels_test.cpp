#include "core/ground_segmentation.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace terrain {
namespace {

// A 1 m x 1 m patch of ground with 0.2 m voxels: 5 x 5 columns, each with returns at 2 and 5 cm.
// In the middle column the foot of a wall adds returns at 11 and 15 cm (the same voxel as the
// ground's). The corner column (0, 0) is non-ground as a whole (a car's underside above it), with
// a return at 3 cm and one at 15 cm. A column 10 m away, non-ground too, has no ground beside it.
struct Scene {
  std::vector<Point3> points;
  VoxelMap map{VoxelMapConfig{}};
  std::vector<std::uint32_t> voxel_of;
  std::vector<std::uint8_t> voxel_ground;
  std::size_t wall_low = 0, wall_high = 0, car_low = 0, car_high = 0, far = 0;

  Scene() {
    auto at = [](int i, int j, double z) { return Point3(0.1 + 0.2 * i, 0.1 + 0.2 * j, z); };
    for (int i = 0; i < 5; ++i)
      for (int j = 0; j < 5; ++j)
        if (i != 0 || j != 0) points.push_back(at(i, j, 0.02)), points.push_back(at(i, j, 0.05));
    wall_low = points.size(), points.push_back(at(2, 2, 0.11));
    wall_high = points.size(), points.push_back(at(2, 2, 0.15));
    car_low = points.size(), points.push_back(at(0, 0, 0.03));
    car_high = points.size(), points.push_back(at(0, 0, 0.15));
    far = points.size(), points.push_back(at(50, 0, 0.03));
    map.insert(points, 0, nullptr, &voxel_of);
    // every voxel ground but the car's column's and the far one
    voxel_ground.assign(map.size(), 1);
    voxel_ground[voxel_of[car_low]] = 0;
    voxel_ground[voxel_of[far]] = 0;
  }
};

TEST(PointLabelsTest, APointOfAGroundVoxelStandingAboveTheGroundsLevelIsNotGround) {
  const Scene s;
  const GroundSegmentationConfig cfg;  // point_rise 0.1 m, point_reach 0.05 m
  const auto labels = labelScanPoints(s.map, s.points, s.voxel_of, s.voxel_ground, cfg);
  ASSERT_EQ(labels.size(), s.points.size());
  // the level everywhere is 0.02 m (the lowest ground return of every column)
  EXPECT_EQ(labels[0], 1);
  EXPECT_EQ(labels[1], 1);
  EXPECT_EQ(labels[s.wall_low], 1);   // 0.09 m above the level
  EXPECT_EQ(labels[s.wall_high], 0);  // 0.13 m above it
}

TEST(PointLabelsTest, APointOfANonGroundVoxelOnTheGroundsLevelBesideItIsGround) {
  const Scene s;
  const GroundSegmentationConfig cfg;
  const auto labels = labelScanPoints(s.map, s.points, s.voxel_of, s.voxel_ground, cfg);
  EXPECT_EQ(labels[s.car_low], 1);   // 0.01 m from the level of the columns beside it
  EXPECT_EQ(labels[s.car_high], 0);  // 0.13 m above it
  EXPECT_EQ(labels[s.far], 0);       // no ground beside it
}

TEST(PointLabelsTest, OffEachPointTakesItsVoxelsLabel) {
  const Scene s;
  GroundSegmentationConfig cfg;
  cfg.point_rise = 0;
  const auto labels = labelScanPoints(s.map, s.points, s.voxel_of, s.voxel_ground, cfg);
  for (std::size_t i = 0; i < s.points.size(); ++i) EXPECT_EQ(labels[i], s.voxel_ground[s.voxel_of[i]]) << i;
}

TEST(PointLabelsTest, APointInNoVoxelIsNotGround) {
  Scene s;
  s.voxel_of[0] = VoxelMap::kNoVoxel;
  const auto labels = labelScanPoints(s.map, s.points, s.voxel_of, s.voxel_ground, GroundSegmentationConfig{});
  EXPECT_EQ(labels[0], 0);
  EXPECT_EQ(labels[1], 1);
}

// The level is the lower median of the lowest ground returns of the column and its eight
// neighbours: nine columns whose lowest returns lie at 10, 11, ..., 18 cm (in no order) give 14 cm.
// A return 23.5 cm up in the middle column, in a non-ground voxel (the one above), lies within a
// point_reach of 10 cm of it and is ground; without the north-east column (18 cm) the lower median
// of eight is 13 cm, and the same return is not. One 25 cm up is ground in neither.
TEST(PointLabelsTest, TheLevelIsTheLowerMedianOfTheNineColumnsLowestGround) {
  for (const bool all_nine : {true, false}) {
    std::vector<Point3> points;
    const int lowest_cm[3][3] = {{15, 10, 17}, {12, 16, 11}, {13, 14, 18}};  // [j][i]: column (i, j)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i)
        if (all_nine || i != 2 || j != 2) points.emplace_back(0.1 + 0.2 * i, 0.1 + 0.2 * j, 0.01 * lowest_cm[j][i]);
    const std::size_t near = points.size(), far = near + 1;
    points.emplace_back(0.3, 0.3, 0.235);
    points.emplace_back(0.3, 0.3, 0.25);
    VoxelMap map{VoxelMapConfig{}};
    std::vector<std::uint32_t> voxel_of;
    map.insert(points, 0, nullptr, &voxel_of);
    std::vector<std::uint8_t> voxel_ground(map.size(), 1);
    voxel_ground[voxel_of[near]] = 0;
    GroundSegmentationConfig cfg;
    cfg.point_reach = 0.1;
    const auto labels = labelScanPoints(map, points, voxel_of, voxel_ground, cfg);
    EXPECT_EQ(labels[near], all_nine ? 1 : 0) << all_nine;
    EXPECT_EQ(labels[far], 0) << all_nine;
  }
}

// On ground rising 15 cm across a column (z = 0.75 x), a column's returns at its downhill and
// uphill edges lie 13.5 cm apart: the uphill one is within point_rise (10 cm) plus that rise of the
// level (the column's own lowest, the median of its row) and stays ground; a return 30 cm above
// the ground does not.
TEST(PointLabelsTest, OnASlopeTheRiseAcrossAColumnIsAllowed) {
  std::vector<Point3> points;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      for (const double x : {0.2 * i + 0.01, 0.2 * i + 0.19}) points.emplace_back(x, 0.2 * j + 0.1, 0.75 * x);
  const std::size_t uphill = 2 * (2 * 5 + 2) + 1;  // column (2, 2), its uphill return
  const std::size_t above = points.size();
  points.emplace_back(0.5, 0.5, 0.75 * 0.5 + 0.3);
  VoxelMap map{VoxelMapConfig{}};
  std::vector<std::uint32_t> voxel_of;
  map.insert(points, 0, nullptr, &voxel_of);
  const std::vector<std::uint8_t> voxel_ground(map.size(), 1);
  const auto labels = labelScanPoints(map, points, voxel_of, voxel_ground, GroundSegmentationConfig{});
  ASSERT_NEAR(points[uphill].x(), 0.59, 1e-12);
  EXPECT_EQ(labels[uphill], 1);
  EXPECT_EQ(labels[uphill - 1], 1);
  EXPECT_EQ(labels[above], 0);
}

}  // namespace
}  // namespace terrain
