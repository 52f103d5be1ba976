/* cli_relight.c - the relight command: new lights and colours for a
 * stored solution (one change set, or every variant of a variations file).
 *
 * A relight takes one of two paths.  When the edits only scale each light
 * group's sources and the solution stores its light responses (solution.h,
 * rad_basis), the answer is their weighted sum: F is never read.  Otherwise
 * (a reflectance edit, a light that was dark when solved, no stored
 * responses, --resolve) F is read, once however many variants, and the
 * solution solved again.  The output says which path and why.
 *
 * Every argument and every variant is checked against the solution before
 * any solving starts, so a typo costs nothing and writes nothing.  Calls
 * only the shared files (cli_args.c, cli_print.c).
 */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The solve options a relight uses: the stored solver and tolerance unless
 * the command line says otherwise. */
static void default_solver(const rad_solution *s, rad_solve_options *opt, int solver_given,
                           int tol_given)
{
    if (!solver_given)
        sv_method_parse(s->solver, &opt->solver.method);
    if (!tol_given && s->tolerance > 0)
        opt->solver.tolerance = s->tolerance;
    if (s->resolution)
        opt->hemicube.resolution = opt->hemicube.resolution ? opt->hemicube.resolution : s->resolution;
}

/* The command line of relight. */
typedef struct relight_args {
    const char *in, *out, *variations;
    int render, solver_given, tol_given;
    int resolve;     /* --resolve: always the full path (F read, solved again) */
    rad_solve_options opt;
    cli_view view;
    rad_edit *edits; /* argc + 1 slots (owned) */
    uint32_t ne;
} relight_args;

/* One edit option (--light, --emission, --reflectance) at argv[*i]:
 * 1 consumed, 0 not one, -1 bad (printed). */
static int edit_option(int argc, char **argv, int *i, relight_args *a)
{
    const char *opt = argv[*i];
    if (strcmp(opt, "--light") && strcmp(opt, "--emission") && strcmp(opt, "--reflectance"))
        return 0;
    rad_edit_kind kind = opt[2] == 'l'   ? RAD_EDIT_LIGHT
                         : opt[2] == 'e' ? RAD_EDIT_EMISSION
                                         : RAD_EDIT_REFLECTANCE;
    rad_error err = {0};
    if (*i + 1 >= argc)
        return cli_usage_error("%s needs NAME=VALUE", opt), -1;
    if (rad_edit_parse(kind, argv[++*i], &a->edits[a->ne], &err))
        return cli_error(&err), -1;
    a->ne++;
    return 1;
}

static int parse_relight(int argc, char **argv, relight_args *a)
{
    a->edits = calloc((size_t)argc + 1, sizeof *a->edits);
    if (!a->edits)
        return 1;
    for (int i = 0; i < argc; i++) {
        const char *arg = argv[i];
        a->solver_given |= !strcmp(arg, "--solver");
        a->tol_given |= !strcmp(arg, "--tolerance");
        int r = cli_solve_option(argc, argv, &i, &a->opt);
        if (r == 0)
            r = cli_view_option(argc, argv, &i, &a->view);
        if (r == 0)
            r = edit_option(argc, argv, &i, a);
        if (r < 0)
            return 2;
        if (r > 0)
            continue;
        if (!strcmp(arg, "-o") && i + 1 < argc)
            a->out = argv[++i];
        else if (!strcmp(arg, "--variations") && i + 1 < argc)
            a->variations = argv[++i];
        else if (!strcmp(arg, "--render"))
            a->render = 1;
        else if (!strcmp(arg, "--resolve"))
            a->resolve = 1;
        else if (arg[0] == '-')
            return cli_usage_error("relight: unknown option '%s'", arg);
        else if (!a->in)
            a->in = arg;
        else
            return cli_usage_error("relight: more than one solution given ('%s')", arg);
    }
    if (!a->in || !a->out)
        return cli_usage_error("usage: radiosity relight SOLUTION -o OUT [--light|--emission|--reflectance NAME=...] [--variations FILE] [--resolve]");
    if (!a->variations && a->ne == 0)
        return cli_usage_error("relight: nothing to change (give --light, --emission, --reflectance or --variations)");
    if (a->render && !a->variations)
        return cli_usage_error("relight: --render goes with --variations (use 'radiosity render' on the result)");
    if (a->view.camera_args > 1)
        return cli_usage_error("relight: --render draws one view per variant (one --camera)");
    if (!a->variations && cli_check_output_dir(a->out))
        return 2;
    if (a->variations)
        return cli_need_dir("relight --variations", a->out);
    return 0;
}

/* What edits change in a solution: ρ and E per patch and the punctual
 * lights' intensities, saved so that each variant starts from the same. */
typedef struct relight_values {
    size_t nvals, nl;
    double *rho, *e, *l;
} relight_values;

static int values_alloc(const rad_solution *s, relight_values *v)
{
    v->nvals = (size_t)s->mesh->patch_count * s->band_count;
    v->nl = s->light_intensity ? (size_t)s->scene->light_count * s->band_count : 0;
    v->rho = malloc((v->nvals + 1) * sizeof *v->rho);
    v->e = malloc((v->nvals + 1) * sizeof *v->e);
    v->l = malloc((v->nl + 1) * sizeof *v->l);
    return v->rho && v->e && v->l ? 0 : 1;
}

static void values_free(relight_values *v)
{
    free(v->rho);
    free(v->e);
    free(v->l);
}

static void values_save(const rad_solution *s, relight_values *v)
{
    memcpy(v->rho, s->rho, v->nvals * sizeof *v->rho);
    memcpy(v->e, s->emission, v->nvals * sizeof *v->e);
    if (v->nl)
        memcpy(v->l, s->light_intensity, v->nl * sizeof *v->l);
}

static void values_restore(rad_solution *s, const relight_values *v)
{
    memcpy(s->rho, v->rho, v->nvals * sizeof *v->rho);
    memcpy(s->emission, v->e, v->nvals * sizeof *v->e);
    if (v->nl)
        memcpy(s->light_intensity, v->l, v->nl * sizeof *v->l);
}

/* Checks everything before any work: the command-line edits, then each
 * variant on top of them, on the solution's own values (put back after
 * each).  Leaves s with the command-line edits applied, and base holding
 * those values. */
static int check_edits(rad_solution *s, const relight_args *a, const rad_variant *var,
                       uint32_t nvar, relight_values *base)
{
    rad_error err = {0};
    if (rad_solution_apply_edits(s, a->edits, a->ne, &err))
        return cli_error(&err);
    values_save(s, base);
    for (uint32_t v = 0; v < nvar; v++) {
        int bad = rad_solution_apply_edits(s, var[v].edits, var[v].edit_count, &err);
        values_restore(s, base);
        if (bad) {
            fprintf(stderr, "radiosity: error: %s: variant '%s': %s\n", a->variations, var[v].name,
                    err.message);
            return 2;
        }
    }
    return 0;
}

/* Writes a relit solution sharing the base's matrix where it can, and
 * says so.  The file holds the elements' rows again: read now if no gather
 * read them (superposition). */
static int write_relit(rad_solution *s, const char *path, rad_error *err)
{
    const rad_write_options wo = {.share_matrix = 1};
    rad_write_info info;
    int rc = rad_solution_load_element_rows(s, err);
    if (!rc)
        rc = rad_solution_write_opts(s, path, &wo, &info, err);
    if (!rc && info.matrix_shared)
        printf("%s: form factors shared with %s%s\n", path, info.matrix_path,
               info.linked ? " (a hard link, no copy)" : " (by path)");
    else if (!rc)
        printf("%s: form factors written in full (%s)\n", path,
               s->rows_computed ? "rows were added" : "the base holds no shareable matrix");
    return rc;
}

/* How a change set was relit, for the output line. */
typedef struct relit_how {
    int superposed;   /* 1: by superposition, F not read */
    char why[512];    /* the responses used, or what stood in the way */
    rad_basis *base;  /* full path: the base's stored responses, put aside (owned) */
} relit_how;

/* The edits applied to s, relights it: by superposition of its stored light
 * responses when they allow and the output can share s's form factors,
 * else F read (once: a later call finds it loaded) and solved again.  The
 * full path makes the output's own responses; the base's wait in how->base
 * for relight_done to put back, for the next variant. */
static int relight_solution(rad_solution *s, const relight_args *a, relit_how *how,
                            rad_error *err)
{
    *how = (relit_how){0};
    const double t0 = rad_seconds();
    int rc = RAD_OK;
    if (a->resolve)
        snprintf(how->why, sizeof how->why, "--resolve");
    else if (!s->F->entries_loaded && !rad_solution_matrix_file(s))
        snprintf(how->why, sizeof how->why, "the form factors it shares could not be found");
    else
        rc = rad_solution_superpose(s, &how->superposed, how->why, sizeof how->why, err);
    if (rc || how->superposed) {
        s->stages[RAD_STAGE_SOLVE] = (rad_stage_info){rad_seconds() - t0, 0};
        return rc;
    }
    how->base = s->basis;
    s->basis = NULL;
    rc = rad_solution_load_matrix(s, err);
    if (!rc)
        rc = rad_resolve(s, &a->opt, err);
    return rc;
}

/* After the output is written: the base's stored responses back in s. */
static void relight_done(rad_solution *s, relit_how *how)
{
    if (how->superposed)
        return;
    rad_basis_destroy(s->basis);
    s->basis = how->base;
    how->base = NULL;
}

/* The path taken, for the output line. */
static void say_how(const char *out, const char *what, const rad_solution *s,
                    const relit_how *how)
{
    if (how->superposed)
        printf("%s: %s, relit by superposition of %s (form factors not read), "
               "0 hemi-cube rows computed, residual bound %.3g, %.3f s\n",
               out, what, how->why, s->residual, s->stages[RAD_STAGE_SOLVE].seconds);
    else
        printf("%s: %s, re-solved with the stored form factors: %s; %llu hemi-cube rows "
               "computed, %s: %u iterations, residual %.3g, solve %.3f s\n",
               out, what, how->why, (unsigned long long)s->rows_computed, s->solver,
               s->iterations, s->residual, s->stages[RAD_STAGE_SOLVE].seconds);
}

/* One change set: relight, write OUT. */
static int relight_one(rad_solution *s, const relight_args *a)
{
    rad_error err = {0};
    relit_how how;
    int rc = relight_solution(s, a, &how, &err);
    if (!rc)
        rc = write_relit(s, a->out, &err);
    relight_done(s, &how);
    if (rc)
        return cli_error(&err);
    char what[64];
    snprintf(what, sizeof what, "relit with %u change%s", a->ne, a->ne == 1 ? "" : "s");
    say_how(a->out, what, s, &how);
    return 0;
}

/* One solution, many variants: only ρ and E change between them; each
 * writes OUT/NAME.sol (or its images with --render).  F is read at most
 * once, by the first variant that needs it. */
static int relight_variants(rad_solution *s, const relight_args *a, const rad_variant *var,
                            uint32_t nvar, const relight_values *base)
{
    rad_error err = {0};
    int rc = 0;
    for (uint32_t v = 0; v < nvar && !rc; v++) {
        values_restore(s, base);
        char path[4096], png[4096], what[192];
        relit_how how = {0};
        if (rad_solution_apply_edits(s, var[v].edits, var[v].edit_count, &err) ||
            relight_solution(s, a, &how, &err)) {
            relight_done(s, &how);
            return cli_error(&err);
        }
        if (a->render) {
            snprintf(path, sizeof path, "%s/%s.exr", a->out, var[v].name);
            snprintf(png, sizeof png, "%s/%s.png", a->out, var[v].name);
            rc = cli_render_to_files(s, &a->view, path, png);
        } else {
            snprintf(path, sizeof path, "%s/%s.sol", a->out, var[v].name);
            if (write_relit(s, path, &err))
                rc = cli_error(&err);
        }
        relight_done(s, &how);
        snprintf(what, sizeof what, "variant '%.128s'", var[v].name);
        if (!rc)
            say_how(path, what, s, &how);
    }
    return rc;
}

static int read_variations(const char *path, rad_variant **var, uint32_t *nvar)
{
    char *text = NULL;
    size_t size = 0;
    rad_error err = {0};
    int rc = cli_read_text(path, &text, &size, &err);
    if (!rc)
        rc = rad_variants_parse(text, size, path, var, nvar, &err);
    free(text);
    return rc ? cli_error(&err) : 0;
}

/* relight: the solution is read once without F (with it under --resolve)
 * and without its elements' rows, whatever the number of variants; every
 * edit and variant is checked before any solve.  The rows are read when
 * first needed, by the gather or the writer; one change set solved again
 * frees F's entries before (release_matrix): the relight's peak is then F
 * and the patches' data, not F and the rows too. */
int cli_relight(int argc, char **argv)
{
    relight_args a = {0};
    rad_variant *var = NULL;
    uint32_t nvar = 0;
    rad_solution *s = NULL;
    relight_values base = {0};
    rad_error err = {0};
    int rc = parse_relight(argc, argv, &a);
    if (!rc && a.variations)
        rc = read_variations(a.variations, &var, &nvar);
    double t0 = rad_seconds();
    /* The light responses always: every path writes a whole new file, and
     * superposition is made of them. */
    const unsigned parts = (a.resolve ? RAD_PART_MATRIX : RAD_PART_MATRIX_PLACE) | RAD_PART_BASIS;
    if (!rc && rad_solution_read_parts(a.in, parts, &s, &err))
        rc = cli_error(&err);
    double load_seconds = rad_seconds() - t0;
    if (!rc) {
        default_solver(s, &a.opt, a.solver_given, a.tol_given);
        cli_enable_progress(&a.opt);
        a.opt.release_matrix = !a.variations;
        rc = values_alloc(s, &base);
    }
    if (!rc)
        rc = check_edits(s, &a, var, nvar, &base);
    if (!rc) {
        for (int k = 0; k < RAD_STAGE_COUNT; k++)
            s->stages[k] = (rad_stage_info){0, 1};
        s->stages[RAD_STAGE_LOAD] = (rad_stage_info){load_seconds, 1};
        rc = a.variations ? relight_variants(s, &a, var, nvar, &base) : relight_one(s, &a);
    }
    values_free(&base);
    free(a.edits);
    rad_variants_free(var, nvar);
    rad_solution_destroy(s);
    return rc;
}
