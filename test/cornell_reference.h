/* cornell_reference.h - the shipped path-traced reference of the glTF
 * Cornell box (bench/data/cornell_reference.json, made once by
 * tools/pathtrace.c) and its region map (bench/data/cornell_regions.pgm),
 * and the score of an engine image against them: per region the mean
 * radiance R + G + B relative to the reference's, the emitter's region
 * left out of the worst and the RMS.  Static functions in a header, like
 * util.h, for test_gather_cornell and bench_gather_cornell.
 */
#ifndef TEST_CORNELL_REFERENCE_H
#define TEST_CORNELL_REFERENCE_H

#include "../render/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CREF_JSON "bench/data/cornell_reference.json"
#define CREF_PGM "bench/data/cornell_regions.pgm"
#define CREF_MAX 32

typedef struct cref {
    int count;                 /* regions */
    int id[CREF_MAX];          /* the value of its pixels in the map */
    char name[CREF_MAX][64];
    double sum[CREF_MAX];      /* the reference's mean R + G + B */
    uint32_t side;             /* the map is side × side */
    unsigned char *map;
} cref;

typedef struct cref_score {
    double err[CREF_MAX];      /* relative error of each region's mean */
    double worst, rms;         /* over the regions other than "light" */
    int worst_at;
} cref_score;

/* The number after `key` in s (a JSON member), or NAN. */
static inline double cref_number_after(const char *s, const char *key, int nth)
{
    const char *p = strstr(s, key);
    if (!p)
        return NAN;
    p += strlen(key);
    for (int k = 0; k <= nth; k++) {
        while (*p && !(*p == '-' || *p == '.' || (*p >= '0' && *p <= '9')))
            p++;
        char *end;
        double v = strtod(p, &end);
        if (end == p)
            return NAN;
        if (k == nth)
            return v;
        p = end;
    }
    return NAN;
}

/* Reads both files (run from the repository's root): 0, or -1 with a line
 * on stderr. */
static inline int cref_load(cref *r)
{
    memset(r, 0, sizeof *r);
    FILE *f = fopen(CREF_JSON, "r");
    if (!f)
        return fprintf(stderr, "  %s: cannot open\n", CREF_JSON), -1;
    char line[4096];
    while (fgets(line, sizeof line, f) && r->count < CREF_MAX) {
        const char *nm = strstr(line, "\"name\": \"");
        if (!strstr(line, "{\"id\":") || !nm)
            continue;
        int k = r->count++;
        r->id[k] = (int)cref_number_after(line, "\"id\":", 0);
        sscanf(nm + 9, "%63[^\"]", r->name[k]);
        r->sum[k] = 0.0;
        for (int b = 0; b < 3; b++)
            r->sum[k] += cref_number_after(line, "\"mean\":", b);
    }
    fclose(f);
    f = fopen(CREF_PGM, "rb");
    unsigned w = 0, h = 0;
    int maxv = 0;
    if (!f || fscanf(f, "P5 %u %u %d", &w, &h, &maxv) != 3 || w != h || maxv != 255 ||
        fgetc(f) == EOF || !(r->map = malloc((size_t)w * h)) ||
        fread(r->map, 1, (size_t)w * h, f) != (size_t)w * h) {
        if (f)
            fclose(f);
        return fprintf(stderr, "  %s: not the 8-bit square map\n", CREF_PGM), -1;
    }
    fclose(f);
    r->side = w;
    return r->count > 1 ? 0 : -1;
}

/* Scores img (r->side square, 3 bands) against the reference. */
static inline void cref_score_image(const cref *r, const rn_image *img, cref_score *out)
{
    double sum[CREF_MAX] = {0}, n[CREF_MAX] = {0};
    for (size_t q = 0; q < (size_t)r->side * r->side; q++)
        for (int k = 0; k < r->count; k++)
            if (r->map[q] == r->id[k]) {
                for (uint32_t b = 0; b < img->channels; b++)
                    sum[k] += img->pixels[q * img->channels + b];
                n[k]++;
            }
    double ss = 0.0;
    int scored = 0;
    out->worst = 0.0;
    out->worst_at = -1;
    for (int k = 0; k < r->count; k++) {
        out->err[k] = n[k] > 0 ? sum[k] / n[k] / r->sum[k] - 1.0 : NAN;
        if (!strcmp(r->name[k], "light"))
            continue;
        ss += out->err[k] * out->err[k];
        scored++;
        if (!(fabs(out->err[k]) <= out->worst)) {
            out->worst = fabs(out->err[k]);
            out->worst_at = k;
        }
    }
    out->rms = sqrt(ss / (scored ? scored : 1));
}

static inline void cref_free(cref *r) { free(r->map); }

#endif /* TEST_CORNELL_REFERENCE_H */
