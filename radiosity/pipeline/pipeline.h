/* pipeline.h - the stages in order: load -> mesh -> form factors -> solve ->
 * store, and rendering a stored solution.  What the command-line program
 * calls, and what a C program calls to do the same without files.
 */
#ifndef RAD_PIPELINE_H
#define RAD_PIPELINE_H

#include "../../hemicube/hemicube.h"
#include "../../render/render.h"
#include "../../solver/solver.h"
#include "../elements/elements.h"
#include "../mesh/mesh.h"
#include "../relight/relight.h"
#include "../scene/scene.h"
#include "../solfile/solfile.h"
#include "../solution/solution.h"

#include <signal.h>

/* What the form factors of a solve will take, estimated before they are
 * computed: a few rows, spread over the patches, are rendered first (they
 * are kept: they are rows the solve needs) and the rest are taken to hold
 * as many entries each as those do on average.  A row holds at most one
 * entry per hemi-cube pixel (3R²) and per other patch; in practice far
 * fewer, as a patch sees only part of the scene.  With a journal
 * (rad_solve_options.journal) the sample rows are journaled like any
 * other, and a resumed solve samples only among the rows still missing. */
typedef struct rad_estimate {
    uint32_t patches;        /* N */
    uint32_t cells;          /* cells drawn in each hemi-cube (N without clusters) */
    uint32_t rows;           /* rows the solve computes in all */
    uint32_t sample_rows;    /* rows rendered to measure */
    double entries_per_row;  /* their mean count of F_ij > 0 */
    uint64_t matrix_bytes;   /* F with every row in */
    uint64_t peak_bytes;     /* the solving process's resident memory at its largest */
    uint64_t file_bytes;     /* the solution file, without elements */
    uint64_t limit_bytes;    /* what F may take (max_memory) */
} rad_estimate;

/* Rows rendered to estimate the form factors' size. */
#define RAD_ESTIMATE_SAMPLES 64u

/* {0} means defaults. */
typedef struct rad_solve_options {
    rad_load_options load;
    rad_mesh_options mesh;
    hc_options hemicube;
    sv_options solver;
    uint64_t max_memory; /* bytes the form-factor matrix may use (its rows and per-patch
                          * index, as rad_estimate.matrix_bytes counts them); 0 = 80 % of
                          * available memory.  Gauss-Seidel and Jacobi refuse a matrix
                          * that may not fit; the progressive solver keeps its rows
                          * within it (dropping and computing again the rows of patches
                          * that shoot again) */
    int all_rows;        /* compute every row, not only those the solve needs (ff, validation) */
    int pixel_emitters;  /* 1 = form factors to emitters by counting pixels like any patch;
                          * 0 (default) = exactly, by the point-to-polygon integral times
                          * the visible fraction (no aliasing of small bright sources) */
    int exact_near;      /* >= 0 (default) = patches nearer than their own size exactly too
                          * (area-averaged contour integral times the visible fraction):
                          * the proximity fix, and in closed rooms the reciprocity the
                          * energy balance rests on (0.12 % -> 0.02 % in a closed room
                          * with a lamp at the default patch size); < 0 = counted in
                          * pixels like the others (before issue 18) */
    int accuracy;        /* form factors where the hemi-cube is weak (issue 39,
                          * docs/limits.md): 0 (default) = thin far surfaces and
                          * nearly touching pairs exactly (hc_options.weak
                          * HC_WEAK_ON); 1 = the accurate setting (HC_WEAK_HIGH:
                          * every patch within 20 diameters area-averaged, 0.1 %
                          * on the catalog); < 0 = pixel counts there (before) */
    int surface_factors; /* 1 = the rows are for surface-to-surface factors F_AB
                          * (ff, a .vs3 matrix): at accuracy 0 the weak rule of
                          * F_AB's own definition, the area average over A, for
                          * every near pair and thin polygon (HC_WEAK_SURFACE,
                          * docs/limits.md); 0 (default) = a solve's collocation
                          * rows (HC_WEAK_ON) */
    /* Progressive solver only, may be NULL: called every solver.preview_every
     * shots and/or every solver.preview_seconds of solving, with the current
     * estimate including the ambient term (patch_count × bands).  Non-zero
     * stops the solve.  Each call is logged in the solution's progress
     * record (its time leaves out the previews' own).  (solver.need_rows,
     * need_column, on_preview, user and max_matrix_bytes are the pipeline's
     * own and are ignored; solver.progress is passed on.) */
    int (*on_preview)(void *user, const rad_solution *s, uint32_t shots, const double *B_display);
    void *preview_user;
    /* Warnings (rad.h), may be NULL: a solve stopped by its iteration limit
     * before its tolerance was met. */
    rad_warn_fn warn;
    void *warn_user;
    /* May be NULL: called with the estimate once it is made, before the
     * rows are computed: a matrix that would not fit is refused right
     * after, with a patch size that would (gathering solvers), or kept
     * within max_memory by dropping and computing again rows (the
     * progressive solver, refused only when not even its few rows of a
     * shot would fit). */
    void (*on_estimate)(void *user, const rad_estimate *e);
    void *estimate_user;
    /* Punctual lights: R of the item-buffer cube rendered at each light
     * (hc_light_power); 0 = the larger of 512 and the hemi-cube resolution. */
    uint32_t light_resolution;
    /* Elements (rad_elements in solution.h): > 0 splits elements, starting
     * from the patches, where what is drawn misses what finer elements
     * gather: an element's four children are gathered (probes), and it
     * splits when the mean difference between their B and the drawn
     * (interpolated) radiosity at their centres, as a fraction of the
     * brightest non-emitting patch's B (any band), times the element's
     * area over its patch's, exceeds this threshold; until none does or
     * they reach min_element_size.  0 = RAD_DEFAULT_REFINE_THRESHOLD
     * (elements.h); RAD_REFINE_OFF (any negative value) = no elements
     * (render the patches). */
    double refine_threshold;
    double min_element_size; /* smallest element edge, scene units; 0 = 1/8 of its patch's */
    uint32_t element_levels; /* > 0: split every reflecting patch this many times instead,
                              * whatever the threshold (uniform elements: references) */
    int element_hemicubes;   /* 1 = every adaptive element's row from a hemi-cube of its own
                              * (rad_refine_options: the slow reference) */
    int whole_contacts;      /* 1 = contact elements get whole hemi-cubes, not near views
                              * (rad_refine_options.whole_contacts: a reference) */
    /* rad_solve_scene only, may be NULL: the solve's output file in progress
     * (rad_journal in solfile.h).  Rows it already holds for this mesh and
     * these options are reused, every new row is appended to it as soon as
     * it is computed; the caller commits it with the solution.  With
     * refinement and one light group, the solution comes back with F's
     * entries released (s->F->entries_loaded = 0, H in s->irradiance, as
     * if read without them): the file holds them, and the matrix and the
     * element rows are then never in memory together. */
    rad_journal *journal;
    /* May be NULL: a flag the caller sets (from a signal handler, say) to
     * stop the form factors (hc_options.stop): no new row is started, the
     * rows the workers are computing are still stored (and journaled), and
     * the call fails with RAD_ERR_INTERRUPTED. */
    const volatile sig_atomic_t *stop;
    /* rad_resolve of a solution read from a file: 1 = once the patches are
     * solved, F's entries are freed before the elements are gathered when
     * that file holds them (rad_solution_matrix_in_file: no row computed)
     * and nothing after reads them (one light group at most); H is kept in
     * s->irradiance, the elements' rows are read only then when the
     * solution was read without them (RAD_PART_ELEMENT_ROWS), and a writer
     * still shares F.  What a relight of one change set asks: F and the
     * element rows never in memory together.  0 keeps F (a relight of
     * several variants reads it once for all). */
    int release_matrix;
    /* 1 = every patch is a target whose F_ij is computed exactly (the
     * point-to-polygon integral times the visible fraction, as for
     * emitters), not by counting pixels: what `ff FILE.vs3` does by
     * default, where a few large surfaces make it cheap (issue 39). */
    int exact_all;
    /* May be NULL: called with hemicube.progress_user as a stage whose
     * hemi-cubes report progress (hemicube.progress) begins: "form factors"
     * (the patches' rows) or "elements" (the elements' hemi-cubes), so
     * that a progress line can say which it counts. */
    void (*progress_stage)(void *user, const char *stage);
} rad_solve_options;

/* The whole computation for a scene file: load, mesh, form factors, solve.
 * Caller owns *out (write it with rad_solution_write). */
int rad_solve_scene_file(const char *path, const rad_solve_options *opt, rad_solution **out,
                         rad_error *err);

/* Mesh, form factors and solve for a scene already in memory (takes
 * ownership of scene, even on failure). */
int rad_solve_scene(rad_scene *scene, const rad_solve_options *opt, rad_solution **out,
                    rad_error *err);

/* Computes the missing form-factor rows that the solve needs (all rows of
 * patches with ρ > 0 in some band) and the per-patch power of every
 * punctual light not yet rendered, then solves with the source term
 * E_j + ρ_j H_d,j.  What a relight calls after changing ρ, E or a light's
 * intensity: no row and no light present is computed again. */
int rad_resolve(rad_solution *s, const rad_solve_options *opt, rad_error *err);

/* Builds s->elements (replacing any) from the patch solution s->B, as
 * opt->refine_threshold, min_element_size and element_levels say (off:
 * removes them): rad_elements_refine on an engine of its own, with the
 * options' hemi-cube settings; emitters get exact factors unless
 * pixel_emitters.  (rad_solve_scene refines on the engine of its solve.) */
int rad_refine_solution(rad_solution *s, const rad_solve_options *opt, rad_error *err);

/* The resolution R of the item buffers rendered at punctual lights:
 * opt->light_resolution, or by default the larger of 512 and the hemi-cube
 * resolution.  The patch power and the elements' visibility use the same. */
uint32_t rad_light_resolution(const rad_solve_options *opt);

/* 1 when the solution has several bands but equal ρ, E and light
 * intensities in all of them:
 * rad_resolve then solves one band and copies it (the same answer at a
 * fraction of the work). */
int rad_solution_is_grey(const rad_solution *s);

/* ----------------------------------------------------- drawing (views.c) */

/* Renders a solution from cam into *out (radiance): rad_drawing_create,
 * one view, rad_drawing_destroy. */
int rad_render_solution(const rad_solution *s, const rn_camera *cam, rn_image **out,
                        rad_error *err);

/* A solution made ready to draw: the mesh drawn (the elements' fans, or the
 * patches) and its vertex radiosities, computed once for any number of
 * views.  Read-only once made: threads may draw from one drawing at once. */
typedef struct rad_drawing rad_drawing;

/* Prepares s for drawing.  s's mesh is drawn in place when it has no
 * elements, so s must outlive the drawing and keep its mesh.  Caller owns
 * *out. */
int rad_drawing_create(const rad_solution *s, rad_drawing **out, rad_error *err);
void rad_drawing_destroy(rad_drawing *d); /* NULL does nothing */

/* What a drawing draws, for writers of other formats (bake.h): the mesh
 * (cells), its vertex radiosities (vertex_count × bands) and each cell's
 * patch (NULL: cell k is patch k).  Owned by d. */
void rad_drawing_parts(const rad_drawing *d, const rad_mesh **mesh, const double **vertex_B,
                       const uint32_t **patch_of);

/* One view into canvas c (rn_canvas_draw: *out is c's image until its next
 * draw); pixel ids name patches, elements or not. */
int rad_drawing_draw(const rad_drawing *d, rn_canvas *c, const rn_camera *cam, rn_image **out,
                     rad_error *err);

/* Called with each view's image as soon as it is drawn, from the thread
 * that drew it (several at once: it must only touch what belongs to view
 * k, e.g. write files of its own).  img is valid during the call.  Non-zero
 * (a rad_result, err filled) fails the run. */
typedef int (*rad_view_fn)(void *user, uint32_t view, const rn_image *img, rad_error *err);

/* Draws views 0..count-1 from cams, each image handed to done (may be
 * NULL), on `threads` threads (rad_view_threads), each with a canvas of its
 * own.  Every camera is checked before any view is drawn.  On a failure no
 * further view starts, the views already handed to done stay done, and the
 * error of the lowest failed view is returned. */
int rad_drawing_views(const rad_drawing *d, const rn_camera *cams, uint32_t count,
                      uint32_t threads, rad_view_fn done, void *user, rad_error *err);

/* The threads rad_drawing_views uses for `views` views: `threads`, or 0 =
 * one per online CPU (the files reach the disk on the caller's committer
 * thread, so no drawing thread waits for them); never more than the
 * views, at least 1. */
uint32_t rad_view_threads(uint32_t threads, uint32_t views);

/* A camera path (a fly-through) held in memory, one view per line:
 *   eye X,Y,Z target X,Y,Z [up X,Y,Z] [fov DEG]
 * '#' starts a comment; blank lines are skipped.  A view's up and fov
 * default to base's, its size is base's.  Every view is checked
 * (rn_camera_check); messages are "NAME: line N: WHAT".  Caller owns *out
 * (free). */
int rad_camera_path_parse(const char *text, size_t size, const char *name, const rn_camera *base,
                          rn_camera **out, uint32_t *count, rad_error *err);

/* A camera from the scene by name (NULL/"" = the first, else a default view
 * of the scene's bounds), sized width×height. */
int rad_camera_from_scene(const rad_scene *scene, const char *name, uint32_t width,
                          uint32_t height, rn_camera *cam, rad_error *err);

/* --------------------------------------------- the final gather (gather_scene.c) */

/* The gather renderer's input (render.h's rn_scene) built from a solution,
 * with the arrays it points to: the cells the vertex renderer draws (the
 * patches, or the elements' fans) and their vertex radiosities (the same
 * rad_elements_vertex_radiosity gives rn_render), each cell's ρ and E from
 * its patch (as solved, so relights count), a sheet's transmitted exitance
 * (rad_elements_transmitted), the materials' glossy lobes, the emitting
 * polygons with their patches' E, and the punctual lights at the
 * intensities solved with.  The form factors stay behind. */
typedef struct rad_gather_scene {
    rn_scene scene;
    uint32_t *cell_patch;   /* scene.mesh->patch_count: the patch each cell lies in */
    /* owned storage behind scene */
    rad_mesh *cells_;
    double *vertex_B_, *rho_, *emission_, *transmitted_;
    rn_material *materials_;
    rn_emitter *emitters_;
    rn_light *lights_;
} rad_gather_scene;

/* Caller owns *out (rad_gather_scene_destroy); s must outlive it. */
int rad_gather_scene_create(const rad_solution *s, rad_gather_scene **out, rad_error *err);
void rad_gather_scene_destroy(rad_gather_scene *g); /* NULL does nothing */

/* {0} means defaults. */
typedef struct rad_gather_options {
    rn_gather_options render;
    /* Ward's cache file, read before and written after (NULL = none): a
     * file made for another solution or other settings, or damaged, is
     * refused with a warning and the cache is computed anew. */
    const char *cache_path;
    rad_warn_fn warn;
    void *warn_user;
} rad_gather_options;

/* The gather render of s from cam into *out (img->patch holds patches, as
 * rad_render_solution's).  stats may be NULL.  Caller owns *out. */
int rad_render_gather(const rad_solution *s, const rn_camera *cam, const rad_gather_options *opt,
                      rn_image **out, rn_gather_stats *stats, rad_error *err);

/* The cache file's usual place beside a solution: SOLUTION.icache. */
void rad_gather_cache_path(const char *solution_path, char *buf, size_t size);

#endif /* RAD_PIPELINE_H */
