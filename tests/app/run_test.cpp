// 'terrain run' through the command line: the same scenario and seed give the same outputs whatever
// the number of cores (the lidar's workers, the segmentation's task arena and the renderer all
// follow the cores the process may use).

#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <thread>

namespace terrain {
namespace {

namespace fs = std::filesystem;

using test::kCli;
using test::sh;

TEST(RunTest, OneCoreAndEveryCoreGiveTheSameOutputs) {
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "needs a machine of two cores or more";
  test::TempDir dir;
  const std::string args = " run --scenario urban --seed 1 --frames 12 --no-baselines > /dev/null --out ";
  ASSERT_EQ(0, sh("taskset -c 0 " + kCli + args + (dir / "one").string()));
  ASSERT_EQ(0, sh(kCli + args + (dir / "all").string()));
  for (const char* file :
       {"mesh.ply", "mesh.obj", "mesh_texture.png", "voxels.pcd", "height_before.png", "height_after.png"}) {
    const std::string one = io::readFile(dir / "one" / file), all = io::readFile(dir / "all" / file);
    EXPECT_FALSE(one.empty()) << file;
    EXPECT_TRUE(one == all) << file << " differs";
  }
  // the report's scores and settings; its timing is the machine's
  auto one = nlohmann::json::parse(io::readFile(dir / "one" / "report.json"));
  auto all = nlohmann::json::parse(io::readFile(dir / "all" / "report.json"));
  ASSERT_TRUE(one.contains("timing") && one.contains("height_recovery"));
  one.erase("timing"), all.erase("timing");
  EXPECT_EQ(one, all);
}

}  // namespace
}  // namespace terrain
