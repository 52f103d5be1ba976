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
    /* Measured: vertex 0.95 % (tall block front) / 0.41 %; gather 0.69 %
     * (short block front, where the uncached gather is 0.60 %: the B it
     * reads) / 0.28 %. */
    CHECK_MSG(g.worst <= v.worst && g.rms <= v.rms, "gather %.4f / %.4f, vertex %.4f / %.4f",
              g.worst, g.rms, v.worst, v.rms);
    /* The vertex render's figures, so that neither bound drifts with it. */
    CHECK_MSG(g.worst < 0.0095 && g.rms < 0.0041, "gather %.4f / %.4f", g.worst, g.rms);
    /* Measured 0.66 % / 0.34 % (6.37 % / 1.91 % before R_i was bounded by
     * the gradient). */
    CHECK_MSG(g2.worst < 0.0095 && g2.rms < 0.0041, "eps 0.2: %.4f / %.4f", g2.worst, g2.rms);
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
    rad_solution_destroy(solution);
    cref_free(&ref);
    return test_finish("test_gather_cornell");
}
