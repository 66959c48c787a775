/* Backend selection by name: the only place that knows every camera backend. Whether "sim" is built
 * in is decided at link time (camera_sim_entry.h). */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "camera_sim_entry.h"
#include "voxcap/edge/camera_backend.h"
#include "voxcap/why.h"

static const vc_camera_backend* const backends[] = {
    &vc_camera_backend_v4l2,
    &vc_camera_backend_libcamera,
    &vc_camera_backend_file,
};

static const char* const names_with_sim[] = {"v4l2", "libcamera", "file", "sim", NULL};
static const char* const names_without_sim[] = {"v4l2", "libcamera", "file", NULL};

const char* const* vc_camera_backend_names(void) {
  return vc_camera_sim_entry ? names_with_sim : names_without_sim;
}

int vc_camera_open(const vc_camera_config* cfg, vc_camera** out, char* why, size_t why_len) {
  if (out) *out = NULL;
  if (!cfg || !out) {
    vc_why(why, why_len, "camera: invalid arguments");
    return -EINVAL;
  }
  if (!cfg->backend || !cfg->backend[0]) {
    vc_why(why, why_len, "camera config: no backend given (one of v4l2, libcamera, file, sim)");
    return -EINVAL;
  }
  for (size_t i = 0; i < sizeof backends / sizeof backends[0]; i++)
    if (strcmp(backends[i]->name, cfg->backend) == 0)
      return vc_camera_open_backend(backends[i], cfg, out, why, why_len);
  if (strcmp(cfg->backend, "sim") == 0) {
    if (vc_camera_sim_entry) return vc_camera_open_backend(vc_camera_sim_entry, cfg, out, why, why_len);
    vc_why(why, why_len,
           "camera config: sim backend not built in (this voxcap-edge was built with -DVOXCAP_SIM=OFF; "
           "use v4l2, libcamera or file)");
    return -ENOTSUP;
  }
  vc_why(why, why_len, "camera config: unknown backend '%s' (one of v4l2, libcamera, file, sim)",
         cfg->backend);
  return -EINVAL;
}
