/* geometry.c - Lambert's contour integral from a differential element to a
 * polygon: the exact point-to-polygon form factor, which the hemi-cube uses
 * for its exact factors to emitters (hc_ff_point_polygon) and the gather
 * renderer for the unshadowed direct light of an area emitter.  Pure math:
 * no allocation, no state, no occlusion.
 *
 * Invariant: the result is in [0, 1], or NAN for a non-finite point or
 * normal, a zero normal or a non-finite corner; fewer than 3 corners give 0.
 */
#include "rad.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif


/* Running sum of Lambert's contour integral over the clipped polygon, fed one
 * vertex at a time so that the clipped polygon is never stored (no
 * allocation, any vertex count).  Vertices are relative to the element: r = P − p. */
typedef struct contour {
    rad_vec3 n;            /* element normal, unit */
    rad_vec3 first, prev;  /* first and latest emitted vertex */
    uint32_t emitted;
    double sum;            /* Σ β_k n·unit(r_k × r_{k+1}) */
} contour;

/* One edge's term β n·unit(r0 × r1).  β comes from atan2(|r0 × r1|, r0·r1),
 * which keeps full relative accuracy for the tiny angles of small or distant
 * polygons where acos of a normalised dot product would not.  An edge
 * collinear with p subtends no solid angle (or p lies on it, where F is
 * undefined anyway): it contributes nothing. */
static void contour_edge(contour *k, rad_vec3 r0, rad_vec3 r1)
{
    rad_vec3 c = rad_cross(r0, r1);
    double s = rad_length(c);
    if (!(s > 0.0)) return;
    double beta = atan2(s, rad_dot(r0, r1));
    k->sum += beta * (rad_dot(k->n, c) / s);
}

static void contour_emit(contour *k, rad_vec3 r)
{
    if (k->emitted == 0)
        k->first = r;
    else
        contour_edge(k, k->prev, r);
    k->prev = r;
    k->emitted++;
}

/* F from the element (p, n) to a planar polygon, by Lambert's formula
 *   F = 1/(2π) Σ_k β_k n·unit(r_k × r_{k+1}),   r_k = P_k − p,
 * over the polygon clipped to the element's front half-space (r·n > 0) by
 * one Sutherland–Hodgman pass, streamed straight into the sum.
 *
 * Why |Σ| is right for either winding: by Stokes the contour sum equals, up
 * to a sign fixed by the winding, the area integral over the clipped polygon
 * of cosθ_i cosθ_j/(r²) dA.  There cosθ_i = n·r̂ > 0 (we clipped), and
 * cosθ_j = m·r̂ for the polygon's normal m has ONE sign over the whole polygon
 * because all of a plane lies on one side of a point off it.  So the integral
 * is single-signed and the winding only flips the sign of the total.  (The
 * individual edge terms need not share a sign: an edge seen from the far
 * side of the polygon's interior counts negatively; only the total is
 * single-signed.)  When p lies in the polygon's plane the polygon is seen
 * edge-on, the terms cancel and F = 0 up to rounding. */
double rad_point_polygon_factor(rad_vec3 p, rad_vec3 n, const rad_vec3 *poly, uint32_t count)
{
    if (poly == NULL || count < 3) return 0.0;
    if (!rad_finite3(p) || !rad_finite3(n)) return NAN;
    double nl = rad_length(n);
    if (!(nl > 0.0) || !isfinite(nl)) return NAN;
    for (uint32_t k = 0; k < count; k++)
        if (!rad_finite3(poly[k])) return NAN;

    contour acc = {.n = rad_scale(n, 1.0 / nl), .emitted = 0, .sum = 0.0};
    rad_vec3 s = rad_sub(poly[count - 1], p);
    double ds = rad_dot(acc.n, s);
    for (uint32_t k = 0; k < count; k++) {
        rad_vec3 e = rad_sub(poly[k], p);
        double de = rad_dot(acc.n, e);
        int s_in = ds > 0.0, e_in = de > 0.0;
        if (s_in != e_in) {
            /* The edge crosses the tangent plane; ds − de cannot be 0 here
             * because one is > 0 and the other <= 0. */
            double t = ds / (ds - de);
            contour_emit(&acc, rad_add(s, rad_scale(rad_sub(e, s), t)));
        }
        if (e_in) contour_emit(&acc, e);
        s = e;
        ds = de;
    }
    if (acc.emitted < 3) return 0.0; /* nothing (or a sliver of no area) in front */
    contour_edge(&acc, acc.prev, acc.first);
    double f = fabs(acc.sum) / (2.0 * M_PI);
    return f > 1.0 ? 1.0 : f; /* round-off may pass 1 by an ulp */
}

/* The same sum over a list of directed edges instead of one polygon's
 * outline: the union of cells that share edges (a cluster), whose interior
 * edges run once each way and cancel term for term (an edge's term changes
 * sign exactly with its direction: r1 × r0 = −(r0 × r1) in floating point),
 * so only the outline's edges are summed.  No clipping: the caller has
 * every end point strictly in front of p (r·n > 0) and p in front of every
 * cell, so the cells' sums share one sign and |Σ| is their total. */
double rad_point_edges_factor(rad_vec3 p, rad_vec3 n, const double *edges, uint32_t count)
{
    if (!rad_finite3(p) || !rad_finite3(n)) return NAN;
    double nl = rad_length(n);
    if (!(nl > 0.0) || !isfinite(nl)) return NAN;
    contour acc = {.n = rad_scale(n, 1.0 / nl), .emitted = 0, .sum = 0.0};
    for (uint32_t k = 0; k < count; k++) {
        const double *q = edges + 6 * (size_t)k;
        rad_vec3 r0 = rad_v3(q[0] - p.x, q[1] - p.y, q[2] - p.z);
        rad_vec3 r1 = rad_v3(q[3] - p.x, q[4] - p.y, q[5] - p.z);
        contour_edge(&acc, r0, r1);
    }
    double f = fabs(acc.sum) / (2.0 * M_PI);
    return f > 1.0 ? 1.0 : f;
}
