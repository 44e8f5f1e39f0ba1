// 'terrain stream': a capture, or a simulated run, sent to a UDP address as HDL-64E packets at the
// sensor's rate, with its position packets (GPS) beside them: what a real sensor on the network
// would send.
#include "app/bounded_queue.hpp"
#include "app/cli_options.hpp"
#include "app/command.hpp"
#include "rig/file_io.hpp"
#include "rig/pcap_file.hpp"
#include "rig/velodyne_packet.hpp"
#include "rig/velodyne_position.hpp"
#include "rig/velodyne_source.hpp"
#include "sim/simulated_rig.hpp"

#include <chrono>
#include <iomanip>
#include <iostream>
#include <thread>

namespace terrain::app {

namespace {

namespace fs = std::filesystem;

// Sends data packets to `data` and position packets to `position` (if not null) in time order, at
// the sensor's pace (scaled by pace) from t0, `first` [s] being the time of t0; returns how many
// went out more than 5 ms late.
long long sendPaced(rig::UdpSender& data, rig::UdpSender* position,
                    const std::vector<rig::velodyne::TimedPacket>& packets,
                    const std::vector<rig::velodyne::TimedPosition>& positions, double first,
                    std::chrono::steady_clock::time_point t0, double pace) {
  long long late = 0;
  const auto sendAt = [&](double time, rig::UdpSender& to, const std::uint8_t* bytes, std::size_t size) {
    const auto due = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>((time - first) / pace));
    if (std::chrono::steady_clock::now() > due + std::chrono::milliseconds(5)) ++late;
    std::this_thread::sleep_until(due);
    to.send(bytes, size);
  };
  std::size_t next = 0;
  for (const auto& p : packets) {
    for (; position && next < positions.size() && positions[next].time <= p.time; ++next)
      sendAt(positions[next].time, *position, positions[next].payload.data(), positions[next].payload.size());
    sendAt(p.time, data, p.payload.data(), p.payload.size());
  }
  for (; position && next < positions.size(); ++next)
    sendAt(positions[next].time, *position, positions[next].payload.data(), positions[next].payload.size());
  return late;
}

int stream(const fs::path& pcap_path, const fs::path& scene_path, int frames, const sim::SimConfig& config,
           const std::string& to, int position_port, double pace) {
  const rig::LidarEndpoint target = rig::LidarEndpoint::parse("udp:" + to, "stream destination");
  if (!(pace > 0 && pace <= 100))
    throw io::InputError("--pace " + std::to_string(pace) + " is out of range (allowed: (0, 100])");
  if (position_port != 0 && position_port == target.port) {
    throw io::InputError("--position-port " + std::to_string(position_port) +
                         " is the data port of --to: position packets go to a port of their own (0: none)");
  }
  rig::UdpSender out(target.host, target.port);
  std::unique_ptr<rig::UdpSender> position_out;
  if (position_port != 0)
    position_out = std::make_unique<rig::UdpSender>(target.host, static_cast<std::uint16_t>(position_port));
  long long sent = 0, positions_sent = 0, late = 0;
  const auto t0 = std::chrono::steady_clock::now();
  if (!pcap_path.empty()) {
    // a capture: its own timestamps set the pace
    rig::pcap::Reader reader(pcap_path,
                             std::vector<std::uint16_t>{rig::velodyne::kDataPort, rig::velodyne::kPositionPort});
    rig::pcap::Frame f;
    std::vector<rig::velodyne::TimedPacket> one(1);
    std::vector<rig::velodyne::TimedPosition> position(1);
    double first = -1;
    while (reader.next(f)) {
      const bool is_position = f.port == rig::velodyne::kPositionPort;
      if (is_position ? !position_out : f.payload.size() != rig::velodyne::kPacketSize) continue;
      if (first < 0) first = f.time;
      if (is_position) {
        position[0] = {f.time, f.payload};
        late += sendPaced(out, position_out.get(), {}, position, first, t0, pace);
        ++positions_sent;
        continue;
      }
      one[0].time = f.time;
      std::copy(f.payload.begin(), f.payload.end(), one[0].payload.begin());
      late += sendPaced(out, nullptr, one, {}, first, t0, pace);
      ++sent;
    }
    std::cerr << "stream: " << reader.stats().summary() << "\n";
  } else {
    // a simulated run (no camera: only the lidar and the GPS go out), simulated on its own thread a
    // few sweeps ahead of the sending
    sim::SimConfig cfg = config;
    cfg.camera.enabled = false;
    auto world = std::make_shared<sim::World>(scene_path);
    sim::SimulatedRig rig(world, cfg, frames);
    rig::velodyne::PacketEncoder encoder(rig.lasers(), rig.firingsPerTurn());
    rig::velodyne::PositionEncoder positions(rig::pcap::kSimulationEpoch);
    struct Batch {
      std::vector<rig::velodyne::TimedPacket> packets;
      std::vector<rig::velodyne::TimedPosition> positions;
    };
    BoundedQueue<Batch> queue(4);
    std::exception_ptr error;
    std::thread simulation([&] {
      try {
        while (auto frame = rig.next()) {
          Batch batch;
          encoder.addSweep(frame->sensors.sweep, batch.packets);
          positions.add(frame->sensors.gps, batch.positions);
          if (!queue.push(std::move(batch))) break;
        }
        Batch last;
        encoder.finish(last.packets);
        queue.push(std::move(last));
      } catch (...) {
        error = std::current_exception();
      }
      queue.close();
    });
    // the first sweep is simulated before the clock starts
    auto first = queue.pop();
    const auto start = std::chrono::steady_clock::now();
    for (auto batch = std::move(first); batch; batch = queue.pop()) {
      late += sendPaced(out, position_out.get(), batch->packets, batch->positions, 0.0, start, pace);
      sent += static_cast<long long>(batch->packets.size());
      if (position_out) positions_sent += static_cast<long long>(batch->positions.size());
    }
    simulation.join();
    if (error) std::rethrow_exception(error);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "sent " << sent << " packets to " << target.host << ":" << target.port;
  if (position_out) std::cout << " and " << positions_sent << " position packets to port " << position_port;
  std::cout << " in " << std::fixed << std::setprecision(2) << seconds << " s ("
            << static_cast<long long>(sent / std::max(seconds, 1e-9)) << " packets/s, " << late
            << " sent more than 5 ms late)\n";
  return 0;
}

class StreamCommand : public Command {
 public:
  explicit StreamCommand(CLI::App& app)
      : Command(app.add_subcommand(
            "stream", "send a capture or a simulated run to a UDP address as HDL-64E packets at the sensor's rate")) {
    auto* source = cli_->add_option("--pcap", pcap_, "capture file to replay (its timestamps set the pace)");
    cli_->add_option("--scene", scene_, "or: scene MJCF file to simulate and send")->excludes(source);
    cli_->add_option("--frames", frames_, "sweeps to simulate with --scene, 1-" + std::to_string(kMaxFrames))
        ->capture_default_str()
        ->check(CLI::Range(1, kMaxFrames));
    addSimConfigOption(*cli_, sim_, "YAML simulation settings for --scene (as for 'terrain record --sim-config')");
    cli_->add_option("--to", to_, "destination HOST:PORT (HOST an IPv4 address or localhost)")->capture_default_str();
    cli_->add_option("--pace", pace_, "pace relative to the real sensor (2: twice as fast), in (0, 100]")
        ->capture_default_str();
    cli_->add_option("--position-port", position_port_,
                     "UDP port on the destination host for the position packets (GPS: a capture's own, or the "
                     "simulated fixes as $GPGGA and $GPRMC); 0: none are sent")
        ->capture_default_str()
        ->check(CLI::Range(0, 65535));
  }

  int run() override {
    if (pcap_.empty() == scene_.empty()) throw io::InputError("give --pcap FILE or --scene FILE to stream");
    return stream(pcap_, scene_, frames_, sim_, to_, position_port_, pace_);
  }

 private:
  fs::path pcap_, scene_;
  int frames_ = 60;
  sim::SimConfig sim_;
  std::string to_ = "127.0.0.1:2368";
  int position_port_ = rig::velodyne::kPositionPort;
  double pace_ = 1.0;
};

}  // namespace

std::unique_ptr<Command> addStreamCommand(CLI::App& app) { return std::make_unique<StreamCommand>(app); }

}  // namespace terrain::app
