// Motion: the lead-in (initialization pose, then a slerp blend into the motion), the mapping of
// BVH clips onto the standard joints, and the standard joints of a pose.
//
// BVH mapping (documented in hw/sim/README.md):
//  - joints by name: cgspeed "MotionBuilder-friendly" (LeftArm/LeftForeArm/LeftHand,
//    LeftUpLeg/LeftLeg/LeftFoot/LeftToeBase), cgspeed "3dsMax-friendly" (LeftShoulder/LeftElbow/
//    LeftWrist, LeftHip/LeftKnee/LeftAnkle/LeftToe) and generic names of the same family (case,
//    "_" and "prefix:" ignored); spine = the joint between hips and neck closest to their midpoint;
//  - units: cgspeed files are CMU units, 0.056444 m/unit (CMU's 1/0.45 inch); other files are
//    scaled so that the rest pose is body.height_m tall; MotionOptions::bvh_scale overrides;
//  - axes: the rest pose's hips->head axis (+Y in CMU files, +Z in some others) becomes +z, then
//    a rotation about z turns the clip so that the performer faces -y (the front cameras) in its
//    first captured frame; the clip's root path is centred on the volume (x, y) and the lowest
//    toe of the whole clip touches the floor;
//  - frames: frame 0 is skipped when it is a converter's synthetic T-pose (all rotation values
//    integers, unlike frame 1); a frame time within one unit of its last written digit of 1/n is
//    snapped to 1/n (".0083333" is 1/120, ".03333" 1/30);
//    cgspeed files of CMU subjects 75, 88, 141 and 143 (captured at 60 fps, written as 120)
//    use 1/60 s; MotionOptions::bvh_frame_time_s overrides. The clip is resampled to the camera
//    rate by its frame time (slerp between the two neighbouring frames).
#include "voxcap/sim/motion.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <regex>
#include <sstream>
#include <stdexcept>

#include "motion_internal.hpp"
#include "voxcap/sim/bvh.hpp"

namespace vc::sim {
namespace detail {

Poser::Poser(const Skeleton& skeleton, const std::vector<int>& aim_child)
    : sk_(skeleton), aim_child_(aim_child) {
  pose_ = rest_pose(skeleton);
  W_.assign(skeleton.joints.size(), cv::Matx33d::eye());
}

void Poser::root(const cv::Vec3d& position, const cv::Matx33d& R_world) {
  pose_.root_position = position;
  pose_.local[0] = R_world;
  W_[0] = R_world;
  for (std::size_t j = 1; j < W_.size(); ++j) W_[j] = W_[static_cast<std::size_t>(sk_.joints[j].parent)] * pose_.local[j];
}

void Poser::local(int joint, const cv::Matx33d& R_local) {
  const auto j = static_cast<std::size_t>(joint);
  pose_.local[j] = R_local;
  // Children are set after their parents; refresh this joint and its descendants' world frames.
  for (std::size_t k = j; k < W_.size(); ++k) {
    if (k == 0) continue;
    W_[k] = W_[static_cast<std::size_t>(sk_.joints[k].parent)] * pose_.local[k];
  }
}

void Poser::aim(int joint, const cv::Vec3d& d_world, double twist) {
  const auto j = static_cast<std::size_t>(joint);
  const int e = aim_child_[j];
  if (e < 0) throw std::logic_error("Poser::aim: joint has no aim child");
  const cv::Matx33d& Wp = joint == 0 ? cv::Matx33d::eye() : W_[static_cast<std::size_t>(sk_.joints[j].parent)];
  const cv::Vec3d v_world = Wp * rest_vector(sk_, joint, e);
  cv::Matx33d Wj = rot_between(v_world, d_world) * Wp;
  if (twist != 0) Wj = rot_axis(d_world, twist) * Wj;
  local(joint, Wp.t() * Wj);
}

cv::Vec3d rest_vector(const Skeleton& skeleton, int j, int e) {
  cv::Vec3d v(0, 0, 0);
  for (int k = e; k != j; k = skeleton.joints[static_cast<std::size_t>(k)].parent) {
    if (k < 0) throw std::logic_error("rest_vector: not a descendant");
    v += skeleton.joints[static_cast<std::size_t>(k)].offset;
  }
  return v;
}

double lowest_sole_z(const BodyPose& pose, const BodyDescription& body, const FootGeometry& feet) {
  std::vector<Primitive> prims;
  build_primitives(pose, body, feet, &prims);
  double lowest = HUGE_VAL;
  for (const Primitive& p : prims) {
    if (p.part != Part::l_foot && p.part != Part::r_foot && p.part != Part::l_toes && p.part != Part::r_toes) continue;
    // Lowest point of a scaled capsule: the lower core end minus the support along -z.
    const cv::Vec3d axis(p.R(0, 2), p.R(1, 2), p.R(2, 2));
    double support = 0;
    for (int i = 0; i < 3; ++i) support += (p.radii[i] * p.R(2, i)) * (p.radii[i] * p.R(2, i));
    const double core_low = p.center[2] - std::abs(axis[2]) * p.half_length;
    lowest = std::min(lowest, core_low - std::sqrt(support));
  }
  return lowest;
}

BodyPose body_pose_from(const MotionData& m, const Pose& pose) {
  std::vector<cv::Vec3d> p;
  std::vector<cv::Matx33d> W;
  forward_kinematics(m.skeleton, pose, &p, &W);
  BodyPose out;
  for (int j = 0; j < kJointCount; ++j) {
    const JointSource& s = m.sources[static_cast<std::size_t>(j)];
    const auto fj = static_cast<std::size_t>(s.frame_joint);
    const cv::Matx33d R = W[fj] * m.canon[fj];
    cv::Vec3d pj = p[static_cast<std::size_t>(s.a)];
    if (s.b >= 0) pj = pj * (1 - s.w) + p[static_cast<std::size_t>(s.b)] * s.w;
    if (s.canon_offset != cv::Vec3d(0, 0, 0)) pj += R * s.canon_offset;
    out.p_world[static_cast<std::size_t>(j)] = pj;
    out.R_world[static_cast<std::size_t>(j)] = R;
  }
  return out;
}

namespace {

std::string norm_name(const std::string& name) {
  const auto colon = name.rfind(':');
  std::string out;
  for (std::size_t i = colon == std::string::npos ? 0 : colon + 1; i < name.size(); ++i) {
    const auto c = static_cast<unsigned char>(name[i]);
    if (std::isalnum(c)) out += static_cast<char>(std::tolower(c));
  }
  return out;
}

constexpr double kCmuMetresPerUnit = 0.056444;  // CMU: 1 unit = 1/0.45 inch

struct Names {
  std::vector<std::string> hips, neck, head, shoulder, elbow, wrist, hip, knee, ankle, toe;
};

Names names_for(bool max3ds, const char* side) {
  const std::string s = side;
  auto n = [&](std::initializer_list<const char*> list) {
    std::vector<std::string> out;
    for (const char* x : list) out.push_back(s + x);
    return out;
  };
  Names t;
  t.hips = {"hips", "pelvis", "hip"};
  t.head = {"head"};
  if (max3ds) {
    t.neck = {"lowerneck", "neck"};
    t.shoulder = n({"shoulder"});
    t.elbow = n({"elbow"});
    t.wrist = n({"wrist"});
    t.hip = n({"hip"});
    t.knee = n({"knee"});
    t.ankle = n({"ankle"});
    t.toe = n({"toe", "toebase"});
  } else {
    t.neck = {"neck", "neck1", "lowerneck"};
    t.shoulder = n({"arm", "upperarm"});
    t.elbow = n({"forearm", "lowerarm", "elbow"});
    t.wrist = n({"hand", "wrist"});
    t.hip = n({"upleg", "upperleg", "thigh"});
    t.knee = n({"leg", "lowerleg", "shin", "calf", "knee"});
    t.ankle = n({"foot", "ankle"});
    t.toe = n({"toebase", "toe", "toes"});
  }
  return t;
}

struct BvhJoints {
  std::array<int, kJointCount> j{};
  int head_end = -1;
  int l_hand_end = -1, r_hand_end = -1;
};

}  // namespace

void make_bvh(const std::string& path, const MotionOptions& opt, const BodyDescription& body, MotionData* m) {
  if (!std::filesystem::is_regular_file(path)) throw std::runtime_error(path + ": no such BVH file");
  const BvhClip clip = read_bvh(path);
  const Skeleton& fsk = clip.skeleton;
  if (clip.frames < 1) throw std::runtime_error(path + ": the clip has no frames");
  std::vector<std::string> normed;
  for (const auto& j : fsk.joints) normed.push_back(j.end_site ? std::string() : norm_name(j.name));
  auto has = [&](const std::string& n) { return std::find(normed.begin(), normed.end(), n) != normed.end(); };
  auto find_any = [&](const std::vector<std::string>& cands) {
    for (const auto& c : cands) {
      for (std::size_t i = 0; i < normed.size(); ++i) {
        if (normed[i] == c) return static_cast<int>(i);
      }
    }
    return -1;
  };
  const bool max3ds = has("leftelbow") && has("leftshoulder") && !has("leftarm");
  const bool cgspeed = has("lhipjoint") && has("rhipjoint");
  const std::string convention = cgspeed ? (max3ds ? "cgspeed-3dsmax" : "cgspeed-motionbuilder") : "generic";

  const Names L = names_for(max3ds, "left"), R = names_for(max3ds, "right");
  BvhJoints bj;
  auto need = [&](Joint sj, const std::vector<std::string>& cands) {
    const int i = find_any(cands);
    if (i < 0) {
      std::string list;
      for (const auto& c : cands) list += (list.empty() ? "" : ", ") + c;
      throw std::runtime_error(path + ": not a humanoid hierarchy: no joint for " + std::string(joint_name(sj)) +
                               " (looked for " + list + ")");
    }
    bj.j[static_cast<std::size_t>(sj)] = i;
  };
  need(Joint::hips, L.hips);
  need(Joint::neck, L.neck);
  need(Joint::head, L.head);
  need(Joint::l_shoulder, L.shoulder);
  need(Joint::l_elbow, L.elbow);
  need(Joint::l_wrist, L.wrist);
  need(Joint::r_shoulder, R.shoulder);
  need(Joint::r_elbow, R.elbow);
  need(Joint::r_wrist, R.wrist);
  need(Joint::l_hip, L.hip);
  need(Joint::l_knee, L.knee);
  need(Joint::l_ankle, L.ankle);
  need(Joint::r_hip, R.hip);
  need(Joint::r_knee, R.knee);
  need(Joint::r_ankle, R.ankle);
  auto first_child = [&](int j) {
    for (std::size_t c = 0; c < fsk.joints.size(); ++c) {
      if (fsk.joints[c].parent == j) return static_cast<int>(c);
    }
    return -1;
  };
  auto toe_or_end = [&](Joint ankle, const std::vector<std::string>& cands) {
    int t = find_any(cands);
    if (t < 0) t = first_child(bj.j[static_cast<std::size_t>(ankle)]);
    if (t < 0) throw std::runtime_error(path + ": the " + std::string(joint_name(ankle)) + " joint has no toe or End Site");
    return t;
  };
  bj.j[static_cast<std::size_t>(Joint::l_toe)] = toe_or_end(Joint::l_ankle, L.toe);
  bj.j[static_cast<std::size_t>(Joint::r_toe)] = toe_or_end(Joint::r_ankle, R.toe);
  bj.head_end = first_child(bj.j[static_cast<std::size_t>(Joint::head)]);
  // The hand's aim target: the first joint down the hand's first-child chain with a non-zero
  // offset from the wrist (CMU's LeftFingerBase sits on the wrist).
  auto hand_end = [&](Joint wrist) {
    const int w = bj.j[static_cast<std::size_t>(wrist)];
    for (int c = first_child(w); c >= 0; c = first_child(c)) {
      if (cv::norm(rest_vector(fsk, w, c)) > 1e-9) return c;
    }
    return -1;
  };
  bj.l_hand_end = hand_end(Joint::l_wrist);
  bj.r_hand_end = hand_end(Joint::r_wrist);
  // Ancestry checks: the mapped joints must form the expected chains.
  auto is_ancestor = [&](int a, int d) {
    for (int k = fsk.joints[static_cast<std::size_t>(d)].parent; k >= 0; k = fsk.joints[static_cast<std::size_t>(k)].parent) {
      if (k == a) return true;
    }
    return false;
  };
  const std::pair<Joint, Joint> chains[] = {
      {Joint::hips, Joint::neck},         {Joint::neck, Joint::head},         {Joint::l_shoulder, Joint::l_elbow},
      {Joint::l_elbow, Joint::l_wrist},   {Joint::r_shoulder, Joint::r_elbow}, {Joint::r_elbow, Joint::r_wrist},
      {Joint::hips, Joint::l_hip},        {Joint::l_hip, Joint::l_knee},      {Joint::l_knee, Joint::l_ankle},
      {Joint::l_ankle, Joint::l_toe},     {Joint::hips, Joint::r_hip},        {Joint::r_hip, Joint::r_knee},
      {Joint::r_knee, Joint::r_ankle},    {Joint::r_ankle, Joint::r_toe}};
  for (const auto& [a, d] : chains) {
    if (!is_ancestor(bj.j[static_cast<std::size_t>(a)], bj.j[static_cast<std::size_t>(d)])) {
      throw std::runtime_error(path + ": not a humanoid hierarchy: " + std::string(joint_name(d)) + " (" +
                               fsk.joints[static_cast<std::size_t>(bj.j[static_cast<std::size_t>(d)])].name +
                               ") is not below " + std::string(joint_name(a)));
    }
  }

  // Rest pose in file units: up axis, height, spine.
  std::vector<cv::Vec3d> p_rest;
  forward_kinematics(fsk, rest_pose(fsk), &p_rest);
  auto P0 = [&](Joint j) { return p_rest[static_cast<std::size_t>(bj.j[static_cast<std::size_t>(j)])]; };
  const cv::Vec3d up_vec = P0(Joint::head) - P0(Joint::hips);
  int up_axis = 0;
  for (int a = 1; a < 3; ++a) {
    if (std::abs(up_vec[a]) > std::abs(up_vec[up_axis])) up_axis = a;
  }
  cv::Vec3d up_file(0, 0, 0);
  up_file[up_axis] = up_vec[up_axis] > 0 ? 1 : -1;
  const cv::Matx33d A_axis = rot_between(up_file, {0, 0, 1});
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (const auto& p : p_rest) {
    lo = std::min(lo, p.dot(up_file));
    hi = std::max(hi, p.dot(up_file));
  }
  double scale = opt.bvh_scale;
  if (scale <= 0) {
    if (cgspeed) {
      scale = kCmuMetresPerUnit;
    } else {
      if (!(hi - lo > 0)) throw std::runtime_error(path + ": the rest pose has no height");
      scale = body.height_m / (hi - lo);
    }
  }
  {
    // spine: the joint strictly between hips and neck nearest their midpoint (else hips).
    const int hips = bj.j[static_cast<std::size_t>(Joint::hips)], neck = bj.j[static_cast<std::size_t>(Joint::neck)];
    const cv::Vec3d mid = 0.5 * (p_rest[static_cast<std::size_t>(hips)] + p_rest[static_cast<std::size_t>(neck)]);
    int best = hips;
    double best_d = HUGE_VAL;
    for (int k = fsk.joints[static_cast<std::size_t>(neck)].parent; k >= 0 && k != hips;
         k = fsk.joints[static_cast<std::size_t>(k)].parent) {
      const double d = cv::norm(p_rest[static_cast<std::size_t>(k)] - mid);
      if (d < best_d) {
        best_d = d;
        best = k;
      }
    }
    bj.j[static_cast<std::size_t>(Joint::spine)] = best;
  }

  // Frames: synthetic T-pose, frame time.
  int first = 0;
  auto all_integer_rotations = [&](int f) {
    const double* v = clip.frame_values(f);
    for (std::size_t j = 0; j < fsk.joints.size(); ++j) {
      for (std::size_t c = 0; c < clip.channels[j].size(); ++c) {
        const BvhChannel ch = clip.channels[j][c];
        if (ch == BvhChannel::Xposition || ch == BvhChannel::Yposition || ch == BvhChannel::Zposition) continue;
        const double x = v[clip.first_channel[j] + static_cast<int>(c)];
        if (std::abs(x - std::round(x)) > 1e-9) return false;
      }
    }
    return true;
  };
  if (clip.frames >= 2 && all_integer_rotations(0) && !all_integer_rotations(1)) first = 1;
  double ft = opt.bvh_frame_time_s;
  if (ft <= 0) {
    ft = clip.frame_time_s;
    // ".0083333" and ".03333" are 1/120 and 1/30 cut to the digits written: snap when 1/n is
    // within one unit of the last written digit.
    const double n = std::round(1.0 / ft);
    const double unit = clip.frame_time_decimals > 0 ? std::pow(10.0, -clip.frame_time_decimals) : 1e-9;
    if (n >= 1 && std::abs(ft - 1.0 / n) < unit) ft = 1.0 / n;
    const std::string stem = std::filesystem::path(path).stem().string();
    static const std::regex k60fps("^(75|88|141|143)_[0-9]+$");
    if (cgspeed && std::regex_match(stem, k60fps)) ft = 1.0 / 60.0;
  }

  // World skeleton: offsets in metres, file axes; the root offset goes into the root position.
  Skeleton sk = clip.scaled_skeleton(scale);
  const cv::Vec3d root_offset = sk.joints[0].offset;
  sk.joints[0].offset = cv::Vec3d(0, 0, 0);
  auto file_pose = [&](int f) {
    Pose p = clip.pose(f, scale);
    p.root_position += root_offset;
    return p;
  };
  auto placed = [&](Pose p, const cv::Matx33d& Rg, const cv::Vec3d& tg) {
    p.root_position = Rg * p.root_position + tg;
    p.local[0] = Rg * p.local[0];
    return p;
  };
  auto idx = [&](Joint j) { return static_cast<std::size_t>(bj.j[static_cast<std::size_t>(j)]); };
  auto yaw_to_front = [&](const std::vector<cv::Vec3d>& p) {
    // Rotation about z taking the performer's left (hips and shoulders) to +x: facing -y.
    const cv::Vec3d left = (p[idx(Joint::l_hip)] - p[idx(Joint::r_hip)]) +
                           (p[idx(Joint::l_shoulder)] - p[idx(Joint::r_shoulder)]);
    if (std::hypot(left[0], left[1]) < 1e-9) return cv::Matx33d::eye();
    return rot_z(-std::atan2(left[1], left[0]));
  };
  std::vector<cv::Vec3d> p;
  forward_kinematics(sk, placed(file_pose(first), A_axis, {0, 0, 0}), &p);
  const cv::Matx33d Rg = yaw_to_front(p) * A_axis;
  // Centre the root path, put the lowest toe of the clip on the floor (at the toes' half height).
  double xmin = HUGE_VAL, xmax = -HUGE_VAL, ymin = HUGE_VAL, ymax = -HUGE_VAL, toe_min = HUGE_VAL;
  for (int f = first; f < clip.frames; ++f) {
    forward_kinematics(sk, placed(file_pose(f), Rg, {0, 0, 0}), &p);
    xmin = std::min(xmin, p[0][0]);
    xmax = std::max(xmax, p[0][0]);
    ymin = std::min(ymin, p[0][1]);
    ymax = std::max(ymax, p[0][1]);
    toe_min = std::min({toe_min, p[idx(Joint::l_toe)][2], p[idx(Joint::r_toe)][2]});
  }
  const cv::Vec3d tg(-0.5 * (xmin + xmax), -0.5 * (ymin + ymax), body.toes_half_height_m - toe_min);

  BvhMapping map;
  map.convention = convention;
  map.scale = scale;
  map.R_world_from_file = Rg;
  map.t_world_m = tg;
  map.frame_time_s = ft;
  map.first_frame = first;
  map.frames = clip.frames;

  m->name = std::filesystem::path(path).stem().string();
  m->skeleton = sk;
  m->length_s = (clip.frames - 1 - first) * ft;
  const int frames = clip.frames;
  const bool loop = opt.loop;
  auto clip_ptr = std::make_shared<BvhClip>(clip);
  m->sample = [clip_ptr, first, frames, ft, loop, scale, root_offset, Rg, tg](double tau) {
    auto fp = [&](int f) {
      Pose pose = clip_ptr->pose(f, scale);
      pose.root_position = Rg * (pose.root_position + root_offset) + tg;
      pose.local[0] = Rg * pose.local[0];
      return pose;
    };
    const int last = frames - 1;
    double f = first + std::max(0.0, tau) / ft;
    if (f > last) {
      if (loop && last > first) {
        f = first + std::fmod(f - first, static_cast<double>(last - first + 1));
      } else {
        return fp(last);
      }
    }
    const int i = static_cast<int>(std::floor(f));
    const double a = f - i;
    if (a < 1e-9 || i >= last) return fp(std::min(i, last));
    if (a > 1 - 1e-9) return fp(i + 1);
    return blend(fp(i), fp(i + 1), a);
  };

  // Standard joints: FK joints, the head as the midpoint of Head and its End Site, head top and
  // hand tips from the head/wrist frames.
  for (int j = 0; j < kJointCount; ++j) {
    detail::JointSource& s = m->sources[static_cast<std::size_t>(j)];
    s.a = bj.j[static_cast<std::size_t>(j)];
    s.frame_joint = s.a;
    map.file_joint[static_cast<std::size_t>(j)] = s.a;
  }
  const int head = bj.j[static_cast<std::size_t>(Joint::head)];
  detail::JointSource& hs = m->sources[static_cast<std::size_t>(Joint::head)];
  hs = {head, bj.head_end, bj.head_end >= 0 ? 0.5 : 0.0, head,
        bj.head_end >= 0 ? cv::Vec3d(0, 0, 0) : cv::Vec3d(0, 0, 0.5 * body.head_radii_m[2])};
  if (bj.head_end >= 0) map.file_joint[static_cast<std::size_t>(Joint::head)] = -1;
  detail::JointSource& ts = m->sources[static_cast<std::size_t>(Joint::head_top)];
  ts = hs;
  ts.canon_offset += cv::Vec3d(0, 0, body.head_radii_m[2]);
  map.file_joint[static_cast<std::size_t>(Joint::head_top)] = -1;
  for (const auto& [tip, wrist, sign] : {std::tuple{Joint::l_hand_tip, Joint::l_wrist, 1.0},
                                         std::tuple{Joint::r_hand_tip, Joint::r_wrist, -1.0}}) {
    const int w = bj.j[static_cast<std::size_t>(wrist)];
    m->sources[static_cast<std::size_t>(tip)] = {w, -1, 0, w, cv::Vec3d(sign * body.hand_m, 0, 0)};
    map.file_joint[static_cast<std::size_t>(tip)] = -1;
  }
  for (int j = 0; j < kJointCount; ++j) {
    const int fj = map.file_joint[static_cast<std::size_t>(j)];
    map.file_joint_name[static_cast<std::size_t>(j)] = fj >= 0 ? fsk.joints[static_cast<std::size_t>(fj)].name : "";
  }

  // The initialization pose on this skeleton: rest frame turned to face -y, legs straight down,
  // arms spread horizontally, spine/neck/head upright, feet pointing forward at their rest pitch.
  std::vector<int> aim(sk.joints.size(), -1);
  std::vector<cv::Vec3d> target(sk.joints.size());
  auto set_aim = [&](Joint j, int child, const cv::Vec3d& d) {
    const auto a = static_cast<std::size_t>(bj.j[static_cast<std::size_t>(j)]);
    if (child < 0) return;
    aim[a] = child;
    target[a] = d;
  };
  forward_kinematics(sk, placed(rest_pose(sk), A_axis, {0, 0, 0}), &p);
  const cv::Matx33d R_rest = yaw_to_front(p) * A_axis;
  auto J = [&](Joint j) { return bj.j[static_cast<std::size_t>(j)]; };
  set_aim(Joint::spine, J(Joint::neck), {0, 0, 1});
  set_aim(Joint::neck, J(Joint::head), {0, 0, 1});
  set_aim(Joint::head, bj.head_end, {0, 0, 1});
  set_aim(Joint::l_shoulder, J(Joint::l_elbow), {1, 0, 0});
  set_aim(Joint::l_elbow, J(Joint::l_wrist), {1, 0, 0});
  set_aim(Joint::l_wrist, bj.l_hand_end, {1, 0, 0});
  set_aim(Joint::r_shoulder, J(Joint::r_elbow), {-1, 0, 0});
  set_aim(Joint::r_elbow, J(Joint::r_wrist), {-1, 0, 0});
  set_aim(Joint::r_wrist, bj.r_hand_end, {-1, 0, 0});
  for (const auto& [hip, knee, ankle, toe] : {std::tuple{Joint::l_hip, Joint::l_knee, Joint::l_ankle, Joint::l_toe},
                                              std::tuple{Joint::r_hip, Joint::r_knee, Joint::r_ankle, Joint::r_toe}}) {
    set_aim(hip, J(knee), {0, 0, -1});
    set_aim(knee, J(ankle), {0, 0, -1});
    const cv::Vec3d v = R_rest * rest_vector(sk, J(ankle), J(toe));
    set_aim(ankle, J(toe), {0, -std::hypot(v[0], v[1]), v[2]});
  }
  if (bj.j[static_cast<std::size_t>(Joint::spine)] == bj.j[static_cast<std::size_t>(Joint::hips)]) {
    aim[static_cast<std::size_t>(J(Joint::hips))] = -1;  // never re-aim the root
  }
  detail::Poser poser(sk, aim);
  poser.root({0, 0, 0}, R_rest);
  for (std::size_t j = 1; j < sk.joints.size(); ++j) {
    if (aim[j] >= 0) poser.aim(static_cast<int>(j), target[j]);
  }
  Pose init = poser.pose();
  std::vector<cv::Matx33d> W;
  forward_kinematics(sk, init, &p, &W);
  m->canon.resize(sk.joints.size());
  for (std::size_t j = 0; j < sk.joints.size(); ++j) m->canon[j] = W[j].t();
  // Stand where the clip starts, toes at their half height (as the clip's lowest toe).
  const Pose first_pose = m->sample(0);
  const double toe_z = std::min(p[idx(Joint::l_toe)][2], p[idx(Joint::r_toe)][2]);
  init.root_position = cv::Vec3d(first_pose.root_position[0], first_pose.root_position[1],
                                 body.toes_half_height_m - toe_z);
  forward_kinematics(sk, init, &p);
  m->feet.ankle_height_m = 0.5 * (p[idx(Joint::l_ankle)][2] + p[idx(Joint::r_ankle)][2]);
  m->init = init;
  m->first = first_pose;
  m->bvh = map;
}

}  // namespace detail

bool MotionOptions::valid(std::string* why) const {
  std::ostringstream os;
  if (source.empty()) {
    os << "motion source is empty";
  } else if (!(fps > 0 && fps <= 1000)) {
    os << "fps must be in (0, 1000], got " << fps;
  } else if (!(lead_hold_s >= 0 && lead_hold_s <= 60) || !(lead_blend_s >= 0 && lead_blend_s <= 60)) {
    os << "lead_hold_s and lead_blend_s must be in [0, 60]";
  } else if (!(bvh_frame_time_s >= 0 && bvh_frame_time_s <= 10)) {
    os << "bvh_frame_time_s must be in [0, 10] (0: from the file)";
  } else if (!(bvh_scale >= 0 && bvh_scale <= 100)) {
    os << "bvh_scale must be in [0, 100] (0: by convention)";
  } else {
    return true;
  }
  if (why) *why = os.str();
  return false;
}

Motion Motion::create(const MotionOptions& options, const BodyDescription& body) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("motion: " + why);
  if (!body.valid(&why)) throw std::invalid_argument("body: " + why);
  auto m = std::make_shared<Impl>();
  m->options = options;
  m->body = body;
  const std::string& src = options.source;
  std::string ext = std::filesystem::path(src).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  const bool is_bvh = ext == ".bvh";
  if (is_bvh) {
    detail::make_bvh(src, options, body, m.get());
  } else {
    detail::make_builtin(src, body, m.get());
  }
  return Motion(std::shared_ptr<const Impl>(std::move(m)));
}

namespace {
double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}
}  // namespace

const std::string& Motion::name() const { return impl_->name; }
double Motion::fps() const { return impl_->options.fps; }
int Motion::lead_in_frames() const {
  return static_cast<int>(std::ceil((impl_->options.lead_hold_s + impl_->options.lead_blend_s) * fps() - 1e-9));
}
int Motion::natural_frames() const {
  return lead_in_frames() + static_cast<int>(std::floor(impl_->length_s * fps() + 1e-9)) + 1;
}
const Skeleton& Motion::skeleton() const { return impl_->skeleton; }
const FootGeometry& Motion::feet() const { return impl_->feet; }
const BodyDescription& Motion::body() const { return impl_->body; }
const BvhMapping* Motion::bvh() const { return impl_->bvh ? &*impl_->bvh : nullptr; }

double Motion::clip_time(int frame) const {
  return frame / fps() - impl_->options.lead_hold_s - impl_->options.lead_blend_s;
}

Pose Motion::skeleton_pose(int frame) const {
  if (frame < 0) throw std::out_of_range("Motion: negative frame");
  const MotionOptions& o = impl_->options;
  const double t = frame / o.fps;
  if (t < o.lead_hold_s) return impl_->init;
  if (t < o.lead_hold_s + o.lead_blend_s) {
    return blend(impl_->init, impl_->first, smoothstep((t - o.lead_hold_s) / o.lead_blend_s));
  }
  return impl_->sample(clip_time(frame));
}

BodyPose Motion::body_pose(int frame) const { return detail::body_pose_from(*impl_, skeleton_pose(frame)); }

}  // namespace vc::sim
