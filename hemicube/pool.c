/* pool.c - the caller's side of the hemi-cube engine: hc_create,
 * hc_destroy, hc_compute_rows, hc_compute_points.
 *
 * Owns the engine and its worker processes.  The caller's process never
 * creates a GL context: hc_create checks the mesh, prepares the geometry
 * (relative to the bounding-box centre, shared copy-on-write), then forks
 * `processes` workers (worker.c), each with its own stream (a socketpair)
 * and its own OSMesa context.  A job of rows is handed out in small chunks,
 * at most about two per worker at a time, so faster workers take more, and
 * the answers are collected as they come (poll).  Invariants: a worker's
 * stream is either in step (every request answered in order) or the engine
 * is broken and every later call fails with broken_msg; hc_destroy always
 * reaps every worker.
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
    stop_workers(e);
    free(e->w);
    free(e->dff);
    free(e->corner);
    free(e->center);
    free(e->ncorner);
    free(e->cfirst);
    free(e->bsphere);
    free(e->radius);
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

/* Forks the workers, each on its own socketpair; they set up in parallel,
 * then their reports are collected.  On failure the caller destroys e. */
static int start_workers(hc_engine *e, rad_error *err)
{
    /* Stdio buffers are copied into each child; empty them so nothing the
     * caller printed can appear twice. */
    fflush(NULL);
    for (uint32_t k = 0; k < e->nproc; k++) {
        int sv[2];
        if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
            return rad_fail(err, RAD_ERR_GL, "hc_create: socketpair: %s", strerror(errno));
        pid_t pid = fork();
        if (pid < 0) {
            int rc = rad_fail(err, RAD_ERR_GL, "hc_create: fork: %s", strerror(errno));
            close(sv[0]);
            close(sv[1]);
            return rc;
        }
        if (pid == 0) {
            close_other_fds(sv[1]);
            hc_worker_main(e, sv[1]);
        }
        close(sv[1]);
        e->w[k].pid = pid;
        e->w[k].fd = sv[0];
    }
    for (uint32_t k = 0; k < e->nproc; k++) {
        int rc = read_status(e, k, err);
        if (rc)
            return rc;
    }
    return RAD_OK;
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
    e->ncell = mesh->cell_first ? mesh->cell_count : n;
    size_t nc = e->ncell ? e->ncell : 1;
    e->cfirst = malloc(((size_t)n + 1) * sizeof *e->cfirst);
    e->corner = malloc(nc * 12 * sizeof *e->corner);
    e->center = malloc((n ? n : 1) * sizeof *e->center);
    e->ncorner = malloc(nc);
    e->bsphere = malloc(((size_t)n / HC_BLOCK + 1) * 4 * sizeof *e->bsphere);
    e->radius = malloc((n ? n : 1) * sizeof *e->radius);
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
    e->any_exact |= o->exact_near != 0 && n > 1;
    e->opt.exact = e->exact;
    if (!e->dff || !e->cfirst || !e->corner || !e->center || !e->ncorner || !e->bsphere || !e->radius ||
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
    }
    e->cfirst[n] = c0;
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
        rc = check_mesh(mesh, &lo, &hi, err);
    if (rc == RAD_OK)
        rc = engine_alloc(mesh, &o, cpus, &e, err);
    if (rc != RAD_OK)
        return rc;
    hc_delta_form_factors(e->R, e->dff);
    prepare_geometry(e, lo, hi);
    block_spheres(e);
    rc = start_workers(e, err);
    if (rc != RAD_OK) {
        hc_destroy(e);
        return rc;
    }
    *out = e;
    return RAD_OK;
}

/* ------------------------------------------------------------------- jobs */

/* One call's work and where its answers go: rows of patches into F, or
 * rows of point receivers handed to the caller's store. */
typedef struct hc_job {
    const uint32_t *rows;       /* rows: patch indices */
    rad_matrix *F;
    const hc_receiver *recv;    /* points */
    hc_row_store store;
    void *user;
    uint32_t count;
} hc_job;

static int send_chunk(hc_engine *e, uint32_t k, const hc_job *job, uint32_t first, uint32_t count)
{
    int rc;
    if (job->recv) {
        hc_point_req pts[HC_MAX_CHUNK];
        for (uint32_t q = 0; q < count; q++) {
            const hc_receiver *r = &job->recv[first + q];
            rad_vec3 at = rad_sub(r->center, e->origin);
            pts[q] = (hc_point_req){first + q, r->patch, {at.x, at.y, at.z}};
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

int hc_pool_gone(hc_engine *e, uint32_t k, rad_error *err)
{
    e->broken = 1;
    snprintf(e->broken_msg, sizeof e->broken_msg, "hemi-cube worker %u stopped", k);
    e->w[k].in_flight = 0;
    return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
}

/* Reads the len bytes of worker k's error text (the worker has exited),
 * marks the engine broken and fails with that text. */
static int worker_error(hc_engine *e, uint32_t k, uint32_t len, rad_error *err)
{
    char text[HC_MAX_MSG + 1] = "";
    if (hc_wire_recv_text(e->w[k].fd, len, text) != 0)
        return hc_pool_gone(e, k, err);
    e->broken = 1;
    snprintf(e->broken_msg, sizeof e->broken_msg, "%s (worker %u)", text, k);
    e->w[k].in_flight = 0;
    return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
}

int hc_pool_header(hc_engine *e, uint32_t k, uint32_t hdr[2], rad_error *err)
{
    if (hc_wire_recv(e->w[k].fd, hdr, 2 * sizeof *hdr) != 0)
        return hc_pool_gone(e, k, err);
    if (hdr[0] == HC_MSG_ERROR)
        return worker_error(e, k, hdr[1], err);
    return RAD_OK;
}

void hc_pool_drop(hc_engine *e, uint32_t k)
{
    close(e->w[k].fd);
    e->w[k].fd = -1;
}

static void keep_first(int *rc, int code)
{
    if (*rc == RAD_OK)
        *rc = code;
}

/* Reads one answer of worker k (a batch of rows) and stores its rows in F
 * while *rc is RAD_OK; the first failure lands in *rc and err.  After a
 * failure to store, the rest is still read so the stream stays in step. */
static void receive_batch(hc_engine *e, uint32_t k, const hc_job *job, int *rc, uint32_t *done,
                          rad_error *err)
{
    int fd = e->w[k].fd;
    rad_error *first = *rc == RAD_OK ? err : NULL;
    uint32_t hdr[2];
    int s = hc_pool_header(e, k, hdr, first);
    if (s == RAD_OK && (hdr[0] != HC_MSG_BATCH || hdr[1] == 0 || hdr[1] > e->w[k].in_flight))
        s = hc_pool_gone(e, k, first);
    if (s != RAD_OK) {
        keep_first(rc, s);
        return;
    }
    for (uint32_t r = 0; r < hdr[1]; r++) {
        first = *rc == RAD_OK ? err : NULL;
        uint32_t rh[2];
        s = hc_pool_header(e, k, rh, first);
        if (s != RAD_OK) {
            keep_first(rc, s);
            return;
        }
        /* i: the patch of a row, or the receiver number of a point. */
        uint32_t i = rh[0], cnt = rh[1];
        if (i >= (job->recv ? job->count : e->n) || cnt > e->n ||
            hc_wire_recv(fd, e->rx_col, (size_t)cnt * sizeof *e->rx_col) != 0 ||
            hc_wire_recv(fd, e->rx_val, (size_t)cnt * sizeof *e->rx_val) != 0) {
            keep_first(rc, hc_pool_gone(e, k, first));
            return;
        }
        e->w[k].in_flight--;
        if (*rc != RAD_OK)
            continue;
        uint32_t self = job->recv ? job->recv[i].patch : i;
        for (uint32_t q = 0; q < cnt; q++)
            if (e->rx_col[q] >= e->n || e->rx_col[q] == self ||
                (q && e->rx_col[q] <= e->rx_col[q - 1]) || !(e->rx_val[q] > 0.0f) ||
                !isfinite(e->rx_val[q])) {
                keep_first(rc, hc_pool_gone(e, k, err));
                return;
            }
        s = job->recv ? job->store(job->user, i, cnt, e->rx_col, e->rx_val, err)
                      : rad_matrix_set_row(job->F, i, cnt, e->rx_col, e->rx_val, err);
        if (s != RAD_OK) {
            keep_first(rc, s);
            continue;
        }
        (*done)++;
        if (e->opt.progress)
            e->opt.progress(e->opt.progress_user, *done, job->count);
    }
}

static int run_job(hc_engine *e, const hc_job *job, rad_error *err);

int hc_compute_rows(hc_engine *e, const uint32_t *rows, uint32_t count, rad_matrix *F,
                    rad_error *err)
{
    if (!e || !F || (count && !rows))
        return rad_fail(err, RAD_ERR_USAGE, "hc_compute_rows: engine, matrix and rows must be given");
    if (F->n != e->n)
        return rad_fail(err, RAD_ERR_USAGE, "hc_compute_rows: matrix has %u rows, the mesh %u patches",
                        F->n, e->n);
    for (uint32_t k = 0; k < count; k++)
        if (rows[k] >= e->n)
            return rad_fail(err, RAD_ERR_USAGE, "hc_compute_rows: row %u: no such patch (%u patches)",
                            rows[k], e->n);
    hc_job job = {.rows = rows, .F = F, .count = count};
    return run_job(e, &job, err);
}

int hc_compute_points(hc_engine *e, const hc_receiver *recv, uint32_t count, hc_row_store store,
                      void *user, rad_error *err)
{
    if (!e || !store || (count && !recv))
        return rad_fail(err, RAD_ERR_USAGE, "hc_compute_points: engine, receivers and store must be given");
    for (uint32_t k = 0; k < count; k++)
        if (recv[k].patch >= e->n || !rad_finite3(recv[k].center))
            return rad_fail(err, RAD_ERR_USAGE, "hc_compute_points: receiver %u: patch %u of %u, or a "
                            "non-finite point", k, recv[k].patch, e->n);
    hc_job job = {.recv = recv, .store = store, .user = user, .count = count};
    return run_job(e, &job, err);
}

/* Hands the job out in chunks and collects every answer. */
static int run_job(hc_engine *e, const hc_job *job, rad_error *err)
{
    const uint32_t count = job->count;
    if (e->broken)
        return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
    if (count == 0)
        return RAD_OK;

    /* Modest chunks, at most two in flight per worker: a fast worker comes
     * back for more, and the tail stays short. */
    uint32_t chunk = count / (e->nproc * 8);
    chunk = chunk < 1 ? 1 : chunk > HC_MAX_CHUNK ? HC_MAX_CHUNK : chunk;
    uint32_t next = 0, done = 0;
    int rc = RAD_OK;
    struct pollfd *pf = malloc(e->nproc * sizeof *pf);
    uint32_t *who = malloc(e->nproc * sizeof *who);
    if (!pf || !who) {
        free(pf);
        free(who);
        return rad_fail(err, RAD_ERR_NOMEM, "hemi-cube: out of memory");
    }
    for (;;) {
        for (uint32_t k = 0; rc == RAD_OK && k < e->nproc; k++)
            while (rc == RAD_OK && next < count && e->w[k].in_flight <= chunk) {
                uint32_t c = count - next < chunk ? count - next : chunk;
                if (send_chunk(e, k, job, next, c) != 0)
                    rc = hc_pool_gone(e, k, err);
                else
                    next += c;
            }
        nfds_t np = 0;
        for (uint32_t k = 0; k < e->nproc; k++)
            if (e->w[k].in_flight) {
                pf[np].fd = e->w[k].fd;
                pf[np].events = POLLIN;
                pf[np].revents = 0;
                who[np++] = k;
            }
        if (np == 0)
            break;
        if (poll(pf, np, -1) < 0) {
            if (errno == EINTR)
                continue;
            if (rc == RAD_OK)
                rc = rad_fail(err, RAD_ERR_GL, "hemi-cube: poll: %s", strerror(errno));
            /* Replies cannot be drained: the protocol is out of step. */
            e->broken = 1;
            snprintf(e->broken_msg, sizeof e->broken_msg, "hemi-cube: workers out of step");
            break;
        }
        /* After a failure the remaining answers are read and dropped, so the
         * workers stay in step for the next call. */
        for (nfds_t q = 0; q < np; q++)
            if (pf[q].revents)
                receive_batch(e, who[q], job, &rc, &done, err);
    }
    free(pf);
    free(who);
    return rc;
}
