/* test_mesh.c - meshing (mesh.c): patch counts, exact area sums, shared
 * vertices, boundary flags, centroids, the patch limit and the mesh checks. */
#include "../radiosity/mesh/mesh.h"
#include "test.h"

static const double ZERO3[3] = {0, 0, 0};

/* A one-band scene with one emitting material and each polygon its own object. */
static rad_scene *scene_of(const rad_vec3 *const *polys, const uint32_t *counts, uint32_t n,
                           uint32_t subdiv_u, uint32_t subdiv_v)
{
    rad_scene *s = rad_scene_create(1, "mesh.rad");
    double rho = 0.5, em = 1.0;
    if (!s || rad_scene_add_material(s, "m", &rho, &em, NULL, NULL, NULL, NULL)) {
        rad_scene_destroy(s);
        return NULL;
    }
    for (uint32_t i = 0; i < n; i++) {
        char name[16];
        uint32_t obj;
        snprintf(name, sizeof name, "p%u", i);
        if (rad_scene_add_object(s, name, NULL, &obj, NULL) ||
            rad_scene_add_polygon(s, name, obj, 0, polys[i], counts[i], subdiv_u, subdiv_v, NULL,
                                  NULL, NULL)) {
            rad_scene_destroy(s);
            return NULL;
        }
    }
    return s;
}

static rad_scene *scene1(const rad_vec3 *p, uint32_t count, uint32_t su, uint32_t sv)
{
    return scene_of(&p, &count, 1, su, sv);
}

/* Is q inside (or on) the convex polygon p (CCW about n)? */
static int inside(rad_vec3 q, const rad_vec3 *p, uint32_t n, rad_vec3 normal, double tol)
{
    for (uint32_t k = 0; k < n; k++) {
        rad_vec3 e = rad_sub(p[(k + 1) % n], p[k]);
        if (rad_dot(rad_cross(e, rad_sub(q, p[k])), normal) < -tol)
            return 0;
    }
    return 1;
}

/* Every patch is convex with its corners counter-clockwise about its normal. */
static int patch_ccw(const rad_mesh *m, const rad_patch *p)
{
    int c = rad_patch_corners(p);
    for (int k = 0; k < c; k++) {
        rad_vec3 a = m->vertices[p->v[k]], b = m->vertices[p->v[(k + 1) % c]],
                 d = m->vertices[p->v[(k + 2) % c]];
        if (rad_dot(rad_cross(rad_sub(b, a), rad_sub(d, b)), p->normal) <= 0.0)
            return 0;
    }
    return 1;
}

static double area_sum(const rad_mesh *m)
{
    double a = 0.0;
    for (uint32_t i = 0; i < m->patch_count; i++)
        a += m->patches[i].area;
    return a;
}

TEST(quad_grid)
{
    rad_vec3 q[4] = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}};
    rad_scene *s = scene1(q, 4, 0, 0);
    CHECK(s != NULL);
    if (!s)
        return;
    rad_mesh_options opt = {.patch_size = 0.5};
    CHECK(rad_mesh_count(s, &opt) == 8);
    rad_mesh *m = NULL;
    rad_error e = {0};
    CHECK_MSG(rad_mesh_build(s, &opt, &m, &e) == RAD_OK, "%s", e.message);
    if (!m) {
        rad_scene_destroy(s);
        return;
    }
    CHECK(m->patch_count == 8);        /* 4 along p0->p1 (length 2), 2 along p1->p2 (length 1) */
    CHECK(m->vertex_count == 5 * 3);   /* (n+1)(m+1): shared corners */
    CHECK(rad_mesh_check(m, 1, 1, 1, &e) == RAD_OK);
    /* 1e-12 relative: a sum of 8 products of small binary fractions */
    CHECK_REL(area_sum(m), 2.0, 1e-12);
    int boundary_ok = 1, interior = 0;
    for (uint32_t k = 0; k < m->vertex_count; k++) {
        rad_vec3 v = m->vertices[k];
        int on = v.x == 0.0 || v.x == 2.0 || v.y == 0.0 || v.y == 1.0;
        boundary_ok &= m->vertex_boundary[k] == on;
        interior += !on;
    }
    CHECK(boundary_ok);
    CHECK(interior == 3); /* (n-1)(m-1) */
    /* each vertex used by as many patches as there are cells around it */
    int uses[15] = {0};
    for (uint32_t i = 0; i < m->patch_count; i++) {
        const rad_patch *p = &m->patches[i];
        CHECK(rad_patch_corners(p) == 4);
        CHECK(p->polygon == 0 && p->object == 0 && p->material == 0);
        CHECK(p->normal.z == 1.0);
        CHECK_REL(p->area, 0.25, 1e-12);
        CHECK(patch_ccw(m, p));
        /* rectangle cells: area centroid = mean of corners, computed here independently */
        rad_vec3 mean = rad_v3(0, 0, 0);
        for (int c = 0; c < 4; c++) {
            mean = rad_add(mean, m->vertices[p->v[c]]);
            uses[p->v[c]]++;
        }
        mean = rad_scale(mean, 0.25);
        CHECK_NEAR(rad_length(rad_sub(p->center, mean)), 0.0, 1e-15);
    }
    int use_ok = 1;
    for (uint32_t k = 0; k < m->vertex_count; k++) {
        rad_vec3 v = m->vertices[k];
        int corner = (v.x == 0.0 || v.x == 2.0) && (v.y == 0.0 || v.y == 1.0);
        int want = corner ? 1 : m->vertex_boundary[k] ? 2 : 4;
        use_ok &= uses[k] == want;
    }
    CHECK(use_ok);
    rad_mesh_destroy(m);
    rad_scene_destroy(s);
}

TEST(quad_parameters_and_override)
{
    /* a trapezoid: bilinear cells are planar convex quads of unequal size */
    rad_vec3 q[4] = {{0, 0, 0}, {4, 0, 0}, {3, 2, 0}, {1, 2, 0}};
    rad_scene *s = scene1(q, 4, 3, 2);
    rad_mesh *m = NULL;
    rad_error e = {0};
    CHECK(rad_mesh_count(s, NULL) == 6); /* the polygon's own subdivide 3 2 */
    CHECK(rad_mesh_build(s, NULL, &m, &e) == RAD_OK);
    if (m) {
        CHECK(m->patch_count == 6 && m->vertex_count == 12);
        CHECK_REL(area_sum(m), 6.0, 1e-12); /* trapezoid (4+2)/2·2 */
        for (uint32_t i = 0; i < m->patch_count; i++) {
            CHECK(patch_ccw(m, &m->patches[i]));
            CHECK(inside(m->patches[i].center, q, 4, rad_v3(0, 0, 1), 1e-12));
        }
        /* the area centroid of a trapezoid cell is not the corner mean:
         * bottom-left cell, corners (0,0) (4/3,0) (1+2/3·... ) checked by
         * decomposition into two triangles, done here by hand */
        const rad_patch *p = &m->patches[0];
        rad_vec3 a = m->vertices[p->v[0]], b = m->vertices[p->v[1]], c = m->vertices[p->v[2]],
                 d = m->vertices[p->v[3]];
        double a1 = 0.5 * rad_cross(rad_sub(b, a), rad_sub(c, a)).z;
        double a2 = 0.5 * rad_cross(rad_sub(c, a), rad_sub(d, a)).z;
        rad_vec3 g = rad_scale(rad_add(rad_scale(rad_add(rad_add(a, b), c), a1 / 3),
                                       rad_scale(rad_add(rad_add(a, c), d), a2 / 3)),
                               1.0 / (a1 + a2));
        CHECK_NEAR(rad_length(rad_sub(p->center, g)), 0.0, 1e-14);
        CHECK_REL(p->area, a1 + a2, 1e-14);
        rad_vec3 mean = rad_scale(rad_add(rad_add(a, b), rad_add(c, d)), 0.25);
        CHECK(rad_length(rad_sub(p->center, mean)) > 1e-6);
    }
    rad_mesh_destroy(m);
    /* a positive patch size overrides the polygon's parameters: longer of
     * the opposite edges, 4 and 2 -> 4 cells; 2.236 and 2.236 -> 3 cells */
    rad_mesh_options opt = {.patch_size = 1.0};
    CHECK(rad_mesh_count(s, &opt) == 12);
    rad_scene_destroy(s);
}

TEST(default_patch_size)
{
    rad_vec3 q[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    rad_scene *s = scene1(q, 4, 0, 0);
    /* bounding-box diagonal / 34 = √2/34 */
    CHECK_REL(rad_mesh_default_patch_size(s), sqrt(2.0) / 34.0, 1e-15);
    /* ceil(1 / (√2/34)) = ceil(24.04) = 25 per side */
    CHECK(rad_mesh_count(s, NULL) == 25 * 25);
    rad_scene_destroy(s);
}

TEST(triangle_subdivision)
{
    rad_vec3 t[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    for (uint32_t k = 1; k <= 6; k++) {
        rad_scene *s = scene1(t, 3, k, 0);
        rad_mesh *m = NULL;
        rad_error e = {0};
        CHECK(rad_mesh_build(s, NULL, &m, &e) == RAD_OK);
        if (!m) {
            rad_scene_destroy(s);
            continue;
        }
        CHECK(m->patch_count == k * k);
        CHECK(m->vertex_count == (k + 1) * (k + 2) / 2);
        CHECK(rad_mesh_check(m, 1, 1, 1, &e) == RAD_OK);
        CHECK_REL(area_sum(m), 0.5, 1e-12); /* rounding in k² small sums */
        uint32_t nb = 0;
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            rad_vec3 p = m->vertices[v];
            int on = fabs(p.x) < 1e-12 || fabs(p.y) < 1e-12 || fabs(p.x + p.y - 1) < 1e-12;
            CHECK(m->vertex_boundary[v] == on);
            nb += on;
        }
        CHECK(nb == 3 * k);
        for (uint32_t i = 0; i < m->patch_count; i++) {
            const rad_patch *p = &m->patches[i];
            CHECK(rad_patch_corners(p) == 3 && p->v[3] == RAD_NONE);
            /* a regular split: all k² triangles have area 1/(2k²) */
            CHECK_REL(p->area, 0.5 / (k * k), 1e-12);
            CHECK(patch_ccw(m, p));
            rad_vec3 mean = rad_scale(rad_add(rad_add(m->vertices[p->v[0]], m->vertices[p->v[1]]),
                                              m->vertices[p->v[2]]),
                                      1.0 / 3.0);
            CHECK_NEAR(rad_length(rad_sub(p->center, mean)), 0.0, 1e-15);
        }
        rad_mesh_destroy(m);
        rad_scene_destroy(s);
    }
}

TEST(pentagon_fan)
{
    rad_vec3 p[5];
    for (int k = 0; k < 5; k++) {
        double a = 2.0 * M_PI * k / 5.0;
        p[k] = rad_v3(cos(a), sin(a), 2.0);
    }
    const uint32_t K = 3;
    rad_scene *s = scene1(p, 5, K, 0);
    rad_mesh *m = NULL;
    rad_error e = {0};
    CHECK(rad_mesh_build(s, NULL, &m, &e) == RAD_OK);
    if (!m) {
        rad_scene_destroy(s);
        return;
    }
    CHECK(m->patch_count == 5 * K * K);
    /* centre + 5 spokes of K points + 5 triangles' K(K-1)/2 own points */
    CHECK(m->vertex_count == 1 + 5 * K + 5 * K * (K - 1) / 2);
    CHECK(rad_mesh_check(m, 1, 1, 1, &e) == RAD_OK);
    /* regular pentagon of circumradius 1: area 5/2 sin 72° */
    CHECK_REL(area_sum(m), 2.5 * sin(2.0 * M_PI / 5.0), 1e-12);
    /* no two vertices at the same place: the spokes are shared, not doubled */
    int distinct = 1;
    for (uint32_t a = 0; a < m->vertex_count; a++)
        for (uint32_t b = a + 1; b < m->vertex_count; b++)
            if (rad_length(rad_sub(m->vertices[a], m->vertices[b])) < 1e-9)
                distinct = 0;
    CHECK(distinct);
    uint32_t nb = 0;
    for (uint32_t v = 0; v < m->vertex_count; v++)
        nb += m->vertex_boundary[v];
    CHECK(nb == 5 * K); /* the outline: 5 corners and K-1 points on each edge */
    rad_vec3 n = rad_v3(0, 0, 1);
    for (uint32_t i = 0; i < m->patch_count; i++) {
        CHECK(inside(m->patches[i].center, p, 5, n, 1e-12));
        CHECK(patch_ccw(m, &m->patches[i]));
        CHECK(m->patches[i].normal.z == 1.0);
    }
    rad_mesh_destroy(m);
    rad_scene_destroy(s);
}

TEST(vertices_not_shared_across_polygons)
{
    rad_vec3 a[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    rad_vec3 b[4] = {{1, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}};
    const rad_vec3 *polys[2] = {a, b};
    uint32_t counts[2] = {4, 4};
    rad_scene *s = scene_of(polys, counts, 2, 2, 2);
    rad_mesh *m = NULL;
    CHECK(rad_mesh_build(s, NULL, &m, NULL) == RAD_OK);
    if (m) {
        CHECK(m->patch_count == 8 && m->vertex_count == 18);
        for (uint32_t i = 0; i < m->patch_count; i++) {
            uint32_t poly = i < 4 ? 0 : 1;
            CHECK(m->patches[i].polygon == poly && m->patches[i].object == poly);
            for (int c = 0; c < 4; c++)
                CHECK((m->patches[i].v[c] >= 9) == (poly == 1));
        }
    }
    rad_mesh_destroy(m);
    rad_scene_destroy(s);
}

TEST(patch_limit)
{
    rad_vec3 q[4] = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}};
    rad_scene *s = scene1(q, 4, 0, 0);
    rad_mesh_options opt = {.patch_size = 0.1, .max_patches = 10};
    rad_mesh *m = (rad_mesh *)1;
    rad_error e = {0};
    CHECK(rad_mesh_build(s, &opt, &m, &e) == RAD_ERR_LIMIT);
    CHECK(m == NULL);
    CHECK_MSG(strstr(e.message, "mesh.rad: mesh: 200 patches exceed the limit of 10") != NULL,
              "%s", e.message);
    /* the advice works: the size it names meshes within the limit */
    const char *adv = strstr(e.message, "use --patch-size ");
    CHECK_MSG(adv != NULL, "%s", e.message);
    rad_mesh_options fits = opt;
    fits.patch_size = adv ? strtod(adv + strlen("use --patch-size "), NULL) : 0.0;
    CHECK(fits.patch_size > 0.1 && rad_mesh_count(s, &fits) <= 10);
    /* a patch size so small the count overflows */
    opt.patch_size = 1e-300;
    opt.max_patches = 0;
    CHECK(rad_mesh_count(s, &opt) == UINT64_MAX);
    CHECK(rad_mesh_build(s, &opt, &m, &e) == RAD_ERR_LIMIT);
    CHECK(m == NULL);
    CHECK_MSG(strstr(e.message, "exceed the limit of 2000000") != NULL, "%s", e.message);
    opt.max_patches = 200;
    opt.patch_size = 0.1;
    CHECK(rad_mesh_build(s, &opt, &m, &e) == RAD_OK);
    CHECK(m && m->patch_count == 200);
    rad_mesh_destroy(m);
    rad_scene_destroy(s);
}

TEST(mesh_check_finds_faults)
{
    rad_vec3 t[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    rad_scene *s = scene1(t, 3, 2, 0);
    rad_mesh *m = NULL;
    rad_error e = {0};
    CHECK(rad_mesh_build(s, NULL, &m, &e) == RAD_OK);
    if (!m) {
        rad_scene_destroy(s);
        return;
    }
    CHECK(rad_mesh_check(m, 1, 1, 1, &e) == RAD_OK);
    CHECK(rad_mesh_check(m, 0, 1, 1, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "patch 0: polygon 0 out of range") != NULL, "%s", e.message);
    CHECK(rad_mesh_check(m, 1, 1, 0, &e) == RAD_ERR_CORRUPT);
    rad_patch keep = m->patches[1];
    m->patches[1].v[2] = m->vertex_count;
    CHECK(rad_mesh_check(m, 1, 1, 1, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "patch 1: vertex index 6 out of range") != NULL, "%s", e.message);
    m->patches[1] = keep;
    m->patches[1].area = 0.0;
    CHECK(rad_mesh_check(m, 1, 1, 1, &e) == RAD_ERR_CORRUPT);
    m->patches[1] = keep;
    m->patches[1].normal = rad_v3(0, 0, 2);
    CHECK(rad_mesh_check(m, 1, 1, 1, &e) == RAD_ERR_CORRUPT);
    m->patches[1] = keep;
    m->vertices[0].x = NAN;
    CHECK(rad_mesh_check(m, 1, 1, 1, &e) == RAD_ERR_CORRUPT);
    rad_mesh_destroy(m);
    rad_scene_destroy(s);

    rad_mesh *empty = rad_mesh_alloc(0, 0);
    CHECK(empty != NULL && empty->patch_count == 0);
    CHECK(rad_mesh_check(empty, 0, 0, 0, &e) == RAD_OK);
    rad_mesh_destroy(empty);
    rad_mesh *some = rad_mesh_alloc(4, 2);
    CHECK(some && some->vertex_count == 4 && some->patch_count == 2 && some->vertex_boundary);
    rad_mesh_destroy(some);
    rad_mesh_destroy(NULL);
}

TEST(cornell_mesh)
{
    rad_scene *s = NULL;
    rad_error e = {0};
    CHECK_MSG(rad_scene_load("models/cornell.rad", NULL, &s, &e) == RAD_OK, "%s", e.message);
    if (!s)
        return;
    rad_mesh *m = NULL;
    CHECK_MSG(rad_mesh_build(s, NULL, &m, &e) == RAD_OK, "%s", e.message);
    if (m) {
        CHECK(m->patch_count == rad_mesh_count(s, NULL));
        CHECK(rad_mesh_check(m, s->polygon_count, s->object_count, s->material_count, &e) ==
              RAD_OK);
        /* per polygon, the cells tile it: Σ cell areas = polygon area (1e-12:
         * rounding).  Cells, not patches: the ceiling's four quads are one
         * planar region since issue 36, whose patches span them. */
        for (uint32_t k = 0; k < s->polygon_count; k++) {
            double a = 0.0;
            for (uint32_t i = 0; i < m->patch_count; i++) {
                const rad_patch *c;
                for (uint32_t q = 0, n = rad_patch_cells(m, i, &c); q < n; q++)
                    if (c[q].polygon == k)
                        a += c[q].area;
            }
            CHECK_REL(a, s->polygons[k].area, 1e-12);
        }
    }
    rad_mesh_destroy(m);
    rad_scene_destroy(s);
}

int main(void)
{
    RUN(quad_grid);
    RUN(quad_parameters_and_override);
    RUN(default_patch_size);
    RUN(triangle_subdivision);
    RUN(pentagon_fan);
    RUN(vertices_not_shared_across_polygons);
    RUN(patch_limit);
    RUN(mesh_check_finds_faults);
    RUN(cornell_mesh);
    (void)ZERO3;
    return test_finish("test_mesh");
}
