#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"
#include "tests/core/core_test_support.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace terrain {
namespace {

TEST(TerrainMeshTest, TrianglesUseOnlyExistingVertices) {
  // cells (0,0) (1,0) (0,1) (1,1) and (2,0): the full quad at (0,0) gives 2 triangles; at (1,0)
  // the corner (2,1) is missing, so one triangle (1,0) (2,0) (1,1); nothing else
  TerrainMesh mesh;
  std::vector<MeshVertex> vs;
  for (const CellIndex& c : {CellIndex(0, 0), CellIndex(1, 0), CellIndex(0, 1), CellIndex(1, 1), CellIndex(2, 0)}) {
    MeshVertex m;
    m.cell = c;
    vs.push_back(m);
  }
  ASSERT_TRUE(mesh.restore(vs));
  EXPECT_EQ(mesh.find(CellIndex(5, 5)), -1);
  EXPECT_EQ(mesh.find(CellIndex(2, 0)), 4);
  const auto tris = mesh.triangles();
  EXPECT_EQ(tris.size(), 3u);
  for (const auto& t : tris) {
    for (auto i : t) EXPECT_LT(i, vs.size());
  }
  // two vertices of one cell are refused
  vs.push_back(vs.front());
  EXPECT_FALSE(mesh.restore(vs));
  EXPECT_TRUE(mesh.vertices().empty());
}

// Cells on both sides of zero and across the edges of the mesh's index blocks (32 cells): every
// vertex is found at its cell whether it came from voxels or from a saved mesh, no other cell has
// one, and the bounds are the cells' extremes.
TEST(TerrainMeshTest, FindsEveryVertexOnBothSidesOfZeroAndAcrossBlocks) {
  std::vector<CellIndex> cells;
  for (int y = -70; y <= 70; y += 7) {
    for (int x : {-65, -64, -33, -32, -31, -1, 0, 1, 31, 32, 33, 63, 64}) cells.emplace_back(x, y);
  }
  VoxelMap map(VoxelMapConfig{0.2});
  std::vector<Point3> points;
  for (const CellIndex& c : cells) points.emplace_back((c.x() + 0.5) * 0.2, (c.y() + 0.5) * 0.2, 1.0);
  map.insert(points, 0);
  TerrainMesh mesh;
  mesh.update(map, map.takeNewVoxels());
  ASSERT_EQ(mesh.vertices().size(), cells.size());
  TerrainMesh saved;
  ASSERT_TRUE(saved.restore(mesh.vertices()));
  for (const TerrainMesh* m : {&mesh, &saved}) {
    for (std::size_t i = 0; i < m->vertices().size(); ++i) EXPECT_EQ(m->find(m->vertices()[i].cell), std::int64_t(i));
    for (const CellIndex& c : cells) {
      EXPECT_EQ(m->find(c + CellIndex(0, 1)), -1) << c.transpose();  // rows are 7 cells apart
    }
    EXPECT_EQ(m->find(CellIndex(-2, -70)), -1);
    EXPECT_EQ(m->find(CellIndex(1000, -1000)), -1);
    EXPECT_EQ(m->cellBounds().first, CellIndex(-65, -70));
    EXPECT_EQ(m->cellBounds().second, CellIndex(64, 70));
    // a box of cells on both sides of zero visits exactly the vertices in it, each once; an empty
    // box (lo above hi) none
    const std::pair<CellIndex, CellIndex> boxes[] = {{CellIndex(-40, -30), CellIndex(33, 14)},
                                                     {CellIndex(-65, -70), CellIndex(64, 70)},
                                                     {CellIndex(-1000, 0), CellIndex(1000, 0)},
                                                     {CellIndex(5, 5), CellIndex(4, 9)}};
    for (const auto& [lo, hi] : boxes) {
      std::vector<std::uint32_t> visited, expected;
      m->forEachInCells(lo, hi, [&](std::uint32_t id, const CellIndex& c) {
        EXPECT_EQ(m->vertices()[id].cell, c);
        visited.push_back(id);
      });
      for (std::uint32_t i = 0; i < m->vertices().size(); ++i) {
        const CellIndex c = m->vertices()[i].cell;
        if ((c.array() >= lo.array()).all() && (c.array() <= hi.array()).all()) expected.push_back(i);
      }
      std::sort(visited.begin(), visited.end());
      EXPECT_EQ(visited, expected) << lo.transpose() << " .. " << hi.transpose();
    }
  }
  // a second voxel higher in a column moves that column's top, not its vertex
  map.insert({Point3((32 + 0.5) * 0.2, (0 + 0.5) * 0.2, 3.0)}, 1);
  mesh.update(map, map.takeNewVoxels());
  EXPECT_EQ(mesh.vertices().size(), cells.size());
  EXPECT_NEAR(mesh.vertices()[mesh.find(CellIndex(32, 0))].sensed_height, 3.0, 0.11);
}

}  // namespace
}  // namespace terrain
