// 'terrain reconstruct': the pipeline over a recorded dataset, over a dataset with its lidar
// replaced by a real Velodyne's packets, or over a real capture alone.
#include "app/cli_options.hpp"
#include "app/command.hpp"
#include "app/interrupt.hpp"
#include "app/pipeline_config_io.hpp"
#include "app/reconstruction.hpp"
#include "rig/dataset.hpp"
#include "rig/file_io.hpp"

#include <nlohmann/json.hpp>

#include <iostream>

namespace terrain::app {

namespace {

namespace fs = std::filesystem;

class ReconstructCommand : public Command {
 public:
  explicit ReconstructCommand(CLI::App& app)
      : Command(app.add_subcommand("reconstruct", "run the pipeline over a recorded dataset")) {
    cli_->add_option("--input", input_,
                     "dataset directory (from 'terrain record'); without it, --lidar pcap:FILE reconstructs a real "
                     "capture alone and --lidar udp:HOST:PORT a live sensor alone (lidar and GPS from its packets, "
                     "unscored)");
    cli_->add_option("--out", out_, "output directory")->required();
    cli_->add_flag("--force", force_,
                   "replace an existing, non-empty output directory (whole, once the new one is complete)");
    addLidarOptions(*cli_, lidar_, "the dataset");
    auto* mast = cli_->add_option("--mast-height", lidar_.mast_height,
                                  "[m] lidar height above the ground, for a capture or live sensor reconstructed alone")
                     ->capture_default_str();
    position_option_ =
        cli_->add_option("--lidar-position-port", position_port_,
                         "a live sensor reconstructed alone (--lidar udp:HOST:PORT, no --input): the UDP port its "
                         "position packets (GPS) come to, on HOST; 0: none are read (the rig stays where it started)")
            ->capture_default_str()
            ->check(CLI::Range(0, 65535));
    cli_->add_option("--sensors", sensors_,
                     "with --lidar pcap:FILE and no --input: a folder with the rig's calibration.json, camera "
                     "images (camera/NAME/images.csv: time_s,file) and gyro.csv recorded beside the capture, "
                     "timed in its clock (layout in docs/velodyne.md); the calibration places the lidar")
        ->excludes(mast);
    addScoringOptions(*cli_, scoring_);
    addPipelineOptions(*cli_, config_);
  }

  int run() override {
    validate(config_);
    if (input_.empty()) {
      if (lidar_.endpoint.empty()) {
        throw io::InputError(
            "give --input DATASET, or --lidar pcap:FILE (a capture) or udp:HOST:PORT (a live sensor) to reconstruct "
            "it alone");
      }
      lidar_.position_port = static_cast<std::uint16_t>(position_port_);
      reconstructCapture(lidar_, config_, out_, force_, scoring_, sensors_);
      return 0;
    }
    if (!sensors_.empty())
      throw io::InputError("--sensors applies to a capture reconstructed alone (--lidar pcap:FILE without --input)");
    if (position_option_->count() > 0) {
      throw io::InputError(
          "--lidar-position-port applies to a live sensor reconstructed alone (--lidar udp:HOST:PORT without "
          "--input); beside a dataset the GPS comes from the dataset");
    }
    auto dataset = std::make_unique<rig::DatasetSource>(input_);
    // a dataset recorded from a scene still on disk can be scored against it
    std::shared_ptr<sim::World> world;
    const auto producer = nlohmann::json::parse(dataset->producerJson());
    if (producer.contains("scene") && producer["scene"].is_string() &&
        fs::exists(producer["scene"].get<std::string>())) {
      world = std::make_shared<sim::World>(producer["scene"].get<std::string>());
    } else if (producer.contains("scene") && producer["scene"].is_string()) {
      std::cerr << "terrain: warning: not scored: the scene the dataset was recorded from, "
                << producer["scene"].get<std::string>() << ", is no longer there (put it back to score the run)\n";
    } else {
      std::cerr << "terrain: note: not scored: the dataset names no scene to score it against\n";
    }
    refuseInputInside(out_, input_, "--input");
    if (lidar_.endpoint.empty()) {
      if (!lidar_.calibration.empty()) throw io::InputError("--calibration applies to --lidar only");
      io::StagedDirectory staged(out_, force_);
      reconstruct(*dataset, config_, staged.path(), world.get(), scoring_);
      throwIfInterrupted();
      staged.commit();
      std::cout << "outputs in " << fs::absolute(out_).string() << "\n";
      return 0;
    }
    // the real-driver path: the lidar from packets, everything else from the dataset
    const auto endpoint = rig::LidarEndpoint::parse(lidar_.endpoint);  // refused before anything is written
    if (endpoint.kind == rig::LidarEndpoint::Kind::Pcap) refuseInputInside(out_, endpoint.path, "--lidar");
    io::StagedDirectory staged(out_, force_);
    reconstructWithLidar(std::move(dataset), lidar_, config_, staged.path(), world.get(), scoring_);
    throwIfInterrupted();
    staged.commit();
    std::cout << "outputs in " << fs::absolute(out_).string() << "\n";
    return 0;
  }

 private:
  fs::path input_, out_, sensors_;
  bool force_ = false;
  int position_port_ = rig::velodyne::kPositionPort;
  CLI::Option* position_option_ = nullptr;
  LidarChoice lidar_;
  eval::EvaluationOptions scoring_;
  PipelineConfig config_;
};

}  // namespace

std::unique_ptr<Command> addReconstructCommand(CLI::App& app) { return std::make_unique<ReconstructCommand>(app); }

}  // namespace terrain::app
