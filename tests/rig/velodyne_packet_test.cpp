#include "rig/velodyne_packet.hpp"

#include "rig/file_io.hpp"
#include "rig/pcap_file.hpp"
#include "rig/velodyne_source.hpp"
#include "sim/simulated_rig.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <pcl/io/hdl_grabber.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <mutex>
#include <random>
#include <thread>

namespace terrain::rig {
namespace {

namespace fs = std::filesystem;
using velodyne::Payload;
using velodyne::SweepAssembler;
using velodyne::TimedPacket;

const std::string kData = std::string(TERRAIN_SOURCE_DIR) + "/tests/data/velodyne/";

LaserCalibration hdl64() {
  return loadLaserCalibration(std::string(TERRAIN_SOURCE_DIR) + "/data/calibration/hdl64e_s2.1-sztaki.yaml");
}

// simulated sweeps of a flat ground and a wall 20 m ahead, noise on, camera off
struct Simulated {
  std::vector<LidarSweep> sweeps;
  int firings_per_turn = 0;
};
Simulated simulate(int frames) {
  auto world = test::wallWorld(20.0);
  sim::SimConfig cfg;
  cfg.camera.enabled = false;
  sim::SimulatedRig rig(world, cfg, frames);
  Simulated s;
  s.firings_per_turn = rig.firingsPerTurn();
  while (auto f = rig.next()) s.sweeps.push_back(f->sensors.sweep);
  return s;
}

std::vector<TimedPacket> encode(const Simulated& s, const LaserCalibration& lasers) {
  velodyne::PacketEncoder encoder(lasers, s.firings_per_turn);
  std::vector<TimedPacket> packets;
  for (const auto& sweep : s.sweeps) encoder.addSweep(sweep, packets);
  encoder.finish(packets);
  return packets;
}

std::vector<LidarSweep> decode(SweepAssembler& a, const std::vector<TimedPacket>& packets) {
  std::vector<LidarSweep> out;
  for (const auto& p : packets) a.push(p.payload.data(), p.payload.size(), out);
  if (auto last = a.flush()) out.push_back(*last);
  return out;
}

void writePcap(const fs::path& path, const std::vector<TimedPacket>& packets) {
  pcap::Writer w(path, true);
  for (const auto& p : packets) w.write(pcap::kSimulationEpoch + p.time, p.payload.data(), p.payload.size());
  w.close();
}

// ---------------------------------------------------------------------------------------------

TEST(VelodynePacketTest, LayoutOfOneHandMadeFiring) {
  // one laser table without corrections; one return of laser 33 at 10 m, position 90.00 deg
  LaserCalibration c = hdl64();
  for (auto& l : c.lasers) l = LaserCorrection{l.id};
  LidarSweep sweep;
  sweep.start_time = 0;
  sweep.end_time = 0.1;
  LidarPoint p;
  p.ring = 33;
  p.time = 0.025;  // firing 500 of 2000
  p.azimuth = static_cast<float>(velodyne::stepToRadians(9000));
  p.x = 0, p.y = -10, p.z = 0;
  p.intensity = 77;
  sweep.points.push_back(p);
  velodyne::PacketEncoder encoder(c, 2000);
  std::vector<TimedPacket> packets;
  encoder.addSweep(sweep, packets);
  ASSERT_EQ(packets.size(), 333u);  // 2000 firings, 6 per packet, the last 2 still pending
  // firing 500 is the third of packet 83 (firings 498..503): blocks 4 (upper) and 5 (lower)
  const std::uint8_t* d = packets[83].payload.data();
  EXPECT_EQ(d[400], 0xFF);
  EXPECT_EQ(d[401], 0xEE);
  EXPECT_EQ(d[500], 0xFF);
  EXPECT_EQ(d[501], 0xDD);
  EXPECT_EQ(d[502] | (d[503] << 8), 9000);
  EXPECT_EQ(d[504 + 3] | (d[505 + 3] << 8), 5000);  // laser 33 = lower block, slot 1: 10 m / 2 mm
  EXPECT_EQ(d[506 + 3], 77);
  // timestamp: the packet's first firing, 498 * 50 us after the top of the hour
  EXPECT_EQ(velodyne::payloadTimestamp(d), 24900u);
  // decoding gives the point back
  SweepAssembler a(c);
  std::vector<LidarSweep> out;
  for (const auto& pk : packets) ASSERT_TRUE(a.push(pk.payload.data(), pk.payload.size(), out));
  auto s = a.flush();
  ASSERT_TRUE(s);
  ASSERT_EQ(s->points.size(), 1u);
  EXPECT_NEAR(s->points[0].x, 0.0, 1e-5);
  EXPECT_NEAR(s->points[0].y, -10.0, 1e-5);
  EXPECT_EQ(s->points[0].ring, 33);
  EXPECT_EQ(s->points[0].intensity, 77);
  // firing times follow the 64E's own firing period (48 us) from the packet's stamp
  EXPECT_NEAR(s->points[0].time, 0.025, 5e-6);
}

TEST(VelodynePacketTest, SimulatedSweepsSurviveTheRoundTripWithin2mm) {
  const Simulated sim = simulate(3);
  const LaserCalibration lasers = hdl64();
  velodyne::PacketEncoder encoder(lasers, sim.firings_per_turn);
  std::vector<TimedPacket> packets;
  for (const auto& sweep : sim.sweeps) encoder.addSweep(sweep, packets);
  encoder.finish(packets);
  EXPECT_EQ(encoder.stats().off_schedule + encoder.stats().too_close + encoder.stats().too_far, 0);
  // 64E: 6 firings a packet
  EXPECT_EQ(packets.size(), static_cast<std::size_t>((3 * sim.firings_per_turn + 5) / 6));
  SweepAssembler a(lasers);
  const auto decoded = decode(a, packets);
  EXPECT_EQ(a.stats().rejected(), 0) << a.stats().summary();
  EXPECT_EQ(a.stats().lost, 0);
  ASSERT_EQ(decoded.size(), sim.sweeps.size());
  for (std::size_t k = 0; k < decoded.size(); ++k) {
    const auto& in = sim.sweeps[k].points;
    const auto& out = decoded[k].points;
    ASSERT_EQ(in.size(), out.size()) << "sweep " << k;
    ASSERT_GT(in.size(), 50000u);
    EXPECT_NEAR(decoded[k].start_time, sim.sweeps[k].start_time, 1e-6);
    // a sweep ends where the next begins; the last one where its last packet ends
    EXPECT_NEAR(decoded[k].end_time, sim.sweeps[k].end_time, k + 1 < decoded.size() ? 1e-6 : 6 * 48e-6);
    double worst = 0;
    for (std::size_t i = 0; i < in.size(); ++i) {
      ASSERT_EQ(in[i].ring, out[i].ring);
      ASSERT_EQ(in[i].azimuth, out[i].azimuth);
      ASSERT_NEAR(in[i].time, out[i].time, 1e-6);
      ASSERT_NEAR(in[i].intensity, out[i].intensity, 0.5);
      worst = std::max(worst, (Vector3(in[i].x, in[i].y, in[i].z) - Vector3(out[i].x, out[i].y, out[i].z)).norm());
    }
    // half a 2 mm unit along the beam, plus float rounding of points up to 120 m away
    EXPECT_LT(worst, 1.0e-3 + 2e-5) << "sweep " << k;
  }
}

TEST(VelodynePacketTest, Hdl32eRoundTrip) {
  // the same encoder and decoder for 32 lasers: 12 firings a packet, every block 0xEEFF
  const LaserCalibration lasers = loadLaserCalibration(kData + "32db.yaml");
  LidarSweep sweep;
  sweep.end_time = 0.1;
  const int n = 2170;
  for (int j = 0; j < n; j += 7) {
    for (int l = 0; l < 32; l += 3) {
      Vector3 o, dir;
      const double a = velodyne::stepToRadians(velodyne::encoderStep(j, n));
      laserRay(lasers.lasers[l], a, o, dir);
      const Vector3 p = o + (5.0 + 0.01 * l + 0.001 * (j % 13)) * dir;
      sweep.points.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()), 10.0f,
                              static_cast<std::uint16_t>(l), static_cast<float>(a), 0.1 * j / n});
    }
  }
  velodyne::PacketEncoder encoder(lasers, n);
  EXPECT_EQ(encoder.model(), velodyne::Model::Hdl32E);
  std::vector<TimedPacket> packets;
  encoder.addSweep(sweep, packets);
  encoder.finish(packets);
  ASSERT_EQ(packets.size(), static_cast<std::size_t>((n + 11) / 12));
  for (int b = 0; b < 12; ++b) EXPECT_EQ(packets[0].payload[100 * b + 1], 0xEE);
  SweepAssembler a(lasers);
  const auto out = decode(a, packets);
  ASSERT_EQ(out.size(), 1u);
  ASSERT_EQ(out[0].points.size(), sweep.points.size());
  for (std::size_t i = 0; i < sweep.points.size(); ++i) {
    const auto& p = sweep.points[i];
    const auto& q = out[0].points[i];
    EXPECT_LT((Vector3(p.x, p.y, p.z) - Vector3(q.x, q.y, q.z)).norm(), 1.0e-3 + 1e-5);
    EXPECT_NEAR(p.time, q.time, 1e-6);  // 46.08 us firings stamped to the microsecond
  }
}

// ---------------------------------------------------------------------------------------------
// robustness: each bad packet is counted and skipped, the sweeps stay those of the good packets

struct Stream {
  LaserCalibration lasers = hdl64();
  std::vector<TimedPacket> packets;
  std::vector<LidarSweep> clean;
  Stream() {
    Simulated sim = simulate(2);
    packets = encode(sim, lasers);
    SweepAssembler a(lasers);
    clean = decode(a, packets);
  }
};
const Stream& stream() {
  static Stream s;
  return s;
}

TEST(VelodynePacketTest, BadPacketsAreCountedAndSkipped) {
  const Stream& s = stream();
  SweepAssembler a(s.lasers);
  std::vector<LidarSweep> out;
  std::mt19937 rng(7);
  long long offered = 0, sizes = 0, headers = 0, again = 0;
  for (std::size_t i = 0; i < s.packets.size(); ++i) {
    const Payload& p = s.packets[i].payload;
    if (i % 50 == 10) {  // truncated and oversized
      EXPECT_FALSE(a.push(p.data(), 1205, out));
      std::vector<std::uint8_t> big(p.begin(), p.end());
      big.push_back(0);
      EXPECT_FALSE(a.push(big.data(), big.size(), out));
      sizes += 2;
    }
    if (i % 50 == 20) {  // wrong block id, position out of range, position jumping, garbage
      Payload bad = p;
      bad[500] = 0x12;
      EXPECT_FALSE(a.push(bad.data(), bad.size(), out));
      bad = p;
      bad[202] = 0xA1, bad[203] = 0x8C;  // 36001: past a turn
      EXPECT_FALSE(a.push(bad.data(), bad.size(), out));
      bad = p;
      bad[602] = static_cast<std::uint8_t>(bad[602] + 0x10), bad[603] = static_cast<std::uint8_t>(bad[603] + 0x10);
      EXPECT_FALSE(a.push(bad.data(), bad.size(), out));
      for (auto& b : bad) b = static_cast<std::uint8_t>(rng());
      EXPECT_FALSE(a.push(bad.data(), bad.size(), out));
      headers += 4;
    }
    ASSERT_TRUE(a.push(p.data(), p.size(), out));
    ++offered;
    if (i % 50 == 30) {  // the same packet again, and an older one
      EXPECT_FALSE(a.push(p.data(), p.size(), out));
      EXPECT_FALSE(a.push(s.packets[i - 3].payload.data(), p.size(), out));
      again += 1;
    }
  }
  if (auto last = a.flush()) out.push_back(*last);
  const auto& st = a.stats();
  EXPECT_EQ(st.packets, offered + sizes + headers + 2 * again);
  EXPECT_EQ(st.accepted, static_cast<long long>(s.packets.size()));
  EXPECT_EQ(st.wrong_size, sizes);
  EXPECT_EQ(st.bad_block + st.bad_position + st.bad_timestamp, headers);
  EXPECT_GE(st.bad_position, headers / 2);
  EXPECT_EQ(st.duplicates, again);
  EXPECT_EQ(st.out_of_order, again);
  EXPECT_EQ(st.lost, 0);
  ASSERT_EQ(out.size(), s.clean.size());
  for (std::size_t k = 0; k < out.size(); ++k) ASSERT_EQ(out[k].points.size(), s.clean[k].points.size());
}

// Real sensors send position 36000 now and then just before the wrap (..., 35979, 36000, 18, ...):
// it is 360 degrees, the direction of 0, and the packet keeps its returns.
TEST(VelodynePacketTest, PositionThirtySixThousandIsZeroDegreesAndKeepsItsReturns) {
  const Stream& s = stream();
  const Payload& original = s.packets[5].payload;
  Payload p = original;
  // the packet's six firings (two blocks each) at 35985, 35988, ..., 36000
  for (int b = 0; b < 12; ++b) {
    const int step = 35985 + 3 * (b / 2);
    p[b * 100 + 2] = static_cast<std::uint8_t>(step & 0xFF), p[b * 100 + 3] = static_cast<std::uint8_t>(step >> 8);
  }
  SweepAssembler a(s.lasers), reference(s.lasers);
  std::vector<LidarSweep> out;
  ASSERT_TRUE(a.push(p.data(), p.size(), out));
  ASSERT_TRUE(reference.push(original.data(), original.size(), out));
  EXPECT_EQ(a.stats().bad_position, 0);
  EXPECT_EQ(a.stats().points, reference.stats().points);  // every return kept
  const auto sweep = a.flush();
  ASSERT_TRUE(sweep);
  int at_zero = 0;
  for (const auto& q : sweep->points) {
    EXPECT_GE(q.azimuth, 0.0f);
    EXPECT_LT(q.azimuth, static_cast<float>(2 * M_PI));
    at_zero += q.azimuth == 0.0f;
  }
  EXPECT_GT(at_zero, 0);  // the last firing's returns, at 0 degrees
  // the next packet's positions past the wrap start a new sweep; no packet in between was lost
  Payload next = s.packets[6].payload;
  for (int b = 0; b < 12; ++b) {
    const int step = 3 + 3 * (b / 2);
    next[b * 100 + 2] = static_cast<std::uint8_t>(step & 0xFF),
                   next[b * 100 + 3] = static_cast<std::uint8_t>(step >> 8);
  }
  SweepAssembler c(s.lasers);
  ASSERT_TRUE(c.push(p.data(), p.size(), out));
  out.clear();
  ASSERT_TRUE(c.push(next.data(), next.size(), out));
  EXPECT_EQ(out.size(), 1u);
  EXPECT_EQ(c.stats().lost, 0);
}

// A packet rejected for its content took its slot in the stream: it is counted as rejected, not
// also as lost.
TEST(VelodynePacketTest, ARejectedPacketIsNotAlsoCountedAsLost) {
  const Stream& s = stream();
  SweepAssembler a(s.lasers);
  std::vector<LidarSweep> out;
  for (std::size_t i = 0; i < 20; ++i) {
    Payload p = s.packets[i].payload;
    if (i == 7) p[0] = 0x12;  // a bad block id
    a.push(p.data(), p.size(), out);
  }
  EXPECT_EQ(a.stats().bad_block, 1);
  EXPECT_EQ(a.stats().lost, 0);
  // a packet that never came is lost
  a.push(s.packets[22].payload.data(), velodyne::kPacketSize, out);
  EXPECT_EQ(a.stats().lost, 2);
}

TEST(VelodynePacketTest, LostPacketsAreCountedAndLeaveHolesNotWrongSweeps) {
  const Stream& s = stream();
  SweepAssembler a(s.lasers);
  std::vector<LidarSweep> out;
  std::size_t dropped_points = 0;
  for (std::size_t i = 0; i < s.packets.size(); ++i) {
    if (i % 100 == 50 || i % 100 == 51) {
      SweepAssembler one(s.lasers);
      std::vector<LidarSweep> tmp;
      one.push(s.packets[i].payload.data(), velodyne::kPacketSize, tmp);
      dropped_points += one.flush() ? one.stats().points : 0;
      continue;
    }
    a.push(s.packets[i].payload.data(), velodyne::kPacketSize, out);
  }
  if (auto last = a.flush()) out.push_back(*last);
  EXPECT_EQ(a.stats().lost, 2 * static_cast<long long>((s.packets.size() + 49) / 100));
  ASSERT_EQ(out.size(), s.clean.size());
  std::size_t total = 0, clean_total = 0;
  for (std::size_t k = 0; k < out.size(); ++k) total += out[k].points.size(), clean_total += s.clean[k].points.size();
  EXPECT_EQ(total + dropped_points, clean_total);
}

TEST(VelodynePacketTest, DecoderRefusesCalibrationsItCannotUse) {
  LaserCalibration c = hdl64();
  c.lasers.resize(16);
  try {
    SweepAssembler a(c);
    FAIL() << "a 16-laser table was taken for a 64E or 32E";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("16 lasers"), std::string::npos) << e.what();
  }
  // a table with a laser missing never gets this far: the parser names it
  const std::string yaml = io::readFile(kData + "32db.yaml");
  const auto cut = yaml.find("laser_id: 5,");
  ASSERT_NE(cut, std::string::npos);
  std::string broken = yaml;
  broken.replace(cut, 12, "laser_id: 6,");
  EXPECT_THROW(parseLaserCalibration(broken, "broken.yaml"), io::InputError);
  // structures the field checks do not expect (found by the calibration fuzzer) are refused too
  for (const char* text : {"lasers: [1, 2]", "distance_resolution: [x]\nlasers: []", "lasers:\n- {laser_id: [0]}"}) {
    EXPECT_THROW(parseLaserCalibration(text, "odd.yaml"), io::InputError) << text;
  }
}

// ---------------------------------------------------------------------------------------------
// pcap files

TEST(VelodynePcapTest, WriterAndReaderRoundTripAndOtherTrafficIsSkipped) {
  test::TempDir dir;
  const Stream& s = stream();
  std::vector<TimedPacket> few(s.packets.begin(), s.packets.begin() + 40);
  writePcap(dir / "a.pcap", few);
  // another file: the same packets with other traffic between them, written by hand
  {
    std::string bytes = io::readFile(dir / "a.pcap");
    std::string mixed = bytes.substr(0, 24);
    std::size_t off = 24;
    int k = 0;
    while (off < bytes.size()) {
      const std::uint32_t len =
          static_cast<std::uint8_t>(bytes[off + 8]) | (static_cast<std::uint8_t>(bytes[off + 9]) << 8);
      std::string rec = bytes.substr(off, 16 + len);
      off += 16 + len;
      mixed += rec;
      std::string other = rec;
      if (k % 3 == 0) other[16 + 12] = 0x08, other[16 + 13] = 0x06;  // ARP
      if (k % 3 == 1) other[16 + 14 + 9] = 6;                        // TCP
      if (k % 3 == 2) other[16 + 14 + 20 + 3] = 0x41;                // UDP to port 2369 (0x0941)
      mixed += other;
      ++k;
    }
    std::ofstream(dir / "mixed.pcap", std::ios::binary) << mixed;
  }
  for (const char* name : {"a.pcap", "mixed.pcap"}) {
    pcap::Reader r(dir / name, velodyne::kDataPort);
    pcap::Frame f;
    std::size_t i = 0;
    while (r.next(f)) {
      ASSERT_LT(i, few.size());
      ASSERT_EQ(f.payload.size(), velodyne::kPacketSize);
      EXPECT_EQ(0, std::memcmp(f.payload.data(), few[i].payload.data(), velodyne::kPacketSize));
      EXPECT_NEAR(f.time, pcap::kSimulationEpoch + few[i].time, 1e-6);
      ++i;
    }
    EXPECT_EQ(i, few.size()) << name;
    EXPECT_TRUE(r.stats().error.empty());
    EXPECT_EQ(r.stats().other, std::string(name) == "mixed.pcap" ? 40 : 0) << r.stats().summary();
  }
}

TEST(VelodynePcapTest, CutOffAndForeignFilesAreReportedNotCrashed) {
  test::TempDir dir;
  const Stream& s = stream();
  std::vector<TimedPacket> few(s.packets.begin(), s.packets.begin() + 10);
  writePcap(dir / "a.pcap", few);
  const std::string bytes = io::readFile(dir / "a.pcap");
  std::ofstream(dir / "cut.pcap", std::ios::binary) << bytes.substr(0, bytes.size() - 500);
  pcap::Reader r(dir / "cut.pcap", velodyne::kDataPort);
  pcap::Frame f;
  int n = 0;
  while (r.next(f)) ++n;
  EXPECT_EQ(n, 9);
  EXPECT_FALSE(r.stats().error.empty());
  std::ofstream(dir / "text.pcap") << "not a capture at all\n";
  try {
    pcap::Reader bad(dir / "text.pcap", velodyne::kDataPort);
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("text.pcap"), std::string::npos);
  }
  EXPECT_THROW(pcap::Reader(dir / "missing.pcap", velodyne::kDataPort), io::InputError);
  // the writer never replaces a file unless told to
  EXPECT_THROW(pcap::Writer(dir / "a.pcap", false), io::InputError);
  EXPECT_EQ(io::readFile(dir / "a.pcap"), bytes);
}

// ---------------------------------------------------------------------------------------------
// agreement with PCL's HDLGrabber

using Cloud = pcl::PointCloud<pcl::PointXYZI>;

std::vector<Cloud::ConstPtr> grab(const std::string& corrections, const fs::path& pcap, double seconds) {
  pcl::HDLGrabber grabber(corrections, pcap.string());
  float min_distance = 0.001f;  // skip returns of distance 0 (no return), as our decoder does
  grabber.setMinimumDistanceThreshold(min_distance);
  std::mutex m;
  std::vector<Cloud::ConstPtr> sweeps;
  std::function<void(const Cloud::ConstPtr&)> cb = [&](const Cloud::ConstPtr& c) {
    std::lock_guard<std::mutex> lock(m);
    sweeps.push_back(c);
  };
  grabber.registerCallback(cb);
  grabber.start();
  // the grabber replays at the capture's own pace and then idles
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  grabber.stop();
  return sweeps;
}

// PCL's frame has y forward at azimuth 0 and x to the right; ours x forward, y left
void expectSameSweep(const Cloud& pcl_sweep, const LidarSweep& ours, double tolerance) {
  ASSERT_EQ(pcl_sweep.size(), ours.points.size());
  for (std::size_t i = 0; i < ours.points.size(); ++i) {
    const auto& q = pcl_sweep[i];
    const auto& p = ours.points[i];
    ASSERT_NEAR(p.x, q.y, tolerance) << i;
    ASSERT_NEAR(p.y, -q.x, tolerance) << i;
    ASSERT_NEAR(p.z, q.z, tolerance) << i;
    ASSERT_EQ(p.intensity, q.intensity) << i;
  }
}

TEST(VelodynePclTest, RealHdl32eCaptureDecodesLikeHdlGrabber) {
  const fs::path capture = kData + "hdl32e_sample.pcap";
  VelodyneLidar lidar(LidarEndpoint::parse("pcap:" + capture.string()), loadLaserCalibration(kData + "32db.yaml"));
  std::vector<LidarSweep> ours;
  while (auto s = lidar.next()) ours.push_back(*s);
  EXPECT_EQ(lidar.stats().rejected(), 0) << lidar.summary();
  // PCL without a corrections file uses its HDL-32E table
  const auto theirs = grab("", capture, 1.5);
  ASSERT_EQ(theirs.size(), 3u);
  ASSERT_GE(ours.size(), 3u);
  std::size_t total = 0;
  for (int k = 0; k < 3; ++k) {
    expectSameSweep(*theirs[k], ours[k], 1e-4);
    total += ours[k].points.size();
  }
  EXPECT_EQ(total, 138832u);
}

TEST(VelodynePclTest, HdlGrabberReadsOurSimulatedHdl64eCapture) {
  test::TempDir dir;
  const Simulated sim = simulate(3);
  writePcap(dir / "sim.pcap", encode(sim, hdl64()));
  // PCL reads the same unit's db.xml
  const auto theirs = grab(kData + "64e_s2.1-sztaki.xml", dir / "sim.pcap", 1.3);
  ASSERT_EQ(theirs.size(), 2u);  // the grabber hands a sweep over when the next one begins
  VelodyneLidar lidar(LidarEndpoint::parse("pcap:" + (dir / "sim.pcap").string()),
                      loadLaserCalibration(kData + "64e_s2.1-sztaki.xml"));
  for (int k = 0; k < 2; ++k) {
    auto ours = lidar.next();
    ASSERT_TRUE(ours);
    expectSameSweep(*theirs[k], *ours, 1e-4);
    // and both are the simulated points, within the 2 mm quantisation
    ASSERT_EQ(ours->points.size(), sim.sweeps[k].points.size());
    for (std::size_t i = 0; i < ours->points.size(); i += 97) {
      const auto& p = ours->points[i];
      const auto& q = sim.sweeps[k].points[i];
      EXPECT_LT((Vector3(p.x, p.y, p.z) - Vector3(q.x, q.y, q.z)).norm(), 1.1e-3);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// live UDP

TEST(VelodyneUdpTest, LoopbackStreamDecodesLikeTheCapture) {
  // packets sent over loopback at the sensor's own pace reach the driver as they were sent
  const Stream& s = stream();
  VelodyneOptions options;
  options.idle_timeout = 1.0;
  VelodyneLidar lidar(LidarEndpoint::parse("udp:127.0.0.1:0"), s.lasers, options);
  const std::uint16_t port = lidar.port();
  ASSERT_GT(port, 0);
  std::thread sender([&] {
    UdpSender out("127.0.0.1", port);
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& p : s.packets) {
      std::this_thread::sleep_until(t0 + std::chrono::duration<double>(p.time));
      out.send(p.payload.data(), p.payload.size());
    }
  });
  std::vector<LidarSweep> got;
  while (auto sweep = lidar.next()) got.push_back(*sweep);
  sender.join();
  EXPECT_EQ(lidar.stats().accepted, static_cast<long long>(s.packets.size())) << lidar.summary();
  ASSERT_EQ(got.size(), s.clean.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    ASSERT_EQ(got[k].points.size(), s.clean[k].points.size());
    for (std::size_t i = 0; i < got[k].points.size(); ++i) {
      ASSERT_EQ(got[k].points[i].x, s.clean[k].points[i].x);
      ASSERT_EQ(got[k].points[i].time, s.clean[k].points[i].time);
    }
  }
}

TEST(VelodyneUdpTest, EndpointsParseOrSayWhatIsWrong) {
  const auto a = LidarEndpoint::parse("udp:0.0.0.0:2368");
  EXPECT_EQ(a.kind, LidarEndpoint::Kind::Udp);
  EXPECT_EQ(a.port, 2368);
  EXPECT_EQ(LidarEndpoint::parse("udp:192.168.3.255").port, 2368);
  const auto b = LidarEndpoint::parse("pcap:/tmp/x.pcap");
  EXPECT_EQ(b.kind, LidarEndpoint::Kind::Pcap);
  EXPECT_EQ(b.path, "/tmp/x.pcap");
  for (const char* bad : {"tcp:1.2.3.4:5", "udp:1.2.3.4:99999", "udp:host.example:2368", "pcap:", "udp:1.2.3.4:x"}) {
    EXPECT_THROW(LidarEndpoint::parse(bad), io::InputError) << bad;
  }
}

}  // namespace
}  // namespace terrain::rig
