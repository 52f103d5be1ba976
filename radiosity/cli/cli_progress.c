/* cli_progress.c - the hemi-cubes' progress on stderr, for solves long
 * enough to need it: the patches' form-factor rows and the elements'
 * hemi-cubes, each counted with its rate and an estimate of the time left.
 *
 * On a terminal one line is redrawn in place (carriage return); when stderr
 * is a file or a pipe, a plain line is written every few seconds
 * (RADIOSITY_PROGRESS_SECONDS, default 5), and at the end of a job that
 * lasted longer than that, so a long solve in a log is never silent and a
 * short one adds nothing.  Only the program prints: the
 * library calls back (hc_options.progress, rad_solve_options.progress_stage)
 * and this file writes.
 *
 * Invariant: the rate and the time left are measured from the start of the
 * current job (a call with fewer items done than the last one, or another
 * total, starts a new one), so neither is polluted by rows read back from a
 * journal or by an earlier stage.
 */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The progress of one process: the program has one solve at a time. */
static struct {
    int tty;
    double every;      /* seconds between plain lines */
    const char *stage; /* what is counted: "form factors" or "elements" */
    double t0;         /* when the current job began */
    double last;       /* when the last line was written */
    uint32_t done, total;
    int printed;       /* a plain line of this job was written */
} pg;

/* "1h02m", "3m05s" or "12s". */
static void duration(double s, char *buf, size_t size)
{
    if (!(s >= 0.0) || s > 1e7) {
        snprintf(buf, size, "?");
        return;
    }
    long t = lround(s);
    if (t >= 3600)
        snprintf(buf, size, "%ldh%02ldm", t / 3600, t % 3600 / 60);
    else if (t >= 60)
        snprintf(buf, size, "%ldm%02lds", t / 60, t % 60);
    else
        snprintf(buf, size, "%lds", t);
}

static void print_line(double now)
{
    const char *unit = strcmp(pg.stage, "elements") == 0 ? "hemi-cubes" : "rows";
    double el = now - pg.t0, rate = el > 0.0 ? pg.done / el : 0.0;
    char eta[32], took[32];
    duration(rate > 0.0 ? (pg.total - pg.done) / rate : -1.0, eta, sizeof eta);
    duration(el, took, sizeof took);
    int pct = pg.total ? (int)(100.0 * pg.done / pg.total) : 100;
    if (pg.tty) {
        int filled = pct * 20 / 100;
        fprintf(stderr, "\r%-12s [%.*s%*s] %3d%% %u/%u %s, %.1f %s/s, ETA %s   ", pg.stage,
                filled, "####################", 20 - filled, "", pct, pg.done, pg.total, unit,
                rate, unit, eta);
        if (pg.done == pg.total)
            fputc('\n', stderr);
    } else {
        fprintf(stderr, "radiosity: %s: %u/%u %s (%d%%), %.1f %s/s, %s elapsed, ETA %s\n",
                pg.stage, pg.done, pg.total, unit, pct, rate, unit, took, eta);
    }
    fflush(stderr);
    pg.last = now;
    pg.printed = 1;
}

static void on_progress(void *user, uint32_t done, uint32_t total)
{
    (void)user;
    double now = rad_seconds();
    if (done < pg.done || total != pg.total || pg.done == pg.total) {
        pg.t0 = now;
        pg.last = pg.tty ? 0.0 : now; /* a plain line first after `every` */
        pg.printed = 0;
    }
    pg.done = done;
    pg.total = total;
    /* A terminal is redrawn at most 10 times a second; a log gets a line
     * every `every` seconds, and the job's last one only when it had others
     * (a job shorter than that leaves the log as it was). */
    double gap = pg.tty ? 0.1 : pg.every;
    if (now - pg.last >= gap || (done == total && (pg.tty || pg.printed)))
        print_line(now);
}

static void on_stage(void *user, const char *stage)
{
    (void)user;
    pg.stage = stage;
    pg.done = pg.total = 0;
}

void cli_progress_enable(rad_solve_options *opt)
{
    pg.tty = isatty(STDERR_FILENO);
    pg.every = 5.0;
    const char *s = getenv("RADIOSITY_PROGRESS_SECONDS");
    char *end;
    double v = s ? strtod(s, &end) : 0.0;
    if (s && end != s && *end == '\0' && v > 0.0 && v < 1e6)
        pg.every = v;
    pg.stage = "form factors";
    pg.done = pg.total = 0;
    opt->hemicube.progress = on_progress;
    opt->hemicube.progress_user = NULL;
    opt->progress_stage = on_stage;
}
