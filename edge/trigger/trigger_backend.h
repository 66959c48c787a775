/* What a trigger backend implements, and the helpers it may use. Internal to edge/trigger. */
#ifndef VOXCAP_EDGE_TRIGGER_BACKEND_H
#define VOXCAP_EDGE_TRIGGER_BACKEND_H

#include <stdarg.h>

#include "voxcap/edge/trigger.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vc_trigger_backend {
  const char* name;
  /* Requests the line / binds the socket; fills info->source (and port). */
  int (*open)(vc_trigger* trig, const vc_trigger_config* cfg, vc_trigger_info* info, void** priv);
  /* Next pulse within timeout_ms; may update stats (lost, late, duplicate, invalid). */
  int (*wait)(vc_trigger* trig, void* priv, int timeout_ms, vc_pulse* pulse, vc_trigger_stats* stats);
  int (*fd)(const void* priv);
  void (*free_priv)(void* priv);
} vc_trigger_backend;

extern const vc_trigger_backend vc_trigger_backend_gpiod;
extern const vc_trigger_backend vc_trigger_backend_udp;

/* Records "<backend>: <source>: <message>" (source set from info once open succeeded or from the
 * config before) as the last error and returns code. */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
int vc_trigger_set_error(vc_trigger* trig, int code, const char* fmt, ...);
/* Sets the name the error messages use for the source before open has completed. */
void vc_trigger_set_source(vc_trigger* trig, const char* source);

/* Pure: udp sequence bookkeeping, a 64-pulse window of recently seen seqs. Unit-tested.
 * A forward jump of more than VC_SEQ_MAX_JUMP pulses is implausible (the host counts every pulse;
 * 1024 is 17 s at 60 Hz, far more than a loopback or LAN loses): the datagram is dropped, and only a
 * second one that follows it in sequence (within the window) moves the window there. So one forged
 * datagram (seq 100000) is never delivered, while a host that really skipped ahead is followed after
 * one pulse. A jump back stays what it was: a restarted host (VC_SEQ_RESTART). VC_SEQ_MAX_JUMP is in
 * voxcap/edge/trigger.h. */
typedef struct vc_seq_window {
  bool started;
  uint64_t highest; /* highest seq seen */
  uint64_t seen;    /* bit i: seq (highest - i) was seen */
  bool jumped;      /* a jump was dropped: jump_seq is where it went */
  uint64_t jump_seq;
} vc_seq_window;
typedef enum vc_seq_verdict {
  VC_SEQ_NEXT,      /* deliver: the next or a later seq (gaps counted as lost) */
  VC_SEQ_LATE,      /* deliver: an earlier seq counted lost before, arrived late (un-lose it) */
  VC_SEQ_DUPLICATE, /* drop: already seen */
  VC_SEQ_RESTART,   /* deliver: far below the window — the sender restarted its count; window reset */
  VC_SEQ_JUMP,      /* drop: more than VC_SEQ_MAX_JUMP above the window (or confirm a dropped one) */
} vc_seq_verdict;
/* Classifies seq; *lost_delta receives how the lost count changes (+gap, −1 for late, 0). */
vc_seq_verdict vc_seq_window_push(vc_seq_window* w, uint64_t seq, int64_t* lost_delta);

#ifdef __cplusplus
}
#endif
#endif
