/* Background model and shadow-aware background subtraction (the method's section 5, eq. 1 and 2).
 *
 * Lifecycle, per camera:  vc_bgmodel_new(w, h, &m, why, why_len)
 *                         vc_bgmodel_learn(m, frame) × n      (frames of the empty scene)
 *                         vc_bgmodel_finish(m)                (mean and standard deviation images)
 *                         vc_bgmodel_set_params(m, &params)   (thresholds from the host's CONFIG;
 *                                                              may be called again at any time)
 *                         vc_subtract(m, frame, mask)         (per frame: no allocation, no float)
 *                         vc_bgmodel_free(m)
 *
 * Pixels are interleaved RGB24 (uint8 R, G, B), rows `stride` bytes apart. Masks are uint8, one byte
 * per pixel, rows `width` bytes apart: 0 = background (including shadow), 255 = foreground
 * (VC_MASK_FG); after the limb-scale cue also 128 (VC_MASK_GROWN, below).
 *
 * Classification of pixel p against mean mu and standard deviation sigma (per channel c; sigma
 * raised to sigma_floor; g_lo, g_hi = shadow_min_gain, shadow_max_gain <= 1):
 *   foreground        if p_c - mu_c >= T_l * sigma_c for any channel (brighter: shadows only darken)
 *                     or mu_c - p_c > min(T_u * sigma_c, (1 - g_lo) mu_c + T_l * sigma_c) for any
 *                     channel (darker than the deepest shadow; eq. 1)
 *   background        if |p_c - mu_c| <  T_l * sigma_c  for every channel
 *   otherwise (band)  per-pixel shadow test: foreground iff cos^2(angle(p, mu)) < cos^2(T_angular)
 *                     (eq. 2) or the brightness ratio alpha = p.mu / |mu|^2 lies outside
 *                     [g_lo, g_hi]; the band pixels that pass are shadow candidates;
 *   texture test      (shadow_texture_k = k > 0) over the 5x5 window around a candidate, with the
 *                     window's candidates C (at least 3, else the per-pixel test decides; C also
 *                     holds the band pixels that failed only eq. 2's lower gain bound, alpha < g_lo
 *                     with the background's colour direction: foreground themselves, but a shadow
 *                     near g_lo has them by noise, and without them the window sees only the part
 *                     of a flat surface at about g_lo over the darker texture, a scaled copy): their
 *                     colours must be one scaled copy of the background's, P = a * mu, up to the noise:
 *                     shadow iff sum_C,c p^2 - (sum_C,c p mu)^2 / sum_C,c mu^2 <= k^2 |C| sum_c s_c^2,
 *                     s_c = max(sigma_c, sigma_floor) of the candidate itself, both in Q8.8 (the
 *                     floor rounded);
 *                     a shadow counts as background, a candidate that fails is foreground;
 *   flat-patch test   (shadow_flat_margin = t > 0) for the candidates that pass (or all, k = 0),
 *                     over the same window and candidates C (at least 3), on the luminance
 *                     L = p_0 + p_1 + p_2 and the background's Lmu = mu_0 + mu_1 + mu_2: a flat
 *                     patch (L = b) must not explain their luminance better than the background's
 *                     scaled (L = a * Lmu) by more than t noise variances per pixel: shadow iff
 *                     (sum_C L)^2 / |C| - (sum_C L Lmu)^2 / sum_C Lmu^2 <= t |C| sum_c s_c^2 (the
 *                     explained energies; 0 for the second when sum_C Lmu^2 is 0; sum_c s_c^2 is
 *                     the variance of L's noise), s_c as above: skin over a floor whose texture is
 *                     within the noise is kept, a shadow over it (a scaled copy) is not;
 * All the integer tables and comparisons are exact: with floor() of the thresholds above (computed
 * in doubles in vc_bgmodel_set_params), a float implementation gives the same mask.
 * The model's mean is an 8-bit image (the rounded mean of the learnt frames) and its sigma is kept in
 * Q8.8; vc_bgmodel_mean()/vc_bgmodel_sigma() return exactly the values the classifier uses, so a
 * float implementation of the rules above on those values gives the same mask (see the tests).
 *
 * Thread safety: a model may be used by one thread at a time. vc_subtract() keeps the texture
 * tests' candidates of 5 rows and its running column sums in the model (32 bytes per pixel of 5
 * rows + 32 per column: 123 KB at 640 wide, allocated by vc_bgmodel_set_params when a test is on),
 * so one frame at a time per model, as the edge runs it (one model per camera); with
 * shadow_texture_k and shadow_flat_margin 0 it only reads the model.
 */
#ifndef VOXCAP_EDGE_BGMODEL_H
#define VOXCAP_EDGE_BGMODEL_H

#include <stddef.h>
#include <stdint.h>

#include "voxcap/subtraction.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Thresholds of the subtraction, normally from the host's CONFIG message. Plain doubles: they are
 * converted to per-pixel integer tables once, in vc_bgmodel_set_params(). */
typedef struct vc_subtract_params {
  double t_upper;            /* T_u, > 0: foreground above T_u * sigma in any channel (eq. 1) */
  double t_lower;            /* T_l, 0 < T_l <= T_u: surely background below T_l * sigma in all channels */
  double cos2_angular;       /* cos^2(T_angular) in [0, 1]: in-band pixels with a smaller squared cosine
                              * to the background colour are foreground (eq. 2) */
  double shadow_min_gain;    /* a shadow darkens: alpha = p.mu/|mu|^2 must be >= this (>= 0) ... */
  double shadow_max_gain;    /* ... and <= this (in [min, 1]: shadows are never brighter than the
                              * background, so a pixel brighter than T_l * sigma in any channel is
                              * foreground); min also bounds how dark a shadow gets per channel (eq. 1') */
  double sigma_floor;        /* sigma below this (grey levels, > 0) is raised to it, so that a perfectly
                              * still pixel does not turn every one-level change into foreground */
  double shadow_texture_k;   /* the texture test, in sigmas of the luminance noise, [0, 16], 0 = off:
                              * a shadow's window must show the background's texture (see below) */
  double shadow_flat_margin; /* the flat-patch test, in noise variances per pixel, [0, 16], 0 = off:
                              * a candidate whose window's luminance a flat patch explains better
                              * than the background's luminance scaled, by more than this, is
                              * foreground (see below) */
  double grow_px;            /* the limb-scale cue, pixels (an integer in [0, 64], 0 = off): background
                              * pixels joined to the foreground through at most this many 4-connected
                              * steps of "weak" pixels become foreground (see below) */
  double grow_sigma;         /* a weak pixel: outside the shadow band and off the background by at least
                              * this many noise sigmas, pooled over the channels, (0, 16] */
  double grow_flat;          /* the cue also enters the shadow band where the background is flat: its
                              * luminance varies over the 5x5 window by less than this many noise
                              * variances per pixel, [0, 16], 0 = never (see below) */
} vc_subtract_params;

/* The flat-patch test's margin (shadow_flat_margin), fixed on the edge (not in rig.toml or CONFIG).
 * Units: the learnt noise variance of a pixel's luminance (sum_c sigma_c^2, sigma floored: the
 * variance of p_0 + p_1 + p_2), per pixel of the window: the gain model (the background's luminance
 * scaled, which a shadow is) may leave at most this much more residual per pixel than a flat patch
 * (which a body part is at the scale of 5 pixels, over a textured floor or wall). Over a flat
 * background the two models are the same and the difference is only the learnt mean's noise (sigma
 * / sqrt(frames)). 0.2: the test runs on one channel, the luminance, where it ran on three (the
 * per-channel test, margin 0.1, cost 1.6 instructions per pixel more than the edge frame's budget
 * allows), and the difference of two one-parameter fits of one channel spreads more with the noise
 * than the sum of three channels' (the same margin takes more shadow); a texture common to the
 * channels (wood grain, tile mottle) gives the luminance up to three times the energy of the
 * channels apart, so a body over it is still seen. On the issue #10 matrix (tests/bench/
 * hull_sweep.cmake, 144 cells) 0.2 misses a target in as many cells as the per-channel test did at
 * 0.1, keeping 0.02-0.03 points more floor shadow; 0.3 misses two more (a hand at 96.9 %), 0.1
 * takes up to 6 % of the synthetic scene's shadows for foreground (the unit tests), 0.4 keeps only
 * 96.1 % of shaded skin over tiles whose texture is within the noise (edge/core/README.md). */
#define VC_SUBTRACT_SHADOW_FLAT_MARGIN 0.2
#define VC_SUBTRACT_SHADOW_FLAT_MARGIN_MAX 16.0

/* The limb-scale cue (grow_px, grow_sigma), fixed on the edge (not in rig.toml or CONFIG): a
 * hysteresis like Canny's on top of the rule above. A pixel the rule leaves background, outside the
 * shadow band (p >= mu - tl in every channel: eq. 1's background, not a shadow verdict), is weak when
 * |p - mu|^2 >= grow_sigma^2 * sum_c s_c^2 (s_c = max(sigma_c, sigma_floor): off the background by
 * grow_sigma noise sigmas in every channel on average, which the per-channel T_l test does not see
 * when no channel alone leaves the noise); a weak pixel becomes foreground when a 4-connected path
 * of weak pixels of at most grow_px steps joins it to the clean mask's foreground. It runs after the
 * clean-up (vc_cleanup_grow, vc_mask_frame below; vc_subtract alone does not grow), so the noise
 * speckles the clean-up removes seed nothing. Skin of the floor's own colour is a little off it
 * everywhere, the sensor noise alone reaches the threshold in few pixels and not in connected runs,
 * and a shadow's pixels are in the band, so a floor shadow touching the feet is not grown into
 * (the band is entered only over a flat background: grow_flat, below). A pixel the subtraction called
 * foreground that the clean-up took away is weak too when another such pixel is among its 8
 * neighbours: the thin parts (a finger, a wrist 1-2 pixels wide) the 3x3 filter cuts off the body
 * come back, a lone speck beside the outline does not (edge/core/README.md, session 15).
 * Exact integers, no allocation per frame (the model holds a queue of width * height indices, each
 * pixel's least |p - mu|^2 for the test, and the clean mask's foreground as bits, which the clean-up
 * writes in its own pass). The pixels it adds are VC_MASK_GROWN (below): the carver takes them, the
 * edge's tracker does not. On by default, grow_px 4: on the issue #10 matrix the cells missing a
 * target go from 29 to 16 (every foot >= 98.7 %), and the edge frame of `voxcap bench edge` stays
 * within #10's budget (9.795 M instructions against 9.80: edge/core/README.md). It was off while the
 * tracker saw the grown rims (live, `voxcap demo --motion squat` 34.9 -> 64.8 mm MPJPE, hands
 * swapped; offline, track_eval's hands untracked in 2-5x as many views on all six motions); given the
 * mask without them, track_eval is the same with the cue as without it. */
#define VC_SUBTRACT_GROW_PX 4.0
#define VC_SUBTRACT_GROW_PX_MAX 64.0
#define VC_SUBTRACT_GROW_SIGMA 1.5 /* the value measured with grow_px 4 */
#define VC_SUBTRACT_GROW_SIGMA_MAX 16.0

/* The cue over a flat background (grow_flat), fixed on the edge: a pixel in the shadow band (darker
 * than the noise, which the subtraction called shadow or the clean-up took back) is weak too when
 * the learnt background around it is flat, its luminance Lmu = mu_0 + mu_1 + mu_2 varying over the
 * 5x5 window (clipped at the image's border) by less than grow_flat * sum_c s_c^2 per pixel (the
 * variance of the window's Lmu about its mean, against the noise variance of L at the pixel). There
 * a shadow verdict rests on colour alone: the texture and flat-patch tests compare the window with
 * the background's texture, and with none to compare (the flat-patch test sees a smooth body darker
 * by a gain a only when a^2 times the texture's variance exceeds its margin of 0.2 noise variances,
 * so below one variance it is blind at any gain down to the deepest shadow's 0.45) a shirt or skin of
 * the background's hue, shaded, passes as a shadow. Joined to the body it is body, up to grow_px
 * steps, as the cue already takes the pixels within the noise; a shadow over a textured floor or
 * wall is still not entered. Computed once per model in vc_bgmodel_set_params (no per-frame cost
 * but the cue's test of the pixels it visits). */
#define VC_SUBTRACT_GROW_FLAT 1.0
#define VC_SUBTRACT_GROW_FLAT_MAX 16.0

/* Fills the defaults of voxcap/subtraction.h (the ones the host's rig.toml starts from): T_u 60,
 * T_l 3.5, T_angular 8 degrees, alpha in [0.45, 1.0], sigma floor 1.0, texture k 1.5; and the
 * flat-patch margin 0.2 (VC_SUBTRACT_SHADOW_FLAT_MARGIN above); the limb-scale cue on (grow_px 4,
 * grow_sigma 1.5: VC_SUBTRACT_GROW_* above). */
void vc_subtract_params_default(vc_subtract_params* params);

/* 0 if the parameters are usable, -EINVAL otherwise. The reason, when why is given (NULL/0 when not
 * wanted), is one line naming the first bad field and its value ("" when usable); edge/README.md's
 * convention. */
int vc_subtract_params_check(const vc_subtract_params* params, char* why, size_t why_len);

typedef struct vc_bgmodel vc_bgmodel;

/* New empty model for width x height frames (1..16384 each) into *out. Returns 0, -EINVAL or -ENOMEM
 * with *out NULL and a one-line reason in why when given (NULL/0 when not wanted; "" on success):
 * edge/README.md's constructor shape. *out owns the model; release it with vc_bgmodel_free(). */
int vc_bgmodel_new(int width, int height, vc_bgmodel** out, char* why, size_t why_len);

/* Frees the model; NULL is a no-op. */
void vc_bgmodel_free(vc_bgmodel* model);

/* Accumulates one frame of the empty scene (borrowed for the call only). Returns 0, -EINVAL on a
 * bad argument (stride < 3*width), -EBUSY after vc_bgmodel_finish(), -EOVERFLOW after 65535 frames. */
int vc_bgmodel_learn(vc_bgmodel* model, const uint8_t* rgb, size_t stride);

/* Computes the mean and standard deviation images from the learnt frames and releases the
 * accumulators. Returns 0, -ENODATA if fewer than 2 frames were learnt, -EBUSY if already finished. */
int vc_bgmodel_finish(vc_bgmodel* model);

/* Restores a finished model from a saved mean and sigma (as vc_bgmodel_mean()/vc_bgmodel_sigma_q8()
 * returned them, both copied) learnt from `frames` frames: an edge that restarts mid-session cannot
 * learn the empty scene again with a person in it. Only on a new model (no frame learnt). Returns 0,
 * -EINVAL, -EBUSY (frames learnt or finished already) or -ENOMEM. */
int vc_bgmodel_restore(vc_bgmodel* model, const uint8_t* mean, const uint16_t* sigma_q8, int frames);

/* Derives the per-pixel integer thresholds from `params` (floats are used here, not per frame).
 * Returns 0, -EINVAL for bad parameters, -EAGAIN before vc_bgmodel_finish(), -ENOMEM (the texture
 * test's scratch; the model is then not ready until a call succeeds). */
int vc_bgmodel_set_params(vc_bgmodel* model, const vc_subtract_params* params);

/* Frames learnt so far (also after finish). */
int vc_bgmodel_frames(const vc_bgmodel* model);
int vc_bgmodel_width(const vc_bgmodel* model);
int vc_bgmodel_height(const vc_bgmodel* model);

/* The model's mean (uint8, interleaved RGB, stride 3*width) and sigma (uint16 Q8.8 grey levels,
 * interleaved RGB, 3*width elements per row), before the sigma floor is applied. Borrowed pointers,
 * valid until the model is freed; NULL before vc_bgmodel_finish(). */
const uint8_t* vc_bgmodel_mean(const vc_bgmodel* model);
const uint16_t* vc_bgmodel_sigma_q8(const vc_bgmodel* model);

/* Per-frame counters (optional output of vc_subtract). */
typedef struct vc_subtract_stats {
  uint32_t band;   /* pixels between the two thresholds that went through the shadow test */
  uint32_t shadow; /* of those, the ones classified shadow (background) */
  uint32_t grown;  /* background pixels the limb-scale cue made foreground */
} vc_subtract_stats;

/* Classifies one frame. `rgb` (stride bytes per row) and `mask` (width bytes per row, width*height
 * bytes, caller-owned) are borrowed for the call. `stats` may be NULL. No allocation, no floating
 * point. Returns 0, -EINVAL on a bad argument, -EAGAIN before vc_bgmodel_set_params(). */
int vc_subtract(const vc_bgmodel* model, const uint8_t* rgb, size_t stride, uint8_t* mask,
                vc_subtract_stats* stats);

/* The limb-scale cue runs on the clean mask, after the clean-up, not in vc_subtract (which leaves
 * stats->grown 0): its first ring is the background pixels of the clean mask with at least 2
 * foreground 8-neighbours, from the clean mask's foreground bits that the clean-up writes in its own
 * pass over each row (no scan of its own), so the speckles the clean-up removes seed nothing.
 *
 * vc_cleanup_grow: vc_cleanup_radius(mask, width, height, radius, scratch, scratch_len) (cleanup.h)
 * and then the cue (when the model's grow_px > 0) against the frame `rgb` the mask came from; *grown
 * (may be NULL) the pixels it added. Returns 0, -EINVAL on a bad argument, -EAGAIN before
 * vc_bgmodel_set_params(). No allocation, integers only.
 *
 * vc_mask_frame: the edge's whole silhouette, vc_subtract and then vc_cleanup_grow; everything that
 * makes a silhouette from a frame (the edge daemon, host/calib's carve, the benches) calls this, so
 * that they all run the same sequence. stats->grown is the cue's count. */
int vc_cleanup_grow(const vc_bgmodel* model, const uint8_t* rgb, size_t stride, uint8_t* mask, int radius,
                    uint8_t* scratch, size_t scratch_len, uint32_t* grown);
int vc_mask_frame(const vc_bgmodel* model, const uint8_t* rgb, size_t stride, uint8_t* mask, int radius,
                  uint8_t* scratch, size_t scratch_len, vc_subtract_stats* stats);

/* The values of a mask after the cue: the subtraction and clean-up's foreground is VC_MASK_FG, the
 * pixels the cue added VC_MASK_GROWN. Carving, RLE and the SILHOUETTE message take any non-zero byte
 * as foreground (the hull and the host see the grown silhouette); the edge's tracker takes only
 * VC_MASK_FG (vc_mask_ungrown): its windows are masked by the silhouette and its seeds and
 * re-acquisitions come from the silhouette's shape and skin blobs, which a grown rim of up to grow_px
 * pixels changes (given the grown mask, track_eval squat's hands went untracked in 461 and 457 of
 * 1671 views, against 212 and 198: edge/core/README.md). */
#define VC_MASK_FG 255
#define VC_MASK_GROWN 128

/* The mask without the cue's pixels: out[i] = 255 where mask[i] is VC_MASK_FG, else 0 (len bytes;
 * out may be mask). What the edge daemon gives its tracker. */
void vc_mask_ungrown(const uint8_t* mask, size_t len, uint8_t* out);

/* Name of the kernel variant in use ("generic", "avx2" or "neon"). */
const char* vc_edge_kernel_name(void);

/* Selects the kernel variant for all subsequent calls of this library: "auto" (the best one this CPU
 * runs), "generic" (portable C, what every CPU runs), "avx2" (x86-64 with AVX2), "neon" (aarch64: the
 * hand-written Advanced SIMD kernels, equal to "generic" bit for bit). Returns 0, or
 * -ENOTSUP when the variant cannot run here. Meant for tests and benchmarks; not thread-safe. */
int vc_edge_kernel_select(const char* name);

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_EDGE_BGMODEL_H */
