/* cluster.c - small polygons grouped into patches (mesh_internal.h).
 *
 * A mesh exported from a modeller is many small triangles, and a polygon
 * gets at least one patch: without grouping, the patch size could not
 * lower the patch count below the triangle count, and every triangle would
 * be a patch of its own, drawn from its own three vertices.  Here the
 * eligible polygons (each one cell at this patch size) are joined:
 *
 *   surfaces  - two eligible polygons of one object and material that
 *               share an edge (the same two points, run in opposite
 *               directions: consistently wound) and whose normals lie
 *               within 30° (a modeller's auto-smooth angle) are
 *               neighbours; a surface is a connected set of neighbours.
 *               Its cells share vertices, so the renderer's vertex
 *               averages run smoothly across its polygons as they do
 *               across one polygon's cells, and stop at creases;
 *   clusters  - within a surface, the neighbours whose centres fall in one
 *               cube of side `size` of a grid over the scene's bounds and
 *               whose normals lie within 30° of the first one's; then a
 *               cluster of less than a quarter of size² (a sliver the grid
 *               cut off) joins the smallest neighbouring cluster whose
 *               first normal is within 30° of all of its polygons', if the
 *               two still fit in a box of 1.5 size.  A cluster is a patch:
 *               about size × size, as the mesher's grid cells are, so the
 *               patch size means the same for small and large polygons.
 *
 * A surface of one polygon is left off the cluster path: such a polygon is
 * meshed exactly as before.  Everything is deterministic: points are
 * matched by their weld ids (weld.c: within 1e-6 of the scene's diagonal),
 * ties go to the lowest index.
 */
#include "mesh_internal.h"

#include <stdlib.h>
#include <string.h>

/* The crease and the cluster normal tolerance (mesh.h). */
#define CLUSTER_COS RAD_MESH_SURFACE_COS
/* A cluster smaller than this share of size² is a sliver to merge. */
#define SLIVER_AREA 0.25
/* Merged clusters must fit in a box of this many sizes. */
#define MERGE_EXTENT 1.5

/* ------------------------------------------------------ hashing positions */

static uint64_t mix(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h;
}

/* Open addressing: slot = index + 1, 0 empty. */
typedef struct table {
    uint32_t *slot;
    size_t mask;
} table;

/* The id of the entry with this hash that same(ctx, id) finds equal, or a
 * new id (*count, then incremented; *made = 1) when there is none. */
static uint32_t intern(table *t, uint64_t hash, int (*same)(const void *ctx, uint32_t id),
                       const void *ctx, uint32_t *count, int *made)
{
    *made = 0;
    for (size_t h = hash & t->mask;; h = (h + 1) & t->mask) {
        uint32_t sl = t->slot[h];
        if (!sl) {
            *made = 1;
            t->slot[h] = ++*count;
            return *count - 1;
        }
        if (same(ctx, sl - 1))
            return sl - 1;
    }
}

static int table_init(table *t, size_t entries)
{
    size_t cap = 16;
    while (cap < 2 * entries + 2)
        cap *= 2;
    t->slot = calloc(cap, sizeof *t->slot);
    t->mask = cap - 1;
    return t->slot ? 0 : -1;
}

/* ---------------------------------------------------------------- edges */

typedef struct edge {
    uint64_t key; /* from position << 32 | to position */
    uint32_t polygon;
    uint32_t side; /* edge k of the polygon: point k -> point k+1 */
} edge;

static int edge_cmp(const void *a, const void *b)
{
    const edge *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->polygon < y->polygon ? -1 : x->polygon > y->polygon;
}

uint32_t mesh_uf_find(uint32_t *up, uint32_t x)
{
    while (up[x] != x) {
        up[x] = up[up[x]];
        x = up[x];
    }
    return x;
}

/* Joins the sets of a and b under the lower root: labels stay the lowest
 * index of their set. */
static void join(uint32_t *up, uint32_t a, uint32_t b)
{
    a = mesh_uf_find(up, a);
    b = mesh_uf_find(up, b);
    if (a < b)
        up[b] = a;
    else if (b < a)
        up[a] = b;
}

/* The working state of one clustering. */
typedef struct work {
    const rad_scene *s;
    const uint8_t *elig;
    uint32_t np;
    const uint32_t *pos; /* scene point -> its weld id (mesh_weld) */
    uint32_t *nb;      /* 4 per polygon: the neighbour across edge k, RAD_NONE */
    uint32_t *surf;    /* union-find over polygons: surfaces */
    uint32_t *cl;      /* polygon -> BFS cluster */
    uint32_t ncl;
    double size;
    rad_vec3 lo;
    double weld;       /* points this close are one (MESH_WELD of the diagonal) */
} work;

static int compatible(const rad_scene *s, uint32_t p, uint32_t q)
{
    const rad_polygon *a = &s->polygons[p], *b = &s->polygons[q];
    return p != q && a->object == b->object && a->material == b->material &&
           rad_dot(a->normal, b->normal) >= CLUSTER_COS;
}

typedef struct key_ctx {
    const uint64_t *keys;
    uint64_t key;
} key_ctx;

static int same_key(const void *ctx, uint32_t id)
{
    const key_ctx *c = ctx;
    return c->keys[id] == c->key;
}

/* Point `end` (0 its start, 1 its end) of edge e. */
static rad_vec3 edge_point(const rad_scene *s, const edge *e, int end)
{
    const rad_polygon *pg = &s->polygons[e->polygon];
    return s->points[pg->first_point + (e->side + (uint32_t)end) % pg->point_count];
}

/* The first of E[0..ne) (sorted by key) whose key's high half is id. */
static size_t first_from(const edge *E, size_t ne, uint64_t id)
{
    size_t lo = 0, hi = ne;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (E[mid].key >> 32 < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* For an edge a -> b that no compatible polygon runs back: the lowest
 * compatible polygon whose edge runs back over part of it from one of its
 * ends (b -> y or x -> a, the other end on the line within the weld
 * distance): a T-junction, an exporter's split triangle against its
 * neighbour's whole edge.  from: E keyed by start, to: keyed by end. */
static uint32_t t_neighbour(const work *w, const edge *from, const edge *to, size_t ne,
                            const edge *e)
{
    const rad_vec3 pa = edge_point(w->s, e, 0), ab = rad_sub(edge_point(w->s, e, 1), pa);
    const double l2 = rad_dot(ab, ab);
    const uint64_t a = e->key >> 32, b = e->key & 0xffffffffu;
    uint32_t best = RAD_NONE;
    for (int side = 0; side < 2 && l2 > 0.0; side++) {
        const edge *E = side ? to : from; /* b -> y, then x -> a */
        const uint64_t id = side ? a : b;
        for (size_t q = first_from(E, ne, id); q < ne && E[q].key >> 32 == id; q++) {
            double d2, u = rad_line_foot(rad_sub(edge_point(w->s, &E[q], side ? 0 : 1), pa), ab, l2, &d2);
            if ((side ? u > 0.0 : u < 1.0) && d2 <= w->weld * w->weld &&
                E[q].polygon < best && compatible(w->s, e->polygon, E[q].polygon))
                best = E[q].polygon;
        }
    }
    return best;
}

/* The T-junction neighbours (t_neighbour) across edges still without one. */
static int t_neighbours(work *w, const edge *E, size_t ne)
{
    edge *to = malloc((ne + 1) * sizeof *to);
    if (!to)
        return -1;
    for (size_t e = 0; e < ne; e++) {
        to[e] = E[e];
        to[e].key = E[e].key << 32 | E[e].key >> 32;
    }
    qsort(to, ne, sizeof *to, edge_cmp);
    for (size_t e = 0; e < ne; e++) {
        uint32_t *nb = &w->nb[4 * (size_t)E[e].polygon + E[e].side];
        if (*nb == RAD_NONE && (*nb = t_neighbour(w, E, to, ne, &E[e])) != RAD_NONE)
            join(w->surf, E[e].polygon, *nb);
    }
    free(to);
    return 0;
}

/* nb: each eligible polygon's neighbour across each edge (the lowest
 * compatible polygon running that edge the other way), and the surfaces. */
static int neighbours(work *w)
{
    const rad_scene *s = w->s;
    size_t ne = 0;
    for (uint32_t i = 0; i < w->np; i++)
        if (w->elig[i])
            ne += s->polygons[i].point_count;
    edge *E = malloc((ne + 1) * sizeof *E);
    w->nb = malloc(((size_t)w->np * 4 + 1) * sizeof *w->nb);
    w->surf = malloc(((size_t)w->np + 1) * sizeof *w->surf);
    if (!E || !w->nb || !w->surf) {
        free(E);
        return -1;
    }
    size_t k = 0;
    for (uint32_t i = 0; i < w->np; i++) {
        w->surf[i] = i;
        for (int c = 0; c < 4; c++)
            w->nb[4 * (size_t)i + c] = RAD_NONE;
        const rad_polygon *pg = &s->polygons[i];
        if (!w->elig[i])
            continue;
        for (uint32_t c = 0; c < pg->point_count; c++) {
            uint64_t a = w->pos[pg->first_point + c];
            uint64_t b = w->pos[pg->first_point + (c + 1) % pg->point_count];
            E[k++] = (edge){a << 32 | b, i, c};
        }
    }
    qsort(E, ne, sizeof *E, edge_cmp);
    for (size_t e = 0; e < ne; e++) {
        uint64_t rev = (E[e].key << 32) | (E[e].key >> 32);
        size_t lo = 0, hi = ne; /* first entry with key >= rev */
        while (lo < hi) {
            size_t mid = lo + (hi - lo) / 2;
            if (E[mid].key < rev)
                lo = mid + 1;
            else
                hi = mid;
        }
        for (size_t q = lo; q < ne && E[q].key == rev; q++)
            if (compatible(s, E[e].polygon, E[q].polygon)) {
                w->nb[4 * (size_t)E[e].polygon + E[e].side] = E[q].polygon;
                join(w->surf, E[e].polygon, E[q].polygon);
                break;
            }
    }
    int rc = t_neighbours(w, E, ne);
    free(E);
    return rc;
}

static rad_vec3 mean_point(const rad_scene *s, uint32_t i)
{
    const rad_polygon *pg = &s->polygons[i];
    rad_vec3 c = rad_v3(0, 0, 0);
    for (uint32_t k = 0; k < pg->point_count; k++)
        c = rad_add(c, s->points[pg->first_point + k]);
    return rad_scale(c, 1.0 / pg->point_count);
}

/* The grid cube holding polygon i's centre. */
static void grid_key(const work *w, uint32_t i, int64_t key[3])
{
    rad_vec3 c = rad_scale(rad_sub(mean_point(w->s, i), w->lo), 1.0 / w->size);
    key[0] = (int64_t)floor(c.x);
    key[1] = (int64_t)floor(c.y);
    key[2] = (int64_t)floor(c.z);
}

/* The cluster path: eligible polygons of surfaces with two or more. */
static int on_path(const work *w, const uint32_t *surf_size, uint32_t i)
{
    return w->elig[i] && surf_size[mesh_uf_find(w->surf, i)] > 1;
}

/* Breadth-first clusters: from the lowest polygon not yet taken, its
 * neighbours in the same grid cube whose normals lie within 30° of its. */
static int grow(work *w, const uint32_t *surf_size)
{
    const rad_scene *s = w->s;
    uint32_t *queue = malloc(((size_t)w->np + 1) * sizeof *queue);
    w->cl = malloc(((size_t)w->np + 1) * sizeof *w->cl);
    if (!queue || !w->cl) {
        free(queue);
        return -1;
    }
    for (uint32_t i = 0; i < w->np; i++)
        w->cl[i] = RAD_NONE;
    for (uint32_t i = 0; i < w->np; i++) {
        if (w->cl[i] != RAD_NONE || !on_path(w, surf_size, i))
            continue;
        int64_t key[3];
        grid_key(w, i, key);
        rad_vec3 n0 = s->polygons[i].normal;
        uint32_t head = 0, tail = 0, c = w->ncl++;
        w->cl[i] = c;
        queue[tail++] = i;
        while (head < tail) {
            uint32_t p = queue[head++];
            for (int e = 0; e < 4; e++) {
                uint32_t q = w->nb[4 * (size_t)p + e];
                if (q == RAD_NONE || w->cl[q] != RAD_NONE ||
                    rad_dot(s->polygons[q].normal, n0) < CLUSTER_COS)
                    continue;
                int64_t kq[3];
                grid_key(w, q, kq);
                if (kq[0] != key[0] || kq[1] != key[1] || kq[2] != key[2])
                    continue;
                w->cl[q] = c;
                queue[tail++] = q;
            }
        }
    }
    free(queue);
    return 0;
}

/* Per cluster while merging slivers. */
typedef struct cinfo {
    double area;
    rad_vec3 lo, hi;
    uint32_t lead;  /* first polygon: its normal is the cluster's reference */
    uint8_t grew;   /* took in a sliver: may not move itself */
} cinfo;

static void box_add(cinfo *c, rad_vec3 p)
{
    c->lo = rad_v3(fmin(c->lo.x, p.x), fmin(c->lo.y, p.y), fmin(c->lo.z, p.z));
    c->hi = rad_v3(fmax(c->hi.x, p.x), fmax(c->hi.y, p.y), fmax(c->hi.z, p.z));
}

/* Slivers join a neighbouring cluster (see the top of the file); up is a
 * union-find over the clusters, which ends holding the final grouping. */
static int merge_slivers(work *w, uint32_t *up)
{
    const rad_scene *s = w->s;
    const uint32_t nc = w->ncl;
    cinfo *ci = malloc(((size_t)nc + 1) * sizeof *ci);
    uint32_t *start = calloc((size_t)nc + 2, sizeof *start);
    uint32_t *mem = malloc(((size_t)w->np + 1) * sizeof *mem);
    if (!ci || !start || !mem) {
        free(ci), free(start), free(mem);
        return -1;
    }
    for (uint32_t c = 0; c < nc; c++) {
        up[c] = c;
        ci[c] = (cinfo){0.0, rad_v3(INFINITY, INFINITY, INFINITY),
                        rad_v3(-INFINITY, -INFINITY, -INFINITY), RAD_NONE, 0};
    }
    for (uint32_t i = 0; i < w->np; i++) {
        uint32_t c = w->cl[i];
        if (c == RAD_NONE)
            continue;
        const rad_polygon *pg = &s->polygons[i];
        ci[c].area += pg->area;
        if (ci[c].lead == RAD_NONE)
            ci[c].lead = i;
        for (uint32_t k = 0; k < pg->point_count; k++)
            box_add(&ci[c], s->points[pg->first_point + k]);
        start[c + 2]++;
    }
    for (uint32_t c = 0; c < nc; c++)
        start[c + 2] += start[c + 1];
    for (uint32_t i = 0; i < w->np; i++)
        if (w->cl[i] != RAD_NONE)
            mem[start[w->cl[i] + 1]++] = i;
    const double sliver = SLIVER_AREA * w->size * w->size, extent = MERGE_EXTENT * w->size;
    for (uint32_t c = 0; c < nc; c++) {
        if (ci[c].area >= sliver || ci[c].grew || mesh_uf_find(up, c) != c)
            continue;
        uint32_t best = RAD_NONE;
        for (uint32_t m = start[c]; m < start[c + 1]; m++)
            for (int e = 0; e < 4; e++) {
                uint32_t q = w->nb[4 * (size_t)mem[m] + e];
                if (q == RAD_NONE)
                    continue;
                uint32_t d = mesh_uf_find(up, w->cl[q]);
                if (d == c || (best != RAD_NONE && (ci[d].area > ci[best].area ||
                                                    (ci[d].area == ci[best].area && d > best))))
                    continue;
                cinfo u = ci[d];
                box_add(&u, ci[c].lo);
                box_add(&u, ci[c].hi);
                rad_vec3 span = rad_sub(u.hi, u.lo);
                if (fmax(span.x, fmax(span.y, span.z)) > extent)
                    continue;
                int fits = 1;
                const rad_vec3 nd = s->polygons[ci[d].lead].normal;
                for (uint32_t k = start[c]; k < start[c + 1] && fits; k++)
                    fits = rad_dot(s->polygons[mem[k]].normal, nd) >= CLUSTER_COS;
                if (fits)
                    best = d;
            }
        if (best == RAD_NONE)
            continue;
        up[c] = best;
        ci[best].area += ci[c].area;
        box_add(&ci[best], ci[c].lo);
        box_add(&ci[best], ci[c].hi);
        ci[best].grew = 1;
    }
    free(ci), free(start), free(mem);
    return 0;
}

/* Final numbering (by lowest polygon) and the member lists. */
static int number(work *w, uint32_t *up, mesh_clusters *out)
{
    uint32_t *label = malloc(((size_t)w->ncl + 1) * sizeof *label);
    out->of = malloc(((size_t)w->np + 1) * sizeof *out->of);
    if (!label || !out->of) {
        free(label);
        return -1;
    }
    for (uint32_t c = 0; c < w->ncl; c++)
        label[c] = RAD_NONE;
    uint32_t count = 0;
    for (uint32_t i = 0; i < w->np; i++) {
        out->of[i] = RAD_NONE;
        if (w->cl[i] == RAD_NONE)
            continue;
        uint32_t r = mesh_uf_find(up, w->cl[i]);
        if (label[r] == RAD_NONE)
            label[r] = count++;
        out->of[i] = label[r];
    }
    free(label);
    out->count = count;
    out->first = calloc((size_t)count + 2, sizeof *out->first);
    out->member = malloc(((size_t)w->np + 1) * sizeof *out->member);
    if (!out->first || !out->member)
        return -1;
    for (uint32_t i = 0; i < w->np; i++)
        if (out->of[i] != RAD_NONE)
            out->first[out->of[i] + 2]++;
    for (uint32_t c = 0; c < count; c++)
        out->first[c + 2] += out->first[c + 1];
    for (uint32_t i = 0; i < w->np; i++)
        if (out->of[i] != RAD_NONE)
            out->member[out->first[out->of[i] + 1]++] = i;
    return 0;
}

/* One vertex per surface and position; a vertex is on its surface's
 * outline when an edge without a neighbour ends there. */
static int vertices(work *w, mesh_clusters *out)
{
    const rad_scene *s = w->s;
    size_t count = 0;
    for (uint32_t i = 0; i < w->np; i++)
        if (out->of[i] != RAD_NONE)
            count += s->polygons[i].point_count;
    table t;
    if (table_init(&t, count) != 0)
        return -1;
    uint64_t *keys = malloc((count + 1) * sizeof *keys);
    out->vkey = malloc(((size_t)s->point_count + 1) * sizeof *out->vkey);
    out->vboundary = calloc(count + 1, 1);
    if (!keys || !out->vkey || !out->vboundary) {
        free(t.slot);
        free(keys);
        return -1;
    }
    uint32_t n = 0;
    for (uint32_t i = 0; i < w->np; i++) {
        if (out->of[i] == RAD_NONE)
            continue;
        const rad_polygon *pg = &s->polygons[i];
        uint64_t surf = mesh_uf_find(w->surf, i);
        for (uint32_t k = 0; k < pg->point_count; k++) {
            const uint32_t pt = pg->first_point + k;
            const key_ctx ctx = {keys, surf << 32 | w->pos[pt]};
            int made;
            out->vkey[pt] = intern(&t, mix(ctx.key), same_key, &ctx, &n, &made);
            if (made)
                keys[out->vkey[pt]] = ctx.key;
        }
        for (uint32_t k = 0; k < pg->point_count; k++)
            if (w->nb[4 * (size_t)i + k] == RAD_NONE) {
                out->vboundary[out->vkey[pg->first_point + k]] = 1;
                out->vboundary[out->vkey[pg->first_point + (k + 1) % pg->point_count]] = 1;
            }
    }
    out->vkeys = n;
    free(t.slot);
    free(keys);
    return 0;
}

void mesh_clusters_free(mesh_clusters *c)
{
    if (!c)
        return;
    free(c->of);
    free(c->first);
    free(c->member);
    free(c->vkey);
    free(c->vboundary);
    memset(c, 0, sizeof *c);
}

int mesh_cluster(const rad_scene *s, const uint8_t *eligible, const uint32_t *pos, double size,
                 mesh_clusters *out, rad_error *err)
{
    memset(out, 0, sizeof *out);
    work w = {.s = s, .elig = eligible, .np = s->polygon_count, .size = size, .pos = pos};
    rad_vec3 hi;
    uint32_t *surf_size = NULL, *up = NULL;
    int rc = -1;
    if (!(size > 0.0) || !isfinite(size) || !rad_scene_bounds(s, &w.lo, &hi)) {
        /* no size to group by: nothing on the cluster path */
        out->of = malloc(((size_t)w.np + 1) * sizeof *out->of);
        out->first = calloc(2, sizeof *out->first);
        if (!out->of || !out->first)
            goto done;
        for (uint32_t i = 0; i < w.np; i++)
            out->of[i] = RAD_NONE;
        rc = 0;
        goto done;
    }
    w.weld = MESH_WELD * rad_length(rad_sub(hi, w.lo));
    if (neighbours(&w) != 0)
        goto done;
    surf_size = calloc((size_t)w.np + 1, sizeof *surf_size);
    if (!surf_size)
        goto done;
    for (uint32_t i = 0; i < w.np; i++)
        if (w.elig[i])
            surf_size[mesh_uf_find(w.surf, i)]++;
    if (grow(&w, surf_size) != 0 || !(up = malloc(((size_t)w.ncl + 1) * sizeof *up)) ||
        merge_slivers(&w, up) != 0 || number(&w, up, out) != 0 || vertices(&w, out) != 0)
        goto done;
    rc = 0;
done:
    free(w.nb);
    free(w.surf);
    free(w.cl);
    free(surf_size);
    free(up);
    if (rc != 0) {
        mesh_clusters_free(out);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: mesh: out of memory while grouping %u polygons",
                        s->source ? s->source : "<memory>", s->polygon_count);
    }
    return RAD_OK;
}

/* -------------------------------------------------------- nearest point */

/* The point of triangle abc nearest to p (Ericson, Real-Time Collision
 * Detection, 5.1.5: by the Voronoi regions of the corners and edges). */
static rad_vec3 nearest_on_triangle(rad_vec3 p, rad_vec3 a, rad_vec3 b, rad_vec3 c)
{
    rad_vec3 ab = rad_sub(b, a), ac = rad_sub(c, a), ap = rad_sub(p, a);
    double d1 = rad_dot(ab, ap), d2 = rad_dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0)
        return a;
    rad_vec3 bp = rad_sub(p, b);
    double d3 = rad_dot(ab, bp), d4 = rad_dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3)
        return b;
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0)
        return rad_add(a, rad_scale(ab, d1 / (d1 - d3)));
    rad_vec3 cp = rad_sub(p, c);
    double d5 = rad_dot(ab, cp), d6 = rad_dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6)
        return c;
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0)
        return rad_add(a, rad_scale(ac, d2 / (d2 - d6)));
    double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)
        return rad_add(b, rad_scale(rad_sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
    double den = 1.0 / (va + vb + vc);
    return rad_add(a, rad_add(rad_scale(ab, vb * den), rad_scale(ac, vc * den)));
}

double rad_cell_nearest(const rad_vec3 *V, const uint32_t v[4], rad_vec3 p, rad_vec3 *out)
{
    rad_vec3 q = nearest_on_triangle(p, V[v[0]], V[v[1]], V[v[2]]);
    rad_vec3 d = rad_sub(q, p);
    double best = rad_dot(d, d);
    *out = q;
    if (v[3] != RAD_NONE) {
        q = nearest_on_triangle(p, V[v[0]], V[v[2]], V[v[3]]);
        d = rad_sub(q, p);
        if (rad_dot(d, d) < best) {
            best = rad_dot(d, d);
            *out = q;
        }
    }
    return best;
}
