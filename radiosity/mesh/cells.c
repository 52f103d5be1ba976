/* cells.c - the geometry of cells and of patches made of several cells
 * (mesh.h, mesh_internal.h): what the mesher's builders (mesh.c, region.c)
 * share, below them in the dependency order.  Invariant: a cell's area and
 * centre are measured projected on its unit normal; a patch of several
 * cells has their summed area, mean normal, and its centre on a cell.
 */
#include "mesh_internal.h"

/* Cells along an edge of length len for a target patch edge `size`.  The
 * 1e-9 keeps an edge of exactly k·size from becoming k+1 cells through
 * rounding.  UINT64_MAX when the count would not fit a uint32. */
uint64_t mesh_divisions(double len, double size)
{
    if (!(size > 0.0) || !isfinite(size))
        return 1;
    double q = len / size;
    if (!(q <= 4294967295.0))
        return UINT64_MAX;
    double c = ceil(q - 1e-9);
    return c < 1.0 ? 1 : (uint64_t)c;
}

int rad_cell_geometry(const rad_vec3 *V, const uint32_t v[4], rad_vec3 n, rad_vec3 *center,
                      double *area)
{
    double a1 = 0.5 * rad_dot(rad_cross(rad_sub(V[v[1]], V[v[0]]), rad_sub(V[v[2]], V[v[0]])), n);
    rad_vec3 c = rad_scale(rad_add(rad_add(V[v[0]], V[v[1]]), V[v[2]]), a1 / 3.0);
    double a = a1;
    if (v[3] != RAD_NONE) {
        double a2 = 0.5 * rad_dot(rad_cross(rad_sub(V[v[2]], V[v[0]]), rad_sub(V[v[3]], V[v[0]])), n);
        c = rad_add(c, rad_scale(rad_add(rad_add(V[v[0]], V[v[2]]), V[v[3]]), a2 / 3.0));
        a += a2;
    }
    if (!(a > 0.0) || !isfinite(a))
        return -1;
    *area = a;
    *center = rad_scale(c, 1.0 / a);
    return 0;
}

int mesh_patch_of_cells(const rad_vec3 *V, const rad_patch *cells, uint32_t n, rad_patch *out)
{
    if (n == 1) {
        *out = cells[0];
        return 0;
    }
    double area = 0.0;
    rad_vec3 sum_n = rad_v3(0, 0, 0), sum_c = rad_v3(0, 0, 0);
    for (uint32_t c = 0; c < n; c++) {
        area += cells[c].area;
        sum_n = rad_add(sum_n, rad_scale(cells[c].normal, cells[c].area));
        sum_c = rad_add(sum_c, rad_scale(cells[c].center, cells[c].area));
    }
    rad_vec3 centroid = rad_scale(sum_c, 1.0 / area), at = centroid;
    uint32_t home = 0;
    double best = INFINITY;
    for (uint32_t c = 0; c < n; c++) {
        rad_vec3 q;
        double d2 = rad_cell_nearest(V, cells[c].v, centroid, &q);
        if (d2 < best) {
            best = d2;
            home = c;
            at = q;
        }
    }
    *out = cells[home];
    out->center = at;
    out->normal = rad_normalize(sum_n);
    out->area = area;
    return rad_length(sum_n) > 0.0 ? 0 : -1;
}
