/* bench_scale.c - a large scene of small triangles, solved with defaults
 * (issue 15, items 4 and 5).
 *
 * The scene is tools/hall.c's vaulted hall (about 99,000 triangles, lit
 * only by a sun through three windows), written as glTF to a temporary
 * directory and loaded as a user's export would be.  It is solved with the
 * program's defaults (R = 128, Gauss-Seidel, every CPU) at three patch
 * sizes, each in a process of its own so that its peak memory is its own,
 * and the table gives per size: the patch count N (and the cells, the
 * small polygons the patches are made of), the form-factor and solve
 * times, the estimate printed before the rows were computed (form factors,
 * peak memory, solution file) against what was measured (VmHWM of the
 * solving process, the largest hemi-cube worker's peak, the file written).
 * A last row meshes the scene one patch per polygon, as before clusters,
 * and shows what the estimate says of it (only the 64 sample rows are
 * rendered; it is refused or not as the solve would).
 *
 *   bench_scale [sizes...]        (default 0.36 0.45 0.6: N about 19,500, 10,000, 6,400)
 *   BENCH_SCALE_FINE=f            tessellation factor of the hall (default 1)
 *   BENCH_SCALE_KEEP=DIR          write the scene and solutions there and keep them
 *
 * Times are wall-clock, one run each, on a machine that may be shared: the
 * load average is printed before and after, and the CPU seconds of the
 * hemi-cube workers (all of them) and of the solving process are given,
 * which a shared machine inflates far less: on an idle machine with W
 * workers the form factors take about their CPU seconds / W.  Nothing here
 * asserts anything.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "../tools/hall.h"
#include "bench_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

/* One solve's figures, sent from the child to the parent through a pipe. */
typedef struct result {
    int rc;
    char message[1024];
    rad_estimate est;
    int have_est;
    uint32_t patches, cells, rows;
    double ff_s, solve_s, wall_s;
    double cpu_main, cpu_workers; /* CPU seconds, user + system */
    uint64_t peak_main, peak_worker, file;
} result;

static double cpu_seconds(const struct rusage *u)
{
    return (double)u->ru_utime.tv_sec + 1e-6 * (double)u->ru_utime.tv_usec +
           (double)u->ru_stime.tv_sec + 1e-6 * (double)u->ru_stime.tv_usec;
}

static void on_estimate(void *user, const rad_estimate *e)
{
    result *r = user;
    r->est = *e;
    r->have_est = 1;
}

/* The child: solve at `size` (0: defaults; no_clusters: one patch per
 * polygon, estimate only), write the solution, measure. */
static void run_child(const char *scene, const char *sol, double size, int no_clusters,
                      result *r)
{
    rad_solve_options opt = {0};
    opt.mesh.patch_size = size;
    opt.mesh.no_clusters = no_clusters;
    opt.on_estimate = on_estimate;
    opt.estimate_user = r;
    if (no_clusters) /* stop after the estimate: a limit of one byte refuses any matrix */
        opt.max_memory = 1;
    rad_error err = {0};
    rad_solution *s = NULL;
    /* As `radiosity solve` does: the rows go to SOL.partial as they come
     * (so F can be freed before refinement) and the file is finished from
     * them.  Not for the estimate alone, which keeps no rows. */
    rad_journal *j = NULL;
    r->rc = no_clusters ? RAD_OK : rad_journal_open(sol, 1, &j, &err);
    opt.journal = j;
    double t0 = rad_seconds();
    if (r->rc == RAD_OK)
        r->rc = rad_solve_scene_file(scene, &opt, &s, &err);
    r->wall_s = rad_seconds() - t0;
    if (r->rc == RAD_OK) {
        r->rc = j ? rad_journal_commit(j, s, &err) /* frees j */
                  : rad_solution_write(s, sol, &err);
        j = NULL;
    }
    rad_journal_close(j);
    if (r->rc != RAD_OK) {
        snprintf(r->message, sizeof r->message, "%s", err.message);
    } else {
        struct stat st;
        r->file = stat(sol, &st) == 0 ? (uint64_t)st.st_size : 0;
        r->patches = s->mesh->patch_count;
        r->cells = s->mesh->cell_first ? s->mesh->cell_count : r->patches;
        r->rows = (uint32_t)s->rows_computed;
        r->ff_s = s->stages[RAD_STAGE_FORM_FACTORS].seconds;
        r->solve_s = s->stages[RAD_STAGE_SOLVE].seconds;
    }
    rad_solution_destroy(s);
    struct rusage self, kids;
    getrusage(RUSAGE_SELF, &self);
    getrusage(RUSAGE_CHILDREN, &kids);
    r->peak_main = rad_process_memory(1);
    r->peak_worker = (uint64_t)kids.ru_maxrss * 1024u;
    r->cpu_main = cpu_seconds(&self);
    r->cpu_workers = cpu_seconds(&kids);
}

static int solve_in_child(const char *scene, const char *sol, double size, int no_clusters,
                          result *r)
{
    int fd[2];
    if (pipe(fd) != 0)
        return -1;
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0)
        return -1;
    if (pid == 0) {
        close(fd[0]);
        result mine;
        memset(&mine, 0, sizeof mine);
        run_child(scene, sol, size, no_clusters, &mine);
        ssize_t w = write(fd[1], &mine, sizeof mine);
        _exit(w == (ssize_t)sizeof mine ? 0 : 1);
    }
    close(fd[1]);
    memset(r, 0, sizeof *r);
    size_t got = 0;
    while (got < sizeof *r) {
        ssize_t n = read(fd[0], (char *)r + got, sizeof *r - got);
        if (n <= 0)
            break;
        got += (size_t)n;
    }
    close(fd[0]);
    int st;
    waitpid(pid, &st, 0);
    return got == sizeof *r ? 0 : -1;
}

static double mib(uint64_t b) { return (double)b / 1048576.0; }

int main(int argc, char **argv)
{
    double sizes[8] = {0.36, 0.45, 0.6};
    int nsizes = 3;
    if (argc > 1) {
        nsizes = 0;
        for (int k = 1; k < argc && nsizes < 8; k++)
            sizes[nsizes++] = atof(argv[k]);
    }
    const char *fine_env = getenv("BENCH_SCALE_FINE"), *keep = getenv("BENCH_SCALE_KEEP");
    double fine = fine_env ? atof(fine_env) : 1.0;
    char tmp[] = "/tmp/bench_scale.XXXXXX", dir[4096];
    if (keep) {
        snprintf(dir, sizeof dir, "%s", keep);
        mkdir(dir, 0755);
    } else if (mkdtemp(tmp)) {
        snprintf(dir, sizeof dir, "%s", tmp);
    } else {
        perror("bench_scale: mkdtemp");
        return 1;
    }
    hall_stats hs;
    if (hall_write(dir, "hall", fine, &hs) != 0)
        return 1;
    char scene[4200], sol[4200];
    snprintf(scene, sizeof scene, "%s/hall.gltf", dir);
    snprintf(sol, sizeof sol, "%s/hall.sol", dir);
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    printf("Generated hall (tools/hall.c): %llu triangles in %u objects, one sun through three "
           "windows; defaults: R = %u, Gauss-Seidel, %ld worker processes\n",
           (unsigned long long)hs.triangles, hs.objects, HC_DEFAULT_RESOLUTION, cpus);
    bench_print_load("before");
    printf("\n| patch size | patches N | cells | form factors s | solve s | CPU s (workers) | "
           "CPU s (main) | estimate: F MiB | estimate: peak MiB | peak MiB (main) | "
           "peak MiB (worker) | estimate: file MiB | file MiB |\n");
    printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int k = 0; k <= nsizes; k++) {
        const int baseline = k == nsizes;
        result r;
        if (solve_in_child(scene, sol, baseline ? 0.0 : sizes[k], baseline, &r) != 0) {
            fprintf(stderr, "bench_scale: the solving process failed\n");
            return 1;
        }
        if (baseline) {
            printf("\nOne patch per polygon (no clusters), default patch size: %u patches; "
                   "estimate from %u sample rows: %.0f entries a row, form factors %.0f MiB, "
                   "peak %.0f MiB, file %.0f MiB.\n",
                   r.est.patches, r.est.sample_rows, r.est.entries_per_row,
                   mib(r.est.matrix_bytes), mib(r.est.peak_bytes), mib(r.est.file_bytes));
            continue;
        }
        if (r.rc != RAD_OK) {
            printf("| %.3g | failed: %s |\n", sizes[k], r.message);
            continue;
        }
        printf("| %.3g | %u | %u | %.1f | %.1f | %.1f | %.1f | %.0f | %.0f | %.0f | %.0f | %.0f | "
               "%.0f |\n",
               sizes[k], r.patches, r.cells, r.ff_s, r.solve_s, r.cpu_workers, r.cpu_main,
               mib(r.est.matrix_bytes),
               mib(r.est.peak_bytes), mib(r.peak_main), mib(r.peak_worker),
               mib(r.est.file_bytes), mib(r.file));
        fflush(stdout);
        if (!keep)
            unlink(sol);
    }
    bench_print_load("after");
    if (!keep) {
        char bin[4200];
        snprintf(bin, sizeof bin, "%s/hall.bin", dir);
        unlink(scene);
        unlink(bin);
        rmdir(dir);
    }
    return 0;
}
