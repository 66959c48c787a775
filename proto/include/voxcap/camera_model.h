/* The calibrated camera and the voxel grid, once for every C side of voxcap: the CONFIG message
 * (proto.h) carries them, the edge's carver (edge/core carver.h) carves with them, and the rig
 * calibration (hw/rig c_models.hpp) is converted to them in one place.
 *
 * Header-only C11 with no functions and no library behind it: edge/core includes it without linking
 * anything. The conventions are DESIGN.md's:
 *  - camera: OpenCV pinhole model with distortion (k1 k2 p1 p2 k3), x_cam = R_cam_from_world·x_world
 *    + t_cam_from_world; pixel (0,0) is the centre of the top-left pixel;
 *  - grid: voxel (i,j,k) has centre min_m + (i+½, j+½, k+½)·voxel_m, linear index i + nx·(j + ny·k),
 *    hulls are bitsets in that order, bit 0 of byte 0 first.
 * Field order and types are those of proto/SPEC.md's CONFIG grid fields and calibration record.
 * Which values are usable is said by their users (vc_config's decoder, vc_camera_check /
 * vc_grid_check of the carver).
 */
#ifndef VOXCAP_CAMERA_MODEL_H
#define VOXCAP_CAMERA_MODEL_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* A calibrated camera (configuration time only: all doubles). */
typedef struct vc_camera {
  uint32_t width, height;     /* image size the calibration is for, pixels; masks are width*height */
  double K[9];                /* row-major intrinsics [fx 0 cx; 0 fy cy; 0 0 1], pixels */
  double dist[5];             /* k1 k2 p1 p2 k3 (OpenCV order) */
  double R_cam_from_world[9]; /* row-major rotation */
  double t_cam_from_world[3]; /* metres */
} vc_camera;

/* The shared voxel grid, world metres. */
typedef struct vc_voxel_grid {
  uint32_t nx, ny, nz; /* voxels along x, y, z */
  double min_m[3];     /* min corner of voxel (0,0,0), not its centre */
  double voxel_m;      /* voxel edge, > 0 */
} vc_voxel_grid;

/* Which voxels a partial hull keeps (CONFIG's `carve_rule`, proto/SPEC.md; rig.toml [carving] rule):
 *  - VC_CARVE_CENTRE: the voxel's centre projects onto a silhouette pixel in both cameras (the paper's rule);
 *  - VC_CARVE_FOOTPRINT: the voxel's projected footprint touches a silhouette pixel in both cameras, so
 *    the hull holds every voxel that holds some of the body when the silhouettes are exact (a superset
 *    of the body, at the price of about half a voxel of extra thickness on every surface);
 *  - VC_CARVE_SUBPIXEL (2.2): a one-pixel square centred on the voxel centre's exact (sub-pixel)
 *    projection touches a silhouette pixel in both cameras: the centre rule without its rounding to
 *    one pixel, so a voxel whose centre is inside the body is kept although the pixel its centre
 *    rounds to lies just outside a mask edge (1 to 4 pixels read instead of 1). */
typedef enum vc_carve_rule {
  VC_CARVE_CENTRE = 0,
  VC_CARVE_FOOTPRINT = 1,
  VC_CARVE_SUBPIXEL = 2
} vc_carve_rule;
#define VC_CARVE_RULE_COUNT 3

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_CAMERA_MODEL_H */
