#include "rig/pcd.hpp"

#include "rig/file_io.hpp"
#include "tests/temp_dir.hpp"

#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>

namespace terrain::rig {
namespace {

LidarSweep sampleSweep() {
  LidarSweep s;
  s.start_time = 10.0;
  s.end_time = 10.1;
  for (int i = 0; i < 5; ++i) {
    s.points.push_back(
        {1.5f * i, -2.0f, 0.25f * i, 10.0f * i, static_cast<std::uint16_t>(i * 7), 0.01f * i, 10.0 + 1e-5 * i});
  }
  return s;
}

TEST(PcdTest, RoundTripIsExact) {
  const LidarSweep s = sampleSweep();
  const std::vector<PointTruth> truth{{3, 1}, {4, 2}, {-1, 0}, {7, 4}, {8, 3}};
  const DecodedPcd d = decodePcd(encodePcd(s, truth), "mem");
  ASSERT_EQ(d.points.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(d.points[i].x, s.points[i].x);
    EXPECT_EQ(d.points[i].z, s.points[i].z);
    EXPECT_EQ(d.points[i].ring, s.points[i].ring);
    EXPECT_EQ(d.points[i].time, s.points[i].time);
    EXPECT_EQ(d.truth[i].geom, truth[i].geom);
    EXPECT_EQ(d.truth[i].cls, truth[i].cls);
  }
}

TEST(PcdTest, PclReadsOurFiles) {
  test::TempDir dir;
  const std::string path = (dir / "sweep.pcd").string();
  io::writeFileAtomic(path, encodePcd(sampleSweep(), {}), false);
  pcl::PCLPointCloud2 cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(path, cloud), 0);
  EXPECT_EQ(cloud.width * cloud.height, 5u);
  std::vector<std::string> names;
  for (const auto& f : cloud.fields) names.push_back(f.name);
  EXPECT_EQ(names, (std::vector<std::string>{"x", "y", "z", "intensity", "ring", "azimuth", "time", "label", "class"}));
  float x = 0;
  std::memcpy(&x, cloud.data.data() + 3 * cloud.point_step + cloud.fields[0].offset, 4);
  EXPECT_EQ(x, 4.5f);
}

TEST(PcdTest, RefusesTruncatedAndMalformedFiles) {
  const std::string good = encodePcd(sampleSweep(), {});
  auto errorOf = [](const std::string& bytes) {
    try {
      decodePcd(bytes, "f.pcd");
    } catch (const io::InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(errorOf(good.substr(0, good.size() - 10)).find("truncated"), std::string::npos);
  EXPECT_NE(errorOf("VERSION 0.7\nFIELDS x y\nSIZE 4 4\nTYPE F F\nPOINTS 0\nDATA binary\n").find("'z' is missing"),
            std::string::npos);
  EXPECT_NE(errorOf("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 0\nDATA ascii\n").find("not supported"),
            std::string::npos);
  EXPECT_NE(errorOf("garbage").find("f.pcd"), std::string::npos);
}

}  // namespace
}  // namespace terrain::rig
