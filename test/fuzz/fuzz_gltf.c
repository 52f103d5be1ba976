/* fuzz_gltf.c - libFuzzer target for the glTF front end.
 *
 * Arbitrary bytes go to rad_scene_parse_gltf from memory, named "fuzz.glb"
 * when they start with the binary container's magic "glTF" and "fuzz.gltf"
 * otherwise, with no base directory (so no external file may be reached),
 * then to rad_scene_validate and rad_mesh_build (capped at
 * FUZZ_MAX_PATCHES).  Invariants under test: no input crashes, leaks, hangs
 * or trips a sanitizer (in gltf.c, in the C++ bridge or in tinygltf as the
 * bridge drives it, or in stb_image as gltf_image.c drives it on embedded
 * textures); a failure hands back no scene and a non-empty message; an
 * accepted scene has three bands, 0 <= ρ < 1 (materials' and polygons'
 * own), E >= 0 and finite, polygons whose indices, normals and areas are
 * sound, and cameras with finite views; a mesh the mesher
 * accepts passes rad_mesh_check.
 * Seeds: test/fuzz/corpus/gltf/; dictionary: test/fuzz/gltf.dict.
 */
#include "../../radiosity/mesh/mesh.h"
#include "../../radiosity/scene/scene.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define FUZZ_MAX_PATCHES 20000u

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_scene(const rad_scene *s)
{
    if (s->band_count != 3)
        abort();
    for (uint32_t m = 0; m < s->material_count; m++)
        for (uint32_t b = 0; b < 3; b++) {
            const rad_material *mt = &s->materials[m];
            if (!(mt->rho[b] >= 0.0 && mt->rho[b] < 1.0) || !(mt->emission[b] >= 0.0) ||
                !isfinite(mt->emission[b]))
                abort();
        }
    for (uint32_t p = 0; p < s->point_count; p++)
        if (!rad_finite3(s->points[p]))
            abort();
    for (uint32_t k = 0; k < s->polygon_count; k++) {
        const rad_polygon *pg = &s->polygons[k];
        if (pg->point_count < 3 || pg->first_point > s->point_count ||
            pg->point_count > s->point_count - pg->first_point || pg->material >= s->material_count ||
            pg->object >= s->object_count || !(pg->area > 0.0) || !isfinite(pg->area) ||
            !(fabs(rad_length(pg->normal) - 1.0) < 1e-9) || !pg->name)
            abort();
    }
    for (uint32_t o = 0; o < s->object_count; o++)
        if (!s->objects[o].name)
            abort();
    for (uint32_t c = 0; c < s->camera_count; c++)
        if (!s->cameras[c].name || !rad_finite3(s->cameras[c].eye) ||
            !(s->cameras[c].yfov_deg > 0.0 && s->cameras[c].yfov_deg < 180.0) ||
            (s->cameras[c].orthographic &&
             !(s->cameras[c].xmag > 0.0 && s->cameras[c].ymag > 0.0 &&
               isfinite(s->cameras[c].xmag) && isfinite(s->cameras[c].ymag))))
            abort();
    /* a polygon's own ρ (vertex colours) obeys the material rules */
    for (uint32_t k = 0; s->polygon_rho && k < s->polygon_count; k++)
        for (uint32_t b = 0; b < 3; b++) {
            double r = rad_polygon_rho(s, k)[b];
            if (!(r >= 0.0 && r < 1.0) ||
                !(r + s->materials[s->polygons[k].material].transmit[b] < 1.0))
                abort();
        }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *name = size >= 4 && memcmp(data, "glTF", 4) == 0 ? "fuzz.glb" : "fuzz.gltf";
    rad_scene *s = NULL;
    rad_error err;
    memset(&err, 0, sizeof err);
    /* warnings dropped (NULL warn), not strict: the repairs are fuzzed too */
    rad_load_options lo = {.max_polygons = 100000};
    int rc = rad_scene_parse_gltf(data, size, name, &lo, &s, &err);
    if (rc != RAD_OK) {
        if (s || err.message[0] == '\0' || !memchr(err.message, '\0', sizeof err.message))
            abort();
        return 0;
    }
    if (!s)
        abort();
    check_scene(s);
    rad_error verr;
    (void)rad_scene_validate(s, &verr);

    rad_mesh_options mo = {.max_patches = FUZZ_MAX_PATCHES};
    rad_mesh *m = NULL;
    rc = rad_mesh_build(s, &mo, &m, &err);
    if (rc == RAD_OK) {
        if (!m || m->patch_count > FUZZ_MAX_PATCHES ||
            rad_mesh_check(m, s->polygon_count, s->object_count, s->material_count, &err) != RAD_OK)
            abort();
    } else if (m) {
        abort();
    }
    rad_mesh_destroy(m);
    rad_scene_destroy(s);
    return 0;
}
