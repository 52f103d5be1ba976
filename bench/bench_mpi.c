/* bench_mpi.c - form factors under MPI (issue 38, report/mpi.md): the
 * inputs of a model of a cluster run, measured on this machine.
 *
 *   1. rows/s of `radiosity solve` with the plain fork pool (1 and 2
 *      workers) and under `mpirun -np K radiosity solve` for K = 1, 2, 3
 *      (one worker a rank), from the solve's own "form factors" time, the
 *      faster of two runs;
 *   2. the bytes a row sends from a rank to rank 0 (8 + 8 × entries, from
 *      the solution's F);
 *   3. the rows/s rank 0 can take in: `mpirun -np 2 bench_mpi --intake M R`
 *      has rank 1 send R synthetic rows of M entries in blocks of 64, in
 *      mpi_ranks.c's layout, and rank 0 unpack, check and store them into
 *      F with the journal attached, as it does for real rows (and the
 *      rate of that storing alone, without the wait for messages);
 * and prints the projection for 100,000 patches on 16 nodes × 32 cores
 * (report/mpi.md writes the model out).  Needs OpenMPI's mpirun; runs the
 * programs in build/release.  As a tool it includes mpi.h itself (the
 * engine's MPI is in hemicube/mpi_ranks.c alone).
 */
#include "../radiosity/solfile/solfile.h"

#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define BLOCK 64u
static const char *bin = "build/release/radiosity";
static const char *scene = "models/cornell.rad";
static const char *patch_size = "0.06";

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---------------------------------------------------------------- intake */

static void fill_row(uint32_t i, uint32_t m, uint32_t n, unsigned char *p)
{
    uint32_t w[2] = {i % BLOCK, m};
    memcpy(p, w, 8);
    uint32_t *col = (uint32_t *)(p + 8);
    float *val = (float *)(p + 8 + 4 * (size_t)m);
    (void)n;
    /* strictly increasing columns, never i itself */
    for (uint32_t q = 0; q < m; q++) {
        col[q] = q < i ? q : q + 1;
        val[q] = 1.0f / (float)(m + 1);
    }
}

static int intake(uint32_t m, uint32_t rows)
{
    int rank;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    uint32_t n = rows > m + 1 ? rows : m + 1;
    size_t rec = 8 + 8 * (size_t)m, len = 8 + BLOCK * rec;
    unsigned char *buf = malloc(len);
    if (!buf)
        return 1;
    if (rank == 1) {
        for (uint32_t b = 0; b < rows; b += BLOCK) {
            uint32_t head[2] = {b, BLOCK};
            memcpy(buf, head, 8);
            for (uint32_t k = 0; k < BLOCK; k++)
                fill_row(b + k, m, n, buf + 8 + k * rec);
            MPI_Send(buf, (int)len, MPI_BYTE, 0, 4, MPI_COMM_WORLD);
        }
        free(buf);
        return 0;
    }
    rad_matrix *F = rad_matrix_create(n);
    rad_journal *j = NULL;
    rad_error err = {0};
    char path[] = "/tmp/bench_mpi_XXXXXX";
    int fd = mkstemp(path);
    close(fd);
    uint32_t *col = malloc(sizeof *col * m + 4);
    float *val = malloc(sizeof *val * m + 4);
    if (!F || !col || !val || rad_journal_open(path, 1, &j, &err) ||
        rad_journal_attach(j, F, 1, &err)) {
        fprintf(stderr, "bench_mpi: %s\n", err.message);
        return 1;
    }
    double t0 = now(), t_store = 0;
    uint64_t bad = 0;
    for (uint32_t b = 0; b < rows; b += BLOCK) {
        MPI_Recv(buf, (int)len, MPI_BYTE, 1, 4, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        double ts = now();
        for (uint32_t k = 0; k < BLOCK; k++) {
            const unsigned char *p = buf + 8 + k * rec;
            uint32_t w[2];
            memcpy(w, p, 8);
            memcpy(col, p + 8, 4 * (size_t)w[1]);
            memcpy(val, p + 8 + 4 * (size_t)w[1], 4 * (size_t)w[1]);
            uint32_t i = b + w[0];
            for (uint32_t q = 0; q < w[1]; q++) /* hc_run_store's checks */
                bad += col[q] >= n || col[q] == i || (q && col[q] <= col[q - 1]) || !(val[q] > 0.0f);
            if (rad_matrix_set_row(F, i, w[1], col, val, &err))
                bad++;
        }
        t_store += now() - ts;
    }
    double t = now() - t0;
    printf("intake %u %u %.0f %.1f %.0f %llu\n", m, rows, rows / t,
           (double)rows * (double)rec / t / 1e6, rows / t_store, (unsigned long long)bad);
    rad_journal_close(j);
    unlink(path);
    char partial[64];
    snprintf(partial, sizeof partial, "%s.partial", path);
    unlink(partial);
    rad_matrix_destroy(F);
    free(col), free(val), free(buf);
    return 0;
}

/* ---------------------------------------------------------------- solves */

/* Runs cmd and reads "form factors X s" and "N rows computed" from it. */
static int solve(const char *cmd, double *ff, double *rows)
{
    FILE *p = popen(cmd, "r");
    if (!p)
        return -1;
    char line[1024];
    *ff = *rows = -1;
    while (fgets(line, sizeof line, p)) {
        const char *f = strstr(line, "form factors ");
        const char *r = strstr(line, " rows computed");
        if (f && strstr(line, "time:"))
            *ff = atof(f + 13);
        if (r) {
            const char *s = r;
            while (s > line && s[-1] >= '0' && s[-1] <= '9')
                s--;
            *rows = atof(s);
        }
    }
    return pclose(p) == 0 && *ff > 0 && *rows > 0 ? 0 : -1;
}

static void row_rates(void)
{
    char cmd[1024];
    printf("| run | workers in all | rows | form factors s | rows/s |\n|---|---:|---:|---:|---:|\n");
    for (int c = 0; c < 5; c++) {
        int procs = c < 2 ? c + 1 : 1, ranks = c < 2 ? 0 : c - 1;
        char mpi[128] = "";
        if (ranks)
            snprintf(mpi, sizeof mpi, "mpirun --oversubscribe -np %d ", ranks);
        snprintf(cmd, sizeof cmd, "%s%s solve %s --patch-size %s --refine-threshold 0 --fresh "
                 "--processes %d -o /tmp/bench_mpi_%d.sol 2>&1", mpi, bin, scene, patch_size,
                 procs, c);
        double ff, rows, ff2, rows2;
        int bad = solve(cmd, &ff, &rows) != 0 || solve(cmd, &ff2, &rows2) != 0;
        ff = ff2 < ff ? ff2 : ff; /* the faster of two: the machine is shared */
        if (bad) {
            printf("| %s | failed |\n", cmd);
            continue;
        }
        if (ranks)
            printf("| mpirun -np %d, 1 worker a rank | %d | %.0f | %.2f | %.1f |\n", ranks, ranks,
                   rows, ff, rows / ff);
        else
            printf("| fork pool, %d worker%s | %d | %.0f | %.2f | %.1f |\n", procs,
                   procs > 1 ? "s" : "", procs, rows, ff, rows / ff);
        if (c == 0) { /* bytes a row sends, from F's entries */
            snprintf(cmd, sizeof cmd, "rm -rf /tmp/bench_mpi_x && mkdir /tmp/bench_mpi_x && %s "
                     "export /tmp/bench_mpi_0.sol -o /tmp/bench_mpi_x > /dev/null && "
                     "grep -v '^%%' /tmp/bench_mpi_x/F.mtx | head -1", bin);
            FILE *p = popen(cmd, "r");
            unsigned n1 = 0, n2 = 0;
            unsigned long long nnz = 0;
            if (p && fscanf(p, "%u %u %llu", &n1, &n2, &nnz) == 3)
                printf("(F: %u patches, %llu entries, %.1f a row: a row sends 8 + 8 × %.1f = "
                       "%.0f bytes)\n", n1, nnz, (double)nnz / rows, (double)nnz / rows,
                       8 + 8.0 * (double)nnz / rows);
            if (p)
                pclose(p);
        }
    }
}

int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "--intake")) {
        MPI_Init(&argc, &argv);
        int rc = intake((uint32_t)atoi(argv[2]), (uint32_t)atoi(argv[3]));
        MPI_Finalize();
        return rc;
    }
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
    setenv("OMPI_MCA_btl_vader_single_copy_mechanism", "none", 1);
    FILE *up = popen("uptime", "r");
    char load[256] = "";
    if (up && fgets(load, sizeof load, up))
        printf("load: %s", load);
    if (up)
        pclose(up);
    printf("Cornell box, --patch-size %s, no elements (rows only):\n\n", patch_size);
    row_rates();
    printf("\nrank 0's intake (unpack, check, store into F with the journal), blocks of %u rows:\n\n"
           "| entries a row | rows | rows/s | MB/s | rows/s storing alone |\n|---:|---:|---:|---:|---:|\n",
           BLOCK);
    const unsigned cases[2][2] = {{60, 64000}, {15000, 1600}};
    for (int c = 0; c < 2; c++) {
        char cmd[512];
        snprintf(cmd, sizeof cmd, "mpirun --oversubscribe -np 2 %s --intake %u %u 2>&1", argv[0],
                 cases[c][0], cases[c][1]);
        FILE *p = popen(cmd, "r");
        char line[256];
        unsigned m = 0, r = 0;
        double rs = 0, mbs = 0, st = 0;
        unsigned long long bad = 1;
        while (p && fgets(line, sizeof line, p))
            if (sscanf(line, "intake %u %u %lf %lf %lf %llu", &m, &r, &rs, &mbs, &st, &bad) == 6)
                printf("| %u | %u | %.0f | %.0f | %.0f |%s\n", m, r, rs, mbs, st,
                       bad ? " (rows refused!)" : "");
        if (p)
            pclose(p);
    }
    return 0;
}
