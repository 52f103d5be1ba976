/* bake_internal.h - private to radiosity/bake/: the baked geometry that
 * bake.c builds from a drawing and bake_json.c writes as glTF. */
#ifndef RAD_BAKE_INTERNAL_H
#define RAD_BAKE_INTERNAL_H

#include "../pipeline/pipeline.h"
#include "bake.h"

/* One glTF primitive: the cells of one object and one material. */
typedef struct bk_prim {
    uint32_t object, material;
    uint64_t first_vertex, vertex_count; /* into bk_geometry's vertex arrays */
    uint64_t first_index, index_count;   /* into index; indices local to the primitive */
    float lo[3], hi[3];                  /* POSITION bounds (glTF asks for them) */
    int textured;                        /* its material has a rad_texture: TEXCOORD_0 */
    uint64_t first_uv;                   /* textured: its first vertex's pair among the
                                          * textured primitives' TEXCOORD_0 */
} bk_prim;

/* Vertex arrays, one glTF buffer view each, primitives one after another. */
typedef struct bk_geometry {
    float *position;   /* 3 per vertex */
    uint16_t *color;   /* COLOR_0: 4 per vertex, normalized, alpha 1 */
    float *radiance;   /* _RADIANCE: 3 per vertex, linear L = B/π */
    uint32_t *index;   /* 3 per triangle, counter-clockwise about the front */
    float *uv;         /* TEXCOORD_0: 2 per vertex (used in textured primitives only);
                        * NULL when no primitive is textured */
    uint64_t vertex_count, index_count;
    uint64_t uv_count; /* vertices of the textured primitives */
    bk_prim *prims;
    uint32_t prim_count;
} bk_geometry;

/* Material m's texture when a bake draws it, else NULL: a reflecting
 * material's (an emitter's light is its own, not the texture's: it bakes
 * as an untextured material). */
const rad_texture *bk_texture(const rad_scene *sc, uint32_t m); /* bake_json.c */

/* Builds g from d, a drawing of s, at exposure ev (caller frees with
 * bk_geometry_free; g is zeroed on failure). */
int bk_geometry_build(const rad_solution *s, const rad_drawing *d, double ev, bk_geometry *g,
                      rad_error *err);
void bk_geometry_free(bk_geometry *g);

/* Writes g with s's names, materials and cameras to path (.glb or .gltf +
 * .bin); *bytes = the files' total size. */
int bk_write_files(const rad_solution *s, const bk_geometry *g, const char *path, uint64_t *bytes,
                   rad_error *err);

#endif /* RAD_BAKE_INTERNAL_H */
