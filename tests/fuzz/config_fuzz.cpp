// libFuzzer target: arbitrary text as a settings file, read both as a simulation config (terrain
// record/run --sim-config) and as a pipeline config (--config). Each loader must either fill its
// config, which then passes or fails validation with io::InputError, or throw io::InputError naming
// the file and line; anything else (a YAML exception escaping, a crash) is a bug.

#include "app/pipeline_config_io.hpp"
#include "rig/file_io.hpp"
#include "sim/sim_config.hpp"

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>

#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/dev/shm/terrain-config-fuzz-" + std::to_string(getpid()) + ".yaml";
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    terrain::sim::SimConfig sim;
    terrain::sim::loadSimConfig(path, sim);
    terrain::sim::validate(sim);
  } catch (const terrain::io::InputError&) {
  }
  try {
    terrain::PipelineConfig pipeline;
    terrain::app::loadPipelineConfig(path, pipeline);
    terrain::app::validate(pipeline);
  } catch (const terrain::io::InputError&) {
  }
  return 0;
}
