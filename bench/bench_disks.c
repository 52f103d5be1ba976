/* bench_disks.c - issue 36's disk pair at defaults (target: ≤ 5 s): two
 * coaxial unit disks one apart, each a regular 256-gon, as a polygon file
 * (one polygon each) and as glTF (a fan of 254 triangles each), written by
 * tools/disks.c with disk A emitting so that a whole solve accepts them.
 *
 * For each form: N at the default patch size against area / size², then
 * the program itself (argv[1], else $RADIOSITY_BIN, else
 * build/release/radiosity) run once for the factor query
 * `radiosity ff FILE --from A --to B` (its F_AB against the closed form
 * 0.381966) and once for `radiosity solve FILE -o SOL`: wall seconds, CPU
 * seconds of the process and its workers, peak resident memory.  One run
 * each, on a machine that may be shared: the load average is printed at the
 * start and the end.  Nothing is asserted.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "../tools/disks.h"
#include "bench_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Writes len bytes of text to path; 0, or -1 with a line on stderr. */
static int write_text(const char *path, const char *text, size_t len)
{
    FILE *f = text ? fopen(path, "wb") : NULL;
    int ok = f && fwrite(text, 1, len, f) == len;
    if (f && fclose(f) != 0)
        ok = 0;
    if (!ok)
        fprintf(stderr, "bench_disks: cannot write %s\n", path);
    return ok ? 0 : -1;
}

/* N at the default size and area / size², from the library. */
static int count(const char *path, uint64_t *n, double *budget, double *size)
{
    rad_scene *sc = NULL;
    rad_error err = {0};
    if (rad_scene_load(path, NULL, &sc, &err) != RAD_OK) {
        fprintf(stderr, "bench_disks: %s\n", err.message);
        return -1;
    }
    double area = 0.0;
    for (uint32_t p = 0; p < sc->polygon_count; p++)
        area += sc->polygons[p].area;
    *size = rad_mesh_default_patch_size(sc);
    *budget = area / (*size * *size);
    *n = rad_mesh_count(sc, NULL);
    rad_scene_destroy(sc);
    return 0;
}

/* The F_AB that `ff` printed ("F(A -> B) = x"), or NAN. */
static double read_factor(const char *out)
{
    FILE *f = fopen(out, "r");
    char line[512];
    double v = NAN;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "F(A -> B) = %lf", &v) == 1)
            break;
    if (f)
        fclose(f);
    return v;
}

static void one_form(const char *bin, const char *dir, const char *form, const char *file)
{
    char path[600], out[600], sol[600];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    snprintf(out, sizeof out, "%s/ff.txt", dir);
    snprintf(sol, sizeof sol, "%s/disks.sol", dir);
    uint64_t n = 0;
    double budget = 0, size = 0;
    bench_run ff = {0}, solve = {0};
    char *ff_argv[] = {(char *)bin, "ff", path, "--from", "A", "--to", "B", NULL};
    char *solve_argv[] = {(char *)bin, "solve", path, "-o", sol, NULL};
    if (count(path, &n, &budget, &size) || bench_spawn(ff_argv, out, &ff) ||
        bench_spawn(solve_argv, NULL, &solve))
        return;
    double f = read_factor(out);
    printf("| %s | %.4f | %llu | %.0f | %.2f | %.6f | %+.3f %% | %.2f | %.2f | %.0f | %.2f | %.2f "
           "| %.0f |\n",
           form, size, (unsigned long long)n, budget, (double)n / budget, f,
           100.0 * (f / DISKS_CLOSED_FORM - 1.0), ff.wall, ff.cpu, ff.peak_mib, solve.wall,
           solve.cpu, solve.peak_mib);
    fflush(stdout);
}

int main(int argc, char **argv)
{
    const char *bin = argc > 1 ? argv[1] : getenv("RADIOSITY_BIN");
    bin = bin ? bin : "build/release/radiosity";
    char dir[] = "/tmp/bench_disks.XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    char rad[600], gltf[600];
    snprintf(rad, sizeof rad, "%s/disks.rad", dir);
    snprintf(gltf, sizeof gltf, "%s/disks.gltf", dir);
    char *text = disks_polyfile(1);
    size_t size = 0;
    char *doc = disks_gltf(1, &size);
    int rc = write_text(rad, text, text ? strlen(text) : 0) || write_text(gltf, doc, size);
    free(text);
    free(doc);
    printf("disk pair at defaults (%d-gons, radius 1, one apart; closed form F_AB %.6f), "
           "load average %.2f at the start\n\n", DISKS_SIDES, DISKS_CLOSED_FORM, bench_load());
    printf("| form | patch size | N | area / size² | N / (area / size²) | F_AB | vs closed form "
           "| ff wall s | ff CPU s | ff peak MiB | solve wall s | solve CPU s | solve peak MiB |\n");
    printf("|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n");
    if (!rc) {
        one_form(bin, dir, "polygon file, 2 polygons", "disks.rad");
        one_form(bin, dir, "glTF, 2 fans of 254 triangles", "disks.gltf");
    }
    printf("\nload average at the end: %.2f\n", bench_load());
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "bench_disks: could not remove %s\n", dir);
    return rc;
}
