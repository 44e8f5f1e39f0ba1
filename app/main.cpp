// terrain: the testbed's command-line entry point. Each subcommand is in a file of its own
// (app/command.hpp lists them); this adds them, parses the command line, runs the one named and
// turns every failure into its exit code: 0 ok, 1 a regression found, 2 bad input or usage,
// 130/143 interrupted (SIGINT/SIGTERM).
#include "app/command.hpp"
#include "app/interrupt.hpp"
#include "rig/file_io.hpp"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>
#include <memory>
#include <vector>

int main(int argc, char** argv) {
  using namespace terrain;
  CLI::App cli{
      "terrain: testbed for robot terrain reconstruction (Song et al. 2012) on simulated and real sensor rigs"};
  cli.require_subcommand(1);
  std::vector<std::unique_ptr<app::Command>> commands;
  for (auto add : {app::addScenesCommand, app::addRecordCommand, app::addReconstructCommand, app::addEvaluateCommand,
                   app::addStreamCommand, app::addRunCommand, app::addRegressCommand, app::addKittiCommand,
                   app::addLidarCommand}) {
    commands.push_back(add(cli));
  }
  try {
    // settings files are read while the command line is parsed (app/cli_options.hpp)
    try {
      cli.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
      return cli.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
      return cli.exit(e);
    } catch (const CLI::CallForVersion& e) {
      return cli.exit(e);
    } catch (const CLI::ParseError& e) {
      // usage errors end as every bad input does: the prefix and exit code 2
      std::cerr << "terrain: error: " << e.what() << "\n"
                << "Run with --help for more information.\n";
      return 2;
    }
    app::installInterruptHandlers();
    for (const auto& command : commands) {
      if (command->parsed()) return command->run();
    }
  } catch (const app::Interrupted& e) {
    std::cerr << "\nterrain: " << e.what() << ": stopped; the output directory was left as it was\n";
    return e.exitCode();
  } catch (const io::InputError& e) {
    std::cerr << "terrain: error: " << e.what() << "\n";
    return 2;
  } catch (const std::filesystem::filesystem_error& e) {
    // a path that cannot be read or written (permissions, a full disk, a file where a folder should be)
    std::cerr << "terrain: error: " << e.path1().string() << ": " << e.code().message() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "terrain: internal error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
