// The volumetric performer. Every body part is one "scaled capsule": in a local frame the points
// whose scaled coordinates (x/rx, y/ry, z/rz) lie within distance 1 of a core segment on the z
// axis. With a zero-length core it is an ellipsoid (head), with equal radii a round capsule
// (limbs), otherwise an elliptic capsule (torso, hands, feet). One closed-form primitive keeps
// ray casting, shadow tests and point-in-body tests exact and cheap (an affine map to the unit
// capsule). Limits: no deformation at joints (parts overlap there), no fingers, no hair.
#include "voxcap/sim/body.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vc::sim {
namespace {

constexpr std::array<std::string_view, kPartCount> kPartNames = {
    "pelvis",    "abdomen", "chest",       "shoulders", "neck",   "head",    "l_upper_arm",
    "l_forearm", "l_hand",  "r_upper_arm", "r_forearm", "r_hand", "l_thigh", "l_shank",
    "l_foot",    "l_toes",  "r_thigh",     "r_shank",   "r_foot", "r_toes"};

cv::Vec3d safe_normalize(const cv::Vec3d& v, const cv::Vec3d& fallback) {
  const double n = cv::norm(v);
  return n > 1e-12 ? v / n : fallback;
}

// A frame with local z along z_axis and local x as close to x_hint as possible.
cv::Matx33d frame_from(const cv::Vec3d& z_axis, const cv::Vec3d& x_hint) {
  const cv::Vec3d z = safe_normalize(z_axis, {0, 0, 1});
  cv::Vec3d x = x_hint - z * x_hint.dot(z);
  if (cv::norm(x) < 1e-9) {
    const cv::Vec3d alt = std::abs(z[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    x = alt - z * alt.dot(z);
  }
  x = cv::normalize(x);
  const cv::Vec3d y = z.cross(x);
  return {x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]};
}

cv::Vec3d column(const cv::Matx33d& R, int c) {
  return {R(0, c), R(1, c), R(2, c)};
}

Primitive make(Part part, const cv::Vec3d& center, const cv::Matx33d& R, const cv::Vec3d& radii,
               double half_length) {
  Primitive p;
  p.part = part;
  p.center = center;
  p.R = R;
  p.radii = radii;
  p.half_length = std::max(0.0, half_length);
  p.finalize();
  return p;
}

// A segment a..b with elliptic cross-section; the caps extend radii[2] beyond a and b.
Primitive segment(Part part, const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& x_hint,
                  const cv::Vec3d& radii) {
  return make(part, 0.5 * (a + b), frame_from(b - a, x_hint), radii, 0.5 * cv::norm(b - a));
}

// Squared distance between segments p1..q1 and p2..q2 (Ericson, Real-Time Collision Detection 5.1.9).
double segment_distance2(const cv::Vec3d& p1, const cv::Vec3d& q1, const cv::Vec3d& p2, const cv::Vec3d& q2) {
  const cv::Vec3d d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.dot(d1), e = d2.dot(d2), f = d2.dot(r);
  double s = 0, t = 0;
  if (a <= 1e-18 && e <= 1e-18) return r.dot(r);
  if (a <= 1e-18) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= 1e-18) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > 1e-18 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  const cv::Vec3d diff = (p1 + d1 * s) - (p2 + d2 * t);
  return diff.dot(diff);
}

// Entry of o + t d into the unit sphere at (0, 0, cz); false if missed.
bool sphere_entry(const cv::Vec3d& o, const cv::Vec3d& d, double cz, double* t) {
  const cv::Vec3d oc(o[0], o[1], o[2] - cz);
  const double a = d.dot(d), b = oc.dot(d), c = oc.dot(oc) - 1.0;
  const double disc = b * b - a * c;
  if (disc < 0 || a <= 0) return false;
  *t = (-b - std::sqrt(disc)) / a;
  return true;
}

}  // namespace

std::string_view part_name(Part p) {
  return kPartNames[static_cast<std::size_t>(p)];
}

Material part_material(Part p) {
  switch (p) {
    case Part::head:
    case Part::neck:
    case Part::l_hand:
    case Part::r_hand:
    case Part::l_foot:
    case Part::r_foot:
    case Part::l_toes:
    case Part::r_toes:
      return Material::skin;
    case Part::abdomen:
    case Part::chest:
    case Part::shoulders:
    case Part::l_upper_arm:
    case Part::l_forearm:
    case Part::r_upper_arm:
    case Part::r_forearm:
      return Material::shirt;
    default:
      return Material::trousers;
  }
}

const std::array<std::string_view, kPartGroups>& part_group_names() {
  static const std::array<std::string_view, kPartGroups> names = {
      "head",   "torso",   "l_upper_arm", "r_upper_arm", "l_forearm", "r_forearm", "l_hand",
      "r_hand", "l_thigh", "r_thigh",     "l_shank",     "r_shank",   "l_foot",    "r_foot"};
  return names;
}

int part_group(int part) {
  using P = Part;
  switch (static_cast<P>(part)) {
    case P::head:
    case P::neck:
      return 0;
    case P::pelvis:
    case P::abdomen:
    case P::chest:
    case P::shoulders:
      return 1;
    case P::l_upper_arm:
      return 2;
    case P::r_upper_arm:
      return 3;
    case P::l_forearm:
      return 4;
    case P::r_forearm:
      return 5;
    case P::l_hand:
      return 6;
    case P::r_hand:
      return 7;
    case P::l_thigh:
      return 8;
    case P::r_thigh:
      return 9;
    case P::l_shank:
      return 10;
    case P::r_shank:
      return 11;
    case P::l_foot:
    case P::l_toes:
      return 12;
    case P::r_foot:
    case P::r_toes:
      return 13;
  }
  throw std::out_of_range("no body part " + std::to_string(part));
}

bool part_of_feature(Part p, Feature f) {
  switch (f) {
    case Feature::head:
      return p == Part::head || p == Part::neck;
    case Feature::l_hand:
      return p == Part::l_hand || p == Part::l_forearm;
    case Feature::r_hand:
      return p == Part::r_hand || p == Part::r_forearm;
    case Feature::l_foot:
      return p == Part::l_foot || p == Part::l_toes || p == Part::l_shank;
    default:
      return p == Part::r_foot || p == Part::r_toes || p == Part::r_shank;
  }
}

double BodyDescription::standing_height_m() const {
  return ankle_height_m + shank_m + thigh_m + pelvis_drop_m + hips_to_spine_m + spine_to_neck_m +
         neck_to_head_m() + head_radii_m[2];
}

double BodyDescription::neck_to_head_m() const {
  // The head centre sits so that the head's top is at height_m.
  return height_m - (ankle_height_m + shank_m + thigh_m + pelvis_drop_m + hips_to_spine_m + spine_to_neck_m +
                     head_radii_m[2]);
}

BodyDescription BodyDescription::adult(double height_m) {
  BodyDescription b;
  const double s = height_m / b.height_m;
  BodyDescription o = b;
  o.height_m = height_m;
  for (double* v : {&o.ankle_height_m,
                    &o.shank_m,
                    &o.thigh_m,
                    &o.pelvis_drop_m,
                    &o.hip_half_width_m,
                    &o.hips_to_spine_m,
                    &o.spine_to_neck_m,
                    &o.shoulder_half_width_m,
                    &o.shoulder_drop_m,
                    &o.upper_arm_m,
                    &o.forearm_m,
                    &o.hand_m,
                    &o.foot_forward_m,
                    &o.heel_back_m,
                    &o.toes_m,
                    &o.neck_radius_m,
                    &o.upper_arm_radius_m,
                    &o.forearm_radius_m,
                    &o.hand_half_width_m,
                    &o.hand_half_thickness_m,
                    &o.thigh_radius_m,
                    &o.shank_radius_m,
                    &o.shoulder_radius_m,
                    &o.foot_half_width_m,
                    &o.foot_half_height_m,
                    &o.toes_half_height_m}) {
    *v *= s;
  }
  o.head_radii_m *= s;
  o.chest_radii_m *= s;
  o.abdomen_radii_m *= s;
  o.pelvis_radii_m *= s;
  return o;
}

bool BodyDescription::valid(std::string* why) const {
  std::ostringstream os;
  const double all[] = {ankle_height_m,
                        shank_m,
                        thigh_m,
                        pelvis_drop_m,
                        hip_half_width_m,
                        hips_to_spine_m,
                        spine_to_neck_m,
                        shoulder_half_width_m,
                        upper_arm_m,
                        forearm_m,
                        hand_m,
                        foot_forward_m,
                        heel_back_m,
                        toes_m,
                        neck_radius_m,
                        upper_arm_radius_m,
                        forearm_radius_m,
                        hand_half_width_m,
                        hand_half_thickness_m,
                        thigh_radius_m,
                        shank_radius_m,
                        shoulder_radius_m,
                        foot_half_width_m,
                        foot_half_height_m,
                        toes_half_height_m,
                        head_radii_m[0],
                        head_radii_m[1],
                        head_radii_m[2],
                        chest_radii_m[0],
                        chest_radii_m[1],
                        chest_radii_m[2],
                        abdomen_radii_m[0],
                        abdomen_radii_m[1],
                        abdomen_radii_m[2],
                        pelvis_radii_m[0],
                        pelvis_radii_m[1],
                        pelvis_radii_m[2]};
  if (!(height_m >= 1.0 && height_m <= 2.3)) {
    os << "height_m must be in [1.0, 2.3], got " << height_m;
  } else if (!std::all_of(std::begin(all), std::end(all), [](double v) { return v > 0 && v < 1.5; })) {
    os << "every length and radius must be in (0, 1.5) m";
  } else if (neck_to_head_m() < 0.05) {
    os << "segment lengths leave no room for the neck below height_m (neck to head " << neck_to_head_m()
       << " m)";
  } else if (shoulder_drop_m < 0 || shoulder_drop_m > spine_to_neck_m) {
    os << "shoulder_drop_m must be in [0, spine_to_neck_m]";
  } else {
    return true;
  }
  if (why) *why = os.str();
  return false;
}

std::vector<Appearance> appearance_presets() {
  // Skin tones from light to dark; clothes chosen so that shirt, trousers and skin differ clearly
  // in hue or brightness. "beige" is deliberately hard: a shirt close to skin colour.
  return {
      {"default", {222, 170, 138}, {38, 78, 168}, {58, 58, 64}},
      {"pale", {240, 205, 185}, {175, 40, 40}, {40, 48, 80}},
      {"olive", {196, 150, 108}, {48, 120, 62}, {30, 30, 34}},
      {"brown", {150, 100, 70}, {222, 150, 40}, {50, 72, 120}},
      {"dark", {96, 62, 44}, {200, 200, 196}, {120, 100, 70}},
      {"beige", {205, 160, 128}, {200, 175, 140}, {70, 50, 40}},
  };
}

Appearance appearance_preset(std::string_view name) {
  std::string known;
  for (const Appearance& a : appearance_presets()) {
    if (a.name == name) return a;
    known += (known.empty() ? "" : ", ") + a.name;
  }
  throw std::invalid_argument("unknown appearance '" + std::string(name) + "' (known: " + known + ")");
}

void Primitive::finalize() {
  const cv::Matx33d S_inv(1.0 / radii[0], 0, 0, 0, 1.0 / radii[1], 0, 0, 0, 1.0 / radii[2]);
  to_local = S_inv * R.t();
  core = half_length / radii[2];
}

bool Primitive::contains(const cv::Vec3d& p_world) const {
  const cv::Vec3d q = to_local * (p_world - center);
  const double dz = q[2] - std::clamp(q[2], -core, core);
  return q[0] * q[0] + q[1] * q[1] + dz * dz <= 1.0;
}

bool Primitive::intersect(const cv::Vec3d& o_world, const cv::Vec3d& d_world, double t_min,
                          double* t_hit) const {
  return intersect_from_local(to_local_point(o_world), d_world, t_min, t_hit);
}

bool Primitive::intersect_from_local(const cv::Vec3d& o, const cv::Vec3d& d_world, double t_min,
                                     double* t_hit) const {
  return intersect_local(o, to_local * d_world, t_min, t_hit);
}

bool Primitive::intersect_local(const cv::Vec3d& o, const cv::Vec3d& d, double t_min, double* t_hit) const {
  // Side of the infinite elliptic cylinder; the capsule lies inside it, so a miss is final.
  const double A = d[0] * d[0] + d[1] * d[1];
  const double B = o[0] * d[0] + o[1] * d[1];
  const double C = o[0] * o[0] + o[1] * o[1] - 1.0;
  int caps = 3;  // the cap spheres that may hold the entry: 1 = at z = +core, 2 = at -core
  if (A > 1e-18) {
    const double disc = B * B - A * C;
    if (disc < 0) return false;
    const double t = (-B - std::sqrt(disc)) / A;
    if (t > t_min) {
      // The line enters the cylinder here. On the core this is the capsule's entry. Above it, the
      // line can reach the capsule only through the top sphere (going lower inside the cylinder
      // crosses that sphere's equator disc), below it only through the bottom one.
      const double z = o[2] + t * d[2];
      if (z >= -core && z <= core) {
        *t_hit = t;
        return true;
      }
      caps = z > core ? 1 : 2;
    }
  } else if (C > 0) {
    return false;  // parallel to the axis and outside the cylinder
  }
  if (core <= 0) caps = 1;  // a single sphere
  // The caps: any entry into a cap sphere is inside the capsule; the earliest is the entry.
  double best = HUGE_VAL, t;
  if ((caps & 1) && sphere_entry(o, d, core, &t) && t > t_min) best = t;
  if ((caps & 2) && sphere_entry(o, d, -core, &t) && t > t_min) best = std::min(best, t);
  if (best == HUGE_VAL) return false;
  *t_hit = best;
  return true;
}

bool Primitive::touches_segment(const cv::Vec3d& a, const cv::Vec3d& b) const {
  return touches_segment_from_local(to_local_point(a), b);
}

bool Primitive::touches_segment_from_local(const cv::Vec3d& la, const cv::Vec3d& b) const {
  return segment_distance2(la, to_local_point(b), {0, 0, -core}, {0, 0, core}) <= 1.0;
}

cv::Vec3d Primitive::normal(const cv::Vec3d& p_world) const {
  const cv::Vec3d q = to_local * (p_world - center);
  const cv::Vec3d n_local(q[0] / radii[0], q[1] / radii[1],
                          (q[2] - std::clamp(q[2], -core, core)) / radii[2]);
  return safe_normalize(R * n_local, column(R, 2));
}

std::array<cv::Vec3d, 8> Primitive::box_corners() const {
  const cv::Vec3d e(radii[0], radii[1], radii[2] + half_length);
  std::array<cv::Vec3d, 8> out;
  for (int i = 0; i < 8; ++i) {
    const cv::Vec3d local((i & 1) ? e[0] : -e[0], (i & 2) ? e[1] : -e[1], (i & 4) ? e[2] : -e[2]);
    out[static_cast<std::size_t>(i)] = center + R * local;
  }
  return out;
}

void build_primitives(const BodyPose& pose, const BodyDescription& body, const FootGeometry& feet,
                      std::vector<Primitive>* out) {
  out->clear();
  out->reserve(kPartCount);
  auto P = [&](Joint j) { return pose.p(j); };
  auto axis = [&](Joint j, int c) { return column(pose.R(j), c); };

  // Torso: pelvis around the hips and hip joints, abdomen hips -> spine, chest spine -> below the
  // neck, and the shoulder girdle joining the shoulders over the chest.
  const cv::Vec3d mid_hip = 0.5 * (P(Joint::l_hip) + P(Joint::r_hip));
  const cv::Vec3d pelvis_x = P(Joint::l_hip) - P(Joint::r_hip);
  out->push_back(make(Part::pelvis, 0.5 * (P(Joint::hips) + mid_hip),
                      frame_from(axis(Joint::hips, 2), pelvis_x), body.pelvis_radii_m, 0.02));
  const cv::Vec3d abdomen_x = axis(Joint::hips, 0) + axis(Joint::spine, 0);
  out->push_back(segment(Part::abdomen, P(Joint::hips), P(Joint::spine), abdomen_x, body.abdomen_radii_m));
  const cv::Vec3d chest_dir = safe_normalize(P(Joint::neck) - P(Joint::spine), axis(Joint::spine, 2));
  const double chest_len =
      std::max(0.0, cv::norm(P(Joint::neck) - P(Joint::spine)) - 0.8 * body.chest_radii_m[2]);
  out->push_back(segment(Part::chest, P(Joint::spine), P(Joint::spine) + chest_dir * chest_len,
                         axis(Joint::spine, 0), body.chest_radii_m));
  const double rs = body.shoulder_radius_m;
  out->push_back(segment(Part::shoulders, P(Joint::r_shoulder), P(Joint::l_shoulder), axis(Joint::spine, 1),
                         {rs, rs, rs}));

  // Neck and head.
  const double rn = body.neck_radius_m;
  out->push_back(segment(Part::neck, P(Joint::neck), P(Joint::neck) + 0.6 * (P(Joint::head) - P(Joint::neck)),
                         axis(Joint::neck, 0), {rn, rn, rn}));
  const cv::Vec3d head_up = safe_normalize(P(Joint::head_top) - P(Joint::head), axis(Joint::head, 2));
  out->push_back(
      make(Part::head, P(Joint::head), frame_from(head_up, axis(Joint::head, 0)), body.head_radii_m, 0));

  // Arms, hands.
  for (int side = 0; side < 2; ++side) {
    const bool left = side == 0;
    const Joint sh = left ? Joint::l_shoulder : Joint::r_shoulder;
    const Joint el = left ? Joint::l_elbow : Joint::r_elbow;
    const Joint wr = left ? Joint::l_wrist : Joint::r_wrist;
    const Joint tip = left ? Joint::l_hand_tip : Joint::r_hand_tip;
    const double ru = body.upper_arm_radius_m, rf = body.forearm_radius_m;
    out->push_back(
        segment(left ? Part::l_upper_arm : Part::r_upper_arm, P(sh), P(el), axis(sh, 1), {ru, ru, ru}));
    out->push_back(
        segment(left ? Part::l_forearm : Part::r_forearm, P(el), P(wr), axis(el, 1), {rf, rf, rf}));
    const cv::Vec3d hand_dir = safe_normalize(P(tip) - P(wr), axis(wr, 0) * (left ? 1.0 : -1.0));
    const double cap = std::min(0.035, 0.5 * body.hand_m);
    out->push_back(make(left ? Part::l_hand : Part::r_hand, P(wr) + hand_dir * (0.5 * body.hand_m),
                        frame_from(hand_dir, axis(wr, 1)),
                        {body.hand_half_width_m, body.hand_half_thickness_m, cap}, 0.5 * body.hand_m - cap));
  }
  // Legs, feet, toes.
  for (int side = 0; side < 2; ++side) {
    const bool left = side == 0;
    const Joint hp = left ? Joint::l_hip : Joint::r_hip;
    const Joint kn = left ? Joint::l_knee : Joint::r_knee;
    const Joint an = left ? Joint::l_ankle : Joint::r_ankle;
    const Joint to = left ? Joint::l_toe : Joint::r_toe;
    const double rt = body.thigh_radius_m, rk = body.shank_radius_m;
    out->push_back(segment(left ? Part::l_thigh : Part::r_thigh, P(hp), P(kn), axis(hp, 1), {rt, rt, rt}));
    out->push_back(segment(left ? Part::l_shank : Part::r_shank, P(kn), P(an), axis(kn, 1), {rk, rk, rk}));
    const cv::Matx33d& Ra = pose.R(an);
    const cv::Matx33d& Rt = pose.R(to);
    const double fh = body.foot_half_height_m, th = body.toes_half_height_m;
    const cv::Vec3d heel = P(an) + Ra * cv::Vec3d(0, body.heel_back_m, -(feet.ankle_height_m - fh));
    const cv::Vec3d ball = P(to) + Rt * cv::Vec3d(0, 0, fh - th);
    out->push_back(segment(left ? Part::l_foot : Part::r_foot, heel, ball, axis(an, 0),
                           {body.foot_half_width_m, fh, fh}));
    const cv::Vec3d fwd = Rt * cv::Vec3d(0, -1, 0);
    const double cap = std::min(0.03, 0.5 * body.toes_m);
    out->push_back(make(left ? Part::l_toes : Part::r_toes, P(to) + fwd * (0.5 * body.toes_m),
                        frame_from(fwd, axis(to, 0)), {body.foot_half_width_m, th, cap},
                        0.5 * body.toes_m - cap));
  }
  // Keep the documented order (index == Part).
  std::sort(out->begin(), out->end(), [](const Primitive& a, const Primitive& b) { return a.part < b.part; });
}

}  // namespace vc::sim
