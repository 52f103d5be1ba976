/* bench_gather.c - what the final gather buys and costs on the Cornell box.
 *
 * Solves models/cornell.rad (default patches, R = 128), then renders the
 * scene's camera at SIZE×SIZE (default 512) with the vertex renderer, the
 * uncached gather (a gather at every pixel: the reference) and the cached
 * gather at three ε, with and without Ward & Heckbert's gradients.  For
 * each it prints the time, the gathers computed (and their share of the
 * pixels), the mean difference from the reference (Σ|L − L_ref| / Σ L_ref
 * over every pixel and band), and the per-object error against the vertex
 * render: regions are the scene's objects, a pixel belonging to the object
 * its patch lies in (both images must see the same object there), and an
 * object's error is |mean L_gather − mean L_vertex| / mean L_vertex.  A
 * second view (another camera position) then reuses the cache of the first:
 * its gathers show what the saved cache spares.
 *
 *   bench_gather [SIZE] [THREADS]
 */
#include "../radiosity/pipeline/pipeline.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double mean_difference(const rn_image *a, const rn_image *ref)
{
    double num = 0, den = 0;
    size_t n = (size_t)a->width * a->height * a->channels;
    for (size_t k = 0; k < n; k++) {
        num += fabs((double)a->pixels[k] - ref->pixels[k]);
        den += ref->pixels[k];
    }
    return den > 0 ? num / den : 0.0;
}

/* Per-object relative error of the means, worst and area-weighted mean
 * (weighted by the object's pixel count) over objects with pixels. */
static void region_error(const rad_solution *s, const rn_image *a, const rn_image *v, double *worst,
                         double *mean)
{
    uint32_t no = s->scene->object_count, nb = a->channels;
    double *sa = calloc(no, sizeof *sa), *sv = calloc(no, sizeof *sv);
    uint64_t *cnt = calloc(no, sizeof *cnt);
    for (size_t q = 0; q < (size_t)a->width * a->height; q++) {
        if (a->patch[q] == RAD_NONE || v->patch[q] == RAD_NONE)
            continue;
        uint32_t oa = s->mesh->patches[a->patch[q]].object, ov = s->mesh->patches[v->patch[q]].object;
        if (oa != ov)
            continue;
        for (uint32_t b = 0; b < nb; b++) {
            sa[oa] += a->pixels[q * nb + b];
            sv[oa] += v->pixels[q * nb + b];
        }
        cnt[oa]++;
    }
    *worst = 0;
    double wsum = 0, esum = 0;
    for (uint32_t o = 0; o < no; o++) {
        if (!cnt[o] || !(sv[o] > 0))
            continue;
        double e = fabs(sa[o] - sv[o]) / sv[o];
        *worst = fmax(*worst, e);
        esum += e * (double)cnt[o];
        wsum += (double)cnt[o];
    }
    *mean = wsum > 0 ? esum / wsum : 0.0;
    free(sa);
    free(sv);
    free(cnt);
}

int main(int argc, char **argv)
{
    uint32_t size = argc > 1 ? (uint32_t)atoi(argv[1]) : 512;
    uint32_t threads = argc > 2 ? (uint32_t)atoi(argv[2]) : 1;
    rad_solve_options so = {0};
    rad_solution *s = NULL;
    rad_error err = {0};
    if (rad_solve_scene_file("models/cornell.rad", &so, &s, &err)) {
        fprintf(stderr, "bench_gather: %s\n", err.message);
        return 1;
    }
    rn_camera cam, cam2;
    rad_camera_from_scene(s->scene, NULL, size, size, &cam, &err);
    cam2 = cam;
    /* A second view: the eye moved left and down, looking at the same point. */
    cam2.eye = rad_add(cam.eye, rad_v3(-0.12, -0.08, 0.05));

    rad_gather_scene *g = NULL;
    if (rad_gather_scene_create(s, &g, &err)) {
        fprintf(stderr, "bench_gather: %s\n", err.message);
        return 1;
    }
    double t0 = rad_seconds();
    rn_image *vert = NULL, *ref = NULL;
    rad_render_solution(s, &cam, &vert, &err);
    double tv = rad_seconds() - t0;

    rn_gather_options ro = {.no_cache = 1, .threads = threads};
    rn_gather_stats st;
    if (rn_gather(&g->scene, &cam, &ro, NULL, &ref, &st, &err)) {
        fprintf(stderr, "bench_gather: %s\n", err.message);
        return 1;
    }
    double worst, mean;
    printf("Cornell box (%u patches), %ux%u, %u thread(s); reference: uncached gather, %u "
           "rays a pixel; regions: the %u objects\n\n",
           s->mesh->patch_count, size, size, threads, RN_DEFAULT_GATHER_RAYS,
           s->scene->object_count);
    printf("| renderer | eps | gradients | seconds | gathers | gathers/pixels | records | "
           "mean diff vs reference | object error vs vertex: worst | mean | 2nd view gathers |\n");
    printf("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    region_error(s, ref, vert, &worst, &mean);
    printf("| vertex | - | - | %.3f | - | - | - | %.4f | - | - | - |\n", tv,
           mean_difference(vert, ref));
    printf("| gather, no cache | - | - | %.3f | %llu | %.3f | - | 0 | %.4f | %.4f | - |\n",
           st.seconds, (unsigned long long)st.gathers, (double)st.gathers / st.pixels, worst,
           mean);
    const double eps[3] = {0.05, 0.1, 0.2};
    for (int e = 0; e < 3; e++)
        for (int grad = 1; grad >= 0; grad--) {
            rn_gather_options co = {.epsilon = eps[e], .no_gradients = !grad, .threads = threads};
            rn_icache *cache = NULL;
            rn_icache_create(rn_gather_key(&g->scene, &co), g->scene.bands, &cache, &err);
            rn_image *img = NULL, *img2 = NULL;
            rn_gather_stats s1, s2;
            if (rn_gather(&g->scene, &cam, &co, cache, &img, &s1, &err) ||
                rn_gather(&g->scene, &cam2, &co, cache, &img2, &s2, &err)) {
                fprintf(stderr, "bench_gather: %s\n", err.message);
                return 1;
            }
            region_error(s, img, vert, &worst, &mean);
            printf("| gather, cache | %.2f | %s | %.3f | %llu | %.4f | %llu | %.4f | %.4f | %.4f | "
                   "%llu |\n",
                   eps[e], grad ? "yes" : "no", s1.seconds, (unsigned long long)s1.gathers,
                   (double)s1.gathers / s1.pixels, (unsigned long long)s1.records,
                   mean_difference(img, ref), worst, mean, (unsigned long long)s2.gathers);
            rn_image_destroy(img);
            rn_image_destroy(img2);
            rn_icache_destroy(cache);
        }
    rn_image_destroy(vert);
    rn_image_destroy(ref);
    rad_gather_scene_destroy(g);
    rad_solution_destroy(s);
    return 0;
}
