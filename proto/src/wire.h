/* Little-endian loads and stores shared by the protocol sources (internal, not installed).
 * memcpy keeps them alignment-free; compilers turn each into a single load/store on LE hosts. */
#ifndef VOXCAP_PROTO_WIRE_H
#define VOXCAP_PROTO_WIRE_H

#include <stdint.h>
#include <string.h>

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
#define VC_WIRE_BIG_ENDIAN 1
#else
#define VC_WIRE_BIG_ENDIAN 0
#endif

static inline uint16_t vc_ld16(const uint8_t* p) {
  return (uint16_t)(p[0] | (p[1] << 8));
}

static inline uint32_t vc_ld32(const uint8_t* p) {
  uint32_t v;
  memcpy(&v, p, 4);
#if VC_WIRE_BIG_ENDIAN
  v = __builtin_bswap32(v);
#endif
  return v;
}

static inline uint64_t vc_ld64(const uint8_t* p) {
  uint64_t v;
  memcpy(&v, p, 8);
#if VC_WIRE_BIG_ENDIAN
  v = __builtin_bswap64(v);
#endif
  return v;
}

static inline void vc_st16(uint8_t* p, uint16_t v) {
  p[0] = (uint8_t)v;
  p[1] = (uint8_t)(v >> 8);
}

static inline void vc_st32(uint8_t* p, uint32_t v) {
#if VC_WIRE_BIG_ENDIAN
  v = __builtin_bswap32(v);
#endif
  memcpy(p, &v, 4);
}

static inline void vc_st64(uint8_t* p, uint64_t v) {
#if VC_WIRE_BIG_ENDIAN
  v = __builtin_bswap64(v);
#endif
  memcpy(p, &v, 8);
}

/* IEEE 754 binary32/binary64 travel as the little-endian bytes of their bit pattern. */
static inline float vc_ldf32(const uint8_t* p) {
  uint32_t u = vc_ld32(p);
  float f;
  memcpy(&f, &u, 4);
  return f;
}

static inline double vc_ldf64(const uint8_t* p) {
  uint64_t u = vc_ld64(p);
  double d;
  memcpy(&d, &u, 8);
  return d;
}

static inline void vc_stf32(uint8_t* p, float f) {
  uint32_t u;
  memcpy(&u, &f, 4);
  vc_st32(p, u);
}

static inline void vc_stf64(uint8_t* p, double d) {
  uint64_t u;
  memcpy(&u, &d, 8);
  vc_st64(p, u);
}

#endif /* VOXCAP_PROTO_WIRE_H */
