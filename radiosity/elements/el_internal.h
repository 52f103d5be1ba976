/* el_internal.h - what the files of radiosity/elements/ share; private to
 * the folder (the public contract is elements.h).
 */
#ifndef RAD_EL_INTERNAL_H
#define RAD_EL_INTERNAL_H

#include "elements.h"

/* ------------------------------------------------- vertices (vertices.c) */

/* The surface of each vertex of m (m->vertex_count labels into label):
 * vertices joined through the cells of m (its cell layer when it has one)
 * share the label, the lowest vertex index among them (see vertices.c). */
void el_vertex_surfaces(const rad_mesh *m, uint32_t *label);

/* Open-addressing table of vertex indices keyed by (surface, exact
 * position).  The vertex arrays live with the caller; the table keeps a
 * pointer to them, refreshed after each growth. */
typedef struct el_vtable {
    uint32_t *slot;          /* vertex + 1, 0 = empty */
    size_t cap;              /* power of two */
    uint32_t count;
    const rad_vec3 *V;       /* positions */
    const uint32_t *Vsurf;   /* surface of each vertex */
} el_vtable;

/* The vertex of surface surf at exactly p, or RAD_NONE. */
uint32_t el_vt_find(const el_vtable *t, uint32_t surf, rad_vec3 p);

/* Inserts vertex v (already in the caller's arrays); doubles the table
 * when half full.  -1 on OOM. */
int el_vt_insert(el_vtable *t, uint32_t v);

/* (a + b)/2, the same double from either end. */
rad_vec3 el_midpoint(rad_vec3 a, rad_vec3 b);

/* ----------------------------------------------------- gather (gather.c) */

/* H_d,e of one element per band into hd: Σ_l I_l h_le from its own h[]
 * (light_count values), or for a level-0 element and without them its
 * patch's H_d,p from Hd (NULL: no direct light). */
void el_element_direct(const rad_solution *s, const double *Hd, const float *h, uint32_t p,
                       uint32_t level, double *hd);

/* B_e of one element of patch p from its row (col/val, count entries), its
 * direct irradiance hd and the transmitted term Tr (NULL: none) into Be. */
void el_gather_one(const rad_solution *s, const double *hd, const double *Tr, uint32_t p,
                   uint32_t level, const uint32_t *col, const float *val, uint32_t count,
                   double *Be);

/* τ_p H_twin(p) per patch and band (n × bands) when the mesh has sheets,
 * else *out = NULL.  Caller owns *out. */
int el_transmitted(const rad_solution *s, double **out, rad_error *err);

/* ---------------------------------------------------------- draw (draw.c) */

/* The crack-free mesh of the cells of m (see rad_elements_render_mesh). */
int el_fan_mesh(const rad_mesh *m, rad_mesh **out, uint32_t **cells_of, rad_error *err);

/* Does an element (of patch p, at level, with row_count entries and
 * radiosity Be) see nothing: an empty row and B = E (buried under a block)? */
int el_sees_nothing(const rad_solution *s, uint32_t p, uint32_t level, uint32_t row_count,
                    const double *Be);

#endif /* RAD_EL_INTERNAL_H */
