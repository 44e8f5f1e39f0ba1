// The real-driver path end to end through the command line: a run recorded from the simulator
// as a dataset and an HDL-64E capture, reconstructed from the dataset's own sweeps, from the
// capture (pcap:FILE) and from the capture streamed over loopback UDP (udp:HOST:PORT).

#include "rig/file_io.hpp"
#include "rig/velodyne_source.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <thread>

namespace terrain {
namespace {

namespace fs = std::filesystem;

using test::kCli;
using test::sh;
const std::string& kScene = test::kUrbanScene;

nlohmann::json report(const fs::path& dir) { return nlohmann::json::parse(io::readFile(dir / "report.json")); }

// the scores of a reconstruction from decoded packets stay close to those from the dataset
void expectSameScores(const nlohmann::json& a, const nlohmann::json& b) {
  EXPECT_EQ(a["frames"], b["frames"]);
  const double va = a["voxels"].get<double>(), vb = b["voxels"].get<double>();
  EXPECT_NEAR(va, vb, 0.002 * va);
  for (const char* m : {"gmrf_icm", "gmrf_mincut", "histogram"}) {
    EXPECT_NEAR(a["ground_segmentation"][m]["f1"].get<double>(), b["ground_segmentation"][m]["f1"].get<double>(), 0.005)
        << m;
  }
  EXPECT_NEAR(a["height_recovery"]["after"]["mae_m"].get<double>(),
              b["height_recovery"]["after"]["mae_m"].get<double>(), 0.2);
  EXPECT_NEAR(a["boundary_coverage"].get<double>(), b["boundary_coverage"].get<double>(), 0.01);
}

class HilTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    ASSERT_EQ(0,
              sh(kCli + " record --scene " + kScene + " --frames 12 --pcap --out " + ds().string() + " > /dev/null"));
    ASSERT_TRUE(fs::exists(ds() / "lidar.pcap"));
    ASSERT_EQ(0, sh(kCli + " reconstruct --input " + ds().string() + " --out " + (*dir_ / "from_dataset").string() +
                    " > /dev/null"));
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path ds() { return *dir_ / "ds"; }
  static test::TempDir* dir_;
};
test::TempDir* HilTest::dir_ = nullptr;

TEST_F(HilTest, CaptureReplayScoresLikeTheDataset) {
  const fs::path out = *dir_ / "from_pcap";
  ASSERT_EQ(0, sh(kCli + " reconstruct --input " + ds().string() + " --lidar pcap:" + (ds() / "lidar.pcap").string() +
                  " --calibration " + (ds() / "lasers.yaml").string() + " --out " + out.string() + " > " +
                  (*dir_ / "pcap.log").string()));
  expectSameScores(report(*dir_ / "from_dataset"), report(out));
  const std::string log = io::readFile(*dir_ / "pcap.log");
  EXPECT_NE(log.find("(HDL-64E): 4166 packets, 4166 decoded"), std::string::npos) << log;
}

TEST_F(HilTest, LoopbackUdpStreamScoresLikeTheDataset) {
  // a free port, then the driver listening on it while 'terrain stream' sends the capture
  std::uint16_t port;
  {
    rig::UdpReceiver probe("127.0.0.1", 0);
    port = probe.port();
  }
  const fs::path out = *dir_ / "from_udp", log = *dir_ / "udp.log";
  std::thread receiver([&] {
    sh(kCli + " reconstruct --input " + ds().string() + " --lidar udp:127.0.0.1:" + std::to_string(port) +
       " --lidar-idle-timeout 1 --out " + out.string() + " > " + log.string() + " 2>&1");
  });
  for (int i = 0; i < 600; ++i) {
    if (fs::exists(log) && io::readFile(log).find("listening") != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(0, sh(kCli + " stream --pcap " + (ds() / "lidar.pcap").string() +
                  " --to 127.0.0.1:" + std::to_string(port) + " > /dev/null 2>&1"));
  receiver.join();
  ASSERT_TRUE(fs::exists(out / "report.json")) << io::readFile(log);
  expectSameScores(report(*dir_ / "from_dataset"), report(out));
  const std::string text = io::readFile(log);
  EXPECT_NE(text.find("4166 packets, 4166 decoded"), std::string::npos) << text;
}

// A live sensor alone: 'terrain stream' sends the capture's data and position packets, and
// 'terrain reconstruct --lidar udp:…' without a dataset takes its GPS from the position packets:
// the same mesh as the capture reconstructed alone (the lidar and GPS the same, on another time base).
TEST_F(HilTest, ALiveSensorAloneReconstructsLikeItsCapture) {
  std::uint16_t port, position_port;
  {
    rig::UdpReceiver a("127.0.0.1", 0), b("127.0.0.1", 0);
    port = a.port();
    position_port = b.port();
  }
  const fs::path out = *dir_ / "live_alone", log = *dir_ / "live_alone.log", ref = *dir_ / "capture_alone";
  std::thread receiver([&] {
    sh(kCli + " reconstruct --lidar udp:127.0.0.1:" + std::to_string(port) + " --lidar-position-port " +
       std::to_string(position_port) + " --lidar-idle-timeout 1 --out " + out.string() + " > " + log.string() +
       " 2>&1");
  });
  for (int i = 0; i < 600; ++i) {
    if (fs::exists(log) && io::readFile(log).find("listening") != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(0, sh(kCli + " stream --pcap " + (ds() / "lidar.pcap").string() + " --to 127.0.0.1:" +
                  std::to_string(port) + " --position-port " + std::to_string(position_port) + " > /dev/null 2>&1"));
  receiver.join();
  ASSERT_EQ(0, sh(kCli + " reconstruct --lidar pcap:" + (ds() / "lidar.pcap").string() + " --out " + ref.string() +
                  " > /dev/null 2>&1"));
  ASSERT_TRUE(fs::exists(out / "report.json")) << io::readFile(log);
  const std::string text = io::readFile(log);
  EXPECT_NE(text.find("time base"), std::string::npos) << text;
  EXPECT_NE(text.find("from the host clock"), std::string::npos) << text;
  EXPECT_NE(text.find("GPS fixes"), std::string::npos) << text;
  EXPECT_EQ(text.find("no GPS fix came"), std::string::npos) << text;
  EXPECT_EQ(report(out)["scored"], false);
  EXPECT_EQ(io::readFile(out / "mesh.ply"), io::readFile(ref / "mesh.ply"));
}

TEST_F(HilTest, SimulatedRigWithAStreamedLidarScoresLikeTheInProcessRun) {
  // 'terrain run --lidar udp:…': camera, GPS and gyro simulated, the lidar streamed by
  // 'terrain stream --scene' from the same scene
  std::uint16_t port;
  {
    rig::UdpReceiver probe("127.0.0.1", 0);
    port = probe.port();
  }
  const fs::path out = *dir_ / "run_udp", ref = *dir_ / "run_ref", log = *dir_ / "run_udp.log";
  std::thread receiver([&] {
    sh(kCli + " run --scenario urban --seed 1 --frames 8 --lidar udp:127.0.0.1:" + std::to_string(port) +
       " --lidar-idle-timeout 1 --out " + out.string() + " > " + log.string() + " 2>&1");
  });
  // the same scene as the run generates (same type and seed: byte-identical), for the sender
  const fs::path scene = *dir_ / "sender_scene" / "urban_1.xml";
  ASSERT_EQ(0, sh(kCli + " scenes generate --type urban --seed 1 --out " + scene.string() + " > /dev/null"));
  for (int i = 0; i < 600; ++i) {
    if (fs::exists(log) && io::readFile(log).find("listening") != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(0, sh(kCli + " stream --scene " + scene.string() + " --frames 8 --to 127.0.0.1:" + std::to_string(port) +
                  " > /dev/null 2>&1"));
  receiver.join();
  ASSERT_EQ(0, sh(kCli + " run --scenario urban --seed 1 --frames 8 --out " + ref.string() + " > /dev/null 2>&1"));
  ASSERT_TRUE(fs::exists(out / "report.json")) << io::readFile(log);
  expectSameScores(report(ref), report(out));
}

TEST_F(HilTest, BadLidarArgumentsGetAClearError) {
  const std::string base = kCli + " reconstruct --input " + ds().string() + " --out " + (*dir_ / "bad").string();
  const fs::path log = *dir_ / "bad.log";
  EXPECT_NE(0, sh(base + " --lidar tcp:1.2.3.4 2> " + log.string()));
  EXPECT_NE(io::readFile(log).find("expected pcap:FILE or udp:HOST:PORT"), std::string::npos);
  EXPECT_NE(0, sh(base + " --lidar pcap:" + (ds() / "lasers.yaml").string() + " 2> " + log.string()));
  EXPECT_NE(io::readFile(log).find("not a pcap capture"), std::string::npos) << io::readFile(log);
  EXPECT_NE(0, sh(base + " --lidar pcap:" + (ds() / "lidar.pcap").string() + " --calibration " + kScene + " 2> " +
                  log.string()));
  EXPECT_NE(io::readFile(log).find("terrain: error:"), std::string::npos) << io::readFile(log);
  EXPECT_FALSE(fs::exists(*dir_ / "bad" / "report.json"));
}

}  // namespace
}  // namespace terrain
