/* draw.c - what the renderer draws for elements (or patches): the crack-free
 * mesh of fans about each element's centre through its corners and the
 * T-vertices of finer neighbours on its edges, the radiosity each element
 * is drawn with (buried elements extrapolated from their seen neighbours),
 * and its fit to the vertices (quadratic for elements, the paper's average
 * for patches).  Refinement's estimate uses the same drawing, so elements
 * split where this drawing is wrong.
 *
 * Invariant: every edge drawn is shared exactly by the cells on both sides
 * (no cracks), and a linear field is drawn exactly across levels.
 */
#include "el_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A growing list of vertex indices. */
typedef struct ulist {
    uint32_t *v;
    size_t n, cap;
    int failed;
} ulist;

static void ul_push(ulist *l, uint32_t v)
{
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 64;
        uint32_t *p = realloc(l->v, cap * sizeof *p);
        if (!p) {
            l->failed = 1;
            return;
        }
        l->v = p;
        l->cap = cap;
    }
    l->v[l->n++] = v;
}

/* Pushes the vertices strictly inside edge a→b, in order from a: the
 * corners of finer neighbours, found as existing midpoints. */
static void edge_inner(const el_vtable *t, uint32_t surf, uint32_t a, uint32_t b, int depth, ulist *out)
{
    if (depth > RAD_MAX_ELEMENT_LEVEL)
        return;
    uint32_t m = el_vt_find(t, surf, el_midpoint(t->V[a], t->V[b]));
    if (m == RAD_NONE)
        return;
    edge_inner(t, surf, a, m, depth + 1, out);
    ul_push(out, m);
    edge_inner(t, surf, m, b, depth + 1, out);
}

/* The outline of a cell of surface `surf`: its corners and every vertex on
 * its edges, in counter-clockwise order, into out (cleared first). */
static void cell_outline(const el_vtable *t, const uint32_t v[4], uint32_t surf, ulist *out)
{
    out->n = 0;
    int corners = v[3] == RAD_NONE ? 3 : 4;
    for (int k = 0; k < corners; k++) {
        ul_push(out, v[k]);
        edge_inner(t, surf, v[k], v[(k + 1) % corners], 0, out);
    }
}

/* ------------------------------------------------------- render mesh */

/* The crack-free mesh of the cells of m (see rad_elements_render_mesh). */
int el_fan_mesh(const rad_mesh *m, rad_mesh **out, uint32_t **cells_of, rad_error *err)
{
    *out = NULL;
    *cells_of = NULL;
    uint32_t nv = m->vertex_count, ne = m->patch_count;
    uint32_t *Vsurf = malloc((nv ? nv : 1) * sizeof *Vsurf);
    el_vtable t = {0};
    ulist ol = {0};
    rad_mesh *rm = NULL;
    uint32_t *of = NULL;
    int rc = RAD_ERR_NOMEM;
    if (!Vsurf)
        goto done;
    el_vertex_surfaces(m, Vsurf);
    t.V = m->vertices;
    t.Vsurf = Vsurf;
    for (uint32_t v = 0; v < nv; v++)
        if (el_vt_insert(&t, v) != 0)
            goto done;
    /* Count first: a cell with k outline vertices beyond its corners becomes
     * a fan of (corners + k) triangles about one new centre vertex. */
    uint64_t cells = 0;
    for (uint32_t e = 0; e < ne; e++) {
        cell_outline(&t, m->patches[e].v, Vsurf[m->patches[e].v[0]], &ol);
        if (ol.failed)
            goto done;
        cells += ol.n;
    }
    if (cells > UINT32_MAX / 2 || (uint64_t)nv + ne > UINT32_MAX / 2) {
        rc = rad_fail(err, RAD_ERR_LIMIT, "elements: %llu cells to draw: too many",
                      (unsigned long long)cells);
        goto done;
    }
    rm = rad_mesh_alloc(nv + ne, (uint32_t)cells);
    of = malloc((size_t)(cells ? cells : 1) * sizeof *of);
    if (!rm || !of)
        goto done;
    memcpy(rm->vertices, m->vertices, (size_t)nv * sizeof *rm->vertices);
    memcpy(rm->vertex_boundary, m->vertex_boundary, (size_t)nv * sizeof *rm->vertex_boundary);
    uint32_t nc = 0, vc = nv;
    for (uint32_t e = 0; e < ne; e++) {
        const rad_patch *c = &m->patches[e];
        cell_outline(&t, c->v, Vsurf[c->v[0]], &ol);
        if (ol.failed)
            goto done;
        uint32_t centre = vc++;
        rm->vertices[centre] = c->center;
        for (size_t k = 0; k < ol.n; k++) {
            rad_patch *f = &rm->patches[nc];
            *f = *c;
            f->v[0] = centre;
            f->v[1] = ol.v[k];
            f->v[2] = ol.v[(k + 1) % ol.n];
            f->v[3] = RAD_NONE;
            if (rad_cell_geometry(rm->vertices, f->v, f->normal, &f->center, &f->area) != 0) {
                rc = rad_fail(err, RAD_ERR_CORRUPT, "elements: element %u: degenerate fan", e);
                goto done;
            }
            /* The fan carries the element's B, which belongs to the
             * element's centre (the fan's apex, a point of every triangle):
             * the renderer's vertex fits sample B there. */
            f->center = c->center;
            of[nc++] = e;
        }
    }
    RAD_ASSERT(nc == cells && vc == rm->vertex_count);
    *out = rm;
    *cells_of = of;
    rm = NULL;
    of = NULL;
    rc = RAD_OK;
done:
    if (rc == RAD_ERR_NOMEM)
        rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the render mesh");
    rad_mesh_destroy(rm);
    free(of);
    free(Vsurf);
    free(t.slot);
    free(ol.v);
    return rc;
}

int rad_elements_render_mesh(const rad_elements *el, rad_mesh **out, uint32_t **cells_of,
                             rad_error *err)
{
    return el_fan_mesh(el->mesh, out, cells_of, err);
}

/* ------------------------------------------------ what the renderer draws */

/* Does an element see nothing?  Its hemi-cube found no front face of
 * anything (an empty row: for a level-0 element its patch's row, when
 * computed) and it receives nothing (B = E).  In a room that is an element
 * buried under a block resting on it: its hemi-cube sees only the block's
 * back faces. */
int el_sees_nothing(const rad_solution *s, uint32_t p, uint32_t level, int interp,
                    uint32_t row_count, const double *Be)
{
    const uint32_t bands = s->band_count;
    if (interp)
        return 0;
    if (level == 0) {
        if (!s->F || !s->F->row_done[p] || s->F->row_count[p] != 0)
            return 0;
    } else if (row_count != 0) {
        return 0;
    }
    for (uint32_t c = 0; c < bands; c++)
        if (Be[c] != s->emission[(size_t)p * bands + c])
            return 0;
    return 1;
}

/* ------------------------------------------------ clusters drawn smoothly */

int rad_elements_of_cells(const rad_solution *s, rad_elements **out, rad_error *err)
{
    const rad_mesh *pm = s->mesh;
    const uint32_t bands = s->band_count;
    const uint32_t count = pm->cell_first ? pm->cell_count : pm->patch_count;
    *out = NULL;
    rad_elements *el = rad_element_store_alloc(pm->vertex_count, count, bands, 0);
    if (!el)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for %u cells", count);
    memcpy(el->mesh->vertices, pm->vertices, (size_t)pm->vertex_count * sizeof *pm->vertices);
    memcpy(el->mesh->vertex_boundary, pm->vertex_boundary, pm->vertex_count);
    for (uint32_t i = 0, e = 0; i < pm->patch_count; i++) {
        const rad_patch *cells;
        const uint32_t k = rad_patch_cells(pm, i, &cells);
        for (uint32_t q = 0; q < k; q++, e++) {
            el->mesh->patches[e] = cells[q];
            el->patch[e] = i;
            memcpy(el->B + (size_t)e * bands, s->B + (size_t)i * bands, bands * sizeof *el->B);
        }
    }
    *out = el;
    return RAD_OK;
}

/* The patches that share a vertex with each patch of pm (through their
 * cells), as compressed rows: patch p's are adj[start[p] .. start[p+1]). */
static int patch_neighbours(const rad_mesh *pm, uint64_t **start_out, uint32_t **adj_out)
{
    const uint32_t np = pm->patch_count, nv = pm->vertex_count;
    uint64_t *vstart = calloc((size_t)nv + 1, sizeof *vstart), *start = NULL;
    uint32_t *vadj = NULL, *stamp = calloc((size_t)np + 1, sizeof *stamp), *adj = NULL;
    int rc = -1;
    if (!vstart || !stamp)
        goto done;
    /* vertex -> patches using it (a patch once per cell corner) */
    for (uint32_t i = 0; i < np; i++) {
        const rad_patch *c;
        for (uint32_t q = 0, k = rad_patch_cells(pm, i, &c); q < k; q++)
            for (int j = 0; j < rad_patch_corners(&c[q]); j++)
                vstart[c[q].v[j] + 1]++;
    }
    for (uint32_t v = 0; v < nv; v++)
        vstart[v + 1] += vstart[v];
    vadj = malloc((size_t)(vstart[nv] + 1) * sizeof *vadj);
    start = calloc((size_t)np + 1, sizeof *start);
    if (!vadj || !start)
        goto done;
    for (uint32_t i = 0; i < np; i++) {
        const rad_patch *c;
        for (uint32_t q = 0, k = rad_patch_cells(pm, i, &c); q < k; q++)
            for (int j = 0; j < rad_patch_corners(&c[q]); j++)
                vadj[vstart[c[q].v[j]]++] = i;
    }
    for (uint32_t v = nv; v > 0; v--)
        vstart[v] = vstart[v - 1];
    vstart[0] = 0;
    /* patch -> distinct other patches on its cells' corners: count, then fill */
    for (int pass = 0; pass < 2; pass++) {
        uint64_t used = 0;
        for (uint32_t i = 0; i < np; i++) {
            const rad_patch *c;
            if (pass)
                start[i] = used;
            for (uint32_t q = 0, k = rad_patch_cells(pm, i, &c); q < k; q++)
                for (int j = 0; j < rad_patch_corners(&c[q]); j++)
                    for (uint64_t a = vstart[c[q].v[j]]; a < vstart[c[q].v[j] + 1]; a++) {
                        uint32_t o = vadj[a];
                        if (o == i || stamp[o] == 2 * i + 1 + (uint32_t)pass)
                            continue;
                        stamp[o] = 2 * i + 1 + (uint32_t)pass;
                        if (pass)
                            adj[used] = o;
                        used++;
                    }
        }
        if (!pass) {
            memset(stamp, 0, ((size_t)np + 1) * sizeof *stamp);
            adj = malloc((size_t)(used + 1) * sizeof *adj);
            if (!adj)
                goto done;
        } else {
            start[np] = used;
        }
    }
    *start_out = start;
    *adj_out = adj;
    start = NULL;
    adj = NULL;
    rc = 0;
done:
    free(vstart);
    free(vadj);
    free(stamp);
    free(start);
    free(adj);
    return rc;
}

/* What a level-0 element of a cluster is drawn with: a cluster is one
 * patch of many cells, and drawing each cell with the patch's B would show
 * the clusters as flat tiles.  The patch's B belongs to its centre, as a
 * patch's does; at point x of cluster p the drawing takes the affine
 * least-squares fit, in p's plane, of the B of p and of the patches sharing
 * a vertex with it (those that see something: a buried patch's B = E says
 * nothing of its neighbourhood) at their centres, limited to the range of
 * those B and to >= 0.  The vertex fits then run smoothly across the
 * cells as across the patches of a polygon.  pB is the patches' field so
 * drawn (s->B, or another field of the patches: element_gather.c's el_interp). */
static void cluster_value(const rad_solution *s, const double *pB, const uint64_t *start,
                          const uint32_t *adj, const uint8_t *dark, uint32_t p, rad_vec3 x,
                          double *sx, double *sy, double *w, uint32_t *id, double *out)
{
    const uint32_t bands = s->band_count;
    const rad_patch *pp = &s->mesh->patches[p];
    size_t n = 0;
    if (!dark[p])
        id[n++] = p;
    for (uint64_t a = start[p]; a < start[p + 1]; a++)
        if (!dark[adj[a]])
            id[n++] = adj[a];
    memcpy(out, pB + (size_t)p * bands, bands * sizeof *out);
    if (n < 2)
        return;
    rad_vec3 a0 = fabs(pp->normal.x) < 0.6 ? rad_v3(1, 0, 0) : rad_v3(0, 1, 0);
    rad_vec3 e1 = rad_normalize(rad_cross(pp->normal, a0)), e2 = rad_cross(pp->normal, e1);
    for (size_t k = 0; k < n; k++) {
        rad_vec3 d = rad_sub(s->mesh->patches[id[k]].center, x);
        sx[k] = rad_dot(d, e1);
        sy[k] = rad_dot(d, e2);
    }
    rn_affine_weights(sx, sy, n, w);
    for (uint32_t c = 0; c < bands; c++) {
        double v = 0.0, lo = INFINITY, hi = -INFINITY;
        for (size_t k = 0; k < n; k++) {
            double b = pB[(size_t)id[k] * bands + c];
            v += w[k] * b;
            lo = fmin(lo, b);
            hi = fmax(hi, b);
        }
        v = v >= lo ? fmin(v, hi) : lo; /* NaN -> lo too */
        out[c] = v > 0.0 ? v : 0.0;
    }
}

/* out[e] of the level-0 elements of clusters (see cluster_value), from
 * the patches' field pB. */
static int draw_clusters(const rad_solution *s, const rad_elements *el, const double *pB,
                         double *out, rad_error *err)
{
    const rad_mesh *pm = s->mesh;
    const uint32_t np = pm->patch_count, bands = s->band_count;
    uint64_t *start = NULL;
    uint32_t *adj = NULL, *id = NULL;
    uint8_t *dark = calloc((size_t)np + 1, 1);
    double *buf = NULL;
    int rc = RAD_ERR_NOMEM;
    if (!dark || patch_neighbours(pm, &start, &adj) != 0)
        goto done;
    uint64_t most = 0;
    for (uint32_t i = 0; i < np; i++) {
        most = start[i + 1] - start[i] > most ? start[i + 1] - start[i] : most;
        dark[i] = (uint8_t)el_sees_nothing(s, i, 0, 0, 0, s->B + (size_t)i * bands);
    }
    buf = malloc(3 * (size_t)(most + 1) * sizeof *buf);
    id = malloc((size_t)(most + 1) * sizeof *id);
    if (!buf || !id)
        goto done;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        const uint32_t p = el->patch[e];
        if (el->level[e] == 0 && pm->cell_first[p + 1] - pm->cell_first[p] > 1 && !dark[p])
            cluster_value(s, pB, start, adj, dark, p, el->mesh->patches[e].center, buf,
                          buf + most + 1, buf + 2 * (most + 1), id, out + (size_t)e * bands);
    }
    rc = RAD_OK;
done:
    if (rc != RAD_OK)
        rad_fail(err, rc, "elements: out of memory for the clusters' drawing");
    free(dark);
    free(start);
    free(adj);
    free(buf);
    free(id);
    return rc;
}

int rad_elements_drawn_radiosity(const rad_solution *s, const rad_elements *el, const rad_mesh *rm,
                                 const uint32_t *cells_of, double *out, rad_error *err)
{
    return el_drawn_field(s, el, rm, cells_of, el ? el->B : s->B, s->B, out, err);
}

/* The drawing mesh rm's vertex -> the elements using it (CSR: start[nv + 1]
 * into adj), and element -> its first cell of rm (first[n]; the cells of
 * one element are consecutive, cells_of[k] the element of cell k, NULL:
 * cell k is element k).  Caller frees the three; -1 on OOM (none left). */
static int vertex_elements(const rad_mesh *rm, uint32_t n, const uint32_t *cells_of,
                           uint64_t **start_out, uint32_t **adj_out, uint32_t **first_out)
{
    const uint32_t nv = rm->vertex_count, nc = rm->patch_count;
    uint64_t *start = calloc((size_t)nv + 1, sizeof *start);
    uint64_t *fill = malloc(((size_t)nv + 1) * sizeof *fill);
    uint32_t *first = malloc(((size_t)n + 1) * sizeof *first), *adj = NULL;
    if (start && fill && first) {
        for (uint32_t k = 0; k < nc; k++)
            for (int c = 0; c < rad_patch_corners(&rm->patches[k]); c++)
                start[rm->patches[k].v[c] + 1]++;
        for (uint32_t v = 0; v < nv; v++)
            start[v + 1] += start[v];
        adj = malloc((size_t)(start[nv] ? start[nv] : 1) * sizeof *adj);
    }
    if (!adj) {
        free(start);
        free(fill);
        free(first);
        return -1;
    }
    memcpy(fill, start, ((size_t)nv + 1) * sizeof *fill);
    for (uint32_t k = nc; k-- > 0;) {
        uint32_t e = cells_of ? cells_of[k] : k;
        first[e] = k;
        for (int c = 0; c < rad_patch_corners(&rm->patches[k]); c++)
            adj[fill[rm->patches[k].v[c]]++] = e;
    }
    free(fill);
    *start_out = start;
    *adj_out = adj;
    *first_out = first;
    return 0;
}

int el_drawn_field(const rad_solution *s, const rad_elements *el, const rad_mesh *rm,
                   const uint32_t *cells_of, const double *field, const double *pfield,
                   double *out, rad_error *err)
{
    const uint32_t bands = s->band_count;
    const rad_mesh *cells = el ? el->mesh : s->mesh;
    const double *B = el ? el->B : s->B;
    const uint32_t n = cells->patch_count, nc = rm->patch_count;
    memcpy(out, field, (size_t)n * bands * sizeof *out);
    if (el && s->mesh->cell_first) {
        int rc = draw_clusters(s, el, pfield, out, err);
        if (rc != RAD_OK)
            return rc;
    }
    uint8_t *buried = calloc(n ? n : 1, 1);
    uint32_t nb = 0;
    if (!buried)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the drawn radiosity");
    for (uint32_t e = 0; e < n; e++) {
        uint32_t p = el ? el->patch[e] : e;
        buried[e] = (uint8_t)el_sees_nothing(s, p, el ? el->level[e] : 0,
                                             el && el->interp ? el->interp[e] : 0,
                                             el ? el->row_count[e] : 0, B + (size_t)e * bands);
        nb += buried[e];
    }
    if (!nb) {
        free(buried);
        return RAD_OK;
    }
    uint64_t *start = NULL;
    uint32_t *first = NULL, *adj = NULL, *stamp = calloc(n ? n : 1, sizeof *stamp);
    double *x = NULL, *y = NULL, *w = NULL;
    uint32_t *id = NULL;
    int rc = RAD_ERR_NOMEM;
    if (!stamp || vertex_elements(rm, n, cells_of, &start, &adj, &first) != 0)
        goto done;
    size_t cap = 64;
    x = malloc(cap * sizeof *x);
    y = malloc(cap * sizeof *y);
    w = malloc(cap * sizeof *w);
    id = malloc(cap * sizeof *id);
    if (!x || !y || !w || !id)
        goto done;
    for (uint32_t h = 0; h < n; h++) {
        if (!buried[h])
            continue;
        /* Plane coordinates along h's first edge and across it. */
        const rad_patch *ph = &cells->patches[h];
        rad_vec3 e1 = rad_normalize(rad_sub(cells->vertices[ph->v[1]], cells->vertices[ph->v[0]]));
        rad_vec3 e2 = rad_cross(ph->normal, e1);
        size_t ns = 0;
        for (uint32_t k = first[h]; k < nc && (cells_of ? cells_of[k] : k) == h; k++)
            for (int c = 0; c < rad_patch_corners(&rm->patches[k]); c++) {
                uint32_t v = rm->patches[k].v[c];
                for (uint64_t q = start[v]; q < start[v + 1]; q++) {
                    uint32_t f = adj[q];
                    if (buried[f] || stamp[f] == h + 1)
                        continue;
                    stamp[f] = h + 1;
                    if (ns == cap) {
                        cap *= 2;
                        double *nx = realloc(x, cap * sizeof *x), *ny = realloc(y, cap * sizeof *y),
                               *nw = realloc(w, cap * sizeof *w);
                        uint32_t *ni = realloc(id, cap * sizeof *id);
                        x = nx ? nx : x;
                        y = ny ? ny : y;
                        w = nw ? nw : w;
                        id = ni ? ni : id;
                        if (!nx || !ny || !nw || !ni)
                            goto done;
                    }
                    rad_vec3 d = rad_sub(cells->patches[f].center, ph->center);
                    x[ns] = rad_dot(d, e1);
                    y[ns] = rad_dot(d, e2);
                    id[ns++] = f;
                }
            }
        if (!ns)
            continue; /* far from anything seen: keeps its own B */
        rn_affine_weights(x, y, ns, w);
        for (uint32_t c = 0; c < bands; c++) {
            double v = 0.0;
            for (size_t k = 0; k < ns; k++)
                v += w[k] * field[(size_t)id[k] * bands + c];
            out[(size_t)h * bands + c] = v > 0.0 ? v : 0.0;
        }
    }
    rc = RAD_OK;
done:
    if (rc != RAD_OK)
        rad_fail(err, rc, "elements: out of memory for the drawn radiosity");
    free(buried);
    free(start);
    free(first);
    free(adj);
    free(stamp);
    free(x);
    free(y);
    free(w);
    free(id);
    return rc;
}

int rad_elements_vertex_radiosity(const rad_solution *s, const rad_elements *el,
                                  const rad_mesh *rm, const uint32_t *cells_of, double *drawn,
                                  double *vertex_B, rad_error *err)
{
    const uint32_t bands = s->band_count;
    const uint32_t n = el ? el->mesh->patch_count : s->mesh->patch_count;
    double *own = drawn ? NULL : malloc(((size_t)n * bands + 1) * sizeof *own);
    double *cell_B = malloc(((size_t)rm->patch_count * bands + 1) * sizeof *cell_B);
    double *d = drawn ? drawn : own;
    int rc = RAD_OK;
    if (!d || !cell_B) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "render: out of memory for the vertex radiosities");
        goto done;
    }
    if ((rc = rad_elements_drawn_radiosity(s, el, rm, cells_of, d, err)) != RAD_OK)
        goto done;
    for (uint32_t k = 0; k < rm->patch_count; k++)
        memcpy(cell_B + (size_t)k * bands, d + (size_t)(cells_of ? cells_of[k] : k) * bands,
               bands * sizeof *cell_B);
    rn_vertex_radiosity_fit(rm, bands, cell_B, vertex_B, el ? RN_FIT_QUADRATIC : RN_FIT_AFFINE);
done:
    free(own);
    free(cell_B);
    return rc;
}

void el_drawn_at(const rad_mesh *rm, const double *vB, uint32_t bands, uint32_t first,
                 uint32_t count, rad_vec3 normal, rad_vec3 p, double *out)
{
    const rad_patch *c = &rm->patches[first];
    /* The fan triangle that holds p best (largest smallest weight). */
    double best = -INFINITY, l[3] = {1 / 3., 1 / 3., 1 / 3.};
    for (uint32_t t = first; t < first + count; t++) {
        const rad_patch *f = &rm->patches[t];
        rad_vec3 a = rm->vertices[f->v[0]], bb = rm->vertices[f->v[1]], cc = rm->vertices[f->v[2]];
        double whole = rad_dot(rad_cross(rad_sub(bb, a), rad_sub(cc, a)), normal);
        if (!(whole != 0.0))
            continue;
        double m[3] = {rad_dot(rad_cross(rad_sub(bb, p), rad_sub(cc, p)), normal) / whole,
                       rad_dot(rad_cross(rad_sub(cc, p), rad_sub(a, p)), normal) / whole, 0};
        m[2] = 1.0 - m[0] - m[1];
        double lo = fmin(m[0], fmin(m[1], m[2]));
        if (lo > best) {
            best = lo;
            c = f;
            memcpy(l, m, sizeof l);
        }
    }
    for (uint32_t b = 0; b < bands; b++) {
        out[b] = 0.0;
        for (int k = 0; k < 3; k++)
            out[b] += l[k] * vB[(size_t)c->v[k] * bands + b];
    }
}
