/* Background model and shadow-aware subtraction (paper section 5, eq. 1 and 2), in integers.
 *
 * Learning sums each channel and its square per pixel (uint32: exact for up to 65535 frames); finish()
 * turns them into an 8-bit mean image and a Q8.8 standard deviation image (sample deviation, n-1).
 * set_params() then precomputes, per pixel and channel, the two integer thresholds the frame loop
 * needs: since p and mu are integers, d > x  <=>  d > floor(x)  and  d >= x  <=>  d > ceil(x) - 1, so
 * eq. 1 and the lower threshold become exact byte comparisons (tu, tl below), with no rounding
 * difference to a float implementation.
 *
 * The rule (bgmodel.h has it in full). A shadow only darkens, by a bounded ratio, keeps the
 * background's colour direction and keeps its texture. With T_u = 60 sigma (deep floor shadows must
 * reach the shadow test) nearly every darker body pixel lands in the band, and the per-pixel colour
 * angle cannot tell skin (222,170,138) over oak (160,114,74), ~6 degrees apart, or the shirt over
 * the blue painting (~1.7 degrees) from a shadow; what a shadow shows and a body does not is the
 * background's texture, scaled. Hence:
 *  A. vectorised, byte-wise over the interleaved RGB row: up = sat(p - mu), dn = sat(mu - p);
 *     code = 0xFF if up > tl (brighter than the noise: shadow_max_gain <= 1) or dn > tu (darker than
 *     the deepest shadow: tu = min(floor(T_u sigma), floor((1 - g_lo) mu + T_l sigma))), 1 if
 *     dn > tl, else 0; a pixel's class is the OR of its three channel codes (0 = background, 1 = in
 *     the band, 0xFF = foreground). Branch-free; the compiler vectorises it.
 *  B. the band pixels only (typically a few percent: shadows and darker body parts) get eq. 2 in
 *     64-bit integers: with dot = p.mu, pp = |p|^2, mm = |mu|^2 (exact integers < 2^18),
 *        candidate  <=>  dot^2 * 2^24 >= c2 * pp * mm              (c2 = cos^2(T_angular) in Q0.24)
 *                   and  g_lo * mm <= dot * 2^16 <= g_hi * mm     (alpha = dot/mm, gains in Q16.16)
 *     the others are foreground. With the texture test off a candidate is background (shadow).
 *  C. the texture test (texture_row): a candidate is shadow only when the candidates of its 5x5
 *     window, fitted as one scaled copy of the background (P = a * M over all their channels), leave
 *     a residual within k noise sigmas. Lit floor next to a shadow is background in pass A and
 *     outside the fit, so shadow edges pass; body pixels that failed eq. 2 are outside it too.
 *     Passes A and B run 2 rows ahead of C and the mask rows themselves hold the in-flight codes;
 *     pass B keeps each candidate's |p|^2, p.mu and |mu|^2 (which eq. 2 computes anyway) in a
 *     5-row ring in the model (12 bytes per pixel per row: 38 KB at 640 wide, allocated once by
 *     set_params; no allocation per frame). C only visits rows with candidates; its window sums
 *     are exact integers (64-bit, the last comparison 128-bit), built from column sums that a run
 *     of candidates shares (each column summed once per run, not once per window).
 * Model data per pixel for pass A: mean, tu, tl = 9 bytes, planar by role, interleaved by channel
 * like the image, so that pass A is three aligned streams of bytes. Memory traffic dominates: at
 * 640x480 a frame reads 0.9 MB of pixels and 2.8 MB of model (plus sigma near candidates).
 * Limits: sigma is clamped to 255.99 (Q8.8); thresholds at or above 255 never fire.
 */
#include "voxcap/edge/bgmodel.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "dispatch.h"
#include "voxcap/why.h"

#define VC_MAX_DIM 16384
#define VC_MAX_FRAMES 65535
#define VC_CHUNK 256            /* pixels per pass-A chunk: the code buffer stays in L1 */
#define VC_TEXTURE_RADIUS 2     /* the texture test's window is (2r+1)^2 pixels */
#define VC_TEXTURE_MIN_PIXELS 3 /* fewer candidates in the window: the per-pixel tests decide */
/* Mask codes while a frame is in flight (the mask rows are the texture test's ring of codes). */
#define VC_CODE_CANDIDATE 0x02u  /* passed the per-pixel shadow tests, texture test pending */
#define VC_CODE_SHADOW 0x42u     /* candidate, decided shadow (background) */
#define VC_CODE_FOREGROUND 0x82u /* candidate, decided foreground */

struct vc_bgmodel {
  int width, height;
  int frames;
  bool finished, ready;
  uint32_t* sum;      /* [3*w*h] sum of samples, while learning */
  uint32_t* sumsq;    /* [3*w*h] sum of squared samples, while learning */
  uint8_t* mean;      /* [3*w*h] rounded mean, grey levels */
  uint16_t* sigma_q8; /* [3*w*h] Q8.8 standard deviation, grey levels */
  uint8_t* tu;        /* [3*w*h] min(floor(T_u*sigma), floor((1-g_lo)*mu + T_l*sigma)), clamped to 255:
                       * foreground when mu - p > tu (darker than the deepest shadow) */
  uint8_t* tl;        /* [3*w*h] ceil(T_l*sigma)-1 clamped to 255: band when mu - p > tl, foreground
                       * when p - mu > tl (shadows only darken) */
  uint64_t c2_q24;    /* Q0.24 cos^2(T_angular) */
  uint64_t glo_q16;   /* Q16.16 lowest brightness ratio of a shadow */
  uint64_t ghi_q16;   /* Q16.16 highest brightness ratio of a shadow */
  uint64_t k2_q8;     /* Q8.8 k^2 of the texture test; 0 = test off */
  uint16_t floor_q8;  /* Q8.8 sigma floor (rounded), grey levels: the texture test's noise floor */
  uint32_t* terms;    /* [5][w][3] scratch of vc_subtract: |p|^2, p.mu, |mu|^2 of each candidate as
                       * pass B computed them, for row y in slot y mod 5 (the texture window's rows) */
};

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
  free(m->tu);
  free(m->tl);
  free(m->terms);
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

int vc_bgmodel_set_params(vc_bgmodel* m, const vc_subtract_params* p) {
  if (m == NULL || vc_subtract_params_check(p, NULL, 0) != 0) return -EINVAL;
  if (!m->finished) return -EAGAIN;
  const size_t n = (size_t)m->width * (size_t)m->height * 3;
  if (m->tu == NULL) m->tu = malloc(n);
  if (m->tl == NULL) m->tl = malloc(n);
  if (m->tu == NULL || m->tl == NULL) return -ENOMEM;
  const uint16_t floor_q8 = (uint16_t)llround(p->sigma_floor * 256.0);
  for (size_t i = 0; i < n; i++) {
    double sigma = fmax((double)m->sigma_q8[i] / 256.0, p->sigma_floor);
    double up =
        fmin(floor(p->t_upper * sigma), floor((1.0 - p->shadow_min_gain) * m->mean[i] + p->t_lower * sigma));
    double lo = ceil(p->t_lower * sigma) - 1.0;
    m->tu[i] = (uint8_t)(up > 255.0 ? 255.0 : up);
    m->tl[i] = (uint8_t)(lo > 255.0 ? 255.0 : lo);
  }
  m->floor_q8 = floor_q8;
  m->k2_q8 = (uint64_t)llround(p->shadow_texture_k * p->shadow_texture_k * 256.0);
  if (m->k2_q8 != 0 && m->terms == NULL) {
    m->terms = malloc((size_t)(2 * VC_TEXTURE_RADIUS + 1) * (size_t)m->width * 3 * sizeof(*m->terms));
    if (m->terms == NULL) {
      m->ready = false;
      return -ENOMEM;
    }
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

/* Pass A over one row: out[i] = 0 (background), 1 (band: darker than the noise) or 0xFF (foreground:
 * brighter than the noise in some channel, or darker than the deepest shadow). Written as min/max
 * byte arithmetic so that gcc and clang both vectorise the first loop; the second loop folds the
 * three channel codes of each pixel (a stride-3 gather, vectorised where the ISA has byte shuffles). */
VC_HOT uint64_t classify_row_body(const uint8_t* restrict px, const uint8_t* restrict mean,
                                  const uint8_t* restrict tu, const uint8_t* restrict tl,
                                  uint8_t* restrict out, int n) {
  uint8_t code[3 * VC_CHUNK];
  uint64_t chunks = 0; /* bit c: chunk c (pixels c*VC_CHUNK...) has a band pixel (value 1) */
  for (int x0 = 0; x0 < n; x0 += VC_CHUNK) {
    uint8_t any_band = 0;
    const int len = n - x0 < VC_CHUNK ? n - x0 : VC_CHUNK;
    const int nb = 3 * len;
    const uint8_t* restrict p = px + 3 * x0;
    const uint8_t* restrict mu = mean + 3 * x0;
    const uint8_t* restrict u = tu + 3 * x0;
    const uint8_t* restrict l = tl + 3 * x0;
    for (int b = 0; b < nb; b++) {
      uint8_t up = (uint8_t)(p[b] - u8min(p[b], mu[b]));  /* saturated p - mu */
      uint8_t dn = (uint8_t)(mu[b] - u8min(p[b], mu[b])); /* saturated mu - p */
      uint8_t band = (uint8_t)(dn - u8min(dn, l[b]));     /* > 0 iff mu - p > tl */
      uint8_t fg =
          (uint8_t)((up - u8min(up, l[b])) | (dn - u8min(dn, u[b]))); /* p - mu > tl or mu - p > tu */
      code[b] = (uint8_t)(u8min(band, 1) | (uint8_t)(0u - u8min(fg, 1)));
    }
    uint8_t* restrict o = out + x0;
    for (int i = 0; i < len; i++) {
      uint8_t v = (uint8_t)(code[3 * i] | code[3 * i + 1] | code[3 * i + 2]);
      o[i] = v;
      any_band |= (uint8_t)(v & (uint8_t) ~(v >> 1) & 1u); /* 1 only for the band value 0x01 */
    }
    chunks |= (uint64_t)any_band << (x0 / VC_CHUNK);
  }
  return chunks;
}

static uint64_t classify_row_generic(const uint8_t* restrict px, const uint8_t* restrict mean,
                                     const uint8_t* restrict tu, const uint8_t* restrict tl,
                                     uint8_t* restrict out, int n) {
  return classify_row_body(px, mean, tu, tl, out, n);
}

#if VC_HAVE_AVX2_VARIANT
VC_TARGET_AVX2 static uint64_t classify_row_avx2(const uint8_t* restrict px, const uint8_t* restrict mean,
                                                 const uint8_t* restrict tu, const uint8_t* restrict tl,
                                                 uint8_t* restrict out, int n) {
  return classify_row_body(px, mean, tu, tl, out, n);
}
#endif

/* Pass B: eq. 2 for the band pixels of one row (out[i] == 1), in the chunks pass A marked. Those
 * are scanned 8 bytes at a time;
 * a band byte (0x01) is the only value whose bit 0 differs from its bit 1 (0x00 and 0xFF do not), so
 * (w ^ w >> 1) & 0x01..01 marks them, and count-trailing-zeros walks the marks without a branch per
 * pixel. Words without band pixels (the vast majority) cost a load and a test. */
static bool shadow_row(const vc_bgmodel* m, const uint8_t* px, const uint8_t* mean, uint8_t* out, int n,
                       uint64_t chunks, uint32_t* terms, int span[2], vc_subtract_stats* stats) {
  int lo = n, hi = -1; /* the first and last candidate */
  const uint64_t lsb = 0x0101010101010101ull;
  /* A pixel that passes: background (0) when it is final, a texture candidate (0x02) when not. */
  const unsigned pass_code = m->k2_q8 != 0 ? VC_CODE_CANDIDATE : 0u;
  uint32_t band = 0, shadow = 0;
  const uint64_t c2 = m->c2_q24, glo = m->glo_q16, ghi = m->ghi_q16;
  for (; chunks != 0; chunks &= chunks - 1) { /* only the chunks pass A found band pixels in */
    const int c0 = __builtin_ctzll(chunks) * VC_CHUNK, c1 = c0 + VC_CHUNK < n ? c0 + VC_CHUNK : n;
    for (int x0 = c0; x0 < c1; x0 += 8) {
      uint64_t w = 0;
      if (n - x0 >= 8)
        memcpy(&w, out + x0, 8); /* a constant size: one load */
      else
        memcpy(&w, out + x0, (size_t)(n - x0));
      uint64_t marks = (w ^ (w >> 1)) & lsb;
      while (marks != 0) {
        int i = x0 + (__builtin_ctzll(marks) >> 3);
        marks &= marks - 1;
        const uint8_t *p = px + 3 * i, *mu = mean + 3 * i;
        uint64_t dot = (uint64_t)p[0] * mu[0] + (uint64_t)p[1] * mu[1] + (uint64_t)p[2] * mu[2];
        uint64_t pp = (uint64_t)p[0] * p[0] + (uint64_t)p[1] * p[1] + (uint64_t)p[2] * p[2];
        uint64_t mm = (uint64_t)mu[0] * mu[0] + (uint64_t)mu[1] * mu[1] + (uint64_t)mu[2] * mu[2];
        /* dot, pp, mm < 2^18: dot^2 * 2^24 < 2^60 and c2 * pp * mm <= 2^24 * 2^36 = 2^60. */
        uint64_t dot16 = dot << 16;
        unsigned is_shadow = ((dot * dot << 24) >= c2 * pp * mm) & (dot16 >= glo * mm) & (dot16 <= ghi * mm);
        out[i] = (uint8_t)(is_shadow ? pass_code : 0xFFu); /* shadow -> 0 or a candidate, else 0xFF */
        if (terms != NULL) {                               /* < 2^18 each */
          terms[3 * i] = (uint32_t)pp;
          terms[3 * i + 1] = (uint32_t)dot;
          terms[3 * i + 2] = (uint32_t)mm;
        }
        band++;
        shadow += is_shadow;
        if (is_shadow) {
          lo = i < lo ? i : lo;
          hi = i;
        }
      }
    }
  }
  if (span != NULL) {
    span[0] = lo;
    span[1] = hi;
  }
  if (stats != NULL) {
    stats->band += band;
    if (pass_code == 0) stats->shadow += shadow; /* else counted by texture_row */
  }
  return shadow != 0;
}

/* The texture test for the candidates of row t (codes 0x02 from shadow_row): over the (2r+1)^2
 * window, the candidates' frame colours P (each channel of each pixel: 3n values) must be one scaled
 * copy of the background's M (through the origin: P = a*M, a = sum PM / sum MM) up to the noise:
 *     SS = sum PP - (sum PM)^2 / sum MM  <=  k^2 * n * sum_c max(sigma_c, floor)^2
 * (n candidates in the window, sigma of the candidate at the centre: the window's noise is taken as
 * its own), i.e. (sum PP * sum MM - (sum PM)^2) * 2^24 <= k2_q8 * n * V_q16 * sum MM, in 128-bit
 * integers: P, M <= 255 and 3n <= 75 values, so the sums are < 2^23, their products < 2^46,
 * n * V_q16 < 2^38 and k2_q8 <= 2^16. One scale for all channels makes the test see both the background's
 * texture (missing under skin over wood grain) and a colour bias that is below the per-pixel angle but
 * consistent over the window. With fewer than VC_TEXTURE_MIN_PIXELS candidates in the window the
 * per-pixel tests decide. The decision is written as 0x42 (shadow) or 0x82 (foreground): the low
 * bits still say "candidate" for the windows of the rows below; finish_row() turns them into
 * 0 / 0xFF once no window needs them. */
/* Sums of one window column (rows y0..y1 of column x): the candidates' count and sum PP, PM, MM. */
typedef struct {
  uint32_t n, pp, pm, mm; /* < 5 * 3 * 255^2 < 2^20 */
} col_sums;

static col_sums column_sums(const vc_bgmodel* m, const uint8_t* mask, int x, int y0, int y1) {
  col_sums cs = {0, 0, 0, 0};
  const size_t w = (size_t)m->width;
  for (int y = y0; y <= y1; y++) {
    if ((mask[(size_t)y * w + (size_t)x] & 0x3F) != VC_CODE_CANDIDATE) continue;
    const uint32_t* t = m->terms + ((size_t)(y % (2 * VC_TEXTURE_RADIUS + 1)) * w + (size_t)x) * 3;
    cs.n++;
    cs.pp += t[0];
    cs.pm += t[1];
    cs.mm += t[2];
  }
  return cs;
}

static uint32_t texture_row(const vc_bgmodel* m, uint8_t* mask, int t, int lo, int hi) {
  const int w = m->width, h = m->height, r = VC_TEXTURE_RADIUS;
  const int y0 = t - r < 0 ? 0 : t - r, y1 = t + r >= h ? h - 1 : t + r;
  const uint64_t lsb = 0x0101010101010101ull, k2 = m->k2_q8;
  const uint64_t fl = m->floor_q8;
  uint8_t* out = mask + (size_t)t * (size_t)w;
  const uint16_t* sigma_row = m->sigma_q8 + (size_t)t * (size_t)w * 3;
  /* Column sums of the columns last computed, by column mod 8 (a window spans 5): candidates come
   * left to right, so each column is summed once per run of nearby candidates, not once per window. */
  col_sums ring[8] = {{0, 0, 0, 0}}; /* every slot read was written first; zeroed for the analyser */
  int have_hi = -8;                  /* columns (have_lo..have_hi] are in the ring; -8: none */
  uint32_t shadow = 0;
  for (int x0 = lo & ~7; x0 <= hi; x0 += 8) { /* the candidates lie in [lo, hi] */
    uint64_t word = 0;
    if (w - x0 >= 8)
      memcpy(&word, out + x0, 8);
    else
      memcpy(&word, out + x0, (size_t)(w - x0));
    uint64_t marks = ((word >> 1) ^ word) & lsb; /* 0x02 is the only value here whose bits 0, 1 differ */
    while (marks != 0) {
      const int x = x0 + (__builtin_ctzll(marks) >> 3);
      marks &= marks - 1;
      const int xa = x - r < 0 ? 0 : x - r, xb = x + r >= w ? w - 1 : x + r;
      for (int xx = have_hi >= xa - 1 ? have_hi + 1 : xa; xx <= xb; xx++)
        ring[xx & 7] = column_sums(m, mask, xx, y0, y1);
      have_hi = xb;
      uint64_t n = 0, spp = 0, spm = 0, smm = 0;
      for (int xx = xa; xx <= xb; xx++) {
        n += ring[xx & 7].n;
        spp += ring[xx & 7].pp;
        spm += ring[xx & 7].pm;
        smm += ring[xx & 7].mm;
      }
      unsigned is_shadow = 1;
      if (n >= VC_TEXTURE_MIN_PIXELS) {
        /* The noise: n times the candidate's own sum_c max(sigma_c, floor)^2 (Q16.16). */
        uint64_t v = 0;
        for (int ch = 0; ch < 3; ch++) {
          const uint64_t sg = sigma_row[3 * x + ch] > fl ? sigma_row[3 * x + ch] : fl;
          v += sg * sg;
        }
        const unsigned __int128 lhs = (unsigned __int128)(spp * smm - spm * spm) << 24;
        is_shadow = lhs <= (unsigned __int128)(k2 * n * v) * smm;
      }
      out[x] = (uint8_t)(is_shadow ? VC_CODE_SHADOW : VC_CODE_FOREGROUND);
      shadow += is_shadow;
    }
  }
  return shadow;
}

/* Turns the decided candidates of a row's span into the mask's 0 / 0xFF. */
static void finish_row(uint8_t* out, int n) {
  for (int i = 0; i < n; i++) {
    const uint8_t v = out[i];
    out[i] = v == VC_CODE_SHADOW ? 0 : v == VC_CODE_FOREGROUND ? 0xFF : v;
  }
}

int vc_subtract(const vc_bgmodel* m, const uint8_t* rgb, size_t stride, uint8_t* mask,
                vc_subtract_stats* stats) {
  if (m == NULL || rgb == NULL || mask == NULL || stride < (size_t)m->width * 3) return -EINVAL;
  if (!m->ready) return -EAGAIN;
  uint64_t (*classify)(const uint8_t* restrict, const uint8_t* restrict, const uint8_t* restrict,
                       const uint8_t* restrict, uint8_t* restrict, int) = classify_row_generic;
#if VC_HAVE_AVX2_VARIANT
  if (vc__use_avx2()) classify = classify_row_avx2;
#endif
  if (stats != NULL) memset(stats, 0, sizeof(*stats));
  const int w = m->width, h = m->height, r = VC_TEXTURE_RADIUS;
  const size_t row = (size_t)w * 3;
  if (m->k2_q8 == 0) { /* texture test off: each row is final after its pass B */
    for (int y = 0; y < h; y++) {
      const uint8_t* px = rgb + (size_t)y * stride;
      const size_t off = (size_t)y * row;
      uint8_t* out = mask + (size_t)y * (size_t)w;
      const uint64_t chunks = classify(px, m->mean + off, m->tu + off, m->tl + off, out, w);
      if (chunks) (void)shadow_row(m, px, m->mean + off, out, w, chunks, NULL, NULL, stats);
    }
    return 0;
  }
  /* Pass A and B run r rows ahead of the texture test; a row is finished r rows after its test,
   * when no window needs its codes any more. Bit (y mod 32) of `cand` marks rows with candidates. */
  uint32_t cand = 0, shadow = 0;
  int span[32][2]; /* the candidates' first and last column, of row y in span[y mod 32] */
  for (int y = 0; y < h + 2 * r; y++) {
    if (y < h) {
      const uint8_t* px = rgb + (size_t)y * stride;
      const size_t off = (size_t)y * row;
      uint8_t* out = mask + (size_t)y * (size_t)w;
      const uint64_t chunks = classify(px, m->mean + off, m->tu + off, m->tl + off, out, w);
      const bool any =
          chunks != 0 && shadow_row(m, px, m->mean + off, out, w, chunks,
                                    m->terms + (size_t)(y % (2 * r + 1)) * row, span[y & 31], stats);
      cand = (cand & ~(1u << (y & 31))) | ((uint32_t)any << (y & 31));
    }
    const int t = y - r;
    if (t >= 0 && t < h && ((cand >> (t & 31)) & 1u))
      shadow += texture_row(m, mask, t, span[t & 31][0], span[t & 31][1]);
    const int f = y - 2 * r;
    if (f >= 0 && ((cand >> (f & 31)) & 1u))
      finish_row(mask + (size_t)f * (size_t)w + span[f & 31][0], span[f & 31][1] - span[f & 31][0] + 1);
  }
  if (stats != NULL) stats->shadow = shadow;
  return 0;
}
