/* wire.c - the protocol between the caller and its workers.
 *
 * Owns the bytes on a worker's stream (today one end of a socketpair, an
 * fd): how requests and replies are framed and encoded.  Neither rows.c nor
 * gl.c sees a stream, so another transport (MPI between machines, say)
 * replaces this file and the fds in pool.c, nothing else.  Protocol
 * (native-endian uint32 words, floats for F_ij):
 *   caller -> worker: count, i[count]            (count <= HC_MAX_CHUNK)
 *   worker -> caller: HC_MSG_BATCH, count, then per row i, m, j[m], F_ij[m]
 *   caller -> worker: HC_REQ_POINTS, count, hc_point_req[count]
 *   worker -> caller: HC_MSG_BATCH, count, then per point: index, m, j[m], F_ej[m]
 *   caller -> worker: HC_REQ_LIGHT, hc_light_req (one part of a light)
 *   worker -> caller: HC_MSG_LIGHT, m, j[m], Φ_j[m] (doubles)
 *   caller -> worker: HC_REQ_VIS, hc_light_req, m, hc_point_req[m] (m <= HC_VIS_CHUNK)
 *   worker -> caller: HC_MSG_VIS, m, V[m] (doubles in [0, 1], in the order asked)
 *   on failure:       HC_MSG_ERROR, length, text (then the worker exits)
 *   at start:         HC_MSG_READY, 0 (ready) or HC_MSG_ERROR, length, text
 * A worker answers its requests in the order asked and stops when its
 * stream closes.  Invariant: every function here moves whole messages or
 * reports the stream lost; it never checks what a message means (patch
 * numbers, resolutions: the receiver's business).
 */
#include "hc_internal.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#define HC_FLUSH (1u << 20) /* a worker sends when this much is buffered */

/* ------------------------------------------------------------- transport */

/* MSG_NOSIGNAL: a dead peer must not SIGPIPE us. */
int hc_wire_send(int fd, const void *p, size_t len)
{
    const char *c = p;
    while (len) {
        ssize_t k = send(fd, c, len, MSG_NOSIGNAL);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        c += k;
        len -= (size_t)k;
    }
    return 0;
}

int hc_wire_recv(int fd, void *p, size_t len)
{
    char *c = p;
    while (len) {
        ssize_t k = recv(fd, c, len, 0);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        if (k == 0)
            return -1;
        c += k;
        len -= (size_t)k;
    }
    return 0;
}

/* -------------------------------------------------------------- requests */

int hc_wire_send_rows(int fd, const uint32_t *rows, uint32_t count)
{
    uint32_t buf[1 + HC_MAX_CHUNK];
    buf[0] = count;
    memcpy(buf + 1, rows, count * sizeof *buf);
    return hc_wire_send(fd, buf, (1 + count) * sizeof *buf);
}

int hc_wire_send_points(int fd, const hc_point_req *pts, uint32_t count)
{
    uint32_t head[2] = {HC_REQ_POINTS, count};
    return hc_wire_send(fd, head, sizeof head) || hc_wire_send(fd, pts, count * sizeof *pts) ? -1 : 0;
}

int hc_wire_send_light(int fd, const hc_light_req *q)
{
    uint32_t word = HC_REQ_LIGHT;
    return hc_wire_send(fd, &word, sizeof word) || hc_wire_send(fd, q, sizeof *q) ? -1 : 0;
}

int hc_wire_send_vis(int fd, const hc_light_req *q, const hc_point_req *pts, uint32_t m)
{
    uint32_t word = HC_REQ_VIS;
    return hc_wire_send(fd, &word, sizeof word) || hc_wire_send(fd, q, sizeof *q) ||
                   hc_wire_send(fd, &m, sizeof m) || hc_wire_send(fd, pts, m * sizeof *pts)
               ? -1
               : 0;
}

hc_req_kind hc_wire_recv_request(int fd, hc_request *rq)
{
    uint32_t count;
    if (hc_wire_recv(fd, &count, sizeof count) != 0)
        return rq->kind = HC_RQ_END;
    if (count == HC_REQ_LIGHT || count == HC_REQ_VIS) {
        rq->kind = count == HC_REQ_LIGHT ? HC_RQ_LIGHT : HC_RQ_VIS;
        rq->count = 0;
        if (hc_wire_recv(fd, &rq->light, sizeof rq->light) != 0 ||
            (rq->kind == HC_RQ_VIS && (hc_wire_recv(fd, &rq->count, sizeof rq->count) != 0 ||
                                       rq->count == 0 || rq->count > HC_VIS_CHUNK)))
            return rq->kind = HC_RQ_BAD;
        return rq->kind;
    }
    /* Rows of patches, or rows of points on patches (elements). */
    int points = count == HC_REQ_POINTS;
    if (points && hc_wire_recv(fd, &count, sizeof count) != 0)
        return rq->kind = HC_RQ_BAD;
    if (count == 0 || count > HC_MAX_CHUNK ||
        (points ? hc_wire_recv(fd, rq->pts, count * sizeof *rq->pts)
                : hc_wire_recv(fd, rq->rows, count * sizeof *rq->rows)) != 0)
        return rq->kind = HC_RQ_BAD;
    rq->count = count;
    return rq->kind = points ? HC_RQ_POINTS : HC_RQ_ROWS;
}

int hc_wire_recv_points(int fd, hc_point_req *pts, uint32_t m)
{
    return hc_wire_recv(fd, pts, m * sizeof *pts);
}

/* ----------------------------------------------------------------- texts */

void hc_wire_send_text(int fd, uint32_t tag, const char *text)
{
    size_t len = strlen(text);
    if (len > HC_MAX_MSG)
        len = HC_MAX_MSG;
    uint32_t hdr[2] = {tag, (uint32_t)len};
    if (hc_wire_send(fd, hdr, sizeof hdr) == 0)
        hc_wire_send(fd, text, len);
}

int hc_wire_recv_text(int fd, uint32_t len, char *text)
{
    if (len > HC_MAX_MSG || hc_wire_recv(fd, text, len) != 0)
        return -1;
    text[len] = '\0';
    return 0;
}

/* --------------------------------------------------------------- replies */

int hc_wire_reply_init(hc_reply *r, uint32_t n)
{
    /* Room for a flush's worth and one whole row of n entries beyond it. */
    r->cap = HC_FLUSH + 16 + (size_t)8 * n;
    r->len = 0;
    r->buf = malloc(r->cap);
    return r->buf ? 0 : -1;
}

void hc_wire_reply_begin(hc_reply *r, uint32_t count)
{
    uint32_t batch[2] = {HC_MSG_BATCH, count};
    memcpy(r->buf, batch, sizeof batch);
    r->len = sizeof batch;
}

/* The caller wakes once per HC_FLUSH bytes or per request, not per row. */
int hc_wire_reply_row(int fd, hc_reply *r, uint32_t index, uint32_t cnt, const uint32_t *col,
                      const float *val)
{
    size_t bytes = sizeof(uint32_t) * (2 + 2 * (size_t)cnt);
    if (r->len + bytes > r->cap) {
        if (hc_wire_send(fd, r->buf, r->len) != 0)
            return -1;
        r->len = 0;
    }
    uint32_t hdr[2] = {index, cnt};
    unsigned char *o = r->buf + r->len;
    memcpy(o, hdr, sizeof hdr);
    memcpy(o + sizeof hdr, col, (size_t)cnt * sizeof *col);
    memcpy(o + sizeof hdr + (size_t)cnt * sizeof *col, val, (size_t)cnt * sizeof *val);
    r->len += bytes;
    if (r->len >= HC_FLUSH) {
        if (hc_wire_send(fd, r->buf, r->len) != 0)
            return -1;
        r->len = 0;
    }
    return 0;
}

int hc_wire_reply_end(int fd, hc_reply *r)
{
    if (r->len && hc_wire_send(fd, r->buf, r->len) != 0)
        return -1;
    r->len = 0;
    return 0;
}

void hc_wire_reply_fail(int fd, hc_reply *r, const char *text)
{
    if (hc_wire_send(fd, r->buf, r->len) == 0)
        hc_wire_send_text(fd, HC_MSG_ERROR, text);
}

int hc_wire_send_light_reply(int fd, uint32_t m, const uint32_t *col, const double *val)
{
    uint32_t hdr[2] = {HC_MSG_LIGHT, m};
    return hc_wire_send(fd, hdr, sizeof hdr) != 0 ||
                   hc_wire_send(fd, col, (size_t)m * sizeof *col) != 0 ||
                   hc_wire_send(fd, val, (size_t)m * sizeof *val) != 0
               ? -1
               : 0;
}

int hc_wire_send_vis_reply(int fd, uint32_t m, const double *vis)
{
    uint32_t hdr[2] = {HC_MSG_VIS, m};
    return hc_wire_send(fd, hdr, sizeof hdr) != 0 || hc_wire_send(fd, vis, m * sizeof *vis) != 0
               ? -1
               : 0;
}
