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
  const std::string convention = cgspeed ? (max3ds ? "cgspeed-3dsmax" : "cgspeed-motionbuilder") : "generic";

  auto is_ancestor = [&](int a, int d) {
    for (int k = fsk.joints[static_cast<std::size_t>(d)].parent; k >= 0;
         k = fsk.joints[static_cast<std::size_t>(k)].parent) {
      if (k == a) return true;
    }
    return false;
  };
  auto fail_missing = [&](Joint sj, const std::string& looked_for) -> int {
    throw std::runtime_error(path + ": not a humanoid hierarchy: no joint for " +
                             std::string(joint_name(sj)) + " (looked for " + looked_for + ")");
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

  BvhMapping map;
  auto set = [&](Joint sj, int file_joint) { map.anchor[static_cast<std::size_t>(sj)] = file_joint; };
  auto get = [&](Joint sj) { return map.anchor[static_cast<std::size_t>(sj)]; };

  // Head and neck (no side): the topmost head, the topmost neck above it (lowerneck before Neck).
  static const std::regex kHead("^head[0-9]*$");
  int head = -1;
  for (std::size_t j = 0; j < n; ++j) {
    if (!fsk.joints[j].end_site && names[j].side == Side::none && std::regex_match(names[j].key, kHead) &&
        (head < 0 || depth[j] < depth[static_cast<std::size_t>(head)])) {
      head = static_cast<int>(j);
    }
  }
  if (head < 0) fail_missing(Joint::head, "head");
  int neck = -1;
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
  {
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
  }
  // Toes: a toe joint below the ankle, else the ankle's first child (an End Site).
  for (const auto& [toe, ankle, side] : {std::tuple{Joint::l_toe, Joint::l_ankle, Side::left},
                                         std::tuple{Joint::r_toe, Joint::r_ankle, Side::right}}) {
    int t = topmost(side, kToe, get(ankle));
    if (t < 0) t = topmost(Side::none, kToe, get(ankle));
    if (t < 0) t = first_child(get(ankle));
    if (t < 0) {
      throw std::runtime_error(path + ": the " + std::string(joint_name(ankle)) +
                               " joint has no toe or End Site");
    }
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
  // Ancestry checks: the mapped joints must form the expected chains.
  const std::pair<Joint, Joint> chains[] = {
      {Joint::hips, Joint::neck},          {Joint::neck, Joint::head},
      {Joint::l_shoulder, Joint::l_elbow}, {Joint::l_elbow, Joint::l_wrist},
      {Joint::r_shoulder, Joint::r_elbow}, {Joint::r_elbow, Joint::r_wrist},
      {Joint::hips, Joint::l_hip},         {Joint::l_hip, Joint::l_knee},
      {Joint::l_knee, Joint::l_ankle},     {Joint::l_ankle, Joint::l_toe},
      {Joint::hips, Joint::r_hip},         {Joint::r_hip, Joint::r_knee},
      {Joint::r_knee, Joint::r_ankle},     {Joint::r_ankle, Joint::r_toe},
      {Joint::hips, Joint::l_shoulder},    {Joint::hips, Joint::r_shoulder}};
  for (const auto& [a, d] : chains) {
    if (!is_ancestor(get(a), get(d))) {
      throw std::runtime_error(path + ": not a humanoid hierarchy: " + std::string(joint_name(d)) + " (" +
                               fsk.joints[static_cast<std::size_t>(get(d))].name + ") is not below " +
                               std::string(joint_name(a)) + " (" +
                               fsk.joints[static_cast<std::size_t>(get(a))].name + ")");
    }
  }

  // Rest pose in file units: up axis, height, spine.
  std::vector<glm::dvec3> p_rest;
  forward_kinematics(fsk, rest_pose(fsk), &p_rest);
  auto P0 = [&](Joint j) { return p_rest[static_cast<std::size_t>(get(j))]; };
  const glm::dvec3 up_vec = P0(Joint::head) - P0(Joint::hips);
  int up_axis = 0;
  for (int a = 1; a < 3; ++a) {
    if (std::abs(up_vec[a]) > std::abs(up_vec[up_axis])) up_axis = a;
  }
  glm::dvec3 up_file(0, 0, 0);
  up_file[up_axis] = up_vec[up_axis] > 0 ? 1 : -1;
  const glm::dmat3 A_axis = rot_between(up_file, {0, 0, 1});
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (const auto& p : p_rest) {
    lo = std::min(lo, glm::dot(p, up_file));
    hi = std::max(hi, glm::dot(p, up_file));
  }
  double scale = opt.scale;
  std::string units = "given";
  if (scale <= 0) {
    const double h = hi - lo;
    if (cgspeed) {
      scale = kCmuMetresPerUnit;
      units = "cmu";
    } else if (h >= 1.0 && h <= 2.3) {
      scale = 1;
      units = "m";
    } else if (h >= 100 && h <= 230) {
      scale = 0.01;
      units = "cm";
    } else if (h >= 1000 && h <= 2300) {
      scale = 0.001;
      units = "mm";
    } else {
      if (!(h > 0)) throw std::runtime_error(path + ": the rest pose has no height");
      scale = opt.height_m / h;
      units = "height";
    }
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
  auto placed = [&](int f, const glm::dmat3& Rg) {
    Pose p = clip.pose(f, scale);
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
  const glm::dmat3 Rg = yaw_to_front(p) * A_axis;
  // Centre the root path, put the lowest toe of the clip at toe_height_m.
  double xmin = HUGE_VAL, xmax = -HUGE_VAL, ymin = HUGE_VAL, ymax = -HUGE_VAL, toe_min = HUGE_VAL;
  for (int f = first; f < clip.frames; ++f) {
    forward_kinematics(out.skeleton, placed(f, Rg), &p);
    xmin = std::min(xmin, p[0][0]);
    xmax = std::max(xmax, p[0][0]);
    ymin = std::min(ymin, p[0][1]);
    ymax = std::max(ymax, p[0][1]);
    toe_min = std::min({toe_min, p[idx(Joint::l_toe)][2], p[idx(Joint::r_toe)][2]});
  }
  // The rest pose stood upright and turned to face -y.
  {
    Pose rest = rest_pose(out.skeleton);
    rest.local[0] = A_axis;
    forward_kinematics(out.skeleton, rest, &p);
    out.R_world_from_rest = yaw_to_front(p) * A_axis;
  }

  map.convention = convention;
  map.units = units;
  map.scale = scale;
  map.R_world_from_file = Rg;
  map.t_world_m = glm::dvec3(-0.5 * (xmin + xmax), -0.5 * (ymin + ymax), opt.toe_height_m - toe_min);
  map.frame_time_s = ft;
  map.first_frame = first;
  map.frames = clip.frames;
  for (int j = 0; j < kJointCount; ++j)
    map.file_joint[static_cast<std::size_t>(j)] = map.anchor[static_cast<std::size_t>(j)];
  if (map.head_end >= 0) map.file_joint[static_cast<std::size_t>(Joint::head)] = -1;
  for (Joint j : {Joint::head_top, Joint::l_hand_tip, Joint::r_hand_tip})
    map.file_joint[static_cast<std::size_t>(j)] = -1;
  for (int j = 0; j < kJointCount; ++j) {
    const int fj = map.file_joint[static_cast<std::size_t>(j)];
    map.file_joint_name[static_cast<std::size_t>(j)] =
        fj >= 0 ? fsk.joints[static_cast<std::size_t>(fj)].name : "";
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
