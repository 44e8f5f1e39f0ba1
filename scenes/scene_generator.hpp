#pragma once
// Procedural scenes: terrain of a chosen type with buildings and trees, written as MJCF with a
// ground-truth sidecar. The same type and seed always give byte-identical files.

#include "scenes/scene_truth.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace terrain::scenes {

// The terrain types the generator knows, in the order they are listed to users.
const std::vector<std::string>& sceneTypes();

struct SceneConfig {
  std::string type = "urban";  // one of sceneTypes()
  std::uint64_t seed = 1;
  double extent = 80.0;                            // [m] half side of the square scene area
  double hfield_cell = 0.5;                        // [m] heightfield grid spacing
  GeodeticOrigin origin{37.5585, 126.9990, 60.0};  // world ENU origin (Seoul, near the paper's lab)
};

struct GeneratedScene {
  std::string mjcf;          // MJCF text
  std::string hfield_bytes;  // MuJoCo binary heightfield (empty for a plane)
  SceneTruth truth;
};

// Builds a scene. Throws io::InputError for an unknown type or an out-of-range parameter.
GeneratedScene generateScene(const SceneConfig& config);

// Writes FILE.xml, FILE.truth.json and (for a heightfield) FILE.hfield next to it. Refuses to
// replace existing files unless overwrite is true; throws io::InputError.
void writeScene(const GeneratedScene& scene, const std::filesystem::path& xml_path, bool overwrite);

}  // namespace terrain::scenes
