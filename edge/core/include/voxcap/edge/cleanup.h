/* Silhouette clean-up: a binary 3x3 majority (median) filter, in place, in integers.
 *
 * One iteration sets each pixel to foreground (255) when at least 5 of the 9 pixels of its 3x3
 * neighbourhood are foreground (nonzero), else to background (0); the image border is replicated.
 * That removes isolated speckles up to 2x2 pixels and fills holes up to 2x2 pixels per iteration,
 * while a straight silhouette edge stays where it is (corners round off by one pixel). Larger
 * blobs of noise need the thresholds of the subtraction, not more iterations.
 */
#ifndef VOXCAP_EDGE_CLEANUP_H
#define VOXCAP_EDGE_CLEANUP_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bytes of scratch vc_cleanup() needs for masks `width` pixels wide. */
size_t vc_cleanup_scratch_size(int width);

/* Filters `mask` (width*height bytes, rows width bytes apart; nonzero = foreground) in place,
 * `iterations` times (0 = only normalise to 0/255). `scratch` (caller-owned, at least
 * vc_cleanup_scratch_size(width) bytes, contents irrelevant) is borrowed for the call. No allocation.
 * Returns 0, or -EINVAL on a bad argument (including a too small scratch). */
int vc_cleanup(uint8_t *mask, int width, int height, int iterations, uint8_t *scratch,
               size_t scratch_len);

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_EDGE_CLEANUP_H */
