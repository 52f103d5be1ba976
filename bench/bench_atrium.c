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
 *   retess   the hall and the hall with every triangle re-tessellated into
 *            four the way exporters write them (hall_write_split: fans,
 *            slivers, T-junctions, unwelded copies) at the patch sizes
 *            BENCH_ATRIUM_RETESS_SIZES (default "1.0 0.6"): wall and CPU
 *            time per row over BENCH_ATRIUM_ROWS rows (default 256) spread
 *            over the patches (rows only, no elements), their ratio, and
 *            the triangles each item buffer draws.
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

/* What solve_timed measured: stage wall times, the whole wall time, and
 * the CPU seconds of this process and of its workers over the solve. */
typedef struct solve_times {
    double ff, el, wall; /* form factors, elements (refinement), all: wall s */
    double cpu_main, cpu_workers;
} solve_times;

/* Solves scene at patch size `size` (0: default) with refinement off, then
 * refines: the form-factor and element times apart.  NULL on failure. */
static rad_solution *solve_timed(const char *scene, double size, solve_times *t)
{
    rad_solve_options opt = {0};
    opt.mesh.patch_size = size;
    opt.refine_threshold = RAD_REFINE_OFF;
    rad_solution *s = NULL;
    rad_error err = {0};
    double c0, k0, c1, k1;
    bench_cpu_seconds(&c0, &k0);
    double t0 = rad_seconds();
    if (rad_solve_scene_file(scene, &opt, &s, &err) != RAD_OK) {
        printf("  %s: %s\n", scene, err.message);
        return NULL;
    }
    t->ff = s->stages[RAD_STAGE_FORM_FACTORS].seconds;
    double t1 = rad_seconds();
    rad_solve_options ref = {0};
    ref.mesh.patch_size = size;
    if (rad_refine_solution(s, &ref, &err) != RAD_OK)
        printf("  refine: %s\n", err.message);
    t->el = rad_seconds() - t1;
    t->wall = rad_seconds() - t0;
    bench_cpu_seconds(&c1, &k1);
    t->cpu_main = c1 - c0;
    t->cpu_workers = k1 - k0;
    return s;
}

/* What row_time measured: N, the rows, their wall and CPU ms a row (this
 * process and its workers while the rows ran: the engine's start and the
 * geometry's upload are not in it) and the triangles an item buffer draws. */
typedef struct row_cost {
    uint32_t n, rows;
    double wall_ms, cpu_ms;
    uint64_t drawn, every_cell;
} row_cost;

/* Times `rows` rows spread over the patches of scene at size; 0, or -1
 * with a line printed. */
static int row_time(const char *scene, double size, uint32_t rows, row_cost *rc)
{
    rad_scene *sc = NULL;
    rad_mesh *m = NULL;
    rad_error err = {0};
    rad_mesh_options mo = {.patch_size = size};
    if (rad_scene_load(scene, NULL, &sc, &err) != RAD_OK || rad_mesh_build(sc, &mo, &m, &err) != RAD_OK) {
        printf("  %s: %s\n", scene, err.message);
        rad_scene_destroy(sc);
        return -1;
    }
    uint32_t n = m->patch_count, k = rows < n ? rows : n;
    uint32_t *list = malloc((size_t)k * sizeof *list);
    rad_matrix *F = rad_matrix_create(n);
    hc_options ho = {0};
    hc_engine *e = NULL;
    uint32_t none;
    double t0 = 0, t1 = 0, c0 = 0, c1 = 0, k0, k1;
    *rc = (row_cost){.n = n, .rows = k};
    for (uint32_t q = 0; list && q < k; q++)
        list[q] = (uint32_t)((uint64_t)q * n / k);
    if (list && F && hc_create(m, &ho, &e, &err) == RAD_OK &&
        hc_draw_triangles(e, 1, &rc->every_cell, &none, &err) == RAD_OK &&
        hc_draw_triangles(e, 0, &rc->drawn, &none, &err) == RAD_OK) {
        bench_cpu_seconds(&c0, &k0);
        c0 += bench_children_cpu();
        t0 = rad_seconds();
        if (hc_compute_rows(e, list, k, F, &err) == RAD_OK) {
            t1 = rad_seconds();
            bench_cpu_seconds(&c1, &k1);
            c1 += bench_children_cpu();
        }
    }
    if (t1 > t0) {
        rc->wall_ms = 1e3 * (t1 - t0) / k;
        rc->cpu_ms = 1e3 * (c1 - c0) / k;
    } else {
        printf("  %s: %s\n", scene, err.message);
    }
    hc_destroy(e);
    rad_matrix_destroy(F);
    free(list);
    rad_mesh_destroy(m);
    rad_scene_destroy(sc);
    return t1 > t0 ? 0 : -1;
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
    row_cost rc;
    if (row_time(scene, 0.0, (uint32_t)env_double("BENCH_ATRIUM_ROWS", 256), &rc) == 0)
        printf("  rows: N %u, %u rows, %.2f ms a row wall (every CPU), %.2f ms CPU; draws %llu "
               "triangles (every cell %llu), load %.2f\n", rc.n, rc.rows, rc.wall_ms, rc.cpu_ms,
               (unsigned long long)rc.drawn, (unsigned long long)rc.every_cell, bench_load());
    const char *solve = getenv("BENCH_ATRIUM_SOLVE");
    double ratio = size > 0 ? n / (st.area / (size * size)) : 0;
    if (solve ? strcmp(solve, "0") == 0 : ratio > 4.0) {
        printf("  whole solve skipped (N %.1f × area / size²%s; BENCH_ATRIUM_SOLVE=1 runs it)\n",
               ratio, solve ? ", BENCH_ATRIUM_SOLVE=0" : ": the meshing does not yet follow the size");
        return;
    }
    solve_times t = {0};
    printf("  solving at defaults (load %.2f) ...\n", bench_load());
    fflush(stdout);
    rad_solution *s = solve_timed(scene, 0.0, &t);
    if (!s)
        return;
    struct rusage kids;
    getrusage(RUSAGE_CHILDREN, &kids);
    printf("  whole solve: N %u, %.1f s wall (form factors %.1f s, elements %.1f s = %.0f %% of "
           "the form factors), CPU %.1f s main + %.1f s workers, load %.2f at the end\n",
           s->mesh->patch_count, t.wall, t.ff, t.el, 100.0 * t.el / t.ff, t.cpu_main,
           t.cpu_workers, bench_load());
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
        double size = atof(tok);
        solve_times t = {0};
        rad_solution *s = size > 0 ? solve_timed(scene, size, &t) : NULL;
        if (!s)
            continue;
        printf("hall (%llu triangles) at %.2f: N %u, form factors %.1f s, elements %.1f s = %.0f "
               "%% (%llu element hemi-cubes), wall %.1f s, load %.2f\n",
               (unsigned long long)hs.triangles, size, s->mesh->patch_count, t.ff, t.el,
               100.0 * t.el / t.ff,
               (unsigned long long)(s->elements ? s->elements->rows_computed : 0), t.wall,
               bench_load());
        near_sets(s);
        rad_solution_destroy(s);
    }
}

/* The hall (fine 1) and the same hall with every triangle split in four
 * as exporters write them (hall_write_split), at each patch size of
 * BENCH_ATRIUM_RETESS_SIZES (default "1.0 0.6"): rows only, no elements. */
static void retess_part(const char *dir)
{
    const uint32_t rows = (uint32_t)env_double("BENCH_ATRIUM_ROWS", 256);
    const char *v = getenv("BENCH_ATRIUM_RETESS_SIZES");
    char buf[256], scene[2][4096];
    hall_stats hs[2];
    snprintf(buf, sizeof buf, "%s", v ? v : "1.0 0.6");
    for (int k = 0; k < 2; k++) {
        snprintf(scene[k], sizeof scene[k], "%s/hall%d.gltf", dir, k);
        if ((k ? hall_write_split : hall_write)(dir, k ? "hall1" : "hall0", 1.0, &hs[k]) != 0)
            return;
    }
    printf("hall re-tessellated (every triangle in four: fans, midpoint splits, unwelded "
           "copies), %u rows spread over the patches, load %.2f:\n\n", rows, bench_load());
    printf("| patch size | hall | triangles | N | rows | triangles drawn | ms a row, wall "
           "| ms a row, CPU | CPU ratio split / original |\n|--:|---|--:|--:|--:|--:|--:|--:|--:|\n");
    for (char *tok = strtok(buf, " ,"); tok; tok = strtok(NULL, " ,")) {
        row_cost rc[2];
        double size = atof(tok);
        for (int k = 0; k < 2; k++) {
            if (size <= 0 || row_time(scene[k], size, rows, &rc[k]) != 0)
                break;
            printf("| %.2f | %s | %llu | %u | %u | %llu | %.2f | %.2f |", size,
                   k ? "split in four" : "original", (unsigned long long)hs[k].triangles,
                   rc[k].n, rc[k].rows, (unsigned long long)rc[k].drawn, rc[k].wall_ms,
                   rc[k].cpu_ms);
            if (k)
                printf(" **%.2f** |\n", rc[1].cpu_ms / rc[0].cpu_ms);
            else
                printf(" |\n");
            fflush(stdout);
        }
    }
    printf("\nload %.2f at the end\n", bench_load());
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
