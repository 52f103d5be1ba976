/* program_mpi.c - main of `radiosity-mpi`, the program `radiosity` runs in
 * its place under mpirun (docs/cluster.md).  Rank 0 runs the command as
 * `radiosity` would, its hemi-cube engines spreading rows over the ranks
 * (hemicube/mpi_ranks.c), and prints one line naming the ranks; every other
 * rank serves rank 0's engines and prints nothing.  Invariant: MPI is
 * started before anything else runs and ended last, on every rank; this
 * file calls MPI only through hemicube.h's hc_mpi_* functions.
 */
#include "cli.h"

#include <stdio.h>

int main(int argc, char **argv)
{
    cli_process_start(argv); /* may run the program again: before MPI starts */
    int rank = 0, size = 1;
    rad_error err = {0};
    if (hc_mpi_start(&argc, &argv, &rank, &size, &err) != RAD_OK)
        return cli_error(&err);
    int rc;
    if (rank == 0) {
        rc = cli_main(argc, argv);
        char line[4096];
        hc_mpi_summary(line, sizeof line);
        fflush(stdout);
        fprintf(stderr, "%s\n", line);
    } else if (hc_mpi_serve(&err) == RAD_OK) {
        rc = 0;
    } else { /* the first serving rank speaks for them */
        rc = err.code == RAD_ERR_INTERRUPTED && rank != 1 ? 1 : cli_error(&err);
    }
    fflush(NULL);
    hc_mpi_finish(rank != 0 && rc != 0);
    return rc;
}
