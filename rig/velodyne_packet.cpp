#include "rig/velodyne_packet.hpp"

#include "rig/file_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

namespace terrain::rig::velodyne {

namespace {

constexpr int kBlockBytes = 100;
constexpr int kMaxStepJump = 1000;  // 10 deg: more between neighbouring blocks is not a spinning sensor

std::uint16_t get16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t get32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
void put16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v & 0xFF);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFF);
}

std::uint32_t microsIntoHour(double time) {
  const long long us = std::llround(time * 1e6);
  const long long h = static_cast<long long>(kMicrosPerHour);
  return static_cast<std::uint32_t>(((us % h) + h) % h);
}

}  // namespace

ModelTiming timing(Model model) {
  // HDL-64E S2: 20,833 firings of 64 lasers per second, 6 per packet (about 3,472 packets/s);
  // HDL-32E: a firing cycle of 46.08 us, 12 per packet (about 1,808 packets/s)
  if (model == Model::Hdl32E) return {32, 12, 46.08e-6};
  return {64, 6, 1.0 / 20833.3};
}

Model modelForLasers(int lasers, const std::string& origin) {
  if (lasers == 64) return Model::Hdl64E;
  if (lasers == 32) return Model::Hdl32E;
  throw io::InputError(origin + ": " + std::to_string(lasers) +
                       " lasers; the packet decoder reads the HDL-64E (64 lasers) and the HDL-32E (32 lasers)");
}

const char* modelName(Model model) { return model == Model::Hdl32E ? "HDL-32E" : "HDL-64E"; }

const char* returnModeName(ReturnMode mode) {
  switch (mode) {
    case ReturnMode::Last:
      return "last";
    case ReturnMode::Dual:
      return "dual";
    default:
      return "strongest";
  }
}

std::optional<Model> packetModel(const std::uint8_t* data, std::size_t size, std::string* why) {
  const auto fail = [why](const std::string& reason) -> std::optional<Model> {
    if (why) *why = reason;
    return std::nullopt;
  };
  if (size != kPacketSize) return fail(std::to_string(size) + " bytes, not the 1206 of a data packet");
  bool all_upper = true, alternating = true;
  for (int b = 0; b < kBlocksPerPacket; ++b) {
    const std::uint16_t id = get16(data + b * kBlockBytes);
    all_upper = all_upper && id == kUpperBlock;
    alternating = alternating && id == (b % 2 == 0 ? kUpperBlock : kLowerBlock);
  }
  if (alternating) return Model::Hdl64E;
  if (!all_upper)
    return fail("block ids are neither the HDL-64E's (0xEEFF, 0xDDFF in turn) nor the HDL-32E's (0xEEFF)");
  const std::uint8_t factory = data[1205];
  if (factory == 0x21 || factory == 0) return Model::Hdl32E;
  if (factory == 0x22) return fail("a VLP-16 packet (model byte 0x22), which this decoder does not read");
  if (factory == 0x28) return fail("a VLP-32C packet (model byte 0x28), which this decoder does not read");
  std::ostringstream s;
  s << "model byte 0x" << std::hex << int(factory) << " is no HDL-32E's (0x21)";
  return fail(s.str());
}

ReturnMode packetReturnMode(const std::uint8_t* data, Model model) {
  if (model != Model::Hdl32E) return ReturnMode::Strongest;
  if (data[1204] == 0x38) return ReturnMode::Last;
  if (data[1204] == 0x39) return ReturnMode::Dual;
  return ReturnMode::Strongest;
}

std::uint32_t payloadTimestamp(const std::uint8_t* data) { return get32(data + kBlocksPerPacket * kBlockBytes); }

std::string DecodeStats::summary() const {
  std::ostringstream s;
  s << packets << " packets, " << accepted << " decoded, " << points << " points, " << sweeps << " sweeps";
  auto add = [&](long long n, const char* what) {
    if (n > 0) s << ", " << n << ' ' << what;
  };
  add(dual_packets, "in dual return mode");
  add(second_returns, "second returns");
  add(wrong_size, "of the wrong size");
  add(bad_block, "with a bad block id");
  add(bad_position, "with a bad rotational position");
  add(bad_timestamp, "with a bad timestamp");
  add(duplicates, "duplicated");
  add(out_of_order, "out of order");
  add(lost, "lost");
  return s.str();
}

// ---------------------------------------------------------------------------------------------
// encoder

PacketEncoder::PacketEncoder(LaserCalibration calibration, int firings_per_turn)
    : calibration_(std::move(calibration)),
      model_(modelForLasers(calibration_.laserCount(), calibration_.source)),
      timing_(timing(model_)),
      firings_per_turn_(firings_per_turn) {
  if (firings_per_turn_ < 1) throw io::InputError("packet encoder: firings per revolution must be positive");
}

void PacketEncoder::addSweep(const LidarSweep& sweep, std::vector<TimedPacket>& out) {
  const int n = firings_per_turn_;
  const double period = sweep.end_time - sweep.start_time;
  const int lasers = calibration_.laserCount();
  std::vector<Firing> firings(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) {
    firings[j].time = sweep.start_time + period * j / n;
    firings[j].step = encoderStep(j, n);
  }
  for (const LidarPoint& p : sweep.points) {
    // the firing this point belongs to, and whether it really is that firing's
    const long long j = period > 0 ? std::llround((p.time - sweep.start_time) * n / period) : -1;
    if (j < 0 || j >= n || p.ring >= lasers ||
        std::abs(p.azimuth - static_cast<float>(stepToRadians(firings[j].step))) > 1e-5f) {
      ++stats_.off_schedule;
      continue;
    }
    // distance along the beam, less the calibration's distance correction, in raw units
    const LaserCorrection& l = calibration_.lasers[p.ring];
    Vector3 o, dir;
    laserRay(l, p.azimuth, o, dir);
    const double t = (Vector3(p.x, p.y, p.z) - o).dot(dir);
    const long long raw = std::llround((t - l.dist_correction) / calibration_.distance_resolution);
    if (raw < 1) {
      ++stats_.too_close;
      continue;
    }
    if (raw > 65535) {
      ++stats_.too_far;
      continue;
    }
    firings[j].distance[p.ring] = static_cast<std::uint16_t>(raw);
    firings[j].intensity[p.ring] = static_cast<std::uint8_t>(std::lround(std::clamp(p.intensity, 0.0f, 255.0f)));
    ++stats_.points;
  }
  for (const Firing& f : firings) addFiring(f, out);
}

void PacketEncoder::addFiring(const Firing& f, std::vector<TimedPacket>& out) {
  pending_.push_back(f);
  if (static_cast<int>(pending_.size()) < timing_.firings_per_packet) return;
  TimedPacket packet;
  std::uint8_t* d = packet.payload.data();
  const int blocks_per_firing = kBlocksPerPacket / timing_.firings_per_packet;
  for (int k = 0; k < timing_.firings_per_packet; ++k) {
    const Firing& fk = pending_[k];
    for (int b = 0; b < blocks_per_firing; ++b) {
      std::uint8_t* block = d + (k * blocks_per_firing + b) * kBlockBytes;
      put16(block, b == 0 ? kUpperBlock : kLowerBlock);
      put16(block + 2, static_cast<std::uint16_t>(fk.step));
      for (int i = 0; i < kReturnsPerBlock; ++i) {
        const int laser = b * kReturnsPerBlock + i;
        put16(block + 4 + 3 * i, fk.distance[laser]);
        block[6 + 3 * i] = fk.intensity[laser];
      }
    }
  }
  put32(d + kBlocksPerPacket * kBlockBytes, microsIntoHour(pending_.front().time));
  // status bytes: the HDL-32E reports its return mode (0x37 strongest) and model (0x21)
  d[1204] = model_ == Model::Hdl32E ? 0x37 : 0;
  d[1205] = model_ == Model::Hdl32E ? 0x21 : 0;
  packet.time = pending_.back().time + timing_.firing_period;
  out.push_back(packet);
  ++stats_.packets;
  pending_.clear();
}

void PacketEncoder::finish(std::vector<TimedPacket>& out) {
  if (pending_.empty()) return;
  Firing pad;
  pad.step = pending_.back().step;
  pad.time = pending_.back().time;
  while (!pending_.empty()) {
    pad.time += timing_.firing_period;
    addFiring(pad, out);
  }
}

// ---------------------------------------------------------------------------------------------
// decoder

SweepAssembler::SweepAssembler(LaserCalibration calibration, DecoderOptions options)
    : calibration_(std::move(calibration)),
      options_(options),
      model_(modelForLasers(calibration_.laserCount(), calibration_.source)),
      timing_(timing(model_)) {
  // cosine and sine of every rotational position, computed once for all decoders
  static const std::pair<std::vector<double>, std::vector<double>> tables = [] {
    std::pair<std::vector<double>, std::vector<double>> t;
    for (int s = 0; s < kStepsPerTurn; ++s) {
      t.first.push_back(std::cos(stepToRadians(s)));
      t.second.push_back(std::sin(stepToRadians(s)));
    }
    return t;
  }();
  cos_step_ = &tables.first;
  sin_step_ = &tables.second;
  for (const LaserCorrection& l : calibration_.lasers) {
    cos_rot_.push_back(std::cos(l.rot_correction));
    sin_rot_.push_back(std::sin(l.rot_correction));
    cos_vert_.push_back(std::cos(l.vert_correction));
    sin_vert_.push_back(std::sin(l.vert_correction));
  }
}

bool SweepAssembler::push(const std::uint8_t* data, std::size_t size, std::vector<LidarSweep>& out) {
  ++stats_.packets;
  if (size != kPacketSize) {
    ++stats_.wrong_size;
    return false;
  }
  // the block ids and positions must be those of a spinning sensor of this model; in dual return
  // mode (HDL-32E) the blocks come in pairs at one position
  const ReturnMode mode = packetReturnMode(data, model_);
  const int copies = mode == ReturnMode::Dual ? 2 : 1;
  const int ids_per_firing = kBlocksPerPacket / timing_.firings_per_packet;
  const int blocks_per_firing = ids_per_firing * copies;
  const int firings = kBlocksPerPacket / blocks_per_firing;
  int steps[kBlocksPerPacket];
  for (int b = 0; b < kBlocksPerPacket; ++b) {
    const std::uint8_t* block = data + b * kBlockBytes;
    const std::uint16_t id = get16(block);
    const std::uint16_t expected = (b % ids_per_firing == 0) ? kUpperBlock : kLowerBlock;
    if (id != expected) {
      ++stats_.bad_block;
      ++rejected_since_;
      return false;
    }
    steps[b] = get16(block + 2);
    const bool pair_apart = copies == 2 && b % 2 == 1 && steps[b] != steps[b - 1];
    if (steps[b] > kStepsPerTurn || pair_apart ||
        (b > 0 && (steps[b] - steps[b - 1] + kStepsPerTurn) % kStepsPerTurn > kMaxStepJump)) {
      ++stats_.bad_position;
      ++rejected_since_;
      return false;
    }
  }
  const std::uint32_t stamp = payloadTimestamp(data);
  if (stamp >= kMicrosPerHour) {
    ++stats_.bad_timestamp;
    ++rejected_since_;
    return false;
  }
  // time order: an hour rollover moves on, anything older than the last packet is refused
  const long long hour_us = kMicrosPerHour;
  long long hours = hours_;
  if (have_payload_ && static_cast<long long>(stamp) + hours * hour_us < last_time_us_ - hour_us / 2) ++hours;
  const long long time_us = static_cast<long long>(stamp) + hours * hour_us;
  if (have_payload_) {
    if (time_us == last_time_us_ && std::memcmp(data, last_payload_.data(), kPacketSize) == 0) {
      ++stats_.duplicates;
      return false;
    }
    if (time_us <= last_time_us_) {
      ++stats_.out_of_order;
      return false;
    }
    const double packet_us = firings * timing_.firing_period * 1e6;
    const double gap = (time_us - last_time_us_) / packet_us;
    // the slots between the two packets that rejected packets took were not lost
    if (gap > 1.5) stats_.lost += std::max(0LL, std::llround(gap) - 1 - rejected_since_);
  }
  rejected_since_ = 0;
  hours_ = hours;
  last_time_us_ = time_us;
  std::memcpy(last_payload_.data(), data, kPacketSize);
  have_payload_ = true;
  ++stats_.accepted;
  if (copies == 2) ++stats_.dual_packets;

  const double packet_time = options_.time_base + time_us * 1e-6;
  const double res = calibration_.distance_resolution;
  for (int b = 0; b < kBlocksPerPacket; ++b) {
    const std::uint8_t* block = data + b * kBlockBytes;
    const int step = steps[b];
    const int firing = b / blocks_per_firing;
    const double t = packet_time + firing * timing_.firing_period;
    // a new revolution starts where the position wraps
    if (b % blocks_per_firing == 0) {
      if (!have_last_) {
        current_.start_time = t;
      } else if (step < last_step_) {
        current_.end_time = t;
        if (!current_.points.empty()) {
          out.push_back(std::move(current_));
          ++stats_.sweeps;
        }
        current_ = LidarSweep{};
        current_.start_time = t;
      }
      have_last_ = true;
      last_step_ = step;
    }
    const int first_laser = (b % ids_per_firing) * kReturnsPerBlock;
    const bool second = copies == 2 && b % 2 == 1;  // the strongest return of a dual pair
    const int direction = step % kStepsPerTurn;     // 36000 is 0 degrees
    const double ca = (*cos_step_)[direction], sa = (*sin_step_)[direction];
    for (int i = 0; i < kReturnsPerBlock; ++i) {
      const std::uint8_t* r = block + 4 + 3 * i;
      const std::uint16_t raw = get16(r);
      if (raw == 0) continue;
      if (second && get16(r - kBlockBytes) == raw) continue;  // the same return as the last one
      const int laser = first_laser + i;
      const LaserCorrection& l = calibration_.lasers[laser];
      const double range = raw * res + l.dist_correction;
      if (range < options_.min_range || range > options_.max_range) continue;
      // the ray of rig::laserRay at azimuth step - rot_correction
      const double cz = ca * cos_rot_[laser] + sa * sin_rot_[laser];
      const double sz = sa * cos_rot_[laser] - ca * sin_rot_[laser];
      const double xy = range * cos_vert_[laser];
      LidarPoint p;
      p.x = static_cast<float>(xy * cz + l.horiz_offset * sz);
      p.y = static_cast<float>(-xy * sz + l.horiz_offset * cz);
      p.z = static_cast<float>(range * sin_vert_[laser] + l.vert_offset);
      p.intensity = r[2];
      p.ring = static_cast<std::uint16_t>(laser);
      p.azimuth = static_cast<float>(stepToRadians(direction));
      p.time = t;
      current_.points.push_back(p);
      ++stats_.points;
      if (second) ++stats_.second_returns;
    }
  }
  current_.end_time = packet_time + firings * timing_.firing_period;
  return true;
}

std::optional<LidarSweep> SweepAssembler::flush() {
  if (current_.points.empty()) return std::nullopt;
  LidarSweep s = std::move(current_);
  current_ = LidarSweep{};
  have_last_ = false;
  ++stats_.sweeps;
  return s;
}

}  // namespace terrain::rig::velodyne
