/* cli_relight.c - the relight and ff commands: re-solving a stored matrix
 * with new lights and colours (one change set, or every variant of a
 * variations file), and object-to-object form factors.
 *
 * Every argument and every variant is checked against the solution before
 * any solving starts, so a typo costs nothing and writes nothing.
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

int cli_relight(int argc, char **argv)
{
    const char *in = NULL, *out = NULL, *variations = NULL;
    int render = 0, solver_given = 0, tol_given = 0;
    rad_solve_options opt = {0};
    cli_view view = {0};
    rad_edit *edits = calloc((size_t)argc + 1, sizeof *edits);
    uint32_t ne = 0;
    rad_error err = {0};
    if (!edits)
        return 1;
    int rc = 0;
    for (int i = 0; i < argc && !rc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--solver"))
            solver_given = 1;
        if (!strcmp(a, "--tolerance"))
            tol_given = 1;
        int r = cli_solve_option(argc, argv, &i, &opt);
        if (r == 0)
            r = cli_view_option(argc, argv, &i, &view);
        if (r < 0)
            rc = 2;
        if (r != 0)
            continue;
        rad_edit_kind kind;
        if (!strcmp(a, "--light") || !strcmp(a, "--emission") || !strcmp(a, "--reflectance")) {
            kind = a[2] == 'l' ? RAD_EDIT_LIGHT : a[2] == 'e' ? RAD_EDIT_EMISSION : RAD_EDIT_REFLECTANCE;
            if (i + 1 >= argc) {
                rc = cli_usage_error("%s needs NAME=VALUE", a);
            } else if (rad_edit_parse(kind, argv[++i], &edits[ne], &err)) {
                rc = cli_error(&err);
            } else {
                ne++;
            }
        } else if (!strcmp(a, "-o") && i + 1 < argc) {
            out = argv[++i];
        } else if (!strcmp(a, "--variations") && i + 1 < argc) {
            variations = argv[++i];
        } else if (!strcmp(a, "--render")) {
            render = 1;
        } else if (a[0] == '-') {
            rc = cli_usage_error("relight: unknown option '%s'", a);
        } else if (!in) {
            in = a;
        } else {
            rc = cli_usage_error("relight: more than one solution given ('%s')", a);
        }
    }
    if (!rc && (!in || !out))
        rc = cli_usage_error("usage: radiosity relight SOLUTION -o OUT [--light|--emission|--reflectance NAME=...] [--variations FILE]");
    if (!rc && !variations && ne == 0)
        rc = cli_usage_error("relight: nothing to change (give --light, --emission, --reflectance or --variations)");
    if (!rc && render && !variations)
        rc = cli_usage_error("relight: --render goes with --variations (use 'radiosity render' on the result)");
    if (!rc && view.camera_args > 1)
        rc = cli_usage_error("relight: --render draws one view per variant (one --camera)");
    if (!rc && !variations && cli_check_output_dir(out))
        rc = 2;
    if (!rc && variations)
        rc = cli_need_dir("relight --variations", out);

    rad_variant *var = NULL;
    uint32_t nvar = 0;
    if (!rc && variations) {
        char *text = NULL;
        size_t size = 0;
        rc = cli_read_text(variations, &text, &size, &err);
        if (!rc)
            rc = rad_variants_parse(text, size, variations, &var, &nvar, &err);
        free(text);
        if (rc)
            rc = cli_error(&err);
    }

    rad_solution *s = NULL;
    double t0 = rad_seconds();
    if (!rc && rad_solution_read(in, &s, &err))
        rc = cli_error(&err);
    double load_seconds = rad_seconds() - t0;
    if (rc) {
        free(edits);
        rad_variants_free(var, nvar);
        return rc;
    }
    default_solver(s, &opt, solver_given, tol_given);
    cli_enable_progress(&opt);

    /* Check everything before any work: command-line edits, then each
     * variant on top of them, on the solution's own ρ and E (restored). */
    size_t nvals = (size_t)s->mesh->patch_count * s->band_count;
    /* punctual lights' intensities change with edits too (relight.c) */
    size_t nl = s->light_intensity ? (size_t)s->scene->light_count * s->band_count : 0;
    double *rho0 = malloc((nvals + 1) * sizeof *rho0), *e0 = malloc((nvals + 1) * sizeof *e0);
    double *l0 = malloc((nl + 1) * sizeof *l0), *l1 = malloc((nl + 1) * sizeof *l1);
    if (!rho0 || !e0 || !l0 || !l1)
        rc = 1;
    if (!rc) {
        memcpy(rho0, s->rho, nvals * sizeof *rho0);
        memcpy(e0, s->emission, nvals * sizeof *e0);
        if (nl)
            memcpy(l0, s->light_intensity, nl * sizeof *l0);
        if (rad_solution_apply_edits(s, edits, ne, &err))
            rc = cli_error(&err);
        for (uint32_t v = 0; v < nvar && !rc; v++) {
            if (rad_solution_apply_edits(s, var[v].edits, var[v].edit_count, &err)) {
                fprintf(stderr, "radiosity: error: %s: variant '%s': %s\n", variations, var[v].name,
                        err.message);
                rc = 2;
            }
            memcpy(s->rho, rho0, nvals * sizeof *rho0);
            memcpy(s->emission, e0, nvals * sizeof *e0);
            if (nl)
                memcpy(s->light_intensity, l0, nl * sizeof *l0);
            if (!rc)
                rad_solution_apply_edits(s, edits, ne, &err);
        }
    }

    for (int k = 0; k < RAD_STAGE_COUNT; k++)
        s->stages[k] = (rad_stage_info){0, 1};
    s->stages[RAD_STAGE_LOAD] = (rad_stage_info){load_seconds, 1};

    if (!rc && !variations) {
        if (rad_resolve(s, &opt, &err) || rad_solution_write(s, out, &err))
            rc = cli_error(&err);
        else
            printf("%s: relit with %u change%s, %llu hemi-cube rows computed, %s: %u iterations, "
                   "residual %.3g, solve %.3f s\n",
                   out, ne, ne == 1 ? "" : "s", (unsigned long long)s->rows_computed, s->solver,
                   s->iterations, s->residual, s->stages[RAD_STAGE_SOLVE].seconds);
    }
    /* One matrix, many variants: only ρ and E change between solves. */
    double *rho1 = NULL, *e1 = NULL;
    if (!rc && variations) {
        rho1 = malloc((nvals + 1) * sizeof *rho1);
        e1 = malloc((nvals + 1) * sizeof *e1);
        if (!rho1 || !e1)
            rc = 1;
        else {
            memcpy(rho1, s->rho, nvals * sizeof *rho1); /* base = solution + command-line edits */
            memcpy(e1, s->emission, nvals * sizeof *e1);
            if (nl)
                memcpy(l1, s->light_intensity, nl * sizeof *l1);
        }
    }
    for (uint32_t v = 0; v < nvar && !rc; v++) {
        memcpy(s->rho, rho1, nvals * sizeof *rho1);
        memcpy(s->emission, e1, nvals * sizeof *e1);
        if (nl)
            memcpy(s->light_intensity, l1, nl * sizeof *l1);
        char path[4096], png[4096];
        if (rad_solution_apply_edits(s, var[v].edits, var[v].edit_count, &err) ||
            rad_resolve(s, &opt, &err)) {
            rc = cli_error(&err);
            break;
        }
        if (render) {
            snprintf(path, sizeof path, "%s/%s.exr", out, var[v].name);
            snprintf(png, sizeof png, "%s/%s.png", out, var[v].name);
            rc = cli_render_to_files(s, &view, path, png);
        } else {
            snprintf(path, sizeof path, "%s/%s.sol", out, var[v].name);
            if (rad_solution_write(s, path, &err))
                rc = cli_error(&err);
        }
        if (!rc)
            printf("%s: variant '%s', %llu hemi-cube rows computed, %u iterations, residual %.3g, "
                   "solve %.3f s\n",
                   path, var[v].name, (unsigned long long)s->rows_computed, s->iterations,
                   s->residual, s->stages[RAD_STAGE_SOLVE].seconds);
    }
    free(rho0);
    free(e0);
    free(rho1);
    free(e1);
    free(l0);
    free(l1);
    free(edits);
    rad_variants_free(var, nvar);
    rad_solution_destroy(s);
    return rc;
}

/* ---------------------------------------------------------------------- ff */

static int has_suffix(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcmp(s + a - b, suffix) == 0;
}

static int find_object(const rad_scene *sc, const char *name, uint32_t *out)
{
    *out = rad_scene_find_object(sc, name);
    if (*out != RAD_NONE)
        return 0;
    char list[1024] = "";
    for (uint32_t o = 0; o < sc->object_count; o++) {
        size_t used = strlen(list);
        if (used + 8 < sizeof list)
            snprintf(list + used, sizeof list - used, "%s'%s'", o ? ", " : "", sc->objects[o].name);
    }
    fprintf(stderr, "radiosity: error: %s: object '%s' not found (objects: %s)\n", sc->source, name,
            list);
    return 2;
}

int cli_ff(int argc, char **argv)
{
    const char *in = NULL, *from = NULL, *to = NULL;
    int json = 0, matrix = 0, rc = 0;
    rad_solve_options opt = {0};
    for (int i = 0; i < argc; i++) {
        int r = cli_solve_option(argc, argv, &i, &opt);
        if (r < 0)
            return 2;
        if (r > 0)
            continue;
        if (!strcmp(argv[i], "--from") && i + 1 < argc)
            from = argv[++i];
        else if (!strcmp(argv[i], "--to") && i + 1 < argc)
            to = argv[++i];
        else if (!strcmp(argv[i], "--json"))
            json = 1;
        else if (!strcmp(argv[i], "--matrix"))
            matrix = 1;
        else if ((rc = cli_other_arg("ff", "input", argv[i], &in)) != 0)
            return rc;
    }
    if (!in || (!matrix && (!from || !to)))
        return cli_usage_error("usage: radiosity ff SCENE_OR_SOLUTION --from A --to B [--json] | --matrix");
    rad_error err = {0};
    rad_solution *s = NULL;
    opt.all_rows = 1; /* every row: F_BA needs B's rows even where B is black */
    opt.load.allow_no_emitter = 1;
    opt.load.warn = cli_warn;
    cli_enable_progress(&opt);
    if (has_suffix(in, ".sol")) {
        if (rad_solution_read(in, &s, &err) || rad_resolve(s, &opt, &err)) {
            rad_solution_destroy(s);
            return cli_error(&err);
        }
    } else if (rad_solve_scene_file(in, &opt, &s, &err)) {
        return cli_error(&err);
    }
    const rad_scene *sc = s->scene;
    uint32_t no = sc->object_count, a = 0, b = 0;
    if (!matrix && (find_object(sc, from, &a) || find_object(sc, to, &b)))
        rc = 2;
    double *M = rc ? NULL : malloc(((size_t)no * no + 1) * sizeof *M);
    rad_object_stats *st = rc ? NULL : calloc(no + 1, sizeof *st);
    if (!rc && (!M || !st))
        rc = 1;
    if (!rc && (rad_object_form_factors(s, M, &err) || rad_solution_object_stats(s, st, &err)))
        rc = cli_error(&err);
    if (!rc && matrix) {
        printf("from\\to");
        for (uint32_t o = 0; o < no; o++)
            printf(",%s", sc->objects[o].name);
        printf(",row_sum\n");
        for (uint32_t r = 0; r < no; r++) {
            double sum = 0;
            printf("%s", sc->objects[r].name);
            for (uint32_t c = 0; c < no; c++) {
                printf(",%.8f", M[(size_t)r * no + c]);
                sum += M[(size_t)r * no + c];
            }
            printf(",%.8f\n", sum);
        }
    } else if (!rc) {
        double fab = M[(size_t)a * no + b], fba = M[(size_t)b * no + a];
        double gap = st[a].area * fab - st[b].area * fba;
        if (json) {
            printf("{\"from\": \"%s\", \"to\": \"%s\", \"F_AB\": %.9g, \"F_BA\": %.9g, "
                   "\"reciprocity_gap\": %.9g, \"area_A\": %.9g, \"area_B\": %.9g, \"patches\": %u, "
                   "\"resolution\": %u}\n",
                   from, to, fab, fba, gap, st[a].area, st[b].area, s->mesh->patch_count,
                   s->resolution);
        } else {
            printf("F(%s -> %s) = %.8f\nF(%s -> %s) = %.8f\nreciprocity gap A_A F_AB - A_B F_BA = %.3g "
                   "(%.3g relative)\n",
                   from, to, fab, to, from, fba, gap,
                   st[a].area * fab > 0 ? gap / (st[a].area * fab) : 0.0);
        }
    }
    free(M);
    free(st);
    rad_solution_destroy(s);
    return rc;
}
