#pragma once
// Ray against a MuJoCo heightfield geom, with mj_rayHfield's geometry (the base box under the
// grid, two triangles per grid cell split along the (c, r)-(c+1, r+1) diagonal, the side walls of
// the top box), but visiting only the cells the ray passes over, nearest first, and stopping at
// the first hit. MuJoCo tests every cell of the segment's bounding rectangle instead, which for a
// near-horizontal lidar ray is thousands of cells. Same distances to rounding (tested).

#include <mujoco/mujoco.h>

namespace terrain::sim {

// Distance along pnt + x * vec (x >= 0) to the heightfield geom `geom`, or -1 if none.
double rayHfield(const mjModel* m, const mjData* d, int geom, const mjtNum pnt[3], const mjtNum vec[3]);

// [m] a world height above every geom but planes (their highest bounding-sphere point + 10 m), for
// rays cast straight down.
double heightAboveGeoms(const mjModel* m, const mjData* d);

// [m] world z of the terrain geom (a plane or heightfield) under (x, y): a ray straight down from
// `from` against that geom alone; NaN where it misses (off a finite plane or the heightfield).
double terrainHeightAt(const mjModel* m, const mjData* d, int terrain_geom, double from, double x, double y);

}  // namespace terrain::sim
