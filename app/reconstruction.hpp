#pragma once
// Running the pipeline as the commands do: sensing on its own thread, processing on the caller's,
// the outputs written into a directory and, where there is ground truth, scored.

#include "core/pipeline.hpp"
#include "evaluation/report.hpp"
#include "rig/sensor_source.hpp"
#include "rig/velodyne_source.hpp"
#include "sim/sim_config.hpp"
#include "sim/world.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <string>

namespace terrain::app {

// where the lidar comes from instead of the simulated rig or the dataset (--lidar, --calibration)
struct LidarChoice {
  std::string endpoint;  // pcap:FILE or udp:HOST:PORT; empty: no replacement
  std::filesystem::path
      calibration;  // empty: the other source's laser table, or the one shipped for the capture's model
  std::string time_base = "auto";
  bool strict = false;       // a cut-off capture is an error
  double mast_height = 1.8;  // [m] a capture reconstructed alone: lidar above the ground
  // a live sensor reconstructed alone: the port of its position packets (0: none are read)
  std::uint16_t position_port = rig::velodyne::kPositionPort;
  rig::VelodyneOptions options;
};

// Scores a finished pipeline against the truth (when there is a world) and writes report.json and
// report.html into out, printing the scorecard unless quiet; without a world, report.json holds
// what needs no truth.
nlohmann::json writeReport(const Pipeline& pipeline, const eval::RunTruth& truth, const sim::World* world,
                           const std::filesystem::path& out, bool quiet, const eval::EvaluationOptions& scoring);

// Runs the pipeline over source and writes its outputs into out (which exists; the command's
// staged directory). With a world, the ground truth the source carries is scored (it never
// reaches the pipeline) and what scoring needs is kept in out/state for 'terrain evaluate'.
nlohmann::json reconstruct(rig::SensorSource& source, const PipelineConfig& config, const std::filesystem::path& out,
                           const sim::World* world, const eval::EvaluationOptions& scoring, bool quiet = false);

// The pipeline over `others` with its lidar replaced by Velodyne packets (a capture or a live
// stream); the lidar's counters and warnings go into report.json and warnings.json.
nlohmann::json reconstructWithLidar(std::unique_ptr<rig::SensorSource> others, const LidarChoice& lidar,
                                    const PipelineConfig& config, const std::filesystem::path& out,
                                    const sim::World* world, const eval::EvaluationOptions& scoring);

// A real capture (lidar and GPS from its packets), with the camera images and gyro samples of a
// sensor folder (rig/sensor_folder.hpp) when `sensors` names one, else alone (no camera, no gyro),
// unscored, into out, replaced whole (with force) once complete.
nlohmann::json reconstructCapture(const LidarChoice& lidar, const PipelineConfig& config,
                                  const std::filesystem::path& out, bool force, const eval::EvaluationOptions& scoring,
                                  const std::filesystem::path& sensors = {});

// Simulates and reconstructs a generated scene of `type` and `seed` into out (the scene in
// out/scene), or with a non-empty scene_file that scene as it is (not copied: its files must stay
// where they are for 'evaluate'); out is replaced whole (with force) once complete. With a lidar
// endpoint, the lidar comes from its packets and the rest from the simulation.
nlohmann::json runScenario(const std::string& type, std::uint64_t seed, int frames, const sim::SimConfig& sim_cfg,
                           const PipelineConfig& pipe_cfg, const std::filesystem::path& out, bool force, bool quiet,
                           const eval::EvaluationOptions& scoring, const LidarChoice* lidar = nullptr,
                           const std::filesystem::path& scene_file = {});

// Throws io::InputError when input lies inside out, the directory a command replaces (option
// names the input in the message).
void refuseInputInside(const std::filesystem::path& out, const std::filesystem::path& input, const std::string& option);

// Prints a scene's warnings; throws io::InputError (naming the scene) on its errors.
void checkSceneOrThrow(const sim::World& world, const sim::SimConfig& config, const std::filesystem::path& scene);

}  // namespace terrain::app
