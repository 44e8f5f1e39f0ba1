#pragma once
// Velodyne position packets: the 512-byte UDP payload a Velodyne sends to port 8308 once a second
// when a GPS receiver is wired to it, and the NMEA sentences in it.
//
// Layout (little-endian): 198 bytes the HDL-32E fills with its gyro, temperature and accelerometer
// readings (not read here); at 198 a uint32 timestamp in microseconds since the top of the hour
// (the clock of the data packets); at 202 the PPS status on sensors that report it (0 none,
// 1 synchronising, 2 locked, 3 error); at 206 the NMEA sentence the receiver last sent ($GPRMC, or
// $GPGGA on some set-ups), ended by CR LF and padded with zeros.

#include "core/sensor_data.hpp"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace terrain::rig::velodyne {

inline constexpr std::size_t kPositionPacketSize = 512;
inline constexpr std::size_t kNmeaOffset = 206;

// What one NMEA sentence says about position and time.
struct NmeaFix {
  std::string type;                  // "GPRMC" or "GPGGA" (any talker: GN, GL, ... read alike)
  bool valid = false;                // RMC status A, or GGA quality > 0
  double time_of_day = 0;            // [s] UTC since midnight
  std::optional<double> epoch;       // [s] UTC since 1970 (RMC: it carries the date; GGA has none)
  double latitude_deg = 0;           // [deg] north positive
  double longitude_deg = 0;          // [deg] east positive
  std::optional<double> altitude_m;  // [m] GGA: above mean sea level plus the geoid separation
  std::optional<double> hdop;        // GGA horizontal dilution of precision
  double speed_mps = 0;              // RMC speed over ground [m/s]
};

// Parses one $--RMC or $--GGA sentence (with or without the trailing CR LF). Checks the checksum
// when the sentence has one. nullopt for anything else; *why (may be null) then names the reason.
std::optional<NmeaFix> parseNmea(const std::string& sentence, std::string* why = nullptr);

struct PositionPacket {
  std::uint32_t timestamp_us = 0;  // since the top of the hour
  std::uint8_t pps = 0;            // byte 202
  std::string nmea;                // the sentence, without CR LF; empty if there is none
};

// Reads a position packet. nullopt (and *why) if the payload is not 512 bytes or its timestamp
// lies beyond the hour.
std::optional<PositionPacket> parsePositionPacket(const std::uint8_t* data, std::size_t size,
                                                  std::string* why = nullptr);

// A position packet carrying `sentence` at `timestamp_us` (the tests' and the recorder's encoder).
std::vector<std::uint8_t> positionPacket(std::uint32_t timestamp_us, const std::string& sentence, std::uint8_t pps = 2);

// An NMEA $GPRMC sentence (with checksum, no CR LF) for a fix at UTC `epoch` [s since 1970].
std::string gprmcSentence(double epoch, double latitude_deg, double longitude_deg, double speed_mps = 0,
                          bool valid = true);

// An NMEA $GPGGA sentence (with checksum, no CR LF) for a fix at UTC `epoch` [s since 1970]: quality 1
// (GPS), 12 satellites, the given HDOP, altitude [m] with a geoid separation of 0 (so that it reads
// back as the ellipsoidal height), angles to 1e-7 minute (0.2 mm).
std::string gpggaSentence(double epoch, double latitude_deg, double longitude_deg, double altitude_m, double hdop);

// Position packets for a rig's GPS fixes, as a Velodyne with a receiver wired to it would send
// them: a $GPGGA for every fix and a $GPRMC (it carries the date) once a second, each at its fix's
// time, stamped with that time's microseconds since the top of the hour. `epoch` [s since 1970,
// UTC] is the UTC time of rig time 0.
struct TimedPosition {
  double time = 0;  // [s] rig time
  std::vector<std::uint8_t> payload;
};
class PositionEncoder {
 public:
  explicit PositionEncoder(double epoch) : epoch_(epoch) {}
  // appends the packets of these fixes (in time order) to out
  void add(const std::vector<GpsFix>& fixes, std::vector<TimedPosition>& out);

 private:
  double epoch_;
  double last_rmc_second_ = -1;
};

// The time base [s] that puts a packet timestamp on UTC: the top of the hour such that
// base + timestamp_us lies nearest to the UTC time the packet's sentence gives.
double timeBaseFromFix(std::uint32_t timestamp_us, double fix_epoch);

// The GPS fix of a valid sentence in a position packet, at the packet's own time on the data
// packets' clock (time_base + timestamp). Altitude is taken from GGA (0 from RMC: it has none);
// sigma_m from HDOP times 2.5 m when GGA gives it, else 5 m.
GpsFix gpsFix(const PositionPacket& packet, const NmeaFix& fix, double time_base);

}  // namespace terrain::rig::velodyne
