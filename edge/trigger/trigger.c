/* The common layer behind vc_trigger (state, stats, errors), the backend table, and the udp
 * sequence window (pure). */
#define _GNU_SOURCE
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trigger_backend.h"
#include "voxcap/why.h"

struct vc_trigger {
  const vc_trigger_backend* be;
  void* priv;
  vc_trigger_info info;
  vc_trigger_stats stats;
  char source[128];
  int err;
  char errmsg[512];
};

static const vc_trigger_backend* const backends[] = {&vc_trigger_backend_gpiod, &vc_trigger_backend_udp};
static const char* const names[] = {"gpiod", "udp", NULL};

const char* const* vc_trigger_backend_names(void) {
  return names;
}

void vc_trigger_config_init(vc_trigger_config* cfg) {
  memset(cfg, 0, sizeof *cfg);
  cfg->event_clock = VC_CLOCK_MONOTONIC;
}

int vc_trigger_set_error(vc_trigger* trig, int code, const char* fmt, ...) {
  char msg[320];
  va_list ap;
  va_start(ap, fmt);
  vc_whyv(msg, sizeof msg, fmt, ap);
  va_end(ap);
  trig->err = code;
  if (trig->source[0])
    vc_why(trig->errmsg, sizeof trig->errmsg, "%s: %s: %s", trig->be->name, trig->source, msg);
  else
    vc_why(trig->errmsg, sizeof trig->errmsg, "%s: %s", trig->be->name, msg);
  return code;
}

void vc_trigger_set_source(vc_trigger* trig, const char* source) {
  snprintf(trig->source, sizeof trig->source, "%s", source ? source : "");
}

int vc_trigger_open(const vc_trigger_config* cfg, vc_trigger** out, char* why, size_t why_len) {
  const vc_trigger_backend* be = NULL;
  vc_trigger* trig;
  int rc;
  if (out) *out = NULL;
  vc_why_clear(why, why_len);
  if (!cfg || !out) {
    vc_why(why, why_len, "trigger: invalid arguments");
    return -EINVAL;
  }
  for (size_t i = 0; cfg->backend && i < sizeof backends / sizeof backends[0]; i++)
    if (strcmp(backends[i]->name, cfg->backend) == 0) be = backends[i];
  if (!be) {
    vc_why(why, why_len, "trigger config: %s backend%s%s%s (one of gpiod, udp)",
           cfg->backend ? "unknown" : "no", cfg->backend ? " '" : "", cfg->backend ? cfg->backend : "",
           cfg->backend ? "'" : " given");
    return -EINVAL;
  }
  if (!vc_clock_name(cfg->event_clock) || cfg->event_clock == VC_CLOCK_BOOTTIME) {
    vc_why(why, why_len, "trigger config: event_clock must be monotonic or realtime");
    return -EINVAL;
  }
  trig = calloc(1, sizeof *trig);
  if (!trig) {
    vc_why(why, why_len, "%s: out of memory", be->name);
    return -ENOMEM;
  }
  trig->be = be;
  trig->info.backend = be->name;
  rc = be->open(trig, cfg, &trig->info, &trig->priv);
  if (rc) {
    if (!trig->err) vc_trigger_set_error(trig, rc, "open failed: %s", strerror(-rc));
    vc_why(why, why_len, "%s", trig->errmsg);
    free(trig);
    return rc;
  }
  vc_trigger_set_source(trig, trig->info.source);
  *out = trig;
  return 0;
}

int vc_trigger_wait(vc_trigger* trig, int timeout_ms, vc_pulse* pulse) {
  int rc;
  if (!trig || !pulse) return -EINVAL;
  trig->err = 0;
  trig->errmsg[0] = '\0';
  rc = trig->be->wait(trig, trig->priv, timeout_ms, pulse, &trig->stats);
  if (rc == 0)
    trig->stats.pulses++;
  else if (!trig->err)
    vc_trigger_set_error(trig, rc, "%s",
                         rc == -ETIMEDOUT ? "no trigger pulse within the timeout" : strerror(-rc));
  return rc;
}

int vc_trigger_fd(const vc_trigger* trig) {
  return trig ? trig->be->fd(trig->priv) : -1;
}

void vc_trigger_free(vc_trigger* trig) {
  if (!trig) return;
  trig->be->free_priv(trig->priv);
  free(trig);
}

const char* vc_trigger_last_error(const vc_trigger* trig) {
  return trig ? trig->errmsg : "";
}
int vc_trigger_last_errno(const vc_trigger* trig) {
  return trig ? trig->err : 0;
}
void vc_trigger_get_info(const vc_trigger* trig, vc_trigger_info* info) {
  if (trig && info) *info = trig->info;
}
void vc_trigger_get_stats(const vc_trigger* trig, vc_trigger_stats* stats) {
  if (trig && stats) *stats = trig->stats;
}

vc_seq_verdict vc_seq_window_push(vc_seq_window* w, uint64_t seq, int64_t* lost_delta) {
  *lost_delta = 0;
  if (!w->started || (seq < w->highest && w->highest - seq >= 64)) {
    vc_seq_verdict v = w->started ? VC_SEQ_RESTART : VC_SEQ_NEXT;
    w->started = true;
    w->jumped = false;
    w->highest = seq;
    w->seen = 1;
    return v;
  }
  if (seq > w->highest && seq - w->highest > VC_SEQ_MAX_JUMP) {
    /* Implausible unless it continues a jump dropped just before: then the sender really moved. */
    bool confirmed = w->jumped && seq > w->jump_seq && seq - w->jump_seq < 64;
    w->jumped = !confirmed;
    w->jump_seq = seq;
    if (!confirmed) return VC_SEQ_JUMP;
    w->highest = seq;
    w->seen = 1;
    return VC_SEQ_RESTART;
  }
  w->jumped = false;
  if (seq > w->highest) {
    uint64_t step = seq - w->highest;
    *lost_delta = (int64_t)(step - 1);
    w->seen = step >= 64 ? 0 : w->seen << step;
    w->seen |= 1;
    w->highest = seq;
    return VC_SEQ_NEXT;
  }
  uint64_t bit = 1ull << (w->highest - seq);
  if (w->seen & bit) return VC_SEQ_DUPLICATE;
  w->seen |= bit;
  *lost_delta = -1;
  return VC_SEQ_LATE;
}
