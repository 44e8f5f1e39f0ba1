#include "rig/velodyne_source.hpp"

#include "rig/file_io.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <sstream>

namespace terrain::rig {

namespace {

// An IPv4 address in dotted form, or localhost (127.0.0.1); no name is looked up.
sockaddr_in socketAddress(const std::string& host, std::uint16_t port, const std::string& what) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  const std::string address = host == "localhost" ? "127.0.0.1" : host;
  if (inet_pton(AF_INET, address.c_str(), &a.sin_addr) != 1) {
    throw io::InputError(what + ": '" + host + "' is not an IPv4 address (nor localhost)");
  }
  return a;
}

std::string addressText(const std::string& host, std::uint16_t port) { return host + ":" + std::to_string(port); }

}  // namespace

LidarEndpoint LidarEndpoint::parse(const std::string& text, const std::string& role) {
  LidarEndpoint e;
  if (text.rfind("pcap:", 0) == 0 && text.size() > 5) {
    e.kind = Kind::Pcap;
    e.path = text.substr(5);
    return e;
  }
  if (text.rfind("udp:", 0) == 0 && text.size() > 4) {
    e.kind = Kind::Udp;
    std::string rest = text.substr(4);
    const auto colon = rest.rfind(':');
    if (colon != std::string::npos) {
      const std::string port = rest.substr(colon + 1);
      rest = rest.substr(0, colon);
      char* end = nullptr;
      const long p = std::strtol(port.c_str(), &end, 10);
      if (port.empty() || *end != '\0' || p < 0 || p > 65535) {
        throw io::InputError(role + " '" + text + "': port '" + port + "' is not a number in [0, 65535]");
      }
      e.port = static_cast<std::uint16_t>(p);
    }
    if (!rest.empty()) e.host = rest;
    socketAddress(e.host, e.port, role + " '" + text + "'");  // checks the address
    return e;
  }
  throw io::InputError(role + " '" + text + "': expected pcap:FILE or udp:HOST:PORT (for example udp:0.0.0.0:2368)");
}

std::string LidarEndpoint::describe() const {
  return kind == Kind::Pcap ? "pcap:" + path : "udp:" + addressText(host, port);
}

// ---------------------------------------------------------------------------------------------
// sockets

UdpReceiver::UdpReceiver(const std::string& host, std::uint16_t port) {
  const std::string where = "udp:" + addressText(host, port);
  sockaddr_in a = socketAddress(host, port, where);
  fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd_ < 0) throw io::InputError(where + ": cannot open a socket (" + std::strerror(errno) + ")");
  // no SO_REUSEADDR: a second receiver on the same port is refused, not handed half the packets
  // a deep receive buffer: a second of HDL-64E traffic is about 4 MB
  const int buffer = 16 << 20;
  ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &buffer, sizeof buffer);
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    const int error = errno;
    ::close(fd_);
    throw io::InputError(where + ": cannot bind (" + std::strerror(error) +
                         (error == EADDRINUSE ? "; another program receives on that port" : "") + ")");
  }
  socklen_t len = sizeof a;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
}

UdpReceiver::~UdpReceiver() {
  if (fd_ >= 0) ::close(fd_);
}

long UdpReceiver::receive(std::uint8_t* buffer, std::size_t capacity, std::chrono::milliseconds timeout) {
  pollfd p{fd_, POLLIN, 0};
  const int ready = ::poll(&p, 1, static_cast<int>(timeout.count()));
  if (ready <= 0) return -1;
  const ssize_t n = ::recv(fd_, buffer, capacity, MSG_TRUNC);
  return n < 0 ? -1 : static_cast<long>(n);
}

UdpSender::UdpSender(const std::string& host, std::uint16_t port) {
  const std::string where = "udp:" + addressText(host, port);
  const sockaddr_in a = socketAddress(host, port, where);
  address_.assign(reinterpret_cast<const std::uint8_t*>(&a), reinterpret_cast<const std::uint8_t*>(&a) + sizeof a);
  fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd_ < 0) throw io::InputError(where + ": cannot open a socket (" + std::strerror(errno) + ")");
  const int one = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_BROADCAST, &one, sizeof one);
}

UdpSender::~UdpSender() {
  if (fd_ >= 0) ::close(fd_);
}

void UdpSender::send(const std::uint8_t* data, std::size_t size) {
  if (::sendto(fd_, data, size, 0, reinterpret_cast<const sockaddr*>(address_.data()),
               static_cast<socklen_t>(address_.size())) < 0) {
    throw std::runtime_error(std::string("sending a lidar packet failed: ") + std::strerror(errno));
  }
}

// ---------------------------------------------------------------------------------------------
// the lidar

VelodyneLidar::VelodyneLidar(const LidarEndpoint& endpoint, LaserCalibration calibration, VelodyneOptions options)
    : endpoint_(endpoint), options_(options), assembler_(std::move(calibration), options.decoder) {
  if (endpoint_.kind == LidarEndpoint::Kind::Pcap) {
    pcap_ = std::make_unique<pcap::Reader>(endpoint_.path,
                                           std::vector<std::uint16_t>{endpoint_.port, velodyne::kPositionPort});
  } else {
    udp_ = std::make_unique<UdpReceiver>(endpoint_.host, endpoint_.port);
    buffer_.resize(65536);  // the largest UDP datagram
  }
}

VelodyneLidar::VelodyneLidar(const LidarEndpoint& endpoint, std::unique_ptr<UdpReceiver> data,
                             std::unique_ptr<UdpReceiver> position, std::vector<std::uint8_t> first,
                             LaserCalibration calibration, VelodyneOptions options)
    : endpoint_(endpoint),
      options_(options),
      assembler_(std::move(calibration), options.decoder),
      udp_(std::move(data)),
      position_udp_(std::move(position)),
      first_(std::move(first)) {
  buffer_.resize(65536);
  received_ = true;
}

void VelodyneLidar::drainPositions() {
  if (!position_udp_) return;
  std::uint8_t packet[2048];
  for (long n; (n = position_udp_->receive(packet, sizeof packet, std::chrono::milliseconds(0))) >= 0;)
    position(packet, static_cast<std::size_t>(std::min<long>(n, sizeof packet)));
}

VelodyneLidar::~VelodyneLidar() = default;

std::optional<LidarSweep> VelodyneLidar::next() {
  while (ready_pos_ >= ready_.size()) {
    if (ended_) return std::nullopt;
    ready_.clear();
    ready_pos_ = 0;
    bool got = false;
    if (pcap_) {
      pcap::Frame f;
      got = pcap_->next(f);
      if (got && f.port == velodyne::kPositionPort && endpoint_.port != velodyne::kPositionPort) {
        position(f.payload.data(), f.payload.size());
        continue;
      }
      if (got && !assembler_.push(f.payload.data(), f.payload.size(), ready_))
        checkModel(f.payload.data(), f.payload.size());
    } else if (!first_.empty()) {
      got = true;
      if (!assembler_.push(first_.data(), first_.size(), ready_)) checkModel(first_.data(), first_.size());
      first_.clear();
    } else {
      const double wait = received_ ? options_.idle_timeout : options_.first_timeout;
      const long n =
          udp_->receive(buffer_.data(), buffer_.size(), std::chrono::milliseconds(static_cast<long>(wait * 1000)));
      got = n >= 0;
      drainPositions();
      if (!got && !received_) {
        std::ostringstream m;
        m << endpoint_.describe() << ": no packet arrived within " << options_.first_timeout
          << " s (--lidar-first-packet-timeout); is the sensor on, and sending to this host and port?";
        throw io::InputError(m.str());
      }
      if (got) {
        received_ = true;
        const std::size_t size = std::min(static_cast<std::size_t>(n), buffer_.size());
        if (!assembler_.push(buffer_.data(), static_cast<std::size_t>(n), ready_)) checkModel(buffer_.data(), size);
      }
    }
    if (!got) {
      ended_ = true;
      if (auto last = assembler_.flush()) ready_.push_back(std::move(*last));
      if (assembler_.stats().sweeps == 0)
        throw io::InputError(endpoint_.describe() + ": no sweep decoded (" + summary() + ")");
    }
  }
  return std::move(ready_[ready_pos_++]);
}

void VelodyneLidar::checkModel(const std::uint8_t* data, std::size_t size) {
  const auto model = velodyne::packetModel(data, size);
  if (model && *model != assembler_.model()) {
    const LaserCalibration& c = assembler_.calibration();
    throw io::InputError(endpoint_.describe() + ": the packets are an " + velodyne::modelName(*model) +
                         "'s, but the calibration " + c.source + " has " + std::to_string(c.laserCount()) +
                         " lasers (an " + velodyne::modelName(assembler_.model()) + "); give the " +
                         velodyne::modelName(*model) + "'s calibration, or none to take the shipped one");
  }
}

void VelodyneLidar::position(const std::uint8_t* data, std::size_t size) {
  ++position_.packets;
  std::string why;
  const auto packet = velodyne::parsePositionPacket(data, size, &why);
  const auto note = [this](const std::string& reason) {
    if (position_.first_problem.empty()) position_.first_problem = reason;
  };
  if (!packet) {
    ++position_.unreadable;
    note("position packet " + std::to_string(position_.packets) + ": " + why);
    return;
  }
  if (packet->nmea.empty()) {
    ++position_.no_sentence;
    return;
  }
  const auto fix = velodyne::parseNmea(packet->nmea, &why);
  if (!fix) {
    ++position_.bad_sentence;
    note("position packet " + std::to_string(position_.packets) + ": '" + packet->nmea + "': " + why);
    return;
  }
  if (!fix->valid) {
    ++position_.no_fix;
    return;
  }
  // a receiver that sends $GPRMC and $GPGGA for one epoch (one packet timestamp) gives one fix, the
  // GGA's, which has the altitude
  const GpsFix g = velodyne::gpsFix(*packet, *fix, options_.decoder.time_base);
  if (last_fix_stamp_ == static_cast<std::int64_t>(packet->timestamp_us)) {
    if (!fix->altitude_m) return;  // an RMC after the epoch's GGA
    if (!fixes_.empty() && fixes_.back().time == g.time) {
      fixes_.back() = g;  // the GGA after the epoch's RMC
      return;
    }
  }
  last_fix_stamp_ = packet->timestamp_us;
  ++position_.fixes;
  fixes_.push_back(g);
}

std::vector<GpsFix> VelodyneLidar::takeFixes() {
  std::vector<GpsFix> out;
  out.swap(fixes_);
  return out;
}

std::string PositionStats::summary() const {
  std::ostringstream s;
  s << packets << " position packets, " << fixes << " GPS fixes";
  if (no_fix > 0) s << ", " << no_fix << " without a fix";
  if (no_sentence > 0) s << ", " << no_sentence << " without a sentence";
  if (bad_sentence > 0) s << ", " << bad_sentence << " with a bad sentence";
  if (unreadable > 0) s << ", " << unreadable << " unreadable";
  if (!first_problem.empty()) s << " (first: " << first_problem << ")";
  return s.str();
}

std::string VelodyneLidar::summary() const {
  std::string s =
      endpoint_.describe() + " (" + velodyne::modelName(assembler_.model()) + "): " + assembler_.stats().summary();
  if (position_.packets > 0) s += "; " + position_.summary();
  if (pcap_) s += "; capture: " + pcap_->stats().summary();
  return s;
}

// ---------------------------------------------------------------------------------------------
// lidar from one place, the other sensors from another

LidarSwapSource::LidarSwapSource(std::unique_ptr<SensorSource> others, std::unique_ptr<VelodyneLidar> lidar)
    : others_(std::move(others)), lidar_(std::move(lidar)) {
  truth_by_laser_.resize(static_cast<std::size_t>(lidar_->calibration().laserCount()));
}

void LidarSwapSource::pullUntil(double time) {
  while (!others_done_ && pulled_until_ < time) {
    auto f = others_->next();
    if (!f) {
      others_done_ = true;
      break;
    }
    const SensorFrame& s = f->sensors;
    pulled_until_ = s.sweep.end_time;
    gps_.insert(gps_.end(), s.gps.begin(), s.gps.end());
    gyro_.insert(gyro_.end(), s.gyro.begin(), s.gyro.end());
    for (const CameraImage& image : s.images) {
      Image im{image.time, image, {}};
      im.truth.camera = image.camera;
      if (f->truth) {
        for (const CameraTruth& t : f->truth->cameras) {
          if (t.camera == image.camera) im.truth = t;
        }
      }
      images_.push_back(std::move(im));
    }
    if (f->truth) {
      has_truth_ = true;
      poses_.insert(poses_.end(), f->truth->poses.begin(), f->truth->poses.end());
      const auto& pts = s.sweep.points;
      for (std::size_t i = 0; i < pts.size() && i < f->truth->points.size(); ++i) {
        if (pts[i].ring < truth_by_laser_.size())
          truth_by_laser_[pts[i].ring].push_back({pts[i].time, f->truth->points[i]});
      }
    }
  }
}

std::optional<RigFrame> LidarSwapSource::next() {
  auto sweep = lidar_->next();
  if (!sweep) return std::nullopt;
  // everything timed before the sweep's end, as the simulated rig and datasets frame it; the
  // packets time the end to about a microsecond, and what is timed at the boundary itself
  // belongs to the next sweep
  const double end = sweep->end_time - 2e-6;
  pullUntil(end);
  RigFrame frame;
  SensorFrame& s = frame.sensors;
  s.index = index_++;
  auto take = [end](auto& buffer, auto& into) {
    auto it = buffer.begin();
    while (it != buffer.end() && it->time < end) ++it;
    into.assign(buffer.begin(), it);
    buffer.erase(buffer.begin(), it);
  };
  take(gps_, s.gps);
  take(gyro_, s.gyro);
  std::vector<Image> images;
  take(images_, images);
  // each camera's latest image of the window, in camera order
  std::map<int, const Image*> latest;
  for (const Image& im : images) latest[im.image.camera] = &im;
  for (const auto& [camera, im] : latest) s.images.push_back(im->image);
  if (has_truth_) {
    FrameTruth t;
    for (const auto& [camera, im] : latest) {
      if (!im->truth.depth.empty() || !im->truth.segmentation.empty()) t.cameras.push_back(im->truth);
    }
    // poses over the sweep and one either side, for interpolation
    const double start = sweep->start_time;
    auto first = std::find_if(poses_.begin(), poses_.end(), [&](const TimedPose& p) { return p.time >= start; });
    if (first != poses_.begin()) --first;
    for (auto it = first; it != poses_.end(); ++it) {
      t.poses.push_back(*it);
      if (it->time > end) break;
    }
    poses_.erase(poses_.begin(), first);
    // each point takes the truth of its partner: same laser, same firing
    t.points.resize(sweep->points.size());
    for (std::size_t i = 0; i < sweep->points.size(); ++i) {
      const LidarPoint& p = sweep->points[i];
      auto& list = truth_by_laser_[p.ring];
      auto it = std::lower_bound(list.begin(), list.end(), p.time - 1e-5,
                                 [](const TruthPoint& a, double time) { return a.time < time; });
      if (it != list.end() && std::abs(it->time - p.time) <= 1e-5) {
        t.points[i] = it->truth;
      } else {
        ++points_without_truth_;
      }
    }
    for (auto& list : truth_by_laser_) {
      while (!list.empty() && list.front().time < start - 1e-3) list.pop_front();
    }
    frame.truth = std::move(t);
  }
  s.sweep = std::move(*sweep);
  return frame;
}

}  // namespace terrain::rig
