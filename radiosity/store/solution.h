/* solution.h - the solution store: everything a later command needs, in one
 * versioned, checksummed file.
 *
 * A solution holds the scene (materials, objects, polygons, cameras), the
 * patch mesh, the form-factor matrix (null entries compressed; rows may be
 * missing), the per-patch ρ and E actually solved with (a relight changes
 * these, never the scene's nominal materials), the radiosities B, and the
 * provenance of each stage (time, reused or recomputed).
 *
 * Invariants: every array is sized by mesh->patch_count × band_count; F->n ==
 * mesh->patch_count; B >= 0 and finite.  Files are written to a temporary
 * name and renamed, so a failed write never replaces a good file.
 *
 * The files of radiosity/store/ implement this header: solution.c (create,
 * destroy), write.c and read.c (the file), format.c (what those two share),
 * elements.c (the element store), lights.c (the punctual lights' stored
 * power), analysis.c (quantities read off a solution), relight.c (edits),
 * basis.c (the stored light responses and relighting by superposition).
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
 * h_le the direct irradiance at the element's centre from light l at unit
 * strength (1 W/sr, or 1 W/m² for a directional light), visibility from the
 * light's item buffer: hc_light_direct × hc_light_visibility.  Stored, so a
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
} rad_elements;

/* Where a solution's F was read from: the MATRIX section of a version 6
 * file (the solution's own file, or the one its MATRIXREF names).  A
 * relight that computed no row writes a reference to it instead of the rows
 * (rad_write_options.share_matrix).  path is NULL when F came from memory
 * or from an older file. */
typedef struct rad_matrix_file {
    char *path;           /* absolute path of the file holding the section (owned) */
    uint64_t offset;      /* the section as that file's index lists it */
    uint64_t length;
    uint64_t crc;         /* CRC-64/XZ of the section */
    uint64_t bytes;       /* F->bytes when read (0 once its entries are released,
                           * rad_solution_release_matrix): a matrix that grew since is
                           * another one */
} rad_matrix_file;

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
 * Made by the pipeline after the final B and elements exist (rad_solve_scene,
 * rad_resolve, rad_refine_solution): for K = 1 the solution itself, for
 * K > 1 one Gauss-Seidel solve per group on the stored rows, only when F
 * holds every row such a solve needs.  A change of ρ, of the elements or of
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

/* The light groups of s's current sources (E and the lights' I): into
 * patch_group[n] and light_group[light_count] (caller's buffers), the count
 * into *groups.  RAD_ERR_NOMEM only. */
int rad_basis_groups(const rad_solution *s, uint32_t *patch_group, uint32_t *light_group,
                     uint32_t *groups, rad_error *err);

/* Does s->basis still describe s: the same patch, light, element and band
 * counts and ρ as when it was made?  (0 when there is none.) */
int rad_basis_matches(const rad_solution *s);

typedef struct rad_solution {
    rad_scene *scene;        /* owned */
    rad_mesh *mesh;          /* owned */
    rad_matrix *F;           /* owned */
    uint32_t band_count;     /* == scene->band_count */
    double *rho;             /* ρ_i per band used in the solve, n × bands (owned) */
    double *emission;        /* E_i per band used in the solve, n × bands (owned) */
    double *B;               /* radiosity per band, n × bands (owned) */

    /* provenance */
    double patch_size;       /* the mesh option used (0 = polygon parameters/default) */
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
    uint32_t light_slots_;         /* entries allocated (private to solution.c) */

    rad_elements *elements;        /* NULL when the solution has none (owned) */

    /* What a solution read from a file remembers of it. */
    double *irradiance;            /* H_i per band of the stored B (n × bands, owned), as
                                    * written: what the report uses when F's entries were not
                                    * read (rad_solution_irradiance); NULL when not read */
    char *file;                    /* the file it was read from (owned), NULL from memory */
    uint64_t file_id;              /* CRC-64 of that file's index (version 6): its content */
    rad_matrix_file matrix_file;   /* where F's rows are (version 6) */
    rad_progress *progress;        /* NULL unless the last solve was progressive (owned) */
    rad_basis *basis;              /* the stored light responses, NULL when none (owned) */
    int basis_skipped;             /* 1: the file holds them, read without RAD_PART_BASIS (a
                                    * writer refuses: they would be lost) */
} rad_solution;

/* A new solution taking ownership of scene and mesh (on failure they are
 * destroyed too).  Allocates F (no rows), ρ and E from the scene's
 * materials, and B = E; the lights' intensities from the scene, their
 * per-patch power not yet computed.  Caller owns *out. */
int rad_solution_create(rad_scene *scene, rad_mesh *mesh, rad_solution **out, rad_error *err);
void rad_solution_destroy(rad_solution *s); /* NULL does nothing */

/* A progress record with room for `previews` previews (all fields 0,
 * preview_count = previews).  NULL when memory runs out.  Caller owns. */
rad_progress *rad_progress_create(uint32_t previews);
void rad_progress_destroy(rad_progress *p); /* NULL does nothing */

/* Writes the solution to path (format version 7, docs/solution-format.md)
 * through a temporary file and rename, F's rows included.  Elements whose
 * rows were not read (rows_loaded 0) are refused (RAD_ERR_USAGE): read
 * RAD_PART_ELEMENT_ROWS to write them. */
int rad_solution_write(const rad_solution *s, const char *path, rad_error *err);

/* {0} means defaults: the rows are written. */
typedef struct rad_write_options {
    /* 1: when F is still the MATRIX section it was read from (s->matrix_file,
     * no row added since), write a MATRIXREF to it instead of the rows.  The
     * file holding it gets a second name, PATH.matrix (a hard link, no
     * copy), which the reference names, so that moving, replacing or
     * deleting the original leaves this solution whole; where the file
     * system has no hard links the reference names the original by its
     * absolute path.  Either way the section's length and CRC-64 are checked
     * whenever it is read: a matrix removed or changed is an error, never a
     * silently different answer. */
    int share_matrix;
} rad_write_options;

/* What rad_solution_write_opts did with F. */
typedef struct rad_write_info {
    int matrix_shared;        /* 1: a MATRIXREF was written, no rows */
    int linked;               /* 1: through the hard link PATH.matrix */
    char matrix_path[4096];   /* the file the reference names */
} rad_write_info;

/* rad_solution_write with options; info (may be NULL) says what was done. */
int rad_solution_write_opts(const rad_solution *s, const char *path, const rad_write_options *opt,
                            rad_write_info *info, rad_error *err);

/* The size in bytes of s's file as a solve writes it now (rad_journal: each
 * row present in a block of its own; rad_solution_write groups rows into
 * larger blocks, a little smaller): a counting pass, nothing written, what
 * a solve's estimate builds on.  Elements whose rows were not read count
 * them at the least an entry takes (MIN_ENTRY bytes: a float and a column
 * gap of one byte). */
uint64_t rad_solution_file_bytes(const rad_solution *s);

/* The bytes row i of F adds to that file (0 for a missing row). */
uint64_t rad_solution_row_file_bytes(const rad_matrix *F, uint32_t i);

/* Reads and checks a solution file, everything in it.  Version 6: the
 * header, the index (its CRC) and each section (its own CRC, then every
 * index and count against the section's size before allocating); F comes
 * from the file's MATRIX or from the file its MATRIXREF names.  Versions
 * 1-5: the whole file and its one CRC.  Caller owns *out. */
int rad_solution_read(const char *path, rad_solution **out, rad_error *err);

/* Parts of a solution that a reader may leave out. */
#define RAD_PART_MATRIX 1u  /* F's entries: without it s->F has the rows present and their
                             * entry counts only (entries_loaded = 0), and s->irradiance */
#define RAD_PART_MATRIX_PLACE 2u /* without RAD_PART_MATRIX: still find where F's rows are
                                  * (s->matrix_file, F->key: the MATRIX section's place, or
                                  * the file a MATRIXREF names, its index checked) so that a
                                  * solution written from it can share them; left empty,
                                  * without an error, when that file is gone or changed */
#define RAD_PART_ELEMENT_ROWS 4u /* the elements' row entries F_ej (ELEMENTROWS, version 7):
                                  * without it rad_elements.rows_loaded = 0; what gathers
                                  * the elements again, exports or writes them needs it */
#define RAD_PART_BASIS 8u /* the stored light responses (BASIS): without it s->basis is NULL,
                           * and basis_skipped 1 when the file holds them; a relight by
                           * superposition and the writer need it */
#define RAD_PARTS_ALL (RAD_PART_MATRIX | RAD_PART_ELEMENT_ROWS | RAD_PART_BASIS)

/* rad_solution_read of the parts in `parts` only (everything else is always
 * read).  A version 6 or 7 file's sections that are not needed are neither
 * read nor checked: render and report read no byte of F, nor (version 7) of
 * the elements' rows.  Older files are read whole (a version 6 file's
 * element rows are inside ELEMENTS: always read). */
int rad_solution_read_parts(const char *path, unsigned parts, rad_solution **out,
                            rad_error *err);

/* Reads F's entries into a solution read without them, from the file it
 * was read from (which must not have changed since: its index's CRC is
 * compared). */
int rad_solution_load_matrix(rad_solution *s, rad_error *err);

/* Reads the elements' rows into a solution read without them
 * (RAD_PART_ELEMENT_ROWS), from its file as rad_solution_load_matrix does;
 * nothing to do when it has no elements or they are read.  A relight reads
 * them only once F's entries are released, so that the two are never in
 * memory together. */
int rad_solution_load_element_rows(rad_solution *s, rad_error *err);

/* Is F, as it is now, the MATRIX section s->matrix_file names: read from
 * it (or released since, below) and no row added?  What a writer needs to
 * share it (rad_write_options.share_matrix). */
int rad_solution_matrix_in_file(const rad_solution *s);

/* Frees F's entries (rad_matrix_release_entries), keeping which rows exist
 * and s->matrix_file in step: when F was that file's section it still is,
 * as for a solution read without RAD_PART_MATRIX, so a writer still shares
 * it and rad_solution_load_matrix reads it again.  For when nothing left
 * in memory reads the entries and a file holds them (this one, or the
 * solve's journal); the caller first puts the H of the current B in
 * s->irradiance (the writer needs it).  NULL does nothing. */
void rad_solution_release_matrix(rad_solution *s);

/* rad_solution_read from memory; `name` appears in messages.  check_sum = 0
 * skips the checksums (the fuzzer uses that to reach the structure checks).
 * A MATRIXREF cannot be followed from memory: with RAD_PART_MATRIX it is an
 * error. */
int rad_solution_parse(const void *data, size_t size, const char *name, int check_sum,
                       rad_solution **out, rad_error *err);
int rad_solution_parse_parts(const void *data, size_t size, const char *name, int check_sum,
                             unsigned parts, rad_solution **out, rad_error *err);

/* ----------------------------------------- a solve's file in progress (journal.c) */

/* What determines the form-factor rows of a solve: a CRC-64 of the mesh
 * (every vertex and patch as MESH stores them), the hemi-cube resolution,
 * the patches with exact factors (may be NULL), `flags` (the options that
 * change rows) and this program's version.  Rows kept from an earlier run
 * are reused only under the same key. */
uint64_t rad_rows_key(const rad_mesh *mesh, uint32_t resolution, const uint8_t *exact,
                      uint32_t flags);

/* A solve's output file while the solve runs: PATH.partial, a version 7
 * file whose MATRIX section grows by one block per finished row.  A crash,
 * a kill or Ctrl-C leaves the rows finished so far in it; the next solve
 * for the same PATH reads them back (a block cut short by the crash is
 * detected by its CRC and dropped) and computes only the others.  When the
 * solve is done, rad_journal_commit appends the other sections and the
 * index and renames the file onto PATH. */
typedef struct rad_journal rad_journal;

typedef struct rad_journal_stats {
    uint32_t kept;        /* rows the file holds now */
    uint32_t resumed;     /* rows taken from the file */
    uint32_t discarded;   /* rows of an earlier run with another key (scene, mesh, options) */
    uint64_t torn_bytes;  /* bytes of an unfinished block at the end, dropped */
} rad_journal_stats;

/* A journal for PATH; fresh = 1 throws away the rows PATH.partial holds
 * (they count as discarded).  The file is opened (or created), and locked
 * against other processes, by rad_journal_attach.  Caller owns *out: it
 * ends with rad_journal_commit or rad_journal_close. */
int rad_journal_open(const char *path, int fresh, rad_journal **out, rad_error *err);

/* Loads the rows the file holds under `key` into F (an empty matrix of the
 * mesh's n), starts the file afresh if it holds another key's rows, and
 * from then on appends every row F receives (F's sink; F must outlive the
 * journal or be detached by rad_journal_close). */
int rad_journal_attach(rad_journal *j, rad_matrix *F, uint64_t key, rad_error *err);

/* Does the file hold exactly the rows F holds, every one written since
 * attach (F attached, no row dropped by a bounded row store)?  Then F's
 * entries may be released (rad_matrix_release_entries) once nothing in
 * memory needs them: rad_journal_commit writes the file without them (its
 * MATRIX is already there, checked row by row as it was appended), the
 * irradiance then from s->irradiance or the basis. */
int rad_journal_holds(const rad_journal *j, const rad_matrix *F);

/* What rad_journal_attach found. */
rad_journal_stats rad_journal_stats_of(const rad_journal *j);

/* The partial file's name, for messages. */
const char *rad_journal_path(const rad_journal *j);

/* Writes s's other sections and the index after the rows, syncs, and
 * renames the file onto PATH.  s->F must be the attached matrix.  When F
 * has dropped rows the file holds (the progressive solver's bounded row
 * store), PATH is written whole from F instead and the partial file
 * removed; F's entries may have been released (rad_journal_holds).  Frees j whatever happens; on failure the partial file stays. */
int rad_journal_commit(rad_journal *j, const rad_solution *s, rad_error *err);

/* Stops taking F's rows (before F is freed: a solve that failed). */
void rad_journal_detach(rad_journal *j);

/* Syncs and closes, keeping the file for the next run (removing it when it
 * holds no row); detaches F.  NULL does nothing. */
void rad_journal_close(rad_journal *j);

/* --------------------------------------------- the element store (elements.c) */

/* Empty elements: a mesh of vertex_count vertices and count cells, every
 * per-element array of count entries (B of count × bands), room for
 * `entries` row entries; row counts zero.  NULL on OOM.  Caller owns. */
rad_elements *rad_elements_alloc(uint32_t vertex_count, uint32_t count, uint32_t bands,
                                 uint64_t entries);
void rad_elements_destroy(rad_elements *el); /* NULL does nothing */

/* Completes the cells of el->mesh from their corners and el->patch (the
 * patch's polygon, object, material and normal; centre and area from the
 * corners) and checks every invariant above against s's mesh (B included).
 * RAD_OK or RAD_ERR_CORRUPT naming `name` and the first bad element. */
int rad_elements_complete(rad_elements *el, const rad_solution *s, const char *name,
                          rad_error *err);

/* The same checks without completing (the derived fields must already
 * agree): what the writer runs before it creates a file.  Elements without
 * their entries (rows_loaded 0) have their rows checked as far as the
 * counts go. */
int rad_elements_check(const rad_elements *el, const rad_solution *s, const char *name,
                       rad_error *err);

/* ------------------------------------------------ reading a solution (analysis.c) */

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

/* ------------------------------------------------- changing a solution (relight.c) */

typedef enum rad_edit_kind {
    RAD_EDIT_LIGHT = 0,   /* NAME=off|on|SCALE: emission off, nominal, or nominal × SCALE */
    RAD_EDIT_EMISSION,    /* NAME=v[,v...]: emission per band (one value = all bands) */
    RAD_EDIT_REFLECTANCE  /* NAME=v[,v...]: reflectance per band (one value = all bands) */
} rad_edit_kind;

typedef struct rad_edit {
    rad_edit_kind kind;
    char name[256];
    double scale;                     /* light: 0 = off, 1 = on, else the factor */
    double values[RAD_MAX_BANDS];     /* emission / reflectance */
    uint32_t value_count;             /* 1 or band count */
} rad_edit;

/* Parses a command-line edit "NAME=..." of the given kind (no name lookup). */
int rad_edit_parse(rad_edit_kind kind, const char *arg, rad_edit *out, rad_error *err);

/* Checks every edit against the solution (names resolve to exactly one
 * object, punctual light or material — in that order — value counts match
 * the bands, 0 <= ρ < 1, E >= 0, a light edit names something that emits)
 * and only then applies them all to s->rho / s->emission /
 * s->light_intensity (a punctual light takes light and emission edits).
 * Nothing changes on error. */
int rad_solution_apply_edits(rad_solution *s, const rad_edit *edits, uint32_t count,
                             rad_error *err);

/* Relights s by superposition of its stored light responses (s->basis,
 * above) when its current sources allow it: ρ is the basis's, each group's
 * patches have E = c_{g,band} E_ref and its light I = c_{g,band} I_ref (one
 * c >= 0 per group and band, relative mismatch <= 1e-12), and every patch
 * and light outside the groups is dark.  Then B = Σ c B^(g), s->irradiance
 * = Σ c H^(g) and the elements' B = Σ c Be^(g) (nothing clamped), iterations
 * 0, residual the bound of solution.h, rows and lights computed 0, progress
 * NULL; the basis stays as it is (it still describes E_ref); *done = 1.
 * Otherwise nothing changes and *done = 0.  Either way `why` (why_size
 * bytes, may be NULL) says which and why, e.g. "3 stored light responses"
 * or "reflectance changed".  Needs no F entries.  RAD_ERR_NOMEM only. */
int rad_solution_superpose(rad_solution *s, int *done, char *why, size_t why_size,
                           rad_error *err);

/* A variations file: named variants, each a list of edits.
 *   variant NAME
 *     light NAME=off|on|SCALE
 *     emission NAME=v[,v...]
 *     reflectance NAME=v[,v...]
 *   end
 * '#' starts a comment. */
typedef struct rad_variant {
    char name[128];
    rad_edit *edits;
    uint32_t edit_count;
} rad_variant;

/* Parses a variations file held in memory; `name` appears in messages.
 * Caller owns *out (free with rad_variants_free). */
int rad_variants_parse(const char *text, size_t size, const char *name, rad_variant **out,
                       uint32_t *count, rad_error *err);
void rad_variants_free(rad_variant *v, uint32_t count); /* NULL does nothing */

/* ------------------------------------------------------ open data (export.c) */

/* Writes s as open data into the existing directory dir (docs/export.md):
 *   patches.csv     patch, object, material, area, centroid, normal, F_row,
 *                   then ρ, E and B per band (rho_R, E_R, B_R, ...)
 *   F.mtx           F_ij, Matrix Market coordinate real general, row i =
 *                   patch i - 1 = line i of patches.csv; rows never
 *                   computed are absent (F_row 0), not zero
 *   elements.csv, elements-F.mtx   the same for elements, when s has them
 * Numbers read back exactly (doubles 15-17 digits, the float F_ij 9).  Files are renamed into
 * place only once all are written: a failure before that replaces none. */
int rad_solution_export(const rad_solution *s, const char *dir, rad_error *err);

#endif /* RAD_SOLUTION_H */
