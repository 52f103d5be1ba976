/* test_scene.c - the scene builder's checks (scene.c): every refusal names
 * the source, the element and the problem; what is accepted gets the right
 * normal and area. */
#include "../radiosity/scene/scene.h"
#include "test.h"

static const double ZERO3[3] = {0, 0, 0};

/* A 3-band scene "t.rad" with one grey material and one object. */
static rad_scene *base_scene(void)
{
    rad_scene *s = rad_scene_create(3, "t.rad");
    double rho[3] = {0.5, 0.5, 0.5};
    if (!s || rad_scene_add_material(s, "grey", rho, ZERO3, NULL, "line 1", NULL, NULL) ||
        rad_scene_add_object(s, "thing", "line 2", NULL, NULL)) {
        rad_scene_destroy(s);
        return NULL;
    }
    return s;
}

static int has(const rad_error *e, const char *text)
{
    return strstr(e->message, text) != NULL;
}

TEST(create_and_destroy)
{
    CHECK(rad_scene_create(0, "x") == NULL);
    CHECK(rad_scene_create(RAD_MAX_BANDS + 1, "x") == NULL);
    rad_scene *s = rad_scene_create(RAD_MAX_BANDS, NULL);
    CHECK(s != NULL);
    if (s) {
        CHECK(strcmp(s->source, "<memory>") == 0);
        CHECK(s->band_count == RAD_MAX_BANDS);
    }
    rad_scene_destroy(s);
    rad_scene_destroy(NULL);
}

TEST(material_checks)
{
    rad_scene *s = base_scene();
    CHECK(s != NULL);
    if (!s)
        return;
    rad_error e = {0};
    double bad_rho[3] = {0.5, 1.2, 0.5};
    CHECK(rad_scene_add_material(s, "m", bad_rho, ZERO3, NULL, "line 5", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 5: material 'm': reflectance 1.2 outside [0, 1) in band 1"),
              "%s", e.message);

    double one[3] = {1.0, 0.5, 0.5};
    CHECK(rad_scene_add_material(s, "m", one, ZERO3, NULL, "line 6", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "line 6: material 'm': reflectance 1 outside [0, 1)"), "%s", e.message);

    double neg[3] = {0.5, 0.5, -0.1};
    CHECK(rad_scene_add_material(s, "m", neg, ZERO3, NULL, "line 7", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "reflectance -0.1 outside [0, 1) in band 2"), "%s", e.message);

    double nanr[3] = {NAN, 0.5, 0.5};
    CHECK(rad_scene_add_material(s, "m", nanr, ZERO3, NULL, "line 8", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "line 8: material 'm': reflectance"), "%s", e.message);

    double rho[3] = {0.5, 0.5, 0.5};
    double em_neg[3] = {1, -1, 0};
    CHECK(rad_scene_add_material(s, "m", rho, em_neg, NULL, "line 9", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "line 9: material 'm': emission -1 must be finite and >= 0"), "%s",
              e.message);
    double em_inf[3] = {INFINITY, 0, 0};
    CHECK(rad_scene_add_material(s, "m", rho, em_inf, NULL, "line 10", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "line 10: material 'm': emission inf"), "%s", e.message);

    double t_one[3] = {0, 1, 0};
    CHECK(rad_scene_add_material(s, "m", ZERO3, ZERO3, t_one, "line 11", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "line 11: material 'm': transmittance 1 outside [0, 1)"), "%s", e.message);
    double t_half[3] = {0.6, 0.6, 0.6};
    CHECK(rad_scene_add_material(s, "m", rho, ZERO3, t_half, "line 12", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "line 12: material 'm': reflectance + transmittance = 1.1 must be < 1"),
              "%s", e.message);

    CHECK(rad_scene_add_material(s, "", rho, ZERO3, NULL, "line 13", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 13: a material needs a non-empty name"), "%s", e.message);
    CHECK(rad_scene_add_material(s, "grey", rho, ZERO3, NULL, "line 14", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 14: material 'grey': a material of this name already exists"),
              "%s", e.message);

    /* refusals add nothing */
    CHECK(s->material_count == 1);

    /* a good one: values stored per band, transmittance kept, bands beyond
     * band_count zero */
    double t_ok[3] = {0.1, 0.2, 0.3};
    double em[3] = {1, 2, 3};
    uint32_t idx = 99;
    CHECK(rad_scene_add_material(s, "glass", rho, em, t_ok, "line 15", &idx, &e) == RAD_OK);
    CHECK(idx == 1);
    CHECK(s->materials[1].rho[2] == 0.5 && s->materials[1].emission[1] == 2.0 &&
          s->materials[1].transmit[2] == 0.3 && s->materials[1].rho[3] == 0.0);
    CHECK(rad_scene_find_material(s, "glass") == 1);
    CHECK(rad_scene_find_material(s, "grey") == 0);
    CHECK(rad_scene_find_material(s, "nope") == RAD_NONE);
    rad_scene_destroy(s);
}

TEST(grey_scene_has_no_band_label)
{
    rad_scene *s = rad_scene_create(1, "g.rad");
    rad_error e = {0};
    double r = 1.5;
    CHECK(rad_scene_add_material(s, "m", &r, NULL, NULL, "line 3", NULL, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "g.rad: line 3: material 'm': reflectance 1.5 outside [0, 1)") &&
                  !has(&e, "band"),
              "%s", e.message);
    rad_scene_destroy(s);
}

TEST(band_names_in_messages)
{
    rad_scene *s = rad_scene_create(3, "n.rad");
    CHECK(s != NULL);
    if (!s)
        return;
    s->band_names[0] = strdup("R");
    s->band_names[1] = strdup("G");
    s->band_names[2] = strdup("B");
    rad_error e = {0};
    double r[3] = {0.1, 0.2, 3.0};
    CHECK(rad_scene_add_material(s, "m", r, NULL, NULL, "line 2", NULL, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "in band 2 (B)"), "%s", e.message);
    rad_scene_destroy(s);
}

TEST(object_checks)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    CHECK(rad_scene_add_object(s, "", "line 4", NULL, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 4: an object needs a non-empty name"), "%s", e.message);
    CHECK(rad_scene_add_object(s, NULL, "line 4", NULL, &e) == RAD_ERR_INVALID);
    CHECK(rad_scene_add_object(s, "thing", "line 5", NULL, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 5: object 'thing': an object of this name already exists"),
              "%s", e.message);
    CHECK(s->object_count == 1);
    rad_scene_destroy(s);
}

/* Many names: the uniqueness check must stay correct past several rehashes. */
TEST(many_objects)
{
    rad_scene *s = rad_scene_create(1, NULL);
    char name[32];
    int ok = 1;
    for (int k = 0; k < 20000 && ok; k++) {
        snprintf(name, sizeof name, "obj%d", k);
        uint32_t idx;
        ok = rad_scene_add_object(s, name, NULL, &idx, NULL) == RAD_OK && idx == (uint32_t)k;
    }
    CHECK(ok);
    CHECK(s->object_count == 20000);
    CHECK(rad_scene_find_object(s, "obj0") == 0);
    CHECK(rad_scene_find_object(s, "obj12345") == 12345);
    CHECK(rad_scene_find_object(s, "obj20000") == RAD_NONE);
    rad_error e = {0};
    CHECK(rad_scene_add_object(s, "obj777", NULL, NULL, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "<memory>: object 'obj777': an object of this name already exists"), "%s",
              e.message);
    rad_scene_destroy(s);
}

static int add_poly(rad_scene *s, const rad_vec3 *p, uint32_t n, rad_error *e)
{
    return rad_scene_add_polygon(s, "p", 0, 0, p, n, 0, 0, "line 7", NULL, e);
}

TEST(polygon_too_few_points)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    rad_vec3 p[2] = {{0, 0, 0}, {1, 0, 0}};
    CHECK(add_poly(s, p, 2, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 7: polygon 'p': 2 points, a polygon needs at least 3"), "%s",
              e.message);
    CHECK(add_poly(s, p, 1, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "polygon 'p': 1 point, a polygon needs at least 3"), "%s", e.message);
    CHECK(s->polygon_count == 0 && s->point_count == 0);
    rad_scene_destroy(s);
}

TEST(polygon_not_finite)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    rad_vec3 p[3] = {{0, 0, 0}, {1, NAN, 0}, {0, 1, 0}};
    CHECK(add_poly(s, p, 3, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 7: polygon 'p': point 2") && has(&e, "not a finite number"),
              "%s", e.message);
    rad_vec3 q[3] = {{0, 0, 0}, {1, 0, 0}, {0, INFINITY, 0}};
    CHECK(add_poly(s, q, 3, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "point 3") && has(&e, "not a finite number"), "%s", e.message);
    rad_scene_destroy(s);
}

TEST(polygon_zero_area)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    rad_vec3 line[3] = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
    CHECK(add_poly(s, line, 3, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 7: polygon 'p': zero area"), "%s", e.message);
    rad_vec3 dot[3] = {{5, 5, 5}, {5, 5, 5}, {5, 5, 5}};
    CHECK(add_poly(s, dot, 3, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "polygon 'p': zero area"), "%s", e.message);
    /* a sliver 1e-7 thin on a unit length: area 5e-8 > 1e-12 · size², kept */
    rad_vec3 thin[3] = {{0, 0, 0}, {1, 0, 0}, {0.5, 1e-7, 0}};
    CHECK(add_poly(s, thin, 3, &e) == RAD_OK);
    rad_scene_destroy(s);
}

TEST(polygon_coincident_points)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    rad_vec3 p[4] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    CHECK(add_poly(s, p, 4, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "polygon 'p': points 2 and 3 coincide"), "%s", e.message);
    rad_scene_destroy(s);
}

TEST(polygon_non_planar)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    /* Unit square with one corner lifted by h: the Newell plane leaves every
     * corner h/4 off it.  Tolerance 1e-4 · √2 = 1.41e-4: h = 1e-3 fails,
     * h = 1e-4 (2.5e-5 off) passes. */
    rad_vec3 bent[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 1e-3}, {0, 1, 0}};
    CHECK(add_poly(s, bent, 4, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 7: polygon 'p': not planar"), "%s", e.message);
    rad_vec3 slight[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 1e-4}, {0, 1, 0}};
    CHECK(add_poly(s, slight, 4, &e) == RAD_OK);
    rad_scene_destroy(s);
}

TEST(polygon_non_convex)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    /* a dart: the corner at (0.5, 0.3) turns the wrong way */
    rad_vec3 dart[4] = {{0, 0, 0}, {0.5, 0.3, 0}, {1, 0, 0}, {0.5, 1, 0}};
    CHECK(add_poly(s, dart, 4, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 7: polygon 'p': not convex"), "%s", e.message);
    /* a bow tie (self-intersecting) */
    rad_vec3 bow[4] = {{0, 0, 0}, {1, 1, 0}, {1, 0, 0}, {0, 1, 0}};
    CHECK(add_poly(s, bow, 4, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "polygon 'p': not convex: the outline crosses itself"), "%s", e.message);
    rad_vec3 bow2[4] = {{0, 0, 0}, {2, 2, 0}, {2, 0, 0}, {0, 1, 0}}; /* lobes of unequal size */
    CHECK(add_poly(s, bow2, 4, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "polygon 'p': not convex"), "%s", e.message);
    /* a pentagram: every corner turns the same way, but twice around */
    rad_vec3 star[5];
    for (int k = 0; k < 5; k++) {
        double a = 2.0 * M_PI * (2 * k) / 5.0;
        star[k] = rad_v3(cos(a), sin(a), 0);
    }
    CHECK(add_poly(s, star, 5, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "polygon 'p': not convex: the outline winds 2"), "%s", e.message);
    /* collinear points are tolerated */
    rad_vec3 mid[5] = {{0, 0, 0}, {0.5, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    CHECK(add_poly(s, mid, 5, &e) == RAD_OK);
    CHECK(s->polygon_count == 1);
    rad_scene_destroy(s);
}

TEST(polygon_normal_and_area)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    uint32_t a, b;
    /* counter-clockwise seen from +z: the normal is +z */
    rad_vec3 ccw[4] = {{0, 0, 0}, {2, 0, 0}, {2, 3, 0}, {0, 3, 0}};
    CHECK(rad_scene_add_polygon(s, "ccw", 0, 0, ccw, 4, 2, 3, "line 1", &a, &e) == RAD_OK);
    /* the same square wound the other way faces -z */
    rad_vec3 cw[4] = {{0, 0, 1}, {0, 3, 1}, {2, 3, 1}, {2, 0, 1}};
    CHECK(rad_scene_add_polygon(s, "cw", 0, 0, cw, 4, 0, 0, "line 2", &b, &e) == RAD_OK);
    CHECK(a == 0 && b == 1);
    /* exact: small integers, no rounding */
    CHECK(s->polygons[0].normal.z == 1.0 && s->polygons[0].normal.x == 0.0);
    CHECK(s->polygons[1].normal.z == -1.0);
    CHECK(s->polygons[0].area == 6.0);
    CHECK(s->polygons[0].subdiv_u == 2 && s->polygons[0].subdiv_v == 3);
    CHECK(s->polygons[1].first_point == 4 && s->polygons[1].point_count == 4);
    CHECK(s->point_count == 8);
    CHECK(strcmp(s->polygons[1].name, "cw") == 0);
    /* a tilted triangle: area |(b-a)×(c-a)|/2 computed by hand = √3/2 · 2 = √3 */
    rad_vec3 t[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    uint32_t c;
    CHECK(rad_scene_add_polygon(s, "t", 0, 0, t, 3, 0, 0, NULL, &c, &e) == RAD_OK);
    CHECK_NEAR(s->polygons[c].area, sqrt(3.0) / 2.0, 1e-15); /* rounding only */
    CHECK_NEAR(s->polygons[c].normal.x, 1.0 / sqrt(3.0), 1e-15);
    rad_vec3 lo, hi;
    CHECK(rad_scene_bounds(s, &lo, &hi) == 1);
    CHECK(lo.x == 0 && lo.y == 0 && lo.z == 0 && hi.x == 2 && hi.y == 3 && hi.z == 1);
    rad_scene_destroy(s);
}

TEST(polygon_bad_indices)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    rad_vec3 p[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    CHECK(rad_scene_add_polygon(s, "p", 1, 0, p, 3, 0, 0, "line 3", NULL, &e) == RAD_ERR_USAGE);
    CHECK_MSG(has(&e, "line 3: polygon 'p': object 1 does not exist"), "%s", e.message);
    CHECK(rad_scene_add_polygon(s, "p", 0, 5, p, 3, 0, 0, "line 3", NULL, &e) == RAD_ERR_USAGE);
    CHECK_MSG(has(&e, "material 5 does not exist"), "%s", e.message);
    rad_scene_destroy(s);
}

/* A where that already names the element is not repeated. */
TEST(where_names_element_once)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    rad_vec3 p[2] = {{0, 0, 0}, {1, 0, 0}};
    CHECK(rad_scene_add_polygon(s, "m/0/3", 0, 0, p, 2, 0, 0, "polygon 'm/0/3'", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(strcmp(e.message, "t.rad: polygon 'm/0/3': 2 points, a polygon needs at least 3") ==
                  0,
              "%s", e.message);
    rad_scene_destroy(s);
}

TEST(camera_checks)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    rad_vec3 eye = {0, 0, -1}, target = {0, 0, 0}, up = {0, 1, 0};
    CHECK(rad_scene_add_camera(s, "c", eye, eye, up, 40, 0, "line 9", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 9: camera 'c': eye and target coincide"), "%s", e.message);
    CHECK(rad_scene_add_camera(s, "c", eye, target, rad_v3(0, 0, 2), 40, 0, "line 9", NULL,
                               &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "camera 'c': up (0 0 2) is zero or parallel"), "%s", e.message);
    CHECK(rad_scene_add_camera(s, "c", eye, target, up, 180, 0, "line 9", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "camera 'c': fov 180 degrees outside (0, 180)"), "%s", e.message);
    CHECK(rad_scene_add_camera(s, "c", eye, target, up, 0, 0, "line 9", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK(rad_scene_add_camera(s, "c", rad_v3(NAN, 0, 0), target, up, 40, 0, "line 9", NULL,
                               &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "must be finite"), "%s", e.message);
    CHECK(rad_scene_add_camera(s, "", eye, target, up, 40, 0, "line 9", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "a camera needs a non-empty name"), "%s", e.message);
    uint32_t idx;
    CHECK(rad_scene_add_camera(s, "c", eye, target, up, 40, 1.5, "line 9", &idx, &e) == RAD_OK);
    CHECK(idx == 0 && s->camera_count == 1 && s->cameras[0].yfov_deg == 40 &&
          s->cameras[0].aspect == 1.5);
    CHECK(rad_scene_add_camera(s, "c", eye, target, up, 40, 0, "line 10", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 10: camera 'c': a camera of this name already exists"), "%s",
              e.message);
    CHECK(rad_scene_find_camera(s, "c") == 0);
    CHECK(rad_scene_find_camera(s, "d") == RAD_NONE);
    rad_scene_destroy(s);
}

/* Orthographic cameras: positive finite half-sizes, the shared checks
 * otherwise; a placeholder fov so that perspective-only readers take them. */
TEST(ortho_camera_checks)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    rad_vec3 eye = {0, 0, -1}, target = {0, 0, 0}, up = {0, 1, 0};
    CHECK(rad_scene_add_ortho_camera(s, "o", eye, target, up, 2, 0, "line 9", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: line 9: camera 'o': orthographic half-sizes 2 × 0 must be finite "
                      "and > 0"),
              "%s", e.message);
    CHECK(rad_scene_add_ortho_camera(s, "o", eye, target, up, INFINITY, 1, "line 9", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK(rad_scene_add_ortho_camera(s, "o", eye, eye, up, 1, 1, "line 9", NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "eye and target coincide"), "%s", e.message);
    uint32_t idx;
    CHECK(rad_scene_add_ortho_camera(s, "o", eye, target, up, 3, 1.5, "line 9", &idx, &e) ==
          RAD_OK);
    const rad_camera *c = &s->cameras[idx];
    CHECK(c->orthographic && c->xmag == 3 && c->ymag == 1.5 && c->aspect == 2 &&
          c->yfov_deg > 0 && c->yfov_deg < 180);
    /* a perspective camera made orthographic (the solution reader's way) */
    CHECK(rad_scene_add_camera(s, "p", eye, target, up, 40, 0, "line 10", &idx, &e) == RAD_OK);
    CHECK(!s->cameras[idx].orthographic);
    CHECK(rad_scene_set_camera_ortho(s, idx, -1, 1, "CAMS", &e) == RAD_ERR_INVALID);
    CHECK(!s->cameras[idx].orthographic);
    CHECK(rad_scene_set_camera_ortho(s, idx, 1, 2, "CAMS", &e) == RAD_OK);
    CHECK(s->cameras[idx].orthographic && s->cameras[idx].ymag == 2);
    rad_scene_destroy(s);
}

/* A polygon's own ρ: refused outside [0, 1) or with τ reaching 1; given,
 * it overrides the material's for that polygon only, and polygons added
 * later start from their material's. */
TEST(polygon_reflectance)
{
    rad_scene *s = base_scene();
    rad_error e = {0};
    double tau[3] = {0.3, 0.3, 0.3}, rho[3] = {0.2, 0.2, 0.2}, zero[3] = {0, 0, 0};
    uint32_t sheet;
    CHECK(rad_scene_add_material(s, "sheet", rho, zero, tau, "line 3", &sheet, &e) == RAD_OK);
    rad_vec3 sq[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    CHECK(rad_scene_add_polygon(s, "a", 0, 0, sq, 4, 0, 0, "line 4", NULL, &e) == RAD_OK);
    CHECK(rad_scene_add_polygon(s, "b", 0, sheet, sq, 4, 0, 0, "line 5", NULL, &e) == RAD_OK);
    CHECK(s->polygon_rho == NULL && rad_polygon_rho(s, 0)[0] == 0.5);
    double bad[3] = {0.1, 1.0, 0.1};
    CHECK(rad_scene_set_polygon_rho(s, 0, bad, "tri 7", &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: tri 7: polygon 'a': reflectance 1 outside [0, 1) in band 1"), "%s",
              e.message);
    double over[3] = {0.1, 0.75, 0.1}; /* + τ 0.3 */
    CHECK(rad_scene_set_polygon_rho(s, 1, over, "tri 8", &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "reflectance + transmittance = 1.05 must be < 1"), "%s", e.message);
    CHECK(s->polygon_rho == NULL); /* nothing changed on failure */
    double own[3] = {0.1, 0.6, 0.3};
    CHECK(rad_scene_set_polygon_rho(s, 0, own, "tri 9", &e) == RAD_OK);
    CHECK(rad_polygon_rho(s, 0)[1] == 0.6 && rad_polygon_rho(s, 1)[1] == 0.2);
    CHECK(s->materials[0].rho[1] == 0.5); /* the material keeps its own */
    /* many more polygons: the array grows with them, each its material's */
    for (int k = 0; k < 40; k++) {
        char name[16];
        snprintf(name, sizeof name, "c%d", k);
        CHECK(rad_scene_add_polygon(s, name, 0, k % 2 ? sheet : 0, sq, 4, 0, 0, "line 6", NULL,
                                    &e) == RAD_OK);
    }
    CHECK(rad_polygon_rho(s, 41)[2] == 0.2 && rad_polygon_rho(s, 40)[2] == 0.5);
    CHECK(rad_polygon_rho(s, 0)[2] == 0.3);
    CHECK(rad_scene_set_polygon_rho(s, 42, own, "x", &e) == RAD_ERR_USAGE);
    rad_scene_destroy(s);
}

TEST(validate_scene)
{
    rad_error e = {0};
    rad_scene *s = base_scene();
    CHECK(rad_scene_validate(s, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: no polygons"), "%s", e.message);

    rad_vec3 p[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    CHECK(add_poly(s, p, 3, &e) == RAD_OK);
    CHECK(rad_scene_validate(s, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: no emitter: no material has emission > 0"), "%s", e.message);

    /* an emitting material that no polygon uses lights nothing */
    double em[3] = {0, 0, 5};
    uint32_t lamp;
    CHECK(rad_scene_add_material(s, "lamp", ZERO3, em, NULL, "line 20", &lamp, &e) == RAD_OK);
    CHECK(rad_scene_validate(s, &e) == RAD_ERR_INVALID);
    CHECK_MSG(has(&e, "t.rad: no emitter: material 'lamp' has emission > 0 but no polygon uses it"),
              "%s", e.message);

    rad_vec3 q[3] = {{0, 0, 1}, {0, 1, 1}, {1, 0, 1}};
    CHECK(rad_scene_add_polygon(s, "lamp", 0, lamp, q, 3, 0, 0, "line 21", NULL, &e) == RAD_OK);
    CHECK(rad_scene_validate(s, &e) == RAD_OK);
    CHECK(rad_scene_validate(NULL, &e) == RAD_ERR_USAGE);
    rad_scene_destroy(s);
}

TEST(empty_scene_bounds)
{
    rad_scene *s = rad_scene_create(1, NULL);
    rad_vec3 lo, hi;
    CHECK(rad_scene_bounds(s, &lo, &hi) == 0);
    CHECK(rad_scene_find_material(s, "x") == RAD_NONE);
    CHECK(rad_scene_find_object(NULL, "x") == RAD_NONE);
    rad_scene_destroy(s);
}

int main(void)
{
    RUN(create_and_destroy);
    RUN(material_checks);
    RUN(grey_scene_has_no_band_label);
    RUN(band_names_in_messages);
    RUN(object_checks);
    RUN(many_objects);
    RUN(polygon_too_few_points);
    RUN(polygon_not_finite);
    RUN(polygon_zero_area);
    RUN(polygon_coincident_points);
    RUN(polygon_non_planar);
    RUN(polygon_non_convex);
    RUN(polygon_normal_and_area);
    RUN(polygon_bad_indices);
    RUN(where_names_element_once);
    RUN(camera_checks);
    RUN(ortho_camera_checks);
    RUN(polygon_reflectance);
    RUN(validate_scene);
    RUN(empty_scene_bounds);
    return test_finish("test_scene");
}
