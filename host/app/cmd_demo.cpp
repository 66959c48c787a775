// `voxcap demo` and `voxcap eval`: the main job on one machine — the emulated rig end to end (virtual
// rig -> voxcap-edge processes -> host: assembly, merge, triangulation, fitting) with the fitted
// skeleton scored against the virtual rig's true joints (host/emulated's pose scorer). `demo` prints the
// figures and writes DIR/take.bvh, DIR/joints.csv and the session (with virtual_rig.json, what
// `voxcap fit SESSION --score` needs to score it again offline); `eval` prints the same figures (with
// --json as one object). Thin: options -> emulated::Options, run, then the take (host/export).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "export_report.hpp"
#include "pose_figures.hpp"
#include "run_recording.hpp"
#include "vmc_option.hpp"
#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/export/take.hpp"
#include "voxcap/view/viewer.hpp"

namespace vc::cli {
namespace {

namespace fs = std::filesystem;

struct DemoArgs {
  emulated::Options rig;
  uint64_t frames = 600;
  int cameras = 0;  // 0: 2 x nodes
  std::string size = "640x480";
  std::string out;  // demo: where the take and the session go
  bool json = false;
  bool eval = false;
  std::string vmc;         // --vmc HOST:PORT: the live pose stream out
  std::string timing_csv;  // --timing-csv FILE: every fitted frame's path through the host
  bool view = false;       // serve the live viewer while it runs
  int view_port = -1;      // -1: 8080
};

void add_rig_options(CLI::App* cmd, DemoArgs& a) {
  cmd->add_option("--motion", a.rig.motion,
                  "Built-in motion (tpose wave walk squat turn arms-close cross) or a BVH file")
      ->capture_default_str();
  cmd->add_option(
         "--bvh-scale", a.rig.bvh_scale,
         "Metres per unit of a --motion FILE.bvh (0: detected from the joint names and the rest pose)")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  cmd->add_option("--frames", a.frames, "Merged frames to run for (the virtual rig's frames 0 .. N-1)")
      ->capture_default_str();
  cmd->add_option("--nodes", a.rig.nodes, "Edge nodes (voxcap-edge processes), two cameras each")
      ->capture_default_str();
  cmd->add_option("--cameras", a.cameras, "Cameras instead of --nodes (even: two per node)");
  cmd->add_option("--size", a.size, "Camera size WxH")->capture_default_str();
  cmd->add_option("--grid", a.rig.grid, "Voxels per axis over the 2.24 m volume")->capture_default_str();
  cmd->add_option("--noise", a.rig.noise, "Sensor noise sigma (8-bit levels; 0: none)")
      ->capture_default_str();
  cmd->add_option("--rate", a.rig.rate_hz, "Trigger rate, Hz")->capture_default_str();
  cmd->add_option("--seed", a.rig.seed, "Simulator seed")->capture_default_str();
  cmd->add_option("--appearance", a.rig.appearance, "The performer's appearance preset")
      ->capture_default_str();
  cmd->add_option("--room", a.rig.room, "Room preset (default camouflage)")->capture_default_str();
  cmd->add_option("--workdir", a.rig.workdir, "Keep rig.yaml, rig.toml and the edge logs here");
  cmd->add_flag("--view", a.view,
                "Serve the live viewer (host/view) on 127.0.0.1:8080 while it runs (the session recorded in "
                "--out can be replayed from the page)");
  cmd->add_option("--view-port", a.view_port, "The viewer's port (0: a free one; the URL is printed)")
      ->check(CLI::Range(0, 65535));
  cmd->add_flag(
      "--verbose", [&a](int64_t) { a.rig.quiet = false; }, "Info logs from host and edges");
  cmd->add_option("--vmc", a.vmc, kVmcHelp)->type_name("HOST:PORT");
  cmd->add_option(
         "--timing-csv", a.timing_csv,
         "Write every fitted frame's path through the host (ms after its trigger pulse): each node's "
         "HULL received, the frame leaving the assembler, each chain stage's start and end, and its "
         "segments (edges, last_node, assembly, <stage>_queue, <stage>) as in the latency line")
      ->type_name("FILE");
}

// The latency line's and --json latency_split's figures: where the fitted frames' trigger -> pose time
// went, per segment, over all frames and over the slowest 1% (pipeline/timing.hpp).
nlohmann::json latency_split_json(const pipeline::LatencySplit& s) {
  nlohmann::json mean = nlohmann::json::object(), tail = nlohmann::json::object();
  for (size_t i = 0; i < s.segments.size(); i++) {
    mean[s.segments[i]] = s.mean_ms[i];
    tail[s.segments[i]] = s.tail_mean_ms[i];
  }
  return {{"frames", s.frames},
          {"mean_ms", mean},
          {"tail_from_ms", s.tail_from_ms},
          {"tail_frames", s.tail_frames},
          {"tail_degraded", s.tail_degraded},
          {"tail_mean_ms", tail}};
}

std::string latency_split_line(const pipeline::LatencySplit& s) {
  std::string segs;
  for (size_t i = 0; i < s.segments.size(); i++)
    segs += fmt::format("{}{} {:.1f}/{:.1f}", i ? ", " : "", s.segments[i], s.mean_ms[i], s.tail_mean_ms[i]);
  return fmt::format(
      "latency     where trigger -> pose goes, mean over {} frames / over the slowest {} (from {:.1f} ms, {} "
      "degraded), ms: {}",
      s.frames, s.tail_frames, s.tail_from_ms, s.tail_degraded, segs);
}

void write_timing_csv(const fs::path& path, const emulated::PoseAccuracy& p,
                      const std::vector<uint16_t>& nodes, const std::vector<std::string>& segments,
                      uint64_t origin) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw std::runtime_error(fmt::format("--timing-csv {}: cannot write", path.string()));
  std::string head = "seq,frame,degraded,missing";
  for (uint16_t n : nodes) head += fmt::format(",hull_node{}_ms", n);
  head += ",assembled_ms";
  const size_t stages = segments.size() > 3 ? (segments.size() - 3) / 2 : 0;
  for (size_t i = 0; i < stages; i++)
    head += fmt::format(",{0}_start_ms,{0}_end_ms", segments[3 + 2 * i + 1]);
  for (const std::string& s : segments) head += "," + s + "_ms";
  head += ",total_ms\n";
  std::fputs(head.c_str(), f);
  for (const pipeline::FrameTiming& t : p.timing) {
    std::string missing;
    for (uint16_t n : t.missing) missing += fmt::format("{}{}", missing.empty() ? "" : " ", n);
    std::string row =
        fmt::format("{},{},{},{}", t.seq, static_cast<int64_t>(t.seq - origin), t.degraded ? 1 : 0, missing);
    for (uint16_t n : nodes) {
      auto it = std::find_if(t.hull_ms.begin(), t.hull_ms.end(), [n](const auto& h) { return h.first == n; });
      row += it == t.hull_ms.end() ? "," : fmt::format(",{:.3f}", it->second);
    }
    row += fmt::format(",{:.3f}", t.assembled_ms);
    for (size_t i = 0; i < stages; i++)
      row += i < t.stage_ms.size() ? fmt::format(",{:.3f},{:.3f}", t.stage_ms[i].first, t.stage_ms[i].second)
                                   : ",,";
    for (size_t i = 0; i < segments.size(); i++)
      row += i < t.segments_ms.size() ? fmt::format(",{:.3f}", t.segments_ms[i]) : ",";
    row += fmt::format(",{:.3f}\n", t.total_ms);
    std::fputs(row.c_str(), f);
  }
  if (std::fclose(f) != 0)
    throw std::runtime_error(fmt::format("--timing-csv {}: write failed", path.string()));
}

nlohmann::json figures_json(const DemoArgs& a, const emulated::Result& r) {
  nlohmann::json j = pose_figures_json(r.poses);
  nlohmann::json drops = nlohmann::json::object();
  for (const auto& s : r.stages.stages) drops[s.name] = s.queue.dropped;
  j["pipeline_drops"] = drops;
  // Where the latency goes: trigger -> merged (assembly), then each stage's time in process() and the
  // most frames its queue held (a stage behind the rig shows here first).
  const aggregator::Latency& m = r.report.merged;
  j["merged_latency_ms"] = {
      {"p50", m.percentile_ms(0.5)}, {"p99", m.percentile_ms(0.99)}, {"max", m.max_ms()}};
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& s : r.stages.stages)
    stages[s.name] = {
        {"busy_ms_mean", s.busy_ms_mean}, {"busy_ms_max", s.busy_ms_max}, {"queue_max", s.queue.max_depth}};
  j["stages"] = stages;
  j["latency_split"] = latency_split_json(r.poses.latency_split);
  j["rig"] = {{"motion", a.rig.motion},     {"nodes", a.rig.nodes},
              {"cameras", 2 * a.rig.nodes}, {"size", a.size},
              {"grid", a.rig.grid},         {"noise", a.rig.noise},
              {"rate_hz", a.rig.rate_hz},   {"appearance", a.rig.appearance},
              {"room", a.rig.room}};
  j["wall_seconds"] = r.wall_seconds;
  return j;
}

void run_demo(DemoArgs& a) {
  if (a.cameras != 0) {
    if (a.cameras < 2 || a.cameras % 2 != 0)
      throw UsageError(fmt::format("--cameras: an even number (two per node), got {}", a.cameras));
    a.rig.nodes = a.cameras / 2;
  }
  if (std::sscanf(a.size.c_str(), "%dx%d", &a.rig.width, &a.rig.height) != 2)
    throw UsageError("--size: expected WxH, got '" + a.size + "'");
  if (a.frames < 2 || a.frames > 10'000'000) throw UsageError("--frames: 2 .. 10000000");
  if (!a.vmc.empty()) {
    const config::VmcOptions vo = vmc_options({}, a.vmc);
    a.rig.stages = [prev = a.rig.stages, vo](pipeline::Pipeline& p) {
      if (prev) prev(p);
      add_vmc_stage(p, vo);
    };
  }
  a.rig.truth_every = 0;  // the hull scorer (voxcap rig --emulated) is not needed here: its renders cost
  a.rig.score_poses = true;
  a.rig.keep_poses = !a.eval || !a.timing_csv.empty();
  if (!a.eval) {
    if (a.out.empty()) a.out = "voxcap-demo";
    std::error_code ec;
    fs::create_directories(a.out, ec);
    if (ec) throw UsageError(fmt::format("--out {}: {}", a.out, ec.message()));
    a.rig.record_dir = fs::path(a.out);
  }
  std::unique_ptr<view::Viewer> viewer;
  if (a.view) {
    view::ViewerOptions vo;
    if (a.view_port >= 0) vo.server.port = static_cast<uint16_t>(a.view_port);
    vo.record_dir = a.out.empty() ? fs::path("recordings") : fs::path(a.out);
    vo.record_switch = false;  // the demo records its session itself
    viewer = std::make_unique<view::Viewer>(vo);
    a.rig.stages = [v = viewer.get(), prev = a.rig.stages](pipeline::Pipeline& p) {
      if (prev) prev(p);
      v->attach(p);
    };
  }
  std::string why;
  if (!a.rig.valid(&why)) throw UsageError(why);
  emulated::EmulatedRig rig(a.rig);
  if (viewer) {
    viewer->set_report([&rig] { return rig.report(); });
    viewer->start();
    fmt::print("viewer: {}\n", viewer->url());
    std::fflush(stdout);
  }
  if (!a.json)
    fmt::print("starting {} edge nodes ({} cameras, {}, {}^3 voxels), motion '{}', {} frames at {} Hz...\n",
               a.rig.nodes, 2 * a.rig.nodes, a.size, a.rig.grid, a.rig.motion, a.frames, a.rig.rate_hz);
  rig.start();
  rig.run_frames(a.frames, double(a.frames) / a.rig.rate_hz * 20 + 30);  // generous on a loaded machine
  emulated::Result r = rig.stop();
  if (viewer) viewer->stop();
  if (r.report.frames == 0) throw std::runtime_error("no frame was merged");
  // demo: the session as it is on disk (read back once closed) against the frames merged up to the
  // host's stop (every stage drained, the recording closed): the summary counts what it holds.
  std::optional<record::RunRecording> rec;
  if (!r.session_dir.empty()) rec = record::read_back(r.session_dir, r.final_report.frames);
  if (a.json) {
    nlohmann::json j = figures_json(a, r);
    if (rec) j["session"] = run_recording_json(*rec);
    fmt::print("{}\n", j.dump(2));
  } else {
    print_pose_figures(r.poses, a.rig.rate_hz);
    const aggregator::Latency& m = r.report.merged;
    std::string stages;
    for (const auto& s : r.stages.stages)
      stages +=
          fmt::format(" {} {:.2f}/{:.1f} ms q{}", s.name, s.busy_ms_mean, s.busy_ms_max, s.queue.max_depth);
    fmt::print(
        "stages      trigger -> merged p50 {:.1f} ms, p99 {:.1f} ms;{} (mean/max in process(), most "
        "queued)\n",
        m.percentile_ms(0.5), m.percentile_ms(0.99), stages);
    fmt::print("{}\n", latency_split_line(r.poses.latency_split));
    if (rec) fmt::print("{}\n", record::run_recording_line(*rec));
  }
  if (!a.timing_csv.empty()) {
    std::vector<uint16_t> nodes;
    for (const auto& n : r.report.nodes) nodes.push_back(n.id);
    write_timing_csv(a.timing_csv, r.poses, nodes, r.poses.latency_split.segments, r.origin);
  }
  if (a.eval) return;
  if (!r.session_dir.empty()) {  // what voxcap fit SESSION --score needs to score it again offline
    VirtualRig v;
    v.rig = a.rig;
    v.origin = r.origin;
    v.frames = a.frames;
    v.live = figures_json(a, r);
    write_virtual_rig(r.session_dir, v);
  }
  if (r.poses.fitted_frames == 0)
    throw std::runtime_error("no frame got a pose (is [fitting] enabled?): no take written");
  const take::Take t = take::make_take(r.poses.poses);
  report_take(t, "demo");
  take::WriteOptions wo;
  wo.frame_time_s = 1.0 / a.rig.rate_hz;
  const fs::path out(a.out);
  take::write_bvh(out / "take.bvh", t, wo);
  const uint64_t rows = take::write_joints_csv(out / "joints.csv", t);
  if (!a.json)
    fmt::print("wrote       {} ({} frames from frame {}), {} ({} rows), session {}\n",
               (out / "take.bvh").string(), t.poses.size(), t.first_frame, (out / "joints.csv").string(),
               rows, r.session_dir.string());
}

}  // namespace

void add_demo_commands(CLI::App& app) {
  auto demo = std::make_shared<DemoArgs>();
  demo->rig.grid = 128;
  CLI::App* d =
      app.add_subcommand("demo",
                         "The main job on this machine: the emulated rig end to end (virtual rig -> "
                         "voxcap-edge processes -> host: "
                         "hulls, tracking, triangulation, skeleton fitting); prints fps, trigger-to-pose "
                         "latency and the accuracy "
                         "against the virtual rig's truth, writes DIR/take.bvh, DIR/joints.csv (frame "
                         "numbers = the virtual rig's, "
                         "as in voxcap sim's truth/joints.csv) and the session (DIR/emulated-<time>, with "
                         "virtual_rig.json: voxcap fit SESSION --score re-fits and scores it offline)");
  add_rig_options(d, *demo);
  d->add_option("--out", demo->out, "Output folder (default ./voxcap-demo)");
  d->add_flag(
      "--json", demo->json,
      "Print the figures as JSON (the keys of voxcap eval --json: mpjpe_mm ... latency_ms, "
      "pipeline_drops, merged_latency_ms, stages, latency_split {frames, mean_ms, tail_from_ms, tail_frames, "
      "tail_degraded, tail_mean_ms}: where trigger -> pose goes per segment, rig, wall_seconds; and session "
      "{dir, frames, "
      "merged_frames, frames_not_recorded, records, skipped_records, skipped_bytes, truncated_bytes, "
      "closed_cleanly, stop, damage[]}: the recorded session read back once closed)");
  d->callback([demo] { run_demo(*demo); });

  auto eval = std::make_shared<DemoArgs>();
  eval->rig.grid = 128;
  eval->eval = true;
  CLI::App* e = app.add_subcommand(
      "eval",
      "The fitted skeleton's accuracy on the emulated rig against the virtual rig's truth. Figures (--json "
      "keys): "
      "mpjpe_mm (mean over the scored frames of the mean distance of the 15 fitted joints to the virtual "
      "rig's "
      "standard joints of the same names: hips, neck, head (centre), shoulders, elbows, wrists, hip joints, "
      "knees, ankles), per_joint_mm, pa_mpjpe_mm (after the per-frame Procrustes similarity alignment), "
      "max_joint_mm, frames (merged frames from the first pose on), fitted_frames (of those with a pose), "
      "init_frames (before the first pose), merged_frames, scored_frames, frames_outside_volume (a true "
      "joint "
      "outside the grid's box: counted, left out of the errors), arm_in_torso_frames (a fitted elbow or "
      "wrist "
      "inside the true torso volume), predicted_frames, reinitialized_frames, fps (poses per second), "
      "latency_ms {p50, p99, max} (trigger -> pose), pipeline_drops {stage: frames}, merged_latency_ms "
      "{p50, p99, max} (trigger -> merged), stages {stage: {busy_ms_mean, busy_ms_max, queue_max}} (time in "
      "process(), most queued), latency_split {frames, mean_ms, tail_from_ms, tail_frames, tail_degraded, "
      "tail_mean_ms} (trigger -> pose per segment: edges, last_node, assembly, <stage>_queue, <stage>; over "
      "all "
      "fitted frames and over the slowest 1%), rig {...}, wall_seconds");
  add_rig_options(e, *eval);
  e->add_flag("--json", eval->json, "Print the figures as one JSON object");
  e->callback([eval] { run_demo(*eval); });
}

}  // namespace vc::cli
