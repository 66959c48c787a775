/* Silhouette clean-up: binary majority (median) filters, in place, in integers.
 *
 * A majority filter of radius r sets each pixel to foreground (255) when more than half of the
 * (2r+1) x (2r+1) pixels of its neighbourhood are foreground (nonzero), else to background (0); the
 * image border is replicated. Radius r removes foreground speckles and fills holes up to about
 * (2r+1)/sqrt(2) pixels across (a square of side s goes when s*s < half the window: r = 1 takes 2x2,
 * r = 2 3x3, r = 4 6x6, r = 8 12x12), while a straight silhouette edge stays where it is and
 * corners round off by about r pixels. The edge runs one pass of radius CONFIG's cleanup_radius_px
 * (vc_cleanup_radius); vc_cleanup repeats the 3x3 filter.
 */
#ifndef VOXCAP_EDGE_CLEANUP_H
#define VOXCAP_EDGE_CLEANUP_H

#include <stddef.h>
#include <stdint.h>

#include "voxcap/subtraction.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Bytes of scratch vc_cleanup() needs for masks `width` pixels wide. */
size_t vc_cleanup_scratch_size(int width);

/* Filters `mask` (width*height bytes, rows width bytes apart; nonzero = foreground) in place with
 * the 3x3 majority, `iterations` times (0 = only normalise to 0/255). `scratch` (caller-owned, at least
 * vc_cleanup_scratch_size(width) bytes, contents irrelevant) is borrowed for the call. No allocation.
 * Returns 0, or -EINVAL on a bad argument (including a too small scratch). */
int vc_cleanup(uint8_t* mask, int width, int height, int iterations, uint8_t* scratch, size_t scratch_len);

/* Largest radius vc_cleanup_radius() runs (the range rig.toml's cleanup_radius_px allows). */
#define VC_CLEANUP_MAX_RADIUS VC_CLEANUP_RADIUS_MAX_PX

/* Bytes of scratch vc_cleanup_radius() needs for masks `width` pixels wide at `radius`; 0 for a
 * width < 1 or a radius outside 0..VC_CLEANUP_MAX_RADIUS. */
size_t vc_cleanup_radius_scratch_size(int width, int radius);

/* One pass of the majority filter of `radius` (0..VC_CLEANUP_MAX_RADIUS; 0 = only normalise to
 * 0/255, 1 = one pass of the 3x3 filter exactly as vc_cleanup) on `mask` in place. `scratch`
 * (caller-owned, at least vc_cleanup_radius_scratch_size(width, radius) bytes, 2-byte aligned as
 * from malloc, contents irrelevant) is borrowed for the call. No allocation, integers only.
 * Returns 0, or -EINVAL on a bad argument (including a radius out of range or a too small scratch). */
int vc_cleanup_radius(uint8_t* mask, int width, int height, int radius, uint8_t* scratch, size_t scratch_len);

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_EDGE_CLEANUP_H */
