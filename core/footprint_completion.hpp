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
  double min_side = 2.0;           // [m] a footprint narrower than this is not completed
  double wall_tolerance = 0.5;     // [m] an object's cell this close to the rectangle's outline is on it
  double min_wall_share = 0.95;    // share of the object's cells that must lie on the outline
  double min_side_support = 0.7;   // share of each of two adjacent sides that walls must cover
  double max_inside_share = 0.02;  // share of the cells inside that may be sensed (ground or another object)
  int min_raised = 5;              // wall vertices with their own height estimates needed for a roof height
};

// A completed footprint: a rectangle in the world's x-y plane and its roof height.
struct Footprint {
  std::array<Eigen::Vector2d, 4> corners;  // [m] counter-clockwise
  float roof_height = 0;                   // [m] median recovered height of the object's raised walls
  std::int32_t object = -1;                // the MeshObjects id it completes
  int wall_vertices = 0;                   // the object's mesh vertices
  int raised_vertices = 0;                 // of which had estimates of their own
  double wall_tolerance = 0;               // [m] the object's cells this close to the outline are its walls
};

// The footprints of the mesh's objects, in object order. Empty when config.enabled is false.
std::vector<Footprint> completeFootprints(const TerrainMesh& mesh, const VoxelMap& map, const FootprintConfig& config);

// The walls of completed footprints (their object's vertices on the outline) that have no estimate
// of their own take the roof height, as spreadEstimates would (MeshVertex::spread). Returns the number of vertices raised so.
int roofWalls(TerrainMesh& mesh, const VoxelMap& map, const std::vector<Footprint>& footprints);

// A cell the mesh has no vertex for, inside a footprint, at its roof height [m].
struct RoofCell {
  CellIndex cell;
  float height = 0;
};

// The cells without a mesh vertex whose centre lies inside a footprint, sorted by cell (y, then x);
// where footprints overlap, the higher roof.
std::vector<RoofCell> roofCells(const std::vector<Footprint>& footprints, const TerrainMesh& mesh, double cell_size);

}  // namespace terrain
