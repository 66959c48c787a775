/* vc_why: the one way C code in voxcap says why something failed (proto, edge/core, the edge daemon).
 *
 * Every function that can fail for a reason worth telling takes `char* why, size_t why_len`
 * (NULL/0 when the caller does not want it) and fills it with one line through vc_why(), never with
 * its own snprintf: the reason is always NUL-terminated, silently truncated to why_len - 1 bytes,
 * and left alone when no buffer was given. (Convention: edge/README.md.) Header-only (target
 * vc_proto_models), so that edge/core, which links nothing of ours, uses the same helper.
 */
#ifndef VOXCAP_WHY_H
#define VOXCAP_WHY_H

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>

/* printf-style: writes the line into why[0..why_len). No-op when why is NULL or why_len is 0. */
static inline void vc_whyv(char* why, size_t why_len, const char* fmt, va_list ap)
    __attribute__((format(printf, 3, 0)));
static inline void vc_whyv(char* why, size_t why_len, const char* fmt, va_list ap) {
  if (!why || why_len == 0) return;
  if (vsnprintf(why, why_len, fmt, ap) < 0) why[0] = '\0'; /* encoding error: no half line */
}

static inline void vc_why(char* why, size_t why_len, const char* fmt, ...)
    __attribute__((format(printf, 3, 4)));
static inline void vc_why(char* why, size_t why_len, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vc_whyv(why, why_len, fmt, ap);
  va_end(ap);
}

/* Empties why (no-op without a buffer): a constructor's first step, so "" means "no reason". */
static inline void vc_why_clear(char* why, size_t why_len) {
  if (why && why_len) why[0] = '\0';
}

#endif /* VOXCAP_WHY_H */
