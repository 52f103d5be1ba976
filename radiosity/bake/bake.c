/* bake.c - the geometry of a bake: the drawing the vertex renderer uses
 * (rad_drawing: elements' fans with their T-vertices, or patches, or
 * clustered cells), grouped into one primitive per object and material,
 * each drawing vertex once per primitive (cells share it), each vertex
 * with the light of rad_bake.h.  A quad cell (patches without elements)
 * is drawn bilinearly by the renderer; here it becomes four triangles about
 * its centre, whose value is the mean of its corners (the bilinear value
 * there), so the two differ only inside the quad.
 *
 * A material with a texture (rad_texture) gets TEXCOORD_0 at each vertex:
 * the (u, v) its cell's scene polygon has there, interpolated from the
 * polygon's corners (polygon_uv).  A drawing vertex shared by cells of two
 * polygons is written once only where both give it the same float (u, v):
 * across a UV seam it is two vertices.  Its COLOR_0 is then the incident
 * light L / ρ̄, ρ̄ the material's (mean) reflectance, which the viewer
 * multiplies by the texture.
 *
 * Invariant: every triangle runs counter-clockwise about its cell's
 * normal (glTF's front face), so one-sided surfaces stay one-sided; a
 * transmitting sheet's back side is cells of their own facing the other
 * way, so it shows on both sides.
 */
#include "bake_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The drawing walked twice: once counting, once filling. */
typedef struct walk {
    const rad_solution *s;
    const rad_mesh *rm;
    const double *vB;
    const uint32_t *patch_of;
    double scale;        /* 2^EV: displayed = L · scale */
    uint32_t *stamp;     /* per drawing vertex: 1 + the primitive that numbered it */
    uint32_t *local;     /* its number in that primitive */
    uint32_t *vpoly;     /* textured: the polygon it was numbered for */
    float *vuv;          /* textured: the (u, v) it was numbered with */
    const double *rho;   /* textured primitive: ρ̄, its material's ρ; else NULL */
    uint32_t poly;       /* textured: the current cell's scene polygon */
    bk_geometry *g;
    int fill;
    uint64_t nv, ni;     /* vertices and indices so far */
    uint64_t first;      /* the current primitive's first vertex */
} walk;

static uint32_t cell_patch(const walk *w, uint32_t c) { return w->patch_of ? w->patch_of[c] : c; }

/* (u, v) at x, a point of polygon poly: barycentric in the triangle of the
 * polygon's fan from its first corner (p0, pk, pk+1) where x lies (the one
 * whose smallest barycentric coordinate is largest, for points on an edge
 * or rounded just outside).  Exact for a triangle, and for a quad whose
 * coordinates are affine over it, which gltf.c makes sure of. */
static void polygon_uv(const rad_scene *sc, uint32_t poly, rad_vec3 x, double uv[2])
{
    uv[0] = uv[1] = 0.0;
    if (!sc->point_uv || poly >= sc->polygon_count)
        return;
    const rad_polygon *pg = &sc->polygons[poly];
    const rad_vec3 *P = sc->points + pg->first_point;
    const double *T = sc->point_uv + 2 * (size_t)pg->first_point;
    double best = -INFINITY;
    for (uint32_t k = 1; k + 1 < pg->point_count; k++) {
        rad_vec3 a = P[0], b = P[k], c = P[k + 1];
        double d = rad_dot(rad_cross(rad_sub(b, a), rad_sub(c, a)), pg->normal);
        if (!(fabs(d) > 0.0))
            continue;
        double la = rad_dot(rad_cross(rad_sub(b, x), rad_sub(c, x)), pg->normal) / d;
        double lb = rad_dot(rad_cross(rad_sub(c, x), rad_sub(a, x)), pg->normal) / d;
        double lc = 1.0 - la - lb, worst = fmin(la, fmin(lb, lc));
        if (worst <= best)
            continue;
        best = worst;
        for (int q = 0; q < 2; q++)
            uv[q] = la * T[q] + lb * T[2 * k + q] + lc * T[2 * (k + 1) + q];
    }
}

/* COLOR_0 of radiance L in a band of reflectance rho (NULL: untextured):
 * min(1, L · 2^EV), textured min(1, L / ρ̄ · 2^EV), 0 where ρ̄ = 0. */
static uint16_t shown(const walk *w, double L, const double *rho, uint32_t band)
{
    double v = L * w->scale;
    if (rho)
        v = rho[band] > 0.0 ? v / rho[band] : 0.0;
    return (uint16_t)lrint(fmin(v, 1.0) * 65535.0);
}

/* Appends a vertex at p with radiosity B (bands values); its local number. */
static uint32_t put_vertex(walk *w, rad_vec3 p, const double *B)
{
    if (w->fill && w->rho) {
        double uv[2];
        polygon_uv(w->s->scene, w->poly, p, uv);
        w->g->uv[2 * w->nv] = (float)uv[0];
        w->g->uv[2 * w->nv + 1] = (float)uv[1];
    }
    if (w->fill) {
        const uint32_t bands = w->s->band_count;
        uint64_t k = w->nv;
        float *pos = w->g->position + 3 * k, *rad = w->g->radiance + 3 * k;
        uint16_t *col = w->g->color + 4 * k;
        pos[0] = (float)p.x, pos[1] = (float)p.y, pos[2] = (float)p.z;
        for (int c = 0; c < 3; c++) {
            uint32_t band = bands >= 3 ? (uint32_t)c : 0;
            double L = B[band] / M_PI;
            L = L > 0.0 ? L : 0.0; /* NaN too */
            rad[c] = (float)L;
            col[c] = shown(w, L, w->rho, band);
        }
        col[3] = 65535;
    }
    return (uint32_t)(w->nv++ - w->first);
}

/* Drawing vertex v in primitive prim: numbered once per primitive, and in
 * a textured one again where the current polygon gives it another float
 * (u, v) than the one it was numbered with (a UV seam). */
static uint32_t drawing_vertex(walk *w, uint32_t prim, uint32_t v)
{
    float uv[2] = {0, 0};
    int again = w->stamp[v] != prim + 1;
    if (w->rho && !again && w->vpoly[v] != w->poly) {
        double d[2];
        polygon_uv(w->s->scene, w->poly, w->rm->vertices[v], d);
        uv[0] = (float)d[0], uv[1] = (float)d[1];
        again = uv[0] != w->vuv[2 * (size_t)v] || uv[1] != w->vuv[2 * (size_t)v + 1];
    }
    if (again) {
        w->stamp[v] = prim + 1;
        w->local[v] = put_vertex(w, w->rm->vertices[v], w->vB + (size_t)v * w->s->band_count);
        if (w->rho) {
            double d[2];
            polygon_uv(w->s->scene, w->poly, w->rm->vertices[v], d);
            w->vpoly[v] = w->poly;
            w->vuv[2 * (size_t)v] = (float)d[0], w->vuv[2 * (size_t)v + 1] = (float)d[1];
        }
    }
    return w->local[v];
}

/* One triangle of drawing vertices (or local numbers when `raw`), turned
 * to run counter-clockwise about n. */
static void put_triangle(walk *w, const rad_vec3 *p, const uint32_t *id, rad_vec3 n)
{
    if (w->fill) {
        double d = rad_dot(rad_cross(rad_sub(p[1], p[0]), rad_sub(p[2], p[0])), n);
        uint32_t *t = w->g->index + w->ni;
        t[0] = id[0];
        t[1] = d >= 0.0 ? id[1] : id[2];
        t[2] = d >= 0.0 ? id[2] : id[1];
    }
    w->ni += 3;
}

/* Cell c of the drawing into primitive prim. */
static void put_cell(walk *w, uint32_t prim, uint32_t c)
{
    const rad_patch *cell = &w->rm->patches[c];
    w->poly = cell->polygon < w->s->scene->polygon_count
                  ? cell->polygon
                  : w->s->mesh->patches[cell_patch(w, c)].polygon;
    const int corners = rad_patch_corners(cell);
    rad_vec3 p[4];
    uint32_t id[4];
    for (int k = 0; k < corners; k++) {
        p[k] = w->rm->vertices[cell->v[k]];
        id[k] = drawing_vertex(w, prim, cell->v[k]);
    }
    if (corners == 3) {
        put_triangle(w, p, id, cell->normal);
        return;
    }
    const uint32_t bands = w->s->band_count;
    double B[RAD_MAX_BANDS] = {0};
    rad_vec3 mid = rad_v3(0, 0, 0);
    for (int k = 0; k < 4; k++) {
        mid = rad_add(mid, rad_scale(p[k], 0.25));
        for (uint32_t b = 0; b < bands; b++)
            B[b] += 0.25 * w->vB[(size_t)cell->v[k] * bands + b];
    }
    uint32_t centre = put_vertex(w, mid, B);
    for (int k = 0; k < 4; k++) {
        rad_vec3 tp[3] = {p[k], p[(k + 1) % 4], mid};
        uint32_t tid[3] = {id[k], id[(k + 1) % 4], centre};
        put_triangle(w, tp, tid, cell->normal);
    }
}

typedef struct cell_key {
    uint64_t key; /* object << 32 | material */
    uint32_t cell;
} cell_key;

static int key_cmp(const void *a, const void *b)
{
    const cell_key *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->cell < y->cell ? -1 : x->cell > y->cell;
}

/* One pass over the cells in order; primitives recorded when filling. */
static void walk_cells(walk *w, const cell_key *ord, uint32_t nc)
{
    uint32_t prim = 0;
    w->nv = w->ni = 0;
    uint64_t nuv = 0;
    const rad_scene *sc = w->s->scene;
    for (uint32_t i = 0; i < nc;) {
        uint32_t j = i;
        w->first = w->nv;
        uint64_t first_index = w->ni;
        const rad_patch *pp = &w->s->mesh->patches[cell_patch(w, ord[i].cell)];
        int textured = bk_texture(sc, pp->material) != NULL;
        w->rho = textured ? sc->materials[pp->material].rho : NULL;
        while (j < nc && ord[j].key == ord[i].key)
            put_cell(w, prim, ord[j++].cell);
        if (w->fill) {
            bk_prim *pr = &w->g->prims[prim];
            pr->object = pp->object;
            pr->material = pp->material;
            pr->first_vertex = w->first;
            pr->vertex_count = w->nv - w->first;
            pr->first_index = first_index;
            pr->index_count = w->ni - first_index;
            pr->textured = textured;
            pr->first_uv = nuv;
        }
        if (textured)
            nuv += w->nv - w->first;
        prim++;
        i = j;
    }
    w->rho = NULL;
    w->g->prim_count = prim;
    w->g->uv_count = nuv;
}

/* POSITION's min and max of every primitive. */
static void prim_bounds(bk_geometry *g)
{
    for (uint32_t k = 0; k < g->prim_count; k++) {
        bk_prim *p = &g->prims[k];
        for (int c = 0; c < 3; c++)
            p->lo[c] = INFINITY, p->hi[c] = -INFINITY;
        for (uint64_t v = p->first_vertex; v < p->first_vertex + p->vertex_count; v++)
            for (int c = 0; c < 3; c++) {
                p->lo[c] = fminf(p->lo[c], g->position[3 * v + c]);
                p->hi[c] = fmaxf(p->hi[c], g->position[3 * v + c]);
            }
    }
}

static int geometry_alloc(bk_geometry *g)
{
    g->position = malloc((g->vertex_count * 3 + 1) * sizeof *g->position);
    g->radiance = malloc((g->vertex_count * 3 + 1) * sizeof *g->radiance);
    g->color = malloc((g->vertex_count * 4 + 1) * sizeof *g->color);
    g->index = malloc((g->index_count + 1) * sizeof *g->index);
    g->prims = calloc((size_t)g->prim_count + 1, sizeof *g->prims);
    if (g->uv_count)
        g->uv = malloc((g->vertex_count * 2 + 1) * sizeof *g->uv);
    return g->position && g->radiance && g->color && g->index && g->prims &&
                   (g->uv || !g->uv_count)
               ? 0
               : -1;
}

int bk_geometry_build(const rad_solution *s, const rad_drawing *d, double ev, bk_geometry *g,
                      rad_error *err)
{
    memset(g, 0, sizeof *g);
    int rc = RAD_OK;
    walk w = {.s = s, .g = g, .scale = exp2(ev)};
    rad_drawing_parts(d, &w.rm, &w.vB, &w.patch_of);
    const uint32_t nc = w.rm->patch_count, nv = w.rm->vertex_count;
    cell_key *ord = malloc(((size_t)nc + 1) * sizeof *ord);
    w.stamp = calloc((size_t)nv + 1, sizeof *w.stamp);
    w.local = malloc(((size_t)nv + 1) * sizeof *w.local);
    if (s->scene->texture_count) {
        w.vpoly = malloc(((size_t)nv + 1) * sizeof *w.vpoly);
        w.vuv = malloc(((size_t)nv + 1) * 2 * sizeof *w.vuv);
    }
    if (!ord || !w.stamp || !w.local || (s->scene->texture_count && (!w.vpoly || !w.vuv))) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "bake: out of memory for %u cells", nc);
        goto done;
    }
    for (uint32_t c = 0; c < nc; c++) {
        const rad_patch *pp = &s->mesh->patches[cell_patch(&w, c)];
        ord[c] = (cell_key){(uint64_t)pp->object << 32 | pp->material, c};
    }
    qsort(ord, nc, sizeof *ord, key_cmp);
    walk_cells(&w, ord, nc);
    g->vertex_count = w.nv;
    g->index_count = w.ni;
    if (w.nv > UINT32_MAX || geometry_alloc(g)) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "bake: out of memory for %llu vertices",
                      (unsigned long long)w.nv);
        goto done;
    }
    memset(w.stamp, 0, ((size_t)nv + 1) * sizeof *w.stamp);
    w.fill = 1;
    walk_cells(&w, ord, nc);
    prim_bounds(g);
done:
    free(ord);
    free(w.stamp);
    free(w.local);
    free(w.vpoly);
    free(w.vuv);
    if (rc)
        bk_geometry_free(g);
    return rc;
}

void bk_geometry_free(bk_geometry *g)
{
    free(g->position);
    free(g->color);
    free(g->radiance);
    free(g->index);
    free(g->uv);
    free(g->prims);
    memset(g, 0, sizeof *g);
}

/* ------------------------------------------------------------ exposure */

typedef struct lit {
    double L, area;
} lit;

static int lit_cmp(const void *a, const void *b)
{
    double x = ((const lit *)a)->L, y = ((const lit *)b)->L;
    return x < y ? -1 : x > y;
}

static int emits(const rad_solution *s, uint32_t p)
{
    for (uint32_t b = 0; b < s->band_count; b++)
        if (s->emission[(size_t)p * s->band_count + b] > 0.0)
            return 1;
    return 0;
}

/* rad_bake_auto_exposure on a drawing of s. */
static int drawing_exposure(const rad_solution *s, const rad_drawing *d, double *ev, rad_error *err)
{
    *ev = 0.0;
    const rad_mesh *rm;
    const double *vB;
    const uint32_t *patch_of;
    rad_drawing_parts(d, &rm, &vB, &patch_of);
    const uint32_t bands = s->band_count, nc = rm->patch_count;
    lit *cells = malloc(((size_t)nc + 1) * sizeof *cells);
    if (!cells)
        return rad_fail(err, RAD_ERR_NOMEM, "bake: out of memory for %u cells", nc);
    uint32_t n = 0;
    double total = 0.0;
    for (uint32_t c = 0; c < nc; c++) {
        const rad_patch *cell = &rm->patches[c];
        const uint32_t p = patch_of ? patch_of[c] : c, m = s->mesh->patches[p].material;
        if (emits(s, p))
            continue;
        /* a textured cell's COLOR_0 is L / ρ̄ (bk_geometry_build) */
        const double *rho = bk_texture(s->scene, m) ? s->scene->materials[m].rho : NULL;
        double L = 0.0;
        for (uint32_t b = 0; b < (bands >= 3 ? 3 : 1); b++) {
            double sum = 0.0;
            for (int k = 0; k < rad_patch_corners(cell); k++)
                sum += vB[(size_t)cell->v[k] * bands + b];
            double v = sum / rad_patch_corners(cell) / M_PI;
            if (rho)
                v = rho[b] > 0.0 ? v / rho[b] : 0.0;
            L = fmax(L, v);
        }
        cells[n++] = (lit){L, cell->area};
        total += cell->area;
    }
    qsort(cells, n, sizeof *cells, lit_cmp);
    double below = 0.0;
    for (uint32_t k = 0; k < n; k++) {
        below += cells[k].area;
        if (below >= 0.99 * total) {
            if (cells[k].L > 0.0 && isfinite(cells[k].L))
                *ev = floor(-log2(cells[k].L) * 100.0) / 100.0;
            break;
        }
    }
    free(cells);
    return RAD_OK;
}

int rad_bake_auto_exposure(const rad_solution *s, double *ev, rad_error *err)
{
    *ev = 0.0;
    rad_drawing *d = NULL;
    int rc = rad_drawing_create(s, &d, err);
    if (!rc)
        rc = drawing_exposure(s, d, ev, err);
    rad_drawing_destroy(d);
    return rc;
}

int rad_bake_write(const rad_solution *s, const char *path, const rad_bake_options *opt,
                   rad_bake_stats *stats, rad_error *err)
{
    rad_bake_options none = {0};
    opt = opt ? opt : &none;
    double ev = opt->exposure;
    if (!isfinite(ev) || fabs(ev) > 64)
        return rad_fail(err, RAD_ERR_USAGE, "bake: exposure %g is not in [-64, 64]", ev);
    /* One drawing for the exposure and the geometry. */
    rad_drawing *d = NULL;
    int rc = rad_drawing_create(s, &d, err);
    if (!rc && !opt->exposure_given)
        rc = drawing_exposure(s, d, &ev, err);
    bk_geometry g = {0};
    if (!rc)
        rc = bk_geometry_build(s, d, ev, &g, err);
    rad_drawing_destroy(d);
    uint64_t bytes = 0;
    if (!rc)
        rc = bk_write_files(s, &g, path, &bytes, err);
    if (!rc && stats)
        *stats = (rad_bake_stats){.vertices = g.vertex_count, .triangles = g.index_count / 3,
                                  .bytes = bytes, .primitives = g.prim_count,
                                  .cameras = s->scene->camera_count, .exposure = ev};
    bk_geometry_free(&g);
    return rc;
}
