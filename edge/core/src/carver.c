/* Partial visual hull carving (paper section 7): hierarchical, exact, integer-only per frame.
 *
 * The paper precomputes every voxel's projection per static camera. A plain table of pixel indices
 * costs 8 bytes per voxel for two cameras (134 MB at 256^3) and reads all of it every frame. Here:
 *
 * Configuration (floats allowed): the grid is cut into 16^3 top blocks, each into 8^3 mid blocks,
 * each into 4^3 leaves. Every voxel centre is projected once with OpenCV's model (including
 * distortion). Each block keeps, per camera, the range of 8x8-pixel image tiles covering the pixels
 * of its voxel centres (an exact bound: it is built from the centres' own pixels), and whether all of
 * its voxels are seen. Each leaf seen by both cameras keeps, per voxel and camera, the pixel as a
 * 2-byte linear offset dv * W + du from the top-left corner of the leaf's pixel rectangle (so a
 * voxel's test is two loads and no address arithmetic), plus a 64-bit mask of voxels seen by both.
 * That is 4.25 bytes per voxel, and only for leaves both cameras see.
 *
 * Per frame: each mask is summarised per 8x8 tile as "any foreground" and "all foreground" (eight
 * 64-bit words per tile), and both summaries get a summed-area table (80x60 tiles at 640x480).
 * Then, top-down, a block whose tile range holds no foreground tile in one camera is empty, a block
 * whose tiles are all full in both cameras (and whose voxels are all seen) is filled, and only the
 * remaining leaves are tested voxel by voxel, for the cameras that are still undecided. The tile
 * bounds are conservative, so the result equals the per-voxel rule exactly; tiles only decide how
 * much work is skipped. A human in a 2-camera hull leaves most blocks empty or full.
 *
 * The footprint rule (carver.h) keeps this shape. A voxel's footprint rectangle is computed at
 * configuration time (corners in normalized coordinates, the distortion at their box's corners plus
 * a curvature bound); the voxel keeps its top-left pixel in the same 2-byte offsets, and its leaf a
 * rectangle size: the largest of its voxels', rounded up to one of at most 4 sizes (classes) per
 * camera. Per frame each class's mask is dilated by its size (byte OR over [x, x+w) x [y, y+h), 64
 * bits at a time), only in the 8x8 tiles within reach of a foreground tile, so a voxel's test is
 * still one byte read; block tile ranges are built from the anchors grown by the class size, so
 * pruning stays exact. A class is dilated from the largest smaller class it contains, by the
 * difference of the sizes. Cost: the dilated tiles (about (8+h-1)w + 8h word operations each, for
 * the few tiles near the silhouette) and more leaves tested, as the footprint hull is thicker;
 * memory: W*H bytes per class and camera, the tables as for the centre rule.
 *
 * A leaf whose rectangle's linear offsets exceed 16 bits (about 100 rows at 640 wide: voxels close
 * to a camera) keeps 4-byte pixel indices instead; that is rare in a sensible rig and costs only memory.
 * Limits: grids up to 4096 per axis and 2^31 voxels; images up to 16384 pixels a side.
 */
#include "voxcap/edge/carver.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "dispatch.h"
#include "voxcap/why.h"

#if VC_HAVE_NEON_VARIANT
#include <arm_neon.h>
#endif
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#define TOP 16
#define MID 8
#define LEAF 4
#define TILE_SHIFT 3 /* 8x8-pixel tiles */
#define NO_TAB UINT32_MAX
#define MAX_CLASS 4 /* footprint rectangle sizes (dilated masks) per camera */

enum {
  F_SKIP = 1,  /* no voxel of the block is seen by both cameras: always empty */
  F_ALL0 = 2,  /* every voxel of the block (inside the grid) is seen by camera 0 */
  F_ALL1 = 4,  /* ... by camera 1 */
  F_NONE0 = 8, /* no voxel of the block is seen by camera 0 (rect 0 meaningless) */
  F_NONE1 = 16,
};

enum { S_OUT = 0, S_PART = 1, S_FULL = 2 };

typedef struct node {
  uint16_t r[2][4]; /* per camera: tx0, ty0, tx1, ty1 (inclusive tile range) */
  uint8_t flags;
} node;

typedef struct leaf_tab {
  uint64_t valid;   /* bit v: voxel v (x + 4y + 16z) is in the grid and seen by both cameras */
  uint32_t base[2]; /* per camera: pixel index of the leaf rectangle's top-left corner */
  uint32_t wide;    /* NO_TAB, or index into `wide`: the leaf's rectangle is too large for 2-byte
                     * linear offsets (voxels close to a camera), so it keeps full pixel indices */
  uint8_t cls[2];   /* per camera: footprint class (index into vc_carver.cls; 0, 1x1, for the centre rule) */
} leaf_tab;

/* A footprint class: every voxel of its leaves reads one byte of the mask dilated by w x h. */
typedef struct fp_class {
  int w, h;       /* rectangle size, pixels */
  uint8_t* dil;   /* W*H: byte (x, y) = any foreground in [x, x+w) x [y, y+h), clipped to the image;
                   * NULL for 1x1 (the mask itself) */
  uint32_t* done; /* [tw*th]: the tiles of dil the last frame computed (the others are zero) */
  uint32_t* todo; /* [tw*th]: this frame's (scratch) */
  uint8_t* mark;  /* [tw*th]: tile is in todo (scratch, zero between frames) */
  uint32_t ndone;
  int from; /* per frame, dilate the mask (-1) or this smaller class's dilated mask, computed first */
} fp_class;

typedef struct cam_frame {
  int tw, th;          /* tiles across and down */
  uint32_t* sat_any;   /* (tw+1)*(th+1) summed-area table of "tile has foreground" */
  uint32_t* sat_full;  /* same for "tile is all foreground" */
  uint8_t *any, *full; /* tw*th per-tile flags (scratch) */
  uint32_t* fg;        /* [tw*th]: this frame's tiles with foreground (footprint rule only) */
  uint32_t nfg;
} cam_frame;

/* The grid as the loops index it: int dimensions (checked <= 4096 each by vc_grid_check). */
typedef struct grid_i {
  double min[3];
  double voxel_m;
  int nx, ny, nz;
} grid_i;

struct vc_carver {
  vc_carve_rule rule;
  grid_i grid;
  int W[2], H[2];
  int tbx, tby, tbz;      /* top blocks per axis */
  node *top, *mid, *leaf; /* [ntop], [8*ntop], [64*ntop] */
  uint32_t* leaf_tab_idx; /* [64*ntop]: index into tabs or NO_TAB */
  leaf_tab* tabs;         /* [ntabs] */
  uint16_t* entries;      /* [ntabs * 2 * 64]: dv * W + du per camera and voxel */
  uint32_t* wide;         /* [nwide * 2 * 64]: pixel index per camera and voxel (wide leaves) */
  size_t ntabs, nwide, wide_cap;
  uint64_t nvox;
  double unseen_fraction;
  size_t memory, scratch; /* scratch: the dilated masks, part of memory */
  cam_frame fr[2];
  fp_class cls[2][MAX_CLASS];
  int ncls[2];
  int order[2][MAX_CLASS]; /* per camera: classes by area, each computed after the one it starts from */
};

/* ---- configuration ---------------------------------------------------------------------------- */

int vc_camera_check(const vc_camera* c, char* why, size_t why_len) {
  vc_why_clear(why, why_len);
  if (c == NULL) {
    vc_why(why, why_len, "camera is NULL");
    return -EINVAL;
  }
  if (c->width < 1 || c->height < 1 || c->width > 16384 || c->height > 16384) {
    vc_why(why, why_len, "image size %ux%u must be 1..16384 each", c->width, c->height);
    return -EINVAL;
  }
  if (!(c->K[0] > 0.0 && c->K[4] > 0.0 && isfinite(c->K[2]) && isfinite(c->K[5]))) {
    vc_why(why, why_len, "K must have positive finite fx, fy and finite cx, cy, not fx %g fy %g cx %g cy %g",
           c->K[0], c->K[4], c->K[2], c->K[5]);
    return -EINVAL;
  }
  if (c->K[1] != 0.0 || c->K[3] != 0.0 || c->K[6] != 0.0 || c->K[7] != 0.0 || c->K[8] != 1.0) {
    vc_why(why, why_len, "K must be [fx 0 cx; 0 fy cy; 0 0 1] (OpenCV's projection ignores skew)");
    return -EINVAL;
  }
  for (int i = 0; i < 5; i++)
    if (!isfinite(c->dist[i])) {
      vc_why(why, why_len, "distortion coefficient %d must be finite", i);
      return -EINVAL;
    }
  for (int i = 0; i < 9; i++)
    if (!isfinite(c->R_cam_from_world[i])) {
      vc_why(why, why_len, "R must be finite");
      return -EINVAL;
    }
  for (int i = 0; i < 3; i++)
    if (!isfinite(c->t_cam_from_world[i])) {
      vc_why(why, why_len, "t must be finite");
      return -EINVAL;
    }
  /* R must be a rotation: R R^T = I within 1e-6. */
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) {
      double d = 0.0;
      for (int k = 0; k < 3; k++) d += c->R_cam_from_world[3 * a + k] * c->R_cam_from_world[3 * b + k];
      if (fabs(d - (a == b ? 1.0 : 0.0)) > 1e-6) {
        vc_why(why, why_len, "R must be a rotation matrix (R R^T is off by %g at row %d, column %d)",
               d - (a == b ? 1.0 : 0.0), a, b);
        return -EINVAL;
      }
    }
  return 0;
}

int vc_grid_check(const vc_voxel_grid* g, char* why, size_t why_len) {
  vc_why_clear(why, why_len);
  if (g == NULL) {
    vc_why(why, why_len, "grid is NULL");
    return -EINVAL;
  }
  if (!(g->voxel_m > 0.0 && isfinite(g->voxel_m))) {
    vc_why(why, why_len, "voxel size must be positive, not %g m", g->voxel_m);
    return -EINVAL;
  }
  if (!isfinite(g->min_m[0]) || !isfinite(g->min_m[1]) || !isfinite(g->min_m[2])) {
    vc_why(why, why_len, "grid min corner must be finite");
    return -EINVAL;
  }
  if (g->nx < 1 || g->ny < 1 || g->nz < 1 || g->nx > 4096 || g->ny > 4096 || g->nz > 4096) {
    vc_why(why, why_len, "grid dimensions must be 1..4096 each, not %ux%ux%u", g->nx, g->ny, g->nz);
    return -EINVAL;
  }
  if ((uint64_t)g->nx * (uint64_t)g->ny * (uint64_t)g->nz > (1ull << 31)) {
    vc_why(why, why_len, "grid has more than 2^31 voxels (%ux%ux%u)", g->nx, g->ny, g->nz);
    return -EINVAL;
  }
  return 0;
}

/* OpenCV's projectPoints model (modules/calib3d, cvProjectPoints2Internal) for one point: the
 * continuous pixel position (u, v), pixel centres at integers. Returns 0 when the point is not in
 * front of the camera (z_cam <= 0; u, v untouched). */
static inline void distort(const vc_camera* c, double x, double y, double* pu, double* pv);

/* Normalized coordinates (X/Z, Y/Z) of p_world; 0 when not in front of the camera. */
static inline int normalize(const vc_camera* c, const double p[3], double* px, double* py) {
  const double *R = c->R_cam_from_world, *t = c->t_cam_from_world;
  double X = R[0] * p[0] + R[1] * p[1] + R[2] * p[2] + t[0];
  double Y = R[3] * p[0] + R[4] * p[1] + R[5] * p[2] + t[1];
  double Z = R[6] * p[0] + R[7] * p[1] + R[8] * p[2] + t[2];
  if (!(Z > 0.0)) return 0;
  double z = 1.0 / Z;
  *px = X * z;
  *py = Y * z;
  return 1;
}

static int project_uv(const vc_camera* c, const double p[3], double* pu, double* pv) {
  double x, y;
  if (!normalize(c, p, &x, &y)) return 0;
  distort(c, x, y, pu, pv);
  return 1;
}

/* Lens distortion and intrinsics: normalized (x, y) to the pixel position (u, v). */
static inline void distort(const vc_camera* c, double x, double y, double* pu, double* pv) {
  double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double* k = c->dist; /* k1 k2 p1 p2 k3 */
  double radial = 1.0 + k[0] * r2 + k[1] * r4 + k[4] * r6;
  double a1 = 2.0 * x * y, a2 = r2 + 2.0 * x * x, a3 = r2 + 2.0 * y * y;
  double xd = x * radial + k[2] * a1 + k[3] * a2;
  double yd = y * radial + k[2] * a3 + k[3] * a1;
  *pu = xd * c->K[0] + c->K[2];
  *pv = yd * c->K[4] + c->K[5];
}

int vc_camera_project(const vc_camera* c, const double p[3], int* px, int* py) {
  double u, v;
  if (!project_uv(c, p, &u, &v)) return 0;
  double fu = floor(u + 0.5), fv = floor(v + 0.5);
  if (!(fu >= 0.0 && fu < (double)c->width && fv >= 0.0 && fv < (double)c->height)) return 0;
  *px = (int)fu;
  *py = (int)fv;
  return 1;
}

static int imin(int a, int b) {
  return a < b ? a : b;
}
static int imax(int a, int b) {
  return a > b ? a : b;
}

/* Pixel rectangle accumulator of one camera over a block. */
typedef struct prect {
  int x0, y0, x1, y1;
  uint64_t seen; /* voxels seen */
} prect;

static void prect_init(prect* r) {
  r->x0 = r->y0 = INT32_MAX;
  r->x1 = r->y1 = -1;
  r->seen = 0;
}

static void prect_add(prect* r, int x, int y) {
  r->x0 = imin(r->x0, x);
  r->y0 = imin(r->y0, y);
  r->x1 = imax(r->x1, x);
  r->y1 = imax(r->y1, y);
  r->seen++;
}

static void prect_union(prect* r, const prect* s) {
  if (s->seen == 0) return;
  r->x0 = imin(r->x0, s->x0);
  r->y0 = imin(r->y0, s->y0);
  r->x1 = imax(r->x1, s->x1);
  r->y1 = imax(r->y1, s->y1);
  r->seen += s->seen;
}

/* Summary of a block while building: rects over the voxels of non-skipped children. */
typedef struct bsum {
  prect r[2];
  bool skip, all0, all1;
} bsum;

static void bsum_init(bsum* b) {
  prect_init(&b->r[0]);
  prect_init(&b->r[1]);
  b->skip = true;
  b->all0 = b->all1 = true;
}

static void bsum_merge(bsum* b, const bsum* c) {
  b->all0 = b->all0 && c->all0;
  b->all1 = b->all1 && c->all1;
  if (c->skip) return;
  b->skip = false;
  prect_union(&b->r[0], &c->r[0]);
  prect_union(&b->r[1], &c->r[1]);
}

static void node_set(node* n, const bsum* b) {
  memset(n, 0, sizeof(*n));
  n->flags = (uint8_t)((b->skip ? F_SKIP : 0) | (b->all0 ? F_ALL0 : 0) | (b->all1 ? F_ALL1 : 0));
  for (int c = 0; c < 2; c++) {
    if (b->skip || b->r[c].seen == 0) {
      n->flags |= (uint8_t)(c == 0 ? F_NONE0 : F_NONE1);
      continue;
    }
    n->r[c][0] = (uint16_t)(b->r[c].x0 >> TILE_SHIFT);
    n->r[c][1] = (uint16_t)(b->r[c].y0 >> TILE_SHIFT);
    n->r[c][2] = (uint16_t)(b->r[c].x1 >> TILE_SHIFT);
    n->r[c][3] = (uint16_t)(b->r[c].y1 >> TILE_SHIFT);
  }
  if (n->flags & (F_NONE0 | F_NONE1)) n->flags |= F_SKIP;
}

static void voxel_centre(const grid_i* g, int i, int j, int k, double p[3]) {
  p[0] = g->min[0] + ((double)i + 0.5) * g->voxel_m;
  p[1] = g->min[1] + ((double)j + 0.5) * g->voxel_m;
  p[2] = g->min[2] + ((double)k + 0.5) * g->voxel_m;
}

/* What one leaf's voxels read, per camera, before it is known whether the leaf gets a table: the
 * anchor pixel (top-left of the footprint rectangle; the centre's pixel for the centre rule) and
 * the rectangle's size. */
typedef struct leaf_proj {
  int px[2][64], py[2][64];
  int pw[2][64], ph[2][64]; /* footprint rectangle, pixels (1x1 for the centre rule) */
  uint64_t seen[2];         /* bit v: voxel v in the grid and seen by camera c */
  uint64_t in_grid;
} leaf_proj;

#define LAT (LEAF + 1) /* voxel corners per leaf axis */

/* min and max of two finite doubles (fmin/fmax are library calls without -ffast-math) */
static inline double dmin(double a, double b) {
  return a < b ? a : b;
}
static inline double dmax(double a, double b) {
  return a > b ? a : b;
}

/* The footprint rule's rectangles of the 64 voxels of a leaf in camera `cam` (see carver.h). In
 * normalized coordinates (X/Z, Y/Z) a voxel in front of the camera projects to the convex hull of its
 * 8 corners, inside their bounding box B. The distortion g maps B to pixels; u (and v) over B is at
 * most its largest value at B's 4 corners plus the bilinear-interpolation error, bounded by
 * e = dx^2/8 max|g_xx| + dy^2/8 max|g_yy| (dx, dy: B's size). The second derivatives are estimated
 * per voxel from second differences of g on a 3x3 grid over B, and e is doubled for their
 * variation. The rectangle then takes every pixel whose square touches [u0 - e, u1 + e] x
 * [v0 - e, v1 + e], clipped to the image. */
static void footprint_leaf(const grid_i* g, const vc_camera* cam, int W, int H, int i0, int j0, int k0, int c,
                           leaf_proj* lp) {
  double X[LAT * LAT * LAT], Y[LAT * LAT * LAT];
  bool front[LAT * LAT * LAT];
  for (int z = 0; z < LAT; z++)
    for (int y = 0; y < LAT; y++)
      for (int x = 0; x < LAT; x++) {
        int n = x + LAT * (y + LAT * z);
        double p[3] = {g->min[0] + (double)(i0 + x) * g->voxel_m, g->min[1] + (double)(j0 + y) * g->voxel_m,
                       g->min[2] + (double)(k0 + z) * g->voxel_m};
        front[n] = normalize(cam, p, &X[n], &Y[n]) && isfinite(X[n]) && isfinite(Y[n]);
      }
  for (int v = 0; v < 64; v++) {
    if (!(lp->in_grid >> v & 1)) continue;
    int x = v & 3, y = v >> 2 & 3, z = v >> 4;
    bool ok = true;
    double bx0 = INFINITY, bx1 = -INFINITY, by0 = INFINITY, by1 = -INFINITY;
    for (int q = 0; q < 8; q++) {
      int n = (x + (q & 1)) + LAT * ((y + (q >> 1 & 1)) + LAT * (z + (q >> 2)));
      ok = ok && front[n];
      bx0 = dmin(bx0, X[n]);
      bx1 = dmax(bx1, X[n]);
      by0 = dmin(by0, Y[n]);
      by1 = dmax(by1, Y[n]);
    }
    if (!ok) continue; /* reaches behind the camera: unseen */
    /* g on the 3x3 grid over B: the corners' range, and second differences along x and y */
    double gu[3][3], gv[3][3];
    bool finite = true;
    const double xs[3] = {bx0, 0.5 * (bx0 + bx1), bx1}, ys[3] = {by0, 0.5 * (by0 + by1), by1};
    for (int b = 0; b < 3; b++)
      for (int a = 0; a < 3; a++) {
        distort(cam, xs[a], ys[b], &gu[b][a], &gv[b][a]);
        finite = finite && isfinite(gu[b][a]) && isfinite(gv[b][a]);
      }
    double u0 = INFINITY, u1 = -INFINITY, v0 = INFINITY, v1 = -INFINITY, sxx = 0.0, syy = 0.0;
    for (int q = 0; q < 4; q++) {
      int a = (q & 1) * 2, b = (q >> 1) * 2;
      u0 = dmin(u0, gu[b][a]);
      u1 = dmax(u1, gu[b][a]);
      v0 = dmin(v0, gv[b][a]);
      v1 = dmax(v1, gv[b][a]);
    }
    for (int k = 0; k < 3; k++) {
      sxx = dmax(
          sxx, dmax(fabs(gu[k][0] - 2.0 * gu[k][1] + gu[k][2]), fabs(gv[k][0] - 2.0 * gv[k][1] + gv[k][2])));
      syy = dmax(
          syy, dmax(fabs(gu[0][k] - 2.0 * gu[1][k] + gu[2][k]), fabs(gv[0][k] - 2.0 * gv[1][k] + gv[2][k])));
    }
    /* a second difference with step d/2 is (d/2)^2 g'': the bound d^2/8 |g''| is half of it; doubled */
    double e = sxx + syy + 1.0 / 1024.0;
    if (!(e < 1e6)) e = 1e6;
    if (!finite) continue; /* beyond the model */
    /* pixel x's square [x-1/2, x+1/2] touches [u0 - e, u1 + e] iff u0 - e - 1/2 <= x <= u1 + e + 1/2 */
    double x0 = dmax(ceil(u0 - 0.5 - e), 0.0), x1 = dmin(floor(u1 + 0.5 + e), (double)(W - 1));
    double y0 = dmax(ceil(v0 - 0.5 - e), 0.0), y1 = dmin(floor(v1 + 0.5 + e), (double)(H - 1));
    if (!(x0 <= x1 && y0 <= y1)) continue; /* wholly outside the image */
    lp->seen[c] |= 1ull << v;
    lp->px[c][v] = (int)x0;
    lp->py[c][v] = (int)y0;
    lp->pw[c][v] = (int)(x1 - x0) + 1;
    lp->ph[c][v] = (int)(y1 - y0) + 1;
  }
}

/* The subpixel rule's rectangle of voxel v (centre p) in camera `cam` (see carver.h): pixel x's square
 * [x - 1/2, x + 1/2] overlaps [u - 1/2, u + 1/2] iff u - 1 < x < u + 1, so x runs from
 * floor(u - 1) + 1 to ceil(u + 1) - 1 (one pixel when u is an integer, else two), clipped to the image. */
static void subpixel_voxel(const vc_camera* cam, const double p[3], int W, int H, int v, int c,
                           leaf_proj* lp) {
  double u, w;
  if (!project_uv(cam, p, &u, &w) || !(fabs(u) < 1e6 && fabs(w) < 1e6)) return; /* behind, or absurd */
  double x0 = dmax(floor(u - 1.0) + 1.0, 0.0), x1 = dmin(ceil(u + 1.0) - 1.0, (double)(W - 1));
  double y0 = dmax(floor(w - 1.0) + 1.0, 0.0), y1 = dmin(ceil(w + 1.0) - 1.0, (double)(H - 1));
  if (!(x0 <= x1 && y0 <= y1)) return; /* wholly outside the image */
  lp->seen[c] |= 1ull << v;
  lp->px[c][v] = (int)x0;
  lp->py[c][v] = (int)y0;
  lp->pw[c][v] = (int)(x1 - x0) + 1;
  lp->ph[c][v] = (int)(y1 - y0) + 1;
}

/* Per leaf with a table, while building (freed at the end of vc_carver_new): what the node ranges
 * and the footprint classes are made from. Pixel coordinates fit 16 bits (images <= 16384). */
typedef struct leaf_build {
  uint16_t r[2][4];    /* per camera: bounding box of the voxels' anchors x0, y0, x1, y1 */
  uint16_t w[2], h[2]; /* per camera: largest footprint rectangle of the leaf's voxels */
} leaf_build;

/* Builds one leaf at voxel origin (i0, j0, k0): the F_ALL flags of its node, and its table and
 * leaf_build when both cameras see some voxel of it. Returns 0 or -ENOMEM. */
static int build_leaf(vc_carver* cv, const vc_camera* cam[2], int i0, int j0, int k0, size_t li,
                      leaf_build** lbs, size_t* tab_cap) {
  const grid_i* g = &cv->grid;
  leaf_proj lp;
  memset(lp.seen, 0, sizeof(lp.seen));
  lp.in_grid = 0;
  cv->leaf_tab_idx[li] = NO_TAB;
  for (int z = 0; z < LEAF; z++)
    for (int y = 0; y < LEAF; y++)
      for (int x = 0; x < LEAF; x++)
        if (i0 + x < g->nx && j0 + y < g->ny && k0 + z < g->nz)
          lp.in_grid |= 1ull << (x + LEAF * (y + LEAF * z));
  for (int c = 0; c < 2; c++) {
    if (cv->rule == VC_CARVE_FOOTPRINT) {
      footprint_leaf(g, cam[c], cv->W[c], cv->H[c], i0, j0, k0, c, &lp);
      continue;
    }
    for (int v = 0; v < 64; v++) {
      if (!(lp.in_grid >> v & 1)) continue;
      double p[3];
      voxel_centre(g, i0 + (v & 3), j0 + (v >> 2 & 3), k0 + (v >> 4), p);
      if (cv->rule == VC_CARVE_SUBPIXEL) {
        subpixel_voxel(cam[c], p, cv->W[c], cv->H[c], v, c, &lp);
        continue;
      }
      if (vc_camera_project(cam[c], p, &lp.px[c][v], &lp.py[c][v])) {
        lp.seen[c] |= 1ull << v;
        lp.pw[c][v] = lp.ph[c][v] = 1;
      }
    }
  }
  prect r[2];
  int fw[2] = {1, 1}, fh[2] = {1, 1};
  for (int c = 0; c < 2; c++) {
    prect_init(&r[c]);
    for (int v = 0; v < 64; v++)
      if (lp.seen[c] >> v & 1) {
        prect_add(&r[c], lp.px[c][v], lp.py[c][v]);
        fw[c] = imax(fw[c], lp.pw[c][v]);
        fh[c] = imax(fh[c], lp.ph[c][v]);
      }
  }
  uint64_t both = lp.seen[0] & lp.seen[1];
  cv->leaf[li].flags =
      (uint8_t)((lp.seen[0] == lp.in_grid ? F_ALL0 : 0) | (lp.seen[1] == lp.in_grid ? F_ALL1 : 0));
  if (both == 0) return 0;

  bool wide = false;
  for (int c = 0; c < 2; c++)
    if ((r[c].y1 - r[c].y0) * cv->W[c] + (r[c].x1 - r[c].x0) > UINT16_MAX) wide = true;
  if (cv->ntabs == *tab_cap) {
    size_t cap = *tab_cap ? *tab_cap * 2 : 1024;
    leaf_tab* t = realloc(cv->tabs, cap * sizeof(*t));
    if (t == NULL) return -ENOMEM;
    cv->tabs = t;
    uint16_t* e = realloc(cv->entries, cap * 2 * 64 * sizeof(*e));
    if (e == NULL) return -ENOMEM;
    cv->entries = e;
    leaf_build* b = realloc(*lbs, cap * sizeof(*b));
    if (b == NULL) return -ENOMEM;
    *lbs = b;
    *tab_cap = cap;
  }
  size_t ti = cv->ntabs++;
  leaf_tab* t = &cv->tabs[ti];
  leaf_build* lb = &(*lbs)[ti];
  t->valid = both;
  t->wide = NO_TAB;
  t->cls[0] = t->cls[1] = 0;
  for (int c = 0; c < 2; c++) {
    lb->r[c][0] = (uint16_t)r[c].x0;
    lb->r[c][1] = (uint16_t)r[c].y0;
    lb->r[c][2] = (uint16_t)r[c].x1;
    lb->r[c][3] = (uint16_t)r[c].y1;
    lb->w[c] = (uint16_t)fw[c];
    lb->h[c] = (uint16_t)fh[c];
  }
  uint16_t* e = cv->entries + ti * 2 * 64;
  if (wide) {
    if (cv->nwide == cv->wide_cap) {
      size_t cap = cv->wide_cap ? cv->wide_cap * 2 : 64;
      uint32_t* wt = realloc(cv->wide, cap * 2 * 64 * sizeof(*wt));
      if (wt == NULL) return -ENOMEM;
      cv->wide = wt;
      cv->wide_cap = cap;
    }
    t->wide = (uint32_t)cv->nwide++;
    uint32_t* we = cv->wide + (size_t)t->wide * 2 * 64;
    for (int c = 0; c < 2; c++) {
      t->base[c] = 0;
      for (int v = 0; v < 64; v++)
        we[c * 64 + v] =
            (lp.seen[c] >> v & 1) ? (uint32_t)lp.py[c][v] * (uint32_t)cv->W[c] + (uint32_t)lp.px[c][v] : 0;
    }
    memset(e, 0, 2 * 64 * sizeof(*e));
    cv->leaf_tab_idx[li] = (uint32_t)ti;
    return 0;
  }
  for (int c = 0; c < 2; c++) {
    t->base[c] = (uint32_t)r[c].y0 * (uint32_t)cv->W[c] + (uint32_t)r[c].x0;
    for (int v = 0; v < 64; v++) {
      uint16_t q = 0; /* unseen voxels point at the rectangle's corner; `valid` masks them */
      if (lp.seen[c] >> v & 1) q = (uint16_t)((lp.py[c][v] - r[c].y0) * cv->W[c] + (lp.px[c][v] - r[c].x0));
      e[c * 64 + v] = q;
    }
  }
  cv->leaf_tab_idx[li] = (uint32_t)ti;
  return 0;
}

/* A footprint class while choosing them: a rectangle size and the voxels that use it. */
typedef struct cls_count {
  int w, h;
  uint64_t n;
} cls_count;

/* Chooses camera c's footprint classes (at most MAX_CLASS rectangle sizes; a leaf reads the mask
 * dilated by the smallest class that holds its rectangle) and assigns every leaf its class.
 * Distinct sizes beyond MAX_CLASS are merged greedily, cheapest first (voxels times added area).
 * Returns 0 or -ENOMEM. */
static int choose_classes(vc_carver* cv, const leaf_build* lbs, int c) {
  cls_count* cl = NULL;
  size_t ncl = 0, cap = 0;
  for (size_t t = 0; t < cv->ntabs; t++) {
    int w = lbs[t].w[c], h = lbs[t].h[c];
    size_t k = 0;
    while (k < ncl && !(cl[k].w == w && cl[k].h == h)) k++;
    if (k == ncl) {
      if (ncl == cap) {
        cap = cap ? 2 * cap : 16;
        cls_count* n = realloc(cl, cap * sizeof(*n));
        if (n == NULL) {
          free(cl);
          return -ENOMEM;
        }
        cl = n;
      }
      cl[ncl++] = (cls_count){w, h, 0};
    }
    cl[k].n += (uint64_t)__builtin_popcountll(cv->tabs[t].valid);
  }
  while (ncl > MAX_CLASS) {
    size_t ba = 0, bb = 1;
    double best = INFINITY;
    for (size_t a = 0; a < ncl; a++)
      for (size_t b = a + 1; b < ncl; b++) {
        double area = (double)imax(cl[a].w, cl[b].w) * (double)imax(cl[a].h, cl[b].h);
        double cost = (double)cl[a].n * (area - (double)cl[a].w * cl[a].h) +
                      (double)cl[b].n * (area - (double)cl[b].w * cl[b].h);
        if (cost < best) {
          best = cost;
          ba = a;
          bb = b;
        }
      }
    cl[ba].w = imax(cl[ba].w, cl[bb].w);
    cl[ba].h = imax(cl[ba].h, cl[bb].h);
    cl[ba].n += cl[bb].n;
    cl[bb] = cl[--ncl];
  }
  cv->ncls[c] = ncl == 0 ? 1 : (int)ncl;
  cv->cls[c][0].w = cv->cls[c][0].h = 1;
  for (size_t k = 0; k < ncl; k++) {
    cv->cls[c][k].w = cl[k].w;
    cv->cls[c][k].h = cl[k].h;
  }
  free(cl);
  for (size_t t = 0; t < cv->ntabs; t++) {
    int best = -1;
    for (int k = 0; k < cv->ncls[c]; k++)
      if (cv->cls[c][k].w >= lbs[t].w[c] && cv->cls[c][k].h >= lbs[t].h[c] &&
          (best < 0 || cv->cls[c][k].w * cv->cls[c][k].h < cv->cls[c][best].w * cv->cls[c][best].h))
        best = k;
    cv->tabs[t].cls[c] = (uint8_t)best; /* a class holds every size merged into it */
  }
  for (int k = 0; k < cv->ncls[c]; k++) {
    fp_class* f = &cv->cls[c][k];
    if (f->w * f->h == 1) continue;
    size_t nt = (size_t)cv->fr[c].tw * (size_t)cv->fr[c].th;
    f->dil = calloc((size_t)cv->W[c] * (size_t)cv->H[c], 1);
    f->done = malloc(nt * sizeof(uint32_t));
    f->todo = malloc(nt * sizeof(uint32_t));
    f->mark = calloc(nt, 1);
    if (f->dil == NULL || f->done == NULL || f->todo == NULL || f->mark == NULL) return -ENOMEM;
    f->ndone = 0;
  }
  /* A class starts from the largest smaller class it contains (a w x h dilation is a w' x h'
   * dilation dilated again by (w-w'+1) x (h-h'+1)), so classes run by increasing area. */
  for (int k = 0; k < cv->ncls[c]; k++) {
    fp_class* f = &cv->cls[c][k];
    f->from = -1;
    for (int b = 0; b < cv->ncls[c]; b++) {
      const fp_class* g = &cv->cls[c][b];
      if (b == k || g->dil == NULL || g->w > f->w || g->h > f->h) continue;
      if (f->from < 0 || g->w * g->h > cv->cls[c][f->from].w * cv->cls[c][f->from].h) f->from = b;
    }
    cv->order[c][k] = k;
  }
  for (int i = 1; i < cv->ncls[c]; i++) /* insertion sort by area */
    for (int j = i; j > 0; j--) {
      const fp_class *a = &cv->cls[c][cv->order[c][j - 1]], *b = &cv->cls[c][cv->order[c][j]];
      if (a->w * a->h <= b->w * b->h) break;
      int t = cv->order[c][j];
      cv->order[c][j] = cv->order[c][j - 1];
      cv->order[c][j - 1] = t;
    }
  return 0;
}

/* The bsum of a built leaf: its voxels' anchors grown by its class's rectangle, per camera. */
static void leaf_bsum(const vc_carver* cv, size_t li, const leaf_build* lbs, bsum* b) {
  bsum_init(b);
  uint8_t fl = cv->leaf[li].flags;
  b->all0 = (fl & F_ALL0) != 0;
  b->all1 = (fl & F_ALL1) != 0;
  uint32_t ti = cv->leaf_tab_idx[li];
  if (ti == NO_TAB || lbs == NULL) return; /* lbs is NULL only when no leaf has a table */
  b->skip = false;
  for (int c = 0; c < 2; c++) {
    const leaf_build* lb = &lbs[ti];
    const fp_class* f = &cv->cls[c][cv->tabs[ti].cls[c]];
    b->r[c] = (prect){lb->r[c][0], lb->r[c][1], imin(lb->r[c][2] + f->w - 1, cv->W[c] - 1),
                      imin(lb->r[c][3] + f->h - 1, cv->H[c] - 1), 1};
  }
}

static int frame_alloc(cam_frame* f, int W, int H) {
  f->tw = (W + (1 << TILE_SHIFT) - 1) >> TILE_SHIFT;
  f->th = (H + (1 << TILE_SHIFT) - 1) >> TILE_SHIFT;
  size_t ns = (size_t)(f->tw + 1) * (size_t)(f->th + 1);
  size_t nt = (size_t)f->tw * (size_t)f->th;
  f->sat_any = calloc(ns, sizeof(uint32_t));
  f->sat_full = calloc(ns, sizeof(uint32_t));
  f->any = calloc(nt, 1);
  f->full = calloc(nt, 1);
  f->fg = malloc(nt * sizeof(uint32_t));
  return (f->sat_any && f->sat_full && f->any && f->full && f->fg) ? 0 : -ENOMEM;
}

static void frame_free(cam_frame* f) {
  free(f->sat_any);
  free(f->sat_full);
  free(f->any);
  free(f->full);
  free(f->fg);
}

int vc_carver_new(const vc_voxel_grid* grid, const vc_camera* cam0, const vc_camera* cam1, vc_carve_rule rule,
                  vc_carver** out, char* why, size_t why_len) {
  int err = -EINVAL;
  vc_carver* cv = NULL;
  leaf_build* lbs = NULL;
  char bad[160]; /* a check's reason */
  vc_why_clear(why, why_len);
  if (out) *out = NULL;
  if (!out) {
    vc_why(why, why_len, "carver: no place for the carver");
    return -EINVAL;
  }
  if (rule != VC_CARVE_CENTRE && rule != VC_CARVE_FOOTPRINT && rule != VC_CARVE_SUBPIXEL) {
    vc_why(why, why_len, "carver: carve rule %d is not centre (0), footprint (1) or subpixel (2)", (int)rule);
    return -EINVAL;
  }
  if (vc_grid_check(grid, bad, sizeof(bad)) != 0) {
    vc_why(why, why_len, "carver: %s", bad);
    return -EINVAL;
  }
  const vc_camera* cam[2] = {cam0, cam1};
  for (int c = 0; c < 2; c++)
    if (vc_camera_check(cam[c], bad, sizeof(bad)) != 0) {
      vc_why(why, why_len, "carver: camera %d: %s", c, bad);
      return -EINVAL;
    }
  err = -ENOMEM;
  cv = calloc(1, sizeof(*cv));
  if (cv == NULL) goto err;
  cv->rule = rule;
  cv->grid = (grid_i){{grid->min_m[0], grid->min_m[1], grid->min_m[2]},
                      grid->voxel_m,
                      (int)grid->nx,
                      (int)grid->ny,
                      (int)grid->nz};
  for (int c = 0; c < 2; c++) {
    cv->W[c] = (int)cam[c]->width;
    cv->H[c] = (int)cam[c]->height;
    if (frame_alloc(&cv->fr[c], cv->W[c], cv->H[c]) != 0) goto err;
  }
  cv->nvox = (uint64_t)grid->nx * (uint64_t)grid->ny * (uint64_t)grid->nz;
  cv->tbx = (cv->grid.nx + TOP - 1) / TOP;
  cv->tby = (cv->grid.ny + TOP - 1) / TOP;
  cv->tbz = (cv->grid.nz + TOP - 1) / TOP;
  size_t ntop = (size_t)cv->tbx * (size_t)cv->tby * (size_t)cv->tbz;
  cv->top = calloc(ntop, sizeof(node));
  cv->mid = calloc(ntop * 8, sizeof(node));
  cv->leaf = calloc(ntop * 64, sizeof(node));
  cv->leaf_tab_idx = malloc(ntop * 64 * sizeof(uint32_t));
  if (!cv->top || !cv->mid || !cv->leaf || !cv->leaf_tab_idx) goto err;
  memset(cv->leaf_tab_idx, 0xFF, ntop * 64 * sizeof(uint32_t)); /* NO_TAB until built */

  /* 1: every leaf's table (pixels per voxel) and rectangle sizes; 2: the footprint classes;
   * 3: the blocks' tile ranges, from the leaves' anchors grown by their class. */
  size_t tab_cap = 0;
  uint64_t seen_both = 0;
  for (int tz = 0; tz < cv->tbz; tz++)
    for (int ty = 0; ty < cv->tby; ty++)
      for (int tx = 0; tx < cv->tbx; tx++) {
        size_t ti = (size_t)tx + (size_t)cv->tbx * ((size_t)ty + (size_t)cv->tby * (size_t)tz);
        for (int m = 0; m < 8; m++)
          for (int l = 0; l < 8; l++) {
            int i0 = tx * TOP + (m & 1) * MID + (l & 1) * LEAF,
                j0 = ty * TOP + (m >> 1 & 1) * MID + (l >> 1 & 1) * LEAF,
                k0 = tz * TOP + (m >> 2) * MID + (l >> 2) * LEAF;
            size_t li = (ti * 8 + (size_t)m) * 8 + (size_t)l;
            err = build_leaf(cv, cam, i0, j0, k0, li, &lbs, &tab_cap);
            if (err != 0) goto err;
            if (cv->leaf_tab_idx[li] != NO_TAB)
              seen_both += (uint64_t)__builtin_popcountll(cv->tabs[cv->leaf_tab_idx[li]].valid);
          }
      }
  for (int c = 0; c < 2; c++) {
    err = choose_classes(cv, lbs, c);
    if (err != 0) goto err;
  }

  for (size_t ti = 0; ti < ntop; ti++) {
    bsum top;
    bsum_init(&top);
    for (int m = 0; m < 8; m++) {
      bsum mid;
      bsum_init(&mid);
      for (int l = 0; l < 8; l++) {
        size_t li = (ti * 8 + (size_t)m) * 8 + (size_t)l;
        bsum leaf;
        leaf_bsum(cv, li, lbs, &leaf);
        node_set(&cv->leaf[li], &leaf);
        bsum_merge(&mid, &leaf);
      }
      node_set(&cv->mid[ti * 8 + (size_t)m], &mid);
      bsum_merge(&top, &mid);
    }
    node_set(&cv->top[ti], &top);
  }
  free(lbs);
  lbs = NULL;
  cv->unseen_fraction = (double)(cv->nvox - seen_both) / (double)cv->nvox;
  cv->memory = sizeof(*cv) + ntop * 73 * sizeof(node) + ntop * 64 * sizeof(uint32_t) +
               cv->ntabs * (sizeof(leaf_tab) + 2 * 64 * sizeof(uint16_t)) +
               cv->nwide * 2 * 64 * sizeof(uint32_t);
  for (int c = 0; c < 2; c++) {
    const cam_frame* f = &cv->fr[c];
    cv->memory += 2 * (size_t)(f->tw + 1) * (size_t)(f->th + 1) * 4 + 6 * (size_t)f->tw * (size_t)f->th;
    for (int k = 0; k < cv->ncls[c]; k++)
      if (cv->cls[c][k].dil != NULL) {
        /* the dilated mask and its tile lists */
        size_t b = (size_t)cv->W[c] * (size_t)cv->H[c] + 9 * (size_t)f->tw * (size_t)f->th;
        cv->memory += b;
        cv->scratch += b;
      }
  }
  *out = cv;
  return 0;

err: /* only allocations fail past the checks */
  free(lbs);
  vc_carver_free(cv);
  vc_why(why, why_len, "carver: out of memory for the tables of a %ux%ux%u grid", grid->nx, grid->ny,
         grid->nz);
  return err;
}

void vc_carver_free(vc_carver* cv) {
  if (cv == NULL) return;
  free(cv->top);
  free(cv->mid);
  free(cv->leaf);
  free(cv->leaf_tab_idx);
  free(cv->tabs);
  free(cv->entries);
  free(cv->wide);
  for (int c = 0; c < 2; c++)
    for (int k = 0; k < MAX_CLASS; k++) {
      free(cv->cls[c][k].dil);
      free(cv->cls[c][k].done);
      free(cv->cls[c][k].todo);
      free(cv->cls[c][k].mark);
    }

  frame_free(&cv->fr[0]);
  frame_free(&cv->fr[1]);
  free(cv);
}

uint64_t vc_carver_voxels(const vc_carver* cv) {
  return cv ? cv->nvox : 0;
}
size_t vc_carver_bitset_bytes(const vc_carver* cv) {
  return cv ? (size_t)((cv->nvox + 7) / 8) : 0;
}
double vc_carver_unseen_fraction(const vc_carver* cv) {
  return cv ? cv->unseen_fraction : 1.0;
}
size_t vc_carver_memory_bytes(const vc_carver* cv) {
  return cv ? cv->memory : 0;
}
size_t vc_carver_scratch_bytes(const vc_carver* cv) {
  return cv ? cv->scratch : 0;
}
int vc_carver_classes(const vc_carver* cv, int cam) {
  return cv && (cam == 0 || cam == 1) ? cv->ncls[cam] : 0;
}

int vc_carver_footprint(const vc_carver* cv, uint32_t i, uint32_t j, uint32_t k, uint32_t rect[2][4]) {
  if (cv == NULL || rect == NULL || i >= (uint32_t)cv->grid.nx || j >= (uint32_t)cv->grid.ny ||
      k >= (uint32_t)cv->grid.nz)
    return 0;
  size_t ti = (size_t)(i / TOP) + (size_t)cv->tbx * ((size_t)(j / TOP) + (size_t)cv->tby * (size_t)(k / TOP));
  size_t m = (i % TOP) / MID | ((j % TOP) / MID) << 1 | ((k % TOP) / MID) << 2;
  size_t l = (i % MID) / LEAF | ((j % MID) / LEAF) << 1 | ((k % MID) / LEAF) << 2;
  uint32_t tab = cv->leaf_tab_idx[(ti * 8 + m) * 8 + l];
  unsigned v = i % LEAF + LEAF * (j % LEAF + LEAF * (k % LEAF));
  if (tab == NO_TAB || !(cv->tabs[tab].valid >> v & 1)) return 0;
  const leaf_tab* t = &cv->tabs[tab];
  for (int c = 0; c < 2; c++) {
    uint32_t W = (uint32_t)cv->W[c], p;
    if (t->wide != NO_TAB) {
      p = cv->wide[(size_t)t->wide * 2 * 64 + (size_t)c * 64 + v];
    } else {
      uint16_t q = cv->entries[(size_t)tab * 2 * 64 + (size_t)c * 64 + v];
      p = t->base[c] + q;
    }
    const fp_class* f = &cv->cls[c][t->cls[c]];
    rect[c][0] = p % W;
    rect[c][1] = p / W;
    rect[c][2] = (uint32_t)imin((int)rect[c][0] + f->w - 1, cv->W[c] - 1);
    rect[c][3] = (uint32_t)imin((int)rect[c][1] + f->h - 1, cv->H[c] - 1);
  }
  return 1;
}

/* ---- per frame ------------------------------------------------------------------------------ */

static inline uint64_t load64(const uint8_t* p) {
  uint64_t w;
  memcpy(&w, p, 8);
  return w;
}

/* Nonzero when some byte of w is zero (exact). */
static inline uint64_t has_zero_byte(uint64_t w) {
  return (w - 0x0101010101010101ull) & ~w & 0x8080808080808080ull;
}

#if defined(__SSE2__)
/* ORs `rows` 16-byte rows from p (stride W) into *or_ and their bytes' compare with zero into *has0. */
VC_HOT void tile_rows_sse2(const uint8_t* p, size_t W, int rows, __m128i* or_, __m128i* has0) {
  const __m128i z128 = _mm_setzero_si128();
  __m128i o = *or_, h = *has0;
  for (int r = 0; r < rows; r++) {
    const __m128i q = _mm_loadu_si128((const __m128i*)(const void*)(p + (size_t)r * W));
    o = _mm_or_si128(o, q);
    h = _mm_or_si128(h, _mm_cmpeq_epi8(q, z128));
  }
  *or_ = o;
  *has0 = h;
}
#endif

/* Tile flags and their summed-area tables for one mask. With SSE2 (the x86-64 baseline) two tiles
 * side by side at a time: a 16-byte row's OR for "any", its byte compare with zero ORed for "not
 * full", one movemask each per tile pair (8 rows: 59 -> ~30 instructions a tile); elsewhere one
 * 8-byte word a row, the zero bytes found by the carry trick. Each row of tiles then goes into the
 * tables at once, through local pointers the compiler need not reload after each store (the tile
 * flags and the tables are different arrays; 22 -> ~12 instructions a tile). */
__attribute__((noinline)) static void summarise(cam_frame* f, const uint8_t* mask, int W, int H) {
  const int ts = 1 << TILE_SHIFT;
  const int full_tiles = W >> TILE_SHIFT; /* tiles with all 8 columns inside the image */
  const int tw = f->tw, th = f->th;       /* locals: the stores below do not make the compiler reload them */
  const size_t sw = (size_t)tw + 1;
  for (int ty = 0; ty < th; ty++) {
    uint8_t* restrict any = f->any + (size_t)ty * (size_t)tw;
    uint8_t* restrict full = f->full + (size_t)ty * (size_t)tw;
    int y0 = ty * ts, y1 = imin(H, y0 + ts);
    int tx = 0;
#if defined(__SSE2__)
    const __m128i z128 = _mm_setzero_si128();
    for (; tx + 2 <= full_tiles; tx += 2) {
      __m128i or_ = z128, has0 = z128;
      const uint8_t* p = mask + (size_t)y0 * (size_t)W + (size_t)(tx * ts);
      if (y1 - y0 == ts) /* a whole tile row: a constant count, unrolled */
        tile_rows_sse2(p, (size_t)W, ts, &or_, &has0);
      else
        tile_rows_sse2(p, (size_t)W, y1 - y0, &or_, &has0);
      const unsigned none = (unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(or_, z128)); /* bit: byte all 0 */
      const unsigned holes = (unsigned)_mm_movemask_epi8(has0);                     /* bit: a byte was 0 */
      any[tx] = (none & 0xFFu) != 0xFFu;
      any[tx + 1] = (none >> 8) != 0xFFu;
      full[tx] = (holes & 0xFFu) == 0;
      full[tx + 1] = (holes >> 8) == 0;
    }
#endif
    for (; tx < full_tiles; tx++) {
      uint64_t or_ = 0, zero = 0;
      for (int y = y0; y < y1; y++) {
        uint64_t w = load64(mask + (size_t)y * (size_t)W + (size_t)(tx * ts));
        or_ |= w;
        zero |= has_zero_byte(w);
      }
      any[tx] = or_ != 0;
      full[tx] = zero == 0;
    }
    if (full_tiles < tw) { /* the last, narrower column of tiles */
      tx = full_tiles;
      bool a = false, fl = true;
      for (int y = y0; y < y1; y++)
        for (int x = tx * ts; x < W; x++) {
          bool on = mask[(size_t)y * (size_t)W + (size_t)x] != 0;
          a = a || on;
          fl = fl && on;
        }
      any[tx] = a;
      full[tx] = fl;
    }
    const uint32_t* restrict sa_up = f->sat_any + (size_t)ty * sw;
    const uint32_t* restrict sf_up = f->sat_full + (size_t)ty * sw;
    uint32_t* restrict sa = f->sat_any + (size_t)(ty + 1) * sw;
    uint32_t* restrict sf = f->sat_full + (size_t)(ty + 1) * sw;
    uint32_t ra = 0, rf = 0;
    for (int x = 0; x < tw; x++) {
      ra += any[x];
      rf += full[x];
      sa[x + 1] = sa_up[x + 1] + ra;
      sf[x + 1] = sf_up[x + 1] + rf;
    }
  }
}

/* The list of this frame's tiles with foreground (footprint rule only), eight tile flags at a time. */
static void fg_list(cam_frame* f) {
  const uint32_t nt = (uint32_t)f->tw * (uint32_t)f->th;
  uint32_t n = 0, t = 0;
  for (; t + 8 <= nt; t += 8) {
    if (load64(f->any + t) == 0) continue;
    for (uint32_t i = t; i < t + 8; i++)
      if (f->any[i]) f->fg[n++] = i;
  }
  for (; t < nt; t++)
    if (f->any[t]) f->fg[n++] = t;
  f->nfg = n;
}

/* One 8x8 tile of the dilated mask at pixel (X, Y): byte (x, y) = any foreground in
 * [x, x+w) x [y, y+h), clipped to the image. Rows of the horizontal windows first (eight outputs
 * per 64-bit word), then the vertical windows over them. */
static void dilate_tile(uint8_t* dil, const uint8_t* mask, int W, int H, int X, int Y, int w, int h) {
  /* mask: the camera's mask, or a smaller class's dilated mask (then w x h is the difference) */
  const int ye = imin(Y + (1 << TILE_SHIFT), H), rows = imin(Y + (1 << TILE_SHIFT) + h - 1, H) - Y;
  if (X + (1 << TILE_SHIFT) + w - 1 > W || rows > 64) { /* at the right edge, or very tall: bytewise */
    const int xe = imin(X + (1 << TILE_SHIFT), W);
    for (int y = Y; y < ye; y++)
      for (int x = X; x < xe; x++) {
        uint8_t acc = 0;
        for (int yy = y; yy < imin(y + h, H) && !acc; yy++)
          for (int xx = x; xx < imin(x + w, W); xx++) acc |= mask[(size_t)yy * (size_t)W + (size_t)xx];
        dil[(size_t)y * (size_t)W + (size_t)x] = acc;
      }
    return;
  }
  uint64_t hr[64];
  for (int r = 0; r < rows; r++) {
    const uint8_t* m = mask + (size_t)(Y + r) * (size_t)W + (size_t)X;
    uint64_t acc = 0;
    for (int i = 0; i < w; i++) acc |= load64(m + i);
    hr[r] = acc;
  }
  for (int r = 0; r < ye - Y && r < rows; r++) { /* rows >= ye - Y: the second bound is for the analyzer */
    uint64_t acc = 0;
    for (int j = r; j < imin(r + h, rows); j++) acc |= hr[j];
    memcpy(dil + (size_t)(Y + r) * (size_t)W + (size_t)X, &acc, 8);
  }
}

/* Makes f->dil the mask dilated by f->w x f->h (see fp_class) for this frame, computing only the
 * tiles within reach of a foreground tile (a dilated tile reads its own tile and, for w, h up to 9,
 * the next one right and down) and zeroing the tiles the last frame computed that this one does not. */
static void dilate(fp_class* f, const cam_frame* fr, const uint8_t* src, int dw, int dh, int W, int H) {
  const int rx = (f->w + 6) >> TILE_SHIFT, ry = (f->h + 6) >> TILE_SHIFT, tw = fr->tw;
  uint32_t nt = 0;
  for (uint32_t i = 0; i < fr->nfg; i++) {
    const int fx = (int)(fr->fg[i] % (uint32_t)tw), fy = (int)(fr->fg[i] / (uint32_t)tw);
    for (int ty = fy; ty >= imax(0, fy - ry); ty--)
      for (int tx = fx; tx >= imax(0, fx - rx); tx--) {
        uint32_t u = (uint32_t)ty * (uint32_t)tw + (uint32_t)tx;
        if (f->mark[u]) continue;
        f->mark[u] = 1;
        f->todo[nt++] = u;
      }
  }
  for (uint32_t i = 0; i < f->ndone; i++) {
    uint32_t u = f->done[i];
    if (f->mark[u]) continue;
    const int X = (int)(u % (uint32_t)tw) << TILE_SHIFT, Y = (int)(u / (uint32_t)tw) << TILE_SHIFT;
    for (int y = Y; y < imin(Y + (1 << TILE_SHIFT), H); y++)
      memset(f->dil + (size_t)y * (size_t)W + (size_t)X, 0, (size_t)(imin(X + (1 << TILE_SHIFT), W) - X));
  }
  for (uint32_t i = 0; i < nt; i++) {
    uint32_t u = f->todo[i];
    f->mark[u] = 0;
    dilate_tile(f->dil, src, W, H, (int)(u % (uint32_t)tw) << TILE_SHIFT,
                (int)(u / (uint32_t)tw) << TILE_SHIFT, dw, dh);
  }
  uint32_t* t = f->done;
  f->done = f->todo;
  f->todo = t;
  f->ndone = nt;
}

static inline uint32_t sat_count(const uint32_t* s, size_t sw, const uint16_t r[4]) {
  size_t x0 = r[0], y0 = r[1], x1 = (size_t)r[2] + 1, y1 = (size_t)r[3] + 1;
  return s[y1 * sw + x1] - s[y0 * sw + x1] - s[y1 * sw + x0] + s[y0 * sw + x0];
}

/* State of a block in camera c: empty, undecided or all foreground. */
static inline int cam_state(const cam_frame* f, const node* n, int c) {
  if (n->flags & (c == 0 ? F_NONE0 : F_NONE1)) return S_OUT;
  const uint16_t* r = n->r[c];
  const size_t sw = (size_t)f->tw + 1;
  if (sat_count(f->sat_any, sw, r) == 0) return S_OUT;
  if (!(n->flags & (c == 0 ? F_ALL0 : F_ALL1))) return S_PART;
  uint32_t area = (uint32_t)(r[2] - r[0] + 1) * (uint32_t)(r[3] - r[1] + 1);
  return sat_count(f->sat_full, sw, r) == area ? S_FULL : S_PART;
}

/* Sets bits [pos, pos+len) of the (zeroed) bitset. */
static void set_bits(uint8_t* bits, uint64_t pos, unsigned len) {
  while (len > 0 && (pos & 7) != 0) {
    bits[pos >> 3] |= (uint8_t)(1u << (pos & 7));
    pos++;
    len--;
  }
  if (len >= 8) {
    memset(bits + (pos >> 3), 0xFF, len >> 3);
    pos += len & ~7u;
    len &= 7u;
  }
  while (len > 0) {
    bits[pos >> 3] |= (uint8_t)(1u << (pos & 7));
    pos++;
    len--;
  }
}

/* Fills the voxels [i0, i0+s) x [j0, j0+s) x [k0, k0+s) clipped to the grid. */
static uint64_t fill_block(const grid_i* g, uint8_t* bits, int i0, int j0, int k0, int s) {
  int i1 = imin(g->nx, i0 + s), j1 = imin(g->ny, j0 + s), k1 = imin(g->nz, k0 + s);
  for (int k = k0; k < k1; k++)
    for (int j = j0; j < j1; j++)
      set_bits(bits, (uint64_t)i0 + (uint64_t)g->nx * ((uint64_t)j + (uint64_t)g->ny * (uint64_t)k),
               (unsigned)(i1 - i0));
  return (uint64_t)(i1 - i0) * (uint64_t)(j1 - j0) * (uint64_t)(k1 - k0);
}

/* The 64 gathered mask bytes of a leaf as its 64 bits: bit v set when byte v is not zero. Packing
 * after the gather costs a load and a store a voxel plus a few operations per 8 or 16 bytes, where
 * a compare, shift and OR per voxel cost twice as many instructions (2.0 -> 1.0 M a 128^3 frame, the
 * bench's 2 cameras). SSE2 (the x86-64 baseline): a byte compare and movemask per 16 bytes; other
 * CPUs: per 8 bytes, bit 7 of each byte set when the byte is not zero (its low 7 bits plus 0x7F
 * carry into bit 7 unless all zero; OR the byte itself for bit 7), moved to bit 0 and gathered into
 * one byte by the multiply (byte k's bit lands in bit 56 + k). */
static inline uint64_t pack64(const uint8_t g[64]) {
#if defined(__SSE2__)
  const __m128i zero = _mm_setzero_si128();
  uint64_t z = 0; /* bit v: byte v is zero */
  for (int k = 0; k < 4; k++) {
    const __m128i q = _mm_loadu_si128((const __m128i*)(const void*)(g + 16 * k));
    z |= (uint64_t)(uint32_t)_mm_movemask_epi8(_mm_cmpeq_epi8(q, zero)) << (16 * k);
  }
  return ~z;
#else
  const uint64_t low7 = 0x7F7F7F7F7F7F7F7Full;
  uint64_t bits = 0;
  for (int k = 0; k < 8; k++) {
    uint64_t w;
    memcpy(&w, g + 8 * k, 8);
    const uint64_t hi = (((w & low7) + low7) | w) & ~low7; /* bit 7 of each nonzero byte */
    bits |= (((hi >> 7) * 0x0102040810204080ull) >> 56) << (8 * k);
  }
  return bits;
#endif
}

/* Bit v of the result: the mask pixel of voxel v is foreground. The bytes are gathered 8 at a time
 * (a constant inner loop the compiler unrolls), then packed. The 8 of one step are 8 apart: gcc
 * merges adjacent byte stores into one word built with a shift and an OR a byte, which costs more
 * than the byte stores it saves (36 -> 27 instructions per 8 voxels). */
static inline uint64_t leaf_lookup(const uint8_t* mask, uint32_t base, const uint16_t* e) {
  const uint8_t* b = mask + base;
  uint8_t g[64];
  for (int v = 0; v < 8; v++)
    for (int k = 0; k < 64; k += 8) g[v + k] = b[e[v + k]];
  return pack64(g);
}

/* Same for a wide leaf: full pixel indices. */
static inline uint64_t leaf_lookup_wide(const uint8_t* mask, const uint32_t* e) {
  uint8_t g[64];
  for (int v = 0; v < 8; v++)
    for (int k = 0; k < 64; k += 8) g[v + k] = mask[e[v + k]];
  return pack64(g);
}

#if VC_HAVE_NEON_VARIANT
/* The NEON variant of the two lookups: the 64 pixel bytes are gathered as they are (NEON has no
 * gather) into one 64-byte block, and the block becomes the 64 bits in vector registers: nonzero
 * bytes to 0xFF (tst), each ANDed with its bit's weight 1..128, three rounds of pairwise adds fold
 * each 8 bytes into one, whose 8 bytes are the result (little-endian: byte k holds voxels 8k..8k+7).
 * The scalar form's compare, shift and OR per voxel go; the same bits. */
static inline uint64_t pack64_neon(const uint8_t g[64]) {
  static const uint8_t weights[16] = {1, 2, 4, 8, 16, 32, 64, 128, 1, 2, 4, 8, 16, 32, 64, 128};
  const uint8x16_t w = vld1q_u8(weights);
  const uint8x16x4_t q = vld1q_u8_x4(g);
  const uint8x16_t t0 = vandq_u8(vtstq_u8(q.val[0], q.val[0]), w);
  const uint8x16_t t1 = vandq_u8(vtstq_u8(q.val[1], q.val[1]), w);
  const uint8x16_t t2 = vandq_u8(vtstq_u8(q.val[2], q.val[2]), w);
  const uint8x16_t t3 = vandq_u8(vtstq_u8(q.val[3], q.val[3]), w);
  uint8x16_t p = vpaddq_u8(vpaddq_u8(t0, t1), vpaddq_u8(t2, t3));
  p = vpaddq_u8(p, p);
  return vgetq_lane_u64(vreinterpretq_u64_u8(p), 0);
}

static inline uint64_t leaf_lookup_neon(const uint8_t* mask, uint32_t base, const uint16_t* e) {
  const uint8_t* b = mask + base;
  uint8_t g[64];
  for (int v = 0; v < 64; v++) g[v] = b[e[v]];
  return pack64_neon(g);
}

static inline uint64_t leaf_lookup_wide_neon(const uint8_t* mask, const uint32_t* e) {
  uint8_t g[64];
  for (int v = 0; v < 64; v++) g[v] = mask[e[v]];
  return pack64_neon(g);
}
#endif

/* ORs a leaf's 64 bits (x + 4y + 16z) into the bitset at voxel origin (i0, j0, k0). Bits of voxels
 * outside the grid are zero, so no byte past a row's last voxel is written. The rows' bit positions
 * are steps of nx (a y row) and nx * ny (a z slice) from the leaf's first: the grid's sizes are read
 * once into locals, as a byte store may alias them and would make the compiler reload them after
 * each write (15 -> ~8 instructions a row written). */
static void write_leaf(const grid_i* g, uint8_t* bits, int i0, int j0, int k0, uint64_t b) {
  const uint64_t nx = (uint64_t)g->nx, slice = nx * (uint64_t)g->ny;
  const uint64_t pos0 = (uint64_t)i0 + nx * (uint64_t)j0 + slice * (uint64_t)k0;
  for (int z = 0; z < LEAF; z++) {
    const unsigned sl = (unsigned)(b >> (LEAF * LEAF * z)) & 0xFFFFu; /* the z slice's 4 rows */
    if (sl == 0) continue;
    for (int y = 0; y < LEAF; y++) {
      const unsigned nib = (sl >> (LEAF * y)) & 0xFu;
      if (nib == 0) continue;
      const uint64_t pos = pos0 + slice * (uint64_t)z + nx * (uint64_t)y;
      const unsigned sh = (unsigned)(pos & 7);
      bits[pos >> 3] |= (uint8_t)(nib << sh);
      if ((nib << sh) > 0xFFu) bits[(pos >> 3) + 1] |= (uint8_t)(nib >> (8 - sh));
    }
  }
}

int vc_carver_run(vc_carver* cv, const uint8_t* mask0, const uint8_t* mask1, uint8_t* bitset,
                  vc_carve_stats* stats) {
  if (cv == NULL || mask0 == NULL || mask1 == NULL || bitset == NULL) return -EINVAL;
  const uint8_t* mask[2] = {mask0, mask1};
  const uint8_t* cm[2][MAX_CLASS] = {{mask0}, {mask1}}; /* this frame's mask per class (mask or dil) */
  for (int c = 0; c < 2; c++) {
    summarise(&cv->fr[c], mask[c], cv->W[c], cv->H[c]);
    if (cv->rule != VC_CARVE_CENTRE) fg_list(&cv->fr[c]);
    for (int i = 0; i < cv->ncls[c]; i++) {
      const int k = cv->order[c][i];
      fp_class* f = &cv->cls[c][k];
      if (f->dil != NULL) {
        const fp_class* b = f->from >= 0 ? &cv->cls[c][f->from] : NULL;
        dilate(f, &cv->fr[c], b ? b->dil : mask[c], b ? f->w - b->w + 1 : f->w, b ? f->h - b->h + 1 : f->h,
               cv->W[c], cv->H[c]);
      }
      cm[c][k] = f->dil != NULL ? f->dil : mask[c];
    }
  }
  memset(bitset, 0, vc_carver_bitset_bytes(cv));
#if VC_HAVE_NEON_VARIANT
  const bool neon = vc__use_neon();
#endif
  const grid_i* g = &cv->grid;
  uint64_t occupied = 0;
  uint32_t skipped = 0, filled = 0, tested = 0;

  for (int tz = 0; tz < cv->tbz; tz++)
    for (int ty = 0; ty < cv->tby; ty++)
      for (int tx = 0; tx < cv->tbx; tx++) {
        size_t ti = (size_t)tx + (size_t)cv->tbx * ((size_t)ty + (size_t)cv->tby * (size_t)tz);
        const node* tn = &cv->top[ti];
        if (tn->flags & F_SKIP) continue;
        int t0 = cam_state(&cv->fr[0], tn, 0);
        int t1 = t0 == S_OUT ? S_OUT : cam_state(&cv->fr[1], tn, 1);
        if (t0 == S_OUT || t1 == S_OUT) {
          skipped++;
          continue;
        }
        if (t0 == S_FULL && t1 == S_FULL) {
          occupied += fill_block(g, bitset, tx * TOP, ty * TOP, tz * TOP, TOP);
          filled++;
          continue;
        }
        for (int m = 0; m < 8; m++) {
          size_t mi = ti * 8 + (size_t)m;
          const node* mn = &cv->mid[mi];
          if (mn->flags & F_SKIP) continue;
          int mi0 = tx * TOP + (m & 1) * MID, mj0 = ty * TOP + (m >> 1 & 1) * MID,
              mk0 = tz * TOP + (m >> 2) * MID;
          int m0 = t0 == S_FULL ? S_FULL : cam_state(&cv->fr[0], mn, 0);
          int m1 =
              (t1 == S_FULL || m0 == S_OUT) ? (m0 == S_OUT ? S_OUT : S_FULL) : cam_state(&cv->fr[1], mn, 1);
          if (m0 == S_OUT || m1 == S_OUT) {
            skipped++;
            continue;
          }
          if (m0 == S_FULL && m1 == S_FULL) {
            occupied += fill_block(g, bitset, mi0, mj0, mk0, MID);
            filled++;
            continue;
          }
          for (int l = 0; l < 8; l++) {
            size_t li = mi * 8 + (size_t)l;
            const node* ln = &cv->leaf[li];
            if (ln->flags & F_SKIP) continue;
            int i0 = mi0 + (l & 1) * LEAF, j0 = mj0 + (l >> 1 & 1) * LEAF, k0 = mk0 + (l >> 2) * LEAF;
            int l0 = m0 == S_FULL ? S_FULL : cam_state(&cv->fr[0], ln, 0);
            int l1 =
                (m1 == S_FULL || l0 == S_OUT) ? (l0 == S_OUT ? S_OUT : S_FULL) : cam_state(&cv->fr[1], ln, 1);
            if (l0 == S_OUT || l1 == S_OUT) {
              skipped++;
              continue;
            }
            const leaf_tab* t = &cv->tabs[cv->leaf_tab_idx[li]];
            uint64_t b = t->valid;
            if (l0 == S_FULL && l1 == S_FULL) {
              filled++;
            } else {
              if (t->wide != NO_TAB) {
                const uint32_t* we = cv->wide + (size_t)t->wide * 2 * 64;
#if VC_HAVE_NEON_VARIANT
                if (neon) {
                  if (l0 == S_PART) b &= leaf_lookup_wide_neon(cm[0][t->cls[0]], we);
                  if (l1 == S_PART && b != 0) b &= leaf_lookup_wide_neon(cm[1][t->cls[1]], we + 64);
                } else
#endif
                {
                  if (l0 == S_PART) b &= leaf_lookup_wide(cm[0][t->cls[0]], we);
                  if (l1 == S_PART && b != 0) b &= leaf_lookup_wide(cm[1][t->cls[1]], we + 64);
                }
              } else {
                const uint16_t* e = cv->entries + (size_t)cv->leaf_tab_idx[li] * 2 * 64;
#if VC_HAVE_NEON_VARIANT
                if (neon) {
                  if (l0 == S_PART) b &= leaf_lookup_neon(cm[0][t->cls[0]], t->base[0], e);
                  if (l1 == S_PART && b != 0) b &= leaf_lookup_neon(cm[1][t->cls[1]], t->base[1], e + 64);
                } else
#endif
                {
                  if (l0 == S_PART) b &= leaf_lookup(cm[0][t->cls[0]], t->base[0], e);
                  if (l1 == S_PART && b != 0) b &= leaf_lookup(cm[1][t->cls[1]], t->base[1], e + 64);
                }
              }
              tested++;
            }
            if (b == 0) continue;
            occupied += (uint64_t)__builtin_popcountll(b);
            write_leaf(g, bitset, i0, j0, k0, b);
          }
        }
      }
  if (stats != NULL) {
    stats->occupied = occupied;
    stats->blocks_skipped = skipped;
    stats->blocks_filled = filled;
    stats->leaves_tested = tested;
  }
  return 0;
}
