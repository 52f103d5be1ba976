/* cli.h - private to the command-line program (main.c and cli_*.c): the
 * commands and the argument helpers they share.  Not part of the library.
 * Every cli_* command returns the process exit status: 0, 1 or 2.
 */
#ifndef RAD_CLI_H
#define RAD_CLI_H

/* A numeric macro as a string literal, for help texts that name a default. */
#define CLI_STR_(x) #x
#define CLI_STR(x) CLI_STR_(x)

#include "../pipeline/pipeline.h"

#include <stdio.h>

int cli_solve(int argc, char **argv);
int cli_render(int argc, char **argv);
int cli_report(int argc, char **argv);
int cli_relight(int argc, char **argv);
int cli_ff(int argc, char **argv);
int cli_validate(int argc, char **argv);
int cli_export(int argc, char **argv);

/* Set by SIGINT or SIGTERM once cli_catch_stop has run: the work in
 * progress should stop, keeping what is done. */
extern volatile sig_atomic_t cli_stop;
/* Installs the handlers (only main handles signals).  A second Ctrl-C
 * ends the process at once. */
void cli_catch_stop(void);

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
/* Value parsers: 0 on success, else the exit status (message printed). */
int cli_parse_double(const char *opt, const char *s, double lo, double hi, double *out);
int cli_parse_u32(const char *opt, const char *s, uint32_t lo, uint32_t hi, uint32_t *out);
int cli_parse_bytes(const char *opt, const char *s, uint64_t *out);
int cli_parse_vec3(const char *opt, const char *s, rad_vec3 *out);
int cli_check_output_dir(const char *path);
/* 0 when path is an existing directory, else a usage error naming `what`
 * (the command and option whose -o it is). */
int cli_need_dir(const char *what, const char *path);
/* Reads a whole text file (at most 64 MiB) into *text (caller frees). */
int cli_read_text(const char *path, char **text, size_t *size, rad_error *err);
/* What every command does with an argument none of its options took: an
 * unknown option is an error, the first plain argument fills *slot, a
 * second one is an error.  0, or the exit status (message printed). */
int cli_other_arg(const char *cmd, const char *what, const char *arg, const char **slot);
/* Meshing, hemi-cube and solver options shared by solve, relight and ff:
 * 1 consumed, 0 not one of them, -1 bad value (printed). */
int cli_solve_option(int argc, char **argv, int *i, rad_solve_options *opt);
/* Turns on the progress bar when stderr is a terminal. */
void cli_enable_progress(rad_solve_options *opt);
/* Prints the form factors' estimate (rad_estimate) on stdout before they
 * are computed. */
void cli_enable_estimate(rad_solve_options *opt);

/* Most --camera options one command line may give (each may list cameras
 * separated by commas). */
#define CLI_MAX_CAMERA_ARGS 64

/* Camera options shared by render and relight --render. */
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
} cli_view;
/* 1 consumed, 0 not a view option, -1 bad value (printed). */
int cli_view_option(int argc, char **argv, int *i, cli_view *v);
/* The camera the view options name for s (0), or the exit status. */
int cli_view_camera(const rad_solution *s, const cli_view *v, rn_camera *out);
/* Renders s with the view and writes exr_path (and v->png if set). */
int cli_render_to_files(const rad_solution *s, const cli_view *v, const char *exr_path,
                        const char *png_path);

/* Many views in one render (cli_views.c): every camera of the scene, a
 * list of them, or a camera path, drawn on all CPUs from one load. */
typedef struct cli_many {
    int all_cameras;    /* --all-cameras */
    const char *path;   /* --path FILE */
    uint32_t threads;   /* --threads N; 0 = one per CPU */
    int no_png;         /* --no-png */
} cli_many;
/* 1 consumed, 0 not one of them, -1 bad value (printed). */
int cli_many_option(int argc, char **argv, int *i, cli_many *m);
/* 1 when the options ask for many views (a --camera value that lists
 * cameras needs the scene to tell: NULL scene answers for the rest). */
int cli_many_views(const cli_view *v, const cli_many *m, const rad_scene *scene);
/* Draws every view into DIR/NAME.exr (and .png): exit status. */
int cli_render_many(const rad_solution *s, const cli_view *v, const cli_many *m, const char *dir);
/* The final gather's options (render --gather, cli_gather.c). */
typedef struct cli_gather {
    int on;                    /* --gather */
    const char *given;         /* the first gather option seen (for "needs --gather") */
    rn_gather_options opt;
    const char *cache;         /* --cache FILE; NULL = SOLUTION.icache */
    int no_cache_file;         /* --no-cache-file */
} cli_gather;
/* 1 consumed, 0 not a gather option, -1 bad value (printed). */
int cli_gather_option(int argc, char **argv, int *i, cli_gather *g);
/* The gather render of s (read from sol_path) with the view, to exr_path
 * and v->png; prints one line of statistics. */
int cli_gather_to_files(const rad_solution *s, const char *sol_path, const cli_view *v,
                        const cli_gather *g, const char *exr_path);
/* Writes s as a JSON string (quotes, escapes). */
void cli_json_string(FILE *f, const char *s);
/* The cache beside sol_path, if any, for report (text or JSON member). */
void cli_report_cache(FILE *f, const char *sol_path, const rad_solution *s, int json);

#endif /* RAD_CLI_H */
