// libFuzzer target: arbitrary text as a scene's truth sidecar (terrain-scene-truth/1 JSON). The
// loader must either return truth that passes its own checks or throw io::InputError naming the
// file; anything else (another exception such as a JSON type error, a crash) is a bug.

#include "rig/file_io.hpp"
#include "scenes/scene_truth.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // the loader reads a file: the input goes to one in memory-backed /dev/shm
  static const std::string path = "/dev/shm/terrain-sidecar-fuzz-" + std::to_string(getpid()) + ".truth.json";
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    const terrain::scenes::SceneTruth t = terrain::scenes::loadTruth(path);
    for (const auto& o : t.objects) {
      if (o.footprint.size() < 3 || !std::isfinite(o.base_height) || !std::isfinite(o.top_height)) std::abort();
    }
    for (std::size_t i = 1; i < t.path.size(); ++i) {
      if ((t.path[i] - t.path[i - 1]).norm() == 0) std::abort();
    }
  } catch (const terrain::io::InputError&) {
  }
  return 0;
}
