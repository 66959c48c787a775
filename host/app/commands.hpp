// The voxcap subcommands. Each group lives in its own cmd_<group>.cpp and adds itself to the app
// in main.cpp; a subcommand's work runs in its CLI11 callback, and errors are thrown as exceptions
// (vc::UsageError for bad input, anything derived from std::exception for I/O), caught once in main.
#pragma once

#include <stdexcept>

#include <CLI/CLI.hpp>

namespace vc::cli {

// Bad input from the user (a missing file, a malformed option value): exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

void add_config_commands(CLI::App& app);     // cmd_config.cpp: voxcap config check
void add_trigger_commands(CLI::App& app);    // cmd_trigger.cpp: voxcap trigger test|listen
void add_session_commands(CLI::App& app);    // cmd_session.cpp: voxcap session info|dump
void add_proto_commands(CLI::App& app);      // cmd_proto.cpp: voxcap proto dump
void add_rig_commands(CLI::App& app);        // cmd_rig.cpp: voxcap rig [--emulated]
void add_sim_commands(CLI::App& app);        // cmd_sim.cpp: voxcap sim (the virtual rig, hw/sim)
void add_track_commands(CLI::App& app);      // cmd_track.cpp: voxcap track debug (edge/segment)
void add_export_commands(CLI::App& app);     // cmd_export.cpp: voxcap export (BVH, joints.csv)
void add_demo_commands(CLI::App& app);       // cmd_demo.cpp: voxcap demo, voxcap eval
void add_fit_commands(CLI::App& app);        // cmd_fit.cpp: voxcap fit (re-fit a session offline)
void add_calib_commands(CLI::App& app);      // cmd_calib.cpp: voxcap calib import (host/calib)
void add_carve_commands(CLI::App& app);      // cmd_carve.cpp: voxcap carve (offline hulls from image folders)
void add_calibrate_commands(CLI::App& app);  // cmd_calibrate.cpp: voxcap calibrate solve|capture
void add_key_commands(CLI::App& app);        // cmd_key.cpp: voxcap key new|check (the rig key)
void add_hil_commands(CLI::App& app);        // cmd_hil.cpp: voxcap hil [--emulated] (hardware-in-loop tests)
void add_deploy_commands(CLI::App& app);     // cmd_deploy.cpp: voxcap deploy [flash-config] (boards over ssh)
void add_view_commands(CLI::App& app);       // cmd_view.cpp: voxcap view SESSION (a session in the viewer)

// `voxcap bench ...` (cmd_bench.cpp).
void add_bench_commands(CLI::App& app);

}  // namespace vc::cli
