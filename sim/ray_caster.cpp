#include "sim/ray_caster.hpp"

#include "sim/hfield_ray.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace terrain::sim {

namespace {

// geoms mj_ray would never report: excluded body, invisible geom or material
bool eliminated(const mjModel* m, int g, int bodyexclude) {
  if (m->geom_bodyid[g] == bodyexclude) return true;
  const int mat = m->geom_matid[g];
  if (mat < 0 && m->geom_rgba[4 * g + 3] == 0) return true;
  if (mat >= 0 && m->mat_rgba[4 * mat + 3] == 0) return true;
  return false;
}

// Half the edges of an axis-aligned box about geom g's centre that encloses it: its own box
// rotated into the world for the primitive shapes (a cylinder's box holds it, a capsule's adds its
// caps), the bounding sphere's for meshes and anything else. A building's sphere box is far looser
// than its walls: every ray near the building would be tested against it.
Eigen::Vector3d halfExtent(const mjModel* m, const mjData* d, int g) {
  const mjtNum* size = m->geom_size + 3 * g;
  Eigen::Vector3d local;
  switch (m->geom_type[g]) {
    case mjGEOM_BOX:
    case mjGEOM_ELLIPSOID:
      local = Eigen::Vector3d(size[0], size[1], size[2]);
      break;
    case mjGEOM_SPHERE:
      local = Eigen::Vector3d::Constant(size[0]);
      break;
    case mjGEOM_CYLINDER:
      local = Eigen::Vector3d(size[0], size[0], size[1]);
      break;
    case mjGEOM_CAPSULE:
      local = Eigen::Vector3d(size[0], size[0], size[1] + size[0]);
      break;
    default:
      return Eigen::Vector3d::Constant(m->geom_rbound[g]);
  }
  // geom_xmat is row-major world_from_geom: the box's extent along world axis i is
  // sum_j |R_ij| local_j
  Eigen::Vector3d half;
  for (int i = 0; i < 3; ++i) {
    half[i] = 0;
    for (int j = 0; j < 3; ++j) half[i] += std::abs(d->geom_xmat[9 * g + 3 * i + j]) * local[j];
  }
  // never looser than the sphere
  return half.cwiseMin(Eigen::Vector3d::Constant(m->geom_rbound[g]));
}

// entry distance of the ray into a box, or +inf if it misses it within [0, tmax]
double slab(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& p, const Eigen::Vector3d& inv,
            double tmax) {
  double t0 = 0, t1 = tmax;
  for (int a = 0; a < 3; ++a) {
    double n = (lo[a] - p[a]) * inv[a], f = (hi[a] - p[a]) * inv[a];
    if (n > f) std::swap(n, f);
    // NaN (0 * inf) arises only when the ray lies in a slab plane: treat as inside
    if (n == n) t0 = std::max(t0, n);
    if (f == f) t1 = std::min(t1, f);
    if (t0 > t1) return std::numeric_limits<double>::infinity();
  }
  return t0;
}

}  // namespace

RayCaster::RayCaster(const mjModel* m, const mjData* d, int bodyexclude) : m_(m), d_(d), bodyexclude_(bodyexclude) {
  for (int g = 0; g < m->ngeom; ++g) {
    if (eliminated(m, g, bodyexclude)) continue;
    const int type = m->geom_type[g];
    if (type == mjGEOM_PLANE || type == mjGEOM_HFIELD) {
      unbounded_.push_back(g);
      continue;
    }
    const Eigen::Vector3d c(d->geom_xpos[3 * g], d->geom_xpos[3 * g + 1], d->geom_xpos[3 * g + 2]);
    const Eigen::Vector3d half = halfExtent(m, d, g) * (1 + 1e-9) + Eigen::Vector3d::Constant(1e-9);
    order_.push_back(g);
    box_lo_.push_back(c - half);
    box_hi_.push_back(c + half);
  }
  if (!order_.empty()) {
    nodes_.reserve(2 * order_.size());
    build(0, static_cast<int>(order_.size()));
  }
}

// median split on the longest axis of the centroids' extent
int RayCaster::build(int first, int count) {
  Node node;
  node.lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  node.hi = -node.lo;
  Eigen::Vector3d clo = node.lo, chi = node.hi;
  for (int i = first; i < first + count; ++i) {
    node.lo = node.lo.cwiseMin(box_lo_[i]);
    node.hi = node.hi.cwiseMax(box_hi_[i]);
    const Eigen::Vector3d c = 0.5 * (box_lo_[i] + box_hi_[i]);
    clo = clo.cwiseMin(c);
    chi = chi.cwiseMax(c);
  }
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(node);
  if (count <= 4) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  int axis = 0;
  (chi - clo).maxCoeff(&axis);
  // sort the range by centroid along the axis, keeping order_ and the boxes together
  std::vector<int> idx(count);
  std::iota(idx.begin(), idx.end(), first);
  std::sort(idx.begin(), idx.end(), [&](int a, int b) {
    const double ca = box_lo_[a][axis] + box_hi_[a][axis], cb = box_lo_[b][axis] + box_hi_[b][axis];
    return ca < cb || (ca == cb && order_[a] < order_[b]);
  });
  std::vector<int> o(count);
  std::vector<Eigen::Vector3d> lo(count), hi(count);
  for (int k = 0; k < count; ++k) o[k] = order_[idx[k]], lo[k] = box_lo_[idx[k]], hi[k] = box_hi_[idx[k]];
  for (int k = 0; k < count; ++k) order_[first + k] = o[k], box_lo_[first + k] = lo[k], box_hi_[first + k] = hi[k];
  const int half = count / 2;
  const int left = build(first, half);
  const int right = build(first + half, count - half);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

double RayCaster::castGeom(int g, const mjtNum* pnt, const mjtNum* vec) const {
  switch (m_->geom_type[g]) {
    case mjGEOM_MESH:
      return mj_rayMesh(m_, d_, g, pnt, vec);
    case mjGEOM_HFIELD:
      return rayHfield(m_, d_, g, pnt, vec);
    default:
      return mju_rayGeom(d_->geom_xpos + 3 * g, d_->geom_xmat + 9 * g, m_->geom_size + 3 * g, pnt, vec,
                         m_->geom_type[g]);
  }
}

RayHit RayCaster::cast(const Eigen::Vector3d& p, const Eigen::Vector3d& v) const {
  const mjtNum pnt[3] = {p.x(), p.y(), p.z()}, vec[3] = {v.x(), v.y(), v.z()};
  RayHit best;
  // mj_ray keeps the first strictly nearer hit in geom order: ties go to the lower geom id
  auto offer = [&](int g) {
    const double t = castGeom(g, pnt, vec);
    if (t >= 0 && (best.distance < 0 || t < best.distance || (t == best.distance && g < best.geom))) {
      best.distance = t;
      best.geom = g;
    }
  };
  for (int g : unbounded_) offer(g);
  if (nodes_.empty()) return best;
  const Eigen::Vector3d inv = v.cwiseInverse();
  int stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    const double limit = best.distance < 0 ? std::numeric_limits<double>::infinity() : best.distance;
    if (slab(n.lo, n.hi, p, inv, limit) == std::numeric_limits<double>::infinity()) continue;
    if (n.count > 0) {
      for (int k = n.first; k < n.first + n.count; ++k) {
        const double lim = best.distance < 0 ? std::numeric_limits<double>::infinity() : best.distance;
        if (slab(box_lo_[k], box_hi_[k], p, inv, lim) != std::numeric_limits<double>::infinity()) offer(order_[k]);
      }
      continue;
    }
    // visit the nearer child first
    const double dl = slab(nodes_[n.left].lo, nodes_[n.left].hi, p, inv, limit);
    const double dr = slab(nodes_[n.right].lo, nodes_[n.right].hi, p, inv, limit);
    if (dl <= dr) {
      stack[top++] = n.right;
      stack[top++] = n.left;
    } else {
      stack[top++] = n.left;
      stack[top++] = n.right;
    }
  }
  return best;
}

RayHit RayCaster::castReference(const Eigen::Vector3d& p, const Eigen::Vector3d& v) const {
  const mjtNum pnt[3] = {p.x(), p.y(), p.z()}, vec[3] = {v.x(), v.y(), v.z()};
  RayHit h;
  h.distance = mj_ray(m_, d_, pnt, vec, nullptr, 1, bodyexclude_, &h.geom);
  if (h.distance < 0) h.geom = -1;
  return h;
}

}  // namespace terrain::sim
