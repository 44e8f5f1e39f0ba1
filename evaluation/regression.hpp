#pragma once
// Regression checks: a suite of scenarios (terrain type x seed x frames) and the metrics to guard,
// each with the direction that is better and a tolerance; a baseline of stored values; the
// comparison, as a table and as JUnit XML.

#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

namespace terrain::eval {

struct ScenarioSpec {
  std::string type;
  std::uint64_t seed = 1;
  int frames = 10;
  std::string id() const { return type + "_s" + std::to_string(seed) + "_f" + std::to_string(frames); }
};

struct MetricSpec {
  std::string name;  // flattened report field, e.g. ground_segmentation.gmrf_icm.f1
  bool higher_is_better = true;
  double tolerance = 0;  // allowed worsening, in the metric's unit
  // With a count field (another flattened report field, e.g. the cells an error is averaged over),
  // the metric is compared only where that count is at least min_count in both the baseline and the
  // run: an average over a handful of cells moves past any tolerance when one cell comes or goes.
  std::string count;
  double min_count = 0;
};

struct Suite {
  std::string name;
  std::vector<ScenarioSpec> scenarios;
  std::vector<MetricSpec> metrics;
};

// Reads a suite YAML; throws io::InputError naming the file, line and field.
Suite loadSuite(const std::filesystem::path& path);

using Results = std::map<std::string, std::map<std::string, double>>;  // scenario -> metric -> value

// Reads and writes baselines (JSON); writing refuses to replace a file unless force.
Results loadBaseline(const std::filesystem::path& path);

// Shards: part k of n (1-based) holds every n-th scenario from the k-th, in suite order, so every
// scenario is in exactly one part and the split is the same for the same suite.
struct Shard {
  int k = 1, n = 1;
};
// Reads "K/N" (1 <= K <= N <= 10000); throws io::InputError naming the text otherwise.
Shard parseShard(const std::string& text);
Suite shardOf(const Suite& suite, Shard shard);
// What a shard's run leaves beside its suite_results.json (DIR/shard.json): the suite, K, N and
// its scenarios.
std::string shardJson(const Suite& suite, Shard shard);
// The results of a whole suite from the directories of its shards' runs. Throws io::InputError
// naming the directory for a shard that is missing or failed (no shard.json or suite_results.json,
// or a scenario of its part without results), one of another suite or split, and a part given twice.
Results mergeShards(const Suite& suite, const std::vector<std::filesystem::path>& dirs);

void writeBaseline(const std::filesystem::path& path, const Suite& suite, const Results& results, bool force);

struct Comparison {
  std::string scenario, metric;
  double baseline = 0, value = 0, tolerance = 0;
  bool higher_is_better = true;
  bool missing = false;  // no baseline or no value
  bool regressed = false;
  // too few to compare (MetricSpec::count below min_count): not compared, not a regression
  bool skipped = false;
  double baseline_count = 0, count = 0;
};

struct RegressionResult {
  std::vector<Comparison> rows;
  int regressions = 0;
  int skipped = 0;  // rows with too few to compare
};

// Compares every guarded metric of every scenario with the baseline.
RegressionResult compare(const Suite& suite, const Results& baseline, const Results& results);

void printTable(std::ostream& out, const RegressionResult& result);
// HTML table of the suite's scenarios: every ground segmentation method's F1 and the height figures.
std::string suiteSummaryHtml(const Suite& suite, const Results& results);
std::string junitXml(const Suite& suite, const RegressionResult& result);

}  // namespace terrain::eval
