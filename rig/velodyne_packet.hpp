#pragma once
// Velodyne HDL-64E and HDL-32E data packets: the 1206-byte UDP payload, its encoder (simulated
// sweeps to packets) and a decoder that assembles packets into sweeps at the azimuth wrap.
//
// Payload layout (little-endian): 12 firing blocks of 100 bytes, each a uint16 block id (0xEEFF:
// lasers 0-31; 0xDDFF: lasers 32-63 of the HDL-64E), a uint16 rotational position in 0.01 deg
// and 32 returns of a uint16 distance (units of the calibration's distance_resolution, 2 mm) and
// a uint8 intensity, distance 0 meaning no return; then a uint32 timestamp in microseconds since
// the top of the hour and two status bytes.
//
// HDL-64E: each packet holds 6 firings of all 64 lasers, an upper block followed by a lower block
// at the same rotational position. HDL-32E: 12 firings of 32 lasers, every block 0xEEFF; its
// status bytes give the return mode (0x37 strongest, 0x38 last, 0x39 dual) and the model (0x21).
// In dual return mode the blocks come in pairs at one position, 6 firings per packet: the first of
// a pair holds the last return, the second the strongest (or, where the two are one, the second
// strongest); a return the second block repeats is decoded once.
// The packet's timestamp is the time of its first firing; later firings follow at the model's
// firing period. Points are computed with rig::laserRay (the db.xml correction model).

#include "core/sensor_data.hpp"
#include "rig/velodyne_calibration.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace terrain::rig::velodyne {

inline constexpr std::size_t kPacketSize = 1206;
inline constexpr int kBlocksPerPacket = 12;
inline constexpr int kReturnsPerBlock = 32;
inline constexpr std::uint16_t kUpperBlock = 0xEEFF;
inline constexpr std::uint16_t kLowerBlock = 0xDDFF;
inline constexpr std::uint16_t kDataPort = 2368;
inline constexpr std::uint16_t kPositionPort = 8308;  // position packets (rig/velodyne_position.hpp)
inline constexpr int kStepsPerTurn = 36000;           // rotational positions per revolution
inline constexpr std::uint32_t kMicrosPerHour = 3600000000u;

enum class Model { Hdl64E, Hdl32E };
enum class ReturnMode { Strongest, Last, Dual };

struct ModelTiming {
  int lasers = 64;
  int firings_per_packet = 6;
  double firing_period = 1.0 / 20833.3;  // [s] between firings of all lasers
};

ModelTiming timing(Model model);
// HDL-64E for 64 lasers, HDL-32E for 32; throws io::InputError naming origin otherwise.
Model modelForLasers(int lasers, const std::string& origin);
const char* modelName(Model model);
const char* returnModeName(ReturnMode mode);

// The sensor that sent a data packet, from its layout: upper and lower blocks in turn for the
// HDL-64E; upper blocks only, with model byte 0x21 (or 0, as older firmware sends), for the
// HDL-32E. nullopt for a payload that is no data packet this decoder reads; *why (may be null)
// then says what it is (the wrong size, a VLP-16 or VLP-32C by its model byte, unknown blocks).
std::optional<Model> packetModel(const std::uint8_t* data, std::size_t size, std::string* why = nullptr);
// The return mode of a data packet of that model: the HDL-32E's status byte (an unknown value
// reads as strongest); the HDL-64E S2 sends one return, strongest (its status bytes cycle
// through other information).
ReturnMode packetReturnMode(const std::uint8_t* data, Model model);

// Rotational position (0.01 deg steps) of firing j of n firings per revolution.
inline int encoderStep(long long j, long long n) {
  return static_cast<int>(((kStepsPerTurn * j * 2 + n) / (2 * n)) % kStepsPerTurn);
}
inline double stepToRadians(int step) { return step * (3.14159265358979323846 / 18000.0); }

using Payload = std::array<std::uint8_t, kPacketSize>;

struct TimedPacket {
  double time = 0;  // [s] when the sensor sends it (after its last firing)
  Payload payload{};
};

struct EncodeStats {
  long long points = 0;        // points written into packets
  long long too_close = 0;     // raw distance would be negative (closer than dist_correction)
  long long too_far = 0;       // raw distance above 65535 units
  long long off_schedule = 0;  // point not at a firing of the schedule, or laser out of range
  long long packets = 0;
};

// Turns simulated sweeps into packets, inverting the calibration so that decoding gives the
// points back within the distance quantisation. Firings follow the schedule of a lidar that
// fires n times per revolution at encoderStep(j, n); every firing is sent, with or without returns.
class PacketEncoder {
 public:
  PacketEncoder(LaserCalibration calibration, int firings_per_turn);

  // Appends the packets completed by this sweep. The sweep's points must be at scheduled firings
  // (point time = start + j * period / n, azimuth = stepToRadians(encoderStep(j, n))).
  void addSweep(const LidarSweep& sweep, std::vector<TimedPacket>& out);
  // Sends the last, partly filled packet (its empty firings repeat the last position, no returns).
  void finish(std::vector<TimedPacket>& out);

  const EncodeStats& stats() const { return stats_; }
  Model model() const { return model_; }

 private:
  struct Firing {
    double time = 0;
    int step = 0;
    std::array<std::uint16_t, 64> distance{};
    std::array<std::uint8_t, 64> intensity{};
  };
  void addFiring(const Firing& f, std::vector<TimedPacket>& out);

  LaserCalibration calibration_;
  Model model_;
  ModelTiming timing_;
  int firings_per_turn_;
  std::vector<Firing> pending_;
  EncodeStats stats_;
};

struct DecodeStats {
  long long packets = 0;         // payloads offered
  long long accepted = 0;        // decoded into points
  long long wrong_size = 0;      // not 1206 bytes (truncated or oversized)
  long long bad_block = 0;       // unknown block id, block order wrong for the model
  long long bad_position = 0;    // rotational position > 36000 or jumping inside the packet (36000 is 0 degrees)
  long long bad_timestamp = 0;   // timestamp beyond the hour
  long long duplicates = 0;      // the same packet again
  long long out_of_order = 0;    // older than the last accepted packet
  long long lost = 0;            // packets missing by the timestamps (rejected ones not among them)
  long long points = 0;          // returns decoded
  long long dual_packets = 0;    // packets in dual return mode
  long long second_returns = 0;  // returns of the second block of a dual pair (not repeats of the first)
  long long sweeps = 0;          // sweeps completed

  long long rejected() const {
    return wrong_size + bad_block + bad_position + bad_timestamp + duplicates + out_of_order;
  }
  // one line: every non-zero counter
  std::string summary() const;
};

struct DecoderOptions {
  double time_base = 0;    // [s] time of the top of the hour of the first packet
  double min_range = 0;    // [m] returns closer than this (from the beam origin) are dropped
  double max_range = 1e9;  // [m] returns farther than this are dropped
};

// Decodes packets into sweeps. A sweep ends where the rotational position wraps (a firing at a
// lower position than the one before it); its end time is the first firing of the next sweep.
// Position 36000, which real sensors send now and then just before the wrap, is 360 degrees: the
// direction of 0, in the sweep before the wrap (as PCL's and VeloView's decoders take it).
// Packets that fail a check are counted and skipped; a packet never reaches a sweep in part.
class SweepAssembler {
 public:
  explicit SweepAssembler(LaserCalibration calibration, DecoderOptions options = {});

  // Feeds one UDP payload; sweeps it completes are appended to out. Returns false if the
  // packet was rejected (the reason is counted in stats()).
  bool push(const std::uint8_t* data, std::size_t size, std::vector<LidarSweep>& out);
  // The sweep in progress at the end of the stream, if it has any points.
  std::optional<LidarSweep> flush();

  const DecodeStats& stats() const { return stats_; }
  Model model() const { return model_; }
  const LaserCalibration& calibration() const { return calibration_; }

 private:
  LaserCalibration calibration_;
  DecoderOptions options_;
  Model model_;
  ModelTiming timing_;
  const std::vector<double>* cos_step_ = nullptr;  // per rotational position
  const std::vector<double>* sin_step_ = nullptr;
  std::vector<double> cos_rot_, sin_rot_, cos_vert_, sin_vert_;  // per laser
  LidarSweep current_;
  bool have_last_ = false;
  int last_step_ = 0;
  long long last_time_us_ = 0;  // accepted packet timestamps, unwrapped over hours
  long long hours_ = 0;
  Payload last_payload_{};
  bool have_payload_ = false;
  long long rejected_since_ = 0;  // packets rejected for their content since the last accepted one
  DecodeStats stats_;
};

// Reads the 4-byte timestamp of a payload [us since the top of the hour].
std::uint32_t payloadTimestamp(const std::uint8_t* data);

}  // namespace terrain::rig::velodyne
