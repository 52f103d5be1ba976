/* test_render.c - vertex radiosities, the item buffer, interpolation and the
 * EXR / PNG writers.
 *
 * Meshes are built by hand here (grids of quads or triangles over a
 * parallelogram or a planar trapezoid), so the tests depend on nothing but
 * rad.h and render.h.  Expected pixel values come from an independent
 * ray-plane intersection in this file, using the camera convention render.h
 * documents: pixel centres, row 0 at the top, right-handed frame.
 */
#include "../radiosity/core/rad.h"
#include "../radiosity/scene/gltf_image.h"
#include "../render/render.h"
#include "exr_read.h"
#include "test.h"

#include <dirent.h>
#include <errno.h>
#include <stdint.h>
#include <sys/stat.h>
#include <unistd.h>

/* ------------------------------------------------------------ meshes */

static rad_mesh *mesh_new(uint32_t vcap, uint32_t pcap)
{
    rad_mesh *m = calloc(1, sizeof *m);
    m->vertices = calloc(vcap, sizeof *m->vertices);
    m->vertex_boundary = calloc(vcap, 1);
    m->patches = calloc(pcap, sizeof *m->patches);
    return m;
}

static void mesh_free(rad_mesh *m)
{
    if (!m)
        return;
    free(m->vertices);
    free(m->vertex_boundary);
    free(m->patches);
    free(m);
}

static void finish_patch(rad_mesh *m, rad_patch *p)
{
    /* Area centroid: triangles (v0 v1 v2) and (v0 v2 v3), weighted by area. */
    int n = rad_patch_corners(p);
    rad_vec3 a = m->vertices[p->v[0]], c = rad_v3(0, 0, 0), nsum = rad_v3(0, 0, 0);
    double area = 0;
    for (int k = 1; k + 1 < n; k++) {
        rad_vec3 b = m->vertices[p->v[k]], d = m->vertices[p->v[k + 1]];
        rad_vec3 cr = rad_cross(rad_sub(b, a), rad_sub(d, a));
        double t = 0.5 * rad_length(cr);
        c = rad_add(c, rad_scale(rad_add(a, rad_add(b, d)), t / 3.0));
        nsum = rad_add(nsum, cr);
        area += t;
    }
    p->center = rad_scale(c, 1.0 / area);
    p->area = area;
    p->normal = rad_normalize(nsum);
}

/* Point (s, t) in [0,1]² of the planar quadrilateral c0 c1 c2 c3 (bilinear). */
static rad_vec3 quad_point(const rad_vec3 c[4], double s, double t)
{
    return rad_add(rad_scale(rad_lerp(c[0], c[1], s), 1 - t), rad_scale(rad_lerp(c[3], c[2], s), t));
}

/* An nx × ny grid over the planar quadrilateral c (counter-clockwise seen from
 * the front), quads or (tri) two triangles per cell.  Returns the first patch
 * index; cell (i, j) is patch first + j·nx + i (times 2 for triangles). */
static uint32_t add_grid(rad_mesh *m, const rad_vec3 c[4], uint32_t nx, uint32_t ny, int tri,
                         uint32_t polygon)
{
    uint32_t base = m->vertex_count, first = m->patch_count;
    for (uint32_t j = 0; j <= ny; j++)
        for (uint32_t i = 0; i <= nx; i++) {
            m->vertices[m->vertex_count] = quad_point(c, (double)i / nx, (double)j / ny);
            m->vertex_boundary[m->vertex_count] = (i == 0 || j == 0 || i == nx || j == ny);
            m->vertex_count++;
        }
    for (uint32_t j = 0; j < ny; j++)
        for (uint32_t i = 0; i < nx; i++) {
            uint32_t v00 = base + j * (nx + 1) + i, v10 = v00 + 1, v01 = v00 + nx + 1, v11 = v01 + 1;
            if (!tri) {
                rad_patch *p = &m->patches[m->patch_count++];
                *p = (rad_patch){{v00, v10, v11, v01}, polygon, 0, 0, {0, 0, 0}, {0, 0, 0}, 0};
                finish_patch(m, p);
            } else {
                rad_patch *p = &m->patches[m->patch_count++];
                *p = (rad_patch){{v00, v10, v11, RAD_NONE}, polygon, 0, 0, {0, 0, 0}, {0, 0, 0}, 0};
                finish_patch(m, p);
                p = &m->patches[m->patch_count++];
                *p = (rad_patch){{v00, v11, v01, RAD_NONE}, polygon, 0, 0, {0, 0, 0}, {0, 0, 0}, 0};
                finish_patch(m, p);
            }
        }
    return first;
}

/* Axis-aligned rectangle [x0,x1]×[y0,y1] in the plane z = z0, facing +z
 * (flip: facing −z). */
static void rect_z(rad_vec3 c[4], double x0, double y0, double x1, double y1, double z0, int flip)
{
    c[0] = rad_v3(x0, y0, z0);
    c[1] = flip ? rad_v3(x0, y1, z0) : rad_v3(x1, y0, z0);
    c[2] = rad_v3(x1, y1, z0);
    c[3] = flip ? rad_v3(x1, y0, z0) : rad_v3(x0, y1, z0);
}

/* ------------------------------------------------------------ camera */

/* The ray of pixel (i, j), written from render.h's convention: from the
 * eye through the pixel (perspective), or along the view from the pixel's
 * point of the window 2·ymag high (orthographic).  Returns the direction,
 * the origin in *o. */
static rad_vec3 pixel_ray(const rn_camera *cam, uint32_t i, uint32_t j, double di, double dj,
                          rad_vec3 *o)
{
    rad_vec3 f = rad_normalize(rad_sub(cam->target, cam->eye));
    rad_vec3 r = rad_normalize(rad_cross(f, cam->up));
    rad_vec3 u = rad_cross(r, f);
    double t = cam->orthographic ? cam->ymag : tan(cam->yfov_deg * M_PI / 360.0);
    double a = (2.0 * (i + 0.5 + di) / cam->width - 1.0) * t * cam->width / cam->height;
    double b = (1.0 - 2.0 * (j + 0.5 + dj) / cam->height) * t;
    rad_vec3 across = rad_add(rad_scale(r, a), rad_scale(u, b));
    *o = cam->orthographic ? rad_add(cam->eye, across) : cam->eye;
    return cam->orthographic ? f : rad_add(f, across);
}

/* Where the ray meets the plane (p0, n); 0 when it does not (in front). */
static int ray_plane(rad_vec3 eye, rad_vec3 d, rad_vec3 p0, rad_vec3 n, rad_vec3 *x)
{
    double dn = rad_dot(d, n);
    if (dn == 0.0)
        return 0;
    double s = rad_dot(rad_sub(p0, eye), n) / dn;
    if (!(s > 0.0))
        return 0;
    *x = rad_add(eye, rad_scale(d, s));
    return 1;
}

/* The patch strictly containing x (a point of the mesh's plane), or -1 when
 * x lies on an edge or outside; *any is set when x is in some patch or on
 * its outline. */
static int patch_at(const rad_mesh *m, rad_vec3 x, int *any)
{
    int found = -1;
    for (uint32_t p = 0; p < m->patch_count; p++) {
        const rad_patch *pa = &m->patches[p];
        int n = rad_patch_corners(pa), strict = 1, in = 1;
        for (int k = 0; k < n; k++) {
            rad_vec3 a = m->vertices[pa->v[k]], b = m->vertices[pa->v[(k + 1) % n]];
            double s = rad_dot(rad_cross(rad_sub(b, a), rad_sub(x, a)), pa->normal);
            strict &= s > 0.0;
            in &= s >= -1e-12; /* rounding of the cross product, scale 1 */
        }
        *any |= in;
        if (strict)
            found = (int)p;
    }
    return found;
}

static rn_camera camera(rad_vec3 eye, rad_vec3 target, rad_vec3 up, double fov, uint32_t w, uint32_t h)
{
    rn_camera c = {.eye = eye, .target = target, .up = up, .yfov_deg = fov, .width = w, .height = h};
    return c;
}

/* ------------------------------------------------- vertex radiosity */

static double lin(rad_vec3 p, const double *k) { return k[0] + k[1] * p.x + k[2] * p.y + k[3] * p.z; }

TEST(vertex_linear_field_exact)
{
    /* A 4×3 grid on a tilted parallelogram; two bands, each a linear field.
     * Patch B = field at the patch centroid (exact mean of a linear field). */
    rad_vec3 c[4] = {{0.3, -0.2, 1.0}, {2.3, -0.2, 1.5}, {2.8, 1.3, 2.0}, {0.8, 1.3, 1.5}};
    rad_mesh *m = mesh_new(20, 12);
    add_grid(m, c, 4, 3, 0, 0);
    const double k[2][4] = {{5.0, 0.7, -1.1, 0.4}, {2.0, -0.3, 0.5, 0.9}};
    double B[12 * 2], vb[20 * 2];
    for (uint32_t p = 0; p < m->patch_count; p++)
        for (int b = 0; b < 2; b++)
            B[p * 2 + b] = lin(m->patches[p].center, k[b]);
    rn_vertex_radiosity(m, 2, B, vb);
    int outline = 0;
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        outline += m->vertex_boundary[v];
        for (int b = 0; b < 2; b++) {
            double want = lin(m->vertices[v], k[b]);
            CHECK(want > 0.5); /* the clamp stays out of it */
            /* 1e-12: a few dozen rounded operations on values of order 10. */
            CHECK_NEAR(vb[v * 2 + b], want, 1e-12);
        }
    }
    CHECK(outline == 14);
    mesh_free(m);
}

TEST(vertex_rules_of_the_paper)
{
    /* Arbitrary (non-linear) patch values on a 4×3 unit grid: the paper's
     * rules, computed here directly, for the cases they name. */
    rad_vec3 c[4];
    rect_z(c, 0, 0, 4, 3, 0, 0);
    rad_mesh *m = mesh_new(20, 12);
    add_grid(m, c, 4, 3, 0, 0);
    double B[12], vb[20];
    for (int p = 0; p < 12; p++)
        B[p] = 3.0 + sin(1.7 * p) + 0.1 * p * p;
#define VX(i, j) ((j) * 5 + (i))
#define PX(i, j) ((j) * 4 + (i))
    rn_vertex_radiosity(m, 1, B, vb);
    /* Interior vertex: mean of its four patches. 1e-12: rounding. */
    CHECK_NEAR(vb[VX(2, 1)], (B[PX(1, 0)] + B[PX(2, 0)] + B[PX(1, 1)] + B[PX(2, 1)]) / 4, 1e-12);
    double i11 = vb[VX(1, 1)], i12 = vb[VX(1, 2)], i31 = vb[VX(3, 1)], i21 = vb[VX(2, 1)];
    CHECK_NEAR(i11, (B[PX(0, 0)] + B[PX(1, 0)] + B[PX(0, 1)] + B[PX(1, 1)]) / 4, 1e-12);
    /* Corner: 2·B_patch − B_(1,1). */
    CHECK_NEAR(vb[VX(0, 0)], fmax(0.0, 2 * B[PX(0, 0)] - i11), 1e-12);
    CHECK_NEAR(vb[VX(4, 0)], fmax(0.0, 2 * B[PX(3, 0)] - i31), 1e-12);
    CHECK_NEAR(vb[VX(0, 3)], fmax(0.0, 2 * B[PX(0, 2)] - i12), 1e-12);
    /* Edge vertex with three interior neighbours: 2·P − their mean. */
    double P = (B[PX(1, 0)] + B[PX(2, 0)]) / 2;
    CHECK_NEAR(vb[VX(2, 0)], fmax(0.0, 2 * P - (i11 + i21 + i31) / 3), 1e-12);
    for (int v = 0; v < 20; v++)
        CHECK(vb[v] >= 0.0);
#undef VX
#undef PX
    mesh_free(m);
}

/* RN_FIT_QUADRATIC on a 6×6 unit grid.  A quadratic field increasing in x
 * and y (so no vertex is an extreme of the cells around it and the limiter
 * stays out of it): every interior vertex exact, where the affine fit is
 * off by the curvature, h²/8·(q_xx + q_yy) = 0.005.  A step (1 for x < 3, 0
 * beyond): the limiter keeps every interior vertex inside the range of the
 * cells using it, so the columns next to the step stay exactly 1 and 0
 * (an unlimited quadratic rings there). */
TEST(vertex_quadratic_fit)
{
    rad_vec3 c[4];
    rect_z(c, 0, 0, 6, 6, 0, 0);
    rad_mesh *m = mesh_new(49, 36);
    add_grid(m, c, 6, 6, 0, 0);
    double B[36], vq[49], va[49];
    for (uint32_t p = 0; p < 36; p++) {
        rad_vec3 x = m->patches[p].center;
        B[p] = 5 + 2 * x.x + x.y + 0.1 * x.x * x.x + 0.05 * x.x * x.y - 0.08 * x.y * x.y;
    }
    rn_vertex_radiosity_fit(m, 1, B, vq, RN_FIT_QUADRATIC);
    rn_vertex_radiosity_fit(m, 1, B, va, RN_FIT_AFFINE);
    double worst_q = 0, least_a = INFINITY;
    uint32_t interior = 0;
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        if (m->vertex_boundary[v])
            continue;
        rad_vec3 x = m->vertices[v];
        double want = 5 + 2 * x.x + x.y + 0.1 * x.x * x.x + 0.05 * x.x * x.y - 0.08 * x.y * x.y;
        worst_q = fmax(worst_q, fabs(vq[v] - want));
        least_a = fmin(least_a, fabs(va[v] - want));
        interior++;
    }
    CHECK(interior == 25);
    CHECK(worst_q < 1e-12); /* rounding on values of order 20 */
    CHECK_NEAR(least_a, 0.005, 1e-12);
    for (uint32_t p = 0; p < 36; p++)
        B[p] = m->patches[p].center.x < 3.0 ? 1.0 : 0.0;
    rn_vertex_radiosity_fit(m, 1, B, vq, RN_FIT_QUADRATIC);
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        if (m->vertex_boundary[v])
            continue;
        double x = m->vertices[v].x;
        CHECK(vq[v] >= 0.0 && vq[v] <= 1.0);
        if (x <= 2.0)
            CHECK(vq[v] == 1.0);
        if (x >= 4.0)
            CHECK(vq[v] == 0.0);
    }
    mesh_free(m);
}

TEST(vertex_clamp_and_fallbacks)
{
    /* B = x − 0.25 on unit cells from x = 0: centres are >= 0.25 but the
     * left outline extrapolates to −0.25, which must become exactly 0. */
    rad_vec3 c[4];
    rect_z(c, 0, 0, 4, 3, 0, 0);
    rad_mesh *m = mesh_new(20, 12);
    add_grid(m, c, 4, 3, 0, 0);
    double B[12], vb[20];
    for (int p = 0; p < 12; p++)
        B[p] = m->patches[p].center.x - 0.25;
    rn_vertex_radiosity(m, 1, B, vb);
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        if (m->vertices[v].x == 0.0)
            CHECK(vb[v] == 0.0);
        else /* 1e-12: rounding on values of order 1 */
            CHECK_NEAR(vb[v], m->vertices[v].x - 0.25, 1e-12);
    }
    mesh_free(m);

    /* A 3×1 strip has no interior vertex: outline vertices take P(v). */
    m = mesh_new(8, 3);
    rect_z(c, 0, 0, 3, 1, 0, 0);
    add_grid(m, c, 3, 1, 0, 0);
    double Bs[3] = {1.0, 4.0, 2.0}, vs[8];
    rn_vertex_radiosity(m, 1, Bs, vs);
    CHECK_NEAR(vs[0], 1.0, 1e-15); /* exact means of one or two values */
    CHECK_NEAR(vs[1], 2.5, 1e-15);
    CHECK_NEAR(vs[2], 3.0, 1e-15);
    CHECK_NEAR(vs[3], 2.0, 1e-15);
    CHECK_NEAR(vs[5], 2.5, 1e-15);
    mesh_free(m);

    /* Bad input leaves zeros rather than crashing. */
    double z[4] = {7, 7, 7, 7};
    rn_vertex_radiosity(NULL, 1, Bs, z);
    CHECK(z[0] == 7.0);
    rad_mesh bad = {0};
    rad_vec3 vv[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    rad_patch pp = {{0, 1, 2, 99}, 0, 0, 0, {0.5, 0.5, 0}, {0, 0, 1}, 1};
    bad.vertices = vv;
    bad.vertex_count = 4;
    bad.patches = &pp;
    bad.patch_count = 1;
    rn_vertex_radiosity(&bad, 1, Bs, z);
    CHECK(z[0] == 0.0 && z[3] == 0.0); /* the only patch is invalid: no value */
}

/* ------------------------------------------------------- rendering */

/* Renders the planar mesh m with per-vertex values vb (band b scaled by
 * b + 1) and checks every pixel.  Each pixel's ray is traced analytically at
 * its centre and at ±0.02 pixel: the item buffer's edges are snapped to
 * 1/4096 pixel, so only pixels whose five points agree are decided.
 *   - all five miss the mesh: background, exactly 0 and RAD_NONE;
 *   - all five strictly inside one patch: that patch, and
 *     L = expect(X)/π within 1e-6 relative (float storage; the
 *     interpolation is exact for the fields used);
 *   - all five in the mesh but near a patch edge: covered, and within 1e-4
 *     (the neighbour may own the pixel; its clamped interpolation is off by
 *     |∇B| × 1/8192 pixel's footprint, below 1e-5 relative here).
 * Returns the number of pixels of the second kind. */
typedef double (*field_fn)(rad_vec3 x, const void *ctx);

static int check_view(const rad_mesh *m, uint32_t bands, const double *vb, const rn_camera *cam,
                      field_fn expect, const void *ctx, rn_image **keep)
{
    static const double off[5][2] = {{0, 0}, {0.02, 0}, {-0.02, 0}, {0, 0.02}, {0, -0.02}};
    rn_image *img = NULL;
    rad_error err = {0};
    int rc = rn_render(m, bands, vb, cam, &img, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return 0;
    CHECK(img->width == cam->width && img->height == cam->height && img->channels == bands);
    rad_vec3 p0 = m->patches[0].center, n = m->patches[0].normal;
    int front = cam->orthographic ? rad_dot(rad_sub(cam->target, cam->eye), n) < 0.0
                                  : rad_dot(rad_sub(cam->eye, p0), n) > 0.0;
    int certain = 0, bad_cov = 0, bad_id = 0, bad_bg = 0, bad_val = 0;
    for (uint32_t j = 0; j < cam->height; j++)
        for (uint32_t i = 0; i < cam->width; i++) {
            size_t k = (size_t)j * cam->width + i;
            int same = -2, all_in = 1, none = 1;
            rad_vec3 xc = {0, 0, 0};
            for (int q = 0; q < 5; q++) {
                rad_vec3 x, o;
                int any = 0, p = -1;
                rad_vec3 d = pixel_ray(cam, i, j, off[q][0], off[q][1], &o);
                if (front && ray_plane(o, d, p0, n, &x))
                    p = patch_at(m, x, &any);
                if (q == 0)
                    xc = x;
                none &= !any;
                all_in &= any;
                same = same == -2 || same == p ? p : -1;
            }
            if (none) {
                if (img->patch[k] != RAD_NONE)
                    bad_bg++;
                for (uint32_t b = 0; b < bands; b++)
                    bad_bg += img->pixels[k * bands + b] != 0.0f;
                continue;
            }
            if (!all_in)
                continue;
            if (img->patch[k] == RAD_NONE) {
                bad_cov++;
                continue;
            }
            double tol = same >= 0 ? 1e-6 : 1e-4;
            if (same >= 0) {
                certain++;
                bad_id += img->patch[k] != (uint32_t)same;
            }
            for (uint32_t b = 0; b < bands; b++) {
                double want = expect(xc, ctx) * (b + 1) / M_PI;
                if (!(fabs(img->pixels[k * bands + b] - want) <= tol * fabs(want)) && bad_val++ < 3)
                    fprintf(stderr, "  pixel %u,%u band %u: %.9g want %.9g\n", i, j, b,
                            img->pixels[k * bands + b], want);
            }
        }
    CHECK_MSG(bad_cov == 0, "%d pixels uncovered", bad_cov);
    CHECK_MSG(bad_id == 0, "%d pixels show the wrong patch", bad_id);
    CHECK_MSG(bad_bg == 0, "%d background pixels wrong", bad_bg);
    CHECK_MSG(bad_val == 0, "%d pixel values wrong", bad_val);
    if (keep)
        *keep = img;
    else
        rn_image_destroy(img);
    return certain;
}

static double field_const(rad_vec3 x, const void *ctx)
{
    (void)x;
    return *(const double *)ctx;
}

static double field_lin(rad_vec3 x, const void *ctx) { return lin(x, ctx); }

/* Per-vertex values of a linear field, band b scaled by (b + 1). */
static double *vertex_field(const rad_mesh *m, uint32_t bands, const double *k)
{
    double *vb = malloc(sizeof *vb * m->vertex_count * bands);
    for (uint32_t v = 0; v < m->vertex_count; v++)
        for (uint32_t b = 0; b < bands; b++)
            vb[v * bands + b] = lin(m->vertices[v], k) * (b + 1);
    return vb;
}

TEST(uniform_quad)
{
    rad_vec3 c[4];
    rect_z(c, -1, -0.7, 1.2, 0.9, 0, 0);
    rad_mesh *m = mesh_new(16, 9);
    add_grid(m, c, 3, 3, 0, 0);
    double B[9], vb[16];
    for (int p = 0; p < 9; p++)
        B[p] = M_PI * 0.5;
    rn_vertex_radiosity(m, 1, B, vb);
    rn_camera cam = camera(rad_v3(0.1, 0.2, 5), rad_v3(0.1, 0.2, 0), rad_v3(0, 1, 0), 40, 64, 48);
    double half = 0.5 * M_PI;
    rn_image *img = NULL;
    int covered = check_view(m, 1, vb, &cam, field_const, &half, &img);
    CHECK(covered > 200 && covered < 64 * 48 - 200); /* part of the view */
    /* Background is exactly 0 and RAD_NONE. */
    if (img) {
        CHECK(img->patch[0] == RAD_NONE && img->pixels[0] == 0.0f);
        /* Pixel values are L = B/π = 0.5 (1e-6: float storage). */
        size_t mid = (size_t)24 * 64 + 32;
        CHECK(img->patch[mid] < 9);
        CHECK_REL(img->pixels[mid], 0.5, 1e-6);
    }
    rn_image_destroy(img);
    mesh_free(m);
}

TEST(linear_ramp_quads)
{
    /* Head-on 4×4 grid, two bands: pixel = field(X)/π at the ray-plane point. */
    rad_vec3 c[4];
    rect_z(c, -1, -1, 1, 1, 0.5, 0);
    rad_mesh *m = mesh_new(25, 16);
    add_grid(m, c, 4, 4, 0, 0);
    const double k[4] = {3.0, 1.1, -0.6, 0.0};
    double *vb = vertex_field(m, 2, k);
    rn_camera cam = camera(rad_v3(0, 0, 4), rad_v3(0, 0, 0.5), rad_v3(0, 1, 0), 45, 80, 60);
    CHECK(check_view(m, 2, vb, &cam, field_lin, k, NULL) > 1000);
    /* Obliquely, the inverse of the perspective is exercised too. */
    cam = camera(rad_v3(1.5, -2.0, 3.0), rad_v3(0.1, 0.1, 0.5), rad_v3(0, 0, 1), 50, 90, 70);
    CHECK(check_view(m, 2, vb, &cam, field_lin, k, NULL) > 1000);
    free(vb);

    /* The whole chain: patch B = field(centroid) -> vertex radiosities ->
     * image, exact for a linear field. */
    double B[16], vb1[25];
    for (int p = 0; p < 16; p++)
        B[p] = lin(m->patches[p].center, k);
    rn_vertex_radiosity(m, 1, B, vb1);
    CHECK(check_view(m, 1, vb1, &cam, field_lin, k, NULL) > 1000);
    mesh_free(m);
}

TEST(linear_ramp_trapezoid)
{
    /* A planar trapezoid: its cells are not parallelograms, so the inverse
     * bilinear map needs its quadratic; a linear field stays exact. */
    rad_vec3 c[4] = {{-1, -1, 0}, {1, -1, 0}, {0.6, 1, 0}, {-0.2, 1, 0}};
    rad_mesh *m = mesh_new(25, 16);
    add_grid(m, c, 4, 4, 0, 0);
    const double k[4] = {2.0, -0.8, 0.7, 0.0};
    double *vb = vertex_field(m, 1, k);
    rn_camera cam = camera(rad_v3(0.4, -1.2, 3.0), rad_v3(0.1, 0.1, 0), rad_v3(0, 0, 1), 40, 100, 80);
    CHECK(check_view(m, 1, vb, &cam, field_lin, k, NULL) > 1000);
    free(vb);
    mesh_free(m);
}

/* A canvas drawn over, view after view (slots shared between patches:
 * shading_slots_shared_by_kinds): each view is right against the analytic field (check_view, on a fresh
 * canvas), and the kept canvas gives exactly the fresh canvas's image,
 * background included where the view before had drawn (its radiance is not
 * cleared in between). */
TEST(canvas_kept_between_views)
{
    rad_vec3 c[4];
    rect_z(c, -1, -1, 1, 1, 0, 0);
    rad_mesh *m = mesh_new(25 * 25, 576);
    add_grid(m, c, 24, 24, 0, 0); /* 576 cells */
    const double k[4] = {2.0, 0.9, -0.5, 0.0};
    double *vb = vertex_field(m, 3, k);
    rn_camera cams[3] = {
        camera(rad_v3(0.3, -2.0, 2.5), rad_v3(0.1, 0.2, 0), rad_v3(0, 0, 1), 40, 64, 48),
        camera(rad_v3(0, 0, 2.0), rad_v3(0, 0, 0), rad_v3(0, 1, 0), 30, 64, 48), /* all plane */
        camera(rad_v3(-1.5, 1.0, 3.0), rad_v3(0, 0, 0), rad_v3(0, 1, 0), 35, 64, 48),
    };
    rn_image *fresh[3] = {NULL, NULL, NULL};
    for (int v = 0; v < 3; v++)
        CHECK(check_view(m, 3, vb, &cams[v], field_lin, k, &fresh[v]) > 500);
    rn_canvas *canvas = rn_canvas_create();
    CHECK(canvas != NULL);
    static const int order[5] = {0, 1, 2, 1, 0};
    size_t bg_after_covered = 0;
    for (int q = 0; q < 5 && canvas; q++) {
        int v = order[q];
        rn_image *img = NULL;
        rad_error err = {0};
        CHECK_MSG(rn_canvas_draw(canvas, m, 3, vb, &cams[v], &img, &err) == RAD_OK, "%s",
                  err.message);
        if (!img || !fresh[v])
            continue;
        size_t n = (size_t)img->width * img->height;
        CHECK(!memcmp(img->pixels, fresh[v]->pixels, n * 3 * sizeof(float)));
        CHECK(!memcmp(img->patch, fresh[v]->patch, n * sizeof(uint32_t)));
        if (q > 0 && order[q - 1] == 1) /* the view before covered every pixel */
            for (size_t i = 0; i < n; i++)
                bg_after_covered += img->patch[i] == RAD_NONE;
    }
    /* The second view fills the image; the others leave background. */
    CHECK(fresh[1] && fresh[1]->patch[0] != RAD_NONE &&
          fresh[1]->patch[(size_t)64 * 48 - 1] != RAD_NONE);
    CHECK(bg_after_covered > 100);
    rn_canvas_destroy(canvas);
    for (int v = 0; v < 3; v++)
        rn_image_destroy(fresh[v]);
    free(vb);
    mesh_free(m);
}

/* Cells of different kinds sharing a shading slot.  The canvas keeps one
 * setup per slot (patch index mod a power of two up to 4096), and a setup
 * prepared over an older one must not keep anything of it.  Triangles
 * 0..127 (linear: barycentric), 3,968 quads far off screen (never drawn),
 * then trapezoid cells 4096..4159 (not parallelograms: the quadratic
 * inverse): triangle q and trapezoid cell 4096 + q share a slot, and both
 * are on screen, so their setups replace each other scan line after scan
 * line.  Every pixel is checked against the analytic field (check_view),
 * and a kept canvas gives the fresh canvas's image. */
TEST(shading_slots_shared_by_kinds)
{
    rad_vec3 tri[4], far[4];
    rect_z(tri, -1.1, -1, -0.1, 1, 0, 0);
    rect_z(far, 50, 50, 60, 60, 0, 0);
    rad_vec3 trap[4] = {{0.1, -1, 0}, {1.1, -1, 0}, {0.8, 1, 0}, {0.3, 1, 0}};
    rad_mesh *m = mesh_new(81 + 63 * 65 + 81, 4160);
    add_grid(m, tri, 8, 8, 1, 0);
    add_grid(m, far, 62, 64, 0, 0);
    uint32_t first = add_grid(m, trap, 8, 8, 0, 0);
    CHECK(m->patch_count == 4160 && first == 4096 && m->patches[0].v[3] == RAD_NONE);
    const double k[4] = {2.0, 0.9, -0.5, 0.0};
    double *vb = vertex_field(m, 3, k);
    rn_camera cams[2] = {
        camera(rad_v3(0, 0, 2.5), rad_v3(0, 0, 0), rad_v3(0, 1, 0), 50, 64, 48),
        camera(rad_v3(0.4, -1.5, 2.0), rad_v3(0, 0, 0), rad_v3(0, 0, 1), 55, 64, 48),
    };
    rn_image *fresh[2] = {NULL, NULL};
    for (int v = 0; v < 2; v++)
        CHECK(check_view(m, 3, vb, &cams[v], field_lin, k, &fresh[v]) > 500);
    rn_canvas *canvas = rn_canvas_create();
    CHECK(canvas != NULL);
    for (int q = 0; q < 4 && canvas; q++) {
        rn_image *img = NULL;
        rad_error err = {0};
        CHECK_MSG(rn_canvas_draw(canvas, m, 3, vb, &cams[q % 2], &img, &err) == RAD_OK, "%s",
                  err.message);
        if (img && fresh[q % 2])
            CHECK(!memcmp(img->pixels, fresh[q % 2]->pixels,
                          (size_t)img->width * img->height * 3 * sizeof(float)));
    }
    rn_canvas_destroy(canvas);
    for (int v = 0; v < 2; v++)
        rn_image_destroy(fresh[v]);
    free(vb);
    mesh_free(m);
}

TEST(linear_ramp_triangles)
{
    rad_vec3 c[4];
    rect_z(c, -1, -0.8, 1.4, 1, -0.3, 0);
    rad_mesh *m = mesh_new(25, 32);
    add_grid(m, c, 4, 4, 1, 0);
    CHECK(m->patch_count == 32 && m->patches[0].v[3] == RAD_NONE);
    const double k[4] = {4.0, -1.3, 0.9, 0.0};
    double *vb = vertex_field(m, 3, k);
    rn_camera cam = camera(rad_v3(0.2, 0.1, 4), rad_v3(0.2, 0.1, -0.3), rad_v3(0, 1, 0), 45, 80, 60);
    CHECK(check_view(m, 3, vb, &cam, field_lin, k, NULL) > 1000);
    cam = camera(rad_v3(-1.0, 2.5, 2.0), rad_v3(0.2, 0.1, -0.3), rad_v3(0, 0, 1), 55, 90, 70);
    CHECK(check_view(m, 3, vb, &cam, field_lin, k, NULL) > 1000);
    free(vb);
    /* Whole chain through rn_vertex_radiosity on triangles. */
    double B[32], vb1[25];
    for (int p = 0; p < 32; p++)
        B[p] = lin(m->patches[p].center, k);
    rn_vertex_radiosity(m, 1, B, vb1);
    CHECK(check_view(m, 1, vb1, &cam, field_lin, k, NULL) > 1000);
    mesh_free(m);
}

/* An 8×8 plane of uniform patches: every pixel whose ray surely hits it is
 * covered, by the patch whose cell contains the hit, with the uniform value
 * (check_view). */
static void no_cracks_case(rn_camera cam, double x0, double y0, double x1, double y1)
{
    rad_vec3 c[4];
    rect_z(c, x0, y0, x1, y1, 0, 0);
    rad_mesh *m = mesh_new(81, 64);
    add_grid(m, c, 8, 8, 0, 0);
    double vb[81];
    for (int v = 0; v < 81; v++)
        vb[v] = 0.5 * M_PI;
    double half = 0.5 * M_PI;
    CHECK(check_view(m, 1, vb, &cam, field_const, &half, NULL) > 800);
    mesh_free(m);
}

TEST(no_cracks)
{
    /* Oblique view of a plane of 8×8 patches. */
    no_cracks_case(camera(rad_v3(2.7, -3.1, 2.2), rad_v3(0.2, 0.1, 0), rad_v3(0, 0, 1), 50, 160, 120),
                   -1, -1, 1, 1);
    /* A floor reaching behind the eye: its patches cross the eye plane and
     * must be clipped, not smeared over the image. */
    no_cracks_case(camera(rad_v3(0.3, 0.2, 1.0), rad_v3(0.5, 5, 0.6), rad_v3(0, 0, 1), 70, 160, 120),
                   -10, -10, 10, 10);
    /* Head-on with odd sizes and k = (H/2)/tan(fov/2) = 120: every patch
     * edge and corner falls exactly on pixel centres, which the top-left
     * rule must give to exactly one patch (never to none). */
    no_cracks_case(camera(rad_v3(0, 0, 3), rad_v3(0, 0, 0), rad_v3(0, 1, 0),
                          2.0 * atan(40.5 / 120.0) * 180.0 / M_PI, 81, 81),
                   -1, -1, 1, 1);
    /* Grazing view from the side: long thin projected patches. */
    no_cracks_case(camera(rad_v3(-4, 0.3, 0.8), rad_v3(0, 0, 0), rad_v3(0, 0, 1), 30, 200, 100),
                   -1, -1, 1, 1);
}

TEST(occlusion_and_culling)
{
    rad_vec3 big[4], small[4], back[4];
    rect_z(big, -2, -2, 2, 2, 0, 0);
    rect_z(small, -0.5, -0.5, 0.5, 0.5, 1, 0);
    rect_z(back, -1, -1, 1, 1, 2, 1); /* faces −z: away from the eye */
    rn_camera cam = camera(rad_v3(0, 0, 5), rad_v3(0, 0, 0), rad_v3(0, 1, 0), 60, 41, 41);
    for (int order = 0; order < 2; order++) {
        rad_mesh *m = mesh_new(12, 3);
        uint32_t pb, ps;
        if (order == 0) {
            pb = add_grid(m, big, 1, 1, 0, 0);
            ps = add_grid(m, small, 1, 1, 0, 1);
        } else {
            ps = add_grid(m, small, 1, 1, 0, 0);
            pb = add_grid(m, big, 1, 1, 0, 1);
        }
        uint32_t pk = add_grid(m, back, 1, 1, 0, 2);
        CHECK(m->patches[pk].normal.z < 0);
        double vb[12];
        for (int v = 0; v < 12; v++) /* big 0.2, small 0.7, back 0.9 (radiance) */
            vb[v] = M_PI * (v < 4 ? (order == 0 ? 0.2 : 0.7) : v < 8 ? (order == 0 ? 0.7 : 0.2) : 0.9);
        rn_image *img = NULL;
        rad_error err;
        CHECK(rn_render(m, 1, vb, &cam, &img, &err) == RAD_OK);
        if (img) {
            size_t centre = 20 * 41 + 20, side = 20 * 41 + 8; /* side: x ≈ −1.7 */
            CHECK(img->patch[centre] == ps);
            CHECK_REL(img->pixels[centre], 0.7, 1e-6); /* float storage */
            CHECK(img->patch[side] == pb);
            CHECK_REL(img->pixels[side], 0.2, 1e-6);
            int culled_seen = 0;
            for (size_t k = 0; k < 41u * 41u; k++)
                culled_seen += img->patch[k] == pk;
            CHECK(culled_seen == 0);
        }
        rn_image_destroy(img);
        mesh_free(m);
    }
    /* A back face alone: nothing at all. */
    rad_mesh *m = mesh_new(4, 1);
    add_grid(m, back, 1, 1, 0, 0);
    double vb[4] = {1, 1, 1, 1};
    rn_image *img = NULL;
    rad_error err;
    CHECK(rn_render(m, 1, vb, &cam, &img, &err) == RAD_OK);
    int seen = 0;
    for (size_t k = 0; img && k < 41u * 41u; k++)
        seen += img->patch[k] != RAD_NONE || img->pixels[k] != 0.0f;
    CHECK(img && seen == 0);
    rn_image_destroy(img);
    mesh_free(m);
}

/* Orthographic views: pixel by pixel against the geometry (coverage, the
 * patch seen, a linear field exactly), head-on and oblique; the window is
 * 2·ymag high whatever the distance, and nothing behind the eye shows. */
TEST(orthographic_views)
{
    rad_vec3 c[4];
    rect_z(c, -1, -1, 1, 1, 0, 0);
    rad_mesh *m = mesh_new(25, 16);
    add_grid(m, c, 4, 4, 0, 0);
    const double k[4] = {3.0, 1.1, -0.6, 0.0};
    double *vb = vertex_field(m, 2, k);
    rn_camera cam = camera(rad_v3(0, 0, 5), rad_v3(0, 0, 0), rad_v3(0, 1, 0), 45, 40, 40);
    cam.orthographic = 1;
    cam.ymag = 2.0; /* 10 pixels per unit: the quad covers columns and rows 10..29 */
    rn_image *img = NULL;
    CHECK(check_view(m, 2, vb, &cam, field_lin, k, &img) > 300);
    if (img) {
        CHECK(img->patch[20 * 40 + 9] == RAD_NONE && img->patch[20 * 40 + 10] != RAD_NONE);
        CHECK(img->patch[20 * 40 + 29] != RAD_NONE && img->patch[20 * 40 + 30] == RAD_NONE);
        CHECK(img->patch[9 * 40 + 20] == RAD_NONE && img->patch[10 * 40 + 20] != RAD_NONE);
    }
    rn_image_destroy(img);
    img = NULL;
    /* ten times farther, the same picture (a perspective one would shrink) */
    rn_camera far = cam;
    far.eye = rad_v3(0, 0, 50);
    CHECK(check_view(m, 2, vb, &far, field_lin, k, &img) > 300);
    if (img)
        CHECK(img->patch[20 * 40 + 10] != RAD_NONE && img->patch[20 * 40 + 9] == RAD_NONE);
    rn_image_destroy(img);
    /* obliquely, wider than high */
    rn_camera ob = camera(rad_v3(1.5, -2.0, 3.0), rad_v3(0.1, 0.1, 0.5), rad_v3(0, 0, 1), 45, 90, 70);
    ob.orthographic = 1;
    ob.ymag = 1.3;
    CHECK(check_view(m, 2, vb, &ob, field_lin, k, NULL) > 1000);
    free(vb);
    mesh_free(m);

    /* a front-facing quad behind the eye is not drawn */
    rect_z(c, -1, -1, 1, 1, 6, 0);
    m = mesh_new(4, 1);
    add_grid(m, c, 1, 1, 0, 0);
    double v1[4] = {1, 1, 1, 1};
    rad_error err;
    img = NULL;
    CHECK(rn_render(m, 1, v1, &cam, &img, &err) == RAD_OK);
    int seen = 0;
    for (size_t q = 0; img && q < 40u * 40u; q++)
        seen += img->patch[q] != RAD_NONE;
    CHECK(img && seen == 0);
    rn_image_destroy(img);

    /* a half-height that is not a positive number is refused */
    cam.ymag = 0.0;
    CHECK(rn_render(m, 1, v1, &cam, &img, &err) == RAD_ERR_USAGE);
    mesh_free(m);
}

TEST(equal_depth_lower_index_wins)
{
    rad_vec3 q[4];
    rect_z(q, -1, -1, 1, 1, 0, 0);
    rad_mesh *m = mesh_new(8, 2);
    add_grid(m, q, 1, 1, 0, 0);
    add_grid(m, q, 1, 1, 0, 1);
    double vb[8] = {1, 1, 1, 1, 2, 2, 2, 2};
    rn_camera cam = camera(rad_v3(0.3, 0.1, 3), rad_v3(0, 0, 0), rad_v3(0, 1, 0), 60, 40, 30);
    rn_image *img = NULL;
    rad_error err;
    CHECK(rn_render(m, 1, vb, &cam, &img, &err) == RAD_OK);
    int covered = 0, wrong = 0;
    for (size_t k = 0; img && k < 40u * 30u; k++) {
        if (img->patch[k] == RAD_NONE)
            continue;
        covered++;
        wrong += img->patch[k] != 0;
    }
    CHECK(covered > 100);
    CHECK(wrong == 0);
    rn_image_destroy(img);
    mesh_free(m);
}

TEST(bad_arguments)
{
    rad_vec3 q[4];
    rect_z(q, -1, -1, 1, 1, 0, 0);
    rad_mesh *m = mesh_new(4, 1);
    add_grid(m, q, 1, 1, 0, 0);
    double vb[4] = {1, 1, 1, 1};
    rn_camera good = camera(rad_v3(0, 0, 3), rad_v3(0, 0, 0), rad_v3(0, 1, 0), 60, 16, 16);
    rn_camera bad[12];
    for (int k = 0; k < 12; k++)
        bad[k] = good;
    bad[0].eye.x = NAN;
    bad[1].yfov_deg = 0;
    bad[2].yfov_deg = 180;
    bad[3].yfov_deg = -5;
    bad[4].width = 0;
    bad[5].height = 16385;
    bad[6].target = bad[6].eye;
    bad[7].up = rad_v3(0, 0, 1); /* parallel to the view direction */
    bad[8].up = rad_v3(0, 0, 0);
    bad[9].target.y = INFINITY;
    bad[10].yfov_deg = NAN;
    bad[11].up = rad_v3(0, 0, -2);
    for (int k = 0; k < 12; k++) {
        rn_image dummy, *img = &dummy; /* must be reset to NULL */
        rad_error err = {0};
        CHECK_MSG(rn_render(m, 1, vb, &bad[k], &img, &err) == RAD_ERR_USAGE, "camera %d", k);
        CHECK(img == NULL);
        CHECK(err.code == RAD_ERR_USAGE && err.message[0] != '\0');
    }
    rn_image *img = NULL;
    rad_error err;
    CHECK(rn_render(m, 0, vb, &good, &img, &err) == RAD_ERR_USAGE);
    CHECK(rn_render(m, RAD_MAX_BANDS + 1, vb, &good, &img, &err) == RAD_ERR_USAGE);
    CHECK(rn_render(m, 1, NULL, &good, &img, &err) == RAD_ERR_USAGE);
    CHECK(rn_render(NULL, 1, vb, &good, &img, &err) == RAD_ERR_USAGE);
    CHECK(rn_render(m, 1, vb, NULL, &img, &err) == RAD_ERR_USAGE);
    m->patches[0].v[2] = 4; /* out of range */
    CHECK(rn_render(m, 1, vb, &good, &img, &err) == RAD_ERR_INVALID);
    CHECK(img == NULL);
    m->patches[0].v[2] = 2;
    m->vertices[1].y = NAN;
    CHECK(rn_render(m, 1, vb, &good, &img, &err) == RAD_ERR_INVALID);
    mesh_free(m);
    rn_image_destroy(NULL); /* does nothing */
}

/* ---------------------------------------------------------------- files */

static char tmpdir[64];

static char *tpath(const char *name)
{
    static char buf[4][256];
    static int k;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

static rn_image *test_image(uint32_t w, uint32_t h, uint32_t c)
{
    rn_image *img = calloc(1, sizeof *img);
    img->width = w;
    img->height = h;
    img->channels = c;
    img->pixels = malloc(sizeof(float) * w * h * c);
    img->patch = malloc(sizeof(uint32_t) * w * h);
    for (size_t k = 0; k < (size_t)w * h * c; k++)
        img->pixels[k] = (float)(sin(0.37 * k) * pow(10.0, (double)(k % 13) - 6.0));
    img->pixels[0] = 0.0f;
    if (w * h * c > 2) {
        img->pixels[1] = 3.0e38f;
        img->pixels[2] = 1.0e-40f; /* denormal */
    }
    for (size_t k = 0; k < (size_t)w * h; k++)
        img->patch[k] = (uint32_t)k;
    return img;
}

static int no_temp_left(void)
{
    DIR *d = opendir(tmpdir);
    struct dirent *e;
    int found = 0;
    while (d && (e = readdir(d)))
        found += strstr(e->d_name, ".tmp.") != NULL;
    if (d)
        closedir(d);
    return found == 0;
}

static long file_size(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 ? (long)st.st_size : -1;
}

TEST(exr_round_trip)
{
    static const uint32_t bands[4] = {1, 3, 2, 12};
    static const char *const codecs[4] = {"zip", "none", "rle", "piz"};
    for (int t = 0; t < 16; t++) {
        rn_image *img = test_image(7 + t % 4, 37, bands[t % 4]), *back = NULL; /* several chunks */
        rad_error err = {0};
        const char *p = tpath("round.exr");
        rn_exr_compression codec = RN_EXR_ZIP;
        CHECK(rn_exr_compression_parse(codecs[t / 4], &codec) == 0);
        CHECK_MSG(rn_write_exr_with(img, p, codec, &err) == RAD_OK, "%s", err.message);
        CHECK_MSG(test_read_exr(p, &back, &err) == RAD_OK, "%s", err.message);
        if (back) {
            CHECK(back->width == img->width && back->height == img->height);
            CHECK(back->channels == img->channels);
            if (back->channels == img->channels && back->width == img->width) {
                size_t n = (size_t)img->width * img->height * img->channels, diff = 0;
                for (size_t k = 0; k < n; k++) /* float channels: bit-exact */
                    diff += memcmp(&back->pixels[k], &img->pixels[k], sizeof(float)) != 0;
                CHECK_MSG(diff == 0, "%zu of %zu values differ (%u bands, %s)", diff, n,
                          bands[t % 4], codecs[t / 4]);
            }
            CHECK(back->patch && back->patch[0] == RAD_NONE);
        }
        rn_image_destroy(back);
        rn_image_destroy(img);
    }
    rn_exr_compression codec = RN_EXR_NONE;
    CHECK(rn_exr_compression_parse("ZIP", &codec) == -1 && codec == RN_EXR_NONE);
    CHECK(rn_exr_compression_parse(NULL, &codec) == -1);
    rad_error e2;
    rn_image *tiny = test_image(2, 2, 1);
    CHECK(rn_write_exr_with(tiny, tpath("bad.exr"), (rn_exr_compression)9, &e2) == RAD_ERR_USAGE);
    rn_image_destroy(tiny);
    CHECK(no_temp_left());
    /* Not an EXR: a parse error, not a crash. */
    const char *junk = tpath("junk.exr");
    FILE *f = fopen(junk, "wb");
    fputs("this is not an image", f);
    fclose(f);
    rn_image *back = NULL;
    rad_error err;
    int rc = test_read_exr(junk, &back, &err);
    CHECK(rc == RAD_ERR_PARSE || rc == RAD_ERR_IO);
    CHECK(back == NULL);
    CHECK(test_read_exr(tpath("missing.exr"), &back, &err) != RAD_OK);
}

static uint32_t be32(const unsigned char *b)
{
    return (uint32_t)b[0] << 24 | (uint32_t)b[1] << 16 | (uint32_t)b[2] << 8 | b[3];
}

TEST(png_written)
{
    static const uint32_t bands[3] = {3, 1, 2};
    static const int colour[3] = {2, 0, 0}; /* PNG colour types: RGB, grey, grey */
    for (int t = 0; t < 3; t++) {
        rn_image *img = test_image(37, 23, bands[t]);
        rad_error err = {0};
        const char *p = tpath("view.png");
        CHECK_MSG(rn_write_png(img, p, 0.5, &err) == RAD_OK, "%s", err.message);
        unsigned char h[33] = {0};
        FILE *f = fopen(p, "rb");
        CHECK(f && fread(h, 1, sizeof h, f) == sizeof h);
        if (f)
            fclose(f);
        CHECK(memcmp(h, "\x89PNG\r\n\x1a\n", 8) == 0);
        CHECK(memcmp(h + 12, "IHDR", 4) == 0);
        CHECK(be32(h + 16) == 37 && be32(h + 20) == 23);
        CHECK(h[24] == 8 && h[25] == colour[t]);
        CHECK(file_size(p) > 33);
        rn_image_destroy(img);
    }
    rn_image *img = test_image(4, 4, 3);
    rad_error err;
    CHECK(rn_write_png(img, tpath("x.png"), NAN, &err) == RAD_ERR_USAGE);
    rn_image_destroy(img);
    CHECK(no_temp_left());
}

/* The PNG's bytes are the sRGB code of each value: checked on one-pixel
 * images at values just below and above every step of the code (the
 * encoder finds its steps by a table), decoded by the glTF loader's
 * decoder (stb_image, sRGB to linear) and compared with this test's own
 * code and decode of the same value. */
static double test_srgb_code(double x)
{
    if (!(x > 0.0))
        return 0;
    if (x >= 1.0)
        return 255;
    double s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return floor(s * 255.0 + 0.5);
}

static double test_srgb_linear(double code)
{
    double c = code / 255.0;
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

TEST(png_srgb_codes)
{
    rn_image *img = test_image(1, 1, 3);
    int bad = 0, tried = 0;
    for (int k = 1; k <= 255 && bad < 5; k++) {
        /* The linear value where the code steps from k - 1 to k. */
        double c = (k - 0.5) / 255.0;
        double step = c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
        const double at[3] = {step * (1 - 1e-6), step * (1 + 1e-6), step * (1 + 0.3 / k)};
        for (int q = 0; q < 3; q++) {
            for (int b = 0; b < 3; b++)
                img->pixels[b] = (float)at[(q + b) % 3];
            rad_error err = {0};
            const char *p = tpath("code.png");
            if (rn_write_png(img, p, 0.0, &err) != RAD_OK) {
                bad++;
                continue;
            }
            unsigned char data[512];
            FILE *f = fopen(p, "rb");
            size_t size = f ? fread(data, 1, sizeof data, f) : 0;
            if (f)
                fclose(f);
            double mean[3] = {-1, -1, -1};
            char why[128];
            int rc = rad_gltf_image_mean(data, size, 16, mean, why, sizeof why);
            for (int b = 0; b < 3; b++) {
                double want = test_srgb_linear(test_srgb_code((double)img->pixels[b]));
                tried++;
                if (rc != 0 || fabs(mean[b] - want) > 1e-12) {
                    bad++;
                    fprintf(stderr, "  value %.9g: decoded %.9g, want %.9g (code %g)\n",
                            (double)img->pixels[b], mean[b], want,
                            test_srgb_code((double)img->pixels[b]));
                }
            }
        }
    }
    CHECK_MSG(bad == 0, "%d of %d channel values coded wrong", bad, tried);
    CHECK(tried == 255 * 9);
    rn_image_destroy(img);
}

TEST(failed_writes_leave_files_alone)
{
    rn_image *img = test_image(8, 6, 3);
    rad_error err;
    /* A directory that does not exist: I/O error and no file. */
    char p[300];
    snprintf(p, sizeof p, "%s/no/such/dir/out.exr", tmpdir);
    CHECK(rn_write_exr(img, p, &err) == RAD_ERR_IO);
    CHECK(err.message[0] != '\0');
    CHECK(file_size(p) < 0);
    snprintf(p, sizeof p, "%s/no/such/dir/out.png", tmpdir);
    CHECK(rn_write_png(img, p, 0, &err) == RAD_ERR_IO);
    CHECK(file_size(p) < 0);

    /* An existing file survives a write that fails. */
    const char *keep = tpath("keep.exr");
    FILE *f = fopen(keep, "wb");
    fputs("precious", f);
    fclose(f);
    float *px = img->pixels;
    img->pixels = NULL; /* invalid image */
    CHECK(rn_write_exr(img, keep, &err) == RAD_ERR_USAGE);
    CHECK(rn_write_png(img, keep, 0, &err) == RAD_ERR_USAGE);
    img->pixels = px;
    img->channels = 0;
    CHECK(rn_write_exr(img, keep, &err) == RAD_ERR_USAGE);
    img->channels = 3;
    char buf[32] = {0};
    f = fopen(keep, "rb");
    CHECK(f && fread(buf, 1, sizeof buf - 1, f) == 8);
    if (f)
        fclose(f);
    CHECK(strcmp(buf, "precious") == 0);

    /* A failure after the temporary file exists (rename onto a directory):
     * the temporary is removed and the directory untouched. */
    const char *dir = tpath("adir");
    CHECK(mkdir(dir, 0700) == 0);
    CHECK(rn_write_exr(img, dir, &err) == RAD_ERR_IO);
    CHECK(rn_write_png(img, dir, 0, &err) == RAD_ERR_IO);
    struct stat st;
    CHECK(stat(dir, &st) == 0 && S_ISDIR(st.st_mode));
    CHECK(no_temp_left());
    rmdir(dir);

    /* And a good write replaces the old file. */
    CHECK(rn_write_exr(img, keep, &err) == RAD_OK);
    CHECK(file_size(keep) > 100);
    CHECK(no_temp_left());
    rn_image_destroy(img);
}

/* Files committed later (rad_committer, as `render` does with many
 * views): each write returns at once; after rad_committer_finish the good
 * ones are in place, bit-identical to a direct write, no temporary is left,
 * and the one whose rename failed (onto a directory) is the failure
 * reported, naming it, while the others still went through. */
TEST(committed_later)
{
    rn_image *img = test_image(8, 6, 3);
    rad_error err = {0};
    rad_committer *c = NULL;
    CHECK(rad_committer_create(&c, &err) == RAD_OK);
    const char *dir = tpath("later_dir");
    CHECK(mkdir(dir, 0700) == 0);
    char a[300], b[300], direct[300];
    snprintf(a, sizeof a, "%s", tpath("later_a.exr"));
    snprintf(b, sizeof b, "%s", tpath("later_b.png"));
    snprintf(direct, sizeof direct, "%s", tpath("direct_a.exr"));
    CHECK(rn_write_exr_later(img, a, RN_EXR_NONE, c, &err) == RAD_OK);
    CHECK(rn_write_exr_later(img, dir, RN_EXR_NONE, c, &err) == RAD_OK); /* fails later */
    CHECK(rn_write_png_later(img, b, 0.0, c, &err) == RAD_OK);
    CHECK(rad_committer_finish(c, &err) == RAD_ERR_IO);
    CHECK_MSG(strstr(err.message, "later_dir") != NULL, "%s", err.message);
    CHECK(rn_write_exr_with(img, direct, RN_EXR_NONE, &err) == RAD_OK);
    const long sa = file_size(a), sd = file_size(direct);
    CHECK(sa > 100 && sa == sd && file_size(b) > 50);
    FILE *fa = fopen(a, "rb"), *fd = fopen(direct, "rb");
    int same = fa && fd;
    for (int x = 0, y = 0; same && x != EOF; same = x == y)
        x = fgetc(fa), y = fgetc(fd);
    if (fa)
        fclose(fa);
    if (fd)
        fclose(fd);
    CHECK(same);
    struct stat st;
    CHECK(stat(dir, &st) == 0 && S_ISDIR(st.st_mode));
    CHECK(no_temp_left());
    CHECK(rad_committer_finish(NULL, &err) == RAD_OK);
    rmdir(dir);
    rn_image_destroy(img);
}

static void cleanup_dir(void)
{
    DIR *d = opendir(tmpdir);
    struct dirent *e;
    while (d && (e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        char p[512];
        snprintf(p, sizeof p, "%s/%s", tmpdir, e->d_name);
        if (unlink(p) != 0)
            rmdir(p);
    }
    if (d)
        closedir(d);
    rmdir(tmpdir);
}

int main(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/test_render.XXXXXX");
    if (!mkdtemp(tmpdir)) {
        fprintf(stderr, "cannot make a temporary directory: %s\n", strerror(errno));
        return 1;
    }
    RUN(vertex_linear_field_exact);
    RUN(vertex_rules_of_the_paper);
    RUN(vertex_quadratic_fit);
    RUN(vertex_clamp_and_fallbacks);
    RUN(uniform_quad);
    RUN(linear_ramp_quads);
    RUN(linear_ramp_trapezoid);
    RUN(linear_ramp_triangles);
    RUN(canvas_kept_between_views);
    RUN(shading_slots_shared_by_kinds);
    RUN(no_cracks);
    RUN(occlusion_and_culling);
    RUN(orthographic_views);
    RUN(equal_depth_lower_index_wins);
    RUN(bad_arguments);
    RUN(exr_round_trip);
    RUN(png_written);
    RUN(png_srgb_codes);
    RUN(failed_writes_leave_files_alone);
    RUN(committed_later);
    cleanup_dir();
    return test_finish("test_render");
}
