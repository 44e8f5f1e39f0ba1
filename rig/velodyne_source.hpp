#pragma once
// The real Velodyne path: lidar packets from a live UDP socket or a pcap capture, decoded into
// sweeps (rig/velodyne_packet.hpp), and a rig that takes its lidar from there while the camera,
// GPS and gyro come from another source (a dataset, the simulator), matched by timestamp.

#include "rig/pcap_file.hpp"
#include "rig/sensor_source.hpp"
#include "rig/velodyne_packet.hpp"
#include "rig/velodyne_position.hpp"

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

namespace terrain::rig {

// Where lidar packets come from: "pcap:FILE" or "udp:HOST:PORT" (HOST the address to bind,
// 0.0.0.0 for every interface; PORT defaults to 2368 when left out, as in "udp:0.0.0.0"; port 0
// binds any free port).
struct LidarEndpoint {
  enum class Kind { Pcap, Udp } kind = Kind::Udp;
  std::string path;              // pcap file
  std::string host = "0.0.0.0";  // udp bind address
  std::uint16_t port = velodyne::kDataPort;

  // Throws io::InputError naming the text (as `role`: what the endpoint is for) if it is neither
  // form. HOST is an IPv4 address in dotted form or localhost.
  static LidarEndpoint parse(const std::string& text, const std::string& role = "lidar source");
  std::string describe() const;
};

// A bound UDP socket that receives datagrams.
class UdpReceiver {
 public:
  // Binds host:port (port 0: any free port). Throws io::InputError naming the address on failure.
  UdpReceiver(const std::string& host, std::uint16_t port);
  ~UdpReceiver();
  UdpReceiver(const UdpReceiver&) = delete;
  UdpReceiver& operator=(const UdpReceiver&) = delete;

  // Waits up to timeout for a datagram; returns its full size (which may exceed the buffer,
  // whose content is then cut), or -1 on timeout.
  long receive(std::uint8_t* buffer, std::size_t capacity, std::chrono::milliseconds timeout);
  std::uint16_t port() const { return port_; }

 private:
  int fd_ = -1;
  std::uint16_t port_ = 0;
};

// Sends datagrams to one address.
class UdpSender {
 public:
  UdpSender(const std::string& host, std::uint16_t port);  // throws io::InputError naming the address
  ~UdpSender();
  UdpSender(const UdpSender&) = delete;
  UdpSender& operator=(const UdpSender&) = delete;
  void send(const std::uint8_t* data, std::size_t size);

 private:
  int fd_ = -1;
  std::vector<std::uint8_t> address_;
};

struct VelodyneOptions {
  velodyne::DecoderOptions decoder;
  double idle_timeout = 2.0;    // [s] a live stream ends after this long without a packet (once one came)
  double first_timeout = 30.0;  // [s] no packet within this long is an error
};

// What the position packets (port 8308) of a capture held.
struct PositionStats {
  long long packets = 0;       // datagrams to port 8308
  long long unreadable = 0;    // not a position packet (size, timestamp)
  long long no_sentence = 0;   // no NMEA sentence in it
  long long bad_sentence = 0;  // a sentence that does not parse (checksum, fields)
  long long no_fix = 0;        // a sentence that says the receiver has no fix (RMC V, GGA quality 0)
  long long fixes = 0;         // valid fixes
  std::string first_problem;   // the first unreadable packet's or bad sentence's reason

  std::string summary() const;
};

// Sweeps from a live sensor or a capture. Position packets become GPS fixes on the data packets'
// clock (takeFixes): a capture's, and a live source's when it was handed a position socket.
//
// Failures (io::InputError, naming the source): packets of another model than the calibration's
// (the calibration says 64 lasers, the packets are an HDL-32E's); no packet within first_timeout
// on a live source; a stream that ends without a single sweep.
class VelodyneLidar {
 public:
  VelodyneLidar(const LidarEndpoint& endpoint, LaserCalibration calibration, VelodyneOptions options = {});
  // A live source on sockets already bound (data, and position unless null) whose first data
  // packet was read already (`first`, decoded before anything else is received): the caller chose
  // the laser table and time base from it.
  VelodyneLidar(const LidarEndpoint& endpoint, std::unique_ptr<UdpReceiver> data, std::unique_ptr<UdpReceiver> position,
                std::vector<std::uint8_t> first, LaserCalibration calibration, VelodyneOptions options);
  ~VelodyneLidar();

  // The next complete sweep; the partial sweep at the end of the stream comes last; nullopt after.
  std::optional<LidarSweep> next();

  const velodyne::DecodeStats& stats() const { return assembler_.stats(); }
  const PositionStats& positionStats() const { return position_; }
  // the capture reader's counters (zeros for a live source)
  pcap::ReadStats captureStats() const { return pcap_ ? pcap_->stats() : pcap::ReadStats{}; }
  // GPS fixes decoded since the last call, oldest first
  std::vector<GpsFix> takeFixes();
  // decoder counters, and for a capture the reader's
  std::string summary() const;
  const LaserCalibration& calibration() const { return assembler_.calibration(); }
  velodyne::Model model() const { return assembler_.model(); }
  // the bound UDP port of a live source (useful after binding port 0), 0 for a capture
  std::uint16_t port() const { return udp_ ? udp_->port() : 0; }
  // the bound position port of a live source, 0 if it reads none
  std::uint16_t positionPort() const { return position_udp_ ? position_udp_->port() : 0; }

 private:
  LidarEndpoint endpoint_;
  VelodyneOptions options_;
  velodyne::SweepAssembler assembler_;
  std::unique_ptr<pcap::Reader> pcap_;
  std::unique_ptr<UdpReceiver> udp_, position_udp_;
  std::vector<std::uint8_t> buffer_;  // one datagram, for a live source
  std::vector<std::uint8_t> first_;   // a live source's first data packet, not decoded yet
  void drainPositions();
  std::vector<LidarSweep> ready_;
  std::size_t ready_pos_ = 0;
  bool ended_ = false;
  bool received_ = false;
  void position(const std::uint8_t* data, std::size_t size);
  void checkModel(const std::uint8_t* data, std::size_t size);
  PositionStats position_;
  std::vector<GpsFix> fixes_;
  std::int64_t last_fix_stamp_ = -1;  // packet timestamp of the last fix taken (-1: none yet)
};

// A rig whose lidar sweeps come from a VelodyneLidar and whose camera, GPS and gyro come from
// another source: each sweep takes the images, fixes and gyro samples timed from its start to
// just before its end, as the simulated rig frames them. When the other source carries ground truth, each decoded point
// takes the truth of the other source's point of the same laser and firing (within 10 us); poses and images keep
// theirs; a point without a partner gets class 0 (unknown), which scoring skips.
class LidarSwapSource : public SensorSource {
 public:
  LidarSwapSource(std::unique_ptr<SensorSource> others, std::unique_ptr<VelodyneLidar> lidar);

  const RigCalibration& calibration() const override { return others_->calibration(); }
  const LaserCalibration& lasers() const override { return lidar_->calibration(); }
  std::optional<RigFrame> next() override;
  int frameCount() const override { return others_->frameCount(); }

  const VelodyneLidar& lidar() const { return *lidar_; }
  // decoded points that found no partner in the other source's truth
  long long pointsWithoutTruth() const { return points_without_truth_; }

 private:
  void pullUntil(double time);

  std::unique_ptr<SensorSource> others_;
  std::unique_ptr<VelodyneLidar> lidar_;
  bool others_done_ = false;
  double pulled_until_ = -1e300;
  int index_ = 0;
  long long points_without_truth_ = 0;
  bool has_truth_ = false;
  // buffered from the other source, oldest first
  std::vector<GpsFix> gps_;
  std::vector<GyroSample> gyro_;
  struct Image {
    double time = 0;
    CameraImage image;
    CameraTruth truth;  // empty images where the other source has no truth
  };
  std::vector<Image> images_;
  std::vector<TimedPose> poses_;
  struct TruthPoint {
    double time;
    PointTruth truth;
  };
  std::vector<std::deque<TruthPoint>> truth_by_laser_;
};

}  // namespace terrain::rig
