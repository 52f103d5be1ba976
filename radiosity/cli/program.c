/* program.c - main of the `radiosity` program: under mpirun it hands over
 * to radiosity-mpi (cli_process.c), else it sets the process up and runs
 * the command (main.c).  Invariant: nothing but main lives here, so that
 * radiosity-mpi links every other file of radiosity/cli/ with a main of
 * its own (program_mpi.c).
 */
#include "cli.h"

int main(int argc, char **argv)
{
    int rc = cli_exec_mpi(argv);
    if (rc)
        return rc;
    cli_process_start(argv);
    return cli_main(argc, argv);
}
