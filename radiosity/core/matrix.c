/* matrix.c - the sparse form-factor matrix of rad.h.
 *
 * The matrix keeps its rows in one growing pool (col/val); a row that is
 * set again is appended and the old copy abandoned, which only a relight of
 * a progressive solution can cause and which costs at most one extra row.
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

static int matrix_reserve(rad_matrix *m, uint64_t need, rad_error *err)
{
    if (need <= m->capacity)
        return RAD_OK;
    uint64_t cap = m->capacity ? m->capacity : 1024;
    while (cap < need)
        cap += cap / 2 + 1024; /* 1.5×: the pool can be most of memory */
    if (cap > SIZE_MAX / sizeof(uint32_t))
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: %llu entries do not fit in memory",
                        (unsigned long long)cap);
    uint32_t *col = realloc(m->col, (size_t)cap * sizeof *col);
    if (!col)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory at %llu entries",
                        (unsigned long long)cap);
    m->col = col;
    float *val = realloc(m->val, (size_t)cap * sizeof *val);
    if (!val)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory at %llu entries",
                        (unsigned long long)cap);
    m->val = val;
    m->capacity = cap;
    return RAD_OK;
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

