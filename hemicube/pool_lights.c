/* pool_lights.c - the local fork pool's side of the punctual lights: the
 * light parts and visibility chunks of light_requests.c sent to the
 * workers, and their answers read (the hc_producer's light_power and
 * light_vis of pool.c's producer); and what both pool files do when a
 * worker's stream is lost or carries its error text (hc_pool_gone,
 * hc_pool_error), so that pool.c calls this file and never the reverse.
 *
 * Part k of a light goes to worker k mod nproc; each worker answers in the
 * order asked, so reading the parts in order reads every stream in order,
 * and the caller adds the parts in part order: the result never depends on
 * which worker drew what.  Invariant: answers already asked for are read
 * even after a failure, while their workers live, so a later call finds
 * the streams in step.
 */
#include "hc_internal.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ------------------------------------------- a worker's stream, lost */


int hc_pool_gone(hc_engine *e, uint32_t k, rad_error *err)
{
    e->broken = 1;
    snprintf(e->broken_msg, sizeof e->broken_msg, "hemi-cube worker %u stopped", k);
    e->w[k].in_flight = 0;
    return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
}

/* Reads the len bytes of worker k's error text (the worker has exited),
 * marks the engine broken and fails with that text. */
int hc_pool_error(hc_engine *e, uint32_t k, uint32_t len, rad_error *err)
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
        return hc_pool_error(e, k, hdr[1], err);
    return RAD_OK;
}

void hc_pool_drop(hc_engine *e, uint32_t k)
{
    close(e->w[k].fd);
    e->w[k].fd = -1;
}

/* ---------------------------------------------------- light requests */

/* Reads the header of worker k's answer to a light request: RAD_OK with
 * its count in *m when the header is `tag`; else the engine is broken (a
 * worker's error message, or a stream out of step). */
static int receive_light_header(hc_engine *e, uint32_t k, uint32_t tag, uint32_t *m,
                                rad_error *err)
{
    uint32_t hdr[2];
    int rc = hc_pool_header(e, k, hdr, err);
    if (rc != RAD_OK)
        return rc;
    if (hdr[0] != tag)
        return hc_pool_gone(e, k, err);
    *m = hdr[1];
    return RAD_OK;
}

/* Reads worker k's answer to one light part and adds it to power (when
 * add); RAD_OK, or the engine is broken and the error is in err. */
static int receive_light(hc_engine *e, uint32_t k, double *power, double *rx, int add,
                         rad_error *err)
{
    int fd = e->w[k].fd;
    uint32_t m = 0;
    int rc = receive_light_header(e, k, HC_MSG_LIGHT, &m, err);
    if (rc != RAD_OK)
        return rc;
    if (m > e->n ||
        hc_wire_recv(fd, e->rx_col, (size_t)m * sizeof *e->rx_col) != 0 ||
        hc_wire_recv(fd, rx, (size_t)m * sizeof *rx) != 0)
        return hc_pool_gone(e, k, err);
    for (uint32_t q = 0; q < m; q++)
        if (e->rx_col[q] >= e->n || (q && e->rx_col[q] <= e->rx_col[q - 1]) || !(rx[q] > 0.0) ||
            !isfinite(rx[q]))
            return hc_pool_gone(e, k, err);
    if (add)
        for (uint32_t q = 0; q < m; q++)
            power[e->rx_col[q]] += rx[q];
    return RAD_OK;
}

int hc_pool_light_power(hc_engine *e, hc_light_req *q, const uint32_t *parts, uint32_t np,
                        double *power, rad_error *err)
{
    int rc = RAD_OK;
    double *rx = malloc((size_t)e->n * sizeof *rx);
    if (!rx)
        return rad_fail(err, RAD_ERR_NOMEM, "hc_light_power: out of memory for %u patches", e->n);
    /* Part k goes to worker k mod nproc; each worker answers in the order
     * asked, so reading the parts in order reads every stream in order. */
    uint32_t sent = 0;
    for (; sent < np; sent++) {
        uint32_t k = sent % e->nproc;
        q->part = parts[sent];
        if (hc_wire_send_light(e->w[k].fd, q) != 0) {
            rc = hc_pool_gone(e, k, err);
            break;
        }
    }
    /* Answers of parts already sent are read even after a failure, while
     * their workers live, so a later call finds the streams in step. */
    for (uint32_t p = 0; p < sent; p++) {
        uint32_t k = p % e->nproc;
        if (e->w[k].fd < 0)
            continue;
        int s = receive_light(e, k, power, rx, rc == RAD_OK, rc == RAD_OK ? err : NULL);
        if (s != RAD_OK && rc == RAD_OK)
            rc = s;
        if (s != RAD_OK) {
            /* That stream is lost: no more reads from it. */
            hc_pool_drop(e, k);
        }
    }
    free(rx);
    return rc;
}

/* Reads worker k's answer to one visibility chunk of m points into
 * vis[idx[0..m)] (when store).  RAD_OK, or the engine is broken. */
static int receive_vis(hc_engine *e, uint32_t k, const uint32_t *idx, uint32_t m, double *vis,
                       double *rx, int store, rad_error *err)
{
    uint32_t got = 0;
    int rc = receive_light_header(e, k, HC_MSG_VIS, &got, err);
    if (rc != RAD_OK)
        return rc;
    if (got != m || hc_wire_recv(e->w[k].fd, rx, (size_t)m * sizeof *rx) != 0)
        return hc_pool_gone(e, k, err);
    for (uint32_t q = 0; q < m; q++)
        if (!(rx[q] >= 0.0 && rx[q] <= 1.0))
            return hc_pool_gone(e, k, err);
    if (store)
        for (uint32_t q = 0; q < m; q++)
            vis[idx[q]] = rx[q];
    return RAD_OK;
}

/* Worker k takes the parts k, k + nproc, ... in turn; per round each worker
 * has one chunk in flight, and every answer of a round is read before the
 * next round is sent, so no socket fills in both directions.  Results
 * depend only on the part's pixels and the point, never on which worker
 * drew them.  rx and buf hold HC_VIS_CHUNK values each. */
static int vis_rounds(hc_engine *e, hc_light_req *q, const hc_receiver *points,
                      const uint32_t *order, const uint32_t start[8], double *vis, double *rx,
                      hc_point_req *buf, rad_error *err)
{
    int rc = RAD_OK;
    uint32_t *wpart = calloc(e->nproc, sizeof *wpart), *wnext = calloc(e->nproc, sizeof *wnext);
    uint32_t *wsent = calloc(e->nproc, sizeof *wsent), *wcnt = calloc(e->nproc, sizeof *wcnt);
    if (!wpart || !wnext || !wsent || !wcnt) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "hc_light_visibility: out of memory");
        goto done;
    }
    for (uint32_t k = 0; k < e->nproc; k++) {
        wpart[k] = k;
        wnext[k] = k < 6 ? start[k] : 0;
    }
    for (;;) {
        int any = 0;
        memset(wcnt, 0, e->nproc * sizeof *wcnt);
        for (uint32_t k = 0; k < e->nproc; k++) {
            while (rc == RAD_OK && wpart[k] < 6 && wnext[k] >= start[wpart[k] + 1]) {
                wpart[k] += e->nproc;
                if (wpart[k] < 6)
                    wnext[k] = start[wpart[k]];
            }
            if (rc != RAD_OK || wpart[k] >= 6 || e->w[k].fd < 0)
                continue;
            uint32_t f = wpart[k], m = start[f + 1] - wnext[k];
            m = m > HC_VIS_CHUNK ? HC_VIS_CHUNK : m;
            for (uint32_t i = 0; i < m; i++) {
                const hc_receiver *pt = &points[order[wnext[k] + i]];
                rad_vec3 at = rad_sub(pt->center, e->origin);
                buf[i] = (hc_point_req){order[wnext[k] + i], pt->patch, {at.x, at.y, at.z}, 0.0};
            }
            q->part = f;
            if (hc_wire_send_vis(e->w[k].fd, q, buf, m) != 0) {
                rc = hc_pool_gone(e, k, err);
                break;
            }
            wsent[k] = wnext[k];
            wcnt[k] = m;
            wnext[k] += m;
            any = 1;
        }
        /* Answers already asked for are read even after a failure, while
         * their workers live, so a later call finds the streams in step. */
        for (uint32_t k = 0; k < e->nproc; k++) {
            if (!wcnt[k] || e->w[k].fd < 0)
                continue;
            int s = receive_vis(e, k, order + wsent[k], wcnt[k], vis, rx, rc == RAD_OK,
                                rc == RAD_OK ? err : NULL);
            if (s != RAD_OK) {
                if (rc == RAD_OK)
                    rc = s;
                hc_pool_drop(e, k);
            }
        }
        if (!any || rc != RAD_OK)
            break;
    }
done:
    free(wpart), free(wnext), free(wsent), free(wcnt);
    return rc;
}

int hc_pool_light_vis(hc_engine *e, hc_light_req *q, const hc_receiver *points,
                      const uint32_t *order, const uint32_t start[8], double *vis, rad_error *err)
{
    double *rx = malloc(HC_VIS_CHUNK * sizeof *rx);
    hc_point_req *buf = malloc(HC_VIS_CHUNK * sizeof *buf);
    int rc = rx && buf ? vis_rounds(e, q, points, order, start, vis, rx, buf, err)
                       : rad_fail(err, RAD_ERR_NOMEM, "hc_light_visibility: out of memory");
    free(rx), free(buf);
    return rc;
}
