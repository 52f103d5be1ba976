/* cli_process.c - the process around the commands: how it starts (malloc's
 * memory on huge pages, which takes running the program again, and the
 * size from which blocks get their own mapping) and how it is asked to
 * stop (SIGINT, SIGTERM).
 *
 * In a file of its own, not in cli_args.c: none of it is about arguments,
 * and all of it is process-wide state that must be set once, by main
 * before any command (cli_process_start) or by the command that can stop
 * early (cli_catch_stop), and the hand-over to radiosity-mpi under mpirun
 * (cli_exec_mpi).  It calls no other file of radiosity/cli/.
 */
#include "cli.h"

#include <errno.h>
#include <malloc.h>
#include <stdio.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

volatile sig_atomic_t cli_stop;

/* The first SIGINT or SIGTERM asks the work to stop (the form factors end
 * at the next finished row, which is kept); the handler then steps aside,
 * so a second Ctrl-C ends the process at once - the rows written so far
 * survive that too. */
static void on_stop(int sig)
{
    cli_stop = 1;
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, NULL);
}

void cli_catch_stop(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

/* Transparent huge pages for malloc's memory: glibc's tunable
 * glibc.malloc.hugetlb=1 (glibc 2.35 on) has malloc ask the kernel for 2 MiB
 * pages (madvise), where Debian's default gives them only to who asks.  On
 * the virtual machines this runs on, a page fault costs several
 * microseconds, and faults were a third of what reading and drawing a large
 * solution takes: `render` of the 32k-patch Cornell box at 1024², 0.40 ->
 * 0.28 s; a solve is unchanged (its time is llvmpipe's), and memory grows
 * by at most a few MB.  The tunable is read only when a program starts, so
 * the program runs itself again once, with it added to GLIBC_TUNABLES; nothing
 * has happened yet but this.  When it is already there (the second start,
 * or a user's choice: glibc.malloc.hugetlb=0 turns it off), or the program
 * cannot be run again, it goes on as it is.  Under Valgrind (its preload
 * library in LD_PRELOAD) it does not try: /proc/self/exe is Valgrind's
 * tool there, and a program started again would run outside it. */
static void with_huge_pages(char **argv)
{
    const char *was = getenv("GLIBC_TUNABLES"), *pre = getenv("LD_PRELOAD");
    if ((was && strstr(was, "glibc.malloc.hugetlb")) || (pre && strstr(pre, "vgpreload")))
        return;
    char value[1024];
    int n = snprintf(value, sizeof value, "%s%sglibc.malloc.hugetlb=1", was ? was : "",
                     was && *was ? ":" : "");
    if (n < 0 || (size_t)n >= sizeof value)
        return;
    char *keep = was ? strdup(was) : NULL;
    if ((was && !keep) || setenv("GLIBC_TUNABLES", value, 1) != 0) {
        free(keep);
        return;
    }
    execv("/proc/self/exe", argv);
    if (keep) /* not run again: the environment as it was */
        setenv("GLIBC_TUNABLES", keep, 1);
    else
        unsetenv("GLIBC_TUNABLES");
    free(keep);
}

void cli_process_start(char **argv)
{
    with_huge_pages(argv);
    /* Blocks of 1 MiB and more always get their own mapping.  Left to
     * itself, glibc raises that threshold to the largest block freed (up
     * to 32 MiB) and then serves such blocks from the heap, where a growing
     * array's realloc copies (old and new resident at once) and a freed
     * block's pages stay resident: the element rows refinement grows,
     * beside F, cost the 8k-patch solve 23 MB more peak (report/store.md).
     * (The hemi-cube workers set their own, after the fork.) */
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
}

/* Under mpirun the work goes to radiosity-mpi, a program of its own (the
 * Makefile's PROG_MPI) linked with MPI, beside this one: so this program
 * never loads MPI's libraries, and runs where none are installed.  Ranks
 * started by mpirun carry OMPI_COMM_WORLD_SIZE. */
int cli_exec_mpi(char **argv)
{
    if (!getenv("OMPI_COMM_WORLD_SIZE"))
        return 0;
    char path[4096];
    ssize_t n = readlink("/proc/self/exe", path, sizeof path - 32);
    if (n <= 0) {
        fprintf(stderr, "radiosity: error: /proc/self/exe: started by mpirun, but the program's "
                        "own path cannot be read\n");
        return 1;
    }
    path[n] = '\0';
    char *slash = strrchr(path, '/');
    strcpy(slash ? slash + 1 : path, "radiosity-mpi");
    execv(path, argv);
    fprintf(stderr, "radiosity: error: %s: started by mpirun (OMPI_COMM_WORLD_SIZE is set), but "
                    "the MPI program cannot be run: %s\n", path, strerror(errno));
    return 1;
}
