#pragma once
// A subcommand of 'terrain': it adds its options to the command line, and runs when the command
// line names it. One file per subcommand (app/*_command.cpp, app/lidar_commands.cpp); main.cpp
// adds them all, parses, and runs the one named.

#include <CLI/CLI.hpp>

#include <memory>

namespace terrain::app {

class Command {
 public:
  // cli: the subcommand whose being parsed means this command runs
  explicit Command(CLI::App* cli) : cli_(cli) {}
  virtual ~Command() = default;
  Command(const Command&) = delete;
  Command& operator=(const Command&) = delete;

  bool parsed() const { return cli_->parsed(); }
  // Runs the command; returns its exit code (0 ok, 1 a regression found). Bad input and usage
  // throw io::InputError; an interruption throws app::Interrupted.
  virtual int run() = 0;

 protected:
  CLI::App* cli_;
};

// 'terrain scenes generate' and 'terrain scenes import'
std::unique_ptr<Command> addScenesCommand(CLI::App& app);
// 'terrain record': drive a scene with the simulated rig and write a dataset
std::unique_ptr<Command> addRecordCommand(CLI::App& app);
// 'terrain reconstruct': the pipeline over a dataset, a dataset with a real lidar, or a capture alone
std::unique_ptr<Command> addReconstructCommand(CLI::App& app);
// 'terrain evaluate': score a finished run again from what it kept
std::unique_ptr<Command> addEvaluateCommand(CLI::App& app);
// 'terrain stream': a capture or a simulated run as HDL-64E packets over UDP
std::unique_ptr<Command> addStreamCommand(CLI::App& app);
// 'terrain run': generate a scene, simulate and reconstruct in one go
std::unique_ptr<Command> addRunCommand(CLI::App& app);
// 'terrain regress': a suite of scenarios against its baseline
std::unique_ptr<Command> addRegressCommand(CLI::App& app);
// 'terrain kitti': ground segmentation scored on real KITTI scans
std::unique_ptr<Command> addKittiCommand(CLI::App& app);
// 'terrain lidar inspect' and 'terrain lidar convert' (app/lidar_commands.cpp)
std::unique_ptr<Command> addLidarCommand(CLI::App& app);

}  // namespace terrain::app
