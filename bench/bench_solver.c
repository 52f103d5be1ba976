/* bench_solver.c - how long the solver takes, and how many sweeps or shots.
 *
 * Table 1: dense-ish random reciprocal systems (half the entries filled, 3
 * bands, A_i F_ij = A_j F_ji, the largest row summing to 1) at n = 500,
 * 2000, 8000: Gauss-Seidel and Jacobi with and without the Aitken step, and
 * progressive refinement, to the default tolerance 1e-4.
 * Table 2: closed rooms of 1000 patches (rows summing to 1) at ρ → 1, where the plain
 * iterations need ~1/(1-ρ) sweeps: the full "every patch sees every patch"
 * enclosure and a slowly mixing ring, with and without the Aitken step.
 * Each row also gives the true error against a reference solved to 1e-10.
 * Timings are wall-clock, one run each; nothing here asserts anything.
 */
#include "../solver/solver.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Deterministic value for an unordered pair: symmetric G without storing it. */
static double pair_hash(uint32_t i, uint32_t j, uint64_t seed)
{
    uint64_t a = i < j ? i : j, b = i < j ? j : i;
    uint64_t z = seed + a * 0x9e3779b97f4a7c15ull + b * 0xc2b2ae3d27d4eb4full;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static double unit(uint64_t k) { return pair_hash((uint32_t)k, (uint32_t)(k >> 32) + 7u, 99); }

typedef struct bsys {
    sv_system s;
    double *A, *rho, *E;
} bsys;

static void bsys_free(bsys *b)
{
    rad_matrix_destroy(b->s.F);
    free(b->A);
    free(b->rho);
    free(b->E);
}

static bsys bsys_alloc(uint32_t n, uint32_t nb)
{
    bsys b;
    b.A = malloc(n * sizeof *b.A);
    b.rho = malloc((size_t)n * nb * sizeof *b.rho);
    b.E = calloc((size_t)n * nb, sizeof *b.E);
    b.s = (sv_system){.n = n, .bands = nb, .F = rad_matrix_create(n), .area = b.A, .rho = b.rho, .emission = b.E};
    return b;
}

/* G_ij = G_ji = h(i,j) when h'(i,j) < fill; F_ij = s G_ij / A_i, s fixed by
 * the largest row sum being 1.  ρ per band in [0.3,0.5], [0.5,0.7], [0.7,0.9];
 * 1 % of the patches emit. */
static bsys random_system(uint32_t n, double fill)
{
    bsys b = bsys_alloc(n, 3);
    for (uint32_t i = 0; i < n; i++) {
        b.A[i] = 0.5 + 1.5 * unit(i);
        for (uint32_t c = 0; c < 3; c++) {
            b.rho[3 * i + c] = 0.3 + 0.2 * c + 0.2 * unit((uint64_t)i << 8 | c);
            b.E[3 * i + c] = i % 100 == 0 ? 1.0 + c : 0.0;
        }
    }
    double maxsum = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        double s = 0.0;
        for (uint32_t j = 0; j < n; j++)
            if (j != i && pair_hash(i, j, 1) < fill)
                s += pair_hash(i, j, 2);
        if (s / b.A[i] > maxsum)
            maxsum = s / b.A[i];
    }
    uint32_t *col = malloc(n * sizeof *col);
    float *val = malloc(n * sizeof *val);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t c = 0;
        for (uint32_t j = 0; j < n; j++)
            if (j != i && pair_hash(i, j, 1) < fill) {
                col[c] = j;
                val[c++] = (float)(pair_hash(i, j, 2) / (maxsum * b.A[i]));
            }
        rad_matrix_set_row(b.s.F, i, c, col, val, NULL);
    }
    free(col);
    free(val);
    return b;
}

/* Every patch sees every other: F_ij = A_j / Σ_{k≠i} A_k; uniform ρ, E. */
static bsys full_enclosure(uint32_t n, double rho)
{
    bsys b = bsys_alloc(n, 3);
    double S = 0.0;
    for (uint32_t i = 0; i < n; i++)
        S += b.A[i] = 0.5 + 2.0 * unit(i);
    uint32_t *col = malloc(n * sizeof *col);
    float *val = malloc(n * sizeof *val);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t c = 0;
        for (uint32_t j = 0; j < n; j++)
            if (j != i) {
                col[c] = j;
                val[c++] = (float)(b.A[j] / (S - b.A[i]));
            }
        rad_matrix_set_row(b.s.F, i, c, col, val, NULL);
        for (uint32_t k = 0; k < 3; k++) {
            b.rho[3 * i + k] = rho;
            b.E[3 * i + k] = i < 10 ? 1.0 : 0.0;
        }
    }
    free(col);
    free(val);
    return b;
}

/* A closed ring: patch i sees its neighbours within 3w, K_ij = exp(-d/w),
 * scaled symmetrically (d_i Σ_j K_ij d_j = A_i) so that rows sum to 1 and
 * F is reciprocal.  Light crosses the ring slowly: many slow modes. */
static bsys ring_enclosure(uint32_t n, uint32_t w, double rho)
{
    bsys b = bsys_alloc(n, 3);
    uint32_t span = 3 * w, m = 2 * span;
    double *d = malloc(n * sizeof *d);
    for (uint32_t i = 0; i < n; i++) {
        b.A[i] = 0.5 + 1.5 * unit(i);
        d[i] = 1.0;
    }
    /* K_i,i+o for o = -span..span (skipping 0), o-th neighbour around the ring */
#define RING_J(i, k) \
    ((uint32_t)(((int64_t)(i) + n + ((k) < span ? (int64_t)(k) - span : (int64_t)(k) - span + 1)) % n))
#define RING_K(i, k) (exp(-(double)((k) < span ? span - (k) : (k) - span + 1) / w) * \
                      (0.5 + pair_hash((i), RING_J(i, k), 3)))
    for (int it = 0; it < 100000; it++) {
        double worst = 0.0;
        for (uint32_t i = 0; i < n; i++) {
            double kd = 0.0;
            for (uint32_t k = 0; k < m; k++)
                kd += RING_K(i, k) * d[RING_J(i, k)];
            double r = d[i] * kd / b.A[i];
            if (fabs(r - 1.0) > worst)
                worst = fabs(r - 1.0);
            d[i] /= sqrt(r);
        }
        if (worst < 1e-13)
            break;
    }
    uint32_t *col = malloc(m * sizeof *col);
    float *val = malloc(m * sizeof *val);
    for (uint32_t i = 0; i < n; i++) {
        /* columns must increase: collect, then insertion-sort the few of them */
        for (uint32_t k = 0; k < m; k++) {
            col[k] = RING_J(i, k);
            val[k] = (float)(d[i] * RING_K(i, k) * d[col[k]] / b.A[i]);
        }
        for (uint32_t k = 1; k < m; k++)
            for (uint32_t q = k; q > 0 && col[q - 1] > col[q]; q--) {
                uint32_t tc = col[q];
                col[q] = col[q - 1];
                col[q - 1] = tc;
                float tv = val[q];
                val[q] = val[q - 1];
                val[q - 1] = tv;
            }
        rad_matrix_set_row(b.s.F, i, m, col, val, NULL);
        for (uint32_t k = 0; k < 3; k++) {
            b.rho[3 * i + k] = rho * (1.0 - 0.02 * k);
            b.E[3 * i + k] = i < 3 ? 5.0 : 0.0;
        }
    }
#undef RING_J
#undef RING_K
    free(col);
    free(val);
    free(d);
    return b;
}

static double rel_diff(const double *a, const double *b, size_t len)
{
    double num = 0.0, den = 0.0;
    for (size_t k = 0; k < len; k++) {
        if (fabs(a[k] - b[k]) > num)
            num = fabs(a[k] - b[k]);
        if (fabs(b[k]) > den)
            den = fabs(b[k]);
    }
    return den > 0.0 ? num / den : num;
}

typedef struct run {
    sv_stats st;
    double seconds, error;
} run;

static run run_one(const bsys *b, sv_method m, int plain, const double *ref, double *B)
{
    sv_options o = {.method = m, .no_acceleration = plain, .max_iterations = 200000};
    run r = {0};
    rad_error err;
    double t0 = rad_seconds();
    if (sv_solve(&b->s, &o, B, &r.st, &err) != RAD_OK)
        fprintf(stderr, "bench_solver: %s\n", err.message);
    r.seconds = rad_seconds() - t0;
    r.error = ref ? rel_diff(B, ref, (size_t)b->s.n * b->s.bands) : NAN;
    return r;
}

/* Reference: accelerated Gauss-Seidel to 1e-10, well below the 1e-4 runs
 * (the method itself is checked against dense elimination in the tests). */
static void reference(const bsys *b, double *ref)
{
    sv_options o = {.method = SV_GAUSS_SEIDEL, .tolerance = 1e-10, .max_iterations = 200000};
    rad_error err;
    if (sv_solve(&b->s, &o, ref, NULL, &err) != RAD_OK)
        fprintf(stderr, "bench_solver: %s\n", err.message);
}

static void print_run(const char *what, uint32_t n, const char *method, const run *r)
{
    printf("%-10s %6u  %-18s %8u%c %6u %9.3f %9.2e %9.2e %8.5f\n", what, n, method,
           r->st.iterations, r->st.converged ? ' ' : '!', r->st.extrapolations, r->seconds,
           r->error, r->st.residual, r->st.contraction);
    fflush(stdout);
}

static void header(const char *title)
{
    printf("\n%s\n", title);
    printf("%-10s %6s  %-18s %9s %6s %9s %9s %9s %8s\n", "system", "n", "method", "iter",
           "aitken", "seconds", "error", "residual", "q");
}

int main(int argc, char **argv)
{
    uint32_t sizes[3] = {500, 2000, 8000};
    int count = 3;
    if (argc > 1 && strcmp(argv[1], "--quick") == 0)
        count = 2;

    header("random reciprocal systems, 50 % filled, 3 bands, tolerance 1e-4 "
           "(iter = sweeps or shots, ! = stopped by the limit)");
    for (int k = 0; k < count; k++) {
        uint32_t n = sizes[k];
        double t0 = rad_seconds();
        bsys b = random_system(n, 0.5);
        double build = rad_seconds() - t0;
        size_t len = (size_t)n * 3;
        double *ref = malloc(len * sizeof *ref), *B = malloc(len * sizeof *B);
        reference(&b, ref);
        printf("# n = %u: %llu entries (%.0f MB), built in %.2f s\n", n,
               (unsigned long long)b.s.F->nnz, b.s.F->nnz * 8.0 / 1e6, build);
        run r = run_one(&b, SV_GAUSS_SEIDEL, 0, ref, B);
        print_run("random", n, "gauss-seidel", &r);
        r = run_one(&b, SV_GAUSS_SEIDEL, 1, ref, B);
        print_run("random", n, "gauss-seidel plain", &r);
        r = run_one(&b, SV_JACOBI, 0, ref, B);
        print_run("random", n, "jacobi", &r);
        r = run_one(&b, SV_JACOBI, 1, ref, B);
        print_run("random", n, "jacobi plain", &r);
        r = run_one(&b, SV_PROGRESSIVE, 0, ref, B);
        print_run("random", n, "progressive", &r);
        free(ref);
        free(B);
        bsys_free(&b);
    }

    header("closed rooms (rows sum to 1), 3 bands, tolerance 1e-4");
    double rhos[3] = {0.9, 0.99, 0.999};
    for (int kind = 0; kind < 2; kind++)
        for (int k = 0; k < 3; k++) {
            uint32_t n = 1000;
            bsys b = kind == 0 ? full_enclosure(n, rhos[k]) : ring_enclosure(n, 20, rhos[k]);
            size_t len = (size_t)n * 3;
            double *ref = malloc(len * sizeof *ref), *B = malloc(len * sizeof *B);
            reference(&b, ref);
            char what[32];
            snprintf(what, sizeof what, "%s %g", kind == 0 ? "full" : "ring", rhos[k]);
            static const char *names[4] = {"gauss-seidel", "gauss-seidel plain", "jacobi",
                                           "jacobi plain"};
            for (int v = 0; v < 4; v++) {
                run r = run_one(&b, v < 2 ? SV_GAUSS_SEIDEL : SV_JACOBI, v & 1, ref, B);
                print_run(what, n, names[v], &r);
            }
            run r = run_one(&b, SV_PROGRESSIVE, 0, ref, B);
            print_run(what, n, "progressive", &r);
            free(ref);
            free(B);
            bsys_free(&b);
        }
    return 0;
}
