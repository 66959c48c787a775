/* Frame/pulse pairing by timestamp; the rules are in pairing.h. Pending pulses are kept sorted by
 * time in a small array (tens of entries: linear scans beat any index), pending frames per camera in
 * arrival order, which for one camera is time order. */
#include "voxcap/edge/pairing.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "voxcap/why.h"
struct pulse_slot {
  uint64_t seq;
  uint64_t t;
  uint32_t have;   /* cameras whose frame matched */
  uint32_t missed; /* cameras known to have skipped it */
};

struct frame_slot {
  int64_t t_e; /* frame time minus the camera's latency: the pulse time it claims */
  uint64_t t;
  uint64_t cookie;
};

struct vc_pairer {
  vc_pairing_config cfg;
  vc_pair_cb cb;
  void* user;
  uint32_t all;
  struct pulse_slot* pulses;
  unsigned npulses;
  struct frame_slot* frames[VC_PAIR_MAX_CAMS];
  unsigned nframes[VC_PAIR_MAX_CAMS];
  bool have_last[VC_PAIR_MAX_CAMS];
  int64_t last_te[VC_PAIR_MAX_CAMS]; /* latest frame seen per camera (its claimed pulse time) */
  vc_pairing_stats st;
};

void vc_pairing_config_init(vc_pairing_config* cfg) {
  memset(cfg, 0, sizeof *cfg);
  cfg->ncams = 2;
  cfg->tolerance_ns = 4000000;
  cfg->max_delay_ns = 50000000;
}

int vc_pairing_config_check(const vc_pairing_config* cfg, char* why, size_t why_len) {
  const char* bad = NULL;
  if (!cfg)
    bad = "no config";
  else if (cfg->ncams < 1 || cfg->ncams > VC_PAIR_MAX_CAMS)
    bad = "ncams must be 1..4";
  else if (cfg->tolerance_ns == 0)
    bad = "tolerance must be > 0";
  else if (cfg->tolerance_ns > (uint64_t)INT64_MAX / 4 || cfg->max_delay_ns > (uint64_t)INT64_MAX / 4)
    bad = "tolerance / max_delay too large";
  else if (cfg->pulse_slots > VC_PAIR_MAX_SLOTS || cfg->frame_slots > VC_PAIR_MAX_SLOTS)
    bad = "pulse_slots / frame_slots must be at most 256";
  if (!bad) return 0;
  vc_why(why, why_len, "pairing config: %s", bad);
  return -EINVAL;
}

int vc_pairer_new(const vc_pairing_config* cfg, vc_pair_cb cb, void* user, vc_pairer** out, char* why,
                  size_t why_len) {
  vc_pairer* p;
  int rc;
  vc_why_clear(why, why_len);
  if (out) *out = NULL;
  if ((rc = vc_pairing_config_check(cfg, why, why_len)) < 0) return rc;
  if (!cb || !out) {
    vc_why(why, why_len, "pairer: %s", !cb ? "no pair callback" : "no out pointer");
    return -EINVAL;
  }
  p = calloc(1, sizeof *p);
  if (!p) goto err_nomem;
  p->cfg = *cfg;
  if (!p->cfg.pulse_slots) p->cfg.pulse_slots = 16;
  if (!p->cfg.frame_slots) p->cfg.frame_slots = 4;
  p->cb = cb;
  p->user = user;
  p->all = (1u << cfg->ncams) - 1;
  p->pulses = calloc(p->cfg.pulse_slots, sizeof *p->pulses);
  if (!p->pulses) goto err_nomem;
  for (unsigned c = 0; c < cfg->ncams; c++) {
    p->frames[c] = calloc(p->cfg.frame_slots, sizeof *p->frames[c]);
    if (!p->frames[c]) goto err_nomem;
  }
  *out = p;
  return 0;
err_nomem:
  vc_pairer_free(p);
  vc_why(why, why_len, "pairer: out of memory");
  return -ENOMEM;
}

void vc_pairer_free(vc_pairer* p) {
  if (!p) return;
  for (unsigned c = 0; c < VC_PAIR_MAX_CAMS; c++) free(p->frames[c]);
  free(p->pulses);
  free(p);
}

static int64_t abs64(int64_t v) {
  return v < 0 ? -v : v;
}

static void remove_pulse(vc_pairer* p, unsigned i) {
  memmove(&p->pulses[i], &p->pulses[i + 1], (p->npulses - i - 1) * sizeof *p->pulses);
  p->npulses--;
}

static void remove_frame(vc_pairer* p, unsigned cam, unsigned i) {
  memmove(&p->frames[cam][i], &p->frames[cam][i + 1], (p->nframes[cam] - i - 1) * sizeof *p->frames[cam]);
  p->nframes[cam]--;
}

/* Emits the pulse's outcome and removes it. */
static void resolve_pulse(vc_pairer* p, unsigned i) {
  struct pulse_slot s = p->pulses[i];
  vc_pair_event ev = {.seq = s.seq, .pulse_t_ns = s.t};
  uint32_t missing = p->all & ~s.have;
  remove_pulse(p, i);
  if (!missing) {
    ev.type = VC_PAIR_COMPLETE;
    p->st.complete++;
  } else {
    ev.type = VC_PAIR_PULSE_UNMATCHED;
    ev.missing_mask = missing;
    p->st.incomplete++;
    for (unsigned c = 0; c < p->cfg.ncams; c++)
      if (missing & (1u << c)) p->st.pulses_without_frame[c]++;
  }
  p->cb(p->user, &ev);
}

/* Resolves every pulse whose cameras are all accounted for. */
static void resolve_done(vc_pairer* p) {
  for (unsigned i = 0; i < p->npulses;) {
    if (((p->pulses[i].have | p->pulses[i].missed) & p->all) == p->all)
      resolve_pulse(p, i);
    else
      i++;
  }
}

static void frame_unmatched(vc_pairer* p, unsigned cam, unsigned i) {
  struct frame_slot f = p->frames[cam][i];
  vc_pair_event ev = {.type = VC_PAIR_FRAME_UNMATCHED, .cam = cam, .frame_t_ns = f.t, .cookie = f.cookie};
  remove_frame(p, cam, i);
  p->st.frames_without_pulse[cam]++;
  p->cb(p->user, &ev);
}

static void match(vc_pairer* p, unsigned cam, unsigned pi, const struct frame_slot* f) {
  struct pulse_slot* s = &p->pulses[pi];
  int64_t err = f->t_e - (int64_t)s->t;
  vc_pair_event ev = {.type = VC_PAIR_MATCHED,
                      .cam = cam,
                      .seq = s->seq,
                      .pulse_t_ns = s->t,
                      .frame_t_ns = f->t,
                      .cookie = f->cookie,
                      .error_ns = err};
  s->have |= 1u << cam;
  if (p->st.matched[cam] == 0 || err < p->st.error_min_ns[cam]) p->st.error_min_ns[cam] = err;
  if (p->st.matched[cam] == 0 || err > p->st.error_max_ns[cam]) p->st.error_max_ns[cam] = err;
  p->st.error_sum_ns[cam] += err;
  p->st.matched[cam]++;
  p->cb(p->user, &ev);
}

/* Index of the pending pulse nearest to t_e within tolerance that lacks cam, or -1. */
static int nearest_pulse(const vc_pairer* p, unsigned cam, int64_t t_e) {
  int best = -1;
  int64_t best_d = 0;
  for (unsigned i = 0; i < p->npulses; i++) {
    const struct pulse_slot* s = &p->pulses[i];
    if ((s->have | s->missed) & (1u << cam)) continue;
    int64_t d = abs64(t_e - (int64_t)s->t);
    if (d <= (int64_t)p->cfg.tolerance_ns && (best < 0 || d < best_d)) {
      best = (int)i;
      best_d = d;
    }
  }
  return best;
}

int vc_pairer_add_frame(vc_pairer* p, unsigned cam, uint64_t t_ns, uint64_t cookie) {
  if (!p || cam >= p->cfg.ncams) return -EINVAL;
  struct frame_slot f = {.t_e = (int64_t)t_ns - p->cfg.latency_ns[cam], .t = t_ns, .cookie = cookie};
  const int64_t tol = (int64_t)p->cfg.tolerance_ns;

  /* this camera's frames come in time order: pulses before this frame's window were skipped by it */
  for (unsigned i = 0; i < p->npulses; i++) {
    struct pulse_slot* s = &p->pulses[i];
    if (!(s->have & (1u << cam)) && (int64_t)s->t + tol < f.t_e) s->missed |= 1u << cam;
  }
  resolve_done(p);
  if (!p->have_last[cam] || f.t_e > p->last_te[cam]) p->last_te[cam] = f.t_e;
  p->have_last[cam] = true;

  int pi = nearest_pulse(p, cam, f.t_e);
  if (pi >= 0) {
    match(p, cam, (unsigned)pi, &f);
    resolve_done(p);
    return 0;
  }
  /* no pulse yet: wait for it */
  if (p->nframes[cam] == p->cfg.frame_slots) {
    p->st.overflow++;
    frame_unmatched(p, cam, 0);
  }
  p->frames[cam][p->nframes[cam]++] = f;
  return 0;
}

int vc_pairer_add_pulse(vc_pairer* p, uint64_t seq, uint64_t t_ns) {
  if (!p) return -EINVAL;
  const int64_t tol = (int64_t)p->cfg.tolerance_ns;
  for (unsigned i = 0; i < p->npulses; i++) {
    if (p->pulses[i].seq == seq) {
      p->st.duplicate_pulses++;
      return -EEXIST;
    }
  }
  if (p->npulses == p->cfg.pulse_slots) {
    p->st.overflow++;
    resolve_pulse(p, 0);
  }
  unsigned at = p->npulses;
  while (at > 0 && p->pulses[at - 1].t > t_ns) at--;
  memmove(&p->pulses[at + 1], &p->pulses[at], (p->npulses - at) * sizeof *p->pulses);
  p->npulses++;
  p->st.pulses++;
  struct pulse_slot* s = &p->pulses[at];
  *s = (struct pulse_slot){.seq = seq, .t = t_ns};

  for (unsigned c = 0; c < p->cfg.ncams; c++) {
    /* a frame waiting for this pulse: the nearest within tolerance */
    int best = -1;
    int64_t best_d = 0;
    for (unsigned i = 0; i < p->nframes[c]; i++) {
      int64_t d = abs64(p->frames[c][i].t_e - (int64_t)t_ns);
      if (d <= tol && (best < 0 || d < best_d)) {
        best = (int)i;
        best_d = d;
      }
    }
    if (best >= 0) {
      struct frame_slot f = p->frames[c][best];
      remove_frame(p, c, (unsigned)best);
      match(p, c, at, &f);
    } else if (p->have_last[c] && (int64_t)t_ns + tol < p->last_te[c]) {
      /* the camera is already past this pulse and left no frame for it */
      s->missed |= 1u << c;
    }
  }
  resolve_done(p);
  return 0;
}

void vc_pairer_advance(vc_pairer* p, uint64_t now_ns) {
  if (!p) return;
  const int64_t now = (int64_t)now_ns, tol = (int64_t)p->cfg.tolerance_ns,
                delay = (int64_t)p->cfg.max_delay_ns;
  for (unsigned c = 0; c < p->cfg.ncams; c++) {
    for (unsigned i = 0; i < p->nframes[c];) {
      if (now > p->frames[c][i].t_e + tol + delay)
        frame_unmatched(p, c, i);
      else
        i++;
    }
  }
  for (unsigned i = 0; i < p->npulses; i++) {
    struct pulse_slot* s = &p->pulses[i];
    for (unsigned c = 0; c < p->cfg.ncams; c++)
      if (!(s->have & (1u << c)) && now > (int64_t)s->t + p->cfg.latency_ns[c] + tol + delay)
        s->missed |= 1u << c;
  }
  resolve_done(p);
}

void vc_pairer_flush(vc_pairer* p) {
  if (!p) return;
  while (p->npulses) resolve_pulse(p, 0);
  for (unsigned c = 0; c < p->cfg.ncams; c++)
    while (p->nframes[c]) frame_unmatched(p, c, 0);
}

void vc_pairer_get_stats(const vc_pairer* p, vc_pairing_stats* stats) {
  if (p && stats) *stats = p->st;
}

unsigned vc_pairer_pending_pulses(const vc_pairer* p) {
  return p ? p->npulses : 0;
}
unsigned vc_pairer_pending_frames(const vc_pairer* p, unsigned cam) {
  return p && cam < p->cfg.ncams ? p->nframes[cam] : 0;
}
