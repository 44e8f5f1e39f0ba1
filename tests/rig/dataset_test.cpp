#include "rig/dataset.hpp"

#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

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
  cal.camera = CameraIntrinsics::fromFovy(64, 48, 1.0);
  {
    DatasetWriter w(dir / "ds", cal, LaserCalibration{}, "{}", false);
    w.finish();
  }
  // an empty laser table is refused on load
  EXPECT_THROW(DatasetSource(dir / "ds"), io::InputError);
  io::writeFileAtomic(dir / "ds" / "lasers.yaml", "lasers:\n" + [] {
    std::string s;
    for (int i = 0; i < 16; ++i) s += "- {laser_id: " + std::to_string(i) + ", rot_correction: 0, vert_correction: 0}\n";
    return s;
  }(), true);
  EXPECT_NO_THROW(DatasetSource(dir / "ds"));
  io::writeFileAtomic(dir / "ds" / "gps.csv", "time_s,lat,lon,alt,sigma\n1,2,3,4,5\n1,2,x,4,5\n", true);
  try {
    DatasetSource s(dir / "ds");
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("gps.csv:3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace terrain::rig
