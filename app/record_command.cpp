// 'terrain record': drive a scene with the simulated rig and write a dataset (and, with --pcap,
// the lidar and GPS as a Velodyne capture).
#include "app/cli_options.hpp"
#include "app/command.hpp"
#include "app/interrupt.hpp"
#include "app/progress.hpp"
#include "app/reconstruction.hpp"
#include "rig/dataset.hpp"
#include "rig/file_io.hpp"
#include "rig/pcap_file.hpp"
#include "rig/velodyne_packet.hpp"
#include "rig/velodyne_position.hpp"
#include "sim/simulated_rig.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <iostream>

namespace terrain::app {

namespace {

namespace fs = std::filesystem;

// [bytes] a lower bound on what one recorded frame takes on disk: the lidar's PCD at 24 bytes a
// firing of every laser (about 30 measured on the generated scenes, where most firings return) and
// every camera's images at 3 bytes a pixel (RGB, depth and segmentation PNGs: about 4.5 measured)
std::uintmax_t recordingFrameBytes(const sim::SimulatedRig& rig) {
  std::uintmax_t bytes = static_cast<std::uintmax_t>(rig.firingsPerTurn()) * rig.lasers().laserCount() * 24;
  for (const auto& c : rig.calibration().cameras)
    bytes += static_cast<std::uintmax_t>(c.intrinsics.width) * c.intrinsics.height * 3;
  return bytes;
}

int record(const fs::path& scene_path, int frames, const fs::path& out, bool force, const sim::SimConfig& config,
           bool with_pcap) {
  auto world = std::make_shared<sim::World>(scene_path);
  checkSceneOrThrow(*world, config, scene_path);
  sim::SimulatedRig rig(world, config, frames);
  nlohmann::json producer;
  producer["scene"] = fs::absolute(scene_path).string();
  producer["scene_type"] = world->truth().type;
  producer["scene_seed"] = world->truth().seed;
  producer["simulation"] = nlohmann::json::parse(sim::simConfigToJson(config));
  io::requireSpace(out, recordingFrameBytes(rig) * static_cast<std::uintmax_t>(frames),
                   "recording " + std::to_string(frames) + " frames (" +
                       std::to_string(recordingFrameBytes(rig) / 1000000) + " MB a frame at least)");
  io::StagedDirectory staged(out, force);
  rig::DatasetWriter writer(staged.path(), rig.calibration(), rig.lasers(), producer.dump(), true);
  // the same sweeps as HDL-64E packets in a capture, as the real sensor would have sent them
  std::unique_ptr<rig::pcap::Writer> capture;
  std::unique_ptr<rig::velodyne::PacketEncoder> encoder;
  std::vector<rig::velodyne::TimedPacket> packets;
  // position packets (port 8308) for the GPS fixes
  rig::velodyne::PositionEncoder position_encoder(rig::pcap::kSimulationEpoch);
  std::vector<rig::velodyne::TimedPosition> positions;
  long long position_packets = 0;
  // data and position packets in time order (a fix before the data packets of the same time)
  auto writePackets = [&] {
    std::size_t next = 0;
    for (const auto& p : packets) {
      for (; next < positions.size() && positions[next].time <= p.time; ++next) {
        capture->write(rig::pcap::kSimulationEpoch + positions[next].time, positions[next].payload.data(),
                       positions[next].payload.size(), 8308);
        ++position_packets;
      }
      capture->write(rig::pcap::kSimulationEpoch + p.time, p.payload.data(), p.payload.size());
    }
    positions.erase(positions.begin(), positions.begin() + static_cast<std::ptrdiff_t>(next));
    packets.clear();
  };
  if (with_pcap) {
    capture = std::make_unique<rig::pcap::Writer>(staged.path() / "lidar.pcap", true);
    encoder = std::make_unique<rig::velodyne::PacketEncoder>(rig.lasers(), rig.firingsPerTurn());
  }
  Progress progress("record", frames);
  long long points = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (auto frame = rig.next()) {
    throwIfInterrupted();
    points += static_cast<long long>(frame->sensors.sweep.points.size());
    writer.write(*frame);
    if (encoder) {
      position_encoder.add(frame->sensors.gps, positions);
      encoder->addSweep(frame->sensors.sweep, packets);
      writePackets();
    }
    progress.update(frame->sensors.index + 1);
  }
  if (encoder) {
    encoder->finish(packets);
    writePackets();
    for (const auto& p : positions) {  // fixes after the last data packet
      capture->write(rig::pcap::kSimulationEpoch + p.time, p.payload.data(), p.payload.size(), 8308);
      ++position_packets;
    }
    capture->close();
    const auto& st = encoder->stats();
    std::cout << "wrote lidar.pcap: " << st.packets << " HDL-64E packets, " << st.points << " returns, "
              << position_packets << " position packets";
    if (st.too_close + st.too_far + st.off_schedule > 0) {
      std::cout << " (" << st.too_close + st.too_far + st.off_schedule << " returns not encodable)";
    }
    std::cout << "\n";
  }
  writer.finish();
  throwIfInterrupted();
  staged.commit();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "recorded " << frames << " frames (" << points << " lidar points, " << rig.raysCast() << " rays, "
            << static_cast<long long>(rig.raysCast() / std::max(seconds, 1e-9)) << " rays/s) into "
            << fs::absolute(out).string() << "\n";
  return 0;
}

class RecordCommand : public Command {
 public:
  explicit RecordCommand(CLI::App& app)
      : Command(app.add_subcommand("record", "drive a scene with the simulated rig and write a dataset")) {
    cli_->add_option("--scene", scene_, "scene MJCF file (with its .truth.json sidecar)")->required();
    cli_->add_option("--frames", frames_,
                     "number of lidar sweeps to record, 1-" + std::to_string(kMaxFrames) +
                         "; refused before anything is written when the filesystem of --out has less space free than "
                         "they take at least (about 7 MB a frame with the surround rig at 640x480)")
        ->capture_default_str()
        ->check(CLI::Range(1, kMaxFrames));
    cli_->add_option("--out", out_, "output dataset directory")->required();
    cli_->add_flag("--force", force_,
                   "replace an existing, non-empty output directory (whole, once the new one is complete)");
    cli_->add_flag(
        "--pcap", pcap_,
        "also write the lidar as HDL-64E packets in OUT/lidar.pcap (Wireshark, VeloView, PCL open it), with the "
        "GPS as position packets (port 8308: $GPGGA for every fix, $GPRMC once a second)");
    // --config, the sim YAML's older name here, still reads it
    addSimOptions(*cli_, sim_, "--sim-config,--config");
  }

  int run() override { return record(scene_, frames_, out_, force_, sim_, pcap_); }

 private:
  fs::path scene_, out_;
  int frames_ = 60;
  bool force_ = false, pcap_ = false;
  sim::SimConfig sim_;
};

}  // namespace

std::unique_ptr<Command> addRecordCommand(CLI::App& app) { return std::make_unique<RecordCommand>(app); }

}  // namespace terrain::app
