/* Pure helpers of the v4l2 backend (no device access): format mapping, format negotiation
 * messages, control-name matching, colorimetry. Internal to edge/camera; unit-tested. */
#ifndef VOXCAP_EDGE_CAMERA_V4L2_UTIL_H
#define VOXCAP_EDGE_CAMERA_V4L2_UTIL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "voxcap/edge/camera.h"
#include "voxcap/edge/pixconv.h"

#ifdef __cplusplus
extern "C" {
#endif

/* V4L2 fourcc of a vc_pixfmt (0 for VC_PIXFMT_DEFAULT) and back (VC_PIXFMT_DEFAULT if unknown). */
uint32_t vc_v4l2_fourcc_from_pixfmt(vc_pixfmt fmt);
vc_pixfmt vc_v4l2_pixfmt_from_fourcc(uint32_t fourcc);
/* True when fourcc is among the n offered ones. */
bool vc_v4l2_format_offered(uint32_t fourcc, const uint32_t* offered, size_t n);
/* "YUYV, RGB3, GREY" into out (always NUL-terminated, truncated with "..."). */
void vc_v4l2_format_list(const uint32_t* offered, size_t n, char* out, size_t cap);
/* A control name as v4l2-ctl spells it: lower case, runs of other characters → one '_', no
 * leading/trailing '_' ("Percentage of Dropped Buffers" → "percentage_of_dropped_buffers"). */
void vc_v4l2_control_key(const char* name, char* out, size_t cap);
/* The Y'CbCr matrix and range a format's colorimetry fields mean (V4L2 defaults resolved). */
void vc_v4l2_colorimetry(uint32_t colorspace, uint32_t ycbcr_enc, uint32_t quantization,
                         vc_yuv_matrix* matrix, bool* full_range);

#ifdef __cplusplus
}
#endif
#endif
