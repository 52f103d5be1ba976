/* analytic.c - form factors in closed form and by contour integral.
 *
 * Owns the "Analytic form factors" of hemicube.h: the catalog closed forms
 * (Howell C-11, C-14, C-41, B-3), Lambert's contour integral from a
 * differential element to a polygon, and its area average from polygon to
 * polygon.  Pure math: no GL, no allocation, no state, no occlusion; the
 * bottom of the folder's order (patch_factors.c calls it, it calls nothing
 * of hemicube/).
 *
 * Invariant: every function returns F in [0, 1], or NAN for non-positive or
 * non-finite sizes and coordinates; polygons with fewer than 3 vertices (or
 * no area) see nothing and give 0.  The catalog formulas are rewritten where
 * their textbook form cancels catastrophically (surfaces far apart, or nearly
 * touching), so they stay accurate to a few ulps over the whole range and
 * serve as references for the hemi-cube.
 */
#include "hemicube.h"

#include <math.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static int positive_finite(double x) { return isfinite(x) && x > 0.0; }

/* Catalog ratios (size / distance) are limited to [1e-60, 1e60] so that
 * their squares and products of squares neither overflow nor underflow.
 * Every closed form here tends to its limit as O(ratio) or O(1/ratio), so
 * the limiting changes F by about 1e-60 absolute: nothing a double sum of
 * form factors can see, and no NaN for absurd but legal proportions. */
static double limit_ratio(double r)
{
    if (!(r >= 1e-60)) return 1e-60;
    if (r > 1e60) return 1e60;
    return r;
}

/* Round-off may push a value an ulp outside [0, 1]; NaN passes through. */
static double clamp_unit(double f)
{
    if (f < 0.0) return 0.0;
    if (f > 1.0) return 1.0;
    return f;
}

/* ------------------------------------------------------------ closed forms */

/* s·atan(x/s) − atan(x) with s = sqrt(1 + y²) and d = s − 1 supplied
 * accurately by the caller.  Written as d·atan(x/s) − [atan(x) − atan(x/s)]
 * with the difference of arctangents folded into one arctangent, the two
 * remaining terms only cancel in their third-order part, so the result keeps
 * full relative accuracy when the rectangles are far apart (x, y → 0). */
static double rect_edge_term(double x, double s, double d)
{
    return d * atan(x / s) - atan(d / (s / x + x));
}

/* Howell C-11, with X = a/c, Y = b/c:
 *   F = 2/(πXY) { ln sqrt[(1+X²)(1+Y²)/(1+X²+Y²)]
 *                 + X sqrt(1+Y²) atan(X/sqrt(1+Y²)) − X atan X
 *                 + Y sqrt(1+X²) atan(Y/sqrt(1+X²)) − Y atan Y }.
 * The logarithm's argument is 1 + X²Y²/(1+X²+Y²), hence log1p; each pair of
 * arctangent terms goes through rect_edge_term.  Far apart, F ≈ ab/(πc²)
 * comes entirely from the logarithm and the arctangent pairs are of higher
 * order, which the textbook form would lose to cancellation. */
double hc_ff_parallel_rectangles(double a, double b, double c)
{
    if (!positive_finite(a) || !positive_finite(b) || !positive_finite(c)) return NAN;
    double X = limit_ratio(a / c), Y = limit_ratio(b / c);
    double sx = hypot(1.0, X), sy = hypot(1.0, Y);
    double dx = X * (X / (sx + 1.0)), dy = Y * (Y / (sy + 1.0)); /* s − 1 = X²/(s + 1) */
    double t = (X / hypot(sx, Y)) * Y;                           /* t² = X²Y²/(1+X²+Y²) */
    double L = t < 1e150 ? log1p(t * t) : 2.0 * log(t);
    double bracket = 0.5 * L / X / Y + rect_edge_term(X, sy, dy) / Y + rect_edge_term(Y, sx, dx) / X;
    return clamp_unit(2.0 / M_PI * bracket);
}

/* ln[w²(1+w²+h²) / ((1+w²)(w²+h²))], one of the two powered factors of C-14.
 * The argument equals 1 − h²/((1+w²)(w²+h²)): log1p when that is near 1,
 * otherwise the product form, which stays finite as w → 0. */
static double perp_log_factor(double w, double h)
{
    double w2 = w * w, h2 = h * h, r2 = w2 + h2;
    double u = h2 / ((1.0 + w2) * r2);
    if (u < 0.5) return log1p(-u);
    return 2.0 * log(w / hypot(w, h)) + log1p(h2 / (1.0 + w2));
}

/* Howell C-14, from rectangle 1 (l × w1) to rectangle 2 (l × w2) meeting it at
 * 90° along the common edge l, with W = w1/l, H = w2/l:
 *   F = 1/(πW) { W atan(1/W) + H atan(1/H) − sqrt(H²+W²) atan(1/sqrt(H²+W²))
 *               + ¼ ln( A · B^{W²} · C^{H²} ) }
 *   A = (1+W²)(1+H²)/(1+W²+H²), B = W²(1+W²+H²)/((1+W²)(W²+H²)), C likewise
 *   with W and H exchanged.
 * The braces are evaluated symmetrically in (W, H) so that reciprocity
 * A_1 F_12 = A_2 F_21 holds to rounding. */
double hc_ff_perpendicular_rectangles(double edge, double w1, double w2)
{
    if (!positive_finite(edge) || !positive_finite(w1) || !positive_finite(w2)) return NAN;
    double W = limit_ratio(w1 / edge), H = limit_ratio(w2 / edge);
    double W2 = W * W, H2 = H * H, R = hypot(W, H);
    /* x atan(1/x) for the smaller of W, H, minus the difference between the
     * larger one (M) and R: R atan(1/R) − M atan(1/M) = δ atan(1/R) −
     * M atan(δ/(MR + 1)) with δ = R − M = m²/(R + M).  Taken directly, that
     * difference is O(m²) out of O(1) terms and would swamp F as m → 0 (a
     * thin strip along the common edge); by min/max the expression stays
     * symmetric in (W, H). */
    double m = fmin(W, H), M = fmax(W, H);
    double delta = m * (m / (R + M));
    double angles = m * atan(1.0 / m) - (delta * atan(1.0 / R) - M * atan(delta / (M * R + 1.0)));
    double lnA = log1p(W2 * H2 / (1.0 + (W2 + H2)));
    double logs = lnA + (W2 * perp_log_factor(W, H) + H2 * perp_log_factor(H, W));
    double braces = angles + 0.25 * logs;
    return clamp_unit(braces / (M_PI * W));
}

/* Howell C-41, with R1 = r1/h, R2 = r2/h, X = 1 + (1+R2²)/R1²:
 *   F = ½ { X − sqrt(X² − 4(R2/R1)²) }.
 * Rationalised and multiplied through by r1² this is
 *   F = 2 r2² / ( h²+r1²+r2² + sqrt[(h²+(r1−r2)²)(h²+(r1+r2)²)] ),
 * a sum of positive terms (no cancellation, no division by r1 or h), which
 * is also symmetric enough that r1² F_12 = r2² F_21 to rounding.  Lengths are
 * scaled by the largest so the squares cannot overflow. */
double hc_ff_coaxial_disks(double r1, double r2, double h)
{
    if (!positive_finite(r1) || !positive_finite(r2) || !positive_finite(h)) return NAN;
    double m = fmax(fmax(r1, r2), h);
    double a = r1 / m, b = r2 / m, c = h / m;
    double c2 = c * c, dm = a - b, dp = a + b;
    double root = sqrt((c2 + dm * dm) * (c2 + dp * dp));
    return clamp_unit(2.0 * b * b / ((c2 + (a * a + b * b)) + root));
}

/* Howell B-3, element on the normal through a corner of an a × b rectangle at
 * distance c, with X = a/c, Y = b/c:
 *   F = 1/(2π) { X/sqrt(1+X²) atan(Y/sqrt(1+X²)) + Y/sqrt(1+Y²) atan(X/sqrt(1+Y²)) }.
 * Both terms are positive: no cancellation anywhere. */
double hc_ff_element_parallel_rectangle(double a, double b, double c)
{
    if (!positive_finite(a) || !positive_finite(b) || !positive_finite(c)) return NAN;
    double X = limit_ratio(a / c), Y = limit_ratio(b / c);
    double sx = hypot(1.0, X), sy = hypot(1.0, Y);
    return clamp_unit((X / sx * atan(Y / sx) + Y / sy * atan(X / sy)) / (2.0 * M_PI));
}

/* The corner term of the general parallel-rectangle integral, for the
 * offsets x = x_i − u_k, y = y_j − v_l between a corner of each rectangle
 * and the gap c:
 *   G = y s_x atan(y / s_x) + x s_y atan(x / s_y) − (c²/2) ln(x² + y² + c²),
 *   s_x = sqrt(x² + c²), s_y = sqrt(y² + c²)
 * (the double integral of the kernel c² / (π r⁴) over both rectangles,
 * twice differentiated; its mixed 4th difference over the 16 corner pairs
 * gives π A_1 F_12). */
static double corner_term(double x, double y, double c)
{
    double sx = hypot(x, c), sy = hypot(y, c);
    return y * sx * atan(y / sx) + x * sy * atan(x / sy) - 0.5 * c * c * log(x * x + y * y + c * c);
}

double hc_ff_parallel_offset(double x0, double x1, double y0, double y1, double u0, double u1,
                             double v0, double v1, double c)
{
    const double xs[2] = {x0, x1}, ys[2] = {y0, y1}, us[2] = {u0, u1}, vs[2] = {v0, v1};
    for (int k = 0; k < 2; k++)
        if (!isfinite(xs[k]) || !isfinite(ys[k]) || !isfinite(us[k]) || !isfinite(vs[k]))
            return NAN;
    if (!(x1 > x0) || !(y1 > y0) || !(u1 > u0) || !(v1 > v0) || !positive_finite(c))
        return NAN;
    double sum = 0.0;
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++)
            for (int k = 0; k < 2; k++)
                for (int l = 0; l < 2; l++) {
                    /* sign (−1)^(i+j+k+l): the mixed difference in all four
                     * coordinates */
                    double g = corner_term(xs[i] - us[k], ys[j] - vs[l], c);
                    sum += (i + j + k + l) % 2 ? -g : g;
                }
    return clamp_unit(sum / (2.0 * M_PI * (x1 - x0) * (y1 - y0)));
}

/* ------------------------------------------------- Lambert's contour integral */

/* The contour integral lives in the core (rad.h), where the gather renderer
 * reads it too. */
double hc_ff_point_polygon(rad_vec3 p, rad_vec3 n, const rad_vec3 *poly, uint32_t count)
{
    return rad_point_polygon_factor(p, n, poly, count);
}

/* ------------------------------------------------- polygon to polygon */

/* Symmetric 7-point rule of degree 5 on a triangle (Radon): the centroid and
 * two orbits of three points (α, α, 1−2α).  With q = sqrt(15):
 *   α₁ = (6 − q)/21, w₁ = (155 − q)/1200;  α₂ = (6 + q)/21, w₂ = (155 + q)/1200;
 *   centroid weight 9/40.  Weights sum to 1 (they multiply the area). */
typedef struct tri_rule {
    double a1, b1, w1, a2, b2, w2, w0;
} tri_rule;

static tri_rule make_tri_rule(void)
{
    double q = sqrt(15.0);
    tri_rule r;
    r.a1 = (6.0 - q) / 21.0;
    r.b1 = 1.0 - 2.0 * r.a1;
    r.w1 = (155.0 - q) / 1200.0;
    r.a2 = (6.0 + q) / 21.0;
    r.b2 = 1.0 - 2.0 * r.a2;
    r.w2 = (155.0 + q) / 1200.0;
    r.w0 = 9.0 / 40.0;
    return r;
}

typedef struct pp_ctx {
    rad_vec3 origin, e1, e2; /* the fan triangle: origin + u e1 + v e2 */
    rad_vec3 n;              /* unit normal of polygon a */
    const rad_vec3 *b;       /* the target: polygon b[0..nb), */
    uint32_t nb;
    const double *edges;     /* or, when b is NULL, directed edges (hc_ff_polygon_edges) */
} pp_ctx;

/* F_{dA→b} at parameter (u, v) of the current fan triangle. */
static double pp_point(const pp_ctx *c, double u, double v)
{
    rad_vec3 x = rad_add(c->origin, rad_add(rad_scale(c->e1, u), rad_scale(c->e2, v)));
    return c->b ? hc_ff_point_polygon(x, c->n, c->b, c->nb)
                : rad_point_edges_factor(x, c->n, c->edges, c->nb);
}

/* Mean of F_{dA→b} over the sub-triangle with parameter corners
 * (u0,v0), (u1,v1), (u2,v2), by the 7-point rule. */
static double pp_subtriangle(const pp_ctx *c, const tri_rule *r, double u0, double v0, double u1,
                             double v1, double u2, double v2)
{
#define PP_AT(l0, l1, l2) pp_point(c, (l0) * u0 + (l1) * u1 + (l2) * u2, (l0) * v0 + (l1) * v1 + (l2) * v2)
    double third = 1.0 / 3.0;
    double f = r->w0 * PP_AT(third, third, third);
    f += r->w1 * (PP_AT(r->b1, r->a1, r->a1) + PP_AT(r->a1, r->b1, r->a1) + PP_AT(r->a1, r->a1, r->b1));
    f += r->w2 * (PP_AT(r->b2, r->a2, r->a2) + PP_AT(r->a2, r->b2, r->a2) + PP_AT(r->a2, r->a2, r->b2));
#undef PP_AT
    return f;
}

/* Largest subdivision honoured: 1024² sub-triangles × 7 points per fan
 * triangle is already far past the accuracy doubles can show. */
#define PP_MAX_SUBDIV 1024u

/* F_ab = (1/A_a) ∫_a F_{dA→b} dA.  Polygon a is cut into a fan of triangles
 * from its first vertex; each fan triangle's integral is weighted by its
 * area signed against a's Newell normal, so a non-convex (but simple, planar)
 * a is integrated correctly: the parts of the fan outside a cancel.  Each fan
 * triangle is split into subdiv² congruent sub-triangles (a barycentric grid
 * of "up" and "down" cells), each integrated with the 7-point rule.  The
 * element normal is a's Newell normal, so b behind a (as a's winding says)
 * is clipped away.  subdiv 0 is taken as 1, values above 1024 as 1024. */
static double polygon_to_target(const rad_vec3 *a, uint32_t na, pp_ctx c, uint32_t subdiv);

double hc_ff_polygon_polygon(const rad_vec3 *a, uint32_t na, const rad_vec3 *b, uint32_t nb,
                             uint32_t subdiv)
{
    if (a == NULL || b == NULL || na < 3 || nb < 3) return 0.0;
    for (uint32_t k = 0; k < nb; k++)
        if (!rad_finite3(b[k])) return NAN;
    return polygon_to_target(a, na, (pp_ctx){.b = b, .nb = nb}, subdiv);
}

double hc_ff_polygon_edges(const rad_vec3 *a, uint32_t na, const double *edges, uint32_t ne,
                           uint32_t subdiv)
{
    if (a == NULL || edges == NULL || na < 3 || ne < 3) return 0.0;
    for (size_t k = 0; k < 6 * (size_t)ne; k++)
        if (!isfinite(edges[k])) return NAN;
    return polygon_to_target(a, na, (pp_ctx){.edges = edges, .nb = ne}, subdiv);
}

/* The integral over a of F_{dA→target}, the target (b or edges) in c. */
static double polygon_to_target(const rad_vec3 *a, uint32_t na, pp_ctx c, uint32_t subdiv)
{
    for (uint32_t k = 0; k < na; k++)
        if (!rad_finite3(a[k])) return NAN;
    uint32_t s = subdiv < 1 ? 1 : (subdiv > PP_MAX_SUBDIV ? PP_MAX_SUBDIV : subdiv);

    /* Newell normal, from vertices taken relative to a[0] so that polygons
     * far from the origin keep their digits; its length is 2 A_a. */
    rad_vec3 N = rad_v3(0.0, 0.0, 0.0);
    for (uint32_t k = 1; k + 1 < na; k++)
        N = rad_add(N, rad_cross(rad_sub(a[k], a[0]), rad_sub(a[k + 1], a[0])));
    double len = rad_length(N);
    if (!(len > 0.0) || !isfinite(len)) return 0.0; /* no area: nothing leaves a */
    double area2 = len; /* 2 A_a */

    tri_rule rule = make_tri_rule();
    c.origin = a[0];
    c.n = rad_scale(N, 1.0 / len);
    double inv_s = 1.0 / (double)s;
    double total = 0.0; /* Σ 2A_T · mean over T of F_{dA→b} */
    for (uint32_t k = 1; k + 1 < na; k++) {
        c.e1 = rad_sub(a[k], a[0]);
        c.e2 = rad_sub(a[k + 1], a[0]);
        double tri2 = rad_dot(rad_cross(c.e1, c.e2), c.n); /* signed 2 A_T */
        if (tri2 == 0.0) continue;
        double sum = 0.0; /* Σ over the s² sub-triangles of their means */
        for (uint32_t i = 0; i < s; i++) {
            for (uint32_t j = 0; i + j < s; j++) {
                double u0 = i * inv_s, v0 = j * inv_s;
                double u1 = (i + 1) * inv_s, v1 = (j + 1) * inv_s;
                sum += pp_subtriangle(&c, &rule, u0, v0, u1, v0, u0, v1);
                if (i + j + 1 < s) sum += pp_subtriangle(&c, &rule, u1, v0, u1, v1, u0, v1);
            }
        }
        total += tri2 * (sum * inv_s * inv_s);
    }
    return clamp_unit(total / area2);
}
