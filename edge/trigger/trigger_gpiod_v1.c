/* The "gpiod" trigger backend for libgpiod 1.x (Debian bookworm's own 1.6, older Raspberry Pi OS).
 * CMake compiles this file INSTEAD of trigger_gpiod.c when pkg-config finds libgpiod < 2; it cannot be
 * built on a v2 machine, so it is kept small and mirrors trigger_gpiod.c. The v1 API has no event
 * sequence numbers and no clock choice: pulses are counted here, and the timestamps are the kernel's
 * (CLOCK_MONOTONIC on kernels >= 5.7; REALTIME before, which event_clock = realtime converts).
 * Checked to compile against Debian bookworm's libgpiod-dev 1.6.3 headers (-fsyntax-only). */
#define _GNU_SOURCE
#include <errno.h>
#include <gpiod.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "trigger_backend.h"

#define EVENT_BATCH 16

struct gpiod_priv {
  struct gpiod_chip* chip;
  struct gpiod_line* line;
  struct gpiod_line_event events[EVENT_BATCH];
  int nevents, next;
  uint64_t next_seq;
  vc_clock_converter clock;
};

static void gpiod_priv_free(void* p) {
  struct gpiod_priv* g = p;
  if (!g) return;
  if (g->line) gpiod_line_release(g->line);
  if (g->chip) gpiod_chip_close(g->chip);
  free(g);
}

static int gpiod_open(vc_trigger* trig, const vc_trigger_config* cfg, vc_trigger_info* info, void** out) {
  struct gpiod_priv* g;
  char src[192];
  int rc, flags = 0;
  if (!cfg->chip || !cfg->chip[0]) return vc_trigger_set_error(trig, -EINVAL, "no chip given (e.g. gpiochip0)");
  vc_trigger_set_source(trig, cfg->chip);
  g = calloc(1, sizeof *g);
  if (!g) return vc_trigger_set_error(trig, -ENOMEM, "out of memory");
  g->next_seq = cfg->seq_base;
  rc = vc_clock_converter_init(&g->clock, cfg->event_clock, 0);
  if (rc) goto err;
  g->chip = gpiod_chip_open_lookup(cfg->chip); /* path, name, label or number */
  if (!g->chip) {
    rc = vc_trigger_set_error(trig, errno ? -errno : -ENODEV, "cannot open chip: %s", strerror(errno ? errno : ENODEV));
    goto err;
  }
  g->line = cfg->line_name ? gpiod_chip_find_line(g->chip, cfg->line_name)
                           : gpiod_chip_get_line(g->chip, cfg->line_offset);
  if (!g->line) {
    rc = cfg->line_name ? vc_trigger_set_error(trig, -ENOENT, "no line named '%s' on this chip", cfg->line_name)
                        : vc_trigger_set_error(trig, -ENOENT, "no line %u on this chip", cfg->line_offset);
    goto err;
  }
  snprintf(src, sizeof src, "%s line %u", cfg->chip, gpiod_line_offset(g->line));
  vc_trigger_set_source(trig, src);
  if (cfg->active_low) flags |= GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW;
  if (cfg->bias == VC_TRIGGER_BIAS_DISABLED) flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE;
  if (cfg->bias == VC_TRIGGER_BIAS_PULL_UP) flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP;
  if (cfg->bias == VC_TRIGGER_BIAS_PULL_DOWN) flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN;
  if (cfg->debounce_us) {
    rc = vc_trigger_set_error(trig, -ENOTSUP, "debounce needs libgpiod 2");
    goto err;
  }
  if (gpiod_line_request_rising_edge_events_flags(g->line, "voxcap-edge trigger", flags) != 0) {
    int e = errno ? errno : EIO;
    g->line = NULL; /* not requested: nothing to release */
    rc = vc_trigger_set_error(trig, -e, "cannot request the line for edge events: %s", strerror(e));
    goto err;
  }
  snprintf(info->source, sizeof info->source, "%s", src);
  *out = g;
  return 0;
err:
  gpiod_priv_free(g);
  return rc;
}

static int gpiod_wait(vc_trigger* trig, void* p, int timeout_ms, vc_pulse* pulse, vc_trigger_stats* st) {
  struct gpiod_priv* g = p;
  for (;;) {
    while (g->next < g->nevents) {
      const struct gpiod_line_event* ev = &g->events[g->next++];
      if (ev->event_type != GPIOD_LINE_EVENT_RISING_EDGE) {
        st->invalid++;
        continue;
      }
      uint64_t t = (uint64_t)ev->ts.tv_sec * 1000000000ull + (uint64_t)ev->ts.tv_nsec;
      pulse->seq = g->next_seq++;
      pulse->t_ns = vc_clock_to_monotonic(&g->clock, t);
      return 0;
    }
    struct timespec tmo = {timeout_ms / 1000, (long)(timeout_ms % 1000) * 1000000L};
    int r = gpiod_line_event_wait(g->line, timeout_ms < 0 ? NULL : &tmo);
    if (r < 0) return vc_trigger_set_error(trig, -errno, "waiting for edge events: %s", strerror(errno));
    if (r == 0) return -ETIMEDOUT;
    int n = gpiod_line_event_read_multiple(g->line, g->events, EVENT_BATCH);
    if (n < 0) return vc_trigger_set_error(trig, -errno, "reading edge events: %s", strerror(errno));
    g->nevents = n;
    g->next = 0;
  }
}

static int gpiod_fd(const void* p) { return gpiod_line_event_get_fd(((const struct gpiod_priv*)p)->line); }

const vc_trigger_backend vc_trigger_backend_gpiod = {
    .name = "gpiod", .open = gpiod_open, .wait = gpiod_wait, .fd = gpiod_fd, .free_priv = gpiod_priv_free};
