#pragma once
// A MuJoCo world of the user's made into a testbed scene: the world as it is, plus what the
// simulated rig needs and the world lacks (a skybox; the robot body with its camera), and the truth
// sidecar derived from its geoms. Geoms are classed by their names (then their material's, then
// their body's) against patterns; objects are the geoms of one class in one body whose outlines
// touch, a tree being a crown with the trunks that stand under it; the terrain is the plane or
// heightfield geom. The path is given, or the straight line along x nearest the terrain's middle
// with room to spare.

#include "scenes/scene_truth.hpp"
#include "sim/scene_checks.hpp"

#include <Eigen/Core>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace terrain::sim {

struct ImportOptions {
  // class -> name patterns (case-insensitive substrings); classes: building, crown, trunk, terrain
  std::map<std::string, std::vector<std::string>> patterns = {
      {"building", {"build", "bldg", "house", "hall", "tower", "shed", "garage", "facade", "roof"}},
      {"crown", {"crown", "leaf", "leaves", "foliage", "canopy", "bush", "tree"}},
      {"trunk", {"trunk", "bark", "stem"}},
      {"terrain", {"ground", "terrain", "floor", "heightfield", "hfield"}},
  };
  std::vector<Eigen::Vector2d> path;  // [m] waypoints; empty: found
  GeodeticOrigin origin{0, 0, 0};     // where the world origin lies (latitude, longitude [deg], altitude [m])
  double clearance = kPathClearance;  // [m] the least room between the robot's side and an object
};

struct ImportedScene {
  std::string mjcf;  // the scene's MJCF text
  scenes::SceneTruth truth;
  std::vector<std::string> added;         // what was added to the world ("a skybox", ...)
  std::vector<std::string> unclassified;  // geoms no pattern matched (unnamed ones by id and body)
  double path_clearance = 0;              // [m] from the path's line to the nearest object footprint
};

// Reads `world` (MJCF, compiled by MuJoCo to place every geom), classes its geoms and derives the
// scene. `out` is where the scene will be written: asset files the world names stay where they
// are, so it must lie in the world's folder when the world names any. Throws io::InputError naming
// the file: a world MuJoCo refuses, no terrain geom, a given path with a point outside the terrain
// or no straight path with room found, patterns of an unknown class, out in another folder.
ImportedScene importScene(const std::filesystem::path& world, const std::filesystem::path& out,
                          const ImportOptions& options);

// Reads class patterns from YAML: a map of class (building, crown, trunk, terrain) to a list of
// patterns, each replacing that class's defaults. Throws io::InputError naming the file and line.
void loadImportPatterns(const std::filesystem::path& path, ImportOptions& options);

}  // namespace terrain::sim
