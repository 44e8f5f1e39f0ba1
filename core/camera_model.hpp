#pragma once
// Pinhole projection and inverse projection (paper Eqs. 7-8).

#include "core/sensor_data.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <optional>
#include <utility>

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

// How far [m] from the vertical line through (x, y) the ray centre + lambda * dir (world frame,
// lambda > 0) passes it: the horizontal distance from the line to where the ray meets the vertical
// plane through it that faces the camera (its normal the horizontal direction from centre to (x, y)).
// A run of pixels beside the line's image measures an object's width there; off the optical axis
// the pinhole stretches it (by 1/cos of the angle off the axis: 1.27 at 38 degrees), and this undoes
// that. NaN if the ray runs parallel to the plane or away from it.
inline double acrossVertical(const Point3& centre, const Vector3& dir, double x, double y) {
  Eigen::Vector2d n(x - centre.x(), y - centre.y());
  const double range = n.norm();
  if (!(range > 1e-9)) return std::numeric_limits<double>::quiet_NaN();
  n /= range;
  const double along = n.dot(dir.head<2>());
  if (!(along > 1e-12)) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector2d meet = centre.head<2>() + (range / along) * dir.head<2>();
  return (meet - Eigen::Vector2d(x, y)).norm();
}

// The images of the world's vertical lines. The top of an object straight above a vertex lies on
// the image of the vertical through the vertex; with the camera pitched or rolled that is not the
// vertex's image column but a line through the vanishing point of the vertical (a camera pitched up
// 8 degrees puts it 2,200 px above a 640 x 480 image: 300 px off the image centre, 200 rows up, a
// column is about 26 px away from the vertical).
class Verticals {
 public:
  Verticals(const CameraIntrinsics& k, const Pose& world_from_camera) {
    // the world's up direction in the camera frame, and its image in homogeneous coordinates
    const Vector3 up = world_from_camera.linear().transpose() * Vector3(0, 0, 1);
    vanish_ = Vector3(k.fx * up.x() + k.cx * up.z(), k.fy * up.y() + k.cy * up.z(), up.z());
  }
  // The column [px] at `row` of the image of the vertical through image position px; px.x() where
  // that image is a row (the camera looking straight up or down the vertical's image line).
  double columnAt(const Pixel& px, double row) const {
    const double du = vanish_.x() - vanish_.z() * px.x(), dv = vanish_.y() - vanish_.z() * px.y();
    if (std::abs(dv) < 1e-12 * (std::abs(du) + 1e-300)) return px.x();
    return px.x() + (row - px.y()) * du / dv;
  }
  // The row [px] of the vanishing point of the vertical; +-inf where it lies at infinity (a level
  // camera: the verticals are the image columns).
  double vanishingRow() const {
    if (vanish_.z() == 0)
      return vanish_.y() < 0 ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return vanish_.y() / vanish_.z();
  }

 private:
  Vector3 vanish_;  // homogeneous image of the vertical's direction
};

// The horizontal area (world x, y [m]) of every point within `reach` metres horizontally of the
// camera that projects into its image: the bounding box of the circular sector the image spans in
// azimuth (the azimuths of a pinhole camera's view lie between those of its four corner rays), or
// the square of half-width reach around the camera where the view takes in the vertical (looking
// straight down or up) or half the horizon or more. Padded by `pad` [m].
inline Eigen::AlignedBox2d viewRegion(const CameraIntrinsics& k, const Pose& world_from_camera, double reach,
                                      double pad = 0.5) {
  const Eigen::Vector2d c = world_from_camera.translation().head<2>();
  const double r = reach + pad;
  const Eigen::AlignedBox2d square(c - Eigen::Vector2d(r, r), c + Eigen::Vector2d(r, r));
  const Pose camera_from_world = world_from_camera.inverse();
  for (const double z : {-1.0, 1.0}) {
    // the vertical, as a direction in the camera frame, inside the image (edges included)
    const Vector3 d = camera_from_world.linear() * Vector3(0, 0, z);
    if (d.z() <= 0) continue;
    const double u = k.fx * d.x() / d.z() + k.cx, v = k.fy * d.y() / d.z() + k.cy;
    if (u >= 0 && v >= 0 && u <= k.width && v <= k.height) return square;
  }
  const auto azimuth = [&](double u, double v) {
    const Vector3 d = world_from_camera.linear() * pixelRay(k, Pixel(u, v));
    return std::atan2(d.y(), d.x());
  };
  const double axis = azimuth(k.cx, k.cy);
  double lo = 0, hi = 0;  // relative to the optical axis's azimuth
  for (const auto& [u, v] : {std::pair<double, double>{0.0, 0.0},
                             {double(k.width), 0.0},
                             {0.0, double(k.height)},
                             {double(k.width), double(k.height)}}) {
    const double d = std::remainder(azimuth(u, v) - axis, 2 * M_PI);
    lo = std::min(lo, d), hi = std::max(hi, d);
  }
  if (!(hi - lo < M_PI)) return square;
  Eigen::AlignedBox2d box(c);
  box.extend(c + r * Eigen::Vector2d(std::cos(axis + lo), std::sin(axis + lo)));
  box.extend(c + r * Eigen::Vector2d(std::cos(axis + hi), std::sin(axis + hi)));
  // the compass directions the sector spans reach out to its arc
  for (int q = -4; q <= 4; ++q) {
    const double a = q * M_PI / 2;
    if (a >= axis + lo && a <= axis + hi) box.extend(c + r * Eigen::Vector2d(std::cos(a), std::sin(a)));
  }
  box.extend(c - Eigen::Vector2d(pad, pad));
  box.extend(c + Eigen::Vector2d(pad, pad));
  return box;
}

}  // namespace terrain
