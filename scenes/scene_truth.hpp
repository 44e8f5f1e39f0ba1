#pragma once
// Ground truth of a generated scene: its objects, its terrain and the robot's path. Written as a
// JSON sidecar next to the MJCF file (FILE.truth.json). Only sim/ and evaluation/ read it.

#include "core/sensor_data.hpp"
#include "core/types.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace terrain::scenes {

// Semantic class of a geom. The numeric values are stored in datasets (PCD field "class").
enum class GeomClass : int { None = 0, Ground = 1, Building = 2, Trunk = 3, Crown = 4, Robot = 5 };

// Name of a class as written in files ("ground", "building", ...).
const char* className(GeomClass c);
// Class of a name; GeomClass::None if the name is unknown.
GeomClass classFromName(const std::string& name);
// True for classes that count as ground in segmentation scores.
inline bool isGroundClass(GeomClass c) { return c == GeomClass::Ground; }
// True for the parts of objects (buildings, trunks, crowns) whose heights are scored.
inline bool isObjectClass(GeomClass c) {
  return c == GeomClass::Building || c == GeomClass::Crown || c == GeomClass::Trunk;
}

struct ObjectTruth {
  std::string id;                            // "building_003", "tree_017"
  GeomClass object_class = GeomClass::None;  // Building, or Crown for trees
  std::vector<std::string> geoms;            // MJCF geom names that make up the object
  std::vector<Eigen::Vector2d> footprint;    // [m] world x, y polygon, counter-clockwise
  double base_height = 0;                    // [m] world z of the terrain at the object's base (lowest)
  double top_height = 0;                     // [m] world z of the object's highest point
};

struct TerrainTruth {
  std::string geom = "ground";  // MJCF name of the terrain geom
  std::string kind = "plane";   // "plane" or "hfield"
  // hfield only: file next to the MJCF, grid size and placement as in MJCF (row 0 at y = -size_y)
  std::string hfield_file;
  int nrow = 0, ncol = 0;
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();   // [m] geom position
  Eigen::Vector4d size = Eigen::Vector4d::Zero();  // [m] (half x, half y, z top, z bottom)
  std::vector<float> elevation;                    // normalised [0, 1], nrow x ncol, not serialised (read from file)
};

struct SceneTruth {
  std::string type;
  std::uint64_t seed = 0;
  GeodeticOrigin origin;
  TerrainTruth terrain;
  std::vector<ObjectTruth> objects;
  std::vector<Eigen::Vector2d> path;  // [m] world x, y waypoints of the robot's path
  double extent = 0;                  // [m] half side of the square scene area

  // Class of every named geom (terrain, object parts, robot parts).
  std::vector<std::pair<std::string, GeomClass>> geomClasses() const;
};

// Serialises truth as JSON text (stable key order, fixed formatting).
std::string truthToJson(const SceneTruth& truth);

// Reads and validates a truth sidecar. Throws io::InputError naming the file and the field.
SceneTruth loadTruth(const std::filesystem::path& path);

// Path of the sidecar that belongs to a scene file: "a/b.xml" -> "a/b.truth.json".
std::filesystem::path truthPathFor(const std::filesystem::path& scene_xml);

}  // namespace terrain::scenes
