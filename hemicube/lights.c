/* lights.c - punctual lights (glTF KHR_lights_punctual): hc_light_power,
 * hc_light_direct, hc_light_visibility and their worker side.
 *
 * Owns a light's views (a cube of six R×R faces at a point or spot light,
 * or one orthographic R×R view along a directional light), their item
 * buffers and pixel solid angles, and the requests that spread the parts
 * over the engine's workers.  Lights are a second request type served by
 * the same workers as rows: one request per cube face (the directional
 * light's single view is part 0), answered with Φ_j of that part; the
 * caller adds the parts in part order, so the result never depends on which
 * worker drew what.  Visibility of points is a third: points are grouped by
 * the part their direction falls in, and a worker renders a part's item
 * buffer once (light_render keeps the last part drawn: same request, same
 * pixels) and looks each point up in it (point_visibility).  Invariant:
 * power and visibility read the one rendering code (light_render), so a
 * point and the patch power agree on what the light sees.
 */
#include "hc_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------ worker side */

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

/* Cube face f of a point light: forward ±x, ±y, ±z; right = forward × up
 * so that front faces stay front faces. */
static void cube_face(uint32_t f, rad_vec3 *right, rad_vec3 *up, rad_vec3 *fwd)
{
    static const double ax[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    *fwd = rad_v3(ax[f][0], ax[f][1], ax[f][2]);
    *up = f < 4 ? rad_v3(0, 0, 1) : rad_v3(0, 1, 0);
    *right = rad_cross(*fwd, *up);
}

/* glTF KHR_lights_punctual spot falloff for a direction whose cosine to the
 * axis is cos_axis: t² with t = clamp(cos_axis·scale + offset, 0, 1),
 * scale = 1/max(0.001, cos_inner − cos_outer), offset = −cos_outer·scale. */
static double spot_falloff(double cos_axis, double cos_inner, double cos_outer)
{
    double scale = 1.0 / fmax(0.001, cos_inner - cos_outer);
    double t = cos_axis * scale - cos_outer * scale;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    return t * t;
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
        cube_face(q->part, &v.right, &v.up, &v.fwd);
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

/* The lval buffer is made on the first light request: most runs have no
 * punctual light. */
long hc_light_part(const hc_engine *e, hc_work *wk, const hc_light_req *q, char *msg)
{
    const uint32_t n = e->n, R = q->resolution;
    if (!wk->lval && !(wk->lval = hc_alloc(n, sizeof *wk->lval, msg)))
        return -1;
    const hc_view v = light_view(e, q);
    if (light_render(e, wk, q, &v, msg) != 0)
        return -1;
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
                    w *= spot_falloff(rad_dot(dir, sd) / rad_length(dir), q->cos_inner, q->cos_outer);
                }
                acc[id] += w;
            }
    }
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

/* Visibility of point `at` (relative to the origin) on patch p in the item
 * buffer of view v: the bilinear weight of the four pixel centres around its
 * projection that show p's plane (clamped at the face's border). */
static double point_visibility(const hc_engine *e, const hc_work *wk, const hc_view *v, uint32_t R,
                               rad_vec3 at, uint32_t p)
{
    double x, y;
    if (v->ortho) {
        x = rad_dot(at, v->right) / v->rw;
        y = rad_dot(at, v->up) / v->rw;
    } else {
        rad_vec3 r = rad_sub(at, v->pos);
        double w = rad_dot(r, v->fwd);
        if (!(w > 0.0))
            return 0.0;
        x = rad_dot(r, v->right) / w;
        y = rad_dot(r, v->up) / w;
    }
    /* Continuous pixel coordinates: pixel k's centre is at k. */
    double X = (x + 1.0) * 0.5 * R - 0.5, Y = (y + 1.0) * 0.5 * R - 0.5;
    if (!(X > -1.0 && X < (double)R && Y > -1.0 && Y < (double)R))
        return 0.0; /* outside the view (an orthographic view covers the whole scene) */
    double fx0 = floor(X), fy0 = floor(Y), fx = X - fx0, fy = Y - fy0;
    long x0 = (long)fx0, y0 = (long)fy0;
    double vis = 0.0;
    for (int dy = 0; dy < 2; dy++)
        for (int dx = 0; dx < 2; dx++) {
            long px = x0 + dx, py = y0 + dy;
            px = px < 0 ? 0 : px >= (long)R ? (long)R - 1 : px;
            py = py < 0 ? 0 : py >= (long)R ? (long)R - 1 : py;
            double w = (dx ? fx : 1.0 - fx) * (dy ? fy : 1.0 - fy);
            if (w > 0.0 && shows_plane(e, wk->lpixels[(size_t)py * R + (size_t)px], p))
                vis += w;
        }
    return vis > 1.0 ? 1.0 : vis;
}

int hc_light_points(const hc_engine *e, hc_work *wk, const hc_light_req *q,
                    const hc_point_req *pts, uint32_t m, double *vis, char *msg)
{
    const hc_view v = light_view(e, q);
    if (light_render(e, wk, q, &v, msg) != 0)
        return -1;
    for (uint32_t k = 0; k < m; k++)
        vis[k] = point_visibility(e, wk, &v, q->resolution,
                                  rad_v3(pts[k].at[0], pts[k].at[1], pts[k].at[2]), pts[k].patch);
    return 0;
}

/* ------------------------------------------------------------ caller side */

/* Reads the header of worker k's answer to a light request: RAD_OK with
 * its count in *m when the header is `tag`; else the engine is broken (a
 * worker's error message, or a stream out of step). */
static int receive_light_header(hc_engine *e, uint32_t k, uint32_t tag, uint32_t *m,
                                rad_error *err)
{
    uint32_t hdr[2];
    int rc = hc_pool_header(e, k, hdr, err);
    if (rc != RAD_OK)
        return rc;
    if (hdr[0] != tag)
        return hc_pool_gone(e, k, err);
    *m = hdr[1];
    return RAD_OK;
}

/* Reads worker k's answer to one light part and adds it to power (when
 * add); RAD_OK, or the engine is broken and the error is in err. */
static int receive_light(hc_engine *e, uint32_t k, double *power, double *rx, int add,
                         rad_error *err)
{
    int fd = e->w[k].fd;
    uint32_t m = 0;
    int rc = receive_light_header(e, k, HC_MSG_LIGHT, &m, err);
    if (rc != RAD_OK)
        return rc;
    if (m > e->n ||
        hc_wire_recv(fd, e->rx_col, (size_t)m * sizeof *e->rx_col) != 0 ||
        hc_wire_recv(fd, rx, (size_t)m * sizeof *rx) != 0)
        return hc_pool_gone(e, k, err);
    for (uint32_t q = 0; q < m; q++)
        if (e->rx_col[q] >= e->n || (q && e->rx_col[q] <= e->rx_col[q - 1]) || !(rx[q] > 0.0) ||
            !isfinite(rx[q]))
            return hc_pool_gone(e, k, err);
    if (add)
        for (uint32_t q = 0; q < m; q++)
            power[e->rx_col[q]] += rx[q];
    return RAD_OK;
}

/* Checks a light and fills the request of its parts (all but q->part);
 * fn names the public function in messages. */
static int light_request(const hc_engine *e, const hc_light *light, uint32_t resolution,
                         const char *fn, hc_light_req *q, rad_error *err)
{
    uint32_t R = resolution ? resolution : HC_DEFAULT_LIGHT_RESOLUTION;
    if (!hc_resolution_ok(R))
        return rad_fail(err, RAD_ERR_USAGE, "%s: resolution %u: must be even and within 8..4096",
                        fn, R);
    memset(q, 0, sizeof *q);
    q->resolution = R;
    q->kind = (uint32_t)light->kind;
    rad_vec3 dir = rad_v3(0, 0, 0);
    switch (light->kind) {
    case HC_LIGHT_SPOT:
        if (!isfinite(light->inner_cone) || !isfinite(light->outer_cone) || light->inner_cone < 0.0 ||
            light->inner_cone > light->outer_cone || light->outer_cone > M_PI / 2)
            return rad_fail(err, RAD_ERR_USAGE,
                            "%s: spot cones %g, %g: need 0 <= inner <= outer <= pi/2", fn,
                            light->inner_cone, light->outer_cone);
        /* fall through */
    case HC_LIGHT_DIRECTIONAL:
        dir = light->direction;
        if (!rad_finite3(dir) || !(rad_length(dir) > 0.0))
            return rad_fail(err, RAD_ERR_USAGE, "%s: light direction must be finite and non-zero", fn);
        dir = rad_normalize(dir);
        if (light->kind == HC_LIGHT_DIRECTIONAL)
            break;
        /* fall through */
    case HC_LIGHT_POINT:
        if (!rad_finite3(light->position))
            return rad_fail(err, RAD_ERR_USAGE, "%s: light position must be finite", fn);
        break;
    default:
        return rad_fail(err, RAD_ERR_USAGE, "%s: unknown light kind %d", fn, (int)light->kind);
    }
    if (e->broken)
        return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
    rad_vec3 pos = light->kind == HC_LIGHT_DIRECTIONAL ? rad_v3(0, 0, 0) : rad_sub(light->position, e->origin);
    q->pos[0] = pos.x, q->pos[1] = pos.y, q->pos[2] = pos.z;
    q->dir[0] = dir.x, q->dir[1] = dir.y, q->dir[2] = dir.z;
    q->cos_inner = cos(light->inner_cone);
    q->cos_outer = cos(light->outer_cone);
    return RAD_OK;
}

int hc_light_power(hc_engine *e, const hc_light *light, uint32_t resolution, double *power,
                   rad_error *err)
{
    if (!e || !light || (!power && e->n))
        return rad_fail(err, RAD_ERR_USAGE, "hc_light_power: engine, light and power must be given");
    hc_light_req q;
    int rc = light_request(e, light, resolution, "hc_light_power", &q, err);
    if (rc != RAD_OK)
        return rc;
    for (uint32_t j = 0; j < e->n; j++)
        power[j] = 0.0;
    if (e->n == 0)
        return RAD_OK;
    const rad_vec3 dir = rad_v3(q.dir[0], q.dir[1], q.dir[2]);

    /* Parts: the cube faces (a spot's faces that its outer cone reaches: the
     * face's directions lie within acos(1/√3) of its axis), or the single
     * orthographic view. */
    uint32_t parts[6], np = 0;
    if (light->kind == HC_LIGHT_DIRECTIONAL) {
        parts[np++] = 0;
    } else {
        for (uint32_t f = 0; f < 6; f++) {
            rad_vec3 right, up, fwd;
            cube_face(f, &right, &up, &fwd);
            double ang = acos(fmax(-1.0, fmin(1.0, rad_dot(fwd, dir))));
            if (light->kind == HC_LIGHT_SPOT && ang > light->outer_cone + acos(1.0 / sqrt(3.0)) + 1e-9)
                continue;
            parts[np++] = f;
        }
    }
    double *rx = malloc((size_t)e->n * sizeof *rx);
    if (!rx)
        return rad_fail(err, RAD_ERR_NOMEM, "hc_light_power: out of memory for %u patches", e->n);
    /* Part k goes to worker k mod nproc; each worker answers in the order
     * asked, so reading the parts in order reads every stream in order. */
    uint32_t sent = 0;
    for (; sent < np; sent++) {
        uint32_t k = sent % e->nproc;
        q.part = parts[sent];
        if (hc_wire_send_light(e->w[k].fd, &q) != 0) {
            rc = hc_pool_gone(e, k, err);
            break;
        }
    }
    /* Answers of parts already sent are read even after a failure, while
     * their workers live, so a later call finds the streams in step. */
    for (uint32_t p = 0; p < sent; p++) {
        uint32_t k = p % e->nproc;
        if (e->w[k].fd < 0)
            continue;
        int s = receive_light(e, k, power, rx, rc == RAD_OK, rc == RAD_OK ? err : NULL);
        if (s != RAD_OK && rc == RAD_OK)
            rc = s;
        if (s != RAD_OK) {
            /* That stream is lost: no more reads from it. */
            hc_pool_drop(e, k);
        }
    }
    free(rx);
    if (rc != RAD_OK)
        for (uint32_t j = 0; j < e->n; j++)
            power[j] = 0.0;
    return rc;
}

double hc_light_direct(const hc_light *light, rad_vec3 p, rad_vec3 n)
{
    if (light->kind == HC_LIGHT_DIRECTIONAL) {
        double c = -rad_dot(n, rad_normalize(light->direction));
        return c > 0.0 ? c : 0.0;
    }
    rad_vec3 r = rad_sub(light->position, p);
    double r2 = rad_dot(r, r);
    if (!(r2 > 0.0))
        return 0.0;
    double len = sqrt(r2), c = rad_dot(n, r) / len;
    if (!(c > 0.0))
        return 0.0;
    double f = 1.0;
    if (light->kind == HC_LIGHT_SPOT)
        f = spot_falloff(-rad_dot(r, rad_normalize(light->direction)) / len, cos(light->inner_cone),
                         cos(light->outer_cone));
    return f * c / r2;
}

/* The part (cube face, or the orthographic view) holding the direction from
 * the light to `at` (relative to the origin): the face of the dominant axis,
 * which projects it into [-1, 1]²; -1 for a point at the light. */
static int vis_part(const hc_light_req *q, rad_vec3 at)
{
    if (q->kind == HC_LIGHT_DIRECTIONAL)
        return 0;
    double r[3] = {at.x - q->pos[0], at.y - q->pos[1], at.z - q->pos[2]};
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (fabs(r[a]) > fabs(r[axis]))
            axis = a;
    if (!(fabs(r[axis]) > 0.0))
        return -1;
    return 2 * axis + (r[axis] < 0.0); /* cube_face's order: +x, -x, +y, -y, +z, -z */
}

/* Reads worker k's answer to one visibility chunk of m points into
 * vis[idx[0..m)] (when store).  RAD_OK, or the engine is broken. */
static int receive_vis(hc_engine *e, uint32_t k, const uint32_t *idx, uint32_t m, double *vis,
                       double *rx, int store, rad_error *err)
{
    uint32_t got = 0;
    int rc = receive_light_header(e, k, HC_MSG_VIS, &got, err);
    if (rc != RAD_OK)
        return rc;
    if (got != m || hc_wire_recv(e->w[k].fd, rx, (size_t)m * sizeof *rx) != 0)
        return hc_pool_gone(e, k, err);
    for (uint32_t q = 0; q < m; q++)
        if (!(rx[q] >= 0.0 && rx[q] <= 1.0))
            return hc_pool_gone(e, k, err);
    if (store)
        for (uint32_t q = 0; q < m; q++)
            vis[idx[q]] = rx[q];
    return RAD_OK;
}

/* The points by part (a counting sort, stable: each part's points in their
 * given order), so a worker renders a part once for all of its chunks
 * (light_render keeps the last part's pixels): order[start[f]..start[f + 1])
 * are part f's points, part 6 those at the light (left at 0). */
static void sort_by_part(const hc_engine *e, const hc_light_req *q, const hc_receiver *points,
                         uint32_t count, uint32_t *part, uint32_t *order, uint32_t start[8])
{
    for (uint32_t k = 0; k < count; k++) {
        int f = vis_part(q, rad_sub(points[k].center, e->origin));
        part[k] = f < 0 ? 6u : (uint32_t)f; /* 6: at the light, left at 0 */
        start[part[k] + 1]++;
    }
    for (int f = 0; f < 7; f++)
        start[f + 1] += start[f];
    uint32_t fill[7];
    memcpy(fill, start, sizeof fill);
    for (uint32_t k = 0; k < count; k++)
        order[fill[part[k]]++] = k;
}

/* Worker k takes the parts k, k + nproc, ... in turn; per round each worker
 * has one chunk in flight, and every answer of a round is read before the
 * next round is sent, so no socket fills in both directions.  Results
 * depend only on the part's pixels and the point, never on which worker
 * drew them.  rx and buf hold HC_VIS_CHUNK values each. */
static int vis_rounds(hc_engine *e, hc_light_req *q, const hc_receiver *points,
                      const uint32_t *order, const uint32_t start[8], double *vis, double *rx,
                      hc_point_req *buf, rad_error *err)
{
    int rc = RAD_OK;
    uint32_t *wpart = calloc(e->nproc, sizeof *wpart), *wnext = calloc(e->nproc, sizeof *wnext);
    uint32_t *wsent = calloc(e->nproc, sizeof *wsent), *wcnt = calloc(e->nproc, sizeof *wcnt);
    if (!wpart || !wnext || !wsent || !wcnt) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "hc_light_visibility: out of memory");
        goto done;
    }
    for (uint32_t k = 0; k < e->nproc; k++) {
        wpart[k] = k;
        wnext[k] = k < 6 ? start[k] : 0;
    }
    for (;;) {
        int any = 0;
        memset(wcnt, 0, e->nproc * sizeof *wcnt);
        for (uint32_t k = 0; k < e->nproc; k++) {
            while (rc == RAD_OK && wpart[k] < 6 && wnext[k] >= start[wpart[k] + 1]) {
                wpart[k] += e->nproc;
                if (wpart[k] < 6)
                    wnext[k] = start[wpart[k]];
            }
            if (rc != RAD_OK || wpart[k] >= 6 || e->w[k].fd < 0)
                continue;
            uint32_t f = wpart[k], m = start[f + 1] - wnext[k];
            m = m > HC_VIS_CHUNK ? HC_VIS_CHUNK : m;
            for (uint32_t i = 0; i < m; i++) {
                const hc_receiver *pt = &points[order[wnext[k] + i]];
                rad_vec3 at = rad_sub(pt->center, e->origin);
                buf[i] = (hc_point_req){order[wnext[k] + i], pt->patch, {at.x, at.y, at.z}};
            }
            q->part = f;
            if (hc_wire_send_vis(e->w[k].fd, q, buf, m) != 0) {
                rc = hc_pool_gone(e, k, err);
                break;
            }
            wsent[k] = wnext[k];
            wcnt[k] = m;
            wnext[k] += m;
            any = 1;
        }
        /* Answers already asked for are read even after a failure, while
         * their workers live, so a later call finds the streams in step. */
        for (uint32_t k = 0; k < e->nproc; k++) {
            if (!wcnt[k] || e->w[k].fd < 0)
                continue;
            int s = receive_vis(e, k, order + wsent[k], wcnt[k], vis, rx, rc == RAD_OK,
                                rc == RAD_OK ? err : NULL);
            if (s != RAD_OK) {
                if (rc == RAD_OK)
                    rc = s;
                hc_pool_drop(e, k);
            }
        }
        if (!any || rc != RAD_OK)
            break;
    }
done:
    free(wpart), free(wnext), free(wsent), free(wcnt);
    return rc;
}

int hc_light_visibility(hc_engine *e, const hc_light *light, uint32_t resolution,
                        const hc_receiver *points, uint32_t count, double *vis, rad_error *err)
{
    if (!e || !light || (count && (!points || !vis)))
        return rad_fail(err, RAD_ERR_USAGE,
                        "hc_light_visibility: engine, light, points and vis must be given");
    for (uint32_t k = 0; k < count; k++)
        if (points[k].patch >= e->n || !rad_finite3(points[k].center))
            return rad_fail(err, RAD_ERR_USAGE, "hc_light_visibility: point %u: patch %u of %u, or "
                            "a non-finite point", k, points[k].patch, e->n);
    hc_light_req q;
    int rc = light_request(e, light, resolution, "hc_light_visibility", &q, err);
    if (rc != RAD_OK)
        return rc;
    for (uint32_t k = 0; k < count; k++)
        vis[k] = 0.0;
    if (count == 0)
        return RAD_OK;
    uint32_t *part = malloc((size_t)count * sizeof *part), *order = malloc((size_t)count * sizeof *order);
    double *rx = malloc(HC_VIS_CHUNK * sizeof *rx);
    hc_point_req *buf = malloc(HC_VIS_CHUNK * sizeof *buf);
    uint32_t start[8] = {0};
    if (!part || !order || !rx || !buf) {
        free(part), free(order), free(rx), free(buf);
        return rad_fail(err, RAD_ERR_NOMEM, "hc_light_visibility: out of memory for %u points", count);
    }
    sort_by_part(e, &q, points, count, part, order, start);
    rc = vis_rounds(e, &q, points, order, start, vis, rx, buf, err);
    if (rc != RAD_OK)
        for (uint32_t k = 0; k < count; k++)
            vis[k] = 0.0;
    free(part), free(order), free(rx), free(buf);
    return rc;
}
