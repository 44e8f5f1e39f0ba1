#include "sim/scene_checks.hpp"

#include "tests/test_support.hpp"

#include <gtest/gtest.h>

namespace terrain::sim {
namespace {

bool anyHas(const std::vector<std::string>& list, const std::string& text) {
  for (const auto& s : list) {
    if (s.find(text) != std::string::npos) return true;
  }
  return false;
}

// A 20 m block 10 m beside a path along x, with a skybox: nothing to say
TEST(SceneChecksTest, AClearSceneWithSkyAndATallObjectPasses) {
  const World world(test::boxScene("block", {0, 10, 10}, {2, 2, 10}, true),
                    test::boxTruth("block", {0, 10, 10}, {2, 2, 10}, {{-20, 0}, {20, 0}}));
  const SceneProblems p = checkScene(world, SimConfig{});
  EXPECT_TRUE(p.errors.empty());
  EXPECT_TRUE(p.warnings.empty()) << p.warnings.front();
}

// Each check fires on a world made to trip it (hand-placed: the robot is 0.7 m wide, the clearance
// 1 m, so an object nearer than 1.35 m to the path's line is too near)
TEST(SceneChecksTest, EachCheckFiresOnASceneMadeToTripIt) {
  // no skybox
  EXPECT_TRUE(anyHas(checkScene(World(test::boxScene("block", {0, 10, 10}, {2, 2, 10}),
                                      test::boxTruth("block", {0, 10, 10}, {2, 2, 10}, {{-20, 0}, {20, 0}})),
                                SimConfig{})
                         .warnings,
                     "no skybox"));
  // the path through the block, and 1.2 m from its side
  const auto through = checkScene(World(test::boxScene("block", {0, 0, 10}, {2, 2, 10}, true),
                                        test::boxTruth("block", {0, 0, 10}, {2, 2, 10}, {{-20, 0}, {20, 0}})),
                                  SimConfig{});
  EXPECT_TRUE(anyHas(through.warnings, "passes through object 'block' at (-2 m, 0 m)")) << through.warnings.front();
  const auto near = checkScene(World(test::boxScene("block", {0, 3.2, 10}, {2, 2, 10}, true),
                                     test::boxTruth("block", {0, 3.2, 10}, {2, 2, 10}, {{-20, 0}, {20, 0}})),
                               SimConfig{});
  EXPECT_TRUE(anyHas(near.warnings, "passes 1.2 m from object 'block'")) << near.warnings.front();
  // 1.4 m from its side: clear
  EXPECT_TRUE(checkScene(World(test::boxScene("block", {0, 3.4, 10}, {2, 2, 10}, true),
                               test::boxTruth("block", {0, 3.4, 10}, {2, 2, 10}, {{-20, 0}, {20, 0}})),
                         SimConfig{})
                  .warnings.empty());
  // a 3 m block only: within the lidar's reach (1.8 m mast + 1.5 m cap)
  EXPECT_TRUE(anyHas(checkScene(World(test::boxScene("block", {0, 10, 1.5}, {2, 2, 1.5}, true),
                                      test::boxTruth("block", {0, 10, 1.5}, {2, 2, 1.5}, {{-20, 0}, {20, 0}})),
                                SimConfig{})
                         .warnings,
                     "no object stands higher than the lidar's reach (3.3 m"));
  // a path that leaves the 120 m plane: an error at its first point past the edge
  const auto off = checkScene(World(test::boxScene("block", {0, 10, 10}, {2, 2, 10}, true),
                                    test::boxTruth("block", {0, 10, 10}, {2, 2, 10}, {{40, 0}, {70, 0}})),
                              SimConfig{});
  ASSERT_EQ(off.errors.size(), 1u);
  EXPECT_NE(off.errors[0].find("no terrain under the path at (60.5 m, 0 m)"), std::string::npos) << off.errors[0];
}

}  // namespace
}  // namespace terrain::sim
