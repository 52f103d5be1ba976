/* scene_internal.h - private to the scene module (scene.c, polyfile.c).
 *
 * A string -> index hash set, so that name-uniqueness checks stay linear in
 * the number of names: a polygon file with a million polygons has a million
 * objects.  The set borrows its keys (it never copies or frees them); the
 * owner keeps each key alive and unchanged while it is in the set.
 */
#ifndef RAD_SCENE_INTERNAL_H
#define RAD_SCENE_INTERNAL_H

#include <stdint.h>

typedef struct rad_names_slot {
    const char *key; /* NULL = empty slot */
    uint32_t value;
} rad_names_slot;

typedef struct rad_names {
    rad_names_slot *slot;
    uint32_t cap;  /* 0 or a power of two */
    uint32_t used;
} rad_names;

/* The value stored for key, or RAD_NONE (UINT32_MAX). */
uint32_t rad_names_find(const rad_names *set, const char *key);
/* Adds key -> value (the caller has checked it is absent).  0, or -1 on OOM. */
int rad_names_insert(rad_names *set, const char *key, uint32_t value);
/* Frees the table (not the keys) and leaves an empty set. */
void rad_names_free(rad_names *set);

#endif /* RAD_SCENE_INTERNAL_H */
