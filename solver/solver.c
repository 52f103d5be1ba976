/* solver.c - solves B_i = E_i + ρ_i Σ_j F_ij B_j (+ τ_i Σ_j F_twin(i),j B_j
 * where a sheet transmits), every band at once (solver.h).
 *
 * Owns the validation of a system, the gather of one patch (shared with the
 * progressive method in progressive.c), the residual, the two sweeping
 * methods (Gauss-Seidel gathering, the Jacobi/Neumann series) with their
 * stopping rule and Aitken acceleration, and sv_solve.  It reads F only
 * through the rad_matrix rows and never sees GL or files.
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
int sv_check_row(const rad_matrix *F, uint32_t i, double *sum, rad_error *err)
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

/* solver.h: for i's own reflection, or for its twin's transmission. */
int sv_row_needed(const sv_system *s, uint32_t i)
{
    if (sv_any_positive(s->rho + (size_t)i * s->bands, s->bands))
        return 1;
    return s->tau && s->twin[i] != RAD_NONE && sv_transmits_from(s, s->twin[i]) != RAD_NONE;
}

/* sv_internal.h: E_i + ρ_i H_i + τ_i H_twin(i). */
void sv_update(const sv_system *s, uint32_t i, const double *B, double *nv)
{
    const uint32_t nb = s->bands;
    const size_t o = (size_t)i * nb;
    const double *E = s->emission + o, *rho = s->rho + o;
    double g[RAD_MAX_BANDS];
    if (sv_any_positive(rho, nb)) {
        gather(s->F, i, B, nb, g);
        for (uint32_t b = 0; b < nb; b++)
            nv[b] = E[b] + rho[b] * g[b];
    } else {
        memcpy(nv, E, nb * sizeof *nv);
    }
    uint32_t t = sv_transmits_from(s, i);
    if (t != RAD_NONE) {
        gather(s->F, t, B, nb, g);
        for (uint32_t b = 0; b < nb; b++)
            nv[b] += s->tau[o + b] * g[b];
    }
}

/* --------------------------------------------------------------- residual */

/* sv_internal.h: max |E_i + ρ_i Σ F_ij B_j - B_i| / max B over the
 * patches that gather (over all when none does).  A patch that needs no
 * row (neither reflects nor transmits) has update = E exactly and is
 * checked too. */
double sv_residual_of(const sv_system *s, const double *B, int skip_missing, int check_rows,
                      uint32_t *unchecked)
{
    const uint32_t nb = s->bands;
    double num = 0.0, ball = 0.0, bgather = 0.0, g[RAD_MAX_BANDS];
    uint32_t skipped = 0;
    for (uint32_t i = 0; i < s->n; i++) {
        const double *Bi = B + (size_t)i * nb;
        const int gathers = sv_gathers(s, i);
        for (uint32_t b = 0; b < nb; b++) {
            ball = Bi[b] > ball ? Bi[b] : ball;
            bgather = gathers && Bi[b] > bgather ? Bi[b] : bgather;
        }
        uint32_t t = sv_transmits_from(s, i);
        const int reflects = sv_any_positive(s->rho + (size_t)i * nb, nb);
        if (skip_missing && ((reflects && !sv_row_present(s->F, i)) ||
                             (t != RAD_NONE && !sv_row_present(s->F, t)))) {
            skipped++;
            continue;
        }
        if (check_rows && ((sv_row_present(s->F, i) && sv_check_row(s->F, i, NULL, NULL) != RAD_OK) ||
                           (t != RAD_NONE && sv_row_present(s->F, t) &&
                            sv_check_row(s->F, t, NULL, NULL) != RAD_OK)))
            return NAN;
        sv_update(s, i, B, g);
        for (uint32_t b = 0; b < nb; b++) {
            double r = fabs(g[b] - Bi[b]);
            if (!(r <= num)) /* also lets a NaN through */
                num = r;
        }
    }
    if (unchecked)
        *unchecked = skipped;
    if (isnan(num))
        return NAN;
    const double scale = bgather > 0.0 ? bgather : ball;
    if (scale > 0.0)
        return num / scale;
    return num == 0.0 ? 0.0 : INFINITY;
}

double sv_residual(const sv_system *sys, const double *B)
{
    if (!B || check_system(sys, NULL) != RAD_OK)
        return NAN;
    return sv_residual_of(sys, B, 0, 1, NULL);
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
