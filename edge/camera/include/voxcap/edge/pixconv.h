/* vc_pixconv: camera pixel formats → interleaved RGB24, in fixed point.
 *
 * Y'CbCr → R'G'B' follows ITU-R BT.601 (SDTV, the V4L2 default for SMPTE 170M / sRGB colorspaces) or
 * BT.709 (HD), limited ("studio", Y' 16..235, C 16..240) or full range:
 *   R = k·(Y − y0) + rv·(Cr − 128)
 *   G = k·(Y − y0) − gu·(Cb − 128) − gv·(Cr − 128)
 *   B = k·(Y − y0) + bu·(Cb − 128)
 * with every coefficient in Q16 (value · 65536, rounded) and one rounding at the end, so the result
 * is within ±1 of the float formula (tested). No floating point in the per-pixel loops, no allocation.
 * Limits: 4:2:2 chroma is applied to both pixels of a pair (no interpolation); an odd width's last
 * pixel uses its pair's chroma.
 */
#ifndef VOXCAP_EDGE_PIXCONV_H
#define VOXCAP_EDGE_PIXCONV_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "voxcap/edge/camera.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vc_yuv_matrix {
  VC_YUV_BT601 = 0,
  VC_YUV_BT709 = 1,
} vc_yuv_matrix;

/* Q16 coefficients of the formula above. */
typedef struct vc_yuv_coeffs {
  int32_t k;  /* Q16 luma gain (255/219 limited, 1 full) */
  int32_t rv; /* Q16 Cr → R */
  int32_t gu; /* Q16 Cb → G (subtracted) */
  int32_t gv; /* Q16 Cr → G (subtracted) */
  int32_t bu; /* Q16 Cb → B */
  int32_t y0; /* luma offset: 16 limited, 0 full */
} vc_yuv_coeffs;

/* Fills c for a matrix and range. 0 or -EINVAL. */
int vc_yuv_coeffs_init(vc_yuv_coeffs* c, vc_yuv_matrix matrix, bool full_range);
/* The same coefficients as doubles (not Q16) — for references and tests. */
void vc_yuv_coeffs_float(vc_yuv_matrix matrix, bool full_range, double* k, double* rv, double* gu,
                         double* gv, double* bu, double* y0);

/* Bytes per pixel of a packed source format (2 for 4:2:2: per pixel on average), 0 if unknown. */
unsigned vc_pixfmt_bytes_per_pixel(vc_pixfmt fmt);

/* Converts one image. Strides in bytes; src holds h rows of the source format, dst h rows of
 * 3·w bytes. c may be NULL for formats without chroma. Returns 0 or -EINVAL (unknown format,
 * NULL pointers, a stride too small). */
int vc_pixconv_to_rgb(vc_pixfmt fmt, const uint8_t* src, size_t src_stride, uint8_t* dst,
                      size_t dst_stride, int w, int h, const vc_yuv_coeffs* c);

/* Single-format entry points (no argument checks). */
void vc_pixconv_yuyv_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                            int w, int h, const vc_yuv_coeffs* c);
void vc_pixconv_uyvy_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                            int w, int h, const vc_yuv_coeffs* c);
void vc_pixconv_grey_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                            int w, int h);
void vc_pixconv_rgb24_copy(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                           int w, int h);
void vc_pixconv_bgr24_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                             int w, int h);
/* 4 bytes per pixel with a padding byte: order "xrgb"-style memory B,G,R,X (libcamera XRGB8888)
 * when bgrx is true, R,G,B,X (libcamera XBGR8888) otherwise. */
void vc_pixconv_rgbx_to_rgb(const uint8_t* src, size_t src_stride, uint8_t* dst, size_t dst_stride,
                            int w, int h, bool bgrx);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_PIXCONV_H */
