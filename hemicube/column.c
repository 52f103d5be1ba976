/* column.c - hc_exact_column: the factors every receiver gathers from one
 * emitting patch, for a progressive solver to shoot with.
 *
 * A hemi-cube row F_ij is what patch i gathers; to shoot from i a solver
 * needs the other way, F_ji for every receiver j.  Reciprocity (A_i F_ij =
 * A_j F_ji) holds for pixel-counted rows only to a few per cent, and not at
 * all where the rows are exact: a receiver's row takes its entry for an
 * emitter as F_exact(j -> i) · v_ji (rows.c), the factor to i averaged
 * over the receiver (issue 18; summed over i's cells when i is a cluster
 * of small polygons) times the fraction of i it sees.  This computes that
 * same quantity from the emitter's side, as Wallace, Elmquist & Haines
 * (1989) shoot from a source to the receivers' points: that factor
 * (hc_area_factor, the very integral of the row), times
 * the visibility of c_j from the sample points of i, looked up in item
 * buffers rendered at those points (hc_light_visibility: a cube of views
 * at a point, bilinear in the pixels that show c_j's own surface).
 *
 * Runs in the caller, at the top of the folder's order: it calls
 * light_requests.c (the visibility) and patch_factors.c (the integral),
 * and nothing in hemicube/ calls it.
 *
 * Invariant of a column: j strictly increasing, j != i, F_ji > 0 and
 * finite, only receivers whose centre lies strictly in front of i's plane
 * and that face it.  What differs from the rows' entries is the visibility
 * alone, sampled at `samples`² points of i rather than as the fraction of i
 * that c_j's hemi-cube (or focused view) shows: equal where nothing is in
 * between, apart inside penumbrae.
 */
#include "hc_internal.h"

#include <stdlib.h>
#include <string.h>

/* The sample points sit this far in front of the emitter's plane (times its
 * size), so that its own polygon and coplanar neighbours (a light set in its
 * ceiling) are behind them, never in between. */
#define HC_SAMPLE_LIFT 1e-3

/* Point (u, v) in [0,1]² of patch i (absolute coordinates), in one of its
 * cells (a cluster's: the cell floor(u × cells), u rescaled within it):
 * bilinear in a quad's corners; in a triangle, the corners' weights
 * (1 - u, u(1 - v), uv). */
static rad_vec3 patch_point(const hc_engine *e, uint32_t i, double u, double v)
{
    const uint32_t cells = e->cfirst[i + 1] - e->cfirst[i];
    uint32_t k = (uint32_t)(u * cells);
    k = k < cells ? k : cells - 1;
    u = u * cells - k;
    const uint32_t cell = e->cfirst[i] + k;
    const double *q = e->corner + (size_t)cell * 12;
    rad_vec3 c[4];
    for (int m = 0; m < 4; m++)
        c[m] = rad_add(rad_v3(q[3 * m], q[3 * m + 1], q[3 * m + 2]), e->origin);
    if (e->ncorner[cell] == 3)
        return rad_add(rad_add(rad_scale(c[0], 1.0 - u), rad_scale(c[1], u * (1.0 - v))),
                       rad_scale(c[2], u * v));
    return rad_lerp(rad_lerp(c[0], c[1], u), rad_lerp(c[3], c[2], u), v);
}

int hc_exact_column(hc_engine *e, uint32_t i, uint32_t resolution, uint32_t samples, uint32_t *col,
                    float *val, uint32_t *count, rad_error *err)
{
    if (!e || !col || !val || !count || i >= e->n)
        return rad_fail(err, RAD_ERR_USAGE, "hc_exact_column: engine, patch (%u) and buffers", i);
    *count = 0;
    const uint32_t n = e->n, s = samples ? samples : 1;
    const rad_patch *P = e->mesh->patches;
    const rad_vec3 ni = P[i].normal;

    /* The receivers: in front of i, facing it (F_exact > 0). */
    hc_receiver *recv = malloc((size_t)n * sizeof *recv);
    double *F = malloc((size_t)n * sizeof *F), *vis = malloc((size_t)n * sizeof *vis);
    double *sum = calloc(n, sizeof *sum);
    int rc = RAD_OK;
    if (!recv || !F || !vis || !sum) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "hc_exact_column: out of memory for %u patches", n);
        goto done;
    }
    uint32_t m = 0;
    for (uint32_t j = 0; j < n; j++) {
        if (j == i || !(rad_dot(rad_sub(e->center[j], e->center[i]), ni) > e->tol))
            continue;
        /* the rows' entry for an exact emitter (rows.c): the factor
         * averaged over the receiver, near or not as its row decides */
        const rad_vec3 d = rad_sub(e->center[i], e->center[j]);
        const int near = e->opt.exact_near && rad_dot(d, d) < 4.0 * e->radius[i] * e->radius[i];
        const double f = hc_area_factor(e, j, i, near);
        if (!(f > 0.0) || !isfinite(f))
            continue;
        recv[m] = (hc_receiver){.center = P[j].center, .patch = j};
        F[m++] = f;
    }

    /* Their visibility from s² points of i, each a point light's views. */
    const double lift = HC_SAMPLE_LIFT * sqrt(P[i].area);
    for (uint32_t a = 0; a < s && rc == RAD_OK && m; a++)
        for (uint32_t b = 0; b < s && rc == RAD_OK; b++) {
            rad_vec3 at = s == 1 ? P[i].center : patch_point(e, i, (a + 0.5) / s, (b + 0.5) / s);
            const hc_light L = {.kind = HC_LIGHT_POINT, .position = rad_add(at, rad_scale(ni, lift))};
            rc = hc_light_visibility(e, &L, resolution, recv, m, vis, err);
            for (uint32_t k = 0; k < m && rc == RAD_OK; k++)
                sum[k] += vis[k];
        }
    for (uint32_t k = 0; k < m && rc == RAD_OK; k++) {
        const float f = (float)(F[k] * sum[k] / ((double)s * s));
        if (f > 0.0f) {
            col[*count] = recv[k].patch;
            val[(*count)++] = f;
        }
    }
done:
    if (rc != RAD_OK)
        *count = 0;
    free(recv);
    free(F);
    free(vis);
    free(sum);
    return rc;
}
