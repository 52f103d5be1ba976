/* cli_print.c - the lines the program prints when something is wrong: an
 * error from the library ("radiosity: error: FILE: WHERE: WHAT"), a
 * warning, a usage error; and the exit status each one means.
 *
 * Invariant: an error is one line on stderr, and its status is 2 for bad
 * input or usage, 1 for a failure of the machine (memory, GL).  This file
 * is the bottom of the CLI: it calls nothing else in radiosity/cli/.
 */
#include "cli.h"

#include <stdarg.h>
#include <stdio.h>

int cli_error_status(const rad_error *err)
{
    return (err->code == RAD_ERR_NOMEM || err->code == RAD_ERR_GL) ? 1 : 2;
}

int cli_error(const rad_error *err)
{
    fprintf(stderr, "radiosity: error: %s\n", err->message);
    return cli_error_status(err);
}

void cli_warn(void *user, const char *message)
{
    (void)user;
    fprintf(stderr, "radiosity: warning: %s\n", message);
}

int cli_usage_error(const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    fprintf(stderr, "radiosity: error: %s (see 'radiosity --help')\n", msg);
    return 2;
}
