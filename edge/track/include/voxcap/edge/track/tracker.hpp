// Head, hands and feet in one camera (paper sec. 6): colour models learnt on the initialization frames,
// CamShift per feature on the back-projection masked by the node's own silhouette, loss detection and
// re-acquisition from the current silhouette.
//
// Life of a CameraTracker (one per camera of a tracking node):
//   init      — every frame, the seeder (segmentation of the silhouette, or given seeds in tests) says
//               where each feature is; the feature's colour model learns the skin pixels of its region
//               (a disk around the seed within the silhouette). After `init_frames` frames in which the
//               seeder succeeded, the models are finished and every seeded feature gets a window on the
//               skin blob at its seed. Reports: every feature not_visible.
//   tracking  — per feature: back-project its model in a search window around the motion-predicted
//               position, masked by the silhouette; CamShift (Bradski 1998) from the previous window.
//               The reported point is the feature's JOINT as hw/sim's truth measures it (head centre,
//               wrist, ankle), estimated from the blob (estimate_point()), not the skin blob's centroid;
//               skin pixels another window owns (feet standing together joined by their shadow) are
//               not the blob's while both windows hold their own mass (clear_others()).
//   loss      — the back-projected mass in the window falls below `min_mass_ratio` of what the feature
//               had while tracked well, the window collapses, it leaves the silhouette, it jumps further
//               than the motion allows, or it merges with another feature's window (the one that moved
//               less against its prediction keeps the blob). A lost feature reports `lost` with its last
//               position and confidence 0.
//   ambiguity — two windows converge (their centres closer than `ambiguous_near` of their mean size:
//               hands crossing or swinging past each other, a hand passing the face, feet crossing in a
//               side view): which window holds which part is no longer known. Both are reported
//               `predicted` — a constant-velocity prediction from where they were when they met, with a
//               low confidence — and the windows may share a blob (no merge loss) while they are. When
//               they part (farther than `ambiguous_far`), each is given to the window nearer its
//               prediction (the pair swapped when that fits clearly better); when neither assignment
//               fits clearly better, both restart their confidence ramp. Together for longer than
//               `ambiguous_max_frames`: decided as if they had parted. Windows that are near but do not
//               close in on each other (feet standing together) are not ambiguous.
//   re-acquire — every frame while lost: the skin blobs of the current silhouette that no tracked window
//               holds (colour: the pooled model of all features; the silhouette's extremities, where
//               hands and feet are, come first) are candidates; the nearest to the last known position
//               within a reach that grows with the frames lost takes the window. A re-acquired feature is
//               reported `tracking` with its confidence ramping up over `recover_frames` frames, so the
//               host can weigh it low at first.
//   join      — a foot or hand whose seed fell on its sibling's blob at init (the feet together seen from
//               the side: one blob, one window) joins at the first frame a free skin blob lies beside the
//               sibling's window; the two are then named by the seeder's image-side rule.
// Identity is kept over time (a tracker never re-decides which hand it follows from the image side);
// left and right are the seeder's, by image side as if the camera faced the performer. A freshly lost
// feature is reported `predicted` (constant velocity, low confidence) for `predict_frames` frames, then
// `lost`; re-acquisition searches around the predicted position.
//
// Limits: one colour per feature; a hand over the face or two hands clasped are one blob, so one of the
// two is lost until they part; a sleeve or trouser of skin colour makes the blob longer than the hand.
// Allocation: buffers are made at the first frame (of a size); a frame allocates only OpenCV's small
// internal buffers, and re-acquisition (a labelling of the silhouette's skin pixels) only while a
// feature is lost.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include <opencv2/core.hpp>

#include "voxcap/edge/track/colour_model.hpp"

namespace vc::track {

inline constexpr int kFeatures = 5;  // head, left_hand, right_hand, left_foot, right_foot (vc_feature_id)
enum class FeatureKind { head, hand, foot };
FeatureKind feature_kind(int feature);

// What a tracker says about one feature in one frame; states as on the wire (proto vc_feature_state).
enum class FeatureState { tracking = 0, predicted = 1, lost = 2, not_visible = 3 };
struct FeatureReport {
  FeatureState state = FeatureState::not_visible;
  cv::Point2f uv{0, 0};  // pixel column/row in the (distorted) image
  float confidence = 0;  // 0..1
};
using FrameReport = std::array<FeatureReport, kFeatures>;

// Where the features are in an initialization frame, in vc_feature_id order.
struct Seed {
  bool found = false;
  cv::Point2f point{0, 0};  // the feature's joint (head centre, wrist, ankle), or a point on its blob
};
using Seeds = std::array<Seed, kFeatures>;
// Segments a silhouette (0/255, CV_8UC1) into seeds; false (why says it) when it cannot.
using Seeder = std::function<bool(const cv::Mat1b& mask, Seeds* seeds, std::string* why)>;

// The method's initialization pose without segmentation (arms spread, legs together, facing roughly
// towards the camera): head = the top of the silhouette, hands = its left- and rightmost points, feet =
// the lowest points on either side of its centre column. Left/right by image side. For cameras that see
// the pose from the side this is a guess that the colour check at the start of tracking may reject.
bool extremity_seeds(const cv::Mat1b& mask, Seeds* seeds, std::string* why);

// The default seeder: edge/segment's GVD segmentation (vc::segment::segment: the five terminal regions
// and their joints' 2D positions); where it does not give all five (a side view of the init pose) the
// silhouette's extremities give what they can, so a side camera still tracks the head and the feet.
bool segment_seeds(const cv::Mat1b& mask, Seeds* seeds, std::string* why);

struct TrackerOptions {
  ColourModelOptions colour;
  int init_frames = 5;           // initialization frames (seeder succeeded) to learn the colour models
  double seed_radius = 0.06;     // the region learnt around a seed, as a share of the silhouette height
  int min_blob_px = 12;          // a skin blob smaller than this is no feature
  int prob_threshold = 48;       // back-projection above this counts as the feature's colour
  double min_mass_ratio = 0.25;  // mass in the window below this share of the reference: lost
  double min_area_ratio = 0.12;  // window area below this share of the reference: collapsed
  double min_inside = 0.5;       // share of the window's skin pixels that must lie in the silhouette
  double max_jump = 1.5;         // the window moves at most this many window sizes past the prediction
  double merge_iou = 0.35;       // two windows overlapping more than this have merged
  int recover_frames = 5;        // confidence ramps up over this many frames after re-acquisition
  double reach_px = 24;          // re-acquisition reach around the last position, + reach_grow per lost frame
  double reach_grow = 6;
  double ambiguous_near = 0.75;  // windows whose centres are closer than this x their mean size: ambiguous
  double ambiguous_far = 1.25;   // ... until farther than this x their mean size
  double swap_ratio = 0.6;  // on parting, the other assignment is taken when its cost is below this share
  int ambiguous_max_frames = 20;       // ambiguous longer than this: decided as on parting
  int predict_frames = 5;              // a lost feature is reported predicted this many frames
  float predicted_confidence = 0.35f;  // confidence of a predicted report (decays over the prediction)

  bool valid(std::string* why) const;
};

class CameraTracker {
 public:
  // seeder: nullptr = segment_seeds. Throws std::invalid_argument for invalid options.
  explicit CameraTracker(const TrackerOptions& options = {}, Seeder seeder = nullptr);

  // Back to initialization (a new START): models and windows are forgotten.
  void reset();
  // One frame: rgb CV_8UC3 (RGB order), mask CV_8UC1 0/255 of the same size (the node's silhouette).
  // A frame of another size than the last resets the tracker. Never throws for image content (an empty
  // mask, a feature never seen): those are reported as states.
  void process(const cv::Mat3b& rgb, const cv::Mat1b& mask, FrameReport* out);

  bool initialised() const { return phase_ == Phase::tracking; }
  int init_frames_done() const { return init_done_; }
  const std::string& last_seed_failure() const { return seed_why_; }
  const ColourModel& model(int feature) const { return models_[static_cast<std::size_t>(feature)]; }
  // Re-acquisitions and losses so far (diagnostics, the bench).
  std::uint64_t losses() const { return losses_; }
  std::uint64_t reacquisitions() const { return reacquired_; }
  std::uint64_t swaps() const { return swaps_; }  // ambiguities resolved by exchanging the two windows

 private:
  enum class Phase { init, tracking };
  struct Track {
    bool seen = false;  // had a window once (else not_visible)
    bool active = false;
    cv::Rect window;
    cv::Point2f centre{0, 0}, velocity{0, 0};
    cv::Point2f uv{0, 0};
    double ref_mass = 0, ref_area = 0;
    int lost_frames = 0, since_recovery = 1000;
    float confidence = 0;
    float moved = 0;        // distance from prediction this frame (merge arbitration)
    double mass_ratio = 1;  // the window's mass against its reference, at its last update
    // Ambiguity (two windows converging) and prediction: where the feature was and how it moved when
    // the ambiguity began or the window was lost; frames since.
    int partner = -1;
    int amb_frames = 0;
    cv::Point2f pred_uv{0, 0}, pred_centre{0, 0}, pred_velocity{0, 0};
    cv::Point2f prev_uv{0, 0}, prev_centre{0, 0}, prev_velocity{0, 0};  // before this frame's update
    // Re-acquired from a blob its lost sibling (the other hand or foot) could have been: which of the two
    // it holds is not known until the sibling is back (settle_doubt()); where it was expected then.
    bool doubt = false;
    cv::Point2f doubt_pred{0, 0};
    // Seeded at init on the blob of its sibling (the other foot or hand: both seen as one, feet together
    // in a side view), which took it: joined as soon as a blob of its own kind parts from the sibling's
    // (join_siblings()).
    bool joins = false;
    cv::Point2f predicted_uv(int frames) const;
    cv::Point2f predicted_centre(int frames) const;
  };

  void learn_frame(const cv::Mat3b& rgb, const cv::Mat1b& mask, const Seeds& seeds);
  void start_tracking(const cv::Mat3b& rgb, const cv::Mat1b& mask, const Seeds& seeds);
  void track_one(int f, const cv::Mat3b& rgb, const cv::Mat1b& mask);
  void resolve_merges();
  void update_ambiguity();
  void part(int a, int b);
  void swap_windows(int a, int b);
  void settle_doubt(int a, int b, cv::Point2f pb);
  float proximity(int f) const;
  void reacquire(const cv::Mat3b& rgb, const cv::Mat1b& mask);
  // The features waiting to join their sibling (Track::joins) take the free skin blob beside it.
  void join_siblings(const cv::Mat3b& rgb, const cv::Mat1b& mask);
  void lose(int f);
  // HSV and the back-projection of `model` over roi (into hsv_ and prob_ at the same pixels).
  void prepare(const cv::Mat3b& rgb, const cv::Mat1b& mask, const cv::Rect& roi, const ColourModel& model);
  // Clears the back-projection over `region` where another tracked window owns the pixel (nearer it).
  void clear_others(int f, const cv::Rect& window, const cv::Rect& region);
  // The feature's joint from the blob in `window`; hsv_ and prob_ are this frame's inside `valid`.
  bool estimate_point(int f, const cv::Rect& window, const cv::Rect& valid, const cv::Mat1b& mask,
                      cv::Point2f* uv);
  // The wrist or ankle where the clothes cover the limb beside the blob (centroid c) in `window`.
  cv::Point2f joint_beyond_blob(const cv::Rect& window, const cv::Rect& inner, const cv::Mat1b& mask,
                                cv::Point2f c);
  // Adopts the skin blob with bounding box `box` as feature f's window (hsv_ and prob_ valid in `valid`).
  void adopt(int f, const cv::Rect& box, const cv::Rect& valid, const cv::Mat1b& mask, bool recovered);

  TrackerOptions opt_;
  Seeder seeder_;
  Phase phase_ = Phase::init;
  int init_done_ = 0;
  std::string seed_why_;
  Seeds last_seeds_{};
  std::array<ColourModel, kFeatures> models_;
  ColourModel pooled_;
  std::array<Track, kFeatures> tracks_{};
  std::array<std::array<int, kFeatures>, kFeatures> since_apart_{};  // per pair a < b: frames since apart
  cv::Size size_{0, 0};
  cv::Mat3b hsv_;
  cv::Mat1b prob_, region_, blobs_, cloth_;
  cv::Mat1f dist_;
  cv::Mat1i labels_, stats_;
  cv::Mat1d centroids_;
  std::uint64_t losses_ = 0, reacquired_ = 0, swaps_ = 0;
  std::uint64_t join_tick_ = 0;  // frames with a feature waiting to join (join_siblings())
};

}  // namespace vc::track
