// 'terrain evaluate': score a finished run again from what it kept (OUT/state/).
#include "app/cli_options.hpp"
#include "app/command.hpp"
#include "app/reconstruction.hpp"
#include "app/run_state.hpp"
#include "rig/file_io.hpp"

#include <iostream>

namespace terrain::app {

namespace {

namespace fs = std::filesystem;

class EvaluateCommand : public Command {
 public:
  explicit EvaluateCommand(CLI::App& app)
      : Command(app.add_subcommand(
            "evaluate",
            "score a finished run (of 'terrain run' or 'terrain reconstruct') again: report.json and report.html")) {
    cli_->add_option("--run", run_, "the run's output directory (it holds state/)")->required();
    cli_->add_option("--out", out_,
                     "where to write report.json and report.html (default: the run directory, replacing its reports)");
    addScoringOptions(*cli_, scoring_);
  }

  int run() override {
    SavedRun saved = readRunState(run_);
    if (!fs::exists(saved.scene)) throw io::InputError(saved.scene.string() + ": the run's scene is no longer there");
    const sim::World world(saved.scene);
    const fs::path out = out_.empty() ? run_ : out_;
    if (!out_.empty()) {
      fs::create_directories(out);
      for (const char* f : {"report.json", "report.html"}) {
        if (fs::exists(out / f))
          throw io::InputError((out / f).string() +
                               ": exists (give another --out, or leave --out out to replace the run's own reports)");
      }
    }
    writeReport(*saved.pipeline, *saved.truth, &world, out, false, scoring_);
    std::cout << "wrote report.json and report.html into " << fs::absolute(out).string() << "\n";
    return 0;
  }

 private:
  fs::path run_, out_;
  eval::EvaluationOptions scoring_;
};

}  // namespace

std::unique_ptr<Command> addEvaluateCommand(CLI::App& app) { return std::make_unique<EvaluateCommand>(app); }

}  // namespace terrain::app
