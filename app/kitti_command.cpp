// 'terrain kitti': the ground segmentation scored on real KITTI HDL-64E scans against their
// SemanticKITTI labels, beside the ground baselines, with where the method errs.
#include "app/cli_options.hpp"
#include "app/command.hpp"
#include "app/pipeline_config_io.hpp"
#include "evaluation/kitti.hpp"
#include "evaluation/metrics.hpp"
#include "rig/file_io.hpp"
#include "rig/kitti.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <optional>

namespace terrain::app {

namespace {

namespace fs = std::filesystem;

class KittiCommand : public Command {
 public:
  explicit KittiCommand(CLI::App& app)
      : Command(app.add_subcommand("kitti",
                                   "score ground segmentation on real KITTI HDL-64E scans with SemanticKITTI labels")) {
    cli_->add_option("--scan", scans_, "KITTI .bin scan(s); labels are read from the .label file beside each")
        ->required();
    cli_->add_option("--sensor-height", sensor_height_, "lidar height above the road [m]")->capture_default_str();
    cli_->add_option("--json", json_, "also write the scores as JSON");
    cli_->add_option("--cloud", cloud_,
                     "also write each scan as a binary PLY in this directory (SCAN.ply): x y z, the SemanticKITTI "
                     "class, the configured solver's ground label and the verdict (0 non-ground right, 1 ground "
                     "right, 2 false ground, 3 missed ground, 4 unscored)");
    cli_->add_flag("--force", force_, "replace an existing --json file or --cloud directory");
    addPipelineOptions(*cli_, config_, true);
  }

  int run() override {
    validate(config_);
    nlohmann::json all;
    std::optional<io::StagedDirectory> cloud;
    if (!cloud_.empty()) cloud.emplace(cloud_, force_);
    std::cout << std::fixed << std::setprecision(3)
              << "scan          method                 F1     IoU    precision recall\n";
    eval::KittiScorer scorer(config_.voxel_map, config_.ground, sensor_height_);
    for (const auto& scan_path : scans_) {
      const rig::KittiScan scan = rig::readKittiScan(scan_path);
      fs::path label_path = scan_path;
      label_path.replace_extension(".label");
      const auto labels = rig::readSemanticKittiLabels(label_path, scan.points.size());
      const auto j = scorer.score(scan.points, labels);
      const auto row = [&](const std::string& method, const nlohmann::json& scores) {
        std::cout << std::left << std::setw(14) << scan_path.stem().string() << std::setw(22) << method << std::right
                  << scores["f1"].get<double>() << "  " << scores["iou"].get<double>() << "  "
                  << scores["precision"].get<double>() << "     " << scores["recall"].get<double>() << "\n";
      };
      for (const char* m : eval::kGroundMethods) row(m, j[m]);
      // the GMRF's own share: its voxel labels before the per-point step
      for (const char* m : {"gmrf_icm", "gmrf_mincut"}) row(std::string(m) + " voxels", j["voxel_labels"][m]);
      // where the configured solver calls ground wrongly
      const auto& conf = j["confusion"];
      std::vector<std::pair<std::uint64_t, std::string>> wrong;
      for (auto it = conf["by_class"].begin(); it != conf["by_class"].end(); ++it) {
        const std::string name = it.key();
        if (name == "road" || name == "parking" || name == "sidewalk" || name == "other-ground" || name == "terrain" ||
            name == "vegetation")
          continue;
        const auto n = it.value()["labelled_ground"].get<std::uint64_t>();
        if (n > 0) wrong.emplace_back(n, name);
      }
      std::sort(wrong.rbegin(), wrong.rend());
      std::cout << std::left << std::setw(14) << scan_path.stem().string() << std::right << "false ground ("
                << conf["method"].get<std::string>() << ") by class:";
      for (const auto& [n, name] : wrong) {
        std::cout << " " << name << " " << n << "/" << conf["by_class"][name]["points"].get<std::uint64_t>();
      }
      std::cout << "\n"
                << std::left << std::setw(14) << scan_path.stem().string() << std::right
                << "false / missed ground by distance:";
      for (auto it = conf["by_distance"].begin(); it != conf["by_distance"].end(); ++it) {
        std::cout << " " << it.key() << " m " << it.value()["false_ground"].get<std::uint64_t>() << " / "
                  << it.value()["missed_ground"].get<std::uint64_t>();
      }
      std::cout << "\n";
      all[scan_path.stem().string()] = j;
      if (cloud) {
        io::writeFileAtomic(cloud->path() / (scan_path.stem().string() + ".ply"),
                            eval::kittiVerdictPly(scan.points, labels, scorer.groundOfLastScan()), false);
      }
    }
    if (!json_.empty()) io::writeFileAtomic(json_, all.dump(1) + "\n", force_);
    if (cloud) cloud->commit();
    return 0;
  }

 private:
  std::vector<fs::path> scans_;
  fs::path json_, cloud_;
  bool force_ = false;
  double sensor_height_ = 1.73;
  PipelineConfig config_;
};

}  // namespace

std::unique_ptr<Command> addKittiCommand(CLI::App& app) { return std::make_unique<KittiCommand>(app); }

}  // namespace terrain::app
