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
 */
#ifndef RAD_SOLUTION_H
#define RAD_SOLUTION_H

#include "mesh.h"
#include "rad.h"
#include "scene.h"

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
    double residual;
    uint64_t rows_computed;  /* hemi-cube rows computed in the run that wrote this file */
    rad_stage_info stages[RAD_STAGE_COUNT];
} rad_solution;

/* A new solution taking ownership of scene and mesh (on failure they are
 * destroyed too).  Allocates F (no rows), ρ and E from the scene's
 * materials, and B = E.  Caller owns *out. */
int rad_solution_create(rad_scene *scene, rad_mesh *mesh, rad_solution **out, rad_error *err);
void rad_solution_destroy(rad_solution *s); /* NULL does nothing */

/* Writes the solution to path through a temporary file and rename. */
int rad_solution_write(const rad_solution *s, const char *path, rad_error *err);

/* Reads and checks a solution file (magic, version, size, checksum, then
 * every index and count against the file's size before allocating).
 * Caller owns *out. */
int rad_solution_read(const char *path, rad_solution **out, rad_error *err);

/* The same from memory; `name` appears in messages.  check_sum = 0 skips the
 * checksum (the fuzzer uses that to reach the structure checks). */
int rad_solution_parse(const void *data, size_t size, const char *name, int check_sum,
                       rad_solution **out, rad_error *err);

#endif /* RAD_SOLUTION_H */
