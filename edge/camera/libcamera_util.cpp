// Pure helpers of the libcamera backend; see libcamera_util.hpp.
#include "libcamera_util.hpp"

#include <libcamera/formats.h>

#include <cerrno>
#include <cstdlib>

namespace vc::edgecam {

Layout layout_of(const libcamera::PixelFormat& fmt) {
  namespace f = libcamera::formats;
  if (fmt == f::BGR888) return Layout::kRgb;
  if (fmt == f::RGB888) return Layout::kBgr;
  if (fmt == f::XBGR8888) return Layout::kRgbx;
  if (fmt == f::XRGB8888) return Layout::kBgrx;
  if (fmt == f::YUYV) return Layout::kYuyv;
  return Layout::kUnsupported;
}

const std::vector<libcamera::PixelFormat>& preferred_formats() {
  namespace f = libcamera::formats;
  static const std::vector<libcamera::PixelFormat> kFormats = {f::BGR888, f::RGB888, f::XBGR8888, f::XRGB8888,
                                                               f::YUYV};
  return kFormats;
}

vc_pixfmt pixfmt_of(Layout layout) {
  switch (layout) {
    case Layout::kRgb: return VC_PIXFMT_RGB24;
    case Layout::kBgr: return VC_PIXFMT_BGR24;
    case Layout::kYuyv: return VC_PIXFMT_YUYV;
    case Layout::kRgbx:
    case Layout::kBgrx:
    case Layout::kUnsupported: break;
  }
  return VC_PIXFMT_DEFAULT;
}

int convert(Layout layout, const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride, int w, int h,
            const vc_yuv_coeffs* yuv) {
  switch (layout) {
    case Layout::kRgb: return vc_pixconv_to_rgb(VC_PIXFMT_RGB24, src, src_stride, dst, dst_stride, w, h, nullptr);
    case Layout::kBgr: return vc_pixconv_to_rgb(VC_PIXFMT_BGR24, src, src_stride, dst, dst_stride, w, h, nullptr);
    case Layout::kYuyv: return vc_pixconv_to_rgb(VC_PIXFMT_YUYV, src, src_stride, dst, dst_stride, w, h, yuv);
    case Layout::kRgbx:
    case Layout::kBgrx:
      if (!src || !dst || w <= 0 || h <= 0 || src_stride < (size_t)w * 4 || dst_stride < (size_t)w * 3) return -EINVAL;
      vc_pixconv_rgbx_to_rgb(src, src_stride, dst, dst_stride, w, h, layout == Layout::kBgrx);
      return 0;
    case Layout::kUnsupported: break;
  }
  return -EINVAL;
}

int64_t frame_duration_us(uint32_t fps_num, uint32_t fps_den) {
  if (fps_num == 0) return 0;
  const uint64_t den = fps_den ? fps_den : 1;
  return (int64_t)((1000000ull * den + fps_num / 2) / fps_num);
}

int pick_camera(const std::vector<std::string>& ids, const std::string& device, std::string* why) {
  auto list = [&] {
    std::string s;
    for (size_t i = 0; i < ids.size(); i++) s += (i ? ", " : "") + std::to_string(i) + "=" + ids[i];
    return s;
  };
  if (ids.empty()) {
    if (why) *why = "no cameras found";
    return -1;
  }
  if (device.empty()) return 0;
  if (device.find_first_not_of("0123456789") == std::string::npos) {
    unsigned long idx = std::strtoul(device.c_str(), nullptr, 10);
    if (idx < ids.size()) return (int)idx;
    if (why) *why = "camera index " + device + " out of range (cameras: " + list() + ")";
    return -1;
  }
  for (size_t i = 0; i < ids.size(); i++)
    if (ids[i] == device) return (int)i;
  if (why) *why = "no camera '" + device + "' (cameras: " + list() + ")";
  return -1;
}

}  // namespace vc::edgecam
