/* cli_export.c - the export command: a solution as open data (CSV and
 * Matrix Market files in a directory, rad_solution_export; the files are
 * described in docs/export.md; DIR is made when missing).  Prints what it
 * wrote, one line.
 */
#include "cli.h"

#include <stdio.h>
#include <string.h>

int cli_export(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    int rc;
    for (int i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "-o") && i + 1 < argc)
            out = argv[++i];
        else if ((rc = cli_other_arg("export", "solution", argv[i], &in)) != 0)
            return rc;
    }
    if (!in || !out)
        return cli_usage_error("usage: radiosity export SOLUTION -o DIR");
    rad_error err = {0};
    rad_solution *s = NULL;
    if (rad_solution_read(in, &s, &err))
        return cli_error(&err);
    /* DIR is made (mkdir -p) once the solution has been read, so that a
     * bad solution leaves no empty directory behind. */
    rc = cli_make_dir(out, &err);
    if (!rc)
        rc = rad_solution_export(s, out, &err);
    if (!rc) {
        printf("%s: patches.csv (%u patches, %u bands), F.mtx (%u of %u rows)", out,
               s->mesh->patch_count, s->band_count, s->F->rows_done, s->F->n);
        if (s->elements)
            printf(", elements.csv and elements-F.mtx (%u elements)",
                   s->elements->mesh->patch_count);
        printf("\n");
    }
    rad_solution_destroy(s);
    return rc ? cli_error(&err) : 0;
}
