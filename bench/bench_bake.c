/* bench_bake.c - what `radiosity bake` costs (issue 37): the time to write
 * a solved scene as glTF and the file's size, for the Cornell box
 * (models/cornell.gltf, the program's defaults) and for the largest bench
 * scene, tools/hall.c's vaulted hall (about 99,000 triangles) solved as
 * bench_scale's coarsest row (patch size 0.6, defaults otherwise; a
 * smaller hemi-cube resolution R may be given to spare a shared machine:
 * it changes the light, hardly the count of elements baked).
 *
 *   bench_bake [hall patch size [R]]   (default 0.6, R 64: the report's row)
 *   BENCH_BAKE_FINE=f              the hall's tessellation factor (default 1)
 *
 * Each scene is solved once (its time is given, not the subject), then
 * baked five times to .glb and five times to .gltf + .bin in a temporary
 * directory; the table gives the fastest of each (a shared machine slows
 * some runs: the load average is printed before and after).  Nothing here
 * asserts anything.
 */
#include "../radiosity/bake/bake.h"
#include "../radiosity/pipeline/pipeline.h"
#include "../tools/hall.h"
#include "bench_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

/* The fastest of five bakes of s to path; *st from the last. */
static int best_bake(const rad_solution *s, const char *path, double *best, rad_bake_stats *st)
{
    *best = 1e30;
    for (int k = 0; k < 5; k++) {
        rad_error err = {0};
        double t0 = rad_seconds();
        if (rad_bake_write(s, path, NULL, st, &err)) {
            fprintf(stderr, "bench_bake: %s\n", err.message);
            return -1;
        }
        double t = rad_seconds() - t0;
        *best = t < *best ? t : *best;
    }
    return 0;
}

/* Solves scene, bakes it into dir, prints one row; 0 or -1. */
static int row(const char *name, const char *scene, double patch_size, uint32_t R,
               const char *dir)
{
    rad_solve_options opt = {0};
    opt.mesh.patch_size = patch_size;
    opt.hemicube.resolution = R;
    rad_solution *s = NULL;
    rad_error err = {0};
    double t0 = rad_seconds();
    if (rad_solve_scene_file(scene, &opt, &s, &err)) {
        fprintf(stderr, "bench_bake: %s\n", err.message);
        return -1;
    }
    double solve_s = rad_seconds() - t0, glb_s, gltf_s;
    char glb[4200], gltf[4200], bin[4200];
    snprintf(glb, sizeof glb, "%s/%s.glb", dir, name);
    snprintf(gltf, sizeof gltf, "%s/%s.gltf", dir, name);
    snprintf(bin, sizeof bin, "%s/%s.bin", dir, name);
    rad_bake_stats a, b;
    int rc = best_bake(s, glb, &glb_s, &a) || best_bake(s, gltf, &gltf_s, &b) ? -1 : 0;
    if (!rc)
        printf("| %s | %u | %u | %.1f | %llu | %llu | %.2f | %.3f | %.3f | %.2f | %.1f |\n", name,
               s->mesh->patch_count, s->elements ? s->elements->mesh->patch_count : 0, solve_s,
               (unsigned long long)a.vertices, (unsigned long long)a.triangles, a.exposure, glb_s,
               gltf_s, (double)a.bytes / 1048576.0,
               (double)(a.bytes - 12 * a.triangles) / (double)(a.vertices ? a.vertices : 1));
    fflush(stdout);
    unlink(glb);
    unlink(gltf);
    unlink(bin);
    rad_solution_destroy(s);
    return rc;
}

int main(int argc, char **argv)
{
    double size = argc > 1 ? atof(argv[1]) : 0.6;
    uint32_t R = argc > 2 ? (uint32_t)atoi(argv[2]) : 64;
    const char *fine_env = getenv("BENCH_BAKE_FINE");
    char dir[] = "/tmp/bench_bake.XXXXXX";
    if (!mkdtemp(dir)) {
        perror("bench_bake: mkdtemp");
        return 1;
    }
    hall_stats hs;
    int rc = hall_write(dir, "hall", fine_env ? atof(fine_env) : 1.0, &hs);
    bench_print_load("before");
    printf("\n| scene | patches | elements | solve s | vertices | triangles | auto EV | "
           ".glb s | .gltf + .bin s | .glb MiB | bytes a vertex beside 12 a triangle |\n"
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    const char *cornell = access("models/cornell.gltf", R_OK) ? "../models/cornell.gltf"
                                                              : "models/cornell.gltf";
    if (!rc)
        rc = row("cornell", cornell, 0.0, 0, dir);
    char scene[4200];
    snprintf(scene, sizeof scene, "%s/hall.gltf", dir);
    if (!rc)
        rc = row("hall", scene, size, R, dir);
    printf("\nhall: %llu triangles in %u objects, patch size %.3g, R = %u\n",
           (unsigned long long)hs.triangles, hs.objects, size, R ? R : HC_DEFAULT_RESOLUTION);
    bench_print_load("after");
    snprintf(scene, sizeof scene, "%s/hall.gltf", dir);
    unlink(scene);
    snprintf(scene, sizeof scene, "%s/hall.bin", dir);
    unlink(scene);
    rmdir(dir);
    return rc ? 1 : 0;
}
