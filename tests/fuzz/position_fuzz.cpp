// libFuzzer target: arbitrary bytes as an NMEA sentence, a position packet and a data packet's
// model bytes. Nothing may crash; a fix that parses must be a place on the Earth.

#include "rig/velodyne_packet.hpp"
#include "rig/velodyne_position.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

using namespace terrain::rig;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (const auto fix = velodyne::parseNmea(text)) {
    if (!(std::abs(fix->latitude_deg) <= 90.0) || !(std::abs(fix->longitude_deg) <= 180.0)) std::abort();
    if (!(fix->time_of_day >= 0.0 && fix->time_of_day < 86401.0)) std::abort();
    if (fix->epoch && !std::isfinite(*fix->epoch)) std::abort();
  }
  if (const auto packet = velodyne::parsePositionPacket(data, size)) {
    if (packet->timestamp_us >= 3600000000u || packet->nmea.size() > size) std::abort();
    velodyne::parseNmea(packet->nmea);
  }
  if (const auto model = velodyne::packetModel(data, size)) velodyne::packetReturnMode(data, *model);
  return 0;
}
