// voxcap: the single user-facing command. Thin: it builds the subcommand tree and turns errors into
// one-line messages and exit codes (0 ok, 1 runtime failure, 2 bad input). No exception leaves main.
// Every command-line error CLI11 finds (an unknown subcommand or option, a value that does not convert
// or fails its check, a missing argument) is bad input: one line and exit 2, never CLI11's own codes
// (105, 106, ...). --help and --version print and exit 0.
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "voxcap/base/log.hpp"

namespace {

// CLI11's messages may span lines (a list of the expected subcommands): the exit-2 contract is one line.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

}  // namespace

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
    vc::cli::add_key_commands(app);
    vc::cli::add_calib_commands(app);
    vc::cli::add_carve_commands(app);
    vc::cli::add_calibrate_commands(app);
    vc::cli::add_deploy_commands(app);
    vc::cli::add_bench_commands(app);
    vc::cli::add_hil_commands(app);
    vc::cli::add_view_commands(app);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);  // help
      std::string what = one_line(e.what());
      if (argc > 1 && argv[1][0] != '-') {  // CLI11 says "A subcommand is required": name the word
        bool known = false;
        const CLI::App& all = app;
        for (const CLI::App* sub : all.get_subcommands([](const CLI::App*) { return true; }))
          known = known || sub->get_name() == argv[1];
        if (!known) what = std::string("unknown command '") + argv[1] + "'";
      }
      std::fprintf(stderr, "voxcap: %s (see --help)\n", what.c_str());
      return 2;
    }
  } catch (const vc::cli::UsageError& e) {
    std::fprintf(stderr, "voxcap: %s\n", one_line(e.what()).c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "voxcap: %s\n", one_line(e.what()).c_str());
    return 1;
  }
  return 0;
}
