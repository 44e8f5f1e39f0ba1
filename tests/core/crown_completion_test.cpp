#include "core/crown_completion.hpp"
#include "core/camera_model.hpp"
#include "tests/core/core_test_support.hpp"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>

namespace terrain {
namespace {

// a level camera 1.6 m above the origin looking north (+y)
Pose northCamera() {
  Pose world_from_camera = Pose::Identity();
  world_from_camera.linear().col(0) = Vector3(1, 0, 0);
  world_from_camera.linear().col(1) = Vector3(0, 0, -1);
  world_from_camera.linear().col(2) = Vector3(0, 1, 0);
  world_from_camera.translation() = Vector3(0, 0, 1.6);
  return world_from_camera;
}

// A tree 20 m north of the camera: the lidar saw its trunk (one cell centred at (0.1, 20.1), sensed
// up to 3 m) and the ground around it (0 m, out to 5 m); its crown is a sphere of radius 3 m centred
// 8 m up, above the lidar's reach.
struct Tree {
  VoxelMap map{VoxelMapConfig{0.2}};
  TerrainMesh mesh;
  CameraIntrinsics k = CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180);
  Pose pose = northCamera();
  bool second = false;
  // behind: an object the lidar saw 10 m behind the tree (y = 30 m), its top unknown: a wall 8 m
  // wide (Behind::Wall) or another trunk (Behind::Trunk, one cell); second_trunk: another trunk the
  // lidar saw 1 m east of this one and 2 m behind it, rising into the crown in the image, its own
  // crown not shown; smear: the trunk's cells run this many cells north from (0, 100), as the pose
  // noise of a long drive spreads a thin trunk's returns (the same vertex ids as without)
  // z0_voxels: everything (ground, trunk, crown, camera) that many voxels higher (z0 [m]); world
  // heights may be negative. grown: what the trunk's object took in after it was measured, as the
  // robot neared: the crown's underside within 2 m of it, sensed at 5 m (Grown::IntoCrown), or a
  // facade running 5 m east from it, sensed at 3 m (Grown::IntoFacade). near_tree: a small tree
  // 10 m north of the camera, its trunk (one cell centred at (-0.1, 10.1)) sensed up to 2.2 m, its
  // crown a sphere of radius 0.4 m centred 2.8 m up, which hides the tree's trunk in the image
  // between the lidar's 3 m and the crown's 5 m
  enum class Behind { Nothing, Wall, Trunk };
  enum class Grown { No, IntoCrown, IntoFacade };
  double z0 = 0;
  bool near = false;
  explicit Tree(Behind behind = Behind::Nothing, bool second_trunk = false, int smear = 1, int z0_voxels = 0,
                Grown grown = Grown::No, bool near_tree = false, bool near_grown = false)
      : second(second_trunk), z0(z0_voxels * 0.2), near(near_tree) {
    pose.translation().z() += z0;
    std::vector<Voxel> voxels;
    std::vector<MeshVertex> vertices;
    if (behind != Behind::Nothing) {
      const int half = behind == Behind::Wall ? 20 : 0;
      for (int x = -half; x <= half; ++x) {
        Voxel v;
        v.height = static_cast<float>(3.0 + z0);
        v.index = VoxelIndex(x, 150, 15 + z0_voxels);
        v.label = VoxelLabel::NonGround;
        MeshVertex m;
        m.cell = CellIndex(x, 150);
        m.top_voxel = static_cast<std::uint32_t>(voxels.size());
        m.sensed_height = v.height;
        voxels.push_back(v);
        vertices.push_back(m);
      }
    }
    if (near)
      test::addColumn(voxels, vertices, CellIndex(-1, 50), 11 + z0_voxels, static_cast<float>(2.2 + z0),
                      VoxelLabel::NonGround);
    // near_grown: the lidar also reached the small tree's crown underside (2.4 m) within 0.6 m of its
    // trunk, so that its object is 1.4 m across: wider than a trunk
    for (int dx = -3; near && near_grown && dx <= 3; ++dx) {
      for (int dy = -3; dy <= 3; ++dy) {
        if ((dx != 0 || dy != 0) && std::hypot(dx, dy) * 0.2 <= 0.65)
          test::addColumn(voxels, vertices, CellIndex(-1 + dx, 50 + dy), 12 + z0_voxels, static_cast<float>(2.4 + z0),
                          VoxelLabel::NonGround);
      }
    }
    for (int x = -25; x <= 25; ++x) {
      for (int y = 75; y <= 125; ++y) {
        const bool trunk = (x == 0 && y >= 100 && y < 100 + smear) || (second_trunk && x == 5 && y == 110) ||
                           (grown == Grown::IntoFacade && x > 0 && y == 100);
        const bool underside = grown == Grown::IntoCrown && !trunk && std::hypot(x * 0.2, (y - 100) * 0.2) <= 2.0;
        if (!trunk && std::hypot(x * 0.2, (y - 100) * 0.2) > 5.0) continue;
        const int z = underside ? 25 : (trunk ? 15 : 0);
        test::addColumn(voxels, vertices, CellIndex(x, y), z + z0_voxels, static_cast<float>(z * 0.2 + z0),
                        trunk || underside ? VoxelLabel::NonGround : VoxelLabel::Ground);
      }
    }
    EXPECT_TRUE(map.restore(voxels));
    EXPECT_TRUE(mesh.restore(vertices));
  }
  const MeshVertex& at(int x, int y) const { return mesh.vertices()[mesh.find(CellIndex(x, y))]; }
  // the ground raised to the crown's cap: its top is 11 m and its radius 3 m, to within a pixel at
  // 20 m (about 0.05 m) and the rasterised silhouette
  void expectCap() const {
    EXPECT_NEAR(at(1, 100).height(), 11.0 + z0, 0.15);
    // 2 m from the trunk: 11 - 3 + sqrt(9 - 4)
    EXPECT_NEAR(at(10, 100).height(), 8.0 + std::sqrt(5.0) + z0, 0.2);
    // beyond 3.2 m the ground stays ground
    EXPECT_FALSE(at(17, 100).raised());
    EXPECT_FALSE(at(0, 117).raised());
  }
  // sky above, ground below the horizon, the trunk and the crown's silhouette (a disc of the
  // sphere's angular radius); crown_shift moves the crown up in the image [px]; facade: a grey facade
  // fills the image above the horizon behind the tree instead of the sky
  cv::Mat image(int crown_shift = 0, bool facade = false) const {
    cv::Mat rgb(k.height, k.width, CV_8UC3, facade ? cv::Scalar(190, 180, 160) : cv::Scalar(120, 170, 235));
    const Pose camera_from_world = pose.inverse();
    const int horizon = static_cast<int>(k.cy);
    cv::rectangle(rgb, cv::Rect(0, horizon, k.width, k.height - horizon), cv::Scalar(90, 110, 60), cv::FILLED);
    const auto base = project(k, camera_from_world * Point3(0.1, 20.1, z0));
    const auto centre = project(k, camera_from_world * Point3(0.1, 20.1, 8.0 + z0));
    const double radius_px = k.fx * std::asin(3.0 / 20.0);
    cv::rectangle(rgb, cv::Point(static_cast<int>(base->x()) - 2, static_cast<int>(centre->y()) - crown_shift),
                  cv::Point(static_cast<int>(base->x()) + 2, static_cast<int>(base->y())), cv::Scalar(90, 60, 30),
                  cv::FILLED);
    if (second) {
      const auto behind = project(k, camera_from_world * Point3(1.1, 22.1, z0));
      cv::rectangle(rgb, cv::Point(static_cast<int>(behind->x()) - 2, static_cast<int>(centre->y())),
                    cv::Point(static_cast<int>(behind->x()) + 2, static_cast<int>(behind->y())), cv::Scalar(90, 60, 30),
                    cv::FILLED);
    }
    cv::circle(
        rgb,
        cv::Point(static_cast<int>(std::lround(centre->x())), static_cast<int>(std::lround(centre->y())) - crown_shift),
        static_cast<int>(std::lround(radius_px)), cv::Scalar(40, 110, 30), cv::FILLED);
    if (near) {
      const auto near_base = project(k, camera_from_world * Point3(-0.1, 10.1, z0));
      const auto near_centre = project(k, camera_from_world * Point3(-0.1, 10.1, 2.8 + z0));
      cv::rectangle(rgb, cv::Point(static_cast<int>(near_base->x()) - 2, static_cast<int>(near_centre->y())),
                    cv::Point(static_cast<int>(near_base->x()) + 2, static_cast<int>(near_base->y())),
                    cv::Scalar(90, 60, 30), cv::FILLED);
      cv::circle(
          rgb,
          cv::Point(static_cast<int>(std::lround(near_centre->x())), static_cast<int>(std::lround(near_centre->y()))),
          static_cast<int>(std::lround(k.fx * std::asin(0.4 / 10.1))), cv::Scalar(40, 110, 30), cv::FILLED);
    }
    return rgb;
  }
};

// The trunk's object takes in an older vertex after it was measured (a return beside it relabels the
// ground there): its key, the object's lowest vertex id, changes; its samples still count.
TEST(CrownCompletionTest, SamplesFollowATrunkWhoseObjectTookAnotherKey) {
  Tree tree;
  CrownSampler sampler;
  const cv::Mat rgb = tree.image();
  CrownConfig cfg;
  cfg.min_baseline = 0;  // the same image stands for views along a baseline here
  for (int frame = 0; frame < 3; ++frame)
    ASSERT_EQ(sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 1);
  const std::int64_t beside = tree.mesh.find(CellIndex(-1, 100)), trunk = tree.mesh.find(CellIndex(0, 100));
  ASSERT_GE(beside, 0);
  ASSERT_LT(beside, trunk);  // older: the object's lowest vertex from now on
  tree.map.voxels()[tree.mesh.vertices()[beside].top_voxel].label = VoxelLabel::NonGround;
  EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
  tree.expectCap();
  // both keys' records carry the verdict
  for (const CrownRecord& r : sampler.records()) EXPECT_EQ(r.verdict, CrownVerdict::Raised) << r.key;
}

TEST(CrownCompletionTest, ACrownAgainstTheSkyRaisesTheGroundUnderItToASphericalCap) {
  Tree tree;
  CrownSampler sampler;
  const cv::Mat rgb = tree.image();
  CrownConfig cfg;
  cfg.enabled = true;
  // off: nothing measured
  CrownConfig off;
  off.enabled = false;
  EXPECT_EQ(sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, off, BoundaryEstimationConfig{}), 0);
  for (int frame = 0; frame < 3; ++frame) {
    EXPECT_EQ(sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 1);
  }
  EXPECT_EQ(sampler.trunks(), 1u);
  // the trunk's record: three frames, each a sample, not judged yet
  ASSERT_EQ(sampler.records().size(), 1u);
  EXPECT_EQ(sampler.records()[0].outcomes[static_cast<std::size_t>(CrownOutcome::Measured)], 3);
  EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::NotApplied);
  // seen from one spot only: a crown behind the column could not have shown itself, nothing raised
  EXPECT_EQ(sampler.apply(tree.mesh, tree.map, cfg), 0);
  EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::NoBaseline);
  // (the same image stands for views along a baseline here)
  cfg.min_baseline = 0;
  EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
  EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
  EXPECT_STREQ(verdictName(CrownVerdict::Raised), "raised");
  // a frame of sky only: the trunk is seen, but no crown above it
  const cv::Mat sky(rgb.size(), rgb.type(), cv::Scalar(120, 160, 230));
  EXPECT_EQ(sampler.measure(tree.mesh, tree.map, sky, tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 0);
  EXPECT_EQ(sampler.records()[0].outcomes[static_cast<std::size_t>(CrownOutcome::NoCrown)], 1);
  EXPECT_STREQ(outcomeName(CrownOutcome::NoCrown), "no_crown");
  // records read back replace the sampler's
  CrownSampler other;
  other.restoreRecords(sampler.records());
  ASSERT_EQ(other.records().size(), 1u);
  EXPECT_EQ(other.records()[0].outcomes, sampler.records()[0].outcomes);
  EXPECT_EQ(other.records()[0].verdict, CrownVerdict::Raised);
  tree.expectCap();
  // the trunk, without an estimate of its own, is under the crown too
  EXPECT_NEAR(tree.at(0, 100).height(), 11.0, 0.15);
}

// A crown 6 m in radius topped at 16 m, 20 m from the camera (95 px): its outline widens by more
// than 3 px a row below its top, as the outline of every large near crown does, yet it is one crown;
// the ground 4 m from the trunk is raised to its cap (with only the first rows' widening, its
// radius was taken as 0.9 m and the ground there stayed ground).
TEST(CrownCompletionTest, ALargeNearCrownIsMeasuredToItsFullRadius) {
  Tree tree;
  cv::Mat rgb(tree.k.height, tree.k.width, CV_8UC3, cv::Scalar(120, 170, 235));
  const Pose camera_from_world = tree.pose.inverse();
  const int horizon = static_cast<int>(tree.k.cy);
  cv::rectangle(rgb, cv::Rect(0, horizon, tree.k.width, tree.k.height - horizon), cv::Scalar(90, 110, 60), cv::FILLED);
  const auto base = project(tree.k, camera_from_world * Point3(0.1, 20.1, 0.0));
  const auto centre = project(tree.k, camera_from_world * Point3(0.1, 20.1, 10.0));
  ASSERT_TRUE(base && centre);
  cv::rectangle(rgb, cv::Point(static_cast<int>(base->x()) - 2, static_cast<int>(centre->y())),
                cv::Point(static_cast<int>(base->x()) + 2, static_cast<int>(base->y())), cv::Scalar(90, 60, 30),
                cv::FILLED);
  const double radius_px = tree.k.fx * std::asin(6.0 / 20.0);
  cv::circle(rgb, cv::Point(static_cast<int>(std::lround(centre->x())), static_cast<int>(std::lround(centre->y()))),
             static_cast<int>(std::lround(radius_px)), cv::Scalar(40, 110, 30), cv::FILLED);
  ASSERT_GT(centre->y() - radius_px, 0.0);  // the whole crown in view
  CrownSampler sampler;
  CrownConfig cfg;
  cfg.min_baseline = 0;  // the same image stands for views along a baseline here
  for (int frame = 0; frame < 3; ++frame)
    ASSERT_EQ(sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 1);
  EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
  ASSERT_EQ(sampler.records().size(), 1u);
  EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
  EXPECT_NEAR(tree.at(1, 100).height(), 16.0, 0.3);
  // 4 m east and 4 m north of the trunk: 16 - 6 + sqrt(36 - 16)
  EXPECT_NEAR(tree.at(20, 100).height(), 10.0 + std::sqrt(20.0), 0.5);
  EXPECT_NEAR(tree.at(0, 120).height(), 10.0 + std::sqrt(20.0), 0.5);
}

// Foliage above the crown in its column (a taller crown behind it in some frames) lifts a sample's
// top, never lowers it: the lowest group of samples that agree, with enough of them seen from far
// enough apart, gives the crown. Shifting the crown up by 25 px in the image stands for such frames.
TEST(CrownCompletionTest, TheLowestGroupOfAgreeingSamplesGivesTheTop) {
  // samples from the camera moved east by each x [m], with the crown drawn up by the shift [px]. The
  // images of one case show the crown at different heights, which no one world does: the sky an
  // unshifted image shows over the trunk's axis would bound the lifted crown, so the axis's ceiling
  // is left out to judge the samples alone
  CrownConfig measuring;
  measuring.axis_ceiling = false;
  const auto sampled = [&measuring](Tree& tree, CrownSampler& sampler,
                                    const std::vector<std::pair<double, int>>& views) {
    const Pose start = tree.pose;
    for (const auto& [x, shift] : views) {
      tree.pose.translation().x() = start.translation().x() + x;
      EXPECT_EQ(sampler.measure(tree.mesh, tree.map, tree.image(shift), tree.k, tree.pose, measuring,
                                BoundaryEstimationConfig{}),
                1)
          << x << " m, " << shift << " px";
    }
    tree.pose = start;
  };
  // 25 px at 20 m lifts the top by about 1.6 m
  const double lifted = 11.0 + 25 * 20.0 / CameraIntrinsics::fromFovy(640, 480, 75 * M_PI / 180).fy;
  CrownConfig cfg;
  cfg.min_baseline = 2.0;
  {
    // three true tops from 2.5 m apart below four lifted ones: the true ones stand (the median of
    // all seven, 12.6 m, with an interquartile range of 1.6 m, would be refused as disagreeing)
    Tree tree;
    CrownSampler sampler;
    sampled(tree, sampler, {{0.0, 0}, {1.2, 0}, {2.5, 0}, {0.4, 25}, {0.8, 25}, {1.6, 25}, {2.0, 25}});
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
    tree.expectCap();
  }
  {
    // the true tops all from within 0.4 m: too close to tell a crown behind; the lifted ones, from
    // 2.5 m apart, agree among themselves and set the top
    Tree tree;
    CrownSampler sampler;
    sampled(tree, sampler, {{0.0, 0}, {0.2, 0}, {0.4, 0}, {0.0, 25}, {0.8, 25}, {1.6, 25}, {2.5, 25}});
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
    EXPECT_NEAR(tree.at(1, 100).height(), lifted, 0.2);
  }
  {
    // tops 1.6 m apart step by step: no two within a tenth of each other, no group of three
    Tree tree;
    CrownSampler sampler;
    sampled(tree, sampler, {{0.0, 0}, {1.2, 25}, {2.5, 50}});
    EXPECT_EQ(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Disagree);
    EXPECT_FALSE(tree.at(1, 100).raised());
  }
  {
    // the first case 40 m below the world origin: the share is of the height above the ground
    // around the trunk, so the tops still agree as they do at the origin
    Tree tree(Tree::Behind::Nothing, false, 1, -200);
    CrownSampler sampler;
    sampled(tree, sampler, {{0.0, 0}, {1.2, 0}, {2.5, 0}, {0.4, 25}, {0.8, 25}, {1.6, 25}, {2.0, 25}});
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
    tree.expectCap();
  }
}

TEST(CrownCompletionTest, NoSampleWhenAnotherObjectMayOwnTheTopOrTheCrownIsCutOff) {
  Tree tree;
  CrownSampler sampler;
  CrownConfig cfg;
  cfg.enabled = true;
  cfg.min_baseline = 0;
  BoundaryEstimationConfig no_clear_line;
  no_clear_line.clear_line = false;
  // against the sky: a sensed wall behind the tree, of unknown height, may own the topmost non-sky
  // pixel
  CrownConfig sky = cfg;
  sky.cue = CrownConfig::Cue::Sky;
  Tree wall(Tree::Behind::Wall);
  EXPECT_EQ(sampler.measure(wall.mesh, wall.map, wall.image(), wall.k, wall.pose, sky, BoundaryEstimationConfig{}), 0);
  EXPECT_EQ(sampler.measure(wall.mesh, wall.map, wall.image(), wall.k, wall.pose, sky, no_clear_line), 1);
  // by its foliage: a wall is no crown, but another trunk behind, its crown unknown, may own the top
  EXPECT_EQ(sampler.measure(wall.mesh, wall.map, wall.image(), wall.k, wall.pose, cfg, BoundaryEstimationConfig{}), 1);
  Tree trunk(Tree::Behind::Trunk);
  EXPECT_EQ(sampler.measure(trunk.mesh, trunk.map, trunk.image(), trunk.k, trunk.pose, cfg, BoundaryEstimationConfig{}),
            0);
  // without the test each of the two trunks in the column takes the crown for its own
  EXPECT_EQ(sampler.measure(trunk.mesh, trunk.map, trunk.image(), trunk.k, trunk.pose, cfg, no_clear_line), 2);
  sampler = CrownSampler();
  // the crown drawn wholly above the image: the trunk runs up to the image top, no crown above it
  EXPECT_EQ(sampler.measure(tree.mesh, tree.map, tree.image(400), tree.k, tree.pose, cfg, BoundaryEstimationConfig{}),
            0);
  EXPECT_EQ(sampler.trunks(), 0u);
  // too few samples: nothing raised
  CrownSampler once;
  EXPECT_EQ(once.measure(tree.mesh, tree.map, tree.image(), tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 1);
  EXPECT_EQ(once.apply(tree.mesh, tree.map, cfg), 0);
}

// A crown drawn 120 px higher runs off the image top (its top at 18.7 m, row -27): a frame gives a
// bound sample, the ray through the top row over the trunk, 1.6 + 239.5 / fy * 20.1 = 17.0 m. With
// no sample of the whole crown the bound samples raise the ground under it to that height; the
// crown's radius still comes from its runs (3 m).
TEST(CrownCompletionTest, ACrownCutOffByTheImageTopIsRaisedToItsBound) {
  CrownConfig cfg;
  cfg.min_baseline = 0;  // the same image stands for views along a baseline here
  {
    Tree tree;
    CrownSampler sampler;
    for (int frame = 0; frame < 3; ++frame)
      EXPECT_EQ(
          sampler.measure(tree.mesh, tree.map, tree.image(120), tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 1);
    ASSERT_EQ(sampler.records().size(), 1u);
    EXPECT_EQ(sampler.records()[0].outcomes[static_cast<std::size_t>(CrownOutcome::CutOff)], 3);
    EXPECT_STREQ(outcomeName(CrownOutcome::CutOff), "cut_off");
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::RaisedToBound);
    EXPECT_STREQ(verdictName(CrownVerdict::RaisedToBound), "raised_to_bound");
    const double bound = 1.6 + (tree.k.cy - 0.5) / tree.k.fy * 20.1;
    EXPECT_NEAR(tree.at(1, 100).height(), bound, 0.15);
    EXPECT_LT(tree.at(1, 100).height(), 11.0 + 120 * 20.0 / tree.k.fy);  // below the crown's top
    // 2 m from the trunk: on the cap of radius 3 m
    EXPECT_NEAR(tree.at(10, 100).height(), bound - 3.0 + std::sqrt(5.0), 0.2);
    EXPECT_FALSE(tree.at(17, 100).raised());
  }
  {
    // drawn 170 px higher only the crown's lowest 18 rows show (0.8 m at the trunk's depth above
    // a bound of 17.0 m, where its runs are 36 px either side: 2.35 m): a crown that shows so little
    // of its depth is not bound by it (crown.max_width_to_depth), so the ground 1.8 m from the trunk
    // is raised and 2.8 m from it is not
    Tree tree;
    CrownSampler sampler;
    for (int frame = 0; frame < 3; ++frame)
      EXPECT_EQ(
          sampler.measure(tree.mesh, tree.map, tree.image(170), tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 1);
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::RaisedToBound);
    EXPECT_TRUE(tree.at(9, 100).raised());
    EXPECT_GT(tree.at(9, 100).height(), 15.5);
    EXPECT_FALSE(tree.at(14, 100).raised());
  }
  {
    // without cut_off_tops such frames give nothing
    Tree tree;
    CrownSampler sampler;
    CrownConfig off = cfg;
    off.cut_off_tops = false;
    for (int frame = 0; frame < 3; ++frame)
      EXPECT_EQ(
          sampler.measure(tree.mesh, tree.map, tree.image(120), tree.k, tree.pose, off, BoundaryEstimationConfig{}), 0);
    EXPECT_EQ(sampler.records()[0].outcomes[static_cast<std::size_t>(CrownOutcome::TooShort)], 3);
    EXPECT_EQ(sampler.apply(tree.mesh, tree.map, off), 0);
    EXPECT_FALSE(tree.at(1, 100).raised());
  }
  {
    // whole crowns in three frames and cut-off ones in three: the whole crowns give the top
    Tree tree;
    CrownSampler sampler;
    for (const int shift : {0, 120, 0, 120, 0, 120})
      EXPECT_EQ(
          sampler.measure(tree.mesh, tree.map, tree.image(shift), tree.k, tree.pose, cfg, BoundaryEstimationConfig{}),
          1);
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
    tree.expectCap();
  }
}

// The tree's image with a grey screen nearer the camera hiding everything from `east` metres east
// of the trunk rightwards.
cv::Mat screenedEastOf(const Tree& tree, double east) {
  cv::Mat cut = tree.image();
  const auto edge = project(tree.k, tree.pose.inverse() * Point3(0.1 + east, 20.1, 8.0));
  if (!edge) ADD_FAILURE() << "the screen's edge is not in the image";
  const int u = edge ? static_cast<int>(edge->x()) + 1 : 0;
  cv::rectangle(cut, cv::Point(u, 0), cv::Point(tree.k.width - 1, tree.k.height - 1), cv::Scalar(150, 150, 150),
                cv::FILLED);
  return cut;
}

// A grey screen nearer the camera hides everything from 1.5 m east of the trunk rightwards in five
// frames of eight: those runs give a radius of 1.5 m, the three whole ones 3 m. The lower quartile
// of the radii (crown.radius_quantile at 0.25; the default is the median) takes the cut ones, and the ground 2 m from
// the trunk stays ground; the highest (1) takes the whole crown's cap.
TEST(CrownCompletionTest, TheRadiusIsTheConfiguredQuantileOfTheSamplesRadii) {
  for (const double q : {0.25, 1.0}) {
    Tree tree;
    CrownConfig cfg;
    cfg.min_baseline = 0;  // the same image stands for views along a baseline here
    cfg.radius_quantile = q;
    CrownSampler sampler;
    const cv::Mat whole = tree.image(), cut = screenedEastOf(tree, 1.5);
    for (const bool hidden : {true, false, true, true, false, true, false, true})
      EXPECT_EQ(sampler.measure(tree.mesh, tree.map, hidden ? cut : whole, tree.k, tree.pose, cfg,
                                BoundaryEstimationConfig{}),
                1)
          << q;
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0) << q;
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised) << q;
    EXPECT_NEAR(tree.at(1, 100).height(), 11.0, 0.15) << q;
    if (q < 0.5) {
      EXPECT_TRUE(tree.at(6, 100).raised());    // 1.2 m from the trunk
      EXPECT_FALSE(tree.at(10, 100).raised());  // 2 m
    } else {
      tree.expectCap();
    }
  }
}

// A grey screen nearer the camera hides everything from 2.6 m east of the trunk rightwards in three
// frames of eight: those runs give a radius of about 2.6 m, the five whole ones 3 m. The radii agree
// (their interquartile range within crown.radius_agreement, 0.3, of their median): seen from
// bearings that spread at least crown.agreement_bearings (0 here), their median takes the whole
// crown's cap; from one bearing only (the same camera for every frame) against the default 10
// degrees, or with the agreement off, the lower quartile (crown.radius_quantile at 0.25: at the
// default median the agreement changes nothing) leaves the ground 2.8 m from the trunk.
TEST(CrownCompletionTest, RadiiThatAgreeFromApartGiveTheirMedian) {
  struct Case {
    double agreement, bearings;
    bool median;
  };
  for (const Case c : {Case{0.3, 0.0, true}, Case{0.3, CrownConfig{}.agreement_bearings, false}, Case{0, 0.0, false}}) {
    Tree tree;
    CrownConfig cfg;
    cfg.min_baseline = 0;  // the same image stands for views along a baseline here
    cfg.radius_quantile = 0.25;
    cfg.radius_agreement = c.agreement;
    cfg.agreement_bearings = c.bearings;
    // the screened runs' radii as measured: an ellipse through them would widen them towards 3 m
    cfg.ellipse_radius = false;
    CrownSampler sampler;
    const cv::Mat whole = tree.image(), cut = screenedEastOf(tree, 2.6);
    for (const bool hidden : {true, false, false, true, false, true, false, false})
      ASSERT_EQ(sampler.measure(tree.mesh, tree.map, hidden ? cut : whole, tree.k, tree.pose, cfg,
                                BoundaryEstimationConfig{}),
                1);
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
    EXPECT_EQ(tree.at(14, 100).raised(), c.median) << c.agreement << " " << c.bearings;  // 2.8 m from the trunk
    if (c.median) tree.expectCap();
  }
}

// Boundary estimation took a taller crown behind for the trunk's top and raised its vertex to 40 m.
// Over the trunk the sky shows just above the crown's 11 m top in every frame: with min_samples
// (3) such frames the axis's ceiling lowers the vertex to the crown's top; with two, or with
// crown.axis_ceiling off, it stays where estimation put it.
TEST(CrownCompletionTest, TheSkyOverTheTrunksAxisLowersWhatStandsAboveIt) {
  for (const int frames : {3, 2, 0}) {
    Tree tree;
    CrownConfig cfg;
    cfg.min_baseline = 0;  // the same image stands for views along a baseline here
    cfg.axis_ceiling = frames > 0;
    MeshVertex& trunk = tree.mesh.vertices()[tree.mesh.find(CellIndex(0, 100))];
    trunk.spread = true;
    trunk.recovered_height = 40.0f;
    CrownSampler sampler;
    // the crown's samples in three frames (its foliage before a facade as against the sky), the sky
    // over the trunk in `frames` of them
    for (int frame = 0; frame < 3; ++frame) {
      const bool facade = frames > 0 && frame >= frames;
      EXPECT_EQ(sampler.measure(tree.mesh, tree.map, tree.image(0, facade), tree.k, tree.pose, cfg,
                                BoundaryEstimationConfig{}),
                1)
          << frames;
    }
    sampler.apply(tree.mesh, tree.map, cfg);
    if (frames == 3) {
      EXPECT_NEAR(tree.at(0, 100).height(), 11.0, 0.15);
      EXPECT_EQ(sampler.loweredByCeiling(), 1);
    } else {
      EXPECT_FLOAT_EQ(tree.at(0, 100).height(), 40.0f) << frames;
      EXPECT_EQ(sampler.loweredByCeiling(), 0) << frames;
    }
    // the cap under the crown stands as without a ceiling
    EXPECT_NEAR(tree.at(10, 100).height(), 8.0 + std::sqrt(5.0), 0.2) << frames;
  }
}

// A sampler that measured the tree's crown in three frames of its image (rgb; empty: tree.image()).
CrownSampler sampledThrice(const Tree& tree, const CrownConfig& cfg, const cv::Mat& rgb = cv::Mat()) {
  CrownSampler sampler;
  for (int frame = 0; frame < 3; ++frame) {
    EXPECT_EQ(sampler.measure(tree.mesh, tree.map, rgb.empty() ? tree.image() : rgb, tree.k, tree.pose, cfg,
                              BoundaryEstimationConfig{}),
              1);
  }
  return sampler;
}

TEST(CrownCompletionTest, ATrunkWhoseReturnsSpreadAsTheDriveGoesOnKeepsItsCrown) {
  // measured while one cell wide
  CrownConfig cfg;
  cfg.min_baseline = 0;  // the same image stands for views along a baseline here
  CrownSampler sampler = sampledThrice(Tree(), cfg);
  // by the end its returns run 1.6 m north: wider than a trunk while measuring, not after. The
  // cap's centre moves north with the trunk's, to y = 20.8 m: (0.1, 17.5), 2.6 m south of where the
  // crown was seen, lies 3.3 m from it, outside the 3 m crown
  Tree grown(Tree::Behind::Nothing, false, 8);
  EXPECT_GT(sampler.apply(grown.mesh, grown.map, cfg), 0);
  EXPECT_NEAR(grown.at(1, 100).height(), 11.0, 0.15);
  EXPECT_FALSE(grown.at(17, 100).raised());
  EXPECT_FALSE(grown.at(0, 87).raised());
  // past max_grown_width it is still the tree, all of it within the crown's radius of where the
  // crown was seen: the cap stands there
  Tree past(Tree::Behind::Nothing, false, 8);
  CrownConfig strict = cfg;
  strict.max_grown_width = strict.max_trunk_width;
  EXPECT_GT(sampler.apply(past.mesh, past.map, strict), 0);
  EXPECT_NEAR(past.at(0, 100).height(), 11.0, 0.15);
  EXPECT_TRUE(past.at(0, 87).raised());
  EXPECT_FALSE(past.at(17, 100).raised());
  // grown: not measured as a trunk
  EXPECT_EQ(sampler.measure(grown.mesh, grown.map, grown.image(), grown.k, grown.pose, cfg, BoundaryEstimationConfig{}),
            0);
}

// As the robot nears, the lidar reaches the crown's underside and the trunk's object grows to the
// crown's width: its samples still raise the ground and the underside to the crown's cap. A trunk
// that grew into a facade reaching past the crown's radius raises nothing.
TEST(CrownCompletionTest, ATrunkGrownIntoItsCrownKeepsItsSamplesOneGrownIntoAFacadeDoesNot) {
  CrownConfig cfg;
  cfg.min_baseline = 0;  // the same image stands for views along a baseline here
  CrownSampler sampler = sampledThrice(Tree(), cfg);
  Tree facade(Tree::Behind::Nothing, false, 1, 0, Tree::Grown::IntoFacade);
  EXPECT_EQ(sampler.apply(facade.mesh, facade.map, cfg), 0);
  for (const CrownRecord& r : sampler.records()) EXPECT_EQ(r.verdict, CrownVerdict::NotApplied);
  EXPECT_FALSE(facade.at(0, 101).raised());
  Tree crown(Tree::Behind::Nothing, false, 1, 0, Tree::Grown::IntoCrown);
  ASSERT_FALSE(crown.at(10, 100).raised());
  EXPECT_GT(sampler.apply(crown.mesh, crown.map, cfg), 0);
  for (const CrownRecord& r : sampler.records()) EXPECT_EQ(r.verdict, CrownVerdict::Raised);
  crown.expectCap();
  // the underside, sensed at 5 m, is raised with the ground beyond it
  EXPECT_NEAR(crown.at(5, 100).height(), 8.0 + std::sqrt(9.0 - 1.0), 0.2);
}

// A patch of terrain labelled non-ground, level with the ground around it, is no trunk, whatever
// foliage stands above it in the image: the tree's trunk seen only 0.3 m up measures nothing unless
// the minimum height is dropped.
TEST(CrownCompletionTest, AnObjectLevelWithTheGroundAroundItIsNoTrunk) {
  Tree low;
  low.mesh.vertices()[low.mesh.find(CellIndex(0, 100))].sensed_height = 0.3f;
  CrownConfig cfg;
  CrownSampler sampler;
  EXPECT_EQ(sampler.measure(low.mesh, low.map, low.image(), low.k, low.pose, cfg, BoundaryEstimationConfig{}), 0);
  cfg.min_trunk_height = 0.2;
  EXPECT_EQ(sampler.measure(low.mesh, low.map, low.image(), low.k, low.pose, cfg, BoundaryEstimationConfig{}), 1);
}

// The tree of Tree seen by a camera at the origin 1.6 m up, turned 40 degrees west of north and
// pitched up 20 degrees: the tree stands near the image's right edge, where the image of the
// vertical through its trunk leans 20-30 px towards the centre between the trunk's top and the
// crown's. The image is ray-cast: the crown sphere, the trunk (a vertical cylinder 0.15 m across
// up to the crown), the ground plane and the sky.
// The tree of Tree as tree.pose's camera sees it, ray by ray (pixel centres): the sky, the ground
// (level at 0 m), the trunk (0.15 m in radius, up to the crown's centre) and the crown (its sphere).
cv::Mat renderTree(const Tree& tree) {
  const Vector3 o = tree.pose.translation(), crown(0.1, 20.1, 8.0);
  cv::Mat rgb(tree.k.height, tree.k.width, CV_8UC3);
  for (int v = 0; v < rgb.rows; ++v) {
    for (int u = 0; u < rgb.cols; ++u) {
      const Vector3 d = (tree.pose.linear() * pixelRay(tree.k, Pixel(u + 0.5, v + 0.5))).normalized();
      cv::Vec3b c(120, 170, 235);  // sky
      double t_best = std::numeric_limits<double>::infinity();
      // the crown
      const Vector3 oc = o - crown;
      const double b = oc.dot(d), disc = b * b - (oc.squaredNorm() - 9.0);
      if (disc >= 0 && -b - std::sqrt(disc) > 0) t_best = -b - std::sqrt(disc), c = cv::Vec3b(40, 110, 30);
      // the trunk, below the crown's centre
      const Eigen::Vector2d oh(o.x() - 0.1, o.y() - 20.1), dh(d.x(), d.y());
      const double a2 = dh.squaredNorm(), b2 = oh.dot(dh), c2 = oh.squaredNorm() - 0.15 * 0.15;
      if (a2 > 0 && b2 * b2 - a2 * c2 >= 0) {
        const double t = (-b2 - std::sqrt(b2 * b2 - a2 * c2)) / a2, z = o.z() + t * d.z();
        if (t > 0 && t < t_best && z >= 0 && z <= 8.0) t_best = t, c = cv::Vec3b(90, 60, 30);
      }
      // the ground
      if (d.z() < 0 && -o.z() / d.z() < t_best) c = cv::Vec3b(90, 110, 60);
      rgb.at<cv::Vec3b>(v, u) = c;
    }
  }
  return rgb;
}

TEST(CrownCompletionTest, ACrownSeenByATurnedAndPitchedCameraIsMeasuredAlongItsVertical) {
  Tree tree;
  const double yaw = 40 * M_PI / 180, pitch = 20 * M_PI / 180;
  const Vector3 forward(-std::sin(yaw) * std::cos(pitch), std::cos(yaw) * std::cos(pitch), std::sin(pitch));
  const Vector3 right(std::cos(yaw), std::sin(yaw), 0);
  tree.pose.linear().col(0) = right;
  tree.pose.linear().col(1) = forward.cross(right);
  tree.pose.linear().col(2) = forward;
  tree.pose.translation() = Vector3(0, 0, 1.6);
  const cv::Mat rgb = renderTree(tree);
  // the trunk's top and the crown's top: near the right edge, the crown's apex 20+ px left of the
  // trunk top's column
  const Pixel trunk = *project(tree.k, tree.pose.inverse() * Point3(0.1, 20.1, 3.0));
  const Pixel apex = *project(tree.k, tree.pose.inverse() * Point3(0.1, 20.1, 11.0));
  ASSERT_GT(trunk.x(), 540);
  ASSERT_GT(trunk.x() - apex.x(), 20);
  CrownConfig cfg;
  cfg.min_baseline = 0;
  CrownSampler sampler = sampledThrice(tree, cfg, rgb);
  EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
  // the crown's top in the image is its silhouette: the ray tangent to the sphere over its top,
  // which passes the trunk 11.34 m up (the sphere's apex is 11 m up, nearer the camera)
  const double d = std::hypot(0.1, 20.1);
  const double tangent = std::atan2(6.4, d) + std::asin(3.0 / std::hypot(d, 6.4));
  const double top = 1.6 + d * std::tan(tangent);
  EXPECT_NEAR(top, 11.34, 0.01);
  EXPECT_NEAR(tree.at(1, 100).height(), top, 0.1);
  // a cap no wider than the crown: 2 m from the trunk raised, lower than a 3 m cap's 10.6 m (near
  // the image's corner the nearer end of a row's run lies closer to the leaning vertical: the radius
  // comes out at 2.2 m: an underestimate, which leaves crown cells low rather than raising terrain),
  // beyond 3.4 m nothing
  EXPECT_TRUE(tree.at(10, 100).raised());
  EXPECT_LE(tree.at(10, 100).height(), top - 3.0 + std::sqrt(5.0) + 0.05);
  EXPECT_FALSE(tree.at(17, 100).raised());
  EXPECT_FALSE(tree.at(0, 117).raised());
}

TEST(CrownCompletionTest, ACrownOffTheOpticalAxisIsNotWidenedByThePinhole) {
  // a level camera turned 30 degrees left of the tree: the crown (a sphere of radius 3 m, 20 m away)
  // lies 30 degrees right of the optical axis, where pixels times depth / fx widen it by 1/cos 30 =
  // 1.15. Its silhouette meets the plane through the trunk facing the camera 3 * 20.1 /
  // sqrt(20.1^2 - 9) = 3.03 m from the trunk
  Tree tree;
  const double yaw = 30 * M_PI / 180;
  const Vector3 forward(-std::sin(yaw), std::cos(yaw), 0), right(std::cos(yaw), std::sin(yaw), 0);
  tree.pose.linear().col(0) = right;
  tree.pose.linear().col(1) = Vector3(0, 0, -1);
  tree.pose.linear().col(2) = forward;
  const cv::Mat rgb = renderTree(tree);
  CrownConfig cfg;
  cfg.min_baseline = 0;
  CrownSampler sampler = sampledThrice(tree, cfg, rgb);
  EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
  // raised out to 2.8 m from the trunk, not at 3.2 m (the nearer end of each run, on the side of the
  // optical axis, would give 3.24 m through depth / fx, and 2.96 m measured at the trunk)
  EXPECT_TRUE(tree.at(14, 100).raised());
  EXPECT_TRUE(tree.at(0, 86).raised());
  EXPECT_FALSE(tree.at(16, 100).raised());
  EXPECT_FALSE(tree.at(0, 84).raised());
}

TEST(CrownCompletionTest, FoliageIsGreenAboveRedAndBlue) {
  EXPECT_TRUE(looksLikeFoliage(cv::Vec3b(20, 58, 18), 10));      // leaves in the simulated scenes, lit
  EXPECT_TRUE(looksLikeFoliage(cv::Vec3b(46, 84, 31), 10));      // their lighter marks
  EXPECT_FALSE(looksLikeFoliage(cv::Vec3b(46, 84, 76), 10));     // green only 8 above blue
  EXPECT_FALSE(looksLikeFoliage(cv::Vec3b(115, 158, 224), 10));  // sky
  EXPECT_FALSE(looksLikeFoliage(cv::Vec3b(199, 189, 168), 10));  // a light facade
  EXPECT_FALSE(looksLikeFoliage(cv::Vec3b(92, 66, 43), 10));     // bark
  CrownConfig::Cue cue = CrownConfig::Cue::Sky;
  EXPECT_TRUE(parseCrownCue("foliage", cue));
  EXPECT_EQ(cue, CrownConfig::Cue::Foliage);
  EXPECT_TRUE(parseCrownCue("sky", cue));
  EXPECT_EQ(cue, CrownConfig::Cue::Sky);
  EXPECT_FALSE(parseCrownCue("leaves", cue));
}

TEST(CrownCompletionTest, ACrownBeforeAFacadeIsMeasuredByItsFoliageNotAgainstTheSky) {
  Tree tree;
  const cv::Mat rgb = tree.image(0, true);
  CrownConfig cfg;
  cfg.enabled = true;
  cfg.min_baseline = 0;
  // no sky around the crown: the sky cue measures nothing
  CrownConfig sky = cfg;
  sky.cue = CrownConfig::Cue::Sky;
  CrownSampler by_sky;
  EXPECT_EQ(by_sky.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, sky, BoundaryEstimationConfig{}), 0);
  // the foliage cue follows the bare trunk up to the crown and measures it as against the sky
  CrownSampler sampler;
  for (int frame = 0; frame < 3; ++frame) {
    EXPECT_EQ(sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 1);
  }
  EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
  tree.expectCap();
  // a bare trunk longer than max_trunk_gap below the crown: no crown found above the trunk (2 m of
  // bare trunk between the lidar's 3 m and the crown's 5 m)
  CrownConfig short_gap = cfg;
  short_gap.max_trunk_gap = 1.0;
  CrownSampler gap;
  EXPECT_EQ(gap.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, short_gap, BoundaryEstimationConfig{}), 0);
}

TEST(CrownCompletionTest, OfTwoTrunksUnderOneCrownOnlyTheOneNearestItsCentreTakesTheSample) {
  // the crown of the first tree stands over both trunks in the image: the second trunk's column lies
  // inside it, 14 px from its centre (the crown is 47 px wide each way), so its walk up ends at the
  // same crown top and the crown's widest row is centred near enough over it
  Tree tree(Tree::Behind::Nothing, true);
  CrownConfig cfg;
  cfg.enabled = true;
  cfg.min_baseline = 0;
  CrownSampler sampler;
  for (int frame = 0; frame < 3; ++frame) {
    EXPECT_EQ(sampler.measure(tree.mesh, tree.map, tree.image(), tree.k, tree.pose, cfg, BoundaryEstimationConfig{}),
              1);
  }
  EXPECT_EQ(sampler.trunks(), 1u);
  EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
  EXPECT_NEAR(tree.at(1, 100).height(), 11.0, 0.15);
  // around the second trunk only the first crown's cap: at 2 m east, 2 m north of the first trunk
  // 11 - 3 + sqrt(9 - 8)
  EXPECT_NEAR(tree.at(10, 110).height(), 9.0, 0.25);
  // no cap of its own: 2.2 m north of it (4.3 m from the first trunk) the ground stays ground
  EXPECT_FALSE(tree.at(5, 121).raised());
}

// A nearer tree's crown hides the trunk between the lidar's reach and the crown: the walk up the
// trunk meets foliage that the nearer trunk owns (its column is nearer the run's centre), passes it
// and goes on up the trunk above it to the tree's own crown.
TEST(CrownCompletionTest, TheWalkUpATrunkPassesANearerTreesCrownThatHidesIt) {
  Tree tree(Tree::Behind::Nothing, false, 1, 0, Tree::Grown::No, true);
  const cv::Mat rgb = tree.image();
  // the nearer crown lies on the trunk's vertical between the trunk's sensed top and its crown
  const Pose camera_from_world = tree.pose.inverse();
  const Pixel trunk_top = *project(tree.k, camera_from_world * Point3(0.1, 20.1, 3.0));
  const Pixel crown_bottom = *project(tree.k, camera_from_world * Point3(0.1, 20.1, 5.0));
  const int u = static_cast<int>(trunk_top.x());
  int foliage_rows = 0;
  for (int row = static_cast<int>(crown_bottom.y()) + 2; row < static_cast<int>(trunk_top.y()); ++row)
    foliage_rows += looksLikeFoliage(rgb.at<cv::Vec3b>(row, u), CrownConfig{}.foliage_margin);
  ASSERT_GT(foliage_rows, 10);
  CrownConfig cfg;
  cfg.min_baseline = 0;
  CrownSampler sampler;
  for (int frame = 0; frame < 3; ++frame) sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, cfg, {});
  EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
  tree.expectCap();
}

// The small tree before the trunk (near_tree) is one object 1.4 m across once the lidar reached its
// crown's underside: no trunk, so the nearer-trunk test does not see it, and the walk up the trunk's
// column takes its crown (at 10 m, over the trunk's vertical from 3 to 4.8 m at 20 m) for the tree's.
// With crown.grown_owners (the default) it owns that run as a nearer trunk would, and the walk goes
// on up to the tree's own crown.
TEST(CrownCompletionTest, ANearerTreeGrownIntoItsCrownOwnsTheRunsOfItsCrown) {
  for (const bool owners : {false, true}) {
    Tree tree(Tree::Behind::Nothing, false, 1, 0, Tree::Grown::No, true, true);
    const cv::Mat rgb = tree.image();
    CrownConfig cfg;
    cfg.min_baseline = 0;
    cfg.grown_owners = owners;
    CrownSampler sampler;
    for (int frame = 0; frame < 3; ++frame) sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, cfg, {});
    sampler.apply(tree.mesh, tree.map, cfg);
    if (owners) {
      tree.expectCap();
    } else {
      // the samples are the small tree's crown, seen at the trunk's depth: too narrow for a crown,
      // and the tree keeps its sensed height
      EXPECT_EQ(sampler.records().back().verdict, CrownVerdict::TooNarrow);
      EXPECT_FALSE(tree.at(1, 100).raised());
    }
  }
}

// A crown is at most crown.max_width_to_depth times as wide as it is deep: the tree's crown is 6 m
// deep (5 to 11 m) and 6 m wide, within the default 2; at 0.5 its samples' radius is cut to
// 0.5 * 0.5 * 6 = 1.5 m, so the cap reaches 1 m from the trunk but not 2 m.
TEST(CrownCompletionTest, ACrownIsNoWiderThanMaxWidthToDepthTimesItsDepth) {
  for (const double ratio : {2.0, 0.5}) {
    Tree tree;
    CrownConfig cfg;
    cfg.min_baseline = 0;
    cfg.max_width_to_depth = ratio;
    CrownSampler sampler;
    for (int frame = 0; frame < 3; ++frame) {
      EXPECT_EQ(sampler.measure(tree.mesh, tree.map, tree.image(), tree.k, tree.pose, cfg, {}), 1);
    }
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    if (ratio == 2.0) {
      tree.expectCap();
    } else {
      EXPECT_NEAR(tree.at(1, 100).height(), 11.0, 0.15);
      // 1 m from the trunk on a 1.5 m cap: 11 - 1.5 + sqrt(2.25 - 1)
      EXPECT_NEAR(tree.at(5, 100).height(), 9.5 + std::sqrt(1.25), 0.25);
      EXPECT_FALSE(tree.at(10, 100).raised());
    }
  }
}

// A crown behind the tree's (a disc of 0.8 of its radius, up and to the left in the image) joins its
// outline on the left a quarter of the way down: the left end jumps out there. The walk stops at that
// row unless crown.one_sided lets the right end go on down to the crown's widest row.
TEST(CrownCompletionTest, OneSidedRunsFollowACrownJoinedOnOneSideToItsWidestRow) {
  for (const bool one_sided : {false, true}) {
    Tree tree;
    cv::Mat rgb = tree.image();
    const auto centre = project(tree.k, tree.pose.inverse() * Point3(0.1, 20.1, 8.0));
    ASSERT_TRUE(centre);
    const double r = tree.k.fx * std::asin(3.0 / 20.0);
    cv::circle(rgb,
               cv::Point(static_cast<int>(std::lround(centre->x() - 1.3 * r)),
                         static_cast<int>(std::lround(centre->y() - 0.3 * r))),
               static_cast<int>(std::lround(0.8 * r)), cv::Scalar(40, 110, 30), cv::FILLED);
    CrownConfig cfg;
    cfg.min_baseline = 0;  // the same image stands for views along a baseline here
    cfg.one_sided = one_sided;
    CrownSampler sampler;
    for (int frame = 0; frame < 3; ++frame)
      ASSERT_EQ(sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 1);
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_NEAR(tree.at(1, 100).height(), 11.0, 0.15);
    // 2.6 m east of the trunk, inside the crown: only the walk past the joined row reaches it (the
    // runs above it give a radius of about 2 m)
    EXPECT_EQ(tree.at(13, 100).raised(), one_sided);
    if (one_sided) tree.expectCap();
  }
}

// Foliage behind the crown joins its right side below the apex and widens smoothly down to the
// crown's foot (each row's end 2.3 px further out: no jump), so the widest run is centred 70 px
// east of the trunk and no frame gives a sample (off_centre). The crown's column still shows its top,
// with its apex centred over the trunk and a bare trunk below it: column samples raise the crown's
// cap. Foliage whose shoulder covers the column's top (a crown behind, its apex 23 px east and 52 px
// above the crown's) gives none, and neither does a crown whose foot lies within column_min_bare of
// the lidar's top on the trunk.
TEST(CrownCompletionTest, AJoinedCrownsColumnStillGivesItsTop) {
  struct Case {
    bool column_tops, shoulder;
    double min_bare;
    bool raised;
  };
  for (const Case c : {Case{true, false, 1.0, true}, Case{false, false, 1.0, false}, Case{true, true, 1.0, false},
                       Case{true, false, 2.5, false}}) {
    Tree tree;
    cv::Mat rgb = tree.image();
    const auto centre = project(tree.k, tree.pose.inverse() * Point3(0.1, 20.1, 8.0));
    ASSERT_TRUE(centre);
    const double r = tree.k.fx * std::asin(3.0 / 20.0);
    const int u = static_cast<int>(std::lround(centre->x())), top = static_cast<int>(std::lround(centre->y() - r));
    const std::vector<cv::Point> behind{{u + 2, top + 20}, {u + 160, top + 90}, {u + 2, top + 90}};
    cv::fillConvexPoly(rgb, behind, cv::Scalar(40, 110, 30));
    if (c.shoulder) {
      cv::circle(rgb,
                 cv::Point(u + static_cast<int>(std::lround(0.5 * r)), top - static_cast<int>(std::lround(0.3 * r))),
                 static_cast<int>(std::lround(0.8 * r)), cv::Scalar(40, 110, 30), cv::FILLED);
    }
    CrownConfig cfg;
    cfg.min_baseline = 0;  // the same image stands for views along a baseline here
    cfg.column_tops = c.column_tops;
    cfg.column_min_bare = c.min_bare;  // the crown's foot is 2 m above the lidar's 3 m
    CrownSampler sampler;
    for (int frame = 0; frame < 3; ++frame)
      ASSERT_EQ(sampler.measure(tree.mesh, tree.map, rgb, tree.k, tree.pose, cfg, BoundaryEstimationConfig{}), 0);
    EXPECT_EQ(sampler.records()[0].outcomes[static_cast<std::size_t>(CrownOutcome::OffCentre)], 3);
    EXPECT_EQ(sampler.apply(tree.mesh, tree.map, cfg) > 0, c.raised);
    EXPECT_EQ(sampler.records()[0].verdict, c.raised ? CrownVerdict::RaisedFromColumns : CrownVerdict::TooFewSamples);
    if (c.raised) {
      tree.expectCap();
    } else {
      EXPECT_FALSE(tree.at(1, 100).raised());
    }
  }
}

// With crown.sky_guard, a vertex under the cap through which the sky showed (here: every point more
// than 1.5 m east of the trunk, at any height) is left alone; without it the cap is whole.
TEST(CrownCompletionTest, TheSkyGuardLeavesAloneTheCapsVerticesTheSkyShowedThrough) {
  for (const bool guard : {false, true}) {
    Tree tree;
    CrownConfig cfg;
    cfg.min_baseline = 0;  // the same image stands for views along a baseline here
    cfg.sky_guard = guard;
    CrownSampler sampler;
    for (int frame = 0; frame < 3; ++frame)
      ASSERT_EQ(sampler.measure(tree.mesh, tree.map, tree.image(), tree.k, tree.pose, cfg, {}), 1);
    double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
    const auto sky_east = [&](double x, double, double lo, double hi) {
      lowest = std::min(lowest, lo), highest = std::max(highest, hi);
      return x > 0.1 + 1.5;
    };
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg, sky_east), 0);
    EXPECT_NEAR(tree.at(1, 100).height(), 11.0, 0.15);
    // 2 m west and east of the trunk: the cap (11 - 3 + sqrt(9 - 4)) west, the ground east
    EXPECT_NEAR(tree.at(-10, 100).height(), 8.0 + std::sqrt(5.0), 0.2);
    EXPECT_EQ(tree.at(10, 100).raised(), !guard);
    if (guard) {
      // asked from the cap's base (its top less its radius, 8 m) up to the cap
      EXPECT_NEAR(lowest, 8.0, 0.15);
      EXPECT_NEAR(highest, 11.0, 0.15);
    }
  }
}

// The trunk's own estimate (40 m: the top edge of a taller crown behind it, which the clear line
// does not know) stands above the cap its crown's samples give (11 m): with crown.cap_bounds_trunk
// the trunk is lowered to the cap, without it the estimate stands.
TEST(CrownCompletionTest, TheCapOfTheTrunksOwnCrownBoundsItsEstimates) {
  for (const bool bound : {false, true}) {
    Tree tree;
    CrownConfig cfg;
    cfg.min_baseline = 0;  // the same image stands for views along a baseline here
    cfg.cap_bounds_trunk = bound;
    cfg.axis_ceiling = false;  // the sky over the crown would lower the trunk to it as well
    MeshVertex& trunk = tree.mesh.vertices()[tree.mesh.find(CellIndex(0, 100))];
    trunk.estimates = {{40.0f, 20.0f, 1.6f}};
    trunk.recovered_height = 40.0f;
    CrownSampler sampler = sampledThrice(tree, cfg);
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
    if (bound) {
      EXPECT_NEAR(tree.at(0, 100).height(), 11.0, 0.15);
      EXPECT_EQ(sampler.loweredByCap(), 1);
    } else {
      EXPECT_FLOAT_EQ(tree.at(0, 100).height(), 40.0f);
      EXPECT_EQ(sampler.loweredByCap(), 0);
    }
    tree.expectCap();
  }
}

// A tall crown (an ellipsoid 2 m in radius and 4 m in half height, topped at 13 m) whose runs a
// wider crown behind it joins on both sides from 1.5 m below its top: the walk ends there, where the
// crown is 1.56 m wide (2 sqrt(1 - 0.375^2)). With crown.ellipse_radius the runs kept, on the crown's
// depth from its top to its lowest pixel on the vertical (5 m), give its radius (2 m); without it the
// cap is 1.56 m wide and the ground 1.8 m from the trunk stays ground.
TEST(CrownCompletionTest, AnEllipseThroughTheRunsKeptGivesTheRadiusOfACrownJoinedAboveItsWidest) {
  for (const bool ellipse : {false, true}) {
    Tree tree;
    cv::Mat rgb(tree.k.height, tree.k.width, CV_8UC3, cv::Scalar(120, 170, 235));
    const int horizon = static_cast<int>(tree.k.cy);
    cv::rectangle(rgb, cv::Rect(0, horizon, tree.k.width, tree.k.height - horizon), cv::Scalar(90, 110, 60),
                  cv::FILLED);
    const auto base = project(tree.k, tree.pose.inverse() * Point3(0.1, 20.1, 0.0));
    ASSERT_TRUE(base);
    const double u = base->x(), depth = 20.0;
    // row by row, the height on the trunk's vertical plane and the silhouettes' half widths there
    for (int row = 0; row < horizon; ++row) {
      const double h = 1.6 + depth * (tree.k.cy - (row + 0.5)) / tree.k.fy;
      double w = 0;
      if (std::abs(h - 9.0) < 4.0) w = 2.0 * std::sqrt(1 - (h - 9.0) * (h - 9.0) / 16.0);
      if (h > 6.0 && h < 11.5) w = 4.0;  // the crown behind
      if (h < 5.0) w = 0.1;              // the bare trunk
      if (w == 0) continue;
      const int half_px = static_cast<int>(std::lround(tree.k.fx * w / depth));
      cv::line(rgb, cv::Point(static_cast<int>(std::lround(u)) - half_px, row),
               cv::Point(static_cast<int>(std::lround(u)) + half_px, row),
               h < 5.0 ? cv::Scalar(90, 60, 30) : cv::Scalar(40, 110, 30));
    }
    CrownConfig cfg;
    cfg.min_baseline = 0;  // the same image stands for views along a baseline here
    cfg.ellipse_radius = ellipse;
    CrownSampler sampler = sampledThrice(tree, cfg, rgb);
    EXPECT_GT(sampler.apply(tree.mesh, tree.map, cfg), 0);
    EXPECT_EQ(sampler.records()[0].verdict, CrownVerdict::Raised);
    EXPECT_NEAR(tree.at(1, 100).height(), 13.0, 0.15);
    if (ellipse) {
      // 1.8 m east of the trunk: 13 - 2 + sqrt(4 - 3.24)
      EXPECT_NEAR(tree.at(9, 100).height(), 11.0 + std::sqrt(0.76), 0.3);
      EXPECT_FALSE(tree.at(12, 100).raised());
    } else {
      // 1.2 m east: 13 - 1.56 + sqrt(1.56^2 - 1.44)
      EXPECT_NEAR(tree.at(6, 100).height(), 13.0 - 1.56 + std::sqrt(1.56 * 1.56 - 1.44), 0.3);
      EXPECT_FALSE(tree.at(9, 100).raised());
    }
  }
}

}  // namespace
}  // namespace terrain
