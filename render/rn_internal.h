/* rn_internal.h - what the files of render/ share: the image helpers of the
 * two writers, the camera frame and cell interpolation of both renderers,
 * the ray-casting kernel (embree.c) and the irradiance cache's records
 * (icache.c) for the gather (final_gather.c).
 *
 * Private to render/: the public contract stays render.h.  Both writers check
 * an image the same way and write through a rad_output (rad.h), so that a
 * failed write never touches the file already at `path`.
 */
#ifndef RN_INTERNAL_H
#define RN_INTERNAL_H

#include "render.h"

/* Largest width or height an image may have (rn_render, the writers, and
 * the tests' EXR reader, test/exr_read.c). */
#define RN_MAX_SIDE 16384u

/* RAD_OK when img has 1..RN_MAX_SIDE pixels a side, 1..RAD_MAX_BANDS channels
 * and pixels; else RAD_ERR_USAGE naming `path`. */
int rn_image_check(const rn_image *img, const char *path, rad_error *err);

/* A zeroed image of the given size with every patch id RAD_NONE; NULL when
 * memory runs out.  Sizes must already be checked.  Caller owns. */
rn_image *rn_image_alloc(uint32_t width, uint32_t height, uint32_t channels);

/* ------------------------------------------------ camera (render.c) */

/* Right-handed camera frame: f forward, r right, u up; with
 * a = (i + ½ − cx)/k, b = (cy − j − ½)/k, a pixel (i, j) looks along
 * f + a·r + b·u from the eye (perspective), or along f from eye + a·r + b·u
 * (orthographic). */
typedef struct rn_frame {
    rad_vec3 eye, f, r, u;
    double k;      /* pixels per unit of x/z: (H/2) / tan(yfov/2); orthographic: per unit
                    * of x, (H/2) / ymag */
    double cx, cy; /* image centre in pixels */
    uint32_t w, h;
    int ortho;     /* orthographic projection */
} rn_frame;

/* Checks cam and fills the frame; RAD_ERR_USAGE naming what is wrong. */
int rn_camera_frame(const rn_camera *cam, rn_frame *fr, rad_error *err);

/* Checks a mesh's indices and finiteness (what both renderers trust). */
int rn_mesh_check(const rad_mesh *m, rad_error *err);

/* ---------------------------------- interpolation in a cell (render.c) */

/* A cell in its own plane: 2-D coordinates (e1, e2) with corner v0 at the
 * origin, and what the inverse bilinear map (quads) or the barycentric
 * coordinates (triangles) need. */
typedef struct rn_cell2d {
    int corners;
    rad_vec3 v0, e1, e2;
    double p[4][2];                         /* corners; p[0] = (0, 0) */
    double ex, ey, fx, fy, gx, gy, k2, kef; /* quads: x = u·e + v·f + u·v·g */
    double det;                             /* triangles: p1 × p2 */
    /* A triangle with det != 0 or a parallelogram (a quad whose g is below
     * 1e-10 of its sides) is linear: its two coordinates (w1, w2), or
     * (u, v), are lin·(hx, hy). */
    int linear;
    double lin[2][2];
} rn_cell2d;

void rn_cell2d_init(rn_cell2d *c, const rad_mesh *m, uint32_t cell);

/* Weights of the corners at the plane point (hx, hy): bilinear for quads,
 * barycentric (clamped, renormalised) for triangles; w[3] unused for
 * triangles.  Every weight in [0, 1], sum 1. */
void rn_cell2d_weights(const rn_cell2d *c, double hx, double hy, double *w);

/* ---------------------------------------------- ray casting (embree.c) */

typedef struct rn_rt rn_rt;

/* The cells of mesh as Embree's scene.  Caller owns *out. */
int rn_rt_create(const rad_mesh *mesh, rn_rt **out, rad_error *err);
void rn_rt_destroy(rn_rt *rt); /* NULL does nothing */

/* The nearest cell met by org + t·dir with tnear < t < tfar (either side of
 * it), its distance in *t; RAD_NONE when none.  Thread-safe. */
uint32_t rn_rt_intersect(const rn_rt *rt, rad_vec3 org, rad_vec3 dir, double tnear, double tfar,
                         double *t);

/* 1 when some cell lies on org + t·dir, tnear < t < tfar.  Thread-safe. */
int rn_rt_occluded(const rn_rt *rt, rad_vec3 org, rad_vec3 dir, double tnear, double tfar);

/* ------------------------------------------ cache records (icache.c) */

/* One primary value of Ward's cache: the indirect irradiance H at P on a
 * surface of normal N, the harmonic mean distance R to what its gather saw
 * (raised to the minimum radius), Ward & Heckbert's gradients per band
 * (translational gt: dH/dx along the surface; rotational gr: H(N') ≈ H +
 * (N × N')·gr), and Zaninetti & Péroche's light vector direction D (unit
 * mean direction the indirect light comes from, cosine-weighted). */
typedef struct rn_record {
    rad_vec3 P, N, D;
    double R;
    double H[RAD_MAX_BANDS];
    rad_vec3 gt[RAD_MAX_BANDS], gr[RAD_MAX_BANDS];
} rn_record;

/* What rn_gather stores in a cache it fills: the settings behind its key. */
void rn_icache_settle(rn_icache *c, double epsilon, uint32_t gather_rays, int gradients,
                      double min_radius_px);
uint64_t rn_icache_key(const rn_icache *c);
uint32_t rn_icache_bands(const rn_icache *c);
uint64_t rn_icache_size(const rn_icache *c);
/* Counts a run and its gathers into the cache's totals. */
void rn_icache_count_run(rn_icache *c, uint64_t gathers);

/* Sets the octree's cube around lo..hi (once; the records already held are
 * sorted into it).  RAD_OK or RAD_ERR_NOMEM. */
int rn_icache_prepare(rn_icache *c, rad_vec3 lo, rad_vec3 hi, double epsilon, rad_error *err);

/* Adds a record (copied).  RAD_OK or RAD_ERR_NOMEM. */
int rn_icache_insert(rn_icache *c, const rn_record *r, rad_error *err);

/* Ward's secondary method at (P, N): the weighted mean over the records
 * whose weight w_i = 1/(|P − P_i|/R_i + sqrt(1 − N·N_i)) exceeds 1/ε and
 * that are not in front of P, of their H (extrapolated by the gradients
 * unless no_gradients) into H[bands], clamped at 0, and of their D into *D.
 * Returns the number of records used (0: compute a new one).  Read-only:
 * safe from several threads at once. */
uint32_t rn_icache_lookup(const rn_icache *c, rad_vec3 P, rad_vec3 N, double epsilon,
                          int no_gradients, double *H, rad_vec3 *D);

/* 64-bit FNV-1a, continued from h (start with RN_FNV_START). */
#define RN_FNV_START 0xcbf29ce484222325ull
uint64_t rn_fnv(uint64_t h, const void *p, size_t n);

#endif /* RN_INTERNAL_H */
