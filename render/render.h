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
 *
 * A second renderer, the final gather (rn_gather, final_gather.c and
 * icache.c), ray-traces a view from the same data with Embree (embree.c, the
 * only file that sees it): per pixel direct light from the emitters and
 * punctual lights with shadow rays, indirect irradiance gathered over the
 * hemisphere from the stored radiosities (cached by Ward, Rubinstein &
 * Clear 1988), and the glossy lobes the solve ignores.
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

/* How an EXR's float pixels are compressed (lossless all).  Rendered
 * radiance has noisy low mantissa bits, so no codec saves much: ZIP saves
 * about 15 % of a 1024² RGB image for about 0.27 s of CPU, five times the
 * cost of drawing it, PIZ about 28 % for as much; RLE saves only flat
 * regions (about 6 %) at next to no cost.  NONE is the default: a view's
 * file is written in 0.01 s, so many views in one call cost little more
 * than drawing them (report/views.md). */
typedef enum rn_exr_compression {
    RN_EXR_NONE = 0, /* the default: uncompressed scanlines */
    RN_EXR_ZIP,      /* ZIP, 16 scanlines per block */
    RN_EXR_RLE,
    RN_EXR_PIZ
} rn_exr_compression;

/* "none", "zip", "rle" or "piz" into *out; 0, or -1 for another word. */
int rn_exr_compression_parse(const char *word, rn_exr_compression *out);

/* Writes linear radiance as OpenEXR (float channels R,G,B for 3 bands, Y for
 * 1, B0..Bk otherwise), uncompressed (RN_EXR_NONE), through a temporary
 * file renamed into place. */
int rn_write_exr(const rn_image *img, const char *path, rad_error *err);

/* rn_write_exr with the compression given. */
int rn_write_exr_with(const rn_image *img, const char *path, rn_exr_compression compression,
                      rad_error *err);

/* rn_write_exr_with whose file is committed by `committer` (NULL: now), so
 * the caller need not wait for it to reach the disk: a failure then comes
 * from rad_committer_finish. */
int rn_write_exr_later(const rn_image *img, const char *path, rn_exr_compression compression,
                       rad_committer *committer, rad_error *err);

/* Writes an 8-bit sRGB PNG preview: value = sRGB(L · 2^exposure), through a
 * temporary file renamed into place.  One band is grey; >= 3 use the first three. */
int rn_write_png(const rn_image *img, const char *path, double exposure, rad_error *err);

/* rn_write_png committed by `committer` (NULL: now), as rn_write_exr_later. */
int rn_write_png_later(const rn_image *img, const char *path, double exposure,
                       rad_committer *committer, rad_error *err);

/* --------------------------------------------------------- the final gather */

/* A material's glossy lobe (rad_material's specular and roughness): Ward's
 * isotropic Gaussian, α = roughness². */
typedef struct rn_material {
    double specular[RAD_MAX_BANDS]; /* ρ_s per band, 0 = none */
    double roughness;               /* r in [0, 1] */
} rn_material;

/* An emitting polygon, sampled as an area light: planar, convex, corners
 * counter-clockwise about `normal`; emits E on its front side (both sides
 * when two_sided: a transmitting sheet's two faces). */
typedef struct rn_emitter {
    const rad_vec3 *points;     /* count corners (not owned) */
    uint32_t count;             /* >= 3 */
    rad_vec3 normal;            /* unit */
    double E[RAD_MAX_BANDS];    /* radiant exitance per band */
    int two_sided;
} rn_emitter;

typedef enum rn_light_kind { RN_LIGHT_POINT = 0, RN_LIGHT_SPOT, RN_LIGHT_DIRECTIONAL } rn_light_kind;

/* A punctual light (rad_light): I in W/sr (point, spot) or E⊥ in W/m²
 * (directional) per band, the intensities the solution was solved with. */
typedef struct rn_light {
    rn_light_kind kind;
    double I[RAD_MAX_BANDS];
    rad_vec3 position;          /* point, spot */
    rad_vec3 direction;         /* spot, directional: unit, the way light travels */
    double inner_cone, outer_cone; /* spot: half-angles in radians */
} rn_light;

/* What the gather draws: plain data, built by the pipeline from a solution
 * (rad_gather_scene in pipeline.h); nothing here is owned by the struct.
 * The cells are those the vertex renderer draws (the patches, or the
 * elements' fans), with the same vertex radiosities.  Invariants: arrays
 * sized as stated, every value finite and >= 0, each cell's material <
 * material_count. */
typedef struct rn_scene {
    const rad_mesh *mesh;        /* cells; patches[c].material indexes materials */
    uint32_t bands;              /* 1..RAD_MAX_BANDS */
    const double *vertex_B;      /* vertex_count × bands: the drawn radiosities */
    const double *rho;           /* patch_count × bands: diffuse ρ per cell */
    const double *emission;      /* patch_count × bands: E per cell */
    const double *transmitted;   /* patch_count × bands, or NULL: τ H_twin, what a
                                  * sheet sends out of the side facing away from
                                  * the light it receives */
    const rn_material *materials;
    uint32_t material_count;
    const rn_emitter *emitters;
    uint32_t emitter_count;
    const rn_light *lights;
    uint32_t light_count;
} rn_scene;

/* How glossy lobes take their indirect light. */
typedef enum rn_glossy_mode {
    /* Mirror-like lobes (roughness < RN_MIRROR_ROUGHNESS) recurse, sharp
     * lobes (roughness below RN_LIGHT_VECTOR_ROUGHNESS) sample the lobe,
     * broad ones read the cached light vector. */
    RN_GLOSSY_AUTO = 0,
    RN_GLOSSY_SAMPLE,        /* every non-mirror lobe by sampling */
    RN_GLOSSY_LIGHT_VECTOR   /* every non-mirror lobe from the light vector */
} rn_glossy_mode;

#define RN_MIRROR_ROUGHNESS 0.1
#define RN_LIGHT_VECTOR_ROUGHNESS 0.5
#define RN_DEFAULT_EPSILON 0.1
#define RN_DEFAULT_GATHER_RAYS 256
#define RN_DEFAULT_LIGHT_SAMPLES 16
#define RN_DEFAULT_GLOSSY_RAYS 16
#define RN_DEFAULT_MAX_DEPTH 4
#define RN_DEFAULT_MIN_RADIUS_PX 1.0

/* {0} means defaults. */
typedef struct rn_gather_options {
    double epsilon;          /* Ward's a, the cache's error bound; 0 = RN_DEFAULT_EPSILON */
    int no_cache;            /* 1 = a gather at every shading point (the reference) */
    int no_gradients;        /* 1 = Ward 1988's weighted average only, without Ward &
                              * Heckbert 1992's translational and rotational gradients */
    uint32_t gather_rays;    /* hemisphere rays per gather (M × N strata, N ≈ πM);
                              * 0 = RN_DEFAULT_GATHER_RAYS */
    uint32_t light_samples;  /* stratified samples per area emitter and shading point
                              * (rounded down to a square); 0 = RN_DEFAULT_LIGHT_SAMPLES */
    uint32_t glossy_rays;    /* lobe samples per glossy shading point (a square);
                              * 0 = RN_DEFAULT_GLOSSY_RAYS */
    uint32_t max_depth;      /* mirror reflections followed; 0 = RN_DEFAULT_MAX_DEPTH */
    double min_radius_px;    /* a cache record's valid radius a·R_i is at least this many
                              * pixels where it is made (R_i raised to it); 0 =
                              * RN_DEFAULT_MIN_RADIUS_PX */
    rn_glossy_mode glossy;
    uint32_t threads;        /* shading threads; 0 = 1 */
    /* Called now and then with the work done out of the total, may be NULL. */
    void (*progress)(void *user, uint64_t done, uint64_t total);
    void *progress_user;
} rn_gather_options;

typedef struct rn_gather_stats {
    uint64_t pixels;          /* pixels of the image */
    uint64_t shading_points;  /* diffuse shading points (pixels and mirror hits) */
    uint64_t gathers;         /* hemisphere gathers computed in this run */
    uint64_t gather_rays;     /* their rays */
    uint64_t cache_hits;      /* shading points answered from the cache */
    uint64_t records_loaded;  /* records the cache held before the run */
    uint64_t records;         /* records it holds after */
    uint64_t shadow_rays;
    uint64_t glossy_rays;     /* lobe samples and mirror rays */
    double seconds;
} rn_gather_stats;

/* Ward's irradiance cache: records of indirect irradiance (with gradients
 * and Zaninetti & Péroche's light vector), shared across pixels and views
 * of one scene under one set of options (the key). */
typedef struct rn_icache rn_icache;

/* The key a cache must carry to serve sc under opt: a 64-bit FNV-1a hash of
 * everything the indirect irradiance depends on (cells, vertex radiosities,
 * E, materials) and of ε, the gather rays, the gradients and the minimum
 * radius. */
uint64_t rn_gather_key(const rn_scene *sc, const rn_gather_options *opt);

/* An empty cache for that key and band count.  Caller owns *out. */
int rn_icache_create(uint64_t key, uint32_t bands, rn_icache **out, rad_error *err);
void rn_icache_destroy(rn_icache *c); /* NULL does nothing */

/* Reads a cache file.  key != 0: the file must carry it, else
 * RAD_ERR_INVALID "PATH: made for another solution or other settings";
 * key 0 takes any (reports).  A missing file is RAD_ERR_IO, a damaged one
 * RAD_ERR_CORRUPT.  Caller owns *out. */
int rn_icache_read(const char *path, uint64_t key, rn_icache **out, rad_error *err);

/* Writes the cache through a temporary file renamed into place. */
int rn_icache_write(const rn_icache *c, const char *path, rad_error *err);

typedef struct rn_icache_info {
    uint64_t key;
    uint32_t bands;
    double epsilon;          /* the settings it was filled with (0 while empty) */
    uint32_t gather_rays;
    int gradients;
    double min_radius_px;
    uint64_t records;
    uint64_t gathers;        /* gathers computed over every run that filled it */
    uint64_t runs;           /* renders that used it */
    double mean_radius;      /* mean valid radius a·R_i of the records, scene units */
} rn_icache_info;

void rn_icache_info_get(const rn_icache *c, rn_icache_info *out);

/* Renders cam's view of sc into *out (radiance per band; img->patch holds
 * the cell seen, RAD_NONE for background).  cache: records to use and
 * extend (its key must be rn_gather_key(sc, opt)); NULL = a cache of this
 * run only.  stats may be NULL.  Caller owns *out. */
int rn_gather(const rn_scene *sc, const rn_camera *cam, const rn_gather_options *opt,
              rn_icache *cache, rn_image **out, rn_gather_stats *stats, rad_error *err);

#endif /* RN_RENDER_H */
