// 'terrain reconstruct' over a recorded dataset through the command line: a dataset damaged part
// way through ends the run with an error that names the file, and leaves --out as it found it.

#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

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
  ASSERT_TRUE(fs::is_directory(out));
  EXPECT_TRUE(fs::is_empty(out)) << fs::begin(fs::directory_iterator(out))->path();
  // the input mended, the same --out takes the run without --force
  io::writeFileAtomic(sweep, whole, true);
  ASSERT_EQ(0, sh(kCli + " reconstruct --input " + ds.string() + " --out " + out.string() + " > /dev/null 2> " +
                  log.string()))
      << io::readFile(log);
  EXPECT_TRUE(fs::exists(out / "report.json"));
  EXPECT_TRUE(fs::is_directory(out / "boundaries"));
}

}  // namespace
}  // namespace terrain
