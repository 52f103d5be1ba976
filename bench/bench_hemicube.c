/* bench_hemicube.c - form-factor throughput of the hemi-cube engine.
 *
 * Builds a Cornell-like box by hand (five walls, a light just under the
 * ceiling, a short and a tall block, each rectangle cut into square-ish
 * patches of side h) at about 500, 2000 and 8000 patches, computes every
 * row at R = 128 with 1 and with 2 worker processes, and prints rows/s and
 * the seconds spent (start-up of the workers shown apart), the CPU seconds
 * the workers used (start-up and the single-row runs included) and the
 * caller spent, and the latency of single-row requests.  A second table
 * times the exact entries (the light's patches marked, then exact_near as
 * well) and a third the punctual lights of hc_light_power, per light and
 * resolution.
 *
 *   bench_hemicube [max_patches]     (default 8000)
 */
#include "../hemicube/hemicube.h"

#include <stdio.h>
#include <sys/resource.h>
#include <stdlib.h>
#include <string.h>

typedef struct builder {
    rad_mesh m;
    uint32_t vcap, pcap, polygons;
} builder;

static int grow(builder *b, uint32_t nv, uint32_t np)
{
    if (b->m.vertex_count + nv > b->vcap) {
        while (b->m.vertex_count + nv > b->vcap)
            b->vcap = b->vcap ? 2 * b->vcap : 256;
        void *v = realloc(b->m.vertices, b->vcap * sizeof *b->m.vertices);
        if (!v)
            return -1;
        b->m.vertices = v;
        void *f = realloc(b->m.vertex_boundary, b->vcap);
        if (!f)
            return -1;
        b->m.vertex_boundary = f;
    }
    if (b->m.patch_count + np > b->pcap) {
        while (b->m.patch_count + np > b->pcap)
            b->pcap = b->pcap ? 2 * b->pcap : 256;
        void *p = realloc(b->m.patches, b->pcap * sizeof *b->m.patches);
        if (!p)
            return -1;
        b->m.patches = p;
    }
    return 0;
}

static uint32_t cells(double len, double h)
{
    double c = ceil(len / h - 1e-9);
    return c < 1 ? 1 : (uint32_t)c;
}

/* Parallelogram o + s·e1 + t·e2 facing e1 × e2, cut into patches of side
 * about h.  Only counts when b is NULL. */
static uint32_t rect(builder *b, rad_vec3 o, rad_vec3 e1, rad_vec3 e2, double h)
{
    uint32_t nx = cells(rad_length(e1), h), ny = cells(rad_length(e2), h);
    if (!b)
        return nx * ny;
    if (grow(b, (nx + 1) * (ny + 1), nx * ny) != 0) {
        fprintf(stderr, "bench_hemicube: out of memory\n");
        exit(1);
    }
    uint32_t v0 = b->m.vertex_count;
    for (uint32_t y = 0; y <= ny; y++)
        for (uint32_t x = 0; x <= nx; x++) {
            b->m.vertices[b->m.vertex_count] =
                rad_add(o, rad_add(rad_scale(e1, (double)x / nx), rad_scale(e2, (double)y / ny)));
            b->m.vertex_boundary[b->m.vertex_count++] = x == 0 || y == 0 || x == nx || y == ny;
        }
    rad_vec3 cr = rad_cross(e1, e2);
    for (uint32_t y = 0; y < ny; y++)
        for (uint32_t x = 0; x < nx; x++) {
            rad_patch *p = &b->m.patches[b->m.patch_count++];
            uint32_t a = v0 + y * (nx + 1) + x;
            p->v[0] = a;
            p->v[1] = a + 1;
            p->v[2] = a + nx + 2;
            p->v[3] = a + nx + 1;
            p->polygon = b->polygons;
            p->object = 0;
            p->material = 0;
            p->center = rad_add(o, rad_add(rad_scale(e1, (x + 0.5) / nx), rad_scale(e2, (y + 0.5) / ny)));
            p->normal = rad_normalize(cr);
            p->area = rad_length(cr) / (nx * ny);
        }
    b->polygons++;
    return nx * ny;
}

/* Block standing on the floor: base centre (cx, cy), side s, height t,
 * turned by `ang` radians; top and four sides facing out. */
static uint32_t block(builder *b, double cx, double cy, double s, double t, double ang, double h)
{
    rad_vec3 ex = rad_v3(cos(ang) * s, sin(ang) * s, 0), ey = rad_v3(-sin(ang) * s, cos(ang) * s, 0);
    rad_vec3 up = rad_v3(0, 0, t);
    rad_vec3 c0 = rad_sub(rad_v3(cx, cy, 0), rad_scale(rad_add(ex, ey), 0.5));
    rad_vec3 c1 = rad_add(c0, ex), c2 = rad_add(c1, ey), c3 = rad_add(c0, ey);
    uint32_t n = 0;
    n += rect(b, rad_add(c0, up), ex, ey, h);                  /* top, +z */
    n += rect(b, c0, ex, up, h);                               /* -ey side */
    n += rect(b, c1, ey, up, h);                               /* +ex side */
    n += rect(b, c2, rad_scale(ex, -1), up, h);                /* +ey side */
    n += rect(b, c3, rad_scale(ey, -1), up, h);                /* -ex side */
    return n;
}

static uint32_t cornell(builder *b, double h)
{
    uint32_t n = 0;
    n += rect(b, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), h);  /* floor, +z */
    n += rect(b, rad_v3(0, 0, 1), rad_v3(0, 1, 0), rad_v3(1, 0, 0), h);  /* ceiling, -z */
    n += rect(b, rad_v3(0, 1, 0), rad_v3(1, 0, 0), rad_v3(0, 0, 1), h);  /* back, -y */
    n += rect(b, rad_v3(0, 0, 0), rad_v3(0, 1, 0), rad_v3(0, 0, 1), h);  /* left, +x */
    n += rect(b, rad_v3(1, 0, 0), rad_v3(0, 0, 1), rad_v3(0, 1, 0), h);  /* right, -x */
    n += rect(b, rad_v3(0.38, 0.38, 0.999), rad_v3(0, 0.24, 0), rad_v3(0.24, 0, 0), h); /* light */
    n += block(b, 0.66, 0.35, 0.30, 0.30, -0.30, h);
    n += block(b, 0.34, 0.65, 0.30, 0.60, 0.29, h);
    return n;
}

/* Patch side giving about `target` patches. */
static double side_for(uint32_t target)
{
    double lo = 1e-3, hi = 1.0;
    for (int k = 0; k < 60; k++) {
        double mid = sqrt(lo * hi);
        if (cornell(NULL, mid) > target)
            lo = mid;
        else
            hi = mid;
    }
    return hi;
}

/* CPU seconds (user + system) of the reaped workers so far: the machine may
 * be shared, so wall time alone can mislead. */
static double cpu_of(int who)
{
    struct rusage ru;
    if (getrusage(who, &ru) != 0)
        return 0.0;
    return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

static double children_cpu(void) { return cpu_of(RUSAGE_CHILDREN); }
static double self_cpu(void) { return cpu_of(RUSAGE_SELF); }

/* Rows with exact entries, and lights, on the box of about `target`
 * patches with 2 workers. */
static void exact_and_lights(uint32_t target)
{
    builder b;
    memset(&b, 0, sizeof b);
    cornell(&b, side_for(target));
    uint32_t n = b.m.patch_count, marked = 0;
    uint32_t *rows = malloc(n * sizeof *rows);
    uint8_t *exact = calloc(n, 1);
    double *power = malloc(n * sizeof *power);
    if (!rows || !exact || !power) {
        fprintf(stderr, "bench_hemicube: out of memory\n");
        exit(1);
    }
    for (uint32_t k = 0; k < n; k++) {
        rows[k] = k;
        /* The light sits at z = 0.999, just under the ceiling. */
        exact[k] = fabs(b.m.patches[k].center.z - 0.999) < 1e-9;
        marked += exact[k];
    }
    printf("\nexact entries, %u patches (%u light patches), R = 128, 2 workers\n", n, marked);
    printf("%-28s %9s %9s %12s\n", "rows", "rows s", "rows/s", "worker cpu s");
    for (int mode = 0; mode < 3; mode++) {
        hc_options o = {.resolution = 128, .processes = 2, .exact = mode ? exact : NULL,
                        .exact_near = mode == 2};
        hc_engine *e = NULL;
        rad_error err;
        if (hc_create(&b.m, &o, &e, &err) != RAD_OK) {
            fprintf(stderr, "bench_hemicube: %s\n", err.message);
            exit(1);
        }
        rad_matrix *F = rad_matrix_create(n);
        double c0 = children_cpu(), t0 = rad_seconds();
        if (!F || hc_compute_rows(e, rows, n, F, &err) != RAD_OK) {
            fprintf(stderr, "bench_hemicube: %s\n", F ? err.message : "out of memory");
            exit(1);
        }
        double t1 = rad_seconds();
        hc_destroy(e);
        printf("%-28s %9.3f %9.0f %12.3f\n",
               mode == 0 ? "pixel counts" : mode == 1 ? "exact = light patches" : "exact + exact_near",
               t1 - t0, n / (t1 - t0), children_cpu() - c0);
        rad_matrix_destroy(F);
    }

    printf("\nlights (hc_light_power), %u patches, 2 workers\n", n);
    printf("%-12s %6s %9s\n", "light", "R", "s/light");
    hc_options o = {.resolution = 128, .processes = 2};
    hc_engine *e = NULL;
    rad_error err;
    if (hc_create(&b.m, &o, &e, &err) != RAD_OK) {
        fprintf(stderr, "bench_hemicube: %s\n", err.message);
        exit(1);
    }
    const hc_light lights[3] = {
        {.kind = HC_LIGHT_POINT, .position = {0.5, 0.5, 0.9}},
        {.kind = HC_LIGHT_SPOT, .position = {0.5, 0.5, 0.9}, .direction = {0, 0, -1},
         .inner_cone = 0.3, .outer_cone = 0.6},
        {.kind = HC_LIGHT_DIRECTIONAL, .direction = {0.2, 0.3, -1}},
    };
    const char *names[3] = {"point", "spot", "directional"};
    const uint32_t res[2] = {512, 1024};
    /* Resolution outside: a worker remakes its light target when R changes.
     * Each light twice: the first call of a worker also compiles llvmpipe's
     * code for the new target; the table shows the second. */
    for (int r = 0; r < 2; r++)
        for (int l = 0; l < 3; l++) {
            double dt = 0.0;
            for (int rep = 0; rep < 2; rep++) {
                double t0 = rad_seconds();
                if (hc_light_power(e, &lights[l], res[r], power, &err) != RAD_OK) {
                    fprintf(stderr, "bench_hemicube: %s\n", err.message);
                    exit(1);
                }
                dt = rad_seconds() - t0;
            }
            printf("%-12s %6u %9.3f\n", names[l], res[r], dt);
        }
    hc_destroy(e);
    free(rows);
    free(exact);
    free(power);
    free(b.m.vertices);
    free(b.m.vertex_boundary);
    free(b.m.patches);
}

int main(int argc, char **argv)
{
    uint32_t max_patches = argc > 1 ? (uint32_t)strtoul(argv[1], NULL, 10) : 8000;
    const uint32_t targets[] = {500, 2000, 8000};
    printf("hemi-cube form factors, Cornell-like box, R = 128\n");
    printf("%8s %6s %9s %9s %9s %12s %12s %12s %8s\n", "patches", "procs", "start s", "rows s",
           "rows/s", "worker cpu s", "caller cpu s", "1-row ms", "nnz/row");
    for (size_t t = 0; t < sizeof targets / sizeof *targets; t++) {
        if (targets[t] > max_patches)
            break;
        builder b;
        memset(&b, 0, sizeof b);
        cornell(&b, side_for(targets[t]));
        uint32_t n = b.m.patch_count;
        uint32_t *rows = malloc(n * sizeof *rows);
        if (!rows)
            return 1;
        for (uint32_t k = 0; k < n; k++)
            rows[k] = k;
        for (uint32_t procs = 1; procs <= 2; procs++) {
            hc_options o = {.resolution = 128, .processes = procs};
            hc_engine *e = NULL;
            rad_error err;
            double c0 = children_cpu();
            double t0 = rad_seconds();
            if (hc_create(&b.m, &o, &e, &err) != RAD_OK) {
                fprintf(stderr, "bench_hemicube: %s\n", err.message);
                return 1;
            }
            double t1 = rad_seconds(), s1 = self_cpu();
            rad_matrix *F = rad_matrix_create(n);
            if (!F || hc_compute_rows(e, rows, n, F, &err) != RAD_OK) {
                fprintf(stderr, "bench_hemicube: %s\n", F ? err.message : "out of memory");
                return 1;
            }
            double t2 = rad_seconds();
            double s2 = self_cpu() - s1;
            double nnz = (double)F->nnz / n;
            /* Latency of single-row requests, as the progressive solver
             * makes them. */
            const uint32_t singles = n < 200 ? n : 200;
            for (uint32_t k = 0; k < singles; k++) {
                uint32_t r = (uint32_t)((uint64_t)k * n / singles);
                if (hc_compute_rows(e, &r, 1, F, &err) != RAD_OK) {
                    fprintf(stderr, "bench_hemicube: %s\n", err.message);
                    return 1;
                }
            }
            double t3 = rad_seconds();
            rad_matrix_destroy(F);
            hc_destroy(e);
            printf("%8u %6u %9.3f %9.3f %9.0f %12.3f %12.3f %12.3f %8.1f\n", n, procs, t1 - t0,
                   t2 - t1, n / (t2 - t1), children_cpu() - c0, s2, 1e3 * (t3 - t2) / singles, nnz);
            fflush(stdout);
        }
        free(rows);
        free(b.m.vertices);
        free(b.m.vertex_boundary);
        free(b.m.patches);
    }
    exact_and_lights(max_patches < 2000 ? max_patches : 2000);
    return 0;
}
