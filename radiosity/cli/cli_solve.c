/* cli_solve.c - the solve command: a scene becomes a stored solution
 * (load, mesh, form factors, solve, store), with its progress bars, its
 * estimate, the progressive solver's previews and its summary lines.
 *
 * Invariant: the form-factor rows go to OUT.partial as they are computed
 * and OUT appears only complete (renamed); a solve that stops (Ctrl-C, a
 * limit, an error) says how many rows it kept and how to resume.  Calls
 * only the shared files (cli_args.c, cli_process.c, cli_print.c).
 */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
