// A failed fit seen from the hull (failure.hpp; host/fit/README.md, "How a failed fit is detected").
//
// The fitter's own checks (torso voxels in the cylinder, the limbs' support, the head's distance from
// the neck, the heading against the feet) all look at what the fit was placed on. None of them sees a
// torso that the PCA has tilted away from the body: on a hull that fills the torso cylinder (a hull
// carved by few cameras is fat) the cylinder's own voxels return its own axes, so the spine can walk
// frame by frame until it lies flat, with the head, the cylinder's voxels and the limbs' support all
// looking fine. What such a fit cannot do is keep its trunk inside the hull: the hull holds the whole
// body, so the spine's axis and the hip joints of a good fit lie in occupied voxels.
#include "voxcap/fit/failure.hpp"

namespace vc::fit {

TrunkInHull trunk_in_hull(const HullBits& hull, const std::array<Vec3, pipeline::kPoseJointCount>& joints) {
  const Vec3& neck = joints[static_cast<size_t>(pipeline::PoseJoint::neck)];
  const Vec3& pelvis = joints[static_cast<size_t>(pipeline::PoseJoint::hips)];
  const rig::VoxelGrid& g = hull.grid();
  const Vec3 lo(g.min_m[0], g.min_m[1], g.min_m[2]);
  const Vec3 hi = lo + Vec3(g.nx, g.ny, g.nz) * g.voxel_m;
  TrunkInHull t;
  auto count = [&](const Vec3& p) {
    if (!(p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x < hi.x && p.y < hi.y && p.z < hi.z)) return;
    ++t.counted;
    t.occupied += hull.at(p) ? 1 : 0;
  };
  // The lower half of the spine, down to the pelvis centre: the upper half stays in the chest (or runs
  // along an arm) for any tilt about the neck, which is where the head holds the fit.
  for (int i = 0; i < kTrunkAxisPoints; ++i)
    count(neck + (0.5 + 0.5 * static_cast<double>(i) / (kTrunkAxisPoints - 1)) * (pelvis - neck));
  count(joints[static_cast<size_t>(pipeline::PoseJoint::l_hip)]);
  count(joints[static_cast<size_t>(pipeline::PoseJoint::r_hip)]);
  return t;
}

bool trunk_off_hull(const TrunkInHull& t) {
  constexpr int kPoints = kTrunkAxisPoints + 2;
  return 2 * t.counted >= kPoints && 2 * t.occupied < t.counted;
}

}  // namespace vc::fit
