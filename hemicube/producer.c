/* producer.c - a job of rows (or of element hemi-cubes) run on the engine's
 * row producer: hc_compute_rows, hc_compute_points, and what every
 * producer shares about a run (hc_run_take, hc_run_retry, hc_run_store).
 *
 * Owns the run of a job: which items are handed out next (those handed
 * out again first), the strikes, and the checks and storing of every
 * answer, whoever computed it; a producer (pool.c's local workers,
 * mpi_ranks.c's MPI ranks) only moves items and answers.  Invariant: every
 * item of a job is stored exactly once, or the call fails; the answer of an
 * item is stored only after the row rules hold for it (columns in range and
 * increasing, never the row's own patch, values > 0 and finite).
 */
#include "hc_internal.h"

#include <stdlib.h>
#include <string.h>

const hc_producer *hc_remote_producer;

int hc_run_take(hc_engine *e, hc_run *run, uint32_t max, hc_range *r)
{
    const hc_job *job = run->job;
    if ((e->opt.stop && *e->opt.stop) || run->rc != RAD_OK || max == 0)
        return 0; /* asked to stop: what is held is still collected */
    if (run->retry_len) {
        hc_range *q = &run->retry[run->retry_head];
        *r = (hc_range){q->first, q->count < max ? q->count : max, 0};
        q->first += r->count;
        q->count -= r->count;
        if (q->count == 0) {
            run->retry_head++;
            run->retry_len--;
        }
        return 1;
    }
    if (run->next >= job->count)
        return 0;
    uint32_t left = job->count - run->next;
    *r = (hc_range){run->next, left < max ? left : max, 0};
    run->next += r->count;
    return 1;
}

void hc_run_retry(hc_run *run, uint32_t first, uint32_t count)
{
    if (count && run->retry_head + run->retry_len < run->retry_cap)
        run->retry[run->retry_head + run->retry_len++] = (hc_range){first, count, 0};
}

int hc_run_store(hc_engine *e, hc_run *run, uint32_t item, uint32_t i, uint32_t cnt,
                 const uint32_t *col, const float *val, rad_error *err)
{
    const hc_job *job = run->job;
    if (item >= job->count || i != (job->recv ? item : job->rows[item]) || cnt > e->n)
        return -1;
    uint32_t self = hc_item_patch(job, item);
    for (uint32_t q = 0; q < cnt; q++)
        if (col[q] >= e->n || col[q] == self || (q && col[q] <= col[q - 1]) ||
            !(val[q] > 0.0f) || !isfinite(val[q]))
            return -1;
    if (run->rc != RAD_OK)
        return 0;
    int s = job->F ? rad_matrix_set_row(job->F, i, cnt, col, val, err)
                   : job->store(job->user, item, cnt, col, val, err);
    if (s != RAD_OK) {
        hc_run_fail(run, s);
        return 0;
    }
    run->done++;
    if (e->opt.progress)
        e->opt.progress(e->opt.progress_user, run->done, job->count);
    return 0;
}

/* Items are left to hand out, and may be. */
static int pending(const hc_engine *e, const hc_run *run)
{
    return run->rc == RAD_OK && !e->broken && !(e->opt.stop && *e->opt.stop) &&
           (run->retry_len || run->next < run->job->count);
}

/* Hands the job out through the producer and collects every answer. */
int hc_run_job(hc_engine *e, const hc_job *job, rad_error *err)
{
    const uint32_t count = job->count;
    if (e->broken)
        return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
    if (count == 0)
        return RAD_OK;
    /* Modest chunks, at most two in flight per local worker: a fast worker
     * comes back for more, and the tail stays short. */
    uint32_t chunk = count / (e->nproc * 8);
    hc_run run = {.job = job, .chunk = chunk < 1 ? 1 : chunk > HC_MAX_CHUNK ? HC_MAX_CHUNK : chunk};
    /* every loss puts back at most two ranges and strikes an item: at most
     * two losses an item before the job fails */
    run.retry_cap = 4 * count + 2;
    run.retry = malloc(run.retry_cap * sizeof *run.retry);
    run.strikes = calloc(count, 1);
    int rc = run.retry && run.strikes ? e->prod->begin(e, &run, err)
                                      : rad_fail(err, RAD_ERR_NOMEM, "hemi-cube: out of memory");
    if (rc == RAD_OK) {
        /* until nothing is held and nothing is left to hand out (a lost
         * worker's items come back to be handed out again) */
        for (;;) {
            e->prod->give(e, &run, err);
            if (e->prod->collect(e, &run, -1, err) == 0 && !pending(e, &run))
                break;
        }
        e->prod->end(e, &run);
        rc = run.rc;
        if (e->broken && rc == RAD_OK)
            rc = rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
        if (rc == RAD_OK && run.done < count)
            rc = rad_fail(err, RAD_ERR_INTERRUPTED, "hemi-cube: stopped after %u of %u rows",
                          run.done, count);
    }
    free(run.retry);
    free(run.strikes);
    return rc;
}

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
    return hc_run_job(e, &job, err);
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
    return hc_run_job(e, &job, err);
}
