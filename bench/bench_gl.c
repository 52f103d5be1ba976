/* bench_gl.c - rows per second through the hemi-cube's two GL back ends
 * (issue 38): OSMesa and EGL, on the same mesh, the same resolution and
 * the same worker count.
 *
 * models/cornell.rad meshed into about `patches` patches; every row at
 * R = 128, with 1 and 2 worker processes, through each back end, each run
 * `repeat` times in turn (OSMesa, EGL, OSMesa, ...) so a change in the
 * machine's load falls on both.  Printed: the engine's start-up (forking
 * the workers, loading the library, the context, the geometry upload), the
 * best and the median rows/s of the runs, and the workers' CPU seconds per
 * row (reaped, so start-up included).  On a machine without a GPU both
 * back ends are llvmpipe and should draw at one speed; the line
 * `EGL renderer` says what EGL drew with.
 *
 *   bench_gl [patches] [repeat]      (default 2000 and 3)
 */
#include "../hemicube/hemicube.h"
#include "../radiosity/mesh/mesh.h"
#include "../radiosity/scene/scene.h"
#include "bench_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>

#define BENCH_MAX_REPEAT 9

static double children_cpu(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_CHILDREN, &ru) != 0)
        return 0.0;
    return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* One run: start an engine, compute every row, stop it.  Seconds of
 * start-up and of rows into *start, *rows; the workers' CPU into *cpu. */
static int run(const rad_mesh *m, const uint32_t *all, hc_gl_kind gl, uint32_t procs,
               double *start, double *rows, double *cpu)
{
    rad_error err = {0};
    rad_matrix *F = rad_matrix_create(m->patch_count);
    hc_engine *e = NULL;
    hc_options o = {.resolution = 128, .processes = procs, .gl = gl};
    double c0 = children_cpu(), t0 = rad_seconds();
    int rc = F ? hc_create(m, &o, &e, &err) : RAD_ERR_NOMEM;
    double t1 = rad_seconds();
    if (rc == RAD_OK)
        rc = hc_compute_rows(e, all, m->patch_count, F, &err);
    double t2 = rad_seconds();
    hc_destroy(e);
    rad_matrix_destroy(F);
    if (rc != RAD_OK) {
        fprintf(stderr, "bench_gl: %s: %s\n", hc_gl_name(gl), err.message);
        return -1;
    }
    *start = t1 - t0, *rows = t2 - t1, *cpu = children_cpu() - c0;
    return 0;
}

int main(int argc, char **argv)
{
    uint32_t target = argc > 1 ? (uint32_t)strtoul(argv[1], NULL, 10) : 2000;
    int repeat = argc > 2 ? atoi(argv[2]) : 3;
    repeat = repeat < 1 ? 1 : repeat > BENCH_MAX_REPEAT ? BENCH_MAX_REPEAT : repeat;
    rad_error err = {0};
    rad_scene *scene = NULL;
    rad_mesh *m = NULL;
    if (rad_scene_load("models/cornell.rad", NULL, &scene, &err) != RAD_OK) {
        fprintf(stderr, "bench_gl: %s\n", err.message);
        return 1;
    }
    rad_mesh_options mo = {.patch_size = bench_patch_size_for(scene, target)};
    uint32_t *all = NULL;
    if (rad_mesh_build(scene, &mo, &m, &err) != RAD_OK ||
        !(all = malloc(m->patch_count * sizeof *all))) {
        fprintf(stderr, "bench_gl: %s\n", err.message[0] ? err.message : "out of memory");
        return 1;
    }
    for (uint32_t k = 0; k < m->patch_count; k++)
        all[k] = k;
    hc_gl_choice c;
    if (hc_gl_choose(HC_GL_EGL, &c, &err) != RAD_OK) {
        fprintf(stderr, "bench_gl: %s\n", err.message);
        return 1;
    }
    printf("models/cornell.rad, %u patches, R = 128, every row, %d runs each, alternating\n",
           m->patch_count, repeat);
    printf("EGL renderer: %s\n\n", c.renderer);
    printf("%-7s %5s %10s %13s %13s %14s\n", "GL", "procs", "start s", "best rows/s",
           "median rows/s", "worker ms/row");
    for (uint32_t procs = 1; procs <= 2; procs++) {
        double start[2][BENCH_MAX_REPEAT], rate[2][BENCH_MAX_REPEAT], cpu[2] = {0, 0};
        for (int r = 0; r < repeat; r++)
            for (int g = 0; g < 2; g++) {
                double s, t, u;
                if (run(m, all, g ? HC_GL_EGL : HC_GL_OSMESA, procs, &s, &t, &u) != 0)
                    return 1;
                start[g][r] = s, rate[g][r] = m->patch_count / t, cpu[g] += u;
            }
        for (int g = 0; g < 2; g++) {
            qsort(start[g], (size_t)repeat, sizeof(double), by_value);
            qsort(rate[g], (size_t)repeat, sizeof(double), by_value);
            printf("%-7s %5u %10.3f %13.0f %13.0f %14.3f\n", g ? "egl" : "osmesa", procs,
                   start[g][repeat / 2], rate[g][repeat - 1], rate[g][repeat / 2],
                   1e3 * cpu[g] / ((double)repeat * m->patch_count));
        }
    }
    free(all);
    rad_mesh_destroy(m);
    rad_scene_destroy(scene);
    return 0;
}
