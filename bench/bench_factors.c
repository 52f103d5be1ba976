/* bench_factors.c - accuracy against time where the hemi-cube is weak
 * (issue 39): the closed-form catalog and punctual lights.
 *
 * Catalog: rad_validate_catalog's pairs at the default patch size, each
 * computed at `ff`'s defaults (HC_WEAK_SURFACE: F_AB queries) and at the
 * accurate setting (HC_WEAK_HIGH, `--accuracy high`), with its relative
 * error against the closed form and its wall-clock seconds (mesh + form
 * factors, 2 worker processes), and the ratio of the two totals.  Lights: a 4 × 4 m floor of
 * 0.2 m tiles under a point light and a spot (inner 30°, outer 50°) 1 m
 * above its centre: the worst tile's mean irradiance against a 200²
 * midpoint quadrature of the closed form, at light resolutions 512 (the
 * default) and 2048, and the seconds of the solve.  The machine is shared:
 * times are noisy, errors are not.  Nothing here asserts anything.
 */
#include "../hemicube/hemicube.h"
#include "../radiosity/pipeline/pipeline.h"
#include "../radiosity/validate/validate.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* The catalog at the defaults and at the accurate setting, one row each. */
static void catalog(void)
{
    rad_val_case c[64];
    double promised[64];
    uint32_t n = rad_validate_catalog(RAD_VAL_DEFAULTS, c, promised, 64);
    printf("| pair | patches | defaults: error | s | accurate: error | s |\n");
    printf("|:--|--:|--:|--:|--:|--:|\n");
    double worst[2] = {0, 0}, secs[2] = {0, 0};
    for (uint32_t k = 0; k < n; k++) {
        rad_val_result r[2];
        int ok = 1;
        for (int m = 0; m < 2 && ok; m++) {
            rad_val_case d = c[k];
            d.engine = m ? RAD_VAL_ACCURATE : RAD_VAL_DEFAULTS;
            d.processes = 2;
            rad_error err = {0};
            if (rad_validate_case(&d, &r[m], &err) != RAD_OK) {
                printf("| %s | error: %s |\n", r[m].name, err.message);
                ok = 0;
            }
        }
        if (!ok)
            continue;
        for (int m = 0; m < 2; m++) {
            worst[m] = fmax(worst[m], fabs(r[m].rel_error));
            secs[m] += r[m].seconds;
        }
        printf("| %s | %u | %+.2e | %.2f | %+.2e | %.2f |\n", r[0].name, r[0].patches,
               r[0].rel_error, r[0].seconds, r[1].rel_error, r[1].seconds);
    }
    printf("| **all %u** | | worst %.2e | %.1f | worst %.2e | %.1f |\n\n", n, worst[0], secs[0],
           worst[1], secs[1]);
    printf("accurate / defaults, seconds: %.2f\n\n", secs[0] > 0 ? secs[1] / secs[0] : NAN);
}

/* glTF's spot falloff, written here again (an independent reference). */
static double falloff(double cd, double inner, double outer)
{
    double t = (cd - cos(outer)) / fmax(0.001, cos(inner) - cos(outer));
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t;
}

/* Mean of I f cos θ / r² over [x0,x1]×[y0,y1] at z = 0, light at height 1. */
static double mean_h(double x0, double x1, double y0, double y1, int spot)
{
    const int N = 200;
    double sum = 0;
    for (int a = 0; a < N; a++)
        for (int b = 0; b < N; b++) {
            double x = x0 + (a + 0.5) * (x1 - x0) / N, y = y0 + (b + 0.5) * (y1 - y0) / N;
            double r2 = x * x + y * y + 1, c = 1 / sqrt(r2);
            sum += (spot ? falloff(c, M_PI / 6, 50 * M_PI / 180) : 1.0) * c / r2;
        }
    return sum / (N * N);
}

static void light_row(int spot, uint32_t R)
{
    rad_scene *s = rad_scene_create(1, "bench-factors");
    rad_error e = {0};
    double rho = 0.5, zero = 0.0, I = 1.0;
    uint32_t m, o;
    rad_vec3 p[4] = {{-2, -2, 0}, {2, -2, 0}, {2, 2, 0}, {-2, 2, 0}};
    int rc = rad_scene_add_material(s, "grey", &rho, &zero, NULL, NULL, &m, &e);
    if (!rc) rc = rad_scene_add_object(s, "floor", NULL, &o, &e);
    if (!rc) rc = rad_scene_add_polygon(s, "floor", o, m, p, 4, 20, 20, NULL, NULL, &e);
    if (!rc)
        rc = rad_scene_add_light(s, "lamp", spot ? RAD_LIGHT_SPOT : RAD_LIGHT_POINT, &I,
                                 rad_v3(0, 0, 1), rad_v3(0, 0, -1), M_PI / 6, 50 * M_PI / 180,
                                 NULL, NULL, &e);
    rad_solve_options opt = {.refine_threshold = RAD_REFINE_OFF, .light_resolution = R};
    rad_solution *sol = NULL;
    double t0 = rad_seconds();
    if (!rc)
        rc = rad_solve_scene(s, &opt, &sol, &e); /* takes s */
    else
        rad_scene_destroy(s);
    double t = rad_seconds() - t0;
    double *H = sol ? malloc((size_t)sol->mesh->patch_count * sizeof *H) : NULL;
    if (rc || !H || rad_solution_direct_irradiance(sol, H, NULL) != RAD_OK) {
        printf("| %s | %u | error: %s |\n", spot ? "spot" : "point", R, e.message);
    } else {
        double worst = 0;
        uint32_t tiles = 0;
        for (uint32_t j = 0; j < sol->mesh->patch_count; j++) {
            const rad_patch *pp = &sol->mesh->patches[j];
            double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
            for (int k = 0; k < 4; k++) {
                rad_vec3 v = sol->mesh->vertices[pp->v[k]];
                x0 = fmin(x0, v.x), x1 = fmax(x1, v.x), y0 = fmin(y0, v.y), y1 = fmax(y1, v.y);
            }
            double want = mean_h(x0, x1, y0, y1, spot);
            if (want < 1e-4)
                continue; /* outside the cone, or its last 1e-4 */
            tiles++;
            worst = fmax(worst, fabs(H[j] / want - 1));
        }
        printf("| %s | %u | %u | %.2e | %.2f |\n", spot ? "spot" : "point", R, tiles, worst, t);
    }
    free(H);
    rad_solution_destroy(sol);
}

int main(void)
{
    printf("Form factors where the hemi-cube is weak (issue 39): the catalog at the default\n"
           "patch size, R = 128, relative error against the closed form, seconds of mesh +\n"
           "form factors (2 workers, shared machine)\n\n");
    catalog();
    printf("Punctual lights over 0.2 m floor tiles, 1 m up: worst tile's mean irradiance\n"
           "against the closed form (tiles with at least 1e-4 of the peak), seconds of the solve\n\n");
    printf("| light | light R | tiles | worst error | s |\n|:--|--:|--:|--:|--:|\n");
    for (int spot = 0; spot < 2; spot++) {
        light_row(spot, 512);
        light_row(spot, 2048);
    }
    return 0;
}
