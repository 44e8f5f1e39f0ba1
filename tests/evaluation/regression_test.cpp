#include "evaluation/regression.hpp"

#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

namespace terrain::eval {
namespace {

Suite twoMetricSuite() {
  Suite s;
  s.name = "t";
  s.scenarios = {{"flat", 1, 5}};
  s.metrics = {{"f1", true, 0.01, "", 0}, {"mae_m", false, 0.5, "", 0}};
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
  EXPECT_EQ(compare(s, {{"flat_s1_f5", {{"f1", 0.95}}}}, {{"flat_s1_f5", {{"f1", 0.95}, {"mae_m", 3.0}}}}).regressions,
            1);
  EXPECT_EQ(compare(s, baseline, {{"flat_s1_f5", {{"f1", std::nan("")}, {"mae_m", 3.0}}}}).regressions, 1);
}

TEST(RegressionTest, AnAverageOverTooFewIsNotComparedButStillNeedsItsCount) {
  Suite s;
  s.name = "t";
  s.scenarios = {{"rough", 1, 8}};
  s.metrics = {{"mae_m", false, 0.5, "cells", 50}};
  const Results baseline{{"rough_s1_f8", {{"mae_m", 10.2}, {"cells", 80}}}};
  // enough cells on both sides: compared
  EXPECT_EQ(compare(s, baseline, {{"rough_s1_f8", {{"mae_m", 10.6}, {"cells", 60}}}}).regressions, 0);
  EXPECT_EQ(compare(s, baseline, {{"rough_s1_f8", {{"mae_m", 14.0}, {"cells", 60}}}}).regressions, 1);
  // too few now, or in the baseline: skipped, whatever the value
  const RegressionResult few = compare(s, baseline, {{"rough_s1_f8", {{"mae_m", 18.2}, {"cells", 1}}}});
  EXPECT_EQ(few.regressions, 0);
  EXPECT_EQ(few.skipped, 1);
  ASSERT_EQ(few.rows.size(), 1u);
  EXPECT_TRUE(few.rows[0].skipped);
  EXPECT_EQ(few.rows[0].count, 1);
  EXPECT_EQ(compare(s, {{"rough_s1_f8", {{"mae_m", 10.2}, {"cells", 49}}}},
                    {{"rough_s1_f8", {{"mae_m", 30.0}, {"cells", 300}}}})
                .skipped,
            1);
  // the count missing from either side fails, as a missing metric does
  EXPECT_EQ(
      compare(s, {{"rough_s1_f8", {{"mae_m", 10.2}}}}, {{"rough_s1_f8", {{"mae_m", 10.2}, {"cells", 80}}}}).regressions,
      1);
  EXPECT_EQ(compare(s, baseline, {{"rough_s1_f8", {{"mae_m", 10.2}}}}).regressions, 1);
  // a NaN count is not enough
  EXPECT_EQ(compare(s, baseline, {{"rough_s1_f8", {{"mae_m", 10.2}, {"cells", std::nan("")}}}}).skipped, 1);
  // the table and the JUnit XML say so
  std::ostringstream table;
  printTable(table, few);
  EXPECT_NE(table.str().find("skipped (count 80 -> 1)"), std::string::npos) << table.str();
  EXPECT_NE(table.str().find("0 regressions in 0 checks, 1 skipped"), std::string::npos) << table.str();
  const std::string xml = junitXml(s, few);
  EXPECT_NE(xml.find("skipped=\"1\""), std::string::npos) << xml;
  EXPECT_NE(xml.find("<skipped message="), std::string::npos) << xml;

  // the baseline keeps the count with the metric; a suite names both or neither
  test::TempDir dir;
  writeBaseline(dir / "b.json", s, {{"rough_s1_f8", {{"mae_m", 10.2}, {"cells", 80}, {"other", 1}}}}, false);
  const Results back = loadBaseline(dir / "b.json");
  EXPECT_EQ(back.at("rough_s1_f8").at("cells"), 80);
  EXPECT_EQ(back.at("rough_s1_f8").count("other"), 0u);
  io::writeFileAtomic(dir / "s.yaml",
                      "scenarios:\n  - {type: rough}\nmetrics:\n  mae_m: {better: lower, tolerance: 0.5, count: cells, "
                      "min_count: 50}\n",
                      true);
  const Suite loaded = loadSuite(dir / "s.yaml");
  ASSERT_EQ(loaded.metrics.size(), 1u);
  EXPECT_EQ(loaded.metrics[0].count, "cells");
  EXPECT_EQ(loaded.metrics[0].min_count, 50);
  io::writeFileAtomic(dir / "word.yaml",
                      "scenarios:\n  - {type: rough}\nmetrics:\n  mae_m: {better: lower, tolerance: 0.5, count: cells, "
                      "min_count: many}\n",
                      true);
  try {
    loadSuite(dir / "word.yaml");
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("word.yaml:4: metric 'mae_m': bad value"), std::string::npos) << e.what();
  }
  io::writeFileAtomic(
      dir / "half.yaml",
      "scenarios:\n  - {type: rough}\nmetrics:\n  mae_m: {better: lower, tolerance: 0.5, count: cells}\n", true);
  try {
    loadSuite(dir / "half.yaml");
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "half.yaml:4: metric 'mae_m': give 'count' (a report field) and 'min_count' together"),
              std::string::npos)
        << e.what();
  }
}

TEST(RegressionTest, BaselinesAndSuitesRoundTripAndJunitNamesFailures) {
  test::TempDir dir;
  const Suite s = twoMetricSuite();
  const Results r{{"flat_s1_f5", {{"f1", 0.95}, {"mae_m", 3.0}, {"unguarded", 7.0}}}};
  writeBaseline(dir / "b.json", s, r, false);
  EXPECT_THROW(writeBaseline(dir / "b.json", s, r, false), io::InputError);  // never replaced silently
  // a metric no scenario reports (misspelled) is refused and nothing is written
  Suite typo = s;
  typo.metrics[0].name = "f1_typo";
  try {
    writeBaseline(dir / "typo.json", typo, r, false);
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("metric 'f1_typo' is in no scenario's report"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "typo.json"));
  const Results back = loadBaseline(dir / "b.json");
  EXPECT_EQ(back.at("flat_s1_f5").at("f1"), 0.95);
  EXPECT_EQ(back.at("flat_s1_f5").count("unguarded"), 0u);
  const auto res = compare(s, back, {{"flat_s1_f5", {{"f1", 0.5}, {"mae_m", 3.0}}}});
  const std::string xml = junitXml(s, res);
  EXPECT_NE(xml.find("failures=\"1\""), std::string::npos);
  EXPECT_NE(xml.find("<testcase classname=\"flat_s1_f5\" name=\"f1\"><failure"), std::string::npos);
  io::writeFileAtomic(
      dir / "s.yaml",
      "frames: 4\nscenarios:\n  - {type: urban, seeds: [1, 2]}\nmetrics:\n  f1: {better: higher, tolerance: 0.01}\n",
      true);
  const Suite loaded = loadSuite(dir / "s.yaml");
  ASSERT_EQ(loaded.scenarios.size(), 2u);
  EXPECT_EQ(loaded.scenarios[1].id(), "urban_s2_f4");
  io::writeFileAtomic(dir / "bad.yaml",
                      "scenarios:\n  - {type: urban}\nmetrics:\n  f1: {better: up, tolerance: 0.01}\n", true);
  try {
    loadSuite(dir / "bad.yaml");
    FAIL();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("better must be higher or lower"), std::string::npos) << e.what();
  }
}

// Shards split a suite into disjoint parts that together are the suite; merging their outputs gives
// the whole suite's results, and a missing, failed, foreign or doubled shard is named.
TEST(RegressionTest, ShardsSplitTheSuiteAndMergeBackOrSayWhatIsMissing) {
  Suite s;
  s.name = "sweep";
  for (int seed = 1; seed <= 7; ++seed) s.scenarios.push_back({"flat", static_cast<std::uint64_t>(seed), 4});
  std::map<std::string, int> owner;
  for (int k = 1; k <= 3; ++k) {
    for (const auto& sc : shardOf(s, {k, 3}).scenarios) EXPECT_TRUE(owner.emplace(sc.id(), k).second) << sc.id();
  }
  EXPECT_EQ(owner.size(), 7u);  // every scenario in exactly one part
  EXPECT_EQ(shardOf(s, {1, 3}).scenarios.size(), 3u);
  EXPECT_EQ(shardOf(s, {3, 3}).scenarios.size(), 2u);
  EXPECT_EQ(parseShard("2/8").k, 2);
  for (const char* bad : {"0/3", "4/3", "3", "a/b", "1/3x", "-1/2"})
    EXPECT_THROW(parseShard(bad), io::InputError) << bad;

  // each shard's output as a shard run leaves it
  test::TempDir dir;
  const auto writeShard = [&](int k, const std::string& name, bool finished) {
    const auto d = dir / name;
    std::filesystem::create_directories(d);
    io::writeFileAtomic(d / "shard.json", shardJson(s, {k, 3}), true);
    nlohmann::json r;
    for (const auto& sc : shardOf(s, {k, 3}).scenarios) r[sc.id()]["f1"] = 0.9 + 0.01 * static_cast<double>(sc.seed);
    if (finished) io::writeFileAtomic(d / "suite_results.json", r.dump(), true);
    return d;
  };
  const auto a = writeShard(1, "a", true), b = writeShard(2, "b", true), c = writeShard(3, "c", true);
  const Results merged = mergeShards(s, {c, a, b});
  ASSERT_EQ(merged.size(), 7u);
  EXPECT_DOUBLE_EQ(merged.at("flat_s5_f4").at("f1"), 0.95);
  const auto refused = [&](const std::vector<std::filesystem::path>& dirs, const std::string& message) {
    try {
      mergeShards(s, dirs);
      ADD_FAILURE() << "merged: " << message;
    } catch (const io::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  refused({a, b}, "shard 3/3 is missing from --merge");
  refused({a, b, c, a}, "shard 1/3 is given twice");
  refused({a, b, writeShard(3, "failed", false)}, "did not finish");
  refused({a, b, dir / "nowhere"}, "shard.json: missing");
  Suite other = s;
  other.name = "other";
  try {
    mergeShards(other, {a, b, c});
    ADD_FAILURE() << "a shard of another suite was merged";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("a shard of suite 'sweep', not 'other'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace terrain::eval
