/* bench_views.c - many views in one `render` call against one view (issue
 * 21: ten views in one call should cost at most 3 × one view).
 *
 * Runs the `radiosity` program itself (argv[1], else $RADIOSITY_BIN, else
 * build/release/radiosity), so each time is a whole command: start, load,
 * preparing the drawing, drawing, writing the files.  Three solutions:
 *   - the Cornell box at about 2,000 and 8,000 patches, solved for real
 *     (F stored, and read whole by `render`: the table gives the file size);
 *   - the Cornell box meshed at about 32,000 patches with a smooth synthetic
 *     B and no rows of F: what the 32k-patch case costs to draw, with next
 *     to nothing to load, the hardest case for the ratio.
 * One view is `render SOL -o DIR/one.exr --eye .. --target ..`, ten views
 * are `render SOL -o DIR --path ten.txt` (an orbit; its first view is the
 * one view), on 1 thread and on the default threads (one per CPU,
 * rad_view_threads).  Each is run three times and the
 * fastest wall time kept (the machine is shared); CPU is user + system
 * time of that run, peak RSS the largest of the three.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "bench_util.h"

#include <fcntl.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>


static int fail(const char *what, const rad_error *err)
{
    fprintf(stderr, "bench_views: %s: %s\n", what, err ? err->message : "failed");
    return 1;
}

/* The Cornell box at about `target` patches: solved, or (synthetic) with
 * B = E + a smooth falloff from the lamp and no rows. */
static int make_solution(const char *model, uint32_t target, int synthetic, const char *path,
                         uint32_t *patches)
{
    rad_error err = {0};
    rad_scene *scene = NULL;
    if (rad_scene_load(model, NULL, &scene, &err))
        return fail(model, &err);
    rad_solve_options opt = {0};
    opt.mesh.patch_size = bench_patch_size_for(scene, target);
    rad_solution *s = NULL;
    if (!synthetic) {
        opt.hemicube.resolution = 128;
        if (rad_solve_scene(scene, &opt, &s, &err))
            return fail("solve", &err);
    } else {
        rad_mesh *mesh = NULL;
        if (rad_mesh_build(scene, &opt.mesh, &mesh, &err))
            return fail("mesh", &err);
        if (rad_solution_create(scene, mesh, &s, &err))
            return fail("solution", &err);
        rad_vec3 lo, hi;
        rad_scene_bounds(s->scene, &lo, &hi);
        rad_vec3 lamp = rad_v3(0.5 * (lo.x + hi.x), hi.y, 0.5 * (lo.z + hi.z));
        double d2 = rad_dot(rad_sub(hi, lo), rad_sub(hi, lo));
        for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
            rad_vec3 d = rad_sub(s->mesh->patches[i].center, lamp);
            for (uint32_t b = 0; b < s->band_count; b++)
                s->B[(size_t)i * s->band_count + b] += (3.0 - b) / (1.0 + 8.0 * rad_dot(d, d) / d2);
        }
    }
    *patches = s->mesh->patch_count;
    int rc = rad_solution_write(s, path, &err);
    rad_solution_destroy(s);
    return rc ? fail(path, &err) : 0;
}

typedef bench_run run_stats;

/* Runs argv three times; the fastest wall time, its CPU, the largest RSS. */
static int measure(char *const argv[], run_stats *out)
{
    *out = (run_stats){INFINITY, 0, 0};
    for (int rep = 0; rep < 3; rep++) {
        bench_run r;
        if (bench_spawn(argv, NULL, &r) != 0)
            return 1;
        if (r.wall < out->wall) {
            out->wall = r.wall;
            out->cpu = r.cpu;
        }
        if (r.peak_mib > out->peak_mib)
            out->peak_mib = r.peak_mib;
    }
    return 0;
}

/* Ten views orbiting the box's centre at the distance the default camera
 * would take; view 1 is also the single view. */
static int write_path(const char *sol, const char *path, rad_vec3 *eye0, rad_vec3 *target)
{
    rad_error err = {0};
    rad_solution *s = NULL;
    if (rad_solution_read(sol, &s, &err))
        return fail(sol, &err);
    rad_vec3 lo, hi;
    rad_scene_bounds(s->scene, &lo, &hi);
    rad_solution_destroy(s);
    rad_vec3 c = rad_scale(rad_add(lo, hi), 0.5), d = rad_sub(hi, lo);
    FILE *f = fopen(path, "w");
    if (!f)
        return fail(path, NULL);
    for (int k = 0; k < 10; k++) {
        double a = 0.6 * (k / 9.0 - 0.5); /* ±17° about the open side (-z) */
        rad_vec3 e = rad_add(c, rad_v3(1.2 * d.x * sin(a), 0.1 * d.y * cos(3 * a), -1.3 * d.z * cos(a)));
        fprintf(f, "eye %.9g,%.9g,%.9g target %.9g,%.9g,%.9g fov 50\n", e.x, e.y, e.z, c.x, c.y, c.z);
        if (k == 0)
            *eye0 = e;
    }
    *target = c;
    return fclose(f) ? fail(path, NULL) : 0;
}

/* What a case needs from its solution: made (make_solution) and its path
 * written (write_path) in a child process, so that this one stays small: a
 * spawned command's peak RSS starts from its parent's (Linux keeps the
 * old address space's high-water mark across exec). */
typedef struct prepared {
    uint32_t patches;
    rad_vec3 eye, target;
} prepared;

static int prepare_apart(const char *model, uint32_t target, int synthetic, const char *sol,
                         const char *path, prepared *out)
{
    int fd[2];
    if (pipe(fd))
        return fail("pipe", NULL);
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0)
        return fail("fork", NULL);
    if (pid == 0) {
        close(fd[0]);
        prepared p = {0};
        int rc = make_solution(model, target, synthetic, sol, &p.patches) ||
                 write_path(sol, path, &p.eye, &p.target);
        _exit(rc || write(fd[1], &p, sizeof p) != (ssize_t)sizeof p);
    }
    close(fd[1]);
    ssize_t got = read(fd[0], out, sizeof *out);
    close(fd[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    return got == (ssize_t)sizeof *out && WIFEXITED(status) && !WEXITSTATUS(status) ? 0 : 1;
}

static double cpu_seconds(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_utime.tv_sec + 1e-6 * ru.ru_utime.tv_usec + ru.ru_stime.tv_sec +
           1e-6 * ru.ru_stime.tv_usec;
}

/* Where one call's time goes, in this process, on one thread (CPU seconds,
 * so other work on the machine matters less): reading the solution,
 * preparing the drawing, and per view (mean of ten, one canvas) drawing,
 * writing the EXR and writing the PNG, at 1024². */
static int per_view_costs(const char *dir, const char *name)
{
    char sol[512], exr[512], png[512];
    snprintf(sol, sizeof sol, "%s/%s", dir, name);
    snprintf(exr, sizeof exr, "%s/cost.exr", dir);
    snprintf(png, sizeof png, "%s/cost.png", dir);
    rad_error err = {0};
    rad_solution *s = NULL;
    rad_drawing *d = NULL;
    rn_canvas *c = rn_canvas_create();
    double t0 = cpu_seconds();
    if (!c || rad_solution_read(sol, &s, &err))
        return fail(sol, &err);
    double t1 = cpu_seconds();
    if (rad_drawing_create(s, &d, &err))
        return fail("drawing", &err);
    double t2 = cpu_seconds(), draw = 0, write_exr = 0, write_raw = 0, write_png = 0;
    rn_camera cam;
    if (rad_camera_from_scene(s->scene, NULL, 1024, 1024, &cam, &err))
        return fail("camera", &err);
    for (int k = 0; k < 10; k++) {
        rn_image *img = NULL;
        double a = cpu_seconds();
        if (rad_drawing_draw(d, c, &cam, &img, &err))
            return fail("draw", &err);
        double b = cpu_seconds();
        if (rn_write_exr_with(img, exr, RN_EXR_ZIP, &err))
            return fail(exr, &err);
        double e = cpu_seconds();
        if (rn_write_exr(img, exr, &err)) /* the default: none */
            return fail(exr, &err);
        double f = cpu_seconds();
        if (rn_write_png(img, png, 0.0, &err))
            return fail(png, &err);
        draw += b - a;
        write_exr += e - b;
        write_raw += f - e;
        write_png += cpu_seconds() - f; /* img is the canvas's own */
    }
    printf("\nwhere the time goes (%u patches, 1024x1024, CPU s in one process): read %.3f, "
           "prepare the drawing %.3f;\nper view (mean of 10, one canvas): draw %.3f, EXR %.3f (ZIP) "
           "or %.3f (none), PNG %.3f\n",
           s->mesh->patch_count, t1 - t0, t2 - t1, draw / 10, write_exr / 10, write_raw / 10,
           write_png / 10);
    rn_canvas_destroy(c);
    rad_drawing_destroy(d);
    rad_solution_destroy(s);
    return 0;
}

int main(int argc, char **argv)
{
    const char *bin = argc > 1 ? argv[1] : getenv("RADIOSITY_BIN");
    if (!bin)
        bin = "build/release/radiosity";
    const char *model = "models/cornell.rad";
    char dir[] = "/tmp/bench_views_XXXXXX";
    if (!mkdtemp(dir))
        return fail("mkdtemp", NULL);
    struct {
        uint32_t target;
        int synthetic;
        const char *what;
    } cases[] = {{2000, 0, "solved"}, {8000, 0, "solved"}, {32000, 1, "synthetic B, no F"}};
    struct {
        char *size;
        int png;
        char *exr; /* --exr-compression */
    } runs[] = {{"512x512", 1, "none"},  {"1024x1024", 1, "none"}, {"1024x1024", 0, "none"},
                {"1024x1024", 1, "zip"}, {"1024x1024", 0, "zip"}};
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    double load[3] = {0};
    getloadavg(load, 3);
    printf("render: one view vs ten views in one call (whole command: start, load, draw, write);\n"
           "fastest wall of 3 runs, its CPU (user + sys), peak RSS; %ld CPUs, load average %.1f\n"
           "at the start (other work on the machine stretches the wall times, not the CPU)\n\n",
           cpus, load[0]);
    printf("| solution | patches | file MB | size | files (EXR codec) | one view s (CPU) | ten views, 1 thread "
           "s (CPU) | ten views, %u threads s (CPU) | ten / one | peak MiB one / ten |\n",
           rad_view_threads(0, 10));
    printf("|---|--:|--:|---|---|--:|--:|--:|--:|--:|\n");
    int rc = 0;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0] && !rc; c++) {
        char sol[512], path[512], one[512], png[512], eye[128], target[128];
        snprintf(sol, sizeof sol, "%s/case%zu.sol", dir, c);
        snprintf(path, sizeof path, "%s/ten.txt", dir);
        snprintf(one, sizeof one, "%s/one.exr", dir);
        snprintf(png, sizeof png, "%s/one.png", dir);
        prepared p = {0};
        rc = prepare_apart(model, cases[c].target, cases[c].synthetic, sol, path, &p);
        rad_vec3 e = p.eye, t = p.target;
        uint32_t patches = p.patches;
        struct stat st;
        double file_mb = stat(sol, &st) == 0 ? st.st_size / 1048576.0 : 0.0;
        snprintf(eye, sizeof eye, "%.9g,%.9g,%.9g", e.x, e.y, e.z);
        snprintf(target, sizeof target, "%.9g,%.9g,%.9g", t.x, t.y, t.z);
        for (size_t z = 0; z < sizeof runs / sizeof runs[0] && !rc; z++) {
            char *size = runs[z].size, *codec = runs[z].exr;
            /* Without PNGs the argument lists end early. */
            char *one_argv[] = {(char *)bin, "render", sol, "-o", one, "--size", size,
                                "--exr-compression", codec, "--eye", eye, "--target", target,
                                "--fov", "50", "--png", png, NULL};
            char *ten1_argv[] = {(char *)bin, "render", sol, "-o", dir, "--path", path, "--size",
                                 size, "--exr-compression", codec, "--threads", "1", "--no-png",
                                 NULL};
            char *ten_argv[] = {(char *)bin, "render", sol, "-o", dir, "--path", path, "--size",
                                size, "--exr-compression", codec, "--no-png", NULL};
            if (runs[z].png) {
                ten1_argv[13] = NULL;
                ten_argv[11] = NULL;
            } else {
                one_argv[15] = NULL;
            }
            run_stats r1, r10a, r10;
            rc = measure(one_argv, &r1) || measure(ten1_argv, &r10a) || measure(ten_argv, &r10);
            if (rc)
                break;
            printf("| Cornell, %s | %u | %.1f | %s | %s (%s) | %.3f (%.3f) | %.3f (%.3f) | %.3f (%.3f) "
                   "| %.2f | %.0f / %.0f |\n",
                   cases[c].what, patches, file_mb, size, runs[z].png ? "EXR + PNG" : "EXR", codec,
                   r1.wall,
                   r1.cpu,
                   r10a.wall, r10a.cpu, r10.wall, r10.cpu, r10.wall / r1.wall, r1.peak_mib,
                   r10.peak_mib);
            fflush(stdout);
        }
    }
    if (!rc)
        rc = per_view_costs(dir, "case2.sol");
    getloadavg(load, 3);
    printf("\nload average at the end: %.1f\n", load[0]);
    /* Leave nothing behind. */
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "bench_views: could not remove %s\n", dir);
    return rc;
}
