/* patch_factors.c - unoccluded factors from the engine's geometry: from a
 * point to a patch (hc_point_to_patch) and from a patch to a patch averaged
 * over the first (hc_area_factor), summed over a patch's cells or over a
 * cluster's outline.
 *
 * Owns the integrals of the exact entries, with no visibility and no GL:
 * rows.c (in a worker) multiplies them by the visibility it measures, and
 * column.c (in the caller) by the visibility of a light's views, so a row's
 * entry and a column's entry read the very same integral.  Both sides may
 * call this file: it reads only the engine, which is filled before the
 * fork and read-only afterwards, and calls analytic.c alone.
 *
 * Invariant: the result depends only on the engine's geometry and the
 * arguments (fixed cell order, fixed subdivision), never on the process
 * that computes it.
 */
#include "hc_internal.h"

/* Bound of the area-average subdivision of exact_near entries: 16² sub-
 * triangles per fan triangle give ~1e-4 at a gap of 1 % of the size. */
#define HC_NEAR_MAX_SUBDIV 16u

/* The area of cell `cell`: a cluster's cell's own, else its patch's. */
static double cell_area(const hc_engine *e, uint32_t cell)
{
    return e->mesh->cell_first ? e->mesh->cells[cell].area : e->mesh->patches[cell].area;
}

/* The normal of cell `cell` by its winding (not normalised): a quad's
 * diagonals' cross product, a triangle's edges'. */
static rad_vec3 cell_winding(const hc_engine *e, uint32_t cell)
{
    rad_vec3 p[4];
    hc_load_corners(e, cell, p);
    return e->ncorner[cell] == 4 ? rad_cross(rad_sub(p[2], p[0]), rad_sub(p[3], p[1]))
                                 : rad_cross(rad_sub(p[1], p[0]), rad_sub(p[2], p[0]));
}

/* May the factor from x[0..nx) (a point, or a convex cell's corners, its
 * normal n) to patch j be summed over j's outline (e->oedge) instead of its
 * cells?  When j has one, no corner of j lies behind x's plane (nothing to
 * clip: a corner in the plane, as where j meets the cell, is what clipping
 * would give), and x sees every cell of j from the same side (the cells'
 * sums share one sign, so |Σ| over the outline is Σ |cell|): a point
 * strictly, a cell's corners on one closed side, one of them strictly, so
 * that its inside, where the area average samples it, is strictly there. */
static int outline_applies(const hc_engine *e, uint32_t j, const rad_vec3 *x, int nx, rad_vec3 n)
{
    if (!e->ofirst || e->ofirst[j] == e->ofirst[j + 1])
        return 0;
    double top = -INFINITY;
    for (int k = 0; k < nx; k++)
        top = fmax(top, rad_dot(x[k], n));
    const double margin = e->tol * rad_length(n);
    int side = 0;
    for (uint32_t cj = e->cfirst[j]; cj < e->cfirst[j + 1]; cj++) {
        const double *q = e->corner + (size_t)cj * 12;
        for (int k = 0; k < e->ncorner[cj]; k++)
            if (!(q[3 * k] * n.x + q[3 * k + 1] * n.y + q[3 * k + 2] * n.z - top > -margin))
                return 0;
        const rad_vec3 g = cell_winding(e, cj), q0 = rad_v3(q[0], q[1], q[2]);
        const double gm = e->tol * rad_length(g);
        int strict = 0;
        for (int k = 0; k < nx; k++) {
            const double sd = rad_dot(rad_sub(x[k], q0), g);
            const int sg = sd > gm ? 1 : sd < -gm ? -1 : 0;
            if (!sg)
                continue;
            if (side && sg != side)
                return 0;
            side = sg;
            strict = 1;
        }
        if (!strict)
            return 0;
    }
    return 1;
}

/* F from point c (normal n) to patch j: the contour integral over each of
 * its cells (hc_ff_point_polygon clips what lies behind c's plane), or over
 * a cluster's outline where outline_applies (the same sum without the
 * inner edges, which cancel: a third to a tenth of the terms). */
double hc_point_to_patch(const hc_engine *e, rad_vec3 c, rad_vec3 n, uint32_t j)
{
    if (outline_applies(e, j, &c, 1, n))
        return rad_point_edges_factor(c, n, e->oedge + 6 * (size_t)e->ofirst[j],
                                      e->ofirst[j + 1] - e->ofirst[j]);
    double f = 0.0;
    for (uint32_t cj = e->cfirst[j]; cj < e->cfirst[j + 1]; cj++) {
        rad_vec3 pj[4];
        hc_load_corners(e, cj, pj);
        f += hc_ff_point_polygon(c, n, pj, e->ncorner[cj]);
    }
    return f;
}

/* F from patch i to patch j, unoccluded, by area averages over i's cells
 * (F_ij = Σ_c (A_c / A_i) Σ_d F_cd) with `sub`² sub-triangles, to j's
 * outline where outline_applies; over cells[0..ncell) of i (summed area
 * `area`) instead when cells is not NULL. */
static double patch_to_patch(const hc_engine *e, uint32_t i, const uint32_t *cells,
                             uint32_t ncell, double area, uint32_t j, uint32_t sub)
{
    double f = 0.0;
    const uint32_t count = cells ? ncell : e->cfirst[i + 1] - e->cfirst[i];
    for (uint32_t k = 0; k < count; k++) {
        const uint32_t ci = cells ? cells[k] : e->cfirst[i] + k;
        rad_vec3 pi[4];
        hc_load_corners(e, ci, pi);
        const uint32_t np = e->ncorner[ci];
        double fc = 0.0;
        if (outline_applies(e, j, pi, (int)np, cell_winding(e, ci))) {
            fc = hc_ff_polygon_edges(pi, np, e->oedge + 6 * (size_t)e->ofirst[j],
                                     e->ofirst[j + 1] - e->ofirst[j], sub);
        } else {
            for (uint32_t cj = e->cfirst[j]; cj < e->cfirst[j + 1]; cj++) {
                rad_vec3 pj[4];
                hc_load_corners(e, cj, pj);
                fc += hc_ff_polygon_polygon(pi, np, pj, e->ncorner[cj], sub);
            }
        }
        f += count == 1 ? fc : fc * cell_area(e, ci) / area;
    }
    return f;
}

/* The subdivision of an area average over patch i towards j (seen from
 * i's centre c): sub-triangles about half the distance across, at least
 * `least`, so that the 7-point rule resolves F_{dA→j}, which varies on that
 * scale. */
static uint32_t average_subdiv(const hc_engine *e, uint32_t i, uint32_t j, rad_vec3 c,
                               double least)
{
    double dist = rad_length(rad_sub(e->center[j], c));
    double sub = ceil(4.0 * e->radius[i] / fmax(dist, 1e-300));
    sub = sub < least ? least : sub > HC_NEAR_MAX_SUBDIV ? HC_NEAR_MAX_SUBDIV : sub;
    return (uint32_t)sub;
}

double hc_area_factor(const hc_engine *e, uint32_t i, uint32_t j, int near)
{
    return hc_cells_factor(e, i, NULL, 0, e->mesh->patches[i].area, j, near);
}

double hc_cells_factor(const hc_engine *e, uint32_t i, const uint32_t *cells, uint32_t ncell,
                       double area, uint32_t j, int near)
{
    return patch_to_patch(e, i, cells, ncell, area, j,
                          average_subdiv(e, i, j, e->center[i], near ? 2.0 : 1.0));
}
