// A fit that has clearly failed, seen from the hull (host/fit/README.md, "How a failed fit is
// detected"): checks the fitter runs on every fitted frame besides its own (torso voxels, support,
// head, heading), each one a geometric fact that holds for any pose of a body inside its visual hull,
// so it cannot fire on a good fit.
#pragma once

#include <array>

#include "voxcap/fit/hull.hpp"
#include "voxcap/fit/model.hpp"
#include "voxcap/pipeline/frame.hpp"

namespace vc::fit {

// The fitted trunk against the hull: points along the lower half of the spine down to the pelvis
// centre, and the two hip joints. A visual hull contains the body, so on a good fit they lie in occupied
// voxels but for the hull's rare holes; a torso left lying or turned away from where the body is (hips 0.3 m
// and more from the hull's column) leaves most of them in empty space.
struct TrunkInHull {
  int counted = 0;   // points inside the grid (a point outside the volume gives no verdict)
  int occupied = 0;  // ... of them in occupied voxels
};

// Points along the trunk: kTrunkAxisPoints from halfway down the spine to the pelvis centre, and the
// two hip joints.
inline constexpr int kTrunkAxisPoints = 6;

// `joints`: the fitted pose's 15 joints (pipeline::PoseJoint order). No allocation.
TrunkInHull trunk_in_hull(const HullBits& hull, const std::array<Vec3, pipeline::kPoseJointCount>& joints);

// The verdict: fewer than half the counted points occupied, with at least half of them counted
// (a trunk leaving the volume is not a failed fit).
bool trunk_off_hull(const TrunkInHull& t);

// A fit whose trunk is off the hull is wrong whatever its other checks say; it is re-acquired when
// this many of the last kTrunkOffHullWindow frames had it so, not after reinit_after_frames: one bad
// hull is ridden over, and a frame whose fat hull still holds a wrong trunk (carved without one
// node: degraded frames come between good ones under load) does not hide the others.
inline constexpr int kTrunkOffHullFrames = 3;
inline constexpr int kTrunkOffHullWindow = 5;

}  // namespace vc::fit
