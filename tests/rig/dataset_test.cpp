#include "rig/dataset.hpp"

#include "rig/file_io.hpp"
#include "tests/temp_dir.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cmath>

namespace terrain::rig {
namespace {

namespace fs = std::filesystem;

TEST(DatasetTest, NeverWritesIntoANonEmptyDirectoryWithoutForce) {
  test::TempDir dir;
  const fs::path out = dir / "ds";
  fs::create_directories(out);
  io::writeFileAtomic(out / "precious.txt", "keep me", false);
  LaserCalibration lasers;
  EXPECT_THROW(DatasetWriter(out, RigCalibration{}, lasers, "{}", false), io::InputError);
  EXPECT_EQ(io::readFile(out / "precious.txt"), "keep me");
  EXPECT_FALSE(fs::exists(out / "calibration.json"));
}

// An output directory is built beside its target and replaces it whole, or not at all.
TEST(StagedDirectoryTest, ReplacesTheTargetWholeOnlyOnCommit) {
  test::TempDir dir;
  const fs::path out = dir / "out";
  fs::create_directories(out);
  io::writeFileAtomic(out / "old.txt", "old", false);
  EXPECT_THROW(io::StagedDirectory(out, false), io::InputError);  // not empty, no force
  {
    io::StagedDirectory staged(out, true);
    EXPECT_EQ(staged.path().parent_path(), fs::absolute(dir.path()).lexically_normal());
    io::writeFileAtomic(staged.path() / "new.txt", "new", false);
    EXPECT_EQ(io::readFile(out / "old.txt"), "old");  // untouched until commit
  }  // dropped without commit: the partial directory goes, the target stays
  EXPECT_EQ(io::readFile(out / "old.txt"), "old");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator{}), 1);
  {
    io::StagedDirectory staged(out.string() + "/", true);  // "out/" names out itself
    io::writeFileAtomic(staged.path() / "new.txt", "new", false);
    staged.commit();
  }
  EXPECT_EQ(io::readFile(out / "new.txt"), "new");
  EXPECT_FALSE(fs::exists(out / "old.txt"));  // no old file survives
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator{}), 1);
  io::writeFileAtomic(dir / "file", "x", false);
  EXPECT_THROW(io::StagedDirectory(dir / "file", true), io::InputError);  // a file is not replaced
}

TEST(DatasetTest, AnUnfinishedRecordingDoesNotLoad) {
  test::TempDir dir;
  {
    DatasetWriter w(dir / "ds", RigCalibration{}, LaserCalibration{}, "{}", false);
    // no finish(): no manifest
  }
  try {
    DatasetSource s(dir / "ds");
    FAIL() << "loaded a dataset without a manifest";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no manifest.json"), std::string::npos) << e.what();
  }
}

TEST(DatasetTest, MalformedCsvIsNamedWithItsLine) {
  test::TempDir dir;
  RigCalibration cal;
  cal.cameras.push_back({"front", CameraIntrinsics::fromFovy(64, 48, 1.0), Pose::Identity()});
  {
    DatasetWriter w(dir / "ds", cal, LaserCalibration{}, "{}", false);
    w.finish();
  }
  // an empty laser table is refused on load
  EXPECT_THROW(DatasetSource(dir / "ds"), io::InputError);
  io::writeFileAtomic(
      dir / "ds" / "lasers.yaml",
      "lasers:\n" +
          [] {
            std::string s;
            for (int i = 0; i < 16; ++i)
              s += "- {laser_id: " + std::to_string(i) + ", rot_correction: 0, vert_correction: 0}\n";
            return s;
          }(),
      true);
  EXPECT_NO_THROW(DatasetSource(dir / "ds"));
  io::writeFileAtomic(dir / "ds" / "gps.csv", "time_s,lat,lon,alt,sigma\n1,2,3,4,5\n1,2,x,4,5\n", true);
  try {
    DatasetSource s(dir / "ds");
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("gps.csv:3"), std::string::npos) << e.what();
  }
  // rows that parse but cannot be: each named with its file and line
  const auto refused = [&](const char* file, const std::string& rows, const std::string& message) {
    const std::string name = file;
    const std::string header = name == "gps.csv"        ? "time_s,lat,lon,alt,sigma\n"
                               : name == "poses_gt.csv" ? "time_s,x,y,z,qw,qx,qy,qz\n"
                                                        : "time_s,wx,wy,wz\n";
    io::writeFileAtomic(dir / "ds" / file, header + rows, true);
    try {
      DatasetSource s(dir / "ds");
      ADD_FAILURE() << file << " " << rows << " was accepted";
    } catch (const io::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
    io::writeFileAtomic(dir / "ds" / file, header, true);
  };
  refused("gps.csv", "1,47,8,400,2\n2,nan,8,400,2\n", "gps.csv:3: a value is not finite");
  refused("gps.csv", "1,47,8,400,2\n1,47,8,400,2\n", "gps.csv:3: time does not increase");
  refused("gps.csv", "1,97,8,400,2\n", "gps.csv:2: latitude/longitude outside");
  refused("gps.csv", "1,47,8,400,-2\n", "sigma_m is negative");
  refused("gyro.csv", "0.1,0,0,inf\n", "gyro.csv:2: a value is not finite");
  // a dataset with ground truth: a true pose whose quaternion is not a rotation
  auto manifest = nlohmann::json::parse(io::readFile(dir / "ds" / "manifest.json"));
  manifest["ground_truth"] = true;
  io::writeFileAtomic(dir / "ds" / "manifest.json", manifest.dump(1), true);
  refused("poses_gt.csv", "0,0,0,0,1,0,0,0\n0.1,0,0,0,0.5,0,0,0\n",
          "poses_gt.csv:3: the quaternion qw qx qy qz has norm 0.5");
  // driving forward along x loads; turning about to face west while still moving east is refused
  // at the row that ends the first 0.5 m stretch driven backwards
  io::writeFileAtomic(dir / "ds" / "poses_gt.csv",
                      "time_s,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.1,0.3,0,0,1,0,0,0\n0.2,0.6,0,0,1,0,0,0\n", true);
  EXPECT_NO_THROW(DatasetSource(dir / "ds"));
  refused("poses_gt.csv", "0,0,0,0,1,0,0,0\n0.1,0.6,0,0,1,0,0,0\n0.2,0.9,0,0,0,0,0,1\n0.3,1.2,0,0,0,0,0,1\n",
          "poses_gt.csv:5: the vehicle drives backwards");
  // rolled 90 degrees about its x axis (qw = qx = 0.7071): the vehicle is on its side
  refused("poses_gt.csv", "0,0,0,0,1,0,0,0\n0.1,0.3,0,0,0.70710678,0.70710678,0,0\n",
          "poses_gt.csv:3: the vehicle is tilted 90 degrees from upright");
}

// a laser table of 16 lasers, enough for a dataset to load
const char* sixteenLasers() {
  static const std::string yaml = [] {
    std::string s = "lasers:\n";
    for (int i = 0; i < 16; ++i)
      s += "- {laser_id: " + std::to_string(i) + ", rot_correction: 0, vert_correction: 0}\n";
    return s;
  }();
  return yaml.c_str();
}

// A rig of three cameras, each with its own size and pose.
RigCalibration threeCameras() {
  RigCalibration cal;
  const char* names[] = {"front", "left", "rear"};
  for (int i = 0; i < 3; ++i) {
    CameraCalibration c;
    c.name = names[i];
    c.intrinsics = CameraIntrinsics::fromFovy(32 + 8 * i, 24 + 4 * i, 1.0 + 0.1 * i);
    c.vehicle_from_camera = Pose::Identity();
    c.vehicle_from_camera.linear() = Eigen::AngleAxisd(i * M_PI / 2, Vector3::UnitZ()).toRotationMatrix();
    c.vehicle_from_camera.translation() = Vector3(0.25 * i, -0.1 * i, 1.6);
    cal.cameras.push_back(c);
  }
  cal.vehicle_from_lidar.translation() = Vector3(0, 0, 1.8);
  return cal;
}

TEST(DatasetTest, CalibrationWithSeveralCamerasRoundTrips) {
  const RigCalibration cal = threeCameras();
  const RigCalibration back = calibrationFromJson(calibrationToJson(cal), "test");
  ASSERT_EQ(back.cameras.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back.cameras[i].name, cal.cameras[i].name);
    EXPECT_EQ(back.cameras[i].intrinsics.width, cal.cameras[i].intrinsics.width);
    EXPECT_EQ(back.cameras[i].intrinsics.height, cal.cameras[i].intrinsics.height);
    EXPECT_EQ(back.cameras[i].intrinsics.fx, cal.cameras[i].intrinsics.fx);
    EXPECT_EQ(back.cameras[i].intrinsics.cy, cal.cameras[i].intrinsics.cy);
    EXPECT_TRUE(back.cameras[i].vehicle_from_camera.isApprox(cal.cameras[i].vehicle_from_camera, 0));
  }
  EXPECT_TRUE(back.vehicle_from_lidar.isApprox(cal.vehicle_from_lidar, 0));
}

TEST(DatasetTest, BadCameraListsAreNamed) {
  auto error = [](const RigCalibration& cal) {
    try {
      calibrationFromJson(calibrationToJson(cal), "cal.json");
    } catch (const io::InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  RigCalibration cal = threeCameras();
  cal.cameras[2].name = "front";
  EXPECT_NE(error(cal).find("cal.json: camera 2 ('front'): duplicate camera name (also camera 0)"), std::string::npos)
      << error(cal);
  cal = threeCameras();
  cal.cameras[1].name = "";
  EXPECT_NE(error(cal).find("camera 1 has no name"), std::string::npos);
  cal = threeCameras();
  cal.cameras[1].name = "../x";
  EXPECT_NE(error(cal).find("may not hold '/'"), std::string::npos);
  cal = threeCameras();
  cal.cameras[0].intrinsics.fx = 0;
  EXPECT_NE(error(cal).find("camera 0 ('front'): size and focal lengths must be positive"), std::string::npos);
  // a rig without cameras is a valid rig (lidar only)
  EXPECT_EQ(error(RigCalibration{}), "");
}

// Writes a dataset of one frame with an image from every camera of `cal`.
void writeOneFrame(const fs::path& dir, const RigCalibration& cal) {
  DatasetWriter w(dir, cal, LaserCalibration{}, "{}", false);
  RigFrame f;
  f.sensors.index = 0;
  f.sensors.sweep.end_time = 0.1;
  for (std::size_t c = 0; c < cal.cameras.size(); ++c) {
    const CameraIntrinsics& k = cal.cameras[c].intrinsics;
    f.sensors.images.push_back(
        {static_cast<int>(c), 0.0, cv::Mat(k.height, k.width, CV_8UC3, cv::Scalar(10 * c, 20, 30))});
  }
  w.write(f);
  w.finish();
  io::writeFileAtomic(dir / "lasers.yaml", sixteenLasers(), true);
}

TEST(DatasetTest, EveryCamerasImagesComeBackUnderItsName) {
  test::TempDir dir;
  const RigCalibration cal = threeCameras();
  writeOneFrame(dir / "ds", cal);
  for (const char* n : {"front", "left", "rear"})
    EXPECT_TRUE(fs::exists(dir / "ds" / "camera" / n / "000000.png")) << n;
  DatasetSource source(dir / "ds");
  EXPECT_EQ(source.formatVersion(), 2);
  const auto f = source.next();
  ASSERT_TRUE(f);
  ASSERT_EQ(f->sensors.images.size(), 3u);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(f->sensors.images[c].camera, c);
    EXPECT_EQ(f->sensors.images[c].rgb.cols, cal.cameras[c].intrinsics.width);
    EXPECT_EQ(f->sensors.images[c].rgb.at<cv::Vec3b>(0, 0), cv::Vec3b(10 * c, 20, 30));
  }
}

TEST(DatasetTest, AManifestCameraWithoutImagesIsNamed) {
  test::TempDir dir;
  writeOneFrame(dir / "ds", threeCameras());
  // the left camera's image of frame 0 is gone
  fs::remove(dir / "ds" / "camera" / "left" / "000000.png");
  DatasetSource source(dir / "ds");
  try {
    source.next();
    FAIL() << "a frame without the left camera's image loaded";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera 'left' no image"), std::string::npos) << e.what();
  }
  // and its folder too
  fs::remove_all(dir / "ds" / "camera" / "left");
  try {
    DatasetSource again(dir / "ds");
    FAIL() << "a dataset without the left camera's folder loaded";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera 'left' has no images"), std::string::npos) << e.what();
  }
}

// A dataset of format 1 (one camera, its calibration at the top, its images in camera/) loads
// as a rig of one camera named "front".
TEST(DatasetTest, FormatOneDatasetsStillLoad) {
  test::TempDir dir;
  RigCalibration cal;
  cal.cameras.push_back({"front", CameraIntrinsics::fromFovy(32, 24, 1.0), Pose::Identity()});
  writeOneFrame(dir / "ds", cal);
  // rewrite it as format 1 wrote it
  fs::rename(dir / "ds" / "camera" / "front" / "000000.png", dir / "ds" / "camera" / "000000.png");
  fs::remove_all(dir / "ds" / "camera" / "front");
  auto j = nlohmann::json::parse(io::readFile(dir / "ds" / "calibration.json"));
  j["camera"] = j["cameras"][0];
  j["vehicle_from_camera"] = j["cameras"][0]["vehicle_from_camera"];
  j["camera"].erase("vehicle_from_camera");
  j["camera"].erase("name");
  j.erase("cameras");
  io::writeFileAtomic(dir / "ds" / "calibration.json", j.dump(1), true);
  auto m = nlohmann::json::parse(io::readFile(dir / "ds" / "manifest.json"));
  m["format"] = "terrain-dataset/1";
  m.erase("cameras");
  io::writeFileAtomic(dir / "ds" / "manifest.json", m.dump(1), true);

  DatasetSource source(dir / "ds");
  EXPECT_EQ(source.formatVersion(), 1);
  ASSERT_EQ(source.calibration().cameras.size(), 1u);
  EXPECT_EQ(source.calibration().cameras[0].name, "front");
  EXPECT_EQ(source.calibration().cameras[0].intrinsics.width, 32);
  const auto f = source.next();
  ASSERT_TRUE(f);
  ASSERT_EQ(f->sensors.images.size(), 1u);
  EXPECT_EQ(f->sensors.images[0].rgb.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 20, 30));
}

}  // namespace
}  // namespace terrain::rig
