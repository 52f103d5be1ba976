/* atrium.h - a generated glTF atrium for bench/bench_atrium.c (issue 36):
 * a courtyard hall whose surfaces are tessellated the way exporters write
 * them (fans, slivers, unwelded seams), with columns, round arches, barrel
 * vaults and thin balusters, lit only by a sun through an opening in the
 * roof.  Its output is written to a temporary directory, never committed.
 */
#ifndef TOOLS_ATRIUM_H
#define TOOLS_ATRIUM_H

#include <stdint.h>

typedef struct atrium_stats {
    uint64_t triangles; /* triangles written */
    uint32_t objects;   /* glTF nodes with a mesh */
    double area;        /* total one-sided area of the triangles, m² */
} atrium_stats;

/* Writes DIR/NAME.gltf and DIR/NAME.bin.  `fine` scales the tessellation
 * (1 = the benchmark's scene, about 70,000 triangles; 2 = about four times
 * as many).  0 on success, -1 with a message on stderr. */
int atrium_write(const char *dir, const char *name, double fine, atrium_stats *stats);

#endif /* TOOLS_ATRIUM_H */
