/* test_catalog.c - issue 39: form factors where the hemi-cube's pixel
 * count is weak (thin, far and nearly touching pairs), against closed
 * forms, at the defaults of `ff` and at the accurate setting.
 *
 * The references are closed forms (analytic.c: Howell C-11, C-14, the
 * general parallel-rectangle superposition, the 32-gons' own contour
 * integral), never a run of the hemi-cube.  The pairs and meshes are
 * rad_validate_catalog's (the default patch size: the scene's diagonal /
 * 24; disks 4 per fan side).  Each bound is written beside the error
 * measured when it was set: about 2.5 times it, never above the issue's
 * 1 % (defaults) and 0.1 % (accurate) for a pair within them, never below
 * 2e-4 (a pixel's worth of rounding in the pixel-counted remainder).
 * These are F_AB queries, computed as `ff` computes them
 * (hc_options.weak HC_WEAK_SURFACE: F_AB is an area average over A), not
 * with a solve's collocation rows (docs/limits.md).
 */
#include "../hemicube/hemicube.h"
#include "../radiosity/validate/validate.h"
#include "test.h"

/* The catalog's cases in rad_validate_catalog's order, with the relative
 * error measured at the defaults (R = 128; before HC_WEAK_SURFACE six were
 * over 1 %: strips at 1 +1.03 %, plates 0.2 x 3 +1.48 %, 3 x 0.2 +1.89 %,
 * 5 x 0.5 +2.12 %, the 1 x 2 x 3 box's ceiling +3.01 %, beside -1.88 %). */
static const struct {
    const char *what;
    double measured;
} at_defaults[] = {
    {"squares, gap 0.05", -2.51e-03},
    {"squares, gap 0.1", -3.44e-03},
    {"squares, gap 0.2", +8.02e-04},
    {"squares, gap 0.5", +6.88e-04},
    {"squares, gap 1", -4.53e-04},
    {"squares, gap 2", +6.30e-04},
    {"squares, gap 5", +5.07e-04},
    {"squares, gap 10", +3.66e-04},
    {"squares, gap 20", +2.08e-04},
    {"strips, gap 1", +6.51e-03},
    {"strips, gap 2", +1.72e-03},
    {"strips, gap 5", -1.18e-03},
    {"strips, gap 10", +6.51e-04},
    {"strips, gap 20", +3.68e-04},
    {"plates 0.2 x 3", +3.48e-03},
    {"plates 0.5 x 2", +2.67e-03},
    {"plates 1 x 1", +2.56e-03},
    {"plates 3 x 0.2", -3.02e-03},
    {"plates 5 x 0.5", -1.90e-03},
    {"disks r/h 0.5", +8.68e-04},
    {"disks r/h 1", +1.28e-03},
    {"disks r/h 2", -3.16e-03},
    {"disks 0.5, 1, gap 0.5", +4.35e-04},
    {"box 1x2x3 ceiling", +6.07e-04},
    {"box 1x1x1 ceiling", -1.06e-03},
    {"box 3x2x1 ceiling", +8.42e-04},
    {"box 1x2x3 wall", +1.34e-03},
    {"box 3x1x0.5 wall", -3.31e-04},
    {"overlap 0.5", +1.02e-03},
    {"overlap 0.5,0.5 gap 0.2", -6.37e-03},
    {"corner to corner", -2.13e-03},
    {"beside", -2.22e-04},
};

/* 2.5 times the measured error, at least 2e-4 (a pixel's worth of
 * rounding), at most the 1 % (cap). */
static double bound_of(double measured, double cap)
{
    const double b = 2.5 * fabs(measured);
    return b < 2e-4 ? 2e-4 : b > cap ? cap : b;
}

/* The general parallel-rectangle form against what it must equal: C-11
 * when the rectangles face each other squarely, the sum of its parts when
 * the target is cut in two (superposition), and reciprocity. */
TEST(offset_closed_form)
{
    CHECK_NEAR(hc_ff_parallel_offset(0, 1, 0, 1, 0, 1, 0, 1, 1), 0.19982490, 5e-9);
    CHECK_REL(hc_ff_parallel_offset(0, 2, 0, 1, 0, 2, 0, 1, 0.5), hc_ff_parallel_rectangles(2, 1, 0.5),
              1e-12);
    double whole = hc_ff_parallel_offset(0, 1, 0, 1, 0.3, 2.3, -0.2, 0.9, 0.4);
    double parts = hc_ff_parallel_offset(0, 1, 0, 1, 0.3, 1.1, -0.2, 0.9, 0.4) +
                   hc_ff_parallel_offset(0, 1, 0, 1, 1.1, 2.3, -0.2, 0.9, 0.4);
    CHECK_REL(whole, parts, 1e-12);
    /* A_1 F_12 = A_2 F_21 (areas 1 and 2.2) */
    CHECK_REL(1.0 * whole, 2.2 * hc_ff_parallel_offset(0.3, 2.3, -0.2, 0.9, 0, 1, 0, 1, 0.4), 1e-12);
    CHECK(isnan(hc_ff_parallel_offset(0, 1, 0, 1, 0, 1, 0, 1, 0)));
    CHECK(isnan(hc_ff_parallel_offset(1, 0, 0, 1, 0, 1, 0, 1, 1)));
}

/* Every catalog pair at the defaults within its own bound, all 32 within
 * the 1 % (worst measured: strips one width apart +6.5e-3). */
TEST(catalog_at_defaults)
{
    rad_validate_options o = {.catalog = 1, .processes = 2};
    rad_val_result *r = NULL;
    uint32_t n = 0;
    rad_error err = {0};
    int rc = rad_validate_run(&o, &r, &n, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    const uint32_t ne = (uint32_t)(sizeof at_defaults / sizeof at_defaults[0]);
    CHECK(n == ne);
    double worst = 0.0, seconds = 0.0;
    for (uint32_t k = 0; rc == RAD_OK && k < n && k < ne; k++) {
        const double b = bound_of(at_defaults[k].measured, 0.01);
        worst = fmax(worst, fabs(r[k].rel_error));
        seconds += r[k].seconds;
        CHECK(r[k].c.engine == RAD_VAL_DEFAULTS && r[k].promised == 0.01);
        CHECK_MSG(fabs(r[k].rel_error) <= b, "%s (%s): %.3g, bound %.3g (measured %.3g)", r[k].name,
                  at_defaults[k].what, r[k].rel_error, b, at_defaults[k].measured);
    }
    printf("     %u pairs at the defaults: worst %.2e, %.1f s\n", n, worst, seconds);
    free(r);
}

/* The accurate setting (HC_WEAK_HIGH, `--accuracy high`): the pairs that
 * were worst by pixel counts, within 0.1 % (issue 39).  Measured: squares
 * at 0.05 -4.8e-08, plates 0.2 × 3 -2.2e-05, strips at 5 -2.7e-09, the
 * 1 × 2 × 3 box floor to wall +1.3e-06, plates 1 × 1 +5.5e-08.  The pairs of
 * this test take about 2 s; the whole catalog about twice the defaults. */
TEST(catalog_accurate)
{
    const rad_val_case t[] = {
        {.config = RAD_VAL_PARALLEL, .a = 1, .b = 1, .c = 0.05},
        {.config = RAD_VAL_PERPENDICULAR, .a = 1, .b = 0.2, .c = 3},
        {.config = RAD_VAL_PARALLEL, .a = 10, .b = 1, .c = 5},
        {.config = RAD_VAL_BOX_WALL, .a = 1, .b = 2, .c = 3},
        {.config = RAD_VAL_PERPENDICULAR, .a = 1, .b = 1, .c = 1},
    };
    for (size_t k = 0; k < sizeof t / sizeof t[0]; k++) {
        rad_val_case c = t[k];
        c.engine = RAD_VAL_ACCURATE;
        c.processes = 2;
        rad_val_result r;
        rad_error err = {0};
        int rc = rad_validate_case(&c, &r, &err);
        CHECK_MSG(rc == RAD_OK, "%s", err.message);
        if (rc)
            continue;
        printf("     accurate: %-44s %+.2e\n", r.name, r.rel_error);
        CHECK_MSG(fabs(r.rel_error) <= 1e-4, "%s: %.3g", r.name, r.rel_error);
    }
}

int main(void)
{
    RUN(offset_closed_form);
    RUN(catalog_at_defaults);
    RUN(catalog_accurate);
    return test_finish("test_catalog");
}
