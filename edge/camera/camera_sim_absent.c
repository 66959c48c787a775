/* Built with VOXCAP_SIM=OFF (a board's voxcap-edge): no sim backend, hence no renderer; the factory
 * answers "sim" with a clear error. */
#include "camera_sim_entry.h"

const vc_camera_backend* const vc_camera_sim_entry = NULL;
