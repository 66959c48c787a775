// Mapping any humanoid BVH onto the standard joints (the rules are in humanoid.hpp). Names are
// read word by word and limbs are found from their ends upwards, because conventions disagree on
// what a word means ("Shoulder" is the clavicle in MotionBuilder files and the shoulder joint in
// 3dsMax and SMPL ones) but agree on the order of the segments along a limb.
#include "voxcap/body/humanoid.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <glm/geometric.hpp>

namespace vc::body {
namespace {

constexpr double kCmuMetresPerUnit = 0.056444;  // CMU: 1 unit = 1/0.45 inch
constexpr double kMetresPerInch = 0.0254;

// Poses of the file's joints on a skeleton with made-up End Sites appended (identity rotations).
void pad_pose(const Skeleton& skeleton, Pose* pose) {
  const std::size_t n = skeleton.joints.size();
  if (pose->local.size() < n) pose->local.resize(n, glm::dmat3(1.0));
  if (!pose->translation.empty() && pose->translation.size() < n) pose->translation.resize(n, glm::dvec3(0));
}

enum class Side { none, left, right };

struct JointName {
  Side side = Side::none;
  std::string key;  // the words other than the side, lower case, joined
};

// Words of a name: "prefix:" dropped, split at non-alphanumerics and case changes (digits stay
// with their word: "Neck1", "Toe0").
std::vector<std::string> words_of(const std::string& name) {
  const auto colon = name.rfind(':');
  const std::string s = colon == std::string::npos ? name : name.substr(colon + 1);
  std::vector<std::string> out;
  std::string cur;
  auto flush = [&] {
    if (!cur.empty()) out.push_back(cur);
    cur.clear();
  };
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (!std::isalnum(c)) {
      flush();
      continue;
    }
    if (std::isupper(c) && i > 0) {
      const auto prev = static_cast<unsigned char>(s[i - 1]);
      const bool next_lower = i + 1 < s.size() && std::islower(static_cast<unsigned char>(s[i + 1]));
      if (std::islower(prev) || std::isdigit(prev) || (std::isupper(prev) && next_lower)) flush();
    }
    cur += static_cast<char>(std::tolower(c));
  }
  flush();
  return out;
}

const std::vector<std::string> kWrist = {"hand", "wrist"};
const std::vector<std::string> kElbow = {"forearm", "lowerarm", "elbow", "radius", "lowarm"};
const std::vector<std::string> kShoulder = {"arm", "upperarm", "humerus", "shoulder", "uparm"};
const std::vector<std::string> kAnkle = {"foot", "ankle"};
const std::vector<std::string> kKnee = {"leg", "lowerleg", "shin", "calf", "knee", "tibia", "lowleg"};
const std::vector<std::string> kHip = {"upleg", "upperleg", "thigh", "femur", "hip"};
const std::vector<std::string> kToe = {"toebase", "toe", "toes", "toe0", "ball"};
const std::vector<std::string> kHips = {"hips", "pelvis", "hip"};

bool in(const std::vector<std::string>& family, const std::string& key) {
  return std::find(family.begin(), family.end(), key) != family.end();
}

bool is_limb_part(const std::string& key) {
  for (const auto* f : {&kWrist, &kElbow, &kShoulder, &kAnkle, &kKnee, &kHip, &kToe}) {
    if (in(*f, key)) return true;
  }
  return false;
}

bool is_side_word(const std::string& w) {
  return w == "left" || w == "right" || w == "l" || w == "r";
}

// `rig_prefix`: a first word most joints of the file share ("Character1_Hips", "Armature_Spine"),
// dropped like the known ones.
JointName parse_name(const std::string& name, const std::string& rig_prefix) {
  std::vector<std::string> w = words_of(name);
  // Noise words: 3ds Max Biped's "Bip01" and similar rig prefixes.
  static const std::regex kNoise("^(bip[0-9]*|mixamorig[0-9]*|def|jnt)$");
  w.erase(
      std::remove_if(w.begin(), w.end(), [](const std::string& x) { return std::regex_match(x, kNoise); }),
      w.end());
  if (!rig_prefix.empty() && w.size() > 1 && w.front() == rig_prefix) w.erase(w.begin());
  JointName out;
  for (auto it = w.begin(); it != w.end(); ++it) {
    if (*it == "left" || *it == "l") {
      out.side = Side::left;
    } else if (*it == "right" || *it == "r") {
      out.side = Side::right;
    } else {
      continue;
    }
    w.erase(it);
    break;
  }
  std::string key;
  for (const auto& x : w) key += x;
  if (out.side == Side::none && key.size() > 1 && (key[0] == 'l' || key[0] == 'r') &&
      is_limb_part(key.substr(1))) {
    out.side = key[0] == 'l' ? Side::left : Side::right;  // "lhumerus", "rfoot"
    key = key.substr(1);
  }
  out.key = key;
  return out;
}

std::string list_of(const std::vector<std::string>& family) {
  std::string s;
  for (const auto& x : family) s += (s.empty() ? "" : ", ") + x;
  return s;
}

// The rest pose's tree for the mapping by the hierarchy: positions (file units), children, the
// longest path below each joint and the path length from the root.
struct Tree {
  const Skeleton& sk;
  std::vector<glm::dvec3> p;
  std::vector<std::vector<int>> kids;
  std::vector<double> reach;
  std::vector<double> from_root;
  double size = 0;  // the rest pose's bounding-box diagonal

  Tree(const Skeleton& skeleton, std::vector<glm::dvec3> p_rest) : sk(skeleton), p(std::move(p_rest)) {
    const std::size_t n = sk.joints.size();
    kids.resize(n);
    reach.assign(n, 0);
    from_root.assign(n, 0);
    glm::dvec3 lo(HUGE_VAL), hi(-HUGE_VAL);
    for (std::size_t j = 0; j < n; ++j) {
      lo = glm::min(lo, p[j]);
      hi = glm::max(hi, p[j]);
      const int par = sk.joints[j].parent;
      if (par < 0) continue;
      kids[static_cast<std::size_t>(par)].push_back(static_cast<int>(j));
      from_root[j] = from_root[static_cast<std::size_t>(par)] + seg(par, static_cast<int>(j));
    }
    size = glm::length(hi - lo);
    for (std::size_t j = n; j-- > 1;) {
      const auto par = static_cast<std::size_t>(sk.joints[j].parent);
      reach[par] = std::max(reach[par], seg(static_cast<int>(par), static_cast<int>(j)) + reach[j]);
    }
  }
  double seg(int a, int b) const {
    return glm::length(p[static_cast<std::size_t>(b)] - p[static_cast<std::size_t>(a)]);
  }
  // The longest path from j through its child c.
  double len(int j, int c) const { return seg(j, c) + reach[static_cast<std::size_t>(c)]; }
  int longest_child(int j) const {
    int best = -1;
    for (int c : kids[static_cast<std::size_t>(j)]) {
      if (best < 0 || len(j, c) > len(j, best)) best = c;
    }
    return best;
  }
  // The joints along the longest path from c down (at most 64).
  std::vector<int> chain(int c) const {
    std::vector<int> out;
    for (; c >= 0 && out.size() < 64; c = longest_child(c)) out.push_back(c);
    return out;
  }
};

// Shoulder, elbow and wrist (or hip, knee and ankle) on a limb's chain, by the lengths of the rest
// pose only (bones are straight lines between joints, so the rest pose may be any: T, A, arms down).
// A joint at the same place as its parent (CMU's LHipJoint, LeftShoulder and LeftFingerBase) stands
// for neither, nor does one at the branch point. Where the chain branches into parts shorter than
// the bone before them (fingers and thumb, heel and toes) is the wrist or ankle. Otherwise, and for
// the joints above, the choice whose segments best have a human limb's proportions (forearm/upper
// arm 0.87, hand 0.34 of the two; shank/thigh 1, foot 0.23) and cover most of the chain (a clavicle
// or a hip joint comes before them, not between).
std::array<int, 3> fit_limb(const Tree& t, int branch, const std::vector<int>& chain, double ratio,
                            double end_ratio) {
  const double eps = 1e-6 * t.size;
  auto parent = [&](int j) { return t.sk.joints[static_cast<std::size_t>(j)].parent; };
  std::vector<int> js;
  for (int c : chain) {
    if (t.sk.joints[static_cast<std::size_t>(c)].end_site) continue;
    if (t.seg(parent(c), c) < eps) continue;  // coincides with its parent
    js.push_back(c);
  }
  const double total = t.len(branch, chain.front());
  // The branching joint, lifted over joints at its place.
  int fixed_w = -1;
  for (std::size_t i = 2; i < chain.size() && fixed_w < 0; ++i) {
    const int b = chain[i];
    const auto& kids = t.kids[static_cast<std::size_t>(b)];
    if (kids.size() < 2) continue;
    int top = b;
    while (t.seg(parent(top), top) < eps && parent(top) != branch) top = parent(top);
    const double into = t.seg(parent(top), top);
    bool short_parts = true;
    for (int c : kids) short_parts = short_parts && t.len(b, c) < into;
    if (short_parts && std::find(js.begin(), js.end(), top) != js.end()) fixed_w = top;
  }
  std::array<int, 3> best{-1, -1, -1};
  double best_cost = HUGE_VAL;
  for (std::size_t a = 0; a < js.size(); ++a) {
    for (std::size_t b = a + 1; b < js.size(); ++b) {
      for (std::size_t c = b + 1; c < js.size(); ++c) {
        if (fixed_w >= 0 && js[c] != fixed_w) continue;
        const double upper = t.seg(js[a], js[b]), lower = t.seg(js[b], js[c]);
        if (!(upper > eps && lower > eps)) continue;
        const double below = t.reach[static_cast<std::size_t>(js[c])];
        double cost =
            std::abs(std::log(lower / upper / ratio)) + 4 * std::max(0.0, 0.45 - (upper + lower) / total);
        // (A wrist or ankle with nothing below it at all, not even an End Site, says nothing.)
        if (!t.kids[static_cast<std::size_t>(js[c])].empty()) {
          const double hand = std::max(below, 0.05 * (upper + lower));
          cost += 0.5 * std::abs(std::log(hand / (end_ratio * (upper + lower))));
        }
        if (cost < best_cost) {
          best_cost = cost;
          best = {js[a], js[b], js[c]};
        }
      }
    }
  }
  return best;
}

// The mapping by the hierarchy alone, for names that do not decide (Joint1..JointN): the hips are
// the first joint from the root where three long chains leave (two legs, one spine); a chain is an
// extremity when it does not branch into long chains again (fingers and toes are short against the
// path to them). The legs are the hips' two longest extremity chains, the spine the chain that
// branches into at least three extremities; along the spine the extremities that leave it are the
// arms and the head, the head being the one that continues the hips->spine direction. Left and
// right come from the rest pose: up is hips->head, forward is where the feet point (ankle to toe),
// left = up x forward. Fills hips, neck, head and the limbs' three joints; returns "" or what is
// missing.
std::string map_by_hierarchy(const Tree& t, std::array<int, kJointCount>* anchor) {
  const std::size_t n = t.sk.joints.size();
  if (!(t.size > 0)) return "the rest pose has no extent";
  auto long_children = [&](int j, double thr) {
    std::vector<int> out;
    for (int c : t.kids[static_cast<std::size_t>(j)]) {
      if (t.len(j, c) >= thr) out.push_back(c);
    }
    return out;
  };
  int hips = 0;
  for (;;) {
    const std::vector<int> l = long_children(hips, 0.12 * t.size);
    if (l.size() >= 3) break;
    if (l.size() != 1) return "no joint where two legs and a spine leave (three long chains)";
    hips = l[0];
  }
  const double h0 = t.from_root[static_cast<std::size_t>(hips)];
  auto thr = [&](int j) {
    return std::max(0.08 * t.size, 0.35 * (t.from_root[static_cast<std::size_t>(j)] - h0));
  };
  std::vector<int> ext(n, 1);
  for (std::size_t j = n; j-- > 0;) {
    const std::vector<int> l = long_children(static_cast<int>(j), thr(static_cast<int>(j)));
    if (l.empty()) continue;
    int sum = 0;
    for (int c : l) sum += ext[static_cast<std::size_t>(c)];
    ext[j] = std::min(sum, 1 << 20);
  }
  std::vector<int> legs;
  int spine = -1;
  for (int c : long_children(hips, 0.12 * t.size)) {
    if (ext[static_cast<std::size_t>(c)] == 1) {
      legs.push_back(c);
    } else if (spine < 0 || ext[static_cast<std::size_t>(c)] > ext[static_cast<std::size_t>(spine)]) {
      spine = c;
    }
  }
  if (legs.size() < 2) return "no two legs below " + t.sk.joints[static_cast<std::size_t>(hips)].name;
  std::sort(legs.begin(), legs.end(), [&](int a, int b) { return t.len(hips, a) > t.len(hips, b); });
  if (spine < 0 || ext[static_cast<std::size_t>(spine)] < 3)
    return "no spine with two arms and a head above " + t.sk.joints[static_cast<std::size_t>(hips)].name;
  // Down the spine: the extremities that leave it.
  std::vector<int> ends;
  for (int j = spine;;) {
    const std::vector<int> l = long_children(j, thr(j));
    int next = -1;
    if (l.size() == 1 && ext[static_cast<std::size_t>(l[0])] > 1) {
      next = l[0];
    } else {
      for (int c : l) {
        if (ext[static_cast<std::size_t>(c)] == 1) {
          ends.push_back(c);
        } else if (next < 0) {
          next = c;
        } else {
          return "the spine forks below " + t.sk.joints[static_cast<std::size_t>(j)].name;
        }
      }
    }
    if (next < 0) break;
    j = next;
  }
  if (ends.size() < 3) return "no two arms and a head on the spine";
  auto end_point = [&](int c) {
    const std::vector<int> ch = t.chain(c);
    return t.p[static_cast<std::size_t>(ch.back())];
  };
  auto parent = [&](int j) { return t.sk.joints[static_cast<std::size_t>(j)].parent; };
  auto P = [&](int j) { return t.p[static_cast<std::size_t>(j)]; };
  int head_branch = -1;
  double best = -HUGE_VAL;
  for (int c : ends) {
    const glm::dvec3 d = end_point(c) - P(parent(c)), up = P(parent(c)) - P(hips);
    const double cosine = glm::dot(d, up) / std::max(1e-300, glm::length(d) * glm::length(up));
    if (cosine > best) {
      best = cosine;
      head_branch = c;
    }
  }
  std::vector<int> arms;
  for (int c : ends) {
    if (c != head_branch) arms.push_back(c);
  }
  std::sort(arms.begin(), arms.end(),
            [&](int a, int b) { return t.len(parent(a), a) > t.len(parent(b), b); });
  std::array<std::array<int, 3>, 2> arm{}, leg{};
  for (int k = 0; k < 2; ++k) {
    const int a = arms[static_cast<std::size_t>(k)], l = legs[static_cast<std::size_t>(k)];
    arm[static_cast<std::size_t>(k)] = fit_limb(t, parent(a), t.chain(a), 0.87, 0.34);
    leg[static_cast<std::size_t>(k)] = fit_limb(t, hips, t.chain(l), 1.0, 0.23);
    if (arm[static_cast<std::size_t>(k)][0] < 0) return "no shoulder, elbow and wrist on an arm's chain";
    if (leg[static_cast<std::size_t>(k)][0] < 0) return "no hip, knee and ankle on a leg's chain";
  }
  // Head: on its chain (after the first joint, the neck), the joint nearest a tenth of the body's
  // height (twice the leg) above the neck's base, the skull's base; a chain of one joint is the head
  // on the spine.
  std::vector<int> hc;
  for (int c : t.chain(head_branch)) {
    if (!t.sk.joints[static_cast<std::size_t>(c)].end_site) hc.push_back(c);
  }
  int head = hc.front(), neck = parent(hc.front());
  if (hc.size() >= 2) {
    neck = hc.front();
    const double body = 2 * (t.seg(leg[0][0], leg[0][1]) + t.seg(leg[0][1], leg[0][2]));
    double nearest = HUGE_VAL;
    for (std::size_t i = 1; i < hc.size(); ++i) {
      const double d = std::abs(t.seg(neck, hc[i]) - 0.1 * body);
      if (d < nearest) {
        nearest = d;
        head = hc[i];
      }
    }
  }
  // Left and right: forward from the feet (ankle -> the next joint on the leg's chain).
  const glm::dvec3 up = P(head) - P(hips);
  glm::dvec3 forward(0, 0, 0);
  for (const auto& lg : leg) {
    const int toe = t.longest_child(lg[2]);
    if (toe >= 0) forward += P(toe) - P(lg[2]);
  }
  forward -= up * (glm::dot(forward, up) / std::max(1e-300, glm::dot(up, up)));
  if (!(glm::length(forward) > 0.01 * t.size))
    return "cannot tell left from right: no toe joint or End Site shows where the feet point";
  const glm::dvec3 left = glm::cross(up, forward);
  auto side_of = [&](const std::array<int, 3>& limb) {
    return glm::dot(P(limb[0]) + P(limb[1]) + P(limb[2]), left);
  };
  if (side_of(arm[0]) < side_of(arm[1])) std::swap(arm[0], arm[1]);
  if (side_of(leg[0]) < side_of(leg[1])) std::swap(leg[0], leg[1]);
  auto set = [&](Joint j, int v) { (*anchor)[static_cast<std::size_t>(j)] = v; };
  set(Joint::hips, hips);
  set(Joint::neck, neck);
  set(Joint::head, head);
  const Joint arm_joints[2][3] = {{Joint::l_shoulder, Joint::l_elbow, Joint::l_wrist},
                                  {Joint::r_shoulder, Joint::r_elbow, Joint::r_wrist}};
  const Joint leg_joints[2][3] = {{Joint::l_hip, Joint::l_knee, Joint::l_ankle},
                                  {Joint::r_hip, Joint::r_knee, Joint::r_ankle}};
  for (std::size_t s = 0; s < 2; ++s) {
    for (std::size_t i = 0; i < 3; ++i) {
      set(arm_joints[s][i], arm[s][i]);
      set(leg_joints[s][i], leg[s][i]);
    }
  }
  return "";
}

}  // namespace

bool HumanoidOptions::valid(std::string* why) const {
  std::ostringstream os;
  if (!(height_m >= 0.5 && height_m <= 2.5)) {
    os << "height_m must be in [0.5, 2.5], got " << height_m;
  } else if (!(toe_height_m >= 0 && toe_height_m <= 0.5)) {
    os << "toe_height_m must be in [0, 0.5]";
  } else if (!(scale >= 0 && scale <= 100)) {
    os << "scale must be in [0, 100] (0: by convention)";
  } else if (!(frame_time_s >= 0 && frame_time_s <= 10)) {
    os << "frame_time_s must be in [0, 10] (0: from the file)";
  } else if (!(start_within_x_m >= 0 && start_within_x_m <= 1000 && start_within_y_m >= 0 &&
               start_within_y_m <= 1000)) {
    os << "start_within_x_m and start_within_y_m must be in [0, 1000] (0: centred)";
  } else {
    return true;
  }
  if (why) *why = os.str();
  return false;
}

double HumanoidClip::length_s() const {
  return (clip.frames - 1 - map.first_frame) * map.frame_time_s;
}

Pose HumanoidClip::frame_pose(int frame) const {
  Pose pose = clip.pose(frame, map.scale);
  pad_pose(skeleton, &pose);
  const glm::dvec3 root_offset = clip.skeleton.joints[0].offset * map.scale;
  pose.root_position = map.R_world_from_file * (pose.root_position + root_offset) + map.t_world_m;
  pose.local[0] = map.R_world_from_file * pose.local[0];
  return pose;
}

Pose HumanoidClip::sample(double tau, bool loop) const {
  const int first = map.first_frame, last = clip.frames - 1;
  double f = first + std::max(0.0, tau) / map.frame_time_s;
  if (f > last) {
    if (loop && last > first) {
      f = first + std::fmod(f - first, static_cast<double>(last - first + 1));
    } else {
      return frame_pose(last);
    }
  }
  const int i = static_cast<int>(std::floor(f));
  const double a = f - i;
  if (a < 1e-9 || i >= last) return frame_pose(std::min(i, last));
  if (a > 1 - 1e-9) return frame_pose(i + 1);
  return blend(frame_pose(i), frame_pose(i + 1), a);
}

HumanoidClip map_humanoid(BvhClip clip, const std::string& path, const HumanoidOptions& opt) {
  std::string why;
  if (!opt.valid(&why)) throw std::invalid_argument("humanoid: " + why);
  const Skeleton& fsk = clip.skeleton;
  if (clip.frames < 1) throw std::runtime_error(path + ": the clip has no frames");
  const std::size_t n = fsk.joints.size();
  // A rig prefix: the first word of more than half of the (at least 8) named joints.
  std::string rig_prefix;
  {
    std::map<std::string, int> first_words;
    int named = 0;
    for (const auto& jt : fsk.joints) {
      if (jt.end_site) continue;
      const std::vector<std::string> w = words_of(jt.name);
      ++named;
      if (w.size() > 1 && !is_side_word(w.front())) ++first_words[w.front()];
    }
    for (const auto& [word, count] : first_words) {
      if (named >= 8 && 2 * count > named) rig_prefix = word;
    }
  }
  std::vector<JointName> names(n);
  std::vector<int> depth(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    if (!fsk.joints[j].end_site) names[j] = parse_name(fsk.joints[j].name, rig_prefix);
    if (fsk.joints[j].parent >= 0) depth[j] = depth[static_cast<std::size_t>(fsk.joints[j].parent)] + 1;
  }
  auto key_is = [&](std::size_t j, const std::string& k) { return names[j].key == k; };
  const bool has_arm =
      std::any_of(names.begin(), names.end(), [](const JointName& x) { return x.key == "arm"; });
  const bool has_elbow =
      std::any_of(names.begin(), names.end(), [](const JointName& x) { return x.key == "elbow"; });
  bool lhip = false, rhip = false;
  for (std::size_t j = 0; j < n; ++j) {
    lhip |= names[j].side == Side::left && key_is(j, "hipjoint");
    rhip |= names[j].side == Side::right && key_is(j, "hipjoint");
  }
  const bool cgspeed = lhip && rhip;
  const bool max3ds = has_elbow && !has_arm;
  std::string convention = cgspeed ? (max3ds ? "cgspeed-3dsmax" : "cgspeed-motionbuilder") : "generic";

  auto is_ancestor = [&](int a, int d) {
    for (int k = fsk.joints[static_cast<std::size_t>(d)].parent; k >= 0;
         k = fsk.joints[static_cast<std::size_t>(k)].parent) {
      if (k == a) return true;
    }
    return false;
  };
  // The named mapping fails with this (caught below: then the hierarchy decides).
  struct NamesFail {
    std::string what;
  };
  auto fail_missing = [&](Joint sj, const std::string& looked_for) -> int {
    throw NamesFail{"no joint for " + std::string(joint_name(sj)) + " (looked for " + looked_for + ")"};
  };
  // The topmost joint (then the first in the file) of a side whose key is in the family, below
  // `below` when given.
  auto topmost = [&](Side side, const std::vector<std::string>& family, int below) {
    int best = -1;
    for (std::size_t j = 0; j < n; ++j) {
      if (fsk.joints[j].end_site || names[j].side != side || !in(family, names[j].key)) continue;
      if (below >= 0 && !is_ancestor(below, static_cast<int>(j))) continue;
      if (best < 0 || depth[j] < depth[static_cast<std::size_t>(best)]) best = static_cast<int>(j);
    }
    return best;
  };
  // The nearest ancestor of j whose key is in the family.
  auto nearest_above = [&](int j, const std::vector<std::string>& family) {
    for (int k = fsk.joints[static_cast<std::size_t>(j)].parent; k >= 0;
         k = fsk.joints[static_cast<std::size_t>(k)].parent) {
      if (in(family, names[static_cast<std::size_t>(k)].key)) return k;
    }
    return -1;
  };
  auto first_child = [&](int j) {
    for (std::size_t c = 0; c < n; ++c) {
      if (fsk.joints[c].parent == j) return static_cast<int>(c);
    }
    return -1;
  };

  // Rest pose in file units: the hierarchy's geometry, up axis, height, spine.
  std::vector<glm::dvec3> p_rest;
  forward_kinematics(fsk, rest_pose(fsk), &p_rest);
  const Tree tree(fsk, p_rest);

  BvhMapping map;
  auto set = [&](Joint sj, int file_joint) { map.anchor[static_cast<std::size_t>(sj)] = file_joint; };
  auto get = [&](Joint sj) { return map.anchor[static_cast<std::size_t>(sj)]; };
  const std::pair<Joint, Joint> chains[] = {
      {Joint::hips, Joint::neck},          {Joint::neck, Joint::head},
      {Joint::l_shoulder, Joint::l_elbow}, {Joint::l_elbow, Joint::l_wrist},
      {Joint::r_shoulder, Joint::r_elbow}, {Joint::r_elbow, Joint::r_wrist},
      {Joint::hips, Joint::l_hip},         {Joint::l_hip, Joint::l_knee},
      {Joint::l_knee, Joint::l_ankle},     {Joint::hips, Joint::r_hip},
      {Joint::r_hip, Joint::r_knee},       {Joint::r_knee, Joint::r_ankle},
      {Joint::hips, Joint::l_shoulder},    {Joint::hips, Joint::r_shoulder}};

  std::string names_error;
  int neck = -1, head = -1;
  try {
    // Head and neck (no side): the topmost head, the topmost neck above it (lowerneck before Neck).
    static const std::regex kHead("^head[0-9]*$");
    for (std::size_t j = 0; j < n; ++j) {
      if (!fsk.joints[j].end_site && names[j].side == Side::none && std::regex_match(names[j].key, kHead) &&
          (head < 0 || depth[j] < depth[static_cast<std::size_t>(head)])) {
        head = static_cast<int>(j);
      }
    }
    if (head < 0) fail_missing(Joint::head, "head");
    for (int k = fsk.joints[static_cast<std::size_t>(head)].parent; k >= 0;
         k = fsk.joints[static_cast<std::size_t>(k)].parent) {
      const std::string& key = names[static_cast<std::size_t>(k)].key;
      if (key.rfind("neck", 0) == 0 || key == "lowerneck" || key == "upperneck") neck = k;
    }
    // No neck joint (a head straight on the spine): the head's parent stands in for it.
    if (neck < 0 && fsk.joints[static_cast<std::size_t>(head)].parent > 0)
      neck = fsk.joints[static_cast<std::size_t>(head)].parent;
    if (neck < 0) fail_missing(Joint::neck, "neck, neck1, lowerneck or a parent of the head");
    set(Joint::head, head);
    set(Joint::neck, neck);

    // Limbs from their ends upwards.
    struct Limb {
      Joint end, mid, root;
      const std::vector<std::string>*end_f, *mid_f, *root_f;
      Side side;
    };
    const Limb limbs[] = {
        {Joint::l_wrist, Joint::l_elbow, Joint::l_shoulder, &kWrist, &kElbow, &kShoulder, Side::left},
        {Joint::r_wrist, Joint::r_elbow, Joint::r_shoulder, &kWrist, &kElbow, &kShoulder, Side::right},
        {Joint::l_ankle, Joint::l_knee, Joint::l_hip, &kAnkle, &kKnee, &kHip, Side::left},
        {Joint::r_ankle, Joint::r_knee, Joint::r_hip, &kAnkle, &kKnee, &kHip, Side::right},
    };
    for (const Limb& L : limbs) {
      const std::string side = L.side == Side::left ? "left " : "right ";
      const int end = topmost(L.side, *L.end_f, -1);
      if (end < 0) fail_missing(L.end, side + list_of(*L.end_f));
      const int mid = nearest_above(end, *L.mid_f);
      if (mid < 0)
        fail_missing(L.mid, list_of(*L.mid_f) + " above " + fsk.joints[static_cast<std::size_t>(end)].name);
      const int root = nearest_above(mid, *L.root_f);
      if (root < 0)
        fail_missing(L.root, list_of(*L.root_f) + " above " + fsk.joints[static_cast<std::size_t>(mid)].name);
      set(L.end, end);
      set(L.mid, mid);
      set(L.root, root);
    }
    // Hips: the topmost hips/pelvis joint above both legs, else the joint where the legs meet.
    int hips = -1;
    for (std::size_t j = 0; j < n; ++j) {
      const int jj = static_cast<int>(j);
      if (fsk.joints[j].end_site || names[j].side != Side::none || !in(kHips, names[j].key)) continue;
      if (!is_ancestor(jj, get(Joint::l_hip)) || !is_ancestor(jj, get(Joint::r_hip)) ||
          !is_ancestor(jj, neck))
        continue;
      if (hips < 0 || depth[j] < depth[static_cast<std::size_t>(hips)]) hips = jj;
    }
    if (hips < 0) {
      for (int k = fsk.joints[static_cast<std::size_t>(get(Joint::l_hip))].parent; k >= 0;
           k = fsk.joints[static_cast<std::size_t>(k)].parent) {
        if (is_ancestor(k, get(Joint::r_hip)) && is_ancestor(k, neck)) {
          hips = k;
          break;
        }
      }
    }
    if (hips < 0) fail_missing(Joint::hips, list_of(kHips) + " or the joint above both legs and the neck");
    set(Joint::hips, hips);
    // Ancestry checks: the mapped joints must form the expected chains.
    for (const auto& [a, d] : chains) {
      if (!is_ancestor(get(a), get(d))) {
        throw NamesFail{std::string(joint_name(d)) + " (" +
                        fsk.joints[static_cast<std::size_t>(get(d))].name + ") is not below " +
                        std::string(joint_name(a)) + " (" +
                        fsk.joints[static_cast<std::size_t>(get(a))].name + ")"};
      }
    }
  } catch (const NamesFail& e) {
    names_error = e.what;
  }
  const bool by_names = names_error.empty();
  if (!by_names) {
    map.anchor.fill(-1);
    const std::string why_not = map_by_hierarchy(tree, &map.anchor);
    if (!why_not.empty()) {
      throw std::runtime_error(path + ": not a humanoid hierarchy: " + names_error +
                               "; by the hierarchy: " + why_not);
    }
    convention = "hierarchy";
    head = get(Joint::head);
    neck = get(Joint::neck);
  }
  // Toes: a toe joint below the ankle (by name), else the next joint on the ankle's longest chain
  // (a toe or an End Site), else made up below (-1 here).
  for (const auto& [toe, ankle, side] : {std::tuple{Joint::l_toe, Joint::l_ankle, Side::left},
                                         std::tuple{Joint::r_toe, Joint::r_ankle, Side::right}}) {
    int t = -1;
    if (by_names) {
      t = topmost(side, kToe, get(ankle));
      if (t < 0) t = topmost(Side::none, kToe, get(ankle));
    }
    if (t < 0) t = tree.longest_child(get(ankle));
    set(toe, t);
  }
  map.head_end = first_child(head);
  // The hand's aim target: the first joint down the hand's first-child chain with a non-zero
  // offset from the wrist (CMU's LeftFingerBase sits on the wrist).
  auto hand_end = [&](Joint wrist) {
    const int w = get(wrist);
    for (int c = first_child(w); c >= 0; c = first_child(c)) {
      if (glm::length(rest_vector(fsk, w, c)) > 1e-9) return c;
    }
    return -1;
  };
  map.l_hand_end = hand_end(Joint::l_wrist);
  map.r_hand_end = hand_end(Joint::r_wrist);
  auto P0 = [&](Joint j) { return p_rest[static_cast<std::size_t>(get(j))]; };
  const glm::dvec3 up_vec = P0(Joint::head) - P0(Joint::hips);
  int up_axis = 0;
  for (int a = 1; a < 3; ++a) {
    if (std::abs(up_vec[a]) > std::abs(up_vec[up_axis])) up_axis = a;
  }
  glm::dvec3 up_file(0, 0, 0);
  up_file[up_axis] = up_vec[up_axis] > 0 ? 1 : -1;
  const glm::dmat3 A_rest = rot_between(up_file, {0, 0, 1});
  // Kept placement: the file is in the world frame already.
  const glm::dmat3 A_axis = opt.keep_placement ? glm::dmat3(1.0) : A_rest;
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (const auto& p : p_rest) {
    lo = std::min(lo, glm::dot(p, up_file));
    hi = std::max(hi, glm::dot(p, up_file));
  }
  double scale = opt.scale;
  std::string units = "given";
  if (scale <= 0) {
    const double h = hi - lo;
    // (A file kept in the world frame is in metres.)
    if (opt.keep_placement || (!cgspeed && h >= 1.0 && h <= 2.3)) {
      scale = 1;
      units = "m";
    } else if (cgspeed) {
      scale = kCmuMetresPerUnit;
      units = "cmu";
    } else if (h >= 100 && h <= 230) {
      scale = 0.01;
      units = "cm";
    } else if (h >= 1000 && h <= 2300) {
      scale = 0.001;
      units = "mm";
    } else if (h >= 50 && h <= 85) {
      scale = kMetresPerInch;
      units = "in";
    } else {
      if (!(h > 0)) throw std::runtime_error(path + ": the rest pose has no height");
      scale = opt.height_m / h;
      units = "height";
    }
  }
  // A rest pose of 1e-300 scaled to a body's height multiplies every position channel by 1e300: the
  // truth would be inf and NaN. Refused: no file unit is below a micrometre (scale <= 1e6), and the
  // scaled body stays within 1 km.
  if (!(scale > 0 && scale <= 1e6) || !((hi - lo) * scale <= 1000.0)) {
    std::ostringstream os;
    os << path << ": the rest pose (height " << (hi - lo) << " file units) at scale " << scale
       << " metres per unit is not a body (the scale must be in (0, 1e6] and the body under 1 km)";
    throw std::runtime_error(os.str());
  }
  {
    // spine: the joint strictly between hips and neck nearest their midpoint (else hips).
    const int hips = get(Joint::hips);
    const glm::dvec3 mid =
        0.5 * (p_rest[static_cast<std::size_t>(hips)] + p_rest[static_cast<std::size_t>(neck)]);
    int best = hips;
    double best_d = HUGE_VAL;
    for (int k = fsk.joints[static_cast<std::size_t>(neck)].parent; k >= 0 && k != hips;
         k = fsk.joints[static_cast<std::size_t>(k)].parent) {
      const double d = glm::length(p_rest[static_cast<std::size_t>(k)] - mid);
      if (d < best_d) {
        best_d = d;
        best = k;
      }
    }
    set(Joint::spine, best);
  }
  // voxcap's own skeleton (the standard joints under their own names, as voxcap sim writes
  // truth/motion.bvh): every standard joint is a file joint, the End Sites included.
  bool own = by_names;
  for (int j = 0; j < kJointCount && own; ++j) {
    if (joint_is_end(j)) continue;
    const int a = map.anchor[static_cast<std::size_t>(j)];
    own = fsk.joints[static_cast<std::size_t>(a)].name == joint_name(j);
  }
  if (own) convention = "voxcap";

  set(Joint::head_top, head);
  set(Joint::l_hand_tip, get(Joint::l_wrist));
  set(Joint::r_hand_tip, get(Joint::r_wrist));

  // Frames: synthetic T-pose, frame time.
  int first = 0;
  auto all_integer_rotations = [&](int f) {
    const double* v = clip.frame_values(f);
    for (std::size_t j = 0; j < n; ++j) {
      for (std::size_t c = 0; c < clip.channels[j].size(); ++c) {
        const BvhChannel ch = clip.channels[j][c];
        if (ch == BvhChannel::Xposition || ch == BvhChannel::Yposition || ch == BvhChannel::Zposition)
          continue;
        const double x = v[clip.first_channel[j] + static_cast<int>(c)];
        if (std::abs(x - std::round(x)) > 1e-9) return false;
      }
    }
    return true;
  };
  if (clip.frames >= 2 && all_integer_rotations(0) && !all_integer_rotations(1)) first = 1;
  double ft = opt.frame_time_s;
  if (ft <= 0) {
    ft = clip.frame_time_s;
    // ".0083333" and ".03333" are 1/120 and 1/30 cut to the digits written: snap when 1/n is
    // within one unit of the last written digit.
    const double fps = std::round(1.0 / ft);
    const double unit = clip.frame_time_decimals > 0 ? std::pow(10.0, -clip.frame_time_decimals) : 1e-9;
    if (fps >= 1 && std::abs(ft - 1.0 / fps) < unit) ft = 1.0 / fps;
    const std::string stem = std::filesystem::path(path).stem().string();
    static const std::regex k60fps("^(75|88|141|143)_[0-9]+$");
    if (cgspeed && std::regex_match(stem, k60fps)) ft = 1.0 / 60.0;
  }

  // World skeleton: offsets in metres, file axes; the root offset goes into the root position.
  HumanoidClip out;
  out.skeleton = clip.scaled_skeleton(scale);
  const glm::dvec3 root_offset = out.skeleton.joints[0].offset;
  out.skeleton.joints[0].offset = glm::dvec3(0, 0, 0);
  // A foot without a toe joint or End Site gets one (an End Site appended to the skeleton): in the
  // rest pose, forward (where the performer faces) 0.16 and down 0.07 of the leg's length from the
  // ankle, the standard skeleton's proportions.
  for (const auto& [toe, hip, knee, ankle] :
       {std::tuple{Joint::l_toe, Joint::l_hip, Joint::l_knee, Joint::l_ankle},
        std::tuple{Joint::r_toe, Joint::r_hip, Joint::r_knee, Joint::r_ankle}}) {
    if (get(toe) >= 0) continue;
    const glm::dvec3 left_rest =
        (P0(Joint::l_hip) - P0(Joint::r_hip)) + (P0(Joint::l_shoulder) - P0(Joint::r_shoulder));
    glm::dvec3 fwd = glm::cross(left_rest, up_file);
    if (!(glm::length(fwd) > 0))
      throw std::runtime_error(path + ": cannot tell where the feet point (no toe joints)");
    fwd /= glm::length(fwd);
    const double leg = glm::length(P0(knee) - P0(hip)) + glm::length(P0(ankle) - P0(knee));
    const glm::dvec3 offset = scale * leg * (0.16 * fwd - 0.07 * up_file);
    out.skeleton.joints.push_back(
        {fsk.joints[static_cast<std::size_t>(get(ankle))].name + "_toe", get(ankle), offset, true});
    set(toe, static_cast<int>(out.skeleton.joints.size()) - 1);
  }
  auto placed = [&](int f, const glm::dmat3& Rg) {
    Pose p = clip.pose(f, scale);
    pad_pose(out.skeleton, &p);
    p.root_position = Rg * (p.root_position + root_offset);
    p.local[0] = Rg * p.local[0];
    return p;
  };
  auto idx = [&](Joint j) { return static_cast<std::size_t>(get(j)); };
  auto yaw_to_front = [&](const std::vector<glm::dvec3>& p) {
    // Rotation about z taking the performer's left (hips and shoulders) to +x: facing -y.
    const glm::dvec3 left = (p[idx(Joint::l_hip)] - p[idx(Joint::r_hip)]) +
                            (p[idx(Joint::l_shoulder)] - p[idx(Joint::r_shoulder)]);
    if (std::hypot(left[0], left[1]) < 1e-9) return glm::dmat3(1.0);
    return rot_z(-std::atan2(left[1], left[0]));
  };
  std::vector<glm::dvec3> p;
  forward_kinematics(out.skeleton, placed(first, A_axis), &p);
  const glm::dmat3 Rg = opt.keep_placement ? glm::dmat3(1.0) : yaw_to_front(p) * A_axis;
  // Centre the root path, put the lowest toe of the clip at toe_height_m.
  double xmin = HUGE_VAL, xmax = -HUGE_VAL, ymin = HUGE_VAL, ymax = -HUGE_VAL, toe_min = HUGE_VAL;
  glm::dvec3 root_first(0, 0, 0);
  for (int f = first; f < clip.frames; ++f) {
    forward_kinematics(out.skeleton, placed(f, Rg), &p);
    if (f == first) root_first = p[0];
    xmin = std::min(xmin, p[0][0]);
    xmax = std::max(xmax, p[0][0]);
    ymin = std::min(ymin, p[0][1]);
    ymax = std::max(ymax, p[0][1]);
    toe_min = std::min({toe_min, p[idx(Joint::l_toe)][2], p[idx(Joint::r_toe)][2]});
  }
  // The rest pose stood upright and turned to face -y.
  {
    Pose rest = rest_pose(out.skeleton);
    rest.local[0] = A_rest;
    forward_kinematics(out.skeleton, rest, &p);
    out.R_world_from_rest = yaw_to_front(p) * A_rest;
  }

  map.convention = convention;
  map.units = units;
  map.scale = scale;
  map.R_world_from_file = Rg;
  map.t_world_m = opt.keep_placement
                      ? glm::dvec3(0, 0, 0)
                      : glm::dvec3(-0.5 * (xmin + xmax), -0.5 * (ymin + ymax), opt.toe_height_m - toe_min);
  if (!opt.keep_placement) {
    // The start in the volume: the centred path moved by the first root's excess over the limit.
    const double limit[2] = {opt.start_within_x_m, opt.start_within_y_m};
    for (int a = 0; a < 2; ++a) {
      const double s = root_first[a] + map.t_world_m[a];
      if (limit[a] > 0 && std::abs(s) > limit[a]) map.t_world_m[a] -= s - std::copysign(limit[a], s);
    }
  }
  map.frame_time_s = ft;
  map.first_frame = first;
  map.frames = clip.frames;
  for (int j = 0; j < kJointCount; ++j)
    map.file_joint[static_cast<std::size_t>(j)] = map.anchor[static_cast<std::size_t>(j)];
  if (map.head_end >= 0 && !own) map.file_joint[static_cast<std::size_t>(Joint::head)] = -1;
  for (const auto& [j, end] :
       {std::pair{Joint::head_top, map.head_end}, std::pair{Joint::l_hand_tip, map.l_hand_end},
        std::pair{Joint::r_hand_tip, map.r_hand_end}}) {
    // voxcap's own End Sites are the end points; others are placed from frames.
    map.file_joint[static_cast<std::size_t>(j)] =
        own && end >= 0 && fsk.joints[static_cast<std::size_t>(end)].end_site ? end : -1;
  }
  for (int j = 0; j < kJointCount; ++j) {
    const int fj = map.file_joint[static_cast<std::size_t>(j)];
    if (fj >= static_cast<int>(n)) map.file_joint[static_cast<std::size_t>(j)] = -1;  // a made-up toe
    const int g = map.file_joint[static_cast<std::size_t>(j)];
    map.file_joint_name[static_cast<std::size_t>(j)] =
        g >= 0 ? fsk.joints[static_cast<std::size_t>(g)].name : "";
  }
  out.map = std::move(map);
  out.clip = std::move(clip);
  return out;
}

HumanoidClip read_humanoid(const std::string& path, const HumanoidOptions& options) {
  if (!std::filesystem::is_regular_file(path)) throw std::runtime_error(path + ": no such BVH file");
  return map_humanoid(read_bvh(path), path, options);
}

}  // namespace vc::body
