/* The voxcap wire protocol (proto/SPEC.md is the normative text; section names below refer to it).
 *
 * This header: protocol constants and the emulated trigger datagram. The node<->host message
 * framing, encoders and the streaming decoder follow in the same header.
 *
 * Conventions: all integers little-endian on the wire; functions return 0 or a negative errno-style
 * code; no function keeps a pointer to caller memory after it returns unless its comment says so.
 */
#ifndef VOXCAP_PROTO_H
#define VOXCAP_PROTO_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Emulated trigger datagram (SPEC.md "Trigger datagram") -------------------------------------
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
int vc_trigger_dgram_decode(const uint8_t *buf, size_t len, uint64_t *seq, uint64_t *t_ns);

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_PROTO_H */
