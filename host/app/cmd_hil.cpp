// `voxcap hil`: the hardware-in-loop tests of a real rig, driven by its rig.toml's [hil] section, and
// their emulated twin (`--emulated`: udp trigger on loopback, sim cameras, the emulated rig). The tests
// themselves (loopback, edge-input, alignment, smoke) and their figures are host/hil's (run.hpp); this
// file reads the options, prints each test's lines and verdict, the summary or the JSON. A test whose
// lines are not configured is SKIPPED with the keys to set; any FAIL exits 1, bad input 2.
#include <algorithm>
#include <atomic>
#include <csignal>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/hil/run.hpp"

namespace vc::cli {
namespace {

using nlohmann::json;

struct HilArgs {
  std::string config;
  bool emulated = false;
  std::string tests;
  uint64_t pulses = 0;
  double rate_hz = 0;
  double seconds = 0;
  bool json = false;
};

std::atomic<bool> g_interrupted{false};

void on_signal(int) {
  g_interrupted = true;
}

std::vector<std::string> parse_tests(const std::string& list) {
  const std::vector<std::string>& names = hil::test_names();
  if (list.empty() || list == "all") return names;
  std::vector<std::string> out;
  std::stringstream ss(list);
  for (std::string t; std::getline(ss, t, ',');) {
    if (t.empty()) continue;
    if (std::find(names.begin(), names.end(), t) == names.end())
      throw UsageError(
          fmt::format("--tests: unknown test \"{}\" (loopback, edge-input, alignment, smoke)", t));
    if (std::find(out.begin(), out.end(), t) == out.end()) out.push_back(t);
  }
  if (out.empty()) throw UsageError("--tests: name at least one test");
  return out;
}

hil::RunOptions make_options(const HilArgs& a, bool* have_file) {
  hil::RunOptions rig;
  rig.emulated = a.emulated;
  *have_file = false;
  if (!a.config.empty() || !a.emulated) {
    const std::filesystem::path path =
        a.config.empty() ? config::default_rig_config_path() : std::filesystem::path(a.config);
    try {
      rig.config = config::load_rig_config(path);
    } catch (const config::ConfigError& e) {
      throw UsageError(e.what());
    }
    *have_file = true;
  } else {
    rig.config.name = "emulated";
  }
  const config::HilOptions& h = rig.config.hil;
  rig.pulses = a.pulses > 0 ? a.pulses : h.pulses;
  rig.rate_hz = a.rate_hz > 0 ? a.rate_hz : rig.config.trigger.rate_hz;
  rig.edge_rates_hz = a.rate_hz > 0 ? std::vector<double>{a.rate_hz} : h.rates_hz;
  // The twin runs every test; a real rig's smoke run only when the file (or --seconds) asks for it.
  rig.smoke_seconds = a.seconds > 0 ? a.seconds : (a.emulated ? 4.0 : h.smoke_seconds);
  if (rig.pulses < 2 || rig.pulses > 1000000) throw UsageError("--pulses: must be in [2, 1000000]");
  if (!(rig.rate_hz > 0 && rig.rate_hz <= 1000)) throw UsageError("--rate: must be in (0, 1000] Hz");
  std::string why;
  if (!rig.valid(&why)) throw UsageError(why);
  if (!a.json) rig.say = [](const std::string& line) { fmt::print("{}\n", line); };
  rig.interrupted = &g_interrupted;
  return rig;
}

void run_hil(const HilArgs& a) {
  const std::vector<std::string> tests = parse_tests(a.tests);
  bool have_file = false;
  const hil::RunOptions rig = make_options(a, &have_file);
  auto say = [&](const std::string& line) {
    if (!a.json) fmt::print("{}\n", line);
  };
  g_interrupted = false;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (!rig.emulated && !rig.config.hil.present)
    say(
        fmt::format("voxcap hil: {} has no [hil] section: every test is skipped (tests/hil/README.md says "
                    "what to wire and configure)",
                    rig.config.source.string()));
  say(rig.emulated ? std::string("voxcap hil: the emulated twin (udp trigger on loopback, sim cameras, the "
                                 "emulated rig)")
                   : fmt::format("voxcap hil: rig \"{}\" ({}), trigger {}", rig.config.name,
                                 rig.config.source.string(), config::to_string(rig.config.trigger.backend)));
  std::vector<hil::Outcome> outcomes;
  for (const std::string& t : tests) {
    if (g_interrupted) break;
    hil::Outcome o;
    try {
      o = hil::run_test(t, rig);  // a device missing or busy: this test FAILs, the others run
    } catch (const hil::HilConfigError& e) {
      throw UsageError(e.what());
    }
    if (o.verdict.status == hil::Status::Skip)
      say(fmt::format("[{}] SKIPPED: {}", t, o.verdict.reason));
    else
      say(fmt::format("[{}] {}: {}", t, hil::to_string(o.verdict.status), o.verdict.reason));
    outcomes.push_back(std::move(o));
  }
  size_t passed = 0, failed = 0, skipped = 0;
  std::string failed_names;
  for (const hil::Outcome& o : outcomes) {
    passed += o.verdict.status == hil::Status::Pass;
    skipped += o.verdict.status == hil::Status::Skip;
    if (o.verdict.status == hil::Status::Fail) {
      ++failed;
      failed_names += (failed_names.empty() ? "" : ", ") + o.name;
    }
  }
  if (a.json) {
    json j = {{"mode", rig.emulated ? "emulated" : "real"},
              {"rig", rig.config.name},
              {"config", have_file ? rig.config.source.string() : std::string()},
              {"tests", json::array()},
              {"passed", passed},
              {"failed", failed},
              {"skipped", skipped}};
    for (const hil::Outcome& o : outcomes)
      j["tests"].push_back({{"name", o.name},
                            {"status", hil::to_string(o.verdict.status)},
                            {"reason", o.verdict.reason},
                            {"figures", o.figures}});
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("voxcap hil: {} PASS, {} FAIL, {} SKIPPED\n", passed, failed, skipped);
  }
  if (failed > 0) throw std::runtime_error(fmt::format("hil: {} failed", failed_names));
}

}  // namespace

void add_hil_commands(CLI::App& app) {
  auto a = std::make_shared<HilArgs>();
  auto* cmd = app.add_subcommand(
      "hil",
      "Hardware-in-loop tests of a real rig, from its rig.toml's [hil] section (tests/hil/README.md): "
      "loopback (trigger output wired to an input: every pulse seen, period jitter p50/p95/p99/max from the "
      "kernel's edge timestamps, missed and extra pulses), edge-input (N pulses -> N events at [hil] "
      "rates_hz, "
      "60 and 120 Hz), alignment (triggered cameras: each frame paired with its pulse, offset percentiles, "
      "unpaired frames), smoke (the whole rig for [hil] smoke_seconds: every node connects, frames merge). "
      "A test whose lines are not configured is SKIPPED with the keys to set. --emulated runs the twin: udp "
      "trigger on loopback, sim cameras, the emulated rig. Exit 1 when a test fails, 2 on bad input");
  cmd->add_option("--config", a->config,
                  "the rig file naming the real lines ([trigger], [hil]); default $VOXCAP_RIG or ./rig.toml");
  cmd->add_flag("--emulated", a->emulated,
                "run the emulated twin: udp trigger on loopback, two sim cameras, a 2-node emulated rig (no "
                "hardware; --config only for [hil] pulses and [trigger] rate_hz)");
  cmd->add_option("--tests", a->tests,
                  "comma-separated tests to run: loopback, edge-input, alignment, smoke (default: all)");
  cmd->add_option("--pulses", a->pulses, "pulses per train (default [hil] pulses, 600)");
  cmd->add_option("--rate", a->rate_hz,
                  "trigger rate of every train, Hz (default: [trigger] rate_hz for loopback and alignment, "
                  "[hil] rates_hz for edge-input)");
  cmd->add_option("--seconds", a->seconds,
                  "smoke run length after every node is running (default [hil] smoke_seconds; emulated 4)");
  cmd->add_flag(
      "--json", a->json,
      "print JSON: {mode, rig, config, passed, failed, skipped, tests[] {name, status (PASS|FAIL|"
      "SKIPPED), reason, figures}}; loopback figures {output, input, rate_hz, pulses, sent, seen, "
      "matched, missed, extra, seq_gaps, input_lost, period_us, offset_us, jitter_us {n, min, p50, p95, "
      "p99, max}, spread_us {...}, missed_seqs, extra_at_us, output_late, output_missed_slots, "
      "output_max_lateness_us, output_error}; edge-input {rates[] {the same, status, reason}}; "
      "alignment {output, input, rate_hz, pulses, pulses_seen, cameras[] {camera, backend, device, "
      "latency_us, frames, paired, unpaired, duplicate, pulses_without_frame, driver_dropped, offset_us "
      "{...}, error}}; smoke {seconds, nodes, nodes_connected, nodes_missing, running, pulses, frames, "
      "complete, degraded, dropped, fps, merged_seconds, trigger_to_merged_ms {p50, p99}, "
      "merging_stopped}; a figure not measured is null");
  cmd->callback([a] { run_hil(*a); });
}

}  // namespace vc::cli
