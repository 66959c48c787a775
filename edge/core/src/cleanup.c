/* Silhouette clean-up: binary 3x3 majority filter (see cleanup.h), in place with a 3-row window.
 *
 * The filter is separable in counts: a row of vertical sums (0..3) of the rows above, at and below,
 * then each output is the sum of three neighbouring vertical sums (0..9) compared with 5. Both loops
 * are byte arithmetic without branches, which the compiler vectorises. In-place operation keeps the
 * original of the current and the previous row in scratch; the row below is still unfiltered.
 * Out-of-image neighbours replicate the border (a body cut by the image edge keeps its edge pixels).
 */
#include "voxcap/edge/cleanup.h"

#include <errno.h>
#include <string.h>

#include "dispatch.h"

size_t vc_cleanup_scratch_size(int width) { return width > 0 ? 3 * (size_t)width + 2 : 0; }

static inline uint8_t bit(uint8_t v) { return v != 0; }

/* Vertical sums of three rows into vs[1..w], replicated into vs[0] and vs[w+1]. */
VC_HOT void vsum_body(const uint8_t *restrict up, const uint8_t *restrict mid,
                      const uint8_t *restrict down, uint8_t *restrict vs, int w) {
  for (int x = 0; x < w; x++) vs[x + 1] = (uint8_t)(bit(up[x]) + bit(mid[x]) + bit(down[x]));
  vs[0] = vs[1];
  vs[w + 1] = vs[w];
}

/* out[x] = 255 when vs[x] + vs[x+1] + vs[x+2] >= 5. */
VC_HOT void hmaj_body(const uint8_t *restrict vs, uint8_t *restrict out, int w) {
  for (int x = 0; x < w; x++) {
    uint8_t s = (uint8_t)(vs[x] + vs[x + 1] + vs[x + 2]);
    out[x] = (uint8_t)(0u - (uint8_t)(s >= 5));
  }
}

static void row_generic(const uint8_t *restrict up, const uint8_t *restrict mid,
                        const uint8_t *restrict down, uint8_t *restrict vs, uint8_t *restrict out,
                        int w) {
  vsum_body(up, mid, down, vs, w);
  hmaj_body(vs, out, w);
}

#if VC_HAVE_AVX2_VARIANT
VC_TARGET_AVX2 static void row_avx2(const uint8_t *restrict up, const uint8_t *restrict mid,
                                    const uint8_t *restrict down, uint8_t *restrict vs,
                                    uint8_t *restrict out, int w) {
  vsum_body(up, mid, down, vs, w);
  hmaj_body(vs, out, w);
}
#endif

int vc_cleanup(uint8_t *mask, int width, int height, int iterations, uint8_t *scratch,
               size_t scratch_len) {
  if (mask == NULL || scratch == NULL || width < 1 || height < 1 || iterations < 0 ||
      scratch_len < vc_cleanup_scratch_size(width))
    return -EINVAL;
  void (*row)(const uint8_t *restrict, const uint8_t *restrict, const uint8_t *restrict,
              uint8_t *restrict, uint8_t *restrict, int) = row_generic;
#if VC_HAVE_AVX2_VARIANT
  if (vc__use_avx2()) row = row_avx2;
#endif
  const size_t w = (size_t)width;
  if (iterations == 0) {
    for (size_t i = 0; i < w * (size_t)height; i++) mask[i] = (uint8_t)(0u - bit(mask[i]));
    return 0;
  }
  uint8_t *prev = scratch;    /* original of row y-1 */
  uint8_t *cur = scratch + w; /* original of row y */
  uint8_t *vs = scratch + 2 * w;
  for (int it = 0; it < iterations; it++) {
    memcpy(cur, mask, w);
    memcpy(prev, mask, w); /* row -1 replicates row 0 */
    for (int y = 0; y < height; y++) {
      uint8_t *out = mask + (size_t)y * w;
      const uint8_t *down = y + 1 < height ? out + w : cur; /* row h replicates row h-1 */
      row(prev, cur, down, vs, out, width);
      /* Slide the window: the original of row y becomes "previous", row y+1 (still unfiltered
       * in the mask) becomes "current". */
      uint8_t *t = prev;
      prev = cur;
      cur = t;
      if (y + 1 < height) memcpy(cur, out + w, w);
    }
  }
  return 0;
}
