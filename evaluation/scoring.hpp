#pragma once
// Scores of a reconstruction against the scene's ground truth.

#include "core/footprint_completion.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"
#include "evaluation/ground_truth.hpp"
#include "evaluation/metrics.hpp"

#include <array>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace terrain::eval {

struct SegmentationScores {
  BinaryScores scores;
  std::size_t unmatched = 0;  // voxels of the map with no truth (no true point fell in them)
};

// Scores per voxel of a labelling (ground[i] for map voxel i) against the voxel truth.
SegmentationScores scoreVoxels(const VoxelMap& map, const std::vector<std::uint8_t>& ground, const VoxelTruth& truth);

// An object's top as the mesh shows it: the 95th percentile of the heights of the cells whose true
// top is the object (mesh vertices, and for the recovered top also the roof cells of completed
// footprints), so that a few stray cells neither make nor break it.
struct ObjectTop {
  bool building = false;                                     // else a tree
  double base = 0, top = 0;                                  // [m] true world z of the object's base and highest point
  double sensed = std::numeric_limits<double>::quiet_NaN();  // [m] sensed heights only
  double recovered = std::numeric_limits<double>::quiet_NaN();  // [m] after recovery
  std::size_t cells = 0;  // mesh vertices and roof cells whose true top is the object
  // boundary estimation's outcomes over the object's mesh vertices: vertex-frames per outcome
  std::array<std::uint64_t, kEstimateOutcomes> outcomes{};
};

// The tolerance [m] within which a recovered top counts as the object's real height: 10 % of its
// height above its base, at least 1 m.
double topTolerance(const ObjectTop& t);

struct HeightScores {
  ErrorStats before, after;  // over object cells: sensed-only heights, then after recovery
  std::map<std::string, std::pair<ErrorStats, ErrorStats>> by_band;    // "0-30", "30-60", "60-100" [m]
  std::map<std::string, std::pair<ErrorStats, ErrorStats>> by_object;  // object id
  std::map<std::string, std::size_t> in_view_by_object;  // object id -> its cells whose sensed top the camera saw
  std::map<std::string, std::pair<ErrorStats, ErrorStats>> by_kind;  // "building", "tree" (trunk or crown on top)
  // object cells whose sensed top is the terrain under the object (ground under a tree crown):
  // their vertex is ground, so boundary estimation, which raises non-ground vertices, cannot reach them
  std::size_t sensed_as_terrain = 0;
  ErrorStats seen_before, seen_after;  // object cells that received at least one estimate
  // object cells by whether the camera ever saw their sensed top (its voxel took a colour from an
  // image; the true top above may lie outside the image): "in_camera_view", "never_in_camera_view",
  // and per kind ("building_in_camera_view", ...); the method can only raise cells it saw
  std::map<std::string, std::pair<ErrorStats, ErrorStats>> by_view;
  std::map<std::string, std::size_t> raised_by_view;  // of those cells, how many were raised
  // cells raised more than 1 m above their true top although terrain is their true top: away from
  // any object (no object surface within 0.5 m), and on an object's edge (a wall or crown within
  // 0.5 m: the cell took the object's points through a small pose or beam error)
  std::size_t raised_terrain_cells = 0;
  // of those, the cells whose vertex the segmentation labelled ground (raised by crown completion)
  std::size_t raised_terrain_ground_cells = 0;
  std::size_t raised_edge_cells = 0;
  std::map<std::string, ObjectTop> tops;  // object id -> its top, for the objects with cells
};

// Height errors of the mesh vertices over cells where an object is the true top. robot_path: the
// true robot positions, for the distance bands (distance of a cell to the nearest of them). roof:
// the roof cells of completed footprints, which join the objects' recovered tops.
HeightScores scoreHeights(const TerrainMesh& mesh, const VoxelMap& map, const sim::World& world,
                          const std::vector<Point3>& robot_path, const std::vector<RoofCell>& roof = {});

// Roof cells of completed building footprints (cells the mesh has no vertex for) against the truth:
// on an object's cell the error of the roof height; elsewhere the cell was filled wrongly.
struct RoofScores {
  std::size_t cells = 0;           // roof cells with a known truth
  std::size_t object_cells = 0;    // of which an object is the true top
  std::size_t building_cells = 0;  // of which a building
  std::size_t wrongly_filled = 0;  // of which terrain is the true top
  ErrorStats on_objects;           // roof height - true top over object_cells [m]
};
RoofScores scoreRoofCells(const std::vector<RoofCell>& roof, double voxel_size, const sim::World& world);

// The true building a completed footprint stands on: the building whose surface is the top of most
// points of the footprint (on a grid of `step` [m]), its top height, and the intersection over union
// of the two footprints. object is empty when no building is under it.
struct FootprintMatch {
  std::string object;
  double true_top = 0;  // [m]
  double iou = 0;
};
FootprintMatch matchFootprint(const Footprint& footprint, const sim::World& world, double step);

// The height map's baselines against the true tops of the object cells in the mapped area (every
// second cell each way): the sensed heights alone, the sensed heights inpainted (Telea, radius 10
// cells), and the recovered heights (mesh vertices, then the roof cells of completed footprints).
// Each error is over the object cells the map has a height for, its coverage the share of object
// cells that have one. A mesh wider than kMaxHeightMapCells cells is not scored.
struct HeightMapError {
  ErrorStats error;
  double coverage = 0;
};
struct HeightBaselineScores {
  enum class Status { NoMesh, TooWide, Scored } status = Status::NoMesh;
  std::int64_t span = 0;  // [cells] the mesh's extent (its larger side)
  HeightMapError sensed_only, inpainting, recovered;
  std::size_t object_cells = 0;
};
inline constexpr std::int64_t kMaxHeightMapCells = 4096;
HeightBaselineScores scoreHeightBaselines(const TerrainMesh& mesh, const std::vector<RoofCell>& roof, double voxel_size,
                                          const sim::World& world);

}  // namespace terrain::eval
