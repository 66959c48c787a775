/* vc_why: the edge's one way to say why something failed.
 *
 * Every edge function that can fail for a reason worth telling takes `char* why, size_t why_len`
 * (NULL/0 when the caller does not want it) and fills it with one line through vc_why(), never with
 * its own snprintf: the reason is always NUL-terminated, silently truncated to why_len - 1 bytes,
 * and left alone when no buffer was given. (Convention: edge/README.md.)
 */
#ifndef VOXCAP_EDGE_WHY_H
#define VOXCAP_EDGE_WHY_H

#include <stdarg.h>
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* printf-style: writes the line into why[0..why_len). No-op when why is NULL or why_len is 0. */
void vc_why(char* why, size_t why_len, const char* fmt, ...) __attribute__((format(printf, 3, 4)));
void vc_whyv(char* why, size_t why_len, const char* fmt, va_list ap) __attribute__((format(printf, 3, 0)));
/* Empties why (no-op without a buffer): a constructor's first step, so "" means "no reason". */
void vc_why_clear(char* why, size_t why_len);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_WHY_H */
