/* mesh.h - meshing: scene polygons -> conforming patch mesh (rad_mesh in rad.h).
 *
 * Quads become an n×m grid of bilinear patches; triangles a regular
 * subdivision into k² triangles; convex polygons with more corners a fan of
 * triangles about the centroid, each subdivided and sharing the fan's edge
 * vertices.  Vertices are shared by neighbouring patches of one polygon.
 * A transmitting polygon gets a back side: the same cells facing -n.
 * Density comes from the polygon's own subdivision parameter, else from the
 * target patch size.
 *
 * Polygons smaller than the patch size (a modeller's export: many small
 * triangles) are grouped instead (cluster.c): neighbouring small polygons
 * of one object and material whose normals agree within 30° form a
 * surface whose cells share vertices, and the surface is cut into clusters
 * about one patch size across, each one patch of several cells (rad_mesh's
 * cell layer).  So the patch size sets the patch count whatever the
 * triangles' size.  A small polygon without such a neighbour is meshed on
 * its own, as any polygon.
 *
 * Before both, points within 1e-6 of the scene's diagonal are welded
 * (weld.c), and coplanar neighbouring polygons of one object and material
 * are meshed as one planar region on a grid of the patch size (region.c);
 * narrow regions of a curved surface are meshed across their facets
 * (smooth.c).  Small parts (a connected set of polygons of one object
 * under 0.1 × the patch size every way, or that thin across and at most a
 * patch long, a baluster: parts.c) are taken out first: the
 * faces of the small parts of one object and material in one cube of a
 * grid of 2 × the patch size, normals within 30°, are the cells of one
 * shared patch, each cell on vertices of its own; each part shows its own
 * B through the elements.  docs/surfaces.md has the rules.
 */
#ifndef RAD_MESH_H
#define RAD_MESH_H

#include "../core/rad.h"
#include "../scene/scene.h"

/* The largest patch (and element) count a solution may have unless told
 * otherwise: the memory check's first line of defence. */
#define RAD_MESH_DEFAULT_MAX_PATCHES 2000000u

/* cos 30° (a modeller's auto-smooth angle): neighbouring small polygons of
 * one object and material whose normals agree within it are one surface
 * (cluster.c); where they meet, the surface bends, no other surface meets
 * it (elements/contact.c). */
/* The default patch edge is the scene's bounding-box diagonal divided by
 * this.  34 (it was 24 while triangulated inputs were meshed about four
 * times finer than asked): report/hemicube.md, section 2, has the sweep. */
#define RAD_MESH_DIAGONAL_DIVISIONS 34.0
/* ... and for a factor query (`ff`, validate's catalog: rad_solve_options.
 * surface_factors), 24.  F_AB between a few plain surfaces gains nothing
 * from finer patches, and the near-surface rules of hemicube/rows.c reach
 * a set number of patch diameters: at / 34 they reach less far, and two
 * catalog pairs (squares 0.05 and 0.1 apart) went from -0.25 %/-0.34 % to
 * -0.61 %/-0.78 % (report/hemicube.md, section 2). */
#define RAD_MESH_FACTOR_DIVISIONS 24.0

#define RAD_MESH_SURFACE_COS 0.86602540378443865

/* {0} means defaults. */
typedef struct rad_mesh_options {
    /* Target patch edge length in scene units.  0 = the polygons' own
     * subdivision parameters, and for polygons without one, the default
     * (scene bounding-box diagonal / 34). A positive value overrides the
     * polygons' parameters. */
    double patch_size;
    /* The default patch edge is the scene's bounding-box diagonal / this;
     * 0 = RAD_MESH_DIAGONAL_DIVISIONS. */
    double divisions;
    /* Refuse to build more patches than this; 0 = RAD_MESH_DEFAULT_MAX_PATCHES. */
    uint32_t max_patches;
    /* 1 = never group polygons (clusters, planar regions, curved
     * surfaces): every polygon gets its own patches (one patch per
     * triangle of a modeller's export). */
    int no_clusters;
} rad_mesh_options;

/* Builds the patch mesh.  Counts the patches first and refuses with
 * RAD_ERR_LIMIT (message gives the count and the memory estimate) before
 * allocating when the count exceeds max_patches.  Caller owns *out. */
int rad_mesh_build(const rad_scene *scene, const rad_mesh_options *opt, rad_mesh **out,
                   rad_error *err);

/* Pairs the two sides of every transmitting polygon's cells into m->twin
 * (rad.h), from the layout rad_mesh_build makes: a transmitting polygon's
 * patches are consecutive, its front cells and then their back twins in the
 * same order.  NULL twin when nothing transmits.  RAD_ERR_CORRUPT when the
 * layout is not that (a damaged solution file); RAD_ERR_NOMEM. */
int rad_mesh_link_twins(rad_mesh *m, const rad_scene *scene, rad_error *err);

/* Number of patches rad_mesh_build would make, without allocating them;
 * UINT64_MAX if it overflows (or memory for the grouping runs out).  Past
 * 1.5 × max_patches, planar regions are not cut and the count is their
 * estimate (area / grid cell); once the regions cut make more than
 * max_patches, the rest are not cut and the count is theirs so far: in
 * both cases more than the limit, not exact. */
uint64_t rad_mesh_count(const rad_scene *scene, const rad_mesh_options *opt);

/* A patch size (scene units) at which rad_mesh_build makes at most `limit`
 * patches with the other options of opt (found by growing the size until
 * rad_mesh_count agrees): the advice of messages that ask for a larger
 * --patch-size.  A polygon's own subdivision is overridden by it. */
double rad_mesh_size_for(const rad_scene *scene, const rad_mesh_options *opt, uint64_t limit);

/* The patch edge length used when neither the option nor a polygon sets one
 * (the diagonal / RAD_MESH_DIAGONAL_DIVISIONS). */
double rad_mesh_default_patch_size(const rad_scene *scene);

/* The edge opt asks for: its patch_size, else the diagonal / its divisions
 * (opt may be NULL: the defaults). */
double rad_mesh_patch_size(const rad_scene *scene, const rad_mesh_options *opt);

/* Centre (area centroid) and area of the cell with corners V[v[0..3]]
 * (v[3] == RAD_NONE: a triangle), measured projected on the unit normal n.
 * 0, or -1 when the area is not positive and finite. */
int rad_cell_geometry(const rad_vec3 *V, const uint32_t v[4], rad_vec3 n, rad_vec3 *center,
                      double *area);

/* 1 when a and b are the same cell: corners, polygon, object, material,
 * centre, normal and area all equal. */
int rad_patch_same(const rad_patch *a, const rad_patch *b);

/* The point of cell v (a triangle, or a quad as two triangles) nearest to
 * p into *out, and its squared distance from p. */
double rad_cell_nearest(const rad_vec3 *V, const uint32_t v[4], rad_vec3 p, rad_vec3 *out);

/* An empty mesh for the solution reader to fill; NULL on OOM. Caller owns. */
rad_mesh *rad_mesh_alloc(uint32_t vertex_count, uint32_t patch_count);
/* Gives m a cell layer of cell_count cells (zeroed, cell_first zeroed);
 * -1 on OOM. */
int rad_mesh_alloc_cells(rad_mesh *m, uint32_t cell_count);
void rad_mesh_destroy(rad_mesh *m); /* NULL does nothing */

/* Checks the mesh invariants (indices in range, area > 0, unit normals, no
 * NaN; cells of one patch share its object and material and sum to its
 * area, a patch of one cell is that cell). RAD_OK or RAD_ERR_CORRUPT. */
int rad_mesh_check(const rad_mesh *m, uint32_t polygon_count, uint32_t object_count,
                   uint32_t material_count, rad_error *err);

#endif /* RAD_MESH_H */
