/* bench_view3d.c - time and accuracy of `ff FILE.vs3` (issue 39) on the
 * test's View3D inputs: the unit cube (closed forms), and the L-shaped
 * room (emit=1: script-F), two squares with an obstruction and a wall with
 * a window, scored against tools/mc_vs3.c's Monte Carlo estimates shipped
 * in test/data/view3d/NAME.mc (standard errors <= 6e-5).
 *
 * Rows per scene: the hemi-cube counting pixels at its defaults (what ff
 * did before issue 39, --pixel-factors), then every patch an exact target
 * (rad_solve_options.exact_all, ff's default for .vs3) at patch sizes 1,
 * 0.5, 0.25 and the mesher's default.  Error: over the reported factors
 * >= 0.01, the worst and mean |F / F_ref − 1|.  Times: wall-clock of load,
 * solve and the View3D algebra, and CPU seconds of this process and its
 * hemi-cube workers, on a machine shared with others.  Nothing here
 * asserts anything.
 */
#include "../radiosity/pipeline/pipeline.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

static double cpu_seconds(void)
{
    struct rusage a, b;
    getrusage(RUSAGE_SELF, &a);
    getrusage(RUSAGE_CHILDREN, &b);
    return a.ru_utime.tv_sec + a.ru_stime.tv_sec + b.ru_utime.tv_sec + b.ru_stime.tv_sec +
           1e-6 * (a.ru_utime.tv_usec + a.ru_stime.tv_usec + b.ru_utime.tv_usec + b.ru_stime.tv_usec);
}

static const char cube[] =
    "T unit cube\nC encl=1\nF 3\n"
    "V 1 0 0 0\nV 2 1 0 0\nV 3 1 1 0\nV 4 0 1 0\nV 5 0 0 1\nV 6 1 0 1\nV 7 1 1 1\nV 8 0 1 1\n"
    "S 1 1 2 3 4 0 0 0.5 bottom\nS 2 1 4 8 5 0 0 0.5 x0\nS 3 1 5 6 2 0 0 0.5 y0\n"
    "S 4 7 6 5 8 0 0 0.5 top\nS 5 7 3 2 6 0 0 0.5 x1\nS 6 7 8 4 3 0 0 0.5 y1\n";

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    char *b = malloc(1 << 20);
    *len = b ? fread(b, 1, (1 << 20) - 1, f) : 0;
    fclose(f);
    if (b)
        b[*len] = '\0';
    return b;
}

/* The reference of reported pair (a, b): the cube's closed forms, else the
 * Monte Carlo file's line "a,b,value,stderr"; -1 when none. */
static double reference(const char *mc, const char *a, const char *b)
{
    if (!mc) {
        static const char *opp[] = {"bottom", "top", "x0", "x1", "y0", "y1"};
        if (!strcmp(a, b))
            return 0.0;
        for (int k = 0; k < 6; k += 2)
            if ((!strcmp(a, opp[k]) && !strcmp(b, opp[k + 1])) ||
                (!strcmp(b, opp[k]) && !strcmp(a, opp[k + 1])))
                return 0.199824896;
        return 0.200043776;
    }
    char key[256];
    snprintf(key, sizeof key, "\n%s,%s,", a, b);
    const char *p = strstr(mc, key);
    return p ? atof(p + strlen(key)) : -1.0;
}

static void run(const char *label, const char *text, const char *mc, int exact, double size)
{
    rad_error err = {0};
    rad_scene *s = NULL;
    rad_vs3 *m = NULL;
    rad_solution *sol = NULL;
    rad_vs3_factors *f = NULL;
    rad_solve_options opt = {0};
    opt.all_rows = 1;
    opt.exact_all = exact;
    opt.mesh.patch_size = size;
    opt.refine_threshold = RAD_REFINE_OFF;
    opt.load.allow_no_emitter = 1;
    double t0 = rad_seconds(), c0 = cpu_seconds();
    if (rad_vs3_parse(text, strlen(text), label, NULL, &s, &m, &err) ||
        rad_solve_scene(s, &opt, &sol, &err) || rad_vs3_factors_compute(sol, m, &f, &err)) {
        printf("| %s | %s | failed: %s |\n", label, exact ? "exact" : "pixels", err.message);
    } else {
        uint32_t patches = sol->mesh->patch_count;
        rad_solution_destroy(sol); /* the workers end: their CPU time counts */
        sol = NULL;
        double wall = rad_seconds() - t0, cpu = cpu_seconds() - c0, worst = 0, sum = 0;
        uint32_t count = 0;
        for (uint32_t i = 0; i < f->n; i++)
            for (uint32_t j = 0; j < f->n; j++) {
                double r = reference(mc, m->surfaces[f->surface[i]].name,
                                     m->surfaces[f->surface[j]].name);
                if (r < 0.01)
                    continue;
                double e = fabs(f->F[i * f->n + j] / r - 1);
                worst = fmax(worst, e);
                sum += e;
                count++;
            }
        char setting[64];
        if (size > 0)
            snprintf(setting, sizeof setting, "%s, patch %g", exact ? "exact" : "pixels", size);
        else
            snprintf(setting, sizeof setting, "%s, default patch", exact ? "exact" : "pixels");
        printf("| %s | %s | %u | %u | %.3f | %.3f | %.3f | %.3f |\n", label, setting, patches,
               count, 100 * worst, count ? 100 * sum / count : 0.0, wall, cpu);
    }
    rad_vs3_factors_destroy(f);
    rad_solution_destroy(sol);
    rad_vs3_destroy(m);
}

int main(void)
{
    static const char *names[] = {"cube", "lroom", "obstruct", "window"};
    printf("| scene | setting | patches | factors >= 0.01 | worst %% | mean %% | wall s | CPU s |\n");
    printf("|---|---|---|---|---|---|---|---|\n");
    for (int k = 0; k < 4; k++) {
        char path[128], *text = NULL, *mc = NULL;
        size_t len;
        if (k > 0) {
            snprintf(path, sizeof path, "test/data/view3d/%s.vs3", names[k]);
            text = slurp(path, &len);
            snprintf(path, sizeof path, "test/data/view3d/%s.mc", names[k]);
            mc = slurp(path, &len);
            if (!text || !mc) {
                printf("| %s | cannot read test/data/view3d (run from the repository root) |\n",
                       names[k]);
                free(text);
                free(mc);
                continue;
            }
        }
        const char *t = k ? text : cube;
        run(names[k], t, mc, 0, 0.0);
        static const double sizes[] = {1.0, 0.5, 0.25, 0.0};
        for (int z = 0; z < 4; z++)
            run(names[k], t, mc, 1, sizes[z]);
        free(text);
        free(mc);
    }
    return 0;
}
