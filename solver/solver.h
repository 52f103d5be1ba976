/* solver.h - solving the radiosity system B_i = E_i + ρ_i Σ_j F_ij B_j
 * (plus τ_i Σ_j F_twin(i),j B_j for the sides of transmitting sheets).
 *
 * Three methods on the same stored matrix:
 *   gauss-seidel  gathering, in place, all bands in one sweep over F;
 *   jacobi        the Neumann series B = Σ_k (ρF)^k E (Heckbert 1992, §4.1);
 *   progressive   shooting from the patch with most unshot power (Cohen,
 *                 Chen, Wallace & Greenberg 1988), asking for rows in
 *                 batches as it goes, within a memory budget; it converges
 *                 to the very system the gathering methods solve
 *                 (progressive.c says how).
 *
 * The solver never sees GL or files: rows it lacks are requested through a
 * callback.  Invariants of every result: B >= 0, finite, B_i >= E_i.
 */
#ifndef SV_SOLVER_H
#define SV_SOLVER_H

#include "../radiosity/core/rad.h"

/* The system to solve.  Arrays are indexed [patch * bands + band]. */
typedef struct sv_system {
    uint32_t n;               /* patches */
    uint32_t bands;           /* 1..RAD_MAX_BANDS */
    rad_matrix *F;            /* form factors; the progressive solver may fill missing rows */
    const double *area;       /* A_i, n values */
    const double *rho;        /* ρ_i per band, n × bands, each in [0,1) */
    const double *emission;   /* E_i per band, n × bands, >= 0 */
    /* Diffuse transmission; both NULL for opaque scenes.  A transmitting
     * patch i is one side of a thin sheet whose other side is patch
     * twin[i] (RAD_NONE: one-sided); what arrives there passes through:
     *   B_i = E_i + ρ_i H_i + τ_i H_twin(i),   H_k = Σ_j F_kj B_j.
     * Requires τ_i >= 0, ρ_i + τ_i < 1, τ_i > 0 only where twin[i] exists,
     * twin[twin[i]] == i; row twin(i) is read wherever τ_i > 0 (the back
     * hemi-cube of i). */
    const double *tau;        /* τ_i per band, n × bands, or NULL */
    const uint32_t *twin;     /* n values, or NULL */
    /* Optional (NULL: none): the flat surface (a scene polygon) of each
     * patch, n values, consecutive patches of one surface being near each
     * other.  The progressive solver's previews take a patch without a row
     * as seeing what the nearest patch of its surface with a row sees. */
    const uint32_t *group;
} sv_system;

typedef enum sv_method {
    SV_GAUSS_SEIDEL = 0,
    SV_JACOBI,
    SV_PROGRESSIVE
} sv_method;

/* The solvers' default stopping tolerance (sv_options.tolerance 0), the one
 * place it is written. */
#define SV_DEFAULT_TOLERANCE 1e-4

/* What the progressive solver shows of itself (sv_options.on_preview and
 * .progress). */
typedef struct sv_progress {
    uint32_t shots;          /* shots so far */
    double unshot;           /* unshot power / emitted power, the worst band */
    double tolerance;        /* the stopping tolerance on unshot */
    double seconds;          /* time in the solve so far, the previews' (their making and
                              * the callbacks) and progress's time left out */
    uint32_t rows_requested; /* rows asked of need_rows so far (recomputed ones included) */
    uint32_t rows_dropped;   /* rows dropped to stay within max_matrix_bytes */
    const double *B;         /* on_preview: the estimate, ambient term included (n × bands) */
    int done;                /* progress: 1 on the last call of a solve */
} sv_progress;

/* {0} means defaults. */
typedef struct sv_options {
    sv_method method;
    /* Stop when the estimated remaining relative error is below this.
     * Gauss-Seidel/Jacobi: max_i |B_i - B_i*| / max B estimated from the
     * last change and the observed contraction rate q: change · q / (1 - q);
     * max B over the patches that reflect or transmit (an emitter's B = E
     * is exact from the start: a bright light must not loosen the
     * tolerance on the walls).
     * Progressive: unshot power / emitted power, the worst band.
     * 0 = SV_DEFAULT_TOLERANCE. */
    double tolerance;
    uint32_t max_iterations; /* sweeps (or shots for progressive); 0 = 10000 (progressive: 100·n) */

    /* Progressive only: fills the rows rows[0..count) of F, all missing
     * (count <= row_batch), for instance on every worker at once.  Required
     * if any row the solve needs is missing; returns RAD_OK or an error code
     * (which stops the solve). */
    int (*need_rows)(void *user, const uint32_t *rows, uint32_t count, rad_error *err);
    uint32_t row_batch;      /* rows per need_rows call at most; 0 = SV_DEFAULT_ROW_BATCH */
    /* Progressive only, may be NULL: column i of F, the factors F_ji its
     * receivers j gather from i, for a shooter whose entries in the
     * gathering rows are computed exactly (an emitter: the point-to-polygon
     * factor times the visibility, as Wallace, Elmquist & Haines 1989 shoot
     * from a source to receiver points).  Fills col[0..*count) strictly
     * increasing, never i, and val[] > 0 (caller's buffers of n entries);
     * *count = RAD_NONE when it has nothing better than reciprocity from
     * row i.  Asked on a patch's first shot, only in a solve that computes
     * rows (never when every row it needs is present). */
    int (*need_column)(void *user, uint32_t i, uint32_t *col, float *val, uint32_t *count,
                       rad_error *err);
    /* Progressive only, may be NULL: called every `preview_every` shots
     * and/or every `preview_seconds` of solve time (either that is set;
     * neither: every shot), with the current estimate B including the
     * ambient term.  Returning non-zero stops the solve with RAD_OK. */
    int (*on_preview)(void *user, const sv_progress *p);
    uint32_t preview_every;
    double preview_seconds;
    void *user;              /* for need_rows, need_column and on_preview */
    /* Progressive only: the most bytes F's pool may hold (rad_matrix_pool_bytes);
     * 0 = no limit.  Rows of the patches least likely to shoot soon are
     * dropped to make room, and computed again if they shoot again. */
    uint64_t max_matrix_bytes;
    /* Progressive only, may be NULL: a few times a second, and once with
     * done = 1 at the end (no B). */
    void (*progress)(void *progress_user, const sv_progress *p);
    void *progress_user;
    /* 1 = plain iteration.  By default Gauss-Seidel and Jacobi
     * extrapolate the dominant error mode (Aitken) once the observed
     * contraction q is stable, B += ΔB·q/(1-q), and keep sweeping until the
     * stopping rule confirms the result.  Closed rooms at ρ = 0.999: ~4500
     * Gauss-Seidel sweeps become 13 (well mixed) to ~800 (slowly mixing). */
    int no_acceleration;
} sv_options;

/* Rows per need_rows call when sv_options.row_batch is 0. */
#define SV_DEFAULT_ROW_BATCH 64u

typedef struct sv_stats {
    uint32_t iterations;    /* sweeps (gauss-seidel, jacobi) or shots (progressive) */
    double residual;        /* max_i |E_i + ρ_i Σ F_ij B_j - B_i| / max B, all bands, over
                             * the patches whose rows are present; max B over the
                             * patches that reflect or transmit, as for tolerance */
    uint32_t unchecked;     /* patches left out of the residual: their rows were dropped
                             * (progressive under max_matrix_bytes) or never computed
                             * (a solve stopped early) */
    double estimated_error; /* the stopping rule's estimate of the remaining relative error
                             * (progressive: the unshot fraction) */
    double contraction;     /* observed ratio of successive changes (spectral-radius estimate) */
    uint32_t rows_requested;/* rows the progressive solver asked for (recomputed ones included) */
    uint32_t rows_recomputed; /* ... of which had been computed before and dropped */
    uint32_t rows_dropped;  /* rows dropped to stay within max_matrix_bytes */
    uint32_t exact_columns; /* shots with need_column's exact column */
    double preview_seconds; /* time spent on previews (making them and on_preview) and
                             * progress calls: left out of sv_progress.seconds */
    int converged;          /* 1 if the tolerance was met, 0 if max_iterations stopped it */
    int stopped;            /* 1 if on_preview asked the solve to stop */
    uint32_t extrapolations;/* Aitken steps taken (gauss-seidel, jacobi) */
} sv_stats;

/* Solves the system.  B (n × bands, caller's buffer) receives the radiosities;
 * its input is ignored (the initial guess is E).  stats may be NULL.
 * Errors: RAD_ERR_USAGE for a malformed system, RAD_ERR_INVALID for ρ outside
 * [0,1), RAD_ERR_LIMIT when max_matrix_bytes cannot hold the rows of one
 * shot, or whatever need_rows or need_column returns. */
int sv_solve(const sv_system *sys, const sv_options *opt, double *B, sv_stats *stats,
             rad_error *err);

/* 1 when the gathering solvers read row i of F: patch i reflects (ρ_i > 0
 * in some band), or its twin transmits (row i is then the twin's back
 * hemi-cube).  A patch that does neither has B = E whatever it sees. */
int sv_row_needed(const sv_system *sys, uint32_t i);

/* Residual as defined in sv_stats for a given B (rows missing from F count
 * as zero rows: right for the gathering solvers, which leave out only the
 * rows of patches that neither reflect nor transmit). */
double sv_residual(const sv_system *sys, const double *B);

/* Name of a method ("gauss-seidel", "jacobi", "progressive"). */
const char *sv_method_name(sv_method m);
/* Parses a method name; returns 0 and sets *m, or -1. */
int sv_method_parse(const char *name, sv_method *m);

#endif /* SV_SOLVER_H */
