// The hardware-in-loop tests of `voxcap hil`, run against a real rig's lines or their emulated twin:
//
//   loopback     the host's trigger output ([trigger]) wired to an input ([hil.loopback]): every pulse
//                seen, period jitter from the kernel's edge timestamps, missed and extra pulses
//   edge-input   the edge's trigger input line ([hil.edge_input]): N pulses -> N events at each rate
//   alignment    externally triggered cameras ([[hil.cameras]]) on the same wire: each frame paired with
//                its pulse (the edge input's timestamps), offset percentiles, unpaired frames
//   smoke        the whole rig of the file for smoke_seconds: every node connects, frames merge
//
// The devices sit behind the existing interfaces (vc::trigger::Generator for the output, edge/trigger's
// vc_trigger for the input, TriggeredCamera for the cameras: camera.hpp, the aggregator); every figure
// and verdict comes from measure.hpp, which sees only timestamp streams, so the emulated twin (udp
// trigger on loopback, sim cameras, the emulated rig) proves the same logic a real run uses and reports
// the same figures. A test whose lines are not configured is skipped with the keys to set.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "voxcap/config/rig_config.hpp"
#include "voxcap/hil/measure.hpp"

namespace vc::hil {

// What the tests run against and how long.
struct RunOptions {
  bool emulated = false;
  config::RigConfig config;  // the rig file (emulated without one: defaults)
  uint64_t pulses = 600;
  double rate_hz = 60;                            // loopback and alignment
  std::vector<double> edge_rates_hz = {60, 120};  // edge-input
  double smoke_seconds = 0;                       // 0: the smoke run is skipped
  // Each progress line as the test runs (the command prints them); none when empty.
  std::function<void(const std::string&)> say;
  // Set (by a signal handler) to end a smoke run early; may be null.
  const std::atomic<bool>* interrupted = nullptr;

  bool valid(std::string* why) const;
};

// Bad input found while running (a camera spec that cannot be opened as written): the command's exit 2.
struct HilConfigError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// One test's outcome: its verdict and its figures (the JSON `voxcap hil --json` prints; a figure not
// measured is null).
struct Outcome {
  std::string name;
  Verdict verdict;
  nlohmann::json figures = nlohmann::json::object();
};

// "loopback", "edge-input", "alignment", "smoke", in the order they run.
const std::vector<std::string>& test_names();

// Runs one test. A device that is missing or busy makes it FAIL with the reason (never throws for
// that); throws HilConfigError for bad input and std::invalid_argument for an unknown name.
Outcome run_test(const std::string& name, const RunOptions& options);

}  // namespace vc::hil
