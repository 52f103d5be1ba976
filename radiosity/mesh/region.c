/* region.c - coplanar polygons meshed as one planar region (mesh_internal.h).
 *
 * A disk written as a 256-sided polygon or a fan of 254 triangles, a wall
 * of slivers, an unwelded export or a T-junctioned floor is one flat
 * surface; meshing each polygon on its own makes the triangulation, not
 * the patch size, set the patch count.  Here:
 *
 *   regions - polygons of one object and material that share a (welded)
 *             point and lie in the plane of the region's first polygon
 *             (normals within ~1°, every point within 1e-5 of the scene's
 *             diagonal of that plane) form a region, grown breadth-first
 *             from its lowest polygon;
 *   grid    - the region gets a grid in its plane, its u axis along the
 *             longest outline edge, over the region's bounding rectangle:
 *             the short side in ceil(L / size) equal steps s, the long side
 *             in equal steps of at most min(size, 2 s); so a grid cell is at
 *             most size wide and at most twice as long as it is wide;
 *   pieces  - every polygon is clipped to every grid cell it covers, on
 *             vertices shared across the region (points on a shared edge
 *             are computed from the edge's ends in one order, so both
 *             sides get the same numbers);
 *   cells   - the pieces of one grid cell (or part) are joined, so that
 *             the cells follow the grid, not the triangulation (a fan disk
 *             has the cells of its polygon): the edges two pieces run both
 *             ways cancel, the rest must chain into one simple loop of the
 *             pieces' area; a corner on a grid line between two stretches
 *             of it is dropped where the grid cell across the line drops
 *             it too; the loop is one quad, a fan of quads when convex, or
 *             ear-clipped triangles (rad_mesh's cell layer is triangles
 *             and quads).  Where the union is not that clean (holes,
 *             pieces apart, T-junctions inside, another area) or would
 *             not make fewer cells, the grid cell keeps its pieces, each a
 *             quad or a fan of triangles.  Only polygons that differ in
 *             nothing but their outline are joined (one object and
 *             material, as in every region, the same ρ of their own, no
 *             base-colour texture whose coordinates each maps its own
 *             way), so a joined cell's polygon, the lowest of its pieces',
 *             stands for any of them;
 *   feet    - where another surface stands on the region inside its
 *             outline (a block on a floor: a polygon from in front of the
 *             plane that reaches it), the light on the region changes
 *             within a patch: the grid cells that line crosses are cut
 *             into REGION_FOOT × REGION_FOOT parts, each a patch of its
 *             own (where a wall meets a floor along the floor's outline,
 *             a corner, nothing is cut);
 *   patches - the pieces in one grid cell (or part) are one patch; a
 *             patch of less than a quarter of its cell (part), or longer
 *             than 4 × its area
 *             allows (longest side² / area > 4), joins the neighbouring
 *             patch that keeps the pair best shaped, if the pair is then no
 *             longer than 2 × size and longest side² / area <= 4.
 *
 * So a patch is about size × size whatever the polygons (longest side of
 * its box in the grid's frame <= 2 × size, longest side² / area <= 4),
 * except where the region itself is smaller.  Each patch is planar: its
 * normal is the region's (its first polygon's), its area the sum of its
 * cells', its centre their area centroid moved onto the nearest cell
 * (mesh_patch_of_cells).  Vertex positions are the region's plane at the
 * points' (u, v): a polygon within the planarity tolerance is flattened.
 */
#include "mesh_internal.h"

#include <stdlib.h>
#include <string.h>

/* Normals of one region agree within about 1.1° (cos). */
#define REGION_COS 0.9998
/* Points of one region lie within this share of the scene's diagonal of
 * the first polygon's plane. */
#define REGION_PLANE_TOL 1e-5
/* Patch shape: longest side² / area at most this; merged patches at most
 * REGION_LONGEST × size long; smaller than REGION_SLIVER of a grid cell
 * is a sliver to merge. */
#define REGION_RATIO 4.0
#define REGION_LONGEST 2.0
#define REGION_SLIVER 0.25
/* Where another surface stands on a region, a grid cell is cut into
 * REGION_FOOT × REGION_FOOT patches. */
#define REGION_FOOT 2
/* A contact nearer the region's outline than this share of the size is a
 * corner, not a foot. */
#define REGION_CORNER 0.1

typedef struct pt2 {
    double c[2];
} pt2;

#define GROW(arr, cap, need) mesh_grow((void **)&(arr), &(cap), (need), sizeof *(arr))

/* One region's scratch, reused. */
typedef struct rwork {
    const rad_scene *s;
    const uint32_t *pos, *first; /* weld ids, their positions' points */
    uint32_t npos;
    double size;
    /* frame and grid */
    rad_vec3 O, U, V, N;
    double x0, y0, x1, y1, sx, sy;
    uint64_t nx, ny;
    /* raw piece corners (before merging equal ones) */
    pt2 *raw;
    size_t nraw, craw;
    /* cells: corners index raw (then unique ids), grid cell per cell */
    rad_patch *cell;
    uint64_t *gi;
    size_t ncell, ccell, cgi;
    pt2 *tmp[3];
    size_t ctmp[3];
    uint64_t *ekey;
    size_t cekey;
    uint64_t climit; /* cells this region may still make */
    size_t nekey;    /* frame(): the members' edges in ekey, then the same
                      * keyed by end (t_chain) */
    uint64_t *okey;  /* frame(): the outline's edges (outline()) */
    size_t nokey, cokey;
    double tol;      /* in the plane: within this of it */
    double weld;     /* points this close are one (mesh_weld's distance) */
    pt2 *oe;         /* the outline's edges in the plane, two ends each */
    size_t noe, coe;
    double *pbox;    /* per scene polygon its box: lo x y z, hi x y z (feet()) */
    uint64_t *foot;  /* grid cells cut into four (sorted, unique) */
    size_t nfoot, cfoot;
} rwork;

/* --------------------------------------------------------------- regions */

static int in_plane(const rad_scene *s, const uint32_t *pos, const uint32_t *first,
                    uint32_t lead, uint32_t q, double tol)
{
    const rad_polygon *a = &s->polygons[lead], *b = &s->polygons[q];
    if (a->object != b->object || a->material != b->material ||
        rad_dot(a->normal, b->normal) < REGION_COS)
        return 0;
    rad_vec3 o = s->points[first[pos[a->first_point]]];
    for (uint32_t k = 0; k < b->point_count; k++) {
        rad_vec3 p = s->points[first[pos[b->first_point + k]]];
        if (fabs(rad_dot(rad_sub(p, o), a->normal)) > tol)
            return 0;
    }
    return 1;
}

/* Region per polygon (of[], RAD_NONE where mode is 0), numbered by lowest
 * polygon; *count regions.  inc/ifirst: weld id -> polygons (CSR). */
static int find_regions(const rad_scene *s, const uint32_t *pos, const uint32_t *first,
                        uint32_t npos, const uint8_t *mode, double tol, uint32_t *of,
                        uint32_t *count)
{
    const uint32_t np = s->polygon_count;
    uint32_t *ifirst = calloc((size_t)npos + 2, sizeof *ifirst);
    uint32_t *stamp = malloc(((size_t)npos + 1) * sizeof *stamp);
    uint32_t *queue = malloc(((size_t)np + 1) * sizeof *queue);
    size_t ninc = 0;
    for (uint32_t i = 0; i < np; i++)
        ninc += mode[i] ? s->polygons[i].point_count : 0;
    uint32_t *inc = malloc((ninc + 1) * sizeof *inc);
    if (!ifirst || !stamp || !queue || !inc) {
        free(ifirst), free(stamp), free(queue), free(inc);
        return -1;
    }
    for (uint32_t i = 0; i < np; i++)
        for (uint32_t k = 0; mode[i] && k < s->polygons[i].point_count; k++)
            ifirst[pos[s->polygons[i].first_point + k] + 2]++;
    for (uint32_t j = 0; j < npos; j++)
        ifirst[j + 2] += ifirst[j + 1];
    for (uint32_t i = 0; i < np; i++)
        for (uint32_t k = 0; mode[i] && k < s->polygons[i].point_count; k++)
            inc[ifirst[pos[s->polygons[i].first_point + k] + 1]++] = i;
    for (uint32_t j = 0; j < npos; j++)
        stamp[j] = RAD_NONE;
    for (uint32_t i = 0; i < np; i++)
        of[i] = RAD_NONE;
    *count = 0;
    for (uint32_t i = 0; i < np; i++) {
        if (!mode[i] || of[i] != RAD_NONE)
            continue;
        uint32_t r = (*count)++, head = 0, tail = 0;
        of[i] = r;
        queue[tail++] = i;
        while (head < tail) {
            const rad_polygon *pg = &s->polygons[queue[head++]];
            for (uint32_t k = 0; k < pg->point_count; k++) {
                uint32_t id = pos[pg->first_point + k];
                if (stamp[id] == r)
                    continue; /* its polygons were all looked at for this region */
                stamp[id] = r;
                for (uint32_t e = ifirst[id]; e < ifirst[id + 1]; e++) {
                    uint32_t q = inc[e];
                    if (of[q] == RAD_NONE && in_plane(s, pos, first, i, q, tol)) {
                        of[q] = r;
                        queue[tail++] = q;
                    }
                }
            }
        }
    }
    free(ifirst), free(stamp), free(queue), free(inc);
    return 0;
}

/* ------------------------------------------------------------ the grid */

static rad_vec3 point_of(const rwork *w, uint32_t pt)
{
    return w->s->points[w->first[w->pos[pt]]];
}

static pt2 to2d(const rwork *w, rad_vec3 p)
{
    rad_vec3 d = rad_sub(p, w->O);
    pt2 r = {{rad_dot(d, w->U), rad_dot(d, w->V)}};
    return r;
}

static int u64_cmp(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* The first of K[0..n) (sorted) whose high half is id, else n. */
static size_t first_from(const uint64_t *K, size_t n, uint64_t id)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (K[mid] >> 32 < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* Whether the members run edge a -> b (w->ekey, sorted). */
static int has_edge(const rwork *w, uint32_t a, uint32_t b)
{
    const uint64_t key = (uint64_t)a << 32 | b;
    return bsearch(&key, w->ekey, w->nekey, sizeof *w->ekey, u64_cmp) != NULL;
}

/* The points strictly inside member edge a -> b (within the weld distance
 * of the segment) through which other members' edges run back from b to a
 * (x1 -> a, x2 -> x1, ..., b -> xk): a T-junction, an exporter's split
 * triangle against its neighbour's whole edge.  Into X[0..max); their
 * count, 0 when there is no such chain.  back: the members' edges keyed
 * end << 32 | start, sorted. */
static uint32_t t_chain(const rwork *w, const uint64_t *back, uint32_t a, uint32_t b, uint32_t *X,
                        uint32_t max)
{
    const rad_vec3 pa = w->s->points[w->first[a]], ab = rad_sub(w->s->points[w->first[b]], pa);
    const double l2 = rad_dot(ab, ab), tol2 = w->weld * w->weld;
    uint32_t cur = a, k = 0;
    double at = 0.0;
    while (k < max && l2 > 0.0) {
        if (k > 0 && has_edge(w, b, cur))
            return k;
        uint32_t next = RAD_NONE;
        double best = 1.0;
        for (size_t q = first_from(back, w->nekey, cur); q < w->nekey && back[q] >> 32 == cur; q++) {
            const uint32_t x = (uint32_t)back[q];
            double d2, u = rad_line_foot(rad_sub(w->s->points[w->first[x]], pa), ab, l2, &d2);
            if (u > at && u < best && d2 <= tol2)
                best = u, next = x;
        }
        if (next == RAD_NONE)
            return 0;
        X[k++] = next, cur = next, at = best;
    }
    return 0;
}

/* The region's outline into w->okey (start << 32 | end, weld ids): the
 * members' edges, each cut at the T-junctions along it (t_chain), that no
 * member runs the other way.  A triangle's whole edge against its
 * neighbour's two halves, and each half against the whole, are inner. */
static int outline(rwork *w)
{
    const size_t ne = w->nekey;
    const uint64_t *back = w->ekey + ne;
    uint32_t X[64];
    size_t n = 0;
    for (size_t e = 0; e < ne; e++) {
        const uint32_t a = (uint32_t)(w->ekey[e] >> 32), b = (uint32_t)w->ekey[e];
        uint32_t k = has_edge(w, b, a) ? 0 : t_chain(w, back, a, b, X, 64);
        if (GROW(w->okey, w->cokey, n + k + 1) != 0)
            return -1;
        uint32_t from = a;
        for (uint32_t q = 0; q < k; q++)
            w->okey[n++] = (uint64_t)from << 32 | X[q], from = X[q];
        w->okey[n++] = (uint64_t)from << 32 | b;
    }
    if (GROW(w->okey, w->cokey, 2 * n + 1) != 0)
        return -1;
    qsort(w->okey, n, sizeof *w->okey, u64_cmp);
    size_t kept = 0;
    for (size_t e = 0; e < n; e++) { /* the outline after the pieces, then moved down */
        const uint64_t rev = w->okey[e] << 32 | w->okey[e] >> 32;
        if (!bsearch(&rev, w->okey, n, sizeof *w->okey, u64_cmp))
            w->okey[n + kept++] = w->okey[e];
    }
    memmove(w->okey, w->okey + n, kept * sizeof *w->okey);
    w->nokey = kept;
    return 0;
}

/* Frame: normal of the lead polygon, u along the region's longest outline
 * edge (outline()). */
static int frame(rwork *w, const uint32_t *mem, uint32_t nm)
{
    const rad_scene *s = w->s;
    const rad_polygon *lead = &s->polygons[mem[0]];
    w->N = lead->normal;
    w->O = point_of(w, lead->first_point);
    size_t ne = 0;
    for (uint32_t m = 0; m < nm; m++)
        ne += s->polygons[mem[m]].point_count;
    if (GROW(w->ekey, w->cekey, 2 * ne + 1) != 0)
        return -1;
    ne = 0;
    for (uint32_t m = 0; m < nm; m++) {
        const rad_polygon *pg = &s->polygons[mem[m]];
        for (uint32_t k = 0; k < pg->point_count; k++)
            w->ekey[ne++] = (uint64_t)w->pos[pg->first_point + k] << 32 |
                            w->pos[pg->first_point + (k + 1) % pg->point_count];
    }
    qsort(w->ekey, ne, sizeof *w->ekey, u64_cmp);
    w->nekey = ne;
    uint64_t *back = w->ekey + ne; /* the edges keyed by end, then start */
    for (size_t e = 0; e < ne; e++)
        back[e] = w->ekey[e] << 32 | w->ekey[e] >> 32;
    qsort(back, ne, sizeof *back, u64_cmp);
    if (outline(w) != 0)
        return -1;
    double best = -1.0;
    rad_vec3 dir = rad_v3(0, 0, 0);
    for (size_t e = 0; e < w->nokey; e++) {
        rad_vec3 a = s->points[w->first[w->okey[e] >> 32]];
        rad_vec3 b = s->points[w->first[w->okey[e] & 0xffffffffu]];
        rad_vec3 d = rad_sub(b, a);
        d = rad_sub(d, rad_scale(w->N, rad_dot(d, w->N)));
        if (rad_length(d) > best) {
            best = rad_length(d);
            dir = d;
        }
    }
    if (!(best > 0.0)) /* cannot happen for a polygon of positive area */
        dir = rad_sub(point_of(w, lead->first_point + 1), w->O);
    w->U = rad_normalize(dir);
    w->V = rad_cross(w->N, w->U);
    return 0;
}

/* Steps along the short side of the box, then the long one (see the top). */
static void grid(rwork *w, const uint32_t *mem, uint32_t nm)
{
    w->x0 = w->y0 = INFINITY;
    w->x1 = w->y1 = -INFINITY;
    for (uint32_t m = 0; m < nm; m++) {
        const rad_polygon *pg = &w->s->polygons[mem[m]];
        for (uint32_t k = 0; k < pg->point_count; k++) {
            pt2 p = to2d(w, point_of(w, pg->first_point + k));
            w->x0 = fmin(w->x0, p.c[0]), w->x1 = fmax(w->x1, p.c[0]);
            w->y0 = fmin(w->y0, p.c[1]), w->y1 = fmax(w->y1, p.c[1]);
        }
    }
    double lx = w->x1 - w->x0, ly = w->y1 - w->y0;
    double shortside = fmin(lx, ly), longside = fmax(lx, ly);
    uint64_t ns = mesh_divisions(shortside, w->size);
    double ss = ns == UINT64_MAX ? 0.0 : shortside / (double)ns;
    uint64_t nl = mesh_divisions(longside, fmin(w->size, 2.0 * ss));
    double sl = nl == UINT64_MAX ? 0.0 : longside / (double)nl;
    if (lx <= ly) {
        w->nx = ns, w->sx = ss, w->ny = nl, w->sy = sl;
    } else {
        w->nx = nl, w->sx = sl, w->ny = ns, w->sy = ss;
    }
}

/* ------------------------------------------------------------- clipping */

/* The point of segment ab on the line c[axis] = at, computed from the end
 * that sorts first, so that both polygons of a shared edge get the same. */
static pt2 isect(pt2 a, pt2 b, int axis, double at)
{
    if (a.c[0] > b.c[0] || (a.c[0] == b.c[0] && a.c[1] > b.c[1])) {
        pt2 t = a;
        a = b;
        b = t;
    }
    double t = (at - a.c[axis]) / (b.c[axis] - a.c[axis]);
    pt2 r;
    r.c[axis] = at;
    r.c[1 - axis] = a.c[1 - axis] + t * (b.c[1 - axis] - a.c[1 - axis]);
    return r;
}

/* Sutherland-Hodgman against one half-plane: keep c[axis] >= at (ge) or <=. */
static size_t clip(const pt2 *in, size_t n, pt2 *out, int axis, double at, int ge)
{
    size_t m = 0;
    for (size_t k = 0; k < n; k++) {
        pt2 a = in[k], b = in[(k + 1) % n];
        int ia = ge ? a.c[axis] >= at : a.c[axis] <= at;
        int ib = ge ? b.c[axis] >= at : b.c[axis] <= at;
        if (ia)
            out[m++] = a;
        if (ia != ib)
            out[m++] = isect(a, b, axis, at);
    }
    return m;
}

static double line_at(const rwork *w, int axis, uint64_t i)
{
    if (axis == 0)
        return i >= w->nx ? w->x1 : w->x0 + (double)i * w->sx;
    return i >= w->ny ? w->y1 : w->y0 + (double)i * w->sy;
}

static double tri2(pt2 a, pt2 b, pt2 c)
{
    return 0.5 * ((b.c[0] - a.c[0]) * (c.c[1] - a.c[1]) - (c.c[0] - a.c[0]) * (b.c[1] - a.c[1]));
}

/* One cell on raw corners r[0..k) (k = 3 or 4), of grid cell g. */
static int add_cell(rwork *w, const rad_polygon *pg, uint32_t polygon, const uint32_t *r, int k,
                    uint64_t g)
{
    if (w->ncell >= w->climit)
        return -3;
    if (GROW(w->cell, w->ccell, w->ncell + 1) != 0 || GROW(w->gi, w->cgi, w->ncell + 1) != 0)
        return -1;
    rad_patch *c = &w->cell[w->ncell];
    memset(c, 0, sizeof *c);
    for (int q = 0; q < 4; q++)
        c->v[q] = q < k ? r[q] : RAD_NONE;
    c->polygon = polygon;
    c->object = pg->object;
    c->material = pg->material;
    c->normal = w->N;
    w->gi[w->ncell++] = g;
    return 0;
}

/* A convex piece p[0..n) of grid cell g: one quad, or a fan of triangles
 * without the ones of no area (corners on one line). */
static int add_piece(rwork *w, uint32_t polygon, const pt2 *p, size_t n, uint64_t g)
{
    const rad_polygon *pg = &w->s->polygons[polygon];
    const double tiny = 1e-12 * w->sx * w->sy;
    size_t m = 0;
    uint32_t base = (uint32_t)w->nraw;
    if (GROW(w->raw, w->craw, w->nraw + n + 1) != 0)
        return -1;
    m = mesh_ring_unique(p, n, &w->raw[base], sizeof *p);
    if (m < 3)
        return 0;
    w->nraw += m;
    const pt2 *q = &w->raw[base];
    if (m == 4 && tri2(q[0], q[1], q[2]) > tiny && tri2(q[0], q[2], q[3]) > tiny) {
        uint32_t r[4] = {base, base + 1, base + 2, base + 3};
        return add_cell(w, pg, polygon, r, 4, g);
    }
    for (size_t t = 1; t + 1 < m; t++)
        if (tri2(q[0], q[t], q[t + 1]) > tiny) {
            uint32_t r[3] = {base, base + (uint32_t)t, base + (uint32_t)t + 1};
            int rc = add_cell(w, pg, polygon, r, 3, g);
            if (rc != 0)
                return rc;
        }
    return 0;
}

static int is_foot(const rwork *w, uint64_t g)
{
    return w->nfoot && bsearch(&g, w->foot, w->nfoot, sizeof *w->foot, u64_cmp) != NULL;
}

/* Line j of REGION_FOOT between grid lines i and i + 1 along axis. */
static double sub_line(const rwork *w, int axis, uint64_t i, int j)
{
    if (j == REGION_FOOT)
        return line_at(w, axis, i + 1);
    return line_at(w, axis, i) + (axis ? w->sy : w->sx) * (double)j / REGION_FOOT;
}

/* Piece p[0..n) of grid cell (x, y), cut into REGION_FOOT² parts where
 * another surface stands (is_foot).  Its id: REGION_FOOT² × the cell's +
 * the part's. */
static int add_parts(rwork *w, uint32_t i, const pt2 *p, size_t n, uint64_t x, uint64_t y)
{
    const uint64_t g = y * w->nx + x, parts = REGION_FOOT * REGION_FOOT;
    if (!is_foot(w, g))
        return add_piece(w, i, p, n, parts * g);
    if (GROW(w->tmp[2], w->ctmp[2], 3 * (n + 8)) != 0)
        return -1;
    pt2 *a = w->tmp[2], *b = a + n + 8, *c = b + n + 8;
    for (int k = 0; k < (int)parts; k++) {
        const int u = k % REGION_FOOT, v = k / REGION_FOOT;
        size_t m = clip(p, n, a, 0, sub_line(w, 0, x, u), 1);
        m = m >= 3 ? clip(a, m, b, 0, sub_line(w, 0, x, u + 1), 0) : 0;
        m = m >= 3 ? clip(b, m, a, 1, sub_line(w, 1, y, v), 1) : 0;
        m = m >= 3 ? clip(a, m, c, 1, sub_line(w, 1, y, v + 1), 0) : 0;
        int rc = m >= 3 ? add_piece(w, i, c, m, parts * g + (uint64_t)k) : 0;
        if (rc != 0)
            return rc;
    }
    return 0;
}

/* Clips polygon i to every grid cell its box covers. */
static int cut_polygon(rwork *w, uint32_t i)
{
    const rad_polygon *pg = &w->s->polygons[i];
    const size_t n = pg->point_count, cap = n + 8;
    if (GROW(w->tmp[0], w->ctmp[0], 2 * cap) != 0 || GROW(w->tmp[1], w->ctmp[1], 2 * cap) != 0)
        return -1;
    pt2 *P = w->tmp[0], *strip = w->tmp[0] + cap, *a = w->tmp[1], *b = w->tmp[1] + cap;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (size_t k = 0; k < n; k++) {
        P[k] = to2d(w, point_of(w, pg->first_point + (uint32_t)k));
        for (int d = 0; d < 2; d++)
            lo[d] = fmin(lo[d], P[k].c[d]), hi[d] = fmax(hi[d], P[k].c[d]);
    }
    const double step[2] = {w->sx, w->sy}, org[2] = {w->x0, w->y0};
    const uint64_t cnt[2] = {w->nx, w->ny};
    uint64_t from[2], to[2];
    for (int d = 0; d < 2; d++) {
        double f = floor((lo[d] - org[d]) / step[d]), t = floor((hi[d] - org[d]) / step[d]);
        from[d] = f < 0 ? 0 : f >= (double)cnt[d] ? cnt[d] - 1 : (uint64_t)f;
        to[d] = t < 0 ? 0 : t >= (double)cnt[d] ? cnt[d] - 1 : (uint64_t)t;
    }
    for (uint64_t x = from[0]; x <= to[0]; x++) {
        size_t ns = clip(P, n, a, 0, line_at(w, 0, x), 1);
        ns = clip(a, ns, strip, 0, line_at(w, 0, x + 1), 0);
        for (uint64_t y = from[1]; ns >= 3 && y <= to[1]; y++) {
            size_t m = clip(strip, ns, a, 1, line_at(w, 1, y), 1);
            m = clip(a, m, b, 1, line_at(w, 1, y + 1), 0);
            int rc = m >= 3 ? add_parts(w, i, b, m, x, y) : 0;
            if (rc != 0)
                return rc;
        }
    }
    return 0;
}

/* ------------------------------------------------------------- feet */

/* Where polygon q meets the region's plane, in the plane's coordinates:
 * 1 when q reaches the plane (within w->tol) from in front of it, and is
 * not of the region's own surface (mesh.h's RAD_MESH_SURFACE_COS). */
static int meets_plane(const rwork *w, const rad_polygon *lead, uint32_t q, pt2 *a, pt2 *b)
{
    const rad_polygon *pg = &w->s->polygons[q];
    const rad_vec3 *Q = w->s->points + pg->first_point;
    if (pg->object == lead->object && pg->material == lead->material &&
        rad_dot(pg->normal, lead->normal) >= RAD_MESH_SURFACE_COS)
        return 0;
    double dmin = INFINITY, dmax = -INFINITY;
    for (uint32_t k = 0; k < pg->point_count; k++) {
        double d = rad_dot(rad_sub(Q[k], w->O), w->N);
        dmin = fmin(dmin, d), dmax = fmax(dmax, d);
    }
    if (!(dmax > w->tol) || !(dmin <= w->tol))
        return 0;
    int got = 0;
    for (uint32_t k = 0; k < pg->point_count; k++) {
        rad_vec3 u = Q[k], v = Q[(k + 1) % pg->point_count], hit[2];
        double du = rad_dot(rad_sub(u, w->O), w->N), dv = rad_dot(rad_sub(v, w->O), w->N);
        int nh = 0;
        if (fabs(du) <= w->tol)
            hit[nh++] = u;
        if ((du > w->tol && dv < -w->tol) || (du < -w->tol && dv > w->tol))
            hit[nh++] = rad_add(u, rad_scale(rad_sub(v, u), du / (du - dv)));
        for (int h = 0; h < nh; h++) {
            pt2 p = to2d(w, hit[h]);
            if (!got++)
                *a = *b = p;
            else if (hypot(p.c[0] - a->c[0], p.c[1] - a->c[1]) >
                     hypot(b->c[0] - a->c[0], b->c[1] - a->c[1]))
                *b = p;
        }
    }
    return got > 0;
}

static double seg_dist(pt2 p, pt2 a, pt2 b)
{
    double dx = b.c[0] - a.c[0], dy = b.c[1] - a.c[1], l2 = dx * dx + dy * dy;
    double t = l2 > 0.0 ? ((p.c[0] - a.c[0]) * dx + (p.c[1] - a.c[1]) * dy) / l2 : 0.0;
    t = fmin(1.0, fmax(0.0, t));
    return hypot(p.c[0] - a.c[0] - t * dx, p.c[1] - a.c[1] - t * dy);
}

/* Is p inside member polygon q (convex, counter-clockwise about the
 * region's normal), not just on its edge? */
static int in_member(const rwork *w, uint32_t q, pt2 p)
{
    const rad_polygon *pg = &w->s->polygons[q];
    pt2 a = to2d(w, point_of(w, pg->first_point + pg->point_count - 1));
    for (uint32_t k = 0; k < pg->point_count; k++) {
        pt2 b = to2d(w, point_of(w, pg->first_point + k));
        double len = hypot(b.c[0] - a.c[0], b.c[1] - a.c[1]);
        if (len > 0.0 && tri2(a, b, p) <= 0.5 * w->tol * len)
            return 0;
        a = b;
    }
    return 1;
}

/* Does segment ab stand inside the region: one of its ends or seven points
 * between them inside a member and farther than REGION_CORNER × size from
 * the outline (so a wall meeting a floor along the floor's edge, a corner,
 * does not, even a wall some tenths of a millimetre off it as the Cornell
 * box's published red wall)? */
static int stands_inside(const rwork *w, const uint32_t *mem, uint32_t nm, pt2 a, pt2 b)
{
    for (int k = 0; k <= 8; k++) {
        const double t = k / 8.0;
        const pt2 p = {{a.c[0] + t * (b.c[0] - a.c[0]), a.c[1] + t * (b.c[1] - a.c[1])}};
        size_t e = 0;
        while (e < w->noe && seg_dist(p, w->oe[2 * e], w->oe[2 * e + 1]) > REGION_CORNER * w->size)
            e++;
        for (uint32_t m = 0; e == w->noe && m < nm; m++)
            if (in_member(w, mem[m], p))
                return 1;
    }
    return 0;
}

/* Clips segment ab to the grid's box; 0 when nothing is left. */
static int clip_to_box(const rwork *w, pt2 *a, pt2 *b)
{
    double t0 = 0.0, t1 = 1.0;
    const double lo[2] = {w->x0, w->y0}, hi[2] = {w->x1, w->y1};
    for (int d = 0; d < 2; d++) {
        double dd = b->c[d] - a->c[d];
        if (dd == 0.0) {
            if (a->c[d] < lo[d] || a->c[d] > hi[d])
                return 0;
            continue;
        }
        double ta = (lo[d] - a->c[d]) / dd, tb = (hi[d] - a->c[d]) / dd;
        t0 = fmax(t0, fmin(ta, tb)), t1 = fmin(t1, fmax(ta, tb));
    }
    if (t0 > t1)
        return 0;
    pt2 p = *a, q = *b;
    for (int d = 0; d < 2; d++)
        a->c[d] = p.c[d] + t0 * (q.c[d] - p.c[d]), b->c[d] = p.c[d] + t1 * (q.c[d] - p.c[d]);
    return 1;
}

/* Appends to w->foot the grid cells segment ab crosses, column by column. */
static int mark_cells(rwork *w, pt2 a, pt2 b)
{
    const double dx = b.c[0] - a.c[0];
    double fx = floor((fmin(a.c[0], b.c[0]) - w->x0) / w->sx);
    double tx = floor((fmax(a.c[0], b.c[0]) - w->x0) / w->sx);
    fx = fmax(0.0, fx), tx = fmin((double)w->nx - 1.0, tx);
    for (uint64_t x = (uint64_t)fx; fx <= tx && x <= (uint64_t)tx; x++) {
        double lo = line_at(w, 0, x), hi = line_at(w, 0, x + 1), t0 = 0.0, t1 = 1.0;
        if (fabs(dx) > 0.0) {
            double ta = (lo - a.c[0]) / dx, tb = (hi - a.c[0]) / dx;
            t0 = fmax(0.0, fmin(ta, tb)), t1 = fmin(1.0, fmax(ta, tb));
        } else if (a.c[0] < lo || a.c[0] > hi) {
            continue;
        }
        if (t0 > t1)
            continue;
        double y0 = a.c[1] + t0 * (b.c[1] - a.c[1]), y1 = a.c[1] + t1 * (b.c[1] - a.c[1]);
        double f = floor((fmin(y0, y1) - w->y0) / w->sy), t = floor((fmax(y0, y1) - w->y0) / w->sy);
        f = fmax(0.0, f), t = fmin((double)w->ny - 1.0, t);
        for (double y = f; y <= t; y++) {
            if (GROW(w->foot, w->cfoot, w->nfoot + 1) != 0)
                return -1;
            w->foot[w->nfoot++] = (uint64_t)y * w->nx + x;
        }
    }
    return 0;
}

/* w->pbox, made on first use. */
static int polygon_boxes(rwork *w)
{
    const rad_scene *s = w->s;
    if (w->pbox)
        return 0;
    if (!(w->pbox = malloc(((size_t)s->polygon_count + 1) * 6 * sizeof *w->pbox)))
        return -1;
    for (uint32_t q = 0; q < s->polygon_count; q++) {
        double *b = w->pbox + 6 * (size_t)q;
        b[0] = b[1] = b[2] = INFINITY;
        b[3] = b[4] = b[5] = -INFINITY;
        for (uint32_t k = 0; k < s->polygons[q].point_count; k++) {
            rad_vec3 p = s->points[s->polygons[q].first_point + k];
            const double c[3] = {p.x, p.y, p.z};
            for (int d = 0; d < 3; d++)
                b[d] = fmin(b[d], c[d]), b[d + 3] = fmax(b[d + 3], c[d]);
        }
    }
    return 0;
}

/* The region's grid box in space, widened by w->tol: lo, hi. */
static void region_box(const rwork *w, double *box)
{
    box[0] = box[1] = box[2] = INFINITY;
    box[3] = box[4] = box[5] = -INFINITY;
    for (int k = 0; k < 4; k++) {
        rad_vec3 p = rad_add(w->O, rad_add(rad_scale(w->U, k & 1 ? w->x1 : w->x0),
                                           rad_scale(w->V, k & 2 ? w->y1 : w->y0)));
        const double c[3] = {p.x, p.y, p.z};
        for (int d = 0; d < 3; d++)
            box[d] = fmin(box[d], c[d] - w->tol), box[d + 3] = fmax(box[d + 3], c[d] + w->tol);
    }
}

/* The region's outline in the plane (w->oe, from frame()'s edges), then
 * w->foot: the grid cells where another surface stands on the region
 * (polygons whose box misses the region's are passed over). */
static int feet(rwork *w, const uint32_t *mem, uint32_t nm)
{
    const rad_polygon *lead = &w->s->polygons[mem[0]];
    w->noe = w->nfoot = 0;
    double box[6];
    if (polygon_boxes(w) != 0)
        return -1;
    region_box(w, box);
    if (GROW(w->oe, w->coe, 2 * w->nokey + 2) != 0)
        return -1;
    for (size_t e = 0; e < w->nokey; e++) {
        w->oe[2 * w->noe] = to2d(w, w->s->points[w->first[w->okey[e] >> 32]]);
        w->oe[2 * w->noe++ + 1] = to2d(w, w->s->points[w->first[w->okey[e] & 0xffffffffu]]);
    }
    for (uint32_t q = 0; q < w->s->polygon_count; q++) {
        const double *pb = w->pbox + 6 * (size_t)q;
        if (pb[0] > box[3] || pb[1] > box[4] || pb[2] > box[5] || pb[3] < box[0] ||
            pb[4] < box[1] || pb[5] < box[2])
            continue;
        pt2 a = {{0.0, 0.0}}, b = a;
        if (meets_plane(w, lead, q, &a, &b) && clip_to_box(w, &a, &b) &&
            stands_inside(w, mem, nm, a, b) && mark_cells(w, a, b) != 0)
            return -1;
    }
    if (w->nfoot)
        qsort(w->foot, w->nfoot, sizeof *w->foot, u64_cmp);
    size_t k = 0;
    for (size_t e = 0; e < w->nfoot; e++)
        if (k == 0 || w->foot[e] != w->foot[k - 1])
            w->foot[k++] = w->foot[e];
    w->nfoot = k;
    return 0;
}

/* ------------------------------------------------------- one region's mesh */

typedef struct gcell {
    uint64_t g;
    uint32_t c;
} gcell;

static int gcell_cmp(const void *a, const void *b)
{
    const gcell *x = a, *y = b;
    if (x->g != y->g)
        return x->g < y->g ? -1 : 1;
    return x->c < y->c ? -1 : x->c > y->c;
}

typedef struct cand {
    uint64_t g;
    double area;
    double lo[2], hi[2];
} cand;

static double cand_ratio(const cand *c, double *longest)
{
    *longest = fmax(c->hi[0] - c->lo[0], c->hi[1] - c->lo[1]);
    return *longest * *longest / c->area;
}

static cand cand_union(const cand *a, const cand *b)
{
    cand u = *a;
    u.area += b->area;
    for (int d = 0; d < 2; d++)
        u.lo[d] = fmin(a->lo[d], b->lo[d]), u.hi[d] = fmax(a->hi[d], b->hi[d]);
    return u;
}

static uint32_t cand_find(const cand *cd, uint32_t n, uint64_t g)
{
    uint32_t lo = 0, hi = n;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (cd[mid].g < g)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && cd[lo].g == g ? lo : RAD_NONE;
}

/* Do boxes a and b share a stretch of edge (not just a corner)? */
static int touching(const cand *a, const cand *b, double eps)
{
    int overlap = 0;
    for (int d = 0; d < 2; d++) {
        double gap = fmax(a->lo[d], b->lo[d]) - fmin(a->hi[d], b->hi[d]);
        if (gap > eps)
            return 0;
        overlap |= gap < -eps;
    }
    return overlap;
}

/* The candidate sliver c joins best: of its grid cell's other parts and
 * its four neighbours' pieces, one it touches that keeps the pair within
 * the size and the shape bound (the best shaped), or RAD_NONE. */
static uint32_t sliver_partner(const rwork *w, const cand *cd, uint32_t n, uint32_t *up, uint32_t c)
{
    const double longmax = REGION_LONGEST * w->size * (1 + 1e-9), eps = 1e-9 * w->size;
    const uint64_t parts = REGION_FOOT * REGION_FOOT, g = cd[c].g / parts, x = g % w->nx;
    uint64_t nb[5] = {g, x > 0 ? g - 1 : UINT64_MAX, x + 1 < w->nx ? g + 1 : UINT64_MAX,
                      g >= w->nx ? g - w->nx : UINT64_MAX, g + w->nx};
    uint32_t best = RAD_NONE;
    double best_r = INFINITY;
    for (uint64_t k = 0; k < 5 * parts; k++) {
        uint32_t d = nb[k / parts] == UINT64_MAX ? RAD_NONE
                                                  : cand_find(cd, n, parts * nb[k / parts] + k % parts);
        if (d == RAD_NONE || (d = mesh_uf_find(up, d)) == c || !touching(&cd[d], &cd[c], eps))
            continue;
        cand u = cand_union(&cd[d], &cd[c]);
        double ul, ur = cand_ratio(&u, &ul);
        if (ul <= longmax && ur <= REGION_RATIO * (1 + 1e-9) &&
            (ur < best_r || (ur == best_r && d < best)))
            best = d, best_r = ur;
    }
    return best;
}

/* Slivers and long pieces join a grid neighbour (see the top of the file). */
static void merge_slivers(const rwork *w, cand *cd, uint32_t n, uint32_t *up)
{
    for (uint32_t c = 0; c < n; c++) {
        const double cellarea = w->sx * w->sy /
                                (is_foot(w, cd[c].g / (REGION_FOOT * REGION_FOOT))
                                     ? REGION_FOOT * REGION_FOOT : 1.0);
        double len, r = cand_ratio(&cd[c], &len);
        if (up[c] != c || (cd[c].area >= REGION_SLIVER * cellarea && r <= REGION_RATIO))
            continue;
        uint32_t best = sliver_partner(w, cd, n, up, c);
        if (best != RAD_NONE) {
            up[c] = best;
            cd[best] = cand_union(&cd[best], &cd[c]);
        }
    }
}

/* Raw corners -> unique ids (equal after rounding to 1e-7 of the size;
 * urep: an id's first raw corner); cells renumbered onto them, those that
 * lose a corner dropped. */
static int unique_corners(rwork *w, uint32_t *uid, uint32_t *urep, uint32_t *nu)
{
    const double q = 1e-7 * w->size;
    mesh_key *k = malloc((w->nraw + 1) * sizeof *k);
    if (!k)
        return -1;
    for (size_t r = 0; r < w->nraw; r++) {
        k[r].k[0] = llround((w->raw[r].c[0] - w->x0) / q);
        k[r].k[1] = llround((w->raw[r].c[1] - w->y0) / q);
        k[r].k[2] = 0;
        k[r].r = (uint32_t)r;
    }
    qsort(k, w->nraw, sizeof *k, mesh_key_cmp);
    *nu = 0;
    for (size_t e = 0; e < w->nraw; e++) {
        if (e == 0 || k[e].k[0] != k[e - 1].k[0] || k[e].k[1] != k[e - 1].k[1])
            urep[(*nu)++] = k[e].r;
        uid[k[e].r] = *nu - 1;
    }
    free(k);
    size_t kept = 0;
    const double tiny = 1e-12 * w->sx * w->sy;
    for (size_t c = 0; c < w->ncell; c++) {
        rad_patch cl = w->cell[c];
        int n = rad_patch_corners(&cl);
        pt2 q[4];
        for (int a = 0; a < n; a++) {
            cl.v[a] = uid[cl.v[a]];
            q[a] = w->raw[urep[cl.v[a]]];
        }
        /* merged corners may have left a half without area: keep the rest */
        int h1 = tri2(q[0], q[1], q[2]) > tiny, h2 = n == 4 && tri2(q[0], q[2], q[3]) > tiny;
        if (n == 4 && h1 != h2) {
            if (h2)
                cl.v[1] = cl.v[2], cl.v[2] = cl.v[3];
            cl.v[3] = RAD_NONE;
        } else if (n == 4 && !h1) {
            continue;
        } else if (n == 3 && !h1) {
            continue;
        }
        w->cell[kept] = cl;
        w->gi[kept++] = w->gi[c];
    }
    w->ncell = kept;
    return 0;
}

/* Candidate patches (one per grid cell holding cells) in grid order, their
 * sizes from the 2D cells; ci[k]: the candidate of sorted cell gc[k]. */
static cand *candidates(const rwork *w, const gcell *gc, const uint32_t *urep, uint32_t *ci,
                        uint32_t *count)
{
    cand *cd = malloc((w->ncell + 1) * sizeof *cd);
    if (!cd)
        return NULL;
    uint32_t n = 0;
    for (size_t k = 0; k < w->ncell; k++) {
        if (k == 0 || gc[k].g != gc[k - 1].g)
            cd[n++] = (cand){gc[k].g, 0.0, {INFINITY, INFINITY}, {-INFINITY, -INFINITY}};
        cand *c = &cd[n - 1];
        const rad_patch *cl = &w->cell[gc[k].c];
        const int corners = rad_patch_corners(cl);
        pt2 p[4];
        for (int a = 0; a < corners; a++) {
            p[a] = w->raw[urep[cl->v[a]]];
            for (int d = 0; d < 2; d++)
                c->lo[d] = fmin(c->lo[d], p[a].c[d]), c->hi[d] = fmax(c->hi[d], p[a].c[d]);
        }
        c->area += tri2(p[0], p[1], p[2]) + (corners == 4 ? tri2(p[0], p[2], p[3]) : 0.0);
        ci[k] = n - 1;
    }
    *count = n;
    return cd;
}



/* The region's cells in grid order, numbered by patch (merged candidates
 * share their root's number, in order of first appearance), on their
 * unique corners placed in the region's plane; appended to out. */
static int emit(rwork *w, const gcell *gc, const uint32_t *ci, uint32_t *up, uint32_t ncand,
                const uint32_t *urep, uint32_t nu, mesh_regions *out, uint32_t *np)
{
    uint32_t *pnum = malloc(((size_t)ncand + 1) * sizeof *pnum);
    uint32_t *of = malloc((w->ncell + 1) * sizeof *of);
    rad_patch *cells = malloc((w->ncell + 1) * sizeof *cells);
    rad_vec3 *pos = malloc(((size_t)nu + 1) * sizeof *pos);
    int rc = -1;
    if (pnum && of && cells && pos) {
        *np = 0;
        for (uint32_t c = 0; c < ncand; c++)
            pnum[c] = RAD_NONE;
        for (uint32_t c = 0; c < ncand; c++)
            if (pnum[mesh_uf_find(up, c)] == RAD_NONE)
                pnum[mesh_uf_find(up, c)] = (*np)++;
        for (size_t k = 0; k < w->ncell; k++) {
            of[k] = pnum[mesh_uf_find(up, ci[k])];
            cells[k] = w->cell[gc[k].c];
        }
        for (uint32_t u = 0; u < nu; u++) {
            pt2 q = w->raw[urep[u]];
            pos[u] = rad_add(w->O, rad_add(rad_scale(w->U, q.c[0]), rad_scale(w->V, q.c[1])));
        }
        rc = mesh_regions_emit(out, cells, w->ncell, of, *np, pos, nu);
    }
    free(pnum), free(of), free(cells), free(pos);
    return rc;
}

/* ------------------------------------------------------- joining pieces */

/* The pieces of one grid cell (or part) joined into as few cells as their
 * union allows ("cells" at the top of the file).  The corner votes keep the
 * region conforming: a corner is dropped only when the two loops it lies
 * in, one either side of its grid line, may both drop it and no cell that
 * stays uses it; a group whose joined cells then fail goes back to its
 * pieces, and where it had dropped corners the votes are taken anew. */

typedef struct join {
    rwork *w;
    const uint32_t *urep;
    uint8_t *vote, *keep; /* per unique corner: loops that may drop it, uses that keep it */
    int nodrop;           /* drop no corner (the votes did not settle) */
    int textured;         /* the region's material has a base-colour texture */
    uint64_t *e;          /* edge scratch */
    size_t ce;
    rad_patch *cell;      /* the joined layer, grid cell by grid cell */
    uint64_t *gi;
    size_t n, cc, cg;
} join;

static pt2 upt(const join *j, uint32_t u)
{
    return j->w->raw[j->urep[u]];
}

static double cell_area2d(const join *j, const rad_patch *cl)
{
    const pt2 a = upt(j, cl->v[0]), b = upt(j, cl->v[1]), c = upt(j, cl->v[2]);
    return tri2(a, b, c) + (cl->v[3] != RAD_NONE ? tri2(a, c, upt(j, cl->v[3])) : 0.0);
}

/* 1 when material m has a base-colour texture mapped by its polygons'
 * own coordinates. */
static int textured(const rad_scene *s, uint32_t m)
{
    for (uint32_t t = 0; s->point_uv && t < s->texture_count; t++)
        if (s->textures[t].material == m)
            return 1;
    return 0;
}

/* 1 when cells of polygons a and b of one region may be one cell: nothing
 * but the region's plane is theirs (ρ of their own alike, no texture whose
 * coordinates each polygon maps its own way). */
static int same_look(const join *j, uint32_t a, uint32_t b)
{
    const rad_scene *s = j->w->s;
    if (a == b)
        return 1;
    if (s->polygon_rho &&
        memcmp(rad_polygon_rho(s, a), rad_polygon_rho(s, b), s->band_count * sizeof(double)) != 0)
        return 0;
    return !j->textured;
}

/* Do segments ab and cd meet (touching counts)? */
static int segs_meet(pt2 a, pt2 b, pt2 c, pt2 d)
{
    const double o1 = tri2(a, b, c), o2 = tri2(a, b, d), o3 = tri2(c, d, a), o4 = tri2(c, d, b);
    if ((o1 > 0.0 && o2 > 0.0) || (o1 < 0.0 && o2 < 0.0) || (o3 > 0.0 && o4 > 0.0) ||
        (o3 < 0.0 && o4 < 0.0))
        return 0;
    for (int k = 0; k < 2; k++)
        if (fmax(a.c[k], b.c[k]) < fmin(c.c[k], d.c[k]) ||
            fmax(c.c[k], d.c[k]) < fmin(a.c[k], b.c[k]))
            return 0;
    return 1;
}

/* 1 when loop lp[0..m) is simple: no two edges but neighbours meet. */
static int loop_simple(const join *j, const uint32_t *lp, size_t m)
{
    for (size_t a = 0; a < m; a++)
        for (size_t b = a + 2; b < m; b++)
            if ((a > 0 || b + 1 < m) && segs_meet(upt(j, lp[a]), upt(j, lp[(a + 1) % m]),
                                                   upt(j, lp[b]), upt(j, lp[(b + 1) % m])))
                return 0;
    return 1;
}

/* Loop q[0..m)'s shape: 2 strictly convex, 1 convex but for straight
 * corners, 0 with a reflex corner or one where it turns back (a slit). */
static int loop_shape(const join *j, const uint32_t *q, size_t m)
{
    const double tiny = 1e-12 * j->w->sx * j->w->sy;
    int shape = 2;
    for (size_t k = 0; k < m; k++) {
        const pt2 a = upt(j, q[(k + m - 1) % m]), b = upt(j, q[k]), c = upt(j, q[(k + 1) % m]);
        const double t = tri2(a, b, c);
        const double d = (b.c[0] - a.c[0]) * (c.c[0] - b.c[0]) + (b.c[1] - a.c[1]) * (c.c[1] - b.c[1]);
        if (t < -tiny || (t <= tiny && d <= 0.0))
            return 0;
        shape = t <= tiny ? 1 : shape;
    }
    return shape;
}

/* The loop's turning, summed over its corners: 2π for a convex one that
 * winds once (so it is simple). */
static double loop_turning(const join *j, const uint32_t *q, size_t m)
{
    double sum = 0.0;
    for (size_t k = 0; k < m; k++) {
        const pt2 a = upt(j, q[(k + m - 1) % m]), b = upt(j, q[k]), c = upt(j, q[(k + 1) % m]);
        const double ux = b.c[0] - a.c[0], uy = b.c[1] - a.c[1];
        const double vx = c.c[0] - b.c[0], vy = c.c[1] - b.c[1];
        sum += atan2(ux * vy - uy * vx, ux * vx + uy * vy);
    }
    return sum;
}

/* Loops longer than JOIN_MAX_LOOP keep their pieces (a fan's centre cell
 * has a corner per spoke crossing its sides, dropped later); one with a
 * reflex corner is checked pair by pair (quadratic) only up to
 * JOIN_MAX_SIMPLE corners, and ear clipped (cubic at worst) only up to
 * JOIN_MAX_EARS; one convex but for straight corners is ear clipped
 * (quadratic) up to JOIN_MAX_SIMPLE. */
#define JOIN_MAX_LOOP 65536
#define JOIN_MAX_SIMPLE 4096
#define JOIN_MAX_EARS 256

/* The union of group gc[k0..k1)'s cells as one loop lp[0..*m), counter-
 * clockwise: 0 when clean, 1 when not (keep the pieces), -1 no memory. */
static int group_loop(join *j, const gcell *gc, size_t k0, size_t k1, uint32_t *lp, size_t *m)
{
    const rwork *w = j->w;
    size_t n = 0, r = 0;
    double area = 0.0, got = 0.0;
    if (GROW(j->e, j->ce, 8 * (k1 - k0) + 1) != 0)
        return -1;
    for (size_t k = k0; k < k1; k++) {
        const rad_patch *cl = &w->cell[gc[k].c];
        const int nc = rad_patch_corners(cl);
        if (!same_look(j, w->cell[gc[k0].c].polygon, cl->polygon))
            return 1;
        for (int a = 0; a < nc; a++)
            j->e[n++] = (uint64_t)cl->v[a] << 32 | cl->v[(a + 1) % nc];
        area += cell_area2d(j, cl);
    }
    uint64_t *E = j->e, *K = j->e + n; /* K: the edges no piece runs back */
    qsort(E, n, sizeof *E, u64_cmp);
    for (size_t k = 0; k < n; k++) {
        uint64_t rev = E[k] << 32 | E[k] >> 32;
        if (k + 1 < n && E[k + 1] == E[k])
            return 1; /* two pieces overlap */
        if (!bsearch(&rev, E, n, sizeof *E, u64_cmp))
            K[r++] = E[k];
    }
    for (size_t k = 1; k < r; k++)
        if (K[k] >> 32 == K[k - 1] >> 32)
            return 1; /* the loop touches itself at a corner */
    if (r < 3 || r > JOIN_MAX_LOOP)
        return 1;
    size_t cur = 0;
    *m = 0;
    do { /* chain from the first edge: each corner starts one edge */
        const uint64_t to = K[cur] & 0xffffffffu;
        if (*m == r)
            return 1; /* a corner two edges lead to: not one loop */
        lp[(*m)++] = (uint32_t)(K[cur] >> 32);
        const size_t lo = first_from(K, r, to);
        if (lo == r || K[lo] >> 32 != to)
            return 1; /* an edge that leads nowhere */
        cur = lo;
    } while (cur != 0);
    if (*m != r)
        return 1; /* more than one loop: holes, or pieces apart */
    for (size_t k = 1; k + 1 < *m; k++)
        got += tri2(upt(j, lp[0]), upt(j, lp[k]), upt(j, lp[k + 1]));
    if (!(area > 0.0) || fabs(got - area) > 1e-9 * area)
        return 1;
    /* convex (straight corners allowed) and winding once, or checked pair
     * by pair */
    if (loop_shape(j, lp, *m) != 0)
        return fabs(loop_turning(j, lp, *m) - 2.0 * M_PI) < 1e-6 ? 0 : 1;
    return *m <= JOIN_MAX_SIMPLE && loop_simple(j, lp, *m) ? 0 : 1;
}

/* Is p a point of a grid line between two stretches of it (a, p, b in
 * line along x or y, a and b on either side)? */
static int on_line_between(pt2 a, pt2 p, pt2 b, double eps)
{
    for (int d = 0; d < 2; d++)
        if (fabs(a.c[d] - p.c[d]) <= eps && fabs(b.c[d] - p.c[d]) <= eps &&
            (a.c[1 - d] - p.c[1 - d]) * (b.c[1 - d] - p.c[1 - d]) < 0.0)
            return 1;
    return 0;
}

/* Appends a cell on corners v[0..k) of grid cell g, else as tmpl. */
static int join_put(join *j, const rad_patch *tmpl, uint64_t g, const uint32_t *v, int k)
{
    if (GROW(j->cell, j->cc, j->n + 1) != 0 || GROW(j->gi, j->cg, j->n + 1) != 0)
        return -1;
    rad_patch c = *tmpl;
    for (int q = 0; q < 4; q++)
        c.v[q] = q < k ? v[q] : RAD_NONE;
    j->cell[j->n] = c;
    j->gi[j->n++] = g;
    return 0;
}

/* Is none of loop q[0..m)'s corners but a, b, c in or on triangle abc? */
static int ear_empty(const join *j, const uint32_t *q, size_t m, size_t a, size_t b, size_t c,
                     double tiny)
{
    const pt2 A = upt(j, q[a]), B = upt(j, q[b]), C = upt(j, q[c]);
    for (size_t k = 0; k < m; k++) {
        const pt2 p = upt(j, q[k]);
        if (k != a && k != b && k != c && tri2(A, B, p) >= -tiny && tri2(B, C, p) >= -tiny &&
            tri2(C, A, p) >= -tiny)
            return 0;
    }
    return 1;
}

/* The cells cut_loop makes of loop q[0..m), or 0 where it would not try. */
static size_t loop_cells(const join *j, const uint32_t *q, size_t m)
{
    const int shape = m >= 3 ? loop_shape(j, q, m) : -1;
    if (shape == 2)
        return (m - 1) / 2;
    return (shape == 1 && m <= JOIN_MAX_SIMPLE) || (shape == 0 && m <= JOIN_MAX_EARS) ? m - 2 : 0;
}

/* Simple loop q[0..m) (counter-clockwise; q is used up) into cells of
 * grid cell g: one quad or triangle, a fan of quads (and a triangle) when
 * convex, else ear clipped triangles.  0, 1 when it cannot, -1 no memory. */
static int cut_loop(join *j, const rad_patch *tmpl, uint64_t g, uint32_t *q, size_t m)
{
    const double tiny = 1e-12 * j->w->sx * j->w->sy;
    const int shape = loop_shape(j, q, m), convex = shape == 2;
    for (size_t k = 1; convex && k + 1 < m; k += 2) {
        const uint32_t v[4] = {q[0], q[k], q[k + 1], k + 2 < m ? q[k + 2] : RAD_NONE};
        if (join_put(j, tmpl, g, v, k + 2 < m ? 4 : 3) != 0)
            return -1;
    }
    if (m > (shape == 0 ? JOIN_MAX_EARS : JOIN_MAX_SIMPLE) && !convex)
        return 1;
    for (size_t i = 0, tries = 0; !convex && m > 3; tries++) {
        const size_t a = (i + m - 1) % m, c = (i + 1) % m;
        if (tries > m)
            return 1; /* no ear: not simple after all */
        if (tri2(upt(j, q[a]), upt(j, q[i]), upt(j, q[c])) > tiny && ear_empty(j, q, m, a, i, c, tiny)) {
            const uint32_t v[3] = {q[a], q[i], q[c]};
            if (join_put(j, tmpl, g, v, 3) != 0)
                return -1;
            memmove(q + i, q + i + 1, (m - i - 1) * sizeof *q);
            m--, tries = 0;
            i = i >= m ? 0 : i;
        } else {
            i = c;
        }
    }
    if (!convex && !(tri2(upt(j, q[0]), upt(j, q[1]), upt(j, q[2])) > tiny))
        return 1;
    return !convex && join_put(j, tmpl, g, q, 3) != 0 ? -1 : 0;
}

/* Votes and keeps of the unique corners: a joined group's loop corner on a
 * grid line between two stretches votes to drop, any other use keeps. */
static void count_uses(join *j, const gcell *gc, const size_t *gb, const size_t *lb,
                       const uint32_t *lv, const uint8_t *joined, size_t ng, uint32_t nu)
{
    const double eps = 1e-9 * j->w->size;
    memset(j->vote, 0, nu), memset(j->keep, 0, nu);
    for (size_t g = 0; g < ng; g++) {
        const size_t m = lb[g + 1] - lb[g];
        for (size_t k = 0; joined[g] && k < m; k++) {
            const uint32_t *l = lv + lb[g];
            if (!j->nodrop &&
                on_line_between(upt(j, l[(k + m - 1) % m]), upt(j, l[k]), upt(j, l[(k + 1) % m]), eps))
                j->vote[l[k]] += j->vote[l[k]] < 255;
            else
                j->keep[l[k]] = 1;
        }
        for (size_t k = gb[g]; !joined[g] && k < gb[g + 1]; k++) {
            const rad_patch *cl = &j->w->cell[gc[k].c];
            for (int a = 0; a < rad_patch_corners(cl); a++)
                j->keep[cl->v[a]] = 1;
        }
    }
}

/* Loop l[0..m) less the corners both sides drop, into q; how many left. */
static size_t reduce_loop(const join *j, const uint32_t *l, size_t m, uint32_t *q)
{
    size_t mq = 0;
    for (size_t k = 0; k < m; k++)
        if (j->vote[l[k]] != 2 || j->keep[l[k]])
            q[mq++] = l[k];
    return mq;
}

/* Votes taken anew at most this often before no corner is dropped. */
#define JOIN_ROUNDS 64

/* Groups whose loop, less the corners both sides drop, would not make
 * fewer cells than their pieces go back to their pieces, until none does
 * (one that had dropped corners changes its neighbours' votes). */
static void settle(join *j, const gcell *gc, const size_t *gb, const size_t *lb,
                   const uint32_t *lv, uint8_t *joined, size_t ng, uint32_t nu, uint32_t *q)
{
    for (int changed = 1, round = 0; changed; round++) {
        changed = 0;
        j->nodrop |= round >= JOIN_ROUNDS;
        count_uses(j, gc, gb, lb, lv, joined, ng, nu);
        for (size_t g = 0; g < ng; g++) {
            const size_t m = lb[g + 1] - lb[g], mq = joined[g] ? reduce_loop(j, lv + lb[g], m, q) : 0;
            const size_t n = joined[g] ? loop_cells(j, q, mq) : 0;
            if (joined[g] && (n == 0 || n >= gb[g + 1] - gb[g])) {
                joined[g] = 0;
                changed |= mq < m;
            }
        }
    }
}

/* Group gc[k0..k1), joined along its loop l[0..m) less the corners both
 * sides drop (q: room for m), or as its pieces.  0, 1 when the joined cells
 * fail (none appended; *dropped whether corners were dropped), -1. */
static int put_group(join *j, const gcell *gc, size_t k0, size_t k1, const uint32_t *l, size_t m,
                     int joined, uint32_t *q, int *dropped)
{
    const size_t n0 = j->n;
    rad_patch tmpl = j->w->cell[gc[k0].c];
    double area = 0.0, got = 0.0;
    size_t mq = 0;
    for (size_t k = k0; k < k1; k++) {
        const rad_patch *cl = &j->w->cell[gc[k].c];
        area += cell_area2d(j, cl);
        tmpl.polygon = cl->polygon < tmpl.polygon ? cl->polygon : tmpl.polygon;
        if (!joined && join_put(j, cl, gc[k].g, cl->v, rad_patch_corners(cl)) != 0)
            return -1;
    }
    if (!joined)
        return 0;
    mq = reduce_loop(j, l, m, q);
    *dropped = mq < m;
    int rc = mq >= 3 ? cut_loop(j, &tmpl, gc[k0].g, q, mq) : 1;
    for (size_t c = n0; rc == 0 && c < j->n; c++)
        got += cell_area2d(j, &j->cell[c]);
    if (rc == 0 && (j->n - n0 >= k1 - k0 || fabs(got - area) > 1e-9 * area))
        rc = 1; /* no fewer cells, or not the pieces' area */
    if (rc == 1)
        j->n = n0;
    return rc;
}

/* The pieces of each grid cell joined (see above): w->cell and w->gi
 * replaced, in grid order, gc renumbered onto them.  0, or -1 no memory. */
static int join_pieces(rwork *w, const uint32_t *urep, uint32_t nu, gcell *gc)
{
    join j = {.w = w, .urep = urep,
              .textured = w->ncell ? textured(w->s, w->cell[0].material) : 0};
    size_t ng = 0, nl = 0;
    for (size_t k = 0; k < w->ncell; k++)
        ng += k == 0 || gc[k].g != gc[k - 1].g;
    size_t *gb = malloc((ng + 1) * sizeof *gb), *lb = malloc((ng + 1) * sizeof *lb);
    uint32_t *lv = malloc((4 * w->ncell + 1) * sizeof *lv), *q = malloc((4 * w->ncell + 1) * sizeof *q);
    uint8_t *joined = malloc(ng + 1);
    j.vote = malloc((size_t)nu + 1), j.keep = malloc((size_t)nu + 1);
    int rc = gb && lb && lv && q && joined && j.vote && j.keep ? 0 : -1;
    for (size_t k = 0, g = 0; rc == 0 && k <= w->ncell; k++)
        if (k == w->ncell || k == 0 || gc[k].g != gc[k - 1].g)
            gb[g++] = k;
    for (size_t g = 0; rc == 0 && g < ng; g++) {
        size_t m = 0;
        lb[g] = nl;
        int got = gb[g + 1] - gb[g] >= 2 ? group_loop(&j, gc, gb[g], gb[g + 1], lv + nl, &m) : 1;
        rc = got < 0 ? -1 : 0;
        joined[g] = got == 0;
        nl += got == 0 ? m : 0;
    }
    if (rc == 0)
        lb[ng] = nl;
    if (rc == 0)
        settle(&j, gc, gb, lb, lv, joined, ng, nu, q);
    for (int again = rc == 0, round = 0; again; round++) { /* a failed group with dropped corners */
        again = 0;
        j.n = 0;
        j.nodrop |= round >= JOIN_ROUNDS;
        count_uses(&j, gc, gb, lb, lv, joined, ng, nu);
        for (size_t g = 0; rc == 0 && g < ng; g++) {
            int dropped = 0, r = put_group(&j, gc, gb[g], gb[g + 1], lv + lb[g], lb[g + 1] - lb[g],
                                           joined[g], q, &dropped);
            if (r == 1) {
                joined[g] = 0;
                again |= dropped;
                r = again ? 0 : put_group(&j, gc, gb[g], gb[g + 1], NULL, 0, 0, q, &dropped);
            }
            rc = r < 0 ? -1 : 0;
        }
        again &= rc == 0;
    }
    if (rc == 0) {
        free(w->cell), free(w->gi);
        w->cell = j.cell, w->gi = j.gi, w->ccell = j.cc, w->cgi = j.cg, w->ncell = j.n;
        j.cell = NULL, j.gi = NULL;
        for (size_t k = 0; k < w->ncell; k++)
            gc[k] = (gcell){w->gi[k], (uint32_t)k};
    }
    free(gb), free(lb), free(lv), free(q), free(joined), free(j.vote), free(j.keep), free(j.e);
    free(j.cell), free(j.gi);
    return rc;
}

/* Meshes one region's members into out (see the top of the file); with
 * only_split, a region of one patch is left alone (returns 1).  RAD_OK; -1
 * out of memory; -2 a cell without area; -3 too many cells. */
static int mesh_region(rwork *w, const uint32_t *mem, uint32_t nm, int only_split,
                       mesh_regions *out, uint32_t *np)
{
    w->nraw = w->ncell = 0;
    if (frame(w, mem, nm) != 0)
        return -1;
    grid(w, mem, nm);
    if (feet(w, mem, nm) != 0)
        return -1;
    /* 2^27 grid cells in one region: beyond any patch limit */
    /* a grid of more cells than the limit allows cells (a convex region
     * covers most of its grid): refused before cutting */
    w->climit = out->cell_limit > out->cells ? out->cell_limit - out->cells : 0;
    double area = 0.0;
    for (uint32_t m = 0; m < nm; m++)
        area += w->s->polygons[mem[m]].area;
    if (mesh_regions_over(out, area / (w->sx * w->sy)) || w->nx == UINT64_MAX ||
        w->ny == UINT64_MAX || (double)w->nx * (double)w->ny > 4.0 * (double)w->climit)
        return -3;
    for (uint32_t m = 0; m < nm; m++) {
        int rc = cut_polygon(w, mem[m]);
        if (rc != 0)
            return rc;
    }
    if (w->nraw >= UINT32_MAX || w->ncell >= UINT32_MAX)
        return -3;
    uint32_t *uid = malloc((w->nraw + 1) * sizeof *uid);
    uint32_t *urep = malloc((w->nraw + 1) * sizeof *urep);
    gcell *gc = malloc((w->ncell + 1) * sizeof *gc);
    uint32_t *ci = malloc((w->ncell + 1) * sizeof *ci), nu = 0, ncand = 0;
    uint32_t *up = NULL;
    cand *cd = NULL;
    int rc = -1;
    if (!uid || !urep || !gc || !ci || unique_corners(w, uid, urep, &nu) != 0)
        goto done;
    for (size_t k = 0; k < w->ncell; k++)
        gc[k] = (gcell){w->gi[k], (uint32_t)k};
    qsort(gc, w->ncell, sizeof *gc, gcell_cmp);
    if (join_pieces(w, urep, nu, gc) != 0)
        goto done;
    if (!(cd = candidates(w, gc, urep, ci, &ncand)) ||
        !(up = malloc(((size_t)ncand + 1) * sizeof *up)))
        goto done;
    for (uint32_t c = 0; c < ncand; c++)
        up[c] = c;
    merge_slivers(w, cd, ncand, up);
    uint32_t roots = 0;
    for (uint32_t c = 0; c < ncand; c++)
        roots += up[c] == c;
    if (roots == 0 || (only_split && roots == 1)) {
        rc = 1;
        goto done;
    }
    rc = emit(w, gc, ci, up, ncand, urep, nu, out, np);
done:
    free(uid), free(urep), free(gc), free(ci), free(up), free(cd);
    return rc;
}

/* ------------------------------------------------------------ the result */


void mesh_regions_free(mesh_regions *r)
{
    if (!r)
        return;
    free(r->of), free(r->lead), free(r->pfirst), free(r->vfirst), free(r->patch);
    free(r->cfirst), free(r->cell), free(r->V), free(r->Vb);
    memset(r, 0, sizeof *r);
}

/* The members of every region, grouped (counting sort over of[]). */
static int members(const mesh_regions *r, uint32_t np, uint32_t nreg, uint32_t **first,
                   uint32_t **mem)
{
    *first = calloc((size_t)nreg + 2, sizeof **first);
    *mem = malloc(((size_t)np + 1) * sizeof **mem);
    if (!*first || !*mem)
        return -1;
    for (uint32_t i = 0; i < np; i++)
        if (r->of[i] != RAD_NONE)
            (*first)[r->of[i] + 2]++;
    for (uint32_t k = 0; k < nreg; k++)
        (*first)[k + 2] += (*first)[k + 1];
    for (uint32_t i = 0; i < np; i++)
        if (r->of[i] != RAD_NONE)
            (*mem)[(*first)[r->of[i] + 1]++] = i;
    return 0;
}

/* Whether region of nm members is meshed here: a lone polygon only when
 * meshing it on its own would be poor; several, unless all are small and
 * they make one patch (the clusters then take them, curved neighbours
 * included).  0 no, 1 yes, 2 yes if it makes more than one patch. */
static int wanted(const uint8_t *mode, const uint32_t *mem, uint32_t nm)
{
    if (nm == 1)
        return mode[mem[0]] == MESH_REGION_SPLIT;
    for (uint32_t m = 0; m < nm; m++)
        if (mode[mem[m]] != MESH_REGION_SMALL)
            return 1;
    return 2;
}

/* Narrow regions (the short side of their box under the size) that share
 * a point, of one object and material with lead normals within 30°, are
 * one curved surface: surf[r] its lowest region (union-find), for regions
 * with want[r] (some member larger than one cell) only; others point to
 * themselves. */
static int curved_surfaces(rwork *w, const uint32_t *first, const uint32_t *mem,
                           const uint8_t *want, uint32_t nreg, uint32_t *surf)
{
    const rad_scene *s = w->s;
    uint8_t *narrow = calloc((size_t)nreg + 1, 1);
    uint32_t *owner = malloc(((size_t)w->npos + 1) * sizeof *owner);
    if (!narrow || !owner) {
        free(narrow), free(owner);
        return -1;
    }
    for (uint32_t j = 0; j < w->npos; j++)
        owner[j] = RAD_NONE;
    for (uint32_t r = 0; r < nreg; r++) {
        surf[r] = r;
        if (!want[r])
            continue;
        if (frame(w, mem + first[r], first[r + 1] - first[r]) != 0) {
            free(narrow), free(owner);
            return -1;
        }
        grid(w, mem + first[r], first[r + 1] - first[r]);
        narrow[r] = fmin(w->x1 - w->x0, w->y1 - w->y0) < w->size;
    }
    for (uint32_t r = 0; r < nreg; r++) {
        const rad_polygon *lead = &s->polygons[mem[first[r]]];
        for (uint32_t m = first[r]; narrow[r] && m < first[r + 1]; m++) {
            const rad_polygon *pg = &s->polygons[mem[m]];
            for (uint32_t k = 0; k < pg->point_count; k++) {
                uint32_t id = w->pos[pg->first_point + k], o = owner[id];
                if (o == RAD_NONE) {
                    owner[id] = r;
                    continue;
                }
                const rad_polygon *ol = &s->polygons[mem[first[o]]];
                if (o != r && ol->object == lead->object && ol->material == lead->material &&
                    rad_dot(ol->normal, lead->normal) >= MESH_FACET_COS) {
                    uint32_t a = mesh_uf_find(surf, o), b = mesh_uf_find(surf, r);
                    surf[a > b ? a : b] = a > b ? b : a;
                }
            }
        }
    }
    for (uint32_t r = 0; r < nreg; r++)
        surf[r] = mesh_uf_find(surf, r);
    free(narrow), free(owner);
    return 0;
}

/* Region r's members, or with a curved surface of several regions (at its
 * lowest region) all of theirs, meshed into out; *skip when r is part of a
 * surface meshed at another region.  rc as mesh_region. */
static int mesh_one(rwork *w, const uint8_t *mode, const uint32_t *first, const uint32_t *mem,
                    const uint32_t *surf, const uint32_t *ssize, uint32_t r, uint32_t nreg,
                    mesh_regions *out, uint32_t *got)
{
    const uint32_t *m = mem + first[r], nm = first[r + 1] - first[r];
    if (ssize[surf[r]] < 2)
        return mesh_region(w, m, nm, wanted(mode, m, nm) == 2, out, got);
    /* the surface's polygons, region by region */
    uint32_t total = 0, k = 0;
    for (uint32_t q = r; q < nreg; q++)
        total += surf[q] == r ? first[q + 1] - first[q] : 0;
    uint32_t *all = malloc(((size_t)total + 1) * sizeof *all);
    if (!all)
        return -1;
    for (uint32_t q = r; q < nreg; q++)
        for (uint32_t e = first[q]; surf[q] == r && e < first[q + 1]; e++)
            all[k++] = mem[e];
    uint32_t p0 = out->patches;
    int rc = mesh_smooth_mesh(w->s, w->pos, w->first, all, total, w->size, out);
    *got = out->patches - p0;
    free(all);
    return rc;
}

static int take_regions(rwork *w, const uint8_t *mode, uint32_t nreg, mesh_regions *out)
{
    const uint32_t np = w->s->polygon_count;
    uint32_t *first = NULL, *mem = NULL, *keep = malloc(((size_t)nreg + 1) * sizeof *keep);
    uint32_t *surf = malloc(((size_t)nreg + 1) * sizeof *surf);
    uint32_t *ssize = calloc((size_t)nreg + 1, sizeof *ssize);
    uint8_t *want = calloc((size_t)nreg + 1, 1);
    int rc = keep && surf && ssize && want ? members(out, np, nreg, &first, &mem) : -1;
    if (rc == 0 && (!(out->lead = malloc(((size_t)nreg + 1) * sizeof *out->lead)) ||
                    !(out->pfirst = malloc(((size_t)nreg + 2) * sizeof *out->pfirst)) ||
                    !(out->vfirst = malloc(((size_t)nreg + 2) * sizeof *out->vfirst))))
        rc = -1;
    /* want: 0 left to the clusters or meshed alone, 1 taken, 2 taken if
     * it makes more than one patch, 3 only as part of a curved surface */
    for (uint32_t r = 0; r < nreg && rc == 0; r++) {
        want[r] = (uint8_t)wanted(mode, mem + first[r], first[r + 1] - first[r]);
        for (uint32_t e = first[r]; !want[r] && e < first[r + 1]; e++)
            want[r] = mode[mem[e]] != MESH_REGION_SMALL ? 3 : 0;
    }
    if (rc == 0)
        rc = curved_surfaces(w, first, mem, want, nreg, surf);
    for (uint32_t r = 0; r < nreg && rc == 0; r++)
        ssize[surf[r]] += want[r] != 0;
    out->count = 0;
    for (uint32_t r = 0; r < nreg && rc == 0; r++) {
        uint32_t v0 = out->vertices, p0 = out->patches, got = 0;
        keep[r] = RAD_NONE;
        if (ssize[surf[r]] >= 2 && surf[r] != r) { /* meshed with its surface */
            keep[r] = keep[surf[r]];
            continue;
        }
        if (!want[r] || (want[r] == 3 && ssize[surf[r]] < 2))
            continue;
        rc = mesh_one(w, mode, first, mem, surf, ssize, r, nreg, out, &got);
        if (rc == 1) {
            rc = 0;
            continue;
        }
        if (rc == -3 && out->estimate_only) { /* counted in out->estimate */
            rc = 0;
            keep[r] = MESH_REGION_ESTIMATED;
            continue;
        }
        if (rc == 0 && !out->estimate_only && out->patches > out->patch_limit) {
            /* past the limit already: the mesh is refused, whatever the
             * other regions, clusters and polygons add (never fewer) */
            out->estimate = out->patches;
            rc = -3;
        }
        if (rc != 0)
            break;
        keep[r] = out->count;
        out->lead[out->count] = mem[first[r]];
        out->pfirst[out->count] = p0;
        out->vfirst[out->count++] = v0;
    }
    if (rc == 0) {
        out->pfirst[out->count] = out->patches;
        out->vfirst[out->count] = out->vertices;
        for (uint32_t i = 0; i < np; i++)
            if (out->of[i] != RAD_NONE)
                out->of[i] = keep[out->of[i]] == MESH_REGION_ESTIMATED && out->estimate_only
                                 ? MESH_REGION_ESTIMATED
                                 : keep[out->of[i]];
    }
    free(first), free(mem), free(keep), free(surf), free(ssize), free(want);
    return rc;
}

int mesh_regions_build(const rad_scene *s, const uint32_t *pos, const uint32_t *first,
                       uint32_t npos, const uint8_t *mode, double size, uint64_t max_patches,
                       int estimate_only, mesh_regions *out, rad_error *err)
{
    memset(out, 0, sizeof *out);
    out->estimate_only = estimate_only;
    out->cell_limit = 16 * max_patches + 1000000;
    out->patch_limit = max_patches;
    const char *src = s->source ? s->source : "<memory>";
    rad_vec3 lo, hi;
    out->of = malloc(((size_t)s->polygon_count + 1) * sizeof *out->of);
    if (!out->of)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: mesh: out of memory", src);
    for (uint32_t i = 0; i < s->polygon_count; i++)
        out->of[i] = RAD_NONE;
    if (!(size > 0.0) || !isfinite(size) || !rad_scene_bounds(s, &lo, &hi))
        return RAD_OK; /* no size to mesh by: every polygon on its own */
    const double tol = REGION_PLANE_TOL * rad_length(rad_sub(hi, lo));
    uint32_t nreg = 0;
    rwork w = {.s = s, .pos = pos, .first = first, .npos = npos, .size = size, .tol = tol,
               .weld = MESH_WELD * rad_length(rad_sub(hi, lo))};
    int rc = find_regions(s, pos, first, npos, mode, tol, out->of, &nreg);
    if (rc == 0)
        rc = take_regions(&w, mode, nreg, out);
    free(w.raw), free(w.cell), free(w.gi), free(w.tmp[0]), free(w.tmp[1]), free(w.tmp[2]);
    free(w.ekey), free(w.okey), free(w.oe), free(w.foot), free(w.pbox);
    if (rc == 0)
        return RAD_OK;
    double estimate = out->estimate;
    mesh_regions_free(out);
    if (rc == -3) {
        out->overflow = 1;
        out->estimate = estimate;
        return RAD_OK;
    }
    if (rc == -2)
        return rad_fail(err, RAD_ERR_INVALID,
                        "%s: mesh: a planar region has a cell without area at this patch size; "
                        "use a larger patch size", src);
    return rad_fail(err, RAD_ERR_NOMEM, "%s: mesh: out of memory while meshing planar regions",
                    src);
}
