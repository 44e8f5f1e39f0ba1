#include "sim/hfield_ray.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::sim {

namespace {

// ray-triangle intersection (Moller-Trumbore), distance or -1; edges count as inside
double rayTriangle(const double a[3], const double b[3], const double c[3], const double p[3], const double v[3]) {
  const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double h[3] = {v[1] * e2[2] - v[2] * e2[1], v[2] * e2[0] - v[0] * e2[2], v[0] * e2[1] - v[1] * e2[0]};
  const double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
  if (std::abs(det) < 1e-15) return -1;
  const double inv = 1.0 / det;
  const double s[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  const double u = inv * (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]);
  if (u < 0 || u > 1) return -1;
  const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
  const double w = inv * (v[0] * q[0] + v[1] * q[1] + v[2] * q[2]);
  if (w < 0 || u + w > 1) return -1;
  const double t = inv * (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]);
  return t >= 0 ? t : -1;
}

// slab test of a local axis-aligned box; entry/exit distances, false if missed
bool slab(const double lo[3], const double hi[3], const double p[3], const double v[3], double& t0, double& t1) {
  t0 = 0;
  t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (v[a] == 0) {
      if (p[a] < lo[a] || p[a] > hi[a]) return false;
      continue;
    }
    double n = (lo[a] - p[a]) / v[a], f = (hi[a] - p[a]) / v[a];
    if (n > f) std::swap(n, f);
    t0 = std::max(t0, n);
    t1 = std::min(t1, f);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

double rayHfield(const mjModel* m, const mjData* d, int id, const mjtNum pnt[3], const mjtNum vec[3]) {
  const int hid = m->geom_dataid[id];
  const int nrow = m->hfield_nrow[hid], ncol = m->hfield_ncol[hid];
  const mjtNum* size = m->hfield_size + 4 * hid;
  const float* data = m->hfield_data + m->hfield_adr[hid];
  const mjtNum* pos = d->geom_xpos + 3 * id;
  const mjtNum* mat = d->geom_xmat + 9 * id;

  // base box below the grid, as MuJoCo has it
  const mjtNum base_size[3] = {size[0], size[1], size[3] * 0.5};
  const mjtNum base_pos[3] = {pos[0] - mat[2] * size[3] * 0.5, pos[1] - mat[5] * size[3] * 0.5,
                              pos[2] - mat[8] * size[3] * 0.5};
  double x = mju_rayGeom(base_pos, mat, base_size, pnt, vec, mjGEOM_BOX);

  // the ray in the geom's frame
  double lp[3], lv[3];
  const double dif[3] = {pnt[0] - pos[0], pnt[1] - pos[1], pnt[2] - pos[2]};
  for (int i = 0; i < 3; ++i) {
    lp[i] = mat[i] * dif[0] + mat[3 + i] * dif[1] + mat[6 + i] * dif[2];
    lv[i] = mat[i] * vec[0] + mat[3 + i] * vec[1] + mat[6 + i] * vec[2];
  }
  // the part of the ray inside the top box
  const double lo[3] = {-size[0], -size[1], 0}, hi[3] = {size[0], size[1], size[2]};
  double t_in, t_out;
  if (!slab(lo, hi, lp, lv, t_in, t_out)) return x;
  if (x >= 0 && x < t_in) return x;

  const double dx = 2.0 * size[0] / (ncol - 1), dy = 2.0 * size[1] / (nrow - 1);
  auto vertex = [&](int r, int c, double out[3]) {
    out[0] = dx * c - size[0];
    out[1] = dy * r - size[1];
    out[2] = data[r * ncol + c] * size[2];
  };
  // walk the cells under the segment in order (2D DDA over the grid)
  const double sx = (lp[0] + t_in * lv[0] + size[0]) / dx, sy = (lp[1] + t_in * lv[1] + size[1]) / dy;
  int c = std::clamp(static_cast<int>(std::floor(sx)), 0, ncol - 2);
  int r = std::clamp(static_cast<int>(std::floor(sy)), 0, nrow - 2);
  const int step_c = lv[0] > 0 ? 1 : -1, step_r = lv[1] > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double delta_c = lv[0] != 0 ? dx / std::abs(lv[0]) : inf, delta_r = lv[1] != 0 ? dy / std::abs(lv[1]) : inf;
  double next_c = lv[0] != 0 ? ((c + (step_c > 0 ? 1 : 0)) * dx - size[0] - lp[0]) / lv[0] : inf;
  double next_r = lv[1] != 0 ? ((r + (step_r > 0 ? 1 : 0)) * dy - size[1] - lp[1]) / lv[1] : inf;
  double cell_entry = t_in;
  while (true) {
    // a hit nearer than this cell's entry cannot be improved on by this or later cells
    if (x >= 0 && x < cell_entry - 1e-9) break;
    const double cell_exit = std::min(next_c, next_r);
    // test this cell and its neighbours across the edges the ray runs close to, unless the ray
    // stays above all of their vertices while it passes over this cell (a lidar ray over terrain,
    // nearly every cell it passes)
    const double z_low = lp[2] + std::min(cell_entry * lv[2], std::min(cell_exit, t_out) * lv[2]);
    float top = -std::numeric_limits<float>::infinity();
    const int r0 = std::max(0, r - 1), r1 = std::min(nrow - 1, r + 2), c0 = std::max(0, c - 1),
              c1 = std::min(ncol - 1, c + 2);
    for (int rr = r0; rr <= r1; ++rr) {
      for (int cc = c0; cc <= c1; ++cc) top = std::max(top, data[rr * ncol + cc]);
    }
    const bool above = z_low > top * size[2] + 1e-9 * (1.0 + size[2]);
    for (int rr = std::max(0, r - 1); !above && rr <= std::min(nrow - 2, r + 1); ++rr) {
      for (int cc = std::max(0, c - 1); cc <= std::min(ncol - 2, c + 1); ++cc) {
        if (rr != r && cc != c) continue;
        double v00[3], v11[3], v01[3], v10[3];
        vertex(rr, cc, v00);
        vertex(rr + 1, cc + 1, v11);
        vertex(rr, cc + 1, v01);
        vertex(rr + 1, cc, v10);
        for (const double* third : {v01, v10}) {
          const double t = rayTriangle(v00, v11, third, lp, lv);
          if (t >= 0 && (x < 0 || t < x)) x = t;
        }
      }
    }
    if (cell_exit >= t_out) break;
    if (next_c < next_r) {
      c += step_c;
      next_c += delta_c;
    } else {
      r += step_r;
      next_r += delta_r;
    }
    if (c < 0 || c > ncol - 2 || r < 0 || r > nrow - 2) break;
    cell_entry = cell_exit;
  }

  // the side walls of the top box, below the grid's edge profile
  for (int i = 0; i < 4; ++i) {
    const int axis = i < 2 ? 0 : 1;
    const double plane = (i % 2 == 0 ? -1.0 : 1.0) * size[axis];
    if (lv[axis] == 0) continue;
    const double t = (plane - lp[axis]) / lv[axis];
    if (t < 0) continue;
    const double p[3] = {lp[0] + t * lv[0], lp[1] + t * lv[1], lp[2] + t * lv[2]};
    const int other = 1 - axis;
    if (std::abs(p[other]) > size[other] || p[2] < 0 || p[2] > size[2]) continue;
    if (!(x < 0 || t < x)) continue;
    const double z = p[2] / size[2];
    double y, y0, z0, z1;
    if (axis == 0) {
      y = (p[1] + size[1]) / dy;
      y0 = std::max(0.0, std::min(nrow - 2.0, std::floor(y)));
      const int col = i == 1 ? ncol - 1 : 0;
      z0 = data[static_cast<int>(std::lround(y0)) * ncol + col];
      z1 = data[static_cast<int>(std::lround(y0 + 1)) * ncol + col];
    } else {
      y = (p[0] + size[0]) / dx;
      y0 = std::max(0.0, std::min(ncol - 2.0, std::floor(y)));
      const int row = i == 3 ? nrow - 1 : 0;
      z0 = data[static_cast<int>(std::lround(y0)) + row * ncol];
      z1 = data[static_cast<int>(std::lround(y0 + 1)) + row * ncol];
    }
    if (z < z0 * (y0 + 1 - y) + z1 * (y - y0)) x = t;
  }
  return x;
}

double heightAboveGeoms(const mjModel* m, const mjData* d) {
  double top = 0;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_type[g] == mjGEOM_PLANE) continue;
    top = std::max(top, d->geom_xpos[3 * g + 2] + m->geom_rbound[g]);
  }
  return top + 10.0;
}

double terrainHeightAt(const mjModel* m, const mjData* d, int terrain_geom, double from, double x, double y) {
  const mjtNum pnt[3] = {x, y, from}, down[3] = {0, 0, -1};
  const int type = m->geom_type[terrain_geom];
  const mjtNum dist = type == mjGEOM_HFIELD
                          ? rayHfield(m, d, terrain_geom, pnt, down)
                          : mju_rayGeom(d->geom_xpos + 3 * terrain_geom, d->geom_xmat + 9 * terrain_geom,
                                        m->geom_size + 3 * terrain_geom, pnt, down, type);
  return dist < 0 ? std::numeric_limits<double>::quiet_NaN() : from - dist;
}

}  // namespace terrain::sim
