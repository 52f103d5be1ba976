/* bench_util.h - what several benchmarks share: the patch size that meshes
 * a scene into about a target number of patches, and the machine's load
 * average printed beside the timings it stretches.  Static functions in a
 * header, like test/util.h: each benchmark is one translation unit.
 */
#ifndef BENCH_UTIL_H
#define BENCH_UTIL_H

#include "../radiosity/mesh/mesh.h"

#include <dirent.h>
#include <fcntl.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

/* The patch size for about `target` patches, by bisection on rad_mesh_count,
 * so a table's sizes are the nearest the mesher makes. */
static inline double bench_patch_size_for(const rad_scene *scene, uint32_t target)
{
    double lo = 1e-4, hi = 1.0;
    for (int it = 0; it < 60; it++) {
        double mid = sqrt(lo * hi);
        rad_mesh_options mo = {.patch_size = mid};
        if (rad_mesh_count(scene, &mo) > target)
            lo = mid;
        else
            hi = mid;
    }
    return hi;
}

/* The 1-minute load average, or -1 where the system does not say. */
static inline double bench_load(void)
{
    double load[1] = {-1.0};
    return getloadavg(load, 1) == 1 ? load[0] : -1.0;
}

/* CPU seconds (user + system) of this process and of its reaped children
 * (the form-factor workers, once a solve has ended), into *self and *kids. */
static inline void bench_cpu_seconds(double *self, double *kids)
{
    struct rusage a, b;
    getrusage(RUSAGE_SELF, &a);
    getrusage(RUSAGE_CHILDREN, &b);
    *self = (double)a.ru_utime.tv_sec + 1e-6 * (double)a.ru_utime.tv_usec +
            (double)a.ru_stime.tv_sec + 1e-6 * (double)a.ru_stime.tv_usec;
    *kids = (double)b.ru_utime.tv_sec + 1e-6 * (double)b.ru_utime.tv_usec +
            (double)b.ru_stime.tv_sec + 1e-6 * (double)b.ru_stime.tv_usec;
}

/* CPU seconds (user + system) so far of this process's living children,
 * the form-factor workers while an engine holds them, from /proc/PID/stat
 * (every thread of each); 0 where /proc cannot be read. */
static inline double bench_children_cpu(void)
{
    DIR *d = opendir("/proc");
    struct dirent *e;
    double ticks = 0.0;
    const long me = (long)getpid();
    while (d && (e = readdir(d)) != NULL) {
        char path[300], buf[1024];
        if (e->d_name[0] < '1' || e->d_name[0] > '9')
            continue;
        snprintf(path, sizeof path, "/proc/%s/stat", e->d_name);
        FILE *f = fopen(path, "r");
        size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
        if (f)
            fclose(f);
        buf[n] = '\0';
        const char *p = strrchr(buf, ')'); /* after the command name */
        long ppid = 0;
        unsigned long ut = 0, st = 0;
        if (p && sscanf(p + 2, "%*c %ld %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu", &ppid, &ut,
                        &st) == 3 && ppid == me)
            ticks += (double)(ut + st);
    }
    if (d)
        closedir(d);
    return ticks / (double)sysconf(_SC_CLK_TCK);
}

/* One run of a program: wall seconds, CPU seconds (user + system, its
 * reaped children, the form-factor workers, included: wait4's usage), and
 * peak resident MiB (the largest of the process and those children). */
typedef struct bench_run {
    double wall, cpu, peak_mib;
} bench_run;

/* Runs argv[0] with argv, its stdout into out_path (NULL: /dev/null);
 * 0, or -1 with a line on stderr when it cannot start or does not exit 0. */
static inline int bench_spawn(char *const argv[], const char *out_path, bench_run *r)
{
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, out_path ? out_path : "/dev/null",
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    pid_t pid;
    int rc = posix_spawn(&pid, argv[0], &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc) {
        fprintf(stderr, "cannot run %s: %s\n", argv[0], strerror(rc));
        return -1;
    }
    int status = 0;
    struct rusage ru;
    if (wait4(pid, &status, 0, &ru) != pid || !WIFEXITED(status) || WEXITSTATUS(status)) {
        fprintf(stderr, "%s %s failed\n", argv[0], argv[1]);
        return -1;
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    r->wall = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    r->cpu = (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec +
             (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec;
    r->peak_mib = (double)ru.ru_maxrss / 1024.0;
    return 0;
}

/* One line "load average WHEN: L" beside a table. */
static inline void bench_print_load(const char *when)
{
    printf("load average %s: %.2f\n", when, bench_load());
}

/* Marks in near[m->patch_count] the patches j within `reach` of c (from c
 * to j's centre, less √A_j: issue 36's near field of a contact element);
 * returns how many. */
static inline uint32_t bench_near_set(const rad_mesh *m, rad_vec3 c, double reach, uint8_t *near)
{
    uint32_t count = 0;
    for (uint32_t j = 0; j < m->patch_count; j++) {
        const rad_vec3 q = m->patches[j].center;
        const double dx = q.x - c.x, dy = q.y - c.y, dz = q.z - c.z;
        near[j] = sqrt(dx * dx + dy * dy + dz * dz) - sqrt(m->patches[j].area) <= reach;
        count += near[j];
    }
    return count;
}

#endif /* BENCH_UTIL_H */
