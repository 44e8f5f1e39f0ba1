#pragma once
// Stage 6b, footprint completion (beyond the paper): the lidar senses a building's walls, never its
// roof, so after 3D boundary estimation a building is a raised outline with no vertices inside. When
// the walls of one object trace two adjacent sides of a rectangle (the robot has seen a corner: the
// facade along its path and an end wall), the building's footprint is that rectangle, and its roof
// stands at the height boundary estimation recovered for the walls. Only objects that fit the
// rectangle closely are completed: nearly all their cells on its outline, and no sensed ground or
// other object inside it (the lidar cannot see into a closed building, so something sensed inside
// means the rectangle is wrong). A single straight wall gives no footprint: its depth is unknown.

#include "core/boundary_estimation.hpp"
#include "core/terrain_mesh.hpp"
#include "core/voxel_map.hpp"

#include <array>
#include <vector>

namespace terrain {

struct FootprintConfig {
  bool enabled = true;
  double min_side = 2.0;  // [m] a footprint narrower than this is not completed
  // [m] an object's cell this close to the rectangle's outline is on it. Walls seen over a long drive
  // thicken (a heading error of a few tenths of a degree shifts a wall 20 m away by 0.1 m): 1000
  // frames of urban seed 1 completed 1 footprint at 0.5 m, 4 at 1.0 m and 8 at 1.5 m; on 60 frames
  // (urban 1-3, flat, mixed, forest, slope, rough seed 1) 1.0 m completed 3 more on mixed (roof
  // error 1.9 -> 1.0 m) and changed nothing else, while 1.5 m filled 542 cells of terrain on slope.
  double wall_tolerance = 1.0;
  double min_wall_share = 0.95;  // share of the object's cells that must lie on the outline
  // [m] for min_wall_share, an object's cells this close to the outline are on it: wider than
  // wall_tolerance, which also bounds the rectangle's inside and the sides' support. Over 1000
  // frames of urban seed 1 the walls of five buildings thickened to 1.5 m, 9-12 % of their cells
  // lying 1.0-1.5 m in and none deeper (a wall, not a solid blob): 1.0 m completed 4 footprints.
  // The band reaches no deeper than a quarter of the rectangle's shorter side (nor less deep than
  // wall_tolerance): in a small rectangle a wide band takes in every cell (on 60 frames of forest 2
  // a 2.5 x 4 m cluster of trees was roofed at 36 m).
  double wall_band = 1.5;
  double min_side_support = 0.7;   // share of each of two adjacent sides that walls must cover
  double max_inside_share = 0.02;  // share of the cells inside that may be sensed (ground or another object)
  int min_raised = 5;              // wall vertices with their own height estimates needed for a roof height
  double min_raised_share = 0.1;   // and their share of the object's vertices
};

// A completed footprint: a rectangle in the world's x-y plane and its roof height.
struct Footprint {
  std::array<Eigen::Vector2d, 4> corners;  // [m] counter-clockwise
  float roof_height = 0;                   // [m] median recovered height of the object's raised walls
  std::int32_t object = -1;                // the MeshObjects id it completes
  int wall_vertices = 0;                   // the object's mesh vertices
  int raised_vertices = 0;                 // of which had estimates of their own
};

// The footprints of the mesh's objects, in object order. Empty when config.enabled is false.
std::vector<Footprint> completeFootprints(const TerrainMesh& mesh, const VoxelMap& map, const FootprintConfig& config);

// The walls of completed footprints (their object's vertices on the outline) that have no estimate
// of their own take the roof height, as spreadEstimates would (MeshVertex::spread). Returns the number of vertices
// raised so.
int roofWalls(TerrainMesh& mesh, const VoxelMap& map, const std::vector<Footprint>& footprints,
              const FootprintConfig& config);

// A cell the mesh has no vertex for, inside a footprint, at its roof height [m].
struct RoofCell {
  CellIndex cell;
  float height = 0;
};

// The cells without a mesh vertex whose centre lies inside a footprint, sorted by cell (y, then x);
// where footprints overlap, the higher roof.
std::vector<RoofCell> roofCells(const std::vector<Footprint>& footprints, const TerrainMesh& mesh, double cell_size);

}  // namespace terrain
