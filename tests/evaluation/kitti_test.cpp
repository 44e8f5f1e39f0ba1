#include "evaluation/kitti.hpp"

#include "evaluation/metrics.hpp"
#include "rig/file_io.hpp"
#include "rig/kitti.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

namespace terrain::eval {
namespace {

const std::filesystem::path kData = std::filesystem::path(TERRAIN_SOURCE_DIR) / "tests" / "data" / "semantickitti";

// the paper's method on the two real HDL-64E scans: a guard on real data
TEST(KittiTest, GroundSegmentationOfRealScans) {
  for (const char* name : {"000000", "000020"}) {
    const rig::KittiScan scan = rig::readKittiScan(kData / (std::string(name) + ".bin"));
    const auto labels = rig::readSemanticKittiLabels(kData / (std::string(name) + ".label"), scan.points.size());
    ASSERT_GT(scan.points.size(), 120000u);
    const auto pred = segmentScan(scan.points, VoxelMapConfig{}, GroundSegmentationConfig{});
    std::vector<bool> p(pred.begin(), pred.end()), truth, skip;
    for (auto l : labels) truth.push_back(rig::isKittiGround(l)), skip.push_back(rig::isKittiIgnored(l));
    const BinaryScores s = binaryScores(p, truth, skip);
    EXPECT_GT(s.f1, 0.92) << name;
    EXPECT_GT(s.recall, 0.95) << name;
  }
}

TEST(KittiTest, MalformedFilesAreRefused) {
  test::TempDir dir;
  io::writeFileAtomic(dir / "bad.bin", std::string(33, '\0'), false);
  try {
    rig::readKittiScan(dir / "bad.bin");
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not a whole number of 16-byte points"), std::string::npos);
  }
  io::writeFileAtomic(dir / "a.label", std::string(12, '\0'), false);
  EXPECT_THROW(rig::readSemanticKittiLabels(dir / "a.label", 4), io::InputError);
  EXPECT_EQ(rig::readSemanticKittiLabels(dir / "a.label", 3).size(), 3u);
  EXPECT_THROW(rig::readKittiScan(dir / "none.bin"), io::InputError);
}

}  // namespace
}  // namespace terrain::eval
