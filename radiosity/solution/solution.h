/* solution.h - the solution in memory: everything a later command needs
 * (the file that keeps it is radiosity/solfile/, solfile.h).
 *
 * A solution holds the scene (materials, objects, polygons, cameras), the
 * patch mesh, the form-factor matrix (null entries compressed; rows may be
 * missing), the per-patch ρ and E actually solved with (a relight changes
 * these, never the scene's nominal materials), the radiosities B, the
 * punctual lights' stored power, the elements, the stored light responses
 * and the provenance of each stage (time, reused or recomputed); and what
 * is read off it (irradiance, per-object and per-light power, object form
 * factors).
 *
 * Invariants: every array is sized by mesh->patch_count × band_count; F->n ==
 * mesh->patch_count; B >= 0 and finite.  Nothing here reads or writes a
 * file: a solution read from one carries the reader's record of it
 * (origin), which only the file module looks into.
 *
 * The files of radiosity/solution/ implement this header: solution.c
 * (create, destroy, the per-band arrays), element_store.c (the element
 * store), light_power.c (the punctual lights' stored power), basis.c (the
 * stored light responses' data), analysis.c (quantities read off a
 * solution).  Relighting (edits, superposition, making the responses) is
 * radiosity/relight/ (relight.h).
 */
#ifndef RAD_SOLUTION_H
#define RAD_SOLUTION_H

#include "../mesh/mesh.h"
#include "../core/rad.h"
#include "../scene/scene.h"

/* Stages timed and reported. */
typedef enum rad_stage {
    RAD_STAGE_LOAD = 0,
    RAD_STAGE_MESH,
    RAD_STAGE_FORM_FACTORS,
    RAD_STAGE_SOLVE,
    RAD_STAGE_STORE,
    RAD_STAGE_COUNT
} rad_stage;

const char *rad_stage_name(rad_stage s); /* "load", "mesh", "form_factors", "solve", "store" */

typedef struct rad_stage_info {
    double seconds;  /* time spent in this run (0 if reused) */
    int reused;      /* 1 if this run took the stage's result from a stored solution */
} rad_stage_info;

/* The power each patch receives from one punctual light at unit strength
 * (1 W/sr for a point or spot, 1 W/m² for a directional light), front faces
 * only, with occlusion (hc_light_power), sparse.  Stored so that a relight
 * can switch and scale lights without rendering them again.  Φ_j is kept in
 * float like F_ij, and the solve uses the float values, so a solution read
 * back solves exactly as the one written. */
typedef struct rad_light_power {
    int present;     /* 1 once computed (or read); 0 = to compute */
    uint32_t count;  /* patches receiving power */
    uint32_t *patch; /* strictly increasing patch indices (owned) */
    float *power;    /* Φ_j > 0 and finite (owned) */
} rad_light_power;

/* Elements (substructuring: Cohen, Greenberg, Immel & Brock 1986).  Coarse
 * patches carry the form-factor rows and the solve; fine elements receive.
 * An element e lies in one patch p and is that patch split k times (level
 * k, quadtree: a quad into four by its edge midpoints and centre, a
 * triangle into four by its edge midpoints).  Its radiosity is gathered
 * from the patch solution through element-to-patch form factors, hemi-cubes
 * at the element's centre, and the punctual lights' direct irradiance at
 * the element itself:
 *   B_e = E_p + ρ_p (Σ_j F_ej B_j + H_d,e),   H_d,e = Σ_l I_l h_le,
 * h_le the mean direct irradiance over the element from light l at unit
 * strength (1 W/sr, or 1 W/m² for a directional light): hc_light_polygon /
 * A_e × its visible fraction in the light's item buffer (hc_light_visibility
 * at its centre, or at points of it where a shadow edge crosses it).  Stored, so a
 * relight rescales it without rendering.  A level-0 element is its patch:
 * B_e = B_p, no row of its own, h_le = 0 (its patch's H_d,p = Σ_l I_l Φ_lp
 * / A_p is in B_p).  Elements read from a version 3 file have no h_le
 * (light_h NULL) and take their patch's H_d,p, as that version did.
 * On a transmitting sheet, B_e also takes τ_p H_twin(p), at the patch's
 * resolution.  Elements are split where the drawn radiosity misses what
 * their children gather, so neighbours may differ in level: a vertex of the
 * finer one may lie on an edge of the coarser one (a T-vertex); rendering
 * triangulates the coarse side (rad_elements_render_mesh), so there are no
 * cracks, and fits vertex values so that a linear field is drawn exactly
 * across levels.
 *
 * Invariants: mesh->patches[e] carries the polygon, object, material and
 * normal of patch[e]; cells of one polygon share vertices; every element of
 * level > 0 has its row, with the invariants of a form-factor row (columns
 * strictly increasing, F_ej > 0, Σ_j F_ej <= 1 + 1e-3, column != patch[e]);
 * B >= 0 and finite; light_h, when present, has light_count == the scene's
 * light count > 0 and every h_le finite and >= 0, 0 at level 0.
 *
 * Interpolated elements (interp, with direct; issue 18).  Most of what an
 * element adds over its patch is the direct light of the emitters and its
 * shadows; the rest, light reflected by other surfaces, is smooth at the
 * patches' scale.  An element with interp[e] = 1 therefore has a row that
 * holds only the direct sources' entries (the patches j with direct[j] = 1,
 * the emitters when it was made: F_ej × visibility, exact point-to-polygon
 * factors over strata of j, each times its visibility from an item buffer
 * rendered at the stratum), and takes the rest of its irradiance from the
 * patches: H_i,p = Σ_{j: !direct[j]} F_pj B_j per patch, interpolated at the
 * element's centre as the renderer draws a field of the patches (buried
 * patches extrapolated, quadratic vertex fits, the fan of its patch):
 *   B_e = E_p + ρ_p (Σ_j F_ej B_j + Ĥ_i(c_e) + H_d,e) + τ_p H_twin(p).
 * Every quantity is stored or follows from stored rows, so a relight that
 * scales an emitter's E rescales the direct entries exactly and renders
 * nothing.  interp is 0 at level 0; an interpolated element's columns all
 * have direct[j] = 1; an interpolated element never counts as buried. */
#define RAD_MAX_ELEMENT_LEVEL 12

typedef struct rad_elements {
    rad_mesh *mesh;        /* leaf elements as cells; vertex_boundary = on the polygon's outline (owned) */
    uint32_t *patch;       /* mesh->patch_count: the patch each element lies in (owned) */
    uint8_t *level;        /* splits below its patch, 0..RAD_MAX_ELEMENT_LEVEL (owned) */
    double *B;             /* mesh->patch_count × bands (owned) */
    uint32_t light_count;  /* lights in light_h (0 when NULL) */
    float *light_h;        /* mesh->patch_count × light_count: h_le at [e·light_count + l],
                            * or NULL: no punctual lights, or a version 3 file (owned) */
    uint8_t *interp;       /* mesh->patch_count: 1 = indirect light interpolated (above), or
                            * NULL: every element's row covers all it sees (owned) */
    uint8_t *direct;       /* the solution's patch count: the direct sources, present exactly
                            * when interp is (owned) */
    uint64_t *row_start;   /* F_ej by rows, columns are patches: row e is entries */
    uint32_t *row_count;   /*   [row_start[e], row_start[e] + row_count[e]) (owned) */
    uint32_t *col;         /* patch j (owned) */
    float *val;            /* F_ej (owned) */
    uint64_t nnz;          /* entries used */
    uint64_t capacity;     /* entries allocated */
    /* 1: col and val hold the rows' entries.  0: a version 7 file read
     * without RAD_PART_ELEMENT_ROWS: row_start, row_count and nnz are
     * right (so an empty row, a buried element, is still known), col and
     * val are NULL and capacity 0.  Whatever reads an entry (the gather,
     * export, the writer) refuses such elements: a bug of its caller, who
     * should have asked for the part. */
    int rows_loaded;
    /* provenance */
    double threshold;      /* the refinement threshold used (0: uniform levels) */
    double min_size;       /* smallest element edge allowed, scene units */
    uint64_t rows_computed; /* element hemi-cubes rendered in the run that made them */
    uint64_t near_views;    /* of those, near views (elements.h's whole_contacts); not
                             * stored in the file: 0 when read from one */
} rad_elements;


/* What a progressive solve did (NULL for the other solvers): how far it
 * got, the rows it computed again under --max-memory, and each preview's
 * time and unshot power.  Times are seconds since the run began (meshing),
 * with the previews' own rendering left out; unshot is the unshot power as
 * a fraction of the emitted power (the worst band). */
typedef struct rad_preview_info {
    uint32_t shots;
    uint32_t rows;   /* rows computed so far in the run (the time's main part) */
    double seconds;
    double unshot;
} rad_preview_info;

typedef struct rad_progress {
    uint32_t shots;
    double unshot;             /* at the end */
    int converged;             /* 1: unshot below the tolerance; 0: the shot limit stopped it */
    uint64_t rows_recomputed;  /* rows computed again after the row store dropped them */
    uint64_t rows_dropped;     /* rows dropped to stay within --max-memory */
    double preview_seconds;    /* time spent rendering previews (outside every stage) */
    uint32_t preview_count;
    rad_preview_info *previews; /* preview_count entries (owned) */
} rad_progress;

/* Stored light responses (issue 21): B is linear in the sources.  With
 * M = (I - diag(ρ) F)^-1, B = M (E + ρ H_d), and the element B, the
 * irradiance H and the light through sheets are linear in (E, I_l) too.
 * The sources are split into K light groups: the emitting patches by
 * (object, material) pair, the finest partition an edit can address, and
 * one group per punctual light of non-zero intensity.  B^(g) is the answer
 * to group g's sources alone (E_ref on its patches, I_ref for its light,
 * every other source 0).  A relight that only scales each group's sources
 * by c_{g,band} >= 0 (and changes no ρ) is then B = Σ_g c_g B^(g), likewise
 * H and the elements' B: no F read, no solve (rad_solution_superpose).
 *
 * Made by rad_basis_make (relight.h), which the pipeline calls after the
 * final B and elements exist (rad_solve_scene, rad_resolve,
 * rad_refine_solution): for K = 1 the solution itself, for K > 1 one
 * Gauss-Seidel solve per group on the stored rows, only when F holds every
 * row such a solve needs.  A change of ρ, of the elements or of
 * the mesh frees it: it describes the ρ it was made with (rho, kept in
 * memory only, from PATCHDATA when read) and is never written stale.
 *
 * Invariants: groups in 1..RAD_BASIS_MAX_GROUPS; patch_group[i] < groups
 * exactly when E_ref of patch i is > 0 in some band, else RAD_NONE; the same
 * for light_group and I_ref; every group has a member; every value finite
 * and >= 0; Σ_g B^(g) = the B solved with E_ref and I_ref (the solution's
 * own B when the basis was just made) within the solve tolerance: residual[g]
 * is group g's relative residual (sv_residual) and |Σ_g B^(g) - B| stays
 * within (Σ_g residual[g] max B^(g) + residual max B) / (1 - ρ_max), each
 * solve's error bound, ρ_max the largest ρ + τ (checked in debug builds,
 * with a factor 2). */
#define RAD_BASIS_MAX_GROUPS 32u /* above it, no basis: K extra solves and K copies of B */

typedef struct rad_basis {
    uint32_t groups;        /* K */
    uint32_t patch_count;   /* n, the solution's */
    uint32_t light_count;   /* the scene's punctual lights */
    uint32_t element_count; /* the solution's elements, 0 without */
    uint32_t band_count;
    double *E_ref;          /* n × bands: the patches' E the basis was solved with (owned) */
    double *I_ref;          /* light_count × bands: the lights' I then, NULL without lights (owned) */
    uint32_t *patch_group;  /* n: group of patch i, RAD_NONE when it emits nothing (owned) */
    uint32_t *light_group;  /* light_count: group of light l, RAD_NONE when dark (owned) */
    double *B;              /* groups × n × bands: B^(g) at [(g·n + i)·bands + b] (owned) */
    double *H;              /* groups × n × bands: H^(g), direct light included (owned) */
    double *Be;             /* groups × element_count × bands, NULL without elements (owned) */
    double *residual;       /* groups: each group's relative residual (owned) */
    double *rho;            /* n × bands: the ρ it was made with; in memory only (owned) */
} rad_basis;

typedef struct rad_solution rad_solution; /* below */

/* A basis of k groups for s's sizes, E_ref, I_ref and ρ copied from s, the
 * groups RAD_NONE, the responses zero.  NULL when memory runs out.  Caller
 * owns. */
rad_basis *rad_basis_create(const rad_solution *s, uint32_t groups);
void rad_basis_destroy(rad_basis *b); /* NULL does nothing */

/* Was s->basis made for s's sizes: the same patch, light, element and band
 * counts?  (0 when there is none.) */
int rad_basis_fits(const rad_solution *s);

/* Does s->basis still describe s: rad_basis_fits and the same ρ as when it
 * was made?  (0 when there is none.) */
int rad_basis_matches(const rad_solution *s);

/* What a solution read from a file remembers of it: the file module's
 * record (solfile.h), opaque here. */
typedef struct rad_solution_origin rad_solution_origin;

typedef struct rad_solution {
    rad_scene *scene;        /* owned */
    rad_mesh *mesh;          /* owned */
    rad_matrix *F;           /* owned */
    uint32_t band_count;     /* == scene->band_count */
    double *rho;             /* ρ_i per band used in the solve, n × bands (owned) */
    double *emission;        /* E_i per band used in the solve, n × bands (owned) */
    double *B;               /* radiosity per band, n × bands (owned) */

    /* provenance */
    double patch_size;       /* the patch size meshed with: the option, else the scene's default
                              * (polygons with subdivision parameters keep theirs); 0 in
                              * files written before it was recorded */
    uint32_t resolution;     /* hemi-cube R of the stored rows */
    char solver[32];         /* "gauss-seidel", "jacobi", "progressive" */
    double tolerance;
    uint32_t iterations;
    double residual;         /* max_i |E_i + ρ_i H_i - B_i| / max B (sv_residual); after a
                              * relight by superposition the bound Σ_g c_g r_g max B^(g) /
                              * max B of the groups' residuals r_g, with iterations 0 */
    uint64_t rows_computed;  /* hemi-cube rows computed in the run that wrote this file */
    rad_stage_info stages[RAD_STAGE_COUNT];

    /* Punctual lights, one entry per scene->lights[l] (NULL when the scene
     * has none).  The direct irradiance they cause,
     *   H_d,j = Σ_l I_l Φ_lj / A_j,
     * enters the solve as the source term E_j + ρ_j H_d,j. */
    double *light_intensity;       /* light_count × bands: I (or E⊥) solved with; a relight
                                    * scales it, the scene keeps the nominal value (owned) */
    rad_light_power *light_power;  /* light_count entries (owned) */
    uint64_t lights_computed;      /* light item buffers rendered in the run that wrote this:
                                    * one per light shot onto the patches, and one per light
                                    * and refinement pass for the elements' visibility */
    uint32_t light_slots_;         /* entries allocated (rad_solution_alloc_lights) */

    rad_elements *elements;        /* NULL when the solution has none (owned) */

    /* H_i per band of the current B (n × bands, owned), or NULL: what
     * rad_solution_irradiance returns when F's entries are not in memory.
     * The reader takes it from the file (as written), a relight by
     * superposition sums it, and the pipeline keeps it before it releases
     * F's entries. */
    double *irradiance;
    rad_progress *progress;        /* NULL unless the last solve was progressive (owned) */
    rad_basis *basis;              /* the stored light responses, NULL when none (owned) */

    /* The file it was read from, as the file module records it (where F's
     * rows are, which parts were left out): NULL when it was made in
     * memory.  Owned, freed by origin_destroy, which the reader sets; the
     * solution never looks inside. */
    rad_solution_origin *origin;
    void (*origin_destroy)(rad_solution_origin *o);
} rad_solution;

/* A new solution taking ownership of scene and mesh (on failure they are
 * destroyed too).  Allocates F (no rows), ρ and E from the scene's
 * materials, and B = E; the lights' intensities from the scene, their
 * per-patch power not yet computed.  Caller owns *out. */
int rad_solution_create(rad_scene *scene, rad_mesh *mesh, rad_solution **out, rad_error *err);
void rad_solution_destroy(rad_solution *s); /* NULL does nothing */

/* n × bands doubles, zeroed (one when n × bands is 0), or NULL when that
 * does not fit in size_t or memory: a per-patch (or per-light) band array
 * of a solution.  Caller owns. */
double *rad_solution_band_array(uint32_t n, uint32_t bands);

/* The light arrays of s for `count` lights (light_intensity, zero, and
 * light_power, none present; light_slots_ = count); nothing for 0.  0, or
 * -1 when memory runs out (what was allocated stays in s for its destroy).
 * For the creator and the file reader. */
int rad_solution_alloc_lights(rad_solution *s, uint32_t count);

/* A progress record with room for `previews` previews (all fields 0,
 * preview_count = previews).  NULL when memory runs out.  Caller owns. */
rad_progress *rad_progress_create(uint32_t previews);
void rad_progress_destroy(rad_progress *p); /* NULL does nothing */

/* ----------------------------------------- the element store (element_store.c) */

/* Empty elements: a mesh of vertex_count vertices and count cells, every
 * per-element array of count entries (B of count × bands), room for
 * `entries` row entries; row counts zero.  NULL on OOM.  Caller owns. */
rad_elements *rad_element_store_alloc(uint32_t vertex_count, uint32_t count, uint32_t bands,
                                      uint64_t entries);
void rad_element_store_destroy(rad_elements *el); /* NULL does nothing */

/* Fills element e's cell in el->mesh from `cell`, the cell of its patch
 * it lies in (a cluster's cell, or the patch itself: its polygon and
 * normal), and `patch` (object, material); centre and area from its
 * corners.  0, or -1 when the area is not positive. */
int rad_element_place(rad_elements *el, uint32_t e, const rad_patch *cell, const rad_patch *patch);

/* Completes the cells of el->mesh from their corners and el->patch (the
 * patch's polygon, object, material and normal; centre and area from the
 * corners) and checks every invariant above against s's mesh (B included).
 * RAD_OK or RAD_ERR_CORRUPT naming `name` and the first bad element. */
int rad_element_store_complete(rad_elements *el, const rad_solution *s, const char *name,
                               rad_error *err);

/* The same checks without completing (the derived fields must already
 * agree): what the writer runs before it creates a file.  Elements without
 * their entries (rows_loaded 0) have their rows checked as far as the
 * counts go. */
int rad_element_store_check(const rad_elements *el, const rad_solution *s, const char *name,
                            rad_error *err);

/* ------------------------ reading a solution (analysis.c; light power: light_power.c) */

typedef struct rad_object_stats {
    double area;                     /* Σ A_i over the object's patches */
    double B[RAD_MAX_BANDS];         /* area-weighted mean radiosity */
    double emitted[RAD_MAX_BANDS];   /* Σ A_i E_i: emitted power */
    double absorbed[RAD_MAX_BANDS];  /* Σ A_i (1 − ρ_i − τ_i) H_i: absorbed power */
    uint32_t patch_count;
    uint32_t material;               /* the material of its patches, RAD_NONE if several */
} rad_object_stats;

/* Irradiance H_i (incident power per area) of every patch, n × bands into
 * the caller's buffer: H_i = Σ_j F_ij B_j from row i when present, else by
 * reciprocity (1/A_i) Σ_j A_j F_ji B_j from the rows present.  When F's
 * entries were not read, the stored s->irradiance (computed so when the
 * file was written); RAD_ERR_USAGE when neither is there. */
int rad_solution_irradiance(const rad_solution *s, double *H, rad_error *err);

/* Direct irradiance from the punctual lights, H_d,j = Σ_l I_l Φ_lj / A_j per
 * band, n × bands into the caller's buffer (lights whose power is not yet
 * computed count as dark).  rad_solution_irradiance includes it. */
int rad_solution_direct_irradiance(const rad_solution *s, double *Hd, rad_error *err);

/* Stores Φ_j of light l (power[mesh->patch_count], dense, from
 * hc_light_power) in the sparse float form and marks it present.  Values
 * must be finite and >= 0; zeros are dropped. */
int rad_solution_set_light_power(rad_solution *s, uint32_t light, const double *power,
                                 rad_error *err);

typedef struct rad_light_stats {
    /* Power the light sends out: 4π I for a point light, I ∫ falloff dω over
     * the cone for a spot; a directional light has no finite emitted power,
     * so for it this is the power delivered (below). */
    double emitted[RAD_MAX_BANDS];
    /* Σ_j I Φ_j: the power reaching the patches' front faces (what enters
     * the energy balance; the rest leaves the scene). */
    double delivered[RAD_MAX_BANDS];
} rad_light_stats;

/* Per-light statistics into out[scene->light_count] (caller's buffer), with
 * the intensities solved with. */
int rad_solution_light_stats(const rad_solution *s, rad_light_stats *out, rad_error *err);

/* Per-object statistics into out[scene->object_count] (caller's buffer). */
int rad_solution_object_stats(const rad_solution *s, rad_object_stats *out, rad_error *err);

/* Object-to-object form factors F_AB = (1/A_A) Σ_{i∈A} Σ_{j∈B} A_i F_ij into
 * M[A * object_count + B] (caller's buffer, object_count² doubles).  Rows of
 * patches missing from F are taken by reciprocity from the rows present. */
int rad_object_form_factors(const rad_solution *s, double *M, rad_error *err);

/* ---- View3D's surface factors (view3d.c, docs/view3d.md) ---- */

/* The surfaces View3D reports for a .vs3 file (radiating and mask
 * surfaces, combined ones as one) with their factors. */
typedef struct rad_vs3_factors {
    uint32_t n;          /* reported surfaces */
    uint32_t *surface;   /* n: the model's index of each one's (primary) surface */
    double *area;        /* n: A_i, combined members summed, subsurfaces cut out */
    double *emittance;   /* n: ε_i, area-weighted over combined members */
    double *F;           /* n×n row-major: F_ij, or script-F_ij when script = 1 */
    int script;          /* 1 = Hottel's script-F (emit = 1) */
    double row_error;    /* encl = 1: largest |Σ_j F_ij − 1| before normalising */
} rad_vs3_factors;

/* The reported surfaces' factors from a solution of the scene that
 * rad_vs3_load built with model m (every row computed).  Caller owns *out. */
int rad_vs3_factors_compute(const rad_solution *s, const rad_vs3 *m, rad_vs3_factors **out,
                            rad_error *err);
void rad_vs3_factors_destroy(rad_vs3_factors *f); /* NULL does nothing */

#endif /* RAD_SOLUTION_H */
