/* Partial visual hull carving over a voxel grid from the two silhouettes of one edge node
 * (paper section 7).
 *
 * A voxel is occupied when its centre projects inside the silhouette (nonzero mask pixel) of both
 * cameras; a centre outside an image, or behind a camera, is empty. The projection is OpenCV's
 * (cv::projectPoints): x_cam = R x_world + t, pinhole with k1 k2 p1 p2 k3 distortion, and the pixel
 * is (floor(u + 0.5), floor(v + 0.5)), pixel centres at integer coordinates.
 *
 * vc_carver_new() does all floating-point work at configuration time; vc_carver_run() is integer-only
 * and allocation-free. The output bitset is voxel i + nx*(j + ny*k), bit 0 of byte 0 first, exactly as
 * the RLE of proto/ expects (vc_rle_encode(bitset, vc_carver_voxels(c), ...)).
 */
#ifndef VOXCAP_EDGE_CARVER_H
#define VOXCAP_EDGE_CARVER_H

#include <stddef.h>
#include <stdint.h>

#include "voxcap/camera_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The camera (vc_camera) and the grid (vc_voxel_grid) are the ones CONFIG carries, from
 * proto/include/voxcap/camera_model.h (header only: nothing to link). The carver's own limits are
 * those of vc_camera_check() and vc_grid_check(). */

/* Projects p_world with the carver's camera model. Returns 1 and the pixel in *px, *py when the point
 * is in front of the camera and its pixel lies inside the image, 0 otherwise (*px, *py untouched).
 * This is the exact rule vc_carver_run() applies to voxel centres. */
int vc_camera_project(const vc_camera* cam, const double p_world[3], int* px, int* py);

/* 0 when the camera is usable by the carver, -EINVAL otherwise, with a one-line reason in why when
 * given (NULL/0 when not wanted; "" when usable; edge/README.md's convention). Cameras: image
 * 1..16384 pixels each way, K = [fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0 (cv::projectPoints ignores
 * skew), finite distortion, R_cam_from_world a rotation within 1e-6, finite t. Grids: finite min_m,
 * voxel_m > 0, nx, ny, nz 1..4096 each and at most 2^31 voxels. */
int vc_camera_check(const vc_camera* cam, char* why, size_t why_len);
int vc_grid_check(const vc_voxel_grid* grid, char* why, size_t why_len);

typedef struct vc_carver vc_carver;

/* Builds the carver's tables for `grid` seen by `cam0` and `cam1` (all three borrowed for the call)
 * into *out. Returns 0, -EINVAL (bad camera or grid: the checks' reason) or -ENOMEM, with *out NULL
 * and a one-line reason in why when given (NULL/0 when not wanted; "" on success): edge/README.md's
 * constructor shape. *out owns the carver; free it with vc_carver_free(). Time and memory grow with the voxel
 * count: about 4.5 bytes per voxel seen by both cameras (more for voxels that project larger than 64 pixels).
 */
int vc_carver_new(const vc_voxel_grid* grid, const vc_camera* cam0, const vc_camera* cam1, vc_carve_rule rule,
                  vc_carver** out, char* why, size_t why_len);

/* Frees the carver; NULL is a no-op. */
void vc_carver_free(vc_carver* carver);

/* Number of voxels, and bytes of a bitset holding them (ceil(voxels / 8)). */
uint64_t vc_carver_voxels(const vc_carver* carver);
size_t vc_carver_bitset_bytes(const vc_carver* carver);

/* Fraction of the grid's voxels whose centre is not seen by both cameras (outside an image or
 * behind a camera): those voxels are always empty. The edge warns at CONFIG when this is > 0. */
double vc_carver_unseen_fraction(const vc_carver* carver);

/* Bytes of tables the carver holds (for memory budgets and the benchmark). */
size_t vc_carver_memory_bytes(const vc_carver* carver);

/* What a run did (optional output of vc_carver_run). */
typedef struct vc_carve_stats {
  uint64_t occupied;       /* voxels set in the bitset */
  uint32_t blocks_skipped; /* blocks (any level) proved empty by the tile summaries */
  uint32_t blocks_filled;  /* blocks (any level) proved full */
  uint32_t leaves_tested;  /* 4x4x4 leaves tested voxel by voxel */
} vc_carve_stats;

/* Carves one frame. mask0/mask1: cam0's and cam1's silhouettes (width*height bytes, stride width,
 * nonzero = foreground), borrowed for the call. bitset: caller-owned, vc_carver_bitset_bytes() bytes,
 * fully overwritten (bits past the last voxel are 0). `stats` may be NULL. Integer-only, no
 * allocation. The carver keeps per-frame scratch, so one carver runs one frame at a time.
 * Returns 0 or -EINVAL. */
int vc_carver_run(vc_carver* carver, const uint8_t* mask0, const uint8_t* mask1, uint8_t* bitset,
                  vc_carve_stats* stats);

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_EDGE_CARVER_H */
