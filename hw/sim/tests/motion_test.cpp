// Motions against ground truth: the rendered joints of a BVH-driven performer equal the file's
// own forward kinematics (computed here independently, with OpenCV quaternions) after the
// documented scale and axis change, within 1 mm; the built-in motions' joints equal the forward
// kinematics of the BVH they export; every motion starts in the initialization pose.
#include "voxcap/sim/motion.hpp"

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <opencv2/core/quaternion.hpp>

#include "voxcap/body/bvh.hpp"
#include "voxcap/body/glm_cv.hpp"
#include "voxcap/body/humanoid.hpp"
#include "voxcap/body/testing/shared_clips.hpp"
#include "voxcap/sim/dataset.hpp"
#include "voxcap/sim/rig_layout.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using vc::body::BvhChannel;
using vc::body::BvhClip;
using vc::body::format_bvh;
using vc::body::parse_bvh;
using vc::body::read_bvh;
using vc::body::to_cv;
using vc::body::testing::find_clip;
using vc::body::testing::no_clips_message;

// Every *.bvh of the shared data folder (listed, never named here).
std::vector<fs::path> clips() {
  return vc::body::testing::shared_bvh_clips();
}

// Independent forward kinematics of one BVH frame (file units, file axes).
struct RefFrame {
  cv::Vec3d root;
  std::vector<cv::Quatd> q;  // local rotations
};

RefFrame ref_frame(const BvhClip& c, int f) {
  RefFrame r;
  r.root = to_cv(c.skeleton.joints[0].offset);
  const double* v = c.frame_values(f);
  for (std::size_t j = 0; j < c.skeleton.joints.size(); ++j) {
    cv::Quatd q(1, 0, 0, 0);
    for (std::size_t k = 0; k < c.channels[j].size(); ++k) {
      const double x = v[c.first_channel[j] + static_cast<int>(k)];
      switch (c.channels[j][k]) {
        case BvhChannel::Xposition:
          r.root[0] += x;
          break;
        case BvhChannel::Yposition:
          r.root[1] += x;
          break;
        case BvhChannel::Zposition:
          r.root[2] += x;
          break;
        case BvhChannel::Xrotation:
          q = q * cv::Quatd::createFromAngleAxis(x * CV_PI / 180, cv::Vec3d(1, 0, 0));
          break;
        case BvhChannel::Yrotation:
          q = q * cv::Quatd::createFromAngleAxis(x * CV_PI / 180, cv::Vec3d(0, 1, 0));
          break;
        case BvhChannel::Zrotation:
          q = q * cv::Quatd::createFromAngleAxis(x * CV_PI / 180, cv::Vec3d(0, 0, 1));
          break;
      }
    }
    r.q.push_back(q);
  }
  return r;
}

std::vector<cv::Vec3d> ref_fk(const BvhClip& c, const RefFrame& r) {
  const std::size_t n = c.skeleton.joints.size();
  std::vector<cv::Vec3d> p(n);
  std::vector<cv::Quatd> W(n);
  for (std::size_t j = 0; j < n; ++j) {
    const int parent = c.skeleton.joints[j].parent;
    if (parent < 0) {
      p[j] = r.root;
      W[j] = r.q[j];
    } else {
      const auto pa = static_cast<std::size_t>(parent);
      p[j] = p[pa] + W[pa].toRotMat3x3() * to_cv(c.skeleton.joints[j].offset);
      W[j] = W[pa] * r.q[j];
    }
  }
  return p;
}

// The file's FK at a fractional frame: slerp of local rotations, lerp of the root.
std::vector<cv::Vec3d> ref_fk_at(const BvhClip& c, double u) {
  const int i = std::min(static_cast<int>(std::floor(u)), c.frames - 1);
  const double a = std::clamp(u - i, 0.0, 1.0);
  RefFrame r = ref_frame(c, i);
  if (a > 1e-9 && i + 1 < c.frames) {
    const RefFrame r1 = ref_frame(c, i + 1);
    r.root = r.root * (1 - a) + r1.root * a;
    for (std::size_t j = 0; j < r.q.size(); ++j)
      r.q[j] = cv::Quatd::slerp(r.q[j], r1.q[j], a, cv::QUAT_ASSUME_NOT_UNIT, true);
  }
  return ref_fk(c, r);
}

void expect_init_pose(const Motion& m, const std::string& what) {
  SCOPED_TRACE(what);
  const BodyPose p = m.body_pose(0);
  auto P = [&](Joint j) { return p.p(j); };
  // Facing -y: the performer's left is +x.
  EXPECT_GT(P(Joint::l_shoulder)[0] - P(Joint::r_shoulder)[0], 0.2);
  EXPECT_LT(std::abs(P(Joint::l_shoulder)[1] - P(Joint::r_shoulder)[1]), 0.03);
  EXPECT_GT(P(Joint::l_hip)[0], P(Joint::r_hip)[0]);
  EXPECT_LT(P(Joint::l_toe)[1], P(Joint::l_ankle)[1]);  // toes point forward (-y)
  // Arms spread horizontally.
  for (const auto& [sh, el, wr, sign] :
       {std::tuple{Joint::l_shoulder, Joint::l_elbow, Joint::l_wrist, 1.0},
        std::tuple{Joint::r_shoulder, Joint::r_elbow, Joint::r_wrist, -1.0}}) {
    EXPECT_NEAR(P(wr)[2], P(sh)[2], 0.01);
    EXPECT_NEAR(P(el)[2], P(sh)[2], 0.01);
    EXPECT_GT(sign * (P(wr)[0] - P(el)[0]), 0.1);
    EXPECT_GT(sign * (P(el)[0] - P(sh)[0]), 0.1);
  }
  // Legs together and straight down, feet on the floor, upright.
  for (const auto& [hip, knee, ankle] : {std::tuple{Joint::l_hip, Joint::l_knee, Joint::l_ankle},
                                         std::tuple{Joint::r_hip, Joint::r_knee, Joint::r_ankle}}) {
    EXPECT_LT(std::hypot(P(ankle)[0] - P(hip)[0], P(ankle)[1] - P(hip)[1]), 0.01);
    EXPECT_LT(std::hypot(P(knee)[0] - P(hip)[0], P(knee)[1] - P(hip)[1]), 0.01);
  }
  EXPECT_LT(std::abs(P(Joint::l_ankle)[0] - P(Joint::r_ankle)[0]), 0.3);
  EXPECT_NEAR(std::min(P(Joint::l_toe)[2], P(Joint::r_toe)[2]), m.body().toes_half_height_m, 1e-9);
  EXPECT_GT(P(Joint::head_top)[2], P(Joint::head)[2]);
  EXPECT_GT(P(Joint::head)[2], P(Joint::neck)[2]);
  EXPECT_GT(P(Joint::neck)[2], P(Joint::hips)[2]);
  // Held for the first second.
  const BodyPose later = m.body_pose(static_cast<int>(m.fps()) - 1);
  for (int j = 0; j < kJointCount; ++j)
    EXPECT_LT(cv::norm(later.p_world[static_cast<std::size_t>(j)] - p.p_world[static_cast<std::size_t>(j)]),
              1e-12);
}

TEST(SimBvhMotion, RenderedJointsEqualTheFilesForwardKinematics) {
  const auto files = clips();
  ASSERT_FALSE(files.empty()) << no_clips_message();
  for (const fs::path& path : files) {
    SCOPED_TRACE(path.string());
    MotionOptions opt;
    opt.source = path.string();
    const Motion m = Motion::create(opt, BodyDescription{});
    const BvhMapping* map = m.bvh();
    ASSERT_NE(map, nullptr);
    const BvhClip clip = read_bvh(path.string());
    // The documented transform is a scale, a proper rotation and a translation.
    EXPECT_NEAR(glm::determinant(map->R_world_from_file), 1.0, 1e-12);
    if (map->convention != "generic") {
      EXPECT_DOUBLE_EQ(map->scale, 0.056444);
    }
    const int head = clip.skeleton.find("Head");
    const int head_end = clip.skeleton.find("Head_end");
    ASSERT_GE(head, 0);
    ASSERT_GE(head_end, 0);
    double worst = 0;
    int compared = 0;
    const int stride = std::max(1, (m.natural_frames() - m.lead_in_frames()) / 300);
    for (int f = m.lead_in_frames(); f < m.natural_frames(); f += stride) {
      const double u = map->first_frame + m.clip_time(f) / map->frame_time_s;
      std::vector<cv::Vec3d> ref = ref_fk_at(clip, u);
      for (auto& p : ref) p = to_cv(map->R_world_from_file) * (map->scale * p) + to_cv(map->t_world_m);
      const BodyPose bp = m.body_pose(f);
      for (int j = 0; j < kJointCount; ++j) {
        const int fj = map->file_joint[static_cast<std::size_t>(j)];
        cv::Vec3d want;
        if (fj >= 0) {
          want = ref[static_cast<std::size_t>(fj)];
        } else if (j == static_cast<int>(Joint::head)) {
          want = 0.5 * (ref[static_cast<std::size_t>(head)] + ref[static_cast<std::size_t>(head_end)]);
        } else {
          continue;  // head_top and hand tips are placed from frames (README)
        }
        worst = std::max(worst, cv::norm(bp.p_world[static_cast<std::size_t>(j)] - want));
        ++compared;
      }
    }
    EXPECT_GT(compared, 1000);
    EXPECT_LT(worst, 1e-3) << "worst joint error " << worst * 1000 << " mm";
    RecordProperty(path.stem().string() + "_worst_mm", std::to_string(worst * 1000));
    expect_init_pose(m, path.filename().string());
  }
}

TEST(SimBvhMotion, DocumentedConventionsAreDetected) {
  // The clips data/README.md documents, looked up in the folder's listing by file name.
  const auto files = clips();
  ASSERT_FALSE(files.empty()) << no_clips_message();
  auto mapping = [&](const std::string& name) {
    const fs::path path = find_clip(files, name);
    if (path.empty())
      throw std::runtime_error(name + " (documented in data/README.md) is not in the listing");
    MotionOptions opt;
    opt.source = path.string();
    return *Motion::create(opt, BodyDescription{}).bvh();
  };
  const BvhMapping walk = mapping("02_01.bvh");
  EXPECT_EQ(walk.convention, "cgspeed-motionbuilder");
  EXPECT_EQ(walk.first_frame, 1);  // synthetic T-pose skipped
  EXPECT_DOUBLE_EQ(walk.frame_time_s, 1.0 / 120);
  EXPECT_EQ(walk.file_joint_name[static_cast<std::size_t>(Joint::l_shoulder)], "LeftArm");
  EXPECT_EQ(walk.file_joint_name[static_cast<std::size_t>(Joint::spine)], "Spine");
  // Y up: the file's +Y maps to +z.
  EXPECT_LT(cv::norm(to_cv(walk.R_world_from_file) * cv::Vec3d(0, 1, 0) - cv::Vec3d(0, 0, 1)), 1e-12);
  const BvhMapping wave = mapping("141_16.bvh");
  EXPECT_EQ(wave.first_frame, 0);
  EXPECT_DOUBLE_EQ(wave.frame_time_s, 1.0 / 60);  // subject 141 was captured at 60 fps
  const BvhMapping jj = mapping("cmu1_jumping_jacks.bvh");
  EXPECT_EQ(jj.convention, "cgspeed-3dsmax");
  EXPECT_EQ(jj.file_joint_name[static_cast<std::size_t>(Joint::l_shoulder)], "LeftShoulder");
  EXPECT_EQ(jj.file_joint_name[static_cast<std::size_t>(Joint::l_wrist)], "LeftWrist");
  EXPECT_DOUBLE_EQ(jj.frame_time_s, 1.0 / 30);
  const BvhMapping fair = mapping("fair1_wave_hello.bvh");
  EXPECT_EQ(fair.convention, "generic");
  EXPECT_DOUBLE_EQ(fair.frame_time_s, 0.008342);
  EXPECT_LT(cv::norm(to_cv(fair.R_world_from_file) * cv::Vec3d(0, 0, 1) - cv::Vec3d(0, 0, 1)),
            1e-12);  // Z up
  // Unknown units: the rest pose is scaled to the body height (1.75 m for ~39 units).
  EXPECT_NEAR(fair.scale, 1.75 / 39.0, 0.004);
}

// voxcap sim reads back its own truth/motion.bvh: a dataset written by write_dataset (what voxcap sim
// does), its truth/motion.bvh given as the motion: after the new lead-in, every standard joint it
// drives equals the original truth/joints.csv within 1 mm on every frame (the file is recognised by
// its scene.yaml and kept in the world frame; a built-in motion's standard skeleton maps as
// "voxcap": head centre and end points are its own joints). Built-in motions and a real clip.
TEST(SimBvhMotion, ReadsBackItsOwnTruthMotionWithinOneMillimetre) {
  std::vector<std::string> sources = {"wave", "turn"};
  const auto files = clips();
  ASSERT_FALSE(files.empty()) << no_clips_message();
  sources.push_back(files.front().string());
  for (const std::string& source : sources) {
    SCOPED_TRACE(source);
    const fs::path dir = fs::path(::testing::TempDir()) / "vc_sim_own_truth";
    fs::remove_all(dir);
    SceneOptions so;
    so.motion.source = source;
    so.rig.cameras = 4;
    so.rig.width = 64;
    so.rig.height = 48;
    const Scene scene(so);
    DatasetOptions dopt;
    dopt.frames = scene.motion().lead_in_frames() + 120;
    dopt.backgrounds = 1;
    dopt.shadows = false;
    dopt.threads = 2;
    (void)write_dataset(scene, dopt, dir.string());
    // The original truth, from joints.csv.
    std::map<std::pair<int, std::string>, cv::Vec3d> truth;
    {
      std::ifstream f(dir / "truth" / "joints.csv");
      std::string line;
      std::getline(f, line);
      while (std::getline(f, line)) {
        std::stringstream ss(line);
        std::string frame, joint, x, y, z;
        std::getline(ss, frame, ',');
        std::getline(ss, joint, ',');
        std::getline(ss, x, ',');
        std::getline(ss, y, ',');
        std::getline(ss, z, ',');
        truth[{std::stoi(frame), joint}] = cv::Vec3d(std::stod(x), std::stod(y), std::stod(z));
      }
    }
    ASSERT_EQ(truth.size(), static_cast<std::size_t>(dopt.frames * kJointCount));
    MotionOptions opt;
    opt.source = (dir / "truth" / "motion.bvh").string();
    const Motion again = Motion::create(opt, BodyDescription{});
    ASSERT_NE(again.bvh(), nullptr);
    EXPECT_EQ(again.bvh()->units, "m");
    const BvhMapping* original = scene.motion().bvh();
    EXPECT_EQ(again.bvh()->convention, original ? original->convention : "voxcap");
    EXPECT_EQ(again.natural_frames(), again.lead_in_frames() + dopt.frames);
    double worst = 0;
    for (int f = 0; f < dopt.frames; ++f) {
      const BodyPose bp = again.body_pose(again.lead_in_frames() + f);
      for (int j = 0; j < kJointCount; ++j) {
        const cv::Vec3d want = truth.at({f, std::string(joint_name(j))});
        worst = std::max(worst, cv::norm(bp.p_world[static_cast<std::size_t>(j)] - want));
      }
    }
    EXPECT_LT(worst, 1e-3) << "worst " << worst * 1000 << " mm";
    RecordProperty(fs::path(source).stem().string() + "_round_trip_worst_mm", std::to_string(worst * 1000));
    // The same file elsewhere (no scene.yaml beside it) is placed by the ordinary rules.
    const fs::path moved = fs::path(::testing::TempDir()) / "vc_sim_own_truth_moved.bvh";
    fs::copy_file(dir / "truth" / "motion.bvh", moved, fs::copy_options::overwrite_existing);
    opt.source = moved.string();
    const Motion placed = Motion::create(opt, BodyDescription{});
    EXPECT_EQ(placed.bvh()->convention, again.bvh()->convention);
    fs::remove_all(dir);
    fs::remove(moved);
  }
}

// Issue #12: the rig sees the initialization pose of every clip. A clip that travels further than the
// volume (a walk or run of 3.4-4.4 m across the 2.5 m volume) was centred on its path's middle, so its
// lead-in (the init pose, where the path starts) stood outside the volume, the fit never saw the init
// pose and fell back to a body of average proportions. Every joint of the held init pose of every
// shared clip lies inside the default volume, and a clip that starts near the axis stays centred.
TEST(SimBvhMotion, EveryClipStartsInsideTheDefaultVolume) {
  const auto files = clips();
  ASSERT_FALSE(files.empty()) << no_clips_message();
  const RigLayout layout;
  for (const fs::path& path : files) {
    SCOPED_TRACE(path.string());
    MotionOptions opt;
    opt.source = path.string();
    const Motion m = Motion::create(opt, BodyDescription{});
    for (int f = 0; m.clip_time(f) < -opt.lead_blend_s; ++f) {  // the held init pose
      const BodyPose bp = m.body_pose(f);
      for (int j = 0; j < kJointCount; ++j)
        for (int a = 0; a < 2; ++a) {
          EXPECT_GT(bp.p_world[static_cast<std::size_t>(j)][a], layout.volume_min_m[a]) << f << " " << j;
          EXPECT_LT(bp.p_world[static_cast<std::size_t>(j)][a], layout.volume_max_m[a]) << f << " " << j;
        }
    }
    // Without the limits the path is centred; a path that starts within them is left so.
    MotionOptions centred = opt;
    centred.bvh_start_within_x_m = centred.bvh_start_within_y_m = 0;
    const Motion c = Motion::create(centred, BodyDescription{});
    const glm::dvec3 start = m.bvh()->t_world_m, start_centred = c.bvh()->t_world_m;
    EXPECT_EQ(start.z, start_centred.z);
    const double moved = glm::length(start - start_centred);
    if (moved > 0) {  // only when the centred path started outside the limits
      const cv::Vec3d hips = c.body_pose(0).p(Joint::hips);
      EXPECT_TRUE(std::abs(hips[0]) > opt.bvh_start_within_x_m - 0.15 ||
                  std::abs(hips[1]) > opt.bvh_start_within_y_m - 0.15)
          << "moved " << moved << " m from a centred start at " << hips;
    }
  }
}

TEST(SimBvhMotion, ErrorsNameTheProblem) {
  MotionOptions opt;
  opt.source = "/nonexistent/clip.bvh";
  EXPECT_THROW(Motion::create(opt, BodyDescription{}), std::runtime_error);
  const fs::path p = fs::path(::testing::TempDir()) / "vc_sim_not_humanoid.bvh";
  {
    std::ofstream f(p);
    f << "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n"
         "JOINT Tail\n{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n}\n"
         "MOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0 0\n";
  }
  opt.source = p.string();
  try {
    (void)Motion::create(opt, BodyDescription{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr(p.string()), HasSubstr("not a humanoid hierarchy")));
  }
  opt.source = "moonwalk";
  try {
    (void)Motion::create(opt, BodyDescription{});
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("moonwalk"), HasSubstr("walk"), HasSubstr("arms-close")));
  }
  opt.source = "walk";
  opt.fps = 0;
  EXPECT_THROW(Motion::create(opt, BodyDescription{}), std::invalid_argument);
}

TEST(SimBuiltinMotion, JointsEqualTheForwardKinematicsOfTheExportedBvh) {
  for (const BuiltinMotion& bm : builtin_motions()) {
    SCOPED_TRACE(bm.name);
    MotionOptions opt;
    opt.source = bm.name;
    const Motion m = Motion::create(opt, BodyDescription{});
    const int frames = m.natural_frames();
    ASSERT_GT(frames, m.lead_in_frames());
    std::vector<Pose> poses;
    poses.reserve(static_cast<std::size_t>(frames));
    for (int f = 0; f < frames; ++f) poses.push_back(m.skeleton_pose(f));
    const BvhClip clip = parse_bvh(format_bvh(m.skeleton(), poses, 1.0 / m.fps()), bm.name);
    ASSERT_EQ(clip.frames, frames);
    double worst = 0;
    for (int f = 0; f < frames; ++f) {
      const std::vector<cv::Vec3d> ref = ref_fk(clip, ref_frame(clip, f));
      const BodyPose bp = m.body_pose(f);
      for (int j = 0; j < kJointCount; ++j) {
        const std::string name(joint_name(j));
        int fj = clip.skeleton.find(name);
        if (fj < 0) {
          // End Sites are named after their parent: head_top, hand tips.
          const int parent = m.skeleton().joints[static_cast<std::size_t>(j)].parent;
          fj = clip.skeleton.find(std::string(joint_name(parent)) + "_end");
        }
        ASSERT_GE(fj, 0) << name;
        worst = std::max(
            worst, cv::norm(bp.p_world[static_cast<std::size_t>(j)] - ref[static_cast<std::size_t>(fj)]));
      }
    }
    EXPECT_LT(worst, 1e-3) << "worst " << worst * 1000 << " mm";
    expect_init_pose(m, bm.name);
  }
}

// The built-in motions exported as the standard humanoid for Blender (Y up, metres, MotionBuilder
// names): read back, every joint's world position is the motion's within 1e-6 m on every frame,
// and the humanoid mapping finds every standard joint under its export name.
TEST(SimBuiltinMotion, ExportsAsTheStandardHumanoidForBlender) {
  const vc::body::BvhWriteOptions o = vc::body::BvhWriteOptions::blender();
  const glm::dmat3 world_from_file = glm::transpose(o.R_file_from_world);
  for (const BuiltinMotion& bm : builtin_motions()) {
    SCOPED_TRACE(bm.name);
    MotionOptions opt;
    opt.source = bm.name;
    const Motion m = Motion::create(opt, BodyDescription{});
    ASSERT_TRUE(vc::body::is_standard(m.skeleton()));
    std::vector<Pose> poses;
    poses.reserve(static_cast<std::size_t>(m.natural_frames()));
    for (int f = 0; f < m.natural_frames(); ++f) poses.push_back(m.skeleton_pose(f));
    const BvhClip clip = parse_bvh(format_bvh(m.skeleton(), poses, 1.0 / m.fps(), o), bm.name);
    ASSERT_EQ(clip.frames, m.natural_frames());
    std::vector<int> in_file(kJointCount);
    for (int j = 0; j < kJointCount; ++j) {
      const std::string name = vc::body::joint_is_end(j)
                                   ? std::string(vc::body::joint_bvh_name(vc::body::joint_parent(j))) + "_end"
                                   : std::string(vc::body::joint_bvh_name(j));
      in_file[static_cast<std::size_t>(j)] = clip.skeleton.find(name);
      ASSERT_GE(in_file[static_cast<std::size_t>(j)], 0) << name;
    }
    double worst = 0;
    std::vector<glm::dvec3> want, got;
    for (int f = 0; f < clip.frames; ++f) {
      vc::body::forward_kinematics(m.skeleton(), poses[static_cast<std::size_t>(f)], &want);
      vc::body::forward_kinematics(clip.skeleton, clip.pose(f), &got);
      for (int j = 0; j < kJointCount; ++j) {
        const glm::dvec3 p =
            world_from_file * got[static_cast<std::size_t>(in_file[static_cast<std::size_t>(j)])];
        worst = std::max(worst, glm::length(p - want[static_cast<std::size_t>(j)]));
      }
    }
    EXPECT_LT(worst, 1e-6) << "worst " << worst * 1e6 << " um";
    const vc::body::HumanoidClip h = vc::body::map_humanoid(clip, bm.name + ".bvh");
    for (int j = 0; j < kJointCount; ++j) {
      if (vc::body::joint_is_end(j)) continue;
      EXPECT_EQ(h.map.anchor[static_cast<std::size_t>(j)], in_file[static_cast<std::size_t>(j)])
          << joint_name(j);
    }
  }
}

// Per-motion sanity: continuity, feet on the floor, and what the motion is meant to show.
TEST(SimBuiltinMotion, EachMotionDoesWhatItsNameSays) {
  const BodyDescription body;
  for (const BuiltinMotion& bm : builtin_motions()) {
    SCOPED_TRACE(bm.name);
    MotionOptions opt;
    opt.source = bm.name;
    const Motion m = Motion::create(opt, body);
    double max_step = 0, min_hips = HUGE_VAL, max_wrist_over_head = -HUGE_VAL, min_hand_gap = HUGE_VAL;
    double min_wrist_to_hip = HUGE_VAL, ymin = HUGE_VAL, ymax = -HUGE_VAL, crossed = -HUGE_VAL, yaw_total = 0;
    BodyPose prev = m.body_pose(0);
    auto heading = [](const BodyPose& p) {
      const cv::Vec3d l = p.p(Joint::l_hip) - p.p(Joint::r_hip);
      return std::atan2(l[1], l[0]);
    };
    const int frames = m.lead_in_frames() + static_cast<int>(std::ceil(bm.cycle_s * m.fps()));
    for (int f = 1; f <= frames; ++f) {
      const BodyPose p = m.body_pose(f);
      for (int j = 0; j < kJointCount; ++j) {
        max_step = std::max(max_step, cv::norm(p.p_world[static_cast<std::size_t>(j)] -
                                               prev.p_world[static_cast<std::size_t>(j)]));
      }
      double dyaw = heading(p) - heading(prev);
      dyaw = std::remainder(dyaw, 2 * M_PI);
      yaw_total += dyaw;
      min_hips = std::min(min_hips, p.p(Joint::hips)[2]);
      max_wrist_over_head = std::max({max_wrist_over_head, p.p(Joint::l_wrist)[2] - p.p(Joint::head)[2],
                                      p.p(Joint::r_wrist)[2] - p.p(Joint::head)[2]});
      min_hand_gap = std::min(min_hand_gap, cv::norm(p.p(Joint::l_wrist) - p.p(Joint::r_wrist)));
      min_wrist_to_hip = std::min(min_wrist_to_hip, cv::norm(p.p(Joint::l_wrist) - p.p(Joint::hips)));
      ymin = std::min(ymin, p.p(Joint::hips)[1]);
      ymax = std::max(ymax, p.p(Joint::hips)[1]);
      // Crossed: in the performer's own frame, the left wrist right of the right wrist.
      const cv::Vec3d left = cv::normalize(p.p(Joint::l_shoulder) - p.p(Joint::r_shoulder));
      crossed = std::max(crossed, (p.p(Joint::r_wrist) - p.p(Joint::l_wrist)).dot(left));
      std::vector<Primitive> prims;
      build_primitives(p, body, m.feet(), &prims);
      prev = p;
    }
    EXPECT_LT(max_step, 0.12) << "a joint jumped (m per frame)";
    const double stand = m.body_pose(0).p(Joint::hips)[2];
    if (bm.name == "squat") {
      EXPECT_LT(min_hips, stand - 0.35);
    } else {
      EXPECT_GT(min_hips, stand - 0.15);
    }
    if (bm.name == "wave") {
      EXPECT_GT(max_wrist_over_head, 0.1);
    }
    if (bm.name == "walk") {
      EXPECT_LT(ymin, -0.7);
      EXPECT_GT(ymax, 0.7);
      EXPECT_NEAR(yaw_total, 2 * M_PI, 0.2);
    } else if (bm.name != "turn") {
      EXPECT_LT(ymax - ymin, 0.35);
    }
    if (bm.name == "turn") {
      EXPECT_NEAR(yaw_total, 2 * M_PI, 0.2);
    }
    if (bm.name == "arms-close") {
      EXPECT_LT(min_hand_gap, 0.08);     // clapping
      EXPECT_LT(min_wrist_to_hip, 0.3);  // hands at the hips
    }
    if (bm.name == "cross") {
      EXPECT_GT(crossed, 0.2);
    }
  }
}

TEST(SimBuiltinMotion, FeetStayOnTheFloor) {
  const BodyDescription body;
  for (const char* name : {"walk", "walk-in-place", "squat", "turn", "arms-close"}) {
    SCOPED_TRACE(name);
    MotionOptions opt;
    opt.source = name;
    const Motion m = Motion::create(opt, body);
    for (int f = m.lead_in_frames(); f < m.natural_frames(); f += 7) {
      std::vector<Primitive> prims;
      build_primitives(m.body_pose(f), body, m.feet(), &prims);
      double lowest = HUGE_VAL;
      for (const Primitive& p : prims) {
        for (const cv::Vec3d& c : p.box_corners()) lowest = std::min(lowest, c[2]);
      }
      // The box corners bound the body from below; the lowest sole touches the floor.
      EXPECT_LT(lowest, 0.005);
      EXPECT_GT(lowest, -0.05);
    }
  }
}

}  // namespace
}  // namespace vc::sim
