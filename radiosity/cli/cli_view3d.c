/* cli_view3d.c - `ff FILE.vs3`: View3D's reported surfaces from a .vs3
 * file, printed as a CSV matrix (--matrix; F_ij, or script-F_ij when the
 * file sets emit=1, the first header cell says which) and/or written as
 * View3D 4.0's text view-factor file (--view3d OUT).
 *
 * Invariant: the scene is solved with every row computed and no elements,
 * as cli_ff.c does for any scene; only this file's caller parses options.
 * With exact factors and without --patch-size, patches are
 * VS3_PATCH_SCALE times a factor query's default edge (mesh.h).
 */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>

/* With every patch an exact target (ff's default for .vs3), error comes
 * only from sampling each source patch at its centre, and the work grows
 * as the square of the patch count: patches VS3_PATCH_SCALE times a
 * factor query's default edge keep the test scenes within 0.15 % of their
 * references at a tenth of a second to half a second of CPU
 * (report/view3d.md), where the default edge takes 10-15 s. */
#define VS3_PATCH_SCALE 4.0

static void print_matrix(const rad_vs3 *m, const rad_vs3_factors *f)
{
    uint32_t n = f->n;
    printf("%s from\\to", f->script ? "script-F" : "F");
    for (uint32_t j = 0; j < n; j++)
        printf(",%s", m->surfaces[f->surface[j]].name);
    printf(",row_sum\n");
    for (uint32_t i = 0; i < n; i++) {
        double sum = 0.0;
        printf("%s", m->surfaces[f->surface[i]].name);
        for (uint32_t j = 0; j < n; j++) {
            printf(",%.8f", f->F[(size_t)i * n + j]);
            sum += f->F[(size_t)i * n + j];
        }
        printf(",%.8f\n", sum);
    }
}

int cli_ff_view3d(const char *in, const rad_solve_options *opt, int matrix, const char *out)
{
    rad_error err = {0};
    rad_scene *sc = NULL;
    rad_vs3 *m = NULL;
    rad_solution *s = NULL;
    rad_vs3_factors *f = NULL;
    int rc = 0;
    rad_solve_options o = *opt;
    if (rad_vs3_load(in, &opt->load, &sc, &m, &err) == RAD_OK && o.exact_all &&
        o.mesh.patch_size <= 0)
        o.mesh.patch_size = VS3_PATCH_SCALE * rad_mesh_patch_size(sc, &o.mesh);
    if (err.code || rad_solve_scene(sc, &o, &s, &err) ||
        rad_vs3_factors_compute(s, m, &f, &err) ||
        (out && rad_view3d_write(out, m, f, &err)))
        rc = cli_error(&err);
    else if (matrix)
        print_matrix(m, f);
    rad_vs3_factors_destroy(f);
    rad_solution_destroy(s);
    rad_vs3_destroy(m);
    return rc;
}
