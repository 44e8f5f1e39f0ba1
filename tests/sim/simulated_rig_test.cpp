#include "sim/simulated_rig.hpp"

#include "core/camera_model.hpp"
#include "core/crown_completion.hpp"
#include "rig/dataset.hpp"
#include "rig/file_io.hpp"
#include "scenes/scene_generator.hpp"
#include "sim/camera.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <GeographicLib/LocalCartesian.hpp>
#include <opencv2/core.hpp>

#include <cmath>
#include <fstream>

namespace terrain::sim {
namespace {

namespace fs = std::filesystem;

std::shared_ptr<World> generatedWorld(const test::TempDir& dir, const std::string& type, std::uint64_t seed) {
  scenes::SceneConfig cfg;
  cfg.type = type;
  cfg.seed = seed;
  cfg.extent = 40;
  const fs::path xml = dir / (type + ".xml");
  scenes::writeScene(scenes::generateScene(cfg), xml, true);
  return std::make_shared<World>(xml);
}

// the paper's single forward camera at 160 x 120
SimConfig smallCamera() {
  SimConfig c;
  c.camera.rig = "forward";
  c.camera.width = 160;
  c.camera.height = 120;
  return c;
}

// the surround rig at 160 x 120
SimConfig smallSurround() {
  SimConfig c = smallCamera();
  c.camera.rig = "surround";
  return c;
}

// one camera of 160 x 120 for the renderer alone
CameraMount smallMount() {
  CameraMount m;
  m.width = 160;
  m.height = 120;
  return m;
}

// Every camera of the surround rig: the lidar points it sees fall on pixels of the geom they hit
// (its extrinsic, its rendering and its truth images agree).
TEST(SimulatedRigTest, LidarPointsProjectOntoPixelsOfTheSameGeomInEveryCamera) {
  test::TempDir dir;
  auto world = generatedWorld(dir, "urban", 2);
  SimConfig cfg = smallSurround();
  cfg.lidar.range_noise = 0;
  SimulatedRig rig(world, cfg, 1);
  const auto f = rig.next();
  ASSERT_EQ(rig.calibration().cameras.size(), 4u);
  ASSERT_EQ(f->sensors.images.size(), 4u);
  ASSERT_EQ(f->truth->cameras.size(), 4u);
  for (std::size_t cam = 0; cam < 4; ++cam) {
    const CameraImage& image = f->sensors.images[cam];
    const rig::CameraTruth& truth = f->truth->cameras[cam];
    ASSERT_EQ(image.camera, static_cast<int>(cam));
    ASSERT_EQ(truth.camera, static_cast<int>(cam));
    const CameraCalibration& calibration = rig.calibration().cameras[cam];
    SCOPED_TRACE(calibration.name);
    const CameraIntrinsics& k = calibration.intrinsics;
    const Pose camera_from_world =
        (rig.trajectory().worldFromVehicle(image.time) * calibration.vehicle_from_camera).inverse();
    int checked = 0, same = 0;
    for (std::size_t i = 0; i < f->sensors.sweep.points.size(); ++i) {
      const auto& p = f->sensors.sweep.points[i];
      const Pose world_from_lidar = rig.trajectory().worldFromVehicle(p.time) * rig.calibration().vehicle_from_lidar;
      const Vector3 c = camera_from_world * (world_from_lidar * Vector3(p.x, p.y, p.z));
      if (c.z() < 1.0) continue;
      const int u = static_cast<int>(std::floor(k.fx * c.x() / c.z() + k.cx));
      const int v = static_cast<int>(std::floor(k.fy * c.y() / c.z() + k.cy));
      if (u < 1 || v < 1 || u >= k.width - 1 || v >= k.height - 1) continue;
      // only points the camera sees: the depth image agrees with the point's depth
      const float depth = truth.depth.at<float>(v, u);
      if (std::abs(depth - c.z()) > 0.02 * c.z() + 0.05) continue;
      ++checked;
      same += truth.segmentation.at<std::uint16_t>(v, u) == f->truth->points[i].geom + 1;
    }
    ASSERT_GT(checked, 1000);
    EXPECT_GT(static_cast<double>(same) / checked, 0.98) << same << " of " << checked;
  }
}

// The surround rig's four optical axes point forward, left, back and right, each tilted up 8 deg,
// and each camera's view is 91.3 deg across at 4:3 and fovy 75: together they see every azimuth.
TEST(SimulatedRigTest, SurroundRigCoversTheWholeHorizon) {
  const RigCalibration cal = SimulatedRig::calibrationFor(SimConfig{}, GeodeticOrigin{});
  ASSERT_EQ(cal.cameras.size(), 4u);
  const double up = std::sin(8 * M_PI / 180), level = std::cos(8 * M_PI / 180);
  const Vector3 expected[] = {{level, 0, up}, {0, level, up}, {-level, 0, up}, {0, -level, up}};
  const char* names[] = {"front", "left", "rear", "right"};
  for (int c = 0; c < 4; ++c) {
    EXPECT_EQ(cal.cameras[c].name, names[c]);
    const Vector3 axis = cal.cameras[c].vehicle_from_camera.linear().col(2);
    EXPECT_NEAR((axis - expected[c]).norm(), 0, 1e-12) << names[c];
    // the image's x axis stays level (no roll)
    EXPECT_NEAR(cal.cameras[c].vehicle_from_camera.linear().col(0).z(), 0, 1e-12) << names[c];
  }
  // every azimuth, 1 deg apart, on the horizon falls inside some camera's image
  for (int a = 0; a < 360; ++a) {
    const Vector3 dir(std::cos(a * M_PI / 180), std::sin(a * M_PI / 180), 0);
    bool seen = false;
    for (const auto& c : cal.cameras)
      seen = seen ||
             project(c.intrinsics, c.vehicle_from_camera.inverse() * (c.vehicle_from_camera.translation() + 10 * dir))
                 .has_value();
    EXPECT_TRUE(seen) << a << " deg";
  }
}

// The forward preset is the paper's camera, today's front camera: the same pose and intrinsics.
TEST(SimulatedRigTest, ForwardPresetIsTheSurroundRigsFrontCamera) {
  SimConfig forward;
  forward.camera.rig = "forward";
  const RigCalibration a = SimulatedRig::calibrationFor(forward, GeodeticOrigin{});
  const RigCalibration b = SimulatedRig::calibrationFor(SimConfig{}, GeodeticOrigin{});
  ASSERT_EQ(a.cameras.size(), 1u);
  EXPECT_EQ(a.cameras[0].name, "front");
  EXPECT_TRUE(a.cameras[0].vehicle_from_camera.isApprox(b.cameras[0].vehicle_from_camera, 0));
  EXPECT_EQ(a.cameras[0].intrinsics.fx, b.cameras[0].intrinsics.fx);
  // x right (-y of the vehicle), y down and tilted, z forward and up 8 deg
  const double p = 8 * M_PI / 180;
  const Eigen::Matrix3d& r = a.cameras[0].vehicle_from_camera.linear();
  EXPECT_EQ(r.col(0), Vector3(0, -1, 0));
  EXPECT_EQ(r.col(1), Vector3(std::sin(p), 0, -std::cos(p)));
  EXPECT_EQ(r.col(2), Vector3(std::cos(p), 0, std::sin(p)));
}

TEST(SimulatedRigTest, GpsConvertsBackToTheTruePositionWithinItsNoise) {
  auto world = test::wallWorld(30.0);
  SimConfig cfg = smallCamera();
  cfg.camera.enabled = false;
  cfg.gps.horizontal_sigma = 0.05;
  cfg.gps.vertical_sigma = 0.1;
  SimulatedRig rig(world, cfg, 20);
  const GeodeticOrigin o = rig.calibration().origin;
  const GeographicLib::LocalCartesian enu(o.latitude_deg, o.longitude_deg, o.altitude_m);
  int n = 0;
  double sum2 = 0;
  while (auto f = rig.next()) {
    for (const auto& fix : f->sensors.gps) {
      double x, y, z;
      enu.Forward(fix.latitude_deg, fix.longitude_deg, fix.altitude_m, x, y, z);
      const Vector3 truth =
          rig.trajectory().worldFromVehicle(fix.time) * rig.calibration().vehicle_from_gps.translation();
      EXPECT_LT(std::abs(x - truth.x()), 5 * 0.05);
      EXPECT_LT(std::abs(y - truth.y()), 5 * 0.05);
      EXPECT_LT(std::abs(z - truth.z()), 5 * 0.1);
      sum2 += (x - truth.x()) * (x - truth.x()) + (y - truth.y()) * (y - truth.y());
      ++n;
    }
  }
  ASSERT_EQ(n, 20);  // one fix per frame at 10 Hz
  EXPECT_NEAR(std::sqrt(sum2 / (2 * n)), 0.05, 0.025);
}

TEST(SimulatedRigTest, IntegratedGyroWithoutNoiseReproducesTheTrueOrientation) {
  test::TempDir dir;
  auto world = generatedWorld(dir, "rough", 4);  // pitch and roll change all the time
  GyroConfig cfg;
  cfg.noise_sigma = 0;
  const GyroModel gyro(cfg, 1);
  const Trajectory trajectory(*world, world->truth().path, RobotConfig{});
  Eigen::Matrix3d r = trajectory.worldFromVehicle(0).linear();
  const Eigen::Matrix3d r0 = r;
  double worst = 0, turned = 0;
  const double dt = gyro.period();
  for (int k = 1; k <= 800; ++k) {  // 4 s
    const GyroSample g = gyro.sample(k, k * dt, trajectory.worldFromVehicle((k - 1) * dt).linear(),
                                     trajectory.worldFromVehicle(k * dt).linear());
    if (g.rate.norm() > 0) r = r * Eigen::AngleAxisd(g.rate.norm() * dt, g.rate.normalized()).toRotationMatrix();
    const Eigen::Matrix3d truth = trajectory.worldFromVehicle(g.time).linear();
    worst = std::max(worst, Eigen::AngleAxisd(truth.transpose() * r).angle());
    turned = std::max(turned, Eigen::AngleAxisd(r0.transpose() * truth).angle());
  }
  EXPECT_GT(turned, 0.01) << "the robot must actually rotate for this test to mean anything";
  EXPECT_LT(worst, 1e-9);
}

TEST(SimulatedRigTest, GyroSamplesCoverEachFrameAtTheirRate) {
  auto world = test::wallWorld(30.0);
  SimConfig cfg = smallCamera();
  cfg.camera.enabled = false;
  SimulatedRig rig(world, cfg, 3);
  std::vector<double> times;
  while (auto f = rig.next()) {
    for (const auto& g : f->sensors.gyro) {
      EXPECT_GE(g.time, f->sensors.sweep.start_time);
      EXPECT_LT(g.time, f->sensors.sweep.end_time);
      times.push_back(g.time);
    }
  }
  ASSERT_EQ(times.size(), 59u);  // 200 Hz over 0.3 s, the sample at t = 0 has no interval
  for (std::size_t i = 1; i < times.size(); ++i) EXPECT_NEAR(times[i] - times[i - 1], 0.005, 1e-12);
}

// reads every file of a directory tree into a map path -> bytes
std::map<std::string, std::string> readTree(const fs::path& root) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.is_regular_file()) out[fs::relative(e.path(), root).string()] = io::readFile(e.path());
  }
  return out;
}

void recordTo(const std::shared_ptr<World>& world, const SimConfig& cfg, int frames, const fs::path& out) {
  SimulatedRig rig(world, cfg, frames);
  rig::DatasetWriter writer(out, rig.calibration(), rig.lasers(), "{}", false);
  while (auto f = rig.next()) writer.write(*f);
  writer.finish();
}

TEST(SimulatedRigTest, SameSeedGivesByteIdenticalDatasetsWhateverTheThreadCount) {
  test::TempDir dir;
  auto world = generatedWorld(dir, "urban", 5);
  SimConfig one = smallCamera();
  one.threads = 1;
  SimConfig two = one;
  two.threads = 2;
  recordTo(world, one, 2, dir / "a");
  recordTo(world, two, 2, dir / "b");
  const auto a = readTree(dir / "a"), b = readTree(dir / "b");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GE(a.size(), 14u);
  for (const auto& [name, bytes] : a) {
    ASSERT_TRUE(b.count(name)) << name;
    EXPECT_TRUE(bytes == b.at(name)) << name << " differs";
  }
  // and another seed gives other data
  SimConfig other = one;
  other.seed = 2;
  recordTo(world, other, 1, dir / "c");
  EXPECT_NE(readTree(dir / "c").at("lidar/000000.pcd"), a.at("lidar/000000.pcd"));
}

TEST(SimulatedRigTest, RecordedDatasetReadsBackFrameForFrameIdentical) {
  test::TempDir dir;
  auto world = generatedWorld(dir, "urban", 6);
  const SimConfig cfg = smallSurround();
  recordTo(world, cfg, 3, dir / "ds");
  SimulatedRig rig(world, cfg, 3);
  rig::DatasetSource source(dir / "ds");
  EXPECT_EQ(source.frameCount(), 3);
  ASSERT_EQ(source.calibration().cameras.size(), rig.calibration().cameras.size());
  for (std::size_t c = 0; c < rig.calibration().cameras.size(); ++c) {
    EXPECT_EQ(source.calibration().cameras[c].name, rig.calibration().cameras[c].name);
    EXPECT_TRUE(source.calibration().cameras[c].vehicle_from_camera.isApprox(
        rig.calibration().cameras[c].vehicle_from_camera, 0));
    EXPECT_EQ(source.calibration().cameras[c].intrinsics.fx, rig.calibration().cameras[c].intrinsics.fx);
  }
  EXPECT_EQ(source.lasers().laserCount(), 64);
  for (int k = 0; k < 3; ++k) {
    const auto live = rig.next();
    const auto read = source.next();
    ASSERT_TRUE(live && read);
    const SensorFrame &a = live->sensors, &b = read->sensors;
    EXPECT_EQ(a.index, b.index);
    EXPECT_EQ(a.sweep.start_time, b.sweep.start_time);
    ASSERT_EQ(a.sweep.points.size(), b.sweep.points.size());
    for (std::size_t i = 0; i < a.sweep.points.size(); ++i) {
      const auto &p = a.sweep.points[i], &q = b.sweep.points[i];
      ASSERT_TRUE(p.x == q.x && p.y == q.y && p.z == q.z && p.intensity == q.intensity && p.ring == q.ring &&
                  p.azimuth == q.azimuth && p.time == q.time)
          << "frame " << k << " point " << i;
      ASSERT_EQ(live->truth->points[i].geom, read->truth->points[i].geom);
      ASSERT_EQ(live->truth->points[i].cls, read->truth->points[i].cls);
    }
    ASSERT_EQ(a.gps.size(), b.gps.size());
    for (std::size_t i = 0; i < a.gps.size(); ++i) {
      EXPECT_EQ(a.gps[i].latitude_deg, b.gps[i].latitude_deg);
      EXPECT_EQ(a.gps[i].longitude_deg, b.gps[i].longitude_deg);
      EXPECT_EQ(a.gps[i].altitude_m, b.gps[i].altitude_m);
    }
    ASSERT_EQ(a.gyro.size(), b.gyro.size());
    for (std::size_t i = 0; i < a.gyro.size(); ++i) EXPECT_EQ(a.gyro[i].rate, b.gyro[i].rate);
    ASSERT_EQ(b.images.size(), a.images.size());
    ASSERT_EQ(read->truth->cameras.size(), live->truth->cameras.size());
    for (std::size_t c = 0; c < a.images.size(); ++c) {
      EXPECT_EQ(b.images[c].camera, a.images[c].camera);
      EXPECT_EQ(b.images[c].time, a.images[c].time);
      EXPECT_EQ(cv::norm(a.images[c].rgb, b.images[c].rgb, cv::NORM_INF), 0.0);
      EXPECT_EQ(cv::norm(live->truth->cameras[c].depth, read->truth->cameras[c].depth, cv::NORM_INF), 0.0);
      EXPECT_EQ(cv::norm(live->truth->cameras[c].segmentation, read->truth->cameras[c].segmentation, cv::NORM_INF),
                0.0);
    }
    ASSERT_EQ(live->truth->poses.size(), read->truth->poses.size());
    for (std::size_t i = 0; i < live->truth->poses.size(); ++i) {
      EXPECT_TRUE(live->truth->poses[i].world_from_vehicle.isApprox(read->truth->poses[i].world_from_vehicle, 1e-12));
    }
  }
  EXPECT_FALSE(source.next().has_value());
}

TEST(SimulatedRigTest, CameraFrameShowsTheTopsTheLidarMisses) {
  test::TempDir dir;
  auto world = generatedWorld(dir, "urban", 1);
  SimulatedRig rig(world, smallCamera(), 1);
  const auto f = rig.next();
  // lidar: nothing above the cap; camera: building pixels well above the sensor
  double highest_lidar = -1e9;
  const Pose vehicle = rig.trajectory().worldFromVehicle(0) * rig.calibration().vehicle_from_lidar;
  for (const auto& p : f->sensors.sweep.points) highest_lidar = std::max(highest_lidar, static_cast<double>(p.z));
  EXPECT_LE(highest_lidar, 1.5);
  const CameraIntrinsics& k = rig.calibration().cameras.at(0).intrinsics;
  const Pose world_from_camera =
      rig.trajectory().worldFromVehicle(0) * rig.calibration().cameras.at(0).vehicle_from_camera;
  double highest_seen = -1e9;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const int geom = f->truth->cameras.at(0).segmentation.at<std::uint16_t>(v, u) - 1;
      if (world->geomClass(geom) != scenes::GeomClass::Building) continue;
      const double z = f->truth->cameras.at(0).depth.at<float>(v, u);
      const Vector3 c((u + 0.5 - k.cx) / k.fx * z, (v + 0.5 - k.cy) / k.fy * z, z);
      highest_seen = std::max(highest_seen, (world_from_camera * c).z() - vehicle.translation().z());
    }
  }
  EXPECT_GT(highest_seen, 5.0);
}

// A crown looks like leaves from every side: green all round (the foliage cue of crown completion
// reads it), not grey on the face a cube texture paints with its second colour. Views from the
// forest's centre in the four directions.
TEST(SimulatedRigTest, CrownsLookLikeFoliageFromEverySide) {
  test::TempDir dir;
  auto world = generatedWorld(dir, "forest", 1);
  CameraRenderer camera(*world, smallMount());
  long crown = 0, foliage = 0;
  for (int i = 0; i < 4; ++i) {
    const double a = i * M_PI / 2;
    Pose world_from_camera = Pose::Identity();
    world_from_camera.linear().col(0) = Vector3(std::sin(a), -std::cos(a), 0);  // right
    world_from_camera.linear().col(1) = Vector3(0, 0, -1);                      // down
    world_from_camera.linear().col(2) = Vector3(std::cos(a), std::sin(a), 0);   // forward
    world_from_camera.translation() = Vector3(0, 0, 3);
    const CameraRender r = camera.render(world_from_camera);
    long seen = 0;
    for (int v = 0; v < r.rgb.rows; ++v) {
      for (int u = 0; u < r.rgb.cols; ++u) {
        const int geom = r.segmentation.at<std::uint16_t>(v, u) - 1;
        if (world->geomClass(geom) != scenes::GeomClass::Crown) continue;
        ++seen;
        foliage += looksLikeFoliage(r.rgb.at<cv::Vec3b>(v, u), 10);
      }
    }
    EXPECT_GT(seen, 500) << "heading " << i * 90 << " deg";
    crown += seen;
  }
  // with the grey face 3 % were not (27,730 of 28,602); without it none
  EXPECT_GT(static_cast<double>(foliage) / crown, 0.995) << foliage << " of " << crown << " crown pixels";
}

// The renderer draws the terrain once per frame (left out of the segmentation pass, which takes
// the terrain's pixels from the first pass's depth) and the skybox in a pass of its own. Views
// along the drive, turning all round, give the images of the straightforward passes: the RGB and
// segmentation alike pixel for pixel, the depth alike wherever something was drawn, and 0 for sky.
TEST(SimulatedRigTest, TerrainDrawnOnceGivesTheImagesOfFullPasses) {
  test::TempDir dir;
  auto world = generatedWorld(dir, "urban", 1);
  CameraRenderer fast(*world, smallMount()), full(*world, smallMount());
  full.setSegmentationPassWithTerrain(true);
  const auto& path = world->truth().path;
  long terrain = 0, sky = 0, objects = 0;
  for (std::size_t i = 0; i < path.size(); ++i) {
    for (int turn = 0; turn < 4; ++turn) {
      const double a = turn * M_PI / 2 + 0.3 * i;
      Pose world_from_camera = Pose::Identity();
      world_from_camera.linear().col(0) = Vector3(std::sin(a), -std::cos(a), 0);
      world_from_camera.linear().col(1) = Vector3(0, 0, -1);
      world_from_camera.linear().col(2) = Vector3(std::cos(a), std::sin(a), 0);
      world_from_camera.translation() =
          Vector3(path[i].x(), path[i].y(), world->terrainHeight(path[i].x(), path[i].y()) + 1.6);
      const CameraRender a1 = fast.render(world_from_camera), a2 = full.render(world_from_camera);
      long rgb = 0, seg = 0, depth = 0;
      for (int v = 0; v < a1.rgb.rows; ++v) {
        for (int u = 0; u < a1.rgb.cols; ++u) {
          const int id = a2.segmentation.at<std::uint16_t>(v, u);
          rgb += a1.rgb.at<cv::Vec3b>(v, u) != a2.rgb.at<cv::Vec3b>(v, u);
          seg += a1.segmentation.at<std::uint16_t>(v, u) != id;
          const float d = a1.depth.at<float>(v, u);
          depth += id == 0 ? d != 0.0f : d != a2.depth.at<float>(v, u);
          if (id == 0) {
            ++sky;
          } else if (world->geomClass(id - 1) == scenes::GeomClass::Ground) {
            ++terrain;
          } else {
            ++objects;
          }
        }
      }
      EXPECT_EQ(rgb, 0) << "view " << i << "/" << turn << ": RGB pixels that differ";
      EXPECT_EQ(seg, 0) << "view " << i << "/" << turn << ": segmentation pixels that differ";
      EXPECT_EQ(depth, 0) << "view " << i << "/" << turn << ": depth pixels that differ";
    }
  }
  // the views hold all three kinds of pixel
  EXPECT_GT(terrain, 10000);
  EXPECT_GT(sky, 10000);
  EXPECT_GT(objects, 1000);
}

TEST(SimulatedRigTest, RefusesOutOfRangeSettingsWithTheAllowedRange) {
  auto world = test::wallWorld(10.0);
  auto expectRefused = [&](SimConfig c, const std::string& field) {
    try {
      SimulatedRig rig(world, c, 1);
      ADD_FAILURE() << field << " was accepted";
    } catch (const io::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("allowed"), std::string::npos) << e.what();
    }
  };
  SimConfig c;
  c.camera.fovy_deg = 180;
  expectRefused(c, "camera.fovy_deg");
  c = SimConfig{};
  c.lidar.max_range = -5;
  expectRefused(c, "lidar.max_range");
  c = SimConfig{};
  c.lidar.rotation_hz = 20;
  expectRefused(c, "lidar.rotation_hz");
  c = SimConfig{};
  c.camera.fovy_deg = 0;
  expectRefused(c, "camera.fovy_deg");
}

}  // namespace
}  // namespace terrain::sim
