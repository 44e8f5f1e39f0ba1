#pragma once
// What scoring a finished run needs, kept in the run's directory (OUT/state/) so that
// `terrain evaluate --run OUT` scores it again without re-running it: the pipeline's final state
// (voxels, mesh, labels, per-frame records), its configuration and the rig calibration, the truth
// gathered beside the run (per-voxel votes, the true path, camera frames with their segmentation)
// and the scene it ran in. The pipeline itself never reads any of it.

#include "core/pipeline.hpp"
#include "evaluation/report.hpp"

#include <filesystem>
#include <memory>

namespace terrain::app {

inline constexpr const char* kRunStateFormat = "terrain-run-state/6";

// Writes OUT/state/ (state.json, pipeline_config.json, pipeline.bin, truth.bin, cameras/*.png).
// The scene is recorded relative to OUT when it lies inside it.
void writeRunState(const std::filesystem::path& out, const Pipeline& pipeline, const eval::RunTruth& truth,
                   const std::filesystem::path& scene);

struct SavedRun {
  std::unique_ptr<Pipeline> pipeline;
  std::unique_ptr<eval::RunTruth> truth;
  std::filesystem::path scene;
};

// Reads OUT/state/. Throws io::InputError naming the file and what is wrong (missing, another
// format, cut short, inconsistent).
SavedRun readRunState(const std::filesystem::path& out);

}  // namespace terrain::app
