#pragma once
// Options that several subcommands share, each with one name and one meaning everywhere. A
// settings file (--sim-config, --config) is read when the command line is parsed, before the
// options that follow it in this file's order, so that an option given on the command line
// overrides the file's value wherever it stands.

#include "app/reconstruction.hpp"
#include "core/pipeline.hpp"
#include "evaluation/report.hpp"
#include "sim/sim_config.hpp"

#include <CLI/CLI.hpp>

#include <string>

namespace terrain::app {

// the most sweeps one command simulates or records: 100,000 sweeps are 2.8 hours at 10 Hz, and a
// recording of them at 640 x 480 with four cameras some 400 GB
constexpr int kMaxFrames = 100000;

// A seed: a whole number from 0 (CLI11 reads "-1" into an unsigned seed as 2^64 - 1).
const CLI::Validator& seedCheck();

// --cameras: the named camera rig
void addCameraRigOption(CLI::App& cmd, std::string& rig);

// --sim-config (read into c as the command line is parsed; `flag` may add older names) and every
// simulation option
void addSimOptions(CLI::App& cmd, sim::SimConfig& c, const std::string& flag = "--sim-config");
// --sim-config alone: the file read into c as the command line is parsed
void addSimConfigOption(CLI::App& cmd, sim::SimConfig& c, const std::string& help);

// --config (read into c as the command line is parsed), the pipeline's options and --set
// KEY=VALUE (applied last). With ground_only, only the voxel map's and the ground segmentation's
// (a command that segments single scans), and --set refuses any other section. The options do not
// check ranges: call app::validate(c) once the command line is parsed.
void addPipelineOptions(CLI::App& cmd, PipelineConfig& c, bool ground_only = false);

// --baselines / --no-baselines
void addScoringOptions(CLI::App& cmd, eval::EvaluationOptions& scoring);

// --lidar and the options of the lidar that replaces the other source's; `others` names that source
// in the help ("the dataset", "the simulated rig")
void addLidarOptions(CLI::App& cmd, LidarChoice& choice, const std::string& others);

}  // namespace terrain::app
