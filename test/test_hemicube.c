/* test_hemicube.c - checks the hemi-cube form factors against closed forms
 * (Howell's catalogue values), conservation in a closed box, reciprocity,
 * the row invariants, determinism, float precision far from the origin,
 * the exact entries (a small light, occluded or not; near plates; a closed
 * box of exact patches), the punctual lights against solid angles, cosines
 * and shadow geometry, option checking and killed workers.
 *
 * Meshes are built here by hand (n×m grids of quads per rectangle) so the
 * test depends on nothing but the core and the hemicube module.
 */
#include "../hemicube/hemicube.h"
#include "test.h"
#include "util.h"

#include <dirent.h>
#include <signal.h>
#include <stdint.h>
#include <sys/types.h>
#include <unistd.h>

/* ------------------------------------------------------------ mesh builder */

typedef struct builder {
    rad_mesh m;
    uint32_t vcap, pcap;
    uint32_t polygons;
} builder;

static uint32_t add_vertex(builder *b, rad_vec3 p)
{
    if (b->m.vertex_count == b->vcap) {
        b->vcap = b->vcap ? 2 * b->vcap : 64;
        b->m.vertices = realloc(b->m.vertices, b->vcap * sizeof *b->m.vertices);
        b->m.vertex_boundary = realloc(b->m.vertex_boundary, b->vcap);
        if (!b->m.vertices || !b->m.vertex_boundary)
            abort();
    }
    b->m.vertices[b->m.vertex_count] = p;
    b->m.vertex_boundary[b->m.vertex_count] = 0;
    return b->m.vertex_count++;
}

/* Rectangle (parallelogram) o + s·e1 + t·e2, s, t in [0, 1], split into
 * nx × ny quads; its normal is e1 × e2 and the corners run counter-clockwise
 * seen from that side.  Returns the first patch index. */
static uint32_t add_rect(builder *b, rad_vec3 o, rad_vec3 e1, rad_vec3 e2, uint32_t nx, uint32_t ny)
{
    uint32_t first_v = b->m.vertex_count, first_p = b->m.patch_count;
    for (uint32_t y = 0; y <= ny; y++)
        for (uint32_t x = 0; x <= nx; x++) {
            uint32_t k = add_vertex(b, rad_add(o, rad_add(rad_scale(e1, (double)x / nx),
                                                          rad_scale(e2, (double)y / ny))));
            b->m.vertex_boundary[k] = x == 0 || y == 0 || x == nx || y == ny;
        }
    rad_vec3 cr = rad_cross(e1, e2);
    double area = rad_length(cr) / (nx * ny);
    rad_vec3 nrm = rad_normalize(cr);
    for (uint32_t y = 0; y < ny; y++)
        for (uint32_t x = 0; x < nx; x++) {
            if (b->m.patch_count == b->pcap) {
                b->pcap = b->pcap ? 2 * b->pcap : 64;
                b->m.patches = realloc(b->m.patches, b->pcap * sizeof *b->m.patches);
                if (!b->m.patches)
                    abort();
            }
            rad_patch *p = &b->m.patches[b->m.patch_count++];
            uint32_t v00 = first_v + y * (nx + 1) + x;
            p->v[0] = v00;
            p->v[1] = v00 + 1;
            p->v[2] = v00 + (nx + 1) + 1;
            p->v[3] = v00 + (nx + 1);
            p->polygon = b->polygons;
            p->object = 0;
            p->material = 0;
            p->center = rad_add(o, rad_add(rad_scale(e1, (x + 0.5) / nx), rad_scale(e2, (y + 0.5) / ny)));
            p->normal = nrm;
            p->area = area;
        }
    b->polygons++;
    return first_p;
}

static void builder_free(builder *b)
{
    free(b->m.vertices);
    free(b->m.vertex_boundary);
    free(b->m.patches);
    memset(b, 0, sizeof *b);
}

/* Two unit squares, distance 1, facing each other: patches [0, n²) below,
 * [n², 2n²) above. */
static void parallel_squares(builder *b, uint32_t n, rad_vec3 off)
{
    add_rect(b, off, rad_v3(1, 0, 0), rad_v3(0, 1, 0), n, n);                 /* z = 0, +z */
    add_rect(b, rad_add(off, rad_v3(0, 0, 1)), rad_v3(0, 1, 0), rad_v3(1, 0, 0), n, n); /* z = 1, -z */
}

/* Unit cube [0,1]³ with six inward faces of n×n patches. */
static void closed_cube(builder *b, uint32_t n)
{
    add_rect(b, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), n, n); /* z=0, normal +z */
    add_rect(b, rad_v3(0, 0, 1), rad_v3(0, 1, 0), rad_v3(1, 0, 0), n, n); /* z=1, normal -z */
    add_rect(b, rad_v3(0, 0, 0), rad_v3(0, 1, 0), rad_v3(0, 0, 1), n, n); /* x=0, normal +x */
    add_rect(b, rad_v3(1, 0, 0), rad_v3(0, 0, 1), rad_v3(0, 1, 0), n, n); /* x=1, normal -x */
    add_rect(b, rad_v3(0, 0, 0), rad_v3(0, 0, 1), rad_v3(1, 0, 0), n, n); /* y=0, normal +y */
    add_rect(b, rad_v3(0, 1, 0), rad_v3(1, 0, 0), rad_v3(0, 0, 1), n, n); /* y=1, normal -y */
}

static uint32_t *all_rows(uint32_t n)
{
    uint32_t *r = malloc((n ? n : 1) * sizeof *r);
    for (uint32_t k = 0; k < n; k++)
        r[k] = k;
    return r;
}

/* Computes every row of b's mesh; NULL (and a failed check) on error. */
static rad_matrix *compute_all(const builder *b, uint32_t R, uint32_t processes)
{
    hc_options o = {0};
    o.resolution = R;
    o.processes = processes;
    hc_engine *e = NULL;
    rad_error err = {0};
    int rc = hc_create(&b->m, &o, &e, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return NULL;
    rad_matrix *F = rad_matrix_create(b->m.patch_count);
    uint32_t *rows = all_rows(b->m.patch_count);
    rc = hc_compute_rows(e, rows, b->m.patch_count, F, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    free(rows);
    hc_destroy(e);
    if (rc) {
        rad_matrix_destroy(F);
        return NULL;
    }
    return F;
}

static double entry(const rad_matrix *F, uint32_t i, uint32_t j)
{
    if (!F->row_done[i])
        return NAN;
    const uint32_t *c;
    const float *v;
    uint32_t cnt = test_row(F, i, 0, &c, &v);
    for (uint32_t k = 0; k < cnt; k++)
        if (c[k] == j)
            return v[k];
    return 0.0;
}

/* (1/A_a) Σ_{i∈a} Σ_{j∈b} A_i F_ij: the polygon-to-polygon factor. */
static double polygon_ff(const builder *b, const rad_matrix *F, uint32_t a0, uint32_t a1, uint32_t b0,
                         uint32_t b1)
{
    double s = 0.0, area = 0.0;
    for (uint32_t i = a0; i < a1; i++) {
        area += b->m.patches[i].area;
        const uint32_t *c;
        const float *v;
        uint32_t cnt = test_row(F, i, 0, &c, &v);
        for (uint32_t k = 0; k < cnt; k++)
            if (c[k] >= b0 && c[k] < b1)
                s += b->m.patches[i].area * v[k];
    }
    return s / area;
}

/* ------------------------------------------------------------------ tests */

TEST(delta_form_factors)
{
    static double buf[3 * 256 * 256];
    double e16 = fabs(hc_delta_form_factors(16, buf) - 1.0);
    double e64 = fabs(hc_delta_form_factors(64, buf) - 1.0);
    double raw = hc_delta_form_factors(256, buf);
    double e256 = fabs(raw - 1.0);
    printf("     raw ΔF sums - 1: R=16 %.3g, R=64 %.3g, R=256 %.3g\n", e16, e64, e256);
    /* The midpoint rule's error is O(1/R²): it must fall with R and be below
     * 1e-3 at R = 256 (the brief's requirement). */
    CHECK(e64 < e16);
    CHECK(e256 < e64);
    CHECK(e256 < 1e-3);
    double s = 0.0;
    for (size_t k = 0; k < 3 * 256 * 256; k++)
        s += buf[k];
    /* Normalised: 196608 double additions, rounding well below 1e-12. */
    CHECK_NEAR(s, 1.0, 1e-12);
    /* One value recomputed independently: top-face pixel (x=10, y=200) and
     * side face +u (second block), pixel (x=3, z=100), from Fig. 7. */
    double d = 2.0 / 256, x = -1 + 10.5 * d, y = -1 + 200.5 * d;
    double top = d * d / (M_PI * pow(x * x + y * y + 1, 2)) / raw;
    CHECK_NEAR(buf[200 * 256 + 10], top, 1e-15);
    double sy = -1 + 3.5 * d, sz = 100.5 * d;
    double side = sz * d * d / (M_PI * pow(sy * sy + sz * sz + 1, 2)) / raw;
    CHECK_NEAR(buf[256 * 256 + 100 * 256 + 3], side, 1e-15);
    /* Invalid resolutions write nothing and return 0. */
    CHECK(hc_delta_form_factors(7, buf) == 0.0);
    CHECK(hc_delta_form_factors(4098, buf) == 0.0);
}

TEST(parallel_squares_analytic)
{
    builder b = {0};
    parallel_squares(&b, 16, rad_v3(0, 0, 0));
    rad_matrix *F = compute_all(&b, 128, 0);
    if (F) {
        double f12 = polygon_ff(&b, F, 0, 256, 256, 512);
        double f21 = polygon_ff(&b, F, 256, 512, 0, 256);
        printf("     parallel squares: F12 = %.8f F21 = %.8f (Howell C-11: 0.19982490)\n", f12, f21);
        /* Hemi-cube aliasing and centre sampling at R = 128 with 16×16
         * patches: +5.9e-4 (measured; the brief's bound is 0.5 %).  0.2 %,
         * so that a factor shifted by 0.4 % either way fails. */
        CHECK_REL(f12, 0.19982490, 2e-3);
        CHECK_REL(f21, 0.19982490, 2e-3);
        rad_error err;
        CHECK(rad_matrix_check(F, &err) == RAD_OK);
    }
    rad_matrix_destroy(F);
    builder_free(&b);
}

TEST(perpendicular_squares_analytic)
{
    builder b = {0};
    add_rect(&b, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 16, 16); /* z=0, +z */
    add_rect(&b, rad_v3(0, 0, 0), rad_v3(0, 1, 0), rad_v3(0, 0, 1), 16, 16); /* x=0, +x */
    rad_matrix *F = compute_all(&b, 128, 0);
    if (F) {
        double f12 = polygon_ff(&b, F, 0, 256, 256, 512);
        printf("     perpendicular squares: F12 = %.8f (Howell C-14: 0.20004378), rel. error %.2e\n",
               f12, f12 / 0.20004378 - 1);
        /* Patches next to the common edge see the other square at close
         * range where the hemi-cube's point-at-centre assumption is coarse
         * (the brief allows 1 %); measured -1.5e-4, so 5e-4. */
        CHECK_REL(f12, 0.20004378, 5e-4);
    }
    rad_matrix_destroy(F);
    builder_free(&b);
}

TEST(closed_cube_rows_sum_to_one)
{
    builder b = {0};
    closed_cube(&b, 8);
    rad_matrix *F = compute_all(&b, 128, 0);
    if (F) {
        double worst = 0.0;
        for (uint32_t i = 0; i < b.m.patch_count; i++) {
            double s = rad_matrix_row_sum(F, i);
            if (fabs(s - 1.0) > worst)
                worst = fabs(s - 1.0);
            /* Every direction above i's plane hits a wall: the row must sum
             * to 1 up to float rounding of the entries (1e-3 per the brief). */
            CHECK_NEAR(s, 1.0, 1e-3);
        }
        printf("     closed cube: worst |row sum - 1| = %.3g\n", worst);
        /* Coplanar patches (same face) never appear. */
        for (uint32_t i = 0; i < b.m.patch_count; i++) {
            const uint32_t *c;
            const float *v;
            uint32_t cnt = test_row(F, i, 0, &c, &v);
            for (uint32_t k = 0; k < cnt; k++)
                CHECK(b.m.patches[c[k]].polygon != b.m.patches[i].polygon);
        }
    }
    rad_matrix_destroy(F);
    builder_free(&b);
}

TEST(reciprocity)
{
    builder b = {0};
    closed_cube(&b, 8);
    /* R = 512 so that a pair with both F >= 0.01 covers at least
     * 0.01 / max ΔF = 0.01·π·R²/4 ≈ 2000 pixels (~45×45): half-pixel aliasing
     * along its four edges is then at most ~4.4 % on either side. */
    rad_matrix *F = compute_all(&b, 512, 0);
    if (F) {
        const double w = 1.0 / 8; /* patch width */
        double worst = 0.0;
        uint32_t pairs = 0;
        for (uint32_t i = 0; i < b.m.patch_count; i++)
            for (uint32_t j = i + 1; j < b.m.patch_count; j++) {
                const rad_patch *pi = &b.m.patches[i], *pj = &b.m.patches[j];
                if (pi->polygon == pj->polygon)
                    continue;
                if (rad_length(rad_sub(pi->center, pj->center)) < 3 * w)
                    continue;
                double fij = entry(F, i, j), fji = entry(F, j, i);
                if (fmin(fij, fji) < 0.01)
                    continue;
                double aij = pi->area * fij, aji = pj->area * fji;
                double rel = fabs(aij - aji) / fmax(aij, aji);
                if (rel > worst)
                    worst = rel;
                pairs++;
                /* A_i F_ij = A_j F_ji within the brief's 5 %. */
                CHECK_MSG(rel <= 0.05, "pair %u,%u: %g vs %g", i, j, aij, aji);
            }
        printf("     reciprocity: %u resolved pairs, worst relative difference %.3g\n", pairs, worst);
        CHECK(pairs >= 500);
    }
    rad_matrix_destroy(F);
    builder_free(&b);

    /* Polygon level, an asymmetric pair: a 0.5×0.3 rectangle (5×3 patches)
     * tilted by 30° above a unit square (8×8), both facing each other.  The
     * sums over many pairs average the aliasing away. */
    builder c = {0};
    add_rect(&c, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 8, 8);
    double s30 = 0.5, c30 = sqrt(3) / 2;
    add_rect(&c, rad_v3(0.3, 0.2, 0.8), rad_v3(0, 0.3, 0), rad_v3(0.5 * c30, 0, 0.5 * s30), 3, 5);
    F = compute_all(&c, 128, 0);
    if (F) {
        double a1 = 1.0, a2 = 0.15;
        double f12 = polygon_ff(&c, F, 0, 64, 64, 79), f21 = polygon_ff(&c, F, 64, 79, 0, 64);
        printf("     polygon reciprocity: A1 F12 = %.6f, A2 F21 = %.6f\n", a1 * f12, a2 * f21);
        CHECK(f12 > 0.0);
        /* Each side is a sum over 960 pairs: 1 % covers the residual aliasing
         * and the centre-point approximation. */
        CHECK_REL(a1 * f12, a2 * f21, 1e-2);
    }
    rad_matrix_destroy(F);
    builder_free(&c);
}

/* From a differential element at the corner of an a×b rectangle, facing it
 * at distance c (Howell B-3), written out here independently. */
static double element_to_rect(double a, double b, double c)
{
    double A = a / c, B = b / c, sa = sqrt(1 + A * A), sb = sqrt(1 + B * B);
    return (A / sa * atan(B / sa) + B / sb * atan(A / sb)) / (2 * M_PI);
}

TEST(element_to_rectangle_analytic)
{
    /* A 1e-3 patch stands in for the differential element; its centre sits
     * on the normal through the rectangle's corner. */
    const double cases[3][3] = {{0.7, 0.4, 1.0}, {3.0, 2.0, 1.0}, {0.3, 5.0, 0.5}};
    for (int t = 0; t < 3; t++) {
        builder b = {0};
        const double s = 1e-3;
        add_rect(&b, rad_v3(-s / 2, -s / 2, 0), rad_v3(s, 0, 0), rad_v3(0, s, 0), 1, 1);
        add_rect(&b, rad_v3(0, 0, cases[t][2]), rad_v3(0, cases[t][1], 0), rad_v3(cases[t][0], 0, 0),
                 1, 1);
        rad_matrix *F = compute_all(&b, 512, 1);
        if (F) {
            double f = entry(F, 0, 1), ex = element_to_rect(cases[t][0], cases[t][1], cases[t][2]);
            printf("     element to rectangle %gx%g at %g: F = %.7f, B-3 %.7f\n", cases[t][0],
                   cases[t][1], cases[t][2], f, ex);
            /* Two rectangle edges lie on pixel boundaries, the other two cost
             * at most half a pixel along their length: below 0.8 % at R = 512
             * for the smallest case (0.7×0.4 → 179×102 pixels). */
            CHECK_REL(f, ex, 1e-2);
        }
        rad_matrix_destroy(F);
        builder_free(&b);
    }
}

TEST(no_self_no_behind)
{
    builder b = {0};
    parallel_squares(&b, 8, rad_v3(0, 0, 0));
    /* Square behind the lower one (z = -0.5), facing it: every one of its
     * patches lies behind the lower square's plane. */
    add_rect(&b, rad_v3(0, 0, -0.5), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 8, 8);
    /* A square crossing the lower square's plane and facing it (-x): its
     * upper half is visible. */
    add_rect(&b, rad_v3(1.2, 0, -0.5), rad_v3(0, 0, 1), rad_v3(0, 1, 0), 4, 4);
    /* The same on the other side, facing away (-x): only its back shows, and
     * a back side belongs to no patch. */
    add_rect(&b, rad_v3(-0.2, 0, -0.5), rad_v3(0, 0, 1), rad_v3(0, 1, 0), 4, 4);
    rad_matrix *F = compute_all(&b, 64, 2);
    if (F) {
        rad_error err;
        CHECK_MSG(rad_matrix_check(F, &err) == RAD_OK, "%s", err.message);
        uint32_t bad = 0, seen_straddle = 0;
        for (uint32_t i = 0; i < b.m.patch_count; i++) {
            const rad_patch *pi = &b.m.patches[i];
            const uint32_t *col;
            const float *val;
            uint32_t cnt = test_row(F, i, 0, &col, &val);
            for (uint32_t k = 0; k < cnt; k++) {
                uint32_t j = col[k];
                CHECK(j != i);
                CHECK(val[k] > 0.0f);
                const rad_patch *pj = &b.m.patches[j];
                int front = 0;
                for (int c = 0; c < 4; c++)
                    front |= rad_dot(rad_sub(b.m.vertices[pj->v[c]], pi->center), pi->normal) > 1e-12;
                bad += !front;
                if (i < 64 && pj->polygon == 3)
                    seen_straddle = 1;
            }
            /* The lower square's rows never hold the square behind it nor
             * the back of polygon 4. */
            if (i < 64)
                for (uint32_t k = 0; k < cnt; k++) {
                    CHECK(b.m.patches[col[k]].polygon != 2);
                    CHECK(b.m.patches[col[k]].polygon != 4);
                }
        }
        CHECK(bad == 0);
        CHECK(seen_straddle);
    }
    rad_matrix_destroy(F);
    builder_free(&b);
}

static int rows_identical(const rad_matrix *A, const rad_matrix *B)
{
    if (A->n != B->n)
        return 0;
    for (uint32_t i = 0; i < A->n; i++) {
        if (A->row_done[i] != B->row_done[i] || A->row_count[i] != B->row_count[i])
            return 0;
        const uint32_t *ca, *cb;
        const float *va, *vb;
        size_t c = test_row(A, i, 0, &ca, &va);
        test_row(B, i, 1, &cb, &vb);
        if (memcmp(ca, cb, c * sizeof *ca) || memcmp(va, vb, c * sizeof *va))
            return 0;
    }
    return 1;
}

TEST(determinism)
{
    builder b = {0};
    closed_cube(&b, 6);
    /* Two coincident coplanar squares (same vertices, polygons 6 and 7) and a
     * third overlapping half of them: z-fighting the fixed draw order must
     * resolve identically every time. */
    add_rect(&b, rad_v3(0.25, 0.25, 0.5), rad_v3(0, 0.5, 0), rad_v3(0.5, 0, 0), 3, 3);
    add_rect(&b, rad_v3(0.25, 0.25, 0.5), rad_v3(0, 0.5, 0), rad_v3(0.5, 0, 0), 3, 3);
    add_rect(&b, rad_v3(0.5, 0.25, 0.5), rad_v3(0, 0.5, 0), rad_v3(0.5, 0, 0), 5, 2);
    rad_matrix *A = compute_all(&b, 64, 1);
    rad_matrix *B = compute_all(&b, 64, 2);
    rad_matrix *C = compute_all(&b, 64, 2);
    if (A && B && C) {
        CHECK(rows_identical(A, B));
        CHECK(rows_identical(B, C));
        /* The same engine, rows in reverse order and twice. */
        hc_options o = {.resolution = 64, .processes = 2};
        hc_engine *e = NULL;
        rad_error err;
        CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
        rad_matrix *D = rad_matrix_create(b.m.patch_count);
        uint32_t n = b.m.patch_count;
        uint32_t *rows = malloc(n * sizeof *rows);
        for (uint32_t k = 0; k < n; k++)
            rows[k] = n - 1 - k;
        CHECK(hc_compute_rows(e, rows, n, D, &err) == RAD_OK);
        CHECK(rows_identical(A, D));
        CHECK(hc_compute_rows(e, rows + n / 2, 1, D, &err) == RAD_OK);
        CHECK(rows_identical(A, D));
        free(rows);
        hc_destroy(e);
        rad_matrix_destroy(D);
        /* Overlap resolved in favour of the lower polygon id: the floor sees
         * polygon 6 and no part of its exact twin 7. */
        double f6 = 0, f7 = 0;
        for (uint32_t i = 0; i < 36; i++) {
            const uint32_t *c;
            const float *v;
            uint32_t cnt = test_row(A, i, 0, &c, &v);
            for (uint32_t k = 0; k < cnt; k++) {
                if (b.m.patches[c[k]].polygon == 6)
                    f6 += v[k];
                if (b.m.patches[c[k]].polygon == 7)
                    f7 += v[k];
            }
        }
        CHECK(f6 > 0.0);
        CHECK(f7 == 0.0);
    }
    rad_matrix_destroy(A);
    rad_matrix_destroy(B);
    rad_matrix_destroy(C);
    builder_free(&b);
}

TEST(far_from_origin)
{
    builder b = {0}, c = {0};
    parallel_squares(&b, 16, rad_v3(0, 0, 0));
    parallel_squares(&c, 16, rad_v3(1e5, 1e5, 1e5));
    rad_matrix *F = compute_all(&b, 128, 0);
    rad_matrix *G = compute_all(&c, 128, 0);
    if (F && G) {
        double f = polygon_ff(&b, F, 0, 256, 256, 512);
        double g = polygon_ff(&c, G, 0, 256, 256, 512);
        printf("     offset 1e5: F12 = %.8f vs %.8f at the origin\n", g, f);
        /* Geometry is sent relative to the scene centre, so the offset costs
         * (almost) nothing; 1e-3 per the brief. */
        CHECK_REL(g, f, 1e-3);
        CHECK_REL(g, 0.19982490, 2e-3); /* as parallel_squares_analytic */
    }
    rad_matrix_destroy(F);
    rad_matrix_destroy(G);
    builder_free(&b);
    builder_free(&c);
}

TEST(bad_options)
{
    builder b = {0};
    parallel_squares(&b, 2, rad_v3(0, 0, 0));
    hc_engine *e = (hc_engine *)&b; /* must be reset to NULL on failure */
    rad_error err = {0};
    const uint32_t bad_res[] = {7, 6, 2, 4098, 8192, 129};
    for (size_t k = 0; k < sizeof bad_res / sizeof *bad_res; k++) {
        hc_options o = {.resolution = bad_res[k], .processes = 1};
        CHECK(hc_create(&b.m, &o, &e, &err) == RAD_ERR_USAGE);
        CHECK(e == NULL);
    }
    hc_options o = {.resolution = 16, .processes = 100000};
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_ERR_USAGE);
    CHECK(hc_create(NULL, NULL, &e, &err) == RAD_ERR_USAGE);
    CHECK(hc_create(&b.m, NULL, NULL, &err) == RAD_ERR_USAGE);
    /* Bad index in the mesh. */
    b.m.patches[1].v[2] = b.m.vertex_count;
    CHECK(hc_create(&b.m, NULL, &e, &err) == RAD_ERR_USAGE);
    b.m.patches[1].v[2] = 0;
    /* Rows out of range and a matrix of the wrong size. */
    o.resolution = 16;
    o.processes = 1;
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    rad_matrix *F = rad_matrix_create(b.m.patch_count);
    rad_matrix *G = rad_matrix_create(b.m.patch_count + 1);
    uint32_t r = b.m.patch_count;
    CHECK(hc_compute_rows(e, &r, 1, F, &err) == RAD_ERR_USAGE);
    r = 0;
    CHECK(hc_compute_rows(e, &r, 1, G, &err) == RAD_ERR_USAGE);
    CHECK(hc_compute_rows(e, NULL, 1, F, &err) == RAD_ERR_USAGE);
    CHECK(hc_compute_rows(e, NULL, 0, F, &err) == RAD_OK);
    CHECK(hc_compute_rows(e, &r, 1, F, &err) == RAD_OK);
    CHECK(F->rows_done == 1);
    hc_destroy(e);
    hc_destroy(NULL);
    rad_matrix_destroy(F);
    rad_matrix_destroy(G);
    /* An empty mesh is fine. */
    rad_mesh empty = {0};
    CHECK(hc_create(&empty, NULL, &e, &err) == RAD_OK);
    rad_matrix *Z = rad_matrix_create(0);
    CHECK(hc_compute_rows(e, NULL, 0, Z, &err) == RAD_OK);
    hc_destroy(e);
    rad_matrix_destroy(Z);
    builder_free(&b);
}

/* ------------------------------------------------------- exact entries */

/* Box [lo, hi] with six outward faces, one patch each. */
static void add_box(builder *b, rad_vec3 lo, rad_vec3 hi)
{
    double dx = hi.x - lo.x, dy = hi.y - lo.y, dz = hi.z - lo.z;
    add_rect(b, lo, rad_v3(0, dy, 0), rad_v3(dx, 0, 0), 1, 1);                      /* -z */
    add_rect(b, rad_v3(lo.x, lo.y, hi.z), rad_v3(dx, 0, 0), rad_v3(0, dy, 0), 1, 1); /* +z */
    add_rect(b, lo, rad_v3(0, 0, dz), rad_v3(0, dy, 0), 1, 1);                      /* -x */
    add_rect(b, rad_v3(hi.x, lo.y, lo.z), rad_v3(0, dy, 0), rad_v3(0, 0, dz), 1, 1); /* +x */
    add_rect(b, lo, rad_v3(dx, 0, 0), rad_v3(0, 0, dz), 1, 1);                      /* -y */
    add_rect(b, rad_v3(lo.x, hi.y, lo.z), rad_v3(0, 0, dz), rad_v3(dx, 0, 0), 1, 1); /* +y */
}

/* Computes the given rows with options o; NULL (and a failed check) on error. */
static rad_matrix *compute_rows_with(const builder *b, const hc_options *o, const uint32_t *rows,
                                     uint32_t count)
{
    hc_engine *e = NULL;
    rad_error err = {0};
    int rc = hc_create(&b->m, o, &e, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return NULL;
    rad_matrix *F = rad_matrix_create(b->m.patch_count);
    rc = hc_compute_rows(e, rows, count, F, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    hc_destroy(e);
    if (rc) {
        rad_matrix_destroy(F);
        return NULL;
    }
    return F;
}

/* F_ij of one row computed alone, NAN on failure. */
static double one_entry(const builder *b, const hc_options *o, uint32_t i, uint32_t j)
{
    rad_matrix *F = compute_rows_with(b, o, &i, 1);
    double f = F ? entry(F, i, j) : NAN;
    rad_matrix_destroy(F);
    return f;
}

static void patch_corners(const builder *b, uint32_t j, rad_vec3 p[4])
{
    for (int k = 0; k < 4; k++)
        p[k] = b->m.vertices[b->m.patches[j].v[k]];
}

/* Keeps the part of convex polygon p (count vertices) where m·(x - o) <= 0;
 * returns the new count (out holds up to count + 1 points). */
static uint32_t clip_half_plane(const rad_vec3 *p, uint32_t count, rad_vec3 o, rad_vec3 m,
                                rad_vec3 *out)
{
    uint32_t k = 0;
    for (uint32_t a = 0; a < count; a++) {
        rad_vec3 s = p[a], t = p[(a + 1) % count];
        double ds = rad_dot(m, rad_sub(s, o)), dt = rad_dot(m, rad_sub(t, o));
        if (ds <= 0)
            out[k++] = s;
        if ((ds <= 0) != (dt <= 0))
            out[k++] = rad_lerp(s, t, ds / (ds - dt));
    }
    return k;
}

/* The room of the small-light tests: a unit floor (patches 0-15, up) and a
 * ceiling 1e-3 above z = 1 (16-31, down), below which the lights hang. */
static void add_light_room(builder *b)
{
    add_rect(b, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 4, 4);
    add_rect(b, rad_v3(0, 0, 1.001), rad_v3(0, 1, 0), rad_v3(1, 0, 0), 4, 4);
}

/* A 0.03 × 0.03 light centred on lc (z = 1), facing down: its patch. */
static uint32_t add_small_light(builder *b, rad_vec3 lc)
{
    return add_rect(b, rad_sub(lc, rad_v3(0.015, 0.015, 0)), rad_v3(0, 0.03, 0), rad_v3(0.03, 0, 0), 1, 1);
}

/* Lambert's point-to-polygon factor from (ci, ni) to the part of light j
 * (centred on lc) left of a shadow line 6 mm off lc along m: the side
 * m·(x − line) <= 0. */
static double shaded_light_ff(const builder *b, uint32_t j, rad_vec3 lc, rad_vec3 m, rad_vec3 ci,
                              rad_vec3 ni)
{
    rad_vec3 lp[4], vis[5];
    patch_corners(b, j, lp);
    uint32_t nv = clip_half_plane(lp, 4, rad_add(lc, rad_scale(m, 0.006)), m, vis);
    return hc_ff_point_polygon(ci, ni, vis, nv);
}

/* Patch i's factor to patch j averaged over i (the continuum's, converged):
 * what a patch row's exact entry to an emitter is (rows.c averages it over
 * the receiving patch, so that an emitter's column sums to its area). */
static double area_ff(const builder *b, uint32_t i, uint32_t j)
{
    rad_vec3 pi[4], pj[4];
    patch_corners(b, i, pi);
    patch_corners(b, j, pj);
    return hc_ff_polygon_polygon(pi, 4, pj, 4, 16);
}

TEST(exact_small_source)
{
    /* A 1×1 room cross-section: floor (patches 0-15, up), ceiling 1e-3
     * above the light (16-31, down) and a 0.03×0.03 light at z = 1 facing
     * down (32), 1/1000 of the floor's area, above floor patch 5 (centre
     * (0.375, 0.375)) and a little off its vertical. */
    builder b = {0};
    add_light_room(&b);
    const rad_vec3 lc = rad_v3(0.3812, 0.3733, 1.0);
    uint32_t light = add_small_light(&b, lc);
    const uint32_t i = 5;
    rad_vec3 ci = b.m.patches[i].center, ni = b.m.patches[i].normal, lp[4];
    patch_corners(&b, light, lp);
    /* the row's exact entry: the factor averaged over patch i (ex_area);
     * the visible fraction is measured from i's centre (ex, below) */
    double ex = hc_ff_point_polygon(ci, ni, lp, 4), ex_area = area_ff(&b, i, light);

    uint8_t *marks = calloc(b.m.patch_count + 1, 1);
    marks[light] = 1;
    hc_options plain = {.resolution = 32, .processes = 1};
    hc_options exact = {.resolution = 32, .processes = 1, .exact = marks};
    double pix32 = one_entry(&b, &plain, i, light);
    double ex32 = one_entry(&b, &exact, i, light);
    exact.resolution = 256;
    double ex256 = one_entry(&b, &exact, i, light);
    printf("     light 0.03² at 1: exact %.7g (at c_i %.7g); unmarked R=32 %.7g (%+.1e), exact "
           "path R=32 %.7g (%+.1e), R=256 %.7g (%+.1e)\n",
           ex_area, ex, pix32, pix32 / ex_area - 1, ex32, ex32 / ex_area - 1, ex256,
           ex256 / ex_area - 1);
    /* Unoccluded: F_exact × 1, the area average by the engine's own
     * quadrature (one subdivision at this distance: measured 8.2e-7 from the
     * converged value) and float rounding; at R = 32 the light (half a
     * pixel wide) is found by the probe, at R = 256 by the ratio of the
     * two pixel sums. */
    CHECK_REL(ex32, ex_area, 2e-6);
    CHECK_REL(ex256, ex_area, 2e-6);
    /* Unmarked, the light is still far too small on the cube to be counted
     * (half a pixel at R = 32, where counting saw either nothing or a whole
     * pixel's ΔF of ~1.2e-3 against 2.9e-4): it gets its exact entry all
     * the same, by the point-to-polygon factor from c_i (not averaged: only
     * emitters are), 2 % above the average here. */
    CHECK_REL(pix32, ex, 1e-6);

    /* Partly occluded: a blocker at z = 0.5 whose edge passes 3 mm beside
     * the midpoint of c_i and the light's centre at 25°, so its shadow line
     * cuts the light 6 mm off its centre; the visible part is the light
     * clipped by that line (reference: the contour integral over it). */
    const double phi = 25.0 * M_PI / 180;
    rad_vec3 t = rad_v3(cos(phi), sin(phi), 0), m = rad_v3(-sin(phi), cos(phi), 0);
    rad_vec3 mid = rad_add(rad_scale(rad_add(ci, lc), 0.5), rad_scale(m, 0.003));
    add_rect(&b, rad_sub(mid, rad_scale(t, 0.2)), rad_scale(m, 0.4), rad_scale(t, 0.4), 1, 1);
    /* the visible fraction at c_i times the averaged factor */
    double ref = shaded_light_ff(&b, light, lc, m, ci, ni) / ex * ex_area;
    uint8_t *marks2 = calloc(b.m.patch_count + 1, 1);
    marks2[light] = 1;
    exact.exact = marks2;
    exact.resolution = 1024;
    double part = one_entry(&b, &exact, i, light);
    exact.resolution = 32;
    double part32 = one_entry(&b, &exact, i, light);
    printf("     partly occluded: visible part %.7g (%.3f of the light), exact path R=1024 %.7g "
           "(%+.3f %%), R=32 %.7g (%+.2f %%)\n",
           ref, ref / ex, part, 100 * (part / ref - 1), part32, 100 * (part32 / ref - 1));
    /* The visible fraction comes from the light's own view, R × R pixels
     * just wide enough to hold it (the hemi-cube gives it ~15 pixels across
     * at R = 1024, under one at R = 32): the shadow line's staircase is off
     * by at most about a pixel row of that view, 1/R of the light, 1.4/R of
     * its visible 72 %: 2/R. */
    CHECK_REL(part, ref, 2.0 / 1024);
    CHECK_REL(part32, ref, 2.0 / 32);

    /* Fully occluded (blocker widened over the whole light): 0. */
    builder c = {0};
    add_light_room(&c);
    light = add_small_light(&c, lc);
    add_rect(&c, rad_v3(0.25, 0.25, 0.5), rad_v3(0, 0.2, 0), rad_v3(0.2, 0, 0), 1, 1);
    exact.exact = marks;
    exact.resolution = 32;
    double hid32 = one_entry(&c, &exact, i, light);
    exact.resolution = 256;
    double hid256 = one_entry(&c, &exact, i, light);
    CHECK(hid32 == 0.0);
    CHECK(hid256 == 0.0);
    free(marks);
    free(marks2);
    builder_free(&b);
    builder_free(&c);
}

TEST(focus_view_budget)
{
    /* Twelve 0.03 × 0.03 lights in a row at z = 1 (separate polygons), all
     * cut by the shadow of one blocker edge 6 mm off their centres, as
     * above: a row may focus at most HC_FOCUS_VIEWS = 8 of them, and the
     * others keep the hemi-cube's visible fraction.  Each F_ij is compared
     * with the contour integral over the light's visible part. */
    enum { LIGHTS = 12 };
    builder b = {0};
    add_light_room(&b);
    const double phi = 25.0 * M_PI / 180;
    const rad_vec3 t = rad_v3(cos(phi), sin(phi), 0), m = rad_v3(-sin(phi), cos(phi), 0);
    const rad_vec3 base = rad_v3(0.3812, 0.3733, 1.0);
    const uint32_t i = 5;
    const rad_vec3 ci = b.m.patches[i].center, ni = b.m.patches[i].normal;
    uint32_t light[LIGHTS];
    double ref[LIGHTS];
    for (int k = 0; k < LIGHTS; k++) {
        rad_vec3 lc = rad_add(base, rad_scale(t, 0.05 * (k - 5.5)));
        light[k] = add_small_light(&b, lc);
        rad_vec3 lp[4];
        patch_corners(&b, light[k], lp);
        /* the visible fraction at c_i times the factor averaged over i */
        ref[k] = shaded_light_ff(&b, light[k], lc, m, ci, ni) / hc_ff_point_polygon(ci, ni, lp, 4) *
                 area_ff(&b, i, light[k]);
    }
    /* The lights' centres lie on a line along t, so the midpoints between
     * them and c_i do too: one edge along t cuts every light alike. */
    rad_vec3 mid = rad_add(rad_scale(rad_add(ci, base), 0.5), rad_scale(m, 0.003));
    add_rect(&b, rad_sub(mid, rad_scale(t, 0.3)), rad_scale(m, 0.4), rad_scale(t, 0.6), 1, 1);
    uint8_t *marks = calloc(b.m.patch_count + 1, 1);
    for (int k = 0; k < LIGHTS; k++)
        marks[light[k]] = 1;
    const uint32_t R = 1024;
    hc_options o = {.resolution = R, .processes = 1, .exact = marks};
    rad_matrix *F = compute_rows_with(&b, &o, &i, 1);
    int focused = 0;
    double worst = 0;
    for (int k = 0; F && k < LIGHTS; k++) {
        double f = entry(F, i, light[k]), d = fabs(f / ref[k] - 1);
        focused += d <= 2.0 / R;
        worst = fmax(worst, d);
    }
    printf("     %d lights: %d within 2/R of the contour integral, worst %.3f %%\n", LIGHTS, focused,
           100 * worst);
    /* The focused ones as in exact_small_source (2/R); the rest, counted
     * on the hemi-cube where a light is ~15 pixels wide, within about a
     * pixel row of it, 1.4/15 of the visible part: 10 %. */
    CHECK(focused >= 8);
    CHECK(worst < 0.10);
    rad_matrix_destroy(F);
    free(marks);
    builder_free(&b);
}

static double worst_row_excess(const rad_matrix *F)
{
    double worst = -INFINITY;
    for (uint32_t i = 0; i < F->n; i++) {
        double s = rad_matrix_row_sum(F, i);
        worst = fmax(worst, s - 1.0);
    }
    return worst;
}

TEST(exact_near_plates)
{
    const double gap = 0.01;
    hc_options near = {.resolution = 128, .processes = 2, .exact_near = 1};
    hc_options plain = {.resolution = 128, .processes = 2};
    /* One patch per plate. */
    builder b = {0};
    add_rect(&b, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 1, 1);
    add_rect(&b, rad_v3(0, 0, gap), rad_v3(0, 1, 0), rad_v3(1, 0, 0), 1, 1);
    uint32_t rows[2] = {0, 1};
    double howell = hc_ff_parallel_rectangles(1, 1, gap);
    rad_matrix *F = compute_rows_with(&b, &near, rows, 2);
    rad_matrix *G = compute_rows_with(&b, &plain, rows, 2);
    if (F && G) {
        printf("     plates 1×1 at 0.01: Howell %.7f, exact_near %.7f (%+.1e), hemi-cube %.7f (%+.1e)\n",
               howell, entry(F, 0, 1), entry(F, 0, 1) / howell - 1, entry(G, 0, 1),
               entry(G, 0, 1) / howell - 1);
        /* The area average with 16² sub-triangles per fan triangle is within
         * 1.3e-4 of C-11 at this gap (measured against subdivision 64); the
         * hemi-cube's point value misses by 2 %. */
        CHECK_REL(entry(F, 0, 1), howell, 1e-3);
        CHECK_REL(entry(F, 1, 0), howell, 1e-3);
        CHECK(fabs(entry(G, 0, 1) / howell - 1) > 0.01);
        CHECK(worst_row_excess(F) <= 1e-6);
    }
    rad_matrix_destroy(F);
    rad_matrix_destroy(G);
    builder_free(&b);

    /* 4×4 patches per plate. */
    add_rect(&b, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 4, 4);
    add_rect(&b, rad_v3(0, 0, gap), rad_v3(0, 1, 0), rad_v3(1, 0, 0), 4, 4);
    uint32_t *all = all_rows(32);
    F = compute_rows_with(&b, &near, all, 32);
    G = compute_rows_with(&b, &plain, all, 32);
    if (F && G) {
        double h1 = hc_ff_parallel_rectangles(0.25, 0.25, gap), worst = 0.0;
        for (uint32_t i = 0; i < 16; i++) {
            /* Patch (x, y) of the lower plate faces patch (y, x) of the upper
             * one, whose grid runs along y first. */
            uint32_t x = i % 4, y = i / 4, j = 16 + x * 4 + y;
            worst = fmax(worst, fabs(entry(F, i, j) / h1 - 1));
            CHECK_REL(entry(F, i, j), h1, 1e-3);
            CHECK_REL(entry(F, j, i), h1, 1e-3);
        }
        double f12 = polygon_ff(&b, F, 0, 16, 16, 32), g12 = polygon_ff(&b, G, 0, 16, 16, 32);
        double excess = worst_row_excess(F);
        printf("     plates 4×4 at 0.01: facing pairs worst %.1e off C-11 (%.6f); plate to plate "
               "%.6f exact_near (%+.1e), %.6f hemi-cube (%+.1e) vs %.6f; max row sum - 1 = %.1e\n",
               worst, h1, f12, f12 / howell - 1, g12, g12 / howell - 1, howell, excess);
        /* Row sums may exceed 1 only by the float rounding of the entries
         * after renormalisation. */
        CHECK(excess <= 1e-6);
        /* Plate to plate: the near pairs are area averages, the rest (at
         * grazing angles, ~1e-3 of the total) still point samples: 0.5 %. */
        CHECK_REL(f12, howell, 5e-3);
    }
    free(all);
    rad_matrix_destroy(F);
    rad_matrix_destroy(G);
    builder_free(&b);
}

TEST(exact_closed_cube)
{
    /* Every patch exact: from a patch's centre the other five walls tile the
     * hemisphere, so the contour integrals of a row sum to 1 (every
     * candidate wholly visible: v = 1).  180 candidates per row take six OR
     * passes of 32 residues. */
    builder b = {0};
    closed_cube(&b, 6);
    uint32_t n = b.m.patch_count;
    uint8_t *marks = malloc(n);
    memset(marks, 1, n);
    uint32_t *rows = all_rows(n);
    hc_options o1 = {.resolution = 32, .processes = 1, .exact = marks};
    hc_options o2 = {.resolution = 32, .processes = 2, .exact = marks};
    rad_matrix *A = compute_rows_with(&b, &o1, rows, n);
    rad_matrix *B = compute_rows_with(&b, &o2, rows, n);
    hc_options o3 = {.resolution = 32, .processes = 2, .exact_near = 1};
    rad_matrix *C = compute_rows_with(&b, &o3, rows, n);
    if (A && B && C) {
        double worst = 0.0;
        for (uint32_t i = 0; i < n; i++)
            worst = fmax(worst, fabs(rad_matrix_row_sum(A, i) - 1.0));
        printf("     closed cube, all exact: worst |row sum - 1| = %.2g; with exact_near max row "
               "sum - 1 = %.2g\n", worst, worst_row_excess(C));
        /* Float entries (≤ 180 roundings of 6e-8 relative) and the
         * renormalisation's trim: 1e-6. */
        CHECK(worst <= 1e-6);
        /* Deterministic whichever worker computes a row. */
        CHECK(rows_identical(A, B));
        /* exact_near alone: the pairs across the cube's edges become area
         * averages, which overfill the rows; the renormalisation scales the
         * pixel entries so that the rows sum to 1 again. */
        double excess = worst_row_excess(C), short_of = 0.0;
        for (uint32_t i = 0; i < n; i++)
            short_of = fmax(short_of, 1.0 - rad_matrix_row_sum(C, i));
        printf("     exact_near: row sums within [1 - %.1e, 1 + %.1e]\n", short_of, excess);
        CHECK(excess <= 1e-6);
        CHECK(short_of <= 1e-6);
        /* Patch 0 (floor corner cell) to the wall cell sharing its edge on
         * x = 0 (patch 72): the area average (C-14 for two squares,
         * 0.2000438), kept as is, not the hemi-cube's point value. */
        rad_vec3 p0[4], p1[4];
        patch_corners(&b, 0, p0);
        patch_corners(&b, 72, p1);
        double pp = hc_ff_polygon_polygon(p0, 4, p1, 4, 32);
        double f = entry(C, 0, 72);
        printf("     floor corner cell to adjacent wall cell: %.7f, area average %.7f, all-exact "
               "point value %.7f\n", f, pp, entry(A, 0, 72));
        /* Subdivision 4 resolves this pair to ~1e-8; float storage 6e-8. */
        CHECK_REL(f, pp, 1e-6);
    }
    free(marks);
    free(rows);
    rad_matrix_destroy(A);
    rad_matrix_destroy(B);
    rad_matrix_destroy(C);
    builder_free(&b);
}

/* ---------------------------------------------------------------- lights */

/* Solid angle of triangle abc seen from p (Van Oosterom & Strackee 1983). */
static double tri_solid_angle(rad_vec3 p, rad_vec3 a, rad_vec3 b, rad_vec3 c)
{
    rad_vec3 r1 = rad_sub(a, p), r2 = rad_sub(b, p), r3 = rad_sub(c, p);
    double l1 = rad_length(r1), l2 = rad_length(r2), l3 = rad_length(r3);
    double num = rad_dot(r1, rad_cross(r2, r3));
    double den = l1 * l2 * l3 + rad_dot(r1, r2) * l3 + rad_dot(r1, r3) * l2 + rad_dot(r2, r3) * l1;
    return fabs(2.0 * atan2(num, den));
}

/* ∫ cosθ/r² dA over patch j from a point light at p: its solid angle. */
static double patch_solid_angle(const builder *b, uint32_t j, rad_vec3 p)
{
    rad_vec3 c[4];
    patch_corners(b, j, c);
    return tri_solid_angle(p, c[0], c[1], c[2]) + tri_solid_angle(p, c[0], c[2], c[3]);
}

/* Φ_j of every patch for one light, or NULL (and a failed check). */
static double *light_power(const builder *b, uint32_t processes, const hc_light *l, uint32_t R,
                           double *seconds)
{
    hc_options o = {.resolution = 16, .processes = processes};
    hc_engine *e = NULL;
    rad_error err = {0};
    int rc = hc_create(&b->m, &o, &e, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return NULL;
    double *pw = malloc(b->m.patch_count * sizeof *pw);
    double t0 = rad_seconds();
    rc = hc_light_power(e, l, R, pw, &err);
    if (seconds)
        *seconds = rad_seconds() - t0;
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    hc_destroy(e);
    if (rc) {
        free(pw);
        return NULL;
    }
    return pw;
}

/* Turns the whole mesh by ang about the z axis: the tests below turn their
 * floors against the light's pixel grid, as a real scene would be, so that
 * patch edges do not all run along pixel rows (where their half-pixel errors
 * would add up instead of averaging out). */
static void rotate_z(builder *b, double ang)
{
    double c = cos(ang), s = sin(ang);
#define ROT(p) (p) = rad_v3(c * (p).x - s * (p).y, s * (p).x + c * (p).y, (p).z)
    for (uint32_t k = 0; k < b->m.vertex_count; k++)
        ROT(b->m.vertices[k]);
    for (uint32_t j = 0; j < b->m.patch_count; j++) {
        ROT(b->m.patches[j].center);
        ROT(b->m.patches[j].normal);
    }
#undef ROT
}

/* Bounds of patch j in the frame turned by ang (the mesh's own frame before
 * rotate_z). */
static void local_bounds(const builder *b, uint32_t j, double ang, double *x0, double *x1, double *y0,
                         double *y1)
{
    rad_vec3 c[4];
    patch_corners(b, j, c);
    *x0 = *y0 = INFINITY;
    *x1 = *y1 = -INFINITY;
    for (int k = 0; k < 4; k++) {
        double x = cos(ang) * c[k].x + sin(ang) * c[k].y, y = -sin(ang) * c[k].x + cos(ang) * c[k].y;
        *x0 = fmin(*x0, x), *x1 = fmax(*x1, x);
        *y0 = fmin(*y0, y), *y1 = fmax(*y1, y);
    }
}

/* In the frame turned by ang: every corner of patch j inside the square
 * |x - cx|, |y - cy| <= h (inside = 1), or the patch wholly outside it (0). */
static int patch_vs_square(const builder *b, uint32_t j, double ang, double cx, double cy, double h,
                           int inside)
{
    double x0, x1, y0, y1;
    local_bounds(b, j, ang, &x0, &x1, &y0, &y1);
    if (inside)
        return x0 >= cx - h && x1 <= cx + h && y0 >= cy - h && y1 <= cy + h;
    return x1 <= cx - h || x0 >= cx + h || y1 <= cy - h || y0 >= cy + h;
}

TEST(point_light)
{
    /* Unit intensity 1 above the centre of a 4×4 floor of 20×20 patches:
     * Φ_j is the solid angle of patch j.  Then a box 0.6×0.6, z in
     * [0.4, 0.6], under the light: its top face throws the shadow
     * |x|, |y| <= 0.3·1/(1-0.6) = 0.75 on the floor (in the floor's frame,
     * both being turned by 20° about the light's vertical). */
    builder b = {0};
    const double ang = 20 * M_PI / 180;
    add_rect(&b, rad_v3(-2, -2, 0), rad_v3(4, 0, 0), rad_v3(0, 4, 0), 20, 20);
    rotate_z(&b, ang);
    const uint32_t nf = 400;
    hc_light l = {.kind = HC_LIGHT_POINT, .position = rad_v3(0, 0, 1)};
    double sec = 0;
    double *pw = light_power(&b, 2, &l, 1024, &sec);
    if (pw) {
        double worst = 0.0, total = 0.0, ref_total = 0.0;
        uint32_t checked = 0;
        for (uint32_t j = 0; j < nf; j++) {
            double ref = patch_solid_angle(&b, j, l.position);
            total += pw[j];
            ref_total += ref;
            if (ref / b.m.patches[j].area < 0.1)
                continue; /* cosθ/r² below a tenth of its peak: few pixels */
            worst = fmax(worst, fabs(pw[j] / ref - 1));
            checked++;
            /* A patch edge costs at most half a pixel along its length, and
             * less when slanted to the pixel grid (the floor is turned by
             * 20°): at R = 1024 the patches checked are 45 to 102 pixels
             * wide: 1 %. */
            CHECK_REL(pw[j], ref, 1e-2);
        }
        printf("     point light, R=1024: %u patches worst %.2e, floor total %.6f vs %.6f, %.3f s\n",
               checked, worst, total, ref_total, sec);
        /* The whole floor: pixel edges only at its outline. */
        CHECK_REL(total, ref_total, 1e-3);
        CHECK(checked >= 100);
    }
    /* Deterministic: one worker or two (faces split differently). */
    double *p1 = light_power(&b, 1, &l, 256, NULL), *p2 = light_power(&b, 2, &l, 256, NULL);
    if (p1 && p2)
        CHECK(memcmp(p1, p2, nf * sizeof *p1) == 0);
    free(p1);
    free(p2);

    builder c = {0};
    add_rect(&c, rad_v3(-2, -2, 0), rad_v3(4, 0, 0), rad_v3(0, 4, 0), 20, 20);
    add_box(&c, rad_v3(-0.3, -0.3, 0.4), rad_v3(0.3, 0.3, 0.6));
    rotate_z(&c, ang);
    double *ps = light_power(&c, 2, &l, 1024, NULL);
    if (pw && ps) {
        uint32_t umbra = 0, lit = 0;
        double worst = 0.0;
        for (uint32_t j = 0; j < nf; j++) {
            if (patch_vs_square(&c, j, ang, 0, 0, 0.75, 1)) {
                umbra++;
                CHECK(ps[j] == 0.0);
            } else if (patch_vs_square(&c, j, ang, 0, 0, 0.75, 0)) {
                double ref = patch_solid_angle(&b, j, l.position);
                if (ref / b.m.patches[j].area < 0.1)
                    continue;
                lit++;
                worst = fmax(worst, fabs(ps[j] / ref - 1));
                CHECK_REL(ps[j], ref, 1e-2); /* as above */
            }
        }
        /* The box's top (patch nf + 1) receives its solid angle; its sides
         * and bottom face away or lie in shadow. */
        double top = patch_solid_angle(&c, nf + 1, l.position);
        printf("     shadowed: %u umbra patches all 0, %u lit worst %.2e; box top %.6f vs %.6f\n",
               umbra, lit, worst, ps[nf + 1], top);
        CHECK(umbra == 36);
        CHECK_REL(ps[nf + 1], top, 1e-3); /* 0.6 wide at 0.4: ~1300 pixels across */
        CHECK(ps[nf] == 0.0);
    }
    free(pw);
    free(ps);
    builder_free(&b);
    builder_free(&c);
}

/* glTF spot falloff at angle cosθ. */
static double spot_falloff(double cos_t, double inner, double outer)
{
    double scale = 1.0 / fmax(0.001, cos(inner) - cos(outer)), off = -cos(outer) * scale;
    double t = cos_t * scale + off;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t;
}

TEST(spot_light)
{
    /* Inner cone 20°, outer 35°, 1 above a 4×4 floor of 40×40 patches: the
     * cones meet the floor in circles of radius tan 20° and tan 35°. */
    builder b = {0};
    const double ang = 20 * M_PI / 180;
    add_rect(&b, rad_v3(-2, -2, 0), rad_v3(4, 0, 0), rad_v3(0, 4, 0), 40, 40);
    rotate_z(&b, ang);
    const double inner = 20 * M_PI / 180, outer = 35 * M_PI / 180;
    hc_light l = {.kind = HC_LIGHT_SPOT, .position = rad_v3(0, 0, 1), .direction = rad_v3(0, 0, -2),
                  .inner_cone = inner, .outer_cone = outer};
    double sec = 0;
    double *pw = light_power(&b, 2, &l, 1024, &sec);
    if (pw) {
        const double ri = tan(inner), ro = tan(outer);
        uint32_t in = 0, out = 0, ring = 0;
        double worst_in = 0, worst_ring = 0;
        for (uint32_t j = 0; j < b.m.patch_count; j++) {
            double x0, x1, y0, y1;
            local_bounds(&b, j, ang, &x0, &x1, &y0, &y1);
            double rmax = hypot(fmax(fabs(x0), fabs(x1)), fmax(fabs(y0), fabs(y1)));
            /* Nearest point of the patch to the cone's axis. */
            double rmin = hypot(fmax(x0, fmin(0, x1)), fmax(y0, fmin(0, y1)));
            if (rmax <= ri) {
                in++;
                double ref = patch_solid_angle(&b, j, l.position);
                worst_in = fmax(worst_in, fabs(pw[j] / ref - 1));
                CHECK_REL(pw[j], ref, 1e-2); /* as for the point light */
            } else if (rmin >= ro) {
                out++;
                CHECK(pw[j] == 0.0);
            } else if (rmin >= ri && rmax <= ro) {
                /* Wholly in the falloff ring: midpoint rule on 64×64 cells
                 * of ∫ t(θ)² cosθ/r² dA (smooth here), good to ~1e-4. */
                ring++;
                double ref = 0.0, h = (x1 - x0) / 64;
                for (int u = 0; u < 64; u++)
                    for (int v = 0; v < 64; v++) {
                        double x = x0 + (u + 0.5) * h, y = y0 + (v + 0.5) * h, r2 = x * x + y * y + 1;
                        double ct = 1 / sqrt(r2);
                        ref += spot_falloff(ct, inner, outer) * ct / r2 * h * h;
                    }
                worst_ring = fmax(worst_ring, fabs(pw[j] / ref - 1));
                /* Edge aliasing as for the point light; the falloff is
                 * sampled at pixel centres, a second-order error: 1 %. */
                CHECK_REL(pw[j], ref, 1e-2);
            }
        }
        printf("     spot 20°/35°, R=1024: %u patches inside (worst %.2e), %u in the ring (worst "
               "%.2e), %u outside = 0; %.3f s\n", in, worst_in, ring, worst_ring, out, sec);
        CHECK(in >= 8 && ring >= 8 && out >= 1000);
    }
    free(pw);
    builder_free(&b);
}

TEST(directional_light)
{
    /* A unit square (12×12 patches) tilted 30° about an axis at 20° to x,
     * lit straight from above: Φ_j/A_j = cos 30°. */
    builder b = {0};
    const double tilt = 30 * M_PI / 180, az = 20 * M_PI / 180;
    rad_vec3 e1 = rad_v3(cos(az), sin(az), 0);
    rad_vec3 e2 = rad_add(rad_scale(rad_v3(-sin(az), cos(az), 0), cos(tilt)), rad_v3(0, 0, sin(tilt)));
    add_rect(&b, rad_v3(-0.5, -0.5, 0), e1, e2, 12, 12);
    hc_light l = {.kind = HC_LIGHT_DIRECTIONAL, .direction = rad_v3(0, 0, -1)};
    double sec = 0;
    double *pw = light_power(&b, 1, &l, 2048, &sec);
    if (pw) {
        double worst = 0, total = 0;
        for (uint32_t j = 0; j < b.m.patch_count; j++) {
            double h = pw[j] / b.m.patches[j].area;
            worst = fmax(worst, fabs(h / cos(tilt) - 1));
            total += pw[j];
            /* Each patch is ~100 pixels wide at R = 2048 and its slanted
             * edges average their half-pixel errors: 0.3 %. */
            CHECK_REL(h, cos(tilt), 3e-3);
        }
        printf("     directional, R=2048: worst patch %.2e, whole plane %.2e, %.3f s\n", worst,
               total / cos(tilt) - 1, sec);
        /* The whole plane: only its outline aliases: 1e-3. */
        CHECK_REL(total, cos(tilt), 1e-3);
    }
    free(pw);
    builder_free(&b);

    /* A floor 2×2 (20×20 patches) under a blocker 0.5×0.5 at height 0.4,
     * both turned by 20°, lit along (0.3, 0.2, -1): the shadow is the
     * blocker moved by 0.4·(0.3, 0.2). */
    builder c = {0};
    const double ang = 20 * M_PI / 180;
    add_rect(&c, rad_v3(-1, -1, 0), rad_v3(2, 0, 0), rad_v3(0, 2, 0), 20, 20);
    add_rect(&c, rad_v3(-0.25, -0.25, 0.4), rad_v3(0.5, 0, 0), rad_v3(0, 0.5, 0), 1, 1);
    rotate_z(&c, ang);
    l.direction = rad_v3(0.3, 0.2, -1);
    double cos_t = 1 / rad_length(l.direction);
    double sx = cos(ang) * 0.12 + sin(ang) * 0.08, sy = -sin(ang) * 0.12 + cos(ang) * 0.08;
    pw = light_power(&c, 2, &l, 1024, NULL);
    if (pw) {
        uint32_t umbra = 0, lit = 0;
        double worst = 0;
        for (uint32_t j = 0; j < 400; j++) {
            if (patch_vs_square(&c, j, ang, sx, sy, 0.25, 1)) {
                umbra++;
                CHECK(pw[j] == 0.0);
            } else if (patch_vs_square(&c, j, ang, sx, sy, 0.25, 0)) {
                lit++;
                double h = pw[j] / c.m.patches[j].area;
                worst = fmax(worst, fabs(h / cos_t - 1));
                /* 0.1-wide patches are ~36 pixels wide at R = 1024 (the view
                 * spans the floor's bounding sphere), their edges slanted
                 * to the pixel grid: 1 %. */
                CHECK_REL(h, cos_t, 1e-2);
            }
        }
        printf("     directional shadow: %u umbra patches all 0, %u lit worst %.2e; blocker %.6f "
               "vs %.6f\n", umbra, lit, worst, pw[400] / 0.25, cos_t);
        CHECK(umbra >= 9);
        CHECK(lit >= 300);
        CHECK_REL(pw[400] / 0.25, cos_t, 1e-2); /* ~180 pixels wide */
    }
    free(pw);
    builder_free(&c);
}

/* Stores one point row (hc_compute_points) into a dense array. */
static int dense_row(void *user, uint32_t k, uint32_t count, const uint32_t *col, const float *val,
                     rad_error *err)
{
    (void)k;
    (void)err;
    double *F = user;
    for (uint32_t q = 0; q < count; q++)
        F[col[q]] = val[q];
    return RAD_OK;
}

/* A near view (hc_receiver.reach): a point on a 4 × 4 floor (8 × 8
 * patches) 0.1 from a 2-high wall (4 × 8 patches) at x = 2, nothing in
 * between.  Its row holds exactly the patches in front whose centre lies
 * within the reach (hc_within_reach), drawn at half the resolution; their
 * sum within NEAR_SUM_TOL of the exact point-to-polygon factors', and
 * each entry within NEAR_ENTRY_TOL of that sum of its exact factor (the
 * wall's lowest patches are seen edge-on from 0.1: at R = 64 they are
 * 5-20 % off, as the whole view's at R = 128 are up to 9 %).  A whole
 * view at the same point gives the patches beyond.  Measured: sum +0.40 %,
 * worst entry 0.58 % of the sum. */
#define NEAR_SUM_TOL 0.015
#define NEAR_ENTRY_TOL 0.02
TEST(near_view_draws_only_the_reach)
{
    builder b = {0};
    add_rect(&b, rad_v3(-2, 0, 0), rad_v3(4, 0, 0), rad_v3(0, 4, 0), 8, 8);
    const uint32_t wall = add_rect(&b, rad_v3(2, 0, 0), rad_v3(0, 0, 2), rad_v3(0, 4, 0), 4, 8);
    const rad_vec3 x = rad_v3(1.9, 1.3, 0);
    const double reach = 1.0;
    /* its floor patch: x in [1.5, 2), y in [1, 1.5) */
    const hc_receiver pt[2] = {{x, 7 + 8 * 2, reach}, {x, 7 + 8 * 2, 0.0}};
    const uint32_t n = b.m.patch_count;
    double *F = calloc(2 * (size_t)n, sizeof *F);
    hc_options o = {.resolution = 128, .processes = 1};
    hc_engine *e = NULL;
    rad_error err = {0};
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    CHECK_MSG(e && hc_compute_points(e, &pt[0], 1, dense_row, F, &err) == RAD_OK, "%s", err.message);
    CHECK_MSG(e && hc_compute_points(e, &pt[1], 1, dense_row, F + n, &err) == RAD_OK, "%s",
              err.message);
    hc_destroy(e);
    uint32_t near = 0, far = 0, stray = 0;
    double worst = 0.0, sum = 0.0, want = 0.0;
    for (uint32_t j = wall; j < n; j++) {
        rad_vec3 q[4];
        for (int c = 0; c < 4; c++)
            q[c] = b.m.vertices[b.m.patches[j].v[c]];
        const double exact = hc_ff_point_polygon(x, rad_v3(0, 0, 1), q, 4);
        if (hc_within_reach(&b.m, j, x, reach)) {
            near++;
            sum += F[j];
            want += exact;
            worst = fmax(worst, fabs(F[j] - exact));
        } else {
            far += F[n + j] > 0.0;
            stray += F[j] != 0.0;
        }
    }
    for (uint32_t j = 0; j < wall; j++)
        stray += F[j] != 0.0 || F[n + j] != 0.0; /* the floor is coplanar */
    printf("     near view: %u wall patches within reach, sum %.6f vs %.6f exact, worst entry "
           "%.2e of it; %u beyond it in the whole view, %u stray\n",
           near, sum, want, worst / want, far, stray);
    CHECK(near >= 6 && far >= 10 && stray == 0);
    CHECK(worst <= NEAR_ENTRY_TOL * want);
    CHECK_REL(sum, want, NEAR_SUM_TOL);
    free(F);
    builder_free(&b);
}

/* hc_light_visibility: a floor of two coplanar polygons [0,1]×[0,1] and
 * [1,2]×[0,1] (4×4 patches each) and a blocker [0.2,0.6]² at z = 0.5 under
 * a point light at (1, 0.5, 2).  The blocker's shadow reaches x = 1 −
 * 0.4·4/3 on the floor.  Along y = 0.25, x in [0.3, 0.9]: V = 0 more than 1.5 pixels (of the
 * light's face, 1.6 cm on the floor at R = 256) inside the shadow, 1 more
 * than that outside, never decreasing outwards, with values between 0 and
 * 1 at the edge (anti-aliased); 1 exactly at patch and polygon seams in the
 * open (the coplanar neighbour counts); the same bits with 1 and 2 workers;
 * a directional light's shadow likewise. */
TEST(light_visibility)
{
    builder b = {0};
    add_rect(&b, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 4, 4);
    add_rect(&b, rad_v3(1, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 4, 4);
    add_rect(&b, rad_v3(0.2, 0.2, 0.5), rad_v3(0.4, 0, 0), rad_v3(0, 0.4, 0), 1, 1);
    const uint32_t R = 256, N = 201;
    const double edge = 1.0 - 0.4 * 4.0 / 3.0, px = 2.0 * 2.0 / R; /* a pixel on the floor */
    hc_receiver pts[201 + 4];
    for (uint32_t k = 0; k < N; k++) {
        double x = 0.3 + 0.6 * k / (N - 1);
        pts[k].center = rad_v3(x, 0.25, 0);
        pts[k].patch = (uint32_t)(x * 4) + 4 * 1; /* row y in [0.25, 0.5) */
    }
    /* seams: between patches of one polygon, and between the polygons */
    pts[N + 0] = (hc_receiver){rad_v3(0.75 - 1e-4, 0.75, 0), 4 * 3 + 2, 0.0};
    pts[N + 1] = (hc_receiver){rad_v3(0.75 + 1e-4, 0.75, 0), 4 * 3 + 3, 0.0};
    pts[N + 2] = (hc_receiver){rad_v3(1.0 - 1e-4, 0.75, 0), 4 * 3 + 3, 0.0};
    pts[N + 3] = (hc_receiver){rad_v3(1.0 + 1e-4, 0.75, 0), 16 + 4 * 3 + 0, 0.0};
    double vis[2][201 + 4];
    hc_light point = {.kind = HC_LIGHT_POINT, .position = rad_v3(1, 0.5, 2)};
    for (uint32_t w = 0; w < 2; w++) {
        hc_options o = {.resolution = 16, .processes = w + 1};
        hc_engine *e = NULL;
        rad_error err = {0};
        CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
        CHECK_MSG(hc_light_visibility(e, &point, R, pts, N + 4, vis[w], &err) == RAD_OK, "%s",
                  err.message);
        hc_destroy(e);
    }
    CHECK(memcmp(vis[0], vis[1], sizeof vis[0]) == 0);
    uint32_t dark = 0, lit = 0, between = 0, monotone = 1;
    for (uint32_t k = 0; k < N; k++) {
        double x = pts[k].center.x, v = vis[0][k];
        if (x < edge - 1.5 * px) {
            dark++;
            CHECK(v == 0.0);
        } else if (x > edge + 1.5 * px) {
            lit++;
            CHECK(v == 1.0);
        } else {
            between += v > 0.0 && v < 1.0;
        }
        if (k && v < vis[0][k - 1])
            monotone = 0;
    }
    printf("     point light: %u dark, %u lit, %u between 0 and 1 at the edge; seams %g %g %g %g\n",
           dark, lit, between, vis[0][N], vis[0][N + 1], vis[0][N + 2], vis[0][N + 3]);
    CHECK(monotone);
    CHECK(dark > 40 && lit > 100 && between >= 1);
    for (int k = 0; k < 4; k++)
        CHECK(vis[0][N + k] == 1.0);
    /* the unoccluded irradiance it multiplies: cosθ / r² */
    rad_vec3 q = rad_v3(0.3, 0.25, 0), r = rad_sub(point.position, q);
    CHECK_REL(hc_light_direct(&point, q, rad_v3(0, 0, 1)), r.z / pow(rad_length(r), 3), 1e-15);
    CHECK(hc_light_direct(&point, q, rad_v3(0, 0, -1)) == 0.0);
    CHECK(hc_light_direct(&point, point.position, rad_v3(0, 0, 1)) == 0.0);

    /* directional straight down: the blocker's shadow is [0.2, 0.6]² */
    hc_light sun = {.kind = HC_LIGHT_DIRECTIONAL, .direction = rad_v3(0, 0, -1)};
    hc_options o = {.resolution = 16, .processes = 2};
    hc_engine *e = NULL;
    rad_error err = {0};
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    CHECK_MSG(hc_light_visibility(e, &sun, R, pts, N + 4, vis[0], &err) == RAD_OK, "%s",
              err.message);
    /* bad input: the light is checked as hc_light_power checks it */
    hc_light bad = point;
    bad.position.x = NAN;
    CHECK(hc_light_visibility(e, &bad, R, pts, 1, vis[1], &err) == RAD_ERR_USAGE);
    hc_receiver off = {rad_v3(0, 0, 0), 999, 0.0};
    CHECK(hc_light_visibility(e, &point, R, &off, 1, vis[1], &err) == RAD_ERR_USAGE);
    CHECK(hc_light_visibility(e, &point, 7, pts, 1, vis[1], &err) == RAD_ERR_USAGE);
    CHECK(hc_light_visibility(e, &point, R, pts, 0, NULL, &err) == RAD_OK);
    hc_destroy(e);
    const double opx = 2.0 * sqrt(2.0 * 2.0 + 1.0 + 0.25) / R; /* orthographic pixel: 2 r_bound / R */
    dark = lit = 0;
    for (uint32_t k = 0; k < N; k++) {
        double x = pts[k].center.x, v = vis[0][k];
        if (x < 0.6 - 1.5 * opx) {
            dark++;
            CHECK(v == 0.0);
        } else if (x > 0.6 + 1.5 * opx) {
            lit++;
            CHECK(v == 1.0);
        }
    }
    printf("     directional: %u dark, %u lit\n", dark, lit);
    CHECK(dark > 40 && lit > 40);
    CHECK_REL(hc_light_direct(&sun, q, rad_normalize(rad_v3(0, 1, 1))), sqrt(0.5), 1e-15);
    builder_free(&b);
}

TEST(light_bad_input)
{
    builder b = {0};
    parallel_squares(&b, 2, rad_v3(0, 0, 0));
    hc_options o = {.resolution = 16, .processes = 1};
    hc_engine *e = NULL;
    rad_error err = {0};
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    double pw[8];
    hc_light ok = {.kind = HC_LIGHT_POINT, .position = rad_v3(0.5, 0.5, 0.5)};
    hc_light l = ok;
    CHECK(hc_light_power(e, &l, 6, pw, &err) == RAD_ERR_USAGE);
    CHECK(hc_light_power(e, &l, 8194, pw, &err) == RAD_ERR_USAGE);
    CHECK(hc_light_power(e, NULL, 0, pw, &err) == RAD_ERR_USAGE);
    CHECK(hc_light_power(e, &l, 0, NULL, &err) == RAD_ERR_USAGE);
    CHECK(hc_light_power(NULL, &l, 0, pw, &err) == RAD_ERR_USAGE);
    l.position.y = NAN;
    CHECK(hc_light_power(e, &l, 0, pw, &err) == RAD_ERR_USAGE);
    l = ok;
    l.kind = (hc_light_kind)7;
    CHECK(hc_light_power(e, &l, 0, pw, &err) == RAD_ERR_USAGE);
    l = ok;
    l.kind = HC_LIGHT_DIRECTIONAL;
    CHECK(hc_light_power(e, &l, 0, pw, &err) == RAD_ERR_USAGE); /* zero direction */
    l.kind = HC_LIGHT_SPOT;
    l.direction = rad_v3(0, 0, 1);
    l.inner_cone = 0.5;
    l.outer_cone = 0.4;
    CHECK(hc_light_power(e, &l, 0, pw, &err) == RAD_ERR_USAGE);
    l.inner_cone = 0.1;
    l.outer_cone = 2.0;
    CHECK(hc_light_power(e, &l, 0, pw, &err) == RAD_ERR_USAGE);
    /* The engine still answers both kinds of request afterwards.  The point
     * light halfway between the squares sees each as a face of a cube around
     * it, 4π/6: the sum is 4π/3 (the outlines lie on pixel edges). */
    CHECK(hc_light_power(e, &ok, 64, pw, &err) == RAD_OK);
    double s = 0;
    for (int k = 0; k < 8; k++)
        s += pw[k];
    CHECK_REL(s, 4 * M_PI / 3, 1e-6);
    rad_matrix *F = rad_matrix_create(b.m.patch_count);
    uint32_t r = 0;
    CHECK(hc_compute_rows(e, &r, 1, F, &err) == RAD_OK);
    CHECK(F->rows_done == 1);
    rad_matrix_destroy(F);
    hc_destroy(e);
    /* An empty mesh receives nothing and needs no buffer. */
    rad_mesh empty = {0};
    CHECK(hc_create(&empty, &o, &e, &err) == RAD_OK);
    CHECK(hc_light_power(e, &ok, 0, NULL, &err) == RAD_OK);
    hc_destroy(e);
    builder_free(&b);
}

typedef struct progress_log {
    uint32_t calls, last_done, total, monotonic;
} progress_log;

static void on_progress(void *user, uint32_t done, uint32_t total)
{
    progress_log *p = user;
    if (done != p->last_done + 1)
        p->monotonic = 0;
    p->calls++;
    p->last_done = done;
    p->total = total;
}

TEST(progress_reports)
{
    builder b = {0};
    parallel_squares(&b, 6, rad_v3(0, 0, 0));
    progress_log log = {0, 0, 0, 1};
    hc_options o = {.resolution = 16, .processes = 2, .progress = on_progress, .progress_user = &log};
    hc_engine *e = NULL;
    rad_error err;
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    rad_matrix *F = rad_matrix_create(b.m.patch_count);
    uint32_t *rows = all_rows(b.m.patch_count);
    CHECK(hc_compute_rows(e, rows, b.m.patch_count, F, &err) == RAD_OK);
    /* One call per row, counting 1, 2, ..., total. */
    CHECK(log.calls == b.m.patch_count);
    CHECK(log.last_done == b.m.patch_count);
    CHECK(log.total == b.m.patch_count);
    CHECK(log.monotonic);
    CHECK(F->rows_done == b.m.patch_count);
    free(rows);
    hc_destroy(e);
    rad_matrix_destroy(F);
    builder_free(&b);
}

/* Kills up to `most` live children of this process (the engine's workers)
 * through /proc; how many, and the last one's pid in *pid (may be NULL). */
static int kill_children_upto(int most, int *pid)
{
    int killed = 0;
    DIR *d = opendir("/proc");
    if (!d)
        return 0;
    struct dirent *de;
    while (killed < most && (de = readdir(d))) {
        char path[300], buf[512];
        if (de->d_name[0] < '0' || de->d_name[0] > '9')
            continue;
        snprintf(path, sizeof path, "/proc/%s/stat", de->d_name);
        FILE *f = fopen(path, "r");
        if (!f)
            continue;
        size_t len = fread(buf, 1, sizeof buf - 1, f);
        fclose(f);
        buf[len] = '\0';
        char *close_paren = strrchr(buf, ')');
        int ppid = 0;
        char state;
        if (close_paren && sscanf(close_paren + 1, " %c %d", &state, &ppid) == 2 &&
            ppid == (int)getpid() && state != 'Z') {
            kill((pid_t)atoi(de->d_name), SIGKILL);
            if (pid)
                *pid = atoi(de->d_name);
            killed++;
        }
    }
    closedir(d);
    return killed;
}

static int kill_children(void) { return kill_children_upto(1 << 30, NULL); }

/* The progress callback of worker_killed_mid_job: kills a worker once. */
typedef struct killer {
    uint32_t at;
    int pid;
} killer;

static void kill_at(void *user, uint32_t done, uint32_t total)
{
    (void)total;
    killer *k = user;
    if (done == k->at && !k->pid)
        kill_children_upto(1, &k->pid);
}

/* Workers killed before a job of rows: others take their place and the rows
 * come out as an undisturbed engine computes them.  Killed before a light
 * request (which does not replace workers), the request fails cleanly, and
 * so does every later call. */
TEST(dead_worker)
{
    builder b = {0};
    parallel_squares(&b, 4, rad_v3(0, 0, 0));
    hc_options o = {.resolution = 16, .processes = 2};
    hc_engine *e = NULL;
    rad_error err = {0};
    rad_matrix *ref = compute_all(&b, 16, 2);
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    CHECK(kill_children() == 2);
    rad_matrix *F = rad_matrix_create(b.m.patch_count);
    uint32_t *rows = all_rows(b.m.patch_count);
    CHECK_MSG(hc_compute_rows(e, rows, b.m.patch_count, F, &err) == RAD_OK, "%s", err.message);
    CHECK(ref && rows_identical(ref, F));
    double pw[32];
    hc_light l = {.kind = HC_LIGHT_POINT, .position = rad_v3(0.5, 0.5, 0.5)};
    CHECK_MSG(hc_light_power(e, &l, 16, pw, &err) == RAD_OK, "%s", err.message);
    hc_destroy(e);
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    CHECK(kill_children() == 2);
    CHECK(hc_light_power(e, &l, 16, pw, &err) == RAD_ERR_GL);
    CHECK(strstr(err.message, "worker") != NULL);
    CHECK(hc_compute_rows(e, rows, 1, F, &err) == RAD_ERR_GL);
    free(rows);
    hc_destroy(e);
    rad_matrix_destroy(F);
    rad_matrix_destroy(ref);
    builder_free(&b);
}

/* A worker killed in the middle of a job costs the rows it held, not the
 * job: they are computed again and the matrix is the undisturbed one. */
TEST(worker_killed_mid_job)
{
    builder b = {0};
    parallel_squares(&b, 8, rad_v3(0, 0, 0));
    rad_matrix *ref = compute_all(&b, 32, 2);
    killer k = {.at = b.m.patch_count / 3};
    hc_options o = {.resolution = 32, .processes = 2, .progress = kill_at, .progress_user = &k};
    hc_engine *e = NULL;
    rad_error err = {0};
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    rad_matrix *F = rad_matrix_create(b.m.patch_count);
    uint32_t *rows = all_rows(b.m.patch_count);
    CHECK_MSG(e && hc_compute_rows(e, rows, b.m.patch_count, F, &err) == RAD_OK, "%s",
              err.message);
    CHECK(k.pid > 0);
    CHECK(ref && rows_identical(ref, F) && F->rows_done == b.m.patch_count);
    /* the engine is whole: another job runs on it */
    rad_matrix *G = rad_matrix_create(b.m.patch_count);
    CHECK(e && hc_compute_rows(e, rows, b.m.patch_count, G, &err) == RAD_OK);
    CHECK(rows_identical(F, G));
    free(rows);
    hc_destroy(e);
    rad_matrix_destroy(F);
    rad_matrix_destroy(G);
    rad_matrix_destroy(ref);
    builder_free(&b);
}

/* A row that stops every worker asked for it (RADIOSITY_TEST_CRASH_ROW)
 * stops two, then the job fails naming its patch; the rows finished before
 * stay stored. */
TEST(a_row_that_stops_two_workers)
{
    builder b = {0};
    parallel_squares(&b, 4, rad_v3(0, 0, 0));
    setenv("RADIOSITY_TEST_CRASH_ROW", "20", 1);
    hc_options o = {.resolution = 16, .processes = 2};
    hc_engine *e = NULL;
    rad_error err = {0};
    CHECK(hc_create(&b.m, &o, &e, &err) == RAD_OK);
    rad_matrix *F = rad_matrix_create(b.m.patch_count);
    uint32_t *rows = all_rows(b.m.patch_count);
    CHECK(e && hc_compute_rows(e, rows, b.m.patch_count, F, &err) == RAD_ERR_GL);
    unsetenv("RADIOSITY_TEST_CRASH_ROW"); /* read by every worker started, replacements too */
    CHECK_MSG(strstr(err.message, "the row of patch 20 stopped two workers (the last killed by "
                                  "signal 9)"), "%s", err.message);
    CHECK(!F->row_done[20] && F->rows_done > 0);
    free(rows);
    hc_destroy(e);
    rad_matrix_destroy(F);
    builder_free(&b);
}

int main(void)
{
    RUN(delta_form_factors);
    RUN(parallel_squares_analytic);
    RUN(perpendicular_squares_analytic);
    RUN(closed_cube_rows_sum_to_one);
    RUN(reciprocity);
    RUN(element_to_rectangle_analytic);
    RUN(no_self_no_behind);
    RUN(determinism);
    RUN(far_from_origin);
    RUN(exact_small_source);
    RUN(focus_view_budget);
    RUN(exact_near_plates);
    RUN(exact_closed_cube);
    RUN(point_light);
    RUN(spot_light);
    RUN(directional_light);
    RUN(light_visibility);
    RUN(near_view_draws_only_the_reach);
    RUN(light_bad_input);
    RUN(bad_options);
    RUN(progress_reports);
    RUN(dead_worker);
    RUN(worker_killed_mid_job);
    RUN(a_row_that_stops_two_workers);
    return test_finish("test_hemicube");
}
