/* Fixed-point pixel conversion to RGB24; the formula and its limits are in pixconv.h. */
#include "voxcap/edge/pixconv.h"

#include <errno.h>
#include <string.h>

/* Kr/Kb of the two matrices; everything else follows from them. */
static void matrix_weights(vc_yuv_matrix m, double* kr, double* kb) {
  if (m == VC_YUV_BT709) {
    *kr = 0.2126;
    *kb = 0.0722;
  } else {
    *kr = 0.299;
    *kb = 0.114;
  }
}

void vc_yuv_coeffs_float(vc_yuv_matrix matrix, bool full_range, double* k, double* rv, double* gu,
                         double* gv, double* bu, double* y0) {
  double kr, kb;
  matrix_weights(matrix, &kr, &kb);
  double kg = 1.0 - kr - kb;
  /* chroma scale: full range C spans 255, limited 224; luma 255 vs 219 */
  double cs = full_range ? 1.0 : 255.0 / 224.0;
  *k = full_range ? 1.0 : 255.0 / 219.0;
  *y0 = full_range ? 0.0 : 16.0;
  *rv = 2.0 * (1.0 - kr) * cs;
  *bu = 2.0 * (1.0 - kb) * cs;
  *gu = 2.0 * (1.0 - kb) * kb / kg * cs;
  *gv = 2.0 * (1.0 - kr) * kr / kg * cs;
}

static int32_t q16(double v) { return (int32_t)(v * 65536.0 + 0.5); }

int vc_yuv_coeffs_init(vc_yuv_coeffs* c, vc_yuv_matrix matrix, bool full_range) {
  double k, rv, gu, gv, bu, y0;
  if (!c || (matrix != VC_YUV_BT601 && matrix != VC_YUV_BT709)) return -EINVAL;
  vc_yuv_coeffs_float(matrix, full_range, &k, &rv, &gu, &gv, &bu, &y0);
  c->k = q16(k);
  c->rv = q16(rv);
  c->gu = q16(gu);
  c->gv = q16(gv);
  c->bu = q16(bu);
  c->y0 = (int32_t)y0;
  return 0;
}

unsigned vc_pixfmt_bytes_per_pixel(vc_pixfmt fmt) {
  switch (fmt) {
    case VC_PIXFMT_RGB24:
    case VC_PIXFMT_BGR24: return 3;
    case VC_PIXFMT_YUYV:
    case VC_PIXFMT_UYVY: return 2;
    case VC_PIXFMT_GREY: return 1;
    case VC_PIXFMT_DEFAULT: break;
  }
  return 0;
}

/* Q16 value (with the rounding half already added) → 0..255. */
static inline uint8_t clamp_q16(int32_t v) {
  if (v < 0) return 0;
  if (v > (255 << 16)) return 255;
  return (uint8_t)(v >> 16);
}

/* Writes two RGB pixels sharing one chroma pair. */
static inline void yuv_pair(const vc_yuv_coeffs* c, int y0, int y1, int u, int v, uint8_t* d,
                            int two) {
  const int32_t du = u - 128, dv = v - 128;
  const int32_t r = c->rv * dv + 32768;           /* Q16, +0.5 for rounding */
  const int32_t g = -c->gu * du - c->gv * dv + 32768;
  const int32_t b = c->bu * du + 32768;
  const int32_t l0 = c->k * (y0 - c->y0);          /* Q16 */
  d[0] = clamp_q16(l0 + r);
  d[1] = clamp_q16(l0 + g);
  d[2] = clamp_q16(l0 + b);
  if (two) {
    const int32_t l1 = c->k * (y1 - c->y0);
    d[3] = clamp_q16(l1 + r);
    d[4] = clamp_q16(l1 + g);
    d[5] = clamp_q16(l1 + b);
  }
}

/* 4:2:2 packed: offsets of Y0, U, Y1, V inside each 4-byte group. */
static void packed422_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                             int w, int h, const vc_yuv_coeffs* c, int oy0, int ou, int oy1, int ov) {
  for (int y = 0; y < h; y++) {
    const uint8_t* s = src + (size_t)y * src_stride;
    uint8_t* d = dst + (size_t)y * dst_stride;
    int x = 0;
    for (; x + 1 < w; x += 2, s += 4, d += 6) yuv_pair(c, s[oy0], s[oy1], s[ou], s[ov], d, 1);
    if (x < w) yuv_pair(c, s[oy0], 0, s[ou], s[ov], d, 0);
  }
}

void vc_pixconv_yuyv_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                            int w, int h, const vc_yuv_coeffs* c) {
  packed422_to_rgb(src, src_stride, dst, dst_stride, w, h, c, 0, 1, 2, 3);
}

void vc_pixconv_uyvy_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                            int w, int h, const vc_yuv_coeffs* c) {
  packed422_to_rgb(src, src_stride, dst, dst_stride, w, h, c, 1, 0, 3, 2);
}

void vc_pixconv_grey_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                            int w, int h) {
  for (int y = 0; y < h; y++) {
    const uint8_t* s = src + (size_t)y * src_stride;
    uint8_t* d = dst + (size_t)y * dst_stride;
    for (int x = 0; x < w; x++, d += 3) d[0] = d[1] = d[2] = s[x];
  }
}

void vc_pixconv_rgb24_copy(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                           int w, int h) {
  for (int y = 0; y < h; y++)
    memcpy(dst + (size_t)y * dst_stride, src + (size_t)y * src_stride, (size_t)w * 3);
}

void vc_pixconv_bgr24_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                             int w, int h) {
  for (int y = 0; y < h; y++) {
    const uint8_t* s = src + (size_t)y * src_stride;
    uint8_t* d = dst + (size_t)y * dst_stride;
    for (int x = 0; x < w; x++, s += 3, d += 3) {
      d[0] = s[2];
      d[1] = s[1];
      d[2] = s[0];
    }
  }
}

void vc_pixconv_rgbx_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                            int w, int h, bool bgrx) {
  const int ir = bgrx ? 2 : 0, ib = bgrx ? 0 : 2;
  for (int y = 0; y < h; y++) {
    const uint8_t* s = src + (size_t)y * src_stride;
    uint8_t* d = dst + (size_t)y * dst_stride;
    for (int x = 0; x < w; x++, s += 4, d += 3) {
      d[0] = s[ir];
      d[1] = s[1];
      d[2] = s[ib];
    }
  }
}

int vc_pixconv_to_rgb(vc_pixfmt fmt, const uint8_t* src, size_t src_stride, uint8_t* dst,
                      size_t dst_stride, int w, int h, const vc_yuv_coeffs* c) {
  unsigned bpp = vc_pixfmt_bytes_per_pixel(fmt);
  if (!src || !dst || w <= 0 || h <= 0 || bpp == 0) return -EINVAL;
  size_t min_src = (fmt == VC_PIXFMT_YUYV || fmt == VC_PIXFMT_UYVY) ? (size_t)((w + 1) / 2) * 4
                                                                    : (size_t)w * bpp;
  if (src_stride < min_src || dst_stride < (size_t)w * 3) return -EINVAL;
  switch (fmt) {
    case VC_PIXFMT_YUYV:
      if (!c) return -EINVAL;
      vc_pixconv_yuyv_to_rgb(src, src_stride, dst, dst_stride, w, h, c);
      return 0;
    case VC_PIXFMT_UYVY:
      if (!c) return -EINVAL;
      vc_pixconv_uyvy_to_rgb(src, src_stride, dst, dst_stride, w, h, c);
      return 0;
    case VC_PIXFMT_GREY: vc_pixconv_grey_to_rgb(src, src_stride, dst, dst_stride, w, h); return 0;
    case VC_PIXFMT_RGB24: vc_pixconv_rgb24_copy(src, src_stride, dst, dst_stride, w, h); return 0;
    case VC_PIXFMT_BGR24: vc_pixconv_bgr24_to_rgb(src, src_stride, dst, dst_stride, w, h); return 0;
    case VC_PIXFMT_DEFAULT: break;
  }
  return -EINVAL;
}
