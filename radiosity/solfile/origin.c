/* origin.c - the reader's record of a solution (rad_solution.origin,
 * solfile_internal.h): the file it was read from and that file's content
 * id, where F's rows are (rad_matrix_file), and which parts were left out;
 * what the solution module carries without looking inside.
 *
 * Invariant: s->origin_destroy frees exactly what sol_origin_attach made,
 * and rad_solution_matrix_file names F's section only while F is that
 * section (read from it, or released since, no row added:
 * rad_solution_matrix_in_file), so no writer shares a matrix that is not
 * the one in memory.
 */
#include "solfile_internal.h"

#include <stdlib.h>

static void origin_destroy(rad_solution_origin *o)
{
    if (!o)
        return;
    free(o->file);
    free(o->matrix_file.path);
    free(o);
}

int sol_origin_attach(rad_solution *s)
{
    RAD_ASSERT(!s->origin);
    s->origin = calloc(1, sizeof *s->origin);
    if (!s->origin)
        return -1;
    s->origin_destroy = origin_destroy;
    return 0;
}

const rad_matrix_file *rad_solution_matrix_file(const rad_solution *s)
{
    return s && s->origin && s->origin->matrix_file.path ? &s->origin->matrix_file : NULL;
}

int rad_solution_basis_skipped(const rad_solution *s)
{
    return s && s->origin && s->origin->basis_skipped;
}

int rad_solution_matrix_in_file(const rad_solution *s)
{
    const rad_matrix_file *mf = rad_solution_matrix_file(s);
    return mf && s->F && s->F->bytes == mf->bytes;
}

void rad_solution_release_matrix(rad_solution *s)
{
    if (!s || !s->F || !s->F->entries_loaded)
        return;
    const int in_file = rad_solution_matrix_in_file(s);
    rad_matrix_release_entries(s->F);
    if (in_file) /* still that section: as read without RAD_PART_MATRIX */
        s->origin->matrix_file.bytes = s->F->bytes;
}
