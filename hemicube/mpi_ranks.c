/* mpi_ranks.c - the MPI row producer: the only file that includes mpi.h,
 * linked into radiosity-mpi alone (never into libradiosity.a), so the plain
 * program and the library need no MPI library at run time.
 *
 * Rank 0 runs the command; every engine it creates (hc_create) is copied
 * to the other ranks: the mesh arrays the hemi-cube reads, the exact marks
 * and the value fields of hc_options, bit for bit, so every rank draws the
 * very rows rank 0 would.  Each rank then starts its own local pool of
 * worker processes (pool.c).  A job's items (patch rows, element
 * hemi-cubes) go out in blocks on demand, at most two per rank at a time,
 * while rank 0's own pool takes chunks beside them; a rank answers a block
 * whole, and rank 0 checks and stores each row (producer.c's hc_run_store,
 * which journals it through F's hook).  The lights' item buffers are drawn
 * by rank 0's pool: a few views per light.
 *
 * Faults: by default mpirun ends the whole job when a rank dies, naming
 * it; the rows rank 0 stored are in its journal already (each written as
 * it comes), so the same command run again computes only the others.
 * Under `mpirun --enable-recovery` the job outlives the rank: rank 0 finds
 * a rank holding blocks whose process is gone (kill(pid, 0), for ranks on
 * its host) and ends the run naming it; serving ranks find rank 0 gone the
 * same way.  After the stop flag (Ctrl-C, or mpirun's SIGTERM) rank 0 waits
 * a moment for the blocks out, then gives them up.  RADIOSITY_TEST_RANK_EXIT=k:n
 * makes rank k exit after n blocks (sent, or for rank 0 received).
 *
 * Invariant: a rank serves one engine at a time, and answers its blocks
 * in the order sent; a rank that failed or was given up on gets nothing
 * more, and what it sends later is dropped.
 */
#include "hc_internal.h"

#include <errno.h>
#include <mpi.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* The sanitizer build: OpenMPI allocates for the process's life in its
 * own threads and in plugins unloaded at MPI_Finalize, whose frames the
 * leak checker cannot name (so no suppression file matches them: measured,
 * 63 reports a rank), so radiosity-mpi's asan build checks memory errors
 * but not leaks, unless ASAN_OPTIONS asks; the engine's code is
 * leak-checked in the plain program and the tests. */
#if defined(__SANITIZE_ADDRESS__)
const char *__asan_default_options(void);
const char *__asan_default_options(void) { return "detect_leaks=0"; }
#endif

enum {
    TAG_ENGINE = 1, /* 0 -> r: an engine's header, then its arrays */
    TAG_READY,      /* r -> 0: int status, then text */
    TAG_BLOCK,      /* 0 -> r: block header, then rows or receivers */
    TAG_RESULT,     /* r -> 0: a block's answers */
    TAG_FAIL,       /* r -> 0: text; the rank takes no more blocks */
    TAG_DROP,       /* 0 -> r: the engine is destroyed */
    TAG_QUIT        /* 0 -> r: hc_mpi_finish */
};

#define MAX_BLOCK 256u        /* items per block */
#define OPT_BYTES 256u        /* the options' room in an engine header */
#define PIECE (1u << 30)      /* largest single message of an array */
#define GIVE_UP_SECONDS 0.2   /* after the stop flag, how long blocks out are waited for */
#define TEXT_BYTES 1200       /* a status word and an error text */

/* hc_options travels as its bytes, with its pointer fields (progress,
 * progress_user, exact, stop) cleared on both sides: every other field is a
 * plain value (resolution, processes, exact_near, and whatever plain field
 * is added later, such as a GL choice), so a new one reaches the ranks
 * without an edit here.  A new pointer field must be cleared in
 * wire_options. */
_Static_assert(sizeof(hc_options) <= OPT_BYTES, "hc_options outgrew the engine header");

typedef struct engine_head {
    uint32_t opt_size; /* sizeof(hc_options) of the sender: one build on every rank */
    uint32_t n, nvert, ncell, has_cells, has_exact;
    unsigned char opt[OPT_BYTES];
} engine_head;

typedef struct block_head {
    uint32_t points; /* 1: hc_receiver items, 0: patch rows */
    uint32_t first, count;
} block_head;

/* ------------------------------------------------------- process state */

static int world_rank, world_size;
static char (*hosts)[64];   /* per rank */
static int *pids;
static uint64_t *items_by;  /* per rank: items it computed (rank 0: its pool's) */
static uint8_t *lost;       /* per rank: failed or given up on */
static int busy;            /* rank 0: the other ranks serve an engine */
static long exit_rank = -1, exit_after = -1, blocks_seen;
static char fault[512];     /* rank 0: what ended the ranks' work, for the summary */

static void wire_options(hc_options *o)
{
    o->progress = NULL;
    o->progress_user = NULL;
    o->exact = NULL;
    o->stop = NULL;
}

/* The test hook: this rank exits (no MPI_Finalize, as a crash would) after
 * its n-th block. */
static void count_block(void)
{
    if (world_rank == exit_rank && ++blocks_seen >= exit_after)
        _exit(3);
}

static int send_big(const void *p, size_t len, int to)
{
    const char *c = p;
    do {
        int k = len > PIECE ? (int)PIECE : (int)len;
        if (MPI_Send(c, k, MPI_BYTE, to, TAG_ENGINE, MPI_COMM_WORLD) != MPI_SUCCESS)
            return -1;
        c += k;
        len -= (size_t)k;
    } while (len);
    return 0;
}

static int recv_big(void *p, size_t len)
{
    char *c = p;
    do {
        int k = len > PIECE ? (int)PIECE : (int)len;
        if (MPI_Recv(c, k, MPI_BYTE, 0, TAG_ENGINE, MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS)
            return -1;
        c += k;
        len -= (size_t)k;
    } while (len);
    return 0;
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Rank r's process is gone: known for a rank on this host (kill(pid, 0));
 * one on another host is reported by mpirun. */
static int rank_gone(int r)
{
    return !strcmp(hosts[r], hosts[world_rank]) && kill(pids[r], 0) != 0 && errno == ESRCH;
}

static void nap(long us)
{
    struct timespec ts = {0, us * 1000};
    nanosleep(&ts, NULL);
}

/* =================================================== ranks 1..: serving */

/* mpirun's SIGTERM when another rank died: the block in hand stops, and
 * the rank says whether rank 0 is gone. */
static volatile sig_atomic_t term;
static void on_term(int sig)
{
    (void)sig;
    term = 1;
}

typedef struct served {
    rad_mesh mesh;
    uint8_t *exact;
    hc_engine *e;
    unsigned char *out; /* a block's answers */
    size_t len, cap;
} served;

static void served_free(served *s)
{
    hc_destroy(s->e);
    free(s->mesh.vertices);
    free(s->mesh.patches);
    free(s->mesh.cells);
    free(s->mesh.cell_first);
    free(s->exact);
    free(s->out);
    memset(s, 0, sizeof *s);
}

static void send_text(int tag, int status, const char *text)
{
    char buf[TEXT_BYTES];
    memcpy(buf, &status, sizeof status);
    snprintf(buf + sizeof status, sizeof buf - sizeof status, "%s", text);
    MPI_Send(buf, (int)(sizeof status + strlen(buf + sizeof status) + 1), MPI_BYTE, 0, tag,
             MPI_COMM_WORLD);
}

/* Receives rank 0's engine and starts a local pool for it; answers
 * TAG_READY with the status. */
static void serve_engine(served *s)
{
    engine_head h;
    MPI_Recv(&h, sizeof h, MPI_BYTE, 0, TAG_ENGINE, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    served_free(s);
    rad_error err = {0};
    int rc = RAD_OK;
    rad_mesh *m = &s->mesh;
    m->vertices = malloc((h.nvert ? h.nvert : 1) * sizeof *m->vertices);
    m->patches = malloc((h.n ? h.n : 1) * sizeof *m->patches);
    m->cells = h.has_cells ? malloc((h.ncell ? h.ncell : 1) * sizeof *m->cells) : NULL;
    m->cell_first = h.has_cells ? malloc(((size_t)h.n + 1) * sizeof *m->cell_first) : NULL;
    s->exact = h.has_exact ? malloc(h.n ? h.n : 1) : NULL;
    if (!m->vertices || !m->patches || (h.has_cells && (!m->cells || !m->cell_first)) ||
        (h.has_exact && !s->exact))
        rc = rad_fail(&err, RAD_ERR_NOMEM, "out of memory for a mesh of %u patches", h.n);
    /* the arrays come whatever happens, so the stream stays in step */
    unsigned char sink[1];
    m->vertex_count = h.nvert, m->patch_count = h.n, m->cell_count = h.ncell;
    recv_big(rc ? sink : (void *)m->vertices, rc ? 0 : (size_t)h.nvert * sizeof *m->vertices);
    recv_big(rc ? sink : (void *)m->patches, rc ? 0 : (size_t)h.n * sizeof *m->patches);
    if (h.has_cells) {
        recv_big(rc ? sink : (void *)m->cells, rc ? 0 : (size_t)h.ncell * sizeof *m->cells);
        recv_big(rc ? sink : (void *)m->cell_first, rc ? 0 : ((size_t)h.n + 1) * sizeof *m->cell_first);
    }
    if (h.has_exact)
        recv_big(rc ? sink : (void *)s->exact, rc ? 0 : h.n);
    hc_options o;
    memset(&o, 0, sizeof o);
    if (h.opt_size != sizeof o && !rc)
        rc = rad_fail(&err, RAD_ERR_USAGE, "another build of radiosity-mpi (options of %u bytes, "
                      "here %zu)", h.opt_size, sizeof o);
    memcpy(&o, h.opt, sizeof o);
    wire_options(&o);
    o.exact = s->exact;
    o.stop = &term;
    if (!rc)
        rc = hc_create(m, &o, &s->e, &err);
    send_text(TAG_READY, rc, rc ? err.message : "");
}

static int keep_answer(void *user, uint32_t k, uint32_t count, const uint32_t *col,
                       const float *val, rad_error *err)
{
    served *s = user;
    size_t need = s->len + 8 + (size_t)count * 8;
    if (need > s->cap) {
        size_t cap = need > 2 * s->cap ? need : 2 * s->cap;
        unsigned char *more = realloc(s->out, cap);
        if (!more)
            return rad_fail(err, RAD_ERR_NOMEM, "out of memory for a block's answers");
        s->out = more, s->cap = cap;
    }
    uint32_t w[2] = {k, count};
    memcpy(s->out + s->len, w, 8);
    if (count) {
        memcpy(s->out + s->len + 8, col, (size_t)count * 4);
        memcpy(s->out + s->len + 8 + (size_t)count * 4, val, (size_t)count * 4);
    }
    s->len = need;
    return RAD_OK;
}

/* Computes one block on the local pool and answers it whole. */
static void serve_block(served *s, int bytes)
{
    unsigned char *in = malloc(bytes > 0 ? (size_t)bytes : 1);
    MPI_Recv(in, bytes, MPI_BYTE, 0, TAG_BLOCK, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    block_head h;
    memcpy(&h, in, sizeof h);
    rad_error err = {0};
    int rc = RAD_OK;
    size_t isz = h.points ? sizeof(hc_receiver) : sizeof(uint32_t);
    if (!s->e || h.count > MAX_BLOCK || (size_t)bytes != sizeof h + h.count * isz)
        rc = rad_fail(&err, RAD_ERR_USAGE, "a block out of step with its engine");
    s->len = 0;
    if (!rc && keep_answer(s, h.first, 0, NULL, NULL, &err) != RAD_OK)
        rc = RAD_ERR_NOMEM;
    if (!rc) /* the header: the block's first item and its count */
        memcpy(s->out + 4, &h.count, 4);
    if (!rc && h.points) {
        hc_receiver *recv = malloc(h.count * sizeof *recv + 1);
        if (recv)
            memcpy(recv, in + sizeof h, h.count * sizeof *recv);
        rc = recv ? hc_compute_points(s->e, recv, h.count, keep_answer, s, &err)
                  : rad_fail(&err, RAD_ERR_NOMEM, "out of memory");
        free(recv);
    } else if (!rc) {
        uint32_t *rows = malloc(h.count * sizeof *rows + 1);
        if (rows)
            memcpy(rows, in + sizeof h, h.count * sizeof *rows);
        hc_job job = {.rows = rows, .store = keep_answer, .user = s, .count = h.count};
        rc = rows ? hc_run_job(s->e, &job, &err) : rad_fail(&err, RAD_ERR_NOMEM, "out of memory");
        free(rows);
    }
    free(in);
    if (rc) {
        send_text(TAG_FAIL, rc, err.message);
        served_free(s);
        return;
    }
    /* an answer larger than MPI's eager size waits for rank 0 to take it */
    MPI_Request req;
    int done = 0;
    MPI_Isend(s->out, (int)s->len, MPI_BYTE, 0, TAG_RESULT, MPI_COMM_WORLD, &req);
    for (int t = 1; MPI_Test(&req, &done, MPI_STATUS_IGNORE) == MPI_SUCCESS && !done; t++) {
        nap(200);
        if (t % 1000 == 0 && rank_gone(0)) {
            term = 1;
            return;
        }
    }
    count_block();
}

/* Ended by mpirun: names rank 0 when its process is gone (on this host). */
static int terminated(served *s, rad_error *err)
{
    served_free(s);
    if (rank_gone(0))
        return rad_fail(err, RAD_ERR_INTERRUPTED, "MPI rank 0 (pid %d on %s), the assembling "
                        "rank, stopped; the rows it received are kept in its journal (the "
                        "solution's .partial file): run the same command again to resume",
                        pids[0], hosts[0]);
    return rad_fail(err, RAD_ERR_INTERRUPTED, "MPI rank %d was stopped", world_rank);
}

int hc_mpi_serve(rad_error *err)
{
    served s;
    memset(&s, 0, sizeof s);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_term;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    for (;;) {
        int flag = 0;
        MPI_Status st;
        /* a nap between probes: a waiting rank leaves its cores to the workers */
        for (int t = 1; !term && MPI_Iprobe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st) ==
                            MPI_SUCCESS && !flag; t++) {
            nap(1000);
            if (t % 250 == 0 && rank_gone(0)) /* under mpirun --enable-recovery */
                term = 1;
        }
        if (term)
            return terminated(&s, err);
        if (!flag)
            return rad_fail(err, RAD_ERR_GL, "MPI rank %d: lost rank 0", world_rank);
        int bytes = 0;
        MPI_Get_count(&st, MPI_BYTE, &bytes);
        switch (st.MPI_TAG) {
        case TAG_ENGINE:
            serve_engine(&s);
            break;
        case TAG_BLOCK:
            serve_block(&s, bytes);
            break;
        case TAG_DROP:
        case TAG_QUIT:
            MPI_Recv(NULL, 0, MPI_BYTE, 0, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            served_free(&s);
            if (st.MPI_TAG == TAG_QUIT)
                return RAD_OK;
            break;
        default:
            return rad_fail(err, RAD_ERR_GL, "MPI rank %d: message %d out of step", world_rank,
                            st.MPI_TAG);
        }
    }
}

/* ============================================== rank 0: the producer */

typedef struct slot {
    hc_range r;          /* the block's items */
    MPI_Request req;
    unsigned char *buf;  /* its message, until sent */
} slot;

typedef struct remote {
    int attached;        /* the other ranks serve this engine */
    uint32_t block;      /* items per block in this run */
    slot *q;             /* per rank: 2 slots, oldest first */
    uint8_t *nq;         /* per rank */
    unsigned char *rx;
    size_t rx_cap;
    uint32_t local_done; /* the run's items stored by rank 0's pool */
    double stop_seen;    /* when the stop flag was first seen with blocks out */
    double checked;      /* when the ranks holding blocks were last seen alive */
} remote;

static uint32_t remote_held(const remote *m)
{
    uint32_t held = 0;
    for (int r = 1; r < world_size; r++)
        for (int k = 0; k < m->nq[r]; k++)
            held += m->q[2 * r + k].r.count;
    return held;
}

static int send_engine(const hc_engine *e, int r)
{
    const rad_mesh *m = e->mesh;
    engine_head h;
    memset(&h, 0, sizeof h);
    hc_options o = e->opt;
    o.processes = e->processes_asked;
    wire_options(&o);
    h.opt_size = sizeof o;
    memcpy(h.opt, &o, sizeof o);
    h.n = m->patch_count, h.nvert = m->vertex_count, h.ncell = m->cell_count;
    h.has_cells = m->cell_first != NULL, h.has_exact = e->exact != NULL;
    if (MPI_Send(&h, sizeof h, MPI_BYTE, r, TAG_ENGINE, MPI_COMM_WORLD) != MPI_SUCCESS ||
        send_big(m->vertices, (size_t)h.nvert * sizeof *m->vertices, r) ||
        send_big(m->patches, (size_t)h.n * sizeof *m->patches, r))
        return -1;
    if (h.has_cells && (send_big(m->cells, (size_t)h.ncell * sizeof *m->cells, r) ||
                        send_big(m->cell_first, ((size_t)h.n + 1) * sizeof *m->cell_first, r)))
        return -1;
    return h.has_exact ? send_big(e->exact, h.n, r) : 0;
}

static void mpi_stop(hc_engine *e)
{
    remote *m = e->remote;
    if (m && m->attached) {
        for (int r = 1; r < world_size; r++)
            if (!lost[r])
                MPI_Send(NULL, 0, MPI_BYTE, r, TAG_DROP, MPI_COMM_WORLD);
        busy = 0;
    }
    if (m) {
        free(m->q);
        free(m->nq);
        free(m->rx);
        free(m);
    }
    e->remote = NULL;
    hc_pool_producer.stop(e);
}

/* Rank 0's pool, then the engine sent to every rank that is not lost,
 * then their reports.  While another engine holds the ranks, this one runs
 * on rank 0's pool alone. */
static int mpi_start(hc_engine *e, rad_error *err)
{
    int rc = hc_pool_producer.start(e, err);
    if (rc)
        return rc;
    remote *m = calloc(1, sizeof *m);
    e->remote = m;
    if (!m || !(m->q = calloc(2 * (size_t)world_size, sizeof *m->q)) ||
        !(m->nq = calloc((size_t)world_size, 1)))
        return rad_fail(err, RAD_ERR_NOMEM, "hemi-cube: out of memory");
    if (busy || world_size < 2)
        return RAD_OK;
    m->attached = busy = 1;
    for (int r = 1; r < world_size; r++)
        if (!lost[r] && send_engine(e, r) != 0)
            return rad_fail(err, RAD_ERR_GL, "MPI: sending the engine to rank %d failed", r);
    for (int r = 1; r < world_size; r++) {
        if (lost[r])
            continue;
        char buf[TEXT_BYTES] = "";
        int status = 0;
        MPI_Recv(buf, sizeof buf, MPI_BYTE, r, TAG_READY, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        memcpy(&status, buf, sizeof status);
        if (status) {
            lost[r] = 1;
            rc = rad_fail(err, RAD_ERR_GL, "MPI rank %d (%s): %s", r, hosts[r], buf + sizeof status);
        }
    }
    return rc;
}

static int mpi_begin(hc_engine *e, hc_run *run, rad_error *err)
{
    remote *m = e->remote;
    int ranks = world_size;
    /* about eight blocks per rank in a job, so that faster ranks take more */
    uint32_t b = run->job->count / (uint32_t)(8 * ranks);
    m->block = b < run->chunk ? run->chunk : b > MAX_BLOCK ? MAX_BLOCK : b;
    m->local_done = 0;
    m->stop_seen = 0;
    run->remote = m;
    return hc_pool_producer.begin(e, run, err);
}

static void send_block(hc_engine *e, remote *m, hc_run *run, int r, hc_range rg)
{
    const hc_job *job = run->job;
    block_head h = {job->recv != NULL, rg.first, rg.count};
    size_t isz = job->recv ? sizeof(hc_receiver) : sizeof(uint32_t);
    size_t len = sizeof h + rg.count * isz;
    slot *s = &m->q[2 * r + m->nq[r]];
    s->buf = malloc(len);
    if (!s->buf) {
        hc_run_retry(run, rg.first, rg.count);
        return;
    }
    memcpy(s->buf, &h, sizeof h);
    memcpy(s->buf + sizeof h, job->recv ? (const void *)(job->recv + rg.first)
                                        : (const void *)(job->rows + rg.first), rg.count * isz);
    s->r = rg;
    MPI_Isend(s->buf, (int)len, MPI_BYTE, r, TAG_BLOCK, MPI_COMM_WORLD, &s->req);
    m->nq[r]++;
    (void)e;
}

static void mpi_give(hc_engine *e, hc_run *run, rad_error *err)
{
    remote *m = e->remote;
    hc_range rg;
    for (int r = 1; m->attached && r < world_size; r++)
        while (!lost[r] && m->nq[r] < 2 && hc_run_take(e, run, m->block, &rg))
            send_block(e, m, run, r, rg);
    hc_pool_producer.give(e, run, err);
}

/* Checks and stores rank r's answer to its oldest block; 0, or -1 when it
 * is malformed. */
static int take_result(hc_engine *e, remote *m, hc_run *run, int r, size_t len, rad_error *err)
{
    slot *s = &m->q[2 * r];
    const unsigned char *p = m->rx, *end = m->rx + len;
    uint32_t w[2];
    uint8_t seen[MAX_BLOCK] = {0};
    if (len < 8 || (memcpy(w, p, 8), w[0] != s->r.first || w[1] != s->r.count))
        return -1;
    p += 8;
    for (uint32_t q = 0; q < s->r.count; q++) {
        if (end - p < 8)
            return -1;
        memcpy(w, p, 8);
        uint32_t k = w[0], cnt = w[1];
        if (k >= s->r.count || seen[k] || cnt > e->n || (size_t)(end - p - 8) < (size_t)cnt * 8)
            return -1;
        seen[k] = 1;
        memcpy(e->rx_col, p + 8, (size_t)cnt * 4);
        memcpy(e->rx_val, p + 8 + (size_t)cnt * 4, (size_t)cnt * 4);
        uint32_t item = s->r.first + k;
        uint32_t i = run->job->recv ? item : run->job->rows[item];
        if (hc_run_store(e, run, item, i, cnt, e->rx_col, e->rx_val, err) != 0)
            return -1;
        p += 8 + (size_t)cnt * 8;
    }
    items_by[r] += s->r.count;
    return p == end ? 0 : -1;
}

/* Rank r's oldest block is answered (or given up): its slot is freed. */
static void pop_slot(remote *m, int r)
{
    slot *s = &m->q[2 * r];
    MPI_Wait(&s->req, MPI_STATUS_IGNORE);
    free(s->buf);
    m->q[2 * r] = m->q[2 * r + 1];
    m->nq[r]--;
}

/* Rank r will get nothing more: its blocks are dropped (the run has
 * failed, or is stopping). */
static void lose_rank(remote *m, int r)
{
    lost[r] = 1;
    for (int k = 0; k < m->nq[r]; k++)
        if (m->q[2 * r + k].buf) /* a send that never completes is left to MPI */
            MPI_Request_free(&m->q[2 * r + k].req);
    m->nq[r] = 0;
}

/* One message from rank r. */
static void intake(hc_engine *e, remote *m, hc_run *run, MPI_Status *st, rad_error *err)
{
    int r = st->MPI_SOURCE, bytes = 0;
    MPI_Get_count(st, MPI_BYTE, &bytes);
    if ((size_t)bytes + 1 > m->rx_cap) {
        unsigned char *more = realloc(m->rx, (size_t)bytes + 1);
        if (!more) { /* nothing can be read: the job cannot go on */
            hc_run_fail(run, rad_fail(err, RAD_ERR_NOMEM, "MPI: out of memory for an answer"));
            lose_rank(m, r);
            return;
        }
        m->rx = more, m->rx_cap = (size_t)bytes + 1;
    }
    MPI_Recv(m->rx, bytes, MPI_BYTE, r, st->MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (lost[r] || m->nq[r] == 0)
        return; /* from a rank given up on: dropped */
    if (st->MPI_TAG == TAG_RESULT && take_result(e, m, run, r, (size_t)bytes, err) == 0) {
        pop_slot(m, r);
        if (exit_rank == 0)
            count_block();
        return;
    }
    m->rx[bytes] = 0;
    hc_run_fail(run, rad_fail(err, RAD_ERR_GL, "MPI rank %d (%s): %s", r, hosts[r],
                              st->MPI_TAG == TAG_FAIL && bytes > 4 ? (char *)m->rx + 4
                                                                   : "an answer out of step"));
    lose_rank(m, r);
}

/* After the stop flag (mpirun's SIGTERM when a rank died, or Ctrl-C) the
 * blocks out are waited for a moment, then given up: the ranks whose
 * process is gone are named. */
static void give_up(hc_engine *e, remote *m, hc_run *run, rad_error *err)
{
    double t = now();
    if (m->stop_seen == 0)
        m->stop_seen = t;
    if (t - m->stop_seen < GIVE_UP_SECONDS)
        return;
    char gone[256] = "", held[256] = "";
    for (int r = 1; r < world_size; r++) {
        if (!m->nq[r])
            continue;
        char *to = rank_gone(r) ? gone : held;
        size_t at = strlen(to);
        snprintf(to + at, 256 - at, "%s%d (pid %d on %s)", at ? ", " : "", r, pids[r], hosts[r]);
        lose_rank(m, r);
    }
    if (gone[0])
        snprintf(fault, sizeof fault, "MPI rank %s stopped while computing rows", gone);
    else
        snprintf(fault, sizeof fault, "the job was stopped while MPI rank %s held rows", held);
    hc_run_fail(run, rad_fail(err, RAD_ERR_INTERRUPTED, "%s", fault));
    (void)e;
}

/* Under mpirun --enable-recovery the job outlives a rank: one holding
 * blocks whose process is gone ends the run, named. */
static void check_ranks(remote *m, hc_run *run, rad_error *err)
{
    m->checked = now();
    for (int r = 1; r < world_size; r++)
        if (m->nq[r] && rank_gone(r)) {
            snprintf(fault, sizeof fault, "MPI rank %d (pid %d on %s) stopped while computing "
                     "rows", r, pids[r], hosts[r]);
            hc_run_fail(run, rad_fail(err, RAD_ERR_GL, "%s", fault));
            lose_rank(m, r);
        }
}

static uint32_t mpi_collect(hc_engine *e, hc_run *run, int timeout_ms, rad_error *err)
{
    remote *m = e->remote;
    uint32_t out = remote_held(m);
    uint32_t before = run->done;
    uint32_t local = hc_pool_producer.collect(e, run, out ? 1 : timeout_ms, err);
    m->local_done += run->done - before;
    items_by[0] += run->done - before;
    if (!out)
        return local;
    int flag = 0, got = 0;
    MPI_Status st;
    while (MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st) == MPI_SUCCESS && flag) {
        intake(e, m, run, &st, err);
        got = 1;
    }
    if (e->opt.stop && *e->opt.stop && remote_held(m))
        give_up(e, m, run, err);
    else if (now() - m->checked > 0.25)
        check_ranks(m, run, err);
    else if (!got && !local)
        nap(200);
    return local + remote_held(m);
}

static void mpi_end(hc_engine *e, hc_run *run)
{
    run->remote = NULL;
    hc_pool_producer.end(e, run);
}

static const hc_producer mpi_producer = {
    .name = "MPI ranks",
    .start = mpi_start,
    .begin = mpi_begin,
    .give = mpi_give,
    .collect = mpi_collect,
    .end = mpi_end,
    .light_power = hc_pool_light_power,
    .light_vis = hc_pool_light_vis,
    .stop = mpi_stop,
};

/* ============================================================ the program */

int hc_mpi_start(int *argc, char ***argv, int *rank, int *size, rad_error *err)
{
    if (MPI_Init(argc, argv) != MPI_SUCCESS)
        return rad_fail(err, RAD_ERR_GL, "MPI_Init failed");
    MPI_Comm_rank(MPI_COMM_WORLD, &world_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &world_size);
    *rank = world_rank, *size = world_size;
    hosts = calloc((size_t)world_size, sizeof *hosts);
    pids = calloc((size_t)world_size, sizeof *pids);
    items_by = calloc((size_t)world_size, sizeof *items_by);
    lost = calloc((size_t)world_size, 1);
    if (!hosts || !pids || !items_by || !lost)
        return rad_fail(err, RAD_ERR_NOMEM, "MPI: out of memory for %d ranks", world_size);
    char me[64] = "";
    gethostname(me, sizeof me - 1);
    int pid = (int)getpid();
    MPI_Allgather(me, sizeof me, MPI_BYTE, hosts, sizeof me, MPI_BYTE, MPI_COMM_WORLD);
    MPI_Allgather(&pid, 1, MPI_INT, pids, 1, MPI_INT, MPI_COMM_WORLD);
    const char *hook = getenv("RADIOSITY_TEST_RANK_EXIT");
    if (hook && sscanf(hook, "%ld:%ld", &exit_rank, &exit_after) != 2)
        exit_rank = -1;
    if (world_rank == 0)
        hc_remote_producer = &mpi_producer;
    return RAD_OK;
}

int hc_mpi_summary(char *line, size_t size)
{
    int at = snprintf(line, size, "radiosity: MPI: %d ranks:", world_size);
    for (int r = 0; r < world_size && at >= 0 && (size_t)at < size; r++)
        at += snprintf(line + at, size - (size_t)at, "%s %d on %s (%llu hemi-cubes%s)",
                       r ? "," : "", r, hosts[r], (unsigned long long)items_by[r],
                       r ? "" : ", assembling");
    if (fault[0] && at >= 0 && (size_t)at < size)
        snprintf(line + at, size - (size_t)at, "; %s", fault);
    return fault[0] != 0;
}

void hc_mpi_finish(int failed)
{
    if (fault[0] || (failed && world_rank))
        MPI_Abort(MPI_COMM_WORLD, 1); /* a rank is gone: Finalize would wait for it */
    /* every rank is alive here, those that failed a block too (they hold
     * nothing larger than a failure's text) */
    if (world_rank == 0)
        for (int r = 1; r < world_size; r++)
            MPI_Send(NULL, 0, MPI_BYTE, r, TAG_QUIT, MPI_COMM_WORLD);
    free(hosts), free(pids), free(items_by), free(lost);
    hosts = NULL, pids = NULL, items_by = NULL, lost = NULL;
    MPI_Finalize();
}
