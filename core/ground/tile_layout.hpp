#pragma once
// The voxels of a map grouped into tiles of k x k columns, for the local histogram, the plane fits
// and the GMRF's neighbour links.

#include "core/ground/fast_math.hpp"
#include "core/ground/parallel.hpp"
#include "core/large_buffers.hpp"
#include "core/voxel_map.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

namespace terrain::ground {

// A set of tiles of k x k columns and their voxels, laid out tile by tile, column by column
// (row-major inside the tile) and upwards inside each column: a position numbers a voxel in this
// order. Finding a voxel's neighbours is then a walk along two short sorted columns, and a
// tile's voxels are contiguous. Built again and again in the same memory.
class TileLayout {
 public:
  struct Tile {
    int tx = 0, ty = 0;
  };
  // Every voxel of the map, in the tiles it covers (in row-major tile order). The tiles' extent
  // comes from the map's index extent, so that the voxels are read only to group them.
  void build(const VoxelMap& map, int k) {
    clear(k);
    const std::vector<Voxel>& voxels = map.voxels();
    if (voxels.empty()) return;
    const VoxelIndex& lo = map.lowestIndex();
    const VoxelIndex& hi = map.highestIndex();
    setGrid(floorDiv(lo.x(), k), floorDiv(lo.y(), k), floorDiv(hi.x(), k), floorDiv(hi.y(), k), voxels.size());
    tile_x_ = OffsetDivider(gx0_ * k, k), tile_y_ = OffsetDivider(gy0_ * k, k);
    if (!grid_.empty()) {
      groupDense(voxels);
    } else {
      groupSparse(voxels);
    }
  }

  // The voxels of the given tiles (tile coordinates and voxel ids), in that order.
  void build(const std::vector<Voxel>& voxels, int k, const std::vector<Tile>& tiles,
             const std::vector<const std::vector<std::uint32_t>*>& ids) {
    clear(k);
    tiles_ = tiles;
    if (tiles.empty()) return;
    int x0 = tiles[0].tx, x1 = x0, y0 = tiles[0].ty, y1 = y0;
    for (const auto& t : tiles) {
      x0 = std::min(x0, t.tx), x1 = std::max(x1, t.tx);
      y0 = std::min(y0, t.ty), y1 = std::max(y1, t.ty);
    }
    setGrid(x0, y0, x1, y1, tiles.size());
    first_.push_back(0);
    for (std::size_t t = 0; t < tiles.size(); ++t) {
      setTile(gridCell(tiles[t].tx, tiles[t].ty), t);
      first_.push_back(first_.back() + static_cast<std::uint32_t>(ids[t]->size()));
    }
    resizePositions(first_.back());
    tbb::parallel_for(std::size_t{0}, tiles.size(), [&](std::size_t t) {
      std::uint32_t q = first_[t];
      for (std::uint32_t i : *ids[t]) place(q++, i, voxels[i], tiles[t]);
    });
    sortColumns();
  }

  int k() const { return k_; }
  std::size_t size() const { return ids_.size(); }
  const std::vector<Tile>& tiles() const { return tiles_; }
  // index in tiles() of the tile at (tx, ty), or -1 if it is not in the layout
  std::int64_t tileAt(int tx, int ty) const {
    if (tx < gx0_ || ty < gy0_ || tx >= gx0_ + nx_ || ty >= gy0_ + ny_) return -1;
    if (!grid_.empty()) return grid_[gridCell(tx, ty)];
    const auto it = sparse_.find(gridCell(tx, ty));
    return it == sparse_.end() ? -1 : it->second;
  }

  // first position of column c (row-major, 0..k*k) of tile t; column k*k is the tile's end
  std::uint32_t column(std::size_t t, std::size_t c) const { return columns_[t * (k_ * k_ + 1) + c]; }
  std::uint32_t id(std::size_t pos) const { return ids_[pos]; }
  std::int32_t z(std::size_t pos) const { return z_[pos]; }
  float height(std::size_t pos) const { return height_[pos]; }
  // the same for every position, by position
  const std::uint32_t* ids() const { return ids_.data(); }
  const std::int32_t* zs() const { return z_.data(); }
  const float* heights() const { return height_.data(); }
  // the heights of the lowest and the highest voxel of tile t [m]
  float lowest(std::size_t t) const { return range_[2 * t]; }
  float highest(std::size_t t) const { return range_[2 * t + 1]; }

  // calls f(lx, ly, b, e) for every non-empty column of tile t, in row-major order: the column at
  // (lx, ly) in the tile holds positions b .. e - 1. With a stride s > 1, only the columns whose
  // grid coordinates are both multiples of s.
  template <class F>
  void forEachColumn(std::size_t t, F&& f, int s = 1) const {
    const std::uint32_t* col = columns_.data() + t * (k_ * k_ + 1);
    const int lx0 = floorMod(-tiles_[t].tx * k_, s), ly0 = floorMod(-tiles_[t].ty * k_, s);
    for (int ly = ly0; ly < k_; ly += s) {
      for (int lx = lx0; lx < k_; lx += s) {
        const std::uint32_t* c = col + ly * k_ + lx;
        if (c[0] != c[1]) f(lx, ly, c[0], c[1]);
      }
    }
  }

  // calls f(ly, lx0, bounds) for every row ly of tile t that holds a column whose grid coordinates
  // are both multiples of s; its first such column is lx0, and column lx0 + j holds positions
  // bounds[j] .. bounds[j + 1] - 1 (all rows, with s = 1)
  template <class F>
  void forEachRow(std::size_t t, F&& f, int s = 1) const {
    const std::uint32_t* col = columns_.data() + t * (k_ * k_ + 1);
    const int lx0 = floorMod(-tiles_[t].tx * k_, s), ly0 = floorMod(-tiles_[t].ty * k_, s);
    for (int ly = ly0; ly < k_; ly += s) f(ly, lx0, col + ly * k_ + lx0);
  }

  // the end of the ground's voxels at the bottom of the column holding positions b .. e - 1 (b < e):
  // ground is one or two voxels thick, so its lowest voxel and the one right above it if there is
  // one
  std::uint32_t groundEnd(std::uint32_t b, std::uint32_t e) const {
    return b + 1 < e && z_[b + 1] == z_[b] + 1 ? b + 2 : b + 1;
  }

  // the top of the ground in the column at grid cell (x, y) as far as its lowest voxels can hold
  // it [m]: the height of the upper of its ground voxels (groundEnd), or higher up the unbroken
  // stack on the lowest while it stays within `thickness` of the lowest (a map of several sweeps
  // with pose error has thicker ground); +inf if the column is empty or its tile is not in the
  // layout
  float groundTop(int x, int y, float thickness) const {
    const std::int64_t t = tileAt(floorDiv(x, k_), floorDiv(y, k_));
    if (t < 0) return std::numeric_limits<float>::infinity();
    const std::size_t c = static_cast<std::size_t>(floorMod(y, k_)) * k_ + static_cast<std::size_t>(floorMod(x, k_));
    const std::uint32_t b = column(static_cast<std::size_t>(t), c), e = column(static_cast<std::size_t>(t), c + 1);
    if (b == e) return std::numeric_limits<float>::infinity();
    std::uint32_t top = groundEnd(b, e) - 1;
    while (top + 1 < e && z_[top + 1] == z_[top] + 1 && height_[top + 1] - height_[b] <= thickness) ++top;
    return height_[top];
  }

  // the height of the lowest voxel of each column of tile t, in row-major order (+inf where the
  // column is empty), into low[0 .. k*k - 1]
  void columnLows(std::size_t t, float* low) const {
    const std::uint32_t* col = columns_.data() + t * (k_ * k_ + 1);
    std::uint32_t q = col[0];
    for (int c = 0; c < k_ * k_; ++c) {
      float l = std::numeric_limits<float>::infinity();
      for (const std::uint32_t e = col[c + 1]; q < e; ++q) l = std::min(l, height_[q]);
      low[c] = l;
    }
  }

  // Links every voxel of tiles 0 .. count - 1 to its neighbours at +x, +y, +z in those tiles, with
  // their pair weights: sets every voxel's next and weight (kNone and 0 where it has no neighbour)
  // and its neighbours' prev. The prev of a voxel no other links to must be kNone already.
  void linkNeighbours(GmrfProblem& p, const GroundSegmentationConfig& cfg, std::size_t count) const {
    const auto inside = [count](std::int64_t u) { return u >= 0 && static_cast<std::size_t>(u) < count ? u : -1; };
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t t) {
      const std::int64_t east = inside(tileAt(tiles_[t].tx + 1, tiles_[t].ty));
      const std::int64_t north = inside(tileAt(tiles_[t].tx, tiles_[t].ty + 1));
      forEachColumn(t, [&](int lx, int ly, std::uint32_t b, std::uint32_t e) {
        for (std::uint32_t q = b; q < e; ++q) {
          if (q + 1 < e && z_[q + 1] == z_[q] + 1) {
            p.link(q, 2, q + 1, pairWeight(cfg, height_[q], height_[q + 1]));
          } else {
            p.next[3 * q + 2] = GmrfProblem::kNone, p.weight[3 * q + 2] = 0;
          }
        }
        const std::size_t c = static_cast<std::size_t>(ly) * k_ + lx;
        const std::size_t o = static_cast<std::size_t>(ly) * k_;
        if (lx + 1 < k_) {
          linkColumns(p, cfg, b, e, column(t, c + 1), column(t, c + 2), 0);
        } else {
          linkColumns(p, cfg, b, e, east >= 0 ? column(east, o) : 0, east >= 0 ? column(east, o + 1) : 0, 0);
        }
        if (ly + 1 < k_) {
          linkColumns(p, cfg, b, e, column(t, c + k_), column(t, c + k_ + 1), 1);
        } else {
          linkColumns(p, cfg, b, e, north >= 0 ? column(north, lx) : 0, north >= 0 ? column(north, lx + 1) : 0, 1);
        }
      });
    });
  }

 private:
  void clear(int k) {
    k_ = k;
    gx0_ = gy0_ = nx_ = ny_ = 0;
    grid_.clear(), sparse_.clear(), tiles_.clear(), ids_.clear(), first_.clear();
  }

  // voxel ids grouped by tile through a grid over the map's extent (counting sort, in id order
  // inside a tile)
  void groupDense(const std::vector<Voxel>& voxels) {
    const std::size_t n = voxels.size(), cells = grid_.size();
    // a counting sort in chunks of voxels (as many as leave a count per chunk and cell no larger
    // than the voxels): each chunk counts, then places, its voxels in id order after those of
    // the chunks before it
    const std::size_t chunks = std::clamp<std::size_t>(n / cells, 1, kChunks);
    std::vector<std::uint32_t>& offset = scratch_;
    offset.assign(chunks * cells, 0);
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      std::uint32_t* count = offset.data() + c * cells;
      for (std::size_t i = n * c / chunks; i < n * (c + 1) / chunks; ++i) {
        const Tile t = tileOf(voxels[i]);
        ++count[gridCell(t.tx, t.ty)];
      }
    });
    std::uint32_t placed = 0;
    for (std::size_t cell = 0; cell < cells; ++cell) {
      const std::uint32_t start = placed;
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::uint32_t count = offset[c * cells + cell];
        offset[c * cells + cell] = placed;
        placed += count;
      }
      if (placed == start) continue;
      grid_[cell] = static_cast<std::int32_t>(tiles_.size());
      tiles_.push_back({static_cast<int>(cell % nx_) + gx0_, static_cast<int>(cell / nx_) + gy0_});
      first_.push_back(start);
    }
    // each voxel placed with what sortColumns needs of it, read here in id order
    resizePositions(n);
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      std::uint32_t* fill = offset.data() + c * cells;
      for (std::size_t i = n * c / chunks; i < n * (c + 1) / chunks; ++i) {
        const Tile t = tileOf(voxels[i]);
        place(fill[gridCell(t.tx, t.ty)]++, static_cast<std::uint32_t>(i), voxels[i], t);
      }
    });
    first_.push_back(static_cast<std::uint32_t>(n));
    sortColumns();
  }

  // the same, in the same tile order, by sorting the voxels' grid cells: for maps whose extent
  // holds far more tiles than voxels (a few returns far from the rest)
  void groupSparse(const std::vector<Voxel>& voxels) {
    const std::size_t n = voxels.size();
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
      const Tile t = tileOf(voxels[i]);
      keyed[i] = {gridCell(t.tx, t.ty), static_cast<std::uint32_t>(i)};
    });
    std::sort(keyed.begin(), keyed.end());
    resizePositions(n);
    for (std::size_t j = 0; j < n; ++j) {
      const std::uint32_t i = keyed[j].second;
      place(j, i, voxels[i], tileOf(voxels[i]));
      if (j > 0 && keyed[j].first == keyed[j - 1].first) continue;
      const std::uint64_t c = keyed[j].first;
      setTile(c, tiles_.size());
      tiles_.push_back({static_cast<int>(c % nx_) + gx0_, static_cast<int>(c / nx_) + gy0_});
      first_.push_back(static_cast<std::uint32_t>(j));
    }
    first_.push_back(static_cast<std::uint32_t>(n));
    sortColumns();
  }

  // the tile grid over [x0, x1] x [y0, y1]: dense unless it would hold far more cells than the
  // count of voxels or tiles going into it
  void setGrid(int x0, int y0, int x1, int y1, std::size_t count) {
    gx0_ = x0, gy0_ = y0, nx_ = x1 - x0 + 1, ny_ = y1 - y0 + 1;
    const std::uint64_t cells = static_cast<std::uint64_t>(nx_) * static_cast<std::uint64_t>(ny_);
    if (cells <= std::max<std::uint64_t>(std::uint64_t{1} << 20, 8 * static_cast<std::uint64_t>(count)))
      grid_.assign(cells, -1);
  }
  std::uint64_t gridCell(int tx, int ty) const {
    return static_cast<std::uint64_t>(ty - gy0_) * static_cast<std::uint64_t>(nx_) +
           static_cast<std::uint64_t>(tx - gx0_);
  }
  void setTile(std::uint64_t cell, std::size_t t) {
    if (!grid_.empty()) {
      grid_[cell] = static_cast<std::int32_t>(t);
    } else {
      sparse_[cell] = static_cast<std::int32_t>(t);
    }
  }

  // the tile of a voxel of the map being built
  Tile tileOf(const Voxel& v) const { return {gx0_ + tile_x_(v.index.x()), gy0_ + tile_y_(v.index.y())}; }

  void resizePositions(std::size_t n) {
    resizeLarge(ids_, n), resizeLarge(z_, n), resizeLarge(height_, n), resizeLarge(placed_, n);
  }
  // puts voxel i, of tile t, at position q of its tile's voxels as placed
  void place(std::size_t q, std::uint32_t i, const Voxel& v, const Tile& t) {
    const auto local = static_cast<std::uint32_t>((v.index.y() - t.ty * k_) * k_ + (v.index.x() - t.tx * k_));
    placed_[q] = {i, local, v.index.z(), v.height};
  }

  // lays each tile's voxels as placed (first_[t] .. first_[t + 1]) out by column and z: a counting
  // sort by column, each voxel inserted by z among those of its column already laid out (a column
  // holds few voxels)
  void sortColumns() {
    const std::vector<std::uint32_t>& first = first_;
    const std::size_t kk = static_cast<std::size_t>(k_) * k_;
    columns_.resize(tiles_.size() * (kk + 1));
    range_.resize(2 * tiles_.size());
    tbb::parallel_for(std::size_t{0}, tiles_.size(), [&](std::size_t t) {
      thread_local std::vector<std::uint32_t> fill;
      const std::uint32_t b = first[t], e = first[t + 1];
      const Placed* const placed = placed_.data();
      std::uint32_t* const ids = ids_.data();
      std::int32_t* const zs = z_.data();
      float* const heights = height_.data();
      std::uint32_t* const col = columns_.data() + t * (kk + 1);
      std::fill(col, col + kk + 1, 0);
      for (std::uint32_t q = b; q < e; ++q) ++col[placed[q].local + 1];
      col[0] = b;
      for (std::size_t c = 0; c < kk; ++c) col[c + 1] += col[c];
      fill.assign(col, col + kk);
      std::uint32_t* const next = fill.data();
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      for (std::uint32_t q = b; q < e; ++q) {
        const Placed v = placed[q];
        const std::uint32_t start = col[v.local];
        std::uint32_t r = next[v.local]++;
        for (; r > start && zs[r - 1] > v.z; --r) ids[r] = ids[r - 1], zs[r] = zs[r - 1], heights[r] = heights[r - 1];
        ids[r] = v.id, zs[r] = v.z, heights[r] = v.height;
        lo = std::min(lo, v.height), hi = std::max(hi, v.height);
      }
      range_[2 * t] = lo, range_[2 * t + 1] = hi;
    });
  }

  // links the voxels of column [b, e) to those of the column [nb, ne) next to it along axis
  // (both sorted by z; empty if there is none): a merge. Voxels with no neighbour there get none.
  void linkColumns(GmrfProblem& p, const GroundSegmentationConfig& cfg, std::uint32_t b, std::uint32_t e,
                   std::uint32_t nb, std::uint32_t ne, int axis) const {
    for (; b < e; ++b) {
      while (nb < ne && z_[nb] < z_[b]) ++nb;
      if (nb < ne && z_[nb] == z_[b]) {
        p.link(b, axis, nb, pairWeight(cfg, height_[b], height_[nb]));
        ++nb;
      } else {
        p.next[3 * b + axis] = GmrfProblem::kNone, p.weight[3 * b + axis] = 0;
      }
    }
  }

  int k_ = 1;
  int gx0_ = 0, gy0_ = 0, nx_ = 0, ny_ = 0;                 // the grid of tiles over the layout's extent
  OffsetDivider tile_x_, tile_y_;                           // a voxel index's tile offset in the grid (whole map)
  std::vector<std::int32_t> grid_;                          // per grid cell: index in tiles_, or -1 (empty if sparse)
  std::unordered_map<std::uint64_t, std::int32_t> sparse_;  // grid cell -> index in tiles_, if sparse
  std::vector<Tile> tiles_;
  std::vector<std::uint32_t> columns_;  // k*k + 1 per tile: first position of each column
  std::vector<std::uint32_t> ids_;      // voxel id per position
  std::vector<std::int32_t> z_;         // voxel z index per position
  std::vector<float> height_;           // voxel height per position [m]
  // a voxel as placed in its tile, before its tile's voxels are laid out by column (while grouping)
  struct Placed {
    std::uint32_t id, local;  // voxel id, and its column in its tile (row-major)
    std::int32_t z;           // voxel z index
    float height;             // [m]
  };
  std::vector<Placed> placed_;          // per position as placed
  std::vector<float> range_;            // per tile: its lowest and highest voxel height [m]
  std::vector<std::uint32_t> first_;    // per tile and one past the last: its first position
  std::vector<std::uint32_t> scratch_;  // per chunk of voxels and grid cell: counts, then offsets (while grouping)
};

}  // namespace terrain::ground
