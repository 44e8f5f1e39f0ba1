#include "app/lidar_commands.hpp"

#include "app/command.hpp"
#include "app/interrupt.hpp"

#include "rig/file_io.hpp"
#include "rig/pcd.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace terrain::app {

namespace fs = std::filesystem;

std::optional<double> parseTimeBase(const std::string& text, const std::string& option) {
  if (text == "auto") return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw io::InputError(option + " '" + text + "': expected auto or a number of seconds");
  }
  return v;
}

void refuseCutOff(const std::string& file, const std::string& cut_off) {
  if (!cut_off.empty()) throw io::InputError(file + ": the capture is cut off (" + cut_off + "); --strict refuses it");
}

nlohmann::json lidarCountersJson(const rig::velodyne::DecodeStats& d, const rig::PositionStats& p,
                                 const rig::pcap::ReadStats& r) {
  nlohmann::json j;
  j["data_packets"] = {{"offered", d.packets},
                       {"decoded", d.accepted},
                       {"lost", d.lost},
                       {"rejected", d.rejected()},
                       {"wrong_size", d.wrong_size},
                       {"bad_block", d.bad_block},
                       {"bad_position", d.bad_position},
                       {"bad_timestamp", d.bad_timestamp},
                       {"duplicates", d.duplicates},
                       {"out_of_order", d.out_of_order},
                       {"dual", d.dual_packets}};
  j["points"] = d.points;
  j["second_returns"] = d.second_returns;
  j["position_packets"] = {{"packets", p.packets},
                           {"fixes", p.fixes},
                           {"no_fix", p.no_fix},
                           {"no_sentence", p.no_sentence},
                           {"bad_sentence", p.bad_sentence},
                           {"unreadable", p.unreadable},
                           {"first_problem", p.first_problem}};
  j["capture"] = {{"frames", r.frames},          {"sensor_datagrams", r.payloads}, {"other_traffic", r.other},
                  {"ip_fragments", r.fragments}, {"malformed", r.malformed},       {"cut_off", r.error}};
  return j;
}

nlohmann::json captureJson(const rig::CaptureScan& scan) {
  nlohmann::json j = lidarCountersJson(scan.decode, scan.position, scan.read);
  j["file"] = scan.file.string();
  j["model"] = scan.model ? nlohmann::json(rig::velodyne::modelName(*scan.model)) : nlohmann::json(nullptr);
  j["calibration"] = scan.calibration;
  j["return_mode_packets"] = {
      {"strongest", scan.packets_by_mode[0]}, {"last", scan.packets_by_mode[1]}, {"dual", scan.packets_by_mode[2]}};
  j["time_base_s"] = scan.time_base;
  j["time_base_source"] = scan.time_base_source;
  j["first_firing_s"] = scan.first_time;
  j["last_firing_s"] = scan.last_time;
  j["duration_s"] = scan.last_time - scan.first_time;
  j["rotation_hz"] = scan.rotation_hz;
  nlohmann::json sweeps = nlohmann::json::array();
  for (const auto& s : scan.sweeps) {
    sweeps.push_back({{"start_s", s.start_time}, {"end_s", s.end_time}, {"points", s.points}, {"partial", s.partial}});
  }
  j["sweeps"] = sweeps;
  nlohmann::json fixes = nlohmann::json::array();
  for (const auto& f : scan.fixes) {
    fixes.push_back({{"time_s", f.time},
                     {"latitude_deg", f.latitude_deg},
                     {"longitude_deg", f.longitude_deg},
                     {"altitude_m", f.altitude_m},
                     {"sigma_m", f.sigma_m}});
  }
  j["gps_fixes"] = fixes;
  j["warnings"] = scan.warnings;
  j["error"] = scan.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(scan.error);
  return j;
}

namespace {

// The options of both subcommands, filled by CLI11.
struct LidarCommands {
  CLI::App* inspect = nullptr;
  CLI::App* convert = nullptr;
  std::string file;         // inspect: the capture
  std::string pcap;         // convert: the capture
  std::string calibration;  // empty: the shipped table of the model found
  std::string time_base = "auto";
  std::string json;  // inspect --json FILE ("-": stdout instead of the text)
  std::string out;   // convert --out
  bool force = false, kitti = false, strict = false;
};

// UTC text of a time [s since 1970], or the seconds alone for a time within the first day
std::string timeText(double t) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(6) << t << " s";
  if (t > 86400.0 * 365) {
    const std::time_t whole = static_cast<std::time_t>(std::floor(t));
    std::tm utc{};
    gmtime_r(&whole, &utc);
    char b[40];
    std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%S", &utc);
    char frac[16];
    std::snprintf(frac, sizeof frac, "%.3f", t - std::floor(t));
    s << " (" << b << (frac + 1) << "Z)";
  }
  return s.str();
}

void printScan(std::ostream& o, const rig::CaptureScan& scan) {
  o << "capture     " << scan.file.string() << "\n";
  if (scan.model)
    o << "sensor      " << rig::velodyne::modelName(*scan.model) << " (from the packets' block ids and model byte)\n";
  if (!scan.calibration.empty()) o << "calibration " << scan.calibration << "\n";
  const auto& d = scan.decode;
  o << "packets     " << d.packets << " data packets: " << d.accepted << " decoded, " << d.rejected() << " rejected, "
    << d.lost << " lost; " << scan.position.packets << " position packets; " << scan.read.other << " other frames\n";
  if (d.rejected() > 0 || d.lost > 0) o << "            " << d.summary() << "\n";
  o << "return mode " << scan.packets_by_mode[0] << " strongest, " << scan.packets_by_mode[1] << " last, "
    << scan.packets_by_mode[2] << " dual packets";
  if (d.second_returns > 0) o << " (" << d.second_returns << " second returns)";
  o << "\n";
  long long partial = 0;
  for (const auto& s : scan.sweeps) partial += s.partial;
  o << "sweeps      " << scan.sweeps.size() << " (" << partial << " partial), " << d.points << " points\n";
  o << std::fixed << std::setprecision(2) << "spin rate   " << scan.rotation_hz << " Hz"
    << (scan.rotation_hz > 0 ? "" : " (no whole turn)") << "\n";
  o << "time        " << timeText(scan.first_time) << " to " << timeText(scan.last_time) << std::setprecision(3) << ", "
    << scan.last_time - scan.first_time << " s\n";
  o << "time base   " << std::setprecision(0) << scan.time_base << " s, from the " << scan.time_base_source << "\n";
  o << "gps         " << scan.position.summary() << "\n";
  if (!scan.fixes.empty()) {
    const auto& a = scan.fixes.front();
    const auto& b = scan.fixes.back();
    o << std::setprecision(7) << "            first " << a.latitude_deg << ", " << a.longitude_deg << " at "
      << timeText(a.time) << "\n            last  " << b.latitude_deg << ", " << b.longitude_deg << " at "
      << timeText(b.time) << "\n";
  }
  o << "capture     " << scan.read.summary() << "\n";
  for (const auto& w : scan.warnings) o << "warning     " << w << "\n";
}

rig::CaptureOptions captureOptions(const LidarCommands& c, const std::string& time_option) {
  rig::CaptureOptions options;
  options.calibration = c.calibration;
  options.time_base = parseTimeBase(c.time_base, time_option);
  return options;
}

// a failed scan, or a cut-off capture under --strict, is an error
void refuse(const rig::CaptureScan& scan, bool strict) {
  if (!scan.error.empty()) throw io::InputError(scan.error);
  if (strict) refuseCutOff(scan.file.string(), scan.read.error);
}

int inspect(const LidarCommands& c) {
  const rig::CaptureScan scan = rig::scanCapture(c.file, captureOptions(c, "--lidar-time-base"));
  // a file that could not be read at all (missing, not a capture) has nothing to summarise
  if (scan.read.frames == 0) refuse(scan, c.strict);
  if (c.json == "-") {
    std::cout << captureJson(scan).dump(1) << "\n";
  } else {
    printScan(std::cout, scan);
    if (!c.json.empty()) io::writeFileAtomic(c.json, captureJson(scan).dump(1) + "\n", c.force);
  }
  refuse(scan, c.strict);
  return 0;
}

int convert(const LidarCommands& c) {
  const rig::CaptureOptions options = captureOptions(c, "--lidar-time-base");
  rig::setupCapture(c.pcap, options);  // refuses a capture it cannot decode before anything is written
  io::StagedDirectory out(c.out, c.force);
  const fs::path dir = out.path();
  fs::create_directories(dir / "sweeps");
  if (c.kitti) fs::create_directories(dir / "kitti");
  std::ofstream csv(dir / "sweeps.csv");
  csv << "sweep,file,start_s,end_s,points,partial\n" << std::setprecision(17);
  int index = 0;
  const auto write = [&](const LidarSweep& sweep, const rig::SweepSummary& s) {
    throwIfInterrupted();
    char name[32];
    std::snprintf(name, sizeof name, "%06d", index);
    io::writeFileAtomic(dir / "sweeps" / (std::string(name) + ".pcd"), rig::encodePcd(sweep, {}, false), false);
    if (c.kitti) {
      // KITTI .bin: float32 x, y, z, reflectance in [0, 1] per point, sensor frame
      std::string bin(sweep.points.size() * 16, '\0');
      char* p = bin.data();
      for (const auto& q : sweep.points) {
        const float v[4] = {q.x, q.y, q.z, q.intensity / 255.0f};
        std::memcpy(p, v, sizeof v);
        p += sizeof v;
      }
      io::writeFileAtomic(dir / "kitti" / (std::string(name) + ".bin"), bin, false);
    }
    csv << index << ",sweeps/" << name << ".pcd," << s.start_time << "," << s.end_time << "," << s.points << ","
        << (s.partial ? 1 : 0) << "\n";
    ++index;
    if (index % 50 == 0) std::cerr << "convert: " << index << " sweeps\r" << std::flush;
  };
  const rig::CaptureScan scan = rig::scanCapture(c.pcap, options, write);
  refuse(scan, c.strict);
  csv.close();
  if (!csv) throw io::InputError((dir / "sweeps.csv").string() + ": writing failed");
  std::ostringstream gps;
  gps << "time_s,latitude_deg,longitude_deg,altitude_m,sigma_m\n" << std::setprecision(17);
  for (const auto& f : scan.fixes) {
    gps << f.time << "," << f.latitude_deg << "," << f.longitude_deg << "," << f.altitude_m << "," << f.sigma_m << "\n";
  }
  io::writeFileAtomic(dir / "gps.csv", gps.str(), false);
  nlohmann::json j = captureJson(scan);
  j.erase("sweeps");  // in sweeps.csv
  j["pcd_fields"] =
      "x y z intensity ring azimuth time: metres in the sensor frame (x forward, y left, z up), 0-255, "
      "laser id, encoder angle [rad], firing time [s] on the time base";
  io::writeFileAtomic(dir / "capture.json", j.dump(1) + "\n", false);
  out.commit();
  printScan(std::cout, scan);
  std::cout << "wrote " << index << " sweeps (sweeps/NNNNNN.pcd" << (c.kitti ? ", kitti/NNNNNN.bin" : "")
            << "), sweeps.csv, gps.csv and capture.json into " << fs::absolute(c.out).string() << "\n";
  return 0;
}

class LidarCommand : public Command {
 public:
  explicit LidarCommand(CLI::App& app)
      : Command(
            app.add_subcommand("lidar", "a real Velodyne capture on its own: inspect it, convert it to point clouds")) {
    cli_->require_subcommand(1);
    LidarCommands* c = &c_;
    const std::string calibration_help =
        "laser calibration (ROS YAML or db.xml); default: the table shipped for the model the packets show "
        "(HDL-64E S2.1 or HDL-32E); one with another number of lasers is refused";
    const std::string time_help =
        "[s] added to the packets' time since the top of the hour; auto: the hour of the position packets' GPS "
        "time, else of the capture clock";
    c->inspect = cli_->add_subcommand("inspect",
                                      "what a capture holds: sensor model, packets, sweeps, points, spin rate, "
                                      "return mode, time span and base, GPS fixes, every counter");
    c->inspect->add_option("FILE", c->file, "pcap capture")->required();
    c->inspect->add_option("--calibration", c->calibration, calibration_help);
    c->inspect->add_option("--lidar-time-base", c->time_base, time_help)->capture_default_str();
    c->inspect->add_option("--json", c->json,
                           "also write it all as JSON to this file; '-' prints the JSON instead of the text");
    c->inspect->add_flag("--force", c->force, "replace an existing --json file");
    c->inspect->add_flag("--strict", c->strict, "a cut-off capture is an error (exit 2), not a warning");
    c->convert = cli_->add_subcommand("convert",
                                      "decode a capture into one PCD per sweep (x y z intensity ring azimuth "
                                      "time), sweeps.csv, gps.csv and capture.json");
    c->convert->add_option("--pcap", c->pcap, "pcap capture")->required();
    c->convert->add_option("--out", c->out, "output directory (built beside it and moved into place when complete)")
        ->required();
    c->convert->add_option("--calibration", c->calibration, calibration_help);
    c->convert->add_option("--lidar-time-base", c->time_base, time_help)->capture_default_str();
    c->convert->add_flag("--kitti", c->kitti, "also write KITTI .bin scans (float32 x y z reflectance) in OUT/kitti/");
    c->convert->add_flag("--force", c->force,
                         "replace an existing, non-empty --out directory (whole, once the new one is complete)");
    c->convert->add_flag("--strict", c->strict,
                         "a cut-off capture is an error (exit 2, nothing written), not a warning");
  }

  int run() override { return c_.inspect->parsed() ? inspect(c_) : convert(c_); }

 private:
  LidarCommands c_;
};

}  // namespace

std::unique_ptr<Command> addLidarCommand(CLI::App& app) { return std::make_unique<LidarCommand>(app); }

}  // namespace terrain::app
