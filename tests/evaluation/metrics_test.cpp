#include "evaluation/metrics.hpp"
#include "core/camera_model.hpp"
#include "evaluation/ground_truth.hpp"
#include "evaluation/report.hpp"
#include "evaluation/scoring.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

namespace terrain::eval {
namespace {

TEST(MetricsTest, BinaryScoresOfASmallConfusionMatrix) {
  // tp 6, fp 2, fn 3, tn 9
  const BinaryScores s = binaryScores(6, 2, 3, 9);
  EXPECT_DOUBLE_EQ(s.precision, 6.0 / 8.0);
  EXPECT_DOUBLE_EQ(s.recall, 6.0 / 9.0);
  EXPECT_DOUBLE_EQ(s.f1, 12.0 / 17.0);
  EXPECT_DOUBLE_EQ(s.iou, 6.0 / 11.0);
  const std::vector<bool> pred{1, 1, 0, 0, 1}, truth{1, 0, 1, 0, 1}, skip{0, 0, 0, 0, 1};
  const BinaryScores t = binaryScores(pred, truth, skip);
  EXPECT_EQ(t.tp, 1u);
  EXPECT_EQ(t.fp, 1u);
  EXPECT_EQ(t.fn, 1u);
  EXPECT_EQ(t.tn, 1u);
  EXPECT_DOUBLE_EQ(binaryScores(0, 0, 0, 5).f1, 0.0);
}

// A scene geom that the truth lists under no object: named by the world, and points on it are
// neither true ground nor true object (a sidecar with "objects": [] once made a building's voxels
// true ground)
TEST(MetricsTest, GeomsOfNoObjectAreNamedAndScoredAsNeitherClass) {
  scenes::SceneTruth truth = test::wallTruth(10);
  EXPECT_TRUE(sim::World(test::wallScene(10), truth).unclassifiedGeoms().empty());
  truth.objects.clear();
  const sim::World world(test::wallScene(10), truth);
  EXPECT_EQ(world.unclassifiedGeoms(), std::vector<std::string>{"wall"});

  // three points in voxel (50, 0, 5) of 0.2 m: on the unclassified wall only; two in (0, 0, 0),
  // one on the ground and one on the wall; one in (1, 0, 0) on a building
  rig::RigFrame frame;
  frame.truth.emplace();
  frame.truth->poses = {{0.0, Pose::Identity()}, {1.0, Pose::Identity()}};
  const auto add = [&](float x, float y, float z, std::uint8_t cls) {
    LidarPoint p;
    p.x = x, p.y = y, p.z = z, p.time = 0.5;
    frame.sensors.sweep.points.push_back(p);
    frame.truth->points.push_back({});
    frame.truth->points.back().cls = cls;
  };
  const auto none = static_cast<std::uint8_t>(scenes::GeomClass::None);
  const auto ground = static_cast<std::uint8_t>(scenes::GeomClass::Ground);
  const auto building = static_cast<std::uint8_t>(scenes::GeomClass::Building);
  for (int i = 0; i < 3; ++i) add(10.05f, 0.05f, 1.05f, none);
  add(0.05f, 0.05f, 0.05f, ground);
  add(0.06f, 0.05f, 0.05f, none);
  add(0.25f, 0.05f, 0.05f, building);
  VoxelTruth voxels(0.2);
  voxels.add(frame, Pose::Identity());
  EXPECT_EQ(voxels.label(VoxelIndex(50, 0, 5)), TruthLabel::Unknown);
  EXPECT_EQ(voxels.label(VoxelIndex(0, 0, 0)), TruthLabel::Ground);
  EXPECT_EQ(voxels.label(VoxelIndex(1, 0, 0)), TruthLabel::NonGround);
  EXPECT_EQ(voxels.label(VoxelIndex(2, 0, 0)), TruthLabel::Unknown);
}

TEST(MetricsTest, ErrorStatsOfAKnownSet) {
  // errors 1, -1, 3, 5: mean 2, |e| mean 2.5, e^2 mean 9, variance 9 - 4 = 5
  const ErrorStats e = errorStats({1, -1, 3, 5});
  EXPECT_DOUBLE_EQ(e.bias, 2.0);
  EXPECT_DOUBLE_EQ(e.mae, 2.5);
  EXPECT_DOUBLE_EQ(e.rmse, 3.0);
  EXPECT_DOUBLE_EQ(e.variance, 5.0);
  EXPECT_EQ(errorStats({}).count, 0u);
}

TEST(MetricsTest, Percentiles) {
  std::vector<double> v;
  for (int i = 1; i <= 100; ++i) v.push_back(i);
  const Percentiles p = percentiles(v);
  EXPECT_DOUBLE_EQ(p.median, 50);
  EXPECT_DOUBLE_EQ(p.p95, 95);
}

// A vehicle at (10, 20, 1) heading 179 deg (just short of west), level, against estimates off by
// one thing each: the heading difference wraps (-179 deg is 2 deg away, not 358), a nose-up tilt is
// pitch and a lean to the side is roll, and a shifted position splits into across and up.
TEST(MetricsTest, PoseErrorSplitsPositionAndAttitude) {
  constexpr double kDeg = M_PI / 180;
  const auto pose = [](double yaw, double pitch_up, double roll, const Vector3& at) {
    Pose p = Pose::Identity();
    p.linear() = (Eigen::AngleAxisd(yaw, Vector3::UnitZ()) * Eigen::AngleAxisd(-pitch_up, Vector3::UnitY()) *
                  Eigen::AngleAxisd(roll, Vector3::UnitX()))
                     .toRotationMatrix();
    p.translation() = at;
    return p;
  };
  const Vector3 at(10, 20, 1);
  const Pose truth = pose(179 * kDeg, 0, 0, at);
  const PoseError same = poseError(truth, truth);
  EXPECT_EQ(same.horizontal + same.vertical + same.heading + same.pitch + same.roll, 0.0);
  const PoseError turned = poseError(pose(-179 * kDeg, 0, 0, at + Vector3(3, -4, -1)), truth);
  EXPECT_NEAR(turned.horizontal, 5, 1e-12);
  EXPECT_NEAR(turned.vertical, 1, 1e-12);
  EXPECT_NEAR(turned.heading, 2 * kDeg, 1e-12);
  EXPECT_NEAR(turned.pitch, 0, 1e-12);
  EXPECT_NEAR(turned.roll, 0, 1e-12);
  const PoseError tilted = poseError(pose(179 * kDeg, 2 * kDeg, 0, at), truth);
  EXPECT_NEAR(tilted.pitch, 2 * kDeg, 1e-12);
  EXPECT_NEAR(tilted.heading, 0, 1e-12);
  EXPECT_NEAR(tilted.roll, 0, 1e-12);
  const PoseError leaning = poseError(pose(179 * kDeg, 0, 3 * kDeg, at), truth);
  EXPECT_NEAR(leaning.roll, 3 * kDeg, 1e-12);
  EXPECT_NEAR(leaning.heading, 0, 1e-12);
  EXPECT_NEAR(leaning.pitch, 0, 1e-12);
}

}  // namespace
}  // namespace terrain::eval

namespace terrain::eval {
namespace {

TEST(RunTruthTest, CameraFramesThinOutOverALongRun) {
  // 1000 frames with an image each: every tenth kept until 64 are held, then every twentieth, ...
  RunTruth truth(0.2);
  for (int i = 0; i < 1000; ++i) {
    rig::RigFrame f;
    f.sensors.index = i;
    f.sensors.images.push_back(CameraImage{0, 0.1 * i, cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3))});
    f.truth = rig::FrameTruth{};
    f.truth->cameras.push_back({0, cv::Mat(), cv::Mat(4, 4, CV_16UC1, cv::Scalar(1))});
    f.truth->poses.push_back({0.1 * i, Pose::Identity()});
    RigCalibration calibration;
    calibration.cameras.push_back({"front", CameraIntrinsics{}, Pose::Identity()});
    addFrameTruth(truth, f, calibration, 10);
    ASSERT_LE(truth.cameras.size(), kMaxCameraFrames) << "frame " << i;
  }
  // strides 10 -> 20 (at frame 640) -> 40 (at frame 1280: not reached)
  EXPECT_EQ(truth.camera_stride, 20);
  ASSERT_EQ(truth.cameras.size(), 50u);  // 0, 20, ..., 980
  for (std::size_t k = 0; k < truth.cameras.size(); ++k) EXPECT_EQ(truth.cameras[k].frame, static_cast<int>(20 * k));
  EXPECT_EQ(truth.path.size(), 1000u);
}

// the test wall is a building 1 m thick, x in [12, 13], y in [-40, 40], 20 m high
Footprint rectangle(double x0, double x1, double y0, double y1) {
  Footprint f;
  f.corners = {Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y0), Eigen::Vector2d(x1, y1), Eigen::Vector2d(x0, y1)};
  return f;
}

TEST(FootprintMatchTest, FindsTheBuildingUnderAFootprintAndTheirOverlap) {
  const auto world = test::wallWorld(12.0);
  // 4 m of the wall: 20 x 5 grid points of its 400 x 5
  const FootprintMatch on = matchFootprint(rectangle(12, 13, -2, 2), *world, 0.2);
  EXPECT_EQ(on.object, "wall");
  EXPECT_DOUBLE_EQ(on.true_top, 20.0);
  EXPECT_NEAR(on.iou, 100.0 / 2000.0, 1e-12);
  // half on the wall (3 of 5 columns of points), half on the ground beside it
  const FootprintMatch half = matchFootprint(rectangle(12.4, 13.4, -2, 2), *world, 0.2);
  EXPECT_EQ(half.object, "wall");
  EXPECT_NEAR(half.iou, 60.0 / 2040.0, 1e-12);
  // on open ground: no building
  EXPECT_TRUE(matchFootprint(rectangle(20, 22, -2, 2), *world, 0.2).object.empty());
}

// 20 cells on the wall of test::wallWorld(12) (x = 12.5 m, y = 0.1 to 3.9 m), sensed 3 m up, all
// but the first raised to 19.6 m.
void addWallCells(std::vector<Voxel>& voxels, std::vector<MeshVertex>& vertices) {
  for (int j = 0; j < 20; ++j) {
    test::addColumn(voxels, vertices, CellIndex(62, j), 15, 3.0f, VoxelLabel::NonGround);
    if (j > 0) vertices.back().estimates = {{19.6f, 12.0f, 1.6f}}, vertices.back().recovered_height = 19.6f;
  }
}

// The wall of test::wallWorld at x = 12 (20 m high): of 20 of its cells in the mesh, sensed 3 m up,
// 19 were raised to 19.6 m; their 95th percentile is the wall's recovered top, within 10 % of its
// height (2 m) of the truth. Roof cells join the recovered top: 5 at 30 m lift it to 30 m.
TEST(ObjectTopTest, AnObjectsTopIsThe95thPercentileOfItsCellsHeights) {
  const auto world = test::wallWorld(12.0);
  std::vector<Voxel> voxels;
  std::vector<MeshVertex> vertices;
  addWallCells(voxels, vertices);
  VoxelMap map(VoxelMapConfig{0.2});
  ASSERT_TRUE(map.restore(voxels));
  TerrainMesh mesh;
  ASSERT_TRUE(mesh.restore(vertices));
  const HeightScores h = scoreHeights(mesh, map, *world, {Point3(0, 0, 0)});
  ASSERT_EQ(h.tops.count("wall"), 1u);
  const ObjectTop& t = h.tops.at("wall");
  EXPECT_TRUE(t.building);
  EXPECT_EQ(t.cells, 20u);
  EXPECT_DOUBLE_EQ(t.top, 20.0);
  EXPECT_DOUBLE_EQ(t.sensed, 3.0);
  EXPECT_NEAR(t.recovered, 19.6, 1e-6);
  EXPECT_DOUBLE_EQ(topTolerance(t), 2.0);
  std::vector<RoofCell> roof;
  for (int j = 20; j < 25; ++j) roof.push_back({CellIndex(62, j), 30.0f});
  const ObjectTop& with_roof = scoreHeights(mesh, map, *world, {Point3(0, 0, 0)}, roof).tops.at("wall");
  EXPECT_EQ(with_roof.cells, 25u);
  EXPECT_NEAR(with_roof.recovered, 30.0, 1e-6);
  EXPECT_DOUBLE_EQ(with_roof.sensed, 3.0);
}

// The wall's 20 cells of the test above, sensed 3 m up and all but the first raised to 19.6 m. The
// height map's baselines score every second cell (10, all over the wall): sensed only and inpainted
// 17 m too low each (nothing to inpaint), recovered 0.4 m too low but the first (17 m): MAE
// (17 + 9 x 0.4) / 10 = 2.06 m. A mesh wider than kMaxHeightMapCells cells is not scored.
TEST(HeightBaselineTest, TheHeightMapsBaselinesScoreEverySecondObjectCell) {
  const auto world = test::wallWorld(12.0);
  std::vector<Voxel> voxels;
  std::vector<MeshVertex> vertices;
  addWallCells(voxels, vertices);
  TerrainMesh mesh;
  ASSERT_TRUE(mesh.restore(vertices));
  const HeightBaselineScores b = scoreHeightBaselines(mesh, {}, 0.2, *world);
  ASSERT_EQ(b.status, HeightBaselineScores::Status::Scored);
  EXPECT_EQ(b.span, 20);
  EXPECT_EQ(b.object_cells, 10u);
  for (const HeightMapError* e : {&b.sensed_only, &b.inpainting}) {
    EXPECT_EQ(e->error.count, 10u);
    EXPECT_NEAR(e->error.mae, 17.0, 1e-5);
    EXPECT_DOUBLE_EQ(e->coverage, 1.0);
  }
  EXPECT_NEAR(b.recovered.error.mae, 2.06, 1e-5);
  EXPECT_NEAR(b.recovered.error.bias, -2.06, 1e-5);
  // an empty mesh, and one 4,101 cells across
  EXPECT_EQ(scoreHeightBaselines(TerrainMesh{}, {}, 0.2, *world).status, HeightBaselineScores::Status::NoMesh);
  test::addColumn(voxels, vertices, CellIndex(62 + 4100, 0), 15, 3.0f, VoxelLabel::NonGround);
  TerrainMesh wide;
  ASSERT_TRUE(wide.restore(vertices));
  const HeightBaselineScores too_wide = scoreHeightBaselines(wide, {}, 0.2, *world);
  EXPECT_EQ(too_wide.status, HeightBaselineScores::Status::TooWide);
  EXPECT_EQ(too_wide.span, 4101);
}

// The wall's top as the test above has it (sensed 3 m, recovered 19.6 m, true 20 m, tolerance 2 m):
// seen with its lower part it stands at its height after recovery and not before; with 5 roof cells
// at 30 m it stands 10 m too high. An object no frame saw is not scored.
TEST(ObjectTopTest, TopsAreCountedAtTheirHeightAndTooHighPerClass) {
  const auto world = test::wallWorld(12.0);
  ObjectTop wall;
  wall.building = true, wall.top = 20, wall.sensed = 3, wall.recovered = 19.6, wall.cells = 20;
  HeightScores h;
  h.tops["wall"] = wall;
  const TopScores at = scoreObjectTops(h, {{"wall", {2, 1}}}, {}, *world);
  ASSERT_EQ(at.objects.count("wall"), 1u);
  const TopScore& o = at.objects.at("wall");
  EXPECT_DOUBLE_EQ(o.error_before, -17.0);
  EXPECT_NEAR(o.error_after, -0.4, 1e-12);
  EXPECT_DOUBLE_EQ(o.tolerance, 2.0);
  EXPECT_FALSE(o.crown);
  const ClassTops& b = at.by_class.at("building");
  EXPECT_EQ(b.all.seen, 1u);
  EXPECT_EQ(b.all.before, 0u);
  EXPECT_EQ(b.all.after, 1u);
  EXPECT_EQ(b.all.high_after, 0u);
  EXPECT_EQ(b.with_lower_part.after, 1u);
  EXPECT_NEAR(b.after.mae, 0.4, 1e-12);
  EXPECT_EQ(at.by_class.at("tree").all.seen, 0u);
  // too high
  h.tops["wall"].recovered = 30;
  const ClassTops& high = scoreObjectTops(h, {{"wall", {2, 0}}}, {}, *world).by_class.at("building");
  EXPECT_EQ(high.all.after, 0u);
  EXPECT_EQ(high.all.high_after, 1u);
  EXPECT_EQ(high.with_lower_part.seen, 0u);
  // not seen
  EXPECT_TRUE(scoreObjectTops(h, {}, {}, *world).objects.empty());
}

// The true segmentation of a camera's image: the geom each pixel's centre ray meets, + 1 (0: sky).
cv::Mat segmentationSeen(const sim::World& world, const CameraIntrinsics& k, const Pose& world_from_camera) {
  cv::Mat seg(k.height, k.width, CV_16UC1, cv::Scalar(0));
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Vector3 dir = world_from_camera.linear() * pixelRay(k, Pixel(u + 0.5, v + 0.5));
      seg.at<std::uint16_t>(v, u) =
          static_cast<std::uint16_t>(world.castRay(world_from_camera.translation(), dir).geom + 1);
    }
  }
  return seg;
}

// A camera 1.6 m up looking east at the 20 m wall: from 40 m its top edge is in the image (the
// pixels just below it look at the wall's top), from 8 m it is above the image (the topmost wall
// pixels look at it 1.6 + 8 tan 30 deg = 6.2 m up, far below its top). Level, the camera sees the
// wall's foot as well; tilted up 35 deg it sees 40 tan 5 deg + 1.6 = 5.1 m up and higher, the wall's
// top but not its lower part.
TEST(ObjectTopTest, ATopIsSeenWhenItsTopBoundaryPixelsLookAtItItsLowerPartWhenItsFootIsInView) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(160, 120, 60 * M_PI / 180);
  struct Case {
    double distance, pitch_deg;
    int top, with_lower_part;  // -1: the top not seen
  };
  for (const Case c : {Case{40, 0, 1, 1}, Case{8, 0, -1, -1}, Case{40, 35, 1, 0}}) {
    const auto world = test::wallWorld(c.distance);
    const double p = c.pitch_deg * M_PI / 180;
    CameraTruthFrame f;
    f.world_from_camera.linear().col(0) = Vector3(0, -1, 0);                      // right = south
    f.world_from_camera.linear().col(1) = Vector3(std::sin(p), 0, -std::cos(p));  // down
    f.world_from_camera.linear().col(2) = Vector3(std::cos(p), 0, std::sin(p));   // forward: east, tilted up
    f.world_from_camera.translation() = Vector3(0, 0, 1.6);
    f.segmentation = segmentationSeen(*world, k, f.world_from_camera);
    RigCalibration calibration;
    calibration.cameras.push_back({"front", k, Pose::Identity()});
    const auto seen = topSeenFrames(*world, calibration, {f});
    SCOPED_TRACE(testing::Message() << c.distance << " m, tilted " << c.pitch_deg << " deg");
    ASSERT_EQ(seen.count("wall"), c.top < 0 ? 0u : 1u);
    if (c.top < 0) continue;
    EXPECT_EQ(seen.at("wall").top, c.top);
    EXPECT_EQ(seen.at("wall").with_lower_part, c.with_lower_part);
  }
}

// A camera 1.6 m up looking east at a 20 m wall 40 m away, with a canopy nearer (x 20-21 m, y
// +-3 m, z 8-12 m) hiding the wall's top: in the 32 columns the canopy spans (|u + 0.5 - 80| <=
// 103.9 * 3 / 20), its top edge is against the sky and the wall's pixels right under its lower
// edge have it above them, nearer. Those 32 are the canopy's edge, not the wall's top: left out.
// Every column keeps one top-boundary pixel, the wall's against the sky or the canopy's.
TEST(BoundaryCoverageTest, AnEdgeUnderANearerSurfaceIsNotATopBoundary) {
  const std::string scene = R"(<mujoco>
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <geom name="ground" type="plane" size="60 60 1"/>
    <geom name="wall" type="box" pos="40.5 0 10" size="0.5 40 10" group="1"/>
    <geom name="canopy" type="box" pos="20.5 0 10" size="0.5 3 2" group="1"/>
  </worldbody>
</mujoco>)";
  scenes::SceneTruth truth = test::wallTruth(40);
  scenes::ObjectTruth canopy = truth.objects[0];
  canopy.id = "canopy", canopy.geoms = {"canopy"};
  canopy.footprint = {{20, -3}, {21, -3}, {21, 3}, {20, 3}};
  canopy.top_height = 12;
  truth.objects.push_back(canopy);
  const sim::World world(scene, truth);
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(160, 120, 60 * M_PI / 180);
  CameraTruthFrame f;
  f.world_from_camera.linear().col(0) = Vector3(0, -1, 0);  // right = south
  f.world_from_camera.linear().col(1) = Vector3(0, 0, -1);  // down
  f.world_from_camera.linear().col(2) = Vector3(1, 0, 0);   // forward = east
  f.world_from_camera.translation() = Vector3(0, 0, 1.6);
  f.segmentation = segmentationSeen(world, k, f.world_from_camera);
  const BoundaryCoverage c = boundaryCoverage(TerrainMesh{}, {}, 0.2, world, k, f, 3);
  EXPECT_EQ(c.boundary_pixels, 160u);
  EXPECT_EQ(c.occluded_pixels, 32u);
  EXPECT_EQ(c.after, 0.0);  // an empty mesh reproduces nothing
}

// The sensing period is the rig's, from the sweeps' start times (in any order, with a late frame
// among them), and frames are over it by their own total time.
TEST(MetricsTest, TheSensingPeriodComesFromTheSweepsStartTimes) {
  std::vector<FrameRecord> records;
  for (const double t : {0.4, 0.0, 0.2, 0.6, 1.4, 0.8}) {  // a 5 Hz lidar; one sweep missing before 1.4 s
    FrameRecord r;
    r.time = t;
    r.total_ms = t < 1.0 ? 150 : 250;
    records.push_back(r);
  }
  EXPECT_NEAR(sensingPeriodMs(records), 200.0, 1e-9);
  const nlohmann::json j = timingJson(records);
  EXPECT_NEAR(j["sensing_period_ms"].get<double>(), 200.0, 1e-9);
  EXPECT_EQ(j["frames_over_sensing_period"].get<std::size_t>(), 1u);
  records.resize(1);
  EXPECT_EQ(sensingPeriodMs(records), 0.0);  // one sweep: no period
  EXPECT_EQ(timingJson(records)["frames_over_sensing_period"].get<std::size_t>(), 0u);
}

}  // namespace
}  // namespace terrain::eval
