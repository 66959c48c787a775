// Motion: the lead-in (initialization pose, then a slerp blend into the motion), BVH clips (mapped
// onto the standard joints by hw/body's humanoid mapping: names, units, axes, placement, frame
// rate; documented in hw/body/include/voxcap/body/humanoid.hpp and hw/sim/README.md), and the
// standard joints of a pose with the frames that orient the head, hands and feet.
#include "voxcap/sim/motion.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "motion_internal.hpp"
#include "voxcap/body/glm_cv.hpp"

namespace vc::sim {
namespace detail {

Poser::Poser(const Skeleton& skeleton, const std::vector<int>& aim_child)
    : sk_(skeleton), aim_child_(aim_child) {
  pose_ = vc::body::rest_pose(skeleton);
  W_.assign(skeleton.joints.size(), glm::dmat3(1.0));
}

void Poser::root(const glm::dvec3& position, const glm::dmat3& R_world) {
  pose_.root_position = position;
  pose_.local[0] = R_world;
  W_[0] = R_world;
  for (std::size_t j = 1; j < W_.size(); ++j)
    W_[j] = W_[static_cast<std::size_t>(sk_.joints[j].parent)] * pose_.local[j];
}

void Poser::local(int joint, const glm::dmat3& R_local) {
  const auto j = static_cast<std::size_t>(joint);
  pose_.local[j] = R_local;
  // Children are set after their parents; refresh this joint and its descendants' world frames.
  for (std::size_t k = j; k < W_.size(); ++k) {
    if (k == 0) continue;
    W_[k] = W_[static_cast<std::size_t>(sk_.joints[k].parent)] * pose_.local[k];
  }
}

void Poser::aim(int joint, const glm::dvec3& d_world, double twist) {
  const auto j = static_cast<std::size_t>(joint);
  const int e = aim_child_[j];
  if (e < 0) throw std::logic_error("Poser::aim: joint has no aim child");
  const glm::dmat3 Wp = joint == 0 ? glm::dmat3(1.0) : W_[static_cast<std::size_t>(sk_.joints[j].parent)];
  const glm::dvec3 v_world = Wp * vc::body::rest_vector(sk_, joint, e);
  glm::dmat3 Wj = vc::body::rot_between(v_world, d_world) * Wp;
  if (twist != 0) Wj = vc::body::rot_axis(d_world, twist) * Wj;
  local(joint, glm::transpose(Wp) * Wj);
}

double lowest_sole_z(const BodyPose& pose, const BodyDescription& body, const FootGeometry& feet) {
  std::vector<Primitive> prims;
  build_primitives(pose, body, feet, &prims);
  double lowest = HUGE_VAL;
  for (const Primitive& p : prims) {
    if (p.part != Part::l_foot && p.part != Part::r_foot && p.part != Part::l_toes && p.part != Part::r_toes)
      continue;
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
  std::vector<glm::dvec3> p;
  std::vector<glm::dmat3> W;
  vc::body::forward_kinematics(m.skeleton, pose, &p, &W);
  BodyPose out;
  for (int j = 0; j < kJointCount; ++j) {
    const JointSource& s = m.sources[static_cast<std::size_t>(j)];
    const auto fj = static_cast<std::size_t>(s.frame_joint);
    const glm::dmat3 R = W[fj] * m.canon[fj];
    glm::dvec3 pj = p[static_cast<std::size_t>(s.a)];
    if (s.b >= 0) pj = pj * (1 - s.w) + p[static_cast<std::size_t>(s.b)] * s.w;
    if (s.canon_offset != glm::dvec3(0, 0, 0)) pj += R * s.canon_offset;
    out.p_world[static_cast<std::size_t>(j)] = vc::body::to_cv(pj);
    out.R_world[static_cast<std::size_t>(j)] = vc::body::to_cv(R);
  }
  return out;
}

// A dataset's own truth/motion.bvh (voxcap sim wrote it, with the scene.yaml beside it): its
// joints are already where the performer stood, in the world frame.
bool is_own_truth(const std::string& path) {
  const std::filesystem::path p(path);
  if (p.filename() != "motion.bvh") return false;
  std::ifstream f(p.parent_path() / "scene.yaml");
  std::string head(512, '\0');
  f.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, f.gcount())));
  return head.find("voxcap's virtual rig") != std::string::npos;
}

// The pelvis centre (`hips`) and the neck base (`neck`) of a clip, defined as the standard body
// defines them, from the joints every skeleton convention agrees on: the pelvis centre pelvis_drop_m
// above the middle of the hip joints, the neck base shoulder_drop_m above the middle of the shoulder
// joints, both along the torso's up (its rest up, turned with the pelvis or the chest), scaled by the
// clip's torso (hip joints to shoulder joints) over the standard body's. A file's own root and neck
// joints are wherever its convention put them: CMU's root is 10 cm above its hip joints and its
// lowerneck 5 cm below its shoulder joints, Mixamo's Neck above them, so scoring a fit against them
// charged the convention to the fit (on the true occupancy of CMU clips' init pose: hips 52-59 mm,
// neck 83-85 mm, against 13-14 mm on the built-in motions). Rotations stay the file joints'.
void standard_hips_and_neck(const Skeleton& sk, const BvhMapping& map, const BodyDescription& body,
                            const std::vector<glm::dvec3>& p_init, MotionData* m) {
  auto J = [&](Joint j) { return map.anchor[static_cast<std::size_t>(j)]; };
  auto P = [&](Joint j) { return p_init[static_cast<std::size_t>(J(j))]; };
  const double torso = glm::length(0.5 * (P(Joint::l_shoulder) + P(Joint::r_shoulder)) -
                                   0.5 * (P(Joint::l_hip) + P(Joint::r_hip)));
  const double torso_std =
      body.pelvis_drop_m + body.hips_to_spine_m + body.spine_to_neck_m - body.shoulder_drop_m;
  if (!(torso > 0.05) || !(torso_std > 0.05)) return;  // degenerate: the file's joints as they are
  const double s = torso / torso_std;
  JointSource& hips = m->sources[static_cast<std::size_t>(Joint::hips)];
  hips = {J(Joint::l_hip), J(Joint::r_hip), 0.5, J(Joint::hips), glm::dvec3(0, 0, s * body.pelvis_drop_m)};
  const int chest = sk.joints[static_cast<std::size_t>(J(Joint::neck))].parent;
  JointSource& neck = m->sources[static_cast<std::size_t>(Joint::neck)];
  neck = {J(Joint::l_shoulder), J(Joint::r_shoulder), 0.5, chest >= 0 ? chest : J(Joint::neck),
          glm::dvec3(0, 0, s * body.shoulder_drop_m)};
  for (Joint j : {Joint::hips, Joint::neck}) {
    m->bvh->file_joint[static_cast<std::size_t>(j)] = -1;  // derived, as the head centre
    m->bvh->file_joint_name[static_cast<std::size_t>(j)] = "";
  }
}

void make_bvh(const std::string& path, const MotionOptions& opt, const BodyDescription& body, MotionData* m) {
  vc::body::HumanoidOptions ho;
  ho.height_m = body.height_m;
  ho.toe_height_m = body.toes_half_height_m;
  ho.scale = opt.bvh_scale;
  ho.frame_time_s = opt.bvh_frame_time_s;
  ho.keep_placement = is_own_truth(path);
  ho.start_within_x_m = opt.bvh_start_within_x_m;
  ho.start_within_y_m = opt.bvh_start_within_y_m;
  auto clip = std::make_shared<const vc::body::HumanoidClip>(vc::body::read_humanoid(path, ho));
  const BvhMapping& map = clip->map;
  const Skeleton& sk = clip->skeleton;
  auto J = [&](Joint j) { return map.anchor[static_cast<std::size_t>(j)]; };
  auto idx = [&](Joint j) { return static_cast<std::size_t>(J(j)); };

  m->name = std::filesystem::path(path).stem().string();
  m->skeleton = sk;
  m->length_s = clip->length_s();
  const bool loop = opt.loop;
  m->sample = [clip, loop](double tau) { return clip->sample(tau, loop); };

  // Standard joints: FK joints, the head as the midpoint of Head and its End Site, head top and
  // hand tips from the head/wrist frames.
  for (int j = 0; j < kJointCount; ++j) {
    JointSource& s = m->sources[static_cast<std::size_t>(j)];
    s.a = map.anchor[static_cast<std::size_t>(j)];
    s.frame_joint = s.a;
  }
  // voxcap's own skeleton (convention "voxcap": a built-in motion's truth/motion.bvh) has every
  // standard joint as a file joint, the head centre and the end points included: taken as they are.
  const bool own = map.convention == "voxcap";
  const int head = J(Joint::head);
  JointSource& hs = m->sources[static_cast<std::size_t>(Joint::head)];
  if (own) {
    hs = {head, -1, 0.0, head, glm::dvec3(0, 0, 0)};
  } else {
    hs = {head, map.head_end, map.head_end >= 0 ? 0.5 : 0.0, head,
          map.head_end >= 0 ? glm::dvec3(0, 0, 0) : glm::dvec3(0, 0, 0.5 * body.head_radii_m[2])};
  }
  JointSource& ts = m->sources[static_cast<std::size_t>(Joint::head_top)];
  ts = hs;
  ts.canon_offset += glm::dvec3(0, 0, body.head_radii_m[2]);
  for (const auto& [tip, wrist, sign] : {std::tuple{Joint::l_hand_tip, Joint::l_wrist, 1.0},
                                         std::tuple{Joint::r_hand_tip, Joint::r_wrist, -1.0}}) {
    const int w = J(wrist);
    m->sources[static_cast<std::size_t>(tip)] = {w, -1, 0, w, glm::dvec3(sign * body.hand_m, 0, 0)};
  }
  for (Joint tip : {Joint::head_top, Joint::l_hand_tip, Joint::r_hand_tip}) {
    const int fj = map.file_joint[static_cast<std::size_t>(tip)];
    if (own && fj >= 0) {
      m->sources[static_cast<std::size_t>(tip)] = {fj, -1, 0.0, J(Joint::head), glm::dvec3(0, 0, 0)};
      m->sources[static_cast<std::size_t>(tip)].frame_joint = sk.joints[static_cast<std::size_t>(fj)].parent;
    }
  }

  // The initialization pose on this skeleton: rest frame turned to face -y, legs straight down,
  // arms spread horizontally, spine/neck/head upright, feet pointing forward at their rest pitch.
  std::vector<int> aim(sk.joints.size(), -1);
  std::vector<glm::dvec3> target(sk.joints.size());
  auto set_aim = [&](Joint j, int child, const glm::dvec3& d) {
    const auto a = static_cast<std::size_t>(J(j));
    if (child < 0) return;
    aim[a] = child;
    target[a] = d;
  };
  const glm::dmat3 R_rest = clip->R_world_from_rest;
  set_aim(Joint::spine, J(Joint::neck), {0, 0, 1});
  set_aim(Joint::neck, J(Joint::head), {0, 0, 1});
  set_aim(Joint::head, map.head_end, {0, 0, 1});
  set_aim(Joint::l_shoulder, J(Joint::l_elbow), {1, 0, 0});
  set_aim(Joint::l_elbow, J(Joint::l_wrist), {1, 0, 0});
  set_aim(Joint::l_wrist, map.l_hand_end, {1, 0, 0});
  set_aim(Joint::r_shoulder, J(Joint::r_elbow), {-1, 0, 0});
  set_aim(Joint::r_elbow, J(Joint::r_wrist), {-1, 0, 0});
  set_aim(Joint::r_wrist, map.r_hand_end, {-1, 0, 0});
  for (const auto& [hip, knee, ankle, toe] :
       {std::tuple{Joint::l_hip, Joint::l_knee, Joint::l_ankle, Joint::l_toe},
        std::tuple{Joint::r_hip, Joint::r_knee, Joint::r_ankle, Joint::r_toe}}) {
    set_aim(hip, J(knee), {0, 0, -1});
    set_aim(knee, J(ankle), {0, 0, -1});
    const glm::dvec3 v = R_rest * vc::body::rest_vector(sk, J(ankle), J(toe));
    set_aim(ankle, J(toe), {0, -std::hypot(v[0], v[1]), v[2]});
  }
  if (J(Joint::spine) == J(Joint::hips)) {
    aim[idx(Joint::hips)] = -1;  // never re-aim the root
  }
  Poser poser(sk, aim);
  poser.root({0, 0, 0}, R_rest);
  for (std::size_t j = 1; j < sk.joints.size(); ++j) {
    if (aim[j] >= 0) poser.aim(static_cast<int>(j), target[j]);
  }
  Pose init = poser.pose();
  std::vector<glm::dvec3> p;
  std::vector<glm::dmat3> W;
  vc::body::forward_kinematics(sk, init, &p, &W);
  m->canon.resize(sk.joints.size());
  for (std::size_t j = 0; j < sk.joints.size(); ++j) m->canon[j] = glm::transpose(W[j]);
  // Stand where the clip starts, toes at their half height (as the clip's lowest toe).
  const Pose first_pose = m->sample(0);
  const double toe_z = std::min(p[idx(Joint::l_toe)][2], p[idx(Joint::r_toe)][2]);
  init.root_position =
      glm::dvec3(first_pose.root_position[0], first_pose.root_position[1], body.toes_half_height_m - toe_z);
  vc::body::forward_kinematics(sk, init, &p);
  m->feet.ankle_height_m = 0.5 * (p[idx(Joint::l_ankle)][2] + p[idx(Joint::r_ankle)][2]);
  m->init = init;
  m->first = first_pose;
  m->bvh = map;
  if (!own) standard_hips_and_neck(sk, map, body, p, m);
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
  } else if (!(bvh_start_within_x_m >= 0 && bvh_start_within_x_m <= 1000 && bvh_start_within_y_m >= 0 &&
               bvh_start_within_y_m <= 1000)) {
    os << "bvh_start_within_x_m and bvh_start_within_y_m must be in [0, 1000] (0: centred)";
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

const std::string& Motion::name() const {
  return impl_->name;
}
double Motion::fps() const {
  return impl_->options.fps;
}
int Motion::lead_in_frames() const {
  return static_cast<int>(
      std::ceil((impl_->options.lead_hold_s + impl_->options.lead_blend_s) * fps() - 1e-9));
}
int Motion::natural_frames() const {
  return lead_in_frames() + static_cast<int>(std::floor(impl_->length_s * fps() + 1e-9)) + 1;
}
const Skeleton& Motion::skeleton() const {
  return impl_->skeleton;
}
const FootGeometry& Motion::feet() const {
  return impl_->feet;
}
const BodyDescription& Motion::body() const {
  return impl_->body;
}
const BvhMapping* Motion::bvh() const {
  return impl_->bvh ? &*impl_->bvh : nullptr;
}

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

BodyPose Motion::body_pose(int frame) const {
  return detail::body_pose_from(*impl_, skeleton_pose(frame));
}

}  // namespace vc::sim
