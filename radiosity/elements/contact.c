/* contact.c - where surfaces meet (issue 18).
 *
 * An interpolated element (solution.h) takes the light reflected onto it
 * from its patch and the neighbours, and never counts as buried.  Both are
 * wrong where another surface meets its own: where an object stands on it,
 * part of the patch lies under the object and sees nothing, and at the foot
 * of the object, as in a room's corners, the light reflected from the
 * other surface changes over less than a patch (the Cornell box's short
 * block casts its shadow towards its own front face: the face's lowest
 * centimetre is 20-40 % darker than its patches say).  Those meetings are
 * found here, from the scene's polygons alone: a polygon that reaches a
 * cell's plane, inside the cell or along its edge, from in front of it (a
 * patch's cells: a cluster's, or the patch itself), and is not of the
 * cell's own surface (mesh.h's RAD_MESH_SURFACE_COS).
 * The elements they touch get hemi-cubes.
 *
 * Invariant: the result depends only on the geometry (a uniform grid over
 * the scene's bounds finds the candidate polygons; the test is exact up to
 * a tolerance relative to the scene's size).
 */
#include "el_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CONTACT_GRID 64u           /* cells along the longest side of the bounds */
#define CONTACT_BIG_CELLS 4096u    /* a polygon over more cells is checked against all */

typedef struct grid {
    rad_vec3 lo;
    double h;          /* cell size */
    uint32_t nx, ny, nz;
    uint32_t *start;   /* per cell, into item (CSR) */
    uint32_t *item;    /* polygons */
    uint32_t *big;     /* polygons too big for the grid */
    uint32_t nbig;
} grid;

static void poly_bounds(const rad_scene *sc, uint32_t q, double tol, rad_vec3 *lo, rad_vec3 *hi)
{
    const rad_polygon *pg = &sc->polygons[q];
    *lo = rad_v3(INFINITY, INFINITY, INFINITY);
    *hi = rad_v3(-INFINITY, -INFINITY, -INFINITY);
    for (uint32_t k = 0; k < pg->point_count; k++) {
        rad_vec3 p = sc->points[pg->first_point + k];
        *lo = rad_v3(fmin(lo->x, p.x - tol), fmin(lo->y, p.y - tol), fmin(lo->z, p.z - tol));
        *hi = rad_v3(fmax(hi->x, p.x + tol), fmax(hi->y, p.y + tol), fmax(hi->z, p.z + tol));
    }
}

/* Cell range of a box, clamped to the grid: c0..c1 per axis. */
static void cell_range(const grid *g, rad_vec3 lo, rad_vec3 hi, uint32_t c0[3], uint32_t c1[3])
{
    const double l[3] = {lo.x - g->lo.x, lo.y - g->lo.y, lo.z - g->lo.z};
    const double u[3] = {hi.x - g->lo.x, hi.y - g->lo.y, hi.z - g->lo.z};
    const uint32_t n[3] = {g->nx, g->ny, g->nz};
    for (int a = 0; a < 3; a++) {
        double f0 = floor(l[a] / g->h), f1 = floor(u[a] / g->h);
        c0[a] = f0 < 0 ? 0 : f0 >= n[a] ? n[a] - 1 : (uint32_t)f0;
        c1[a] = f1 < 0 ? 0 : f1 >= n[a] ? n[a] - 1 : (uint32_t)f1;
    }
}

static uint64_t cells_in(const uint32_t c0[3], const uint32_t c1[3])
{
    return (uint64_t)(c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);
}

static int grid_make(const rad_scene *sc, rad_vec3 lo, rad_vec3 hi, double tol, grid *g)
{
    memset(g, 0, sizeof *g);
    double ext = fmax(hi.x - lo.x, fmax(hi.y - lo.y, hi.z - lo.z));
    g->lo = lo;
    g->h = ext > 0.0 ? ext / CONTACT_GRID : 1.0;
    g->nx = (uint32_t)fmin(CONTACT_GRID, floor((hi.x - lo.x) / g->h) + 1);
    g->ny = (uint32_t)fmin(CONTACT_GRID, floor((hi.y - lo.y) / g->h) + 1);
    g->nz = (uint32_t)fmin(CONTACT_GRID, floor((hi.z - lo.z) / g->h) + 1);
    const size_t ncell = (size_t)g->nx * g->ny * g->nz;
    g->start = calloc(ncell + 1, sizeof *g->start);
    g->big = malloc(((size_t)sc->polygon_count + 1) * sizeof *g->big);
    if (!g->start || !g->big)
        return -1;
    uint64_t total = 0;
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1) {
            for (size_t c = 0; c < ncell; c++)
                g->start[c + 1] += g->start[c];
            g->item = malloc((total + 1) * sizeof *g->item);
            if (!g->item)
                return -1;
        }
        uint32_t *fill = pass ? calloc(ncell + 1, sizeof *fill) : NULL;
        if (pass && !fill)
            return -1;
        for (uint32_t q = 0; q < sc->polygon_count; q++) {
            rad_vec3 a, b;
            uint32_t c0[3], c1[3];
            poly_bounds(sc, q, tol, &a, &b);
            cell_range(g, a, b, c0, c1);
            if (cells_in(c0, c1) > CONTACT_BIG_CELLS) {
                if (pass == 0)
                    g->big[g->nbig++] = q;
                continue;
            }
            for (uint32_t z = c0[2]; z <= c1[2]; z++)
                for (uint32_t y = c0[1]; y <= c1[1]; y++)
                    for (uint32_t x = c0[0]; x <= c1[0]; x++) {
                        size_t c = ((size_t)z * g->ny + y) * g->nx + x;
                        if (pass == 0) {
                            g->start[c + 1]++;
                            total++;
                        } else {
                            g->item[g->start[c] + fill[c]++] = q;
                        }
                    }
        }
        free(fill);
    }
    return 0;
}

static void grid_free(grid *g)
{
    free(g->start);
    free(g->item);
    free(g->big);
}

int el_cell_touches(const rad_scene *sc, const rad_vec3 *V, const uint32_t *v, int corners,
                    rad_vec3 n, uint32_t polygon, uint32_t q, double tol)
{
    const rad_polygon *pg = &sc->polygons[q], *own = &sc->polygons[polygon];
    if (q == polygon)
        return 0;
    /* A polygon of the cell's own surface, as the mesher groups them: where
     * a curved surface of small triangles (a vault, an arch's underside)
     * folds towards itself it bends, and its light changes over the bend,
     * not over less than a patch as at the foot of another surface. */
    if (pg->object == own->object && pg->material == own->material &&
        rad_dot(pg->normal, own->normal) >= RAD_MESH_SURFACE_COS)
        return 0;
    const rad_vec3 c = V[v[0]], *Q = sc->points + pg->first_point;
    const uint32_t nq = pg->point_count;
    double dmin = INFINITY, dmax = -INFINITY;
    for (uint32_t k = 0; k < nq; k++) {
        double d = rad_dot(rad_sub(Q[k], c), n);
        dmin = fmin(dmin, d);
        dmax = fmax(dmax, d);
    }
    if (!(dmax > tol) || !(dmin <= tol))
        return 0; /* nothing in front, or all of it in front: no contact */
    /* Where q meets the plane: its vertices on it and its edges' crossings
     * (a segment: q is convex). */
    rad_vec3 a = rad_v3(0, 0, 0), b = a;
    int got = 0;
    for (uint32_t k = 0; k < nq; k++) {
        rad_vec3 u = Q[k], v = Q[(k + 1) % nq];
        double du = rad_dot(rad_sub(u, c), n), dv = rad_dot(rad_sub(v, c), n);
        rad_vec3 hit[2];
        int nh = 0;
        if (fabs(du) <= tol)
            hit[nh++] = u;
        if ((du > tol && dv < -tol) || (du < -tol && dv > tol))
            hit[nh++] = rad_add(u, rad_scale(rad_sub(v, u), du / (du - dv)));
        for (int h = 0; h < nh; h++) {
            if (!got++) {
                a = b = hit[h];
            } else if (rad_length(rad_sub(hit[h], a)) > rad_length(rad_sub(b, a))) {
                b = hit[h];
            }
        }
    }
    if (!got)
        return 0;
    /* Clip [a, b] to the cell (convex; `in` points inside whichever way
     * its corners run). */
    const double wind = rad_dot(rad_cross(rad_sub(V[v[1]], V[v[0]]), rad_sub(V[v[2]], V[v[0]])), n) < 0.0
                            ? -1.0 : 1.0;
    double t0 = 0.0, t1 = 1.0;
    const rad_vec3 ab = rad_sub(b, a);
    for (int k = 0; k < corners && t0 <= t1; k++) {
        rad_vec3 u = V[v[k]], w = V[v[(k + 1) % corners]];
        rad_vec3 in = rad_scale(rad_cross(n, rad_sub(w, u)), wind); /* points inside */
        double il = rad_length(in);
        if (!(il > 0.0))
            continue;
        double fa = rad_dot(rad_sub(a, u), in) / il + tol, fd = rad_dot(ab, in) / il;
        if (fd == 0.0) {
            if (fa < 0.0)
                return 0;
        } else if (fd > 0.0) {
            t0 = fmax(t0, -fa / fd);
        } else {
            t1 = fmin(t1, -fa / fd);
        }
    }
    return t0 <= t1;
}

int el_segment_crosses(const rad_scene *sc, uint32_t q, rad_vec3 a, rad_vec3 b, double tol)
{
    const rad_polygon *pg = &sc->polygons[q];
    const rad_vec3 *Q = sc->points + pg->first_point, n = pg->normal;
    const uint32_t nq = pg->point_count;
    const double da = rad_dot(rad_sub(a, Q[0]), n), db = rad_dot(rad_sub(b, Q[0]), n);
    if (!((da > tol && db < -tol) || (da < -tol && db > tol)))
        return 0;
    const rad_vec3 x = rad_add(a, rad_scale(rad_sub(b, a), da / (da - db)));
    /* inside a convex polygon: x on one side of every edge, whichever way
     * the corners run */
    int pos = 0, neg = 0;
    for (uint32_t k = 0; k < nq; k++) {
        const rad_vec3 e = rad_sub(Q[(k + 1) % nq], Q[k]);
        const double len = rad_length(e);
        if (!(len > 0.0))
            continue;
        const double side = rad_dot(rad_cross(e, rad_sub(x, Q[k])), n) / len;
        pos |= side > tol;
        neg |= side < -tol;
    }
    return !(pos && neg);
}

int el_contact_rows(const rad_solution *s, const el_contacts *c, el_rows *out, rad_error *err)
{
    const uint32_t np = s->mesh->patch_count;
    memset(out, 0, sizeof *out);
    out->start = calloc((size_t)np + 1, sizeof *out->start);
    if (!out->start)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the contact rows");
    for (uint32_t p = 0; p < np; p++)
        out->start[p + 1] = out->start[p] + (c->start[p + 1] > c->start[p] && s->F
                                                 ? rad_matrix_row(s->F, p).count : 0);
    out->col = malloc((out->start[np] + 1) * sizeof *out->col);
    out->val = malloc((out->start[np] + 1) * sizeof *out->val);
    if (!out->col || !out->val)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the contact rows");
    for (uint32_t p = 0; p < np; p++)
        if (out->start[p + 1] > out->start[p])
            rad_matrix_get_row(s->F, p, out->col + out->start[p], out->val + out->start[p]);
    return RAD_OK;
}

void el_contacts_free(el_contacts *c)
{
    if (!c)
        return;
    free(c->start);
    free(c->poly);
    memset(c, 0, sizeof *c);
}

/* Adds q to patch p's list (the last one open) when it touches one of p's
 * cells; RAD_OK or out of memory. */
static int check_poly(const rad_solution *s, uint32_t p, uint32_t q, el_contacts *out, size_t *cap,
                      rad_error *err)
{
    const rad_patch *cells;
    const uint32_t k = rad_patch_cells(s->mesh, p, &cells);
    int hit = 0;
    for (uint32_t c = 0; c < k && !hit; c++)
        hit = el_cell_touches(s->scene, s->mesh->vertices, cells[c].v, rad_patch_corners(&cells[c]),
                              cells[c].normal, cells[c].polygon, q, out->tol);
    if (!hit)
        return RAD_OK;
    size_t used = out->start[p + 1];
    if (used == *cap) {
        size_t c = *cap ? 2 * *cap : 256;
        uint32_t *g = realloc(out->poly, c * sizeof *g);
        if (!g)
            return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the contact test");
        out->poly = g;
        *cap = c;
    }
    out->poly[used] = q;
    out->start[p + 1]++;
    return RAD_OK;
}

int el_contact_patches(const rad_solution *s, el_contacts *out, rad_error *err)
{
    const rad_scene *sc = s->scene;
    const rad_mesh *m = s->mesh;
    const uint32_t np = m->patch_count;
    memset(out, 0, sizeof *out);
    out->start = calloc((size_t)np + 1, sizeof *out->start);
    if (!out->start)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the contact test");
    rad_vec3 lo, hi;
    if (!np || !rad_scene_bounds(sc, &lo, &hi))
        return RAD_OK;
    out->tol = 1e-7 * rad_length(rad_sub(hi, lo)) + 1e-300;
    const double tol = out->tol;
    grid g = {0};
    size_t cap = 0;
    uint32_t *stamp = calloc((size_t)sc->polygon_count + 1, sizeof *stamp);
    int rc = RAD_OK;
    if (!stamp || grid_make(sc, lo, hi, tol, &g) != 0)
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the contact test");
    for (uint32_t p = 0; p < np && rc == RAD_OK; p++) {
        const rad_patch *cells;
        const uint32_t ncells = rad_patch_cells(m, p, &cells);
        out->start[p + 1] = out->start[p];
        rad_vec3 a = rad_v3(INFINITY, INFINITY, INFINITY), b = rad_scale(a, -1.0);
        for (uint32_t c = 0; c < ncells; c++)
            for (int k = 0; k < rad_patch_corners(&cells[c]); k++) {
                rad_vec3 v = m->vertices[cells[c].v[k]];
                a = rad_v3(fmin(a.x, v.x - tol), fmin(a.y, v.y - tol), fmin(a.z, v.z - tol));
                b = rad_v3(fmax(b.x, v.x + tol), fmax(b.y, v.y + tol), fmax(b.z, v.z + tol));
            }
        uint32_t c0[3], c1[3];
        cell_range(&g, a, b, c0, c1);
        for (uint32_t k = 0; k < g.nbig && rc == RAD_OK; k++)
            rc = check_poly(s, p, g.big[k], out, &cap, err);
        for (uint32_t z = c0[2]; z <= c1[2] && rc == RAD_OK; z++)
            for (uint32_t y = c0[1]; y <= c1[1] && rc == RAD_OK; y++)
                for (uint32_t x = c0[0]; x <= c1[0] && rc == RAD_OK; x++) {
                    size_t c = ((size_t)z * g.ny + y) * g.nx + x;
                    for (uint32_t i = g.start[c]; i < g.start[c + 1] && rc == RAD_OK; i++) {
                        uint32_t q = g.item[i];
                        if (stamp[q] == p + 1)
                            continue;
                        stamp[q] = p + 1;
                        rc = check_poly(s, p, q, out, &cap, err);
                    }
                }
    }
    free(stamp);
    grid_free(&g);
    if (rc != RAD_OK)
        el_contacts_free(out);
    return rc;
}
