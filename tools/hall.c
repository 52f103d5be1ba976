/* hall.c - bench_scale's hall (hall.h): geometry made in code, written as
 * glTF 2.0 (JSON and one external binary buffer).
 *
 * The hall is 24 × 14 m and 8 m high (metres, y up).  Two arcades run
 * along x at z = 5 and z = 9: seven columns each (32 sides, 18 rings) carry
 * a wall pierced by six round arches (the spandrels' faces and the arches'
 * undersides tessellated along the arc).  The floor, the walls and the
 * ceiling are grids of small triangles whose inner vertices are moved a
 * little within the plane, as a remesher leaves them, so that neighbouring
 * triangles are not parallelograms and stay triangles in the loader.  The
 * south wall (z = 0) has three windows 2 × 3 m; the sun, a directional
 * light of 100,000 lux, shines through them onto the floor and the
 * arcades; nothing else emits.  Tables and benches stand in the aisles.
 * Every triangle faces into the room (one-sided surfaces), and every
 * object is one node with one mesh of one primitive and one material.
 * The geometry depends only on `fine`: the pseudo-random jitter is a fixed
 * linear congruential sequence.
 */
#include "hall.h"
#include "scene_gltf.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const gs_material materials[] = {
    {"stone floor", {0.45, 0.42, 0.38}}, {"plaster", {0.72, 0.70, 0.64}},
    {"ceiling", {0.68, 0.66, 0.62}},     {"column stone", {0.58, 0.54, 0.48}},
    {"arcade", {0.64, 0.60, 0.54}},      {"oak", {0.42, 0.28, 0.17}},
};
enum { M_FLOOR, M_PLASTER, M_CEILING, M_COLUMN, M_ARCADE, M_OAK };

/* A window in a grid: cells whose centre lies inside are left out. */
typedef struct hole {
    double u0, u1, v0, v1; /* in the grid's parameters, [0, 1] */
} hole;

static int in_hole(const hole *holes, int nh, double u, double v)
{
    for (int k = 0; k < nh; k++)
        if (u > holes[k].u0 && u < holes[k].u1 && v > holes[k].v0 && v < holes[k].v1)
            return 1;
    return 0;
}

/* The rectangle p0 + s·U + t·V, s, t in [0, 1], as a grid of nu × nv
 * cells, each two triangles facing `facing`; inner vertices not next to a
 * hole move by up to `jit` of a cell within the plane. */
static void grid(gs_scene *h, obj *o, v3 p0, v3 U, v3 V, uint32_t nu, uint32_t nv, double jit,
                 const hole *holes, int nh, v3 facing)
{
    uint32_t base = o->nv;
    for (uint32_t j = 0; j <= nv; j++)
        for (uint32_t i = 0; i <= nu; i++) {
            double s = (double)i / nu, t = (double)j / nv;
            int inner = i > 0 && i < nu && j > 0 && j < nv;
            double du = 1.0 / nu, dv = 1.0 / nv;
            /* next to a hole: keep the window's edges straight */
            for (int a = -1; a <= 0 && inner; a++)
                for (int b = -1; b <= 0 && inner; b++)
                    inner = !in_hole(holes, nh, s + (a + 0.5) * du, t + (b + 0.5) * dv);
            if (inner && jit > 0.0) {
                s += jit * du * gs_jitter(h);
                t += jit * dv * gs_jitter(h);
            }
            gs_vert(o, add(p0, add(scl(U, s), scl(V, t))));
        }
    for (uint32_t j = 0; j < nv; j++)
        for (uint32_t i = 0; i < nu; i++) {
            if (in_hole(holes, nh, (i + 0.5) / nu, (j + 0.5) / nv))
                continue;
            uint32_t a = base + j * (nu + 1) + i, b = a + 1, c = b + nu + 1, d = a + nu + 1;
            if ((i + j) % 2) {
                gs_tri(o, a, b, c, facing);
                gs_tri(o, a, c, d, facing);
            } else {
                gs_tri(o, a, b, d, facing);
                gs_tri(o, b, c, d, facing);
            }
        }
}

/* The rectangle p0 + s·U + t·V, s, t in [0, 1], |U| = lu, |V| = lv, as
 * near-equilateral triangles of edge about `cell` facing `facing`: rows of
 * points a triangle's height apart, every other row offset by half a cell,
 * each strip between two rows zipped by the shorter diagonal; inner points
 * move by up to `jit` of a cell within the plane (a remesher's output). */
static void tri_grid(gs_scene *h, obj *o, v3 p0, v3 U, v3 V, double lu, double lv, double cell,
                     double jit, v3 facing)
{
    uint32_t nu = (uint32_t)ceil(lu / cell - 1e-9), nv = (uint32_t)ceil(lv / (cell * 0.8660254) - 1e-9);
    nu = nu < 1 ? 1 : nu;
    nv = nv < 1 ? 1 : nv;
    uint32_t prev = 0, prev_n = 0;
    for (uint32_t j = 0; j <= nv; j++) {
        int odd = j % 2, inner_row = j > 0 && j < nv;
        uint32_t n = odd ? nu + 2 : nu + 1, first = o->nv;
        for (uint32_t i = 0; i < n; i++) {
            double sp = odd ? (i == 0 ? 0.0 : i == n - 1 ? 1.0 : (i - 0.5) / nu) : (double)i / nu;
            double t = (double)j / nv;
            if (inner_row && i > 0 && i + 1 < n && jit > 0.0) {
                sp += jit * gs_jitter(h) / nu;
                t += jit * gs_jitter(h) / nv;
            }
            gs_vert(o, add(p0, add(scl(U, sp), scl(V, t))));
        }
        if (j > 0) { /* zip row prev (prev_n points) with this one */
            uint32_t a = 0, b = 0;
            while (a + 1 < prev_n || b + 1 < n) {
                int step_a;
                if (a + 1 >= prev_n)
                    step_a = 0;
                else if (b + 1 >= n)
                    step_a = 1;
                else {
                    v3 da = sub(gs_vat(o, prev + a + 1), gs_vat(o, first + b));
                    v3 db = sub(gs_vat(o, first + b + 1), gs_vat(o, prev + a));
                    step_a = dot(da, da) < dot(db, db);
                }
                if (step_a) {
                    gs_tri(o, prev + a, first + b, prev + a + 1, facing);
                    a++;
                } else {
                    gs_tri(o, prev + a, first + b, first + b + 1, facing);
                    b++;
                }
            }
        }
        prev = first;
        prev_n = n;
    }
}

static uint32_t cells(double len, double cell)
{
    double n = ceil(len / cell - 1e-9);
    return n < 1 ? 1 : (uint32_t)n;
}

/* An axis-aligned box lo..hi, faces outwards, cells about `cell`; the
 * bottom face is left out when it stands on the floor (no one sees it). */
static void box(gs_scene *h, obj *o, v3 lo, v3 hi, double cell, int bottom)
{
    v3 d = sub(hi, lo);
    v3 X = mk(d.x, 0, 0), Y = mk(0, d.y, 0), Z = mk(0, 0, d.z);
    uint32_t nx = cells(d.x, cell), ny = cells(d.y, cell), nz = cells(d.z, cell);
    grid(h, o, lo, X, Z, nx, nz, 0, NULL, 0, mk(0, -1, 0));
    if (!bottom)
        o->nt -= 2 * nx * nz; /* drop the bottom face just made */
    grid(h, o, add(lo, Y), X, Z, nx, nz, 0, NULL, 0, mk(0, 1, 0));
    grid(h, o, lo, X, Y, nx, ny, 0, NULL, 0, mk(0, 0, -1));
    grid(h, o, add(lo, Z), X, Y, nx, ny, 0, NULL, 0, mk(0, 0, 1));
    grid(h, o, lo, Z, Y, nz, ny, 0, NULL, 0, mk(-1, 0, 0));
    grid(h, o, add(lo, X), Z, Y, nz, ny, 0, NULL, 0, mk(1, 0, 0));
}

/* A column: the side of a cylinder about the vertical through (cx, cz). */
static void column(obj *o, double cx, double cz, double r, double y0, double y1, uint32_t sides,
                   uint32_t rings)
{
    uint32_t base = o->nv;
    for (uint32_t j = 0; j <= rings; j++)
        for (uint32_t i = 0; i < sides; i++) {
            double a = 2 * M_PI * i / sides;
            gs_vert(o, mk(cx + r * cos(a), y0 + (y1 - y0) * j / rings, cz + r * sin(a)));
        }
    for (uint32_t j = 0; j < rings; j++)
        for (uint32_t i = 0; i < sides; i++) {
            uint32_t i1 = (i + 1) % sides;
            uint32_t a = base + j * sides + i, b = base + j * sides + i1;
            uint32_t c = b + sides, d = a + sides;
            double am = 2 * M_PI * (i + 0.5) / sides;
            v3 out = mk(cos(am), 0, sin(am));
            gs_tri(o, a, b, c, out);
            gs_tri(o, a, c, d, out);
        }
}

/* An arcade wall in the plane z = zc, thickness th, from y = ya (the
 * springing line, the columns' tops) to y = yb (the ceiling), between
 * x = xs[0] and xs[n-1]: a round arch of radius (xs[k+1] - xs[k])/2 over
 * each span.  Each spandrel face is strips from the arc up to yb, each
 * strip split into rows; the underside of each arch faces its centre. */
static void arcade(obj *o, const double *xs, int n, double zc, double th, double ya, double yb,
                   uint32_t steps, uint32_t rows, uint32_t across)
{
    for (int k = 0; k + 1 < n; k++) {
        double r = 0.5 * (xs[k + 1] - xs[k]), xm = 0.5 * (xs[k] + xs[k + 1]);
        for (int side = 0; side < 2; side++) {
            double z = zc + (side ? 0.5 : -0.5) * th;
            v3 facing = mk(0, 0, side ? 1 : -1);
            uint32_t base = o->nv;
            for (uint32_t i = 0; i <= steps; i++) {
                double a = M_PI * i / steps;
                double x = xm - r * cos(a), y = ya + r * sin(a);
                for (uint32_t j = 0; j <= rows; j++)
                    gs_vert(o, mk(x, y + (yb - y) * j / rows, z));
            }
            for (uint32_t i = 0; i < steps; i++)
                for (uint32_t j = 0; j < rows; j++) {
                    uint32_t a = base + i * (rows + 1) + j, b = a + rows + 1;
                    gs_tri(o, a, b, b + 1, facing);
                    gs_tri(o, a, b + 1, a + 1, facing);
                }
        }
        /* the intrados: quads across the thickness, facing the arch's centre */
        uint32_t base = o->nv;
        for (uint32_t i = 0; i <= steps; i++) {
            double a = M_PI * i / steps;
            for (uint32_t j = 0; j <= across; j++)
                gs_vert(o, mk(xm - r * cos(a), ya + r * sin(a), zc - 0.5 * th + th * j / across));
        }
        for (uint32_t i = 0; i < steps; i++)
            for (uint32_t j = 0; j < across; j++) {
                uint32_t a = base + i * (across + 1) + j, b = a + across + 1;
                double am = M_PI * (i + 0.5) / steps;
                v3 in = mk(cos(am), -sin(am), 0);
                gs_tri(o, a, b, b + 1, in);
                gs_tri(o, a, b + 1, a + 1, in);
            }
    }
}

/* ------------------------------------------------------------- the scene */

static int build(gs_scene *h, double fine)
{
    const double W = 24, D = 14, H = 8;
    const double c_floor = 0.23 / fine, c_wall = 0.23 / fine, c_ceil = 0.23 / fine;
    char name[48];
    obj *o = gs_new_obj(h, "floor", M_FLOOR);
    if (!o)
        return -1;
    tri_grid(h, o, mk(0, 0, 0), mk(W, 0, 0), mk(0, 0, D), W, D, c_floor, 0.2, mk(0, 1, 0));
    if (!(o = gs_new_obj(h, "ceiling", M_CEILING)))
        return -1;
    tri_grid(h, o, mk(0, H, 0), mk(W, 0, 0), mk(0, 0, D), W, D, c_ceil, 0.2, mk(0, -1, 0));
    /* the south wall in panels around three windows 2 m wide, from 2 m to 5 m */
    if (!(o = gs_new_obj(h, "south wall", M_PLASTER)))
        return -1;
    tri_grid(h, o, mk(0, 0, 0), mk(W, 0, 0), mk(0, 2, 0), W, 2, c_wall, 0.2, mk(0, 0, 1));
    tri_grid(h, o, mk(0, 5, 0), mk(W, 0, 0), mk(0, H - 5, 0), W, H - 5, c_wall, 0.2, mk(0, 0, 1));
    const double piers[5] = {0, 7, 13, 19, W}, gaps[4] = {5, 11, 17, W};
    for (int k = 0; k < 4; k++)
        tri_grid(h, o, mk(piers[k], 2, 0), mk(gaps[k] - piers[k], 0, 0), mk(0, 3, 0),
                 gaps[k] - piers[k], 3, c_wall, 0.2, mk(0, 0, 1));
    if (!(o = gs_new_obj(h, "north wall", M_PLASTER)))
        return -1;
    tri_grid(h, o, mk(0, 0, D), mk(W, 0, 0), mk(0, H, 0), W, H, c_wall, 0.2, mk(0, 0, -1));
    if (!(o = gs_new_obj(h, "west wall", M_PLASTER)))
        return -1;
    tri_grid(h, o, mk(0, 0, 0), mk(0, 0, D), mk(0, H, 0), D, H, c_wall, 0.2, mk(1, 0, 0));
    if (!(o = gs_new_obj(h, "east wall", M_PLASTER)))
        return -1;
    tri_grid(h, o, mk(W, 0, 0), mk(0, 0, D), mk(0, H, 0), D, H, c_wall, 0.2, mk(-1, 0, 0));
    /* two arcades: columns 3.3 m apart from x = 2.1 to 21.9 */
    double xs[7];
    for (int k = 0; k < 7; k++)
        xs[k] = 2.1 + 3.3 * k;
    const double zs[2] = {5.0, 9.0}, ya = 4.5;
    uint32_t sides = (uint32_t)lround(24 * fine), rings = (uint32_t)lround(20 * fine);
    for (int a = 0; a < 2; a++) {
        for (int k = 0; k < 7; k++) {
            snprintf(name, sizeof name, "column %c%d", 'A' + a, k + 1);
            if (!(o = gs_new_obj(h, name, M_COLUMN)))
                return -1;
            column(o, xs[k], zs[a], 0.3, 0.0, ya, sides < 8 ? 8 : sides, rings < 2 ? 2 : rings);
        }
        snprintf(name, sizeof name, "arcade %c", 'A' + a);
        if (!(o = gs_new_obj(h, name, M_ARCADE)))
            return -1;
        uint32_t steps = (uint32_t)lround(24 * fine), rows = (uint32_t)lround(14 * fine);
        arcade(o, xs, 7, zs[a], 0.6, ya, H, steps < 4 ? 4 : steps, rows < 1 ? 1 : rows,
               (uint32_t)(fine < 1 ? 2 : 3));
        /* the walls from the end columns to the hall's ends, above the springing line */
        for (int side = 0; side < 2; side++) {
            double z = zs[a] + (side ? 0.3 : -0.3);
            v3 f = mk(0, 0, side ? 1 : -1);
            tri_grid(h, o, mk(0, ya, z), mk(xs[0], 0, 0), mk(0, H - ya, 0), xs[0], H - ya, c_wall,
                     0.2, f);
            tri_grid(h, o, mk(xs[6], ya, z), mk(W - xs[6], 0, 0), mk(0, H - ya, 0), W - xs[6],
                     H - ya, c_wall, 0.2, f);
        }
        /* their undersides at the springing line */
        grid(h, o, mk(0, ya, zs[a] - 0.3), mk(0, 0, 0.6), mk(xs[0], 0, 0), 2, cells(xs[0], c_wall),
             0, NULL, 0, mk(0, -1, 0));
        grid(h, o, mk(xs[6], ya, zs[a] - 0.3), mk(0, 0, 0.6), mk(W - xs[6], 0, 0), 2,
             cells(W - xs[6], c_wall), 0, NULL, 0, mk(0, -1, 0));
    }
    /* tables in the nave (between the arcades) and benches in the aisles */
    const double c_wood = 0.15 / fine;
    for (int k = 0; k < 6; k++) {
        double x = 3.0 + 3.3 * k;
        snprintf(name, sizeof name, "table %d", k + 1);
        if (!(o = gs_new_obj(h, name, M_OAK)))
            return -1;
        box(h, o, mk(x, 0.72, 6.4), mk(x + 1.8, 0.78, 7.6), c_wood, 1);
        for (int l = 0; l < 4; l++) {
            double lx = x + (l & 1 ? 1.68 : 0.06), lz = 6.4 + (l & 2 ? 1.08 : 0.06);
            box(h, o, mk(lx, 0, lz), mk(lx + 0.06, 0.72, lz + 0.06), c_wood, 0);
        }
        for (int a = 0; a < 2; a++) {
            double z = a ? 11.0 : 2.6;
            snprintf(name, sizeof name, "bench %c%d", 'A' + a, k + 1);
            if (!(o = gs_new_obj(h, name, M_OAK)))
                return -1;
            box(h, o, mk(x, 0.42, z), mk(x + 1.8, 0.47, z + 0.4), c_wood, 1);
            box(h, o, mk(x + 0.1, 0, z + 0.05), mk(x + 0.16, 0.42, z + 0.35), c_wood, 0);
            box(h, o, mk(x + 1.64, 0, z + 0.05), mk(x + 1.7, 0.42, z + 0.35), c_wood, 0);
        }
    }
    return gs_failed(h) ? -1 : 0;
}

/* build, then every object's triangles split in four (hall_write_split) */
static int build_split(gs_scene *h, double fine)
{
    return build(h, fine) != 0 ? -1 : gs_split4_all(h);
}

static int write_with(int (*make)(gs_scene *, double), const char *dir, const char *name,
                      double fine, hall_stats *stats)
{
    gs_scene h = {.seed = 12345,
                  .materials = materials,
                  .material_count = sizeof materials / sizeof materials[0],
                  .sun = mk(0.3, -0.55, 1.0),
                  .generator = "tools/hall.c"};
    int rc = gs_make(&h, make, fine, dir, name);
    if (stats) {
        stats->triangles = gs_triangles(&h);
        stats->objects = h.n;
    }
    gs_free(&h);
    return rc;
}

int hall_write(const char *dir, const char *name, double fine, hall_stats *stats)
{
    return write_with(build, dir, name, fine, stats);
}

int hall_write_split(const char *dir, const char *name, double fine, hall_stats *stats)
{
    return write_with(build_split, dir, name, fine, stats);
}
