/* element_store.c - the element store of solution.h: allocating, freeing
 * and checking a rad_elements (substructuring: Cohen, Greenberg, Immel &
 * Brock 1986: patches shoot, elements receive).  What elements are and how
 * they are made lives in radiosity/elements/; this file only keeps the
 * data, which the solution file (radiosity/solfile/) reads and writes.
 *
 * Invariant: rad_element_store_check accepts exactly the element sets that
 * obey solution.h's element invariants against their solution, and the
 * reader and the writer both run it.
 */
#include "solution.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------ storage */

rad_elements *rad_element_store_alloc(uint32_t vertex_count, uint32_t count, uint32_t bands,
                                      uint64_t entries)
{
    rad_elements *el = calloc(1, sizeof *el);
    if (!el)
        return NULL;
    size_t n = count ? count : 1, ne = entries ? (size_t)entries : 1;
    el->mesh = rad_mesh_alloc(vertex_count, count);
    el->patch = calloc(n, sizeof *el->patch);
    el->level = calloc(n, sizeof *el->level);
    el->B = calloc(n * (bands ? bands : 1), sizeof *el->B);
    el->row_start = calloc(n, sizeof *el->row_start);
    el->row_count = calloc(n, sizeof *el->row_count);
    el->col = malloc(ne * sizeof *el->col);
    el->val = malloc(ne * sizeof *el->val);
    if (!el->mesh || !el->patch || !el->level || !el->B || !el->row_start || !el->row_count ||
        !el->col || !el->val) {
        rad_element_store_destroy(el);
        return NULL;
    }
    el->capacity = entries;
    el->rows_loaded = 1;
    return el;
}

void rad_element_store_destroy(rad_elements *el)
{
    if (!el)
        return;
    rad_mesh_destroy(el->mesh);
    free(el->patch);
    free(el->level);
    free(el->B);
    free(el->row_start);
    free(el->row_count);
    free(el->col);
    free(el->val);
    free(el->light_h);
    free(el->interp);
    free(el->direct);
    free(el);
}

/* The cell of patch p an element with corners c->v (in m) lies in: the
 * patch itself when it is one cell, else the patch's cell nearest to the
 * mean of the element's corners (an element lies inside one cell: it is
 * that cell split `level` times). */
static const rad_patch *element_cell(const rad_mesh *pm, uint32_t p, const rad_mesh *m,
                                     const rad_patch *c)
{
    const rad_patch *cells;
    uint32_t count = rad_patch_cells(pm, p, &cells);
    if (count == 1)
        return &pm->patches[p];
    int corners = rad_patch_corners(c);
    rad_vec3 mid = rad_v3(0, 0, 0);
    for (int k = 0; k < corners; k++)
        mid = rad_add(mid, m->vertices[c->v[k]]);
    mid = rad_scale(mid, 1.0 / corners);
    const rad_patch *best = cells;
    double dbest = INFINITY;
    for (uint32_t q = 0; q < count; q++) {
        rad_vec3 at;
        double d2 = rad_cell_nearest(pm->vertices, cells[q].v, mid, &at);
        if (d2 < dbest) {
            dbest = d2;
            best = &cells[q];
        }
    }
    return best;
}

int rad_element_store_complete(rad_elements *el, const rad_solution *s, const char *name,
                               rad_error *err)
{
    const rad_mesh *pm = s->mesh;
    rad_mesh *m = el->mesh;
    for (uint32_t e = 0; e < m->patch_count; e++) {
        rad_patch *c = &m->patches[e];
        uint32_t p = el->patch[e];
        if (p >= pm->patch_count)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: patch %u out of range (%u patches)",
                            name, e, p, pm->patch_count);
        for (int k = 0; k < rad_patch_corners(c); k++)
            if (c->v[k] >= m->vertex_count)
                return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: vertex %u out of range", name,
                                e, c->v[k]);
        if (rad_element_place(el, e, element_cell(pm, p, m, c), &pm->patches[p]) != 0)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: area is not positive", name, e);
    }
    return rad_element_store_check(el, s, name, err);
}

int rad_element_place(rad_elements *el, uint32_t e, const rad_patch *cell, const rad_patch *patch)
{
    rad_patch *c = &el->mesh->patches[e];
    c->polygon = cell->polygon;
    c->object = patch->object;
    c->material = patch->material;
    c->normal = cell->normal;
    return rad_cell_geometry(el->mesh->vertices, c->v, c->normal, &c->center, &c->area) != 0 ? -1
                                                                                            : 0;
}

int rad_element_store_check(const rad_elements *el, const rad_solution *s, const char *name,
                            rad_error *err)
{
    const rad_mesh *pm = s->mesh, *m = el->mesh;
    const uint32_t bands = s->band_count;
    /* Without their entries (rows_loaded 0) the rows are checked as far as
     * their counts go: in range of nnz, none at level 0. */
    const int rows = el->rows_loaded;
    if (!m || !el->patch || !el->level || !el->B || !el->row_start || !el->row_count ||
        (rows && el->nnz && (!el->col || !el->val)) || (rows && el->nnz > el->capacity) ||
        (!rows && (el->col || el->val)))
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: elements: missing arrays", name);
    int rc = rad_mesh_check(m, s->scene->polygon_count, s->scene->object_count,
                            s->scene->material_count, err);
    if (rc != RAD_OK)
        return rc;
    for (uint32_t e = 0; e < m->patch_count; e++) {
        const rad_patch *c = &m->patches[e];
        uint32_t p = el->patch[e];
        if (p >= pm->patch_count)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: patch %u out of range (%u patches)",
                            name, e, p, pm->patch_count);
        const rad_patch *pp = &pm->patches[p], *home = element_cell(pm, p, m, c);
        if (c->polygon != home->polygon || c->object != pp->object || c->material != pp->material)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: not in its patch's polygon", name, e);
        if (el->level[e] > RAD_MAX_ELEMENT_LEVEL)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: level %u above %u", name, e,
                            el->level[e], RAD_MAX_ELEMENT_LEVEL);
        /* The element lies in its patch: its area is at most the patch's. */
        if (!(c->area <= pp->area * (1.0 + 1e-9)))
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: larger than its patch", name, e);
        uint32_t cnt = el->row_count[e];
        if (el->row_start[e] > el->nnz || cnt > el->nnz - el->row_start[e])
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: row outside the entries", name, e);
        if (el->level[e] == 0 && cnt != 0)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: level 0 with a row", name, e);
        double sum = 0.0;
        for (uint32_t q = 0; rows && q < cnt; q++) {
            uint64_t k = el->row_start[e] + q;
            uint32_t j = el->col[k];
            if (j >= pm->patch_count || j == p || (q && j <= el->col[k - 1]) ||
                !(el->val[k] > 0.0f) || !isfinite(el->val[k]))
                return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: bad row entry %u", name, e, q);
            sum += el->val[k];
        }
        if (!(sum <= 1.0 + 1e-3))
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: row sum %g above 1", name, e, sum);
        for (uint32_t b = 0; b < bands; b++) {
            double v = el->B[(size_t)e * bands + b];
            if (!(v >= 0.0) || !isfinite(v))
                return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: radiosity %g", name, e, v);
        }
    }
    if (el->light_h) {
        if (el->light_count == 0 || el->light_count != s->scene->light_count)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: elements: direct light of %u lights, the scene has %u",
                            name, el->light_count, s->scene->light_count);
        for (uint32_t e = 0; e < m->patch_count; e++)
            for (uint32_t l = 0; l < el->light_count; l++) {
                float h = el->light_h[(size_t)e * el->light_count + l];
                if (!(h >= 0.0f) || !isfinite(h) || (el->level[e] == 0 && h != 0.0f))
                    return rad_fail(err, RAD_ERR_CORRUPT,
                                    "%s: element %u: direct light %g from light %u (level %u)", name,
                                    e, (double)h, l, el->level[e]);
            }
    } else if (el->light_count) {
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: elements: light count without direct light", name);
    }
    if ((el->interp != NULL) != (el->direct != NULL))
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: elements: interpolation flags without sources",
                        name);
    for (uint32_t j = 0; el->direct && j < pm->patch_count; j++)
        if (el->direct[j] > 1)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: patch %u: direct-source flag %u", name, j,
                            el->direct[j]);
    for (uint32_t e = 0; el->interp && e < m->patch_count; e++) {
        if (el->interp[e] > 1 || (el->interp[e] && el->level[e] == 0))
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: interpolation flag %u at level %u",
                            name, e, el->interp[e], el->level[e]);
        for (uint32_t q = 0; rows && el->interp[e] && q < el->row_count[e]; q++)
            if (!el->direct[el->col[el->row_start[e] + q]])
                return rad_fail(err, RAD_ERR_CORRUPT,
                                "%s: element %u: interpolated, but its row holds patch %u, "
                                "not a direct source", name, e, el->col[el->row_start[e] + q]);
    }
    if (!(el->threshold >= 0.0) || !isfinite(el->threshold) || !(el->min_size >= 0.0) ||
        !isfinite(el->min_size))
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: elements: bad threshold or minimum size", name);
    return RAD_OK;
}
