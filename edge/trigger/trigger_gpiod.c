/* The "gpiod" trigger backend, libgpiod v2 API (bookworm-backports, current Raspberry Pi OS; the
 * build requires libgpiod >= 2.0).
 *
 * The host's trigger pulse reaches the edge board on a GPIO line. We request that one line as an
 * input with rising-edge detection (falling on the wire when active_low), optional bias and debounce,
 * and the kernel's edge timestamps on CLOCK_MONOTONIC (or REALTIME, converted in vc_clock). Each
 * event carries the kernel's per-line sequence number, which counts every edge since the request even
 * when the kernel's event FIFO overflowed, so seq = seq_base + line_seqno − 1 counts the pulses and
 * its gaps are pulses lost. Events are read in batches into a buffer and handed out one by one. */
#define _GNU_SOURCE
#include <errno.h>
#include <gpiod.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trigger_backend.h"

#define EVENT_BATCH 16

struct gpiod_priv {
  struct gpiod_chip* chip;
  struct gpiod_line_request* req;
  struct gpiod_edge_event_buffer* events;
  int nevents, next;
  unsigned offset;
  uint64_t seq_base;
  uint64_t last_line_seqno;
  vc_clock_converter clock;
};

static void gpiod_priv_free(void* p) {
  struct gpiod_priv* g = p;
  if (!g) return;
  if (g->events) gpiod_edge_event_buffer_free(g->events);
  if (g->req) gpiod_line_request_release(g->req);
  if (g->chip) gpiod_chip_close(g->chip);
  free(g);
}

static enum gpiod_line_bias to_bias(vc_trigger_bias b) {
  switch (b) {
    case VC_TRIGGER_BIAS_DISABLED:
      return GPIOD_LINE_BIAS_DISABLED;
    case VC_TRIGGER_BIAS_PULL_UP:
      return GPIOD_LINE_BIAS_PULL_UP;
    case VC_TRIGGER_BIAS_PULL_DOWN:
      return GPIOD_LINE_BIAS_PULL_DOWN;
    case VC_TRIGGER_BIAS_AS_IS:
      break;
  }
  return GPIOD_LINE_BIAS_AS_IS;
}

/* "gpiochip0" → "/dev/gpiochip0"; paths stay as they are. */
static void chip_path(const char* chip, char* out, size_t cap) {
  if (strchr(chip, '/'))
    snprintf(out, cap, "%s", chip);
  else
    snprintf(out, cap, "/dev/%s", chip);
}

static int gpiod_open(vc_trigger* trig, const vc_trigger_config* cfg, vc_trigger_info* info, void** out) {
  struct gpiod_priv* g;
  struct gpiod_line_settings* settings = NULL;
  struct gpiod_line_config* lcfg = NULL;
  struct gpiod_request_config* rcfg = NULL;
  char path[96], src[128];
  int rc;
  if (!cfg->chip || !cfg->chip[0])
    return vc_trigger_set_error(trig, -EINVAL, "no chip given (e.g. gpiochip0)");
  chip_path(cfg->chip, path, sizeof path);
  vc_trigger_set_source(trig, path);
  g = calloc(1, sizeof *g);
  if (!g) return vc_trigger_set_error(trig, -ENOMEM, "out of memory");
  g->seq_base = cfg->seq_base;
  rc = vc_clock_converter_init(&g->clock, cfg->event_clock, 0);
  if (rc) {
    vc_trigger_set_error(trig, rc, "cannot read the %s clock", vc_clock_name(cfg->event_clock));
    goto out;
  }
  g->chip = gpiod_chip_open(path);
  if (!g->chip) {
    rc = vc_trigger_set_error(trig, errno ? -errno : -ENODEV, "cannot open chip: %s",
                              strerror(errno ? errno : ENODEV));
    goto out;
  }
  if (cfg->line_name) {
    int off = gpiod_chip_get_line_offset_from_name(g->chip, cfg->line_name);
    if (off < 0) {
      rc = vc_trigger_set_error(trig, -ENOENT, "no line named '%s' on this chip", cfg->line_name);
      goto out;
    }
    g->offset = (unsigned)off;
  } else {
    g->offset = cfg->line_offset;
  }
  snprintf(src, sizeof src, "%s line %u%s%.20s%s", path, g->offset, cfg->line_name ? " (" : "",
           cfg->line_name ? cfg->line_name : "", cfg->line_name ? ")" : "");
  vc_trigger_set_source(trig, src);

  settings = gpiod_line_settings_new();
  lcfg = gpiod_line_config_new();
  rcfg = gpiod_request_config_new();
  g->events = gpiod_edge_event_buffer_new(EVENT_BATCH);
  if (!settings || !lcfg || !rcfg || !g->events) {
    rc = vc_trigger_set_error(trig, -ENOMEM, "out of memory");
    goto out;
  }
  if (gpiod_line_settings_set_direction(settings, GPIOD_LINE_DIRECTION_INPUT) ||
      gpiod_line_settings_set_edge_detection(settings, GPIOD_LINE_EDGE_RISING) ||
      gpiod_line_settings_set_bias(settings, to_bias(cfg->bias)) ||
      gpiod_line_settings_set_event_clock(settings, cfg->event_clock == VC_CLOCK_REALTIME
                                                        ? GPIOD_LINE_CLOCK_REALTIME
                                                        : GPIOD_LINE_CLOCK_MONOTONIC)) {
    rc = vc_trigger_set_error(trig, -EINVAL, "invalid line settings");
    goto out;
  }
  gpiod_line_settings_set_active_low(settings, cfg->active_low);
  gpiod_line_settings_set_debounce_period_us(settings, cfg->debounce_us);
  if (gpiod_line_config_add_line_settings(lcfg, &g->offset, 1, settings)) {
    rc = vc_trigger_set_error(trig, -errno, "line config: %s", strerror(errno));
    goto out;
  }
  gpiod_request_config_set_consumer(rcfg, "voxcap-edge trigger");
  gpiod_request_config_set_event_buffer_size(rcfg, 64);
  g->req = gpiod_chip_request_lines(g->chip, rcfg, lcfg);
  if (!g->req) {
    int e = errno ? errno : EIO;
    rc = vc_trigger_set_error(trig, -e, "cannot request the line for edge events: %s%s", strerror(e),
                              e == EBUSY    ? " (used by another program?)"
                              : e == EINVAL ? " (no such line, or edge detection unsupported)"
                                            : "");
    goto out;
  }
  snprintf(info->source, sizeof info->source, "%s", src);
  *out = g;
  g = NULL;
  rc = 0;
out:
  gpiod_request_config_free(rcfg);
  gpiod_line_config_free(lcfg);
  gpiod_line_settings_free(settings);
  gpiod_priv_free(g);
  return rc;
}

static int gpiod_wait(vc_trigger* trig, void* p, int timeout_ms, vc_pulse* pulse, vc_trigger_stats* st) {
  struct gpiod_priv* g = p;
  for (;;) {
    while (g->next < g->nevents) {
      struct gpiod_edge_event* ev = gpiod_edge_event_buffer_get_event(g->events, (unsigned long)g->next++);
      if (gpiod_edge_event_get_event_type(ev) != GPIOD_EDGE_EVENT_RISING_EDGE) {
        st->invalid++;
        continue;
      }
      uint64_t line_seqno = gpiod_edge_event_get_line_seqno(ev);
      if (line_seqno > g->last_line_seqno + 1) /* the first event of a request is number 1 */
        st->lost += line_seqno - g->last_line_seqno - 1;
      g->last_line_seqno = line_seqno;
      pulse->seq = g->seq_base + (line_seqno ? line_seqno - 1 : 0);
      pulse->t_ns = vc_clock_to_monotonic(&g->clock, gpiod_edge_event_get_timestamp_ns(ev));
      return 0;
    }
    int64_t tmo = timeout_ms < 0 ? -1 : (int64_t)timeout_ms * 1000000;
    int r = gpiod_line_request_wait_edge_events(g->req, tmo);
    if (r < 0) return vc_trigger_set_error(trig, -errno, "waiting for edge events: %s", strerror(errno));
    if (r == 0) return -ETIMEDOUT;
    int n = gpiod_line_request_read_edge_events(g->req, g->events, EVENT_BATCH);
    if (n < 0) return vc_trigger_set_error(trig, -errno, "reading edge events: %s", strerror(errno));
    g->nevents = n;
    g->next = 0;
  }
}

static int gpiod_fd(const void* p) {
  return gpiod_line_request_get_fd(((const struct gpiod_priv*)p)->req);
}

const vc_trigger_backend vc_trigger_backend_gpiod = {
    .name = "gpiod", .open = gpiod_open, .wait = gpiod_wait, .fd = gpiod_fd, .free_priv = gpiod_priv_free};
