#include "rig/velodyne_capture.hpp"

#include "rig/file_io.hpp"
#include "rig/pcap_file.hpp"
#include "rig/velodyne_position.hpp"
#include "tests/cli_support.hpp"
#include "tests/temp_dir.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <thread>

namespace terrain::rig {
namespace {

namespace fs = std::filesystem;
using velodyne::Model;
using velodyne::TimedPacket;

const std::string kData = std::string(TERRAIN_SOURCE_DIR) + "/tests/data/velodyne/";
const fs::path kSample = kData + "hdl32e_sample.pcap";

// packets of n firings per turn for `turns` turns of a ring 5 m out, every even laser at every firing, from the
// encoder of the given table (64 lasers: HDL-64E packets, 32: HDL-32E packets)
std::vector<TimedPacket> ringPackets(const LaserCalibration& lasers, int n, int turns, double start = 0.0) {
  velodyne::PacketEncoder encoder(lasers, n);
  std::vector<TimedPacket> packets;
  for (int t = 0; t < turns; ++t) {
    LidarSweep sweep;
    sweep.start_time = start + 0.1 * t;
    sweep.end_time = sweep.start_time + 0.1;
    for (int j = 0; j < n; ++j) {
      const double a = velodyne::stepToRadians(velodyne::encoderStep(j, n));
      for (int l = 0; l < lasers.laserCount(); l += 2) {
        Vector3 o, dir;
        laserRay(lasers.lasers[l], a, o, dir);
        const Vector3 p = o + 5.0 * dir;
        sweep.points.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()), 20.0f,
                                static_cast<std::uint16_t>(l), static_cast<float>(a), sweep.start_time + 0.1 * j / n});
      }
    }
    encoder.addSweep(sweep, packets);
  }
  encoder.finish(packets);
  return packets;
}

// a capture of those packets, with position packets carrying `sentences` once a second from `start`
void writeCapture(const fs::path& path, const std::vector<TimedPacket>& packets,
                  const std::vector<std::string>& sentences = {}, double epoch = pcap::kSimulationEpoch) {
  pcap::Writer w(path, true);
  std::size_t next_sentence = 0;
  for (const auto& p : packets) {
    const double due = static_cast<double>(next_sentence);
    if (next_sentence < sentences.size() && p.time >= due) {
      const auto pos =
          velodyne::positionPacket(static_cast<std::uint32_t>(std::llround(due * 1e6)), sentences[next_sentence]);
      w.write(epoch + due, pos.data(), pos.size(), velodyne::kPositionPort);
      ++next_sentence;
    }
    w.write(epoch + p.time, p.payload.data(), p.payload.size());
  }
  w.close();
}

// a capture of one position packet and nothing else
void writePositionOnly(const fs::path& path) {
  pcap::Writer w(path, true);
  const auto p = velodyne::positionPacket(1000, velodyne::gprmcSentence(pcap::kSimulationEpoch, 47, 8));
  w.write(pcap::kSimulationEpoch, p.data(), p.size(), velodyne::kPositionPort);
  w.close();
}

LaserCalibration hdl32() { return loadLaserCalibration(kData + "32db.yaml"); }
LaserCalibration hdl64() { return loadLaserCalibration(shippedCalibration(Model::Hdl64E)); }

// ---------------------------------------------------------------------------------------------

TEST(VelodyneCaptureTest, TheRealHdl32eCaptureDecodesAloneWithItsModelFound) {
  const CaptureScan scan = scanCapture(kSample, {});
  ASSERT_TRUE(scan.error.empty()) << scan.error;
  ASSERT_TRUE(scan.model.has_value());
  EXPECT_EQ(*scan.model, Model::Hdl32E);
  EXPECT_EQ(fs::path(scan.calibration), shippedCalibration(Model::Hdl32E));
  EXPECT_EQ(scan.decode.packets, 500);
  EXPECT_EQ(scan.decode.accepted, 500);
  EXPECT_EQ(scan.decode.rejected(), 0);
  EXPECT_EQ(scan.packets_by_mode[0], 500);  // strongest return (status byte 0x37)
  // three turns in 0.28 s: two whole sweeps between a partial first and a partial last one
  ASSERT_EQ(scan.sweeps.size(), 4u);
  EXPECT_TRUE(scan.sweeps.front().partial);
  EXPECT_FALSE(scan.sweeps[1].partial);
  EXPECT_FALSE(scan.sweeps[2].partial);
  EXPECT_TRUE(scan.sweeps.back().partial);
  EXPECT_GT(scan.rotation_hz, 8.0);
  EXPECT_LT(scan.rotation_hz, 11.0);
  // no position packets: the time base is the hour of the capture clock, 2011-10-28 02:00 UTC
  EXPECT_EQ(scan.position.packets, 0);
  EXPECT_EQ(scan.time_base_source, "capture clock");
  EXPECT_DOUBLE_EQ(scan.time_base, 1319767200.0);
  EXPECT_NEAR(scan.last_time - scan.first_time, 0.276, 0.005);
}

TEST(VelodyneCaptureTest, SyntheticHdl64eAndHdl32eCapturesAreEachFoundAsSuch) {
  test::TempDir dir;
  writeCapture(dir / "64.pcap", ringPackets(hdl64(), 2000, 3));
  writeCapture(dir / "32.pcap", ringPackets(hdl32(), 2170, 3));
  const CaptureScan a = scanCapture(dir / "64.pcap", {});
  const CaptureScan b = scanCapture(dir / "32.pcap", {});
  ASSERT_TRUE(a.error.empty()) << a.error;
  ASSERT_TRUE(b.error.empty()) << b.error;
  EXPECT_EQ(*a.model, Model::Hdl64E);
  EXPECT_EQ(*b.model, Model::Hdl32E);
  EXPECT_EQ(a.sweeps.size(), 3u);
  EXPECT_EQ(b.sweeps.size(), 3u);
  EXPECT_NEAR(a.rotation_hz, 10.0, 0.05);
  // the simulated capture starts at the top of an hour: its time base is that hour
  EXPECT_DOUBLE_EQ(a.time_base, pcap::kSimulationEpoch);
}

TEST(VelodyneCaptureTest, AKnownGprmcSentenceGivesItsFix) {
  // the sentence every NMEA reference quotes: 12:35:19 UTC on 23 March 1994, 48 07.038' N 11 31.000' E
  const std::string s = "$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A";
  std::string why;
  const auto fix = velodyne::parseNmea(s, &why);
  ASSERT_TRUE(fix) << why;
  EXPECT_TRUE(fix->valid);
  EXPECT_NEAR(fix->latitude_deg, 48.0 + 7.038 / 60.0, 1e-12);
  EXPECT_NEAR(fix->longitude_deg, 11.0 + 31.0 / 60.0, 1e-12);
  ASSERT_TRUE(fix->epoch);
  EXPECT_DOUBLE_EQ(*fix->epoch, 764426119.0);
  EXPECT_NEAR(fix->speed_mps, 22.4 * 1852.0 / 3600.0, 1e-9);
  // in a position packet stamped 35:19.2 into the hour (the fix lags the PPS by 0.2 s)
  const auto bytes = velodyne::positionPacket(35u * 60'000'000u + 19'200'000u, s);
  ASSERT_EQ(bytes.size(), 512u);
  const auto packet = velodyne::parsePositionPacket(bytes.data(), bytes.size());
  ASSERT_TRUE(packet);
  EXPECT_EQ(packet->nmea, s);
  EXPECT_DOUBLE_EQ(velodyne::timeBaseFromFix(packet->timestamp_us, *fix->epoch), 764424000.0);  // 12:00 UTC
  const GpsFix g = velodyne::gpsFix(*packet, *fix, 764424000.0);
  EXPECT_NEAR(g.time, 764426119.2, 1e-6);
  // southern and western hemispheres, GGA with altitude, and what is refused
  const auto gga = velodyne::parseNmea("$GPGGA,123519,4807.038,S,01131.000,W,1,08,0.9,545.4,M,46.9,M,,");
  ASSERT_TRUE(gga);
  EXPECT_NEAR(gga->latitude_deg, -(48.0 + 7.038 / 60.0), 1e-12);
  EXPECT_NEAR(gga->longitude_deg, -(11.0 + 31.0 / 60.0), 1e-12);
  EXPECT_NEAR(*gga->altitude_m, 545.4 + 46.9, 1e-9);
  EXPECT_NEAR(*gga->hdop, 0.9, 1e-12);
  EXPECT_FALSE(velodyne::parseNmea("$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6B", &why));
  EXPECT_NE(why.find("checksum"), std::string::npos) << why;
  const auto no_fix = velodyne::parseNmea("$GPRMC,123519,V,,,,,,,230394,,*" + std::string("00"), &why);
  EXPECT_FALSE(no_fix);  // the checksum of that sentence is not 00
  EXPECT_FALSE(velodyne::parseNmea("$GPXXX,1,2,3", &why));
  // a time of day with a sign (found by scripts/fuzz) is no hhmmss
  EXPECT_FALSE(velodyne::parseNmea("$GPGGA,-10760,38,,,,,,,-21520,,,", &why));
  EXPECT_NE(why.find("is not hhmmss"), std::string::npos) << why;
  EXPECT_FALSE(
      velodyne::parseNmea("$GPRMC,15555555555523519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W", &why));
  EXPECT_NE(why.find("is not hhmmss"), std::string::npos) << why;
  ASSERT_TRUE(velodyne::parseNmea("$GPRMC,123519.25,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W", &why)) << why;
  // our own sentences read back
  const auto ours = velodyne::parseNmea(velodyne::gprmcSentence(1767225600.0 + 75.5, -33.5, 151.25, 2.0), &why);
  ASSERT_TRUE(ours) << why;
  EXPECT_DOUBLE_EQ(*ours->epoch, 1767225600.0 + 75.5);
  EXPECT_NEAR(ours->latitude_deg, -33.5, 1e-6);
  EXPECT_NEAR(ours->longitude_deg, 151.25, 1e-6);
}

TEST(VelodyneCaptureTest, PositionPacketsGiveTheCaptureItsGpsAndTimeBase) {
  test::TempDir dir;
  // 2.5 s of HDL-32E packets on the simulated clock, and a GPS fix each second 20 s into the hour
  // of 2026-01-01 10:00 UTC (the capture clock says 00:00: the GPS wins)
  const double hour = pcap::kSimulationEpoch + 10 * 3600.0;
  std::vector<std::string> sentences;
  for (int k = 0; k < 3; ++k) sentences.push_back(velodyne::gprmcSentence(hour + k, 47.0 + 1e-5 * k, 8.5));
  writeCapture(dir / "gps.pcap", ringPackets(hdl32(), 2170, 25), sentences);
  const CaptureScan scan = scanCapture(dir / "gps.pcap", {});
  ASSERT_TRUE(scan.error.empty()) << scan.error;
  EXPECT_EQ(scan.position.packets, 3);
  EXPECT_EQ(scan.position.fixes, 3);
  EXPECT_EQ(scan.time_base_source, "gps");
  EXPECT_DOUBLE_EQ(scan.time_base, hour);
  ASSERT_EQ(scan.fixes.size(), 3u);
  EXPECT_NEAR(scan.fixes[1].time, hour + 1.0, 1e-6);
  EXPECT_NEAR(scan.fixes[1].latitude_deg, 47.00001, 1e-9);
  EXPECT_NEAR(scan.first_time, hour, 1e-3);
  // a given time base wins over both
  CaptureOptions given;
  given.time_base = 5.0;
  EXPECT_EQ(scanCapture(dir / "gps.pcap", given).time_base_source, "given");
  // the source delivers each fix with the sweep it falls in, the origin at the first
  CaptureSource source(dir / "gps.pcap", {}, 1.8);
  EXPECT_DOUBLE_EQ(source.calibration().origin.latitude_deg, 47.0);
  std::vector<double> fix_times;
  while (auto f = source.next()) {
    for (const GpsFix& g : f->sensors.gps) {
      EXPECT_LT(g.time, f->sensors.sweep.end_time);
      EXPECT_GE(g.time, f->sensors.sweep.start_time - 1e-6);
      fix_times.push_back(g.time - hour);
    }
  }
  ASSERT_EQ(fix_times.size(), 3u);
  EXPECT_NEAR(fix_times[2], 2.0, 1e-6);
}

// A $GPGGA sentence reads back as the fix it was written from (angles to 1e-7 minute, altitude to
// the millimetre, HDOP to 0.01), in both hemispheres, and minutes that round to 60 carry
TEST(VelodyneCaptureTest, AGpggaSentenceReadsBackAsItsFix) {
  const double epoch = 1767225600.0 + 3723.25;  // 2026-01-01 01:02:03.25 UTC
  for (const auto& [lat, lon] : {std::pair{37.5585098482, 126.9983172650}, {-33.8688, -151.2093}, {0.0, 0.0}}) {
    const std::string s = velodyne::gpggaSentence(epoch, lat, lon, 61.7297, 0.02);
    const auto fix = velodyne::parseNmea(s);
    ASSERT_TRUE(fix) << s;
    EXPECT_EQ(fix->type, "GPGGA");
    EXPECT_TRUE(fix->valid);
    EXPECT_NEAR(fix->time_of_day, 3723.25, 1e-6);
    EXPECT_NEAR(fix->latitude_deg, lat, 1e-7 / 60 + 1e-12) << s;
    EXPECT_NEAR(fix->longitude_deg, lon, 1e-7 / 60 + 1e-12) << s;
    ASSERT_TRUE(fix->altitude_m);
    EXPECT_NEAR(*fix->altitude_m, 61.730, 1e-9);
    ASSERT_TRUE(fix->hdop);
    EXPECT_NEAR(*fix->hdop, 0.02, 1e-12);
  }
  // 10.99999999999 degrees: 59.99999999 minutes round to 60 and carry into 11 degrees 0 minutes
  const std::string carried = velodyne::gpggaSentence(epoch, 10.99999999999, 0.5, 0, 1);
  EXPECT_NE(carried.find(",1100.0000000,N,"), std::string::npos) << carried;
}

// 'terrain record --pcap' writes the simulated GPS as position packets (port 8308): a $GPGGA for
// every fix and a $GPRMC once a second; the capture alone then carries the same fixes, one per fix
// (the RMC of an epoch adds none), on the capture clock
TEST(VelodyneCaptureTest, ARecordedCaptureCarriesTheSimulatedGps) {
  test::TempDir dir;
  const std::string rec = (dir / "rec").string(), conv = (dir / "conv").string();
  ASSERT_EQ(0, test::sh(test::kCli + " record --scene " + test::kUrbanScene +
                        " --frames 12 --cameras forward --pcap --out " + rec + " > /dev/null"));
  ASSERT_EQ(0, test::sh(test::kCli + " lidar convert --pcap " + rec + "/lidar.pcap --out " + conv + " > /dev/null"));
  const auto rows = [](const std::string& path) {
    std::vector<std::vector<double>> out;
    std::istringstream in(io::readFile(path));
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::vector<double> v;
      std::istringstream fields(line);
      for (std::string f; std::getline(fields, f, ',');) v.push_back(std::stod(f));
      out.push_back(v);
    }
    return out;
  };
  const auto simulated = rows(rec + "/gps.csv"), decoded = rows(conv + "/gps.csv");
  ASSERT_EQ(simulated.size(), 12u);  // 10 Hz, one a frame
  ASSERT_EQ(decoded.size(), simulated.size());
  for (std::size_t i = 0; i < simulated.size(); ++i) {
    EXPECT_NEAR(decoded[i][0] - pcap::kSimulationEpoch, simulated[i][0], 1e-6) << i;  // time on the capture clock
    EXPECT_NEAR(decoded[i][1], simulated[i][1], 1e-8) << i;
    EXPECT_NEAR(decoded[i][2], simulated[i][2], 1e-8) << i;
    EXPECT_NEAR(decoded[i][3], simulated[i][3], 6e-4) << i;
    EXPECT_NEAR(decoded[i][4], simulated[i][4], 1e-12) << i;
  }
  const auto capture = nlohmann::json::parse(io::readFile(conv + "/capture.json"));
  EXPECT_EQ(capture["position_packets"]["packets"], 14);  // 12 GGA, RMC at 0 s and 1 s
  EXPECT_EQ(capture["position_packets"]["fixes"], 12);
  EXPECT_EQ(capture["time_base_source"], "gps");
}

TEST(VelodyneCaptureTest, DualReturnPacketsDecodeBothReturnsOnce) {
  const LaserCalibration lasers = hdl32();
  auto packets = ringPackets(lasers, 2170, 1);
  // make the first packet a dual one: its 12 blocks become 6 pairs at the positions of the first
  // 6 firings; the second block of a pair keeps laser 0's return (the same: decoded once) and moves
  // laser 2's 1 m farther (a second return)
  velodyne::Payload& d = packets[0].payload;
  for (int pair = 5; pair >= 0; --pair) {
    std::memcpy(&d[200 * pair], &d[100 * pair], 100);
    std::memcpy(&d[200 * pair + 100], &d[100 * pair], 100);
    std::uint8_t* second = &d[200 * pair + 100];
    const std::uint16_t raw = static_cast<std::uint16_t>(second[4 + 6] | (second[4 + 7] << 8));
    const std::uint16_t farther = static_cast<std::uint16_t>(raw + 500);  // 2 mm units
    second[4 + 6] = farther & 0xFF;
    second[4 + 7] = farther >> 8;
  }
  d[1204] = 0x39;
  EXPECT_EQ(velodyne::packetReturnMode(d.data(), Model::Hdl32E), velodyne::ReturnMode::Dual);
  velodyne::SweepAssembler a(lasers);
  std::vector<LidarSweep> out;
  ASSERT_TRUE(a.push(d.data(), d.size(), out));
  EXPECT_EQ(a.stats().dual_packets, 1);
  // laser 2 twice per firing, every other even laser once: 6 firings x (16 + 1) returns
  EXPECT_EQ(a.stats().second_returns, 6);
  EXPECT_EQ(a.stats().points, 6 * 17);
  // a pair whose blocks disagree on the position is refused
  d[200 + 100 + 2] ^= 0x01;
  EXPECT_FALSE(a.push(d.data(), d.size(), out));
  EXPECT_EQ(a.stats().bad_position, 1);
}

TEST(VelodyneCaptureTest, CapturesThatCannotBeDecodedAreRefusedWithTheReason) {
  test::TempDir dir;
  // only position packets
  writePositionOnly(dir / "pos.pcap");
  try {
    setupCapture(dir / "pos.pcap", {});
    ADD_FAILURE() << "a capture of position packets only was accepted";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no lidar data packet"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("1 position packets only"), std::string::npos) << e.what();
  }
  // an HDL-64E calibration for HDL-32E packets
  CaptureOptions wrong;
  wrong.calibration = shippedCalibration(Model::Hdl64E);
  try {
    setupCapture(kSample, wrong);
    ADD_FAILURE() << "a 64-laser table for HDL-32E packets was accepted";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("64 lasers, but"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("HDL-32E"), std::string::npos) << e.what();
  }
  // the same mismatch met by a decoder already running (a live stream) stops it with the reason
  VelodyneLidar lidar(LidarEndpoint::parse("pcap:" + kSample.string()), hdl64());
  try {
    lidar.next();
    ADD_FAILURE() << "HDL-32E packets decoded with a 64-laser table";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the packets are an HDL-32E's"), std::string::npos) << e.what();
  }
  // packets of no model this decoder reads (a VLP-16's model byte)
  auto packets = ringPackets(hdl32(), 2170, 1);
  for (auto& p : packets) p.payload[1205] = 0x22;
  writeCapture(dir / "vlp16.pcap", packets);
  const CaptureScan vlp = scanCapture(dir / "vlp16.pcap", {});
  EXPECT_NE(vlp.error.find("VLP-16"), std::string::npos) << vlp.error;
  // a capture cut off in mid-packet: decoded up to there, and said so
  writeCapture(dir / "full.pcap", ringPackets(hdl32(), 2170, 3));
  const std::string bytes = io::readFile(dir / "full.pcap");
  { std::ofstream(dir / "cut.pcap", std::ios::binary) << bytes.substr(0, bytes.size() - 700); }
  const CaptureScan cut = scanCapture(dir / "cut.pcap", {});
  EXPECT_TRUE(cut.error.empty()) << cut.error;
  EXPECT_FALSE(cut.read.error.empty());
  ASSERT_FALSE(cut.warnings.empty());
  EXPECT_NE(cut.warnings.front().find("cut off"), std::string::npos) << cut.warnings.front();
}

TEST(VelodyneCaptureTest, ALiveStreamWithoutAPacketIsAnErrorAfterTheFirstPacketTimeout) {
  VelodyneOptions options;
  options.first_timeout = 0.3;
  VelodyneLidar lidar(LidarEndpoint::parse("udp:127.0.0.1:0"), hdl64(), options);
  try {
    lidar.next();
    ADD_FAILURE() << "a silent stream ended without an error";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no packet arrived within 0.3 s"), std::string::npos) << e.what();
  }
}

// a UDP port free a moment ago (binding port 0 finds one)
std::uint16_t freePort() { return UdpReceiver("127.0.0.1", 0).port(); }

// A live HDL-32E alone: its model found from its first packet, the shipped table taken, the time
// base from the host clock, and its position packets (another port) give the fixes and the origin.
TEST(VelodyneCaptureTest, ALiveSensorAloneFindsItsModelAndTakesItsGpsFromItsPositionPackets) {
  const std::uint16_t data_port = freePort(), position_port = freePort();
  ASSERT_NE(data_port, position_port);
  const double hour = pcap::kSimulationEpoch + 10 * 3600.0;
  const auto packets = ringPackets(hdl32(), 2170, 25);  // 2.5 s
  std::thread sensor([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    UdpSender data("127.0.0.1", data_port), position("127.0.0.1", position_port);
    int next_fix = 0;
    for (std::size_t i = 0; i < packets.size(); ++i) {
      if (next_fix < 3 && packets[i].time >= next_fix) {
        const auto p = velodyne::positionPacket(static_cast<std::uint32_t>(next_fix * 1000000),
                                                velodyne::gprmcSentence(hour + next_fix, 47.0 + 1e-5 * next_fix, 8.5));
        position.send(p.data(), p.size());
        ++next_fix;
      }
      data.send(packets[i].payload.data(), packets[i].payload.size());
      if (i % 16 == 15) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // within the socket's buffer
    }
  });
  CaptureOptions options;
  options.position_port = position_port;
  options.lidar.first_timeout = 10;
  options.lidar.idle_timeout = 0.5;
  LidarEndpoint live = LidarEndpoint::parse("udp:127.0.0.1:" + std::to_string(data_port));
  std::optional<CaptureSource> source;
  try {
    source.emplace(live, options, 1.8);
  } catch (...) {
    sensor.join();
    throw;
  }
  const CaptureSetup& setup = source->setup();
  EXPECT_EQ(setup.model, Model::Hdl32E);
  EXPECT_EQ(setup.lasers.laserCount(), 32);
  EXPECT_EQ(setup.time_base_source, "host clock");
  const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  EXPECT_LT(std::abs(setup.time_base - now), 3600.0 + 10.0);
  EXPECT_DOUBLE_EQ(std::fmod(setup.time_base, 3600.0), 0.0);
  ASSERT_TRUE(setup.first_fix.has_value());
  EXPECT_DOUBLE_EQ(source->calibration().origin.latitude_deg, 47.0);
  EXPECT_DOUBLE_EQ(source->calibration().origin.longitude_deg, 8.5);
  int sweeps = 0;
  std::vector<double> fix_times;
  while (auto f = source->next()) {
    ++sweeps;
    for (const GpsFix& g : f->sensors.gps) {
      EXPECT_LT(g.time, f->sensors.sweep.end_time);
      fix_times.push_back(g.time - setup.time_base);
    }
  }
  sensor.join();
  EXPECT_GE(sweeps, 24);
  EXPECT_EQ(source->lidar().positionStats().fixes, 3);
  ASSERT_EQ(fix_times.size(), 3u);
  EXPECT_NEAR(fix_times[0], 0.0, 1e-6);  // on the data packets' clock, whatever the NMEA time
  EXPECT_NEAR(fix_times[2], 2.0, 1e-6);
  // a live source whose position port another program holds is refused, naming it
  source.reset();
  try {
    UdpReceiver busy("127.0.0.1", position_port);
    CaptureSource again(LidarEndpoint::parse("udp:127.0.0.1:0"), options, 1.8);
    ADD_FAILURE() << "bound a position port already in use";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--lidar-position-port 0 reads none"), std::string::npos) << e.what();
  }
}

// The command line: each failure exits 2 with its message and leaves an existing --out as it was.
TEST(VelodyneCaptureTest, LidarCommandsFailLoudlyAndLeaveOutputsAlone) {
  test::TempDir dir;
  const std::string cli = test::kCli;
  ASSERT_EQ(0, test::sh(cli + " lidar inspect " + kSample.string() + " --json " + (dir / "scan.json").string() +
                        " > /dev/null"));
  const std::string json = io::readFile(dir / "scan.json");
  EXPECT_NE(json.find("\"model\": \"HDL-32E\""), std::string::npos);
  // convert: the sweeps, and nothing of a failed attempt over it
  const fs::path out = dir / "out";
  ASSERT_EQ(0, test::sh(cli + " lidar convert --pcap " + kSample.string() + " --out " + out.string() +
                        " --kitti > /dev/null 2>&1"));
  EXPECT_TRUE(fs::exists(out / "sweeps" / "000003.pcd"));
  EXPECT_TRUE(fs::exists(out / "kitti" / "000003.bin"));
  EXPECT_EQ(fs::file_size(out / "kitti" / "000001.bin") % 16, 0u);
  const std::string csv = io::readFile(out / "sweeps.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5);
  const std::string before = io::readFile(out / "sweeps.csv");
  writePositionOnly(dir / "pos.pcap");
  const std::string cut = (dir / "cut.pcap").string();
  {
    const std::string bytes = io::readFile(kSample);
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 500);
  }
  const std::string err = (dir / "err.txt").string();
  const auto fails = [&](const std::string& args, const std::string& message) {
    const int rc = test::sh(cli + " " + args + " > /dev/null 2> " + err);
    EXPECT_EQ(WEXITSTATUS(rc), 2) << args;
    const std::string text = io::readFile(err);
    EXPECT_NE(text.find(message), std::string::npos) << args << ": " << text;
  };
  fails("lidar convert --pcap " + (dir / "pos.pcap").string() + " --out " + out.string() + " --force",
        "no lidar data packet");
  fails("lidar convert --pcap " + kSample.string() + " --out " + out.string() + " --force --calibration " +
            shippedCalibration(Model::Hdl64E).string(),
        "64 lasers, but");
  fails("lidar convert --pcap " + cut + " --out " + out.string() + " --force --strict", "cut off");
  fails("lidar convert --pcap " + kSample.string() + " --out " + out.string(), "exists and is not empty");
  fails("lidar inspect " + cut + " --strict", "cut off");
  // a capture that is not there: the error alone, no summary of an empty capture
  fails("lidar inspect " + (dir / "missing.pcap").string(), "no such capture file");
  test::sh(cli + " lidar inspect " + (dir / "missing.pcap").string() + " > " + (dir / "stdout.txt").string() +
           " 2> /dev/null");
  EXPECT_EQ(io::readFile(dir / "stdout.txt"), "");
  fails("reconstruct --lidar pcap:" + (dir / "pos.pcap").string() + " --out " + out.string() + " --force",
        "no lidar data packet");
  fails("reconstruct --lidar pcap:" + cut + " --strict --out " + out.string() + " --force", "cut off");
  fails("reconstruct --lidar udp:127.0.0.1:0 --lidar-first-packet-timeout 0.3 --lidar-position-port 0 --out " +
            out.string() + " --force",
        "no lidar data packet of a known model arrived within 0.3 s");
  fails("reconstruct --lidar udp:127.0.0.1:0 --sensors " + dir.path().string() + " --out " + out.string() + " --force",
        "a sensor folder goes with a capture");
  EXPECT_EQ(io::readFile(out / "sweeps.csv"), before);
  for (const auto& e : fs::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos) << e.path();
  }
  // a cut-off capture without --strict converts, with the warning in capture.json
  ASSERT_EQ(0,
            test::sh(cli + " lidar convert --pcap " + cut + " --out " + (dir / "cut").string() + " > /dev/null 2>&1"));
  EXPECT_NE(io::readFile(dir / "cut" / "capture.json").find("cut off"), std::string::npos);
  // and reconstructs alone, unscored, the warning in warnings.json and report.json
  ASSERT_EQ(
      0, test::sh(cli + " reconstruct --lidar pcap:" + cut + " --out " + (dir / "rec").string() + " > /dev/null 2>&1"));
  const std::string report = io::readFile(dir / "rec" / "report.json");
  EXPECT_NE(report.find("\"scored\": false"), std::string::npos);
  EXPECT_NE(report.find("cut off"), std::string::npos);
  EXPECT_NE(io::readFile(dir / "rec" / "warnings.json").find("cut off"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "rec" / "mesh.ply"));
}

}  // namespace
}  // namespace terrain::rig
