/* cli_render.c - the render command: a stored solution drawn as images.
 * Three ways, one command line:
 *   - one view (a camera of the scene, or --eye/--target), drawn from the
 *     stored B to IMAGE.exr (and --png), cli_render_to_files in cli_args.c;
 *   - many views from one load (--all-cameras, --camera A,B or repeated,
 *     --path FILE, a fly-through), on every CPU, into a directory;
 *   - the final gather (--gather): one view ray-traced from the solution,
 *     with its options, its progress bar and its summary line.
 *
 * Many views: -o names an existing directory; a view of camera NAME becomes
 * NAME.exr and NAME.png (characters other than letters, digits, '.', '_'
 * and '-' replaced by '_'), view k of a path frame-000k.exr and .png (from
 * 1).  Every view and every file name is settled before the first is
 * drawn, so a bad camera or a clash writes nothing; each file is written
 * through a temporary and renamed (rad_output), as any other output.
 * Calls only the shared files (cli_args.c, cli_print.c).
 */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ------------------------------------------------------------ many views */

/* Many views in one render: every camera of the scene, a list of them, or
 * a camera path, drawn on all CPUs from one load. */
typedef struct many_args {
    int all_cameras;    /* --all-cameras */
    const char *path;   /* --path FILE */
    uint32_t threads;   /* --threads N; 0 = one per CPU */
    int no_png;         /* --no-png */
} many_args;

/* 1 consumed, 0 not one of them, -1 bad value (printed). */
static int many_option(int argc, char **argv, int *i, many_args *m)
{
    const char *a = argv[*i];
    const char *val = *i + 1 < argc ? argv[*i + 1] : NULL;
    if (!strcmp(a, "--all-cameras")) {
        m->all_cameras = 1;
        return 1;
    }
    if (!strcmp(a, "--no-png")) {
        m->no_png = 1;
        return 1;
    }
    if (!strcmp(a, "--path")) {
        if (!val)
            return cli_usage_error("--path needs a file"), -1;
        m->path = val;
    } else if (!strcmp(a, "--threads")) {
        if (cli_parse_u32(a, val, 1, 256, &m->threads))
            return -1;
    } else {
        return 0;
    }
    (*i)++;
    return 1;
}

/* 1 when the options ask for many views (a --camera value that lists
 * cameras needs the scene to tell: NULL scene answers for the rest). */
static int many_views(const cli_view *v, const many_args *m, const rad_scene *scene)
{
    if (m->all_cameras || m->path || v->camera_args > 1)
        return 1;
    /* One --camera: a list when it names no camera but its parts might. */
    return scene && v->camera_args == 1 && strchr(v->camera, ',') &&
           rad_scene_find_camera(scene, v->camera) == RAD_NONE;
}

/* Each view's camera and the stem of its files. */
typedef struct view_list {
    rn_camera *cams;
    char (*stem)[256];
    uint32_t count;
} view_list;

static void views_free(view_list *l)
{
    free(l->cams);
    free(l->stem);
}

/* Makes room for n views (count unchanged). */
static int views_reserve(view_list *l, uint32_t n, rad_error *err)
{
    rn_camera *cams = realloc(l->cams, ((size_t)n + 1) * sizeof *cams);
    if (cams)
        l->cams = cams;
    void *stem = cams ? realloc(l->stem, ((size_t)n + 1) * sizeof *l->stem) : NULL;
    if (!stem)
        return rad_fail(err, RAD_ERR_NOMEM, "render: out of memory for %u views", n);
    l->stem = stem;
    return RAD_OK;
}

/* A camera's name as a file stem: letters, digits, '.', '_' and '-' kept,
 * anything else '_', no leading '.'. */
static void safe_stem(const char *name, char *out, size_t size)
{
    size_t n = 0;
    for (const char *p = name; *p && n + 1 < size; p++) {
        char c = *p;
        int keep = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                   c == '_' || c == '-' || (c == '.' && n > 0);
        out[n++] = keep ? c : '_';
    }
    out[n] = '\0';
    if (!n)
        snprintf(out, size, "camera");
}

/* Adds camera `name` of the scene (with the view options' size, up and
 * fov).  A camera named twice is an error: two views, one file. */
static int add_camera(view_list *l, const rad_solution *s, const cli_view *v, const char *name,
                      rad_error *err)
{
    uint32_t w = v->width ? v->width : 512, h = v->height ? v->height : 512;
    rn_camera cam;
    int rc = rad_camera_from_scene(s->scene, name, w, h, &cam, err);
    if (rc)
        return rc;
    if (v->have_up)
        cam.up = v->up;
    if (v->have_fov)
        cam.yfov_deg = v->fov, cam.orthographic = 0;
    if (v->have_ortho)
        cam.orthographic = 1, cam.ymag = v->ortho;
    rad_error why;
    if (rn_camera_check(&cam, &why))
        return rad_fail(err, RAD_ERR_INVALID, "%s: camera '%s': %s", s->scene->source, name,
                        why.message);
    for (uint32_t j = 0; j < l->count; j++)
        if (!strcmp(name, l->stem[j]))
            return rad_fail(err, RAD_ERR_USAGE, "render: camera '%s' named twice", name);
    l->cams[l->count] = cam;
    /* The name for now; turned into a file stem once all are known. */
    snprintf(l->stem[l->count], sizeof l->stem[0], "%s", name);
    l->count++;
    return RAD_OK;
}

/* The cameras named by --camera values: each value one camera, or a list
 * A,B,C when it names none. */
static int named_cameras(view_list *l, const rad_solution *s, const cli_view *v, rad_error *err)
{
    uint32_t most = 0;
    for (uint32_t a = 0; a < v->camera_args; a++) {
        most++;
        for (const char *p = v->cameras[a]; *p; p++)
            most += *p == ',';
    }
    int rc = views_reserve(l, most, err);
    for (uint32_t a = 0; a < v->camera_args && !rc; a++) {
        const char *val = v->cameras[a];
        if (rad_scene_find_camera(s->scene, val) != RAD_NONE || !strchr(val, ',')) {
            rc = add_camera(l, s, v, val, err);
            continue;
        }
        for (const char *p = val; !rc;) {
            const char *comma = strchr(p, ',');
            size_t len = comma ? (size_t)(comma - p) : strlen(p);
            char part[1024];
            if (len >= sizeof part)
                return rad_fail(err, RAD_ERR_USAGE, "--camera: a name longer than %zu characters",
                                sizeof part - 1);
            memcpy(part, p, len);
            part[len] = '\0';
            if (!len)
                return rad_fail(err, RAD_ERR_USAGE, "--camera '%s': an empty name in the list", val);
            rc = add_camera(l, s, v, part, err);
            if (!comma)
                break;
            p = comma + 1;
        }
    }
    return rc;
}

/* Cameras of the scene or the command line: file stems from their names,
 * made distinct (a clash after replacing characters gets "-K", K the
 * view's number). */
static int camera_views(view_list *l, const rad_solution *s, const cli_view *v, const many_args *m,
                        rad_error *err)
{
    int rc;
    if (m->all_cameras) {
        const rad_scene *sc = s->scene;
        if (!sc->camera_count)
            return rad_fail(err, RAD_ERR_USAGE, "%s: --all-cameras: the scene has no cameras",
                            sc->source);
        rc = views_reserve(l, sc->camera_count, err);
        for (uint32_t c = 0; c < sc->camera_count && !rc; c++)
            rc = add_camera(l, s, v, sc->cameras[c].name, err);
    } else {
        rc = named_cameras(l, s, v, err);
    }
    for (uint32_t k = 0; k < l->count && !rc; k++) {
        char stem[256];
        safe_stem(l->stem[k], stem, sizeof stem);
        memcpy(l->stem[k], stem, sizeof stem);
    }
    for (uint32_t k = 0; k < l->count && !rc; k++)
        for (int pass = 0; pass < 2 && !rc; pass++) {
            uint32_t j = 0;
            while (j < k && strcmp(l->stem[j], l->stem[k]))
                j++;
            if (j == k)
                break;
            if (pass)
                rc = rad_fail(err, RAD_ERR_USAGE, "render: views %u and %u would both write '%s'",
                              j + 1, k + 1, l->stem[k]);
            size_t n = strlen(l->stem[k]);
            snprintf(l->stem[k] + (n < 240 ? n : 240), 16, "-%u", k + 1);
        }
    return rc;
}

/* The views of a camera path file: frame-0001, frame-0002, ... */
static int path_views(view_list *l, const cli_view *v, const many_args *m, rad_error *err)
{
    rn_camera base = {.up = v->have_up ? v->up : rad_v3(0, 1, 0),
                      .yfov_deg = v->have_fov ? v->fov : 45.0,
                      .width = v->width ? v->width : 512,
                      .height = v->height ? v->height : 512};
    char *text = NULL;
    size_t size = 0;
    int rc = cli_read_text(m->path, &text, &size, err);
    if (!rc)
        rc = rad_camera_path_parse(text, size, m->path, &base, &l->cams, &l->count, err);
    free(text);
    if (rc)
        return rc;
    l->stem = malloc(((size_t)l->count + 1) * sizeof *l->stem);
    if (!l->stem)
        return rad_fail(err, RAD_ERR_NOMEM, "render: out of memory for %u views", l->count);
    for (uint32_t k = 0; k < l->count; k++)
        snprintf(l->stem[k], sizeof l->stem[0], "frame-%04u", k + 1);
    return RAD_OK;
}

typedef struct sink {
    const char *dir;
    const view_list *views;
    const cli_view *v;
    int png;
    rad_committer *committer; /* syncs and renames the files while the next views draw */
} sink;

/* rad_view_fn: writes view k's files (its own names: threads never meet). */
static int write_view(void *user, uint32_t k, const rn_image *img, rad_error *err)
{
    const sink *w = user;
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.exr", w->dir, w->views->stem[k]);
    int rc = rn_write_exr_later(img, path, w->v->exr_compression, w->committer, err);
    if (!rc && w->png) {
        snprintf(path, sizeof path, "%s/%s.png", w->dir, w->views->stem[k]);
        rc = rn_write_png_later(img, path, w->v->exposure, w->committer, err);
    }
    return rc;
}

/* Draws every view into DIR/NAME.exr (and .png): exit status. */
static int render_many(const rad_solution *s, const cli_view *v, const many_args *m,
                       const char *dir)
{
    if (v->have_eye || v->have_target)
        return cli_usage_error("render: --eye/--target draw one view; a path of them is --path FILE");
    if (v->have_fov && v->have_ortho)
        return cli_usage_error("--fov and --ortho exclude each other");
    if (v->ids)
        return cli_usage_error("render: --ids goes with one view");
    if (v->png)
        return cli_usage_error("render: with several views each PNG goes beside its EXR in '%s' "
                               "(--no-png: none)", dir);
    if ((m->all_cameras || m->path) && v->camera_args)
        return cli_usage_error("render: --camera goes without --all-cameras and --path");
    if (m->all_cameras && m->path)
        return cli_usage_error("render: --all-cameras or --path, not both");
    rad_error err = {0};
    view_list l = {0};
    int rc = m->path ? path_views(&l, v, m, &err) : camera_views(&l, s, v, m, &err);
    if (!rc) /* DIR once the views are known good (mkdir -p) */
        rc = cli_make_dir(dir, &err);
    rad_drawing *d = NULL;
    double t0 = rad_seconds();
    if (!rc)
        rc = rad_drawing_create(s, &d, &err);
    sink w = {dir, &l, v, !m->no_png, NULL};
    if (!rc)
        rc = rad_committer_create(&w.committer, &err);
    if (!rc)
        rc = rad_drawing_views(d, l.cams, l.count, m->threads, write_view, &w, &err);
    /* The files of the views drawn are complete: committed even after a
     * failure, which is the one reported. */
    rad_error cerr = {0};
    int crc = rad_committer_finish(w.committer, &cerr);
    if (!rc && crc) {
        rc = crc;
        err = cerr;
    }
    if (!rc)
        printf("%s: %u view%s %ux%u (%s%s%s)%s, %u thread%s, %.3f s\n", dir, l.count,
               l.count == 1 ? "" : "s", l.cams[0].width, l.cams[0].height, l.stem[0],
               l.count > 1 ? " .. " : "", l.count > 1 ? l.stem[l.count - 1] : "",
               m->no_png ? "" : " with PNGs", rad_view_threads(m->threads, l.count),
               rad_view_threads(m->threads, l.count) == 1 ? "" : "s", rad_seconds() - t0);
    rad_drawing_destroy(d);
    views_free(&l);
    return rc ? cli_error(&err) : 0;
}

/* ---------------------------------------------------------- final gather */

/* The final gather's options (render --gather). */
typedef struct gather_args {
    int on;                    /* --gather */
    const char *given;         /* the first gather option seen (for "needs --gather") */
    rn_gather_options opt;
    const char *cache;         /* --cache FILE; NULL = SOLUTION.icache */
    int no_cache_file;         /* --no-cache-file */
} gather_args;

/* 1 consumed, 0 not a gather option, -1 bad value (printed). */
static int gather_option(int argc, char **argv, int *i, gather_args *g)
{
    const char *a = argv[*i];
    const char *v = *i + 1 < argc ? argv[*i + 1] : NULL;
    rn_gather_options *o = &g->opt;
    int rc = 0, takes = 1;
    if (!strcmp(a, "--gather")) {
        g->on = 1;
        return 1;
    }
    if (!strcmp(a, "--epsilon"))
        rc = cli_parse_double(a, v, 1e-4, 1.0, &o->epsilon);
    else if (!strcmp(a, "--gather-rays"))
        rc = cli_parse_u32(a, v, 8, 1u << 20, &o->gather_rays);
    else if (!strcmp(a, "--light-samples"))
        rc = cli_parse_u32(a, v, 1, 1u << 16, &o->light_samples);
    else if (!strcmp(a, "--glossy-rays"))
        rc = cli_parse_u32(a, v, 1, 1u << 16, &o->glossy_rays);
    else if (!strcmp(a, "--max-depth"))
        rc = cli_parse_u32(a, v, 1, 64, &o->max_depth);
    else if (!strcmp(a, "--min-radius"))
        rc = cli_parse_double(a, v, 1e-3, 1e6, &o->min_radius_px);
    else if (!strcmp(a, "--cache")) {
        if (!v)
            return cli_usage_error("--cache needs a file name"), -1;
        g->cache = v;
    } else if (!strcmp(a, "--glossy")) {
        if (v && !strcmp(v, "auto"))
            o->glossy = RN_GLOSSY_AUTO;
        else if (v && !strcmp(v, "sample"))
            o->glossy = RN_GLOSSY_SAMPLE;
        else if (v && !strcmp(v, "light-vector"))
            o->glossy = RN_GLOSSY_LIGHT_VECTOR;
        else
            return cli_usage_error("--glossy: '%s' is not auto, sample or light-vector",
                                   v ? v : ""), -1;
    } else {
        takes = 0;
        if (!strcmp(a, "--no-cache"))
            o->no_cache = 1;
        else if (!strcmp(a, "--no-cache-file"))
            g->no_cache_file = 1;
        else if (!strcmp(a, "--no-gradients"))
            o->no_gradients = 1;
        else
            return 0;
    }
    if (rc)
        return -1;
    if (!g->given)
        g->given = a;
    *i += takes;
    return 1;
}

/* Progress on stderr, only when stderr is a terminal. */
static void gather_bar(void *user, uint64_t done, uint64_t total)
{
    int *last = user;
    int pct = total ? (int)(100.0 * (double)done / (double)total) : 100;
    if (pct == *last && done != total)
        return;
    *last = pct;
    int filled = pct * 30 / 100;
    fprintf(stderr, "\rgather [%.*s%*s] %3d%%", filled, "##############################",
            30 - filled, "", pct);
    if (done >= total)
        fputc('\n', stderr);
    fflush(stderr);
}

/* The gather render of s (read from sol_path) with the view, to exr_path
 * and v->png; prints one line of statistics. */
static int gather_to_files(const rad_solution *s, const char *sol_path, const cli_view *v,
                           const gather_args *g, const char *exr_path)
{
    rad_error err = {0};
    rn_camera cam;
    int rc = cli_view_camera(s, v, &cam);
    if (rc)
        return rc;
    if (cli_check_output_dir(exr_path) || (v->png && cli_check_output_dir(v->png)))
        return 2;
    char path[4096];
    rad_gather_options opt = {.render = g->opt, .warn = cli_warn};
    if (!g->no_cache_file && !g->opt.no_cache) {
        if (g->cache)
            snprintf(path, sizeof path, "%s", g->cache);
        else
            rad_gather_cache_path(sol_path, path, sizeof path);
        opt.cache_path = path;
    }
    int last = -1;
    if (isatty(STDERR_FILENO)) {
        opt.render.progress = gather_bar;
        opt.render.progress_user = &last;
    }
    rn_image *img = NULL;
    rn_gather_stats st;
    rc = rad_render_gather(s, &cam, &opt, &img, &st, &err);
    if (!rc)
        rc = rn_write_exr_with(img, exr_path, v->exr_compression, &err);
    if (!rc && v->png)
        rc = rn_write_png(img, v->png, v->exposure, &err);
    rn_image_destroy(img);
    if (rc)
        return cli_error(&err);
    printf("gather: %llu pixels in %.2f s: %llu gathers (%.2f %% of pixels), %llu of %llu "
           "shading points from the cache, %llu records (%llu loaded)\n",
           (unsigned long long)st.pixels, st.seconds, (unsigned long long)st.gathers,
           st.pixels ? 100.0 * (double)st.gathers / (double)st.pixels : 0.0,
           (unsigned long long)st.cache_hits, (unsigned long long)st.shading_points,
           (unsigned long long)st.records, (unsigned long long)st.records_loaded);
    return 0;
}

/* ---------------------------------------------------------------- render */

/* render SOLUTION -o OUT: one view, many views or a final gather, as the
 * options say (the solution is read once, without F). */
int cli_render(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    cli_view view = {0};
    many_args many = {0};
    gather_args gather = {0};
    int rc;
    for (int i = 0; i < argc; i++) {
        int r = cli_view_option(argc, argv, &i, &view);
        if (!r)
            r = many_option(argc, argv, &i, &many);
        if (!r)
            r = gather_option(argc, argv, &i, &gather);
        if (r < 0)
            return 2;
        if (r > 0)
            continue;
        if (!strcmp(argv[i], "-o") && i + 1 < argc)
            out = argv[++i];
        else if ((rc = cli_other_arg("render", "solution", argv[i], &in)) != 0)
            return rc;
    }
    if (!in || !out)
        return cli_usage_error("usage: radiosity render SOLUTION -o IMAGE.exr [options]");
    if (gather.given && !gather.on)
        return cli_usage_error("render: %s is a --gather option", gather.given);
    if (many_views(&view, &many, NULL) && gather.on)
        return cli_usage_error("render: --gather draws one view (several views: run it per view)");
    /* --threads: drawing threads for several views, shading threads for a
     * gather (default: one per CPU, as for several views). */
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    gather.opt.threads = many.threads ? many.threads : cpus > 64 ? 64 : cpus > 1 ? (uint32_t)cpus : 1;
    rad_error err = {0};
    rad_solution *s = NULL;
    /* a view needs B, the mesh and the elements: F is neither read nor checked */
    if (rad_solution_read_parts(in, 0, &s, &err))
        return cli_error(&err);
    if (many_views(&view, &many, s->scene))
        rc = gather.on ? cli_usage_error("render: --gather draws one view (several views: run it "
                                         "per view)")
                       : render_many(s, &view, &many, out);
    else if ((many.threads && !gather.on) || many.no_png)
        rc = cli_usage_error("render: --threads and --no-png go with several views "
                             "(--all-cameras, --path or --camera A,B) or, --threads, with --gather");
    else
        rc = gather.on ? gather_to_files(s, in, &view, &gather, out)
                       : cli_render_to_files(s, &view, out, view.png);
    rad_solution_destroy(s);
    return rc;
}
