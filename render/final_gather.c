/* final_gather.c - the final gather: a ray-traced view of a stored radiosity
 * solution (Ward, Rubinstein & Clear 1988), with glossy lobes the solve
 * does not know (Ward's isotropic Gaussian; Zaninetti & Péroche's light
 * vectors).
 *
 * A pixel's eye ray meets a cell at X (normal n, diffuse ρ, emission E,
 * transmitted exitance T, lobe ρ_s and α) and its radiance is
 *     L = (E + T)/π + (ρ/π)(H_direct + H_indirect) + L_glossy.
 * H_direct is sampled at X from every emitting polygon (stratified points,
 * one shadow ray each) and every punctual light (one shadow ray).
 * H_indirect is the hemisphere gather: M × N stratified cosine-weighted
 * rays (θ_j = asin sqrt((j + ξ)/M), φ_k = 2π(k + ξ')/N, the paper's eq. 2),
 * each reading at its hit the stored radiosity as the vertex renderer draws
 * it (vertex values interpolated in the cell) minus that cell's E, because
 * an emitter's own light is already in H_direct: one bounce of gather from
 * the radiosity solution, the classic final gather.  Ward's cache
 * (icache.c) reuses gathers across pixels and views.  A glossy lobe takes
 * its direct light from the same light samples, its indirect light by
 * sampling the lobe against the stored radiosity or from the cache's light
 * vector, and a mirror-like lobe (roughness < RN_MIRROR_ROUGHNESS) follows
 * the reflected ray, shading what it meets in full, to max_depth.
 *
 * Passes: with the cache, pass 1 visits the pixels coarse to fine (strides
 * 16, 8, 4, 2, 1) and runs Ward's secondary method at every diffuse
 * shading point, computing and storing a record where none is valid; pass
 * 2 shades every pixel, reading the finished cache without changing it, so
 * it may run on several threads and every pixel sees the same records.
 * Each pixel draws its random numbers from its own stream, so an image does
 * not depend on the threads or on the order of the rows.
 *
 * Visibility as in the solution: a back face blocks gather, lobe and
 * shadow rays and sends nothing; the eye and mirror rays pass through back
 * faces, as the vertex renderer does not draw them; a sheet (mesh twins)
 * is seen from either side as the twin facing the ray.
 */
#include "rn_internal.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ----------------------------------------------------------- random */

typedef struct rng {
    uint64_t s;
} rng;

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* splitmix64: a uniform double in [0, 1). */
static double rnd(rng *r)
{
    r->s += 0x9e3779b97f4a7c15ull;
    return (double)(mix64(r->s) >> 11) * 0x1.0p-53;
}

static rng pixel_rng(uint64_t pixel, uint64_t pass)
{
    rng r = {mix64(pixel * 0x2545f4914f6cdd1dull + pass * 0x632be59bd9b4e019ull + 1)};
    return r;
}

/* ------------------------------------------------------------ setup */

/* An emitting polygon as a fan of triangles about its first corner. */
typedef struct emitter_prep {
    double area;
    uint32_t first_tri, tris; /* into the run's tri_area (cumulative) */
} emitter_prep;

typedef struct run {
    const rn_scene *sc;
    uint32_t nb;
    rn_rt *rt;
    rn_cell2d *cell;
    emitter_prep *em;
    double *tri_cum;          /* cumulative fan triangle areas per emitter */
    double off;               /* ray origin offset: above float rounding of the scene */
    double diag;              /* scene bounding-box diagonal */
    rad_vec3 lo, hi;
    /* resolved options */
    double eps;
    int cached, gradients;
    uint32_t M, N;            /* gather strata: θ × φ */
    uint32_t ls, gs;          /* light and lobe samples: a side of their square */
    uint32_t max_depth;
    double min_radius_px;
    rn_glossy_mode glossy;
    double k;                 /* camera pixels per unit of depth */
    rn_icache *cache;
    int filling;              /* pass 1: the cache may grow (one thread) */
    rad_error *err;
    atomic_int stop;          /* pass 2: stop handing out rows */
} run;

/* What one thread counts and its gather scratch. */
typedef struct worker {
    run *g;
    rn_gather_stats st;
    double *L;                /* M·N × bands */
    double *dist;             /* M·N */
    double *theta, *phi;      /* M·N */
} worker;

static int check_scene(const rn_scene *sc, rad_error *err)
{
    if (!sc || !sc->mesh || !sc->vertex_B || !sc->rho || !sc->emission)
        return rad_fail(err, RAD_ERR_USAGE, "render: gather: incomplete scene");
    if (sc->bands == 0 || sc->bands > RAD_MAX_BANDS)
        return rad_fail(err, RAD_ERR_USAGE, "render: gather: %u bands, not 1..%d", sc->bands,
                        RAD_MAX_BANDS);
    int rc = rn_mesh_check(sc->mesh, err);
    if (rc)
        return rc;
    const rad_mesh *m = sc->mesh;
    uint32_t nb = sc->bands;
    for (uint32_t c = 0; c < m->patch_count; c++) {
        if (m->patches[c].material >= sc->material_count)
            return rad_fail(err, RAD_ERR_USAGE, "render: gather: cell %u: material %u of %u", c,
                            m->patches[c].material, sc->material_count);
        if (m->twin && m->twin[c] != RAD_NONE && m->twin[c] >= m->patch_count)
            return rad_fail(err, RAD_ERR_USAGE, "render: gather: cell %u: twin out of range", c);
        for (uint32_t b = 0; b < nb; b++) {
            size_t q = (size_t)c * nb + b;
            if (!(sc->rho[q] >= 0.0 && sc->rho[q] < 1.0) || !(sc->emission[q] >= 0.0) ||
                !isfinite(sc->emission[q]) ||
                (sc->transmitted && !(sc->transmitted[q] >= 0.0 && isfinite(sc->transmitted[q]))))
                return rad_fail(err, RAD_ERR_USAGE, "render: gather: cell %u: bad ρ, E or T", c);
        }
    }
    for (size_t q = 0; q < (size_t)m->vertex_count * nb; q++)
        if (!(sc->vertex_B[q] >= 0.0) || !isfinite(sc->vertex_B[q]))
            return rad_fail(err, RAD_ERR_USAGE, "render: gather: vertex radiosity %zu is %g",
                            q / nb, sc->vertex_B[q]);
    for (uint32_t i = 0; i < sc->material_count; i++) {
        const rn_material *mt = &sc->materials[i];
        if (!(mt->roughness >= 0.0 && mt->roughness <= 1.0))
            return rad_fail(err, RAD_ERR_USAGE, "render: gather: material %u: roughness %g", i,
                            mt->roughness);
        for (uint32_t b = 0; b < nb; b++)
            if (!(mt->specular[b] >= 0.0 && mt->specular[b] < 1.0))
                return rad_fail(err, RAD_ERR_USAGE, "render: gather: material %u: ρ_s %g", i,
                                mt->specular[b]);
    }
    for (uint32_t e = 0; e < sc->emitter_count; e++) {
        const rn_emitter *em = &sc->emitters[e];
        if (!em->points || em->count < 3 || fabs(rad_length(em->normal) - 1.0) > 1e-6)
            return rad_fail(err, RAD_ERR_USAGE, "render: gather: emitter %u is not a polygon", e);
        for (uint32_t k = 0; k < em->count; k++)
            if (!rad_finite3(em->points[k]))
                return rad_fail(err, RAD_ERR_USAGE, "render: gather: emitter %u: corner %u", e, k);
        for (uint32_t b = 0; b < nb; b++)
            if (!(em->E[b] >= 0.0) || !isfinite(em->E[b]))
                return rad_fail(err, RAD_ERR_USAGE, "render: gather: emitter %u: E %g", e,
                                em->E[b]);
    }
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const rn_light *L = &sc->lights[l];
        if (!rad_finite3(L->position) || !rad_finite3(L->direction) ||
            (L->kind != RN_LIGHT_POINT && fabs(rad_length(L->direction) - 1.0) > 1e-6))
            return rad_fail(err, RAD_ERR_USAGE, "render: gather: light %u: bad position or "
                            "direction", l);
        for (uint32_t b = 0; b < nb; b++)
            if (!(L->I[b] >= 0.0) || !isfinite(L->I[b]))
                return rad_fail(err, RAD_ERR_USAGE, "render: gather: light %u: I %g", l, L->I[b]);
    }
    return RAD_OK;
}

/* The settings a cache's records depend on, resolved from opt. */
typedef struct settings {
    double eps;
    uint32_t rays, M, N;
    int gradients;
    double min_radius_px;
} settings;

static void resolve_settings(const rn_gather_options *opt, settings *s)
{
    static const rn_gather_options none;
    if (!opt)
        opt = &none;
    s->eps = opt->epsilon > 0.0 ? opt->epsilon : RN_DEFAULT_EPSILON;
    uint32_t rays = opt->gather_rays ? opt->gather_rays : RN_DEFAULT_GATHER_RAYS;
    s->rays = rays;
    /* Ward & Heckbert: N ≈ πM makes the strata about square. */
    s->M = (uint32_t)lround(sqrt((double)rays / M_PI));
    if (s->M < 2)
        s->M = 2;
    s->N = (uint32_t)lround((double)rays / s->M);
    if (s->N < 3)
        s->N = 3;
    s->gradients = !opt->no_gradients;
    s->min_radius_px = opt->min_radius_px > 0.0 ? opt->min_radius_px : RN_DEFAULT_MIN_RADIUS_PX;
}

/* How a record's R is set, in the key: a cache file filled under another
 * rule is made anew (2: R_i bounded by the gradient, limit_radius). */
#define RN_RECORD_RULE 2u

uint64_t rn_gather_key(const rn_scene *sc, const rn_gather_options *opt)
{
    settings st;
    resolve_settings(opt, &st);
    uint64_t h = RN_FNV_START;
    uint32_t head[4] = {sc->bands, sc->mesh->vertex_count, sc->mesh->patch_count,
                        sc->material_count};
    h = rn_fnv(h, head, sizeof head);
    h = rn_fnv(h, sc->mesh->vertices, (size_t)sc->mesh->vertex_count * sizeof(rad_vec3));
    for (uint32_t c = 0; c < sc->mesh->patch_count; c++) {
        const rad_patch *p = &sc->mesh->patches[c];
        h = rn_fnv(h, p->v, sizeof p->v);
        h = rn_fnv(h, &p->normal, sizeof p->normal);
        h = rn_fnv(h, &p->material, sizeof p->material);
    }
    size_t nv = (size_t)sc->mesh->vertex_count * sc->bands, nc = (size_t)sc->mesh->patch_count * sc->bands;
    h = rn_fnv(h, sc->vertex_B, nv * sizeof(double));
    h = rn_fnv(h, sc->emission, nc * sizeof(double));
    for (uint32_t i = 0; i < sc->material_count; i++) {
        h = rn_fnv(h, sc->materials[i].specular, sc->bands * sizeof(double));
        h = rn_fnv(h, &sc->materials[i].roughness, sizeof(double));
    }
    double d[2] = {st.eps, st.min_radius_px};
    uint32_t u[4] = {st.M, st.N, (uint32_t)st.gradients, RN_RECORD_RULE};
    h = rn_fnv(h, d, sizeof d);
    h = rn_fnv(h, u, sizeof u);
    return h ? h : 1; /* 0 means "any key" to rn_icache_read */
}

static int run_setup(run *g, const rn_scene *sc, const rn_gather_options *opt, rad_error *err)
{
    static const rn_gather_options none;
    if (!opt)
        opt = &none;
    memset(g, 0, sizeof *g);
    g->sc = sc;
    g->nb = sc->bands;
    g->err = err;
    settings st;
    resolve_settings(opt, &st);
    if (!(st.eps <= 1.0))
        return rad_fail(err, RAD_ERR_USAGE, "render: gather: epsilon %g not in (0, 1]", st.eps);
    g->eps = st.eps;
    g->M = st.M;
    g->N = st.N;
    g->gradients = st.gradients;
    g->min_radius_px = st.min_radius_px;
    g->cached = !opt->no_cache;
    uint32_t ls = opt->light_samples ? opt->light_samples : RN_DEFAULT_LIGHT_SAMPLES;
    uint32_t gs = opt->glossy_rays ? opt->glossy_rays : RN_DEFAULT_GLOSSY_RAYS;
    g->ls = (uint32_t)floor(sqrt((double)ls));
    g->gs = (uint32_t)floor(sqrt((double)gs));
    g->ls = g->ls ? g->ls : 1;
    g->gs = g->gs ? g->gs : 1;
    g->max_depth = opt->max_depth ? opt->max_depth : RN_DEFAULT_MAX_DEPTH;
    g->glossy = opt->glossy;
    if (g->glossy != RN_GLOSSY_AUTO && g->glossy != RN_GLOSSY_SAMPLE &&
        g->glossy != RN_GLOSSY_LIGHT_VECTOR)
        return rad_fail(err, RAD_ERR_USAGE, "render: gather: unknown glossy mode %d", g->glossy);

    const rad_mesh *m = sc->mesh;
    double maxabs = 0;
    g->lo = rad_v3(INFINITY, INFINITY, INFINITY);
    g->hi = rad_scale(g->lo, -1.0);
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        rad_vec3 p = m->vertices[v];
        g->lo = rad_v3(fmin(g->lo.x, p.x), fmin(g->lo.y, p.y), fmin(g->lo.z, p.z));
        g->hi = rad_v3(fmax(g->hi.x, p.x), fmax(g->hi.y, p.y), fmax(g->hi.z, p.z));
        maxabs = fmax(maxabs, fmax(fabs(p.x), fmax(fabs(p.y), fabs(p.z))));
    }
    g->diag = rad_length(rad_sub(g->hi, g->lo));
    if (!(g->diag > 0.0))
        return rad_fail(err, RAD_ERR_USAGE, "render: gather: the scene has no extent");
    /* Embree intersects in float: 1e-5 of the scene's size is ~100 float
     * ulps of its largest coordinate, and far below the gaps scenes model
     * (5.6e-6 m in the Cornell box, whose lamp hangs 1e-4 m below the
     * ceiling). */
    g->off = 1e-5 * fmax(g->diag, maxabs);

    g->cell = malloc((size_t)m->patch_count * sizeof *g->cell);
    uint32_t tris = 0;
    for (uint32_t e = 0; e < sc->emitter_count; e++)
        tris += sc->emitters[e].count - 2;
    g->em = calloc((size_t)sc->emitter_count + 1, sizeof *g->em);
    g->tri_cum = malloc(((size_t)tris + 1) * sizeof *g->tri_cum);
    if (!g->cell || !g->em || !g->tri_cum)
        return rad_fail(err, RAD_ERR_NOMEM, "render: gather: out of memory");
    for (uint32_t c = 0; c < m->patch_count; c++)
        rn_cell2d_init(&g->cell[c], m, c);
    uint32_t t = 0;
    for (uint32_t e = 0; e < sc->emitter_count; e++) {
        const rn_emitter *em = &sc->emitters[e];
        emitter_prep *ep = &g->em[e];
        ep->first_tri = t;
        ep->tris = em->count - 2;
        double cum = 0;
        for (uint32_t k = 1; k + 1 < em->count; k++) {
            rad_vec3 a = rad_sub(em->points[k], em->points[0]);
            rad_vec3 b = rad_sub(em->points[k + 1], em->points[0]);
            cum += 0.5 * rad_length(rad_cross(a, b));
            g->tri_cum[t++] = cum;
        }
        ep->area = cum;
    }
    return rn_rt_create(m, &g->rt, err);
}

static void run_free(run *g)
{
    rn_rt_destroy(g->rt);
    free(g->cell);
    free(g->em);
    free(g->tri_cum);
}

/* --------------------------------------------------------- tracing */

static rad_vec3 along(rad_vec3 o, rad_vec3 d, double t) { return rad_add(o, rad_scale(d, t)); }

/* Two unit vectors completing n to a right-handed frame. */
static void tangents(rad_vec3 n, rad_vec3 *t1, rad_vec3 *t2)
{
    rad_vec3 a = fabs(n.x) < 0.6 ? rad_v3(1, 0, 0) : fabs(n.y) < 0.6 ? rad_v3(0, 1, 0)
                                                                     : rad_v3(0, 0, 1);
    *t1 = rad_normalize(rad_cross(a, n));
    *t2 = rad_cross(n, *t1);
}

/* The cell facing a ray that met cell c: c itself from the front, its twin
 * from behind (a sheet), RAD_NONE for the back of an opaque cell. */
static uint32_t facing(const run *g, uint32_t c, rad_vec3 dir)
{
    const rad_mesh *m = g->sc->mesh;
    if (rad_dot(dir, m->patches[c].normal) < 0.0)
        return c;
    return m->twin ? m->twin[c] : RAD_NONE;
}

/* Eye and mirror rays: the nearest front face (back faces are passed, as
 * the vertex renderer culls them).  Unit dir. */
static uint32_t trace_view(const run *g, rad_vec3 org, rad_vec3 dir, double tnear, double *t)
{
    for (int tries = 0; tries < 64; tries++) {
        uint32_t c = rn_rt_intersect(g->rt, org, dir, tnear, INFINITY, t);
        if (c == RAD_NONE)
            return RAD_NONE;
        uint32_t f = facing(g, c, dir);
        if (f != RAD_NONE)
            return f;
        tnear = *t + g->off;
    }
    return RAD_NONE;
}

/* Gather and lobe rays: the first face met; a back face blocks (returns
 * RAD_NONE with *t set, *blocked = 1). */
static uint32_t trace_block(const run *g, rad_vec3 org, rad_vec3 dir, double *t, int *blocked)
{
    uint32_t c = rn_rt_intersect(g->rt, org, dir, 0.0, INFINITY, t);
    *blocked = 0;
    if (c == RAD_NONE)
        return RAD_NONE;
    uint32_t f = facing(g, c, dir);
    *blocked = f == RAD_NONE;
    return f;
}

/* The stored radiosity at X in cell c as the vertex renderer draws it,
 * less the cell's own E (an emitter's light is direct light), as radiance
 * per band into L (>= 0). */
static void stored_radiance(const run *g, uint32_t c, rad_vec3 X, double *L)
{
    const rn_cell2d *cl = &g->cell[c];
    rad_vec3 d = rad_sub(X, cl->v0);
    double w[4];
    rn_cell2d_weights(cl, rad_dot(d, cl->e1), rad_dot(d, cl->e2), w);
    const uint32_t *v = g->sc->mesh->patches[c].v;
    uint32_t nb = g->nb;
    for (uint32_t b = 0; b < nb; b++) {
        double B = 0;
        for (int q = 0; q < cl->corners; q++)
            B += w[q] * g->sc->vertex_B[(size_t)v[q] * nb + b];
        B -= g->sc->emission[(size_t)c * nb + b];
        L[b] = B > 0.0 ? B / M_PI : 0.0;
    }
}

/* ------------------------------------------------------- the lobe */

/* Ward's isotropic BRDF lobe, without ρ_s:
 *   exp(−tan²δ / α²) / (4π α² sqrt(cosθ_i cosθ_o)),
 * δ the angle between n and the half vector of wi and wo (both unit, away
 * from the surface). */
static double ward_lobe(rad_vec3 n, rad_vec3 wi, rad_vec3 wo, double alpha)
{
    double ci = rad_dot(n, wi), co = rad_dot(n, wo);
    if (!(ci > 0.0 && co > 0.0))
        return 0.0;
    rad_vec3 h = rad_normalize(rad_add(wi, wo));
    double cd = rad_dot(n, h);
    if (!(cd > 0.0))
        return 0.0;
    double a2 = alpha * alpha, c2 = cd * cd;
    double tan2 = (1.0 - c2) / c2;
    return exp(-tan2 / a2) / (4.0 * M_PI * a2 * sqrt(ci * co));
}

/* Samples the lobe's half vector from (u1, u2) (Walter's "Notes on the
 * Ward BRDF", 2005): tan²δ = −α² ln u1, φ = 2π u2, wi the reflection of wo
 * about it.  Returns f cosθ_i / pdf without ρ_s,
 *   (h·wo) cos³δ sqrt(cosθ_i / cosθ_o),
 * or 0 when wi falls below the surface. */
static double ward_sample(rad_vec3 n, rad_vec3 wo, double alpha, double u1, double u2,
                          rad_vec3 *wi)
{
    double tan2 = -alpha * alpha * log(1.0 - u1); /* 1 − u1 in (0, 1] */
    double cd = 1.0 / sqrt(1.0 + tan2), sd = sqrt(fmax(0.0, 1.0 - cd * cd));
    double phi = 2.0 * M_PI * u2;
    rad_vec3 t1, t2;
    tangents(n, &t1, &t2);
    rad_vec3 h = rad_add(rad_add(rad_scale(t1, sd * cos(phi)), rad_scale(t2, sd * sin(phi))),
                         rad_scale(n, cd));
    double ho = rad_dot(h, wo);
    if (!(ho > 0.0))
        return 0.0;
    *wi = rad_sub(rad_scale(h, 2.0 * ho), wo);
    double ci = rad_dot(n, *wi), co = rad_dot(n, wo);
    if (!(ci > 0.0 && co > 0.0))
        return 0.0;
    return ho * cd * cd * cd * sqrt(ci / co);
}

/* --------------------------------------------------- direct light */

/* glTF's spot falloff (the one the solution's light item buffers used):
 * t² with t = clamp((cos − cos_outer) / max(0.001, cos_inner − cos_outer)). */
static double spot(const rn_light *L, double cos_axis)
{
    double ci = cos(L->inner_cone), co = cos(L->outer_cone);
    double t = (cos_axis - co) / fmax(0.001, ci - co);
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    return t * t;
}

/* Direct irradiance at X (normal n) into H[bands]; with a lobe (alpha > 0,
 * wo the unit direction to the viewer) also the lobe's direct radiance,
 * without ρ_s, into S[bands].
 *
 * An area emitter is sampled at stratified points with one shadow ray each,
 * and the samples only measure what share of its light gets through: the
 * unshadowed irradiance is exact, E·F with F Lambert's point-to-polygon
 * factor (rad_point_polygon_factor), and
 *     H = E F Σ_k V_k G_k / Σ_k G_k,   S = E F Σ_k V_k G_k f_k / Σ_k G_k,
 * G_k = cosθ_X cosθ_e / r² at sample k, V_k its visibility, f_k the lobe
 * (a ratio estimator: exact wherever the emitter is wholly seen, the
 * noise of the samples confined to penumbrae).  Geometry is taken from X,
 * the shadow rays leave from X lifted by the offset. */
static void direct_light(worker *w, rng *r, rad_vec3 X, rad_vec3 n, rad_vec3 wo, double alpha,
                         double *H, double *S)
{
    const run *g = w->g;
    const rn_scene *sc = g->sc;
    uint32_t nb = g->nb;
    for (uint32_t b = 0; b < nb; b++)
        H[b] = S[b] = 0.0;
    rad_vec3 Xo = along(X, n, g->off);
    for (uint32_t e = 0; e < sc->emitter_count; e++) {
        const rn_emitter *em = &sc->emitters[e];
        const emitter_prep *ep = &g->em[e];
        double side = rad_dot(rad_sub(X, em->points[0]), em->normal);
        if (!em->two_sided && !(side > 0.0))
            continue; /* behind a one-sided emitter */
        double F = rad_point_polygon_factor(X, n, em->points, em->count);
        if (!(F > 0.0) || !(ep->area > 0.0))
            continue;
        double gsum = 0, vsum = 0, ssum = 0;
        for (uint32_t sy = 0; sy < g->ls; sy++)
            for (uint32_t sx = 0; sx < g->ls; sx++) {
                /* A stratum of the unit square onto the fan: u picks the
                 * triangle by area (and is stretched back to [0, 1) inside
                 * it), then the uniform triangle map. */
                double u = ((double)sx + rnd(r)) / g->ls * ep->area;
                double v = ((double)sy + rnd(r)) / g->ls;
                uint32_t t = 0;
                while (t + 1 < ep->tris && g->tri_cum[ep->first_tri + t] <= u)
                    t++;
                double below = t ? g->tri_cum[ep->first_tri + t - 1] : 0.0;
                double at = g->tri_cum[ep->first_tri + t] - below;
                double uu = at > 0.0 ? (u - below) / at : 0.0;
                uu = uu < 0.0 ? 0.0 : uu > 1.0 ? 1.0 : uu;
                double s = sqrt(uu);
                rad_vec3 a = em->points[0], bq = em->points[t + 1], cq = em->points[t + 2];
                rad_vec3 P = rad_add(rad_add(rad_scale(a, 1.0 - s), rad_scale(bq, s * (1.0 - v))),
                                     rad_scale(cq, s * v));
                rad_vec3 d = rad_sub(P, X);
                double r2 = rad_dot(d, d), dist = sqrt(r2);
                if (!(dist > 0.0))
                    continue;
                rad_vec3 wi = rad_scale(d, 1.0 / dist);
                double cx = rad_dot(n, wi), ce = -rad_dot(em->normal, wi);
                if (em->two_sided)
                    ce = fabs(ce);
                if (!(cx > 0.0 && ce > 0.0))
                    continue;
                double G = cx * ce / r2;
                gsum += G;
                rad_vec3 ds = rad_sub(P, Xo);
                double ls = rad_length(ds);
                w->st.shadow_rays++;
                if (ls > 2.0 * g->off &&
                    rn_rt_occluded(g->rt, Xo, rad_scale(ds, 1.0 / ls), 0.0, ls - 2.0 * g->off))
                    continue;
                vsum += G;
                if (alpha > 0.0)
                    ssum += G * ward_lobe(n, wi, wo, alpha);
            }
        if (!(gsum > 0.0))
            continue; /* only a sliver in front of X, which no sample met */
        for (uint32_t b = 0; b < nb; b++) {
            H[b] += em->E[b] * F * vsum / gsum;
            S[b] += em->E[b] * F * ssum / gsum;
        }
    }
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const rn_light *L = &sc->lights[l];
        rad_vec3 wi, to;
        double f, tfar;
        if (L->kind == RN_LIGHT_DIRECTIONAL) {
            wi = to = rad_scale(L->direction, -1.0);
            f = 1.0;
            tfar = INFINITY;
        } else {
            rad_vec3 d = rad_sub(L->position, X);
            double r2 = rad_dot(d, d);
            if (!(r2 > 0.0))
                continue;
            wi = rad_scale(d, 1.0 / sqrt(r2));
            f = 1.0 / r2;
            if (L->kind == RN_LIGHT_SPOT)
                f *= spot(L, -rad_dot(wi, L->direction));
            rad_vec3 ds = rad_sub(L->position, Xo);
            tfar = rad_length(ds);
            to = rad_scale(ds, 1.0 / tfar);
        }
        double cx = rad_dot(n, wi);
        if (!(cx > 0.0 && f > 0.0))
            continue;
        w->st.shadow_rays++;
        if (rn_rt_occluded(g->rt, Xo, to, 0.0, tfar))
            continue;
        double lobe = alpha > 0.0 ? ward_lobe(n, wi, wo, alpha) : 0.0;
        for (uint32_t b = 0; b < nb; b++) {
            H[b] += L->I[b] * f * cx;
            S[b] += L->I[b] * f * cx * lobe;
        }
    }
}

/* ----------------------------------------------- the hemisphere gather */

/* Ward & Heckbert's gradients of the gather just made into rec. */
static void gradients(worker *w, rn_record *rec, rad_vec3 t1, rad_vec3 t2)
{
    const run *g = w->g;
    uint32_t nb = g->nb, M = g->M, N = g->N;
    double scale = M_PI / ((double)M * N);
    /* Rotational gradient: turning n by the small rotation vector ω changes
     * each sample's cosθ by (ω × n)·wi; with cosine-weighted samples that is
     * a relative change tanθ along v(φ) = (−sinφ, cosφ) in the tangent plane:
     *   gr = π/(MN) Σ L tanθ v(φ),   H(N') ≈ H + (N × N')·gr. */
    for (size_t q = 0; q < (size_t)M * N; q++) {
        double tn = tan(w->theta[q]);
        rad_vec3 v = rad_add(rad_scale(t1, -sin(w->phi[q])), rad_scale(t2, cos(w->phi[q])));
        for (uint32_t b = 0; b < nb; b++)
            rec->gr[b] = rad_add(rec->gr[b], rad_scale(v, scale * tn * w->L[q * nb + b]));
    }
    /* Translational gradient (Ward & Heckbert 1992): the boundaries between
     * strata move as X moves; across a θ boundary (j−1 | j) along the
     * stratum's azimuth u_k, and across a φ boundary (k−1 | k) along its
     * normal v_k−, each weighted by the change of projected solid angle per
     * unit move, with the nearer of the two distances:
     *   gt = Σ_k [ u_k 2π/N Σ_{j>=1} sinθ_j− cos²θ_j− (L_jk − L_j−1,k) / min(r)
     *            + v_k− Σ_j (sinθ_j+ − sinθ_j−) (L_jk − L_j,k−1) / min(r) ]. */
    for (uint32_t k = 0; k < N; k++) {
        double pc = 2.0 * M_PI * (k + 0.5) / N, pb = 2.0 * M_PI * k / N;
        rad_vec3 uk = rad_add(rad_scale(t1, cos(pc)), rad_scale(t2, sin(pc)));
        rad_vec3 vk = rad_add(rad_scale(t1, -sin(pb)), rad_scale(t2, cos(pb)));
        uint32_t km = (k + N - 1) % N;
        for (uint32_t j = 0; j < M; j++) {
            size_t q = (size_t)j * N + k;
            double sm = sqrt((double)j / M), sp = sqrt((double)(j + 1) / M);
            if (j > 0) {
                size_t q2 = (size_t)(j - 1) * N + k;
                double rm = fmin(w->dist[q], w->dist[q2]);
                if (isfinite(rm) && rm > 0.0) {
                    double f = 2.0 * M_PI / N * sm * (1.0 - (double)j / M) / rm;
                    for (uint32_t b = 0; b < nb; b++)
                        rec->gt[b] = rad_add(rec->gt[b],
                                             rad_scale(uk, f * (w->L[q * nb + b] - w->L[q2 * nb + b])));
                }
            }
            size_t q3 = (size_t)j * N + km;
            double rm = fmin(w->dist[q], w->dist[q3]);
            if (isfinite(rm) && rm > 0.0) {
                double f = (sp - sm) / rm;
                for (uint32_t b = 0; b < nb; b++)
                    rec->gt[b] = rad_add(rec->gt[b],
                                         rad_scale(vk, f * (w->L[q * nb + b] - w->L[q3 * nb + b])));
            }
        }
    }
}

/* R_i, the harmonic mean distance, is the split sphere's guess of how fast
 * H changes: it sees geometry, not light.  Where the light the gather sees
 * changes across the surface faster than the distances say (a face looking
 * at a floor half in shadow, through an open side that sends most rays to
 * nothing and makes R_i large), a record would be used far beyond where its
 * H holds: on the Cornell box at 512 × 512 the short block's front was
 * 4.3 % below a gather at every pixel.  So R_i is also bounded by the
 * measured translational gradient, R_i <= H_i / |∇_t H_i| in every band:
 * across its valid radius ε R_i a record's H then changes by at most ε H_i,
 * which is what ε bounds (report/gather.md).  Then kept between the
 * smallest radius in pixels and the scene's size. */
static void limit_radius(const run *g, rn_record *rec, double footprint)
{
    for (uint32_t b = 0; b < g->nb; b++) {
        double grad = rad_length(rec->gt[b]);
        if (grad > 0.0 && rec->H[b] > 0.0)
            rec->R = fmin(rec->R, rec->H[b] / grad);
    }
    double Rmin = g->min_radius_px * footprint / g->eps;
    rec->R = fmin(fmax(rec->R, Rmin), fmax(g->diag, Rmin));
}

/* Ward's primary method at X (normal n): the record of indirect
 * irradiance, with the harmonic mean distance, Ward & Heckbert's gradients
 * and the light vector.  footprint: a pixel's size at X (scene units). */
static void gather(worker *w, rng *r, rad_vec3 X, rad_vec3 n, double footprint, rn_record *rec)
{
    const run *g = w->g;
    uint32_t nb = g->nb, M = g->M, N = g->N;
    rad_vec3 t1, t2;
    tangents(n, &t1, &t2);
    rad_vec3 Xo = along(X, n, g->off);
    memset(rec, 0, sizeof *rec);
    rec->P = X;
    rec->N = n;
    double inv_sum = 0;
    rad_vec3 D = rad_v3(0, 0, 0);
    for (uint32_t j = 0; j < M; j++)
        for (uint32_t k = 0; k < N; k++) {
            size_t q = (size_t)j * N + k;
            double u = ((double)j + rnd(r)) / M;
            double st = sqrt(u), ct = sqrt(1.0 - u);
            double ph = 2.0 * M_PI * ((double)k + rnd(r)) / N;
            rad_vec3 wi = rad_add(rad_add(rad_scale(t1, st * cos(ph)), rad_scale(t2, st * sin(ph))),
                                  rad_scale(n, ct));
            w->theta[q] = asin(st);
            w->phi[q] = ph;
            double t = INFINITY;
            int blocked;
            uint32_t c = trace_block(g, Xo, wi, &t, &blocked);
            double *L = w->L + q * nb;
            if (c != RAD_NONE) {
                stored_radiance(g, c, along(Xo, wi, t), L);
            } else {
                for (uint32_t b = 0; b < nb; b++)
                    L[b] = 0.0;
                if (!blocked)
                    t = INFINITY;
            }
            w->dist[q] = t;
            if (isfinite(t) && t > 0.0)
                inv_sum += 1.0 / t;
            double lum = 0;
            for (uint32_t b = 0; b < nb; b++) {
                rec->H[b] += L[b];
                lum += L[b];
            }
            D = rad_add(D, rad_scale(wi, lum));
        }
    w->st.gathers++;
    w->st.gather_rays += (uint64_t)M * N;
    /* E = π/(MN) Σ L (eq. 2: cosine-weighted samples). */
    double scale = M_PI / ((double)M * N);
    for (uint32_t b = 0; b < nb; b++)
        rec->H[b] *= scale;
    double lD = rad_length(D);
    rec->D = lD > 0.0 ? rad_scale(D, 1.0 / lD) : n;
    /* R: harmonic mean distance (nothing met counts as infinitely far),
     * kept between the minimum radius in pixels and the scene's size. */
    double R = inv_sum > 0.0 ? (double)M * N / inv_sum : g->diag;
    rec->R = fmin(R, g->diag);
    /* The gradients are computed even when they are not interpolated: they
     * bound R (limit_radius). */
    gradients(w, rec, t1, t2);
    limit_radius(g, rec, footprint);
    if (!g->gradients)
        for (uint32_t b = 0; b < nb; b++)
            rec->gt[b] = rec->gr[b] = rad_v3(0, 0, 0);
}

/* Indirect irradiance at X into H and its light vector into *D: from the
 * cache when some record is valid, else a new gather (stored while the
 * cache is being filled). */
static int indirect(worker *w, rng *r, rad_vec3 X, rad_vec3 n, double footprint, double *H,
                    rad_vec3 *D)
{
    run *g = w->g;
    /* Counted in the shading pass only (pass 1 visits the same points). */
    w->st.shading_points += !g->filling;
    if (g->cached && rn_icache_lookup(g->cache, X, n, g->eps, !g->gradients, H, D)) {
        w->st.cache_hits += !g->filling;
        return RAD_OK;
    }
    rn_record rec;
    gather(w, r, X, n, footprint, &rec);
    for (uint32_t b = 0; b < g->nb; b++)
        H[b] = rec.H[b];
    *D = rec.D;
    if (g->cached && g->filling)
        return rn_icache_insert(g->cache, &rec, g->err);
    return RAD_OK;
}

/* ------------------------------------------------------------ shade */

/* Radiance along the ray org + t·dir (unit dir) into L[bands]; *cell_out
 * gets the cell seen (may be NULL).  fill_only: pass 1, only the cache's
 * shading points are visited. */
static int shade(worker *w, rng *r, rad_vec3 org, rad_vec3 dir, double tnear, uint32_t depth,
                 double path, int fill_only, double *L, uint32_t *cell_out)
{
    const run *g = w->g;
    const rn_scene *sc = g->sc;
    uint32_t nb = g->nb;
    for (uint32_t b = 0; b < nb; b++)
        L[b] = 0.0;
    double t;
    uint32_t c = trace_view(g, org, dir, tnear, &t);
    if (cell_out)
        *cell_out = c;
    if (c == RAD_NONE)
        return RAD_OK;
    rad_vec3 X = along(org, dir, t), n = sc->mesh->patches[c].normal;
    path += t;
    const double *rho = sc->rho + (size_t)c * nb;
    const rn_material *mt = &sc->materials[sc->mesh->patches[c].material];
    int diffuse = 0, glossy = 0;
    for (uint32_t b = 0; b < nb; b++) {
        diffuse |= rho[b] > 0.0;
        glossy |= mt->specular[b] > 0.0;
    }
    int mirror = glossy && mt->roughness < RN_MIRROR_ROUGHNESS;
    int lv = glossy && !mirror &&
             (g->glossy == RN_GLOSSY_LIGHT_VECTOR ||
              (g->glossy == RN_GLOSSY_AUTO && mt->roughness >= RN_LIGHT_VECTOR_ROUGHNESS));
    double alpha = glossy && !mirror ? mt->roughness * mt->roughness : 0.0;
    rad_vec3 wo = rad_scale(dir, -1.0);

    double Hi[RAD_MAX_BANDS] = {0};
    rad_vec3 D = n;
    if (diffuse || lv) {
        int rc = indirect(w, r, X, n, path / g->k, Hi, &D);
        if (rc)
            return rc;
    }
    double Lm[RAD_MAX_BANDS] = {0};
    if (mirror && depth < g->max_depth) {
        w->st.glossy_rays++;
        rad_vec3 rd = rad_sub(dir, rad_scale(n, 2.0 * rad_dot(dir, n)));
        int rc = shade(w, r, along(X, n, g->off), rad_normalize(rd), 0.0, depth + 1, path,
                       fill_only, Lm, NULL);
        if (rc)
            return rc;
    }
    if (fill_only)
        return RAD_OK;

    double Hd[RAD_MAX_BANDS], Sd[RAD_MAX_BANDS];
    direct_light(w, r, X, n, wo, alpha, Hd, Sd);
    const double *E = sc->emission + (size_t)c * nb;
    const double *T = sc->transmitted ? sc->transmitted + (size_t)c * nb : NULL;
    for (uint32_t b = 0; b < nb; b++)
        L[b] = (E[b] + (T ? T[b] : 0.0)) / M_PI + rho[b] / M_PI * (Hd[b] + Hi[b]);
    if (!glossy)
        return RAD_OK;
    if (mirror) {
        for (uint32_t b = 0; b < nb; b++)
            L[b] += mt->specular[b] * Lm[b];
        return RAD_OK;
    }
    double Ls[RAD_MAX_BANDS];
    for (uint32_t b = 0; b < nb; b++)
        Ls[b] = Sd[b];
    if (lv) {
        /* Zaninetti & Péroche: the indirect light as one virtual source of
         * irradiance H from the light vector's direction D. */
        double f = ward_lobe(n, D, wo, alpha);
        for (uint32_t b = 0; b < nb; b++)
            Ls[b] += f * Hi[b];
    } else {
        rad_vec3 Xo = along(X, n, g->off);
        double acc[RAD_MAX_BANDS] = {0}, Lh[RAD_MAX_BANDS];
        for (uint32_t sy = 0; sy < g->gs; sy++)
            for (uint32_t sx = 0; sx < g->gs; sx++) {
                rad_vec3 wi;
                double wt = ward_sample(n, wo, alpha, ((double)sx + rnd(r)) / g->gs,
                                        ((double)sy + rnd(r)) / g->gs, &wi);
                if (!(wt > 0.0))
                    continue;
                w->st.glossy_rays++;
                double th;
                int blocked;
                uint32_t h = trace_block(g, Xo, wi, &th, &blocked);
                if (h == RAD_NONE)
                    continue;
                stored_radiance(g, h, along(Xo, wi, th), Lh);
                for (uint32_t b = 0; b < nb; b++)
                    acc[b] += wt * Lh[b];
            }
        for (uint32_t b = 0; b < nb; b++)
            Ls[b] += acc[b] / ((double)g->gs * g->gs);
    }
    for (uint32_t b = 0; b < nb; b++)
        L[b] += mt->specular[b] * Ls[b];
    return RAD_OK;
}

/* ----------------------------------------------------------- passes */

typedef struct pass2 {
    run *g;
    const rn_frame *fr;
    rn_image *img;
    atomic_uint_fast64_t next_row;
    atomic_uint_fast64_t rows_done;
} pass2;

/* The primary ray of pixel (i, j): from the eye along f + a·r + b·u, or for
 * an orthographic view from eye + a·r + b·u along f (rn_frame). */
static rad_vec3 pixel_ray(const rn_frame *fr, uint32_t i, uint32_t j, rad_vec3 *origin)
{
    double a = ((double)i + 0.5 - fr->cx) / fr->k, b = (fr->cy - (double)j - 0.5) / fr->k;
    rad_vec3 off = rad_add(rad_scale(fr->r, a), rad_scale(fr->u, b));
    if (fr->ortho) {
        *origin = rad_add(fr->eye, off);
        return fr->f;
    }
    *origin = fr->eye;
    return rad_normalize(rad_add(fr->f, off));
}

static int worker_init(worker *w, run *g)
{
    memset(w, 0, sizeof *w);
    w->g = g;
    size_t n = (size_t)g->M * g->N;
    w->L = malloc(n * g->nb * sizeof *w->L);
    w->dist = malloc(n * sizeof *w->dist);
    w->theta = malloc(n * sizeof *w->theta);
    w->phi = malloc(n * sizeof *w->phi);
    return w->L && w->dist && w->theta && w->phi ? 0 : -1;
}

static void worker_free(worker *w)
{
    free(w->L);
    free(w->dist);
    free(w->theta);
    free(w->phi);
}

typedef struct thread_arg {
    pass2 *p;
    worker w;
    int id;
    void (*progress)(void *, uint64_t, uint64_t);
    void *progress_user;
    uint64_t base, total; /* progress: work before this pass, and in all */
} thread_arg;

static void *shade_rows(void *arg)
{
    thread_arg *ta = arg;
    pass2 *p = ta->p;
    run *g = p->g;
    const rn_frame *fr = p->fr;
    uint32_t nb = g->nb;
    for (;;) {
        if (atomic_load(&g->stop))
            break;
        uint64_t j = atomic_fetch_add(&p->next_row, 1);
        if (j >= fr->h)
            break;
        for (uint32_t i = 0; i < fr->w; i++) {
            size_t k = (size_t)j * fr->w + i;
            rng r = pixel_rng(k, 2);
            double L[RAD_MAX_BANDS];
            uint32_t cell;
            /* Pass 2 never stores a record, so shading cannot fail. */
            rad_vec3 o, d = pixel_ray(fr, i, (uint32_t)j, &o);
            int rc = shade(&ta->w, &r, o, d, 0.0, 0, 0.0, 0, L,
                           &cell);
            RAD_ASSERT(rc == RAD_OK);
            (void)rc;
            p->img->patch[k] = cell;
            for (uint32_t b = 0; b < nb; b++)
                p->img->pixels[k * nb + b] = (float)L[b];
        }
        uint64_t done = atomic_fetch_add(&p->rows_done, 1) + 1;
        if (ta->id == 0 && ta->progress)
            ta->progress(ta->progress_user, ta->base + done * fr->w, ta->total);
    }
    return NULL;
}

/* Pass 1: Ward's secondary method at every pixel's shading points, coarse
 * to fine, creating records where none is valid. */
static int fill_cache(run *g, worker *w, const rn_frame *fr, const rn_gather_options *opt,
                      uint64_t total)
{
    g->filling = 1;
    uint64_t done = 0;
    for (int stride = 16; stride >= 1; stride /= 2) {
        for (uint32_t j = 0; j < fr->h; j += (uint32_t)stride) {
            for (uint32_t i = 0; i < fr->w; i += (uint32_t)stride) {
                /* Visited at a coarser stride already. */
                if (stride < 16 && (i % (2u * stride)) == 0 && (j % (2u * stride)) == 0)
                    continue;
                rng r = pixel_rng((uint64_t)j * fr->w + i, 1);
                double L[RAD_MAX_BANDS];
                rad_vec3 o, d = pixel_ray(fr, i, j, &o);
                int rc = shade(w, &r, o, d, 0.0, 0, 0.0, 1, L, NULL);
                if (rc) {
                    g->filling = 0;
                    return rc;
                }
                done++;
            }
            if (opt && opt->progress)
                opt->progress(opt->progress_user, done, total);
        }
    }
    g->filling = 0;
    return RAD_OK;
}

static void add_stats(rn_gather_stats *a, const rn_gather_stats *b)
{
    a->shading_points += b->shading_points;
    a->gathers += b->gathers;
    a->gather_rays += b->gather_rays;
    a->cache_hits += b->cache_hits;
    a->shadow_rays += b->shadow_rays;
    a->glossy_rays += b->glossy_rays;
}

/* Pass 2: shading, rows handed out to `threads` threads, this one among
 * them.  Thread 0 takes over w0, whose counters carry pass 1's (*w0_ok is
 * cleared then; until then w0 is the caller's to free); every thread's
 * counters are added to *st.  Progress counts from `base` of `total`. */
static int shade_pass(run *g, const rn_frame *fr, rn_image *img, const rn_gather_options *opt,
                      uint32_t threads, uint64_t base, uint64_t total, worker *w0, int *w0_ok,
                      rn_gather_stats *st, rad_error *err)
{
    thread_arg *ta = calloc(threads, sizeof *ta);
    if (!ta)
        return rad_fail(err, RAD_ERR_NOMEM, "render: gather: out of memory");
    int rc = RAD_OK;
    pass2 p = {.g = g, .fr = fr, .img = img};
    atomic_init(&p.next_row, 0);
    atomic_init(&p.rows_done, 0);
    atomic_init(&g->stop, 0);
    pthread_t tid[64];
    uint32_t started = 0;
    for (uint32_t t = 0; t < threads && !rc; t++) {
        ta[t].p = &p;
        ta[t].id = (int)t;
        ta[t].progress = opt ? opt->progress : NULL;
        ta[t].progress_user = opt ? opt->progress_user : NULL;
        ta[t].base = base;
        ta[t].total = total;
        if (t == 0) {
            ta[t].w = *w0; /* its counters carry pass 1's */
            *w0_ok = 0;
        } else if (worker_init(&ta[t].w, g)) {
            worker_free(&ta[t].w);
            rc = rad_fail(err, RAD_ERR_NOMEM, "render: gather: out of memory");
            break;
        }
        if (t > 0 && pthread_create(&tid[t], NULL, shade_rows, &ta[t]) != 0) {
            worker_free(&ta[t].w);
            rc = rad_fail(err, RAD_ERR_NOMEM, "render: gather: cannot start thread %u", t);
            break;
        }
        started = t + 1;
    }
    if (!rc && started)
        shade_rows(&ta[0]);
    else
        atomic_store(&g->stop, 1);
    for (uint32_t t = 1; t < started; t++)
        pthread_join(tid[t], NULL);
    for (uint32_t t = 0; t < started; t++) {
        add_stats(st, &ta[t].w.st);
        worker_free(&ta[t].w);
    }
    free(ta);
    return rc;
}

int rn_gather(const rn_scene *sc, const rn_camera *cam, const rn_gather_options *opt,
              rn_icache *cache, rn_image **out, rn_gather_stats *stats, rad_error *err)
{
    if (!out)
        return rad_fail(err, RAD_ERR_USAGE, "render: gather: no output pointer");
    *out = NULL;
    double t0 = rad_seconds();
    int rc = check_scene(sc, err);
    if (rc)
        return rc;
    rn_frame fr;
    memset(&fr, 0, sizeof fr);
    if ((rc = rn_camera_frame(cam, &fr, err)))
        return rc;
    uint32_t threads = opt && opt->threads ? opt->threads : 1;
    if (threads > 64)
        return rad_fail(err, RAD_ERR_USAGE, "render: gather: %u threads (at most 64)", threads);
    if (cache && (rn_icache_key(cache) != rn_gather_key(sc, opt) ||
                  rn_icache_bands(cache) != sc->bands))
        return rad_fail(err, RAD_ERR_USAGE,
                        "render: gather: the cache was made for another scene or settings");

    run g;
    rc = run_setup(&g, sc, opt, err);
    rn_icache *own = NULL;
    if (!rc && g.cached && !cache) {
        rc = rn_icache_create(rn_gather_key(sc, opt), sc->bands, &own, err);
        cache = own;
    }
    g.cache = cache;
    g.k = fr.k;
    rn_image *img = NULL;
    if (!rc) {
        img = rn_image_alloc(fr.w, fr.h, sc->bands);
        if (!img)
            rc = rad_fail(err, RAD_ERR_NOMEM, "render: gather: out of memory for a %ux%u image",
                          fr.w, fr.h);
    }
    rn_gather_stats st;
    memset(&st, 0, sizeof st);
    st.pixels = (uint64_t)fr.w * fr.h;
    if (!rc && g.cached) {
        st.records_loaded = rn_icache_size(cache);
        settings set;
        resolve_settings(opt, &set);
        rn_icache_settle(cache, set.eps, set.rays, set.gradients, set.min_radius_px);
        rc = rn_icache_prepare(cache, g.lo, g.hi, g.eps, err);
    }
    uint64_t total = st.pixels * (g.cached ? 2u : 1u);
    worker w0;
    int w0_ok = 0;
    if (!rc) {
        w0_ok = worker_init(&w0, &g) == 0;
        if (!w0_ok)
            rc = rad_fail(err, RAD_ERR_NOMEM, "render: gather: out of memory");
    }
    if (!rc && g.cached)
        rc = fill_cache(&g, &w0, &fr, opt, total);

    if (!rc)
        rc = shade_pass(&g, &fr, img, opt, threads, g.cached ? st.pixels : 0, total, &w0, &w0_ok,
                        &st, err);
    if (w0_ok) {
        add_stats(&st, &w0.st);
        worker_free(&w0);
    }
    if (!rc && g.cached) {
        st.records = rn_icache_size(cache);
        rn_icache_count_run(cache, st.gathers);
    }
    run_free(&g);
    rn_icache_destroy(own);
    st.seconds = rad_seconds() - t0;
    if (stats)
        *stats = st;
    if (rc) {
        rn_image_destroy(img);
        return rc;
    }
    *out = img;
    return RAD_OK;
}
