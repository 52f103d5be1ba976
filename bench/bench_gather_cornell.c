/* bench_gather_cornell.c - the final gather's accuracy against its time on
 * the glTF Cornell box (issue 39), scored like bench_cornell: 256 × 256
 * through the scene's camera, per region the mean radiance R + G + B
 * against the shipped path-traced reference (bench/data/), the worst region
 * and the RMS over the 13 regions other than the emitter.
 *
 * Solves models/cornell.gltf once at the defaults, then renders with the
 * vertex renderer and the gather in the settings of BENCH_ROWS
 * (comma-separated; default all of them): "vertex"; "uncached" (a gather
 * at every pixel, 256 rays) and "uncached1024"; "eps=A" with ε = A
 * (Ward's cache, 256 rays, gradients), "eps=A/nograd" without gradients;
 * "after512" (ε = 0.1, the cache that a 512 × 512 view of the same camera
 * filled first: what a second `render --gather` at another size reads from
 * SOLUTION.icache).  CPU is this process's processor time for the render
 * (one shading thread), on a machine shared with others.
 *
 *   bench_gather_cornell          (from the repository's root)
 */
#include "../radiosity/pipeline/pipeline.h"
#include "../test/cornell_reference.h"

#include <time.h>

static cref ref;
static rad_solution *sol;
static rad_gather_scene *gs;

static double cpu_now(void) { return (double)clock() / CLOCKS_PER_SEC; }

static void die(const char *what, const rad_error *err)
{
    fprintf(stderr, "bench_gather_cornell: %s: %s\n", what, err ? err->message : "failed");
    exit(1);
}

/* One row: renders, scores and prints it. */
static void row(const char *spec)
{
    rad_error err = {0};
    rn_camera cam;
    if (rad_camera_from_scene(sol->scene, NULL, ref.side, ref.side, &cam, &err))
        die(spec, &err);
    rn_gather_options o = {.threads = 1};
    rn_gather_stats st = {0};
    rn_icache *cache = NULL;
    rn_image *img = NULL;
    int vertex = !strcmp(spec, "vertex");
    if (!strncmp(spec, "uncached", 8)) {
        o.no_cache = 1;
        o.gather_rays = spec[8] ? (uint32_t)atoi(spec + 8) : 256;
    } else if (!strncmp(spec, "eps=", 4)) {
        o.epsilon = atof(spec + 4);
        o.no_gradients = strstr(spec, "/nograd") != NULL;
    } else if (!strcmp(spec, "after512")) {
        rn_camera big;
        rn_image *first = NULL;
        if (rn_icache_create(rn_gather_key(&gs->scene, &o), gs->scene.bands, &cache, &err) ||
            rad_camera_from_scene(sol->scene, NULL, 512, 512, &big, &err) ||
            rn_gather(&gs->scene, &big, &o, cache, &first, NULL, &err))
            die(spec, &err);
        rn_image_destroy(first);
    } else if (!vertex) {
        fprintf(stderr, "bench_gather_cornell: unknown row '%s'\n", spec);
        exit(2);
    }
    double c0 = cpu_now();
    int rc = vertex ? rad_render_solution(sol, &cam, &img, &err)
                    : rn_gather(&gs->scene, &cam, &o, cache, &img, &st, &err);
    double cpu = cpu_now() - c0;
    if (rc)
        die(spec, &err);
    cref_score sc;
    cref_score_image(&ref, img, &sc);
    printf("| %s | %.2f | %llu | %.2f %% (%s) | %.2f %% |\n", spec, cpu,
           (unsigned long long)st.gathers, 100 * sc.worst,
           sc.worst_at >= 0 ? ref.name[sc.worst_at] : "-", 100 * sc.rms);
    fflush(stdout);
    rn_image_destroy(img);
    rn_icache_destroy(cache);
}

int main(void)
{
    if (cref_load(&ref))
        return 1;
    rad_solve_options opt = {0};
    rad_error err = {0};
    double c0 = cpu_now();
    if (rad_solve_scene_file("models/cornell.gltf", &opt, &sol, &err) ||
        rad_gather_scene_create(sol, &gs, &err))
        die("models/cornell.gltf", &err);
    printf("glTF Cornell box at the defaults (%u patches, %u elements; solve %.1f s CPU of this "
           "process), %ux%u, against %s\n\n", sol->mesh->patch_count,
           sol->elements ? sol->elements->mesh->patch_count : 0, cpu_now() - c0, ref.side,
           ref.side, CREF_JSON);
    printf("| render | CPU s | gathers | worst region | RMS |\n|:--|--:|--:|--:|--:|\n");
    const char *env = getenv("BENCH_ROWS");
    char list[512];
    snprintf(list, sizeof list, "%s",
             env && *env ? env
                         : "vertex,uncached,uncached1024,eps=0.05,eps=0.05/nograd,eps=0.1,"
                           "eps=0.1/nograd,eps=0.2,eps=0.2/nograd,after512");
    for (char *t = strtok(list, ","); t; t = strtok(NULL, ","))
        row(t);
    rad_gather_scene_destroy(gs);
    rad_solution_destroy(sol);
    cref_free(&ref);
    return 0;
}
