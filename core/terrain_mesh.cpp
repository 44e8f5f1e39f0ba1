#include "core/terrain_mesh.hpp"

#include <algorithm>
#include <cmath>

namespace terrain {

std::pair<CellIndex, CellIndex> TerrainMesh::cellBounds() const {
  CellIndex lo = vertices_.front().cell, hi = lo;
  for (const auto& v : vertices_) {
    lo = lo.cwiseMin(v.cell);
    hi = hi.cwiseMax(v.cell);
  }
  return {lo, hi};
}

bool TerrainMesh::restore(std::vector<MeshVertex> vertices) {
  vertices_ = std::move(vertices);
  index_.clear();
  for (std::uint32_t id = 0; id < vertices_.size(); ++id) {
    if (!index_.try_emplace(key(vertices_[id].cell), id).second) {
      vertices_.clear();
      index_.clear();
      return false;
    }
  }
  return true;
}

std::int64_t TerrainMesh::find(const CellIndex& cell) const {
  auto it = index_.find(key(cell));
  return it == index_.end() ? std::int64_t{-1} : static_cast<std::int64_t>(it->second);
}

void TerrainMesh::update(const VoxelMap& map, const std::vector<std::uint32_t>& voxel_ids) {
  const auto& voxels = map.voxels();
  for (std::uint32_t id : voxel_ids) {
    const Voxel& v = voxels[id];
    const CellIndex cell(v.index.x(), v.index.y());
    auto [it, inserted] = index_.try_emplace(key(cell), static_cast<std::uint32_t>(vertices_.size()));
    if (inserted) {
      MeshVertex m;
      m.cell = cell;
      m.top_voxel = id;
      m.sensed_height = v.height;
      vertices_.push_back(m);
      continue;
    }
    MeshVertex& m = vertices_[it->second];
    const Voxel& top = voxels[m.top_voxel];
    if (id == m.top_voxel || v.index.z() > top.index.z()) {
      m.top_voxel = id;
      m.sensed_height = v.height;
    }
  }
}

void TerrainMesh::addEstimate(std::uint32_t vertex, float height, std::size_t max_estimates, double quantile) {
  MeshVertex& m = vertices_[vertex];
  if (m.estimates.size() >= max_estimates) m.estimates.erase(m.estimates.begin());
  m.estimates.push_back(height);
  std::vector<float> sorted = m.estimates;
  const auto k = static_cast<std::size_t>(std::lround(quantile * (sorted.size() - 1)));
  std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
  m.recovered_height = sorted[k];
}

std::vector<std::array<std::uint32_t, 3>> TerrainMesh::triangles() const {
  std::vector<CellIndex> cells;
  cells.reserve(vertices_.size());
  for (const auto& m : vertices_) cells.push_back(m.cell);
  return gridTriangles(cells, [this](const CellIndex& c) { return find(c); });
}

}  // namespace terrain
