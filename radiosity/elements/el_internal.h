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

/* ----------------------------------------------------- direct (direct.c) */

/* Strata per direct source of one cell: the four cells of its first split
 * (a cluster's strata are its cells). */
#define EL_STRATA 4u
/* At most this many strata (item buffers per refinement pass): beyond it,
 * elements get hemi-cubes of their own. */
#define EL_MAX_STRATA 1024u
/* The strata's item-buffer resolution when the caller gives none. */
#define EL_DIRECT_RESOLUTION 512u

typedef struct el_stratum el_stratum;

/* The direct sources of an element set (solution.h's interpolated
 * elements): the emitting patches, each cut into strata (direct.c). */
typedef struct el_sources {
    uint8_t *direct;   /* per patch of s->mesh: 1 = a direct source */
    uint32_t patches;  /* how many */
    el_stratum *st;    /* the strata, source by source in patch order */
    uint32_t count;
} el_sources;

/* Rows in compressed form: point k's entries are [start[k], start[k + 1]). */
typedef struct el_rows {
    uint64_t *start;
    uint32_t *col;
    float *val;
} el_rows;

/* The sources of s: the patches with E > 0 in some band.  Free with
 * el_sources_free (which takes NULL or a zeroed struct). */
int el_sources_make(const rad_solution *s, el_sources *src, rad_error *err);
void el_sources_free(el_sources *src);
void el_rows_free(el_rows *r);

/* The direct sources' entries of the points pts[0..count) (a point on its
 * patch, as a hemi-cube receiver, with normal[k] the normal of the cell it
 * lies on: in a cluster of a curved surface each cell has its own, and the
 * cluster's mean normal took 1.3 % off a sphere's elements' direct light,
 * issue 36) into *out, the caller's to free:
 * F_xj = Σ_s F(x → σ_s) v_s(x) over the strata of each source j, v_s from
 * an item buffer of resolution R rendered at the stratum (one per stratum
 * that some point faces; *renders counts them when not NULL). */
int el_direct_rows(const el_sources *src, hc_engine *hc, uint32_t R,
                   const hc_receiver *pts, const rad_vec3 *normal, uint32_t count, el_rows *out,
                   uint64_t *renders, rad_error *err);

/* --------------------------------------------- gather (element_gather.c) */

/* A field of the patches (n × bands) drawn as elements are (buried patches
 * extrapolated, quadratic vertex fits on the patches' fans), to be read at
 * points inside the patches: an interpolated element's indirect light. */
typedef struct el_interp {
    rad_mesh *rm;      /* the patches' fans */
    uint32_t *cells_of;
    uint32_t *first;   /* patch p's fans are [first[p], first[p + 1]) */
    double *vB;        /* the field at the fans' vertices, rm->vertex_count × bands */
} el_interp;

/* The patches' fans and the field's fit; free with el_interp_free (NULL
 * or zeroed: nothing). */
int el_interp_make(const rad_solution *s, const double *field, el_interp *ip, rad_error *err);
void el_interp_free(el_interp *ip);

/* The field at point x of patch p, per band, into out. */
void el_interp_at(const el_interp *ip, const rad_solution *s, uint32_t p, rad_vec3 x, double *out);

/* The patches' irradiance from everything but the direct sources:
 * H_i,p = Σ_{j: !direct[j]} F_pj B_j (0 without a row), n × bands into H. */
void el_patch_indirect(const rad_solution *s, const uint8_t *direct, double *H);


/* H_d,e of one element per band into hd: Σ_l I_l h_le from its own h[]
 * (light_count values), or for a level-0 element and without them its
 * patch's H_d,p from Hd (NULL: no direct light). */
void el_element_direct(const rad_solution *s, const double *Hd, const float *h, uint32_t p,
                       uint32_t level, double *hd);

/* B_e of one element of patch p from its row (col/val, count entries), its
 * direct irradiance hd, its interpolated indirect irradiance ind (NULL:
 * none) and the transmitted term Tr (NULL: none) into Be. */
void el_gather_one(const rad_solution *s, const double *hd, const double *ind, const double *Tr,
                   uint32_t p, uint32_t level, const uint32_t *col, const float *val,
                   uint32_t count, double *Be);

/* τ_p H_twin(p) per patch and band (n × bands) when the mesh has sheets,
 * else *out = NULL.  Caller owns *out. */
int el_transmitted(const rad_solution *s, double **out, rad_error *err);

/* ---------------------------------------------------- contact (contact.c) */

/* The polygons that meet each patch of s->mesh: those that reach the
 * patch's plane, inside the patch or along its edge, from in front of it
 * (an object standing on it, a wall at a floor's edge).  Patch p's are
 * poly[start[p] .. start[p + 1]).  Elements such a polygon touches get
 * hemi-cubes: part of them may be buried, and the light reflected onto
 * them changes faster than the patches show. */
typedef struct el_contacts {
    uint32_t *start;   /* patch count + 1 */
    uint32_t *poly;
    double tol;        /* the test's tolerance, scene units */
} el_contacts;

int el_contact_patches(const rad_solution *s, el_contacts *out, rad_error *err);
void el_contacts_free(el_contacts *c); /* NULL or zeroed: nothing */

/* Does polygon q (not the cell's own `polygon`) reach the plane of the
 * convex cell of `corners` corners V[v[k]] (normal n), inside the cell or
 * along its edge (within tol), from in front of it? */
int el_cell_touches(const rad_scene *sc, const rad_vec3 *V, const uint32_t *v, int corners,
                    rad_vec3 n, uint32_t polygon, uint32_t q, double tol);

/* Does the segment a-b pass through convex polygon q (its inside or its
 * outline, within tol)?  A contact element whose segment to its patch's
 * centre crosses a polygon that meets the patch lies on the other side of
 * it (beside a block whose foot covers the patch's centre, across a wall
 * the patch runs under): the patch's view is not its own. */
int el_segment_crosses(const rad_scene *sc, uint32_t q, rad_vec3 a, rad_vec3 b, double tol);

/* The far field of contact patches (refine.c's near views): a copy of the
 * rows F_pj of every patch some polygon meets (empty for the others),
 * taken before the pipeline may release F's entries. */
int el_contact_rows(const rad_solution *s, const el_contacts *c, el_rows *out, rad_error *err);

/* ---------------------------------------------------------- draw (draw.c) */

/* The crack-free mesh of the cells of m (see rad_elements_render_mesh). */
int el_fan_mesh(const rad_mesh *m, rad_mesh **out, uint32_t **cells_of, rad_error *err);

/* Does an element (of patch p, at level, with row_count entries and
 * radiosity Be) see nothing: an empty row and B = E (buried under a block)?
 * An interpolated element (interp) never does: its row holds only direct
 * sources. */
int el_sees_nothing(const rad_solution *s, uint32_t p, uint32_t level, int interp,
                    uint32_t row_count, const double *Be);

/* rad_elements_drawn_radiosity of any field of the cells (el's elements,
 * or with el NULL the patches), n × bands: the cells that see nothing (by
 * their own B) get the affine extrapolation of `field` at the seen cells
 * they touch, and the level-0 elements of clusters the affine fit of
 * pfield, the same field per patch of s->mesh (s->B for radiosity). */
int el_drawn_field(const rad_solution *s, const rad_elements *el, const rad_mesh *rm,
                   const uint32_t *cells_of, const double *field, const double *pfield,
                   double *out, rad_error *err);

/* The value drawn at point p of a cell whose fans are rm's cells
 * [first, first + count), from the vertex values vB: the interpolant in the
 * fan triangle that holds p best (barycentric weights in the plane of
 * normal). */
void el_drawn_at(const rad_mesh *rm, const double *vB, uint32_t bands, uint32_t first,
                 uint32_t count, rad_vec3 normal, rad_vec3 p, double *out);

#endif /* RAD_EL_INTERNAL_H */
