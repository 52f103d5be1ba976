/* draw_conform.c - the cells an item buffer draws made watertight (issue 36).
 *
 * The mesher's planar regions (mesh/region.c) cut their polygons on a grid
 * and place their corners in the region's plane: where a region meets
 * another surface (a floor meeting a round wall), the region's outline
 * carries grid-cut points the neighbour's edge does not (T-junctions), and
 * its corners may differ from the neighbour's in the last bits.  A fixed
 * point rasteriser snaps each vertex on its own, so a T-junction leaves
 * pixels between the long edge and the two short ones uncovered: light
 * leaks out of a closed room.  Here, before anything is drawn:
 *
 *   corners within HC_CONFORM_WELD × bradius of each other are one point;
 *   a cell edge that no cell runs the other way gets every such point lying
 *   on it (within the same tolerance) inserted, and its cell is drawn as a
 *   fan from its centroid over the longer outline.
 *
 * Invariant: afterwards every edge shared by two surfaces is run by both
 * with one and the same vertex sequence, so both the cell-by-cell drawing
 * and draw_geometry.c's simplified outlines (which keep or drop a shared
 * vertex identically on both sides) meet without a crack.  A cell without
 * such points keeps its corners (each its weld's first).  No GL here.
 */
#include "hc_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Welding and on-edge tolerance, as a share of the scene's radius. */
#define HC_CONFORM_WELD 1e-9

/* Points are sorted along a direction no scene axis or usual plane is
 * perpendicular to, so a wall at x = const does not put all its corners in
 * one window; two points within q in every coordinate differ by at most
 * q × KEY_SUM along it. */
#define KEY_SUM (0.5386 + 0.6871 + 0.4873)

static double key_of(const double *p)
{
    return 0.5386 * p[0] + 0.6871 * p[1] + 0.4873 * p[2];
}

typedef struct xkey {
    double x;
    uint32_t k;
} xkey;

static int xkey_cmp(const void *a, const void *b)
{
    const xkey *p = a, *q = b;
    return p->x < q->x ? -1 : p->x > q->x ? 1 : (p->k > q->k) - (p->k < q->k);
}

static int u64_cmp(const void *a, const void *b)
{
    uint64_t p = *(const uint64_t *)a, q = *(const uint64_t *)b;
    return (p > q) - (p < q);
}

typedef struct cf {
    const hc_engine *e;
    double q;         /* tolerance */
    uint32_t *id;     /* ncell × 4: corner -> its weld representative corner */
    uint64_t *edge;   /* sorted directed edges a << 32 | b */
    size_t nedge;
    xkey *cand;       /* representatives on unpaired edges, by key_of */
    size_t ncand;
} cf;

static const double *cpos(const cf *c, uint32_t k)
{
    return c->e->corner + 3 * (size_t)k;
}

static uint32_t uf_find(uint32_t *up, uint32_t k)
{
    while (up[k] != k)
        k = up[k] = up[up[k]];
    return k;
}

/* Corners within q of each other (every coordinate) share the lowest one
 * (xkey.x: the point's key_of). */
static int weld(cf *c)
{
    const size_t n = (size_t)c->e->ncell * 4;
    xkey *s = malloc((n + 1) * sizeof *s);
    c->id = malloc((n + 1) * sizeof *c->id);
    if (!s || !c->id) {
        free(s);
        return -1;
    }
    for (size_t k = 0; k < n; k++)
        s[k] = (xkey){key_of(cpos(c, (uint32_t)k)), (uint32_t)k}, c->id[k] = (uint32_t)k;
    qsort(s, n, sizeof *s, xkey_cmp);
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n && s[j].x - s[i].x <= c->q * KEY_SUM; j++) {
            const double *a = cpos(c, s[i].k), *b = cpos(c, s[j].k);
            if (fabs(a[0] - b[0]) <= c->q && fabs(a[1] - b[1]) <= c->q && fabs(a[2] - b[2]) <= c->q) {
                uint32_t ra = uf_find(c->id, s[i].k), rb = uf_find(c->id, s[j].k);
                c->id[ra > rb ? ra : rb] = ra < rb ? ra : rb;
            }
        }
    for (size_t k = 0; k < n; k++)
        c->id[k] = uf_find(c->id, (uint32_t)k);
    free(s);
    return 0;
}

static uint32_t corner_id(const cf *c, uint32_t cell, int k)
{
    return c->id[(size_t)cell * 4 + (size_t)(k % c->e->ncorner[cell])];
}

static int paired(const cf *c, uint32_t a, uint32_t b)
{
    uint64_t key = (uint64_t)b << 32 | a;
    return bsearch(&key, c->edge, c->nedge, sizeof key, u64_cmp) != NULL;
}

/* Every directed cell edge, sorted; the corners of unpaired ones by x. */
static int edges(cf *c)
{
    const hc_engine *e = c->e;
    c->edge = malloc(((size_t)e->ncell * 4 + 1) * sizeof *c->edge);
    c->cand = malloc(((size_t)e->ncell * 8 + 1) * sizeof *c->cand);
    if (!c->edge || !c->cand)
        return -1;
    for (uint32_t q = 0; q < e->ncell; q++)
        for (int k = 0; k < e->ncorner[q]; k++)
            c->edge[c->nedge++] = (uint64_t)corner_id(c, q, k) << 32 | corner_id(c, q, k + 1);
    qsort(c->edge, c->nedge, sizeof *c->edge, u64_cmp);
    for (uint32_t q = 0; q < e->ncell; q++)
        for (int k = 0; k < e->ncorner[q]; k++) {
            uint32_t a = corner_id(c, q, k), b = corner_id(c, q, k + 1);
            if (!paired(c, a, b)) {
                c->cand[c->ncand++] = (xkey){key_of(cpos(c, a)), a};
                c->cand[c->ncand++] = (xkey){key_of(cpos(c, b)), b};
            }
        }
    qsort(c->cand, c->ncand, sizeof *c->cand, xkey_cmp);
    return 0;
}

typedef struct tpt {
    double t;
    uint32_t g;
} tpt;

static int tpt_cmp(const void *a, const void *b)
{
    const tpt *p = a, *q = b;
    return p->t < q->t ? -1 : p->t > q->t ? 1 : (p->g > q->g) - (p->g < q->g);
}

/* The points strictly inside edge a -> b of the unpaired edges' corners,
 * in order from a, into T (at most cap); their number. */
static size_t on_edge(const cf *c, uint32_t a, uint32_t b, tpt *T, size_t cap)
{
    const double *pa = cpos(c, a), *pb = cpos(c, b);
    double ab[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
    double l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2], ka = key_of(pa), kb = key_of(pb);
    double lo = fmin(ka, kb) - c->q * KEY_SUM, hi_key = fmax(ka, kb) + c->q * KEY_SUM;
    size_t i = 0, hi = c->ncand, n = 0;
    while (i < hi) { /* first candidate with key >= lo */
        size_t m = (i + hi) / 2;
        if (c->cand[m].x < lo)
            i = m + 1;
        else
            hi = m;
    }
    for (; i < c->ncand && c->cand[i].x <= hi_key && n < cap; i++) {
        uint32_t g = c->cand[i].k;
        if (g == a || g == b || !(l2 > 0.0))
            continue;
        const double *p = cpos(c, g);
        double ap[3] = {p[0] - pa[0], p[1] - pa[1], p[2] - pa[2]};
        double t = (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / l2, d2 = 0.0;
        for (int x = 0; x < 3; x++)
            d2 += (ap[x] - t * ab[x]) * (ap[x] - t * ab[x]);
        if (t * t * l2 > c->q * c->q && (1 - t) * (1 - t) * l2 > c->q * c->q && t > 0 && t < 1 &&
            d2 <= c->q * c->q) {
            int dup = 0;
            for (size_t s = 0; s < n; s++)
                dup |= T[s].g == g;
            if (!dup)
                T[n++] = (tpt){t, g};
        }
    }
    qsort(T, n, sizeof *T, tpt_cmp);
    return n;
}

/* The output being built: cells with their parent's rad_patch. */
typedef struct cout {
    uint32_t n, cap;
    double *corner;
    uint8_t *ncorner;
    rad_patch *cell;
} cout;

static int put_cell(cout *o, const double *const *p, int m, const rad_patch *parent,
                    rad_vec3 origin)
{
    if (o->n == o->cap) {
        uint32_t cap = o->cap ? 2 * o->cap : 64;
        double *c = realloc(o->corner, (size_t)cap * 12 * sizeof *c);
        o->corner = c ? c : o->corner;
        uint8_t *nc = realloc(o->ncorner, cap);
        o->ncorner = nc ? nc : o->ncorner;
        rad_patch *pc = realloc(o->cell, (size_t)cap * sizeof *pc);
        o->cell = pc ? pc : o->cell;
        if (!c || !nc || !pc)
            return -1;
        o->cap = cap;
    }
    for (int k = 0; k < 4; k++)
        memcpy(o->corner + (size_t)o->n * 12 + 3 * k, p[k < m ? k : 0], 3 * sizeof(double));
    o->ncorner[o->n] = (uint8_t)m;
    o->cell[o->n] = *parent;
    if (m == 3) { /* a piece of its parent: its own area and centre */
        rad_vec3 a = rad_v3(p[0][0], p[0][1], p[0][2]), b = rad_v3(p[1][0], p[1][1], p[1][2]),
                 d = rad_v3(p[2][0], p[2][1], p[2][2]);
        o->cell[o->n].area = 0.5 * rad_length(rad_cross(rad_sub(b, a), rad_sub(d, a)));
        o->cell[o->n].center = rad_add(origin, rad_scale(rad_add(rad_add(a, b), d), 1.0 / 3.0));
    }
    o->n++;
    return 0;
}

/* Cell q into o: as it is (welded corners), or as a fan from its centroid
 * over its outline with the points on its unpaired edges. */
static int conform_cell(const cf *c, uint32_t q, cout *o, uint32_t *ring, tpt *T, size_t cap)
{
    const hc_engine *e = c->e;
    const rad_patch *parent = e->mesh->cell_first ? &e->mesh->cells[q] : &e->mesh->patches[q];
    const int m = e->ncorner[q];
    size_t len = 0;
    for (int k = 0; k < m; k++) {
        uint32_t a = corner_id(c, q, k), b = corner_id(c, q, k + 1);
        ring[len++] = a;
        if (!paired(c, a, b)) {
            size_t nt = on_edge(c, a, b, T, cap - len);
            for (size_t s = 0; s < nt; s++)
                ring[len++] = T[s].g;
        }
    }
    const double *p[4];
    if (len == (size_t)m) {
        for (int k = 0; k < m; k++)
            p[k] = cpos(c, ring[k]);
        return put_cell(o, p, m, parent, e->origin);
    }
    double mid[3] = {0, 0, 0};
    for (int k = 0; k < m; k++)
        for (int x = 0; x < 3; x++)
            mid[x] += e->corner[(size_t)q * 12 + 3 * k + x] / m;
    for (size_t s = 0; s < len; s++) {
        p[0] = mid, p[1] = cpos(c, ring[s]), p[2] = cpos(c, ring[(s + 1) % len]);
        if (put_cell(o, p, 3, parent, e->origin) != 0)
            return -1;
    }
    return 0;
}

static void cf_free(cf *c)
{
    free(c->id), free(c->edge), free(c->cand);
}

int hc_draw_conform(const hc_engine *e, hc_engine *ce, rad_mesh *cm, char *msg)
{
    cf c = {.e = e, .q = HC_CONFORM_WELD * (e->bradius > 0.0 ? e->bradius : 1.0)};
    cout o = {0};
    const size_t cap = (size_t)e->ncell * 8 + 16;
    uint32_t *ring = malloc(cap * sizeof *ring), *first = malloc(((size_t)e->n + 1) * sizeof *first);
    tpt *T = malloc(cap * sizeof *T);
    int rc = !ring || !first || !T || weld(&c) != 0 || edges(&c) != 0 ? -1 : 0;
    for (uint32_t j = 0; !rc && j < e->n; j++) {
        first[j] = o.n;
        for (uint32_t q = e->cfirst[j]; !rc && q < e->cfirst[j + 1]; q++)
            rc = conform_cell(&c, q, &o, ring, T, cap);
    }
    cf_free(&c), free(ring), free(T);
    if (rc) {
        free(first), free(o.corner), free(o.ncorner), free(o.cell);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for the draw geometry");
        return -1;
    }
    first[e->n] = o.n;
    *cm = *e->mesh;
    cm->cells = o.cell, cm->cell_count = o.n, cm->cell_first = first;
    *ce = *e;
    ce->mesh = cm, ce->ncell = o.n, ce->cfirst = first, ce->corner = o.corner, ce->ncorner = o.ncorner;
    return 0;
}

void hc_draw_conform_free(hc_engine *ce, rad_mesh *cm)
{
    free(ce->corner), free(ce->ncorner), free(cm->cells), free(cm->cell_first);
}
