#include "sim/world.hpp"

#include "rig/file_io.hpp"
#include "sim/hfield_ray.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace terrain::sim {

namespace fs = std::filesystem;

namespace {

// loads MJCF text through a virtual file system so that inline scenes need no file on disk
mjModel* loadFromText(const std::string& text, const std::string& origin) {
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  const char* name = "scene.xml";
  if (mj_makeEmptyFileVFS(&vfs, name, static_cast<int>(text.size())) != 0) {
    throw io::InputError(origin + ": cannot create a virtual file for the scene");
  }
  const int i = mj_findFileVFS(&vfs, name);
  std::memcpy(vfs.filedata[i], text.data(), text.size());
  char error[1024] = "";
  mjModel* m = mj_loadXML(name, &vfs, error, sizeof error);
  mj_deleteVFS(&vfs);
  if (!m) throw io::InputError(origin + ": MuJoCo could not load the scene: " + error);
  return m;
}

}  // namespace

World::World(const fs::path& scene_xml) : scene_path_(scene_xml) {
  if (!fs::exists(scene_xml)) throw io::InputError(scene_xml.string() + ": no such scene file");
  const fs::path truth_path = scenes::truthPathFor(scene_xml);
  if (!fs::exists(truth_path)) {
    throw io::InputError(truth_path.string() +
                         ": ground-truth sidecar is missing (generate scenes with 'terrain scenes generate')");
  }
  truth_ = scenes::loadTruth(truth_path);
  char error[1024] = "";
  model_ = mj_loadXML(scene_xml.c_str(), nullptr, error, sizeof error);
  if (!model_) {
    std::string msg = error;
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
    for (auto& ch : msg) ch = ch == '\n' ? ' ' : ch;
    throw io::InputError(scene_xml.string() + ": MuJoCo could not load the scene: " + msg);
  }
  finishLoading();
}

World::World(const std::string& mjcf_text, scenes::SceneTruth truth) : truth_(std::move(truth)) {
  model_ = loadFromText(mjcf_text, "(inline scene)");
  finishLoading();
}

World::~World() {
  if (data_) mj_deleteData(data_);
  if (model_) mj_deleteModel(model_);
}

void World::finishLoading() {
  data_ = mj_makeData(model_);
  mj_forward(model_, data_);
  classes_.assign(model_->ngeom, scenes::GeomClass::None);
  for (const auto& [name, cls] : truth_.geomClasses()) {
    const int id = mj_name2id(model_, mjOBJ_GEOM, name.c_str());
    if (id < 0) {
      if (cls == scenes::GeomClass::Robot) continue;  // scenes without a robot body
      throw io::InputError("scene and truth disagree: truth names geom '" + name + "', which the scene lacks");
    }
    classes_[id] = cls;
  }
  robot_body_ = mj_name2id(model_, mjOBJ_BODY, "robot");
  terrain_geom_ = mj_name2id(model_, mjOBJ_GEOM, truth_.terrain.geom.c_str());
  if (terrain_geom_ < 0) throw io::InputError("scene has no terrain geom named '" + truth_.terrain.geom + "'");
  // a start height above everything in the scene, for downward rays
  top_z_ = heightAboveGeoms(model_, data_);
  caster_ = std::make_unique<RayCaster>(model_, data_, robot_body_);
}

std::vector<std::string> World::unclassifiedGeoms() const {
  std::vector<std::string> out;
  for (int g = 0; g < model_->ngeom; ++g) {
    if (classes_[g] != scenes::GeomClass::None) continue;
    if (robot_body_ >= 0 && model_->geom_bodyid[g] == robot_body_) continue;
    const char* name = mj_id2name(model_, mjOBJ_GEOM, g);
    out.push_back(name ? std::string(name) : "geom " + std::to_string(g));
  }
  return out;
}

double World::terrainHeight(double x, double y) const {
  return terrainHeightAt(model_, data_, terrain_geom_, top_z_, x, y);
}

double World::surfaceHeight(double x, double y, int* geom) const {
  const RayHit hit = caster_->cast(Eigen::Vector3d(x, y, top_z_), Eigen::Vector3d(0, 0, -1));
  if (geom) *geom = hit.geom;
  return hit.geom < 0 ? std::numeric_limits<double>::quiet_NaN() : top_z_ - hit.distance;
}

}  // namespace terrain::sim
