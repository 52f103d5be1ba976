/* basis.c - the stored light responses' data (solution.h, rad_basis):
 * making an empty basis for a solution's sizes, freeing it, and telling
 * whether it still describes the solution.  The responses are computed in
 * radiosity/relight/ (rad_basis_make) and read and written with the
 * solution's file (BASIS, radiosity/solfile/).
 *
 * Invariant: a basis made here has s's sizes and copies of its E, I and ρ;
 * rad_basis_matches is 1 exactly while those sizes and ρ are still s's.
 */
#include "solution.h"

#include <stdlib.h>
#include <string.h>

void rad_basis_destroy(rad_basis *b)
{
    if (!b)
        return;
    free(b->E_ref);
    free(b->I_ref);
    free(b->patch_group);
    free(b->light_group);
    free(b->B);
    free(b->H);
    free(b->Be);
    free(b->residual);
    free(b->rho);
    free(b);
}

/* count doubles, or NULL (count 0 allocates one, so that NULL means OOM). */
static double *doubles(uint64_t count)
{
    return count > SIZE_MAX / sizeof(double) - 1 ? NULL : calloc((size_t)count + 1, sizeof(double));
}

rad_basis *rad_basis_create(const rad_solution *s, uint32_t groups)
{
    rad_basis *b = calloc(1, sizeof *b);
    if (!b)
        return NULL;
    const uint32_t n = s->mesh->patch_count, nb = s->band_count;
    const uint32_t nl = s->light_intensity ? s->scene->light_count : 0;
    const uint32_t ne = s->elements ? s->elements->mesh->patch_count : 0;
    const uint64_t nv = (uint64_t)n * nb;
    *b = (rad_basis){.groups = groups, .patch_count = n, .light_count = nl,
                     .element_count = ne, .band_count = nb};
    b->E_ref = doubles(nv);
    b->rho = doubles(nv);
    b->I_ref = nl ? doubles((uint64_t)nl * nb) : NULL;
    b->patch_group = malloc(((size_t)n + 1) * sizeof *b->patch_group);
    b->light_group = malloc(((size_t)nl + 1) * sizeof *b->light_group);
    b->B = doubles(groups * nv);
    b->H = doubles(groups * nv);
    b->Be = ne ? doubles((uint64_t)groups * ne * nb) : NULL;
    b->residual = doubles(groups);
    if (!b->E_ref || !b->rho || (nl && !b->I_ref) || !b->patch_group || !b->light_group ||
        !b->B || !b->H || (ne && !b->Be) || !b->residual) {
        rad_basis_destroy(b);
        return NULL;
    }
    memcpy(b->E_ref, s->emission, nv * sizeof *b->E_ref);
    memcpy(b->rho, s->rho, nv * sizeof *b->rho);
    if (nl)
        memcpy(b->I_ref, s->light_intensity, (size_t)nl * nb * sizeof *b->I_ref);
    for (uint32_t i = 0; i < n; i++)
        b->patch_group[i] = RAD_NONE;
    for (uint32_t l = 0; l < nl; l++)
        b->light_group[l] = RAD_NONE;
    return b;
}

int rad_basis_fits(const rad_solution *s)
{
    const rad_basis *b = s->basis;
    const uint32_t nl = s->light_intensity ? s->scene->light_count : 0;
    const uint32_t ne = s->elements ? s->elements->mesh->patch_count : 0;
    return b && b->patch_count == s->mesh->patch_count && b->band_count == s->band_count &&
           b->light_count == nl && b->element_count == ne;
}

int rad_basis_matches(const rad_solution *s)
{
    const rad_basis *b = s->basis;
    return rad_basis_fits(s) &&
           memcmp(b->rho, s->rho, (size_t)b->patch_count * b->band_count * sizeof *b->rho) == 0;
}
