// The humanoid mapping: hierarchies written under the naming conventions of common tools (Mixamo,
// SMPL, 3ds Max Biped, Unity, Blender, Unreal, CMU ASF, MotionBuilder HumanIK, cgspeed), in metres,
// centimetres, millimetres or unknown units, Y or Z up, facing anywhere, must map onto the standard joints
// with the standard skeleton's shape; every real clip of the shared data folder (listed) must map upright,
// facing -y, toes on the floor; non-humanoids are refused with the missing joint named.
#include "voxcap/body/humanoid.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "voxcap/body/testing/shared_clips.hpp"

namespace vc::body {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

double deg(double d) {
  return d * M_PI / 180.0;
}

// A naming convention: a name per standard joint (end points unnamed) and optional extra joints
// (clavicles between spine and shoulders, hip joints between hips and thighs, a chest between
// spine and neck) that the mapping must skip.
struct Convention {
  std::string label;
  std::map<Joint, std::string> names;
  std::string l_collar, r_collar, l_hipjoint, r_hipjoint, chest;
};

Convention convention(const std::string& label, const std::string& hips, const std::string& spine,
                      const std::string& neck, const std::string& head,
                      const std::array<std::string, 8>& left, const std::array<std::string, 8>& right,
                      const std::array<std::string, 5>& extras) {
  Convention c;
  c.label = label;
  c.names = {{Joint::hips, hips}, {Joint::spine, spine}, {Joint::neck, neck}, {Joint::head, head}};
  const Joint L[] = {Joint::l_shoulder, Joint::l_elbow, Joint::l_wrist, Joint::l_hip,
                     Joint::l_knee,     Joint::l_ankle, Joint::l_toe};
  const Joint R[] = {Joint::r_shoulder, Joint::r_elbow, Joint::r_wrist, Joint::r_hip,
                     Joint::r_knee,     Joint::r_ankle, Joint::r_toe};
  for (int i = 0; i < 7; ++i) {
    c.names[L[i]] = left[static_cast<std::size_t>(i)];
    c.names[R[i]] = right[static_cast<std::size_t>(i)];
  }
  c.l_collar = extras[0];
  c.r_collar = extras[1];
  c.l_hipjoint = extras[2];
  c.r_hipjoint = extras[3];
  c.chest = extras[4];
  return c;
}

const std::vector<Convention>& conventions() {
  static const std::vector<Convention> list = {
      convention(
          "mixamo", "mixamorig:Hips", "mixamorig:Spine", "mixamorig:Neck", "mixamorig:Head",
          {"mixamorig:LeftArm", "mixamorig:LeftForeArm", "mixamorig:LeftHand", "mixamorig:LeftUpLeg",
           "mixamorig:LeftLeg", "mixamorig:LeftFoot", "mixamorig:LeftToeBase", ""},
          {"mixamorig:RightArm", "mixamorig:RightForeArm", "mixamorig:RightHand", "mixamorig:RightUpLeg",
           "mixamorig:RightLeg", "mixamorig:RightFoot", "mixamorig:RightToeBase", ""},
          {"mixamorig:LeftShoulder", "mixamorig:RightShoulder", "", "", "mixamorig:Spine1"}),
      convention("smpl", "Pelvis", "Spine1", "Neck", "Head",
                 {"L_Shoulder", "L_Elbow", "L_Wrist", "L_Hip", "L_Knee", "L_Ankle", "L_Foot", ""},
                 {"R_Shoulder", "R_Elbow", "R_Wrist", "R_Hip", "R_Knee", "R_Ankle", "R_Foot", ""},
                 {"L_Collar", "R_Collar", "", "", "Spine3"}),
      convention("biped", "Bip01 Pelvis", "Bip01 Spine", "Bip01 Neck", "Bip01 Head",
                 {"Bip01 L UpperArm", "Bip01 L Forearm", "Bip01 L Hand", "Bip01 L Thigh", "Bip01 L Calf",
                  "Bip01 L Foot", "Bip01 L Toe0", ""},
                 {"Bip01 R UpperArm", "Bip01 R Forearm", "Bip01 R Hand", "Bip01 R Thigh", "Bip01 R Calf",
                  "Bip01 R Foot", "Bip01 R Toe0", ""},
                 {"Bip01 L Clavicle", "Bip01 R Clavicle", "", "", "Bip01 Spine1"}),
      convention("unity", "Hips", "Spine", "Neck", "Head",
                 {"LeftUpperArm", "LeftLowerArm", "LeftHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot",
                  "LeftToes", ""},
                 {"RightUpperArm", "RightLowerArm", "RightHand", "RightUpperLeg", "RightLowerLeg",
                  "RightFoot", "RightToes", ""},
                 {"LeftShoulder", "RightShoulder", "", "", "Chest"}),
      // No joint named neck: the head's parent stands in for it.
      convention("unity-no-neck", "Hips", "Spine", "UpperChest", "Head",
                 {"LeftUpperArm", "LeftLowerArm", "LeftHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot",
                  "LeftToes", ""},
                 {"RightUpperArm", "RightLowerArm", "RightHand", "RightUpperLeg", "RightLowerLeg",
                  "RightFoot", "RightToes", ""},
                 {"", "", "", "", "Chest"}),
      convention("blender", "pelvis", "spine", "neck", "head",
                 {"upper_arm.L", "forearm.L", "hand.L", "thigh.L", "shin.L", "foot.L", "toe.L", ""},
                 {"upper_arm.R", "forearm.R", "hand.R", "thigh.R", "shin.R", "foot.R", "toe.R", ""},
                 {"clavicle.L", "clavicle.R", "", "", "spine.001"}),
      convention("unreal", "pelvis", "spine_01", "neck_01", "head",
                 {"upperarm_l", "lowerarm_l", "hand_l", "thigh_l", "calf_l", "foot_l", "ball_l", ""},
                 {"upperarm_r", "lowerarm_r", "hand_r", "thigh_r", "calf_r", "foot_r", "ball_r", ""},
                 {"clavicle_l", "clavicle_r", "", "", "spine_02"}),
      convention("cmu-asf", "root", "upperback", "lowerneck", "head",
                 {"lhumerus", "lradius", "lwrist", "lfemur", "ltibia", "lfoot", "ltoes", ""},
                 {"rhumerus", "rradius", "rwrist", "rfemur", "rtibia", "rfoot", "rtoes", ""},
                 {"lclavicle", "rclavicle", "lhipjoint", "rhipjoint", "thorax"}),
      convention(
          "humanik", "Character1_Hips", "Character1_Spine", "Character1_Neck", "Character1_Head",
          {"Character1_LeftArm", "Character1_LeftForeArm", "Character1_LeftHand", "Character1_LeftUpLeg",
           "Character1_LeftLeg", "Character1_LeftFoot", "Character1_LeftToeBase", ""},
          {"Character1_RightArm", "Character1_RightForeArm", "Character1_RightHand", "Character1_RightUpLeg",
           "Character1_RightLeg", "Character1_RightFoot", "Character1_RightToeBase", ""},
          {"Character1_LeftShoulder", "Character1_RightShoulder", "", "", "Character1_Spine1"}),
      convention(
          "cgspeed-3dsmax", "Hips", "Chest", "lowerneck", "Head",
          {"LeftShoulder", "LeftElbow", "LeftWrist", "LeftHip", "LeftKnee", "LeftAnkle", "LeftToe", ""},
          {"RightShoulder", "RightElbow", "RightWrist", "RightHip", "RightKnee", "RightAnkle", "RightToe",
           ""},
          {"LeftCollar", "RightCollar", "LHipJoint", "RHipJoint", "Chest2"}),
  };
  return list;
}

// The standard skeleton under a convention's names, with its extra joints inserted (each takes
// half of the segment it splits). index[j]: the file joint of standard joint j.
Skeleton named_skeleton(const Convention& c, std::array<int, kJointCount>* index) {
  const Skeleton s = standard_skeleton({});
  Skeleton out;
  auto add = [&](const std::string& name, int parent, const glm::dvec3& offset, bool end) {
    out.joints.push_back({name, parent, offset, end});
    return static_cast<int>(out.joints.size()) - 1;
  };
  for (int j = 0; j < kJointCount; ++j) {
    const SkeletonJoint& sj = s.joints[static_cast<std::size_t>(j)];
    int parent = sj.parent < 0 ? -1 : (*index)[static_cast<std::size_t>(sj.parent)];
    glm::dvec3 offset = sj.offset;
    std::string extra;
    if (j == static_cast<int>(Joint::l_shoulder)) extra = c.l_collar;
    if (j == static_cast<int>(Joint::r_shoulder)) extra = c.r_collar;
    if (j == static_cast<int>(Joint::l_hip)) extra = c.l_hipjoint;
    if (j == static_cast<int>(Joint::r_hip)) extra = c.r_hipjoint;
    if (j == static_cast<int>(Joint::neck)) extra = c.chest;
    if (!extra.empty()) {
      parent = add(extra, parent, 0.5 * offset, false);
      offset *= 0.5;
    }
    const auto it = c.names.find(static_cast<Joint>(j));
    const std::string name = it != c.names.end() ? it->second : sj.name;
    (*index)[static_cast<std::size_t>(j)] = add(name, parent, offset, sj.end_site);
  }
  // Parents must precede children: a joint added after its inserted parent always does.
  EXPECT_TRUE(out.valid(nullptr));
  return out;
}

struct Axes {
  std::string label;
  glm::dmat3 R_file_from_world;
};

TEST(BodyHumanoid, EveryNamingConventionUnitAndAxisMaps) {
  const std::vector<Axes> axes = {
      {"y-up facing +z", from_rows(1, 0, 0, 0, 0, 1, 0, -1, 0)},
      {"z-up facing -y", glm::dmat3(1.0)},
      {"z-up facing +x", rot_z(deg(90))},
      {"y-up facing -x", from_rows(1, 0, 0, 0, 0, 1, 0, -1, 0) * rot_z(deg(-90))},
  };
  // Inches are detected (a rest pose 50-85 tall); 25 units per metre is no known unit (height).
  const std::vector<std::pair<double, std::string>> units = {
      {1.0, "m"}, {100.0, "cm"}, {1000.0, "mm"}, {1 / 0.0254, "in"}, {25.0, "height"}};
  for (const Convention& c : conventions()) {
    std::array<int, kJointCount> index{};
    const Skeleton sk = named_skeleton(c, &index);
    for (const Axes& ax : axes) {
      for (const auto& [per_metre, unit] : units) {
        SCOPED_TRACE(c.label + ", " + ax.label + ", " + unit);
        // Three frames: standing turned by 0/10/20 degrees, the left arm lowering, walking forward.
        std::vector<Pose> poses;
        for (int f = 0; f < 3; ++f) {
          Pose p = rest_pose(sk, {0, -0.2 * f, 0.95});
          p.local[0] = rot_z(deg(10 * f));
          p.local[static_cast<std::size_t>(index[static_cast<std::size_t>(Joint::l_shoulder)])] =
              rot_y(deg(20 * f + 0.5));
          poses.push_back(p);
        }
        BvhWriteOptions w;
        w.R_file_from_world = ax.R_file_from_world;
        w.units_per_metre = per_metre;
        const std::string text = format_bvh(sk, poses, 1.0 / 30, w);
        HumanoidClip h;
        ASSERT_NO_THROW(h = map_humanoid(parse_bvh(text, c.label), c.label + ".bvh")) << text.substr(0, 400);
        // cgspeed files (LHipJoint/RHipJoint) are CMU units whatever they measure.
        const bool cgspeed = c.label == "cgspeed-3dsmax";
        EXPECT_EQ(h.map.units, cgspeed ? "cmu" : unit);
        if (cgspeed) {
          EXPECT_DOUBLE_EQ(h.map.scale, 0.056444);
        } else if (unit != "height") {
          EXPECT_NEAR(h.map.scale * per_metre, 1.0, 1e-12);
        }
        EXPECT_EQ(h.map.convention, c.label == "cgspeed-3dsmax" ? "cgspeed-3dsmax" : "generic");
        // (The file has a zero End Site after each toe: compare by name, not index.)
        for (int j = 0; j < kJointCount; ++j) {
          if (joint_is_end(j)) continue;
          EXPECT_EQ(
              h.clip.skeleton.joints[static_cast<std::size_t>(h.map.anchor[static_cast<std::size_t>(j)])]
                  .name,
              sk.joints[static_cast<std::size_t>(index[static_cast<std::size_t>(j)])].name)
              << joint_name(j);
        }
        // The mapped clip is the original up to the placement: upright, facing -y in frame 0.
        // (cgspeed units are CMU units; the shape is compared after undoing the scale.)
        const double k = unit == "height" || cgspeed ? h.map.scale * per_metre : 1.0;
        std::vector<glm::dvec3> want, got;
        forward_kinematics(sk, poses[0], &want);
        forward_kinematics(h.skeleton, h.frame_pose(0), &got);
        const glm::dvec3 w0 = want[0], g0 = got[0];
        double worst = 0;
        for (int j = 0; j < kJointCount; ++j) {
          if (joint_is_end(j)) continue;
          // Frame 0 of `poses` is not turned, so the placement is a translation (and a scale).
          const glm::dvec3 g = got[static_cast<std::size_t>(h.map.anchor[static_cast<std::size_t>(j)])];
          const glm::dvec3 wj = want[static_cast<std::size_t>(index[static_cast<std::size_t>(j)])];
          worst = std::max(worst, glm::length((g - g0) / k - (wj - w0)));
        }
        EXPECT_LT(worst, 1e-6);
        const int toe = h.map.anchor[static_cast<std::size_t>(Joint::l_toe)];
        double lowest = HUGE_VAL;
        for (int f = 0; f < 3; ++f) {
          forward_kinematics(h.skeleton, h.frame_pose(f), &got);
          lowest = std::min(
              {lowest, got[static_cast<std::size_t>(toe)].z,
               got[static_cast<std::size_t>(h.map.anchor[static_cast<std::size_t>(Joint::r_toe)])].z});
        }
        EXPECT_NEAR(lowest, HumanoidOptions{}.toe_height_m, 1e-9);
      }
    }
  }
}

TEST(BodyHumanoid, RefusesNonHumanoidsNamingTheMissingJoint) {
  const std::string tail =
      "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n"
      "JOINT Tail\n{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n}\n"
      "MOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0 0\n";
  try {
    (void)map_humanoid(parse_bvh(tail), "tail.bvh");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(),
                AllOf(HasSubstr("tail.bvh"), HasSubstr("not a humanoid hierarchy"), HasSubstr("head")));
  }
  // A right hand under an unknown name: the names do not decide, the hierarchy does.
  std::array<int, kJointCount> index{};
  Convention c = conventions()[0];
  Skeleton sk = named_skeleton(c, &index);
  for (auto& j : sk.joints) {
    if (j.name == "mixamorig:RightHand") j.name = "mixamorig:RightPaw";
  }
  std::string text = format_bvh(sk, {rest_pose(sk)}, 0.1);
  const HumanoidClip paw = map_humanoid(parse_bvh(text), "paw.bvh");
  EXPECT_EQ(paw.map.convention, "hierarchy");
  EXPECT_EQ(paw.map.file_joint_name[static_cast<std::size_t>(Joint::r_wrist)], "mixamorig:RightPaw");
  EXPECT_EQ(paw.map.file_joint_name[static_cast<std::size_t>(Joint::l_wrist)], "mixamorig:LeftHand");
  // A one-armed figure (the right arm cut off at the clavicle): the right wrist is missing, by
  // the names and by the hierarchy.
  Skeleton one_arm;
  std::vector<int> new_index(sk.joints.size(), -1);
  for (std::size_t j = 0; j < sk.joints.size(); ++j) {
    const int par = sk.joints[j].parent;
    if (sk.joints[j].name == "mixamorig:RightShoulder" ||
        (par >= 0 && new_index[static_cast<std::size_t>(par)] < 0))
      continue;
    SkeletonJoint jt = sk.joints[j];
    jt.parent = par < 0 ? -1 : new_index[static_cast<std::size_t>(par)];
    new_index[j] = static_cast<int>(one_arm.joints.size());
    one_arm.joints.push_back(jt);
  }
  ASSERT_LT(one_arm.joints.size(), sk.joints.size() - 3);
  text = format_bvh(one_arm, {rest_pose(one_arm)}, 0.1);
  try {
    (void)map_humanoid(parse_bvh(text), "paw.bvh");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("paw.bvh"), HasSubstr("r_wrist"), HasSubstr("right hand"),
                                HasSubstr("by the hierarchy: no spine with two arms and a head")));
  }
  HumanoidOptions bad;
  bad.height_m = 0;
  EXPECT_THROW(map_humanoid(parse_bvh(text), "x", bad), std::invalid_argument);
  EXPECT_THROW(read_humanoid("/nonexistent/clip.bvh"), std::runtime_error);
}

TEST(BodyHumanoid, EveryRealClipMapsUprightFacingTheFrontOnTheFloor) {
  const std::vector<fs::path> clips = testing::shared_bvh_clips();
  ASSERT_FALSE(clips.empty()) << testing::no_clips_message();
  for (const fs::path& path : clips) {
    SCOPED_TRACE(path.string());
    const HumanoidClip h = read_humanoid(path.string());
    EXPECT_NEAR(glm::determinant(h.map.R_world_from_file), 1.0, 1e-12);
    EXPECT_GT(h.map.frame_time_s, 0);
    EXPECT_GT(h.length_s(), 0.5);
    // Standard joints come from distinct file joints (except the derived ones).
    std::vector<int> used;
    for (int j = 0; j < kJointCount; ++j) {
      const int fj = h.map.file_joint[static_cast<std::size_t>(j)];
      if (fj < 0) continue;
      EXPECT_EQ(std::count(used.begin(), used.end(), fj), 0) << joint_name(j);
      used.push_back(fj);
    }
    std::vector<glm::dvec3> p;
    forward_kinematics(h.skeleton, h.frame_pose(h.map.first_frame), &p);
    auto P = [&](Joint j) { return p[static_cast<std::size_t>(h.map.anchor[static_cast<std::size_t>(j)])]; };
    EXPECT_GT(P(Joint::head).z, P(Joint::hips).z + 0.3);
    EXPECT_GT(P(Joint::hips).z, P(Joint::l_ankle).z + 0.4);
    EXPECT_GT(P(Joint::l_hip).x, P(Joint::r_hip).x);  // facing -y: the left is +x
    EXPECT_GT(P(Joint::l_shoulder).x, P(Joint::r_shoulder).x);
    const double height = P(Joint::head).z - std::min(P(Joint::l_toe).z, P(Joint::r_toe).z);
    EXPECT_GT(height, 1.2);
    EXPECT_LT(height, 2.1);
    // The clip's lowest toe is on the floor (at toe_height_m).
    double lowest = HUGE_VAL;
    for (int f = h.map.first_frame; f < h.map.frames; ++f) {
      forward_kinematics(h.skeleton, h.frame_pose(f), &p);
      lowest = std::min({lowest, P(Joint::l_toe).z, P(Joint::r_toe).z});
    }
    EXPECT_NEAR(lowest, HumanoidOptions{}.toe_height_m, 1e-9);
  }
}

// Issue #13: every value finite after scaling. A rest pose 1e-300 tall (finite, within the reader's
// magnitude limit) was scaled to a body's height by 1.7e300, and its root positions became inf/NaN
// truth. Refused by name; and read_bvh refuses a FIFO at once instead of waiting for a writer.
TEST(BodyHumanoid, ScaleThatMakesTheTruthInfiniteIsRefused) {
  std::array<int, kJointCount> index{};
  const Skeleton sk = named_skeleton(conventions()[0], &index);
  const std::string text = format_bvh(sk, {rest_pose(sk, {0, 0, 0.95})}, 1.0 / 30, BvhWriteOptions{});
  std::string tiny;  // every OFFSET number times 1e-300
  std::size_t start = 0;
  for (std::size_t nl; (nl = text.find('\n', start)) != std::string::npos; start = nl + 1) {
    std::string line = text.substr(start, nl - start);
    const std::size_t at = line.find("OFFSET ");
    if (at != std::string::npos) {
      std::string out = line.substr(0, at + 7);
      std::size_t p = at + 7;
      for (std::size_t sp; p < line.size(); p = sp + 1) {
        sp = line.find(' ', p);
        if (sp == std::string::npos) sp = line.size();
        out += line.substr(p, sp - p) + "e-300" + (sp < line.size() ? " " : "");
      }
      line = out;
    }
    tiny += line + "\n";
  }
  ASSERT_NE(tiny, text);
  const BvhClip clip = parse_bvh(tiny, "tiny.bvh");  // every number is in range for the reader
  try {
    (void)map_humanoid(clip, "tiny.bvh");
    ADD_FAILURE() << "a 1e-300 tall rest pose was scaled to a body";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("tiny.bvh: the rest pose (height"));
    EXPECT_THAT(e.what(), HasSubstr("is not a body"));
  }
  // The same file in metres maps, and its truth is finite.
  const HumanoidClip h = map_humanoid(parse_bvh(text, "m.bvh"), "m.bvh");
  std::vector<glm::dvec3> p;
  forward_kinematics(h.skeleton, h.sample(0.0), &p);
  for (const glm::dvec3& q : p) EXPECT_TRUE(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z));

  const fs::path fifo = fs::temp_directory_path() / ("vc_body_fifo_" + std::to_string(::getpid()) + ".bvh");
  fs::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    (void)read_bvh(fifo.string());
    ADD_FAILURE() << "a FIFO was read";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), fifo.string() + ": not a regular file");
  }
  fs::remove(fifo);
}

// Issue #12: a clip that travels further than the capture volume (CMU's walks and runs go 3.4-4.4 m
// in a line, the volume is 2.5 m) was centred on its path's middle, so it began and ended outside the
// volume and the initialization pose of the lead-in was never seen by the rig. With start_within_*_m
// the path is moved just enough for the first frame's root to be that near the axis; a path that
// already starts there is left centred, and the path's shape is untouched.
TEST(BodyHumanoid, ALongPathStartsWithinTheAskedDistanceOfTheAxis) {
  std::array<int, kJointCount> index{};
  const Skeleton sk = named_skeleton(conventions()[0], &index);
  auto walk = [&sk](double metres) {  // forward (-y of the standard skeleton), 2 cm to the left
    std::vector<Pose> poses;
    poses.reserve(61);
    for (int i = 0; i < 61; ++i) poses.push_back(rest_pose(sk, {0.02 * i / 60, -metres * i / 60, 0.95}));
    return parse_bvh(format_bvh(sk, poses, 1.0 / 30, BvhWriteOptions{}), "walk.bvh");
  };
  auto root = [](const HumanoidClip& h, int f) {
    std::vector<glm::dvec3> p;
    forward_kinematics(h.skeleton, h.frame_pose(f), &p);
    return p[static_cast<std::size_t>(h.map.anchor[static_cast<std::size_t>(Joint::hips)])];
  };
  HumanoidOptions within;
  within.start_within_x_m = 0.35;
  within.start_within_y_m = 0.9;
  const HumanoidClip centred = map_humanoid(walk(4.0), "walk.bvh");
  const HumanoidClip started = map_humanoid(walk(4.0), "walk.bvh", within);
  // Centred: the 4 m walk starts 2 m from the axis (outside a 2.5 m volume).
  EXPECT_NEAR(std::abs(root(centred, 0).y), 2.0, 1e-6);
  // Moved: it starts 0.9 m from the axis, on the side it walks away from, and walks the same 4 m.
  EXPECT_NEAR(root(started, 0).y, 0.9, 1e-6);
  EXPECT_NEAR(root(started, 60).y, 0.9 - 4.0, 1e-6);
  EXPECT_NEAR(root(started, 0).x, root(centred, 0).x, 1e-9);  // x was within its limit: centred
  EXPECT_NEAR(root(started, 0).z, root(centred, 0).z, 1e-9);
  // A 1 m walk starts 0.5 m from the axis: within the limit, centred as before.
  const HumanoidClip short_centred = map_humanoid(walk(1.0), "walk.bvh");
  const HumanoidClip short_started = map_humanoid(walk(1.0), "walk.bvh", within);
  EXPECT_NEAR(glm::length(root(short_started, 0) - root(short_centred, 0)), 0.0, 1e-9);
  EXPECT_NEAR(root(short_started, 0).y, 0.5, 1e-6);
  HumanoidOptions bad;
  bad.start_within_y_m = -1;
  EXPECT_FALSE(bad.valid(nullptr));
}
}  // namespace
}  // namespace vc::body
