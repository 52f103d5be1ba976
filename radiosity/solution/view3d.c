/* view3d.c - View3D's surface-to-surface factors from a solution of a .vs3
 * scene (docs/view3d.md): the object factors turned into the surfaces
 * View3D reports, with its post-processing.
 *
 *   1. exchange areas AF_ij = (A_i F_ij + A_j F_ji) / 2 between the
 *      surfaces' objects: symmetric, so reciprocity holds exactly;
 *   2. a mask M over base b: AF_Mb = A_M, nothing else; b keeps its whole
 *      area (its covered part sees only the mask);
 *   3. obstructions (O) and null surfaces (N) are dropped (a null surface's
 *      area was already cut out of its base by the reader);
 *   4. surfaces combined with a primary are summed into it: areas, AF rows
 *      and columns; ε area-weighted;
 *   5. encl = 1: every row scaled to sum 1 by the symmetric scaling
 *      AF_ij <- d_i AF_ij d_j (so reciprocity still holds exactly);
 *   6. emit = 1: Hottel's script-F, from radiosity solves with each surface
 *      in turn a unit emitter, ρ = 1 − ε (the solver module).
 * Invariant: AF symmetric and >= 0 throughout; with encl = 1 every row
 * that saw anything sums to 1 within 1e-12.
 */
#include "solution.h"

#include "../../solver/solver.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void rad_vs3_factors_destroy(rad_vs3_factors *f)
{
    if (!f)
        return;
    free(f->surface);
    free(f->area);
    free(f->emittance);
    free(f->F);
    free(f);
}

/* Steps 1 and 2: surface-level exchange areas AF (m×m) and areas a. */
static int surface_exchange(const rad_solution *s, const rad_vs3 *m, double *AF, double *a,
                            rad_error *err)
{
    uint32_t no = s->scene->object_count, ns = m->surface_count;
    double *M = malloc((size_t)no * no * sizeof *M);
    rad_object_stats *st = calloc(no, sizeof *st);
    int rc = (!M || !st) ? rad_fail(err, RAD_ERR_NOMEM, "view3d: out of memory") : RAD_OK;
    if (!rc)
        rc = rad_object_form_factors(s, M, err);
    if (!rc)
        rc = rad_solution_object_stats(s, st, err);
    for (uint32_t i = 0; !rc && i < ns; i++) {
        uint32_t oi = m->surfaces[i].object;
        a[i] = st[oi].area;
        for (uint32_t j = 0; j < ns; j++) {
            uint32_t oj = m->surfaces[j].object;
            AF[(size_t)i * ns + j] =
                0.5 * (st[oi].area * M[(size_t)oi * no + oj] + st[oj].area * M[(size_t)oj * no + oi]);
        }
    }
    free(M);
    free(st);
    for (uint32_t k = 0; !rc && k < ns; k++) {
        const rad_vs3_surface *S = &m->surfaces[k];
        if (S->kind != RAD_VS3_MASK)
            continue;
        for (uint32_t j = 0; j < ns; j++)
            AF[(size_t)k * ns + j] = AF[(size_t)j * ns + k] = 0.0;
        AF[(size_t)k * ns + S->base] = AF[(size_t)S->base * ns + k] = S->area;
        a[k] = S->area;
        a[S->base] += S->area;
    }
    return rc;
}

/* Steps 3 and 4: which reported surface each surface goes into (RAD_NONE:
 * none); returns how many are reported. */
static uint32_t map_reported(const rad_vs3 *m, uint32_t *to, uint32_t *primary)
{
    uint32_t n = 0;
    for (uint32_t i = 0; i < m->surface_count; i++) {
        const rad_vs3_surface *S = &m->surfaces[i];
        to[i] = RAD_NONE;
        if (S->kind == RAD_VS3_OBSTRUCTION || S->kind == RAD_VS3_NULL)
            continue;
        if (S->combine == RAD_NONE) {
            primary[n] = i;
            to[i] = n++;
        } else {
            to[i] = to[S->combine];
        }
    }
    return n;
}

/* Step 5: d_i <- d_i / sqrt(r_i), r_i the current row sum, until every
 * row sums to 1; rows that see nothing are left alone.  Returns the
 * largest |r_i − 1| before scaling. */
static double normalise_enclosure(double *AF, const double *a, uint32_t n)
{
    double *d = malloc((size_t)n * 2 * sizeof *d), before = 0.0;
    if (!d)
        return -1.0;
    double *r = d + n;
    for (uint32_t i = 0; i < n; i++)
        d[i] = 1.0;
    for (int it = 0; it < 10000; it++) {
        double worst = 0.0;
        for (uint32_t i = 0; i < n; i++) {
            double sum = 0.0;
            for (uint32_t j = 0; j < n; j++)
                sum += AF[(size_t)i * n + j] * d[j];
            r[i] = d[i] * sum / a[i];
            if (r[i] > 0)
                worst = fmax(worst, fabs(r[i] - 1.0));
        }
        if (it == 0)
            before = worst;
        if (worst < 1e-13)
            break;
        for (uint32_t i = 0; i < n; i++)
            if (r[i] > 0)
                d[i] /= sqrt(r[i]);
    }
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = 0; j < n; j++)
            AF[(size_t)i * n + j] *= d[i] * d[j];
    free(d);
    return before;
}

/* Step 6 for emitters e0 .. e0+nb-1, one band each: B = E + ρ F B with
 * E_k = ε_k where k is band b's emitter; then the power that surface j
 * absorbs, ε_j A_j H_j, over what emitter i would emit as a black body
 * (A_i · 1) is script-F_ij.  Writes rows e0 .. e0+nb-1 of SF. */
static int script_rows(const sv_system *sys, uint32_t e0, const double *F, const double *a,
                       const double *eps, double *emission, double *B, double *SF, rad_error *err)
{
    uint32_t n = sys->n, nb = sys->bands;
    memset(emission, 0, (size_t)n * nb * sizeof *emission);
    for (uint32_t b = 0; b < nb; b++)
        emission[(size_t)(e0 + b) * nb + b] = eps[e0 + b];
    sv_options o = {.method = SV_GAUSS_SEIDEL, .tolerance = 1e-12, .max_iterations = 1000000};
    int rc = sv_solve(sys, &o, B, NULL, err);
    for (uint32_t j = 0; !rc && j < n; j++)
        for (uint32_t b = 0; b < nb; b++) {
            double H = 0.0;
            for (uint32_t k = 0; k < n; k++)
                H += F[(size_t)j * n + k] * B[(size_t)k * nb + b];
            SF[(size_t)(e0 + b) * n + j] = eps[j] * a[j] * H / a[e0 + b];
        }
    return rc;
}

static int script_f(const double *F, const double *a, const double *eps, uint32_t n, double *SF,
                    rad_error *err)
{
    rad_matrix *Fm = rad_matrix_create(n);
    uint32_t *col = malloc((size_t)n * sizeof *col);
    float *val = malloc((size_t)n * sizeof *val);
    double *rho = malloc((size_t)n * RAD_MAX_BANDS * 3 * sizeof *rho);
    int rc = (!Fm || !col || !val || !rho) ? rad_fail(err, RAD_ERR_NOMEM, "view3d: out of memory")
                                           : RAD_OK;
    for (uint32_t i = 0; !rc && i < n; i++) {
        uint32_t c = 0;
        for (uint32_t j = 0; j < n; j++)
            if (F[(size_t)i * n + j] > 0) {
                col[c] = j;
                val[c++] = (float)F[(size_t)i * n + j];
            }
        rc = rad_matrix_set_row(Fm, i, c, col, val, err);
    }
    for (uint32_t e0 = 0; !rc && e0 < n; e0 += RAD_MAX_BANDS) {
        uint32_t nb = n - e0 < RAD_MAX_BANDS ? n - e0 : RAD_MAX_BANDS;
        double *emission = rho + (size_t)n * nb, *B = emission + (size_t)n * nb;
        for (uint32_t k = 0; k < n; k++)
            for (uint32_t b = 0; b < nb; b++)
                rho[(size_t)k * nb + b] = 1.0 - eps[k];
        sv_system sys = {.n = n, .bands = nb, .F = Fm, .area = a, .rho = rho,
                         .emission = emission};
        rc = script_rows(&sys, e0, F, a, eps, emission, B, SF, err);
    }
    rad_matrix_destroy(Fm);
    free(col);
    free(val);
    free(rho);
    return rc;
}

/* Steps 4 to 6 on the surface-level AF (ns×ns) and areas a. */
static int report(const char *src, const rad_vs3 *m, const double *AF, const double *a,
                  rad_vs3_factors *f, uint32_t *to, rad_error *err)
{
    uint32_t ns = m->surface_count, n = f->n;
    for (uint32_t i = 0; i < ns; i++) {
        if (to[i] == RAD_NONE)
            continue;
        f->area[to[i]] += a[i];
        f->emittance[to[i]] += a[i] * m->surfaces[i].emittance;
        for (uint32_t j = 0; j < ns; j++)
            if (to[j] != RAD_NONE)
                f->F[(size_t)to[i] * n + to[j]] += AF[(size_t)i * ns + j];
    }
    for (uint32_t i = 0; i < n; i++) {
        if (!(f->area[i] > 0.0))
            return rad_fail(err, RAD_ERR_INVALID, "%s: line %llu: surface '%s' has no area left",
                            src, m->surfaces[f->surface[i]].line, m->surfaces[f->surface[i]].name);
        f->emittance[i] /= f->area[i];
    }
    if (m->encl && (f->row_error = normalise_enclosure(f->F, f->area, n)) < 0)
        return rad_fail(err, RAD_ERR_NOMEM, "view3d: out of memory");
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = 0; j < n; j++)
            f->F[(size_t)i * n + j] /= f->area[i];
    if (!m->emit)
        return RAD_OK;
    double *SF = malloc((size_t)n * n * sizeof *SF);
    if (!SF)
        return rad_fail(err, RAD_ERR_NOMEM, "view3d: out of memory");
    int rc = script_f(f->F, f->area, f->emittance, n, SF, err);
    if (!rc) {
        free(f->F);
        f->F = SF;
        f->script = 1;
    } else {
        free(SF);
    }
    return rc;
}

int rad_vs3_factors_compute(const rad_solution *s, const rad_vs3 *m, rad_vs3_factors **out,
                            rad_error *err)
{
    *out = NULL;
    uint32_t ns = m->surface_count;
    if (!ns || s->scene->object_count < ns)
        return rad_fail(err, RAD_ERR_USAGE, "view3d: the solution is not of this .vs3 file");
    double *AF = malloc((size_t)ns * ns * sizeof *AF), *a = malloc((size_t)ns * sizeof *a);
    uint32_t *to = malloc((size_t)ns * 2 * sizeof *to);
    rad_vs3_factors *f = calloc(1, sizeof *f);
    int rc = (!AF || !a || !to || !f) ? rad_fail(err, RAD_ERR_NOMEM, "view3d: out of memory")
                                      : surface_exchange(s, m, AF, a, err);
    if (!rc) {
        uint32_t n = f->n = map_reported(m, to, to + ns);
        f->surface = malloc((size_t)(n ? n : 1) * sizeof *f->surface);
        f->area = calloc(n ? n : 1, sizeof *f->area);
        f->emittance = calloc(n ? n : 1, sizeof *f->emittance);
        f->F = calloc((size_t)n * n + 1, sizeof *f->F);
        if (!f->surface || !f->area || !f->emittance || !f->F)
            rc = rad_fail(err, RAD_ERR_NOMEM, "view3d: out of memory");
        else if (n == 0)
            rc = rad_fail(err, RAD_ERR_INVALID, "%s: no radiating surface to report",
                          s->scene->source);
        else
            memcpy(f->surface, to + ns, n * sizeof *f->surface);
    }
    if (!rc)
        rc = report(s->scene->source, m, AF, a, f, to, err);
    free(AF);
    free(a);
    free(to);
    if (rc)
        rad_vs3_factors_destroy(f);
    else
        *out = f;
    return rc;
}
