// Initialization: the body model measured on the hull and the features of the init pose (init.hpp
// has the rules). Everything here is geometry on the decoded hull: walks along lines and areas of
// cross-sections, at a step of a voxel or finer.
#include "voxcap/fit/init.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <glm/geometric.hpp>

namespace vc::fit {
namespace {

Vec3 level(const Vec3& v) {
  return {v.x, v.y, 0};
}

bool fail(std::string* why, std::string m) {
  if (why) *why = std::move(m);
  return false;
}

// From p (occupied) along unit dir: the distance to the last occupied point before the first empty
// stretch of more than one voxel, up to max_m; -1 when p itself is empty.
double walk(const HullBits& h, const Vec3& p, const Vec3& dir, double max_m) {
  const double step = h.grid().voxel_m / 4;
  if (!h.at(p)) return -1;
  double last = 0;
  for (double s = step; s <= max_m; s += step) {
    if (h.at(p + s * dir))
      last = s;
    else if (s - last > 1.01 * h.grid().voxel_m)
      break;
  }
  return last;
}

// Occupied area (m^2) of the disc of radius r about c perpendicular to unit u, keeping only points
// with dot(q - c, keep_dir) >= 0 when keep_dir is non-zero.
double section_area(const HullBits& h, const Vec3& c, const Vec3& u, double r, const Vec3& keep_dir) {
  const Vec3 any = std::abs(u.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0);
  const Vec3 p1 = glm::normalize(glm::cross(u, any)), p2 = glm::cross(u, p1);
  const double step = h.grid().voxel_m / 2;
  const int n = static_cast<int>(std::ceil(r / step));
  int count = 0;
  for (int a = -n; a <= n; ++a)
    for (int b = -n; b <= n; ++b) {
      const double x = a * step, y = b * step;
      if (x * x + y * y > r * r) continue;
      const Vec3 q = c + x * p1 + y * p2;
      if (glm::dot(keep_dir, keep_dir) > 0 && glm::dot(q - c, keep_dir) < 0) continue;
      count += h.at(q) ? 1 : 0;
    }
  return count * step * step;
}

// A two-level fit of a profile: the index m (first of the second level) minimising the squared
// error, and the two means. m = -1 when the profile is too short.
struct Step {
  int m = -1;
  double hi = 0, lo = 0;
};
Step step_fit(const std::vector<double>& a) {
  Step best;
  const int n = static_cast<int>(a.size());
  double best_err = 1e300;
  for (int m = 2; m <= n - 2; ++m) {
    double s0 = 0, s1 = 0;
    for (int i = 0; i < m; ++i) s0 += a[static_cast<size_t>(i)];
    for (int i = m; i < n; ++i) s1 += a[static_cast<size_t>(i)];
    const double m0 = s0 / m, m1 = s1 / (n - m);
    double e = 0;
    for (int i = 0; i < n; ++i) {
      const double d = a[static_cast<size_t>(i)] - (i < m ? m0 : m1);
      e += d * d;
    }
    if (e < best_err) best = {m, m0, m1}, best_err = e;
  }
  return best;
}

// A limb from root to end (straight): the hinge's fraction of the length and the two radii, from
// the cross-section profile; `ratio` and the default radii when no step shows.
struct LimbProfile {
  double hinge_fraction;
  double upper_radius, lower_radius;
  bool stepped;
};
LimbProfile limb_profile(const HullBits& h, const Vec3& root, const Vec3& end, double max_r,
                         const Vec3& keep_dir, double ratio, double r_upper, double r_lower) {
  const Vec3 seg = end - root;
  const double len = glm::length(seg);
  const Vec3 u = seg / len;
  const double t0 = 0.25, t1 = 0.85;
  const int n = std::max(6, static_cast<int>((t1 - t0) * len / (h.grid().voxel_m / 2)));
  std::vector<double> area(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i)
    area[static_cast<size_t>(i)] =
        section_area(h, root + (t0 + (t1 - t0) * (i + 0.5) / n) * seg, u, max_r, keep_dir);
  const Step s = step_fit(area);
  LimbProfile p{ratio, r_upper, r_lower, false};
  if (s.m > 0 && s.lo > 0 && s.hi > 1.15 * s.lo) {
    p.upper_radius = std::sqrt(s.hi / M_PI);
    p.lower_radius = std::sqrt(s.lo / M_PI);
    // The area steps where the upper segment's rounded end has narrowed to the lower one's radius,
    // sqrt(ru^2 - rl^2) past the hinge: taken back.
    const double past = std::sqrt(std::max(0.0, s.hi - s.lo) / M_PI);
    p.hinge_fraction = t0 + (t1 - t0) * s.m / n - past / len;
    p.stepped = true;
  } else if (s.m > 0 && s.lo > 0) {
    p.upper_radius = p.lower_radius = std::sqrt((s.hi + s.lo) / 2 / M_PI);
  }
  return p;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

bool looks_like_init_pose(const FeatureSet& f, std::string* why) {
  const Vec3 &head = f[0], &lw = f[1], &rw = f[2], &la = f[3], &ra = f[4];
  const double ankle_z = std::min(la.z, ra.z);
  const double tall = head.z - ankle_z;
  if (tall < 0.5) return fail(why, fmt::format("head only {:.2f} m above the feet", tall));
  const double span = glm::length(level(rw - lw));
  if (span < 0.6 * tall) return fail(why, fmt::format("hands {:.2f} m apart: arms not spread", span));
  if (std::abs(lw.z - rw.z) > 0.12 * tall) return fail(why, "hands not level");
  const double hand_z = 0.5 * (lw.z + rw.z);
  if (hand_z > head.z || hand_z < ankle_z + 0.6 * tall) return fail(why, "hands not at shoulder height");
  if (glm::length(level(ra - la)) > 0.25 * tall) return fail(why, "feet not together");
  if (std::abs(la.z - ra.z) > 0.08 * tall) return fail(why, "feet not level");
  // The head between the hands, near the line joining them.
  const Vec3 x = glm::normalize(level(rw - lw));
  const double along = glm::dot(level(head - lw), x);
  if (along < 0.3 * span || along > 0.7 * span) return fail(why, "head not between the hands");
  if (glm::length(level(head - lw) - along * x) > 0.25 * span)
    return fail(why, "head away from the arms' line");
  return true;
}

Mat3 init_torso_frame(const FeatureSet& f) {
  const Vec3 x = glm::normalize(level(f[2] - f[1]));
  const Vec3 z(0, 0, 1);
  return Mat3(x, glm::cross(z, x), z);
}

std::optional<InitMeasurement> measure_init_frame(const HullBits& hull, const FeatureSet& f,
                                                  std::string* why) {
  const double vox = hull.grid().voxel_m;
  const Vec3 &head = f[0], &lw = f[1], &rw = f[2], &la = f[3], &ra = f[4];
  InitMeasurement m;
  m.R_torso_world = init_torso_frame(f);
  const Vec3 x = m.R_torso_world[0], y = m.R_torso_world[1], z(0, 0, 1);
  BodyModel& b = m.body;

  // Head top: the highest occupied point above the head feature.
  const double up = walk(hull, head, z, 0.5);
  if (up < 0) return fail(why, "no hull at the head feature"), std::nullopt;
  const double top_z = head.z + up;
  m.stature_m = top_z;
  b.head_to_top_m = up;
  const double ankle_z = 0.5 * (la.z + ra.z);
  const double shoulder_z = 0.5 * (lw.z + rw.z);

  // Torso: its axis below the head, its extents at three chest levels (below the arms).
  Vec3 axis(head.x, head.y, 0);
  double half_w = 0, half_d = 0;
  for (double frac : {0.12, 0.17, 0.22}) {
    Vec3 c = axis + Vec3(0, 0, shoulder_z - frac * (shoulder_z - ankle_z));
    const double fy = walk(hull, c, y, 0.6), by = walk(hull, c, -y, 0.6);
    if (fy < 0 || by < 0) return fail(why, "no hull below the head (torso)"), std::nullopt;
    c += 0.5 * (fy - by) * y;  // centred front to back
    const double rx = walk(hull, c, x, 0.8), lx = walk(hull, c, -x, 0.8);
    half_w = std::max(half_w, 0.5 * (rx + lx));
    half_d = std::max(half_d, 0.5 * (fy + by));
    if (frac == 0.17) axis = Vec3(c.x + 0.5 * (rx - lx) * x.x, c.y + 0.5 * (rx - lx) * x.y, 0);
  }
  b.torso_half_width_m = half_w;
  b.torso_half_depth_m = half_d;

  // Arms: the shoulder joint above the armpit, 0.3 upper-arm radii outside the chest's side.
  const Vec3 neck_axis(axis.x, axis.y, shoulder_z);
  double arm_len[2], hinge_frac[2], r_up[2], r_lo[2];
  for (int s = 0; s < 2; ++s) {
    const double side = s == 0 ? -1 : 1;
    const Vec3 wrist = s == 0 ? lw : rw;
    const Vec3 guess = neck_axis + side * (half_w + 0.015) * x;
    const LimbProfile p = limb_profile(hull, guess, wrist, 0.15, Vec3(0), 0.56, 0.05, 0.04);
    r_up[s] = p.upper_radius;
    r_lo[s] = p.lower_radius;
    const Vec3 shoulder = neck_axis + side * (half_w + 0.3 * p.upper_radius) * x;
    arm_len[s] = glm::length(wrist - shoulder);
    // The profile ran from `guess`; its hinge fraction is of that length.
    const double hinge_from_guess = p.hinge_fraction * glm::length(wrist - guess);
    const double frac = (hinge_from_guess + glm::length(shoulder - guess)) / arm_len[s];
    // A step far from the usual split (0.56 +- 0.06) is a hull artefact (phantom volume), not the elbow.
    hinge_frac[s] = p.stepped && std::abs(frac - 0.56) <= 0.06 ? frac : 0.56;
  }
  b.shoulder_half_width_m = half_w + 0.3 * 0.5 * (r_up[0] + r_up[1]);
  const double arm = 0.5 * (arm_len[0] + arm_len[1]);
  const double arm_frac = 0.5 * (hinge_frac[0] + hinge_frac[1]);
  b.upper_arm_m = arm * arm_frac;
  b.forearm_m = arm - b.upper_arm_m;
  b.upper_arm_radius_m = 0.5 * (r_up[0] + r_up[1]);
  b.forearm_radius_m = 0.5 * (r_lo[0] + r_lo[1]);

  // Neck base half way between the head's bottom and the shoulders.
  const double neck_z = 0.5 * (head.z - b.head_to_top_m + shoulder_z);
  b.shoulder_drop_m = neck_z - shoulder_z;
  b.neck_to_head_m = head.z - neck_z;
  m.neck_world = Vec3(axis.x, axis.y, neck_z);

  // Legs: hip joints above the ankles; the crotch between them.
  b.hip_half_width_m = std::max(0.5 * glm::length(level(ra - la)), 0.02);
  const Vec3 mid = 0.5 * (la + ra);
  double crotch_z = -1;
  for (double zz = ankle_z + 0.1; zz < shoulder_z; zz += vox / 4)
    if (hull.at(Vec3(mid.x, mid.y, zz))) {
      crotch_z = zz;
      break;
    }
  // The gap between legs held together closes in a visual hull below the real crotch (the phantom
  // volume of the few views that see through it): a crotch far from the usual 0.47 of the ankle ->
  // head-top height is such an artefact, as for the elbow and knee steps, and the usual height is used.
  const double usual_crotch_z = ankle_z + 0.47 * (top_z - ankle_z);
  const bool crotch_ok = crotch_z > 0 && std::abs(crotch_z - usual_crotch_z) <= 0.05 * (top_z - ankle_z);
  if (!crotch_ok) crotch_z = usual_crotch_z;  // legs touching all the way, or a phantom between them
  // The knee's split of the crotch -> ankle profile: about 0.45 of it in adults (0.40-0.50), further
  // in stylised or retargeted skeletons (0.53 in a public BVH clip whose thighs are 1.3 shanks). A
  // step outside 0.33-0.57 is a hull artefact (a phantom volume near either end of the profile), as
  // for the elbow, and a leg without a step says nothing: each leg counts only when it stepped within.
  constexpr double usual_knee_frac = 0.45, knee_frac_span = 0.12;
  double knee_frac_sum = 0, t_up[2], t_lo[2];
  int knee_steps = 0;
  for (int s = 0; s < 2; ++s) {
    const Vec3 ankle = s == 0 ? la : ra;
    const Vec3 hip_guess(ankle.x, ankle.y, crotch_z);
    const double side = s == 0 ? -1 : 1;
    const LimbProfile p = limb_profile(hull, hip_guess, ankle, 0.14, side * x, 0.5, 0.075, 0.055);
    if (p.stepped && std::abs(p.hinge_fraction - usual_knee_frac) <= knee_frac_span) {
      knee_frac_sum += p.hinge_fraction;
      ++knee_steps;
    }
    t_up[s] = p.upper_radius;
    t_lo[s] = p.lower_radius;
  }
  // A half section (one leg's side of the midline) for each leg: area doubled for the radius.
  b.thigh_radius_m = std::sqrt(2.0) * 0.5 * (t_up[0] + t_up[1]);
  b.shank_radius_m = std::sqrt(2.0) * 0.5 * (t_lo[0] + t_lo[1]);
  const double hip_z = crotch_z + b.thigh_radius_m;
  const double leg = hip_z - ankle_z;
  const double knee_frac = knee_steps > 0 ? knee_frac_sum / knee_steps : usual_knee_frac;
  const double knee_z = crotch_z - knee_frac * (crotch_z - ankle_z);
  b.thigh_m = hip_z - knee_z;
  b.shank_m = leg - b.thigh_m;
  b.pelvis_drop_m = 0.04 * m.stature_m;
  b.spine_m = neck_z - (hip_z + b.pelvis_drop_m);
  std::string bad;
  if (!b.valid(&bad)) return fail(why, "implausible body: " + bad), std::nullopt;
  return m;
}

InitMeasurement combine_measurements(const std::vector<InitMeasurement>& ms) {
  if (ms.empty()) throw std::invalid_argument("fit: no initialization measurements");
  InitMeasurement out = ms.back();
  auto med = [&ms](double BodyModel::*f) {
    std::vector<double> v;
    v.reserve(ms.size());
    for (const InitMeasurement& m : ms) v.push_back(m.body.*f);
    return median(v);
  };
  for (double BodyModel::*f :
       {&BodyModel::neck_to_head_m, &BodyModel::spine_m, &BodyModel::shoulder_half_width_m,
        &BodyModel::shoulder_drop_m, &BodyModel::hip_half_width_m, &BodyModel::pelvis_drop_m,
        &BodyModel::upper_arm_m, &BodyModel::forearm_m, &BodyModel::thigh_m, &BodyModel::shank_m,
        &BodyModel::upper_arm_radius_m, &BodyModel::forearm_radius_m, &BodyModel::thigh_radius_m,
        &BodyModel::shank_radius_m, &BodyModel::torso_half_width_m, &BodyModel::torso_half_depth_m,
        &BodyModel::head_to_top_m})
    out.body.*f = med(f);
  std::vector<double> st;
  st.reserve(ms.size());
  for (const InitMeasurement& m : ms) st.push_back(m.stature_m);
  out.stature_m = median(st);
  return out;
}

BodyModel proportional_body(double stature_m) {
  BodyModel b;  // the defaults are an adult of 1.75 m
  const double s = stature_m / 1.75;
  for (double BodyModel::*f :
       {&BodyModel::neck_to_head_m, &BodyModel::spine_m, &BodyModel::shoulder_half_width_m,
        &BodyModel::shoulder_drop_m, &BodyModel::hip_half_width_m, &BodyModel::pelvis_drop_m,
        &BodyModel::upper_arm_m, &BodyModel::forearm_m, &BodyModel::thigh_m, &BodyModel::shank_m,
        &BodyModel::upper_arm_radius_m, &BodyModel::forearm_radius_m, &BodyModel::thigh_radius_m,
        &BodyModel::shank_radius_m, &BodyModel::torso_half_width_m, &BodyModel::torso_half_depth_m,
        &BodyModel::head_to_top_m})
    b.*f *= s;
  return b;
}

void apply_body_toml_text(const std::string& text, const std::string& source, BodyModel* body) {
  if (text.size() > 65536) throw std::runtime_error(source + ": body file over 64 KiB");
  toml::table t;
  try {
    t = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw std::runtime_error(
        fmt::format("{}: TOML syntax error: {} (line {})", source, e.description(), e.source().begin.line));
  }
  struct Key {
    const char* name;
    double BodyModel::*field;
  };
  static const Key kKeys[] = {
      {"neck_to_head_m", &BodyModel::neck_to_head_m},
      {"spine_m", &BodyModel::spine_m},
      {"shoulder_half_width_m", &BodyModel::shoulder_half_width_m},
      {"shoulder_drop_m", &BodyModel::shoulder_drop_m},
      {"hip_half_width_m", &BodyModel::hip_half_width_m},
      {"pelvis_drop_m", &BodyModel::pelvis_drop_m},
      {"upper_arm_m", &BodyModel::upper_arm_m},
      {"forearm_m", &BodyModel::forearm_m},
      {"thigh_m", &BodyModel::thigh_m},
      {"shank_m", &BodyModel::shank_m},
      {"upper_arm_radius_m", &BodyModel::upper_arm_radius_m},
      {"forearm_radius_m", &BodyModel::forearm_radius_m},
      {"thigh_radius_m", &BodyModel::thigh_radius_m},
      {"shank_radius_m", &BodyModel::shank_radius_m},
      {"torso_half_width_m", &BodyModel::torso_half_width_m},
      {"torso_half_depth_m", &BodyModel::torso_half_depth_m},
      {"head_to_top_m", &BodyModel::head_to_top_m},
  };
  BodyModel b = *body;
  for (auto&& [k, v] : t) {
    const std::string key(k.str());
    const Key* found = nullptr;
    for (const Key& kk : kKeys)
      if (key == kk.name) found = &kk;
    const int line = static_cast<int>(v.source().begin.line);
    if (!found) throw std::runtime_error(fmt::format("{}: {}: unknown key (line {})", source, key, line));
    if (v.is_floating_point())
      b.*(found->field) = v.as_floating_point()->get();
    else if (v.is_integer())
      b.*(found->field) = static_cast<double>(v.as_integer()->get());
    else
      throw std::runtime_error(
          fmt::format("{}: {}: expected a number of metres (line {})", source, key, line));
  }
  std::string why;
  if (!b.valid(&why)) throw std::runtime_error(fmt::format("{}: {}", source, why));
  *body = b;
}

void apply_body_toml(const std::string& path, BodyModel* body) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open the body file");
  std::string text;
  char buf[4096];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<size_t>(in.gcount()));
    if (text.size() > 65536) throw std::runtime_error(path + ": body file over 64 KiB");
  }
  apply_body_toml_text(text, path, body);
}

}  // namespace vc::fit
