/* scene.c - building and checking a scene (scene.h).
 *
 * Every material, object, polygon and camera enters the scene through an
 * add function here, which refuses anything that would break the invariants
 * the later stages rely on: polygons planar, convex, of positive area and
 * wound counter-clockwise about their normal (the Newell normal, so the file's
 * winding decides which side is lit); 0 <= ρ < 1 and E >= 0 in every band;
 * unique non-empty names; punctual lights finite, of non-negative
 * intensity, with unit directions and valid cones.  Once added, an element is
 * never changed, except that a polygon may be given a reflectance of its own
 * (rad_scene_set_polygon_rho), under the same rules as a material's, and
 * texture coordinates (rad_scene_set_polygon_uv, finite).  Images enter
 * only as PNG or JPEG whose bytes start with that format's signature, and a
 * material has at most one texture, whose indices exist.
 *
 * Also holds the private name set (scene_internal.h) that keeps the
 * uniqueness checks linear in the number of names.
 */
#include "scene.h"
#include "scene_internal.h"

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------- name set */

static uint64_t hash_name(const char *s)
{
    uint64_t h = 1469598103934665603ull; /* FNV-1a: cheap and good enough for names */
    for (; *s; s++) {
        h ^= (unsigned char)*s;
        h *= 1099511628211ull;
    }
    return h;
}

uint32_t rad_names_find(const rad_names *set, const char *key)
{
    if (!set || !set->cap || !key)
        return RAD_NONE;
    uint32_t mask = set->cap - 1;
    uint32_t i = (uint32_t)(hash_name(key) & mask);
    for (;;) {
        const rad_names_slot *sl = &set->slot[i];
        if (!sl->key)
            return RAD_NONE;
        if (strcmp(sl->key, key) == 0)
            return sl->value;
        i = (i + 1) & mask;
    }
}

static void names_put(rad_names_slot *slot, uint32_t cap, const char *key, uint32_t value)
{
    uint32_t mask = cap - 1;
    uint32_t i = (uint32_t)(hash_name(key) & mask);
    while (slot[i].key)
        i = (i + 1) & mask;
    slot[i].key = key;
    slot[i].value = value;
}

int rad_names_insert(rad_names *set, const char *key, uint32_t value)
{
    /* Keep the load below 3/4 so that probing stays short and a free slot
     * always exists. */
    if ((uint64_t)(set->used + 1) * 4 > (uint64_t)set->cap * 3) {
        if (set->cap >= 0x80000000u)
            return -1;
        uint32_t cap = set->cap ? set->cap * 2 : 16;
        rad_names_slot *slot = calloc(cap, sizeof *slot);
        if (!slot)
            return -1;
        for (uint32_t k = 0; k < set->cap; k++)
            if (set->slot[k].key)
                names_put(slot, cap, set->slot[k].key, set->slot[k].value);
        free(set->slot);
        set->slot = slot;
        set->cap = cap;
    }
    names_put(set->slot, set->cap, key, value);
    set->used++;
    return 0;
}

void rad_names_free(rad_names *set)
{
    if (!set)
        return;
    free(set->slot);
    set->slot = NULL;
    set->cap = set->used = 0;
}

/* The scene's three indexes.  An index is trusted only while its size equals
 * the array's count; otherwise it is rebuilt (or, in the const find
 * functions, bypassed by a linear scan). */
typedef struct scene_names {
    rad_names material, object, camera, light;
} scene_names;

static scene_names *names_of(rad_scene *s)
{
    if (!s->names_)
        s->names_ = calloc(1, sizeof(scene_names));
    return s->names_;
}

/* Name of element k of an array of structs whose `char *name` sits at `off`. */
static const char *name_at(const void *base, size_t stride, size_t off, uint32_t k)
{
    const char *const *p = (const char *const *)((const char *)base + (size_t)k * stride + off);
    return *p;
}

static int names_sync(rad_names *set, const void *base, size_t stride, size_t off,
                      uint32_t count)
{
    if (set->used == count)
        return 0;
    rad_names_free(set);
    for (uint32_t k = 0; k < count; k++) {
        const char *n = name_at(base, stride, off, k);
        if (n && rad_names_insert(set, n, k) != 0) {
            rad_names_free(set);
            return -1;
        }
    }
    return set->used == count ? 0 : -1;
}

static uint32_t find_named(const rad_scene *s, const rad_names *set, const void *base,
                           size_t stride, size_t off, uint32_t count, const char *name)
{
    if (!s || !name)
        return RAD_NONE;
    if (set && set->used == count && count > 0)
        return rad_names_find(set, name);
    for (uint32_t k = 0; k < count; k++) {
        const char *n = name_at(base, stride, off, k);
        if (n && strcmp(n, name) == 0)
            return k;
    }
    return RAD_NONE;
}

uint32_t rad_scene_find_material(const rad_scene *s, const char *name)
{
    const scene_names *nm = s ? s->names_ : NULL;
    return find_named(s, nm ? &nm->material : NULL, s ? s->materials : NULL,
                      sizeof(rad_material), offsetof(rad_material, name),
                      s ? s->material_count : 0, name);
}

uint32_t rad_scene_find_object(const rad_scene *s, const char *name)
{
    const scene_names *nm = s ? s->names_ : NULL;
    return find_named(s, nm ? &nm->object : NULL, s ? s->objects : NULL, sizeof(rad_object),
                      offsetof(rad_object, name), s ? s->object_count : 0, name);
}

uint32_t rad_scene_find_light(const rad_scene *s, const char *name)
{
    const scene_names *nm = s ? s->names_ : NULL;
    return find_named(s, nm ? &nm->light : NULL, s ? s->lights : NULL, sizeof(rad_light),
                      offsetof(rad_light, name), s ? s->light_count : 0, name);
}

uint32_t rad_scene_find_camera(const rad_scene *s, const char *name)
{
    const scene_names *nm = s ? s->names_ : NULL;
    return find_named(s, nm ? &nm->camera : NULL, s ? s->cameras : NULL, sizeof(rad_camera),
                      offsetof(rad_camera, name), s ? s->camera_count : 0, name);
}

/* ------------------------------------------------------------------ helpers */

static const char *source_of(const rad_scene *s)
{
    return s && s->source ? s->source : "<memory>";
}

/* "SOURCE: WHERE: WHAT", or "SOURCE: WHAT" when the caller gave no where. */
static int failf(rad_error *err, const rad_scene *s, int code, const char *where,
                 const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;
static int failf(rad_error *err, const rad_scene *s, int code, const char *where,
                 const char *fmt, ...)
{
    char what[900];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    if (where && *where)
        return rad_fail(err, code, "%s: %s: %s", source_of(s), where, what);
    return rad_fail(err, code, "%s: %s", source_of(s), what);
}

/* "kind 'name': " to put before WHAT, or "" when `where` already names the
 * element (a glTF loader passes where = "polygon 'x'"), so it is not said twice. */
static const char *element(char *buf, size_t size, const char *kind, const char *name,
                           const char *where)
{
    snprintf(buf, size, "%s '%s'", kind, name ? name : "");
    if (where && strstr(where, buf))
        return "";
    size_t len = strlen(buf);
    if (len + 2 < size) {
        buf[len] = ':';
        buf[len + 1] = ' ';
        buf[len + 2] = '\0';
    }
    return buf;
}

/* " in band 2 (B)" for multi-band scenes, "" for grey ones. */
static const char *band_label(char *buf, size_t size, const rad_scene *s, uint32_t b)
{
    if (s->band_count <= 1) {
        buf[0] = '\0';
    } else if (s->band_names[b]) {
        snprintf(buf, size, " in band %u (%s)", b, s->band_names[b]);
    } else {
        snprintf(buf, size, " in band %u", b);
    }
    return buf;
}

/* Grows *arr to hold `need` elements; capacities double so that n adds cost O(n). */
static int grow(void **arr, uint32_t *cap, uint64_t need, size_t elem)
{
    if (need <= *cap)
        return 0;
    if (need > UINT32_MAX)
        return -1;
    uint64_t c = *cap ? *cap : 8;
    while (c < need)
        c *= 2;
    if (c > UINT32_MAX)
        c = UINT32_MAX;
    if (c > SIZE_MAX / elem)
        return -1;
    void *p = realloc(*arr, (size_t)c * elem);
    if (!p)
        return -1;
    *arr = p;
    *cap = (uint32_t)c;
    return 0;
}

/* -------------------------------------------------------------- lifecycle */

rad_scene *rad_scene_create(uint32_t band_count, const char *source)
{
    if (band_count < 1 || band_count > RAD_MAX_BANDS)
        return NULL;
    rad_scene *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->band_count = band_count;
    s->source = strdup(source ? source : "<memory>");
    if (!s->source) {
        free(s);
        return NULL;
    }
    return s;
}

void rad_scene_destroy(rad_scene *s)
{
    if (!s)
        return;
    for (uint32_t k = 0; k < s->material_count; k++)
        free(s->materials[k].name);
    for (uint32_t k = 0; k < s->object_count; k++)
        free(s->objects[k].name);
    for (uint32_t k = 0; k < s->polygon_count; k++)
        free(s->polygons[k].name);
    for (uint32_t k = 0; k < s->camera_count; k++)
        free(s->cameras[k].name);
    for (uint32_t k = 0; k < s->light_count; k++)
        free(s->lights[k].name);
    for (uint32_t b = 0; b < RAD_MAX_BANDS; b++)
        free(s->band_names[b]);
    scene_names *nm = s->names_;
    if (nm) {
        rad_names_free(&nm->material);
        rad_names_free(&nm->object);
        rad_names_free(&nm->camera);
        rad_names_free(&nm->light);
        free(nm);
    }
    free(s->materials);
    free(s->objects);
    free(s->polygons);
    free(s->points);
    free(s->cameras);
    free(s->lights);
    free(s->polygon_rho);
    for (uint32_t k = 0; k < s->image_count; k++) {
        free(s->images[k].mime);
        free(s->images[k].data);
    }
    free(s->images);
    free(s->textures);
    free(s->point_uv);
    free(s->source);
    free(s);
}

/* ---------------------------------------------------------------- materials */

int rad_scene_add_material(rad_scene *s, const char *name, const double *rho,
                           const double *emission, const double *transmit, const char *where,
                           uint32_t *index, rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_add_material: no scene");
    if (!name || !*name)
        return failf(err, s, RAD_ERR_INVALID, where, "a material needs a non-empty name");
    char eb[320], bb[80];
    const char *el = element(eb, sizeof eb, "material", name, where);
    scene_names *nm = names_of(s);
    if (!nm || names_sync(&nm->material, s->materials, sizeof(rad_material),
                          offsetof(rad_material, name), s->material_count) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    if (rad_names_find(&nm->material, name) != RAD_NONE)
        return failf(err, s, RAD_ERR_INVALID, where, "%sa material of this name already exists",
                     el);

    rad_material m;
    memset(&m, 0, sizeof m);
    m.roughness = 1.0; /* no lobe: pure diffuse */
    for (uint32_t b = 0; b < s->band_count; b++) {
        double r = rho ? rho[b] : 0.0;
        double e = emission ? emission[b] : 0.0;
        double t = transmit ? transmit[b] : 0.0;
        /* ρ < 1 strictly: with ρ = 1 an enclosure never reaches equilibrium
         * (the paper's diagonal dominance argument needs ρ F < 1). */
        if (!isfinite(r) || r < 0.0 || r >= 1.0)
            return failf(err, s, RAD_ERR_INVALID, where, "%sreflectance %g outside [0, 1)%s", el,
                         r, band_label(bb, sizeof bb, s, b));
        if (!isfinite(e) || e < 0.0)
            return failf(err, s, RAD_ERR_INVALID, where,
                         "%semission %g must be finite and >= 0%s", el, e,
                         band_label(bb, sizeof bb, s, b));
        if (!isfinite(t) || t < 0.0 || t >= 1.0)
            return failf(err, s, RAD_ERR_INVALID, where, "%stransmittance %g outside [0, 1)%s",
                         el, t, band_label(bb, sizeof bb, s, b));
        if (!(r + t < 1.0))
            return failf(err, s, RAD_ERR_INVALID, where,
                         "%sreflectance + transmittance = %g must be < 1%s", el, r + t,
                         band_label(bb, sizeof bb, s, b));
        m.rho[b] = r;
        m.emission[b] = e;
        m.transmit[b] = t;
    }

    if (grow((void **)&s->materials, &s->material_cap_, (uint64_t)s->material_count + 1,
             sizeof *s->materials) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%stoo many materials", el);
    m.name = strdup(name);
    if (!m.name || rad_names_insert(&nm->material, m.name, s->material_count) != 0) {
        free(m.name);
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    }
    s->materials[s->material_count] = m;
    if (index)
        *index = s->material_count;
    s->material_count++;
    return RAD_OK;
}

int rad_scene_set_material_lobe(rad_scene *s, uint32_t material, const double *specular,
                                double roughness, const char *where, rad_error *err)
{
    if (!s || material >= s->material_count || !specular)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_set_material_lobe: bad arguments");
    rad_material *m = &s->materials[material];
    char eb[320], bb[80];
    const char *el = element(eb, sizeof eb, "material", m->name, where);
    if (!(roughness >= 0.0 && roughness <= 1.0))
        return failf(err, s, RAD_ERR_INVALID, where, "%sroughness %g outside [0, 1]", el,
                     roughness);
    for (uint32_t b = 0; b < s->band_count; b++) {
        double r = specular[b];
        if (!isfinite(r) || r < 0.0)
            return failf(err, s, RAD_ERR_INVALID, where,
                         "%sspecular reflectance %g must be finite and >= 0%s", el, r,
                         band_label(bb, sizeof bb, s, b));
        /* Energy: what the surface reflects and transmits stays below 1. */
        if (!(m->rho[b] + r + m->transmit[b] < 1.0))
            return failf(err, s, RAD_ERR_INVALID, where,
                         "%sdiffuse + specular reflectance + transmittance = %g must be < 1%s",
                         el, m->rho[b] + r + m->transmit[b], band_label(bb, sizeof bb, s, b));
    }
    for (uint32_t b = 0; b < s->band_count; b++)
        m->specular[b] = specular[b];
    m->roughness = roughness;
    return RAD_OK;
}

int rad_scene_set_material_gloss(rad_scene *s, uint32_t material, double metallic,
                                 double roughness, const char *where, rad_error *err)
{
    if (!s || material >= s->material_count)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_set_material_gloss: bad arguments");
    rad_material *m = &s->materials[material];
    char eb[320];
    const char *el = element(eb, sizeof eb, "material", m->name, where);
    if (!(metallic >= 0.0 && metallic <= 1.0))
        return failf(err, s, RAD_ERR_INVALID, where, "%smetallic %g outside [0, 1]", el,
                     metallic);
    if (!(roughness >= 0.0 && roughness <= 1.0))
        return failf(err, s, RAD_ERR_INVALID, where, "%sroughness %g outside [0, 1]", el,
                     roughness);
    double spec[RAD_MAX_BANDS] = {0}, rho[RAD_MAX_BANDS];
    for (uint32_t b = 0; b < s->band_count; b++) {
        double c = m->rho[b];
        rho[b] = c;
        if (roughness < 1.0) {
            /* glTF's split: a metal reflects its base colour in the lobe, a
             * dielectric F0 there and the rest of its base colour diffusely. */
            spec[b] = RAD_DIELECTRIC_F0 * (1.0 - metallic) + metallic * c;
            rho[b] = (1.0 - metallic) * (1.0 - RAD_DIELECTRIC_F0) * c;
        }
    }
    double keep[RAD_MAX_BANDS];
    memcpy(keep, m->rho, sizeof keep);
    memcpy(m->rho, rho, sizeof rho);
    int rc = rad_scene_set_material_lobe(s, material, spec, roughness, where, err);
    if (rc)
        memcpy(m->rho, keep, sizeof keep);
    return rc;
}

/* ------------------------------------------------------------------ objects */

int rad_scene_add_object(rad_scene *s, const char *name, const char *where, uint32_t *index,
                         rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_add_object: no scene");
    if (!name || !*name)
        return failf(err, s, RAD_ERR_INVALID, where, "an object needs a non-empty name");
    char eb[320];
    const char *el = element(eb, sizeof eb, "object", name, where);
    scene_names *nm = names_of(s);
    if (!nm || names_sync(&nm->object, s->objects, sizeof(rad_object),
                          offsetof(rad_object, name), s->object_count) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    if (rad_names_find(&nm->object, name) != RAD_NONE)
        return failf(err, s, RAD_ERR_INVALID, where, "%san object of this name already exists",
                     el);
    if (grow((void **)&s->objects, &s->object_cap_, (uint64_t)s->object_count + 1,
             sizeof *s->objects) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%stoo many objects", el);
    char *copy = strdup(name);
    if (!copy || rad_names_insert(&nm->object, copy, s->object_count) != 0) {
        free(copy);
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    }
    s->objects[s->object_count].name = copy;
    if (index)
        *index = s->object_count;
    s->object_count++;
    return RAD_OK;
}

/* ----------------------------------------------------------------- polygons */

/* Checks one polygon's geometry; on success writes its unit normal and area,
 * on failure a description of the fault into why. */
static int polygon_geometry(const rad_vec3 *p, uint32_t n, rad_vec3 *normal, double *area,
                            char *why, size_t whylen)
{
    rad_vec3 lo = p[0], hi = p[0], c = rad_v3(0, 0, 0);
    for (uint32_t k = 0; k < n; k++) {
        if (!rad_finite3(p[k])) {
            snprintf(why, whylen, "point %u (%g %g %g) is not a finite number", k + 1, p[k].x,
                     p[k].y, p[k].z);
            return -1;
        }
        lo = rad_v3(fmin(lo.x, p[k].x), fmin(lo.y, p[k].y), fmin(lo.z, p[k].z));
        hi = rad_v3(fmax(hi.x, p[k].x), fmax(hi.y, p[k].y), fmax(hi.z, p[k].z));
        c = rad_add(c, p[k]);
    }
    c = rad_scale(c, 1.0 / n);
    /* The bounding-box diagonal stands for the polygon's size: within √3 of
     * its diameter, and O(n) where the diameter would be O(n²). */
    double size = rad_length(rad_sub(hi, lo));
    if (!isfinite(size) || !rad_finite3(c)) {
        snprintf(why, whylen, "coordinates too large to compute with");
        return -1;
    }

    /* Newell's normal: Σ (p_k - c) × (p_k+1 - c) is twice the vector area of
     * the outline, exact for planar polygons and the least-squares-like
     * plane normal for slightly bent ones.  Its direction follows the winding. */
    rad_vec3 N = rad_v3(0, 0, 0);
    for (uint32_t k = 0; k < n; k++) {
        rad_vec3 a = rad_sub(p[k], c), b = rad_sub(p[(k + 1) % n], c);
        N = rad_add(N, rad_cross(a, b));
    }
    double A = 0.5 * rad_length(N);
    if (!(size > 0.0) || !(A >= 1e-12 * size * size) || !isfinite(A)) {
        /* A symmetric bow tie has zero net area though its points span a
         * plane: say what is wrong with it. */
        double spread = 0.0;
        for (uint32_t k = 1; k + 1 < n; k++)
            spread = fmax(spread, 0.5 * rad_length(rad_cross(rad_sub(p[k], p[0]),
                                                             rad_sub(p[k + 1], p[0]))));
        if (size > 0.0 && spread >= 1e-12 * size * size && isfinite(spread)) {
            snprintf(why, whylen, "not convex: the outline crosses itself (zero net area)");
            return -1;
        }
        snprintf(why, whylen, "zero area (%g for a polygon %g across)", isfinite(A) ? A : 0.0,
                 size);
        return -1;
    }
    for (uint32_t k = 0; k < n; k++) {
        if (rad_length(rad_sub(p[(k + 1) % n], p[k])) <= 1e-12 * size) {
            snprintf(why, whylen, "points %u and %u coincide", k + 1, (k + 1) % n + 1);
            return -1;
        }
    }
    /* divide rather than multiply by 1/|N|: an axis-aligned polygon then
     * gets an exactly unit normal */
    double NL = rad_length(N);
    rad_vec3 nh = rad_v3(N.x / NL, N.y / NL, N.z / NL);

    double tol = 1e-4 * size, worst = 0.0;
    uint32_t worst_k = 0;
    for (uint32_t k = 0; k < n; k++) {
        double d = fabs(rad_dot(rad_sub(p[k], c), nh));
        if (d > worst) {
            worst = d;
            worst_k = k;
        }
    }
    if (worst > tol) {
        snprintf(why, whylen, "not planar: point %u is %g off the plane (tolerance %g)",
                 worst_k + 1, worst, tol);
        return -1;
    }

    /* Convex and simple: every corner turns left about the normal (collinear
     * corners, turning 0, are tolerated) and the turns add up to one full
     * revolution (a star or a folded outline turns more). */
    const double eps = 1e-6; /* radians: rounding of typed coordinates, not real dents */
    double total = 0.0;
    for (uint32_t k = 0; k < n; k++) {
        rad_vec3 e1 = rad_sub(p[k], p[(k + n - 1) % n]);
        rad_vec3 e2 = rad_sub(p[(k + 1) % n], p[k]);
        double turn = atan2(rad_dot(rad_cross(e1, e2), nh), rad_dot(e1, e2));
        if (turn < -eps) {
            snprintf(why, whylen, "not convex: the outline turns the wrong way at point %u",
                     k + 1);
            return -1;
        }
        total += turn;
    }
    if (fabs(total - 2.0 * M_PI) > 1e-6 * n) {
        snprintf(why, whylen, "not convex: the outline winds %.3g times about its normal",
                 total / (2.0 * M_PI));
        return -1;
    }
    *normal = nh;
    *area = A;
    return 0;
}

/* Room in polygon_rho (allocated when NULL) for `need` polygons; 0 or -1. */
static int polygon_rho_room(rad_scene *s, uint64_t need)
{
    if (s->polygon_rho && need <= s->polygon_rho_cap_)
        return 0;
    uint64_t cap = s->polygon_cap_ > need ? s->polygon_cap_ : need;
    if (cap > UINT32_MAX || cap * s->band_count > SIZE_MAX / sizeof(double))
        return -1;
    double *p = realloc(s->polygon_rho, (size_t)(cap * s->band_count) * sizeof *p);
    if (!p)
        return -1;
    s->polygon_rho = p;
    s->polygon_rho_cap_ = (uint32_t)cap;
    return 0;
}

int rad_scene_add_polygon(rad_scene *s, const char *name, uint32_t object, uint32_t material,
                          const rad_vec3 *points, uint32_t count, uint32_t subdiv_u,
                          uint32_t subdiv_v, const char *where, uint32_t *index, rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_add_polygon: no scene");
    const char *pname = name ? name : "";
    char eb[320], why[400];
    const char *el = element(eb, sizeof eb, "polygon", pname, where);
    if (object >= s->object_count)
        return failf(err, s, RAD_ERR_USAGE, where, "%sobject %u does not exist (%u objects)", el,
                     object, s->object_count);
    if (material >= s->material_count)
        return failf(err, s, RAD_ERR_USAGE, where, "%smaterial %u does not exist (%u materials)",
                     el, material, s->material_count);
    if (count < 3)
        return failf(err, s, RAD_ERR_INVALID, where,
                     "%s%u point%s, a polygon needs at least 3", el, count,
                     count == 1 ? "" : "s");
    if (!points)
        return failf(err, s, RAD_ERR_USAGE, where, "%sno points given", el);
    if ((uint64_t)s->point_count + count > UINT32_MAX)
        return failf(err, s, RAD_ERR_LIMIT, where, "%smore than %u points in the scene", el,
                     UINT32_MAX);
    rad_vec3 normal;
    double area;
    if (polygon_geometry(points, count, &normal, &area, why, sizeof why) != 0)
        return failf(err, s, RAD_ERR_INVALID, where, "%s%s", el, why);

    if (grow((void **)&s->polygons, &s->polygon_cap_, (uint64_t)s->polygon_count + 1,
             sizeof *s->polygons) != 0 ||
        grow((void **)&s->points, &s->point_cap_, (uint64_t)s->point_count + count,
             sizeof *s->points) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    if (s->polygon_rho && polygon_rho_room(s, (uint64_t)s->polygon_count + 1) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    if (s->point_uv && grow((void **)&s->point_uv, &s->point_uv_cap_,
                            2 * ((uint64_t)s->point_count + count), sizeof *s->point_uv) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    rad_polygon *pg = &s->polygons[s->polygon_count];
    pg->name = strdup(pname);
    if (!pg->name)
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    if (s->polygon_rho) /* until told otherwise, its material's */
        memcpy(s->polygon_rho + (size_t)s->polygon_count * s->band_count,
               s->materials[material].rho, s->band_count * sizeof(double));
    memcpy(s->points + s->point_count, points, (size_t)count * sizeof *points);
    if (s->point_uv) /* until told otherwise, (0, 0) */
        memset(s->point_uv + 2 * (size_t)s->point_count, 0, 2 * (size_t)count * sizeof(double));
    pg->first_point = s->point_count;
    pg->point_count = count;
    pg->material = material;
    pg->object = object;
    pg->subdiv_u = subdiv_u;
    pg->subdiv_v = subdiv_v;
    pg->normal = normal;
    pg->area = area;
    s->point_count += count;
    if (index)
        *index = s->polygon_count;
    s->polygon_count++;
    return RAD_OK;
}

int rad_scene_set_polygon_rho(rad_scene *s, uint32_t polygon, const double *rho,
                              const char *where, rad_error *err)
{
    if (!s || !rho)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_set_polygon_rho: no scene or no values");
    if (polygon >= s->polygon_count)
        return failf(err, s, RAD_ERR_USAGE, where, "polygon %u does not exist (%u polygons)",
                     polygon, s->polygon_count);
    const rad_polygon *pg = &s->polygons[polygon];
    const rad_material *m = &s->materials[pg->material];
    char eb[320], bb[80];
    const char *el = element(eb, sizeof eb, "polygon", pg->name, where);
    for (uint32_t b = 0; b < s->band_count; b++) {
        /* the rules of rad_scene_add_material, for the same reasons */
        if (!isfinite(rho[b]) || rho[b] < 0.0 || rho[b] >= 1.0)
            return failf(err, s, RAD_ERR_INVALID, where, "%sreflectance %g outside [0, 1)%s", el,
                         rho[b], band_label(bb, sizeof bb, s, b));
        if (!(rho[b] + m->transmit[b] < 1.0))
            return failf(err, s, RAD_ERR_INVALID, where,
                         "%sreflectance + transmittance = %g must be < 1%s", el,
                         rho[b] + m->transmit[b], band_label(bb, sizeof bb, s, b));
    }
    if (!s->polygon_rho) {
        if (polygon_rho_room(s, s->polygon_count) != 0)
            return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
        for (uint32_t p = 0; p < s->polygon_count; p++)
            memcpy(s->polygon_rho + (size_t)p * s->band_count,
                   s->materials[s->polygons[p].material].rho, s->band_count * sizeof(double));
    }
    memcpy(s->polygon_rho + (size_t)polygon * s->band_count, rho,
           s->band_count * sizeof(double));
    return RAD_OK;
}

/* ----------------------------------------------------------------- textures */

/* The signature an encoded image of this media type starts with, or NULL
 * for a type glTF does not allow. */
static const char *image_signature(const char *mime, size_t *n)
{
    if (mime && !strcmp(mime, "image/png"))
        return *n = 8, "\x89PNG\r\n\x1a\n";
    if (mime && !strcmp(mime, "image/jpeg"))
        return *n = 3, "\xff\xd8\xff";
    return NULL;
}

int rad_scene_add_image(rad_scene *s, const char *mime, const unsigned char *data,
                        uint64_t size, const char *where, uint32_t *index, rad_error *err)
{
    if (!s || (!data && size))
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_add_image: no scene or no data");
    size_t n = 0;
    const char *sig = image_signature(mime, &n);
    if (!sig)
        return failf(err, s, RAD_ERR_INVALID, where, "image type '%.40s' is not image/png or "
                     "image/jpeg", mime ? mime : "");
    if (size < n || memcmp(data, sig, n) != 0)
        return failf(err, s, RAD_ERR_INVALID, where, "image: %llu bytes that do not start as "
                     "%s does", (unsigned long long)size, mime);
    if (size > SIZE_MAX || grow((void **)&s->images, &s->image_cap_,
                                (uint64_t)s->image_count + 1, sizeof *s->images) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "image: out of memory");
    rad_image *im = &s->images[s->image_count];
    im->mime = strdup(mime);
    im->data = malloc((size_t)size);
    if (!im->mime || !im->data) {
        free(im->mime);
        free(im->data);
        return failf(err, s, RAD_ERR_NOMEM, where, "image: out of memory");
    }
    memcpy(im->data, data, (size_t)size);
    im->size = size;
    if (index)
        *index = s->image_count;
    s->image_count++;
    return RAD_OK;
}

static int wrap_ok(int w)
{
    return w == 0 || w == RAD_WRAP_REPEAT || w == RAD_WRAP_CLAMP || w == RAD_WRAP_MIRROR;
}

int rad_scene_add_texture(rad_scene *s, const rad_texture *t, const char *where, rad_error *err)
{
    if (!s || !t)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_add_texture: no scene or no texture");
    if (t->material >= s->material_count || t->image >= s->image_count)
        return failf(err, s, RAD_ERR_INVALID, where, "texture: material %u or image %u does not "
                     "exist (%u materials, %u images)", t->material, t->image,
                     s->material_count, s->image_count);
    const char *mname = s->materials[t->material].name;
    if (rad_material_texture(s, t->material))
        return failf(err, s, RAD_ERR_INVALID, where, "material '%s': a second texture", mname);
    if (!wrap_ok(t->wrap_s) || !wrap_ok(t->wrap_t) || t->mag_filter < 0 || t->min_filter < 0)
        return failf(err, s, RAD_ERR_INVALID, where, "material '%s': sampler %d %d %d %d is not "
                     "glTF's", mname, t->wrap_s, t->wrap_t, t->mag_filter, t->min_filter);
    for (int c = 0; c < 4; c++)
        if (!(t->factor[c] >= 0.0 && t->factor[c] <= 1.0))
            return failf(err, s, RAD_ERR_INVALID, where, "material '%s': baseColorFactor %g "
                         "outside [0, 1]", mname, t->factor[c]);
    if (grow((void **)&s->textures, &s->texture_cap_, (uint64_t)s->texture_count + 1,
             sizeof *s->textures) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "texture: out of memory");
    s->textures[s->texture_count++] = *t;
    return RAD_OK;
}

int rad_scene_set_polygon_uv(rad_scene *s, uint32_t polygon, const double *uv,
                             const char *where, rad_error *err)
{
    if (!s || !uv)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_set_polygon_uv: no scene or no values");
    if (polygon >= s->polygon_count)
        return failf(err, s, RAD_ERR_USAGE, where, "polygon %u does not exist (%u polygons)",
                     polygon, s->polygon_count);
    const rad_polygon *pg = &s->polygons[polygon];
    for (uint32_t k = 0; k < 2 * pg->point_count; k++)
        if (!isfinite(uv[k]))
            return failf(err, s, RAD_ERR_INVALID, where, "polygon '%s': texture coordinate %g "
                         "is not finite", pg->name, uv[k]);
    if (!s->point_uv) {
        if (grow((void **)&s->point_uv, &s->point_uv_cap_,
                 2 * (uint64_t)(s->point_cap_ ? s->point_cap_ : 1), sizeof *s->point_uv) != 0)
            return failf(err, s, RAD_ERR_NOMEM, where, "polygon '%s': out of memory", pg->name);
        memset(s->point_uv, 0, 2 * (size_t)s->point_count * sizeof *s->point_uv);
    }
    memcpy(s->point_uv + 2 * (size_t)pg->first_point, uv,
           2 * (size_t)pg->point_count * sizeof *uv);
    return RAD_OK;
}

/* ------------------------------------------------------------------ cameras */

/* A camera of either projection; the checks both share, then the one
 * each has (fov, or the window's half-sizes). */
static int add_camera(rad_scene *s, const char *name, rad_vec3 eye, rad_vec3 target,
                      rad_vec3 up, double yfov_deg, double aspect, int ortho, double xmag,
                      double ymag, const char *where, uint32_t *index, rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_add_camera: no scene");
    if (!name || !*name)
        return failf(err, s, RAD_ERR_INVALID, where, "a camera needs a non-empty name");
    char eb[320];
    const char *el = element(eb, sizeof eb, "camera", name, where);
    if (!rad_finite3(eye) || !rad_finite3(target) || !rad_finite3(up))
        return failf(err, s, RAD_ERR_INVALID, where, "%seye, target and up must be finite", el);
    rad_vec3 dir = rad_sub(target, eye);
    double dl = rad_length(dir), ul = rad_length(up);
    if (!(dl > 0.0) || !isfinite(dl))
        return failf(err, s, RAD_ERR_INVALID, where, "%seye and target coincide", el);
    if (!(ul > 0.0) || !isfinite(ul) ||
        !(rad_length(rad_cross(dir, up)) > 1e-9 * dl * ul))
        return failf(err, s, RAD_ERR_INVALID, where,
                     "%sup (%g %g %g) is zero or parallel to the view direction", el, up.x, up.y,
                     up.z);
    if (!isfinite(yfov_deg) || !(yfov_deg > 0.0) || !(yfov_deg < 180.0))
        return failf(err, s, RAD_ERR_INVALID, where, "%sfov %g degrees outside (0, 180)", el,
                     yfov_deg);
    if (!isfinite(aspect) || aspect < 0.0)
        return failf(err, s, RAD_ERR_INVALID, where, "%saspect %g must be finite and >= 0", el,
                     aspect);
    if (ortho && (!isfinite(xmag) || !isfinite(ymag) || !(xmag > 0.0) || !(ymag > 0.0)))
        return failf(err, s, RAD_ERR_INVALID, where,
                     "%sorthographic half-sizes %g × %g must be finite and > 0", el, xmag, ymag);
    scene_names *nm = names_of(s);
    if (!nm || names_sync(&nm->camera, s->cameras, sizeof(rad_camera),
                          offsetof(rad_camera, name), s->camera_count) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    if (rad_names_find(&nm->camera, name) != RAD_NONE)
        return failf(err, s, RAD_ERR_INVALID, where, "%sa camera of this name already exists",
                     el);
    if (grow((void **)&s->cameras, &s->camera_cap_, (uint64_t)s->camera_count + 1,
             sizeof *s->cameras) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%stoo many cameras", el);
    char *copy = strdup(name);
    if (!copy || rad_names_insert(&nm->camera, copy, s->camera_count) != 0) {
        free(copy);
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    }
    rad_camera *c = &s->cameras[s->camera_count];
    memset(c, 0, sizeof *c);
    c->name = copy;
    c->eye = eye;
    c->target = target;
    c->up = up;
    c->yfov_deg = yfov_deg;
    c->aspect = aspect;
    c->orthographic = ortho;
    c->xmag = ortho ? xmag : 0.0;
    c->ymag = ortho ? ymag : 0.0;
    if (index)
        *index = s->camera_count;
    s->camera_count++;
    return RAD_OK;
}

int rad_scene_add_camera(rad_scene *s, const char *name, rad_vec3 eye, rad_vec3 target,
                         rad_vec3 up, double yfov_deg, double aspect, const char *where,
                         uint32_t *index, rad_error *err)
{
    return add_camera(s, name, eye, target, up, yfov_deg, aspect, 0, 0.0, 0.0, where, index,
                      err);
}

/* The yfov an orthographic camera carries: any valid angle, so that code
 * and files that know only perspective cameras still take it. */
#define ORTHO_PLACEHOLDER_FOV 45.0

int rad_scene_add_ortho_camera(rad_scene *s, const char *name, rad_vec3 eye, rad_vec3 target,
                               rad_vec3 up, double xmag, double ymag, const char *where,
                               uint32_t *index, rad_error *err)
{
    double aspect = xmag / ymag; /* refused below unless both are finite and > 0 */
    return add_camera(s, name, eye, target, up, ORTHO_PLACEHOLDER_FOV,
                      isfinite(aspect) && aspect > 0.0 ? aspect : 0.0, 1, xmag, ymag, where,
                      index, err);
}

int rad_scene_set_camera_ortho(rad_scene *s, uint32_t camera, double xmag, double ymag,
                               const char *where, rad_error *err)
{
    if (!s || camera >= s->camera_count)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_set_camera_ortho: no scene or no camera %u",
                        camera);
    rad_camera *c = &s->cameras[camera];
    char eb[320];
    const char *el = element(eb, sizeof eb, "camera", c->name, where);
    if (!isfinite(xmag) || !isfinite(ymag) || !(xmag > 0.0) || !(ymag > 0.0))
        return failf(err, s, RAD_ERR_INVALID, where,
                     "%sorthographic half-sizes %g × %g must be finite and > 0", el, xmag, ymag);
    c->orthographic = 1;
    c->xmag = xmag;
    c->ymag = ymag;
    return RAD_OK;
}

/* ------------------------------------------------------------------- lights */

int rad_scene_add_light(rad_scene *s, const char *name, rad_light_kind kind,
                        const double *intensity, rad_vec3 position, rad_vec3 direction,
                        double inner_cone, double outer_cone, const char *where,
                        uint32_t *index, rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_add_light: no scene");
    if (!name || !*name)
        return failf(err, s, RAD_ERR_INVALID, where, "a light needs a non-empty name");
    char eb[320], bb[40];
    const char *el = element(eb, sizeof eb, "light", name, where);
    if (kind != RAD_LIGHT_POINT && kind != RAD_LIGHT_SPOT && kind != RAD_LIGHT_DIRECTIONAL)
        return failf(err, s, RAD_ERR_USAGE, where, "%skind %d is not point, spot or directional",
                     el, (int)kind);
    if (!intensity)
        return failf(err, s, RAD_ERR_USAGE, where, "%sno intensity given", el);
    rad_light L;
    memset(&L, 0, sizeof L);
    L.kind = kind;
    for (uint32_t b = 0; b < s->band_count; b++) {
        if (!isfinite(intensity[b]) || intensity[b] < 0.0)
            return failf(err, s, RAD_ERR_INVALID, where,
                         "%s%s %g must be finite and >= 0%s", el,
                         kind == RAD_LIGHT_DIRECTIONAL ? "irradiance" : "intensity",
                         intensity[b], band_label(bb, sizeof bb, s, b));
        L.intensity[b] = intensity[b];
    }
    if (kind != RAD_LIGHT_DIRECTIONAL) {
        if (!rad_finite3(position))
            return failf(err, s, RAD_ERR_INVALID, where, "%sposition is not finite", el);
        L.position = position;
    }
    if (kind != RAD_LIGHT_POINT) {
        double len = rad_length(direction);
        if (!rad_finite3(direction) || !isfinite(len) || !(len > 1e-12))
            return failf(err, s, RAD_ERR_INVALID, where,
                         "%sdirection (%g %g %g) is zero or not finite", el, direction.x,
                         direction.y, direction.z);
        /* A direction already unit to rounding is kept as given, so that a
         * light read back from a solution file is bit-identical. */
        L.direction = fabs(len - 1.0) <= 1e-12
                          ? direction
                          : rad_v3(direction.x / len, direction.y / len, direction.z / len);
    } else {
        L.direction = rad_v3(0, 0, -1);
    }
    L.inner_cone = 0.0;
    L.outer_cone = M_PI / 2;
    if (kind == RAD_LIGHT_SPOT) {
        /* glTF's rule: 0 <= inner < outer <= π/2 (a cone wider than a
         * half-space is no spot). */
        if (!isfinite(inner_cone) || !isfinite(outer_cone) || !(inner_cone >= 0.0) ||
            !(inner_cone < outer_cone) || !(outer_cone <= M_PI / 2))
            return failf(err, s, RAD_ERR_INVALID, where,
                         "%scone angles inner %g, outer %g rad: need 0 <= inner < outer <= π/2",
                         el, inner_cone, outer_cone);
        L.inner_cone = inner_cone;
        L.outer_cone = outer_cone;
    }
    scene_names *nm = names_of(s);
    if (!nm || names_sync(&nm->light, s->lights, sizeof(rad_light), offsetof(rad_light, name),
                          s->light_count) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    if (rad_names_find(&nm->light, name) != RAD_NONE)
        return failf(err, s, RAD_ERR_INVALID, where, "%sa light of this name already exists", el);
    if (grow((void **)&s->lights, &s->light_cap_, (uint64_t)s->light_count + 1,
             sizeof *s->lights) != 0)
        return failf(err, s, RAD_ERR_NOMEM, where, "%stoo many lights", el);
    L.name = strdup(name);
    if (!L.name || rad_names_insert(&nm->light, L.name, s->light_count) != 0) {
        free(L.name);
        return failf(err, s, RAD_ERR_NOMEM, where, "%sout of memory", el);
    }
    s->lights[s->light_count] = L;
    if (index)
        *index = s->light_count;
    s->light_count++;
    return RAD_OK;
}

/* --------------------------------------------------------------- whole scene */

int rad_scene_validate(const rad_scene *s, rad_error *err) { return rad_scene_check(s, 1, err); }

int rad_scene_check(const rad_scene *s, int need_emitter, rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_validate: no scene");
    if (s->band_count < 1 || s->band_count > RAD_MAX_BANDS)
        return failf(err, s, RAD_ERR_INVALID, NULL, "%u bands, expected 1 to %d", s->band_count,
                     RAD_MAX_BANDS);
    if (s->polygon_count == 0)
        return failf(err, s, RAD_ERR_INVALID, NULL, "no polygons: the scene is empty");
    for (uint32_t k = 0; k < s->polygon_count; k++) {
        const rad_polygon *p = &s->polygons[k];
        if (p->material >= s->material_count || p->object >= s->object_count ||
            p->point_count < 3 || (uint64_t)p->first_point + p->point_count > s->point_count)
            return failf(err, s, RAD_ERR_INVALID, NULL,
                         "polygon %u ('%s'): material, object or points out of range", k,
                         p->name ? p->name : "");
    }

    if (!need_emitter)
        return RAD_OK;
    /* A punctual light of some strength is an emitter on its own. */
    for (uint32_t l = 0; l < s->light_count; l++)
        if (rad_any_positive(s->lights[l].intensity, s->band_count))
            return RAD_OK;
    /* E_i > 0 only matters where a patch carries it: an emitting material
     * that no polygon uses lights nothing. */
    uint32_t unused_emitter = RAD_NONE;
    uint8_t *used = calloc(s->material_count ? s->material_count : 1, 1);
    if (!used)
        return failf(err, s, RAD_ERR_NOMEM, NULL, "out of memory");
    for (uint32_t k = 0; k < s->polygon_count; k++)
        used[s->polygons[k].material] = 1;
    for (uint32_t m = 0; m < s->material_count; m++) {
        if (!rad_any_positive(s->materials[m].emission, s->band_count))
            continue;
        if (used[m]) {
            free(used);
            return RAD_OK;
        }
        if (unused_emitter == RAD_NONE)
            unused_emitter = m;
    }
    free(used);
    if (unused_emitter != RAD_NONE)
        return failf(err, s, RAD_ERR_INVALID, NULL,
                     "no emitter: material '%s' has emission > 0 but no polygon uses it",
                     s->materials[unused_emitter].name);
    return failf(err, s, RAD_ERR_INVALID, NULL,
                 s->light_count ? "no emitter: no material has emission > 0 and every light "
                                  "has intensity 0"
                                : "no emitter: no material has emission > 0");
}

int rad_scene_bounds(const rad_scene *s, rad_vec3 *lo, rad_vec3 *hi)
{
    if (!s || s->point_count == 0 || !s->points)
        return 0;
    rad_vec3 a = s->points[0], b = s->points[0];
    for (uint32_t k = 1; k < s->point_count; k++) {
        rad_vec3 p = s->points[k];
        a = rad_v3(fmin(a.x, p.x), fmin(a.y, p.y), fmin(a.z, p.z));
        b = rad_v3(fmax(b.x, p.x), fmax(b.y, p.y), fmax(b.z, p.z));
    }
    if (lo)
        *lo = a;
    if (hi)
        *hi = b;
    return 1;
}
