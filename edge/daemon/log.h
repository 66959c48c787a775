/* vc_log: the edge daemon's one logger.
 *
 * One level scale, the host's (spdlog's) names, so a line reads the same on both sides:
 * debug < info < warning < error. One sink: stderr, one line per call with a wall-clock timestamp and
 * the level as spdlog's default pattern prints them ("[2026-11-24 12:52:05.123] [warning] voxcap-edge:
 * ..."). The threshold comes from the daemon's verbosity (--verbosity / [log] verbosity: 0 warnings,
 * 1 info, 2 debug). Thread-safe: every call writes its line with one stdio call. Tests may redirect the
 * sink to capture lines.
 */
#ifndef VOXCAP_EDGE_LOG_H
#define VOXCAP_EDGE_LOG_H

#include <stdarg.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vc_log_level {
  VC_LOG_DEBUG = 0,
  VC_LOG_INFO = 1,
  VC_LOG_WARN = 2,
  VC_LOG_ERROR = 3,
} vc_log_level;

/* "debug", "info", "warning", "error" (spdlog's names); NULL for anything else. */
const char* vc_log_level_name(vc_log_level level);
/* The lowest level written (default VC_LOG_INFO). */
void vc_log_set_level(vc_log_level min);
vc_log_level vc_log_get_level(void);
/* The daemon's verbosity (0 warnings, 1 info, 2 debug; below 0 as 0, above 2 as 2) as a threshold. */
vc_log_level vc_log_level_from_verbosity(int verbosity);
/* True when a line at this level would be written. */
int vc_log_enabled(vc_log_level level);

void vc_log(vc_log_level level, const char* fmt, ...) __attribute__((format(printf, 2, 3)));
void vc_logv(vc_log_level level, const char* fmt, va_list ap) __attribute__((format(printf, 2, 0)));

/* Where lines go (NULL: stderr, the default): the sink gets the level and the message without
 * timestamp, level or prefix. For tests; set it before any thread logs. */
typedef void (*vc_log_sink)(void* user, vc_log_level level, const char* msg);
void vc_log_set_sink(vc_log_sink sink, void* user);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_LOG_H */
