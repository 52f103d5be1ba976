/* superpose.c - relighting by superposition of a solution's stored light
 * responses (solution.h, rad_basis; relight.h, rad_solution_superpose).
 *
 * B is linear in the sources, per band: B = M (E + ρ H_d) with
 * M = (I - diag(ρ) F)^-1, and so are H and the elements' B.  A relight that
 * scales each light group's sources by one factor per band is therefore a
 * weighted sum of the stored responses, exact up to the groups' own solve
 * tolerance: no F read, no solve.  The responses are made in responses.c.
 *
 * Invariant: rad_solution_superpose either finds one c_{g,band} >= 0 for
 * every group such that the solution's sources are exactly (to 1e-12
 * relative) c times the reference ones, and then replaces B, H and the
 * elements' B by the sums, or changes nothing.
 */
#include "relight.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Largest relative difference between a source and c × its reference that
 * still counts as a scaling: what a decimal scale factor costs in rounding
 * (two products and a quotient), far below any intended edit. */
#define SCALE_MISMATCH 1e-12

/* Is v = c × ref within SCALE_MISMATCH? (ref 0: v must be 0.) */
static int scaled(double v, double c, double ref)
{
    const double want = c * ref;
    return fabs(v - want) <= SCALE_MISMATCH * fmax(fabs(v), fabs(want));
}

/* The factor of group g in band b from its largest reference source, into
 * c; 0 and a reason in why when some source of the group is not c times
 * its reference. */
static int group_factor(const rad_solution *s, const rad_basis *bs, uint32_t g, uint32_t b,
                        double *c, char *why, size_t why_size)
{
    const uint32_t nb = bs->band_count;
    double ref = 0.0, now = 0.0;
    for (uint32_t i = 0; i < bs->patch_count; i++)
        if (bs->patch_group[i] == g && bs->E_ref[(size_t)i * nb + b] > ref) {
            ref = bs->E_ref[(size_t)i * nb + b];
            now = s->emission[(size_t)i * nb + b];
        }
    for (uint32_t l = 0; l < bs->light_count; l++)
        if (bs->light_group[l] == g && bs->I_ref[(size_t)l * nb + b] > ref) {
            ref = bs->I_ref[(size_t)l * nb + b];
            now = s->light_intensity[(size_t)l * nb + b];
        }
    *c = ref > 0.0 ? now / ref : 0.0;
    for (uint32_t i = 0; i < bs->patch_count; i++) {
        size_t k = (size_t)i * nb + b;
        if (bs->patch_group[i] == g && !scaled(s->emission[k], *c, bs->E_ref[k])) {
            const rad_patch *p = &s->mesh->patches[i];
            snprintf(why, why_size, "emission of '%s' (material '%s') is not a scaling of the "
                     "one solved with", s->scene->objects[p->object].name,
                     s->scene->materials[p->material].name);
            return 0;
        }
    }
    for (uint32_t l = 0; l < bs->light_count; l++) {
        size_t k = (size_t)l * nb + b;
        if (bs->light_group[l] == g && !scaled(s->light_intensity[k], *c, bs->I_ref[k])) {
            snprintf(why, why_size, "intensity of light '%s' is not a scaling of the one solved "
                     "with", s->scene->lights[l].name);
            return 0;
        }
    }
    return 1;
}

/* The sources outside every group must be dark: 0, or a reason in why. */
static int outside_dark(const rad_solution *s, const rad_basis *bs, char *why, size_t why_size)
{
    const uint32_t nb = bs->band_count;
    for (uint32_t i = 0; i < bs->patch_count; i++)
        if (bs->patch_group[i] == RAD_NONE && rad_any_positive(s->emission + (size_t)i * nb, nb)) {
            const rad_patch *p = &s->mesh->patches[i];
            snprintf(why, why_size, "'%s' (material '%s') emits, but emitted nothing when solved",
                     s->scene->objects[p->object].name, s->scene->materials[p->material].name);
            return 0;
        }
    for (uint32_t l = 0; l < bs->light_count; l++)
        if (bs->light_group[l] == RAD_NONE &&
            rad_any_positive(s->light_intensity + (size_t)l * nb, nb)) {
            snprintf(why, why_size, "light '%s' shines, but was dark when solved",
                     s->scene->lights[l].name);
            return 0;
        }
    return 1;
}

/* Why s cannot be relit by superposition before its sources are looked
 * at, or NULL. */
static const char *no_basis(const rad_solution *s, char *buf, size_t size)
{
    if (!s->basis) {
        uint32_t k = 0;
        uint32_t *pg = malloc(((size_t)s->mesh->patch_count + 1) * sizeof *pg);
        uint32_t *lg = malloc(((size_t)s->scene->light_count + 1) * sizeof *lg);
        if (pg && lg)
            rad_basis_groups(s, pg, lg, &k, NULL);
        free(pg);
        free(lg);
        if (k > RAD_BASIS_MAX_GROUPS)
            snprintf(buf, size, "more than %u light groups, no stored light responses",
                     RAD_BASIS_MAX_GROUPS);
        else
            snprintf(buf, size, "the solution holds no stored light responses (an older file, "
                     "or a solve that kept too few rows)");
        return buf;
    }
    if (!rad_basis_matches(s))
        return rad_basis_fits(s) ? "reflectance changed"
                              : "the stored light responses no longer match the solution";
    return NULL;
}

/* out[v] = Σ_g c[g·nb + b] × r[g·count + v], v over count values of nb bands. */
static void weighted_sum(const double *r, const double *c, uint32_t groups, uint64_t values,
                         uint32_t nb, double *out)
{
    for (uint64_t v = 0; v < values; v++) {
        double sum = 0.0;
        for (uint32_t g = 0; g < groups; g++)
            sum += c[(size_t)g * nb + v % nb] * r[(size_t)g * values + v];
        out[v] = sum;
    }
}

static double max_of(const double *v, uint64_t count)
{
    double m = 0.0;
    for (uint64_t q = 0; q < count; q++)
        m = v[q] > m ? v[q] : m;
    return m;
}

int rad_solution_superpose(rad_solution *s, int *done, char *why, size_t why_size,
                           rad_error *err)
{
    char local[512], buf[512];
    if (!why) {
        why = local;
        why_size = sizeof local;
    }
    *done = 0;
    const char *stop = no_basis(s, buf, sizeof buf);
    if (stop) {
        snprintf(why, why_size, "%s", stop);
        return RAD_OK;
    }
    const rad_basis *bs = s->basis;
    const uint32_t K = bs->groups, nb = bs->band_count, n = bs->patch_count;
    const uint64_t nv = (uint64_t)n * nb, ne = (uint64_t)bs->element_count * nb;
    double c[RAD_BASIS_MAX_GROUPS * RAD_MAX_BANDS];
    if (!outside_dark(s, bs, why, why_size))
        return RAD_OK;
    for (uint32_t g = 0; g < K; g++)
        for (uint32_t b = 0; b < nb; b++)
            if (!group_factor(s, bs, g, b, &c[(size_t)g * nb + b], why, why_size))
                return RAD_OK;
    double *B = malloc((nv + 1) * sizeof *B), *H = malloc((nv + 1) * sizeof *H);
    if (!B || !H) {
        free(B);
        free(H);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    }
    /* Nothing can fail from here: the elements' B is summed in place. */
    weighted_sum(bs->B, c, K, nv, nb, B);
    weighted_sum(bs->H, c, K, nv, nb, H);
    if (ne) {
        weighted_sum(bs->Be, c, K, ne, nb, s->elements->B);
        s->elements->rows_computed = 0;
    }
    /* The residual: each group's solve left r_g max B^(g) behind, scaled by
     * its largest factor; relative to the new max B. */
    double bound = 0.0, top = max_of(B, nv);
    for (uint32_t g = 0; g < K; g++) {
        double cg = max_of(c + (size_t)g * nb, nb);
        bound += cg * bs->residual[g] * max_of(bs->B + (size_t)g * nv, nv);
    }
    free(s->B);
    s->B = B;
    free(s->irradiance);
    s->irradiance = H;
    s->iterations = 0;
    s->residual = top > 0.0 ? bound / top : 0.0;
    s->rows_computed = 0;
    s->lights_computed = 0;
    rad_progress_destroy(s->progress);
    s->progress = NULL;
    *done = 1;
    snprintf(why, why_size, "%u stored light response%s", K, K == 1 ? "" : "s");
#if RAD_DEBUG
    for (uint64_t q = 0; q < nv; q++)
        RAD_ASSERT(isfinite(s->B[q]) && s->B[q] >= 0.0 && s->irradiance[q] >= 0.0);
#endif
    return RAD_OK;
}
