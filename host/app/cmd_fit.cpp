// `voxcap fit SESSION [--samples N --steps N --span-deg S --k K ...] --out DIR`: re-fits a recorded
// session offline with other [fitting] parameters (host/fit) and writes a new session: the same frames,
// 2D and 3D features and stats, with a new pose stream (POSE records, layout voxcap.pose15/1). Reads
// the records in file order, fitting each frame once its 3D features are in (the record stage writes a
// frame's FRAME record first, then its features, stats and FEATURES3D); the old poses are left out.
//
// `--score`: a session that voxcap demo recorded (it has virtual_rig.json) is also scored against the
// virtual rig's truth, offline (host/emulated's pose scorer, the figures of voxcap eval; the latency is
// then the fit's own time per frame, `live` holds the recorded run's figures). Without the real-time rig
// the figures do not depend on the machine's load: the way to iterate on the fitter. It also counts
// the frames with a left/right swap (`lr_swap_frames`: a pair of fitted joints nearer the other side's
// true joints than their own, per limb pair) and, with `--frames-csv FILE`, writes every scored frame's
// per-joint errors: where in a take the error is. `heading_flips` is how often the fit turned the torso
// round because the feet on the hull pointed the other way (Fitter::heading_flips), beside eval's
// `reinitialized_frames`: the two ways the fit corrects itself, which a score alone does not show.
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "pose_figures.hpp"
#include "session_rig.hpp"
#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/base/clock.hpp"
#include "voxcap/body/joints.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/emulated/pose_scorer.hpp"
#include "voxcap/fit/fitter.hpp"
#include "voxcap/record/from_proto.hpp"
#include "voxcap/record/pose.hpp"
#include "voxcap/record/recorder.hpp"
#include "voxcap/rig/calibration.hpp"
#include "voxcap/sim/scene.hpp"
#include "voxcap/triangulate/triangulate_stage.hpp"

namespace vc::cli {
namespace {

namespace fs = std::filesystem;

struct FitArgs {
  std::string session, out;
  std::optional<int> samples, steps, init_frames, reinit_after, predict_frames;
  std::optional<double> span_deg, k, straight_deg, min_cutoff, beta;
  std::string smoothing, body, frames_csv;
  bool score = false, json = false, retriangulate = false, no_hull_rule = false, hull_reject = false;
  std::optional<bool> follow_pair_swaps;
};

// A recorded FEATURES record (one node camera's 2D features) put back into its frame, as the live
// triangulation stage receives it.
void add_features(const record::FeatureRecord& r, pipeline::Frame* frame) {
  pipeline::NodePart* part = nullptr;
  for (pipeline::NodePart& p : frame->nodes)
    if (p.node_id == r.node_id) part = &p;
  if (!part) {
    frame->nodes.emplace_back();
    part = &frame->nodes.back();
    part->node_id = r.node_id;
  }
  part->features.push_back(record::to_proto(r));
}

config::FittingOptions fitting_options(const config::RigConfig& rig, const FitArgs& a) {
  config::FittingOptions o = rig.fitting;
  o.enabled = true;
  if (a.samples) o.samples = *a.samples;
  if (a.steps) o.steps = *a.steps;
  if (a.span_deg) o.span_deg = *a.span_deg;
  if (a.k) o.k = *a.k;
  if (a.straight_deg) o.straight_deg = *a.straight_deg;
  if (a.init_frames) o.init_frames = *a.init_frames;
  if (a.reinit_after) o.reinit_after_frames = *a.reinit_after;
  if (a.predict_frames) o.predict_frames = *a.predict_frames;
  if (a.follow_pair_swaps) o.follow_pair_swaps = *a.follow_pair_swaps;
  if (a.min_cutoff) o.one_euro_min_cutoff = *a.min_cutoff;
  if (a.beta) o.one_euro_beta = *a.beta;
  if (!a.smoothing.empty()) {
    if (a.smoothing == "none")
      o.smoothing = config::Smoothing::None;
    else if (a.smoothing == "one-euro")
      o.smoothing = config::Smoothing::OneEuro;
    else
      throw UsageError("--smoothing: none or one-euro, got '" + a.smoothing + "'");
  }
  if (!a.body.empty()) o.body = fs::absolute(a.body);
  std::string why;
  if (!o.valid(&why)) throw UsageError("fit: " + why);
  return o;
}

// Left/right swaps and per-frame errors of the fitted poses against the virtual rig's truth (the same
// joints as the pose scorer: PoseJoints by hw/body's standard names). A pair is swapped in a frame when
// its two fitted joints lie nearer the other side's true joints than their own (summed distances).
// Frames with part of the body outside the volume are left out, as the pose scorer does.
class SwapAudit {
 public:
  using J = pipeline::PoseJoint;
  // The pairs: arms (wrist, elbow), legs (ankle, knee), shoulders, hips.
  static constexpr std::array<std::array<J, 2>, 4> kPairs = {{{J::l_wrist, J::r_wrist},
                                                              {J::l_ankle, J::r_ankle},
                                                              {J::l_shoulder, J::r_shoulder},
                                                              {J::l_hip, J::r_hip}}};
  static constexpr std::array<const char*, 4> kPairNames = {"hands", "feet", "shoulders", "hips"};

  SwapAudit(std::unique_ptr<sim::Scene> scene, const rig::VoxelGrid& grid, uint64_t origin,
            const std::string& csv_path, double confident)
      : scene_(std::move(scene)), grid_(grid), origin_(origin), confident_(confident) {
    if (csv_path.empty()) return;
    csv_.emplace(csv_path);
    if (!*csv_) throw UsageError(fmt::format("fit: --frames-csv {}: cannot write", csv_path));
    *csv_ << "frame,state,mpjpe_mm";
    for (int j = 0; j < pipeline::kPoseJointCount; ++j) *csv_ << "," << pipeline::pose_joint_name(j) << "_mm";
    for (const char* n : kPairNames) *csv_ << ",swap_" << n;
    for (int f = 0; f < body::kFeatureCount; ++f)
      for (const char* c : {"_conf", "_err_mm", "_other_mm", "_hull_mm"})
        *csv_ << "," << body::feature_name(static_cast<body::Feature>(f)) << c;
    *csv_ << "\n";
  }

  // The frame's 3D features against the true head centre, wrists and ankles (as voxcap rig's
  // feature scorer): a feature above `confident` more than 10 cm off is a confident wrong answer,
  // counted on every frame.
  void add_features(uint64_t seq, const std::vector<pipeline::Feature3D>& features) {
    feature_row_.clear();
    if (seq < origin_) return;
    const std::array<cv::Vec3d, body::kJointCount> truth = scene_->joints(static_cast<int>(seq - origin_));
    auto joint = [&truth](int f) {
      return truth[static_cast<size_t>(body::feature_joint(static_cast<body::Feature>(f)))];
    };
    for (int f = 0; f < body::kFeatureCount; ++f) {
      const pipeline::Feature3D* p = nullptr;
      for (const pipeline::Feature3D& q : features)
        if (q.feature_id == f) p = &q;
      if (!p || p->state != pipeline::Feature3DState::Triangulated) {
        feature_row_ += ",,,,";
        continue;
      }
      const cv::Vec3d x(p->p_world[0], p->p_world[1], p->p_world[2]);
      const double err = 1e3 * cv::norm(x - joint(f));
      // The other side's truth (hands and feet): a point named wrong lies near it.
      const int other = f == 0 ? 0 : f % 2 == 1 ? f + 1 : f - 1;
      const double err_other = 1e3 * cv::norm(x - joint(other));
      if (double(p->confidence) > confident_ && err > 100) confident_wrong_[static_cast<size_t>(f)]++;
      feature_row_ += fmt::format(",{:.3f},{:.1f},{:.1f},", p->confidence, err, err_other);
      if (p->hull_clearance_m >= 0) feature_row_ += fmt::format("{:.1f}", 1e3 * p->hull_clearance_m);
    }
  }

  void add(uint64_t seq, const pipeline::Pose& pose) {
    if (seq < origin_ || !pose.valid()) return;
    const int frame = static_cast<int>(seq - origin_);
    const std::array<cv::Vec3d, body::kJointCount> truth = scene_->joints(frame);
    // As the pose scorer: a frame with part of the body outside the volume is left out.
    const cv::Vec3d lo = grid_.min_m, hi = lo + cv::Vec3d(grid_.nx, grid_.ny, grid_.nz) * grid_.voxel_m;
    for (const cv::Vec3d& p : truth)
      for (int a = 0; a < 3; ++a)
        if (p[a] < lo[a] || p[a] > hi[a]) return;
    auto fit = [&pose](J j) {
      const auto& v = pose.p_world[static_cast<size_t>(j)];
      return cv::Vec3d(v[0], v[1], v[2]);
    };
    auto tru = [&truth](J j) {
      return truth[static_cast<size_t>(
          body::joint_from_name(pipeline::pose_joint_name(static_cast<int>(j))))];
    };
    std::array<bool, kPairs.size()> sw{};
    bool any = false;
    for (size_t i = 0; i < kPairs.size(); ++i) {
      const J l = kPairs[i][0], r = kPairs[i][1];
      const double own = cv::norm(fit(l) - tru(l)) + cv::norm(fit(r) - tru(r));
      const double other = cv::norm(fit(l) - tru(r)) + cv::norm(fit(r) - tru(l));
      sw[i] = other < own;
      swaps_[i] += sw[i] ? 1 : 0;
      any = any || sw[i];
    }
    any_ += any ? 1 : 0;
    if (!csv_) return;
    double sum = 0;
    std::array<double, pipeline::kPoseJointCount> e{};
    for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
      e[static_cast<size_t>(j)] = 1e3 * cv::norm(fit(static_cast<J>(j)) - tru(static_cast<J>(j)));
      sum += e[static_cast<size_t>(j)];
    }
    *csv_ << frame << "," << static_cast<int>(pose.state) << ","
          << fmt::format("{:.1f}", sum / pipeline::kPoseJointCount);
    for (double v : e) *csv_ << "," << fmt::format("{:.1f}", v);
    for (bool b : sw) *csv_ << "," << (b ? 1 : 0);
    *csv_ << (feature_row_.empty() ? std::string(4 * body::kFeatureCount, ',') : feature_row_) << "\n";
  }

  nlohmann::json confident_wrong_json() const {
    nlohmann::json j = nlohmann::json::object();
    uint64_t all = 0;
    for (int f = 0; f < body::kFeatureCount; ++f) {
      j[std::string(body::feature_name(static_cast<body::Feature>(f)))] =
          confident_wrong_[static_cast<size_t>(f)];
      all += confident_wrong_[static_cast<size_t>(f)];
    }
    j["all"] = all;
    return j;
  }

  nlohmann::json json() const {
    nlohmann::json j = {{"any", any_}};
    for (size_t i = 0; i < kPairs.size(); ++i) j[kPairNames[i]] = swaps_[i];
    return j;
  }
  std::string line() const {
    std::string s = fmt::format("{} frames", any_);
    for (size_t i = 0; i < kPairs.size(); ++i) s += fmt::format(", {} {}", kPairNames[i], swaps_[i]);
    return s;
  }

 private:
  std::unique_ptr<sim::Scene> scene_;
  rig::VoxelGrid grid_;
  uint64_t origin_;
  std::optional<std::ofstream> csv_;
  std::array<uint64_t, kPairs.size()> swaps_{};
  uint64_t any_ = 0;
  double confident_ = 0.5;
  std::array<uint64_t, body::kFeatureCount> confident_wrong_{};
  std::string feature_row_;  // this frame's feature columns of the CSV
};

void run_fit(const FitArgs& a) {
  const fs::path in(a.session);
  std::error_code ec;
  if (!fs::is_directory(in, ec) || !fs::exists(in / "records.vcr", ec))
    throw UsageError(fmt::format("fit: {}: not a voxcap session (no records.vcr)", a.session));
  if (a.out.empty() && !a.score)
    throw UsageError("fit: --out DIR is required (a new session folder), unless --score");
  if (!a.frames_csv.empty() && !a.score) throw UsageError("fit: --frames-csv needs --score");
  if ((a.no_hull_rule || a.hull_reject) && !a.retriangulate)
    throw UsageError("fit: --no-hull-rule and --hull-reject need --retriangulate");
  if (a.no_hull_rule && a.hull_reject)
    throw UsageError("fit: --hull-reject needs the hull rule (no --no-hull-rule)");
  if (a.retriangulate && (!a.score || !a.out.empty()))
    throw UsageError("fit: --retriangulate needs --score and no --out (the new 3D features are not written)");
  // The session's own rig.toml and calibration copies: the grid the hulls were carved on.
  const config::RigConfig rig = session_rig(in, "fit", a.retriangulate);
  const config::FittingOptions options = fitting_options(rig, a);
  fit::Fitter fitter(rig.grid, options, rig.trigger.rate_hz);
  // --retriangulate: the recorded 2D features triangulated again (host/triangulate, this build's rules),
  // with the fit's torso right fed back as in the live pipeline; the recorded 3D features are ignored.
  pipeline::StageContext tctx;
  tctx.rig = &rig;
  triangulate::TriangulateStage tri;
  if (a.retriangulate) {
    try {
      tri.configure(tctx);
      tri.set_hull_rule(!a.no_hull_rule);
      tri.set_hull_reject(a.hull_reject);
    } catch (const std::invalid_argument& e) {
      throw UsageError(fmt::format("fit --retriangulate: {}", e.what()));
    }
  }

  // The virtual rig's truth, when scoring: the same scene the edges rendered, on the session's calibration.
  std::optional<VirtualRig> vrig;
  std::unique_ptr<emulated::PoseScorer> scorer;
  std::optional<SwapAudit> audit;
  if (a.score) {
    try {
      vrig = read_virtual_rig(in);
    } catch (const std::runtime_error& e) {
      throw UsageError(fmt::format("fit --score: {}", e.what()));
    }
    const rig::Calibration cal = rig::read_calibration((in / "calibration.yaml").string());
    scorer = std::make_unique<emulated::PoseScorer>(
        std::make_unique<sim::Scene>(emulated::truth_scene_options(vrig->rig, cal)), rig.grid, false);
    scorer->set_origin(vrig->origin);
    audit.emplace(std::make_unique<sim::Scene>(emulated::truth_scene_options(vrig->rig, cal)), rig.grid,
                  vrig->origin, a.frames_csv, rig.triangulation.confident);
  }

  record::Reader reader = record::Reader::open(in);
  const nlohmann::json meta = {
      {"refit_of", fs::absolute(in).string()},
      {"fitting",
       {{"samples", options.samples},
        {"steps", options.steps},
        {"span_deg", options.span_deg},
        {"k", options.k},
        {"straight_deg", options.straight_deg},
        {"smoothing", options.smoothing == config::Smoothing::OneEuro ? "one-euro" : "none"},
        {"init_frames", options.init_frames}}}};
  std::optional<record::Recorder> out;
  if (!a.out.empty())
    out = record::Recorder::create(a.out, in / "rig.toml", in / "calibration.yaml", meta.dump());
  auto append = [&out](const auto& rec) {
    if (out) out->append(rec);
  };

  pipeline::Frame frame;  // the frame being gathered (its FRAME record came, its features may follow)
  bool pending = false;
  uint64_t frames = 0, posed = 0, init = 0, old_poses = 0;
  uint64_t fit_ns = 0;
  // The fit's own time per stage (Fitter::times), for the score's figures: where a slow frame goes.
  constexpr std::array<const char*, 6> kStageNames = {"decode", "segment", "pca",
                                                      "layer1", "layer2",  "total"};
  std::array<aggregator::Latency, kStageNames.size()> stage_ns;
  record::PoseRecord pose_rec;
  auto flush = [&] {
    if (!pending) return;
    if (a.retriangulate) tri.process(frame);
    const uint64_t t0 = vc::monotonic_ns();
    const pipeline::Pose pose = fitter.fit(frame);
    fit_ns += vc::monotonic_ns() - t0;
    if (a.retriangulate) fit::publish_heading(pose, frame.seq, tctx.body_heading.get());
    if (scorer) {  // offline, the "trigger" is the moment the frame is handed to the fitter
      const fit::StageTimes& st = fitter.times();
      uint64_t l2 = 0;
      for (uint64_t v : st.layer2_ns) l2 += v;
      const std::array<uint64_t, kStageNames.size()> v = {
          st.decode_ns, st.segment_ns, st.pca_ns, st.layer1_ns, l2, st.total_ns};
      for (size_t i = 0; i < v.size(); ++i) stage_ns[i].add(v[i]);
      frame.t_trigger_ns = t0;
      frame.pose = pose;
      scorer->process(frame);
      audit->add_features(frame.seq, frame.features3d);
      audit->add(frame.seq, pose);
    }
    record::to_record(frame.seq, pose, frames == 0, &pose_rec);
    append(pose_rec);
    ++frames;
    posed += pose.valid() ? 1 : 0;
    init += (!pose.valid() && posed == 0) ? 1 : 0;
    pending = false;
  };
  record::Record r;
  while (reader.next(r)) {
    if (const auto* f = std::get_if<record::FrameRecord>(&r)) {
      flush();
      frame = record::frame_from_record(*f);
      pending = true;
      append(*f);
    } else if (const auto* fr = std::get_if<record::FeatureRecord>(&r); fr && a.retriangulate) {
      if (pending && fr->seq == frame.seq) add_features(*fr, &frame);
    } else if (const auto* f3 = std::get_if<record::Features3DRecord>(&r)) {
      if (pending && f3->seq == frame.seq && !a.retriangulate) {
        frame.triangulated = true;
        frame.features3d.clear();
        for (const auto& p : f3->features) frame.features3d.push_back(record::feature3d_from_record(p));
      }
      append(*f3);
    } else if (std::holds_alternative<record::PoseRecord>(r)) {
      ++old_poses;  // replaced by the new pose stream
    } else {
      std::visit([&](const auto& x) { append(x); }, r);
    }
  }
  flush();
  if (out) out->close();
  const record::Reader::Summary& s = reader.summary_ref();
  if (!s.closed_cleanly)
    fmt::print(stderr, "voxcap fit: {}: the session is {} ({}); fitted up to its last complete record\n",
               a.session, to_string(s.stop), s.stop_detail);
  if (scorer) {
    const emulated::PoseAccuracy acc = scorer->accuracy();
    if (a.json) {
      nlohmann::json j = pose_figures_json(acc);
      j["offline"] = true;  // latency_ms and fps: the fit's own time per frame on this machine
      j["session"] = fs::absolute(in).string();
      j["rig"] = {
          {"motion", vrig->rig.motion},     {"nodes", vrig->rig.nodes},
          {"cameras", 2 * vrig->rig.nodes}, {"size", fmt::format("{}x{}", vrig->rig.width, vrig->rig.height)},
          {"grid", vrig->rig.grid},         {"noise", vrig->rig.noise},
          {"rate_hz", vrig->rig.rate_hz},   {"appearance", vrig->rig.appearance},
          {"room", vrig->rig.room}};
      j["live"] = vrig->live;
      j["lr_swap_frames"] = audit->json();
      j["confident_wrong_features"] = audit->confident_wrong_json();
      j["fit_pair_swaps"] = {{"hands", fitter.pair_swaps()[0]}, {"feet", fitter.pair_swaps()[1]}};
      j["heading_flips"] = fitter.heading_flips();
      j["hull_named_feet"] = fitter.hull_named_feet();
      nlohmann::json stages = nlohmann::json::object();
      for (size_t i = 0; i < kStageNames.size(); ++i)
        stages[kStageNames[i]] = {{"p50", stage_ns[i].percentile_ms(0.5)},
                                  {"p99", stage_ns[i].percentile_ms(0.99)},
                                  {"max", stage_ns[i].max_ms()}};
      j["fit_stage_ms"] = stages;
      fmt::print("{}\n", j.dump(2));
    } else {
      fmt::print("scored      {} against the virtual rig's truth (motion '{}'), offline\n", a.session,
                 vrig->rig.motion);
      print_pose_figures(acc, vrig->rig.rate_hz, "fit time");
      fmt::print(
          "swaps       left/right swapped on {} (fitted pairs against the truth); the fit swapped the "
          "hands' features {} times, the feet's {} times; the feet turned the torso round {} times "
          "(heading_flips), {} frames re-initialized (reinitialized_frames); the hull renamed a foot on {} "
          "frames (hull_named_feet)\n",
          audit->line(), fitter.pair_swaps()[0], fitter.pair_swaps()[1], fitter.heading_flips(),
          acc.reinitialized_frames, fitter.hull_named_feet());
      std::string stages;
      for (size_t i = 0; i < kStageNames.size(); ++i)
        stages += fmt::format(" {} {:.3f}/{:.3f}/{:.3f}", kStageNames[i], stage_ns[i].percentile_ms(0.5),
                              stage_ns[i].percentile_ms(0.99), stage_ns[i].max_ms());
      fmt::print("fit stages {} ms (p50/p99/max)\n", stages);
      if (vrig->live.contains("latency_ms"))
        fmt::print("live run    trigger -> pose p50 {:.1f} ms, p99 {:.1f} ms; fitted_frames {} of {}\n",
                   vrig->live["latency_ms"].value("p50", 0.0), vrig->live["latency_ms"].value("p99", 0.0),
                   vrig->live.value("fitted_frames", 0), vrig->live.value("frames", 0));
    }
  }
  if (!a.json)
    fmt::print(
        "{} frames re-fitted ({} initialization, {} with a pose; {} old poses replaced), {:.3f} ms a "
        "frame{}\n",
        frames, init, posed, old_poses, frames ? double(fit_ns) / double(frames) * 1e-6 : 0.0,
        a.out.empty() ? std::string() : ", session " + a.out);
}

}  // namespace

void add_fit_commands(CLI::App& app) {
  auto a = std::make_shared<FitArgs>();
  CLI::App* cmd =
      app.add_subcommand("fit",
                         "Re-fit a recorded session offline with other [fitting] parameters (host/fit) and "
                         "write a new session to "
                         "--out: the same frames, features and stats with a new pose stream (voxcap export "
                         "reads it). Options not "
                         "given keep the session's rig.toml [fitting] values (host/config/README.md)");
  cmd->add_option("SESSION", a->session, "Session folder with merged hulls and 3D features")->required();
  cmd->add_option("--out", a->out,
                  "The new session folder (must not exist or be empty); required unless --score");
  cmd->add_flag("--score", a->score,
                "Score the new poses against the virtual rig's truth offline (a session of voxcap demo, "
                "with its virtual_rig.json): the figures of voxcap eval; latency_ms and fps are then the "
                "fit's own time per frame, `live` the recorded run's figures");
  cmd->add_flag(
      "--json", a->json,
      "With --score: the figures as one JSON object (voxcap eval's keys, reinitialized_frames "
      "among them: frames whose pose is a re-initialization; offline: true, session, rig {...}, "
      "live (the recorded run's figures), lr_swap_frames {any, hands, feet, shoulders, hips}, "
      "fit_pair_swaps {hands, feet}, confident_wrong_features {head, l_hand, r_hand, l_foot, r_foot, all}: "
      "3D features above `confident` more than 10 cm off, heading_flips: how often the feet on the hull "
      "turned the "
      "torso round, hull_named_feet: frames where the hull changed an untrusted foot name, "
      "host/fit/README.md; fit_stage_ms {decode, segment, pca, layer1, layer2, "
      "total: {p50, p99, max}})");
  cmd->add_option("--frames-csv", a->frames_csv,
                  "With --score: write every scored frame's per-joint errors (mm) and left/right swaps "
                  "to this CSV, and per 3D feature its confidence, its error against the true head "
                  "centre / wrist / ankle, against the other side's, and its clearance outside the "
                  "merged hull (mm; --retriangulate)");
  cmd->add_flag("--retriangulate", a->retriangulate,
                "With --score (no --out): triangulate the recorded 2D features again (this build's "
                "host/triangulate, the fit's torso right fed back as live) instead of using the recorded "
                "3D features: a deterministic check of the left/right naming");
  cmd->add_flag("--no-hull-rule", a->no_hull_rule,
                "With --retriangulate: triangulate without the merged hull's rule (a point outside the "
                "hull may be confident, host/triangulate/README.md \"On the body\"); the clearance is "
                "still reported");
  cmd->add_flag("--hull-reject", a->hull_reject,
                "With --retriangulate: also reject two-view hypotheses more than 2 voxels outside the "
                "merged hull (off by default: host/triangulate/README.md \"On the body\")");
  cmd->add_option("--samples", a->samples, "Cylinder samples per limb");
  cmd->add_option("--steps", a->steps, "The method's nu: angles tried per layer-2 search");
  cmd->add_option("--span-deg", a->span_deg, "The method's s: the search covers rho(t-1) +- s degrees");
  cmd->add_option("--k", a->k, "The match score is n^k");
  cmd->add_option("--straight-deg", a->straight_deg, "A limb bent less than this keeps rho(t-1)");
  cmd->add_option("--smoothing", a->smoothing, "Output smoothing: none or one-euro");
  cmd->add_option("--one-euro-min-cutoff", a->min_cutoff, "One-Euro filter minimum cutoff, Hz");
  cmd->add_option("--one-euro-beta", a->beta, "One-Euro filter speed coefficient");
  cmd->add_option("--body", a->body, "A body.toml overriding the automatic body model");
  cmd->add_option("--init-frames", a->init_frames, "Initialization frames averaged for the body model");
  cmd->add_option("--reinit-after", a->reinit_after, "Frames the fit must fail in a row to re-initialize");
  cmd->add_option("--predict-frames", a->predict_frames,
                  "A lost feature is predicted for at most this many frames");
  cmd->add_option("--follow-pair-swaps", a->follow_pair_swaps,
                  "true/false: take a hand or foot pair crosswise when the limbs' paths say its names were "
                  "swapped (rig.toml [fitting] follow_pair_swaps; off by default, host/fit/README.md)");
  cmd->callback([a] { run_fit(*a); });
}

}  // namespace vc::cli
