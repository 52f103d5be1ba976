/* solver.c - solves B_i = E_i + ρ_i Σ_j F_ij B_j (+ τ_i Σ_j F_twin(i),j B_j
 * where a sheet transmits), every band at once (solver.h).
 *
 * Owns the two sweeping methods (Gauss-Seidel gathering, the Jacobi/Neumann
 * series) with their stopping rule and Aitken acceleration, and sv_solve,
 * which validates the system and hands it to a method (the progressive one
 * is progressive.c's).  The system itself - validation, the gather of one
 * patch, the update, the residual - is system.c's.  It reads F only through
 * the rad_matrix rows and never sees GL or files.
 *
 * Invariant: the B handed back always comes out of a full sweep or a shot,
 * never straight out of an extrapolation, so B_i >= E_i >= 0 holds exactly in
 * floating point (every update adds a non-negative ρ_i H_i + τ_i H_twin(i) to E_i) and
 * the stopping rule has looked at the result it returns.
 */
#include "sv_internal.h"

#include <stdlib.h>
#include <string.h>

#define SV_DEFAULT_SWEEPS 10000u

/* The stopping rule smooths the contraction q as the largest of the last
 * SV_RATIO_WINDOW ratios of successive changes: a transient that dies fast
 * must not make the slow mode look fast. */
#define SV_RATIO_WINDOW 3
/* Aitken is only worth it, and only trusted, when the error is dominated by
 * one slow mode: q at least this large, and the last SV_RATIO_WINDOW ratios
 * agreeing within SV_STABLE·(1 - q).  After extrapolating with an estimate
 * q̂ = q + ε the dominant error shrinks to about ε/((1-q)q) of itself, so the
 * spread must be small against 1 - q, not against q. */
#define SV_AITKEN_MIN_Q 0.5
#define SV_STABLE 0.003
/* ... and ΔB_k must point the way ΔB_k-1 did (cosine of the angle between
 * them, per band): equal norm ratios alone would also let through a mode
 * that flips sign every sweep (Jacobi between two facing walls, eigenvalue
 * -q), which Aitken with +q amplifies by 2/(1-q) instead of removing.  A
 * misfit sin θ injects about sin θ of the removed error. */
#define SV_ALIGNED 0.99995

/* ------------------------------------------------------- stopping monitor */

/* Per band, because the bands are independent systems with their own ρ and
 * so their own contraction rate. */
typedef struct band_monitor {
    double d_prev;                  /* max_i |ΔB_i,b| of the previous sweep; < 0 = unknown */
    double ratio[SV_RATIO_WINDOW];  /* d_k / d_k-1, most recent first */
    uint32_t ratios;                /* valid entries of ratio[] */
    uint32_t aligned;               /* consecutive sweeps with cos(ΔB_k, ΔB_k-1) >= SV_ALIGNED */
    double q_floor;                 /* q of the last extrapolation (see below) */
    double gamma;                   /* max_i ρ_i,b Σ_j F_ij: a proven bound on the contraction */
} band_monitor;

static void monitor_push(band_monitor *m, double d, double cosine)
{
    if (m->d_prev > 0.0) {
        memmove(m->ratio + 1, m->ratio, (SV_RATIO_WINDOW - 1) * sizeof m->ratio[0]);
        m->ratio[0] = d / m->d_prev;
        if (m->ratios < SV_RATIO_WINDOW)
            m->ratios++;
        m->aligned = cosine >= SV_ALIGNED ? m->aligned + 1 : 0;
    }
    m->d_prev = d;
}

/* The contraction the stopping rule believes: the largest recent ratio, never
 * below q_floor, never above gamma.  After an extrapolation the fast modes
 * dominate the change for a while and their ratios are small, yet what is
 * left of the slow mode still decays at the old q: q_floor remembers it.
 * gamma bounds ||M||∞ for Jacobi and Gauss-Seidel alike (nonnegative
 * splitting), so capping by it never understates the error. */
static double monitor_q(const band_monitor *m)
{
    double q = m->q_floor;
    for (uint32_t k = 0; k < m->ratios; k++)
        if (!(m->ratio[k] <= q))
            q = m->ratio[k];
    if (m->gamma < q)
        q = m->gamma;
    return q;
}

/* ---------------------------------------------------- Gauss-Seidel, Jacobi */

/* One sweep.  Gauss-Seidel: src == dst, each B_i gathered from the newest
 * values (gathering in place, Cohen & Greenberg 1985).  Jacobi: dst =
 * E + ρ F src, one more term of the Neumann series.  D holds the previous
 * change of every value and receives the new one; per band, dmax[b] gets
 * max |ΔB_k| and cosine[b] the cosine between ΔB_k and ΔB_k-1 (0 when
 * either is zero).  Returns the scale of the stopping rule: max B over
 * the patches that gather (sv_gathers), or over all when none does; not
 * finite when some B is not. */
static double sweep(const sv_system *s, const double *src, double *dst, double *D, double *dmax,
                    double *cosine)
{
    const uint32_t nb = s->bands;
    double ball = 0.0, bgather = 0.0, g[RAD_MAX_BANDS];
    double dot[RAD_MAX_BANDS], now[RAD_MAX_BANDS], before[RAD_MAX_BANDS];
    for (uint32_t b = 0; b < nb; b++)
        dmax[b] = dot[b] = now[b] = before[b] = 0.0;
    for (uint32_t i = 0; i < s->n; i++) {
        const size_t o = (size_t)i * nb;
        const int gathers = sv_gathers(s, i);
        sv_update(s, i, src, g);
        for (uint32_t b = 0; b < nb; b++) {
            double old = src[o + b];
            double nv = g[b];
            double d = nv - old, prev = D[o + b];
            dst[o + b] = nv;
            D[o + b] = d;
            dot[b] += d * prev;
            now[b] += d * d;
            before[b] += prev * prev;
            if (fabs(d) > dmax[b])
                dmax[b] = fabs(d);
            if (!(nv <= ball)) /* NaN or overflow propagates to the caller's check */
                ball = nv;
            if (gathers && nv > bgather)
                bgather = nv;
        }
    }
    for (uint32_t b = 0; b < nb; b++)
        cosine[b] = now[b] > 0.0 && before[b] > 0.0 ? dot[b] / sqrt(now[b] * before[b]) : 0.0;
    return isfinite(ball) && bgather > 0.0 ? bgather : ball;
}

/* Aitken on the dominant mode of each band whose last SV_RATIO_WINDOW
 * ratios agree: once ΔB_k = q ΔB_k-1, the rest of the geometric series is
 * ΔB_k·q/(1-q).  Clamping at E only moves a value toward the solution
 * (B* >= E), and restores B >= 0 for the next Gauss-Seidel sweep to
 * gather from. */
static void extrapolate(const sv_system *s, band_monitor *mon, double *cur, const double *D,
                        sv_stats *st)
{
    const uint32_t nb = s->bands;
    const size_t len = (size_t)s->n * nb;
    for (uint32_t b = 0; b < nb; b++) {
        band_monitor *m = &mon[b];
        if (m->ratios < SV_RATIO_WINDOW || m->aligned < SV_RATIO_WINDOW)
            continue;
        double lo = m->ratio[0], hi = m->ratio[0];
        for (uint32_t r = 1; r < SV_RATIO_WINDOW; r++) {
            if (m->ratio[r] < lo)
                lo = m->ratio[r];
            if (m->ratio[r] > hi)
                hi = m->ratio[r];
        }
        if (!(lo >= SV_AITKEN_MIN_Q && hi < 1.0 && hi - lo <= SV_STABLE * (1.0 - hi)))
            continue;
        double q = m->ratio[0], f = q / (1.0 - q);
        for (size_t x = b; x < len; x += nb) {
            double v = cur[x] + D[x] * f;
            cur[x] = v > s->emission[x] ? v : s->emission[x];
        }
        /* The next change is measured from the extrapolated B: no ratio
         * across the jump. */
        m->ratios = 0;
        m->aligned = 0;
        m->d_prev = -1.0;
        if (hi > m->q_floor)
            m->q_floor = hi;
        st->extrapolations++;
    }
}

static int solve_sweeps(const sv_system *s, const sv_options *o, double tol, double *B,
                        sv_stats *st, rad_error *err)
{
    const uint32_t n = s->n, nb = s->bands;
    const size_t len = (size_t)n * nb;
    const int jacobi = o->method == SV_JACOBI;
    const uint32_t max_sweeps = o->max_iterations ? o->max_iterations : SV_DEFAULT_SWEEPS;

    band_monitor mon[RAD_MAX_BANDS];
    for (uint32_t b = 0; b < nb; b++)
        mon[b] = (band_monitor){.d_prev = -1.0, .gamma = 0.0};
    /* Every row the sweeps will read is checked once here, and gamma falls
     * out: max_i ρ_i Σ_j F_ij + τ_i Σ_j F_twin(i),j. */
    double *sum = malloc((size_t)n * sizeof *sum);
    if (!sum)
        return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for %u patches", n);
    for (uint32_t i = 0; i < n; i++) {
        sum[i] = 0.0;
        if (!sv_row_present(s->F, i))
            continue;
        int rc = sv_check_row(s->F, i, &sum[i], err);
        if (rc) {
            free(sum);
            return rc;
        }
    }
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = sv_transmits_from(s, i);
        for (uint32_t b = 0; b < nb; b++) {
            double gb = s->rho[(size_t)i * nb + b] * sum[i] +
                        (t != RAD_NONE ? s->tau[(size_t)i * nb + b] * sum[t] : 0.0);
            if (gb > mon[b].gamma)
                mon[b].gamma = gb;
        }
    }
    free(sum);

    double *D = calloc(len, sizeof *D); /* ΔB_0 = 0: no direction yet */
    double *other = jacobi ? malloc(len * sizeof *other) : NULL;
    if (!D || (jacobi && !other)) {
        free(D);
        free(other);
        return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for %u patches", n);
    }
    memcpy(B, s->emission, len * sizeof *B); /* initial guess B = E */
    double *cur = B, *nxt = jacobi ? other : B;

    double dmax[RAD_MAX_BANDS], cosine[RAD_MAX_BANDS];
    uint32_t k = 0;
    int rc = RAD_OK;
    for (k = 1; k <= max_sweeps; k++) {
        double bmax = sweep(s, cur, nxt, D, dmax, cosine);
        if (jacobi) {
            double *t = cur;
            cur = nxt;
            nxt = t;
        }
        if (!isfinite(bmax)) {
            rc = rad_fail(err, RAD_ERR_INVALID,
                          "solver: radiosity overflowed in sweep %u (emission too large)", k);
            break;
        }

        /* The stopping rule: δ = max|ΔB|/max B (the brightest patch that
         * gathers), remaining error ≈ δ·q/(1-q). */
        double e = 0.0, qmax = 0.0;
        int known = 1;
        for (uint32_t b = 0; b < nb; b++) {
            monitor_push(&mon[b], dmax[b], cosine[b]);
            if (dmax[b] == 0.0)
                continue; /* this band is at its fixed point, exactly */
            double q = monitor_q(&mon[b]);
            if (q > qmax)
                qmax = q;
            if (mon[b].ratios < 2) {
                known = 0; /* one ratio is no rate: wait for a second */
                e = INFINITY;
                continue;
            }
            double eb = q < 1.0 ? dmax[b] / bmax * q / (1.0 - q) : INFINITY;
            if (!(eb <= e))
                e = eb;
        }
        st->iterations = k;
        st->estimated_error = e;
        st->contraction = qmax;
        if (k >= 2 && known && e < tol) {
            st->converged = 1;
            break;
        }
        if (o->no_acceleration || k == max_sweeps)
            continue;

        extrapolate(s, mon, cur, D, st);
    }
    if (rc == RAD_OK && cur != B)
        memcpy(B, cur, len * sizeof *B);
    free(D);
    free(other);
    return rc;
}

/* ------------------------------------------------------------------ solve */

int sv_solve(const sv_system *sys, const sv_options *opt, double *B, sv_stats *stats,
             rad_error *err)
{
    sv_stats local;
    sv_stats *st = stats ? stats : &local;
    memset(st, 0, sizeof *st);
    static const sv_options defaults;
    const sv_options *o = opt ? opt : &defaults;

    int rc = sv_check_system(sys, err);
    if (rc)
        return rc;
    if (!B)
        return rad_fail(err, RAD_ERR_USAGE, "solver: no output array for B");
    double tol = o->tolerance;
    if (tol == 0.0)
        tol = SV_DEFAULT_TOLERANCE;
    if (!(tol > 0.0))
        return rad_fail(err, RAD_ERR_USAGE, "solver: tolerance %g is not positive", o->tolerance);

    switch (o->method) {
    case SV_GAUSS_SEIDEL:
    case SV_JACOBI:
        rc = solve_sweeps(sys, o, tol, B, st, err);
        break;
    case SV_PROGRESSIVE:
        rc = sv_solve_progressive(sys, o, tol, B, st, err);
        break;
    default:
        return rad_fail(err, RAD_ERR_USAGE, "solver: unknown method %d", (int)o->method);
    }
    if (rc)
        return rc;

    const size_t len = (size_t)sys->n * sys->bands;
    for (size_t x = 0; x < len; x++)
        if (!isfinite(B[x]))
            return rad_fail(err, RAD_ERR_INVALID,
                            "solver: patch %zu band %zu: radiosity overflowed (emission too large)",
                            x / sys->bands, x % sys->bands);
#if RAD_DEBUG
    /* Every update adds ρ_i H_i + τ_i H_twin(i) >= 0 to E_i: anything else is a bug. */
    for (size_t x = 0; x < len; x++)
        RAD_ASSERT(B[x] >= sys->emission[x] && B[x] >= 0.0);
#endif
    /* need_rows may have left rows that no shot checked: the progressive
     * residual guards its indices itself, and leaves out the patches whose
     * rows are missing (dropped, or never computed by a solve stopped
     * early), counted in unchecked. */
    const int prog = o->method == SV_PROGRESSIVE;
    st->residual = sv_residual_of(sys, B, prog, prog, &st->unchecked);
    return RAD_OK;
}

/* ------------------------------------------------------------------ names */

const char *sv_method_name(sv_method m)
{
    switch (m) {
    case SV_GAUSS_SEIDEL: return "gauss-seidel";
    case SV_JACOBI: return "jacobi";
    case SV_PROGRESSIVE: return "progressive";
    }
    return "unknown";
}

int sv_method_parse(const char *name, sv_method *m)
{
    static const sv_method all[] = {SV_GAUSS_SEIDEL, SV_JACOBI, SV_PROGRESSIVE};
    if (!name || !m)
        return -1;
    for (size_t k = 0; k < sizeof all / sizeof all[0]; k++)
        if (strcmp(name, sv_method_name(all[k])) == 0) {
            *m = all[k];
            return 0;
        }
    return -1;
}
