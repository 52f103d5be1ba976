/* mc_vs3.c - reference factors for a .vs3 file by Monte Carlo ray casting,
 * independent of the hemi-cube: from points spread uniformly over each
 * surface (jittered on a grid over parallelograms), cosine-distributed rays (stratified on a G×G grid per point) are
 * traced against every polygon; a ray whose first hit is the front of
 * surface j counts towards F_ij, a back side or nothing towards no one.
 *
 *   mc_vs3 FILE.vs3 POINTS_PER_BATCH BATCHES SEED
 *
 * prints, for the surfaces View3D reports (combined ones summed, area
 * weighted), F_ij, or with emit=1 Hottel's script-F from a dense solve of
 * (I − ρF) B = ε e_i, as "from,to,value,stderr": the mean over the batches
 * and its standard error (batch spread / sqrt(batches)).  Masks and null
 * surfaces are refused (the tests do not use them).  Run by hand; its
 * output is shipped in test/data/view3d/ and never recomputed by the tests.
 */
#include "../radiosity/scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define GRID 16

static uint64_t rng_state;
static double rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

/* First polygon hit by the ray (o, d) beyond t > tmin: its object when
 * its front faces the ray, else RAD_NONE. */
static uint32_t trace(const rad_scene *s, rad_vec3 o, rad_vec3 d, double tmin)
{
    double best = INFINITY;
    uint32_t hit = RAD_NONE;
    for (uint32_t p = 0; p < s->polygon_count; p++) {
        const rad_polygon *P = &s->polygons[p];
        const rad_vec3 *v = s->points + P->first_point;
        double dn = rad_dot(d, P->normal);
        if (fabs(dn) < 1e-14)
            continue;
        double t = rad_dot(rad_sub(v[0], o), P->normal) / dn;
        if (t <= tmin || t >= best)
            continue;
        rad_vec3 x = rad_add(o, rad_scale(d, t));
        int inside = 1;
        for (uint32_t k = 0; k < P->point_count && inside; k++) {
            rad_vec3 a = v[k], b = v[(k + 1) % P->point_count];
            inside = rad_dot(rad_cross(rad_sub(b, a), rad_sub(x, a)), P->normal) >= 0;
        }
        if (inside) {
            best = t;
            hit = dn < 0 ? P->object : RAD_NONE;
        }
    }
    return hit;
}

/* A uniform point on polygon p: in cell (q mod k, q / k) of a k×k grid
 * when p is a parallelogram (stratified), else fan triangles chosen by area. */
static rad_vec3 sample_polygon(const rad_scene *s, const rad_polygon *P, uint32_t q, uint32_t k)
{
    const rad_vec3 *v = s->points + P->first_point;
    if (P->point_count == 4 &&
        rad_length(rad_sub(rad_add(v[0], v[2]), rad_add(v[1], v[3]))) < 1e-12 * sqrt(P->area)) {
        double a = (q % k + rnd()) / k, b = (q / k + rnd()) / k;
        return rad_add(v[0], rad_add(rad_scale(rad_sub(v[1], v[0]), a), rad_scale(rad_sub(v[3], v[0]), b)));
    }
    double pick = rnd() * P->area, acc = 0;
    k = 1;
    for (; k + 1 < P->point_count; k++) {
        acc += 0.5 * rad_length(rad_cross(rad_sub(v[k], v[0]), rad_sub(v[k + 1], v[0])));
        if (pick <= acc)
            break;
    }
    if (k + 1 >= P->point_count)
        k = P->point_count - 2;
    double a = rnd(), b = rnd();
    if (a + b > 1) {
        a = 1 - a;
        b = 1 - b;
    }
    return rad_add(v[0], rad_add(rad_scale(rad_sub(v[k], v[0]), a), rad_scale(rad_sub(v[k + 1], v[0]), b)));
}

/* One batch: counts[i][j] += rays from object i's points first hitting j. */
static void batch(const rad_scene *s, uint32_t points, double tmin, double *F)
{
    uint32_t no = s->object_count;
    double *oarea = calloc(no, sizeof *oarea);
    for (uint32_t p = 0; p < s->polygon_count; p++)
        oarea[s->polygons[p].object] += s->polygons[p].area;
    for (uint32_t p = 0; p < s->polygon_count; p++) {
        const rad_polygon *P = &s->polygons[p];
        uint32_t i = P->object;
        /* this polygon's share of its object's points */
        uint32_t g = (uint32_t)ceil(sqrt(points * P->area / oarea[i])), np = g * g;
        rad_vec3 n = P->normal, t1 = rad_normalize(rad_cross(fabs(n.x) < 0.9 ? rad_v3(1, 0, 0) : rad_v3(0, 1, 0), n));
        rad_vec3 t2 = rad_cross(n, t1);
        double w = P->area / oarea[i] / ((double)np * GRID * GRID);
        for (uint32_t q = 0; q < np; q++) {
            rad_vec3 o = sample_polygon(s, P, q, g);
            for (int gu = 0; gu < GRID; gu++)
                for (int gv = 0; gv < GRID; gv++) {
                    double u = (gu + rnd()) / GRID, phi = 2 * M_PI * (gv + rnd()) / GRID;
                    double r = sqrt(u), z = sqrt(1 - u);
                    rad_vec3 d = rad_add(rad_scale(n, z), rad_add(rad_scale(t1, r * cos(phi)), rad_scale(t2, r * sin(phi))));
                    uint32_t j = trace(s, o, d, tmin);
                    if (j != RAD_NONE)
                        F[(size_t)i * no + j] += w;
                }
        }
    }
    free(oarea);
}

/* Solves A x = b (n×n, dense, partial pivoting); A and b are overwritten. */
static void gauss(double *A, double *b, uint32_t n)
{
    for (uint32_t c = 0; c < n; c++) {
        uint32_t p = c;
        for (uint32_t r = c + 1; r < n; r++)
            if (fabs(A[r * n + c]) > fabs(A[p * n + c]))
                p = r;
        for (uint32_t k = 0; k < n; k++) {
            double t = A[c * n + k];
            A[c * n + k] = A[p * n + k];
            A[p * n + k] = t;
        }
        double t = b[c];
        b[c] = b[p];
        b[p] = t;
        for (uint32_t r = c + 1; r < n; r++) {
            double f = A[r * n + c] / A[c * n + c];
            for (uint32_t k = c; k < n; k++)
                A[r * n + k] -= f * A[c * n + k];
            b[r] -= f * b[c];
        }
    }
    for (uint32_t c = n; c-- > 0;) {
        for (uint32_t k = c + 1; k < n; k++)
            b[c] -= A[c * n + k] * b[k];
        b[c] /= A[c * n + c];
    }
}

/* Object factors F (no×no) -> reported factors R (n×n), script-F if emit. */
static void reported(const rad_scene *s, const rad_vs3 *m, const double *F, const uint32_t *to,
                     uint32_t n, double *R)
{
    uint32_t no = s->object_count;
    double *a = calloc(n, sizeof *a), *e = calloc(n, sizeof *e), *oa = calloc(no, sizeof *oa);
    for (uint32_t p = 0; p < s->polygon_count; p++)
        oa[s->polygons[p].object] += s->polygons[p].area;
    memset(R, 0, (size_t)n * n * sizeof *R);
    for (uint32_t i = 0; i < m->surface_count; i++) {
        if (to[i] == RAD_NONE)
            continue;
        uint32_t oi = m->surfaces[i].object;
        a[to[i]] += oa[oi];
        e[to[i]] += oa[oi] * m->surfaces[i].emittance;
        for (uint32_t j = 0; j < m->surface_count; j++)
            if (to[j] != RAD_NONE)
                R[to[i] * n + to[j]] += oa[oi] * F[(size_t)oi * no + m->surfaces[j].object];
    }
    for (uint32_t i = 0; i < n; i++) {
        e[i] /= a[i];
        for (uint32_t j = 0; j < n; j++)
            R[i * n + j] /= a[i];
    }
    if (m->emit) {
        double *A = malloc((size_t)n * n * sizeof *A), *B = malloc(n * sizeof *B);
        double *S = malloc((size_t)n * n * sizeof *S);
        for (uint32_t i = 0; i < n; i++) {
            for (uint32_t r = 0; r < n; r++) {
                for (uint32_t c = 0; c < n; c++)
                    A[r * n + c] = (r == c) - (1 - e[r]) * R[r * n + c];
                B[r] = r == i ? e[i] : 0;
            }
            gauss(A, B, n);
            for (uint32_t j = 0; j < n; j++) {
                double H = 0;
                for (uint32_t k = 0; k < n; k++)
                    H += R[j * n + k] * B[k];
                S[i * n + j] = e[j] * a[j] * H / a[i];
            }
        }
        memcpy(R, S, (size_t)n * n * sizeof *R);
        free(A);
        free(B);
        free(S);
    }
    free(a);
    free(e);
    free(oa);
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: mc_vs3 FILE.vs3 POINTS_PER_BATCH BATCHES SEED\n");
        return 2;
    }
    rad_scene *s;
    rad_vs3 *m;
    rad_error err = {0};
    if (rad_vs3_load(argv[1], NULL, &s, &m, &err)) {
        fprintf(stderr, "mc_vs3: error: %s\n", err.message);
        return 1;
    }
    uint32_t points = (uint32_t)atoi(argv[2]), batches = (uint32_t)atoi(argv[3]);
    rng_state = strtoull(argv[4], NULL, 10) * 2654435761u + 1;
    uint32_t ns = m->surface_count, no = s->object_count, n = 0;
    uint32_t *to = malloc(ns * sizeof *to), *prim = malloc(ns * sizeof *prim);
    for (uint32_t i = 0; i < ns; i++) {
        const rad_vs3_surface *S = &m->surfaces[i];
        if (S->kind == RAD_VS3_MASK || S->kind == RAD_VS3_NULL) {
            fprintf(stderr, "mc_vs3: masks and null surfaces are not handled\n");
            return 1;
        }
        to[i] = S->kind == RAD_VS3_OBSTRUCTION ? RAD_NONE
                : S->combine == RAD_NONE       ? (prim[n] = i, n++)
                                               : to[S->combine];
    }
    rad_vec3 lo, hi;
    rad_scene_bounds(s, &lo, &hi);
    double tmin = 1e-9 * rad_length(rad_sub(hi, lo));
    double *F = malloc((size_t)no * no * sizeof *F), *R = malloc((size_t)n * n * sizeof *R);
    double *sum = calloc((size_t)n * n, sizeof *sum), *sq = calloc((size_t)n * n, sizeof *sq);
    for (uint32_t b = 0; b < batches; b++) {
        memset(F, 0, (size_t)no * no * sizeof *F);
        batch(s, points, tmin, F);
        reported(s, m, F, to, n, R);
        for (size_t k = 0; k < (size_t)n * n; k++) {
            sum[k] += R[k];
            sq[k] += R[k] * R[k];
        }
    }
    printf("# %s factors of %s by mc_vs3 (tools/mc_vs3.c): %u batches x %u points x %d rays\n",
           m->emit ? "script-F" : "F", argv[1], batches, points, GRID * GRID);
    printf("# command: mc_vs3 %s %s %s %s\n", argv[1], argv[2], argv[3], argv[4]);
    printf("from,to,value,stderr\n");
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = 0; j < n; j++) {
            size_t k = (size_t)i * n + j;
            double mean = sum[k] / batches;
            double var = batches > 1 ? (sq[k] - batches * mean * mean) / (batches - 1) : 0;
            printf("%s,%s,%.7f,%.7f\n", m->surfaces[prim[i]].name, m->surfaces[prim[j]].name, mean,
                   sqrt(fmax(var, 0) / batches));
        }
    free(F);
    free(R);
    free(sum);
    free(sq);
    free(to);
    free(prim);
    rad_vs3_destroy(m);
    rad_scene_destroy(s);
    return 0;
}
