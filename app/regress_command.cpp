// 'terrain regress': a suite of scenarios run and every metric compared with its baseline (or the
// baseline written); a shard of a suite and the merge of shards for cluster sweeps.
#include "app/cli_options.hpp"
#include "app/command.hpp"
#include "app/interrupt.hpp"
#include "app/pipeline_config_io.hpp"
#include "app/reconstruction.hpp"
#include "evaluation/regression.hpp"
#include "rig/file_io.hpp"

#include <cstdlib>
#include <iostream>

namespace terrain::app {

namespace {

namespace fs = std::filesystem;

class RegressCommand : public Command {
 public:
  explicit RegressCommand(CLI::App& app)
      : Command(app.add_subcommand("regress", "run a suite of scenarios and compare every metric with its baseline")) {
    cli_->add_option("--suite", suite_, "suite YAML: scenarios (type, seed, frames) and metrics with tolerances")
        ->required();
    cli_->add_option("--baseline", baseline_,
                     "baseline JSON to compare with; any metric past its tolerance fails the run (exit 1)");
    cli_->add_option("--write-baseline", write_,
                     "run the suite and write its metrics as the new baseline (the only way baselines change)");
    cli_->add_option("--junit", junit_, "also write the comparison as JUnit XML");
    cli_->add_option("--out", out_,
                     "directory for the scenarios' outputs (default out/regress-SUITE, reused run after run)");
    auto* shard = cli_->add_option(
        "--shard", shard_,
        "run only part K of N of the suite (K/N: every N-th scenario from the K-th) and write its results "
        "and shard.json into --out, for 'regress --merge' (cluster sweeps); never writes a baseline");
    cli_->add_option("--merge", merge_,
                     "run nothing: merge the --out directories of every shard of the suite, then compare or write the "
                     "baseline as a whole run would (a missing, failed or duplicated shard is an error)")
        ->excludes(shard);
    cli_->add_flag("--force", force_, "replace an existing --write-baseline file, and write into a non-empty --out");
    cli_->add_flag("--list", list_,
                   "run nothing: print the suite's scenarios (of --shard K/N's part only, if given), one id a line "
                   "(TYPE_sSEED_fFRAMES)");
    addPipelineOptions(*cli_, config_);
  }

  int run() override {
    validate(config_);
    const eval::Suite suite = eval::loadSuite(suite_);
    const bool sharded = !shard_.empty();
    if (list_) {
      if (!merge_.empty()) throw io::InputError("--list runs nothing: give it without --merge");
      for (const auto& sc : eval::shardOf(suite, sharded ? eval::parseShard(shard_) : eval::Shard{}).scenarios)
        std::cout << sc.id() << "\n";
      return 0;
    }
    if (!write_.empty() && !baseline_.empty())
      throw io::InputError("give --baseline (to check) or --write-baseline (to refresh), not both");
    if (sharded && !write_.empty())
      throw io::InputError("--shard never writes a baseline: merge the shards with --merge and --write-baseline");
    if (!sharded && write_.empty() && baseline_.empty())
      throw io::InputError("give --baseline FILE to check against, or --write-baseline FILE to refresh it");
    const eval::Shard shard = sharded ? eval::parseShard(shard_) : eval::Shard{};
    const eval::Suite part = eval::shardOf(suite, shard);
    const fs::path work =
        out_.empty() ? fs::path("out") / ("regress-" + suite.name + (sharded ? "-shard" + std::to_string(shard.k) : ""))
                     : out_;
    // refused before the suite runs, not after
    if (!write_.empty() && fs::exists(write_) && !force_) {
      throw io::InputError(write_.string() + ": exists (pass --force to replace it)");
    }
    if (!out_.empty() && fs::is_directory(out_) && !fs::is_empty(out_) && !force_) {
      throw io::InputError(out_.string() +
                           ": directory exists and is not empty (pass --force to replace what the suite writes there)");
    }
    // on a cluster node, the cores Slurm gave the task, not every core of the node
    if (const char* cpus = std::getenv("SLURM_CPUS_PER_TASK"); cpus && sim_.threads == 0) {
      const int n = std::atoi(cpus);
      if (n > 0) sim_.threads = n;
    }
    eval::Results results;
    if (sharded) {
      // the shard's identity first, its results last: a shard that fails leaves no results to merge
      fs::create_directories(work);
      std::error_code ec;
      fs::remove(work / "suite_results.json", ec);
      io::writeFileAtomic(work / "shard.json", eval::shardJson(suite, shard), true);
    }
    if (!merge_.empty()) {
      results = eval::mergeShards(suite, merge_);
      std::cerr << "regress: merged " << merge_.size() << " shards, " << results.size() << " scenarios\n";
    } else {
      int done = 0;
      for (const auto& sc : part.scenarios) {
        throwIfInterrupted();
        std::cerr << "regress: " << sc.id() << " (" << ++done << "/" << part.scenarios.size() << ") ...\n";
        results[sc.id()] = eval::flattenMetrics(
            runScenario(sc.type, sc.seed, sc.frames, sim_, config_, work / sc.id(), true, true, {}));
      }
    }
    fs::create_directories(work);
    // every metric of every scenario, and a summary table beside the per-scenario reports
    nlohmann::json all = results;
    io::writeFileAtomic(work / "suite_results.json", all.dump(1) + "\n", true);
    io::writeFileAtomic(work / "suite_summary.html", eval::suiteSummaryHtml(part, results), true);
    std::cerr << "regress: all metrics in " << (work / "suite_results.json").string() << ", summary in "
              << (work / "suite_summary.html").string() << "\n";
    if (!write_.empty()) {
      eval::writeBaseline(write_, suite, results, force_);
      std::cout << "wrote baseline " << write_.string() << " for " << results.size() << " scenarios\n";
      return 0;
    }
    if (baseline_.empty()) return 0;  // a shard without a baseline: its results are all it writes
    const eval::RegressionResult res = eval::compare(part, eval::loadBaseline(baseline_), results);
    eval::printTable(std::cout, res);
    if (!junit_.empty()) io::writeFileAtomic(junit_, eval::junitXml(suite, res), true);
    return res.regressions > 0 ? 1 : 0;
  }

 private:
  fs::path suite_, baseline_, write_, junit_, out_;
  std::string shard_;
  std::vector<fs::path> merge_;
  bool force_ = false, list_ = false;
  PipelineConfig config_;
  sim::SimConfig sim_;  // the simulation's defaults: a suite's scenarios differ in type, seed and frames only
};

}  // namespace

std::unique_ptr<Command> addRegressCommand(CLI::App& app) { return std::make_unique<RegressCommand>(app); }

}  // namespace terrain::app
