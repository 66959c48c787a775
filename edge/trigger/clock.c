/* vc_clock: clock reading and the one clock conversion of the edge (see clock.h for why). */
#define _GNU_SOURCE
#include "voxcap/edge/clock.h"

#include <errno.h>
#include <string.h>
#include <time.h>

static clockid_t to_clockid(vc_clock_id id) {
  switch (id) {
    case VC_CLOCK_BOOTTIME:
      return CLOCK_BOOTTIME;
    case VC_CLOCK_REALTIME:
      return CLOCK_REALTIME;
    case VC_CLOCK_MONOTONIC:
    default:
      return CLOCK_MONOTONIC;
  }
}

const char* vc_clock_name(vc_clock_id id) {
  switch (id) {
    case VC_CLOCK_MONOTONIC:
      return "monotonic";
    case VC_CLOCK_BOOTTIME:
      return "boottime";
    case VC_CLOCK_REALTIME:
      return "realtime";
  }
  return NULL;
}

int vc_clock_from_name(const char* name, vc_clock_id* out) {
  static const vc_clock_id ids[] = {VC_CLOCK_MONOTONIC, VC_CLOCK_BOOTTIME, VC_CLOCK_REALTIME};
  if (!name || !out) return -EINVAL;
  for (size_t i = 0; i < sizeof ids / sizeof ids[0]; i++) {
    if (strcmp(name, vc_clock_name(ids[i])) == 0) {
      *out = ids[i];
      return 0;
    }
  }
  return -EINVAL;
}

uint64_t vc_clock_now_ns(vc_clock_id id) {
  struct timespec ts;
  if (clock_gettime(to_clockid(id), &ts) != 0) return 0;
  return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

uint64_t vc_clock_monotonic_ns(void) {
  return vc_clock_now_ns(VC_CLOCK_MONOTONIC);
}

struct timespec vc_clock_timespec(uint64_t t_ns) {
  struct timespec ts = {.tv_sec = (time_t)(t_ns / 1000000000ull), .tv_nsec = (long)(t_ns % 1000000000ull)};
  return ts;
}

struct timespec vc_clock_deadline_ns(uint64_t delay_ns) {
  uint64_t now = vc_clock_monotonic_ns();
  return vc_clock_timespec(delay_ns > UINT64_MAX - now ? UINT64_MAX : now + delay_ns);
}

int vc_clock_offset_from_samples(const vc_clock_sample* samples, size_t n, int64_t* offset_ns,
                                 uint64_t* uncertainty_ns) {
  const vc_clock_sample* best = NULL;
  uint64_t best_width = UINT64_MAX;
  if (!samples || n == 0) return -EINVAL;
  for (size_t i = 0; i < n; i++) {
    if (samples[i].mono_after_ns < samples[i].mono_before_ns) continue;
    uint64_t width = samples[i].mono_after_ns - samples[i].mono_before_ns;
    if (width < best_width) {
      best_width = width;
      best = &samples[i];
    }
  }
  if (!best) return -EINVAL;
  /* midpoint without overflow */
  uint64_t mid = best->mono_before_ns + best_width / 2;
  if (offset_ns) *offset_ns = (int64_t)(best->other_ns - mid);
  if (uncertainty_ns) *uncertainty_ns = (best_width + 1) / 2;
  return 0;
}

int vc_clock_measure_offset(vc_clock_id other, unsigned nsamples, int64_t* offset_ns,
                            uint64_t* uncertainty_ns) {
  vc_clock_sample samples[32];
  if (nsamples == 0) nsamples = 8;
  if (nsamples > sizeof samples / sizeof samples[0]) nsamples = sizeof samples / sizeof samples[0];
  if (!vc_clock_name(other)) return -EINVAL;
  for (unsigned i = 0; i < nsamples; i++) {
    samples[i].mono_before_ns = vc_clock_monotonic_ns();
    samples[i].other_ns = vc_clock_now_ns(other);
    samples[i].mono_after_ns = vc_clock_monotonic_ns();
  }
  return vc_clock_offset_from_samples(samples, nsamples, offset_ns, uncertainty_ns);
}

static int converter_measure(vc_clock_converter* conv) {
  if (conv->src == VC_CLOCK_MONOTONIC) {
    conv->offset_ns = 0;
    conv->uncertainty_ns = 0;
  } else {
    int rc = vc_clock_measure_offset(conv->src, 8, &conv->offset_ns, &conv->uncertainty_ns);
    if (rc) return rc;
  }
  conv->measured_at_ns = vc_clock_monotonic_ns();
  return 0;
}

int vc_clock_converter_init(vc_clock_converter* conv, vc_clock_id src, uint64_t refresh_ns) {
  if (!conv || !vc_clock_name(src)) return -EINVAL;
  memset(conv, 0, sizeof *conv);
  conv->src = src;
  conv->refresh_ns = refresh_ns ? refresh_ns : 1000000000ull;
  return converter_measure(conv);
}

uint64_t vc_clock_apply_offset(uint64_t t_src_ns, int64_t offset_ns) {
  if (offset_ns >= 0) {
    uint64_t off = (uint64_t)offset_ns;
    return t_src_ns > off ? t_src_ns - off : 0;
  }
  uint64_t add = (uint64_t)(-(offset_ns + 1)) + 1; /* |offset| without overflowing INT64_MIN */
  return t_src_ns > UINT64_MAX - add ? UINT64_MAX : t_src_ns + add;
}

uint64_t vc_clock_to_monotonic(vc_clock_converter* conv, uint64_t t_src_ns) {
  if (conv->src == VC_CLOCK_MONOTONIC) return t_src_ns;
  if (conv->measured_at_ns == 0 ||
      (conv->refresh_ns && vc_clock_monotonic_ns() - conv->measured_at_ns > conv->refresh_ns))
    (void)converter_measure(conv); /* on failure keep the previous offset */
  return vc_clock_apply_offset(t_src_ns, conv->offset_ns);
}
