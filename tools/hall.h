/* hall.h - a generated glTF scene of many small triangles for the
 * large-scene benchmark (bench/bench_scale.c): a vaulted hall with two
 * arcades of columns and round arches, tables and benches, every surface
 * tessellated finely as a modeller's export would be, lit only by a sun
 * (KHR_lights_punctual directional light) through three tall windows.
 * Its output is written to a temporary directory and never committed.
 */
#ifndef TOOLS_HALL_H
#define TOOLS_HALL_H

#include <stdint.h>

typedef struct hall_stats {
    uint64_t triangles; /* triangles written */
    uint32_t objects;   /* glTF nodes with a mesh */
} hall_stats;

/* Writes DIR/NAME.gltf and DIR/NAME.bin.  `fine` scales the tessellation
 * (1 = the benchmark's scene, about 100,000 triangles; 0.5 = a quarter of
 * that).  0 on success, -1 with a message on stderr. */
int hall_write(const char *dir, const char *name, double fine, hall_stats *stats);

/* The same hall with every triangle then re-tessellated into four the way
 * exporters write them (fans, slivers, T-junctions, unwelded copies:
 * gs_split4 in scene_gltf.h): the same surfaces, four times the triangles. */
int hall_write_split(const char *dir, const char *name, double fine, hall_stats *stats);

#endif /* TOOLS_HALL_H */
