// 'terrain evaluate --run OUT' scores a finished run again from what it kept in OUT/state/: the
// same report as the run wrote, and clear errors for a damaged state.

#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>

namespace terrain {
namespace {

namespace fs = std::filesystem;
using test::kCli;
using test::sh;

class EvaluateTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    ASSERT_EQ(0, sh(kCli + " run --scenario forest --seed 3 --frames 8 --out " + run().string() + " > /dev/null"));
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path run() { return *dir_ / "run"; }
  static test::TempDir* dir_;
};
test::TempDir* EvaluateTest::dir_ = nullptr;

TEST_F(EvaluateTest, ScoresAFinishedRunAsTheRunDid) {
  ASSERT_TRUE(fs::exists(run() / "state" / "state.json"));
  const fs::path again = *dir_ / "again";
  ASSERT_EQ(0, sh(kCli + " evaluate --run " + run().string() + " --out " + again.string() + " > /dev/null"));
  EXPECT_EQ(io::readFile(run() / "report.json"), io::readFile(again / "report.json"));
  EXPECT_EQ(io::readFile(run() / "report.html"), io::readFile(again / "report.html"));
  // a second time into the same place is refused, and what is there stays
  const std::string before = io::readFile(again / "report.json");
  EXPECT_NE(0, sh(kCli + " evaluate --run " + run().string() + " --out " + again.string() + " > /dev/null 2>&1"));
  EXPECT_EQ(before, io::readFile(again / "report.json"));
}

TEST_F(EvaluateTest, WithoutBaselinesTheReportSaysSoAndScoresTheMethodAsBefore) {
  const fs::path lean = *dir_ / "lean";
  ASSERT_EQ(0,
            sh(kCli + " evaluate --run " + run().string() + " --out " + lean.string() + " --no-baselines > /dev/null"));
  const auto full = nlohmann::json::parse(io::readFile(run() / "report.json"));
  const auto r = nlohmann::json::parse(io::readFile(lean / "report.json"));
  const auto& g = r["ground_segmentation"];
  for (const char* m : {"fixed_band", "ransac_plane", "morphological_filter"}) {
    EXPECT_TRUE(full["ground_segmentation"].contains(m)) << m;
    EXPECT_FALSE(g.contains(m)) << m;
  }
  EXPECT_NE(g.value("baselines_skipped", "").find("--no-baselines"), std::string::npos);
  for (const char* m : {"histogram", "gmrf_icm", "gmrf_mincut"}) EXPECT_EQ(g[m], full["ground_segmentation"][m]) << m;
  EXPECT_EQ(r["height_recovery"], full["height_recovery"]);
  EXPECT_TRUE(fs::exists(lean / "report.html"));
}

TEST_F(EvaluateTest, ASceneChangedSinceTheRunIsRefused) {
  // a copy of the run (its scene inside it) whose sidecar, then heightfield, is edited afterwards
  for (const char* edited : {"forest_3.truth.json", "forest_3.hfield", "forest_3.xml"}) {
    const fs::path copy = *dir_ / (std::string("changed_") + edited);
    fs::copy(run(), copy, fs::copy_options::recursive);
    const fs::path file = copy / "scene" / edited;
    ASSERT_TRUE(fs::exists(file)) << file;
    std::string bytes = io::readFile(file);
    bytes[bytes.size() / 2] ^= 0x01;
    std::ofstream(file, std::ios::binary) << bytes;
    const fs::path err = *dir_ / "err.txt";
    const int rc = sh(kCli + " evaluate --run " + copy.string() + " --out " + (copy / "again").string() +
                      " > /dev/null 2> " + err.string());
    EXPECT_EQ(WEXITSTATUS(rc), 2) << edited;
    EXPECT_NE(io::readFile(err).find(std::string(edited) + ": changed since the run"), std::string::npos)
        << io::readFile(err);
    EXPECT_FALSE(fs::exists(copy / "again" / "report.json"));
  }
}

TEST_F(EvaluateTest, DamagedStateGetsAClearError) {
  // a copy of the run whose files are damaged one at a time
  const fs::path copy = *dir_ / "copy", log = *dir_ / "log";
  auto damaged = [&](const std::string& file, const std::string& content) {
    fs::remove_all(copy);
    fs::copy(run(), copy, fs::copy_options::recursive);
    std::ofstream(copy / "state" / file, std::ios::binary | std::ios::trunc) << content;
    const int rc = sh(kCli + " evaluate --run " + copy.string() + " --out " + (*dir_ / "x").string() + " > " +
                      log.string() + " 2>&1");
    return std::make_pair(rc, io::readFile(log));
  };
  const std::string bin = io::readFile(run() / "state" / "pipeline.bin");
  auto [rc1, msg1] = damaged("pipeline.bin", bin.substr(0, bin.size() / 2));
  EXPECT_EQ(rc1 >> 8, 2);
  EXPECT_NE(msg1.find("pipeline.bin"), std::string::npos) << msg1;
  EXPECT_TRUE(msg1.find("cut short") != std::string::npos || msg1.find("do not fit in the file") != std::string::npos)
      << msg1;
  auto [rc2, msg2] = damaged("truth.bin", "garbage");
  EXPECT_NE(rc2, 0);
  EXPECT_NE(msg2.find("not a terrain run state"), std::string::npos) << msg2;
  auto [rc3, msg3] = damaged("state.json", "{\"format\": \"something-else/9\"}");
  EXPECT_NE(rc3, 0);
  EXPECT_NE(msg3.find("format is not terrain-run-state/6"), std::string::npos) << msg3;
  auto [rc4, msg4] = damaged("pipeline_config.json", "ground: {delta: -1}");
  EXPECT_NE(rc4, 0);
  EXPECT_NE(msg4.find("ground.delta"), std::string::npos) << msg4;
  EXPECT_FALSE(fs::exists(*dir_ / "x" / "report.json"));
  // not a run directory at all
  EXPECT_NE(0, sh(kCli + " evaluate --run " + dir_->path().string() + " > " + log.string() + " 2>&1"));
  EXPECT_NE(io::readFile(log).find("state.json: missing"), std::string::npos) << io::readFile(log);
}

}  // namespace
}  // namespace terrain
