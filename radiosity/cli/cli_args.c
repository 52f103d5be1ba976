/* cli_args.c - what the commands share of their command lines: the value
 * parsers (numbers, sizes, X,Y,Z), the checks on output paths, the
 * meshing, hemi-cube and solver options (solve, relight, ff) with the
 * progress bars and estimate they turn on, and the view options (camera,
 * size, exposure, PNG, EXR compression) with the one-view drawing they
 * feed (render, solve's previews, relight --render).
 *
 * Invariant: a parser either fills its output and returns 0, or prints one
 * usage error and returns the exit status; an option taker returns 1 when
 * it consumed argv[*i] (and its value), 0 when the option is not its own,
 * -1 on a bad value (printed).  This file calls no command: it is below
 * every cli_<command>.c and above cli_print.c only.
 */
#include "cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---------------------------------------------------------------- values */

int cli_parse_double(const char *opt, const char *s, double lo, double hi, double *out)
{
    char *end;
    errno = 0;
    double v = s ? strtod(s, &end) : 0;
    if (!s || end == s || *end || errno || !isfinite(v) || v < lo || v > hi)
        return cli_usage_error("%s: '%s' is not a number in [%g, %g]", opt, s ? s : "", lo, hi);
    *out = v;
    return 0;
}

int cli_parse_u32(const char *opt, const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = s ? strtoull(s, &end, 10) : 0;
    if (!s || end == s || *end || errno || s[0] == '-' || v < lo || v > hi)
        return cli_usage_error("%s: '%s' is not a whole number in [%u, %u]", opt, s ? s : "", lo, hi);
    *out = (uint32_t)v;
    return 0;
}

int cli_parse_bytes(const char *opt, const char *s, uint64_t *out)
{
    char *end;
    errno = 0;
    double v = s ? strtod(s, &end) : 0;
    if (!s || end == s || errno || !(v > 0))
        return cli_usage_error("%s: '%s' is not a size (e.g. 512M, 4G)", opt, s ? s : "");
    double mult = 1;
    if (*end == 'K' || *end == 'k') mult = 1024.0, end++;
    else if (*end == 'M' || *end == 'm') mult = 1048576.0, end++;
    else if (*end == 'G' || *end == 'g') mult = 1073741824.0, end++;
    if (*end)
        return cli_usage_error("%s: '%s' is not a size (e.g. 512M, 4G)", opt, s);
    *out = (uint64_t)(v * mult);
    return 0;
}

int cli_parse_vec3(const char *opt, const char *s, rad_vec3 *out)
{
    double a, b, c;
    char tail;
    if (!s || sscanf(s, "%lf,%lf,%lf%c", &a, &b, &c, &tail) != 3 || !isfinite(a) || !isfinite(b) ||
        !isfinite(c))
        return cli_usage_error("%s: '%s' is not X,Y,Z", opt, s ? s : "");
    *out = rad_v3(a, b, c);
    return 0;
}

/* --------------------------------------------------------- solve options */

/* The progressive solver's progress on stderr: shots, and the unshot
 * power on a logarithmic bar from all of it (1) down to the tolerance. */
static void shots_bar(void *user, const sv_progress *p)
{
    (void)user;
    double f = p->unshot > 0.0 && p->tolerance < 1.0 ? log(p->unshot) / log(p->tolerance) : 1.0;
    f = f < 0.0 ? 0.0 : f > 1.0 ? 1.0 : f;
    int filled = (int)(f * 30.0);
    fprintf(stderr, "\rprogressive  [%.*s%*s] %u shots, unshot %.2e (to %.0e), %u rows   ", filled,
            "##############################", 30 - filled, "", p->shots, p->unshot, p->tolerance,
            p->rows_requested);
    if (p->done)
        fputc('\n', stderr);
    fflush(stderr);
}

void cli_enable_progress(rad_solve_options *opt)
{
    cli_progress_enable(opt); /* rows and element hemi-cubes: terminal or log */
    if (isatty(STDERR_FILENO)) {
        opt->solver.progress = shots_bar;
        opt->solver.progress_user = NULL;
    }
}

/* The estimate of a solve, on stdout before the form factors start. */
static void print_estimate(void *user, const rad_estimate *e)
{
    (void)user;
    char f[32], p[32], s[32], l[32];
    printf("estimate: %u patches (%u cells), %u rows of about %.0f entries (measured on %u): "
           "form factors %s, peak memory %s, solution file %s (memory limit for form factors %s)\n",
           e->patches, e->cells, e->rows, e->entries_per_row, e->sample_rows,
           rad_human_bytes((double)e->matrix_bytes, f, sizeof f),
           rad_human_bytes((double)e->peak_bytes, p, sizeof p),
           rad_human_bytes((double)e->file_bytes, s, sizeof s),
           rad_human_bytes((double)e->limit_bytes, l, sizeof l));
    fflush(stdout);
}

void cli_enable_estimate(rad_solve_options *opt)
{
    opt->on_estimate = print_estimate;
    opt->estimate_user = NULL;
}

int cli_gl_option(const char *opt, const char *v, hc_gl_kind *out)
{
    hc_gl_kind want;
    if (hc_gl_parse(v, &want) != 0)
        return cli_usage_error("%s: '%s' is not osmesa, egl or auto", opt, v ? v : "");
    rad_error err = {0};
    hc_gl_choice c;
    if (hc_gl_choose(want, &c, &err) != RAD_OK) {
        fprintf(stderr, "radiosity: error: %s %s: %s\n", opt, v, err.message);
        return cli_error_status(&err);
    }
    if (want == HC_GL_AUTO && c.kind == HC_GL_OSMESA)
        fprintf(stderr, "radiosity: %s auto: no GPU (%s); drawing with OSMesa\n", opt, c.reason);
    *out = c.kind;
    return 0;
}

/* Shared by solve, relight and ff: meshing, hemi-cube and solver options.
 * Returns 1 if argv[*i] was one of them (consuming its value), 0 if not, -1
 * on a bad value (message printed). */
int cli_solve_option(int argc, char **argv, int *i, rad_solve_options *opt)
{
    const char *a = argv[*i];
    const char *v = *i + 1 < argc ? argv[*i + 1] : NULL;
    int rc;
#define TAKE(expr) do { if ((rc = (expr)) != 0) return -1; (*i)++; return 1; } while (0)
    if (!strcmp(a, "--patch-size"))
        TAKE(cli_parse_double(a, v, 1e-9, 1e12, &opt->mesh.patch_size));
    if (!strcmp(a, "--max-patches"))
        TAKE(cli_parse_u32(a, v, 1, 100000000, &opt->mesh.max_patches));
    if (!strcmp(a, "--resolution"))
        TAKE(cli_parse_u32(a, v, 8, 4096, &opt->hemicube.resolution));
    if (!strcmp(a, "--processes"))
        TAKE(cli_parse_u32(a, v, 1, 256, &opt->hemicube.processes));
    if (!strcmp(a, "--gl"))
        TAKE(cli_gl_option(a, v, &opt->hemicube.gl));
    if (!strcmp(a, "--tolerance"))
        TAKE(cli_parse_double(a, v, 1e-15, 0.5, &opt->solver.tolerance));
    if (!strcmp(a, "--max-iterations"))
        TAKE(cli_parse_u32(a, v, 1, 100000000, &opt->solver.max_iterations));
    if (!strcmp(a, "--max-memory"))
        TAKE(cli_parse_bytes(a, v, &opt->max_memory));
    if (!strcmp(a, "--refine-threshold")) {
        /* 0 turns elements off here; the library's 0 means its default. */
        if ((rc = cli_parse_double(a, v, 0.0, 1e6, &opt->refine_threshold)) != 0)
            return -1;
        if (opt->refine_threshold == 0.0)
            opt->refine_threshold = RAD_REFINE_OFF;
        (*i)++;
        return 1;
    }
    if (!strcmp(a, "--min-element-size"))
        TAKE(cli_parse_double(a, v, 1e-12, 1e12, &opt->min_element_size));
    if (!strcmp(a, "--element-levels"))
        TAKE(cli_parse_u32(a, v, 0, RAD_MAX_ELEMENT_LEVEL, &opt->element_levels));
    if (!strcmp(a, "--pixel-emitters")) {
        opt->pixel_emitters = 1;
        return 1;
    }
    if (!strcmp(a, "--exact-near")) {
        opt->exact_near = 1;
        return 1;
    }
    if (!strcmp(a, "--element-hemicubes")) {
        opt->element_hemicubes = 1;
        return 1;
    }
    if (!strcmp(a, "--whole-contacts")) {
        opt->whole_contacts = 1;
        return 1;
    }
    if (!strcmp(a, "--accuracy")) {
        if (!v || (strcmp(v, "default") && strcmp(v, "high") && strcmp(v, "pixels")))
        {
            cli_usage_error("--accuracy '%s': default, high or pixels", v ? v : "");
            return -1;
        }
        opt->accuracy = !strcmp(v, "high") ? 1 : !strcmp(v, "pixels") ? -1 : 0;
        (*i)++;
        return 1;
    }
    if (!strcmp(a, "--pixel-near")) {
        opt->exact_near = -1;
        return 1;
    }
    if (!strcmp(a, "--strict")) {
        opt->load.strict = 1;
        return 1;
    }
    if (!strcmp(a, "--solver")) {
        if (!v || sv_method_parse(v, &opt->solver.method)) {
            cli_usage_error("--solver: '%s' is not gauss-seidel, jacobi or progressive", v ? v : "");
            return -1;
        }
        (*i)++;
        return 1;
    }
#undef TAKE
    return 0;
}

/* ------------------------------------------------- other arguments, files */

int cli_other_arg(const char *cmd, const char *what, const char *arg, const char **slot)
{
    if (arg[0] == '-')
        return cli_usage_error("%s: unknown option '%s'", cmd, arg);
    if (*slot)
        return cli_usage_error("%s: more than one %s given ('%s')", cmd, what, arg);
    *slot = arg;
    return 0;
}

int cli_read_text(const char *path, char **text, size_t *size, rad_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return rad_fail(err, RAD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len == cap) {
            cap = cap ? cap * 2 : 4096;
            if (cap > (64u << 20)) {
                free(buf);
                fclose(f);
                return rad_fail(err, RAD_ERR_LIMIT, "%s: larger than 64 MiB", path);
            }
            char *nb = realloc(buf, cap);
            if (!nb) {
                free(buf);
                fclose(f);
                return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", path);
            }
            buf = nb;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        return rad_fail(err, RAD_ERR_IO, "%s: read error", path);
    }
    *text = buf;
    *size = len;
    return RAD_OK;
}

/* Checks that an output's directory exists, so the error names it plainly
 * instead of surfacing as a failed temporary file. */
int cli_check_output_dir(const char *path)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash)
        return 0;
    if (slash == dir)
        return 0;
    *slash = '\0';
    struct stat st;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
        return cli_usage_error("%s: directory '%s' does not exist", path, dir);
    return 0;
}

int cli_need_dir(const char *what, const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISDIR(st.st_mode))
        return cli_usage_error("%s: -o '%s' must be an existing directory", what, path);
    return 0;
}

/* Makes directory `path` and its missing parents, as `mkdir -p` does (the
 * -o DIR of export and of a many-view render): 0, or an error naming the
 * part that could not be made. */
int cli_make_dir(const char *path, rad_error *err)
{
    char p[4096];
    size_t n = strlen(path);
    if (n == 0 || n >= sizeof p)
        return rad_fail(err, RAD_ERR_USAGE, "-o '%s': not a usable directory name", path);
    memcpy(p, path, n + 1);
    for (char *c = p + 1;; c++) {
        if (*c != '/' && *c != '\0')
            continue;
        char keep = *c;
        *c = '\0';
        if (mkdir(p, 0777) != 0 && errno != EEXIST)
            return rad_fail(err, RAD_ERR_IO, "%s: cannot create directory '%s': %s", path, p,
                            strerror(errno));
        *c = keep;
        if (!keep)
            break;
    }
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISDIR(st.st_mode))
        return rad_fail(err, RAD_ERR_IO, "%s: exists and is not a directory", path);
    return RAD_OK;
}

/* ------------------------------------------------------------------ views */

int cli_view_option(int argc, char **argv, int *i, cli_view *v)
{
    const char *a = argv[*i];
    const char *val = *i + 1 < argc ? argv[*i + 1] : NULL;
    int rc = 0;
    if (!strcmp(a, "--camera")) {
        if (!val)
            return cli_usage_error("--camera needs a name"), -1;
        if (v->camera_args == CLI_MAX_CAMERA_ARGS)
            return cli_usage_error("--camera given more than %d times (list cameras as A,B,C)",
                                   CLI_MAX_CAMERA_ARGS), -1;
        v->camera = v->cameras[v->camera_args++] = val;
    } else if (!strcmp(a, "--eye")) {
        rc = cli_parse_vec3(a, val, &v->eye), v->have_eye = 1;
    } else if (!strcmp(a, "--target")) {
        rc = cli_parse_vec3(a, val, &v->target), v->have_target = 1;
    } else if (!strcmp(a, "--up")) {
        rc = cli_parse_vec3(a, val, &v->up), v->have_up = 1;
    } else if (!strcmp(a, "--fov")) {
        rc = cli_parse_double(a, val, 0.01, 179.99, &v->fov), v->have_fov = 1;
    } else if (!strcmp(a, "--ortho")) {
        rc = cli_parse_double(a, val, 1e-12, 1e12, &v->ortho), v->have_ortho = 1;
    } else if (!strcmp(a, "--size")) {
        unsigned w, h;
        char tail;
        if (!val || sscanf(val, "%ux%u%c", &w, &h, &tail) != 2 || w < 1 || h < 1 || w > 16384 ||
            h > 16384)
            return cli_usage_error("--size: '%s' is not WxH (1..16384 each)", val ? val : ""), -1;
        v->width = w, v->height = h;
    } else if (!strcmp(a, "--png")) {
        if (!val)
            return cli_usage_error("--png needs a file name"), -1;
        v->png = val;
    } else if (!strcmp(a, "--exposure")) {
        rc = cli_parse_double(a, val, -64, 64, &v->exposure);
    } else if (!strcmp(a, "--ids")) {
        if (!val)
            return cli_usage_error("--ids needs a file name"), -1;
        v->ids = val;
    } else if (!strcmp(a, "--exr-compression")) {
        if (rn_exr_compression_parse(val, &v->exr_compression))
            return cli_usage_error("--exr-compression: '%s' is not none, zip, rle or piz",
                                   val ? val : ""), -1;
    } else {
        return 0;
    }
    if (rc)
        return -1;
    (*i)++;
    return 1;
}

int cli_view_camera(const rad_solution *s, const cli_view *v, rn_camera *out)
{
    rad_error err = {0};
    rn_camera cam;
    uint32_t w = v->width ? v->width : 512, h = v->height ? v->height : 512;
    if (v->have_fov && v->have_ortho)
        return cli_usage_error("--fov and --ortho exclude each other");
    if (v->have_eye || v->have_target) {
        if (!v->have_eye || !v->have_target)
            return cli_usage_error("--eye and --target go together");
        if (v->camera)
            return cli_usage_error("--camera and --eye/--target exclude each other");
        cam = (rn_camera){.eye = v->eye, .target = v->target,
                          .up = v->have_up ? v->up : rad_v3(0, 1, 0),
                          .yfov_deg = v->have_fov ? v->fov : 45.0, .width = w, .height = h};
    } else {
        if (rad_camera_from_scene(s->scene, v->camera, w, h, &cam, &err))
            return cli_error(&err);
        if (v->have_up)
            cam.up = v->up;
        if (v->have_fov) /* a field of view makes any camera perspective */
            cam.yfov_deg = v->fov, cam.orthographic = 0;
    }
    if (v->have_ortho)
        cam.orthographic = 1, cam.ymag = v->ortho;
    *out = cam;
    return 0;
}

/* The item buffer as the objects each pixel sees: a 16-bit binary PGM
 * (big-endian), 0 = background, k + 1 = object k (65535 for any beyond),
 * for tests that compare another renderer's image away from edges. */
static int write_ids(const rad_solution *s, const rn_image *img, const char *path, rad_error *err)
{
    rad_output *o = NULL;
    int rc = rad_output_open(path, &o, err);
    if (rc)
        return rc;
    char head[64];
    int n = snprintf(head, sizeof head, "P5\n%u %u\n65535\n", img->width, img->height);
    rad_output_write(o, head, (size_t)n);
    for (size_t q = 0; q < (size_t)img->width * img->height; q++) {
        uint32_t p = img->patch[q];
        uint32_t id = p == RAD_NONE || p >= s->mesh->patch_count ? 0 : s->mesh->patches[p].object + 1;
        id = id > 65535 ? 65535 : id;
        unsigned char b[2] = {(unsigned char)(id >> 8), (unsigned char)id};
        rad_output_write(o, b, 2);
    }
    return rad_output_commit(o, err);
}

int cli_render_to_files(const rad_solution *s, const cli_view *v, const char *exr_path,
                        const char *png_path)
{
    rad_error err = {0};
    rn_camera cam;
    int rc = cli_view_camera(s, v, &cam);
    if (rc)
        return rc;
    if (cli_check_output_dir(exr_path) || (png_path && cli_check_output_dir(png_path)))
        return 2;
    rn_image *img = NULL;
    rc = rad_render_solution(s, &cam, &img, &err);
    if (!rc)
        rc = rn_write_exr_with(img, exr_path, v->exr_compression, &err);
    if (!rc && png_path)
        rc = rn_write_png(img, png_path, v->exposure, &err);
    if (!rc && v->ids)
        rc = write_ids(s, img, v->ids, &err);
    rn_image_destroy(img);
    return rc ? cli_error(&err) : 0;
}
