/* util.h - helpers several tests share: a scene solved from polygon-file
 * text, and a dense direct solver for the references.  Static functions in
 * a header, like test.h: each test is one translation unit.
 */
#ifndef TEST_UTIL_H
#define TEST_UTIL_H

#include "../radiosity/pipeline/pipeline.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Parses polygon-file text (`name` in messages) and solves it; NULL, with
 * the message on stderr, on failure.  Caller owns the result. */
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
    if (rad_solve_scene(scene, opt, &s, &err)) {
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

#endif /* TEST_UTIL_H */
