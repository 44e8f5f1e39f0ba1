#pragma once
// pcap capture files of lidar traffic, through libpcap: a writer that wraps each packet payload in
// Ethernet/IPv4/UDP as a Velodyne sensor sends it (so Wireshark, VeloView and PCL's HDLGrabber
// open the file), and a reader that returns the UDP payloads sent to one port and counts
// everything else.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace terrain::rig::pcap {

// Capture time of simulated time 0: 2026-01-01T00:00:00Z, the top of an hour, so that a packet's
// own timestamp (microseconds since the top of the hour) is the simulated time.
inline constexpr double kSimulationEpoch = 1767225600.0;

struct Frame {
  double time = 0;                    // [s] capture time (seconds since 1970)
  std::uint16_t port = 0;             // UDP destination port
  std::vector<std::uint8_t> payload;  // UDP payload as captured (may be cut short by the snap length)
};

struct ReadStats {
  long long frames = 0;     // records in the file
  long long payloads = 0;   // UDP datagrams to the port(s) read
  long long other = 0;      // other traffic: not IPv4/UDP, or another port
  long long fragments = 0;  // IPv4 fragments (a sensor never fragments)
  long long malformed = 0;  // headers cut short or inconsistent
  std::string error;        // why reading stopped early (a cut-off file), empty otherwise

  std::string summary() const;
};

class Reader {
 public:
  // Opens a capture (Ethernet, Linux cooked or raw IP link layer). Throws io::InputError naming
  // the file if it cannot be opened or its link layer is not one of those.
  Reader(const std::filesystem::path& path, std::uint16_t port);
  // ... returning the datagrams to any of these ports (Frame::port says which)
  Reader(const std::filesystem::path& path, std::vector<std::uint16_t> ports);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // The next UDP payload to the port(s); false at the end of the file (or where it is cut off).
  bool next(Frame& frame);
  const ReadStats& stats() const { return stats_; }

 private:
  struct Handle;
  std::unique_ptr<Handle> handle_;
  std::filesystem::path path_;
  std::vector<std::uint16_t> ports_;
  int link_ = 0;
  ReadStats stats_;
};

class Writer {
 public:
  // Writes into a temporary file that close() renames to path. Throws io::InputError if path
  // exists and overwrite is false.
  Writer(std::filesystem::path path, bool overwrite);
  ~Writer();  // without close(), the temporary file is removed and path left untouched
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // One UDP datagram from the sensor (192.168.3.43:2368) to the broadcast address, port 2368.
  // `port` is the destination (and source) port: 2368 data, 8308 position packets.
  void write(double time, const std::uint8_t* payload, std::size_t size, std::uint16_t port = 2368);
  void close();

 private:
  struct Handle;
  std::unique_ptr<Handle> handle_;
  std::filesystem::path path_, partial_;
  bool overwrite_;
  std::uint16_t ip_id_ = 0;
};

}  // namespace terrain::rig::pcap
