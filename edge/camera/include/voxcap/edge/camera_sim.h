/* The "sim" camera backend's own entry point (built with VOXCAP_SIM, the default; see camera_sim.cpp
 * for its device spec and options). */
#ifndef VOXCAP_EDGE_CAMERA_SIM_H
#define VOXCAP_EDGE_CAMERA_SIM_H

#include "voxcap/edge/camera.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Opens a "sim" camera on a scene the caller built: `scene` is a const vc::sim::Scene*, borrowed —
 * it must outlive the camera (e.g. shared with the caller's reference renders); cfg->device is
 * ignored and cfg->backend need not be set. Otherwise as vc_camera_open. */
int vc_camera_open_sim(const vc_camera_config* cfg, const void* scene, vc_camera** out, char* why,
                       size_t why_len);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_CAMERA_SIM_H */
