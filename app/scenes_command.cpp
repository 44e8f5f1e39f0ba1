// 'terrain scenes generate' (a generated MJCF scene with its ground truth) and 'terrain scenes
// import' (a MuJoCo world of the user's as a testbed scene).
#include "app/cli_options.hpp"
#include "app/command.hpp"
#include "app/reconstruction.hpp"
#include "rig/file_io.hpp"
#include "scenes/scene_generator.hpp"
#include "sim/scene_import.hpp"

#include <cmath>
#include <iostream>
#include <map>
#include <sstream>

namespace terrain::app {

namespace {

namespace fs = std::filesystem;

// numbers separated by `sep`; throws io::InputError naming the option
std::vector<double> numbersIn(const std::string& text, char sep, const std::string& option) {
  std::vector<double> out;
  std::istringstream in(text);
  for (std::string item; std::getline(in, item, sep);) {
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || item.find_first_not_of(" ", used) != std::string::npos || !std::isfinite(v))
      throw io::InputError(option + " '" + text + "': '" + item + "' is not a number");
    out.push_back(v);
  }
  return out;
}

int importScene(const fs::path& world, const fs::path& out, const fs::path& classes, const std::string& path,
                const std::string& origin, bool force) {
  sim::ImportOptions options;
  if (!classes.empty()) sim::loadImportPatterns(classes, options);
  for (std::istringstream in(path); !path.empty();) {
    std::string point;
    if (!std::getline(in, point, ';')) break;
    const auto xy = numbersIn(point, ',', "--path");
    if (xy.size() != 2) throw io::InputError("--path '" + path + "': '" + point + "' is not x,y");
    options.path.emplace_back(xy[0], xy[1]);
  }
  if (!path.empty() && options.path.size() < 2)
    throw io::InputError("--path '" + path + "': needs at least 2 waypoints");
  const auto o = numbersIn(origin, ',', "--origin");
  if (o.size() != 3 || std::abs(o[0]) > 90 || std::abs(o[1]) > 180)
    throw io::InputError("--origin '" + origin +
                         "': expected latitude,longitude,altitude within [-90, 90] and [-180, 180] deg");
  options.origin = {o[0], o[1], o[2]};
  const fs::path sidecar = scenes::truthPathFor(out);
  for (const fs::path& f : {out, sidecar}) {
    if (fs::exists(f) && !force) throw io::InputError(f.string() + ": exists (pass --force to overwrite it)");
  }
  if (fs::absolute(out).lexically_normal() == fs::absolute(world).lexically_normal())
    throw io::InputError(out.string() + ": is the world itself; write the scene to another file");
  const sim::ImportedScene scene = sim::importScene(world, out, options);
  if (!fs::absolute(out).parent_path().empty()) fs::create_directories(fs::absolute(out).parent_path());
  io::writeFileAtomic(out, scene.mjcf, true);
  io::writeFileAtomic(sidecar, scenes::truthToJson(scene.truth), true);
  std::map<std::string, int> by_class;
  for (const auto& ob : scene.truth.objects) ++by_class[scenes::className(ob.object_class)];
  std::cout << "wrote " << out.string() << " and " << sidecar.string() << ": " << scene.truth.objects.size()
            << " objects (";
  const char* sep = "";
  for (const auto& [cls, n] : by_class) std::cout << sep << n << " " << cls, sep = ", ";
  std::cout << "), terrain '" << scene.truth.terrain.geom << "' (" << scene.truth.terrain.kind << "), path of "
            << scene.truth.path.size() << " waypoints with " << scene.path_clearance << " m to the nearest object\n";
  for (const auto& a : scene.added) std::cout << "  added " << a << "\n";
  if (!scene.unclassified.empty()) {
    std::cout << "  " << scene.unclassified.size()
              << " geom(s) no pattern classed (scored as neither ground nor object; "
              << "give --classes patterns that match them):";
    for (const auto& u : scene.unclassified) std::cout << " " << u;
    std::cout << "\n";
  }
  // the scene as 'run --scene' will see it
  const sim::World loaded(out);
  checkSceneOrThrow(loaded, sim::SimConfig{}, out);
  return 0;
}

int generateScene(const scenes::SceneConfig& cfg, const fs::path& out, bool force) {
  const scenes::GeneratedScene scene = scenes::generateScene(cfg);
  scenes::writeScene(scene, out, force);
  std::cout << "wrote " << out.string() << " (" << scene.truth.objects.size() << " objects) and "
            << scenes::truthPathFor(out).string() << "\n";
  return 0;
}

class ScenesCommand : public Command {
 public:
  explicit ScenesCommand(CLI::App& app)
      : Command(app.add_subcommand("scenes", "generated MuJoCo scenes with ground truth")) {
    cli_->require_subcommand(1);
    generate_ = cli_->add_subcommand("generate",
                                     "write FILE.xml, FILE.truth.json (and FILE.hfield) for a terrain type and seed");
    std::string types;
    for (const auto& t : scenes::sceneTypes()) types += (types.empty() ? "" : ", ") + t;
    generate_->add_option("--type", scene_.type, "terrain type: " + types)
        ->capture_default_str()
        ->check(CLI::IsMember(scenes::sceneTypes()));
    generate_->add_option("--seed", scene_.seed, "random seed (>= 0); the same type and seed give byte-identical files")
        ->capture_default_str()
        ->check(seedCheck());
    generate_->add_option("--extent", scene_.extent, "half side of the square scene [m], 20-500")
        ->capture_default_str();
    generate_->add_option("--cell", scene_.hfield_cell, "heightfield grid spacing [m], 0.1-5")->capture_default_str();
    generate_->add_option("--out", generate_out_, "output MJCF file")->required();
    generate_->add_flag("--force", generate_force_, "overwrite existing files");

    import_ = cli_->add_subcommand(
        "import",
        "make a MuJoCo world of your own a testbed scene: SCENE.xml (the world, plus a skybox, a light and the "
        "robot with its camera where it has none) and SCENE.truth.json (objects classed from geom names)");
    import_->add_option("--mjcf", world_, "the world (MJCF)")->required()->check(CLI::ExistingFile);
    import_
        ->add_option("--out", import_out_,
                     "the scene to write (MJCF; its sidecar beside it); in the world's folder when the world "
                     "names files (heightfields, meshes, textures)")
        ->required();
    import_
        ->add_option(
            "--classes", classes_,
            "YAML map of class (building, crown, trunk, terrain) to name patterns (case-insensitive substrings of "
            "a geom's, its material's or its body's name), each replacing that class's defaults: building: build, "
            "bldg, house, hall, tower, shed, garage, facade, roof; crown: crown, leaf, leaves, foliage, canopy, "
            "bush, tree; trunk: trunk, bark, stem (checked first: tree_trunk is a trunk); terrain: ground, terrain, "
            "floor, heightfield, hfield")
        ->check(CLI::ExistingFile);
    import_->add_option(
        "--path", path_,
        "the robot's path as waypoints \"x,y;x,y;...\" [m, world]; default: the straight line along x, 90 % of "
        "the terrain long, nearest the terrain's middle with 3.35 m of room to every object (else the one "
        "with the most room, at least 1.35 m: the robot's half width and a metre)");
    import_->add_option("--origin", origin_, "the world origin on the globe: latitude,longitude [deg],altitude [m]")
        ->capture_default_str();
    import_->add_flag("--force", import_force_, "overwrite an existing scene and sidecar");
  }

  int run() override {
    if (generate_->parsed()) return generateScene(scene_, generate_out_, generate_force_);
    return importScene(world_, import_out_, classes_, path_, origin_, import_force_);
  }

 private:
  CLI::App* generate_ = nullptr;
  CLI::App* import_ = nullptr;
  scenes::SceneConfig scene_;
  fs::path generate_out_;
  bool generate_force_ = false;
  fs::path world_, import_out_, classes_;
  std::string path_, origin_ = "0,0,0";
  bool import_force_ = false;
};

}  // namespace

std::unique_ptr<Command> addScenesCommand(CLI::App& app) { return std::make_unique<ScenesCommand>(app); }

}  // namespace terrain::app
