/* The edge daemon's main loop: the host's commands and every complete frame pair, on the pipeline
 * thread (see edged.h). Capture is capture.c's; pairing and the queues are frameq.c's. */
#define _GNU_SOURCE
#include "edged.h"

#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture.h"
#include "log.h"
#include "node.h"
#include "voxcap/edge/clock.h"

#define INBOUND 8

typedef struct ctl {
  uint16_t type;
  uint64_t seq;
  uint32_t frames;
  vc_config cfg;
  vc_grab grab; /* GRAB (2.4) */
} ctl;

typedef struct edged {
  const vc_edged_options* opt;
  vc_capture* cap;
  pthread_mutex_t mu; /* the inbound commands */
  ctl inbound[INBOUND];
  unsigned in_head, in_count;
  vc_node* node;
  atomic_uint node_state;
  vc_link* link;
  uint64_t hulls_sent, frame_sum_ns, frame_max_ns, frame_n; /* pipeline thread */
  uint64_t silhouettes_sent, silhouettes_dropped;           /* pipeline thread: queued / no room */
  uint64_t frames_sent, frames_dropped;                     /* pipeline thread: FRAMEs queued / no room */
} edged;

static atomic_bool g_stop;
void vc_edged_request_stop(void) {
  atomic_store(&g_stop, true);
}

static uint64_t mono_ms(void) {
  return vc_clock_monotonic_ns() / 1000000u;
}

static void send_error(edged* d, uint32_t code, uint16_t severity, uint16_t about, const char* fmt, ...)
    __attribute__((format(printf, 5, 6)));
static void send_error(edged* d, uint32_t code, uint16_t severity, uint16_t about, const char* fmt, ...) {
  char text[VC_PROTO_MAX_ERROR_TEXT];
  va_list ap;
  va_start(ap, fmt);
  int n = vsnprintf(text, sizeof(text), fmt, ap);
  va_end(ap);
  if (n < 0) return;
  vc_log(severity == VC_SEVERITY_WARNING ? VC_LOG_WARN : VC_LOG_ERROR, "%s", text);
  if (!d->link) return;
  uint8_t buf[VC_PROTO_HEADER_SIZE + 16 + VC_PROTO_MAX_ERROR_TEXT];
  size_t len = 0;
  vc_header hdr = {.node_id = d->opt->node_id};
  vc_error e = {.code = code,
                .severity = severity,
                .about_type = about,
                .text_len = (uint16_t)((size_t)n < sizeof(text) ? (size_t)n : sizeof(text) - 1),
                .text = text};
  if (vc_encode_error(buf, sizeof(buf), &len, &hdr, &e) == 0) vc_link_send(d->link, buf, len);
}

/* ---- the capture's callbacks (capture threads) ---------------------------------------------------- */

static void capture_error(void* user, uint32_t code, const char* text) {
  send_error(user, code, VC_SEVERITY_ERROR, 0, "%s", text);
}

/* ---- the link's callbacks (link thread) ---------------------------------------------------------- */

static void on_message(void* user, const vc_msg* m) {
  edged* d = user;
  if (!m->known) {
    vc_log(VC_LOG_INFO, "ignoring a message of unknown type %u from the host", m->hdr.type);
    return;
  }
  switch (m->hdr.type) {
    case VC_MSG_CONFIG:
    case VC_MSG_BACKGROUND:
    case VC_MSG_START:
    case VC_MSG_STOP:
    case VC_MSG_GRAB:
      break;
    case VC_MSG_HEARTBEAT:
      return;
    case VC_MSG_ERROR:
      vc_log(VC_LOG_WARN, "host says: %.*s", (int)m->u.error.text_len, m->u.error.text);
      return;
    default:
      vc_log(VC_LOG_WARN, "unexpected %s from the host", vc_msg_type_name(m->hdr.type));
      return;
  }
  pthread_mutex_lock(&d->mu);
  if (d->in_count == INBOUND) {
    pthread_mutex_unlock(&d->mu);
    vc_log(VC_LOG_ERROR, "too many host commands pending; dropping %s", vc_msg_type_name(m->hdr.type));
    return;
  }
  ctl* c = &d->inbound[(d->in_head + d->in_count) % INBOUND];
  c->type = m->hdr.type;
  c->seq = m->hdr.seq;
  if (m->hdr.type == VC_MSG_CONFIG) c->cfg = m->u.config;
  if (m->hdr.type == VC_MSG_BACKGROUND) c->frames = m->u.background.frame_count;
  if (m->hdr.type == VC_MSG_GRAB) c->grab = m->u.grab;
  d->in_count++;
  pthread_mutex_unlock(&d->mu);
  vc_capture_wake(d->cap);
}

static void on_connection(void* user, bool up) {
  edged* d = user;
  vc_log(up ? VC_LOG_INFO : VC_LOG_WARN, "host connection %s", up ? "up" : "down");
  (void)d;
}

static uint32_t node_state_cb(void* user) {
  edged* d = user;
  return atomic_load(&d->node_state);
}

/* ---- the pipeline thread ------------------------------------------------------------------------- */

/* Publishes the node state and, when it changed, tells the host at once (a HEARTBEAT out of turn):
 * the host drives the session on these changes, and waiting for the periodic heartbeat would add up
 * to a heartbeat period to every step of a (re)join. */
static void publish_state(edged* d) {
  uint32_t st = vc_node_state(d->node);
  if (atomic_exchange(&d->node_state, st) == st || !d->link) return;
  uint8_t buf[VC_PROTO_HEADER_SIZE + 32];
  size_t len = 0;
  vc_header hdr = {.node_id = d->opt->node_id};
  vc_heartbeat hb = {.sender_time_ns = vc_clock_monotonic_ns(), .state = st};
  if (vc_encode_heartbeat(buf, sizeof(buf), &len, &hdr, &hb) == 0) vc_link_send(d->link, buf, len);
}

static void handle_ctl(edged* d, ctl* c) {
  char why[256] = "", warn[256] = "";
  int rc;
  switch (c->type) {
    case VC_MSG_CONFIG:
      if (vc_capture_get_phase(d->cap) != VC_CAPTURE_IDLE) vc_capture_set_phase(d->cap, VC_CAPTURE_IDLE, 0);
      rc = vc_node_configure(d->node, &c->cfg, why, sizeof(why), warn, sizeof(warn));
      if (rc < 0) {
        send_error(d, VC_ERR_CONFIG, VC_SEVERITY_ERROR, VC_MSG_CONFIG, "CONFIG rejected: %s", why);
      } else {
        if (warn[0]) send_error(d, VC_ERR_CONFIG, VC_SEVERITY_WARNING, VC_MSG_CONFIG, "%s", warn);
        vc_log(VC_LOG_INFO,
               "configured: grid %ux%ux%u (id %u), %s carving, a SILHOUETTE every %u frames (0: none) at "
               "scale %u",
               c->cfg.grid.nx, c->cfg.grid.ny, c->cfg.grid.nz, c->cfg.grid_id,
               vc_carve_rule_name(c->cfg.carve_rule), c->cfg.silhouette_every, c->cfg.silhouette_scale);
      }
      break;
    case VC_MSG_BACKGROUND:
      rc = vc_node_background_begin(d->node, c->frames);
      if (rc < 0) {
        send_error(d, VC_ERR_STATE, VC_SEVERITY_ERROR, VC_MSG_BACKGROUND, "BACKGROUND before CONFIG");
        break;
      }
      vc_capture_set_phase(d->cap, VC_CAPTURE_BACKGROUND, vc_capture_last_pulse_seq(d->cap) + 1);
      vc_log(VC_LOG_INFO, "learning the background");
      break;
    case VC_MSG_START:
      rc = vc_node_start(d->node, c->seq);
      if (rc < 0) {
        send_error(d, VC_ERR_STATE, VC_SEVERITY_ERROR, VC_MSG_START,
                   "START before the background was learnt");
        break;
      }
      vc_capture_set_phase(d->cap, VC_CAPTURE_RUNNING, c->seq);
      vc_log(VC_LOG_INFO, "running from seq %llu", (unsigned long long)c->seq);
      break;
    case VC_MSG_GRAB:
      rc = vc_node_grab(d->node, &c->grab, c->seq, why, sizeof(why));
      if (rc == -EAGAIN) {
        send_error(d, VC_ERR_STATE, VC_SEVERITY_ERROR, VC_MSG_GRAB, "%s", why);
      } else if (rc < 0) {
        send_error(d, rc == -ENOMEM ? VC_ERR_INTERNAL : VC_ERR_CAMERA, VC_SEVERITY_ERROR, VC_MSG_GRAB, "%s",
                   why);
      }
      if (rc != -EAGAIN && c->grab.every == 0)
        vc_log(VC_LOG_INFO, "GRAB: no more FRAMEs");
      else if (vc_node_grabbing(d->node))
        vc_log(VC_LOG_INFO, "GRAB: %s FRAMEs of every %u-th frame from seq %llu (%u frames; 0: no end)",
               vc_frame_format_name(c->grab.format), c->grab.every, (unsigned long long)c->seq,
               c->grab.count);
      break;
    case VC_MSG_STOP:
      vc_node_stop(d->node);
      vc_capture_set_phase(d->cap, VC_CAPTURE_IDLE, 0);
      vc_log(VC_LOG_INFO, "stopped");
      break;
  }
  publish_state(d);
}

static void handle_work(edged* d, const vc_capture_pair* p) {
  const vc_frame_pair* w = &p->pair;
  const uint8_t* const* rgb = p->rgb;
  const size_t* stride = p->stride;
  uint32_t st = vc_node_state(d->node);
  if (st == VC_STATE_BACKGROUND) {
    int rc = vc_node_background_add(d->node, rgb, stride);
    if (rc == 1) {
      vc_log(VC_LOG_INFO, "background learnt");
      if (d->opt->state_dir) {
        int src = vc_node_save_background(d->node, d->opt->state_dir);
        if (src < 0)
          vc_log(VC_LOG_WARN, "cannot keep the background model in %s: %s", d->opt->state_dir,
                 strerror(-src));
      }
      vc_capture_set_phase(d->cap, VC_CAPTURE_IDLE, 0);
    } else if (rc < 0) {
      send_error(d, VC_ERR_INTERNAL, VC_SEVERITY_ERROR, VC_MSG_BACKGROUND, "background learning failed: %s",
                 strerror(-rc));
    }
  } else if (st == VC_STATE_RUNNING) {
    vc_node_output out;
    int rc = vc_node_process_frame(d->node, w->seq, w->t_ns, rgb, stride, &out);
    if (rc == 0) {
      /* the frame's FEATURES and SILHOUETTEs, then its HULL (the last: the host resolves a frame on it) */
      for (int i = 0; i < out.count; i++) {
        if (out.type[i] == VC_MSG_HULL) {
          if (vc_link_send(d->link, out.msg[i], out.len[i]) == 0) d->hulls_sent++;
          uint64_t lat = vc_clock_monotonic_ns() - w->t_ns; /* the frame stage: trigger edge -> HULL queued */
          d->frame_sum_ns += lat;
          if (lat > d->frame_max_ns) d->frame_max_ns = lat;
          d->frame_n++;
        } else if (out.type[i] != VC_MSG_SILHOUETTE) {
          vc_link_send(d->link, out.msg[i], out.len[i]);
        } else if (vc_link_send_if_room(d->link, out.msg[i], out.len[i]) == 0) { /* never costs a HULL */
          d->silhouettes_sent++;
        } else {
          d->silhouettes_dropped++;
        }
      }
      /* GRAB (2.4): the frame's camera images after its HULL, only where the queue stays half empty
       * (never at a HULL's cost, never waited for); what finds no room is counted. */
      int k = vc_node_frames(d->node, w->seq, w->t_ns, rgb, stride, &out);
      for (int i = 0; i < k; i++) {
        if (vc_link_send_if_room(d->link, out.msg[i], out.len[i]) == 0)
          d->frames_sent++;
        else
          d->frames_dropped++;
      }
    } else if (rc < 0 && rc != -EAGAIN) {
      send_error(d, VC_ERR_OVERLOAD, VC_SEVERITY_WARNING, 0, "frame %llu not sent: %s",
                 (unsigned long long)w->seq, vc_proto_strerror(rc));
    }
  }
  publish_state(d);
}

/* Appends a stage record (mean and max over n frames) and resets the accumulators. */
static void put_stage(vc_stats* s, int* k, uint32_t id, uint64_t* sum_ns, uint64_t* max_ns, uint64_t* n) {
  if (*n == 0) return;
  uint64_t mean = *sum_ns / *n;
  s->stages[*k].stage_id = id;
  s->stages[*k].mean_ns = mean > UINT32_MAX ? UINT32_MAX : (uint32_t)mean;
  s->stages[*k].max_ns = *max_ns > UINT32_MAX ? UINT32_MAX : (uint32_t)*max_ns;
  (*k)++;
  *sum_ns = *max_ns = *n = 0;
}

static void send_stats(edged* d) {
  vc_stats s;
  memset(&s, 0, sizeof(s));
  int k = vc_node_take_stage_times(d->node, s.stages, VC_PROTO_MAX_STAGES - 2, &s.frames);
  uint64_t capture_sum_ns, capture_max_ns, capture_n;
  vc_capture_take_capture_time(d->cap, &capture_sum_ns, &capture_max_ns, &capture_n);
  put_stage(&s, &k, VC_STAGE_CAPTURE, &capture_sum_ns, &capture_max_ns, &capture_n);
  put_stage(&s, &k, VC_STAGE_FRAME, &d->frame_sum_ns, &d->frame_max_ns, &d->frame_n);
  s.stage_count = (uint16_t)k;
  vc_capture_stats cs;
  vc_node_counters nc;
  vc_link_stats ls;
  vc_capture_get_stats(d->cap, &cs);
  const vc_pairing_stats* ps = &cs.queue.pairing;
  uint64_t frames = cs.frames[0] + cs.frames[1];
  uint64_t cam_errors = cs.errors[0] + cs.errors[1];
  uint64_t drops = cs.queue.work_drops + cs.queue.slot_drops[0] + cs.queue.slot_drops[1];
  vc_node_get_counters(d->node, &nc);
  vc_link_get_stats(d->link, &ls);
  struct {
    uint32_t id;
    uint64_t v;
  } c[] = {
      {VC_COUNTER_FRAMES_CAPTURED, frames},
      {VC_COUNTER_HULLS_SENT, d->hulls_sent},
      {VC_COUNTER_SEND_QUEUE_DROPS, ls.queue_dropped + drops},
      {VC_COUNTER_FRAMES_WITHOUT_PULSE, ps->frames_without_pulse[0] + ps->frames_without_pulse[1]},
      {VC_COUNTER_PULSES_WITHOUT_FRAME, ps->pulses_without_frame[0] + ps->pulses_without_frame[1]},
      {VC_COUNTER_HULLS_OVER_LIMIT, nc.hulls_over_limit},
      {VC_COUNTER_CAMERA_ERRORS, cam_errors},
      {VC_COUNTER_SILHOUETTES_SENT, d->silhouettes_sent},
      {VC_COUNTER_SILHOUETTES_DROPPED, d->silhouettes_dropped + nc.silhouettes_over_limit},
      {VC_COUNTER_FRAMES_SENT, d->frames_sent},
      {VC_COUNTER_FRAMES_DROPPED, d->frames_dropped},
  };
  for (size_t i = 0; i < sizeof(c) / sizeof(c[0]); i++) {
    s.counters[i].counter_id = c[i].id;
    s.counters[i].value = c[i].v;
  }
  s.counter_count = (uint16_t)(sizeof(c) / sizeof(c[0]));
  uint8_t buf[VC_PROTO_HEADER_SIZE + 1024];
  size_t len = 0;
  vc_header hdr = {.node_id = d->opt->node_id};
  if (vc_encode_stats(buf, sizeof(buf), &len, &hdr, &s) == 0) vc_link_send(d->link, buf, len);
}

static uint32_t fourcc_of(vc_pixfmt f) {
  switch (f) {
    case VC_PIXFMT_YUYV:
      return VC_FOURCC('Y', 'U', 'Y', 'V');
    case VC_PIXFMT_UYVY:
      return VC_FOURCC('U', 'Y', 'V', 'Y');
    case VC_PIXFMT_GREY:
      return VC_FOURCC('G', 'R', 'E', 'Y');
    case VC_PIXFMT_BGR24:
      return VC_FOURCC('B', 'G', 'R', '3');
    default:
      return VC_FOURCC('R', 'G', 'B', '3');
  }
}

static void teardown(edged* d) {
  vc_capture_free(d->cap); /* its threads report through the link: stopped first */
  vc_link_free(d->link);
  vc_node_free(d->node);
  pthread_mutex_destroy(&d->mu);
}

/* Opens trigger and cameras (the capture), the node and the link to the host. */
static int setup(edged* d) {
  const vc_edged_options* opt = d->opt;
  char why[256] = "";
  int rc;
  vc_capture_options co;
  memset(&co, 0, sizeof(co));
  for (int c = 0; c < 2; c++) co.cameras[c] = opt->cameras[c];
  co.trigger = &opt->trigger;
  vc_pairing_config_init(&co.pairing);
  if (opt->pair_tolerance_ns) co.pairing.tolerance_ns = opt->pair_tolerance_ns;
  if (opt->pair_max_delay_ns) co.pairing.max_delay_ns = opt->pair_max_delay_ns;
  for (int c = 0; c < 2; c++) co.pairing.latency_ns[c] = opt->camera_latency_ns[c];
  co.frame_slots = opt->frame_slots;
  co.camera_timeout_ms = opt->camera_timeout_ms;
  vc_capture_callbacks ccb = {.error = capture_error, .user = d};
  if ((rc = vc_capture_new(&co, &ccb, &d->cap, why, sizeof(why))) < 0) {
    vc_log(VC_LOG_ERROR, "%s", why);
    return rc;
  }
  vc_trigger_info ti;
  vc_capture_get_trigger_info(d->cap, &ti);
  vc_log(VC_LOG_INFO, "trigger: %s %s", ti.backend, ti.source);

  vc_node_camera ncam[2];
  for (int c = 0; c < 2; c++) {
    vc_camera_info ci;
    vc_capture_get_camera_info(d->cap, c, &ci);
    ncam[c].width = ci.width;
    ncam[c].height = ci.height;
    ncam[c].pixel_format = fourcc_of(ci.pixfmt);
    ncam[c].max_fps_milli =
        ci.fps_num ? (uint32_t)((uint64_t)ci.fps_num * 1000u / (ci.fps_den ? ci.fps_den : 1)) : 0;
    vc_log(VC_LOG_INFO, "camera %d: %s %s %dx%d (%s)", c, ci.backend, ci.device, ci.width, ci.height,
           ci.driver);
  }

  if ((rc = vc_node_new(opt->node_id, ncam, &d->node, why, sizeof(why))) < 0) {
    vc_log(VC_LOG_ERROR, "%s", why);
    return rc;
  }
  if (opt->features) vc_node_set_features_producer(d->node, opt->features);
  if (opt->state_dir) {
    int lrc = vc_node_load_background(d->node, opt->state_dir, why, sizeof(why));
    if (lrc == 0)
      vc_log(VC_LOG_INFO, "restored the background model kept in %s", opt->state_dir);
    else if (lrc != -ENOENT)
      vc_log(VC_LOG_WARN, "not restoring the background model: %s", why);
  }
  atomic_store(&d->node_state, vc_node_state(d->node));
  uint8_t hello[VC_PROTO_HEADER_SIZE + 256];
  size_t hello_len = 0;
  uint32_t caps =
      VC_CAP_HULL | (strcmp(opt->trigger.backend, "udp") == 0 ? VC_CAP_UDP_TRIGGER : VC_CAP_GPIO_TRIGGER);
  if (opt->features) caps |= VC_CAP_FEATURES;
  if (opt->link.key) caps |= VC_CAP_AUTH;
  if ((rc = vc_node_hello(d->node, caps, hello, sizeof(hello), &hello_len)) < 0) return rc;
  vc_link_config lc = opt->link;
  lc.node_id = opt->node_id;
  vc_link_callbacks cb = {
      .on_message = on_message, .on_connection = on_connection, .state = node_state_cb, .user = d};
  if ((rc = vc_link_new(&lc, &cb, hello, hello_len, &d->link, why, sizeof(why))) < 0) {
    vc_log(VC_LOG_ERROR, "%s", why);
    return rc;
  }
  return vc_capture_start(d->cap);
}

int vc_edged_run(const vc_edged_options* opt) {
  vc_log_set_level(vc_log_level_from_verbosity(opt->verbosity));
  edged* d = calloc(1, sizeof(*d));
  if (!d) return -ENOMEM;
  d->opt = opt;
  pthread_mutex_init(&d->mu, NULL);
  int rc = setup(d);
  if (rc < 0) goto out;

  int stats_ms = opt->stats_ms ? opt->stats_ms : 1000;
  uint64_t last_stats = mono_ms();
  while (!atomic_load(&g_stop)) {
    /* The host's commands come first; else the next frame pair (waiting up to 10 ms for one). */
    pthread_mutex_lock(&d->mu);
    bool have_ctl = d->in_count > 0;
    ctl c;
    if (have_ctl) {
      c = d->inbound[d->in_head];
      d->in_head = (d->in_head + 1) % INBOUND;
      d->in_count--;
    }
    pthread_mutex_unlock(&d->mu);
    if (have_ctl) {
      handle_ctl(d, &c);
    } else {
      vc_capture_pair p;
      if (vc_capture_next(d->cap, 10, &p)) {
        handle_work(d, &p);
        vc_capture_done(d->cap, &p);
      }
    }
    if (mono_ms() - last_stats >= (uint64_t)stats_ms) {
      if (vc_link_connected(d->link)) send_stats(d);
      last_stats = mono_ms();
    }
  }
  rc = 0;
  {
    vc_capture_stats cs;
    vc_capture_get_stats(d->cap, &cs);
    vc_log(VC_LOG_INFO,
           "stopping: frames %llu + %llu, pulses %llu (complete %llu, incomplete %llu), emulated exposures "
           "missed %llu + %llu, hulls sent %llu",
           (unsigned long long)cs.frames[0], (unsigned long long)cs.frames[1],
           (unsigned long long)cs.queue.pairing.pulses, (unsigned long long)cs.queue.pairing.complete,
           (unsigned long long)cs.queue.pairing.incomplete, (unsigned long long)cs.missed_pulses[0],
           (unsigned long long)cs.missed_pulses[1], (unsigned long long)d->hulls_sent);
  }
out:
  teardown(d);
  free(d);
  return rc;
}

int vc_edged_check(const vc_edged_options* opt) {
  int failures = 0;
  char why[256];
  for (int c = 0; c < 2; c++) {
    vc_camera* cam = NULL;
    why[0] = '\0';
    int rc = vc_camera_open(&opt->cameras[c], &cam, why, sizeof(why));
    if (rc < 0) {
      printf("camera %d: FAIL %s\n", c, why);
      failures++;
      continue;
    }
    vc_camera_info ci;
    vc_camera_get_info(cam, &ci);
    printf("camera %d: ok %s %s %dx%d %s (%s)\n", c, ci.backend, ci.device, ci.width, ci.height,
           vc_pixfmt_name(ci.pixfmt) ? vc_pixfmt_name(ci.pixfmt) : "?", ci.driver);
    vc_camera_free(cam);
  }
  vc_trigger* trig = NULL;
  why[0] = '\0';
  if (vc_trigger_open(&opt->trigger, &trig, why, sizeof(why)) < 0) {
    printf("trigger: FAIL %s\n", why);
    failures++;
  } else {
    vc_trigger_info ti;
    vc_trigger_get_info(trig, &ti);
    printf("trigger: ok %s %s\n", ti.backend, ti.source);
    vc_trigger_free(trig);
  }
  printf("host: %s:%u\n", opt->link.host, opt->link.port);
  return failures ? -EINVAL : 0;
}
