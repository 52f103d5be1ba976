/* test_lights.c - punctual lights (glTF KHR_lights_punctual) end to end,
 * through the public API, against values computed here independently:
 *   - a point light above a lone floor: patch irradiance H_d,j against the
 *     patch average of I cosθ / r², integrated by fine quadrature here; and
 *     B_j = ρ H_d,j (a lone floor sees nothing, so the solve adds nothing);
 *   - the shadow of a black box: umbra patches dark, far patches unoccluded;
 *   - a spot light's cone: inside like a point light, outside dark, between
 *     glTF's smooth falloff;
 *   - a directional light: H = E⊥ cosθ on a tilted plane, and a blocker's
 *     shadow;
 *   - glTF parsing: 683 lm/W, node transforms, the required extension;
 *   - relight: off, scale 2, nothing rendered again; solution round trip;
 *   - elements (substructuring) get their own direct light, not their
 *     patch's: the mean irradiance over each (issue 39) from a point light
 *     on uniform elements, the edges of a box's shadow, a spot's cone and a
 *     directional light's shadow placed within a fraction of an element,
 *     elements at grazing angles against quadrature,
 *     adaptive refinement following a shadow edge, and a relight that
 *     doubles every element's direct term with nothing rendered.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Light cube resolution for the accuracy tests.  hc_light_power counts
 * pixels, and a patch edge lying along a pixel row or column is off by up
 * to half a pixel: a floor patch 0.2 m wide seen from 1 m spans ~200 pixels
 * of a 2048 face, which puts the worst patch near 0.8 % (measured: 1.2 % at
 * R = 1024, 0.8 % at 2048, 0.3 % at 4096).  The shadow test's light is 2 m
 * up, which halves the pixels per patch: it uses 4096. */
#define LIGHT_R 2048u
#define LIGHT_R_FAR 4096u

/* ------------------------------------------------------------ building */

static rad_scene *new_scene(void)
{
    rad_scene *s = rad_scene_create(1, "lights-test");
    CHECK(s != NULL);
    return s;
}

/* An axis-aligned horizontal square [-h,h]² at height z facing up (+z),
 * n×n patches, as its own object. */
static void floor_square(rad_scene *s, const char *name, double h, double z, uint32_t n,
                         uint32_t mat)
{
    uint32_t o;
    rad_error e;
    CHECK(rad_scene_add_object(s, name, NULL, &o, &e) == RAD_OK);
    rad_vec3 p[4] = {{-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}};
    int rc = rad_scene_add_polygon(s, name, o, mat, p, 4, n, n, NULL, NULL, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
}

/* The box [lo, hi] with outward faces, one object. */
static void box(rad_scene *s, const char *name, rad_vec3 lo, rad_vec3 hi, uint32_t mat)
{
    uint32_t o;
    rad_error e;
    CHECK(rad_scene_add_object(s, name, NULL, &o, &e) == RAD_OK);
    double c[2][3] = {{lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z}};
    for (int axis = 0; axis < 3; axis++)
        for (int side = 0; side < 2; side++) {
            int a = (axis + 1) % 3, b = (axis + 2) % 3;
            double uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
            rad_vec3 p[4];
            for (int k = 0; k < 4; k++) {
                /* (a, b, axis) is right-handed: this order faces +axis; the
                 * low side is reversed to face -axis */
                int kk = side ? k : (4 - k) % 4;
                double q[3];
                q[axis] = c[side][axis];
                q[a] = c[(int)uv[kk][0]][a];
                q[b] = c[(int)uv[kk][1]][b];
                p[k] = rad_v3(q[0], q[1], q[2]);
            }
            char pn[64];
            snprintf(pn, sizeof pn, "%s/%d%d", name, axis, side);
            int rc = rad_scene_add_polygon(s, pn, o, mat, p, 4, 1, 1, NULL, NULL, &e);
            CHECK_MSG(rc == RAD_OK, "%s", e.message);
        }
}

static void light(rad_scene *s, const char *name, rad_light_kind kind, double I, rad_vec3 pos,
                  rad_vec3 dir, double inner, double outer)
{
    rad_error e;
    int rc = rad_scene_add_light(s, name, kind, &I, pos, dir, inner, outer, NULL, NULL, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
}

static rad_solution *solve(rad_scene *s, uint32_t light_resolution)
{
    rad_solve_options opt = {.refine_threshold = RAD_REFINE_OFF}; /* patches only */
    opt.light_resolution = light_resolution;
    rad_solution *sol = NULL;
    rad_error e = {0};
    int rc = rad_solve_scene(s, &opt, &sol, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    return rc ? NULL : sol;
}

static double *direct(const rad_solution *s)
{
    double *H = malloc(((size_t)s->mesh->patch_count * s->band_count + 1) * sizeof *H);
    CHECK(H && rad_solution_direct_irradiance(s, H, NULL) == RAD_OK);
    return H;
}

/* The x-y extent of patch j (horizontal patches). */
static void extent(const rad_solution *s, uint32_t j, double *x0, double *x1, double *y0,
                   double *y1)
{
    const rad_patch *p = &s->mesh->patches[j];
    *x0 = *y0 = INFINITY;
    *x1 = *y1 = -INFINITY;
    for (int k = 0; k < rad_patch_corners(p); k++) {
        rad_vec3 v = s->mesh->vertices[p->v[k]];
        *x0 = fmin(*x0, v.x), *x1 = fmax(*x1, v.x);
        *y0 = fmin(*y0, v.y), *y1 = fmax(*y1, v.y);
    }
}

/* ---------------------------------------------------- independent values */

/* glTF KHR_lights_punctual spot falloff for the angle whose cosine is cd. */
static double spot_falloff(double cd, double inner, double outer)
{
    double scale = 1.0 / fmax(0.001, cos(inner) - cos(outer));
    double t = (cd - cos(outer)) * scale;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t;
}

/* Mean over the horizontal rectangle [x0,x1]×[y0,y1] at z = 0 (facing up)
 * of the irradiance I f(θ_axis) cosθ / r² from a light at height h above
 * the origin pointing down (f = 1 for a point light): midpoint rule on a
 * 200×200 grid, whose error for these smooth integrands is ~1e-6, far
 * below the tolerances used. */
static double mean_irradiance(double x0, double x1, double y0, double y1, double h, double I,
                              int spot, double inner, double outer)
{
    const int N = 200;
    double sum = 0.0;
    for (int a = 0; a < N; a++)
        for (int b = 0; b < N; b++) {
            double x = x0 + (a + 0.5) * (x1 - x0) / N, y = y0 + (b + 0.5) * (y1 - y0) / N;
            double r2 = x * x + y * y + h * h, r = sqrt(r2);
            double cosang = h / r; /* both at the surface and against the axis */
            double f = spot ? spot_falloff(cosang, inner, outer) : 1.0;
            sum += I * f * cosang / r2;
        }
    return sum / (N * N);
}

/* ------------------------------------------------------------------ tests */

/* A 4×4 m floor at 20×20 patches, ρ = 0.5, a point light of I = 3 W/sr 1 m
 * above its centre.  H_d within 1 % of the analytic patch average at every
 * patch within 1.4 m of the centre (the pixel counting of a patch seen at
 * grazing angles further out is coarser); B = ρ H_d (the floor sees
 * nothing else: the solve adds nothing) to 1e-12 relative. */
TEST(point_light_above_floor)
{
    rad_scene *s = new_scene();
    uint32_t m = test_material(s, "grey", 0.5);
    floor_square(s, "floor", 2.0, 0.0, 20, m);
    light(s, "bulb", RAD_LIGHT_POINT, 3.0, rad_v3(0, 0, 1), rad_v3(0, 0, -1), 0, 0);
    CHECK(rad_scene_check(s, 1, NULL) == RAD_OK); /* a light alone is an emitter */
    rad_solution *sol = solve(s, LIGHT_R);
    if (!sol)
        return;
    double *H = direct(sol);
    double worst = 0.0, total = 0.0, exact_total = 0.0;
    int sampled = 0;
    for (uint32_t j = 0; j < sol->mesh->patch_count; j++) {
        double x0, x1, y0, y1;
        extent(sol, j, &x0, &x1, &y0, &y1);
        double want = mean_irradiance(x0, x1, y0, y1, 1.0, 3.0, 0, 0, 0);
        double A = sol->mesh->patches[j].area;
        total += H[j] * A;
        exact_total += want * A;
        CHECK_NEAR(sol->B[j], 0.5 * H[j], 1e-12 * H[j]);
        rad_vec3 c = sol->mesh->patches[j].center;
        if (hypot(c.x, c.y) > 1.4)
            continue;
        sampled++;
        worst = fmax(worst, fabs(H[j] / want - 1.0));
        CHECK_REL(H[j], want, 0.01);
    }
    printf("     point light: %d patches sampled, worst relative error %.2e\n", sampled, worst);
    CHECK(sampled >= 150);
    /* The whole floor receives I Ω(floor): solid angle of a 4×4 square seen
     * from 1 m above its centre is 4 asin(a²/(1+a²)) with a = 2 (half
     * width / height)... here from the patches' analytic sum; 0.5 %: the
     * far patches carry their coarser counts. */
    CHECK_REL(total, exact_total, 0.005);
    double omega = 4.0 * asin(4.0 / 5.0); /* 4 asin(a b / sqrt((1+a²)(1+b²))), a = b = 2 */
    CHECK_REL(exact_total, 3.0 * omega, 1e-4);
    rad_light_stats st;
    CHECK(rad_solution_light_stats(sol, &st, NULL) == RAD_OK);
    CHECK_REL(st.emitted[0], 4.0 * M_PI * 3.0, 1e-12);
    CHECK_REL(st.delivered[0], total, 1e-6); /* Σ I Φ_j = Σ H_j A_j */
    /* The absorbed power is the delivered power times (1 − ρ): nothing else
     * lights the floor. */
    rad_object_stats os;
    CHECK(rad_solution_object_stats(sol, &os, NULL) == RAD_OK);
    CHECK_REL(os.absorbed[0], 0.5 * total, 1e-9);
    free(H);
    rad_solution_destroy(sol);
}

/* The same floor (light at 2 m) and a black box [-0.35,0.35]²×[0.5,1]: its
 * top face's outline, projected from the light, is the umbra
 * [-0.7,0.7]².  Patches wholly inside [-0.6,0.6]² get H_d = 0 exactly;
 * patches wholly outside [-0.8,0.8]² (clear of the shadow by a pixel or
 * more) within 1 % of the unoccluded value. */
TEST(point_light_shadow_of_a_box)
{
    rad_scene *s = new_scene();
    uint32_t grey = test_material(s, "grey", 0.5), black = test_material(s, "black", 0.0);
    floor_square(s, "floor", 2.0, 0.0, 20, grey);
    box(s, "box", rad_v3(-0.35, -0.35, 0.5), rad_v3(0.35, 0.35, 1.0), black);
    light(s, "bulb", RAD_LIGHT_POINT, 1.0, rad_v3(0, 0, 2), rad_v3(0, 0, -1), 0, 0);
    rad_solution *sol = solve(s, LIGHT_R_FAR);
    if (!sol)
        return;
    double *H = direct(sol);
    int umbra = 0, lit = 0;
    for (uint32_t j = 0; j < sol->mesh->patch_count; j++) {
        if (sol->mesh->patches[j].object != 0)
            continue;
        double x0, x1, y0, y1;
        extent(sol, j, &x0, &x1, &y0, &y1);
        if (x0 >= -0.6 - 1e-9 && x1 <= 0.6 + 1e-9 && y0 >= -0.6 - 1e-9 && y1 <= 0.6 + 1e-9) {
            umbra++;
            CHECK(H[j] == 0.0);
            CHECK(sol->B[j] == 0.0);
        } else if (x0 >= 0.8 - 1e-9 || x1 <= -0.8 + 1e-9 || y0 >= 0.8 - 1e-9 ||
                   y1 <= -0.8 + 1e-9) {
            rad_vec3 c = sol->mesh->patches[j].center;
            if (hypot(c.x, c.y) > 1.5)
                continue; /* grazing: see point_light_above_floor */
            lit++;
            CHECK_REL(H[j], mean_irradiance(x0, x1, y0, y1, 2.0, 1.0, 0, 0, 0), 0.01);
        }
    }
    CHECK(umbra == 36);
    CHECK(lit > 20);
    /* The box's top face faces the light: it receives I × its solid angle
     * (0.7 × 0.7 m at 1 m: 4 asin(ab/√((1+a²)(1+b²))), a = b = 0.35). */
    double top = 0.0;
    for (uint32_t j = 0; j < sol->mesh->patch_count; j++)
        if (sol->mesh->patches[j].object == 1 && sol->mesh->patches[j].normal.z > 0.5)
            top += H[j] * sol->mesh->patches[j].area;
    CHECK_REL(top, 4.0 * asin(0.35 * 0.35 / (1 + 0.35 * 0.35)), 0.01);
    free(H);
    rad_solution_destroy(sol);
}

/* The spot scenes: a grey floor (half-width h, n × n patches) and a spot of
 * I = 2 W/sr 1 m above its centre pointing down, inner 30°, outer 50°. */
#define SPOT_INNER (30.0 * M_PI / 180.0)
#define SPOT_OUTER (50.0 * M_PI / 180.0)
static rad_scene *spot_scene(double h, uint32_t n)
{
    rad_scene *s = new_scene();
    uint32_t m = test_material(s, "grey", 0.5);
    floor_square(s, "floor", h, 0.0, n, m);
    light(s, "spot", RAD_LIGHT_SPOT, 2.0, rad_v3(0, 0, 1), rad_v3(0, 0, -1), SPOT_INNER, SPOT_OUTER);
    return s;
}

/* A spot 1 m above the floor pointing down, inner 30°, outer 50°: patches
 * wholly inside the inner cone (r < tan 30°) within 1 % of a point light;
 * wholly outside the outer cone (r > tan 50°) exactly 0; the patches the
 * falloff crosses within 5 % of the quadrature of I t² cosθ / r². */
TEST(spot_light_cone)
{
    const double inner = SPOT_INNER, outer = SPOT_OUTER;
    rad_solution *sol = solve(spot_scene(2.0, 20), LIGHT_R);
    if (!sol)
        return;
    double *H = direct(sol);
    int in = 0, out = 0, edge = 0;
    double worst_edge = 0.0;
    for (uint32_t j = 0; j < sol->mesh->patch_count; j++) {
        double x0, x1, y0, y1;
        extent(sol, j, &x0, &x1, &y0, &y1);
        /* nearest and farthest distance of the patch from the axis */
        double nx = x0 > 0 ? x0 : x1 < 0 ? -x1 : 0, ny = y0 > 0 ? y0 : y1 < 0 ? -y1 : 0;
        double fx = fmax(fabs(x0), fabs(x1)), fy = fmax(fabs(y0), fabs(y1));
        double rmin = hypot(nx, ny), rmax = hypot(fx, fy);
        if (rmax < tan(inner)) {
            in++;
            CHECK_REL(H[j], mean_irradiance(x0, x1, y0, y1, 1.0, 2.0, 0, 0, 0), 0.01);
        } else if (rmin > tan(outer)) {
            out++;
            CHECK(H[j] == 0.0);
        } else {
            double want = mean_irradiance(x0, x1, y0, y1, 1.0, 2.0, 1, inner, outer);
            if (want < 0.02 * 2.0)
                continue; /* a sliver of the falloff's tail: relative error is meaningless */
            edge++;
            worst_edge = fmax(worst_edge, fabs(H[j] / want - 1.0));
            CHECK_REL(H[j], want, 0.05);
        }
    }
    printf("     spot: %d inside, %d outside, %d in the falloff (worst %.2e)\n", in, out, edge,
           worst_edge);
    CHECK(in >= 4 && out > 100 && edge > 8);
    rad_light_stats st;
    CHECK(rad_solution_light_stats(sol, &st, NULL) == RAD_OK);
    /* 2π I [(1 − cos i) + (cos i − cos o)/3]: the closed form of the cone's
     * falloff integral; the floor (to 63° off axis) catches the whole cone */
    double emitted = 2 * M_PI * 2.0 * ((1 - cos(inner)) + (cos(inner) - cos(outer)) / 3);
    CHECK_REL(st.emitted[0], emitted, 1e-12);
    CHECK_REL(st.delivered[0], emitted, 0.01);
    free(H);
    rad_solution_destroy(sol);
}

/* A directional light straight down, E⊥ = 2 W/m², on a 1×1 m plane tilted
 * 30° about x: H = E⊥ cos 30° on every patch.  The plane's total within
 * 1e-3 (pixel counting errors cancel along shared edges, leaving the
 * outline's); each patch within 1 %. */
TEST(directional_light_tilted_plane)
{
    const double a = 30.0 * M_PI / 180.0;
    rad_scene *s = new_scene();
    uint32_t m = test_material(s, "grey", 0.5), o;
    CHECK(rad_scene_add_object(s, "plane", NULL, &o, NULL) == RAD_OK);
    rad_vec3 p[4] = {{-0.5, -0.5 * cos(a), -0.5 * sin(a)},
                     {0.5, -0.5 * cos(a), -0.5 * sin(a)},
                     {0.5, 0.5 * cos(a), 0.5 * sin(a)},
                     {-0.5, 0.5 * cos(a), 0.5 * sin(a)}};
    rad_error e;
    CHECK_MSG(rad_scene_add_polygon(s, "plane", o, m, p, 4, 4, 4, NULL, NULL, &e) == RAD_OK, "%s",
              e.message);
    light(s, "sun", RAD_LIGHT_DIRECTIONAL, 2.0, rad_v3(0, 0, 0), rad_v3(0, 0, -1), 0, 0);
    rad_solution *sol = solve(s, LIGHT_R);
    if (!sol)
        return;
    double *H = direct(sol);
    double sum = 0.0, area = 0.0, worst = 0.0;
    for (uint32_t j = 0; j < sol->mesh->patch_count; j++) {
        sum += H[j] * sol->mesh->patches[j].area;
        area += sol->mesh->patches[j].area;
        worst = fmax(worst, fabs(H[j] / (2.0 * cos(a)) - 1.0));
        CHECK_REL(H[j], 2.0 * cos(a), 0.01);
    }
    printf("     directional: plane mean error %.2e, worst patch %.2e\n",
           sum / area / (2.0 * cos(a)) - 1.0, worst);
    CHECK_REL(sum / area, 2.0 * cos(a), 1e-3);
    rad_light_stats st;
    CHECK(rad_solution_light_stats(sol, &st, NULL) == RAD_OK);
    CHECK_REL(st.emitted[0], st.delivered[0], 1e-12); /* stated: delivered, for directional */
    CHECK_REL(st.delivered[0], sum, 1e-6);
    free(H);
    rad_solution_destroy(sol);
}

/* A directional light along (0.5, 0, −1) and a 0.6×0.6 m black square at
 * z = 0.5 above a 2×2 m floor (10×10 patches): the shadow is the square
 * moved by 0.25 in x, [−0.05, 0.55]×[−0.3, 0.3].  The four patches wholly
 * inside it are dark; patches clear of it by a patch get E⊥ cosθ within 1 %. */
TEST(directional_light_shadow)
{
    rad_scene *s = new_scene();
    uint32_t grey = test_material(s, "grey", 0.5), black = test_material(s, "black", 0.0);
    floor_square(s, "floor", 1.0, 0.0, 10, grey);
    floor_square(s, "blocker", 0.3, 0.5, 1, black);
    rad_vec3 d = rad_normalize(rad_v3(0.5, 0, -1));
    light(s, "sun", RAD_LIGHT_DIRECTIONAL, 1.0, rad_v3(0, 0, 0), d, 0, 0);
    rad_solution *sol = solve(s, LIGHT_R);
    if (!sol)
        return;
    double *H = direct(sol);
    int dark = 0, lit = 0;
    for (uint32_t j = 0; j < sol->mesh->patch_count; j++) {
        if (sol->mesh->patches[j].object != 0)
            continue;
        double x0, x1, y0, y1;
        extent(sol, j, &x0, &x1, &y0, &y1);
        if (x0 >= -0.05 && x1 <= 0.55 && y0 >= -0.3 && y1 <= 0.3) {
            dark++;
            CHECK(H[j] == 0.0);
        } else if (x1 <= -0.2 || x0 >= 0.7 || y1 <= -0.45 || y0 >= 0.45) {
            lit++;
            CHECK_REL(H[j], -d.z, 0.01);
        }
    }
    CHECK(dark == 4);
    CHECK(lit > 60);
    free(H);
    rad_solution_destroy(sol);
}

/* --------------------------------------------------------------- relight */

/* A lone floor lit only by a point light: "off" gives B = 0; 2 doubles B;
 * "on" restores it; none of these renders a light or computes a row.  The
 * solution survives a file round trip bit for bit, lights included. */
TEST(relight_punctual_light)
{
    rad_scene *s = new_scene();
    uint32_t m = test_material(s, "grey", 0.5);
    floor_square(s, "floor", 1.0, 0.0, 6, m);
    light(s, "bulb", RAD_LIGHT_POINT, 1.0, rad_v3(0.2, 0.1, 0.8), rad_v3(0, 0, -1), 0, 0);
    rad_solution *sol = solve(s, 0) /* the default resolution */;
    if (!sol)
        return;
    CHECK(sol->lights_computed == 1);
    uint32_t n = sol->mesh->patch_count;
    double *B0 = malloc(n * sizeof *B0);
    memcpy(B0, sol->B, n * sizeof *B0);

    char dir[] = "/tmp/test_lights_XXXXXX", path[300];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(path, sizeof path, "%s/floor.sol", dir);
    rad_error e;
    CHECK_MSG(rad_solution_write(sol, path, &e) == RAD_OK, "%s", e.message);
    rad_solution *r = NULL;
    CHECK_MSG(rad_solution_read(path, &r, &e) == RAD_OK, "%s", e.message);
    if (!r) {
        free(B0);
        rad_solution_destroy(sol);
        return;
    }
    /* lights bit-exact */
    CHECK(r->scene->light_count == 1);
    const rad_light *a = &sol->scene->lights[0], *b = &r->scene->lights[0];
    CHECK(strcmp(a->name, b->name) == 0 && a->kind == b->kind);
    CHECK(memcmp(&a->position, &b->position, sizeof a->position) == 0);
    CHECK(memcmp(&a->direction, &b->direction, sizeof a->direction) == 0);
    CHECK(memcmp(a->intensity, b->intensity, sizeof(double)) == 0);
    const rad_light_power *pa = &sol->light_power[0], *pb = &r->light_power[0];
    CHECK(pb->present && pa->count == pb->count && pa->count > 0);
    CHECK(pa->count == pb->count && memcmp(pa->patch, pb->patch, pa->count * 4) == 0 &&
          memcmp(pa->power, pb->power, pa->count * 4) == 0);
    CHECK(memcmp(r->B, sol->B, n * sizeof *B0) == 0);
    CHECK(r->lights_computed == 1);

    const char *args[3] = {"bulb=off", "bulb=2", "bulb=on"};
    const double factor[3] = {0.0, 2.0, 1.0};
    for (int k = 0; k < 3; k++) {
        rad_edit ed;
        CHECK(rad_edit_parse(RAD_EDIT_LIGHT, args[k], &ed, NULL) == RAD_OK);
        CHECK_MSG(rad_solution_apply_edits(r, &ed, 1, &e) == RAD_OK, "%s", e.message);
        CHECK(r->light_intensity[0] == factor[k]);
        rad_solve_options opt = {0};
        CHECK_MSG(rad_resolve(r, &opt, &e) == RAD_OK, "%s", e.message);
        CHECK(r->rows_computed == 0);
        CHECK(r->lights_computed == 0);
        /* linear in the source: 1e-9 covers the solver's rounding */
        for (uint32_t j = 0; j < n; j++)
            CHECK_NEAR(r->B[j], factor[k] * B0[j], 1e-9 * B0[j] + 1e-300);
    }
    /* a light is reached by name before materials; reflectance is refused */
    rad_edit bad;
    CHECK(rad_edit_parse(RAD_EDIT_REFLECTANCE, "bulb=0.3", &bad, NULL) == RAD_OK);
    CHECK(rad_solution_apply_edits(r, &bad, 1, &e) == RAD_ERR_USAGE);
    CHECK(strstr(e.message, "punctual light") != NULL);
    rad_edit em;
    CHECK(rad_edit_parse(RAD_EDIT_EMISSION, "bulb=0.25", &em, NULL) == RAD_OK);
    CHECK(rad_solution_apply_edits(r, &em, 1, &e) == RAD_OK && r->light_intensity[0] == 0.25);
    /* an unknown name lists the light among the candidates */
    rad_edit unk;
    CHECK(rad_edit_parse(RAD_EDIT_LIGHT, "nothing=off", &unk, NULL) == RAD_OK);
    CHECK(rad_solution_apply_edits(r, &unk, 1, &e) == RAD_ERR_NOTFOUND);
    CHECK(strstr(e.message, "light 'bulb'") != NULL);

    unlink(path);
    rmdir(dir);
    free(B0);
    rad_solution_destroy(r);
    rad_solution_destroy(sol);
}

/* -------------------------------------------------------------- elements */

/* Light resolution of the element tests: a pixel of a 1024 face seen from
 * 2 m covers 4 mm of floor below the light, so every shadow edge is placed
 * to within EDGE_EPS (2.5 pixels), a fifth of the 5 cm elements and a
 * twentieth of the 20 cm patches. */
#define ELEM_LIGHT_R 1024u
#define EDGE_EPS 0.01

/* Relative tolerance of an element's H_d,e where no shadow edge crosses
 * it: there the visibility is exactly 1 and h_le is the closed-form mean of
 * I cosθ / r² stored as a float, so its rounding and the reference's
 * quadrature error are left (2^-24 = 6e-8; measured: at most 8.4e-8 in the
 * tests below).  Four roundings' worth:
 * an element's direct light off by 0.5 % fails by a factor of 20,000. */
#define ELEM_H_TOL 2.5e-7

static rad_solution *solve_elements(rad_scene *s, uint32_t levels, double threshold,
                                    double min_size)
{
    rad_solve_options opt = {0};
    opt.light_resolution = ELEM_LIGHT_R;
    opt.hemicube.resolution = 64; /* the element rows do not matter here: black or no surroundings */
    opt.element_levels = levels;
    opt.refine_threshold = threshold;
    opt.min_element_size = min_size;
    rad_solution *sol = NULL;
    rad_error e = {0};
    int rc = rad_solve_scene(s, &opt, &sol, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    CHECK(rc != RAD_OK || sol->elements != NULL);
    if (rc == RAD_OK && !sol->elements) {
        rad_solution_destroy(sol);
        return NULL;
    }
    return rc ? NULL : sol;
}

static double *element_direct(const rad_solution *s)
{
    const rad_elements *el = s->elements;
    double *H = malloc(((size_t)el->mesh->patch_count * s->band_count + 1) * sizeof *H);
    CHECK(H && rad_elements_direct_irradiance(s, el, H, NULL) == RAD_OK);
    return H;
}

/* I cosθ / r² (× the spot falloff) at floor point c from a light at height
 * h above the origin pointing down. */
static double point_value(rad_vec3 c, double h, double I, int spot, double inner, double outer)
{
    double r2 = c.x * c.x + c.y * c.y + h * h, cosang = h / sqrt(r2);
    return I * (spot ? spot_falloff(cosang, inner, outer) : 1.0) * cosang / r2;
}

/* Signed distance of (x, y) outside the rectangle [x0,x1]×[y0,y1]
 * (negative inside: the depth). */
static double outside_rect(double x, double y, double x0, double x1, double y0, double y1)
{
    double dx = fmax(x0 - x, x - x1), dy = fmax(y0 - y, y - y1);
    if (dx <= 0 && dy <= 0)
        return fmax(dx, dy);
    return hypot(fmax(dx, 0), fmax(dy, 0));
}

/* Element e's extent (horizontal, axis-aligned elements). */
static void el_extent(const rad_elements *el, uint32_t e, double *x0, double *x1, double *y0,
                      double *y1)
{
    const rad_patch *p = &el->mesh->patches[e];
    *x0 = *y0 = INFINITY;
    *x1 = *y1 = -INFINITY;
    for (int k = 0; k < rad_patch_corners(p); k++) {
        rad_vec3 v = el->mesh->vertices[p->v[k]];
        *x0 = fmin(*x0, v.x), *x1 = fmax(*x1, v.x);
        *y0 = fmin(*y0, v.y), *y1 = fmax(*y1, v.y);
    }
}

/* Mean over [x0,x1]×[y0,y1] at z = 0 (facing up) of I f cosθ / r² from a
 * light at pos, a spot (f: glTF's falloff about unit axis ax) or a point
 * (f = 1): the midpoint rule on an N×N grid, independent of the engine's
 * solid-angle closed form.  Its error on these smooth integrands falls as
 * 1/N² (N = 100 on a 5 cm element: ~1e-8 relative). */
static double mean_from(double x0, double x1, double y0, double y1, rad_vec3 pos, rad_vec3 ax,
                        double I, int spot, double inner, double outer, int N)
{
    double sum = 0.0;
    for (int a = 0; a < N; a++)
        for (int b = 0; b < N; b++) {
            double x = x0 + (a + 0.5) * (x1 - x0) / N, y = y0 + (b + 0.5) * (y1 - y0) / N;
            rad_vec3 r = rad_v3(x - pos.x, y - pos.y, -pos.z);
            double r2 = rad_dot(r, r), len = sqrt(r2);
            double f = spot ? spot_falloff(rad_dot(r, ax) / len, inner, outer) : 1.0;
            sum += I * f * (pos.z / len) / r2;
        }
    return sum / ((double)N * N);
}

/* mean_from for element e of a light at height h above the origin
 * pointing down. */
static double element_mean(const rad_elements *el, uint32_t e, double h, double I, int spot,
                           double inner, double outer)
{
    double x0, x1, y0, y1;
    el_extent(el, e, &x0, &x1, &y0, &y1);
    return mean_from(x0, x1, y0, y1, rad_v3(0, 0, h), rad_v3(0, 0, -1), I, spot, inner, outer, 100);
}

/* A 2×2 m floor at 10×10 patches split twice (elements 5 cm), a point light
 * of 3 W/sr 1 m above its centre: every element's H_d,e within ELEM_H_TOL
 * of the element's mean of I cosθ / r² (element_mean; the floor is
 * unoccluded and the visibility exactly 1; measured 8.4e-8), and B_e = ρ
 * H_d,e.  (Issue 39: the value at the centre, used before, was up to
 * 6.2e-4 off the mean here.) */
TEST(elements_point_light_irradiance)
{
    rad_scene *s = new_scene();
    uint32_t m = test_material(s, "grey", 0.5);
    floor_square(s, "floor", 1.0, 0.0, 10, m);
    light(s, "bulb", RAD_LIGHT_POINT, 3.0, rad_v3(0, 0, 1), rad_v3(0, 0, -1), 0, 0);
    rad_solution *sol = solve_elements(s, 2, 0.0, 0.0);
    if (!sol)
        return;
    const rad_elements *el = sol->elements;
    double *H = element_direct(sol);
    double worst = 0.0;
    uint32_t lit = 0;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        CHECK(el->level[e] == 2);
        double want = element_mean(el, e, 1.0, 3.0, 0, 0, 0);
        worst = fmax(worst, fabs(H[e] / want - 1.0));
        CHECK_NEAR(el->B[e], 0.5 * H[e], 1e-12 * H[e]);
        lit += H[e] > 0.0;
    }
    printf("     %u elements lit, worst |H_d,e / mean(I cos/r²) - 1| = %.2e\n", lit, worst);
    CHECK_MSG(worst <= ELEM_H_TOL, "worst relative error of H_d,e %.3g", worst);
    CHECK(lit == 1600);
    free(H);
    rad_solution_destroy(sol);
}

/* A 2.8×2.8 m floor (14×14 patches of 20 cm), a black box of half side
 * 0.33 from 0.5 to 1 m high, a 1 W/sr point light 2 m above the origin. */
static rad_scene *box_shadow_scene(void)
{
    rad_scene *s = new_scene();
    uint32_t grey = test_material(s, "grey", 0.5), black = test_material(s, "black", 0.0);
    floor_square(s, "floor", 1.4, 0.0, 14, grey);
    box(s, "box", rad_v3(-0.33, -0.33, 0.5), rad_v3(0.33, 0.33, 1.0), black);
    light(s, "bulb", RAD_LIGHT_POINT, 1.0, rad_v3(0, 0, 2), rad_v3(0, 0, -1), 0, 0);
    return s;
}

/* Where element e's rectangle lies against the rectangle [x0,x1]×[y0,y1]
 * widened by m on every side: 1 wholly outside, -1 wholly inside the
 * rectangle narrowed by m, 0 across its outline. */
static int element_side(const rad_elements *el, uint32_t e, double x0, double x1, double y0,
                        double y1, double m)
{
    double a0, a1, b0, b1;
    el_extent(el, e, &a0, &a1, &b0, &b1);
    if (a0 >= x1 + m || a1 <= x0 - m || b0 >= y1 + m || b1 <= y0 - m)
        return 1;
    if (a0 >= x0 + m && a1 <= x1 - m && b0 >= y0 + m && b1 <= y1 - m)
        return -1;
    return 0;
}

/* The box of point_light_shadow_of_a_box moved off the element grid: half
 * side 0.33, top at 1 m, light 2 m above the origin: the umbra is
 * [-0.66, 0.66]², mid-element and mid-patch.  Elements (5 cm, two splits of
 * 20 cm patches) wholly inside it by ELEM_MARGIN get exactly 0, those wholly
 * outside the mean of I cosθ / r² over them within ELEM_H_TOL (measured
 * 6.3e-8); the 108 the outline crosses ([0.65, 0.70] and its mirrors: 80 %
 * or 20 % of them lit) their lit part's mean within 0.08 of the element's
 * unoccluded mean (their visibility from 4×4 points of the element, a
 * step of 1/4 of its side smoothed over a pixel; measured 0.050; the
 * centre alone, used before, gave 1 or 0: off by 0.2). */
#define ELEM_MARGIN 0.005
TEST(elements_point_light_shadow_edge)
{
    rad_scene *s = box_shadow_scene();
    rad_solution *sol = solve_elements(s, 2, 0.0, 0.0);
    if (!sol)
        return;
    const rad_elements *el = sol->elements;
    double *H = element_direct(sol), *Hp = direct(sol);
    uint32_t dark = 0, lit = 0, between = 0, straddling_patches = 0;
    double worst = 0.0, worst_between = 0.0;
    uint8_t *mixed = calloc(sol->mesh->patch_count, 1); /* bit 0: a dark element, bit 1: a lit one */
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        if (el->mesh->patches[e].object != 0)
            continue;
        const int side = element_side(el, e, -0.66, 0.66, -0.66, 0.66, ELEM_MARGIN);
        const double full = element_mean(el, e, 2.0, 1.0, 0, 0, 0);
        if (side < 0) {
            dark++;
            CHECK(H[e] == 0.0);
            CHECK(el->B[e] == 0.0);
            mixed[el->patch[e]] |= 1;
        } else if (side > 0) {
            lit++;
            worst = fmax(worst, fabs(H[e] / full - 1.0));
            mixed[el->patch[e]] |= 2;
        } else {
            between++;
            double a0, a1, b0, b1, sum = 0.0;
            el_extent(el, e, &a0, &a1, &b0, &b1);
            const int N = 100; /* the lit part's mean, the umbra cut out */
            for (int i = 0; i < N; i++)
                for (int k = 0; k < N; k++) {
                    double x = a0 + (i + 0.5) * (a1 - a0) / N, y = b0 + (k + 0.5) * (b1 - b0) / N;
                    if (outside_rect(x, y, -0.66, 0.66, -0.66, 0.66) > 0)
                        sum += mean_from(x, x, y, y, rad_v3(0, 0, 2), rad_v3(0, 0, -1), 1.0, 0, 0, 0, 1);
                }
            worst_between = fmax(worst_between, fabs(H[e] - sum / (N * N)) / full);
        }
    }
    for (uint32_t j = 0; j < sol->mesh->patch_count; j++)
        if (mixed[j] == 3) {
            straddling_patches++;
            /* the patch's own average is neither: what elements fix */
            CHECK(Hp[j] > 0.0 && Hp[j] < 0.9 * point_value(sol->mesh->patches[j].center, 2.0, 1.0, 0, 0, 0));
        }
    printf("     %u dark, %u lit (worst %.2e), %u across the edge (worst %.3f of the unoccluded "
           "mean); %u patches hold both\n", dark, lit, worst, between, worst_between, straddling_patches);
    CHECK_MSG(worst <= ELEM_H_TOL, "worst relative error of H_d,e %.3g", worst);
    CHECK_MSG(worst_between <= 0.08, "worst error across the edge %.3g", worst_between);
    /* umbra: 26 elements per side; the outline crosses the ring around them */
    CHECK(dark == 26 * 26);
    CHECK(between == 28 * 28 - 26 * 26);
    CHECK(straddling_patches == 4 * 6 + 4);
    free(mixed);
    free(H);
    free(Hp);
    rad_solution_destroy(sol);
}

/* A spot 1 m above a 3.2×3.2 m floor pointing down, inner 30°, outer 50°:
 * every element gets the mean over it of I t² cosθ / r² (element_mean):
 * exactly 0 wholly outside the outer cone, within ELEM_SPOT_TOL of the mean
 * (of a tenth of the peak I/h² where the mean is less) elsewhere (the
 * falloff integrated adaptively, as for patches: measured 1.1e-4), or within 1e-7 of I/h² absolute in the falloff's last 1e-4
 * (measured 3e-9).  (The falloff at the centre, used before, was up to
 * 1.9 times the mean of an element the outer cone crosses.) */
#define ELEM_SPOT_TOL 3e-4
TEST(elements_spot_cone_edge)
{
    const double inner = SPOT_INNER, outer = SPOT_OUTER;
    rad_solution *sol = solve_elements(spot_scene(1.6, 16), 2, 0.0, 0.0);
    if (!sol)
        return;
    const rad_elements *el = sol->elements;
    double *H = element_direct(sol);
    uint32_t in = 0, out = 0, falloff = 0, tail = 0;
    double worst = 0.0;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        rad_vec3 c = el->mesh->patches[e].center;
        double want = element_mean(el, e, 1.0, 2.0, 1, inner, outer);
        if (want == 0.0) {
            out++;
            CHECK(H[e] == 0.0);
        } else if (want < 1e-4 * 2.0) {
            tail++;
            CHECK_MSG(fabs(H[e] - want) <= 1e-7 * 2.0, "element %u: %.6g, want %.6g", e, H[e], want);
        } else {
            in++;
            falloff += hypot(c.x, c.y) > tan(inner);
            /* relative where the mean is a tenth of the peak I/h² or more,
             * else against a tenth of the peak (the adaptive integral's
             * tolerance is absolute) */
            worst = fmax(worst, fabs(H[e] - want) / fmax(want, 0.1 * 2.0));
        }
    }
    printf("     spot: %u elements inside the cone (%u in the falloff, worst %.2e), %u in its tail, "
           "%u outside\n", in, falloff, worst, tail, out);
    CHECK_MSG(worst <= ELEM_SPOT_TOL, "worst relative error of H_d,e %.3g", worst);
    CHECK(in > 1500 && falloff > 800 && out > 2000);
    free(H);
    rad_solution_destroy(sol);
}

/* A directional light along (0.5, 0, −1) and a 0.6×0.6 m black square at
 * z = 0.5 centred over (0.02, 0.013): its shadow on the 2×2 m floor is
 * [−0.03, 0.57]×[−0.287, 0.313], off the element grid.  Elements wholly
 * inside by ELEM_MARGIN are dark, wholly outside get E⊥ cosθ within
 * ELEM_H_TOL (measured 1.2e-8). */
TEST(elements_directional_shadow_edge)
{
    rad_scene *s = new_scene();
    uint32_t grey = test_material(s, "grey", 0.5), black = test_material(s, "black", 0.0), o;
    floor_square(s, "floor", 1.0, 0.0, 10, grey);
    CHECK(rad_scene_add_object(s, "blocker", NULL, &o, NULL) == RAD_OK);
    const double bx = 0.02, by = 0.013;
    rad_vec3 p[4] = {{bx - 0.3, by - 0.3, 0.5}, {bx + 0.3, by - 0.3, 0.5},
                     {bx + 0.3, by + 0.3, 0.5}, {bx - 0.3, by + 0.3, 0.5}};
    CHECK(rad_scene_add_polygon(s, "blocker", o, black, p, 4, 1, 1, NULL, NULL, NULL) == RAD_OK);
    rad_vec3 d = rad_normalize(rad_v3(0.5, 0, -1));
    light(s, "sun", RAD_LIGHT_DIRECTIONAL, 1.0, rad_v3(0, 0, 0), d, 0, 0);
    rad_solution *sol = solve_elements(s, 2, 0.0, 0.0);
    if (!sol)
        return;
    const rad_elements *el = sol->elements;
    double *H = element_direct(sol);
    uint32_t dark = 0, lit = 0;
    double worst = 0.0;
    const double x0 = bx - 0.3 + 0.25, x1 = bx + 0.3 + 0.25, y0 = by - 0.3, y1 = by + 0.3;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        if (el->mesh->patches[e].object != 0)
            continue;
        const int side = element_side(el, e, x0, x1, y0, y1, ELEM_MARGIN);
        if (side < 0) {
            dark++;
            CHECK(H[e] == 0.0);
        } else if (side > 0) {
            lit++;
            worst = fmax(worst, fabs(H[e] / -d.z - 1.0));
        }
    }
    printf("     directional: %u dark, %u lit elements (worst %.2e)\n", dark, lit, worst);
    CHECK_MSG(worst <= ELEM_H_TOL, "worst relative error of H_d,e %.3g", worst);
    /* elements wholly inside by ELEM_MARGIN: 11 columns in x (0 .. 0.55),
     * 11 rows in y (−0.25 .. 0.3) */
    CHECK(dark == 11 * 11);
    CHECK(lit > 1400);
    free(H);
    rad_solution_destroy(sol);
}

/* Adaptive refinement sees the shadow edge through the elements' own
 * direct light: the point-light box shadow above, threshold 0.002 (both
 * 0.001 and 0.003 give the same leaves here), no uniform
 * levels, elements down to 2.5 cm (three splits).  Every leaf that straddles
 * the umbra's outline (corners on both sides) reached the floor size, every
 * leaf of level > 0 wholly on one side of the edge carries its mean of
 * I cosθ / r² or 0 (within ELEM_H_TOL), and leaves far from the edge in the umbra
 * stay coarse. */
TEST(elements_refinement_follows_light_edge)
{
    rad_scene *s = box_shadow_scene();
    rad_solution *sol = solve_elements(s, 0, 0.002, 0.025);
    if (!sol)
        return;
    const rad_elements *el = sol->elements;
    double *H = element_direct(sol);
    uint32_t straddle = 0, fine = 0, coarse_umbra = 0, checked = 0;
    double worst = 0.0;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        const rad_patch *c = &el->mesh->patches[e];
        if (c->object != 0)
            continue;
        int in = 0, outc = 0;
        for (int k = 0; k < rad_patch_corners(c); k++) {
            rad_vec3 v = el->mesh->vertices[c->v[k]];
            double dd = outside_rect(v.x, v.y, -0.66, 0.66, -0.66, 0.66);
            in += dd < 0;
            outc += dd > 0;
        }
        if (in && outc) {
            straddle++;
            fine += el->level[e] == 3;
            CHECK(el->level[e] == 3);
        }
        double dc = outside_rect(c->center.x, c->center.y, -0.66, 0.66, -0.66, 0.66);
        const int side = element_side(el, e, -0.66, 0.66, -0.66, 0.66, ELEM_MARGIN);
        if (el->level[e] > 0 && side != 0) {
            checked++;
            if (side < 0)
                CHECK(H[e] == 0.0);
            else
                worst = fmax(worst, fabs(H[e] / element_mean(el, e, 2.0, 1.0, 0, 0, 0) - 1.0));
        }
        if (dc < -0.2)
            coarse_umbra += el->level[e] == 0;
    }
    printf("     %u elements: %u straddle the umbra's outline (%u at level 3), %u deep-umbra "
           "leaves unsplit, %u split leaves checked (worst %.2e)\n",
           el->mesh->patch_count, straddle, fine, coarse_umbra, checked, worst);
    CHECK_MSG(worst <= ELEM_H_TOL, "worst relative error of H_d,e %.3g", worst);
    CHECK(straddle > 0 && fine == straddle && coarse_umbra >= 4 && checked > 100);
    free(H);
    rad_solution_destroy(sol);
}

/* Relight ×2 of a light doubles every element's direct term exactly and
 * renders nothing; a solution with element light data round-trips through
 * the file bit for bit (version 4) and relights there identically. */
TEST(elements_relight_and_round_trip)
{
    rad_scene *s = new_scene();
    uint32_t grey = test_material(s, "grey", 0.5), black = test_material(s, "black", 0.0);
    floor_square(s, "floor", 1.0, 0.0, 6, grey);
    box(s, "box", rad_v3(-0.2, -0.2, 0.3), rad_v3(0.2, 0.2, 0.5), black);
    light(s, "bulb", RAD_LIGHT_POINT, 1.0, rad_v3(0.2, 0.1, 1.5), rad_v3(0, 0, -1), 0, 0);
    light(s, "sun", RAD_LIGHT_DIRECTIONAL, 0.5, rad_v3(0, 0, 0), rad_v3(0.3, 0.2, -1), 0, 0);
    rad_solution *sol = solve_elements(s, 1, 0.0, 0.0);
    if (!sol)
        return;
    const rad_elements *el = sol->elements;
    const uint32_t ne = el->mesh->patch_count;
    CHECK(el->light_h != NULL && el->light_count == 2);
    CHECK(sol->lights_computed >= 4); /* 2 patch-power renders + 2 element visibility passes */
    double *H0 = element_direct(sol);

    char dir[] = "/tmp/test_lights_XXXXXX", path[300];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(path, sizeof path, "%s/elements.sol", dir);
    rad_error e;
    CHECK_MSG(rad_solution_write(sol, path, &e) == RAD_OK, "%s", e.message);
    FILE *f = fopen(path, "rb");
    unsigned char head[12] = {0};
    CHECK(f && fread(head, 1, 12, f) == 12);
    if (f)
        fclose(f);
    /* format version 8; its INFO announces LIGHTS, ELEMENTS and ELEMENTLIGHTS
     * (elements with their own direct light), which the read below needs */
    CHECK(head[8] == 8 && head[9] == 0);
    rad_solution *r = NULL;
    CHECK_MSG(rad_solution_read(path, &r, &e) == RAD_OK, "%s", e.message);
    if (r) {
        const rad_elements *y = r->elements;
        CHECK(y && y->light_count == 2 && y->mesh->patch_count == ne);
        if (y && y->light_h && y->mesh->patch_count == ne) {
            CHECK(memcmp(y->light_h, el->light_h, (size_t)ne * 2 * sizeof *y->light_h) == 0);
            CHECK(memcmp(y->B, el->B, (size_t)ne * sizeof *y->B) == 0);
        }
    }
    /* relight both copies: bulb ×2 */
    rad_solution *both[2] = {sol, r};
    double *H1[2] = {NULL, NULL};
    for (int k = 0; k < 2 && r; k++) {
        rad_edit ed;
        CHECK(rad_edit_parse(RAD_EDIT_LIGHT, "bulb=2", &ed, NULL) == RAD_OK);
        CHECK_MSG(rad_solution_apply_edits(both[k], &ed, 1, &e) == RAD_OK, "%s", e.message);
        rad_solve_options opt = {0};
        CHECK_MSG(rad_resolve(both[k], &opt, &e) == RAD_OK, "%s", e.message);
        CHECK(both[k]->rows_computed == 0 && both[k]->lights_computed == 0);
        CHECK(both[k]->elements->rows_computed == 0);
        H1[k] = element_direct(both[k]);
    }
    /* the sun alone, from the stored h: H_d,e(bulb ×2) = H0 + I_bulb Σ h_bulb */
    uint32_t doubled = 0;
    for (uint32_t q = 0; q < ne && H1[0] && H1[1]; q++) {
        if (el->level[q] == 0)
            continue;
        double bulb = 1.0 * (double)el->light_h[(size_t)q * 2 + 0];
        double sun = 0.5 * (double)el->light_h[(size_t)q * 2 + 1];
        CHECK(H0[q] == bulb + sun);
        CHECK(H1[0][q] == 2.0 * bulb + sun); /* exact: scaling by 2 rounds nothing */
        CHECK(memcmp(&H1[0][q], &H1[1][q], sizeof(double)) == 0);
        doubled += bulb > 0.0;
    }
    for (uint32_t q = 0; r && q < ne; q++)
        CHECK(memcmp(&sol->elements->B[q], &r->elements->B[q], sizeof(double)) == 0);
    printf("     %u elements, %u lit by the bulb: its term doubled exactly, nothing rendered\n",
           ne, doubled);
    CHECK(doubled > ne / 2);
    unlink(path);
    rmdir(dir);
    free(H0);
    free(H1[0]);
    free(H1[1]);
    rad_solution_destroy(r);
    rad_solution_destroy(sol);
}

/* ------------------------------------------------------------------ glTF */

static void b64(char *out, const unsigned char *d, size_t n)
{
    static const char al[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)d[i] << 16 | (i + 1 < n ? (uint32_t)d[i + 1] << 8 : 0) |
                     (i + 2 < n ? d[i + 2] : 0);
        out[o++] = al[v >> 18 & 63];
        out[o++] = al[v >> 12 & 63];
        out[o++] = i + 1 < n ? al[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? al[v & 63] : '=';
    }
    out[o] = '\0';
}

/* A glTF document: one floor quad (two triangles, node "floor") and the
 * given lights and extra nodes. */
static char *gltf_doc(const char *lights, const char *nodes, const char *scene_nodes,
                      const char *required)
{
    const float pos[18] = {-1, 0, 1, 1, 0, 1, 1, 0, -1, -1, 0, 1, 1, 0, -1, -1, 0, -1};
    unsigned char bytes[72];
    memcpy(bytes, pos, sizeof bytes); /* little-endian hosts only, as the project assumes */
    char data[200];
    b64(data, bytes, sizeof bytes);
    char *doc = malloc(8192);
    snprintf(doc, 8192,
             "{\"asset\":{\"version\":\"2.0\"},%s"
             "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[%s]}},"
             "\"scene\":0,\"scenes\":[{\"nodes\":[0%s]}],"
             "\"nodes\":[{\"name\":\"floor\",\"mesh\":0}%s],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0}]}],"
             "\"materials\":[{\"name\":\"m\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,"
             "0.5,0.5,1]}}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":6,\"type\":"
             "\"VEC3\",\"min\":[-1,0,-1],\"max\":[1,0,1]}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":72}],"
             "\"buffers\":[{\"byteLength\":72,\"uri\":\"data:application/"
             "octet-stream;base64,%s\"}]}",
             required, lights, scene_nodes, nodes, data);
    return doc;
}

static int parse_doc(const char *doc, rad_scene **s, rad_error *e)
{
    return rad_scene_parse_gltf(doc, strlen(doc), NULL, NULL, s, e);
}

/* Units: I = color × intensity / 683.  Transforms: position = the node's
 * world origin (parent × child), direction = its world −Z. */
TEST(gltf_lights_punctual)
{
    const char *lights =
        "{\"name\":\"bulb\",\"type\":\"point\",\"color\":[1,0.5,0.25],\"intensity\":1366,"
        "\"range\":3},"
        "{\"type\":\"spot\",\"intensity\":683,\"spot\":{\"innerConeAngle\":0.2,"
        "\"outerConeAngle\":0.6}},"
        "{\"name\":\"sun\",\"type\":\"directional\",\"color\":[0.2,0.4,1],\"intensity\":6830},"
        "{\"name\":\"unused\",\"type\":\"point\"}";
    /* node 1: translation; node 2 (child of 3): a 90° turn about x maps −Z
     * to +Y; node 3 translates; node 4 directional turned 180° about y
     * (−Z -> +Z); node 5 carries a light but is not in the scene. */
    const char *nodes =
        ",{\"name\":\"lamp\",\"translation\":[1,2,3],"
        "\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}"
        ",{\"name\":\"spotnode\",\"rotation\":[0.70710678118654752,0,0,0.70710678118654752],"
        "\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}}"
        ",{\"name\":\"arm\",\"translation\":[0,5,0],\"children\":[2]}"
        ",{\"rotation\":[0,1,0,0],\"extensions\":{\"KHR_lights_punctual\":{\"light\":2}}}"
        ",{\"extensions\":{\"KHR_lights_punctual\":{\"light\":3}}}";
    char *doc = gltf_doc(lights, nodes, ",1,3,4",
                         "\"extensionsUsed\":[\"KHR_lights_punctual\"],"
                         "\"extensionsRequired\":[\"KHR_lights_punctual\"],");
    rad_scene *s = NULL;
    rad_error e = {0};
    int rc = parse_doc(doc, &s, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    free(doc);
    if (!s)
        return;
    CHECK(s->light_count == 3);
    uint32_t k = rad_scene_find_light(s, "bulb");
    CHECK(k != RAD_NONE);
    if (k != RAD_NONE) {
        const rad_light *L = &s->lights[k];
        CHECK(L->kind == RAD_LIGHT_POINT);
        /* 1366 cd × (1, 0.5, 0.25) / 683 lm/W = (2, 1, 0.5) W/sr */
        CHECK_NEAR(L->intensity[0], 2.0, 1e-12);
        CHECK_NEAR(L->intensity[1], 1.0, 1e-12);
        CHECK_NEAR(L->intensity[2], 0.5, 1e-12);
        CHECK(L->position.x == 1 && L->position.y == 2 && L->position.z == 3);
    }
    /* the unnamed spot takes its node's name */
    k = rad_scene_find_light(s, "spotnode");
    CHECK(k != RAD_NONE);
    if (k != RAD_NONE) {
        const rad_light *L = &s->lights[k];
        CHECK(L->kind == RAD_LIGHT_SPOT);
        for (int b = 0; b < 3; b++)
            CHECK_NEAR(L->intensity[b], 1.0, 1e-12); /* 683 cd white */
        CHECK_NEAR(L->position.y, 5.0, 1e-12);
        CHECK_NEAR(L->direction.x, 0.0, 1e-12);
        CHECK_NEAR(L->direction.y, 1.0, 1e-12);
        CHECK_NEAR(L->direction.z, 0.0, 1e-12);
        CHECK(L->inner_cone == 0.2 && L->outer_cone == 0.6);
    }
    k = rad_scene_find_light(s, "sun");
    CHECK(k != RAD_NONE);
    if (k != RAD_NONE) {
        const rad_light *L = &s->lights[k];
        CHECK(L->kind == RAD_LIGHT_DIRECTIONAL);
        CHECK_NEAR(L->intensity[0], 2.0, 1e-12); /* 6830 lx × 0.2 / 683 W/m² */
        CHECK_NEAR(L->intensity[2], 10.0, 1e-12);
        CHECK_NEAR(L->direction.z, 1.0, 1e-12);
    }
    CHECK(rad_scene_find_light(s, "unused") == RAD_NONE);
    rad_scene_destroy(s);

    /* a scene lit only by a punctual light passes the emitter rule */
    doc = gltf_doc("{\"type\":\"point\"}",
                   ",{\"translation\":[0,1,0],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}",
                   ",1", "");
    CHECK(parse_doc(doc, &s, &e) == RAD_OK);
    CHECK(s && s->light_count == 1 && rad_scene_validate(s, NULL) == RAD_OK);
    CHECK(s && strcmp(s->lights[0].name, "light0") == 0);
    rad_scene_destroy(s);
    free(doc);

    /* refusals: a bad index, a bad type, a bad cone, a negative colour */
    struct {
        const char *lights, *nodes;
        int code;
        const char *needle;
    } bad[] = {
        {"{\"type\":\"point\"}", ",{\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}}",
         RAD_ERR_PARSE, "light 1 does not exist"},
        {"{\"type\":\"area\"}", ",{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}",
         RAD_ERR_PARSE, "not point, spot or directional"},
        {"{\"name\":\"s\",\"type\":\"spot\",\"spot\":{\"innerConeAngle\":0.5,\"outerConeAngle\":0.5}}",
         ",{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}", RAD_ERR_INVALID,
         "light 's'"},
        {"{\"type\":\"point\",\"color\":[1,-1,1]}",
         ",{\"name\":\"n\",\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}",
         RAD_ERR_INVALID, "light 'n'"},
        {"{\"type\":\"point\",\"intensity\":\"bright\"}",
         ",{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}", RAD_ERR_PARSE,
         "intensity is not a number"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        doc = gltf_doc(bad[i].lights, bad[i].nodes, ",1", "");
        s = NULL;
        rc = parse_doc(doc, &s, &e);
        CHECK_MSG(rc == bad[i].code && s == NULL, "case %zu: rc %d: %s", i, rc, e.message);
        CHECK_MSG(strstr(e.message, bad[i].needle) != NULL, "case %zu: %s", i, e.message);
        free(doc);
    }
}

/* --------------------------------------------------------------- scene */

TEST(scene_light_rules)
{
    rad_scene *s = new_scene();
    double one = 1.0, neg = -1.0, nan_ = NAN;
    rad_error e;
    rad_vec3 o = rad_v3(0, 0, 0), down = rad_v3(0, 0, -2);
    CHECK(rad_scene_add_light(s, "a", RAD_LIGHT_SPOT, &one, o, down, 0.1, 0.5, NULL, NULL, &e) ==
          RAD_OK);
    CHECK(s->lights[0].direction.z == -1.0); /* normalised */
    CHECK(rad_scene_add_light(s, "a", RAD_LIGHT_POINT, &one, o, down, 0, 0, NULL, NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK(strstr(e.message, "already exists") != NULL);
    CHECK(rad_scene_add_light(s, "b", RAD_LIGHT_POINT, &neg, o, down, 0, 0, NULL, NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK(rad_scene_add_light(s, "b", RAD_LIGHT_POINT, &nan_, o, down, 0, 0, NULL, NULL, &e) ==
          RAD_ERR_INVALID);
    CHECK(rad_scene_add_light(s, "b", RAD_LIGHT_POINT, &one, rad_v3(INFINITY, 0, 0), down, 0, 0,
                              NULL, NULL, &e) == RAD_ERR_INVALID);
    CHECK(rad_scene_add_light(s, "b", RAD_LIGHT_DIRECTIONAL, &one, o, o, 0, 0, NULL, NULL, &e) ==
          RAD_ERR_INVALID);
    const double cones[4][2] = {{-0.1, 0.5}, {0.5, 0.5}, {0.6, 0.5}, {0.1, 1.6}};
    for (int k = 0; k < 4; k++)
        CHECK(rad_scene_add_light(s, "b", RAD_LIGHT_SPOT, &one, o, down, cones[k][0], cones[k][1],
                                  NULL, NULL, &e) == RAD_ERR_INVALID);
    CHECK(rad_scene_add_light(s, "b", RAD_LIGHT_SPOT, &one, o, down, 0.0, M_PI / 2, NULL, NULL,
                              &e) == RAD_OK);
    CHECK(rad_scene_find_light(s, "b") == 1 && rad_scene_find_light(s, "c") == RAD_NONE);
    /* lights of intensity 0 are no emitters */
    rad_scene *z = new_scene();
    uint32_t m = test_material(z, "grey", 0.5);
    floor_square(z, "floor", 1.0, 0.0, 1, m);
    double zero = 0.0;
    CHECK(rad_scene_add_light(z, "dark", RAD_LIGHT_POINT, &zero, o, down, 0, 0, NULL, NULL, &e) ==
          RAD_OK);
    CHECK(rad_scene_validate(z, &e) == RAD_ERR_INVALID);
    CHECK(strstr(e.message, "no emitter") != NULL);
    rad_scene_destroy(z);
    rad_scene_destroy(s);
}

/* The polygon file's light statement: radiometric values as written (no
 * 683), degrees for the cones, errors with the line. */
TEST(polyfile_lights)
{
    const char *text = "bands 3\n"
                       "material m reflectance 0.5\n"
                       "polygon floor m 0 0 0 1 0 0 1 1 0 0 1 0 end\n"
                       "light bulb point 0.5 0.5 1 intensity 2 1 0.5\n"
                       "light cone spot 0 0 2 direction 0 0 -4 inner 20 outer 40 intensity 3\n"
                       "light sun directional direction 1 0 -1 irradiance 100\n";
    rad_scene *s = NULL;
    rad_error e = {0};
    int rc = rad_scene_parse_polyfile(text, strlen(text), "lit.rad", NULL, &s, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    if (!s)
        return;
    CHECK(s->light_count == 3 && rad_scene_validate(s, NULL) == RAD_OK);
    const rad_light *b = &s->lights[0], *c = &s->lights[1], *d = &s->lights[2];
    CHECK(b->kind == RAD_LIGHT_POINT && b->intensity[0] == 2 && b->intensity[2] == 0.5);
    CHECK(b->position.x == 0.5 && b->position.z == 1);
    CHECK(c->kind == RAD_LIGHT_SPOT && c->intensity[1] == 3 && c->direction.z == -1.0);
    CHECK_NEAR(c->inner_cone, 20 * M_PI / 180, 1e-15);
    CHECK_NEAR(c->outer_cone, 40 * M_PI / 180, 1e-15);
    CHECK(d->kind == RAD_LIGHT_DIRECTIONAL && d->intensity[0] == 100);
    CHECK_NEAR(d->direction.x, sqrt(0.5), 1e-15);
    rad_scene_destroy(s);

    const char *bad[][2] = {
        {"light x area 0 0 0 intensity 1\n", "line 4: light 'x': expected point, spot or"},
        {"light x spot 0 0 1 direction 0 0 -1 inner 50 outer 40 intensity 1\n",
         "line 4: light 'x': cone angles"},
        {"light x point 0 0 1 intensity -1\n", "line 4: light 'x': intensity -1"},
        {"light x point 0 0 1 irradiance 1\n", "expected 'intensity'"},
        {"light x point 0 0 1 intensity 1\nlight x point 0 0 2 intensity 1\n",
         "line 5: light 'x': a light of this name already exists"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        char t[512];
        snprintf(t, sizeof t, "bands 1\nmaterial m reflectance 0.5\n"
                              "polygon floor m 0 0 0 1 0 0 1 1 0 0 1 0 end\n%s", bad[k][0]);
        s = NULL;
        rc = rad_scene_parse_polyfile(t, strlen(t), "lit.rad", NULL, &s, &e);
        CHECK_MSG(rc != RAD_OK && s == NULL && strstr(e.message, bad[k][1]), "case %zu: %s", k,
                  e.message);
    }
}


/* A point light 1 m above the centre of a 2×2 m floor (ρ = 0.5, nothing
 * else), solved and drawn at the defaults: the drawn radiance along the
 * floor's axis, relative to the centre's, follows the exact cos³ θ law
 * within 1 % (issue 18: patches alone drew the edge 2.2 % and x = 0.5 3 %
 * too bright - each patch holds its mean Φ/A, and vertex averages flatten
 * the peak; the default elements carry their own mean h_le and are
 * drawn with quadratic fits).  Measured: worst 0.32 % over x = 0.25 ... 0.98.
 * Cost: under 1 s. */
TEST(point_light_cos3_at_defaults)
{
    rad_scene *s = new_scene();
    floor_square(s, "floor", 1.0, 0.0, 0, test_material(s, "grey", 0.5)); /* default patches */
    light(s, "bulb", RAD_LIGHT_POINT, 1.0, rad_v3(0, 0, 1), rad_v3(0, 0, -1), 0, 0);
    rad_solution *sol = NULL;
    rad_error e = {0};
    CHECK_MSG(rad_solve_scene(s, &(rad_solve_options){0}, &sol, &e) == RAD_OK, "%s", e.message);
    if (!sol)
        return;
    CHECK(sol->elements != NULL);
    const uint32_t W = 512;
    const double dist = 20.0, half = tan(3.0 * M_PI / 180.0) * dist;
    rn_camera cam = {.eye = {0, 0, dist}, .target = {0, 0, 0}, .up = {0, 1, 0}, .yfov_deg = 6.0,
                     .width = W, .height = W};
    rn_image *img = NULL;
    CHECK_MSG(rad_render_solution(sol, &cam, &img, &e) == RAD_OK, "%s", e.message);
    /* row W/2 - 1 and W/2 straddle y = 0; pixel i's centre lies at
     * x = (i + 0.5 - W/2) / (W/2) × half (right = f × up = +x) */
    const double xs[] = {0.25, 0.5, 0.75, 0.9, 0.95, 0.98};
    double worst = 0.0;
    for (size_t k = 0; img && k < sizeof xs / sizeof xs[0]; k++) {
        uint32_t i = (uint32_t)(W / 2 + xs[k] / half * (W / 2)), c = W / 2;
        double x = (i + 0.5 - 0.5 * W) / (0.5 * W) * half, x0 = (c + 0.5 - 0.5 * W) / (0.5 * W) * half;
        double y = 0.5 / (0.5 * W) * half; /* the two rows' mean: their centres at ±y */
        double got = (img->pixels[(size_t)(W / 2 - 1) * W + i] + img->pixels[(size_t)(W / 2) * W + i]) /
                     (img->pixels[(size_t)(W / 2 - 1) * W + c] + img->pixels[(size_t)(W / 2) * W + c]);
        double want = pow(1.0 + x * x + y * y, -1.5) / pow(1.0 + x0 * x0 + y * y, -1.5);
        worst = fmax(worst, fabs(got / want - 1.0));
        printf("     x = %.3f: L/L(0) %.5f, cos³ %.5f (%+.2f %%)\n", x, got, want, 100 * (got / want - 1));
        CHECK_REL(got, want, 0.01);
    }
    printf("     %u elements on %u patches; worst %.2f %%\n",
           sol->elements ? sol->elements->mesh->patch_count : 0, sol->mesh->patch_count, 100 * worst);
    rn_image_destroy(img);
    rad_solution_destroy(sol);
}

/* Issue 39: punctual lights exact at the default light resolution (512).
 * A 4×4 m floor of 20×20 tiles (0.2 m), a black box floating over it, lit
 * by a point light, then by a spot (inner 30°, outer 50°, its cone's edge,
 * r = tan 50° = 1.19 m, crossing tiles), each 1 m above the centre.  The
 * box [0.4, 0.8]×[-0.3, 0.3]×[0.45, 0.55] casts a shadow whose outline
 * (the hull of its corners projected from the light) crosses tiles; a tile
 * clear of the hull's bounding box is unshadowed and must be within 0.5 %
 * of the closed-form mean irradiance (mean_irradiance: the point light's
 * cos θ / r², the spot's falloff too) out to the floor's corners, where it
 * is seen 70° off the vertical (pixel counts were 2.5 % low there); a tile
 * inside the box's shadow core [0.889, 1.455]×[-0.545, 0.545] gets exactly
 * 0, and one the outline crosses something in between.  Tiles in the
 * falloff's last 1e-4 of the peak I/h² (t² ~ 1e-6) are held to 1e-7 of
 * the peak absolute instead (measured 6e-9: the adaptive integral's
 * tolerance).  Measured worst relative: point 2.1e-7, spot 1.0e-4.  (With
 * pixel visibility lookups alone, tiles along the floor's outer edge were
 * 0.56 % low: pixels beside the edge show nothing.) */
TEST(punctual_tiles_exact)
{
    const double lo[3] = {0.4, -0.3, 0.45}, hi[3] = {0.8, 0.3, 0.55};
    /* the shadow hull's bounding box: corners projected from (0, 0, 1) */
    double sx0 = INFINITY, sx1 = -INFINITY, sy0 = INFINITY, sy1 = -INFINITY;
    for (int k = 0; k < 8; k++) {
        double x = k & 1 ? hi[0] : lo[0], y = k & 2 ? hi[1] : lo[1], z = k & 4 ? hi[2] : lo[2];
        double f = 1.0 / (1.0 - z);
        sx0 = fmin(sx0, x * f), sx1 = fmax(sx1, x * f), sy0 = fmin(sy0, y * f), sy1 = fmax(sy1, y * f);
    }
    for (int spot = 0; spot < 2; spot++) {
        rad_scene *s = new_scene();
        uint32_t grey = test_material(s, "grey", 0.5), black = test_material(s, "black", 0.0);
        floor_square(s, "floor", 2.0, 0.0, 20, grey);
        box(s, "box", rad_v3(lo[0], lo[1], lo[2]), rad_v3(hi[0], hi[1], hi[2]), black);
        light(s, "lamp", spot ? RAD_LIGHT_SPOT : RAD_LIGHT_POINT, 2.0, rad_v3(0, 0, 1),
              rad_v3(0, 0, -1), SPOT_INNER, SPOT_OUTER);
        rad_solution *sol = solve(s, 0); /* the default light resolution */
        if (!sol)
            return;
        double *H = direct(sol), worst = 0.0;
        int clear = 0, core = 0, edge = 0, falloff = 0, tail = 0;
        for (uint32_t j = 0; j < sol->mesh->patch_count; j++) {
            if (sol->mesh->patches[j].object != 0)
                continue;
            double x0, x1, y0, y1;
            extent(sol, j, &x0, &x1, &y0, &y1);
            double want = mean_irradiance(x0, x1, y0, y1, 1.0, 2.0, spot, SPOT_INNER, SPOT_OUTER);
            if (x1 <= sx0 || x0 >= sx1 || y1 <= sy0 || y0 >= sy1) {
                if (want == 0.0) {
                    CHECK(H[j] == 0.0); /* outside the spot's outer cone */
                    continue;
                }
                clear++;
                double rmin = hypot(fmax(0, fmax(x0, -x1)), fmax(0, fmax(y0, -y1)));
                double rmax = hypot(fmax(fabs(x0), fabs(x1)), fmax(fabs(y0), fabs(y1)));
                falloff += spot && rmin < tan(SPOT_OUTER) && rmax > tan(SPOT_INNER);
                if (want < 1e-4 * 2.0) { /* the falloff's last 1e-4 (t² ~ 1e-6 of the peak I/h²) */
                    tail++;
                    CHECK_MSG(fabs(H[j] - want) <= 1e-7 * 2.0, "tile [%g,%g]x[%g,%g]: %.6g, want %.6g",
                              x0, x1, y0, y1, H[j], want);
                    continue;
                }
                worst = fmax(worst, fabs(H[j] / want - 1.0));
                CHECK_MSG(fabs(H[j] / want - 1.0) <= 0.005, "tile [%g,%g]x[%g,%g]: %.6g, want %.6g",
                          x0, x1, y0, y1, H[j], want);
            } else if (x0 >= 0.889 && x1 <= 1.455 && y0 >= -0.545 && y1 <= 0.545) {
                core++;
                CHECK(H[j] == 0.0);
            } else if (want > 0.0 && H[j] > 0.0 && H[j] < want * (1 - 1e-3)) {
                edge++; /* the outline crosses it: partly lit */
            }
        }
        printf("     %s: %d unshadowed tiles (%d in the falloff, %d in its tail), worst %.2e; %d in "
               "the core at 0, %d partly shadowed\n", spot ? "spot" : "point", clear, falloff, tail,
               worst, core, edge);
        CHECK(clear >= (spot ? 100 : 340) && core == 8 && edge >= 8);
        CHECK(!spot || falloff >= 30);
        free(H);
        rad_solution_destroy(sol);
    }
}

/* Issue 39, per element: a 4×4 m floor of 0.5 m patches split once
 * (elements 0.25 m, large next to the light's height) lit at grazing
 * angles: a point light 0.3 m above the centre with a black box casting a
 * shadow, then a spot 0.3 m up at x = -1.8 aimed along (1, 0, -0.25) (inner
 * 30°, outer 50°, its cone's edge crossing elements).  Every element clear
 * of the shadow hull's bounding box is within 0.5 % of the mean of
 * I f cosθ / r² over it (mean_from, midpoint quadrature 100×100; the spot's
 * elements in the falloff's last 1e-4 of I/h² against 1e-7 of it
 * absolute).  Measured worst relative: point 5.8e-6, spot 6.0e-4 (an
 * element deep in the falloff: the adaptive integral's absolute
 * tolerance).  The value at the element's centre, which elements took
 * before, is off by up to 5.2 % (point) and 100 % (spot: an element whose
 * centre lies outside the cone) here: the test checks that it would fail. */
TEST(elements_grazing_exact)
{
    const double h = 0.3, lo[3] = {0.5, -0.1, 0.1}, hi[3] = {0.7, 0.1, 0.2};
    double sx0 = INFINITY, sx1 = -INFINITY, sy0 = INFINITY, sy1 = -INFINITY;
    for (int k = 0; k < 8; k++) { /* the shadow hull's bounding box from (0, 0, h) */
        double x = k & 1 ? hi[0] : lo[0], y = k & 2 ? hi[1] : lo[1], z = k & 4 ? hi[2] : lo[2];
        double f = h / (h - z);
        sx0 = fmin(sx0, x * f), sx1 = fmax(sx1, x * f), sy0 = fmin(sy0, y * f), sy1 = fmax(sy1, y * f);
    }
    for (int spot = 0; spot < 2; spot++) {
        const rad_vec3 pos = spot ? rad_v3(-1.8, 0, h) : rad_v3(0, 0, h);
        const rad_vec3 ax = rad_normalize(rad_v3(1, 0, -0.25));
        rad_scene *s = new_scene();
        uint32_t grey = test_material(s, "grey", 0.5), black = test_material(s, "black", 0.0);
        floor_square(s, "floor", 2.0, 0.0, 8, grey);
        if (!spot)
            box(s, "box", rad_v3(lo[0], lo[1], lo[2]), rad_v3(hi[0], hi[1], hi[2]), black);
        light(s, "lamp", spot ? RAD_LIGHT_SPOT : RAD_LIGHT_POINT, 2.0, pos, ax, SPOT_INNER, SPOT_OUTER);
        rad_solution *sol = solve_elements(s, 1, 0.0, 0.0);
        if (!sol)
            return;
        const rad_elements *el = sol->elements;
        double *H = element_direct(sol), worst = 0.0, centre_worst = 0.0;
        uint32_t clear = 0;
        for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
            if (el->mesh->patches[e].object != 0)
                continue;
            double x0, x1, y0, y1;
            el_extent(el, e, &x0, &x1, &y0, &y1);
            if (!spot && !(x1 <= sx0 || x0 >= sx1 || y1 <= sy0 || y0 >= sy1))
                continue; /* the shadow may reach it */
            double want = mean_from(x0, x1, y0, y1, pos, ax, 2.0, spot, SPOT_INNER, SPOT_OUTER, 100);
            double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
            double at_centre = mean_from(cx, cx, cy, cy, pos, ax, 2.0, spot, SPOT_INNER, SPOT_OUTER, 1);
            if (want < 1e-4 * 2.0 / (h * h)) {
                CHECK_MSG(fabs(H[e] - want) <= 1e-7 * 2.0 / (h * h), "element [%g,%g]x[%g,%g]: %.6g, "
                          "want %.6g", x0, x1, y0, y1, H[e], want);
                continue;
            }
            clear++;
            worst = fmax(worst, fabs(H[e] / want - 1.0));
            centre_worst = fmax(centre_worst, fabs(at_centre / want - 1.0));
            CHECK_MSG(fabs(H[e] / want - 1.0) <= 0.005, "element [%g,%g]x[%g,%g]: %.6g, want %.6g",
                      x0, x1, y0, y1, H[e], want);
        }
        printf("     %s: %u unshadowed elements, worst %.2e (the centre's value: %.1f %%)\n",
               spot ? "spot" : "point", clear, worst, 100 * centre_worst);
        CHECK(clear >= (spot ? 60u : 200u));
        CHECK(centre_worst > 0.02); /* centre sampling would fail this test */
        free(H);
        rad_solution_destroy(sol);
    }
}

int main(void)
{
    RUN(polyfile_lights);
    RUN(scene_light_rules);
    RUN(gltf_lights_punctual);
    RUN(point_light_above_floor);
    RUN(point_light_shadow_of_a_box);
    RUN(spot_light_cone);
    RUN(directional_light_tilted_plane);
    RUN(directional_light_shadow);
    RUN(relight_punctual_light);
    RUN(elements_point_light_irradiance);
    RUN(elements_point_light_shadow_edge);
    RUN(elements_spot_cone_edge);
    RUN(elements_directional_shadow_edge);
    RUN(elements_refinement_follows_light_edge);
    RUN(elements_relight_and_round_trip);
    RUN(point_light_cos3_at_defaults);
    RUN(punctual_tiles_exact);
    RUN(elements_grazing_exact);
    return test_finish("test_lights");
}
