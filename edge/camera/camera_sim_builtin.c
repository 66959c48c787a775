/* Built with VOXCAP_SIM=ON: the factory's "sim" entry is the sim backend (camera_sim.cpp, hw/sim). */
#include "camera_sim_entry.h"

const vc_camera_backend* const vc_camera_sim_entry = &vc_camera_backend_sim;
