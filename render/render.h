/* render.h - drawing any view of a stored solution.
 *
 * Patch radiosities move to vertices as in the paper: an interior vertex
 * takes the value at it of the affine least-squares fit to its polygon's
 * surrounding patches (on a regular grid, their average, the paper's rule;
 * exact for a linear field where cells of different sizes meet), outline
 * vertices are extrapolated; both are clamped at zero.  A camera's item buffer tells which patch
 * each pixel sees; the eye ray meets that patch's plane at a point whose
 * (u,v) in the patch gives a bilinear (quads) or barycentric (triangles)
 * interpolation of the vertex radiosities.  Pixels hold radiance L = B/π.
 *
 * The renderer never sees form factors, GL or the solver: it reads the mesh
 * and radiosities only.  OpenEXR and PNG output live in their own files here.
 */
#ifndef RN_RENDER_H
#define RN_RENDER_H

#include "../radiosity/core/rad.h"

/* A perspective camera spans yfov_deg vertically from the eye; an
 * orthographic one (orthographic = 1) projects along the view direction
 * onto a window 2·ymag high centred on the eye's line of sight, its width
 * from the image's (square pixels), and sees what lies in front of the eye
 * along the view direction. */
typedef struct rn_camera {
    rad_vec3 eye, target, up;
    double yfov_deg;   /* vertical field of view, degrees, (0, 180); unused when orthographic */
    uint32_t width;    /* pixels */
    uint32_t height;
    int orthographic;  /* 0 = perspective (appended: {0} keeps the old meaning) */
    double ymag;       /* orthographic: half-height of the view, scene units, > 0 */
} rn_camera;

/* A float image, channels interleaved, row 0 at the top. */
typedef struct rn_image {
    uint32_t width, height, channels;
    float *pixels;       /* width × height × channels */
    uint32_t *patch;     /* width × height: patch seen, RAD_NONE for background */
} rn_image;

/* Vertex radiosities from patch radiosities.  B is n_patches × bands, each
 * patch's value taken at its `center`; vertex_B (caller's buffer) gets
 * vertex_count × bands values, all >= 0. */
void rn_vertex_radiosity(const rad_mesh *mesh, uint32_t bands, const double *B, double *vertex_B);

/* How an interior vertex's radiosity is fitted to the cells around it. */
typedef enum rn_vertex_fit {
    /* The affine least-squares fit to the centres of the cells using the
     * vertex: the paper's average on a regular grid (rn_vertex_radiosity). */
    RN_FIT_AFFINE = 0,
    /* The quadratic least-squares fit to the distinct centres of those cells
     * and of their neighbours (two rings: 12 on a regular grid of fans, 16
     * of quads), limited to the range of the cells using the vertex, so
     * that no new extreme appears beside a shadow edge; the affine fit where
     * no quadratic is determined.  Exact for a quadratic field away from its
     * extremes. */
    RN_FIT_QUADRATIC
} rn_vertex_fit;

/* rn_vertex_radiosity with a choice of fit for interior vertices (outline
 * vertices are extrapolated affinely either way).  A vertex that is the
 * centre of every cell using it (the apex of a fan) takes their B. */
void rn_vertex_radiosity_fit(const rad_mesh *mesh, uint32_t bands, const double *B,
                             double *vertex_B, rn_vertex_fit how);

/* Weights w[0..n) such that Σ_k w_k b_k is, at the origin, the affine
 * function of the plane fitted by least squares to the samples b_k at
 * (x_k, y_k) (along their line only when they are collinear; the mean when
 * they coincide).  What outline vertices are extrapolated with. */
void rn_affine_weights(const double *x, const double *y, size_t n, double *w);

/* Renders radiance L = B/π seen from cam, with `bands` channels.  Caller owns
 * *out (free with rn_image_destroy). */
int rn_render(const rad_mesh *mesh, uint32_t bands, const double *vertex_B, const rn_camera *cam,
              rn_image **out, rad_error *err);

void rn_image_destroy(rn_image *img); /* NULL does nothing */

/* Many views of one mesh: a canvas keeps its image, depth buffer and
 * camera-space vertices from one view to the next, so a view of the same
 * size draws over memory already mapped (at 1024² the page faults of fresh
 * buffers cost about as much as the drawing).  One canvas per thread; any
 * number of canvases may draw the same mesh at once (rn_render reads the
 * mesh and vertex_B only). */
typedef struct rn_canvas rn_canvas;

/* NULL when memory runs out.  Caller owns (rn_canvas_destroy). */
rn_canvas *rn_canvas_create(void);
void rn_canvas_destroy(rn_canvas *c); /* NULL does nothing; frees its image too */

/* rn_render into the canvas: *out is the canvas's image, valid until its
 * next draw or destruction (the canvas owns it and the caller may change
 * its pixels and ids meanwhile; NULL on failure). */
int rn_canvas_draw(rn_canvas *c, const rad_mesh *mesh, uint32_t bands, const double *vertex_B,
                   const rn_camera *cam, rn_image **out, rad_error *err);

/* RAD_OK when rn_render can draw from cam (finite, eye != target, up not
 * along the view, field of view in (0, 180) degrees, 1..16384 pixels a
 * side), else RAD_ERR_USAGE with the reason alone ("eye and target
 * coincide"), for the caller to say which camera: many views are checked
 * before any is drawn. */
int rn_camera_check(const rn_camera *cam, rad_error *err);

/* Writes linear radiance as OpenEXR (float channels R,G,B for 3 bands, Y for
 * 1, B0..Bk otherwise), through a temporary file renamed into place. */
int rn_write_exr(const rn_image *img, const char *path, rad_error *err);

/* Reads an EXR written by rn_write_exr (tests, comparisons). Caller owns *out. */
int rn_read_exr(const char *path, rn_image **out, rad_error *err);

/* Writes an 8-bit sRGB PNG preview: value = sRGB(L · 2^exposure), through a
 * temporary file renamed into place.  One band is grey; >= 3 use the first three. */
int rn_write_png(const rn_image *img, const char *path, double exposure, rad_error *err);

#endif /* RN_RENDER_H */
