// terrain: the testbed's command-line entry point. Subcommands:
//   scenes generate   write a generated MJCF scene with its ground truth
//   record            drive a scene with the simulated rig and write a dataset
#include "app/progress.hpp"
#include "rig/dataset.hpp"
#include "rig/file_io.hpp"
#include "scenes/scene_generator.hpp"
#include "sim/simulated_rig.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstring>
#include <iostream>

namespace {

using namespace terrain;
namespace fs = std::filesystem;

// the value of "--config FILE" if present, read before the other options so that the command line
// overrides the file
std::string preScanConfig(int argc, char** argv) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], "--config") == 0) return argv[i + 1];
  }
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--config=", 9) == 0) return argv[i] + 9;
  }
  return {};
}

// options that fill the simulation settings; defaults shown in --help
void addSimOptions(CLI::App& cmd, sim::SimConfig& c, std::string& config_file) {
  cmd.add_option("--config", config_file, "YAML file with simulation settings (sections robot, lidar, camera, gps, gyro); "
                                          "command-line options override it");
  cmd.add_option("--seed", c.seed, "noise seed")->capture_default_str();
  cmd.add_option("--threads", c.threads, "lidar worker threads, 0 = all cores (output does not depend on it)")->capture_default_str();
  cmd.add_option("--speed", c.robot.speed, "robot speed along the path [m/s]")->capture_default_str();
  cmd.add_option("--mast-height", c.robot.mast_height, "lidar height above the ground [m]")->capture_default_str();
  cmd.add_option("--lidar-calibration", c.lidar.calibration,
                 "Velodyne calibration file (ROS YAML or db.xml); default: the shipped HDL-64E S2");
  cmd.add_option("--rotation-hz", c.lidar.rotation_hz, "lidar spin rate [Hz], 5-15")->capture_default_str();
  cmd.add_option("--max-range", c.lidar.max_range, "lidar maximum range [m]")->capture_default_str();
  cmd.add_option("--range-noise", c.lidar.range_noise, "1-sigma range noise [m]")->capture_default_str();
  cmd.add_option("--laser-bias", c.lidar.laser_bias, "1-sigma of a fixed per-laser range bias [m]")->capture_default_str();
  cmd.add_option("--dropout", c.lidar.dropout, "probability a return is lost")->capture_default_str();
  cmd.add_option("--height-cap", c.lidar.height_cap, "returns higher than this above the sensor are dropped [m]")->capture_default_str();
  cmd.add_flag("!--no-camera", c.camera.enabled, "do not render camera frames");
  cmd.add_option("--width", c.camera.width, "camera image width [px]")->capture_default_str();
  cmd.add_option("--height", c.camera.height, "camera image height [px]")->capture_default_str();
  cmd.add_option("--fovy", c.camera.fovy_deg, "camera vertical field of view [deg]")->capture_default_str();
  cmd.add_option("--camera-pitch", c.camera.pitch_deg, "camera upward tilt [deg]")->capture_default_str();
  cmd.add_option("--gps-sigma", c.gps.horizontal_sigma, "GPS horizontal 1-sigma noise [m]")->capture_default_str();
  cmd.add_option("--gyro-noise", c.gyro.noise_sigma, "gyro 1-sigma noise [rad/s]")->capture_default_str();
  cmd.add_option("--gyro-bias", c.gyro.bias_sigma, "1-sigma of the constant gyro bias [rad/s]")->capture_default_str();
}

int generateScene(const scenes::SceneConfig& cfg, const fs::path& out, bool force) {
  const scenes::GeneratedScene scene = scenes::generateScene(cfg);
  scenes::writeScene(scene, out, force);
  std::cout << "wrote " << out.string() << " (" << scene.truth.objects.size() << " objects) and "
            << scenes::truthPathFor(out).string() << "\n";
  return 0;
}

int record(const fs::path& scene_path, int frames, const fs::path& out, bool force, const sim::SimConfig& config) {
  auto world = std::make_shared<sim::World>(scene_path);
  sim::SimulatedRig rig(world, config, frames);
  nlohmann::json producer;
  producer["scene"] = fs::absolute(scene_path).string();
  producer["scene_type"] = world->truth().type;
  producer["scene_seed"] = world->truth().seed;
  producer["simulation"] = nlohmann::json::parse(sim::simConfigToJson(config));
  rig::DatasetWriter writer(out, rig.calibration(), rig.lasers(), producer.dump(), force);
  app::Progress progress("record", frames);
  long long points = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (auto frame = rig.next()) {
    points += static_cast<long long>(frame->sensors.sweep.points.size());
    writer.write(*frame);
    progress.update(frame->sensors.index + 1);
  }
  writer.finish();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "recorded " << frames << " frames (" << points << " lidar points, " << rig.raysCast() << " rays, "
            << static_cast<long long>(rig.raysCast() / std::max(seconds, 1e-9)) << " rays/s) into "
            << fs::absolute(out).string() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"terrain: testbed for robot terrain reconstruction (Song et al. 2012) on simulated and real sensor rigs"};
  app.require_subcommand(1);

  // terrain scenes generate
  CLI::App* scenes_cmd = app.add_subcommand("scenes", "generated MuJoCo scenes with ground truth");
  scenes_cmd->require_subcommand(1);
  CLI::App* gen = scenes_cmd->add_subcommand("generate", "write FILE.xml, FILE.truth.json (and FILE.hfield) for a terrain type and seed");
  scenes::SceneConfig scene_cfg;
  fs::path scene_out;
  bool scene_force = false;
  std::string types;
  for (const auto& t : scenes::sceneTypes()) types += (types.empty() ? "" : ", ") + t;
  gen->add_option("--type", scene_cfg.type, "terrain type: " + types)->capture_default_str()->check(CLI::IsMember(scenes::sceneTypes()));
  gen->add_option("--seed", scene_cfg.seed, "random seed; the same type and seed give byte-identical files")->capture_default_str();
  gen->add_option("--extent", scene_cfg.extent, "half side of the square scene [m], 20-500")->capture_default_str();
  gen->add_option("--cell", scene_cfg.hfield_cell, "heightfield grid spacing [m], 0.1-5")->capture_default_str();
  gen->add_option("--out", scene_out, "output MJCF file")->required();
  gen->add_flag("--force", scene_force, "overwrite existing files");

  // terrain record
  CLI::App* rec = app.add_subcommand("record", "drive a scene with the simulated rig and write a dataset");
  sim::SimConfig sim_cfg;
  std::string config_file = preScanConfig(argc, argv);
  fs::path rec_scene, rec_out;
  int rec_frames = 60;
  bool rec_force = false;
  rec->add_option("--scene", rec_scene, "scene MJCF file (with its .truth.json sidecar)")->required();
  rec->add_option("--frames", rec_frames, "number of lidar sweeps to record")->capture_default_str();
  rec->add_option("--out", rec_out, "output dataset directory")->required();
  rec->add_flag("--force", rec_force, "write into an existing, non-empty directory");
  try {
    if (!config_file.empty()) sim::loadSimConfig(config_file, sim_cfg);
  } catch (const io::InputError& e) {
    std::cerr << "terrain: error: " << e.what() << "\n";
    return 2;
  }
  addSimOptions(*rec, sim_cfg, config_file);

  CLI11_PARSE(app, argc, argv);
  try {
    if (gen->parsed()) return generateScene(scene_cfg, scene_out, scene_force);
    if (rec->parsed()) return record(rec_scene, rec_frames, rec_out, rec_force, sim_cfg);
  } catch (const io::InputError& e) {
    std::cerr << "terrain: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "terrain: internal error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
