#include "app/reconstruction.hpp"

#include "app/bounded_queue.hpp"
#include "app/html_report.hpp"
#include "app/interrupt.hpp"
#include "app/lidar_commands.hpp"
#include "app/outputs.hpp"
#include "app/pipeline_config_io.hpp"
#include "app/progress.hpp"
#include "app/run_state.hpp"
#include "app/scorecard.hpp"
#include "evaluation/metrics.hpp"
#include "rig/file_io.hpp"
#include "scenes/scene_generator.hpp"
#include "sim/scene_checks.hpp"
#include "sim/simulated_rig.hpp"

#include <exception>
#include <iomanip>
#include <iostream>
#include <optional>
#include <thread>

namespace terrain::app {

namespace fs = std::filesystem;

nlohmann::json writeReport(const Pipeline& pipeline, const eval::RunTruth& truth, const sim::World* world,
                           const fs::path& out, bool quiet, const eval::EvaluationOptions& scoring) {
  nlohmann::json report;
  if (world) {
    report = eval::evaluateRun(pipeline, truth, *world, scoring);
    if (!quiet) printScorecard(std::cout, report);
    io::writeFileAtomic(out / "report.html",
                        htmlReport(report, pipeline, truth, *world, "terrain reconstruction report"), true);
  } else {
    report["frames"] = pipeline.records().size();
    report["voxels"] = pipeline.map().size();
    report["timing"] = eval::timingJson(pipeline.records());
  }
  report["config"] = nlohmann::json::parse(pipelineConfigToJson(pipeline.config()));
  io::writeFileAtomic(out / "report.json", report.dump(1) + "\n", true);
  return report;
}

nlohmann::json reconstruct(rig::SensorSource& source, const PipelineConfig& config, const fs::path& out,
                           const sim::World* world, const eval::EvaluationOptions& scoring, bool quiet) {
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
  BoundedQueue<SensorFrame> queue(4);
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
  Progress progress(quiet ? "" : "reconstruct", source.frameCount());
  int done = 0, last_written = -1;
  try {
    while (auto frame = queue.pop()) {
      throwIfInterrupted();
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
          writeBoundaryImages(boundary_dir, last_written, pipeline.calibration().cameras.at(b.camera).name, b.images,
                              rgb);
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
  throwIfInterrupted();
  pipeline.finish();
  throwIfInterrupted();
  writeReconstruction(out, pipeline);
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
  if (scored) writeRunState(out, pipeline, truth, world->scenePath());
  nlohmann::json report = writeReport(pipeline, truth, scored ? world : nullptr, out, quiet, scoring);
  if (!quiet)
    std::cout << "wrote mesh.ply, mesh.obj, voxels.pcd, height_before.png, height_after.png, boundaries/, report.json"
              << (scored ? ", report.html, state/" : "") << "\n";
  return report;
}

void refuseInputInside(const fs::path& out, const fs::path& input, const std::string& option) {
  const fs::path o = fs::weakly_canonical(fs::absolute(out)), i = fs::weakly_canonical(fs::absolute(input));
  const fs::path rel = i.lexically_relative(o);
  if (!rel.empty() && *rel.begin() != "..") {
    throw io::InputError(option + " " + input.string() + " lies inside --out " + out.string() +
                         ", which the command replaces: give another --out");
  }
}

namespace {

// the lidar's counters and warnings beside the run's own, in report.json and warnings.json
void addLidarToOutputs(const fs::path& out, nlohmann::json& report, const rig::VelodyneLidar& lidar,
                       const std::string& cut_off, const std::vector<std::string>& notes) {
  nlohmann::json j = lidarCountersJson(lidar.stats(), lidar.positionStats(), lidar.captureStats());
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

}  // namespace

nlohmann::json reconstructWithLidar(std::unique_ptr<rig::SensorSource> others, const LidarChoice& lidar_choice,
                                    const PipelineConfig& pipe_cfg, const fs::path& out, const sim::World* world,
                                    const eval::EvaluationOptions& scoring) {
  const rig::LidarEndpoint endpoint = rig::LidarEndpoint::parse(lidar_choice.endpoint);
  rig::VelodyneOptions options = lidar_choice.options;
  // beside a dataset or a simulation the packets keep the other sensors' clock unless told otherwise
  options.decoder.time_base = parseTimeBase(lidar_choice.time_base, "--lidar-time-base").value_or(0.0);
  rig::LaserCalibration lasers = others->lasers();
  std::string cut_off;
  if (endpoint.kind == rig::LidarEndpoint::Kind::Pcap) {
    // a capture shows its model: its table is the given one, the other source's if it fits, else the shipped one
    rig::CaptureOptions capture;
    capture.calibration = lidar_choice.calibration;
    capture.time_base = options.decoder.time_base;
    const rig::CaptureSetup setup = rig::setupCapture(endpoint.path, capture);
    if (lidar_choice.strict) refuseCutOff(endpoint.path, setup.cut_off);
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

nlohmann::json reconstructCapture(const LidarChoice& lidar_choice, const PipelineConfig& pipe_cfg, const fs::path& out,
                                  bool force, const eval::EvaluationOptions& scoring, const fs::path& sensors_dir) {
  const rig::LidarEndpoint endpoint = rig::LidarEndpoint::parse(lidar_choice.endpoint);
  const bool live = endpoint.kind == rig::LidarEndpoint::Kind::Udp;
  if (live && !sensors_dir.empty()) {
    throw io::InputError("--sensors " + sensors_dir.string() +
                         ": a sensor folder goes with a capture (pcap:FILE); a live sensor is reconstructed from "
                         "its lidar and GPS packets alone");
  }
  if (!(lidar_choice.mast_height > 0 && lidar_choice.mast_height < 10)) {
    throw io::InputError("--mast-height " + std::to_string(lidar_choice.mast_height) + ": expected (0, 10) m");
  }
  rig::CaptureOptions capture;
  capture.calibration = lidar_choice.calibration;
  capture.time_base = parseTimeBase(lidar_choice.time_base, "--lidar-time-base");
  capture.lidar = lidar_choice.options;
  capture.position_port = lidar_choice.position_port;
  std::shared_ptr<const rig::SensorFolder> sensors;
  if (!sensors_dir.empty()) sensors = std::make_shared<rig::SensorFolder>(sensors_dir);
  if (live) {
    std::cerr << "reconstruct: listening for lidar packets on " << endpoint.describe();
    if (capture.position_port != 0) std::cerr << " and position packets on port " << capture.position_port;
    std::cerr << "\n";
  } else {
    refuseInputInside(out, endpoint.path, "--lidar");
  }
  if (sensors) refuseInputInside(out, sensors_dir, "--sensors");
  // a capture is checked before the output is touched; for a live sensor an output that cannot be
  // written is refused before the sensor is waited for
  std::optional<io::StagedDirectory> staged;
  if (live) staged.emplace(out, force);
  auto source = live ? std::make_unique<rig::CaptureSource>(endpoint, capture, lidar_choice.mast_height)
                     : std::make_unique<rig::CaptureSource>(endpoint.path, capture, lidar_choice.mast_height, sensors);
  const auto& setup = source->setup();
  if (lidar_choice.strict && !live) refuseCutOff(endpoint.path, setup.cut_off);
  if (!live) staged.emplace(out, force);
  // what the rest of the rig is
  std::string others = "no camera, no gyro";
  if (sensors) {
    const auto& cameras = sensors->calibration().cameras;
    others = std::to_string(cameras.size()) + (cameras.size() == 1 ? " camera (" : " cameras (");
    for (std::size_t c = 0; c < cameras.size(); ++c) others += (c ? ", " : "") + cameras[c].name;
    others += ", " + std::to_string(sensors->images()) + " images) and " +
              (sensors->gyroSamples() ? std::to_string(sensors->gyroSamples()) + " gyro samples" : "no gyro") +
              " from " + sensors_dir.string();
  }
  std::cout << "reconstruct: " << (live ? endpoint.describe() : endpoint.path) << ", an "
            << rig::velodyne::modelName(setup.model) << (live ? " sensor" : " capture") << ", calibration "
            << setup.lasers.source << ", time base " << std::fixed << std::setprecision(0) << setup.time_base
            << " s from the " << setup.time_base_source << "; " << others << "; unscored (a real "
            << (live ? "sensor" : "capture") << " has no ground truth)\n";
  nlohmann::json report = reconstruct(*source, pipe_cfg, staged->path(), nullptr, scoring);
  std::vector<std::string> notes = {std::string("unscored: a real ") + (live ? "sensor" : "capture") +
                                    " has no ground truth"};
  if (!sensors || sensors->calibration().cameras.empty())
    notes.push_back("no camera images, so nothing above the lidar's reach is recovered");
  if (!sensors || sensors->gyroSamples() == 0)
    notes.push_back("no gyro, so the heading comes from the GPS track alone");
  report["sensors"] = others;
  if (!setup.first_fix) {
    notes.push_back(std::string(live ? "no GPS fix came in the first 2 s" : "the capture has no GPS fix") +
                    ": the rig is taken to stand where it started, heading east");
  }
  report["scored"] = false;
  report["time_base_s"] = setup.time_base;
  report["time_base_source"] = setup.time_base_source;
  addLidarToOutputs(staged->path(), report, source->lidar(), setup.cut_off, notes);
  throwIfInterrupted();
  staged->commit();
  std::cout << "lidar " << source->lidar().summary() << "\noutputs in " << fs::absolute(out).string() << "\n";
  return report;
}

void checkSceneOrThrow(const sim::World& world, const sim::SimConfig& config, const fs::path& scene) {
  const sim::SceneProblems problems = sim::checkScene(world, config);
  for (const auto& w : problems.warnings) std::cerr << "terrain: warning: " << scene.string() << ": " << w << "\n";
  if (!problems.errors.empty()) throw io::InputError(scene.string() + ": " + problems.errors.front());
}

nlohmann::json runScenario(const std::string& type, std::uint64_t seed, int frames, const sim::SimConfig& sim_cfg,
                           const PipelineConfig& pipe_cfg, const fs::path& out, bool force, bool quiet,
                           const eval::EvaluationOptions& scoring, const LidarChoice* lidar,
                           const fs::path& scene_file) {
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
  throwIfInterrupted();
  staged.commit();
  if (!quiet) std::cout << "outputs in " << fs::absolute(out).string() << "\n";
  return report;
}

}  // namespace terrain::app
