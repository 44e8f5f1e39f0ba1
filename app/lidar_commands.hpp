#pragma once
// 'terrain lidar': a real Velodyne capture on its own, with no simulated part (the command is added
// by app::addLidarCommand, app/command.hpp).
//   lidar inspect FILE.pcap   what the capture holds: sensor model (from the data), packets,
//                             sweeps, points, spin rate, return mode, time span and base, GPS
//                             fixes of its position packets, every counter (text, --json)
//   lidar convert --pcap FILE --out DIR
//                             one PCD per sweep (and KITTI .bin with --kitti), sweeps.csv,
//                             gps.csv and capture.json

#include "rig/velodyne_capture.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

namespace terrain::app {

// A capture's scan as JSON (the content of --json and capture.json).
nlohmann::json captureJson(const rig::CaptureScan& scan);
// The decoder's, the position packets' and the capture reader's counters as JSON (part of the above,
// and the 'lidar' object of report.json).
nlohmann::json lidarCountersJson(const rig::velodyne::DecodeStats& decode, const rig::PositionStats& position,
                                 const rig::pcap::ReadStats& read);

// Throws io::InputError for a capture cut off (cut_off: the reader's reason) under --strict.
void refuseCutOff(const std::string& file, const std::string& cut_off);

// "auto" (nullopt) or a number of seconds; throws io::InputError naming `option` otherwise.
std::optional<double> parseTimeBase(const std::string& text, const std::string& option);

}  // namespace terrain::app
