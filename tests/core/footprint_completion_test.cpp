#include "core/footprint_completion.hpp"
#include "tests/core/core_test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

namespace terrain {
namespace {

// A map of 0.2 m cells: wall cells (non-ground, sensed 3 m high, the first `raised` of them with a
// 10 m estimate) and ground cells (0 m).
struct Scene {
  VoxelMap map{VoxelMapConfig{0.2}};
  TerrainMesh mesh;
  Scene(const std::vector<CellIndex>& walls, std::size_t raised, const std::vector<CellIndex>& ground) {
    std::vector<Voxel> voxels;
    std::vector<MeshVertex> vertices;
    auto add = [&](const CellIndex& c, float height, VoxelLabel label) {
      test::addColumn(voxels, vertices, c, static_cast<int>(std::floor(height / 0.2)), height, label);
    };
    for (const auto& c : walls) add(c, 3.0f, VoxelLabel::NonGround);
    for (const auto& c : ground) add(c, 0.0f, VoxelLabel::Ground);
    EXPECT_TRUE(map.restore(voxels));
    EXPECT_TRUE(mesh.restore(vertices));
    for (std::size_t i = 0; i < raised && i < walls.size(); ++i)
      mesh.addEstimate(static_cast<std::uint32_t>(i), {10.0f, 20.0f, 1.6f}, 15);
  }
};

// The building occupies x in [2, 8) m and y in [2, 6) m: cells 10-39 by 10-29. The robot saw its
// south wall (row 10) and its west wall (column 10); nothing inside was sensed.
std::vector<CellIndex> southWall() {
  std::vector<CellIndex> cells;
  for (int x = 10; x < 40; ++x) cells.emplace_back(x, 10);
  return cells;
}
std::vector<CellIndex> southAndWestWalls() {
  std::vector<CellIndex> cells = southWall();
  for (int y = 11; y < 30; ++y) cells.emplace_back(10, y);
  return cells;
}
// ground south and west of the building, where the robot drove
std::vector<CellIndex> groundOutside() {
  std::vector<CellIndex> cells;
  for (int x = 0; x < 50; ++x) {
    for (int y = 0; y < 40; ++y) {
      if (x < 10 || y < 10) cells.emplace_back(x, y);
    }
  }
  return cells;
}

TEST(FootprintCompletionTest, TwoWallsOfACornerGiveTheRectangleAndItsRoof) {
  Scene s(southAndWestWalls(), 49, groundOutside());
  const auto footprints = completeFootprints(s.mesh, s.map, FootprintConfig{});
  ASSERT_EQ(footprints.size(), 1u);
  const Footprint& f = footprints[0];
  EXPECT_FLOAT_EQ(f.roof_height, 10.0f);
  EXPECT_EQ(f.wall_vertices, 49);
  EXPECT_EQ(f.raised_vertices, 49);
  // the corners, in any rotation of the counter-clockwise order: (2,2) (8,2) (8,6) (2,6)
  std::map<std::pair<long, long>, int> corners;
  for (const auto& c : f.corners) ++corners[{std::lround(c.x() * 1000), std::lround(c.y() * 1000)}];
  for (const auto& [x, y] : {std::pair{2000L, 2000L}, {8000L, 2000L}, {8000L, 6000L}, {2000L, 6000L}}) {
    EXPECT_EQ((corners[{x, y}]), 1) << x << " " << y;
  }
  const Eigen::Vector2d e1 = f.corners[1] - f.corners[0], e2 = f.corners[2] - f.corners[1];
  EXPECT_GT(e1.x() * e2.y() - e1.y() * e2.x(), 0.0);  // counter-clockwise
  // the roof: every cell inside without a vertex of its own, columns 11-39 by rows 11-29
  const auto roof = roofCells(footprints, s.mesh, 0.2);
  EXPECT_EQ(roof.size(), 29u * 19u);
  for (const auto& r : roof) {
    EXPECT_FLOAT_EQ(r.height, 10.0f);
    EXPECT_TRUE(r.cell.x() >= 11 && r.cell.x() <= 39 && r.cell.y() >= 11 && r.cell.y() <= 29) << r.cell.transpose();
  }
  // sorted by row, then column
  EXPECT_EQ(roof.front().cell, CellIndex(11, 11));
  EXPECT_EQ(roof.back().cell, CellIndex(39, 29));
}

TEST(FootprintCompletionTest, WallsWithoutEstimatesTakeTheRoofHeight) {
  // 40 of the 49 wall vertices have a 10 m estimate; the other 9 take the roof, ground stays
  Scene s(southAndWestWalls(), 40, groundOutside());
  const auto footprints = completeFootprints(s.mesh, s.map, FootprintConfig{});
  ASSERT_EQ(footprints.size(), 1u);
  EXPECT_EQ(footprints[0].raised_vertices, 40);
  EXPECT_EQ(roofWalls(s.mesh, s.map, footprints, FootprintConfig{}), 9);
  const auto& v = s.mesh.vertices();
  for (std::size_t i = 0; i < 49; ++i) EXPECT_FLOAT_EQ(v[i].height(), 10.0f) << i;
  for (std::size_t i = 49; i < v.size(); ++i) EXPECT_FALSE(v[i].raised()) << i;
  EXPECT_TRUE(v[45].spread);
  EXPECT_FALSE(v[5].spread);
}

TEST(FootprintCompletionTest, WallsThickenedByALongDriveStillGiveTheFootprint) {
  // a building of 12 x 8 m (cells 10-69 by 10-49) whose south and west walls are 1.4 m thick (7
  // cells): a long drive's pose noise spreads a wall's returns
  std::vector<CellIndex> walls;
  for (int y = 10; y < 50; ++y) {
    for (int x = 10; x < 70; ++x) {
      if (y < 17 || x < 17) walls.emplace_back(x, y);
    }
  }
  Scene s(walls, walls.size(), groundOutside());
  const auto footprints = completeFootprints(s.mesh, s.map, FootprintConfig{});
  ASSERT_EQ(footprints.size(), 1u);
  EXPECT_FLOAT_EQ(footprints[0].roof_height, 10.0f);
  std::map<std::pair<long, long>, int> corners;
  for (const auto& c : footprints[0].corners) ++corners[{std::lround(c.x() * 10), std::lround(c.y() * 10)}];
  EXPECT_EQ(corners,
            (std::map<std::pair<long, long>, int>{{{20, 20}, 1}, {{140, 20}, 1}, {{140, 100}, 1}, {{20, 100}, 1}}));
  // with the band as narrow as the outline's tolerance, the cells 1.1 and 1.3 m in are off the walls
  FootprintConfig narrow;
  narrow.wall_band = narrow.wall_tolerance;
  EXPECT_TRUE(completeFootprints(s.mesh, s.map, narrow).empty());
}

TEST(FootprintCompletionTest, TheWallBandStaysShallowInASmallRectangle) {
  // a solid 2.4 x 3 m block: a 1.5 m band would put every cell on the outline
  std::vector<CellIndex> block;
  for (int y = 10; y < 25; ++y) {
    for (int x = 10; x < 22; ++x) block.emplace_back(x, y);
  }
  Scene s(block, block.size(), groundOutside());
  EXPECT_TRUE(completeFootprints(s.mesh, s.map, FootprintConfig{}).empty());
}

TEST(FootprintCompletionTest, AStraightWallAloneGivesNoFootprint) {
  Scene s(southWall(), 30, groundOutside());
  EXPECT_TRUE(completeFootprints(s.mesh, s.map, FootprintConfig{}).empty());
}

TEST(FootprintCompletionTest, SomethingSensedInsideRejectsTheRectangle) {
  // a patch of 5 x 4 ground cells in the middle: 20 of about 375 inner cells (more than 2 %)
  std::vector<CellIndex> ground = groundOutside();
  for (int x = 20; x < 25; ++x) {
    for (int y = 18; y < 22; ++y) ground.emplace_back(x, y);
  }
  Scene s(southAndWestWalls(), 49, ground);
  EXPECT_TRUE(completeFootprints(s.mesh, s.map, FootprintConfig{}).empty());
  // one sensed cell inside is within the allowance
  std::vector<CellIndex> one = groundOutside();
  one.emplace_back(20, 20);
  Scene t(southAndWestWalls(), 49, one);
  EXPECT_EQ(completeFootprints(t.mesh, t.map, FootprintConfig{}).size(), 1u);
}

TEST(FootprintCompletionTest, NeedsEnoughRaisedWallsAndCanBeTurnedOff) {
  Scene few(southAndWestWalls(), 4, groundOutside());
  EXPECT_TRUE(completeFootprints(few.mesh, few.map, FootprintConfig{}).empty());
  // a share of the walls: 9 of 49 is under 20 %, 10 is over
  FootprintConfig share;
  share.min_raised_share = 0.2;
  Scene nine(southAndWestWalls(), 9, groundOutside()), ten(southAndWestWalls(), 10, groundOutside());
  EXPECT_TRUE(completeFootprints(nine.mesh, nine.map, share).empty());
  EXPECT_EQ(completeFootprints(ten.mesh, ten.map, share).size(), 1u);
  Scene s(southAndWestWalls(), 49, groundOutside());
  FootprintConfig off;
  off.enabled = false;
  EXPECT_TRUE(completeFootprints(s.mesh, s.map, off).empty());
}

TEST(FootprintCompletionTest, ARotatedCornerGivesARotatedRectangle) {
  // walls 6 m and 4 m long from (10, 10) m along 30 degrees and 120 degrees, rasterised into cells
  const double angle = 30 * M_PI / 180;
  const Eigen::Vector2d o(10, 10), u(std::cos(angle), std::sin(angle)), v(-std::sin(angle), std::cos(angle));
  std::vector<CellIndex> walls;
  auto addCell = [&](const Eigen::Vector2d& p) {
    const CellIndex c(static_cast<int>(std::floor(p.x() / 0.2)), static_cast<int>(std::floor(p.y() / 0.2)));
    if (std::find(walls.begin(), walls.end(), c) == walls.end()) walls.push_back(c);
  };
  for (double t = 0; t <= 6.0; t += 0.05) addCell(o + t * u);
  for (double t = 0; t <= 4.0; t += 0.05) addCell(o + t * v);
  Scene s(walls, walls.size(), {});
  const auto footprints = completeFootprints(s.mesh, s.map, FootprintConfig{});
  ASSERT_EQ(footprints.size(), 1u);
  // the true corners, each matched by one within a cell's diagonal and a half
  const std::array<Eigen::Vector2d, 4> truth = {o, o + 6 * u, o + 6 * u + 4 * v, o + 4 * v};
  for (const auto& t : truth) {
    double nearest = 1e9;
    for (const auto& c : footprints[0].corners) nearest = std::min(nearest, (c - t).norm());
    EXPECT_LT(nearest, 0.45) << t.transpose();
  }
  // and a roof of the 24 m2 less the wall cells (about 3 m2), give or take the half-cell margins
  const double area = roofCells(footprints, s.mesh, 0.2).size() * 0.04;
  EXPECT_GT(area, 19.0);
  EXPECT_LT(area, 25.0);
}

TEST(TerrainMeshTest, AQuadMissingItsLowerLeftCornerStillGetsATriangle) {
  // cells (1,0) (0,1) (1,1): one triangle, counter-clockwise from above
  const std::vector<CellIndex> cells = {CellIndex(1, 0), CellIndex(0, 1), CellIndex(1, 1)};
  const auto tris = gridTriangles(cells, [&](const CellIndex& c) -> std::int64_t {
    for (std::size_t i = 0; i < cells.size(); ++i) {
      if (cells[i] == c) return static_cast<std::int64_t>(i);
    }
    return -1;
  });
  ASSERT_EQ(tris.size(), 1u);
  const Eigen::Vector2i a = cells[tris[0][0]], b = cells[tris[0][1]], c = cells[tris[0][2]];
  EXPECT_GT((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x(), 0);
}

}  // namespace
}  // namespace terrain
