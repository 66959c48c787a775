// The per-frame skeleton fitter (the method's sections 8.2-8.4, online), and the pipeline's "fit"
// stage. host/fit/README.md explains the steps, what is done beyond the method, the confidence and
// how a failed fit is detected.
//
// Per frame: decode the merged hull once into a reused bitset; torso segmentation (the hull voxels
// inside the torso cylinder placed as at t-1, moved with the head) and its PCA (continuity gives the
// components' order and signs); layer 1 from the triangulated head, hands and feet (a missing or
// implausible one predicted from its history in the limb root's frame, then fitted to the hull);
// layer 2 by the method's search (eq. 3). No allocation per frame after the first.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "voxcap/config/rig_config.hpp"
#include "voxcap/fit/hull.hpp"
#include "voxcap/fit/init.hpp"
#include "voxcap/fit/model.hpp"
#include "voxcap/pipeline/frame.hpp"
#include "voxcap/pipeline/stage.hpp"

namespace vc::fit {

// Time spent in each step of the last fit() (nanoseconds, CLOCK_MONOTONIC), as the method's Table 1
// splits it (decoding the hull is ours: the method had the voxels at hand).
struct StageTimes {
  uint64_t decode_ns = 0;
  uint64_t segment_ns = 0;  // torso segmentation: voxels in the cylinder, their moments
  uint64_t pca_ns = 0;      // covariance, eigenvectors, components' order and signs
  uint64_t layer1_ns = 0;
  std::array<uint64_t, kLimbCount> layer2_ns{};    // per limb
  std::array<bool, kLimbCount> layer2_searched{};  // the limb was bent: searched (else rho kept)
  uint64_t total_ns = 0;
};

class Fitter {
 public:
  // Grid, calibration and rig.fitting; reads rig.fitting.body when set (throws std::runtime_error on
  // a bad body.toml, std::invalid_argument on bad options).
  explicit Fitter(const config::RigConfig& rig);
  Fitter(const rig::VoxelGrid& grid, const config::FittingOptions& options, double rate_hz = 60);
  ~Fitter();

  // One merged frame (frame.rle = merged hull, frame.features3d, frame.seq): the pose for it.
  // State None while the body model is not initialized yet (initialization frames) and on a frame
  // without a usable merged hull. A frame older than the last one fitted (frames can reach the fit out
  // of trigger order) gets its pose from the history as it stands and leaves that history unchanged.
  pipeline::Pose fit(const pipeline::Frame& frame);
  // Forget the body model and the history.
  void reset();

  bool initialized() const;
  const BodyModel& body() const;  // valid once initialized()
  const Layer1& layer1() const;
  const Layer2& layer2() const;
  const StageTimes& times() const;
  // Frames the fit has failed in a row (README: "Re-initialization").
  int failing_frames() const;
  // How often the fit swapped the assignment of a pair's features to its limbs (README: "A pair named
  // the wrong way round"): [0] the hands, [1] the feet, since construction.
  const std::array<uint64_t, 2>& pair_swaps() const;
  // Whether the pair's features are taken the other way round now ([0] hands, [1] feet).
  bool pair_swapped(int pair) const;
  // Frames fitted after a newer one (README: "Frames out of order"), since construction.
  uint64_t late_frames() const;
  // How often the feet on the hull turned the torso round (README: "The heading from the body").
  uint64_t heading_flips() const;
  // Frames where the hull changed an untrusted foot name (README: "The feet's names from the hull").
  uint64_t hull_named_feet() const;

  struct State;

 private:
  pipeline::Pose fit_next(const pipeline::Frame& frame);  // moves the history on to this frame
  std::unique_ptr<State> s_;
  uint64_t late_frames_ = 0;
};

// The "fit" chain stage (after "triangulate"): Frame::pose for every frame.
class FitStage : public pipeline::Stage {
 public:
  std::string name() const override { return "fit"; }
  void configure(const pipeline::StageContext& ctx) override;
  void process(pipeline::Frame& frame) override;
  const Fitter* fitter() const { return fitter_.get(); }

 private:
  std::unique_ptr<Fitter> fitter_;
  std::shared_ptr<pipeline::BodyHeading> heading_;  // the pipeline's: this stage publishes the torso right
};

// Publishes a fitted pose's torso right (torso_R_world's x column) to `heading`, for the triangulation
// of later frames to check the hands' and feet's left/right against (host/triangulate/README.md). Only
// poses fitted to their frame with every feature (Fitted): a re-initialized one took its heading from
// the features' names, which is what the check must not lean on, and on loaded live takes the heading
// flipped in stretches of Predicted frames (turn: 217.8 mm with them, 127.1 without).
void publish_heading(const pipeline::Pose& pose, uint64_t seq, pipeline::BodyHeading* heading);

}  // namespace vc::fit
