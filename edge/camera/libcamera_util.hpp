// Pure helpers of the libcamera backend (no camera needed): pixel layouts, frame duration, naming.
// Internal to edge/camera; unit-tested natively.
#pragma once

#include <libcamera/camera.h>
#include <libcamera/pixel_format.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "voxcap/edge/pixconv.h"

namespace vc::edgecam {

// How a libcamera format lies in memory. libcamera names formats after DRM: RGB888 is a little-endian
// 24-bit word with R in the top byte, i.e. the bytes B,G,R in memory; BGR888 is R,G,B in memory —
// voxcap's order. XRGB8888 is B,G,R,X; XBGR8888 is R,G,B,X.
enum class Layout { kRgb, kBgr, kRgbx, kBgrx, kYuyv, kUnsupported };

Layout layout_of(const libcamera::PixelFormat& fmt);
// The formats we ask for, best first (no conversion needed first).
const std::vector<libcamera::PixelFormat>& preferred_formats();
// The vc_pixfmt reported in vc_camera_info for a layout (RGBX/BGRX have none: VC_PIXFMT_DEFAULT).
vc_pixfmt pixfmt_of(Layout layout);
// Converts one frame of `layout` to RGB24. 0 or -EINVAL.
int convert(Layout layout, const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride, int w, int h,
            const vc_yuv_coeffs* yuv);

// Frame duration in µs for fps_num/fps_den Hz (rounded); 0 if fps_num == 0.
int64_t frame_duration_us(uint32_t fps_num, uint32_t fps_den);

// Camera chosen by the device string: "" → the first, all digits → that index, else the id.
// Returns the index into `ids`, or -1 (why says what is there).
int pick_camera(const std::vector<std::string>& ids, const std::string& device, std::string* why);

}  // namespace vc::edgecam
