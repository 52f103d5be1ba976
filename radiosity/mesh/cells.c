/* cells.c - the geometry of cells and of patches made of several cells
 * (mesh.h, mesh_internal.h): what the mesher's builders (mesh.c, region.c)
 * share, below them in the dependency order.  Invariant: a cell's area and
 * centre are measured projected on its unit normal; a patch of several
 * cells has their summed area, mean normal, and its centre on a cell.
 */
#include "mesh_internal.h"

#include <stdlib.h>
#include <string.h>

/* Cells along an edge of length len for a target patch edge `size`.  The
 * 1e-9 keeps an edge of exactly k·size from becoming k+1 cells through
 * rounding.  UINT64_MAX when the count would not fit a uint32. */
uint64_t mesh_divisions(double len, double size)
{
    if (!(size > 0.0) || !isfinite(size))
        return 1;
    double q = len / size;
    if (!(q <= 4294967295.0))
        return UINT64_MAX;
    double c = ceil(q - 1e-9);
    return c < 1.0 ? 1 : (uint64_t)c;
}

int rad_cell_geometry(const rad_vec3 *V, const uint32_t v[4], rad_vec3 n, rad_vec3 *center,
                      double *area)
{
    double a1 = 0.5 * rad_dot(rad_cross(rad_sub(V[v[1]], V[v[0]]), rad_sub(V[v[2]], V[v[0]])), n);
    rad_vec3 c = rad_scale(rad_add(rad_add(V[v[0]], V[v[1]]), V[v[2]]), a1 / 3.0);
    double a = a1;
    if (v[3] != RAD_NONE) {
        double a2 = 0.5 * rad_dot(rad_cross(rad_sub(V[v[2]], V[v[0]]), rad_sub(V[v[3]], V[v[0]])), n);
        c = rad_add(c, rad_scale(rad_add(rad_add(V[v[0]], V[v[2]]), V[v[3]]), a2 / 3.0));
        a += a2;
    }
    if (!(a > 0.0) || !isfinite(a))
        return -1;
    *area = a;
    *center = rad_scale(c, 1.0 / a);
    return 0;
}

int mesh_patch_of_cells(const rad_vec3 *V, const rad_patch *cells, uint32_t n, rad_patch *out)
{
    if (n == 1) {
        *out = cells[0];
        return 0;
    }
    double area = 0.0;
    rad_vec3 sum_n = rad_v3(0, 0, 0), sum_c = rad_v3(0, 0, 0);
    for (uint32_t c = 0; c < n; c++) {
        area += cells[c].area;
        sum_n = rad_add(sum_n, rad_scale(cells[c].normal, cells[c].area));
        sum_c = rad_add(sum_c, rad_scale(cells[c].center, cells[c].area));
    }
    rad_vec3 centroid = rad_scale(sum_c, 1.0 / area), at = centroid;
    uint32_t home = 0;
    double best = INFINITY;
    for (uint32_t c = 0; c < n; c++) {
        rad_vec3 q;
        double d2 = rad_cell_nearest(V, cells[c].v, centroid, &q);
        if (d2 < best) {
            best = d2;
            home = c;
            at = q;
        }
    }
    *out = cells[home];
    out->center = at;
    out->normal = rad_normalize(sum_n);
    out->area = area;
    return rad_length(sum_n) > 0.0 ? 0 : -1;
}

int mesh_grow(void **p, size_t *cap, size_t need, size_t elt)
{
    if (need <= *cap)
        return 0;
    size_t n = *cap ? *cap : 64;
    while (n < need)
        n *= 2;
    void *q = realloc(*p, n * elt);
    if (!q)
        return -1;
    *p = q;
    *cap = n;
    return 0;
}

#define GROW(arr, cap, need) mesh_grow((void **)&(arr), &(cap), (need), sizeof *(arr))

static int u64_order(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Vertices on the outline of the cells from c0 on: ends of cell edges
 * that no other cell runs the other way. */
static int outline_flags(mesh_regions *out, uint32_t c0)
{
    size_t ne = 0;
    for (uint32_t c = c0; c < out->cells; c++)
        ne += (size_t)rad_patch_corners(&out->cell[c]);
    uint64_t *ekey = malloc((ne + 1) * sizeof *ekey);
    if (!ekey)
        return -1;
    ne = 0;
    for (uint32_t c = c0; c < out->cells; c++) {
        const rad_patch *cl = &out->cell[c];
        const int n = rad_patch_corners(cl);
        for (int k = 0; k < n; k++)
            ekey[ne++] = (uint64_t)cl->v[k] << 32 | cl->v[(k + 1) % n];
    }
    qsort(ekey, ne, sizeof *ekey, u64_order);
    for (size_t e = 0; e < ne; e++) {
        uint64_t rev = ekey[e] << 32 | ekey[e] >> 32;
        if (!bsearch(&rev, ekey, ne, sizeof *ekey, u64_order))
            out->Vb[ekey[e] >> 32] = out->Vb[ekey[e] & 0xffffffffu] = 1;
    }
    free(ekey);
    return 0;
}

int mesh_regions_emit(mesh_regions *out, const rad_patch *cells, size_t ncell,
                      const uint32_t *patch_of, uint32_t np, const rad_vec3 *pos, uint32_t nu)
{
    uint32_t *vmap = malloc(((size_t)nu + 1) * sizeof *vmap);
    uint32_t *start = calloc((size_t)np + 2, sizeof *start);
    if (!vmap || !start || GROW(out->patch, out->cap_p, out->patches + np + 1) ||
        GROW(out->cfirst, out->cap_f, out->patches + np + 2) ||
        GROW(out->cell, out->cap_c, out->cells + ncell + 1) ||
        GROW(out->V, out->cap_v, out->vertices + nu + 1) ||
        GROW(out->Vb, out->cap_b, out->vertices + nu + 1)) {
        free(vmap), free(start);
        return -1;
    }
    for (size_t k = 0; k < ncell; k++)
        start[patch_of[k] + 2]++;
    for (uint32_t p = 0; p < np; p++)
        start[p + 2] += start[p + 1];
    for (uint32_t u = 0; u < nu; u++)
        vmap[u] = RAD_NONE;
    const uint32_t c0 = out->cells, p0 = out->patches;
    for (size_t k = 0; k < ncell; k++) {
        rad_patch cl = cells[k];
        for (int a = 0; a < rad_patch_corners(&cl); a++) {
            uint32_t u = cl.v[a];
            if (vmap[u] == RAD_NONE) {
                vmap[u] = out->vertices;
                out->Vb[out->vertices] = 0;
                out->V[out->vertices++] = pos[u];
            }
            cl.v[a] = vmap[u];
        }
        out->cell[c0 + start[patch_of[k] + 1]++] = cl;
    }
    out->cells += (uint32_t)ncell;
    int bad = 0;
    for (uint32_t c = c0; c < out->cells; c++) {
        rad_patch *cl = &out->cell[c];
        bad |= rad_cell_geometry(out->V, cl->v, cl->normal, &cl->center, &cl->area) != 0;
    }
    for (uint32_t p = 0; p < np && !bad; p++) {
        out->cfirst[p0 + p] = c0 + start[p];
        bad |= mesh_patch_of_cells(out->V, &out->cell[c0 + start[p]], start[p + 1] - start[p],
                                   &out->patch[p0 + p]) != 0;
    }
    out->patches += np;
    out->cfirst[out->patches] = out->cells;
    free(vmap), free(start);
    if (bad)
        return -2;
    return outline_flags(out, c0);
}

int mesh_key_cmp(const void *a, const void *b)
{
    const mesh_key *x = a, *y = b;
    for (int d = 0; d < 3; d++)
        if (x->k[d] != y->k[d])
            return x->k[d] < y->k[d] ? -1 : 1;
    return x->r < y->r ? -1 : x->r > y->r;
}

size_t mesh_ring_unique(const void *in, size_t n, void *out, size_t elt)
{
    const unsigned char *p = in;
    unsigned char *q = out;
    size_t m = 0;
    for (size_t k = 0; k < n; k++)
        if (m == 0 || memcmp(p + k * elt, q + (m - 1) * elt, elt) != 0)
            memcpy(q + m++ * elt, p + k * elt, elt);
    while (m > 1 && memcmp(q, q + (m - 1) * elt, elt) == 0)
        m--;
    return m;
}

int mesh_regions_over(mesh_regions *out, double more)
{
    if (out->estimate_only) {
        out->estimate += more;
        return 1;
    }
    double n = (double)out->patches + more;
    if (!(n > 1.5 * (double)out->patch_limit)) /* 1.5: slivers make more than area / s² */
        return 0;
    out->estimate = n;
    return 1;
}
