#pragma once
// Stage 3, terrain mesh: the top voxel of each horizontal cell becomes a vertex of a regular
// triangle mesh. Vertices take their colour from the camera (through the top voxel's colour);
// vertices never seen by the camera are flagged. The mesh also holds the heights recovered by 3D
// boundary estimation (stage 6), fused over frames.

#include "core/voxel_map.hpp"

#include <array>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

namespace terrain {

// One frame's recovered-height estimate for a vertex, with where the camera was when it was made:
// its horizontal distance to the vertex's cell centre and its height.
struct HeightEstimate {
  float height = 0;         // [m]
  float distance = 0;       // [m]
  float camera_height = 0;  // [m]
};

// What boundary estimation made of a vertex in one frame whose image it fell in: an estimate, or the
// reason it gave none (see estimateBoundaries).
enum class EstimateOutcome : std::uint8_t {
  Estimated,      // a height estimate
  NoTopBoundary,  // no boundary pixel above it on its vertical
  CutOff,         // its top (boundary or foliage run) at the image's top margin
  NoSky,          // no sky just above its top boundary (sky test)
  EndsBelow,      // its pixels end against sky below its top boundary
  Implausible,    // the height is not above its sensed top, or too far above (max_height)
  NotClear,       // another object may own its top pixel (clear-line test)
};
constexpr std::size_t kEstimateOutcomes = 7;
// the outcome's name in reports: estimated, no_top_boundary, cut_off, no_sky, ends_below,
// implausible, not_clear
const char* outcomeName(EstimateOutcome outcome);

// one more in a count that stops at its largest value
inline void countUp(std::uint16_t& n) { n += n < 0xffff; }

struct MeshVertex {
  CellIndex cell;
  std::uint32_t top_voxel = 0;            // voxel id of the column's top
  float sensed_height = 0;                // [m] height of the top voxel
  std::vector<HeightEstimate> estimates;  // from the frames that saw the top, oldest first
  float recovered_height = 0;             // [m] fused estimate, valid when estimated() or spread
  // [m] the lowest sky ray over the cell (SkyCeiling): a raised vertex stands no higher; +inf: none
  float ceiling = std::numeric_limits<float>::infinity();
  // the estimates change with the camera's distance: the top edge seen above the vertex lies
  // behind it (boundary estimation's parallax test), and they do not stand
  bool parallax = false;
  // without estimates of its own: recovered_height comes from the nearest estimated vertex of the
  // same object (spreadEstimates), its completed footprint's roof (roofWalls) or a tree crown over
  // it (CrownSampler::apply)
  bool spread = false;
  // frames per outcome of boundary estimation (saturating at 65535): why a vertex was or was not raised
  std::array<std::uint16_t, kEstimateOutcomes> outcomes{};

  void count(EstimateOutcome o) { countUp(outcomes[static_cast<std::size_t>(o)]); }
  // has estimates of its own that stand
  bool estimated() const { return !estimates.empty() && !parallax; }
  // raised by boundary estimation, from its own estimates or its object's
  bool raised() const { return estimated() || spread; }
  float height() const {
    return raised() ? std::max(sensed_height, std::min(recovered_height, ceiling)) : sensed_height;
  }
};

// Triangles over vertices on a regular grid of cells: two per complete quad, one where a corner is
// missing; counter-clockwise seen from above. cells[i] is vertex i's cell; find(cell) gives the
// vertex of a cell, or -1.
template <typename Find>
std::vector<std::array<std::uint32_t, 3>> gridTriangles(const std::vector<CellIndex>& cells, Find&& find) {
  std::vector<std::array<std::uint32_t, 3>> tris;
  const auto u = [](std::int64_t v) { return static_cast<std::uint32_t>(v); };
  for (std::uint32_t i = 0; i < cells.size(); ++i) {
    // the quad whose lower-left corner is vertex i
    const CellIndex c = cells[i];
    const std::int64_t right = find(CellIndex(c.x() + 1, c.y())), up = find(CellIndex(c.x(), c.y() + 1)),
                       diag = find(CellIndex(c.x() + 1, c.y() + 1));
    if (right >= 0 && diag >= 0 && up >= 0) {
      tris.push_back({i, u(right), u(diag)});
      tris.push_back({i, u(diag), u(up)});
    } else if (right >= 0 && diag >= 0) {
      tris.push_back({i, u(right), u(diag)});
    } else if (right >= 0 && up >= 0) {
      tris.push_back({i, u(right), u(up)});
    } else if (diag >= 0 && up >= 0) {
      tris.push_back({i, u(diag), u(up)});
    }
    // the quad to its left, when that quad's lower-left corner is missing
    if (find(CellIndex(c.x() - 1, c.y())) < 0) {
      const std::int64_t upleft = find(CellIndex(c.x() - 1, c.y() + 1));
      if (up >= 0 && upleft >= 0) tris.push_back({i, u(up), u(upleft)});
    }
  }
  return tris;
}

class TerrainMesh {
 public:
  // Updates the columns touched by the given voxels (new or changed).
  void update(const VoxelMap& map, const std::vector<std::uint32_t>& voxel_ids);

  const std::vector<MeshVertex>& vertices() const { return vertices_; }
  std::vector<MeshVertex>& vertices() { return vertices_; }
  // Smallest and largest cell index over all vertices (component-wise); the mesh must not be empty.
  std::pair<CellIndex, CellIndex> cellBounds() const;
  // Vertex id of a cell, or -1.
  std::int64_t find(const CellIndex& cell) const;
  // Calls f(vertex id, cell) for every vertex whose cell lies in [lo, hi] (inclusive), in id order.
  // A walk over the vertices' cells in id order, which reads memory in sequence: on a 1000-frame run
  // it took the per-frame estimation 1.8 ms early and late, a walk of the area's cells through the
  // block index 6.7 ms early (most of the mesh in view; vertices read out of order) and 2.7 ms late.
  template <typename F>
  void forEachInCells(const CellIndex& lo, const CellIndex& hi, F&& f) const;
  // Triangles over neighbouring cells (two per complete quad, one where a corner is missing),
  // counter-clockwise seen from above.
  std::vector<std::array<std::uint32_t, 3>> triangles() const;

  // Replaces the mesh with these vertices (a saved mesh read back). Returns false, leaving the
  // mesh empty, if two vertices share a cell.
  bool restore(std::vector<MeshVertex> vertices);

  // Adds a recovered-height estimate to a vertex; the fused value is the `quantile` (0.5: median)
  // of the heights of the last max_estimates estimates.
  void addEstimate(std::uint32_t vertex, const HeightEstimate& estimate, std::size_t max_estimates,
                   double quantile = 0.5);

 private:
  // The vertices are indexed by blocks of kBlock x kBlock cells, each a dense array of vertex ids:
  // a lookup hashes the block (a few thousand keys, not one per vertex).
  static constexpr int kBlock = 32;
  static constexpr std::uint32_t kNoVertex = ~std::uint32_t{0};
  using Block = std::array<std::uint32_t, kBlock * kBlock>;
  static int blockOf(int c) { return c >= 0 ? c / kBlock : -((-c + kBlock - 1) / kBlock); }
  static std::uint64_t key(int bx, int by) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(bx)) << 32) | static_cast<std::uint32_t>(by);
  }
  // a cell's place in its block (bx, by)
  static int offset(const CellIndex& c, int bx, int by) {
    return (c.y() - by * kBlock) * kBlock + (c.x() - bx * kBlock);
  }
  // the slot of a cell's vertex id, creating its block if asked; nullptr where there is no block
  std::uint32_t* slot(const CellIndex& cell, bool create);
  const std::uint32_t* slot(const CellIndex& cell) const;

  std::vector<MeshVertex> vertices_;
  std::unordered_map<std::uint64_t, std::uint32_t> block_index_;  // block key -> index into blocks_
  std::vector<Block> blocks_;
  CellIndex lo_ = CellIndex::Zero(), hi_ = CellIndex::Zero();  // cellBounds(), kept up to date
};

template <typename F>
void TerrainMesh::forEachInCells(const CellIndex& lo, const CellIndex& hi, F&& f) const {
  for (std::uint32_t id = 0; id < vertices_.size(); ++id) {
    const CellIndex c = vertices_[id].cell;
    if (c.x() >= lo.x() && c.y() >= lo.y() && c.x() <= hi.x() && c.y() <= hi.y()) f(id, c);
  }
}

}  // namespace terrain
