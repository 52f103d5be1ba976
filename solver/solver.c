/* solver.c - solves B_i = E_i + ρ_i Σ_j F_ij B_j (+ τ_i Σ_j F_twin(i),j B_j
 * where a sheet transmits), every band at once (solver.h).
 *
 * Owns the three methods (Gauss-Seidel gathering, the Jacobi/Neumann series,
 * progressive shooting), their common stopping rule and the Aitken
 * acceleration of the two sweeping methods.  It reads F only through the
 * rad_matrix rows and never sees GL or files.
 *
 * Invariant: the B handed back always comes out of a full sweep or a shot,
 * never straight out of an extrapolation, so B_i >= E_i >= 0 holds exactly in
 * floating point (every update adds a non-negative ρ_i H_i + τ_i H_twin(i) to E_i) and
 * the stopping rule has looked at the result it returns.
 */
#include "solver.h"

#include <stdlib.h>
#include <string.h>

#define SV_DEFAULT_SWEEPS 10000u
#define SV_DEFAULT_SHOTS_PER_PATCH 100u
/* rad.h allows rows to sum to 1 + 1e-3 (hemi-cube rounding); more is not a form-factor row. */
#define SV_ROW_SUM_MAX (1.0 + 1e-3)

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

/* ------------------------------------------------------------- validation */

/* The scalar parts of the system: counts, arrays, A_i, ρ_i, E_i.  Cheap
 * (n × bands) and done before anything is allocated. */
static int check_system(const sv_system *s, rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "solver: no system given");
    if (s->n == 0)
        return rad_fail(err, RAD_ERR_USAGE, "solver: the system has no patches");
    if (s->bands < 1 || s->bands > RAD_MAX_BANDS)
        return rad_fail(err, RAD_ERR_USAGE, "solver: %u bands (must be 1..%d)", s->bands,
                        RAD_MAX_BANDS);
    if (!s->F || !s->area || !s->rho || !s->emission)
        return rad_fail(err, RAD_ERR_USAGE, "solver: the system lacks %s",
                        !s->F      ? "its form-factor matrix"
                        : !s->area ? "its areas"
                        : !s->rho  ? "its reflectances"
                                   : "its emissions");
    const rad_matrix *F = s->F;
    if (F->n != s->n)
        return rad_fail(err, RAD_ERR_USAGE,
                        "solver: the form-factor matrix has %u rows but the system %u patches",
                        F->n, s->n);
    if (!F->row_done || !F->row_start || !F->row_count || F->bytes > F->capacity ||
        (F->nnz && !F->data))
        return rad_fail(err, RAD_ERR_USAGE, "solver: the form-factor matrix is malformed");
    if (!F->entries_loaded)
        return rad_fail(err, RAD_ERR_USAGE,
                        "solver: the form-factor matrix holds row counts only (read without F)");
    if ((uint64_t)s->n * s->bands > SIZE_MAX / (2 * sizeof(double)))
        return rad_fail(err, RAD_ERR_LIMIT, "solver: %u patches × %u bands do not fit in memory",
                        s->n, s->bands);

    const uint32_t nb = s->bands;
    for (uint32_t i = 0; i < s->n; i++) {
        double a = s->area[i];
        if (!(a > 0.0) || !isfinite(a))
            return rad_fail(err, RAD_ERR_INVALID, "solver: patch %u: area %.9g is not positive",
                            i, a);
        for (uint32_t b = 0; b < nb; b++) {
            double r = s->rho[(size_t)i * nb + b], e = s->emission[(size_t)i * nb + b];
            if (isnan(r))
                return rad_fail(err, RAD_ERR_INVALID,
                                "solver: patch %u band %u: reflectance is not a number", i, b);
            if (r < 0.0)
                return rad_fail(err, RAD_ERR_INVALID,
                                "solver: patch %u band %u: reflectance %.9g is negative", i, b, r);
            if (r >= 1.0)
                return rad_fail(err, RAD_ERR_INVALID,
                                "solver: patch %u band %u: reflectance %.9g is not below 1", i, b,
                                r);
            if (!isfinite(e))
                return rad_fail(err, RAD_ERR_INVALID,
                                "solver: patch %u band %u: emission %.9g is not finite", i, b, e);
            if (e < 0.0)
                return rad_fail(err, RAD_ERR_INVALID,
                                "solver: patch %u band %u: emission %.9g is negative", i, b, e);
        }
    }
    if (!s->tau != !s->twin)
        return rad_fail(err, RAD_ERR_USAGE, "solver: transmittances and twins go together");
    for (uint32_t i = 0; s->tau && i < s->n; i++) {
        uint32_t t = s->twin[i];
        if (t != RAD_NONE && (t >= s->n || t == i || s->twin[t] != i))
            return rad_fail(err, RAD_ERR_USAGE, "solver: patch %u: twin %u is not its pair", i, t);
        for (uint32_t b = 0; b < nb; b++) {
            double tau = s->tau[(size_t)i * nb + b], r = s->rho[(size_t)i * nb + b];
            if (!(tau >= 0.0) || !(r + tau < 1.0))
                return rad_fail(err, RAD_ERR_INVALID,
                                "solver: patch %u band %u: transmittance %.9g with reflectance "
                                "%.9g is not in [0, 1 - ρ)", i, b, tau, r);
            if (tau > 0.0 && t == RAD_NONE)
                return rad_fail(err, RAD_ERR_INVALID,
                                "solver: patch %u transmits but has no other side", i);
        }
    }
    return RAD_OK;
}

/* One present row against rad.h's invariants.  Indices are what keeps a bad
 * matrix from crashing us; F_ij > 0 and the row sum are what keep B >= 0 and
 * the iteration a contraction.  The row is walked with bounds on the pool,
 * so that the gathers may then walk it without.  *sum receives Σ_j F_ij. */
static int check_row(const rad_matrix *F, uint32_t i, double *sum, rad_error *err)
{
    uint64_t start = F->row_start[i];
    uint32_t count = F->row_count[i];
    if (count == 0) { /* an empty row may have no pool behind it */
        if (sum)
            *sum = 0.0;
        return RAD_OK;
    }
    if (start > F->bytes || (uint64_t)count * 5 > F->bytes - start)
        return rad_fail(err, RAD_ERR_USAGE, "solver: form-factor row %u: entries out of range", i);
    const rad_row r = rad_matrix_row(F, i);
    const uint8_t *p = r.col, *end = F->data + F->bytes;
    double s = 0.0;
    uint64_t j = 0;
    for (uint32_t k = 0; k < count; k++) {
        uint64_t d = 0;
        for (int shift = 0;; shift += 7) {
            if (p >= end || shift > 28)
                return rad_fail(err, RAD_ERR_USAGE, "solver: form-factor row %u: bad column", i);
            d |= (uint64_t)(*p & 0x7f) << shift;
            if (!(*p++ & 0x80))
                break;
        }
        j = k ? j + d : d;
        if (j >= F->n || j == i || (k > 0 && d == 0))
            return rad_fail(err, RAD_ERR_USAGE, "solver: form-factor row %u: bad column %llu", i,
                            (unsigned long long)j);
        float v = rad_row_value(&r, k);
        if (!(v > 0.0f) || !isfinite(v))
            return rad_fail(err, RAD_ERR_USAGE, "solver: form-factor row %u: F_%u,%llu = %g", i, i,
                            (unsigned long long)j, (double)v);
        s += v;
    }
    if (s > SV_ROW_SUM_MAX)
        return rad_fail(err, RAD_ERR_USAGE, "solver: form-factor row %u: Σ_j F_ij = %.6f exceeds 1",
                        i, s);
    if (sum)
        *sum = s;
    return RAD_OK;
}

static int row_present(const rad_matrix *F, uint32_t i) { return F->row_done[i] != 0; }

/* ----------------------------------------------------------------- gather */

/* s_b = Σ_j F_ij B_j,b for every band, walking the row's packed values and
 * column gaps once (rad.h: decoding the gaps on the fly costs less than
 * reading 4-byte columns from memory would).  The band counts that matter
 * get their own loop so that the compiler keeps the partial sums in
 * registers; two partial sums hide some latency of the floating-point adds
 * (the sum order differs from a naive loop only by rounding). */
static void gather1(const rad_row *r, const double *B, double *s)
{
    double a0 = 0.0, a1 = 0.0;
    const uint8_t *p = r->col;
    uint32_t j = 0, k = 0;
    for (; k + 2 <= r->count; k += 2) {
        j = rad_row_next(&p, j);
        a0 += rad_row_value(r, k) * B[j];
        j = rad_row_next(&p, j);
        a1 += rad_row_value(r, k + 1) * B[j];
    }
    if (k < r->count) {
        j = rad_row_next(&p, j);
        a0 += rad_row_value(r, k) * B[j];
    }
    s[0] = a0 + a1;
}

static void gather3(const rad_row *r, const double *B, double *s)
{
    double a0 = 0.0, a1 = 0.0, a2 = 0.0, b0 = 0.0, b1 = 0.0, b2 = 0.0;
    const uint8_t *p = r->col;
    uint32_t j = 0, k = 0;
    for (; k + 2 <= r->count; k += 2) {
        j = rad_row_next(&p, j);
        const double *x = B + 3 * (size_t)j;
        j = rad_row_next(&p, j);
        const double *y = B + 3 * (size_t)j;
        double f = rad_row_value(r, k), g = rad_row_value(r, k + 1);
        a0 += f * x[0];
        a1 += f * x[1];
        a2 += f * x[2];
        b0 += g * y[0];
        b1 += g * y[1];
        b2 += g * y[2];
    }
    if (k < r->count) {
        j = rad_row_next(&p, j);
        const double *x = B + 3 * (size_t)j;
        double f = rad_row_value(r, k);
        a0 += f * x[0];
        a1 += f * x[1];
        a2 += f * x[2];
    }
    s[0] = a0 + b0;
    s[1] = a1 + b1;
    s[2] = a2 + b2;
}

static void gathern(const rad_row *r, const double *B, uint32_t nb, double *s)
{
    double acc[RAD_MAX_BANDS] = {0};
    const uint8_t *p = r->col;
    uint32_t j = 0;
    for (uint32_t k = 0; k < r->count; k++) {
        j = rad_row_next(&p, j);
        const double *x = B + (size_t)nb * j;
        double f = rad_row_value(r, k);
        for (uint32_t b = 0; b < nb; b++)
            acc[b] += f * x[b];
    }
    for (uint32_t b = 0; b < nb; b++)
        s[b] = acc[b];
}

/* A missing row counts as empty: the pipeline leaves out only rows of
 * patches with ρ = 0, whose B = E needs no gathering. */
static void gather(const rad_matrix *F, uint32_t i, const double *B, uint32_t nb, double *s)
{
    const rad_row r = rad_matrix_row(F, i);
    if (r.count == 0) {
        for (uint32_t b = 0; b < nb; b++)
            s[b] = 0.0;
        return;
    }
    if (nb == 1)
        gather1(&r, B, s);
    else if (nb == 3)
        gather3(&r, B, s);
    else
        gathern(&r, B, nb, s);
}

static int reflects(const double *rho_i, uint32_t nb)
{
    for (uint32_t b = 0; b < nb; b++)
        if (rho_i[b] > 0.0)
            return 1;
    return 0;
}

/* The other side of patch i when light passes through it to i, else RAD_NONE. */
static uint32_t transmits_from(const sv_system *s, uint32_t i)
{
    if (!s->tau || s->twin[i] == RAD_NONE)
        return RAD_NONE;
    return reflects(s->tau + (size_t)i * s->bands, s->bands) ? s->twin[i] : RAD_NONE;
}

/* solver.h: for i's own reflection, or for its twin's transmission. */
int sv_row_needed(const sv_system *s, uint32_t i)
{
    if (reflects(s->rho + (size_t)i * s->bands, s->bands))
        return 1;
    return s->tau && s->twin[i] != RAD_NONE && transmits_from(s, s->twin[i]) != RAD_NONE;
}

/* B_i's new value per band into nv: E_i + ρ_i H_i + τ_i H_twin(i). */
static void update(const sv_system *s, uint32_t i, const double *B, double *nv)
{
    const uint32_t nb = s->bands;
    const size_t o = (size_t)i * nb;
    const double *E = s->emission + o, *rho = s->rho + o;
    double g[RAD_MAX_BANDS];
    if (reflects(rho, nb)) {
        gather(s->F, i, B, nb, g);
        for (uint32_t b = 0; b < nb; b++)
            nv[b] = E[b] + rho[b] * g[b];
    } else {
        memcpy(nv, E, nb * sizeof *nv);
    }
    uint32_t t = transmits_from(s, i);
    if (t != RAD_NONE) {
        gather(s->F, t, B, nb, g);
        for (uint32_t b = 0; b < nb; b++)
            nv[b] += s->tau[o + b] * g[b];
    }
}

/* --------------------------------------------------------------- residual */

/* max |E_i + ρ_i Σ F_ij B_j - B_i| / max B.  skip_missing leaves out patches
 * whose row is missing (the progressive solver never needed them, so their
 * row is unknown rather than empty).  check_rows guards indices for callers
 * that have not validated the matrix; a bad row gives NaN. */
static double residual(const sv_system *s, const double *B, int skip_missing, int check_rows)
{
    const uint32_t nb = s->bands;
    double num = 0.0, bmax = 0.0, g[RAD_MAX_BANDS];
    for (uint32_t i = 0; i < s->n; i++) {
        const double *Bi = B + (size_t)i * nb;
        for (uint32_t b = 0; b < nb; b++)
            if (Bi[b] > bmax)
                bmax = Bi[b];
        uint32_t t = transmits_from(s, i);
        if ((!row_present(s->F, i) || (t != RAD_NONE && !row_present(s->F, t))) && skip_missing)
            continue;
        if (check_rows && ((row_present(s->F, i) && check_row(s->F, i, NULL, NULL) != RAD_OK) ||
                           (t != RAD_NONE && row_present(s->F, t) &&
                            check_row(s->F, t, NULL, NULL) != RAD_OK)))
            return NAN;
        update(s, i, B, g);
        for (uint32_t b = 0; b < nb; b++) {
            double r = fabs(g[b] - Bi[b]);
            if (!(r <= num)) /* also lets a NaN through */
                num = r;
        }
    }
    if (isnan(num))
        return NAN;
    if (bmax > 0.0)
        return num / bmax;
    return num == 0.0 ? 0.0 : INFINITY;
}

double sv_residual(const sv_system *sys, const double *B)
{
    if (!B || check_system(sys, NULL) != RAD_OK)
        return NAN;
    return residual(sys, B, 0, 1);
}

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
 * either is zero), and *rmax max (B − E), the largest reflected radiosity.
 * Returns max B. */
static double sweep(const sv_system *s, const double *src, double *dst, double *D, double *dmax,
                    double *cosine, double *rmax)
{
    const uint32_t nb = s->bands;
    double bmax = 0.0, g[RAD_MAX_BANDS];
    *rmax = 0.0;
    double dot[RAD_MAX_BANDS], now[RAD_MAX_BANDS], before[RAD_MAX_BANDS];
    for (uint32_t b = 0; b < nb; b++)
        dmax[b] = dot[b] = now[b] = before[b] = 0.0;
    for (uint32_t i = 0; i < s->n; i++) {
        const size_t o = (size_t)i * nb;
        update(s, i, src, g);
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
            if (!(nv <= bmax)) /* NaN or overflow propagates to the caller's check */
                bmax = nv;
            if (nv - s->emission[o + b] > *rmax)
                *rmax = nv - s->emission[o + b];
        }
    }
    for (uint32_t b = 0; b < nb; b++)
        cosine[b] = now[b] > 0.0 && before[b] > 0.0 ? dot[b] / sqrt(now[b] * before[b]) : 0.0;
    return bmax;
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
        if (!row_present(s->F, i))
            continue;
        int rc = check_row(s->F, i, &sum[i], err);
        if (rc) {
            free(sum);
            return rc;
        }
    }
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = transmits_from(s, i);
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
        double rmax, bmax = sweep(s, cur, nxt, D, dmax, cosine, &rmax);
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

        /* The stopping rule: δ = max|ΔB| / max (B − E), remaining error ≈
         * δ·q/(1-q).  Relative to the light the solve computes, not to the
         * emitters' own E: a lamp a hundred times brighter than the walls
         * would otherwise let the walls stop a per cent short (a closed
         * room then absorbed 0.9 % less than it emitted). */
        const double scale = rmax > 0.0 ? rmax : bmax;
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
            double eb = q < 1.0 ? dmax[b] / scale * q / (1.0 - q) : INFINITY;
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

        /* Aitken on the dominant mode: once ΔB_k = q ΔB_k-1, the rest of the
         * geometric series is ΔB_k·q/(1-q).  Clamping at E only moves a value
         * toward the solution (B* >= E), and restores B >= 0 for the next
         * Gauss-Seidel sweep to gather from. */
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
    if (rc == RAD_OK && cur != B)
        memcpy(B, cur, len * sizeof *B);
    free(D);
    free(other);
    return rc;
}

/* ------------------------------------------------------------ progressive */

/* Column access to F: for each i, the pairs (j, F_ji) of the rows present,
 * j increasing.  Built once per progressive solve that has every row it
 * needs. */
typedef struct transpose {
    uint64_t *start; /* n + 1 */
    uint32_t *col;   /* j */
    float *val;      /* F_ji */
} transpose;

static void transpose_free(transpose *T)
{
    free(T->start);
    free(T->col);
    free(T->val);
}

static int transpose_build(const rad_matrix *F, transpose *T, rad_error *err)
{
    const uint32_t n = F->n;
    uint64_t total = 0;
    T->start = calloc((size_t)n + 1, sizeof *T->start);
    if (!T->start)
        return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for the transposed matrix");
    for (uint32_t j = 0; j < n; j++) {
        const rad_row r = rad_matrix_row(F, j);
        const uint8_t *p = r.col;
        uint32_t c = 0;
        for (uint32_t k = 0; k < r.count; k++) {
            c = rad_row_next(&p, c);
            T->start[c + 1]++;
        }
        total += r.count;
    }
    for (uint32_t i = 0; i < n; i++)
        T->start[i + 1] += T->start[i];
    T->col = malloc((size_t)(total ? total : 1) * sizeof *T->col);
    T->val = malloc((size_t)(total ? total : 1) * sizeof *T->val);
    uint64_t *fill = malloc(((size_t)n + 1) * sizeof *fill);
    if (!T->col || !T->val || !fill) {
        free(fill);
        return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for the transposed matrix");
    }
    memcpy(fill, T->start, ((size_t)n + 1) * sizeof *fill);
    for (uint32_t j = 0; j < n; j++) { /* j increasing, so each column comes out sorted */
        const rad_row r = rad_matrix_row(F, j);
        const uint8_t *p = r.col;
        uint32_t c = 0;
        for (uint32_t k = 0; k < r.count; k++) {
            c = rad_row_next(&p, c);
            uint64_t at = fill[c]++;
            T->col[at] = j;
            T->val[at] = rad_row_value(&r, k);
        }
    }
    free(fill);
    return RAD_OK;
}

/* Σ_i A_i ΔB_i,b per band, summed afresh. */
static void unshot_power(const double *U, const double *A, uint32_t n, uint32_t nb, double *out)
{
    for (uint32_t b = 0; b < nb; b++)
        out[b] = 0.0;
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t b = 0; b < nb; b++)
            out[b] += A[i] * U[(size_t)i * nb + b];
}

/* Unshot power relative to emitted power, the worst band.  A band that emits
 * nothing never holds unshot power and is left out. */
static double unshot_fraction(const double *unshot, const double *emitted, uint32_t nb)
{
    double e = 0.0;
    for (uint32_t b = 0; b < nb; b++)
        if (emitted[b] > 0.0 && unshot[b] / emitted[b] > e)
            e = unshot[b] / emitted[b];
    return e;
}

/* Shooting (Cohen, Chen, Wallace & Greenberg 1988).  U holds the unshot
 * radiosity ΔB; each shot sends A_i ΔB_i from the patch with the most unshot
 * power to every patch j, which receives ρ_j F_ji ΔB_i.
 *
 * Where F_ji comes from: when every reflecting patch already has its row
 * (a relight, or a comparison with the gathering solvers), F_ji is read
 * from j's own row through a transposed copy, so shooting solves exactly
 * the system Gauss-Seidel and Jacobi solve.  Otherwise rows come on demand
 * and reciprocity turns the shooter's row into what j gathers,
 * F_ji = F_ij A_i / A_j, asking for row i only when i first shoots; the
 * hemi-cube's rows are reciprocal only to a few per cent, so the two
 * routes differ by that much.
 *
 * power[i] = A_i Σ_b ΔB_i,b and the per-band unshot totals are kept up to
 * date shot by shot, so choosing the shooter reads n values rather than
 * n × bands.  The totals drift by rounding only (~1e-16 per shot against a
 * tolerance of ~1e-4); they are summed afresh before any decision to stop
 * and for every preview. */
static int solve_progressive(const sv_system *s, const sv_options *o, double tol, double *B,
                             sv_stats *st, rad_error *err)
{
    const uint32_t n = s->n, nb = s->bands;
    const size_t len = (size_t)n * nb;
    const double *A = s->area, *rho = s->rho, *E = s->emission;
    rad_matrix *F = s->F;

    uint64_t shots_default = (uint64_t)SV_DEFAULT_SHOTS_PER_PATCH * n;
    const uint32_t max_shots = o->max_iterations ? o->max_iterations
                               : shots_default > UINT32_MAX ? UINT32_MAX
                                                            : (uint32_t)shots_default;
    /* preview_every = 0 with a callback: every shot (the caller asked for previews) */
    const uint32_t every = o->preview_every ? o->preview_every : 1;

    double *U = malloc(len * sizeof *U);
    double *power = malloc((size_t)n * sizeof *power);
    double *inv_area = malloc((size_t)n * sizeof *inv_area);
    uint8_t *checked = calloc(n, 1);
    double *display = o->on_preview ? malloc(len * sizeof *display) : NULL;
    uint32_t *row_col = malloc((size_t)n * sizeof *row_col);
    float *row_val = malloc((size_t)n * sizeof *row_val);
    transpose T = {0};
    int rc = RAD_OK;
    if (!U || !power || !inv_area || !checked || (o->on_preview && !display) || !row_col ||
        !row_val) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for %u patches", n);
        goto done;
    }
    memcpy(B, E, len * sizeof *B);
    memcpy(U, E, len * sizeof *U);
    /* Rows present now are checked now; rows need_row brings are checked
     * before their first shot. */
    for (uint32_t i = 0; i < n; i++) {
        if (!row_present(F, i))
            continue;
        rc = check_row(F, i, NULL, err);
        if (rc)
            goto done;
        checked[i] = 1;
    }
    int gather_rows = 1;
    for (uint32_t i = 0; i < n && gather_rows; i++)
        if (!row_present(F, i) && sv_row_needed(s, i))
            gather_rows = 0;
    if (gather_rows && (rc = transpose_build(F, &T, err)) != RAD_OK)
        goto done;

    /* Emitted power per band, and the ambient's interreflection factor
     * R_b = 1/(1 - ρ_avg,b) with ρ_avg area-weighted (finite: every ρ < 1). */
    double area_sum = 0.0, emitted[RAD_MAX_BANDS] = {0}, rho_avg[RAD_MAX_BANDS] = {0};
    for (uint32_t i = 0; i < n; i++) {
        inv_area[i] = 1.0 / A[i];
        area_sum += A[i];
        power[i] = 0.0;
        for (uint32_t b = 0; b < nb; b++) {
            /* what a sheet passes on is re-emitted too, on its other side */
            double albedo = rho[(size_t)i * nb + b] + (s->tau ? s->tau[(size_t)i * nb + b] : 0.0);
            emitted[b] += A[i] * E[(size_t)i * nb + b];
            rho_avg[b] += A[i] * albedo;
            power[i] += E[(size_t)i * nb + b];
        }
        power[i] *= A[i];
    }
    double R[RAD_MAX_BANDS], unshot[RAD_MAX_BANDS];
    for (uint32_t b = 0; b < nb; b++) {
        rho_avg[b] /= area_sum;
        R[b] = 1.0 / (1.0 - rho_avg[b]);
        unshot[b] = emitted[b];
    }

    uint32_t shots = 0;
    for (;;) {
        double e = unshot_fraction(unshot, emitted, nb);
        if (display && shots > 0 && shots % every == 0) {
            /* Cohen et al. 1988: the unshot power, spread evenly and
             * interreflected with the average ρ, as an ambient term. */
            unshot_power(U, A, n, nb, unshot);
            e = unshot_fraction(unshot, emitted, nb);
            double ambient[RAD_MAX_BANDS];
            for (uint32_t b = 0; b < nb; b++)
                ambient[b] = R[b] * unshot[b] / area_sum;
            for (size_t x = 0; x < len; x++)
                display[x] = B[x] + rho[x] * ambient[x % nb];
            st->iterations = shots;
            if (o->on_preview(o->user, shots, display))
                break;
        }
        if (e < tol) {
            unshot_power(U, A, n, nb, unshot);
            e = unshot_fraction(unshot, emitted, nb);
            if (e < tol) {
                st->converged = 1;
                break;
            }
        }
        if (shots >= max_shots)
            break;

        uint32_t best = RAD_NONE;
        double best_power = 0.0;
        for (uint32_t i = 0; i < n; i++)
            if (power[i] > best_power) { /* strict: the lowest index wins a tie */
                best_power = power[i];
                best = i;
            }
        if (best == RAD_NONE) { /* nothing left to shoot: exact */
            st->converged = 1;
            break;
        }

        if (!gather_rows && !row_present(F, best)) {
            if (!o->need_row) {
                rc = rad_fail(err, RAD_ERR_USAGE,
                              "solver: form-factor row %u is missing and no need_row was given",
                              best);
                break;
            }
            rad_error cb = {0};
            st->rows_requested++;
            rc = o->need_row(o->user, best, &cb);
            if (rc != RAD_OK) {
                if (!cb.message[0])
                    rad_fail(&cb, rc, "solver: computing form-factor row %u failed", best);
                if (err)
                    *err = cb;
                break;
            }
            if (!row_present(F, best)) {
                rc = rad_fail(err, RAD_ERR_USAGE, "solver: need_row did not fill row %u", best);
                break;
            }
        }
        if (!gather_rows && !checked[best]) {
            rc = check_row(F, best, NULL, err);
            if (rc)
                break;
            checked[best] = 1;
        }

        /* need_row may have grown F's pool: read the row only now.
         * The weight of receiver j is F_ji A_j / A_i: from j's own row via
         * the transpose, or F_ij from i's row by reciprocity (decoded into
         * row_col/row_val). */
        const uint32_t count = gather_rows ? (uint32_t)(T.start[best + 1] - T.start[best])
                                           : rad_matrix_get_row(F, best, row_col, row_val);
        const uint32_t *c = !count ? NULL : gather_rows ? T.col + T.start[best] : row_col;
        const float *v = !count ? NULL : gather_rows ? T.val + T.start[best] : row_val;
        double *Ui = U + (size_t)best * nb;
        double shot[RAD_MAX_BANDS], landed[RAD_MAX_BANDS] = {0};
        for (uint32_t b = 0; b < nb; b++) {
            shot[b] = A[best] * Ui[b];
            unshot[b] -= shot[b];
            Ui[b] = 0.0;
        }
        power[best] = 0.0;
        for (uint32_t k = 0; k < count; k++) {
            const uint32_t j = c[k];
            const double f = gather_rows ? v[k] * A[j] * inv_area[best] : v[k];
            /* The irradiance ΔH_j = shot·f / A_j landing on j comes out of j
             * (ρ_j ΔH_j) and, through a sheet, out of its other side t
             * (τ_t ΔH_j). */
            const uint32_t t = s->tau && s->twin[j] != RAD_NONE ? s->twin[j] : RAD_NONE;
            for (int side = 0; side < (t == RAD_NONE ? 1 : 2); side++) {
                const uint32_t r = side ? t : j;
                const double *gain = side ? s->tau : rho;
                const size_t o = (size_t)r * nb;
                const double inv = inv_area[j];
                double pr = 0.0;
                for (uint32_t b = 0; b < nb; b++) {
                    const double d = gain[o + b] * shot[b] * f * inv; /* ΔB_r */
                    const double w = d * A[r];                       /* A_r ΔB_r: power r re-emits */
                    B[o + b] += d;
                    U[o + b] += d;
                    landed[b] += w;
                    pr += w;
                }
                power[r] += pr;
            }
        }
        for (uint32_t b = 0; b < nb; b++)
            unshot[b] += landed[b];
        shots++;
    }
    st->iterations = shots;
    if (rc == RAD_OK) {
        unshot_power(U, A, n, nb, unshot);
        st->estimated_error = unshot_fraction(unshot, emitted, nb);
    }
done:
    free(U);
    free(power);
    free(inv_area);
    free(checked);
    free(display);
    free(row_col);
    free(row_val);
    transpose_free(&T);
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

    int rc = check_system(sys, err);
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
        rc = solve_progressive(sys, o, tol, B, st, err);
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
    /* need_row may have left rows that no shot checked: the progressive
     * residual guards its indices itself. */
    st->residual = residual(sys, B, o->method == SV_PROGRESSIVE, o->method == SV_PROGRESSIVE);
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
