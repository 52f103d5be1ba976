/* light_power.c - punctual lights in a solution: the per-patch power they deliver
 * (sparse, float), the direct irradiance it gives, and their power balance.
 *
 * Invariant: s->light_power[l], when present, lists strictly increasing
 * patch indices < patch_count with finite Φ_j > 0, and everything computed
 * from it uses the stored float values, so a solution read back from a file
 * gives the same H_d bit for bit as the one that was written.
 *
 * Units: I_l is radiometric (W/sr for point and spot lights, W/m² of
 * irradiance on a surface facing a directional light), Φ_lj is the power
 * patch j receives from the light at unit I (m²·sr/sr = W per W/sr, or m²
 * of projected area for a directional light), so I_l Φ_lj is a power and
 * H_d,j = Σ_l I_l Φ_lj / A_j an irradiance.
 */
#include "solution.h"

#include <stdlib.h>
#include <string.h>

int rad_solution_set_light_power(rad_solution *s, uint32_t light, const double *power,
                                 rad_error *err)
{
    if (!s || !s->scene || !s->mesh || !power || light >= s->scene->light_count ||
        !s->light_power)
        return rad_fail(err, RAD_ERR_USAGE, "rad_solution_set_light_power: bad arguments");
    const rad_scene *sc = s->scene;
    uint32_t n = s->mesh->patch_count, count = 0;
    for (uint32_t j = 0; j < n; j++) {
        if (!isfinite(power[j]) || power[j] < 0.0)
            return rad_fail(err, RAD_ERR_INVALID, "%s: light '%s': patch %u receives power %g",
                            sc->source, sc->lights[light].name, j, power[j]);
        /* a value below float's range would be stored as 0 */
        if ((float)power[j] > 0.0f)
            count++;
    }
    uint32_t *patch = malloc((count ? count : 1) * sizeof *patch);
    float *val = malloc((count ? count : 1) * sizeof *val);
    if (!patch || !val) {
        free(patch);
        free(val);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: light '%s': out of memory", sc->source,
                        sc->lights[light].name);
    }
    count = 0;
    for (uint32_t j = 0; j < n; j++) {
        float f = (float)power[j];
        if (f > 0.0f && isfinite(f)) {
            patch[count] = j;
            val[count] = f;
            count++;
        }
    }
    rad_light_power *lp = &s->light_power[light];
    free(lp->patch);
    free(lp->power);
    lp->patch = patch;
    lp->power = val;
    lp->count = count;
    lp->present = 1;
    return RAD_OK;
}

int rad_solution_direct_irradiance(const rad_solution *s, double *Hd, rad_error *err)
{
    (void)err;
    uint32_t n = s->mesh->patch_count, nb = s->band_count;
    memset(Hd, 0, (size_t)n * nb * sizeof *Hd);
    uint32_t nl = s->light_power && s->light_intensity ? s->scene->light_count : 0;
    for (uint32_t l = 0; l < nl; l++) {
        const rad_light_power *lp = &s->light_power[l];
        if (!lp->present)
            continue;
        const double *I = s->light_intensity + (size_t)l * nb;
        for (uint32_t k = 0; k < lp->count; k++) {
            uint32_t j = lp->patch[k];
            double phi_per_area = (double)lp->power[k] / s->mesh->patches[j].area;
            for (uint32_t b = 0; b < nb; b++)
                Hd[(size_t)j * nb + b] += I[b] * phi_per_area;
        }
    }
    return RAD_OK;
}

/* ∫ over the sphere of glTF's spot falloff, in steradians: with u = cos θ,
 * 2π ∫ t(u)² du, t = clamp((u − cos_outer)/d, 0, 1), d = max(0.001,
 * cos_inner − cos_outer) (the same guard as the specification's sample code
 * and hc_light_power). */
static double spot_solid_angle(double inner, double outer)
{
    double ci = cos(inner), co = cos(outer);
    double d = fmax(0.001, ci - co);
    if (co + d <= 1.0)
        return 2.0 * M_PI * ((1.0 - co - d) + d / 3.0);
    double w = 1.0 - co;
    return 2.0 * M_PI * w * w * w / (3.0 * d * d);
}

int rad_solution_light_stats(const rad_solution *s, rad_light_stats *out, rad_error *err)
{
    (void)err;
    const rad_scene *sc = s->scene;
    uint32_t nb = s->band_count;
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const rad_light *L = &sc->lights[l];
        const double *I = s->light_intensity ? s->light_intensity + (size_t)l * nb : L->intensity;
        const rad_light_power *lp = s->light_power ? &s->light_power[l] : NULL;
        double phi = 0.0; /* Σ_j Φ_j */
        for (uint32_t k = 0; lp && lp->present && k < lp->count; k++)
            phi += lp->power[k];
        double omega = L->kind == RAD_LIGHT_POINT  ? 4.0 * M_PI
                       : L->kind == RAD_LIGHT_SPOT ? spot_solid_angle(L->inner_cone, L->outer_cone)
                                                   : 0.0;
        memset(&out[l], 0, sizeof out[l]);
        for (uint32_t b = 0; b < nb; b++) {
            out[l].delivered[b] = I[b] * phi;
            out[l].emitted[b] = L->kind == RAD_LIGHT_DIRECTIONAL ? I[b] * phi : I[b] * omega;
        }
    }
    return RAD_OK;
}
