// 'terrain reconstruct' over a recorded dataset through the command line: a dataset damaged part
// way through ends the run with an error that names the file, and leaves --out as it found it.

#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace terrain {
namespace {

namespace fs = std::filesystem;

using test::kCli;
using test::sh;
const std::string& kScene = test::kUrbanScene;

TEST(ReconstructTest, ADamagedSweepLeavesTheOutputDirectoryAsItWasFound) {
  test::TempDir dir;
  const fs::path ds = dir / "ds", out = dir / "out", log = dir / "log";
  ASSERT_EQ(0, sh(kCli + " record --scene " + kScene + " --frames 6 --out " + ds.string() + " > /dev/null"));
  // frame 4's sweep cut short: frames 0-3 are processed before the reader reaches it
  const fs::path sweep = ds / "lidar" / "000004.pcd";
  const std::string whole = io::readFile(sweep);
  io::writeFileAtomic(sweep, whole.substr(0, 1000), true);
  EXPECT_NE(0, sh(kCli + " reconstruct --input " + ds.string() + " --out " + out.string() + " > /dev/null 2> " +
                  log.string()));
  const std::string error = io::readFile(log);
  EXPECT_NE(error.find("000004.pcd: data is truncated"), std::string::npos) << error;
  // nothing under its name, and no partial directory beside it
  EXPECT_FALSE(fs::exists(out));
  for (const auto& e : fs::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
  }
  // the input mended, the same --out takes the run without --force
  io::writeFileAtomic(sweep, whole, true);
  ASSERT_EQ(0, sh(kCli + " reconstruct --input " + ds.string() + " --out " + out.string() + " > /dev/null 2> " +
                  log.string()))
      << io::readFile(log);
  EXPECT_TRUE(fs::exists(out / "report.json"));
  EXPECT_TRUE(fs::is_directory(out / "boundaries"));
}

// A dataset of format 1 (one camera: its calibration at the top of calibration.json, its images in
// camera/ itself) still reconstructs, its images used: the same report as the format-2 recording it
// was rewritten from.
TEST(ReconstructTest, AFormatOneDatasetStillReconstructs) {
  test::TempDir dir;
  const fs::path ds = dir / "ds", out2 = dir / "out2", out1 = dir / "out1";
  ASSERT_EQ(0, sh(kCli + " record --scene " + kScene + " --frames 4 --cameras forward --width 160 --height 120 --out " +
                  ds.string() + " > /dev/null"));
  ASSERT_EQ(0, sh(kCli + " reconstruct --input " + ds.string() + " --out " + out2.string() + " > /dev/null 2>&1"));
  // rewrite it as format 1 wrote it
  for (const auto& e : fs::directory_iterator(ds / "camera" / "front"))
    fs::rename(e.path(), ds / "camera" / e.path().filename());
  fs::remove(ds / "camera" / "front");
  auto cal = nlohmann::json::parse(io::readFile(ds / "calibration.json"));
  cal["camera"] = cal["cameras"][0];
  cal["vehicle_from_camera"] = cal["cameras"][0]["vehicle_from_camera"];
  cal["camera"].erase("vehicle_from_camera"), cal["camera"].erase("name"), cal.erase("cameras");
  io::writeFileAtomic(ds / "calibration.json", cal.dump(1), true);
  auto manifest = nlohmann::json::parse(io::readFile(ds / "manifest.json"));
  manifest["format"] = "terrain-dataset/1";
  manifest.erase("cameras");
  io::writeFileAtomic(ds / "manifest.json", manifest.dump(1), true);
  ASSERT_EQ(0, sh(kCli + " reconstruct --input " + ds.string() + " --out " + out1.string() + " > /dev/null 2>&1"));
  const auto a = nlohmann::json::parse(io::readFile(out2 / "report.json"));
  const auto b = nlohmann::json::parse(io::readFile(out1 / "report.json"));
  EXPECT_EQ(a["height_recovery"]["after"], b["height_recovery"]["after"]);
  EXPECT_EQ(a["height_recovery"]["by_camera_view"], b["height_recovery"]["by_camera_view"]);
  EXPECT_EQ(b["cameras"], nlohmann::json::array({"front"}));
  // its images were used: vertices were coloured and no frame went without an image
  EXPECT_TRUE(b["height_recovery"]["by_camera_view"].contains("in_camera_view"));
  EXPECT_EQ(io::readFile(out1 / "warnings.json").find("no image"), std::string::npos);
}

}  // namespace
}  // namespace terrain
