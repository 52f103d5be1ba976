/* cli_ff.c - the ff command: object-to-object form factors of a scene
 * (solved for them) or of a stored solution (its missing rows computed),
 * as one pair F_AB and F_BA with their reciprocity gap (text or JSON), or
 * as the whole object matrix (CSV, with each row's sum).
 *
 * Invariant: every row is computed, even where an object is black (F_BA
 * needs B's rows), and no elements are made: form factors are between
 * patches.  Calls only the shared files (cli_args.c, cli_print.c).
 */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
    const char *in = NULL, *from = NULL, *to = NULL, *view3d = NULL;
    int json = 0, matrix = 0, rc = 0, pixel_factors = 0;
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
        else if (!strcmp(argv[i], "--view3d") && i + 1 < argc)
            view3d = argv[++i];
        else if (!strcmp(argv[i], "--pixel-factors"))
            pixel_factors = 1;
        else if ((rc = cli_other_arg("ff", "input", argv[i], &in)) != 0)
            return rc;
    }
    if (in && (view3d || pixel_factors) && !has_suffix(in, ".vs3"))
        return cli_usage_error("ff: --view3d and --pixel-factors need a .vs3 input");
    if (!in || (!matrix && !view3d && (!from || !to)))
        return cli_usage_error("usage: radiosity ff SCENE_OR_SOLUTION --from A --to B [--json] | "
                               "--matrix | FILE.vs3 [--matrix] [--view3d OUT] [--pixel-factors]");
    rad_error err = {0};
    rad_solution *s = NULL;
    opt.all_rows = 1; /* every row: F_BA needs B's rows even where B is black */
    opt.surface_factors = 1; /* F_AB is an area average over A (docs/limits.md) */
    if (opt.mesh.divisions <= 0.0)
        opt.mesh.divisions = RAD_MESH_FACTOR_DIVISIONS; /* its own default edge (mesh.h) */
    opt.refine_threshold = RAD_REFINE_OFF; /* form factors need no elements */
    opt.element_levels = 0;
    opt.load.allow_no_emitter = 1;
    opt.load.warn = cli_warn;
    cli_enable_progress(&opt);
    if (has_suffix(in, ".vs3") && (matrix || view3d)) {
        opt.exact_all = !pixel_factors; /* View3D's few large surfaces: exact is cheap */
        return cli_ff_view3d(in, &opt, matrix, view3d);
    }
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
