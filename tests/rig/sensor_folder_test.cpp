#include "rig/sensor_folder.hpp"

#include "rig/dataset.hpp"
#include "rig/file_io.hpp"
#include "rig/velodyne_capture.hpp"
#include "tests/cli_support.hpp"
#include "tests/temp_dir.hpp"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <fstream>
#include <map>
#include <memory>

namespace terrain::rig {
namespace {

namespace fs = std::filesystem;

const fs::path kSample = fs::path(TERRAIN_SOURCE_DIR) / "tests" / "data" / "velodyne" / "hdl32e_sample.pcap";
// the sample's firings span 1319768035.3747 to .6511 s in its own clock
constexpr double kT0 = 1319768035.0;

// A sensor folder: camera "left" (64 x 48 px) with images at kT0 + 0.40, 0.50, 0.60 s, each a
// plain colour (red 10, 20, 30), and a gyro at 100 Hz from kT0 + 0.30 to 0.70 s turning at 0.1 rad/s.
void writeFolder(const fs::path& dir) {
  RigCalibration c;
  CameraCalibration cam;
  cam.name = "left";
  cam.intrinsics = CameraIntrinsics::fromFovy(64, 48, 1.2);
  cam.vehicle_from_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  cam.vehicle_from_camera.translation() = Vector3(0, 0.3, 1.5);
  c.cameras = {cam};
  c.vehicle_from_lidar.translation() = Vector3(0.1, 0, 1.9);
  c.vehicle_from_gps.translation() = Vector3(-0.2, 0, 2.0);
  c.gyro_period = 0.01;
  fs::create_directories(dir / "camera" / "left");
  io::writeFileAtomic(dir / "calibration.json", calibrationToJson(c), true);
  std::ofstream list(dir / "camera" / "left" / "images.csv");
  list << "time_s,file\n" << std::setprecision(17);
  for (int k = 0; k < 3; ++k) {
    const std::string name = "img" + std::to_string(k) + ".png";
    cv::imwrite((dir / "camera" / "left" / name).string(), cv::Mat(48, 64, CV_8UC3, cv::Scalar(0, 0, 10 * (k + 1))));
    list << kT0 + 0.4 + 0.1 * k << "," << name << "\n";
  }
  std::ofstream gyro(dir / "gyro.csv");
  gyro << "time_s,wx_rad_s,wy_rad_s,wz_rad_s\n" << std::setprecision(17);
  for (int k = 0; k <= 40; ++k) gyro << kT0 + 0.3 + 0.01 * k << ",0,0,0.1\n";
}

// A capture with a sensor folder hands the pipeline the folder's calibration, and each image and
// gyro sample once, in the sweep whose window (previous end, end] holds its time.
TEST(SensorFolderTest, ACaptureCarriesTheFoldersImagesAndGyroSweepBySweep) {
  test::TempDir dir;
  writeFolder(dir.path());
  auto folder = std::make_shared<const SensorFolder>(dir.path());
  EXPECT_EQ(folder->images(), 3u);
  EXPECT_EQ(folder->gyroSamples(), 41u);
  CaptureSource source(kSample, CaptureOptions{}, 1.8, folder);
  ASSERT_EQ(source.calibration().cameras.size(), 1u);
  EXPECT_EQ(source.calibration().cameras[0].name, "left");
  EXPECT_NEAR(source.calibration().vehicle_from_lidar.translation().z(), 1.9, 1e-12);  // not the mast height
  std::vector<double> image_times, gyro_times;
  std::vector<int> reds;
  double last_end = -1e300;
  int sweeps = 0;
  while (auto frame = source.next()) {
    ++sweeps;
    const SensorFrame& s = frame->sensors;
    EXPECT_LE(s.images.size(), 1u);
    for (const CameraImage& image : s.images) {
      EXPECT_GT(image.time, last_end);
      EXPECT_LE(image.time, s.sweep.end_time);
      EXPECT_EQ(image.camera, 0);
      ASSERT_EQ(image.rgb.cols, 64);
      reds.push_back(image.rgb.at<cv::Vec3b>(10, 10)[0]);  // RGB order
      image_times.push_back(image.time);
    }
    for (const GyroSample& g : s.gyro) {
      EXPECT_GT(g.time, last_end);
      EXPECT_LE(g.time, s.sweep.end_time);
      EXPECT_DOUBLE_EQ(g.rate.z(), 0.1);
      gyro_times.push_back(g.time);
    }
    last_end = s.sweep.end_time;
  }
  EXPECT_EQ(sweeps, 4);
  // the sweeps (about 0.11 s each) end after 0.65 s: every image, each once, in order
  EXPECT_EQ(reds, (std::vector<int>{10, 20, 30}));
  EXPECT_TRUE(std::is_sorted(image_times.begin(), image_times.end()));
  // the gyro samples up to the last sweep's end, each once
  std::size_t expected = 0;
  for (int k = 0; k <= 40; ++k) expected += kT0 + 0.3 + 0.01 * k <= last_end;
  EXPECT_EQ(gyro_times.size(), expected);
  EXPECT_GT(expected, 30u);
  EXPECT_TRUE(std::adjacent_find(gyro_times.begin(), gyro_times.end(), std::greater_equal<double>()) ==
              gyro_times.end());
}

// Each broken folder is refused with a message that names the file (and line) at fault.
TEST(SensorFolderTest, ABrokenFolderIsRefusedNamingWhatIsWrong) {
  const auto refused = [](const fs::path& dir, const std::string& message) {
    try {
      SensorFolder folder(dir);
      CaptureSource source(kSample, CaptureOptions{}, 1.8, std::make_shared<const SensorFolder>(dir));
      while (source.next()) {
      }
      ADD_FAILURE() << "accepted; expected: " << message;
    } catch (const io::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  const auto fresh = [](const fs::path& dir) {
    fs::remove_all(dir);
    writeFolder(dir);
  };
  test::TempDir tmp;
  const fs::path dir = tmp / "sensors";
  refused(dir, "not a directory");
  fresh(dir);
  fs::remove(dir / "calibration.json");
  refused(dir, "no calibration.json");
  fresh(dir);
  fs::remove(dir / "camera" / "left" / "images.csv");
  refused(dir, "left/images.csv: missing: calibration.json lists camera 'left'");
  fresh(dir);
  fs::remove(dir / "camera" / "left" / "img1.png");
  refused(dir, "images.csv:3: ");
  fresh(dir);
  std::ofstream(dir / "camera" / "left" / "images.csv", std::ios::app) << "1319768035.1,img0.png\n";
  refused(dir, "images.csv:5: time does not increase");
  fresh(dir);
  std::ofstream(dir / "camera" / "left" / "images.csv", std::ios::app) << "soon,img0.png\n";
  refused(dir, "images.csv:5: 'soon' is not a number");
  fresh(dir);
  cv::imwrite((dir / "camera" / "left" / "img1.png").string(), cv::Mat(40, 64, CV_8UC3, cv::Scalar(1, 2, 3)));
  refused(dir, "img1.png: 64 x 40 px, but calibration.json gives camera 'left' 64 x 48");
  fresh(dir);
  std::ofstream(dir / "camera" / "left" / "img2.png", std::ios::trunc) << "not a png";
  refused(dir, "img2.png: not a readable image");
  fresh(dir);
  std::ofstream(dir / "gyro.csv", std::ios::app) << "1319768036,0,nan,0\n";
  refused(dir, "gyro.csv:43: a value is not finite");
}

// 'terrain reconstruct' takes the folder beside a capture, says what it found, and refuses it
// where it does not apply.
TEST(SensorFolderTest, ReconstructTakesTheFolderBesideACaptureOnly) {
  test::TempDir dir;
  writeFolder(dir / "sensors");
  const std::string out = (dir / "out").string(), log = (dir / "log.txt").string();
  ASSERT_EQ(0, test::sh(test::kCli + " reconstruct --lidar pcap:" + kSample.string() + " --sensors " +
                        (dir / "sensors").string() + " --out " + out + " > " + log + " 2>&1"))
      << io::readFile(log);
  const std::string said = io::readFile(log);
  EXPECT_NE(said.find("1 camera (left, 3 images) and 41 gyro samples from"), std::string::npos) << said;
  const std::string report = io::readFile(dir / "out" / "report.json");
  EXPECT_NE(report.find("\"scored\": false"), std::string::npos);
  EXPECT_NE(report.find("1 camera (left, 3 images)"), std::string::npos);
  EXPECT_EQ(report.find("no gyro, so the heading"), std::string::npos);
  const auto fails = [&](const std::string& args, const std::string& message) {
    const int rc = test::sh(test::kCli + " reconstruct " + args + " > /dev/null 2> " + log);
    EXPECT_EQ(WEXITSTATUS(rc), 2) << args;
    EXPECT_NE(io::readFile(log).find(message), std::string::npos) << io::readFile(log);
  };
  fails("--lidar pcap:" + kSample.string() + " --sensors " + (dir / "sensors").string() + " --mast-height 2 --out " +
            (dir / "o2").string(),
        "excludes");
  fails(
      "--lidar pcap:" + kSample.string() + " --sensors " + (dir / "none").string() + " --out " + (dir / "o3").string(),
      "not a directory");
  EXPECT_FALSE(fs::exists(dir / "o3"));
}

}  // namespace
}  // namespace terrain::rig
