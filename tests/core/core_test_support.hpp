#pragma once
// Helpers for the core's unit tests, which link only terrain::core: tiny maps and meshes built by
// hand. (tests/test_support.hpp adds scratch directories and inline worlds for the rest.)

#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"

#include <vector>

namespace terrain::test {

// Appends one voxel of the given height and label at (cell, z), and the mesh vertex on top of it:
// the lists VoxelMap::restore and TerrainMesh::restore take.
inline void addColumn(std::vector<Voxel>& voxels, std::vector<MeshVertex>& vertices, const CellIndex& cell, int z,
                      float height, VoxelLabel label) {
  Voxel v;
  v.index = VoxelIndex(cell.x(), cell.y(), z);
  v.height = height;
  v.label = label;
  MeshVertex m;
  m.cell = cell;
  m.top_voxel = static_cast<std::uint32_t>(voxels.size());
  m.sensed_height = height;
  voxels.push_back(v);
  vertices.push_back(m);
}

}  // namespace terrain::test
