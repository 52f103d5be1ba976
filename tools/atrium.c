/* atrium.c - bench_atrium's scene (atrium.h): geometry made in code and
 * written as glTF 2.0 by scene_gltf.c.
 *
 * A 30 × 30 m courtyard hall, 12 m high (metres, y up).  A square arcade
 * 4 m in from the walls (24 columns of radius 0.3 m, 5 m high, their caps
 * fans of slivers; 24 round arches, each spandrel face fanned from its two
 * top corners as an exporter triangulates an n-gon) carries a balustrade of
 * 6 cm balusters at 7.5 m; barrel vaults span the four aisles between
 * arcade and walls.  The floor is one square polygon fanned from a corner
 * (slivers hundreds of times longer than wide), the roof a square ring of
 * slivers around an 8 × 8 m opening through which the sun (a directional
 * light of 100,000 lux) falls on the court; nothing else emits.  The walls
 * are unwelded (every triangle has its own three vertices), the vaults
 * welded but for one seam along their crown.  Every triangle faces into
 * the room.  The geometry depends only on `fine`.
 */
#include "atrium.h"
#include "scene_gltf.h"

#include <stdio.h>
#include <stdlib.h>

#define W 30.0       /* the hall's width and depth */
#define H 12.0       /* its height */
#define INSET 4.0    /* the arcade's distance from the walls */
#define SPRING 5.0   /* the arches' and vaults' springing line */
#define GALLERY 7.5  /* the top of the arcade */
#define OPENING 4.0  /* half the roof opening's side */

static const gs_material materials[] = {
    {"floor", {0.40, 0.38, 0.35}}, {"plaster", {0.75, 0.72, 0.66}}, {"stone", {0.60, 0.56, 0.50}},
    {"vault", {0.70, 0.68, 0.62}}, {"iron", {0.12, 0.12, 0.12}},
};
enum { M_FLOOR, M_PLASTER, M_STONE, M_VAULT, M_IRON };

static double area_of(v3 a, v3 b, v3 c)
{
    v3 n = cross(sub(b, a), sub(c, a));
    return 0.5 * sqrt(dot(n, n));
}

/* A triangle with vertices of its own (an unwelded export). */
static void loose(obj *o, v3 a, v3 b, v3 c, v3 facing)
{
    uint32_t i = gs_vert(o, a), j = gs_vert(o, b), k = gs_vert(o, c);
    gs_tri(o, i, j, k, facing);
}

/* The floor: the square's outline at `step` spacing, fanned from the
 * corner (0, 0) to the points of the two far sides. */
static void floor_fan(obj *o, double step)
{
    uint32_t per = (uint32_t)ceil(W / step), c = gs_vert(o, mk(0, 0, 0)), prev = 0;
    for (uint32_t k = 0; k <= 2 * per; k++) {
        double s = W * (double)k / per;
        uint32_t v = gs_vert(o, k <= per ? mk(W, 0, s) : mk(2 * W - s, 0, W));
        if (k > 0)
            gs_tri(o, c, prev, v, mk(0, 1, 0));
        prev = v;
    }
}

/* The roof at y = H facing down: per side, the trapezoid between the wall
 * and the opening, its two long edges at `step` spacing zipped by slivers. */
static void roof_ring(obj *o, double step)
{
    const v3 corner[4] = {mk(0, H, 0), mk(W, H, 0), mk(W, H, W), mk(0, H, W)};
    const double m = 0.5 * W;
    const v3 inner[4] = {mk(m - OPENING, H, m - OPENING), mk(m + OPENING, H, m - OPENING),
                         mk(m + OPENING, H, m + OPENING), mk(m - OPENING, H, m + OPENING)};
    uint32_t no = (uint32_t)ceil(W / step), ni = (uint32_t)ceil(2 * OPENING / step);
    for (int s = 0; s < 4; s++) {
        v3 a0 = corner[s], a1 = corner[(s + 1) % 4], b0 = inner[s], b1 = inner[(s + 1) % 4];
        uint32_t i = 0, j = 0;
        while (i < no || j < ni) { /* advance the edge whose next point is behind */
            v3 pa = add(a0, scl(sub(a1, a0), (double)i / no));
            v3 pb = add(b0, scl(sub(b1, b0), (double)j / ni));
            if (j >= ni || (i < no && (double)(i + 1) / no <= (double)(j + 1) / ni)) {
                loose(o, pa, add(a0, scl(sub(a1, a0), (double)(i + 1) / no)), pb, mk(0, -1, 0));
                i++;
            } else {
                loose(o, pa, add(b0, scl(sub(b1, b0), (double)(j + 1) / ni)), pb, mk(0, -1, 0));
                j++;
            }
        }
    }
}

/* A wall p0 + s·U + t·V facing `in`, nu × nv quads of unwelded triangles. */
static void loose_wall(obj *o, v3 p0, v3 U, v3 V, uint32_t nu, uint32_t nv, v3 in)
{
    for (uint32_t j = 0; j < nv; j++)
        for (uint32_t i = 0; i < nu; i++) {
            v3 a = add(p0, add(scl(U, (double)i / nu), scl(V, (double)j / nv)));
            v3 b = add(a, scl(U, 1.0 / nu)), d = add(a, scl(V, 1.0 / nv)), c = add(b, scl(V, 1.0 / nv));
            loose(o, a, b, c, in);
            loose(o, a, c, d, in);
        }
}

/* A column about the vertical through (cx, cz): side rings and two caps,
 * each cap a fan from one rim point (an n-gon as exporters cut it). */
static void column(obj *o, double cx, double cz, uint32_t sides, uint32_t rings)
{
    const double r = 0.3;
    uint32_t base = o->nv;
    for (uint32_t j = 0; j <= rings; j++)
        for (uint32_t i = 0; i < sides; i++) {
            double a = 2 * M_PI * i / sides;
            gs_vert(o, mk(cx + r * cos(a), SPRING * j / rings, cz + r * sin(a)));
        }
    for (uint32_t j = 0; j < rings; j++)
        for (uint32_t i = 0; i < sides; i++) {
            uint32_t a = base + j * sides + i, b = base + j * sides + (i + 1) % sides;
            double am = 2 * M_PI * (i + 0.5) / sides;
            gs_tri(o, a, b, b + sides, mk(cos(am), 0, sin(am)));
            gs_tri(o, a, b + sides, a + sides, mk(cos(am), 0, sin(am)));
        }
    for (uint32_t i = 1; i + 1 < sides; i++) /* the top cap, under the arcade: seen by no one */
        gs_tri(o, base + rings * sides, base + rings * sides + i, base + rings * sides + i + 1,
               mk(0, 1, 0));
}

/* A round arch from p (springing, left) along unit U, span `span`, in a
 * wall of thickness th across N (unit, horizontal): both faces up to
 * GALLERY, each fanned from its top corners, and the intrados. */
static void arch(obj *o, v3 p, v3 U, v3 N, double span, double th, uint32_t steps)
{
    const double r = 0.5 * span, top = GALLERY - SPRING;
    for (int side = 0; side < 2; side++) {
        v3 q = add(p, scl(N, side ? 0.5 * th : -0.5 * th)), f = scl(N, side ? 1 : -1);
        uint32_t tl = gs_vert(o, add(q, mk(0, top, 0)));
        uint32_t tr = gs_vert(o, add(add(q, scl(U, span)), mk(0, top, 0)));
        uint32_t first = o->nv;
        for (uint32_t i = 0; i <= steps; i++) {
            double a = M_PI * i / steps;
            gs_vert(o, add(q, add(scl(U, r - r * cos(a)), mk(0, r * sin(a), 0))));
        }
        for (uint32_t i = 0; i < steps; i++) /* left half from tl, right half from tr */
            gs_tri(o, 2 * i < steps ? tl : tr, first + i, first + i + 1, f);
        gs_tri(o, tl, first + steps / 2, tr, f);
    }
    for (uint32_t i = 0; i < steps; i++) {
        double a0 = M_PI * i / steps, a1 = M_PI * (i + 1) / steps, am = 0.5 * (a0 + a1);
        v3 p0 = add(p, add(scl(U, r - r * cos(a0)), mk(0, r * sin(a0), 0)));
        v3 p1 = add(p, add(scl(U, r - r * cos(a1)), mk(0, r * sin(a1), 0)));
        v3 in = add(scl(U, cos(am)), mk(0, -sin(am), 0));
        v3 h = scl(N, 0.5 * th);
        loose(o, sub(p0, h), sub(p1, h), add(p1, h), in);
        loose(o, sub(p0, h), add(p1, h), add(p0, h), in);
    }
}

/* A barrel vault over an aisle: a half cylinder of radius 2 springing at
 * SPRING, its axis from a to b (horizontal), across unit N; welded rows,
 * with an unwelded seam at the crown (two halves of their own). */
static void vault(obj *o, v3 a, v3 b, v3 N, uint32_t steps, uint32_t along)
{
    const double r = 0.5 * INSET;
    for (int half = 0; half < 2; half++) {
        uint32_t base = o->nv, n = steps / 2;
        for (uint32_t i = 0; i <= n; i++) {
            double ang = M_PI * (half * n + i) / steps;
            v3 q = add(scl(N, -r * cos(ang)), mk(0, r * sin(ang), 0));
            for (uint32_t j = 0; j <= along; j++)
                gs_vert(o, add(add(a, scl(sub(b, a), (double)j / along)), q));
        }
        for (uint32_t i = 0; i < n; i++)
            for (uint32_t j = 0; j < along; j++) {
                uint32_t p = base + i * (along + 1) + j, q = p + along + 1;
                double am = M_PI * (half * n + i + 0.5) / steps;
                v3 in = add(scl(N, cos(am)), mk(0, -sin(am), 0));
                gs_tri(o, p, q, q + 1, in);
                gs_tri(o, p, q + 1, p + 1, in);
            }
    }
}

/* An axis-aligned thin box (a baluster, a rail) without its bottom. */
static void stick(obj *o, v3 lo, v3 hi)
{
    v3 d = sub(hi, lo), X = mk(d.x, 0, 0), Y = mk(0, d.y, 0), Z = mk(0, 0, d.z);
    const v3 face[5][3] = {{add(lo, Y), X, Z}, {lo, X, Y}, {add(lo, Z), X, Y}, {lo, Z, Y}, {add(lo, X), Z, Y}};
    const v3 out[5] = {mk(0, 1, 0), mk(0, 0, -1), mk(0, 0, 1), mk(-1, 0, 0), mk(1, 0, 0)};
    for (int f = 0; f < 5; f++)
        loose_wall(o, face[f][0], face[f][1], face[f][2], 1, 2, out[f]);
}

/* The arcade of one side s (0..3): its columns, arches, vault and
 * balustrade, the side running from corner P along unit U, N pointing
 * from the court to the wall. */
static int side(gs_scene *h, int s, double fine)
{
    const v3 P[4] = {mk(INSET, 0, INSET), mk(W - INSET, 0, INSET), mk(W - INSET, 0, W - INSET),
                     mk(INSET, 0, W - INSET)};
    const v3 U[4] = {mk(1, 0, 0), mk(0, 0, 1), mk(-1, 0, 0), mk(0, 0, -1)};
    const v3 N[4] = {mk(0, 0, -1), mk(1, 0, 0), mk(0, 0, 1), mk(-1, 0, 0)};
    const double len = W - 2 * INSET, span = len / 6;
    char name[48];
    snprintf(name, sizeof name, "columns %d", s + 1);
    obj *o = gs_new_obj(h, name, M_STONE);
    for (int k = 0; o && k < 6; k++) { /* the seventh is the next side's first */
        v3 c = add(P[s], scl(U[s], span * k));
        column(o, c.x, c.z, (uint32_t)lround(32 * fine), (uint32_t)lround(20 * fine));
    }
    snprintf(name, sizeof name, "arcade %d", s + 1);
    if (!o || !(o = gs_new_obj(h, name, M_STONE)))
        return -1;
    for (int k = 0; k < 6; k++)
        arch(o, add(add(P[s], scl(U[s], span * k + 0.3)), mk(0, SPRING, 0)), U[s], N[s], span - 0.6,
             0.5, 2 * (uint32_t)lround(16 * fine));
    loose_wall(o, add(add(P[s], scl(N[s], -0.25)), mk(0, GALLERY, 0)), scl(U[s], len),
               scl(N[s], 0.5), (uint32_t)lround(40 * fine), 1, mk(0, 1, 0));
    snprintf(name, sizeof name, "vault %d", s + 1);
    if (!(o = gs_new_obj(h, name, M_VAULT)))
        return -1;
    v3 a = add(add(P[s], scl(N[s], 0.5 * INSET)), mk(0, SPRING, 0));
    vault(o, sub(a, scl(U[s], INSET)), add(a, scl(U[s], len + INSET)), N[s],
          (uint32_t)lround(32 * fine), (uint32_t)lround(75 * fine));
    snprintf(name, sizeof name, "balustrade %d", s + 1);
    if (!(o = gs_new_obj(h, name, M_IRON)))
        return -1;
    uint32_t nb = (uint32_t)lround(70 * fine);
    for (uint32_t k = 0; k < nb; k++) {
        v3 c = add(add(P[s], scl(U[s], len * (k + 0.5) / nb)), mk(0, GALLERY, 0));
        stick(o, sub(c, mk(0.03, 0, 0.03)), add(c, mk(0.03, 0.9, 0.03)));
    }
    return 0;
}

static int build(gs_scene *h, double fine)
{
    obj *o = gs_new_obj(h, "floor", M_FLOOR);
    if (!o)
        return -1;
    floor_fan(o, 0.5 / fine);
    if (!(o = gs_new_obj(h, "roof", M_PLASTER)))
        return -1;
    roof_ring(o, 0.5 / fine);
    const v3 p0[4] = {mk(0, 0, 0), mk(W, 0, 0), mk(W, 0, W), mk(0, 0, W)};
    const v3 U[4] = {mk(W, 0, 0), mk(0, 0, W), mk(-W, 0, 0), mk(0, 0, -W)};
    const v3 in[4] = {mk(0, 0, 1), mk(-1, 0, 0), mk(0, 0, -1), mk(1, 0, 0)};
    uint32_t nu = (uint32_t)lround(50 * fine), nv = (uint32_t)lround(20 * fine);
    for (int s = 0; s < 4; s++) {
        char name[32];
        snprintf(name, sizeof name, "wall %d", s + 1);
        if (!(o = gs_new_obj(h, name, M_PLASTER)))
            return -1;
        loose_wall(o, p0[s], U[s], mk(0, H, 0), nu, nv, in[s]);
        if (side(h, s, fine) != 0)
            return -1;
    }
    return gs_failed(h) ? -1 : 0;
}

int atrium_write(const char *dir, const char *name, double fine, atrium_stats *stats)
{
    gs_scene h = {.seed = 4242,
                  .materials = materials,
                  .material_count = sizeof materials / sizeof materials[0],
                  .sun = mk(0.25, -1.0, 0.35),
                  .generator = "tools/atrium.c"};
    int rc = gs_make(&h, build, fine, dir, name);
    if (stats) {
        stats->triangles = gs_triangles(&h);
        stats->objects = h.n;
        stats->area = 0.0;
        for (uint32_t k = 0; k < h.n; k++)
            for (uint32_t t = 0; t < h.o[k].nt; t++) {
                const uint32_t *q = h.o[k].t + 3 * (size_t)t;
                stats->area += area_of(gs_vat(&h.o[k], q[0]), gs_vat(&h.o[k], q[1]),
                                       gs_vat(&h.o[k], q[2]));
            }
    }
    gs_free(&h);
    return rc;
}
