#pragma once
// The interactive 3D view of report.html: the reconstruction's heights on a grid, before and after
// recovery and the true ones, the vertex colours, the robot's path and the camera positions, with
// the bundled viewer script (web/src/viewer.js and three.js) that draws them with WebGL.

#include "core/pipeline.hpp"
#include "evaluation/report.hpp"
#include "sim/world.hpp"

#include <cstddef>
#include <string>

namespace terrain::app {

// Grid points the view embeds at most: above it, the mesh is binned to a coarser grid.
constexpr std::size_t kViewVertexBudget = 160000;

// What the view embeds.
struct ViewGrid {
  double cell = 0;             // [m] grid step (a multiple of the voxel size)
  int step = 1;                // mesh cells per grid step either way
  std::size_t vertices = 0;    // grid points with a height after recovery
  std::size_t mesh_cells = 0;  // mesh vertices and roof cells they were binned from
};

// The view as an HTML section (a heading, the controls, the canvas holder, the data and the
// script); when the viewer script was not built, a paragraph saying so in its place. grid: what
// was embedded (may be null).
std::string reportView(const Pipeline& pipeline, const eval::RunTruth& truth, const sim::World& world,
                       ViewGrid* grid = nullptr);

}  // namespace terrain::app
