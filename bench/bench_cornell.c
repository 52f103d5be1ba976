/* bench_cornell.c - accuracy against time on the glTF Cornell box (issue 18).
 *
 * The engine solves models/cornell.gltf (render included) at several
 * refinement settings and each image, 256×256 through the scene's camera,
 * is scored against the independent path-traced reference shipped in
 * bench/data/ (made once by tools/pathtrace.c, the command in the JSON):
 * per region, the mean radiance over its pixels, band sum R + G + B,
 * relative to the reference's.  The emitter's region (radiance exact in
 * both) is printed apart and left out of the scores: the worst region and
 * the RMS over the 13 others.
 *
 * Rows: each entry of BENCH_THRESHOLDS (comma-separated, default
 * off,1e-2,3e-3,default,3e-4,1e-4,1e-3h): "default" (rad_solve_options
 * {0}), "off" (no elements) or a threshold T.  Each row is
 * one run (BENCH_REPEAT runs: the fastest is kept), wall-clock time of
 * solve + render on a machine shared with others: the times are noisy, the
 * errors are not; the CPU seconds (this process and the hemi-cube workers)
 * are steadier.  A T followed by "h" (e.g. 1e-3h) gives every element a
 * hemi-cube of its own (rad_solve_options.element_hemicubes).
 * BENCH_REGIONS=1 also prints every region's error for each row;
 * BENCH_SVG=FILE writes the curve (worst and RMS region error against CPU
 * seconds); BENCH_PATCH_SIZE, BENCH_TOLERANCE, BENCH_EXACT_NEAR and
 * BENCH_ACCURACY set those options for every row.  Nothing here asserts anything.
 *
 * "near:K" (issue 36) is the defaults with a what-if applied before the
 * render: every element that has a hemi-cube of its own (a contact one)
 * keeps only its row's entries for the patches within K of its parent's
 * sizes √A_p (the near field, measured from the element's centre to patch
 * j's centre less √A_j) and takes the rest from its parent's row, scaled
 * to the part of the hemisphere the near patches leave open:
 *   H_e ≈ Σ_near F_ej B_j + H_far,p · O_e / O_p,
 * O the part of the hemisphere left to far patches other than the direct
 * sources: 1 − F_near − F_direct − (1 − Σ_j F_j), the last term what the
 * row misses (backs of the near surfaces in a closed room, as under a
 * block: a near-only hemi-cube would see them cover it).  The near F_ej
 * are the full hemi-cube's (what a hemi-cube drawing only the near cells
 * would give, but for near cells hidden behind far ones); the direct
 * sources' entries (their own rows) are kept as they are.  An element
 * whose parent sees little of the far field (O_p < τ O_e, τ from
 * BENCH_NEAR_TAU, default 0.5: the parent's centre under a block, say)
 * keeps its full row, as it would keep its full hemi-cube.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "bench_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#define SCENE "models/cornell.gltf"
#define REGIONS "bench/data/cornell_regions.pgm"
#define REFERENCE "bench/data/cornell_reference.json"
enum { MAX_REGIONS = 32, MAX_ROWS = 24 };

typedef struct region {
    int id;
    char name[64];
    double mean[3], se[3], rel_se;
} region;

static region reg[MAX_REGIONS];
static int nreg;
static uint8_t *mask;
static uint32_t side;

static void die(const char *what, const char *why)
{
    fprintf(stderr, "bench_cornell: %s: %s\n", what, why);
    exit(1);
}

/* The reference: one region a line, as pathtrace writes it. */
static void read_reference(void)
{
    FILE *f = fopen(REFERENCE, "r");
    if (!f)
        die(REFERENCE, "cannot open (run from the repository's root)");
    char line[4096];
    while (fgets(line, sizeof line, f)) {
        const char *p = strstr(line, "{\"id\": ");
        if (!p || nreg == MAX_REGIONS)
            continue;
        region *r = &reg[nreg];
        const char *nm = strstr(p, "\"name\": \""), *mn = strstr(p, "\"mean\": ["),
                   *se = strstr(p, "\"stderr\": ["), *rs = strstr(p, "\"sum_relative_stderr\": ");
        if (!nm || !mn || !se || !rs || sscanf(p, "{\"id\": %d", &r->id) != 1 ||
            sscanf(nm + 9, "%63[^\"]", r->name) != 1 ||
            sscanf(mn + 9, "%lf, %lf, %lf", &r->mean[0], &r->mean[1], &r->mean[2]) != 3 ||
            sscanf(se + 11, "%lf, %lf, %lf", &r->se[0], &r->se[1], &r->se[2]) != 3 ||
            sscanf(rs + 23, "%lf", &r->rel_se) != 1)
            die(REFERENCE, "a region line does not parse");
        nreg++;
    }
    fclose(f);
    f = fopen(REGIONS, "rb");
    uint32_t w, h;
    int maxv;
    if (!f || fscanf(f, "P5 %u %u %d", &w, &h, &maxv) != 3 || w != h || maxv != 255 || fgetc(f) == EOF)
        die(REGIONS, "not an 8-bit square PGM");
    side = w;
    mask = malloc((size_t)w * h);
    if (!mask || fread(mask, 1, (size_t)w * h, f) != (size_t)w * h)
        die(REGIONS, "short");
    fclose(f);
}

typedef struct row {
    char label[32];
    double threshold;   /* rad_solve_options.refine_threshold */
    int hemicubes;      /* rad_solve_options.element_hemicubes */
    double near;        /* > 0: "near:K", the near-field what-if with K */
    double seconds;     /* solve + render, the fastest run */
    double cpu;         /* CPU seconds of that run, workers included */
    uint32_t patches, elements;
    uint64_t element_rows, lights;
    double err[MAX_REGIONS]; /* band-sum relative error per region */
    double worst, rms, worst_band;
    int worst_at;
} row;

/* CPU seconds of this process and of its children that have ended (the
 * hemi-cube workers, reaped when a solve's engine is destroyed). */
static double cpu_seconds(void)
{
    struct rusage a, b;
    getrusage(RUSAGE_SELF, &a);
    getrusage(RUSAGE_CHILDREN, &b);
    return (double)a.ru_utime.tv_sec + (double)a.ru_stime.tv_sec + (double)b.ru_utime.tv_sec +
           (double)b.ru_stime.tv_sec +
           1e-6 * (double)(a.ru_utime.tv_usec + a.ru_stime.tv_usec + b.ru_utime.tv_usec + b.ru_stime.tv_usec);
}

/* Per band, Σ F_j B_j over a row's entries other than the direct sources'
 * into H, the same over the j in near[] into Hn; returns O (above). */
static double split_row(const rad_solution *s, const uint8_t *direct, const uint8_t *near,
                        const uint32_t *col, const float *val, uint32_t cnt, double *H, double *Hn)
{
    const uint32_t bands = s->band_count;
    double far = 0.0; /* Σ F_j over the far j other than the direct sources */
    for (uint32_t b = 0; b < bands; b++)
        H[b] = Hn[b] = 0.0;
    for (uint32_t q = 0; q < cnt; q++) {
        const uint32_t j = col[q];
        if (direct && direct[j])
            continue;
        if (!near[j])
            far += val[q];
        for (uint32_t b = 0; b < bands; b++) {
            const double fb = (double)val[q] * s->B[(size_t)j * bands + b];
            H[b] += fb;
            if (near[j])
                Hn[b] += fb;
        }
    }
    return far;
}

/* The near-field what-if ("near:K", top of the file) on s's elements:
 * rewrites the B of each element with a hemi-cube row; prints to stderr how
 * many, the mean near set and the largest change of B (band sum). */
static void near_rule(rad_solution *s, double K)
{
    rad_elements *el = s->elements;
    const rad_mesh *m = s->mesh;
    const uint32_t n = m->patch_count, bands = s->band_count;
    uint8_t *near = calloc(n + 1, 1);
    uint32_t *fcol = malloc(((size_t)n + 1) * sizeof *fcol);
    float *fval = malloc(((size_t)n + 1) * sizeof *fval);
    if (!el || !near || !fcol || !fval)
        die("near", "no elements, or out of memory");
    uint64_t touched = 0, near_total = 0, kept = 0;
    const char *te = getenv("BENCH_NEAR_TAU");
    const double tau = te ? atof(te) : 0.5;
    double worst = 0.0, ss = 0.0;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        if (el->level[e] == 0 || (el->interp && el->interp[e]))
            continue;
        const uint32_t p = el->patch[e];
        const rad_vec3 c = el->mesh->patches[e].center;
        const double reach = K * sqrt(m->patches[p].area);
        const uint32_t nn = bench_near_set(m, c, reach, near);
        const rad_row r = rad_matrix_row(s->F, p);
        const uint8_t *cp = r.col;
        for (uint32_t q = 0, j = 0; q < r.count; q++) {
            j = rad_row_next(&cp, j);
            fcol[q] = j;
            fval[q] = rad_row_value(&r, q);
        }
        double He[RAD_MAX_BANDS], Hne[RAD_MAX_BANDS], Hp[RAD_MAX_BANDS], Hnp[RAD_MAX_BANDS];
        const double Oe = split_row(s, el->direct, near, el->col + el->row_start[e],
                                    el->val + el->row_start[e], el->row_count[e], He, Hne);
        const double Op = split_row(s, el->direct, near, fcol, fval, r.count, Hp, Hnp);
        if (Op < tau * Oe) { /* the parent sees too little of the far field */
            kept++;
            continue;
        }
        const double open = Op > 0.0 ? Oe / Op : 0.0;
        double before = 0.0, after = 0.0, patch = 0.0;
        for (uint32_t b = 0; b < bands; b++) {
            const size_t eb = (size_t)e * bands + b;
            const double Ha = Hne[b] + (Hp[b] - Hnp[b]) * open;
            before += el->B[eb];
            el->B[eb] = fmax(0.0, el->B[eb] + s->rho[(size_t)p * bands + b] * (Ha - He[b]));
            after += el->B[eb];
            patch += s->B[(size_t)p * bands + b];
        }
        /* relative to B_e, but no less than a tenth of B_p (buried ones) */
        const double rel = patch > 0.0 ? (after - before) / fmax(before, 0.1 * patch) : 0.0;
        worst = fmax(worst, fabs(rel));
        ss += rel * rel;
        touched++;
        near_total += nn;
    }
    fprintf(stderr, "near:%g: %llu elements with hemi-cubes keep them (O_p < %g O_e), %llu take the "
            "rule: near set %.1f of %u patches (mean), B changed by %.2f %% RMS, %.2f %% at most\n",
            K, (unsigned long long)kept, tau, (unsigned long long)touched,
            touched ? (double)near_total / (double)touched : 0.0, n,
            touched ? 100 * sqrt(ss / (double)touched) : 0.0, 100 * worst);
    free(near);
    free(fcol);
    free(fval);
}

static void run(row *r, int repeat)
{
    r->seconds = INFINITY;
    for (int k = 0; k < repeat; k++) {
        rad_solve_options opt = {0};
        opt.refine_threshold = r->threshold;
        opt.element_hemicubes = r->hemicubes;
        if (getenv("BENCH_PATCH_SIZE"))
            opt.mesh.patch_size = atof(getenv("BENCH_PATCH_SIZE"));
        if (getenv("BENCH_EXACT_NEAR"))
            opt.exact_near = atoi(getenv("BENCH_EXACT_NEAR"));
        if (getenv("BENCH_ACCURACY")) /* -1 pixels, 0 default, 1 high (issue 39) */
            opt.accuracy = atoi(getenv("BENCH_ACCURACY"));
        if (getenv("BENCH_TOLERANCE"))
            opt.solver.tolerance = atof(getenv("BENCH_TOLERANCE"));
        rad_solution *s = NULL;
        rn_image *img = NULL;
        rn_camera cam;
        rad_error err;
        double t0 = rad_seconds(), c0 = cpu_seconds();
        if (rad_solve_scene_file(SCENE, &opt, &s, &err) ||
            rad_camera_from_scene(s->scene, NULL, side, side, &cam, &err) ||
            rad_render_solution(s, &cam, &img, &err))
            die(r->label, err.message);
        if (r->near > 0.0) { /* the what-if, then the image again */
            near_rule(s, r->near);
            rn_image_destroy(img);
            img = NULL;
            if (rad_render_solution(s, &cam, &img, &err))
                die(r->label, err.message);
        }
        double t = rad_seconds() - t0;
        if (t < r->seconds) {
            r->seconds = t;
            r->cpu = -1.0; /* filled in below, with the scoring: CPU is not wall time */
        }
        r->patches = s->mesh->patch_count;
        r->elements = s->elements ? s->elements->mesh->patch_count : 0;
        r->element_rows = s->elements ? s->elements->rows_computed : 0;
        r->lights = s->lights_computed;
        /* region means of the image */
        double sum[MAX_REGIONS][3] = {{0}};
        uint64_t cnt[MAX_REGIONS] = {0};
        for (size_t q = 0; q < (size_t)side * side; q++)
            for (int g = 0; g < nreg; g++)
                if (mask[q] == reg[g].id) {
                    for (int b = 0; b < 3; b++)
                        sum[g][b] += img->pixels[q * img->channels + (uint32_t)b];
                    cnt[g]++;
                }
        double ss = 0.0;
        int scored = 0;
        r->worst = r->worst_band = 0.0;
        r->worst_at = -1;
        for (int g = 0; g < nreg; g++) {
            double e = 0.0, ref = 0.0;
            for (int b = 0; b < 3; b++) {
                double m = sum[g][b] / (double)(cnt[g] ? cnt[g] : 1);
                e += m;
                ref += reg[g].mean[b];
                if (strcmp(reg[g].name, "light"))
                    r->worst_band = fmax(r->worst_band, fabs(m / reg[g].mean[b] - 1.0));
            }
            r->err[g] = e / ref - 1.0;
            if (!strcmp(reg[g].name, "light"))
                continue;
            ss += r->err[g] * r->err[g];
            scored++;
            if (fabs(r->err[g]) > r->worst) {
                r->worst = fabs(r->err[g]);
                r->worst_at = g;
            }
        }
        r->rms = sqrt(ss / (scored ? scored : 1));
        rn_image_destroy(img);
        rad_solution_destroy(s);
        if (r->cpu < 0.0)
            r->cpu = cpu_seconds() - c0;
    }
}

/* The error-versus-time curve as SVG: worst and RMS region error (log)
 * against CPU seconds (log), one point each per row, labelled. */
static void write_svg(const char *path, const row *rows, int n)
{
    FILE *f = fopen(path, "w");
    if (!f)
        die(path, "cannot write");
    const double W = 720, H = 420, x0 = 70, x1 = 690, y0 = 370, y1 = 40;
    double tmin = INFINITY, tmax = 0, emin = INFINITY, emax = 0;
    for (int k = 0; k < n; k++) {
        tmin = fmin(tmin, rows[k].cpu);
        tmax = fmax(tmax, rows[k].cpu);
        emin = fmin(emin, rows[k].rms);
        emax = fmax(emax, rows[k].worst);
    }
    double lt0 = floor(log10(tmin)), lt1 = ceil(log10(tmax)), le0 = floor(log10(emin)),
           le1 = ceil(log10(emax));
#define SX(t) (x0 + (log10(t) - lt0) / (lt1 - lt0) * (x1 - x0))
#define SY(e) (y0 - (log10(e) - le0) / (le1 - le0) * (y0 - y1))
    fprintf(f, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
               "font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%%\" "
               "height=\"100%%\" fill=\"white\"/>\n", W, H);
    fprintf(f, "<text x=\"%.0f\" y=\"22\" font-size=\"14\" font-weight=\"bold\">glTF Cornell "
               "box: region error vs CPU seconds (solve + render)</text>\n", x0);
    for (double d = lt0; d <= lt1; d++)
        fprintf(f, "<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"#ccc\"/>"
                   "<text x=\"%.1f\" y=\"%.0f\" text-anchor=\"middle\">%g s</text>\n",
                SX(pow(10, d)), y0, SX(pow(10, d)), y1, SX(pow(10, d)), y0 + 16, pow(10, d));
    for (double d = le0; d <= le1; d++)
        fprintf(f, "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"#ccc\"/>"
                   "<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\">%g %%</text>\n",
                x0, SY(pow(10, d)), x1, SY(pow(10, d)), x0 - 4, SY(pow(10, d)) + 4, 100 * pow(10, d));
    for (int k = 0; k < n; k++) {
        const row *r = &rows[k];
        fprintf(f, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"4\" fill=\"#c33\"/>"
                   "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"4\" fill=\"#36c\"/>"
                   "<text x=\"%.1f\" y=\"%.1f\">%s</text>\n",
                SX(r->cpu), SY(r->worst), SX(r->cpu), SY(r->rms), SX(r->cpu) + 6, SY(r->worst) - 4,
                r->label);
    }
    fprintf(f, "<circle cx=\"%.0f\" cy=\"%.0f\" r=\"4\" fill=\"#c33\"/><text x=\"%.0f\" "
               "y=\"%.0f\">worst region</text><circle cx=\"%.0f\" cy=\"%.0f\" r=\"4\" "
               "fill=\"#36c\"/><text x=\"%.0f\" y=\"%.0f\">RMS over the regions</text>\n"
               "</svg>\n",
            x1 - 150, y1 + 10, x1 - 140, y1 + 14, x1 - 150, y1 + 28, x1 - 140, y1 + 32);
#undef SX
#undef SY
    if (fclose(f))
        die(path, "cannot write");
}

int main(void)
{
    read_reference();
    const char *env = getenv("BENCH_THRESHOLDS");
    char list[512];
    snprintf(list, sizeof list, "%s", env && *env ? env : "off,1e-2,3e-3,default,3e-4,1e-4,1e-3h");
    int repeat = getenv("BENCH_REPEAT") ? atoi(getenv("BENCH_REPEAT")) : 1;
    repeat = repeat < 1 ? 1 : repeat;
    row rows[MAX_ROWS];
    int nrows = 0;
    for (char *tok = strtok(list, ","); tok && nrows < MAX_ROWS; tok = strtok(NULL, ",")) {
        row *r = &rows[nrows++];
        memset(r, 0, sizeof *r);
        if (!strcmp(tok, "default")) {
            snprintf(r->label, sizeof r->label, "defaults");
            r->threshold = 0.0;
        } else if (!strncmp(tok, "near:", 5)) {
            r->near = atof(tok + 5);
            snprintf(r->label, sizeof r->label, "defaults, near %g", r->near);
            r->threshold = 0.0;
        } else if (!strcmp(tok, "off")) {
            snprintf(r->label, sizeof r->label, "off");
            r->threshold = -1.0;
        } else {
            /* "h" after T: every element from its own hemi-cube */
            r->hemicubes = strchr(tok, 'h') != NULL;
            r->threshold = atof(tok);
            snprintf(r->label, sizeof r->label, "T = %.0e%s", r->threshold,
                     r->hemicubes ? ", hemi-cubes" : "");
        }
    }
    printf("glTF Cornell box, %ux%u through its camera, against %s\n", side, side, REFERENCE);
    double se_lo = INFINITY, se_hi = 0.0;
    for (int g = 0; g < nreg; g++)
        if (strcmp(reg[g].name, "light")) {
            se_lo = fmin(se_lo, reg[g].rel_se);
            se_hi = fmax(se_hi, reg[g].rel_se);
        }
    printf("(region error: mean radiance R+G+B over the region, relative; worst and RMS over %d "
           "regions, the emitter's left out; the reference's standard errors %.2g %% to %.2g %%)\n\n",
           nreg - 1, 100 * se_lo, 100 * se_hi);
    printf("| setting | patches | elements | element hemi-cubes | item buffers at lights/emitters "
           "| solve + render s | CPU s | worst region | RMS | worst band |\n");
    printf("|:--|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n");
    for (int k = 0; k < nrows; k++) {
        row *r = &rows[k];
        run(r, repeat);
        printf("| %s | %u | %u | %llu | %llu | %.1f | %.1f | %.2f %% (%s) | %.2f %% | %.2f %% |\n",
               r->label, r->patches, r->elements, (unsigned long long)r->element_rows,
               (unsigned long long)r->lights, r->seconds, r->cpu, 100 * r->worst,
               r->worst_at >= 0 ? reg[r->worst_at].name : "-", 100 * r->rms, 100 * r->worst_band);
        fflush(stdout);
    }
    if (getenv("BENCH_SVG") && *getenv("BENCH_SVG"))
        write_svg(getenv("BENCH_SVG"), rows, nrows);
    if (getenv("BENCH_REGIONS") && atoi(getenv("BENCH_REGIONS"))) {
        printf("\n| region | pixels' reference (R+G+B) | ± |");
        for (int k = 0; k < nrows; k++)
            printf(" %s |", rows[k].label);
        printf("\n|:--|--:|--:|");
        for (int k = 0; k < nrows; k++)
            printf("--:|");
        printf("\n");
        for (int g = 0; g < nreg; g++) {
            printf("| %s | %.5f | %.2g %% |", reg[g].name, reg[g].mean[0] + reg[g].mean[1] + reg[g].mean[2],
                   100 * reg[g].rel_se);
            for (int k = 0; k < nrows; k++)
                printf(" %+.2f %% |", 100 * rows[k].err[g]);
            printf("\n");
        }
    }
    free(mask);
    return 0;
}
