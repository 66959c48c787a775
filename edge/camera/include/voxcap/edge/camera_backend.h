/* vc_camera_backend: what a camera backend implements (the struct of function pointers behind
 * vc_camera). The common layer (camera.c) owns the state machine, the held RGB frame buffers, the
 * statistics and the error string; a backend only talks to its device and converts into the RGB
 * buffer it is handed. Backends never see each other; the factory (camera_factory.c) maps names to
 * them. A program that needs one backend only (the static V4L2 VM test) links camera.c plus that
 * backend and calls vc_camera_open_backend().
 */
#ifndef VOXCAP_EDGE_CAMERA_BACKEND_H
#define VOXCAP_EDGE_CAMERA_BACKEND_H

#include <stdarg.h>

#include "voxcap/edge/camera.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vc_camera_backend {
  const char* name;
  /* Opens and configures the device. Fills info->width/height (actual), pixfmt, fps, buffers,
   * driver. *priv receives the backend's state (freed by free_priv). On failure: report the error
   * with vc_camera_set_error, release everything, return its code. */
  int (*open)(vc_camera* cam, const vc_camera_config* cfg, vc_camera_info* info, void** priv);
  int (*start)(vc_camera* cam, void* priv);
  /* Waits up to timeout_ms (< 0: forever) for a frame and converts it into rgb (info's size,
   * `stride` bytes per row). Fills meta->t_ns, sequence, index, flags. */
  int (*capture)(vc_camera* cam, void* priv, int timeout_ms, uint8_t* rgb, size_t stride, vc_frame* meta);
  int (*stop)(vc_camera* cam, void* priv);
  void (*free_priv)(void* priv);
  /* Optional (NULL: -ENOTSUP): emulated external trigger. */
  int (*soft_trigger)(vc_camera* cam, void* priv, uint64_t seq, uint64_t t_ns);
  /* Optional (NULL: none): VC_CAMERA_CAP_* of this open camera. */
  uint32_t (*caps)(const void* priv);
  /* Optional (NULL: -ENOTSUP): see vc_camera_rewind; called while stopped. */
  int (*rewind)(vc_camera* cam, void* priv, uint64_t seq_base, vc_camera_scene scene);
} vc_camera_backend;

extern const vc_camera_backend vc_camera_backend_v4l2;
extern const vc_camera_backend vc_camera_backend_libcamera;
extern const vc_camera_backend vc_camera_backend_file;
extern const vc_camera_backend vc_camera_backend_sim;

/* Opens a camera on an explicit backend (cfg->backend is ignored). Same contract as vc_camera_open. */
int vc_camera_open_backend(const vc_camera_backend* backend, const vc_camera_config* cfg, vc_camera** out,
                           char* why, size_t why_len);
/* The same with an object for the backend (borrowed; the backend's own open function says what it
 * is), which the backend's open reads with vc_camera_backend_arg. */
int vc_camera_open_backend_arg(const vc_camera_backend* backend, const vc_camera_config* cfg, const void* arg,
                               vc_camera** out, char* why, size_t why_len);
/* For backends, during open: the object given to vc_camera_open_backend_arg (NULL if none). */
const void* vc_camera_backend_arg(const vc_camera* cam);

/* For backends: records "<backend>: <device>: <message>" as the camera's last error and returns
 * code (a negative errno), so that `return vc_camera_set_error(cam, -ENOENT, "...")` reads well. */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
int vc_camera_set_error(vc_camera* cam, int code, const char* fmt, ...);
#if defined(__GNUC__)
__attribute__((format(printf, 3, 0)))
#endif
int vc_camera_set_verror(vc_camera* cam, int code, const char* fmt, va_list ap);
/* For backends: counts a frame the driver delivered marked corrupt (it is skipped). */
void vc_camera_count_corrupted(vc_camera* cam);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_CAMERA_BACKEND_H */
