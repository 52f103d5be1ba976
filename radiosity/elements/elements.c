/* elements.c - substructuring: patches shoot, elements receive (Cohen,
 * Greenberg, Immel & Brock 1986).
 *
 * Owns the rad_elements store (solution.h), the gather
 *   B_e = E_p + ρ_p (Σ_j F_ej B_j + H_d,e) + τ_p H_twin(p),   H_d,e = Σ_l I_l h_le,
 * the direct light of the punctual lights at each element (h_le: unit
 * strength, at the element's centre, visibility from the light's item
 * buffer: hc_light_direct × hc_light_visibility) and, on the sides of a
 * transmitting sheet, what comes through from the other side's patch;
 * adaptive refinement (rad_solution_refine, pipeline.h), the crack-free
 * mesh the renderer draws and the radiosity it draws on it (buried
 * elements extrapolated from their seen neighbours).  Refinement splits
 * where the drawn radiosity misses what a finer element gathers: each leaf
 * is probed (its four children gathered) and split when the children's B
 * differ from what the renderer draws at their centres by more than the
 * threshold, weighted by the leaf's area, or when it lies across the foot
 * of a block, part seen and part buried (see estimate).  An element is its
 * patch split `level` times as a quadtree; vertices are found again by
 * their exact position within their surface (one side of a polygon; a
 * midpoint is computed as (a + b)/2 from the two ends, which is the same
 * double whichever side computes it), so neighbours share them and a vertex
 * of a finer neighbour that lies on an element's edge (a T-vertex) is found
 * by looking up the edge's midpoints recursively.
 *
 * Invariant: a leaf element of level k > 0 has its own row F_ej from a
 * hemi-cube at its centre, and (when the scene has punctual lights) its own
 * h_le, computed before its B_e is gathered, so the refinement rule sees
 * shadow edges finer than the patches; level-0 elements are their patches
 * (B_e = B_p, exactly the patch's own equation, whose H_d,p is the patch
 * average Φ_lp / A_p).
 */
#include "../pipeline/pipeline.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------ storage */

rad_elements *rad_elements_alloc(uint32_t vertex_count, uint32_t count, uint32_t bands,
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
        rad_elements_destroy(el);
        return NULL;
    }
    el->capacity = entries;
    return el;
}

void rad_elements_destroy(rad_elements *el)
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
    free(el);
}

int rad_elements_complete(rad_elements *el, const rad_solution *s, const char *name,
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
        const rad_patch *pp = &pm->patches[p];
        c->polygon = pp->polygon;
        c->object = pp->object;
        c->material = pp->material;
        c->normal = pp->normal;
        for (int k = 0; k < rad_patch_corners(c); k++)
            if (c->v[k] >= m->vertex_count)
                return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: vertex %u out of range", name,
                                e, c->v[k]);
        if (rad_cell_geometry(m->vertices, c->v, c->normal, &c->center, &c->area) != 0)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: element %u: area is not positive", name, e);
    }
    return rad_elements_check(el, s, name, err);
}

int rad_elements_check(const rad_elements *el, const rad_solution *s, const char *name,
                       rad_error *err)
{
    const rad_mesh *pm = s->mesh, *m = el->mesh;
    const uint32_t bands = s->band_count;
    if (!m || !el->patch || !el->level || !el->B || !el->row_start || !el->row_count ||
        (el->nnz && (!el->col || !el->val)) || el->nnz > el->capacity)
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
        const rad_patch *pp = &pm->patches[p];
        if (c->polygon != pp->polygon || c->object != pp->object || c->material != pp->material)
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
        for (uint32_t q = 0; q < cnt; q++) {
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
    if (!(el->threshold >= 0.0) || !isfinite(el->threshold) || !(el->min_size >= 0.0) ||
        !isfinite(el->min_size))
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: elements: bad threshold or minimum size", name);
    return RAD_OK;
}

/* ------------------------------------------------------------- gather */

/* H_d,e of one element per band into hd: Σ_l I_l h_le from its own h[]
 * (light_count values), or for a level-0 element and without them its
 * patch's H_d,p from Hd (NULL: no direct light). */
static void element_direct(const rad_solution *s, const double *Hd, const float *h, uint32_t p,
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
static void gather_one(const rad_solution *s, const double *hd, const double *Tr, uint32_t p,
                       uint32_t level, const uint32_t *col, const float *val, uint32_t cnt,
                       double *Be)
{
    const uint32_t bands = s->band_count;
    const size_t pb = (size_t)p * bands;
    if (level == 0) {
        memcpy(Be, s->B + pb, bands * sizeof *Be);
        return;
    }
    for (uint32_t b = 0; b < bands; b++) {
        double h = hd[b];
        for (uint32_t q = 0; q < cnt; q++)
            h += (double)val[q] * s->B[(size_t)col[q] * bands + b];
        double v = s->emission[pb + b] + s->rho[pb + b] * h + (Tr ? Tr[pb + b] : 0.0);
        Be[b] = v > 0.0 ? v : 0.0;
    }
}

/* τ_p H_twin(p) of every patch when the mesh has two-sided sheets, else
 * NULL: what reaches an element through its sheet, taken at the patch's
 * resolution (the twin's irradiance from its own row). */
static int transmitted(const rad_solution *s, double **out, rad_error *err)
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
        element_direct(s, patch_Hd, own_light(el, e), el->patch[e], el->level[e],
                       Hd + (size_t)e * bands);
    free(patch_Hd);
    return RAD_OK;
}

int rad_elements_gather(const rad_solution *s, rad_elements *el, rad_error *err)
{
    if (!s || !el)
        return rad_fail(err, RAD_ERR_USAGE, "rad_elements_gather: solution and elements must be given");
    double *Hd, *Tr = NULL;
    int rc = direct_irradiance(s, &Hd, err);
    if (rc == RAD_OK)
        rc = transmitted(s, &Tr, err);
    const uint32_t bands = s->band_count;
    double hd[RAD_MAX_BANDS];
    for (uint32_t e = 0; rc == RAD_OK && e < el->mesh->patch_count; e++) {
        element_direct(s, Hd, own_light(el, e), el->patch[e], el->level[e], hd);
        gather_one(s, hd, Tr, el->patch[e], el->level[e], el->col + el->row_start[e],
                   el->val + el->row_start[e], el->row_count[e], el->B + (size_t)e * bands);
    }
    free(Hd);
    free(Tr);
    return rc;
}

/* -------------------------------------------------- vertices by position */

/* A surface is one side of one polygon: 2·polygon, + 1 when the cell's
 * normal has its largest component negative.  The two sides of a
 * transmitting sheet have opposite normals, hence different surfaces, and
 * never share a vertex (their radiosities differ); every cell of one side
 * carries its polygon's normal, hence the same surface. */
static uint32_t surface_of(const rad_patch *c)
{
    rad_vec3 n = c->normal;
    double big = n.x;
    if (fabs(n.y) > fabs(big))
        big = n.y;
    if (fabs(n.z) > fabs(big))
        big = n.z;
    return 2u * c->polygon + (big < 0.0);
}

/* Open-addressing table of vertex indices keyed by (surface, exact
 * position).  The vertex arrays live with the caller; the table keeps a
 * pointer to them, refreshed after each growth. */
typedef struct vtable {
    uint32_t *slot;          /* vertex + 1, 0 = empty */
    size_t cap;              /* power of two */
    uint32_t count;
    const rad_vec3 *V;       /* positions */
    const uint32_t *Vsurf;   /* surface of each vertex */
} vtable;

static uint64_t vhash(uint32_t surf, rad_vec3 p)
{
    uint64_t w[3], h = 0x9E3779B97F4A7C15ull ^ surf;
    /* +0.0 makes -0 and 0 the same key. */
    double c[3] = {p.x + 0.0, p.y + 0.0, p.z + 0.0};
    memcpy(w, c, sizeof w);
    for (int k = 0; k < 3; k++) {
        h ^= w[k];
        h *= 0xff51afd7ed558ccdull;
        h ^= h >> 33;
    }
    return h;
}

static int same(rad_vec3 a, rad_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

static uint32_t vt_find(const vtable *t, uint32_t surf, rad_vec3 p)
{
    size_t mask = t->cap - 1;
    for (size_t h = vhash(surf, p) & mask;; h = (h + 1) & mask) {
        uint32_t s = t->slot[h];
        if (!s)
            return RAD_NONE;
        if (t->Vsurf[s - 1] == surf && same(t->V[s - 1], p))
            return s - 1;
    }
}

/* Inserts vertex v (already in the caller's arrays); doubles the table
 * when half full.  -1 on OOM. */
static int vt_insert(vtable *t, uint32_t v)
{
    if (2 * ((size_t)t->count + 1) > t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 1024;
        uint32_t *slot = calloc(cap, sizeof *slot);
        if (!slot)
            return -1;
        for (size_t k = 0; k < t->cap; k++)
            if (t->slot[k]) {
                uint32_t w = t->slot[k] - 1;
                size_t h = vhash(t->Vsurf[w], t->V[w]) & (cap - 1);
                while (slot[h])
                    h = (h + 1) & (cap - 1);
                slot[h] = t->slot[k];
            }
        free(t->slot);
        t->slot = slot;
        t->cap = cap;
    }
    size_t mask = t->cap - 1, h = vhash(t->Vsurf[v], t->V[v]) & mask;
    while (t->slot[h])
        h = (h + 1) & mask;
    t->slot[h] = v + 1;
    t->count++;
    return 0;
}

static rad_vec3 midpoint(rad_vec3 a, rad_vec3 b)
{
    return rad_v3((a.x + b.x) * 0.5, (a.y + b.y) * 0.5, (a.z + b.z) * 0.5);
}

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
static void edge_inner(const vtable *t, uint32_t surf, uint32_t a, uint32_t b, int depth, ulist *out)
{
    if (depth > RAD_MAX_ELEMENT_LEVEL)
        return;
    uint32_t m = vt_find(t, surf, midpoint(t->V[a], t->V[b]));
    if (m == RAD_NONE)
        return;
    edge_inner(t, surf, a, m, depth + 1, out);
    ul_push(out, m);
    edge_inner(t, surf, m, b, depth + 1, out);
}

/* The outline of a cell of surface `surf`: its corners and every vertex on
 * its edges, in counter-clockwise order, into out (cleared first). */
static void cell_outline(const vtable *t, const uint32_t v[4], uint32_t surf, ulist *out)
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
static int fan_mesh(const rad_mesh *m, rad_mesh **out, uint32_t **cells_of, rad_error *err)
{
    *out = NULL;
    *cells_of = NULL;
    uint32_t nv = m->vertex_count, ne = m->patch_count;
    uint32_t *Vsurf = malloc((nv ? nv : 1) * sizeof *Vsurf);
    vtable t = {0};
    ulist ol = {0};
    rad_mesh *rm = NULL;
    uint32_t *of = NULL;
    int rc = RAD_ERR_NOMEM;
    if (!Vsurf)
        goto done;
    for (uint32_t e = 0; e < ne; e++)
        for (int k = 0; k < rad_patch_corners(&m->patches[e]); k++)
            Vsurf[m->patches[e].v[k]] = surface_of(&m->patches[e]);
    t.V = m->vertices;
    t.Vsurf = Vsurf;
    for (uint32_t v = 0; v < nv; v++)
        if (vt_insert(&t, v) != 0)
            goto done;
    /* Count first: a cell with k outline vertices beyond its corners becomes
     * a fan of (corners + k) triangles about one new centre vertex. */
    uint64_t cells = 0;
    for (uint32_t e = 0; e < ne; e++) {
        cell_outline(&t, m->patches[e].v, surface_of(&m->patches[e]), &ol);
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
        cell_outline(&t, c->v, surface_of(c), &ol);
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
    return fan_mesh(el->mesh, out, cells_of, err);
}

/* ------------------------------------------------ what the renderer draws */

/* Does an element see nothing?  Its hemi-cube found no front face of
 * anything (an empty row: for a level-0 element its patch's row, when
 * computed) and it receives nothing (B = E).  In a room that is an element
 * buried under a block resting on it: its hemi-cube sees only the block's
 * back faces. */
static int sees_nothing(const rad_solution *s, uint32_t p, uint32_t level, uint32_t row_count,
                        const double *Be)
{
    const uint32_t bands = s->band_count;
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

int rad_solution_drawn_radiosity(const rad_solution *s, const rad_elements *el, const rad_mesh *rm,
                                 const uint32_t *cells_of, double *out, rad_error *err)
{
    const uint32_t bands = s->band_count;
    const rad_mesh *cells = el ? el->mesh : s->mesh;
    const double *B = el ? el->B : s->B;
    const uint32_t n = cells->patch_count, nv = rm->vertex_count, nc = rm->patch_count;
    memcpy(out, B, (size_t)n * bands * sizeof *out);
    uint8_t *buried = calloc(n ? n : 1, 1);
    uint32_t nb = 0;
    if (!buried)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the drawn radiosity");
    for (uint32_t e = 0; e < n; e++) {
        uint32_t p = el ? el->patch[e] : e;
        buried[e] = (uint8_t)sees_nothing(s, p, el ? el->level[e] : 0, el ? el->row_count[e] : 0,
                                          B + (size_t)e * bands);
        nb += buried[e];
    }
    if (!nb) {
        free(buried);
        return RAD_OK;
    }
    /* Drawing vertex -> elements using it; element -> its first cell (the
     * cells of one element are consecutive). */
    uint64_t *start = calloc((size_t)nv + 1, sizeof *start);
    uint32_t *first = malloc(((size_t)n + 1) * sizeof *first), *adj = NULL, *stamp = NULL;
    double *x = NULL, *y = NULL, *w = NULL;
    uint32_t *id = NULL;
    int rc = RAD_ERR_NOMEM;
    if (!start || !first)
        goto done;
    for (uint32_t k = 0; k < nc; k++)
        for (int c = 0; c < rad_patch_corners(&rm->patches[k]); c++)
            start[rm->patches[k].v[c] + 1]++;
    for (uint32_t v = 0; v < nv; v++)
        start[v + 1] += start[v];
    adj = malloc((size_t)(start[nv] ? start[nv] : 1) * sizeof *adj);
    stamp = calloc(n ? n : 1, sizeof *stamp);
    if (!adj || !stamp)
        goto done;
    {
        uint64_t *fill = malloc(((size_t)nv + 1) * sizeof *fill);
        if (!fill)
            goto done;
        memcpy(fill, start, ((size_t)nv + 1) * sizeof *fill);
        for (uint32_t k = nc; k-- > 0;) {
            uint32_t e = cells_of ? cells_of[k] : k;
            first[e] = k;
            for (int c = 0; c < rad_patch_corners(&rm->patches[k]); c++)
                adj[fill[rm->patches[k].v[c]]++] = e;
        }
        free(fill);
    }
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
                v += w[k] * B[(size_t)id[k] * bands + c];
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

int rad_solution_vertex_radiosity(const rad_solution *s, const rad_elements *el,
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
    if ((rc = rad_solution_drawn_radiosity(s, el, rm, cells_of, d, err)) != RAD_OK)
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

/* ---------------------------------------------------------- refinement */

/* Every element made so far while refining: the leaves, the parents they
 * were split from, and probes (the four children of a leaf, gathered to
 * test whether the leaf should split; kept only if it does, and then they
 * reuse their rows: a kept split costs no hemi-cube beyond its probes). */
enum { NODE_LEAF = 0, NODE_SPLIT, NODE_PROBE };

typedef struct enode {
    uint32_t v[4];     /* corners; v[3] == RAD_NONE for a triangle */
    uint32_t patch;
    uint32_t kids;     /* first of its four children (probes or split), RAD_NONE: none */
    uint8_t level;
    uint8_t state;     /* NODE_* */
    uint8_t settled;   /* 1: not worth probing (see refine_adaptive) */
    uint32_t cnt;      /* row entries */
    uint64_t start;    /* first row entry */
} enode;

typedef struct builder {
    rad_solution *s;
    const double *Tr;  /* transmitted (τ_p H_twin(p)), or NULL */
    uint32_t bands;
    /* punctual lights: h_le of every element, ne × nl (level 0: 0) */
    uint32_t nl;
    uint32_t light_R;  /* item-buffer resolution at the lights */
    float *h;
    uint64_t lights_rendered;
    /* vertices */
    rad_vec3 *V;
    uint8_t *Vb;
    uint32_t *Vsurf;
    uint32_t nv, cap_v;
    vtable t;
    /* elements */
    enode *E;
    double *B;         /* ne × bands */
    uint32_t ne, cap_e;
    /* rows */
    uint32_t *col;
    float *val;
    uint64_t nnz, cap_r;
    /* the elements of the rows being computed (receiver k -> which[k]) */
    const uint32_t *which;
    uint64_t rows_computed;
} builder;

/* Is p on an edge of polygon poly's outline?  Decides the boundary flag of
 * a new vertex (the renderer extrapolates outline vertices). */
static int on_outline(const rad_scene *sc, uint32_t poly, rad_vec3 p)
{
    const rad_polygon *pg = &sc->polygons[poly];
    const rad_vec3 *P = sc->points + pg->first_point;
    for (uint32_t k = 0; k < pg->point_count; k++) {
        rad_vec3 a = P[k], b = P[(k + 1) % pg->point_count], ab = rad_sub(b, a);
        double len2 = rad_dot(ab, ab);
        if (!(len2 > 0.0))
            continue;
        double u = rad_dot(rad_sub(p, a), ab) / len2;
        if (u < -1e-9 || u > 1.0 + 1e-9)
            continue;
        rad_vec3 d = rad_sub(p, rad_add(a, rad_scale(ab, u)));
        if (rad_dot(d, d) <= 1e-18 * len2)
            return 1;
    }
    return 0;
}

/* The vertex at p on surface surf, made when missing; RAD_NONE on OOM. */
static uint32_t vertex_at(builder *b, uint32_t surf, rad_vec3 p, int maybe_outline)
{
    uint32_t v = b->nv ? vt_find(&b->t, surf, p) : RAD_NONE;
    if (v != RAD_NONE)
        return v;
    if (b->nv == b->cap_v) {
        uint32_t cap = b->cap_v ? 2 * b->cap_v : 1024;
        rad_vec3 *V = realloc(b->V, (size_t)cap * sizeof *V);
        if (V)
            b->V = V;
        uint8_t *Vb = realloc(b->Vb, cap);
        if (Vb)
            b->Vb = Vb;
        uint32_t *Vp = realloc(b->Vsurf, (size_t)cap * sizeof *Vp);
        if (Vp)
            b->Vsurf = Vp;
        if (!V || !Vb || !Vp)
            return RAD_NONE;
        b->cap_v = cap;
        b->t.V = b->V;
        b->t.Vsurf = b->Vsurf;
    }
    v = b->nv++;
    b->V[v] = p;
    b->Vsurf[v] = surf;
    b->Vb[v] = maybe_outline && on_outline(b->s->scene, surf / 2, p);
    if (vt_insert(&b->t, v) != 0)
        return RAD_NONE;
    return v;
}

static int add_element(builder *b, const uint32_t v[4], uint32_t patch, uint32_t level, int state)
{
    if (b->ne == b->cap_e) {
        uint32_t cap = b->cap_e ? 2 * b->cap_e : 1024;
        enode *E = realloc(b->E, (size_t)cap * sizeof *E);
        if (E)
            b->E = E;
        double *B = realloc(b->B, (size_t)cap * b->bands * sizeof *B);
        if (B)
            b->B = B;
        float *h = b->nl ? realloc(b->h, (size_t)cap * b->nl * sizeof *h) : NULL;
        if (h)
            b->h = h;
        if (!E || !B || (b->nl && !h))
            return -1;
        b->cap_e = cap;
    }
    enode *n = &b->E[b->ne];
    memcpy(n->v, v, sizeof n->v);
    n->patch = patch;
    n->kids = RAD_NONE;
    n->level = (uint8_t)level;
    n->state = (uint8_t)state;
    n->settled = 0;
    n->cnt = 0;
    n->start = 0;
    memcpy(b->B + (size_t)b->ne * b->bands, b->s->B + (size_t)patch * b->bands,
           b->bands * sizeof *b->B);
    for (uint32_t l = 0; l < b->nl; l++)
        b->h[(size_t)b->ne * b->nl + l] = 0.0f; /* set before a row is gathered (level > 0) */
    b->ne++;
    return 0;
}

/* Makes the four children of leaf e (appended): leaves that replace it
 * (kid_state NODE_LEAF), or probes beside it (NODE_PROBE).  -1 on OOM. */
static int split(builder *b, uint32_t e, int kid_state)
{
    enode n = b->E[e];
    uint32_t surf = surface_of(&b->s->mesh->patches[n.patch]);
    uint32_t c[4];
    memcpy(c, n.v, sizeof c);
    int corners = c[3] == RAD_NONE ? 3 : 4;
    uint32_t m[4];
    for (int k = 0; k < corners; k++) {
        uint32_t a = c[k], z = c[(k + 1) % corners];
        /* Only a midpoint between two outline vertices can be on the outline. */
        m[k] = vertex_at(b, surf, midpoint(b->V[a], b->V[z]), b->Vb[a] && b->Vb[z]);
        if (m[k] == RAD_NONE)
            return -1;
    }
    uint32_t kids[4][4];
    if (corners == 4) {
        rad_vec3 mid = rad_scale(rad_add(rad_add(b->V[c[0]], b->V[c[1]]), rad_add(b->V[c[2]], b->V[c[3]])), 0.25);
        uint32_t ctr = vertex_at(b, surf, mid, 0);
        if (ctr == RAD_NONE)
            return -1;
        uint32_t q[4][4] = {{c[0], m[0], ctr, m[3]}, {m[0], c[1], m[1], ctr},
                            {ctr, m[1], c[2], m[2]}, {m[3], ctr, m[2], c[3]}};
        memcpy(kids, q, sizeof kids);
    } else {
        uint32_t q[4][4] = {{c[0], m[0], m[2], RAD_NONE}, {m[0], c[1], m[1], RAD_NONE},
                            {m[2], m[1], c[2], RAD_NONE}, {m[0], m[1], m[2], RAD_NONE}};
        memcpy(kids, q, sizeof kids);
    }
    uint32_t first = b->ne;
    for (int k = 0; k < 4; k++)
        if (add_element(b, kids[k], n.patch, n.level + 1u, kid_state) != 0)
            return -1;
    b->E[e].kids = first;
    if (kid_state == NODE_LEAF)
        b->E[e].state = NODE_SPLIT;
    return 0;
}

/* Leaf e takes its probes as its children. */
static void promote(builder *b, uint32_t e)
{
    enode *n = &b->E[e];
    RAD_ASSERT(n->state == NODE_LEAF && n->kids != RAD_NONE);
    n->state = NODE_SPLIT;
    for (uint32_t k = 0; k < 4; k++)
        b->E[n->kids + k].state = NODE_LEAF;
}

/* Where the centre of child k of a cell stands in the cell, as weights of
 * the cell's corners (split's order): bilinear (u, v) = (¼ or ¾, ¼ or ¾)
 * for a quad, barycentric for a triangle. */
static void child_weights(int corners, uint32_t k, double w[4])
{
    if (corners == 4) {
        static const double uv[4][2] = {{0.25, 0.25}, {0.75, 0.25}, {0.75, 0.75}, {0.25, 0.75}};
        double u = uv[k][0], v = uv[k][1];
        w[0] = (1 - u) * (1 - v);
        w[1] = u * (1 - v);
        w[2] = u * v;
        w[3] = (1 - u) * v;
        return;
    }
    static const double bw[4][3] = {{4 / 6., 1 / 6., 1 / 6.}, {1 / 6., 4 / 6., 1 / 6.},
                                    {1 / 6., 1 / 6., 4 / 6.}, {1 / 3., 1 / 3., 1 / 3.}};
    for (int c = 0; c < 3; c++)
        w[c] = bw[k][c];
    w[3] = 0.0;
}

static int store_row(void *user, uint32_t k, uint32_t count, const uint32_t *col, const float *val,
                     rad_error *err)
{
    builder *b = user;
    if (b->nnz + count > b->cap_r) {
        uint64_t cap = b->cap_r ? b->cap_r : 4096;
        while (cap < b->nnz + count)
            cap *= 2;
        uint32_t *c = realloc(b->col, cap * sizeof *c);
        if (c)
            b->col = c;
        float *v = realloc(b->val, cap * sizeof *v);
        if (v)
            b->val = v;
        if (!c || !v)
            return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for element rows");
        b->cap_r = cap;
    }
    uint32_t e = b->which[k];
    enode *n = &b->E[e];
    n->start = b->nnz;
    n->cnt = count;
    if (count) { /* an element that sees nothing: the pool may not exist yet */
        memcpy(b->col + b->nnz, col, count * sizeof *col);
        memcpy(b->val + b->nnz, val, count * sizeof *val);
    }
    b->nnz += count;
    double hd[RAD_MAX_BANDS];
    element_direct(b->s, NULL, b->nl ? b->h + (size_t)e * b->nl : NULL, n->patch, n->level, hd);
    gather_one(b->s, hd, b->Tr, n->patch, n->level, col, val, count, b->B + (size_t)e * b->bands);
    return RAD_OK;
}

/* h_le of the elements which[k] at the receivers r[k] (their centres), for
 * every light: the unoccluded unit-strength irradiance there times the
 * visibility from the light's item buffer.  Only points that face the light
 * (and lie in a spot's cone) are looked up. */
static int element_lights(builder *b, hc_engine *hc, const hc_receiver *r, const uint32_t *which,
                          uint32_t count, rad_error *err)
{
    const uint32_t nl = b->nl;
    if (!nl || !count)
        return RAD_OK;
    hc_receiver *lit = malloc((size_t)count * sizeof *lit);
    uint32_t *at = malloc((size_t)count * sizeof *at);
    double *direct = malloc((size_t)count * sizeof *direct), *vis = malloc((size_t)count * sizeof *vis);
    int rc = RAD_OK;
    if (!lit || !at || !direct || !vis)
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t l = 0; l < nl && rc == RAD_OK; l++) {
        hc_light hl = rad_light_for_hemicube(&b->s->scene->lights[l]);
        uint32_t m = 0;
        for (uint32_t k = 0; k < count; k++) {
            double d = hc_light_direct(&hl, r[k].center, b->s->mesh->patches[r[k].patch].normal);
            b->h[(size_t)which[k] * nl + l] = 0.0f;
            if (d > 0.0) {
                lit[m] = r[k];
                at[m] = which[k];
                direct[m++] = d;
            }
        }
        if (!m)
            continue;
        rc = hc_light_visibility(hc, &hl, b->light_R, lit, m, vis, err);
        for (uint32_t k = 0; k < m && rc == RAD_OK; k++)
            b->h[(size_t)at[k] * nl + l] = (float)(direct[k] * vis[k]);
        b->lights_rendered++;
    }
    free(lit);
    free(at);
    free(direct);
    free(vis);
    return rc;
}

/* Rows and radiosities of the elements which[0..count). */
static int compute_rows_of(builder *b, hc_engine *hc, const uint32_t *which, uint32_t count,
                           rad_error *err)
{
    if (!count)
        return RAD_OK;
    hc_receiver *r = malloc((size_t)count * sizeof *r);
    if (!r)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t k = 0; k < count; k++) {
        const enode *n = &b->E[which[k]];
        double area;
        if (rad_cell_geometry(b->V, n->v, b->s->mesh->patches[n->patch].normal, &r[k].center,
                              &area) != 0) {
            free(r);
            return rad_fail(err, RAD_ERR_INVALID, "elements: element %u has no area", which[k]);
        }
        r[k].patch = n->patch;
    }
    b->which = which;
    /* The direct light first: store_row gathers B_e as each row arrives. */
    int rc = element_lights(b, hc, r, which, count, err);
    if (rc == RAD_OK)
        rc = hc_compute_points(hc, r, count, store_row, b, err);
    b->rows_computed += count;
    free(r);
    return rc;
}

/* Rows of the elements [first, b->ne), made by the last splits (uniform:
 * only the leaves below level 0). */
static int compute_from(builder *b, hc_engine *hc, uint32_t first, int leaves_only, rad_error *err)
{
    uint32_t *which = malloc(((size_t)b->ne - first + 1) * sizeof *which), count = 0;
    if (!which)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t e = first; e < b->ne; e++)
        if (!leaves_only || (b->E[e].state == NODE_LEAF && b->E[e].level > 0))
            which[count++] = e;
    int rc = compute_rows_of(b, hc, which, count, err);
    free(which);
    return rc;
}

/* Longest edge of element n. */
static double longest_edge(const builder *b, const enode *n)
{
    int corners = n->v[3] == RAD_NONE ? 3 : 4;
    double l = 0.0;
    for (int k = 0; k < corners; k++)
        l = fmax(l, rad_length(rad_sub(b->V[n->v[(k + 1) % corners]], b->V[n->v[k]])));
    return l;
}

/* May leaf n split: a reflecting patch (a black one's B is its emission
 * whatever it receives), children not below the size floor. */
static int may_split(const builder *b, const enode *n, const double *min_edge)
{
    if (n->state != NODE_LEAF || n->level >= RAD_MAX_ELEMENT_LEVEL)
        return 0;
    int reflects = 0;
    for (uint32_t c = 0; c < b->bands; c++)
        reflects |= b->s->rho[(size_t)n->patch * b->bands + c] > 0.0;
    return reflects &&
           (!min_edge || 0.5 * longest_edge(b, n) >= min_edge[n->patch] * (1.0 - 1e-9));
}

/* The builder's leaves as a rad_elements, with their rows and only the
 * vertices they use (a probe that was not kept leaves vertices no leaf
 * uses); node_of[k] = the node of element k when node_of is not NULL. */
static int leaves_to_elements(const builder *b, rad_elements **out, uint32_t **node_of,
                              rad_error *err)
{
    *out = NULL;
    uint32_t leaves = 0, used = 0;
    uint64_t entries = 0;
    uint32_t *remap = malloc(((size_t)b->nv + 1) * sizeof *remap);
    uint32_t *of = malloc(((size_t)b->ne + 1) * sizeof *of);
    if (!remap || !of) {
        free(remap);
        free(of);
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    for (uint32_t v = 0; v < b->nv; v++)
        remap[v] = RAD_NONE;
    for (uint32_t e = 0; e < b->ne; e++) {
        const enode *n = &b->E[e];
        if (n->state != NODE_LEAF)
            continue;
        of[leaves++] = e;
        entries += n->cnt;
        for (int k = 0; k < 4 && n->v[k] != RAD_NONE; k++)
            if (remap[n->v[k]] == RAD_NONE)
                remap[n->v[k]] = used++;
    }
    rad_elements *el = rad_elements_alloc(used, leaves, b->bands, entries);
    if (el && b->nl) {
        el->light_count = b->nl;
        el->light_h = malloc((size_t)(leaves ? leaves : 1) * b->nl * sizeof *el->light_h);
        if (!el->light_h) {
            rad_elements_destroy(el);
            el = NULL;
        }
    }
    if (!el) {
        free(remap);
        free(of);
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    for (uint32_t v = 0; v < b->nv; v++)
        if (remap[v] != RAD_NONE) {
            el->mesh->vertices[remap[v]] = b->V[v];
            el->mesh->vertex_boundary[remap[v]] = b->Vb[v];
        }
    for (uint32_t k = 0; k < leaves; k++) {
        const enode *n = &b->E[of[k]];
        for (int c = 0; c < 4; c++)
            el->mesh->patches[k].v[c] = n->v[c] == RAD_NONE ? RAD_NONE : remap[n->v[c]];
        el->patch[k] = n->patch;
        el->level[k] = n->level;
        el->row_start[k] = el->nnz;
        el->row_count[k] = n->cnt;
        if (n->cnt) {
            memcpy(el->col + el->nnz, b->col + n->start, (size_t)n->cnt * sizeof *el->col);
            memcpy(el->val + el->nnz, b->val + n->start, (size_t)n->cnt * sizeof *el->val);
        }
        el->nnz += n->cnt;
        memcpy(el->B + (size_t)k * b->bands, b->B + (size_t)of[k] * b->bands,
               b->bands * sizeof *el->B);
        if (b->nl)
            memcpy(el->light_h + (size_t)k * b->nl, b->h + (size_t)of[k] * b->nl,
                   b->nl * sizeof *b->h);
    }
    free(remap);
    int rc = rad_elements_complete(el, b->s, "elements", err);
    if (rc != RAD_OK) {
        rad_elements_destroy(el);
        free(of);
        return rc;
    }
    *out = el;
    if (node_of)
        *node_of = of;
    else
        free(of);
    return RAD_OK;
}

/* The value the renderer draws at point p of element k: the interpolant of
 * its fan [first, first + count) of the render mesh rm, in the triangle
 * that holds p (barycentric weights). */
static void drawn_at(const rad_mesh *rm, const double *vB, uint32_t bands, uint32_t first,
                     uint32_t count, const rad_patch *e, rad_vec3 p, double *out)
{
    const rad_patch *c = &rm->patches[first];
    /* The fan triangle that holds p best (largest smallest weight). */
    double best = -INFINITY, l[3] = {1 / 3., 1 / 3., 1 / 3.};
    for (uint32_t t = first; t < first + count; t++) {
        const rad_patch *f = &rm->patches[t];
        rad_vec3 a = rm->vertices[f->v[0]], bb = rm->vertices[f->v[1]], cc = rm->vertices[f->v[2]];
        double whole = rad_dot(rad_cross(rad_sub(bb, a), rad_sub(cc, a)), e->normal);
        if (!(whole != 0.0))
            continue;
        double m[3] = {rad_dot(rad_cross(rad_sub(bb, p), rad_sub(cc, p)), e->normal) / whole,
                       rad_dot(rad_cross(rad_sub(cc, p), rad_sub(a, p)), e->normal) / whole, 0};
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

/* The share of a leaf across a block's foot counted as missing its B (see
 * estimate), chosen on bench_elements: 1/4 and 1/12 spent elements along
 * the blocks' feet that the rest of the floor needed more (ratios up to
 * 0.08 and 0.03 worse at T >= 1e-4); 1/32 is within 0.01 of no rule at
 * T >= 1e-4 and better at T <= 3e-5. */
#define CONTACT_SHARE (1.0 / 32.0)

/* The estimated error of each probed leaf (eps[node], 0 for the others):
 * the mean difference, over its four probes, between the probe's gathered
 * B and what the renderer draws there from the current leaves, relative to
 * scale[] (the largest band), times the leaf's share of its patch's area.
 * That is the leaf's share of the integrated error |drawn − B|: splitting
 * the leaves of largest share first is what lowers the mean error most per
 * element added, and a linear gradient, which the renderer's interpolation
 * draws exactly, costs nothing.  contact[node] marks a leaf at the foot of
 * a block: 1 across it (below), 2 seen but touching a buried leaf. */
static int estimate(builder *b, const double *scale, double *eps, uint8_t *contact, rad_error *err)
{
    const uint32_t bands = b->bands;
    rad_elements *el = NULL;
    rad_mesh *rm = NULL;
    uint32_t *node_of = NULL, *cells_of = NULL;
    double *vB = NULL, *drawn = NULL;
    uint8_t *buried_leaf = NULL, *vertex_side = NULL;
    int rc = leaves_to_elements(b, &el, &node_of, err);
    if (rc != RAD_OK)
        return rc;
    rc = fan_mesh(el->mesh, &rm, &cells_of, err);
    if (rc != RAD_OK)
        goto done;
    vB = malloc(((size_t)rm->vertex_count * bands + 1) * sizeof *vB);
    drawn = malloc(((size_t)el->mesh->patch_count * bands + 1) * sizeof *drawn);
    if (!vB || !drawn) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
        goto done;
    }
    rc = rad_solution_vertex_radiosity(b->s, el, rm, cells_of, drawn, vB, err);
    if (rc != RAD_OK)
        goto done;
    /* Buried leaves; per drawing vertex, bit 0: a seen leaf's cells use it,
     * bit 1: a buried leaf's. */
    const uint32_t nel = el->mesh->patch_count;
    buried_leaf = calloc(nel ? nel : 1, 1);
    vertex_side = calloc(rm->vertex_count ? rm->vertex_count : 1, 1);
    if (!buried_leaf || !vertex_side) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
        goto done;
    }
    for (uint32_t e = 0; e < nel; e++)
        buried_leaf[e] = (uint8_t)sees_nothing(b->s, el->patch[e], el->level[e], el->row_count[e],
                                               el->B + (size_t)e * bands);
    for (uint32_t k = 0; k < rm->patch_count; k++)
        for (int c = 0; c < rad_patch_corners(&rm->patches[k]); c++)
            vertex_side[rm->patches[k].v[c]] |= (uint8_t)(buried_leaf[cells_of[k]] ? 2 : 1);
    for (uint32_t e = 0; e < b->ne; e++) {
        eps[e] = 0.0;
        contact[e] = 0;
    }
    for (uint32_t first = 0, next; first < rm->patch_count; first = next) {
        uint32_t k = cells_of[first];
        for (next = first + 1; next < rm->patch_count && cells_of[next] == k;)
            next++;
        const enode *n = &b->E[node_of[k]];
        if (n->kids == RAD_NONE)
            continue;
        const rad_patch *ec = &el->mesh->patches[k];
        int corners = rad_patch_corners(ec);
        double d[RAD_MAX_BANDS] = {0}, seen_B[RAD_MAX_BANDS] = {0};
        uint32_t seen = 0, buried = buried_leaf[k];
        /* touches: a vertex of the other kind (seen for a buried leaf,
         * buried for a seen one) */
        int touches = 0;
        for (uint32_t f = first; f < next && !touches; f++)
            for (int c = 0; c < rad_patch_corners(&rm->patches[f]); c++)
                touches |= (vertex_side[rm->patches[f].v[c]] >> (buried ? 0 : 1)) & 1;
        for (uint32_t q = 0; q < 4; q++) {
            const enode *kid = &b->E[n->kids + q];
            const double *Bk = b->B + (size_t)(n->kids + q) * bands;
            /* A probe that sees nothing is never seen either: its error
             * costs nothing. */
            if (sees_nothing(b->s, kid->patch, kid->level, kid->cnt, Bk)) {
                buried++;
                continue;
            }
            seen++;
            for (uint32_t c = 0; c < bands; c++)
                seen_B[c] += Bk[c];
            double w[4], at[RAD_MAX_BANDS];
            child_weights(corners, q, w);
            rad_vec3 p = rad_v3(0, 0, 0);
            for (int c = 0; c < corners; c++)
                p = rad_add(p, rad_scale(el->mesh->vertices[ec->v[c]], w[c]));
            drawn_at(rm, vB, bands, first, next - first, ec, p, at);
            for (uint32_t c = 0; c < bands; c++)
                d[c] += 0.25 * fabs(Bk[c] - at[c]);
        }
        /* A leaf across the foot of a block - seen, with buried probes, or
         * buried itself (with buried probes) beside a seen leaf - draws its
         * seen part from values that belong to neither side of the contact
         * line, and no probe may land in that part: count CONTACT_SHARE of
         * the leaf as missing its B entirely (the seen probes' B, or what is
         * drawn for the buried leaf, extrapolated from its seen
         * neighbours).  Without this, a sliver of floor beside a block,
         * inside a patch whose centre and probes lie under the block, kept
         * the patch's wrong value: the largest single error of the adaptive
         * sets in bench_elements. */
        contact[node_of[k]] = (seen && buried) || (!seen && touches) ? 1 : touches ? 2 : 0;
        for (uint32_t c = 0; c < bands && contact[node_of[k]] == 1; c++)
            d[c] = fmax(d[c], CONTACT_SHARE * (seen ? seen_B[c] / seen : drawn[(size_t)k * bands + c]));
        double worst = 0.0;
        for (uint32_t c = 0; c < bands; c++)
            if (scale[c] > 0.0)
                worst = fmax(worst, d[c] / scale[c]);
        eps[node_of[k]] = worst * ec->area / b->s->mesh->patches[n->patch].area;
    }
done:
    rad_elements_destroy(el);
    rad_mesh_destroy(rm);
    free(drawn);
    free(buried_leaf);
    free(vertex_side);
    free(node_of);
    free(cells_of);
    free(vB);
    return rc;
}

static int too_many(const builder *b, const rad_solve_options *opt, uint64_t adding, rad_error *err)
{
    uint64_t after = (uint64_t)b->ne + adding;
    uint32_t limit = opt->mesh.max_patches ? opt->mesh.max_patches : 2000000u;
    if (after <= limit)
        return RAD_OK;
    return rad_fail(err, RAD_ERR_LIMIT,
                    "elements: refinement would make %llu elements, above the limit of %u "
                    "(raise --min-element-size or --refine-threshold)",
                    (unsigned long long)after, limit);
}

/* Uniform levels: every leaf that may split does, opt->element_levels
 * times; only the final leaves get hemi-cubes. */
static int refine_uniform(builder *b, const rad_solve_options *opt, hc_engine *hc, rad_error *err)
{
    for (uint32_t level = 0; level < opt->element_levels; level++) {
        uint32_t ne = b->ne, marked = 0;
        for (uint32_t e = 0; e < ne; e++)
            marked += may_split(b, &b->E[e], NULL) && b->E[e].level == level;
        int rc = too_many(b, opt, 4ull * marked, err);
        if (rc != RAD_OK)
            return rc;
        for (uint32_t e = 0; e < ne; e++)
            if (may_split(b, &b->E[e], NULL) && b->E[e].level == level &&
                split(b, e, NODE_LEAF) != 0)
                return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    return compute_from(b, hc, 0, 1, err);
}

/* A leaf to probe: it may split, has no probes yet and is not settled. */
static int wants_probe(const builder *b, const enode *n, const double *min_edge)
{
    return n->kids == RAD_NONE && !n->settled && may_split(b, n, min_edge);
}

/* Adaptive: probe every leaf that may split (gather its four children),
 * estimate each probed leaf's error from its probes (estimate), split those
 * above the threshold - their probes become leaves, to be probed in turn -
 * and again until no leaf splits.  Splitting changes what is drawn next to
 * it, so every probed leaf is estimated again each pass.
 *
 * A child's share of the error is at most about a quarter of its parent's
 * whenever the error density does not grow at the finer scale (a sixteenth
 * for a smooth field, a quarter at a step): the children of a leaf that
 * split with an estimate of at most 4 T cannot reach T, and are not probed
 * (settled).  On the Cornell box that saves half the hemi-cubes for a few
 * per cent of error. */
static int refine_adaptive(builder *b, const rad_solve_options *opt, const double *scale,
                           const double *min_edge, hc_engine *hc, rad_error *err)
{
    const double T = opt->refine_threshold;
    double *eps = NULL;
    uint8_t *contact = NULL;
    int rc = RAD_OK;
    for (;;) {
        uint32_t ne = b->ne, probing = 0;
        for (uint32_t e = 0; e < ne; e++)
            probing += wants_probe(b, &b->E[e], min_edge);
        if ((rc = too_many(b, opt, 4ull * probing, err)) != RAD_OK)
            break;
        for (uint32_t e = 0; e < ne; e++)
            if (wants_probe(b, &b->E[e], min_edge) && split(b, e, NODE_PROBE) != 0) {
                rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
                goto done;
            }
        if ((rc = compute_from(b, hc, ne, 0, err)) != RAD_OK)
            break;
        free(eps);
        free(contact);
        eps = malloc(((size_t)b->ne + 1) * sizeof *eps);
        contact = malloc((size_t)b->ne + 1);
        if (!eps || !contact) {
            rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
            break;
        }
        if ((rc = estimate(b, scale, eps, contact, err)) != RAD_OK)
            break;
        uint32_t splits = 0;
        for (uint32_t e = 0; e < b->ne; e++) {
            enode *n = &b->E[e];
            if (n->state != NODE_LEAF || n->kids == RAD_NONE || !(eps[e] > T))
                continue;
            promote(b, e);
            /* Across or beside a contact line the error is a line's, and
             * may sit in a child that no probe of the leaf saw: no child
             * is settled. */
            for (uint32_t k = 0; k < 4; k++)
                b->E[n->kids + k].settled = eps[e] <= 4.0 * T && !contact[e];
            splits++;
        }
        if (!splits)
            break;
    }
done:
    free(eps);
    free(contact);
    return rc;
}

int rad_solution_refine(rad_solution *s, const rad_solve_options *options, rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_solution_refine: no solution");
    rad_solve_options opt = {0};
    if (options)
        opt = *options;
    if (!(opt.refine_threshold >= 0.0) || !isfinite(opt.refine_threshold) ||
        !(opt.min_element_size >= 0.0) || !isfinite(opt.min_element_size) ||
        opt.element_levels > RAD_MAX_ELEMENT_LEVEL)
        return rad_fail(err, RAD_ERR_USAGE,
                        "refine: threshold and minimum element size must be finite and >= 0, "
                        "levels at most %u", RAD_MAX_ELEMENT_LEVEL);
    rad_elements_destroy(s->elements);
    s->elements = NULL;
    if (!(opt.refine_threshold > 0.0) && opt.element_levels == 0)
        return RAD_OK;

    const rad_mesh *pm = s->mesh;
    const uint32_t np = pm->patch_count, bands = s->band_count;
    const int uniform = opt.element_levels && !(opt.refine_threshold > 0.0);
    builder b = {.s = s, .bands = bands, .nl = s->scene->light_count,
                 .light_R = rad_light_resolution(&opt)};
    double *Tr = NULL, *min_edge = NULL;
    hc_engine *hc = NULL;
    int rc = transmitted(s, &Tr, err);
    if (rc != RAD_OK)
        return rc;
    b.Tr = Tr;
    min_edge = malloc((np ? np : 1) * sizeof *min_edge);
    if (!min_edge) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
        goto done;
    }
    /* Level 0: one element per patch, on the patch's own corners. */
    for (uint32_t i = 0; i < np; i++) {
        const rad_patch *p = &pm->patches[i];
        uint32_t v[4] = {RAD_NONE, RAD_NONE, RAD_NONE, RAD_NONE};
        for (int k = 0; k < rad_patch_corners(p); k++) {
            v[k] = vertex_at(&b, surface_of(p), pm->vertices[p->v[k]], 0);
            if (v[k] == RAD_NONE) {
                rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
                goto done;
            }
            b.Vb[v[k]] = pm->vertex_boundary[p->v[k]];
        }
        if (add_element(&b, v, i, 0, NODE_LEAF) != 0) {
            rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
            goto done;
        }
        /* Default floor: three splits below the patch (1/8 of its size). */
        double own = longest_edge(&b, &b.E[i]);
        min_edge[i] = opt.min_element_size > 0.0 ? opt.min_element_size : own / 8.0;
    }
    /* Errors are relative to the brightest reflecting (non-emitting) patch
     * per band: emitters would make any threshold meaningless. */
    double scale[RAD_MAX_BANDS] = {0};
    for (uint32_t i = 0; i < np; i++)
        for (uint32_t c = 0; c < bands; c++)
            if (s->emission[(size_t)i * bands + c] == 0.0)
                scale[c] = fmax(scale[c], s->B[(size_t)i * bands + c]);
    hc_options ho = opt.hemicube;
    ho.progress = NULL;
    uint8_t *exact = NULL;
    if (!opt.pixel_emitters) {
        /* The same exact marks the patch rows used: element-to-emitter
         * factors by the contour integral. */
        exact = calloc(np ? np : 1, 1);
        if (!exact) {
            rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
            goto done;
        }
        for (uint32_t i = 0; i < np; i++)
            for (uint32_t c = 0; c < bands; c++)
                exact[i] |= s->emission[(size_t)i * bands + c] > 0.0;
        ho.exact = exact;
    }
    ho.exact_near = 0;
    rc = hc_create(pm, &ho, &hc, err);
    free(exact);
    if (rc != RAD_OK)
        goto done;
    rc = uniform ? refine_uniform(&b, &opt, hc, err)
                 : refine_adaptive(&b, &opt, scale, min_edge, hc, err);
    if (rc == RAD_OK) {
        rad_elements *el = NULL;
        rc = leaves_to_elements(&b, &el, NULL, err);
        if (rc == RAD_OK) {
            el->threshold = opt.refine_threshold > 0.0 ? opt.refine_threshold : 0.0;
            el->min_size = opt.min_element_size;
            el->rows_computed = b.rows_computed;
            s->elements = el;
            s->lights_computed += b.lights_rendered;
        }
    }
done:
    hc_destroy(hc);
    free(min_edge);
    free(Tr);
    free(b.h);
    free(b.V);
    free(b.Vb);
    free(b.Vsurf);
    free(b.t.slot);
    free(b.E);
    free(b.B);
    free(b.col);
    free(b.val);
    return rc;
}
