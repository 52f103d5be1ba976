/* bench_render.c - time to draw a 512×512 view of a solved box-like scene.
 *
 * The scene is a room (six inward-facing walls, n×n patches each) holding a
 * block (six outward faces, m×m), with a smooth synthetic radiosity per patch
 * and three bands: what rn_render meets after a solve, without needing one.
 * Prints ms per image (mean of several) and the vertex-radiosity time.
 * With an argument DIR it also writes DIR/bench_render_<patches>.png.
 */
#include "../radiosity/core/rad.h"
#include "../render/render.h"

#include <stdio.h>
#include <stdlib.h>

typedef struct builder {
    rad_mesh m;
    uint32_t vcap, pcap;
} builder;

/* An n×n grid over the parallelogram o + s·a + t·b, facing a × b. */
static void add_face(builder *b, rad_vec3 o, rad_vec3 a, rad_vec3 bb, uint32_t n, uint32_t polygon)
{
    rad_mesh *m = &b->m;
    uint32_t base = m->vertex_count;
    rad_vec3 nrm = rad_normalize(rad_cross(a, bb));
    double area = rad_length(rad_cross(a, bb)) / ((double)n * n);
    for (uint32_t j = 0; j <= n; j++)
        for (uint32_t i = 0; i <= n; i++) {
            m->vertices[m->vertex_count] =
                rad_add(o, rad_add(rad_scale(a, (double)i / n), rad_scale(bb, (double)j / n)));
            m->vertex_boundary[m->vertex_count++] = i == 0 || j == 0 || i == n || j == n;
        }
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            uint32_t v0 = base + j * (n + 1) + i;
            rad_patch *p = &m->patches[m->patch_count++];
            p->v[0] = v0;
            p->v[1] = v0 + 1;
            p->v[2] = v0 + n + 2;
            p->v[3] = v0 + n + 1;
            p->polygon = polygon;
            p->object = polygon < 6 ? 0 : 1;
            p->material = 0;
            p->center = rad_add(o, rad_add(rad_scale(a, (i + 0.5) / n), rad_scale(bb, (j + 0.5) / n)));
            p->normal = nrm;
            p->area = area;
        }
}

/* Axis box [lo, hi]: faces pointing inward (room) or outward (block). */
static void add_box(builder *b, rad_vec3 lo, rad_vec3 hi, uint32_t n, int inward, uint32_t poly0)
{
    rad_vec3 d = rad_sub(hi, lo), X = rad_v3(d.x, 0, 0), Y = rad_v3(0, d.y, 0), Z = rad_v3(0, 0, d.z);
    struct {
        rad_vec3 o, a, b;
    } f[6] = {
        {lo, Y, X},                          /* z = lo, outward −z */
        {rad_add(lo, Z), X, Y},              /* z = hi, outward +z */
        {lo, X, Z},                          /* y = lo, outward −y */
        {rad_add(lo, Y), Z, X},              /* y = hi, outward +y */
        {lo, Z, Y},                          /* x = lo, outward −x */
        {rad_add(lo, X), Y, Z},              /* x = hi, outward +x */
    };
    for (int k = 0; k < 6; k++) {
        if (inward) /* swap the edges: the normal flips */
            add_face(b, f[k].o, f[k].b, f[k].a, n, poly0 + (uint32_t)k);
        else
            add_face(b, f[k].o, f[k].a, f[k].b, n, poly0 + (uint32_t)k);
    }
}

static int run(uint32_t n_room, uint32_t n_block, const char *dir)
{
    builder b = {{0}, 0, 0};
    b.vcap = 6 * (n_room + 1) * (n_room + 1) + 6 * (n_block + 1) * (n_block + 1);
    b.pcap = 6 * n_room * n_room + 6 * n_block * n_block;
    b.m.vertices = malloc(sizeof(rad_vec3) * b.vcap);
    b.m.vertex_boundary = malloc(b.vcap);
    b.m.patches = malloc(sizeof(rad_patch) * b.pcap);
    double *B = malloc(sizeof(double) * 3 * b.pcap);
    double *vb = malloc(sizeof(double) * 3 * b.vcap);
    if (!b.m.vertices || !b.m.vertex_boundary || !b.m.patches || !B || !vb) {
        fprintf(stderr, "bench_render: out of memory\n");
        return 1;
    }
    add_box(&b, rad_v3(0, 0, 0), rad_v3(5, 5, 5), n_room, 1, 0);
    add_box(&b, rad_v3(1.5, 1.5, 0.0), rad_v3(3.0, 3.0, 2.0), n_block, 0, 6);
    /* Lit from a lamp near the ceiling: B falls off with distance. */
    for (uint32_t p = 0; p < b.m.patch_count; p++) {
        rad_vec3 c = b.m.patches[p].center, d = rad_sub(rad_v3(2.5, 2.5, 4.8), c);
        double fall = 1.0 / (1.0 + rad_dot(d, d));
        B[3 * p + 0] = 3.0 * fall;
        B[3 * p + 1] = 2.6 * fall * (b.m.patches[p].polygon == 4 ? 0.3 : 1.0);
        B[3 * p + 2] = 2.2 * fall * (b.m.patches[p].polygon == 5 ? 0.3 : 1.0);
    }
    const int reps = 10;
    double t0 = rad_seconds();
    for (int r = 0; r < reps; r++)
        rn_vertex_radiosity(&b.m, 3, B, vb);
    double t_vertex = (rad_seconds() - t0) / reps;

    rn_camera cam = {.eye = rad_v3(4.6, 0.4, 2.8), .target = rad_v3(2.2, 2.4, 1.0),
                     .up = rad_v3(0, 0, 1), .yfov_deg = 70, .width = 512, .height = 512};
    rn_image *img = NULL;
    rad_error err;
    for (int r = 0; r < 3; r++) { /* warm-up: caches, the allocator, the clock */
        if (rn_render(&b.m, 3, vb, &cam, &img, &err) != RAD_OK) {
            fprintf(stderr, "bench_render: %s\n", err.message);
            return 1;
        }
        rn_image_destroy(img);
    }
    /* Mean and best of reps: the machine may be shared, the best is the
     * renderer's own cost. */
    double sum = 0.0, best = INFINITY;
    for (int r = 0; r < reps; r++) {
        t0 = rad_seconds();
        if (rn_render(&b.m, 3, vb, &cam, &img, &err) != RAD_OK) {
            fprintf(stderr, "bench_render: %s\n", err.message);
            return 1;
        }
        double t = rad_seconds() - t0;
        sum += t;
        best = t < best ? t : best;
        if (r + 1 < reps)
            rn_image_destroy(img);
    }
    printf("render 512x512  %6u patches  %8.2f ms/image (best %.2f)   vertex radiosity %6.3f ms\n",
           b.m.patch_count, 1e3 * sum / reps, 1e3 * best, 1e3 * t_vertex);
    if (dir) {
        char path[1024];
        snprintf(path, sizeof path, "%s/bench_render_%u.png", dir, b.m.patch_count);
        if (rn_write_png(img, path, 0.0, &err) != RAD_OK)
            fprintf(stderr, "bench_render: %s\n", err.message);
    }
    rn_image_destroy(img);
    free(b.m.vertices);
    free(b.m.vertex_boundary);
    free(b.m.patches);
    free(B);
    free(vb);
    return 0;
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : NULL;
    int rc = run(16, 9, dir);   /* 6·256 + 6·81  = 2022 patches */
    rc |= run(32, 18, dir);     /* 6·1024 + 6·324 = 8088 patches */
    return rc;
}
