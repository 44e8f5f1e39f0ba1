#include "evaluation/regression.hpp"

#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>

namespace terrain::eval {
namespace {

Suite twoMetricSuite() {
  Suite s;
  s.name = "t";
  s.scenarios = {{"flat", 1, 5}};
  s.metrics = {{"f1", true, 0.01}, {"mae_m", false, 0.5}};
  return s;
}

TEST(RegressionTest, PassesWithinToleranceAndFailsPastIt) {
  const Suite s = twoMetricSuite();
  const Results baseline{{"flat_s1_f5", {{"f1", 0.95}, {"mae_m", 3.0}}}};
  // worse, but within tolerance; and better
  EXPECT_EQ(compare(s, baseline, {{"flat_s1_f5", {{"f1", 0.945}, {"mae_m", 3.4}}}}).regressions, 0);
  EXPECT_EQ(compare(s, baseline, {{"flat_s1_f5", {{"f1", 0.99}, {"mae_m", 1.0}}}}).regressions, 0);
  // past tolerance, each direction
  EXPECT_EQ(compare(s, baseline, {{"flat_s1_f5", {{"f1", 0.93}, {"mae_m", 3.0}}}}).regressions, 1);
  EXPECT_EQ(compare(s, baseline, {{"flat_s1_f5", {{"f1", 0.95}, {"mae_m", 3.6}}}}).regressions, 1);
  // a metric without a baseline, or a NaN value, fails
  EXPECT_EQ(compare(s, {{"flat_s1_f5", {{"f1", 0.95}}}}, {{"flat_s1_f5", {{"f1", 0.95}, {"mae_m", 3.0}}}}).regressions, 1);
  EXPECT_EQ(compare(s, baseline, {{"flat_s1_f5", {{"f1", std::nan("")}, {"mae_m", 3.0}}}}).regressions, 1);
}

TEST(RegressionTest, BaselinesAndSuitesRoundTripAndJunitNamesFailures) {
  test::TempDir dir;
  const Suite s = twoMetricSuite();
  const Results r{{"flat_s1_f5", {{"f1", 0.95}, {"mae_m", 3.0}, {"unguarded", 7.0}}}};
  writeBaseline(dir / "b.json", s, r, false);
  EXPECT_THROW(writeBaseline(dir / "b.json", s, r, false), io::InputError);  // never replaced silently
  const Results back = loadBaseline(dir / "b.json");
  EXPECT_EQ(back.at("flat_s1_f5").at("f1"), 0.95);
  EXPECT_EQ(back.at("flat_s1_f5").count("unguarded"), 0u);
  const auto res = compare(s, back, {{"flat_s1_f5", {{"f1", 0.5}, {"mae_m", 3.0}}}});
  const std::string xml = junitXml(s, res);
  EXPECT_NE(xml.find("failures=\"1\""), std::string::npos);
  EXPECT_NE(xml.find("<testcase classname=\"flat_s1_f5\" name=\"f1\"><failure"), std::string::npos);
  io::writeFileAtomic(dir / "s.yaml", "frames: 4\nscenarios:\n  - {type: urban, seeds: [1, 2]}\nmetrics:\n  f1: {better: higher, tolerance: 0.01}\n", true);
  const Suite loaded = loadSuite(dir / "s.yaml");
  ASSERT_EQ(loaded.scenarios.size(), 2u);
  EXPECT_EQ(loaded.scenarios[1].id(), "urban_s2_f4");
  io::writeFileAtomic(dir / "bad.yaml", "scenarios:\n  - {type: urban}\nmetrics:\n  f1: {better: up, tolerance: 0.01}\n", true);
  try {
    loadSuite(dir / "bad.yaml");
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("better must be higher or lower"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace terrain::eval
