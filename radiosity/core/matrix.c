/* matrix.c - the sparse form-factor matrix of rad.h, its rows packed as
 * records in one pool.
 *
 * The pool holds row records exactly as a solution file stores them (u32 i,
 * u32 c, c × f32, c varint column gaps), so a reader can read a file's rows
 * straight into it and a solve can hand each new record to a sink that
 * appends it to a file.  A row that is set again is appended and the old
 * copy abandoned (a relight of a progressive solution can cause it, and
 * so can a bounded row store computing a dropped row again), until
 * rad_matrix_compact moves the records present together again.
 *
 * Invariant: rows present obey rad.h's row rules.  Records that come from
 * outside (rad_matrix_add_records) are checked one by one before any is
 * indexed; records this file encodes come from checked arrays.  So the
 * unchecked walk (rad_row_next) never leaves a record.
 */
#include "rad.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The pool's floats are the little-endian bit patterns of the file format,
 * read with memcpy: a big-endian machine would need a byte swap here. */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "the packed form-factor rows assume a little-endian machine"
#endif

/* Largest row sum accepted: Σ_j F_ij <= 1 plus the hemi-cube's discretisation error. */
#define ROW_SUM_MAX (1.0 + 1e-3)
#define RECORD_HEAD 8u /* u32 i, u32 c */

rad_matrix *rad_matrix_create(uint32_t n)
{
    rad_matrix *m = calloc(1, sizeof *m);
    if (!m)
        return NULL;
    m->n = n;
    m->entries_loaded = 1;
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
    free(m->data);
    free(m);
}

void rad_matrix_release_entries(rad_matrix *m)
{
    if (!m)
        return;
    free(m->data);
    m->data = NULL;
    m->bytes = m->capacity = 0;
    memset(m->row_start, 0, (m->n ? m->n : 1) * sizeof *m->row_start);
    m->entries_loaded = 0;
}

uint8_t *rad_matrix_reserve(rad_matrix *m, uint64_t more, rad_error *err)
{
    if (more > UINT64_MAX - m->bytes || m->bytes + more > SIZE_MAX)
        return rad_fail(err, RAD_ERR_LIMIT, "form-factor matrix: %llu bytes do not fit in memory",
                        (unsigned long long)more), NULL;
    uint64_t need = m->bytes + more;
    /* An empty pool is allocated too (a request for 0 bytes included):
     * the caller gets a pointer into memory, never NULL + 0 (found by
     * fuzz_solution: a MATRIX section of no rows). */
    if (need > m->capacity || !m->data) {
        /* 1.5× steps while rows trickle in (the pool can be most of memory;
         * glibc grows large blocks by remapping, not copying), exact when a
         * reader asks for a whole file's rows at once. */
        uint64_t cap = m->capacity + m->capacity / 2 + 65536;
        if (cap < need || cap > SIZE_MAX)
            cap = need;
        uint8_t *d = realloc(m->data, (size_t)cap);
        if (!d)
            return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory at %llu bytes",
                            (unsigned long long)cap), NULL;
        m->data = d;
        m->capacity = cap;
    }
    return m->data + m->bytes;
}

size_t rad_varint_put(uint8_t out[5], uint32_t v)
{
    size_t n = 0;
    do {
        uint8_t byte = v & 0x7f;
        v >>= 7;
        out[n++] = v ? (uint8_t)(byte | 0x80) : byte;
    } while (v);
    return n;
}

static void put_u32(uint8_t *p, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        p[k] = (uint8_t)(v >> (8 * k));
}

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void index_row(rad_matrix *m, uint32_t i, uint32_t count, uint64_t values_at)
{
    if (m->row_done[i])
        m->nnz -= m->row_count[i];
    else
        m->rows_done++;
    m->row_done[i] = 1;
    m->row_start[i] = values_at;
    m->row_count[i] = count;
    m->nnz += count;
}

int rad_matrix_set_row(rad_matrix *m, uint32_t i, uint32_t count, const uint32_t *col,
                       const float *val, rad_error *err)
{
    if (!m || i >= m->n || (count && (!col || !val)) || !m->entries_loaded)
        return rad_fail(err, RAD_ERR_USAGE, "form-factor matrix: bad row %u", i);
    rad_error local, *e = err ? err : &local;
    uint8_t *p = rad_matrix_reserve(m, rad_matrix_row_bytes(count), e);
    if (!p)
        return e->code;
    put_u32(p, i);
    put_u32(p + 4, count);
    size_t at = RECORD_HEAD;
    if (count) {
        memcpy(p + at, val, (size_t)count * sizeof *val);
        at += 4 * (size_t)count;
        for (uint32_t k = 0; k < count; k++)
            at += rad_varint_put(p + at, k ? col[k] - col[k - 1] : col[0]);
    }
    uint64_t record = m->bytes;
    m->bytes += at;
    index_row(m, i, count, record + RECORD_HEAD);
    return m->sink ? m->sink(m->sink_user, i, m->data + record, at, err) : RAD_OK;
}

uint32_t rad_matrix_get_row(const rad_matrix *m, uint32_t i, uint32_t *col, float *val)
{
    rad_row r = rad_matrix_row(m, i);
    const uint8_t *p = r.col;
    uint32_t j = 0;
    for (uint32_t k = 0; k < r.count; k++) {
        j = rad_row_next(&p, j);
        if (col)
            col[k] = j;
    }
    if (val && r.count)
        memcpy(val, r.val, 4 * (size_t)r.count);
    return r.count;
}

double rad_matrix_row_sum(const rad_matrix *m, uint32_t i)
{
    if (!m || i >= m->n)
        return 0.0;
    rad_row r = rad_matrix_row(m, i);
    double s = 0.0;
    for (uint32_t k = 0; k < r.count; k++)
        s += rad_row_value(&r, k);
    return s;
}

uint64_t rad_matrix_record_bytes(const rad_matrix *m, uint32_t i)
{
    if (!m->row_done[i])
        return 0;
    rad_row r = rad_matrix_row(m, i);
    const uint8_t *p = r.col;
    for (uint32_t k = 0; k < r.count; k++)
        while (*p++ & 0x80)
            ;
    return RECORD_HEAD + (r.count ? (uint64_t)(p - r.val) : 0);
}

/* One record at p (len bytes left) checked against the row rules; its
 * total size into *size.  `seen` marks rows met earlier in the same call. */
static int check_record(const rad_matrix *m, const uint8_t *p, uint64_t len, const uint8_t *seen,
                        uint64_t *size, rad_error *err)
{
    if (len < RECORD_HEAD)
        return rad_fail(err, RAD_ERR_CORRUPT, "record truncated (%llu bytes)",
                        (unsigned long long)len);
    uint32_t i = get_u32(p), c = get_u32(p + 4);
    if (i >= m->n)
        return rad_fail(err, RAD_ERR_CORRUPT, "row %u out of range (n = %u)", i, m->n);
    if (m->row_done[i] || seen[i])
        return rad_fail(err, RAD_ERR_CORRUPT, "row %u appears twice", i);
    if (c > m->n - 1)
        return rad_fail(err, RAD_ERR_CORRUPT, "row %u: %u entries but n = %u", i, c, m->n);
    /* each entry takes at least 5 bytes: bound the count before reading */
    if ((uint64_t)c * 5 > len - RECORD_HEAD)
        return rad_fail(err, RAD_ERR_CORRUPT, "row %u: %u entries cannot fit in %llu bytes", i, c,
                        (unsigned long long)(len - RECORD_HEAD));
    const uint8_t *val = p + RECORD_HEAD, *q = val + 4 * (size_t)c, *end = p + len;
    double sum = 0.0;
    uint64_t j = 0;
    for (uint32_t k = 0; k < c; k++) {
        /* LEB128 of a u32: at most 5 bytes, no bits above 32, no padding */
        uint64_t d = 0;
        int s = 0;
        for (;;) {
            if (q >= end || s > 28)
                return rad_fail(err, RAD_ERR_CORRUPT,
                                "row %u: entry %u: truncated or malformed column", i, k);
            uint8_t b = *q++;
            d |= (uint64_t)(b & 0x7f) << s;
            if (!(b & 0x80)) {
                if ((s > 0 && b == 0) || d > UINT32_MAX)
                    return rad_fail(err, RAD_ERR_CORRUPT,
                                    "row %u: entry %u: truncated or malformed column", i, k);
                break;
            }
            s += 7;
        }
        if (k > 0 && d == 0)
            return rad_fail(err, RAD_ERR_CORRUPT, "row %u: column %llu repeated", i,
                            (unsigned long long)j);
        j = k ? j + d : d;
        if (j >= m->n)
            return rad_fail(err, RAD_ERR_CORRUPT, "row %u: column %llu out of range (n = %u)", i,
                            (unsigned long long)j, m->n);
        if (j == i)
            return rad_fail(err, RAD_ERR_CORRUPT,
                            "row %u: entry on its own patch (F of a planar patch to itself is 0)",
                            i);
        float f;
        memcpy(&f, val + 4 * (size_t)k, sizeof f);
        if (!(f > 0.0f) || !isfinite(f))
            return rad_fail(err, RAD_ERR_CORRUPT, "row %u: F_%u,%llu = %g is not positive and finite",
                            i, i, (unsigned long long)j, (double)f);
        sum += f;
    }
    if (sum > ROW_SUM_MAX)
        return rad_fail(err, RAD_ERR_CORRUPT, "row %u: Σ_j F_ij = %.6f exceeds 1", i, sum);
    *size = (uint64_t)(q - p);
    return RAD_OK;
}

int rad_matrix_add_records(rad_matrix *m, uint64_t len, uint64_t rows, uint64_t *at,
                           rad_error *err)
{
    if (!m || !m->entries_loaded || len > m->capacity - m->bytes)
        return rad_fail(err, RAD_ERR_USAGE, "form-factor matrix: records outside the pool");
    uint8_t *seen = calloc(m->n ? m->n : 1, 1);
    if (!seen)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory");
    const uint8_t *base = m->data + m->bytes;
    uint64_t off = 0, count = 0;
    int rc = RAD_OK;
    while (off < len) {
        uint64_t size = 0;
        rc = check_record(m, base + off, len - off, seen, &size, err);
        if (rc) {
            if (at)
                *at = off;
            break;
        }
        seen[get_u32(base + off)] = 1;
        off += size;
        count++;
    }
    free(seen);
    if (!rc && count != rows) {
        rc = rad_fail(err, RAD_ERR_CORRUPT, "%llu rows announced, %llu found",
                      (unsigned long long)rows, (unsigned long long)count);
        if (at)
            *at = 0;
    }
    if (rc)
        return rc;
    /* all good: index them */
    for (off = 0; off < len;) {
        uint32_t i = get_u32(base + off), c = get_u32(base + off + 4);
        index_row(m, i, c, m->bytes + off + RECORD_HEAD);
        rad_row r = rad_matrix_row(m, i);
        const uint8_t *q = r.col;
        for (uint32_t k = 0; k < c; k++)
            while (*q++ & 0x80)
                ;
        off += RECORD_HEAD + (c ? (uint64_t)(q - r.val) : 0);
    }
    m->bytes += len;
    return RAD_OK;
}

/* A gap between visible patches of 1/fill on average, as a varint. */
static double entry_bytes(double fill)
{
    double gap = fill > 0.0 ? 1.0 / fill : 1.0;
    return 4.0 + (gap < 128.0 ? 1.0 : gap < 16384.0 ? 2.0 : 3.0);
}

/* ---- a bounded row store: dropping rows, compacting the pool ---- */

uint64_t rad_matrix_pool_bytes(const rad_matrix *m) { return m->capacity; }

uint64_t rad_matrix_used_bytes(const rad_matrix *m) { return m->bytes; }

/* A record at most: its head, 4 bytes a value, 5 a varint gap. */
uint64_t rad_matrix_row_bytes(uint32_t count) { return RECORD_HEAD + (uint64_t)count * 9u; }

uint64_t rad_matrix_index_bytes(uint32_t n)
{
    return (uint64_t)n * (sizeof(uint64_t) + sizeof(uint32_t) + 1);
}

uint64_t rad_matrix_live_bytes(const rad_matrix *m)
{
    uint64_t bytes = 0;
    for (uint32_t i = 0; i < m->n; i++)
        bytes += rad_matrix_record_bytes(m, i);
    return bytes;
}

void rad_matrix_drop_row(rad_matrix *m, uint32_t i)
{
    if (!m || i >= m->n || !m->row_done[i])
        return;
    m->nnz -= m->row_count[i];
    m->row_done[i] = 0;
    m->row_count[i] = 0;
    m->row_start[i] = 0;
    m->rows_done--;
}

/* A present row's record: where it starts in the pool and its size. */
typedef struct placed {
    uint64_t start, size;
    uint32_t row;
} placed;

static int by_start(const void *a, const void *b)
{
    uint64_t x = ((const placed *)a)->start, y = ((const placed *)b)->start;
    return x < y ? -1 : x > y;
}

int rad_matrix_compact(rad_matrix *m, uint64_t bytes, rad_error *err)
{
    /* The records present, in order of their place in the pool: each then
     * moves towards the front, never over a record not yet moved, so the
     * compaction needs no second pool (a bounded store has no room for
     * one). */
    placed *order = malloc(((size_t)m->rows_done + 1) * sizeof *order);
    uint32_t count = 0;
    if (!order)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory compacting");
    for (uint32_t i = 0; i < m->n; i++)
        if (m->row_done[i])
            order[count++] =
                (placed){m->row_start[i] - RECORD_HEAD, rad_matrix_record_bytes(m, i), i};
    qsort(order, count, sizeof *order, by_start);
    uint64_t next = 0;
    for (uint32_t k = 0; k < count; k++) {
        if (next != order[k].start)
            memmove(m->data + next, m->data + order[k].start, (size_t)order[k].size);
        m->row_start[order[k].row] = next + RECORD_HEAD;
        next += order[k].size;
    }
    free(order);
    m->bytes = next;
    uint64_t cap = bytes > next ? bytes : next;
    if (cap == m->capacity || cap == 0)
        return RAD_OK;
    if (cap > SIZE_MAX)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: %llu bytes do not fit in memory",
                        (unsigned long long)cap);
    uint8_t *d = realloc(m->data, (size_t)cap);
    if (!d)
        return rad_fail(err, RAD_ERR_NOMEM, "form-factor matrix: out of memory at %llu bytes",
                        (unsigned long long)cap);
    m->data = d;
    m->capacity = cap;
    return RAD_OK;
}

uint64_t rad_matrix_estimate_bytes(uint32_t n, double fill)
{
    if (fill < 0.0)
        fill = 0.0;
    if (fill > 1.0)
        fill = 1.0;
    double entries = (double)n * (double)n * fill;
    double bytes = entries * entry_bytes(fill) +
                   (double)n * RECORD_HEAD + (double)rad_matrix_index_bytes(n);
    return bytes >= 1.8e19 ? UINT64_MAX : (uint64_t)bytes;
}

int rad_matrix_check(const rad_matrix *m, rad_error *err)
{
    if (!m->entries_loaded)
        return RAD_OK; /* nothing but counts to check */
    for (uint32_t i = 0; i < m->n; i++) {
        if (!m->row_done[i] || m->row_count[i] == 0)
            continue;
        uint64_t rec = m->row_start[i] - RECORD_HEAD;
        if (m->row_start[i] < RECORD_HEAD || m->row_start[i] > m->bytes ||
            get_u32(m->data + rec) != i || get_u32(m->data + rec + 4) != m->row_count[i])
            return rad_fail(err, RAD_ERR_CORRUPT, "form-factor row %u: entries out of range", i);
        rad_row r = rad_matrix_row(m, i);
        const uint8_t *p = r.col;
        uint32_t j = 0;
        double sum = 0.0;
        for (uint32_t k = 0; k < r.count; k++) {
            uint32_t prev = j;
            j = rad_row_next(&p, j);
            float f = rad_row_value(&r, k);
            if (j >= m->n || j == i || (k > 0 && j <= prev))
                return rad_fail(err, RAD_ERR_CORRUPT, "form-factor row %u: bad column %u", i, j);
            if (!(f > 0.0f) || !isfinite(f))
                return rad_fail(err, RAD_ERR_CORRUPT, "form-factor row %u: bad F_ij %g", i,
                                (double)f);
            sum += f;
        }
        if (sum > ROW_SUM_MAX)
            return rad_fail(err, RAD_ERR_CORRUPT, "form-factor row %u: row sum %.6f exceeds 1", i,
                            sum);
    }
    return RAD_OK;
}
