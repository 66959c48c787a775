/* Partial visual hull carving over a voxel grid from the two silhouettes of one edge node
 * (paper section 7). The projection is OpenCV's (cv::projectPoints): x_cam = R x_world + t, pinhole
 * with k1 k2 p1 p2 k3 distortion, continuous pixel position (u, v) with pixel centres at integer
 * coordinates; pixel (x, y) is the square [x-1/2, x+1/2] x [y-1/2, y+1/2]. Three rules (vc_carve_rule):
 *
 * VC_CARVE_CENTRE (the paper's): a voxel is occupied when its centre's pixel (floor(u + 0.5),
 * floor(v + 0.5)) is foreground (nonzero) in both masks; a centre outside an image, or behind a
 * camera (z_cam <= 0), is empty.
 *
 * VC_CARVE_SUBPIXEL: a voxel reads every pixel whose square overlaps the one-pixel square centred on
 * its centre's exact projection (u, v), i.e. x in (u - 1, u + 1) and y in (v - 1, v + 1): the 1 to 4
 * pixels nearest to (u, v), clipped to the image, among them the centre rule's pixel. It is occupied
 * when one of them is foreground in both masks; a centre behind a camera, or whose square lies wholly
 * outside an image, is empty. A mask pixel is foreground when the body covers its centre (about), so
 * the centre rule misses a voxel whose centre is inside the body but within half a pixel of the
 * silhouette's edge; this rule keeps it, at the cost of a hull about half a pixel thicker in each
 * view (far less than the footprint rule's whole voxel). Same machinery and per-frame cost shape as
 * the footprint rule (one or two small dilated masks per camera).
 *
 * VC_CARVE_FOOTPRINT (conservative): per camera, the voxel's 8 corners in normalized coordinates
 * (X/Z, Y/Z) have a bounding box B; without distortion the cube projects inside B (a convex polytope
 * in front of the camera projects to the convex hull of its corners). The distortion and intrinsics
 * g map B to pixels; [u0, u1] x [v0, v1] is the range of g at B's 4 corners, grown on every side by
 * e = s_x + s_y + 1/1024 pixel, where s_x (s_y) is the largest |g(a) - 2 g(m) + g(b)| of u or v over
 * B's 3x3 grid of corners and midpoints along x (y): twice the bilinear-interpolation error bound
 * dx^2/8 |g_xx| + dy^2/8 |g_yy| with the second derivatives taken from those differences. The voxel
 * reads every pixel whose square touches that rectangle:
 *   x in [ceil(u0 - 1/2 - e), floor(u1 + 1/2 + e)], y likewise, clipped to the image,
 * widened to the right and downwards to its class's size, and is occupied when some pixel it reads is
 * foreground in both masks. Precision: a voxel's reads are widened to the largest rectangle of its
 * 4x4x4 leaf, and a camera keeps at most 4 such sizes (classes; more are merged, fewest added pixels
 * first), so a voxel reads up to about one pixel column and row more than its own rectangle (the
 * tests measure 1.3-1.6x the pixels of the exact corner boxes for cameras 3-4 m from the grid).
 * The centre's pixel is always among the pixels read, so the footprint hull holds the centre hull.
 * So, with exact silhouettes (a pixel is foreground when the body's projection meets its square), every
 * voxel that holds some of the body seen by both cameras is kept. Edge cases: a voxel with a corner
 * behind a camera (z_cam <= 0) is empty, like a centre behind it; a voxel whose rectangle lies
 * wholly outside an image is empty (nothing of it is seen); a voxel partly outside an image reads the
 * part of its rectangle inside, so it is kept when that part touches the silhouette (body outside
 * the image cannot be seen, and the superset property holds for the body the cameras see).
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
 * This is the exact rule vc_carver_run() applies to voxel centres under VC_CARVE_CENTRE. */
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
 * under `rule` into *out. Returns 0, -EINVAL (bad camera, grid or rule: the checks' reason) or -ENOMEM,
 * with *out NULL and a one-line reason in why when given (NULL/0 when not wanted; "" on success):
 * edge/README.md's constructor shape. *out owns the carver; free it with vc_carver_free(). Time and
 * memory grow with the voxel count: about 4.5 bytes per voxel seen by both cameras for either rule
 * (more for leaves whose pixels spread over more than 256 pixels); the footprint rule adds per-frame
 * scratch of one width*height byte mask per footprint class and camera (vc_carver_scratch_bytes()),
 * and its construction projects every voxel corner instead of every centre. */
int vc_carver_new(const vc_voxel_grid* grid, const vc_camera* cam0, const vc_camera* cam1, vc_carve_rule rule,
                  vc_carver** out, char* why, size_t why_len);

/* Frees the carver; NULL is a no-op. */
void vc_carver_free(vc_carver* carver);

/* Number of voxels, and bytes of a bitset holding them (ceil(voxels / 8)). */
uint64_t vc_carver_voxels(const vc_carver* carver);
size_t vc_carver_bitset_bytes(const vc_carver* carver);

/* Fraction of the grid's voxels not seen by both cameras under the carver's rule (centre, or
 * footprint, outside an image or behind a camera): those voxels are always empty. The edge warns at
 * CONFIG when this is > 0. */
double vc_carver_unseen_fraction(const vc_carver* carver);

/* Bytes of tables the carver holds (for memory budgets and the benchmark), per-frame scratch included. */
size_t vc_carver_memory_bytes(const vc_carver* carver);

/* Of those, the per-frame scratch: the footprint rule's dilated masks (0 for the centre rule). */
size_t vc_carver_scratch_bytes(const vc_carver* carver);

/* Footprint classes of camera `cam` (0 or 1): distinct rectangle sizes, 1..4 (1 for the centre rule);
 * each is one dilated mask computed per frame. 0 for a bad argument. */
int vc_carver_classes(const vc_carver* carver, int cam);

/* The pixels voxel (i, j, k) reads in each camera, as rect[c] = {x0, y0, x1, y1} (inclusive): its
 * centre's pixel for the centre rule, its widened footprint rectangle for the footprint rule, the up to
 * 2x2 pixels nearest to its centre's projection (widened to its class) for the subpixel rule.
 * Returns 1 when the voxel is seen by both cameras (it is occupied exactly when both rectangles hold
 * foreground), 0 when it is always empty or out of the grid (rect untouched). For tests and tools. */
int vc_carver_footprint(const vc_carver* carver, uint32_t i, uint32_t j, uint32_t k, uint32_t rect[2][4]);

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
