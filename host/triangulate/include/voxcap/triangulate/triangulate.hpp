// Robust multi-view triangulation of the tracked features (head, hands, feet) from the edges' 2D
// positions, and the agreement of left and right across views. The algorithm, its confidence and the
// left/right rule are written out in host/triangulate/README.md and at the top of triangulate.cpp.
//
//   triangulate_point()    one point from n >= 2 views: undistort (cv::undistortPoints), every pair
//                          of views as a two-view DLT hypothesis (exhaustive RANSAC over views, at most
//                          28 pairs for 8 cameras), the hypothesis most views agree with, a weighted DLT
//                          over those views, Gauss-Newton on the reprojection error.
//   FeatureTriangulator    per frame, all five features: the head from its views; each pair (hands,
//                          feet) from the views' observations taken without their labels, then named
//                          the performer's left/right in 3D, kept by continuity; per camera the swap of
//                          its labels (kept over time, re-decided when the data is clear).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/config/rig_config.hpp"
#include "voxcap/pipeline/frame.hpp"
#include "voxcap/rig/camera.hpp"
#include "voxcap/triangulate/hull_map.hpp"

namespace vc::triangulate {

using Options = config::TriangulationOptions;

// One camera's 2D observation of one point.
struct View {
  int camera = 0;     // rig camera index (calibration order)
  cv::Point2d uv_px;  // distorted pixel position, as the edge reports it
  double weight = 1;  // the view's confidence times its state's weight (predicted: predicted_weight)
};

struct PointResult {
  bool ok = false;             // two or more views agree (else `p_world` is meaningless)
  cv::Vec3d p_world{0, 0, 0};  // metres
  double rms_px = 0;           // RMS reprojection error over the inliers, pixels
  double confidence = 0;       // 0..1, see confidence() (before any left/right naming cap)
  std::vector<int> inliers;    // indices into the views given, ascending
};

// On the body (README, "On the body"): a point outside the frame's merged hull is not confident; with
// rejection on, a hypothesis whose point lies more than this many voxels outside it is not considered.
constexpr double kHullMarginVoxels = 2;
// Clearances are searched up to this far outside the hull (metres); farther is reported as this.
constexpr double kHullClearanceCapM = 0.25;

// Triangulates one point from its views (any order; a camera at most once). With a hull that is on,
// two-view hypotheses whose point lies more than kHullMarginVoxels outside it are not considered.
// Throws std::invalid_argument for a camera index outside `cameras`.
PointResult triangulate_point(const std::vector<rig::Camera>& cameras, const std::vector<View>& views,
                              const Options& options, const HullMap* hull = nullptr);
// Whether p lies more than kHullMarginVoxels outside the hull (false without a hull, or when the hull
// says nothing about p).
bool off_the_body(const HullMap* hull, const cv::Vec3d& p);

// The 3D confidence of a point (README, "Confidence"): the mean weight of the views used, times a
// factor for their count (two views: 0.5, three: 0.85, more: 1 — two views cannot outvote an
// outlier), times sqrt(views used / views that reported it), times exp(-(rms / (inlier_px/2))^2 / 2),
// times min(1, widest angle between two rays used / 20 degrees).
double confidence(double mean_weight, int used, int reported, double rms_px, double widest_angle_rad,
                  const Options& options);

// A camera's observations for one frame: the edges' five features in vc_feature_id order.
struct Observation {
  bool present = false;
  uint16_t state = 0;  // vc_feature_state
  cv::Point2d uv_px;
  double confidence = 0;
};
struct CameraObservations {
  int camera = 0;  // rig camera index
  std::array<Observation, 5> features;
};

enum class Pair { hands = 0, feet = 1 };

class FeatureTriangulator {
 public:
  // `front_cameras`: rig indices of the cameras of the nodes whose role is front (the performer faces
  // them at initialization). Throws std::invalid_argument for invalid options.
  FeatureTriangulator(std::vector<rig::Camera> cameras, std::vector<int> front_cameras, Options options);

  // One frame. Returns the five features in vc_feature_id order, named by the performer's side.
  // `hull`: the frame's merged hull (README, "On the body"), or null / off: the rule is off.
  std::array<pipeline::Feature3D, 5> process(const std::vector<CameraObservations>& frame,
                                             const HullMap* hull = nullptr);
  // The hull rule (README, "On the body") on (default) or off: a point outside the merged hull is
  // not confident. Off, the clearance is still reported (for before/after figures).
  void set_hull_rule(bool on) { hull_rule_ = on; }
  // With the rule on, also reject two-view hypotheses more than kHullMarginVoxels outside the hull
  // (off by default: README, "On the body", for what it gains and what it breaks).
  void set_hull_reject(bool on) { hull_reject_ = on; }

  // Whether camera `camera`'s left/right labels of a pair are the performer's right/left: 1 swapped,
  // 0 not, -1 not decided yet.
  int swapped(int camera, Pair pair) const;
  // The frame count processed (for tests and figures).
  uint64_t frames() const { return frames_; }

  // The performer's right as the body says, for the frames processed from now on (README, "The
  // body's right"): a direction in the world (its level part is used), or none. The stage gives the
  // fit's torso right of a recent frame (pipeline::BodyHeading).
  void set_body_right(const std::optional<cv::Vec3d>& right);
  // The times a pair was renamed because its names contradicted the body's right.
  uint64_t body_renames(Pair pair) const { return pairs_[static_cast<size_t>(pair)].renames; }

 private:
  struct Track {
    std::optional<cv::Vec3d> last, before;  // the last two positions (before: the frame before last)
    uint64_t last_frame = 0;                // frame index of `last`
    std::optional<cv::Vec3d> anchor;        // where the side has stood still (none before it is seen)
    int still = 0;                          // later positions within kStillM of `anchor`, in a row
  };
  struct PairState {
    Track side[2];         // 0: the performer's left, 1: right
    bool named = false;    // left/right have been named (init rule or swap votes) and are followed
    bool certain = false;  // the naming is trusted (confidence not capped)
    int against = 0;       // frames in a row the names contradicted the body's right, well apart
    uint64_t renames = 0;  // renamed by the body's right
    int verdict = 0;       // the body's right's last verdict on the names: 1 confirmed, -1 contradicted
    bool turned = false;   // confirmed, then the body's right turned round at once: it has no say
  };
  // The body's right check of a pair named A (found point 0) left when `*a_left`: may rename it and
  // sets *certain (README, "The body's right").
  void check_body_right(Pair pair, const cv::Vec3d& a, const cv::Vec3d& b, bool* a_left, bool* certain);

  void solve_pair(const std::vector<CameraObservations>& frame, Pair pair,
                  const std::optional<cv::Vec3d>& head, std::array<pipeline::Feature3D, 5>* out);
  // A triangulated feature against this frame's hull: its clearance reported, its confidence capped
  // below `confident` when it lies outside the hull at all (README, "On the body": the margin is
  // rejection's only).
  void on_the_body(pipeline::Feature3D* f) const;
  bool usable(const Observation& o) const;
  double view_weight(const Observation& o) const;
  int camera_slot(int camera) const;

  std::vector<rig::Camera> cameras_;
  std::vector<int> front_;
  Options opt_;
  std::array<PairState, 2> pairs_{};
  std::vector<std::array<int, 2>> swap_;  // per rig camera, per pair: -1, 0, 1
  std::optional<cv::Vec3d> body_right_;   // unit, level
  std::optional<cv::Vec3d> last_right_;   // the last body's right given (kept while none is given)
  uint64_t frames_ = 0;
  const HullMap* hull_ = nullptr;    // this frame's hull for the rule (null: off), during process()
  const HullMap* reject_ = nullptr;  // this frame's hull for rejecting hypotheses (null: off)
  const HullMap* seen_ = nullptr;    // this frame's hull for the reported clearance, during process()
  bool hull_rule_ = true;
  bool hull_reject_ = false;
};

}  // namespace vc::triangulate
