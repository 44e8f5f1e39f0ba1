// The files a reconstruction writes: a mesh wider than the images' pixel limit is drawn coarser,
// with a warning, instead of allocating an image per cell over its whole extent.

#include "app/outputs.hpp"
#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cstdlib>
#include <memory>
#include <sstream>

namespace terrain {
namespace {

TEST(OutputsTest, AMeshWiderThanTheImageLimitIsDrawnCoarserWithAWarning) {
  test::TempDir dir;
  // 2 km: 10,003 cells across, 3 cells a pixel
  app::writeReconstruction(dir.path(), *test::twoPatches(10000));
  const cv::Mat tex = cv::imread((dir / "mesh_texture.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(tex.cols, 3335);
  EXPECT_EQ(tex.rows, 1);
  const cv::Mat map = cv::imread((dir / "height_before.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_GT(map.cols, 3335);
  EXPECT_LT(map.cols, 3335 + 400);  // the map and its scale bar
  const std::string warnings = io::readFile(dir / "warnings.json");
  EXPECT_NE(warnings.find("0.6 m per pixel"), std::string::npos) << warnings;
  // the texture coordinates of the far patch's last cell: (10002 + 0.5) / (3335 * 3), in the last texel
  const std::string obj = io::readFile(dir / "mesh.obj");
  EXPECT_NE(obj.find("vt 0.999750 0.833333"), std::string::npos);
}

TEST(OutputsTest, AMeshWithinTheImageLimitIsDrawnACellAPixel) {
  test::TempDir dir;
  app::writeReconstruction(dir.path(), *test::twoPatches(100));
  const cv::Mat tex = cv::imread((dir / "mesh_texture.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(tex.cols, 103);
  EXPECT_EQ(tex.rows, 3);
  EXPECT_EQ(io::readFile(dir / "warnings.json").find("per pixel"), std::string::npos);
}

// A recorded drive whose GPS fixes run 90 m apart (1 km in 1.1 s; allowed by pose.max_speed):
// the reconstruction's mesh is 1.2 km long. Its images are drawn coarser, and the report skips the
// inpainted height map over its extent (it took over ten minutes).
TEST(OutputsTest, ALongDriveIsReconstructedWithCoarserImages) {
  test::TempDir dir;
  const std::string cli = TERRAIN_CLI;
  ASSERT_EQ(0, std::system((cli + " record --scene " + std::string(TERRAIN_SOURCE_DIR) + "/scenes/library/urban_1.xml" +
                            " --frames 12 --out " + (dir / "ds").string() + " > /dev/null 2>&1")
                               .c_str()));
  std::istringstream in(io::readFile(dir / "ds" / "gps.csv"));
  std::string line, out;
  std::getline(in, line);
  out = line + "\n";
  for (int i = 0; std::getline(in, line); ++i) {
    // time, latitude, ...: latitude moved i * 90 m north
    const auto a = line.find(','), b = line.find(',', a + 1);
    std::ostringstream moved;
    moved.precision(12);
    moved << std::stod(line.substr(a + 1, b - a - 1)) + i * 90.0 / 111320.0;
    out += line.substr(0, a + 1) + moved.str() + line.substr(b) + "\n";
  }
  io::writeFileAtomic(dir / "ds" / "gps.csv", out, true);
  io::writeFileAtomic(dir / "cfg.yaml", "pose:\n  max_speed: 1000\n", true);
  ASSERT_EQ(0, std::system((cli + " reconstruct --input " + (dir / "ds").string() + " --out " + (dir / "out").string() +
                            " --config " + (dir / "cfg.yaml").string() + " > /dev/null 2>&1")
                               .c_str()));
  EXPECT_NE(io::readFile(dir / "out" / "warnings.json").find("m per pixel"), std::string::npos);
  EXPECT_NE(io::readFile(dir / "out" / "report.json").find("no height map over its extent"), std::string::npos);
  const cv::Mat tex = cv::imread((dir / "out" / "mesh_texture.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_LE(std::max(tex.cols, tex.rows), 4096);
}

}  // namespace
}  // namespace terrain
