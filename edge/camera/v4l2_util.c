/* Pure helpers of the v4l2 backend; see v4l2_util.h. */
#define _GNU_SOURCE
#include "v4l2_util.h"

#include <ctype.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <string.h>

static const struct {
  vc_pixfmt fmt;
  uint32_t fourcc;
} fourccs[] = {
    {VC_PIXFMT_RGB24, V4L2_PIX_FMT_RGB24}, {VC_PIXFMT_BGR24, V4L2_PIX_FMT_BGR24},
    {VC_PIXFMT_YUYV, V4L2_PIX_FMT_YUYV},   {VC_PIXFMT_UYVY, V4L2_PIX_FMT_UYVY},
    {VC_PIXFMT_GREY, V4L2_PIX_FMT_GREY},
};

uint32_t vc_v4l2_fourcc_from_pixfmt(vc_pixfmt fmt) {
  for (size_t i = 0; i < sizeof fourccs / sizeof fourccs[0]; i++)
    if (fourccs[i].fmt == fmt) return fourccs[i].fourcc;
  return 0;
}

vc_pixfmt vc_v4l2_pixfmt_from_fourcc(uint32_t fourcc) {
  for (size_t i = 0; i < sizeof fourccs / sizeof fourccs[0]; i++)
    if (fourccs[i].fourcc == fourcc) return fourccs[i].fmt;
  return VC_PIXFMT_DEFAULT;
}

bool vc_v4l2_format_offered(uint32_t fourcc, const uint32_t* offered, size_t n) {
  if (!fourcc) return false;
  for (size_t i = 0; i < n; i++)
    if (offered[i] == fourcc) return true;
  return false;
}

void vc_v4l2_format_list(const uint32_t* offered, size_t n, char* out, size_t cap) {
  size_t len = 0;
  if (!cap) return;
  out[0] = '\0';
  if (n == 0) {
    snprintf(out, cap, "none");
    return;
  }
  for (size_t i = 0; i < n; i++) {
    char cc[5];
    for (int k = 0; k < 4; k++) {
      char ch = (char)((offered[i] >> (8 * k)) & 0xff);
      cc[k] = isprint((unsigned char)ch) ? ch : '?';
    }
    cc[4] = '\0';
    /* trailing blanks of short fourccs ("Y8  ") carry no information */
    for (int k = 3; k > 0 && cc[k] == ' '; k--) cc[k] = '\0';
    int w = snprintf(out + len, cap - len, "%s%s", i ? ", " : "", cc);
    if (w < 0 || (size_t)w >= cap - len) {
      if (cap >= 4) snprintf(out + cap - 4, 4, "...");
      return;
    }
    len += (size_t)w;
  }
}

void vc_v4l2_control_key(const char* name, char* out, size_t cap) {
  size_t n = 0;
  bool sep = false;
  if (!cap) return;
  for (const char* p = name; *p && n + 1 < cap; p++) {
    unsigned char c = (unsigned char)*p;
    if (isalnum(c)) {
      if (sep && n > 0 && n + 2 < cap) out[n++] = '_';
      sep = false;
      out[n++] = (char)tolower(c);
    } else {
      sep = true;
    }
  }
  out[n] = '\0';
}

void vc_v4l2_colorimetry(uint32_t colorspace, uint32_t ycbcr_enc, uint32_t quantization,
                         vc_yuv_matrix* matrix, bool* full_range) {
  if (ycbcr_enc == V4L2_YCBCR_ENC_DEFAULT) ycbcr_enc = V4L2_MAP_YCBCR_ENC_DEFAULT(colorspace);
  if (quantization == V4L2_QUANTIZATION_DEFAULT)
    quantization = V4L2_MAP_QUANTIZATION_DEFAULT(false, colorspace, ycbcr_enc);
  *matrix = (ycbcr_enc == V4L2_YCBCR_ENC_709 || ycbcr_enc == V4L2_YCBCR_ENC_XV709) ? VC_YUV_BT709
                                                                                  : VC_YUV_BT601;
  *full_range = quantization == V4L2_QUANTIZATION_FULL_RANGE;
}
