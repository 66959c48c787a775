// Automatic initialization (the method's section 4, without clicks): the body model measured on the
// hull and the triangulated features of a frame in the initialization pose (facing the front
// cameras, legs together, arms spread horizontally). Which way is front comes from the features:
// the performer's right is the horizontal direction from the left to the right hand (the
// triangulation names them from the front cameras and their continuity), up is the world's z.
//
// What is measured (host/fit/README.md, "Initialization", has the rules and the tolerances):
//   - head top: the highest occupied voxel above the head feature;
//   - shoulder height: the wrists' (arms horizontal); torso half width and depth: the hull's extent
//     through the torso axis (below the head) at three chest levels;
//   - elbows and knees: where the limb's cross-section area steps down (a two-level fit along the
//     limb from 25 % to 85 % of its length), less sqrt(ru^2 - rl^2) (the upper segment's rounded end
//     reaches past the hinge); limb radii from those areas;
//   - hip joints: half the ankles' distance apart (legs straight down), their height from the crotch
//     (the first occupied voxel above the ankles between the legs) plus one thigh radius;
//   - neck base half way between the bottom of the head and the shoulders; the pelvis centre
//     0.04 x stature above the hip joints (anthropometric); the elbow at 0.56 of the arm and the knee
//     at 0.5 of the leg when no step is found.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "voxcap/fit/hull.hpp"
#include "voxcap/fit/model.hpp"

namespace vc::fit {

// The five features (head, left hand = wrist, right hand, left foot = ankle, right foot), world.
using FeatureSet = std::array<Vec3, 5>;

// Whether the features look like the initialization pose: hands spread level at about shoulder
// height, the head between them, feet together. *why says what does not fit.
bool looks_like_init_pose(const FeatureSet& f, std::string* why = nullptr);

// The torso frame the initialization pose implies: x from the left to the right hand (level), z up.
Mat3 init_torso_frame(const FeatureSet& f);

struct InitMeasurement {
  BodyModel body;
  Mat3 R_torso_world{1.0};
  Vec3 neck_world{0, 0, 0};
  double stature_m = 0;  // head top above the floor (z = 0)
};

// Measures the body on one initialization frame; nothing (with *why) when the hull does not show
// what the rules need (no head top, a torso wider than the arms, ...).
std::optional<InitMeasurement> measure_init_frame(const HullBits& hull, const FeatureSet& f,
                                                  std::string* why = nullptr);

// The per-value median of several frames' measurements (frames disagree by a voxel here and there).
InitMeasurement combine_measurements(const std::vector<InitMeasurement>& m);

// A body scaled from average adult proportions to a stature (when no initialization pose is seen).
BodyModel proportional_body(double stature_m);

// body.toml: any BodyModel value by its name (e.g. `upper_arm_m = 0.31`), metres; unknown keys and
// values out of range are errors. Applies the file's values over *body. Throws std::runtime_error
// naming the file (and key) on a bad or unreadable file.
void apply_body_toml(const std::string& path, BodyModel* body);
void apply_body_toml_text(const std::string& text, const std::string& source, BodyModel* body);

}  // namespace vc::fit
