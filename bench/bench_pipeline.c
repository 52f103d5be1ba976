/* bench_pipeline.c - the end-to-end table of issue 2: the bundled Cornell box
 * at about 500, 2,000 and 8,000 patches, R = 128, one row per size and one
 * column per stage (load, mesh, form factors, solve, render 512×512), plus
 * form-factor rows per second and peak memory (this process and, separately,
 * the largest hemi-cube worker).
 *
 * The patch size for each target count is found by bisection on
 * rad_mesh_count, so the table's sizes are the nearest the mesher makes.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "bench_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

int main(int argc, char **argv)
{
    const char *model = argc > 1 ? argv[1] : "models/cornell.rad";
    uint32_t targets[] = {500, 2000, 8000};
    uint32_t processes = argc > 2 ? (uint32_t)atoi(argv[2]) : 0;
    printf("Cornell box (%s), R = 128, Gauss-Seidel tolerance 1e-4, render 512x512, %s worker processes\n\n",
           model, processes ? argv[2] : "all-CPU");
    printf("| patches | load s | mesh s | form factors s | solve s | render s | rows/s | peak MiB (main) | peak MiB (worker) |\n");
    printf("|--------:|-------:|-------:|---------------:|--------:|---------:|-------:|----------------:|------------------:|\n");
    for (size_t t = 0; t < sizeof targets / sizeof targets[0]; t++) {
        rad_error err = {0};
        double t0 = rad_seconds();
        rad_scene *scene = NULL;
        if (rad_scene_load(model, NULL, &scene, &err)) {
            fprintf(stderr, "bench: %s\n", err.message);
            return 1;
        }
        double load = rad_seconds() - t0;
        rad_solve_options opt = {0};
        opt.mesh.patch_size = bench_patch_size_for(scene, targets[t]);
        opt.hemicube.resolution = 128;
        opt.hemicube.processes = processes;
        rad_solution *s = NULL;
        if (rad_solve_scene(scene, &opt, &s, &err)) {
            fprintf(stderr, "bench: %s\n", err.message);
            return 1;
        }
        rn_camera cam;
        rn_image *img = NULL;
        t0 = rad_seconds();
        if (rad_camera_from_scene(s->scene, NULL, 512, 512, &cam, &err) ||
            rad_render_solution(s, &cam, &img, &err)) {
            fprintf(stderr, "bench: %s\n", err.message);
            return 1;
        }
        double render = rad_seconds() - t0;
        rn_image_destroy(img);
        struct rusage self, kids;
        getrusage(RUSAGE_SELF, &self);
        getrusage(RUSAGE_CHILDREN, &kids);
        double ff = s->stages[RAD_STAGE_FORM_FACTORS].seconds;
        printf("| %7u | %6.3f | %6.3f | %14.3f | %7.3f | %8.3f | %6.0f | %15.0f | %17.0f |\n",
               s->mesh->patch_count, load, s->stages[RAD_STAGE_MESH].seconds, ff,
               s->stages[RAD_STAGE_SOLVE].seconds, render, ff > 0 ? s->rows_computed / ff : 0.0,
               self.ru_maxrss / 1024.0, kids.ru_maxrss / 1024.0);
        fflush(stdout);
        rad_solution_destroy(s);
    }
    return 0;
}
