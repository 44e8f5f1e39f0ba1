// 'terrain run' through the command line: the same scenario and seed give the same outputs whatever
// the number of cores (the lidar's workers, the segmentation's task arena and the renderer all
// follow the cores the process may use).

#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <map>
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

// Ctrl-C (SIGINT) or SIGTERM during 'run', 'record' and 'reconstruct' stops the command with exit
// 130 or 143; the output directory it would have replaced is byte-identical afterwards, and no
// partial directory is left beside it.
TEST(RunTest, AnInterruptedCommandLeavesTheOldOutputAsItWas) {
  test::TempDir dir;
  const std::string cli = test::kCli;
  const fs::path run = dir / "run", ds = dir / "ds", rec = dir / "rec";
  ASSERT_EQ(0, test::sh(cli + " run --frames 3 --cameras forward --out " + run.string() + " > /dev/null 2>&1"));
  ASSERT_EQ(0, test::sh(cli + " record --scene " + test::kUrbanScene + " --frames 3 --out " + ds.string() +
                        " > /dev/null 2>&1"));
  ASSERT_EQ(0, test::sh(cli + " reconstruct --input " + ds.string() + " --out " + rec.string() + " > /dev/null 2>&1"));
  const auto snapshot = [](const fs::path& d) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(d)) {
      if (e.is_regular_file()) files[e.path().lexically_relative(d).string()] = io::readFile(e.path());
    }
    return files;
  };
  const auto before_run = snapshot(run), before_ds = snapshot(ds);
  // the command in the background, the signal after a few seconds (it needs a minute or more)
  const auto interrupt = [&](const std::string& args, const char* signal) {
    const std::string rc = (dir / "rc").string();
    test::sh("(" + cli + " " + args + " > /dev/null 2> " + (dir / "err").string() + " & p=$!; sleep 6; kill -" +
             signal + " $p; wait $p; echo $? > " + rc + ")");
    return std::stoi(io::readFile(rc));
  };
  EXPECT_EQ(interrupt("run --frames 400 --cameras forward --force --out " + run.string(), "INT"), 130);
  EXPECT_NE(io::readFile(dir / "err").find("interrupted (SIGINT)"), std::string::npos) << io::readFile(dir / "err");
  EXPECT_EQ(snapshot(run), before_run);
  EXPECT_EQ(interrupt("record --scene " + test::kUrbanScene + " --frames 400 --force --out " + ds.string(), "TERM"),
            143);
  EXPECT_EQ(snapshot(ds), before_ds);
  for (const auto& e : fs::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
  }
  // an input inside the output it would replace is refused before anything is written
  EXPECT_EQ(WEXITSTATUS(test::sh(cli + " reconstruct --input " + ds.string() + " --out " + dir.path().string() +
                                 " --force > /dev/null 2>&1")),
            2);
  EXPECT_EQ(snapshot(ds), before_ds);
}

}  // namespace
}  // namespace terrain
