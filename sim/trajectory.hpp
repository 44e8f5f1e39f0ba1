#pragma once
// The robot's true motion: it drives the scene's path (a Catmull-Rom spline through the
// waypoints) at constant speed, stops at its end, and its body rests on the terrain, so it
// pitches and rolls with the ground under its four contact points.

#include "core/types.hpp"
#include "sim/sim_config.hpp"
#include "sim/world.hpp"

#include <vector>

namespace terrain::sim {

class Trajectory {
 public:
  Trajectory(const World& world, const std::vector<Eigen::Vector2d>& waypoints, const RobotConfig& robot);

  // Vehicle pose at time t [s] (t < 0 is the start, past the end the robot stands still).
  Pose worldFromVehicle(double t) const;
  // Path length [m].
  double length() const { return table_.back().s; }

 private:
  struct Sample {
    double u;  // spline parameter: segment index + local parameter
    double s;  // arc length [m]
  };
  Eigen::Vector2d position(double u) const;
  Eigen::Vector2d tangent(double u) const;
  double terrain(double x, double y) const;

  const World& world_;
  std::vector<Eigen::Vector2d> points_;  // waypoints with the ends repeated
  std::vector<Sample> table_;
  RobotConfig robot_;
};

}  // namespace terrain::sim
