/* gather_scene.c - what the final gather needs from a solution, and the
 * one call that renders a view with it: the plain-data rn_scene the gather
 * renderer (render/final_gather.c) reads, built here so that the renderer never
 * sees form factors, and Ward's cache file beside the solution.
 *
 * Invariant of a rad_gather_scene: its cells and vertex radiosities are
 * exactly what rad_render_solution draws (same mesh, same
 * rad_elements_vertex_radiosity), so the two renderers read one field of B;
 * every per-cell value is its patch's as solved (s->rho, s->emission).
 */
#include "pipeline.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void rad_gather_scene_destroy(rad_gather_scene *g)
{
    if (!g)
        return;
    free(g->cell_patch);
    rad_mesh_destroy(g->cells_);
    free(g->vertex_B_);
    free(g->rho_);
    free(g->emission_);
    free(g->transmitted_);
    free(g->materials_);
    free(g->emitters_);
    free(g->lights_);
    free(g);
}

/* A fan cell for the twin search: its centroid on a fine grid. */
typedef struct fan_key {
    int64_t q[3];
    uint32_t cell;
} fan_key;

static int fan_cmp(const void *a, const void *b)
{
    const fan_key *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x->q[k] != y->q[k])
            return x->q[k] < y->q[k] ? -1 : 1;
    return x->cell < y->cell ? -1 : x->cell > y->cell;
}

/* The elements' fans on a transmitting sheet get twin links (the fan cell
 * on the other side over the same triangle), so that the gather sees a
 * sheet's facing side; fan meshes are built without them.  A cell whose
 * other side is split differently keeps none. */
static int link_fan_twins(rad_mesh *m, const rad_scene *sc, rad_error *err)
{
    uint32_t n = m->patch_count, count = 0;
    for (uint32_t c = 0; c < n; c++)
        count += rad_material_transmits(&sc->materials[m->patches[c].material], sc->band_count);
    if (!count)
        return RAD_OK;
    fan_key *k = malloc((size_t)count * sizeof *k);
    m->twin = malloc((size_t)n * sizeof *m->twin);
    if (!k || !m->twin) {
        free(k);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", sc->source);
    }
    rad_vec3 lo, hi;
    rad_scene_bounds(sc, &lo, &hi);
    double grid = 1e-9 * (rad_length(rad_sub(hi, lo)) + 1e-300);
    uint32_t q = 0;
    for (uint32_t c = 0; c < n; c++) {
        m->twin[c] = RAD_NONE;
        const rad_patch *p = &m->patches[c];
        if (!rad_material_transmits(&sc->materials[p->material], sc->band_count))
            continue;
        rad_vec3 s = rad_v3(0, 0, 0);
        int nc = rad_patch_corners(p);
        for (int v = 0; v < nc; v++)
            s = rad_add(s, m->vertices[p->v[v]]);
        s = rad_scale(s, 1.0 / nc);
        k[q++] = (fan_key){{llround(s.x / grid), llround(s.y / grid), llround(s.z / grid)}, c};
    }
    qsort(k, count, sizeof *k, fan_cmp);
    for (uint32_t i = 0; i + 1 < count; i++) {
        uint32_t a = k[i].cell, b = k[i + 1].cell;
        if (memcmp(k[i].q, k[i + 1].q, sizeof k[i].q) == 0 &&
            rad_dot(m->patches[a].normal, m->patches[b].normal) < -0.999) {
            m->twin[a] = b;
            m->twin[b] = a;
            i++;
        }
    }
    free(k);
    return RAD_OK;
}

/* The emitting polygons: those whose (front) patches emit, with their
 * area-weighted E as solved. */
static int build_emitters(const rad_solution *s, rad_gather_scene *g, rad_error *err)
{
    const rad_scene *sc = s->scene;
    const uint32_t nb = s->band_count, np = sc->polygon_count;
    double *E = calloc((size_t)np * nb + 1, sizeof *E), *A = calloc((size_t)np + 1, sizeof *A);
    g->emitters_ = calloc((size_t)np + 1, sizeof *g->emitters_);
    if (!E || !A || !g->emitters_) {
        free(E);
        free(A);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", sc->source);
    }
    for (uint32_t p = 0; p < s->mesh->patch_count; p++) {
        const rad_patch *pa = &s->mesh->patches[p];
        const rad_polygon *poly = &sc->polygons[pa->polygon];
        if (rad_dot(pa->normal, poly->normal) <= 0.0)
            continue; /* a sheet's back twin: same E, counted once */
        A[pa->polygon] += pa->area;
        for (uint32_t b = 0; b < nb; b++)
            E[(size_t)pa->polygon * nb + b] += pa->area * s->emission[(size_t)p * nb + b];
    }
    uint32_t count = 0;
    for (uint32_t i = 0; i < np; i++) {
        if (!rad_any_positive(E + (size_t)i * nb, nb) || !(A[i] > 0.0))
            continue;
        const rad_polygon *poly = &sc->polygons[i];
        rn_emitter *em = &g->emitters_[count++];
        em->points = sc->points + poly->first_point;
        em->count = poly->point_count;
        em->normal = poly->normal;
        em->two_sided = rad_material_transmits(&sc->materials[poly->material], nb);
        for (uint32_t b = 0; b < nb; b++)
            em->E[b] = E[(size_t)i * nb + b] / A[i];
    }
    free(E);
    free(A);
    g->scene.emitters = g->emitters_;
    g->scene.emitter_count = count;
    return RAD_OK;
}

int rad_gather_scene_create(const rad_solution *s, rad_gather_scene **out, rad_error *err)
{
    *out = NULL;
    if (!s || !s->scene || !s->mesh)
        return rad_fail(err, RAD_ERR_USAGE, "gather: no solution");
    rad_gather_scene *g = calloc(1, sizeof *g);
    if (!g)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    const rad_scene *sc = s->scene;
    const uint32_t nb = s->band_count;
    const rad_mesh *mesh = s->mesh;
    uint32_t *cells_of = NULL;
    int rc = RAD_OK;
    if (s->elements) {
        if ((rc = rad_elements_render_mesh(s->elements, &g->cells_, &cells_of, err)))
            goto fail;
        if ((rc = link_fan_twins(g->cells_, sc, err)))
            goto fail;
        mesh = g->cells_;
    }
    const uint32_t nc = mesh->patch_count;
    g->cell_patch = malloc(((size_t)nc + 1) * sizeof *g->cell_patch);
    g->vertex_B_ = malloc(((size_t)mesh->vertex_count * nb + 1) * sizeof *g->vertex_B_);
    g->rho_ = malloc(((size_t)nc * nb + 1) * sizeof *g->rho_);
    g->emission_ = malloc(((size_t)nc * nb + 1) * sizeof *g->emission_);
    g->materials_ = calloc((size_t)sc->material_count + 1, sizeof *g->materials_);
    g->lights_ = calloc((size_t)sc->light_count + 1, sizeof *g->lights_);
    if (!g->cell_patch || !g->vertex_B_ || !g->rho_ || !g->emission_ || !g->materials_ ||
        !g->lights_) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for the gather", sc->source);
        goto fail;
    }
    if ((rc = rad_elements_vertex_radiosity(s, s->elements, mesh, cells_of, NULL, g->vertex_B_,
                                            err)))
        goto fail;
    double *T = NULL;
    if ((rc = rad_elements_transmitted(s, &T, err)))
        goto fail;
    if (T) {
        g->transmitted_ = malloc(((size_t)nc * nb + 1) * sizeof *g->transmitted_);
        if (!g->transmitted_) {
            free(T);
            rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for the gather", sc->source);
            goto fail;
        }
    }
    for (uint32_t c = 0; c < nc; c++) {
        uint32_t p = cells_of ? s->elements->patch[cells_of[c]] : c;
        g->cell_patch[c] = p;
        memcpy(g->rho_ + (size_t)c * nb, s->rho + (size_t)p * nb, nb * sizeof(double));
        memcpy(g->emission_ + (size_t)c * nb, s->emission + (size_t)p * nb, nb * sizeof(double));
        if (T)
            memcpy(g->transmitted_ + (size_t)c * nb, T + (size_t)p * nb, nb * sizeof(double));
    }
    free(T);
    for (uint32_t i = 0; i < sc->material_count; i++) {
        memcpy(g->materials_[i].specular, sc->materials[i].specular, sizeof g->materials_[i].specular);
        g->materials_[i].roughness = sc->materials[i].roughness;
    }
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const rad_light *L = &sc->lights[l];
        rn_light *o = &g->lights_[l];
        o->kind = L->kind == RAD_LIGHT_SPOT          ? RN_LIGHT_SPOT
                  : L->kind == RAD_LIGHT_DIRECTIONAL ? RN_LIGHT_DIRECTIONAL
                                                     : RN_LIGHT_POINT;
        for (uint32_t b = 0; b < nb; b++)
            o->I[b] = s->light_intensity ? s->light_intensity[(size_t)l * nb + b] : L->intensity[b];
        o->position = L->position;
        o->direction = L->direction;
        o->inner_cone = L->inner_cone;
        o->outer_cone = L->outer_cone;
    }
    if ((rc = build_emitters(s, g, err)))
        goto fail;
    g->scene.mesh = mesh;
    g->scene.bands = nb;
    g->scene.vertex_B = g->vertex_B_;
    g->scene.rho = g->rho_;
    g->scene.emission = g->emission_;
    g->scene.transmitted = g->transmitted_;
    g->scene.materials = g->materials_;
    g->scene.material_count = sc->material_count;
    g->scene.lights = g->lights_;
    g->scene.light_count = sc->light_count;
    free(cells_of);
    *out = g;
    return RAD_OK;
fail:
    free(cells_of);
    rad_gather_scene_destroy(g);
    return rc;
}

void rad_gather_cache_path(const char *solution_path, char *buf, size_t size)
{
    snprintf(buf, size, "%s.icache", solution_path);
}

int rad_render_gather(const rad_solution *s, const rn_camera *cam, const rad_gather_options *opt,
                      rn_image **out, rn_gather_stats *stats, rad_error *err)
{
    static const rad_gather_options defaults;
    if (!opt)
        opt = &defaults;
    *out = NULL;
    rad_gather_scene *g = NULL;
    int rc = rad_gather_scene_create(s, &g, err);
    if (rc)
        return rc;
    const rn_gather_options *ro = &opt->render;
    rn_icache *cache = NULL;
    if (!ro->no_cache) {
        uint64_t key = rn_gather_key(&g->scene, ro);
        rad_error sub = {0};
        if (opt->cache_path) {
            int r = rn_icache_read(opt->cache_path, key, &cache, &sub);
            if (r == RAD_ERR_NOMEM) {
                rad_gather_scene_destroy(g);
                if (err)
                    *err = sub;
                return r;
            }
            /* A missing file is the usual first run; anything else is said. */
            if (r && r != RAD_ERR_IO)
                rad_warn(opt->warn, opt->warn_user, "%s; computing the cache anew", sub.message);
        }
        if (!cache && (rc = rn_icache_create(key, g->scene.bands, &cache, err))) {
            rad_gather_scene_destroy(g);
            return rc;
        }
    }
    rc = rn_gather(&g->scene, cam, ro, cache, out, stats, err);
    if (!rc) {
        /* The image names patches, whatever cells were drawn. */
        uint32_t *id = (*out)->patch;
        for (size_t q = 0; q < (size_t)(*out)->width * (*out)->height; q++)
            if (id[q] != RAD_NONE)
                id[q] = g->cell_patch[id[q]];
    }
    if (!rc && cache && opt->cache_path)
        rc = rn_icache_write(cache, opt->cache_path, err);
    if (rc) {
        rn_image_destroy(*out);
        *out = NULL;
    }
    rn_icache_destroy(cache);
    rad_gather_scene_destroy(g);
    return rc;
}
