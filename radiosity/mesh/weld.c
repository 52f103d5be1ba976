/* weld.c - scene points that are one position (mesh_internal.h).
 *
 * An export often repeats a vertex once per triangle (split normals, UV
 * seams), sometimes with the last bits of its coordinates differing.  The
 * mesher's grouping (planar regions, clusters) needs to know which points
 * are the same place: points within eps of an earlier point get that
 * point's id.  Invariant: id[k] < count for every point; the position of
 * id j is the point first[j], the lowest point holding it; two points of
 * one id lie within eps of first[id] (so within 2 eps of each other).
 * Deterministic: points are taken in order, ties go to the lowest id.
 */
#include "mesh_internal.h"

#include <stdlib.h>
#include <string.h>

typedef struct cellkey {
    int64_t k[3];
} cellkey;

static uint64_t key_hash(cellkey c)
{
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int a = 0; a < 3; a++) {
        h ^= (uint64_t)c.k[a];
        h *= 0xff51afd7ed558ccdull;
        h ^= h >> 32;
    }
    return h;
}

/* Grid cells of side eps; a point may match any id in the 27 cells about
 * its own. */
typedef struct welder {
    const rad_vec3 *P;
    rad_vec3 lo;
    double eps;
    uint32_t *slot; /* id + 1, 0 empty */
    size_t mask;
    cellkey *key;   /* per id */
    uint32_t *first;
} welder;

static cellkey cell_of(const welder *w, rad_vec3 p)
{
    rad_vec3 d = rad_scale(rad_sub(p, w->lo), 1.0 / w->eps);
    cellkey c = {{(int64_t)floor(d.x), (int64_t)floor(d.y), (int64_t)floor(d.z)}};
    return c;
}

static uint32_t lookup(const welder *w, cellkey c, rad_vec3 p)
{
    for (size_t h = key_hash(c) & w->mask; w->slot[h]; h = (h + 1) & w->mask) {
        uint32_t id = w->slot[h] - 1;
        if (memcmp(&w->key[id], &c, sizeof c) == 0 &&
            rad_length(rad_sub(w->P[w->first[id]], p)) <= w->eps)
            return id;
    }
    return RAD_NONE;
}

static uint32_t find_near(const welder *w, cellkey c, rad_vec3 p)
{
    uint32_t best = RAD_NONE;
    for (int dx = -1; dx <= 1; dx++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dz = -1; dz <= 1; dz++) {
                cellkey n = {{c.k[0] + dx, c.k[1] + dy, c.k[2] + dz}};
                uint32_t id = lookup(w, n, p);
                if (id < best)
                    best = id;
            }
    return best;
}

int mesh_weld(const rad_scene *s, double eps, uint32_t *id, uint32_t *first, uint32_t *count)
{
    const uint32_t n = s->point_count;
    *count = 0;
    rad_vec3 hi;
    welder w = {.P = s->points, .eps = eps, .first = first};
    if (!rad_scene_bounds(s, &w.lo, &hi) || !(eps > 0.0) || !isfinite(eps)) {
        for (uint32_t k = 0; k < n; k++) /* nothing to weld by: every point its own */
            id[k] = first[k] = k;
        *count = n;
        return 0;
    }
    size_t cap = 16;
    while (cap < 2 * (size_t)n + 2)
        cap *= 2;
    w.slot = calloc(cap, sizeof *w.slot);
    w.key = malloc(((size_t)n + 1) * sizeof *w.key);
    w.mask = cap - 1;
    if (!w.slot || !w.key) {
        free(w.slot);
        free(w.key);
        return -1;
    }
    for (uint32_t k = 0; k < n; k++) {
        rad_vec3 p = s->points[k];
        cellkey c = {{0, 0, 0}};
        if (rad_finite3(p))
            c = cell_of(&w, p);
        uint32_t j = rad_finite3(p) ? find_near(&w, c, p) : RAD_NONE;
        if (j == RAD_NONE) {
            j = (*count)++;
            first[j] = k;
            w.key[j] = c;
            size_t h = key_hash(c) & w.mask;
            while (w.slot[h])
                h = (h + 1) & w.mask;
            w.slot[h] = j + 1;
        }
        id[k] = j;
    }
    free(w.slot);
    free(w.key);
    return 0;
}
