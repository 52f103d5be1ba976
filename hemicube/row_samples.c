/* row_samples.c - where a row's hemi-cubes sit on a patch whose cells
 * bend (issue 36), and the row as the area-weighted mean of theirs.
 *
 * A curved surface of narrow facets is meshed across its facets
 * (radiosity/mesh/smooth.c): such a patch's cells are planar, each with
 * its own normal, and the patch is not.  One cube at the patch's centre
 * about its mean normal n̄ takes the light of a facet tilted by θ as if
 * it faced n̄: near a terminator the mean over the facets of max(0, n·l)
 * exceeds max(0, n̄·l), so such patches came out dark (a sphere's mean B
 * 2 % low in test_room), and an emitter below the mean plane was lost.
 * The row is instead
 *   F_ij = Σ_s (A_s / A_i) F_sj,
 * F_sj the row of a cube on sample s: a group of i's cells whose normals
 * lie within HC_SAMPLE_DEG of the group's seed, the cube at the centre of
 * the group's cell nearest its mean normal, about that cell's normal, its
 * area-averaged exact entries over the group's cells.  Seeds are chosen by
 * farthest normal (the largest cell first, then the cell whose normal is
 * farthest from every seed so far, while that is more than HC_SAMPLE_DEG),
 * at most HC_SAMPLE_MAX.  A patch whose cells all lie within HC_SAMPLE_DEG
 * of its largest cell (every planar patch) is one sample: the cube at its
 * centre about its normal, the row as it always was.
 *
 * Invariant: the samples depend only on the mesh (fixed cell order, ties
 * to the lower index), so a row stays bit-identical whichever worker
 * computes it; Σ_j F_ij <= 1 since each sample's row is and the weights
 * sum to 1.
 */
#include "hc_internal.h"

#include <stdlib.h>

/* 12°: a facet 12° off its cube's axis errs by 1 - cos 12° = 2 % only on
 * the sliver of the sky within 12° of its horizon. */
#define HC_SAMPLE_COS 0.97814760073380564
#define HC_SAMPLE_MAX 4u

/* The sample of each cell of patch i (into group[0..k), k its cell count)
 * and the seeds' cell numbers (into seed); returns the sample count. */
static uint32_t group_cells(const rad_mesh *m, uint32_t i, uint8_t *group, uint32_t *seed)
{
    const rad_patch *cells;
    const uint32_t k = rad_patch_cells(m, i, &cells);
    uint32_t big = 0;
    for (uint32_t c = 0; c < k; c++) {
        group[c] = 0;
        big = cells[c].area > cells[big].area ? c : big;
    }
    seed[0] = big;
    uint32_t ns = 1;
    for (;;) {
        double worst = 2.0;
        uint32_t far = 0;
        for (uint32_t c = 0; c < k; c++) {
            double best = -2.0;
            for (uint32_t g = 0; g < ns; g++) {
                const double d = rad_dot(cells[c].normal, cells[seed[g]].normal);
                if (d > best) {
                    best = d;
                    group[c] = (uint8_t)g;
                }
            }
            if (best < worst) {
                worst = best;
                far = c;
            }
        }
        if (worst >= HC_SAMPLE_COS || ns == HC_SAMPLE_MAX)
            return ns;
        seed[ns++] = far;
    }
}

uint32_t hc_row_cubes(const rad_mesh *m, uint32_t i)
{
    const rad_patch *cells;
    const uint32_t k = rad_patch_cells(m, i, &cells);
    if (k == 1)
        return 1;
    uint8_t *group = malloc(k);
    uint32_t seed[HC_SAMPLE_MAX];
    const uint32_t ns = group ? group_cells(m, i, group, seed) : 1;
    free(group);
    return ns;
}

/* Sample g of patch i from its cells (group[], of k): its cells into
 * cells[] (returned: how many), area, and the cube at the centre of its
 * cell nearest its area-mean normal, about that cell's normal. */
static uint32_t make_sample(const hc_engine *e, uint32_t i, const uint8_t *group, uint32_t g,
                            uint32_t *list, hc_sample *s)
{
    const rad_patch *cells;
    const uint32_t k = rad_patch_cells(e->mesh, i, &cells), c0 = e->cfirst[i];
    rad_vec3 mean = rad_v3(0, 0, 0);
    uint32_t cnt = 0;
    s->area = 0.0;
    for (uint32_t c = 0; c < k; c++)
        if (group[c] == g) {
            list[cnt++] = c0 + c;
            s->area += cells[c].area;
            mean = rad_add(mean, rad_scale(cells[c].normal, cells[c].area));
        }
    uint32_t best = list[0] - c0;
    for (uint32_t q = 1; q < cnt; q++)
        if (rad_dot(cells[list[q] - c0].normal, mean) > rad_dot(cells[best].normal, mean))
            best = list[q] - c0;
    s->c = rad_sub(cells[best].center, e->origin);
    s->n = cells[best].normal;
    s->cells = list;
    s->ncell = cnt;
    s->point = 0;
    return cnt;
}

/* The normal of the cell of patch i that holds point x (relative to the
 * origin): the cell whose plane x lies nearest, by its centre's distance
 * between cells as near (x lies on a shared edge). */
static rad_vec3 normal_at(const hc_engine *e, uint32_t i, rad_vec3 x)
{
    const rad_patch *cells;
    const uint32_t k = rad_patch_cells(e->mesh, i, &cells);
    uint32_t best = 0;
    double bd = INFINITY, bc = INFINITY;
    for (uint32_t c = 0; c < k; c++) {
        const rad_vec3 q = rad_sub(cells[c].center, e->origin);
        const double d = fabs(rad_dot(rad_sub(x, q), cells[c].normal));
        const double r = rad_length(rad_sub(x, q));
        if (d < bd - 1e-9 * e->radius[i] || (d <= bd + 1e-9 * e->radius[i] && r < bc)) {
            best = c;
            bd = d;
            bc = r;
        }
    }
    return cells[best].normal;
}

/* Copies wk->racc's entries into the row (j ascending) and clears it. */
static long take_mean(const hc_engine *e, hc_work *wk)
{
    long cnt = 0;
    for (uint32_t j = 0; j < e->n; j++) {
        const float f = (float)wk->racc[j];
        wk->racc[j] = 0.0;
        if (f > 0.0f) {
            wk->col[cnt] = j;
            wk->val[cnt] = f;
            cnt++;
        }
    }
    return cnt;
}

long hc_row(const hc_engine *e, hc_work *wk, uint32_t i, const rad_vec3 *at, double reach,
            char *msg)
{
    const rad_patch *pi = &e->mesh->patches[i];
    hc_sample s = {.c = e->center[i], .n = pi->normal, .area = pi->area};
    uint32_t seed[HC_SAMPLE_MAX];
    const uint32_t k = e->cfirst[i + 1] - e->cfirst[i];
    uint8_t *group = wk->rgroup + e->cfirst[i];
    const uint32_t ns = k == 1 ? 1 : group_cells(e->mesh, i, group, seed);
    if (at) {
        s.c = *at;
        s.n = ns == 1 ? pi->normal : normal_at(e, i, *at);
        s.point = 1;
        s.reach = reach;
        return hc_row_sample(e, wk, i, &s, msg);
    }
    if (ns == 1)
        return hc_row_sample(e, wk, i, &s, msg);
    for (uint32_t g = 0; g < ns; g++) {
        make_sample(e, i, group, g, wk->rcell, &s);
        const long cnt = hc_row_sample(e, wk, i, &s, msg);
        if (cnt < 0)
            return -1;
        const double w = s.area / pi->area;
        for (long q = 0; q < cnt; q++)
            wk->racc[wk->col[q]] += w * wk->val[q];
    }
    return take_mean(e, wk);
}
