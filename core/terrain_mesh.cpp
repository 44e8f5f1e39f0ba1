#include "core/terrain_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace terrain {

std::pair<CellIndex, CellIndex> TerrainMesh::cellBounds() const { return {lo_, hi_}; }

std::uint32_t* TerrainMesh::slot(const CellIndex& cell, bool create) {
  if (const std::uint32_t* s = std::as_const(*this).slot(cell)) return const_cast<std::uint32_t*>(s);
  if (!create) return nullptr;
  const int bx = blockOf(cell.x()), by = blockOf(cell.y());
  block_index_.emplace(key(bx, by), static_cast<std::uint32_t>(blocks_.size()));
  blocks_.emplace_back().fill(kNoVertex);
  return &blocks_.back()[offset(cell, bx, by)];
}

const std::uint32_t* TerrainMesh::slot(const CellIndex& cell) const {
  const int bx = blockOf(cell.x()), by = blockOf(cell.y());
  const auto it = block_index_.find(key(bx, by));
  if (it == block_index_.end()) return nullptr;
  return &blocks_[it->second][offset(cell, bx, by)];
}

bool TerrainMesh::restore(std::vector<MeshVertex> vertices) {
  vertices_ = std::move(vertices);
  block_index_.clear();
  blocks_.clear();
  for (std::uint32_t id = 0; id < vertices_.size(); ++id) {
    std::uint32_t* s = slot(vertices_[id].cell, true);
    if (*s != kNoVertex) {
      vertices_.clear();
      block_index_.clear();
      blocks_.clear();
      return false;
    }
    *s = id;
    const CellIndex c = vertices_[id].cell;
    lo_ = id == 0 ? c : lo_.cwiseMin(c);
    hi_ = id == 0 ? c : hi_.cwiseMax(c);
  }
  return true;
}

std::int64_t TerrainMesh::find(const CellIndex& cell) const {
  const std::uint32_t* s = slot(cell);
  return s == nullptr || *s == kNoVertex ? std::int64_t{-1} : static_cast<std::int64_t>(*s);
}

void TerrainMesh::update(const VoxelMap& map, const std::vector<std::uint32_t>& voxel_ids) {
  const auto& voxels = map.voxels();
  for (std::uint32_t id : voxel_ids) {
    const Voxel& v = voxels[id];
    const CellIndex cell(v.index.x(), v.index.y());
    std::uint32_t* s = slot(cell, true);
    if (*s == kNoVertex) {
      *s = static_cast<std::uint32_t>(vertices_.size());
      lo_ = vertices_.empty() ? cell : lo_.cwiseMin(cell);
      hi_ = vertices_.empty() ? cell : hi_.cwiseMax(cell);
      MeshVertex m;
      m.cell = cell;
      m.top_voxel = id;
      m.sensed_height = v.height;
      vertices_.push_back(m);
      continue;
    }
    MeshVertex& m = vertices_[*s];
    const Voxel& top = voxels[m.top_voxel];
    if (id == m.top_voxel || v.index.z() > top.index.z()) {
      m.top_voxel = id;
      m.sensed_height = v.height;
    }
  }
}

const char* outcomeName(EstimateOutcome outcome) {
  switch (outcome) {
    case EstimateOutcome::Estimated:
      return "estimated";
    case EstimateOutcome::NoTopBoundary:
      return "no_top_boundary";
    case EstimateOutcome::CutOff:
      return "cut_off";
    case EstimateOutcome::NoSky:
      return "no_sky";
    case EstimateOutcome::EndsBelow:
      return "ends_below";
    case EstimateOutcome::Implausible:
      return "implausible";
    case EstimateOutcome::NotClear:
      return "not_clear";
  }
  return "unknown";
}

void TerrainMesh::addEstimate(std::uint32_t vertex, const HeightEstimate& estimate, std::size_t max_estimates,
                              double quantile) {
  MeshVertex& m = vertices_[vertex];
  if (m.estimates.size() >= max_estimates) m.estimates.erase(m.estimates.begin());
  m.estimates.push_back(estimate);
  std::vector<float> sorted;
  sorted.reserve(m.estimates.size());
  for (const auto& e : m.estimates) sorted.push_back(e.height);
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
