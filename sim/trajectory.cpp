#include "sim/trajectory.hpp"

#include "rig/file_io.hpp"

#include <algorithm>
#include <cmath>

namespace terrain::sim {

Trajectory::Trajectory(const World& world, const std::vector<Eigen::Vector2d>& waypoints, const RobotConfig& robot)
    : world_(world), robot_(robot) {
  if (waypoints.size() < 2) throw io::InputError("the robot's path needs at least two waypoints");
  points_.push_back(waypoints.front());
  points_.insert(points_.end(), waypoints.begin(), waypoints.end());
  points_.push_back(waypoints.back());
  // arc length table, 400 steps per segment
  const int segments = static_cast<int>(waypoints.size()) - 1;
  table_.push_back({0.0, 0.0});
  Eigen::Vector2d prev = position(0.0);
  for (int k = 1; k <= segments * 400; ++k) {
    const double u = k / 400.0;
    const Eigen::Vector2d p = position(u);
    table_.push_back({u, table_.back().s + (p - prev).norm()});
    prev = p;
  }
}

// uniform Catmull-Rom through points_[i+1] .. points_[i+2] for u in [i, i+1]
Eigen::Vector2d Trajectory::position(double u) const {
  const int segments = static_cast<int>(points_.size()) - 3;
  const int i = std::clamp(static_cast<int>(std::floor(u)), 0, segments - 1);
  const double t = u - i;
  const Eigen::Vector2d &p0 = points_[i], &p1 = points_[i + 1], &p2 = points_[i + 2], &p3 = points_[i + 3];
  return 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t * t +
                (-p0 + 3 * p1 - 3 * p2 + p3) * t * t * t);
}

Eigen::Vector2d Trajectory::tangent(double u) const {
  const int segments = static_cast<int>(points_.size()) - 3;
  const int i = std::clamp(static_cast<int>(std::floor(u)), 0, segments - 1);
  const double t = u - i;
  const Eigen::Vector2d &p0 = points_[i], &p1 = points_[i + 1], &p2 = points_[i + 2], &p3 = points_[i + 3];
  return 0.5 * ((-p0 + p2) + 2 * (2 * p0 - 5 * p1 + 4 * p2 - p3) * t + 3 * (-p0 + 3 * p1 - 3 * p2 + p3) * t * t);
}

double Trajectory::terrain(double x, double y) const {
  const double h = world_.terrainHeight(x, y);
  return std::isnan(h) ? 0.0 : h;
}

Pose Trajectory::worldFromVehicle(double t) const {
  const double s = std::clamp(robot_.speed * std::max(0.0, t), 0.0, length());
  // arc length -> spline parameter
  auto it = std::lower_bound(table_.begin(), table_.end(), s, [](const Sample& a, double v) { return a.s < v; });
  double u = table_.back().u;
  if (it == table_.begin()) {
    u = 0;
  } else if (it != table_.end()) {
    const Sample& b = *it;
    const Sample& a = *(it - 1);
    u = a.u + (b.u - a.u) * (s - a.s) / std::max(1e-12, b.s - a.s);
  }
  const Eigen::Vector2d c = position(u);
  Eigen::Vector2d f2 = tangent(u);
  if (f2.norm() < 1e-9) f2 = points_[points_.size() - 2] - points_[1];
  f2.normalize();
  const Eigen::Vector2d l2(-f2.y(), f2.x());
  // the body rests on four contact points: forward and left axes follow the terrain
  const double hw = 0.5 * robot_.wheelbase, ht = 0.5 * robot_.track;
  const double zf = terrain(c.x() + hw * f2.x(), c.y() + hw * f2.y());
  const double zb = terrain(c.x() - hw * f2.x(), c.y() - hw * f2.y());
  const double zl = terrain(c.x() + ht * l2.x(), c.y() + ht * l2.y());
  const double zr = terrain(c.x() - ht * l2.x(), c.y() - ht * l2.y());
  const Vector3 fwd = Vector3(robot_.wheelbase * f2.x(), robot_.wheelbase * f2.y(), zf - zb).normalized();
  Vector3 left = Vector3(robot_.track * l2.x(), robot_.track * l2.y(), zl - zr);
  const Vector3 up = fwd.cross(left).normalized();
  left = up.cross(fwd);
  Pose p = Pose::Identity();
  p.linear().col(0) = fwd;
  p.linear().col(1) = left;
  p.linear().col(2) = up;
  p.translation() = Vector3(c.x(), c.y(), 0.25 * (zf + zb + zl + zr));
  return p;
}

}  // namespace terrain::sim
