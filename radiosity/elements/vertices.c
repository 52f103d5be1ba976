/* vertices.c - element vertices found again by their exact position within
 * their surface (one side of one polygon, or a clustered surface of small
 * polygons that share vertices: mesh.h).  A midpoint is computed as
 * (a + b)/2 from the two ends, which is the same double whichever side
 * computes it, so neighbours share vertices and a vertex of a finer
 * neighbour lying on an element's edge (a T-vertex) is found by looking up
 * the edge's midpoints recursively.
 *
 * Invariant: the table maps each (surface, position) to at most one vertex.
 */
#include "el_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* -------------------------------------------------- vertices by position */

static uint32_t root(uint32_t *up, uint32_t x)
{
    while (up[x] != x) {
        up[x] = up[up[x]];
        x = up[x];
    }
    return x;
}

/* A surface is a set of cells joined by shared vertices: one side of one
 * polygon (the mesher shares vertices within a side and never across
 * polygons, and the two sides of a transmitting sheet have vertices of
 * their own), or a clustered surface of small polygons.  The label of a
 * vertex is the lowest vertex index of its surface. */
void el_vertex_surfaces(const rad_mesh *m, uint32_t *label)
{
    const rad_patch *cells = m->cell_first ? m->cells : m->patches;
    const uint32_t count = m->cell_first ? m->cell_count : m->patch_count;
    for (uint32_t v = 0; v < m->vertex_count; v++)
        label[v] = v;
    for (uint32_t c = 0; c < count; c++)
        for (int k = 1; k < rad_patch_corners(&cells[c]); k++) {
            uint32_t a = root(label, cells[c].v[0]), b = root(label, cells[c].v[k]);
            if (a < b)
                label[b] = a;
            else if (b < a)
                label[a] = b;
        }
    for (uint32_t v = 0; v < m->vertex_count; v++)
        label[v] = root(label, v);
}

static uint64_t vhash(uint32_t surf, rad_vec3 p)
{
    uint64_t w[3], h = 0x9E3779B97F4A7C15ull ^ surf;
    /* +0.0 makes -0 and 0 the same key. */
    double c[3] = {p.x + 0.0, p.y + 0.0, p.z + 0.0};
    memcpy(w, c, sizeof w);
    for (int k = 0; k < 3; k++) {
        h ^= w[k];
        h *= 0xff51afd7ed558ccdull;
        h ^= h >> 33;
    }
    return h;
}

static int same(rad_vec3 a, rad_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

uint32_t el_vt_find(const el_vtable *t, uint32_t surf, rad_vec3 p)
{
    size_t mask = t->cap - 1;
    for (size_t h = vhash(surf, p) & mask;; h = (h + 1) & mask) {
        uint32_t s = t->slot[h];
        if (!s)
            return RAD_NONE;
        if (t->Vsurf[s - 1] == surf && same(t->V[s - 1], p))
            return s - 1;
    }
}

/* Inserts vertex v (already in the caller's arrays); doubles the table
 * when half full.  -1 on OOM. */
int el_vt_insert(el_vtable *t, uint32_t v)
{
    if (2 * ((size_t)t->count + 1) > t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 1024;
        uint32_t *slot = calloc(cap, sizeof *slot);
        if (!slot)
            return -1;
        for (size_t k = 0; k < t->cap; k++)
            if (t->slot[k]) {
                uint32_t w = t->slot[k] - 1;
                size_t h = vhash(t->Vsurf[w], t->V[w]) & (cap - 1);
                while (slot[h])
                    h = (h + 1) & (cap - 1);
                slot[h] = t->slot[k];
            }
        free(t->slot);
        t->slot = slot;
        t->cap = cap;
    }
    size_t mask = t->cap - 1, h = vhash(t->Vsurf[v], t->V[v]) & mask;
    while (t->slot[h])
        h = (h + 1) & mask;
    t->slot[h] = v + 1;
    t->count++;
    return 0;
}

rad_vec3 el_midpoint(rad_vec3 a, rad_vec3 b)
{
    return rad_v3((a.x + b.x) * 0.5, (a.y + b.y) * 0.5, (a.z + b.z) * 0.5);
}
