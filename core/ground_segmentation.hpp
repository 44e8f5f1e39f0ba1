#pragma once
// Stage 4, ground segmentation (paper Sec. 3 and Appendix).
//
// Height histogram (Eq. 1): the peak gives the ground height h1; voxels within +-delta of it form
// G1 (towards ground), the rest G2. The paper's single global histogram fails on slopes and rough
// ground, so the default is local: the map is cut into tiles; in each tile (with its neighbours) a
// plane is fitted to the lowest voxel of every 2 x 2 block of columns, and the histogram is taken
// of heights above that plane, so h1 follows the terrain: all of the tile's own voxels and those
// of every histogram_stride-th column each way of its neighbours. The global variant stays
// selectable.
//
// Gibbs-Markov random field (Eqs. 9-22) over the voxels, neighbours at L1 distance 1:
//   V1(f_v)        = -alpha if f_v agrees with v's rough class (G1 ground, G2 non-ground), else +alpha
//   V1(h_v | f_v)  = -alpha if h_v lies in R(f_v), else +alpha; R(ground) = [h1 - range_margin,
//                    h1 + range_margin], R(non-ground) its complement
//   V2 + V2(h)     = -(beta + gamma e^{-|h_v - h_v'|}) if f_v = f_v', else +(beta + gamma e^{-|h_v - h_v'|})
// Solvers: iterated conditional modes (red-black order, so it runs in parallel and gives the same
// labels whatever the thread count), and the exact minimum by s-t min-cut (the energy is binary
// and submodular).

#include "core/voxel_map.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace terrain {

struct GroundSegmentationConfig {
  enum class Histogram { Global, Local };
  enum class Solver { Icm, MinCut };
  Histogram histogram = Histogram::Local;
  // The GMRF's solver: min-cut, the exact minimum of the energy, or ICM, its local minimum from the
  // rough classes. ICM leaves whole patches of ground outside the band as non-ground where every
  // voxel agrees with its neighbours (rough terrain, ramps): on 60-frame runs of seeds 11 and 12 of
  // every terrain type (not looked at before) ICM F1 was rough 94.33 / 97.15 %, mixed 97.80 /
  // 97.92, slope 98.50 / 98.44, forest 99.28 / 99.09 and min-cut 98.96 / 99.26, 99.44 / 99.36,
  // 98.86 / 98.38, 99.60 / 99.65 (flat and urban the same); on the real KITTI scans 0.978 / 0.969
  // by ICM and 0.978 / 0.968 by min-cut; a scan segmented in 8.0 ms against ICM's 6.9.
  Solver solver = Solver::MinCut;
  double bin_size = 0.1;      // [m] histogram bin width
  double delta = 0.3;         // [m] half-width of the ground band around h1 (rough class G1)
  double range_margin = 0.5;  // [m] half-width of R(ground) around h1
  // A voxel at the foot of an unbroken stack of voxels (each directly above the one below) that
  // reaches more than stack_height above it stands under something upright (a wall, a fence, a
  // trunk, the side of a car): rough class non-ground, and its single-site term that of a voxel
  // outside R(ground). Ground is one or two voxels thick in its column, and the ground under a car
  // body, a crown or an overhang has empty voxels between them. 0: off (the paper's terms). On the
  // two real KITTI scans ICM F1 0.964 -> 0.977 and 0.940 -> 0.967 (0.2 m: 0.978, 0.971); 0.4 rather
  // than 0.2 because a map of several sweeps with pose error has thicker ground columns (8-frame
  // slope seed 1, 6.6 deg of pitch error: 0.981 -> 0.940 at 0.2, 0.985 at 0.4).
  double stack_height = 0.4;  // [m]
  // [m] empty space allowed between two voxels of such a stack above its second voxel (the foot's
  // upper neighbour must be there: the ground under a car body with one empty voxel between keeps
  // its class). A single scan samples a far wall ring by ring, leaving empty voxels in its column.
  // On the two real KITTI scans 0 -> 0.2 m took ICM F1 0.977 -> 0.978 and 0.967 -> 0.969 (with
  // depth_below 2 m: 0.982 -> 0.983 and 0.970 -> 0.972); on 60-frame simulated runs (seed 9) it
  // changes nothing but rough's F1 (93.18 -> 93.22 %).
  double stack_gap = 0.2;
  // [m] a voxel standing more than this above the ground's level around it, plus what the tile's
  // plane rises across one column, is not ground: rough class non-ground, and the single-site term
  // of a voxel outside R(ground). The level is the lower median, over its column and the eight
  // around it, of each column's ground top: the voxel right above the column's lowest if there is
  // one (ground is one or two voxels thick), else the lowest, or higher up the unbroken stack on
  // the lowest while within stack_height of it (thick ground from pose error). The side of a car, a
  // kerb's top or a wall's low rows step up from the ground their neighbours share. 0: off, the
  // default. At 0.1 m, on the two real KITTI scans min-cut F1 0.988 -> 0.989 and 0.975 -> 0.979, on
  // 60-frame simulated runs (seeds 29-32, before rise_above) 99.44 -> 99.45 %, but the object-cell
  // error 8.95 -> 9.03 m and trees at their height 584 -> 576: voxels beside trunks' feet turn
  // non-ground and join them, too wide then for trunks.
  double step_height = 0;
  // [m] the lowest voxel of a column, and the one right above it (ground is one or two voxels
  // thick), lying below h1 by more than delta but no more than this are in G1, with the single-site
  // term of a voxel at h1: the lidar sees nothing under the ground, so the lowest returns of a
  // column below the fitted plane are ground where the plane does not follow it (a dip, a ditch, a
  // road below its kerbs, the path cut into rough ground). 0: off. At 1 m, on 60-frame simulated
  // runs of every terrain type (seeds 29-32) ICM F1 98.15 -> 99.12 % and 98.35 -> 99.06 % (rough
  // 92.35 -> 97.48 and 95.13 -> 98.50), object-cell MAE 8.44 -> 8.35 and 9.63 -> 9.55 m, terrain
  // cells raised by mistake 229.8 -> 216.8 and 640.9 -> 612.9 a run; on the two real KITTI scans
  // min-cut F1 0.988 -> 0.988 and 0.976 -> 0.975.
  double depth_below = 1.0;
  // [m] the lowest voxel of a column, and the one right above it, lying above R(ground) but no
  // more than this above h1 have a weak single-site term (a quarter of alpha, leaning to
  // non-ground), so that their neighbours decide: ground where they continue the ground around
  // them through the GMRF's links (the foot of a slope, a bank, where the tile's plane does not
  // follow the ground), non-ground where they stand apart (a ledge, a car's roof: no voxel of the
  // ground beside them shares their layer). 0: off (the terms of Eqs. 19-20). At 1 m, on 60-frame
  // simulated runs of every terrain type (seeds 29-34) min-cut F1 99.46 -> 99.59 %, object-cell
  // MAE 8.95 -> 8.85 and 8.89 -> 8.84 m (seeds 29-32, 33-34), terrain cells raised by mistake
  // 414.9 -> 346.8 and 284.2 -> 233.7 a run, objects too high 8.71 -> 8.83 and 9.00 -> 9.08 a run;
  // on the two real KITTI scans min-cut F1 unchanged (0.988, 0.975).
  double rise_above = 1.0;
  // The local histogram's tile planes follow the lower envelope of the columns' lowest voxels
  // where that holds more of them than a symmetric least-squares fit (plane_fit.hpp), and the
  // histogram's peak is sought within range_margin of the plane; false: symmetric least squares
  // always, and the peak anywhere. Symmetric fits let a building's low ledge and bushes among
  // sparse far ground lift the plane 0.5-2 m above the ground beside them. On the two real KITTI
  // scans min-cut F1 0.978 -> 0.988 and 0.968 -> 0.976 (ICM 0.978 -> 0.988, 0.969 -> 0.977).
  bool lower_envelope = true;
  // Labels of the points of a single scan (labelScanPoints): a point of a ground voxel standing more
  // than point_rise above the ground's level at its column, plus what the ground rises across one
  // column there, is not ground, and a point of a non-ground voxel within point_reach of that level
  // is. The level is the lower median, over the column and its eight neighbours, of each column's
  // lowest point in a ground voxel; the rise across a column comes from the lowest points of the
  // columns on either side. A voxel is 0.2 m tall: the foot of a wall, a fence or a car shares
  // voxels with the ground beside it, and a column that holds a bush, a car's underside or a pole
  // over the ground is non-ground as a whole. point_rise 0: off (each point takes its voxel's
  // label). On the two real KITTI scans min-cut F1 0.988 -> 0.994 and 0.975 -> 0.984.
  double point_rise = 0.1;    // [m]
  double point_reach = 0.05;  // [m]
  double tile_size = 6.0;     // [m] local histogram tile edge
  int tile_radius = 1;        // tiles on each side whose voxels join a tile's histogram
  // [columns] of a tile's neighbours, its histogram takes the columns whose grid x and y are
  // multiples of this (all of them if that leaves fewer than 256 voxels); the tile's own columns
  // all count. 2 rather than 1: a quarter of the work, and the tile's own ground weighs more, which
  // follows slopes and rough ground more closely (8-frame CI suite, ICM F1 slope 0.942 -> 0.981,
  // rough 0.945 -> 0.958, mixed 0.951 -> 0.962; real KITTI scans 0.956 -> 0.964, 0.939 -> 0.940).
  int histogram_stride = 2;
  double alpha = 1.0;       // single-site weight
  double beta = 0.6;        // pair-site Potts weight
  double gamma = 0.6;       // pair-site height-contrast weight
  int icm_iterations = 20;  // ICM sweeps at most
  int threads = 0;          // 0: all cores
  // Incremental segmentation: a tile that gains voxels waits until they make up this share of its
  // voxels before it is re-segmented (its new voxels stay unlabelled until then); 0: at once. A
  // spinning lidar adds a trickle of voxels to hundreds of far tiles every frame: on a 1000-frame
  // urban run 0.1 took the per-frame median from 59 to 30 ms and p95 from 102 to 43 ms with the same
  // final labels (the whole map is segmented at the end) and 1615 instead of 1664 estimated cells.
  double defer_share = 0.1;
};

// Parses "global"/"local" and "icm"/"mincut"; false if unknown.
bool parseHistogram(const std::string& s, GroundSegmentationConfig::Histogram& out);
bool parseSolver(const std::string& s, GroundSegmentationConfig::Solver& out);

// Height h1 [m] at the peak of a histogram of heights with bins of bin_size; NaN if empty. The
// peak is refined to the mean of the heights in the peak bin and its two neighbours.
double histogramPeak(const std::vector<double>& heights, double bin_size);

// The binary energy of the GMRF: unary costs per node and label, and weighted neighbour pairs.
// The graph is a grid's: along each of three axes a node has at most one neighbour forward (next)
// and one backward (prev); the two nodes of a pair differ in parity (red-black colouring), so that
// ICM can update all nodes of one colour at once. Costs are floats: a 1.8 M-voxel problem is read
// several times per solve, and half the bytes make it faster.
struct GmrfProblem {
  static constexpr std::uint32_t kNone = 0xffffffffu;
  // per node: V1(f) + V1(h|f) for f = ground and non-ground
  std::vector<float> unary_ground, unary_nonground;
  // 3 per node: its neighbour forward along each axis, or kNone
  std::vector<std::uint32_t> next;
  // 3 per node: the node whose forward neighbour along each axis it is, or kNone
  std::vector<std::uint32_t> prev;
  // 3 per node: the weight beta + gamma e^{-|h_u - h_v|} of its pair with next
  std::vector<float> weight;
  // red-black colour of each node (neighbours differ)
  std::vector<std::uint8_t> parity;

  // n nodes with zero unary costs and no pairs
  void resize(std::size_t n);
  std::size_t size() const { return parity.size(); }
  // makes v the forward neighbour of u along axis (0..2), with the pair's weight
  void link(std::uint32_t u, int axis, std::uint32_t v, float pair_weight) {
    next[3 * u + axis] = v;
    prev[3 * v + axis] = u;
    weight[3 * u + axis] = pair_weight;
  }
};

// The pair-site weight beta + gamma e^{-|a - b|} of two neighbouring voxels of heights a and b [m]
// (Eqs. 21-22), in single precision.
float pairWeight(const GroundSegmentationConfig& config, float a, float b);

// Energy U(f|d) of a labelling (true = ground), Eq. 18.
double gmrfEnergy(const GmrfProblem& problem, const std::vector<std::uint8_t>& ground);
struct IcmResult {
  int sweeps = 0;  // sweeps that changed a label
  // U(f|d) of the labelling given and of the one returned
  double energy_initial = 0, energy_final = 0;
};
// ICM from an initial labelling, red-black in place: a first sweep over every node, then sweeps
// over only the nodes next to one that changed (the labels of full sweeps, at a fraction of the
// cost). The energies are summed on the way. Throws std::invalid_argument if the problem's graph
// is not a grid's (a node linked forward from two along one axis, or a pair of equal parity).
IcmResult solveIcm(const GmrfProblem& problem, std::vector<std::uint8_t>& ground, int max_iterations, int threads);
// Exact minimum by s-t min-cut.
void solveMinCut(const GmrfProblem& problem, std::vector<std::uint8_t>& ground);
// The same, keeping the flow graph's memory from one call to the next (about 220 bytes per node of
// a grid problem): a map re-segmented as it grows pays for those pages once, not on every call.
class MinCutSolver {
 public:
  MinCutSolver();
  ~MinCutSolver();
  MinCutSolver(const MinCutSolver&) = delete;
  MinCutSolver& operator=(const MinCutSolver&) = delete;
  void solve(const GmrfProblem& problem, std::vector<std::uint8_t>& ground);

 private:
  struct Graph;
  std::unique_ptr<Graph> graph_;
};

struct SegmentationResult {
  std::vector<std::uint8_t> rough;    // per voxel: 1 if in G1
  std::vector<std::uint8_t> refined;  // per voxel: 1 if in G1'
  std::vector<float> ground_height;   // per voxel: h1 at its position [m]
  double energy_rough = 0, energy_refined = 0;
  int iterations = 0;
  int tiles = 0;  // local histograms used (1 for global)
};

// Keeps the segmentation of a growing map current frame by frame, at a cost that follows the
// sensor's footprint rather than the map's size (local histogram only; with the global one every
// update segments the whole map). Tiles whose voxels added since they were last segmented make up
// defer_share of their voxels are re-segmented: their ground planes, and those of the tiles whose window reaches them,
// are refitted exactly as segmentGroundLabels fits them, and the GMRF is solved over the voxels of the refitted tiles
// with the labels of their neighbours outside held fixed.
class IncrementalGroundSegmentation {
 public:
  explicit IncrementalGroundSegmentation(const GroundSegmentationConfig& config);
  ~IncrementalGroundSegmentation();
  IncrementalGroundSegmentation(const IncrementalGroundSegmentation&) = delete;
  IncrementalGroundSegmentation& operator=(const IncrementalGroundSegmentation&) = delete;

  // Takes in the voxels added to the map since the last update and re-segments the tiles they made
  // due (defer_share); writes the labels of the re-segmented voxels into the map.
  void update(VoxelMap& map);

  // Per voxel id: rough, refined, ground_height. Energies and iterations are those of the last
  // update's subproblem.
  const SegmentationResult& result() const;
  struct Stats {
    // tiles due, tiles refitted (those due and those whose window reaches them), voxels re-segmented
    std::size_t touched_tiles = 0, refitted_tiles = 0, voxels = 0;
  };
  const Stats& lastStats() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Segments every voxel of the map; the map is not changed.
SegmentationResult segmentGroundLabels(const VoxelMap& map, const GroundSegmentationConfig& config);

// Per-point ground labels (1 ground) of a single scan whose points were inserted into `map` alone:
// voxel_of holds each point's voxel id (VoxelMap::insert; kNoVoxel for a point left out, labelled
// 0) and voxel_ground the voxels' labels (SegmentationResult::refined). Each point takes its
// voxel's label, refined by config.point_rise and config.point_reach; a map wider than
// kMaxScanColumns columns (scanColumnCount) keeps the voxels' labels as they are.
std::vector<std::uint8_t> labelScanPoints(const VoxelMap& map, const std::vector<Point3>& points,
                                          const std::vector<std::uint32_t>& voxel_of,
                                          const std::vector<std::uint8_t>& voxel_ground,
                                          const GroundSegmentationConfig& config);
// What labelScanPoints works in: a scan's column grid and per-voxel levels, kept by a caller that
// labels scan after scan so that their memory is reused.
struct PointLabelBuffers {
  std::vector<float> columns, level, ceiling;
};
// The same into out (resized to the points), working in buffers.
void labelScanPoints(const VoxelMap& map, const std::vector<Point3>& points, const std::vector<std::uint32_t>& voxel_of,
                     const std::vector<std::uint8_t>& voxel_ground, const GroundSegmentationConfig& config,
                     PointLabelBuffers& buffers, std::vector<std::uint8_t>& out);
// Columns of the grid labelScanPoints lays over a map (its extent and a margin of one column); 0
// for an empty map. A scan 120 m in reach with 0.2 m voxels: 1.44 M.
std::int64_t scanColumnCount(const VoxelMap& map);
constexpr std::int64_t kMaxScanColumns = std::int64_t{1} << 26;

// Segments single scans one after another, as a robot's sweeps or a dataset's scans come: each scan
// becomes a voxel map of its own, whose voxels are segmented (segmentGroundLabels) and whose points
// take their voxels' labels (labelScanPoints). The map, the segmentation's workspace and the
// labels' buffers are kept from one scan to the next, so that a scan costs no fresh memory: on a
// 2-core machine a KITTI scan's pages alone took longer than its segmentation. The labels are
// those of a segmenter made for each scan.
class ScanSegmenter {
 public:
  ScanSegmenter(const VoxelMapConfig& voxels, const GroundSegmentationConfig& config);
  ~ScanSegmenter();
  ScanSegmenter(const ScanSegmenter&) = delete;
  ScanSegmenter& operator=(const ScanSegmenter&) = delete;

  // Per point: 1 ground (valid until the next call). The scan replaces the last one.
  const std::vector<std::uint8_t>& segment(const std::vector<Point3>& points);
  // Of the last scan: its map, each point's voxel (kNoVoxel for a point left out) and the voxels'
  // segmentation.
  const VoxelMap& map() const;
  const std::vector<std::uint32_t>& voxelOf() const;
  const SegmentationResult& result() const;
  const GroundSegmentationConfig& config() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Segments every voxel of the map and writes the refined labels into the voxels.
SegmentationResult segmentGround(VoxelMap& map, const GroundSegmentationConfig& config);

}  // namespace terrain
