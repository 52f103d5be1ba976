/* pool.c - the caller's side of the hemi-cube engine: hc_create and
 * hc_destroy, and the local fork pool, the engine's first row producer
 * (hc_pool_producer: producer.c runs a job of rows or element hemi-cubes
 * through its give and collect; radiosity-mpi's MPI producer runs it
 * beside its ranks).
 *
 * Owns the engine and its worker processes.  The caller's process never
 * creates a GL context: hc_create checks the mesh, prepares the geometry
 * (relative to the bounding-box centre, shared copy-on-write) and the
 * delta form factors (delta_factors.c), then forks `processes` workers
 * (worker.c), each with its own stream (a socketpair) and its own OSMesa
 * context.  A job of rows is handed out in small chunks,
 * at most about two per worker at a time, so faster workers take more, and
 * the answers are collected as they come (poll).  A worker that stops
 * during a job of rows (killed, crashed: its stream ends or goes out of
 * step) is reaped and replaced by a new one forked from the same engine,
 * and the rows it held are handed out again - the one it was computing
 * alone, so that a row that stops a second worker is named in an error
 * instead of stopping workers forever.  Invariants: a worker's stream is
 * either in step (every request answered in order) or the worker is
 * replaced, or the engine is broken and every later call fails with
 * broken_msg (a worker's own error report, a failed replacement, or a
 * worker lost outside a job of rows); hc_destroy always reaps every
 * worker.
 */
#include "hc_internal.h"

#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define HC_MAX_PROCESSES 1024u
/* Six vertices per quad must fit GLint `first`. */
#define HC_MAX_PATCHES (UINT32_C(1) << 28)

/* ------------------------------------------------------------ the workers */

static void stop_workers(hc_engine *e)
{
    if (!e->w)
        return;
    for (uint32_t k = 0; k < e->nproc; k++)
        if (e->w[k].fd >= 0) {
            close(e->w[k].fd);
            e->w[k].fd = -1;
        }
    /* A worker blocked in recv sees EOF at once and _exits; one that does not
     * within ~2 s (e.g. another process still holds its socket) is killed. */
    for (uint32_t k = 0; k < e->nproc; k++) {
        pid_t pid = e->w[k].pid;
        if (pid <= 0)
            continue;
        int st;
        for (int t = 0;; t++) {
            pid_t r = waitpid(pid, &st, WNOHANG);
            if (r == pid || (r < 0 && errno != EINTR))
                break;
            if (t == 2000) {
                kill(pid, SIGKILL);
                while (waitpid(pid, &st, 0) < 0 && errno == EINTR)
                    ;
                break;
            }
            struct timespec ts = {0, 1000000};
            nanosleep(&ts, NULL);
        }
        e->w[k].pid = -1;
    }
}

void hc_destroy(hc_engine *e)
{
    if (!e)
        return;
    if (e->prod)
        e->prod->stop(e);
    stop_workers(e);
    free(e->w);
    free(e->dff);
    free(e->dff_near);
    free(e->corner);
    free(e->center);
    free(e->ncorner);
    free(e->cfirst);
    free(e->shared);
    free(e->bsphere);
    free(e->poly_area);
    free(e->poly_patches);
    free(e->poly_center);
    free(e->radius);
    free(e->ofirst);
    free(e->oedge);
    free(e->exact);
    free(e->rx_col);
    free(e->rx_val);
    free(e);
}

/* Closes every descriptor but `keep` (and stdio) in a fresh worker, so that
 * no worker holds another worker's or another engine's socket: otherwise a
 * closed socket would never reach EOF and hc_destroy would wait. */
static void close_other_fds(int keep)
{
    long max = sysconf(_SC_OPEN_MAX);
    if (max < 0 || max > 65536)
        max = 65536;
#ifdef SYS_close_range
    if (keep > 3)
        syscall(SYS_close_range, 3u, (unsigned)keep - 1, 0u);
    if (syscall(SYS_close_range, (unsigned)keep + 1, ~0u, 0u) == 0)
        return;
#endif
    for (int fd = 3; fd < max; fd++)
        if (fd != keep)
            close(fd);
}

/* The worker's start-up report: ready, or its error text. */
static int read_status(hc_engine *e, uint32_t k, rad_error *err)
{
    uint32_t hdr[2];
    if (hc_wire_recv(e->w[k].fd, hdr, sizeof hdr) != 0)
        return rad_fail(err, RAD_ERR_GL, "hemi-cube: worker %u stopped while starting", k);
    if (hdr[0] == HC_MSG_READY && hdr[1] == 0)
        return RAD_OK;
    char text[HC_MAX_MSG + 1] = "";
    uint32_t len = hdr[1] > HC_MAX_MSG ? HC_MAX_MSG : hdr[1];
    if (hc_wire_recv_text(e->w[k].fd, len, text) != 0)
        return rad_fail(err, RAD_ERR_GL, "hemi-cube: worker %u stopped while starting", k);
    return rad_fail(err, RAD_ERR_GL, "%s (worker %u)", text, k);
}

/* Forks worker k on a socketpair of its own (its report not yet read). */
static int fork_worker(hc_engine *e, uint32_t k, rad_error *err)
{
    /* Stdio buffers are copied into each child; empty them so nothing the
     * caller printed can appear twice. */
    fflush(NULL);
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
        return rad_fail(err, RAD_ERR_GL, "hemi-cube: socketpair: %s", strerror(errno));
    pid_t pid = fork();
    if (pid < 0) {
        int rc = rad_fail(err, RAD_ERR_GL, "hemi-cube: fork: %s", strerror(errno));
        close(sv[0]);
        close(sv[1]);
        return rc;
    }
    if (pid == 0) {
        close_other_fds(sv[1]);
        hc_worker_main(e, sv[1]);
    }
    close(sv[1]);
    e->w[k] = (hc_worker){.pid = pid, .fd = sv[0]};
    return RAD_OK;
}

/* Forks the workers; they set up in parallel, then their reports are
 * collected.  On failure the caller destroys e. */
static int start_workers(hc_engine *e, rad_error *err)
{
    for (uint32_t k = 0; k < e->nproc; k++) {
        int rc = fork_worker(e, k, err);
        if (rc)
            return rc;
    }
    for (uint32_t k = 0; k < e->nproc; k++) {
        int rc = read_status(e, k, err);
        if (rc)
            return rc;
    }
    return RAD_OK;
}

/* Worker k is gone (its stream closed or out of step): reaps it (killing
 * it first if it still runs; how it ended into why) and starts another in
 * its place, which sets up from the same engine.  The new worker's replies
 * start afresh. */
static int replace_worker(hc_engine *e, uint32_t k, char *why, size_t size, rad_error *err)
{
    snprintf(why, size, "its stream was out of step");
    if (e->w[k].fd >= 0)
        close(e->w[k].fd);
    if (e->w[k].pid > 0) {
        int st = 0;
        /* closing the stream ends a live worker; one that lingers is killed */
        pid_t r = 0;
        for (int t = 0; t < 200 && (r = waitpid(e->w[k].pid, &st, WNOHANG)) == 0; t++) {
            struct timespec ts = {0, 1000000};
            nanosleep(&ts, NULL);
        }
        if (r == 0) {
            kill(e->w[k].pid, SIGKILL);
            while ((r = waitpid(e->w[k].pid, &st, 0)) < 0 && errno == EINTR)
                ;
        }
        if (r > 0 && WIFSIGNALED(st))
            snprintf(why, size, "killed by signal %d", WTERMSIG(st));
        else if (r > 0 && WIFEXITED(st))
            snprintf(why, size, "exited with status %d", WEXITSTATUS(st));
    }
    e->w[k] = (hc_worker){.pid = -1, .fd = -1};
    int rc = fork_worker(e, k, err);
    if (!rc)
        rc = read_status(e, k, err);
    if (rc) {
        e->broken = 1;
        snprintf(e->broken_msg, sizeof e->broken_msg, "hemi-cube worker %u stopped and could not "
                 "be replaced", k);
    }
    return rc;
}

/* ------------------------------------------------------------- the engine */

/* The options with their defaults filled in; *cpus: online CPUs (1..64). */
static int check_options(const hc_options *opt, hc_options *o, long *cpus, rad_error *err)
{
    *o = (hc_options){0};
    if (opt)
        *o = *opt;
    if (o->resolution == 0)
        o->resolution = HC_DEFAULT_RESOLUTION;
    if (!hc_resolution_ok(o->resolution))
        return rad_fail(err, RAD_ERR_USAGE,
                        "hc_create: hemi-cube resolution %u: must be even and within 8..4096",
                        o->resolution);
    if (o->processes > HC_MAX_PROCESSES)
        return rad_fail(err, RAD_ERR_USAGE, "hc_create: %u worker processes: at most %u",
                        o->processes, HC_MAX_PROCESSES);
    if (o->weak < HC_WEAK_OFF || o->weak > HC_WEAK_SURFACE)
        return rad_fail(err, RAD_ERR_USAGE, "hc_create: weak %d: must be 0, 1, 2 or 3", o->weak);
    *cpus = sysconf(_SC_NPROCESSORS_ONLN);
    *cpus = *cpus < 1 ? 1 : *cpus > 64 ? 64 : *cpus;
    if (o->processes == 0)
        o->processes = (uint32_t)*cpus;
    return RAD_OK;
}

/* Checks every index before any of it is used (the cells' too); finds the
 * bounding box. */
static int check_mesh(const rad_mesh *mesh, rad_vec3 *lo_out, rad_vec3 *hi_out, rad_error *err)
{
    uint32_t n = mesh->patch_count;
    if (n > HC_MAX_PATCHES || (mesh->cell_first && mesh->cell_count > HC_MAX_PATCHES))
        return rad_fail(err, RAD_ERR_LIMIT, "hc_create: %u patches: the hemi-cube handles at most %u",
                        n, HC_MAX_PATCHES);
    if (n && (!mesh->patches || !mesh->vertices))
        return rad_fail(err, RAD_ERR_USAGE, "hc_create: mesh has %u patches but no arrays", n);
    if (mesh->cell_first && (!mesh->cells || mesh->cell_first[0] != 0 ||
                             mesh->cell_first[n] != mesh->cell_count))
        return rad_fail(err, RAD_ERR_USAGE, "hc_create: the cells do not cover the patches");
    rad_vec3 lo = rad_v3(INFINITY, INFINITY, INFINITY), hi = rad_scale(lo, -1);
    for (uint32_t j = 0; j < n; j++) {
        const rad_patch *p = &mesh->patches[j], *cell;
        if (mesh->cell_first && mesh->cell_first[j + 1] <= mesh->cell_first[j])
            return rad_fail(err, RAD_ERR_USAGE, "hc_create: patch %u has no cell", j);
        uint32_t ncells = rad_patch_cells(mesh, j, &cell);
        for (uint32_t c = 0; c < ncells; c++) {
            int nc = rad_patch_corners(&cell[c]);
            for (int k = 0; k < nc; k++) {
                uint32_t v = cell[c].v[k];
                if (v >= mesh->vertex_count)
                    return rad_fail(err, RAD_ERR_USAGE,
                                    "hc_create: patch %u: vertex index %u out of range", j, v);
                rad_vec3 q = mesh->vertices[v];
                if (!rad_finite3(q))
                    return rad_fail(err, RAD_ERR_USAGE,
                                    "hc_create: patch %u: vertex %u is not finite", j, v);
                lo = rad_v3(fmin(lo.x, q.x), fmin(lo.y, q.y), fmin(lo.z, q.z));
                hi = rad_v3(fmax(hi.x, q.x), fmax(hi.y, q.y), fmax(hi.z, q.z));
            }
        }
        double nl = rad_length(p->normal);
        if (!rad_finite3(p->center) || !(fabs(nl - 1.0) < 1e-6) || !(p->area > 0.0) ||
            !isfinite(p->area))
            return rad_fail(err, RAD_ERR_USAGE,
                            "hc_create: patch %u: needs a finite centre, a unit normal and area > 0", j);
    }
    *lo_out = lo;
    *hi_out = hi;
    return RAD_OK;
}

/* A new engine with every array allocated (workers not started); RAD_OK or
 * RAD_ERR_NOMEM. */
static int engine_alloc(const rad_mesh *mesh, const hc_options *o, long cpus, hc_engine **out,
                        rad_error *err)
{
    uint32_t n = mesh->patch_count;
    hc_engine *e = calloc(1, sizeof *e);
    if (!e)
        return rad_fail(err, RAD_ERR_NOMEM, "hc_create: out of memory");
    e->mesh = mesh;
    e->n = n;
    e->R = o->resolution;
    e->nproc = o->processes;
    e->lp_threads = (uint32_t)cpus / o->processes >= 2 ? (uint32_t)cpus / o->processes : 0;
    e->opt = *o;
    size_t npix = (size_t)3 * e->R * e->R;
    e->dff = malloc(npix * sizeof *e->dff);
    e->R_near = e->R % 4 == 0 && e->R >= 32 ? e->R / 2 : e->R;
    e->dff_near = malloc((size_t)3 * e->R_near * e->R_near * sizeof *e->dff_near);
    e->ncell = mesh->cell_first ? mesh->cell_count : n;
    size_t nc = e->ncell ? e->ncell : 1;
    e->cfirst = malloc(((size_t)n + 1) * sizeof *e->cfirst);
    e->shared = malloc((size_t)n + 1);
    e->corner = malloc(nc * 12 * sizeof *e->corner);
    e->center = malloc((n ? n : 1) * sizeof *e->center);
    e->ncorner = malloc(nc);
    e->bsphere = malloc(((size_t)n / HC_BLOCK + 1) * 4 * sizeof *e->bsphere);
    e->radius = malloc((n ? n : 1) * sizeof *e->radius);
    e->npoly = 0;
    for (uint32_t j = 0; j < n; j++)
        e->npoly = mesh->patches[j].polygon >= e->npoly ? mesh->patches[j].polygon + 1 : e->npoly;
    e->poly_area = calloc((size_t)e->npoly + 1, sizeof *e->poly_area);
    e->poly_patches = calloc((size_t)e->npoly + 1, sizeof *e->poly_patches);
    e->poly_center = calloc((size_t)e->npoly + 1, sizeof *e->poly_center);
    e->rx_col = malloc((n ? n : 1) * sizeof *e->rx_col);
    e->rx_val = malloc((n ? n : 1) * sizeof *e->rx_val);
    e->w = calloc(e->nproc, sizeof *e->w);
    if (o->exact && n) {
        /* Read once here: later changes to the caller's array never reach
         * workers that already forked, so none may reach the caller either. */
        e->exact = malloc(n);
        if (e->exact) {
            memcpy(e->exact, o->exact, n);
            for (uint32_t j = 0; j < n && !e->any_exact; j++)
                e->any_exact = e->exact[j] != 0;
        }
    }
    e->any_exact |= n > 1; /* small polygons get exact entries (rows.c) */
    e->opt.exact = e->exact;
    if (!e->dff || !e->dff_near || !e->cfirst || !e->shared || rad_mesh_shared_parts(mesh, e->shared) != RAD_OK ||
        !e->corner || !e->center || !e->ncorner || !e->bsphere ||
        !e->radius || !e->poly_area || !e->poly_center || !e->poly_patches ||
        !e->rx_col || !e->rx_val || !e->w || (o->exact && n && !e->exact)) {
        hc_destroy(e);
        return rad_fail(err, RAD_ERR_NOMEM, "hc_create: out of memory for %u patches at resolution %u",
                        n, o->resolution);
    }
    for (uint32_t k = 0; k < e->nproc; k++) {
        e->w[k].fd = -1;
        e->w[k].pid = -1;
    }
    *out = e;
    return RAD_OK;
}

/* The geometry relative to the bounding box [lo, hi]'s centre: corners,
 * centres, radii, the scene radius and the "strictly in front" margin. */
static void prepare_geometry(hc_engine *e, rad_vec3 lo, rad_vec3 hi)
{
    const rad_mesh *mesh = e->mesh;
    uint32_t n = e->n;
    if (n) {
        e->origin = rad_scale(rad_add(lo, hi), 0.5);
        double diag = rad_length(rad_sub(hi, lo));
        double far = fmax(fmax(fabs(lo.x), fabs(hi.x)), fmax(fmax(fabs(lo.y), fabs(hi.y)),
                                                              fmax(fabs(lo.z), fabs(hi.z))));
        /* Above the rounding noise of coordinates this far from 0, far below
         * any real gap between surfaces. */
        e->tol = 1e-9 * diag + 1e-12 * far;
    }
    uint32_t c0 = 0;
    for (uint32_t j = 0; j < n; j++) {
        const rad_patch *p = &mesh->patches[j], *cell;
        const uint32_t ncells = rad_patch_cells(mesh, j, &cell);
        e->cfirst[j] = c0;
        e->center[j] = rad_sub(p->center, e->origin);
        double r2 = 0.0, b2 = 0.0;
        for (uint32_t c = 0; c < ncells; c++, c0++) {
            int nc = rad_patch_corners(&cell[c]);
            double *corner = e->corner + (size_t)c0 * 12;
            e->ncorner[c0] = (uint8_t)nc;
            for (int k = 0; k < 4; k++) {
                rad_vec3 q = rad_sub(mesh->vertices[cell[c].v[k < nc ? k : 0]], e->origin);
                corner[3 * k + 0] = q.x;
                corner[3 * k + 1] = q.y;
                corner[3 * k + 2] = q.z;
                rad_vec3 d = rad_sub(q, e->center[j]);
                r2 = fmax(r2, rad_dot(d, d));
                b2 = fmax(b2, rad_dot(q, q));
            }
        }
        e->radius[j] = sqrt(r2);
        e->bradius = fmax(e->bradius, sqrt(b2));
        e->poly_area[p->polygon] += p->area;
        e->poly_patches[p->polygon]++;
        e->poly_center[p->polygon] =
            rad_add(e->poly_center[p->polygon], rad_scale(e->center[j], p->area));
    }
    e->cfirst[n] = c0;
    for (uint32_t q = 0; q < e->npoly; q++)
        if (e->poly_area[q] > 0.0)
            e->poly_center[q] = rad_scale(e->poly_center[q], 1.0 / e->poly_area[q]);
}

/* An edge of a cell by its mesh vertices: (lo, hi) and whether it runs
 * lo -> hi (dir 1) or back (0); `at` is its start corner in e->corner. */
typedef struct cell_edge {
    uint32_t lo, hi;
    uint32_t dir;
    uint32_t at, to; /* corner indices (cell × 4 + k) of its start and end */
} cell_edge;

static int edge_order(const void *pa, const void *pb)
{
    const cell_edge *a = pa, *b = pb;
    if (a->lo != b->lo)
        return a->lo < b->lo ? -1 : 1;
    if (a->hi != b->hi)
        return a->hi < b->hi ? -1 : 1;
    return (a->dir > b->dir) - (a->dir < b->dir);
}

/* e->ofirst and e->oedge (hc_internal.h) for every cluster of the mesh: its
 * cells' edges by mesh vertex, sorted so the two runs of one inner edge
 * meet; of an edge run f times one way and b times the other, |f - b| are
 * kept, in the majority's direction (the rest cancel in pairs). */
static int cluster_outlines(hc_engine *e, rad_error *err)
{
    const rad_mesh *m = e->mesh;
    if (!m->cell_first || !e->n)
        return RAD_OK;
    uint32_t most = 0;
    for (uint32_t j = 0; j < e->n; j++)
        most = e->cfirst[j + 1] - e->cfirst[j] > most ? e->cfirst[j + 1] - e->cfirst[j] : most;
    e->ofirst = calloc((size_t)e->n + 1, sizeof *e->ofirst);
    cell_edge *ed = malloc(4 * (size_t)most * sizeof *ed);
    size_t cap = 0, used = 0;
    int rc = e->ofirst && ed ? RAD_OK : RAD_ERR_NOMEM;
    for (uint32_t j = 0; j < e->n && rc == RAD_OK; j++) {
        const rad_patch *cells;
        const uint32_t nc = rad_patch_cells(m, j, &cells);
        e->ofirst[j] = (uint32_t)used;
        if (nc < 2)
            continue;
        uint32_t ne = 0;
        for (uint32_t c = 0; c < nc; c++) {
            const int k = rad_patch_corners(&cells[c]);
            for (int q = 0; q < k; q++) {
                uint32_t a = cells[c].v[q], b = cells[c].v[(q + 1) % k];
                uint32_t base = (e->cfirst[j] + c) * 4;
                ed[ne++] = (cell_edge){a < b ? a : b, a < b ? b : a, a < b, base + (uint32_t)q,
                                       base + (uint32_t)((q + 1) % k)};
            }
        }
        qsort(ed, ne, sizeof *ed, edge_order);
        size_t kept = 0, start = used;
        for (uint32_t r = 0; r < ne && rc == RAD_OK;) {
            uint32_t z = r, fwd = 0;
            while (z < ne && ed[z].lo == ed[r].lo && ed[z].hi == ed[r].hi)
                fwd += ed[z++].dir;
            const uint32_t back = z - r - fwd, keep = fwd > back ? fwd - back : back - fwd;
            /* the run is sorted back edges first: the majority's are at its ends */
            for (uint32_t t = 0; t < keep; t++) {
                const cell_edge *x = fwd > back ? &ed[z - 1 - t] : &ed[r + t];
                if (used == cap) {
                    cap = cap ? 2 * cap : 4096;
                    double *g = realloc(e->oedge, cap * 6 * sizeof *g);
                    if (!g) {
                        rc = RAD_ERR_NOMEM;
                        break;
                    }
                    e->oedge = g;
                }
                memcpy(e->oedge + 6 * used, e->corner + 3 * (size_t)x->at, 3 * sizeof(double));
                memcpy(e->oedge + 6 * used + 3, e->corner + 3 * (size_t)x->to, 3 * sizeof(double));
                used++;
                kept++;
            }
            r = z;
        }
        if (kept >= ne) /* nothing cancels: the cells themselves are as cheap */
            used = start;
    }
    if (rc == RAD_OK)
        e->ofirst[e->n] = (uint32_t)used;
    free(ed);
    if (rc != RAD_OK || used > UINT32_MAX)
        return rad_fail(err, RAD_ERR_NOMEM, "hc_create: out of memory for the clusters' outlines");
    return RAD_OK;
}

/* The bounding sphere of every HC_BLOCK consecutive patches (rows.c culls
 * a block against i's plane at once). */
static void block_spheres(hc_engine *e)
{
    uint32_t n = e->n;
    for (uint32_t b0 = 0; b0 < n; b0 += HC_BLOCK) {
        uint32_t b1 = n - b0 < HC_BLOCK ? n : b0 + HC_BLOCK;
        const double *q0 = e->corner + (size_t)e->cfirst[b0] * 12;
        const double *q1 = e->corner + (size_t)e->cfirst[b1] * 12;
        double lo3[3] = {INFINITY, INFINITY, INFINITY}, hi3[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (const double *q = q0; q < q1; q += 3)
            for (int a = 0; a < 3; a++) {
                lo3[a] = fmin(lo3[a], q[a]);
                hi3[a] = fmax(hi3[a], q[a]);
            }
        double *sp = e->bsphere + 4 * (size_t)(b0 / HC_BLOCK), r2 = 0.0;
        for (int a = 0; a < 3; a++)
            sp[a] = 0.5 * (lo3[a] + hi3[a]);
        for (const double *q = q0; q < q1; q += 3) {
            double d2 = (q[0] - sp[0]) * (q[0] - sp[0]) + (q[1] - sp[1]) * (q[1] - sp[1]) +
                        (q[2] - sp[2]) * (q[2] - sp[2]);
            r2 = fmax(r2, d2);
        }
        /* A hair larger than exact so rounding can never cull a corner. */
        sp[3] = sqrt(r2) * (1.0 + 1e-12) + e->tol;
    }
}

int hc_create(const rad_mesh *mesh, const hc_options *opt, hc_engine **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!mesh || !out)
        return rad_fail(err, RAD_ERR_USAGE, "hc_create: mesh and out must not be NULL");
    hc_options o;
    long cpus = 1;
    rad_vec3 lo = rad_v3(0, 0, 0), hi = lo;
    hc_engine *e = NULL;
    int rc = check_options(opt, &o, &cpus, err);
    if (rc == RAD_OK)
        rc = hc_gl_settle(&o, err); /* GL back end: gl_choice.c (issue 38) */
    if (rc == RAD_OK)
        rc = check_mesh(mesh, &lo, &hi, err);
    if (rc == RAD_OK)
        rc = engine_alloc(mesh, &o, cpus, &e, err);
    if (rc != RAD_OK)
        return rc;
    hc_delta_form_factors(e->R, e->dff);
    hc_delta_form_factors(e->R_near, e->dff_near);
    prepare_geometry(e, lo, hi);
    block_spheres(e);
    rc = cluster_outlines(e, err);
    e->processes_asked = opt ? opt->processes : 0;
    e->prod = hc_remote_producer ? hc_remote_producer : &hc_pool_producer;
    if (rc == RAD_OK)
        rc = e->prod->start(e, err);
    if (rc != RAD_OK) {
        hc_destroy(e);
        return rc;
    }
    *out = e;
    return RAD_OK;
}

/* ------------------------------------------------- the pool as a producer */

/* A worker is topped up while it holds at most `chunk` items, so it holds
 * at most 2 × HC_MAX_CHUNK of them, in at most that many ranges. */
#define HC_MAX_HELD (2u * HC_MAX_CHUNK + 1u)

/* The pool's bookkeeping of one run: each worker's ranges in the order
 * sent (answers come in the order asked), and poll's arrays. */
typedef struct pool_run {
    hc_range *held;      /* nproc × HC_MAX_HELD */
    uint32_t *nheld;     /* per worker */
    struct pollfd *pf;
    uint32_t *who;
} pool_run;

/* Worker k stopped.  The item it was computing (the first unanswered one it
 * holds) takes a strike: a second strike is the error, so that an item that
 * stops a second worker is known for certain and ends the job with an error
 * naming it, never a loop.  What it held goes back to be handed out again
 * (the struck item alone), and a new worker takes its place. */
static void worker_lost(hc_engine *e, hc_run *run, uint32_t k, rad_error *err)
{
    const hc_job *job = run->job;
    pool_run *pr = run->local;
    hc_range *held = pr->held + (size_t)k * HC_MAX_HELD;
    char why[96];
    rad_error sub;
    int rc = replace_worker(e, k, why, sizeof why, &sub);
    if (pr->nheld[k] && run->rc == RAD_OK) {
        uint32_t item = held[0].first + held[0].done;
        if (++run->strikes[item] >= 2)
            hc_run_fail(run,
                        rad_fail(err, RAD_ERR_GL,
                                 "hemi-cube: the %s of patch %u stopped two workers (the last %s); "
                                 "it cannot be computed", job->recv ? "element hemi-cube" : "row",
                                 hc_item_patch(job, item), why));
    }
    for (uint32_t q = 0; q < pr->nheld[k] && run->rc == RAD_OK; q++) {
        uint32_t first = held[q].first + held[q].done, left = held[q].count - held[q].done;
        if (q == 0) { /* the one it was computing goes alone */
            hc_run_retry(run, first, 1);
            first++;
            left--;
        }
        hc_run_retry(run, first, left);
    }
    pr->nheld[k] = 0;
    if (rc)
        hc_run_fail(run, rad_fail(err, rc, "%s", sub.message));
}

static int send_chunk(hc_engine *e, uint32_t k, const hc_job *job, uint32_t first, uint32_t count)
{
    int rc;
    if (job->recv) {
        hc_point_req pts[HC_MAX_CHUNK];
        for (uint32_t q = 0; q < count; q++) {
            const hc_receiver *r = &job->recv[first + q];
            rad_vec3 at = rad_sub(r->center, e->origin);
            pts[q] = (hc_point_req){first + q, r->patch, {at.x, at.y, at.z}, r->reach};
        }
        rc = hc_wire_send_points(e->w[k].fd, pts, count);
    } else {
        rc = hc_wire_send_rows(e->w[k].fd, job->rows + first, count);
    }
    if (rc != 0)
        return -1;
    e->w[k].in_flight += count;
    return 0;
}

/* Tops worker k up to two requests' worth: items handed out again first,
 * then new ones.  A worker that cannot be sent to is replaced. */
static void top_up(hc_engine *e, hc_run *run, uint32_t k, rad_error *err)
{
    pool_run *pr = run->local;
    hc_range *held = pr->held + (size_t)k * HC_MAX_HELD;
    hc_range r;
    while (run->rc == RAD_OK && e->w[k].in_flight <= run->chunk && pr->nheld[k] < HC_MAX_HELD &&
           hc_run_take(e, run, run->chunk, &r)) {
        if (send_chunk(e, k, run->job, r.first, r.count) != 0) {
            /* it never got these: they go back without a strike */
            hc_run_retry(run, r.first, r.count);
            worker_lost(e, run, k, err);
            return;
        }
        held[pr->nheld[k]++] = r;
    }
}

/* Reads two words, or says the stream ended (-1) or the worker sent its
 * error text and exited (-2, the engine is then broken, err filled). */
static int batch_word(hc_engine *e, uint32_t k, uint32_t w[2], rad_error *err)
{
    if (hc_wire_recv(e->w[k].fd, w, 2 * sizeof *w) != 0)
        return -1;
    if (w[0] == HC_MSG_ERROR) {
        hc_pool_error(e, k, w[1], err);
        return -2;
    }
    return 0;
}

/* One answered row: in order, well formed, then stored (hc_run_store).
 * 0, or -1 when the stream is out of step. */
static int receive_row(hc_engine *e, hc_run *run, uint32_t k, hc_range *r, rad_error *err)
{
    uint32_t rh[2];
    int s = batch_word(e, k, rh, err);
    if (s == -2)
        hc_run_fail(run, RAD_ERR_GL);
    if (s != 0)
        return -1;
    uint32_t cnt = rh[1];
    if (cnt > e->n ||
        hc_wire_recv(e->w[k].fd, e->rx_col, (size_t)cnt * sizeof *e->rx_col) != 0 ||
        hc_wire_recv(e->w[k].fd, e->rx_val, (size_t)cnt * sizeof *e->rx_val) != 0 ||
        hc_run_store(e, run, r->first + r->done, rh[0], cnt, e->rx_col, e->rx_val, err) != 0)
        return -1;
    r->done++;
    e->w[k].in_flight--;
    return 0;
}

/* Reads one answer of worker k: the rows of its oldest range.  A stream
 * that ends or goes out of step is a worker lost. */
static void receive_batch(hc_engine *e, hc_run *run, uint32_t k, rad_error *err)
{
    pool_run *pr = run->local;
    hc_range *held = pr->held + (size_t)k * HC_MAX_HELD;
    uint32_t hdr[2];
    int s = pr->nheld[k] ? batch_word(e, k, hdr, err) : -1;
    if (s == -2) {
        hc_run_fail(run, RAD_ERR_GL);
        return;
    }
    if (s == 0 && (hdr[0] != HC_MSG_BATCH || hdr[1] != held[0].count - held[0].done))
        s = -1;
    for (uint32_t q = 0; s == 0 && q < hdr[1]; q++)
        s = receive_row(e, run, k, &held[0], err);
    if (s == -2 || (s != 0 && e->broken)) {
        hc_run_fail(run, RAD_ERR_GL);
        return;
    }
    if (s != 0) {
        worker_lost(e, run, k, err);
        return;
    }
    memmove(held, held + 1, (pr->nheld[k] - 1) * sizeof *held);
    pr->nheld[k]--;
}

static void pool_end(hc_engine *e, hc_run *run)
{
    (void)e;
    pool_run *pr = run->local;
    if (!pr)
        return;
    free(pr->held);
    free(pr->nheld);
    free(pr->pf);
    free(pr->who);
    free(pr);
    run->local = NULL;
}

static int pool_begin(hc_engine *e, hc_run *run, rad_error *err)
{
    pool_run *pr = calloc(1, sizeof *pr);
    run->local = pr;
    if (pr) {
        pr->held = malloc((size_t)e->nproc * HC_MAX_HELD * sizeof *pr->held);
        pr->nheld = calloc(e->nproc, sizeof *pr->nheld);
        pr->pf = malloc(e->nproc * sizeof *pr->pf);
        pr->who = malloc(e->nproc * sizeof *pr->who);
    }
    if (!pr || !pr->held || !pr->nheld || !pr->pf || !pr->who) {
        pool_end(e, run);
        return rad_fail(err, RAD_ERR_NOMEM, "hemi-cube: out of memory");
    }
    return RAD_OK;
}

static void pool_give(hc_engine *e, hc_run *run, rad_error *err)
{
    for (uint32_t k = 0; k < e->nproc && !e->broken; k++)
        top_up(e, run, k, err);
}

/* Waits for the workers' answers (poll) and reads those that came.  After
 * a failure the remaining answers are read and dropped, so the workers
 * stay in step for the next call. */
static uint32_t pool_collect(hc_engine *e, hc_run *run, int timeout_ms, rad_error *err)
{
    pool_run *pr = run->local;
    nfds_t np = 0;
    for (uint32_t k = 0; k < e->nproc && !e->broken; k++)
        if (e->w[k].in_flight) {
            pr->pf[np] = (struct pollfd){.fd = e->w[k].fd, .events = POLLIN};
            pr->who[np++] = k;
        }
    if (np == 0)
        return 0;
    int got = poll(pr->pf, np, timeout_ms);
    if (got < 0 && errno != EINTR) {
        hc_run_fail(run, rad_fail(err, RAD_ERR_GL, "hemi-cube: poll: %s", strerror(errno)));
        /* Replies cannot be drained: the protocol is out of step. */
        e->broken = 1;
        snprintf(e->broken_msg, sizeof e->broken_msg, "hemi-cube: workers out of step");
        return 0;
    }
    for (nfds_t q = 0; got > 0 && q < np && !e->broken; q++)
        if (pr->pf[q].revents)
            receive_batch(e, run, pr->who[q], err);
    uint32_t held = 0;
    for (uint32_t k = 0; k < e->nproc && !e->broken; k++)
        held += e->w[k].in_flight;
    return held;
}

static void pool_stop(hc_engine *e)
{
    stop_workers(e);
}

const hc_producer hc_pool_producer = {
    .name = "local worker processes",
    .start = start_workers,
    .begin = pool_begin,
    .give = pool_give,
    .collect = pool_collect,
    .end = pool_end,
    .light_power = hc_pool_light_power,
    .light_vis = hc_pool_light_vis,
    .stop = pool_stop,
};
