#include "core/ground_segmentation.hpp"

#include "core/ground/fast_math.hpp"
#include "core/ground/gmrf.hpp"
#include "core/ground/parallel.hpp"
#include "core/ground/peak_histogram.hpp"
#include "core/ground/plane_fit.hpp"
#include "core/ground/tile_layout.hpp"
#include "core/large_buffers.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace terrain {

bool parseHistogram(const std::string& s, GroundSegmentationConfig::Histogram& out) {
  if (s == "global") return out = GroundSegmentationConfig::Histogram::Global, true;
  if (s == "local") return out = GroundSegmentationConfig::Histogram::Local, true;
  return false;
}

bool parseSolver(const std::string& s, GroundSegmentationConfig::Solver& out) {
  if (s == "icm") return out = GroundSegmentationConfig::Solver::Icm, true;
  if (s == "mincut") return out = GroundSegmentationConfig::Solver::MinCut, true;
  return false;
}

// in this file, beside the links it weighs, so that it is inlined into them
float pairWeight(const GroundSegmentationConfig& cfg, float a, float b) {
  return static_cast<float>(cfg.beta + cfg.gamma * ground::expNegative(std::abs(a - b)));
}

double histogramPeak(const std::vector<double>& heights, double bin_size) {
  if (heights.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto [lo, hi] = std::minmax_element(heights.begin(), heights.end());
  ground::PeakHistogram histogram;
  histogram.reset(*lo, *hi, bin_size);
  for (double h : heights) histogram.add(h);
  return histogram.peak();
}

namespace {

using namespace ground;

// a tile's histogram takes every histogram_stride-th column unless that leaves fewer voxels than this
constexpr std::int64_t kMinHistogram = 256;

// The single-site term for ground of a column's lowest returns above R(ground) but within
// rise_above of h1, in units of alpha: a quarter of alpha, leaning to non-ground (a voxel outside
// R(ground) and G1 has 2 alpha), so that a patch standing apart (a ledge, a car's roof) stays
// non-ground and one that continues the ground around it through its neighbours becomes ground.
constexpr double kRiseTerm = 0.25;

// Eqs. 19-20 for a voxel d [m] above the ground height h1 at its column: its rough class (true: G1)
// and its single-site term V1(f) + V1(h|f) for f = ground. That for non-ground is the negative.
struct Unary {
  bool g1;
  float ground;
};
Unary unary(double d, double delta, double range_margin, double alpha) {
  const bool g1 = std::abs(d) <= delta;
  const bool in_range = std::abs(d) <= range_margin;
  return {g1, static_cast<float>((g1 ? -alpha : alpha) + (in_range ? -alpha : alpha))};
}

// The peak of the histogram of heights above a plane over a set of tiles of a layout: the offset
// that lifts the plane to the tiles' ground; with window > 0 the peak of the heights within
// +-window [m] of the plane. One pass over the voxels: the residuals' range is bounded beforehand
// from each tile's lowest and highest voxel and the plane at its corner columns.
double residualPeak(const TileLayout& layout, const std::vector<std::size_t>& tiles, std::size_t centre,
                    const Plane& plane, double cell, double bin_size, int stride, double window,
                    PeakHistogram& histogram) {
  const int k = layout.k();
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t t : tiles) {
    const auto& tile = layout.tiles()[t];
    const double x0 = (tile.tx * k + 0.5) * cell, y0 = (tile.ty * k + 0.5) * cell, span = (k - 1) * cell;
    const double corners[4] = {plane.at(x0, y0), plane.at(x0 + span, y0), plane.at(x0, y0 + span),
                               plane.at(x0 + span, y0 + span)};
    lo = std::min(lo, layout.lowest(t) - *std::max_element(corners, corners + 4));
    hi = std::max(hi, layout.highest(t) - *std::min_element(corners, corners + 4));
  }
  // heights outside the window fall in the histogram's end bins, which the peak then leaves out
  if (window > 0) lo = std::max(lo, -window), hi = std::min(hi, window);
  // every stride-th column each way, or every column if that leaves too few voxels
  for (const int s : {stride, 1}) {
    histogram.reset(lo, hi, bin_size);
    for (std::size_t t : tiles) {
      const auto& tile = layout.tiles()[t];
      const int step = t == centre ? 1 : s;
      layout.forEachRow(
          t,
          [&](int ly, int lx0, const std::uint32_t* bounds) {
            const double at = plane.at((tile.tx * k + lx0 + 0.5) * cell, (tile.ty * k + ly + 0.5) * cell);
            histogram.addColumns(layout.heights(), bounds, k - lx0, step, at, plane.a * cell * step);
          },
          step);
    }
    if (histogram.total() >= kMinHistogram) break;
  }
  return histogram.peak(window > 0);
}

// What a segmentation works in, kept from one call to the next so that its memory is reused.
struct Workspace {
  TileLayout layout;
  std::vector<Candidates> candidates;       // per tile of the layout
  std::vector<Plane> planes;                // per tile segmented
  GmrfProblem problem;                      // over the positions of the tiles segmented
  std::vector<std::uint8_t> rough, labels;  // per position: rough and refined labels
  MinCutSolver mincut;                      // with its flow graph
};

// The ground planes of tiles 0 .. count - 1 of the workspace's layout (h1 as a function of
// position): each fitted through the plane-fit candidates of the tiles of its window that are in
// the layout, and lifted to the peak of the window's heights above it. The whole-map and the
// incremental segmentation both take their planes from here.
void tilePlanes(Workspace& ws, std::size_t count, const GroundSegmentationConfig& cfg, double cell) {
  const TileLayout& layout = ws.layout;
  const int k = layout.k();
  const std::size_t tiles = layout.tiles().size();
  auto& candidates = ws.candidates;
  candidates.resize(tiles);
  tbb::parallel_for(std::size_t{0}, tiles, [&](std::size_t t) {
    // the lowest voxel of each column, in one pass along the tile's columns
    thread_local std::vector<float> lows;
    lows.resize(static_cast<std::size_t>(k) * k);
    layout.columnLows(t, lows.data());
    candidatesFromLows([&](std::size_t c) { return lows[c]; }, k, layout.tiles()[t].tx * k, layout.tiles()[t].ty * k,
                       cell, candidates[t]);
  });
  ws.planes.resize(count);
  tbb::parallel_for(std::size_t{0}, count, [&](std::size_t t) {
    std::vector<std::size_t> window;
    std::vector<const Candidates*> points;
    for (int dy = -cfg.tile_radius; dy <= cfg.tile_radius; ++dy) {
      for (int dx = -cfg.tile_radius; dx <= cfg.tile_radius; ++dx) {
        const std::int64_t u = layout.tileAt(layout.tiles()[t].tx + dx, layout.tiles()[t].ty + dy);
        if (u >= 0) window.push_back(static_cast<std::size_t>(u)), points.push_back(&candidates[u]);
      }
    }
    // a plane on the ground's lower envelope is lifted within R(ground) only: the peak of a window
    // may be a flat structure's, a ledge or a car park deck
    Plane plane = fitPlane(points, cfg.lower_envelope);
    PeakHistogram histogram;
    plane.c += residualPeak(layout, window, t, plane, cell, cfg.bin_size, std::max(1, cfg.histogram_stride),
                            cfg.lower_envelope ? cfg.range_margin : 0.0, histogram);
    ws.planes[t] = plane;
  });
}

// The problem and rough labels over the voxels of tiles 0 .. count - 1 of the workspace's layout
// (its first positions): single-site terms from each tile's ground plane, no backward links (the
// forward ones and the weights are left for linkNeighbours to set). Writes the voxels' ground
// heights and rough classes into out (by voxel id). edge(q, t, lx, ly, h) is called for every
// voxel q of a column on the edge of its tile t, to add the terms of neighbours held fixed.
template <class Edge>
void setUnaries(Workspace& ws, std::size_t count, double cell, const GroundSegmentationConfig& cfg,
                SegmentationResult& out, Edge&& edge) {
  const TileLayout& layout = ws.layout;
  const int k = layout.k();
  const std::size_t m = count < layout.tiles().size() ? layout.column(count, 0) : layout.size();
  // every node's fields are written below or by linkNeighbours: only the vectors' sizes are set here
  GmrfProblem& p = ws.problem;
  resizeLarge(p.unary_ground, m), resizeLarge(p.unary_nonground, m), resizeLarge(p.parity, m);
  resizeLarge(p.next, 3 * m), resizeLarge(p.prev, 3 * m), resizeLarge(p.weight, 3 * m);
  resizeLarge(ws.rough, m);
  tbb::parallel_for(std::size_t{0}, count, [&](std::size_t t) {
    // arrays through pointers and settings by value held here: the compiler then need not read
    // them again after every store of a rough class (a byte, which may alias anything)
    float* const unary_ground = p.unary_ground.data();
    float* const unary_nonground = p.unary_nonground.data();
    std::uint8_t* const parity = p.parity.data();
    std::uint32_t* const prev = p.prev.data();
    std::uint8_t* const rough = ws.rough.data();
    float* const ground_height = out.ground_height.data();
    std::uint8_t* const rough_by_id = out.rough.data();
    const std::uint32_t* const ids = layout.ids();
    const std::int32_t* const zs = layout.zs();
    const float* const heights = layout.heights();
    const double delta = cfg.delta, range_margin = cfg.range_margin, alpha = cfg.alpha;
    const float stack_height = static_cast<float>(cfg.stack_height);
    // a stack's next voxel lies at most this many grid steps above the one below it
    const std::int32_t stack_step = 1 + static_cast<std::int32_t>(std::floor(cfg.stack_gap / cell + 1e-6));
    const double depth_below = cfg.depth_below, rise_above = cfg.rise_above;
    const Plane plane = ws.planes[t];
    // what the ground rises across one column on the tile's plane, added to step_height
    const float step = static_cast<float>(cfg.step_height + cell * std::hypot(plane.a, plane.b));
    const auto& tile = layout.tiles()[t];
    layout.forEachColumn(t, [&](int lx, int ly, std::uint32_t b, std::uint32_t e) {
      const int x = tile.tx * k + lx, y = tile.ty * k + ly;
      const double ground = plane.at((x + 0.5) * cell, (y + 0.5) * cell);
      const bool on_edge = lx == 0 || ly == 0 || lx == k - 1 || ly == k - 1;
      // the ground's level here: the (lower) median of the ground tops of this column and the
      // eight around it
      float step_limit = std::numeric_limits<float>::infinity();
      if (cfg.step_height > 0) {
        float tops[9];
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const float top = layout.groundTop(x + dx, y + dy, stack_height);
            if (top < std::numeric_limits<float>::infinity()) tops[n++] = top;
          }
        }
        std::nth_element(tops, tops + (n - 1) / 2, tops + n);
        step_limit = tops[(n - 1) / 2] + step;
      }
      // the column's lowest voxel and the one right above it, if there is one
      const std::uint32_t ground_end = layout.groundEnd(b, e);
      for (auto q = b; q < e; ++q) {
        const float h = heights[q];
        double d = h - ground;
        const bool lowest = q < ground_end;
        // below the plane: nothing is seen under the ground
        if (lowest && d < -delta && d >= -depth_below) d = 0;
        Unary u = unary(d, delta, range_margin, alpha);
        // the lowest returns of a column above R(ground), within rise_above of h1: a weak term, so
        // that the neighbours decide whether they continue the ground around them
        if (lowest && d > range_margin && d <= rise_above) u = {false, static_cast<float>(kRiseTerm * alpha)};
        // the foot of something upright: a stack of the column's voxels (sorted upwards) rises
        // from it, starting right above it and with gaps of at most stack_gap further up
        if (stack_height > 0) {
          for (auto r = q + 1; r < e && zs[r] <= zs[r - 1] + (r == q + 1 ? 1 : stack_step); ++r) {
            if (heights[r] - h > stack_height) {
              u = {false, static_cast<float>(2 * alpha)};
              break;
            }
          }
        }
        // standing on the ground rather than being it: a step above the ground's level here
        if (h > step_limit) u = {false, static_cast<float>(2 * alpha)};
        unary_ground[q] = u.ground, unary_nonground[q] = -u.ground;
        parity[q] = static_cast<std::uint8_t>((x + y + zs[q]) & 1);
        prev[3 * q] = prev[3 * q + 1] = prev[3 * q + 2] = GmrfProblem::kNone;
        rough[q] = u.g1;
        ground_height[ids[q]] = static_cast<float>(ground);
        rough_by_id[ids[q]] = u.g1;
        if (on_edge) edge(q, t, lx, ly, h);
      }
    });
  });
}

// The refined labels G1' of the workspace's problem, from its rough labels by the configured
// solver; sets the result's energies and ICM sweeps.
void refine(Workspace& ws, const GroundSegmentationConfig& cfg, SegmentationResult& out) {
  ws.labels = ws.rough;
  if (cfg.solver == GroundSegmentationConfig::Solver::MinCut) {
    out.energy_rough = gmrfEnergy(ws.problem, ws.rough);
    ws.mincut.solve(ws.problem, ws.labels);
    out.energy_refined = gmrfEnergy(ws.problem, ws.labels);
    out.iterations = 0;
  } else {
    // the problem is a grid's by construction (linkNeighbours): solved without solveIcm's check
    tbb::task_arena arena = arenaFor(cfg.threads);
#ifndef NDEBUG
    checkGrid(ws.problem, ws.labels.size(), arena);
#endif
    const IcmResult r = icm(ws.problem, ws.labels, cfg.icm_iterations, arena);
    out.energy_rough = r.energy_initial, out.energy_refined = r.energy_final;
    out.iterations = r.sweeps;
  }
}

// Segments every voxel of the map into out, working in ws.
void segmentWhole(const VoxelMap& map, const GroundSegmentationConfig& cfg, Workspace& ws, SegmentationResult& out) {
  const auto& voxels = map.voxels();
  const std::size_t n = voxels.size();
  // every voxel's entries are written below
  resizeLarge(out.rough, n);
  resizeLarge(out.refined, n);
  resizeLarge(out.ground_height, n);
  out.energy_rough = out.energy_refined = 0;
  out.iterations = out.tiles = 0;
  if (n == 0) return;
  const double cell = map.voxelSize();
  const int k = std::max(1, static_cast<int>(std::lround(cfg.tile_size / cell)));
  const bool global = cfg.histogram == GroundSegmentationConfig::Histogram::Global;
  tbb::task_arena arena = arenaFor(cfg.threads);
  arena.execute([&] {
    ws.layout.build(map, k);
    const std::size_t tiles = ws.layout.tiles().size();
    // h1: one plane per tile, fitted through the plane-fit candidates of the tiles in its window
    // and lifted to the peak of the window's heights above it; or one level for the whole map
    if (global) {
      std::vector<double> h(n);
      for (std::size_t i = 0; i < n; ++i) h[i] = voxels[i].height;
      ws.planes.assign(tiles, Plane{0, 0, histogramPeak(h, cfg.bin_size)});
      out.tiles = 1;
    } else {
      tilePlanes(ws, tiles, cfg, cell);
      out.tiles = static_cast<int>(tiles);
    }
    // the problem over positions of the layout
    setUnaries(ws, tiles, cell, cfg, out, [](std::uint32_t, std::size_t, int, int, float) {});
    ws.layout.linkNeighbours(ws.problem, cfg, tiles);
    refine(ws, cfg, out);
    // by chunks, through pointers held in locals (a label is a byte, whose store may alias anything)
    tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
      std::uint8_t* const refined = out.refined.data();
      const std::uint8_t* const labels = ws.labels.data();
      const std::uint32_t* const ids = ws.layout.ids();
      for (std::size_t q = n * c / kChunks, end = n * (c + 1) / kChunks; q < end; ++q) refined[ids[q]] = labels[q];
    });
  });
}

}  // namespace

SegmentationResult segmentGround(VoxelMap& map, const GroundSegmentationConfig& cfg) {
  SegmentationResult out = segmentGroundLabels(map, cfg);
  auto& voxels = map.voxels();
  for (std::size_t i = 0; i < voxels.size(); ++i)
    voxels[i].label = out.refined[i] ? VoxelLabel::Ground : VoxelLabel::NonGround;
  return out;
}

SegmentationResult segmentGroundLabels(const VoxelMap& map, const GroundSegmentationConfig& cfg) {
  Workspace ws;
  SegmentationResult out;
  segmentWhole(map, cfg, ws, out);
  return out;
}

struct ScanSegmenter::State {
  GroundSegmentationConfig config;
  VoxelMap map;
  std::vector<std::uint32_t> voxel_of;
  Workspace work;
  SegmentationResult result;
  PointLabelBuffers buffers;
  std::vector<std::uint8_t> labels;
  State(const VoxelMapConfig& voxels, const GroundSegmentationConfig& c) : config(c), map(voxels) {}
};

ScanSegmenter::ScanSegmenter(const VoxelMapConfig& voxels, const GroundSegmentationConfig& config)
    : state_(std::make_unique<State>(voxels, config)) {}
ScanSegmenter::~ScanSegmenter() = default;

const std::vector<std::uint8_t>& ScanSegmenter::segment(const std::vector<Point3>& points) {
  State& s = *state_;
  s.map.clear();
  s.map.insert(points, 0, nullptr, &s.voxel_of);
  segmentWhole(s.map, s.config, s.work, s.result);
  labelScanPoints(s.map, points, s.voxel_of, s.result.refined, s.config, s.buffers, s.labels);
  return s.labels;
}

const VoxelMap& ScanSegmenter::map() const { return state_->map; }
const std::vector<std::uint32_t>& ScanSegmenter::voxelOf() const { return state_->voxel_of; }
const SegmentationResult& ScanSegmenter::result() const { return state_->result; }
const GroundSegmentationConfig& ScanSegmenter::config() const { return state_->config; }

// ---------------------------------------------------------------------------------------------
// incremental

namespace {

std::uint64_t tileKey(int tx, int ty) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(tx)) << 32) | static_cast<std::uint32_t>(ty);
}

// the tile coordinates of a key made by tileKey
std::pair<int, int> keyTile(std::uint64_t key) {
  return {static_cast<int>(static_cast<std::uint32_t>(key >> 32)), static_cast<int>(static_cast<std::uint32_t>(key))};
}

}  // namespace

struct IncrementalGroundSegmentation::State {
  GroundSegmentationConfig cfg;
  double cell = 0;
  int k = 0;     // columns per tile edge
  int base = 0;  // a tile corner's index below every index a map holds (+-2^20)
  struct Tile {
    int tx = 0, ty = 0;
    std::vector<std::uint32_t> ids;  // in id order
    std::size_t pending = 0;         // voxels added since it was last re-segmented
  };
  std::unordered_map<std::uint64_t, Tile> tiles;
  std::unordered_set<std::uint64_t> touched;
  std::size_t taken = 0;             // voxels already placed in tiles
  std::vector<std::uint64_t> fresh;  // the tile of each voxel added since the last update (while taking them in)
  SegmentationResult result;
  Stats stats;
  Workspace work;  // the last update's layout and subproblem, kept so that their memory is reused

  void setCell(double voxel_size) {
    if (cell == voxel_size) return;
    cell = voxel_size;
    k = std::max(1, static_cast<int>(std::lround(cfg.tile_size / cell)));
    base = floorDiv(-(1 << 20), k) * k;
  }

  // appends to out, in key order, the tiles of the map within `radius` tiles of any of these that
  // are not yet in seen (and adds them to it)
  void windows(const std::vector<std::uint64_t>& of, int radius, std::unordered_set<std::uint64_t>& seen,
               std::vector<std::uint64_t>& out) const {
    const std::size_t first = out.size();
    for (std::uint64_t key : of) {
      const auto [tx, ty] = keyTile(key);
      for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
          const std::uint64_t u = tileKey(tx + dx, ty + dy);
          if (tiles.count(u) && seen.insert(u).second) out.push_back(u);
        }
      }
    }
    std::sort(out.begin() + static_cast<std::ptrdiff_t>(first), out.end());
  }
};

IncrementalGroundSegmentation::IncrementalGroundSegmentation(const GroundSegmentationConfig& config)
    : state_(std::make_unique<State>()) {
  state_->cfg = config;
}

IncrementalGroundSegmentation::~IncrementalGroundSegmentation() = default;

const SegmentationResult& IncrementalGroundSegmentation::result() const { return state_->result; }
const IncrementalGroundSegmentation::Stats& IncrementalGroundSegmentation::lastStats() const { return state_->stats; }

void IncrementalGroundSegmentation::update(VoxelMap& map) {
  State& st = *state_;
  const auto& cfg = st.cfg;
  st.stats = Stats{};
  if (cfg.histogram == GroundSegmentationConfig::Histogram::Global) {
    st.result = segmentGround(map, cfg);
    st.taken = map.size();
    st.touched.clear();
    st.stats.voxels = map.size();
    return;
  }
  st.setCell(map.voxelSize());
  auto& voxels = map.voxels();
  const std::size_t n = voxels.size();
  tbb::task_arena arena = arenaFor(cfg.threads);
  // take in the new voxels, run by run of successive voxels in one tile (most runs are long), their
  // tiles found in parallel first. A tile is due once its new voxels make up defer_share of its
  // voxels: a share that only grows as voxels are added, so whether a run made it due is known at
  // the run's end.
  const OffsetDivider divide(st.base, st.k);
  const int first_tile = st.base / st.k;
  std::vector<std::uint64_t>& fresh = st.fresh;
  fresh.resize(n - std::min(n, st.taken));
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, fresh.size(), [&](std::size_t i) {
      const VoxelIndex& index = voxels[st.taken + i].index;
      fresh[i] = tileKey(first_tile + divide(index.x()), first_tile + divide(index.y()));
    });
  });
  for (std::size_t i = 0; i < fresh.size();) {
    const std::uint64_t key = fresh[i];
    std::size_t end = i + 1;
    while (end < fresh.size() && fresh[end] == key) ++end;
    State::Tile& t = st.tiles[key];
    if (t.ids.empty()) std::tie(t.tx, t.ty) = keyTile(key);
    const auto due = [&] {
      return t.pending > 0 && static_cast<double>(t.pending) >= cfg.defer_share * static_cast<double>(t.ids.size());
    };
    const bool was_due = due();
    t.pending += end - i;
    const std::size_t had = t.ids.size();
    t.ids.resize(had + (end - i));
    std::iota(t.ids.begin() + static_cast<std::ptrdiff_t>(had), t.ids.end(), static_cast<std::uint32_t>(st.taken + i));
    if (!was_due && due()) st.touched.insert(key);
    i = end;
  }
  st.taken = n;
  SegmentationResult& out = st.result;
  out.rough.resize(n, 0);
  out.refined.resize(n, 0);
  out.ground_height.resize(n, 0.0f);
  st.stats.touched_tiles = st.touched.size();
  // the tiles whose window reaches a touched tile, in a fixed order
  std::vector<std::uint64_t> keys;
  std::unordered_set<std::uint64_t> seen;
  st.windows(std::vector<std::uint64_t>(st.touched.begin(), st.touched.end()), cfg.tile_radius, seen, keys);
  for (std::uint64_t key : st.touched) {
    auto it = st.tiles.find(key);
    if (it != st.tiles.end()) it->second.pending = 0;
  }
  st.touched.clear();
  st.stats.refitted_tiles = keys.size();
  if (keys.empty()) return;
  // the tiles to refit, then the other tiles of their windows (their voxels enter the planes) and
  // those next to them (their voxels' labels enter the pair terms)
  std::vector<std::uint64_t> context;
  st.windows(keys, std::max(1, cfg.tile_radius), seen, context);
  std::vector<TileLayout::Tile> tiles;
  std::vector<const std::vector<std::uint32_t>*> tile_ids;
  for (const auto* list : {&keys, &context}) {
    for (std::uint64_t key : *list) {
      const State::Tile& t = st.tiles.at(key);
      tiles.push_back({t.tx, t.ty}), tile_ids.push_back(&t.ids);
    }
  }
  const std::size_t count = keys.size();
  const int k = st.k;
  arena.execute([&] {
    Workspace& ws = st.work;
    ws.layout.build(voxels, k, tiles, tile_ids);
    const TileLayout& layout = ws.layout;
    tilePlanes(ws, count, cfg, st.cell);
    // the subproblem: every voxel of the refitted tiles, the first positions of the layout.
    // Neighbours in tiles outside it keep their labels: their pair terms become unary terms. Every
    // tile of the map next to a refitted one is in the layout, so such a neighbour is looked up in
    // its column there; a tile missing from the layout holds no voxel.
    GmrfProblem& p = ws.problem;
    const auto fixed = [&](std::uint32_t q, std::size_t t, int lx, int ly, float h) {
      const TileLayout::Tile& tile = tiles[t];
      static constexpr int kSteps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
      for (const auto& step : kSteps) {
        const int nx = lx + step[0], ny = ly + step[1];
        if (nx >= 0 && nx < k && ny >= 0 && ny < k) continue;
        const std::int64_t u = layout.tileAt(tile.tx + step[0], tile.ty + step[1]);
        if (u < 0 || static_cast<std::size_t>(u) < count) continue;
        const std::size_t c = static_cast<std::size_t>(floorMod(ny, k)) * k + static_cast<std::size_t>(floorMod(nx, k));
        const std::int32_t z = layout.z(q);
        std::uint32_t r = layout.column(u, c);
        const std::uint32_t e = layout.column(u, c + 1);
        while (r < e && layout.z(r) < z) ++r;
        if (r == e || layout.z(r) != z) continue;
        const float w = pairWeight(cfg, h, layout.height(r));
        const bool ground_r = out.refined[layout.id(r)] != 0;
        p.unary_ground[q] += ground_r ? -w : w;
        p.unary_nonground[q] += ground_r ? w : -w;
      }
    };
    setUnaries(ws, count, st.cell, cfg, out, fixed);
    const std::size_t m = ws.rough.size();
    st.stats.voxels = m;
    layout.linkNeighbours(p, cfg, count);
    refine(ws, cfg, out);
    out.tiles = static_cast<int>(st.tiles.size());
    // by chunks, through pointers held in locals (a label is a byte, whose store may alias anything)
    tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
      std::uint8_t* const refined = out.refined.data();
      Voxel* const voxel = voxels.data();
      const std::uint8_t* const labels = ws.labels.data();
      const std::uint32_t* const ids = layout.ids();
      for (std::size_t q = m * c / kChunks, end = m * (c + 1) / kChunks; q < end; ++q) {
        refined[ids[q]] = labels[q];
        voxel[ids[q]].label = labels[q] ? VoxelLabel::Ground : VoxelLabel::NonGround;
      }
    });
  });
}

}  // namespace terrain
