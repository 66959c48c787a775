// voxcap: the single user-facing command. Thin: it builds the subcommand tree and turns errors into
// one-line messages and exit codes (0 ok, 1 runtime failure, 2 bad input). No exception leaves main.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "voxcap/base/log.hpp"

int main(int argc, char** argv) {
  try {
    vc::log::init("voxcap");  // log lines: "[time] [level] voxcap: ..." on stderr
    CLI::App app{"voxcap — marker-less motion capture with hardware-triggered cameras and visual hulls"};
    app.set_version_flag("--version", "voxcap 0.1.0");
    app.require_subcommand(1, 1);
    // Subcommand groups register here (one line each).
    vc::cli::add_config_commands(app);
    vc::cli::add_trigger_commands(app);
    vc::cli::add_session_commands(app);
    vc::cli::add_proto_commands(app);
    vc::cli::add_rig_commands(app);
    vc::cli::add_sim_commands(app);
    vc::cli::add_track_commands(app);
    vc::cli::add_export_commands(app);
    vc::cli::add_demo_commands(app);
    vc::cli::add_fit_commands(app);
    vc::cli::add_bench_commands(app);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return app.exit(e);
    }
  } catch (const vc::cli::UsageError& e) {
    std::fprintf(stderr, "voxcap: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "voxcap: %s\n", e.what());
    return 1;
  }
  return 0;
}
