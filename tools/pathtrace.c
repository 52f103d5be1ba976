/* pathtrace.c - the independent reference for bench_cornell: a small Monte
 * Carlo path tracer over the scene's polygons.
 *
 * It shares nothing with the engine but the scene reader (rad_scene_load):
 * no hemi-cube, no form factor, no patch, no renderer.  Every polygon of the
 * scene is intersected as it is (planar, convex); a ray that meets a
 * polygon's back side stops there (opaque surfaces are one-sided: a back
 * hides what lies beyond it and reflects nothing), as in the engine.
 * Surfaces are Lambertian with the scene's ρ and emit radiance E/π from the
 * front; what the camera sees is radiance per band, the engine's B/π.
 *
 * Estimator: camera rays jittered over each pixel (a box filter), next-event
 * estimation at every diffuse bounce (a point on an emitter polygon chosen
 * by power, uniform on its area, with a shadow ray), cosine-weighted
 * continuation, emission counted only where the camera sees an emitter (so
 * nothing is counted twice), Russian roulette after three bounces.  Each
 * path is one sample of its pixel's radiance, unbiased.
 *
 * Regions (the Cornell box's objects by name; see classify): a pixel
 * belongs to one only when 5×5 points over its square (corners and edges
 * included) all see
 * the same object's same plane, so that any point sampling of the pixel -
 * the engine's renderer takes its centre - sees that surface too.  The
 * floor is split by its direct light: points that see the whole light,
 * points in the short block's shadow (some of the light hidden by it and
 * none by the tall one; all of the light hidden: umbra, else penumbra),
 * points in the tall block's.  The region of each pixel is written as an
 * 8-bit PGM (255: none), and the region means with their standard errors
 * as JSON, both for bench_cornell.
 *
 *   pathtrace SCENE REGIONS.pgm REFERENCE.json [--size N] [--paths P]
 *             [--target T] [--seed S] [--jobs J]
 *   pathtrace --check
 *   pathtrace SCENE --image OUT.pfm [--size N] [--spp K] [--jobs J]
 *   pathtrace SCENE --objects OUT.json [--paths P] [--target T] [--seed S]
 *             [--jobs J]
 *
 * Each pass gives every pixel of a region one path.  A region gets at least
 * P paths (default 1e6), and more until the relative standard error of its
 * mean band sum (R + G + B) is at most T (default 5e-4), estimated from a
 * pilot of about 1e5 paths.
 * --image traces every pixel K times (default 256) and writes the image as
 * a float PFM (radiance, rows bottom-up as PFM has them): for looking at
 * where an engine's image departs from the reference, not for scores.
 * --objects (issue 36) gives each object's area-mean outgoing radiance:
 * points uniform over the object's area, at each the radiance leaving it
 * by the same estimator (its E/π, plus ρ × the incident radiance by next-
 * event estimation and continuation), until the band sum's relative
 * standard error is T; with the incident estimate, each object's absorbed
 * power A (1 − ρ) H and the total against the emitted power.
 * --check runs the tracer on two closed forms (a furnace and a lamp over a
 * floor), and --objects on a third (a box lit by its ceiling), and
 * fails when any is off by more than four standard errors.
 */
#include "../radiosity/scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* ------------------------------------------------------------ random */

/* xoshiro256** seeded by splitmix64: fast, and each job its own stream. */
typedef struct rng {
    uint64_t s[4];
} rng;

static uint64_t splitmix(uint64_t *x)
{
    uint64_t z = (*x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static void rng_seed(rng *r, uint64_t seed)
{
    for (int k = 0; k < 4; k++)
        r->s[k] = splitmix(&seed);
}

static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

static double rnd(rng *r)
{
    uint64_t *s = r->s, out = rotl(s[1] * 5, 7) * 9, t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return (double)(out >> 11) * 0x1.0p-53;
}

/* ------------------------------------------------------------ geometry */

typedef struct { double x, y, z; } v3;
static v3 V(double x, double y, double z) { return (v3){x, y, z}; }
static v3 add(v3 a, v3 b) { return V(a.x + b.x, a.y + b.y, a.z + b.z); }
static v3 sub(v3 a, v3 b) { return V(a.x - b.x, a.y - b.y, a.z - b.z); }
static v3 mul(v3 a, double s) { return V(a.x * s, a.y * s, a.z * s); }
static double dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static v3 cross(v3 a, v3 b) { return V(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
static v3 unit(v3 a) { return mul(a, 1.0 / sqrt(dot(a, a))); }

enum { MAXB = RAD_MAX_BANDS, MAXPTS = 64 };

typedef struct poly {
    v3 p[MAXPTS];     /* corners, counter-clockwise about n */
    v3 e[MAXPTS];     /* n × (p[k+1] - p[k]): inward edge normals */
    uint32_t count;
    v3 n;             /* unit front normal */
    double d;         /* plane: n·x = d */
    double area;
    v3 c;             /* bounding sphere */
    double r2;
    uint32_t object, material;
    double cdf_tri[MAXPTS]; /* fan triangles' cumulative area share, for sampling */
} poly;

typedef struct world {
    poly *P;
    uint32_t np;
    uint32_t bands;
    double rho[64][MAXB], E[64][MAXB]; /* per material */
    uint32_t *emit;   /* emitter polygons */
    double *emit_cdf; /* chosen by power: area × Σ E */
    uint32_t ne;
    double eps;       /* ray offset, scene-relative */
} world;

static int world_from_scene(const rad_scene *s, world *w)
{
    memset(w, 0, sizeof *w);
    if (s->material_count > 64 || s->light_count) {
        fprintf(stderr, "pathtrace: at most 64 materials and no punctual lights\n");
        return -1;
    }
    w->bands = s->band_count;
    w->np = s->polygon_count;
    w->P = calloc(w->np, sizeof *w->P);
    w->emit = calloc(w->np, sizeof *w->emit);
    w->emit_cdf = calloc(w->np, sizeof *w->emit_cdf);
    if (!w->P || !w->emit || !w->emit_cdf)
        return -1;
    for (uint32_t m = 0; m < s->material_count; m++) {
        if (rad_material_transmits(&s->materials[m], s->band_count)) {
            fprintf(stderr, "pathtrace: transmitting materials are not traced\n");
            return -1;
        }
        for (uint32_t b = 0; b < w->bands; b++) {
            w->rho[m][b] = s->materials[m].rho[b];
            w->E[m][b] = s->materials[m].emission[b];
        }
    }
    double lo = INFINITY, hi = -INFINITY, total = 0.0;
    for (uint32_t i = 0; i < w->np; i++) {
        const rad_polygon *sp = &s->polygons[i];
        poly *q = &w->P[i];
        if (sp->point_count > MAXPTS)
            return -1;
        q->count = sp->point_count;
        q->object = sp->object;
        q->material = sp->material;
        v3 c = V(0, 0, 0);
        for (uint32_t k = 0; k < q->count; k++) {
            rad_vec3 a = s->points[sp->first_point + k];
            q->p[k] = V(a.x, a.y, a.z);
            c = add(c, q->p[k]);
            lo = fmin(lo, fmin(a.x, fmin(a.y, a.z)));
            hi = fmax(hi, fmax(a.x, fmax(a.y, a.z)));
        }
        /* Normal and area from the corners themselves (Newell), not the
         * scene's: the tracer derives everything it uses. */
        v3 nw = V(0, 0, 0);
        for (uint32_t k = 0; k < q->count; k++)
            nw = add(nw, cross(q->p[k], q->p[(k + 1) % q->count]));
        q->area = 0.5 * sqrt(dot(nw, nw));
        q->n = unit(nw);
        q->c = mul(c, 1.0 / q->count);
        q->d = dot(q->n, q->c);
        for (uint32_t k = 0; k < q->count; k++) {
            q->e[k] = cross(q->n, sub(q->p[(k + 1) % q->count], q->p[k]));
            v3 r = sub(q->p[k], q->c);
            q->r2 = fmax(q->r2, dot(r, r));
        }
        double acc = 0.0;
        for (uint32_t k = 1; k + 1 < q->count; k++) {
            acc += 0.5 * sqrt(dot(cross(sub(q->p[k], q->p[0]), sub(q->p[k + 1], q->p[0])),
                                  cross(sub(q->p[k], q->p[0]), sub(q->p[k + 1], q->p[0]))));
            q->cdf_tri[k] = acc;
        }
        for (uint32_t k = 1; k + 1 < q->count; k++)
            q->cdf_tri[k] /= acc;
        double power = 0.0;
        for (uint32_t b = 0; b < w->bands; b++)
            power += w->E[q->material][b];
        if (power > 0.0) {
            total += power * q->area;
            w->emit[w->ne] = i;
            w->emit_cdf[w->ne++] = total;
        }
    }
    for (uint32_t k = 0; k < w->ne; k++)
        w->emit_cdf[k] /= total;
    w->eps = 1e-7 * (hi - lo);
    return 0;
}

/* Nearest polygon hit along o + t d, eps < t < tmax: its index (or -1),
 * *t, and *front (1 when the ray meets the front side). */
static int trace(const world *w, v3 o, v3 d, double tmax, double *t_out, int *front)
{
    int best = -1;
    double tb = tmax;
    for (uint32_t i = 0; i < w->np; i++) {
        const poly *q = &w->P[i];
        /* bounding sphere */
        v3 oc = sub(q->c, o);
        double tc = dot(oc, d), dc2 = dot(oc, oc) - tc * tc;
        if (dc2 > q->r2 || tc + sqrt(q->r2) < w->eps)
            continue;
        double dn = dot(d, q->n);
        if (dn == 0.0)
            continue;
        double t = (q->d - dot(q->n, o)) / dn;
        if (!(t > w->eps && t < tb))
            continue;
        v3 x = add(o, mul(d, t));
        int inside = 1;
        for (uint32_t k = 0; k < q->count && inside; k++)
            inside = dot(q->e[k], sub(x, q->p[k])) >= 0.0;
        if (!inside)
            continue;
        best = (int)i;
        tb = t;
        *front = dn < 0.0;
    }
    *t_out = tb;
    return best;
}

/* Is the segment from x to y clear (nothing strictly between)? */
static int clear(const world *w, v3 x, v3 y)
{
    v3 d = sub(y, x);
    double len = sqrt(dot(d, d)), t;
    int front;
    return trace(w, x, mul(d, 1.0 / len), len - 2.0 * w->eps, &t, &front) < 0;
}

/* A uniform point on polygon q. */
static v3 sample_poly(const poly *q, rng *r)
{
    double u = rnd(r);
    uint32_t k = 1;
    while (k + 2 < q->count && u > q->cdf_tri[k])
        k++;
    double a = rnd(r), b = rnd(r);
    if (a + b > 1.0) {
        a = 1.0 - a;
        b = 1.0 - b;
    }
    return add(q->p[0], add(mul(sub(q->p[k], q->p[0]), a), mul(sub(q->p[k + 1], q->p[0]), b)));
}

/* A cosine-weighted direction about n. */
static v3 cosine_dir(v3 n, rng *r)
{
    v3 a = fabs(n.x) < 0.6 ? V(1, 0, 0) : V(0, 1, 0);
    v3 u = unit(cross(n, a)), v = cross(n, u);
    double phi = 2.0 * M_PI * rnd(r), s2 = rnd(r), s = sqrt(s2);
    return add(add(mul(u, s * cos(phi)), mul(v, s * sin(phi))), mul(n, sqrt(1.0 - s2)));
}

/* The light a diffuse point x of polygon `hit` reflects, per band, added
 * to L: next-event estimation at every bounce and cosine continuation.
 * With `incident` the first vertex reflects as if ρ were 1 (so L gains
 * the incident radiance H/π itself, for a ρ of any value, 0 included). */
static void scatter(const world *w, int hit, v3 x, rng *r, int incident, double *L)
{
    const uint32_t nb = w->bands;
    double thr[MAXB], one[MAXB];
    for (uint32_t b = 0; b < nb; b++) {
        thr[b] = 1.0;
        one[b] = 1.0;
    }
    for (int depth = 0;; depth++) {
        const poly *q = &w->P[hit];
        const double *rho = depth == 0 && incident ? one : w->rho[q->material];
        v3 n = q->n;
        double rmax = 0.0;
        for (uint32_t b = 0; b < nb; b++)
            rmax = fmax(rmax, rho[b]);
        if (!(rmax > 0.0))
            return;
        /* next event: a point y on an emitter, by power */
        if (w->ne) {
            double u = rnd(r);
            uint32_t k = 0;
            while (k + 1 < w->ne && u > w->emit_cdf[k])
                k++;
            const poly *l = &w->P[w->emit[k]];
            double pk = w->emit_cdf[k] - (k ? w->emit_cdf[k - 1] : 0.0);
            v3 y = sample_poly(l, r), xy = sub(y, x);
            double d2 = dot(xy, xy), dl = sqrt(d2);
            v3 wi = mul(xy, 1.0 / dl);
            double cx = dot(n, wi), cy = -dot(l->n, wi);
            if (cx > 0.0 && cy > 0.0 && clear(w, x, y)) {
                double g = cx * cy / d2 * l->area / pk / M_PI; /* ρ/π · L_e · G / pdf, L_e = E/π */
                for (uint32_t b = 0; b < nb; b++)
                    L[b] += thr[b] * rho[b] * w->E[l->material][b] / M_PI * g;
            }
        }
        /* continue: cosine sampling makes the weight ρ */
        double tmax = 0.0;
        for (uint32_t b = 0; b < nb; b++) {
            thr[b] *= rho[b];
            tmax = fmax(tmax, thr[b]);
        }
        if (depth >= 2) {
            double keep = fmin(0.95, tmax);
            if (!(rnd(r) < keep))
                return;
            for (uint32_t b = 0; b < nb; b++)
                thr[b] /= keep;
        }
        double t;
        int front;
        v3 d = cosine_dir(n, r);
        hit = trace(w, x, d, INFINITY, &t, &front);
        if (hit < 0 || !front)
            return;
        x = add(x, mul(d, t));
    }
}

/* One path's radiance along o + t d, per band, into L: the emission of
 * what it meets first (only there, so nothing is counted twice), then
 * what that point reflects. */
static void radiance(const world *w, v3 o, v3 d, rng *r, double *L)
{
    for (uint32_t b = 0; b < w->bands; b++)
        L[b] = 0.0;
    double t;
    int front, hit = trace(w, o, d, INFINITY, &t, &front);
    if (hit < 0 || !front)
        return;
    for (uint32_t b = 0; b < w->bands; b++)
        L[b] = w->E[w->P[hit].material][b] / M_PI;
    scatter(w, hit, add(o, mul(d, t)), r, 0, L);
}

/* ------------------------------------------------------------ camera */

/* The engine's pinhole: pixel (i, j), row 0 at the top, looks along
 * f + a·r + b·u with a = (i + ½ − W/2)/k, b = (H/2 − j − ½)/k,
 * k = (H/2)/tan(yfov/2) (render.h's rn_camera, rewritten here). */
typedef struct cam {
    v3 eye, f, r, u;
    double k;
    uint32_t W, H;
} cam;

static void cam_make(const rad_camera *c, uint32_t W, uint32_t H, cam *k)
{
    k->eye = V(c->eye.x, c->eye.y, c->eye.z);
    k->f = unit(sub(V(c->target.x, c->target.y, c->target.z), k->eye));
    k->r = unit(cross(k->f, V(c->up.x, c->up.y, c->up.z)));
    k->u = cross(k->r, k->f);
    k->W = W;
    k->H = H;
    k->k = 0.5 * H / tan(0.5 * c->yfov_deg * M_PI / 180.0);
}

/* Direction through image point (x, y) in pixels from the top-left corner. */
static v3 cam_dir(const cam *k, double x, double y)
{
    return unit(add(k->f, add(mul(k->r, (x - 0.5 * k->W) / k->k), mul(k->u, (0.5 * k->H - y) / k->k))));
}

/* ------------------------------------------------------------ regions */

enum {
    RG_LIGHT = 0, RG_CEILING, RG_BACK, RG_RED, RG_GREEN, RG_FLOOR_LIT, RG_FLOOR_SHORT_PEN,
    RG_FLOOR_SHORT_UMBRA, RG_FLOOR_TALL, RG_SHORT_TOP, RG_SHORT_FRONT, RG_SHORT_SIDE,
    RG_TALL_FRONT, RG_TALL_SIDE, RG_COUNT, RG_NONE = 255
};
static const char *const region_name[RG_COUNT] = {
    "light", "ceiling", "back wall", "red wall", "green wall", "floor lit",
    "floor, short block's penumbra", "floor, short block's umbra", "floor, tall block's shadow",
    "short block top", "short block front", "short block side", "tall block front",
    "tall block side"};

static uint32_t object_named(const rad_scene *s, const char *name)
{
    uint32_t o = rad_scene_find_object(s, name);
    if (o == RAD_NONE) {
        fprintf(stderr, "pathtrace: the scene has no object '%s' (the Cornell box's names)\n", name);
        exit(2);
    }
    return o;
}

/* The light's visibility from x, on a 16×16 grid over the (one) emitter:
 * how much of it is hidden by object `only` (RAD_NONE: by anything).
 * Returns the hidden fraction. */
static double hidden_by(const world *w, v3 x, uint32_t only)
{
    const poly *l = &w->P[w->emit[0]];
    int hidden = 0, total = 0;
    for (int a = 0; a < 16; a++)
        for (int b = 0; b < 16; b++) {
            /* a grid over the parallelogram p0 + s(p1 - p0) + t(p3 - p0) */
            double s = (a + 0.5) / 16, t = (b + 0.5) / 16;
            v3 y = add(l->p[0], add(mul(sub(l->p[1], l->p[0]), s), mul(sub(l->p[3], l->p[0]), t)));
            v3 d = sub(y, x);
            double len = sqrt(dot(d, d)), tt;
            int front;
            total++;
            if (only == RAD_NONE) {
                hidden += !clear(w, x, y);
                continue;
            }
            /* hidden by `only`: some polygon of it lies between */
            world one = *w;
            for (uint32_t i = 0; i < w->np; i++) {
                if (w->P[i].object != only)
                    continue;
                one.P = &w->P[i];
                one.np = 1;
                if (trace(&one, x, mul(d, 1.0 / len), len - 2.0 * w->eps, &tt, &front) >= 0) {
                    hidden++;
                    break;
                }
            }
        }
    return (double)hidden / total;
}

/* Region of pixel (i, j): see the top of the file. */
static uint8_t classify(const world *w, const rad_scene *s, const cam *k, uint32_t i, uint32_t j)
{
    const uint32_t floor_o = object_named(s, "floor"), short_o = object_named(s, "short_block"),
                   tall_o = object_named(s, "tall_block");
    int poly0 = -2;
    double any_short = 0, any_tall = 0, all_short = 1;
    v3 n0 = V(0, 0, 0);
    for (int a = 0; a <= 4; a++)
        for (int b = 0; b <= 4; b++) {
            v3 d = cam_dir(k, i + a / 4.0, j + b / 4.0);
            double t;
            int front, h = trace(w, k->eye, d, INFINITY, &t, &front);
            if (h < 0 || !front)
                return RG_NONE;
            const poly *q = &w->P[h];
            if (poly0 == -2) {
                poly0 = h;
                n0 = q->n;
            } else if (q->object != w->P[poly0].object || dot(q->n, n0) < 1.0 - 1e-9 ||
                       fabs(q->d - w->P[poly0].d) > 1e-9) {
                return RG_NONE; /* another object or another plane */
            }
            if (q->object == floor_o) {
                v3 x = add(k->eye, mul(d, t));
                double hs = hidden_by(w, x, short_o), ht = hidden_by(w, x, tall_o);
                any_short = fmax(any_short, hs);
                any_tall = fmax(any_tall, ht);
                all_short = fmin(all_short, hs);
            }
        }
    const poly *q = &w->P[poly0];
    const char *name = s->objects[q->object].name;
    if (!strcmp(name, "light"))
        return RG_LIGHT;
    if (!strcmp(name, "ceiling"))
        return RG_CEILING;
    if (!strcmp(name, "back_wall"))
        return RG_BACK;
    if (!strcmp(name, "left_wall_red"))
        return RG_RED;
    if (!strcmp(name, "right_wall_green"))
        return RG_GREEN;
    if (q->object == floor_o) {
        if (any_short == 0 && any_tall == 0)
            return RG_FLOOR_LIT;
        if (any_short > 0 && any_tall == 0)
            return all_short >= 1.0 ? RG_FLOOR_SHORT_UMBRA : RG_FLOOR_SHORT_PEN;
        if (any_tall > 0 && any_short == 0)
            return RG_FLOOR_TALL;
        return RG_NONE;
    }
    /* block faces: the top, and the two sides the camera sees (the one
     * facing it most is the front) */
    if (q->n.y > 0.5)
        return q->object == short_o ? RG_SHORT_TOP : RG_NONE;
    int front = dot(q->n, unit(sub(k->eye, q->c))) > 0.5;
    if (q->object == short_o)
        return front ? RG_SHORT_FRONT : RG_SHORT_SIDE;
    if (q->object == tall_o)
        return front ? RG_TALL_FRONT : RG_TALL_SIDE;
    return RG_NONE;
}

/* ------------------------------------------------------------ the run */

/* Sums over paths per band, and at [MAXB] of the band sum (the quantity
 * whose standard error decides how many paths a region gets). */
typedef struct acc {
    double sum[MAXB + 1], sum2[MAXB + 1]; /* per band, and of the band sum at [MAXB] */
    double absorbed, absorbed2;           /* --objects: power absorbed (band sum) */
    uint64_t paths;
} acc;

/* What a job traces: `count` samples with stream `seed` into a. */
typedef void (*work_fn)(const void *job, uint64_t count, uint64_t seed, acc *a);

static void acc_add(acc *a, const acc *part)
{
    for (uint32_t b = 0; b <= MAXB; b++) {
        a->sum[b] += part->sum[b];
        a->sum2[b] += part->sum2[b];
    }
    a->absorbed += part->absorbed;
    a->absorbed2 += part->absorbed2;
    a->paths += part->paths;
}

/* One sample L (per band) into a. */
static void acc_put(acc *a, const double *L, uint32_t bands)
{
    double all = 0.0;
    for (uint32_t b = 0; b < bands; b++) {
        a->sum[b] += L[b];
        a->sum2[b] += L[b] * L[b];
        all += L[b];
    }
    a->sum[MAXB] += all;
    a->sum2[MAXB] += all * all;
    a->paths++;
}

/* Traces `passes` passes over the pixels of region rg (one path a pixel a
 * pass) with stream seed, adding to a. */
static void trace_region(const world *w, const cam *k, const uint8_t *region, uint8_t rg,
                         uint64_t passes, uint64_t seed, acc *a)
{
    rng r;
    rng_seed(&r, seed);
    double L[MAXB];
    for (uint64_t p = 0; p < passes; p++)
        for (uint32_t j = 0; j < k->H; j++)
            for (uint32_t i = 0; i < k->W; i++) {
                if (region[(size_t)j * k->W + i] != rg)
                    continue;
                radiance(w, k->eye, cam_dir(k, i + rnd(&r), j + rnd(&r)), &r, L);
                acc_put(a, L, w->bands);
            }
}

typedef struct region_job {
    const world *w;
    const cam *k;
    const uint8_t *region;
    uint8_t rg;
} region_job;

static void region_work(const void *job, uint64_t passes, uint64_t seed, acc *a)
{
    const region_job *j = job;
    trace_region(j->w, j->k, j->region, j->rg, passes, seed + 7919u * j->rg, a);
}

/* Runs work in `jobs` processes (streams seed + 1000·job), summing their
 * accumulators through pipes. */
static int trace_parallel(work_fn work, const void *job, uint64_t passes, uint64_t seed, int jobs,
                          acc *a)
{
    memset(a, 0, sizeof *a);
    int fds[64][2];
    pid_t pid[64];
    for (int q = 0; q < jobs; q++) {
        uint64_t mine = passes / jobs + ((uint64_t)q < passes % jobs);
        if (pipe(fds[q]) != 0)
            return -1;
        pid[q] = fork();
        if (pid[q] < 0)
            return -1;
        if (pid[q] == 0) {
            acc part = {0};
            work(job, mine, seed + 1000u * (uint64_t)q, &part);
            ssize_t put = write(fds[q][1], &part, sizeof part);
            _exit(put == (ssize_t)sizeof part ? 0 : 1);
        }
        close(fds[q][1]);
    }
    int rc = 0;
    for (int q = 0; q < jobs; q++) {
        acc part;
        if (read(fds[q][0], &part, sizeof part) != (ssize_t)sizeof part)
            rc = -1;
        close(fds[q][0]);
        int st;
        waitpid(pid[q], &st, 0);
        if (rc == 0)
            acc_add(a, &part);
    }
    return rc;
}

/* ------------------------------------------------------------ checks */

/* Polygon-file text of a closed cube [0,1]³ whose six inward faces all have
 * ρ and E: B = E/(1 − ρ) everywhere, radiance E/(π(1 − ρ)). */
static const char *FURNACE =
    "bands 1\n"
    "material m reflectance 0.5 emission 1\n"
    "polygon floor m 0 0 0  0 0 1  1 0 1  1 0 0 end\n"
    "polygon ceil m 0 1 0  1 1 0  1 1 1  0 1 1 end\n"
    "polygon x0 m 0 0 0  0 1 0  0 1 1  0 0 1 end\n"
    "polygon x1 m 1 0 0  1 0 1  1 1 1  1 1 0 end\n"
    "polygon z0 m 0 0 0  1 0 0  1 1 0  0 1 0 end\n"
    "polygon z1 m 0 0 1  0 1 1  1 1 1  1 0 1 end\n"
    "camera c eye 0.5 0.5 0.5 target 0.5 0.5 1 up 0 1 0 fov 60\n";

/* A unit square lamp (E = π: radiance 1) facing down at height h over the
 * point (0,0,0) of a floor with ρ = 0.5, nothing else: the floor's radiance
 * at the origin is ρ F, F the corner form factor of Howell B-3. */
static const char *LAMP =
    "bands 1\n"
    "material lamp emission 3.141592653589793\n"
    "material floor reflectance 0.5\n"
    "polygon lamp lamp 0 0.5 0  1 0.5 0  1 0.5 1  0 0.5 1 end\n"
    "polygon floor floor -2 0 -2  -2 0 2  2 0 2  2 0 -2 end\n"
    "camera c eye 0 0.25 -1e-3 target 0 0 0 up 0 0 1 fov 0.01\n";

static double howell_b3(double a, double b, double c)
{
    double X = a / c, Y = b / c, x1 = sqrt(1 + X * X), y1 = sqrt(1 + Y * Y);
    return (X / x1 * atan(Y / x1) + Y / y1 * atan(X / y1)) / (2 * M_PI);
}

static int check_one(const char *name, const char *text, double expect, int jobs)
{
    rad_scene *s = NULL;
    rad_error err;
    if (rad_scene_parse_polyfile(text, strlen(text), name, NULL, &s, &err)) {
        fprintf(stderr, "pathtrace: %s\n", err.message);
        return -1;
    }
    world w;
    cam k;
    if (world_from_scene(s, &w))
        return -1;
    cam_make(&s->cameras[0], 1, 1, &k);
    uint8_t region = 0;
    acc a;
    region_job job = {&w, &k, &region, 0};
    if (trace_parallel(region_work, &job, 4000000, 12345, jobs, &a))
        return -1;
    double m = a.sum[0] / a.paths, se = sqrt((a.sum2[0] / a.paths - m * m) / (a.paths - 1));
    int ok = fabs(m - expect) <= 4.0 * se;
    printf("check %-8s radiance %.6f, expected %.6f, off %+.2e (%.1f standard errors of %.1e): %s\n",
           name, m, expect, m / expect - 1.0, fabs(m - expect) / se, se / expect, ok ? "ok" : "FAIL");
    rad_scene_destroy(s);
    free(w.P);
    free(w.emit);
    free(w.emit_cdf);
    return ok ? 0 : -1;
}

/* ------------------------------------------------------------ image */

/* Every pixel traced spp times, rows split among jobs, written as PFM. */
static int trace_image(const char *scene, const char *out, uint32_t size, uint64_t spp,
                       uint64_t seed, int jobs)
{
    rad_scene *s = NULL;
    rad_error err;
    if (rad_scene_load(scene, NULL, &s, &err)) {
        fprintf(stderr, "pathtrace: %s\n", err.message);
        return 2;
    }
    world w;
    if (world_from_scene(s, &w) || !s->camera_count || w.bands < 3) {
        fprintf(stderr, "pathtrace: %s: a camera and three bands expected\n", scene);
        return 2;
    }
    cam k;
    cam_make(&s->cameras[0], size, size, &k);
    const size_t npx = (size_t)size * size;
    float *img = calloc(npx * 3, sizeof *img);
    int fds[64][2];
    pid_t pid[64];
    for (int q = 0; q < jobs; q++) {
        if (pipe(fds[q]) != 0 || (pid[q] = fork()) < 0)
            return 1;
        if (pid[q] == 0) {
            rng r;
            rng_seed(&r, seed + 77u * (uint64_t)q);
            double L[MAXB];
            for (uint32_t j = (uint32_t)q; j < size; j += (uint32_t)jobs)
                for (uint32_t i = 0; i < size; i++) {
                    double acc[3] = {0, 0, 0};
                    for (uint64_t t = 0; t < spp; t++) {
                        radiance(&w, k.eye, cam_dir(&k, i + rnd(&r), j + rnd(&r)), &r, L);
                        for (int b = 0; b < 3; b++)
                            acc[b] += L[b];
                    }
                    float px[3] = {(float)(acc[0] / spp), (float)(acc[1] / spp), (float)(acc[2] / spp)};
                    if (write(fds[q][1], px, sizeof px) != (ssize_t)sizeof px)
                        _exit(1);
                }
            _exit(0);
        }
        close(fds[q][1]);
    }
    for (int q = 0; q < jobs; q++) {
        for (uint32_t j = (uint32_t)q; j < size; j += (uint32_t)jobs)
            for (uint32_t i = 0; i < size; i++)
                if (read(fds[q][0], img + ((size_t)j * size + i) * 3, 3 * sizeof *img) !=
                    (ssize_t)(3 * sizeof *img))
                    return 1;
        close(fds[q][0]);
        waitpid(pid[q], NULL, 0);
    }
    FILE *f = fopen(out, "wb");
    if (!f || fprintf(f, "PF\n%u %u\n-1.0\n", size, size) < 0)
        return 1;
    for (uint32_t j = size; j-- > 0;)
        if (fwrite(img + (size_t)j * size * 3, sizeof *img, (size_t)size * 3, f) != (size_t)size * 3)
            return 1;
    free(img);
    rad_scene_destroy(s);
    return fclose(f) ? 1 : 0;
}

/* ------------------------------------------------------- the reference */

/* Every pixel's region (classify) into region[size²], counted per region
 * into count[], and written to `path` as an 8-bit PGM.  0, or 1 when the
 * file cannot be written (named on stderr). */
static int write_regions(const world *w, const rad_scene *s, const cam *k, uint32_t size,
                         const char *path, uint8_t *region, uint64_t *count)
{
    for (uint32_t j = 0; j < size; j++)
        for (uint32_t i = 0; i < size; i++) {
            uint8_t g = classify(w, s, k, i, j);
            region[(size_t)j * size + i] = g;
            if (g != RG_NONE)
                count[g]++;
        }
    FILE *f = fopen(path, "wb");
    if (!f || fprintf(f, "P5\n%u %u\n255\n", size, size) < 0 ||
        fwrite(region, 1, (size_t)size * size, f) != (size_t)size * size || fclose(f)) {
        fprintf(stderr, "pathtrace: cannot write %s\n", path);
        return 1;
    }
    return 0;
}

/* A job's samples (`count` a pass: a region's pixels, or 1) traced into
 * *a: a pilot of about 1e5 paths measures the spread of one path's band
 * sum; the job then gets enough paths for its mean's relative standard
 * error to reach `target`, and at least `paths`.  0, or 1 when a job failed (named on stderr). */
static int trace_to_target(work_fn work, const void *job, uint64_t count, double paths,
                           double target, uint64_t seed, int jobs, acc *a)
{
    uint64_t pilot = (uint64_t)ceil(1e5 / count);
    acc more;
    if (trace_parallel(work, job, pilot, seed, jobs, a)) {
        fprintf(stderr, "pathtrace: a job failed\n");
        return 1;
    }
    double m = a->sum[MAXB] / a->paths, var = fmax(0.0, a->sum2[MAXB] / a->paths - m * m);
    double need = fmax(paths, m > 0.0 ? var / (m * m * target * target) : 0.0);
    uint64_t passes = (uint64_t)ceil(need / count);
    if (passes > pilot) {
        if (trace_parallel(work, job, passes - pilot, seed + 500u, jobs, &more)) {
            fprintf(stderr, "pathtrace: a job failed\n");
            return 1;
        }
        acc_add(a, &more);
    }
    return 0;
}

/* Region g's JSON object (its means and their standard errors per band and
 * of the band sum) into f, after a comma unless it is the first, and its
 * line on stdout with the seconds since t0. */
static void put_region(FILE *f, int first, uint8_t g, uint64_t count, const acc *a,
                       uint32_t bands, time_t t0)
{
    fprintf(f, "%s  {\"id\": %u, \"name\": \"%s\", \"pixels\": %llu, \"paths\": %llu, \"mean\": [",
            first ? "" : ",\n", g, region_name[g], (unsigned long long)count,
            (unsigned long long)a->paths);
    printf("%-32s %6llu px %10llu paths", region_name[g], (unsigned long long)count,
           (unsigned long long)a->paths);
    for (uint32_t b = 0; b < bands; b++) {
        double m = a->sum[b] / a->paths;
        fprintf(f, "%s%.9g", b ? ", " : "", m);
        printf(" %.5f", m);
    }
    fprintf(f, "], \"stderr\": [");
    for (uint32_t b = 0; b < bands; b++) {
        double m = a->sum[b] / a->paths;
        double se = sqrt(fmax(0.0, a->sum2[b] / a->paths - m * m) / (double)(a->paths - 1));
        fprintf(f, "%s%.3g", b ? ", " : "", se);
        printf(" (%.2g%%)", m > 0 ? 100 * se / m : 0.0);
    }
    double ms = a->sum[MAXB] / a->paths;
    double ses = sqrt(fmax(0.0, a->sum2[MAXB] / a->paths - ms * ms) / (double)(a->paths - 1));
    fprintf(f, "], \"sum_relative_stderr\": %.3g}", ms > 0.0 ? ses / ms : 0.0);
    printf("  band sum %.3g%%, %.0f s\n", ms > 0.0 ? 100.0 * ses / ms : 0.0,
           difftime(time(NULL), t0));
    fflush(stdout);
}

/* The reference of scene pos[0]: its regions to pos[1] (PGM), their means
 * to pos[2] (JSON, with the command line argv that made it).  0, 1 when a
 * file cannot be written or a job failed, 2 for a scene it cannot use. */
static int trace_reference(const char *const pos[3], uint32_t size, double paths, double target,
                           uint64_t seed, int jobs, int argc, char **argv)
{
    rad_scene *s = NULL;
    rad_error err;
    if (rad_scene_load(pos[0], NULL, &s, &err)) {
        fprintf(stderr, "pathtrace: %s\n", err.message);
        return 2;
    }
    world w;
    if (world_from_scene(s, &w) || w.ne != 1 || !s->camera_count) {
        fprintf(stderr, "pathtrace: %s: one emitter polygon and a camera expected\n", pos[0]);
        return 2;
    }
    cam k;
    cam_make(&s->cameras[0], size, size, &k);
    uint8_t *region = malloc((size_t)size * size);
    uint64_t count[RG_COUNT] = {0};
    if (write_regions(&w, s, &k, size, pos[1], region, count))
        return 1;
    FILE *f = fopen(pos[2], "w");
    if (!f) {
        fprintf(stderr, "pathtrace: cannot write %s\n", pos[2]);
        return 1;
    }
    fprintf(f, "{\n \"scene\": \"%s\",\n \"size\": %u,\n \"regions_file\": \"%s\",\n"
               " \"method\": \"pathtrace (tools/pathtrace.c): next-event estimation, cosine "
               "continuation, Russian roulette after 3 bounces, box-filtered pixels\",\n"
               " \"command\": \"",
            pos[0], size, pos[1]);
    for (int a = 0; a < argc; a++)
        fprintf(f, "%s%s", a ? " " : "", argv[a]);
    fprintf(f, "\",\n \"units\": \"radiance per band (the engine's B/pi)\",\n \"regions\": [\n");
    int first = 1;
    for (uint8_t g = 0; g < RG_COUNT; g++) {
        if (!count[g])
            continue;
        time_t t0 = time(NULL);
        acc a;
        region_job job = {&w, &k, region, g};
        if (trace_to_target(region_work, &job, count[g], paths, target, seed, jobs, &a))
            return 1;
        put_region(f, first, g, count[g], &a, w.bands, t0);
        first = 0;
    }
    fprintf(f, "\n ]\n}\n");
    if (fclose(f)) {
        fprintf(stderr, "pathtrace: cannot write %s\n", pos[2]);
        return 1;
    }
    free(region);
    rad_scene_destroy(s);
    return 0;
}

/* ------------------------------------------------------------ objects */

/* An object's polygons, chosen by area. */
typedef struct object_job {
    const world *w;
    uint32_t object;
    uint32_t *poly;  /* its polygons */
    double *cdf;     /* their cumulative area share */
    uint32_t count;
    double area;     /* A_o */
} object_job;

/* `count` points uniform over the object's area, each one sample of the
 * radiance leaving it (E/π + ρ × the incident radiance, the latter one
 * estimate by next-event estimation and continuation), and of the power
 * it absorbs, A_o Σ_b (1 − ρ_b) π L_in,b. */
static void object_work(const void *job, uint64_t count, uint64_t seed, acc *a)
{
    const object_job *j = job;
    const world *w = j->w;
    rng r;
    rng_seed(&r, seed + 7919u * j->object);
    double Lin[MAXB], L[MAXB];
    for (uint64_t n = 0; n < count; n++) {
        double u = rnd(&r);
        uint32_t k = 0;
        while (k + 1 < j->count && u > j->cdf[k])
            k++;
        const poly *q = &w->P[j->poly[k]];
        v3 x = sample_poly(q, &r);
        for (uint32_t b = 0; b < w->bands; b++)
            Lin[b] = 0.0;
        scatter(w, (int)j->poly[k], x, &r, 1, Lin);
        double ab = 0.0;
        for (uint32_t b = 0; b < w->bands; b++) {
            L[b] = w->E[q->material][b] / M_PI + w->rho[q->material][b] * Lin[b];
            ab += j->area * (1.0 - w->rho[q->material][b]) * M_PI * Lin[b];
        }
        acc_put(a, L, w->bands);
        a->absorbed += ab;
        a->absorbed2 += ab * ab;
    }
}

/* Mean and standard error of the mean of sums s, s2 over n samples. */
static double mean_se(double s, double s2, uint64_t n, double *se)
{
    double m = s / (double)n;
    *se = n > 1 ? sqrt(fmax(0.0, s2 / (double)n - m * m) / (double)(n - 1)) : 0.0;
    return m;
}

/* Object o's JSON entry and stdout line; its emitted power into *emit. */
static void put_object(FILE *f, int first, const rad_scene *s, const object_job *j,
                       const acc *a, double *emit, time_t t0)
{
    const world *w = j->w;
    uint32_t m = w->P[j->poly[0]].material;
    double se, e = 0.0;
    fprintf(f, "%s  {\"name\": \"%s\", \"area\": %.9g, \"rho\": [", first ? "" : ",\n",
            s->objects[j->object].name, j->area);
    for (uint32_t b = 0; b < w->bands; b++) {
        fprintf(f, "%s%.6g", b ? ", " : "", w->rho[m][b]);
        e += j->area * w->E[m][b];
    }
    fprintf(f, "], \"paths\": %llu, \"mean\": [", (unsigned long long)a->paths);
    printf("%-10s %10llu paths", s->objects[j->object].name, (unsigned long long)a->paths);
    for (uint32_t b = 0; b < w->bands; b++) {
        fprintf(f, "%s%.9g", b ? ", " : "", mean_se(a->sum[b], a->sum2[b], a->paths, &se));
        printf(" %.5f", a->sum[b] / (double)a->paths);
    }
    fprintf(f, "], \"stderr\": [");
    for (uint32_t b = 0; b < w->bands; b++) {
        mean_se(a->sum[b], a->sum2[b], a->paths, &se);
        fprintf(f, "%s%.3g", b ? ", " : "", se);
    }
    double ms = mean_se(a->sum[MAXB], a->sum2[MAXB], a->paths, &se), sa;
    double ab = mean_se(a->absorbed, a->absorbed2, a->paths, &sa);
    fprintf(f, "], \"sum_relative_stderr\": %.3g, \"emitted\": %.9g, \"absorbed\": %.9g, "
               "\"absorbed_stderr\": %.3g}",
            ms > 0.0 ? se / ms : 0.0, e, ab, sa);
    printf("  band sum %.3g%%, absorbed %.5f ± %.2g, %.0f s\n", ms > 0 ? 100 * se / ms : 0.0, ab,
           sa, difftime(time(NULL), t0));
    fflush(stdout);
    *emit = e;
}

/* Object o's polygons into j (the caller frees j->poly, j->cdf); 0 when
 * it has none. */
static uint32_t object_polygons(const world *w, uint32_t o, object_job *j)
{
    j->count = 0;
    j->area = 0.0;
    for (uint32_t i = 0; i < w->np; i++)
        if (w->P[i].object == o && w->P[i].area > 0.0) {
            j->poly[j->count] = i;
            j->area += w->P[i].area;
            j->cdf[j->count++] = j->area;
        }
    for (uint32_t k = 0; k < j->count; k++)
        j->cdf[k] /= j->area;
    return j->count;
}

/* The area-mean radiance leaving each object of SCENE, with standard
 * errors, and the power absorbed against the power emitted, as JSON into
 * OUT (with the command line).  0; 1 when a file cannot be written or a
 * job failed; 2 for a scene it cannot use. */
static int trace_objects(const char *scene, const char *out, double paths, double target,
                         uint64_t seed, int jobs, int argc, char **argv)
{
    rad_scene *s = NULL;
    rad_error err;
    world w;
    if (rad_scene_load(scene, NULL, &s, &err)) {
        fprintf(stderr, "pathtrace: %s\n", err.message);
        return 2;
    }
    if (world_from_scene(s, &w) || !w.ne) {
        fprintf(stderr, "pathtrace: %s: an emitter expected\n", scene);
        return 2;
    }
    FILE *f = fopen(out, "w");
    object_job j = {&w, 0, calloc(w.np, sizeof *j.poly), calloc(w.np, sizeof *j.cdf), 0, 0};
    if (!f || !j.poly || !j.cdf) {
        fprintf(stderr, "pathtrace: cannot write %s\n", out);
        return 1;
    }
    fprintf(f, "{\n \"scene\": \"%s\",\n \"method\": \"pathtrace --objects (tools/pathtrace.c): "
               "points uniform over each object's area; at each, E/pi plus rho times one "
               "next-event + cosine-continuation estimate of the incident radiance, Russian "
               "roulette after 3 bounces\",\n \"command\": \"", scene);
    for (int a = 0; a < argc; a++)
        fprintf(f, "%s%s", a ? " " : "", argv[a]);
    fprintf(f, "\",\n \"units\": \"radiance per band (the engine's B/pi); power in the "
               "scene's units (sum over bands of area times exitance)\",\n \"objects\": [\n");
    double emitted = 0.0, absorbed = 0.0, var = 0.0;
    int first = 1;
    for (j.object = 0; j.object < s->object_count; j.object++) {
        time_t t0 = time(NULL);
        acc a;
        double e, se;
        if (!object_polygons(&w, j.object, &j))
            continue;
        if (trace_to_target(object_work, &j, 1, paths, target, seed, jobs, &a))
            return 1;
        put_object(f, first, s, &j, &a, &e, t0);
        first = 0;
        emitted += e;
        absorbed += mean_se(a.absorbed, a.absorbed2, a.paths, &se);
        var += se * se;
    }
    fprintf(f, "\n ],\n \"emitted\": %.9g,\n \"absorbed\": %.9g,\n \"absorbed_stderr\": %.3g\n}\n",
            emitted, absorbed, sqrt(var));
    printf("absorbed / emitted - 1 = %+.4f %% ± %.4f %%\n", 100 * (absorbed / emitted - 1),
           100 * sqrt(var) / emitted);
    free(j.poly);
    free(j.cdf);
    rad_scene_destroy(s);
    if (fclose(f)) {
        fprintf(stderr, "pathtrace: cannot write %s\n", out);
        return 1;
    }
    return 0;
}

/* A unit cube lit by its ceiling (E = π, radiance 1) alone, its walls
 * black, its floor of ρ = 0.5: the floor's mean radiance is ρ F, F the
 * factor between the two unit squares one apart (Howell C-11), and it
 * absorbs A (1 − ρ) π F.  (No emitter touches the floor: next-event
 * samples near a shared edge, as in the furnace, have a variance too
 * heavy-tailed for a check by standard errors.) */
static const char *BOX =
    "bands 1\n"
    "material floor reflectance 0.5\n"
    "material black reflectance 0\n"
    "material lamp emission 3.141592653589793\n"
    "polygon floor floor 0 0 0  0 0 1  1 0 1  1 0 0 end\n"
    "polygon ceil lamp 0 1 0  1 1 0  1 1 1  0 1 1 end\n"
    "polygon x0 black 0 0 0  0 1 0  0 1 1  0 0 1 end\n"
    "polygon x1 black 1 0 0  1 0 1  1 1 1  1 1 0 end\n"
    "polygon z0 black 0 0 0  1 0 0  1 1 0  0 1 0 end\n"
    "polygon z1 black 0 0 1  0 1 1  1 1 1  1 0 1 end\n";

/* Howell C-11: directly opposed a × b rectangles c apart. */
static double howell_c11(double a, double b, double c)
{
    double X = a / c, Y = b / c, x1 = sqrt(1 + X * X), y1 = sqrt(1 + Y * Y);
    return 2.0 / (M_PI * X * Y) *
           (log(sqrt((1 + X * X) * (1 + Y * Y) / (1 + X * X + Y * Y))) + X * y1 * atan(X / y1) +
            Y * x1 * atan(Y / x1) - X * atan(X) - Y * atan(Y));
}

/* --check of --objects: the box's floor, its radiance and what it absorbs. */
static int check_objects(int jobs)
{
    rad_scene *s = NULL;
    rad_error err;
    world w;
    if (rad_scene_parse_polyfile(BOX, strlen(BOX), "box", NULL, &s, &err) ||
        world_from_scene(s, &w))
        return -1;
    uint32_t poly[MAXPTS];
    double cdf[MAXPTS];
    object_job j = {&w, 0, poly, cdf, 0, 0};
    acc a;
    if (!object_polygons(&w, 0, &j) || trace_parallel(object_work, &j, 400000, 777, jobs, &a))
        return -1;
    double se, sa, m = mean_se(a.sum[0], a.sum2[0], a.paths, &se);
    double F = howell_c11(1.0, 1.0, 1.0), expect = 0.5 * F;
    double ab = mean_se(a.absorbed, a.absorbed2, a.paths, &sa), emitted = 0.5 * M_PI * F;
    int ok = fabs(m - expect) <= 4.0 * se && fabs(ab - emitted) <= 4.0 * sa;
    printf("check objects  radiance %.6f, expected %.6f (%.1f standard errors); absorbed %.5f, "
           "expected %.5f (%.1f): %s\n",
           m, expect, fabs(m - expect) / se, ab, emitted, fabs(ab - emitted) / sa,
           ok ? "ok" : "FAIL");
    rad_scene_destroy(s);
    free(w.P);
    free(w.emit);
    free(w.emit_cdf);
    return ok ? 0 : -1;
}

/* ------------------------------------------------------------ main */

static int usage(void)
{
    fprintf(stderr, "usage: pathtrace SCENE REGIONS.pgm REFERENCE.json [--size N] [--paths P] "
                    "[--target T] [--seed S] [--jobs J]\n       pathtrace --check [--jobs J]\n"
                    "       pathtrace SCENE --image OUT.pfm [--size N] [--spp K] [--jobs J]\n"
                    "       pathtrace SCENE --objects OUT.json [--paths P] [--target T] [--seed S] "
                    "[--jobs J]\n");
    return 2;
}

int main(int argc, char **argv)
{
    uint32_t size = 256;
    double paths = 1e6, target = 5e-4;
    uint64_t seed = 1;
    int jobs = 2, check = 0;
    const char *image = NULL, *objects = NULL;
    uint64_t spp = 256;
    const char *pos[3];
    int npos = 0;
    for (int a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "--check"))
            check = 1;
        else if (!strcmp(argv[a], "--size") && a + 1 < argc)
            size = (uint32_t)atoi(argv[++a]);
        else if (!strcmp(argv[a], "--paths") && a + 1 < argc)
            paths = atof(argv[++a]);
        else if (!strcmp(argv[a], "--target") && a + 1 < argc)
            target = atof(argv[++a]);
        else if (!strcmp(argv[a], "--seed") && a + 1 < argc)
            seed = strtoull(argv[++a], NULL, 10);
        else if (!strcmp(argv[a], "--jobs") && a + 1 < argc)
            jobs = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--image") && a + 1 < argc)
            image = argv[++a];
        else if (!strcmp(argv[a], "--objects") && a + 1 < argc)
            objects = argv[++a];
        else if (!strcmp(argv[a], "--spp") && a + 1 < argc)
            spp = strtoull(argv[++a], NULL, 10);
        else if (npos < 3 && argv[a][0] != '-')
            pos[npos++] = argv[a];
        else
            return usage();
    }
    if (jobs < 1 || jobs > 64 || size < 8 || size > 4096)
        return usage();
    if (check) {
        int bad = check_one("furnace", FURNACE, 1.0 / (M_PI * 0.5), jobs);
        bad |= check_one("lamp", LAMP, 0.5 * howell_b3(1.0, 1.0, 0.5), jobs);
        bad |= check_objects(jobs);
        return bad ? 1 : 0;
    }
    if (image)
        return trace_image(pos[0], image, size, spp, seed, jobs);
    if (objects)
        return npos == 1 ? trace_objects(pos[0], objects, paths, target, seed, jobs, argc, argv)
                         : usage();
    if (npos != 3)
        return usage();
    return trace_reference(pos, size, paths, target, seed, jobs, argc, argv);
}
