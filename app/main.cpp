// terrain: the testbed's command-line entry point. Subcommands:
//   scenes generate   write a generated MJCF scene with its ground truth
//   record            drive a scene with the simulated rig and write a dataset
//   reconstruct       run the pipeline over a recorded dataset (optionally with a real lidar)
//   run               generate a scene, simulate and reconstruct in one go
//   stream            send a capture or a simulated run as HDL-64E packets over UDP
//   evaluate          score a finished run again from what it kept (OUT/state/)
//   lidar             a real Velodyne capture alone: inspect, convert (app/lidar_commands.hpp)
#include "app/bounded_queue.hpp"
#include "app/html_report.hpp"
#include "app/interrupt.hpp"
#include "app/lidar_commands.hpp"
#include "app/outputs.hpp"
#include "app/pipeline_config_io.hpp"
#include "app/progress.hpp"
#include "app/run_state.hpp"
#include "core/pipeline.hpp"
#include "evaluation/kitti.hpp"
#include "evaluation/metrics.hpp"
#include "evaluation/regression.hpp"
#include "evaluation/report.hpp"
#include "rig/dataset.hpp"
#include "rig/file_io.hpp"
#include "rig/kitti.hpp"
#include "rig/pcap_file.hpp"
#include "rig/velodyne_source.hpp"
#include "scenes/scene_generator.hpp"
#include "sim/scene_checks.hpp"
#include "sim/scene_import.hpp"
#include "sim/simulated_rig.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iomanip>
#include <iostream>
#include <thread>

namespace {

using namespace terrain;
namespace fs = std::filesystem;

// the value of an option such as "--config FILE" if present, read before the other options so
// that the command line overrides the file
std::string preScan(int argc, char** argv, const std::string& name) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (argv[i] == name) return argv[i + 1];
  }
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind(name + "=", 0) == 0) return a.substr(name.size() + 1);
  }
  return {};
}

// the most sweeps one command simulates or records: 100,000 sweeps are 2.8 hours at 10 Hz, and a
// recording of them at 640 x 480 with four cameras some 400 GB
constexpr int kMaxFrames = 100000;

// a seed: a whole number from 0 (CLI11 reads "-1" into an unsigned seed as 2^64 - 1)
const CLI::Validator kSeed(
    [](std::string& s) {
      const bool digits = !s.empty() && s.size() <= 19 && s.find_first_not_of("0123456789") == std::string::npos;
      return digits ? std::string() : "a seed is a whole number from 0 to 10^19, not '" + s + "'";
    },
    "SEED");

bool isSubcommand(int argc, char** argv, const char* name) { return argc > 1 && std::strcmp(argv[1], name) == 0; }

// the named camera rig, for the commands that simulate
void addCameraRigOption(CLI::App& cmd, std::string& rig) {
  cmd.add_option("--cameras", rig,
                 std::string("camera rig (") + sim::kCameraRigs +
                     "): surround has a front, left, rear and right camera 90 deg apart that see the whole horizon; "
                     "forward is the paper's single forward camera. A sim config's 'cameras' list replaces it")
      ->capture_default_str();
}

// options that fill the simulation settings; defaults shown in --help
void addSimOptions(CLI::App& cmd, sim::SimConfig& c, std::string& config_file, const std::string& flag) {
  cmd.add_option(flag, config_file,
                 "YAML file with simulation settings (sections robot, lidar, camera, gps, gyro); "
                 "command-line options override it");
  cmd.add_option("--seed", c.seed, "noise seed (>= 0)")->capture_default_str()->check(kSeed);
  cmd.add_option("--threads", c.threads, "lidar worker threads, 0 = all cores (output does not depend on it)")
      ->capture_default_str();
  cmd.add_option("--speed", c.robot.speed, "robot speed along the path [m/s]")->capture_default_str();
  cmd.add_option("--mast-height", c.robot.mast_height, "lidar height above the ground [m]")->capture_default_str();
  cmd.add_option("--lidar-calibration", c.lidar.calibration,
                 "Velodyne calibration file (ROS YAML or db.xml); default: the shipped HDL-64E S2");
  cmd.add_option("--rotation-hz", c.lidar.rotation_hz, "lidar spin rate [Hz], 5-15")->capture_default_str();
  cmd.add_option("--max-range", c.lidar.max_range, "lidar maximum range [m]")->capture_default_str();
  cmd.add_option("--range-noise", c.lidar.range_noise, "1-sigma range noise [m]")->capture_default_str();
  cmd.add_option("--laser-bias", c.lidar.laser_bias, "1-sigma of a fixed per-laser range bias [m]")
      ->capture_default_str();
  cmd.add_option("--dropout", c.lidar.dropout, "probability a return is lost")->capture_default_str();
  cmd.add_option("--height-cap", c.lidar.height_cap, "returns higher than this above the sensor are dropped [m]")
      ->capture_default_str();
  cmd.add_flag("!--no-camera", c.camera.enabled, "do not render camera frames");
  addCameraRigOption(cmd, c.camera.rig);
  cmd.add_option("--width", c.camera.width, "image width [px] of every camera (default: each camera's own, 640)");
  cmd.add_option("--height", c.camera.height, "image height [px] of every camera (default: each camera's own, 480)");
  cmd.add_option("--fovy", c.camera.fovy_deg,
                 "vertical field of view [deg] of every camera (default: each camera's own, 75)");
  cmd.add_option("--camera-pitch", c.camera.pitch_deg,
                 "upward tilt [deg] of every camera (default: each camera's own, 8)");
  cmd.add_option("--gps-sigma", c.gps.horizontal_sigma, "GPS horizontal 1-sigma noise [m]")->capture_default_str();
  cmd.add_option("--gyro-noise", c.gyro.noise_sigma, "gyro 1-sigma noise [rad/s]")->capture_default_str();
  cmd.add_option("--gyro-bias", c.gyro.bias_sigma, "1-sigma of the constant gyro bias [rad/s]")->capture_default_str();
}

// options that fill the pipeline settings; defaults shown in --help
// The pipeline's options; with ground_only, those of the voxel map and the ground segmentation alone
// (a command that segments single scans: no camera, no frames).
void addPipelineOptions(CLI::App& cmd, PipelineConfig& c, std::string& config_file, std::string& histogram,
                        std::string& solver, std::vector<std::string>& settings, bool ground_only = false) {
  cmd.add_option("--config", config_file,
                 ground_only ? "YAML file with pipeline settings (of its sections, voxel_map and ground apply here); "
                               "command-line options override it"
                             : "YAML file with pipeline settings (sections pose, voxel_map, ground, boundary, "
                               "estimation, footprint, crown, hull, free_space); command-line options override it");
  cmd.add_option("--voxel-size", c.voxel_map.voxel_size, "voxel edge [m]")->capture_default_str();
  cmd.add_option("--histogram", histogram,
                 "ground height histogram: local (tiles following the terrain) or global (the paper's)")
      ->capture_default_str();
  cmd.add_option("--solver", solver, "GMRF solver: icm or mincut (exact)")->capture_default_str();
  cmd.add_option("--delta", c.ground.delta, "half-width of the ground band around the histogram peak [m]")
      ->capture_default_str();
  cmd.add_option("--alpha", c.ground.alpha, "GMRF single-site weight")->capture_default_str();
  cmd.add_option("--beta", c.ground.beta, "GMRF pair-site Potts weight")->capture_default_str();
  cmd.add_option("--gamma", c.ground.gamma, "GMRF pair-site height-contrast weight")->capture_default_str();
  cmd.add_option("--tile-size", c.ground.tile_size, "local histogram tile edge [m]")->capture_default_str();
  if (ground_only) {
    cmd.add_option("--set", settings,
                   "KEY=VALUE: any voxel_map or ground setting by its name in the --config file (section.field, e.g. "
                   "ground.icm_iterations=4); repeatable; applied after --config and the options above");
    return;
  }
  cmd.add_option("--segment-every", c.segment_every, "run ground segmentation every N frames")->capture_default_str();
  cmd.add_option("--boundary-threshold", c.boundary.threshold, "boundary gradient threshold (grey levels)")
      ->capture_default_str();
  cmd.add_option("--kx", c.boundary.kx, "weight of horizontal change in the gradient")->capture_default_str();
  cmd.add_option("--ky", c.boundary.ky, "weight of vertical change in the gradient")->capture_default_str();
  cmd.add_flag(
      "--erode-all-directions,!--erode-horizontal", c.boundary.erode_all_directions,
      "erosion keeps thin boundaries of every direction, or near-horizontal ones only (default: near-horizontal)");
  cmd.add_flag("--erode-sloping,!--no-erode-sloping", c.boundary.erode_sloping,
               "the near-horizontal erosion also keeps boundaries sloping up to 1 row per column, away from foliage "
               "(roof lines seen obliquely) (default: on)");
  cmd.add_option("--max-distance", c.estimation.max_distance, "vertices farther than this are not raised [m]")
      ->capture_default_str();
  cmd.add_flag("--clear-line,!--no-clear-line", c.estimation.clear_line,
               "skip a frame's estimate when another sensed object stands in the vertex's image column (default: on)");
  cmd.add_flag("--sky-test,!--no-sky-test", c.estimation.require_sky_above,
               "accept a top boundary only with daylight sky just above it (default: on)");
  cmd.add_flag("--foliage-tops,!--no-foliage-tops", c.estimation.foliage_tops,
               "a vertex of a crown the lidar saw part of takes the end of the foliage above it as its top, not the "
               "topmost boundary of its column (default: on)");
  cmd.add_flag("--footprints,!--no-footprints", c.footprint.enabled,
               "complete building footprints from two walls of a corner and roof them at the walls' recovered height "
               "(default: on)");
  cmd.add_flag("--crowns,!--no-crowns", c.crown.enabled,
               "raise the ground under tree crowns measured in the images above sensed trunks (by their foliage "
               "colour, or against the sky with --set crown.cue=sky) (default: on)");
  cmd.add_flag("--crown-hull,!--no-crown-hull", c.hull.enabled,
               "raise the ground under tree crowns to the top of their visual hull: the voxels around sensed trunks "
               "that many images from places min_parallax apart saw as foliage and almost none as sky (default: off)");
  cmd.add_flag("--sky-ceiling,!--no-sky-ceiling", c.free_space.enabled,
               "lower every recovered height to the lowest ray of a sky pixel over its cell: nothing stands higher "
               "where the cameras saw sky (default: off)");
  cmd.add_option(
         "--spread-distance", c.estimation.spread_distance,
         "[m] object vertices without an estimate take the nearest estimated one's height up to this far away (0: off)")
      ->capture_default_str();
  cmd.add_option(
      "--set", settings,
      "KEY=VALUE: any pipeline setting by its name in the --config file (section.field, e.g. crown.cue=sky, "
      "ground.icm_iterations=4); repeatable; applied after --config and the options above; the settings used "
      "are written to report.json");
}

void applyChoices(PipelineConfig& c, const std::string& histogram, const std::string& solver,
                  const std::vector<std::string>& settings) {
  for (const std::string& s : settings) app::applyPipelineSetting(s, c, "--set");
  if (!parseHistogram(histogram, c.ground.histogram))
    throw io::InputError("--histogram must be local or global, not '" + histogram + "'");
  if (!parseSolver(solver, c.ground.solver))
    throw io::InputError("--solver must be icm or mincut, not '" + solver + "'");
  app::validate(c);
}

// the scorecard on the terminal, from the report
void printScorecard(const nlohmann::json& r) {
  std::cout << std::fixed << std::setprecision(3) << "scorecard\n";
  if (r.contains("pose") && r["pose"]["frames"].get<std::size_t>() > 0) {
    const auto& p = r["pose"];
    std::cout << "  pose at " << p["frames"].get<std::size_t>() << " kept camera frames, error median (max):";
    for (const auto& [key, what] : {std::pair<const char*, const char*>{"horizontal_error_m", "m across"},
                                    {"vertical_error_m", "m up"},
                                    {"heading_error_deg", "deg heading"},
                                    {"pitch_error_deg", "deg pitch"},
                                    {"roll_error_deg", "deg roll"}}) {
      std::cout << " " << p[key]["median"].get<double>() << " (" << p[key]["max"].get<double>() << ") " << what << ";";
    }
    std::cout << "\n";
  }
  std::cout << "  ground segmentation per voxel    F1     IoU    precision  recall\n";
  for (const char* m : {"histogram", "gmrf_icm", "gmrf_mincut", "fixed_band", "ransac_plane", "morphological_filter"}) {
    if (!r["ground_segmentation"].contains(m)) continue;  // baselines not asked for
    const auto& g = r["ground_segmentation"][m];
    std::cout << "    " << std::left << std::setw(28) << m << std::right << g["f1"].get<double>() << "  "
              << g["iou"].get<double>() << "  " << g["precision"].get<double>() << "      " << g["recall"].get<double>()
              << "\n";
  }
  for (const auto& w : r.value("truth_warnings", nlohmann::json::array()))
    std::cerr << "terrain: warning: " << w.get<std::string>() << "\n";
  const auto& h = r["height_recovery"];
  if (h["after"]["cells"].get<std::size_t>() == 0) {
    std::cout << "  object heights: no object cells, not scored\n";
  } else {
    std::cout << "  object heights (" << h["after"]["cells"].get<std::size_t>()
              << " cells)   MAE m   RMSE m  bias m   variance m2\n";
    for (const char* k : {"before", "after"}) {
      std::cout << "    " << std::left << std::setw(28)
                << (std::string(k) == "before" ? "sensed only" : "boundary estimation") << std::right
                << h[k]["mae_m"].get<double>() << "  " << h[k]["rmse_m"].get<double>() << "  "
                << h[k]["bias_m"].get<double>() << "  " << h[k]["variance_m2"].get<double>() << "\n";
    }
    std::cout << "    cells that got an estimate: " << h["estimated_cells"]["after"]["cells"].get<std::size_t>()
              << ", MAE " << h["estimated_cells"]["before"]["mae_m"].get<double>() << " -> "
              << h["estimated_cells"]["after"]["mae_m"].get<double>()
              << " m; terrain cells wrongly raised: " << h["raised_terrain_cells"].get<std::size_t>() << "\n";
  }
  if (h.contains("by_kind")) {
    std::cout << "    by kind:";
    for (const auto& [kind, e] : h["by_kind"].items()) {
      std::cout << " " << kind << " " << e["before"]["mae_m"].get<double>() << " -> "
                << e["after"]["mae_m"].get<double>() << " m (" << e["after"]["cells"].get<std::size_t>() << " cells);";
    }
    std::cout << " sensed as terrain (under crowns): " << h["object_cells_sensed_as_terrain"].get<std::size_t>()
              << " cells\n";
  }
  if (h.contains("by_camera_view")) {
    std::cout << "    cells whose sensed top the camera saw:";
    for (const char* k : {"building_in_camera_view", "tree_in_camera_view"}) {
      if (!h["by_camera_view"].contains(k)) continue;
      const auto& e = h["by_camera_view"][k];
      std::cout << " " << std::string(k).substr(0, std::string(k).find('_')) << " "
                << e["before"]["mae_m"].get<double>() << " -> " << e["after"]["mae_m"].get<double>() << " m ("
                << e["raised_cells"].get<std::size_t>() << " of " << e["after"]["cells"].get<std::size_t>()
                << " raised);";
    }
    if (h["by_camera_view"].contains("never_in_camera_view")) {
      std::cout << " never in view: "
                << h["by_camera_view"]["never_in_camera_view"]["after"]["cells"].get<std::size_t>() << " cells";
    }
    std::cout << "\n    object edge cells raised (a wall or crown within 0.5 m): " << h.value("raised_edge_cells", 0)
              << "\n";
  }
  if (h.contains("footprints")) {
    const auto& f = h["footprints"];
    std::cout << "    building footprints completed: " << f["completed"].get<std::size_t>() << ", roof cells "
              << f["roof_cells"].get<std::size_t>() << " (" << f["object_cells"].get<std::size_t>()
              << " over objects, MAE " << f["on_objects"]["mae_m"].get<double>() << " m; "
              << f["wrongly_filled_cells"].get<std::size_t>() << " over terrain)\n";
  }
  if (h.contains("crown_ground_vertices")) {
    std::cout << "    ground vertices raised under tree crowns: " << h["crown_ground_vertices"].get<std::size_t>()
              << "\n";
  }
  if (h.contains("crown_hull")) {
    const auto& ch = h["crown_hull"];
    std::cout << "    vertices raised by the crowns' visual hull: " << ch["raised_vertices"].get<int>() << " ("
              << ch["crown_voxels"].get<std::size_t>() << " crown voxels in " << ch["columns"].get<std::size_t>()
              << " columns)\n";
  }
  if (h.contains("sky_ceiling")) {
    std::cout << "    raised vertices lowered to the sky's ceiling: " << h["sky_ceiling"]["lowered_vertices"].get<int>()
              << " (of " << h["sky_ceiling"]["vertices_with_ceiling"].get<std::size_t>()
              << " vertices with a ceiling)\n";
  }
  if (h.contains("object_tops")) {
    std::cout << "    object tops the camera saw, at their real height (10 %, at least 1 m) sensed -> recovered:";
    for (const char* k : {"building", "tree"}) {
      const auto& t = h["object_tops"][k];
      std::cout << " " << k << "s " << t["at_height_before"].get<std::size_t>() << " -> "
                << t["at_height_after"].get<std::size_t>() << " of " << t["top_seen"].get<std::size_t>()
                << " (too high " << t["too_high_before"].get<std::size_t>() << " -> "
                << t["too_high_after"].get<std::size_t>() << "; top MAE " << t["before"]["mae_m"].get<double>()
                << " -> " << t["after"]["mae_m"].get<double>() << " m);";
    }
    std::cout << "\n    of those, seen in a frame with their lower part (where the lidar reaches):";
    for (const char* k : {"building", "tree"}) {
      const auto& w = h["object_tops"][k]["lower_part_seen_with_top"];
      std::cout << " " << k << "s " << w["at_height_before"].get<std::size_t>() << " -> "
                << w["at_height_after"].get<std::size_t>() << " of " << w["objects"].get<std::size_t>() << ";";
    }
    std::cout << "\n";
  }
  if (r["height_baselines"].contains("inpainting")) {
    const auto& b = r["height_baselines"];
    std::cout << "  height map over object cells     coverage  MAE m\n";
    for (const char* k : {"sensed_only", "inpainting", "boundary_estimation"}) {
      std::cout << "    " << std::left << std::setw(28) << k << std::right << b[k]["coverage"].get<double>() << "     "
                << b[k]["mae_m"].get<double>() << "\n";
    }
  }
  std::cout << "  boundary coverage: " << r["boundary_coverage_before"].get<double>() << " sensed only, "
            << r["boundary_coverage"].get<double>() << " after recovery";
  if (r.contains("boundary_coverage_by_camera") && r["boundary_coverage_by_camera"].size() > 1) {
    std::cout << " (";
    const char* sep = "";
    for (auto it = r["boundary_coverage_by_camera"].begin(); it != r["boundary_coverage_by_camera"].end(); ++it) {
      std::cout << sep << it.key() << " " << it.value()["after"].get<double>();
      sep = ", ";
    }
    std::cout << ")";
  }
  std::cout << "\n"
            << "  per frame: median " << r["timing"]["total"]["median_ms"].get<double>() << " ms, p95 "
            << r["timing"]["total"]["p95_ms"].get<double>() << " ms (sensing period 100 ms)\n";
}

// scores a finished pipeline against the truth (when there is a world) and writes report.json and
// report.html into out; without a world, report.json holds what needs no truth
nlohmann::json evaluate(const Pipeline& pipeline, const eval::RunTruth& truth, const sim::World* world,
                        const fs::path& out, bool quiet, const eval::EvaluationOptions& scoring) {
  nlohmann::json report;
  if (world) {
    report = eval::evaluateRun(pipeline, truth, *world, scoring);
    if (!quiet) printScorecard(report);
    io::writeFileAtomic(out / "report.html",
                        app::htmlReport(report, pipeline, truth, *world, "terrain reconstruction report"), true);
  } else {
    report["frames"] = pipeline.records().size();
    report["voxels"] = pipeline.map().size();
    report["timing"] = eval::timingJson(pipeline.records());
  }
  report["config"] = nlohmann::json::parse(app::pipelineConfigToJson(pipeline.config()));
  io::writeFileAtomic(out / "report.json", report.dump(1) + "\n", true);
  return report;
}

// sensing on its own thread, processing on this one; writes the outputs into out. With a world,
// the ground truth the source carries is scored (it never reaches the pipeline).
nlohmann::json reconstruct(rig::SensorSource& source, const PipelineConfig& config, const fs::path& out,
                           const sim::World* world, const eval::EvaluationOptions& scoring, bool quiet = false) {
  Pipeline pipeline(source.calibration(), config);
  eval::RunTruth truth(config.voxel_map.voxel_size);
  // boundary images go into out/boundaries (out is the staged directory of the command: a run
  // that fails leaves nothing of it)
  const fs::path boundary_dir = out / "boundaries";
  {
    // made before the sensing starts: a folder that cannot be made ends the run with its reason
    std::error_code ec;
    fs::create_directories(boundary_dir, ec);
    if (ec || !fs::is_directory(boundary_dir))
      throw io::InputError(boundary_dir.string() + ": cannot make the folder for the boundary images (" +
                           (ec ? ec.message() : std::string("a file of that name is in the way")) + ")");
  }
  app::BoundedQueue<SensorFrame> queue(4);
  std::exception_ptr sensing_error;
  std::thread sensing([&] {
    try {
      while (auto f = source.next()) {
        if (world && f->truth) eval::addFrameTruth(truth, *f, source.calibration(), 10);
        if (!queue.push(std::move(f->sensors))) break;
      }
    } catch (...) {
      sensing_error = std::current_exception();
    }
    queue.close();
  });
  app::Progress progress(quiet ? "" : "reconstruct", source.frameCount());
  int done = 0, last_written = -1;
  try {
    while (auto frame = queue.pop()) {
      app::throwIfInterrupted();
      const int before = pipeline.lastBoundaryFrame();
      pipeline.process(*frame);
      // boundary images of every tenth frame (paper Fig. 7)
      if (pipeline.lastBoundaryFrame() != before && pipeline.lastBoundaryFrame() % 10 == 0 &&
          pipeline.lastBoundaryFrame() != last_written) {
        last_written = pipeline.lastBoundaryFrame();
        for (const auto& b : pipeline.lastBoundaries()) {
          // the camera image itself only while it is this frame's
          cv::Mat rgb;
          for (const auto& image : frame->images) {
            if (last_written == frame->index && image.camera == b.camera) rgb = image.rgb;
          }
          app::writeBoundaryImages(boundary_dir, last_written, pipeline.calibration().cameras.at(b.camera).name,
                                   b.images, rgb);
        }
      }
      ++done;
      if (!quiet) progress.update(done);
    }
  } catch (...) {
    queue.close();
    sensing.join();
    throw;
  }
  sensing.join();
  progress.finish();
  if (sensing_error) std::rethrow_exception(sensing_error);
  app::throwIfInterrupted();
  pipeline.finish();
  app::throwIfInterrupted();
  app::writeReconstruction(out, pipeline);
  // summary
  std::vector<double> total, seg;
  for (const auto& r : pipeline.records()) total.push_back(r.total_ms), seg.push_back(r.segmentation_ms);
  std::size_t recovered = 0;
  for (const auto& v : pipeline.mesh().vertices()) recovered += v.raised();
  const auto& s = pipeline.segmentation();
  std::size_t ground = 0;
  for (auto g : s.refined) ground += g;
  if (!quiet)
    std::cout << std::fixed << std::setprecision(1) << "frames " << pipeline.records().size() << ", voxels "
              << pipeline.map().size() << " (" << ground << " ground), mesh vertices "
              << pipeline.mesh().vertices().size() << " (" << recovered << " raised by boundary estimation)\n"
              << "GMRF energy " << s.energy_rough << " (rough) -> " << s.energy_refined << " (refined)\n"
              << "per frame: median " << eval::percentiles(total).median << " ms in all, "
              << eval::percentiles(seg).median << " ms ground segmentation\n";
  // memory growth between the first tenth of the run and its end, against the voxels added
  if (!quiet && pipeline.records().size() >= 10 && pipeline.records().back().resident_bytes > 0) {
    const auto& recs = pipeline.records();
    const auto& a = recs[recs.size() / 10];
    const auto& b = recs.back();
    std::cout << "memory: " << a.resident_bytes / 1e6 << " MB resident after frame " << a.frame << ", "
              << b.resident_bytes / 1e6 << " MB after frame " << b.frame;
    if (b.voxels > a.voxels && b.resident_bytes > a.resident_bytes) {
      std::cout << "; "
                << (static_cast<double>(b.resident_bytes) - static_cast<double>(a.resident_bytes)) /
                       (b.voxels - a.voxels)
                << " bytes per voxel added in between (" << b.voxels - a.voxels << " voxels)";
    }
    std::cout << "\n";
  }
  if (!quiet) {
    for (const auto& w : pipeline.warnings()) std::cerr << "terrain: warning: " << w << "\n";
  }
  // what scoring needs stays beside the outputs, for 'terrain evaluate --run'
  const bool scored = world && truth.voxels.size() > 0;
  if (scored) app::writeRunState(out, pipeline, truth, world->scenePath());
  nlohmann::json report = evaluate(pipeline, truth, scored ? world : nullptr, out, quiet, scoring);
  if (!quiet)
    std::cout << "wrote mesh.ply, mesh.obj, voxels.pcd, height_before.png, height_after.png, boundaries/, report.json"
              << (scored ? ", report.html, state/" : "") << "\n";
  return report;
}

// generate a scenario's scene into out/scene, simulate and reconstruct it into out
// an input a command reads must not lie inside the output directory it replaces
void refuseInputInside(const fs::path& out, const fs::path& input, const std::string& option) {
  const fs::path o = fs::weakly_canonical(fs::absolute(out)), i = fs::weakly_canonical(fs::absolute(input));
  const fs::path rel = i.lexically_relative(o);
  if (!rel.empty() && *rel.begin() != "..") {
    throw io::InputError(option + " " + input.string() + " lies inside --out " + out.string() +
                         ", which the command replaces: give another --out");
  }
}

// where the lidar comes from instead of the simulated rig or the dataset (--lidar, --calibration)
struct LidarChoice {
  std::string endpoint;  // pcap:FILE or udp:HOST:PORT; empty: no replacement
  fs::path calibration;  // empty: the other source's laser table, or the one shipped for the capture's model
  std::string time_base = "auto";
  bool strict = false;       // a cut-off capture is an error
  double mast_height = 1.8;  // [m] a capture reconstructed alone: lidar above the ground
  rig::VelodyneOptions options;
};

// the lidar's counters and warnings beside the run's own, in report.json and warnings.json
void addLidarToOutputs(const fs::path& out, nlohmann::json& report, const rig::VelodyneLidar& lidar,
                       const std::string& cut_off, const std::vector<std::string>& notes) {
  nlohmann::json j = app::lidarCountersJson(lidar.stats(), lidar.positionStats(), lidar.captureStats());
  j["model"] = rig::velodyne::modelName(lidar.model());
  j["calibration"] = lidar.calibration().source;
  std::vector<std::string> warnings = notes;
  if (!cut_off.empty()) warnings.push_back("lidar capture cut off (" + cut_off + "); everything before was decoded");
  const auto& d = lidar.stats();
  if (d.lost > 0)
    warnings.push_back("lidar: " + std::to_string(d.lost) + " data packets lost (gaps in the timestamps)");
  if (d.rejected() > 0)
    warnings.push_back("lidar: " + std::to_string(d.rejected()) + " data packets rejected: " + d.summary());
  j["source"] = lidar.summary();
  report["lidar"] = j;
  nlohmann::json w = nlohmann::json::parse(io::readFile(out / "warnings.json"));
  for (const auto& m : warnings) {
    w.push_back(m);
    std::cerr << "terrain: warning: " << m << "\n";
  }
  report["lidar_warnings"] = warnings;
  io::writeFileAtomic(out / "warnings.json", w.dump(1) + "\n", true);
  io::writeFileAtomic(out / "report.json", report.dump(1) + "\n", true);
}

// the pipeline over `others` with its lidar replaced by Velodyne packets
nlohmann::json reconstructWithLidar(std::unique_ptr<rig::SensorSource> others, const LidarChoice& lidar_choice,
                                    const PipelineConfig& pipe_cfg, const fs::path& out, const sim::World* world,
                                    const eval::EvaluationOptions& scoring) {
  const rig::LidarEndpoint endpoint = rig::LidarEndpoint::parse(lidar_choice.endpoint);
  rig::VelodyneOptions options = lidar_choice.options;
  // beside a dataset or a simulation the packets keep the other sensors' clock unless told otherwise
  options.decoder.time_base = app::parseTimeBase(lidar_choice.time_base, "--lidar-time-base").value_or(0.0);
  rig::LaserCalibration lasers = others->lasers();
  std::string cut_off;
  if (endpoint.kind == rig::LidarEndpoint::Kind::Pcap) {
    // a capture shows its model: its table is the given one, the other source's if it fits, else the shipped one
    rig::CaptureOptions capture;
    capture.calibration = lidar_choice.calibration;
    capture.time_base = options.decoder.time_base;
    const rig::CaptureSetup setup = rig::setupCapture(endpoint.path, capture);
    if (lidar_choice.strict) app::refuseCutOff(endpoint.path, setup.cut_off);
    cut_off = setup.cut_off;
    if (!lidar_choice.calibration.empty() || lasers.laserCount() != setup.lasers.laserCount()) lasers = setup.lasers;
  } else if (!lidar_choice.calibration.empty()) {
    lasers = rig::loadLaserCalibration(lidar_choice.calibration);
  }
  auto lidar = std::make_unique<rig::VelodyneLidar>(endpoint, std::move(lasers), options);
  if (endpoint.kind == rig::LidarEndpoint::Kind::Udp) {
    std::cerr << "reconstruct: listening for lidar packets on " << endpoint.describe() << "\n";
  }
  rig::LidarSwapSource source(std::move(others), std::move(lidar));
  nlohmann::json report = reconstruct(source, pipe_cfg, out, world, scoring);
  std::vector<std::string> notes;
  if (source.pointsWithoutTruth() > 0) {
    notes.push_back(std::to_string(source.pointsWithoutTruth()) +
                    " decoded points had no partner in the other source's truth (not scored)");
  }
  addLidarToOutputs(out, report, source.lidar(), cut_off, notes);
  std::cout << "lidar " << source.lidar().summary() << "\n";
  return report;
}

// a real capture alone: lidar and GPS from its packets, no camera, no gyro, nothing to score
nlohmann::json reconstructCapture(const LidarChoice& lidar_choice, const PipelineConfig& pipe_cfg, const fs::path& out,
                                  bool force, const eval::EvaluationOptions& scoring) {
  const rig::LidarEndpoint endpoint = rig::LidarEndpoint::parse(lidar_choice.endpoint);
  if (endpoint.kind != rig::LidarEndpoint::Kind::Pcap) {
    throw io::InputError("--lidar " + lidar_choice.endpoint +
                         " without --input: a live sensor needs the other sensors "
                         "from a dataset (--input); a capture (pcap:FILE) can be reconstructed alone");
  }
  if (!(lidar_choice.mast_height > 0 && lidar_choice.mast_height < 10)) {
    throw io::InputError("--mast-height " + std::to_string(lidar_choice.mast_height) + ": expected (0, 10) m");
  }
  rig::CaptureOptions capture;
  capture.calibration = lidar_choice.calibration;
  capture.time_base = app::parseTimeBase(lidar_choice.time_base, "--lidar-time-base");
  capture.lidar = lidar_choice.options;
  rig::CaptureSource source(endpoint.path, capture, lidar_choice.mast_height);
  const auto& setup = source.setup();
  if (lidar_choice.strict) app::refuseCutOff(endpoint.path, setup.cut_off);
  refuseInputInside(out, endpoint.path, "--lidar");
  io::StagedDirectory staged(out, force);
  std::cout << "reconstruct: " << endpoint.path << ", an " << rig::velodyne::modelName(setup.model)
            << " capture, calibration " << setup.lasers.source << ", time base " << std::fixed << std::setprecision(0)
            << setup.time_base << " s from the " << setup.time_base_source
            << "; no camera, no gyro; unscored (a real capture has no ground truth)\n";
  nlohmann::json report = reconstruct(source, pipe_cfg, staged.path(), nullptr, scoring);
  std::vector<std::string> notes = {
      "unscored: a real capture has no ground truth; no camera images and no gyro, so nothing "
      "above the lidar's reach is recovered and the heading comes from the GPS track alone"};
  if (!setup.first_fix)
    notes.push_back("the capture has no GPS fix: the rig is taken to stand where it started, heading east");
  report["scored"] = false;
  report["time_base_s"] = setup.time_base;
  report["time_base_source"] = setup.time_base_source;
  addLidarToOutputs(staged.path(), report, source.lidar(), setup.cut_off, notes);
  app::throwIfInterrupted();
  staged.commit();
  std::cout << "lidar " << source.lidar().summary() << "\noutputs in " << fs::absolute(out).string() << "\n";
  return report;
}

// Prints a scene's warnings; throws io::InputError (naming the scene) on its errors.
void checkSceneOrThrow(const sim::World& world, const sim::SimConfig& config, const fs::path& scene) {
  const sim::SceneProblems problems = sim::checkScene(world, config);
  for (const auto& w : problems.warnings) std::cerr << "terrain: warning: " << scene.string() << ": " << w << "\n";
  if (!problems.errors.empty()) throw io::InputError(scene.string() + ": " + problems.errors.front());
}

// Simulates and reconstructs a generated scene of `type` and `seed`, or with a non-empty
// scene_file that scene as it is (not copied: its files must stay where they are for 'evaluate').
nlohmann::json runScenario(const std::string& type, std::uint64_t seed, int frames, const sim::SimConfig& sim_cfg,
                           const PipelineConfig& pipe_cfg, const fs::path& out, bool force, bool quiet,
                           const eval::EvaluationOptions& scoring, const LidarChoice* lidar = nullptr,
                           const fs::path& scene_file = {}) {
  sim::validate(sim_cfg);  // bad settings are refused before anything is written
  std::shared_ptr<sim::World> world;
  if (!scene_file.empty()) {
    world = std::make_shared<sim::World>(scene_file);
    checkSceneOrThrow(*world, sim_cfg, scene_file);
    refuseInputInside(out, scene_file, "--scene");
  }
  // everything goes into a staged directory that replaces out only once the run is complete
  io::StagedDirectory staged(out, force);
  const fs::path dir = staged.path();
  if (!world) {
    scenes::SceneConfig scene_cfg;
    scene_cfg.type = type;
    scene_cfg.seed = seed;
    const fs::path scene_path = dir / "scene" / (type + "_" + std::to_string(seed) + ".xml");
    scenes::writeScene(scenes::generateScene(scene_cfg), scene_path, true);
    world = std::make_shared<sim::World>(scene_path);
  }
  nlohmann::json report;
  if (lidar && !lidar->endpoint.empty()) {
    // camera, GPS and gyro simulated, the lidar from packets (for example 'terrain stream --scene')
    report = reconstructWithLidar(std::make_unique<sim::SimulatedRig>(world, sim_cfg, frames), *lidar, pipe_cfg, dir,
                                  world.get(), scoring);
  } else {
    sim::SimulatedRig rig(world, sim_cfg, frames);
    report = reconstruct(rig, pipe_cfg, dir, world.get(), scoring, quiet);
  }
  app::throwIfInterrupted();
  staged.commit();
  if (!quiet) std::cout << "outputs in " << fs::absolute(out).string() << "\n";
  return report;
}

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

// [bytes] a lower bound on what one recorded frame takes on disk: the lidar's PCD at 24 bytes a
// firing of every laser (about 30 measured on the generated scenes, where most firings return) and
// every camera's images at 3 bytes a pixel (RGB, depth and segmentation PNGs: about 4.5 measured)
std::uintmax_t recordingFrameBytes(const sim::SimulatedRig& rig) {
  std::uintmax_t bytes = static_cast<std::uintmax_t>(rig.firingsPerTurn()) * rig.lasers().laserCount() * 24;
  for (const auto& c : rig.calibration().cameras)
    bytes += static_cast<std::uintmax_t>(c.intrinsics.width) * c.intrinsics.height * 3;
  return bytes;
}

int record(const fs::path& scene_path, int frames, const fs::path& out, bool force, const sim::SimConfig& config,
           bool with_pcap) {
  auto world = std::make_shared<sim::World>(scene_path);
  checkSceneOrThrow(*world, config, scene_path);
  sim::SimulatedRig rig(world, config, frames);
  nlohmann::json producer;
  producer["scene"] = fs::absolute(scene_path).string();
  producer["scene_type"] = world->truth().type;
  producer["scene_seed"] = world->truth().seed;
  producer["simulation"] = nlohmann::json::parse(sim::simConfigToJson(config));
  io::requireSpace(out, recordingFrameBytes(rig) * static_cast<std::uintmax_t>(frames),
                   "recording " + std::to_string(frames) + " frames (" +
                       std::to_string(recordingFrameBytes(rig) / 1000000) + " MB a frame at least)");
  io::StagedDirectory staged(out, force);
  rig::DatasetWriter writer(staged.path(), rig.calibration(), rig.lasers(), producer.dump(), true);
  // the same sweeps as HDL-64E packets in a capture, as the real sensor would have sent them
  std::unique_ptr<rig::pcap::Writer> capture;
  std::unique_ptr<rig::velodyne::PacketEncoder> encoder;
  std::vector<rig::velodyne::TimedPacket> packets;
  // position packets (port 8308) for the GPS fixes: $GPGGA for every fix, $GPRMC (the date) once a
  // simulated second, each at its fix's time
  struct PositionOut {
    double time;
    std::vector<std::uint8_t> payload;
  };
  std::vector<PositionOut> positions;
  long long position_packets = 0;
  double last_rmc_second = -1;
  const auto addPositions = [&](const std::vector<GpsFix>& fixes) {
    for (const GpsFix& f : fixes) {
      const double epoch = rig::pcap::kSimulationEpoch + f.time;
      const auto stamp = static_cast<std::uint32_t>(std::llround(f.time * 1e6) % 3600000000LL);
      positions.push_back({f.time, rig::velodyne::positionPacket(
                                       stamp, rig::velodyne::gpggaSentence(epoch, f.latitude_deg, f.longitude_deg,
                                                                           f.altitude_m, f.sigma_m / 2.5))});
      if (std::floor(f.time) != last_rmc_second) {
        last_rmc_second = std::floor(f.time);
        positions.push_back({f.time, rig::velodyne::positionPacket(
                                         stamp, rig::velodyne::gprmcSentence(epoch, f.latitude_deg, f.longitude_deg))});
      }
    }
  };
  // data and position packets in time order (a fix before the data packets of the same time)
  auto writePackets = [&] {
    std::size_t next = 0;
    for (const auto& p : packets) {
      for (; next < positions.size() && positions[next].time <= p.time; ++next) {
        capture->write(rig::pcap::kSimulationEpoch + positions[next].time, positions[next].payload.data(),
                       positions[next].payload.size(), 8308);
        ++position_packets;
      }
      capture->write(rig::pcap::kSimulationEpoch + p.time, p.payload.data(), p.payload.size());
    }
    positions.erase(positions.begin(), positions.begin() + static_cast<std::ptrdiff_t>(next));
    packets.clear();
  };
  if (with_pcap) {
    capture = std::make_unique<rig::pcap::Writer>(staged.path() / "lidar.pcap", true);
    encoder = std::make_unique<rig::velodyne::PacketEncoder>(rig.lasers(), rig.firingsPerTurn());
  }
  app::Progress progress("record", frames);
  long long points = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (auto frame = rig.next()) {
    app::throwIfInterrupted();
    points += static_cast<long long>(frame->sensors.sweep.points.size());
    writer.write(*frame);
    if (encoder) {
      addPositions(frame->sensors.gps);
      encoder->addSweep(frame->sensors.sweep, packets);
      writePackets();
    }
    progress.update(frame->sensors.index + 1);
  }
  if (encoder) {
    encoder->finish(packets);
    writePackets();
    for (const auto& p : positions) {  // fixes after the last data packet
      capture->write(rig::pcap::kSimulationEpoch + p.time, p.payload.data(), p.payload.size(), 8308);
      ++position_packets;
    }
    capture->close();
    const auto& st = encoder->stats();
    std::cout << "wrote lidar.pcap: " << st.packets << " HDL-64E packets, " << st.points << " returns, "
              << position_packets << " position packets";
    if (st.too_close + st.too_far + st.off_schedule > 0) {
      std::cout << " (" << st.too_close + st.too_far + st.off_schedule << " returns not encodable)";
    }
    std::cout << "\n";
  }
  writer.finish();
  app::throwIfInterrupted();
  staged.commit();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "recorded " << frames << " frames (" << points << " lidar points, " << rig.raysCast() << " rays, "
            << static_cast<long long>(rig.raysCast() / std::max(seconds, 1e-9)) << " rays/s) into "
            << fs::absolute(out).string() << "\n";
  return 0;
}

// sends packets at the sensor's pace (scaled by speed); returns how many went out late
long long sendPaced(rig::UdpSender& out, const std::vector<rig::velodyne::TimedPacket>& packets, double first,
                    std::chrono::steady_clock::time_point t0, double speed) {
  long long late = 0;
  for (const auto& p : packets) {
    const auto due = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>((p.time - first) / speed));
    if (std::chrono::steady_clock::now() > due + std::chrono::milliseconds(5)) ++late;
    std::this_thread::sleep_until(due);
    out.send(p.payload.data(), p.payload.size());
  }
  return late;
}

int stream(const fs::path& pcap_path, const fs::path& scene_path, int frames, const sim::SimConfig& config,
           const std::string& to, double speed) {
  const rig::LidarEndpoint target = rig::LidarEndpoint::parse("udp:" + to, "stream destination");
  if (!(speed > 0 && speed <= 100))
    throw io::InputError("--speed " + std::to_string(speed) + " is out of range (allowed: (0, 100])");
  rig::UdpSender out(target.host, target.port);
  long long sent = 0, late = 0;
  const auto t0 = std::chrono::steady_clock::now();
  if (!pcap_path.empty()) {
    // a capture: its own timestamps set the pace
    rig::pcap::Reader reader(pcap_path, rig::velodyne::kDataPort);
    rig::pcap::Frame f;
    std::vector<rig::velodyne::TimedPacket> one(1);
    double first = -1;
    while (reader.next(f)) {
      if (f.payload.size() != rig::velodyne::kPacketSize) continue;
      if (first < 0) first = f.time;
      one[0].time = f.time;
      std::copy(f.payload.begin(), f.payload.end(), one[0].payload.begin());
      late += sendPaced(out, one, first, t0, speed);
      ++sent;
    }
    std::cerr << "stream: " << reader.stats().summary() << "\n";
  } else {
    // a simulated run (no camera: only the lidar goes out), simulated on its own thread a few
    // sweeps ahead of the sending
    sim::SimConfig cfg = config;
    cfg.camera.enabled = false;
    auto world = std::make_shared<sim::World>(scene_path);
    sim::SimulatedRig rig(world, cfg, frames);
    rig::velodyne::PacketEncoder encoder(rig.lasers(), rig.firingsPerTurn());
    app::BoundedQueue<std::vector<rig::velodyne::TimedPacket>> queue(4);
    std::exception_ptr error;
    std::thread simulation([&] {
      try {
        while (auto frame = rig.next()) {
          std::vector<rig::velodyne::TimedPacket> packets;
          encoder.addSweep(frame->sensors.sweep, packets);
          if (!queue.push(std::move(packets))) break;
        }
        std::vector<rig::velodyne::TimedPacket> last;
        encoder.finish(last);
        queue.push(std::move(last));
      } catch (...) {
        error = std::current_exception();
      }
      queue.close();
    });
    // the first sweep is simulated before the clock starts
    auto first = queue.pop();
    const auto start = std::chrono::steady_clock::now();
    for (auto packets = std::move(first); packets; packets = queue.pop()) {
      late += sendPaced(out, *packets, 0.0, start, speed);
      sent += static_cast<long long>(packets->size());
    }
    simulation.join();
    if (error) std::rethrow_exception(error);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "sent " << sent << " packets to " << target.host << ":" << target.port << " in " << std::fixed
            << std::setprecision(2) << seconds << " s (" << static_cast<long long>(sent / std::max(seconds, 1e-9))
            << " packets/s, " << late << " sent more than 5 ms late)\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "terrain: testbed for robot terrain reconstruction (Song et al. 2012) on simulated and real sensor rigs"};
  app.require_subcommand(1);

  // terrain scenes generate
  CLI::App* scenes_cmd = app.add_subcommand("scenes", "generated MuJoCo scenes with ground truth");
  scenes_cmd->require_subcommand(1);
  CLI::App* gen = scenes_cmd->add_subcommand(
      "generate", "write FILE.xml, FILE.truth.json (and FILE.hfield) for a terrain type and seed");
  scenes::SceneConfig scene_cfg;
  fs::path scene_out;
  bool scene_force = false;
  std::string types;
  for (const auto& t : scenes::sceneTypes()) types += (types.empty() ? "" : ", ") + t;
  gen->add_option("--type", scene_cfg.type, "terrain type: " + types)
      ->capture_default_str()
      ->check(CLI::IsMember(scenes::sceneTypes()));
  gen->add_option("--seed", scene_cfg.seed, "random seed (>= 0); the same type and seed give byte-identical files")
      ->capture_default_str()
      ->check(kSeed);
  gen->add_option("--extent", scene_cfg.extent, "half side of the square scene [m], 20-500")->capture_default_str();
  gen->add_option("--cell", scene_cfg.hfield_cell, "heightfield grid spacing [m], 0.1-5")->capture_default_str();
  gen->add_option("--out", scene_out, "output MJCF file")->required();
  gen->add_flag("--force", scene_force, "overwrite existing files");

  // terrain scenes import
  CLI::App* imp = scenes_cmd->add_subcommand(
      "import",
      "make a MuJoCo world of your own a testbed scene: SCENE.xml (the world, plus a skybox, a light and the "
      "robot with its camera where it has none) and SCENE.truth.json (objects classed from geom names)");
  fs::path imp_world, imp_out, imp_classes;
  std::string imp_path, imp_origin = "0,0,0";
  bool imp_force = false;
  imp->add_option("--mjcf", imp_world, "the world (MJCF)")->required()->check(CLI::ExistingFile);
  imp->add_option("--out", imp_out,
                  "the scene to write (MJCF; its sidecar beside it); in the world's folder when the world "
                  "names files (heightfields, meshes, textures)")
      ->required();
  imp->add_option(
         "--classes", imp_classes,
         "YAML map of class (building, crown, trunk, terrain) to name patterns (case-insensitive substrings of "
         "a geom's, its material's or its body's name), each replacing that class's defaults: building: build, "
         "bldg, house, hall, tower, shed, garage, facade, roof; crown: crown, leaf, leaves, foliage, canopy, "
         "bush, tree; trunk: trunk, bark, stem (checked first: tree_trunk is a trunk); terrain: ground, terrain, "
         "floor, "
         "heightfield, hfield")
      ->check(CLI::ExistingFile);
  imp->add_option(
      "--path", imp_path,
      "the robot's path as waypoints \"x,y;x,y;...\" [m, world]; default: the straight line along x, 90 % of "
      "the terrain long, nearest the terrain's middle with 3.35 m of room to every object (else the one "
      "with the most room, at least 1.35 m: the robot's half width and a metre)");
  imp->add_option("--origin", imp_origin, "the world origin on the globe: latitude,longitude [deg],altitude [m]")
      ->capture_default_str();
  imp->add_flag("--force", imp_force, "overwrite an existing scene and sidecar");

  // terrain record
  CLI::App* rec = app.add_subcommand("record", "drive a scene with the simulated rig and write a dataset");
  sim::SimConfig sim_cfg;
  // record's sim YAML is --sim-config, as for run and stream (--config, its older name, still reads it)
  std::string config_file;
  if (isSubcommand(argc, argv, "record")) {
    config_file = preScan(argc, argv, "--sim-config");
    if (config_file.empty()) config_file = preScan(argc, argv, "--config");
  }
  fs::path rec_scene, rec_out;
  int rec_frames = 60;
  bool rec_force = false;
  rec->add_option("--scene", rec_scene, "scene MJCF file (with its .truth.json sidecar)")->required();
  rec->add_option("--frames", rec_frames,
                  "number of lidar sweeps to record, 1-" + std::to_string(kMaxFrames) +
                      "; refused before anything is written when the filesystem of --out has less space free than "
                      "they take at least (about 7 MB a frame with the surround rig at 640x480)")
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxFrames));
  rec->add_option("--out", rec_out, "output dataset directory")->required();
  rec->add_flag("--force", rec_force,
                "replace an existing, non-empty output directory (whole, once the new one is complete)");
  bool rec_pcap = false;
  rec->add_flag(
      "--pcap", rec_pcap,
      "also write the lidar as HDL-64E packets in OUT/lidar.pcap (Wireshark, VeloView, PCL open it), with the "
      "GPS as position packets (port 8308: $GPGGA for every fix, $GPRMC once a second)");
  try {
    if (!config_file.empty()) sim::loadSimConfig(config_file, sim_cfg);
  } catch (const io::InputError& e) {
    std::cerr << "terrain: error: " << e.what() << "\n";
    return 2;
  }
  addSimOptions(*rec, sim_cfg, config_file, "--sim-config,--config");

  // terrain reconstruct
  CLI::App* recon = app.add_subcommand("reconstruct", "run the pipeline over a recorded dataset");
  PipelineConfig pipe_cfg;
  std::string pipe_config_file = !isSubcommand(argc, argv, "record") ? preScan(argc, argv, "--config") : "";
  std::string histogram = "local", solver = "icm";
  std::vector<std::string> pipe_settings;  // --set KEY=VALUE, applied after --config
  fs::path recon_input, recon_out;
  bool recon_force = false;
  recon->add_option(
      "--input", recon_input,
      "dataset directory (from 'terrain record'); without it, --lidar pcap:FILE reconstructs a real capture "
      "alone (lidar and GPS from its packets, unscored)");
  recon->add_option("--out", recon_out, "output directory")->required();
  recon->add_flag("--force", recon_force,
                  "replace an existing, non-empty output directory (whole, once the new one is complete)");
  LidarChoice lidar_choice;
  auto addLidarOptions = [&lidar_choice](CLI::App& cmd, const std::string& others) {
    cmd.add_option("--lidar", lidar_choice.endpoint,
                   "take the lidar from a Velodyne: pcap:FILE (a capture) or udp:HOST:PORT (live packets, e.g. "
                   "udp:0.0.0.0:2368); camera, GPS and gyro still come from " +
                       others + ", matched by time");
    cmd.add_option("--calibration", lidar_choice.calibration,
                   "laser calibration for --lidar (ROS YAML or db.xml); default: the laser table of " + others);
    cmd.add_option("--lidar-time-base", lidar_choice.time_base,
                   "[s] added to the packets' time since the top of the hour; auto: 0 beside " + others +
                       " (its clock), and for a capture reconstructed alone the hour of its GPS time, else of the "
                       "capture clock")
        ->capture_default_str();
    cmd.add_option("--lidar-idle-timeout", lidar_choice.options.idle_timeout,
                   "[s] a live lidar stream ends after this long without packets")
        ->capture_default_str();
    cmd.add_option("--lidar-first-packet-timeout", lidar_choice.options.first_timeout,
                   "[s] a live lidar stream without a single packet this long is an error (exit 2)")
        ->capture_default_str();
    cmd.add_flag("--strict", lidar_choice.strict,
                 "a cut-off lidar capture is an error (exit 2, nothing written), not a warning");
  };
  addLidarOptions(*recon, "the dataset");
  recon
      ->add_option("--mast-height", lidar_choice.mast_height,
                   "[m] lidar height above the ground, for a capture reconstructed alone")
      ->capture_default_str();
  eval::EvaluationOptions scoring;
  const auto addScoringOptions = [&scoring](CLI::App& cmd) {
    cmd.add_flag("--baselines,!--no-baselines", scoring.ground_baselines,
                 "score the ground segmentation baselines (fixed band, RANSAC plane, PCL's progressive morphological "
                 "filter) beside the method; the filter takes about a minute on a map of millions of voxels "
                 "(default: on)");
  };
  addScoringOptions(*recon);

  // terrain evaluate
  CLI::App* evalc = app.add_subcommand(
      "evaluate",
      "score a finished run (of 'terrain run' or 'terrain reconstruct') again: report.json and report.html");
  fs::path eval_run, eval_out;
  evalc->add_option("--run", eval_run, "the run's output directory (it holds state/)")->required();
  evalc->add_option("--out", eval_out,
                    "where to write report.json and report.html (default: the run directory, replacing its reports)");
  addScoringOptions(*evalc);

  // terrain stream
  CLI::App* strm = app.add_subcommand(
      "stream", "send a capture or a simulated run to a UDP address as HDL-64E packets at the sensor's rate");
  fs::path strm_pcap, strm_scene;
  int strm_frames = 60;
  std::string strm_to = "127.0.0.1:2368", strm_sim_config;
  double strm_speed = 1.0;
  auto* strm_src = strm->add_option("--pcap", strm_pcap, "capture file to replay (its timestamps set the pace)");
  strm->add_option("--scene", strm_scene, "or: scene MJCF file to simulate and send")->excludes(strm_src);
  strm->add_option("--frames", strm_frames, "sweeps to simulate with --scene, 1-" + std::to_string(kMaxFrames))
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxFrames));
  strm->add_option("--sim-config", strm_sim_config,
                   "YAML simulation settings for --scene (as for 'terrain record --sim-config')");
  strm->add_option("--to", strm_to, "destination HOST:PORT (HOST an IPv4 address or localhost)")->capture_default_str();
  strm->add_option("--speed", strm_speed, "pace relative to the real sensor (2: twice as fast), in (0, 100]")
      ->capture_default_str();

  // terrain run
  CLI::App* run =
      app.add_subcommand("run", "generate a scene, simulate the rig and reconstruct, streaming (no dataset on disk)");
  std::string run_scenario = "urban";
  std::uint64_t run_seed = 1;
  int run_frames = 60;
  fs::path run_out = "out/run";
  bool run_force = false;
  sim::SimConfig run_sim;
  std::string sim_config_file = isSubcommand(argc, argv, "run") ? preScan(argc, argv, "--sim-config") : "";
  fs::path run_scene;
  auto* run_scenario_opt = run->add_option("--scenario", run_scenario, "terrain type of the generated scene")
                               ->capture_default_str()
                               ->check(CLI::IsMember(scenes::sceneTypes()));
  auto* run_seed_opt = run->add_option("--seed", run_seed, "scene seed, >= 0 (the sensor noise seed is --noise-seed)")
                           ->capture_default_str()
                           ->check(kSeed);
  run->add_option("--scene", run_scene,
                  "run on this scene (MJCF with its .truth.json sidecar) instead of a generated one; it is checked "
                  "before the simulation (terrain under the path: an error; no skybox, the path within a metre of an "
                  "object, nothing above the lidar's reach: warnings) and used where it is")
      ->check(CLI::ExistingFile)
      ->excludes(run_scenario_opt)
      ->excludes(run_seed_opt);
  run->add_option("--frames", run_frames, "lidar sweeps to simulate, 1-" + std::to_string(kMaxFrames))
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxFrames));
  run->add_option("--out", run_out, "output directory")->capture_default_str();
  run->add_flag("--force", run_force,
                "replace an existing, non-empty output directory (whole, once the new one is complete)");
  addLidarOptions(*run, "the simulated rig");
  addScoringOptions(*run);
  try {
    if (!config_file.empty()) sim::loadSimConfig(config_file, sim_cfg);
    if (!pipe_config_file.empty()) app::loadPipelineConfig(pipe_config_file, pipe_cfg);
    if (!sim_config_file.empty()) sim::loadSimConfig(sim_config_file, run_sim);
  } catch (const io::InputError& e) {
    std::cerr << "terrain: error: " << e.what() << "\n";
    return 2;
  }
  addPipelineOptions(*recon, pipe_cfg, pipe_config_file, histogram, solver, pipe_settings);
  addPipelineOptions(*run, pipe_cfg, pipe_config_file, histogram, solver, pipe_settings);
  run->add_option("--noise-seed", run_sim.seed, "sensor noise seed (>= 0)")->capture_default_str()->check(kSeed);
  run->add_option("--sim-config", sim_config_file,
                  "YAML file with simulation settings (as for 'terrain record --sim-config')");
  run->add_option("--speed", run_sim.robot.speed, "robot speed along the path [m/s]")->capture_default_str();
  run->add_option("--height-cap", run_sim.lidar.height_cap,
                  "lidar returns higher than this above the sensor are dropped [m]")
      ->capture_default_str();
  run->add_option("--threads", run_sim.threads, "lidar simulation threads, 0 = all cores")->capture_default_str();
  addCameraRigOption(*run, run_sim.camera.rig);

  // terrain regress
  CLI::App* reg = app.add_subcommand("regress", "run a suite of scenarios and compare every metric with its baseline");
  fs::path reg_suite, reg_baseline, reg_write, reg_junit, reg_out;
  bool reg_force = false;
  reg->add_option("--suite", reg_suite, "suite YAML: scenarios (type, seed, frames) and metrics with tolerances")
      ->required();
  reg->add_option("--baseline", reg_baseline,
                  "baseline JSON to compare with; any metric past its tolerance fails the run (exit 1)");
  reg->add_option("--write-baseline", reg_write,
                  "run the suite and write its metrics as the new baseline (the only way baselines change)");
  reg->add_option("--junit", reg_junit, "also write the comparison as JUnit XML");
  reg->add_option("--out", reg_out,
                  "directory for the scenarios' outputs (default out/regress-SUITE, reused run after run)");
  std::string reg_shard;
  std::vector<fs::path> reg_merge;
  reg->add_option("--shard", reg_shard,
                  "run only part K of N of the suite (K/N: every N-th scenario from the K-th) and write its results "
                  "and shard.json into --out, for 'regress --merge' (cluster sweeps); never writes a baseline");
  reg->add_option("--merge", reg_merge,
                  "run nothing: merge the --out directories of every shard of the suite, then compare or write the "
                  "baseline as a whole run would (a missing, failed or duplicated shard is an error)")
      ->excludes(reg->get_option("--shard"));
  reg->add_flag("--force", reg_force, "replace an existing --write-baseline file, and write into a non-empty --out");
  bool reg_list = false;
  reg->add_flag("--list", reg_list,
                "run nothing: print the suite's scenarios (of --shard K/N's part only, if given), one id a line "
                "(TYPE_sSEED_fFRAMES)");
  addPipelineOptions(*reg, pipe_cfg, pipe_config_file, histogram, solver, pipe_settings);

  // terrain kitti
  CLI::App* kitti =
      app.add_subcommand("kitti", "score ground segmentation on real KITTI HDL-64E scans with SemanticKITTI labels");
  std::vector<fs::path> kitti_scans;
  fs::path kitti_json;
  double kitti_height = 1.73;
  kitti->add_option("--scan", kitti_scans, "KITTI .bin scan(s); labels are read from the .label file beside each")
      ->required();
  kitti->add_option("--sensor-height", kitti_height, "lidar height above the road [m]")->capture_default_str();
  kitti->add_option("--json", kitti_json, "also write the scores as JSON");
  addPipelineOptions(*kitti, pipe_cfg, pipe_config_file, histogram, solver, pipe_settings, true);

  // terrain lidar inspect / convert
  const auto lidar_cmds = app::addLidarCommands(app);

  // usage errors end as every bad input does: the prefix and exit code 2 (help and version: 0)
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "terrain: error: " << e.what() << "\n"
              << "Run with --help for more information.\n";
    return 2;
  }
  app::installInterruptHandlers();
  try {
    if (gen->parsed()) return generateScene(scene_cfg, scene_out, scene_force);
    if (imp->parsed()) return importScene(imp_world, imp_out, imp_classes, imp_path, imp_origin, imp_force);
    if (const int rc = app::runLidarCommands(*lidar_cmds); rc >= 0) return rc;
    if (rec->parsed()) return record(rec_scene, rec_frames, rec_out, rec_force, sim_cfg, rec_pcap);
    if (evalc->parsed()) {
      app::SavedRun saved = app::readRunState(eval_run);
      if (!fs::exists(saved.scene)) throw io::InputError(saved.scene.string() + ": the run's scene is no longer there");
      const sim::World world(saved.scene);
      const fs::path out = eval_out.empty() ? eval_run : eval_out;
      if (!eval_out.empty()) {
        fs::create_directories(out);
        for (const char* f : {"report.json", "report.html"}) {
          if (fs::exists(out / f))
            throw io::InputError((out / f).string() +
                                 ": exists (give another --out, or leave --out out to replace the run's own reports)");
        }
      }
      evaluate(*saved.pipeline, *saved.truth, &world, out, false, scoring);
      std::cout << "wrote report.json and report.html into " << fs::absolute(out).string() << "\n";
      return 0;
    }
    if (strm->parsed()) {
      if (strm_pcap.empty() == strm_scene.empty()) throw io::InputError("give --pcap FILE or --scene FILE to stream");
      sim::SimConfig cfg;
      if (!strm_sim_config.empty()) sim::loadSimConfig(strm_sim_config, cfg);
      return stream(strm_pcap, strm_scene, strm_frames, cfg, strm_to, strm_speed);
    }
    if (recon->parsed()) {
      applyChoices(pipe_cfg, histogram, solver, pipe_settings);
      if (recon_input.empty()) {
        if (lidar_choice.endpoint.empty())
          throw io::InputError("give --input DATASET, or --lidar pcap:FILE to reconstruct a capture alone");
        reconstructCapture(lidar_choice, pipe_cfg, recon_out, recon_force, scoring);
        return 0;
      }
      auto dataset = std::make_unique<rig::DatasetSource>(recon_input);
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
      refuseInputInside(recon_out, recon_input, "--input");
      if (lidar_choice.endpoint.empty()) {
        if (!lidar_choice.calibration.empty()) throw io::InputError("--calibration applies to --lidar only");
        io::StagedDirectory staged(recon_out, recon_force);
        reconstruct(*dataset, pipe_cfg, staged.path(), world.get(), scoring);
        app::throwIfInterrupted();
        staged.commit();
        std::cout << "outputs in " << fs::absolute(recon_out).string() << "\n";
        return 0;
      }
      // the real-driver path: the lidar from packets, everything else from the dataset
      const auto endpoint = rig::LidarEndpoint::parse(lidar_choice.endpoint);  // refused before anything is written
      if (endpoint.kind == rig::LidarEndpoint::Kind::Pcap) refuseInputInside(recon_out, endpoint.path, "--lidar");
      io::StagedDirectory staged(recon_out, recon_force);
      reconstructWithLidar(std::move(dataset), lidar_choice, pipe_cfg, staged.path(), world.get(), scoring);
      app::throwIfInterrupted();
      staged.commit();
      std::cout << "outputs in " << fs::absolute(recon_out).string() << "\n";
      return 0;
    }
    if (run->parsed()) {
      applyChoices(pipe_cfg, histogram, solver, pipe_settings);
      if (!lidar_choice.endpoint.empty()) rig::LidarEndpoint::parse(lidar_choice.endpoint);
      runScenario(run_scenario, run_seed, run_frames, run_sim, pipe_cfg, run_out, run_force, false, scoring,
                  &lidar_choice, run_scene);
      return 0;
    }
    if (kitti->parsed()) {
      for (const std::string& s : pipe_settings) {
        if (s.rfind("voxel_map.", 0) != 0 && s.rfind("ground.", 0) != 0)
          throw io::InputError("--set " + s +
                               ": kitti segments single scans and reads only voxel_map and ground settings");
      }
      applyChoices(pipe_cfg, histogram, solver, pipe_settings);
      nlohmann::json all;
      std::cout << std::fixed << std::setprecision(3)
                << "scan          method                 F1     IoU    precision recall\n";
      for (const auto& scan_path : kitti_scans) {
        const rig::KittiScan scan = rig::readKittiScan(scan_path);
        fs::path label_path = scan_path;
        label_path.replace_extension(".label");
        const auto labels = rig::readSemanticKittiLabels(label_path, scan.points.size());
        const auto j = eval::scoreKittiScan(scan.points, labels, pipe_cfg.voxel_map, pipe_cfg.ground, kitti_height);
        for (const char* m :
             {"histogram", "gmrf_icm", "gmrf_mincut", "fixed_band", "ransac_plane", "morphological_filter"}) {
          std::cout << std::left << std::setw(14) << scan_path.stem().string() << std::setw(22) << m << std::right
                    << j[m]["f1"].get<double>() << "  " << j[m]["iou"].get<double>() << "  "
                    << j[m]["precision"].get<double>() << "     " << j[m]["recall"].get<double>() << "\n";
        }
        // where the configured solver calls ground wrongly
        const auto& conf = j["confusion"];
        std::vector<std::pair<std::uint64_t, std::string>> wrong;
        for (auto it = conf["by_class"].begin(); it != conf["by_class"].end(); ++it) {
          const std::string name = it.key();
          if (name == "road" || name == "parking" || name == "sidewalk" || name == "other-ground" ||
              name == "terrain" || name == "vegetation")
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
      }
      if (!kitti_json.empty()) io::writeFileAtomic(kitti_json, all.dump(1) + "\n", false);
      return 0;
    }
    if (reg->parsed()) {
      applyChoices(pipe_cfg, histogram, solver, pipe_settings);
      const eval::Suite suite = eval::loadSuite(reg_suite);
      const bool sharded = !reg_shard.empty();
      if (reg_list) {
        if (!reg_merge.empty()) throw io::InputError("--list runs nothing: give it without --merge");
        for (const auto& sc : eval::shardOf(suite, sharded ? eval::parseShard(reg_shard) : eval::Shard{}).scenarios)
          std::cout << sc.id() << "\n";
        return 0;
      }
      if (!reg_write.empty() && !reg_baseline.empty())
        throw io::InputError("give --baseline (to check) or --write-baseline (to refresh), not both");
      if (sharded && !reg_write.empty())
        throw io::InputError("--shard never writes a baseline: merge the shards with --merge and --write-baseline");
      if (!sharded && reg_write.empty() && reg_baseline.empty())
        throw io::InputError("give --baseline FILE to check against, or --write-baseline FILE to refresh it");
      const eval::Shard shard = sharded ? eval::parseShard(reg_shard) : eval::Shard{};
      const eval::Suite part = eval::shardOf(suite, shard);
      const fs::path work =
          reg_out.empty()
              ? fs::path("out") / ("regress-" + suite.name + (sharded ? "-shard" + std::to_string(shard.k) : ""))
              : reg_out;
      // refused before the suite runs, not after
      if (!reg_write.empty() && fs::exists(reg_write) && !reg_force) {
        throw io::InputError(reg_write.string() + ": exists (pass --force to replace it)");
      }
      if (!reg_out.empty() && fs::is_directory(reg_out) && !fs::is_empty(reg_out) && !reg_force) {
        throw io::InputError(
            reg_out.string() +
            ": directory exists and is not empty (pass --force to replace what the suite writes there)");
      }
      // on a cluster node, the cores Slurm gave the task, not every core of the node
      if (const char* cpus = std::getenv("SLURM_CPUS_PER_TASK"); cpus && run_sim.threads == 0) {
        const int n = std::atoi(cpus);
        if (n > 0) run_sim.threads = n;
      }
      eval::Results results;
      if (sharded) {
        // the shard's identity first, its results last: a shard that fails leaves no results to merge
        fs::create_directories(work);
        std::error_code ec;
        fs::remove(work / "suite_results.json", ec);
        io::writeFileAtomic(work / "shard.json", eval::shardJson(suite, shard), true);
      }
      if (!reg_merge.empty()) {
        results = eval::mergeShards(suite, reg_merge);
        std::cerr << "regress: merged " << reg_merge.size() << " shards, " << results.size() << " scenarios\n";
      } else {
        int done = 0;
        for (const auto& sc : part.scenarios) {
          app::throwIfInterrupted();
          std::cerr << "regress: " << sc.id() << " (" << ++done << "/" << part.scenarios.size() << ") ...\n";
          results[sc.id()] = eval::flattenMetrics(
              runScenario(sc.type, sc.seed, sc.frames, run_sim, pipe_cfg, work / sc.id(), true, true, {}));
        }
      }
      fs::create_directories(work);
      // every metric of every scenario, and a summary table beside the per-scenario reports
      nlohmann::json all = results;
      io::writeFileAtomic(work / "suite_results.json", all.dump(1) + "\n", true);
      io::writeFileAtomic(work / "suite_summary.html", eval::suiteSummaryHtml(part, results), true);
      std::cerr << "regress: all metrics in " << (work / "suite_results.json").string() << ", summary in "
                << (work / "suite_summary.html").string() << "\n";
      if (!reg_write.empty()) {
        eval::writeBaseline(reg_write, suite, results, reg_force);
        std::cout << "wrote baseline " << reg_write.string() << " for " << results.size() << " scenarios\n";
        return 0;
      }
      if (reg_baseline.empty()) return 0;  // a shard without a baseline: its results are all it writes
      const eval::RegressionResult res = eval::compare(part, eval::loadBaseline(reg_baseline), results);
      eval::printTable(std::cout, res);
      if (!reg_junit.empty()) io::writeFileAtomic(reg_junit, eval::junitXml(suite, res), true);
      return res.regressions > 0 ? 1 : 0;
    }
  } catch (const app::Interrupted& e) {
    std::cerr << "\nterrain: " << e.what() << ": stopped; the output directory was left as it was\n";
    return e.exitCode();
  } catch (const io::InputError& e) {
    std::cerr << "terrain: error: " << e.what() << "\n";
    return 2;
  } catch (const fs::filesystem_error& e) {
    // a path that cannot be read or written (permissions, a full disk, a file where a folder should be)
    std::cerr << "terrain: error: " << e.path1().string() << ": " << e.code().message() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "terrain: internal error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
