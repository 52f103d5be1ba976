/* element_gather.c - an element's radiosity from the patch solution:
 *   B_e = E_p + ρ_p (Σ_j F_ej B_j + [Ĥ_i(c_e)] + H_d,e) + τ_p H_twin(p),
 *   H_d,e = Σ_l I_l h_le,
 * with h_le the punctual lights' mean direct irradiance over the element
 * (unit strength, closed form times the visible fraction from the light's
 * item buffer, refine.c's element_lights), Ĥ_i the
 * patches' irradiance from all but the direct sources interpolated at the
 * element's centre (interpolated elements only, solution.h) and, on the
 * side of a transmitting sheet, what comes through from the other side's
 * patch.
 *
 * Invariant: a gather reads only stored rows and stored h_le (no hemi-cube,
 * no item buffer), so a relight re-gathers elements at the cost of a sparse
 * product; a level-0 element is its patch (B_e = B_p, whose H_d,p is the
 * patch average Φ_lp / A_p).
 */
#include "el_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------- gather */

/* H_d,e of one element per band into hd: Σ_l I_l h_le from its own h[]
 * (light_count values), or for a level-0 element and without them its
 * patch's H_d,p from Hd (NULL: no direct light). */
void el_element_direct(const rad_solution *s, const double *Hd, const float *h, uint32_t p,
                           uint32_t level, double *hd)
{
    const uint32_t bands = s->band_count, nl = s->scene->light_count;
    for (uint32_t b = 0; b < bands; b++) {
        double v = 0.0;
        if (h && level > 0)
            for (uint32_t l = 0; l < nl; l++)
                v += s->light_intensity[(size_t)l * bands + b] * (double)h[l];
        else if (Hd)
            v = Hd[(size_t)p * bands + b];
        hd[b] = v;
    }
}

/* B_e of one element from its row and its direct irradiance hd (see the
 * top of the file).  Tr, when not NULL, holds per patch the light a sheet
 * lets through from its other side, τ_p H_twin(p), at the patch's
 * resolution. */
void el_gather_one(const rad_solution *s, const double *hd, const double *ind, const double *Tr,
                   uint32_t p, uint32_t level, const uint32_t *col, const float *val, uint32_t cnt,
                   double *Be)
{
    const uint32_t bands = s->band_count;
    const size_t pb = (size_t)p * bands;
    if (level == 0) {
        memcpy(Be, s->B + pb, bands * sizeof *Be);
        return;
    }
    for (uint32_t b = 0; b < bands; b++) {
        double h = hd[b] + (ind ? ind[b] : 0.0);
        for (uint32_t q = 0; q < cnt; q++)
            h += (double)val[q] * s->B[(size_t)col[q] * bands + b];
        double v = s->emission[pb + b] + s->rho[pb + b] * h + (Tr ? Tr[pb + b] : 0.0);
        Be[b] = v > 0.0 ? v : 0.0;
    }
}

/* τ_p H_twin(p) of every patch when the mesh has two-sided sheets, else
 * NULL: what reaches an element through its sheet, taken at the patch's
 * resolution (the twin's irradiance from its own row). */
int el_transmitted(const rad_solution *s, double **out, rad_error *err)
{
    *out = NULL;
    if (!s->mesh->twin)
        return RAD_OK;
    const uint32_t n = s->mesh->patch_count, bands = s->band_count;
    double *H = malloc(((size_t)n * bands + 1) * sizeof *H);
    double *T = malloc(((size_t)n * bands + 1) * sizeof *T);
    int rc = H && T ? rad_solution_irradiance(s, H, err)
                    : rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t p = 0; rc == RAD_OK && p < n; p++) {
        uint32_t t = s->mesh->twin[p];
        const double *tau = s->scene->materials[s->mesh->patches[p].material].transmit;
        for (uint32_t b = 0; b < bands; b++)
            T[(size_t)p * bands + b] = t != RAD_NONE ? tau[b] * H[(size_t)t * bands + b] : 0.0;
    }
    free(H);
    if (rc != RAD_OK) {
        free(T);
        return rc;
    }
    *out = T;
    return RAD_OK;
}

int rad_elements_transmitted(const rad_solution *s, double **out, rad_error *err)
{
    return el_transmitted(s, out, err);
}

/* H_d of every patch when the scene has punctual lights, else NULL (no
 * direct term).  *hd_out NULL with RAD_OK means none. */
static int direct_irradiance(const rad_solution *s, double **hd_out, rad_error *err)
{
    *hd_out = NULL;
    if (!s->scene->light_count)
        return RAD_OK;
    double *Hd = malloc((size_t)s->mesh->patch_count * s->band_count * sizeof *Hd + 1);
    if (!Hd)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    int rc = rad_solution_direct_irradiance(s, Hd, err);
    if (rc != RAD_OK) {
        free(Hd);
        return rc;
    }
    *hd_out = Hd;
    return RAD_OK;
}

/* Element e's own h_le, or NULL. */
static const float *own_light(const rad_elements *el, uint32_t e)
{
    return el->light_h ? el->light_h + (size_t)e * el->light_count : NULL;
}

int rad_elements_direct_irradiance(const rad_solution *s, const rad_elements *el, double *Hd,
                                   rad_error *err)
{
    if (!s || !el || !Hd)
        return rad_fail(err, RAD_ERR_USAGE,
                        "rad_elements_direct_irradiance: solution, elements and Hd must be given");
    double *patch_Hd;
    int rc = direct_irradiance(s, &patch_Hd, err);
    if (rc != RAD_OK)
        return rc;
    const uint32_t bands = s->band_count;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++)
        el_element_direct(s, patch_Hd, own_light(el, e), el->patch[e], el->level[e],
                       Hd + (size_t)e * bands);
    free(patch_Hd);
    return RAD_OK;
}

int rad_elements_patch_indirect(const rad_solution *s, const rad_elements *el, double **Hi,
                                rad_error *err)
{
    *Hi = NULL;
    if (!el->interp)
        return RAD_OK;
    /* The patches' indirect irradiance, drawn the elements' way. */
    RAD_ASSERT(s->F->entries_loaded);
    if (!s->F->entries_loaded)
        return rad_fail(err, RAD_ERR_USAGE, "%s: the form factors were not read",
                        s->scene->source);
    *Hi = malloc(((size_t)s->mesh->patch_count * s->band_count + 1) * sizeof **Hi);
    if (!*Hi)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    el_patch_indirect(s, el->direct, *Hi);
    return RAD_OK;
}

int rad_elements_gather_from(const rad_solution *s, rad_elements *el, const double *Hi,
                             rad_error *err)
{
    /* the gather reads every row: the caller reads RAD_PART_ELEMENT_ROWS */
    RAD_ASSERT(el->rows_loaded && (Hi || !el->interp));
    if (!el->rows_loaded)
        return rad_fail(err, RAD_ERR_USAGE, "%s: the elements' rows were not read",
                        s->scene->source);
    if (el->interp && !Hi)
        return rad_fail(err, RAD_ERR_USAGE, "rad_elements_gather_from: no Hi for the "
                        "interpolated elements (rad_elements_patch_indirect)");
    double *Hd, *Tr = NULL;
    el_interp ip = {0};
    int rc = direct_irradiance(s, &Hd, err);
    if (rc == RAD_OK)
        rc = el_transmitted(s, &Tr, err);
    const uint32_t bands = s->band_count;
    if (rc == RAD_OK && el->interp)
        rc = el_interp_make(s, Hi, &ip, err);
    double hd[RAD_MAX_BANDS], ind[RAD_MAX_BANDS];
    for (uint32_t e = 0; rc == RAD_OK && e < el->mesh->patch_count; e++) {
        const int interp = el->interp && el->interp[e];
        el_element_direct(s, Hd, own_light(el, e), el->patch[e], el->level[e], hd);
        if (interp)
            el_interp_at(&ip, s, el->patch[e], el->mesh->patches[e].center, ind);
        el_gather_one(s, hd, interp ? ind : NULL, Tr, el->patch[e], el->level[e],
                      el->col + el->row_start[e], el->val + el->row_start[e], el->row_count[e],
                      el->B + (size_t)e * bands);
    }
    el_interp_free(&ip);
    free(Hd);
    free(Tr);
    return rc;
}

int rad_elements_gather(const rad_solution *s, rad_elements *el, rad_error *err)
{
    if (!s || !el)
        return rad_fail(err, RAD_ERR_USAGE, "rad_elements_gather: solution and elements must be given");
    double *Hi;
    int rc = rad_elements_patch_indirect(s, el, &Hi, err);
    if (rc == RAD_OK)
        rc = rad_elements_gather_from(s, el, Hi, err);
    free(Hi);
    return rc;
}

/* ------------------------------------------------------- interpolation */

void el_patch_indirect(const rad_solution *s, const uint8_t *direct, double *H)
{
    const rad_matrix *F = s->F;
    const uint32_t n = s->mesh->patch_count, bands = s->band_count;
    for (uint32_t p = 0; p < n; p++) {
        double *h = H + (size_t)p * bands;
        for (uint32_t b = 0; b < bands; b++)
            h[b] = 0.0;
        const rad_row r = rad_matrix_row(F, p); /* a missing row reads as empty */
        const uint8_t *cp = r.col;
        for (uint32_t q = 0, j = 0; q < r.count; q++) {
            j = rad_row_next(&cp, j);
            if (direct[j])
                continue;
            const double f = rad_row_value(&r, q);
            for (uint32_t b = 0; b < bands; b++)
                h[b] += f * s->B[(size_t)j * bands + b];
        }
    }
}

void el_interp_free(el_interp *ip)
{
    if (!ip)
        return;
    rad_mesh_destroy(ip->rm);
    free(ip->cells_of);
    free(ip->first);
    free(ip->vB);
    memset(ip, 0, sizeof *ip);
}

int el_interp_make(const rad_solution *s, const double *field, el_interp *ip, rad_error *err)
{
    memset(ip, 0, sizeof *ip);
    const uint32_t n = s->mesh->patch_count, bands = s->band_count;
    /* A clustered mesh is drawn by its cells (level-0 elements, each of its
     * patch), clusters with the affine fit of the patches' field; without
     * clusters the cells are the patches. */
    rad_elements *cells = NULL;
    int rc = s->mesh->cell_first ? rad_elements_of_cells(s, &cells, err) : RAD_OK;
    const rad_mesh *cm = cells ? cells->mesh : s->mesh;
    const uint32_t ncell = cm->patch_count;
    if (rc == RAD_OK)
        rc = el_fan_mesh(cm, &ip->rm, &ip->cells_of, err);
    if (rc != RAD_OK) {
        rad_element_store_destroy(cells);
        return rc;
    }
    const uint32_t nc = ip->rm->patch_count;
    double *cfield = NULL;
    double *drawn = malloc(((size_t)ncell * bands + 1) * sizeof *drawn);
    double *cell = malloc(((size_t)nc * bands + 1) * sizeof *cell);
    ip->vB = malloc(((size_t)ip->rm->vertex_count * bands + 1) * sizeof *ip->vB);
    ip->first = calloc((size_t)n + 1, sizeof *ip->first);
    if (cells && (cfield = malloc(((size_t)ncell * bands + 1) * sizeof *cfield)))
        for (uint32_t c = 0; c < ncell; c++)
            memcpy(cfield + (size_t)c * bands, field + (size_t)cells->patch[c] * bands,
                   bands * sizeof *cfield);
    if (!drawn || !cell || !ip->vB || !ip->first || (cells && !cfield))
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the interpolation");
    if (rc == RAD_OK)
        rc = el_drawn_field(s, cells, ip->rm, ip->cells_of, cells ? cfield : field, field, drawn,
                            err);
    if (rc == RAD_OK) {
        /* The fans of one cell are consecutive, in cell order, and so are
         * the cells of one patch. */
        for (uint32_t k = 0; k < nc; k++) {
            const uint32_t c = ip->cells_of[k];
            ip->first[(cells ? cells->patch[c] : c) + 1]++;
            memcpy(cell + (size_t)k * bands, drawn + (size_t)c * bands, bands * sizeof *cell);
        }
        for (uint32_t p = 0; p < n; p++)
            ip->first[p + 1] += ip->first[p];
        rn_vertex_radiosity_fit(ip->rm, bands, cell, ip->vB, RN_FIT_QUADRATIC);
    }
    rad_element_store_destroy(cells);
    free(cfield);
    free(drawn);
    free(cell);
    if (rc != RAD_OK)
        el_interp_free(ip);
    return rc;
}

void el_interp_at(const el_interp *ip, const rad_solution *s, uint32_t p, rad_vec3 x, double *out)
{
    el_drawn_at(ip->rm, ip->vB, s->band_count, ip->first[p], ip->first[p + 1] - ip->first[p],
                s->mesh->patches[p].normal, x, out);
}
