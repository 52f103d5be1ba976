/* light_views.c - the worker side of the punctual lights: a light part's
 * view, its item buffer, Φ_j of its patches (hc_light_part) and the
 * visibility of points in it (hc_light_points), run in a worker only.
 *
 * Owns a light's views (a cube of six R×R faces at a point or spot light,
 * or one orthographic R×R view along a directional light), their item
 * buffers drawn through gl.c and their pixel solid angles.  The caller's
 * side (light_requests.c) sends one part per request and adds the answers
 * in part order, so a result never depends on which worker drew what.  A
 * worker renders a part's item buffer once for a run of visibility
 * chunks (light_render keeps the last part drawn: same request, same
 * pixels) and looks each point up in it (point_visibility).  Invariant:
 * power and visibility read the one rendering code (light_render), so a
 * point and the patch power agree on what the light sees.
 *
 * A part's Φ_j is exact where nothing shadows j (issue 39): the closed-form
 * solid angle of j's part in the face (a spot's falloff integrated over
 * it; a directional light's projected area) times j's visible fraction,
 * sampled in the item buffer at points of j (exact_power); the pixel sums
 * (pixel_power) stand only for a sliver of j that no sample falls in.
 */
#include "hc_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Makes (or keeps) the R×R light target current, with its table of pixel
 * solid angles: a cube-face pixel at (x, y) on the face at distance 1
 * subtends ΔA/(x² + y² + 1)^{3/2}, ΔA = (2/R)², scaled so that six faces
 * give exactly 4π (the midpoint rule is off by O(1/R²)). */
static int light_target(hc_work *wk, uint32_t R, char *msg)
{
    if (wk->lR == R)
        return hc_gl_light_target(wk->gl, R, msg);
    free(wk->lpixels);
    free(wk->lweight);
    wk->lR = 0;
    wk->lpixels = malloc((size_t)R * R * sizeof *wk->lpixels);
    wk->lweight = malloc((size_t)R * R * sizeof *wk->lweight);
    if (!wk->lpixels || !wk->lweight) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: worker out of memory for a %u² light view", R);
        return -1;
    }
    if (hc_gl_light_target(wk->gl, R, msg) != 0)
        return -1;
    double d = 2.0 / R, sum = 0.0;
    for (uint32_t y = 0; y < R; y++)
        for (uint32_t x = 0; x < R; x++) {
            double px = -1.0 + (x + 0.5) * d, py = -1.0 + (y + 0.5) * d;
            double r2 = px * px + py * py + 1.0;
            double w = d * d / (r2 * sqrt(r2));
            wk->lweight[(size_t)y * R + x] = w;
            sum += w;
        }
    double s = 4.0 * M_PI / (6.0 * sum);
    for (size_t q = 0; q < (size_t)R * R; q++)
        wk->lweight[q] *= s;
    wk->lR = R;
    return 0;
}

/* The camera of one light part: a cube face (perspective, x and y in
 * [-1, 1] at distance 1 along fwd) or the directional light's orthographic
 * view (x and y in [-rw, rw] around the scene origin). */
typedef struct hc_view {
    rad_vec3 pos, right, up, fwd; /* pos relative to the scene origin */
    double rw;                    /* orthographic half width (directional only) */
    int ortho;
} hc_view;

static hc_view light_view(const hc_engine *e, const hc_light_req *q)
{
    hc_view v = {.pos = rad_v3(q->pos[0], q->pos[1], q->pos[2])};
    if (q->kind == HC_LIGHT_DIRECTIONAL) {
        rad_vec3 u, w;
        v.fwd = rad_v3(q->dir[0], q->dir[1], q->dir[2]);
        hc_basis(v.fwd, &u, &w);
        v.up = w;
        v.right = rad_cross(v.fwd, v.up);
        v.rw = e->bradius * (1.0 + 1e-9);
        v.ortho = 1;
    } else {
        hc_cube_face(q->part, &v.right, &v.up, &v.fwd);
    }
    return v;
}

/* Renders part q->part of a light into wk->lpixels (R×R item buffer, pixel
 * (x, y) at y·R + x), unless the last rendering was of the very same part:
 * the pixels are then still there (hc_light_visibility sends a part's
 * points in several chunks).  0, or -1 with msg set. */
static int light_render(const hc_engine *e, hc_work *wk, const hc_light_req *q, const hc_view *v,
                        char *msg)
{
    const uint32_t n = e->n, R = q->resolution;
    if (wk->lkey_valid && wk->lR == R && memcmp(&wk->lkey, q, sizeof *q) == 0)
        return 0;
    wk->lkey_valid = 0;
    if (light_target(wk, R, msg) != 0)
        return -1;
    const rad_vec3 pos = v->pos, right = v->right, up = v->up, fwd = v->fwd;
    double m[16];
    int nr = 0;
    if (v->ortho) {
        /* Orthographic along the light, x, y in [-rw, rw] around the origin,
         * reversed depth (r_z - p·fwd)/(2 r_z) in (0, 1) for every corner. */
        double rw = v->rw, rz = e->bradius * 1.01 + 1e-300;
        const double mm[16] = {right.x / rw, right.y / rw, right.z / rw, 0,
                               up.x / rw, up.y / rw, up.z / rw, 0,
                               -fwd.x / (2 * rz), -fwd.y / (2 * rz), -fwd.z / (2 * rz), 0.5,
                               0, 0, 0, 1};
        memcpy(m, mm, sizeof m);
        wk->first[0][0] = 0;
        wk->count[0][0] = (int)wk->nvert;
        nr = wk->nvert ? 1 : 0;
    } else {
        /* Geometry nearer than this to the light is clipped; far below any
         * real distance, and reversed Z keeps full precision beyond. */
        double near = 1e-6 * (e->bradius + rad_length(pos)) + 1e-300;
        hc_gl_projection(m, right, up, fwd, 0, near);
        /* Draw only the patches that may reach the face's frustum
         * |p·right| <= p·fwd, |p·up| <= p·fwd; a patch is skipped when all
         * its corners lie outside one of the four planes. */
        uint32_t last = 0;
        for (uint32_t j = 0; j < n; j++) {
            const double *p = e->corner + (size_t)e->cfirst[j] * 12;
            const double *end = e->corner + (size_t)e->cfirst[j + 1] * 12;
            unsigned reach = 0; /* bit: some corner of its cells inside that plane */
            for (; p < end; p += 3) {
                rad_vec3 r = rad_v3(p[0] - pos.x, p[1] - pos.y, p[2] - pos.z);
                double a = rad_dot(r, right), b = rad_dot(r, up), h = rad_dot(r, fwd);
                double t = -e->tol;
                reach |= (h - a >= t) | (h + a >= t) << 1 | (h - b >= t) << 2 | (h + b >= t) << 3;
            }
            if (reach != 15u)
                continue;
            hc_push_range(wk, wk->first[0], wk->count[0], &nr, &last, j);
        }
    }
    hc_gl_square_view(wk->gl, m, R, 0);
    hc_gl_eye(wk->gl, v->ortho ? rad_v3(0.0, 0.0, 0.0) : pos);
    if (nr)
        hc_gl_draw(wk->gl, wk->first[0], wk->count[0], nr);
    hc_gl_read_items(wk->gl, R, R, wk->lpixels);
    if (hc_gl_check("rendering a light view", msg))
        return -1;
    wk->lkey = *q;
    wk->lkey_valid = 1;
    return 0;
}

/* Φ_j of part q by pixel counts into wk->acc: the sum of the solid angles
 * (times the spot's falloff), or for a directional light the areas, of the
 * pixels showing j.  Kept for patches the exact integral misses (none,
 * bar a cell edge-on to the light). */
static void pixel_power(const hc_engine *e, hc_work *wk, const hc_light_req *q, const hc_view *vv)
{
    const uint32_t n = e->n, R = q->resolution;
    const hc_view v = *vv;
    const rad_vec3 sd = rad_v3(q->dir[0], q->dir[1], q->dir[2]);
    double *acc = wk->acc;
    if (v.ortho) {
        double pa = 2.0 * v.rw / R;
        pa *= pa;
        for (size_t k = 0; k < (size_t)R * R; k++)
            if (wk->lpixels[k] < n)
                acc[wk->lpixels[k]] += pa;
    } else {
        const int spot = q->kind == HC_LIGHT_SPOT;
        double d = 2.0 / R;
        for (uint32_t y = 0; y < R; y++)
            for (uint32_t x = 0; x < R; x++) {
                size_t k = (size_t)y * R + x;
                uint32_t id = wk->lpixels[k];
                if (id >= n)
                    continue;
                double w = wk->lweight[k];
                if (spot) {
                    double px = -1.0 + (x + 0.5) * d, py = -1.0 + (y + 0.5) * d;
                    rad_vec3 dir = rad_add(v.fwd, rad_add(rad_scale(v.right, px), rad_scale(v.up, py)));
                    w *= hc_spot_falloff(rad_dot(dir, sd) / rad_length(dir), q->cos_inner, q->cos_outer);
                }
                acc[id] += w;
            }
    }
}

/* Does pixel id show the receiving surface of a point on patch p: p itself
 * or, across a patch seam, a front side in p's plane (a coplanar neighbour
 * of the same or another polygon)?  Anything else in front of the plane is
 * an occluder; a back side or nothing is no light reaching the plane. */
static int shows_plane(const hc_engine *e, uint32_t id, uint32_t p)
{
    if (id == p)
        return 1;
    if (id >= e->n)
        return 0;
    const rad_vec3 np = e->mesh->patches[p].normal, nk = e->mesh->patches[id].normal;
    return rad_dot(np, nk) > 1.0 - 1e-6 &&
           fabs(rad_dot(np, rad_sub(e->center[id], e->center[p]))) <= 1e-6 * e->bradius + e->tol;
}

static int pixel_lets_through(const hc_engine *e, hc_work *wk, const hc_light_req *q,
                              const hc_view *v, uint32_t px, uint32_t py, rad_vec3 x, uint32_t j);
static double pixel_visibility(const hc_engine *e, hc_work *wk, const hc_light_req *q,
                               const hc_view *v, rad_vec3 x, uint32_t j, double X, double Y);

/* Continuous pixel coordinates (X, Y) of point x in view v at resolution R
 * (pixel k's centre at k); 0 when x is not in front of a perspective eye
 * (X and Y are then not meaningful). */
static int view_pixel(const hc_view *v, uint32_t R, rad_vec3 x, double *X, double *Y)
{
    double a, b;
    int in_front = 1;
    if (v->ortho) {
        a = rad_dot(x, v->right) / v->rw;
        b = rad_dot(x, v->up) / v->rw;
    } else {
        const rad_vec3 r = rad_sub(x, v->pos);
        const double w = rad_dot(r, v->fwd);
        in_front = w > 0.0;
        a = rad_dot(r, v->right) / w;
        b = rad_dot(r, v->up) / w;
    }
    *X = (a + 1.0) * 0.5 * R - 0.5;
    *Y = (b + 1.0) * 0.5 * R - 0.5;
    return in_front;
}

/* Do patch p's cells bend: does one face away from its mean normal?
 * (Two faces of a block, or planar patches meeting at a crease, stay
 * apart: one may shadow the other.) */
static int bent(const hc_engine *e, uint32_t p)
{
    for (uint32_t a = e->cfirst[p]; a < e->cfirst[p + 1]; a++)
        if (rad_dot(e->mesh->cells[a].normal, e->mesh->patches[p].normal) < 1.0 - 1e-6)
            return 1;
    return 0;
}

/* Are bent patches p and k neighbours on one surface: do a cell of each
 * share a corner (the mesher welds the facets' points)?  Two patches of a
 * curved surface meshed across its facets (radiosity/mesh/smooth.c) each
 * span up to 60° of it, so their mean normals, and the chord between
 * their centres, may lean far more than same_surface allows planar
 * neighbours, while the facets along their seam differ by one facet's
 * bend (test_room's sphere, radius 1.5 patch sizes, and head: their
 * elements' direct light was 2.8 % and 1.5 % low against their patches'). */
static int bent_neighbours(const hc_engine *e, uint32_t p, uint32_t k)
{
    if (!e->mesh->cell_first || e->cfirst[p + 1] - e->cfirst[p] < 2 ||
        e->cfirst[k + 1] - e->cfirst[k] < 2 || !bent(e, p) || !bent(e, k))
        return 0;
    const rad_patch *C = e->mesh->cells;
    for (uint32_t a = e->cfirst[p]; a < e->cfirst[p + 1]; a++)
        for (uint32_t b = e->cfirst[k]; b < e->cfirst[k + 1]; b++)
            for (int x = 0; x < e->ncorner[a]; x++)
                for (int y = 0; y < e->ncorner[b]; y++)
                    if (C[a].v[x] == C[b].v[y])
                        return 1;
    return 0;
}

/* Is patch k the same smooth surface as patch p, next to it: one object and
 * material, normals within the mesher's crease angle (30°, mesh.h's
 * RAD_MESH_SURFACE_COS), centres within 1.5 × the sum of their radii, and
 * the chord between the centres within 30° of p's tangent plane (on a
 * surface that bends by at most 30° the chord leans by about half that; a
 * parallel plate above or below p, such as a blocker over a floor of one
 * object, leans far more and stays an occluder)?
 * A point of a curved cluster (a sphere's, a head's) lies on its own cell,
 * not on the cluster's drawn outline, and near a seam the pixels about its
 * projection show the neighbouring cluster: that neighbour continues the
 * point's surface and shadows nothing (issue 36: counted as an occluder,
 * it took 0.3 % off the direct light of a sphere's elements).  Two bent
 * patches of one object and material that share a corner are such
 * neighbours whatever their normals (bent_neighbours). */
static int same_surface(const hc_engine *e, uint32_t k, uint32_t p)
{
    if (k >= e->n)
        return 0;
    const rad_patch *a = &e->mesh->patches[p], *b = &e->mesh->patches[k];
    const rad_vec3 chord = rad_sub(e->center[k], e->center[p]);
    const double d = rad_length(chord);
    if (!(a->object == b->object && a->material == b->material &&
          d <= 1.5 * (e->radius[p] + e->radius[k])))
        return 0;
    return (rad_dot(a->normal, b->normal) >= 0.86602540378443865 &&
            fabs(rad_dot(chord, a->normal)) <= 0.5 * d) ||
           bent_neighbours(e, p, k);
}

/* Visibility of point `at` (relative to the origin) on patch p in the item
 * buffer of view v: the bilinear weight of the four pixel centres around
 * its projection that let the light through (pixel_lets_through: p's
 * plane, a patch `at` lies in front of, nothing, a back side beyond it) or
 * show p's own smooth surface (same_surface); 0 outside the view.  Before
 * issue 36 any other patch counted as an occluder: beside a sphere's
 * silhouette the wall behind it shadowed its elements (0.5 % of their
 * direct light). */
static double point_visibility(const hc_engine *e, hc_work *wk, const hc_light_req *q,
                               const hc_view *v, rad_vec3 at, uint32_t p)
{
    const uint32_t R = q->resolution;
    double X, Y;
    if (!view_pixel(v, R, at, &X, &Y))
        return 0.0;
    if (!(X > -1.0 && X < (double)R && Y > -1.0 && Y < (double)R))
        return 0.0; /* outside the view (an orthographic view covers the whole scene) */
    return pixel_visibility(e, wk, q, v, at, p, X, Y);
}

int hc_light_points(const hc_engine *e, hc_work *wk, const hc_light_req *q,
                    const hc_point_req *pts, uint32_t m, double *vis, char *msg)
{
    const hc_view v = light_view(e, q);
    if (light_render(e, wk, q, &v, msg) != 0)
        return -1;
    for (uint32_t k = 0; k < m; k++)
        vis[k] = point_visibility(e, wk, q, &v, rad_v3(pts[k].at[0], pts[k].at[1], pts[k].at[2]),
                                  pts[k].patch);
    return 0;
}

/* ------------------------------------------------- exact power (issue 39) */

/* Φ_j = Φ°_j · v_j: Φ°_j the unoccluded power in closed form, v_j the
 * visible fraction from the item buffer.  Pixel counts were 2.5 % low on
 * floor tiles seen at grazing angles (a tile there covers a few pixels
 * whose solid angles the count takes whole or not at all); the closed form
 * has no such error, and v_j = 1 exactly for a tile nothing shadows.
 *   point: Φ° = the solid angle of j's part inside this cube face (each
 *     cell clipped to the face's frustum, fanned into triangles, each
 *     triangle's solid angle by Van Oosterom & Strackee's formula);
 *   spot: the same integral weighted by the falloff, each triangle split
 *     in four until the falloff at its centroid and the mean at its corners
 *     agree to HC_SPOT_TOL (the glTF falloff has a kink at the inner cone:
 *     the splitting follows it), at most HC_SPOT_DEPTH times;
 *   directional: Φ° = A_j max(0, −n_j·d), the projected area.
 * v_j is the weighted mean of the bilinear visibility (point_visibility)
 * at HC_VIS_SAMPLES² points of each cell inside the part, weight the
 * unoccluded irradiance there; where they disagree (a shadow's or the
 * view's edge crosses j) at HC_VIS_FINE² points. */
#define HC_SPOT_TOL 1e-5
#define HC_SPOT_DEPTH 12
#define HC_VIS_SAMPLES 4u
#define HC_VIS_FINE 16u

/* Solid angle of triangle a, b, c (relative to the light), unsigned. */
static double tri_solid_angle(rad_vec3 a, rad_vec3 b, rad_vec3 c)
{
    const double la = rad_length(a), lb = rad_length(b), lc = rad_length(c);
    const double num = fabs(rad_dot(a, rad_cross(b, c)));
    const double den = la * lb * lc + rad_dot(a, b) * lc + rad_dot(a, c) * lb + rad_dot(b, c) * la;
    return 2.0 * atan2(num, den);
}

static double falloff_at(const hc_light_req *q, rad_vec3 r)
{
    const rad_vec3 sd = rad_v3(q->dir[0], q->dir[1], q->dir[2]);
    return hc_spot_falloff(rad_dot(r, sd) / rad_length(r), q->cos_inner, q->cos_outer);
}

/* ∫ falloff dω over triangle a, b, c (relative to the light). */
static double spot_triangle(const hc_light_req *q, rad_vec3 a, rad_vec3 b, rad_vec3 c, int depth)
{
    const double omega = tri_solid_angle(a, b, c);
    const rad_vec3 g = rad_scale(rad_add(rad_add(a, b), c), 1.0 / 3.0);
    const double fg = falloff_at(q, g);
    const double fv = (falloff_at(q, a) + falloff_at(q, b) + falloff_at(q, c)) / 3.0;
    if (depth >= HC_SPOT_DEPTH || (fabs(fg - fv) <= HC_SPOT_TOL && (fg > 0.0) == (fv > 0.0)))
        return omega * (2.0 * fg + fv) / 3.0;
    const rad_vec3 ab = rad_scale(rad_add(a, b), 0.5), bc = rad_scale(rad_add(b, c), 0.5),
                   ca = rad_scale(rad_add(c, a), 0.5);
    return spot_triangle(q, a, ab, ca, depth + 1) + spot_triangle(q, ab, b, bc, depth + 1) +
           spot_triangle(q, ca, bc, c, depth + 1) + spot_triangle(q, ab, bc, ca, depth + 1);
}

double hc_light_polygon(const hc_light *light, const rad_vec3 *poly, uint32_t count, rad_vec3 n)
{
    if (count < 3)
        return 0.0;
    if (light->kind == HC_LIGHT_DIRECTIONAL) {
        rad_vec3 twice = rad_v3(0, 0, 0);
        for (uint32_t k = 1; k + 1 < count; k++)
            twice = rad_add(twice, rad_cross(rad_sub(poly[k], poly[0]), rad_sub(poly[k + 1], poly[0])));
        const double cosl = -rad_dot(n, rad_normalize(light->direction));
        return cosl > 0.0 ? 0.5 * rad_length(twice) * cosl : 0.0;
    }
    const rad_vec3 d = light->kind == HC_LIGHT_SPOT ? rad_normalize(light->direction) : rad_v3(0, 0, 1);
    const hc_light_req q = {.kind = (uint32_t)light->kind, .dir = {d.x, d.y, d.z},
                            .cos_inner = cos(light->inner_cone), .cos_outer = cos(light->outer_cone)};
    const rad_vec3 a = rad_sub(poly[0], light->position);
    if (!(rad_dot(a, n) < 0.0))
        return 0.0; /* the light is on or behind the polygon's plane */
    double phi = 0.0;
    for (uint32_t k = 1; k + 1 < count; k++) {
        const rad_vec3 b = rad_sub(poly[k], light->position), c = rad_sub(poly[k + 1], light->position);
        phi += light->kind == HC_LIGHT_SPOT ? spot_triangle(&q, a, b, c, 0) : tri_solid_angle(a, b, c);
    }
    return phi;
}

/* Clips polygon p[0..np) (relative to the light) to the cube face of view
 * v (|r·right| <= r·fwd, |r·up| <= r·fwd) into out; returns its count. */
static int clip_to_face(const hc_view *v, const rad_vec3 *p, int np, rad_vec3 out[16])
{
    rad_vec3 buf[2][16];
    const rad_vec3 pl[4] = {rad_sub(v->fwd, v->right), rad_add(v->fwd, v->right),
                            rad_sub(v->fwd, v->up), rad_add(v->fwd, v->up)};
    int cur = 0;
    for (int k = 0; k < np; k++)
        buf[0][k] = p[k];
    for (int k = 0; k < 4 && np > 0; k++) {
        int nn = 0;
        for (int t = 0; t < np && nn < 15; t++) {
            const rad_vec3 a = buf[cur][t], b = buf[cur][(t + 1) % np];
            const double da = rad_dot(pl[k], a), db = rad_dot(pl[k], b);
            if (da >= 0.0)
                buf[!cur][nn++] = a;
            if ((da >= 0.0) != (db >= 0.0))
                buf[!cur][nn++] = rad_add(a, rad_scale(rad_sub(b, a), da / (da - db)));
        }
        np = nn;
        cur = !cur;
    }
    for (int k = 0; k < np; k++)
        out[k] = buf[cur][k];
    return np;
}

/* Φ°_j of part q: the closed form over j's cells that face the light. */
static double unoccluded_power(const hc_engine *e, const hc_light_req *q, const hc_view *v, uint32_t j)
{
    double phi = 0.0;
    for (uint32_t cell = e->cfirst[j]; cell < e->cfirst[j + 1]; cell++) {
        const rad_vec3 nj = hc_cell_normal(e, j, cell); /* a bent patch's cell faces its own way */
        rad_vec3 p[4], c[16];
        hc_load_corners(e, cell, p);
        const int np = e->ncorner[cell];
        if (v->ortho) {
            const double cosl = -rad_dot(nj, v->fwd);
            const double area = np == 4 ? 0.5 * rad_length(rad_cross(rad_sub(p[2], p[0]), rad_sub(p[3], p[1])))
                                        : 0.5 * rad_length(rad_cross(rad_sub(p[1], p[0]), rad_sub(p[2], p[0])));
            phi += cosl > 0.0 ? area * cosl : 0.0;
            continue;
        }
        for (int k = 0; k < np; k++)
            p[k] = rad_sub(p[k], v->pos);
        if (!(rad_dot(p[0], nj) < 0.0))
            continue; /* the light is on or behind the cell's plane */
        const int nc = clip_to_face(v, p, np, c);
        for (int k = 1; k + 1 < nc; k++)
            phi += q->kind == HC_LIGHT_SPOT ? spot_triangle(q, c[0], c[k], c[k + 1], 0)
                                            : tri_solid_angle(c[0], c[k], c[k + 1]);
    }
    return phi;
}

/* The unoccluded irradiance weight of a point at r (relative to the light)
 * with normal n, for the visibility's weighted mean. */
static double sample_weight(const hc_light_req *q, const hc_view *v, rad_vec3 r, rad_vec3 n)
{
    if (v->ortho)
        return 1.0;
    const double l2 = rad_dot(r, r), cosj = -rad_dot(r, n) / sqrt(l2);
    if (!(cosj > 0.0))
        return 0.0;
    return cosj / l2 * (q->kind == HC_LIGHT_SPOT ? falloff_at(q, r) : 1.0);
}

/* Does pixel (px, py) of part q's item buffer let the light reach point x
 * of patch j?  Yes when it shows j's plane (shows_plane); when it shows
 * another patch k, unless x lies behind k's plane (the light is in front
 * of it, so the ray to x crosses it; a surface x lies in front of is
 * beyond x, like the wall a floor tile meets); when it shows nothing
 * (depth cleared: the ray misses everything, as beside a floor's outer
 * edge) or a back side farther than x. */
/* Do all of patch k's cells lie in its plane?  Not a curved patch's, nor a
 * shared patch's of small parts (mesh/parts.c): its centre and normal say
 * nothing of where the cell a pixel shows lies, and the depth decides. */
static int planar_patch(const hc_engine *e, uint32_t k)
{
    const rad_patch *pk = &e->mesh->patches[k], *c;
    const uint32_t n = rad_patch_cells(e->mesh, k, &c);
    for (uint32_t q = 0; q < n && n > 1; q++)
        if (rad_dot(c[q].normal, pk->normal) < 1.0 - 1e-6 ||
            fabs(rad_dot(rad_sub(c[q].center, pk->center), pk->normal)) > 1e-6 * e->bradius + e->tol)
            return 0;
    return 1;
}

static int pixel_lets_through(const hc_engine *e, hc_work *wk, const hc_light_req *q,
                              const hc_view *v, uint32_t px, uint32_t py, rad_vec3 x, uint32_t j)
{
    const uint32_t id = wk->lpixels[(size_t)py * q->resolution + px];
    if (shows_plane(e, id, j))
        return 1;
    const rad_vec3 r = rad_sub(x, v->pos);
    const double dist = v->ortho ? e->bradius : rad_length(r);
    if (id < e->n && planar_patch(e, id))
        return rad_dot(rad_sub(x, e->center[id]), e->mesh->patches[id].normal) >= -1e-4 * dist;
    const double D = hc_gl_read_depth(wk->gl, px, py);
    if (!(D > 0.0))
        return 1;
    if (v->ortho) { /* light_render's orthographic depth */
        const double rz = e->bradius * 1.01 + 1e-300;
        return D <= (rz - rad_dot(x, v->fwd)) / (2.0 * rz) + 1e-6;
    }
    const double near = 1e-6 * (e->bradius + rad_length(v->pos)) + 1e-300;
    return D <= near / rad_dot(r, v->fwd) * (1.0 + 1e-4);
}

/* Visibility of point x of patch j at its continuous pixel coordinates
 * (X, Y): the bilinear weight of the four pixel centres around them that
 * let the light through or show j's own smooth surface (same_surface). */
static double pixel_visibility(const hc_engine *e, hc_work *wk, const hc_light_req *q,
                               const hc_view *v, rad_vec3 x, uint32_t j, double X, double Y)
{
    const uint32_t R = q->resolution;
    const double fx0 = floor(X), fy0 = floor(Y), fx = X - fx0, fy = Y - fy0;
    double vis = 0.0;
    for (int dy = 0; dy < 2; dy++)
        for (int dx = 0; dx < 2; dx++) {
            long px = (long)fx0 + dx, py = (long)fy0 + dy;
            px = px < 0 ? 0 : px >= (long)R ? (long)R - 1 : px;
            py = py < 0 ? 0 : py >= (long)R ? (long)R - 1 : py;
            const double w = (dx ? fx : 1.0 - fx) * (dy ? fy : 1.0 - fy);
            if (w > 0.0 && (pixel_lets_through(e, wk, q, v, (uint32_t)px, (uint32_t)py, x, j) ||
                            same_surface(e, wk->lpixels[(size_t)py * R + (size_t)px], j)))
                vis += w;
        }
    return vis > 1.0 ? 1.0 : vis;
}

/* v_j from k² points per cell of j; *mixed set when some are lit and some
 * not.  -1 when no point falls in the part. */
static double sampled_visibility(const hc_engine *e, hc_work *wk, const hc_light_req *q,
                                 const hc_view *v, uint32_t j, uint32_t k, int *mixed)
{
    double sw = 0.0, sv = 0.0;
    int lit = 0, dark = 0;
    for (uint32_t cell = e->cfirst[j]; cell < e->cfirst[j + 1]; cell++) {
        const rad_vec3 nj = hc_cell_normal(e, j, cell);
        rad_vec3 p[4];
        hc_load_corners(e, cell, p);
        const int quad = e->ncorner[cell] == 4;
        for (uint32_t a = 0; a < k; a++)
            for (uint32_t b = 0; b < k; b++) {
                double s = (a + 0.5) / k, t = (b + 0.5) / k;
                rad_vec3 x;
                if (quad) {
                    x = rad_add(rad_scale(rad_add(rad_scale(p[0], 1 - s), rad_scale(p[1], s)), 1 - t),
                                rad_scale(rad_add(rad_scale(p[3], 1 - s), rad_scale(p[2], s)), t));
                } else { /* the square folded onto the triangle: s along 0-1, t towards 2 */
                    x = rad_add(rad_add(rad_scale(p[0], (1 - s) * (1 - t)), rad_scale(p[1], s * (1 - t))),
                                rad_scale(p[2], t));
                }
                const double w = sample_weight(q, v, rad_sub(x, v->pos), nj) * (quad ? 1.0 : 1.0 - t);
                if (!(w > 0.0))
                    continue;
                if (!v->ortho) { /* only the points of this face */
                    const rad_vec3 r = rad_sub(x, v->pos);
                    const double h = rad_dot(r, v->fwd);
                    if (!(h > 0.0) || fabs(rad_dot(r, v->right)) > h || fabs(rad_dot(r, v->up)) > h)
                        continue;
                }
                double X, Y; /* in front of the eye: checked above, or an orthographic view */
                (void)view_pixel(v, q->resolution, x, &X, &Y);
                const double vis = pixel_visibility(e, wk, q, v, x, j, X, Y);
                sw += w;
                sv += w * vis;
                lit |= vis > 0.0;
                dark |= vis < 1.0;
            }
    }
    *mixed = lit && dark;
    return sw > 0.0 ? sv / sw : -1.0;
}

/* Replaces the pixel counts in wk->acc by Φ°_j v_j for every patch with a
 * closed form in this part (see the top of this section). */
static void exact_power(const hc_engine *e, hc_work *wk, const hc_light_req *q, const hc_view *v)
{
    for (uint32_t j = 0; j < e->n; j++) {
        const double phi = unoccluded_power(e, q, v, j);
        if (!(phi > 0.0) || !isfinite(phi)) {
            wk->acc[j] = 0.0;
            continue;
        }
        int mixed = 0;
        double vis = sampled_visibility(e, wk, q, v, j, HC_VIS_SAMPLES, &mixed);
        if (mixed)
            vis = sampled_visibility(e, wk, q, v, j, HC_VIS_FINE, &mixed);
        if (vis < 0.0) /* a sliver of j in this face: no sample in it */
            vis = wk->acc[j] > 0.0 ? 1.0 : 0.0;
        wk->acc[j] = phi * vis;
    }
}

/* The lval buffer is made on the first light request: most runs have no
 * punctual light. */
long hc_light_part(const hc_engine *e, hc_work *wk, const hc_light_req *q, char *msg)
{
    const uint32_t n = e->n;
    if (!wk->lval && !(wk->lval = hc_alloc(n, sizeof *wk->lval, msg)))
        return -1;
    const hc_view v = light_view(e, q);
    if (light_render(e, wk, q, &v, msg) != 0)
        return -1;
    double *acc = wk->acc;
    pixel_power(e, wk, q, &v);
    exact_power(e, wk, q, &v);
    long cnt = 0;
    for (uint32_t j = 0; j < n; j++)
        if (acc[j] != 0.0) {
            if (acc[j] > 0.0) {
                wk->col[cnt] = j;
                wk->lval[cnt] = acc[j];
                cnt++;
            }
            acc[j] = 0.0;
        }
    return cnt;
}
