/* vc_node: what an edge node does with the host's commands and its frame pairs, free of sockets and
 * devices so that it can be tested frame by frame.
 *
 *   IDLE --CONFIG--> CONFIGURED --BACKGROUND--> BACKGROUND --n frames--> READY --START--> RUNNING
 *                                                                          ^----STOP-------'
 * CONFIG may come again at any time (it returns the node to CONFIGURED, keeping a learnt background
 * when the cameras' sizes did not change, so a node that rejoins does not need the empty scene again).
 *
 * Per frame in RUNNING: subtraction (eq. 1–2) and clean-up for both cameras, partial hull carving,
 * and the HULL message encoded straight from the bitset into the node's own buffer. Everything per
 * frame is allocation-free; CONFIG allocates (background models, carver, buffers).
 *
 * A node has exactly two cameras (one partial hull from two views, DESIGN.md). Not thread-safe: one
 * thread (the edge's pipeline thread) drives it.
 */
#ifndef VOXCAP_EDGE_NODE_H
#define VOXCAP_EDGE_NODE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "voxcap/proto.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VC_NODE_CAMS 2

typedef struct vc_node vc_node;

typedef struct vc_node_camera {
  int width, height;     /* what the camera delivers (RGB24 after conversion) */
  uint32_t pixel_format; /* FourCC of the device's native format, as HELLO reports it */
  uint32_t max_fps_milli;
} vc_node_camera;

/* A node with id node_id and the two cameras described (copied); *out owns it (vc_node_free).
 * 0, -EINVAL or -ENOMEM with *out = NULL and a one-line reason in why (if given). */
int vc_node_new(uint16_t node_id, const vc_node_camera cams[VC_NODE_CAMS], vc_node** out, char* why,
                size_t why_len);
void vc_node_free(vc_node* node); /* NULL is a no-op */

/* The node's HELLO (written to buf, as vc_encode_hello). capabilities: VC_CAP_*. */
int vc_node_hello(const vc_node* node, uint32_t capabilities, uint8_t* buf, size_t cap, size_t* len);

/* Applies a CONFIG: the carver is built with its carve_rule (vc_carver_new says why a rule it cannot
 * run is refused), the SILHOUETTE buffers when silhouette_every > 0. On failure (-EINVAL: cameras
 * disagree with HELLO, bad thresholds, grid or carve rule; -ENOMEM) the node keeps its previous configuration
 * and why says what was wrong. On success *warning is set (non-empty) when part of the grid is seen by
 * neither camera. */
int vc_node_configure(vc_node* node, const vc_config* cfg, char* why, size_t why_len, char* warning,
                      size_t warning_len);

/* BACKGROUND: learn from the next `frames` frame pairs (0: CONFIG's background_frames). -EAGAIN
 * before CONFIG. */
int vc_node_background_begin(vc_node* node, uint32_t frames);
/* One frame pair of the empty scene. Returns 1 when the model is complete (node READY), 0 when more
 * frames are wanted, or a negative code (-EAGAIN when not learning). */
int vc_node_background_add(vc_node* node, const uint8_t* const rgb[VC_NODE_CAMS],
                           const size_t stride[VC_NODE_CAMS]);

/* Background persistence. An edge that restarts mid-session cannot learn the empty scene again with
 * the performer in it, so the learnt model is kept in dir/background-cam<k>.vcbg (little-endian:
 * "VCBG", u32 version 1, u32 width, u32 height, u32 frames, u32 CRC32C of what follows, then the mean
 * (u8) and sigma (u16 Q8.8) images, RGB interleaved). save: 0 or a negative errno (-EAGAIN when no
 * model is learnt). load: 0 when both cameras' models were restored (a later CONFIG then makes the node
 * READY without BACKGROUND), -ENOENT when there is none, -EINVAL when a file is corrupt or its size does
 * not match the camera (why says which), other negative errno on I/O errors. */
int vc_node_save_background(const vc_node* node, const char* dir);
int vc_node_load_background(vc_node* node, const char* dir, char* why, size_t why_len);

/* START: stream frames with seq >= first_seq. -EAGAIN unless READY (or already RUNNING). */
int vc_node_start(vc_node* node, uint64_t first_seq);
/* STOP: back to READY. */
void vc_node_stop(vc_node* node);

/* Feature tracking on nodes with a tracking role (CONFIG's feature_role FRONT): the tracker (a later
 * issue) fills this hook, the node runs it on every processed frame after the hull and turns what it
 * returns into one FEATURES message per camera for the same seq. */
typedef struct vc_features_producer {
  /* Tracks head, hands and feet in one frame pair: rgb/stride the frames, mask the node's silhouettes
   * (cams[c].width x height bytes, 0/255) before the limb-scale cue: the clean-up's foreground only,
   * without the rim the cue grows for the carver (edge/core bgmodel.h: VC_MASK_GROWN). Fills out[0..n-1]
   * (camera, feature_count, features) and returns n (0..VC_NODE_CAMS), or a negative errno (the frame's HULL
   * is still sent). Runs on the pipeline thread; everything it is given is valid during the call only. */
  int (*track)(void* user, uint64_t seq, const uint8_t* const rgb[VC_NODE_CAMS],
               const size_t stride[VC_NODE_CAMS], const uint8_t* const mask[VC_NODE_CAMS],
               const vc_node_camera cams[VC_NODE_CAMS], vc_features out[VC_NODE_CAMS]);
  void* user;
  /* Optional (NULL: none): called at every START, before its first frame, so the tracker initializes
   * anew (the performer stands in the init pose again). */
  void (*reset)(void* user);
} vc_features_producer;

/* Installs (copied) or removes (NULL) the features producer. */
void vc_node_set_features_producer(vc_node* node, const vc_features_producer* producer);

/* What one frame gives the host, in the order to send: FEATURES per camera, then (on frames whose seq
 * is a multiple of CONFIG's silhouette_every) one SILHOUETTE per camera, then the HULL, last because
 * the host resolves a frame when its last HULL arrives (proto/SPEC.md, HULL). type[i] is
 * msg[i]'s message type: the sender queues SILHOUETTEs only where they cost no HULL its place. The
 * messages live in the node's buffers, valid until the next call on the node. */
#define VC_NODE_MAX_MSGS (1 + 2 * VC_NODE_CAMS)
typedef struct vc_node_output {
  int count;
  const uint8_t* msg[VC_NODE_MAX_MSGS];
  size_t len[VC_NODE_MAX_MSGS];
  uint16_t type[VC_NODE_MAX_MSGS]; /* VC_MSG_HULL, VC_MSG_FEATURES, VC_MSG_SILHOUETTE */
} vc_node_output;

/* One frame pair in RUNNING: subtract, clean up, carve, and encode the HULL (header seq and
 * t_trigger_ns as given); on a node with a tracking role and a producer, track and encode FEATURES for
 * the same seq; when CONFIG's silhouette_every N > 0 and seq % N == 0, encode each camera's mask
 * (the one carved with, downscaled by silhouette_scale) as a SILHOUETTE into buffers made at CONFIG
 * (no allocation here; one over a limit is not sent and counted in silhouettes_over_limit). Returns 0 (out
 * filled: FEATURES, then SILHOUETTEs, the HULL last), 1 when the frame was skipped (seq < first_seq), -EAGAIN
 * when not RUNNING, VC_PROTO_ELIMIT when the hull has too many runs (counted, nothing to send). A producer's
 * failure or invalid features cost only the FEATURES (counted). */
int vc_node_process_frame(vc_node* node, uint64_t seq, uint64_t t_trigger_ns,
                          const uint8_t* const rgb[VC_NODE_CAMS], const size_t stride[VC_NODE_CAMS],
                          vc_node_output* out);
/* The same for a caller that wants the HULL only: *msg and *len point at it. */
int vc_node_process(vc_node* node, uint64_t seq, uint64_t t_trigger_ns,
                    const uint8_t* const rgb[VC_NODE_CAMS], const size_t stride[VC_NODE_CAMS],
                    const uint8_t** msg, size_t* len);

/* GRAB (2.4): from now on, the frames whose seq is a multiple of g->every and >= first_seq (0: any)
 * get one FRAME per asked camera from vc_node_frames, until g->count frames were sent (0: no end) or
 * the next GRAB, START, STOP or CONFIG; g->every 0 stops. The FRAME buffers are made here, never per
 * frame. 0; -EAGAIN when not RUNNING; -ENODEV when g->cameras names a camera the node does not have
 * (the cameras it has are grabbed; why says which) ; -EMSGSIZE when no asked camera's image fits a
 * payload; -ENOMEM (the previous GRAB stays). */
int vc_node_grab(vc_node* node, const vc_grab* g, uint64_t first_seq, char* why, size_t why_len);
/* Whether a GRAB is in force. */
bool vc_node_grabbing(const vc_node* node);
/* The FRAMEs of frame seq when the GRAB in force selects it (after vc_node_process_frame of the same
 * frame: send them after its HULL): rgb/stride the frame pair as it was processed, out filled with
 * FRAME messages (type VC_MSG_FRAME) in the node's buffers, valid until the next call on the node.
 * Returns the number of FRAMEs (0: not selected). A GRAB whose count is reached stops here. */
int vc_node_frames(vc_node* node, uint64_t seq, uint64_t t_trigger_ns, const uint8_t* const rgb[VC_NODE_CAMS],
                   const size_t stride[VC_NODE_CAMS], vc_node_output* out);

/* The silhouettes of the last processed frame as carved (width x height bytes each: 0, 255, and 128
 * for the limb-scale cue's pixels: edge/core bgmodel.h), for diagnostics; NULL before the first frame. Valid
 * until the next call on the node. */
const uint8_t* vc_node_mask(const vc_node* node, int cam);
/* The bitset of the last carved hull and its voxel count (NULL/0 before the first frame). */
const uint8_t* vc_node_bitset(const vc_node* node, uint64_t* voxels);

uint32_t vc_node_state(const vc_node* node); /* vc_node_state (proto.h) */
uint16_t vc_node_id(const vc_node* node);
uint64_t vc_node_first_seq(const vc_node* node);

/* Counters the node keeps itself; the daemon adds its own (queue drops, pairing) to STATS. */
typedef struct vc_node_counters {
  uint64_t frames_processed;
  uint64_t hulls_encoded;
  uint64_t hulls_over_limit;
  uint64_t features_encoded;       /* FEATURES messages */
  uint64_t features_failed;        /* frames whose producer failed or gave features that do not encode */
  uint64_t silhouettes_encoded;    /* SILHOUETTE messages */
  uint64_t silhouettes_over_limit; /* SILHOUETTEs not encoded: over a protocol limit (runs, payload) */
  uint64_t frames_encoded;         /* FRAME messages (2.4) */
} vc_node_counters;
void vc_node_get_counters(const vc_node* node, vc_node_counters* out);

/* Per-stage times since the last call: fills stages[] (subtract, cleanup, carve, encode) and returns
 * how many, plus *frames covered; resets the accumulators. */
int vc_node_take_stage_times(vc_node* node, vc_stage_time* stages, int max_stages, uint32_t* frames);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_NODE_H */
