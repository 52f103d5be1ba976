/* matrix.c - the sparse form-factor matrix of rad.h.
 *
 * The matrix keeps its rows in one growing pool (col/val); a row that is
 * set again is appended and the old copy abandoned, as is a row dropped by
 * a bounded row store (rad_matrix_drop_row), until rad_matrix_compact moves
 * the rows present together again.
 * Invariant: rows present obey rad.h's row rules (rad_matrix_check: the
 * solution writer and reader always, the pipeline after a solve in debug
 * builds).
 */
#include "rad.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

rad_matrix *rad_matrix_create(uint32_t n)
{
    rad_matrix *m = calloc(1, sizeof *m);
    if (!m)
        return NULL;
    m->n = n;
    size_t k = n ? n : 1;
    m->row_done = calloc(k, sizeof *m->row_done);
    m->row_start = calloc(k, sizeof *m->row_start);
    m->row_count = calloc(k, sizeof *m->row_count);
    if (!m->row_done || !m->row_start || !m->row_count) {
        rad_matrix_destroy(m);
        return NULL;
    }
    return m;
}

void rad_matrix_destroy(rad_matrix *m)
{
    if (!m)
        return;
    free(m->row_done);
    free(m->row_start);
    free(m->row_count);
    free(m->col);
    free(m->val);
    free(m);
}

/* Resizes the pool to exactly cap entries (> 0).  col and val are resized
 * one after the other and capacity is the smaller of the two at every step,
 * so a failure leaves a usable pool. */
static int resize_pool(rad_matrix *m, uint64_t cap, rad_error *err)
{
    if (cap > SIZE_MAX / sizeof(uint32_t))
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: %llu entries do not fit in memory",
                        (unsigned long long)cap);
    const uint64_t old = m->capacity;
    uint32_t *col = realloc(m->col, (size_t)cap * sizeof *col);
    if (!col)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory at %llu entries",
                        (unsigned long long)cap);
    m->col = col;
    m->capacity = cap < old ? cap : old;
    float *val = realloc(m->val, (size_t)cap * sizeof *val);
    if (!val)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory at %llu entries",
                        (unsigned long long)cap);
    m->val = val;
    m->capacity = cap;
    return RAD_OK;
}

static int matrix_reserve(rad_matrix *m, uint64_t need, rad_error *err)
{
    if (need <= m->capacity)
        return RAD_OK;
    uint64_t cap = m->capacity ? m->capacity : 1024;
    while (cap < need)
        cap += cap / 2 + 1024; /* 1.5×: the pool can be most of memory */
    return resize_pool(m, cap, err);
}

int rad_matrix_set_row(rad_matrix *m, uint32_t i, uint32_t count, const uint32_t *col,
                       const float *val, rad_error *err)
{
    if (!m || i >= m->n || (count && (!col || !val)))
        return rad_fail(err, RAD_ERR_USAGE, "form-factor matrix: bad row %u", i);
    int rc = matrix_reserve(m, m->nnz + count, err);
    if (rc)
        return rc;
    if (count) {
        memcpy(m->col + m->nnz, col, (size_t)count * sizeof *col);
        memcpy(m->val + m->nnz, val, (size_t)count * sizeof *val);
    }
    m->row_start[i] = m->nnz;
    m->row_count[i] = count;
    m->nnz += count;
    if (!m->row_done[i]) {
        m->row_done[i] = 1;
        m->rows_done++;
    }
    return RAD_OK;
}

double rad_matrix_row_sum(const rad_matrix *m, uint32_t i)
{
    if (!m || i >= m->n || !m->row_done[i] || m->row_count[i] == 0)
        return 0.0; /* an empty row may have no pool behind it */
    const float *v = m->val + m->row_start[i];
    double s = 0.0;
    for (uint32_t k = 0; k < m->row_count[i]; k++)
        s += v[k];
    return s;
}

/* One pool entry: its column and its value. */
#define ENTRY_BYTES (sizeof(uint32_t) + sizeof(float))

uint64_t rad_matrix_pool_bytes(const rad_matrix *m) { return m->capacity * ENTRY_BYTES; }

uint64_t rad_matrix_used_bytes(const rad_matrix *m) { return m->nnz * ENTRY_BYTES; }

uint64_t rad_matrix_row_bytes(uint32_t count) { return (uint64_t)count * ENTRY_BYTES; }

uint64_t rad_matrix_live_bytes(const rad_matrix *m)
{
    uint64_t entries = 0;
    for (uint32_t i = 0; i < m->n; i++)
        if (m->row_done[i])
            entries += m->row_count[i];
    return entries * ENTRY_BYTES;
}

void rad_matrix_drop_row(rad_matrix *m, uint32_t i)
{
    if (!m || i >= m->n || !m->row_done[i])
        return;
    m->row_done[i] = 0;
    m->row_count[i] = 0;
    m->row_start[i] = 0;
    m->rows_done--;
}

/* A row present and where it starts in the pool, sorted by the latter. */
typedef struct placed {
    uint64_t start;
    uint32_t row;
} placed;

static int by_start(const void *a, const void *b)
{
    uint64_t x = ((const placed *)a)->start, y = ((const placed *)b)->start;
    return x < y ? -1 : x > y;
}

int rad_matrix_compact(rad_matrix *m, uint64_t bytes, rad_error *err)
{
    /* The rows present, in order of their place in the pool: each then
     * moves towards the front, never over a row not yet moved, so the
     * compaction needs no second pool (a bounded store has no room for
     * one). */
    placed *order = malloc(((size_t)m->rows_done + 1) * sizeof *order);
    uint32_t count = 0;
    if (!order)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory compacting");
    for (uint32_t i = 0; i < m->n; i++) {
        if (!m->row_done[i])
            continue;
        if (m->row_count[i] == 0)
            m->row_start[i] = 0; /* an empty row has no pool behind it */
        else
            order[count++] = (placed){m->row_start[i], i};
    }
    qsort(order, count, sizeof *order, by_start);
    uint64_t next = 0;
    for (uint32_t k = 0; k < count; k++) {
        uint32_t i = order[k].row;
        if (next != m->row_start[i]) {
            memmove(m->col + next, m->col + m->row_start[i], (size_t)m->row_count[i] * sizeof *m->col);
            memmove(m->val + next, m->val + m->row_start[i], (size_t)m->row_count[i] * sizeof *m->val);
        }
        m->row_start[i] = next;
        next += m->row_count[i];
    }
    free(order);
    m->nnz = next;
    uint64_t cap = bytes / ENTRY_BYTES > next ? bytes / ENTRY_BYTES : next;
    cap = cap ? cap : 1;
    return cap == m->capacity ? RAD_OK : resize_pool(m, cap, err);
}

uint64_t rad_matrix_estimate_bytes(uint32_t n, double fill)
{
    if (fill < 0.0)
        fill = 0.0;
    if (fill > 1.0)
        fill = 1.0;
    double entries = (double)n * (double)n * fill;
    double bytes = entries * (sizeof(uint32_t) + sizeof(float)) +
                   (double)n * (sizeof(uint64_t) + sizeof(uint32_t) + 1);
    return bytes >= 1.8e19 ? UINT64_MAX : (uint64_t)bytes;
}

int rad_matrix_check(const rad_matrix *m, rad_error *err)
{
    for (uint32_t i = 0; i < m->n; i++) {
        if (!m->row_done[i] || m->row_count[i] == 0)
            continue; /* an empty row may have no pool behind it */
        if (m->row_start[i] + m->row_count[i] > m->nnz)
            return rad_fail(err, RAD_ERR_CORRUPT, "form-factor row %u: entries out of range", i);
        const uint32_t *c = m->col + m->row_start[i];
        const float *v = m->val + m->row_start[i];
        double sum = 0.0;
        for (uint32_t k = 0; k < m->row_count[i]; k++) {
            if (c[k] >= m->n || c[k] == i || (k > 0 && c[k] <= c[k - 1]))
                return rad_fail(err, RAD_ERR_CORRUPT, "form-factor row %u: bad column %u", i, c[k]);
            if (!(v[k] > 0.0f) || !isfinite(v[k]))
                return rad_fail(err, RAD_ERR_CORRUPT, "form-factor row %u: bad F_ij %g", i,
                                (double)v[k]);
            sum += v[k];
        }
        if (sum > 1.0 + 1e-3)
            return rad_fail(err, RAD_ERR_CORRUPT, "form-factor row %u: row sum %.6f exceeds 1", i,
                            sum);
    }
    return RAD_OK;
}

