// The one place where GLM (skeletons, kinematics) meets OpenCV (cameras, images, rendering):
// exact conversions of 3-vectors and 3x3 matrices. GLM stores matrices by column (M[c][r]),
// OpenCV by row (M(r, c)); these functions keep the mathematical matrix the same.
// Target vc_body_cv (header only: vc_body + opencv_core); vc_body itself never sees OpenCV.
#pragma once

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <opencv2/core.hpp>

namespace vc::body {

inline cv::Vec3d to_cv(const glm::dvec3& v) {
  return {v.x, v.y, v.z};
}
inline glm::dvec3 to_glm(const cv::Vec3d& v) {
  return {v[0], v[1], v[2]};
}

inline cv::Matx33d to_cv(const glm::dmat3& m) {
  return {m[0][0], m[1][0], m[2][0],  //
          m[0][1], m[1][1], m[2][1],  //
          m[0][2], m[1][2], m[2][2]};
}
inline glm::dmat3 to_glm(const cv::Matx33d& m) {
  return glm::dmat3(m(0, 0), m(1, 0), m(2, 0),   // column 0
                    m(0, 1), m(1, 1), m(2, 1),   // column 1
                    m(0, 2), m(1, 2), m(2, 2));  // column 2
}

}  // namespace vc::body
