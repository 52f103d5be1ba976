/* test_gather.c - the final gather (render --gather): agreement with the
 * vertex renderer and with analytic direct light, Ward's irradiance cache
 * against the uncached gather, the saved cache, a mirror against a direct
 * ray-traced reflection, glossy lobes two ways, and the materials' glossy
 * parameters from the polygon file, glTF and the solution file.
 *
 * Scenes are polygon-file text solved here; the references are analytic
 * (Lambert's point-to-polygon factor, I cosθ/r²) or independent renders
 * (the vertex renderer, the uncached gather, a camera mirrored through the
 * floor).  Cost (release, this 2-core machine): about 5 s; each test says
 * its share.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <unistd.h>

/* ------------------------------------------------------------ helpers */

/* A unit room without its front wall (z = 0), lit by a 0.2 × 0.2 lamp set
 * into the middle of its ceiling, the ceiling cut around the lamp; the
 * floor's material is FLOOR, the rest are "wall" and "lamp". */
#define OPEN_ROOM(FLOOR)                                                            \
    "polygon floor " FLOOR " 0 0 0  0 0 1  1 0 1  1 0 0 end\n"                      \
    "polygon back wall 0 0 1  0 1 1  1 1 1  1 0 1 end\n"                            \
    "polygon left wall 0 0 0  0 1 0  0 1 1  0 0 1 end\n"                            \
    "polygon right wall 1 0 0  1 0 1  1 1 1  1 1 0 end\n"                           \
    "group ceiling\n"                                                               \
    "  polygon c1 wall 0 1 0  1 1 0  1 1 0.4  0 1 0.4 end\n"                        \
    "  polygon c2 wall 0 1 0.6  1 1 0.6  1 1 1  0 1 1 end\n"                        \
    "  polygon c3 wall 0 1 0.4  0.4 1 0.4  0.4 1 0.6  0 1 0.6 end\n"                \
    "  polygon c4 wall 0.6 1 0.4  1 1 0.4  1 1 0.6  0.6 1 0.6 end\n"                \
    "end\n"                                                                         \
    "polygon lamp lamp 0.4 1 0.4  0.6 1 0.4  0.6 1 0.6  0.4 1 0.6 end\n"

/* The closed room: grey (ρ = 0.5), its front wall in place. */
#define CLOSED_ROOM(FLOOR)                                                          \
    OPEN_ROOM(FLOOR) "polygon front wall 0 0 0  1 0 0  1 1 0  0 1 0 end\n"          \
    "camera inside eye 0.5 0.5 0.02 target 0.5 0.42 1 up 0 1 0 fov 75\n"

static const char room_text[] = "bands 1\n"
                                "material wall reflectance 0.5\n"
                                "material lamp reflectance 0 emission 10\n" CLOSED_ROOM("wall");

static rad_solution *solve(const char *text, double patch_size)
{
    rad_solve_options opt = {.refine_threshold = RAD_REFINE_OFF}; /* patches only */
    opt.mesh.patch_size = patch_size;
    /* Converged well past the default tolerance: the gather is one more
     * bounce of the stored B, so an unconverged B shows as a difference
     * (0.7 % in the room at the default 1e-4). */
    opt.solver.tolerance = 1e-8;
    opt.hemicube.processes = 1; /* tiny scenes: one worker starts faster than two */
    return test_solve_text(text, "gather-test", &opt);
}

/* Solves text and builds its gather scene; NULL (printed) on failure, with
 * *out the solution or NULL.  The caller destroys both. */
static rad_gather_scene *prepare(const char *text, double patch_size, rad_solution **out)
{
    *out = solve(text, patch_size);
    rad_gather_scene *g = NULL;
    rad_error err = {0};
    if (*out && rad_gather_scene_create(*out, &g, &err))
        fprintf(stderr, "  gather scene: %s\n", err.message);
    return g;
}

static rn_camera scene_camera(const rad_solution *s, uint32_t w, uint32_t h)
{
    rn_camera cam;
    rad_error err = {0};
    rad_camera_from_scene(s->scene, NULL, w, h, &cam, &err);
    return cam;
}

/* The gather with opt and an optional cache; NULL on failure (printed). */
static rn_image *gather(const rad_gather_scene *g, const rn_camera *cam, const rn_gather_options *opt,
                        rn_icache *cache, rn_gather_stats *st)
{
    rn_image *img = NULL;
    rad_error err = {0};
    rn_gather_stats own;
    if (rn_gather(&g->scene, cam, opt, cache, &img, st ? st : &own, &err)) {
        fprintf(stderr, "  gather: %s\n", err.message);
        return NULL;
    }
    return img;
}

/* Σ|a − b| / Σ b over every pixel and band. */
static double mean_difference(const rn_image *a, const rn_image *b)
{
    double num = 0, den = 0;
    for (size_t k = 0; k < (size_t)a->width * a->height * a->channels; k++) {
        num += fabs((double)a->pixels[k] - b->pixels[k]);
        den += b->pixels[k];
    }
    return num / den;
}

/* Mean radiance of object o over the pixels where image a and the vertex
 * image v both see it (cells map to patches through cell_patch when given). */
static void object_means(const rad_solution *s, const rn_image *a, const uint32_t *cell_patch,
                         const rn_image *v, uint32_t o, double *ma, double *mv)
{
    double sa = 0, sv = 0;
    uint64_t n = 0;
    for (size_t q = 0; q < (size_t)a->width * a->height; q++) {
        if (a->patch[q] == RAD_NONE || v->patch[q] == RAD_NONE)
            continue;
        uint32_t pa = cell_patch ? cell_patch[a->patch[q]] : a->patch[q];
        if (s->mesh->patches[pa].object != o || s->mesh->patches[v->patch[q]].object != o)
            continue;
        sa += a->pixels[q];
        sv += v->pixels[q];
        n++;
    }
    *ma = n ? sa / n : 0;
    *mv = n ? sv / n : 0;
}

/* Pixel (i, j)'s unit ray direction, the camera convention of render.h. */
static rad_vec3 pixel_ray(const rn_camera *c, uint32_t i, uint32_t j)
{
    rad_vec3 f = rad_normalize(rad_sub(c->target, c->eye));
    rad_vec3 r = rad_normalize(rad_cross(f, c->up)), u = rad_cross(r, f);
    double k = 0.5 * c->height / tan(0.5 * c->yfov_deg * M_PI / 180.0);
    double a = (i + 0.5 - 0.5 * c->width) / k, b = (0.5 * c->height - j - 0.5) / k;
    return rad_normalize(rad_add(f, rad_add(rad_scale(r, a), rad_scale(u, b))));
}

/* ------------------------------------------------------------- tests */

/* A Lambertian room on a fine mesh (12 × 12 patches a wall): per wall, the
 * gather's mean agrees with the vertex render's.  Cost ~1.3 s. */
TEST(lambertian_room_matches_vertex_render)
{
    rad_solution *s = solve(room_text, 1.0 / 12.0);
    CHECK(s != NULL);
    if (!s)
        return;
    rn_camera cam = scene_camera(s, 64, 64);
    rn_image *v = NULL;
    rad_error err = {0};
    CHECK(rad_render_solution(s, &cam, &v, &err) == RAD_OK);
    rad_gather_scene *g = NULL;
    CHECK(rad_gather_scene_create(s, &g, &err) == RAD_OK);
    rn_gather_options opt = {0};
    rn_image *a = gather(g, &cam, &opt, NULL, NULL);
    CHECK(a != NULL);
    const char *walls[] = {"floor", "back", "left", "right", "ceiling"};
    double worst = 0, sum = 0;
    for (int k = 0; a && k < 5; k++) {
        uint32_t o = rad_scene_find_object(s->scene, walls[k]);
        double ma, mv;
        object_means(s, a, g->cell_patch, v, o, &ma, &mv);
        CHECK(mv > 0);
        double e = fabs(ma - mv) / mv;
        worst = fmax(worst, e);
        sum += e;
        printf("  %-8s gather %.5f vertex %.5f  (%+.2f %%)\n", walls[k], ma, mv, 100 * (ma - mv) / mv);
    }
    /* Measured: mean 0.37 %, worst 0.64 % (back wall). */
    CHECK_MSG(sum / 5 < 0.01, "mean over regions %.4f", sum / 5);
    CHECK_MSG(worst < 0.015, "worst region %.4f", worst);
    rn_image_destroy(a);
    rn_image_destroy(v);
    rad_gather_scene_destroy(g);
    rad_solution_destroy(s);
}


/* A 0.1 × 0.1 lamp 0.5 above a floor, a point light and a spot below it
 * (so that the lamp shades neither), nothing else: every floor pixel is (ρ/π) H with H the lamp's E F(X → lamp)
 * (Lambert's point-to-polygon factor, hc_ff_point_polygon) plus the point
 * light's I cosθ/r² and the spot's, times its falloff, as the gather meets
 * no reflecting surface.  The lamp's samples only measure its visible share
 * (render/final_gather.c), so an unshadowed pixel is exact but for float hit
 * points; plain sampling with 16 points erred by 4.5 % here.  Cost ~0.3 s. */
TEST(direct_light_of_a_lamp_and_punctual_lights)
{
    static const char text[] =
        "bands 1\n"
        "material floor reflectance 0.5\n"
        "material lamp reflectance 0 emission 10\n"
        "polygon floor floor -1 0 -1  -1 0 1  1 0 1  1 0 -1 end\n"
        "polygon lamp lamp -0.05 0.5 -0.05  0.05 0.5 -0.05  0.05 0.5 0.05  -0.05 0.5 0.05 end\n"
        "light bulb point 0.3 0.4 0 intensity 0.02\n"
        "light beam spot -0.4 0.45 0.1 direction 0 -1 0 inner 15 outer 30 intensity 0.03\n"
        "camera top eye 0 1.2 -1.2 target 0 0 0 up 0 1 0 fov 50\n";
    rad_solution *s = NULL;
    rad_gather_scene *g = prepare(text, 0.25, &s);
    CHECK(g != NULL);
    if (!g) {
        rad_solution_destroy(s);
        return;
    }
    rn_camera cam = scene_camera(s, 48, 48);
    rn_gather_options opt = {0};
    rn_image *a = gather(g, &cam, &opt, NULL, NULL);
    CHECK(a != NULL);
    const rad_vec3 *lamp = s->scene->points + s->scene->polygons[1].first_point;
    double worst = 0, ci = cos(15 * M_PI / 180), co = cos(30 * M_PI / 180);
    uint32_t n = 0;
    for (uint32_t j = 0; a && j < 48; j++)
        for (uint32_t i = 0; i < 48; i++) {
            size_t q = (size_t)j * 48 + i;
            if (a->patch[q] == RAD_NONE || s->mesh->patches[a->patch[q]].object != 0)
                continue;
            rad_vec3 d = pixel_ray(&cam, i, j);
            rad_vec3 X = rad_add(cam.eye, rad_scale(d, -cam.eye.y / d.y));
            rad_vec3 p = rad_sub(rad_v3(0.3, 0.4, 0), X), sp = rad_sub(rad_v3(-0.4, 0.45, 0.1), X);
            double r2 = rad_dot(p, p), s2 = rad_dot(sp, sp);
            double t = (sp.y / sqrt(s2) - co) / (ci - co); /* cos to the axis (0, -1, 0) */
            t = t < 0 ? 0 : t > 1 ? 1 : t;
            double H = 10.0 * hc_ff_point_polygon(X, rad_v3(0, 1, 0), lamp, 4) +
                       0.02 * p.y / sqrt(r2) / r2 + 0.03 * t * t * sp.y / sqrt(s2) / s2;
            double L = 0.5 / M_PI * H;
            worst = fmax(worst, fabs(a->pixels[q] - L) / L);
            n++;
        }
    CHECK(n > 1000);
    printf("  worst %.3g over %u pixels\n", worst, n);
    /* Measured: 1.3e-6 (float hit points, float pixels; the acceptance
     * asks for 1 % under a small lamp). */
    CHECK_MSG(worst < 1e-5, "worst %.5f over %u pixels", worst, n);
    rn_image_destroy(a);
    rad_gather_scene_destroy(g);
    rad_solution_destroy(s);
}

/* The Cornell box, solved once for the tests that share it (freed by
 * main).  Coarse: the cache's numbers depend on the geometry, not on B's
 * detail. */
static rad_solution *cornell_box;
static rad_solution *cornell(void)
{
    if (cornell_box)
        return cornell_box;
    rad_solve_options opt = {.refine_threshold = RAD_REFINE_OFF}; /* patches only */
    opt.mesh.patch_size = 0.1;
    opt.hemicube.processes = 1;
    rad_error err = {0};
    if (rad_solve_scene_file("models/cornell.rad", &opt, &cornell_box, &err))
        fprintf(stderr, "  solve: %s\n", err.message);
    return cornell_box;
}

/* Ward's cache at ε = 0.1 against a gather at every pixel (both with 1024
 * rays a gather, so that the reference's own noise stays below the
 * difference measured), and its economy on the Cornell box at 512 × 512,
 * the benchmark's size (one light sample a pixel: the count does not
 * depend on it).  Cost ~3 s. */
TEST(cache_against_uncached_gather)
{
    rad_solution *s = cornell();
    CHECK(s != NULL);
    if (!s)
        return;
    rad_error err = {0};
    rad_gather_scene *g = NULL;
    CHECK(rad_gather_scene_create(s, &g, &err) == RAD_OK);
    rn_camera cam = scene_camera(s, 48, 48);
    rn_gather_options ref_opt = {.no_cache = 1, .gather_rays = 1024};
    rn_gather_options opt = {.epsilon = 0.1, .gather_rays = 1024};
    rn_gather_stats st;
    rn_image *ref = gather(g, &cam, &ref_opt, NULL, NULL);
    rn_image *a = gather(g, &cam, &opt, NULL, &st);
    CHECK(ref && a);
    if (ref && a) {
        double d = mean_difference(a, ref);
        printf("  cached vs uncached: %.4f mean, %llu gathers for %llu pixels\n", d,
               (unsigned long long)st.gathers, (unsigned long long)st.pixels);
        /* Measured: 0.44 % (0.46 % before R_i was bounded by the
         * gradient; the acceptance asks for 2 %). */
        CHECK_MSG(d < 0.02, "mean difference %.4f", d);
        CHECK(st.cache_hits == st.shading_points); /* pass 2 found every point cached */
        /* Two shading threads draw the same image: each pixel has its own
         * random stream and pass 2 only reads the cache. */
        rn_gather_options two = opt;
        two.threads = 2;
        rn_image *t = gather(g, &cam, &two, NULL, NULL);
        CHECK(t && memcmp(t->pixels, a->pixels, (size_t)48 * 48 * sizeof(float)) == 0);
        rn_image_destroy(t);
    }
    rn_image_destroy(a);
    rn_image_destroy(ref);

    rn_camera big = scene_camera(s, 512, 512);
    rn_gather_options cheap = {.epsilon = 0.1, .light_samples = 1};
    a = gather(g, &big, &cheap, NULL, &st);
    CHECK(a != NULL);
    double share = (double)st.gathers / (double)st.pixels;
    printf("  512x512: %llu gathers, %.4f of the pixels\n", (unsigned long long)st.gathers, share);
    /* Measured: 0.059 (0.048 before R_i was bounded by the gradient; the
     * acceptance asks for 0.10). */
    CHECK_MSG(share <= 0.10, "gathers / pixels = %.4f", share);
    rn_image_destroy(a);
    rad_gather_scene_destroy(g);
}

static int warnings;
static char last_warning[1024];
static void count_warning(void *user, const char *msg)
{
    (void)user;
    warnings++;
    snprintf(last_warning, sizeof last_warning, "%s", msg);
}

/* The cache saved beside the solution: the same view again computes no
 * gather and draws the same image bit for bit; another view computes
 * fewer than it would alone; a relit solution refuses the file with a
 * warning and computes anew.  Cost ~1 s. */
TEST(cache_file_serves_a_second_view)
{
    rad_solution *s = cornell(); /* relit at the end: runs after the other user */
    CHECK(s != NULL);
    if (!s)
        return;
    char path[64];
    snprintf(path, sizeof path, "/tmp/test_gather_%d.icache", (int)getpid());
    unlink(path);
    rad_gather_options opt = {.cache_path = path, .warn = count_warning};
    rn_camera cam = scene_camera(s, 64, 64), cam2 = cam;
    cam2.eye = rad_add(cam.eye, rad_v3(-0.12, -0.08, 0.05));
    rn_image *a = NULL, *b = NULL, *c = NULL, *d = NULL;
    rn_gather_stats s1, s2, s3, s4;
    rad_error err = {0};
    warnings = 0;
    CHECK(rad_render_gather(s, &cam, &opt, &a, &s1, &err) == RAD_OK);
    CHECK(access(path, F_OK) == 0);
    CHECK(rad_render_gather(s, &cam, &opt, &b, &s2, &err) == RAD_OK);
    CHECK(s1.gathers > 100);
    CHECK(s2.gathers == 0);
    CHECK(s2.records_loaded == s1.records);
    if (a && b)
        CHECK(memcmp(a->pixels, b->pixels, (size_t)64 * 64 * a->channels * sizeof(float)) == 0);
    CHECK(rad_render_gather(s, &cam2, &opt, &c, &s3, &err) == RAD_OK);
    rad_gather_options alone = {0};
    CHECK(rad_render_gather(s, &cam2, &alone, &d, &s4, &err) == RAD_OK);
    printf("  view 1: %llu gathers; again: %llu; view 2 with the file: %llu, alone: %llu\n",
           (unsigned long long)s1.gathers, (unsigned long long)s2.gathers,
           (unsigned long long)s3.gathers, (unsigned long long)s4.gathers);
    /* Measured: 732 with the file, 1694 alone (547, 1188 before R_i was
     * bounded by the gradient). */
    CHECK(s3.gathers < 0.7 * s4.gathers);
    CHECK(warnings == 0);

    /* Relit: B changes, so does the key. */
    rad_edit e;
    CHECK(rad_edit_parse(RAD_EDIT_LIGHT, "light=0.5", &e, &err) == RAD_OK);
    CHECK(rad_solution_apply_edits(s, &e, 1, &err) == RAD_OK);
    rad_solve_options so = {0};
    CHECK(rad_resolve(s, &so, &err) == RAD_OK);
    rn_image_destroy(b);
    CHECK(rad_render_gather(s, &cam, &opt, &b, &s2, &err) == RAD_OK);
    CHECK(warnings == 1);
    CHECK_MSG(strstr(last_warning, "made for another solution") != NULL, "%s", last_warning);
    CHECK(s2.records_loaded == 0 && s2.gathers > 100);
    /* A damaged file is refused the same way. */
    FILE *f = fopen(path, "r+b");
    CHECK(f != NULL);
    if (f) {
        fseek(f, 100, SEEK_SET);
        fputc(0x5a, f);
        fclose(f);
    }
    rn_icache *ic = NULL;
    CHECK(rn_icache_read(path, 0, &ic, &err) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(err.message, "checksum mismatch") != NULL, "%s", err.message);
    /* Cut short: refused by its size before anything is allocated. */
    CHECK(truncate(path, 200) == 0);
    CHECK(rn_icache_read(path, 0, &ic, &err) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(err.message, "records need") != NULL, "%s", err.message);
    CHECK(ic == NULL);
    unlink(path);
    rn_image_destroy(a);
    rn_image_destroy(b);
    rn_image_destroy(c);
    rn_image_destroy(d);
}

static rad_solution *mirror_room;

/* A Cornell-like room whose floor is a mirror (metallic 1, roughness 0,
 * ρ_s = 0.9); what a pixel sees in the floor must be 0.9 × what a camera
 * mirrored through the floor's plane sees directly (its image flipped left
 * to right: a reflection is improper).  Both renders share one cache, so
 * the indirect light at a point is the same records' either way.  The
 * mirrored camera looks through the floor's back, which the eye rays pass
 * as the vertex renderer does.  Cost ~0.6 s. */
TEST(mirror_floor_reflects_the_blocks)
{
    static const char text[] =
        "bands 1\n"
        "material wall reflectance 0.6\n"
        "material mirror reflectance 0.9 metallic 1 roughness 0\n"
        "material lamp reflectance 0 emission 30\n" OPEN_ROOM("mirror")
        "group block\n"
        "  polygon top wall 0.3 0.3 0.5  0.3 0.3 0.7  0.5 0.3 0.7  0.5 0.3 0.5 end\n"
        "  polygon face wall 0.3 0 0.5  0.3 0.3 0.5  0.5 0.3 0.5  0.5 0 0.5 end\n"
        "  polygon west wall 0.3 0 0.5  0.3 0 0.7  0.3 0.3 0.7  0.3 0.3 0.5 end\n"
        "  polygon east wall 0.5 0 0.5  0.5 0.3 0.5  0.5 0.3 0.7  0.5 0 0.7 end\n"
        "end\n";
    rad_solution *s = NULL;
    rad_gather_scene *g = prepare(text, 0.1, &s);
    CHECK(g != NULL);
    if (!g) {
        rad_solution_destroy(s);
        return;
    }
    CHECK(s->scene->materials[1].specular[0] == 0.9 && s->scene->materials[1].rho[0] == 0.0);
    rad_error err = {0};
    const uint32_t W = 64;
    rn_camera a = {.eye = rad_v3(0.55, 0.3, -0.3), .target = rad_v3(0.42, 0.02, 0.5),
                   .up = rad_v3(0, 1, 0), .yfov_deg = 50, .width = W, .height = W};
    rn_camera m = a;
    m.eye.y = -a.eye.y;
    m.target.y = -a.target.y;
    m.up = rad_v3(0, -1, 0);
    rn_gather_options opt = {.light_samples = 64};
    rn_icache *cache = NULL;
    CHECK(rn_icache_create(rn_gather_key(&g->scene, &opt), 1, &cache, &err) == RAD_OK);
    rn_image *A = gather(g, &a, &opt, cache, NULL), *M = gather(g, &m, &opt, cache, NULL);
    CHECK(A && M);
    uint32_t floor_o = rad_scene_find_object(s->scene, "floor");
    uint32_t block_o = rad_scene_find_object(s->scene, "block");
    double num = 0, den = 0;
    uint32_t n = 0, blocks = 0;
    for (uint32_t j = 0; A && M && j < W; j++)
        for (uint32_t i = 0; i < W; i++) {
            size_t q = (size_t)j * W + i, r = (size_t)j * W + (W - 1 - i);
            if (A->patch[q] == RAD_NONE || s->mesh->patches[g->cell_patch[A->patch[q]]].object != floor_o ||
                M->patch[r] == RAD_NONE)
                continue;
            num += fabs(A->pixels[q] - 0.9 * M->pixels[r]);
            den += 0.9 * M->pixels[r];
            n++;
            blocks += s->mesh->patches[g->cell_patch[M->patch[r]]].object == block_o;
        }
    printf("  %u mirror pixels, %u of them showing the block; mean difference %.5f\n", n, blocks,
           num / den);
    CHECK(n > 800);
    CHECK(blocks > 100);
    /* Measured: 0.17 %: the direct light's samples differ between the two
     * renders (each pixel has its own random stream). */
    CHECK_MSG(num / den < 0.006, "mean difference %.5f", num / den);
    rn_image_destroy(A);
    rn_image_destroy(M);
    rn_icache_destroy(cache);
    rad_gather_scene_destroy(g);
    mirror_room = s; /* materials_gloss_from_files_and_store writes it */
}

/* A broad glossy floor (roughness 0.6) in the lamp-lit room: its indirect
 * light from Zaninetti & Péroche's light vector (one virtual source from
 * the cache's mean direction) against sampling the lobe with many rays.
 * The two take different code (the lobe's value, and its importance
 * sampling), so an error in either shows.  Cost ~0.5 s. */
TEST(glossy_light_vector_against_lobe_sampling)
{
    static const char buf[] = "bands 1\n"
                              "material wall reflectance 0.5\n"
                              "material satin reflectance 0.5 metallic 0.5 roughness 0.6\n"
                              "material lamp reflectance 0 emission 10\n" CLOSED_ROOM("satin");
    rad_solution *s = NULL;
    rad_gather_scene *g = prepare(buf, 0.125, &s);
    CHECK(g != NULL);
    if (!g) {
        rad_solution_destroy(s);
        return;
    }
    rn_camera cam = scene_camera(s, 48, 48);
    rn_gather_options lv = {.glossy = RN_GLOSSY_LIGHT_VECTOR};
    rn_gather_options sm = {.glossy = RN_GLOSSY_SAMPLE, .glossy_rays = 256};
    rn_image *a = gather(g, &cam, &lv, NULL, NULL), *b = gather(g, &cam, &sm, NULL, NULL);
    CHECK(a && b);
    uint32_t o = rad_scene_find_object(s->scene, "floor");
    double ma, mb;
    if (a && b) {
        object_means(s, a, g->cell_patch, b, o, &ma, &mb);
        printf("  floor: light vector %.5f, lobe sampled %.5f (%+.2f %%)\n", ma, mb,
               100 * (ma - mb) / mb);
        /* Measured: −5.3 %: the light vector puts all the indirect light in
         * one direction, which a lobe this broad (α = 0.36) averages less
         * than it should; the sampled lobe is checked exactly below
         * (glossy_furnace). */
        CHECK_MSG(fabs(ma - mb) < 0.10 * mb, "%.5f vs %.5f", ma, mb);
    }
    rn_image_destroy(a);
    rn_image_destroy(b);
    rad_gather_scene_destroy(g);
    rad_solution_destroy(s);
}

/* glTF metallicFactor / roughnessFactor and the polygon file's keywords
 * give the documented lobe; a scene that names neither stays diffuse; the
 * solution file keeps the lobe (section SURFACE).  Cost ~0.1 s. */
TEST(materials_gloss_from_files_and_store)
{
    static const char fmt[] =
        "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"mesh\":0}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0}]}],"
        "\"materials\":[{\"emissiveFactor\":[1,1,1],"
        "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.4,0.2,1]%s}}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
        "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,"
        "AAAAAAAAAAAAAAAAAAAAAAAAAAAAAIA/AACAPwAAAAAAAAAA\"}]}";
    const char *extra[3] = {"", ",\"roughnessFactor\":0.5", ",\"metallicFactor\":1,\"roughnessFactor\":0.2"};
    /* expected ρ and ρ_s in band 0 (base 0.5), and roughness */
    const double rho[3] = {0.5, 0.5 * 0.96, 0.0}, spec[3] = {0.0, 0.04, 0.5}, rough[3] = {1, 0.5, 0.2};
    for (int k = 0; k < 3; k++) {
        char doc[2048];
        snprintf(doc, sizeof doc, fmt, extra[k]);
        rad_scene *sc = NULL;
        rad_error err = {0};
        int rc = rad_scene_parse_gltf(doc, strlen(doc), "gloss.gltf", NULL, &sc, &err);
        CHECK_MSG(rc == RAD_OK, "%s", err.message);
        if (rc)
            continue;
        CHECK_NEAR(sc->materials[0].rho[0], rho[k], 1e-12);
        CHECK_NEAR(sc->materials[0].specular[0], spec[k], 1e-12);
        CHECK_NEAR(sc->materials[0].roughness, rough[k], 1e-12);
        rad_scene_destroy(sc);
    }
    /* The polygon file: same mapping; out of range refused. */
    rad_scene *sc = NULL;
    rad_error err = {0};
    static const char poly[] = "bands 2\nmaterial m reflectance 0.5 0.3 metallic 0.25 roughness 0.4\n"
                               "material lamp emission 1\n"
                               "polygon p m 0 0 0  0 0 1  1 0 0 end\npolygon l lamp 0 1 0  1 1 0  0 1 1 end\n";
    CHECK(rad_scene_parse_polyfile(poly, strlen(poly), "p.rad", NULL, &sc, &err) == RAD_OK);
    if (sc) {
        CHECK_NEAR(sc->materials[0].rho[1], 0.75 * 0.96 * 0.3, 1e-12);
        CHECK_NEAR(sc->materials[0].specular[1], 0.04 * 0.75 + 0.25 * 0.3, 1e-12);
        CHECK_NEAR(sc->materials[0].roughness, 0.4, 0);
        CHECK(sc->materials[1].roughness == 1.0 && sc->materials[1].specular[0] == 0.0);
        rad_scene_destroy(sc);
    }
    static const char bad[] = "bands 1\nmaterial m reflectance 0.5 roughness 1.5\n";
    CHECK(rad_scene_parse_polyfile(bad, strlen(bad), "bad.rad", NULL, &sc, &err) == RAD_ERR_INVALID);
    CHECK_MSG(strstr(err.message, "roughness 1.5 outside [0, 1]") != NULL, "%s", err.message);

    /* Stored: the mirror room (one glossy material) is written with SURFACE
     * and read back equal. */
    rad_solution *s = mirror_room;
    CHECK(s != NULL);
    if (!s)
        return;
    char path[64];
    snprintf(path, sizeof path, "/tmp/test_gather_%d.sol", (int)getpid());
    CHECK(rad_solution_write(s, path, &err) == RAD_OK);
    rad_solution *r = NULL;
    CHECK_MSG(rad_solution_read(path, &r, &err) == RAD_OK, "%s", err.message);
    if (r) {
        for (uint32_t m = 0; m < s->scene->material_count; m++) {
            CHECK(r->scene->materials[m].specular[0] == s->scene->materials[m].specular[0]);
            CHECK(r->scene->materials[m].roughness == s->scene->materials[m].roughness);
        }
        CHECK(r->scene->materials[1].specular[0] == 0.9 && r->scene->materials[1].roughness == 0.0);
        rad_solution_destroy(r);
    }
    /* version 7 on (8 now): SURFACE in the index, and INFO's last byte announces it
     * (bit 16: a reader that does not know it refuses the file) */
    size_t size = 0;
    unsigned char *b = (unsigned char *)test_slurp(path, &size);
    uint64_t len = 0, ilen = 0;
    size_t surf = b ? test_v6_section(b, size, "SURF", &len) : 0;
    size_t info = b ? test_v6_section(b, size, "INFO", &ilen) : 0;
    CHECK(b && size > 32 && b[8] == 8);
    CHECK(surf > 0 && len > 0);
    CHECK(info > 0 && ilen > 0 && (b[info + ilen - 1] & 16));
    free(b);
    unlink(path);
}

/* ------------------------------------------- hand-built gather scenes */

/* Ward's lobe, written here from the formula (not render/'s code):
 * exp(−tan²δ/α²) / (4π α² sqrt(cosθ_i cosθ_o)). */
static double lobe_ref(rad_vec3 n, rad_vec3 wi, rad_vec3 wo, double a)
{
    double ci = rad_dot(n, wi), co = rad_dot(n, wo);
    if (ci <= 0 || co <= 0)
        return 0;
    rad_vec3 h = rad_normalize(rad_add(wi, wo));
    double c = rad_dot(n, h), t2 = (1 - c * c) / (c * c);
    return exp(-t2 / (a * a)) / (4 * M_PI * a * a * sqrt(ci * co));
}

/* ∫ lobe cosθ_i dω_i for a viewer at θ_o (midpoint rule, 200 × 400: the
 * steps are 1/30 of the lobe's width at α = 0.25). */
static double lobe_albedo(double theta_o, double a)
{
    rad_vec3 n = rad_v3(0, 0, 1), wo = rad_v3(sin(theta_o), 0, cos(theta_o));
    const int T = 200, P = 400;
    double sum = 0;
    for (int i = 0; i < T; i++) {
        double th = (i + 0.5) * (M_PI / 2) / T;
        for (int j = 0; j < P; j++) {
            double ph = (j + 0.5) * 2 * M_PI / P;
            rad_vec3 wi = rad_v3(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
            sum += lobe_ref(n, wi, wo, a) * cos(th) * sin(th);
        }
    }
    return sum * (M_PI / 2 / T) * (2 * M_PI / P);
}

/* A closed unit box, n × n quads a face, facing inward; the floor (y = 0)
 * is material 1, the rest material 0.  Caller owns (rad_mesh_destroy). */
static rad_mesh *box_mesh(uint32_t n)
{
    rad_mesh *m = rad_mesh_alloc(6 * (n + 1) * (n + 1), 6 * n * n);
    if (!m)
        return NULL;
    /* Each face: origin and edges a, b with a × b pointing inward; the
     * floor, ceiling, back, front, left, right. */
    const rad_vec3 O[6] = {{0, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}, {0, 0, 0}, {1, 0, 0}};
    const rad_vec3 A[6] = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const rad_vec3 Bv[6] = {{1, 0, 0}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 1, 0}};
    uint32_t v = 0, p = 0;
    for (int f = 0; f < 6; f++) {
        rad_vec3 a = A[f], b = Bv[f], org = O[f];
        rad_vec3 nrm = rad_normalize(rad_cross(a, b));
        uint32_t base = v;
        for (uint32_t j = 0; j <= n; j++)
            for (uint32_t i = 0; i <= n; i++) {
                m->vertices[v] = rad_add(org, rad_add(rad_scale(a, (double)i / n), rad_scale(b, (double)j / n)));
                m->vertex_boundary[v++] = i == 0 || j == 0 || i == n || j == n;
            }
        for (uint32_t j = 0; j < n; j++)
            for (uint32_t i = 0; i < n; i++) {
                rad_patch *q = &m->patches[p++];
                uint32_t v0 = base + j * (n + 1) + i;
                q->v[0] = v0;
                q->v[1] = v0 + 1;
                q->v[2] = v0 + n + 2;
                q->v[3] = v0 + n + 1;
                q->normal = nrm;
                q->polygon = q->object = (uint32_t)f;
                q->material = f == 0;
                q->area = 1.0 / ((double)n * n);
                q->center = rad_add(org, rad_add(rad_scale(a, (i + 0.5) / n), rad_scale(b, (j + 0.5) / n)));
            }
    }
    return m;
}

/* A white furnace for the gather: a closed box whose every surface has
 * B = 1 and E = 0, so every gather ray returns exactly 1/π and
 * H_indirect = 1 at every point.  Diffuse walls then show exactly ρ/π
 * (cached and uncached); the glossy floor ρ/π + (ρ_s/π) a(θ_o), a the
 * lobe's directional albedo, which the test integrates from the formula
 * itself: the lobe sampling's weights must reproduce it.  Cost ~0.5 s. */
TEST(glossy_furnace)
{
    rad_mesh *m = box_mesh(3);
    CHECK(m != NULL);
    if (!m)
        return;
    /* Faces point inward? The centre of the box must be in front of each. */
    for (uint32_t p = 0; p < m->patch_count; p++)
        CHECK(rad_dot(rad_sub(rad_v3(0.5, 0.5, 0.5), m->patches[p].center), m->patches[p].normal) > 0);
    double *vb = malloc(m->vertex_count * sizeof *vb), *rho = malloc(m->patch_count * sizeof *rho);
    double *E = calloc(m->patch_count, sizeof *E);
    for (uint32_t k = 0; k < m->vertex_count; k++)
        vb[k] = 1.0;
    for (uint32_t k = 0; k < m->patch_count; k++)
        rho[k] = m->patches[k].material ? 0.2 : 0.5;
    const double rough = 0.5, alpha = rough * rough, rs = 0.3;
    rn_material mats[2] = {{{0}, 1.0}, {{rs}, rough}};
    rn_scene sc = {.mesh = m, .bands = 1, .vertex_B = vb, .rho = rho, .emission = E,
                   .materials = mats, .material_count = 2};
    rn_camera cam = {.eye = rad_v3(0.5, 0.8, 0.05), .target = rad_v3(0.5, 0.0, 0.7),
                     .up = rad_v3(0, 1, 0), .yfov_deg = 70, .width = 40, .height = 40};
    /* a(θ_o) tabulated every degree. */
    double table[91];
    for (int d = 0; d <= 90; d++)
        table[d] = lobe_albedo(fmin(d, 89.5) * M_PI / 180, alpha);
    rad_error err = {0};
    for (int cached = 0; cached < 2; cached++) {
        rn_gather_options opt = {.no_cache = !cached, .glossy = RN_GLOSSY_SAMPLE, .glossy_rays = 64,
                                 .gather_rays = 64};
        rn_image *img = NULL;
        CHECK(rn_gather(&sc, &cam, &opt, NULL, &img, NULL, &err) == RAD_OK);
        if (!img)
            continue;
        double worst_wall = 0, sum = 0, ref = 0;
        for (uint32_t j = 0; j < 40; j++)
            for (uint32_t i = 0; i < 40; i++) {
                size_t q = (size_t)j * 40 + i;
                uint32_t c = img->patch[q];
                CHECK(c != RAD_NONE);
                if (c == RAD_NONE)
                    continue;
                if (!m->patches[c].material) {
                    worst_wall = fmax(worst_wall, fabs(img->pixels[q] - 0.5 / M_PI));
                    continue;
                }
                rad_vec3 d = pixel_ray(&cam, i, j);
                double th = acos(-d.y) * 180 / M_PI; /* θ_o at the floor */
                int k = (int)th;
                double a = table[k] + (th - k) * (table[k < 90 ? k + 1 : 90] - table[k]);
                sum += img->pixels[q];
                ref += 0.2 / M_PI + rs / M_PI * a;
            }
        printf("  %s: walls off by %.2g at most; floor %.6f vs %.6f (%+.3f %%)\n",
               cached ? "cached" : "uncached", worst_wall, sum, ref, 100 * (sum - ref) / ref);
        /* Exact but for float pixels: measured 1e-8. */
        CHECK(worst_wall < 1e-6);
        /* Measured: −0.014 % uncached, −0.009 % cached: 64 lobe samples a
         * pixel over ~700 floor pixels. */
        CHECK_MSG(fabs(sum - ref) < 0.001 * ref, "%.6f vs %.6f", sum, ref);
        rn_image_destroy(img);
    }
    free(vb);
    free(rho);
    free(E);
    rad_mesh_destroy(m);
}

/* A point light over a glossy floor: each pixel exactly
 * (ρ/π + ρ_s lobe(ω_i, ω_o)) I cosθ / r², the lobe written in this file.
 * Cost ~0.05 s. */
TEST(glossy_direct_light_of_a_point_light)
{
    static const char text[] =
        "bands 1\n"
        "material floor reflectance 0.4 metallic 0.5 roughness 0.4\n"
        "polygon floor floor -1 0 -1  -1 0 1  1 0 1  1 0 -1 end\n"
        "light bulb point 0.1 0.5 0.2 intensity 2\n"
        "camera top eye 0 0.8 -1.0 target 0 0 0.2 up 0 1 0 fov 60\n";
    rad_solution *s = NULL;
    rad_gather_scene *g = prepare(text, 0.5, &s);
    CHECK(g != NULL);
    if (!g) {
        rad_solution_destroy(s);
        return;
    }
    const rad_material *mt = &s->scene->materials[0];
    double rho = mt->rho[0], rs = mt->specular[0], a = mt->roughness * mt->roughness;
    rn_camera cam = scene_camera(s, 40, 40);
    rn_gather_options opt = {.glossy = RN_GLOSSY_SAMPLE};
    rn_image *img = gather(g, &cam, &opt, NULL, NULL);
    CHECK(img != NULL);
    double worst = 0;
    for (uint32_t j = 0; img && j < 40; j++)
        for (uint32_t i = 0; i < 40; i++) {
            size_t q = (size_t)j * 40 + i;
            if (img->patch[q] == RAD_NONE)
                continue;
            rad_vec3 d = pixel_ray(&cam, i, j);
            rad_vec3 X = rad_add(cam.eye, rad_scale(d, -cam.eye.y / d.y));
            rad_vec3 l = rad_sub(rad_v3(0.1, 0.5, 0.2), X);
            double r2 = rad_dot(l, l);
            rad_vec3 wi = rad_scale(l, 1 / sqrt(r2)), wo = rad_scale(d, -1);
            double L = (rho / M_PI + rs * lobe_ref(rad_v3(0, 1, 0), wi, wo, a)) * 2.0 * wi.y / r2;
            worst = fmax(worst, fabs(img->pixels[q] - L) / L);
        }
    printf("  worst %.3g\n", worst);
    /* Measured: 7e-7 (float hit points); nothing but the floor, so no
     * indirect light. */
    CHECK_MSG(worst < 5e-6, "worst %.3g", worst);
    rn_image_destroy(img);
    rad_gather_scene_destroy(g);
    rad_solution_destroy(s);
}

int main(void)
{
    /* Each in a child of its own (test.h, RUN_ISOLATED), so that no solve
     * forks its hemi-cube workers after an earlier gather started Embree's
     * threads in this process; the last two share mirror_room and run here,
     * the mirror room's solve first, in a process that has gathered nothing. */
    RUN_ISOLATED(lambertian_room_matches_vertex_render);
    RUN_ISOLATED(direct_light_of_a_lamp_and_punctual_lights);
    RUN_ISOLATED(cache_against_uncached_gather);
    RUN_ISOLATED(cache_file_serves_a_second_view);
    RUN_ISOLATED(glossy_light_vector_against_lobe_sampling);
    RUN_ISOLATED(glossy_furnace);
    RUN_ISOLATED(glossy_direct_light_of_a_point_light);
    RUN(mirror_floor_reflects_the_blocks);
    RUN(materials_gloss_from_files_and_store);
    rad_solution_destroy(cornell_box);
    rad_solution_destroy(mirror_room);
    return test_finish("test_gather");
}
