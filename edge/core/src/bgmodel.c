/* Background model and shadow-aware subtraction (paper section 5, eq. 1 and 2), in integers.
 *
 * Learning sums each channel and its square per pixel (uint32: exact for up to 65535 frames); finish()
 * turns them into an 8-bit mean image and a Q8.8 standard deviation image (sample deviation, n-1).
 * set_params() then precomputes, per pixel and channel, the integer thresholds the frame loop
 * needs: since p and mu are integers, d > x  <=>  d > floor(x)  and  d >= x  <=>  d > ceil(x) - 1, so
 * eq. 1 and the lower threshold become exact byte comparisons (tu, tl below, stored as the bounds
 * blo, flo, fhi on p), with no rounding difference to a float implementation.
 *
 * The rule (bgmodel.h has it in full). A shadow only darkens, by a bounded ratio, keeps the
 * background's colour direction and keeps its texture. With T_u = 60 sigma (deep floor shadows must
 * reach the shadow test) nearly every darker body pixel lands in the band, and the per-pixel colour
 * angle cannot tell skin (222,170,138) over oak (160,114,74), ~6 degrees apart, or the shirt over
 * the blue painting (~1.7 degrees) from a shadow; what a shadow shows and a body does not is the
 * background's texture, scaled. Hence:
 *  A. vectorised, byte-wise over the interleaved RGB row, against three planes that hold the
 *     thresholds as bounds on p itself: blo = mu - tl, flo = mu - tu, fhi = mu + tl (saturated;
 *     tl = ceil(T_l sigma) - 1, tu = min(floor(T_u sigma), floor((1 - g_lo) mu + T_l sigma))):
 *     code = 0xFF if p > fhi (brighter than the noise: shadow_max_gain <= 1) or p < flo (darker
 *     than the deepest shadow), 1 if p < blo, else 0 -- three saturated subtractions a byte. A
 *     pixel's class is the OR of its three channel codes (0 = background, 1 = in the band,
 *     0xFF = foreground), written to the mask row, and pass A also gives the row's band pixels
 *     as a bitmap. The AVX2 variant folds the channels with lane shuffles and takes the bitmap
 *     from a movemask (32 pixels a step); the portable one is left to the auto-vectoriser.
 *  B. the band pixels only (typically a few percent: shadows and darker body parts), walked
 *     through the bitmap, get eq. 2 in 64-bit integers: with dot = p.mu, pp = |p|^2, mm = |mu|^2
 *     (exact integers < 2^18),
 *        candidate  <=>  dot^2 * 2^24 >= c2 * pp * mm              (c2 = cos^2(T_angular) in Q0.24)
 *                   and  g_lo * mm <= dot * 2^16 <= g_hi * mm     (alpha = dot/mm, gains in Q16.16)
 *     the others are foreground. With the texture test off a candidate is background (shadow).
 *  C. the texture test (texture_row): a candidate is shadow only when the candidates of its 5x5
 *     window, fitted as one scaled copy of the background (P = a * M over all their channels), leave
 *     a residual within k noise sigmas. Lit floor next to a shadow is background in pass A and
 *     outside the fit, so shadow edges pass; body pixels that failed eq. 2 are outside it too,
 *     except those that failed only its lower gain bound (the background's hue, darker than g_lo:
 *     eq. 1 lets them into the band within T_l sigma of the deepest shadow). They stay foreground
 *     but count in the windows' fits: a per-pixel cut at a fixed ratio keeps, of a flat surface
 *     at about that ratio (skin in deep shade over tiles), the pixels over the darker tiles, and
 *     those alone are a scaled copy of the background (session 16, edge/core/README.md).
 *     Then the flat-patch test (flat_beats_texture), on the luminance L = p_0 + p_1 + p_2: a flat
 *     patch must not explain the window's L better than the background's L scaled.
 *     Passes A and B run 2 rows ahead of C. Pass B lists each row's candidates with their |p|^2,
 *     p.mu and |mu|^2 (which eq. 2 computes anyway) and their L, L * Lmu and Lmu^2 in a 5-row ring,
 *     and adds them to running column sums (count and six sums per column over the window's rows,
 *     one 32-byte vector); a row leaves the sums when the windows below no longer reach it. A
 *     window's sums are then those of its 5 columns, so the work is a few dozen operations per
 *     candidate and nothing per other pixel. Ring and sums live in the model (32 bytes per pixel of
 *     5 rows + 32 per column: 123 KB at 640 wide), allocated once by set_params; no allocation per
 *     frame. Exact integers (64-bit, the last comparisons 128-bit).
 * Model data per pixel for pass A: blo, flo, fhi = 9 bytes, planar by role, interleaved by channel
 * like the image, so that pass A is four streams of bytes; mean is read for band pixels only, sigma
 * for candidates. At 640x480 a frame reads 0.9 MB of pixels and 2.8 MB of model.
 * Limits: sigma is clamped to 255.99 (Q8.8); thresholds at or above 255 never fire.
 */
#include "voxcap/edge/bgmodel.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "cleanup_bits.h"
#include "dispatch.h"
#include "voxcap/why.h"

#if VC_HAVE_NEON_VARIANT
#include <arm_neon.h>
#endif
#if VC_HAVE_AVX2_VARIANT
#include <immintrin.h>
#endif

#define VC_MAX_DIM 16384
#define VC_MAX_FRAMES 65535
#define VC_CHUNK 256            /* pixels per pass-A chunk: the code buffer stays in L1 */
#define VC_TEXTURE_RADIUS 2     /* the texture test's window is (2r+1)^2 pixels */
#define VC_TEXTURE_MIN_PIXELS 3 /* fewer candidates in the window: the per-pixel tests decide */

/* The terms the window tests sum over a window's candidates, one uint32 lane each (enum VC_S_*):
 * the count (1 per candidate), |p|^2, p.mu and |mu|^2 (the texture test's), the luminance L = p_0 +
 * p_1 + p_2, L * Lmu and Lmu^2 with Lmu = mu_0 + mu_1 + mu_2 (the flat-patch test's); the last lane
 * holds a candidate's column (its sum in colsum is never read). 32 bytes, one vector of the
 * compiler's vector extension (gcc and clang: two SSE2 or NEON registers, one AVX2), so that adding a
 * candidate to the column sums, and the window's sums, are whole-vector operations. */
enum { VC_S_N, VC_S_PP, VC_S_PM, VC_S_MM, VC_S_L, VC_S_LM, VC_S_MML, VC_S_X, VC_SUMS };
typedef uint32_t vc_sums __attribute__((vector_size(VC_SUMS * sizeof(uint32_t))));

/* A shadow candidate as pass B found it: its terms and its column (t[VC_S_X]), with VC_CAND_DARK
 * set for a pixel below eq. 2's lower gain bound with the background's hue, which the windows' fits
 * count but which is foreground and not tested (columns < 16384, so the top bit is free). */
#define VC_CAND_DARK 0x80000000u
struct vc_cand {
  vc_sums t;
};

struct vc_bgmodel {
  int width, height;
  int frames;
  bool finished, ready;
  uint32_t* sum;      /* [3*w*h] sum of samples, while learning */
  uint32_t* sumsq;    /* [3*w*h] sum of squared samples, while learning */
  uint8_t* mean;      /* [3*w*h] rounded mean, grey levels */
  uint16_t* sigma_q8; /* [3*w*h] Q8.8 standard deviation, grey levels */
  /* Pass A's planes, from tu = min(floor(T_u*sigma), floor((1-g_lo)*mu + T_l*sigma)) and
   * tl = ceil(T_l*sigma)-1 (both clamped to 255), as bounds on p itself (grey levels): */
  uint8_t* blo;      /* [3*w*h] max(mu - tl, 0): band when p < blo (mu - p > tl) */
  uint8_t* flo;      /* [3*w*h] max(mu - tu, 0): foreground when p < flo (darker than the deepest shadow) */
  uint8_t* fhi;      /* [3*w*h] min(mu + tl, 255): foreground when p > fhi (shadows only darken) */
  uint64_t c2_q24;   /* Q0.24 cos^2(T_angular) */
  uint64_t glo_q16;  /* Q16.16 lowest brightness ratio of a shadow */
  uint64_t ghi_q16;  /* Q16.16 highest brightness ratio of a shadow */
  uint64_t k2_q8;    /* Q8.8 k^2 of the texture test; 0 = test off */
  uint64_t flat_q8;  /* Q8.8 the flat-patch test's margin, noise variances per pixel; 0 = test off */
  uint16_t floor_q8; /* Q8.8 sigma floor (rounded), grey levels: the texture test's noise floor */
  int grow_px;       /* the limb-scale cue's steps; 0 = off */
  uint64_t grow_q8;  /* Q8.8 grow_sigma^2 */
  uint32_t* queue;   /* [w*h] the cue's pixels to test, each queued once a frame (when it is on) */
  uint64_t* fgbits;  /* [h+2][vc_fg_stride(w)] the mask's foreground as bits, for the cue's first
                      * ring: 64 pixels a word, a zero word before and after each row, a zero row
                      * above and below the image (grow_ring1) */
  uint8_t* row_any;  /* [h+2] whether a row of fgbits has foreground */
  uint32_t* grow_d2; /* [w*h] the cue's weak test's least |p - mu|^2 per pixel (set_params), with
                      * VC_GROW_FLAT set where the background is flat (grow_flat) */
  int16_t* span;     /* [h+2][2] a row of fgbits' first and last word with foreground (grow_ring1) */
  uint8_t* raw;      /* [w*h] the frame's mask before the clean-up (vc__cleanup_radius_bits leaves it) */
  /* Scratch of vc_subtract's texture test (allocated by set_params when it is on): */
  struct vc_cand* cand; /* [5][w] the candidates of row y (slot y mod 5) with their terms */
  vc_sums* colsum;      /* [w + 4] per column: the candidates' count and sums over the window's rows */
};

/* Words per row of the cue's foreground bits: the row's and a zero guard on either side. */
static size_t vc_fg_stride(int w) {
  return ((size_t)w + 63) / 64 + 2;
}

void vc_subtract_params_default(vc_subtract_params* params) {
  if (params == NULL) return;
  const double angle = VC_SUBTRACT_SHADOW_ANGLE_DEG * (acos(-1.0) / 180.0);
  params->t_upper = VC_SUBTRACT_T_UPPER;
  params->t_lower = VC_SUBTRACT_T_LOWER;
  params->cos2_angular = cos(angle) * cos(angle);
  params->shadow_min_gain = VC_SUBTRACT_SHADOW_MIN_GAIN;
  params->shadow_max_gain = VC_SUBTRACT_SHADOW_MAX_GAIN;
  params->sigma_floor = VC_SUBTRACT_SIGMA_FLOOR;
  params->shadow_texture_k = VC_SUBTRACT_SHADOW_TEXTURE_K;
  params->shadow_flat_margin = VC_SUBTRACT_SHADOW_FLAT_MARGIN;
  params->grow_px = VC_SUBTRACT_GROW_PX;
  params->grow_sigma = VC_SUBTRACT_GROW_SIGMA;
  params->grow_flat = VC_SUBTRACT_GROW_FLAT;
}

int vc_subtract_params_check(const vc_subtract_params* p, char* why, size_t why_len) {
  const char* bad = NULL;
  double got = 0.0; /* the offending value, said after the rule */
  if (p == NULL) {
    vc_why(why, why_len, "params is NULL");
    return -EINVAL;
  }
  if (!(p->t_upper > 0.0 && p->t_upper <= 1000.0)) {
    bad = "t_upper must be in (0, 1000]";
    got = p->t_upper;
  } else if (!(p->t_lower > 0.0 && p->t_lower <= p->t_upper)) {
    bad = "t_lower must be in (0, t_upper]";
    got = p->t_lower;
  } else if (!(p->cos2_angular >= 0.0 && p->cos2_angular <= 1.0)) {
    bad = "cos2_angular must be in [0, 1]";
    got = p->cos2_angular;
  } else if (!(p->shadow_min_gain >= 0.0 && p->shadow_min_gain <= 1.0)) {
    bad = "shadow_min_gain must be in [0, 1]";
    got = p->shadow_min_gain;
  } else if (!(p->shadow_max_gain >= p->shadow_min_gain && p->shadow_max_gain <= 1.0)) {
    bad = "shadow_max_gain must be in [shadow_min_gain, 1] (a shadow only darkens)";
    got = p->shadow_max_gain;
  } else if (!(p->sigma_floor > 0.0 && p->sigma_floor <= 255.0)) {
    bad = "sigma_floor must be in (0, 255]";
    got = p->sigma_floor;
  } else if (!(p->shadow_texture_k >= 0.0 && p->shadow_texture_k <= VC_SUBTRACT_SHADOW_TEXTURE_K_MAX)) {
    bad = "shadow_texture_k must be in [0, 16] (0 = off)";
    got = p->shadow_texture_k;
  } else if (!(p->shadow_flat_margin >= 0.0 && p->shadow_flat_margin <= VC_SUBTRACT_SHADOW_FLAT_MARGIN_MAX)) {
    bad = "shadow_flat_margin must be in [0, 16] (0 = off)";
    got = p->shadow_flat_margin;
  } else if (!(p->grow_px >= 0.0 && p->grow_px <= VC_SUBTRACT_GROW_PX_MAX &&
               p->grow_px == floor(p->grow_px))) {
    bad = "grow_px must be an integer in [0, 64] (0 = off)";
    got = p->grow_px;
  } else if (!(p->grow_sigma > 0.0 && p->grow_sigma <= VC_SUBTRACT_GROW_SIGMA_MAX)) {
    bad = "grow_sigma must be in (0, 16]";
    got = p->grow_sigma;
  } else if (!(p->grow_flat >= 0.0 && p->grow_flat <= VC_SUBTRACT_GROW_FLAT_MAX)) {
    bad = "grow_flat must be in [0, 16] (0 = off)";
    got = p->grow_flat;
  }
  if (bad == NULL) {
    vc_why_clear(why, why_len);
    return 0;
  }
  vc_why(why, why_len, "%s, not %g", bad, got);
  return -EINVAL;
}

int vc_bgmodel_new(int width, int height, vc_bgmodel** out, char* why, size_t why_len) {
  vc_why_clear(why, why_len);
  if (out) *out = NULL;
  if (!out) {
    vc_why(why, why_len, "background model: no place for the model");
    return -EINVAL;
  }
  if (width < 1 || height < 1 || width > VC_MAX_DIM || height > VC_MAX_DIM) {
    vc_why(why, why_len, "background model: frame size %dx%d must be 1..%d each", width, height, VC_MAX_DIM);
    return -EINVAL;
  }
  size_t n = (size_t)width * (size_t)height * 3;
  vc_bgmodel* m = calloc(1, sizeof(*m));
  if (m == NULL) goto err_nomem;
  m->width = width;
  m->height = height;
  m->sum = calloc(n, sizeof(*m->sum));
  m->sumsq = calloc(n, sizeof(*m->sumsq));
  if (m->sum == NULL || m->sumsq == NULL) goto err_nomem;
  *out = m;
  return 0;

err_nomem:
  vc_bgmodel_free(m);
  vc_why(why, why_len, "background model: out of memory for %dx%d frames", width, height);
  return -ENOMEM;
}

void vc_bgmodel_free(vc_bgmodel* m) {
  if (m == NULL) return;
  free(m->sum);
  free(m->sumsq);
  free(m->mean);
  free(m->sigma_q8);
  free(m->blo);
  free(m->flo);
  free(m->fhi);
  free(m->cand);
  free(m->colsum);
  free(m->queue);
  free(m->fgbits);
  free(m->row_any);
  free(m->span);
  free(m->grow_d2);
  free(m->raw);
  free(m);
}

int vc_bgmodel_learn(vc_bgmodel* m, const uint8_t* rgb, size_t stride) {
  if (m == NULL || rgb == NULL || stride < (size_t)m->width * 3) return -EINVAL;
  if (m->finished) return -EBUSY;
  if (m->frames >= VC_MAX_FRAMES) return -EOVERFLOW;
  const size_t row = (size_t)m->width * 3;
  for (int y = 0; y < m->height; y++) {
    const uint8_t* restrict src = rgb + (size_t)y * stride;
    uint32_t* restrict s = m->sum + (size_t)y * row;
    uint32_t* restrict q = m->sumsq + (size_t)y * row;
    for (size_t i = 0; i < row; i++) {
      uint32_t v = src[i];
      s[i] += v;
      q[i] += v * v;
    }
  }
  m->frames++;
  return 0;
}

int vc_bgmodel_finish(vc_bgmodel* m) {
  if (m == NULL) return -EINVAL;
  if (m->finished) return -EBUSY;
  if (m->frames < 2) return -ENODATA;
  const size_t n = (size_t)m->width * (size_t)m->height * 3;
  m->mean = malloc(n);
  m->sigma_q8 = malloc(n * sizeof(*m->sigma_q8));
  if (m->mean == NULL || m->sigma_q8 == NULL) goto err_nomem;
  const uint64_t f = (uint64_t)m->frames;
  for (size_t i = 0; i < n; i++) {
    uint64_t s = m->sum[i], q = m->sumsq[i];
    m->mean[i] = (uint8_t)((s + f / 2) / f);
    /* n*sum(x^2) - (sum x)^2 >= 0 exactly in 64 bits (< 2^49 for 65535 frames). */
    uint64_t num = f * q - s * s;
    double sigma = sqrt((double)num / (double)(f * (f - 1)));
    double q8 = floor(sigma * 256.0 + 0.5);
    m->sigma_q8[i] = (uint16_t)(q8 > 65535.0 ? 65535.0 : q8);
  }
  free(m->sum);
  free(m->sumsq);
  m->sum = m->sumsq = NULL;
  m->finished = true;
  return 0;

err_nomem:
  free(m->mean);
  free(m->sigma_q8);
  m->mean = NULL;
  m->sigma_q8 = NULL;
  return -ENOMEM;
}

int vc_bgmodel_restore(vc_bgmodel* m, const uint8_t* mean, const uint16_t* sigma_q8, int frames) {
  if (m == NULL || mean == NULL || sigma_q8 == NULL || frames < 2) return -EINVAL;
  if (m->finished || m->frames != 0) return -EBUSY;
  const size_t n = (size_t)m->width * (size_t)m->height * 3;
  uint8_t* mu = malloc(n);
  uint16_t* sg = malloc(n * sizeof(*sg));
  if (mu == NULL || sg == NULL) {
    free(mu);
    free(sg);
    return -ENOMEM;
  }
  memcpy(mu, mean, n);
  memcpy(sg, sigma_q8, n * sizeof(*sg));
  free(m->sum);
  free(m->sumsq);
  m->sum = m->sumsq = NULL;
  m->mean = mu;
  m->sigma_q8 = sg;
  m->frames = frames;
  m->finished = true;
  return 0;
}

/* The cue's flat-background mark (bgmodel.h: grow_flat): VC_GROW_FLAT in grow_d2[i] where the
 * variance of the background's luminance Lmu over the 5x5 window around pixel i (clipped to the
 * image; exact integer sums of Lmu and Lmu^2 per window, the comparison in doubles, at set-up time)
 * is below grow_flat times the noise variance of L at i (sum_c s_c^2, floored sigma). */
#define VC_GROW_FLAT 0x80000000u

/* The noise variance of the luminance L = p_0 + p_1 + p_2 at pixel i: sum_c s_c^2, s_c the channel's
 * sigma floored at floor_q8 (both Q8.8), so Q16.16. The cue's weak test and its flat mark use it. */
static uint64_t noise_var_q16(const vc_bgmodel* m, size_t i) {
  uint64_t v = 0;
  for (int c = 0; c < 3; c++) {
    const uint64_t sg = m->sigma_q8[3 * i + c] > m->floor_q8 ? m->sigma_q8[3 * i + c] : m->floor_q8;
    v += sg * sg;
  }
  return v;
}

static void mark_flat_background(vc_bgmodel* m, double grow_flat) {
  const int w = m->width, h = m->height, r = VC_TEXTURE_RADIUS;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      uint64_t s = 0, s2 = 0, cnt = 0;
      for (int yy = y - r; yy <= y + r; yy++) {
        if (yy < 0 || yy >= h) continue;
        for (int xx = x - r; xx <= x + r; xx++) {
          if (xx < 0 || xx >= w) continue;
          const uint8_t* mu = m->mean + 3 * ((size_t)yy * (size_t)w + (size_t)xx);
          const uint64_t l = (uint64_t)mu[0] + mu[1] + mu[2];
          s += l;
          s2 += l * l;
          cnt++;
        }
      }
      const size_t i = (size_t)y * (size_t)w + (size_t)x;
      const double v = (double)noise_var_q16(m, i) / 65536.0; /* exact: an integer < 2^34 */
      /* variance * cnt^2 = cnt * s2 - s^2, exact in 64 bits (cnt <= 25, l <= 765) */
      const double var = (double)(cnt * s2 - s * s) / ((double)cnt * (double)cnt);
      if (var < grow_flat * v) m->grow_d2[i] |= VC_GROW_FLAT;
    }
}

int vc_bgmodel_set_params(vc_bgmodel* m, const vc_subtract_params* p) {
  if (m == NULL || vc_subtract_params_check(p, NULL, 0) != 0) return -EINVAL;
  if (!m->finished) return -EAGAIN;
  const size_t n = (size_t)m->width * (size_t)m->height * 3;
  if (m->blo == NULL) m->blo = malloc(n);
  if (m->flo == NULL) m->flo = malloc(n);
  if (m->fhi == NULL) m->fhi = malloc(n);
  m->ready = false;
  if (m->blo == NULL || m->flo == NULL || m->fhi == NULL) return -ENOMEM;
  const uint16_t floor_q8 = (uint16_t)llround(p->sigma_floor * 256.0);
  for (size_t i = 0; i < n; i++) {
    double sigma = fmax((double)m->sigma_q8[i] / 256.0, p->sigma_floor);
    double up =
        fmin(floor(p->t_upper * sigma), floor((1.0 - p->shadow_min_gain) * m->mean[i] + p->t_lower * sigma));
    double lo = ceil(p->t_lower * sigma) - 1.0;
    const int mu = m->mean[i], tu = (int)(up > 255.0 ? 255.0 : up), tl = (int)(lo > 255.0 ? 255.0 : lo);
    m->blo[i] = (uint8_t)(mu - tl > 0 ? mu - tl : 0);
    m->flo[i] = (uint8_t)(mu - tu > 0 ? mu - tu : 0);
    m->fhi[i] = (uint8_t)(mu + tl < 255 ? mu + tl : 255);
  }
  m->floor_q8 = floor_q8;
  m->k2_q8 = (uint64_t)llround(p->shadow_texture_k * p->shadow_texture_k * 256.0);
  m->flat_q8 = (uint64_t)llround(p->shadow_flat_margin * 256.0);
  if ((m->k2_q8 != 0 || m->flat_q8 != 0) && m->cand == NULL) {
    /* sizes are multiples of the vectors' alignment, as aligned_alloc wants */
    m->cand = aligned_alloc(sizeof(vc_sums),
                            (size_t)(2 * VC_TEXTURE_RADIUS + 1) * (size_t)m->width * sizeof(*m->cand));
    m->colsum =
        aligned_alloc(sizeof(vc_sums), (size_t)(m->width + 2 * VC_TEXTURE_RADIUS) * sizeof(*m->colsum));
    if (m->cand == NULL || m->colsum == NULL) {
      free(m->cand);
      free(m->colsum);
      m->cand = NULL;
      m->colsum = NULL;
      return -ENOMEM;
    }
  }
  m->grow_px = (int)p->grow_px;
  m->grow_q8 = (uint64_t)llround(p->grow_sigma * p->grow_sigma * 256.0);
  if (m->grow_px > 0 && m->queue == NULL) {
    m->queue = malloc((size_t)m->width * (size_t)m->height * sizeof(*m->queue));
    m->fgbits = calloc(vc_fg_stride(m->width) * ((size_t)m->height + 2), sizeof(*m->fgbits));
    m->row_any = malloc((size_t)m->height + 2);
    m->span = malloc(2 * ((size_t)m->height + 2) * sizeof(*m->span));
    m->grow_d2 = malloc((size_t)m->width * (size_t)m->height * sizeof(*m->grow_d2));
    m->raw = malloc((size_t)m->width * (size_t)m->height);
    if (m->queue == NULL || m->fgbits == NULL || m->row_any == NULL || m->span == NULL ||
        m->grow_d2 == NULL || m->raw == NULL) {
      free(m->queue);
      free(m->fgbits);
      free(m->row_any);
      free(m->span);
      free(m->grow_d2);
      free(m->raw);
      m->queue = NULL;
      m->fgbits = NULL;
      m->row_any = NULL;
      m->span = NULL;
      m->grow_d2 = NULL;
      m->raw = NULL;
      return -ENOMEM;
    }
  }
  if (m->grow_px > 0) { /* d2 * 2^24 >= grow_q8 * v  <=>  d2 >= ceil(grow_q8 * v / 2^24) (d2 < 2^18) */
    for (size_t i = 0; i < n / 3; i++) { /* n: the model's values, 3 a pixel */
      const uint64_t t = (m->grow_q8 * noise_var_q16(m, i) + (1ull << 24) - 1) >> 24;
      m->grow_d2[i] = (uint32_t)(t > (1ull << 20) ? (1ull << 20) : t);
    }
    if (p->grow_flat > 0.0) mark_flat_background(m, p->grow_flat);
  }
  m->c2_q24 = (uint64_t)llround(p->cos2_angular * 16777216.0);
  m->glo_q16 = (uint64_t)llround(p->shadow_min_gain * 65536.0);
  m->ghi_q16 = (uint64_t)llround(p->shadow_max_gain * 65536.0);
  m->ready = true;
  return 0;
}

int vc_bgmodel_frames(const vc_bgmodel* m) {
  return m ? m->frames : 0;
}
int vc_bgmodel_width(const vc_bgmodel* m) {
  return m ? m->width : 0;
}
int vc_bgmodel_height(const vc_bgmodel* m) {
  return m ? m->height : 0;
}
const uint8_t* vc_bgmodel_mean(const vc_bgmodel* m) {
  return m ? m->mean : NULL;
}
const uint16_t* vc_bgmodel_sigma_q8(const vc_bgmodel* m) {
  return m ? m->sigma_q8 : NULL;
}

/* ---- per-frame kernels ---------------------------------------------------------------------- */

static inline uint8_t u8min(uint8_t a, uint8_t b) {
  return a < b ? a : b;
}

/* Pass A, portable, over pixels [x0, n) of a row: out[i] = 0 (background), 1 (band: darker than
 * the noise) or 0xFF (foreground), from the three byte planes (see the top of this file). Written
 * as min/sub byte arithmetic so that gcc and clang vectorise the first loop; the second folds the
 * three channel codes of each pixel (a stride-3 gather, vectorised where the ISA has it: NEON ld3). */
static void classify_span(const uint8_t* restrict px, const uint8_t* restrict blo,
                          const uint8_t* restrict flo, const uint8_t* restrict fhi, uint8_t* restrict out,
                          int x0, int n) {
  uint8_t code[3 * VC_CHUNK];
  for (; x0 < n; x0 += VC_CHUNK) {
    const int len = n - x0 < VC_CHUNK ? n - x0 : VC_CHUNK;
    const int nb = 3 * len;
    const uint8_t* restrict p = px + 3 * x0;
    const uint8_t* restrict b = blo + 3 * x0;
    const uint8_t* restrict fl = flo + 3 * x0;
    const uint8_t* restrict fh = fhi + 3 * x0;
    for (int k = 0; k < nb; k++) {
      const uint8_t band = (uint8_t)(b[k] - u8min(b[k], p[k])); /* p < blo */
      const uint8_t fg =
          (uint8_t)((fl[k] - u8min(fl[k], p[k])) | (p[k] - u8min(p[k], fh[k]))); /* p < flo, p > fhi */
      code[k] = (uint8_t)(u8min(band, 1) | (uint8_t)(0u - u8min(fg, 1)));
    }
    uint8_t* restrict o = out + x0;
    for (int i = 0; i < len; i++) o[i] = (uint8_t)(code[3 * i] | code[3 * i + 1] | code[3 * i + 2]);
  }
}

/* The band pixels (value 1) of out[x0, n) as bits of `bits` (bit i of word i / 64; the words from
 * x0 / 64 on are overwritten, x0 a multiple of 64). A band byte is the only value whose bit 0 differs
 * from its bit 1 (0x00 and 0xFF do not), and the multiply gathers the 8 marks of a word. */
static int band_bits(const uint8_t* out, int x0, int n, uint64_t* bits) {
  const uint64_t lsb = 0x0101010101010101ull;
  uint64_t any = 0;
  for (int x = x0; x < n; x += 64) {
    uint64_t word = 0;
    for (int k = 0; k < 64 && x + k < n; k += 8) {
      uint64_t w = 0;
      if (n - (x + k) >= 8)
        memcpy(&w, out + x + k, 8); /* a constant size: one load */
      else
        memcpy(&w, out + x + k, (size_t)(n - (x + k)));
      const uint64_t marks = (w ^ (w >> 1)) & lsb;
      word |= ((marks * 0x0102040810204080ull) >> 56) << k;
    }
    bits[x / 64] = word;
    any |= word;
  }
  return any != 0;
}

static int classify_row_generic(const uint8_t* restrict px, const uint8_t* restrict blo,
                                const uint8_t* restrict flo, const uint8_t* restrict fhi,
                                uint8_t* restrict out, uint64_t* restrict bits, int n) {
  classify_span(px, blo, flo, fhi, out, 0, n);
  return band_bits(out, 0, n, bits);
}

#if VC_HAVE_AVX2_VARIANT
/* Pass A with AVX2, 32 pixels (96 bytes of each plane) per step; the same codes as classify_span.
 * The 3 code vectors c0 c1 c2 (bytes 0-31, 32-63, 64-95) are regrouped by 128-bit lanes into
 * A = [0-15 | 48-63], B = [16-31 | 64-79], C = [32-47 | 80-95], so that each lane holds 16 whole
 * pixels' bytes in a row; OR-ing each byte with its next two (alignr) puts a pixel's code at its
 * first byte, and three shuffles gather those 16 bytes per lane. The band mask is one movemask. */
VC_TARGET_AVX2 static inline __m256i codes32(const uint8_t* p, const uint8_t* b, const uint8_t* fl,
                                             const uint8_t* fh) {
  const __m256i vp = _mm256_loadu_si256((const __m256i*)(const void*)p);
  const __m256i band = _mm256_subs_epu8(_mm256_loadu_si256((const __m256i*)(const void*)b), vp);
  const __m256i fg =
      _mm256_or_si256(_mm256_subs_epu8(_mm256_loadu_si256((const __m256i*)(const void*)fl), vp),
                      _mm256_subs_epu8(vp, _mm256_loadu_si256((const __m256i*)(const void*)fh)));
  const __m256i zero = _mm256_setzero_si256();
  /* 0xFF where fg != 0, else min(band, 1) */
  return _mm256_or_si256(_mm256_andnot_si256(_mm256_cmpeq_epi8(fg, zero), _mm256_set1_epi8(-1)),
                         _mm256_min_epu8(band, _mm256_set1_epi8(1)));
}

VC_TARGET_AVX2 static int classify_row_avx2(const uint8_t* restrict px, const uint8_t* restrict blo,
                                            const uint8_t* restrict flo, const uint8_t* restrict fhi,
                                            uint8_t* restrict out, uint64_t* restrict bits, int n) {
  const __m256i m0 = _mm256_setr_epi8(0, 3, 6, 9, 12, 15, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, /* A */
                                      0, 3, 6, 9, 12, 15, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
  const __m256i m1 = _mm256_setr_epi8(-1, -1, -1, -1, -1, -1, 2, 5, 8, 11, 14, -1, -1, -1, -1, -1, /* B */
                                      -1, -1, -1, -1, -1, -1, 2, 5, 8, 11, 14, -1, -1, -1, -1, -1);
  const __m256i m2 = _mm256_setr_epi8(-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 1, 4, 7, 10, 13, /* C */
                                      -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 1, 4, 7, 10, 13);
  const __m256i one = _mm256_set1_epi8(1);
  const int n32 = n & ~31;
  uint64_t any = 0;
  for (int x = 0; x < n32; x += 32) {
    const size_t o = 3 * (size_t)x;
    const __m256i c0 = codes32(px + o, blo + o, flo + o, fhi + o);
    const __m256i c1 = codes32(px + o + 32, blo + o + 32, flo + o + 32, fhi + o + 32);
    const __m256i c2 = codes32(px + o + 64, blo + o + 64, flo + o + 64, fhi + o + 64);
    const __m256i a = _mm256_permute2x128_si256(c0, c1, 0x30);
    const __m256i b = _mm256_permute2x128_si256(c0, c2, 0x21);
    const __m256i c = _mm256_permute2x128_si256(c1, c2, 0x30);
    const __m256i ta =
        _mm256_or_si256(a, _mm256_or_si256(_mm256_alignr_epi8(b, a, 1), _mm256_alignr_epi8(b, a, 2)));
    const __m256i tb =
        _mm256_or_si256(b, _mm256_or_si256(_mm256_alignr_epi8(c, b, 1), _mm256_alignr_epi8(c, b, 2)));
    const __m256i tc = _mm256_or_si256(c, _mm256_or_si256(_mm256_srli_si256(c, 1), _mm256_srli_si256(c, 2)));
    const __m256i v =
        _mm256_or_si256(_mm256_shuffle_epi8(ta, m0),
                        _mm256_or_si256(_mm256_shuffle_epi8(tb, m1), _mm256_shuffle_epi8(tc, m2)));
    _mm256_storeu_si256((__m256i*)(void*)(out + x), v);
    const uint64_t mb = (uint32_t)_mm256_movemask_epi8(_mm256_cmpeq_epi8(v, one));
    if ((x & 63) == 0)
      bits[x / 64] = mb;
    else
      bits[x / 64] |= mb << 32;
    any |= mb;
  }
  if (n32 < n) { /* the last n % 32 pixels: the portable code, from a multiple of 32 */
    const int x64 = n32 & ~63;
    classify_span(px, blo, flo, fhi, out, n32, n);
    any |= (uint64_t)band_bits(out, x64, n, bits);
  }
  return any != 0;
}
#endif

#if VC_HAVE_NEON_VARIANT
/* Pass A with NEON, 16 pixels per step; the same codes as classify_span. ld3 de-interleaves the
 * 48 bytes of each plane into one vector per channel, so a pixel's three channel codes fold with
 * plain ORs (no shuffles): with band = OR of the channels' (blo - p) and fg = OR of (flo - p) and
 * (p - fhi) (saturated), the code is 0xFF where fg != 0, else min(band, 1) -- the OR of the three
 * channel codes of classify_span. The band pixels' bits come from (code == 1) ANDed with the bit
 * weights 1..128 and summed per half. */
static int classify_row_neon(const uint8_t* restrict px, const uint8_t* restrict blo,
                             const uint8_t* restrict flo, const uint8_t* restrict fhi, uint8_t* restrict out,
                             uint64_t* restrict bits, int n) {
  static const uint8_t weights[16] = {1, 2, 4, 8, 16, 32, 64, 128, 1, 2, 4, 8, 16, 32, 64, 128};
  const uint8x16_t wv = vld1q_u8(weights);
  const uint8x16_t one = vdupq_n_u8(1);
  const int n16 = n & ~15;
  uint64_t any = 0;
  for (int x = 0; x < n16; x += 16) {
    const size_t o = 3 * (size_t)x;
    const uint8x16x3_t p = vld3q_u8(px + o);
    const uint8x16x3_t b = vld3q_u8(blo + o);
    const uint8x16x3_t fl = vld3q_u8(flo + o);
    const uint8x16x3_t fh = vld3q_u8(fhi + o);
    uint8x16_t band = vqsubq_u8(b.val[0], p.val[0]);
    band = vorrq_u8(band, vqsubq_u8(b.val[1], p.val[1]));
    band = vorrq_u8(band, vqsubq_u8(b.val[2], p.val[2]));
    uint8x16_t fg = vorrq_u8(vqsubq_u8(fl.val[0], p.val[0]), vqsubq_u8(p.val[0], fh.val[0]));
    fg = vorrq_u8(fg, vorrq_u8(vqsubq_u8(fl.val[1], p.val[1]), vqsubq_u8(p.val[1], fh.val[1])));
    fg = vorrq_u8(fg, vorrq_u8(vqsubq_u8(fl.val[2], p.val[2]), vqsubq_u8(p.val[2], fh.val[2])));
    const uint8x16_t v = vorrq_u8(vtstq_u8(fg, fg), vminq_u8(band, one)); /* vtst: 0xFF where != 0 */
    vst1q_u8(out + x, v);
    const uint8x16_t marks = vandq_u8(vceqq_u8(v, one), wv);
    const uint64_t mb = (uint64_t)vaddv_u8(vget_low_u8(marks)) | (uint64_t)vaddv_u8(vget_high_u8(marks)) << 8;
    if ((x & 63) == 0)
      bits[x / 64] = mb;
    else
      bits[x / 64] |= mb << (x & 63);
    any |= mb;
  }
  if (n16 < n) { /* the last n % 16 pixels: the portable code, from a multiple of 16 */
    const int x64 = n16 & ~63;
    classify_span(px, blo, flo, fhi, out, n16, n);
    any |= (uint64_t)band_bits(out, x64, n, bits);
  }
  return any != 0;
}
#endif

/* Pass B: eq. 2 for the band pixels of one row (bit i of `bits`), walked with count-trailing-zeros
 * (words without band pixels cost a test). A pixel that fails is foreground (0xFF); one that
 * passes is background (0), and when the texture test is on (`cand` not NULL) also a candidate,
 * appended to cand[] with its terms; so is a pixel that failed only the lower gain bound, marked
 * VC_CAND_DARK (in the windows' sums, not tested). Returns the number of entries of cand[] (with
 * the texture test off: the pixels that passed); adds the row's band pixels to *band_count. */
static int shadow_row(const vc_bgmodel* m, const uint8_t* px, const uint8_t* mean, uint8_t* out,
                      const uint64_t* bits, int n, struct vc_cand* cand, uint32_t* band_count) {
  const uint64_t c2 = m->c2_q24, glo = m->glo_q16, ghi = m->ghi_q16;
  int k = 0;
  uint32_t band = 0;
  for (int wi = 0; wi < (n + 63) / 64; wi++) {
    for (uint64_t b = bits[wi]; b != 0; b &= b - 1) {
      const int i = wi * 64 + __builtin_ctzll(b);
      const uint8_t *p = px + 3 * i, *mu = mean + 3 * i;
      const uint64_t dot = (uint64_t)p[0] * mu[0] + (uint64_t)p[1] * mu[1] + (uint64_t)p[2] * mu[2];
      const uint64_t pp = (uint64_t)p[0] * p[0] + (uint64_t)p[1] * p[1] + (uint64_t)p[2] * p[2];
      const uint64_t mm = (uint64_t)mu[0] * mu[0] + (uint64_t)mu[1] * mu[1] + (uint64_t)mu[2] * mu[2];
      /* dot, pp, mm < 2^18: dot^2 * 2^24 < 2^60 and c2 * pp * mm <= 2^24 * 2^36 = 2^60. */
      const uint64_t dot16 = dot << 16;
      const unsigned hue = (dot * dot << 24) >= c2 * pp * mm, above = dot16 >= glo * mm;
      const unsigned is_shadow = hue & above & (dot16 <= ghi * mm);
      out[i] = (uint8_t)(is_shadow - 1u); /* shadow -> 0 (background, or a candidate), else 0xFF */
      band++;
      /* below the gain bound with the background's hue: foreground itself, but in the windows' fits
       * (VC_CAND_DARK), so that they see the sample untruncated by eq. 2's per-pixel gain bound */
      const unsigned dark = hue & (above ^ 1u);
      if (cand != NULL && (is_shadow | dark)) {
        const uint32_t l = (uint32_t)p[0] + p[1] + p[2], lmu = (uint32_t)mu[0] + mu[1] + mu[2];
        /* the lanes in the order of enum VC_S_*: N, PP, PM, MM, L, LM, MML, X */
        cand[k].t = (vc_sums){1, (uint32_t)pp, (uint32_t)dot, (uint32_t)mm,
                              l, l * lmu,      lmu * lmu,     (uint32_t)i | (dark << 31)};
        k++;
      } else {
        k += (int)is_shadow; /* counted as shadows when the texture test is off */
      }
    }
  }
  *band_count += band;
  return k;
}

/* Adds or removes a row's candidates to the column sums: colsum[x + r] holds, for column x, the
 * sums of the terms (enum VC_S_*) over the candidates of the rows in the texture window (< 5 * 765^2
 * < 2^22 each). The r columns of zeros on either side make the window's horizontal sum
 * branch-free at the image's edges. */
static void colsum_update(vc_sums* colsum, const struct vc_cand* cand, int count, bool add) {
  if (add)
    for (int k = 0; k < count; k++)
      colsum[(cand[k].t[VC_S_X] & ~VC_CAND_DARK) + VC_TEXTURE_RADIUS] += cand[k].t;
  else
    for (int k = 0; k < count; k++)
      colsum[(cand[k].t[VC_S_X] & ~VC_CAND_DARK) + VC_TEXTURE_RADIUS] -= cand[k].t;
}

/* The flat-patch test of a window's sums s (enum VC_S_*, n >= 1 candidates, v the noise as in
 * texture_row), on the luminance L = p_0 + p_1 + p_2 (its noise variance is v, the sum of the
 * channels'): whether a flat patch (L = b, the window's mean) explains the candidates' luminance
 * better than the background's, scaled (L = a * Lmu), by more than the margin (Q8.8 noise variances
 * per pixel):
 *     E_flat - E_gain > margin * n * v,   E_flat = SL^2 / n,   E_gain = SLM^2 / SMML
 * (both are the energy the model explains, so their difference is the gain model's residual minus
 * the flat model's; one parameter each). A shadow over a floor with any texture is a scaled copy of
 * it, E_gain wins; skin or cloth over it is smoother than the floor's texture, E_flat wins; over a
 * flat background the two agree within the noise and the margin keeps it a shadow. Exact in 128 bits
 * (SMML = 0 taken as 1: then SLM = 0 too; SL < 2^15, SLM, SMML < 2^24, so both products < 2^54):
 *     (SL^2 * SMML - n * SLM^2) * 2^24 > margin_q8 * n^2 * v_q16 * SMML */
static unsigned flat_beats_texture(const vc_sums* s, uint64_t v, uint64_t margin_q8) {
  typedef unsigned __int128 u128;
  const uint64_t n = (*s)[VC_S_N], sl = (*s)[VC_S_L], slm = (*s)[VC_S_LM];
  const uint64_t smml = (*s)[VC_S_MML] != 0 ? (*s)[VC_S_MML] : 1;
  return ((u128)(sl * sl * smml) << 24) >
         ((u128)(slm * slm * n) << 24) + (u128)(margin_q8 * n * n * v) * smml;
}

/* The texture tests for the candidates of row t (their list from shadow_row), with colsum holding
 * rows t - r .. t + r. First (k2 != 0): over the (2r+1)^2 window, the candidates' frame colours P
 * (each channel of each pixel: 3n values) must be one scaled copy of the background's M (through
 * the origin: P = a*M, a = sum PM / sum MM) up to the noise:
 *     SS = sum PP - (sum PM)^2 / sum MM  <=  k^2 * n * sum_c max(sigma_c, floor)^2
 * (n candidates in the window, sigma of the candidate at the centre: the window's noise is taken as
 * its own), i.e. (sum PP * sum MM - (sum PM)^2) * 2^24 <= k2_q8 * n * V_q16 * sum MM, in 128-bit
 * integers: P, M <= 255 and 3n <= 75 values, so the sums are < 2^23, their products < 2^46,
 * n * V_q16 < 2^38 and k2_q8 <= 2^16. One scale for all channels makes the test see both the
 * background's texture (missing under skin over wood grain) and a colour bias that is below the
 * per-pixel angle but consistent over the window. Second (flat_q8 != 0), for those that pass: the
 * flat-patch test (flat_beats_texture): a texture the noise hides from the first test still tells
 * a shadow, which copies it, from a body, which is smoother than it. With fewer than
 * VC_TEXTURE_MIN_PIXELS candidates in the window the per-pixel tests decide (shadow). A candidate
 * that fails becomes foreground. Returns the number of shadows. */
static uint32_t texture_row(const vc_bgmodel* m, uint8_t* out, const uint16_t* sigma_row,
                            const struct vc_cand* cand, int count) {
  const uint64_t k2 = m->k2_q8, fl = m->floor_q8, flat = m->flat_q8;
  const vc_sums* colsum = m->colsum;
  uint32_t shadow = 0, last = UINT32_MAX - 1;
  vc_sums s = {0}; /* the window sums of the previous candidate (slid when x follows it) */
  for (int k = 0; k < count; k++) {
    if (cand[k].t[VC_S_X] & VC_CAND_DARK) continue; /* in the fits, not tested: foreground already */
    const uint32_t x = cand[k].t[VC_S_X];
    if (x == last + 1) /* the window one column on: add column x + r, drop column x - r - 1 */
      s += colsum[x + 4] - colsum[x - 1];
    else /* columns x - r .. x + r: colsum[x] .. colsum[x + 2r] */
      s = colsum[x] + colsum[x + 1] + colsum[x + 2] + colsum[x + 3] + colsum[x + 4];
    last = x;
    const uint64_t n = s[VC_S_N];
    unsigned is_shadow = 1;
    if (n >= VC_TEXTURE_MIN_PIXELS) {
      uint64_t v = 0; /* the noise: sum_c max(sigma_c, floor)^2 of the candidate (Q16.16) */
      for (uint32_t ch = 0; ch < 3; ch++) {
        const uint64_t sg = sigma_row[3 * x + ch] > fl ? sigma_row[3 * x + ch] : fl;
        v += sg * sg;
      }
      const uint64_t spp = s[VC_S_PP], spm = s[VC_S_PM], smm = s[VC_S_MM];
      if (k2 != 0) {
        const unsigned __int128 lhs = (unsigned __int128)(spp * smm - spm * spm) << 24;
        is_shadow = lhs <= (unsigned __int128)(k2 * n * v) * smm;
      }
      if (is_shadow && flat != 0) is_shadow = !flat_beats_texture(&s, v, flat);
    }
    out[x] = (uint8_t)(is_shadow - 1u);
    shadow += is_shadow;
  }
  return shadow;
}

/* ---- the limb-scale cue (bgmodel.h: grow_px, grow_sigma) ---------------------------------------- */

/* The mask's mark while the cue runs: queued, to be tested (a pixel that fails goes back to 0, one
 * that passes becomes VC_MASK_GROWN at once; the first ring is found before any is marked). */
enum { VC_GROW_QUEUED = 1 };

/* Whether background pixel i (pixel index; px its colour) is weak: eq. 1's background in every
 * channel (not a shadow verdict of the band: p >= blo) and |p - mu|^2 >= grow_sigma^2 * sum_c s_c^2
 * (s_c floored sigma, Q8.8): d2 * 2^24 >= grow_q8 * v_q16, d2 < 2^18, v < 2^34, grow_q8 <= 2^16, as
 * d2 >= grow_d2[i], the least such d2 that set_params computed; or in the band over a flat
 * background (grow_flat: VC_GROW_FLAT in grow_d2[i], mark_flat_background). */
static unsigned grow_weak(const vc_bgmodel* m, const uint8_t* px, size_t i) {
  const uint8_t *mu = m->mean + 3 * i, *blo = m->blo + 3 * i;
  const int d0 = (int)px[0] - mu[0], d1 = (int)px[1] - mu[1], d2 = (int)px[2] - mu[2];
  const unsigned in_band = (px[0] < blo[0]) | (px[1] < blo[1]) | (px[2] < blo[2]);
  const uint32_t g = m->grow_d2[i];
  /* in the band: weak only over a flat background (grow_flat); else off the background enough */
  return in_band ? g >> 31 : (uint32_t)(d0 * d0 + d1 * d1 + d2 * d2) >= (g & ~VC_GROW_FLAT);
}

/* Queues the first ring: background pixels with at least 2 foreground pixels among their 8
 * neighbours (an edge of a region, not a lone speckle: a straight edge gives 3, a convex corner 2, a
 * speckle's neighbour 1), marking them queued. Works on the rows' foreground bits (`fg`: exactly the
 * mask's 0xFF pixels, 64 a word, `stride` words a row, with a zero word before and after each row
 * and a zero row above and below the image), from rows whose 3-row neighbourhood has foreground:
 * the 8 neighbours' bits are shifts of the 3 rows' words, "at least two" two bitwise accumulators.
 * Returns the count. */
static size_t grow_ring1(uint8_t* mk, const uint64_t* fg, size_t stride, uint8_t* row_any, int16_t* span,
                         int w, int h, uint32_t* q) {
  const int words = (w + 63) / 64;
  const uint64_t last = w % 64 ? ~0ull >> (64 - w % 64) : ~0ull; /* the last word's pixels */
  size_t n = 0;
  row_any[0] = row_any[h + 1] = 0; /* the zero rows; the image's rows come from the clean-up */
  /* Each row's first and last word with foreground (span[2r], span[2r+1]), so that a row's scan
   * covers only the words its 3-row neighbourhood's foreground reaches (and the 4-neighbours of its
   * own). */
  for (int r = 0; r < h + 2; r++) {
    int16_t lo = (int16_t)words, hi = -1;
    if (row_any[r]) {
      const uint64_t* c = fg + (size_t)r * stride + 1;
      while (c[lo - 1] == 0) lo--; /* from the right: the last non-zero word */
      hi = (int16_t)(lo - 1);
      lo = 0;
      while (c[lo] == 0) lo++;
    }
    span[2 * r] = lo;
    span[2 * r + 1] = hi;
  }
  for (int y = 0; y < h; y++) {
    if (!(row_any[y] | row_any[y + 1] | row_any[y + 2])) continue;
    int lo = span[2 * y], hi = span[2 * y + 1];
    for (int r = y + 1; r <= y + 2; r++) {
      lo = span[2 * r] < lo ? span[2 * r] : lo;
      hi = span[2 * r + 1] > hi ? span[2 * r + 1] : hi;
    }
    const uint64_t* c = fg + (size_t)(y + 1) * stride + 1;
    /* the word before (after) the span holds seeds only when the row's own first (last) pixel of the
     * span is foreground: the rows above and below have nothing there */
    const int w0 = lo > 0 && (c[lo] & 1u) ? lo - 1 : lo, w1 = hi + 1 < words && (c[hi] >> 63) ? hi + 1 : hi;
    const uint64_t *u = c - stride, *d = c + stride;
    /* the words before w0: the guard word when w0 is 0 */
    uint64_t cp = c[w0 - 1], cc = c[w0];
    for (int wi = w0; wi <= w1; wi++) {
      const uint64_t cn = c[wi + 1], uc = u[wi], dc = d[wi]; /* c[words]: the guard word after the row, 0 */
      if (cc != ~0ull && (uc | cc | dc | (cp >> 63) | (cn << 63)) != 0) {
        const uint64_t near = uc | dc | (cc << 1) | (cp >> 63) | (cc >> 1) | (cn << 63); /* 4-neighbours */
        uint64_t front = near & ~cc & (wi + 1 < words ? ~0ull : last);
        for (; front != 0; front &= front - 1) {
          const size_t i = (size_t)y * (size_t)w + (size_t)wi * 64 + (size_t)__builtin_ctzll(front);
          mk[i] = VC_GROW_QUEUED;
          q[n++] = (uint32_t)i;
        }
      }
      cp = cc, cc = cn;
    }
  }
  return n;
}

/* The cue over a finished mask: ring 1 from the scan, then up to grow_px rings of breadth-first
 * search through weak pixels (4-connected), then the marks back to 0 / VC_MASK_GROWN. A pixel the
 * subtraction called foreground and the clean-up took away (m->raw) passes as weak when it is part of
 * a structure of two or more such pixels (raw_joined): the filter is there for speckles apart from the
 * body, so this gives back the thin parts it cut off the body (a reconstruction of the clean mask
 * within the subtraction's, grow_px steps deep, on the weak pixels' path). Returns the pixels grown. */
/* Whether pixel i, which the subtraction called foreground (m->raw) and the clean-up took away, is part
 * of a structure the filter cut off: another such pixel (foreground in m->raw, not in the clean mask)
 * among its 8 neighbours, as in a finger or a wrist 1-2 pixels wide. A lone one beside the clean
 * outline is what the filter is there for (the subtraction's specks where a floor shadow meets the
 * feet look the same as an outline's) and stays removed. */
static unsigned raw_joined(const vc_bgmodel* m, const uint8_t* mk, uint32_t i) {
  const int w = m->width, h = m->height, y = (int)(i / (uint32_t)w), x = (int)(i - (uint32_t)y * (uint32_t)w);
  for (int yy = y > 0 ? y - 1 : 0; yy <= y + 1 && yy < h; yy++)
    for (int xx = x > 0 ? x - 1 : 0; xx <= x + 1 && xx < w; xx++) {
      const size_t j = (size_t)yy * (size_t)w + (size_t)xx;
      if (j != i && m->raw[j] != 0 && mk[j] != VC_MASK_FG) return 1;
    }
  return 0;
}

static uint32_t grow_mask(const vc_bgmodel* m, const uint8_t* rgb, size_t stride, uint8_t* mk) {
  const int w = m->width, h = m->height;
  const bool packed = stride == 3 * (size_t)w; /* pixel i at rgb + 3 i, no division to find its row */
  uint32_t* q = m->queue;
  size_t n = grow_ring1(mk, m->fgbits, vc_fg_stride(w), m->row_any, m->span, w, h, q), head = 0;
  uint32_t grown = 0;
  for (int ring = 1; ring <= m->grow_px && head < n; ring++) {
    const size_t end = n;
    for (; head < end; head++) {
      const uint32_t i = q[head];
      const uint8_t* px = packed ? rgb + 3 * (size_t)i
                                 : rgb + (size_t)(i / (uint32_t)w) * stride + 3 * (size_t)(i % (uint32_t)w);
      /* a failed pixel is unmarked at once: a later ring may queue it again, and it fails again */
      if (!(m->raw[i] && raw_joined(m, mk, i)) && !grow_weak(m, px, i)) {
        mk[i] = 0;
        continue;
      }
      mk[i] = VC_MASK_GROWN;
      grown++;
      if (ring == m->grow_px) continue;
      const int y = (int)(i / (uint32_t)w), x = (int)(i - (uint32_t)y * (uint32_t)w);
      const uint32_t nb[4] = {i - 1, i + 1, i - (uint32_t)w, i + (uint32_t)w};
      const unsigned ok[4] = {x > 0, x<w - 1, y> 0, y < h - 1};
      for (int k = 0; k < 4; k++)
        if (ok[k] && mk[nb[k]] == 0) {
          mk[nb[k]] = VC_GROW_QUEUED;
          q[n++] = nb[k];
        }
    }
  }
  for (; head < n; head++) mk[q[head]] = 0; /* queued beyond the last ring, never tested */
  return grown;
}

int vc_subtract(const vc_bgmodel* m, const uint8_t* rgb, size_t stride, uint8_t* mask,
                vc_subtract_stats* stats) {
  if (m == NULL || rgb == NULL || mask == NULL || stride < (size_t)m->width * 3) return -EINVAL;
  if (!m->ready) return -EAGAIN;
  int (*classify)(const uint8_t* restrict, const uint8_t* restrict, const uint8_t* restrict,
                  const uint8_t* restrict, uint8_t* restrict, uint64_t* restrict, int) = classify_row_generic;
#if VC_HAVE_AVX2_VARIANT
  if (vc__use_avx2()) classify = classify_row_avx2;
#endif
#if VC_HAVE_NEON_VARIANT
  if (vc__use_neon()) classify = classify_row_neon;
#endif
  const int w = m->width, h = m->height, r = VC_TEXTURE_RADIUS, rows = 2 * VC_TEXTURE_RADIUS + 1;
  const size_t row = (size_t)w * 3;
  const bool texture = m->k2_q8 != 0 || m->flat_q8 != 0;
  uint64_t bits[VC_MAX_DIM / 64] = {0}; /* the band pixels of the row in pass A and B; pass A
                                         * writes the words of the row, zeroed for the analyser */
  uint32_t band = 0, shadow = 0;
  int count[2 * VC_TEXTURE_RADIUS + 1] = {0}; /* candidates of row y in cand slot y mod rows */
  if (texture) memset(m->colsum, 0, (size_t)(w + 2 * r) * sizeof(*m->colsum));
  /* Passes A and B run r rows ahead of the texture test, which needs the candidates of rows
   * t - r .. t + r in the column sums; row t - r leaves them after row t's test. */
  for (int y = 0; y < h + (texture ? r : 0); y++) {
    if (y < h) {
      const uint8_t* px = rgb + (size_t)y * stride;
      const size_t off = (size_t)y * row;
      uint8_t* out = mask + (size_t)y * (size_t)w;
      struct vc_cand* cand = texture ? m->cand + (size_t)(y % rows) * (size_t)w : NULL;
      int k = 0;
      if (classify(px, m->blo + off, m->flo + off, m->fhi + off, out, bits, w))
        k = shadow_row(m, px, m->mean + off, out, bits, w, cand, &band);
      if (!texture) {
        shadow += (uint32_t)k;
        continue;
      }
      count[y % rows] = k;
      colsum_update(m->colsum, cand, k, true);
    }
    const int t = y - r;
    if (t < 0) continue;
    const struct vc_cand* cand_t = m->cand + (size_t)(t % rows) * (size_t)w;
    shadow +=
        texture_row(m, mask + (size_t)t * (size_t)w, m->sigma_q8 + (size_t)t * row, cand_t, count[t % rows]);
    const int gone = t - r; /* the windows of rows after t no longer reach row t - r */
    if (gone >= 0) {
      colsum_update(m->colsum, m->cand + (size_t)(gone % rows) * (size_t)w, count[gone % rows], false);
      count[gone % rows] = 0;
    }
  }
  if (stats != NULL) {
    stats->band = band;
    stats->shadow = shadow;
    stats->grown = 0;
  }
  return 0;
}

int vc_cleanup_grow(const vc_bgmodel* m, const uint8_t* rgb, size_t stride, uint8_t* mask, int radius,
                    uint8_t* scratch, size_t scratch_len, uint32_t* grown) {
  if (grown != NULL) *grown = 0;
  if (m == NULL || rgb == NULL || mask == NULL || stride < (size_t)m->width * 3) return -EINVAL;
  if (!m->ready) return -EAGAIN;
  const int w = m->width, h = m->height;
  const bool grow = m->grow_px > 0 && w > 2 && h > 2;
  const size_t fgs = vc_fg_stride(w);
  const int rc =
      vc__cleanup_radius_bits(mask, w, h, radius, scratch, scratch_len, grow ? m->fgbits + fgs + 1 : NULL,
                              fgs, grow ? m->row_any + 1 : NULL, grow ? m->raw : NULL);
  if (rc < 0 || !grow) return rc;
  const uint32_t n = grow_mask(m, rgb, stride, mask);
  if (grown != NULL) *grown = n;
  return 0;
}

int vc_mask_frame(const vc_bgmodel* m, const uint8_t* rgb, size_t stride, uint8_t* mask, int radius,
                  uint8_t* scratch, size_t scratch_len, vc_subtract_stats* stats) {
  int rc = vc_subtract(m, rgb, stride, mask, stats);
  if (rc < 0) return rc;
  uint32_t grown = 0;
  rc = vc_cleanup_grow(m, rgb, stride, mask, radius, scratch, scratch_len, &grown);
  if (stats != NULL) stats->grown = grown;
  return rc;
}

void vc_mask_ungrown(const uint8_t* mask, size_t len, uint8_t* out) {
  for (size_t i = 0; i < len; i++) out[i] = (uint8_t)(0u - (unsigned)(mask[i] == VC_MASK_FG));
}
