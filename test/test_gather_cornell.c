/* test_gather_cornell.c - issue 39's gather item: `render --gather` of the
 * glTF Cornell box at 256 × 256 through its camera against the project's
 * path-traced reference (bench/data/, the regions of bench_cornell), no
 * worse in its worst region and its RMS over the regions than the vertex
 * render of the same solution.  The solution is solved here at the
 * defaults: nearly all of this test's processor time (15.5 s in the release
 * build under a load average of 13, 23 s under ASan), in the hemi-cube
 * workers; the two gathers take 1.9 s of it.
 *
 * What went wrong before (report/gather.md): Ward's cache trusted the
 * harmonic mean distance R_i alone, and on the short block's front, which
 * looks through the open side at a floor half in shadow, a few records
 * with R_i near the scene's size covered the face: 3.6 % off the reference
 * after a 512 × 512 view's cache, 6.4 % at ε = 0.2.  R_i is now bounded by
 * the record's gradient; the ε = 0.2 check guards that.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "cornell_reference.h"
#include "test.h"

#include <time.h>

static rad_solution *solution;
static cref ref;

static void print_score(const char *what, const cref_score *sc, double cpu)
{
    printf("  %-22s worst %.2f %% (%s), RMS %.2f %%", what, 100 * sc->worst,
           sc->worst_at >= 0 ? ref.name[sc->worst_at] : "-", 100 * sc->rms);
    if (cpu >= 0.0)
        printf(", %.2f s CPU", cpu);
    printf("\n");
}

/* A gather of the scene's camera at the reference's size, scored. */
static int gather_score(rn_gather_options o, const char *what, cref_score *sc)
{
    rad_error err = {0};
    rn_camera cam;
    rn_image *img = NULL;
    rn_gather_stats st;
    rad_gather_options go = {.render = o};
    double c0 = (double)clock() / CLOCKS_PER_SEC;
    int rc = rad_camera_from_scene(solution->scene, NULL, ref.side, ref.side, &cam, &err) ||
             rad_render_gather(solution, &cam, &go, &img, &st, &err);
    if (rc) {
        fprintf(stderr, "  %s: %s\n", what, err.message);
        return -1;
    }
    cref_score_image(&ref, img, sc);
    print_score(what, sc, (double)clock() / CLOCKS_PER_SEC - c0);
    rn_image_destroy(img);
    return 0;
}

/* The vertex render and the default gather (ε = 0.1, 256 rays, with
 * gradients); then ε = 0.2, where records are fewest and largest. */
TEST(gather_no_worse_than_vertex_render)
{
    rad_error err = {0};
    rn_camera cam;
    rn_image *img = NULL;
    CHECK(rad_camera_from_scene(solution->scene, NULL, ref.side, ref.side, &cam, &err) == RAD_OK &&
          rad_render_solution(solution, &cam, &img, &err) == RAD_OK);
    if (!img)
        return;
    cref_score v, g, g2;
    cref_score_image(&ref, img, &v);
    rn_image_destroy(img);
    print_score("vertex render", &v, -1.0);
    CHECK(gather_score((rn_gather_options){.threads = 1}, "gather, defaults", &g) == 0);
    CHECK(gather_score((rn_gather_options){.epsilon = 0.2, .threads = 1}, "gather, eps 0.2", &g2) ==
          0);
    for (int k = 0; k < ref.count; k++)
        printf("  %-32s vertex %+.2f %%  gather %+.2f %%  eps 0.2 %+.2f %%\n", ref.name[k],
               100 * v.err[k], 100 * g.err[k], 100 * g2.err[k]);
    /* No worse than the vertex render, within three times the reference's
     * own standard error (about 0.05 % a region, bench/data): both are now
     * near that floor.  Measured (2026-12-08): vertex 0.33 % (tall block
     * side) / 0.18 %, gather 0.36 % (short block front) / 0.15 %.  With
     * whole contact hemi-cubes, this machine gave vertex 0.30 % / 0.17 %,
     * gather 0.35 % / 0.15 %: the gather 0.05 % above, where the machine
     * of 2026-12-07 had it below. */
    const double noise = 3 * 0.0005;
    CHECK_MSG(g.worst <= v.worst + noise && g.rms <= v.rms + noise,
              "gather %.4f / %.4f, vertex %.4f / %.4f", g.worst, g.rms, v.worst, v.rms);
    /* The vertex render's figures, so that neither bound drifts with it. */
    CHECK_MSG(g.worst < 0.0095 && g.rms < 0.0041, "gather %.4f / %.4f", g.worst, g.rms);
    /* Measured 0.66 % / 0.34 % (6.37 % / 1.91 % before R_i was bounded by
     * the gradient). */
    CHECK_MSG(g2.worst < 0.0095 && g2.rms < 0.0041, "eps 0.2: %.4f / %.4f", g2.worst, g2.rms);
}

/* The vertex render's score of a solution. */
static int vertex_score(const rad_solution *s, cref_score *sc)
{
    rad_error err = {0};
    rn_camera cam;
    rn_image *img = NULL;
    if (rad_camera_from_scene(s->scene, NULL, ref.side, ref.side, &cam, &err) ||
        rad_render_solution(s, &cam, &img, &err)) {
        fprintf(stderr, "  render: %s\n", err.message);
        return -1;
    }
    cref_score_image(&ref, img, sc);
    rn_image_destroy(img);
    return 0;
}

/* Contact elements by near views (the default: the patches within 4 × the
 * patch's size drawn, the rest from the patch's row) against whole
 * hemi-cubes (--whole-contacts): each region's error against the
 * reference moves by at most NEAR_REGION_TOL, and the near views' worst
 * region stays within NEAR_WORST_TOL of the whole hemi-cubes' worst.
 * Measured (2026-12-08): 1,454 near views of 1,802 element hemi-cubes;
 * largest move 0.21 % (short block front, +0.32 % against +0.11 %), worst
 * 0.33 % against 0.30 %, RMS 0.18 % against 0.17 %. */
#define NEAR_REGION_TOL 0.005
#define NEAR_WORST_TOL 0.001
TEST(near_views_agree_with_whole_hemicubes)
{
    rad_solve_options opt = {.whole_contacts = 1};
    rad_error err = {0};
    rad_solution *whole = NULL;
    CHECK(rad_solve_scene_file("models/cornell.gltf", &opt, &whole, &err) == RAD_OK);
    if (!whole)
        return;
    CHECK(solution->elements && whole->elements);
    if (!solution->elements || !whole->elements) {
        rad_solution_destroy(whole);
        return;
    }
    printf("  near views %llu of %llu element hemi-cubes; whole: %llu of %llu\n",
           (unsigned long long)solution->elements->near_views,
           (unsigned long long)solution->elements->rows_computed,
           (unsigned long long)whole->elements->near_views,
           (unsigned long long)whole->elements->rows_computed);
    CHECK(solution->elements->near_views > 0 && whole->elements->near_views == 0);
    cref_score n, w;
    CHECK(vertex_score(solution, &n) == 0 && vertex_score(whole, &w) == 0);
    double most = 0.0;
    for (int k = 0; k < ref.count; k++) {
        printf("  %-32s near views %+.2f %%  whole %+.2f %%\n", ref.name[k], 100 * n.err[k],
               100 * w.err[k]);
        most = fmax(most, fabs(n.err[k] - w.err[k]));
    }
    printf("  worst %.2f %% / %.2f %%, RMS %.2f %% / %.2f %%, largest move %.2f %%\n",
           100 * n.worst, 100 * w.worst, 100 * n.rms, 100 * w.rms, 100 * most);
    CHECK_MSG(most <= NEAR_REGION_TOL, "a region moved by %.4f", most);
    CHECK_MSG(n.worst <= w.worst + NEAR_WORST_TOL, "worst %.4f against %.4f", n.worst, w.worst);
    rad_solution_destroy(whole);
}

int main(void)
{
    if (cref_load(&ref)) {
        printf("FAIL reference\n");
        return test_finish("test_gather_cornell") | 1;
    }
    rad_solve_options opt = {0}; /* the defaults, as bench_cornell's "defaults" row */
    rad_error err = {0};
    if (rad_solve_scene_file("models/cornell.gltf", &opt, &solution, &err)) {
        fprintf(stderr, "  solve: %s\n", err.message);
        printf("FAIL solve\n");
        cref_free(&ref);
        return 1;
    }
    RUN(gather_no_worse_than_vertex_render);
    RUN(near_views_agree_with_whole_hemicubes);
    rad_solution_destroy(solution);
    cref_free(&ref);
    return test_finish("test_gather_cornell");
}
