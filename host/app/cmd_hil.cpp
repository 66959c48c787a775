// `voxcap hil`: the hardware-in-loop tests of a real rig, driven by its rig.toml's [hil] section, and
// their emulated twin (`--emulated`: udp trigger on loopback, sim cameras, the emulated rig):
//
//   loopback     the host's trigger output ([trigger]) wired to an input ([hil.loopback]): every pulse
//                seen, period jitter from the kernel's edge timestamps, missed and extra pulses
//   edge-input   the edge's trigger input line ([hil.edge_input]): N pulses -> N events at each of
//                [hil] rates_hz (60 and 120 Hz)
//   alignment    externally triggered cameras ([[hil.cameras]]) on the same wire: each frame paired with
//                its pulse (the edge input's timestamps), offset percentiles, unpaired frames
//   smoke        the whole rig of the file for [hil] smoke_seconds: every node connects, frames merge
//
// The devices sit behind the existing interfaces (vc::trigger::Generator for the output, vc_trigger for
// the input, vc_camera for the cameras, the aggregator); every figure and verdict comes from host/hil,
// which sees only timestamp streams, so the emulated twin proves the same logic a real run uses and
// prints the same lines and JSON keys. A test whose lines are not configured is SKIPPED with the keys to
// set; any FAIL exits 1, bad input 2.
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/edge/camera.h"
#include "voxcap/edge/trigger.h"
#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/hil/measure.hpp"
#include "voxcap/trigger/generator.hpp"

namespace vc::cli {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

const std::vector<std::string> kTests = {"loopback", "edge-input", "alignment", "smoke"};

struct HilArgs {
  std::string config;
  bool emulated = false;
  std::string tests;
  uint64_t pulses = 0;
  double rate_hz = 0;
  double seconds = 0;
  bool json = false;
};

// One test's outcome: its verdict, the figures (JSON) and the lines printed for it.
struct Outcome {
  std::string name;
  hil::Verdict verdict;
  json figures = json::object();
};

json number(double x) {
  return std::isfinite(x) ? json(x) : json(nullptr);
}

json percentiles_json(const hil::Percentiles& p) {
  return {{"n", p.n},
          {"min", number(p.min)},
          {"p50", number(p.p50)},
          {"p95", number(p.p95)},
          {"p99", number(p.p99)},
          {"max", number(p.max)}};
}

std::string fmt_us(double x) {
  return std::isfinite(x) ? fmt::format("{:.1f}", x) : std::string("-");
}

std::string percentiles_line(const hil::Percentiles& p) {
  return fmt::format("p50 {} / p95 {} / p99 {} / max {} us", fmt_us(p.p50), fmt_us(p.p95), fmt_us(p.p99),
                     fmt_us(p.max));
}

// Where the tests' pulses come from and go to: a real rig's lines or the emulated twin's loopback.
struct Rig {
  bool emulated = false;
  config::RigConfig config;  // the rig file (emulated without --config: defaults)
  bool have_file = false;
  uint64_t pulses = 600;
  double rate_hz = 60;
  std::vector<double> edge_rates_hz = {60, 120};
  double smoke_seconds = 0;
  bool json = false;
};

void say(const Rig& rig, const std::string& line) {
  if (!rig.json) fmt::print("{}\n", line);
}

// ---- the input side: a vc_trigger (gpiod line on a real rig, loopback udp when emulated) ----

struct Input {
  vc_trigger* trig = nullptr;
  std::string describe;
  uint16_t udp_port = 0;
  std::string chip;  // kept alive for the config's borrowed pointers
  std::string line_name;
  Input() = default;
  Input(const Input&) = delete;
  Input& operator=(const Input&) = delete;
  ~Input() { vc_trigger_free(trig); }
};

// Opens the input: the configured line, or a udp socket on a free loopback port. Throws with the
// backend's one-line message.
std::unique_ptr<Input> open_input(const Rig& rig, const config::HilLine* line) {
  auto in = std::make_unique<Input>();
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  if (rig.emulated) {
    cfg.backend = "udp";
    cfg.bind_address = "127.0.0.1";
    cfg.source_address = "127.0.0.1";
    cfg.port = 0;
  } else {
    in->chip = line->chip;
    in->line_name = line->line_name;
    cfg.backend = "gpiod";
    cfg.chip = in->chip.c_str();
    if (!in->line_name.empty())
      cfg.line_name = in->line_name.c_str();
    else
      cfg.line_offset = static_cast<unsigned>(line->line_offset);
    cfg.active_low = line->active_low.value_or(rig.config.trigger.active_low);
    cfg.debounce_us = static_cast<unsigned>(line->debounce_us);
    cfg.event_clock = VC_CLOCK_MONOTONIC;
  }
  char why[320] = "";
  if (vc_trigger_open(&cfg, &in->trig, why, sizeof why) != 0)
    throw std::runtime_error(fmt::format("input: {}", why));
  vc_trigger_info info;
  vc_trigger_get_info(in->trig, &info);
  in->describe = fmt::format("{} {}", info.backend, info.source);
  in->udp_port = info.port;
  return in;
}

// The output: the rig's [trigger] (gpiod or ftdi), or udp to the input's port when emulated.
config::TriggerOptions output_options(const Rig& rig, const Input& in, double rate_hz) {
  config::TriggerOptions o = rig.config.trigger;
  if (rig.emulated) {
    o = config::TriggerOptions{};
    o.backend = config::TriggerBackend::Udp;
    o.udp.targets = {config::Endpoint{"127.0.0.1", in.udp_port}};
    o.rt_priority = 0;  // a shared machine: no real-time thread for the twin
  }
  o.rate_hz = rate_hz;
  // Keep the configured width where the rate allows it (below half the period, with margin).
  o.pulse_width_us = std::min(o.pulse_width_us, 0.4 * 1e6 / rate_hz);
  return o;
}

// What one train produced: the output's pulses (its own times) and the input's edges (kernel times).
struct TrainRun {
  std::vector<hil::Stamp> sent, seen;
  trigger::Stats out;
  vc_trigger_stats in{};
  std::string output, error;
  double rate_hz = 0;
  uint64_t pulses = 0;
};

// Sends `n` pulses at `rate_hz` through the output while a thread reads the input; `on_pulse` is
// called on the reader thread for each edge (the alignment test's emulated cameras take their soft
// trigger there).
TrainRun run_train(const Rig& rig, Input& in, double rate_hz, uint64_t n,
                   const std::function<void(const vc_pulse&)>& on_pulse = {}) {
  TrainRun run;
  run.rate_hz = rate_hz;
  run.pulses = n;
  const config::TriggerOptions o = output_options(rig, in, rate_hz);
  std::string why;
  if (!o.valid(&why)) throw std::runtime_error("trigger." + why);
  std::unique_ptr<trigger::Generator> gen = trigger::make_generator(o);
  run.output = gen->describe();
  std::mutex mu;
  gen->set_observer([&](const trigger::Pulse& p) {
    std::lock_guard<std::mutex> lock(mu);
    run.sent.push_back({p.seq, p.t_ns});
  });
  std::atomic<bool> stop{false};
  std::vector<hil::Stamp> seen;
  std::thread reader([&] {
    while (!stop) {
      vc_pulse p{};
      if (vc_trigger_wait(in.trig, 50, &p) != 0) continue;
      {
        std::lock_guard<std::mutex> lock(mu);
        seen.push_back({p.seq, static_cast<int64_t>(p.t_ns)});
      }
      if (on_pulse) on_pulse(p);
    }
  });
  try {
    gen->start(trigger::PulseTrain{o.rate_hz, o.pulse_width_us, n, 0});
    const auto budget =
        std::chrono::milliseconds(static_cast<long>(3000 + 2000.0 * static_cast<double>(n) / rate_hz));
    if (!gen->wait_done(budget)) run.error = "the output did not finish its train in time";
    gen->stop();
  } catch (const std::exception& e) {
    run.error = e.what();
  }
  // Edges still in flight (the input's queue, the loopback socket): a bounded wait for the last ones.
  const auto until = Clock::now() + std::chrono::milliseconds(300);
  while (Clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::lock_guard<std::mutex> lock(mu);
    if (seen.size() >= run.sent.size() && !run.sent.empty()) break;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(60));
  stop = true;
  reader.join();
  std::lock_guard<std::mutex> lock(mu);
  run.seen = std::move(seen);
  run.out = gen->stats();
  if (run.error.empty()) run.error = gen->last_error();
  vc_trigger_get_stats(in.trig, &run.in);
  return run;
}

// The train's figures as JSON and as the printed lines.
json train_json(const TrainRun& run, const hil::TrainResult& r, const std::string& input) {
  json missed = json::array(), extra = json::array();
  for (uint64_t s : r.missed_seqs) missed.push_back(s);
  for (int64_t t : r.extra_at_us) extra.push_back(t);
  return {{"output", run.output},
          {"input", input},
          {"rate_hz", run.rate_hz},
          {"pulses", run.pulses},
          {"sent", r.sent},
          {"seen", r.seen},
          {"matched", r.matched},
          {"missed", r.missed},
          {"extra", r.extra},
          {"seq_gaps", r.seq_gaps},
          {"input_lost", run.in.lost},
          {"period_us", number(r.period_us)},
          {"offset_us", number(r.offset_us)},
          {"jitter_us", percentiles_json(r.jitter_us)},
          {"spread_us", percentiles_json(r.spread_us)},
          {"missed_seqs", missed},
          {"extra_at_us", extra},
          {"output_late", run.out.late},
          {"output_missed_slots", run.out.missed},
          {"output_max_lateness_us", static_cast<double>(run.out.max_lateness_ns) / 1e3},
          {"output_error", run.error}};
}

void print_train(const Rig& rig, const TrainRun& run, const hil::TrainResult& r) {
  say(rig, fmt::format("  sent {}, seen {}, matched {}, missed {}, extra {}, input counter gaps {}", r.sent,
                       r.seen, r.matched, r.missed, r.extra, r.seq_gaps));
  say(rig, fmt::format("  period {} us; jitter {}; offset {} us (spread p99 {} us)", fmt_us(r.period_us),
                       percentiles_line(r.jitter_us), fmt_us(r.offset_us), fmt_us(r.spread_us.p99)));
  say(rig, fmt::format("  output: late {}, missed slots {}, max lateness {:.1f} us{}", run.out.late,
                       run.out.missed, static_cast<double>(run.out.max_lateness_ns) / 1e3,
                       run.error.empty() ? "" : ", error: " + run.error));
}

hil::Verdict with_output_error(hil::Verdict v, const TrainRun& run) {
  if (run.error.empty()) return v;
  v.status = hil::Status::Fail;
  v.reason = "output: " + run.error + (v.reason.empty() ? "" : "; " + v.reason);
  return v;
}

hil::Verdict skip(std::string reason) {
  return {hil::Status::Skip, std::move(reason)};
}

// ---- 1. trigger loopback ----

Outcome test_loopback(const Rig& rig) {
  Outcome out{"loopback", {}, json::object()};
  const config::HilLine& line = rig.config.hil.loopback;
  if (!rig.emulated && !line.configured()) {
    out.verdict = skip(
        "no loopback line configured: wire the trigger output ([trigger]) to a free GPIO input and name it "
        "in "
        "the rig file as [hil.loopback] chip = \"gpiochip0\", line = 17");
    return out;
  }
  if (!rig.emulated && rig.config.trigger.backend == config::TriggerBackend::Udp) {
    out.verdict =
        skip("[trigger] backend is udp: a loopback needs a wire ([trigger] backend = \"gpiod\" or \"ftdi\")");
    return out;
  }
  auto in = open_input(rig, &line);
  say(rig, fmt::format("[loopback] {} pulses at {} Hz -> input {}", rig.pulses, rig.rate_hz, in->describe));
  const TrainRun run = run_train(rig, *in, rig.rate_hz, rig.pulses);
  const hil::TrainResult r = hil::match_train(run.sent, run.seen, {rig.rate_hz});
  print_train(rig, run, r);
  out.figures = train_json(run, r, in->describe);
  out.verdict = with_output_error(hil::judge_train(r, rig.pulses, rig.config.hil.max_jitter_us), run);
  return out;
}

// ---- 2. edge trigger input at each rate ----

Outcome test_edge_input(const Rig& rig) {
  Outcome out{"edge-input", {}, json::object()};
  const config::HilLine& line = rig.config.hil.edge_input;
  if (!rig.emulated && !line.configured()) {
    out.verdict = skip(
        "no edge trigger input configured: name the edge's trigger input line, fed by the trigger output, as "
        "[hil.edge_input] chip = \"gpiochip0\", line = \"GPIO17\" (as the edge's edge.toml)");
    return out;
  }
  if (!rig.emulated && rig.config.trigger.backend == config::TriggerBackend::Udp) {
    out.verdict = skip(
        "[trigger] backend is udp: the edge input test needs a wire ([trigger] backend = \"gpiod\" or "
        "\"ftdi\")");
    return out;
  }
  out.figures["rates"] = json::array();
  std::vector<std::string> failed;
  uint64_t events = 0;
  for (double rate : rig.edge_rates_hz) {
    auto in = open_input(rig, &line);  // a fresh request per rate: its counter starts again
    say(rig, fmt::format("[edge-input] {} pulses at {} Hz -> input {}", rig.pulses, rate, in->describe));
    const TrainRun run = run_train(rig, *in, rate, rig.pulses);
    const hil::TrainResult r = hil::match_train(run.sent, run.seen, {rate});
    print_train(rig, run, r);
    const hil::Verdict v =
        with_output_error(hil::judge_train(r, rig.pulses, rig.config.hil.max_jitter_us), run);
    json f = train_json(run, r, in->describe);
    f["status"] = hil::to_string(v.status);
    f["reason"] = v.reason;
    out.figures["rates"].push_back(f);
    say(rig, fmt::format("  {} Hz: {}: {}", rate, hil::to_string(v.status), v.reason));
    if (v.status == hil::Status::Fail) failed.push_back(fmt::format("{} Hz: {}", rate, v.reason));
    events += r.matched;
  }
  if (failed.empty()) {
    std::string rates;
    for (double r : rig.edge_rates_hz) rates += (rates.empty() ? "" : " and ") + fmt::format("{}", r);
    out.verdict = {hil::Status::Pass, fmt::format("{} pulses -> {} events at each of {} Hz, none missed",
                                                  rig.pulses, rig.pulses, rates)};
  } else {
    std::string reason;
    for (const std::string& f : failed) reason += (reason.empty() ? "" : "; ") + f;
    out.verdict = {hil::Status::Fail, reason};
  }
  (void)events;
  return out;
}

// ---- 3. frame/trigger alignment ----

struct Camera {
  vc_camera* cam = nullptr;
  std::string backend, device, options;
  double latency_us = 0;
  Camera() = default;
  Camera(const Camera&) = delete;
  Camera& operator=(const Camera&) = delete;
  ~Camera() { vc_camera_free(cam); }
};

// The emulated twin's cameras: two sim cameras of the virtual rig, externally triggered (a frame per
// soft trigger, stamped pulse + latency), small so they keep up on a loaded machine.
constexpr double kEmulatedLatencyUs = 1000;

std::vector<std::unique_ptr<Camera>> open_cameras(const Rig& rig, double rate_hz) {
  std::vector<std::unique_ptr<Camera>> cams;
  const size_t n = rig.emulated ? 2 : rig.config.hil.cameras.size();
  for (size_t k = 0; k < n; ++k) {
    auto c = std::make_unique<Camera>();
    vc_camera_config cfg;
    vc_camera_config_init(&cfg);
    cfg.external_trigger = true;
    cfg.fps_num = static_cast<uint32_t>(std::lround(rate_hz));
    cfg.fps_den = 1;
    if (rig.emulated) {
      c->backend = "sim";
      c->device = "motion=tpose,cameras=2,size=160x120,noise=0";
      c->options = "pace=0";
      c->latency_us = kEmulatedLatencyUs;
      cfg.index = static_cast<int>(k);
      cfg.options = c->options.c_str();
    } else {
      const config::HilCamera& hc = rig.config.hil.cameras[k];
      c->backend = hc.backend;
      c->device = hc.device;
      c->latency_us = hc.latency_us;
      cfg.width = hc.width;
      cfg.height = hc.height;
      cfg.exposure_us = hc.exposure_us;
      if (hc.backend == "v4l2" && vc_pixfmt_from_name(hc.format.c_str(), &cfg.pixfmt) != 0)
        throw UsageError(fmt::format("hil.cameras[{}].format: unknown pixel format \"{}\"", k, hc.format));
    }
    cfg.backend = c->backend.c_str();
    cfg.device = c->device.c_str();
    cfg.trigger_latency_ns = static_cast<int64_t>(c->latency_us * 1e3);
    char why[320] = "";
    if (vc_camera_open(&cfg, &c->cam, why, sizeof why) != 0)
      throw std::runtime_error(fmt::format("camera {} ({} {}): {}", k, c->backend, c->device, why));
    cams.push_back(std::move(c));
  }
  return cams;
}

Outcome test_alignment(const Rig& rig) {
  Outcome out{"alignment", {}, json::object()};
  const config::HilOptions& h = rig.config.hil;
  if (!rig.emulated && (h.cameras.empty() || !h.edge_input.configured())) {
    out.verdict = skip(
        "no triggered cameras configured: name them as [[hil.cameras]] backend = \"libcamera\", device = "
        "\"0\" "
        "(their trigger inputs on the trigger wire, external trigger on) and the line that times the pulses "
        "as "
        "[hil.edge_input]");
    return out;
  }
  if (!rig.emulated && rig.config.trigger.backend == config::TriggerBackend::Udp) {
    out.verdict = skip(
        "[trigger] backend is udp: real cameras need a trigger wire ([trigger] backend = \"gpiod\" or "
        "\"ftdi\")");
    return out;
  }
  auto in = open_input(rig, &h.edge_input);
  auto cams = open_cameras(rig, rig.rate_hz);
  std::string names;
  for (const auto& c : cams) names += (names.empty() ? "" : ", ") + c->backend + " " + c->device;
  say(rig, fmt::format("[alignment] {} pulses at {} Hz -> input {}, cameras: {}", rig.pulses, rig.rate_hz,
                       in->describe, names));
  for (const auto& c : cams)
    if (vc_camera_start(c->cam) != 0)
      throw std::runtime_error(
          fmt::format("camera {} {}: {}", c->backend, c->device, vc_camera_last_error(c->cam)));

  std::mutex mu;
  std::vector<hil::FrameStamp> frames;
  std::atomic<bool> stop{false};
  std::vector<std::string> errors(cams.size());
  std::vector<std::thread> capture;
  for (size_t k = 0; k < cams.size(); ++k) {
    capture.emplace_back([&, k] {
      while (!stop) {
        vc_frame f;
        const int rc = vc_camera_capture(cams[k]->cam, 100, &f);
        if (rc == -ETIMEDOUT) continue;
        if (rc != 0) {
          errors[k] = vc_camera_last_error(cams[k]->cam);
          return;
        }
        {
          std::lock_guard<std::mutex> lock(mu);
          frames.push_back({static_cast<int>(k), f.sequence, static_cast<int64_t>(f.t_ns)});
        }
        vc_camera_release(cams[k]->cam, &f);
      }
    });
  }
  // The emulated cameras' trigger wire: each pulse the input sees exposes a frame.
  std::function<void(const vc_pulse&)> wire;
  if (rig.emulated)
    wire = [&](const vc_pulse& p) {
      for (const auto& c : cams) vc_camera_soft_trigger(c->cam, p.seq, p.t_ns);
    };
  TrainRun run;
  try {
    run = run_train(rig, *in, rig.rate_hz, rig.pulses, wire);
    // The last frames: exposure and readout after the last pulse.
    const auto until = Clock::now() + std::chrono::milliseconds(1000);
    while (Clock::now() < until) {
      {
        std::lock_guard<std::mutex> lock(mu);
        if (frames.size() >= run.seen.size() * cams.size()) break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  } catch (...) {
    stop = true;
    for (auto& t : capture) t.join();
    throw;
  }
  stop = true;
  for (auto& t : capture) t.join();

  // Each camera may have its own latency: each camera's frames are paired alone.
  hil::AlignOptions ao;
  ao.rate_hz = rig.rate_hz;
  out.figures = {{"output", run.output}, {"input", in->describe},          {"rate_hz", rig.rate_hz},
                 {"pulses", rig.pulses}, {"pulses_seen", run.seen.size()}, {"cameras", json::array()}};
  std::vector<std::string> wrong;
  uint64_t paired = 0, total = 0;
  for (size_t k = 0; k < cams.size(); ++k) {
    hil::AlignOptions one = ao;
    one.cameras = 1;
    one.latency_us = cams[k]->latency_us;
    std::vector<hil::FrameStamp> mine;
    for (const hil::FrameStamp& f : frames)
      if (f.camera == static_cast<int>(k)) mine.push_back({0, f.sequence, f.t_ns});
    const hil::AlignResult a = hil::align_frames(run.seen, mine, one);
    const hil::CameraAlignment& c = a.cameras.at(0);
    const hil::Verdict v = hil::judge_alignment(a, one, rig.config.hil.max_offset_us);
    paired += c.paired;
    total += c.frames;
    vc_camera_stats st{};
    vc_camera_get_stats(cams[k]->cam, &st);
    out.figures["cameras"].push_back({{"camera", k},
                                      {"backend", cams[k]->backend},
                                      {"device", cams[k]->device},
                                      {"latency_us", cams[k]->latency_us},
                                      {"frames", c.frames},
                                      {"paired", c.paired},
                                      {"unpaired", c.unpaired},
                                      {"duplicate", c.duplicate},
                                      {"pulses_without_frame", c.pulses_without_frame},
                                      {"driver_dropped", st.dropped},
                                      {"offset_us", percentiles_json(c.offset_us)},
                                      {"error", errors[k]}});
    say(rig,
        fmt::format("  camera {} ({} {}): frames {}, paired {}, unpaired {}, pulses without frame {}, driver "
                    "dropped {}",
                    k, cams[k]->backend, cams[k]->device, c.frames, c.paired, c.unpaired,
                    c.pulses_without_frame, st.dropped));
    say(rig,
        fmt::format("    frame - pulse offset min {} / {} (expected latency {} us)", fmt_us(c.offset_us.min),
                    percentiles_line(c.offset_us), fmt_us(cams[k]->latency_us)));
    if (v.status == hil::Status::Fail) {
      std::string reason = v.reason;  // judged as camera 0 of one: named by its index here
      for (size_t at = 0; (at = reason.find("camera 0", at)) != std::string::npos; at += 6)
        reason.replace(at, 8, fmt::format("camera {}", k));
      wrong.push_back(reason);
    }
    if (!errors[k].empty()) wrong.push_back(fmt::format("camera {}: {}", k, errors[k]));
  }
  if (run.seen.empty()) wrong.insert(wrong.begin(), "no pulse seen on the input line");
  if (!run.error.empty()) wrong.insert(wrong.begin(), "output: " + run.error);
  if (wrong.empty()) {
    out.verdict = {hil::Status::Pass, fmt::format("{} of {} frames paired with their pulse on {} camera(s)",
                                                  paired, total, cams.size())};
  } else {
    std::string reason;
    for (const std::string& w : wrong) reason += (reason.empty() ? "" : "; ") + w;
    out.verdict = {hil::Status::Fail, reason};
  }
  return out;
}

// ---- 4. full-rig smoke run ----

hil::SmokeFigures smoke_figures(const aggregator::Report& rep, size_t nodes, double seconds) {
  hil::SmokeFigures f;
  f.nodes = nodes;
  for (const aggregator::NodeReport& n : rep.nodes) {
    if (n.connected && n.state == VC_STATE_RUNNING)
      ++f.nodes_connected;
    else
      f.nodes_missing.push_back(n.name);
  }
  f.pulses = rep.pulses;
  f.frames = rep.frames;
  f.complete = rep.complete;
  f.degraded = rep.degraded;
  f.dropped = rep.dropped;
  f.seconds = seconds;
  f.fps = rep.fps;
  f.merged_p50_ms = rep.merged.percentile_ms(0.5);
  f.merged_p99_ms = rep.merged.percentile_ms(0.99);
  f.running = rep.running;
  f.merging_stopped = rep.merging_stopped();
  return f;
}

std::atomic<bool> g_interrupted{false};

void on_signal(int) {
  g_interrupted = true;
}

void wait_seconds(double s) {
  const auto end = Clock::now() + std::chrono::duration<double>(s);
  while (!g_interrupted && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(20));
}

Outcome test_smoke(const Rig& rig) {
  Outcome out{"smoke", {}, json::object()};
  if (rig.smoke_seconds <= 0) {
    out.verdict = skip(
        "no smoke run configured: give the rig's run length as [hil] smoke_seconds = 10 (or --seconds); the "
        "rig's edges must be up (voxcap deploy)");
    return out;
  }
  aggregator::Report rep;
  size_t nodes = 0;
  if (rig.emulated) {
    emulated::Options o;
    o.nodes = 2;
    o.width = 320;
    o.height = 240;
    o.rate_hz = 30;
    o.grid = 32;
    o.truth_every = 0;
    o.motion = "wave";
    nodes = 2;
    say(rig, fmt::format("[smoke] the emulated rig: {} nodes, {}x{}, {} Hz, {} s", o.nodes, o.width, o.height,
                         o.rate_hz, rig.smoke_seconds));
    emulated::EmulatedRig er(o);
    er.start(120);
    wait_seconds(rig.smoke_seconds);
    rep = er.stop().report;
  } else {
    nodes = rig.config.nodes.size();
    say(rig, fmt::format("[smoke] rig \"{}\": {} nodes, {} s after every node is running", rig.config.name,
                         nodes, rig.smoke_seconds));
    aggregator::Options ao;
    ao.log_every_s = 0;
    aggregator::Aggregator agg(rig.config, ao);
    agg.start();
    // Every node must connect, configure, learn its background and start: bounded.
    const auto deadline = Clock::now() + std::chrono::seconds(60);
    while (!g_interrupted && !agg.report().running && Clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (agg.report().running) wait_seconds(rig.smoke_seconds);
    rep = agg.report();
    agg.stop();
  }
  const hil::SmokeFigures f = smoke_figures(rep, nodes, rep.seconds);
  json missing = json::array();
  for (const std::string& id : f.nodes_missing) missing.push_back(id);
  out.figures = {
      {"seconds", rig.smoke_seconds},
      {"nodes", f.nodes},
      {"nodes_connected", f.nodes_connected},
      {"nodes_missing", missing},
      {"running", f.running},
      {"pulses", f.pulses},
      {"frames", f.frames},
      {"complete", f.complete},
      {"degraded", f.degraded},
      {"dropped", f.dropped},
      {"fps", number(f.fps)},
      {"merged_seconds", number(rep.seconds)},
      {"trigger_to_merged_ms", {{"p50", number(f.merged_p50_ms)}, {"p99", number(f.merged_p99_ms)}}},
      {"merging_stopped", f.merging_stopped}};
  say(rig,
      fmt::format(
          "  nodes {} of {} connected{}, pulses {}, frames {} (complete {}, degraded {}, dropped {}), "
          "{:.1f} fps",
          f.nodes_connected, f.nodes,
          f.nodes_missing.empty() ? std::string()
                                  : " (missing: " + fmt::format("{}", fmt::join(f.nodes_missing, ", ")) + ")",
          f.pulses, f.frames, f.complete, f.degraded, f.dropped, f.fps));
  say(rig, fmt::format("  trigger -> merged p50 {:.1f} / p99 {:.1f} ms{}", f.merged_p50_ms, f.merged_p99_ms,
                       f.merging_stopped ? ", merging STOPPED" : ""));
  out.verdict = hil::judge_smoke(f);
  return out;
}

std::vector<std::string> parse_tests(const std::string& list) {
  if (list.empty() || list == "all") return kTests;
  std::vector<std::string> out;
  std::stringstream ss(list);
  for (std::string t; std::getline(ss, t, ',');) {
    if (t.empty()) continue;
    if (std::find(kTests.begin(), kTests.end(), t) == kTests.end())
      throw UsageError(
          fmt::format("--tests: unknown test \"{}\" (loopback, edge-input, alignment, smoke)", t));
    if (std::find(out.begin(), out.end(), t) == out.end()) out.push_back(t);
  }
  if (out.empty()) throw UsageError("--tests: name at least one test");
  return out;
}

Rig make_rig(const HilArgs& a) {
  Rig rig;
  rig.emulated = a.emulated;
  rig.json = a.json;
  if (!a.config.empty() || !a.emulated) {
    const std::filesystem::path path =
        a.config.empty() ? config::default_rig_config_path() : std::filesystem::path(a.config);
    try {
      rig.config = config::load_rig_config(path);
    } catch (const config::ConfigError& e) {
      throw UsageError(e.what());
    }
    rig.have_file = true;
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
  return rig;
}

void run_hil(const HilArgs& a) {
  const std::vector<std::string> tests = parse_tests(a.tests);
  const Rig rig = make_rig(a);
  g_interrupted = false;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (!rig.emulated && !rig.config.hil.present)
    say(rig,
        fmt::format("voxcap hil: {} has no [hil] section: every test is skipped (tests/hil/README.md says "
                    "what to wire and configure)",
                    rig.config.source.string()));
  say(rig, rig.emulated
               ? std::string("voxcap hil: the emulated twin (udp trigger on loopback, sim cameras, the "
                             "emulated rig)")
               : fmt::format("voxcap hil: rig \"{}\" ({}), trigger {}", rig.config.name,
                             rig.config.source.string(), config::to_string(rig.config.trigger.backend)));
  std::vector<Outcome> outcomes;
  for (const std::string& t : tests) {
    if (g_interrupted) break;
    Outcome o;
    try {
      if (t == "loopback") o = test_loopback(rig);
      if (t == "edge-input") o = test_edge_input(rig);
      if (t == "alignment") o = test_alignment(rig);
      if (t == "smoke") o = test_smoke(rig);
    } catch (const UsageError&) {
      throw;
    } catch (const std::exception& e) {  // a device missing or busy: this test fails, the others run
      o.name = t;
      o.verdict = {hil::Status::Fail, e.what()};
    }
    if (o.verdict.status == hil::Status::Skip)
      say(rig, fmt::format("[{}] SKIPPED: {}", t, o.verdict.reason));
    else
      say(rig, fmt::format("[{}] {}: {}", t, hil::to_string(o.verdict.status), o.verdict.reason));
    outcomes.push_back(std::move(o));
  }
  size_t passed = 0, failed = 0, skipped = 0;
  std::string failed_names;
  for (const Outcome& o : outcomes) {
    passed += o.verdict.status == hil::Status::Pass;
    skipped += o.verdict.status == hil::Status::Skip;
    if (o.verdict.status == hil::Status::Fail) {
      ++failed;
      failed_names += (failed_names.empty() ? "" : ", ") + o.name;
    }
  }
  if (rig.json) {
    json j = {{"mode", rig.emulated ? "emulated" : "real"},
              {"rig", rig.config.name},
              {"config", rig.have_file ? rig.config.source.string() : std::string()},
              {"tests", json::array()},
              {"passed", passed},
              {"failed", failed},
              {"skipped", skipped}};
    for (const Outcome& o : outcomes)
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
