#pragma once
// Pinhole projection and inverse projection (paper Eqs. 7-8).

#include "core/sensor_data.hpp"

#include <optional>

namespace terrain {

// Pixel position of a point given in the camera frame (x right, y down, z forward); nullopt if
// the point is not in front of the camera (z <= min_depth) or falls outside the image.
inline std::optional<Pixel> project(const CameraIntrinsics& k, const Point3& p, double min_depth = 0.1) {
  if (!(p.z() > min_depth)) return std::nullopt;
  const Pixel px(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy);
  if (px.x() < 0 || px.y() < 0 || px.x() >= k.width || px.y() >= k.height) return std::nullopt;
  return px;
}

// Direction (camera frame, z = 1) of the ray through an image position.
inline Vector3 pixelRay(const CameraIntrinsics& k, const Pixel& px) {
  return {(px.x() - k.cx) / k.fx, (px.y() - k.cy) / k.fy, 1.0};
}

// Eqs. 7-8: the height [m] at which the ray centre + lambda * dir (world frame, lambda > 0) passes
// the vertical line through (x, y); uses the horizontal coordinates as the paper's ratio
// y1' = y'' z1 / z'' does, in the least-squares sense. NaN if the ray is vertical or points away.
inline double heightAbove(const Point3& centre, const Vector3& dir, double x, double y) {
  const double h2 = dir.x() * dir.x() + dir.y() * dir.y();
  if (h2 < 1e-12) return std::numeric_limits<double>::quiet_NaN();
  const double lambda = ((x - centre.x()) * dir.x() + (y - centre.y()) * dir.y()) / h2;
  if (!(lambda > 0)) return std::numeric_limits<double>::quiet_NaN();
  return centre.z() + lambda * dir.z();
}

}  // namespace terrain
