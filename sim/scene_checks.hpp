#pragma once
// What is wrong with a scene for the testbed, found before any simulation: a path with no terrain
// under it (an error), and what would make a run silently poor (warnings): no skybox (the sky
// renders black and boundary estimation's sky test rejects every top), a path through or within a
// metre of an object (the robot would drive into it; its sweeps lose whole sectors), nothing taller
// than the lidar's reach (nothing for the method to recover).

#include "sim/sim_config.hpp"
#include "sim/world.hpp"

#include <string>
#include <vector>

namespace terrain::sim {

// [m] half the robot's track, and the least room the checks want between its side and an object
constexpr double kRobotHalfWidth = 0.35;
constexpr double kPathClearance = 1.0;

struct SceneProblems {
  std::vector<std::string> errors;    // the scene cannot be simulated as it is
  std::vector<std::string> warnings;  // it can, but a run would tell little
};

// [m] from p to the polygon's outline (any orientation), 0 inside it.
double distanceToPolygon(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p);

// Checks the scene's path (sampled every 0.5 m) and objects against the rig of `config`.
SceneProblems checkScene(const World& world, const SimConfig& config);

}  // namespace terrain::sim
