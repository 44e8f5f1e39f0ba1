#pragma once
// The MuJoCo world: a generated scene loaded with its ground truth. Read-only after loading;
// every sensor takes what it needs from here.

#include "scenes/scene_truth.hpp"
#include "sim/ray_caster.hpp"

#include <mujoco/mujoco.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace terrain::sim {

class World {
 public:
  // Loads FILE.xml and FILE.truth.json. Throws io::InputError with MuJoCo's parse message (and
  // its line) for a malformed scene, or naming the missing geom for an inconsistent sidecar.
  explicit World(const std::filesystem::path& scene_xml);
  // Loads MJCF text with the given truth (tests use tiny inline scenes).
  World(const std::string& mjcf_text, scenes::SceneTruth truth);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  const mjModel* model() const { return model_; }
  const mjData* data() const { return data_; }
  const scenes::SceneTruth& truth() const { return truth_; }
  const std::filesystem::path& scenePath() const { return scene_path_; }

  // class of a geom id (GeomClass::None for -1 or unnamed geoms)
  scenes::GeomClass geomClass(int geom) const {
    return geom >= 0 && geom < static_cast<int>(classes_.size()) ? classes_[geom] : scenes::GeomClass::None;
  }
  // Geoms the truth gives no class (neither the terrain, an object's nor the robot's), by name
  // ("geom N" when unnamed): the evaluation scores them as neither ground nor object.
  std::vector<std::string> unclassifiedGeoms() const;
  // body id of the robot, excluded from lidar rays; -1 if the scene has no robot
  int robotBody() const { return robot_body_; }
  // geom id of the terrain
  int terrainGeom() const { return terrain_geom_; }

  // True terrain height [m] at (x, y), from a downward ray against the terrain geom only;
  // NaN outside the terrain.
  double terrainHeight(double x, double y) const;
  // True height [m] of the highest surface at (x, y): terrain or any object; NaN if none.
  double surfaceHeight(double x, double y, int* geom = nullptr) const;
  // Nearest surface along origin + x * dir, x >= 0, over every geom but the robot's (mj_ray's
  // semantics); distance -1 and geom -1 if none.
  RayHit castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const { return caster_->cast(origin, dir); }

 private:
  void finishLoading();

  std::filesystem::path scene_path_;
  mjModel* model_ = nullptr;
  mjData* data_ = nullptr;
  scenes::SceneTruth truth_;
  std::vector<scenes::GeomClass> classes_;
  int robot_body_ = -1;
  int terrain_geom_ = -1;
  double top_z_ = 1000;
  std::unique_ptr<RayCaster> caster_;  // every geom but the robot's
};

}  // namespace terrain::sim
