#include "core/boundary_estimation.hpp"
#include "core/boundary_detection.hpp"
#include "core/camera_model.hpp"
#include "tests/core/core_test_support.hpp"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain {
namespace {

// a level camera 1.6 m above the origin looking north (+y)
Pose northCamera() {
  Pose world_from_camera = Pose::Identity();
  world_from_camera.linear().col(0) = Vector3(1, 0, 0);   // x right = east
  world_from_camera.linear().col(1) = Vector3(0, 0, -1);  // y down
  world_from_camera.linear().col(2) = Vector3(0, 1, 0);   // z forward = north
  world_from_camera.translation() = Vector3(0, 0, 1.6);
  return world_from_camera;
}

// a boundary image with one full row of boundary pixels: the row in which `top` (world) appears;
// empty if the camera does not see it; px_out: where it appears
cv::Mat boundaryRowThrough(const CameraIntrinsics& k, const Pose& world_from_camera, const Point3& top,
                           Pixel* px_out = nullptr) {
  const auto px = project(k, world_from_camera.inverse() * top);
  if (!px) return cv::Mat();
  if (px_out) *px_out = *px;
  cv::Mat boundary(k.height, k.width, CV_8UC1, cv::Scalar(0));
  boundary.row(static_cast<int>(px->y())).setTo(255);
  return boundary;
}

TEST(BoundaryEstimationTest, InverseProjectionOfAKnownTopPixelGivesTheExactHeight) {
  // camera 1.6 m up looking north (+y), level; a wall top 12 m high at y = 20
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  const Pose world_from_camera = northCamera();
  const Point3 top(3.0, 20.0, 12.0);
  const auto px = project(k, world_from_camera.inverse() * top);
  ASSERT_TRUE(px.has_value());
  const Vector3 dir = world_from_camera.linear() * pixelRay(k, *px);
  EXPECT_NEAR(heightAbove(world_from_camera.translation(), dir, 3.0, 20.0), 12.0, 1e-9);
  // and the stage raises a non-ground vertex at (3, 20) from the boundary image
  VoxelMap map(VoxelMapConfig{0.2});
  map.insert({Point3(3.05, 20.05, 1.05)}, 0);
  map.voxels()[0].label = VoxelLabel::NonGround;
  TerrainMesh mesh;
  mesh.update(map, map.takeNewVoxels());
  const cv::Mat boundary = boundaryRowThrough(k, world_from_camera, Vector3(3.1, 20.1, 12.0));
  const auto stats = estimateBoundaries(mesh, map, boundary, k, world_from_camera, BoundaryEstimationConfig{});
  EXPECT_EQ(stats.estimated, 1);
  // the pixel centre lies within half a pixel of the projected top: about 2 cm at 20 m
  EXPECT_NEAR(mesh.vertices()[0].height(), 12.0, 0.05);
}

// with the sky test on, a top boundary with sky above gives an estimate and one with more of
// the object above (cut off by the image top) does not
TEST(BoundaryEstimationTest, SkyTestSkipsObjectsThatRunOffTheImage) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  const Pose world_from_camera = northCamera();
  VoxelMap map(VoxelMapConfig{0.2});
  map.insert({Point3(3.05, 20.05, 1.05)}, 0);
  map.voxels()[0].label = VoxelLabel::NonGround;
  const cv::Mat boundary = boundaryRowThrough(k, world_from_camera, Vector3(3.1, 20.1, 12.0));
  BoundaryEstimationConfig cfg;
  cfg.require_sky_above = true;
  for (const bool sky : {true, false}) {
    TerrainMesh mesh;
    mesh.update(map, {0});
    // above the edge: sky blue, or a beige facade
    const cv::Mat rgb(480, 640, CV_8UC3, sky ? cv::Scalar(120, 160, 230) : cv::Scalar(200, 190, 170));
    const auto stats = estimateBoundaries(mesh, map, boundary, k, world_from_camera, cfg, rgb);
    EXPECT_EQ(stats.estimated, sky ? 1 : 0);
    EXPECT_EQ(stats.no_sky, sky ? 0 : 1);
    // the vertex keeps the frame's outcome
    const auto& outcomes = mesh.vertices()[0].outcomes;
    EXPECT_EQ(outcomes[static_cast<std::size_t>(EstimateOutcome::Estimated)], sky ? 1 : 0);
    EXPECT_EQ(outcomes[static_cast<std::size_t>(EstimateOutcome::NoSky)], sky ? 0 : 1);
    int total = 0;
    for (std::uint16_t n : outcomes) total += n;
    EXPECT_EQ(total, 1);
  }
  // an empty boundary image: no top boundary on the vertex's vertical, frame after frame
  TerrainMesh mesh;
  mesh.update(map, {0});
  const cv::Mat none = cv::Mat::zeros(480, 640, CV_8UC1);
  for (int frame = 0; frame < 3; ++frame)
    estimateBoundaries(mesh, map, none, k, world_from_camera, BoundaryEstimationConfig{});
  EXPECT_EQ(mesh.vertices()[0].outcomes[static_cast<std::size_t>(EstimateOutcome::NoTopBoundary)], 3);
  EXPECT_STREQ(outcomeName(EstimateOutcome::NoTopBoundary), "no_top_boundary");
  MeshVertex full;
  full.outcomes[0] = 0xffff;
  full.count(EstimateOutcome::Estimated);
  EXPECT_EQ(full.outcomes[0], 0xffff);  // saturates
}

// A wall top 12 m high at (3, 20) seen from the origin looking north, and a second object B on the
// same line of sight, twice as far: the top boundary could be B's unless B is known to be lower
// than the ray where the ray passes over it.
TEST(BoundaryEstimationTest, ClearLineSkipsATopThatAnotherObjectMayOwn) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  const Pose world_from_camera = northCamera();
  const cv::Mat boundary = boundaryRowThrough(k, world_from_camera, Vector3(3.1, 20.1, 12.0));
  ASSERT_FALSE(boundary.empty());
  // where the top pixel's ray passes B (40 m away) it is 1.6 + 2 * 10.4 = 22.4 m up
  struct Case {
    bool clear_line;
    float b_top;  // B's recovered top; 0: B has no estimate (unknown top)
    int estimated;
  };
  for (const Case c : {Case{true, 0, 0}, Case{false, 0, 1}, Case{true, 15, 1}, Case{true, 30, 0}}) {
    VoxelMap map(VoxelMapConfig{0.2});
    map.insert({Point3(3.05, 20.05, 1.05), Point3(6.25, 40.25, 1.05)}, 0);
    for (auto& v : map.voxels()) v.label = VoxelLabel::NonGround;
    TerrainMesh mesh;
    mesh.update(map, map.takeNewVoxels());
    ASSERT_EQ(mesh.vertices().size(), 2u);
    const std::uint32_t a = mesh.vertices()[0].cell.y() < 150 ? 0 : 1, b = 1 - a;
    if (c.b_top > 0) mesh.addEstimate(b, {c.b_top, 40.0f, 1.6f}, 15);
    BoundaryEstimationConfig cfg;
    cfg.clear_line = c.clear_line;
    estimateBoundaries(mesh, map, boundary, k, world_from_camera, cfg);
    EXPECT_EQ(static_cast<int>(mesh.vertices()[a].estimates.size()), c.estimated)
        << "clear_line " << c.clear_line << ", B's top " << c.b_top;
    EXPECT_EQ(mesh.vertices()[a].outcomes[static_cast<std::size_t>(EstimateOutcome::NotClear)], 1 - c.estimated)
        << "clear_line " << c.clear_line << ", B's top " << c.b_top;
  }
}

// a camera 1.6 m above the origin looking north, pitched up by `pitch` [rad]
Pose pitchedNorthCamera(double pitch) {
  Pose world_from_camera = Pose::Identity();
  world_from_camera.linear().col(0) = Vector3(1, 0, 0);                               // x right = east
  world_from_camera.linear().col(1) = Vector3(0, std::sin(pitch), -std::cos(pitch));  // y down
  world_from_camera.linear().col(2) = Vector3(0, std::cos(pitch), std::sin(pitch));   // z forward
  world_from_camera.translation() = Vector3(0, 0, 1.6);
  return world_from_camera;
}

// The image of a vertical line is the line through the vertical's vanishing point: every point of
// the vertical through (5, 20) projects onto it, for a pitched and a level camera (where it is the
// column).
TEST(BoundaryEstimationTest, VerticalsAreLinesThroughTheVanishingPoint) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  for (const double pitch : {0.0, 15 * M_PI / 180, -10 * M_PI / 180}) {
    const Pose pose = pitchedNorthCamera(pitch);
    const Verticals verticals(k, pose);
    const auto px = [&](double z) { return *project(k, pose.inverse() * Point3(5, 20, z)); };
    const Pixel base = px(1.0);
    for (const double z : {0.0, 4.0, 8.0, 12.0}) {
      const Pixel p = px(z);
      EXPECT_NEAR(verticals.columnAt(base, p.y()), p.x(), 1e-9) << pitch << " " << z;
    }
    if (pitch == 0) {
      EXPECT_EQ(verticals.columnAt(base, 0.0), base.x());
      EXPECT_EQ(verticals.vanishingRow(), -std::numeric_limits<double>::infinity());
    } else {
      // 312.8 px / tan(pitch) above the image centre for a camera pitched up, below for one pitched down
      EXPECT_NEAR(verticals.vanishingRow(), k.cy - k.fy / std::tan(pitch), 1e-6);
    }
  }
}

// A wall from x = 4 to 6 m at y = 20, 12 m high, seen by a camera pitched up 15 degrees. Above its
// vertex at x = 5.9 the image column drifts right of the vertical (which leans towards the
// vanishing point above the image centre) and passes beyond the wall's end, where there is no top
// edge; along the vertical the stage finds the wall's top and gives its height.
TEST(BoundaryEstimationTest, TheTopIsSearchedAlongTheVerticalNotTheColumn) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  const Pose pose = pitchedNorthCamera(15 * M_PI / 180);
  const Pose camera_from_world = pose.inverse();
  // the wall's top edge, one pixel wide, with sky above it
  cv::Mat boundary(480, 640, CV_8UC1, cv::Scalar(0));
  for (double x = 4.0; x <= 6.0; x += 0.005) {
    const Pixel p = *project(k, camera_from_world * Point3(x, 20.0, 12.0));
    boundary.at<std::uint8_t>(static_cast<int>(p.y()), static_cast<int>(p.x())) = 255;
  }
  VoxelMap map(VoxelMapConfig{0.2});
  map.insert({Point3(5.9, 20.05, 1.05)}, 0);
  map.voxels()[0].label = VoxelLabel::NonGround;
  TerrainMesh mesh;
  mesh.update(map, map.takeNewVoxels());
  const Pixel vertex = *project(k, camera_from_world * Point3(5.9, 20.1, 1.1));
  const Pixel top = *project(k, camera_from_world * Point3(5.9, 20.1, 12.0));
  // the column above the vertex holds no edge pixel: it leaves the wall 0.7 m past its end
  ASSERT_GT(vertex.x() - top.x(), 10.0);
  EXPECT_EQ(cv::countNonZero(boundary.col(static_cast<int>(vertex.x()))), 0);
  BoundaryEstimationConfig cfg;
  cfg.clear_line = false;
  const auto stats = estimateBoundaries(mesh, map, boundary, k, pose, cfg);
  ASSERT_EQ(stats.estimated, 1);
  // within a pixel of the edge: about 6 cm at 20 m
  EXPECT_NEAR(mesh.vertices()[0].height(), 12.0, 0.1);
}

// A crown the lidar saw the underside of, at (3, 20), 3 m up and topped at 6 m, seen from the origin
// looking north against a grey building 40 m away whose roof, 20 m up, is the topmost boundary of
// its column, with sky above. The topmost boundary raises the crown to where its ray passes over
// it, 1.6 + 18.4 / 2 = 10.8 m; the end of the foliage above the vertex's pixel gives its own top,
// when the crown shows foliage and stands over the ground the lidar saw under it.
TEST(BoundaryEstimationTest, ACrownBeforeABuildingTakesTheTopOfItsFoliage) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  const Pose world_from_camera = northCamera();
  const Pose camera_from_world = world_from_camera.inverse();
  const auto row = [&](const Point3& p) { return static_cast<int>(project(k, camera_from_world * p)->y()); };
  const int crown_top = row(Point3(3.1, 20.1, 6.0)), roof = row(Point3(6.2, 40.2, 20.0));
  // sky over the roof, the grey facade below it, the crown's green from its top down to the ground
  cv::Mat rgb(480, 640, CV_8UC3, cv::Scalar(120, 160, 230));
  rgb.rowRange(roof, 480).setTo(cv::Scalar(150, 150, 150));
  rgb(cv::Range(crown_top, row(Point3(3.1, 20.1, 0.0))), cv::Range(300, 500)).setTo(cv::Scalar(40, 110, 35));
  cv::Mat boundary(480, 640, CV_8UC1, cv::Scalar(0));
  boundary.row(roof).setTo(255);
  boundary.row(crown_top).setTo(255);
  struct Case {
    bool foliage_tops, clear_line, leafy, ground_below, wide_building;
    double height;  // expected; 0: no estimate
  };
  for (const Case c :
       {Case{true, true, true, true, true, 6.0},
        // the paper's topmost boundary; with the clear-line test the building, whose top is unknown, may own it
        Case{false, false, true, true, true, 10.8}, Case{false, true, true, true, true, 0.0},
        // no foliage object, or none over ground the lidar saw
        Case{true, false, false, true, true, 10.8}, Case{true, false, true, false, true, 10.8},
        // an object as narrow as a trunk may carry a crown that owns the pixel
        Case{true, true, true, true, false, 0.0}}) {
    VoxelMap map(VoxelMapConfig{0.2});
    // the crown's underside over the ground the lidar saw beneath it
    std::vector<Point3> points{Point3(3.05, 20.05, 3.05)};
    if (c.ground_below) points.emplace_back(3.05, 20.05, 0.05);
    // the building's wall at the lidar's reach: 3 m wide, or one voxel (as narrow as a trunk)
    const int wall = c.wide_building ? 15 : 1;
    for (int i = 0; i < wall; ++i) points.emplace_back(6.05 + 0.2 * i, 40.05, 1.05);
    map.insert(points, 0);
    for (auto& v : map.voxels()) {
      const bool crown = v.index.y() == 100 && v.index.z() == 15;
      v.label = v.index.z() == 0 ? VoxelLabel::Ground : VoxelLabel::NonGround;
      v.coloured = true;
      if (crown && c.leafy)
        v.r = 40, v.g = 110, v.b = 35;
      else
        v.r = v.g = v.b = 150;
    }
    TerrainMesh mesh;
    mesh.update(map, map.takeNewVoxels());
    const std::int64_t crown = mesh.find(CellIndex(15, 100));
    ASSERT_GE(crown, 0);
    BoundaryEstimationConfig cfg;
    cfg.foliage_tops = c.foliage_tops;
    cfg.clear_line = c.clear_line;
    const auto stats = estimateBoundaries(mesh, map, boundary, k, world_from_camera, cfg, rgb);
    const MeshVertex& m = mesh.vertices()[crown];
    const std::string what = "foliage_tops " + std::to_string(c.foliage_tops) + ", clear_line " +
                             std::to_string(c.clear_line) + ", leafy " + std::to_string(c.leafy) + ", ground below " +
                             std::to_string(c.ground_below) + ", wide " + std::to_string(c.wide_building);
    if (c.height == 0) {
      EXPECT_TRUE(m.estimates.empty()) << what;
      EXPECT_GE(stats.not_clear, 1) << what;
      continue;
    }
    ASSERT_EQ(m.estimates.size(), 1u) << what;
    // a pixel is 6 cm high at 20 m
    EXPECT_NEAR(m.height(), c.height, 0.1) << what;
    EXPECT_EQ(stats.by_foliage, c.height == 6.0 ? 1 : 0) << what;
  }
}

// An object the lidar saw at (3, 20), 3 m up, that ends at 6 m, seen from the origin looking north
// against the sky: a crown with no ground seen under it (so its top is searched as the topmost
// boundary) or a grey facade. Above it in the image, foliage from 8 to 12 m up at its distance (a
// crown overhanging it, or standing behind it) is the topmost boundary of the column, with sky
// above. Where sky shows between the object and that foliage, the object ends below it: no
// estimate. Where the object runs on up to it, or the gap fails the sky test (a band of two
// sky-blue pixels in a facade), or the sky test is off, the estimate is 12 m.
TEST(BoundaryEstimationTest, AnObjectThatEndsInSkyBelowItsTopmostBoundaryIsNotRaisedToIt) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  const Pose world_from_camera = northCamera();
  const Pose camera_from_world = world_from_camera.inverse();
  const auto row = [&](double z) {
    return static_cast<int>(project(k, camera_from_world * Point3(3.1, 20.1, z))->y());
  };
  const cv::Scalar sky(120, 160, 230), leaves(40, 110, 35), bark(90, 60, 40), facade(150, 150, 150);
  cv::Mat boundary(480, 640, CV_8UC1, cv::Scalar(0));
  boundary.row(row(12.0)).setTo(255);
  boundary.row(row(6.0)).setTo(255);
  enum class Gap { Sky, None, Band };
  struct Case {
    bool crown, on_bark, sky_test;  // on_bark: the crown's vertex's pixel shows bark below it
    Gap gap;
    double height;  // expected; 0: no estimate
  };
  for (const Case c : {Case{true, false, true, Gap::Sky, 0.0}, Case{true, true, true, Gap::Sky, 0.0},
                       Case{false, false, true, Gap::Sky, 0.0}, Case{true, false, true, Gap::None, 12.0},
                       Case{true, true, true, Gap::None, 12.0}, Case{false, false, true, Gap::None, 12.0},
                       Case{false, false, true, Gap::Band, 12.0}, Case{true, false, false, Gap::Sky, 12.0},
                       Case{false, false, false, Gap::Sky, 12.0}}) {
    const cv::Scalar own = c.crown ? leaves : facade;
    cv::Mat rgb(480, 640, CV_8UC3, sky);
    const cv::Range columns(300, 500);
    rgb(cv::Range(row(12.0), row(8.0)), columns).setTo(leaves);
    rgb(cv::Range(row(c.gap == Gap::Sky ? 6.0 : 8.0), 480), columns).setTo(own);
    if (c.gap == Gap::Band) rgb(cv::Range(row(7.0), row(7.0) + 2), columns).setTo(sky);
    if (c.on_bark) rgb(cv::Range(row(3.6), 480), columns).setTo(bark);
    VoxelMap map(VoxelMapConfig{0.2});
    map.insert({Point3(3.05, 20.05, 3.05)}, 0);
    auto& voxel = map.voxels()[0];
    voxel.label = VoxelLabel::NonGround;
    voxel.coloured = true;
    voxel.r = static_cast<std::uint8_t>(own[0]), voxel.g = static_cast<std::uint8_t>(own[1]),
    voxel.b = static_cast<std::uint8_t>(own[2]);
    TerrainMesh mesh;
    mesh.update(map, map.takeNewVoxels());
    BoundaryEstimationConfig cfg;
    cfg.clear_line = false;
    cfg.require_sky_above = c.sky_test;
    const auto stats = estimateBoundaries(mesh, map, boundary, k, world_from_camera, cfg, rgb);
    const MeshVertex& m = mesh.vertices()[0];
    const std::string what = std::string(c.crown ? "crown" : "facade") + (c.on_bark ? " on bark" : "") + ", sky test " +
                             std::to_string(c.sky_test) + ", gap " + std::to_string(static_cast<int>(c.gap));
    EXPECT_EQ(stats.projected, 1) << what;
    EXPECT_EQ(stats.by_foliage, 0) << what;
    if (c.height == 0) {
      EXPECT_TRUE(m.estimates.empty()) << what;
      EXPECT_EQ(stats.ends_below, 1) << what;
      continue;
    }
    EXPECT_EQ(stats.ends_below, 0) << what;
    ASSERT_EQ(m.estimates.size(), 1u) << what;
    // a pixel is 6 cm high at 20 m
    EXPECT_NEAR(m.height(), c.height, 0.1) << what;
  }
}

// Estimates of a top edge over the vertex stay put as the camera nears; those of an edge behind it
// (height H, gap g) fall as c + (H - c) d / (d + g), those of an edge in front rise as
// c + (H - c) d / (d - g). Hand-computed heights for a camera 1.6 m up.
TEST(BoundaryEstimationTest, ParallaxTestTellsAnEdgeBehindOrInFrontFromTheVertexsOwn) {
  const auto behind = [](double top, double gap, double d) {
    return HeightEstimate{static_cast<float>(1.6 + (top - 1.6) * d / (d + gap)), static_cast<float>(d), 1.6f};
  };
  std::vector<HeightEstimate> own, back, near_edge, steep, front, scattered;
  for (int i = 0; i < 8; ++i) {
    const float d = 20.0f - i;
    own.push_back({12.0f + 0.02f * (i % 2 ? 1 : -1), d, 1.6f});  // a pixel's jitter
    back.push_back(behind(30, 20, d));                           // 15.8 m at 20 m, 12.8 m at 13 m
    near_edge.push_back(behind(40, 0.5, d - 10));                // a roof edge 0.5 m behind: 38.1 -> 36.5 m
    steep.push_back({12.0f + (d - 13), d, 1.6f});                // 1 m per m: faster than any gap explains
    front.push_back(behind(14, -8, d));                          // a crown's edge 8 m nearer: 22.3 -> 33.8 m
    // falling by 0.5 m per m, give or take 3 m: 1.1 standard errors
    scattered.push_back({static_cast<float>(20.0 - 0.5 * (d - 13) + (i % 2 ? 3 : -3)), d, 1.6f});
  }
  const auto test = [](const std::vector<HeightEstimate>& e, double slope = 0.2, double change = 0.3) {
    return showsParallax(e, slope, change, 2.0, 100.0, 8.0);
  };
  EXPECT_FALSE(test(own));
  EXPECT_TRUE(test(back));
  EXPECT_FALSE(test(back, 0.0)) << "slope 0 turns the test off";
  EXPECT_FALSE(test(back, 0.2, 4.0)) << "3 m across 7 m is not more than 4 m";
  EXPECT_FALSE(test({back.begin(), back.begin() + 4})) << "fewer than 5 estimates";
  // (a curved series: 7.6 standard errors of the straight line's slope; min_t 0 leaves the gap to tell)
  EXPECT_TRUE(showsParallax(near_edge, 0.2, 0.3, 0.0, 100.0, 0.0));
  EXPECT_FALSE(showsParallax(near_edge, 0.2, 0.3, 2.0, 100.0, 0.0)) << "a gap of 0.5 m is the object's own edge";
  EXPECT_FALSE(test(steep)) << "no gap makes (h - c) fall faster than d";
  EXPECT_FALSE(showsParallax(back, 0.2, 0.3, 2.0, 10.0, 8.0)) << "a gap of 20 m is past 10 m";
  EXPECT_TRUE(test(front)) << "an edge 8 m in front";
  EXPECT_FALSE(showsParallax(front, 0.2, 0.3, 2.0, 5.0, 8.0)) << "a gap of 8 m is past 5 m";
  EXPECT_FALSE(test(scattered)) << "a slope lost in the scatter";
  EXPECT_TRUE(showsParallax(scattered, 0.2, 0.3, 2.0, 100.0, 0.0)) << "min_t 0 takes any slope";
  // a camera that stands still: no slope to measure
  EXPECT_FALSE(test(std::vector<HeightEstimate>(6, HeightEstimate{15.0f, 20.0f, 1.6f})));
}

// A vertex with 2 estimates amid a wall's vertices with 6 each: held back when more of those within
// 1 m are held back than stand, whatever it shows itself; left alone otherwise, and when the test is off.
TEST(BoundaryEstimationTest, AYoungVertexFollowsItsNeighboursParallax) {
  for (const int held : {0, 3, 4, 5, 8}) {
    std::vector<Voxel> voxels;
    std::vector<MeshVertex> vertices;
    int n = 0;
    for (int y = -1; y <= 1; ++y) {
      for (int x = -1; x <= 1; ++x) {
        test::addColumn(voxels, vertices, CellIndex(x, y), 10, 2.0f, VoxelLabel::NonGround);
        MeshVertex& m = vertices.back();
        const bool centre = x == 0 && y == 0;
        m.estimates.assign(centre ? 2 : 6, HeightEstimate{12.0f, 20.0f, 1.6f});
        m.recovered_height = 12.0f;
        if (!centre) m.parallax = n++ < held;
      }
    }
    VoxelMap map(VoxelMapConfig{0.2});
    ASSERT_TRUE(map.restore(voxels));
    TerrainMesh mesh;
    ASSERT_TRUE(mesh.restore(vertices));
    const std::int64_t centre = mesh.find(CellIndex(0, 0));
    BoundaryEstimationConfig cfg;
    EXPECT_EQ(holdBackYoungVertices(mesh, map, cfg), held > 4 ? 1 : 0) << held;
    EXPECT_EQ(mesh.vertices()[centre].parallax, held > 4) << held;
    EXPECT_EQ(mesh.vertices()[centre].estimated(), held <= 4) << held;
  }
  // off with the parallax test
  std::vector<Voxel> voxels;
  std::vector<MeshVertex> vertices;
  test::addColumn(voxels, vertices, CellIndex(0, 0), 10, 2.0f, VoxelLabel::NonGround);
  vertices.back().estimates.assign(2, HeightEstimate{12.0f, 20.0f, 1.6f});
  test::addColumn(voxels, vertices, CellIndex(1, 0), 10, 2.0f, VoxelLabel::NonGround);
  vertices.back().estimates.assign(6, HeightEstimate{12.0f, 20.0f, 1.6f});
  vertices.back().parallax = true;
  VoxelMap map(VoxelMapConfig{0.2});
  ASSERT_TRUE(map.restore(voxels));
  TerrainMesh mesh;
  ASSERT_TRUE(mesh.restore(vertices));
  BoundaryEstimationConfig off;
  off.parallax_slope = 0;
  EXPECT_EQ(holdBackYoungVertices(mesh, map, off), 0);
  EXPECT_EQ(holdBackYoungVertices(mesh, map, BoundaryEstimationConfig{}), 1);
}

// Two objects of 3 x 3 vertices, one with a foliage-green top and one grey, each with a vertex of
// `young` estimates amid vertices of 6 that stand: the crown's young vertex is held back until it
// has the 5 estimates the parallax test needs; the grey one stands; neither with hold_young_crowns
// off or the parallax test off.
TEST(BoundaryEstimationTest, AYoungCrownVertexWaitsForTheParallaxTest) {
  struct Case {
    std::size_t young;
    bool hold, parallax_on, crown_held;
  };
  for (const Case c : {Case{1, true, true, true}, Case{4, true, true, true}, Case{5, true, true, false},
                       Case{2, false, true, false}, Case{2, true, false, false}}) {
    std::vector<Voxel> voxels;
    std::vector<MeshVertex> vertices;
    for (const int x0 : {0, 10}) {
      const bool leafy = x0 == 0;
      for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
          test::addColumn(voxels, vertices, CellIndex(x0 + x, y), 40, 8.0f, VoxelLabel::NonGround);
          Voxel& top = voxels.back();
          top.coloured = true;
          top.r = leafy ? 40 : 120, top.g = leafy ? 110 : 120, top.b = leafy ? 35 : 120;
          MeshVertex& m = vertices.back();
          m.estimates.assign(x == 0 && y == 0 ? c.young : 6, HeightEstimate{12.0f, 20.0f, 1.6f});
          m.recovered_height = 12.0f;
        }
      }
    }
    VoxelMap map(VoxelMapConfig{0.2});
    ASSERT_TRUE(map.restore(voxels));
    TerrainMesh mesh;
    ASSERT_TRUE(mesh.restore(vertices));
    BoundaryEstimationConfig cfg;
    cfg.hold_young_crowns = c.hold;
    if (!c.parallax_on) cfg.parallax_slope = 0;
    const std::string what = "young " + std::to_string(c.young) + ", hold " + std::to_string(c.hold) +
                             ", parallax test " + std::to_string(c.parallax_on);
    EXPECT_EQ(holdBackYoungVertices(mesh, map, cfg), c.crown_held ? 1 : 0) << what;
    const auto& v = mesh.vertices();
    EXPECT_EQ(v[mesh.find(CellIndex(0, 0))].estimated(), !c.crown_held) << what;
    EXPECT_TRUE(v[mesh.find(CellIndex(10, 0))].estimated()) << what;
    for (const auto& m : v) {
      if (m.cell != CellIndex(0, 0)) {
        EXPECT_TRUE(m.estimated()) << what;
      }
    }
  }
}

// A wall at (3, 20), 12 m high, seen by a camera driving north from y = -10 to -1; in one drive its
// own top is the topmost boundary, in the other an unsensed building 20 m behind it, 30 m high. The
// first raises the wall to 12 m; the second is caught by its parallax and leaves the wall as sensed.
TEST(BoundaryEstimationTest, AWallInFrontOfATallerUnsensedBuildingIsNotRaisedToItsSkyline) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  for (const bool own_top : {true, false}) {
    VoxelMap map(VoxelMapConfig{0.2});
    map.insert({Point3(3.05, 20.05, 1.05)}, 0);
    map.voxels()[0].label = VoxelLabel::NonGround;
    TerrainMesh mesh;
    mesh.update(map, map.takeNewVoxels());
    for (int step = 0; step < 10; ++step) {
      Pose camera = northCamera();
      camera.translation().y() = step - 10;
      const Point3 edge = own_top ? Point3(3.1, 20.1, 12.0) : Point3(3.1, 40.1, 30.0);
      const cv::Mat boundary = boundaryRowThrough(k, camera, edge);
      ASSERT_FALSE(boundary.empty());
      EXPECT_EQ(estimateBoundaries(mesh, map, boundary, k, camera, BoundaryEstimationConfig{}).estimated, 1);
    }
    const MeshVertex& m = mesh.vertices()[0];
    ASSERT_EQ(m.estimates.size(), 10u);
    EXPECT_EQ(m.parallax, !own_top);
    if (own_top) {
      EXPECT_TRUE(m.raised());
      EXPECT_NEAR(m.height(), 12.0, 0.05);
    } else {
      // without the test the wall would stand between 16.1 and 18.6 m
      EXPECT_GT(m.recovered_height, 16.0f);
      EXPECT_FALSE(m.raised());
      EXPECT_FLOAT_EQ(m.height(), m.sensed_height);
    }
  }
}

// a row of cells x = 0..6 at y = 0, each with one voxel; labels as given (1 ground, 2 non-ground)
struct Row {
  VoxelMap map{VoxelMapConfig{}};
  TerrainMesh mesh;
  explicit Row(const std::vector<VoxelLabel>& labels) {
    std::vector<Voxel> voxels;
    std::vector<MeshVertex> vertices;
    for (int x = 0; x < static_cast<int>(labels.size()); ++x)
      test::addColumn(voxels, vertices, CellIndex(x, 0), 10, 2.0f, labels[x]);
    EXPECT_TRUE(map.restore(voxels));
    EXPECT_TRUE(mesh.restore(vertices));
  }
};

// Object A: a 20 m wall of non-ground cells along +x from the camera at the origin; a gap of
// ground; object B, 30-32 m away. Gridded within 10 m of the camera, A is found whole (also its
// cells beyond 10 m) and B not at all.
TEST(BoundaryEstimationTest, SkylineOwnersKnowOnlyTheObjectsWithinReachButThemWhole) {
  std::vector<VoxelLabel> labels(161, VoxelLabel::Ground);
  for (int x = 0; x <= 160; ++x) {
    if (x <= 100 || x >= 150) labels[x] = VoxelLabel::NonGround;
  }
  const Row row(labels);
  const TerrainMesh& mesh = row.mesh;
  const VoxelMap& map = row.map;
  const SkylineOwners owners(mesh, map, Eigen::Vector2d(0, 0), 10.0);
  ASSERT_EQ(owners.objects().count, 1);
  EXPECT_EQ(owners.objects().of[0], 0);
  EXPECT_EQ(owners.objects().of[100], 0);   // 20 m out, beyond the square: still A
  EXPECT_EQ(owners.objects().of[120], -1);  // ground
  EXPECT_EQ(owners.objects().of[155], -1);  // B, never reaching the square
  // a ray along A (A's top unknown) may belong to A; one the other way passes nothing
  const Point3 eye(-1.0, 0.1, 1.5);
  EXPECT_TRUE(owners.otherMayOwn(eye, Vector3(1, 0, 0.01), 10.0, -1, Eigen::Vector2d(-5, 0), 0.5, 1.0));
  EXPECT_FALSE(owners.otherMayOwn(eye, Vector3(1, 0, 0.01), 10.0, 0, Eigen::Vector2d(-5, 0), 0.5, 1.0));
  EXPECT_FALSE(owners.otherMayOwn(eye, Vector3(-1, 0, 0.01), 10.0, -1, Eigen::Vector2d(-5, 0), 0.5, 1.0));
  // the whole mesh within reach: B is found too
  EXPECT_EQ(SkylineOwners(mesh, map, Eigen::Vector2d(0, 0), 40.0).objects().count, 2);
  // the members are A's 101 vertices
  std::vector<std::uint32_t> members = owners.objects().members;
  std::sort(members.begin(), members.end());
  ASSERT_EQ(members.size(), 101u);
  for (std::uint32_t i = 0; i < members.size(); ++i) EXPECT_EQ(members[i], i);
}

// Objects are numbered by their lowest vertex id in the region, whatever order they are found in.
TEST(BoundaryEstimationTest, MeshObjectsAreNumberedByTheirLowestVertexInTheRegion) {
  const auto N = VoxelLabel::NonGround, G = VoxelLabel::Ground;
  // ids 0..6 along x: objects {0, 1}, {3}, {5, 6}; saved in reverse, ids 6..0
  std::vector<Voxel> voxels;
  std::vector<MeshVertex> vertices;
  const std::vector<VoxelLabel> labels{N, N, G, N, G, N, N};
  for (int x = 6; x >= 0; --x) test::addColumn(voxels, vertices, CellIndex(x, 0), 10, 2.0f, labels[x]);
  VoxelMap map{VoxelMapConfig{}};
  TerrainMesh mesh;
  ASSERT_TRUE(map.restore(voxels));
  ASSERT_TRUE(mesh.restore(vertices));
  const MeshObjects all = findMeshObjects(mesh, map);
  ASSERT_EQ(all.count, 3);
  // vertex id 0 is cell 6: the object {5, 6} first, then {3} (id 3), then {0, 1} (ids 5, 6)
  EXPECT_EQ(all.of, (std::vector<std::int32_t>{0, 0, -1, 1, -1, 2, 2}));
  EXPECT_EQ(all.members.size(), 5u);
  // cells 1..3 only (x in [0.2, 0.8] m): {0, 1} whole, and {3}; the region's lowest ids are 3 and 5
  const Eigen::AlignedBox2d region(Eigen::Vector2d(0.2, -1.0), Eigen::Vector2d(0.8, 1.0));
  const MeshObjects part = findMeshObjects(mesh, map, &region);
  ASSERT_EQ(part.count, 2);
  EXPECT_EQ(part.of, (std::vector<std::int32_t>{-1, -1, -1, 0, -1, 1, 1}));
}

// The owners' known tops follow estimates added after they were made once refreshTops is called,
// and a frame estimated with owners made beforehand matches one that makes its own.
TEST(BoundaryEstimationTest, SharedOwnersGiveWhatOwnOwnersGive) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  const Pose world_from_camera = northCamera();
  Pixel top_px;
  const cv::Mat boundary = boundaryRowThrough(k, world_from_camera, Vector3(3.1, 20.1, 12.0), &top_px);
  ASSERT_FALSE(boundary.empty());
  // the wall A at (3, 20) and B on the same line of sight at (6.25, 40.25), B's top unknown
  VoxelMap map(VoxelMapConfig{0.2});
  map.insert({Point3(3.05, 20.05, 1.05), Point3(6.25, 40.25, 1.05)}, 0);
  for (auto& v : map.voxels()) v.label = VoxelLabel::NonGround;
  TerrainMesh mesh;
  mesh.update(map, map.takeNewVoxels());
  const std::uint32_t a = mesh.vertices()[0].cell.y() < 150 ? 0 : 1, b = 1 - a;
  const BoundaryEstimationConfig cfg;
  SkylineOwners owners(mesh, map, world_from_camera.translation().head<2>(), cfg.max_distance);
  TerrainMesh own = mesh;
  const auto shared_stats = estimateBoundaries(mesh, map, boundary, k, world_from_camera, cfg, cv::Mat(), &owners);
  const auto own_stats = estimateBoundaries(own, map, boundary, k, world_from_camera, cfg);
  // neither top is clear: each object's top is unknown and lies on the other's line of sight
  EXPECT_EQ(shared_stats.not_clear, 2);
  EXPECT_EQ(own_stats.not_clear, shared_stats.not_clear);
  EXPECT_EQ(own_stats.estimated, shared_stats.estimated);
  // B turns out 15 m high, below the ray (22.4 m where it passes B): stale owners still say B may
  // own A's top, refreshed ones do not
  mesh.addEstimate(b, {15.0f, 30.0f, 1.6f}, 15);
  const Point3 eye = world_from_camera.translation();
  const Vector3 dir = world_from_camera.linear() * pixelRay(k, top_px);
  const std::int32_t a_object = owners.objects().of[a];
  EXPECT_TRUE(owners.otherMayOwn(eye, dir, cfg.max_distance, a_object, Eigen::Vector2d(3.1, 20.1), 1.0, 1.0));
  owners.refreshTops(mesh);
  EXPECT_FALSE(owners.otherMayOwn(eye, dir, cfg.max_distance, a_object, Eigen::Vector2d(3.1, 20.1), 1.0, 1.0));
  // A now gets its estimate (B, behind A whose top is still unknown, does not)
  EXPECT_EQ(estimateBoundaries(mesh, map, boundary, k, world_from_camera, cfg, cv::Mat(), &owners).estimated, 1);
  EXPECT_EQ(mesh.vertices()[a].estimates.size(), 1u);
}

TEST(BoundaryEstimationTest, EstimatesSpreadOverTheirObjectOnlyAndOnlySoFar) {
  const auto N = VoxelLabel::NonGround, G = VoxelLabel::Ground;
  Row row({N, N, N, N, G, N, N});
  row.mesh.addEstimate(0, {12.0f, 10.0f, 1.6f}, 15);
  BoundaryEstimationConfig cfg;
  cfg.spread_distance = 0.5;  // 2 cells of 0.2 m
  EXPECT_EQ(spreadEstimates(row.mesh, row.map, cfg), 2);
  const auto& v = row.mesh.vertices();
  EXPECT_FLOAT_EQ(v[1].height(), 12.0f);
  EXPECT_FLOAT_EQ(v[2].height(), 12.0f);
  EXPECT_FLOAT_EQ(v[3].height(), 2.0f);  // 3 cells away
  // a ground vertex ends the object: nothing crosses it however far the spread goes
  cfg.spread_distance = 10;
  EXPECT_EQ(spreadEstimates(row.mesh, row.map, cfg), 3);
  EXPECT_FLOAT_EQ(v[3].height(), 12.0f);
  EXPECT_FALSE(v[4].raised());
  EXPECT_FALSE(v[5].raised());
  EXPECT_FLOAT_EQ(v[6].height(), 2.0f);
  // off: nothing spread, and what was spread before is taken back
  cfg.spread_distance = 0;
  EXPECT_EQ(spreadEstimates(row.mesh, row.map, cfg), 0);
  EXPECT_FLOAT_EQ(v[1].height(), 2.0f);
  EXPECT_TRUE(v[0].raised());
}
// Every point within reach that a camera sees lies in its view region, whichever way it looks; the
// region of a level camera is the sector its image spans, not the square around it.
TEST(BoundaryEstimationTest, TheViewRegionHoldsEveryPointTheCameraSeesWithinReach) {
  const CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  const double reach = 50.0;
  const double half_hfov = std::atan(320.0 / k.fx);
  for (const double yaw_deg : {0.0, 30.0, 90.0, 135.0, 200.0, 300.0}) {
    for (const double pitch_deg : {0.0, 20.0, -30.0, -89.0}) {
      // north camera turned by yaw about z, then pitched up about its own x axis
      Pose pose = northCamera();
      pose.linear() = Eigen::AngleAxisd(-yaw_deg * M_PI / 180, Vector3::UnitZ()).toRotationMatrix() * pose.linear() *
                      Eigen::AngleAxisd(-pitch_deg * M_PI / 180, Vector3::UnitX()).toRotationMatrix();
      pose.translation() = Vector3(3.0, -7.0, 1.6);
      const Eigen::AlignedBox2d region = viewRegion(k, pose, reach, 0.0);
      int seen = 0;
      for (double x = -reach; x <= reach; x += 1.0) {
        for (double y = -reach; y <= reach; y += 1.0) {
          if (std::hypot(x, y) > reach) continue;
          for (const double z : {-30.0, 0.0, 1.6, 10.0, 40.0}) {
            const Point3 p(3.0 + x, -7.0 + y, z);
            if (!project(k, pose.inverse() * p)) continue;
            ++seen;
            EXPECT_TRUE(region.contains(p.head<2>())) << yaw_deg << " " << pitch_deg << " " << p.transpose();
          }
        }
      }
      EXPECT_GT(seen, 100);
    }
  }
  // level, looking north: the sector between the image's edges, reach deep
  const Eigen::AlignedBox2d north = viewRegion(k, northCamera(), reach, 0.0);
  EXPECT_NEAR(north.min().y(), 0.0, 1e-9);
  EXPECT_NEAR(north.max().y(), reach, 1e-9);
  // (a level camera's corner rays share their azimuth with the image's side edges)
  EXPECT_NEAR(north.max().x(), reach * std::sin(half_hfov), 1e-9);
  EXPECT_NEAR(north.min().x(), -north.max().x(), 1e-9);
  // looking straight down the view takes in every direction: the square
  Pose down = Pose::Identity();
  down.linear().col(0) = Vector3(1, 0, 0);
  down.linear().col(1) = Vector3(0, -1, 0);
  down.linear().col(2) = Vector3(0, 0, -1);
  const Eigen::AlignedBox2d square = viewRegion(k, down, reach, 0.0);
  EXPECT_NEAR(square.min().x(), -reach, 1e-9);
  EXPECT_NEAR(square.max().y(), reach, 1e-9);
}

}  // namespace
}  // namespace terrain
