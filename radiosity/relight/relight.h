/* relight.h - relighting a stored solution: changing its lights and
 * colours without touching its geometry, between the solution (solution.h)
 * and the pipeline (pipeline.h, which solves again when it must).
 *
 * Edits change the ρ and E (and the punctual lights' I) a solution is
 * solved with (edits.c); a variations file names sets of edits
 * (variants.c); the stored light responses (solution.h, rad_basis) are made
 * per light group (responses.c) and summed when an edit only scales lights
 * (superpose.c): no F read, no solve.  A relight that changes ρ solves
 * again: rad_resolve (pipeline.h).
 *
 * Invariants: a batch of edits is checked whole before any is applied;
 * superposition either relights exactly (to the groups' solve tolerance) or
 * changes nothing; a basis made here obeys solution.h's rad_basis
 * invariants.
 */
#ifndef RAD_RELIGHT_H
#define RAD_RELIGHT_H

#include "../core/rad.h"
#include "../solution/solution.h"

/* ------------------------------------------------------------- edits (edits.c) */

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

/* ------------------------------------------------- variations file (variants.c) */

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

/* ------------------------------------------- the stored light responses (responses.c) */

/* The light groups of s's current sources (E and the lights' I): into
 * patch_group[n] and light_group[light_count] (caller's buffers), the count
 * into *groups.  RAD_ERR_NOMEM only. */
int rad_basis_groups(const rad_solution *s, uint32_t *patch_group, uint32_t *light_group,
                     uint32_t *groups, rad_error *err);

/* What rad_basis_make needs of the pipeline, which alone knows how to solve
 * (its solver options, its hemi-cube engine for the rows): a solve of s's
 * patches for other sources on the rows F holds. */
typedef struct rad_group_solver {
    /* Called once before any solve: *rows_ready = 1 when F holds every row
     * a solve of s for other sources needs (none is computed then).  Its
     * failure fails rad_basis_make. */
    int (*prepare)(void *user, const rad_solution *s, int *rows_ready, rad_error *err);
    /* Solves s's patches by Gauss-Seidel to s->tolerance for its current
     * sources (s->emission and s->light_intensity, which rad_basis_make has
     * set to one group's): B into s->B, the relative residual (sv_residual)
     * into *residual. */
    int (*solve)(void *user, rad_solution *s, double *residual, rad_error *err);
    void *user;
} rad_group_solver;

/* Makes s->basis (solution.h, rad_basis), replacing any, for s's final B
 * and elements: none when neither F's entries nor s->irradiance are there
 * or the residual is not finite and >= 0, nor for no group or more than
 * RAD_BASIS_MAX_GROUPS; for one group the solution itself (exact for every
 * solver); for more, one solve per group through `solver` (its elements
 * gathered, its H computed) when F's entries are loaded and prepare says
 * the rows are ready, the solution's sources, B, elements' B, residual and
 * iterations put back after.  Checked against solution.h's invariant in
 * debug builds. */
int rad_basis_make(rad_solution *s, const rad_group_solver *solver, rad_error *err);

/* ---------------------------------------- superposition (superpose.c) */

/* Relights s by superposition of its stored light responses (s->basis,
 * solution.h) when its current sources allow it: ρ is the basis's, each group's
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

#endif /* RAD_RELIGHT_H */
