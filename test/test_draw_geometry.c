/* test_draw_geometry.c - clusters drawn by their simplified outlines
 * (hemicube/draw_geometry.c, issue 36): in a closed round room whose wall,
 * floor and ceiling are exports' small triangles, grouped into clusters,
 * drawing each cluster by its simplified outline changes no object's
 * area-mean B by more than 0.2 % against drawing every cell
 * (RADIOSITY_DRAW_EVERY_CELL=1), draws fewer triangles, and lets no light
 * out: a point light in the room puts nothing on an object outside it.
 * Cost: about 4 s of CPU (release), 8-19 s wall on the 2-core machine
 * under a load of 10-16. */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"

#include <stdlib.h>

#define SIDES 64   /* the round wall's facets */
#define ROWS 8     /* its rows of triangles */
#define RINGS 6    /* floor and ceiling: rings of triangles */
#define HEIGHT 1.2

/* The point of the room's circle at facet k (of SIDES), radius r, height y:
 * computed one way only, so neighbouring triangles share it exactly. */
static rad_vec3 rim(uint32_t k, double r, double y)
{
    double a = 2.0 * M_PI * (double)(k % SIDES) / SIDES;
    return rad_v3(r * cos(a), y, r * sin(a));
}

static int tri(rad_scene *s, uint32_t o, uint32_t m, rad_vec3 a, rad_vec3 b, rad_vec3 c)
{
    rad_vec3 p[3] = {a, b, c};
    return rad_scene_add_polygon(s, "t", o, m, p, 3, 0, 0, NULL, NULL, NULL);
}

/* The round wall of radius 1, facing in, as ROWS × SIDES quads cut in two. */
static int wall(rad_scene *s, uint32_t o, uint32_t m)
{
    int rc = 0;
    for (uint32_t h = 0; h < ROWS; h++)
        for (uint32_t k = 0; k < SIDES && !rc; k++) {
            double y0 = HEIGHT * h / ROWS, y1 = HEIGHT * (h + 1) / ROWS;
            rad_vec3 a = rim(k, 1, y0), b = rim(k + 1, 1, y0), c = rim(k + 1, 1, y1), d = rim(k, 1, y1);
            rc = tri(s, o, m, a, b, c) || tri(s, o, m, a, c, d);
        }
    return rc;
}

/* A disk of radius 1 at height y facing +y (up = 1) or -y: a fan of short
 * triangles about the centre, then rings of quads cut in two. */
static int disk(rad_scene *s, uint32_t o, uint32_t m, double y, int up)
{
    int rc = 0;
    for (uint32_t r = 0; r < RINGS && !rc; r++)
        for (uint32_t k = 0; k < SIDES && !rc; k++) {
            double r0 = (double)r / RINGS, r1 = (double)(r + 1) / RINGS;
            rad_vec3 a = rim(k, r0, y), b = rim(k + 1, r0, y), c = rim(k + 1, r1, y), d = rim(k, r1, y);
            if (r == 0)
                rc = up ? tri(s, o, m, a, c, d) : tri(s, o, m, a, d, c);
            else
                rc = up ? (tri(s, o, m, a, b, c) || tri(s, o, m, a, c, d))
                        : (tri(s, o, m, a, c, b) || tri(s, o, m, a, d, c));
        }
    return rc;
}

/* The closed room, a square lamp under its ceiling, and outside it a wall
 * facing the room and a floor under it. */
static rad_scene *room(void)
{
    rad_scene *s = rad_scene_create(1, "round room");
    const double white = 0.7, black = 0.0, none = 0.0, lamp_e = 10.0;
    uint32_t mw, ml, o[5];
    const char *names[5] = {"wall", "floor", "ceiling", "lamp", "outside"};
    int rc = !s || rad_scene_add_material(s, "white", &white, &none, NULL, NULL, &mw, NULL) ||
             rad_scene_add_material(s, "lamp", &black, &lamp_e, NULL, NULL, &ml, NULL);
    for (int k = 0; k < 5 && !rc; k++)
        rc = rad_scene_add_object(s, names[k], NULL, &o[k], NULL);
    rc = rc || wall(s, o[0], mw) || disk(s, o[1], mw, 0.0, 1) || disk(s, o[2], mw, HEIGHT, 0);
    const rad_vec3 lamp[4] = {{-0.2, 1.1, -0.2}, {0.2, 1.1, -0.2}, {0.2, 1.1, 0.2}, {-0.2, 1.1, 0.2}};
    const rad_vec3 out1[4] = {{1.3, -0.5, 1.5}, {1.3, -0.5, -1.5}, {1.3, 1.7, -1.5}, {1.3, 1.7, 1.5}};
    const rad_vec3 out2[4] = {{-1.5, -0.3, -1.5}, {-1.5, -0.3, 1.5}, {1.2, -0.3, 1.5}, {1.2, -0.3, -1.5}};
    rc = rc || rad_scene_add_polygon(s, "lamp", o[3], ml, lamp, 4, 0, 0, NULL, NULL, NULL) ||
         rad_scene_add_polygon(s, "out", o[4], mw, out1, 4, 0, 0, NULL, NULL, NULL) ||
         rad_scene_add_polygon(s, "out", o[4], mw, out2, 4, 0, 0, NULL, NULL, NULL);
    if (rc) {
        rad_scene_destroy(s);
        return NULL;
    }
    return s;
}

static rad_solution *solve(int every_cell)
{
    setenv("RADIOSITY_DRAW_EVERY_CELL", every_cell ? "1" : "0", 1); /* read by the workers */
    rad_scene *sc = room();
    rad_solve_options opt = {0};
    opt.mesh.patch_size = 0.35;
    opt.hemicube.processes = 2;
    opt.refine_threshold = RAD_REFINE_OFF; /* the patches' B */
    rad_solution *sol = NULL;
    rad_error err = {0};
    CHECK_MSG(sc && rad_solve_scene(sc, &opt, &sol, &err) == RAD_OK, "%s", err.message);
    unsetenv("RADIOSITY_DRAW_EVERY_CELL");
    return sol;
}

TEST(simplified_clusters_match_every_cell)
{
    rad_solution *ref = solve(1), *fan = solve(0);
    if (!ref || !fan) {
        rad_solution_destroy(ref);
        rad_solution_destroy(fan);
        return;
    }
    rad_error err = {0};
    rad_object_stats a[5], b[5];
    CHECK(rad_solution_object_stats(ref, a, &err) == RAD_OK &&
          rad_solution_object_stats(fan, b, &err) == RAD_OK);
    double worst = 0.0;
    for (int k = 0; k < 4; k++) {
        double d = fabs(b[k].B[0] - a[k].B[0]) / a[k].B[0];
        printf("  object %d: B %.6f every cell, %.6f simplified (%.3f %%)\n", k, a[k].B[0],
               b[k].B[0], 100.0 * d);
        worst = fmax(worst, d);
    }
    /* Measured: 0.088 % worst (the ceiling); the bound is 0.2 %. */
    CHECK_MSG(worst <= 0.002, "worst %.4f %%", 100.0 * worst);
    CHECK(a[0].B[0] > 0.0 && a[1].B[0] > 0.0);

    /* What the item buffers draw: every cell, then the fans. */
    hc_options ho = {.processes = 1};
    hc_engine *e = NULL;
    uint64_t all = 0, few = 0;
    uint32_t s0 = 0, s1 = 0;
    CHECK_MSG(hc_create(fan->mesh, &ho, &e, &err) == RAD_OK, "%s", err.message);
    CHECK(e && hc_draw_triangles(e, 1, &all, &s0, &err) == RAD_OK &&
          hc_draw_triangles(e, 0, &few, &s1, &err) == RAD_OK);
    /* Nothing leaks out: a point light in the middle of the room, drawn
     * into a fine item-buffer cube (hc_light_power: pixels only, no
     * integral), gives the outside object exactly nothing, and the room the
     * light's whole 4π less the lamp's back. */
    const uint32_t n = fan->mesh->patch_count;
    double *phi = calloc(n, sizeof *phi);
    const hc_light pt = {.kind = HC_LIGHT_POINT, .position = {0.1, 0.6, 0.05}};
    CHECK(phi && e && hc_light_power(e, &pt, 1024, phi, &err) == RAD_OK);
    double out = 0.0, in = 0.0;
    for (uint32_t i = 0; phi && i < n; i++)
        *(fan->mesh->patches[i].object == 4 ? &out : &in) += phi[i];
    printf("  point light: %.6f of 4pi on the room, %g outside\n", in / (4 * M_PI), out);
    CHECK(out == 0.0 && in > 0.9 * 4 * M_PI);
    free(phi);
    hc_destroy(e);
    uint32_t clusters = 0;
    for (uint32_t i = 0; i < fan->mesh->patch_count; i++)
        clusters += fan->mesh->cell_first[i + 1] - fan->mesh->cell_first[i] > 1;
    printf("  %u patches, %u clusters: %llu triangles every cell, %llu simplified (%u clusters)\n",
           fan->mesh->patch_count, clusters, (unsigned long long)all, (unsigned long long)few, s1);
    CHECK(s0 == 0);
    /* Most clusters simplified (measured 135 of 140), and fewer triangles
     * (measured 1662 of 2710: these clusters hold few cells each). */
    CHECK_MSG(s1 >= clusters * 9 / 10, "%u of %u clusters simplified", s1, clusters);
    CHECK_MSG(few * 3 < all * 2, "%llu of %llu", (unsigned long long)few, (unsigned long long)all);
    rad_solution_destroy(ref);
    rad_solution_destroy(fan);
}

int main(void)
{
    RUN(simplified_clusters_match_every_cell);
    return test_finish("test_draw_geometry");
}
