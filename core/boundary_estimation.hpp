#pragma once
// Stage 6, 3D boundary estimation (paper Sec. 4.2): non-ground mesh vertices are projected into
// the camera image; above each, the topmost boundary pixel of the object is searched in the
// boundary image; its inverse projection (Eqs. 7-8) at the vertex's fixed (x, y) gives the true
// height, and the vertex is raised. Estimates from later frames are kept and fused (median), so
// the shape is refined as the robot moves on (paper Fig. 14b).

#include "core/boundary_detection.hpp"
#include "core/sensor_data.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"

#include <opencv2/core/matx.hpp>

namespace terrain {

struct BoundaryEstimationConfig {
  // [m] vertices farther from the camera are not estimated; the clear-line test reaches as far. 130
  // rather than 100 (since the search along the vertical): over 12 scenes at 60 frames 5 more
  // objects at their real height (buildings 42 -> 45 of 69, trees 114 -> 116 of 332, the 6 trees
  // lost all in forest 1), terrain cells raised by mistake on rough 149 -> 18, slope 144 -> 108,
  // forest 2 316 -> 272, but urban 3 1 -> 22; estimation takes about twice as long (3.6 -> 7.7 ms
  // a frame on urban seed 1, two runs sharing the machine).
  double max_distance = 130.0;
  double max_height = 60.0;        // [m] above the sensed top: larger estimates are rejected
  int top_margin = 2;              // [px] a boundary this close to the image top may be cut: skipped
  std::size_t max_estimates = 15;  // estimates kept per vertex
  // The fused height is this quantile of the kept estimates. With sky just above the top boundary
  // (require_sky_above) an estimate bounds the vertex's height from above: were the object taller
  // there, the pixel above would show it, not sky; the estimate is too high where an object behind
  // forms the skyline. A low quantile keeps the tighter bounds, and a quarter of the estimates must
  // be low before a stray one (a column grazing past the object's side) sets the height. On 60
  // frames (urban seeds 1-3, forest, mixed, flat) the lower quartile rather than the median took the
  // error over estimated cells from 3.73 / 3.58 / 5.70 / 11.93 / 1.52 / 0.79 m to
  // 3.64 / 3.53 / 5.54 / 11.60 / 1.50 / 0.75 m (0.1: 3.60 / 3.35 / 5.40 / 11.40 / 1.48 / 0.75);
  // the large errors left are taller objects behind in every view of the drive.
  double fusion_quantile = 0.25;
  // Skip a frame's estimate for a vertex when another object the lidar saw stands in the same image
  // column, in front of the vertex or behind it up to max_distance, unless that object is known
  // (from its own estimates) to be lower than the pixel's ray where the ray passes it: the topmost
  // boundary may be that object's top (a tree before a taller building, a second row of buildings,
  // a bump of rough ground taken for an object). On 30 frames of each terrain type (seed 1) this
  // cut the terrain cells raised more than 1 m from 1926 to 8 (slope), 8427 to 24 (rough), 243 to 13
  // (mixed), at the cost of fewer object cells raised.
  bool clear_line = true;
  // Accept a top boundary only if the pixels just above it look like daylight sky (blue at least
  // sky_blue_margin grey levels above red and not below green, mean brightness >= sky_min_brightness):
  // an object that runs off the top of the image has more of itself above its topmost edge (a
  // facade's horizontal texture edge was taken for its roof line: roofs at half height). Measured on
  // 60 frames (seed 1-3 urban, seed 1 flat, mixed, forest): roof height error of completed
  // footprints 3.4 / 5.0 / 7.6 m -> 1.6 / 0.8 / 5.9 m on urban, 0.5 -> 0.7 flat, 1.6 -> 2.0 mixed;
  // error over estimated forest cells 10.5 -> 11.9 m. The colour test suits a clear daytime sky:
  // under overcast or at dusk check the thresholds against the camera, or turn it off.
  // With the sky test on, a vertex whose own pixel is not sky is also skipped when, going up its
  // vertical, an edge to sky that passes the sky test comes more than 6 px below the topmost
  // boundary: the object ends there, and the boundary above is something else's (a crown that
  // overhangs it or stands behind it, as around many far crowns in a forest). On 60 frames of 12
  // scenes (urban seeds 1-5, forest 1-2, mixed 1-2, flat, slope, rough) the trees at their real
  // height went from 116 to 123 of 332 and those too high from 34 to 23 (7 raised 6-52 m too high
  // now stand at their height, none lost: forest 1 13 -> 16 of 96, forest 2 30 -> 32 of 101,
  // urban 3 10 -> 12 of 20), buildings unchanged (45 of 69); the terrain cells raised by mistake
  // 1042 -> 895, the error over estimated cells urban 1 1.75 -> 1.43 m, urban 3 3.49 -> 1.90 m,
  // forest 1 6.47 -> 5.50 m, forest 2 8.34 -> 5.98 m, urban 5 2.37 -> 2.43 m; boundary coverage
  // within 0.01 of before.
  bool require_sky_above = true;
  int sky_blue_margin = 10;
  int sky_min_brightness = 100;
  // Crown tops by their foliage (beyond the paper). The topmost boundary above a vertex of a tree
  // crown that the lidar saw part of is the skyline behind the tree when a building or a taller
  // tree stands there, and without sky just above the crown's top the sky test rejects it. A vertex
  // takes as its top the end of the foliage run above its own pixel instead, with no sky test, when
  //  - its object shows foliage: at least half of its top voxels that the camera coloured are
  //    foliage-coloured (green at least foliage_margin grey levels above both red and blue);
  //  - its pixel is foliage;
  //  - it stands at least 1 m above the lowest voxel of its column: the ground the lidar saw under
  //    the crown (a patch of grass labelled non-ground has none, and its foliage run would climb
  //    the hillside behind it).
  // For the clear-line test only objects that may carry a crown (foliage objects, and trunk-sized
  // ones: 1.5 m across at most) may then own the pixel. A run that reaches top_margin is cut off.
  bool foliage_tops = true;
  int foliage_margin = 10;  // [grey levels]
  // Vertices of an object that never got an estimate of their own (the camera never saw their
  // column's top) take the recovered height of the nearest estimated vertex reachable through
  // neighbouring non-ground vertices, up to spread_distance away; 0 turns this off.
  double spread_distance = 0.0;  // [m]
  // Parallax test (beyond the paper). A top edge above the vertex back-projects to the same height
  // from every viewpoint; an edge a gap g behind it, at height H, gives c + (H - c) d / (d + g) from
  // a camera at height c and horizontal distance d, which falls as the camera nears: its slope b
  // over d is (h - c) g / (d (d + g)), so g = e d / (1 - e) with e = b d / (h - c). Once a vertex
  // holds 5 estimates, their heights' least-squares slope over the distances they were made from
  // may not exceed parallax_slope while predicting more than parallax_change across those
  // distances, with an implied gap (at the mean d and h - c) between parallax_min_gap and
  // parallax_max_gap; a vertex that fails does not count as estimated until its latest estimates
  // pass (MeshVertex::parallax). A building of 13.5 m whose walls faced the camera in front of one of
  // 35 m (urban seed 1) got wall estimates of 15-28 m, falling by 0.2-0.3 m per metre driven (gaps
  // of 15-20 m). The gap's bounds keep what is not a second object: a wall's sensed cells a little
  // in front of its roof edge (on a 40 m building, urban seed 4), and slopes steeper than any gap
  // explains (the camera's pose noise; implied gaps of 228 m and more on urban seed 1).
  // An edge a gap g in front of the vertex (an object nearer the camera that the lidar did not see
  // up there: a tree's crown, whose trunk is thinner than the ray's column) gives
  // c + (H - c) d / (d - g), which rises as the camera nears: slope -(h - c) g / (d (d - g)), so
  // g = e d / (1 + e) with e = -b d / (h - c); the same bounds apply. On urban seed 3 the walls of a
  // 21 m building 96-100 m away had estimates rising from 43 to 51 m over 9 m of driving, the top
  // edge of a tree's crown 30 m from the camera (gap 68 m); their roof stood at 49 m. Either way the
  // slope must also be at least parallax_min_t standard errors (of the least-squares line through
  // the estimates): on rough ground the pitching camera made slopes of -0.4 to -3.6 m/m over 1-3 m
  // of driving at 77 m, 1-9 standard errors, against 20 and more for the crown's edge.
  // A vertex with fewer estimates than the test needs is held back at the end of the run when, of the
  // non-ground vertices within 1 m that have enough, more are held back than not
  // (holdBackYoungVertices): a wall's last vertices, sensed as the robot neared, saw the same edge.
  // parallax_slope 0 turns the test off.
  double parallax_slope = 0.2;      // [m of height per m of distance]
  double parallax_change = 0.3;     // [m]
  double parallax_min_gap = 2.0;    // [m]
  double parallax_max_gap = 100.0;  // [m]
  double parallax_min_t = 8.0;      // [standard errors of the slope]
  // At the end of a run (holdBackYoungVertices, with the parallax test on), a vertex of an object
  // that shows foliage (as for foliage_tops) is also held back while it has fewer estimates than
  // the parallax test needs: crowns stand before and behind other crowns and buildings, and the
  // topmost edge above a crown's vertex is often one of theirs, which only the test can tell. On 60
  // frames of 12 scenes (urban seeds 1-5, forest 1-2, mixed 1-2, flat, slope, rough) the trees too
  // high went from 23 to 16 (forest 1 11 -> 5: an 8.2 m tree had been raised to 28.1 m), those at
  // their real height stayed 133 of 332 (forest 1 19 -> 21, mixed 1 8 -> 7, urban 3 12 -> 11) and
  // the buildings 50 of 69 (7 too high); terrain cells raised by mistake 932 -> 703; the error over
  // estimated cells forest 1 5.50 -> 4.56 m, forest 2 6.04 -> 4.71 m, urban 2 0.71 -> 0.61 m, rough
  // 0.66 -> 2.89 m (part of a 21.8 m tree's crown held back: its top 21.6 -> 19.9 m); boundary
  // coverage forest 1 0.407 -> 0.383, urban 5 0.601 -> 0.583, urban 1 0.682 -> 0.694, the rest
  // within 0.015.
  bool hold_young_crowns = true;
};

// estimates a vertex needs before the parallax test can tell
constexpr std::size_t kParallaxEstimates = 5;

// The parallax test on a vertex's estimates (see BoundaryEstimationConfig::parallax_slope): true
// when they hold at least kParallaxEstimates estimates whose heights rise or fall with the distance
// they were made from by more than `slope` per metre, by more than `change` across those distances
// and by at least min_t standard errors of the slope, as an edge between min_gap and max_gap behind
// the vertex (rising with distance) or in front of it (falling) would make them.
bool showsParallax(const std::vector<HeightEstimate>& estimates, double slope, double change, double min_gap,
                   double max_gap, double min_t);

// The sky test's colour rule for one RGB colour: daylight sky is blue at least blue_margin grey
// levels above red and not below green, with a mean brightness of at least min_brightness.
bool looksLikeSky(const cv::Vec3b& rgb, int blue_margin, int min_brightness);

// The objects the lidar saw: 8-connected groups of mesh vertices whose top voxel is non-ground,
// numbered in the order of their lowest vertex id. With a region (world x, y [m]), only the
// objects with a vertex whose cell centre lies in it, whole (also where they reach beyond it),
// numbered in the order of their lowest vertex id in the region.
struct MeshObjects {
  std::vector<std::int32_t> of;        // per vertex: its object, -1 for a ground vertex or one left out
  std::int32_t count = 0;              // objects
  std::vector<std::uint32_t> members;  // the vertices of the objects found (of >= 0), in no set order
};
MeshObjects findMeshObjects(const TerrainMesh& mesh, const VoxelMap& map, const Eigen::AlignedBox2d* region = nullptr);

// Which sensed object may own a skyline pixel (clear_line): the objects of the mesh in an area around
// the camera on a grid of grid_size [m] cells, with each object's known top (its highest recovered
// height; unknown, +inf, before any estimate). Only the area is gridded (cells aligned with the
// mesh's lowest corner; an area over 100 km across grids nothing), and only the objects with a
// vertex in it are found: apart from one pass over the vertices' cells, the cost follows the area,
// not the map's size. The area a frame needs is the camera's view up to the rays' reach:
// viewRegion(intrinsics, pose, reach).
class SkylineOwners {
 public:
  SkylineOwners(const TerrainMesh& mesh, const VoxelMap& map, const Eigen::AlignedBox2d& area, double grid_size = 1.0);
  // the square of half-width reach [m] around centre
  SkylineOwners(const TerrainMesh& mesh, const VoxelMap& map, const Eigen::Vector2d& centre, double reach,
                double grid_size = 1.0);
  const MeshObjects& objects() const { return objects_; }
  // Takes each object's known top again from the mesh's recovered heights (after estimates were
  // added); the objects and the grid stay as they are.
  void refreshTops(const TerrainMesh& mesh);
  // Could the pixel whose ray (origin o, direction dir, world frame), followed up to `range` metres
  // horizontally, belong to an object other than `own`? It could where the ray, outside the disc
  // (centre, radius [m]), passes over a grid cell of another object (or of several) whose top is not
  // at least `margin` [m] below the ray there. Beyond the gridded area the ray passes nothing.
  // candidates: per object, whether it could own such a pixel at all (nullptr: every object); a
  // grid cell shared by several objects counts as one that could.
  bool otherMayOwn(const Point3& o, const Vector3& dir, double range, std::int32_t own, const Eigen::Vector2d& centre,
                   double radius, double margin, const std::vector<char>* candidates = nullptr) const;

 private:
  static constexpr std::int32_t kEmpty = -1, kMixed = -2;
  std::size_t index(double x, double y) const;
  MeshObjects objects_;
  std::vector<double> tops_;
  double size_ = 1.0, x0_ = 0, y0_ = 0;
  int nx_ = 0, ny_ = 0;
  std::vector<std::int32_t> cells_;  // per grid cell: the object there, kEmpty or kMixed
};

struct BoundaryEstimationStats {
  int projected = 0;   // non-ground vertices that fell inside the image
  int estimated = 0;   // of which received a height estimate
  int no_sky = 0;      // of which were skipped: no sky above their top boundary
  int not_clear = 0;   // of which were skipped: another object in their column (clear_line)
  int by_foliage = 0;  // of the estimated, those whose top is the end of their crown's foliage (foliage_tops)
  int ends_below = 0;  // of which were skipped: their pixels end against sky below their top boundary
};

// One frame: camera pose world_from_camera at the image time, the cleaned boundary image.
// rgb: the camera image (CV_8UC3, RGB) for the sky test and the foliage tops; may be empty (neither).
// owners: the objects in view for the clear-line test and the foliage tops, made for this mesh over
// at least viewRegion(intrinsics, world_from_camera, max_distance) (a caller that needs them too
// builds them once); nullptr: built here. Only the vertices in that view region are looked at
// further than their cell.
BoundaryEstimationStats estimateBoundaries(TerrainMesh& mesh, const VoxelMap& map, const cv::Mat& boundary,
                                           const CameraIntrinsics& intrinsics, const Pose& world_from_camera,
                                           const BoundaryEstimationConfig& config, const cv::Mat& rgb = cv::Mat(),
                                           const SkylineOwners* owners = nullptr);

// Spreads recovered heights over the rest of each object (config.spread_distance): a breadth-first
// walk from every estimated non-ground vertex through 4-neighbouring non-ground vertices; each
// vertex without estimates takes the height of the nearest one (ties: the lower vertex id).
// Returns the number of vertices that took a height.
int spreadEstimates(TerrainMesh& mesh, const VoxelMap& map, const BoundaryEstimationConfig& config);

// At the end of a run: a vertex with too few estimates for the parallax test (fewer than 5) is held
// back too when, of the non-ground vertices within 1 m that have enough, more show parallax than do
// not: they saw the same edges; and, with config.hold_young_crowns, when its object shows foliage.
// Nothing is held back with the parallax test off. Returns the number of vertices held back.
int holdBackYoungVertices(TerrainMesh& mesh, const VoxelMap& map, const BoundaryEstimationConfig& config);

}  // namespace terrain
