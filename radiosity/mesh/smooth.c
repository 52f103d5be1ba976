/* smooth.c - curved surfaces of narrow facets meshed across their facets
 * (mesh_internal.h).
 *
 * A moulding, a vault or the side of a cylinder is exported as long narrow
 * facets, each a plane of its own: meshed facet by facet, the surface gets
 * patches no wider than a facet, however large the patch size.  region.c
 * finds such surfaces (neighbouring narrow planar regions of one object
 * and material whose normals lie within 30°) and hands their polygons
 * here.  The polygons are cut by a grid of cubes of side `size` over the
 * scene's bounds; in each cube, the pieces whose normals lie within 30° of
 * the first one's (a cube may hold two sides of a thin surface) are one
 * patch; a patch under a quarter of size² joins the largest patch of a
 * neighbouring cube within 30° of it if the two fit in 2 × size.
 *
 * Such a patch is not planar.  Its cells are the planar pieces, each with
 * its facet's normal, drawn as they are by the hemi-cube and the renderer;
 * the patch's area is the sum of theirs, its normal their area-weighted
 * mean, its centre their area centroid moved onto the nearest cell
 * (mesh_patch_of_cells), where its hemi-cube sits.  The cells share
 * vertices across facets, so the renderer averages across the surface.
 */
#include "mesh_internal.h"

#include <stdlib.h>
#include <string.h>

/* 30°, as the clusters' (mesh.h), facets exactly 30° apart included
 * (mesh_internal.h) */
#define SMOOTH_COS MESH_FACET_COS
#define SMOOTH_SLIVER 0.25
#define SMOOTH_LONGEST 2.0

typedef struct swork {
    const rad_scene *s;
    double h;
    rad_vec3 lo;
    rad_vec3 *raw;
    size_t nraw, craw;
    rad_patch *cell;
    size_t ncell, ccell;
    int64_t (*cube)[3];
    size_t ccube;
    rad_vec3 *tmp;
    size_t ctmp;
    uint64_t climit; /* cells this surface may still make */
} swork;

#define GROW3(arr, cap, need) mesh_grow((void **)&(arr), &(cap), (need), sizeof *(arr))

static double comp(rad_vec3 v, int a)
{
    return a == 0 ? v.x : a == 1 ? v.y : v.z;
}

static void set_comp(rad_vec3 *v, int a, double x)
{
    if (a == 0)
        v->x = x;
    else if (a == 1)
        v->y = x;
    else
        v->z = x;
}

static int before(rad_vec3 a, rad_vec3 b)
{
    return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
}

/* Where segment ab meets the plane v[axis] = at, from the end that sorts
 * first (both facets of a shared edge get the same point). */
static rad_vec3 cut(rad_vec3 a, rad_vec3 b, int axis, double at)
{
    if (before(b, a)) {
        rad_vec3 t = a;
        a = b;
        b = t;
    }
    double t = (at - comp(a, axis)) / (comp(b, axis) - comp(a, axis));
    rad_vec3 r = rad_add(a, rad_scale(rad_sub(b, a), t));
    set_comp(&r, axis, at);
    return r;
}

static size_t clip3(const rad_vec3 *in, size_t n, rad_vec3 *out, int axis, double at, int ge)
{
    size_t m = 0;
    for (size_t k = 0; k < n; k++) {
        rad_vec3 a = in[k], b = in[(k + 1) % n];
        int ia = ge ? comp(a, axis) >= at : comp(a, axis) <= at;
        int ib = ge ? comp(b, axis) >= at : comp(b, axis) <= at;
        if (ia)
            out[m++] = a;
        if (ia != ib)
            out[m++] = cut(a, b, axis, at);
    }
    return m;
}

static double tri_area(rad_vec3 a, rad_vec3 b, rad_vec3 c, rad_vec3 n)
{
    return 0.5 * rad_dot(rad_cross(rad_sub(b, a), rad_sub(c, a)), n);
}

/* A convex piece of polygon i in cube key: a quad, or a fan of triangles
 * with area. */
static int add_piece(swork *w, uint32_t i, const rad_vec3 *p, size_t n, const int64_t key[3])
{
    const rad_polygon *pg = &w->s->polygons[i];
    const double tiny = 1e-12 * w->h * w->h;
    if (GROW3(w->raw, w->craw, w->nraw + n + 1) != 0)
        return -1;
    size_t base = w->nraw, m = 0;
    m = mesh_ring_unique(p, n, &w->raw[base], sizeof *p);
    if (m < 3)
        return 0;
    w->nraw += m;
    const rad_vec3 *q = &w->raw[base];
    int quad = m == 4 && tri_area(q[0], q[1], q[2], pg->normal) > tiny &&
               tri_area(q[0], q[2], q[3], pg->normal) > tiny;
    for (size_t t = 1; t + 1 < m; t += quad ? 2 : 1) {
        if (!quad && !(tri_area(q[0], q[t], q[t + 1], pg->normal) > tiny))
            continue;
        if (w->ncell >= w->climit)
            return -3;
        if (GROW3(w->cell, w->ccell, w->ncell + 1) != 0 ||
            GROW3(w->cube, w->ccube, w->ncell + 1) != 0)
            return -1;
        rad_patch *c = &w->cell[w->ncell];
        memset(c, 0, sizeof *c);
        c->v[0] = (uint32_t)base;
        c->v[1] = (uint32_t)(base + t);
        c->v[2] = (uint32_t)(base + t + 1);
        c->v[3] = quad ? (uint32_t)(base + 3) : RAD_NONE;
        c->polygon = i;
        c->object = pg->object;
        c->material = pg->material;
        c->normal = pg->normal;
        memcpy(w->cube[w->ncell++], key, 3 * sizeof *key);
    }
    return 0;
}

/* Polygon i (its welded points) cut by the cubes its box covers. */
static int cut_polygon(swork *w, const uint32_t *pos, const uint32_t *first, uint32_t i)
{
    const rad_polygon *pg = &w->s->polygons[i];
    const size_t n = pg->point_count, cap = n + 12;
    if (GROW3(w->tmp, w->ctmp, 5 * cap) != 0)
        return -1;
    rad_vec3 *P = w->tmp, *bufs[4] = {w->tmp + cap, w->tmp + 2 * cap, w->tmp + 3 * cap,
                                      w->tmp + 4 * cap};
    int64_t from[3], to[3];
    for (size_t k = 0; k < n; k++)
        P[k] = w->s->points[first[pos[pg->first_point + k]]];
    for (int a = 0; a < 3; a++) {
        double lo = INFINITY, hi = -INFINITY;
        for (size_t k = 0; k < n; k++)
            lo = fmin(lo, comp(P[k], a)), hi = fmax(hi, comp(P[k], a));
        from[a] = (int64_t)floor((lo - comp(w->lo, a)) / w->h);
        to[a] = (int64_t)floor((hi - comp(w->lo, a)) / w->h);
        if ((double)(to[a] - from[a]) > 1e6)
            return -3;
    }
    int64_t key[3];
    for (key[0] = from[0]; key[0] <= to[0]; key[0]++) {
        double x = comp(w->lo, 0) + (double)key[0] * w->h;
        size_t nx = clip3(P, n, bufs[0], 0, x, 1);
        nx = clip3(bufs[0], nx, bufs[1], 0, x + w->h, 0);
        for (key[1] = from[1]; nx >= 3 && key[1] <= to[1]; key[1]++) {
            double y = comp(w->lo, 1) + (double)key[1] * w->h;
            size_t ny = clip3(bufs[1], nx, bufs[0], 1, y, 1);
            ny = clip3(bufs[0], ny, bufs[2], 1, y + w->h, 0);
            for (key[2] = from[2]; ny >= 3 && key[2] <= to[2]; key[2]++) {
                double z = comp(w->lo, 2) + (double)key[2] * w->h;
                size_t nz = clip3(bufs[2], ny, bufs[0], 2, z, 1);
                nz = clip3(bufs[0], nz, bufs[3], 2, z + w->h, 0);
                int rc = nz >= 3 ? add_piece(w, i, bufs[3], nz, key) : 0;
                if (rc != 0)
                    return rc;
            }
        }
    }
    return 0;
}

/* ------------------------------------------------------ unique corners */

/* Raw corners equal after rounding to 1e-7 of the size are one; cells
 * renumbered onto them (pos: each one's place), those left without area
 * dropped. */
static int unique(swork *w, rad_vec3 *pos, uint32_t *nu)
{
    const double q = 1e-7 * w->h, tiny = 1e-12 * w->h * w->h;
    mesh_key *k = malloc((w->nraw + 1) * sizeof *k);
    uint32_t *uid = malloc((w->nraw + 1) * sizeof *uid);
    if (!k || !uid) {
        free(k), free(uid);
        return -1;
    }
    for (size_t r = 0; r < w->nraw; r++) {
        for (int a = 0; a < 3; a++)
            k[r].k[a] = llround((comp(w->raw[r], a) - comp(w->lo, a)) / q);
        k[r].r = (uint32_t)r;
    }
    qsort(k, w->nraw, sizeof *k, mesh_key_cmp);
    *nu = 0;
    for (size_t e = 0; e < w->nraw; e++) {
        if (e == 0 || memcmp(k[e].k, k[e - 1].k, sizeof k[e].k) != 0)
            pos[(*nu)++] = w->raw[k[e].r];
        uid[k[e].r] = *nu - 1;
    }
    size_t kept = 0;
    for (size_t c = 0; c < w->ncell; c++) {
        rad_patch cl = w->cell[c];
        const int n = rad_patch_corners(&cl);
        for (int a = 0; a < n; a++)
            cl.v[a] = uid[cl.v[a]];
        int ok = tri_area(pos[cl.v[0]], pos[cl.v[1]], pos[cl.v[2]], cl.normal) > tiny &&
                 (n == 3 || tri_area(pos[cl.v[0]], pos[cl.v[2]], pos[cl.v[3]], cl.normal) > tiny);
        if (!ok)
            continue;
        w->cell[kept] = cl;
        memcpy(w->cube[kept++], w->cube[c], sizeof w->cube[c]);
    }
    w->ncell = kept;
    free(k), free(uid);
    return 0;
}

/* ---------------------------------------------------------------- patches */

typedef struct sgroup {
    int64_t k[3];
    rad_vec3 lead, lo, hi;
    double area;
} sgroup;

static int key_cmp3(const int64_t *a, const int64_t *b)
{
    for (int d = 0; d < 3; d++)
        if (a[d] != b[d])
            return a[d] < b[d] ? -1 : 1;
    return 0;
}

static void group_add(sgroup *g, const rad_vec3 *pos, const rad_patch *c)
{
    const int n = rad_patch_corners(c);
    g->area += tri_area(pos[c->v[0]], pos[c->v[1]], pos[c->v[2]], c->normal) +
               (n == 4 ? tri_area(pos[c->v[0]], pos[c->v[2]], pos[c->v[3]], c->normal) : 0.0);
    for (int a = 0; a < n; a++) {
        rad_vec3 p = pos[c->v[a]];
        g->lo = rad_v3(fmin(g->lo.x, p.x), fmin(g->lo.y, p.y), fmin(g->lo.z, p.z));
        g->hi = rad_v3(fmax(g->hi.x, p.x), fmax(g->hi.y, p.y), fmax(g->hi.z, p.z));
    }
}

/* Groups in each cube by a 30° lead normal; of[k]: group of sorted cell k. */
static uint32_t make_groups(const swork *w, const mesh_key *order, const rad_vec3 *pos,
                            sgroup *g, uint32_t *of)
{
    uint32_t ng = 0;
    for (size_t a = 0, z; a < w->ncell; a = z) {
        for (z = a; z < w->ncell && key_cmp3(order[z].k, order[a].k) == 0; z++)
            ;
        const uint32_t g0 = ng;
        for (size_t k = a; k < z; k++) {
            const rad_patch *c = &w->cell[order[k].r];
            uint32_t j = g0;
            while (j < ng && rad_dot(g[j].lead, c->normal) < SMOOTH_COS)
                j++;
            if (j == ng) {
                memcpy(g[ng].k, order[k].k, sizeof g[ng].k);
                g[ng].lead = c->normal;
                g[ng].area = 0.0;
                g[ng].lo = rad_v3(INFINITY, INFINITY, INFINITY);
                g[ng].hi = rad_v3(-INFINITY, -INFINITY, -INFINITY);
                ng++;
            }
            group_add(&g[j], pos, c);
            of[k] = j;
        }
    }
    return ng;
}

/* Small groups join the largest group of a face-neighbouring cube within
 * 30° of them that keeps the pair within 2 × size. */
static void merge_small(const swork *w, sgroup *g, uint32_t ng, uint32_t *up)
{
    const double longmax = SMOOTH_LONGEST * w->h * (1 + 1e-9);
    for (uint32_t a = 0; a < ng; a++) {
        if (up[a] != a || g[a].area >= SMOOTH_SLIVER * w->h * w->h)
            continue;
        uint32_t best = RAD_NONE;
        for (int nb = 0; nb < 6; nb++) {
            int64_t k[3] = {g[a].k[0], g[a].k[1], g[a].k[2]};
            k[nb / 2] += nb % 2 ? 1 : -1;
            uint32_t lo = 0, hi = ng;
            while (lo < hi) {
                uint32_t mid = lo + (hi - lo) / 2;
                if (key_cmp3(g[mid].k, k) < 0)
                    lo = mid + 1;
                else
                    hi = mid;
            }
            for (uint32_t e = lo; e < ng && key_cmp3(g[e].k, k) == 0; e++) {
                uint32_t d = mesh_uf_find(up, e);
                if (d == a || rad_dot(g[d].lead, g[a].lead) < SMOOTH_COS ||
                    (best != RAD_NONE && g[d].area <= g[best].area))
                    continue;
                rad_vec3 l = rad_v3(fmin(g[d].lo.x, g[a].lo.x), fmin(g[d].lo.y, g[a].lo.y),
                                    fmin(g[d].lo.z, g[a].lo.z));
                rad_vec3 h = rad_v3(fmax(g[d].hi.x, g[a].hi.x), fmax(g[d].hi.y, g[a].hi.y),
                                    fmax(g[d].hi.z, g[a].hi.z));
                rad_vec3 span = rad_sub(h, l);
                if (fmax(span.x, fmax(span.y, span.z)) <= longmax)
                    best = d;
            }
        }
        if (best == RAD_NONE)
            continue;
        up[a] = best;
        g[best].area += g[a].area;
        g[best].lo = rad_v3(fmin(g[best].lo.x, g[a].lo.x), fmin(g[best].lo.y, g[a].lo.y),
                            fmin(g[best].lo.z, g[a].lo.z));
        g[best].hi = rad_v3(fmax(g[best].hi.x, g[a].hi.x), fmax(g[best].hi.y, g[a].hi.y),
                            fmax(g[best].hi.z, g[a].hi.z));
    }
}

/* Patches from the cells in w (see the top of the file), appended to out. */
static int group_and_emit(swork *w, const rad_vec3 *pos, uint32_t nu, mesh_regions *out)
{
    mesh_key *order = malloc((w->ncell + 1) * sizeof *order);
    sgroup *g = malloc((w->ncell + 1) * sizeof *g);
    uint32_t *of = malloc((w->ncell + 1) * sizeof *of);
    uint32_t *up = malloc((w->ncell + 1) * sizeof *up);
    rad_patch *cells = malloc((w->ncell + 1) * sizeof *cells);
    int rc = -1;
    if (order && g && of && up && cells) {
        for (size_t c = 0; c < w->ncell; c++) {
            memcpy(order[c].k, w->cube[c], sizeof order[c].k);
            order[c].r = (uint32_t)c;
        }
        qsort(order, w->ncell, sizeof *order, mesh_key_cmp);
        uint32_t ng = make_groups(w, order, pos, g, of), np = 0;
        for (uint32_t a = 0; a < ng; a++)
            up[a] = a;
        merge_small(w, g, ng, up);
        uint32_t *pn = malloc(((size_t)ng + 1) * sizeof *pn);
        if (pn) {
            for (uint32_t a = 0; a < ng; a++)
                pn[a] = RAD_NONE;
            for (uint32_t a = 0; a < ng; a++)
                if (pn[mesh_uf_find(up, a)] == RAD_NONE)
                    pn[mesh_uf_find(up, a)] = np++;
            for (size_t k = 0; k < w->ncell; k++) {
                of[k] = pn[mesh_uf_find(up, of[k])];
                cells[k] = w->cell[order[k].r];
            }
            rc = mesh_regions_emit(out, cells, w->ncell, of, np, pos, nu);
            free(pn);
        }
    }
    free(order), free(g), free(of), free(up), free(cells);
    return rc;
}

int mesh_smooth_mesh(const rad_scene *s, const uint32_t *pos, const uint32_t *first,
                     const uint32_t *mem, uint32_t nm, double size, mesh_regions *out)
{
    rad_vec3 hi;
    swork w = {.s = s, .h = size,
               .climit = out->cell_limit > out->cells ? out->cell_limit - out->cells : 0};
    if (!rad_scene_bounds(s, &w.lo, &hi))
        return -2;
    double area = 0.0;
    for (uint32_t m = 0; m < nm; m++)
        area += s->polygons[mem[m]].area;
    int rc = mesh_regions_over(out, area / (size * size)) ? -3 : 0;
    for (uint32_t m = 0; m < nm && rc == 0; m++)
        rc = cut_polygon(&w, pos, first, mem[m]);
    if (rc == 0 && (w.nraw >= UINT32_MAX || w.ncell >= UINT32_MAX))
        rc = -3;
    rad_vec3 *P = rc == 0 ? malloc((w.nraw + 1) * sizeof *P) : NULL;
    uint32_t nu = 0;
    if (rc == 0 && (!P || unique(&w, P, &nu) != 0))
        rc = -1;
    if (rc == 0)
        rc = group_and_emit(&w, P, nu, out);
    free(P), free(w.raw), free(w.cell), free(w.cube), free(w.tmp);
    return rc;
}
