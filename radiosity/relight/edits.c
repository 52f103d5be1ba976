/* edits.c - changing lights and colours of a stored solution without
 * touching its geometry: the hemi-cube paper's "lights can be turned on/off
 * and object colors can be changed simply by resolving the matrices".
 *
 * An edit changes the per-patch ρ and E a solution is solved with; the
 * scene's materials stay the nominal values ("on" and scale factors refer to
 * them).  Every edit of a batch is checked before any is applied, so a bad
 * argument leaves the solution as it was.
 *
 * Names: an exact object name wins, then an exact punctual-light name, then
 * an exact material name; failing all, a unique case-insensitive prefix of
 * any is accepted, several prefix matches are "ambiguous", none is
 * "unknown"; both errors list the candidates.  A punctual light has no
 * patches: a light or emission edit changes its s->light_intensity.
 */
#include "relight.h"

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static const char *edit_flag(rad_edit_kind k)
{
    return k == RAD_EDIT_LIGHT ? "--light" : k == RAD_EDIT_EMISSION ? "--emission" : "--reflectance";
}

/* Parses "v[,v...]" into values; returns the count or -1. */
static int parse_values(const char *text, double *values)
{
    int count = 0;
    const char *p = text;
    for (;;) {
        if (count == RAD_MAX_BANDS)
            return -1;
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (end == p || errno || !isfinite(v))
            return -1;
        values[count++] = v;
        if (*end == '\0')
            return count;
        if (*end != ',')
            return -1;
        p = end + 1;
    }
}

int rad_edit_parse(rad_edit_kind kind, const char *arg, rad_edit *out, rad_error *err)
{
    memset(out, 0, sizeof *out);
    out->kind = kind;
    const char *eq = arg ? strrchr(arg, '=') : NULL;
    if (!eq || eq == arg)
        return rad_fail(err, RAD_ERR_USAGE, "%s '%s': expected NAME=%s", edit_flag(kind),
                        arg ? arg : "", kind == RAD_EDIT_LIGHT ? "off|on|SCALE" : "VALUE[,VALUE...]");
    size_t len = (size_t)(eq - arg);
    if (len >= sizeof out->name)
        return rad_fail(err, RAD_ERR_USAGE, "%s: name too long", edit_flag(kind));
    memcpy(out->name, arg, len);
    const char *v = eq + 1;
    if (kind == RAD_EDIT_LIGHT) {
        if (strcmp(v, "off") == 0)
            out->scale = 0.0;
        else if (strcmp(v, "on") == 0)
            out->scale = 1.0;
        else {
            char *end;
            errno = 0;
            out->scale = strtod(v, &end);
            if (end == v || *end || errno || !isfinite(out->scale) || out->scale < 0)
                return rad_fail(err, RAD_ERR_USAGE,
                                "--light '%s': '%s' is not off, on or a non-negative scale", arg, v);
        }
        return RAD_OK;
    }
    int count = parse_values(v, out->values);
    if (count < 1)
        return rad_fail(err, RAD_ERR_USAGE, "%s '%s': '%s' is not a comma-separated list of numbers",
                        edit_flag(kind), arg, v);
    out->value_count = (uint32_t)count;
    for (int b = 0; b < count; b++) {
        if (kind == RAD_EDIT_EMISSION && out->values[b] < 0)
            return rad_fail(err, RAD_ERR_USAGE, "--emission '%s': emission %g is negative", arg,
                            out->values[b]);
        if (kind == RAD_EDIT_REFLECTANCE && !(out->values[b] >= 0 && out->values[b] < 1))
            return rad_fail(err, RAD_ERR_USAGE, "--reflectance '%s': reflectance %g outside [0, 1)",
                            arg, out->values[b]);
    }
    return RAD_OK;
}

/* A resolved name: an object, a punctual light (is_light) or a material. */
typedef struct target {
    int is_object;
    uint32_t index;
    int is_light;
} target;

static int prefix_match(const char *name, const char *prefix)
{
    return strncasecmp(name, prefix, strlen(prefix)) == 0;
}

static void append_name(char *list, size_t size, const char *kind, const char *name)
{
    size_t used = strlen(list);
    if (used + 8 >= size)
        return;
    snprintf(list + used, size - used, "%s%s '%s'", used ? ", " : "", kind, name);
}

static int resolve(const rad_solution *s, const rad_edit *e, target *t, rad_error *err)
{
    const rad_scene *sc = s->scene;
    uint32_t k = rad_scene_find_object(sc, e->name);
    if (k != RAD_NONE) {
        *t = (target){1, k, 0};
        return RAD_OK;
    }
    k = rad_scene_find_light(sc, e->name);
    if (k != RAD_NONE) {
        *t = (target){0, k, 1};
        return RAD_OK;
    }
    k = rad_scene_find_material(sc, e->name);
    if (k != RAD_NONE) {
        *t = (target){0, k, 0};
        return RAD_OK;
    }
    char list[768] = "";
    uint32_t matches = 0;
    for (uint32_t o = 0; o < sc->object_count; o++)
        if (prefix_match(sc->objects[o].name, e->name)) {
            *t = (target){1, o, 0};
            matches++;
            append_name(list, sizeof list, "object", sc->objects[o].name);
        }
    for (uint32_t l = 0; l < sc->light_count; l++)
        if (prefix_match(sc->lights[l].name, e->name)) {
            *t = (target){0, l, 1};
            matches++;
            append_name(list, sizeof list, "light", sc->lights[l].name);
        }
    for (uint32_t m = 0; m < sc->material_count; m++)
        if (prefix_match(sc->materials[m].name, e->name)) {
            *t = (target){0, m, 0};
            matches++;
            append_name(list, sizeof list, "material", sc->materials[m].name);
        }
    if (matches == 1)
        return RAD_OK;
    if (matches > 1)
        return rad_fail(err, RAD_ERR_NOTFOUND, "%s: %s '%s': ambiguous name; candidates: %s",
                        sc->source, edit_flag(e->kind), e->name, list);
    for (uint32_t o = 0; o < sc->object_count; o++)
        append_name(list, sizeof list, "object", sc->objects[o].name);
    for (uint32_t l = 0; l < sc->light_count; l++)
        append_name(list, sizeof list, "light", sc->lights[l].name);
    for (uint32_t m = 0; m < sc->material_count; m++)
        append_name(list, sizeof list, "material", sc->materials[m].name);
    return rad_fail(err, RAD_ERR_NOTFOUND, "%s: %s '%s': no object%s or material of that name; candidates: %s",
                    sc->source, edit_flag(e->kind), e->name, sc->light_count ? ", light" : "", list);
}

static int targets_patch(const target *t, const rad_patch *p)
{
    if (t->is_light)
        return 0;
    return t->is_object ? p->object == t->index : p->material == t->index;
}

/* The checks of check_edit for a punctual light. */
static int check_light_edit(const rad_solution *s, const rad_edit *e, const target *t,
                            rad_error *err)
{
    const rad_scene *sc = s->scene;
    const rad_light *L = &sc->lights[t->index];
    if (e->kind == RAD_EDIT_REFLECTANCE)
        return rad_fail(err, RAD_ERR_USAGE, "%s: --reflectance '%s': '%s' is a punctual light, "
                        "which reflects nothing", sc->source, e->name, L->name);
    if (e->kind == RAD_EDIT_EMISSION) {
        if (e->value_count != 1 && e->value_count != s->band_count)
            return rad_fail(err, RAD_ERR_USAGE, "%s: %s '%s': %u values given, the scene has %u bands",
                            sc->source, edit_flag(e->kind), e->name, e->value_count, s->band_count);
        return RAD_OK;
    }
    if (rad_any_positive(L->intensity, s->band_count))
        return RAD_OK;
    return rad_fail(err, RAD_ERR_USAGE,
                    "%s: --light '%s': light '%s' has intensity 0; use --emission to set one",
                    sc->source, e->name, L->name);
}

static int check_edit(const rad_solution *s, const rad_edit *e, target *t, rad_error *err)
{
    int rc = resolve(s, e, t, err);
    if (rc)
        return rc;
    if (t->is_light)
        return check_light_edit(s, e, t, err);
    const rad_scene *sc = s->scene;
    const char *what = t->is_object ? sc->objects[t->index].name : sc->materials[t->index].name;
    uint32_t nb = s->band_count;
    if (e->kind != RAD_EDIT_LIGHT && e->value_count != 1 && e->value_count != nb)
        return rad_fail(err, RAD_ERR_USAGE, "%s: %s '%s': %u values given, the scene has %u bands",
                        sc->source, edit_flag(e->kind), e->name, e->value_count, nb);
    int emits = 0, any = 0;
    for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        if (!targets_patch(t, p))
            continue;
        any = 1;
        const rad_material *m = &sc->materials[p->material];
        emits |= rad_any_positive(m->emission, nb);
        for (uint32_t b = 0; e->kind == RAD_EDIT_REFLECTANCE && b < nb; b++) {
            double rho = e->values[e->value_count == 1 ? 0 : b];
            if (rho + m->transmit[b] >= 1.0)
                return rad_fail(err, RAD_ERR_USAGE,
                                "%s: --reflectance '%s': reflectance %g plus transmittance %g "
                                "is not below 1",
                                sc->source, e->name, rho, m->transmit[b]);
        }
    }
    if (!any)
        return rad_fail(err, RAD_ERR_USAGE, "%s: %s '%s': '%s' has no patches", sc->source,
                        edit_flag(e->kind), e->name, what);
    if (e->kind == RAD_EDIT_LIGHT && !emits)
        return rad_fail(err, RAD_ERR_USAGE,
                        "%s: --light '%s': '%s' emits nothing; use --emission to make it a light",
                        sc->source, e->name, what);
    return RAD_OK;
}

int rad_solution_apply_edits(rad_solution *s, const rad_edit *edits, uint32_t count,
                             rad_error *err)
{
    target *t = malloc((count ? count : 1) * sizeof *t);
    if (!t)
        return rad_fail(err, RAD_ERR_NOMEM, "out of memory");
    for (uint32_t e = 0; e < count; e++) {
        int rc = check_edit(s, &edits[e], &t[e], err);
        if (rc) {
            free(t);
            return rc;
        }
    }
    uint32_t nb = s->band_count;
    for (uint32_t e = 0; e < count; e++) {
        const rad_edit *ed = &edits[e];
        for (uint32_t b = 0; t[e].is_light && b < nb; b++) {
            /* I per band: the nominal one scaled, or the value given */
            double *I = s->light_intensity + (size_t)t[e].index * nb;
            I[b] = ed->kind == RAD_EDIT_LIGHT ? s->scene->lights[t[e].index].intensity[b] * ed->scale
                                              : ed->values[ed->value_count == 1 ? 0 : b];
        }
        for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
            const rad_patch *p = &s->mesh->patches[i];
            if (!targets_patch(&t[e], p))
                continue;
            const rad_material *m = &s->scene->materials[p->material];
            for (uint32_t b = 0; b < nb; b++) {
                size_t k = (size_t)i * nb + b;
                double v = ed->values[ed->value_count == 1 ? 0 : b];
                if (ed->kind == RAD_EDIT_LIGHT)
                    s->emission[k] = m->emission[b] * ed->scale;
                else if (ed->kind == RAD_EDIT_EMISSION)
                    s->emission[k] = v;
                else
                    s->rho[k] = v;
            }
        }
    }
    free(t);
    return RAD_OK;
}
