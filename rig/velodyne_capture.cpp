#include "rig/velodyne_capture.hpp"

#include "rig/file_io.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

namespace terrain::rig {

namespace fs = std::filesystem;

fs::path shippedCalibration(velodyne::Model model) {
  return fs::path(TERRAIN_DATA_DIR) / "calibration" /
         (model == velodyne::Model::Hdl32E ? "hdl32e.yaml" : "hdl64e_s2.1-sztaki.yaml");
}

namespace {

// The laser table for packets of `model`: the given one, which must have the model's lasers, or
// the shipped one. `holding` names where the packets are ("FILE holds", "udp:... sends").
LaserCalibration laserTable(velodyne::Model model, const fs::path& given, const std::string& holding) {
  const fs::path table = given.empty() ? shippedCalibration(model) : given;
  LaserCalibration lasers = loadLaserCalibration(table);
  const int wanted = velodyne::timing(model).lasers;
  if (lasers.laserCount() != wanted) {
    throw io::InputError(table.string() + ": " + std::to_string(lasers.laserCount()) + " lasers, but " + holding + " " +
                         velodyne::modelName(model) + " packets (" + std::to_string(wanted) +
                         " lasers); give that sensor's calibration, or none to take the shipped one");
  }
  return lasers;
}

}  // namespace

CaptureSetup setupCapture(const fs::path& path, const CaptureOptions& options) {
  CaptureSetup setup;
  pcap::Reader reader(path, std::vector<std::uint16_t>{velodyne::kDataPort, velodyne::kPositionPort});
  std::optional<velodyne::Model> model;
  std::string first_reason;
  std::optional<double> gps_base, clock_base;
  long long position_packets = 0;
  pcap::Frame f;
  while (reader.next(f)) {
    if (f.port == velodyne::kPositionPort) {
      ++position_packets;
      const auto packet = velodyne::parsePositionPacket(f.payload.data(), f.payload.size());
      if (!packet || packet->nmea.empty()) continue;
      const auto fix = velodyne::parseNmea(packet->nmea);
      if (!fix || !fix->valid) continue;
      if (!gps_base && fix->epoch) gps_base = velodyne::timeBaseFromFix(packet->timestamp_us, *fix->epoch);
      if (!setup.first_fix) setup.first_fix = velodyne::gpsFix(*packet, *fix, 0.0);
      continue;
    }
    ++setup.data_packets;
    std::string why;
    const auto m = velodyne::packetModel(f.payload.data(), f.payload.size(), &why);
    if (!m) {
      if (first_reason.empty()) first_reason = "data packet " + std::to_string(setup.data_packets) + ": " + why;
      continue;
    }
    if (!model) {
      model = m;
      const double stamp = velodyne::payloadTimestamp(f.payload.data()) * 1e-6;
      clock_base = std::round((f.time - stamp) / 3600.0) * 3600.0;
    } else if (*m != *model) {
      throw io::InputError(path.string() + ": data packet " + std::to_string(setup.data_packets) + " is an " +
                           velodyne::modelName(*m) + "'s, the ones before an " + velodyne::modelName(*model) +
                           "'s: two sensors on one port cannot be decoded as one");
    }
  }
  if (setup.data_packets == 0) {
    std::ostringstream m;
    m << path.string() << ": no lidar data packet (UDP port " << velodyne::kDataPort
      << ") in the capture: " << reader.stats().summary();
    if (position_packets > 0) m << "; " << position_packets << " position packets only";
    throw io::InputError(m.str());
  }
  if (!model) {
    throw io::InputError(path.string() + ": none of its " + std::to_string(setup.data_packets) +
                         " data packets is an HDL-64E's or an HDL-32E's (" + first_reason + ")");
  }
  setup.model = *model;
  setup.cut_off = reader.stats().error;
  setup.lasers = laserTable(*model, options.calibration, path.string() + " holds");
  // the time base: given, else from the GPS time, else from the capture clock
  if (options.time_base) {
    setup.time_base = *options.time_base;
    setup.time_base_source = "given";
  } else if (gps_base) {
    setup.time_base = *gps_base;
    setup.time_base_source = "gps";
  } else {
    setup.time_base = clock_base.value_or(0.0);
    setup.time_base_source = "capture clock";
  }
  if (setup.first_fix) setup.first_fix->time += setup.time_base;
  return setup;
}

namespace {

bool partialSweep(const LidarSweep& s) {
  if (s.points.empty()) return true;
  // the share of the turn its firings cover, from the azimuths in 1-degree bins
  std::vector<bool> bins(360, false);
  for (const auto& p : s.points) {
    const int b = static_cast<int>(p.azimuth * (180.0 / 3.14159265358979323846));
    bins[static_cast<std::size_t>(std::clamp(b, 0, 359))] = true;
  }
  return std::count(bins.begin(), bins.end(), true) < 342;
}

}  // namespace

CaptureScan scanCapture(const fs::path& path, const CaptureOptions& options, const SweepCallback& on_sweep) {
  CaptureScan scan;
  scan.file = path;
  try {
    const CaptureSetup setup = setupCapture(path, options);
    scan.model = setup.model;
    scan.calibration = setup.lasers.source;
    scan.time_base = setup.time_base;
    scan.time_base_source = setup.time_base_source;
    VelodyneOptions lidar_options = options.lidar;
    lidar_options.decoder.time_base = setup.time_base;
    LidarEndpoint endpoint;
    endpoint.kind = LidarEndpoint::Kind::Pcap;
    endpoint.path = path.string();
    VelodyneLidar lidar(endpoint, setup.lasers, lidar_options);
    // the return mode of each data packet
    {
      pcap::Reader reader(path, velodyne::kDataPort);
      pcap::Frame f;
      while (reader.next(f)) {
        if (velodyne::packetModel(f.payload.data(), f.payload.size()) != setup.model) continue;
        ++scan.packets_by_mode[static_cast<int>(velodyne::packetReturnMode(f.payload.data(), setup.model))];
      }
    }
    try {
      bool first = true;
      while (auto sweep = lidar.next()) {
        SweepSummary s;
        s.start_time = sweep->start_time;
        s.end_time = sweep->end_time;
        s.points = static_cast<long long>(sweep->points.size());
        s.partial = partialSweep(*sweep);
        if (first) scan.first_time = sweep->points.empty() ? sweep->start_time : sweep->points.front().time;
        first = false;
        if (!sweep->points.empty()) scan.last_time = sweep->points.back().time;
        scan.sweeps.push_back(s);
        if (on_sweep) on_sweep(*sweep, s);
      }
    } catch (const io::InputError& e) {
      scan.error = e.what();
    }
    scan.decode = lidar.stats();
    scan.position = lidar.positionStats();
    scan.read = lidar.captureStats();
    scan.fixes = lidar.takeFixes();
  } catch (const io::InputError& e) {
    scan.error = e.what();
    return scan;
  }
  // the spin rate from the whole turns
  std::vector<double> rates;
  for (const auto& s : scan.sweeps) {
    if (!s.partial && s.end_time > s.start_time) rates.push_back(1.0 / (s.end_time - s.start_time));
  }
  if (!rates.empty()) {
    std::nth_element(rates.begin(), rates.begin() + rates.size() / 2, rates.end());
    scan.rotation_hz = rates[rates.size() / 2];
  }
  // what a user has to know before trusting the result
  if (!scan.read.error.empty()) {
    scan.warnings.push_back(path.string() + ": the capture is cut off after " + std::to_string(scan.read.frames) +
                            " frames (" + scan.read.error + "); everything before was decoded");
  }
  const auto& d = scan.decode;
  if (d.lost > 0)
    scan.warnings.push_back(std::to_string(d.lost) + " data packets lost (gaps in the packet timestamps)");
  if (d.rejected() > 0)
    scan.warnings.push_back(std::to_string(d.rejected()) + " data packets rejected: " + d.summary());
  if (scan.position.unreadable + scan.position.bad_sentence > 0) scan.warnings.push_back(scan.position.summary());
  const long long partial =
      std::count_if(scan.sweeps.begin(), scan.sweeps.end(), [](const SweepSummary& s) { return s.partial; });
  if (partial > 0) {
    scan.warnings.push_back(std::to_string(partial) + " of " + std::to_string(scan.sweeps.size()) +
                            " sweeps are partial turns (the capture starts or ends mid-turn, or packets are missing)");
  }
  return scan;
}

// ---------------------------------------------------------------------------------------------

CaptureSource::CaptureSource(const fs::path& path, const CaptureOptions& options, double mast_height,
                             std::shared_ptr<const SensorFolder> sensors)
    : setup_(setupCapture(path, options)), sensors_(std::move(sensors)) {
  placeRig(mast_height);
  VelodyneOptions lidar_options = options.lidar;
  lidar_options.decoder.time_base = setup_.time_base;
  LidarEndpoint endpoint;
  endpoint.kind = LidarEndpoint::Kind::Pcap;
  endpoint.path = path.string();
  lidar_ = std::make_unique<VelodyneLidar>(endpoint, setup_.lasers, lidar_options);
}

CaptureSource::CaptureSource(const LidarEndpoint& live, const CaptureOptions& options, double mast_height) {
  const std::string where = live.describe();
  auto data = std::make_unique<UdpReceiver>(live.host, live.port);
  std::unique_ptr<UdpReceiver> position;
  if (options.position_port != 0 && options.position_port != live.port) {
    try {
      position = std::make_unique<UdpReceiver>(live.host, options.position_port);
    } catch (const io::InputError& e) {
      throw io::InputError(std::string(e.what()) + " (the position packets, GPS; --lidar-position-port 0 reads none)");
    }
  }
  // the first data packet of a known model sets the laser table and the time base
  std::vector<std::uint8_t> first(65536);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(options.lidar.first_timeout);
  long long other = 0;
  std::string first_reason;
  std::optional<velodyne::Model> model;
  while (!model) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    const long n = left.count() > 0 ? data->receive(first.data(), first.size(), left) : -1;
    if (n < 0) {
      std::ostringstream m;
      m << where << ": no lidar data packet of a known model arrived within " << options.lidar.first_timeout
        << " s (--lidar-first-packet-timeout)";
      if (other > 0) m << "; " << other << " other datagrams (first: " << first_reason << ")";
      m << "; is the sensor on, and sending to this host and port?";
      throw io::InputError(m.str());
    }
    first.resize(static_cast<std::size_t>(std::min<long>(n, 65536)));
    std::string why;
    model = velodyne::packetModel(first.data(), first.size(), &why);
    if (!model && other++ == 0) first_reason = why;
    if (!model) first.resize(65536);
  }
  setup_.model = *model;
  setup_.lasers = laserTable(*model, options.calibration, where + " sends");
  setup_.data_packets = 1;
  if (options.time_base) {
    setup_.time_base = *options.time_base;
    setup_.time_base_source = "given";
  } else {
    // the top of the hour that puts the packet nearest to the host clock's time now
    const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    setup_.time_base = std::round((now - velodyne::payloadTimestamp(first.data()) * 1e-6) / 3600.0) * 3600.0;
    setup_.time_base_source = "host clock";
  }
  VelodyneOptions lidar_options = options.lidar;
  lidar_options.decoder.time_base = setup_.time_base;
  lidar_ = std::make_unique<VelodyneLidar>(live, std::move(data), std::move(position), std::move(first), setup_.lasers,
                                           lidar_options);
  // the world's origin is the first fix: wait for one over up to 2 s of sweeps (a Velodyne sends a
  // position packet a second), keeping the sweeps for next()
  if (lidar_->positionPort() != 0) {
    while (pending_.empty()) {
      auto sweep = lidar_->next();
      if (!sweep) break;
      const bool enough = !buffered_.empty() && sweep->end_time - buffered_.front().start_time >= 2.0;
      buffered_.push_back(std::move(*sweep));
      for (const GpsFix& g : lidar_->takeFixes()) pending_.push_back(g);
      if (enough) break;
    }
  }
  if (!pending_.empty()) setup_.first_fix = pending_.front();
  placeRig(mast_height);
}

void CaptureSource::placeRig(double mast_height) {
  if (sensors_) {
    calibration_ = sensors_->calibration();
  } else {
    calibration_.vehicle_from_lidar = Pose::Identity();
    calibration_.vehicle_from_lidar.translation() = Vector3(0, 0, mast_height);
    calibration_.vehicle_from_gps = calibration_.vehicle_from_lidar;
  }
  if (setup_.first_fix) {
    calibration_.origin.latitude_deg = setup_.first_fix->latitude_deg;
    calibration_.origin.longitude_deg = setup_.first_fix->longitude_deg;
    calibration_.origin.altitude_m = setup_.first_fix->altitude_m;
  }
}

std::optional<RigFrame> CaptureSource::next() {
  std::optional<LidarSweep> sweep;
  if (!buffered_.empty()) {
    sweep = std::move(buffered_.front());
    buffered_.pop_front();
  } else {
    sweep = lidar_->next();
  }
  if (!sweep) return std::nullopt;
  // the fixes timed before the sweep's end belong to it (as the simulated rig frames them)
  for (const GpsFix& g : lidar_->takeFixes()) pending_.push_back(g);
  RigFrame frame;
  SensorFrame& s = frame.sensors;
  s.index = index_++;
  auto it = std::find_if(pending_.begin(), pending_.end(), [&](const GpsFix& g) { return g.time >= sweep->end_time; });
  s.gps.assign(pending_.begin(), it);
  pending_.erase(pending_.begin(), it);
  if (sensors_) sensors_->fill(s, last_end_, sweep->end_time);
  last_end_ = sweep->end_time;
  s.sweep = std::move(*sweep);
  return frame;
}

}  // namespace terrain::rig
