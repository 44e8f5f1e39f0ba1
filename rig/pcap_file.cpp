#include "rig/pcap_file.hpp"

#include "rig/file_io.hpp"

#include <pcap/pcap.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace terrain::rig::pcap {

namespace fs = std::filesystem;

namespace {

constexpr int kLinkEthernet = 1;       // DLT_EN10MB
constexpr int kLinkRaw = 101;          // LINKTYPE_RAW
constexpr int kLinkDltRaw = 12;        // DLT_RAW on most systems
constexpr int kLinkLinuxCooked = 113;  // DLT_LINUX_SLL

std::uint16_t big16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }
void putBig16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v & 0xFF);
}

// the Internet checksum of an IPv4 header
std::uint16_t ipChecksum(const std::uint8_t* h, int n) {
  std::uint32_t sum = 0;
  for (int i = 0; i < n; i += 2) sum += big16(h + i);
  while (sum >> 16) sum = (sum & 0xFFFF) + (sum >> 16);
  return static_cast<std::uint16_t>(~sum & 0xFFFF);
}

}  // namespace

struct Reader::Handle {
  pcap_t* pcap = nullptr;
  ~Handle() {
    if (pcap) pcap_close(pcap);
  }
};

struct Writer::Handle {
  pcap_t* pcap = nullptr;
  pcap_dumper_t* dumper = nullptr;
  ~Handle() {
    if (dumper) pcap_dump_close(dumper);
    if (pcap) pcap_close(pcap);
  }
};

std::string ReadStats::summary() const {
  std::ostringstream s;
  s << frames << " captured frames, " << payloads << " sensor datagrams";
  if (other > 0) s << ", " << other << " other traffic";
  if (fragments > 0) s << ", " << fragments << " IP fragments";
  if (malformed > 0) s << ", " << malformed << " malformed";
  if (!error.empty()) s << "; stopped early: " << error;
  return s.str();
}

Reader::Reader(const fs::path& path, std::uint16_t port) : Reader(path, std::vector<std::uint16_t>{port}) {}

Reader::Reader(const fs::path& path, std::vector<std::uint16_t> ports)
    : handle_(std::make_unique<Handle>()), path_(path), ports_(std::move(ports)) {
  if (!fs::exists(path)) throw io::InputError(path.string() + ": no such capture file");
  char err[PCAP_ERRBUF_SIZE] = {0};
  handle_->pcap = pcap_open_offline(path.c_str(), err);
  if (!handle_->pcap) throw io::InputError(path.string() + ": not a pcap capture (" + err + ")");
  link_ = pcap_datalink(handle_->pcap);
  if (link_ != kLinkEthernet && link_ != kLinkRaw && link_ != kLinkDltRaw && link_ != kLinkLinuxCooked) {
    throw io::InputError(path.string() + ": link layer type " + std::to_string(link_) +
                         " is not Ethernet, Linux cooked or raw IP");
  }
}

Reader::~Reader() = default;

bool Reader::next(Frame& frame) {
  while (true) {
    pcap_pkthdr* header = nullptr;
    const u_char* data = nullptr;
    const int rc = pcap_next_ex(handle_->pcap, &header, &data);
    if (rc == -2) return false;  // end of file
    if (rc < 0) {
      stats_.error = pcap_geterr(handle_->pcap);
      return false;
    }
    if (rc == 0) continue;
    ++stats_.frames;
    const std::size_t n = header->caplen;
    // link layer to IPv4
    std::size_t ip = 0;
    if (link_ == kLinkEthernet) {
      if (n < 14) {
        ++stats_.malformed;
        continue;
      }
      std::uint16_t type = big16(data + 12);
      ip = 14;
      if (type == 0x8100 && n >= 18) {  // one VLAN tag
        type = big16(data + 16);
        ip = 18;
      }
      if (type != 0x0800) {
        ++stats_.other;
        continue;
      }
    } else if (link_ == kLinkLinuxCooked) {
      if (n < 16) {
        ++stats_.malformed;
        continue;
      }
      if (big16(data + 14) != 0x0800) {
        ++stats_.other;
        continue;
      }
      ip = 16;
    }
    if (n < ip + 20) {
      ++stats_.malformed;
      continue;
    }
    const std::uint8_t* h = data + ip;
    if ((h[0] >> 4) != 4) {
      ++stats_.other;
      continue;
    }
    const std::size_t ihl = static_cast<std::size_t>(h[0] & 0x0F) * 4;
    if (ihl < 20 || n < ip + ihl + 8) {
      ++stats_.malformed;
      continue;
    }
    if (h[9] != 17) {
      ++stats_.other;
      continue;
    }
    if ((big16(h + 6) & 0x3FFF) != 0) {
      ++stats_.fragments;
      continue;
    }  // more-fragments flag or an offset
    const std::uint8_t* udp = h + ihl;
    const std::uint16_t port = big16(udp + 2);
    if (std::find(ports_.begin(), ports_.end(), port) == ports_.end()) {
      ++stats_.other;
      continue;
    }
    const std::size_t udp_len = big16(udp + 4);
    if (udp_len < 8) {
      ++stats_.malformed;
      continue;
    }
    // the payload as far as it was captured
    const std::size_t start = ip + ihl + 8;
    const std::size_t len = std::min(udp_len - 8, n - start);
    frame.time = header->ts.tv_sec + header->ts.tv_usec * 1e-6;
    frame.port = port;
    frame.payload.assign(data + start, data + start + len);
    ++stats_.payloads;
    return true;
  }
}

Writer::Writer(fs::path path, bool overwrite)
    : handle_(std::make_unique<Handle>()), path_(std::move(path)), overwrite_(overwrite) {
  if (fs::exists(path_) && !overwrite_) {
    throw io::InputError(path_.string() + ": exists (pass --force to replace it)");
  }
  if (!path_.parent_path().empty()) fs::create_directories(path_.parent_path());
  partial_ = path_;
  partial_ += ".partial";
  handle_->pcap = pcap_open_dead(DLT_EN10MB, 65535);
  handle_->dumper = handle_->pcap ? pcap_dump_open(handle_->pcap, partial_.c_str()) : nullptr;
  if (!handle_->dumper) throw io::InputError(partial_.string() + ": cannot write a capture file");
}

Writer::~Writer() {
  if (handle_ && handle_->dumper) {
    handle_.reset();
    std::error_code ec;
    fs::remove(partial_, ec);
  }
}

void Writer::write(double time, const std::uint8_t* payload, std::size_t size, std::uint16_t port) {
  std::vector<std::uint8_t> f(42 + size);
  // Ethernet: broadcast from a Velodyne address (OUI 60:76:88)
  const std::uint8_t mac[12] = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x60, 0x76, 0x88, 0x00, 0x00, 0x2B};
  std::copy(mac, mac + 12, f.begin());
  putBig16(&f[12], 0x0800);
  // IPv4 from 192.168.3.43 to 255.255.255.255, no fragmentation
  std::uint8_t* ip = &f[14];
  ip[0] = 0x45;
  putBig16(ip + 2, static_cast<std::uint16_t>(20 + 8 + size));
  putBig16(ip + 4, ip_id_++);
  putBig16(ip + 6, 0x4000);  // don't fragment
  ip[8] = 64;
  ip[9] = 17;
  const std::uint8_t addrs[8] = {192, 168, 3, 43, 255, 255, 255, 255};
  std::copy(addrs, addrs + 8, ip + 12);
  putBig16(ip + 10, ipChecksum(ip, 20));
  // UDP port -> port, checksum left out (optional over IPv4)
  std::uint8_t* udp = ip + 20;
  putBig16(udp, port);
  putBig16(udp + 2, port);
  putBig16(udp + 4, static_cast<std::uint16_t>(8 + size));
  std::copy(payload, payload + size, udp + 8);
  pcap_pkthdr h{};
  const double whole = std::floor(time);
  h.ts.tv_sec = static_cast<time_t>(whole);
  h.ts.tv_usec = static_cast<suseconds_t>(std::lround((time - whole) * 1e6));
  if (h.ts.tv_usec >= 1000000) {
    h.ts.tv_sec += 1;
    h.ts.tv_usec -= 1000000;
  }
  h.caplen = h.len = static_cast<bpf_u_int32>(f.size());
  pcap_dump(reinterpret_cast<u_char*>(handle_->dumper), &h, f.data());
}

void Writer::close() {
  if (!handle_->dumper) return;
  const bool ok = pcap_dump_flush(handle_->dumper) == 0;
  pcap_dump_close(handle_->dumper);
  handle_->dumper = nullptr;
  if (!ok) throw io::InputError(partial_.string() + ": writing the capture failed");
  if (fs::exists(path_) && !overwrite_) throw io::InputError(path_.string() + ": exists (pass --force to replace it)");
  fs::rename(partial_, path_);
}

}  // namespace terrain::rig::pcap
