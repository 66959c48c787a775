// track_eval MOTION [FRAMES] [truth|edge] [seeds|own] [APPEARANCE] [ROOM]: runs the trackers of every
// camera of the 6-camera virtual rig over a motion and prints, per feature, the 2D error (p50/p95, px)
// while visible and tracked, visible frames not tracked, losses, frames to recover, and the cost.
// TRACK_EVAL_GROW_PX=N makes the edge masks with the limb-scale cue at N pixels (0: off; unset: the
// edge's default). TRACK_EVAL_TRACE=F (0-4) also prints every camera frame of feature F: state,
// confidence, error, the reported and the true point (where a tail comes from).
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "track_eval.hpp"

int main(int argc, char** argv) {
  using namespace vc::track::eval;
  EvalOptions o;
  if (argc > 1) o.motion = argv[1];
  if (argc > 2) o.frames = std::atoi(argv[2]);
  if (argc > 3) o.masks = std::string(argv[3]) == "truth" ? Masks::truth : Masks::edge;
  if (argc > 4) o.truth_seeds = std::string(argv[4]) != "own";
  if (argc > 5) o.appearance = argv[5];
  if (argc > 6) o.room = argv[6];
  if (const char* t = std::getenv("TRACK_EVAL_TRACE")) o.trace_feature = std::atoi(t);
  if (const char* g = std::getenv("TRACK_EVAL_GROW_PX")) o.grow_px = std::atoi(g);
  EvalResult r;
  try {
    r = evaluate(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "track_eval: %s\n", e.what());
    return 1;
  }
  static const char* names[] = {"head", "left_hand", "right_hand", "left_foot", "right_foot"};
  std::printf("%s: %d frames x %d cameras, %s masks, %s seeds, grow_px %d\n", o.motion.c_str(), o.frames,
              o.cameras, o.masks == Masks::truth ? "true" : "edge", o.truth_seeds ? "true" : "own",
              o.grow_px);
  std::printf("%-11s %7s %7s %8s %9s %7s %9s %11s %6s %5s %13s %17s\n", "feature", "p50_px", "p95_px",
              "visible", "untracked", "losses", "rec_max", "unrecovered", ">25px", "conf", "bias_px",
              "pred p50/p95");
  for (int f = 0; f < vc::track::kFeatures; ++f) {
    const FeatureScore& s = r.features[static_cast<std::size_t>(f)];
    int rmax = 0;
    for (int k : s.recover) rmax = std::max(rmax, k);
    const double n = std::max(1, s.near);
    std::printf("%-11s %7.2f %7.2f %8d %9d %7d %9d %11d %6d %5d %6.1f,%6.1f %5zu %5.1f/%5.1f\n", names[f],
                s.pct(0.5), s.pct(0.95), s.visible, s.visible_untracked, s.losses, rmax, s.unrecovered,
                s.far_tracking, s.far_confident, s.bias.x / n, s.bias.y / n, s.predicted.size(),
                FeatureScore::pct_of(s.predicted, 0.5), FeatureScore::pct_of(s.predicted, 0.95));
  }
  FeatureScore all;
  all.errors = r.all_errors();
  std::printf("limb frame (2D px over tracked reports within 25 px; 3D mm over triangulated frames):\n");
  std::printf("%-11s %8s %8s %8s | %8s %8s %8s %8s %8s %6s\n", "feature", "2d_along", "2d_acrss", "2d_n",
              "3d_along", "3d_acrss", "3d_fwd", "3d_p50", "3d_p95", "3d_n");
  for (int f = 0; f < vc::track::kFeatures; ++f) {
    const LimbBias& b2 = r.bias2d[static_cast<std::size_t>(f)];
    const LimbBias& b3 = r.bias3d[static_cast<std::size_t>(f)];
    std::printf("%-11s %8.2f %8.2f %8d | %8.1f %8.1f %8.1f %8.1f %8.1f %6d\n", names[f],
                b2.mean(&LimbBias::along), b2.mean(&LimbBias::across), b2.n, b3.mean(&LimbBias::along),
                b3.mean(&LimbBias::across), b3.mean(&LimbBias::forward), FeatureScore::pct_of(b3.err_mm, 0.5),
                FeatureScore::pct_of(b3.err_mm, 0.95), b3.n);
  }
  std::printf("per camera p50/p95 px:\n");
  for (int f = 0; f < vc::track::kFeatures; ++f) {
    std::printf("%-11s", names[f]);
    for (const auto& e : r.features[static_cast<std::size_t>(f)].per_camera)
      std::printf(" %5.1f/%5.1f", FeatureScore::pct_of(e, 0.5), FeatureScore::pct_of(e, 0.95));
    std::printf("\n");
  }
  std::printf("all         %7.2f %7.2f   cost %.3f ms per camera frame (%d camera frames)\n", all.pct(0.5),
              all.pct(0.95), r.track_ms_per_camera_frame, r.camera_frames);
  return 0;
}
