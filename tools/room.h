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
 * stderr.  The geometry is fixed (no randomness). */
int room_write(const char *dir, const char *name, room_stats *stats);

#endif /* TOOLS_ROOM_H */
