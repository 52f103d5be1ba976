/* test_pipeline.c - the stages together, on scenes whose answers are known
 * independently of this program:
 *   - a closed cube with uniform E and ρ: B = E/(1 - ρ) exactly (furnace);
 *   - two parallel unit squares one unit apart: F = 0.19982490 (Howell C-11);
 *   - the bundled Cornell box: finite non-negative image, the light's pixels
 *     equal its radiance, colour bleeding from the red wall;
 *   - relight (issue 3): scaling, switching off, changing ρ without a row;
 *   - the three solvers agree on one matrix.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Polygon-file text of an axis-aligned box [0,s]³ with inward faces, each
 * face its own object, one material for all. */
static void box_text(char *buf, size_t size, double side, const char *material_line,
                     unsigned subdiv)
{
    size_t used = (size_t)snprintf(buf, size, "bands 3\n%s\n", material_line);
    static const char *names[6] = {"x0", "x1", "y0", "y1", "z0", "z1"};
    for (int f = 0; f < 6; f++) {
        int axis = f / 2, hi = f % 2;
        double c = hi ? side : 0.0;
        int a = (axis + 1) % 3, b = (axis + 2) % 3;
        double q[4][3];
        double uv[4][2] = {{0, 0}, {side, 0}, {side, side}, {0, side}};
        for (int k = 0; k < 4; k++) {
            q[k][axis] = c;
            q[k][a] = uv[k][0];
            q[k][b] = uv[k][1];
        }
        /* (a,b,axis) is right-handed, so this order's normal is +axis; the
         * inward normal is +axis on the low face and -axis on the high one. */
        int order[4] = {0, 1, 2, 3};
        if (hi) {
            order[1] = 3;
            order[3] = 1;
        }
        used += (size_t)snprintf(buf + used, size - used, "polygon %s m subdivide %u %u\n", names[f],
                                 subdiv, subdiv);
        for (int k = 0; k < 4; k++)
            used += (size_t)snprintf(buf + used, size - used, "  %g %g %g\n", q[order[k]][0],
                                     q[order[k]][1], q[order[k]][2]);
        used += (size_t)snprintf(buf + used, size - used, "end\n");
    }
}

static rad_solution *solve_text(const char *text, rad_solve_options *opt)
{
    return test_solve_text(text, "test.rad", opt);
}

/* Furnace: every patch of a closed cube with E = 1 and ρ = 0.5 has B = 2.
 * The hemi-cube's rows sum to 1 up to float rounding of the entries, so
 * what is left is the solver's tolerance, 1e-4 of max B (measured 3.8e-5):
 * 2e-4.  Rows summing to 1.004 would move B by ρ/(1 − ρ)·0.004 = 0.4 %. */
TEST(furnace_cube)
{
    char text[8192];
    box_text(text, sizeof text, 1.0, "material m reflectance 0.5 emission 1", 6);
    rad_solve_options opt = {0};
    rad_solution *s = solve_text(text, &opt);
    CHECK(s != NULL);
    if (!s)
        return;
    double worst = 0;
    for (size_t k = 0; k < (size_t)s->mesh->patch_count * 3; k++)
        worst = fmax(worst, fabs(s->B[k] - 2.0) / 2.0);
    CHECK_MSG(worst < 2e-4, "worst relative error %.3g", worst);
    printf("  furnace: %u patches, worst |B - 2E|/2E = %.2e\n", s->mesh->patch_count, worst);
    rad_solution_destroy(s);
}

/* Two parallel unit squares one unit apart, 16×16 patches each: the
 * area-weighted polygon-to-polygon factor (rad_object_form_factors) within
 * 0.2 % of Howell C-11's 0.19982490: the hemi-cube at R = 128 on this mesh
 * is +5.9e-4 off (measured; `radiosity validate` shows the same), so a
 * factor shifted by 0.4 % either way fails. */
TEST(parallel_squares_ff)
{
    const char *text = "bands 1\n"
                       "material m reflectance 0.5\n"
                       "polygon bottom m subdivide 16 16\n 0 0 0  0 0 1  1 0 1  1 0 0\nend\n"
                       "polygon top m subdivide 16 16\n 0 1 0  1 1 0  1 1 1  0 1 1\nend\n";
    rad_solve_options opt = {.all_rows = 1};
    rad_solution *s = solve_text(text, &opt);
    CHECK(s != NULL);
    if (!s)
        return;
    double M[4];
    rad_error err;
    CHECK(rad_object_form_factors(s, M, &err) == RAD_OK);
    CHECK_REL(M[0 * 2 + 1], 0.19982490, 2e-3);
    CHECK_REL(M[1 * 2 + 0], 0.19982490, 2e-3);
    printf("  F_bottom,top = %.6f (%+.1e), F_top,bottom = %.6f (%+.1e) (analytic 0.19982490)\n",
           M[1], M[1] / 0.19982490 - 1, M[2], M[2] / 0.19982490 - 1);
    rad_solution_destroy(s);
}

static rad_solution *cornell(double patch_size)
{
    rad_error err = {0};
    rad_solve_options opt = {0};
    opt.mesh.patch_size = patch_size;
    rad_solution *s = NULL;
    if (rad_solve_scene_file("models/cornell.rad", &opt, &s, &err))
        fprintf(stderr, "  cornell: %s\n", err.message);
    return s;
}

/* The Cornell box: finite non-negative pixels, the light's pixels equal its
 * radiance (17, 12, 4) exactly up to float rounding (the light has ρ = 0, so
 * all its patches and vertices hold B = E), and the ceiling near the red wall
 * is redder than near the green wall (colour bleeding, >= 5 % in R/G). */
TEST(cornell_image)
{
    rad_solution *s = cornell(0.05);
    CHECK(s != NULL);
    if (!s)
        return;
    rn_camera cam;
    rn_image *img = NULL;
    rad_error err;
    CHECK(rad_camera_from_scene(s->scene, NULL, 128, 128, &cam, &err) == RAD_OK);
    CHECK(rad_render_solution(s, &cam, &img, &err) == RAD_OK);
    if (!img) {
        rad_solution_destroy(s);
        return;
    }
    uint32_t light = rad_scene_find_material(s->scene, "light");
    CHECK(light != RAD_NONE);
    int bad = 0, light_pixels = 0, light_wrong = 0;
    static const double Le[3] = {17, 12, 4};
    for (size_t p = 0; p < (size_t)img->width * img->height; p++) {
        for (int c = 0; c < 3; c++) {
            float v = img->pixels[p * 3 + c];
            bad += !(isfinite(v) && v >= 0);
        }
        uint32_t id = img->patch[p];
        if (id != RAD_NONE && s->mesh->patches[id].material == light) {
            light_pixels++;
            for (int c = 0; c < 3; c++)
                light_wrong += fabs(img->pixels[p * 3 + c] - Le[c]) > 1e-5 * Le[c];
        }
    }
    CHECK(bad == 0);
    CHECK(light_pixels > 0);
    CHECK(light_wrong == 0);

    uint32_t ceiling = rad_scene_find_object(s->scene, "ceiling");
    CHECK(ceiling != RAD_NONE);
    double red_side[3] = {0}, green_side[3] = {0};
    for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        if (p->object != ceiling)
            continue;
        double *acc = p->center.x > 0.45 ? red_side : p->center.x < 0.10 ? green_side : NULL;
        for (int c = 0; acc && c < 3; c++)
            acc[c] += p->area * s->B[(size_t)i * 3 + c];
    }
    double ratio_red = red_side[0] / red_side[1], ratio_green = green_side[0] / green_side[1];
    CHECK_MSG(ratio_red > 1.05 * ratio_green, "R/G near red wall %.4f, near green wall %.4f", ratio_red,
              ratio_green);
    printf("  cornell: %u patches, %d light pixels, ceiling R/G %.3f (red side) vs %.3f (green side)\n",
           s->mesh->patch_count, light_pixels, ratio_red, ratio_green);
    rn_image_destroy(img);
    rad_solution_destroy(s);
}

/* Relight (issue 3): light ×2 doubles every B within 1e-6 relative (the
 * system is linear in E; the tolerance covers the iterative solve's stopping
 * point, which is scale-invariant), light off gives exactly 0, and a
 * reflectance change matches a fresh solve of the changed scene within the
 * solver tolerance without computing a single hemi-cube row. */
TEST(relight_cornell)
{
    rad_solution *s = cornell(0.08);
    CHECK(s != NULL);
    if (!s)
        return;
    size_t nv = (size_t)s->mesh->patch_count * 3;
    double *B1 = malloc(nv * sizeof *B1);
    memcpy(B1, s->B, nv * sizeof *B1);
    rad_error err = {0};
    rad_solve_options opt = {0};
    opt.solver.tolerance = 1e-9;
    CHECK(rad_resolve(s, &opt, &err) == RAD_OK);
    memcpy(B1, s->B, nv * sizeof *B1);

    rad_edit e;
    CHECK(rad_edit_parse(RAD_EDIT_LIGHT, "light=2", &e, &err) == RAD_OK);
    CHECK(rad_solution_apply_edits(s, &e, 1, &err) == RAD_OK);
    CHECK(rad_resolve(s, &opt, &err) == RAD_OK);
    CHECK(s->rows_computed == 0);
    double worst = 0;
    for (size_t k = 0; k < nv; k++)
        if (B1[k] > 0)
            worst = fmax(worst, fabs(s->B[k] / (2 * B1[k]) - 1));
    CHECK_MSG(worst < 1e-6, "light x2: worst relative deviation from 2B %.3g", worst);

    CHECK(rad_edit_parse(RAD_EDIT_LIGHT, "light=off", &e, &err) == RAD_OK);
    CHECK(rad_solution_apply_edits(s, &e, 1, &err) == RAD_OK);
    CHECK(rad_resolve(s, &opt, &err) == RAD_OK);
    double maxb = 0;
    for (size_t k = 0; k < nv; k++)
        maxb = fmax(maxb, s->B[k]);
    CHECK(maxb == 0.0);

    /* Reflectance change vs a fresh solve of the changed scene. */
    CHECK(rad_edit_parse(RAD_EDIT_LIGHT, "light=on", &e, &err) == RAD_OK);
    rad_edit edits[2] = {e};
    CHECK(rad_edit_parse(RAD_EDIT_REFLECTANCE, "white=0.3,0.4,0.5", &edits[1], &err) == RAD_OK);
    CHECK(rad_solution_apply_edits(s, edits, 2, &err) == RAD_OK);
    CHECK(rad_resolve(s, &opt, &err) == RAD_OK);
    CHECK(s->rows_computed == 0);

    rad_scene *scene = NULL;
    CHECK(rad_scene_load("models/cornell.rad", NULL, &scene, &err) == RAD_OK);
    uint32_t white = scene ? rad_scene_find_material(scene, "white") : RAD_NONE;
    CHECK(white != RAD_NONE);
    if (scene && white != RAD_NONE) {
        scene->materials[white].rho[0] = 0.3;
        scene->materials[white].rho[1] = 0.4;
        scene->materials[white].rho[2] = 0.5;
        rad_solve_options fresh_opt = {0};
        fresh_opt.mesh.patch_size = 0.08;
        fresh_opt.solver.tolerance = 1e-9;
        rad_solution *fresh = NULL;
        CHECK(rad_solve_scene(scene, &fresh_opt, &fresh, &err) == RAD_OK);
        if (fresh) {
            CHECK(fresh->mesh->patch_count == s->mesh->patch_count);
            double bmax = 0, dmax = 0;
            for (size_t k = 0; k < nv; k++) {
                bmax = fmax(bmax, fresh->B[k]);
                dmax = fmax(dmax, fabs(fresh->B[k] - s->B[k]));
            }
            /* Same mesh, same rows (deterministic hemi-cubes): only the
             * solver's stopping point differs, 1e-9 relative to max B. */
            CHECK_MSG(dmax <= 1e-7 * bmax, "relit vs fresh: max |dB| %.3g of max B %.3g", dmax, bmax);
            rad_solution_destroy(fresh);
        }
    }
    free(B1);
    rad_solution_destroy(s);
}

/* Gauss-Seidel, Jacobi and progressive on one Cornell matrix agree within
 * 10× the tolerance (relative to max B), as issue 3 asks. */
TEST(three_solvers_agree)
{
    rad_solution *s = cornell(0.08);
    CHECK(s != NULL);
    if (!s)
        return;
    rad_error err = {0};
    rad_solve_options opt = {.all_rows = 1};
    const double tol = 1e-5;
    opt.solver.tolerance = tol;
    size_t nv = (size_t)s->mesh->patch_count * 3;
    double *ref = malloc(nv * sizeof *ref);
    CHECK(rad_resolve(s, &opt, &err) == RAD_OK);
    memcpy(ref, s->B, nv * sizeof *ref);
    double bmax = 0;
    for (size_t k = 0; k < nv; k++)
        bmax = fmax(bmax, ref[k]);
    const sv_method others[2] = {SV_JACOBI, SV_PROGRESSIVE};
    for (int m = 0; m < 2; m++) {
        opt.solver.method = others[m];
        CHECK(rad_resolve(s, &opt, &err) == RAD_OK);
        CHECK(s->rows_computed == 0);
        double d = 0;
        for (size_t k = 0; k < nv; k++)
            d = fmax(d, fabs(s->B[k] - ref[k]));
        CHECK_MSG(d <= 10 * tol * bmax, "%s vs gauss-seidel: max |dB| %.3g, allowed %.3g",
                  sv_method_name(others[m]), d, 10 * tol * bmax);
        printf("  %s vs gauss-seidel: max |dB|/max B = %.2e after %u iterations\n",
               sv_method_name(others[m]), d / bmax, s->iterations);
    }
    free(ref);
    rad_solution_destroy(s);
}

/* A relight whose writing fails leaves the original file intact, and a
 * round trip through the file keeps every radiosity bit-exact. */
TEST(solution_file_round_trip)
{
    rad_solution *s = cornell(0.1);
    CHECK(s != NULL);
    if (!s)
        return;
    char dir[] = "/tmp/radtestXXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[256];
    snprintf(path, sizeof path, "%s/c.sol", dir);
    rad_error err = {0};
    CHECK(rad_solution_write(s, path, &err) == RAD_OK);
    rad_solution *r = NULL;
    CHECK(rad_solution_read(path, &r, &err) == RAD_OK);
    if (r) {
        CHECK(r->mesh->patch_count == s->mesh->patch_count);
        CHECK(memcmp(r->B, s->B, (size_t)s->mesh->patch_count * 3 * sizeof *s->B) == 0);
        CHECK(r->F->rows_done == s->F->rows_done);
        rad_solution_destroy(r);
    }
    char bad[300];
    snprintf(bad, sizeof bad, "%s/missing/c.sol", dir);
    CHECK(rad_solution_write(s, bad, &err) == RAD_ERR_IO);
    unlink(path);
    rmdir(dir);
    rad_solution_destroy(s);
}

/* Economy (issue 6): a grey scene in three bands is solved as one band and
 * gives the same B as the one-band scene (1e-12 relative: the same
 * arithmetic on the same matrix); a black object that does not emit
 * computes no hemi-cube row for its patches. */
TEST(economy_grey_and_black)
{
    char grey3[8192], grey1[8192];
    box_text(grey3, sizeof grey3, 1.0, "material m reflectance 0.6 emission 1", 4);
    box_text(grey1, sizeof grey1, 1.0, "material m reflectance 0.6 emission 1", 4);
    memcpy(grey1, "bands 1", 7);
    rad_solve_options opt = {0};
    rad_solution *a = solve_text(grey3, &opt), *b = solve_text(grey1, &opt);
    CHECK(a && b);
    if (a && b) {
        CHECK(rad_solution_is_grey(a) == 1);
        CHECK(rad_solution_is_grey(b) == 0); /* one band: nothing to save */
        double worst = 0;
        for (uint32_t i = 0; i < a->mesh->patch_count; i++)
            for (int c = 0; c < 3; c++)
                worst = fmax(worst, fabs(a->B[i * 3 + c] / b->B[i] - 1));
        CHECK_MSG(worst <= 1e-12, "grey 3-band vs 1-band: %.3g", worst);
    }
    rad_solution_destroy(a);
    rad_solution_destroy(b);

    const char *text = "bands 3\n"
                       "material white reflectance 0.5\n"
                       "material black reflectance 0\n"
                       "material lamp emission 5\n"
                       "polygon floor white subdivide 4 4\n 0 0 0  0 0 1  1 0 1  1 0 0\nend\n"
                       "polygon rug black subdivide 2 2\n 0.3 0.01 0.3  0.3 0.01 0.7  0.7 0.01 0.7  0.7 0.01 0.3\nend\n"
                       "polygon lamp lamp\n 0.4 1 0.4  0.6 1 0.4  0.6 1 0.6  0.4 1 0.6\nend\n";
    rad_solution *s = solve_text(text, &opt);
    CHECK(s != NULL);
    if (!s)
        return;
    uint32_t rug = rad_scene_find_object(s->scene, "rug"), black_rows = 0, reflecting = 0;
    for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        if (p->object == rug)
            black_rows += s->F->row_done[i];
        reflecting += s->rho[(size_t)i * 3] > 0;
    }
    CHECK(black_rows == 0);
    CHECK(s->rows_computed == reflecting); /* 16 floor rows; the rug and the (black) lamp none */
    printf("  economy: grey scene solved as 1 band; %llu rows for %u patches (rug and lamp skipped)\n",
           (unsigned long long)s->rows_computed, s->mesh->patch_count);
    rad_solution_destroy(s);
}

int main(void)
{
    RUN(furnace_cube);
    RUN(parallel_squares_ff);
    RUN(cornell_image);
    RUN(relight_cornell);
    RUN(three_solvers_agree);
    RUN(solution_file_round_trip);
    RUN(economy_grey_and_black);
    return test_finish("test_pipeline");
}
