/* worker.c - a worker process, from the fork to its _exit.
 *
 * Owns the worker's set-up (signals, allocator and llvmpipe settings, its
 * scratch buffers, its GL context through gl.c) and its request loop: read
 * a request (wire.c), compute (rows.c, light_views.c), answer (wire.c).
 *
 * Invariants: a worker answers every request in the order asked, or sends
 * an error text and exits; any message it cannot take for a request of
 * this protocol ends it silently (the caller sees its stream close); it
 * never returns into the caller's code.
 */
#include "hc_internal.h"

#include <malloc.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Fault injection for the tests of worker replacement (pool.c): the patch
 * named by RADIOSITY_TEST_CRASH_ROW makes any worker asked for its row (or
 * a point on it) kill itself, as a crash would.  Read once per worker;
 * RAD_NONE when unset. */
static uint32_t crash_row = RAD_NONE;

/* Process settings a worker wants, inherited from nobody. */
static void worker_settings(const hc_engine *e)
{
    const char *crash = getenv("RADIOSITY_TEST_CRASH_ROW");
    if (crash && *crash)
        crash_row = (uint32_t)strtoul(crash, NULL, 10);
    signal(SIGPIPE, SIG_IGN);
    /* Ctrl-C goes to the whole process group; the caller decides when its
     * workers stop (by closing the socket). */
    signal(SIGINT, SIG_IGN);
    signal(SIGQUIT, SIG_IGN);
    /* So is a SIGTERM to the group (mpirun's, when a rank died): the
     * caller stops at it and keeps its rows; its workers go when it does. */
    signal(SIGTERM, SIG_IGN);
    /* llvmpipe allocates and frees large scene bins every frame; keeping them
     * on the heap spares an mmap/munmap pair each time (reported to save up
     * to 17 % with llvmpipe threads; within noise when this thread
     * rasterises, as it does by default below). */
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 64 << 20);
    /* With a worker per core, llvmpipe's own rasteriser threads only add
     * synchronisation (measured: 2.2 s of CPU with LP_NUM_THREADS=0 against
     * 3.0 s with 1 or 2 threads for the same rows), so rasterise in this
     * thread; with fewer workers than cores, lend the spare cores to
     * llvmpipe.  A user's own LP_NUM_THREADS wins. */
    char threads[16];
    snprintf(threads, sizeof threads, "%u", e->lp_threads);
    setenv("LP_NUM_THREADS", threads, 0);
}

/* The scratch every request uses, the GL context and the reply buffer; 0,
 * or -1 with msg set. */
static int worker_setup(const hc_engine *e, hc_work *wk, char *msg)
{
    uint32_t n = e->n, R = e->R;
    int ok = (wk->pixels = hc_alloc((size_t)3 * R * R, sizeof *wk->pixels, msg)) &&
             (wk->acc = hc_alloc(n, sizeof *wk->acc, msg)) &&
             (wk->front = hc_alloc(n, sizeof *wk->front, msg)) &&
             (wk->col = hc_alloc(n, sizeof *wk->col, msg)) &&
             (wk->val = hc_alloc(n, sizeof *wk->val, msg)) &&
             (wk->racc = hc_alloc(n, sizeof *wk->racc, msg)) &&
             (wk->rcell = hc_alloc((size_t)e->ncell + 1, sizeof *wk->rcell, msg)) &&
             (wk->rgroup = hc_alloc((size_t)e->ncell + 1, sizeof *wk->rgroup, msg));
    for (int f = 0; ok && f < 5; f++)
        ok = (wk->first[f] = hc_alloc(n, sizeof *wk->first[f], msg)) &&
             (wk->count[f] = hc_alloc(n, sizeof *wk->count[f], msg));
    if (!ok || hc_rows_init(e, wk, msg) != 0 || hc_gl_create(e, wk, msg) != 0)
        return -1;
    /* The answer to a request goes out in one piece (or in pieces of about
     * a megabyte), so the caller wakes once per request, not per row. */
    if (hc_wire_reply_init(&wk->out, n) != 0) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: worker out of memory for its reply buffer");
        return -1;
    }
    return 0;
}

static void fail(int fd, const char *msg) __attribute__((noreturn));
static void fail(int fd, const char *msg)
{
    hc_wire_send_text(fd, HC_MSG_ERROR, msg);
    _exit(1);
}

/* A light part as the caller can send it. */
static int light_ok(const hc_light_req *q)
{
    return hc_resolution_ok(q->resolution) && q->kind <= HC_LIGHT_DIRECTIONAL && q->part < 6;
}

/* Rows of patches, or rows of points on patches (elements). */
static void serve_rows(const hc_engine *e, hc_work *wk, int fd, const hc_request *rq, char *msg)
{
    const int points = rq->kind == HC_RQ_POINTS;
    hc_wire_reply_begin(&wk->out, rq->count);
    for (uint32_t k = 0; k < rq->count; k++) {
        uint32_t i = points ? rq->pts[k].patch : rq->rows[k];
        if (i >= e->n)
            _exit(1);
        if (i == crash_row)
            raise(SIGKILL);
        const hc_point_req *pt = &rq->pts[k];
        rad_vec3 at = points ? rad_v3(pt->at[0], pt->at[1], pt->at[2]) : rad_v3(0, 0, 0);
        long cnt = hc_row(e, wk, i, points ? &at : NULL, points ? pt->reach : 0.0, msg);
        if (cnt < 0) {
            hc_wire_reply_fail(fd, &wk->out, msg);
            _exit(1);
        }
        if (hc_wire_reply_row(fd, &wk->out, points ? pt->index : i, (uint32_t)cnt, wk->col,
                              wk->val) != 0)
            _exit(1);
    }
    if (hc_wire_reply_end(fd, &wk->out) != 0)
        _exit(1);
}

static void serve_light(const hc_engine *e, hc_work *wk, int fd, const hc_request *rq, char *msg)
{
    if (!light_ok(&rq->light))
        _exit(1);
    long cnt = hc_light_part(e, wk, &rq->light, msg);
    if (cnt < 0)
        fail(fd, msg);
    if (hc_wire_send_light_reply(fd, (uint32_t)cnt, wk->col, wk->lval) != 0)
        _exit(1);
}

static void serve_vis(const hc_engine *e, hc_work *wk, int fd, const hc_request *rq, char *msg)
{
    const uint32_t m = rq->count;
    if (!light_ok(&rq->light))
        _exit(1);
    /* Made on the first such request: most runs have no punctual light. */
    if (!wk->vpts && (!(wk->vpts = hc_alloc(HC_VIS_CHUNK, sizeof *wk->vpts, msg)) ||
                      !(wk->vis = hc_alloc(HC_VIS_CHUNK, sizeof *wk->vis, msg))))
        fail(fd, msg);
    if (hc_wire_recv_points(fd, wk->vpts, m) != 0)
        _exit(1);
    for (uint32_t k = 0; k < m; k++)
        if (wk->vpts[k].patch >= e->n)
            _exit(1);
    if (hc_light_points(e, wk, &rq->light, wk->vpts, m, wk->vis, msg) != 0)
        fail(fd, msg);
    if (hc_wire_send_vis_reply(fd, m, wk->vis) != 0)
        _exit(1);
}

/* Every path ends in _exit, which also keeps atexit handlers, stdio
 * buffers and leak checkers of the caller's image from running twice. */
void hc_worker_main(const hc_engine *e, int fd)
{
    worker_settings(e);
    char msg[HC_MAX_MSG + 1] = "";
    hc_work wk;
    memset(&wk, 0, sizeof wk);
    if (worker_setup(e, &wk, msg) != 0)
        fail(fd, msg);
    hc_wire_send_text(fd, HC_MSG_READY, "");

    hc_request rq;
    for (;;) {
        switch (hc_wire_recv_request(fd, &rq)) {
        case HC_RQ_END:
            _exit(0); /* the caller closed the socket: hc_destroy */
        case HC_RQ_ROWS:
        case HC_RQ_POINTS:
            serve_rows(e, &wk, fd, &rq, msg);
            break;
        case HC_RQ_LIGHT:
            serve_light(e, &wk, fd, &rq, msg);
            break;
        case HC_RQ_VIS:
            serve_vis(e, &wk, fd, &rq, msg);
            break;
        case HC_RQ_BAD:
        default:
            _exit(1);
        }
    }
}
