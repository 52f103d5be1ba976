/* mesh_internal.h - what the files of radiosity/mesh/ share; private to the
 * folder (the public contract is mesh.h).
 */
#ifndef RAD_MESH_INTERNAL_H
#define RAD_MESH_INTERNAL_H

#include "mesh.h"

/* How the small polygons of a scene are grouped (cluster.c).  A polygon is
 * on the cluster path when it is eligible (mesh.c: it would be one cell at
 * this patch size, and it does not transmit) and shares an edge with
 * another eligible polygon of its surface; every other polygon is meshed
 * on its own as before.  Clusters are numbered in the order of their first
 * (lowest) polygon, and list their polygons in ascending order. */
typedef struct mesh_clusters {
    uint32_t count;        /* clusters: one patch each */
    uint32_t *of;          /* polygon -> its cluster, RAD_NONE off the cluster path */
    uint32_t *first;       /* count + 1: cluster k's polygons are member[first[k] .. first[k+1]) */
    uint32_t *member;
    uint32_t *vkey;        /* scene point -> its vertex (cluster-path polygons' points only):
                            * one per surface and exact position */
    uint32_t vkeys;        /* vertices on the cluster path */
    uint8_t *vboundary;    /* per vertex: on its surface's outline */
} mesh_clusters;

/* Groups the eligible polygons (eligible[i] = 1) into clusters of about
 * `size` (the patch edge length); pos: each scene point's weld id
 * (mesh_weld), so that points at one place join.  *out is zeroed first;
 * free it with mesh_clusters_free.  RAD_OK or RAD_ERR_NOMEM. */
int mesh_cluster(const rad_scene *s, const uint8_t *eligible, const uint32_t *pos, double size,
                 mesh_clusters *out, rad_error *err);
void mesh_clusters_free(mesh_clusters *c);

/* The root of x in the union-find forest up (cluster.c), halving paths. */
uint32_t mesh_uf_find(uint32_t *up, uint32_t x);

/* Points within this share of the scene's diagonal are one (mesh.c's
 * weld; region.c's T-junctions). */
#define MESH_WELD 1e-6

/* The 30° of RAD_MESH_SURFACE_COS for facets of one curved surface
 * (region.c, smooth.c), widened by 1e-3 in the cosine (0.11°): facets
 * exactly 30° apart (a 12-sided cylinder's, every other one of 24) are
 * then one surface whatever the rounding of their normals, which an
 * export's slivers on float coordinates move by up to 1e-4 rad (7.5e-5
 * measured on bench_atrium's split hall). */
#define MESH_FACET_COS (RAD_MESH_SURFACE_COS - 1e-3)

/* Weld (weld.c): id[k] for each of the scene's points, equal for points
 * within eps of the first point of that id (first[id]); *count ids.  Both
 * arrays hold point_count entries.  0, or -1 out of memory. */
int mesh_weld(const rad_scene *s, double eps, uint32_t *id, uint32_t *first, uint32_t *count);

/* Small parts (parts.c): a part (polygons of one object sharing welded
 * points) whose bounding box's diagonal is under MESH_PART_SMALL × the
 * patch size, or, along its principal axes, whose box's diagonal is at
 * most MESH_PART_FIT × the size and second-largest extent under
 * MESH_PART_SMALL × the size (thin: a baluster),
 * each polygon one cell, touching no other polygon, shares a patch with
 * the small parts of its object and material in its cube of a grid of
 * MESH_PART_GRID × the patch size whose normals lie within 30°
 * (docs/surfaces.md). */
#define MESH_PART_SMALL 0.1
#define MESH_PART_FIT 1.0
#define MESH_PART_GRID 2.0

typedef struct mesh_parts {
    uint32_t count;   /* shared patches */
    uint32_t *of;     /* polygon -> its shared patch, RAD_NONE when meshed otherwise */
    uint32_t *first;  /* count + 1: patch k's polygons are member[first[k] .. first[k+1]) */
    uint32_t *member; /* ascending within a patch */
    uint64_t points;  /* the members' corners: each cell has vertices of its own */
} mesh_parts;

/* Finds the small parts among the candidates (small[i] = 1: one cell at
 * this size, opaque, no subdivision of its own: MESH_REGION_SMALL) and
 * groups them; pos/npos from mesh_weld.  *out zeroed first; free with
 * mesh_parts_free.  0, or -1 out of memory. */
int mesh_parts_find(const rad_scene *s, const uint32_t *pos, uint32_t npos, const uint8_t *small,
                    double size, mesh_parts *out);
void mesh_parts_free(mesh_parts *p);

/* How a polygon may enter a planar region (region.c), decided by mesh.c. */
enum {
    MESH_REGION_OFF = 0, /* never: transmits, keeps its own subdivision, or degenerate */
    MESH_REGION_SMALL,   /* one cell at this size (the clusters' kind) */
    MESH_REGION_ALONE,   /* larger, and meshed well on its own */
    MESH_REGION_SPLIT    /* larger, and poor on its own (many sides, or long and thin) */
};

/* Planar regions (region.c): coplanar neighbouring polygons meshed as one.
 * Regions are numbered by their lowest polygon; region r holds patches
 * pfirst[r]..pfirst[r+1], its cells and vertices [vfirst[r], vfirst[r+1])
 * of V, which the patches and cells index.  Patch p's cells are
 * cell[cfirst[p] .. cfirst[p+1]). */
typedef struct mesh_regions {
    uint32_t count;
    uint32_t *of;     /* polygon -> its region, RAD_NONE when meshed otherwise */
    uint32_t *lead;   /* region -> its lowest polygon */
    uint32_t *pfirst, *vfirst;
    rad_patch *patch, *cell;
    uint32_t *cfirst;
    rad_vec3 *V;
    uint8_t *Vb;      /* per vertex: on its region's outline */
    uint32_t patches, cells, vertices;
    int overflow;     /* the regions would need too many patches or cells */
    double estimate;  /* with overflow: the patches they would make, about;
                       * with estimate_only: the estimated regions' */
    int estimate_only;
    uint64_t cell_limit, patch_limit;
    size_t cap_p, cap_f, cap_c, cap_v, cap_b;
} mesh_regions;

/* Finds and meshes the regions of polygons with mode[i] != OFF at patch
 * size `size` (pos/first/npos from mesh_weld), stopping with
 * out->overflow set once the patches (estimated from the area before a
 * region is cut) pass 1.5 × max_patches or the cells 16 × max_patches +
 * 10^6, or the regions cut so far made more than max_patches (out->estimate
 * then their count): a patch size far too small must be refused, not
 * tried, and a mesh past the limit is not cut further.  *out zeroed first; free
 * with mesh_regions_free.  RAD_OK (out->overflow set when too large),
 * RAD_ERR_NOMEM, RAD_ERR_INVALID (a cell without area). */
int mesh_regions_build(const rad_scene *s, const uint32_t *pos, const uint32_t *first,
                       uint32_t npos, const uint8_t *mode, double size, uint64_t max_patches,
                       int estimate_only, mesh_regions *out, rad_error *err);

/* With estimate_only, no region is cut: each adds area / its grid cell to
 * out->estimate and its polygons' of[] is MESH_REGION_ESTIMATED (for a
 * patch size search, rad_mesh_size_for). */
#define MESH_REGION_ESTIMATED (RAD_NONE - 1)
void mesh_regions_free(mesh_regions *r);

/* 1 (and out->estimate set) when `more` patches on top of out's would pass
 * 1.5 × its patch limit: the region is not cut, and the mesh refused. */
int mesh_regions_over(mesh_regions *out, double more);

/* Appends to out one region's ncell cells (corners: ids 0..nu-1 into pos,
 * normals set), cell k in patch patch_of[k] (0..np-1): the vertices in
 * order of first use, cells grouped by patch, areas and centres measured,
 * each patch from its cells (mesh_patch_of_cells), outline flags from
 * unmatched edges.  0, -1 out of memory, -2 a cell or patch without area. */
int mesh_regions_emit(mesh_regions *out, const rad_patch *cells, size_t ncell,
                      const uint32_t *patch_of, uint32_t np, const rad_vec3 *pos, uint32_t nu);

/* Meshes the nm polygons mem[] of one curved surface of narrow facets
 * (smooth.c) into patches of about size across, appended to out as one
 * region.  0, -1 out of memory, -2 a cell without area, -3 too many. */
int mesh_smooth_mesh(const rad_scene *s, const uint32_t *pos, const uint32_t *first,
                     const uint32_t *mem, uint32_t nm, double size, mesh_regions *out);

/* A rounded position (or cube) and the index it belongs to; mesh_key_cmp
 * orders by key, then index (cells.c), for qsort. */
typedef struct mesh_key {
    int64_t k[3];
    uint32_t r;
} mesh_key;
int mesh_key_cmp(const void *a, const void *b);

/* The corners in[0..n) of a closed outline (elt bytes each) into out
 * without repeats (a corner equal to the one before it, or the last equal
 * to the first); returns how many (cells.c). */
size_t mesh_ring_unique(const void *in, size_t n, void *out, size_t elt);

/* Grows *p (of *cap elements of elt bytes) to hold need, doubling
 * (cells.c); 0, or -1 out of memory with *p kept. */
int mesh_grow(void **p, size_t *cap, size_t need, size_t elt);

/* Cells along an edge of length len for a target patch edge `size`
 * (mesh.c); UINT64_MAX when more than a uint32 holds. */
uint64_t mesh_divisions(double len, double size);

/* A patch of n cells (mesh.c): area their sum, normal their area-weighted
 * mean, centre their area centroid moved onto the nearest cell, whose
 * corners and polygon it carries; one cell is the patch.  -1 when the
 * normals cancel. */
int mesh_patch_of_cells(const rad_vec3 *V, const rad_patch *cells, uint32_t n, rad_patch *out);

#endif /* RAD_MESH_INTERNAL_H */
