/* hemicube.h - form factors by the hemi-cube (Cohen & Greenberg 1985).
 *
 * For patch i a cube is centred at the patch's centre and aligned with its
 * normal: one full face R×R looking along the normal and four half faces
 * R×R/2.  Every other patch is rasterised into it as an item buffer of patch
 * ids with a depth test; F_ij is the sum of the precomputed delta form
 * factors of the pixels that show patch j.
 *
 * Invariants of every row produced: j != i, F_ij > 0, patches behind i's
 * plane never appear, Σ_j F_ij <= 1 (the delta form factors are normalised to
 * sum to exactly 1 over the whole cube).
 *
 * Punctual lights are rendered here too: hc_light_power (what each patch
 * receives) and hc_light_visibility (whether a point sees the light), from
 * the same item buffers.
 *
 * This is the only module that sees GL (OSMesa or EGL).  Rows are computed
 * by worker processes, each with its own GL context, so a caller never
 * holds a GL context and can fork freely; only the workers load libOSMesa
 * or libEGL (at run time), so the caller's memory holds none of it.
 */
#ifndef HC_HEMICUBE_H
#define HC_HEMICUBE_H

#include "../radiosity/core/rad.h"

#include <signal.h>

/* The default hemi-cube resolution R (hc_options.resolution 0), the one
 * place it is written. */
#define HC_DEFAULT_RESOLUTION 128

/* What makes the workers' GL contexts (hc_options.gl). */
typedef enum hc_gl_kind {
    HC_GL_OSMESA = 0, /* libOSMesa (llvmpipe on the CPU): the default */
    HC_GL_EGL,        /* libEGL: a GPU (EGL device platform), else Mesa's surfaceless llvmpipe */
    HC_GL_AUTO        /* EGL where it finds a GPU, else OSMesa (hc_gl_choose) */
} hc_gl_kind;

/* {0} means defaults. */
typedef struct hc_options {
    uint32_t resolution; /* R: the top face is R×R pixels, side faces R×R/2;
                          * 0 = HC_DEFAULT_RESOLUTION; even, 8..4096 */
    uint32_t processes;  /* worker processes; 0 = number of online CPUs */
    /* Called from the caller's process as rows complete (may be NULL). */
    void (*progress)(void *user, uint32_t done, uint32_t total);
    void *progress_user;
    /* Per patch (mesh->patch_count bytes, may be NULL): 1 marks the patches j
     * whose F_ij is computed exactly rather than by counting pixels: the
     * point-to-polygon contour integral from i's centre to patch j
     * (hc_ff_point_polygon), times the fraction of j that i's centre sees
     * (from the hemi-cube, then measured again in an R×R view aimed at j's
     * polygon whenever something in that view lies between them).  The
     * pipeline marks emitters: this removes the aliasing of small bright
     * sources the hemi-cube paper warns about, and most of a penumbra's. */
    const uint8_t *exact;
    /* 1 = also treat exactly every patch j nearer to i's centre than j's own
     * size (the proximity case, where point sampling of i is the weak part). */
    int exact_near;
    /* Exact entries where the hemi-cube's pixel count is weak (issue 39,
     * docs/limits.md): HC_WEAK_OFF (0) adds none; HC_WEAK_ON makes exact
     * the entries of far polygons too thin on the cube (under 8 pixels,
     * facing the eye) and, with exact_near, area-averages the entries of
     * a facing plane nearer to c_i than i's diameter (nearly touching
     * surfaces); HC_WEAK_HIGH widens both for the accurate setting (0.1 %:
     * 64 pixels at any angle, every j within 20 diameters).
     * HC_WEAK_SURFACE is the default for rows that make surface-to-surface
     * factors F_AB (ff, validate's catalog), which are area averages over
     * A by definition: thin under 32 pixels at any angle and every j within
     * 2 diameters area-averaged (1 %); a solve's rows stay HC_WEAK_ON, as
     * collocation rows (docs/limits.md says why). */
    int weak;
    /* May be NULL: a flag the caller sets (from a signal handler, say) to
     * stop a job of rows: no new row is handed out, the rows the workers
     * hold are still received and stored, and the call then fails with
     * RAD_ERR_INTERRUPTED.  Read in the caller's process only. */
    const volatile sig_atomic_t *stop;
    /* The workers' GL (0 = HC_GL_OSMESA).  HC_GL_AUTO is settled by
     * hc_create as hc_gl_choose settles it; HC_GL_EGL where EGL cannot
     * start fails hc_create with the reason. */
    hc_gl_kind gl;
} hc_options;

/* The GL back end hc_gl_choose settled on. */
typedef struct hc_gl_choice {
    hc_gl_kind kind;    /* HC_GL_OSMESA or HC_GL_EGL */
    char renderer[128]; /* EGL: its GL_RENDERER ("llvmpipe (LLVM ...)", a GPU's name); else "" */
    char reason[1024];  /* HC_GL_AUTO settled on OSMesa: why no GPU was taken; else "" */
} hc_gl_choice;

/* Settles `want` (HC_GL_OSMESA, HC_GL_EGL or HC_GL_AUTO) into out, trying
 * EGL in a short-lived child process (the caller never loads a GL library):
 *   OSMesa: taken as is, nothing tried;
 *   EGL: a GL 4.5 context made through EGL (a GPU, else surfaceless), or
 *     RAD_ERR_GL with the reason in err;
 *   auto: EGL when it finds a GPU device whose GL_RENDERER is not Mesa's
 *     software (llvmpipe, softpipe), else OSMesa with the reason.
 * The caller says what it chose, if anything (the library prints nothing). */
int hc_gl_choose(hc_gl_kind want, hc_gl_choice *out, rad_error *err);
/* "osmesa", "egl" or "auto"; NULL for any other value. */
const char *hc_gl_name(hc_gl_kind kind);
/* The kind a name ("osmesa", "egl", "auto") names: 0, or -1 for any other. */
int hc_gl_parse(const char *name, hc_gl_kind *out);

/* hc_options.weak */
enum { HC_WEAK_OFF = 0, HC_WEAK_ON = 1, HC_WEAK_HIGH = 2, HC_WEAK_SURFACE = 3 };

typedef struct hc_engine hc_engine;

/* Prepares an engine for `mesh` (the mesh must outlive the engine).  Starts
 * the worker processes, which each upload the geometry once.  Caller owns
 * *out and frees it with hc_destroy. */
int hc_create(const rad_mesh *mesh, const hc_options *opt, hc_engine **out, rad_error *err);

/* Computes rows rows[0..count) into F (replacing any present copy), spread over
 * the workers.  A worker that stops (killed, crashed) is replaced and the
 * rows it held are computed again (the one it was computing alone); a row
 * that stops two workers fails the call, naming its patch.  (Tests make a
 * row do that with the environment variable RADIOSITY_TEST_CRASH_ROW=i,
 * read by each worker when it starts.) */
int hc_compute_rows(hc_engine *e, const uint32_t *rows, uint32_t count, rad_matrix *F,
                    rad_error *err);

/* A point receiver: the hemi-cube of an element (Cohen, Greenberg, Immel &
 * Brock 1986: patches shoot, elements receive) sits at `center`, a point of
 * patch `patch` (on its plane, inside it), looking along the patch's normal.
 * Its row F_ej holds the form factors from the element to every patch j
 * (j != patch), with the same invariants as a patch row; exact entries
 * (hc_options.exact) are the point-to-polygon factor. */
typedef struct hc_receiver {
    rad_vec3 center;
    uint32_t patch;
    /* 0: every patch is drawn.  > 0: a near view: only the patches j whose
     * centre lies within `reach` of center (hc_within_reach) are drawn, and
     * what lies beyond them is left uncovered: the row holds the near
     * entries only, and 1 − Σ_j F_ej is the share of the hemisphere the
     * near patches leave open.  For a caller that takes the far field from
     * elsewhere (elements/refine.c: the patch's own row). */
    double reach;
} hc_receiver;

/* Is patch j within a near view's reach of point c (hc_receiver.reach)?
 * The same test the engine draws by, up to rounding at the boundary. */
static inline int hc_within_reach(const rad_mesh *m, uint32_t j, rad_vec3 c, double reach)
{
    const rad_vec3 d = rad_sub(m->patches[j].center, c);
    return rad_dot(d, d) <= reach * reach;
}

/* Receives one row: receiver k's count entries (j strictly increasing).
 * Returns RAD_OK or an error code (filling err), which stops the call. */
typedef int (*hc_row_store)(void *user, uint32_t k, uint32_t count, const uint32_t *col,
                            const float *val, rad_error *err);

/* Computes the rows of recv[0..count), spread over the workers, handing each
 * to store (in the caller's process, in any order); stopped workers are
 * replaced as for hc_compute_rows. */
int hc_compute_points(hc_engine *e, const hc_receiver *recv, uint32_t count, hc_row_store store,
                      void *user, rad_error *err);

/* Stops the workers and frees everything.  NULL does nothing. */
void hc_destroy(hc_engine *e);

/* The triangles the engine's item buffers draw (hemicube/draw_geometry.c):
 * a patch of one cell as itself, a cluster as a fan of its outline
 * simplified within 3 % of its size √A_i, neighbours sharing one simplified
 * boundary; every_cell = 1: every cell of every cluster instead (what
 * RADIOSITY_DRAW_EVERY_CELL=1 makes the workers draw).  *triangles gets the
 * total, *simplified the clusters drawn by their fans.  Computed in the
 * caller's process, without GL: for benchmarks and tests. */
int hc_draw_triangles(const hc_engine *e, int every_cell, uint64_t *triangles,
                      uint32_t *simplified, rad_error *err);

/* Punctual lights (glTF KHR_lights_punctual), for shooting their direct
 * light before the solve. */
typedef enum hc_light_kind {
    HC_LIGHT_POINT = 0,
    HC_LIGHT_SPOT,
    HC_LIGHT_DIRECTIONAL
} hc_light_kind;

typedef struct hc_light {
    hc_light_kind kind;
    rad_vec3 position;   /* point, spot: where the light is */
    rad_vec3 direction;  /* spot, directional: unit vector along which light travels */
    double inner_cone;   /* spot: radians, full intensity inside */
    double outer_cone;   /* spot: radians, zero outside; glTF's smooth falloff between */
} hc_light;

/* The light views' resolution when none is given (resolution 0 in
 * hc_light_power and hc_light_visibility). */
#define HC_DEFAULT_LIGHT_RESOLUTION 512

/* Power each patch receives from a light of unit strength, front sides only
 * and with occlusion, into power[mesh->patch_count] (caller's buffer), the
 * light's views R×R with R = resolution (even, 8..4096; 0 =
 * HC_DEFAULT_LIGHT_RESOLUTION):
 *   point, spot: unit intensity (1 per steradian); an item-buffer cube (six
 *     R×R faces; the spot's cone faces only) rendered at the light,
 *     Φ_j = Σ over pixels showing j of the pixel's solid angle × the spot
 *     falloff;
 *   directional: unit irradiance on a surface facing the light; an
 *     orthographic item buffer R×R covering the scene's bounds,
 *     Φ_j = Σ over pixels showing j of the pixel's area.
 * Patch irradiance is then H_j = Φ_j / A_j (I cos θ / r² for a small patch). */
int hc_light_power(hc_engine *e, const hc_light *light, uint32_t resolution, double *power,
                   rad_error *err);

/* Unoccluded direct irradiance at point p, on a surface with unit normal n,
 * from `light` at unit strength (hc_light_power's units):
 *   point, spot: max(0, n·ω) / r² × the spot's falloff (glTF's smooth t²
 *     between the inner and outer cone, the one hc_light_power applies;
 *     1 for a point light), ω the unit vector from p to the light;
 *   directional: max(0, −n·d).
 * 0 at the light itself.  The light is taken as hc_light_power checks it. */
double hc_light_direct(const hc_light *light, rad_vec3 p, rad_vec3 n);

/* Unoccluded power polygon poly[0..count) (planar, convex, unit normal n)
 * receives from `light` at unit strength, front side only (hc_light_power's
 * units, the closed form its exact path uses, issue 39): point, the solid
 * angle of the polygon seen from the light; spot, the falloff integrated
 * over that solid angle (adaptively, to ~1e-5 of the peak); directional, the
 * projected area A max(0, -n·d).  Divided by A: the polygon's mean
 * irradiance, where hc_light_direct gives one point's.  0 when the light
 * lies on or behind the polygon's plane. */
double hc_light_polygon(const hc_light *light, const rad_vec3 *poly, uint32_t count, rad_vec3 n);

/* Visibility from a light of points on patches (an element's centre, say):
 * vis[k] in [0, 1] for points[k].center on patch points[k].patch (caller's
 * buffer of count values).  Read from the same item buffers hc_light_power
 * renders for that light and resolution (the cube face the direction to the
 * point falls in, or the orthographic view): the bilinear weight of the four
 * pixel centres around the point's projection that show the point's own
 * surface (its patch, or a front side in its patch's plane: a coplanar
 * neighbour across a patch seam) or nothing at all (no surface drawn, as
 * beside a floor's outer edge).  Hence 1 where all four show it, 0 where
 * something nearer the light covers all four, and in between a value that
 * moves continuously across a shadow edge within one pixel: the edge is
 * anti-aliased, not a staircase of pixels.  A point at the light gets 0.
 * The engine's workers render each part once per call (the points are
 * grouped by part); the result depends only on the light, the resolution and
 * the point, never on the number of workers.  Multiply by hc_light_direct
 * for the point's direct irradiance.  On failure vis is all 0. */
int hc_light_visibility(hc_engine *e, const hc_light *light, uint32_t resolution,
                        const hc_receiver *points, uint32_t count, double *vis, rad_error *err);

/* The factors every receiver gathers from patch i, for shooting from i: for
 * each patch j whose centre lies in front of i and which faces it,
 *   F_ji = hc_ff_point_polygon(c_j, n_j, patch i) · v_j,
 * v_j the visibility of c_j from i: the mean over samples² points of i
 * (0 = 1: its centre) of hc_light_visibility from a point light there, at
 * `resolution` (0 = HC_DEFAULT_LIGHT_RESOLUTION).  The same quantity as a
 * row's exact entry for i (hc_options.exact), F_exact · v_ji, measured from
 * the emitter's side (Wallace, Elmquist & Haines 1989): equal where nothing
 * is in between.  Writes the entries with F_ji > 0 into col[] (strictly
 * increasing) and val[] (caller's buffers of mesh->patch_count entries),
 * their number into *count. */
int hc_exact_column(hc_engine *e, uint32_t i, uint32_t resolution, uint32_t samples, uint32_t *col,
                    float *val, uint32_t *count, rad_error *err);

/* The delta form factor of every pixel of a resolution-R hemi-cube, in the
 * layout the item buffer uses (top face R×R, then the four side faces R×R/2
 * each).  Normalised to sum to 1.  Writes 3·R² values to out (caller's
 * buffer); returns the sum before normalisation (a check against π-rules:
 * it tends to 1 as R grows). */
double hc_delta_form_factors(uint32_t resolution, double *out);

/* ---------------------------------------------------------------------------
 * Analytic form factors (hemicube/analytic.c): closed forms from the catalog
 * (Howell, "A Catalog of Radiation Heat Transfer Configuration Factors";
 * Siegel & Howell), for validation and for the exact point-to-polygon
 * factor used near emitters.  No occlusion is considered.
 * ------------------------------------------------------------------------- */

/* Two directly opposed parallel rectangles a×b, a distance c apart (Howell C-11). */
double hc_ff_parallel_rectangles(double a, double b, double c);

/* From rectangle 1 (edge × w1) to rectangle 2 (edge × w2), perpendicular,
 * sharing the edge of length `edge` (Howell C-14). */
double hc_ff_perpendicular_rectangles(double edge, double w1, double w2);

/* From disk of radius r1 to a coaxial parallel disk of radius r2 a distance h
 * away (Howell C-41). */
double hc_ff_coaxial_disks(double r1, double r2, double h);

/* From a differential element to a parallel rectangle a×b at distance c, the
 * element facing the rectangle and lying on the normal through one of its
 * corners (Howell B-3). */
double hc_ff_element_parallel_rectangle(double a, double b, double c);

/* From rectangle 1, [x0, x1] × [y0, y1] in the plane z = 0, to rectangle 2,
 * [u0, u1] × [v0, v1] in the plane z = c, edges parallel, anywhere in their
 * planes (offset or partly overlapping): the superposition of corner-to-
 * corner integrals (Howell C-12's general form).  NAN for an empty
 * rectangle or c <= 0.  Accurate where the rectangles are within a few
 * hundred gaps of each other (the terms cancel as the distance grows). */
double hc_ff_parallel_offset(double x0, double x1, double y0, double y1, double u0, double u1,
                             double v0, double v1, double c);

/* From a differential element at p with unit normal n to a planar polygon
 * (any orientation; the part behind the element's plane is clipped away),
 * by Lambert's contour integral.  Counts only the side of the polygon that
 * faces p (its points counter-clockwise seen from p are taken as is; the
 * result is the same for either winding). */
double hc_ff_point_polygon(rad_vec3 p, rad_vec3 n, const rad_vec3 *poly, uint32_t count);

/* From planar polygon a to planar polygon b, unoccluded: the area average of
 * the point-to-polygon factor over a, by a fan of triangles each integrated
 * with `subdiv`² sub-triangles and a 7-point rule.  Converges as subdiv grows;
 * exact to ~1e-7 for subdiv 16 on separated polygons. */
double hc_ff_polygon_polygon(const rad_vec3 *a, uint32_t na, const rad_vec3 *b, uint32_t nb,
                             uint32_t subdiv);

/* How many hemi-cubes the row of patch i of mesh m costs (row_samples.c):
 * 1 for a planar patch, up to 4 for a patch whose cells bend (each group
 * of its cells within 12° of one normal gets a cube of its own). */
uint32_t hc_row_cubes(const rad_mesh *m, uint32_t i);

/* ---------------------------------------------------------------------------
 * MPI ranks (hemicube/mpi_ranks.c): linked into the radiosity-mpi program
 * only, never into libradiosity.a, so nothing else needs MPI's libraries.
 * ------------------------------------------------------------------------- */

/* Starts MPI and says which rank this process is of how many.  On rank 0,
 * every engine created afterwards spreads its rows and element hemi-cubes
 * over the ranks (each with its own worker processes) beside its own
 * workers.  Call once, first thing in main. */
int hc_mpi_start(int *argc, char ***argv, int *rank, int *size, rad_error *err);
/* Ranks 1..size-1: serves rank 0's engines until rank 0 finishes. */
int hc_mpi_serve(rad_error *err);
/* Rank 0: one line naming the ranks, their hosts and the hemi-cubes each
 * computed, and what stopped them if something did (returns 1 then). */
int hc_mpi_summary(char *line, size_t size);
/* Every rank, last: releases the ranks (rank 0) and ends MPI; after a rank
 * was lost (rank 0), or when a serving rank failed (failed = 1), the job is
 * aborted instead (MPI's finish would wait for the lost rank). */
void hc_mpi_finish(int failed);

#endif /* HC_HEMICUBE_H */
