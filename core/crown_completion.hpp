#pragma once
// Stage 6c, crown completion (beyond the paper): with the lidar capped a little above the sensor, a
// tree is a trunk; the ground under its crown is sensed and labelled ground, so boundary estimation,
// which raises non-ground vertices, never reaches the crown. Each frame, every trunk-sized object
// the camera sees is followed up its image column to its crown: by default the crown's pixels are
// foliage-coloured (green above red and blue) and the walk first climbs the bare trunk above the
// lidar's reach; with the sky cue they are all pixels that are not sky. The last crown pixel is the
// crown's top (unless another sensed object may own it: the clear-line test of boundary estimation,
// with the foliage cue only other trunks), and the largest distance from the column to the nearer
// end of the crown's run of pixels around it, row by row while the run ends in non-crown pixels on
// both sides, is the crown's radius at the trunk's depth. The rows end where the run jumps outwards
// (an end moving out by more than 3 px and by more than it moved at the row before: an outline
// widens less and less down to its widest row, so that is another crown joining it; where they end
// above the widest row, an ellipse through them from the crown's top to its lowest pixel on the
// vertical gives the radius, CrownConfig::ellipse_radius). Where another
// trunk stands under the run nearer its centre, or the widest run is centred away from the column,
// the crown is another tree's; the frame gives no sample. The sky cue
// measures only crowns against the sky; the foliage cue also those before facades. At the end of
// the run, a tree with enough samples raises the ground vertices within its crown radius to a
// spherical cap of that radius whose top is the crown's top height (the median of the lowest group of
// samples that agree), and lowers the trunk's own estimates to the cap.

#include "core/boundary_estimation.hpp"
#include "core/sensor_data.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"

#include <opencv2/core/mat.hpp>

#include <array>
#include <unordered_map>
#include <vector>

namespace terrain {

struct CrownConfig {
  // On 60 frames of 12 scenes (urban seeds 1-5, forest 1-2, mixed 1-2, flat, slope, rough) the
  // error over the tree cells the camera saw went, sensed only -> sky cue -> foliage cue, 10.99 ->
  // 8.87 -> 6.44 m (urban 1), 13.80 -> 13.79 -> 8.89 (urban 2), 12.68 -> 12.69 -> 10.86 (urban 3),
  // 14.52 -> 14.18 -> 10.36 (urban 4), 11.93 -> 11.50 -> 9.23 (urban 5), 14.95 -> 14.93 -> 14.67
  // (forest 1), 13.90 -> 13.99 -> 14.00 (forest 2), with the same terrain cells raised; none measured
  // on the others. Crowns that touch in the image (most of a forest's) give no sample.
  bool enabled = true;
  // What tells a crown's pixels from what is behind it. Foliage: green-dominant pixels (green at
  // least foliage_margin grey levels above both red and blue, as leaves in daylight), so a crown is
  // measured before a facade or another object as well as against the sky. Sky: every pixel that
  // is not sky (the sky test of boundary estimation), so only crowns against the sky.
  enum class Cue { Foliage, Sky };
  Cue cue = Cue::Foliage;
  int foliage_margin = 10;  // [grey levels]
  // [m] (foliage) bare trunk allowed between the lidar's highest return on it and the crown's lowest
  // pixel in its column. Tall trees carry their crowns high: a 21 m tree whose crown starts 13.6 m
  // up, 28 m from the drive, stands 3 m high in the lidar. On 60 frames of seeds 11-14 of every
  // terrain type (fresh), 8 -> 16 m took the object-cell error from 11.21 to 10.26 m (11-12) and
  // from 11.38 to 11.34 m (13-14), trees at their real height 275 -> 282 and 257 -> 258 of 641 and
  // 662, with as many objects too high and 177 -> 188 and 362 -> 362 terrain cells raised a run.
  double max_trunk_gap = 16.0;
  double max_trunk_width = 1.2;  // [m] objects wider than this (either way) are not trunks
  // [m] a trunk measured while it was within max_trunk_width is still one when the samples are
  // applied if it has grown to no more than this: over a long drive the pose noise spreads a thin
  // trunk's returns (urban 1, 300 frames: the trunks of the two tallest trees seen, 0.8 x 1.4 m and
  // 0.6 x 1.4 m, had 51 and 96 samples and raised nothing; at 2.4 m the tree cells whose sensed top
  // the camera saw went from 12.77 to 8.12 m). Wider limits while measuring took facade fragments
  // for trunks (on 60 frames urban 3-5 lost crowns at 1.6 m).
  double max_grown_width = 2.4;
  // [m] a trunk is measured for a crown only if it stands at least this far above the lowest ground
  // vertex within 1 m of it: a patch of terrain labelled non-ground is no trunk (it still counts
  // among those that may own a crown's pixels). On 60 frames of slope seed 1 such a patch, level
  // with the ground around it, took the crown of a tree 12 m nearer the camera (1,060 terrain cells
  // raised). Real trunks the lidar saw only low stood 0.5-1 m above it: at 1 m forest seed 1 lost
  // 319 of 533 cells raised under crowns.
  double min_trunk_height = 0.5;
  double min_radius = 0.6;  // [m] a narrower top is a pole's, not a crown
  double max_radius = 8.0;  // [m] wider runs are not one crown
  int min_samples = 3;      // frames that must have measured a crown
  // A sample's crown top bounds the crown from above (foliage behind or before the crown in its
  // column only lifts it): the crown's top is the median of the lowest group of samples whose tops
  // lie within this share above the group's lowest (a share of its height above the ground around
  // the trunk, or above the trunk's sensed top where no ground is near: world heights may be
  // negative), with min_samples samples whose cameras spread min_baseline. Before, the median of all samples with their
  // interquartile range within this share of it: on 60 frames of the 12 scenes (above) trees at their real height 128
  // -> 129 of 332 (urban 4 tree_042: five samples at 12.4-12.7 m from the first 2.5 m of the drive, then eight at
  // 15.3-16.2 m rising as the camera neared, a crown behind), nothing else changed.
  double max_top_spread = 0.1;
  // [m] the samples' camera positions must spread this far: a crown behind the column moves against
  // the trunk only with parallax. On 60 frames of the 12 scenes, 2 rather than 4 took the trees at
  // their real height from 123 to 127 of 332 (flat 1, forest 1 twice, urban 4; their samples' cameras
  // 2-4 m apart), none more too high (23) and the terrain cells raised by mistake unchanged (931); at
  // 1 m 132 trees but urban 3's terrain raised 22 -> 322 cells, at 0 136 trees, 25 too high and 1554
  // terrain cells raised. With the crown taken from the lowest group of agreeing samples (above):
  // 2 m 129 trees (23 too high, terrain 931), 1.5 m 131 (23, 932: forest 2 tree_148, urban 2
  // tree_050), 1.25 m 133 (23, but urban 3's terrain 22 -> 322: a false crown whose samples'
  // cameras lie 1.25-1.5 m apart), 1 m 134 (24, 1374). 1.5 keeps a quarter of a metre from that.
  double min_baseline = 1.5;
  int min_height_px = 3;       // [px] crown rows needed in the trunk's column
  double max_offcentre = 0.2;  // the widest run's centre may lie this share of its width (+1 px)
                               // beside the trunk's column; farther, the run is another crown
  // a crown's width (twice its radius) is at most this many times its depth (its top above the
  // lowest crown pixel on the trunk's vertical, or above the trunk's sensed top with the sky cue);
  // a sample's radius is cut to it. 0: no bound. On 60 frames of forest seeds 13 and 14 it took the
  // terrain cells raised by mistake from 572.5 to 190.0 a run, the error unchanged (one tree's runs,
  // joined on both sides by crowns behind it, gave a radius of 6.65 m; true 2.5 m)
  double max_width_to_depth = 2.0;
  // Where one end of the crown's runs jumps outwards (a crown behind joins it on that side), the
  // runs below are followed on by their other end alone, whose distance from the vertical goes on
  // giving the crown's radius; without it the walk stops at the first such row, often above the
  // crown's widest. Off by default: on 60 frames of every terrain type, seeds 29 and 30, it took the
  // object-cell MAE 8.34 -> 7.80 m and the terrain cells raised by mistake 195.7 -> 262.2 a run
  // (seed 35: 10.28 -> 9.54 m, 52.3 -> 118.2): a crown behind that joins the other end smoothly
  // widens the runs (docs/results.md, 2026-12-07).
  bool one_sided = false;
  // Bound each cap from outside by the sky: a visual hull of its own (skyGuardHull in
  // core/crown_hull: guard_cell voxels out to where crowns are measured, whatever hull.enabled
  // says) is voted on frame by frame, and at the end a vertex under a cap is left alone
  // where the sky showed through every hull voxel of its column between the cap's base (its top
  // less its radius) and the cap's height there: no crown stands there, whatever the runs said.
  // Off by default: on 60 frames of every terrain type, seeds 29, 30, 36 and 37, it took the
  // terrain cells raised by mistake 213.5 -> 184.6 a run and the object-cell MAE 8.49 -> 8.64 m;
  // with one_sided 7.83 m and 258.4 cells. It costs about 16 ms a frame (urban seed 29: median
  // 38 -> 57 ms with one_sided).
  bool sky_guard = false;
  // The same hull bounds what boundary estimation raised on trunks: at the end of the run a raised
  // vertex of a trunk is lowered to where the sky showed through its column without a break from
  // above (CrownHull::skyFloor: from the highest layer any image saw at or below its height, down
  // through the layers two sky pixels' rays passed), when that lies more than a layer below it. A trunk seen under the
  // crown of a nearer tree, or before a taller one, takes that crown's top edge at its own depth: tens of metres too
  // high, the clear line knowing only what the lidar sensed. The hull then needs only the trunks' own columns
  // (skyGuardHull). On 60 frames of every terrain type, seeds 38-41 (fresh), it took the objects too high from 10.21
  // to 9.25 a run and the trees at their real height from 508 to 526, with the same object-cell
  // MAE (8.82 m), terrain cells raised and buildings at height; a frame 31.6 -> 33.7 ms median
  // (urban seed 29). In a dense forest the hull's upper voxels are seen only through other crowns
  // (foliage in every image), and a trunk there keeps its estimate.
  bool guard_estimates = true;
  double guard_cell = 1.0;  // [m] the width and height of the guard's hull voxels (skyGuardHull)
  // A crown that runs off the top of the image (a tall tree near the drive: the cameras look up to
  // 45.5 degrees) has its top above the image's top row, so the ray through that row over the
  // trunk bounds the top from below. With cut_off_tops such a frame gives a bound sample (the
  // crown's runs checked as for a sample, from the first run bounded on both sides: near the
  // camera the crown may fill the image's width at the top), and a trunk whose samples give no
  // crown is raised to the cut_off_quantile of its bound samples' tops when it has min_samples of
  // them from cameras min_baseline apart (verdict raised_to_bound). Before, such frames gave
  // nothing (too_short): on 60 frames of seeds 11 and 12 of every terrain type a third of the tree
  // error lay under 36 trees, most 18-25 m tall beside the drive, cut off in nearly every frame.
  // There it took the object-cell error from 10.32 to 9.61 m (flat 8.46 -> 7.75, slope 12.52 ->
  // 10.95, rough 9.90 -> 9.54, forest 11.71 -> 11.18, mixed 8.99 -> 7.93 m; urban 10.35 -> 10.33),
  // with the same terrain cells raised and one more tree too high (forest: a 10.7 m tree raised
  // to 12.7 m by a taller crown behind it in its column); 11 trees were raised to their bound, all
  // but that one below their true top. Before the runs were taken from the first bounded one, the
  // highest bound (quantile 1) rather than the median took the error on flat, forest, mixed and
  // slope from 9.80 to 9.74 m, with one more tree too high (flat). A bound sample's radius is not
  // bound by the crown's depth (max_width_to_depth): the crown is deeper than the image shows. That
  // took seeds 11-12 from 9.61 to 9.15 m (flat 7.75 -> 6.26, urban 10.33 -> 9.72, forest 11.18 ->
  // 10.65 m), with the same terrain cells raised and trees too high; seeds 19-20 did not move.
  bool cut_off_tops = true;
  double cut_off_quantile = 0.5;
  // The crown's radius is this quantile of its samples' radii (of the agreeing group, or of the
  // bound samples): a run widened by a crown beside it errs only upwards, one cut short by a
  // nearer object downwards. The lower quartile (0.25) until the radii were measured at the trunk
  // (acrossVertical) rather than as pixels times depth / fx, which widened crowns off the optical
  // axis: with that, on 60 frames of every terrain type, the median took the object-cell MAE from
  // the lower quartile's before 8.13 -> 7.85 m on seeds 50 and 51, 8.06 -> 7.36 m on seeds 55 and
  // 56 and 9.47 -> 9.24 m on seeds 57 and 58 (fresh), the terrain cells raised by mistake 198.9 ->
  // 129.8, 204.9 -> 190.7 and 351.8 -> 384.7 a run; 0.75 gave 7.59 and 6.80 m with 148.2 and 304.0
  // cells on the first two (docs/results.md, 2026-12-07, seventh part).
  double radius_quantile = 0.5;
  // Where the agreeing group's radii agree with each other (their interquartile range within
  // radius_agreement of their median) and its cameras lie agreement_bearings apart as seen from
  // the trunk, the crown's radius is their median instead: runs cut short by something nearer, or
  // widened by a crown behind, do not repeat from views that far apart. 0: off. With the median as
  // radius_quantile it changes nothing; it was measured with the lower quartile: on 60 frames of
  // every terrain type, seeds 50 and 51 (fresh), it took the object-cell MAE from 8.20 to 8.13 m
  // (within 60 m 8.19 -> 8.08) with the same terrain cells raised on every run and one more tree at
  // its height; seeds 52 and 53 (checked after) 7.48 -> 7.45 m, 4 more terrain cells raised over
  // the 12 runs, no run's MAE higher. Without the bearings (0), seeds 50 and 51 gave 8.13 m with
  // 9 % more terrain raised; at 20 degrees hardly a tree qualifies (8.19 m).
  double radius_agreement = 0.3;
  double agreement_bearings = 0.17;  // [rad] (10 degrees)
  // The axis's ceiling: a sky pixel's ray meets nothing, so where one crosses the vertical through a
  // trunk the tree stands lower. Each image gives the lowest rising ray over the trunk's top whose
  // pixels on the vertical's image are sky for ceiling_halfwidth on either side of the vertical (the
  // trunk's position is known to a cell, and a crown's apex is narrow); the min_samples-th lowest
  // over the run bounds the trunk's vertices and its crown's cap from above. Unlike the guard's
  // hull (guard_estimates) it needs no voxel that two rays passed, and reaches a trunk anywhere
  // crowns are measured.
  bool axis_ceiling = true;
  double ceiling_halfwidth = 0.5;  // [m]
  // Column samples: a frame whose crown another joined (off_centre, nearer_trunk, unbounded) still
  // shows the crown's column up to its highest foliage pixel over the trunk, and what joins it there
  // (a crown behind or before) only lifts it. Such a frame gives a column sample where the crown's
  // apex is centred over the vertical (the runs of the top metre's rows within max_offcentre) and
  // its foot lies column_min_bare above the lidar's top on the trunk (where the lidar reached the
  // crown, what stands over it in the column may be another's). A trunk whose samples give no crown
  // takes its top from the lowest agreeing group of all its samples, column samples among them
  // (verdict raised_from_columns), its radius the column_radius_quantile of the group's radii.
  // Off by default: on 60 frames of every terrain type it took the object-cell MAE 8.13 -> 7.81 m on
  // seeds 50 and 51 and 8.07 -> 8.03 m on seeds 55 and 56 (fresh), trees at their height 366 -> 380
  // and 369 -> 375, but the terrain cells raised by mistake 198.9 -> 203.8 and 204.9 -> 277.1 a run
  // (mixed 56: 65 -> 370, its MAE 8.99 -> 9.13 m); with the radius quantile at 0.25, 7.78 and 7.92 m,
  // 204.5 and 367.6 cells (docs/results.md, 2026-12-07, sixth part).
  bool column_tops = false;
  double column_min_bare = 1.0;       // [m] bare trunk between the lidar's top on it and the crown's foot
  double column_radius_quantile = 0;  // of the group's radii (a run a crown joined errs upwards)
  // A tree whose crown's underside the lidar reached is one object wider than a trunk; standing
  // nearer the camera in a trunk's column, its trunk passes for the bare trunk climbed and its crown
  // for the crown (forest 57 tree_154, 8.1 m, took seven samples of 62-67 m from tree_196's capsule
  // crown 17 m from the camera). With grown_owners such an object (no wider than max_grown_width,
  // and farther than that from the trunk: nearer, it may be the trunk's own crown underside) owns a
  // run as a nearer trunk does, and the walk goes on above it. On 60 frames of every terrain type,
  // seeds 50, 51 and 55-58, it took the terrain cells raised by mistake from 235.1 to 187.9 a run
  // and the objects too high from 6.00 to 5.81 a run, the object-cell MAE 8.15 -> 8.14 m; without
  // the distance, mixed 55 tree_049 lost 18 of its 22 samples to its own underside (6.38 -> 9.66 m).
  bool grown_owners = true;
  // A trunk's own estimates (boundary estimation's, from the top edge seen over it) stand no higher
  // than the cap its crown's samples give (verdict raised: the samples bound the top from above):
  // where the edge over a thin trunk was a taller crown's behind it, which the clear line does not
  // know, the trunk is lowered to its cap. On 60 frames of every terrain type, seeds 50, 51 and
  // 55-58, it took the objects too high from 5.81 to 5.67 a run and the trees at their height from
  // 1,061 to 1,064, with the same mean object-cell MAE (8.14 m; rough 57 8.03 -> 8.10 m the most a
  // run rose) and terrain cells raised (docs/results.md, 2026-12-07, ninth part).
  bool cap_bounds_trunk = true;
  // A crown's runs often end above its widest row (a crown behind joins them there), and the half
  // width kept is then the narrower width of the crown's upper part. With ellipse_radius the crown's
  // outline on the vertical plane through the trunk is taken for an ellipse whose vertical axis runs
  // from the crown's top to its lowest pixel on the vertical: each run kept at a depth q of the
  // half axis below the top (ellipse_min_depth <= q <= 2 - ellipse_min_depth; near the apex a pixel
  // of width is much of the run) gives the radius w / sqrt(1 - (1 - q)^2), and the sample's radius
  // is the median of those when it is larger than the widest run's (still bound by
  // max_width_to_depth and max_radius). On 60 frames of every terrain type it took the object-cell
  // MAE 7.85 -> 7.72 m on seeds 50 and 51 and 8.29 -> 8.10 m on seeds 55-58 (no run higher), the
  // terrain cells raised 121.8 -> 129.9 and 220.9 -> 230.4 a run; with cap_bounds_trunk on fresh
  // seeds 60 and 61, 7.16 -> 7.06 m, 248.2 -> 249.0 cells and objects too high 5.67 -> 5.42 a run.
  bool ellipse_radius = true;
  // of the crown's vertical half axis, below its top; on seeds 50 and 51, 0.15 / 0.3 / 0.5 gave
  // MAE 7.65 / 7.72 / 7.77 m with 146.1 / 129.9 / 124.1 terrain cells raised a run
  double ellipse_min_depth = 0.3;
};

// A trunk-sized object of the mesh: where it stands and how high the lidar saw it.
struct Trunk {
  std::uint32_t key = 0;  // its lowest vertex id
  std::int32_t object = -1;
  Eigen::Vector2d centre;  // [m] mean of its cell centres
  double top = 0;          // [m] highest sensed height
  CellIndex lo, hi;        // its cells' bounds
};
// Raises a vertex without estimates of its own to height h under a crown (MeshVertex::spread)
// unless it stands that high already; true when it was not raised before.
inline bool raiseUnderCrown(MeshVertex& m, float h) {
  if (h <= m.sensed_height || (m.spread && m.recovered_height >= h)) return false;
  const bool fresh = !m.spread;
  m.spread = true;
  m.recovered_height = h;
  return fresh;
}
// The objects no wider than max_width [m] either way, in object order.
std::vector<Trunk> findTrunks(const TerrainMesh& mesh, const VoxelMap& map, const MeshObjects& objects,
                              double max_width);
// Is the trunk's object no wider than width [m] either way (cells of `cell` m)?
bool fitsWithin(const Trunk& t, double width, double cell);
// The height [m] of the lowest ground vertex within 1 m of the trunk; +inf if there is none.
double groundAround(const Trunk& t, const TerrainMesh& mesh, const VoxelMap& map);
// Does the trunk stand at least min_height above the ground around it (groundAround)? (Yes when
// there is no ground there to compare with.)
bool standsAboveGround(const Trunk& t, double ground, double min_height);

// Parses "foliage"/"sky"; false if unknown.
bool parseCrownCue(const std::string& s, CrownConfig::Cue& out);

// What a frame made of a trunk in its image: a crown sample, or the reason it gave none.
enum class CrownOutcome : std::uint8_t {
  Measured,        // a sample
  NoCrown,         // no crown pixel above the bare trunk within max_trunk_gap
  TooShort,        // the crown cut off by the image top, or fewer than min_height_px rows
  Unbounded,       // no run bounded by non-crown pixels on both sides
  OffCentre,       // the widest run centred away from the trunk (max_offcentre)
  NearerTrunk,     // another trunk stands under the run nearer its centre
  Implausible,     // the top not above the trunk, or the radius past max_radius
  NotClear,        // another object may own the crown's top pixel (clear-line test)
  NotAboveGround,  // the trunk does not stand min_trunk_height above its ground
  CutOff,          // a bound sample: the crown cut off by the image top (cut_off_tops)
};
constexpr std::size_t kCrownOutcomes = 10;
// What the end of the run made of a trunk's samples.
enum class CrownVerdict : std::uint8_t {
  NotApplied,         // not judged (the run did not end, or the trunk is no longer one nor an object
                      // within the crown's radius of it)
  TooFewSamples,      // fewer than min_samples
  NoBaseline,         // the samples' cameras within min_baseline of each other
  Sunk,               // the trunk no longer stands min_trunk_height above its ground
  Disagree,           // no group of samples within max_top_spread of each other has min_samples seen from min_baseline
  TooNarrow,          // the radius below min_radius
  Raised,             // the ground under its crown raised
  RaisedToBound,      // no crown from its samples; the ground under it raised to its bound samples' top
  RaisedFromColumns,  // no crown from its samples alone; raised to the lowest agreeing group of them
                      // and its column samples (CrownConfig::column_tops)
};
// names in reports: measured, no_crown, too_short, unbounded, off_centre, nearer_trunk,
// implausible, not_clear, not_above_ground, cut_off; not_applied, too_few_samples, no_baseline,
// sunk, disagree, too_narrow, raised, raised_to_bound, raised_from_columns
const char* outcomeName(CrownOutcome outcome);
const char* verdictName(CrownVerdict verdict);

// A trunk's record over the run: where it stands, frames per outcome (saturating at 65535) and the
// verdict on its samples.
struct CrownRecord {
  std::uint32_t key = 0;                             // the trunk's lowest vertex id
  Eigen::Vector2f centre = Eigen::Vector2f::Zero();  // [m] where it stood when last seen
  std::array<std::uint16_t, kCrownOutcomes> outcomes{};
  CrownVerdict verdict = CrownVerdict::NotApplied;
};

// The crown samples of the trunks, gathered frame by frame.
class CrownSampler {
 public:
  // One frame: rgb (CV_8UC3, RGB), the camera pose at the image time. Sky is judged with the sky
  // test of boundary estimation (its sky_blue_margin and sky_min_brightness); with its clear_line on,
  // a crown top that another sensed object may own (SkylineOwners, up to its max_distance) gives no
  // sample. owners: the mesh's objects over at least viewRegion(intrinsics, world_from_camera,
  // ownersReach()), their tops up to date (SkylineOwners::refreshTops after this frame's estimates);
  // nullptr: built here. Returns the number of crowns measured.
  int measure(const TerrainMesh& mesh, const VoxelMap& map, const cv::Mat& rgb, const CameraIntrinsics& intrinsics,
              const Pose& world_from_camera, const CrownConfig& config, const BoundaryEstimationConfig& estimation,
              const SkylineOwners* owners = nullptr);
  // [m] the reach of the SkylineOwners that measure() uses: a trunk within max_distance and the far
  // side of its crown
  static double ownersReach(const CrownConfig& config, const BoundaryEstimationConfig& estimation);

  // At the end of the run: raises the ground vertices under each trunk with min_samples samples
  // (MeshVertex::spread, as spreadEstimates does). Returns the number of vertices raised. A trunk
  // whose object changed as the map grew (another lowest vertex) left samples under its old key:
  // samples go to the trunk of their key, else to the trunk nearest where they were taken, within
  // 1 m, else to the object with a vertex nearest there, within 1 m: a trunk grown past
  // max_grown_width (the lidar reached the crown's underside), which takes them only if all of it
  // lies within the crown's radius (+0.5 m) of where the trunk was seen, and then raises its own
  // vertices under the cap as well.
  // Sets each trunk record's verdict.
  // sky_through(x, y, lo, hi): did the sky show through the point (x, y) [m] at every height in
  // [lo, hi] [m] (CrownHull::skyThrough)? With config.sky_guard such a vertex is not raised.
  using SkyThrough = std::function<bool(double x, double y, double lo, double hi)>;
  int apply(TerrainMesh& mesh, const VoxelMap& map, const CrownConfig& config, const SkyThrough& sky_through = {});

  // trunks with samples
  std::size_t trunks() const { return samples_.size(); }
  // raised trunk vertices the axis's ceiling lowered in the last apply()
  int loweredByCeiling() const { return lowered_; }
  // trunk vertices whose own estimates the cap of their crown lowered in the last apply()
  // (CrownConfig::cap_bounds_trunk)
  int loweredByCap() const { return lowered_by_cap_; }
  // every trunk a frame looked at, by key
  std::vector<CrownRecord> records() const;
  // Replaces the records (a saved run read back); the samples stay as they are.
  void restoreRecords(const std::vector<CrownRecord>& records);

 private:
  struct Sample {
    float top = 0;           // [m] crown top height
    float radius = 0;        // [m]
    Eigen::Vector2f camera;  // [m] where the camera was (x, y)
    Eigen::Vector2f trunk;   // [m] where the trunk stood (x, y)
    bool bound = false;      // the crown cut off by the image top: `top` bounds it from below
    bool column = false;     // a column sample (CrownConfig::column_tops): `top` bounds it from above
  };
  std::unordered_map<std::uint32_t, std::vector<Sample>> samples_;  // by the trunk's lowest vertex id
  std::unordered_map<std::uint32_t, std::vector<Sample>> columns_;  // column samples, by the same key
  std::unordered_map<std::uint32_t, CrownRecord> records_;          // by the same key
  std::unordered_map<std::uint32_t, std::vector<float>> ceilings_;  // [m] the axis's ceilings, by the same key
  int lowered_ = 0;
  int lowered_by_cap_ = 0;
};

}  // namespace terrain
