// The hardware-in-loop tests' runners (run.hpp): the devices on one side, measure.hpp's figures and
// verdicts on the other. Moved here from the command (host/app/cmd_hil.cpp), which keeps its options
// and the printing.
#include "voxcap/hil/run.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/edge/trigger.h"
#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/hil/camera.hpp"
#include "voxcap/trigger/generator.hpp"

namespace vc::hil {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

// Why the alignment test cannot open a camera in this build.
std::string open_camera_reason() {
  try {
    open_camera(CameraSpec{});
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no camera backend";
}

json number(double x) {
  return std::isfinite(x) ? json(x) : json(nullptr);
}

json percentiles_json(const Percentiles& p) {
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

std::string percentiles_line(const Percentiles& p) {
  return fmt::format("p50 {} / p95 {} / p99 {} / max {} us", fmt_us(p.p50), fmt_us(p.p95), fmt_us(p.p99),
                     fmt_us(p.max));
}

void say(const RunOptions& rig, const std::string& line) {
  if (rig.say) rig.say(line);
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
std::unique_ptr<Input> open_input(const RunOptions& rig, const config::HilLine* line) {
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
config::TriggerOptions output_options(const RunOptions& rig, const Input& in, double rate_hz) {
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
  std::vector<Stamp> sent, seen;
  trigger::Stats out;
  vc_trigger_stats in{};
  std::string output, error;
  double rate_hz = 0;
  uint64_t pulses = 0;
};

// Sends `n` pulses at `rate_hz` through the output while a thread reads the input; `on_pulse` is
// called on the reader thread for each edge (the alignment test's emulated cameras take their soft
// trigger there).
TrainRun run_train(const RunOptions& rig, Input& in, double rate_hz, uint64_t n,
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
  std::vector<Stamp> seen;
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
json train_json(const TrainRun& run, const TrainResult& r, const std::string& input) {
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

void print_train(const RunOptions& rig, const TrainRun& run, const TrainResult& r) {
  say(rig, fmt::format("  sent {}, seen {}, matched {}, missed {}, extra {}, input counter gaps {}", r.sent,
                       r.seen, r.matched, r.missed, r.extra, r.seq_gaps));
  say(rig, fmt::format("  period {} us; jitter {}; offset {} us (spread p99 {} us)", fmt_us(r.period_us),
                       percentiles_line(r.jitter_us), fmt_us(r.offset_us), fmt_us(r.spread_us.p99)));
  say(rig, fmt::format("  output: late {}, missed slots {}, max lateness {:.1f} us{}", run.out.late,
                       run.out.missed, static_cast<double>(run.out.max_lateness_ns) / 1e3,
                       run.error.empty() ? "" : ", error: " + run.error));
}

Verdict with_output_error(Verdict v, const TrainRun& run) {
  if (run.error.empty()) return v;
  v.status = Status::Fail;
  v.reason = "output: " + run.error + (v.reason.empty() ? "" : "; " + v.reason);
  return v;
}

Verdict skip(std::string reason) {
  return {Status::Skip, std::move(reason)};
}

// ---- 1. trigger loopback ----

Outcome test_loopback(const RunOptions& rig) {
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
  const TrainResult r = match_train(run.sent, run.seen, {rig.rate_hz});
  print_train(rig, run, r);
  out.figures = train_json(run, r, in->describe);
  out.verdict = with_output_error(judge_train(r, rig.pulses, rig.config.hil.max_jitter_us), run);
  return out;
}

// ---- 2. edge trigger input at each rate ----

Outcome test_edge_input(const RunOptions& rig) {
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
    const TrainResult r = match_train(run.sent, run.seen, {rate});
    print_train(rig, run, r);
    const Verdict v = with_output_error(judge_train(r, rig.pulses, rig.config.hil.max_jitter_us), run);
    json f = train_json(run, r, in->describe);
    f["status"] = to_string(v.status);
    f["reason"] = v.reason;
    out.figures["rates"].push_back(f);
    say(rig, fmt::format("  {} Hz: {}: {}", rate, to_string(v.status), v.reason));
    if (v.status == Status::Fail) failed.push_back(fmt::format("{} Hz: {}", rate, v.reason));
    events += r.matched;
  }
  if (failed.empty()) {
    std::string rates;
    for (double r : rig.edge_rates_hz) rates += (rates.empty() ? "" : " and ") + fmt::format("{}", r);
    out.verdict = {Status::Pass, fmt::format("{} pulses -> {} events at each of {} Hz, none missed",
                                             rig.pulses, rig.pulses, rates)};
  } else {
    std::string reason;
    for (const std::string& f : failed) reason += (reason.empty() ? "" : "; ") + f;
    out.verdict = {Status::Fail, reason};
  }
  (void)events;
  return out;
}

// ---- 3. frame/trigger alignment ----

// The emulated twin's cameras: two sim cameras of the virtual rig, externally triggered (a frame per
// soft trigger, stamped pulse + latency), small so they keep up on a loaded machine.
constexpr double kEmulatedLatencyUs = 1000;

std::vector<CameraSpec> camera_specs(const RunOptions& rig, double rate_hz) {
  std::vector<CameraSpec> specs;
  const size_t n = rig.emulated ? 2 : rig.config.hil.cameras.size();
  for (size_t k = 0; k < n; ++k) {
    CameraSpec s;
    s.rate_hz = rate_hz;
    if (rig.emulated) {
      s.backend = "sim";
      s.device = "motion=tpose,cameras=2,size=160x120,noise=0";
      s.options = "pace=0";
      s.latency_us = kEmulatedLatencyUs;
      s.index = static_cast<int>(k);
    } else {
      const config::HilCamera& hc = rig.config.hil.cameras[k];
      s.backend = hc.backend;
      s.device = hc.device;
      s.latency_us = hc.latency_us;
      s.width = hc.width;
      s.height = hc.height;
      s.exposure_us = hc.exposure_us;
      s.format = hc.format;
    }
    specs.push_back(std::move(s));
  }
  return specs;
}

std::vector<std::unique_ptr<TriggeredCamera>> open_cameras(const std::vector<CameraSpec>& specs) {
  std::vector<std::unique_ptr<TriggeredCamera>> cams;
  for (size_t k = 0; k < specs.size(); ++k) {
    const CameraSpec& s = specs[k];
    try {
      cams.push_back(open_camera(s));
    } catch (const CameraSpecError& e) {
      throw HilConfigError(fmt::format("hil.cameras[{}].format: {}", k, e.what()));
    } catch (const CamerasUnavailable&) {
      throw;
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format("camera {} ({} {}): {}", k, s.backend, s.device, e.what()));
    }
  }
  return cams;
}

Outcome test_alignment(const RunOptions& rig) {
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
  if (!cameras_built_in()) {
    out.verdict = skip(open_camera_reason());
    return out;
  }
  const std::vector<CameraSpec> specs = camera_specs(rig, rig.rate_hz);
  auto in = open_input(rig, &h.edge_input);
  auto cams = open_cameras(specs);
  std::string names;
  for (const CameraSpec& c : specs) names += (names.empty() ? "" : ", ") + c.backend + " " + c.device;
  say(rig, fmt::format("[alignment] {} pulses at {} Hz -> input {}, cameras: {}", rig.pulses, rig.rate_hz,
                       in->describe, names));
  for (size_t k = 0; k < cams.size(); ++k) {
    try {
      cams[k]->start();
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format("camera {} {}: {}", specs[k].backend, specs[k].device, e.what()));
    }
  }

  std::mutex mu;
  std::vector<FrameStamp> frames;
  std::atomic<bool> stop{false};
  std::vector<std::string> errors(cams.size());
  std::vector<std::thread> capture;
  for (size_t k = 0; k < cams.size(); ++k) {
    capture.emplace_back([&, k] {
      while (!stop) {
        FrameStamp f{static_cast<int>(k), 0, 0};
        const int rc = cams[k]->capture(100, &f);
        if (rc == 0) continue;
        if (rc < 0) {
          errors[k] = cams[k]->last_error();
          return;
        }
        std::lock_guard<std::mutex> lock(mu);
        frames.push_back(f);
      }
    });
  }
  // The emulated cameras' trigger wire: each pulse the input sees exposes a frame.
  std::function<void(const vc_pulse&)> wire;
  if (rig.emulated)
    wire = [&](const vc_pulse& p) {
      for (const auto& c : cams) c->soft_trigger(p.seq, static_cast<int64_t>(p.t_ns));
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
  AlignOptions ao;
  ao.rate_hz = rig.rate_hz;
  out.figures = {{"output", run.output}, {"input", in->describe},          {"rate_hz", rig.rate_hz},
                 {"pulses", rig.pulses}, {"pulses_seen", run.seen.size()}, {"cameras", json::array()}};
  std::vector<std::string> wrong;
  uint64_t paired = 0, total = 0;
  for (size_t k = 0; k < cams.size(); ++k) {
    AlignOptions one = ao;
    one.cameras = 1;
    one.latency_us = specs[k].latency_us;
    std::vector<FrameStamp> mine;
    for (const FrameStamp& f : frames)
      if (f.camera == static_cast<int>(k)) mine.push_back({0, f.sequence, f.t_ns});
    const AlignResult a = align_frames(run.seen, mine, one);
    const CameraAlignment& c = a.cameras.at(0);
    const Verdict v = judge_alignment(a, one, rig.config.hil.max_offset_us);
    paired += c.paired;
    total += c.frames;
    const uint64_t dropped = cams[k]->driver_dropped();
    out.figures["cameras"].push_back({{"camera", k},
                                      {"backend", specs[k].backend},
                                      {"device", specs[k].device},
                                      {"latency_us", specs[k].latency_us},
                                      {"frames", c.frames},
                                      {"paired", c.paired},
                                      {"unpaired", c.unpaired},
                                      {"duplicate", c.duplicate},
                                      {"pulses_without_frame", c.pulses_without_frame},
                                      {"driver_dropped", dropped},
                                      {"offset_us", percentiles_json(c.offset_us)},
                                      {"error", errors[k]}});
    say(rig,
        fmt::format("  camera {} ({} {}): frames {}, paired {}, unpaired {}, pulses without frame {}, driver "
                    "dropped {}",
                    k, specs[k].backend, specs[k].device, c.frames, c.paired, c.unpaired,
                    c.pulses_without_frame, dropped));
    say(rig,
        fmt::format("    frame - pulse offset min {} / {} (expected latency {} us)", fmt_us(c.offset_us.min),
                    percentiles_line(c.offset_us), fmt_us(specs[k].latency_us)));
    if (v.status == Status::Fail) {
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
    out.verdict = {Status::Pass, fmt::format("{} of {} frames paired with their pulse on {} camera(s)",
                                             paired, total, cams.size())};
  } else {
    std::string reason;
    for (const std::string& w : wrong) reason += (reason.empty() ? "" : "; ") + w;
    out.verdict = {Status::Fail, reason};
  }
  return out;
}

// ---- 4. full-rig smoke run ----

SmokeFigures smoke_figures(const aggregator::Report& rep, size_t nodes, double seconds) {
  SmokeFigures f;
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

bool interrupted(const RunOptions& rig) {
  return rig.interrupted != nullptr && rig.interrupted->load();
}

void wait_seconds(const RunOptions& rig, double s) {
  const auto end = Clock::now() + std::chrono::duration<double>(s);
  while (!interrupted(rig) && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(20));
}

Outcome test_smoke(const RunOptions& rig) {
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
    wait_seconds(rig, rig.smoke_seconds);
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
    while (!interrupted(rig) && !agg.report().running && Clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (agg.report().running) wait_seconds(rig, rig.smoke_seconds);
    rep = agg.report();
    agg.stop();
  }
  const SmokeFigures f = smoke_figures(rep, nodes, rep.seconds);
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
  out.verdict = judge_smoke(f);
  return out;
}

}  // namespace

bool RunOptions::valid(std::string* why) const {
  const char* bad = nullptr;
  if (pulses < 2 || pulses > 1000000)
    bad = "pulses: must be in [2, 1000000]";
  else if (!(rate_hz > 0 && rate_hz <= 1000))
    bad = "rate: must be in (0, 1000] Hz";
  else if (edge_rates_hz.empty())
    bad = "rates_hz: name at least one rate";
  else if (!std::all_of(edge_rates_hz.begin(), edge_rates_hz.end(),
                        [](double r) { return r > 0 && r <= 1000; }))
    bad = "rates_hz: each must be in (0, 1000] Hz";
  else if (!(smoke_seconds >= 0 && smoke_seconds <= 86400))
    bad = "smoke_seconds: must be in [0, 86400]";
  if (bad && why) *why = bad;
  return bad == nullptr;
}

const std::vector<std::string>& test_names() {
  static const std::vector<std::string> names = {"loopback", "edge-input", "alignment", "smoke"};
  return names;
}

Outcome run_test(const std::string& name, const RunOptions& options) {
  std::string why;
  if (!options.valid(&why)) throw HilConfigError(why);
  Outcome o;
  try {
    if (name == "loopback") return test_loopback(options);
    if (name == "edge-input") return test_edge_input(options);
    if (name == "alignment") return test_alignment(options);
    if (name == "smoke") return test_smoke(options);
  } catch (const HilConfigError&) {
    throw;
  } catch (const std::exception& e) {  // a device missing or busy: this test fails, the others run
    o.name = name;
    o.verdict = {Status::Fail, e.what()};
    return o;
  }
  throw std::invalid_argument(fmt::format("hil: unknown test \"{}\"", name));
}

}  // namespace vc::hil
