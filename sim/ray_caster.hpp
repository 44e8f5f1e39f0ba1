#pragma once
// Ray casting against a MuJoCo world with mj_ray's semantics (same geom, same distance), but
// with a bounding volume hierarchy over the bounded geoms so that a ray only tests the geoms it
// can reach. Planes and heightfields are tested for every ray, as in mj_ray. Thread-safe: the
// caster and the world are only read.

#include <mujoco/mujoco.h>

#include <Eigen/Core>

#include <vector>

namespace terrain::sim {

struct RayHit {
  double distance = -1;  // [units of the direction vector's length]; -1: no hit
  int geom = -1;         // geom id; -1: no hit
};

class RayCaster {
 public:
  // Builds the hierarchy for the geoms of (m, d) as they are now. Geoms of bodyexclude (-1: none)
  // and invisible geoms are left out, as mj_ray does; geom groups are not used.
  RayCaster(const mjModel* m, const mjData* d, int bodyexclude);

  // Nearest hit along pnt + x * vec, x >= 0.
  RayHit cast(const Eigen::Vector3d& pnt, const Eigen::Vector3d& vec) const;

  // The same query answered by MuJoCo's own mj_ray (the reference).
  RayHit castReference(const Eigen::Vector3d& pnt, const Eigen::Vector3d& vec) const;

 private:
  struct Node {
    Eigen::Vector3d lo, hi;    // bounding box
    int first = 0, count = 0;  // leaf: range in order_; inner: count == 0
    int left = -1, right = -1;
  };

  int build(int first, int count);
  double castGeom(int geom, const mjtNum* pnt, const mjtNum* vec) const;

  const mjModel* m_;
  const mjData* d_;
  int bodyexclude_;
  std::vector<int> unbounded_;                    // planes and heightfields
  std::vector<int> order_;                        // bounded geoms, ordered by the hierarchy
  std::vector<Eigen::Vector3d> box_lo_, box_hi_;  // per entry of order_
  std::vector<Node> nodes_;
};

}  // namespace terrain::sim
