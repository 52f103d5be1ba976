/* render.c - vertex radiosities, the item buffer and the interpolated image.
 *
 * Owns rn_vertex_radiosity, rn_render, rn_canvas (the buffers kept from one
 * view to the next) and rn_image_destroy, plus the small helpers the two
 * writers share (rn_internal.h).  Invariant of an image made
 * here: each pixel is either background (patch RAD_NONE, every band 0) or the
 * radiance L = B/π of the one front-facing patch nearest along the pixel's
 * eye ray, B interpolated from the vertex radiosities at the point X where
 * that ray meets the patch's plane (Cohen & Greenberg 1985, "Rendering").
 *
 * The item buffer is a CPU z-buffer: patches are clipped in camera space
 * (near plane and a guard band around the screen), projected, snapped to a
 * fixed-point grid and filled with exact integer edge functions under a
 * top-left rule, so a shared edge is owned by exactly one of its two patches.
 * Perspective and orthographic cameras differ only in the projection
 * (x/z or x), the depth kept (1/z or a constant minus z, both affine on
 * the screen over a plane), the back-face test and the pixel ray (from the
 * eye, or parallel to the view from the pixel's point of the window).
 */
#include "rn_internal.h"

#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Sub-pixel precision of the snapped screen coordinates: 1/4096 pixel.
 * Snapped coordinates stay below 2^16 pixels (guard band), so below 2^28
 * sub-pixels: an edge function (two products of differences < 2^29) fits
 * int64 exactly. */
#define SUBPIX_BITS 12
#define SUBPIX ((int64_t)1 << SUBPIX_BITS)

/* The near plane sits this fraction of the scene's extent (seen from the eye)
 * in front of the eye.  Depth is 1/z in double, so a tiny near plane costs no
 * depth precision; it only has to keep 1/z finite. */
#define NEAR_FRACTION 1e-10

/* A polygon clipped by five planes; convex patches never need more than 9
 * corners, the rest is slack for bad input. */
#define CLIP_MAX 64

/* ------------------------------------------------------------- helpers */

int rn_image_check(const rn_image *img, const char *path, rad_error *err)
{
    const char *p = path ? path : "(no path)";
    if (!img)
        return rad_fail(err, RAD_ERR_USAGE, "%s: no image", p);
    if (img->width == 0 || img->height == 0 || img->width > RN_MAX_SIDE ||
        img->height > RN_MAX_SIDE)
        return rad_fail(err, RAD_ERR_USAGE, "%s: image size %ux%u outside 1..%u", p, img->width,
                        img->height, RN_MAX_SIDE);
    if (img->channels == 0 || img->channels > RAD_MAX_BANDS)
        return rad_fail(err, RAD_ERR_USAGE, "%s: image has %u channels, not 1..%d", p,
                        img->channels, RAD_MAX_BANDS);
    if (!img->pixels)
        return rad_fail(err, RAD_ERR_USAGE, "%s: image has no pixels", p);
    return RAD_OK;
}

rn_image *rn_image_alloc(uint32_t width, uint32_t height, uint32_t channels)
{
    rn_image *img = calloc(1, sizeof *img);
    if (!img)
        return NULL;
    size_t n = (size_t)width * height;
    img->width = width;
    img->height = height;
    img->channels = channels;
    img->pixels = calloc(n * channels, sizeof *img->pixels);
    img->patch = malloc(n * sizeof *img->patch);
    if (!img->pixels || !img->patch) {
        rn_image_destroy(img);
        return NULL;
    }
    for (size_t k = 0; k < n; k++)
        img->patch[k] = RAD_NONE;
    return img;
}

void rn_image_destroy(rn_image *img)
{
    if (!img)
        return;
    free(img->pixels);
    free(img->patch);
    free(img);
}

/* Indices in range for this mesh (a triangle's v[3] is RAD_NONE). */
static int patch_valid(const rad_mesh *m, const rad_patch *p)
{
    int n = rad_patch_corners(p);
    for (int k = 0; k < n; k++)
        if (p->v[k] >= m->vertex_count)
            return 0;
    return 1;
}

static int same_point(rad_vec3 a, rad_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

/* Two unit vectors spanning the plane with normal n (any n != 0). */
static void plane_basis(rad_vec3 n, rad_vec3 *e1, rad_vec3 *e2)
{
    rad_vec3 a = fabs(n.x) <= fabs(n.y) && fabs(n.x) <= fabs(n.z) ? rad_v3(1, 0, 0)
                 : fabs(n.y) <= fabs(n.z)                          ? rad_v3(0, 1, 0)
                                                                   : rad_v3(0, 0, 1);
    *e1 = rad_normalize(rad_cross(n, a));
    *e2 = rad_normalize(rad_cross(n, *e1));
}

/* -------------------------------------------------- vertex radiosities */

/* Outline vertex v: the paper extrapolates "from the adjacent interior vertex
 * radiosities through an average of the adjacent patch radiosities".  We fit
 * an affine B(x) in the polygon's plane, by least squares, to the samples
 * around v - the centres of the patches using v (value B_patch) and the
 * interior vertices sharing a patch with v (value B_w) - and evaluate it at v.
 * On a regular grid this is exactly the paper's rule: a corner gives
 * 2·B_patch − B_(1,1) and an edge vertex with three interior neighbours
 * 2·P(v) − their mean.  Unlike a plain "2·P − mean" it stays exact for a
 * linear field next to a corner, where the interior neighbours are lopsided.
 * When the samples are collinear (a corner) the fit is along their line only
 * (pseudo-inverse), which still contains v on a regular grid.  When no
 * interior vertex shares a patch with v, the samples come from one ring
 * further; when there is none there either, B_v = P(v). */
typedef struct vr_sample {
    double x, y;   /* plane coordinates relative to v */
    uint32_t id;   /* patch index or vertex index */
    int is_vertex;
} vr_sample;

void rn_affine_weights(const double *x, const double *y, size_t n, double *w)
{
    double mx = 0, my = 0;
    for (size_t k = 0; k < n; k++) {
        mx += x[k];
        my += y[k];
    }
    mx /= n;
    my /= n;
    double sxx = 0, sxy = 0, syy = 0;
    for (size_t k = 0; k < n; k++) {
        double dx = x[k] - mx, dy = y[k] - my;
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    /* Pseudo-inverse of the 2×2 scatter matrix S: full inverse when both
     * eigenvalues are significant, else the projector on the dominant one. */
    double tr = sxx + syy, det = sxx * syy - sxy * sxy;
    double disc = sqrt(fmax(0.0, 0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy));
    double l1 = 0.5 * tr + disc, l2 = 0.5 * tr - disc;
    double ixx = 0, ixy = 0, iyy = 0;
    if (l1 > 0 && l2 > 1e-9 * l1) {
        ixx = syy / det;
        iyy = sxx / det;
        ixy = -sxy / det;
    } else if (l1 > 0) {
        /* Rank one: S ≈ λ1 e eᵀ, and its larger column is parallel to e. */
        double cx = sxx, cy = sxy;
        if (sxy * sxy + syy * syy > cx * cx + cy * cy) {
            cx = sxy;
            cy = syy;
        }
        double l = sqrt(cx * cx + cy * cy);
        cx /= l;
        cy /= l;
        ixx = cx * cx / l1;
        ixy = cx * cy / l1;
        iyy = cy * cy / l1;
    }
    /* B(0) = mean b − g·m with gradient g = S⁺ Σ (s_k − m) b_k: linear in
     * the b_k, with these weights. */
    double qx = ixx * mx + ixy * my, qy = ixy * mx + iyy * my;
    for (size_t k = 0; k < n; k++)
        w[k] = 1.0 / (double)n - (qx * (x[k] - mx) + qy * (y[k] - my));
}

/* Weights w[0..n) such that Σ_k w_k b_k is, at the origin, the quadratic
 * fitted by least squares to the samples at (x_k, y_k).  Returns 0, or -1
 * when the samples do not determine a quadratic (fewer than 7, or too close
 * to a conic).  Coordinates are scaled by their RMS distance first. */
static int quadratic_weights(const double *x, const double *y, size_t n, double *w)
{
    if (n < 7)
        return -1;
    double r2 = 0;
    for (size_t k = 0; k < n; k++)
        r2 += x[k] * x[k] + y[k] * y[k];
    double sc = sqrt(r2 / (double)n);
    if (!(sc > 0))
        return -1;
    double M[6][7] = {{0}};
    for (size_t k = 0; k < n; k++) {
        double u = x[k] / sc, v = y[k] / sc, a[6] = {1, u, v, u * u, u * v, v * v};
        for (int i = 0; i < 6; i++)
            for (int j = 0; j < 6; j++)
                M[i][j] += a[i] * a[j];
    }
    M[0][6] = 1.0; /* solve (AᵀA) z = e_0 */
    double trace = 0;
    for (int i = 0; i < 6; i++)
        trace += M[i][i];
    for (int c = 0; c < 6; c++) {
        int piv = c;
        for (int r = c + 1; r < 6; r++)
            if (fabs(M[r][c]) > fabs(M[piv][c]))
                piv = r;
        if (!(fabs(M[piv][c]) > 1e-10 * trace))
            return -1;
        for (int j = 0; j < 7; j++) {
            double t = M[c][j];
            M[c][j] = M[piv][j];
            M[piv][j] = t;
        }
        for (int r = 0; r < 6; r++) {
            if (r == c)
                continue;
            double f = M[r][c] / M[c][c];
            for (int j = c; j < 7; j++)
                M[r][j] -= f * M[c][j];
        }
    }
    double z[6];
    for (int i = 0; i < 6; i++)
        z[i] = M[i][6] / M[i][i];
    for (size_t k = 0; k < n; k++) {
        double u = x[k] / sc, v = y[k] / sc;
        w[k] = z[0] + z[1] * u + z[2] * v + z[3] * u * u + z[4] * u * v + z[5] * v * v;
    }
    return 0;
}

static void outline_fit(uint32_t bands, const double *B, double *vertex_B, uint32_t v,
                        const vr_sample *s, size_t ns, double *scratch)
{
    double *x = scratch, *y = scratch + ns, *w = scratch + 2 * ns;
    for (size_t k = 0; k < ns; k++) {
        x[k] = s[k].x;
        y[k] = s[k].y;
    }
    rn_affine_weights(x, y, ns, w);
    for (uint32_t c = 0; c < bands; c++) {
        double bv = 0.0;
        for (size_t k = 0; k < ns; k++)
            bv += w[k] * (s[k].is_vertex ? vertex_B[(size_t)s[k].id * bands + c]
                                         : B[(size_t)s[k].id * bands + c]);
        /* v is the origin of the plane coordinates. */
        vertex_B[(size_t)v * bands + c] = bv > 0.0 ? bv : 0.0; /* NaN -> 0 too */
    }
}

/* The samples of one outline vertex v, each patch and interior vertex once
 * (stamps hold v + 1 once taken). */
typedef struct gather {
    vr_sample *s;
    double *scratch; /* 3 × cap: the fit's positions and weights */
    size_t n, cap;
    uint32_t *vstamp, *pstamp;
    int failed; /* out of memory: v keeps P(v) */
} gather;

static void gather_push(gather *g, double x, double y, uint32_t id, int is_vertex)
{
    if (g->n == g->cap) {
        size_t cap = g->cap ? 2 * g->cap : 64;
        vr_sample *s = realloc(g->s, cap * sizeof *s);
        if (s)
            g->s = s;
        double *w = realloc(g->scratch, 3 * cap * sizeof *w);
        if (w)
            g->scratch = w;
        if (!s || !w) {
            g->failed = 1;
            return;
        }
        g->cap = cap;
    }
    g->s[g->n++] = (vr_sample){x, y, id, is_vertex};
}

/* Adds patch q's centre and its interior corners to v's samples; returns the
 * number of interior vertices added other than q's centre. */
static size_t gather_patch(gather *g, const rad_mesh *m, const uint8_t *outline, uint32_t v,
                           uint32_t q, rad_vec3 e1, rad_vec3 e2)
{
    if (g->pstamp[q] == v + 1)
        return 0;
    g->pstamp[q] = v + 1;
    const rad_patch *pa = &m->patches[q];
    rad_vec3 pv = m->vertices[v], d = rad_sub(pa->center, pv);
    gather_push(g, rad_dot(d, e1), rad_dot(d, e2), q, 0);
    size_t added = 0;
    for (int c = 0; c < rad_patch_corners(pa); c++) {
        uint32_t w = pa->v[c];
        if (w == v || outline[w] || g->vstamp[w] == v + 1)
            continue;
        g->vstamp[w] = v + 1;
        d = rad_sub(m->vertices[w], pv);
        gather_push(g, rad_dot(d, e1), rad_dot(d, e2), w, 1);
        /* A fan's apex is the cell's own centre: no new direction. */
        added += !same_point(m->vertices[w], pa->center);
    }
    return added;
}

/* Interior vertex v by the quadratic fit (RN_FIT_QUADRATIC in render.h).
 * start/adj: vertex -> cells; seen (may be NULL): a stamp per cell, v + 1
 * once a cell was looked at for v (the two rings reach most cells several
 * times: skipping those changes no sample and saves comparing centres).
 * Returns -1, writing nothing, when no quadratic is determined (the
 * caller falls back to the affine fit). */
static int quadratic_vertex(const rad_mesh *mesh, const uint64_t *start, const uint32_t *adj,
                            uint32_t v, uint32_t bands, const double *B, double *vertex_B,
                            uint32_t *seen)
{
    enum { CAP = 256 }; /* more distinct centres than this: fall back */
    uint32_t id[CAP];
    size_t n = 0;
    for (uint64_t k = start[v]; k < start[v + 1]; k++) {
        const rad_patch *pa = &mesh->patches[adj[k]];
        for (int c = 0; c < rad_patch_corners(pa); c++) {
            uint32_t u = pa->v[c];
            for (uint64_t q = start[u]; q < start[u + 1]; q++) {
                if (seen && seen[adj[q]] == v + 1)
                    continue;
                if (seen)
                    seen[adj[q]] = v + 1;
                /* The cells of one fan share their element's centre: one
                 * sample each. */
                rad_vec3 b = mesh->patches[adj[q]].center;
                int dup = 0;
                for (size_t i = 0; i < n && !dup; i++)
                    dup = same_point(mesh->patches[id[i]].center, b);
                if (dup)
                    continue;
                if (n == CAP)
                    return -1;
                id[n++] = adj[q];
            }
        }
    }
    double x[CAP], y[CAP], w[CAP];
    rad_vec3 e1, e2;
    plane_basis(mesh->patches[adj[start[v]]].normal, &e1, &e2);
    for (size_t k = 0; k < n; k++) {
        rad_vec3 d = rad_sub(mesh->patches[id[k]].center, mesh->vertices[v]);
        x[k] = rad_dot(d, e1);
        y[k] = rad_dot(d, e2);
    }
    if (quadratic_weights(x, y, n, w) != 0)
        return -1;
    for (uint32_t c = 0; c < bands; c++) {
        double sum = 0, lo = INFINITY, hi = -INFINITY;
        for (size_t k = 0; k < n; k++)
            sum += w[k] * B[(size_t)id[k] * bands + c];
        for (uint64_t k = start[v]; k < start[v + 1]; k++) {
            lo = fmin(lo, B[(size_t)adj[k] * bands + c]);
            hi = fmax(hi, B[(size_t)adj[k] * bands + c]);
        }
        sum = sum >= lo ? fmin(sum, hi) : lo; /* NaN -> lo too */
        vertex_B[(size_t)v * bands + c] = sum > 0.0 ? sum : 0.0;
    }
    return 0;
}

void rn_vertex_radiosity(const rad_mesh *mesh, uint32_t bands, const double *B, double *vertex_B)
{
    rn_vertex_radiosity_fit(mesh, bands, B, vertex_B, RN_FIT_AFFINE);
}

/* Vertex -> patches adjacency (compressed rows): the patches using vertex v
 * are adj[start[v]..start[v + 1]), in patch order; both NULL when memory
 * runs out. */
static void vertex_adjacency(const rad_mesh *mesh, uint64_t **start_out, uint32_t **adj_out)
{
    uint32_t nv = mesh->vertex_count, np = mesh->patch_count;
    *start_out = NULL;
    *adj_out = NULL;
    uint64_t *start = calloc((size_t)nv + 1, sizeof *start);
    if (!start)
        return;
    for (uint32_t p = 0; p < np; p++) {
        const rad_patch *pa = &mesh->patches[p];
        if (!patch_valid(mesh, pa))
            continue;
        for (int k = 0; k < rad_patch_corners(pa); k++)
            start[pa->v[k] + 1]++;
    }
    for (uint32_t v = 0; v < nv; v++)
        start[v + 1] += start[v];
    uint32_t *adj = malloc((size_t)(start[nv] ? start[nv] : 1) * sizeof *adj);
    uint64_t *fill = malloc(((size_t)nv + 1) * sizeof *fill);
    if (!adj || !fill) {
        free(start);
        free(adj);
        free(fill);
        return;
    }
    memcpy(fill, start, ((size_t)nv + 1) * sizeof *fill);
    for (uint32_t p = 0; p < np; p++) {
        const rad_patch *pa = &mesh->patches[p];
        if (!patch_valid(mesh, pa))
            continue;
        for (int k = 0; k < rad_patch_corners(pa); k++)
            adj[fill[pa->v[k]]++] = p;
    }
    free(fill);
    *start_out = start;
    *adj_out = adj;
}

/* P(v): mean B of the patches using v, kept by an outline vertex until it
 * is extrapolated (outline_vertices).  An interior vertex takes, at v, the
 * affine function fitted by least squares to the centres of the patches
 * around it.  Around a vertex of a regular grid the centres are symmetric
 * and that is the paper's average; where cells of different sizes meet
 * (the T-vertices and corners of refined elements) the plain average is
 * off by about half a cell times the gradient, while the fit reproduces a
 * linear field exactly. */
static void interior_vertices(const rad_mesh *mesh, uint32_t bands, const double *B,
                              double *vertex_B, rn_vertex_fit how, const uint64_t *start,
                              const uint32_t *adj)
{
    uint32_t nv = mesh->vertex_count, np = mesh->patch_count;
    uint64_t most = 0;
    for (uint32_t v = 0; v < nv; v++)
        most = start[v + 1] - start[v] > most ? start[v + 1] - start[v] : most;
    double *fit = malloc(3 * (size_t)(most ? most : 1) * sizeof *fit);
    uint32_t *seen = how == RN_FIT_QUADRATIC ? calloc(np ? np : 1, sizeof *seen) : NULL;
    for (uint32_t v = 0; v < nv; v++) {
        uint64_t n = start[v + 1] - start[v];
        if (n == 0)
            continue;
        const int interior = !(mesh->vertex_boundary && mesh->vertex_boundary[v]);
        if (interior && how == RN_FIT_QUADRATIC &&
            rad_length(mesh->patches[adj[start[v]]].normal) > 0.0 &&
            quadratic_vertex(mesh, start, adj, v, bands, B, vertex_B, seen) == 0)
            continue;
        if (interior && fit && rad_length(mesh->patches[adj[start[v]]].normal) > 0.0) {
            double *x = fit, *y = fit + n, *w = fit + 2 * n;
            rad_vec3 e1, e2;
            plane_basis(mesh->patches[adj[start[v]]].normal, &e1, &e2);
            for (uint64_t k = 0; k < n; k++) {
                rad_vec3 d = rad_sub(mesh->patches[adj[start[v] + k]].center, mesh->vertices[v]);
                x[k] = rad_dot(d, e1);
                y[k] = rad_dot(d, e2);
            }
            rn_affine_weights(x, y, n, w);
            for (uint32_t c = 0; c < bands; c++) {
                double sum = 0;
                for (uint64_t k = 0; k < n; k++)
                    sum += w[k] * B[(size_t)adj[start[v] + k] * bands + c];
                vertex_B[(size_t)v * bands + c] = sum > 0.0 ? sum : 0.0; /* NaN -> 0 too */
            }
            continue;
        }
        for (uint32_t c = 0; c < bands; c++) {
            double sum = 0;
            for (uint64_t k = start[v]; k < start[v + 1]; k++)
                sum += B[(size_t)adj[k] * bands + c];
            double pv = sum / (double)n;
            vertex_B[(size_t)v * bands + c] = pv > 0.0 ? pv : 0.0;
        }
    }
    free(fit);
    free(seen);
}

/* Outline vertices, extrapolated from the interior values next to them
 * (outline_fit).  They read only interior values, which are final
 * already, so they can be overwritten in place. */
static void outline_vertices(const rad_mesh *mesh, uint32_t bands, const double *B,
                             double *vertex_B, const uint64_t *start, const uint32_t *adj)
{
    uint32_t nv = mesh->vertex_count, np = mesh->patch_count;
    const uint8_t *outline = mesh->vertex_boundary;
    gather g = {NULL, NULL, 0, 0, NULL, NULL, 0};
    if (outline) {
        g.vstamp = calloc(nv, sizeof *g.vstamp);
        g.pstamp = calloc(np, sizeof *g.pstamp);
    }
    for (uint32_t v = 0; outline && g.vstamp && g.pstamp && v < nv; v++) {
        if (!outline[v] || start[v + 1] == start[v])
            continue;
        rad_vec3 n = mesh->patches[adj[start[v]]].normal;
        if (!(rad_length(n) > 0.0))
            continue; /* keep P(v) */
        rad_vec3 e1, e2;
        plane_basis(n, &e1, &e2);
        g.n = 0;
        g.failed = 0;
        size_t interior = 0;
        for (uint64_t k = start[v]; k < start[v + 1]; k++)
            interior += gather_patch(&g, mesh, outline, v, adj[k], e1, e2);
        /* No interior vertex next to v (the sharp corner of a triangle
         * polygon, say): look one ring further, through v's neighbours. */
        for (uint64_t k = start[v]; interior == 0 && k < start[v + 1]; k++) {
            const rad_patch *pa = &mesh->patches[adj[k]];
            for (int c = 0; c < rad_patch_corners(pa); c++) {
                uint32_t u = pa->v[c];
                for (uint64_t q = start[u]; u != v && q < start[u + 1]; q++)
                    interior += gather_patch(&g, mesh, outline, v, adj[q], e1, e2);
            }
        }
        if (interior > 0 && !g.failed)
            outline_fit(bands, B, vertex_B, v, g.s, g.n, g.scratch);
    }
    free(g.s);
    free(g.scratch);
    free(g.vstamp);
    free(g.pstamp);
}

void rn_vertex_radiosity_fit(const rad_mesh *mesh, uint32_t bands, const double *B,
                             double *vertex_B, rn_vertex_fit how)
{
    if (!mesh || !vertex_B || bands == 0 || bands > RAD_MAX_BANDS)
        return;
    uint32_t nv = mesh->vertex_count, np = mesh->patch_count;
    for (size_t k = 0; k < (size_t)nv * bands; k++)
        vertex_B[k] = 0.0;
    if (!B || nv == 0 || np == 0 || !mesh->patches || !mesh->vertices)
        return;
    /* Allocation failure leaves every vertex at 0: the function has no
     * error channel, and 0 is the one value that cannot be mistaken for
     * light. */
    uint64_t *start;
    uint32_t *adj;
    vertex_adjacency(mesh, &start, &adj);
    if (!start)
        return;
    interior_vertices(mesh, bands, B, vertex_B, how, start, adj);
    outline_vertices(mesh, bands, B, vertex_B, start, adj);
    free(start);
    free(adj);
}

/* ---------------------------------------------------------------- camera */

int rn_camera_frame(const rn_camera *cam, rn_frame *fr, rad_error *err)
{
    if (!cam)
        return rad_fail(err, RAD_ERR_USAGE, "render: camera: none given");
    fr->ortho = cam->orthographic != 0;
    if (!rad_finite3(cam->eye) || !rad_finite3(cam->target) || !rad_finite3(cam->up) ||
        (!fr->ortho && !isfinite(cam->yfov_deg)))
        return rad_fail(err, RAD_ERR_USAGE, "render: camera: eye, target, up and fov must be finite");
    if (fr->ortho && !(cam->ymag > 0.0 && isfinite(cam->ymag)))
        return rad_fail(err, RAD_ERR_USAGE,
                        "render: camera: orthographic half-height %g must be finite and > 0",
                        cam->ymag);
    if (!fr->ortho && !(cam->yfov_deg > 0.0 && cam->yfov_deg < 180.0))
        return rad_fail(err, RAD_ERR_USAGE, "render: camera: field of view %g not in (0, 180) degrees",
                        cam->yfov_deg);
    if (cam->width < 1 || cam->height < 1 || cam->width > RN_MAX_SIDE || cam->height > RN_MAX_SIDE)
        return rad_fail(err, RAD_ERR_USAGE, "render: camera: image size %ux%u outside 1..%u",
                        cam->width, cam->height, RN_MAX_SIDE);
    rad_vec3 d = rad_sub(cam->target, cam->eye);
    double dl = rad_length(d);
    if (!(dl > 0.0) || !isfinite(dl))
        return rad_fail(err, RAD_ERR_USAGE, "render: camera: eye and target coincide");
    double ul = rad_length(cam->up);
    if (!(ul > 0.0) || !isfinite(ul))
        return rad_fail(err, RAD_ERR_USAGE, "render: camera: up vector is zero");
    fr->f = rad_scale(d, 1.0 / dl);
    rad_vec3 r = rad_cross(fr->f, rad_scale(cam->up, 1.0 / ul));
    /* |r| = sin of the angle between up and the view direction. */
    if (!(rad_length(r) > 1e-9))
        return rad_fail(err, RAD_ERR_USAGE, "render: camera: up vector parallel to the view direction");
    fr->r = rad_normalize(r);
    fr->u = rad_cross(fr->r, fr->f);
    fr->eye = cam->eye;
    fr->w = cam->width;
    fr->h = cam->height;
    fr->cx = 0.5 * cam->width;
    fr->cy = 0.5 * cam->height;
    if (fr->ortho) {
        fr->k = fr->cy / cam->ymag;
        if (!(fr->k > 0.0) || !isfinite(fr->k))
            return rad_fail(err, RAD_ERR_USAGE, "render: camera: orthographic half-height %g unusable",
                            cam->ymag);
        return RAD_OK;
    }
    fr->k = fr->cy / tan(0.5 * cam->yfov_deg * (M_PI / 180.0));
    if (!(fr->k > 0.0) || !isfinite(fr->k))
        return rad_fail(err, RAD_ERR_USAGE, "render: camera: field of view %g unusable", cam->yfov_deg);
    return RAD_OK;
}

/* ------------------------------------------------------------ clipping */

/* Half-space a·x + b·y + c·z + d >= 0 in camera coordinates. */
typedef struct plane4 {
    double a, b, c, d;
} plane4;

static double plane_dist(const plane4 *p, rad_vec3 v) { return p->a * v.x + p->b * v.y + p->c * v.z + p->d; }

static int vec_less(rad_vec3 a, rad_vec3 b)
{
    if (a.x != b.x)
        return a.x < b.x;
    if (a.y != b.y)
        return a.y < b.y;
    return a.z < b.z;
}

/* The crossing point is computed from the edge's endpoints in a canonical
 * order, so the two patches sharing an edge get bit-identical points and the
 * shared edge stays shared after clipping (no cracks). */
static rad_vec3 clip_cross(rad_vec3 a, rad_vec3 b, const plane4 *p)
{
    if (vec_less(b, a)) {
        rad_vec3 t = a;
        a = b;
        b = t;
    }
    double da = plane_dist(p, a), db = plane_dist(p, b);
    return rad_lerp(a, b, da / (da - db));
}

/* Sutherland-Hodgman against one plane; returns the new corner count, 0 when
 * nothing is left or the buffer would overflow. */
static int clip_polygon(const rad_vec3 *in, int n, rad_vec3 *out, const plane4 *p)
{
    int m = 0;
    for (int i = 0; i < n; i++) {
        rad_vec3 a = in[i], b = in[(i + 1) % n];
        int ina = plane_dist(p, a) >= 0.0, inb = plane_dist(p, b) >= 0.0;
        if (m + 2 > CLIP_MAX)
            return 0;
        if (ina)
            out[m++] = a;
        if (ina != inb)
            out[m++] = clip_cross(a, b, p);
    }
    return m;
}

/* --------------------------------------------------------- item buffer */

/* llround(x) for |x| < 2^52 without the libm call: x − trunc(x) is exact
 * there, so rounding half away from zero is a comparison with ±0.5. */
static inline int64_t round_half_away(double x)
{
    int64_t t = (int64_t)x;
    double f = x - (double)t;
    return t + (f >= 0.5) - (f <= -0.5);
}

typedef struct ibuf {
    double *invz;  /* 1/z of the nearest surface so far; 0 = none (background) */
    uint32_t *id;  /* its patch */
    uint32_t w, h;
} ibuf;

/* 1/z over the image for one patch's plane: invz(i, j) = A·i + Bj·j + C, from
 * the ray-plane intersection (exact perspective-correct depth). */
typedef struct depth_plane {
    double A, Bj, C;
} depth_plane;

static int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

/* Top-left rule in y-down screen coordinates with the triangle wound so that
 * edge functions are positive inside: pixels exactly on an edge belong to it
 * only when it is a top edge (horizontal, going right) or a left edge (going
 * up).  The reversed edge of the neighbour gets the complementary answer. */
static int64_t edge_bias(int64_t dx, int64_t dy) { return (dy < 0 || (dy == 0 && dx > 0)) ? 0 : -1; }

/* Narrows [*lo, *hi] (offsets from the row's first pixel) to where
 * e + s·t >= 0; 0 when nothing is left. */
static inline int edge_run(int64_t e, int64_t s, int64_t *lo, int64_t *hi)
{
    if (s > 0) {
        int64_t t = e >= 0 ? 0 : -floor_div(e, s); /* ceil(−e / s) */
        if (t > *lo)
            *lo = t;
    } else if (s < 0) {
        if (e < 0)
            return 0;
        int64_t t = e / -s; /* floor(e / −s), e >= 0 */
        if (t < *hi)
            *hi = t;
    } else if (e < 0) {
        return 0;
    }
    return *lo <= *hi;
}

static void raster_triangle(ibuf *ib, const int64_t *X, const int64_t *Y, int i0, int i1, int i2,
                            uint32_t pid, const depth_plane *dp)
{
    int64_t x0 = X[i0], y0 = Y[i0], x1 = X[i1], y1 = Y[i1], x2 = X[i2], y2 = Y[i2];
    int64_t area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0);
    if (area == 0)
        return;
    if (area < 0) { /* the 3-D test already culled back faces; only snapping can flip */
        int64_t t = x1;
        x1 = x2;
        x2 = t;
        t = y1;
        y1 = y2;
        y2 = t;
    }
    int64_t xmin = x0 < x1 ? (x0 < x2 ? x0 : x2) : (x1 < x2 ? x1 : x2);
    int64_t xmax = x0 > x1 ? (x0 > x2 ? x0 : x2) : (x1 > x2 ? x1 : x2);
    int64_t ymin = y0 < y1 ? (y0 < y2 ? y0 : y2) : (y1 < y2 ? y1 : y2);
    int64_t ymax = y0 > y1 ? (y0 > y2 ? y0 : y2) : (y1 > y2 ? y1 : y2);
    /* Pixel i's centre is at i·SUBPIX + SUBPIX/2. */
    int64_t ia = -floor_div(-(xmin - SUBPIX / 2), SUBPIX), ib_ = floor_div(xmax - SUBPIX / 2, SUBPIX);
    int64_t ja = -floor_div(-(ymin - SUBPIX / 2), SUBPIX), jb = floor_div(ymax - SUBPIX / 2, SUBPIX);
    if (ia < 0)
        ia = 0;
    if (ja < 0)
        ja = 0;
    if (ib_ > (int64_t)ib->w - 1)
        ib_ = (int64_t)ib->w - 1;
    if (jb > (int64_t)ib->h - 1)
        jb = (int64_t)ib->h - 1;
    if (ia > ib_ || ja > jb)
        return;

    int64_t dx0 = x1 - x0, dy0 = y1 - y0, dx1 = x2 - x1, dy1 = y2 - y1, dx2 = x0 - x2, dy2 = y0 - y2;
    int64_t b0 = edge_bias(dx0, dy0), b1 = edge_bias(dx1, dy1), b2 = edge_bias(dx2, dy2);
    int64_t px0 = ia * SUBPIX + SUBPIX / 2;
    /* Along a row an edge function is e(i) = e(ia) + s·(i − ia), s = −dy·SUBPIX:
     * the pixels inside all three edges are one run [lo, hi], found with a
     * division per edge instead of a test per pixel (the same pixels). */
    int64_t s0 = -dy0 * SUBPIX, s1 = -dy1 * SUBPIX, s2 = -dy2 * SUBPIX;
    for (int64_t j = ja; j <= jb; j++) {
        int64_t py = j * SUBPIX + SUBPIX / 2;
        int64_t e0 = dx0 * (py - y0) - dy0 * (px0 - x0) + b0;
        int64_t e1 = dx1 * (py - y1) - dy1 * (px0 - x1) + b1;
        int64_t e2 = dx2 * (py - y2) - dy2 * (px0 - x2) + b2;
        int64_t lo = 0, hi = ib_ - ia;
        if (!edge_run(e0, s0, &lo, &hi) || !edge_run(e1, s1, &lo, &hi) ||
            !edge_run(e2, s2, &lo, &hi))
            continue;
        size_t row = (size_t)j * ib->w;
        for (int64_t i = ia + lo; i <= ia + hi; i++) {
            double z = dp->A * (double)i + dp->Bj * (double)j + dp->C;
            size_t k = row + (size_t)i;
            /* Nearer wins; on equal depth the lower patch index. */
            if (z > 0.0 && (z > ib->invz[k] || (z == ib->invz[k] && pid < ib->id[k]))) {
                ib->invz[k] = z;
                ib->id[k] = pid;
            }
        }
    }
}

/* ------------------------------------------------------- interpolation */

/* h = l1·a + l2·b solved by Cramer's rule, det = a × b: c becomes linear
 * with (l1, l2) = lin·h, unless det is 0. */
static void cell_linear(rn_cell2d *c, double det, double ax, double ay, double bx, double by)
{
    if (det == 0.0)
        return;
    double id = 1.0 / det;
    c->linear = 1;
    c->lin[0][0] = by * id;
    c->lin[0][1] = -bx * id;
    c->lin[1][0] = -ay * id;
    c->lin[1][1] = ax * id;
}

void rn_cell2d_init(rn_cell2d *c, const rad_mesh *m, uint32_t cell)
{
    const rad_patch *pa = &m->patches[cell];
    c->corners = rad_patch_corners(pa);
    c->linear = 0; /* a cached cell is initialised over an older one */
    c->v0 = m->vertices[pa->v[0]];
    c->e1 = rad_normalize(rad_sub(m->vertices[pa->v[1]], c->v0));
    c->e2 = rad_cross(pa->normal, c->e1);
    for (int k = 0; k < c->corners; k++) {
        rad_vec3 q = rad_sub(m->vertices[pa->v[k]], c->v0);
        c->p[k][0] = rad_dot(q, c->e1);
        c->p[k][1] = rad_dot(q, c->e2);
    }
    if (c->corners == 4) {
        c->ex = c->p[1][0];
        c->ey = c->p[1][1];
        c->fx = c->p[3][0];
        c->fy = c->p[3][1];
        c->gx = -c->p[1][0] + c->p[2][0] - c->p[3][0];
        c->gy = -c->p[1][1] + c->p[2][1] - c->p[3][1];
        c->k2 = c->gx * c->fy - c->gy * c->fx;
        c->kef = c->ex * c->fy - c->ey * c->fx;
        /* Subdivided rectangles and parallelograms are parallelograms only
         * up to rounding (|g| ~ 1e-16 of a side): below 1e-10 of the sides
         * g is taken as 0, so (u, v) is linear in h.  What that ignores
         * moves u and v by under 1e-10, far below a float pixel's 6e-8. */
        double side = fabs(c->ex) + fabs(c->ey) + fabs(c->fx) + fabs(c->fy);
        if (fabs(c->gx) + fabs(c->gy) <= 1e-10 * side) /* h = u·e + v·f */
            cell_linear(c, c->kef, c->ex, c->ey, c->fx, c->fy);
    } else {
        c->det = c->p[1][0] * c->p[2][1] - c->p[1][1] * c->p[2][0];
        /* h = w1·p1 + w2·p2 */
        cell_linear(c, c->det, c->p[1][0], c->p[1][1], c->p[2][0], c->p[2][1]);
    }
}

/* (u, v) of the plane point h in the quad: h = u·e + v·f + u·v·g.
 * Eliminating u gives k2·v² + k1·v + k0 = 0, solved in the
 * cancellation-free form (k2 = 0, g parallel to f, falls out as
 * v = −k0/k1; parallelograms never get here, rn_cell2d_init made them
 * linear); the root nearest [0, 1] is taken, then u by projection on
 * e + v·g.  Both are clamped to [0, 1]: a pixel centre may sit a snapping
 * error outside the patch that owns it, and clamping keeps B a convex
 * combination of the corner values (never negative). */
static void inverse_bilinear(const rn_cell2d *s, double hx, double hy, double *uo, double *vo)
{
    double k1 = s->kef + hx * s->gy - hy * s->gx;
    double k0 = hx * s->ey - hy * s->ex;
    if (s->k2 == 0.0 && k1 != 0.0) { /* linear in v, no root to pick */
        double v = -k0 / k1;
        v = v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0;
        double ax = s->ex + s->gx * v, ay = s->ey + s->gy * v, den = ax * ax + ay * ay;
        double u = den > 0.0 ? ((hx - s->fx * v) * ax + (hy - s->fy * v) * ay) / den : 0.5;
        u = u >= 0.0 ? u : 0.0;
        *uo = u > 1.0 ? 1.0 : u;
        *vo = v;
        return;
    }
    double disc = k1 * k1 - 4.0 * k0 * s->k2;
    double q = -0.5 * (k1 + copysign(sqrt(disc > 0.0 ? disc : 0.0), k1));
    double cand[2] = {NAN, NAN}, v = 0.5, best = INFINITY;
    if (s->k2 != 0.0)
        cand[0] = q / s->k2;
    if (q != 0.0)
        cand[1] = k0 / q;
    for (int c = 0; c < 2; c++) {
        if (!isfinite(cand[c]))
            continue;
        double out = cand[c] < 0.0 ? -cand[c] : cand[c] > 1.0 ? cand[c] - 1.0 : 0.0;
        if (out < best) {
            best = out;
            v = cand[c];
        }
    }
    v = v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v;
    double ax = s->ex + s->gx * v, ay = s->ey + s->gy * v, den = ax * ax + ay * ay;
    double u = den > 0.0 ? ((hx - s->fx * v) * ax + (hy - s->fy * v) * ay) / den : 0.5;
    u = u >= 0.0 ? u : 0.0; /* NaN too */
    *uo = u > 1.0 ? 1.0 : u;
    *vo = v;
}

/* The bilinear weights at (u, v), clamped to the cell (NaN to 0). */
static inline void quad_weights(double u, double v, double *w)
{
    u = u > 0.0 ? (u < 1.0 ? u : 1.0) : 0.0;
    v = v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0;
    w[0] = (1 - u) * (1 - v);
    w[1] = u * (1 - v);
    w[2] = u * v;
    w[3] = (1 - u) * v;
}

/* The barycentric weights (1 − w1 − w2, w1, w2); a point outside (a
 * snapping error away) is clamped and renormalised. */
static inline void tri_weights(double w1, double w2, double *w)
{
    double w0 = 1.0 - w1 - w2;
    if (w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0) { /* inside (no NaN): sums to 1 by construction */
        w[0] = w0;
        w[1] = w1;
        w[2] = w2;
        return;
    }
    w0 = w0 > 0.0 ? w0 : 0.0;
    w1 = w1 > 0.0 ? w1 : 0.0;
    w2 = w2 > 0.0 ? w2 : 0.0;
    double sum = w0 + w1 + w2;
    if (!(sum > 0.0) || !isfinite(sum))
        w0 = w1 = w2 = sum = 1.0;
    w[0] = w0 / sum;
    w[1] = w1 / sum;
    w[2] = w2 / sum;
}

/* The weights from a linear cell's coordinates (l1, l2).  Coordinates
 * that are not finite (a ray grazing the plane) need no test: the clamps
 * above still give weights in [0, 1] summing to 1. */
static inline void linear_weights(const rn_cell2d *s, double l1, double l2, double *w)
{
    if (s->corners == 4)
        quad_weights(l1, l2, w);
    else
        tri_weights(l1, l2, w);
}

/* rn_cell2d_weights's body, inline: the shading loop calls it per pixel. */
static inline void cell2d_weights(const rn_cell2d *s, double hx, double hy, double *w)
{
    if (!isfinite(hx) || !isfinite(hy))
        hx = hy = 0.0;
    if (s->linear) {
        linear_weights(s, s->lin[0][0] * hx + s->lin[0][1] * hy,
                       s->lin[1][0] * hx + s->lin[1][1] * hy, w);
    } else if (s->corners == 4) {
        double u, v;
        inverse_bilinear(s, hx, hy, &u, &v);
        quad_weights(u, v, w);
    } else {
        tri_weights(1.0 / 3.0, 1.0 / 3.0, w);
    }
}

void rn_cell2d_weights(const rn_cell2d *s, double hx, double hy, double *w)
{
    cell2d_weights(s, hx, hy, w);
}

/* What shading one patch needs, prepared once per patch and view (kept in
 * the canvas's setup cache, see SHADE_CACHE).  For the pixel ray
 * d = f + a·r + b·u every needed dot product is affine in (a, b), so a pixel
 * costs a few multiply-adds before (u, v). */
typedef struct shade_setup {
    uint32_t patch;        /* RAD_NONE: empty cache slot */
    rn_cell2d cell;
    double *cB;            /* the corners' vertex radiosities, cB[q·bands + c] */
    int ortho;             /* rays parallel to f from the window, not from the eye */
    double Dn;             /* n·(centre − eye) */
    double nf, nr, nu;     /* n·f, n·r, n·u */
    double of1, of2;       /* (eye − v0)·e1, ·e2 */
    double f1, r1, u1;     /* f·e1, r·e1, u·e1 */
    double f2, r2, u2;     /* f·e2, r·e2, u·e2 */
    /* A linear cell seen in perspective: its coordinates are
     * l_k = L[k][0] + t·(L[k][1] + a·L[k][2] + b·L[k][3]), t = Dn / (n·d). */
    int linear;
    double L[2][4];
} shade_setup;

static void shade_prepare(shade_setup *s, const rad_mesh *m, uint32_t patch, const rn_frame *fr,
                          const double *vertex_B, uint32_t bands)
{
    const rad_patch *pa = &m->patches[patch];
    for (int q = 0; q < rad_patch_corners(pa); q++)
        memcpy(s->cB + (size_t)q * bands, vertex_B + (size_t)pa->v[q] * bands,
               bands * sizeof *s->cB);
    rn_cell2d_init(&s->cell, m, patch);
    rad_vec3 n = pa->normal, e1 = s->cell.e1, e2 = s->cell.e2;
    rad_vec3 o = rad_sub(fr->eye, s->cell.v0);
    s->patch = patch;
    s->ortho = fr->ortho;
    s->Dn = rad_dot(n, rad_sub(pa->center, fr->eye));
    s->nf = rad_dot(n, fr->f);
    s->nr = rad_dot(n, fr->r);
    s->nu = rad_dot(n, fr->u);
    s->of1 = rad_dot(o, e1);
    s->of2 = rad_dot(o, e2);
    s->f1 = rad_dot(fr->f, e1);
    s->r1 = rad_dot(fr->r, e1);
    s->u1 = rad_dot(fr->u, e1);
    s->f2 = rad_dot(fr->f, e2);
    s->r2 = rad_dot(fr->r, e2);
    s->u2 = rad_dot(fr->u, e2);
    s->linear = !s->ortho && s->cell.linear;
    for (int k = 0; k < 2 && s->linear; k++) {
        double mx = s->cell.lin[k][0], my = s->cell.lin[k][1];
        s->L[k][0] = mx * s->of1 + my * s->of2;
        s->L[k][1] = mx * s->f1 + my * s->f2;
        s->L[k][2] = mx * s->r1 + my * s->r2;
        s->L[k][3] = mx * s->u1 + my * s->u2;
    }
}

/* Interpolation weights of the patch's corners where the ray of pixel
 * (a, b) meets its plane (from the eye along f + a·r + b·u, or, for an
 * orthographic view, from eye + a·r + b·u along f). */
static inline void shade_weights(const shade_setup *s, double a, double b, double *w)
{
    if (s->linear) { /* the plane point's two coordinates, without the point */
        double dn = s->nf + a * s->nr + b * s->nu;
        double t = dn != 0.0 ? s->Dn / dn : 0.0;
        double l1 = s->L[0][0] + t * (s->L[0][1] + a * s->L[0][2] + b * s->L[0][3]);
        double l2 = s->L[1][0] + t * (s->L[1][1] + a * s->L[1][2] + b * s->L[1][3]);
        linear_weights(&s->cell, l1, l2, w);
        return;
    }
    double hx, hy;
    if (s->ortho) { /* eye + a·r + b·u + t·f */
        double t = s->nf != 0.0 ? (s->Dn - a * s->nr - b * s->nu) / s->nf : 0.0;
        hx = s->of1 + a * s->r1 + b * s->u1 + t * s->f1;
        hy = s->of2 + a * s->r2 + b * s->u2 + t * s->f2;
    } else { /* eye + t·(f + a·r + b·u) */
        double dn = s->nf + a * s->nr + b * s->nu;
        double t = dn != 0.0 ? s->Dn / dn : 0.0;
        hx = s->of1 + t * (s->f1 + a * s->r1 + b * s->u1);
        hy = s->of2 + t * (s->f2 + a * s->r2 + b * s->u2);
    }
    cell2d_weights(&s->cell, hx, hy, w);
}

/* px = Σ_q w_q B_q / π per band, the corners summed in order.  Three
 * bands (the common case) are written out, the compiler does not unroll
 * the loop; the arithmetic is the same either way. */
static inline double corner_sum(const double *w, const double *cB, uint32_t bands, int corners,
                                uint32_t c)
{
    double sum = 0.0;
    sum += w[0] * cB[c];
    sum += w[1] * cB[bands + c];
    sum += w[2] * cB[2 * bands + c];
    if (corners == 4)
        sum += w[3] * cB[3 * bands + c];
    return sum;
}

static inline void shade_store(float *px, const double *w, const double *cB, uint32_t bands,
                               int corners, double inv_pi)
{
    if (bands == 3) {
        px[0] = (float)(corner_sum(w, cB, 3, corners, 0) * inv_pi);
        px[1] = (float)(corner_sum(w, cB, 3, corners, 1) * inv_pi);
        px[2] = (float)(corner_sum(w, cB, 3, corners, 2) * inv_pi);
        return;
    }
    for (uint32_t c = 0; c < bands; c++)
        px[c] = (float)(corner_sum(w, cB, bands, corners, c) * inv_pi);
}

/* -------------------------------------------------------------- render */

int rn_mesh_check(const rad_mesh *m, rad_error *err)
{
    if (m->vertex_count > 0 && !m->vertices)
        return rad_fail(err, RAD_ERR_USAGE, "render: mesh: %u vertices but no vertex array", m->vertex_count);
    if (m->patch_count > 0 && !m->patches)
        return rad_fail(err, RAD_ERR_USAGE, "render: mesh: %u patches but no patch array", m->patch_count);
    for (uint32_t v = 0; v < m->vertex_count; v++)
        if (!rad_finite3(m->vertices[v]))
            return rad_fail(err, RAD_ERR_INVALID, "render: mesh: vertex %u is not finite", v);
    for (uint32_t p = 0; p < m->patch_count; p++) {
        const rad_patch *pa = &m->patches[p];
        if (!patch_valid(m, pa))
            return rad_fail(err, RAD_ERR_INVALID,
                            "render: mesh: patch %u: vertex index out of range (%u vertices)", p,
                            m->vertex_count);
        if (!rad_finite3(pa->normal) || !rad_finite3(pa->center))
            return rad_fail(err, RAD_ERR_INVALID, "render: mesh: patch %u: normal or centre not finite", p);
    }
    return RAD_OK;
}

int rn_camera_check(const rn_camera *cam, rad_error *err)
{
    rn_frame fr;
    rad_error why;
    int rc = rn_camera_frame(cam, &fr, &why);
    if (!rc)
        return RAD_OK;
    /* The reason alone: the caller says which camera. */
    const char *prefix = "render: camera: ";
    size_t n = strlen(prefix);
    return rad_fail(err, rc, "%s", strncmp(why.message, prefix, n) ? why.message : why.message + n);
}

/* Shading setups kept per view, direct-mapped by patch index: a patch is
 * met again on the next rows of the image, by which time a scan line has
 * passed hundreds to thousands of others (element fans at 1024²: 512 slots
 * made rn_cell2d_init 8 % of a ten-view render, 4096 make it 3 % and the
 * call 11 % faster; under 2 MB a canvas).  A setup is a pure function of
 * the patch and the view, so a hit gives exactly what preparing it again
 * would. */
#define SHADE_CACHE 4096

/* What a canvas keeps between views: the image drawn last, its depth buffer
 * (1/z per pixel), room for the camera-space vertices and the shading
 * setups (emptied at each view). */
struct rn_canvas {
    rn_image *img;
    double *invz;      /* img->width × img->height */
    rad_vec3 *cv;      /* cv_cap entries */
    uint32_t cv_cap;
    shade_setup *setup; /* SHADE_CACHE entries, each with 4 × setup_bands corner values */
    double *setup_B;
    uint32_t setup_bands;
    double *acol;       /* acol_cap entries: each column's ray coordinate a */
    uint32_t acol_cap;
};

rn_canvas *rn_canvas_create(void) { return calloc(1, sizeof(rn_canvas)); }

void rn_canvas_destroy(rn_canvas *c)
{
    if (!c)
        return;
    rn_image_destroy(c->img);
    free(c->invz);
    free(c->cv);
    free(c->setup);
    free(c->setup_B);
    free(c->acol);
    free(c);
}

/* Makes c's buffers fit a w×h image of `bands` channels and a mesh of nv
 * vertices, and clears them: every pixel's patch RAD_NONE, every depth 0
 * (at infinity); a kept image's radiance is left to the shading pass, which
 * writes every pixel (0 for the background).  Buffers of the right size are
 * kept; new ones are written here first, so each page is faulted in once,
 * not read as the shared zero page and copied on the first depth test. */
static int canvas_prepare(rn_canvas *c, uint32_t w, uint32_t h, uint32_t bands, uint32_t nv,
                          rad_error *err)
{
    size_t npix = (size_t)w * h;
    rn_image *img = c->img;
    if (!img || img->width != w || img->height != h || img->channels != bands) {
        uint64_t need = (uint64_t)npix * (4u * bands + sizeof(uint32_t) + sizeof(double)) +
                        (uint64_t)nv * sizeof(rad_vec3);
        uint64_t avail = rad_available_memory();
        if (avail && need > avail)
            return rad_fail(err, RAD_ERR_LIMIT,
                            "render: a %ux%u image of %u bands needs %llu bytes, %llu available", w,
                            h, bands, (unsigned long long)need, (unsigned long long)avail);
        rn_image_destroy(c->img);
        free(c->invz);
        c->img = NULL;
        c->invz = malloc(npix * sizeof *c->invz);
        img = c->invz ? rn_image_alloc(w, h, bands) : NULL;
        if (!img)
            return rad_fail(err, RAD_ERR_NOMEM, "render: out of memory for a %ux%u image", w, h);
        c->img = img;
    } else { /* the pixels: every one is written by the shading pass */
        for (size_t k = 0; k < npix; k++)
            img->patch[k] = RAD_NONE;
    }
    memset(c->invz, 0, npix * sizeof *c->invz);
    if (c->cv_cap < nv + 1) {
        free(c->cv);
        c->cv_cap = 0;
        c->cv = malloc(((size_t)nv + 1) * sizeof *c->cv);
        if (!c->cv)
            return rad_fail(err, RAD_ERR_NOMEM, "render: out of memory for %u vertices", nv);
        c->cv_cap = nv + 1;
    }
    if (!c->setup || c->setup_bands != bands) {
        free(c->setup);
        free(c->setup_B);
        c->setup_bands = 0;
        c->setup = malloc(SHADE_CACHE * sizeof *c->setup);
        c->setup_B = malloc((size_t)SHADE_CACHE * 4 * bands * sizeof *c->setup_B);
        if (!c->setup || !c->setup_B)
            return rad_fail(err, RAD_ERR_NOMEM, "render: out of memory for shading");
        c->setup_bands = bands;
        for (size_t e = 0; e < SHADE_CACHE; e++)
            c->setup[e].cB = c->setup_B + e * 4 * bands;
    }
    for (size_t e = 0; e < SHADE_CACHE; e++)
        c->setup[e].patch = RAD_NONE;
    if (c->acol_cap < w) {
        free(c->acol);
        c->acol_cap = 0;
        c->acol = malloc((size_t)w * sizeof *c->acol);
        if (!c->acol)
            return rad_fail(err, RAD_ERR_NOMEM, "render: out of memory for a %u-pixel row", w);
        c->acol_cap = w;
    }
    return RAD_OK;
}

int rn_render(const rad_mesh *mesh, uint32_t bands, const double *vertex_B, const rn_camera *cam,
              rn_image **out, rad_error *err)
{
    if (!out)
        return rad_fail(err, RAD_ERR_USAGE, "render: no output pointer");
    *out = NULL;
    rn_canvas *c = rn_canvas_create();
    if (!c)
        return rad_fail(err, RAD_ERR_NOMEM, "render: out of memory");
    int rc = rn_canvas_draw(c, mesh, bands, vertex_B, cam, out, err);
    if (!rc)
        c->img = NULL; /* the caller takes the image, the rest goes */
    rn_canvas_destroy(c);
    return rc;
}

/* The mesh's vertices in camera space (x right, y up, z forward), once
 * each so shared corners stay identical; returns their largest coordinate,
 * the scene's extent seen from the eye. */
static double camera_vertices(const rad_mesh *mesh, const rn_frame *fr, rad_vec3 *cv)
{
    double extent = 0.0;
    for (uint32_t v = 0; v < mesh->vertex_count; v++) {
        rad_vec3 d = rad_sub(mesh->vertices[v], fr->eye);
        cv[v] = rad_v3(rad_dot(d, fr->r), rad_dot(d, fr->u), rad_dot(d, fr->f));
        double a = fmax(fabs(cv[v].x), fmax(fabs(cv[v].y), fabs(cv[v].z)));
        if (a > extent)
            extent = a;
    }
    return extent;
}

/* Fills the item buffer ib (depth, patch id): every front-facing patch
 * clipped (near plane, guard band), projected, snapped and rasterised. */
static void draw_items(const rad_mesh *mesh, const rn_frame *fr, const rad_vec3 *cv,
                       double extent, ibuf *ib)
{
    double znear = extent * NEAR_FRACTION;
    if (!(znear > DBL_MIN))
        znear = DBL_MIN;

    /* Near plane, then a guard band one image size wide around the screen:
     * it bounds the snapped coordinates (|x| < 3·16384 < 2^16 pixels) so the
     * edge functions are exact in int64, and the cuts it makes lie off screen.
     * A perspective band scales with z (sx = cx + k·x/z), an orthographic
     * one does not (sx = cx + k·x): its constant goes to the z or the 1
     * coefficient. */
    double G = fr->w > fr->h ? fr->w : fr->h;
    double zc = fr->ortho ? 0.0 : 1.0, oc = fr->ortho ? 1.0 : 0.0;
    plane4 planes[5] = {
        {0, 0, 1, -znear},
        {fr->k, 0, zc * (fr->cx + G), oc * (fr->cx + G)},                  /* sx >= -G */
        {-fr->k, 0, zc * (fr->w + G - fr->cx), oc * (fr->w + G - fr->cx)}, /* sx <= W + G */
        {0, -fr->k, zc * (fr->cy + G), oc * (fr->cy + G)},                 /* sy >= -G */
        {0, fr->k, zc * (fr->h + G - fr->cy), oc * (fr->h + G - fr->cy)},  /* sy <= H + G */
    };
    /* Orthographic depth: zfar − z, positive for everything in front of
     * the eye up to the scene's extent, so that "larger is nearer" and "0
     * is background" hold as for 1/z. */
    double zfar = 2.0 * extent > DBL_MIN ? 2.0 * extent : 1.0;

    rad_vec3 bufa[CLIP_MAX], bufb[CLIP_MAX];
    int64_t X[CLIP_MAX], Y[CLIP_MAX];
    for (uint32_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *pa = &mesh->patches[p];
        rad_vec3 n = pa->normal;
        /* One-sided patch: seen only from the side its normal points to. */
        double Dn = rad_dot(n, rad_sub(pa->center, fr->eye));
        double nf = rad_dot(n, fr->f), nr = rad_dot(n, fr->r), nu = rad_dot(n, fr->u);
        if (fr->ortho ? !(nf < 0.0) : !(Dn < 0.0))
            continue;
        depth_plane dp;
        if (fr->ortho) { /* zfar − z, z = (Dn − x·nr − y·nu)/nf */
            double q = 1.0 / (fr->k * nf);
            dp = (depth_plane){nr * q, -nu * q,
                               zfar - Dn / nf + (0.5 - fr->cx) * nr * q +
                                   (fr->cy - 0.5) * nu * q};
        } else {
            dp = (depth_plane){nr / (fr->k * Dn), -nu / (fr->k * Dn),
                               (nf + (0.5 - fr->cx) / fr->k * nr +
                                (fr->cy - 0.5) / fr->k * nu) / Dn};
        }
        int nc = rad_patch_corners(pa);
        for (int c = 0; c < nc; c++)
            bufa[c] = cv[pa->v[c]];
        rad_vec3 *cur = bufa, *nxt = bufb;
        /* A patch inside all five planes (most are) comes out of clipping
         * unchanged: then the clipping is skipped. */
        int inside = 1;
        for (int k = 0; k < 5 && inside; k++)
            for (int c = 0; c < nc; c++)
                if (!(plane_dist(&planes[k], bufa[c]) >= 0.0)) {
                    inside = 0;
                    break;
                }
        for (int k = 0; k < 5 && nc >= 3 && !inside; k++) {
            nc = clip_polygon(cur, nc, nxt, &planes[k]);
            rad_vec3 *t = cur;
            cur = nxt;
            nxt = t;
        }
        if (nc < 3)
            continue;
        int ok = 1;
        for (int c = 0; c < nc; c++) {
            double sx = fr->ortho ? fr->cx + fr->k * cur[c].x
                                  : fr->cx + fr->k * cur[c].x / cur[c].z;
            double sy = fr->ortho ? fr->cy - fr->k * cur[c].y
                                  : fr->cy - fr->k * cur[c].y / cur[c].z;
            if (!(fabs(sx) < 65536.0) || !(fabs(sy) < 65536.0)) { /* unreachable after the guard band */
                ok = 0;
                break;
            }
            X[c] = round_half_away(sx * (double)SUBPIX);
            Y[c] = round_half_away(sy * (double)SUBPIX);
        }
        if (!ok)
            continue;
        for (int c = 1; c + 1 < nc; c++)
            raster_triangle(ib, X, Y, 0, c, c + 1, p, &dp);
    }
}

/* Shades every pixel of the canvas's image: the vertex radiosities
 * interpolated at the ray-plane point of the patch the item buffer holds,
 * over π (0 for the background).  Neighbouring pixels mostly see the same
 * patch, so its setup is kept; the sums run over the corners in order, as
 * Σ_q w_q B_q. */
static void shade_pixels(rn_canvas *canvas, const rad_mesh *mesh, const rn_frame *fr,
                         const double *vertex_B, uint32_t bands)
{
    rn_image *img = canvas->img;
    const double inv_pi = 1.0 / M_PI;
    const shade_setup *ss = NULL;
    double *acol = canvas->acol; /* a of each column, computed once a view */
    for (uint32_t i = 0; i < fr->w; i++)
        acol[i] = ((double)i + 0.5 - fr->cx) / fr->k;
    for (uint32_t j = 0; j < fr->h; j++) {
        double b = (fr->cy - (double)j - 0.5) / fr->k;
        for (uint32_t i = 0; i < fr->w; i++) {
            size_t k = (size_t)j * fr->w + i;
            uint32_t p = img->patch[k];
            float *px = img->pixels + k * bands;
            if (p == RAD_NONE) {
                for (uint32_t c = 0; c < bands; c++)
                    px[c] = 0.0f;
                continue;
            }
            if (!ss || p != ss->patch) {
                shade_setup *e = &canvas->setup[p % SHADE_CACHE];
                if (e->patch != p)
                    shade_prepare(e, mesh, p, fr, vertex_B, bands);
                ss = e;
            }
            double w[4];
            shade_weights(ss, acol[i], b, w);
            const double *cB = ss->cB;
            if (ss->cell.corners == 4)
                shade_store(px, w, cB, bands, 4, inv_pi);
            else
                shade_store(px, w, cB, bands, 3, inv_pi);
        }
    }
}

int rn_canvas_draw(rn_canvas *canvas, const rad_mesh *mesh, uint32_t bands,
                   const double *vertex_B, const rn_camera *cam, rn_image **out,
                   rad_error *err)
{
    if (!out)
        return rad_fail(err, RAD_ERR_USAGE, "render: no output pointer");
    *out = NULL;
    if (!canvas)
        return rad_fail(err, RAD_ERR_USAGE, "render: no canvas");
    if (!mesh)
        return rad_fail(err, RAD_ERR_USAGE, "render: no mesh");
    if (bands == 0 || bands > RAD_MAX_BANDS)
        return rad_fail(err, RAD_ERR_USAGE, "render: %u bands, not 1..%d", bands, RAD_MAX_BANDS);
    if (mesh->vertex_count > 0 && !vertex_B)
        return rad_fail(err, RAD_ERR_USAGE, "render: no vertex radiosities");
    rn_frame fr;
    memset(&fr, 0, sizeof fr);
    int rc = rn_camera_frame(cam, &fr, err);
    if (rc)
        return rc;
    rc = rn_mesh_check(mesh, err);
    if (rc)
        return rc;
    rc = canvas_prepare(canvas, fr.w, fr.h, bands, mesh->vertex_count, err);
    if (rc)
        return rc;
    rn_image *img = canvas->img;
    double extent = camera_vertices(mesh, &fr, canvas->cv);
    ibuf ib = {canvas->invz, img->patch, fr.w, fr.h};
    draw_items(mesh, &fr, canvas->cv, extent, &ib);
    shade_pixels(canvas, mesh, &fr, vertex_B, bands);
    *out = img;
    return RAD_OK;
}
