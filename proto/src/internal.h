/* Internal to vc_proto: payload layouts (SPEC.md "Messages") and the body checks shared by the
 * encoders and the decoder, so both apply exactly the same rules. */
#ifndef VOXCAP_PROTO_INTERNAL_H
#define VOXCAP_PROTO_INTERNAL_H

#include "voxcap/proto.h"

/* Fixed parts and record sizes of version 1.0 payloads, in bytes. */
#define VC_HELLO_FIXED 16
#define VC_HELLO_CAMERA_SIZE 12
#define VC_CONFIG_FIXED 78
#define VC_CONFIG_CAMERA_SIZE 216
#define VC_BACKGROUND_SIZE 4
#define VC_HULL_FIXED 24
#define VC_FEATURES_FIXED 6
#define VC_FEATURE_SIZE 16
#define VC_STATS_FIXED 8
#define VC_STAGE_SIZE 12
#define VC_COUNTER_SIZE 12
#define VC_HEARTBEAT_SIZE 12
#define VC_ERROR_FIXED 10
#define VC_SILHOUETTE_FIXED 16 /* 2.1 */
#define VC_AUTH_MSG_SIZE 68    /* 2.3 */
#define VC_GRAB_SIZE 12        /* 2.4 */
#define VC_FRAME_FIXED 12      /* 2.4 */

#if defined(__GNUC__) || defined(__clang__)
#define VC_PRINTF(fmt_idx, arg_idx) __attribute__((format(printf, fmt_idx, arg_idx)))
#else
#define VC_PRINTF(fmt_idx, arg_idx)
#endif

/* Records code and a formatted detail in diag (which may be NULL); returns code. */
int vc_diag_set(vc_proto_diag* diag, int code, const char* fmt, ...) VC_PRINTF(3, 4);

int vc_check_hello(const vc_hello* m, uint16_t header_node_id, vc_proto_diag* diag);
int vc_check_config(const vc_config* m, vc_proto_diag* diag);
/* Validates the RLE against the counts; *runs (may be NULL) receives the number of runs. */
int vc_check_hull(const vc_hull* m, uint64_t* runs, vc_proto_diag* diag);
int vc_check_features(const vc_features* m, vc_proto_diag* diag);
int vc_check_stats(const vc_stats* m, vc_proto_diag* diag);
int vc_check_heartbeat(const vc_heartbeat* m, vc_proto_diag* diag);
int vc_check_error(const vc_error* m, vc_proto_diag* diag);
int vc_check_auth(const vc_auth_msg* m, uint16_t reserved, vc_proto_diag* diag);
/* Sizes, then the RLE against them; *runs (may be NULL) receives the number of runs. */
int vc_check_silhouette(const vc_silhouette* m, uint64_t* runs, vc_proto_diag* diag);
/* The fields of a SILHOUETTE that do not depend on its RLE. */
int vc_check_silhouette_fields(uint16_t camera, uint16_t scale, uint16_t width, uint16_t height,
                               vc_proto_diag* diag);

/* GRAB (2.4): the fields, reserved as received (0 when encoding). */
int vc_check_grab(const vc_grab* m, uint16_t reserved, vc_proto_diag* diag);
/* FRAME (2.4): camera, format and size; then pixels_len against them. */
int vc_check_frame_fields(uint16_t camera, uint16_t format, uint16_t width, uint16_t height,
                          vc_proto_diag* diag);
int vc_check_frame(const vc_frame_msg* m, vc_proto_diag* diag);

#endif /* VOXCAP_PROTO_INTERNAL_H */
