// Built-in procedural motions on the standard skeleton. Each is a function of time built from a
// few bone directions (chest frame for arms, heading frame for legs) with a two-bone IK where the
// hands must reach a place (hands on hips, clapping, crossing); the feet are then planted: the
// lowest point of either foot is put on the floor, which gives the pelvis its natural bob.
// Limits: feet may slide a little (no foot-lock IK), joint limits are respected by construction
// only, not checked.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

#include "motion_internal.hpp"

namespace vc::sim {
namespace {

using vc::body::rot_x;
using vc::body::rot_y;
using vc::body::rot_z;

constexpr double kPi = M_PI;

double ease(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}
glm::dvec3 dir(double x, double y, double z) {
  return glm::normalize(glm::dvec3(x, y, z));
}
int J(Joint j) {
  return static_cast<int>(j);
}

// What a motion specifies at one instant. Directions: arms in the chest frame, legs in the
// heading frame (world turned by yaw); frames have x = performer's left, y = back, z = up.
struct Spec {
  double yaw = 0;          // heading, radians about +z (0: facing -y)
  glm::dvec2 xy{0, 0};     // where the root stands (x, y)
  double pelvis_lean = 0;  // forward lean of the pelvis (about its x axis)
  double spine_lean = 0, spine_twist = 0, spine_roll = 0;
  double neck_lean = 0, head_nod = 0, head_turn = 0, head_tilt = 0;
  struct Arm {
    glm::dvec3 upper, fore, hand;
    double hand_twist = 0;
  } arm[2];
  struct Leg {
    glm::dvec3 thigh{0, 0, -1}, shank{0, 0, -1};
    double foot_pitch = 0;  // positive: toes down
  } leg[2];
};

double side_sign(int side) {
  return side == 0 ? 1.0 : -1.0;
}

Spec init_spec() {
  Spec s;
  for (int side = 0; side < 2; ++side) {
    const glm::dvec3 out(side_sign(side), 0, 0);
    s.arm[side] = {out, out, out, 0};
  }
  return s;
}

void arm_hang(Spec& s, int side, double abduct = 0.14) {
  const double sg = side_sign(side);
  s.arm[side].upper = dir(sg * abduct, 0.02, -1);
  s.arm[side].fore = dir(sg * abduct * 0.6, -0.22, -1);
  s.arm[side].hand = s.arm[side].fore;
  s.arm[side].hand_twist = 0;
}

// Two-bone IK in the chest frame: shoulder S, wrist target T, lengths, elbow pole direction.
void reach(Spec& s, int side, const glm::dvec3& S, const glm::dvec3& T, double L1, double L2,
           const glm::dvec3& pole, const glm::dvec3& hand_dir, double hand_twist) {
  glm::dvec3 st = T - S;
  double d = glm::length(st);
  const glm::dvec3 axis = d > 1e-9 ? st / d : glm::dvec3(side_sign(side), 0, 0);
  d = std::clamp(d, std::abs(L1 - L2) + 1e-4, L1 + L2 - 1e-4);
  const double along = (d * d + L1 * L1 - L2 * L2) / (2 * d);
  const double h = std::sqrt(std::max(0.0, L1 * L1 - along * along));
  glm::dvec3 perp = pole - axis * glm::dot(pole, axis);
  perp = glm::length(perp) > 1e-9 ? glm::normalize(perp) : glm::dvec3(0, 0, -1);
  const glm::dvec3 E = S + axis * along + perp * h;
  const glm::dvec3 W = S + axis * d;
  s.arm[side].upper = glm::normalize(E - S);
  s.arm[side].fore = glm::normalize(W - E);
  s.arm[side].hand = glm::normalize(hand_dir);
  s.arm[side].hand_twist = hand_twist;
}

struct Ctx {
  const BodyDescription& body;
  const Skeleton& sk;
  std::vector<int> aim_child;
  detail::MotionData* m;
  glm::dvec3 shoulder_chest[2];  // shoulder joints in the chest frame
};

Pose build(const Ctx& c, const Spec& s, bool anchor_feet) {
  detail::Poser poser(c.sk, c.aim_child);
  const glm::dmat3 heading = rot_z(s.yaw);
  poser.root({0, 0, 0}, heading * rot_x(s.pelvis_lean));
  poser.local(J(Joint::spine), rot_z(s.spine_twist) * rot_x(s.spine_lean) * rot_y(s.spine_roll));
  poser.local(J(Joint::neck), rot_x(s.neck_lean));
  poser.local(J(Joint::head), rot_z(s.head_turn) * rot_x(s.head_nod) * rot_y(s.head_tilt));
  const glm::dmat3 chest = poser.world(J(Joint::spine));
  const Joint arms[2][3] = {{Joint::l_shoulder, Joint::l_elbow, Joint::l_wrist},
                            {Joint::r_shoulder, Joint::r_elbow, Joint::r_wrist}};
  for (int side = 0; side < 2; ++side) {
    poser.aim(J(arms[side][0]), chest * s.arm[side].upper);
    poser.aim(J(arms[side][1]), chest * s.arm[side].fore);
    poser.aim(J(arms[side][2]), chest * s.arm[side].hand, s.arm[side].hand_twist);
  }
  const Joint legs[2][3] = {{Joint::l_hip, Joint::l_knee, Joint::l_ankle},
                            {Joint::r_hip, Joint::r_knee, Joint::r_ankle}};
  const BodyDescription& b = c.body;
  for (int side = 0; side < 2; ++side) {
    poser.aim(J(legs[side][0]), heading * s.leg[side].thigh);
    poser.aim(J(legs[side][1]), heading * s.leg[side].shank);
    const glm::dvec3 toe_rest(0, -b.foot_forward_m, -(b.ankle_height_m - b.toes_half_height_m));
    poser.aim(J(legs[side][2]), heading * (rot_x(s.leg[side].foot_pitch) * toe_rest));
  }
  Pose pose = poser.pose();
  // Plant: lowest foot point on the floor; x, y at the root or the ankles' midpoint.
  const BodyPose bp = detail::body_pose_from(*c.m, pose);
  const double sole = detail::lowest_sole_z(bp, b, c.m->feet);
  glm::dvec3 shift(s.xy[0], s.xy[1], -sole);
  if (anchor_feet) {
    const cv::Vec3d mid = 0.5 * (bp.p(Joint::l_ankle) + bp.p(Joint::r_ankle));
    shift[0] -= mid[0];
    shift[1] -= mid[1];
  }
  pose.root_position = shift;
  return pose;
}

// --- the motions -------------------------------------------------------------------------------

Pose tpose(const Ctx& c, double) {
  return build(c, init_spec(), false);
}

// Gait (walking) for one leg pair at phase phi with amplitude k in [0, 1].
void gait(Spec& s, double phi, double k) {
  for (int side = 0; side < 2; ++side) {
    const double p = phi + (side == 0 ? 0 : kPi);
    const double th = k * 0.38 * std::sin(p);
    const double kn = 0.08 + k * 0.95 * std::pow(std::max(0.0, std::cos(p + 1.0)), 2);
    s.leg[side].thigh = dir(side_sign(side) * 0.03, -std::sin(th), -std::cos(th));
    s.leg[side].shank = dir(0, -std::sin(th - kn), -std::cos(th - kn));
    s.leg[side].foot_pitch = k * (0.3 * std::pow(std::max(0.0, -std::sin(p - 0.3)), 4) -
                                  0.15 * std::pow(std::max(0.0, std::cos(p + 1.0)), 2));
    // The arm on this side swings with the other leg.
    const double a = -k * 0.32 * std::sin(p);
    const double sg = side_sign(side);
    s.arm[side].upper = dir(sg * 0.14, -std::sin(a), -std::cos(a));
    s.arm[side].fore = dir(sg * 0.08, -std::sin(a + 0.35), -std::cos(a + 0.35));
    s.arm[side].hand = s.arm[side].fore;
  }
  s.spine_twist = -0.06 * k * std::sin(phi);
}

Pose walk_in_place(const Ctx& c, double tau) {
  Spec s = init_spec();
  const double phi = 2 * kPi * tau / 1.1;
  for (int side = 0; side < 2; ++side) {
    const double p = phi + (side == 0 ? 0 : kPi);
    const double lift = std::pow(std::max(0.0, std::sin(p)), 1.5);
    const double th = 0.55 * lift, kn = 1.25 * th + 0.05;
    s.leg[side].thigh = dir(side_sign(side) * 0.03, -std::sin(th), -std::cos(th));
    s.leg[side].shank = dir(0, -std::sin(th - kn), -std::cos(th - kn));
    s.leg[side].foot_pitch = 0.35 * lift;
    const double a = 0.3 * std::sin(p);  // the arm swings forward with the other leg's lift
    const double sg = side_sign(side);
    s.arm[side].upper = dir(sg * 0.14, std::sin(a), -std::cos(a));
    s.arm[side].fore = dir(sg * 0.08, std::sin(a) - 0.35, -std::cos(a + 0.35));
    s.arm[side].hand = s.arm[side].fore;
  }
  s.spine_twist = 0.05 * std::sin(phi);
  return build(c, s, false);
}

// Back and forth across the volume along y with turns in place:
// (0,0) -> (0,-0.8) facing -y, turn, -> (0,0.8) facing +y, turn, -> (0,0). 6.4 s per cycle.
Pose walk(const Ctx& c, double tau) {
  constexpr double kCycle = 6.4;
  const double n = std::floor(tau / kCycle);
  const double u = tau - n * kCycle;
  double yaw = 2 * kPi * n, y = 0, walking = 0;
  auto ramp = [](double t, double len) { return ease(std::min(t, len - t) / 0.35); };
  if (u < 1.0) {
    y = -0.8 * (u / 1.0);
    walking = ease((1.0 - u) / 0.35);
  } else if (u < 2.2) {
    y = -0.8;
    yaw += kPi * ease((u - 1.0) / 1.2);
  } else if (u < 4.2) {
    y = -0.8 + 1.6 * (u - 2.2) / 2.0;
    yaw += kPi;
    walking = ramp(u - 2.2, 2.0);
  } else if (u < 5.4) {
    y = 0.8;
    yaw += kPi + kPi * ease((u - 4.2) / 1.2);
  } else {
    y = 0.8 - 0.8 * (u - 5.4) / 1.0;
    yaw += 2 * kPi;
    walking = ease((u - 5.4) / 0.35);
  }
  Spec s = init_spec();
  s.yaw = yaw;
  s.xy = {0, y};
  gait(s, 2 * kPi * tau / 1.1, 0.45 + 0.55 * walking);
  return build(c, s, false);
}

Pose squat(const Ctx& c, double tau) {
  const double u = std::fmod(tau, 3.2);
  double d = 0;
  if (u < 1.2) {
    d = ease(u / 1.2);
  } else if (u < 1.6) {
    d = 1;
  } else if (u < 2.8) {
    d = 1 - ease((u - 1.6) / 1.2);
  }
  Spec s = init_spec();
  const double alpha = 1.45 * d, gamma = 0.62 * d;
  for (int side = 0; side < 2; ++side) {
    const double sg = side_sign(side);
    s.leg[side].thigh = dir(sg * (0.03 + 0.18 * d), -std::sin(alpha), -std::cos(alpha));
    s.leg[side].shank = dir(sg * 0.04 * d, std::sin(gamma), -std::cos(gamma));
    s.arm[side].upper = dir(sg * 0.12, -1, 0.05 + 0.15 * d);
    s.arm[side].fore = s.arm[side].upper;
    s.arm[side].hand = s.arm[side].upper;
  }
  s.pelvis_lean = 0.55 * d;
  s.spine_lean = 0.1 * d;
  s.neck_lean = -0.35 * d;
  return build(c, s, true);
}

Pose turn(const Ctx& c, double tau) {
  constexpr double kCycle = 6.0;
  const double n = std::floor(tau / kCycle);
  const double u = tau - n * kCycle;
  const double turning = u > 0.7 && u < 5.3 ? ease(std::min(u - 0.7, 5.3 - u) / 0.3) : 0;
  Spec s = init_spec();
  s.yaw = 2 * kPi * (n + ease((u - 1.0) / 4.0));
  for (int side = 0; side < 2; ++side) {
    const double sg = side_sign(side);
    const double lift = turning * std::pow(std::max(0.0, std::sin(2 * kPi * 0.8 * tau + side * kPi)), 2);
    const double th = 0.3 * lift;
    s.leg[side].thigh = dir(sg * 0.03, -std::sin(th), -std::cos(th));
    s.leg[side].shank = dir(0, -std::sin(-th), -std::cos(-th));
    s.leg[side].foot_pitch = 0.3 * lift;
    s.arm[side].upper = dir(sg * 0.75, -0.1, -0.66);
    s.arm[side].fore = dir(sg * 0.6, -0.35, -0.7);
    s.arm[side].hand = s.arm[side].fore;
  }
  s.head_turn = 0.25 * std::sin(2 * kPi * u / kCycle) * turning;
  return build(c, s, false);
}

// Hands on hips, arms hanging against the torso, clapping in front of the chest: 3 s each.
Pose arms_close(const Ctx& c, double tau) {
  const BodyDescription& b = c.body;
  auto phase_spec = [&](int phase, double t) {
    Spec s = init_spec();
    for (int side = 0; side < 2; ++side) {
      const double sg = side_sign(side);
      const glm::dvec3 S = c.shoulder_chest[side];
      if (phase == 0) {  // hands on hips (akimbo), elbows out and back
        const glm::dvec3 T(sg * (b.pelvis_radii_m[0] + 0.035), 0.015, -b.hips_to_spine_m + 0.10);
        reach(s, side, S, T, b.upper_arm_m, b.forearm_m, {sg * 1.0, 0.45, 0}, {-sg * 0.45, -0.35, -1}, 0);
      } else if (phase == 1) {  // hanging, pressed against the torso
        s.arm[side].upper = dir(sg * 0.03, 0.03, -1);
        s.arm[side].fore = dir(-sg * 0.02, -0.12, -1);
        s.arm[side].hand = s.arm[side].fore;
      } else {  // clapping at 2 Hz in front of the chest, palms facing
        const double open = 0.5 - 0.5 * std::cos(2 * kPi * 2.0 * t);
        const double gap = b.hand_half_thickness_m + 0.004 + 0.11 * open;
        const glm::dvec3 T(sg * gap, -0.34, b.spine_to_neck_m - 0.20);
        reach(s, side, S, T, b.upper_arm_m, b.forearm_m, {sg * 1.0, 0.2, -1.0}, {-sg * 0.05, -0.75, 0.65},
              sg * kPi / 2);
      }
    }
    return s;
  };
  constexpr double kPhase = 3.0, kBlend = 0.6;
  const double u = std::fmod(tau, 3 * kPhase);
  const int phase = static_cast<int>(u / kPhase);
  const double in_phase = u - phase * kPhase;
  const Pose here = build(c, phase_spec(phase, in_phase), false);
  if (in_phase < kPhase - kBlend) return here;
  const Pose next = build(c, phase_spec((phase + 1) % 3, 0), false);
  return blend(here, next, ease((in_phase - (kPhase - kBlend)) / kBlend));
}

// Hands crossing in front of the body and opening again, 3 s per cycle; the left arm passes in
// front of the right.
Pose cross(const Ctx& c, double tau) {
  const BodyDescription& b = c.body;
  const double x = 0.5 - 0.5 * std::cos(2 * kPi * tau / 3.0);
  Spec s = init_spec();
  for (int side = 0; side < 2; ++side) {
    const double sg = side_sign(side);
    const glm::dvec3 S = c.shoulder_chest[side];
    const double reach_len = b.upper_arm_m + b.forearm_m;
    const glm::dvec3 open = S + glm::dvec3(sg * reach_len, -0.02, 0);
    const glm::dvec3 crossed(-sg * 0.13, side == 0 ? -0.40 : -0.31, S[2] - (side == 0 ? 0.24 : 0.17));
    const glm::dvec3 T = open * (1 - x) + crossed * x;
    const glm::dvec3 hand_dir = glm::dvec3(sg, 0, 0) * (1 - x) + glm::dvec3(-sg, -0.4, 0.1) * x;
    reach(s, side, S, T, b.upper_arm_m, b.forearm_m, {sg * 0.3, 0.3, -1}, hand_dir, 0);
  }
  return build(c, s, false);
}

// Waving: the right hand for 4 s, then the left for 4 s; the other arm hangs.
Pose wave(const Ctx& c, double tau) {
  auto spec_for = [&](int waving) {
    Spec s = init_spec();
    for (int side = 0; side < 2; ++side) {
      const double sg = side_sign(side);
      if (side == waving) {
        const double phi = 0.25 + 0.42 * std::sin(2 * kPi * 1.8 * tau);
        s.arm[side].upper = dir(sg * 0.85, -0.25, 0.45);
        s.arm[side].fore = dir(sg * std::sin(phi), -0.2, std::cos(phi));
        s.arm[side].hand = dir(sg * std::sin(phi * 1.2), -0.25, std::cos(phi * 1.2));
        s.arm[side].hand_twist = sg * kPi / 2;
      } else {
        arm_hang(s, side);
      }
    }
    s.head_tilt = (waving == 0 ? 1 : -1) * 0.08;
    return s;
  };
  constexpr double kHalf = 4.0, kBlend = 0.6;
  const double u = std::fmod(tau, 2 * kHalf);
  const int waving = u < kHalf ? 1 : 0;  // right (1) first
  const double in_half = u - (waving == 1 ? 0 : kHalf);
  const Pose here = build(c, spec_for(waving), false);
  if (in_half < kHalf - kBlend) return here;
  const Pose next = build(c, spec_for(1 - waving), false);
  return blend(here, next, ease((in_half - (kHalf - kBlend)) / kBlend));
}

using MotionFn = Pose (*)(const Ctx&, double);
struct Entry {
  BuiltinMotion info;
  MotionFn fn;
};

const std::vector<Entry>& entries() {
  static const std::vector<Entry> list = {
      {{"tpose", "hold the initialization pose (facing the front, legs together, arms spread)", 1.0}, tpose},
      {{"wave", "wave the right hand, then the left, the other arm hanging", 8.0}, wave},
      {{"walk", "walk back and forth across the volume along y, turning in place at the ends", 6.4}, walk},
      {{"walk-in-place", "step on the spot, arms swinging", 2.2}, walk_in_place},
      {{"squat", "deep squats with the arms held forward", 3.2}, squat},
      {{"turn", "a full turn about the vertical axis in 4 s, stepping, arms lowered", 6.0}, turn},
      {{"arms-close", "hands on hips, arms hanging against the torso, clapping in front of the chest", 9.0},
       arms_close},
      {{"cross", "arms cross in front of the body (left in front) and open again", 3.0}, cross},
  };
  return list;
}

}  // namespace

const std::vector<BuiltinMotion>& builtin_motions() {
  static const std::vector<BuiltinMotion> list = [] {
    std::vector<BuiltinMotion> out;
    for (const Entry& e : entries()) out.push_back(e.info);
    return out;
  }();
  return list;
}

vc::body::StandardSegments standard_segments(const BodyDescription& b) {
  vc::body::StandardSegments s;
  s.hips_to_spine_m = b.hips_to_spine_m;
  s.spine_to_neck_m = b.spine_to_neck_m;
  s.neck_to_head_m = b.neck_to_head_m();
  s.head_to_top_m = b.head_radii_m[2];
  s.shoulder_half_width_m = b.shoulder_half_width_m;
  s.shoulder_drop_m = b.shoulder_drop_m;
  s.upper_arm_m = b.upper_arm_m;
  s.forearm_m = b.forearm_m;
  s.hand_m = b.hand_m;
  s.hip_half_width_m = b.hip_half_width_m;
  s.pelvis_drop_m = b.pelvis_drop_m;
  s.thigh_m = b.thigh_m;
  s.shank_m = b.shank_m;
  s.foot_forward_m = b.foot_forward_m;
  s.ankle_to_toe_drop_m = b.ankle_height_m - b.toes_half_height_m;
  return s;
}

Skeleton standard_skeleton(const BodyDescription& b) {
  return vc::body::standard_skeleton(standard_segments(b));
}

namespace detail {

void make_builtin(const std::string& name, const BodyDescription& body, MotionData* m) {
  const Entry* entry = nullptr;
  std::string known;
  for (const Entry& e : entries()) {
    if (e.info.name == name) entry = &e;
    known += (known.empty() ? "" : ", ") + e.info.name;
  }
  if (!entry)
    throw std::invalid_argument("unknown motion '" + name + "' (built-in: " + known + "; or a .bvh file)");
  m->name = name;
  m->skeleton = standard_skeleton(body);
  m->feet.ankle_height_m = body.ankle_height_m;
  m->length_s = entry->info.cycle_s;
  m->canon.assign(m->skeleton.joints.size(), glm::dmat3(1.0));
  for (int j = 0; j < kJointCount; ++j) m->sources[static_cast<std::size_t>(j)] = {j, -1, 0, j, {0, 0, 0}};

  std::vector<int> aim_child(kJointCount, -1);
  const std::pair<Joint, Joint> aims[] = {
      {Joint::spine, Joint::neck},         {Joint::neck, Joint::head},
      {Joint::head, Joint::head_top},      {Joint::l_shoulder, Joint::l_elbow},
      {Joint::l_elbow, Joint::l_wrist},    {Joint::l_wrist, Joint::l_hand_tip},
      {Joint::r_shoulder, Joint::r_elbow}, {Joint::r_elbow, Joint::r_wrist},
      {Joint::r_wrist, Joint::r_hand_tip}, {Joint::l_hip, Joint::l_knee},
      {Joint::l_knee, Joint::l_ankle},     {Joint::l_ankle, Joint::l_toe},
      {Joint::r_hip, Joint::r_knee},       {Joint::r_knee, Joint::r_ankle},
      {Joint::r_ankle, Joint::r_toe}};
  for (const auto& [j, child] : aims) aim_child[static_cast<std::size_t>(j)] = J(child);
  // The context refers to m's own body and skeleton: m owns the sampler, so it outlives it.
  m->body = body;
  auto ctx2 =
      std::make_shared<Ctx>(Ctx{m->body,
                                m->skeleton,
                                aim_child,
                                m,
                                {m->skeleton.joints[static_cast<std::size_t>(Joint::l_shoulder)].offset,
                                 m->skeleton.joints[static_cast<std::size_t>(Joint::r_shoulder)].offset}});
  const MotionFn fn = entry->fn;
  m->init = build(*ctx2, init_spec(), false);
  m->sample = [ctx2, fn](double tau) { return fn(*ctx2, tau); };
  m->first = m->sample(0);
}

}  // namespace detail
}  // namespace vc::sim
