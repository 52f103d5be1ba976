/* elements.h - elements: detail where the light changes (substructuring,
 * Cohen, Greenberg, Immel & Brock 1986: patches shoot, elements receive).
 *
 * The element data (rad_elements) belongs to the solution
 * (solution.h); this module computes with it: the gather of each element's
 * B from the patch solution, what the renderer draws for elements, and the
 * refinement that decides where elements are needed.  Only refinement
 * renders (element hemi-cubes and light visibility, on the caller's
 * engine); gathering and drawing read stored data only.
 */
#ifndef RAD_ELEMENTS_H
#define RAD_ELEMENTS_H

#include "../../hemicube/hemicube.h"
#include "../../render/render.h"
#include "../solution/solution.h"

/* -------------------------------------------------- gather (element_gather.c) */

/* B_e of every element from the patch solution s->B (and the punctual
 * lights' direct irradiance), by the gather in solution.h's rad_elements.  What a relight calls:
 * no hemi-cube, no item buffer. */
int rad_elements_gather(const rad_solution *s, rad_elements *el, rad_error *err);

/* rad_elements_gather in two steps, so that F's entries can go in between
 * (a relight: F and the elements' rows never in memory together).  What
 * the gather reads of F is the patches' irradiance from all but the direct
 * sources, for the interpolated elements: into *Hi (patch_count × bands,
 * caller owns; NULL when el interpolates none), while F is loaded.  The
 * gather proper then needs of F only H, through rad_solution_irradiance
 * (s->irradiance once F is released), and el's rows. */
int rad_elements_patch_indirect(const rad_solution *s, const rad_elements *el, double **Hi,
                                rad_error *err);
int rad_elements_gather_from(const rad_solution *s, rad_elements *el, const double *Hi,
                             rad_error *err);

/* H_d,e of every element per band, mesh->patch_count × bands into the
 * caller's buffer: Σ_l I_l h_le with the intensities solved with, or its
 * patch's H_d,p for a level-0 element and for elements without light_h. */
int rad_elements_direct_irradiance(const rad_solution *s, const rad_elements *el, double *Hd,
                                   rad_error *err);

/* τ_p H_twin(p) per patch and band (patch_count × bands, caller owns *out)
 * when the mesh has two-sided sheets, else *out NULL: the exitance a sheet
 * lets through from its other side, at patch resolution, as the element
 * gather adds it.  What the gather renderer adds to a sheet's own E. */
int rad_elements_transmitted(const rad_solution *s, double **out, rad_error *err);

/* ------------------------------------------------------------ drawing (draw.c) */

/* What the renderer should draw for each element of el (el->mesh->patch_count
 * × bands into out) or, with el NULL, each patch of s: B, except that an
 * element that sees nothing (an empty row and B = E: buried under a block)
 * and touches one that sees something is drawn with the affine
 * extrapolation of those it touches, so that its darkness does not bleed
 * into the visible elements through the vertex averages; and that a level-0
 * element in a cluster (a cell of a patch of several) is drawn with the
 * affine fit, at its centre, of its patch's B and its neighbouring
 * patches' (so clusters do not show as flat tiles).  rm is the mesh
 * drawn (rad_elements_render_mesh; for patches, s->mesh) and cells_of its
 * cell -> element map (NULL: the identity). */
int rad_elements_drawn_radiosity(const rad_solution *s, const rad_elements *el,
                                 const rad_mesh *rm, const uint32_t *cells_of, double *out,
                                 rad_error *err);

/* The vertex radiosities the renderer draws rm with (rm->vertex_count ×
 * bands into vertex_B): each cell carries its element's (or patch's) drawn
 * B (rad_elements_drawn_radiosity, also written to drawn when not NULL),
 * fitted to the vertices by RN_FIT_QUADRATIC for elements (the fans of
 * rad_elements_render_mesh) and by the paper's rule for patches.  Same
 * rm, el and cells_of as rad_elements_drawn_radiosity. */
int rad_elements_vertex_radiosity(const rad_solution *s, const rad_elements *el,
                                  const rad_mesh *rm, const uint32_t *cells_of, double *drawn,
                                  double *vertex_B, rad_error *err);

/* The cells of s->mesh as level-0 elements (a patch of one cell, or each
 * cell of a cluster: rad.h), B_e = B_p, no rows: what a clustered mesh
 * without elements is drawn as (rad_render_solution), its clusters'
 * cells drawn smoothly (rad_elements_drawn_radiosity).  Caller owns *out. */
int rad_elements_of_cells(const rad_solution *s, rad_elements **out, rad_error *err);

/* The mesh to draw: every leaf element is split into a fan of triangles
 * about its centre, through its corners and the vertices of finer
 * neighbours that lie on its edges (each fan triangle's `center` is the
 * element's, where its B belongs; the apex, drawn with the element's own B,
 * is the vertex count of el's mesh plus the element's index).  *cells_of
 * gets, per cell of *out, its element (the cells of one element are
 * consecutive).  Caller owns both.  Vertex radiosities for it come from
 * rn_vertex_radiosity_fit with RN_FIT_QUADRATIC. */
int rad_elements_render_mesh(const rad_elements *el, rad_mesh **out, uint32_t **cells_of,
                             rad_error *err);

/* ------------------------------------------------------- refinement (refine.c) */

/* The refinement threshold when none is given (threshold 0), the one
 * place it is written; RAD_REFINE_OFF, or any negative threshold, asks for
 * no adaptive elements. */
#define RAD_DEFAULT_REFINE_THRESHOLD 1e-3
#define RAD_REFINE_OFF (-1.0)

/* {0} means defaults: adaptive elements at RAD_DEFAULT_REFINE_THRESHOLD. */
typedef struct rad_refine_options {
    /* > 0 splits elements, starting from the patches, where what is drawn
     * misses what finer elements gather: an element's four children are
     * gathered (probes), and it splits when the mean difference between
     * their B and the drawn radiosity at their centres, as a fraction of the
     * brightest non-emitting patch's B (any band), times the element's area
     * over its patch's, exceeds this threshold; until none does or they
     * reach min_element_size.  0 = RAD_DEFAULT_REFINE_THRESHOLD; < 0
     * (RAD_REFINE_OFF) = no adaptive elements. */
    double threshold;
    double min_element_size;   /* smallest element edge, scene units; 0 = 1/8 of its patch's */
    uint32_t levels;           /* > 0: split every patch this many times instead, whatever
                                * the threshold (uniform elements: references, benchmarks) */
    uint32_t max_elements;     /* refuse to make more; 0 = RAD_MESH_DEFAULT_MAX_PATCHES */
    /* The scene's punctual lights as the hemi-cube takes them
     * (scene->light_count entries; may be NULL without lights), and the
     * resolution of their item buffers (the one the patch power used). */
    const hc_light *lights;
    uint32_t light_resolution;
    /* 1 = every adaptive element gets its row from a hemi-cube of its own
     * (the method before interpolated elements: a reference, and slow);
     * 0 = interpolated elements wherever nothing rests on the surface
     * (solution.h). */
    int element_hemicubes;
    /* 1 = an element where another surface meets its patch gets a whole
     * hemi-cube (the method before issue 36: a reference); 0 = a near view
     * of what lies within twice its patch's size, the rest from the
     * patch's own row (refine.c's near_reach). */
    int whole_contacts;
    /* Called once, when refinement has read all it needs of F's entries
     * (the patches' indirect irradiance, the light through sheets) and
     * before the first element row: from then on it reads only which rows
     * exist and their counts, so the caller may release the entries (the
     * pipeline does when the rows are safe in the solve's file: the matrix
     * and the element rows need not be in memory together).  NULL: none. */
    void (*entries_read)(void *user);
    void *entries_read_user;
} rad_refine_options;

/* Builds s->elements (replacing any) from the patch solution s->B, as opt
 * says (threshold < 0 and levels 0: removes them).  Renders on hc, an
 * engine for s->mesh (whose exact marks decide which element-to-patch
 * factors are exact): the lights' visibility at the elements, one item
 * buffer per emitter stratum and refinement pass, and a hemi-cube for each
 * element that is not interpolated (refine.c says which). */
int rad_elements_refine(rad_solution *s, hc_engine *hc, const rad_refine_options *opt,
                        rad_error *err);

#endif /* RAD_ELEMENTS_H */
