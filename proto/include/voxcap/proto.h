/* The voxcap wire protocol, both sides: framing, the message types, encoders, a streaming
 * decoder, and the emulated trigger datagram. proto/SPEC.md is the normative text; every struct field
 * below is named as in SPEC.md and appears on the wire in the order listed there.
 *
 * Conventions
 *  - Integers little-endian, floats IEEE 754 (little-endian bit patterns) on the wire.
 *  - Functions return 0 (or 1 where documented) or a negative code: -EINVAL/-ENOSPC/-ENOMEM (errno) or
 *    a VC_PROTO_E* code below. vc_proto_strerror() names any of them.
 *  - Encoders write into a caller buffer and never allocate; on -ENOSPC they set *len to the size
 *    needed. The only allocation in the library is vc_decoder_new() (and its buffer growth).
 *  - "View" pointers in decoded messages (vc_msg.payload, vc_hull.rle, vc_error.text) borrow from the
 *    buffer that was decoded; their lifetime is stated where they are produced.
 */
#ifndef VOXCAP_PROTO_H
#define VOXCAP_PROTO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "voxcap/camera_model.h"
#include "voxcap/subtraction.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Versions and limits (SPEC.md "Framing", "Limits") ------------------------------------------ */

#define VC_PROTO_MAGIC 0x50435856u /* "VXCP" in memory */
#define VC_PROTO_VERSION_MAJOR 2
#define VC_PROTO_VERSION_MINOR 4
#define VC_PROTO_HEADER_SIZE 40

#define VC_PROTO_MAX_PAYLOAD (8u * 1024u * 1024u) /* bytes after the header, any type */
#define VC_PROTO_MAX_VOXELS (UINT64_C(1) << 27)   /* voxels in a grid (512^3) */
#define VC_PROTO_MAX_RLE_RUNS (UINT64_C(1) << 22) /* runs in one HULL */
#define VC_PROTO_MAX_CAMERAS 8                    /* cameras per node */
#define VC_PROTO_MAX_FEATURES 16                  /* feature records per FEATURES */
#define VC_PROTO_MAX_STAGES 32                    /* stage records per STATS */
#define VC_PROTO_MAX_COUNTERS 32                  /* counter records per STATS */
#define VC_PROTO_MAX_ERROR_TEXT 1024              /* bytes of ERROR text */
#define VC_PROTO_MAX_SILHOUETTE_SIDE 16384        /* SILHOUETTE width and height, pixels (2.1) */
#define VC_PROTO_MAX_SILHOUETTE_SCALE 16          /* CONFIG silhouette_scale, SILHOUETTE scale (2.1) */
#define VC_PROTO_MAX_HELLO_PAYLOAD 1024           /* a receiver's cap on the first message (HELLO) */
#define VC_PROTO_MAX_FRAME_SIDE 16384             /* FRAME width and height, pixels (2.4) */

/* ---- Error codes of the decoder and encoders (SPEC.md "Errors") ----------------------------------
 * Fatal codes concern the framing: the byte stream cannot be resynchronised, the decoder stays in the
 * error state and the receiver must drop the connection. Non-fatal codes concern one message whose
 * frame (and CRC) was intact: that message is consumed and rejected, decoding continues after it. */
enum vc_proto_err {
  VC_PROTO_EMAGIC = -1001,        /* fatal: the bytes at a message boundary are not "VXCP" */
  VC_PROTO_EVERSION = -1002,      /* fatal: version_major is not VC_PROTO_VERSION_MAJOR */
  VC_PROTO_EHEADER_CRC = -1003,   /* fatal: header_crc does not match header bytes 0..35 */
  VC_PROTO_EPAYLOAD_CRC = -1004,  /* fatal: payload_crc does not match the payload */
  VC_PROTO_EOVERSIZE = -1005,     /* fatal: payload_len is over the receiver's maximum */
  VC_PROTO_EEOF = -1006,          /* fatal: the stream ended inside a message */
  VC_PROTO_ETRUNCATED = -1007,    /* the payload is shorter than the fields it announces */
  VC_PROTO_ETRAILING = -1008,     /* bytes after the last field, and the message is not newer */
  VC_PROTO_EINCONSISTENT = -1009, /* counts or sizes that disagree with each other or the data */
  VC_PROTO_ERLE = -1010,          /* malformed RLE in a HULL or SILHOUETTE */
  VC_PROTO_ELIMIT = -1011,        /* a count over one of the VC_PROTO_MAX_* limits */
  VC_PROTO_EFIELD = -1012,        /* a field value outside its documented range */
  VC_PROTO_EMAC = -1013,          /* 2.3: no MAC, or a MAC that does not verify (forged) */
  VC_PROTO_EREPLAY = -1014,       /* 2.3: a valid MAC on a counter already used (replayed) */
  VC_PROTO_EORDER = -1015,        /* 2.3: a valid MAC on a counter ahead of the next (reordered) */
};

/* Short description of any code returned here ("bad magic", "no space", ...). Static string. */
const char* vc_proto_strerror(int code);
/* The enum name ("VC_PROTO_EMAGIC", "ENOSPC", "OK"), as test vectors and `voxcap proto dump` show it. */
const char* vc_proto_error_name(int code);
/* True for the fatal codes listed above. */
bool vc_proto_error_is_fatal(int code);

/* Where and why decoding failed. */
typedef struct vc_proto_diag {
  int code;         /* 0 or the error code */
  uint64_t offset;  /* offset of the first byte of the failing message (stream offset in a decoder) */
  char detail[256]; /* NUL-terminated: message type, field, the values seen */
} vc_proto_diag;

/* ---- Message types and enumerations (SPEC.md "Messages") ----------------------------------------- */

enum vc_msg_type {
  VC_MSG_HELLO = 1,       /* node -> host, first message of a session */
  VC_MSG_CONFIG = 2,      /* host -> node */
  VC_MSG_BACKGROUND = 3,  /* host -> node: learn the background */
  VC_MSG_START = 4,       /* host -> node: stream frames */
  VC_MSG_STOP = 5,        /* host -> node: stop streaming */
  VC_MSG_HULL = 6,        /* node -> host, per frame */
  VC_MSG_FEATURES = 7,    /* node -> host, per frame and camera (front nodes) */
  VC_MSG_STATS = 8,       /* node -> host, periodic */
  VC_MSG_HEARTBEAT = 9,   /* both ways, periodic */
  VC_MSG_ERROR = 10,      /* both ways */
  VC_MSG_SILHOUETTE = 11, /* node -> host, per camera every silhouette_every-th frame (2.1) */
  VC_MSG_AUTH = 12,       /* both ways, the key's challenge-response on connect (2.3, auth.h) */
  VC_MSG_GRAB = 13,       /* host -> node: send full camera images of some frames (2.4) */
  VC_MSG_FRAME = 14       /* node -> host: one camera's image of one frame, as GRAB asked (2.4) */
};
/* "HELLO", ... for known types, NULL otherwise. */
const char* vc_msg_type_name(uint16_t type);

/* HELLO capabilities (bit set = supported). Unknown bits are ignored by receivers. */
#define VC_CAP_HULL (1u << 0)         /* carves and sends HULL */
#define VC_CAP_FEATURES (1u << 1)     /* can track features (role FRONT) */
#define VC_CAP_GPIO_TRIGGER (1u << 2) /* trigger input on a GPIO line */
#define VC_CAP_UDP_TRIGGER (1u << 3)  /* emulated trigger input (trigger datagram) */
#define VC_CAP_AUTH (1u << 4)         /* holds the rig key: AUTH follows HELLO (2.3) */

/* Header flags (2.3). */
#define VC_FLAG_MAC 0x0001u /* the payload ends with the MAC trailer (auth.h, SPEC.md "Authentication") */

/* V4L2-style FourCC of a pixel format, e.g. VC_FOURCC('R','G','B','3'). */
#define VC_FOURCC(a, b, c, d) \
  ((uint32_t)(a) | ((uint32_t)(b) << 8) | ((uint32_t)(c) << 16) | ((uint32_t)(d) << 24))

enum vc_feature_role { VC_ROLE_NONE = 0, VC_ROLE_FRONT = 1 };

enum vc_feature_id {
  VC_FEATURE_HEAD = 0,
  VC_FEATURE_LEFT_HAND = 1,
  VC_FEATURE_RIGHT_HAND = 2,
  VC_FEATURE_LEFT_FOOT = 3,
  VC_FEATURE_RIGHT_FOOT = 4,
  VC_FEATURE_ID_COUNT = 5
};

enum vc_feature_state {
  VC_FEATURE_TRACKING = 0,    /* measured in this frame */
  VC_FEATURE_PREDICTED = 1,   /* not measured; u, v predicted from motion */
  VC_FEATURE_LOST = 2,        /* tracker lost it; u, v are the last known position */
  VC_FEATURE_NOT_VISIBLE = 3, /* outside this camera's view or occluded; u, v meaningless */
  VC_FEATURE_STATE_COUNT = 4
};

enum vc_node_state {                          /* HEARTBEAT */
                     VC_STATE_HOST = 0,       /* sent by the host, which has no node state */
                     VC_STATE_IDLE = 1,       /* connected, no CONFIG yet */
                     VC_STATE_CONFIGURED = 2, /* CONFIG accepted, no background model */
                     VC_STATE_BACKGROUND = 3, /* learning the background */
                     VC_STATE_READY = 4,      /* background learnt; START will stream */
                     VC_STATE_RUNNING = 5,    /* streaming HULL/FEATURES */
                     VC_STATE_COUNT = 6
};

/* STATS ids: open sets; receivers show unknown ids as numbers. */
enum vc_stage_id {
  VC_STAGE_CAPTURE = 0,  /* trigger edge -> both frames in memory */
  VC_STAGE_SUBTRACT = 1, /* background subtraction, both cameras */
  VC_STAGE_CLEANUP = 2,  /* silhouette clean-up */
  VC_STAGE_CARVE = 3,    /* partial hull carving */
  VC_STAGE_ENCODE = 4,   /* RLE + message encoding */
  VC_STAGE_FEATURES = 5, /* feature tracking */
  VC_STAGE_SEND = 6,     /* queued -> written to the socket */
  VC_STAGE_FRAME = 7,    /* trigger edge -> HULL written: the whole frame */
};
enum vc_counter_id {
  VC_COUNTER_FRAMES_CAPTURED = 0,
  VC_COUNTER_HULLS_SENT = 1,
  VC_COUNTER_FEATURES_SENT = 2,
  VC_COUNTER_SEND_QUEUE_DROPS = 3,     /* messages dropped because the send queue was full */
  VC_COUNTER_FRAMES_WITHOUT_PULSE = 4, /* frames that matched no trigger pulse */
  VC_COUNTER_PULSES_WITHOUT_FRAME = 5, /* pulses for which a camera delivered no frame */
  VC_COUNTER_HULLS_OVER_LIMIT = 6,     /* hulls not sent: RLE over VC_PROTO_MAX_* limits */
  VC_COUNTER_CAMERA_ERRORS = 7,
  VC_COUNTER_SILHOUETTES_SENT = 8,    /* SILHOUETTE messages queued for the host (2.1) */
  VC_COUNTER_SILHOUETTES_DROPPED = 9, /* SILHOUETTEs not sent: no room in the send queue, or a limit */
  VC_COUNTER_FRAMES_SENT = 10,        /* FRAME messages queued for the host (2.4) */
  VC_COUNTER_FRAMES_DROPPED = 11,     /* FRAMEs asked for but not sent: no room in the send queue (2.4) */
};
const char* vc_stage_name(uint32_t id);            /* "capture", ... or NULL */
const char* vc_counter_name(uint32_t id);          /* "frames_captured", ... or NULL */
const char* vc_feature_name(uint32_t id);          /* "head", "left_hand", ... or NULL */
const char* vc_feature_state_name(uint32_t state); /* "tracking", ... or NULL */
const char* vc_node_state_name(uint32_t state);    /* "host", "idle", ... or NULL */
const char* vc_role_name(uint32_t role);           /* "none", "front" or NULL */
const char* vc_carve_rule_name(uint32_t rule);     /* "centre", "footprint", "subpixel" or NULL */

/* ERROR codes (the ERROR message's `code`; open set) and severities. */
enum vc_error_code {
  VC_ERR_PROTOCOL = 1, /* a received message was rejected by the decoder */
  VC_ERR_VERSION = 2,  /* unsupported protocol version */
  VC_ERR_STATE = 3,    /* message not valid in the current session state */
  VC_ERR_CONFIG = 4,   /* CONFIG rejected */
  VC_ERR_CAMERA = 5,
  VC_ERR_TRIGGER = 6,
  VC_ERR_OVERLOAD = 7, /* cannot keep up; data dropped */
  VC_ERR_INTERNAL = 8,
  VC_ERR_AUTH = 9, /* the peer did not prove the rig key, or a message failed its MAC (2.3) */
};
enum vc_error_severity {
  VC_SEVERITY_WARNING = 0, /* informational; nothing was rejected */
  VC_SEVERITY_ERROR = 1,   /* the message or request was rejected; the session continues */
  VC_SEVERITY_FATAL = 2,   /* the sender closes the connection after this message */
  VC_SEVERITY_COUNT = 3
};
const char* vc_error_code_name(uint32_t code);         /* "protocol", ... or NULL */
const char* vc_error_severity_name(uint32_t severity); /* "warning", ... or NULL */

/* ---- Header and message bodies -------------------------------------------------------------------- */

typedef struct vc_header {
  uint8_t version_major;
  uint8_t version_minor;
  uint16_t type;
  uint16_t flags; /* VC_FLAG_MAC (2.3); other bits sent as 0, ignored on receipt */
  uint16_t node_id;
  uint32_t payload_len;
  uint64_t seq;          /* trigger pulse counter of the frame (0 if the message is not about one) */
  uint64_t t_trigger_ns; /* host CLOCK_MONOTONIC time of that pulse's edge (0 likewise) */
  uint32_t payload_crc;  /* CRC32C of the payload */
  uint32_t header_crc;   /* CRC32C of header bytes 0..35 */
} vc_header;

typedef struct vc_hello_camera {
  uint16_t width, height;
  uint32_t pixel_format;  /* FourCC */
  uint32_t max_fps_milli; /* highest frame rate, in 1/1000 fps */
} vc_hello_camera;

typedef struct vc_hello {
  uint16_t node_id; /* must equal the header's node_id */
  uint16_t sw_major, sw_minor, sw_patch;
  uint32_t capabilities;       /* VC_CAP_* */
  uint16_t camera_count;       /* <= VC_PROTO_MAX_CAMERAS */
  uint16_t camera_record_size; /* decoded: as received; encoders write this version's size */
  vc_hello_camera cameras[VC_PROTO_MAX_CAMERAS];
} vc_hello;

typedef struct vc_config {
  uint32_t grid_id;            /* names this grid in HULL messages */
  vc_voxel_grid grid;          /* nx ny nz min_m voxel_m (camera_model.h) */
  float t_upper;               /* eq. 1: foreground if |p - mu| > t_upper * sigma in some channel */
  float t_lower;               /* background if below t_lower * sigma in all channels */
  float shadow_angle_deg;      /* eq. 2: angular (hue) threshold between the two */
  uint32_t cleanup_radius_px;  /* clean-up: one pass of a (2r+1)^2 majority filter, 0..8 (0: off) */
  uint16_t carve_rule;         /* vc_carve_rule (camera_model.h): 0 centre, 1 footprint (2.1) */
  uint8_t silhouette_every;    /* 0: no SILHOUETTE; N: one per camera for every seq % N == 0 (2.1) */
  uint8_t silhouette_scale;    /* SILHOUETTE downscale 1..16; may be 0 only when silhouette_every is 0 */
  uint32_t background_frames;  /* frames BACKGROUND learns when it says 0 */
  uint16_t feature_role;       /* vc_feature_role */
  uint16_t camera_count;       /* 1..VC_PROTO_MAX_CAMERAS, in the node's HELLO order */
  uint16_t camera_record_size; /* decoded: as received; encoders write this version's size */
  vc_camera cameras[VC_PROTO_MAX_CAMERAS]; /* calibration records (camera_model.h) */
} vc_config;

typedef struct vc_background {
  uint32_t frame_count; /* 0: CONFIG's background_frames */
} vc_background;

typedef struct vc_hull {
  uint32_t grid_id;
  uint32_t rle_len;
  uint64_t voxel_count;    /* must equal the sum of the runs */
  uint64_t occupied_count; /* must equal the sum of the occupied runs */
  const uint8_t* rle;      /* rle_len bytes (rle.h format) */
  uint64_t run_count;      /* filled by the decoder; ignored by the encoder */
} vc_hull;

/* SILHOUETTE (2.1): one camera's mask after clean-up, exactly what the carver used, at 1/scale of the
 * camera's resolution (a scaled pixel is foreground when any pixel of its scale x scale block is). The
 * RLE (rle.h) is over the width*height bitset, pixel (x, y) at bit x + width*y. */
typedef struct vc_silhouette {
  uint16_t camera;           /* the node's camera index, < VC_PROTO_MAX_CAMERAS */
  uint16_t scale;            /* 1..VC_PROTO_MAX_SILHOUETTE_SCALE */
  uint16_t width, height;    /* of the scaled mask, 1..VC_PROTO_MAX_SILHOUETTE_SIDE */
  uint32_t rle_len;          /* bytes of RLE */
  uint32_t foreground_count; /* foreground pixels of the scaled mask: the sum of the occupied runs */
  const uint8_t* rle;        /* rle_len bytes */
  uint64_t run_count;        /* filled by the decoder; ignored by the encoder */
} vc_silhouette;

typedef struct vc_feature {
  uint16_t feature_id; /* vc_feature_id; unique within a message */
  uint16_t state;      /* vc_feature_state */
  float u, v;          /* pixel position (distorted image coordinates) */
  float confidence;    /* 0..1 */
} vc_feature;

typedef struct vc_features {
  uint16_t camera; /* the node's camera index */
  uint16_t feature_count;
  uint16_t feature_record_size; /* decoded: as received; encoders write this version's size */
  vc_feature features[VC_PROTO_MAX_FEATURES];
} vc_features;

typedef struct vc_stage_time {
  uint32_t stage_id; /* vc_stage_id */
  uint32_t mean_ns;
  uint32_t max_ns; /* >= mean_ns */
} vc_stage_time;

typedef struct vc_counter {
  uint32_t counter_id; /* vc_counter_id */
  uint64_t value;      /* cumulative since the node started */
} vc_counter;

typedef struct vc_stats {
  uint32_t frames; /* frames the stage times cover (since the previous STATS) */
  uint16_t stage_count, counter_count;
  vc_stage_time stages[VC_PROTO_MAX_STAGES];
  vc_counter counters[VC_PROTO_MAX_COUNTERS];
} vc_stats;

typedef struct vc_heartbeat {
  uint64_t sender_time_ns; /* sender's CLOCK_MONOTONIC */
  uint32_t state;          /* vc_node_state */
} vc_heartbeat;

typedef struct vc_error {
  uint32_t code;       /* vc_error_code */
  uint16_t severity;   /* vc_error_severity */
  uint16_t about_type; /* type of the message that caused it, 0 if none */
  uint16_t text_len;
  const char* text; /* text_len bytes of UTF-8, no NUL; not NUL-terminated */
} vc_error;

enum vc_auth_step {                        /* AUTH (2.3) */
                    VC_AUTH_CHALLENGE = 1, /* node -> host: the node's nonce */
                    VC_AUTH_RESPONSE = 2,  /* host -> node: the host's nonce and proof */
                    VC_AUTH_PROOF = 3      /* node -> host: the node's proof */
};

typedef struct vc_auth_msg {
  uint16_t step;     /* vc_auth_step */
  uint8_t nonce[32]; /* CHALLENGE: the node's, RESPONSE: the host's; zero in PROOF */
  uint8_t proof[32]; /* RESPONSE, PROOF: vc_auth_prove (auth.h); zero in CHALLENGE */
} vc_auth_msg;

/* GRAB (2.4): which frames' full camera images the node sends, as FRAME messages. */
enum vc_frame_format {
  VC_FRAME_GRAY8 = 1, /* one byte per pixel, luma (BT.601 weights of the RGB the node has) */
  VC_FRAME_RGB8 = 2,  /* three bytes per pixel, R G B: the node's frame as it is */
  VC_FRAME_FORMAT_COUNT = 3
};
const char* vc_frame_format_name(uint32_t format); /* "gray8", "rgb8" or NULL */
/* Bytes per pixel of a format, 0 for an unknown one. */
unsigned vc_frame_format_channels(uint32_t format);

typedef struct vc_grab {
  uint16_t every;   /* 0: stop grabbing; N: frames whose seq is a multiple of N (and >= the header's seq) */
  uint16_t format;  /* vc_frame_format; 0 allowed only with every 0 */
  uint16_t cameras; /* bit k: the node's camera k; 0 allowed only with every 0 */
  uint32_t count;   /* frames to send, then stop; 0: until the next GRAB, CONFIG, START or STOP */
} vc_grab;

/* FRAME (2.4): one camera's image of frame hdr.seq, rows top to bottom, no padding. */
typedef struct vc_frame_msg {
  uint16_t camera;        /* the node's camera index, < VC_PROTO_MAX_CAMERAS */
  uint16_t format;        /* vc_frame_format */
  uint16_t width, height; /* 1..VC_PROTO_MAX_FRAME_SIDE */
  uint32_t pixels_len;    /* width * height * channels, exactly */
  const uint8_t* pixels;  /* pixels_len bytes */
} vc_frame_msg;

typedef struct vc_msg {
  vc_header hdr;
  const uint8_t* payload; /* view of hdr.payload_len bytes (decoded messages only) */
  bool known;             /* hdr.type is a type this library knows; otherwise `u` is unset */
  uint32_t ignored_bytes; /* bytes of a newer minor version skipped by the decoder */
  union {
    vc_hello hello;
    vc_config config;
    vc_background background;
    vc_hull hull;
    vc_features features;
    vc_stats stats;
    vc_heartbeat heartbeat;
    vc_error error;
    vc_silhouette silhouette;
    vc_auth_msg auth;
    vc_grab grab;
    vc_frame_msg frame;
  } u;
} vc_msg;

/* ---- Encoding ------------------------------------------------------------------------------------
 * Every encoder reads node_id, flags, seq and t_trigger_ns from `hdr` and writes the whole message
 * (header with this library's version, type, payload_len and both CRCs, then the payload) to
 * buf[0..*len). The body is checked against the same rules the decoder applies, so an encoder never
 * produces a message a receiver of this version rejects: a violation returns that VC_PROTO_E* code.
 * -EINVAL for NULL pointers, -ENOSPC (with *len = size needed) when cap is too small. */

int vc_encode_hello(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_hello* m);
int vc_encode_config(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_config* m);
int vc_encode_background(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_background* m);
int vc_encode_start(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr);
int vc_encode_stop(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr);
/* m->rle holds m->rle_len bytes of RLE; it is validated (counts, runs) before it is copied. */
int vc_encode_hull(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_hull* m);
/* HULL straight from a bitset: the RLE is written into buf in place (no intermediate buffer, no
 * allocation), voxel_count = nbits and occupied_count come from the same pass. This is the edge's
 * per-frame path. cap >= VC_PROTO_HEADER_SIZE + 24 + vc_rle_max_encoded_size(nbits) always suffices;
 * VC_PROTO_ELIMIT when the hull has more runs or bytes than the limits allow. */
int vc_encode_hull_bits(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, uint32_t grid_id,
                        const uint8_t* bits, size_t nbits);
int vc_encode_features(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_features* m);
int vc_encode_stats(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_stats* m);
int vc_encode_heartbeat(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_heartbeat* m);
int vc_encode_error(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_error* m);
/* m->rle holds m->rle_len bytes of RLE; it is validated (sizes, counts, runs) before it is copied. */
int vc_encode_silhouette(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_silhouette* m);
/* SILHOUETTE straight from a bitset of width*height bits (pixel x + width*y, LSB-first): the RLE is
 * written into buf in place, foreground_count comes from the same pass; no allocation (the edge's
 * path). cap >= VC_PROTO_HEADER_SIZE + 16 + vc_rle_max_encoded_size(width * height) always suffices.
 * VC_PROTO_EFIELD / VC_PROTO_ELIMIT for a camera, scale or size out of range or too many runs. */
int vc_encode_silhouette_bits(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, uint16_t camera,
                              uint16_t scale, uint16_t width, uint16_t height, const uint8_t* bits);

int vc_encode_auth(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_auth_msg* m);

int vc_encode_grab(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_grab* m);
/* m->pixels holds m->pixels_len bytes; the sizes are checked before it is copied. */
int vc_encode_frame(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_frame_msg* m);
/* FRAME straight from a camera image of interleaved RGB rows (`stride` bytes apart, width * 3 bytes
 * each): written into buf as `format` (gray8: luma in fixed point, rgb8: copied), no allocation (the
 * edge's path). cap >= VC_PROTO_HEADER_SIZE + 12 + width * height * channels always suffices.
 * VC_PROTO_EFIELD / VC_PROTO_ELIMIT for a camera, format or size out of range or over the payload. */
int vc_encode_frame_rgb(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, uint16_t camera,
                        uint16_t format, uint16_t width, uint16_t height, const uint8_t* rgb, size_t stride);

/* Dispatches on msg->hdr.type to the encoder above (msg->known types only; -EINVAL otherwise). */
int vc_msg_encode(uint8_t* buf, size_t cap, size_t* len, const vc_msg* msg);

/* Low level: a frame with an arbitrary header (version, type and flags taken from hdr as given) and
 * payload. payload_len and both CRCs are computed. For forwarding, tools and test vectors; the typed
 * encoders are built on it. */
int vc_frame_encode(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const uint8_t* payload,
                    size_t payload_len);

/* ---- Decoding one buffer ---------------------------------------------------------------------------
 * Decodes the message at the start of buf[0..len) (framing checks, then the payload of known types).
 * Returns 1 with *out filled and *consumed = its size; 0 if buf holds only a prefix of a message (more
 * bytes needed, nothing consumed); or an error code. After a non-fatal error *consumed is the whole
 * message (skip it and go on), out->hdr and out->payload are filled and out->known tells whether the
 * body was being parsed; after a fatal one *consumed is 0. Views in *out point into buf. diag may be
 * NULL; its offset is 0 (the start of buf). max_payload: 0 means VC_PROTO_MAX_PAYLOAD; larger is -EINVAL.
 * A message of an unknown type with valid framing is returned (1) with out->known = false. */
int vc_msg_decode(const uint8_t* buf, size_t len, size_t max_payload, vc_msg* out, size_t* consumed,
                  vc_proto_diag* diag);

/* ---- Streaming decoder ------------------------------------------------------------------------------
 * Takes bytes in whatever chunks the transport delivers and yields whole messages. Memory is bounded:
 * its buffer grows (from 64 KiB, or less) to at most VC_PROTO_HEADER_SIZE + max_payload bytes.
 *
 *   while ((n = recv(fd, chunk, sizeof chunk, 0)) > 0) {
 *     for (size_t off = 0, used; off < (size_t)n; off += used) {
 *       if ((rc = vc_decoder_feed(dec, chunk + off, n - off, &used)) < 0) goto drop;
 *       while ((rc = vc_decoder_next(dec, &msg)) != 0) {
 *         if (rc < 0 && vc_proto_error_is_fatal(rc)) goto drop;   // see vc_decoder_diag(dec)
 *         if (rc > 0) handle(&msg);                               // else: one bad message, skipped
 *       }
 *     }
 *   }
 *   if (n == 0 && vc_decoder_finish(dec) < 0) ... // the peer closed mid-message
 *
 * Not thread-safe per decoder; separate decoders are independent. */
typedef struct vc_decoder vc_decoder;

/* Low level: as vc_msg_decode, and when rx is not NULL the message must carry a valid MAC trailer
 * for rx (vc_mac_open, auth.h): VC_PROTO_EMAC, EREPLAY or EORDER otherwise (non-fatal, the message is
 * consumed). The trailer is not part of the decoded message: out->hdr.payload_len excludes it. */
struct vc_mac;
int vc_msg_decode_mac(const uint8_t* buf, size_t len, size_t max_payload, struct vc_mac* rx, vc_msg* out,
                      size_t* consumed, vc_proto_diag* diag);

/* A decoder accepting payloads up to max_payload bytes (0: VC_PROTO_MAX_PAYLOAD) into *out. Returns 0,
 * -EINVAL (max_payload > VC_PROTO_MAX_PAYLOAD, or no out) or -ENOMEM, with *out NULL and a one-line
 * reason in why when given (NULL/0 when not wanted; "" on success): the edge's constructor shape
 * (edge/README.md). *out owns the decoder; free it with vc_decoder_free. */
int vc_decoder_new(size_t max_payload, vc_decoder** out, char* why, size_t why_len);
void vc_decoder_free(vc_decoder* dec); /* NULL is a no-op */

/* Changes the largest payload taken from the next message on (0: VC_PROTO_MAX_PAYLOAD; larger is
 * -EINVAL). A receiver starts an unauthenticated peer's stream small (VC_PROTO_MAX_HELLO_PAYLOAD: its
 * first message must be a HELLO) and raises it once the HELLO was accepted, so a stranger cannot make
 * it buffer megabytes (SPEC.md "Limits"). The buffer already grown is kept. */
int vc_decoder_set_max_payload(vc_decoder* dec, size_t max_payload);

/* From the next message on, every message must carry a valid MAC for rx (copied; its counter is the
 * next expected), checked before its payload is parsed: see vc_msg_decode_mac. NULL turns the check
 * off. 0 or -EINVAL. */
int vc_decoder_set_mac(vc_decoder* dec, const struct vc_mac* rx);

/* Copies up to len bytes into the decoder; *consumed = how many. It takes fewer (possibly 0) only when
 * its buffer holds a whole message or an error that vc_decoder_next has not yet returned, so
 * alternating feed and next always makes progress. Returns 0, -ENOMEM, or the sticky fatal error. */
int vc_decoder_feed(vc_decoder* dec, const uint8_t* data, size_t len, size_t* consumed);

/* The next message: 1 (*out filled), 0 (need more bytes), or an error code (vc_decoder_diag says
 * where and why). Fatal errors are sticky: every later call returns the same code. Views in *out
 * (payload, hull.rle, error.text) stay valid until the next call of feed, next, finish or free on
 * this decoder. */
int vc_decoder_next(vc_decoder* dec, vc_msg* out);

/* End of stream: 0 if it ended on a message boundary, VC_PROTO_EEOF (fatal) if inside a message. */
int vc_decoder_finish(vc_decoder* dec);

/* The last error (code 0 if none). Valid until the decoder is freed. */
const vc_proto_diag* vc_decoder_diag(const vc_decoder* dec);
/* Stream offset of the next message not yet returned (bytes consumed by next so far). */
uint64_t vc_decoder_offset(const vc_decoder* dec);
/* Bytes buffered but not yet returned as messages. */
size_t vc_decoder_pending(const vc_decoder* dec);

/* ---- Emulated trigger datagram (SPEC.md "Trigger datagram") ----------------------------------------
 * One UDP datagram per trigger pulse, host -> every edge, on loopback in the emulated rig:
 *   0  u32 magic 0x52545856 ("VXTR" in memory)   4  u16 version = 1   6  u16 flags = 0
 *   8  u64 seq (trigger pulse counter)            16 u64 t_ns (host CLOCK_MONOTONIC of the pulse edge) */
#define VC_TRIGGER_DGRAM_SIZE 24
#define VC_TRIGGER_DGRAM_MAGIC 0x52545856u
#define VC_TRIGGER_DGRAM_VERSION 1

/* Writes the 24-byte datagram. -EINVAL if out is NULL. */
int vc_trigger_dgram_encode(uint8_t out[VC_TRIGGER_DGRAM_SIZE], uint64_t seq, uint64_t t_ns);

/* Parses a received datagram: -EBADMSG unless len == 24 with the right magic and version 1
 * (flags are reserved: ignored). seq and t_ns may be NULL; they are written only on success. */
int vc_trigger_dgram_decode(const uint8_t* buf, size_t len, uint64_t* seq, uint64_t* t_ns);

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_PROTO_H */
