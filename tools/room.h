/* room.h - a generated closed room for issue 36's test (test/test_room.c)
 * and its path-traced reference (tools/pathtrace.c --objects): a box room
 * lit only by an emissive lamp in its ceiling, holding a UV sphere, a
 * round table (48-sided fanned caps, thin legs) and a flat-shaded
 * head-like mesh, written as glTF 2.0 the way exporters write them.
 */
#ifndef TOOLS_ROOM_H
#define TOOLS_ROOM_H

#include <stdint.h>

typedef struct room_stats {
    uint64_t triangles; /* triangles written */
    uint32_t objects;   /* glTF nodes with a mesh */
} room_stats;

/* Writes DIR/NAME.gltf and DIR/NAME.bin; 0, or -1 with a message on
 * stderr.  The geometry is fixed (no randomness).  dark = 1: every
 * material but the lamp's, the sphere's and the head's black (ρ = 0), so
 * that those two receive the lamp's direct light only. */
int room_write(const char *dir, const char *name, int dark, room_stats *stats);

#endif /* TOOLS_ROOM_H */
