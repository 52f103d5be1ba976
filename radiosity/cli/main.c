/* main.c - the `radiosity` command: argument parsing, printing and exit
 * codes around the library.  Nothing else in the project prints or exits.
 *
 *   radiosity solve    SCENE -o SOLUTION [options] [--fresh]
 *   radiosity render   SOLUTION -o IMAGE.exr [--png FILE] [camera options] [--gather ...]
 *   radiosity render   SOLUTION -o DIR --all-cameras | --camera A,B | --path FILE
 *   radiosity report   SOLUTION [--json]
 *   radiosity relight  SOLUTION -o OUT [--light N=off|on|S] [--emission N=v,..]
 *                      [--reflectance N=v,..] [--variations FILE [--render]]
 *   radiosity ff       SCENE_OR_SOLUTION --from A --to B [--json] [--matrix]
 *   radiosity validate [--json] [--quick]
 *   radiosity export   SOLUTION -o DIR
 *
 * Errors print one line "radiosity: error: FILE: WHERE: WHAT" and exit 2 for
 * bad input or usage, 1 for failures of the machine (memory, GL).  Outputs
 * are written through temporary files, so an error never leaves a partial
 * file.
 */
#include "cli.h"

#include <errno.h>
#include <malloc.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ------------------------------------------------------------ small helpers */

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

/* Progress on stderr, only when stderr is a terminal. */
static void progress_bar(void *user, uint32_t done, uint32_t total)
{
    (void)user;
    static int last = -1;
    int pct = total ? (int)(100.0 * done / total) : 100;
    if (pct == last && done != total)
        return;
    last = pct;
    int filled = pct * 30 / 100;
    fprintf(stderr, "\rform factors [%.*s%*s] %3d%% %u/%u rows", filled,
            "##############################", 30 - filled, "", pct, done, total);
    if (done == total) {
        fputc('\n', stderr);
        last = -1;
    }
    fflush(stderr);
}

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
    if (isatty(STDERR_FILENO)) {
        opt->hemicube.progress = progress_bar;
        opt->hemicube.progress_user = NULL;
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
           "form factors %s, peak memory %s, solution file %s (form factors may take %s)\n",
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

/* ------------------------------------------------------------------- help */

static const char usage[] =
    "usage: radiosity COMMAND [options]\n"
    "\n"
    "commands:\n"
    "  solve SCENE -o SOLUTION      load, mesh, form factors, solve, store\n"
    "      --patch-size S           target patch edge length (scene units)\n"
    "      --resolution R           hemi-cube resolution (default " CLI_STR(HC_DEFAULT_RESOLUTION) ")\n"
    "      --processes P            form-factor worker processes (default: CPUs)\n"
    "      --solver NAME            gauss-seidel (default), jacobi, progressive\n"
    "      --tolerance T            solver tolerance (default " CLI_STR(SV_DEFAULT_TOLERANCE) ")\n"
    "      --max-iterations N       solver iteration limit\n"
    "      --max-patches N          refuse a mesh of more than N patches (default 2 million)\n"
    "      --max-memory SIZE        limit for the form-factor matrix (e.g. 4G); progressive\n"
    "                               keeps its rows within it, computing some again\n"
    "      --pixel-emitters         form factors to emitters by pixel counts, not exactly\n"
    "      --exact-near             near patches (closer than their size) exactly (default)\n"
    "      --pixel-near             near patches by pixel counts, like the others\n"
    "      --strict                 glTF: refuse reflectance >= 1, primitives without a\n"
    "                               material or area, unreadable textures (default: clamp\n"
    "                               to 0.95, glTF's default material, skip, warn)\n"
    "      --refine-threshold T     elements: split where the drawn B misses the B of the\n"
    "                               element's four children by more than T × the brightest\n"
    "                               reflecting patch's B, weighted by area (default "
    CLI_STR(RAD_DEFAULT_REFINE_THRESHOLD) "; 0: no elements)\n"
    "      --element-hemicubes      every element's row from a hemi-cube of its own (slow)\n"
    "      --min-element-size S     smallest element edge (default: 1/8 of its patch)\n"
    "      --element-levels L       uniform elements: split every patch L times\n"
    "      --preview-every K|Ts     progressive: write a preview image every K shots or\n"
    "                               every T seconds of solving (e.g. 2s); --camera NAME,\n"
    "                               --size WxH, --exposure EV as for render\n"
    "      --preview-dir DIR        where previews go (default: the solution's directory)\n"
    "      --fresh                  compute every row again: do not resume from the rows an\n"
    "                               interrupted run kept in SOLUTION.partial\n"
    "  render SOLUTION -o IMAGE.exr draw a view (radiance, linear OpenEXR)\n"
    "      --png FILE               also write an sRGB PNG preview\n"
    "      --exposure EV            PNG exposure in stops (default 0)\n"
    "      --exr-compression C      none (default), zip, rle or piz: zip: files\n"
    "                               15 % smaller, a 1024x1024 view 5x the CPU\n"
    "      --camera NAME            a camera of the scene (default: the first)\n"
    "      --eye X,Y,Z --target X,Y,Z --up X,Y,Z --fov DEG   an explicit camera\n"
    "      --ortho H                orthographic, a view 2H high (scene units)\n"
    "      --size WxH               image size (default 512x512)\n"
    "  render SOLUTION -o DIR VIEWS many views from one load, on every CPU: DIR/NAME.exr\n"
    "                               and DIR/NAME.png for each (DIR must exist)\n"
    "      --all-cameras            every camera of the scene (NAME: the camera's)\n"
    "      --camera A,B,C           these cameras (or --camera repeated)\n"
    "      --path FILE              a fly-through, one view per line (NAME: frame-0001..):\n"
    "                               eye X,Y,Z target X,Y,Z [up X,Y,Z] [fov DEG]\n"
    "      --threads N              drawing threads (default: CPUs), or shading\n"
    "                               threads with --gather (default: CPUs)\n"
    "      --no-png                 EXR only\n"
    "      --gather                 ray-trace the view from the solution (final gather):\n"
    "                               direct light per pixel, indirect gathered from the\n"
    "                               stored B through Ward's irradiance cache, glossy lobes\n"
    "      --epsilon A              cache error bound a (default " CLI_STR(RN_DEFAULT_EPSILON) ")\n"
    "      --no-cache               gather at every pixel (the reference; slow)\n"
    "      --cache FILE             the cache file (default SOLUTION.icache)\n"
    "      --no-cache-file          neither read nor write a cache file\n"
    "      --no-gradients           cache without Ward & Heckbert's gradients\n"
    "      --gather-rays N          hemisphere rays per gather (default " CLI_STR(RN_DEFAULT_GATHER_RAYS) ")\n"
    "      --light-samples N        samples per area light and pixel (default " CLI_STR(RN_DEFAULT_LIGHT_SAMPLES) ")\n"
    "      --glossy-rays N          lobe samples per glossy pixel (default " CLI_STR(RN_DEFAULT_GLOSSY_RAYS) ")\n"
    "      --glossy MODE            auto, sample or light-vector (indirect light on lobes)\n"
    "      --max-depth D            mirror reflections followed (default " CLI_STR(RN_DEFAULT_MAX_DEPTH) ")\n"
    "      --min-radius PX          smallest valid radius of a cache record, pixels (default " CLI_STR(RN_DEFAULT_MIN_RADIUS_PX) ")\n"
    "  report SOLUTION [--json]     per-object power balance, solver and stage times\n"
    "  relight SOLUTION -o OUT      re-solve with changed lights or colours, no new hemi-cubes\n"
    "      --light NAME=off|on|S    switch or scale an emitting object, punctual light or material\n"
    "      --emission NAME=V[,V..]  set emission (one value per band, or one for all)\n"
    "      --reflectance NAME=V[,V..] set reflectance\n"
    "      --variations FILE        run each variant of FILE; OUT is a directory\n"
    "      --render                 with --variations: write NAME.exr/.png, not NAME.sol\n"
    "  ff SCENE_OR_SOLUTION --from A --to B [--json] | --matrix\n"
    "                               object-to-object form factors\n"
    "  validate [--json] [--quick]  form factors against analytic catalog values\n"
    "  export SOLUTION -o DIR       open data: DIR/patches.csv (ρ, E, B per patch), F.mtx\n"
    "                               (Matrix Market), elements.csv and elements-F.mtx\n"
    "                               (docs/export.md; DIR must exist)\n"
    "\n"
    "  --help, --version\n";

/* Transparent huge pages for malloc's memory: glibc's tunable
 * glibc.malloc.hugetlb=1 (glibc 2.35 on) has malloc ask the kernel for 2 MiB
 * pages (madvise), where Debian's default gives them only to who asks.  On
 * the virtual machines this runs on, a page fault costs several
 * microseconds, and faults were a third of what reading and drawing a large
 * solution takes: `render` of the 32k-patch Cornell box at 1024², 0.40 ->
 * 0.28 s; a solve is unchanged (its time is llvmpipe's), and memory grows
 * by at most a few MB.  The tunable is read only when a program starts, so
 * main runs itself again once, with it added to GLIBC_TUNABLES; nothing
 * has happened yet but this.  When it is already there (the second start,
 * or a user's choice: glibc.malloc.hugetlb=0 turns it off), or the program
 * cannot be run again, main goes on as it is.  Under Valgrind (its preload
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

int main(int argc, char **argv)
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
    if (argc < 2)
        return cli_usage_error("no command given");
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
        fputs(usage, stdout);
        return 0;
    }
    if (!strcmp(cmd, "--version")) {
        printf("radiosity %s\n", RAD_VERSION_STRING);
        return 0;
    }
    if (!strcmp(cmd, "solve"))
        return cli_solve(argc - 2, argv + 2);
    if (!strcmp(cmd, "render"))
        return cli_render(argc - 2, argv + 2);
    if (!strcmp(cmd, "report"))
        return cli_report(argc - 2, argv + 2);
    if (!strcmp(cmd, "relight"))
        return cli_relight(argc - 2, argv + 2);
    if (!strcmp(cmd, "ff"))
        return cli_ff(argc - 2, argv + 2);
    if (!strcmp(cmd, "validate"))
        return cli_validate(argc - 2, argv + 2);
    if (!strcmp(cmd, "export"))
        return cli_export(argc - 2, argv + 2);
    return cli_usage_error("unknown command '%s'", cmd);
}
