// The humanoid mapping on BVH files as public motion data writes them, generated here (never copied):
// the naming families (Mixamo, 3ds Max Biped, game engines' UpperArm_L / upperarm_l, SMPL, and names
// that say nothing, Joint1..JointN), with and without neck, clavicle, toe and finger joints, every
// joint with six channels whose positions replace the OFFSET, end joints without End Sites, rest poses
// that are not T-poses (A-pose, arms down), Y-up and Z-up, units in m, cm, mm and inches. The ground
// truth is the generator's own world: every mapped standard joint must be where the generator put the
// joint it stands for, on every frame, up to the placement's translation (and the scale for unknown
// units).
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "voxcap/body/humanoid.hpp"
#include "voxcap/body/testing/shared_clips.hpp"

namespace vc::body {
namespace {

using ::testing::HasSubstr;

double deg(double d) {
  return d * M_PI / 180.0;
}

// Parts of the generated body; a family names each (side: +1 left, -1 right, 0 none).
enum class Part {
  hips,
  spine,
  chest,
  neck,
  head,
  clavicle,
  upper_arm,
  forearm,
  hand,
  finger,
  thigh,
  shin,
  foot,
  toe
};

struct Family {
  std::string label;
  std::function<std::string(Part, int side, int index)> name;
};

std::string sided(const std::string& left, const std::string& right, int side, const std::string& base) {
  return side > 0 ? left + base : side < 0 ? right + base : base;
}

std::vector<Family> families() {
  std::vector<Family> f;
  f.push_back({"mixamo", [](Part p, int s, int i) {
                 static const std::map<Part, std::string> n = {
                     {Part::hips, "Hips"},        {Part::spine, "Spine"},     {Part::chest, "Spine2"},
                     {Part::neck, "Neck"},        {Part::head, "Head"},       {Part::clavicle, "Shoulder"},
                     {Part::upper_arm, "Arm"},    {Part::forearm, "ForeArm"}, {Part::hand, "Hand"},
                     {Part::finger, "HandIndex"}, {Part::thigh, "UpLeg"},     {Part::shin, "Leg"},
                     {Part::foot, "Foot"},        {Part::toe, "ToeBase"}};
                 std::string base = n.at(p) + (p == Part::finger ? std::to_string(i + 1) : "");
                 return "mixamorig:" + sided("Left", "Right", s, base);
               }});
  f.push_back({"biped", [](Part p, int s, int i) {
                 static const std::map<Part, std::string> n = {
                     {Part::hips, "Pelvis"},        {Part::spine, "Spine"},     {Part::chest, "Spine1"},
                     {Part::neck, "Neck"},          {Part::head, "Head"},       {Part::clavicle, "Clavicle"},
                     {Part::upper_arm, "UpperArm"}, {Part::forearm, "Forearm"}, {Part::hand, "Hand"},
                     {Part::finger, "Finger2"},     {Part::thigh, "Thigh"},     {Part::shin, "Calf"},
                     {Part::foot, "Foot"},          {Part::toe, "Toe0"}};
                 std::string base = n.at(p) + (p == Part::finger && i > 0 ? std::to_string(i) : "");
                 return "Bip01 " + sided("L ", "R ", s, base);
               }});
  f.push_back({"game-engine", [](Part p, int s, int i) {
                 static const std::map<Part, std::string> n = {
                     {Part::hips, "Pelvis"},        {Part::spine, "Spine_01"},   {Part::chest, "Spine_03"},
                     {Part::neck, "Neck_01"},       {Part::head, "Head"},        {Part::clavicle, "Clavicle"},
                     {Part::upper_arm, "UpperArm"}, {Part::forearm, "LowerArm"}, {Part::hand, "Hand"},
                     {Part::finger, "Middle_0"},    {Part::thigh, "Thigh"},      {Part::shin, "Calf"},
                     {Part::foot, "Foot"},          {Part::toe, "Ball"}};
                 std::string base = n.at(p) + (p == Part::finger ? std::to_string(i + 1) : "");
                 return s > 0 ? base + "_L" : s < 0 ? base + "_R" : base;
               }});
  f.push_back({"game-engine-lower", [](Part p, int s, int i) {
                 static const std::map<Part, std::string> n = {
                     {Part::hips, "pelvis"},        {Part::spine, "spine_01"},   {Part::chest, "spine_03"},
                     {Part::neck, "neck_01"},       {Part::head, "head"},        {Part::clavicle, "clavicle"},
                     {Part::upper_arm, "upperarm"}, {Part::forearm, "lowerarm"}, {Part::hand, "hand"},
                     {Part::finger, "middle_0"},    {Part::thigh, "thigh"},      {Part::shin, "calf"},
                     {Part::foot, "foot"},          {Part::toe, "ball"}};
                 std::string base = n.at(p) + (p == Part::finger ? std::to_string(i + 1) : "");
                 return s > 0 ? base + "_l" : s < 0 ? base + "_r" : base;
               }});
  f.push_back({"smpl", [](Part p, int s, int i) {
                 static const std::map<Part, std::string> n = {
                     {Part::hips, "Pelvis"},        {Part::spine, "Spine1"},  {Part::chest, "Spine3"},
                     {Part::neck, "Neck"},          {Part::head, "Head"},     {Part::clavicle, "Collar"},
                     {Part::upper_arm, "Shoulder"}, {Part::forearm, "Elbow"}, {Part::hand, "Wrist"},
                     {Part::finger, "Hand"},        {Part::thigh, "Hip"},     {Part::shin, "Knee"},
                     {Part::foot, "Ankle"},         {Part::toe, "Foot"}};
                 std::string base = n.at(p) + (p == Part::finger && i > 0 ? std::to_string(i) : "");
                 return sided("L_", "R_", s, base);
               }});
  return f;
}

// Names that say nothing: Joint1, Joint2, ... in the order the joints are made.
Family nameless() {
  auto counter = std::make_shared<int>(0);
  return {"nameless", [counter](Part, int, int) { return "Joint" + std::to_string(++*counter); }};
}

enum class Rest { t_pose, a_pose, arms_down };

struct Shape {
  bool neck = true, clavicle = true, toe = true, fingers = false, end_sites = true;
  Rest rest = Rest::t_pose;
};

// The generated body in the world (metres, z up, facing -y, left +x) and which generated joint
// each standard joint is.
struct Body {
  Skeleton sk;
  std::map<Joint, int> at;
};

Body make_body(const Family& fam, const Shape& shape) {
  Body b;
  auto add = [&](const std::string& name, int parent, const glm::dvec3& off, bool end = false) {
    b.sk.joints.push_back({name, parent, off, end});
    return static_cast<int>(b.sk.joints.size()) - 1;
  };
  auto end_site = [&](int parent, const glm::dvec3& off) {
    if (shape.end_sites) add(b.sk.joints[static_cast<std::size_t>(parent)].name + "_end", parent, off, true);
  };
  const int hips = add(fam.name(Part::hips, 0, 0), -1, {0, 0, 0});
  b.at[Joint::hips] = hips;
  // Legs first (as most exporters write them).
  for (int s : {1, -1}) {
    const int thigh = add(fam.name(Part::thigh, s, 0), hips, {s * 0.09, 0, -0.07});
    const int shin = add(fam.name(Part::shin, s, 0), thigh, {0, 0.01, -0.43});
    const int foot = add(fam.name(Part::foot, s, 0), shin, {0, -0.01, -0.43});
    b.at[s > 0 ? Joint::l_hip : Joint::r_hip] = thigh;
    b.at[s > 0 ? Joint::l_knee : Joint::r_knee] = shin;
    b.at[s > 0 ? Joint::l_ankle : Joint::r_ankle] = foot;
    if (shape.toe) {
      const int toe = add(fam.name(Part::toe, s, 0), foot, {0, -0.14, -0.058});
      b.at[s > 0 ? Joint::l_toe : Joint::r_toe] = toe;
      end_site(toe, {0, -0.05, 0});
    } else {
      end_site(foot, {0, -0.14, -0.058});
      if (shape.end_sites)
        b.at[s > 0 ? Joint::l_toe : Joint::r_toe] = static_cast<int>(b.sk.joints.size()) - 1;
    }
  }
  const int spine = add(fam.name(Part::spine, 0, 0), hips, {0, 0, 0.12});
  const int chest = add(fam.name(Part::chest, 0, 0), spine, {0, 0.01, 0.2});
  int head_parent = chest;
  glm::dvec3 head_off(0, 0, 0.3);
  if (shape.neck) {
    head_parent = add(fam.name(Part::neck, 0, 0), chest, {0, 0, 0.2});
    head_off = {0, 0, 0.1};
  }
  b.at[Joint::neck] = head_parent;
  const int head = add(fam.name(Part::head, 0, 0), head_parent, head_off);
  b.at[Joint::head] = head;
  end_site(head, {0, 0, 0.2});
  // The spine joint is the one nearest the middle of hips and neck (documented rule).
  b.at[Joint::spine] = shape.neck ? chest : spine;
  for (int s : {1, -1}) {
    glm::dvec3 d(s, 0, 0);
    if (shape.rest == Rest::a_pose) d = glm::dvec3(s * std::cos(deg(45)), 0, -std::sin(deg(45)));
    if (shape.rest == Rest::arms_down) d = glm::normalize(glm::dvec3(s * 0.08, 0, -1));
    int parent = chest;
    glm::dvec3 off(s * 0.17, 0, 0.17);
    if (shape.clavicle) {
      parent = add(fam.name(Part::clavicle, s, 0), chest, {s * 0.03, 0, 0.17});
      off = {s * 0.14, 0, 0};
    }
    const int upper = add(fam.name(Part::upper_arm, s, 0), parent, off);
    const int fore = add(fam.name(Part::forearm, s, 0), upper, 0.3 * d);
    const int hand = add(fam.name(Part::hand, s, 0), fore, 0.26 * d);
    b.at[s > 0 ? Joint::l_shoulder : Joint::r_shoulder] = upper;
    b.at[s > 0 ? Joint::l_elbow : Joint::r_elbow] = fore;
    b.at[s > 0 ? Joint::l_wrist : Joint::r_wrist] = hand;
    if (shape.fingers) {
      // Three fingers of three joints, the thumb forward.
      for (int k = 0; k < 3; ++k) {
        const glm::dvec3 spread = k == 0 ? glm::dvec3(0, -0.03, 0) : glm::dvec3(0, 0.015 * k, 0);
        int j = add(fam.name(Part::finger, s, 3 * k) + (k ? "_" + std::to_string(k) : ""), hand,
                    0.09 * d + spread);
        j = add(fam.name(Part::finger, s, 3 * k + 1) + (k ? "_" + std::to_string(k) : ""), j, 0.045 * d);
        j = add(fam.name(Part::finger, s, 3 * k + 2) + (k ? "_" + std::to_string(k) : ""), j, 0.03 * d);
        end_site(j, 0.025 * d);
      }
    } else {
      end_site(hand, 0.09 * d);
    }
  }
  return b;
}

// Position channels on the joints other than the root: none, the bone repeated (replacing the
// OFFSET) or zero (added to it).
enum class Six { no, replace, zero };

// A BVH text of the body's poses: axes R_file_from_world, units per metre, every joint with six
// channels or three (the root always six), rotation orders varying by joint; End Sites only where
// the body has them.
std::string write_text(const Body& b, const std::vector<Pose>& poses, const glm::dmat3& A, double u,
                       Six six) {
  const Skeleton& sk = b.sk;
  const std::size_t n = sk.joints.size();
  static const char* kOrders[] = {"ZYX", "ZXY", "YXZ", "XYZ"};
  std::vector<std::string> order(n);
  std::vector<bool> pos(n);
  std::string out = "HIERARCHY\n";
  char buf[160];
  auto v3 = [&](const glm::dvec3& v) {
    std::snprintf(buf, sizeof buf, "%.9f %.9f %.9f", v[0], v[1], v[2]);
    return std::string(buf);
  };
  std::vector<int> written;
  auto emit = [&](auto&& self, int j, const std::string& ind) -> void {
    const SkeletonJoint& jt = sk.joints[static_cast<std::size_t>(j)];
    if (jt.end_site) {
      out +=
          ind + "End Site\n" + ind + "{\n" + ind + "  OFFSET " + v3(A * jt.offset * u) + "\n" + ind + "}\n";
      return;
    }
    const auto js = static_cast<std::size_t>(j);
    order[js] = kOrders[js % 4];
    pos[js] = j == 0 || six != Six::no;
    out += ind + (j == 0 ? "ROOT " : "JOINT ") + jt.name + "\n" + ind + "{\n";
    out += ind + "  OFFSET " + v3(A * jt.offset * u) + "\n" + ind + "  CHANNELS " + (pos[js] ? "6" : "3");
    if (pos[js]) out += " Xposition Yposition Zposition";
    for (char c : order[js]) out += std::string(" ") + c + "rotation";
    out += "\n";
    written.push_back(j);
    for (std::size_t c = 0; c < n; ++c) {
      if (sk.joints[c].parent == j) self(self, static_cast<int>(c), ind + "  ");
    }
    out += ind + "}\n";
  };
  emit(emit, 0, "");
  out += "MOTION\nFrames: " + std::to_string(poses.size()) + "\nFrame Time: 0.0333333\n";
  for (const Pose& p : poses) {
    for (int j : written) {
      const auto js = static_cast<std::size_t>(j);
      // Root: its position; other joints: the bone itself (replacing OFFSET).
      if (pos[js]) {
        const glm::dvec3 t = j == 0                ? p.root_position
                             : six == Six::replace ? sk.joints[js].offset
                                                   : glm::dvec3(0);
        out += v3(A * t * u) + " ";
      }
      const glm::dvec3 e = euler_from_matrix(order[js], A * p.local[js] * glm::transpose(A));
      // euler_from_matrix gives the angles in the order's own axis order.
      out += v3(e) + " ";
    }
    out += "\n";
  }
  return out;
}

// Four frames: standing, turning 15 degrees a frame, the arms and legs moving.
std::vector<Pose> motion(const Body& b) {
  std::vector<Pose> poses;
  for (int f = 0; f < 4; ++f) {
    Pose p = rest_pose(b.sk, {0.1 * f, -0.2 * f, 0.95});
    p.local[0] = rot_z(deg(15 * f)) * rot_x(deg(3.5 * f));
    auto set = [&](Joint j, const glm::dmat3& R) { p.local[static_cast<std::size_t>(b.at.at(j))] = R; };
    // (Not all rotations integer in frame 0: it is no converter's synthetic T-pose.)
    set(Joint::l_shoulder, rot_y(deg(12.5 * f + 0.25)) * rot_x(deg(4.5 * f)));
    set(Joint::r_elbow, rot_z(deg(20.5 * f)));
    set(Joint::l_hip, rot_x(deg(-10.5 * f)));
    set(Joint::r_knee, rot_x(deg(15.5 * f)));
    set(Joint::neck, rot_y(deg(5.5 * f)));
    poses.push_back(p);
  }
  return poses;
}

struct Axes {
  std::string label;
  glm::dmat3 R_file_from_world;
};

const std::vector<Axes>& axes() {
  static const std::vector<Axes> a = {{"y-up", from_rows(1, 0, 0, 0, 0, 1, 0, -1, 0)},
                                      {"z-up", rot_z(deg(30))}};
  return a;
}

// Maps the generated file and checks every standard joint against the generator's world.
void expect_maps(const Family& fam, const Shape& shape, const Axes& ax, double per_metre,
                 const std::string& unit, Six six) {
  const Body b = make_body(fam, shape);
  const std::vector<Pose> poses = motion(b);
  const std::string text = write_text(b, poses, ax.R_file_from_world, per_metre, six);
  HumanoidClip h;
  ASSERT_NO_THROW(h = map_humanoid(parse_bvh(text, fam.label), fam.label + ".bvh")) << text.substr(0, 600);
  EXPECT_EQ(h.map.units, unit);
  if (unit != "height") EXPECT_NEAR(h.map.scale * per_metre, 1.0, 1e-9);
  const double k = h.map.scale * per_metre;  // 1 unless the units are unknown
  // Every file joint (End Sites too) has the generator's name: find the generator's joint by name.
  auto gen_index = [&](int file_joint) {
    const std::string& name = h.clip.skeleton.joints[static_cast<std::size_t>(file_joint)].name;
    return b.sk.find(name);
  };
  std::vector<glm::dvec3> want, got;
  glm::dvec3 w0, g0;
  double worst = 0;
  for (int f = 0; f < static_cast<int>(poses.size()); ++f) {
    forward_kinematics(b.sk, poses[static_cast<std::size_t>(f)], &want);
    forward_kinematics(h.skeleton, h.frame_pose(f), &got);
    if (f == 0) {
      w0 = want[0];
      g0 = got[0];
    }
    for (int j = 0; j < kJointCount; ++j) {
      if (joint_is_end(j)) continue;
      const int a = h.map.anchor[static_cast<std::size_t>(j)];
      const glm::dvec3 g = (got[static_cast<std::size_t>(a)] - g0) / k;
      const auto it = b.at.find(static_cast<Joint>(j));
      if (it == b.at.end()) {
        // A made-up toe (no toe joint, no End Site): ahead of and below the ankle.
        ASSERT_TRUE(j == static_cast<int>(Joint::l_toe) || j == static_cast<int>(Joint::r_toe))
            << joint_name(j);
        EXPECT_EQ(h.map.file_joint[static_cast<std::size_t>(j)], -1);
        if (f == 0) {
          const int ankle = h.map.anchor[static_cast<std::size_t>(joint_parent(j))];
          const glm::dvec3 d = (got[static_cast<std::size_t>(a)] - got[static_cast<std::size_t>(ankle)]) / k;
          EXPECT_NEAR(d.x, 0, 1e-6);
          EXPECT_NEAR(d.y, -0.16 * 0.86, 0.01);
          EXPECT_NEAR(d.z, -0.07 * 0.86, 0.01);
        }
        continue;
      }
      if (f == 0 && fam.label != "nameless") {
        EXPECT_EQ(h.clip.skeleton.joints[static_cast<std::size_t>(a)].name,
                  b.sk.joints[static_cast<std::size_t>(it->second)].name)
            << joint_name(j);
      }
      if (f == 0)
        EXPECT_EQ(gen_index(a), it->second)
            << joint_name(j) << " is " << h.clip.skeleton.joints[static_cast<std::size_t>(a)].name;
      worst = std::max(worst, glm::length(g - (want[static_cast<std::size_t>(it->second)] - w0)));
    }
  }
  EXPECT_LT(worst, 1e-6) << "worst " << worst << " m";
  EXPECT_EQ(h.map.convention, fam.label == "nameless" ? "hierarchy" : "generic");
}

TEST(BodyHumanoidFamilies, EveryFamilyShapeRestPoseAxisAndUnitMaps) {
  const std::vector<std::pair<double, std::string>> units = {
      {1.0, "m"}, {100.0, "cm"}, {1000.0, "mm"}, {1 / 0.0254, "in"}, {17.7, "height"}};
  std::vector<Family> fams = families();
  for (const Family& fam : fams) {
    for (Rest rest : {Rest::t_pose, Rest::a_pose, Rest::arms_down}) {
      for (int variant = 0; variant < 4; ++variant) {
        Shape shape;
        shape.rest = rest;
        shape.neck = variant != 1;
        shape.clavicle = variant != 2;
        shape.toe = variant != 3;
        shape.fingers = variant == 2;
        for (const Axes& ax : axes()) {
          const auto& [per_metre, unit] =
              units[static_cast<std::size_t>(variant + (ax.label == "z-up")) % units.size()];
          SCOPED_TRACE(fam.label + " rest " + std::to_string(static_cast<int>(rest)) + " variant " +
                       std::to_string(variant) + " " + ax.label + " " + unit);
          expect_maps(fam, shape, ax, per_metre, unit, variant % 2 == 0 ? Six::replace : Six::no);
        }
      }
    }
  }
}

TEST(BodyHumanoidFamilies, NamesThatSayNothingMapByTheHierarchy) {
  for (Rest rest : {Rest::t_pose, Rest::a_pose, Rest::arms_down}) {
    for (int variant = 0; variant < 4; ++variant) {
      Shape shape;
      shape.rest = rest;
      shape.neck = variant != 1;
      shape.clavicle = variant != 2;
      shape.fingers = variant >= 2;
      for (const Axes& ax : axes()) {
        SCOPED_TRACE("rest " + std::to_string(static_cast<int>(rest)) + " variant " +
                     std::to_string(variant) + " " + ax.label);
        expect_maps(nameless(), shape, ax, 100.0, "cm", variant % 2 == 1 ? Six::replace : Six::zero);
      }
    }
  }
}

TEST(BodyHumanoidFamilies, EndJointsWithoutEndSites) {
  for (const Family& fam : families()) {
    SCOPED_TRACE(fam.label);
    Shape shape;
    shape.end_sites = false;
    shape.toe = true;
    expect_maps(fam, shape, axes()[0], 100.0, "cm", Six::replace);
    shape.toe = false;  // no toe joint and no End Site: a toe is made up
    expect_maps(fam, shape, axes()[1], 1.0, "m", Six::zero);
  }
}

TEST(BodyHumanoidFamilies, SixChannelsAddOrReplaceTheOffsetAsTheValuesSay) {
  // Positions that repeat the OFFSET replace it; positions of zero add to it; both read right.
  const Body b = make_body(families()[0], Shape{});
  const std::vector<Pose> poses = motion(b);
  std::vector<glm::dvec3> want, got;
  forward_kinematics(b.sk, poses[2], &want);
  for (Six six : {Six::replace, Six::zero}) {
    SCOPED_TRACE(six == Six::replace ? "replace" : "zero");
    const BvhClip c = parse_bvh(write_text(b, poses, glm::dmat3(1.0), 100.0, six), "six");
    ASSERT_EQ(c.positions_absolute.size(), c.skeleton.joints.size());
    int absolute = 0;
    for (std::size_t j = 1; j < c.skeleton.joints.size(); ++j) {
      if (c.channels[j].empty()) continue;
      const bool offset_zero = c.skeleton.joints[j].offset == glm::dvec3(0);
      EXPECT_EQ(c.positions_absolute[j] != 0, six == Six::replace && !offset_zero)
          << c.skeleton.joints[j].name;
      absolute += c.positions_absolute[j];
    }
    EXPECT_EQ(absolute >= 19, six == Six::replace);  // every joint but the root has an OFFSET
    EXPECT_EQ(c.positions_absolute[0], 0);           // the root's OFFSET is zero: the values add
    forward_kinematics(c.scaled_skeleton(0.01), c.pose(2, 0.01), &got);
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t j = 0; j < want.size(); ++j) EXPECT_LT(glm::length(got[j] - want[j]), 1e-9) << j;
  }
}

TEST(BodyHumanoidFamilies, BvhScaleOverridesTheDetectedUnits) {
  const Body b = make_body(families()[0], Shape{});
  const std::string text = write_text(b, motion(b), glm::dmat3(1.0), 100.0, Six::no);
  HumanoidOptions o;
  o.scale = 0.02;  // a file in "half centimetres", say
  const HumanoidClip h = map_humanoid(parse_bvh(text), "scaled.bvh", o);
  EXPECT_EQ(h.map.units, "given");
  EXPECT_DOUBLE_EQ(h.map.scale, 0.02);
  std::vector<glm::dvec3> p;
  forward_kinematics(h.skeleton, h.frame_pose(0), &p);
  const auto P = [&](Joint j) {
    return p[static_cast<std::size_t>(h.map.anchor[static_cast<std::size_t>(j)])];
  };
  EXPECT_NEAR(P(Joint::head).z - P(Joint::l_ankle).z, 2 * (0.62 + 0.93), 1e-6);  // 155 units
}

TEST(BodyHumanoidFamilies, UnmappableClipsAreRefusedInOneLineNamingWhatIsMissing) {
  // No head: names and hierarchy both fail; the message names both.
  Body b = make_body(families()[0], Shape{});
  Skeleton headless;
  std::vector<int> at(b.sk.joints.size(), -1);
  for (std::size_t j = 0; j < b.sk.joints.size(); ++j) {
    const int par = b.sk.joints[j].parent;
    if (b.sk.joints[j].name == "mixamorig:Neck" || (par >= 0 && at[static_cast<std::size_t>(par)] < 0))
      continue;
    SkeletonJoint jt = b.sk.joints[j];
    jt.parent = par < 0 ? -1 : at[static_cast<std::size_t>(par)];
    at[j] = static_cast<int>(headless.joints.size());
    headless.joints.push_back(jt);
  }
  const std::string text = format_bvh(headless, {rest_pose(headless)}, 0.1);
  try {
    (void)map_humanoid(parse_bvh(text), "headless.bvh");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos);
    EXPECT_THAT(what, AllOf(HasSubstr("headless.bvh: not a humanoid hierarchy: no joint for head"),
                            HasSubstr("by the hierarchy: no spine with two arms and a head")));
  }
  // Nameless and no toes nor End Sites: nothing shows where the feet point.
  Shape s;
  s.toe = false;
  s.end_sites = false;
  Family fam = nameless();
  const Body nb = make_body(fam, s);
  try {
    (void)map_humanoid(parse_bvh(write_text(nb, motion(nb), glm::dmat3(1.0), 1.0, Six::no)), "blind.bvh");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("blind.bvh"), HasSubstr("cannot tell left from right")));
  }
}

// The real clips with every name replaced by Joint1..JointN: the hierarchy alone finds the joints
// their names give (the fingers, thumbs, clavicles and hip joints of real skeletons included).
TEST(BodyHumanoidFamilies, EveryRealClipWithoutItsNamesMapsByTheHierarchyAsByTheNames) {
  const auto clips = testing::shared_bvh_clips();
  ASSERT_FALSE(clips.empty()) << testing::no_clips_message();
  for (const auto& path : clips) {
    SCOPED_TRACE(path.string());
    const BvhClip named = read_bvh(path.string());
    BvhClip blind = named;
    int k = 0;
    for (auto& j : blind.skeleton.joints) {
      if (!j.end_site) j.name = "Joint" + std::to_string(++k);
    }
    const HumanoidClip by_names = map_humanoid(named, path.string());
    const HumanoidClip by_tree = map_humanoid(blind, path.string());
    EXPECT_EQ(by_tree.map.convention, "hierarchy");
    for (int j = 0; j < kJointCount; ++j) {
      if (joint_is_end(j)) continue;
      EXPECT_EQ(by_tree.map.anchor[static_cast<std::size_t>(j)],
                by_names.map.anchor[static_cast<std::size_t>(j)])
          << joint_name(j) << ": by the names "
          << named.skeleton.joints[static_cast<std::size_t>(by_names.map.anchor[static_cast<std::size_t>(j)])]
                 .name
          << ", by the hierarchy "
          << named.skeleton.joints[static_cast<std::size_t>(by_tree.map.anchor[static_cast<std::size_t>(j)])]
                 .name;
    }
    // Placed the same way up and facing the same way (the units of cgspeed files come from their
    // names: without them the clip is scaled to the body height instead).
    for (int c = 0; c < 3; ++c)
      EXPECT_LT(glm::length(by_tree.map.R_world_from_file[c] - by_names.map.R_world_from_file[c]), 1e-9);
  }
}

}  // namespace
}  // namespace vc::body
