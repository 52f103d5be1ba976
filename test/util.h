/* util.h - helpers several tests share: a scene solved from polygon-file
 * text, and a dense direct solver for the references.  Static functions in
 * a header, like test.h: each test is one translation unit.
 */
#ifndef TEST_UTIL_H
#define TEST_UTIL_H

#include "../radiosity/pipeline/pipeline.h"
#include "test.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Row i of F decoded into arrays (F keeps its rows packed, rad.h); slot 0
 * or 1 holds two rows at once, each valid until the next call with that
 * slot.  Returns the entry count (0 for a missing row). */
static inline uint32_t test_row(const rad_matrix *F, uint32_t i, int slot, const uint32_t **col,
                                const float **val)
{
    static uint32_t *c[2];
    static float *v[2];
    static uint32_t cap[2];
    uint32_t need = F->row_count[i] + 1;
    if (need > cap[slot]) {
        uint32_t *nc = realloc(c[slot], need * sizeof *nc);
        float *nv = realloc(v[slot], need * sizeof *nv);
        if (nc)
            c[slot] = nc;
        if (nv)
            v[slot] = nv;
        if (!nc || !nv)
            abort(); /* a test machine out of memory: nothing sensible to check */
        cap[slot] = need;
    }
    uint32_t n = rad_matrix_get_row(F, i, c[slot], v[slot]);
    *col = c[slot];
    *val = v[slot];
    return n;
}

/* Row i of `from` copied into `to` (a need_rows source built on a full
 * reference matrix). */
static inline int test_copy_row(const rad_matrix *from, rad_matrix *to, uint32_t i,
                                rad_error *err)
{
    const uint32_t *col;
    const float *val;
    uint32_t cnt = test_row(from, i, 0, &col, &val);
    return rad_matrix_set_row(to, i, cnt, col, val, err);
}

/* A growing text buffer (NUL-terminated; free s), printf-style appends,
 * and base64 for glTF data URIs; abort on OOM. */
typedef struct test_text {
    char *s;
    size_t len, cap;
} test_text;

static inline void test_text_add(test_text *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0)
        abort();
    if (t->len + (size_t)n + 1 > t->cap) {
        size_t cap = (t->cap ? t->cap * 2 : 1024) + (size_t)n + 1;
        t->s = realloc(t->s, cap);
        if (!t->s)
            abort();
        t->cap = cap;
    }
    va_start(ap, fmt);
    vsnprintf(t->s + t->len, (size_t)n + 1, fmt, ap);
    va_end(ap);
    t->len += (size_t)n;
}

static inline void test_text_base64(test_text *t, const unsigned char *d, size_t n)
{
    static const char al[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t k = 0; k < n; k += 3) {
        uint32_t v = (uint32_t)d[k] << 16;
        if (k + 1 < n)
            v |= (uint32_t)d[k + 1] << 8;
        if (k + 2 < n)
            v |= d[k + 2];
        char q[5] = {al[v >> 18 & 63], al[v >> 12 & 63], k + 1 < n ? al[v >> 6 & 63] : '=',
                     k + 2 < n ? al[v & 63] : '=', 0};
        test_text_add(t, "%s", q);
    }
}

/* Parses polygon-file text (`name` in messages) and solves it as opt says
 * (NULL: defaults, but no elements: patches only); NULL, with the message
 * on stderr, on failure.  Caller owns the result. */
static inline rad_solution *test_solve_text(const char *text, const char *name,
                                            const rad_solve_options *opt)
{
    rad_scene *scene = NULL;
    rad_error err = {0};
    if (rad_scene_parse_polyfile(text, strlen(text), name, NULL, &scene, &err)) {
        fprintf(stderr, "  parse: %s\n", err.message);
        return NULL;
    }
    rad_solution *s = NULL;
    const rad_solve_options patches = {.refine_threshold = RAD_REFINE_OFF};
    if (rad_solve_scene(scene, opt ? opt : &patches, &s, &err)) {
        fprintf(stderr, "  solve: %s\n", err.message);
        return NULL;
    }
    return s;
}

/* Warning lines caught through rad_load_options.warn: the first 16 kept,
 * all counted. */
typedef struct test_warnings {
    char line[16][1024];
    int count;
} test_warnings;

static inline void test_catch_warning(void *user, const char *message)
{
    test_warnings *w = user;
    if (w->count < 16)
        snprintf(w->line[w->count], sizeof w->line[0], "%s", message);
    w->count++;
}

/* A whole file in memory with a NUL after its `*size` bytes; NULL when it
 * cannot be read.  Caller frees. */
static inline char *test_slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = n >= 0 ? malloc((size_t)n + 1) : NULL;
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    if (buf) {
        buf[n] = '\0';
        *size = (size_t)n;
    }
    return buf;
}

/* Where a version 6 solution file (docs/solution-format.md: the index's
 * offset at byte 16, then u32 count and 32-byte entries: tag, u32, u64
 * offset, u64 length, u64 CRC) holds section `tag`: its offset, and its
 * length in *len; 0 when the index does not list it. */
static inline size_t test_v6_section(const unsigned char *b, size_t size, const char *tag,
                                     uint64_t *len)
{
    uint64_t at = 0, count = 0;
    for (int k = 7; size >= 32 && k >= 0; k--)
        at = (at << 8) | b[16 + k];
    for (int k = 3; at >= 32 && at + 8 <= size && k >= 0; k--)
        count = (count << 8) | b[at + k];
    for (uint64_t q = 0; q < count && at + 8 + 32 * (q + 1) <= size; q++) {
        const unsigned char *e = b + at + 8 + 32 * q;
        if (memcmp(e, tag, 4) != 0)
            continue;
        uint64_t off = 0;
        *len = 0;
        for (int k = 7; k >= 0; k--) {
            off = (off << 8) | e[8 + k];
            *len = (*len << 8) | e[16 + k];
        }
        return (size_t)off;
    }
    return 0;
}

/* Solves A x = b in place by Gaussian elimination with partial pivoting:
 * A is n×n row-major and is destroyed, x holds b on entry and the solution
 * on return.  The independent reference for iterative solvers; small n. */
static inline void test_dense_solve(double *A, double *x, uint32_t n)
{
    for (uint32_t c = 0; c < n; c++) {
        uint32_t piv = c;
        for (uint32_t r = c + 1; r < n; r++)
            if (fabs(A[(size_t)r * n + c]) > fabs(A[(size_t)piv * n + c]))
                piv = r;
        if (piv != c) {
            for (uint32_t k = 0; k < n; k++) {
                double tmp = A[(size_t)c * n + k];
                A[(size_t)c * n + k] = A[(size_t)piv * n + k];
                A[(size_t)piv * n + k] = tmp;
            }
            double tmp = x[c];
            x[c] = x[piv];
            x[piv] = tmp;
        }
        for (uint32_t r = c + 1; r < n; r++) {
            double f = A[(size_t)r * n + c] / A[(size_t)c * n + c];
            if (f == 0.0)
                continue;
            for (uint32_t k = c; k < n; k++)
                A[(size_t)r * n + k] -= f * A[(size_t)c * n + k];
            x[r] -= f * x[c];
        }
    }
    for (uint32_t c = n; c-- > 0;) {
        double v = x[c];
        for (uint32_t k = c + 1; k < n; k++)
            v -= A[(size_t)c * n + k] * x[k];
        x[c] = v / A[(size_t)c * n + c];
    }
}

/* A material of reflectance rho in every band, no emission; its index. */
static inline uint32_t test_material(rad_scene *s, const char *name, double rho)
{
    double zero = 0.0;
    uint32_t m = RAD_NONE;
    rad_error e;
    int rc = rad_scene_add_material(s, name, &rho, &zero, NULL, NULL, &m, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    return m;
}

#endif /* TEST_UTIL_H */
