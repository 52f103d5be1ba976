/* bench_store.c - issue 21's table: what a stored solution costs the
 * commands that use it.  For the Cornell box at three patch counts (the
 * glTF model at its defaults, ~3k patches; models/cornell.rad at patch size
 * 0.0156, ~8k, and 0.0078, ~32k) it runs the program (build/release/
 * radiosity) as a user would and prints, per command, the wall time and the
 * peak resident memory of its largest process (wait4's ru_maxrss, which
 * counts the hemi-cube workers the program reaped: the solve's main process
 * when F is large, a worker, ~90 MiB with OSMesa and llvmpipe, when it is
 * small; report/store.md): solve (from nothing: --fresh), report, render
 * 1024², relight --light light=2 (by superposition of the stored light
 * responses: F is not read) and relight --reflectance floor=0.5 (F read,
 * solved again); the solution's size and its MATRIX section's; and how
 * many times faster each relight is than the solve.
 *
 * The 32k row takes a solve of minutes and a file of ~1.8 GB: it runs only
 * with RADIOSITY_BENCH_LARGE=1 (the table says so otherwise).  Timings are
 * wall-clock, one run each, on a machine that may be shared; nothing here
 * asserts anything.  Run from the repository's root (make bench does).
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static const char *bin = "build/release/radiosity";

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

typedef struct run {
    double seconds;
    double mib;  /* peak resident set of the largest process, MiB */
    int status;
} run;

/* Runs bin with argv (NULL-terminated, argv[0] the command), output to
 * /dev/null; its time and peak memory. */
static run run_cmd(const char *const *argv)
{
    run r = {0, 0, -1};
    fflush(stdout); /* else the child's freopen would write the table's pending lines again */
    double t0 = now();
    pid_t pid = fork();
    if (pid == 0) {
        if (!freopen("/dev/null", "w", stdout) || !freopen("/dev/null", "w", stderr))
            _exit(126);
        execv(bin, (char *const *)argv);
        _exit(127);
    }
    if (pid < 0)
        return r;
    int st = 0;
    struct rusage ru;
    while (wait4(pid, &st, 0, &ru) < 0 && errno == EINTR)
        ;
    r.seconds = now() - t0;
    r.mib = (double)ru.ru_maxrss / 1024.0; /* kilobytes on Linux */
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return r;
}

static uint64_t le(const unsigned char *p, int bytes)
{
    uint64_t v = 0;
    for (int k = bytes - 1; k >= 0; k--)
        v = (v << 8) | p[k];
    return v;
}

/* The length of a version 6 file's MATRIX section (0 if not found). */
static uint64_t matrix_bytes(const char *path)
{
    FILE *f = fopen(path, "rb");
    unsigned char head[32], e[32];
    uint64_t len = 0;
    if (f && fread(head, 1, 32, f) == 32 && fseek(f, (long)le(head + 16, 8), SEEK_SET) == 0 &&
        fread(e, 1, 8, f) == 8) {
        uint32_t count = (uint32_t)le(e, 4);
        for (uint32_t q = 0; q < count && fread(e, 1, 32, f) == 32; q++)
            if (memcmp(e, "MTRX", 4) == 0)
                len = le(e + 16, 8);
    }
    if (f)
        fclose(f);
    return len;
}

static double file_mib(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (double)st.st_size / 1048576.0 : 0.0;
}

static void cell(const run *r)
{
    if (r->status)
        printf(" %12s", "failed");
    else
        printf(" %6.2f s %4.0fM", r->seconds, r->mib);
}

/* One row of the table: scene and options for the solve. */
static void row(const char *label, const char *dir, const char *scene, const char *patch_size)
{
    char sol[600], lit[600], exr[600];
    snprintf(sol, sizeof sol, "%s/%s.sol", dir, label);
    snprintf(lit, sizeof lit, "%s/%s-lit.sol", dir, label);
    snprintf(exr, sizeof exr, "%s/%s.exr", dir, label);
    const char *solve[] = {"radiosity", "solve", scene, "-o", sol, "--fresh",
                           patch_size ? "--patch-size" : NULL, patch_size, NULL};
    const char *report[] = {"radiosity", "report", sol, NULL};
    const char *render[] = {"radiosity", "render", sol, "-o", exr, "--size", "1024x1024", NULL};
    const char *relight[] = {"radiosity", "relight", sol, "-o", lit, "--light", "light=2", NULL};
    const char *refl[] = {"radiosity", "relight", sol, "-o", lit, "--reflectance", "floor=0.5",
                          NULL};
    run s = run_cmd(solve);
    run rp = run_cmd(report), rn = run_cmd(render), rl = run_cmd(relight), rr = run_cmd(refl);
    uint64_t F = matrix_bytes(sol);
    printf("%-6s %8.1fM %8.1fM", label, file_mib(sol), (double)F / 1048576.0);
    cell(&s);
    cell(&rp);
    cell(&rn);
    cell(&rl);
    cell(&rr);
    if (!s.status && !rl.status && !rr.status)
        printf(" %7.0f× %6.1f× %5.2f %5.2f %5.2f", s.seconds / rl.seconds, s.seconds / rr.seconds,
               s.mib * 1048576.0 / (double)F, rl.mib * 1048576.0 / (double)F,
               rr.mib * 1048576.0 / (double)F);
    printf("\n");
    fflush(stdout);
    remove(sol);
    remove(lit);
    char link[620];
    snprintf(link, sizeof link, "%s.matrix", lit);
    remove(link);
    remove(exr);
}

int main(void)
{
    char dir[] = "/tmp/bench_store_XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    printf("the stored solution: Cornell box, one run each, wall time and peak resident memory "
           "(largest process)\n");
    printf("%-6s %9s %9s %15s %15s %15s %15s %15s %8s %7s %5s %5s %5s\n", "", "file", "MATRIX",
           "solve", "report", "render 1024²", "relight --light", "relight ρ", "solve/", "solve/",
           "solve", "light", "ρ");
    printf("%-6s %9s %9s %15s %15s %15s %15s %15s %8s %7s %5s %5s %5s\n", "", "", "", "", "", "",
           "(superposed)", "(F, re-solve)", "light", "ρ", "mem/F", "mem/F", "mem/F");
    row("3k", dir, "models/cornell.gltf", NULL);
    row("8k", dir, "models/cornell.rad", "0.0156");
    const char *large = getenv("RADIOSITY_BENCH_LARGE");
    if (large && strcmp(large, "1") == 0)
        row("32k", dir, "models/cornell.rad", "0.0078");
    else
        printf("32k    (left out: a solve of minutes and a 1.8 GB file; RADIOSITY_BENCH_LARGE=1 "
               "runs it)\n");
    rmdir(dir);
    return 0;
}
