/* light_requests.c - the caller's side of the punctual lights (glTF
 * KHR_lights_punctual): hc_light_power, hc_light_visibility and
 * hc_light_direct.
 *
 * Owns the checks of a light and the requests that split it into parts;
 * the engine's producer (e->prod: the local pool's side in pool_lights.c)
 * sends them to workers and reads the answers, and the worker side
 * (light_views.c) draws the parts.  Lights are a second request type served
 * by the same workers as rows: one request per cube face (the directional
 * light's single view is part 0), answered with Φ_j of that part; the
 * parts are added in part order, so the result never depends on which
 * worker drew what.  Visibility of points is a third: points are grouped by
 * the part their direction falls in (sort_by_part), sent in chunks, and
 * each worker answers a chunk from the part's item buffer.  Invariant: a
 * function of this file runs in the caller only (it reaches workers only
 * through the producer); nothing here is reachable from worker.c.
 */
#include "hc_internal.h"

#include <stdlib.h>
#include <string.h>

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
            hc_cube_face(f, &right, &up, &fwd);
            double ang = acos(fmax(-1.0, fmin(1.0, rad_dot(fwd, dir))));
            if (light->kind == HC_LIGHT_SPOT && ang > light->outer_cone + acos(1.0 / sqrt(3.0)) + 1e-9)
                continue;
            parts[np++] = f;
        }
    }
    rc = e->prod->light_power(e, &q, parts, np, power, err);
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
        f = hc_spot_falloff(-rad_dot(r, rad_normalize(light->direction)) / len,
                            cos(light->inner_cone), cos(light->outer_cone));
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
    return 2 * axis + (r[axis] < 0.0); /* hc_cube_face's order: +x, -x, +y, -y, +z, -z */
}

/* The points by part (a counting sort, stable: each part's points in their
 * given order), so a worker renders a part once for all of its chunks
 * (light_views.c keeps the last part's pixels): part f's points are
 * order[start[f]..start[f + 1]), part 6 those at the light (left at 0). */
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
    uint32_t start[8] = {0};
    if (!part || !order) {
        free(part), free(order);
        return rad_fail(err, RAD_ERR_NOMEM, "hc_light_visibility: out of memory for %u points", count);
    }
    sort_by_part(e, &q, points, count, part, order, start);
    rc = e->prod->light_vis(e, &q, points, order, start, vis, err);
    if (rc != RAD_OK)
        for (uint32_t k = 0; k < count; k++)
            vis[k] = 0.0;
    free(part), free(order);
    return rc;
}
