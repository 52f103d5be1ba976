/* rows.c - one hemi-cube row F_ij, computed in a worker.
 *
 * Owns the five faces of a cube at c_i (culling, drawing through gl.c,
 * accumulation into F_ij with the delta form factors of delta_factors.c),
 * the exact entries to emitters and near patches (their unoccluded
 * integrals from patch_factors.c), their focused visibility views and
 * probes.
 *
 * Invariants of every row: j strictly increasing, j != i, F_ij > 0, no j
 * lying wholly on or behind i's plane, and Σ_j F_ij <= 1 because the delta
 * form factors ΔF_q are normalised to sum to exactly 1 over the cube (and
 * rows with exact entries are renormalised).  A row depends only on the
 * mesh, R, the exact options and i (fixed basis, fixed draw order, fixed
 * accumulation order), so it is bit-identical whichever worker computes it
 * and however the rows are split.
 *
 * Item-buffer atlas, R wide and 3R tall, GL's bottom-up rows, pixel q at
 * index y·R + x: rows [0, R) are the top face (looking along n_i); then the
 * four half faces (+u, -u, +v, -v), R/2 rows each, their bottom row at the
 * horizon and their top row towards n_i.  hc_delta_form_factors
 * (delta_factors.c) uses the same order.
 *
 * Exact entries (hc_options.exact, .exact_near).  For a candidate j of row
 * i the pixel sum S_ij (ΔF over the pixels showing j) is replaced by
 *   F_ij = F_exact · v_ij,   v_ij = S_ij / S°_ij,
 * where F_exact is hc_ff_point_polygon from (c_i, n_i) to j, or for a j
 * nearer to c_i than its own diameter (exact_near; marked or not) the area
 * average hc_ff_polygon_polygon from i to j: near a patch, the point c_i is
 * what is wrong with the hemi-cube, not the pixel count.  S°_ij is the same
 * sum in a second rendering of only the candidates with the depth test off
 * and GL_OR logic: candidate j writes bit (j mod 32), so a pixel lists every
 * candidate covering it and S°_ij is j's whole unoccluded projection even
 * where candidates overlap (more than one pass when 32 residues do not
 * suffice).  Both sums cover the same rasterisation, so an unoccluded j gets
 * v_ij = 1 exactly.  A candidate with no pixel (sub-pixel, or wholly hidden)
 * is probed instead: v_ij is 1 or 0 as c_j is visible or hidden at the one
 * pixel holding the direction to it (probe_visible).  A far candidate's
 * v_ij is then measured again in a focused view (focused_visibility): an
 * R×R item buffer aimed at its polygon's candidates, which fill it, so a
 * shadow's edge moves v_ij in steps of about 1/R of the source's width
 * rather than one hemi-cube pixel (a twelfth to a fifteenth of the
 * Cornell light at R = 128).  Only candidates small on the hemi-cube get
 * one, at most HC_FOCUS_VIEWS a row, and the view is rendered only when
 * some patch inside it lies between c_i and the source, else v_ij = 1.
 * With far exact entries only, the pixel entries are then rescaled so that
 * the row keeps the cube's own total Σ_j F_ij (1 in a closed room): exact
 * entries redistribute the row and never open a closed room; with near
 * entries the row is only kept from exceeding 1 (renormalise), unless the
 * cube saw every pixel covered, when it keeps 1.
 *
 * Candidates are the marked patches (emitters), with exact_near the near
 * ones, and the patches of any far polygon too small on the cube for its
 * pixels to be counted (small_polygon: fewer than HC_SMALL_PIXELS); with
 * hc_options.weak (issue 39) also far polygons too thin on the cube, the
 * patches within weak_near diameters of i where i's centre samples them
 * poorly (sampling_weak; area-averaged), and a closed
 * row's deficit goes to the entries nearest i (spread_deficit).  An
 * emitter's entry in a patch row is averaged over the patch
 * (hc_ff_polygon_polygon) rather than taken at its centre: its column then
 * sums to the emitter's area, which a closed room's energy balance needs.
 */
#include "hc_internal.h"

#include <string.h>

/* A candidate shows nothing nearer than this relative depth margin: a
 * coplanar neighbour (a light flush with its ceiling) never hides it. */
#define HC_PROBE_MARGIN 1e-4
/* Focused views (focused_visibility) are for candidates covering fewer
 * hemi-cube pixels than this (1/16 of the view: a quarter of its width),
 * and a candidate covering fewer of its polygon's view gets one of its own. */
#define HC_FOCUS_PIXELS(R) ((R) * (R) / 16u)
#define HC_FOCUS_VIEWS 8u  /* focused views a row may render at most */
/* A far polygon estimated to cover fewer hemi-cube pixels than this is too
 * small for its pixels to be counted: its patches get exact entries, all of
 * a polygon's or none, at most HC_SMALL_MAX a row (held-out cases of
 * surfaces 20 times their size away were 6-12 % off by pixel counts,
 * covering about ten pixels). */
#define HC_SMALL_PIXELS 64.0
#define HC_SMALL_MAX 1024u

/* Most cells a patch may have on either side of an exact entry, which
 * costs a polygon pair per cell pair (7 points per cell of i, an atan2 per
 * outline edge of j at each).  A planar region's patch has a few cells
 * (its pieces are joined, mesh/region.c); a curved patch of narrow facets
 * (mesh/smooth.c: the atrium's columns, 40 cells a patch, and vaults, 21)
 * has dozens, and at 64 the atrium's exact entries were 62 % of its
 * form-factor CPU (perf: atan2, contour_edge, rad_point_polygon_factor);
 * at 16 its form factors take 49 s instead of 117 s (report/atrium.md
 * §7h), such patches keep their pixel counts.  A shared patch of small
 * parts (mesh/parts.c, e->shared) keeps its pixels whatever its cells:
 * its row is one point's for parts spread over a grid cube, so an exact
 * average buys nothing. */
#define HC_EXACT_MAX_CELLS 16u
/* Where the hemi-cube is weak (hc_options.weak, docs/limits.md), by
 * HC_WEAK_OFF, _ON, _HIGH, _SURFACE: a far polygon narrower on the cube than
 * weak_thin pixels is thin (a pixel count's error goes as its boundary
 * over its area, one pixel over its width: a 10:1 strip 20 widths away, 3
 * pixels wide at R = 128, was 6.4 % low; the ceiling of a 1 × 2 × 3 box,
 * 21 pixels wide from the floor, 2.8 % high where the floor's patch
 * centres fell in step with the pixel grid), and with exact_near a patch j
 * whose centre is within weak_near diameters of patch i's centre, where
 * sampling_weak says so, gets the area average over i (near a surface, F_{dA→j} varies across i on the
 * scale of the gap, so i's centre is what is wrong: squares 0.05 apart
 * were 3.8 % low, plates meeting at an edge 1.5-2.5 %). */
static const double weak_thin[4] = {0.0, 8.0, 64.0, 32.0};
static const double weak_near[4] = {0.0, 2.0, 20.0, 2.0};
/* At the defaults the thin rule takes only polygons facing the eye (cos
 * θ_j at least weak_cos) and narrower than 8 pixels, and the near rule
 * only facing planes closer than i's diameter (sampling_weak): broader
 * (32 pixels at any angle, every patch within 2 diameters) the glTF Cornell
 * box's solve took 2.8 times the CPU and its worst region (the tall
 * block's front) went from 0.95 % to 1.24 % of the path-traced reference
 * (report/factors.md); the accurate setting keeps the broad rules, and so
 * do rows for surface-to-surface factors (HC_WEAK_SURFACE: F_AB is an
 * area average over A by definition, where a solve's row is a collocation
 * row at c_i; docs/limits.md). */
static const double weak_cos[4] = {0.0, 0.5, 0.0, 0.0};
/* ... and a thin or small polygon's patch within weak_area diameters of
 * i's centre gets the area average over i too, not the factor at c_i (2×1
 * plates side by side, 0.5 apart: -1.3 % at the centres). */
static const double weak_area[4] = {0.0, 10.0, 30.0, 10.0};

/* ------------------------------------------------------------------ faces */

/* A candidate for an exact entry in the current row. */
struct hc_cand {
    uint32_t j;
    uint32_t pass;     /* OR pass that measures S°_ij: earlier candidates with j's residue */
    double occ;        /* S_ij: ΔF of the pixels showing j in the occluded item buffer */
    double free;       /* S°_ij: the same with only the candidates drawn;
                        * for a candidate without pixels, the probe's 1 or 0 */
    double exact;      /* F_exact */
    double vis;        /* v_ij */
    uint32_t px;       /* pixels of S°_ij */
    uint8_t focus;     /* 1: its focused view is still to be measured */
    uint8_t faces;     /* bit f: drawn on hemi-cube face f */
    uint8_t near;      /* 1: nearer to c_i than its own diameter; 2: within
                        * weak_near diameters of i (hc_options.weak) */
    uint8_t area;      /* F_exact averaged over patch i (an emitter seen from a patch row) */
};

int hc_rows_init(const hc_engine *e, hc_work *wk, char *msg)
{
    uint32_t n = e->n;
    if (!e->any_exact)
        return 0;
    int ok = (wk->cand = hc_alloc(n, sizeof *wk->cand, msg)) &&
             (wk->order = hc_alloc(n, sizeof *wk->order, msg)) &&
             (wk->mark = hc_alloc(n, sizeof *wk->mark, msg)) &&
             (wk->fslot = hc_alloc((size_t)2 * n, sizeof *wk->fslot, msg)) &&
             (wk->fsum = hc_alloc((size_t)3 * n, sizeof *wk->fsum, msg)) &&
             (wk->preach = hc_alloc((size_t)e->npoly + 1, sizeof *wk->preach, msg));
    if (!ok)
        return -1;
    for (uint32_t j = 0; j < n; j++) {
        const uint32_t q = e->mesh->patches[j].polygon;
        for (uint32_t cell = e->cfirst[j]; cell < e->cfirst[j + 1]; cell++) {
            rad_vec3 p[4];
            hc_load_corners(e, cell, p);
            for (int k = 0; k < 4; k++)
                wk->preach[q] = fmax(wk->preach[q], rad_length(rad_sub(p[k], e->poly_center[q])));
        }
    }
    return 0;
}

/* Frustum planes through the eye, as bits of a mask; a patch is skipped for
 * a face when every corner lies outside one of the face's four planes.  With
 * a = p·u, b = p·v, h = p·n (p relative to the eye):  */
enum {
    PL_H_MA = 1 << 0,  /* h - a */
    PL_H_PA = 1 << 1,  /* h + a */
    PL_H_MB = 1 << 2,  /* h - b */
    PL_H_PB = 1 << 3,  /* h + b */
    PL_A_MB = 1 << 4,  /* a - b */
    PL_A_PB = 1 << 5,  /* a + b */
    PL_NA_MB = 1 << 6, /* -a - b */
    PL_B_MA = 1 << 7,  /* b - a */
    PL_H = 1 << 8,     /* h: above the horizon */
    PL_A_MH = 1 << 9,  /* a - h */
    PL_NA_MH = 1 << 10,/* -a - h */
    PL_B_MH = 1 << 11, /* b - h */
    PL_NB_MH = 1 << 12 /* -b - h */
};
static const unsigned face_planes[5] = {
    PL_H_MA | PL_H_PA | PL_H_MB | PL_H_PB, /* top: |a| <= h, |b| <= h */
    PL_A_MB | PL_A_PB | PL_H | PL_A_MH,    /* +u: |b| <= a, 0 <= h <= a */
    PL_NA_MB | PL_B_MA | PL_H | PL_NA_MH,  /* -u: |b| <= -a, 0 <= h <= -a */
    PL_B_MA | PL_A_PB | PL_H | PL_B_MH,    /* +v: |a| <= b, 0 <= h <= b */
    PL_NA_MB | PL_A_MB | PL_H | PL_NB_MH,  /* -v: |a| <= -b, 0 <= h <= -b */
};

/* Per-face matrix (float, row-major), viewport row and height of the atlas. */
typedef struct hc_faces {
    float m[5][16];
    uint32_t y0[5];
    uint32_t h[5];
} hc_faces;

static void face_setup(hc_faces *fs, const rad_vec3 fr[5][3], uint32_t R, double near)
{
    for (int f = 0; f < 5; f++) {
        double m[16];
        hc_gl_projection(m, fr[f][0], fr[f][1], fr[f][2], f != 0, near);
        for (int k = 0; k < 16; k++)
            fs->m[f][k] = (float)m[k];
        fs->y0[f] = f == 0 ? 0 : R + (uint32_t)(f - 1) * (R / 2);
        fs->h[f] = f == 0 ? R : R / 2;
    }
}

static void draw_face(const hc_faces *fs, hc_work *wk, int f, uint32_t R, const int *first,
                      const int *count, int nr)
{
    hc_gl_view(wk->gl, fs->y0[f], R, fs->h[f], fs->m[f]);
    hc_gl_draw(wk->gl, first, count, nr);
}

/* ---------------------------------------------------------- probes, views */

/* The probe of a candidate without pixels: is c_j hidden at the pixel q
 * holding the direction to it?  When q shows a patch k (never j, which has
 * no pixel), j is hidden when c_j lies behind k's plane as seen from c_i: a
 * surface flush with j, like the ceiling around a small light, or one
 * beyond it never hides it.  When q shows a back side (no patch), the depth
 * buffer decides: hidden when it holds something nearer than c_j.  An empty
 * q hides nothing. */
static int probe_visible(const hc_engine *e, const hc_work *wk, uint32_t j, rad_vec3 c,
                         const rad_vec3 fr[5][3], double near)
{
    const uint32_t R = e->R;
    const rad_vec3 d = rad_sub(e->center[j], c), nj = e->mesh->patches[j].normal;
    if (!(rad_dot(d, nj) < 0.0))
        return 0; /* c_i sees j's back, or lies in j's plane */
    double h = rad_dot(d, fr[0][2]), a = rad_dot(d, fr[1][2]), b = rad_dot(d, fr[3][2]);
    if (!(h > 0.0))
        return 0; /* centre on or below the horizon: left to the pixel sum (0) */
    int f = fabs(a) <= h && fabs(b) <= h ? 0 : fabs(a) >= fabs(b) ? (a > 0 ? 1 : 2) : (b > 0 ? 3 : 4);
    const rad_vec3 rt = fr[f][0], up = fr[f][1], fw = fr[f][2];
    double w = rad_dot(d, fw), x = rad_dot(d, rt) / w, y = rad_dot(d, up) / w;
    long rows = f == 0 ? (long)R : (long)R / 2;
    long px = (long)floor((x + 1.0) * 0.5 * R);
    long py = (long)floor(f == 0 ? (y + 1.0) * 0.5 * R : y * (R / 2));
    px = px < 0 ? 0 : px >= (long)R ? (long)R - 1 : px;
    py = py < 0 ? 0 : py >= rows ? rows - 1 : py;
    long row = f == 0 ? py : (long)R + (f - 1) * ((long)R / 2) + py;
    uint32_t k = wk->pixels[(size_t)row * R + (size_t)px];
    double dl = rad_length(d);
    if (k < e->n) {
        const rad_vec3 nk = e->mesh->patches[k].normal;
        return rad_dot(rad_sub(e->center[j], e->center[k]), nk) >= -HC_PROBE_MARGIN * dl;
    }
    float D = hc_gl_read_depth(wk->gl, (uint32_t)px, (uint32_t)row);
    return !((double)D > near / w * (1.0 + HC_PROBE_MARGIN));
}

/* A focused view from c: forward d (at the candidates' mean centre), right
 * rt and up, half width span (the view's x, y in [-span, span] at distance
 * 1).  p0 holds the first candidate's corners. */
typedef struct hc_focus {
    rad_vec3 d, rt, up;
    double span;
    rad_vec3 p0[4];
} hc_focus;

/* Aims a focused view at js[0..nj) from c; -1 when the candidates are too
 * wide for one view (a corner 76° or more off its axis). */
static int focus_aim(const hc_engine *e, const uint32_t *js, uint32_t nj, rad_vec3 c, hc_focus *v)
{
    rad_vec3 mid = rad_v3(0, 0, 0);
    for (uint32_t k = 0; k < nj; k++)
        mid = rad_add(mid, e->center[js[k]]);
    const rad_vec3 d = rad_normalize(rad_sub(rad_scale(mid, 1.0 / nj), c));
    rad_vec3 bu, up;
    hc_basis(d, &bu, &up);
    const rad_vec3 rt = rad_cross(d, up); /* right = forward × up: unmirrored, as the faces */
    double span = 0.0;
    hc_load_corners(e, e->cfirst[js[0]], v->p0);
    for (uint32_t k = 0; k < nj; k++)
        for (uint32_t cj = e->cfirst[js[k]]; cj < e->cfirst[js[k] + 1]; cj++) {
            rad_vec3 pj[4];
            hc_load_corners(e, cj, pj);
            for (int q = 0; q < e->ncorner[cj]; q++) {
                rad_vec3 r = rad_sub(pj[q], c);
                double w = rad_dot(r, d);
                if (!(w > 0.25 * rad_length(r)))
                    return -1;
                span = fmax(span, fmax(fabs(rad_dot(r, rt)), fabs(rad_dot(r, up))) / w);
            }
        }
    span *= 1.02; /* a margin: the edge pixels stay inside the view */
    if (!(span > 0.0))
        return -1;
    v->d = d;
    v->rt = rt;
    v->up = up;
    v->span = span;
    return 0;
}

/* Is the sphere at r (relative to the eye) of radius rad wholly behind one
 * of the planes through the eye with normals pa[0..3], each of length at
 * most plen? */
static int sphere_outside(const rad_vec3 pa[4], double plen, rad_vec3 r, double rad)
{
    for (int pl = 0; pl < 4; pl++)
        if (rad_dot(pa[pl], r) < -rad * plen)
            return 1;
    return 0;
}

/* The patches to draw in focused view v, into the draw list wk->first[0],
 * wk->count[0] (*nr ranges): those of the nfront in front of i with a
 * corner inside the view's four planes (conservative, as the faces'
 * culling).  Returns 1 when one of them, not a candidate, may hide a
 * candidate: only a patch with some of it inside the view between c_i and
 * the polygon's plane can; it is clipped to those five planes (the
 * polygon's moved a margin towards c_i, so that what is flush with it
 * never counts). */
static int focus_list(const hc_engine *e, hc_work *wk, const uint32_t *js, uint32_t nj, rad_vec3 c,
                      uint32_t nfront, const hc_focus *v, int *nr)
{
    const rad_vec3 pn = e->mesh->patches[js[0]].normal, d = v->d, rt = v->rt, up = v->up;
    const double span = v->span;
    const double margin = 1e-6 * e->radius[js[0]];
    const double jd = rad_dot(rad_sub(v->p0[0], c), pn); /* < 0: c_i sees the front */
    const rad_vec3 pa[5] = {rad_sub(rad_scale(d, span), rt), rad_add(rad_scale(d, span), rt),
                            rad_sub(rad_scale(d, span), up), rad_add(rad_scale(d, span), up), pn};
    const double po[5] = {0, 0, 0, 0, -jd - margin};
    /* A sphere wholly behind one of the four planes has no corner in front
     * of it: the block's or the patch's bounding sphere rejects most of the
     * nfront patches of a narrow view in four dot products, before their
     * corners (the same patches as the corner test alone, only sooner; a
     * hair of margin keeps rounding from rejecting one the corners keep). */
    const double plen = sqrt(span * span + 1.0) * (1.0 + 1e-9); /* |pa[0..3]| */
    uint32_t last = 0, next = 0, block = UINT32_MAX;
    int hider = 0, block_out = 0;
    *nr = 0;
    for (uint32_t k = 0; k < nfront; k++) {
        uint32_t m = wk->front[k];
        if (m / HC_BLOCK != block) {
            block = m / HC_BLOCK;
            const double *sp = e->bsphere + 4 * (size_t)block;
            block_out = sphere_outside(pa, plen, rad_v3(sp[0] - c.x, sp[1] - c.y, sp[2] - c.z),
                                       sp[3] + e->tol);
        }
        if (block_out ||
            sphere_outside(pa, plen, rad_sub(e->center[m], c), e->radius[m] * (1.0 + 1e-9) + e->tol))
            continue;
        const double *p0 = e->corner + (size_t)e->cfirst[m] * 12;
        const double *p1 = e->corner + (size_t)e->cfirst[m + 1] * 12;
        unsigned in = 0;
        for (const double *p = p0; p < p1 && in != 15u; p += 3) {
            rad_vec3 r = rad_v3(p[0] - c.x, p[1] - c.y, p[2] - c.z);
            for (int pl = 0; pl < 4; pl++)
                in |= (unsigned)(rad_dot(pa[pl], r) >= 0) << pl;
        }
        if (in != 15u)
            continue;
        hc_push_range(wk, wk->first[0], wk->count[0], nr, &last, m);
        while (next < nj && js[next] < m)
            next++;
        if (hider || (next < nj && js[next] == m))
            continue;
        for (uint32_t cell = e->cfirst[m]; cell < e->cfirst[m + 1] && !hider; cell++) {
            const double *p = e->corner + (size_t)cell * 12;
            rad_vec3 poly[2][16];
            int np = e->ncorner[cell], cur = 0;
            for (int q = 0; q < np; q++)
                poly[0][q] = rad_v3(p[3 * q] - c.x, p[3 * q + 1] - c.y, p[3 * q + 2] - c.z);
            for (int pl = 0; pl < 5 && np > 0; pl++) {
                int nn = 0;
                for (int q = 0; q < np; q++) {
                    rad_vec3 a = poly[cur][q], b = poly[cur][(q + 1) % np];
                    double da = rad_dot(pa[pl], a) + po[pl], db = rad_dot(pa[pl], b) + po[pl];
                    if (da >= 0)
                        poly[!cur][nn++] = a;
                    if ((da >= 0) != (db >= 0))
                        poly[!cur][nn++] = rad_add(a, rad_scale(rad_sub(b, a), da / (da - db)));
                }
                np = nn;
                cur = !cur;
            }
            hider = np > 0;
        }
    }
    return hider;
}

/* The visibilities v_ij of far exact candidates js[0..nj) (ascending, all
 * patches of one polygon, so that none can hide another), measured in a
 * view of their own: an R×R item buffer from c_i aimed at their centre and
 * just wide enough to hold them, so that they cover most of it instead of
 * the few hundred pixels they cover on the hemi-cube (at R = 128 the
 * Cornell light, 0.13 × 0.105 m seen from the middle of the floor 0.55 m
 * below, is about 15 × 12 pixels, and a block's edge sweeping across it
 * changed v in steps of 1/15 to 1/12).  Two renderings: every patch in
 * front of i inside the view (S_j), and the candidates alone (S°_j); both
 * sum the weight cosθ_i dω of the pixels showing j (in the view's tangent
 * plane at (x, y), dω ∝ (1 + x² + y²)^{-3/2} and cosθ_i ∝ the direction's
 * dot n_i over its length), so v_ij = S_j / S°_j is the cosine-weighted
 * fraction of j that c_i sees, as F_exact weighs it.  cover[k] counts the
 * pixels of js[k] in the second rendering, and vis[k] is -1 for a
 * candidate without any (sub-pixel in this view).  Sets vis[k] = 1 without
 * rendering when no other patch lies inside the view between c_i and the
 * polygon's plane (nothing can hide them: the light's own patches, the
 * ceiling around it; cover[k] is then R²), and returns -1 (vis untouched)
 * when the candidates are too wide for one view. */
static int focused_visibility(const hc_engine *e, hc_work *wk, const uint32_t *js, uint32_t nj,
                              rad_vec3 c, rad_vec3 ni, uint32_t nfront, double near, double *vis,
                              uint32_t *cover)
{
    const uint32_t R = e->R;
    hc_focus v;
    if (focus_aim(e, js, nj, c, &v) != 0)
        return -1;
    int nr;
    if (!focus_list(e, wk, js, nj, c, nfront, &v, &nr)) {
        for (uint32_t k = 0; k < nj; k++) {
            vis[k] = 1.0;
            cover[k] = R * R;
        }
        return 0;
    }
    const rad_vec3 d = v.d, rt = v.rt, up = v.up;
    const double span = v.span;
    double mat[16];
    hc_gl_projection(mat, rad_scale(rt, 1.0 / span), rad_scale(up, 1.0 / span), d, 0, near);
    /* Weight of pixel (x, y): (d + a·rt + b·up)·n_i / (1 + a² + b²)². */
    const double dn = rad_dot(d, ni), rn = rad_dot(rt, ni), un = rad_dot(up, ni);
    double *sum = wk->fsum; /* S_j, then S°_j */
    memset(sum, 0, 2 * (size_t)nj * sizeof *sum);
    memset(cover, 0, (size_t)nj * sizeof *cover);
    /* Both renderings side by side in the atlas (rows [0, R) and [R, 2R)),
     * read back at once: one wait for the rasteriser instead of two. */
    for (int pass = 0; pass < 2; pass++) {
        hc_gl_square_view(wk->gl, mat, R, pass ? R : 0);
        if (pass == 1) {
            uint32_t last = 0;
            nr = 0;
            for (uint32_t k = 0; k < nj; k++)
                hc_push_range(wk, wk->first[0], wk->count[0], &nr, &last, js[k]);
        }
        hc_gl_draw(wk->gl, wk->first[0], wk->count[0], nr);
    }
    hc_gl_read_items(wk->gl, R, 2 * R, wk->pixels);
    for (uint32_t pass = 0; pass < 2; pass++) {
        for (uint32_t y = 0; y < R; y++) {
            const double b = ((y + 0.5) * 2.0 / R - 1.0) * span;
            for (uint32_t x = 0; x < R; x++) {
                uint32_t id = wk->pixels[((size_t)pass * R + y) * R + x];
                if (id < js[0] || id > js[nj - 1])
                    continue;
                uint32_t lo = 0, hi = nj; /* id's slot, if it is a candidate */
                while (hi - lo > 1) {
                    uint32_t md = (lo + hi) / 2;
                    if (js[md] <= id)
                        lo = md;
                    else
                        hi = md;
                }
                if (js[lo] != id)
                    continue;
                const double a = ((x + 0.5) * 2.0 / R - 1.0) * span, l2 = 1.0 + a * a + b * b;
                const double w = dn + a * rn + b * un;
                if (w > 0.0)
                    sum[(size_t)pass * nj + lo] += w / (l2 * l2);
                cover[lo] += pass;
            }
        }
    }
    for (uint32_t k = 0; k < nj; k++)
        vis[k] = cover[k] > 0 && sum[nj + k] > 0.0 ? fmin(1.0, sum[k] / sum[nj + k]) : -1.0;
    return 0;
}

/* ---------------------------------------------------------- exact entries */

/* F_exact of the ncand candidates, their occluded sums S_ij (from wk->acc)
 * and their OR passes; returns the number of OR passes. */
static uint32_t exact_factors(const hc_engine *e, hc_work *wk, uint32_t i, rad_vec3 c,
                              uint32_t ncand)
{
    const hc_sample *s = wk->smp;
    uint32_t per_residue[32] = {0}, passes = 0;
    for (uint32_t k = 0; k < ncand; k++) {
        hc_cand *cd = &wk->cand[k];
        uint32_t j = cd->j;
        cd->occ = wk->acc[j];
        cd->free = 0.0;
        cd->px = 0;
        double ex;
        if (cd->near || cd->area) {
            ex = hc_cells_factor(e, i, s->cells, s->ncell, s->area, j, cd->near == 1);
        } else {
            ex = hc_point_to_patch(e, c, s->n, j);
        }
        cd->exact = ex > 0.0 && isfinite(ex) ? ex : 0.0;
        cd->pass = UINT32_MAX;
        if (cd->exact > 0.0 && cd->occ > 0.0) {
            cd->pass = per_residue[j & 31u]++;
            passes = cd->pass + 1 > passes ? cd->pass + 1 : passes;
        }
    }
    return passes;
}

/* The unoccluded sums S°_ij (and pixel counts) of the candidates with
 * pixels, in `passes` OR renderings of the candidates alone. */
static void or_passes(const hc_engine *e, hc_work *wk, uint32_t ncand, uint32_t passes,
                      const hc_faces *fs)
{
    const uint32_t R = e->R;
    const size_t npix = (size_t)3 * R * R;
    hc_gl_or_mode(wk->gl, 1);
    for (uint32_t p = 0; p < passes; p++) {
        uint32_t slot[32], nin = 0;
        for (uint32_t k = 0; k < ncand; k++)
            if (wk->cand[k].pass == p) {
                slot[wk->cand[k].j & 31u] = k;
                wk->order[nin++] = k;
            }
        hc_gl_clear_items(wk->gl, R, 3 * R, 0u);
        for (int f = 0; f < 5; f++) {
            int nr = 0;
            uint32_t last = 0;
            for (uint32_t t = 0; t < nin; t++) {
                const hc_cand *cd = &wk->cand[wk->order[t]];
                if (!(cd->faces & (1u << f)))
                    continue;
                hc_push_range(wk, wk->first[0], wk->count[0], &nr, &last, cd->j);
            }
            if (nr)
                draw_face(fs, wk, f, R, wk->first[0], wk->count[0], nr);
        }
        hc_gl_read_items(wk->gl, R, 3 * R, wk->pixels);
        /* In pixel order, as the occluded sums: deterministic. */
        for (size_t q = 0; q < npix; q++) {
            uint32_t bits = wk->pixels[q];
            while (bits) {
                uint32_t r = (uint32_t)__builtin_ctz(bits);
                bits &= bits - 1;
                wk->cand[slot[r]].free += e->dff[q];
                wk->cand[slot[r]].px++;
            }
        }
    }
    hc_gl_or_mode(wk->gl, 0);
}

/* The hemi-cube's v_ij, then the focused views' where they apply: to far
 * candidates that cover fewer hemi-cube pixels than a focused view would
 * give them, one view per polygon (its such candidates, ascending as the
 * row found them), and one per patch when the polygon is too wide for one
 * view or a patch too small in it.  At most HC_FOCUS_VIEWS views a row,
 * taken in candidate order, a polygon's per-patch views all or none: a room
 * whose every wall glows keeps the hemi-cube's ratios (its walls are large
 * and near; what the views are for is a few small bright sources). */
static void visibilities(const hc_engine *e, hc_work *wk, uint32_t i, rad_vec3 c, uint32_t ncand,
                         uint32_t nfront, double near)
{
    const uint32_t R = e->R;
    const rad_vec3 nn = wk->smp->n;
    (void)i;
    for (uint32_t k = 0; k < ncand; k++) {
        hc_cand *cd = &wk->cand[k];
        cd->vis = cd->occ > 0.0 ? fmin(1.0, cd->occ / cd->free) : cd->free;
        cd->focus = cd->exact > 0.0 && !cd->near && cd->px < HC_FOCUS_PIXELS(R);
    }
    uint32_t views = 0;
    for (uint32_t k = 0; k < ncand && views < HC_FOCUS_VIEWS; k++) {
        if (!wk->cand[k].focus)
            continue;
        uint32_t ng = 0, poly = e->mesh->patches[wk->cand[k].j].polygon;
        for (uint32_t q = k; q < ncand; q++)
            if (wk->cand[q].focus && e->mesh->patches[wk->cand[q].j].polygon == poly) {
                wk->order[ng] = wk->cand[q].j;
                wk->cand[q].focus = 0;
                wk->fslot[ng++] = q;
            }
        double *vis = wk->fsum + 2 * (size_t)e->n;
        uint32_t *cover = wk->fslot + e->n, singles = 0;
        views++;
        const int whole = focused_visibility(e, wk, wk->order, ng, c, nn, nfront, near, vis, cover) == 0;
        for (uint32_t q = 0; q < ng; q++)
            singles += ng > 1 && (!whole || cover[q] < HC_FOCUS_PIXELS(R));
        const int alone = singles > 0 && views + singles <= HC_FOCUS_VIEWS;
        views += alone ? singles : 0;
        for (uint32_t q = 0; q < ng; q++) {
            hc_cand *cd = &wk->cand[wk->fslot[q]];
            double v1 = -1.0;
            uint32_t c1;
            if (alone && (!whole || cover[q] < HC_FOCUS_PIXELS(R)) &&
                focused_visibility(e, wk, &cd->j, 1, c, nn, nfront, near, &v1, &c1) == 0 && v1 >= 0.0)
                cd->vis = v1;
            else if (whole && vis[q] >= 0.0)
                cd->vis = vis[q];
        }
    }
}

/* Replaces the pixel sums wk->acc[j] of the ncand candidates in wk->cand by
 * their exact entries F_exact · v_ij (see the top of the file).  Needs the
 * occluded pass's depth buffer; leaves the item buffer overwritten. */
static void exact_entries(const hc_engine *e, hc_work *wk, uint32_t i, rad_vec3 c, uint32_t ncand,
                          uint32_t nfront, const rad_vec3 fr[5][3], const hc_faces *fs, double near)
{
    const uint32_t passes = exact_factors(e, wk, i, c, ncand);
    /* Probes read the occluded pass's depth, which the OR passes keep (no
     * depth test, so no depth writes). */
    for (uint32_t k = 0; k < ncand; k++) {
        hc_cand *cd = &wk->cand[k];
        if (cd->exact > 0.0 && cd->occ == 0.0)
            cd->free = probe_visible(e, wk, cd->j, c, fr, near) ? 1.0 : 0.0;
    }
    if (passes)
        or_passes(e, wk, ncand, passes, fs);
    visibilities(e, wk, i, c, ncand, nfront, near);
    for (uint32_t k = 0; k < ncand; k++) {
        const hc_cand *cd = &wk->cand[k];
        wk->acc[cd->j] = cd->exact > 0.0 ? cd->exact * cd->vis : 0.0;
    }
}

/* -------------------------------------------------------------------- row */

/* Is patch j's polygon far (its centre farther than twice the square root
 * of its area) and so small on the cube at c (frame u, v, nn) that it
 * covers fewer than HC_SMALL_PIXELS pixels?  Its solid angle A cos θ / r²
 * over the solid angle of a pixel of the face it falls on, pixel × μ³ with
 * μ the cosine to that face's axis. */
static int small_polygon(const hc_engine *e, const hc_work *wk, uint32_t j, rad_vec3 c,
                         rad_vec3 nn, rad_vec3 u, rad_vec3 v, double pixel)
{
    const uint32_t q = e->mesh->patches[j].polygon;
    const rad_vec3 d = rad_sub(e->poly_center[q], c);
    const double r2 = rad_dot(d, d), A = e->poly_area[q];
    if (!(A > 0.0))
        return 0;
    const double r = sqrt(r2);
    const double cos_j = fabs(rad_dot(d, e->mesh->patches[j].normal)) / r;
    const double mu = fmax(fabs(rad_dot(d, nn)), fmax(fabs(rad_dot(d, u)), fabs(rad_dot(d, v)))) / r;
    if (r2 > 4.0 * A && A * cos_j / r2 < HC_SMALL_PIXELS * pixel * mu * mu * mu)
        return 1;
    /* Thin: the polygon's width A / (2 reach), foreshortened by cos θ_j, in
     * pixels of side sqrt(pixel) μ^1.5 at this direction; only for a
     * polygon whose reach ends short of c (its patches are then all in
     * front, within one focused view's cone or probed). */
    const double reach = wk->preach[q], thin = weak_thin[e->opt.weak];
    if (cos_j < weak_cos[e->opt.weak])
        return 0;
    return thin > 0.0 && r > reach &&
           A * cos_j / (2.0 * reach * r) < thin * sqrt(pixel * mu * mu * mu);
}

/* Is patch i's centre a poor sample of its entry for a patch j within
 * weak_near diameters, at the defaults?  Only facing planes closer than i's
 * diameter (squares 0.05 apart: -3.8 % by centres, -0.25 % averaged).
 * Plates meeting at an edge are left to the centres (a patch by the edge
 * errs one way, the next ones the other, and over a wide wall it averages
 * out): with them too (every j within 2 diameters, or only where i's or
 * j's polygon is under 2.2 patch diameters wide, as the narrow plates of
 * the catalog are) the Cornell box's tall block front went from -0.95 %
 * to -1.19 % or -0.97 % of the reference (a solve's rows are collocation
 * rows: docs/limits.md).  For surface-to-surface factors (HC_WEAK_SURFACE)
 * and at the accurate setting every j within weak_near diameters. */
static int sampling_weak(const hc_engine *e, uint32_t i, uint32_t j)
{
    if (e->opt.weak == HC_WEAK_HIGH || e->opt.weak == HC_WEAK_SURFACE)
        return 1;
    const rad_patch *P = e->mesh->patches;
    const double gap = fabs(rad_dot(P[j].normal, rad_sub(e->center[i], e->center[j])));
    return rad_dot(P[i].normal, P[j].normal) < -0.9 && gap < 2.0 * e->radius[i];
}

/* The patches a cube at c on patch i (normal nn, basis u, v) may see:
 * wk->front[0..*nfront) ascending, each face's draw list in wk->first[f],
 * wk->count[f] (nr[f] ranges) and, when the engine has any, the exact
 * candidates in wk->cand (returned: how many). */
static uint32_t cull(const hc_engine *e, hc_work *wk, uint32_t i, rad_vec3 c, rad_vec3 nn,
                     rad_vec3 u, rad_vec3 v, int near_ok, int whole, uint32_t *nfront_out,
                     int nr[5])
{
    const uint32_t n = e->n;
    const double tol = e->tol;
    const double pixel = 4.0 / ((double)e->R * e->R); /* a top-face pixel's ΔA at distance 1 */
    uint32_t nfront = 0, ncand = 0, nsmall = 0;
    /* A polygon's patches are decided together: the last one decided */
    uint32_t last_poly = UINT32_MAX;
    int last_small = 0;
    uint32_t last[5] = {0, 0, 0, 0, 0};
    /* A near view (hc_receiver.reach) draws only the patches whose centre
     * lies within reach. */
    const double reach = wk->smp ? wk->smp->reach : 0.0;
    const rad_vec3 at = rad_add(c, e->origin); /* as the caller placed it */
    for (uint32_t j = 0; j < n; j++) {
        if (j % HC_BLOCK == 0) {
            const double *sp = e->bsphere + 4 * (size_t)(j / HC_BLOCK);
            double hb = (sp[0] - c.x) * nn.x + (sp[1] - c.y) * nn.y + (sp[2] - c.z) * nn.z;
            const rad_vec3 db = rad_v3(sp[0] - c.x, sp[1] - c.y, sp[2] - c.z);
            if (hb + sp[3] <= tol || (reach > 0.0 && rad_length(db) > reach + sp[3])) {
                j += HC_BLOCK - 1;
                continue;
            }
        }
        if (j == i)
            continue;
        if (reach > 0.0 && !hc_within_reach(e->mesh, j, at, reach))
            continue;
        /* Ranges of a = p·u, b = p·v, h = p·n over the corners of j's
         * cells (triangles repeat corner 0).  max(h - a) <= max h - min a
         * etc. bound each plane from above: cheap, and conservative (a
         * patch is only ever drawn needlessly, never skipped wrongly). */
        const double *p = e->corner + (size_t)e->cfirst[j] * 12;
        const double *end = e->corner + (size_t)e->cfirst[j + 1] * 12;
        double amin = INFINITY, amax = -INFINITY, bmin = INFINITY, bmax = -INFINITY;
        double hmax = -INFINITY, hmin = INFINITY;
        for (; p < end; p += 3) {
            double x = p[0] - c.x, y = p[1] - c.y, z = p[2] - c.z;
            double a = x * u.x + y * u.y + z * u.z;
            double b = x * v.x + y * v.y + z * v.z;
            double h = x * nn.x + y * nn.y + z * nn.z;
            amin = a < amin ? a : amin;
            amax = a > amax ? a : amax;
            bmin = b < bmin ? b : bmin;
            bmax = b > bmax ? b : bmax;
            hmin = h < hmin ? h : hmin;
            hmax = h > hmax ? h : hmax;
        }
        /* Only patches with a corner strictly in front of i's plane can be
         * seen; this also drops every patch coplanar with i.  (A cluster's
         * own cells are never drawn in its row: they are patch i, and
         * nearly coplanar with it.) */
        if (!(hmax > tol))
            continue;
        const double t = -tol;
        unsigned inside = (hmax - amin >= t) * PL_H_MA | (hmax + amax >= t) * PL_H_PA |
                          (hmax - bmin >= t) * PL_H_MB | (hmax + bmax >= t) * PL_H_PB |
                          (amax - bmin >= t) * PL_A_MB | (amax + bmax >= t) * PL_A_PB |
                          (-amin - bmin >= t) * PL_NA_MB | (bmax - amin >= t) * PL_B_MA |
                          PL_H | (amax - hmin >= t) * PL_A_MH | (-amin - hmin >= t) * PL_NA_MH |
                          (bmax - hmin >= t) * PL_B_MH | (-bmin - hmin >= t) * PL_NB_MH;
        wk->front[nfront++] = j;
        unsigned faces = 0;
        for (int f = 0; f < 5; f++) {
            if ((inside & face_planes[f]) != face_planes[f])
                continue;
            faces |= 1u << f;
            hc_push_range(wk, wk->first[f], wk->count[f], &nr[f], &last[f], j);
        }
        if (e->any_exact && !(reach > 0.0)) {
            int is_near = 0, close = 0;
            if (near_ok) {
                rad_vec3 d = rad_sub(e->center[j], c);
                const double reach = weak_area[e->opt.weak] * 2.0 * e->radius[i];
                close = rad_dot(d, d) < reach * reach;
                double size = 2.0 * e->radius[j];
                const double wide = weak_near[e->opt.weak] * 2.0 * e->radius[i];
                /* 1: nearer than j's own size (the finer average); 2: only
                 * within the weak rule's reach */
                is_near = rad_dot(d, d) < size * size ? 1
                          : rad_dot(d, d) < wide * wide && sampling_weak(e, i, j) ? 2
                                                        : 0;
            }
            const int marked = e->exact && e->exact[j];
            const uint32_t q = e->mesh->patches[j].polygon;
            if (q != last_poly) {
                last_poly = q;
                last_small = nsmall + e->poly_patches[q] <= HC_SMALL_MAX &&
                             small_polygon(e, wk, j, c, nn, u, v, pixel);
                nsmall += last_small ? e->poly_patches[q] : 0;
            }
            const int costly = e->cfirst[i + 1] - e->cfirst[i] > HC_EXACT_MAX_CELLS ||
                               e->cfirst[j + 1] - e->cfirst[j] > HC_EXACT_MAX_CELLS ||
                               e->shared[i] || e->shared[j];
            is_near = costly ? 0 : is_near;
            const int small = last_small && !is_near && !marked && !costly;
            if (is_near || marked || small) {
                hc_cand *cd = &wk->cand[ncand++];
                cd->j = j;
                cd->faces = (uint8_t)faces;
                cd->near = (uint8_t)is_near;
                cd->area = (uint8_t)(whole && (marked || close) && !is_near);
            }
        }
    }
    *nfront_out = nfront;
    return ncand;
}

/* A closed row's deficit delta = T − Σ exact − Σ pixel entries, added to
 * the pixel entries (those not in wk->mark) in proportion to
 * F_ij (r_i / d_ij)², d_ij the distance between centres: where i's centre
 * misjudges the average over i, the error goes as F_ij times (size /
 * distance)², so the entries just beyond the near ones take nearly all of
 * it and a far ceiling keeps its pixel count (a uniform scale moved the
 * ceiling of a 1 × 2 × 3 box by 2.7 %).  0, or -1 (nothing changed) when
 * an entry would fall to 0 or below. */
static int spread_deficit(const hc_engine *e, hc_work *wk, uint32_t i, uint32_t nfront,
                          double delta)
{
    const double r2 = e->radius[i] * e->radius[i];
    double W = 0.0;
    for (uint32_t k = 0; k < nfront; k++) {
        const uint32_t j = wk->front[k];
        const rad_vec3 d = rad_sub(e->center[j], e->center[i]);
        if (!wk->mark[j] && wk->acc[j] > 0.0)
            W += wk->acc[j] * r2 / fmax(rad_dot(d, d), r2);
    }
    if (!(W > 0.0) || (delta < 0.0 && -delta >= W))
        return -1; /* each entry's share is below delta / W × acc[j] <= acc[j] */
    for (uint32_t k = 0; k < nfront; k++) {
        const uint32_t j = wk->front[k];
        const rad_vec3 d = rad_sub(e->center[j], e->center[i]);
        if (!wk->mark[j] && wk->acc[j] > 0.0)
            wk->acc[j] += delta / W * wk->acc[j] * r2 / fmax(rad_dot(d, d), r2);
    }
    return 0;
}

/* Renormalisation of a row with exact entries (wk->acc holding the pixel
 * sums): replaces the candidates' sums by their exact entries and sets the
 * scales of the pixel entries and of the exact ones; marks the candidates
 * in wk->mark.  0, or -1 with msg set on a GL error. */
static int renormalise(const hc_engine *e, hc_work *wk, uint32_t i, rad_vec3 c, uint32_t ncand,
                       uint32_t nfront, const rad_vec3 fr[5][3], const hc_faces *fs, double near,
                       double *scale_px, double *scale_ex, char *msg)
{
    double *acc = wk->acc;
    /* The row's pixel total T = Σ_j F_ij is what the cube saw covered:
     * exact to the pixel in a closed room (T = 1).  Exact entries fix
     * how T is shared between patches, not T itself. */
    double total = 0.0;
    for (uint32_t k = 0; k < nfront; k++)
        total += acc[wk->front[k]];
    total = total < 1.0 ? total : 1.0;
    exact_entries(e, wk, i, c, ncand, nfront, fr, fs, near);
    if (hc_gl_check("measuring exact form factors", msg))
        return -1;
    /* With far exact entries only (emitters), the pixel entries, the less
     * accurate ones, are scaled to fill T - Σ exact: the row keeps the
     * cube's total and a closed room stays closed (energy is conserved).  A
     * near entry is different: there T itself carries the error of
     * sampling i at its centre (two plates 0.01 apart cover 99.8 % of the
     * centre's view, 98.0 % on average over the plate), so the exact
     * entries stand and the row is only scaled down should it exceed 1. */
    double sum_ex = 0.0, sum_px = 0.0;
    int any_near = 0;
    for (uint32_t k = 0; k < ncand; k++) {
        sum_ex += acc[wk->cand[k].j];
        wk->mark[wk->cand[k].j] = 1;
        any_near |= wk->cand[k].near;
    }
    for (uint32_t k = 0; k < nfront; k++)
        if (!wk->mark[wk->front[k]])
            sum_px += acc[wk->front[k]];
    /* A row whose cube saw every pixel covered (a closed room) sums to 1
     * at every point of i, near entries or not: there too the pixel
     * entries fill what the exact ones leave (without this a room at ρ =
     * 0.999 lost 9 % of its light through rows 1.6e-3 short). */
    const int closed = total >= 1.0 - 1e-9;
    if (any_near && closed && e->opt.weak != HC_WEAK_OFF && sum_ex <= total &&
        spread_deficit(e, wk, i, nfront, total - sum_ex - sum_px) == 0)
        return 0;
    if ((!any_near || closed) && sum_ex <= total) {
        if (sum_px > 0.0)
            *scale_px = (total - sum_ex) / sum_px;
    } else if (sum_ex + sum_px > 1.0) {
        *scale_px = sum_ex < 1.0 ? (1.0 - sum_ex) / sum_px : 1.0 / (sum_ex + sum_px);
        *scale_ex = sum_ex < 1.0 ? 1.0 : *scale_px;
    }
    return 0;
}

/* A point receiver's exact entries are the point-to-polygon factor only
 * (no near area averages over i).  A near view (s->reach) has none, and is
 * drawn at R_near: what it draws is near, so large on the cube. */
long hc_row_sample(const hc_engine *e, hc_work *wk, uint32_t i, const hc_sample *s, char *msg)
{
    const uint32_t n = e->n, R = s->reach > 0.0 ? e->R_near : e->R;
    const rad_patch *pi = &e->mesh->patches[i];
    rad_vec3 nn = s->n, u, v;
    hc_basis(nn, &u, &v);
    const rad_vec3 c = s->c;
    const int near_ok = e->opt.exact_near && !s->point;
    uint32_t nfront = 0;
    int nr[5] = {0, 0, 0, 0, 0};
    wk->smp = s;
    const uint32_t ncand = cull(e, wk, i, c, nn, u, v, near_ok, !s->point, &nfront, nr);

    hc_gl_atlas_begin(wk->gl, R, c);
    const double near = 1e-4 * sqrt(pi->area);
    const rad_vec3 mu = rad_scale(u, -1), mv = rad_scale(v, -1);
    /* (right, up, forward) per face; right = forward × up keeps every face
     * unmirrored. */
    const rad_vec3 fr[5][3] = {{mu, v, nn}, {mv, nn, u}, {v, nn, mu}, {u, nn, v}, {mu, nn, mv}};
    hc_faces fs;
    face_setup(&fs, fr, R, near);
    for (int f = 0; f < 5; f++)
        if (nr[f])
            draw_face(&fs, wk, f, R, wk->first[f], wk->count[f], nr[f]);
    hc_gl_read_items(wk->gl, R, 3 * R, wk->pixels);
    if (hc_gl_check("rendering a hemi-cube", msg))
        return -1;

    /* F_ij = Σ ΔF_q over the pixels q showing j (paper, eq. 7), summed in
     * pixel order so the result never depends on scheduling. */
    const size_t npix = (size_t)3 * R * R;
    const uint32_t *px = wk->pixels;
    const double *dff = s->reach > 0.0 ? e->dff_near : e->dff;
    double *acc = wk->acc;
    for (size_t q = 0; q < npix; q++) {
        uint32_t id = px[q];
        if (id < n)
            acc[id] += dff[q];
    }
    double scale_px = 1.0, scale_ex = 1.0;
    if (ncand &&
        renormalise(e, wk, i, c, ncand, nfront, fr, &fs, near, &scale_px, &scale_ex, msg) != 0)
        return -1;
    long cnt = 0;
    for (uint32_t k = 0; k < nfront; k++) {
        uint32_t j = wk->front[k];
        double scale = scale_px;
        if (ncand && wk->mark[j]) {
            scale = scale_ex;
            wk->mark[j] = 0;
        }
        if (acc[j] > 0.0) {
            float f = (float)(acc[j] * scale);
            if (f > 0.0f) {
                wk->col[cnt] = j;
                wk->val[cnt] = f;
                cnt++;
            }
        }
        acc[j] = 0.0;
    }
    return cnt;
}
