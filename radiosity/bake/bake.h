/* bake.h - a solved scene as glTF 2.0 that any viewer draws with no light
 * of its own: the cells the vertex renderer draws (elements' crack-free
 * fans, patches, clustered cells), each vertex carrying the light the
 * renderer would show there, under KHR_materials_unlit.
 *
 * The light (docs/bake.md): COLOR_0 = clamp(L · 2^EV, 0, 1) per channel,
 * L = B/π the vertex's radiance, with baseColorFactor 1, so a viewer's
 * baseColor × COLOR_0, sRGB-encoded, is the pixel `render --png --exposure
 * EV` writes (the reflectance is already inside B = E + ρH).  The linear
 * radiance L itself, unclamped, rides along as the custom `_RADIANCE`.
 * One band is grey, three or more bands RGB from the first three (as
 * render/png.c).  Units are the scene's, coordinates untouched.
 * A material with a texture (scene.h's rad_texture) keeps it, its
 * baseColorFactor and TEXCOORD_0 (interpolated from its polygons' corners),
 * and its COLOR_0 carries the incident light instead: clamp(L / ρ̄ · 2^EV,
 * 0, 1), ρ̄ the material's mean reflectance per band (0 where ρ̄ = 0), so
 * the viewer's factor × texture × COLOR_0 averages to L · 2^EV.
 */
#ifndef RAD_BAKE_H
#define RAD_BAKE_H

#include "../solution/solution.h"

/* {0} means defaults. */
typedef struct rad_bake_options {
    int exposure_given; /* 1 = use `exposure`; 0 = rad_bake_auto_exposure */
    double exposure;    /* EV: COLOR_0 = L · 2^EV */
} rad_bake_options;

/* What a bake wrote. */
typedef struct rad_bake_stats {
    uint64_t vertices;   /* in all primitives (a vertex is shared by its cells) */
    uint64_t triangles;
    uint64_t bytes;      /* every file written (.glb; or .gltf + .bin) */
    uint32_t primitives; /* one per object and material */
    uint32_t cameras;
    double exposure;     /* the EV used */
} rad_bake_stats;

/* The automatic exposure: the EV that maps the 99th percentile (by area)
 * of the reflecting (non-emitting) cells' brightest channel of radiance to
 * 1, rounded down to 1/100 stop, so that 1 % of the reflecting area at most
 * is clipped whatever the scene's units; 0 when nothing reflects light.
 * A textured cell counts with what its COLOR_0 carries, L / ρ̄. */
int rad_bake_auto_exposure(const rad_solution *s, double *ev, rad_error *err);

/* Writes s as glTF to path: binary when path ends in ".glb" (any case), else JSON
 * (.gltf) with its buffer in PATH-without-extension.bin beside it.  Each
 * file through a temporary renamed into place: on failure nothing new is
 * left behind.  stats may be NULL. */
int rad_bake_write(const rad_solution *s, const char *path, const rad_bake_options *opt,
                   rad_bake_stats *stats, rad_error *err);

#endif /* RAD_BAKE_H */
