// libFuzzer target: arbitrary text as a calibration file (ROS YAML or db.xml). The parser must
// either return a table that passes its own checks or throw io::InputError; anything else
// (another exception, a crash) is a bug.

#include "rig/file_io.hpp"
#include "rig/velodyne_calibration.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const terrain::rig::LaserCalibration c = terrain::rig::parseLaserCalibration(text, "fuzz.yaml");
    if (c.laserCount() != 16 && c.laserCount() != 32 && c.laserCount() != 64) std::abort();
    for (const auto& l : c.lasers) {
      if (!std::isfinite(l.vert_correction) || !std::isfinite(l.dist_correction)) std::abort();
    }
  } catch (const terrain::io::InputError&) {
  }
  return 0;
}
