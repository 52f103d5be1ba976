/* system.c - the radiosity system of solver.h as every method reads it:
 * its validation (counts, A_i, ρ_i, E_i, and each row F_ij against rad.h's
 * invariants), the gather of one patch, H_i = Σ_j F_ij B_j, the update
 * B_i = E_i + ρ_i H_i + τ_i H_twin(i), and the residual.  The sweeping
 * methods (solver.c) and the progressive method (progressive.c) both stand
 * on it; it calls neither.
 *
 * Invariant: F is read only through rows sv_check_row has accepted (or that
 * sv_residual_of checks itself), so a bad matrix is an error, never a
 * crash; an update adds only non-negative terms to E_i, so B_i >= E_i >= 0.
 */
#include "sv_internal.h"

#include <stdlib.h>
#include <string.h>

/* rad.h allows rows to sum to 1 + 1e-3 (hemi-cube rounding); more is not a form-factor row. */
#define SV_ROW_SUM_MAX (1.0 + 1e-3)

/* ------------------------------------------------------------- validation */

/* The scalar parts of the system: counts, arrays, A_i, ρ_i, E_i.  Cheap
 * (n × bands) and done before anything is allocated. */
int sv_check_system(const sv_system *s, rad_error *err)
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
    if (rad_any_positive(s->rho + (size_t)i * s->bands, s->bands))
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
    if (rad_any_positive(rho, nb)) {
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
        const int reflects = rad_any_positive(s->rho + (size_t)i * nb, nb);
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
    if (!B || sv_check_system(sys, NULL) != RAD_OK)
        return NAN;
    return sv_residual_of(sys, B, 0, 1, NULL);
}
