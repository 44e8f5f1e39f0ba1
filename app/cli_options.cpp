#include "app/cli_options.hpp"

#include "app/pipeline_config_io.hpp"
#include "rig/file_io.hpp"

namespace terrain::app {

const CLI::Validator& seedCheck() {
  static const CLI::Validator check(
      [](std::string& s) {
        const bool digits = !s.empty() && s.size() <= 19 && s.find_first_not_of("0123456789") == std::string::npos;
        return digits ? std::string() : "a seed is a whole number from 0 to 10^19, not '" + s + "'";
      },
      "SEED");
  return check;
}

void addCameraRigOption(CLI::App& cmd, std::string& rig) {
  cmd.add_option("--cameras", rig,
                 std::string("camera rig (") + sim::kCameraRigs +
                     "): surround has a front, left, rear and right camera 90 deg apart that see the whole horizon; "
                     "forward is the paper's single forward camera. A sim config's 'cameras' list replaces it")
      ->capture_default_str();
}

void addSimConfigOption(CLI::App& cmd, sim::SimConfig& c, const std::string& flag, const std::string& help) {
  cmd.add_option_function<std::string>(
      flag, [&c](const std::string& file) { sim::loadSimConfig(file, c); }, help);
}

void addSimConfigOption(CLI::App& cmd, sim::SimConfig& c, const std::string& help) {
  addSimConfigOption(cmd, c, "--sim-config", help);
}

void addSimOptions(CLI::App& cmd, sim::SimConfig& c, const std::string& flag) {
  addSimConfigOption(cmd, c, flag,
                     "YAML file with simulation settings (sections robot, lidar, camera, gps, gyro); "
                     "command-line options override it");
  cmd.add_option("--seed", c.seed, "noise seed (>= 0)")->capture_default_str()->check(seedCheck());
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
  cmd.add_option("--width", c.camera.width,
                 "image width [px] of every camera, in [16, 4096] (default: each camera's own, 640)");
  cmd.add_option("--height", c.camera.height,
                 "image height [px] of every camera, in [16, 4096] (default: each camera's own, 480)");
  cmd.add_option("--fovy", c.camera.fovy_deg,
                 "vertical field of view [deg] of every camera, in (0, 180) (default: each camera's own, 75)");
  cmd.add_option("--camera-pitch", c.camera.pitch_deg,
                 "upward tilt [deg] of every camera, in [-45, 45] (default: each camera's own, 8)");
  cmd.add_option("--gps-sigma", c.gps.horizontal_sigma, "GPS horizontal 1-sigma noise [m]")->capture_default_str();
  cmd.add_option("--gyro-noise", c.gyro.noise_sigma, "gyro 1-sigma noise [rad/s]")->capture_default_str();
  cmd.add_option("--gyro-bias", c.gyro.bias_sigma, "1-sigma of the constant gyro bias [rad/s]")->capture_default_str();
}

void addPipelineOptions(CLI::App& cmd, PipelineConfig& c, bool ground_only) {
  cmd.add_option_function<std::string>(
      "--config", [&c](const std::string& file) { loadPipelineConfig(file, c); },
      ground_only ? "YAML file with pipeline settings (of its sections, voxel_map and ground apply here); "
                    "command-line options override it"
                  : "YAML file with pipeline settings (sections pose, voxel_map, ground, boundary, estimation, "
                    "footprint, crown, hull, free_space); command-line options override it");
  cmd.add_option("--voxel-size", c.voxel_map.voxel_size, "voxel edge [m]")->capture_default_str();
  cmd.add_option_function<std::string>(
         "--histogram",
         [&c](const std::string& s) {
           if (!parseHistogram(s, c.ground.histogram))
             throw io::InputError("--histogram must be local or global, not '" + s + "'");
         },
         "ground height histogram: local (tiles following the terrain) or global (the paper's)")
      ->default_str("local");
  cmd.add_option_function<std::string>(
         "--solver",
         [&c](const std::string& s) {
           if (!parseSolver(s, c.ground.solver))
             throw io::InputError("--solver must be icm or mincut, not '" + s + "'");
         },
         "GMRF solver: mincut (the exact minimum) or icm (iterated conditional modes, the paper's)")
      ->default_str("mincut");
  cmd.add_option("--delta", c.ground.delta, "half-width of the ground band around the histogram peak [m]")
      ->capture_default_str();
  cmd.add_option("--alpha", c.ground.alpha, "GMRF single-site weight")->capture_default_str();
  cmd.add_option("--beta", c.ground.beta, "GMRF pair-site Potts weight")->capture_default_str();
  cmd.add_option("--gamma", c.ground.gamma, "GMRF pair-site height-contrast weight")->capture_default_str();
  cmd.add_option("--tile-size", c.ground.tile_size, "local histogram tile edge [m]")->capture_default_str();
  if (!ground_only) {
    cmd.add_option("--segment-every", c.segment_every, "run ground segmentation every N frames")->capture_default_str();
    cmd.add_option("--boundary-threshold", c.boundary.threshold, "boundary gradient threshold (grey levels)")
        ->capture_default_str();
    cmd.add_option("--kx", c.boundary.kx, "weight of horizontal change in the gradient")->capture_default_str();
    cmd.add_option("--ky", c.boundary.ky, "weight of vertical change in the gradient")->capture_default_str();
    cmd.add_flag(
        "--erode-all-directions,!--erode-horizontal", c.boundary.erode_all_directions,
        "erosion keeps thin boundaries of every direction, or near-horizontal ones only (default: near-horizontal)");
    cmd.add_flag("--erode-sloping,!--no-erode-sloping", c.boundary.erode_sloping,
                 "the near-horizontal erosion also keeps boundaries sloping up to 1 row per column, away from "
                 "foliage (roof lines seen obliquely) (default: on)");
    cmd.add_option("--max-distance", c.estimation.max_distance, "vertices farther than this are not raised [m]")
        ->capture_default_str();
    cmd.add_flag(
        "--clear-line,!--no-clear-line", c.estimation.clear_line,
        "skip a frame's estimate when another sensed object stands in the vertex's image column (default: on)");
    cmd.add_flag("--sky-test,!--no-sky-test", c.estimation.require_sky_above,
                 "accept a top boundary only with daylight sky just above it (default: on)");
    cmd.add_flag("--foliage-tops,!--no-foliage-tops", c.estimation.foliage_tops,
                 "a vertex of a crown the lidar saw part of takes the end of the foliage above it as its top, not "
                 "the topmost boundary of its column (default: on)");
    cmd.add_flag("--footprints,!--no-footprints", c.footprint.enabled,
                 "complete building footprints from two walls of a corner and roof them at the walls' recovered "
                 "height (default: on)");
    cmd.add_flag("--crowns,!--no-crowns", c.crown.enabled,
                 "raise the ground under tree crowns measured in the images above sensed trunks (by their foliage "
                 "colour, or against the sky with --set crown.cue=sky) (default: on)");
    cmd.add_flag("--crown-hull,!--no-crown-hull", c.hull.enabled,
                 "raise the ground under tree crowns to the top of their visual hull: the voxels around sensed "
                 "trunks that many images from places min_parallax apart saw as foliage and almost none as sky "
                 "(default: off)");
    cmd.add_flag("--sky-ceiling,!--no-sky-ceiling", c.free_space.enabled,
                 "lower every recovered height to the lowest ray of a sky pixel over its cell: nothing stands "
                 "higher where the cameras saw sky (default: off)");
    cmd.add_option("--spread-distance", c.estimation.spread_distance,
                   "[m] object vertices without an estimate take the nearest estimated one's height up to this far "
                   "away (0: off)")
        ->capture_default_str();
  }
  cmd.add_option_function<std::vector<std::string>>(
      "--set",
      [&c, ground_only](const std::vector<std::string>& settings) {
        for (const std::string& s : settings) {
          if (ground_only && s.rfind("voxel_map.", 0) != 0 && s.rfind("ground.", 0) != 0)
            throw io::InputError("--set " + s +
                                 ": kitti segments single scans and reads only voxel_map and ground settings");
          applyPipelineSetting(s, c, "--set");
        }
      },
      ground_only ? "KEY=VALUE: any voxel_map or ground setting by its name in the --config file (section.field, "
                    "e.g. ground.icm_iterations=4); repeatable; applied after --config and the options above"
                  : "KEY=VALUE: any pipeline setting by its name in the --config file (section.field, e.g. "
                    "crown.cue=sky, ground.icm_iterations=4); repeatable; applied after --config and the options "
                    "above; the settings used are written to report.json");
}

void addScoringOptions(CLI::App& cmd, eval::EvaluationOptions& scoring) {
  cmd.add_flag("--baselines,!--no-baselines", scoring.ground_baselines,
               "score the ground segmentation baselines (fixed band, RANSAC plane, PCL's progressive morphological "
               "filter) beside the method; the filter takes about a minute on a map of millions of voxels "
               "(default: on)");
}

void addLidarOptions(CLI::App& cmd, LidarChoice& choice, const std::string& others) {
  cmd.add_option("--lidar", choice.endpoint,
                 "take the lidar from a Velodyne: pcap:FILE (a capture) or udp:HOST:PORT (live packets, e.g. "
                 "udp:0.0.0.0:2368); camera, GPS and gyro still come from " +
                     others + ", matched by time");
  cmd.add_option("--calibration", choice.calibration,
                 "laser calibration for --lidar (ROS YAML or db.xml); default: the laser table of " + others);
  cmd.add_option("--lidar-time-base", choice.time_base,
                 "[s] added to the packets' time since the top of the hour; auto: 0 beside " + others +
                     " (its clock), for a capture reconstructed alone the hour of its GPS time, else of the "
                     "capture clock, and for a live sensor alone the hour of this machine's clock")
      ->capture_default_str();
  cmd.add_option("--lidar-idle-timeout", choice.options.idle_timeout,
                 "[s] a live lidar stream ends after this long without packets")
      ->capture_default_str();
  cmd.add_option("--lidar-first-packet-timeout", choice.options.first_timeout,
                 "[s] a live lidar stream without a single packet this long is an error (exit 2)")
      ->capture_default_str();
  cmd.add_flag("--strict", choice.strict,
               "a cut-off lidar capture is an error (exit 2, nothing written), not a warning");
}

}  // namespace terrain::app
