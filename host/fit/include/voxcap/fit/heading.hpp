// The body's own heading cue, independent of the features' names (host/fit/README.md, "The heading
// from the body"): a foot on the hull reaches forward of its ankle (heel ~5 cm behind, toes ~20 cm in
// front), whichever foot the triangulation calls left or right. The fitter uses it to sign the torso's
// PCA, to judge a heading, and to re-initialize one.
#pragma once

#include <array>

#include "voxcap/fit/hull.hpp"
#include "voxcap/fit/init.hpp"

namespace vc::fit {

struct FeetCue {
  Vec3 forward{0.0};   // level unit vector where the feet point (zero when !valid)
  double reach_m = 0;  // mean level offset of the feet's voxels ahead of their ankles
  int feet = 0;        // feet that contributed (0..2)
  bool valid = false;  // both offsets were long enough and agreed (see feet_forward)
  // The performer's right it implies (level): forward x up.
  Vec3 right() const { return {forward.y, -forward.x, 0}; }
};

// The feet's forward on the hull. For each foot feature (ankle), the occupied voxels below it (2 to
// 16 cm down) within 24 cm level of it, nearer it than the other ankle: their mean level offset from
// the ankle points along the foot. The cue is valid when both feet give one, each 3 to 14 cm long (a
// lifted foot pointing down gives a short one; a longer one is a feature that is not at its ankle),
// within 60 degrees of each other; forward is their sum's direction. An ankle more than 35 cm above the
// floor (z = 0) is in the air (a kick, a jump) and gives none: its foot points where the leg swings.
FeetCue feet_forward(const HullBits& hull, const FeatureSet& f, const std::array<bool, 5>& ok);

// Whether the torso (R's columns: right, forward, up) faces away from where the valid cue's feet point:
// its level forward more than 120 degrees from theirs. False without a verdict (cue invalid, torso
// lying flat).
bool faces_away(const Mat3& R, const FeetCue& cue);

// The sign vote: the torso's forward (level) against the feet's, frame after frame. Disagreeing
// clearly (more than 120 degrees apart) for kFlipFrames valid frames in a row says the torso's sign
// is wrong (its shoulder line right, its sign continuity carried a swap): flip() turns it round.
// Frames without a verdict keep the count for at most kMaxGapFrames in a row (cmu/02_06: seven votes
// of a kick and an eighth 160 frames later turned a correct torso round).
class HeadingVote {
 public:
  static constexpr int kFlipFrames = 8;
  static constexpr int kMaxGapFrames = 30;
  // Returns true when the torso (R's columns: right, forward, up) should be turned round by 180
  // degrees about the vertical. Invalid cues leave the count as it is (the feet are often in the air
  // or merged for a few frames), for kMaxGapFrames calls in a row; after that it starts again.
  bool update(const Mat3& R, const FeetCue& cue);
  void reset() {
    against_ = 0;
    gap_ = 0;
  }
  int against() const { return against_; }

 private:
  int against_ = 0;
  int gap_ = 0;  // update() calls without a verdict since the last one
};

// R turned round about its spine: right and forward negated.
Mat3 turned_round(const Mat3& R);

}  // namespace vc::fit
