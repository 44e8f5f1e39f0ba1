// libFuzzer target: arbitrary bytes as a stream of lidar packets of arbitrary sizes, through
// the HDL-64E and HDL-32E decoders. Bad packets must be counted, never crash or reach a sweep.

#include "rig/velodyne_packet.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace {

using namespace terrain;
using namespace terrain::rig;

LaserCalibration table(int lasers, double offset) {
  LaserCalibration c;
  c.source = "fuzz";
  for (int i = 0; i < lasers; ++i) {
    LaserCorrection l;
    l.id = i;
    l.vert_correction = -0.4 + 0.6 * i / lasers;
    l.rot_correction = 0.01 * (i % 5);
    l.dist_correction = 1.2 + offset;
    l.vert_offset = offset;
    l.horiz_offset = -offset;
    c.lasers.push_back(l);
  }
  return c;
}

void check(const LidarSweep& s) {
  for (const auto& p : s.points) {
    // every point of a sweep comes from a checked packet: finite, within the 16-bit range
    if (!(p.x == p.x) || !(p.y == p.y) || !(p.z == p.z) || p.x * p.x + p.y * p.y + p.z * p.z > 200.0f * 200.0f)
      std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const LaserCalibration c64 = table(64, 0.1), c32 = table(32, 0.0);
  velodyne::SweepAssembler a64(c64), a32(c32);
  std::vector<LidarSweep> out;
  // the first byte of each chunk picks its length: mostly whole packets, sometimes cut or padded
  std::size_t pos = 0;
  while (pos < size) {
    const std::uint8_t pick = data[pos++];
    std::size_t n = velodyne::kPacketSize;
    if (pick % 8 == 1) n = pick;                                  // short
    if (pick % 8 == 2) n = velodyne::kPacketSize + pick % 3 + 1;  // oversized
    n = std::min(n, size - pos);
    a64.push(data + pos, n, out);
    a32.push(data + pos, n, out);
    pos += n;
  }
  if (auto s = a64.flush()) out.push_back(*s);
  if (auto s = a32.flush()) out.push_back(*s);
  for (const auto& s : out) check(s);
  return 0;
}
