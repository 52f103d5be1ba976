/* rad.c - the shared vocabulary's code: error values, the debug assertion,
 * which patches of a mesh are shared patches of small parts, and two small
 * system queries (memory, clock).  The sparse matrix is in
 * matrix.c, atomic output files in output.c.
 */
#include "rad.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

int rad_fail(rad_error *err, int code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
        err->code = code;
    }
    return code;
}

void rad_warn(rad_warn_fn fn, void *user, const char *fmt, ...)
{
    if (!fn)
        return;
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    fn(user, msg);
}

const char *rad_result_name(int code)
{
    switch (code) {
    case RAD_OK: return "ok";
    case RAD_ERR_IO: return "I/O error";
    case RAD_ERR_PARSE: return "malformed input";
    case RAD_ERR_INVALID: return "invalid input";
    case RAD_ERR_LIMIT: return "limit exceeded";
    case RAD_ERR_NOMEM: return "out of memory";
    case RAD_ERR_GL: return "OpenGL error";
    case RAD_ERR_CORRUPT: return "corrupt data";
    case RAD_ERR_USAGE: return "usage error";
    case RAD_ERR_NOTFOUND: return "not found";
    case RAD_ERR_INTERRUPTED: return "interrupted";
    default: return "unknown error";
    }
}

#ifndef NDEBUG
void rad_assert_fail(const char *expr, const char *file, int line)
{
    /* A broken invariant is a bug in this program, not bad input: stop at once. */
    fprintf(stderr, "radiosity: internal error: %s:%d: assertion failed: %s\n", file, line, expr);
    abort();
}
#endif

/* ------------------------------------------------------------------ system */

static uint64_t proc_kb(const char *path, const char *name);

uint64_t rad_available_memory(void)
{
    /* MemAvailable counts reclaimable cache; sysconf's free pages would not. */
    uint64_t avail = proc_kb("/proc/meminfo", "MemAvailable");
    if (avail)
        return avail;
    long pages = sysconf(_SC_AVPHYS_PAGES), size = sysconf(_SC_PAGESIZE);
    return (pages > 0 && size > 0) ? (uint64_t)pages * (uint64_t)size : 0;
}

/* The value of a "NAME: N kB" line of a /proc file, in bytes (0 if absent). */
static uint64_t proc_kb(const char *path, const char *name)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    char line[256];
    size_t len = strlen(name);
    uint64_t bytes = 0;
    while (fgets(line, sizeof line, f)) {
        unsigned long long kb;
        if (strncmp(line, name, len) == 0 && line[len] == ':' &&
            sscanf(line + len + 1, "%llu kB", &kb) == 1) {
            bytes = (uint64_t)kb * 1024u;
            break;
        }
    }
    fclose(f);
    return bytes;
}

uint64_t rad_process_memory(int peak)
{
    return proc_kb("/proc/self/status", peak ? "VmHWM" : "VmRSS");
}

const char *rad_human_bytes(double bytes, char *buf, size_t size)
{
    if (bytes >= 1073741824.0)
        snprintf(buf, size, "%.1f GiB", bytes / 1073741824.0);
    else if (bytes >= 1048576.0)
        snprintf(buf, size, "%.1f MiB", bytes / 1048576.0);
    else
        snprintf(buf, size, "%.1f KiB", bytes / 1024.0);
    return buf;
}

double rad_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ------------------------------------------------------ shared parts */

int rad_mesh_shared_parts(const rad_mesh *m, uint8_t *shared)
{
    for (uint32_t i = 0; i < m->patch_count; i++)
        shared[i] = 0;
    if (!m->cell_first)
        return RAD_OK;
    /* seen_by[v]: the last patch one of whose cells has vertex v; a vertex
     * met twice within one patch joins two of its cells. */
    uint32_t *seen_by = malloc(((size_t)m->vertex_count + 1) * sizeof *seen_by);
    if (!seen_by)
        return RAD_ERR_NOMEM;
    for (uint32_t v = 0; v < m->vertex_count; v++)
        seen_by[v] = RAD_NONE;
    for (uint32_t i = 0; i < m->patch_count; i++) {
        const rad_patch *c;
        const uint32_t n = rad_patch_cells(m, i, &c);
        int apart = n > 1;
        for (uint32_t a = 0; a < n; a++)
            for (int k = 0; k < rad_patch_corners(&c[a]); k++) {
                apart &= seen_by[c[a].v[k]] != i;
                seen_by[c[a].v[k]] = i;
            }
        shared[i] = (uint8_t)apart;
    }
    free(seen_by);
    return RAD_OK;
}
