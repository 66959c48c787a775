// The debug picture of a segmentation (voxcap track debug): regions tinted over the camera image,
// the GVD in white, critical points as small red rings, cuts in green, the five features as
// crosses with their names, and the reason when the segmentation failed.
#include <algorithm>
#include <string>

#include <opencv2/imgproc.hpp>

#include "voxcap/edge/segment.hpp"

namespace vc::segment {

namespace {

cv::Vec3b region_colour(int id) {
  // Well-separated hues, deterministic per id.
  static const cv::Vec3b table[] = {{230, 120, 40},  {40, 200, 240}, {200, 60, 200},  {60, 220, 60},
                                    {40, 120, 240},  {240, 200, 60}, {140, 80, 240},  {60, 200, 170},
                                    {200, 200, 200}, {40, 60, 200},  {160, 240, 120}, {240, 60, 120}};
  return table[static_cast<size_t>(id) % (sizeof table / sizeof table[0])];
}

}  // namespace

void draw(const Segmentation& s, const cv::Mat& bgr, cv::Mat* out) {
  cv::Size size = s.labels.empty() ? bgr.size() : s.labels.size();
  if (size.empty()) size = cv::Size(320, 240);
  cv::Mat img;
  if (!bgr.empty() && bgr.type() == CV_8UC3 && bgr.size() == size) {
    img = bgr.clone();
  } else {
    img = cv::Mat(size, CV_8UC3, cv::Scalar(40, 40, 40));
    if (!s.labels.empty()) img.setTo(cv::Scalar(110, 110, 110), s.labels >= 0);
  }
  if (!s.labels.empty()) {
    for (int y = 0; y < img.rows; y++)
      for (int x = 0; x < img.cols; x++) {
        const int id = s.labels(y, x);
        if (id < 0) continue;
        const cv::Vec3b c = region_colour(id);
        cv::Vec3b& p = img.at<cv::Vec3b>(y, x);
        for (int k = 0; k < 3; k++) p[k] = static_cast<uchar>((p[k] + c[k]) / 2);
      }
  }
  if (!s.gvd.empty()) img.setTo(cv::Scalar(255, 255, 255), s.gvd);
  for (const Cut& k : s.cuts) cv::line(img, k.a, k.b, cv::Scalar(0, 255, 0), 1, cv::LINE_AA);
  for (const cv::Point& c : s.critical) cv::circle(img, c, 2, cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  const double scale = std::max(0.35, img.rows / 1200.0);
  for (int f = 0; f < kFeatures; f++) {
    if (s.terminal[static_cast<size_t>(f)] < 0) continue;
    const cv::Point2f p = s.point[static_cast<size_t>(f)];
    const cv::Point c(cvRound(p.x), cvRound(p.y));
    cv::drawMarker(img, c, cv::Scalar(0, 255, 255), cv::MARKER_CROSS, 9, 1, cv::LINE_AA);
    cv::putText(img, feature_name(f), c + cv::Point(5, -4), cv::FONT_HERSHEY_SIMPLEX, scale,
                cv::Scalar(0, 255, 255), 1, cv::LINE_AA);
  }
  const std::string status = s.ok ? "ok" : "not ok: " + s.why;
  cv::putText(img, status, cv::Point(8, 8 + static_cast<int>(22 * scale)), cv::FONT_HERSHEY_SIMPLEX, scale,
              s.ok ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  *out = img;
}

}  // namespace vc::segment
