/* analysis.c - quantities read off a solution: irradiance, per-object power
 * balance, object-to-object form factors.
 *
 * Rows of F may be missing (patches with ρ = 0 need none).  Wherever a row
 * is missing, its entries are recovered by reciprocity, A_i F_ij = A_j F_ji,
 * from the rows that are present; an entry missing from both sides (two
 * black patches facing each other) is unknown and counts as zero, which the
 * report states.
 */
#include "solution.h"

#include <stdlib.h>
#include <string.h>

int rad_solution_irradiance(const rad_solution *s, double *H, rad_error *err)
{
    const rad_matrix *F = s->F;
    const rad_patch *p = s->mesh->patches;
    uint32_t n = s->mesh->patch_count, nb = s->band_count;
    if (!F->entries_loaded) {
        /* read without F: what the writer computed from it */
        if (!s->irradiance)
            return rad_fail(err, RAD_ERR_USAGE, "%s: irradiance: the form factors were not read",
                            s->scene->source);
        memcpy(H, s->irradiance, (size_t)n * nb * sizeof *H);
        return RAD_OK;
    }
    /* the punctual lights' direct part first (zero without lights) */
    int rc = rad_solution_direct_irradiance(s, H, err);
    if (rc)
        return rc;
    for (uint32_t i = 0; i < n; i++) {
        const rad_row r = rad_matrix_row(F, i);
        const uint8_t *q = r.col;
        uint32_t j = 0;
        for (uint32_t k = 0; k < r.count; k++) {
            j = rad_row_next(&q, j);
            double f = rad_row_value(&r, k);
            if (F->row_done[j] == 0) {
                /* j has no row: light from i reaches j with A_i F_ij / A_j = F_ji. */
                double fji = f * p[i].area / p[j].area;
                for (uint32_t b = 0; b < nb; b++)
                    H[(size_t)j * nb + b] += fji * s->B[(size_t)i * nb + b];
            }
            for (uint32_t b = 0; b < nb; b++)
                H[(size_t)i * nb + b] += f * s->B[(size_t)j * nb + b];
        }
    }
    return RAD_OK;
}

int rad_solution_object_stats(const rad_solution *s, rad_object_stats *out, rad_error *err)
{
    uint32_t n = s->mesh->patch_count, nb = s->band_count, no = s->scene->object_count;
    double *H = malloc(((size_t)n * nb + 1) * sizeof *H);
    if (!H)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    int rc = rad_solution_irradiance(s, H, err);
    if (rc) {
        free(H);
        return rc;
    }
    memset(out, 0, (size_t)no * sizeof *out);
    for (uint32_t o = 0; o < no; o++)
        out[o].material = RAD_NONE;
    for (uint32_t i = 0; i < n; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        rad_object_stats *st = &out[p->object];
        const rad_material *m = &s->scene->materials[p->material];
        st->material = st->patch_count == 0 || st->material == p->material ? p->material
                                                                             : RAD_NONE - 1;
        st->patch_count++;
        st->area += p->area;
        for (uint32_t b = 0; b < nb; b++) {
            size_t k = (size_t)i * nb + b;
            st->B[b] += p->area * s->B[k];
            st->emitted[b] += p->area * s->emission[k];
            st->absorbed[b] += p->area * (1.0 - s->rho[k] - m->transmit[b]) * H[k];
        }
    }
    for (uint32_t o = 0; o < no; o++) {
        if (out[o].material == RAD_NONE - 1)
            out[o].material = RAD_NONE;
        for (uint32_t b = 0; b < nb && out[o].area > 0; b++)
            out[o].B[b] /= out[o].area;
    }
    free(H);
    return RAD_OK;
}

int rad_object_form_factors(const rad_solution *s, double *M, rad_error *err)
{
    const rad_matrix *F = s->F;
    if (!F->entries_loaded)
        return rad_fail(err, RAD_ERR_USAGE, "%s: form factors: the matrix was not read",
                        s->scene->source);
    const rad_patch *p = s->mesh->patches;
    uint32_t n = s->mesh->patch_count, no = s->scene->object_count;
    memset(M, 0, (size_t)no * no * sizeof *M);
    /* Accumulate A_i F_ij (power-like exchange areas), then divide by A_A. */
    for (uint32_t i = 0; i < n; i++) {
        const rad_row r = rad_matrix_row(F, i);
        const uint8_t *q = r.col;
        uint32_t j = 0;
        for (uint32_t k = 0; k < r.count; k++) {
            j = rad_row_next(&q, j);
            double g = p[i].area * (double)rad_row_value(&r, k);
            M[(size_t)p[i].object * no + p[j].object] += g;
            if (!F->row_done[j])
                M[(size_t)p[j].object * no + p[i].object] += g; /* reciprocity */
        }
    }
    double *area = calloc(no ? no : 1, sizeof *area);
    if (!area)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    for (uint32_t i = 0; i < n; i++)
        area[p[i].object] += p[i].area;
    for (uint32_t a = 0; a < no; a++)
        for (uint32_t b = 0; b < no; b++)
            M[(size_t)a * no + b] = area[a] > 0 ? M[(size_t)a * no + b] / area[a] : 0.0;
    free(area);
    return RAD_OK;
}
