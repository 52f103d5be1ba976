/* solution.c - creating and destroying a rad_solution (solution.h): the
 * per-patch ρ (its polygon's, rad_polygon_rho) and E from the scene's
 * materials, B = E, an empty matrix, the punctual lights' nominal
 * intensities; the per-band arrays and light arrays the file reader fills
 * too (radiosity/solfile/), and the progress record.
 *
 * Invariant: a solution made here satisfies solution.h (arrays sized
 * patch_count × band_count, F->n == patch_count, B >= 0 finite), and
 * rad_solution_destroy frees whatever a creator or a reader attached,
 * the reader's record (origin) through the function the reader gave.
 */
#include "solution.h"

#include <stdlib.h>
#include <string.h>

const char *rad_stage_name(rad_stage s)
{
    switch (s) {
    case RAD_STAGE_LOAD: return "load";
    case RAD_STAGE_MESH: return "mesh";
    case RAD_STAGE_FORM_FACTORS: return "form_factors";
    case RAD_STAGE_SOLVE: return "solve";
    case RAD_STAGE_STORE: return "store";
    default: return "unknown";
    }
}

/* ------------------------------------------------------- create / destroy */

void rad_solution_destroy(rad_solution *s)
{
    if (!s)
        return;
    rad_scene_destroy(s->scene);
    rad_mesh_destroy(s->mesh);
    rad_matrix_destroy(s->F);
    free(s->rho);
    free(s->emission);
    free(s->B);
    for (uint32_t l = 0; s->light_power && l < s->light_slots_; l++) {
        free(s->light_power[l].patch);
        free(s->light_power[l].power);
    }
    free(s->light_power);
    free(s->light_intensity);
    rad_element_store_destroy(s->elements);
    free(s->irradiance);
    rad_progress_destroy(s->progress);
    rad_basis_destroy(s->basis);
    if (s->origin && s->origin_destroy)
        s->origin_destroy(s->origin);
    free(s);
}

rad_progress *rad_progress_create(uint32_t previews)
{
    rad_progress *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    p->previews = calloc((size_t)previews + 1, sizeof *p->previews);
    if (!p->previews) {
        free(p);
        return NULL;
    }
    p->preview_count = previews;
    return p;
}

void rad_progress_destroy(rad_progress *p)
{
    if (!p)
        return;
    free(p->previews);
    free(p);
}

int rad_solution_alloc_lights(rad_solution *s, uint32_t count)
{
    if (count == 0)
        return 0;
    s->light_intensity = rad_solution_band_array(count, s->band_count);
    s->light_power = calloc(count, sizeof *s->light_power);
    if (!s->light_intensity || !s->light_power)
        return -1;
    s->light_slots_ = count;
    return 0;
}

double *rad_solution_band_array(uint32_t n, uint32_t bands)
{
    uint64_t count = (uint64_t)n * bands;
    if (count > SIZE_MAX / sizeof(double))
        return NULL;
    return calloc(count ? (size_t)count : 1, sizeof(double));
}

int rad_solution_create(rad_scene *scene, rad_mesh *mesh, rad_solution **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!scene || !mesh || !out) {
        rad_scene_destroy(scene);
        rad_mesh_destroy(mesh);
        return rad_fail(err, RAD_ERR_USAGE,
                        "rad_solution_create: scene, mesh and out are required");
    }
    const char *src = scene->source ? scene->source : "<memory>";
    if (scene->band_count < 1 || scene->band_count > RAD_MAX_BANDS) {
        rad_fail(err, RAD_ERR_USAGE, "%s: %u bands (1..%d allowed)", src, scene->band_count,
                 RAD_MAX_BANDS);
        rad_scene_destroy(scene);
        rad_mesh_destroy(mesh);
        return RAD_ERR_USAGE;
    }
    for (uint32_t i = 0; i < mesh->patch_count; i++) {
        if (mesh->patches[i].material >= scene->material_count) {
            rad_fail(err, RAD_ERR_USAGE, "%s: patch %u: material %u out of range (%u materials)",
                     src, i, mesh->patches[i].material, scene->material_count);
            rad_scene_destroy(scene);
            rad_mesh_destroy(mesh);
            return RAD_ERR_USAGE;
        }
    }
    rad_solution *s = calloc(1, sizeof *s);
    if (!s) {
        rad_scene_destroy(scene);
        rad_mesh_destroy(mesh);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for the solution", src);
    }
    s->scene = scene;
    s->mesh = mesh;
    s->band_count = scene->band_count;
    uint32_t n = mesh->patch_count, nb = s->band_count;
    s->rho = rad_solution_band_array(n, nb);
    s->emission = rad_solution_band_array(n, nb);
    s->B = rad_solution_band_array(n, nb);
    s->F = rad_matrix_create(n);
    if (!s->rho || !s->emission || !s->B || !s->F ||
        rad_solution_alloc_lights(s, scene->light_count) != 0) {
        rad_solution_destroy(s);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for %u patches × %u bands", src, n,
                        nb);
    }
    for (uint32_t i = 0; i < n; i++) {
        const rad_material *m = &scene->materials[mesh->patches[i].material];
        /* ρ of the patch's polygon: its own (glTF vertex colours) or its
         * material's */
        const double *rho = mesh->patches[i].polygon < scene->polygon_count
                                ? rad_polygon_rho(scene, mesh->patches[i].polygon)
                                : m->rho;
        for (uint32_t b = 0; b < nb; b++) {
            s->rho[(size_t)i * nb + b] = rho[b];
            s->emission[(size_t)i * nb + b] = m->emission[b];
            s->B[(size_t)i * nb + b] = m->emission[b]; /* B = E before any bounce */
        }
    }
    for (uint32_t l = 0; l < scene->light_count; l++)
        memcpy(s->light_intensity + (size_t)l * nb, scene->lights[l].intensity,
               nb * sizeof(double));
    *out = s;
    return RAD_OK;
}
