/* cli.h - private to the command-line program (radiosity/cli/): the
 * commands and what they share.  Not part of the library.
 *
 * The files call one way, down this list, never back up and never across
 * (checked on the objects with nm: no file calls one that calls it):
 *   main.c            usage text and dispatch: COMMAND -> cli_COMMAND
 *   cli_<command>.c   one command each (solve, render, report, relight,
 *                     ff, validate, export, bake); a command prints its own
 *                     results and calls no other command
 *   cli_args.c        argument parsers and options shared by commands:
 *                     solve options, view options, a view drawn to files
 *   cli_progress.c    the hemi-cubes' progress lines on stderr
 *   cli_process.c     the process: huge pages, malloc, stop signals
 *   cli_print.c       the error, warning and usage-error lines
 * Every cli_* command returns the process exit status: 0, 1, 2 (or 130
 * for a solve stopped by a signal).
 */
#ifndef RAD_CLI_H
#define RAD_CLI_H

/* A numeric macro as a string literal, for help texts that name a default. */
#define CLI_STR_(x) #x
#define CLI_STR(x) CLI_STR_(x)

#include "../pipeline/pipeline.h"

#include <stdio.h>

/* ------------------------------------------------ the commands (cli_*.c) */

int cli_solve(int argc, char **argv);
int cli_render(int argc, char **argv);
int cli_report(int argc, char **argv);
int cli_relight(int argc, char **argv);
int cli_ff(int argc, char **argv);
/* ff on a .vs3 file (cli_view3d.c): --matrix prints, out (may be NULL) gets
 * View3D's text output; opt as cli_ff prepared it. */
int cli_ff_view3d(const char *in, const rad_solve_options *opt, int matrix, const char *out);
int cli_validate(int argc, char **argv);
int cli_export(int argc, char **argv);
int cli_bake(int argc, char **argv);

/* ----------------------------------------------- the process (cli_process.c) */

/* The first thing main does: may run the program again with huge pages
 * (nothing else has happened yet), then sets malloc's mmap threshold. */
void cli_process_start(char **argv);
/* main.c: the command named by argv[1], run; its exit status. */
int cli_main(int argc, char **argv);
/* cli_process.c: when mpirun started this program (OMPI_COMM_WORLD_SIZE is
 * set), runs radiosity-mpi from the program's own directory in its place;
 * returns only when it is not so started, or with the status of an error
 * it printed (the program could not be run). */
int cli_exec_mpi(char **argv);
/* Set by SIGINT or SIGTERM once cli_catch_stop has run: the work in
 * progress should stop, keeping what is done. */
extern volatile sig_atomic_t cli_stop;
/* Installs the handlers (only the program handles signals, never the
 * library).  A second Ctrl-C ends the process at once. */
void cli_catch_stop(void);

/* ---------------------------------------------- progress (cli_progress.c) */

/* Sets opt's hemi-cube progress and stage callbacks: rows (or element
 * hemi-cubes) done, their rate and the time left, on one redrawn line when
 * stderr is a terminal, else one plain line every RADIOSITY_PROGRESS_SECONDS
 * (default 5) and at the end of each job. */
void cli_progress_enable(rad_solve_options *opt);

/* ---------------------------------------------------- printing (cli_print.c) */

/* Prints "radiosity: error: MESSAGE" and returns the exit status for it. */
int cli_error(const rad_error *err);
/* The exit status for an error, without printing. */
int cli_error_status(const rad_error *err);
/* Prints a library warning (a rad_warn_fn; user unused). */
void cli_warn(void *user, const char *message);
/* Prints a usage error and returns 2. */
int cli_usage_error(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* --------------------------------------------------- arguments (cli_args.c) */

/* Value parsers: 0 on success, else the exit status (message printed). */
int cli_parse_double(const char *opt, const char *s, double lo, double hi, double *out);
int cli_parse_u32(const char *opt, const char *s, uint32_t lo, uint32_t hi, uint32_t *out);
int cli_parse_bytes(const char *opt, const char *s, uint64_t *out);
int cli_parse_vec3(const char *opt, const char *s, rad_vec3 *out);
int cli_check_output_dir(const char *path);
/* 0 when path is an existing directory, else a usage error naming `what`
 * (the command and option whose -o it is). */
int cli_need_dir(const char *what, const char *path);
/* Makes directory path and its missing parents (mkdir -p): 0 or an error. */
int cli_make_dir(const char *path, rad_error *err);
/* Reads a whole text file (at most 64 MiB) into *text (caller frees). */
int cli_read_text(const char *path, char **text, size_t *size, rad_error *err);
/* What every command does with an argument none of its options took: an
 * unknown option is an error, the first plain argument fills *slot, a
 * second one is an error.  0, or the exit status (message printed). */
int cli_other_arg(const char *cmd, const char *what, const char *arg, const char **slot);
/* Meshing, hemi-cube and solver options shared by solve, relight and ff:
 * 1 consumed, 0 not one of them, -1 bad value (printed). */
int cli_solve_option(int argc, char **argv, int *i, rad_solve_options *opt);
/* --gl osmesa|egl|auto (v its value), settled at once by hc_gl_choose:
 * auto that finds no GPU says so in one line and takes OSMesa; egl that
 * cannot start is an error (printed).  0, or the exit status. */
int cli_gl_option(const char *opt, const char *v, hc_gl_kind *out);
/* Turns on the progress bar when stderr is a terminal. */
void cli_enable_progress(rad_solve_options *opt);
/* Prints the form factors' estimate (rad_estimate) on stdout before they
 * are computed. */
void cli_enable_estimate(rad_solve_options *opt);

/* Most --camera options one command line may give (each may list cameras
 * separated by commas). */
#define CLI_MAX_CAMERA_ARGS 64

/* Camera options shared by render, solve --preview-every and relight
 * --render. */
typedef struct cli_view {
    const char *camera;                         /* the last --camera */
    const char *cameras[CLI_MAX_CAMERA_ARGS];   /* every --camera, in order */
    uint32_t camera_args;
    int have_eye, have_target, have_up, have_fov, have_ortho;
    rad_vec3 eye, target, up;
    double fov;
    double ortho; /* --ortho: half-height of an orthographic view */
    uint32_t width, height;
    const char *png;
    double exposure;
    rn_exr_compression exr_compression; /* --exr-compression */
    const char *ids;    /* --ids FILE: the item buffer's objects, one view only */
} cli_view;
/* 1 consumed, 0 not a view option, -1 bad value (printed). */
int cli_view_option(int argc, char **argv, int *i, cli_view *v);
/* The camera the view options name for s (0), or the exit status. */
int cli_view_camera(const rad_solution *s, const cli_view *v, rn_camera *out);
/* Renders s with the view and writes exr_path (and png_path if set). */
int cli_render_to_files(const rad_solution *s, const cli_view *v, const char *exr_path,
                        const char *png_path);

#endif /* RAD_CLI_H */
