/* sv_internal.h - what the files of solver/ share; no file outside solver/
 * includes it (the public header is solver.h).
 *
 *   system.c       the system every method reads: validation, the gather
 *                  of one patch, the update, the residual;
 *   solver.c       the sweeping methods (Gauss-Seidel, Jacobi) and sv_solve,
 *                  which hands a system to its method;
 *   progressive.c  the progressive method: shooting, its row store, the
 *                  ambient term and previews.
 * Dependencies point one way: solver.c -> progressive.c -> system.c (and
 * solver.c -> system.c).
 *
 * Invariant of the shared functions: they read F only through rows that
 * check_row has accepted (or, for sv_residual_of with check_rows, check
 * them themselves), so a bad matrix is an error, never a crash.
 */
#ifndef SV_INTERNAL_H
#define SV_INTERNAL_H

#include "solver.h"

/* The scalar parts of the system: counts, arrays, A_i, ρ_i, E_i.  Cheap
 * (n × bands) and done before anything is allocated.  RAD_OK or
 * RAD_ERR_USAGE (err may be NULL). */
int sv_check_system(const sv_system *s, rad_error *err);

/* One present row against rad.h's invariants; *sum (when not NULL)
 * receives Σ_j F_ij.  RAD_OK or RAD_ERR_USAGE naming the row. */
int sv_check_row(const rad_matrix *F, uint32_t i, double *sum, rad_error *err);

static inline int sv_row_present(const rad_matrix *F, uint32_t i) { return F->row_done[i] != 0; }

/* The other side of patch i when light passes through it to i, else RAD_NONE. */
static inline uint32_t sv_transmits_from(const sv_system *s, uint32_t i)
{
    if (!s->tau || s->twin[i] == RAD_NONE)
        return RAD_NONE;
    return rad_any_positive(s->tau + (size_t)i * s->bands, s->bands) ? s->twin[i] : RAD_NONE;
}

/* Does patch i gather anything (reflect, or pass its twin's light on)?
 * Else its update is E_i whatever B is.  The brightest such patch is the
 * scale of the stopping rules and of the residual: an emitter's B = E is
 * exact from the start, and a light 50 times brighter than the walls must
 * not loosen the tolerance on the walls 50 times. */
static inline int sv_gathers(const sv_system *s, uint32_t i)
{
    return rad_any_positive(s->rho + (size_t)i * s->bands, s->bands) ||
           sv_transmits_from(s, i) != RAD_NONE;
}

/* B_i's new value per band into nv: E_i + ρ_i H_i + τ_i H_twin(i), from the
 * rows present (a missing row counts as empty). */
void sv_update(const sv_system *s, uint32_t i, const double *B, double *nv);

/* The residual of sv_stats for B: max over the patches gathered of
 * |update - B| / max B.  skip_missing leaves out (and counts in *unchecked,
 * when not NULL) patches that need a row that is missing; check_rows guards
 * indices for callers that have not validated the matrix (a bad row gives
 * NaN). */
double sv_residual_of(const sv_system *s, const double *B, int skip_missing, int check_rows,
                      uint32_t *unchecked);

/* progressive.c: the progressive method (sv_solve has checked the system
 * and the tolerance). */
int sv_solve_progressive(const sv_system *s, const sv_options *o, double tol, double *B,
                         sv_stats *st, rad_error *err);

#endif /* SV_INTERNAL_H */
