#include "rig/velodyne_calibration.hpp"

#include "rig/file_io.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace terrain::rig {
namespace {

// real calibration files of Velodyne units (from the BSD-licensed ROS velodyne driver)
const std::string kShared = std::string(TERRAIN_SOURCE_DIR) + "/tests/data/velodyne/";
const std::string kShipped = std::string(TERRAIN_SOURCE_DIR) + "/data/calibration/hdl64e_s2.1-sztaki.yaml";

std::string errorOf(const std::string& text) {
  try {
    parseLaserCalibration(text, "cal.yaml");
  } catch (const io::InputError& e) {
    return e.what();
  }
  return "";
}

// a 32-laser YAML with one laser's line replaced
std::string yaml32(int bad_laser = -1, const std::string& bad_entry = "") {
  std::string s = "lasers:\n";
  for (int i = 0; i < 32; ++i) {
    s += i == bad_laser ? bad_entry
                        : "- {laser_id: " + std::to_string(i) +
                              ", rot_correction: 0.0, vert_correction: " + std::to_string(-0.5 + i * 0.03) + "}\n";
  }
  return s;
}

TEST(VelodyneCalibrationTest, YamlAndDbXmlOfTheSameUnitAgree) {
  const LaserCalibration y = loadLaserCalibration(kShipped);
  ASSERT_EQ(y.laserCount(), 64);
  EXPECT_DOUBLE_EQ(y.distance_resolution, 0.002);
  EXPECT_NEAR(y.lasers[0].vert_correction, -0.15304134919741974, 1e-15);
  EXPECT_NEAR(y.lasers[0].vert_offset, 0.19548199, 1e-12);
  const std::string xml = kShared + "64e_s2.1-sztaki.xml";
  const LaserCalibration x = loadLaserCalibration(xml);
  ASSERT_EQ(x.laserCount(), 64);
  EXPECT_NEAR(x.distance_resolution, 0.002, 1e-12);
  for (int i = 0; i < 64; ++i) {
    EXPECT_NEAR(x.lasers[i].rot_correction, y.lasers[i].rot_correction, 1e-6) << i;
    EXPECT_NEAR(x.lasers[i].vert_correction, y.lasers[i].vert_correction, 1e-6) << i;
    EXPECT_NEAR(x.lasers[i].dist_correction, y.lasers[i].dist_correction, 1e-6) << i;
    EXPECT_NEAR(x.lasers[i].vert_offset, y.lasers[i].vert_offset, 1e-6) << i;
    EXPECT_NEAR(x.lasers[i].horiz_offset, y.lasers[i].horiz_offset, 1e-6) << i;
  }
}

TEST(VelodyneCalibrationTest, ReadsTheOtherRealUnits) {
  for (const char* name : {"64e_utexas.yaml", "32db.yaml"}) {
    const std::string path = kShared + name;
    const LaserCalibration c = loadLaserCalibration(path);
    EXPECT_EQ(c.laserCount(), std::string(name) == "32db.yaml" ? 32 : 64) << name;
  }
}

TEST(VelodyneCalibrationTest, YamlRoundTripIsExact) {
  const LaserCalibration a = loadLaserCalibration(kShipped);
  const LaserCalibration b = parseLaserCalibration(laserCalibrationToYaml(a), "round trip");
  ASSERT_EQ(a.laserCount(), b.laserCount());
  for (int i = 0; i < a.laserCount(); ++i) {
    EXPECT_EQ(a.lasers[i].rot_correction, b.lasers[i].rot_correction);
    EXPECT_EQ(a.lasers[i].vert_correction, b.lasers[i].vert_correction);
    EXPECT_EQ(a.lasers[i].vert_offset, b.lasers[i].vert_offset);
  }
}

TEST(VelodyneCalibrationTest, RefusesBadFilesNamingTheProblem) {
  EXPECT_EQ(errorOf(yaml32()), "");
  EXPECT_NE(errorOf("lasers: []\n").find("no lasers"), std::string::npos);
  EXPECT_NE(errorOf("lasers: [\n").find("not valid YAML"), std::string::npos);
  EXPECT_NE(errorOf("hello: 1\n").find("'lasers'"), std::string::npos);
  // a missing laser: ids 0..30 and 31 replaced by a duplicate of 5
  EXPECT_NE(errorOf(yaml32(31, "- {laser_id: 5, rot_correction: 0, vert_correction: 0}\n")).find("appears twice"),
            std::string::npos);
  EXPECT_NE(errorOf(yaml32(3, "- {laser_id: 3, rot_correction: 0}\n")).find("'vert_correction' is missing"),
            std::string::npos);
  EXPECT_NE(
      errorOf(yaml32(3, "- {laser_id: 3, rot_correction: 0, vert_correction: 7.5}\n")).find("laser 3: vert_correction"),
      std::string::npos);
  EXPECT_NE(errorOf(yaml32(3, "- {laser_id: 3, rot_correction: abc, vert_correction: 0}\n")).find("not a number"),
            std::string::npos);
  EXPECT_NE(errorOf(yaml32(3, "- {laser_id: 99, rot_correction: 0, vert_correction: 0}\n")).find("laser_id 99"),
            std::string::npos);
  EXPECT_NE(errorOf("<boost_serialization><DB><points_></points_></DB></boost_serialization>").find("no lasers"),
            std::string::npos);
  EXPECT_NE(errorOf("<boost_serialization><DB>").find("not valid XML"), std::string::npos);
  EXPECT_THROW(loadLaserCalibration("/nonexistent/cal.yaml"), io::InputError);
}

}  // namespace
}  // namespace terrain::rig
