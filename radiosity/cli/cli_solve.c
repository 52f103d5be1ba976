/* cli_solve.c - the solve and render commands: a scene becomes a stored
 * solution, a solution becomes images.  (report is in cli_report.c.)
 */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ------------------------------------------------------------------ views */

int cli_view_option(int argc, char **argv, int *i, cli_view *v)
{
    const char *a = argv[*i];
    const char *val = *i + 1 < argc ? argv[*i + 1] : NULL;
    int rc = 0;
    if (!strcmp(a, "--camera")) {
        if (!val)
            return cli_usage_error("--camera needs a name"), -1;
        if (v->camera_args == CLI_MAX_CAMERA_ARGS)
            return cli_usage_error("--camera given more than %d times (list cameras as A,B,C)",
                                   CLI_MAX_CAMERA_ARGS), -1;
        v->camera = v->cameras[v->camera_args++] = val;
    } else if (!strcmp(a, "--eye")) {
        rc = cli_parse_vec3(a, val, &v->eye), v->have_eye = 1;
    } else if (!strcmp(a, "--target")) {
        rc = cli_parse_vec3(a, val, &v->target), v->have_target = 1;
    } else if (!strcmp(a, "--up")) {
        rc = cli_parse_vec3(a, val, &v->up), v->have_up = 1;
    } else if (!strcmp(a, "--fov")) {
        rc = cli_parse_double(a, val, 0.01, 179.99, &v->fov), v->have_fov = 1;
    } else if (!strcmp(a, "--ortho")) {
        rc = cli_parse_double(a, val, 1e-12, 1e12, &v->ortho), v->have_ortho = 1;
    } else if (!strcmp(a, "--size")) {
        unsigned w, h;
        char tail;
        if (!val || sscanf(val, "%ux%u%c", &w, &h, &tail) != 2 || w < 1 || h < 1 || w > 16384 ||
            h > 16384)
            return cli_usage_error("--size: '%s' is not WxH (1..16384 each)", val ? val : ""), -1;
        v->width = w, v->height = h;
    } else if (!strcmp(a, "--png")) {
        if (!val)
            return cli_usage_error("--png needs a file name"), -1;
        v->png = val;
    } else if (!strcmp(a, "--exposure")) {
        rc = cli_parse_double(a, val, -64, 64, &v->exposure);
    } else if (!strcmp(a, "--exr-compression")) {
        if (rn_exr_compression_parse(val, &v->exr_compression))
            return cli_usage_error("--exr-compression: '%s' is not none, zip, rle or piz",
                                   val ? val : ""), -1;
    } else {
        return 0;
    }
    if (rc)
        return -1;
    (*i)++;
    return 1;
}

int cli_view_camera(const rad_solution *s, const cli_view *v, rn_camera *out)
{
    rad_error err = {0};
    rn_camera cam;
    uint32_t w = v->width ? v->width : 512, h = v->height ? v->height : 512;
    if (v->have_fov && v->have_ortho)
        return cli_usage_error("--fov and --ortho exclude each other");
    if (v->have_eye || v->have_target) {
        if (!v->have_eye || !v->have_target)
            return cli_usage_error("--eye and --target go together");
        if (v->camera)
            return cli_usage_error("--camera and --eye/--target exclude each other");
        cam = (rn_camera){.eye = v->eye, .target = v->target,
                          .up = v->have_up ? v->up : rad_v3(0, 1, 0),
                          .yfov_deg = v->have_fov ? v->fov : 45.0, .width = w, .height = h};
    } else {
        if (rad_camera_from_scene(s->scene, v->camera, w, h, &cam, &err))
            return cli_error(&err);
        if (v->have_up)
            cam.up = v->up;
        if (v->have_fov) /* a field of view makes any camera perspective */
            cam.yfov_deg = v->fov, cam.orthographic = 0;
    }
    if (v->have_ortho)
        cam.orthographic = 1, cam.ymag = v->ortho;
    *out = cam;
    return 0;
}

int cli_render_to_files(const rad_solution *s, const cli_view *v, const char *exr_path,
                        const char *png_path)
{
    rad_error err = {0};
    rn_camera cam;
    int rc = cli_view_camera(s, v, &cam);
    if (rc)
        return rc;
    if (cli_check_output_dir(exr_path) || (png_path && cli_check_output_dir(png_path)))
        return 2;
    rn_image *img = NULL;
    rc = rad_render_solution(s, &cam, &img, &err);
    if (!rc)
        rc = rn_write_exr_with(img, exr_path, v->exr_compression, &err);
    if (!rc && png_path)
        rc = rn_write_png(img, png_path, v->exposure, &err);
    rn_image_destroy(img);
    return rc ? cli_error(&err) : 0;
}

/* ------------------------------------------------------------------ solve */

typedef struct preview_state {
    const char *dir;
    cli_view view;
    int failed;
} preview_state;

/* Writes DIR/preview-NNNNNN.png of the progressive estimate. */
static int write_preview(void *user, const rad_solution *s, uint32_t shots, const double *B)
{
    preview_state *ps = user;
    rad_solution view = *s; /* shallow: only B differs */
    view.B = (double *)B;
    char exr[4096], png[4096];
    snprintf(exr, sizeof exr, "%s/preview-%06u.exr", ps->dir, shots);
    snprintf(png, sizeof png, "%s/preview-%06u.png", ps->dir, shots);
    if (cli_render_to_files(&view, &ps->view, exr, png)) {
        ps->failed = 1;
        return 1; /* stop the solve */
    }
    return 0;
}

/* What a solve that stopped early tells the user: the rows it kept and how
 * to go on.  Returns the exit status: 130 after Ctrl-C (or SIGTERM), else
 * the error's.  A matrix refused as too large (RAD_ERR_LIMIT, after the
 * estimate's sample rows) gets its one line only: the same command would
 * be refused again; its rows stay and a run with a larger --max-memory
 * resumes from them (a larger --patch-size is another mesh: discarded). */
static int solve_stopped(rad_journal *j, const rad_error *err, int rc)
{
    rad_journal_stats st = rad_journal_stats_of(j);
    if ((cli_stop || rc == RAD_ERR_INTERRUPTED) && st.kept)
        fprintf(stderr, "radiosity: interrupted: %u form-factor rows kept in %s; run the same "
                        "command again to resume\n", st.kept, rad_journal_path(j));
    else if (cli_stop || rc == RAD_ERR_INTERRUPTED)
        fprintf(stderr, "radiosity: interrupted before any form-factor row was finished\n");
    else {
        cli_error(err);
        if (st.kept && rc != RAD_ERR_LIMIT)
            fprintf(stderr, "radiosity: note: %u form-factor rows kept in %s; run the same "
                            "command again to resume from them\n", st.kept, rad_journal_path(j));
    }
    rad_journal_close(j);
    return (cli_stop || rc == RAD_ERR_INTERRUPTED) ? 130 : cli_error_status(err);
}

/* The solve's summary lines. */
static void solve_summary(const char *out, const rad_solution *s, const rad_journal_stats *st,
                          double store)
{
    printf("%s: %u patches, %u bands, %llu rows computed (R = %u), %s: %u iterations, residual %.3g\n",
           out, s->mesh->patch_count, s->band_count, (unsigned long long)s->rows_computed,
           s->resolution, s->solver, s->iterations, s->residual);
    if (st->resumed || st->torn_bytes)
        printf("resumed: %u rows kept by an interrupted run (%llu bytes of an unfinished row "
               "dropped)\n", st->resumed, (unsigned long long)st->torn_bytes);
    if (st->discarded)
        printf("discarded: %u rows kept by a run of other inputs or options\n", st->discarded);
    if (s->progress)
        printf("progressive: %.3g of the emitted power unshot, %u previews, %llu rows computed "
               "again (%llu dropped to stay within --max-memory)\n",
               s->progress->unshot, s->progress->preview_count,
               (unsigned long long)s->progress->rows_recomputed,
               (unsigned long long)s->progress->rows_dropped);
    if (s->elements)
        printf("elements: %u (from %u patches), %llu element hemi-cubes\n",
               s->elements->mesh->patch_count, s->mesh->patch_count,
               (unsigned long long)s->elements->rows_computed);
    printf("time: load %.3f s, mesh %.3f s, form factors %.3f s, solve %.3f s, store %.3f s\n",
           s->stages[RAD_STAGE_LOAD].seconds, s->stages[RAD_STAGE_MESH].seconds,
           s->stages[RAD_STAGE_FORM_FACTORS].seconds, s->stages[RAD_STAGE_SOLVE].seconds, store);
}

/* Where --preview-every writes: --preview-dir, else the solution's
 * directory; every K shots or T seconds. */
static int setup_preview(const char *out, const char *preview_dir, uint32_t every, double seconds,
                         preview_state *ps, char *dirbuf, size_t size, rad_solve_options *opt)
{
    if (!every && !(seconds > 0.0)) {
        if (ps->view.camera || ps->view.have_eye || ps->view.have_target || ps->view.width)
            return cli_usage_error("solve: camera options are for previews (--preview-every)");
        return 0;
    }
    if (opt->solver.method != SV_PROGRESSIVE)
        return cli_usage_error("--preview-every needs --solver progressive");
    if (!preview_dir) {
        snprintf(dirbuf, size, "%s", out);
        char *slash = strrchr(dirbuf, '/');
        if (slash)
            *slash = '\0';
        else
            snprintf(dirbuf, size, ".");
        preview_dir = dirbuf;
    }
    ps->dir = preview_dir;
    opt->solver.preview_every = every;
    opt->solver.preview_seconds = seconds;
    opt->on_preview = write_preview;
    opt->preview_user = ps;
    return 0;
}

/* --preview-every: K shots, or "Ts" seconds of solving (T > 0, decimals
 * allowed).  0, or the exit status (message printed). */
static int parse_preview_every(const char *opt, const char *v, uint32_t *shots, double *seconds)
{
    size_t len = v ? strlen(v) : 0;
    char *end = NULL;
    if (len > 1 && v[len - 1] == 's') {
        double t = strtod(v, &end);
        if (end == v + len - 1 && isfinite(t) && t >= 1e-3 && t <= 1e6) {
            *seconds = t;
            return 0;
        }
    } else if (len > 0 && v[0] >= '0' && v[0] <= '9') {
        unsigned long long k = strtoull(v, &end, 10);
        if (*end == '\0' && k >= 1 && k <= 100000000) {
            *shots = (uint32_t)k;
            return 0;
        }
    }
    return cli_usage_error("%s: '%s' is not K shots (1..1e8) or Ts seconds (0.001s..1e6s)", opt,
                           v ? v : "");
}

/* The rows go to OUT.partial as they are computed (rad_journal), so that
 * a crash, a kill or Ctrl-C loses none of them, and the next run of the
 * same command computes only the others; the finished file is that one,
 * completed and renamed. */
int cli_solve(int argc, char **argv)
{
    const char *scene = NULL, *out = NULL, *preview_dir = NULL;
    uint32_t preview_every = 0;
    double preview_seconds = 0.0;
    int rc, fresh = 0;
    rad_solve_options opt = {0};
    preview_state ps = {0};
    for (int i = 0; i < argc; i++) {
        int r = cli_solve_option(argc, argv, &i, &opt);
        if (r == 0)
            r = cli_view_option(argc, argv, &i, &ps.view);
        if (r < 0)
            return 2;
        if (r > 0)
            continue;
        if (!strcmp(argv[i], "-o") && i + 1 < argc)
            out = argv[++i];
        else if (!strcmp(argv[i], "--preview-every") && i + 1 < argc) {
            if (parse_preview_every(argv[i], argv[i + 1], &preview_every, &preview_seconds))
                return 2;
            i++;
        } else if (!strcmp(argv[i], "--preview-dir") && i + 1 < argc)
            preview_dir = argv[++i];
        else if (!strcmp(argv[i], "--fresh"))
            fresh = 1;
        else if ((rc = cli_other_arg("solve", "scene", argv[i], &scene)) != 0)
            return rc;
    }
    if (!scene || !out)
        return cli_usage_error("usage: radiosity solve SCENE -o SOLUTION [options]");
    if (cli_check_output_dir(out))
        return 2;
    if (ps.view.png)
        return cli_usage_error("solve: --png is for render (previews are written as PNG and EXR)");
    char dirbuf[4096];
    if ((rc = setup_preview(out, preview_dir, preview_every, preview_seconds, &ps, dirbuf,
                            sizeof dirbuf, &opt)))
        return rc;
    cli_enable_progress(&opt);
    opt.warn = cli_warn;
    cli_enable_estimate(&opt);
    opt.load.warn = cli_warn;

    rad_error err = {0};
    rad_journal *j = NULL;
    if (rad_journal_open(out, fresh, &j, &err))
        return cli_error(&err);
    cli_catch_stop();
    opt.journal = j;
    opt.stop = &cli_stop;
    rad_solution *s = NULL;
    rc = rad_solve_scene_file(scene, &opt, &s, &err);
    if (rc || cli_stop) {
        rad_solution_destroy(s);
        return solve_stopped(j, &err, rc);
    }
    if (ps.failed) { /* a preview could not be written (printed): the rows stay */
        rad_solution_destroy(s);
        rad_journal_close(j);
        return 2;
    }
    rad_journal_stats st = rad_journal_stats_of(j);
    double t0 = rad_seconds();
    rc = rad_journal_commit(j, s, &err); /* frees j */
    double store = rad_seconds() - t0;
    if (rc) {
        rad_solution_destroy(s);
        cli_error(&err);
        fprintf(stderr, "radiosity: note: the form-factor rows stay in %s.partial; run the same "
                        "command again to finish\n", out);
        return cli_error_status(&err);
    }
    solve_summary(out, s, &st, store);
    rad_solution_destroy(s);
    return 0;
}

/* ----------------------------------------------------------------- render */

int cli_render(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    cli_view view = {0};
    cli_many many = {0};
    cli_gather gather = {0};
    int rc;
    for (int i = 0; i < argc; i++) {
        int r = cli_view_option(argc, argv, &i, &view);
        if (!r)
            r = cli_many_option(argc, argv, &i, &many);
        if (!r)
            r = cli_gather_option(argc, argv, &i, &gather);
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
    if (cli_many_views(&view, &many, NULL)) {
        if (gather.on)
            return cli_usage_error("render: --gather draws one view (several views: run it per view)");
        if (cli_need_dir("render", out))
            return 2;
    }
    /* --threads: drawing threads for several views, shading threads for a
     * gather (default: one per CPU, as for several views). */
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    gather.opt.threads = many.threads ? many.threads : cpus > 64 ? 64 : cpus > 1 ? (uint32_t)cpus : 1;
    rad_error err = {0};
    rad_solution *s = NULL;
    /* a view needs B, the mesh and the elements: F is neither read nor checked */
    if (rad_solution_read_parts(in, 0, &s, &err))
        return cli_error(&err);
    if (cli_many_views(&view, &many, s->scene))
        rc = gather.on ? cli_usage_error("render: --gather draws one view (several views: run it "
                                         "per view)")
                       : cli_render_many(s, &view, &many, out);
    else if ((many.threads && !gather.on) || many.no_png)
        rc = cli_usage_error("render: --threads and --no-png go with several views "
                             "(--all-cameras, --path or --camera A,B) or, --threads, with --gather");
    else
        rc = gather.on ? cli_gather_to_files(s, in, &view, &gather, out)
                       : cli_render_to_files(s, &view, out, view.png);
    rad_solution_destroy(s);
    return rc;
}
