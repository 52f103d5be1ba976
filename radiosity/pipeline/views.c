/* views.c - drawing a stored solution: once prepared, any number of views.
 *
 * What every view of a solution shares is computed once, by
 * rad_drawing_create: the mesh drawn (the elements' crack-free fans, or the
 * patches; a mesh with clusters is drawn as its cells, level-0 elements)
 * and its vertex radiosities (the paper's vertex averages; the
 * quadratic fit on elements).  A view is then only the item buffer and the
 * interpolation (rn_canvas_draw), and views are independent, so
 * rad_drawing_views hands them out to threads, each drawing into a canvas
 * of its own and passing the image to the caller's sink (which writes it)
 * while the other threads draw on.
 *
 * Invariant: a drawing is never written after rad_drawing_create, so
 * threads share it without locks; the only shared state of a run of views
 * is the next view to hand out and the first failure, under one mutex.
 * Also here: camera paths (fly-throughs), one view per line of text.
 */
#include "pipeline.h"

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

struct rad_drawing {
    const rad_mesh *mesh; /* drawn: cells, or the solution's patches */
    rad_mesh *cells;      /* the elements' fans (owned), NULL without elements */
    uint32_t *patch_of;   /* cells: the patch each cell lies in (owned), else NULL */
    double *vertex_B;     /* mesh->vertex_count × bands (owned) */
    uint32_t bands;
};

int rad_drawing_create(const rad_solution *s, rad_drawing **out, rad_error *err)
{
    *out = NULL;
    rad_drawing *d = calloc(1, sizeof *d);
    if (!d)
        return rad_fail(err, RAD_ERR_NOMEM, "render: out of memory");
    d->mesh = s->mesh;
    d->bands = s->band_count;
    uint32_t *cell_element = NULL;
    const rad_elements *el = s->elements;
    rad_elements *of_cells = NULL;
    int rc = RAD_OK;
    /* Clusters without elements: drawn as their cells, level-0 elements. */
    if (!el && s->mesh->cell_first) {
        rc = rad_elements_of_cells(s, &of_cells, err);
        if (rc != RAD_OK)
            goto fail;
        el = of_cells;
    }
    if (el) {
        /* Elements: the crack-free mesh of their cells. */
        rc = rad_elements_render_mesh(el, &d->cells, &cell_element, err);
        if (rc != RAD_OK)
            goto fail;
        d->mesh = d->cells;
        d->patch_of = malloc(((size_t)d->cells->patch_count + 1) * sizeof *d->patch_of);
        if (!d->patch_of) {
            rc = rad_fail(err, RAD_ERR_NOMEM, "render: out of memory");
            goto fail;
        }
        for (uint32_t c = 0; c < d->cells->patch_count; c++)
            d->patch_of[c] = el->patch[cell_element[c]];
    }
    /* What each element (or patch) is drawn with - its B, buried ones
     * extrapolated from their seen neighbours - fitted to the vertices. */
    d->vertex_B = malloc(((size_t)d->mesh->vertex_count * d->bands + 1) * sizeof *d->vertex_B);
    if (!d->vertex_B) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "render: out of memory");
        goto fail;
    }
    rc = rad_elements_vertex_radiosity(s, el, d->mesh, cell_element, NULL, d->vertex_B, err);
    if (rc != RAD_OK)
        goto fail;
    free(cell_element);
    rad_element_store_destroy(of_cells);
    *out = d;
    return RAD_OK;
fail:
    free(cell_element);
    rad_element_store_destroy(of_cells);
    rad_drawing_destroy(d);
    return rc;
}

void rad_drawing_destroy(rad_drawing *d)
{
    if (!d)
        return;
    rad_mesh_destroy(d->cells);
    free(d->patch_of);
    free(d->vertex_B);
    free(d);
}

void rad_drawing_parts(const rad_drawing *d, const rad_mesh **mesh, const double **vertex_B,
                       const uint32_t **patch_of)
{
    *mesh = d->mesh;
    *vertex_B = d->vertex_B;
    *patch_of = d->patch_of;
}

/* The image names patches, whatever was drawn. */
static void name_patches(const rad_drawing *d, rn_image *img)
{
    if (!d->patch_of)
        return;
    uint32_t *id = img->patch;
    for (size_t q = 0; q < (size_t)img->width * img->height; q++)
        if (id[q] != RAD_NONE)
            id[q] = d->patch_of[id[q]];
}

int rad_drawing_draw(const rad_drawing *d, rn_canvas *c, const rn_camera *cam, rn_image **out,
                     rad_error *err)
{
    int rc = rn_canvas_draw(c, d->mesh, d->bands, d->vertex_B, cam, out, err);
    if (!rc)
        name_patches(d, *out);
    return rc;
}

int rad_render_solution(const rad_solution *s, const rn_camera *cam, rn_image **out,
                        rad_error *err)
{
    *out = NULL;
    rad_drawing *d = NULL;
    int rc = rad_drawing_create(s, &d, err);
    if (!rc)
        rc = rn_render(d->mesh, d->bands, d->vertex_B, cam, out, err);
    if (!rc)
        name_patches(d, *out);
    rad_drawing_destroy(d);
    return rc;
}

/* ------------------------------------------------------- many views at once */

/* One run of rad_drawing_views: what the threads share. */
typedef struct views_run {
    const rad_drawing *d;
    const rn_camera *cams;
    uint32_t count;
    rad_view_fn done;
    void *user;
    pthread_mutex_t lock;
    uint32_t next;       /* the next view to hand out */
    int rc;              /* the failure of the lowest view that failed, RAD_OK */
    uint32_t failed;     /* that view, count while none did */
    rad_error err;       /* its message */
} views_run;

static void *views_worker(void *arg)
{
    views_run *r = arg;
    rn_canvas *canvas = rn_canvas_create();
    rad_error err = {0};
    for (;;) {
        pthread_mutex_lock(&r->lock);
        /* After a failure no view starts: the run ends as soon as it can. */
        uint32_t k = r->rc ? r->count : r->next;
        if (k < r->count)
            r->next++;
        pthread_mutex_unlock(&r->lock);
        if (k >= r->count)
            break;
        rn_image *img = NULL;
        int rc = canvas ? rad_drawing_draw(r->d, canvas, &r->cams[k], &img, &err)
                        : rad_fail(&err, RAD_ERR_NOMEM, "render: out of memory for a canvas");
        if (!rc && r->done)
            rc = r->done(r->user, k, img, &err);
        if (rc) {
            pthread_mutex_lock(&r->lock);
            if (!r->rc || k < r->failed) {
                r->rc = rc;
                r->failed = k;
                r->err = err;
            }
            pthread_mutex_unlock(&r->lock);
        }
    }
    rn_canvas_destroy(canvas);
    return NULL;
}

/* One thread per CPU.  A view's files are synced and renamed by the
 * committer thread (rad_committer), so no drawing thread waits for the
 * disk, and each extra thread would cost a canvas (24 MB at 1024², faulted
 * in on its first view: report/views.md). */
uint32_t rad_view_threads(uint32_t threads, uint32_t views)
{
    if (!threads) {
        long cpus = sysconf(_SC_NPROCESSORS_ONLN);
        threads = cpus > 0 ? (uint32_t)(cpus < 256 ? cpus : 256) : 1;
    }
    if (threads > views)
        threads = views;
    return threads ? threads : 1;
}

int rad_drawing_views(const rad_drawing *d, const rn_camera *cams, uint32_t count,
                      uint32_t threads, rad_view_fn done, void *user, rad_error *err)
{
    if (!d || (count && !cams))
        return rad_fail(err, RAD_ERR_USAGE, "render: no drawing or no cameras");
    /* Every camera is checked before any view is drawn. */
    for (uint32_t k = 0; k < count; k++) {
        rad_error why;
        if (rn_camera_check(&cams[k], &why))
            return rad_fail(err, RAD_ERR_USAGE, "render: view %u: %s", k + 1, why.message);
    }
    views_run r = {.d = d, .cams = cams, .count = count, .done = done, .user = user,
                   .failed = count};
    if (pthread_mutex_init(&r.lock, NULL))
        return rad_fail(err, RAD_ERR_NOMEM, "render: cannot create a mutex");
    uint32_t n = rad_view_threads(threads, count);
    pthread_t *tid = malloc(n * sizeof *tid);
    uint32_t started = 0;
    /* This thread draws too; extra threads that cannot start leave their
     * views to the others. */
    while (tid && started + 1 < n && pthread_create(&tid[started], NULL, views_worker, &r) == 0)
        started++;
    views_worker(&r);
    for (uint32_t t = 0; t < started; t++)
        pthread_join(tid[t], NULL);
    free(tid);
    pthread_mutex_destroy(&r.lock);
    if (r.rc && err)
        *err = r.err;
    return r.rc;
}

/* -------------------------------------------------------------- camera paths */

/* One "X,Y,Z" token into *v: exactly three finite numbers. */
static int parse_point(const char *tok, rad_vec3 *v)
{
    double c[3];
    const char *p = tok;
    for (int k = 0; k < 3; k++) {
        char *end;
        errno = 0;
        c[k] = strtod(p, &end);
        if (end == p || errno || !isfinite(c[k]))
            return -1;
        p = end;
        if (k < 2 && *p++ != ',')
            return -1;
    }
    if (*p)
        return -1;
    *v = rad_v3(c[0], c[1], c[2]);
    return 0;
}

/* Parses one line (NUL-terminated, comment removed) into *cam, *got = 1
 * (0 for a blank line). */
static int parse_view(char *line, const char *name, uint32_t lno, const rn_camera *base,
                      rn_camera *cam, int *got, rad_error *err)
{
    *cam = *base;
    *got = 0;
    int have_eye = 0, have_target = 0, have_up = 0, have_fov = 0, words = 0;
    char *save = NULL;
    for (char *key = strtok_r(line, " \t\r", &save); key; key = strtok_r(NULL, " \t\r", &save)) {
        words++;
        char *val = strtok_r(NULL, " \t\r", &save);
        int *seen = !strcmp(key, "eye")      ? &have_eye
                    : !strcmp(key, "target") ? &have_target
                    : !strcmp(key, "up")     ? &have_up
                    : !strcmp(key, "fov")    ? &have_fov
                                             : NULL;
        if (!seen)
            return rad_fail(err, RAD_ERR_PARSE,
                            "%s: line %u: '%s' is not eye, target, up or fov", name, lno, key);
        if (*seen)
            return rad_fail(err, RAD_ERR_PARSE, "%s: line %u: %s given twice", name, lno, key);
        *seen = 1;
        if (!val)
            return rad_fail(err, RAD_ERR_PARSE, "%s: line %u: %s needs a value", name, lno, key);
        if (seen == &have_fov) {
            char *end;
            errno = 0;
            cam->yfov_deg = strtod(val, &end);
            if (end == val || *end || errno)
                return rad_fail(err, RAD_ERR_PARSE, "%s: line %u: fov '%s' is not a number", name,
                                lno, val);
            continue;
        }
        rad_vec3 *v = seen == &have_eye ? &cam->eye : seen == &have_target ? &cam->target : &cam->up;
        if (parse_point(val, v))
            return rad_fail(err, RAD_ERR_PARSE, "%s: line %u: %s '%s' is not X,Y,Z", name, lno,
                            key, val);
    }
    if (!words)
        return RAD_OK;
    if (!have_eye || !have_target)
        return rad_fail(err, RAD_ERR_PARSE, "%s: line %u: a view needs both eye and target", name,
                        lno);
    rad_error why;
    if (rn_camera_check(cam, &why))
        return rad_fail(err, RAD_ERR_INVALID, "%s: line %u: %s", name, lno, why.message);
    *got = 1;
    return RAD_OK;
}

int rad_camera_path_parse(const char *text, size_t size, const char *name, const rn_camera *base,
                          rn_camera **out, uint32_t *count, rad_error *err)
{
    *out = NULL;
    *count = 0;
    rn_camera *cams = NULL;
    uint32_t n = 0, cap = 0;
    char line[1024];
    int rc = RAD_OK;
    rad_lines lines;
    rad_line ln;
    rad_lines_start(&lines, text, size);
    while (!rc && rad_lines_next(&lines, &ln)) {
        const uint32_t lno = (uint32_t)ln.number;
        if (ln.length >= sizeof line) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: longer than %zu characters", name, lno,
                          sizeof line - 1);
            break;
        }
        if (memchr(ln.text, '\0', ln.length)) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: a NUL byte (not a text file)", name, lno);
            break;
        }
        memcpy(line, ln.text, ln.content); /* the comment cut off */
        line[ln.content] = '\0';
        rn_camera cam;
        int got = 0;
        rc = parse_view(line, name, lno, base, &cam, &got, err);
        if (rc || !got)
            continue;
        if (n == cap) {
            if (cap >= 100000000u) {
                rc = rad_fail(err, RAD_ERR_LIMIT, "%s: more than %u views", name, cap);
                break;
            }
            cap = cap ? 2 * cap : 64;
            rn_camera *grown = realloc(cams, (size_t)cap * sizeof *grown);
            if (!grown) {
                rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", name);
                break;
            }
            cams = grown;
        }
        cams[n++] = cam;
    }
    if (!rc && n == 0)
        rc = rad_fail(err, RAD_ERR_PARSE, "%s: no views (lines 'eye X,Y,Z target X,Y,Z')", name);
    if (rc) {
        free(cams);
        return rc;
    }
    *out = cams;
    *count = n;
    return RAD_OK;
}
