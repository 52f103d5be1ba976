/* bench_atrium.c - real models at the speed of their patch count (issue
 * 36): tools/atrium.c's courtyard hall (about 68,000 triangles written the
 * way exporters write them, lit by a sun through the roof) and
 * tools/hall.c's hall, loaded from glTF as a user's export would be.
 *
 * Parts (BENCH_ATRIUM_PARTS, a comma list; default all of them):
 *   atrium   N against area / size² at the default size and at 2× and 4×
 *            it (rad_mesh_count), the time per row over BENCH_ATRIUM_ROWS
 *            rows and the triangles each item buffer draws (every cell
 *            against the simplified clusters), then the whole solve at
 *            defaults (BENCH_ATRIUM_SOLVE=1 always, 0 never; by default
 *            only when N <= 4 × area / size², so that `make bench` ends
 *            while the meshing makes far more patches): wall time,
 *            this process's peak memory (VmHWM) and the largest worker's,
 *            and the elements' time against the form factors' (the patches
 *            solved with refinement off, then refined: the stages apart);
 *   hall     the same element / form-factor ratio on the hall at the sizes
 *            BENCH_ATRIUM_HALL_SIZES (default "0.36 0.6");
 *   retess   the hall and the hall tessellated 4× as finely (fine 2) at one
 *            patch size (BENCH_ATRIUM_RETESS_SIZE, default 0.6): time per
 *            row over BENCH_ATRIUM_ROWS rows (default 256) spread over the
 *            patches, and the triangles each item buffer draws.
 * BENCH_ATRIUM_FINE scales the atrium's tessellation (default 1).
 *
 * Times are wall-clock, one run each; the load average is printed with
 * every figure, since the machine may be shared.  Nothing is asserted.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "../tools/atrium.h"
#include "../tools/hall.h"
#include "bench_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

static int wants(const char *part)
{
    const char *p = getenv("BENCH_ATRIUM_PARTS");
    return !p || strstr(p, part) != NULL;
}

static double env_double(const char *name, double dflt)
{
    const char *v = getenv(name);
    return v && atof(v) > 0 ? atof(v) : dflt;
}

/* Solves scene at patch size `size` (0: default) with refinement off, then
 * refines: the form-factor and element times apart.  NULL on failure. */
static rad_solution *solve_timed(const char *scene, double size, double *ff_s, double *el_s,
                                 double *wall_s)
{
    rad_solve_options opt = {0};
    opt.mesh.patch_size = size;
    opt.refine_threshold = RAD_REFINE_OFF;
    rad_solution *s = NULL;
    rad_error err = {0};
    double t0 = rad_seconds();
    if (rad_solve_scene_file(scene, &opt, &s, &err) != RAD_OK) {
        printf("  %s: %s\n", scene, err.message);
        return NULL;
    }
    *ff_s = s->stages[RAD_STAGE_FORM_FACTORS].seconds;
    double t1 = rad_seconds();
    rad_solve_options ref = {0};
    ref.mesh.patch_size = size;
    if (rad_refine_solution(s, &ref, &err) != RAD_OK)
        printf("  refine: %s\n", err.message);
    *el_s = rad_seconds() - t1;
    *wall_s = rad_seconds() - t0;
    return s;
}

/* Time per row of `rows` rows spread over the patches of scene at size. */
static void row_time(const char *scene, double size, uint32_t rows, const char *label)
{
    rad_scene *sc = NULL;
    rad_mesh *m = NULL;
    rad_error err = {0};
    rad_mesh_options mo = {.patch_size = size};
    if (rad_scene_load(scene, NULL, &sc, &err) != RAD_OK || rad_mesh_build(sc, &mo, &m, &err) != RAD_OK) {
        printf("  %s: %s\n", scene, err.message);
        rad_scene_destroy(sc);
        return;
    }
    uint32_t n = m->patch_count, k = rows < n ? rows : n;
    uint32_t *list = malloc((size_t)k * sizeof *list);
    rad_matrix *F = rad_matrix_create(n);
    hc_options ho = {0};
    hc_engine *e = NULL;
    uint64_t all = 0, few = 0;
    uint32_t fans = 0, none;
    double t0 = 0, t1 = 0;
    for (uint32_t q = 0; list && q < k; q++)
        list[q] = (uint32_t)((uint64_t)q * n / k);
    if (list && F && hc_create(m, &ho, &e, &err) == RAD_OK &&
        hc_draw_triangles(e, 1, &all, &none, &err) == RAD_OK &&
        hc_draw_triangles(e, 0, &few, &fans, &err) == RAD_OK) {
        t0 = rad_seconds();
        if (hc_compute_rows(e, list, k, F, &err) == RAD_OK)
            t1 = rad_seconds();
    }
    if (t1 > t0)
        printf("  %s: N %u, %u rows in %.2f s = %.2f ms a row (wall, every CPU); draws %llu "
               "triangles (every cell %llu), load %.2f\n",
               label, n, k, t1 - t0, 1e3 * (t1 - t0) / k, (unsigned long long)few,
               (unsigned long long)all, bench_load());
    else
        printf("  %s: %s\n", label, err.message);
    hc_destroy(e);
    rad_matrix_destroy(F);
    free(list);
    rad_mesh_destroy(m);
    rad_scene_destroy(sc);
}

/* Patch counts of the scene at the default size and at 2× and 4×, without
 * meshing (rad_mesh_count); the default size into *size. */
static uint64_t atrium_counts(const char *scene, double area, double *size)
{
    rad_scene *sc = NULL;
    rad_error err = {0};
    *size = 0.0;
    if (rad_scene_load(scene, NULL, &sc, &err) != RAD_OK) {
        printf("  %s\n", err.message);
        return 0;
    }
    *size = rad_mesh_default_patch_size(sc);
    uint64_t n1 = 0;
    for (int k = 1; k <= 4; k *= 2) {
        rad_mesh_options mo = {.patch_size = k * *size};
        uint64_t nk = rad_mesh_count(sc, &mo);
        n1 = k == 1 ? nk : n1;
        printf("  patch size %.3f (%d×): N %llu, area / size² %.0f, N / (area / size²) %.2f, "
               "N / N(1×) %.3f\n", k * *size, k, (unsigned long long)nk,
               area / (k * *size * k * *size), nk / (area / (k * *size * k * *size)),
               (double)nk / (double)n1);
    }
    rad_scene_destroy(sc);
    return n1;
}

static void atrium_part(const char *dir)
{
    double fine = env_double("BENCH_ATRIUM_FINE", 1.0), size;
    atrium_stats st;
    char scene[4096];
    snprintf(scene, sizeof scene, "%s/atrium.gltf", dir);
    if (atrium_write(dir, "atrium", fine, &st) != 0)
        return;
    printf("atrium (tools/atrium.c, fine %g): %llu triangles, %u objects, %.0f m²\n", fine,
           (unsigned long long)st.triangles, st.objects, st.area);
    uint64_t n = atrium_counts(scene, st.area, &size);
    row_time(scene, 0.0, (uint32_t)env_double("BENCH_ATRIUM_ROWS", 256), "atrium rows");
    const char *solve = getenv("BENCH_ATRIUM_SOLVE");
    double ratio = size > 0 ? n / (st.area / (size * size)) : 0;
    if (solve ? strcmp(solve, "0") == 0 : ratio > 4.0) {
        printf("  whole solve skipped (N %.1f × area / size²%s; BENCH_ATRIUM_SOLVE=1 runs it)\n",
               ratio, solve ? ", BENCH_ATRIUM_SOLVE=0" : ": the meshing does not yet follow the size");
        return;
    }
    double ff = 0, el = 0, wall = 0;
    printf("  solving at defaults (load %.2f) ...\n", bench_load());
    fflush(stdout);
    rad_solution *s = solve_timed(scene, 0.0, &ff, &el, &wall);
    if (!s)
        return;
    struct rusage kids;
    getrusage(RUSAGE_CHILDREN, &kids);
    printf("  whole solve: %.1f s wall (form factors %.1f s, elements %.1f s = %.0f %% of the "
           "form factors), load %.2f\n", wall, ff, el, 100.0 * el / ff, bench_load());
    printf("  peak memory: main %.0f MiB, largest worker %.0f MiB\n",
           (double)rad_process_memory(1) / 1048576.0, (double)kids.ru_maxrss / 1024.0);
    rad_solution_destroy(s);
}

/* BENCH_ATRIUM_NEAR=K: the mean near set (bench_near_set, K parent sizes)
 * of the elements with hemi-cubes of their own, what a contact hemi-cube
 * drawing only its near field would draw (issue 36). */
static void near_sets(const rad_solution *s)
{
    const char *v = getenv("BENCH_ATRIUM_NEAR");
    const rad_elements *el = s->elements;
    if (!v || atof(v) <= 0 || !el)
        return;
    const rad_mesh *m = s->mesh;
    uint8_t *near = malloc((size_t)m->patch_count + 1);
    uint64_t count = 0, total = 0, most = 0;
    for (uint32_t e = 0; near && e < el->mesh->patch_count; e++) {
        if (el->level[e] == 0 || (el->interp && el->interp[e]))
            continue;
        const uint32_t p = el->patch[e];
        const uint32_t nn = bench_near_set(m, el->mesh->patches[e].center,
                                           atof(v) * sqrt(m->patches[p].area), near);
        total += nn;
        most = nn > most ? nn : most;
        count++;
    }
    printf("  near %s: %llu elements with hemi-cubes, near set %.1f patches (mean), %llu at "
           "most, of %u\n", v, (unsigned long long)count, count ? (double)total / (double)count : 0.0,
           (unsigned long long)most, m->patch_count);
    free(near);
}

static void hall_part(const char *dir)
{
    char scene[4096];
    snprintf(scene, sizeof scene, "%s/hall.gltf", dir);
    hall_stats hs;
    if (hall_write(dir, "hall", 1.0, &hs) != 0)
        return;
    const char *list = getenv("BENCH_ATRIUM_HALL_SIZES");
    char buf[256];
    snprintf(buf, sizeof buf, "%s", list ? list : "0.36 0.6");
    for (char *tok = strtok(buf, " ,"); tok; tok = strtok(NULL, " ,")) {
        double size = atof(tok), ff = 0, el = 0, wall = 0;
        rad_solution *s = size > 0 ? solve_timed(scene, size, &ff, &el, &wall) : NULL;
        if (!s)
            continue;
        printf("hall (%llu triangles) at %.2f: N %u, form factors %.1f s, elements %.1f s = %.0f "
               "%% (%llu element hemi-cubes), wall %.1f s, load %.2f\n",
               (unsigned long long)hs.triangles, size, s->mesh->patch_count, ff, el,
               100.0 * el / ff,
               (unsigned long long)(s->elements ? s->elements->rows_computed : 0), wall,
               bench_load());
        near_sets(s);
        rad_solution_destroy(s);
    }
}

static void retess_part(const char *dir)
{
    double size = env_double("BENCH_ATRIUM_RETESS_SIZE", 0.6);
    uint32_t rows = (uint32_t)env_double("BENCH_ATRIUM_ROWS", 256);
    const double fine[2] = {1.0, 2.0};
    printf("hall re-tessellated, patch size %.2f:\n", size);
    for (int k = 0; k < 2; k++) {
        char name[32], scene[4096], label[64];
        hall_stats hs;
        snprintf(name, sizeof name, "hall%d", k);
        snprintf(scene, sizeof scene, "%s/%s.gltf", dir, name);
        if (hall_write(dir, name, fine[k], &hs) != 0)
            continue;
        snprintf(label, sizeof label, "%llu triangles", (unsigned long long)hs.triangles);
        row_time(scene, size, rows, label);
    }
}

int main(void)
{
    char dir[] = "/tmp/bench_atrium.XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    printf("bench_atrium: load average %.2f\n", bench_load());
    if (wants("atrium"))
        atrium_part(dir);
    if (wants("hall"))
        hall_part(dir);
    if (wants("retess"))
        retess_part(dir);
    char cmd[4200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "bench_atrium: could not remove %s\n", dir);
    return 0;
}
