// The take: fitted poses -> hw/body's standard skeleton (rest T-pose with the fitted lengths, one
// pose per frame) -> BVH and joints.csv. The rules are in take.hpp.
#include "voxcap/export/take.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <stdexcept>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "voxcap/body/joints.hpp"

namespace vc::take {
namespace {

using body::Joint;
using glm::dmat3;
using glm::dvec3;
using pipeline::PoseJoint;

// Standard proportions of the joints the model does not fit (hw/body's StandardSegments defaults).
constexpr double kHeadTopShare = 0.115 / 0.165;   // head -> top, of neck -> head
constexpr double kHandShare = 0.19 / 0.26;        // wrist -> fingertips, of the forearm
constexpr double kToeForwardShare = 0.14 / 0.43;  // ankle -> ball of the foot, forwards, of the shank
constexpr double kToeDropShare = 0.058 / 0.43;    // ... and downwards

dvec3 at(const pipeline::Pose& p, PoseJoint j) {
  const auto& v = p.p_world[static_cast<size_t>(j)];
  return {v[0], v[1], v[2]};
}

// The frame whose z is along `up` and whose x is `lat` made orthogonal to it (columns x, y, z).
dmat3 frame(const dvec3& up, const dvec3& lat) {
  const double nu = glm::length(up);
  const dvec3 z = nu > 1e-12 ? up / nu : dvec3(0, 0, 1);
  dvec3 x = lat - glm::dot(lat, z) * z;
  if (glm::length(x) < 1e-9) {  // no lateral direction: any perpendicular one
    x = glm::cross(z, dvec3(0, 1, 0));
    if (glm::length(x) < 1e-6) x = glm::cross(z, dvec3(1, 0, 0));
  }
  x = glm::normalize(x);
  return dmat3(x, glm::cross(z, x), z);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

dvec3 median3(const std::vector<dvec3>& v) {
  std::array<std::vector<double>, 3> c;
  for (const dvec3& p : v)
    for (int a = 0; a < 3; ++a) c[static_cast<size_t>(a)].push_back(p[a]);
  return {median(c[0]), median(c[1]), median(c[2])};
}

size_t ix(Joint j) {
  return static_cast<size_t>(j);
}

// A limb of three joints (shoulder, elbow, wrist or hip, knee, ankle) and its hinge axis at rest in the
// upper segment's frame: the axis about which the lower segment bends forwards (arm) or backwards
// (leg) from the T-pose.
struct Limb {
  PoseJoint a, b, c;  // fitted joints
  Joint ja, jb, jc;   // skeleton joints
  dvec3 hinge_rest;
};
constexpr std::array<Limb, 4> kLimbs = {{
    {PoseJoint::l_shoulder,
     PoseJoint::l_elbow,
     PoseJoint::l_wrist,
     Joint::l_shoulder,
     Joint::l_elbow,
     Joint::l_wrist,
     {0, 0, -1}},
    {PoseJoint::r_shoulder,
     PoseJoint::r_elbow,
     PoseJoint::r_wrist,
     Joint::r_shoulder,
     Joint::r_elbow,
     Joint::r_wrist,
     {0, 0, 1}},
    {PoseJoint::l_hip,
     PoseJoint::l_knee,
     PoseJoint::l_ankle,
     Joint::l_hip,
     Joint::l_knee,
     Joint::l_ankle,
     {1, 0, 0}},
    {PoseJoint::r_hip,
     PoseJoint::r_knee,
     PoseJoint::r_ankle,
     Joint::r_hip,
     Joint::r_knee,
     Joint::r_ankle,
     {1, 0, 0}},
}};

bool finite_pose(const pipeline::Pose& p) {
  for (const auto& q : p.p_world)
    for (double v : q)
      if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace

namespace {

constexpr double kSpineAboveHipsM = 0.01;  // the Spine pivot, just above the hips (see take.hpp)
constexpr double kPelvisDropMinM = 0.01;   // hips centre this far above the hip line: the pelvis has a frame

// The pelvis frame of a pose: its z from the hip joints' midpoint up to the hips centre when the model's
// pelvis has a drop (a triangle), else along hips -> neck; its x along the hip line.
dmat3 pelvis_frame(const pipeline::Pose& p, bool triangle) {
  const dvec3 hips = at(p, PoseJoint::hips), l = at(p, PoseJoint::l_hip), r = at(p, PoseJoint::r_hip);
  const dvec3 up = triangle ? hips - 0.5 * (l + r) : at(p, PoseJoint::neck) - hips;
  return frame(up, l - r);
}
dmat3 pelvis_frame_rest(const body::Skeleton& sk, bool triangle) {
  const dvec3 l = sk.joints[ix(Joint::l_hip)].offset, r = sk.joints[ix(Joint::r_hip)].offset;
  const dvec3 up = triangle ? -0.5 * (l + r) : dvec3(0, 0, 1);
  return frame(up, l - r);
}

bool pelvis_is_triangle(const std::vector<const pipeline::Pose*>& poses) {
  std::vector<double> drop;
  for (const pipeline::Pose* p : poses) {
    const dvec3 mid = 0.5 * (at(*p, PoseJoint::l_hip) + at(*p, PoseJoint::r_hip));
    drop.push_back(glm::length(at(*p, PoseJoint::hips) - mid));
  }
  return median(drop) >= kPelvisDropMinM;
}

}  // namespace

body::Skeleton rest_skeleton(const std::vector<const pipeline::Pose*>& poses, bool* pelvis_triangle) {
  const bool tri = pelvis_is_triangle(poses);
  if (pelvis_triangle) *pelvis_triangle = tri;
  body::Skeleton sk = body::standard_skeleton(body::StandardSegments{});  // names, hierarchy, end sites
  auto set = [&](Joint j, const dvec3& o) { sk.joints[ix(j)].offset = o; };
  // Pass 1: the pelvis (hip joints in its frame).
  std::vector<dvec3> l_hip, r_hip;
  for (const pipeline::Pose* pp : poses) {
    const dmat3 Fp = glm::transpose(pelvis_frame(*pp, tri));
    l_hip.push_back(Fp * (at(*pp, PoseJoint::l_hip) - at(*pp, PoseJoint::hips)));
    r_hip.push_back(Fp * (at(*pp, PoseJoint::r_hip) - at(*pp, PoseJoint::hips)));
  }
  set(Joint::hips, {0, 0, 0});
  set(Joint::l_hip, median3(l_hip));
  set(Joint::r_hip, median3(r_hip));
  const dmat3 Fp_rest = pelvis_frame_rest(sk, tri);
  set(Joint::spine, Fp_rest * dvec3(0, 0, kSpineAboveHipsM));
  // Pass 2: the chest (neck and shoulders from the Spine pivot), the head and the limbs.
  std::vector<double> spine_neck, neck_head;
  std::vector<dvec3> l_sh, r_sh;
  std::array<std::vector<double>, 4> upper, lower;
  for (const pipeline::Pose* pp : poses) {
    const pipeline::Pose& p = *pp;
    const dmat3 W_hips = pelvis_frame(p, tri) * glm::transpose(Fp_rest);
    const dvec3 spine = at(p, PoseJoint::hips) + W_hips * sk.joints[ix(Joint::spine)].offset;
    const dvec3 neck = at(p, PoseJoint::neck);
    const dmat3 Fc =
        glm::transpose(frame(neck - spine, at(p, PoseJoint::l_shoulder) - at(p, PoseJoint::r_shoulder)));
    spine_neck.push_back(glm::length(neck - spine));
    neck_head.push_back(glm::length(at(p, PoseJoint::head) - neck));
    l_sh.push_back(Fc * (at(p, PoseJoint::l_shoulder) - spine));
    r_sh.push_back(Fc * (at(p, PoseJoint::r_shoulder) - spine));
    for (size_t k = 0; k < kLimbs.size(); ++k) {
      upper[k].push_back(glm::length(at(p, kLimbs[k].b) - at(p, kLimbs[k].a)));
      lower[k].push_back(glm::length(at(p, kLimbs[k].c) - at(p, kLimbs[k].b)));
    }
  }
  const double nh = median(neck_head);
  set(Joint::neck, {0, 0, median(spine_neck)});
  set(Joint::head, {0, 0, nh});
  set(Joint::head_top, {0, 0, kHeadTopShare * nh});
  set(Joint::l_shoulder, median3(l_sh));
  set(Joint::r_shoulder, median3(r_sh));
  for (size_t k = 0; k < kLimbs.size(); ++k) {
    const double u = median(upper[k]), f = median(lower[k]);
    const double sg = (k % 2 == 0) ? 1.0 : -1.0;  // left +x, right -x
    const Limb& l = kLimbs[k];
    if (k < 2) {  // arms along +-x
      set(l.jb, {sg * u, 0, 0});
      set(l.jc, {sg * f, 0, 0});
      set(k == 0 ? Joint::l_hand_tip : Joint::r_hand_tip, {sg * kHandShare * f, 0, 0});
    } else {  // legs straight down
      set(l.jb, {0, 0, -u});
      set(l.jc, {0, 0, -f});
      set(k == 2 ? Joint::l_toe : Joint::r_toe, {0, -kToeForwardShare * f, -kToeDropShare * f});
    }
  }
  return sk;
}

body::Pose skeleton_pose(const body::Skeleton& sk, bool pelvis_triangle, const pipeline::Pose& p) {
  auto off = [&](Joint j) { return sk.joints[ix(j)].offset; };
  std::array<dmat3, body::kJointCount> W;
  W.fill(dmat3(1.0));
  const dvec3 hips = at(p, PoseJoint::hips), neck = at(p, PoseJoint::neck);
  // Pelvis: its own frame against the rest one. Chest: the Spine pivot's bone at the neck, the
  // shoulder line across, against the same at rest.
  W[ix(Joint::hips)] =
      pelvis_frame(p, pelvis_triangle) * glm::transpose(pelvis_frame_rest(sk, pelvis_triangle));
  const dvec3 spine = hips + W[ix(Joint::hips)] * off(Joint::spine);
  W[ix(Joint::spine)] =
      frame(neck - spine, at(p, PoseJoint::l_shoulder) - at(p, PoseJoint::r_shoulder)) *
      glm::transpose(frame(off(Joint::neck), off(Joint::l_shoulder) - off(Joint::r_shoulder)));
  // Neck: its bone at the head; the head turns with it.
  W[ix(Joint::neck)] =
      body::rot_between(W[ix(Joint::spine)] * off(Joint::head), at(p, PoseJoint::head) - neck) *
      W[ix(Joint::spine)];
  W[ix(Joint::head)] = W[ix(Joint::neck)];
  for (const Limb& l : kLimbs) {
    const dmat3& parent = W[ix(static_cast<Joint>(body::joint_parent(static_cast<int>(l.ja))))];
    const dvec3 u = at(p, l.b) - at(p, l.a), f = at(p, l.c) - at(p, l.b);
    const dvec3 n = glm::cross(u, f);
    const double nu = glm::length(u), nf = glm::length(f);
    dmat3 Wa = parent;
    if (nu > 1e-9 && nf > 1e-9 && glm::length(n) > 1e-3 * nu * nf) {
      // Bent: the upper bone on u and the hinge on u x f, so the lower joint only bends about its hinge.
      const dvec3 ur = glm::normalize(off(l.jb)), hr = l.hinge_rest;
      const dvec3 uo = u / nu, no = glm::normalize(n);
      Wa = dmat3(uo, no, glm::cross(uo, no)) * glm::transpose(dmat3(ur, hr, glm::cross(ur, hr)));
    } else if (nu > 1e-9) {
      Wa = body::rot_between(parent * off(l.jb), u) * parent;  // straight: the smallest turn
    }
    W[ix(l.ja)] = Wa;
    W[ix(l.jb)] = nf > 1e-9 ? body::rot_between(Wa * off(l.jc), f) * Wa : Wa;
    W[ix(l.jc)] = W[ix(l.jb)];  // the hand (foot) follows the forearm (shank)
  }
  W[ix(Joint::l_toe)] = W[ix(Joint::l_ankle)];
  W[ix(Joint::r_toe)] = W[ix(Joint::r_ankle)];

  body::Pose out;
  out.root_position = hips;
  out.local.resize(sk.joints.size(), dmat3(1.0));
  for (size_t j = 0; j < sk.joints.size(); ++j) {
    if (sk.joints[j].end_site) continue;
    const int parent = sk.joints[j].parent;
    out.local[j] = parent < 0 ? W[j] : glm::transpose(W[static_cast<size_t>(parent)]) * W[j];
  }
  return out;
}

Take make_take(const std::vector<PosedFrame>& frames) {
  std::map<int64_t, const pipeline::Pose*> by_frame;
  for (const PosedFrame& f : frames) {
    if (f.pose.valid() && !finite_pose(f.pose))
      throw std::invalid_argument(
          fmt::format("frame {}: the pose has a coordinate that is not finite", f.frame));
    by_frame[f.frame] = &f.pose;
  }
  std::map<uint32_t, std::vector<const pipeline::Pose*>> versions;
  int64_t first = 0, last = -1;
  bool any = false;
  for (const auto& [n, p] : by_frame) {
    if (!p->valid()) continue;
    versions[p->body_version].push_back(p);
    if (!any) first = n;
    last = n;
    any = true;
  }
  if (!any) throw std::invalid_argument("no frame has a pose (was the fitting stage running?)");
  Take t;
  size_t most = 0;
  for (const auto& [v, ps] : versions)
    if (ps.size() > most) {
      most = ps.size();
      t.body_version = v;
    }
  t.skeleton = rest_skeleton(versions[t.body_version], &t.pelvis_triangle);
  t.first_frame = first;
  for (const auto& [n, p] : by_frame) {
    if (n < first) ++t.before_first;
    if (n > last) ++t.after_last;
  }
  const auto count = static_cast<size_t>(last - first + 1);
  t.poses.reserve(count);
  t.states.reserve(count);
  t.body_versions.reserve(count);
  for (int64_t n = first; n <= last; ++n) {
    const auto it = by_frame.find(n);
    if (it != by_frame.end() && it->second->valid()) {
      const pipeline::Pose& p = *it->second;
      t.poses.push_back(skeleton_pose(t.skeleton, t.pelvis_triangle, p));
      t.states.push_back(p.state);
      t.body_versions.push_back(p.body_version);
      if (p.body_version != t.body_version) ++t.other_version_frames;
    } else {
      t.poses.push_back(t.poses.back());  // the first take frame has a pose: back() exists
      t.states.push_back(pipeline::PoseState::None);
      t.body_versions.push_back(t.body_versions.back());
      ++t.held;
      if (it == by_frame.end()) ++t.missing;
    }
  }
  return t;
}

bool WriteOptions::valid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(frame_time_s > 0) || !std::isfinite(frame_time_s) || frame_time_s > 10)
    return fail("frame time: must be in (0, 10] s");
  if (units_per_metre != 1.0 && units_per_metre != 100.0)
    return fail("units: metres (1) or centimetres (100)");
  return true;
}

void write_bvh(const std::filesystem::path& path, const Take& take, const WriteOptions& options) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("BVH export: " + why);
  body::BvhWriteOptions o = body::BvhWriteOptions::blender();
  o.units_per_metre = options.units_per_metre;
  body::write_bvh(path.string(), take.skeleton, take.poses, options.frame_time_s, o);
}

std::vector<glm::dvec3> take_positions(const Take& take, size_t k) {
  std::vector<glm::dvec3> p;
  body::forward_kinematics(take.skeleton, take.poses.at(k), &p);
  return p;
}

uint64_t write_joints_csv(const std::filesystem::path& path, const Take& take) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(fmt::format("{}: cannot open for writing", path.string()));
  out << "frame,joint,x,y,z,state,fitted\n";
  std::array<bool, body::kJointCount> fitted{};
  for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
    const int b = body::joint_from_name(pipeline::pose_joint_name(j));
    if (b >= 0) fitted[static_cast<size_t>(b)] = true;
  }
  uint64_t rows = 0;
  std::vector<glm::dvec3> p;
  char line[256];
  for (size_t k = 0; k < take.poses.size(); ++k) {
    if (take.states[k] == pipeline::PoseState::None) continue;  // held in the BVH, not a measurement
    body::forward_kinematics(take.skeleton, take.poses[k], &p);
    const int64_t frame = take.first_frame + static_cast<int64_t>(k);
    for (int j = 0; j < body::kJointCount; ++j) {
      if (body::joint_is_end(j)) continue;
      const glm::dvec3& q = p[static_cast<size_t>(j)];
      const int n =
          std::snprintf(line, sizeof line, "%lld,%s,%.6f,%.6f,%.6f,%s,%d\n", static_cast<long long>(frame),
                        std::string(body::joint_bvh_name(j)).c_str(), q.x, q.y, q.z,
                        pipeline::pose_state_name(take.states[k]), fitted[static_cast<size_t>(j)] ? 1 : 0);
      out.write(line, n);
      ++rows;
    }
  }
  out.flush();
  if (!out) throw std::runtime_error(fmt::format("{}: write error", path.string()));
  return rows;
}

}  // namespace vc::take
