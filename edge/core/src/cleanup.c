/* Silhouette clean-up: binary majority filters (see cleanup.h), in place.
 *
 * 3x3 (vc_cleanup, and vc_cleanup_radius with radius 1), with a 3-row window:
 *
 * The filter is separable in counts: a row of vertical sums (0..3) of the rows above, at and below,
 * then each output is the sum of three neighbouring vertical sums (0..9) compared with 5. Both loops
 * are byte arithmetic without branches, which the compiler vectorises. In-place operation keeps the
 * original of the current and the previous row in scratch; the row below is still unfiltered.
 * Out-of-image neighbours replicate the border (a body cut by the image edge keeps its edge pixels).
 */
#include "voxcap/edge/cleanup.h"

#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "cleanup_bits.h"
#include "dispatch.h"

#if VC_HAVE_AVX2_VARIANT
#include <immintrin.h>
#endif

size_t vc_cleanup_scratch_size(int width) {
  return width > 0 ? 3 * (size_t)width + 2 : 0;
}

static inline uint8_t bit(uint8_t v) {
  return v != 0;
}

/* Vertical sums of three rows into vs[1..w], replicated into vs[0] and vs[w+1]. */
VC_HOT void vsum_body(const uint8_t* restrict up, const uint8_t* restrict mid, const uint8_t* restrict down,
                      uint8_t* restrict vs, int w) {
  for (int x = 0; x < w; x++) vs[x + 1] = (uint8_t)(bit(up[x]) + bit(mid[x]) + bit(down[x]));
  vs[0] = vs[1];
  vs[w + 1] = vs[w];
}

/* out[x] = 255 when vs[x] + vs[x+1] + vs[x+2] >= 5. */
VC_HOT void hmaj_body(const uint8_t* restrict vs, uint8_t* restrict out, int w) {
  for (int x = 0; x < w; x++) {
    uint8_t s = (uint8_t)(vs[x] + vs[x + 1] + vs[x + 2]);
    out[x] = (uint8_t)(0u - (uint8_t)(s >= 5));
  }
}

static void row_generic(const uint8_t* restrict up, const uint8_t* restrict mid, const uint8_t* restrict down,
                        uint8_t* restrict vs, uint8_t* restrict out, int w) {
  vsum_body(up, mid, down, vs, w);
  hmaj_body(vs, out, w);
}

/* A final row's foreground (bytes 0 / 255) as bits (cleanup_bits.h); returns whether it has any. The
 * multiply gathers the 8 sign bits of a word. */
static int bits_generic(const uint8_t* out, int w, uint64_t* bits) {
  const uint64_t lsb = 0x0101010101010101ull;
  uint64_t any = 0;
  for (int x = 0; x < w; x += 64) {
    uint64_t word = 0;
    for (int k = 0; k < 64 && x + k < w; k += 8) {
      uint64_t v = 0;
      memcpy(&v, out + x + k, (size_t)(w - (x + k) >= 8 ? 8 : w - (x + k)));
      word |= ((((v >> 7) & lsb) * 0x0102040810204080ull) >> 56) << k;
    }
    bits[x / 64] = word;
    any |= word;
  }
  return any != 0;
}

#if VC_HAVE_AVX2_VARIANT
/* The same with the sign bits of 32 bytes at a time (little-endian halves of the words, as x86 is). */
VC_TARGET_AVX2 static int bits_avx2(const uint8_t* out, int w, uint64_t* bits) {
  const int n32 = w & ~31;
  uint64_t any = 0;
  bits[(w - 1) / 64] = 0; /* the last word's pixels past the width when the halves do not fill it */
  for (int x = 0; x < n32; x += 32) {
    const uint32_t b =
        (uint32_t)_mm256_movemask_epi8(_mm256_loadu_si256((const __m256i*)(const void*)(out + x)));
    memcpy((uint8_t*)bits + x / 8, &b, sizeof(b));
    any |= b;
  }
  if (n32 < w) { /* the last w % 32 pixels, from the word they share (n32 % 64 is 0 or 32) */
    const int x64 = n32 & ~63;
    any |= (uint64_t)bits_generic(out + x64, w - x64, bits + x64 / 64); /* the whole word again */
  }
  return any != 0;
}
#endif

#if VC_HAVE_AVX2_VARIANT
/* One row of the 3x3 filter in 32-byte vectors: the vertical sums (min(v, 1) makes 0/nonzero a 0/1
 * count), then the majority's compare, which gives the row's bytes and, when `bits` is wanted (the
 * clean-up's last pass), by movemask its foreground bits (cleanup_bits.h); the last w % 32 pixels in
 * the portable code. with_bits is a constant in each caller. */
VC_TARGET_AVX2 static inline __attribute__((always_inline)) int row_avx2_impl(
    const uint8_t* restrict up, const uint8_t* restrict mid, const uint8_t* restrict down,
    uint8_t* restrict vs, uint8_t* restrict out, int w, uint64_t* bits, const bool with_bits) {
  const __m256i one = _mm256_set1_epi8(1), four = _mm256_set1_epi8(4);
  const int n32 = w & ~31;
  for (int x = 0; x < n32; x += 32) {
    const __m256i a = _mm256_min_epu8(_mm256_loadu_si256((const __m256i*)(const void*)(up + x)), one);
    const __m256i b = _mm256_min_epu8(_mm256_loadu_si256((const __m256i*)(const void*)(mid + x)), one);
    const __m256i c = _mm256_min_epu8(_mm256_loadu_si256((const __m256i*)(const void*)(down + x)), one);
    _mm256_storeu_si256((__m256i*)(void*)(vs + 1 + x), _mm256_add_epi8(_mm256_add_epi8(a, b), c));
  }
  for (int x = n32; x < w; x++) vs[x + 1] = (uint8_t)(bit(up[x]) + bit(mid[x]) + bit(down[x]));
  vs[0] = vs[1];
  vs[w + 1] = vs[w];
  uint64_t any = 0;
  if (with_bits)
    bits[(w - 1) / 64] = 0; /* the last word's pixels past the width when the halves do not fill it */
  for (int x = 0; x < n32; x += 32) {
    const __m256i a = _mm256_loadu_si256((const __m256i*)(const void*)(vs + x));
    const __m256i b = _mm256_loadu_si256((const __m256i*)(const void*)(vs + x + 1));
    const __m256i c = _mm256_loadu_si256((const __m256i*)(const void*)(vs + x + 2));
    const __m256i m = _mm256_cmpgt_epi8(_mm256_add_epi8(_mm256_add_epi8(a, b), c), four); /* sums <= 9 */
    _mm256_storeu_si256((__m256i*)(void*)(out + x), m);
    if (with_bits) {
      const uint32_t mb = (uint32_t)_mm256_movemask_epi8(m);
      memcpy((uint8_t*)bits + x / 8, &mb, sizeof(mb));
      any |= mb;
    }
  }
  if (n32 < w) {
    hmaj_body(vs + n32, out + n32, w - n32);
    if (with_bits) {
      const int x64 = n32 & ~63;
      any |= (uint64_t)bits_generic(out + x64, w - x64, bits + x64 / 64); /* the whole word again */
    }
  }
  return any != 0;
}

VC_TARGET_AVX2 static void row_avx2(const uint8_t* restrict up, const uint8_t* restrict mid,
                                    const uint8_t* restrict down, uint8_t* restrict vs, uint8_t* restrict out,
                                    int w) {
  (void)row_avx2_impl(up, mid, down, vs, out, w, NULL, false);
}

VC_TARGET_AVX2 static int row_bits_avx2(const uint8_t* restrict up, const uint8_t* restrict mid,
                                        const uint8_t* restrict down, uint8_t* restrict vs,
                                        uint8_t* restrict out, int w, uint64_t* bits) {
  return row_avx2_impl(up, mid, down, vs, out, w, bits, true);
}
#endif

static int (*select_bits(void))(const uint8_t*, int, uint64_t*) {
#if VC_HAVE_AVX2_VARIANT
  if (vc__use_avx2()) return bits_avx2;
#endif
  return bits_generic;
}

/* vc_cleanup with the bits of the last pass and, when `orig` is given (one pass at most), the mask as
 * it came in there (cleanup_bits.h). */
static int cleanup3_bits(uint8_t* mask, int width, int height, int iterations, uint8_t* scratch,
                         size_t scratch_len, uint64_t* bits, size_t bits_stride, uint8_t* row_any,
                         uint8_t* orig) {
  if (mask == NULL || scratch == NULL || width < 1 || height < 1 || iterations < 0 ||
      scratch_len < vc_cleanup_scratch_size(width))
    return -EINVAL;
  void (*row)(const uint8_t* restrict, const uint8_t* restrict, const uint8_t* restrict, uint8_t* restrict,
              uint8_t* restrict, int) = row_generic;
#if VC_HAVE_AVX2_VARIANT
  if (vc__use_avx2()) row = row_avx2;
#endif
  const size_t w = (size_t)width;
  int (*to_bits)(const uint8_t*, int, uint64_t*) = select_bits();
  if (orig != NULL && iterations > 1) return -EINVAL;
  if (iterations == 0) {
    for (size_t i = 0; i < w * (size_t)height; i++) mask[i] = (uint8_t)(0u - bit(mask[i]));
    if (orig != NULL) memcpy(orig, mask, w * (size_t)height);
    for (int y = 0; bits != NULL && y < height; y++)
      row_any[y] = (uint8_t)to_bits(mask + (size_t)y * w, width, bits + (size_t)y * bits_stride);
    return 0;
  }
  /* The originals of rows y-1 and y: two rows of scratch that slide, or with `orig` its rows y-1 and
   * y, so that the whole mask as it came in is left there (the same one copy of each row). */
  uint8_t* prev = orig != NULL ? orig : scratch;
  uint8_t* cur = orig != NULL ? orig : scratch + w;
  uint8_t* vs = scratch + 2 * w;
  for (int it = 0; it < iterations; it++) {
    memcpy(cur, mask, w);
    if (orig == NULL) memcpy(prev, mask, w); /* row -1 replicates row 0 */
    for (int y = 0; y < height; y++) {
      uint8_t* out = mask + (size_t)y * w;
      const uint8_t* down = y + 1 < height ? out + w : cur; /* row h replicates row h-1 */
      if (bits == NULL || it + 1 < iterations) {
        row(prev, cur, down, vs, out, width);
      } else { /* the last pass: the row is final, its bits from the same pass */
#if VC_HAVE_AVX2_VARIANT
        if (to_bits == bits_avx2) {
          row_any[y] =
              (uint8_t)row_bits_avx2(prev, cur, down, vs, out, width, bits + (size_t)y * bits_stride);
        } else
#endif
        {
          row(prev, cur, down, vs, out, width);
          row_any[y] = (uint8_t)to_bits(out, width, bits + (size_t)y * bits_stride);
        }
      }
      /* Slide the window: the original of row y becomes "previous", row y+1 (still unfiltered
       * in the mask) becomes "current". */
      if (orig != NULL) {
        prev = cur;
        cur += w;
      } else {
        uint8_t* t = prev;
        prev = cur;
        cur = t;
      }
      if (y + 1 < height) memcpy(cur, out + w, w);
    }
  }
  return 0;
}

int vc_cleanup(uint8_t* mask, int width, int height, int iterations, uint8_t* scratch, size_t scratch_len) {
  return cleanup3_bits(mask, width, height, iterations, scratch, scratch_len, NULL, 0, NULL, NULL);
}

/* (2r+1) x (2r+1) majority, r >= 2 (cleanup.h), with running sums:
 *   cs[x]  = foreground count of column x over rows y-r..y+r (border rows replicated), updated per
 *            row by adding the row entering below and subtracting the row leaving above;
 *   a sliding horizontal sum over cs (border columns replicated) gives the window count.
 * Rows above y are already filtered in the mask, so the originals of rows y-r..y are kept in a ring
 * of r+1 rows (0/1 bytes); rows below y are still the originals in the mask. Counts fit in 16 bits:
 * at most 17 x 17 = 289. Not on the default path (radius 1), so plain C without a vector variant. */
static size_t ring_offset(int width, int radius) {
  return 2 * ((size_t)width + 2 * (size_t)radius); /* after cs[] (uint16, width + 2r) */
}

size_t vc_cleanup_radius_scratch_size(int width, int radius) {
  if (width < 1 || radius < 0 || radius > VC_CLEANUP_MAX_RADIUS) return 0;
  if (radius <= 1) return vc_cleanup_scratch_size(width);
  return ring_offset(width, radius) + ((size_t)radius + 1) * (size_t)width;
}

int vc_cleanup_radius(uint8_t* mask, int width, int height, int radius, uint8_t* scratch,
                      size_t scratch_len) {
  return vc__cleanup_radius_bits(mask, width, height, radius, scratch, scratch_len, NULL, 0, NULL, NULL);
}

int vc__cleanup_radius_bits(uint8_t* mask, int width, int height, int radius, uint8_t* scratch,
                            size_t scratch_len, uint64_t* bits, size_t bits_stride, uint8_t* row_any,
                            uint8_t* orig) {
  if (radius < 0 || radius > VC_CLEANUP_MAX_RADIUS || width < 1 ||
      scratch_len < vc_cleanup_radius_scratch_size(width, radius) || ((uintptr_t)scratch & 1u) != 0)
    return -EINVAL;
  if (radius <= 1)
    return cleanup3_bits(mask, width, height, radius, scratch, scratch_len, bits, bits_stride, row_any, orig);
  if (mask == NULL || scratch == NULL || height < 1) return -EINVAL;

  const size_t w = (size_t)width;
  const int r = radius, side = 2 * radius + 1;
  const unsigned need = (unsigned)(side * side + 1) / 2; /* strict majority: 5 of 9, 13 of 25, ... */
  uint16_t* cs = (uint16_t*)(void*)scratch + r;          /* cs[-r .. width-1+r] */
  /* originals of rows y-r..y, row % (r+1); with `orig` every row there, row y at row y */
  uint8_t* ring = orig != NULL ? orig : scratch + ring_offset(width, radius);
  const int ring_rows = orig != NULL ? height : r + 1;
#define ROW(yy) (mask + (size_t)((yy) < 0 ? 0 : (yy) >= height ? height - 1 : (yy)) * w)

  for (size_t x = 0; x < w; x++) {
    unsigned n = 0;
    for (int dy = -r; dy <= r; dy++) n += ROW(dy)[x] != 0;
    cs[x] = (uint16_t)n;
  }
  for (int y = 0; y < height; y++) {
    uint8_t* out = mask + (size_t)y * w;
    uint8_t* keep = ring + (size_t)(y % ring_rows) * w;
    for (size_t x = 0; x < w; x++) keep[x] = out[x] != 0;
    for (int k = 1; k <= r; k++) {
      cs[-k] = cs[0];
      cs[width - 1 + k] = cs[width - 1];
    }
    unsigned s = 0;
    for (int x = -r; x <= r; x++) s += cs[x];
    for (int x = 0;; x++) {
      out[x] = (uint8_t)(0u - (uint8_t)(s >= need));
      if (x + 1 == width) break; /* cs[width + r] would be past the padding */
      s += (unsigned)cs[x + r + 1] - (unsigned)cs[x - r];
    }
    if (bits != NULL) row_any[y] = (uint8_t)bits_generic(out, width, bits + (size_t)y * bits_stride);
    if (y + 1 == height) break;
    /* Next row's column counts: the row leaving above (an original, from the ring: rows <= y are
     * filtered now) out, the row entering below (still original in the mask) in. */
    const int leave = y - r < 0 ? 0 : y - r;
    const uint8_t* old = ring + (size_t)(leave % ring_rows) * w;
    const uint8_t* enter = ROW(y + 1 + r);
    for (size_t x = 0; x < w; x++) cs[x] = (uint16_t)(cs[x] - old[x] + (enter[x] != 0));
  }
#undef ROW
  return 0;
}
