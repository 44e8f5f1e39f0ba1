// 'terrain run': generate a scene (or take the user's), simulate the rig and reconstruct,
// streaming from the simulation to the pipeline with no dataset on disk.
#include "app/cli_options.hpp"
#include "app/command.hpp"
#include "app/pipeline_config_io.hpp"
#include "app/reconstruction.hpp"
#include "rig/velodyne_source.hpp"
#include "scenes/scene_generator.hpp"

namespace terrain::app {

namespace {

namespace fs = std::filesystem;

class RunCommand : public Command {
 public:
  explicit RunCommand(CLI::App& app)
      : Command(app.add_subcommand(
            "run", "generate a scene, simulate the rig and reconstruct, streaming (no dataset on disk)")) {
    auto* scenario = cli_->add_option("--scenario", scenario_, "terrain type of the generated scene")
                         ->capture_default_str()
                         ->check(CLI::IsMember(scenes::sceneTypes()));
    auto* seed = cli_->add_option("--seed", seed_, "scene seed, >= 0 (the sensor noise seed is --noise-seed)")
                     ->capture_default_str()
                     ->check(seedCheck());
    cli_->add_option("--scene", scene_,
                     "run on this scene (MJCF with its .truth.json sidecar) instead of a generated one; it is checked "
                     "before the simulation (terrain under the path: an error; no skybox, the path within a metre of "
                     "an object, nothing above the lidar's reach: warnings) and used where it is")
        ->check(CLI::ExistingFile)
        ->excludes(scenario)
        ->excludes(seed);
    cli_->add_option("--frames", frames_, "lidar sweeps to simulate, 1-" + std::to_string(kMaxFrames))
        ->capture_default_str()
        ->check(CLI::Range(1, kMaxFrames));
    cli_->add_option("--out", out_, "output directory")->capture_default_str();
    cli_->add_flag("--force", force_,
                   "replace an existing, non-empty output directory (whole, once the new one is complete)");
    addLidarOptions(*cli_, lidar_, "the simulated rig");
    addScoringOptions(*cli_, scoring_);
    addPipelineOptions(*cli_, config_);
    // the simulation: its file first, so that the options after it override the file
    addSimConfigOption(*cli_, sim_, "YAML file with simulation settings (as for 'terrain record --sim-config')");
    cli_->add_option("--noise-seed", sim_.seed, "sensor noise seed (>= 0)")->capture_default_str()->check(seedCheck());
    cli_->add_option("--speed", sim_.robot.speed, "robot speed along the path [m/s]")->capture_default_str();
    cli_->add_option("--height-cap", sim_.lidar.height_cap,
                     "lidar returns higher than this above the sensor are dropped [m]")
        ->capture_default_str();
    cli_->add_option("--threads", sim_.threads, "lidar simulation threads, 0 = all cores")->capture_default_str();
    addCameraRigOption(*cli_, sim_.camera.rig);
  }

  int run() override {
    validate(config_);
    if (!lidar_.endpoint.empty()) rig::LidarEndpoint::parse(lidar_.endpoint);
    runScenario(scenario_, seed_, frames_, sim_, config_, out_, force_, false, scoring_, &lidar_, scene_);
    return 0;
  }

 private:
  std::string scenario_ = "urban";
  std::uint64_t seed_ = 1;
  fs::path scene_;
  int frames_ = 60;
  fs::path out_ = "out/run";
  bool force_ = false;
  LidarChoice lidar_;
  eval::EvaluationOptions scoring_;
  PipelineConfig config_;
  sim::SimConfig sim_;
};

}  // namespace

std::unique_ptr<Command> addRunCommand(CLI::App& app) { return std::make_unique<RunCommand>(app); }

}  // namespace terrain::app
