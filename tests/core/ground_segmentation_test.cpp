#include "core/ground_segmentation.hpp"

#include "core/random.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>

namespace terrain {
namespace {

TEST(GroundSegmentationTest, HistogramPeakOfASyntheticColumnIsAtTheKnownHeight) {
  // 200 ground heights around 1.30 m, a wall spread evenly from 1.5 m to 4 m
  std::vector<double> h;
  Random rng(3);
  for (int i = 0; i < 200; ++i) h.push_back(1.30 + 0.02 * rng.normal());
  for (int i = 0; i < 100; ++i) h.push_back(1.5 + 2.5 * i / 100.0);
  EXPECT_NEAR(histogramPeak(h, 0.1), 1.30, 0.02);
  EXPECT_TRUE(std::isnan(histogramPeak({}, 0.1)));
}

// flat ground at z = 0 (voxels 0.2 m) with a 2 m box standing on it
VoxelMap groundWithBox() {
  VoxelMap map(VoxelMapConfig{0.2});
  std::vector<Point3> pts;
  for (int x = -30; x < 30; ++x) {
    for (int y = -30; y < 30; ++y) {
      pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, 0.05);
      const bool box = x >= 0 && x < 10 && y >= 0 && y < 10;
      const bool wall = box && (x == 0 || x == 9 || y == 0 || y == 9);
      for (int z = 1; wall && z < 10; ++z) pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, z * 0.2 + 0.1);
    }
  }
  map.insert(pts, 0);
  return map;
}

TEST(GroundSegmentationTest, GmrfCleansANoisyLabelling) {
  VoxelMap map = groundWithBox();
  GroundSegmentationConfig cfg;
  cfg.histogram = GroundSegmentationConfig::Histogram::Global;
  cfg.stack_height = 0;                                // the paper's terms: the walls' feet are ground here
  cfg.solver = GroundSegmentationConfig::Solver::Icm;  // the paper's solver, whose cleaning this tests
  const SegmentationResult clean = segmentGround(map, cfg);
  // truth: ground voxels are the ones at z index 0; the lowest wall voxel (0.25 m above the
  // ground, inside the +-delta band) is ambiguous and not scored
  auto scored = [&](std::size_t i) { return map.voxels()[i].index.z() != 1; };
  std::size_t wrong_clean = 0;
  for (std::size_t i = 0; i < map.size(); ++i)
    wrong_clean += scored(i) && clean.refined[i] != (map.voxels()[i].index.z() == 0);
  EXPECT_EQ(wrong_clean, 0u);
  // flip 10 % of the rough labels: the refinement must undo nearly all of it
  GmrfProblem p;
  {
    // rebuild the problem from the map through a second segmentation with a noisy start
    std::vector<std::uint8_t> noisy = clean.rough;
    Random rng(5);
    std::size_t flipped = 0;
    for (auto& l : noisy) {
      if (rng.uniform() < 0.1) l ^= 1, ++flipped;
    }
    ASSERT_GT(flipped, 100u);
    // unary terms as segmentGround builds them
    const double a = cfg.alpha;
    p.resize(map.size());
    for (std::size_t i = 0; i < map.size(); ++i) {
      const bool g1 = clean.rough[i];
      p.unary_ground[i] = g1 ? -2 * a : 2 * a;
      p.unary_nonground[i] = g1 ? 2 * a : -2 * a;
      const auto& idx = map.voxels()[i].index;
      p.parity[i] = static_cast<std::uint8_t>((idx.x() + idx.y() + idx.z()) & 1);
    }
    for (std::uint32_t i = 0; i < map.size(); ++i) {
      for (int axis = 0; axis < 3; ++axis) {
        VoxelIndex j = map.voxels()[i].index;
        j[axis] += 1;
        const auto k = map.find(j);
        if (k >= 0) p.link(i, axis, static_cast<std::uint32_t>(k), cfg.beta + cfg.gamma);
      }
    }
    std::vector<std::uint8_t> icm = noisy;
    solveIcm(p, icm, 20, 0);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < map.size(); ++i) wrong += scored(i) && icm[i] != (map.voxels()[i].index.z() == 0);
    EXPECT_LT(wrong, flipped / 20) << "ICM left " << wrong << " of " << flipped << " flipped labels";
    EXPECT_LT(gmrfEnergy(p, icm), gmrfEnergy(p, noisy));
  }
}

// a random binary problem of n nodes on a chain with cross links
GmrfProblem randomProblem(int n, std::uint64_t seed) {
  Random rng(seed);
  GmrfProblem p;
  p.resize(n);
  for (int i = 0; i < n; ++i) {
    p.unary_ground[i] = rng.uniform(-2, 2);
    p.unary_nonground[i] = rng.uniform(-2, 2);
    p.parity[i] = static_cast<std::uint8_t>(i & 1);
  }
  for (int i = 0; i + 1 < n; ++i) p.link(i, 0, i + 1, rng.uniform(0.1, 1.5));
  for (int i = 0; i + 3 < n; i += 2) p.link(i, 1, i + 3, rng.uniform(0.1, 1.5));
  return p;
}

// The foot of something upright: on flat ground, a box's walls stand as unbroken stacks of voxels
// from the ground voxel of their columns up to 1.9 m. With the stack test (ground.stack_height) the
// feet of the walls, in the ground band, and the lowest wall voxels, within delta of the ground,
// are non-ground; every other ground voxel stays ground. Without it, the feet are ground.
TEST(GroundSegmentationTest, TheFootOfAWallIsNotGround) {
  VoxelMap map = groundWithBox();
  GroundSegmentationConfig cfg;
  ASSERT_GT(cfg.stack_height, 0);  // on by default
  const SegmentationResult with = segmentGround(map, cfg);
  cfg.stack_height = 0;
  const SegmentationResult without = segmentGround(map, cfg);
  std::size_t feet = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const VoxelIndex& v = map.voxels()[i].index;
    const bool box = v.x() >= 0 && v.x() < 10 && v.y() >= 0 && v.y() < 10;
    const bool wall = box && (v.x() == 0 || v.x() == 9 || v.y() == 0 || v.y() == 9);
    if (v.z() == 0 && wall) {
      ++feet;
      EXPECT_EQ(with.rough[i], 0) << v.transpose();
      EXPECT_EQ(with.refined[i], 0) << v.transpose();
      EXPECT_EQ(without.rough[i], 1) << v.transpose();
    } else if (v.z() == 0) {
      EXPECT_EQ(with.refined[i], 1) << v.transpose();
    } else {
      EXPECT_EQ(with.refined[i], 0) << v.transpose();
    }
  }
  EXPECT_EQ(feet, 36u);
}

// A car body over the road: the road voxels under its edge, with an empty voxel between them and
// the body, stay ground; the body's lowest voxels (within delta of the road) do not.
TEST(GroundSegmentationTest, GroundUnderAnOverhangStaysGround) {
  VoxelMap map(VoxelMapConfig{0.2});
  std::vector<Point3> pts;
  for (int x = -30; x < 30; ++x) {
    for (int y = -30; y < 30; ++y) {
      pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, 0.05);
      // a body from 0.4 m to 1.4 m over a 2 x 4 m patch
      const bool body = x >= 0 && x < 10 && y >= 0 && y < 20;
      for (int z = 2; body && z < 7; ++z) pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, z * 0.2 + 0.1);
    }
  }
  map.insert(pts, 0);
  const SegmentationResult s = segmentGround(map, GroundSegmentationConfig{});
  for (std::size_t i = 0; i < map.size(); ++i) {
    const VoxelIndex& v = map.voxels()[i].index;
    if (v.z() == 0) {
      EXPECT_EQ(s.rough[i], 1) << v.transpose();
    } else if (v.z() == 2) {
      EXPECT_EQ(s.rough[i], 0) << v.transpose();  // 0.5 m up: its stack rises to 1.3 m
    }
  }
}

// A wall sampled ring by ring, as a single far scan sees it: its column holds the foot, the voxel
// right above it and then every second voxel up to 1.9 m. With ground.stack_gap (0.2 m: one empty
// voxel) the foot is non-ground; with an unbroken stack required (0) it is ground, as the paper's
// terms make it. The wall is two voxels thick so that ICM keeps its feet (min-cut's exact minimum
// joins the feet of so thin a wall to the ground around them).
TEST(GroundSegmentationTest, AWallSampledRingByRingIsAStack) {
  VoxelMap map(VoxelMapConfig{0.2});
  std::vector<Point3> pts;
  for (int x = -30; x < 30; ++x) {
    for (int y = -30; y < 30; ++y) {
      pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, 0.05);
      if (x < 5 || x > 6 || y < 0 || y >= 10) continue;
      for (const int z : {1, 3, 5, 7, 9}) pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, z * 0.2 + 0.1);
    }
  }
  map.insert(pts, 0);
  GroundSegmentationConfig cfg;
  ASSERT_NEAR(cfg.stack_gap, 0.2, 1e-12);  // the default
  cfg.solver = GroundSegmentationConfig::Solver::Icm;
  const SegmentationResult with = segmentGround(map, cfg);
  cfg.stack_gap = 0;
  const SegmentationResult without = segmentGround(map, cfg);
  std::size_t feet = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const VoxelIndex& v = map.voxels()[i].index;
    if (v.z() != 0) continue;
    if (v.x() >= 5 && v.x() <= 6 && v.y() >= 0 && v.y() < 10) {
      ++feet;
      EXPECT_EQ(with.rough[i], 0) << v.transpose();
      EXPECT_EQ(with.refined[i], 0) << v.transpose();
      EXPECT_EQ(without.rough[i], 1) << v.transpose();  // its stack stops at 0.2 m
    } else {
      EXPECT_EQ(with.refined[i], 1) << v.transpose();
    }
  }
  EXPECT_EQ(feet, 20u);
}

// Flat ground with a ditch 0.8 m deep and 2 m wide: the plane and the histogram follow the flat
// ground (z = 0), so the ditch's floor lies 0.8 m below h1, outside the band of +-0.3 m. Being
// the lowest voxels of their columns, below the plane, they are ground with ground.depth_below at
// 2 m, non-ground without it (0). Ground is one or two voxels thick: a voxel right above the
// floor, 0.2 m up, is ground with it as well, and non-ground without. The floor holds 11 % of the
// columns' lowest voxels, more than the lower envelope's lowest tenth: a plane on the envelope
// would lie on the floor and leave the flat ground above the band, so this also checks that the
// plane fit keeps the symmetric fit where that holds more of the voxels (it fails without that
// test).
TEST(GroundSegmentationTest, TheLowestVoxelBelowThePlaneIsGround) {
  VoxelMap map(VoxelMapConfig{0.2});
  std::vector<Point3> pts;
  auto ditch = [](int x, int y) { return x >= 0 && x < 10 && y >= -20 && y < 20; };
  for (int x = -30; x < 30; ++x) {
    for (int y = -30; y < 30; ++y) {
      const double floor = ditch(x, y) ? -0.75 : 0.05;
      pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, floor);
      if (ditch(x, y) && x == 4 && y == 0) pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, floor + 0.2);
    }
  }
  map.insert(pts, 0);
  GroundSegmentationConfig cfg;
  cfg.depth_below = 2.0;
  const SegmentationResult with = segmentGround(map, cfg);
  cfg.depth_below = 0;
  const SegmentationResult without = segmentGround(map, cfg);
  std::size_t floor_voxels = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const VoxelIndex& v = map.voxels()[i].index;
    if (ditch(v.x(), v.y())) {  // the floor and the voxel right above it
      floor_voxels += v.z() == -4;
      EXPECT_EQ(with.rough[i], 1) << v.transpose();
      EXPECT_EQ(with.refined[i], 1) << v.transpose();
      EXPECT_EQ(without.rough[i], 0) << v.transpose();
      EXPECT_EQ(without.refined[i], 0) << v.transpose();
    } else {
      EXPECT_EQ(with.refined[i], 1) << v.transpose();
    }
  }
  EXPECT_EQ(floor_voxels, 400u);
}

// A map of 0.2 m voxels holding one return per column of a 60 x 60 grid of 0.2 m columns around
// the origin, at height z(x, y) of the column's grid index (none where z is NaN).
template <class Z>
VoxelMap oneReturnPerColumn(Z&& z) {
  VoxelMap map(VoxelMapConfig{0.2});
  std::vector<Point3> pts;
  for (int x = -30; x < 30; ++x) {
    for (int y = -30; y < 30; ++y) {
      const double h = z(x, y);
      if (!std::isnan(h)) pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, h);
    }
  }
  map.insert(pts, 0);
  return map;
}

// Flat ground (z = 0) beside a flat ledge 0.7 m high and 3 m wide, whose top the lidar sees over
// a quarter of the map's columns, the ground under it not at all. A least-squares plane through the
// columns' lowest voxels leans towards the ledge and lies more than the band above the ground
// beside it; the plane on their lower envelope lies on the ground, and the histogram's peak is
// sought within R(ground) of it, not at the ledge's top. So every ground voxel is ground and every
// ledge voxel non-ground with ground.lower_envelope (the default); without it, ground beside the
// ledge is lost (with ground.depth_below off, which would take it back as the lowest voxels below
// the plane).
TEST(GroundSegmentationTest, ALowLedgeDoesNotLiftTheGroundPlane) {
  const auto ledge = [](int x) { return x >= 15 && x < 30; };
  const VoxelMap map = oneReturnPerColumn([&](int x, int) { return ledge(x) ? 0.75 : 0.05; });
  GroundSegmentationConfig cfg;
  ASSERT_TRUE(cfg.lower_envelope);  // the default
  cfg.depth_below = 0;
  const SegmentationResult envelope = segmentGroundLabels(map, cfg);
  cfg.lower_envelope = false;
  const SegmentationResult symmetric = segmentGroundLabels(map, cfg);
  std::size_t ground = 0, lost = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const VoxelIndex& v = map.voxels()[i].index;
    if (ledge(v.x())) {
      EXPECT_EQ(envelope.refined[i], 0) << v.transpose();
      continue;
    }
    ++ground;
    EXPECT_EQ(envelope.refined[i], 1) << v.transpose();
    EXPECT_NEAR(envelope.ground_height[i], 0.05, 0.05) << v.transpose();
    lost += symmetric.refined[i] == 0;
  }
  EXPECT_EQ(ground, 45u * 60u);
  EXPECT_GT(lost, 100u);  // the symmetric fit loses ground beside the ledge
}

// Flat ground (z = 0) with a ridge along y: from column x = 7 the ground rises 0.1 m per 0.2 m
// column to 0.7 m at x = 14 and falls back as steeply (a bank, a berm, the foot of a slope where
// the tile's plane does not turn with it), sensed two returns thick (0.12 m apart, as in a map of
// several sweeps), so that each column shares a voxel layer with the next. The ridge holds a
// quarter of the columns: the plane and h1 lie on the flat ground, and the ridge's top voxels lie
// outside R(ground) and G1 (without ground.rise_above, 0, they are non-ground). They lie within
// ground.rise_above (1 m) of h1, and their weak terms let their links to the slopes on both sides
// decide: every voxel is ground. A ledge with no slope up to it (above) stays non-ground with it;
// a wide plateau on such a ridge would too (its weak terms outweigh the few links).
TEST(GroundSegmentationTest, ARidgeThatContinuesTheGroundIsGround) {
  VoxelMap map(VoxelMapConfig{0.2});
  std::vector<Point3> pts;
  const auto height = [](int x) { return 0.05 + std::max(0.0, 0.7 - 0.1 * std::abs(x - 14)); };
  for (int x = -30; x < 30; ++x) {
    for (int y = -30; y < 30; ++y) {
      pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, height(x));
      pts.emplace_back(x * 0.2 + 0.1, y * 0.2 + 0.1, height(x) + 0.12);
    }
  }
  map.insert(pts, 0);
  GroundSegmentationConfig cfg;
  ASSERT_EQ(cfg.rise_above, 1.0);  // the default
  const SegmentationResult with = segmentGroundLabels(map, cfg);
  cfg.rise_above = 0;
  const SegmentationResult without = segmentGroundLabels(map, cfg);
  std::size_t top = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const VoxelIndex& v = map.voxels()[i].index;
    EXPECT_EQ(with.refined[i], 1) << v.transpose();
    if (map.voxels()[i].height > with.ground_height[i] + cfg.range_margin) {
      ++top;
      EXPECT_EQ(with.rough[i], 0) << v.transpose();
      EXPECT_EQ(without.refined[i], 0) << v.transpose();
    }
  }
  EXPECT_GE(top, 3u * 60u);  // the ridge's top: three voxels or more in each row
}

// Flat ground (z = 0) and the side of a car seen from beside it: a column-wide row whose lowest
// return lies 0.2 m up (the body above its shadow), with nothing sensed behind it. Inside the band and
// with no stack above, they would be ground by the histogram and the GMRF alike; they stand a step
// above the ground tops of the columns around them (most of which are ground), so with ground.step_height at
// 0.1 m they are non-ground, and the ground around them stays ground.
TEST(GroundSegmentationTest, AVoxelSteppingUpFromTheGroundIsNotGround) {
  const auto side = [](int x, int y) { return x == 10 && y >= 0 && y < 20; };
  const auto shadow = [](int x, int y) { return x > 10 && x < 20 && y >= 0 && y < 20; };
  const VoxelMap map = oneReturnPerColumn([&](int x, int y) {
    return shadow(x, y) ? std::numeric_limits<double>::quiet_NaN() : side(x, y) ? 0.27 : 0.05;
  });
  for (const auto solver : {GroundSegmentationConfig::Solver::MinCut, GroundSegmentationConfig::Solver::Icm}) {
    GroundSegmentationConfig cfg;
    cfg.solver = solver;
    cfg.step_height = 0.1;
    const SegmentationResult with = segmentGroundLabels(map, cfg);
    cfg.step_height = 0;
    const SegmentationResult without = segmentGroundLabels(map, cfg);
    std::size_t steps = 0;
    for (std::size_t i = 0; i < map.size(); ++i) {
      const VoxelIndex& v = map.voxels()[i].index;
      if (side(v.x(), v.y())) {
        ++steps;
        EXPECT_EQ(with.rough[i], 0) << v.transpose();
        EXPECT_EQ(with.refined[i], 0) << v.transpose();
        EXPECT_EQ(without.refined[i], 1) << v.transpose();
      } else {
        EXPECT_EQ(with.refined[i], 1) << v.transpose();
      }
    }
    EXPECT_EQ(steps, 20u);
  }
}

// Thick ground is no step: ground rising 0.5 m per metre (27 deg), sampled four times across each
// column, so that a column spans 0.1 m of height and many hold two voxels (the tile's plane's rise
// across a column is allowed); flat ground sensed 0.3 m thick (a map of sweeps with pose error),
// every column holding two voxels whose means lie 0.28 m apart (each column's ground top is the
// upper one); and flat ground sensed 0.36 m thick, every column holding three voxels (0.05, 0.25
// and 0.41 m: an unbroken stack within the stack test's 0.4 m, so the ground top is the third; with
// the voxel right above the lowest as the top, the third voxels stand 0.16 m above the level and
// would be steps). Every voxel is ground.
TEST(GroundSegmentationTest, ThickGroundIsNoStep) {
  enum Case { Slope, TwoVoxels, ThreeVoxels };
  for (const Case c : {Slope, TwoVoxels, ThreeVoxels}) {
    SCOPED_TRACE(c == Slope ? "slope" : c == TwoVoxels ? "two voxels thick" : "three voxels thick");
    VoxelMap map(VoxelMapConfig{0.2});
    std::vector<Point3> pts;
    for (int i = -120; i < 120; ++i) {
      for (int y = -30; y < 30; ++y) {
        const double x = i * 0.05 + 0.025;
        if (c == Slope) {
          pts.emplace_back(x, y * 0.2 + 0.1, 0.5 * x + 0.03);
        } else if (c == TwoVoxels) {
          pts.emplace_back(x, y * 0.2 + 0.1, i % 2 ? 0.05 : 0.33);
        } else {
          pts.emplace_back(x, y * 0.2 + 0.1, std::array<double, 3>{0.05, 0.25, 0.41}[(i + 120) % 3]);
        }
      }
    }
    map.insert(pts, 0);
    GroundSegmentationConfig cfg;
    cfg.step_height = 0.1;
    const SegmentationResult s = segmentGroundLabels(map, cfg);
    std::size_t upper = 0;
    for (std::size_t i = 0; i < map.size(); ++i) {
      const VoxelIndex& v = map.voxels()[i].index;
      EXPECT_EQ(s.refined[i], 1) << v.transpose();
      upper += map.find(VoxelIndex(v.x(), v.y(), v.z() - 1)) >= 0;
    }
    EXPECT_GT(upper, c == Slope ? 1000u : 3000u);  // columns of several voxels are common
  }
}

TEST(GroundSegmentationTest, MinCutIsExactAndNeverWorseThanIcm) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const int n = 14;
    const GmrfProblem p = randomProblem(n, seed);
    double best = 1e18;
    for (int mask = 0; mask < (1 << n); ++mask) {
      std::vector<std::uint8_t> l(n);
      for (int i = 0; i < n; ++i) l[i] = (mask >> i) & 1;
      best = std::min(best, gmrfEnergy(p, l));
    }
    std::vector<std::uint8_t> cut(n, 0), icm(n, 0);
    solveMinCut(p, cut);
    solveIcm(p, icm, 100, 1);
    EXPECT_NEAR(gmrfEnergy(p, cut), best, 1e-9) << "seed " << seed;
    EXPECT_LE(gmrfEnergy(p, cut), gmrfEnergy(p, icm) + 1e-9) << "seed " << seed;
  }
}

// one solver, its graph kept from call to call, on problems that grow and shrink: the labels of a
// fresh solve every time, and the exact minimum on those small enough to enumerate
TEST(GroundSegmentationTest, AReusedMinCutSolverGivesTheLabelsOfAFreshOne) {
  MinCutSolver solver;
  for (const int n : {14, 3000, 12, 20000, 500}) {
    const GmrfProblem p = randomProblem(n, 100 + n);
    std::vector<std::uint8_t> reused(n, 0), fresh(n, 0);
    solver.solve(p, reused);
    solveMinCut(p, fresh);
    EXPECT_EQ(reused, fresh) << n;
    if (n <= 14) {
      double best = 1e18;
      std::vector<std::uint8_t> l(n);
      for (int mask = 0; mask < (1 << n); ++mask) {
        for (int i = 0; i < n; ++i) l[i] = (mask >> i) & 1;
        best = std::min(best, gmrfEnergy(p, l));
      }
      EXPECT_NEAR(gmrfEnergy(p, reused), best, 1e-9) << n;
    }
  }
}

TEST(GroundSegmentationTest, PairWeightFollowsTheExponentialOfTheHeightDifference) {
  GroundSegmentationConfig cfg;
  cfg.beta = 0, cfg.gamma = 2.0;
  double worst = 0;
  for (int i = 0; i <= 200000; ++i) {
    const float d = i * 1e-4f;  // 0 .. 20 m
    const double exact = cfg.gamma * std::exp(-static_cast<double>(d));
    worst = std::max(worst, std::abs(pairWeight(cfg, 0.0f, d) - exact) / exact);
    EXPECT_EQ(pairWeight(cfg, 3.0f, 3.0f + d), pairWeight(cfg, 3.0f + d, 3.0f));
  }
  EXPECT_LT(worst, 2e-7);
  // e^-d itself (beta 0, gamma 1) is the correctly rounded float of e^-d but for rare inputs, and
  // then one unit in the last place off (the rounding of std::exp in double as reference)
  cfg.beta = 0, cfg.gamma = 1;
  int off = 0;
  for (int i = 0; i <= 200000; ++i) {
    const float d = i * 1e-4f;
    const float exact = static_cast<float>(std::exp(-static_cast<double>(d)));
    const float w = pairWeight(cfg, 0.0f, d);
    if (w != exact) {
      ++off;
      EXPECT_TRUE(w == std::nextafter(exact, 0.0f) || w == std::nextafter(exact, 1.0f)) << "d = " << d;
    }
  }
  EXPECT_LE(off, 2);
  cfg.gamma = 2.0;
  cfg.beta = 0.25;
  EXPECT_FLOAT_EQ(pairWeight(cfg, 0.0f, 1.0f), 0.25f + 2.0f * std::exp(-1.0f));
  EXPECT_FLOAT_EQ(pairWeight(cfg, 0.0f, 120.0f), 0.25f);
  EXPECT_FLOAT_EQ(pairWeight(cfg, 0.0f, std::numeric_limits<float>::infinity()), 0.25f);
  EXPECT_TRUE(std::isnan(pairWeight(cfg, 0.0f, std::numeric_limits<float>::quiet_NaN())));
}

// the energies ICM sums during its sweeps are those of the labellings it starts from and returns,
// whether it converges, runs out of sweeps or makes none
TEST(GroundSegmentationTest, IcmReportsTheEnergiesOfItsFirstAndLastLabelling) {
  const GmrfProblem p = randomProblem(5000, 4);
  Random rng(5);
  std::vector<std::uint8_t> start(5000);
  for (auto& l : start) l = rng.uniform(0, 1) < 0.5;
  for (const int max_sweeps : {50, 1, 0}) {
    std::vector<std::uint8_t> labels = start;
    const IcmResult r = solveIcm(p, labels, max_sweeps, 2);
    const double initial = gmrfEnergy(p, start), final = gmrfEnergy(p, labels);
    EXPECT_NEAR(r.energy_initial, initial, 1e-9) << max_sweeps << " sweeps";
    EXPECT_NEAR(r.energy_final, final, 1e-9) << max_sweeps << " sweeps";
    if (max_sweeps == 50) {
      EXPECT_LT(r.sweeps, 50);
      EXPECT_LT(final, initial - 100);
    } else {
      EXPECT_EQ(r.sweeps, max_sweeps);
    }
  }
}

// after its first sweep ICM only revisits nodes next to a change: the labels and sweeps must be
// those of plain red-black sweeps over every node
TEST(GroundSegmentationTest, IcmGivesTheLabelsOfFullSweeps) {
  const GmrfProblem p = randomProblem(3000, 8);
  Random rng(2);
  std::vector<std::uint8_t> start(3000);
  for (auto& l : start) l = rng.uniform(0, 1) < 0.5;
  for (const int max_sweeps : {1, 2, 3, 50}) {
    std::vector<std::uint8_t> plain = start;
    int plain_sweeps = 0;
    for (int sweep = 0; sweep < max_sweeps; ++sweep) {
      bool changed = false;
      for (std::uint8_t colour = 0; colour < 2; ++colour) {
        for (std::uint32_t v = 0; v < p.size(); ++v) {
          if (p.parity[v] != colour) continue;
          std::vector<std::uint8_t> with = plain;
          with[v] = 1;
          const double g = gmrfEnergy(p, with);
          with[v] = 0;
          const double ng = gmrfEnergy(p, with);
          const std::uint8_t best = g < ng - 1e-9 ? 1 : (ng < g - 1e-9 ? 0 : plain[v]);
          changed |= best != plain[v];
          plain[v] = best;
        }
      }
      if (!changed) break;
      ++plain_sweeps;
    }
    if (max_sweeps == 50) {
      EXPECT_GE(plain_sweeps, 3);  // revisits happen
    }
    std::vector<std::uint8_t> labels = start;
    EXPECT_EQ(solveIcm(p, labels, max_sweeps, 2).sweeps, plain_sweeps) << max_sweeps;
    EXPECT_EQ(labels, plain) << max_sweeps;
  }
}

TEST(GroundSegmentationTest, IcmRefusesAProblemThatIsNotAGrids) {
  GmrfProblem same_colour = randomProblem(10, 3);
  same_colour.link(4, 2, 6, 1.0f);  // nodes 4 and 6 are both of parity 0
  std::vector<std::uint8_t> labels(10, 0);
  EXPECT_THROW(solveIcm(same_colour, labels, 5, 1), std::invalid_argument);
  GmrfProblem two_forward = randomProblem(10, 3);
  two_forward.next[3 * 2 + 0] = 5;  // 2 -> 5 along x, but 5's backward neighbour along x is 4
  EXPECT_THROW(solveIcm(two_forward, labels, 5, 1), std::invalid_argument);
  GmrfProblem stale_back = randomProblem(10, 3);
  stale_back.prev[3 * 7 + 2] = 2;  // 7 says 2 is before it along z, but 2 has no forward neighbour there
  ASSERT_EQ(stale_back.next[3 * 2 + 2], GmrfProblem::kNone);
  EXPECT_THROW(solveIcm(stale_back, labels, 5, 1), std::invalid_argument);
  EXPECT_EQ(labels, std::vector<std::uint8_t>(10, 0));
  EXPECT_NO_THROW(solveIcm(randomProblem(10, 3), labels, 5, 1));
}

TEST(GroundSegmentationTest, IcmGivesTheSameLabelsWhateverTheThreadCount) {
  const GmrfProblem p = randomProblem(5000, 9);
  std::vector<std::uint8_t> a(5000, 0), b(5000, 0);
  solveIcm(p, a, 50, 1);
  solveIcm(p, b, 50, 2);
  EXPECT_EQ(a, b);
}

// a 12-degree slope with a box on it: the global histogram misses most of the slope, the local
// one follows it
TEST(GroundSegmentationTest, LocalHistogramFollowsASlope) {
  VoxelMap map(VoxelMapConfig{0.2});
  std::vector<Point3> pts;
  const double slope = std::tan(12 * M_PI / 180);
  for (double x = -20; x < 20; x += 0.2) {
    for (double y = -10; y < 10; y += 0.2) pts.emplace_back(x + 0.1, y + 0.1, slope * x);
  }
  for (double z = 0.1; z < 3; z += 0.2) {
    for (double y = 0; y < 4; y += 0.2) pts.emplace_back(5.1, y + 0.1, slope * 5 + z);
  }
  map.insert(pts, 0);
  auto accuracy = [&](GroundSegmentationConfig::Histogram h) {
    GroundSegmentationConfig cfg;
    cfg.histogram = h;
    const auto r = segmentGround(map, cfg);
    std::size_t right = 0;
    for (std::size_t i = 0; i < map.size(); ++i) {
      const auto& v = map.voxels()[i];
      const bool truth =
          v.height < slope * ((v.index.x() + 0.5) * 0.2) + 0.15 || std::abs(v.index.x() * 0.2 + 0.1 - 5.1) > 0.15;
      right += (r.refined[i] != 0) == truth;
    }
    return static_cast<double>(right) / map.size();
  };
  const double global = accuracy(GroundSegmentationConfig::Histogram::Global);
  const double local = accuracy(GroundSegmentationConfig::Histogram::Local);
  EXPECT_LT(global, 0.5);
  EXPECT_GT(local, 0.97);
}

// rolling terrain 120 m x 60 m with walls every 20 m and posts, seen in four strips as a robot
// driving along x would add them; with second_look, the second strip sees the first one's far end
// again, 5 cm higher
std::vector<std::vector<Point3>> strips(bool second_look = true) {
  std::vector<std::vector<Point3>> out(4);
  Random rng(5);
  for (int x = 0; x < 600; ++x) {
    for (int y = 0; y < 300; ++y) {
      const double px = x * 0.2 + 0.1, py = y * 0.2 + 0.1;
      const double ground = 0.8 * std::sin(px / 11) + 0.4 * std::cos(py / 7) + 0.02 * px;
      auto& strip = out[static_cast<std::size_t>(x / 150)];
      strip.emplace_back(px, py, ground + 0.01 * rng.normal());
      if (x % 100 == 50 || (x % 37 == 0 && y % 41 == 0)) {
        for (int z = 1; z < 12; ++z) strip.emplace_back(px, py, ground + z * 0.2);
      }
    }
  }
  // a second look at the first strip's far end while passing the second
  for (const auto& p : second_look ? out[0] : std::vector<Point3>{}) {
    if (p.x() > 25) out[1].push_back(p + Point3(0, 0, 0.05));
  }
  return out;
}

// Segments strips() incrementally with cfg and compares the result with the whole-map segmentation.
void expectIncrementalMatchesWhole(const GroundSegmentationConfig& cfg) {
  SCOPED_TRACE("tile_radius " + std::to_string(cfg.tile_radius));
  VoxelMap map(VoxelMapConfig{0.2});
  IncrementalGroundSegmentation inc(cfg);
  std::size_t refitted_last = 0;
  for (const auto& strip : strips()) {
    map.insert(strip, 0);
    inc.update(map);
    refitted_last = inc.lastStats().refitted_tiles;
  }
  const SegmentationResult whole = segmentGroundLabels(map, cfg);
  const SegmentationResult& part = inc.result();
  ASSERT_EQ(part.refined.size(), map.size());
  // the last strip touched only its own tiles and their neighbours
  EXPECT_LT(refitted_last, static_cast<std::size_t>(whole.tiles));
  // planes are refitted exactly as the whole-map segmentation fits them
  std::size_t same_height = 0, same_rough = 0, same_refined = 0, ground = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    same_height += part.ground_height[i] == whole.ground_height[i];
    same_rough += part.rough[i] == whole.rough[i];
    same_refined += part.refined[i] == whole.refined[i];
    ground += part.refined[i];
  }
  EXPECT_EQ(same_height, map.size());
  EXPECT_EQ(same_rough, map.size());
  // the GMRF solved tile group by tile group with fixed surroundings: nearly the same labels
  EXPECT_GT(static_cast<double>(same_refined) / map.size(), 0.995) << same_refined << " of " << map.size();
  EXPECT_GT(ground, map.size() / 2);
  // and the labels are in the map
  for (std::size_t i = 0; i < map.size(); i += 97) {
    EXPECT_EQ(map.voxels()[i].label, part.refined[i] ? VoxelLabel::Ground : VoxelLabel::NonGround);
  }
}

TEST(IncrementalGroundSegmentationTest, MatchesTheWholeMapSegmentation) {
  expectIncrementalMatchesWhole(GroundSegmentationConfig{});
}

// Windows of one tile (no neighbours in a tile's plane and histogram) and of five by five tiles:
// the update re-segments the tiles whose window reaches a new voxel and lays out the tiles around
// them, whose labels it holds fixed.
TEST(IncrementalGroundSegmentationTest, MatchesTheWholeMapSegmentationWithOtherWindows) {
  for (const int radius : {0, 2}) {
    GroundSegmentationConfig cfg;
    cfg.tile_radius = radius;
    expectIncrementalMatchesWhole(cfg);
  }
}

// The same strips across the origin, off the tile grid: the whole-map segmentation groups voxels
// into tiles from the map's index extent, the incremental one tile by tile as points arrive; both
// put every voxel in the same tile, so their ground heights and rough classes agree exactly.
TEST(IncrementalGroundSegmentationTest, MatchesTheWholeMapSegmentationAcrossTheOrigin) {
  VoxelMap map(VoxelMapConfig{0.2});
  GroundSegmentationConfig cfg;
  IncrementalGroundSegmentation inc(cfg);
  // without the second look, whose points change the heights of voxels in tiles that no new voxel
  // makes due (their planes stay as they were until the run's final whole-map segmentation)
  for (auto strip : strips(false)) {
    for (auto& p : strip) p += Point3(-61.3, -17.1, 0);
    map.insert(strip, 0);
    inc.update(map);
  }
  ASSERT_LT(map.lowestIndex().x(), 0);
  ASSERT_LT(map.lowestIndex().y(), 0);
  ASSERT_GT(map.highestIndex().x(), 0);
  ASSERT_GT(map.highestIndex().y(), 0);
  const SegmentationResult whole = segmentGroundLabels(map, cfg);
  const SegmentationResult& part = inc.result();
  ASSERT_EQ(part.refined.size(), map.size());
  // x from -61.2 to 58.6 m and y from -17.0 to 42.8 m: 21 x 11 tiles of 6 m
  EXPECT_EQ(whole.tiles, 21 * 11);
  std::size_t same_height = 0, same_rough = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    same_height += part.ground_height[i] == whole.ground_height[i];
    same_rough += part.rough[i] == whole.rough[i];
  }
  EXPECT_EQ(same_height, map.size());
  EXPECT_EQ(same_rough, map.size());
}

// the whole-map segmentation, every stage parallel over tiles or nodes, with either solver
TEST(GroundSegmentationTest, SameResultWhateverTheThreadCount) {
  VoxelMap map(VoxelMapConfig{0.2});
  for (const auto& strip : strips()) map.insert(strip, 0);
  for (const auto solver : {GroundSegmentationConfig::Solver::Icm, GroundSegmentationConfig::Solver::MinCut}) {
    SegmentationResult r[2];
    for (int threads : {1, 2}) {
      GroundSegmentationConfig cfg;
      cfg.solver = solver;
      cfg.threads = threads;
      r[threads - 1] = segmentGroundLabels(map, cfg);
    }
    EXPECT_EQ(r[0].rough, r[1].rough);
    EXPECT_EQ(r[0].refined, r[1].refined);
    EXPECT_EQ(r[0].ground_height, r[1].ground_height);
    EXPECT_EQ(r[0].energy_rough, r[1].energy_rough);
    EXPECT_EQ(r[0].energy_refined, r[1].energy_refined);
    EXPECT_LT(r[0].energy_refined, r[0].energy_rough);
  }
}

TEST(IncrementalGroundSegmentationTest, SameLabelsWhateverTheThreadCount) {
  std::vector<std::uint8_t> labels[2];
  for (int threads : {1, 2}) {
    VoxelMap map(VoxelMapConfig{0.2});
    GroundSegmentationConfig cfg;
    cfg.threads = threads;
    IncrementalGroundSegmentation inc(cfg);
    for (const auto& strip : strips()) {
      map.insert(strip, 0);
      inc.update(map);
    }
    labels[threads - 1] = inc.result().refined;
  }
  EXPECT_EQ(labels[0], labels[1]);
}

}  // namespace
}  // namespace terrain

namespace terrain {
namespace {

// One 6 m tile of flat ground, then a few voxels more in it: with defer_share they wait (unlabelled)
// until they make up that share of the tile's voxels.
TEST(IncrementalGroundSegmentationTest, DeferredTilesWaitForTheirShareOfNewVoxels) {
  std::vector<Point3> ground;
  for (int i = 0; i < 30; ++i) {
    for (int j = 0; j < 30; ++j) ground.emplace_back(0.1 + 0.2 * i, 0.1 + 0.2 * j, 0.0);
  }
  auto box = [](int n, double z) {  // n voxels of a box 1 m up, in the same tile
    std::vector<Point3> pts;
    for (int i = 0; i < n; ++i) pts.emplace_back(2.1 + 0.2 * (i % 10), 2.1 + 0.2 * (i / 10), z);
    return pts;
  };
  for (const double share : {0.0, 0.1}) {
    VoxelMap map(VoxelMapConfig{0.2});
    GroundSegmentationConfig cfg;
    cfg.defer_share = share;
    IncrementalGroundSegmentation inc(cfg);
    map.insert(ground, 0);
    inc.update(map);
    EXPECT_EQ(inc.lastStats().touched_tiles, 1u);
    // 20 new voxels: 20 / 920 < 0.1, so with the share they wait
    const std::size_t first_box = map.size();
    map.insert(box(20, 1.1), 1);
    inc.update(map);
    EXPECT_EQ(inc.lastStats().touched_tiles, share > 0 ? 0u : 1u) << share;
    EXPECT_EQ(map.voxels()[first_box].label, share > 0 ? VoxelLabel::Unknown : VoxelLabel::NonGround) << share;
    // 80 more in a layer above: 100 new voxels since the tile was last segmented, 100 / 1000 >= 0.1
    map.insert(box(80, 1.3), 2);
    inc.update(map);
    EXPECT_EQ(inc.lastStats().touched_tiles, 1u) << share;
    EXPECT_EQ(map.voxels()[first_box].label, VoxelLabel::NonGround) << share;
    EXPECT_EQ(map.voxels()[0].label, VoxelLabel::Ground) << share;
  }
}

// A voxel whose single-site terms cancel (0.3-0.5 m above its ground: not in G1, inside R) and
// whose only neighbour lies in a tile that the update holds fixed takes that neighbour's label.
// Tiles (6 m): x 0-6 m, ground at 0.1 m, and a voxel u at 0.21 m on its east edge; x 6-12 m, ground
// at 0.01 m but for the column of a voxel v at 0.39 m next to u. With the default window (one tile
// each way) adding ground at x 12-18 m re-segments the second tile, not the first; with a window of
// one tile, a new voxel in the second tile does.
TEST(IncrementalGroundSegmentationTest, ANeighbourHeldFixedAcrossTheRefittedTilesEdgeCounts) {
  std::vector<Point3> first, later;
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < 30; ++j) {
      const Point3 p(0.1 + 0.2 * i, 0.1 + 0.2 * j, i < 30 ? 0.1 : 0.01);
      if (i != 30 || j != 15) first.push_back(p);
      if (i < 30) later.emplace_back(p.x() + 12.0, p.y(), 0.01);
    }
  }
  first.emplace_back(5.9, 3.1, 0.21);  // u
  first.emplace_back(6.1, 3.1, 0.39);  // v
  for (const int radius : {1, 0}) {
    SCOPED_TRACE("tile_radius " + std::to_string(radius));
    VoxelMap map(VoxelMapConfig{0.2});
    GroundSegmentationConfig cfg;
    cfg.tile_radius = radius;
    cfg.defer_share = 0;
    IncrementalGroundSegmentation inc(cfg);
    map.insert(first, 0);
    inc.update(map);
    const std::int64_t u = map.find(VoxelIndex(29, 15, 1)), v = map.find(VoxelIndex(30, 15, 1));
    ASSERT_GE(u, 0);
    ASSERT_GE(v, 0);
    if (radius == 1) {
      map.insert(later, 1);
    } else {
      // one new voxel in the second tile's far corner makes it due (defer_share 0)
      map.insert({Point3(11.9, 0.1, 0.21)}, 1);
    }
    inc.update(map);
    EXPECT_EQ(inc.lastStats().refitted_tiles, radius == 1 ? 2u : 1u);
    const SegmentationResult& r = inc.result();
    // u is ground on its own terms; v's terms cancel, and its rough class is non-ground
    EXPECT_TRUE(r.rough[u] && r.refined[u]);
    const double above = map.voxels()[v].height - r.ground_height[v];
    ASSERT_GT(above, cfg.delta);
    ASSERT_LE(above, cfg.range_margin);
    ASSERT_FALSE(r.rough[v]);
    // so its pair with u decides
    EXPECT_TRUE(r.refined[v]);
    EXPECT_EQ(map.voxels()[v].label, VoxelLabel::Ground);
  }
}

// Two patches of flat ground 150 km apart (a GPS jump, say): the map's extent holds 6e8 tiles of
// which two are occupied; both whole-map and incremental segmentation label them without a grid
// over the whole extent.
TEST(IncrementalGroundSegmentationTest, PatchesFarApartAreSegmentedWithoutAGridOverTheExtent) {
  std::vector<Point3> ground;
  for (const double offset : {0.0, 150000.0}) {
    for (int i = 0; i < 30; ++i) {
      for (int j = 0; j < 30; ++j)
        ground.emplace_back(offset + 0.1 + 0.2 * i, offset + 0.1 + 0.2 * j, 0.05 * (offset > 0));
    }
  }
  VoxelMap map(VoxelMapConfig{0.2});
  map.insert(ground, 0);
  ASSERT_EQ(map.size(), 1800u);
  const SegmentationResult whole = segmentGroundLabels(map, GroundSegmentationConfig{});
  EXPECT_EQ(whole.tiles, 2);
  IncrementalGroundSegmentation inc(GroundSegmentationConfig{});
  inc.update(map);
  EXPECT_EQ(inc.lastStats().refitted_tiles, 2u);
  for (std::size_t i = 0; i < map.size(); ++i) {
    EXPECT_EQ(whole.refined[i], 1) << i;
    EXPECT_EQ(inc.result().refined[i], 1) << i;
    EXPECT_EQ(inc.result().ground_height[i], whole.ground_height[i]) << i;
  }
  EXPECT_NEAR(whole.ground_height[0], 0.0, 1e-6);
  EXPECT_NEAR(whole.ground_height[900], 0.05, 1e-6);
}

// The tile at (-1, -1), whose packed key has every bit set, is taken in and touched like any other.
TEST(IncrementalGroundSegmentationTest, TheTileSouthWestOfTheOriginIsSegmented) {
  std::vector<Point3> ground;
  for (int i = 0; i < 30; ++i) {
    for (int j = 0; j < 30; ++j) ground.emplace_back(-5.9 + 0.2 * i, -5.9 + 0.2 * j, 0.0);
  }
  VoxelMap map(VoxelMapConfig{0.2});
  IncrementalGroundSegmentation inc(GroundSegmentationConfig{});
  map.insert(ground, 0);
  inc.update(map);
  EXPECT_EQ(inc.lastStats().touched_tiles, 1u);
  EXPECT_EQ(inc.lastStats().voxels, 900u);
  EXPECT_EQ(map.voxels()[0].label, VoxelLabel::Ground);
  // the same points again: no new voxel, so no tile is due and nothing is re-segmented (the whole
  // map is segmented once more at the end of a run); the labels stay
  map.insert(ground, 1);
  inc.update(map);
  EXPECT_EQ(inc.lastStats().touched_tiles, 0u);
  EXPECT_EQ(inc.lastStats().voxels, 0u);
  EXPECT_EQ(map.voxels()[0].label, VoxelLabel::Ground);
}

}  // namespace
}  // namespace terrain
