// `voxcap rig`: run a rig. `--emulated` runs the whole rig on this machine (the host in this process,
// one voxcap-edge process per node with sim cameras and the udp trigger, on loopback) and prints
// per-node and overall figures; without it, the host aggregator runs the rig described by rig.toml
// until Ctrl-C or --seconds.
#include <cmath>
#include <csignal>
#include <optional>
#include <thread>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "run_recording.hpp"
#include "vmc_option.hpp"
#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/aggregator/record_stage.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/view/viewer.hpp"

namespace vc::cli {
namespace {

std::atomic<bool> g_interrupted{false};
void on_sigint(int) {
  g_interrupted = true;
}

nlohmann::json report_json(const aggregator::Report& r) {
  nlohmann::json j;
  j["pulses"] = r.pulses;
  j["frames"] = r.frames;
  j["complete"] = r.complete;
  j["degraded"] = r.degraded;
  j["dropped"] = r.dropped;
  j["evicted"] = r.evicted;
  j["first_seq"] = r.first_seq;
  j["last_seq"] = r.last_seq;
  j["fps"] = r.fps;
  j["last_pulse"] = r.last_pulse;
  j["unmerged_pulses"] = r.unmerged_pulses();
  j["merging_stopped"] = r.merging_stopped();
  j["trigger_to_merged_ms"] = {{"mean", r.merged.mean_ms()},
                               {"p50", r.merged.percentile_ms(0.5)},
                               {"p99", r.merged.percentile_ms(0.99)}};
  for (const auto& n : r.nodes) {
    nlohmann::json s;
    for (const auto& [k, v] : n.edge_stage_ms) s[k] = v;
    j["nodes"].push_back(
        {{"id", n.id},
         {"name", n.name},
         {"connected", n.connected},
         {"state", vc_node_state_name(n.state) ? vc_node_state_name(n.state) : "?"},
         {"joins", n.joins},
         {"hellos_refused", n.hellos_refused},
         {"leaves", n.leaves},
         {"hulls", n.hulls},
         {"late", n.late},
         {"missing", n.missing},
         {"rejected", n.rejected},
         {"errors", n.errors},
         {"last_error", n.last_error},
         {"edge_queue_drops", n.edge_queue_drops},
         {"edge_frames_without_pulse", n.edge_frames_without_pulse},
         {"edge_pulses_without_frame", n.edge_pulses_without_frame},
         {"host_queue_drops", n.host_queue_drops},
         {"features", n.features},
         {"features_late", n.features_late},
         {"refused", n.refused},
         {"unpulsed", n.unpulsed},
         {"mac_rejected",
          {{"forged", n.mac_rejected.forged},
           {"replayed", n.mac_rejected.replayed},
           {"reordered", n.mac_rejected.reordered}}},
         {"edge_stage_ms", s},
         {"trigger_to_received_ms",
          {{"mean", n.rx.mean_ms()}, {"p50", n.rx.percentile_ms(0.5)}, {"p99", n.rx.percentile_ms(0.99)}}}});
  }
  const session::ServerStats& sv = r.server;
  j["server"] = {{"accepted", sv.accepted},
                 {"closed", sv.closed},
                 {"hello_rejected", sv.hello_rejected},
                 {"decode_drops", sv.decode_drops},
                 {"timeouts", sv.timeouts},
                 {"overflow_drops", sv.overflow_drops},
                 {"prehello_evicted", sv.prehello_evicted},
                 {"prehello_timeouts", sv.prehello_timeouts},
                 {"auth_refused", sv.auth_refused},
                 {"mac_rejected",
                  {{"forged", sv.mac_forged},
                   {"replayed", sv.mac_replayed},
                   {"reordered", sv.mac_reordered},
                   {"unidentified", sv.mac_unidentified}}}};
  for (const auto& s : r.pipeline.stages)
    j["stages"].push_back({{"name", s.name},
                           {"overflow", pipeline::overflow_name(s.overflow)},
                           {"processed", s.processed},
                           {"dropped", s.queue.dropped},
                           {"errors", s.errors},
                           {"queue_max", s.queue.max_depth},
                           {"queue_capacity", s.queue.capacity},
                           {"busy_ms", {{"mean", s.busy_ms_mean}, {"max", s.busy_ms_max}}}});
  return j;
}

void print_report(const aggregator::Report& r) {
  fmt::print("nodes:\n");
  for (const auto& n : r.nodes) {
    auto st = [&](const char* k) {
      auto it = n.edge_stage_ms.find(k);
      return it == n.edge_stage_ms.end() ? 0.0 : it->second;
    };
    fmt::print(
        "  {:<8} hulls {:>6}  late {:>4}  missing {:>4}  edge: capture {:.2f} ms  subtract {:.2f} ms  "
        "carve {:.2f} ms  trigger->hull {:.2f} ms  trigger->host p50 {:.2f} ms p99 {:.2f} ms  drops {}  "
        "joins {}{}\n",
        n.name, n.hulls, n.late, n.missing, st("capture"), st("subtract"), st("carve"), n.edge_frame_ms,
        n.rx.percentile_ms(0.5), n.rx.percentile_ms(0.99), n.edge_queue_drops + n.edge_pulses_without_frame,
        n.joins, n.last_error.empty() ? "" : "  last error: " + n.last_error);
    std::string refused;
    for (const auto& [reason, count] : n.refused) refused += fmt::format("  {} {}", reason, count);
    if (n.unpulsed) refused += fmt::format("  unpulsed (assembler) {}", n.unpulsed);
    if (!refused.empty()) fmt::print("  {:<8} refused:{}\n", n.name, refused);
    if (n.mac_rejected.total())
      fmt::print("  {:<8} MAC rejected: forged {}  replayed {}  reordered {}\n", n.name,
                 n.mac_rejected.forged, n.mac_rejected.replayed, n.mac_rejected.reordered);
  }
  const session::ServerStats& sv = r.server;
  if (sv.auth_refused || sv.mac_rejected || sv.hello_rejected || sv.decode_drops || sv.prehello_evicted ||
      sv.prehello_timeouts)
    fmt::print(
        "connections: {} accepted; refused: {} HELLOs ({} without the key), {} undecodable, {} evicted and "
        "{} "
        "timed out before HELLO; MAC rejected: forged {}  replayed {}  reordered {} ({} on no node's "
        "connection)\n",
        sv.accepted, sv.hello_rejected, sv.auth_refused, sv.decode_drops, sv.prehello_evicted,
        sv.prehello_timeouts, sv.mac_forged, sv.mac_replayed, sv.mac_reordered, sv.mac_unidentified);
  fmt::print("frames: {} merged ({} complete, {} degraded, {} dropped) of {} pulses, seq {}..{}\n", r.frames,
             r.complete, r.degraded, r.dropped, r.pulses, r.first_seq, r.last_seq);
  if (r.merging_stopped())
    fmt::print("merging STOPPED: {} pulses after seq {} never merged (the last pulse was seq {})\n",
               r.unmerged_pulses(), r.frames ? r.last_seq : r.origin, r.last_pulse);
  fmt::print("fps: {:.1f}   trigger->merged hull: mean {:.2f} ms  p50 {:.2f} ms  p99 {:.2f} ms\n", r.fps,
             r.merged.mean_ms(), r.merged.percentile_ms(0.5), r.merged.percentile_ms(0.99));
  fmt::print("stages:");
  for (const auto& s : r.pipeline.stages)
    fmt::print("  {} {:.3f} ms (max {:.1f}), queue max {}/{}, dropped {}{}", s.name, s.busy_ms_mean,
               s.busy_ms_max, s.queue.max_depth, s.queue.capacity, s.queue.dropped,
               s.errors ? fmt::format(", {} errors", s.errors) : "");
  fmt::print("\n");
}

nlohmann::json silhouette_json(const emulated::SilhouetteScore& s) {
  return {{"frames", s.frames},
          {"missing", s.missing},
          {"bad", s.bad},
          {"recall", s.recall},
          {"precision", s.precision},
          {"shadow_kept", s.shadow_kept},
          {"shadow_frames", s.shadow_frames}};
}

// A figure that may be missing (no samples: NaN) as JSON: null then.
nlohmann::json number(double x) {
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

// accuracy.features.<name>: the feature scorer's figures (emulated::FeatureScore).
nlohmann::json features_json(const emulated::FeatureAccuracy& a) {
  nlohmann::json j = nlohmann::json::object();
  for (size_t i = 0; i < a.features.size(); i++) {
    const emulated::FeatureScore& s = a.features[i];
    j[emulated::kTrackedFeatureNames[i]] = {{"err3d_p50_mm", number(s.err3d_p50_mm)},
                                            {"err3d_p95_mm", number(s.err3d_p95_mm)},
                                            {"frames_visible", s.frames_visible},
                                            {"frames_triangulated", s.frames_triangulated},
                                            {"frames_lost", s.frames_lost},
                                            {"frames_to_acquire", s.frames_to_acquire},
                                            {"losses", s.losses},
                                            {"recover_max_frames", s.recover_max_frames},
                                            {"recover_p95_frames", s.recover_p95_frames},
                                            {"confident_wrong", s.confident_wrong},
                                            {"views_visible", s.views_visible},
                                            {"views_untracked", s.views_untracked},
                                            {"err2d_p50_px", number(s.err2d_p50_px)},
                                            {"err2d_p95_px", number(s.err2d_p95_px)}};
  }
  return j;
}

// The scorer's figures (emulated::Accuracy) under the keys --help names.
nlohmann::json accuracy_json(const emulated::Accuracy& a) {
  nlohmann::json parts = nlohmann::json::object();
  for (size_t p = 0; p < emulated::kPartGroups; p++)
    parts[std::string(emulated::part_group_names()[p])] = a.part_recall[p];
  nlohmann::json cams = nlohmann::json::array();
  for (size_t c = 0; c < a.cameras.size(); c++) {
    nlohmann::json j = silhouette_json(a.cameras[c]);
    j["camera"] = c;
    j["node"] = c / 2;
    cams.push_back(j);
  }
  nlohmann::json sil = silhouette_json(a.silhouettes);
  sil["source"] = "edge masks (SILHOUETTE messages)";
  sil["cameras"] = cams;
  return {{"frames", a.frames},
          {"agree", a.agree},
          {"min_agree", a.min_agree},
          {"iou_silhouette_hull", a.iou_silhouette_hull},
          {"body_recall", a.body_recall},
          {"hull_precision", a.hull_precision},
          {"reference_carve", a.reference_carve},
          {"parts", parts},
          {"silhouettes", sil},
          {"feature_frames", a.features.frames},
          {"feature_confident", a.features.confident},
          {"features", features_json(a.features)}};
}

void print_features(const emulated::FeatureAccuracy& a) {
  fmt::print(
      "tracked features ({} frames scored, every frame): 3D vs the true head centre, wrists, ankles over "
      "the frames two or more cameras see the part; 2D: the edges' FEATURES while visible\n",
      a.frames);
  fmt::print("  {:<11}{:>8}{:>17}{:>7}{:>8}{:>8}{:>9}{:>11}{:>14}{:>15}\n", "feature", "visible",
             "3d p50/p95", "lost", "losses", "rec max", "rec p95", "conf wrong", "2d p50/p95",
             "2d untracked");
  auto pair = [](double p50, double p95, const char* unit) {
    return std::isfinite(p50) ? fmt::format("{:.1f}/{:.1f}{}", p50, p95, unit) : std::string("-");
  };
  for (size_t i = 0; i < a.features.size(); i++) {
    const emulated::FeatureScore& s = a.features[i];
    fmt::print("  {:<11}{:>8}{:>17}{:>7}{:>8}{:>8}{:>9.1f}{:>11}{:>14}{:>15}\n",
               emulated::kTrackedFeatureNames[i], s.frames_visible,
               pair(s.err3d_p50_mm, s.err3d_p95_mm, "mm"), s.frames_lost, s.losses, s.recover_max_frames,
               s.recover_p95_frames, s.confident_wrong, pair(s.err2d_p50_px, s.err2d_p95_px, "px"),
               fmt::format("{}/{}", s.views_untracked, s.views_visible));
  }
  fmt::print(
      "  (lost: seen by two cameras but not triangulated, after the first triangulation; rec: frames a loss "
      "lasted; conf wrong: confidence > {:.2f} and > 10 cm from the truth)\n",
      a.confident);
}

void print_accuracy(const emulated::Accuracy& a) {
  fmt::print(
      "accuracy ({} frames scored): merged hull vs hull of the true silhouettes ({} carve): {:.3f} % of "
      "voxels "
      "agree (min {:.3f} %), IoU {:.3f}; true body voxels inside the hull: {:.2f} %; hull voxels within one "
      "voxel of the body: {:.2f} %\n",
      a.frames, a.reference_carve, 100 * a.agree, 100 * a.min_agree, a.iou_silhouette_hull,
      100 * a.body_recall, 100 * a.hull_precision);
  fmt::print("body recall per part (% of its true voxels inside the merged hull):\n");
  for (size_t p = 0; p < emulated::kPartGroups; p++)
    fmt::print("  {:<12}{:>7.2f} %{}", emulated::part_group_names()[p], 100 * a.part_recall[p],
               p % 4 == 3 || p + 1 == emulated::kPartGroups ? "\n" : "   ");
  fmt::print("silhouettes, from the edges' real masks (SILHOUETTE) vs the true silhouettes:\n");
  fmt::print("  {:<8}{:>7}{:>9}{:>5}{:>10}{:>11}{:>13}\n", "camera", "frames", "missing", "bad", "recall",
             "precision", "shadow kept");
  auto row = [](const std::string& name, const emulated::SilhouetteScore& s) {
    if (s.frames == 0) {
      fmt::print("  {:<8}{:>7}{:>9}{:>5}{:>10}{:>11}{:>13}\n", name, 0, s.missing, s.bad, "-", "-", "-");
      return;
    }
    fmt::print("  {:<8}{:>7}{:>9}{:>5}{:>9.2f}%{:>10.2f}%{:>12}\n", name, s.frames, s.missing, s.bad,
               100 * s.recall, 100 * s.precision,
               s.shadow_frames ? fmt::format("{:.2f}%", 100 * s.shadow_kept) : std::string("-"));
  };
  for (size_t c = 0; c < a.cameras.size(); c++) row(fmt::format("cam{}", c), a.cameras[c]);
  row("all", a.silhouettes);
  if (a.silhouettes.frames == 0 && a.frames > 0)
    fmt::print("  (no edge sent its masks: the figures above need edges that send SILHOUETTE)\n");
  if (a.features.frames > 0) print_features(a.features);
}

}  // namespace

void add_rig_commands(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "rig",
      "Run a rig: the host aggregator (and with --emulated, the edges too); exit 1 when its frames "
      "stopped merging (more than a second of pulses after the last merged frame)");
  auto opt = std::make_shared<emulated::Options>();
  auto emulated = std::make_shared<bool>(false);
  auto frames = std::make_shared<uint64_t>(600);
  auto seconds = std::make_shared<double>(0);
  auto json = std::make_shared<bool>(false);
  auto config = std::make_shared<std::string>();
  auto size = std::make_shared<std::string>("640x480");
  cmd->add_flag(
      "--emulated", *emulated,
      "Run the whole rig on this machine: voxcap-edge processes with sim cameras, udp trigger, loopback");
  cmd->add_option("--config", *config,
                  "rig.toml of a real rig (without --emulated; default $VOXCAP_RIG or ./rig.toml)");
  cmd->add_option("--nodes", opt->nodes, "emulated: edge nodes, two cameras each")->capture_default_str();
  cmd->add_option("--motion", opt->motion,
                  "emulated: built-in motion (tpose wave walk squat turn arms-close cross) or a BVH file")
      ->capture_default_str();
  cmd->add_option("--bvh-scale", opt->bvh_scale,
                  "emulated: metres per unit of a BVH motion (0: detected: m, cm, mm, inches, CMU, else the "
                  "body height)")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  cmd->add_option("--frames", *frames, "emulated: merged frames to run for")->capture_default_str();
  cmd->add_option("--seconds", *seconds, "run this long instead (0: --frames; a real rig: until Ctrl-C)");
  cmd->add_option("--size", *size, "emulated: camera size WxH")->capture_default_str();
  cmd->add_option("--rate", opt->rate_hz, "emulated: trigger rate, Hz")->capture_default_str();
  cmd->add_option("--grid", opt->grid, "emulated: voxels per axis over the 2.24 m volume")
      ->capture_default_str();
  cmd->add_option("--noise", opt->noise, "emulated: sensor noise sigma (8-bit levels)")
      ->capture_default_str();
  cmd->add_option("--seed", opt->seed, "emulated: simulator seed")->capture_default_str();
  cmd->add_option("--appearance", opt->appearance,
                  "emulated: the performer's appearance preset (default pale olive brown dark beige)")
      ->capture_default_str();
  cmd->add_option("--room", opt->room, "emulated: room preset (default camouflage)")->capture_default_str();
  cmd->add_option(
         "--carve", opt->carve,
         "emulated: the edges' carve rule, subpixel | footprint | centre (proto/SPEC.md \"Carve rules\")")
      ->capture_default_str();
  cmd->add_option("--policy", opt->missing_policy, "emulated: missing-node policy, drop | degraded")
      ->capture_default_str();
  cmd->add_option("--truth-every", opt->truth_every,
                  "emulated: score the frames whose seq is a multiple of k against ground truth, the edges "
                  "sending their masks for them (0: off)")
      ->capture_default_str();
  cmd->add_option("--workdir", opt->workdir, "emulated: keep rig.yaml, rig.toml and edge logs here");
  auto record = std::make_shared<std::string>();
  cmd->add_option("--record", *record,
                  "record the session (merged hulls, features, stats, rig.toml, calibration) in a new folder "
                  "below this one; a real rig records to rig.toml's recording.dir unless this is given");
  auto vmc = std::make_shared<std::string>();
  cmd->add_option("--vmc", *vmc, kVmcHelp)->type_name("HOST:PORT");
  cmd->add_flag(
      "--verbose", [opt](int64_t) { opt->quiet = false; }, "emulated: info logs from host and edges");
  cmd->add_flag(
      "--keyless", [opt](int64_t) { opt->keyed = false; },
      "emulated: run without a rig key (control not authenticated; loopback only). By default the emulated "
      "rig makes a fresh key (rig.key, mode 0600) in its workdir and host and edges prove it");
  cmd->add_flag(
      "--json", *json,
      "print the figures as JSON: emulated {nodes, motion, appearance, room, carve, grid, size, rate_hz, "
      "truth_every}, frames, complete, degraded, dropped, pulses, fps, last_pulse, unmerged_pulses, "
      "merging_stopped, trigger_to_merged_ms {mean,p50,p99}, nodes[] {id, name, hulls, late, missing, "
      "host_queue_drops, refused {not_running, unpulsed}, unpulsed, hellos_refused, mac_rejected {forged, "
      "replayed, reordered}, edge_stage_ms, trigger_to_received_ms, ...}, server {accepted, closed, "
      "hello_rejected, decode_drops, timeouts, overflow_drops, prehello_evicted, prehello_timeouts, "
      "auth_refused, mac_rejected {forged, replayed, reordered, unidentified}}, session {dir, frames, "
      "merged_frames, frames_not_recorded, records, skipped_records, skipped_bytes, truncated_bytes, "
      "closed_cleanly, stop, damage[]} (with --record, or a real rig: the recorded session read back), "
      "stages[] {name, overflow, processed, dropped, errors, queue_max, queue_capacity, busy_ms {mean,max}}, "
      "accuracy {frames, agree, min_agree, iou_silhouette_hull, body_recall, hull_precision, "
      "reference_carve, "
      "parts {head, torso, l_upper_arm, r_upper_arm, l_forearm, r_forearm, l_hand, r_hand, l_thigh, r_thigh, "
      "l_shank, r_shank, l_foot, r_foot}, silhouettes {source, frames, missing, bad, recall, precision, "
      "shadow_kept, shadow_frames, cameras[] {camera, node, frames, missing, bad, recall, precision, "
      "shadow_kept, shadow_frames}}, feature_frames, feature_confident, features {head, left_hand, "
      "right_hand, left_foot, right_foot: {err3d_p50_mm, err3d_p95_mm, frames_visible, frames_triangulated, "
      "frames_lost, frames_to_acquire, losses, recover_max_frames, recover_p95_frames, confident_wrong, "
      "views_visible, views_untracked, err2d_p50_px, err2d_p95_px}}} (emulated; silhouettes from the edges' "
      "real masks; features scored on every frame, null where nothing was measured)");
  auto view = std::make_shared<bool>(false);
  auto no_view = std::make_shared<bool>(false);
  auto view_port = std::make_shared<int>(-1);
  auto view_bind = std::make_shared<std::string>();
  cmd->add_flag(
      "--view", *view,
      "emulated: serve the live viewer (host/view: the page, /ws, /pose.json) on 127.0.0.1:8080 (or "
      "--view-bind/--view-port); sessions recorded from the page go below --record (default ./recordings)");
  cmd->add_flag("--no-view", *no_view,
                "a real rig: do not serve the viewer (rig.toml [viewer] enabled = false)");
  cmd->add_option("--view-port", *view_port,
                  "the viewer's port, over rig.toml [viewer] port (0: a free one; the URL is printed)")
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--view-bind", *view_bind, "the viewer's IPv4 address, over rig.toml [viewer] bind");
  cmd->callback([=] {
    std::signal(SIGINT, on_sigint);
    std::signal(SIGTERM, on_sigint);
    if (*emulated) {
      if (std::sscanf(size->c_str(), "%dx%d", &opt->width, &opt->height) != 2)
        throw UsageError("--size: expected WxH, got '" + *size + "'");
      opt->record_dir = *record;
      if (!vmc->empty()) {  // the emulated rig's own rig.toml has no [vmc]: --vmc alone turns it on
        const config::VmcOptions vo = vmc_options({}, *vmc);
        opt->stages = [prev = opt->stages, vo](pipeline::Pipeline& p) {
          if (prev) prev(p);
          add_vmc_stage(p, vo);
        };
      }
      std::unique_ptr<view::Viewer> viewer;
      if (*view) {
        view::ViewerOptions vo;
        if (*view_port >= 0) vo.server.port = static_cast<uint16_t>(*view_port);
        if (!view_bind->empty()) vo.server.bind = *view_bind;
        config::ViewerOptions check = vo.server;
        check.port = 1;  // --view-port 0 (a free port) is fine here
        std::string why;
        if (!check.valid(&why)) throw UsageError("--view-bind: " + why);
        vo.record_dir =
            record->empty() ? std::filesystem::path("recordings") : std::filesystem::path(*record);
        vo.record_at_start = !record->empty();  // the viewer's record switch records instead
        opt->record_dir.clear();
        viewer = std::make_unique<view::Viewer>(vo);
        opt->stages = [v = viewer.get(), prev = opt->stages](pipeline::Pipeline& p) {
          if (prev) prev(p);
          v->attach(p);
        };
      }
      std::string why;
      if (!opt->valid(&why)) throw UsageError(why);
      emulated::EmulatedRig rig(*opt);
      if (viewer) {
        viewer->set_report([&rig] { return rig.report(); });
        viewer->start();
        fmt::print("viewer: {}\n", viewer->url());
        std::fflush(stdout);
      }
      if (!*json)
        fmt::print("starting {} edge nodes ({} cameras, {}), motion '{}', appearance '{}', room '{}'...\n",
                   opt->nodes, 2 * opt->nodes, *size, opt->motion, opt->appearance, opt->room);
      rig.start();
      if (*seconds > 0) {
        auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(*seconds);
        while (!g_interrupted && std::chrono::steady_clock::now() < end)
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
      } else {
        // Generous: a loaded machine runs below the trigger rate. A run whose frames stopped merging
        // for 10 s after its first one ends early (and says so below).
        double timeout = double(*frames) / opt->rate_hz * 20 + 30;
        auto now = std::chrono::steady_clock::now();
        auto end = now + std::chrono::duration<double>(timeout);
        uint64_t seen = 0;
        auto last_progress = now;
        while (!g_interrupted && rig.merged_frames() < *frames &&
               (now = std::chrono::steady_clock::now()) < end) {
          if (rig.merged_frames() != seen) {
            seen = rig.merged_frames();
            last_progress = now;
          } else if (seen > 0 && now - last_progress > std::chrono::seconds(10)) {
            break;
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
      }
      emulated::Result r = rig.stop();
      if (viewer) viewer->stop();
      // The session as it is on disk (read back once closed) against the frames merged up to the host's
      // stop (every stage drained, the recording closed): the session line counts what it holds.
      std::optional<record::RunRecording> rec;
      if (!r.session_dir.empty()) rec = record::read_back(r.session_dir, r.final_report.frames);
      if (*json) {
        nlohmann::json j = report_json(r.report);
        if (rec) j["session"] = run_recording_json(*rec);
        j["accuracy"] = accuracy_json(r.accuracy);
        j["emulated"] = {{"nodes", opt->nodes}, {"motion", opt->motion},   {"appearance", opt->appearance},
                         {"room", opt->room},   {"carve", opt->carve},     {"grid", opt->grid},
                         {"size", *size},       {"rate_hz", opt->rate_hz}, {"truth_every", opt->truth_every}};
        j["wall_seconds"] = r.wall_seconds;
        if (!r.session_dir.empty()) j["session_dir"] = r.session_dir.string();
        j["host_rss_kb"] = {{"start", r.host_rss_start_kb}, {"end", r.host_rss_end_kb}};
        fmt::print("{}\n", j.dump(2));
      } else {
        print_report(r.report);
        if (rec) fmt::print("{}\n", record::run_recording_line(*rec));
        print_accuracy(r.accuracy);
      }
      if (r.report.frames == 0) throw std::runtime_error("no frame was merged");
      if (r.report.merging_stopped())
        throw std::runtime_error(fmt::format("frames stopped merging after seq {}: {} pulses never merged",
                                             r.report.last_seq, r.report.unmerged_pulses()));
      return;
    }
    // A real rig: the aggregator alone; the edges are on their boards. A rig.toml that cannot be read
    // or is wrong (a bad key, a node id without a number) is bad input: exit code 2.
    std::unique_ptr<aggregator::Aggregator> agg_ptr;
    config::RigConfig rig;
    try {
      std::filesystem::path path =
          config->empty() ? config::default_rig_config_path() : std::filesystem::path(*config);
      rig = config::load_rig_config(path);
      agg_ptr = std::make_unique<aggregator::Aggregator>(rig, aggregator::Options{});
    } catch (const config::ConfigError& e) {
      throw UsageError(e.what());
    }
    aggregator::Aggregator& agg = *agg_ptr;
    const std::filesystem::path record_dir =
        record->empty() ? rig.recording.dir : std::filesystem::path(*record);
    // The viewer (rig.toml [viewer]) records through its record switch, on from the start as without it.
    std::unique_ptr<view::Viewer> viewer;
    aggregator::RecordStage* recording = nullptr;
    if (rig.viewer.enabled && !*no_view) {
      view::ViewerOptions vo;
      vo.server = rig.viewer;
      if (*view_port >= 0) vo.server.port = static_cast<uint16_t>(*view_port);
      if (!view_bind->empty()) vo.server.bind = *view_bind;
      vo.record_dir = record_dir;
      vo.record_at_start = true;
      viewer = std::make_unique<view::Viewer>(vo);
      viewer->attach(agg.pipeline());
      viewer->set_report([&agg] { return agg.report(); });
      viewer->start();
      fmt::print("viewer: {}\n", viewer->url());
    } else {
      recording = &agg.pipeline().tap(std::make_unique<aggregator::RecordStage>(record_dir),
                                      aggregator::RecordStage::kQueue);
    }
    add_vmc_stage(agg.pipeline(), vmc_options(rig.vmc, *vmc));
    agg.start();  // creates the session folder
    const std::filesystem::path session_dir = recording ? recording->dir() : viewer->recorder()->state().dir;
    fmt::print("recording to {}\n", session_dir.string());
    auto end =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(*seconds > 0 ? *seconds : 1e12);
    while (!g_interrupted && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    agg.stop();
    if (viewer) viewer->stop();
    const aggregator::Report rep = agg.report();
    const record::RunRecording rec = record::read_back(session_dir, rep.frames);
    if (*json) {
      nlohmann::json j = report_json(rep);
      j["session"] = run_recording_json(rec);
      fmt::print("{}\n", j.dump(2));
    } else {
      print_report(rep);
      fmt::print("{}\n", record::run_recording_line(rec));
    }
    if (rep.merging_stopped())
      throw std::runtime_error(fmt::format("frames stopped merging after seq {}: {} pulses never merged",
                                           rep.last_seq, rep.unmerged_pulses()));
  });
}

}  // namespace vc::cli
