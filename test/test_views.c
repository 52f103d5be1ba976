/* test_views.c - many views from one drawing (issue 21).
 *   - views drawn on several threads, each into a canvas it reuses across
 *     sizes, are bit for bit the images rad_render_solution draws one at a
 *     time (pixels and patch ids), with elements (ids mapped back to
 *     patches) and without;
 *   - a sink's failure is the run's, and no view starts after it; a bad
 *     camera fails before any view is drawn;
 *   - camera paths: defaults, comments, overrides, and every error names
 *     its line.
 * Cost: one solve of ~60 patches (with one level of elements) and a dozen
 * small images, ~0.3 s.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char room[] =
    "bands 3\n"
    "material white reflectance 0.6 0.5 0.4\n"
    "material red reflectance 0.6 0.1 0.1\n"
    "material lamp reflectance 0 emission 10 10 10\n"
    "polygon floor white subdivide 5 5\n 0 0 0\n 0 0 1\n 1 0 1\n 1 0 0\nend\n"
    "polygon left red subdivide 4 4\n 0 0 0\n 0 1 0\n 0 1 1\n 0 0 1\nend\n"
    "polygon back white subdivide 4 4\n 0 0 1\n 0 1 1\n 1 1 1\n 1 0 1\nend\n"
    "polygon lamp lamp subdivide 1 1\n 0.4 0.99 0.4\n 0.6 0.99 0.4\n 0.6 0.99 0.6\n 0.4 0.99 0.6\nend\n";

enum { VIEWS = 7 };

/* Views from in front of the open side, of three sizes in no order, so a
 * thread's canvas is drawn over and reallocated. */
static void cameras(rn_camera *cams)
{
    static const uint32_t size[VIEWS][2] = {{64, 48}, {80, 80}, {64, 48}, {33, 65},
                                            {80, 80}, {64, 48}, {33, 65}};
    for (int k = 0; k < VIEWS; k++)
        cams[k] = (rn_camera){.eye = rad_v3(0.2 + 0.1 * k, 0.5, -1.2 - 0.05 * k),
                              .target = rad_v3(0.5, 0.45, 0.5),
                              .up = rad_v3(0, 1, 0),
                              .yfov_deg = 50,
                              .width = size[k][0],
                              .height = size[k][1]};
}

/* What the sink keeps: a copy of each view, written by the thread that
 * drew it (slots of their own: no lock). */
typedef struct kept {
    rn_image *img[VIEWS];
    int calls[VIEWS];
    pthread_t thread[VIEWS];
    uint32_t fail_at; /* the view whose sink fails, or VIEWS */
} kept;

static int keep(void *user, uint32_t k, const rn_image *img, rad_error *err)
{
    kept *kp = user;
    kp->calls[k]++;
    kp->thread[k] = pthread_self();
    if (k == kp->fail_at)
        return rad_fail(err, RAD_ERR_IO, "view %u: disk full", k);
    rn_image *c = calloc(1, sizeof *c);
    size_t n = (size_t)img->width * img->height;
    *c = (rn_image){img->width, img->height, img->channels,
                    malloc(n * img->channels * sizeof(float)), malloc(n * sizeof(uint32_t))};
    memcpy(c->pixels, img->pixels, n * img->channels * sizeof(float));
    memcpy(c->patch, img->patch, n * sizeof(uint32_t));
    kp->img[k] = c;
    return RAD_OK;
}

/* The room solved at R = 32, with `levels` uniform element levels. */
static rad_solution *solve_room(uint32_t levels)
{
    rad_solve_options opt = {0};
    opt.hemicube.resolution = 32;
    opt.element_levels = levels;
    rad_solution *s = test_solve_text(room, "room.rad", &opt);
    CHECK(s != NULL && (levels == 0) == (s->elements == NULL));
    return s;
}

static void same_as_one_at_a_time(const rad_solution *s, uint32_t threads)
{
    rn_camera cams[VIEWS];
    cameras(cams);
    rad_error err = {0};
    rad_drawing *d = NULL;
    CHECK(rad_drawing_create(s, &d, &err) == RAD_OK);
    kept kp = {.fail_at = VIEWS};
    CHECK_MSG(rad_drawing_views(d, cams, VIEWS, threads, keep, &kp, &err) == RAD_OK, "%s",
              err.message);
    int threads_seen = 0;
    for (int k = 0; k < VIEWS; k++) {
        CHECK(kp.calls[k] == 1);
        int first = 1;
        for (int j = 0; j < k; j++)
            first &= !pthread_equal(kp.thread[j], kp.thread[k]);
        threads_seen += first;
        rn_image *ref = NULL;
        CHECK(rad_render_solution(s, &cams[k], &ref, &err) == RAD_OK);
        rn_image *got = kp.img[k];
        CHECK(ref && got && got->width == ref->width && got->height == ref->height &&
              got->channels == ref->channels);
        if (ref && got && got->width == ref->width && got->height == ref->height) {
            size_t n = (size_t)ref->width * ref->height, lit = 0, max_id = 0;
            CHECK(!memcmp(got->pixels, ref->pixels, n * ref->channels * sizeof(float)));
            CHECK(!memcmp(got->patch, ref->patch, n * sizeof(uint32_t)));
            for (size_t q = 0; q < n; q++)
                if (ref->patch[q] != RAD_NONE) {
                    lit++;
                    max_id = ref->patch[q] > max_id ? ref->patch[q] : max_id;
                }
            /* the views see the room, and the ids are patches (not cells) */
            CHECK_MSG(lit > n / 5 && max_id < s->mesh->patch_count, "lit %zu of %zu, id %zu", lit, n, max_id);
        }
        rn_image_destroy(ref);
        rn_image_destroy(got);
    }
    /* Up to `threads` threads drew (the caller's among them). */
    CHECK(threads_seen >= 1 && threads_seen <= (int)threads);
    rad_drawing_destroy(d);
}

TEST(threads_draw_what_one_view_at_a_time_draws)
{
    rad_solution *s = solve_room(0);
    if (!s)
        return;
    same_as_one_at_a_time(s, 3);
    same_as_one_at_a_time(s, 1);
    rad_solution_destroy(s);
}

TEST(elements_draw_the_same_on_threads)
{
    rad_solution *s = solve_room(1);
    if (!s)
        return;
    same_as_one_at_a_time(s, 2);
    rad_solution_destroy(s);
}

TEST(a_failed_view_stops_the_run)
{
    rad_solution *s = solve_room(0);
    if (!s)
        return;
    rn_camera cams[VIEWS];
    cameras(cams);
    rad_error err = {0};
    rad_drawing *d = NULL;
    CHECK(rad_drawing_create(s, &d, &err) == RAD_OK);
    /* One thread: views run in order, so none after the failed one. */
    kept kp = {.fail_at = 2};
    CHECK(rad_drawing_views(d, cams, VIEWS, 1, keep, &kp, &err) == RAD_ERR_IO);
    CHECK(strstr(err.message, "view 2: disk full") != NULL);
    CHECK(kp.calls[0] == 1 && kp.calls[1] == 1 && kp.calls[2] == 1);
    for (int k = 3; k < VIEWS; k++)
        CHECK(kp.calls[k] == 0);
    for (int k = 0; k < VIEWS; k++)
        rn_image_destroy(kp.img[k]);

    /* A bad camera (up along the view) fails before any view is drawn. */
    cams[4].up = rad_sub(cams[4].target, cams[4].eye);
    kept none = {.fail_at = VIEWS};
    CHECK(rad_drawing_views(d, cams, VIEWS, 2, keep, &none, &err) == RAD_ERR_USAGE);
    CHECK_MSG(strstr(err.message, "view 5:") && strstr(err.message, "parallel"), "%s", err.message);
    for (int k = 0; k < VIEWS; k++)
        CHECK(none.calls[k] == 0);
    rad_drawing_destroy(d);
    rad_solution_destroy(s);
}

TEST(camera_paths)
{
    const rn_camera base = {.up = rad_v3(0, 0, 1), .yfov_deg = 30, .width = 40, .height = 20};
    const char good[] = "# a fly-through\n"
                        "eye 1,2,3 target 0,0,0\n"
                        "\n"
                        "   \t\n"
                        "target 0,0,1e-3 eye -1,2.5,3   # any order\n"
                        "eye 1,2,3 target 0,0,0 up 0,1,0 fov 60";
    rn_camera *cams = NULL;
    uint32_t n = 0;
    rad_error err = {0};
    CHECK_MSG(rad_camera_path_parse(good, strlen(good), "fly.txt", &base, &cams, &n, &err) == RAD_OK,
              "%s", err.message);
    CHECK(n == 3);
    if (n == 3) {
        CHECK(cams[0].eye.x == 1 && cams[0].eye.y == 2 && cams[0].eye.z == 3);
        CHECK(cams[0].up.z == 1 && cams[0].yfov_deg == 30 && cams[0].width == 40 &&
              cams[0].height == 20);
        CHECK(cams[1].eye.x == -1 && cams[1].eye.y == 2.5 && cams[1].target.z == 1e-3);
        CHECK(cams[2].up.y == 1 && cams[2].up.z == 0 && cams[2].yfov_deg == 60);
    }
    free(cams);

    struct {
        const char *text, *message;
    } bad[] = {
        {"eye 1,2,3 target 0,0,0\nlook 1,1,1\n", "fly.txt: line 2: 'look' is not eye, target, up or fov"},
        {"eye 1,2,3\n", "fly.txt: line 1: a view needs both eye and target"},
        {"\n\neye 1,2 target 0,0,0\n", "fly.txt: line 3: eye '1,2' is not X,Y,Z"},
        {"eye 1,2,3,4 target 0,0,0\n", "fly.txt: line 1: eye '1,2,3,4' is not X,Y,Z"},
        {"eye 1,2,3 target 1,2,3\n", "fly.txt: line 1: eye and target coincide"},
        {"eye 1,2,3 target 0,0,0 eye 0,0,1\n", "fly.txt: line 1: eye given twice"},
        {"eye 1,2,3 target 0,0,0 fov\n", "fly.txt: line 1: fov needs a value"},
        {"eye 1,2,3 target 0,0,0 fov 180\n", "fly.txt: line 1: field of view 180 not in (0, 180)"},
        {"eye 0,0,1 target 0,0,0\n", "fly.txt: line 1: up vector parallel to the view direction"},
        {"eye nan,0,1 target 0,0,0\n", "fly.txt: line 1: eye 'nan,0,1' is not X,Y,Z"},
        {"# nothing\n\n", "fly.txt: no views"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        cams = NULL;
        int rc = rad_camera_path_parse(bad[k].text, strlen(bad[k].text), "fly.txt", &base, &cams,
                                       &n, &err);
        CHECK_MSG(rc != RAD_OK && cams == NULL && n == 0, "case %zu", k);
        CHECK_MSG(strstr(err.message, bad[k].message) == err.message, "case %zu: '%s'", k,
                  err.message);
    }
}

int main(void)
{
    RUN(threads_draw_what_one_view_at_a_time_draws);
    RUN(elements_draw_the_same_on_threads);
    RUN(a_failed_view_stops_the_run);
    RUN(camera_paths);
    return test_finish("test_views");
}
