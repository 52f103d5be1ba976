/* room.c - issue 36's closed room (room.h), made in code and written as
 * glTF 2.0 through scene_gltf.c.
 *
 * A box 4 × 2.7 × 3 m (x, y up, z) closed on every side, every wall facing
 * in; the ceiling is a frame of triangles around a 0.8 × 0.6 m lamp set
 * flush in it (emissive, ρ = 0), the only source.  Inside: a UV sphere
 * (32 segments, 16 rings, smooth: vertices shared) resting on the floor; a
 * round table, its top a 48-sided cylinder whose caps are fans from one
 * corner (as exporters triangulate an n-gon) and its four legs thin
 * 12-sided tubes from the floor to the top's underside; on the table a
 * head-like closed mesh, an icosphere (320 faces) pushed in and out by a
 * smooth radial displacement, flat-shaded: every facet has its own three
 * vertices, as an exporter writes flat shading.  Each part is one node,
 * one mesh, one material of its own ρ.  Everything faces out of the solid
 * it bounds, so the room is closed: all light is absorbed somewhere in it.
 */
#include "room.h"
#include "scene_gltf.h"

#include <math.h>
#include <stddef.h>

enum { M_FLOOR, M_WALLS, M_CEILING, M_LAMP, M_SPHERE, M_TABLE, M_HEAD };
static const gs_material materials[] = {
    {"floor", {0.40, 0.30, 0.22}},  {"walls", {0.62, 0.60, 0.55}}, {"ceiling", {0.78, 0.78, 0.76}},
    {"lamp", {0, 0, 0}},            {"sphere", {0.70, 0.25, 0.20}}, {"table", {0.45, 0.33, 0.20}},
    {"head", {0.55, 0.60, 0.70}},
};
/* emissiveFactor per material: the lamp alone (E = π × this) */
static const double emit[][3] = {{0}, {0}, {0}, {1.0, 0.95, 0.85}, {0}, {0}, {0}};

#define RX 4.0
#define RY 2.7
#define RZ 3.0
#define TABLE_Y 0.76 /* the table's top */

/* The quad p, p + U, p + U + V, p + V as two triangles facing `facing`. */
static void quad(obj *o, v3 p, v3 U, v3 V, v3 facing)
{
    uint32_t a = gs_vert(o, p), b = gs_vert(o, add(p, U));
    uint32_t c = gs_vert(o, add(add(p, U), V)), d = gs_vert(o, add(p, V));
    gs_tri(o, a, b, c, facing);
    gs_tri(o, a, c, d, facing);
}

static int box(gs_scene *h)
{
    /* the first gs_new_obj makes room for 32 objects: these stay put */
    obj *f = gs_new_obj(h, "floor", M_FLOOR), *w = gs_new_obj(h, "walls", M_WALLS);
    obj *c = gs_new_obj(h, "ceiling", M_CEILING), *l = gs_new_obj(h, "lamp", M_LAMP);
    if (!f || !w || !c || !l)
        return -1;
    quad(f, mk(0, 0, 0), mk(RX, 0, 0), mk(0, 0, RZ), mk(0, 1, 0));
    quad(w, mk(0, 0, 0), mk(RX, 0, 0), mk(0, RY, 0), mk(0, 0, 1));
    quad(w, mk(0, 0, RZ), mk(RX, 0, 0), mk(0, RY, 0), mk(0, 0, -1));
    quad(w, mk(0, 0, 0), mk(0, 0, RZ), mk(0, RY, 0), mk(1, 0, 0));
    quad(w, mk(RX, 0, 0), mk(0, 0, RZ), mk(0, RY, 0), mk(-1, 0, 0));
    /* the lamp [1.6, 2.4] × [1.2, 1.8] and the ceiling's frame around it */
    double x0 = 1.6, x1 = 2.4, z0 = 1.2, z1 = 1.8;
    v3 down = mk(0, -1, 0);
    quad(l, mk(x0, RY, z0), mk(x1 - x0, 0, 0), mk(0, 0, z1 - z0), down);
    quad(c, mk(0, RY, 0), mk(RX, 0, 0), mk(0, 0, z0), down);
    quad(c, mk(0, RY, z1), mk(RX, 0, 0), mk(0, 0, RZ - z1), down);
    quad(c, mk(0, RY, z0), mk(x0, 0, 0), mk(0, 0, z1 - z0), down);
    quad(c, mk(x1, RY, z0), mk(RX - x1, 0, 0), mk(0, 0, z1 - z0), down);
    return 0;
}

/* A UV sphere of centre c, radius r: `seg` segments, `rings` rings, poles
 * on y, vertices shared (smooth shading). */
static void uv_sphere(obj *o, v3 c, double r, uint32_t seg, uint32_t rings)
{
    uint32_t top = gs_vert(o, add(c, mk(0, r, 0))), base = o->nv;
    for (uint32_t j = 1; j < rings; j++)
        for (uint32_t i = 0; i < seg; i++) {
            double th = M_PI * j / rings, ph = 2 * M_PI * i / seg;
            gs_vert(o, add(c, scl(mk(sin(th) * cos(ph), cos(th), sin(th) * sin(ph)), r)));
        }
    uint32_t bottom = gs_vert(o, add(c, mk(0, -r, 0)));
    for (uint32_t i = 0; i < seg; i++) {
        uint32_t i1 = (i + 1) % seg, last = base + (rings - 2) * seg;
        gs_tri(o, top, base + i, base + i1, mk(0, 1, 0));
        gs_tri(o, bottom, last + i, last + i1, mk(0, -1, 0));
        for (uint32_t j = 0; j + 2 < rings; j++) {
            uint32_t a = base + j * seg + i, b = base + j * seg + i1;
            uint32_t d = a + seg, e = b + seg;
            v3 mid = sub(scl(add(gs_vat(o, a), gs_vat(o, e)), 0.5), c);
            gs_tri(o, a, b, e, mid);
            gs_tri(o, a, e, d, mid);
        }
    }
}

/* A vertical cylinder's side about (cx, cz) from y0 to y1, n sides, its
 * vertices shared; with caps (each n-gon its own vertices, a fan from its
 * first corner) when `caps`. */
static void cylinder(obj *o, double cx, double cz, double r, double y0, double y1, uint32_t n,
                     int caps)
{
    uint32_t base = o->nv;
    for (uint32_t i = 0; i < n; i++) {
        double ph = 2 * M_PI * i / n;
        gs_vert(o, mk(cx + r * cos(ph), y0, cz + r * sin(ph)));
        gs_vert(o, mk(cx + r * cos(ph), y1, cz + r * sin(ph)));
    }
    for (uint32_t i = 0; i < n; i++) {
        uint32_t a = base + 2 * i, b = base + 2 * ((i + 1) % n);
        double ph = 2 * M_PI * (i + 0.5) / n;
        v3 out = mk(cos(ph), 0, sin(ph));
        gs_tri(o, a, b, b + 1, out);
        gs_tri(o, a, b + 1, a + 1, out);
    }
    for (int k = 0; k < 2 * caps; k++) {
        double y = k ? y1 : y0;
        uint32_t first = o->nv;
        for (uint32_t i = 0; i < n; i++) {
            double ph = 2 * M_PI * i / n;
            gs_vert(o, mk(cx + r * cos(ph), y, cz + r * sin(ph)));
        }
        for (uint32_t i = 1; i + 1 < n; i++)
            gs_tri(o, first, first + i, first + i + 1, mk(0, k ? 1 : -1, 0));
    }
}

static int table(gs_scene *h)
{
    obj *o = gs_new_obj(h, "table", M_TABLE);
    if (!o)
        return -1;
    double cx = 2.4, cz = 1.6, y0 = TABLE_Y - 0.04, y1 = TABLE_Y;
    cylinder(o, cx, cz, 0.55, y0, y1, 48, 1);
    for (int k = 0; k < 4; k++)
        cylinder(o, cx + (k & 1 ? 0.3 : -0.3), cz + (k & 2 ? 0.3 : -0.3), 0.025, 0.0, y0, 12, 0);
    return 0;
}

static double sq(double x) { return x * x; }

/* The head's radius in unit direction u: a sphere pushed in and out. */
static double head_radius(v3 u)
{
    /* a brow and a nose forward (+x), two eye sockets below the brow */
    double r = 1.0 + 0.10 * sin(3.0 * u.x) * cos(2.0 * u.y) + 0.08 * u.z * u.z - 0.06 * u.y * u.x;
    r += 0.25 * exp(-(sq(u.x - 0.95) + sq(u.y + 0.05) + sq(u.z)) / 0.02);
    r -= 0.18 * exp(-(sq(u.x - 0.85) + sq(u.y - 0.25) + sq(u.z - 0.35)) / 0.015);
    r -= 0.18 * exp(-(sq(u.x - 0.85) + sq(u.y - 0.25) + sq(u.z + 0.35)) / 0.015);
    return r;
}

/* An icosphere (each of the 20 faces cut into s² triangles, pushed onto
 * the displaced sphere) of centre c and half-axes ax, flat-shaded: each
 * facet its own vertices. */
static int head(gs_scene *h, v3 c, v3 ax, uint32_t s, double rest_y)
{
    obj *o = gs_new_obj(h, "head", M_HEAD);
    if (!o)
        return -1;
    const double t = (1.0 + sqrt(5.0)) / 2.0;
    const v3 P[12] = {mk(-1, t, 0), mk(1, t, 0),  mk(-1, -t, 0), mk(1, -t, 0),
                      mk(0, -1, t), mk(0, 1, t),  mk(0, -1, -t), mk(0, 1, -t),
                      mk(t, 0, -1), mk(t, 0, 1),  mk(-t, 0, -1), mk(-t, 0, 1)};
    static const int F[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (int f = 0; f < 20; f++) {
        v3 A = P[F[f][0]], B = P[F[f][1]], C = P[F[f][2]];
        for (uint32_t i = 0; i < s; i++)
            for (uint32_t j = 0; i + j < s; j++)
                for (int up = 0; up < 2 && (up == 0 || i + j + 1 < s); up++) {
                    /* grid corners (i, j), (i+1, j), (i, j+1), or the flipped one */
                    double g[3][2] = {{i + up, j + up}, {i + 1, j}, {i, j + 1}};
                    v3 q[3], mid = mk(0, 0, 0);
                    for (int k = 0; k < 3; k++) {
                        double a = g[k][0] / s, b = g[k][1] / s;
                        v3 p = add(A, add(scl(sub(B, A), a), scl(sub(C, A), b)));
                        v3 u = scl(p, 1.0 / sqrt(dot(p, p)));
                        double r = head_radius(u);
                        q[k] = add(c, mk(ax.x * r * u.x, ax.y * r * u.y, ax.z * r * u.z));
                        mid = add(mid, u);
                    }
                    uint32_t a = gs_vert(o, q[0]), b = gs_vert(o, q[1]), d = gs_vert(o, q[2]);
                    gs_tri(o, a, b, d, mid);
                }
    }
    /* resting on y = rest_y: its lowest corner moved there */
    float low = INFINITY;
    for (uint32_t k = 0; k < o->nv; k++)
        low = fminf(low, o->v[3 * k + 1]);
    for (uint32_t k = 0; k < o->nv; k++)
        o->v[3 * k + 1] += (float)rest_y - low;
    return 0;
}

static int build(gs_scene *h, double fine)
{
    (void)fine;
    if (box(h))
        return -1;
    obj *s = gs_new_obj(h, "sphere", M_SPHERE);
    if (!s)
        return -1;
    uv_sphere(s, mk(2.05, TABLE_Y + 0.25, 1.85), 0.25, 32, 16);
    if (table(h) || head(h, mk(2.6, 1.0, 1.35), mk(0.14, 0.18, 0.16), 4, TABLE_Y))
        return -1;
    return gs_failed(h) ? -1 : 0;
}

int room_write(const char *dir, const char *name, int dark, room_stats *stats)
{
    gs_material black[sizeof materials / sizeof materials[0]];
    for (size_t m = 0; m < sizeof materials / sizeof materials[0]; m++) {
        black[m] = materials[m];
        if (m != M_SPHERE && m != M_HEAD)
            black[m].rgb[0] = black[m].rgb[1] = black[m].rgb[2] = 0.0;
    }
    gs_scene h = {.seed = 1,
                  .materials = dark ? black : materials,
                  .material_count = sizeof materials / sizeof materials[0],
                  .emit = &emit[0][0],
                  .generator = "tools/room.c"};
    int rc = gs_make(&h, build, 1.0, dir, name);
    if (stats) {
        stats->triangles = gs_triangles(&h);
        stats->objects = h.n;
    }
    gs_free(&h);
    return rc;
}
