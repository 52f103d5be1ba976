/* draw_geometry.c - the triangles an item buffer draws for each patch, so
 * that a hemi-cube row costs what the patches cost, not what the input's
 * triangulation costs (issue 36).  No GL here: gl.c uploads what this file
 * builds; the caller's process may build it too (hc_draw_triangles).
 *
 * A patch of one cell is drawn as that cell (one or two triangles).  A
 * cluster (many cells, planar or curved: mesh.h) is drawn as a fan from a
 * point of its surface to its outline, the outline simplified: the chain of
 * outline vertices that two clusters A and B share (vertices on the outline
 * of A and B and of no other patch) keeps, by Douglas-Peucker, only the
 * vertices needed to stay within HC_DRAW_TOLERANCE × min(√A_A, √A_B) of the
 * chain (HC_DRAW_SLIDE along a plane shared by coplanar patches); a planar
 * cluster whose outline no fan covers is drawn by the outline's ear
 * clipping.  The choice depends only on the chain's vertices, not on which
 * side asks, so A and B are drawn with one and the same boundary: no crack
 * opens between simplified neighbours and no light leaks through.  Every
 * other outline vertex (where three patches meet, along a one-cell patch, on
 * a surface's free edge) is kept.
 *
 * Invariant, checked for each cluster before its shape is used: its
 * triangles all face the patch's side (n_i), they cover its outline's
 * projection on n_i once (their projected area is the cells' within 25 %:
 * an outline wound twice doubles it), and every vertex of the cells lies
 * within the tolerance of them.  The fan's centre is the patch's centre,
 * else one of the cells' corners nearest their centroid.  A cluster
 * failing these (a hole, a fold, a shape no fan or ear clipping of its
 * outline covers) is drawn cell by cell, and its outline vertices are then
 * kept for its neighbours too, which are checked again.  So a patch is
 * drawn either exactly or within the tolerance, and neighbours always meet.
 *
 * Outlines are found on the cells' edges: a cell edge whose reverse no
 * cell of the patch runs.  Two things made inner edges look like outline
 * (a patch of an exporter's triangles then had no single outline loop and
 * was drawn cell by cell): corners of one point computed twice a rounding
 * step apart (merged here within HC_DRAW_MERGE of the cells' diagonal),
 * and T-junctions the region cutter keeps from its input (a triangle's
 * edge against two of its neighbour's: split_edges cuts the long edge at
 * the vertices the other side runs through).
 *
 * RADIOSITY_DRAW_EVERY_CELL=1 in the environment draws every cell (the
 * reference the simplified drawing is tested against).
 */
#include "hc_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The simplification's tolerance, as a fraction of the patch's size √A_i. */
#define HC_DRAW_TOLERANCE 0.03
/* How far a shared outline between coplanar patches may move along their
 * plane (it changes which patch owns a sliver, not the geometry), as a
 * fraction of √A_i.  Measured (test_draw_geometry, bench_atrium): 0.25
 * makes the hall's drawn triangles independent of its tessellation (47,000
 * at 1× and 4×) but moves object means by up to 0.46 %: rows.c's small
 * polygons then look covered by their slid neighbour.  So no more than
 * across the surface until rows.c tells a coplanar neighbour apart. */
#define HC_DRAW_SLIDE 0.03
/* cos of the angle within which two patches count as coplanar for that. */
#define HC_DRAW_COPLANAR 0.9999

/* The builder's scratch, all indexed by a global vertex g (equal double
 * positions of any cells are one vertex) or by patch. */
typedef struct dg {
    const hc_engine *e;
    uint32_t nv;          /* global vertices */
    uint32_t *cv;         /* ncell × 4: corner -> global vertex */
    uint32_t *cef, *cea, *ceb; /* cell c's edges cea -> ceb from cef[c] */
    double *pos;          /* nv × 3 */
    /* Outline edges of every patch, grouped by patch: ea -> eb, e of patch
     * ep; partner: the patch owning eb -> ea, or RAD_NONE. */
    uint32_t ne, *efirst, *ea, *eb, *epartner;
    uint8_t *simple;      /* per patch: 1 = drawn by its fan (so far) */
    uint8_t *keep;        /* per vertex: kept on every outline it lies on */
    uint32_t *loop;       /* per patch: scratch of outline vertices in order */
    uint32_t *lfirst;     /* n + 1: patch j's loop is loop[lfirst[j] .. ) */
    uint32_t *llen;       /* n: its length (0: no single loop) */
    rad_vec3 *apex;       /* n: the fan's centre of a patch drawn by its fan */
    rad_vec3 *T;          /* scratch: a shape's triangles, 3 × (ne + 1) */
    uint32_t *left;       /* scratch: ear clipping's outline, ne + 1 */
} dg;

static uint64_t mix(uint64_t h, uint64_t w)
{
    h = (h ^ w) * 0xff51afd7ed558ccdull;
    return h ^ (h >> 32);
}

static uint64_t hash_words(const void *p, size_t words)
{
    uint32_t w[6];
    memcpy(w, p, words * 4);
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (size_t k = 0; k < words; k++)
        h = mix(h, w[k]);
    return h;
}

static size_t table_size(size_t n)
{
    size_t cap = 16;
    while (cap < 2 * n)
        cap *= 2;
    return cap;
}

/* Corners closer than this share of the cells' diagonal are one vertex:
 * the region cutter rounds each point to a grid (1e-7 of the patch size),
 * and two computations of one point that straddle a rounding step, or
 * land in two regions' frames, differ by about that; numbered apart they
 * make inner edges look like outline. */
#define HC_DRAW_MERGE 1e-7
/* A T-junction's vertex lies on the edge it splits within this share of
 * the cells' diagonal (the mesher's weld, mesh_internal.h's MESH_WELD):
 * an export's float midpoints far from the origin are a few ulps off the
 * line, more than a share of a small patch's size allows. */
#define HC_DRAW_TJUNCTION 1e-6

typedef struct vgrid {
    double eps;
    size_t cap;
    uint32_t *slot;  /* vertex + 1, 0 empty */
    int64_t *key;    /* per vertex: its grid cell, 3 words */
} vgrid;

static size_t vgrid_hash(const vgrid *v, const int64_t k[3])
{
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int a = 0; a < 3; a++)
        h = mix(h, (uint64_t)k[a]);
    return (size_t)h & (v->cap - 1);
}

/* The vertex within eps of p in the 27 grid cells about its own, or
 * RAD_NONE. */
static uint32_t vgrid_find(const dg *d, const vgrid *v, const double *p, const int64_t k[3])
{
    for (int q = 0; q < 27; q++) {
        int64_t c[3] = {k[0] + q % 3 - 1, k[1] + q / 3 % 3 - 1, k[2] + q / 9 - 1};
        for (size_t h = vgrid_hash(v, c); v->slot[h]; h = (h + 1) & (v->cap - 1)) {
            uint32_t g = v->slot[h] - 1;
            const int64_t *gk = v->key + 3 * (size_t)g;
            const double *gp = d->pos + 3 * (size_t)g;
            if (gk[0] == c[0] && gk[1] == c[1] && gk[2] == c[2] && fabs(gp[0] - p[0]) <= v->eps &&
                fabs(gp[1] - p[1]) <= v->eps && fabs(gp[2] - p[2]) <= v->eps)
                return g;
        }
    }
    return RAD_NONE;
}

static double corner_diagonal(const hc_engine *e)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t k = 0; k < (size_t)e->ncell * 4; k++)
        for (int a = 0; a < 3; a++)
            lo[a] = fmin(lo[a], e->corner[3 * k + a]), hi[a] = fmax(hi[a], e->corner[3 * k + a]);
    double d2 = 0.0;
    for (int a = 0; a < 3; a++)
        d2 += hi[a] > lo[a] ? (hi[a] - lo[a]) * (hi[a] - lo[a]) : 0.0;
    return sqrt(d2);
}

/* Global vertices: every cell corner numbered by its position, corners
 * within HC_DRAW_MERGE of the diagonal one vertex (the first one's). */
static int number_vertices(dg *d, char *msg)
{
    const hc_engine *e = d->e;
    size_t nc = (size_t)e->ncell * 4;
    vgrid v = {.eps = HC_DRAW_MERGE * corner_diagonal(e), .cap = table_size(nc)};
    v.slot = calloc(v.cap, sizeof *v.slot);
    v.key = malloc((nc * 3 + 1) * sizeof *v.key);
    d->cv = malloc(nc * sizeof *d->cv);
    d->pos = malloc(nc * 3 * sizeof *d->pos);
    if (!v.slot || !v.key || !d->cv || !d->pos) {
        free(v.slot), free(v.key);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for the draw geometry");
        return -1;
    }
    const double cell = v.eps > 0.0 ? 2.0 * v.eps : 1.0;
    for (size_t k = 0; k < nc; k++) {
        const double *p = e->corner + 3 * k;
        int64_t key[3];
        for (int a = 0; a < 3; a++)
            key[a] = (int64_t)floor(p[a] / cell);
        uint32_t g = vgrid_find(d, &v, p, key);
        if (g == RAD_NONE) {
            g = d->nv++;
            memcpy(d->pos + 3 * (size_t)g, p, 3 * sizeof *p);
            memcpy(v.key + 3 * (size_t)g, key, sizeof key);
            size_t h = vgrid_hash(&v, key);
            while (v.slot[h])
                h = (h + 1) & (v.cap - 1);
            v.slot[h] = g + 1;
        }
        d->cv[k] = g;
    }
    free(v.slot), free(v.key);
    return 0;
}

/* A directed edge table: key (a, b) -> value. */
typedef struct etab {
    size_t cap;
    uint32_t *a, *b, *val; /* val RAD_NONE: empty */
} etab;

static size_t etab_find(const etab *t, uint32_t a, uint32_t b)
{
    uint32_t k[2] = {a, b};
    size_t h = hash_words(k, 2) & (t->cap - 1);
    while (t->val[h] != RAD_NONE && (t->a[h] != a || t->b[h] != b))
        h = (h + 1) & (t->cap - 1);
    return h;
}

static int etab_init(etab *t, size_t n)
{
    t->cap = table_size(n);
    t->a = malloc(t->cap * sizeof *t->a);
    t->b = malloc(t->cap * sizeof *t->b);
    t->val = malloc(t->cap * sizeof *t->val);
    if (!t->a || !t->b || !t->val)
        return -1;
    memset(t->val, 0xFF, t->cap * sizeof *t->val);
    return 0;
}

static void etab_free(etab *t)
{
    free(t->a), free(t->b), free(t->val);
}

static double patch_tol(const dg *d, uint32_t j);
static rad_vec3 vpos(const dg *d, uint32_t g);

/* The directed edges of cell c as its corners give them, less any whose
 * two ends were merged into one vertex (a sliver's). */
static int raw_edges(const dg *d, uint32_t c, uint32_t a[4], uint32_t b[4])
{
    int m = d->e->ncorner[c], n = 0;
    for (int k = 0; k < m; k++) {
        a[n] = d->cv[(size_t)c * 4 + k];
        b[n] = d->cv[(size_t)c * 4 + (k + 1) % m];
        n += a[n] != b[n];
    }
    return n >= 3 ? n : 0; /* a triangle of two corners: no area, no edges */
}

/* The vertices strictly inside edge a -> b through which other edges run
 * back from b to a (x1 -> a, x2 -> x1, ..., b -> xk, each on the segment
 * within tol), into X[0..max); their count, 0 when there is no such chain.
 * back: edges whose reverse no cell has, listed by their end (bfirst,
 * bfrom); t: every cell edge. */
static uint32_t t_chain(const dg *d, const etab *t, const uint32_t *bfirst, const uint32_t *bfrom,
                        uint32_t a, uint32_t b, double tol, uint32_t *X, uint32_t max)
{
    const rad_vec3 pa = vpos(d, a), ab = rad_sub(vpos(d, b), pa);
    const double l2 = rad_dot(ab, ab);
    uint32_t cur = a, k = 0;
    double at = 0.0;
    while (k < max && l2 > 0.0) {
        if (k > 0 && t->val[etab_find(t, b, cur)] != RAD_NONE)
            return k;
        uint32_t next = RAD_NONE;
        double best = 1.0;
        for (uint32_t q = bfirst[cur]; q < bfirst[cur + 1]; q++) {
            double d2, u = rad_line_foot(rad_sub(vpos(d, bfrom[q]), pa), ab, l2, &d2);
            if (u > at && u < best && d2 <= tol * tol)
                best = u, next = bfrom[q];
        }
        if (next == RAD_NONE)
            return 0;
        X[k++] = next, cur = next, at = best;
    }
    return 0;
}

/* Edges whose reverse no cell has, listed by their end vertex (CSR). */
static int back_edges(const dg *d, const etab *t, uint32_t **bfirst, uint32_t **bfrom)
{
    const hc_engine *e = d->e;
    *bfirst = calloc((size_t)d->nv + 2, sizeof **bfirst);
    *bfrom = malloc(((size_t)e->ncell * 4 + 1) * sizeof **bfrom);
    if (!*bfirst || !*bfrom)
        return -1;
    for (int pass = 0; pass < 2; pass++)
        for (uint32_t c = 0; c < e->ncell; c++) {
            uint32_t a[4], b[4];
            int m = raw_edges(d, c, a, b);
            for (int k = 0; k < m; k++) {
                if (t->val[etab_find(t, b[k], a[k])] != RAD_NONE)
                    continue;
                if (pass == 0)
                    (*bfirst)[b[k] + 2]++;
                else
                    (*bfrom)[(*bfirst)[b[k] + 1]++] = a[k];
            }
            if (pass == 0 && c + 1 == e->ncell)
                for (uint32_t g = 0; g < d->nv; g++)
                    (*bfirst)[g + 2] += (*bfirst)[g + 1];
        }
    return 0;
}


static int grow_edges(dg *d, size_t *cap, size_t need)
{
    size_t c = *cap;
    while (c < need)
        c *= 2;
    uint32_t *a = realloc(d->cea, c * sizeof *a);
    if (a)
        d->cea = a;
    uint32_t *b = a ? realloc(d->ceb, c * sizeof *b) : NULL;
    if (b)
        d->ceb = b;
    if (!a || !b)
        return -1;
    *cap = c;
    return 0;
}

/* Every cell's directed edges into d->cea/ceb (cell c's from cef[c]), an
 * edge split where other cells run back along it through vertices it
 * lacks: a T-junction (an input triangle's edge against two of its
 * neighbour's, which the region cutter keeps as they are), so that the
 * line is inner on both sides, not outline. */
static int split_edges(dg *d)
{
    const hc_engine *e = d->e;
    etab t;
    uint32_t *bfirst = NULL, *bfrom = NULL, X[64];
    size_t cap = (size_t)e->ncell * 4 + 1, n = 0;
    const double tj = HC_DRAW_TJUNCTION * corner_diagonal(e);
    int rc = etab_init(&t, cap);
    d->cef = malloc(((size_t)e->ncell + 1) * sizeof *d->cef);
    d->cea = malloc(cap * sizeof *d->cea), d->ceb = malloc(cap * sizeof *d->ceb);
    for (uint32_t c = 0; !rc && c < e->ncell; c++) {
        uint32_t a[4], b[4];
        int m = raw_edges(d, c, a, b);
        for (int k = 0; k < m; k++) {
            size_t h = etab_find(&t, a[k], b[k]);
            t.a[h] = a[k], t.b[h] = b[k], t.val[h] = 0;
        }
    }
    if (rc || !d->cef || !d->cea || !d->ceb || back_edges(d, &t, &bfirst, &bfrom) != 0)
        rc = -1;
    for (uint32_t j = 0; !rc && j < e->n; j++)
        for (uint32_t c = e->cfirst[j]; !rc && c < e->cfirst[j + 1]; c++) {
            uint32_t a[4], b[4];
            int m = raw_edges(d, c, a, b);
            d->cef[c] = (uint32_t)n;
            for (int k = 0; k < m && !rc; k++) {
                uint32_t nx = t.val[etab_find(&t, b[k], a[k])] != RAD_NONE ? 0
                              : t_chain(d, &t, bfirst, bfrom, a[k], b[k],
                                        fmax(1e-4 * patch_tol(d, j), tj), X, 64);
                if (n + nx + 1 > cap && grow_edges(d, &cap, n + nx + 1) != 0) {
                    rc = -1;
                    break;
                }
                uint32_t from = a[k];
                for (uint32_t q = 0; q < nx; q++)
                    d->cea[n] = from, d->ceb[n++] = X[q], from = X[q];
                d->cea[n] = from, d->ceb[n++] = b[k];
            }
        }
    if (!rc)
        d->cef[e->ncell] = (uint32_t)n;
    etab_free(&t), free(bfirst), free(bfrom);
    return rc;
}

/* The directed edges of cell c (split at T-junctions): from cea[*first]. */
static uint32_t cell_edges(const dg *d, uint32_t c, uint32_t *first)
{
    *first = d->cef[c];
    return d->cef[c + 1] - d->cef[c];
}

/* Every cell's edges into t, valued by patch (an edge run twice in one
 * direction is marked by ORing the top bit). */
static void fill_cell_edges(const dg *d, etab *t)
{
    const hc_engine *e = d->e;
    for (uint32_t j = 0; j < e->n; j++)
        for (uint32_t c = e->cfirst[j]; c < e->cfirst[j + 1]; c++) {
            uint32_t f, m = cell_edges(d, c, &f);
            for (uint32_t k = f; k < f + m; k++) {
                size_t h = etab_find(t, d->cea[k], d->ceb[k]);
                if (t->val[h] == RAD_NONE) {
                    t->a[h] = d->cea[k], t->b[h] = d->ceb[k], t->val[h] = j;
                } else {
                    t->val[h] |= 0x80000000u;
                }
            }
        }
}

/* The outline edges of every patch (a cell edge whose reverse is not a
 * cell edge of the same patch) and the patch across each. */
static int outline_edges(dg *d, char *msg)
{
    const hc_engine *e = d->e;
    etab t;
    size_t cap = (size_t)d->cef[e->ncell] + 1;
    d->efirst = malloc(((size_t)e->n + 1) * sizeof *d->efirst);
    d->ea = malloc(cap * sizeof *d->ea);
    d->eb = malloc(cap * sizeof *d->eb);
    d->epartner = malloc(cap * sizeof *d->epartner);
    if (etab_init(&t, cap) != 0 || !d->efirst || !d->ea || !d->eb || !d->epartner) {
        etab_free(&t);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for the draw geometry");
        return -1;
    }
    fill_cell_edges(d, &t);
    d->ne = 0;
    for (uint32_t j = 0; j < e->n; j++) {
        d->efirst[j] = d->ne;
        for (uint32_t c = e->cfirst[j]; c < e->cfirst[j + 1]; c++) {
            uint32_t f, m = cell_edges(d, c, &f);
            for (uint32_t k = f; k < f + m; k++) {
                const uint32_t a = d->cea[k], b = d->ceb[k];
                uint32_t own = t.val[etab_find(&t, a, b)];
                uint32_t rev = t.val[etab_find(&t, b, a)];
                if (own & 0x80000000u)
                    d->simple[j] = 0; /* an edge run twice one way: not a surface */
                if (rev == j)
                    continue; /* inner edge */
                d->ea[d->ne] = a, d->eb[d->ne] = b;
                d->epartner[d->ne++] = (rev & 0x80000000u) ? RAD_NONE : rev;
            }
        }
    }
    d->efirst[e->n] = d->ne;
    etab_free(&t);
    return 0;
}

/* Patch j's outline as one loop of vertices into d->loop (llen[j]), or
 * llen[j] = 0 when its outline edges are not exactly one simple loop.
 * next[] (per vertex, RAD_NONE between calls) is the walk's scratch. */
static void make_loop(dg *d, uint32_t j, uint32_t *next)
{
    uint32_t f = d->efirst[j], m = d->efirst[j + 1] - f, *L = d->loop + d->lfirst[j];
    d->llen[j] = 0;
    if (m < 3)
        return;
    int ok = 1;
    for (uint32_t q = f; q < f + m; q++) {
        if (next[d->ea[q]] != RAD_NONE)
            ok = 0; /* two ways on from one vertex: a pinched outline */
        next[d->ea[q]] = d->eb[q];
    }
    uint32_t len = 0, at = d->ea[f];
    while (ok && len < m && next[at] != RAD_NONE) {
        L[len++] = at;
        at = next[at];
        if (at == L[0])
            break;
    }
    if (ok && at == L[0] && len == m)
        d->llen[j] = len;
    for (uint32_t q = f; q < f + m; q++)
        next[d->ea[q]] = RAD_NONE;
}

static rad_vec3 vpos(const dg *d, uint32_t g)
{
    return rad_v3(d->pos[3 * (size_t)g], d->pos[3 * (size_t)g + 1], d->pos[3 * (size_t)g + 2]);
}

static double patch_tol(const dg *d, uint32_t j)
{
    return HC_DRAW_TOLERANCE * sqrt(d->e->mesh->patches[j].area);
}

/* Which outline vertices may go: those on the outlines of exactly two
 * patches, both drawn by fans, every outline edge there running between
 * the two.  keep[g] = 1 for every other vertex; tol_of[g] = the chain's
 * tolerance (the smaller patch's) for the others, n_of[g] the mean of the
 * two patches' normals (the same whichever side asks). */
static void fixed_vertices(dg *d, uint32_t *p1, uint32_t *p2, double *tol_of, rad_vec3 *n_of)
{
    for (uint32_t g = 0; g < d->nv; g++)
        p1[g] = p2[g] = RAD_NONE, d->keep[g] = 0;
    for (uint32_t j = 0; j < d->e->n; j++)
        for (uint32_t q = d->efirst[j]; q < d->efirst[j + 1]; q++) {
            const uint32_t ends[2] = {d->ea[q], d->eb[q]}, o = d->epartner[q];
            const int bad = !d->simple[j] || o == RAD_NONE || !d->simple[o];
            for (int s = 0; s < 2; s++) {
                uint32_t g = ends[s];
                if (p1[g] == RAD_NONE || p1[g] == j)
                    p1[g] = j;
                else if (p2[g] == RAD_NONE || p2[g] == j)
                    p2[g] = j;
                else
                    d->keep[g] = 1; /* a third patch meets here */
                d->keep[g] |= (uint8_t)bad;
            }
        }
    /* Every outline edge at a vertex that may go must run between its two. */
    for (uint32_t j = 0; j < d->e->n; j++)
        for (uint32_t q = d->efirst[j]; q < d->efirst[j + 1]; q++) {
            const uint32_t ends[2] = {d->ea[q], d->eb[q]};
            for (int s = 0; s < 2; s++) {
                uint32_t g = ends[s], other = p1[g] == j ? p2[g] : p1[g];
                if (d->epartner[q] != other)
                    d->keep[g] = 1;
            }
        }
    for (uint32_t g = 0; g < d->nv; g++) {
        if (p2[g] == RAD_NONE)
            d->keep[g] = 1;
        if (!d->keep[g]) {
            double a = patch_tol(d, p1[g]), b = patch_tol(d, p2[g]);
            tol_of[g] = a < b ? a : b;
            rad_vec3 na = d->e->mesh->patches[p1[g]].normal, nb = d->e->mesh->patches[p2[g]].normal;
            /* Coplanar: the outline may slide in the plane; else not at all. */
            n_of[g] = rad_dot(na, nb) >= HC_DRAW_COPLANAR ? rad_normalize(rad_add(na, nb))
                                                          : rad_v3(0, 0, 0);
        }
    }
}

/* The point of segment ab nearest to p. */
static rad_vec3 seg_nearest(rad_vec3 p, rad_vec3 a, rad_vec3 b)
{
    rad_vec3 ab = rad_sub(b, a), ap = rad_sub(p, a);
    double l2 = rad_dot(ab, ab), t = l2 > 0.0 ? rad_dot(ap, ab) / l2 : 0.0;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    return rad_add(a, rad_scale(ab, t));
}

/* An offset v measured against the tolerances: across the surface (unit
 * normal n) against tol, along it against tol × SLIDE / TOLERANCE; > 1 is
 * out of tolerance.  n = 0 (an outline between surfaces that are not
 * coplanar): tol in every direction. */
static double off_ratio(rad_vec3 v, rad_vec3 n, double tol)
{
    if (rad_dot(n, n) == 0.0)
        return rad_length(v) / tol;
    double across = fabs(rad_dot(v, n));
    double along = rad_length(rad_sub(v, rad_scale(n, rad_dot(v, n))));
    double a = across / tol, b = along / (tol * HC_DRAW_SLIDE / HC_DRAW_TOLERANCE);
    return a > b ? a : b;
}

/* Douglas-Peucker on the loop's vertices strictly between positions s and
 * t (cyclic, t after s): keeps the farthest from the chord while it is
 * farther than the tolerance.  Ties go to the smaller vertex number, so the
 * outcome is the same whichever way the chain is walked: both patches of a
 * chain keep the same vertices. */
static void simplify_chain(dg *d, const uint32_t *L, uint32_t len, uint32_t s, uint32_t t,
                           const double *tol_of, const rad_vec3 *n_of)
{
    uint32_t span = (t + len - s) % len;
    if (span < 2)
        return;
    rad_vec3 a = vpos(d, L[s]), b = vpos(d, L[t]);
    double best = -1.0;
    uint32_t at = RAD_NONE;
    for (uint32_t k = 1; k < span; k++) {
        uint32_t i = (s + k) % len;
        rad_vec3 p = vpos(d, L[i]);
        double dist = off_ratio(rad_sub(p, seg_nearest(p, a, b)), n_of[L[i]], tol_of[L[i]]);
        if (dist > 1.0 &&
            (dist > best || (dist == best && L[i] < L[at]))) {
            best = dist;
            at = i;
        }
    }
    if (at == RAD_NONE)
        return;
    d->keep[L[at]] = 1;
    simplify_chain(d, L, len, s, at, tol_of, n_of);
    simplify_chain(d, L, len, at, t, tol_of, n_of);
}

/* Simplifies every chain of patch j's loop between its kept vertices.  A
 * loop with none kept (a closed surface cut in two) first keeps its
 * smallest vertex and the one farthest from it: the same two on both sides. */
static void simplify_loop(dg *d, uint32_t j, const double *tol_of, const rad_vec3 *n_of)
{
    const uint32_t *L = d->loop + d->lfirst[j], len = d->llen[j];
    uint32_t first = RAD_NONE;
    for (uint32_t k = 0; k < len && first == RAD_NONE; k++)
        if (d->keep[L[k]])
            first = k;
    if (first == RAD_NONE) {
        uint32_t lo = 0, far = 0;
        for (uint32_t k = 1; k < len; k++)
            lo = L[k] < L[lo] ? k : lo;
        double best = -1.0;
        for (uint32_t k = 0; k < len; k++) {
            double dd = rad_length(rad_sub(vpos(d, L[k]), vpos(d, L[lo])));
            if (dd > best || (dd == best && L[k] < L[far]))
                best = dd, far = k;
        }
        d->keep[L[lo]] = d->keep[L[far]] = 1;
        first = lo;
    }
    uint32_t s = first;
    for (uint32_t k = 1; k <= len; k++) {
        uint32_t i = (first + k) % len;
        if (d->keep[L[i]]) {
            simplify_chain(d, L, len, s, i, tol_of, n_of);
            s = i;
        }
    }
}

/* The point of triangle abc nearest to p. */
static rad_vec3 tri_nearest(rad_vec3 p, rad_vec3 a, rad_vec3 b, rad_vec3 c)
{
    rad_vec3 n = rad_cross(rad_sub(b, a), rad_sub(c, a));
    double nn = rad_dot(n, n);
    if (nn > 0.0) {
        rad_vec3 q = rad_sub(p, rad_scale(n, rad_dot(rad_sub(p, a), n) / nn)); /* on the plane */
        double u = rad_dot(rad_cross(rad_sub(b, q), rad_sub(c, q)), n);
        double v = rad_dot(rad_cross(rad_sub(c, q), rad_sub(a, q)), n);
        double w = rad_dot(rad_cross(rad_sub(a, q), rad_sub(b, q)), n);
        if (u >= 0.0 && v >= 0.0 && w >= 0.0)
            return q;
    }
    rad_vec3 q0 = seg_nearest(p, a, b), q1 = seg_nearest(p, b, c), q2 = seg_nearest(p, c, a);
    double d0 = rad_length(rad_sub(p, q0)), d1 = rad_length(rad_sub(p, q1)),
           d2 = rad_length(rad_sub(p, q2));
    return d0 <= d1 && d0 <= d2 ? q0 : d1 <= d2 ? q1 : q2;
}

/* Patch j's kept outline vertices into K; their number. */
static uint32_t kept_loop(const dg *d, uint32_t j, uint32_t *K)
{
    const uint32_t *L = d->loop + d->lfirst[j];
    uint32_t k = 0;
    for (uint32_t q = 0; q < d->llen[j]; q++)
        if (d->keep[L[q]])
            K[k++] = L[q];
    return k;
}

/* 1 when the triangles T[0..3nt) drawn for patch j meet the file's
 * invariant: every triangle facing n_j, the projection covered once, every
 * cell vertex within the tolerance. */
static int shape_ok(const dg *d, uint32_t j, const rad_vec3 *T, uint32_t nt)
{
    const hc_engine *e = d->e;
    rad_vec3 n = e->mesh->patches[j].normal, slide = n;
    for (uint32_t c = e->cfirst[j]; c < e->cfirst[j + 1]; c++)
        if (rad_dot(e->mesh->cells[c].normal, n) < HC_DRAW_COPLANAR)
            slide = rad_v3(0, 0, 0); /* curved: the shape may not slide along it */
    double drawn = 0.0, cells = 0.0, tol = patch_tol(d, j);
    for (uint32_t q = 0; q < nt; q++) {
        const rad_vec3 *t = T + 3 * (size_t)q;
        double a = rad_dot(rad_cross(rad_sub(t[1], t[0]), rad_sub(t[2], t[0])), n);
        if (!(a >= -1e-9 * e->mesh->patches[j].area))
            return 0; /* faces away (0: a triangle of no area, harmless) */
        drawn += 0.5 * a;
    }
    for (uint32_t c = e->cfirst[j]; c < e->cfirst[j + 1]; c++) {
        rad_vec3 p[4];
        hc_load_corners(e, c, p);
        cells += 0.5 * rad_dot(rad_cross(rad_sub(p[1], p[0]), rad_sub(p[2], p[0])), n);
        if (e->ncorner[c] == 4)
            cells += 0.5 * rad_dot(rad_cross(rad_sub(p[2], p[0]), rad_sub(p[3], p[0])), n);
    }
    /* Covered once: an outline wound twice would double the area; the
     * simplified outline itself moves the area by a few per cent at most. */
    if (nt < 1 || !(fabs(drawn - cells) <= 0.25 * fabs(cells)))
        return 0;
    for (size_t c = e->cfirst[j]; c < e->cfirst[j + 1]; c++)
        for (int s = 0; s < e->ncorner[c]; s++) {
            rad_vec3 p = vpos(d, d->cv[c * 4 + (size_t)s]);
            double best = 1e300;
            for (uint32_t q = 0; q < nt && best > 1.0; q++) {
                const rad_vec3 *t = T + 3 * (size_t)q;
                double r = off_ratio(rad_sub(p, tri_nearest(p, t[0], t[1], t[2])), slide, tol);
                best = r < best ? r : best;
            }
            if (best > 1.0)
                return 0;
        }
    return 1;
}

/* The fan from o to K[0..k) into T; its triangle count. */
static uint32_t fan_shape(const dg *d, const uint32_t *K, uint32_t k, rad_vec3 o, rad_vec3 *T)
{
    for (uint32_t q = 0; q < k; q++) {
        T[3 * q] = o;
        T[3 * q + 1] = vpos(d, K[q]);
        T[3 * q + 2] = vpos(d, K[(q + 1) % k]);
    }
    return k;
}

static int fan_ok(dg *d, uint32_t j, const uint32_t *K, uint32_t k, rad_vec3 o)
{
    return k >= 3 && shape_ok(d, j, d->T, fan_shape(d, K, k, o, d->T));
}

/* Ear clipping of the outline K[0..k) seen along n (counter-clockwise about
 * it): the triangles into T (k - 2 of them), or 0 when some step finds no
 * ear (the outline crosses itself in that view). */
static uint32_t ear_shape(const dg *d, const uint32_t *K, uint32_t k, rad_vec3 n, rad_vec3 *T,
                          uint32_t *left)
{
    rad_vec3 u = rad_normalize(rad_cross(fabs(n.x) < 0.9 ? rad_v3(1, 0, 0) : rad_v3(0, 1, 0), n));
    rad_vec3 v = rad_cross(n, u);
    uint32_t m = k, nt = 0;
    for (uint32_t q = 0; q < k; q++)
        left[q] = q;
#define EAR_X(q) rad_dot(vpos(d, K[left[q]]), u)
#define EAR_Y(q) rad_dot(vpos(d, K[left[q]]), v)
    while (m > 3) {
        uint32_t q = 0;
        for (; q < m; q++) {
            uint32_t a = (q + m - 1) % m, c = (q + 1) % m;
            double ax = EAR_X(a), ay = EAR_Y(a), bx = EAR_X(q), by = EAR_Y(q), cx = EAR_X(c), cy = EAR_Y(c);
            if ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax) < 0.0)
                continue; /* a reflex corner */
            int inside = 0;
            for (uint32_t r = 0; r < m && !inside; r++) {
                if (r == a || r == q || r == c || K[left[r]] == K[left[a]] || K[left[r]] == K[left[c]])
                    continue;
                double px = EAR_X(r), py = EAR_Y(r);
                inside = (bx - ax) * (py - ay) - (by - ay) * (px - ax) >= 0.0 &&
                         (cx - bx) * (py - by) - (cy - by) * (px - bx) >= 0.0 &&
                         (ax - cx) * (py - cy) - (ay - cy) * (px - cx) >= 0.0;
            }
            if (!inside)
                break;
        }
        if (q == m)
            return 0;
        T[3 * nt] = vpos(d, K[left[(q + m - 1) % m]]);
        T[3 * nt + 1] = vpos(d, K[left[q]]);
        T[3 * nt + 2] = vpos(d, K[left[(q + 1) % m]]);
        nt++;
        memmove(left + q, left + q + 1, (size_t)(m - q - 1) * sizeof *left);
        m--;
    }
#undef EAR_X
#undef EAR_Y
    T[3 * nt] = vpos(d, K[left[0]]);
    T[3 * nt + 1] = vpos(d, K[left[1]]);
    T[3 * nt + 2] = vpos(d, K[left[2]]);
    return nt + 1;
}

/* A shape for patch j's kept outline K[0..k) that meets the invariant: a
 * fan (simple[j] = 1) from d->apex[j], the patch's centre or else one of
 * the cells' corners nearest the cells' area centroid; else the outline's
 * ear clipping (simple[j] = 2); 0 when none does. */
static int choose_apex(dg *d, uint32_t j, const uint32_t *K, uint32_t k)
{
    const hc_engine *e = d->e;
    if (fan_ok(d, j, K, k, e->center[j])) {
        d->apex[j] = e->center[j];
        d->simple[j] = 1;
        return 1;
    }
    rad_vec3 mid = {0, 0, 0};
    double area = 0.0;
    for (uint32_t c = e->cfirst[j]; c < e->cfirst[j + 1]; c++) {
        const rad_patch *cell = e->mesh->cell_first ? &e->mesh->cells[c] : &e->mesh->patches[c];
        mid = rad_add(mid, rad_scale(rad_sub(cell->center, e->origin), cell->area));
        area += cell->area;
    }
    mid = rad_scale(mid, 1.0 / area);
    enum { TRIES = 48 };
    uint32_t best[TRIES];
    double bd[TRIES];
    int nb = 0;
    for (size_t q = (size_t)e->cfirst[j] * 4; q < (size_t)e->cfirst[j + 1] * 4; q++) {
        uint32_t g = d->cv[q];
        double dist = rad_length(rad_sub(vpos(d, g), mid));
        int at = nb;
        for (int t = 0; t < nb; t++)
            if (best[t] == g)
                at = -1;
        while (at > 0 && bd[at - 1] > dist)
            at--;
        if (at < 0 || at >= TRIES)
            continue;
        for (int t = (nb < TRIES ? nb : TRIES - 1); t > at; t--)
            best[t] = best[t - 1], bd[t] = bd[t - 1];
        best[at] = g, bd[at] = dist;
        nb += nb < TRIES;
    }
    for (int t = 0; t < nb; t++)
        if (fan_ok(d, j, K, k, vpos(d, best[t]))) {
            d->apex[j] = vpos(d, best[t]);
            d->simple[j] = 1;
            return 1;
        }
    /* No fan: a planar patch by its outline's own triangulation. */
    int planar = 1;
    for (uint32_t c = e->cfirst[j]; c < e->cfirst[j + 1]; c++)
        planar &= rad_dot(e->mesh->cells[c].normal, e->mesh->patches[j].normal) >= HC_DRAW_COPLANAR;
    uint32_t nt = planar && k >= 3 ? ear_shape(d, K, k, e->mesh->patches[j].normal, d->T, d->left) : 0;
    if (nt && shape_ok(d, j, d->T, nt)) {
        d->simple[j] = 2;
        return 1;
    }
    return 0;
}

/* Decides which clusters are drawn by their fans (d->simple) and which
 * outline vertices stay (d->keep), dropping a cluster whose fan fails and
 * deciding again until none does. */
static int decide(dg *d, char *msg)
{
    const hc_engine *e = d->e;
    uint32_t *p1 = malloc((size_t)d->nv * sizeof *p1), *p2 = malloc((size_t)d->nv * sizeof *p2);
    double *tol_of = malloc((size_t)d->nv * sizeof *tol_of);
    rad_vec3 *n_of = malloc((size_t)d->nv * sizeof *n_of);
    uint32_t *K = malloc(((size_t)d->ne + 1) * sizeof *K);
    if (!p1 || !p2 || !tol_of || !n_of || !K) {
        free(p1), free(p2), free(tol_of), free(n_of), free(K);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for the draw geometry");
        return -1;
    }
    for (int round = 0, changed = 1; changed; round++) {
        changed = 0;
        fixed_vertices(d, p1, p2, tol_of, n_of);
        for (uint32_t j = 0; j < e->n; j++)
            if (d->simple[j])
                simplify_loop(d, j, tol_of, n_of);
        for (uint32_t j = 0; j < e->n; j++)
            if (d->simple[j] && (round >= 32 || !choose_apex(d, j, K, kept_loop(d, j, K)))) {
                d->simple[j] = 0; /* cell by cell, and its outline kept whole */
                changed = 1;
            }
    }
    free(p1), free(p2), free(tol_of), free(n_of), free(K);
    return 0;
}

/* The vertices and indices being emitted, one vertex per patch and float
 * position (a cluster's cells share theirs, so the rasteriser shades a
 * shared vertex once). */
typedef struct emit {
    hc_draw *out;
    uint32_t *slot;
    size_t cap;
} emit;

static void put(emit *m, const double p[3], uint32_t id)
{
    hc_draw *o = m->out;
    hc_draw_vtx v = {{(float)p[0], (float)p[1], (float)p[2]}, id};
    size_t h = hash_words(&v, 4) & (m->cap - 1);
    while (m->slot[h] && memcmp(&o->vtx[m->slot[h] - 1], &v, sizeof v) != 0)
        h = (h + 1) & (m->cap - 1);
    if (!m->slot[h]) {
        o->vtx[o->nvtx++] = v;
        m->slot[h] = o->nvtx;
    }
    o->idx[o->nidx++] = m->slot[h] - 1;
}

/* Patch j's triangles: its fan, or its cells. */
static void emit_patch(const dg *d, emit *m, uint32_t j, uint32_t *K)
{
    const hc_engine *e = d->e;
    if (d->simple && d->simple[j]) {
        uint32_t k = kept_loop(d, j, K);
        uint32_t nt = d->simple[j] == 1 ? fan_shape(d, K, k, d->apex[j], d->T)
                                        : ear_shape(d, K, k, e->mesh->patches[j].normal, d->T, d->left);
        for (size_t q = 0; q < 3 * (size_t)nt; q++) {
            const double p[3] = {d->T[q].x, d->T[q].y, d->T[q].z};
            put(m, p, j);
        }
        m->out->simplified++;
        return;
    }
    static const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (uint32_t c = e->cfirst[j]; c < e->cfirst[j + 1]; c++)
        for (int t = 0; t < (e->ncorner[c] == 4 ? 2 : 1); t++)
            for (int s = 0; s < 3; s++)
                put(m, e->corner + (size_t)c * 12 + 3 * tri[t][s], j);
}

/* Counts and emits every patch's triangles into out (vfirst/vcount: each
 * patch's range of indices). */
static int emit_all(const dg *d, hc_draw *out, int *vfirst, int *vcount, char *msg)
{
    const hc_engine *e = d->e;
    size_t ni = 0;
    for (uint32_t j = 0; j < e->n; j++) {
        size_t c = 0;
        if (d->simple && d->simple[j]) {
            uint32_t *K = d->loop + d->lfirst[j], k = 0; /* counted in place: loop is scratch */
            for (uint32_t q = 0; q < d->llen[j]; q++)
                k += d->keep[K[q]];
            c = 3 * (size_t)(d->simple[j] == 1 ? k : k - 2);
        } else {
            for (uint32_t q = e->cfirst[j]; q < e->cfirst[j + 1]; q++)
                c += e->ncorner[q] == 4 ? 6 : 3;
        }
        ni += c;
    }
    emit m = {.out = out, .cap = table_size(ni)};
    out->vtx = malloc((ni + 1) * sizeof *out->vtx);
    out->idx = malloc((ni + 1) * sizeof *out->idx);
    m.slot = calloc(m.cap, sizeof *m.slot);
    uint32_t *K = malloc(((size_t)d->ne + 1) * sizeof *K);
    if (!out->vtx || !out->idx || !m.slot || !K) {
        free(m.slot), free(K);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for %zu vertices", ni);
        return -1;
    }
    for (uint32_t j = 0; j < e->n; j++) {
        vfirst[j] = (int)out->nidx;
        emit_patch(d, &m, j, K);
        vcount[j] = (int)(out->nidx - (size_t)vfirst[j]);
    }
    free(m.slot), free(K);
    return 0;
}

static void dg_free(dg *d)
{
    free(d->cef), free(d->cea), free(d->ceb);
    free(d->cv), free(d->pos), free(d->efirst), free(d->ea), free(d->eb), free(d->epartner);
    free(d->simple), free(d->keep), free(d->loop), free(d->lfirst), free(d->llen), free(d->apex);
    free(d->T), free(d->left);
}

/* The outlines, loops and decisions of d (its e set). */
static int prepare(dg *d, char *msg)
{
    const hc_engine *e = d->e;
    int rc = number_vertices(d, msg);
    d->simple = calloc((size_t)e->n + 1, 1);
    d->lfirst = malloc(((size_t)e->n + 1) * sizeof *d->lfirst);
    d->llen = calloc((size_t)e->n + 1, sizeof *d->llen);
    d->apex = malloc(((size_t)e->n + 1) * sizeof *d->apex);
    if (!rc && (!d->simple || !d->lfirst || !d->llen || !d->apex)) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for the draw geometry");
        rc = -1;
    }
    for (uint32_t j = 0; !rc && j < e->n; j++)
        d->simple[j] = e->cfirst[j + 1] - e->cfirst[j] > 1;
    if (!rc && split_edges(d) != 0) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for the draw geometry");
        rc = -1;
    }
    if (!rc)
        rc = outline_edges(d, msg);
    uint32_t *next = rc ? NULL : malloc(((size_t)d->nv + 1) * sizeof *next);
    d->keep = rc ? NULL : malloc((size_t)d->nv + 1);
    d->loop = rc ? NULL : malloc(((size_t)d->ne + 1) * sizeof *d->loop);
    d->T = rc ? NULL : malloc(3 * ((size_t)d->ne + 1) * sizeof *d->T);
    d->left = rc ? NULL : malloc(((size_t)d->ne + 1) * sizeof *d->left);
    if (!rc && (!next || !d->keep || !d->loop || !d->T || !d->left)) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for the draw geometry");
        rc = -1;
    }
    if (!rc) {
        memset(next, 0xFF, (size_t)d->nv * sizeof *next);
        for (uint32_t j = 0; j < e->n; j++) {
            d->lfirst[j] = d->efirst[j];
            if (d->simple[j])
                make_loop(d, j, next);
            d->simple[j] = d->simple[j] && d->llen[j] > 0;
        }
        rc = decide(d, msg);
    }
    free(next);
    return rc;
}

static int build(const hc_engine *e, int every_cell, hc_draw *out, int *vfirst, int *vcount,
                 char *msg)
{
    dg d = {.e = e};
    *out = (hc_draw){0};
    int rc = 0, clusters = 0;
    for (uint32_t j = 0; j < e->n && !clusters; j++)
        clusters = e->cfirst[j + 1] - e->cfirst[j] > 1;
    if (clusters && !every_cell)
        rc = prepare(&d, msg);
    else
        d.simple = NULL; /* every patch cell by cell */
    if (!rc)
        rc = emit_all(&d, out, vfirst, vcount, msg);
    dg_free(&d);
    if (rc)
        hc_draw_free(out);
    return rc;
}

int hc_draw_build(const hc_engine *e, hc_draw *out, int *vfirst, int *vcount, char *msg)
{
    const char *v = getenv("RADIOSITY_DRAW_EVERY_CELL");
    return build(e, v && strcmp(v, "1") == 0, out, vfirst, vcount, msg);
}

void hc_draw_free(hc_draw *d)
{
    if (!d)
        return;
    free(d->vtx), free(d->idx);
    *d = (hc_draw){0};
}

int hc_draw_triangles(const hc_engine *e, int every_cell, uint64_t *triangles,
                      uint32_t *simplified, rad_error *err)
{
    char msg[HC_MAX_MSG];
    hc_draw d;
    int *vf = malloc(((size_t)e->n + 1) * sizeof *vf), *vc = malloc(((size_t)e->n + 1) * sizeof *vc);
    int rc = vf && vc ? build(e, every_cell, &d, vf, vc, msg) : -1;
    if (!vf || !vc)
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for the draw geometry");
    free(vf), free(vc);
    if (rc)
        return rad_fail(err, RAD_ERR_NOMEM, "%s", msg);
    *triangles = d.nidx / 3;
    *simplified = d.simplified;
    hc_draw_free(&d);
    return RAD_OK;
}
