/* The factory's "sim" entry: &vc_camera_backend_sim when the sim backend is built in (VOXCAP_SIM,
 * camera_sim_builtin.c), NULL when not (camera_sim_absent.c). CMake links exactly one of the two, so
 * the choice is made at link time, not by #ifdef. Internal to edge/camera. */
#ifndef VOXCAP_EDGE_CAMERA_SIM_ENTRY_H
#define VOXCAP_EDGE_CAMERA_SIM_ENTRY_H

#include "voxcap/edge/camera_backend.h"

#ifdef __cplusplus
extern "C" {
#endif

extern const vc_camera_backend* const vc_camera_sim_entry;

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_CAMERA_SIM_ENTRY_H */
