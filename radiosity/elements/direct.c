/* direct.c - the emitters' direct light at points of elements (issue 18).
 *
 * The direct sources are the emitting patches (E > 0 in some band) when an
 * element set is made.  Each is cut into EL_STRATA strata, the four cells
 * of its first quadtree split (a cluster, a patch of several small
 * polygons, into its cells instead), and an item buffer is rendered at a point
 * just in front of each stratum's centre (hc_light_visibility: a point
 * light's cube, the same views punctual lights use).  The entry of a
 * receiving point x (normal n: its own cell's, which in a curved cluster
 * is not the cluster's mean normal) for source patch j is then
 *   F_xj = Σ_s F(x → σ_s) · v_s(x),
 * F(x → σ_s) the exact unoccluded point-to-polygon factor of stratum σ_s
 * (hc_ff_point_polygon), v_s(x) x's visibility in the item buffer of σ_s
 * (anti-aliased over one pixel).  It is exact where each stratum is wholly
 * seen or hidden; in a penumbra the strata make steps of about 1/(4 × the
 * source's patches) of its light, smoothed over a pixel of the item buffer.
 * One rendering per stratum serves every point of a call, whatever their
 * number: that is what makes an element's direct light cheap next to a
 * hemi-cube of its own.
 *
 * Invariant: entries come out per point in increasing j, each > 0 and
 * finite; a point gets nothing from a stratum it lies behind or that lies
 * behind it (emitters are one-sided).
 */
#include "el_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The light's point sits this far in front of its stratum (relative to the
 * stratum's size): off the emitter's own plane, far below any geometry. */
#define EL_STRATUM_LIFT 1e-5

/* A stratum: a quarter of an emitter patch, and where its views are drawn. */
struct el_stratum {
    uint32_t patch;
    uint32_t corners;
    rad_vec3 p[4];
    rad_vec3 normal;    /* the emitter's: it emits to this side only */
    hc_light light;     /* a point light just in front of the stratum's centre */
};

void el_sources_free(el_sources *src)
{
    if (!src)
        return;
    free(src->direct);
    free(src->st);
    memset(src, 0, sizeof *src);
}

/* The four cells of a cell's first split (refine.c's split, corner for
 * corner), of patch p, into st[0..4). */
static void strata_of_cell(const rad_mesh *m, uint32_t p, const rad_patch *c, el_stratum *st)
{
    const int corners = rad_patch_corners(c);
    rad_vec3 v[4], mid[4];
    for (int k = 0; k < corners; k++)
        v[k] = m->vertices[c->v[k]];
    for (int k = 0; k < corners; k++)
        mid[k] = el_midpoint(v[k], v[(k + 1) % corners]);
    if (corners == 4) {
        rad_vec3 ctr = rad_scale(rad_add(rad_add(v[0], v[1]), rad_add(v[2], v[3])), 0.25);
        const rad_vec3 q[4][4] = {{v[0], mid[0], ctr, mid[3]}, {mid[0], v[1], mid[1], ctr},
                                  {ctr, mid[1], v[2], mid[2]}, {mid[3], ctr, mid[2], v[3]}};
        for (int k = 0; k < 4; k++) {
            memcpy(st[k].p, q[k], sizeof st[k].p);
            st[k].corners = 4;
        }
    } else {
        const rad_vec3 q[4][3] = {{v[0], mid[0], mid[2]}, {mid[0], v[1], mid[1]},
                                  {mid[2], mid[1], v[2]}, {mid[0], mid[1], mid[2]}};
        for (int k = 0; k < 4; k++) {
            memcpy(st[k].p, q[k], 3 * sizeof st[k].p[0]);
            st[k].corners = 3;
        }
    }
    for (uint32_t k = 0; k < EL_STRATA; k++) {
        st[k].patch = p;
        st[k].normal = c->normal;
    }
}

/* Patch p's strata into st (room for strata_count(m, p)): the four
 * quarters of a patch of one cell, each cell of a cluster; each with its
 * point light just in front of its centre. */
static uint32_t strata_of(const rad_mesh *m, uint32_t p, el_stratum *st)
{
    const rad_patch *cells;
    const uint32_t k = rad_patch_cells(m, p, &cells);
    uint32_t count = 0;
    if (k == 1) {
        strata_of_cell(m, p, &cells[0], st);
        count = EL_STRATA;
    } else {
        for (uint32_t q = 0; q < k; q++, count++) {
            const int corners = rad_patch_corners(&cells[q]);
            for (int c = 0; c < corners; c++)
                st[count].p[c] = m->vertices[cells[q].v[c]];
            st[count].corners = (uint32_t)corners;
            st[count].patch = p;
            st[count].normal = cells[q].normal;
        }
    }
    for (uint32_t q = 0; q < count; q++) {
        el_stratum *s = &st[q];
        rad_vec3 ctr = rad_v3(0, 0, 0);
        double size = 0.0;
        for (uint32_t c = 0; c < s->corners; c++) {
            ctr = rad_add(ctr, s->p[c]);
            size = fmax(size, rad_length(rad_sub(s->p[(c + 1) % s->corners], s->p[c])));
        }
        ctr = rad_scale(ctr, 1.0 / s->corners);
        s->light = (hc_light){.kind = HC_LIGHT_POINT,
                              .position = rad_add(ctr, rad_scale(s->normal, EL_STRATUM_LIFT * size))};
    }
    return count;
}

/* How many strata patch p has (strata_of). */
static uint32_t strata_count(const rad_mesh *m, uint32_t p)
{
    const rad_patch *cells;
    const uint32_t k = rad_patch_cells(m, p, &cells);
    return k == 1 ? EL_STRATA : k;
}

int el_sources_make(const rad_solution *s, el_sources *src, rad_error *err)
{
    memset(src, 0, sizeof *src);
    const uint32_t n = s->mesh->patch_count, bands = s->band_count;
    src->direct = calloc(n ? n : 1, 1);
    if (!src->direct)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the direct sources");
    for (uint32_t j = 0; j < n; j++)
        if (rad_any_positive(s->emission + (size_t)j * bands, bands)) {
            src->direct[j] = 1;
            src->patches++;
        }
    size_t total = 0;
    for (uint32_t j = 0; j < n; j++)
        total += src->direct[j] ? strata_count(s->mesh, j) : 0;
    src->st = malloc((total + 1) * sizeof *src->st);
    if (!src->st) {
        el_sources_free(src);
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for the direct sources");
    }
    for (uint32_t j = 0; j < n; j++)
        if (src->direct[j])
            src->count += strata_of(s->mesh, j, src->st + src->count);
    return RAD_OK;
}

void el_rows_free(el_rows *r)
{
    if (!r)
        return;
    free(r->start);
    free(r->col);
    free(r->val);
    memset(r, 0, sizeof *r);
}

/* One entry found: point k, source patch j. */
typedef struct triplet {
    uint32_t k, j;
    float v;
} triplet;

int el_direct_rows(const el_sources *src, hc_engine *hc, uint32_t R,
                   const hc_receiver *pts, const rad_vec3 *normal, uint32_t count, el_rows *out,
                   uint64_t *renders, rad_error *err)
{
    memset(out, 0, sizeof *out);
    double *acc = calloc((size_t)count + 1, sizeof *acc), *vis = malloc(((size_t)count + 1) * sizeof *vis);
    double *f = malloc(((size_t)count + 1) * sizeof *f);
    hc_receiver *sub = malloc(((size_t)count + 1) * sizeof *sub);
    uint32_t *at = malloc(((size_t)count + 1) * sizeof *at);
    triplet *t = NULL;
    size_t nt = 0, cap = 0;
    int rc = RAD_OK;
    out->start = calloc((size_t)count + 1, sizeof *out->start);
    if (!acc || !vis || !f || !sub || !at || !out->start)
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for direct light");
    for (uint32_t first = 0, end = 0; rc == RAD_OK && first < src->count; first = end) {
        const uint32_t j = src->st[first].patch;
        while (end < src->count && src->st[end].patch == j)
            end++;
        for (uint32_t q = first; rc == RAD_OK && q < end; q++) {
            const el_stratum *st = &src->st[q];
            uint32_t m = 0;
            for (uint32_t k = 0; k < count; k++) {
                const rad_vec3 x = pts[k].center, nx = normal[k];
                /* One-sided: x must lie in front of the emitter. */
                if (pts[k].patch == j || !(rad_dot(rad_sub(x, st->p[0]), st->normal) > 0.0))
                    continue;
                double ff = hc_ff_point_polygon(x, nx, st->p, st->corners);
                if (!(ff > 0.0) || !isfinite(ff))
                    continue;
                sub[m] = pts[k];
                at[m] = k;
                f[m++] = ff;
            }
            if (!m)
                continue;
            rc = hc_light_visibility(hc, &st->light, R, sub, m, vis, err);
            if (renders)
                (*renders)++;
            for (uint32_t k = 0; k < m && rc == RAD_OK; k++)
                acc[at[k]] += f[k] * vis[k];
        }
        /* Patch j's entries, point by point (j rises from one source to the
         * next, so each point's entries come out in order). */
        for (uint32_t k = 0; k < count && rc == RAD_OK; k++) {
            float v = (float)acc[k];
            acc[k] = 0.0;
            if (!(v > 0.0f))
                continue;
            if (nt == cap) {
                cap = cap ? 2 * cap : 4096;
                triplet *g = realloc(t, cap * sizeof *t);
                if (!g) {
                    rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for direct light");
                    break;
                }
                t = g;
            }
            t[nt++] = (triplet){k, j, v};
            out->start[k + 1]++;
        }
    }
    if (rc == RAD_OK) {
        for (uint32_t k = 0; k < count; k++)
            out->start[k + 1] += out->start[k];
        out->col = malloc((nt + 1) * sizeof *out->col);
        out->val = malloc((nt + 1) * sizeof *out->val);
        uint64_t *fill = malloc(((size_t)count + 1) * sizeof *fill);
        if (!out->col || !out->val || !fill) {
            rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for direct light");
        } else {
            /* A stable bucket sort by point keeps each point's j in order. */
            memcpy(fill, out->start, ((size_t)count + 1) * sizeof *fill);
            for (size_t q = 0; q < nt; q++) {
                uint64_t w = fill[t[q].k]++;
                out->col[w] = t[q].j;
                out->val[w] = t[q].v;
            }
        }
        free(fill);
    }
    if (rc != RAD_OK)
        el_rows_free(out);
    free(acc);
    free(vis);
    free(f);
    free(sub);
    free(at);
    free(t);
    return rc;
}
