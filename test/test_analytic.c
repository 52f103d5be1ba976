/* test_analytic.c - the analytic form factors of hemicube/analytic.c.
 *
 * Checks the catalog closed forms against published values, reciprocity,
 * their limits and superposition; the contour integral against the closed
 * forms (including clipping by the element's plane); and the polygon-to-
 * polygon average against the closed forms and an independent brute-force
 * double-area quadrature of cosθ_i cosθ_j/(π r²) written here.
 */
#include "../hemicube/hemicube.h"
#include "test.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ------------------------------------------------------------- helpers */

/* Regular n-gon of radius r (vertices on the circle) in the plane z = z0,
 * counter-clockwise seen from +z. */
static void ngon(rad_vec3 *out, uint32_t n, double r, double z0)
{
    for (uint32_t k = 0; k < n; k++) {
        double t = 2.0 * M_PI * k / n;
        out[k] = rad_v3(r * cos(t), r * sin(t), z0);
    }
}

/* Axis-aligned rectangle [x0,x1]×[y0,y1] at height z, counter-clockwise seen from +z. */
static void rect_z(rad_vec3 *out, double x0, double x1, double y0, double y1, double z)
{
    out[0] = rad_v3(x0, y0, z);
    out[1] = rad_v3(x1, y0, z);
    out[2] = rad_v3(x1, y1, z);
    out[3] = rad_v3(x0, y1, z);
}

/* Brute-force F from element (p, n) to triangle t: centroid rule on the
 * k² sub-triangles of a barycentric grid, integrand
 * max(0, cosθ_i) |cosθ_j| / (π r²).  Independent of the contour integral. */
static double brute_point_triangle(rad_vec3 p, rad_vec3 n, const rad_vec3 t[3], int k)
{
    rad_vec3 e1 = rad_sub(t[1], t[0]), e2 = rad_sub(t[2], t[0]);
    rad_vec3 m2 = rad_cross(e1, e2);
    double area = 0.5 * rad_length(m2);
    rad_vec3 m = rad_normalize(m2);
    double dA = area / ((double)k * k), sum = 0.0;
    for (int i = 0; i < k; i++)
        for (int j = 0; i + j < k; j++) {
            for (int down = 0; down < 2; down++) {
                if (down && i + j + 1 >= k) break;
                double u = down ? (i + 2.0 / 3.0) / k : (i + 1.0 / 3.0) / k;
                double v = down ? (j + 2.0 / 3.0) / k : (j + 1.0 / 3.0) / k;
                rad_vec3 x = rad_add(t[0], rad_add(rad_scale(e1, u), rad_scale(e2, v)));
                rad_vec3 d = rad_sub(x, p);
                double r2 = rad_dot(d, d), r = sqrt(r2);
                double ci = rad_dot(n, d) / r, cj = fabs(rad_dot(m, d)) / r;
                if (ci > 0.0) sum += ci * cj / (M_PI * r2) * dA;
            }
        }
    return sum;
}

/* Centroids and weight of the k² sub-triangles of triangle t. */
static int subtri_points(const rad_vec3 t[3], int k, rad_vec3 *pts)
{
    rad_vec3 e1 = rad_sub(t[1], t[0]), e2 = rad_sub(t[2], t[0]);
    int c = 0;
    for (int i = 0; i < k; i++)
        for (int j = 0; i + j < k; j++) {
            pts[c++] = rad_add(t[0], rad_add(rad_scale(e1, (i + 1.0 / 3.0) / k),
                                             rad_scale(e2, (j + 1.0 / 3.0) / k)));
            if (i + j + 1 < k)
                pts[c++] = rad_add(t[0], rad_add(rad_scale(e1, (i + 2.0 / 3.0) / k),
                                                 rad_scale(e2, (j + 2.0 / 3.0) / k)));
        }
    return c;
}

static rad_vec3 tri_normal(const rad_vec3 t[3])
{
    return rad_normalize(rad_cross(rad_sub(t[1], t[0]), rad_sub(t[2], t[0])));
}

static double tri_area(const rad_vec3 t[3])
{
    return 0.5 * rad_length(rad_cross(rad_sub(t[1], t[0]), rad_sub(t[2], t[0])));
}

/* Brute-force F_ab between two triangles: centroid rule over k² × k² pairs
 * of sub-triangles of (1/A_a) ∫∫ cosθ_a cosθ_b / (π r²) dA_a dA_b. */
static double brute_triangle_triangle(const rad_vec3 a[3], const rad_vec3 b[3], int k)
{
    static rad_vec3 pa[200 * 200], pb[200 * 200];
    int ca = subtri_points(a, k, pa), cb = subtri_points(b, k, pb);
    rad_vec3 na = tri_normal(a), nb = tri_normal(b);
    double dAa = tri_area(a) / ca, dAb = tri_area(b) / cb, sum = 0.0;
    for (int i = 0; i < ca; i++) {
        double row = 0.0;
        for (int j = 0; j < cb; j++) {
            rad_vec3 d = rad_sub(pb[j], pa[i]);
            double r2 = rad_dot(d, d);
            double ci = rad_dot(na, d), cj = -rad_dot(nb, d); /* both × r */
            if (ci > 0.0 && cj > 0.0) row += ci * cj / (r2 * r2);
        }
        sum += row;
    }
    return sum * dAa * dAb / (M_PI * tri_area(a));
}

/* ------------------------------------------------------ closed forms */

TEST(catalog_values)
{
    /* Published catalog values to 8 digits: the tolerance is their last digit. */
    CHECK_NEAR(hc_ff_parallel_rectangles(1.0, 1.0, 1.0), 0.19982490, 1e-7);
    CHECK_NEAR(hc_ff_perpendicular_rectangles(1.0, 1.0, 1.0), 0.20004378, 1e-7);
    /* Coaxial unit disks one radius apart: X = 3, F = (3 − √5)/2 exactly. */
    CHECK_NEAR(hc_ff_coaxial_disks(1.0, 1.0, 1.0), (3.0 - sqrt(5.0)) / 2.0, 1e-15);
    /* B-3 for the unit square at unit distance: (1/2π)·2·(1/√2)·atan(1/√2); rounding only. */
    CHECK_NEAR(hc_ff_element_parallel_rectangle(1.0, 1.0, 1.0),
               (2.0 / sqrt(2.0)) * atan(1.0 / sqrt(2.0)) / (2.0 * M_PI), 1e-15);
}

TEST(reciprocity)
{
    /* A1 F12 = A2 F21; both sides come from the same symmetric expression,
     * so only rounding separates them: 1e-12 relative. */
    double l = 1.3, w1 = 0.7, w2 = 2.9;
    double f12 = hc_ff_perpendicular_rectangles(l, w1, w2);
    double f21 = hc_ff_perpendicular_rectangles(l, w2, w1);
    CHECK(f12 > 0.0 && f21 > 0.0 && fabs(f12 - f21) > 0.05); /* the test means something */
    CHECK_REL(l * w1 * f12, l * w2 * f21, 1e-12);

    double r1 = 0.5, r2 = 1.7, h = 0.8;
    double g12 = hc_ff_coaxial_disks(r1, r2, h), g21 = hc_ff_coaxial_disks(r2, r1, h);
    CHECK(g12 > 0.0 && g21 > 0.0 && fabs(g12 - g21) > 0.05);
    CHECK_REL(r1 * r1 * g12, r2 * r2 * g21, 1e-12);

    /* Parallel rectangles are symmetric in a and b (the swap is exact up to rounding). */
    CHECK_REL(hc_ff_parallel_rectangles(0.3, 2.5, 0.9), hc_ff_parallel_rectangles(2.5, 0.3, 0.9), 1e-14);
}

TEST(limits)
{
    /* c → 0: F → 1.  The loss is escape through the gap along the perimeter:
     * an element x from an edge of a half-plane loses ½(1 − x/√(x²+c²)), which
     * integrates to c/2 per unit length, so 1 − F ≈ P c / (2A) = 2c for the
     * unit square, with corner corrections O(c²).  At c = 1e-6 the slope
     * is 2 within 1e-4 (measured 1.99998997). */
    double c = 1e-6;
    double F = hc_ff_parallel_rectangles(1.0, 1.0, c);
    CHECK(F < 1.0);
    CHECK_NEAR((1.0 - F) / c, 2.0, 1e-4);
    CHECK_NEAR(hc_ff_parallel_rectangles(1.0, 1.0, 1e-12), 1.0, 1e-11);

    /* Large c: F ≈ ab/(π c²), the relative error being O((a²+b²)/c²) ≈ 1.7e-4 at c = 100. */
    CHECK_REL(hc_ff_parallel_rectangles(1.0, 2.0, 100.0), 2.0 / (M_PI * 100.0 * 100.0), 1e-3);
    /* Far beyond: the rewritten form keeps its digits where the textbook form
     * cancels away (X = 1e-8: all terms ~1e-16 of the leading ones). */
    CHECK_REL(hc_ff_parallel_rectangles(1.0, 2.0, 1e8), 2.0 / (M_PI * 1e16), 1e-12);

    /* Coaxial disks: F(r, r, h) → 1 as h → 0, with 1 − F ≈ h/r. */
    double h = 1e-6;
    double G = hc_ff_coaxial_disks(1.0, 1.0, h);
    CHECK(G < 1.0);
    CHECK_NEAR(1.0 - G, h, 1e-11); /* the next term is O(h²) */
    /* r1 → 0 gives the element-to-disk factor r²/(h²+r²): relative O(r1²). */
    CHECK_REL(hc_ff_coaxial_disks(1e-9, 1.5, 0.7), 1.5 * 1.5 / (0.7 * 0.7 + 1.5 * 1.5), 1e-12);

    /* Perpendicular rectangles: a very long common edge turns them into
     * infinite strips, F = ½(1 + H/W − √(1 + (H/W)²)) (Hottel's crossed
     * strings); the end effect is O(w/l), 1e-5 at l = 1e5. */
    double W = 1.0, Hh = 2.0, L = 1e5, q = Hh / W;
    CHECK_NEAR(hc_ff_perpendicular_rectangles(L, W, Hh), 0.5 * (1.0 + q - sqrt(1.0 + q * q)), 1e-4);

    /* A thin strip along the common edge sees the wall as a half-plane:
     * F → ½, with a correction O(W log W) (W = w1/l).  In the textbook form
     * the O(W) braces drown in O(1) rounding long before W = 1e-30. */
    CHECK_NEAR(hc_ff_perpendicular_rectangles(1.0, 1e-30, 1.3), 0.5, 1e-12);
    CHECK_NEAR(hc_ff_perpendicular_rectangles(1.0, 1e-6, 1.3), 0.5, 1e-4);

    /* Absurd but legal proportions give a value in [0, 1], never NaN. */
    static const double v[] = {1e-300, 1e-100, 1e-8, 1.0, 1e8, 1e100, 1e300};
    int bad = 0;
    for (int i = 0; i < 7; i++)
        for (int j = 0; j < 7; j++)
            for (int k = 0; k < 7; k++) {
                double f[4] = {hc_ff_parallel_rectangles(v[i], v[j], v[k]),
                               hc_ff_perpendicular_rectangles(v[i], v[j], v[k]),
                               hc_ff_coaxial_disks(v[i], v[j], v[k]),
                               hc_ff_element_parallel_rectangle(v[i], v[j], v[k])};
                for (int m = 0; m < 4; m++) bad += !(f[m] >= 0.0 && f[m] <= 1.0);
            }
    CHECK(bad == 0);
}

TEST(superposition_element_rectangle)
{
    /* An element under an interior point of a rectangle sees the sum of the
     * four corner rectangles (B-3 each); the contour integral over the whole
     * rectangle is an independent computation.  Rounding only: 1e-12. */
    double c = 0.8, x0 = -0.7, x1 = 1.9, y0 = -1.2, y1 = 0.4;
    double sum = hc_ff_element_parallel_rectangle(-x0, -y0, c) + hc_ff_element_parallel_rectangle(x1, -y0, c) +
                 hc_ff_element_parallel_rectangle(x1, y1, c) + hc_ff_element_parallel_rectangle(-x0, y1, c);
    rad_vec3 r[4];
    rect_z(r, x0, x1, y0, y1, c);
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), r, 4), sum, 1e-12);

    /* Centred: four equal quarters. */
    rect_z(r, -1.5, 1.5, -0.5, 0.5, c);
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), r, 4),
               4.0 * hc_ff_element_parallel_rectangle(1.5, 0.5, c), 1e-12);

    /* Foot outside the rectangle: a difference of two corner rectangles. */
    rect_z(r, 1.0, 3.0, 0.0, 2.0, c);
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), r, 4),
               hc_ff_element_parallel_rectangle(3.0, 2.0, c) - hc_ff_element_parallel_rectangle(1.0, 2.0, c),
               1e-12);
}

/* ------------------------------------------------- point to polygon */

TEST(point_polygon_corner_and_winding)
{
    rad_vec3 r[4], rev[4];
    rect_z(r, 0.0, 1.3, 0.0, 0.6, 0.9);
    for (int k = 0; k < 4; k++) rev[k] = r[3 - k];
    double ref = hc_ff_element_parallel_rectangle(1.3, 0.6, 0.9);
    /* Same quantity by the contour integral: rounding only, 1e-12. */
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), r, 4), ref, 1e-12);
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), rev, 4), ref, 1e-12);
    /* The length of n does not matter. */
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 7), r, 4), ref, 1e-12);

    /* A tiny square far away: F = B-3; the atan2 form keeps relative accuracy
     * (acos would lose everything below ~1e-8 rad).  1e-9 relative. */
    rect_z(r, 0.0, 1e-6, 0.0, 1e-6, 1.0);
    CHECK_REL(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), r, 4),
              hc_ff_element_parallel_rectangle(1e-6, 1e-6, 1.0), 1e-9);

    /* An element almost touching the centre of a square: F = 4·B-3 → 1. */
    rect_z(r, -0.5, 0.5, -0.5, 0.5, 1e-9);
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), r, 4),
               4.0 * hc_ff_element_parallel_rectangle(0.5, 0.5, 1e-9), 1e-12);

    /* Element in the polygon's plane, outside it: seen edge-on, F = 0 up to
     * the cancellation of O(1) terms (1e-14). */
    rect_z(r, 1.0, 2.0, -0.5, 0.5, 0.0);
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_normalize(rad_v3(1, 0.3, 0.2)), r, 4), 0.0, 1e-14);
}

TEST(point_polygon_disk)
{
    /* Element under the centre of a 1024-gon inscribed in a circle of radius
     * r at height h.  The polygon lies between the disks of radius r cos(π/N)
     * and r, so its F is bracketed by the exact disk values r²/(h²+r²) (and
     * the bracket is exact, up to rounding 1e-14).  Relative to the outer
     * disk the discretisation error is at most d ln F / d ln r · (1 − cos π/N)
     * = 2h²/(h²+r²) · 4.7e-6 <= 9.4e-6: tolerance 1e-5. */
    enum { N = 1024 };
    static rad_vec3 poly[N];
    double r = 0.75, h = 0.6;
    ngon(poly, N, r, h);
    double F = hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), poly, N);
    double ri = r * cos(M_PI / N);
    double outer = r * r / (h * h + r * r), inner = ri * ri / (h * h + ri * ri);
    CHECK(F <= outer + 1e-14 && F >= inner - 1e-14);
    CHECK_REL(F, outer, 1e-5);
}

TEST(point_polygon_clipping)
{
    rad_vec3 r[4];
    /* Entirely behind the element's plane: exactly 0. */
    rect_z(r, -1.0, 1.0, -1.0, 1.0, -0.5);
    CHECK(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), r, 4) == 0.0);

    /* A rectangle in the plane x = c, y ∈ [0, b], z ∈ [−1, a], straddling the
     * element's plane z = 0.  The part in front is the rectangle z ∈ [0, a]
     * perpendicular to the element with an edge in its plane and a corner
     * opposite it: catalog B-2,
     *   F = 1/(2π) [atan(b/c) − c/√(a²+c²) · atan(b/√(a²+c²))].
     * Rounding only: 1e-12. */
    double a = 0.8, b = 1.4, c = 0.6;
    r[0] = rad_v3(c, 0.0, -1.0);
    r[1] = rad_v3(c, b, -1.0);
    r[2] = rad_v3(c, b, a);
    r[3] = rad_v3(c, 0.0, a);
    double s = sqrt(a * a + c * c);
    double b2 = (atan(b / c) - c / s * atan(b / s)) / (2.0 * M_PI);
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), r, 4), b2, 1e-12);

    /* A non-convex U in the same plane x = c, its bar behind the element's
     * plane and its two arms (y ∈ [0,1] and [2,3], z up to a) in front: the
     * clipped contour runs back and forth along the horizon between the arms,
     * and those bridge edges must cancel.  By superposition of B-2 corner
     * rectangles F = B2(1) + B2(3) − B2(2); rounding only, 1e-12. */
    rad_vec3 u[8] = {rad_v3(c, 0, -1), rad_v3(c, 3, -1), rad_v3(c, 3, a),   rad_v3(c, 2, a),
                     rad_v3(c, 2, -0.5), rad_v3(c, 1, -0.5), rad_v3(c, 1, a), rad_v3(c, 0, a)};
    double u_ref = 0.0;
    for (int w = 1; w <= 3; w++)
        u_ref += (w == 2 ? -1.0 : 1.0) * (atan(w / c) - c / s * atan(w / s)) / (2.0 * M_PI);
    CHECK(u_ref > 0.01);
    CHECK_NEAR(hc_ff_point_polygon(rad_v3(0, 0, 0), rad_v3(0, 0, 1), u, 8), u_ref, 1e-12);

    /* A tilted triangle straddling the plane of a tilted element, against
     * brute-force quadrature of max(0, cosθ_i)|cosθ_j|/(π r²) over the whole
     * triangle (the clamp does the clipping).  Centroid rule on 1500² cells:
     * O(h²) error, measured 1.0e-7, 2.5e-8, 6.1e-9, 1.5e-9 at 375, 750, 1500,
     * 3000 cells a side; tolerance 1e-7. */
    rad_vec3 t[3] = {rad_v3(-0.4, 0.3, -0.7), rad_v3(1.1, -0.2, 0.9), rad_v3(0.2, 1.3, 0.6)};
    rad_vec3 p = rad_v3(0.1, -0.3, 0.05), n = rad_normalize(rad_v3(0.2, 0.1, 1.0));
    double Fc = hc_ff_point_polygon(p, n, t, 3);
    double Fb = brute_point_triangle(p, n, t, 1500);
    CHECK(Fc > 0.01); /* a real partial view */
    CHECK_NEAR(Fc, Fb, 1e-7);
}

/* ------------------------------------------------ polygon to polygon */

TEST(polygon_polygon_parallel)
{
    /* Smooth integrand, degree-5 rule: error O((1/s)^6), measured 1.3e-10 at
     * subdiv 8; the brief's bound 1e-7. */
    rad_vec3 a[4], b[4];
    rect_z(a, 0.0, 1.0, 0.0, 1.0, 0.0);
    rect_z(b, 0.0, 1.0, 0.0, 1.0, 1.0);
    CHECK_NEAR(hc_ff_polygon_polygon(a, 4, b, 4, 8), 0.19982490, 1e-7);
    CHECK_NEAR(hc_ff_polygon_polygon(a, 4, b, 4, 8), hc_ff_parallel_rectangles(1.0, 1.0, 1.0), 1e-7);
    /* Close, elongated plates: sub-triangles must be small against the gap
     * (0.3); measured 6e-7 at subdiv 8, 1e-8 at 16: 1e-7 at 16. */
    rect_z(a, 0.0, 2.0, 0.0, 0.5, 0.0);
    rect_z(b, 0.0, 2.0, 0.0, 0.5, 0.3);
    CHECK_NEAR(hc_ff_polygon_polygon(a, 4, b, 4, 16), hc_ff_parallel_rectangles(2.0, 0.5, 0.3), 1e-7);

    /* b behind a (a's normal is +z): nothing. */
    rect_z(b, 0.0, 1.0, 0.0, 1.0, -1.0);
    CHECK(hc_ff_polygon_polygon(a, 4, b, 4, 4) == 0.0);
}

TEST(polygon_polygon_perpendicular)
{
    /* Common edge along y ∈ [0, l]; a in z = 0, x ∈ [0, w1] (normal +z), b in
     * x = 0, z ∈ [0, w2].  F_{dA→b} has x·log x terms at the edge (x the
     * distance from it), which cuts the rule's order to O(1/s²): the error
     * must decrease with subdiv, and stay within 1e-4 at subdiv 16 (measured
     * 4.5e-6 for the unequal widths below; for equal unit squares the
     * symmetric leading errors cancel and it is 5e-13). */
    double l = 1.0, w1 = 1.0, w2 = 1.0;
    rad_vec3 a[4], b[4] = {rad_v3(0, 0, 0), rad_v3(0, l, 0), rad_v3(0, l, w2), rad_v3(0, 0, w2)};
    rect_z(a, 0.0, w1, 0.0, l, 0.0);
    double ref = hc_ff_perpendicular_rectangles(l, w1, w2);
    double e4 = fabs(hc_ff_polygon_polygon(a, 4, b, 4, 4) - ref);
    double e8 = fabs(hc_ff_polygon_polygon(a, 4, b, 4, 8) - ref);
    double e16 = fabs(hc_ff_polygon_polygon(a, 4, b, 4, 16) - ref);
    CHECK_NEAR(e16, 0.0, 1e-4);
    CHECK(e8 < e4 && e16 < e8);
    CHECK_NEAR(ref, 0.20004378, 1e-7);

    /* Unequal widths, both directions. */
    w1 = 0.4, w2 = 1.7, l = 1.1;
    rect_z(a, 0.0, w1, 0.0, l, 0.0);
    b[1] = rad_v3(0, l, 0), b[2] = rad_v3(0, l, w2), b[3] = rad_v3(0, 0, w2);
    CHECK_NEAR(hc_ff_polygon_polygon(a, 4, b, 4, 16), hc_ff_perpendicular_rectangles(l, w1, w2), 1e-4);
    /* b's Newell normal is +x, towards a, so F_ba needs no reordering; with
     * the winding reversed b faces away and a is clipped away entirely. */
    CHECK_NEAR(hc_ff_polygon_polygon(b, 4, a, 4, 16), hc_ff_perpendicular_rectangles(l, w2, w1), 1e-4);
    rad_vec3 bb[4] = {b[0], b[3], b[2], b[1]};
    CHECK(hc_ff_polygon_polygon(bb, 4, a, 4, 4) == 0.0);
}

TEST(polygon_polygon_disks)
{
    /* Coaxial 256-gons inscribed in circles r1, r2.  The exchange factor
     * A_a F_ab = (1/π)∫∫ cos cos / r² is monotone in both domains, so it lies
     * between the disks of radii r cos(π/N) and r (exact, plus the quadrature
     * error, 3e-9 at subdiv 4 on these long sliver fan triangles: margin 1e-8).
     * Relative to the outer disks' F the discretisation error is bounded by
     * the relative area deficits of the polygons, ≈ 2(1 − cos π/N) = 1.5e-4
     * each: tolerance 3e-4 (measured 3.9e-5). */
    enum { N = 256 };
    static rad_vec3 pa[N], pb[N];
    double r1 = 0.5, r2 = 0.9, h = 0.7;
    ngon(pa, N, r1, 0.0);
    ngon(pb, N, r2, h);
    double F = hc_ff_polygon_polygon(pa, N, pb, N, 4);
    double Aa = 0.5 * N * r1 * r1 * sin(2.0 * M_PI / N);
    double cs = cos(M_PI / N);
    double outer = M_PI * r1 * r1 * hc_ff_coaxial_disks(r1, r2, h);
    double inner = M_PI * r1 * r1 * cs * cs * hc_ff_coaxial_disks(r1 * cs, r2 * cs, h);
    CHECK(Aa * F <= outer + 1e-8 && Aa * F >= inner - 1e-8);
    CHECK_REL(F, hc_ff_coaxial_disks(r1, r2, h), 3e-4);
}

TEST(polygon_polygon_nonconvex)
{
    /* An L-shaped a whose fan starts at a vertex from which it is not star
     * shaped: some fan triangles lie partly outside a and are cancelled by
     * negative ones.  By superposition F_ab A_a = Σ over its two rectangles.
     * Each term converges to ~1e-10 at subdiv 8: tolerance 1e-8. */
    rad_vec3 L[6] = {rad_v3(2, 1, 0), rad_v3(1, 1, 0), rad_v3(1, 2, 0),
                     rad_v3(0, 2, 0), rad_v3(0, 0, 0), rad_v3(2, 0, 0)};
    rad_vec3 r1[4], r2[4], b[4];
    rect_z(r1, 0.0, 2.0, 0.0, 1.0, 0.0);
    rect_z(r2, 0.0, 1.0, 1.0, 2.0, 0.0);
    rect_z(b, 0.5, 1.7, 0.3, 1.6, 0.8);
    double whole = 3.0 * hc_ff_polygon_polygon(L, 6, b, 4, 8);
    double parts = 2.0 * hc_ff_polygon_polygon(r1, 4, b, 4, 8) + 1.0 * hc_ff_polygon_polygon(r2, 4, b, 4, 8);
    CHECK(parts > 0.1);
    CHECK_NEAR(whole, parts, 1e-8);
}

TEST(polygon_polygon_brute_force)
{
    /* Two skewed triangles facing each other, each wholly in front of the
     * other (so no clipping is involved).  Reference: the double-area
     * centroid rule on 160² × 160² sub-triangle pairs, independent of the
     * contour integral; its O(h²) error is measured 1.3e-4, 3.3e-5, 8.1e-6
     * relative at 40, 80, 160 cells a side, so 1e-3 is a safe bound.
     * Reciprocity A_a F_ab = A_b F_ba holds to the quadrature error of
     * subdiv 16 (measured 2.5e-12; tolerance 1e-9). */
    rad_vec3 a[3] = {rad_v3(0.0, 0.0, 0.0), rad_v3(1.2, 0.1, 0.05), rad_v3(0.3, 0.9, 0.2)};
    rad_vec3 b[3] = {rad_v3(0.2, 0.1, 0.9), rad_v3(0.4, 1.1, 1.3), rad_v3(1.3, 0.2, 0.7)};
    rad_vec3 na = tri_normal(a), nb = tri_normal(b);
    for (int k = 0; k < 3; k++) {
        CHECK(rad_dot(na, rad_sub(b[k], a[0])) > 0.0);
        CHECK(rad_dot(nb, rad_sub(a[k], b[0])) > 0.0);
    }
    double Fab = hc_ff_polygon_polygon(a, 3, b, 3, 16);
    double Fba = hc_ff_polygon_polygon(b, 3, a, 3, 16);
    double ref = brute_triangle_triangle(a, b, 160);
    CHECK(Fab > 0.05);
    CHECK_REL(Fab, ref, 1e-3);
    CHECK_NEAR(tri_area(a) * Fab, tri_area(b) * Fba, 1e-9);
}

TEST(bad_arguments)
{
    CHECK(isnan(hc_ff_parallel_rectangles(0.0, 1.0, 1.0)));
    CHECK(isnan(hc_ff_parallel_rectangles(1.0, -1.0, 1.0)));
    CHECK(isnan(hc_ff_parallel_rectangles(1.0, 1.0, 0.0)));
    CHECK(isnan(hc_ff_parallel_rectangles(1.0, NAN, 1.0)));
    CHECK(isnan(hc_ff_perpendicular_rectangles(0.0, 1.0, 1.0)));
    CHECK(isnan(hc_ff_perpendicular_rectangles(1.0, INFINITY, 1.0)));
    CHECK(isnan(hc_ff_coaxial_disks(1.0, 0.0, 1.0)));
    CHECK(isnan(hc_ff_coaxial_disks(1.0, 1.0, -2.0)));
    CHECK(isnan(hc_ff_element_parallel_rectangle(1.0, 1.0, 0.0)));

    rad_vec3 r[4];
    rect_z(r, 0.0, 1.0, 0.0, 1.0, 1.0);
    rad_vec3 o = rad_v3(0, 0, 0), up = rad_v3(0, 0, 1);
    CHECK(hc_ff_point_polygon(o, up, r, 2) == 0.0);
    CHECK(hc_ff_point_polygon(o, up, NULL, 4) == 0.0);
    CHECK(isnan(hc_ff_point_polygon(o, rad_v3(0, 0, 0), r, 4)));
    CHECK(isnan(hc_ff_point_polygon(rad_v3(NAN, 0, 0), up, r, 4)));
    rad_vec3 bad[4] = {r[0], r[1], rad_v3(INFINITY, 0, 1), r[3]};
    CHECK(isnan(hc_ff_point_polygon(o, up, bad, 4)));

    rad_vec3 a[4];
    rect_z(a, 0.0, 1.0, 0.0, 1.0, 0.0);
    CHECK(hc_ff_polygon_polygon(a, 2, r, 4, 4) == 0.0);
    CHECK(hc_ff_polygon_polygon(a, 4, r, 1, 4) == 0.0);
    CHECK(hc_ff_polygon_polygon(NULL, 4, r, 4, 4) == 0.0);
    rad_vec3 flat[3] = {rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(2, 0, 0)}; /* no area */
    CHECK(hc_ff_polygon_polygon(flat, 3, r, 4, 4) == 0.0);
    CHECK(isnan(hc_ff_polygon_polygon(a, 4, bad, 4, 4)));
    /* subdiv 0 is taken as 1: a valid (if coarse, error ~4e-5) estimate. */
    CHECK_NEAR(hc_ff_polygon_polygon(a, 4, r, 4, 0), hc_ff_parallel_rectangles(1.0, 1.0, 1.0), 1e-4);
}

int main(void)
{
    RUN(catalog_values);
    RUN(reciprocity);
    RUN(limits);
    RUN(superposition_element_rectangle);
    RUN(point_polygon_corner_and_winding);
    RUN(point_polygon_disk);
    RUN(point_polygon_clipping);
    RUN(polygon_polygon_parallel);
    RUN(polygon_polygon_perpendicular);
    RUN(polygon_polygon_disks);
    RUN(polygon_polygon_nonconvex);
    RUN(polygon_polygon_brute_force);
    RUN(bad_arguments);
    return test_finish("test_analytic");
}
