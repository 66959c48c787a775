/* vc_clock: the ONE place on the edge where timestamps change clocks.
 *
 * Everything the edge pairs is stamped in CLOCK_MONOTONIC nanoseconds: camera frames (V4L2 buffers
 * are MONOTONIC already; libcamera's SensorTimestamp is CLOCK_BOOTTIME), trigger pulses (gpio edge
 * events are MONOTONIC by default, REALTIME if so configured; the emulated trigger datagram carries
 * the host's MONOTONIC time). A backend whose timestamps are on another clock converts them here and
 * nowhere else.
 *
 * The offset between two clocks is measured by sampling: read MONOTONIC, the other clock, MONOTONIC
 * again; the sample with the narrowest bracket gives offset = other - midpoint(mono) with an
 * uncertainty of half the bracket. BOOTTIME - MONOTONIC only changes when the system suspends,
 * REALTIME - MONOTONIC whenever the wall clock is stepped or slewed, so a converter re-measures once
 * its measurement is older than a refresh period (default 1 s). No allocation anywhere.
 */
#ifndef VOXCAP_EDGE_CLOCK_H
#define VOXCAP_EDGE_CLOCK_H

#include <stddef.h>
#include <stdint.h>
#include <time.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vc_clock_id {
  VC_CLOCK_MONOTONIC = 0, /* the edge's reference clock */
  VC_CLOCK_BOOTTIME = 1,  /* MONOTONIC + time spent in suspend: libcamera sensor timestamps */
  VC_CLOCK_REALTIME = 2,  /* wall clock: gpio edge events when event_clock = realtime */
} vc_clock_id;

/* "monotonic", "boottime", "realtime"; NULL for an unknown id. */
const char* vc_clock_name(vc_clock_id id);
/* Parses the names above; 0 or -EINVAL. */
int vc_clock_from_name(const char* name, vc_clock_id* out);

/* Current time of a clock in ns (0 if the clock cannot be read, which Linux never does for these). */
uint64_t vc_clock_now_ns(vc_clock_id id);
/* Shorthand for vc_clock_now_ns(VC_CLOCK_MONOTONIC). */
uint64_t vc_clock_monotonic_ns(void);

/* MONOTONIC ns as a timespec, and the absolute MONOTONIC deadline delay_ns from now: for
 * pthread_cond_timedwait on a condition variable whose clock is CLOCK_MONOTONIC
 * (pthread_condattr_setclock), the only place the edge needs a struct timespec. */
struct timespec vc_clock_timespec(uint64_t t_ns);
struct timespec vc_clock_deadline_ns(uint64_t delay_ns);

/* One bracketed reading: mono_before <= (the instant `other` was read) <= mono_after. */
typedef struct vc_clock_sample {
  uint64_t mono_before_ns;
  uint64_t other_ns;
  uint64_t mono_after_ns;
} vc_clock_sample;

/* Pure: offset (other - monotonic) from the sample with the narrowest bracket.
 * Returns 0, or -EINVAL when n == 0 or every sample is inconsistent (after < before). */
int vc_clock_offset_from_samples(const vc_clock_sample* samples, size_t n, int64_t* offset_ns,
                                 uint64_t* uncertainty_ns);

/* Samples the clock `other` against MONOTONIC `nsamples` times (0 = 8) and returns the offset. */
int vc_clock_measure_offset(vc_clock_id other, unsigned nsamples, int64_t* offset_ns,
                            uint64_t* uncertainty_ns);

/* Converter from one clock to MONOTONIC; a plain struct the owner embeds (no allocation).
 * Not thread-safe: one converter per thread (they are cheap). */
typedef struct vc_clock_converter {
  vc_clock_id src;
  int64_t offset_ns;       /* src - monotonic at the last measurement */
  uint64_t uncertainty_ns; /* half the narrowest bracket of the last measurement */
  uint64_t measured_at_ns; /* MONOTONIC time of the last measurement (0 = never) */
  uint64_t refresh_ns;     /* re-measure when the measurement is older than this (0 = never) */
} vc_clock_converter;

/* Initialises and measures once. refresh_ns = 0 uses 1 s. Returns 0 or -EINVAL. */
int vc_clock_converter_init(vc_clock_converter* conv, vc_clock_id src, uint64_t refresh_ns);
/* Converts a timestamp on conv->src to MONOTONIC ns, re-measuring first if the measurement is stale.
 * MONOTONIC sources pass through unchanged. Results below 0 clamp to 0. */
uint64_t vc_clock_to_monotonic(vc_clock_converter* conv, uint64_t t_src_ns);
/* Pure: t_src - offset, clamped to [0, UINT64_MAX]. */
uint64_t vc_clock_apply_offset(uint64_t t_src_ns, int64_t offset_ns);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_CLOCK_H */
