/* hc_internal.h - what the files of hemicube/ share with one another; no
 * file outside hemicube/ includes it (the public header is hemicube.h).
 *
 * The rooms, each owning one concern, from the caller down:
 *   column.c          an emitter's exact column for shooting (the caller's
 *                     side: light_requests.c's visibility times
 *                     patch_factors.c's integral);
 *   light_requests.c  punctual lights, the caller's side: hc_light_power,
 *                     hc_light_visibility, hc_light_direct, the requests of
 *                     their parts and the reading of the answers;
 *   producer.c        a job of rows or element hemi-cubes (hc_compute_rows,
 *                     hc_compute_points) run on the engine's row producer
 *                     (struct hc_producer below): what is handed out next,
 *                     strikes, and the checking and storing of answers;
 *   pool.c            the engine (hc_create, hc_destroy) and the local fork
 *                     pool, the first producer: its worker processes, chunks
 *                     of items handed out and the answers collected (poll);
 *   pool_lights.c     the pool's light parts and visibility chunks;
 *   mpi_ranks.c       (radiosity-mpi only, not in the library) the MPI
 *                     producer: blocks of items to other ranks, each with
 *                     its own local pool, beside rank 0's pool;
 *   worker.c          a worker process: its buffers and its request loop;
 *   rows.c            one hemi-cube row F_ij (or a point receiver's F_ej),
 *                     with its exact entries, computed in a worker;
 *   light_views.c     punctual lights, the worker's side: a light part's
 *                     item buffer, its Φ_j and the visibility of points;
 *   gl_choice.c       which GL back end (hc_options.gl: osmesa, egl,
 *                     auto), EGL tried in a short-lived probe process;
 *   gl.c              GL, the only file that draws: the entry points from
 *                     a back end, the shaders, the vertex buffer of every
 *                     patch, views, drawing into an item buffer, readback;
 *   gl_osmesa.c       the OSMesa back end (libOSMesa, dlopen, in a worker);
 *   gl_egl.c          the EGL back end (libEGL, dlopen: a GPU device, or
 *                     Mesa's surfaceless platform);
 *   wire.c            the protocol between the caller and a worker over a
 *                     byte stream (today a socketpair): framing, requests,
 *                     replies, both ends' calls (each end calls its own);
 *   draw_geometry.c   the triangles each patch is drawn with: a cell as
 *                     itself, a cluster as a fan of its simplified outline
 *                     (no GL: gl.c uploads it);
 *   patch_factors.c   unoccluded point-to-patch and patch-to-patch
 *                     integrals from the engine's geometry (no GL), read by
 *                     rows.c in a worker and column.c in the caller;
 *   delta_factors.c   the delta form factors ΔF_q (hc_create's table);
 *   analytic.c        closed-form factors (public, pure math).
 * Dependencies point one way (a file calls only files below it, by `nm`):
 *   column.c -> light_requests.c, patch_factors.c;
 *   light_requests.c -> the producer (e->prod);
 *   producer.c -> the producer (e->prod);
 *   mpi_ranks.c -> producer.c, pool.c (its local pool);
 *   pool.c -> pool_lights.c, worker.c, wire.c, delta_factors.c, gl_choice.c;
 *   pool_lights.c -> wire.c;
 *   worker.c -> rows.c, light_views.c, gl.c, wire.c;
 *   rows.c -> patch_factors.c, gl.c;  light_views.c -> gl.c;
 *   gl_choice.c -> gl.c;  gl.c -> gl_osmesa.c, gl_egl.c, draw_geometry.c;
 *   patch_factors.c -> analytic.c.
 * A worker runs hc_worker_main and reaches only what lies below worker.c,
 * so no caller-side function (a request, a pool call) can run inside a
 * forked worker; GL types and headers stay in gl.c and its back ends (rows.c and
 * light_views.c draw through the hc_gl_* calls below).  Helpers several
 * rooms share are static inline here (hc_alloc, hc_basis, hc_cube_face,
 * hc_spot_falloff, hc_load_corners, hc_push_range), never a call upwards.
 *
 * Row producers (issue 38): the engine's geometry (hc_create's checks and
 * preparation, pool.c) is shared; everything that draws item buffers (patch
 * rows, element hemi-cubes, the lights' parts and visibility) goes through
 * e->prod, a struct hc_producer.  The local fork pool (pool.c,
 * pool_lights.c, ending in worker.c's request loop) is one producer; MPI
 * ranks (mpi_ranks.c) another, which runs the local pool beside its ranks.
 * Behind each, gl.c's drawing is shared, over whichever GL back end
 * (hc_gl_context: gl_osmesa.c, gl_egl.c) hc_options.gl names.
 *
 * Invariant of the shared data: the engine (struct hc_engine) is filled in
 * the caller before the fork and read-only afterwards, so every worker holds
 * the same copy; a worker's scratch (hc_work) is its own.
 */
#ifndef HC_INTERNAL_H
#define HC_INTERNAL_H

#include "hemicube.h"

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/types.h>

#define HC_NO_PATCH 0xFFFFFFFFu /* item-buffer clear value */
#define HC_MAX_MSG 900u         /* longest error text a worker sends */
#define HC_MAX_CHUNK 32u        /* rows or points per row request */
#define HC_VIS_CHUNK 4096u      /* points per visibility request */
/* Consecutive patches culled together against i's plane by a bounding
 * sphere: half the scene is usually behind the plane. */
#define HC_BLOCK 16u

static inline int hc_resolution_ok(uint32_t R) { return R >= 8 && R <= 4096 && R % 2 == 0; }

/* Deterministic orthonormal basis (u, v, n) with u × v = n. */
static inline void hc_basis(rad_vec3 n, rad_vec3 *u, rad_vec3 *v)
{
    double ax = fabs(n.x), ay = fabs(n.y), az = fabs(n.z);
    rad_vec3 a = ax <= ay && ax <= az ? rad_v3(1, 0, 0) : ay <= az ? rad_v3(0, 1, 0) : rad_v3(0, 0, 1);
    *u = rad_normalize(rad_cross(n, a));
    *v = rad_cross(n, *u);
}

/* calloc of at least one element; NULL with msg (HC_MAX_MSG bytes) set on
 * failure: a worker's allocations (worker.c, rows.c, light_views.c, gl.c). */
static inline void *hc_alloc(size_t count, size_t size, char *msg)
{
    void *p = calloc(count ? count : 1, size);
    if (!p)
        snprintf(msg, HC_MAX_MSG, "hemi-cube: worker out of memory (%zu × %zu bytes)", count, size);
    return p;
}

/* Cube face f (0..5) of a point light: forward ±x, ±y, ±z; right = forward
 * × up so that front faces stay front faces.  The caller picks the faces a
 * spot reaches with it (light_requests.c), a worker draws them
 * (light_views.c). */
static inline void hc_cube_face(uint32_t f, rad_vec3 *right, rad_vec3 *up, rad_vec3 *fwd)
{
    static const double ax[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    *fwd = rad_v3(ax[f][0], ax[f][1], ax[f][2]);
    *up = f < 4 ? rad_v3(0, 0, 1) : rad_v3(0, 1, 0);
    *right = rad_cross(*fwd, *up);
}

/* glTF KHR_lights_punctual spot falloff for a direction whose cosine to the
 * axis is cos_axis: t² with t = clamp(cos_axis·scale + offset, 0, 1),
 * scale = 1/max(0.001, cos_inner − cos_outer), offset = −cos_outer·scale.
 * hc_light_direct (caller) and a spot's Φ_j (worker) weigh with it. */
static inline double hc_spot_falloff(double cos_axis, double cos_inner, double cos_outer)
{
    double scale = 1.0 / fmax(0.001, cos_inner - cos_outer);
    double t = cos_axis * scale - cos_outer * scale;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    return t * t;
}

/* ------------------------------------------------------------ the engine */

typedef struct hc_worker {
    pid_t pid;
    int fd;             /* the caller's end of the worker's stream */
    uint32_t in_flight; /* rows sent and not yet answered */
} hc_worker;

struct hc_engine {
    const rad_mesh *mesh;
    uint32_t n;       /* patches */
    uint32_t R;       /* resolution */
    uint32_t nproc;
    uint32_t lp_threads; /* llvmpipe threads per worker (0: none) */
    hc_options opt;
    double *dff;      /* normalised ΔF_q, 3R² (atlas order) */
    uint32_t R_near;  /* a near view's resolution (hc_receiver.reach): R / 2 where R / 2 is
                       * a multiple of 2 and at least 16, else R */
    double *dff_near; /* ΔF_q at R_near */
    /* Geometry relative to the bounding-box centre, in double, prepared before
     * the fork so every worker shares it copy-on-write. */
    rad_vec3 origin;
    double tol;        /* "strictly in front" margin, scene-relative */
    /* Cells: a patch is one cell, or a cluster of several (rad.h's cell
     * layer); patch j's cells are [cfirst[j], cfirst[j + 1]), ncell in all. */
    uint32_t ncell;
    uint32_t *cfirst;  /* n + 1 */
    uint8_t *shared;   /* n: 1 for a shared patch of small parts (rad_mesh_shared_parts) */
    double *corner;    /* ncell × 4 × 3: cell corners - origin (a triangle repeats corner 0) */
    uint8_t *ncorner;  /* ncell: 3 or 4 */
    rad_vec3 *center;  /* n: patch centre - origin */
    double *bsphere;   /* per HC_BLOCK consecutive patches: centre - origin, radius */
    double *radius;    /* n: largest distance from patch centre to a corner of its cells */
    /* A cluster's outline: the directed edges of its cells left when every
     * inner edge, run once each way by two cells, is dropped (exact factors
     * to the cluster sum these alone: patch_factors.c, rad_point_edges_factor).
     * Patch j's are edges [ofirst[j], ofirst[j + 1]) of oedge (x0 y0 z0 x1
     * y1 z1 each, - origin, the cells' corners bit for bit); none for a
     * one-cell patch or where dropping saves nothing.  NULL without clusters. */
    uint32_t *ofirst;  /* n + 1, or NULL */
    double *oedge;
    double bradius;    /* every corner lies within this distance of the origin */
    uint8_t *exact;    /* n: copy of opt->exact, or NULL */
    int any_exact;     /* rows may have candidates: exact marks, exact_near or small
                        * polygons (any mesh of two patches or more) */
    /* Per polygon of the mesh (the largest polygon index + 1): the summed
     * area of its patches and their area-weighted centre - origin, to tell
     * a polygon too small on the cube for its pixels to be counted (rows.c). */
    uint32_t npoly;
    uint32_t *poly_patches; /* patches of each polygon */
    double *poly_area;
    rad_vec3 *poly_center;
    hc_worker *w;
    uint32_t processes_asked; /* hc_options.processes as given (0: each machine's CPUs) */
    const struct hc_producer *prod; /* where items are computed (producer.c) */
    void *remote;      /* the remote producer's state (mpi_ranks.c), or NULL */
    int broken;        /* a worker is gone: every later call fails */
    char broken_msg[HC_MAX_MSG + 64];
    uint32_t *rx_col;  /* receive buffers in the caller */
    float *rx_val;
};

/* The corners of cell `cell` (a patch's cells: e->cfirst), relative to the
 * origin; a triangle's fourth repeats its first. */
static inline void hc_load_corners(const hc_engine *e, uint32_t cell, rad_vec3 p[4])
{
    const double *q = e->corner + (size_t)cell * 12;
    for (int k = 0; k < 4; k++)
        p[k] = rad_v3(q[3 * k], q[3 * k + 1], q[3 * k + 2]);
}

/* The normal of cell `cell` of patch j: a bent patch's cells each have
 * their own (radiosity/mesh/smooth.c), and so do a shared patch's of small
 * parts (mesh/parts.c: a closed part's back faces must not count as facing
 * a light); a one-cell patch's is its own. */
static inline rad_vec3 hc_cell_normal(const hc_engine *e, uint32_t j, uint32_t cell)
{
    return e->mesh->cell_first ? e->mesh->cells[cell].normal : e->mesh->patches[j].normal;
}

/* pool_lights.c: reads the len bytes of worker k's error text (the worker
 * has exited), marks the engine broken and fails with that text. */
int hc_pool_error(hc_engine *e, uint32_t k, uint32_t len, rad_error *err);
/* pool_lights.c: worker k's stream is lost (EOF, garbage, a failed send).  Marks
 * the engine broken and fails with its message; err may be NULL. */
int hc_pool_gone(hc_engine *e, uint32_t k, rad_error *err);
/* pool_lights.c: reads the header (two words) of worker k's next reply: RAD_OK,
 * or the engine is broken (the stream is lost, or the worker sent its error
 * text in place of the reply and has exited). */
int hc_pool_header(hc_engine *e, uint32_t k, uint32_t hdr[2], rad_error *err);
/* pool_lights.c: closes worker k's stream after a reply that could not be read:
 * nothing more is read from it (the engine is broken already). */
void hc_pool_drop(hc_engine *e, uint32_t k);

/* -------------------------------------------------------------- the wire */

/* Message words (wire.c describes the protocol).  A row request starts with
 * its row count (1..HC_MAX_CHUNK), any other request with one of the
 * HC_REQ_ words; a reply starts with one of the HC_MSG_ words. */
#define HC_MSG_READY 0u           /* a worker's start-up report: 0, 0 */
#define HC_MSG_ERROR 0xFFFFFFFFu  /* row field of a worker's error message */
#define HC_MSG_BATCH 0xFFFFFFFEu  /* header of the answer to one request */
#define HC_MSG_LIGHT 0xFFFFFFFDu  /* header of the answer to one light part */
#define HC_MSG_VIS 0xFFFFFFFCu    /* header of the answer to one visibility chunk */
#define HC_REQ_LIGHT 0xFFFFFFF0u  /* request word of a light part (else: a row count) */
#define HC_REQ_POINTS 0xFFFFFFF1u /* request word of a chunk of point receivers */
#define HC_REQ_VIS 0xFFFFFFF2u    /* request word of a chunk of points seen from a light part */

/* One point receiver of a HC_REQ_POINTS chunk: the cube sits at `at`
 * (relative to the scene origin) on patch `patch`; `index` is the caller's
 * receiver number, echoed in the answer. */
typedef struct hc_point_req {
    uint32_t index, patch;
    double at[3];
    double reach;  /* hc_receiver.reach: 0, or a near view's */
} hc_point_req;

/* One part of a light request.  pos is relative to the scene origin. */
typedef struct hc_light_req {
    uint32_t resolution, kind, part, pad;
    double pos[3], dir[3];
    double cos_inner, cos_outer;
} hc_light_req;

/* A request as a worker reads it (hc_wire_recv_request). */
typedef enum hc_req_kind {
    HC_RQ_END = 0, /* the caller closed the stream */
    HC_RQ_BAD,     /* a stream out of step or cut */
    HC_RQ_ROWS,    /* rows[0..count) */
    HC_RQ_POINTS,  /* pts[0..count) */
    HC_RQ_LIGHT,   /* light */
    HC_RQ_VIS      /* light, then count points to read with hc_wire_recv_points */
} hc_req_kind;

typedef struct hc_request {
    hc_req_kind kind;
    uint32_t count;
    uint32_t rows[HC_MAX_CHUNK];
    hc_point_req pts[HC_MAX_CHUNK];
    hc_light_req light;
} hc_request;

/* A worker's reply to a row request, collected so that it goes out in one
 * piece (or in pieces of about a megabyte). */
typedef struct hc_reply {
    unsigned char *buf;
    size_t len, cap;
} hc_reply;

/* Transport: 0, or -1 on error or end of stream. */
int hc_wire_send(int fd, const void *p, size_t len);
int hc_wire_recv(int fd, void *p, size_t len);

/* Caller -> worker requests; 0 or -1 (the stream is lost). */
int hc_wire_send_rows(int fd, const uint32_t *rows, uint32_t count);
int hc_wire_send_points(int fd, const hc_point_req *pts, uint32_t count);
int hc_wire_send_light(int fd, const hc_light_req *q);
int hc_wire_send_vis(int fd, const hc_light_req *q, const hc_point_req *pts, uint32_t m);

/* Worker side: the next request, and the points of a HC_RQ_VIS (0 or -1). */
hc_req_kind hc_wire_recv_request(int fd, hc_request *rq);
int hc_wire_recv_points(int fd, hc_point_req *pts, uint32_t m);

/* Worker -> caller: a tagged text (an error, or the start-up report with
 * tag HC_MSG_READY and ""), cut at HC_MAX_MSG bytes; failures are ignored
 * (the worker exits after an error anyway). */
void hc_wire_send_text(int fd, uint32_t tag, const char *text);
/* Caller side: reads the len bytes of such a text into text[HC_MAX_MSG + 1]
 * and ends it with '\0'; 0, or -1 (len too long, or the stream is lost). */
int hc_wire_recv_text(int fd, uint32_t len, char *text);

/* The reply to a row request: hc_wire_reply_init once (0, or -1 when out of
 * memory), then per request _begin, one _row per row (0 or -1: the stream
 * is lost), then _end, which sends what is left (0 or -1), or _fail. */
int hc_wire_reply_init(hc_reply *r, uint32_t n);
void hc_wire_reply_begin(hc_reply *r, uint32_t count);
int hc_wire_reply_row(int fd, hc_reply *r, uint32_t index, uint32_t cnt, const uint32_t *col,
                      const float *val);
int hc_wire_reply_end(int fd, hc_reply *r);
/* A row failed: sends the rows collected so far, then the error text in
 * place of the next row's header (the worker exits after). */
void hc_wire_reply_fail(int fd, hc_reply *r, const char *text);
/* Replies to one light part (m entries j, Φ_j) and to one visibility chunk. */
int hc_wire_send_light_reply(int fd, uint32_t m, const uint32_t *col, const double *val);
int hc_wire_send_vis_reply(int fd, uint32_t m, const double *vis);

/* ------------------------------------------------------- the producers */

/* One call's work and where its answers go: rows of patches into F (or,
 * with F NULL, to store), or rows of point receivers handed to store.  Its
 * items are numbered 0..count (rows[k] or recv[k]); store gets the item
 * number. */
typedef struct hc_job {
    const uint32_t *rows;       /* rows: patch indices */
    rad_matrix *F;
    const hc_receiver *recv;    /* points */
    hc_row_store store;
    void *user;
    uint32_t count;
} hc_job;

/* Items [first, first + count) handed out in one request, of which `done`
 * are answered. */
typedef struct hc_range {
    uint32_t first, count, done;
} hc_range;

/* One run of a job (producer.c): which items are handed out, which come
 * back to be handed out again (retry), and the strikes of items whose
 * worker stopped while computing them.  `local` and `remote` are the
 * producers' own bookkeeping of the run. */
typedef struct hc_run {
    const hc_job *job;
    uint32_t chunk;      /* items per request to one local worker */
    uint32_t next;       /* items from here on are not handed out yet */
    uint32_t done;       /* items stored */
    hc_range *retry;     /* ranges to hand out again, before `next` */
    uint32_t retry_head, retry_len, retry_cap;
    uint8_t *strikes;    /* per item: workers that stopped while computing it */
    int rc;              /* the first failure; then answers are only drained */
    void *local;         /* pool.c's */
    void *remote;        /* mpi_ranks.c's */
} hc_run;

/* A row producer: what computes the items of a job and draws the lights'
 * item buffers.  The engine calls only these (producer.c, light_requests.c),
 * so another transport or machine is a new table, not a rewrite.  A job
 * runs as begin, then give and collect in turn until collect reports
 * nothing held, then end:
 *   start        the engine's geometry is ready: start the workers (or
 *                ranks) and have them set up; RAD_OK or an error;
 *   begin/end    a run's own bookkeeping (run->local, run->remote);
 *   give         hand blocks of items (hc_run_take) to whoever has room;
 *   collect      receive answers (hc_run_store), waiting at most timeout_ms
 *                (-1: until one comes); returns the items still held;
 *   light_power  Φ of the light parts parts[0..np) added into power;
 *   light_vis    visibility of points, grouped by part (light_requests.c's
 *                order and start);
 *   stop         stop the workers (hc_destroy).
 * The local fork pool (pool.c, pool_lights.c) is the producer of every
 * engine; radiosity-mpi installs hc_remote_producer (mpi_ranks.c), which
 * spreads the items over MPI ranks and runs the local pool beside them. */
typedef struct hc_producer {
    const char *name;
    int (*start)(hc_engine *e, rad_error *err);
    int (*begin)(hc_engine *e, hc_run *run, rad_error *err);
    void (*give)(hc_engine *e, hc_run *run, rad_error *err);
    uint32_t (*collect)(hc_engine *e, hc_run *run, int timeout_ms, rad_error *err);
    void (*end)(hc_engine *e, hc_run *run);
    int (*light_power)(hc_engine *e, hc_light_req *q, const uint32_t *parts, uint32_t np,
                       double *power, rad_error *err);
    int (*light_vis)(hc_engine *e, hc_light_req *q, const hc_receiver *points,
                     const uint32_t *order, const uint32_t start[8], double *vis, rad_error *err);
    void (*stop)(hc_engine *e);
} hc_producer;

/* pool.c: the local fork pool. */
extern const hc_producer hc_pool_producer;
/* pool_lights.c: its light_power and light_vis. */
int hc_pool_light_power(hc_engine *e, hc_light_req *q, const uint32_t *parts, uint32_t np,
                        double *power, rad_error *err);
int hc_pool_light_vis(hc_engine *e, hc_light_req *q, const hc_receiver *points,
                      const uint32_t *order, const uint32_t start[8], double *vis, rad_error *err);
/* producer.c: the producer of new engines when set (radiosity-mpi sets it
 * once, before any engine: process-wide), else hc_pool_producer. */
extern const hc_producer *hc_remote_producer;

/* producer.c: the next block of at most max items to hand out (items
 * handed out again first); 0 when none is left or the caller asked to stop. */
int hc_run_take(hc_engine *e, hc_run *run, uint32_t max, hc_range *r);
/* producer.c: items [first, first + count) go back to be handed out again. */
void hc_run_retry(hc_run *run, uint32_t first, uint32_t count);
/* producer.c: the answer for item `item` (i: the patch of a row, or the
 * item number of a point, as the worker echoes it): checked (i, columns
 * in range and increasing, not i's own, values > 0 and finite) and stored
 * unless the run has failed.  0, or -1 when malformed (nothing stored). */
int hc_run_store(hc_engine *e, hc_run *run, uint32_t item, uint32_t i, uint32_t cnt,
                 const uint32_t *col, const float *val, rad_error *err);
/* producer.c: the first failure of a run is the one kept. */
static inline void hc_run_fail(hc_run *run, int code)
{
    if (run->rc == RAD_OK)
        run->rc = code;
}
/* producer.c: the patch an item is of, for messages. */
static inline uint32_t hc_item_patch(const hc_job *job, uint32_t item)
{
    return job->recv ? job->recv[item].patch : job->rows[item];
}
/* producer.c: runs a job on e's producer. */
int hc_run_job(hc_engine *e, const hc_job *job, rad_error *err);

/* ------------------------------------------------------------ the worker */

typedef struct hc_gl hc_gl;     /* gl.c */
typedef struct hc_cand hc_cand; /* rows.c */

/* A worker's scratch: made once at start-up (the light and visibility
 * buffers on the first such request), reused by every request. */
typedef struct hc_work {
    hc_gl *gl;
    /* The vertex buffer's layout (gl.c): patch j's triangles are the
     * vcount[j] (3 or 6) vertices from vfirst[j], nvert in all. */
    int *vfirst;
    int *vcount;
    uint32_t nvert;
    uint32_t *pixels;  /* 3R²: the item-buffer atlas read back */
    double *acc;       /* n: F_ij (or Φ_j) accumulators, zero between requests */
    uint32_t *front;   /* patches in front of the current plane, ascending */
    int *first[5];     /* per face: merged vertex ranges of a draw list */
    int *count[5];
    uint32_t *col;     /* one row's entries */
    float *val;
    /* Exact entries (rows.c, when the engine's any_exact), n each: */
    hc_cand *cand;     /* the current row's candidates */
    uint32_t *order;   /* candidates of one OR pass, then the patches of one focused view */
    uint8_t *mark;     /* 1 for the current row's candidates, else 0 */
    uint32_t *fslot;   /* 2n: a focused view's candidates (indices into cand),
                        * then their pixel counts */
    double *fsum;      /* 3n: a focused view's sums S, S° and visibilities */
    double *preach;    /* npoly: farthest corner of a polygon's patches from its
                        * centre (rows.c's thin polygons, hc_options.weak) */
    /* Lights (light_views.c): */
    uint32_t lR;       /* size of lpixels and lweight (0: none yet) */
    hc_light_req lkey; /* the part whose item buffer lpixels holds, when lkey_valid */
    int lkey_valid;
    uint32_t *lpixels; /* lR²: a light view's item buffer */
    double *lweight;   /* lR²: pixel solid angle of a cube face, 6 faces sum to 4π */
    double *lval;      /* n: Φ_j of one answer */
    hc_point_req *vpts; /* HC_VIS_CHUNK: the points of a visibility request */
    double *vis;       /* HC_VIS_CHUNK: their visibilities */
    hc_reply out;      /* replies not yet sent */
    /* A bent patch's row (row_samples.c): */
    double *racc;      /* n: Σ_s (A_s / A_i) F_sj, zero between rows */
    uint32_t *rcell;   /* ncell: a patch's cells, sample by sample */
    uint8_t *rgroup;   /* ncell: each cell's sample */
    const struct hc_sample *smp; /* the sample of the row being computed */
} hc_work;

/* worker.c: the worker process's body, from the fork to its _exit. */
void hc_worker_main(const hc_engine *e, int fd) __attribute__((noreturn));

/* Appends patch j's vertices to a draw list of merged ranges (first[],
 * count[], *nr of them), extending the last range when j follows *last. */
static inline void hc_push_range(const hc_work *w, int *first, int *count, int *nr,
                                 uint32_t *last, uint32_t j)
{
    if (*nr > 0 && *last + 1 == j) {
        count[*nr - 1] += w->vcount[j];
    } else {
        first[*nr] = w->vfirst[j];
        count[*nr] = w->vcount[j];
        (*nr)++;
    }
    *last = j;
}

/* ---------------------------------------------------------------- rows.c */

/* Allocates the exact entries' scratch of w (when e->any_exact); 0, or -1
 * with msg set. */
int hc_rows_init(const hc_engine *e, hc_work *w, char *msg);
/* Where one hemi-cube of a row of patch i sits: its centre c and axis n
 * (relative to the origin), and the cells of i it stands for, over which
 * its area-averaged exact entries are taken (cells[0..ncell), area their
 * sum; cells NULL: all of i's).  point: a point receiver (an element),
 * whose exact entries are point factors only. */
typedef struct hc_sample {
    rad_vec3 c, n;
    const uint32_t *cells;
    uint32_t ncell;
    double area;
    int point;
    double reach;  /* > 0: draw only the patches within reach (hc_receiver) */
} hc_sample;
/* Computes the hemi-cube row of patch i from sample s into w->col/w->val
 * (F_sj: its cells' part of the row); returns the entry count, or -1 with
 * msg set on a GL error. */
long hc_row_sample(const hc_engine *e, hc_work *w, uint32_t i, const hc_sample *s, char *msg);
/* Computes row i into w->col/w->val; returns the entry count, or -1 with
 * msg set on a GL error.  `at` (relative to the origin) moves the cube from
 * i's centre to a point of i: an element's row F_ej (hc_compute_points),
 * about the normal of the cell of i that holds it.  Without `at`, the row
 * of a patch whose cells bend (row_samples.c): the area-weighted mean of
 * hc_row_cubes(i) samples' rows, one for a planar patch.  reach (points
 * only): hc_receiver.reach. */
long hc_row(const hc_engine *e, hc_work *w, uint32_t i, const rad_vec3 *at, double reach,
            char *msg);

/* --------------------------------------------------------- light_views.c */

/* Renders part q->part of a light and leaves Φ_j > 0 in w->col/w->lval;
 * returns the entry count or -1 with msg set. */
long hc_light_part(const hc_engine *e, hc_work *w, const hc_light_req *q, char *msg);
/* Visibility of pts[0..m) (patches checked by the caller) from part
 * q->part of a light into vis[0..m); 0, or -1 with msg set. */
int hc_light_points(const hc_engine *e, hc_work *w, const hc_light_req *q,
                    const hc_point_req *pts, uint32_t m, double *vis, char *msg);

/* ------------------------------------------------------- patch_factors.c */

/* F from point c (normal n, both relative to the origin) to patch j, the
 * point-to-polygon integral summed over j's cells: what an exact entry of
 * a row holds before visibility, and column.c's factor. */
double hc_point_to_patch(const hc_engine *e, rad_vec3 c, rad_vec3 n, uint32_t j);
/* F from patch i to patch j averaged over i (no visibility): what a row of
 * i holds before visibility for a near j (near: at least 2 subdivisions)
 * or an emitter j (issue 18: averaged over the receiving patch, so that
 * Σ_i A_i F_ij = A_j holds for the emitter's column, the one every watt
 * leaves by; at the centre a closed room absorbed 0.3-0.8 % more than its
 * lamp emitted), and column.c's factor for its receivers. */
double hc_area_factor(const hc_engine *e, uint32_t i, uint32_t j, int near);
/* The same averaged over the cells cells[0..ncell) of i only (of summed
 * area `area`): a sample's part of a bent patch's row (row_samples.c). */
double hc_cells_factor(const hc_engine *e, uint32_t i, const uint32_t *cells, uint32_t ncell,
                       double area, uint32_t j, int near);

/* ------------------------------------------------------------ analytic.c */

/* hc_ff_polygon_polygon's area average over polygon a of the factor to a
 * surface given as directed edges (rad_point_edges_factor: no clipping, so
 * every end point must lie strictly in front of a's plane and a in front
 * of every cell the edges bound). */
double hc_ff_polygon_edges(const rad_vec3 *a, uint32_t na, const double *edges, uint32_t ne,
                           uint32_t subdiv);

/* ------------------------------------- GL back ends (gl_osmesa.c, gl_egl.c) */

/* What makes a GL context for gl.c's drawing: one per third-party library,
 * each in a file of its own that alone knows it.  gl.c calls load, then
 * proc for every entry point it draws with, then context; after that it
 * draws with the entry points alone, whichever back end made the context.
 * Nothing is ever torn down: the context lives until the process's _exit. */
typedef void (*hc_gl_proc)(void);
typedef struct hc_gl_context {
    /* The file name of the library (for messages). */
    const char *(*library)(void);
    /* Loads the library (dlopen: never linked); 0, or -1 with msg set. */
    int (*load)(char *msg);
    /* A GL entry point by name ("glEnable"), or NULL; after load. */
    hc_gl_proc (*proc)(const char *name);
    /* Makes a desktop GL 4.5 core context current in this process, drawing
     * into framebuffer objects only; gpu_only: a GPU or fail (EGL; OSMesa
     * ignores it, the chooser never asks it); 0, or -1 with msg set. */
    int (*context)(int gpu_only, char *msg);
} hc_gl_context;

extern const hc_gl_context hc_gl_osmesa; /* gl_osmesa.c: libOSMesa, llvmpipe */
extern const hc_gl_context hc_gl_egl;    /* gl_egl.c: libEGL, a GPU or surfaceless */

/* ------------------------------------------------------------ gl_choice.c */

/* hc_create's: settles o->gl (HC_GL_AUTO as hc_gl_choose settles it, the
 * probe forked before the workers are); RAD_OK, or RAD_ERR_USAGE for a
 * value that is no hc_gl_kind. */
int hc_gl_settle(hc_options *o, rad_error *err);

/* ------------------------------------------------------- draw_geometry.c */

/* A vertex of the item buffer's geometry: position relative to the origin
 * (float), then the patch id. */
typedef struct hc_draw_vtx {
    float p[3];
    uint32_t id;
} hc_draw_vtx;

/* The triangles every patch is drawn with (draw_geometry.c): indexed,
 * patch j's indices contiguous. */
typedef struct hc_draw {
    hc_draw_vtx *vtx;
    uint32_t nvtx;
    uint32_t *idx;
    size_t nidx;
    uint32_t simplified; /* clusters drawn by a fan of their simplified outline */
} hc_draw;

/* Builds the draw geometry of e's patches (simplified clusters unless
 * RADIOSITY_DRAW_EVERY_CELL=1), patch j's indices [vfirst[j], vfirst[j] +
 * vcount[j]) (caller's arrays of e->n); 0, or -1 with msg set. */
int hc_draw_build(const hc_engine *e, hc_draw *out, int *vfirst, int *vcount, char *msg);
void hc_draw_free(hc_draw *d); /* NULL does nothing */

/* ------------------------------------------------------------------ gl.c */

/* Loads the GL back end e->opt.gl names (HC_GL_EGL, else OSMesa; the
 * library is never linked: only a worker loads it, here) and makes the
 * worker's context, the 3R×R item-buffer atlas, the shaders and the vertex
 * buffer of every patch (filling w->gl, w->vfirst, w->vcount, w->nvert);
 * 0, or -1 with msg set. */
int hc_gl_create(const hc_engine *e, hc_work *w, char *msg);
/* In a process of its own (gl_choice.c's probe, which then exits): starts
 * back end c (gpu_only as hc_gl_context.context) and copies its GL_RENDERER
 * into renderer[size]; 0, or -1 with msg set. */
int hc_gl_probe(const hc_gl_context *c, int gpu_only, char *renderer, size_t size, char *msg);
/* 0, or -1 with msg "hemi-cube: WHERE: GL error ..." when GL flagged one. */
int hc_gl_check(const char *where, char *msg);

/* Row-major P·V for a camera looking along d, with the depth convention of
 * gl.c (reversed Z, infinite far plane, clip z = near).  side 0: x, y in
 * [-1, 1] at distance 1; side 1 (a half face): "up" in [0, 1]. */
void hc_gl_projection(double m[16], rad_vec3 right, rad_vec3 up, rad_vec3 d, int side, double near);

/* Binds the atlas, clears its 3R×R items to HC_NO_PATCH and its depth, and
 * places the eye (relative to the origin). */
void hc_gl_atlas_begin(hc_gl *g, uint32_t R, rad_vec3 eye);
/* Places the eye without clearing anything. */
void hc_gl_eye(hc_gl *g, rad_vec3 eye);
/* Clears the items of rows [0, h) of the bound target to `value`. */
void hc_gl_clear_items(hc_gl *g, uint32_t w, uint32_t h, uint32_t value);
/* Makes rows [y0, y0 + h) of the bound target the current view, with the
 * row-major projection m (float). */
void hc_gl_view(hc_gl *g, uint32_t y0, uint32_t w, uint32_t h, const float m[16]);
/* Makes an R×R view at row y0 current with the row-major projection m, and
 * clears its item and depth buffers. */
void hc_gl_square_view(hc_gl *g, const double m[16], uint32_t R, uint32_t y0);
/* Draws the nr vertex ranges first[k], count[k] into the current view. */
void hc_gl_draw(hc_gl *g, const int *first, const int *count, int nr);
/* Reads the items of rows [0, h) of the bound target into dst (w × h,
 * bottom row first). */
void hc_gl_read_items(hc_gl *g, uint32_t w, uint32_t h, uint32_t *dst);
/* The depth at pixel (x, y) of the bound target (near / distance). */
float hc_gl_read_depth(hc_gl *g, uint32_t x, uint32_t y);
/* on = 1: the candidates' OR passes (a front side sets bit id mod 32, no
 * depth test); on = 0: back to the item buffer with depth test. */
void hc_gl_or_mode(hc_gl *g, int on);
/* Makes (or keeps) the R×R light target and binds it; 0, or -1 with msg. */
int hc_gl_light_target(hc_gl *g, uint32_t R, char *msg);

#endif /* HC_INTERNAL_H */
