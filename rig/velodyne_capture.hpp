#pragma once
// A real Velodyne capture on its own: what it holds (model, counters, sweeps, GPS from its
// position packets, its time base), the laser table that fits it, and a sensor source that runs
// the pipeline from it with no simulated part.

#include "rig/sensor_folder.hpp"
#include "rig/sensor_source.hpp"
#include "rig/velodyne_source.hpp"

#include <deque>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace terrain::rig {

// The laser table the project ships for a model (data/calibration/): the HDL-64E S2.1 of the ROS
// driver's examples, the HDL-32E's standard table. Units of one model differ by a few
// centimetres and tenths of a degree; give a unit's own file where there is one.
std::filesystem::path shippedCalibration(velodyne::Model model);

// One decoded sweep; the first and the last of a capture are usually partial revolutions.
struct SweepSummary {
  double start_time = 0;  // [s] on the capture's time base
  double end_time = 0;
  long long points = 0;
  bool partial = false;  // covers less than 95 % of a turn
};

// Everything one pass over a capture finds. `error` is set (and the rest holds what was found up
// to there) when the capture cannot be decoded: no data packet, none of a model this decoder
// reads, packets of two models, no sweep.
struct CaptureScan {
  std::filesystem::path file;
  std::optional<velodyne::Model> model;      // from the first data packet of a known layout
  std::string calibration;                   // the table decoded with (shipped, or given)
  long long packets_by_mode[3] = {0, 0, 0};  // strongest, last, dual
  pcap::ReadStats read;
  velodyne::DecodeStats decode;
  PositionStats position;
  std::vector<GpsFix> fixes;  // on the time base below
  std::vector<SweepSummary> sweeps;
  double time_base = 0;                  // [s] added to the packets' time since the top of the hour
  std::string time_base_source;          // "gps" (the position packets' NMEA time), "capture clock" or "given"
  double first_time = 0, last_time = 0;  // [s] first and last firing, on the time base
  double rotation_hz = 0;                // median over the complete sweeps; 0 without one
  std::vector<std::string> warnings;     // cut-off file, lost and rejected packets, partial sweeps
  std::string error;
};

struct CaptureOptions {
  std::filesystem::path calibration;  // empty: the shipped table of the capture's model
  std::optional<double> time_base;    // given: used as is; else from the GPS, else the capture clock
  VelodyneOptions lidar;              // decoder ranges (its time_base is set from the above)
  // a live sensor (CaptureSource's live constructor): the UDP port its position packets (GPS) come
  // to, on the data socket's address, read as data packets arrive (0: none are read)
  std::uint16_t position_port = velodyne::kPositionPort;
};

// The time base of a capture (GPS when its position packets hold a valid RMC sentence, else the
// capture clock of its first data packet), the model of its first data packet and the laser
// table to use; throws io::InputError naming the file when there is no data packet of a known
// model, or the given calibration has another number of lasers than the model.
struct CaptureSetup {
  velodyne::Model model = velodyne::Model::Hdl64E;
  LaserCalibration lasers;
  double time_base = 0;
  std::string time_base_source;
  std::optional<GpsFix> first_fix;  // the first valid fix of the position packets
  long long data_packets = 0;
  std::string cut_off;  // why reading stopped before the end of the file, empty if it did not
};
CaptureSetup setupCapture(const std::filesystem::path& path, const CaptureOptions& options);

// Decodes the whole capture (setupCapture, then every packet), handing each sweep to on_sweep
// (may be empty) as it is decoded. Input errors end up in `error`; so does an exception of
// on_sweep's that is an io::InputError.
using SweepCallback = std::function<void(const LidarSweep&, const SweepSummary&)>;
CaptureScan scanCapture(const std::filesystem::path& path, const CaptureOptions& options,
                        const SweepCallback& on_sweep = {});

// The pipeline's input from a capture: lidar sweeps and GPS fixes from the position packets. Alone,
// no camera and no gyro: the vehicle frame has the lidar mast_height above its origin and the GPS
// antenna at the lidar (a Velodyne's GPS input carries no lever arm). With a sensor folder, its
// calibration places the lidar, the antenna and the cameras (mast_height is not used), and each
// sweep carries the folder's images and gyro samples timed in (the previous sweep's end, its end].
// The world origin is the first fix (0, 0 without one: the pipeline then keeps the rig where it
// stands, heading east).
//
// Live (udp:HOST:PORT), the same from a sensor on the network, with no sensor folder: the data port
// is bound, and options.position_port unless 0; the first data packet of a known model (within
// options.lidar.first_timeout) gives the model and so the laser table (the given one must fit it),
// and the time base when none is given (the top of the hour that puts that packet nearest to the
// host clock: setup().time_base_source "host clock"). The constructor then reads sweeps until a
// GPS fix comes or they span 2 s, and keeps them for next(). Throws io::InputError naming the
// address when a port cannot be bound or no data packet arrives.
class CaptureSource : public SensorSource {
 public:
  CaptureSource(const std::filesystem::path& path, const CaptureOptions& options, double mast_height,
                std::shared_ptr<const SensorFolder> sensors = nullptr);
  CaptureSource(const LidarEndpoint& live, const CaptureOptions& options, double mast_height);

  const RigCalibration& calibration() const override { return calibration_; }
  const LaserCalibration& lasers() const override { return lidar_->calibration(); }
  std::optional<RigFrame> next() override;
  int frameCount() const override { return -1; }

  const VelodyneLidar& lidar() const { return *lidar_; }
  const CaptureSetup& setup() const { return setup_; }

 private:
  CaptureSetup setup_;
  RigCalibration calibration_;
  std::unique_ptr<VelodyneLidar> lidar_;
  std::shared_ptr<const SensorFolder> sensors_;
  std::vector<GpsFix> pending_;
  std::deque<LidarSweep> buffered_;  // sweeps read before the first frame (live: waiting for a fix)
  void placeRig(double mast_height);
  double last_end_ = -std::numeric_limits<double>::infinity();  // the previous sweep's end [s]
  int index_ = 0;
};

}  // namespace terrain::rig
