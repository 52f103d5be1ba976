/* responses.c - the stored light responses of a solution (solution.h,
 * rad_basis; relight.h): its light groups, and the response of each, made
 * once the solution's B and elements are final.
 *
 * The sources are grouped by (object, material) for emitting patches and
 * one group per punctual light that shines.  For one group the solution is
 * its own response (scaling the one source scales the answer, whatever the
 * solver); for more, each group's sources are set alone and the patches
 * solved again through the pipeline's solver (rad_group_solver: the rows F
 * holds, Gauss-Seidel), the elements gathered and H computed, then the
 * solution put back as it was.
 *
 * Invariant: rad_basis_make leaves s's sources, B, elements' B, residual
 * and iterations as it found them, and s->basis either NULL or a basis
 * whose Σ_g B^(g) is B within the solves' error bounds (solution.h;
 * checked in debug builds).
 */
#include "relight.h"

#include "../elements/elements.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int rad_basis_groups(const rad_solution *s, uint32_t *patch_group, uint32_t *light_group,
                     uint32_t *groups, rad_error *err)
{
    (void)err; /* nothing is allocated: the pairs seen are at most the cap + 1 */
    const uint32_t n = s->mesh->patch_count, nb = s->band_count;
    const uint32_t nl = s->light_intensity ? s->scene->light_count : 0;
    uint32_t pair[RAD_BASIS_MAX_GROUPS + 1][2], k = 0;
    for (uint32_t i = 0; i < n; i++) {
        patch_group[i] = RAD_NONE;
        if (!rad_any_positive(s->emission + (size_t)i * nb, nb))
            continue;
        const rad_patch *p = &s->mesh->patches[i];
        uint32_t g = 0;
        while (g < k && (pair[g][0] != p->object || pair[g][1] != p->material))
            g++;
        if (g == k && k <= RAD_BASIS_MAX_GROUPS) {
            pair[k][0] = p->object;
            pair[k][1] = p->material;
            k++;
        }
        patch_group[i] = g < k ? g : RAD_NONE; /* past the cap: the count says so */
    }
    for (uint32_t l = 0; l < nl; l++) {
        light_group[l] = RAD_NONE;
        if (rad_any_positive(s->light_intensity + (size_t)l * nb, nb))
            light_group[l] = k++;
    }
    *groups = k;
    return RAD_OK;
}


/* The solution's sources and answers, kept while the groups are solved
 * one by one and put back after. */
typedef struct kept {
    double *E, *I, *B, *Be, residual;
    uint32_t iterations;
} kept;

static void kept_free(kept *k)
{
    free(k->E);
    free(k->I);
    free(k->B);
    free(k->Be);
}

static int keep(const rad_solution *s, kept *k)
{
    const size_t nv = (size_t)s->mesh->patch_count * s->band_count;
    const size_t nl = s->light_intensity ? (size_t)s->scene->light_count * s->band_count : 0;
    const size_t ne = s->elements ? (size_t)s->elements->mesh->patch_count * s->band_count : 0;
    *k = (kept){.E = malloc((nv + 1) * sizeof *k->E), .I = malloc((nl + 1) * sizeof *k->I),
                .B = malloc((nv + 1) * sizeof *k->B), .Be = malloc((ne + 1) * sizeof *k->Be),
                .residual = s->residual, .iterations = s->iterations};
    if (!k->E || !k->I || !k->B || !k->Be) {
        kept_free(k);
        *k = (kept){0}; /* nothing to put back, nothing left to free */
        return -1;
    }
    memcpy(k->E, s->emission, nv * sizeof *k->E);
    memcpy(k->B, s->B, nv * sizeof *k->B);
    if (nl)
        memcpy(k->I, s->light_intensity, nl * sizeof *k->I);
    if (ne)
        memcpy(k->Be, s->elements->B, ne * sizeof *k->Be);
    return 0;
}

static void put_back(rad_solution *s, const kept *k)
{
    const size_t nv = (size_t)s->mesh->patch_count * s->band_count;
    const size_t nl = s->light_intensity ? (size_t)s->scene->light_count * s->band_count : 0;
    const size_t ne = s->elements ? (size_t)s->elements->mesh->patch_count * s->band_count : 0;
    memcpy(s->emission, k->E, nv * sizeof *k->E);
    memcpy(s->B, k->B, nv * sizeof *k->B);
    if (nl)
        memcpy(s->light_intensity, k->I, nl * sizeof *k->I);
    if (ne)
        memcpy(s->elements->B, k->Be, ne * sizeof *k->Be);
    s->residual = k->residual;
    s->iterations = k->iterations;
}

/* Group g's response into b: s's sources set to g's alone (the reference
 * ones on its members, 0 elsewhere), solved by the pipeline's solver on the
 * stored rows, the elements gathered, H computed. */
static int solve_group(rad_solution *s, const rad_group_solver *solver, rad_basis *b, uint32_t g,
                       rad_error *err)
{
    const uint32_t n = s->mesh->patch_count, nb = s->band_count;
    const size_t nv = (size_t)n * nb;
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t k = 0; k < nb; k++)
            s->emission[(size_t)i * nb + k] =
                b->patch_group[i] == g ? b->E_ref[(size_t)i * nb + k] : 0.0;
    for (uint32_t l = 0; l < b->light_count; l++)
        for (uint32_t k = 0; k < nb; k++)
            s->light_intensity[(size_t)l * nb + k] =
                b->light_group[l] == g ? b->I_ref[(size_t)l * nb + k] : 0.0;
    double residual = 0.0;
    int rc = solver->solve(solver->user, s, &residual, err);
    if (!rc && s->elements)
        rc = rad_elements_gather(s, s->elements, err);
    if (!rc)
        rc = rad_solution_irradiance(s, b->H + g * nv, err);
    if (rc)
        return rc;
    memcpy(b->B + g * nv, s->B, nv * sizeof *s->B);
    if (b->Be)
        memcpy(b->Be + (size_t)g * b->element_count * nb, s->elements->B,
               (size_t)b->element_count * nb * sizeof *b->Be);
    b->residual[g] = residual;
    return RAD_OK;
}

#if RAD_DEBUG
/* solution.h's invariant: Σ_g B^(g) = B within what the solves' residuals
 * allow.  A residual r (of max B) bounds a solve's error by r max B / (1 -
 * ρ_max) (ρ_max: the largest ρ + τ, rows summing to at most 1 + 1e-3), and
 * B itself carries one too; twice that, for the estimate's rounding. */
static void check_basis(const rad_solution *s)
{
    const rad_basis *b = s->basis;
    const size_t nv = (size_t)b->patch_count * b->band_count;
    double rho_max = 0.0, top_B = 0.0;
    for (size_t q = 0; q < nv; q++) {
        const rad_material *m = &s->scene->materials[s->mesh->patches[q / b->band_count].material];
        rho_max = fmax(rho_max, s->rho[q] + m->transmit[q % b->band_count]);
        top_B = fmax(top_B, s->B[q]);
    }
    const double gain = 1.0 / fmax(1e-6, 1.0 - rho_max * (1.0 + 1e-3));
    double slack = 1e-12 + s->residual * top_B;
    for (uint32_t g = 0; g < b->groups; g++) {
        double top = 0.0;
        for (size_t q = 0; q < nv; q++)
            top = fmax(top, b->B[g * nv + q]);
        slack += b->residual[g] * top;
    }
    slack *= 2.0 * gain;
    for (size_t q = 0; q < nv; q++) {
        double sum = 0.0;
        for (uint32_t g = 0; g < b->groups; g++)
            sum += b->B[g * nv + q];
        RAD_ASSERT(fabs(sum - s->B[q]) <= slack + 1e-9 * s->B[q]);
    }
}
#endif

int rad_basis_make(rad_solution *s, const rad_group_solver *solver, rad_error *err)
{
    const uint32_t n = s->mesh->patch_count, nb = s->band_count;
    const size_t nv = (size_t)n * nb;
    rad_basis_destroy(s->basis);
    s->basis = NULL;
    /* Without F's entries, only when H was kept (the pipeline released
     * them after taking it): one group. */
    if ((!s->F->entries_loaded && !s->irradiance) || !(s->residual >= 0.0) ||
        !isfinite(s->residual))
        return RAD_OK;
    uint32_t *pg = malloc(((size_t)n + 1) * sizeof *pg);
    uint32_t *lg = malloc(((size_t)s->scene->light_count + 1) * sizeof *lg);
    uint32_t K = 0;
    int rows_ready = 0;
    int rc = pg && lg ? rad_basis_groups(s, pg, lg, &K, err)
                      : rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    if (!rc)
        rc = solver->prepare(solver->user, s, &rows_ready, err);
    rad_basis *b = NULL;
    if (!rc && K >= 1 && K <= RAD_BASIS_MAX_GROUPS &&
        (K == 1 || (s->F->entries_loaded && rows_ready)) && !(b = rad_basis_create(s, K)))
        rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for %u light responses",
                      s->scene->source, K);
    if (b) {
        memcpy(b->patch_group, pg, (size_t)n * sizeof *pg);
        memcpy(b->light_group, lg, (size_t)b->light_count * sizeof *lg);
    }
    if (b && K == 1) { /* scaling the one source scales the answer */
        memcpy(b->B, s->B, nv * sizeof *s->B);
        if (b->Be)
            memcpy(b->Be, s->elements->B, (size_t)b->element_count * nb * sizeof *b->Be);
        b->residual[0] = s->residual;
        rc = rad_solution_irradiance(s, b->H, err);
    } else if (b) {
        kept k;
        if (keep(s, &k) != 0)
            rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
        for (uint32_t g = 0; !rc && g < K; g++)
            rc = solve_group(s, solver, b, g, err);
        if (k.E)
            put_back(s, &k);
        kept_free(&k);
    }
    free(pg);
    free(lg);
    if (rc)
        rad_basis_destroy(b);
    else
        s->basis = b;
#if RAD_DEBUG
    if (s->basis)
        check_basis(s);
#endif
    return rc;
}
