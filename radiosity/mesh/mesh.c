/* mesh.c - scene polygons -> the conforming patch mesh (mesh.h).
 *
 * Quads become an n×m grid of bilinear cells, triangles a regular k² split,
 * larger convex polygons a fan of triangles about their area centroid, each
 * split with one k so that neighbouring fan triangles share the vertices of
 * their common spoke.  Invariant of the output: every patch is planar and
 * convex with positive area A_i, corners counter-clockwise about the polygon
 * normal, centre = area centroid; vertices are shared within a polygon and
 * never across polygons (the paper averages vertex radiosities per polygon).
 * A polygon whose material transmits is a thin sheet: its cells are
 * followed by their back twins (the same cells reversed, on vertices of
 * their own, so the two sides never average together), and mesh->twin pairs
 * them (rad_mesh_link_twins, which the solution reader calls too).
 * The patch count is computed and checked against the limit before anything
 * is allocated.
 *
 * Polygons that would be one cell each, and that have neighbours of their
 * kind, are grouped into clusters instead (cluster.c): each cluster is one
 * patch of several cells, in the place of its first polygon; its cells'
 * vertices are shared across its surface.  The mesh then has a cell layer
 * (rad.h), in which every other patch is its own single cell.
 *
 * Planar regions (region.c) and curved surfaces of narrow facets
 * (smooth.c) are meshed whole before that, and placed as a cluster is, in
 * the place of their lowest polygon, their cells' vertices shared across
 * their polygons.
 */
#include "mesh_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ----------------------------------------------------------- mesh storage */

rad_mesh *rad_mesh_alloc(uint32_t vertex_count, uint32_t patch_count)
{
    rad_mesh *m = calloc(1, sizeof *m);
    if (!m)
        return NULL;
    /* Allocate at least one element so that an empty mesh still has arrays. */
    size_t nv = vertex_count ? vertex_count : 1, np = patch_count ? patch_count : 1;
    m->vertices = calloc(nv, sizeof *m->vertices);
    m->vertex_boundary = calloc(nv, sizeof *m->vertex_boundary);
    m->patches = calloc(np, sizeof *m->patches);
    if (!m->vertices || !m->vertex_boundary || !m->patches) {
        rad_mesh_destroy(m);
        return NULL;
    }
    m->vertex_count = vertex_count;
    m->patch_count = patch_count;
    return m;
}

int rad_mesh_alloc_cells(rad_mesh *m, uint32_t cell_count)
{
    free(m->cells);
    free(m->cell_first);
    m->cells = calloc(cell_count ? cell_count : 1, sizeof *m->cells);
    m->cell_first = calloc((size_t)m->patch_count + 1, sizeof *m->cell_first);
    if (!m->cells || !m->cell_first) {
        free(m->cells);
        free(m->cell_first);
        m->cells = NULL;
        m->cell_first = NULL;
        return -1;
    }
    m->cell_count = cell_count;
    return 0;
}

void rad_mesh_destroy(rad_mesh *m)
{
    if (!m)
        return;
    free(m->vertices);
    free(m->vertex_boundary);
    free(m->patches);
    free(m->twin);
    free(m->cells);
    free(m->cell_first);
    free(m);
}

int rad_patch_same(const rad_patch *a, const rad_patch *b)
{
    return memcmp(a->v, b->v, sizeof a->v) == 0 && a->polygon == b->polygon &&
           a->object == b->object && a->material == b->material && a->area == b->area &&
           a->center.x == b->center.x && a->center.y == b->center.y &&
           a->center.z == b->center.z && a->normal.x == b->normal.x &&
           a->normal.y == b->normal.y && a->normal.z == b->normal.z;
}

/* One cell (or patch) against the mesh: corners in range and distinct,
 * indices in range, positive area, finite centre, unit normal. */
static int check_cell(const rad_mesh *m, const rad_patch *p, const char *what, uint32_t i,
                      uint32_t polygon_count, uint32_t object_count, uint32_t material_count,
                      rad_error *err)
{
    int corners = rad_patch_corners(p);
    for (int c = 0; c < corners; c++) {
        if (p->v[c] >= m->vertex_count)
            return rad_fail(err, RAD_ERR_CORRUPT,
                            "mesh: %s %u: vertex index %u out of range (%u vertices)", what, i,
                            p->v[c], m->vertex_count);
        for (int d = 0; d < c; d++)
            if (p->v[d] == p->v[c])
                return rad_fail(err, RAD_ERR_CORRUPT, "mesh: %s %u: vertex %u used twice", what,
                                i, p->v[c]);
    }
    if (p->polygon >= polygon_count)
        return rad_fail(err, RAD_ERR_CORRUPT,
                        "mesh: %s %u: polygon %u out of range (%u polygons)", what, i, p->polygon,
                        polygon_count);
    if (p->object >= object_count)
        return rad_fail(err, RAD_ERR_CORRUPT, "mesh: %s %u: object %u out of range (%u objects)",
                        what, i, p->object, object_count);
    if (p->material >= material_count)
        return rad_fail(err, RAD_ERR_CORRUPT,
                        "mesh: %s %u: material %u out of range (%u materials)", what, i,
                        p->material, material_count);
    if (!isfinite(p->area) || !(p->area > 0.0))
        return rad_fail(err, RAD_ERR_CORRUPT, "mesh: %s %u: area %g is not positive", what, i,
                        p->area);
    if (!rad_finite3(p->center))
        return rad_fail(err, RAD_ERR_CORRUPT, "mesh: %s %u: centre is not finite", what, i);
    double nl = rad_length(p->normal);
    /* 1e-6: a unit vector stored in doubles is off by ~1e-16; anything
     * more than rounding means the normal was not normalised. */
    if (!rad_finite3(p->normal) || !(fabs(nl - 1.0) <= 1e-6))
        return rad_fail(err, RAD_ERR_CORRUPT, "mesh: %s %u: normal length %g is not 1", what, i,
                        nl);
    return RAD_OK;
}

/* The cell layer: cell_first counts every cell once, in order; a patch's
 * cells share its object and material and sum to its area; a patch of one
 * cell is that cell. */
static int check_cells(const rad_mesh *m, uint32_t polygon_count, uint32_t object_count,
                       uint32_t material_count, rad_error *err)
{
    if (!m->cells || !m->cell_first)
        return rad_fail(err, RAD_ERR_CORRUPT, "mesh: cell layer without its arrays");
    if (m->cell_first[0] != 0 || m->cell_first[m->patch_count] != m->cell_count)
        return rad_fail(err, RAD_ERR_CORRUPT, "mesh: the patches' cells do not cover the %u cells",
                        m->cell_count);
    for (uint32_t i = 0; i < m->patch_count; i++) {
        uint32_t c0 = m->cell_first[i], c1 = m->cell_first[i + 1];
        if (c1 <= c0 || c1 > m->cell_count)
            return rad_fail(err, RAD_ERR_CORRUPT, "mesh: patch %u: cells %u..%u out of order", i,
                            c0, c1);
        const rad_patch *p = &m->patches[i];
        double area = 0.0;
        for (uint32_t c = c0; c < c1; c++) {
            const rad_patch *q = &m->cells[c];
            int rc = check_cell(m, q, "cell", c, polygon_count, object_count, material_count, err);
            if (rc != RAD_OK)
                return rc;
            if (q->object != p->object || q->material != p->material)
                return rad_fail(err, RAD_ERR_CORRUPT,
                                "mesh: cell %u: object or material differs from its patch %u", c,
                                i);
            area += q->area;
        }
        /* 1e-9: the sum of a few hundred areas in another order */
        if (!(fabs(area - p->area) <= 1e-9 * p->area))
            return rad_fail(err, RAD_ERR_CORRUPT,
                            "mesh: patch %u: area %.17g but its cells sum to %.17g", i, p->area,
                            area);
        if (c1 - c0 == 1 && !rad_patch_same(&m->cells[c0], p))
            return rad_fail(err, RAD_ERR_CORRUPT, "mesh: patch %u: differs from its one cell", i);
    }
    return RAD_OK;
}

int rad_mesh_check(const rad_mesh *m, uint32_t polygon_count, uint32_t object_count,
                   uint32_t material_count, rad_error *err)
{
    if (!m)
        return rad_fail(err, RAD_ERR_USAGE, "mesh: no mesh");
    if ((m->vertex_count && (!m->vertices || !m->vertex_boundary)) ||
        (m->patch_count && !m->patches))
        return rad_fail(err, RAD_ERR_CORRUPT, "mesh: missing arrays");
    for (uint32_t k = 0; k < m->vertex_count; k++) {
        if (!rad_finite3(m->vertices[k]))
            return rad_fail(err, RAD_ERR_CORRUPT, "mesh: vertex %u is not finite", k);
        if (m->vertex_boundary[k] > 1)
            return rad_fail(err, RAD_ERR_CORRUPT, "mesh: vertex %u: boundary flag %u not 0 or 1",
                            k, m->vertex_boundary[k]);
    }
    for (uint32_t i = 0; i < m->patch_count; i++) {
        int rc = check_cell(m, &m->patches[i], "patch", i, polygon_count, object_count,
                            material_count, err);
        if (rc != RAD_OK)
            return rc;
    }
    if (m->cell_first || m->cells)
        return check_cells(m, polygon_count, object_count, material_count, err);
    return RAD_OK;
}

/* ---------------------------------------------------------------- density */

static uint64_t mul_sat(uint64_t a, uint64_t b)
{
    if (a && b > UINT64_MAX / a)
        return UINT64_MAX;
    return a * b;
}

static uint64_t add_sat(uint64_t a, uint64_t b)
{
    return a > UINT64_MAX - b ? UINT64_MAX : a + b;
}


/* The default edge: the diagonal / opt's divisions (the option unset or
 * not set for a patch size). */
static double diagonal_size(const rad_scene *scene, const rad_mesh_options *opt)
{
    rad_vec3 lo, hi;
    if (!rad_scene_bounds(scene, &lo, &hi))
        return 0.0;
    const double k = opt && opt->divisions > 0.0 ? opt->divisions : RAD_MESH_DIAGONAL_DIVISIONS;
    double d = rad_length(rad_sub(hi, lo)) / k;
    return isfinite(d) ? d : 0.0;
}

double rad_mesh_default_patch_size(const rad_scene *scene)
{
    return diagonal_size(scene, NULL);
}

double rad_mesh_patch_size(const rad_scene *scene, const rad_mesh_options *opt)
{
    return opt && opt->patch_size > 0.0 ? opt->patch_size : diagonal_size(scene, opt);
}

static int polygon_ok(const rad_scene *s, const rad_polygon *pg)
{
    return pg->point_count >= 3 && s->points &&
           (uint64_t)pg->first_point + pg->point_count <= s->point_count;
}

/* Area centroid of a convex polygon (fan from the first point). */
static rad_vec3 area_centroid(const rad_vec3 *p, uint32_t n, rad_vec3 normal)
{
    rad_vec3 c = rad_v3(0, 0, 0);
    double total = 0.0;
    for (uint32_t k = 1; k + 1 < n; k++) {
        double a = rad_dot(rad_cross(rad_sub(p[k], p[0]), rad_sub(p[k + 1], p[0])), normal);
        c = rad_add(c, rad_scale(rad_add(rad_add(p[0], p[k]), p[k + 1]), a / 3.0));
        total += a;
    }
    if (!(total > 0.0)) { /* cannot happen for a validated polygon; fall back to the mean */
        c = rad_v3(0, 0, 0);
        for (uint32_t k = 0; k < n; k++)
            c = rad_add(c, p[k]);
        return rad_scale(c, 1.0 / n);
    }
    return rad_scale(c, 1.0 / total);
}

/* How one polygon is split: a quad into nu×nv cells, anything else into
 * triangles each split k = nu ways (a fan for more than 3 points). */
typedef struct split {
    uint64_t nu, nv;
    uint64_t patches, vertices; /* UINT64_MAX when they overflow */
} split;

static split polygon_split(const rad_scene *s, const rad_polygon *pg, double opt_size,
                           double def_size)
{
    split r = {1, 1, 0, 0};
    const rad_vec3 *p = s->points + pg->first_point;
    uint32_t n = pg->point_count;
    int use_param = !(opt_size > 0.0) && pg->subdiv_u > 0;
    double size = opt_size > 0.0 ? opt_size : def_size;
    if (n == 4) {
        if (use_param) {
            r.nu = pg->subdiv_u;
            r.nv = pg->subdiv_v ? pg->subdiv_v : pg->subdiv_u;
        } else {
            double lu = fmax(rad_length(rad_sub(p[1], p[0])), rad_length(rad_sub(p[2], p[3])));
            double lv = fmax(rad_length(rad_sub(p[2], p[1])), rad_length(rad_sub(p[3], p[0])));
            r.nu = mesh_divisions(lu, size);
            r.nv = mesh_divisions(lv, size);
        }
        if (r.nu == UINT64_MAX || r.nv == UINT64_MAX) {
            r.patches = r.vertices = UINT64_MAX;
            return r;
        }
        r.patches = mul_sat(r.nu, r.nv);
        r.vertices = mul_sat(r.nu + 1, r.nv + 1);
        return r;
    }
    uint64_t k;
    if (use_param) {
        k = pg->subdiv_u;
    } else {
        double longest = 0.0;
        for (uint32_t i = 0; i < n; i++)
            longest = fmax(longest, rad_length(rad_sub(p[(i + 1) % n], p[i])));
        if (n > 4) { /* the fan's spokes are edges of its triangles too */
            rad_vec3 c = area_centroid(p, n, pg->normal);
            for (uint32_t i = 0; i < n; i++)
                longest = fmax(longest, rad_length(rad_sub(p[i], c)));
        }
        k = mesh_divisions(longest, size);
    }
    r.nu = r.nv = k;
    if (k == UINT64_MAX) {
        r.patches = r.vertices = UINT64_MAX;
        return r;
    }
    uint64_t k2 = mul_sat(k, k);
    if (n == 3) {
        r.patches = k2;
        r.vertices = mul_sat(k + 1, k + 2) / 2; /* (k+1)(k+2) is even */
    } else {
        r.patches = mul_sat(n, k2);
        /* centre + n spokes of k points + n triangles' k(k-1)/2 own points */
        r.vertices = add_sat(add_sat(1, mul_sat(n, k)), mul_sat(n, mul_sat(k, k - 1) / 2));
    }
    return r;
}


static int transmits(const rad_scene *scene, const rad_polygon *pg)
{
    return pg->material < scene->material_count &&
           rad_material_transmits(&scene->materials[pg->material], scene->band_count);
}

/* What rad_mesh_build and rad_mesh_count share: the weld, the planar
 * regions (region.c), which polygons are grouped into clusters (eligible:
 * one cell at this size, no subdivision of its own, opaque, not in a
 * region; grouped: eligible with a neighbour of its kind, see cluster.c)
 * and the totals.  `cells` counts the cell layer's cells when there is one
 * (some polygon grouped or in a region), else 0. */
typedef struct plan {
    double opt_size, def_size;
    uint32_t *pos, *first, npos; /* weld ids (mesh_weld) */
    mesh_regions rg;
    mesh_clusters cl;
    mesh_parts pt; /* small parts' shared patches (parts.c) */
    uint64_t patches, vertices, cells;
} plan;

static void plan_free(plan *pl)
{
    free(pl->pos);
    free(pl->first);
    mesh_regions_free(&pl->rg);
    mesh_clusters_free(&pl->cl);
    mesh_parts_free(&pl->pt);
}

static int distinct_points(const plan *pl, const rad_polygon *pg)
{
    for (uint32_t a = 0; a < pg->point_count; a++)
        for (uint32_t b = 0; b < a; b++)
            if (pl->pos[pg->first_point + a] == pl->pos[pg->first_point + b])
                return 0;
    return 1;
}

/* How polygon pg may enter a planar region (mesh_internal.h). */
static uint8_t region_mode(const rad_scene *scene, const plan *pl, const rad_polygon *pg)
{
    if (!polygon_ok(scene, pg) || pg->object >= scene->object_count ||
        pg->material >= scene->material_count || transmits(scene, pg) ||
        (!(pl->opt_size > 0.0) && pg->subdiv_u > 0) || !distinct_points(pl, pg))
        return MESH_REGION_OFF;
    split sp = polygon_split(scene, pg, pl->opt_size, pl->def_size);
    if (sp.patches == 1)
        return MESH_REGION_SMALL;
    const rad_vec3 *p = scene->points + pg->first_point;
    if (pg->point_count > 4)
        return MESH_REGION_SPLIT;
    double longest = 0.0;
    for (uint32_t k = 0; k < pg->point_count; k++)
        longest = fmax(longest, rad_length(rad_sub(p[(k + 1) % pg->point_count], p[k])));
    if (pg->point_count == 3) /* its k² cells have its shape */
        return longest * longest > 4.0 * (1 + 1e-9) * pg->area ? MESH_REGION_SPLIT
                                                               : MESH_REGION_ALONE;
    double lu = fmax(rad_length(rad_sub(p[1], p[0])), rad_length(rad_sub(p[2], p[3])));
    double lv = fmax(rad_length(rad_sub(p[2], p[1])), rad_length(rad_sub(p[3], p[0])));
    double cu = lu / (double)sp.nu, cv = lv / (double)sp.nv;
    return fmax(cu, cv) > 4.0 * (1 + 1e-9) * fmin(cu, cv) ? MESH_REGION_SPLIT : MESH_REGION_ALONE;
}

/* The weld and the planar regions. */
static int plan_regions(const rad_scene *scene, const rad_mesh_options *opt, int estimate,
                        plan *pl, rad_error *err)
{
    const char *src = scene->source ? scene->source : "<memory>";
    const uint32_t np = scene->polygon_count;
    pl->pos = malloc(((size_t)scene->point_count + 1) * sizeof *pl->pos);
    pl->first = malloc(((size_t)scene->point_count + 1) * sizeof *pl->first);
    uint8_t *mode = calloc((size_t)np + 1, 1), *small = calloc((size_t)np + 1, 1);
    rad_vec3 lo, hi;
    double eps = rad_scene_bounds(scene, &lo, &hi) ? MESH_WELD * rad_length(rad_sub(hi, lo)) : 0;
    if (!pl->pos || !pl->first || !mode || !small ||
        mesh_weld(scene, eps, pl->pos, pl->first, &pl->npos) != 0) {
        free(mode);
        free(small);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: mesh: out of memory", src);
    }
    for (uint32_t i = 0; i < np && !(opt && opt->no_clusters); i++)
        mode[i] = region_mode(scene, pl, &scene->polygons[i]);
    /* Small parts first: their polygons go nowhere else. */
    const double size = pl->opt_size > 0.0 ? pl->opt_size : pl->def_size;
    for (uint32_t i = 0; i < np; i++)
        small[i] = mode[i] == MESH_REGION_SMALL;
    if (mesh_parts_find(scene, pl->pos, pl->npos, small, size, &pl->pt) != 0) {
        free(mode);
        free(small);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: mesh: out of memory", src);
    }
    for (uint32_t i = 0; i < np; i++)
        if (pl->pt.of[i] != RAD_NONE)
            mode[i] = MESH_REGION_OFF;
    free(small);
    uint64_t limit = opt && opt->max_patches ? opt->max_patches : RAD_MESH_DEFAULT_MAX_PATCHES;
    int rc = mesh_regions_build(scene, pl->pos, pl->first, pl->npos, mode, size, limit, estimate,
                                &pl->rg, err);
    free(mode);
    return rc;
}

/* estimate: planar regions counted by area (no cutting), for a patch
 * size search. */
static int make_plan(const rad_scene *scene, const rad_mesh_options *opt, int estimate,
                     plan *pl, rad_error *err)
{
    memset(pl, 0, sizeof *pl);
    pl->opt_size = opt && opt->patch_size > 0.0 ? opt->patch_size : 0.0;
    pl->def_size = diagonal_size(scene, opt);
    const uint32_t np = scene->polygon_count;
    int rc = plan_regions(scene, opt, estimate, pl, err);
    if (rc != RAD_OK || pl->rg.overflow) {
        /* too many: the regions' estimate, at least past the limit */
        uint64_t limit = opt && opt->max_patches ? opt->max_patches : RAD_MESH_DEFAULT_MAX_PATCHES;
        double e = pl->rg.estimate;
        pl->patches = pl->vertices = rc != RAD_OK ? UINT64_MAX
                                     : e >= 1.8e19 ? UINT64_MAX
                                     : e > (double)limit ? (uint64_t)e
                                     : limit + 1;
        return rc;
    }
    uint8_t *eligible = calloc((size_t)np + 1, 1);
    if (!eligible)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: mesh: out of memory",
                        scene->source ? scene->source : "<memory>");
    for (uint32_t i = 0; i < np && !(opt && opt->no_clusters); i++) {
        const rad_polygon *pg = &scene->polygons[i];
        if (!polygon_ok(scene, pg) || pg->object >= scene->object_count ||
            pg->material >= scene->material_count || transmits(scene, pg) ||
            (!(pl->opt_size > 0.0) && pg->subdiv_u > 0) || pl->rg.of[i] != RAD_NONE ||
            pl->pt.of[i] != RAD_NONE || !distinct_points(pl, pg))
            continue;
        eligible[i] = polygon_split(scene, pg, pl->opt_size, pl->def_size).patches == 1;
    }
    rc = mesh_cluster(scene, eligible, pl->pos, pl->opt_size > 0.0 ? pl->opt_size : pl->def_size,
                      &pl->cl, err);
    free(eligible);
    if (rc != RAD_OK)
        return rc;
    uint64_t tp = 0, tv = 0;
    for (uint32_t i = 0; i < np; i++) {
        const rad_polygon *pg = &scene->polygons[i];
        if (!polygon_ok(scene, pg) || pl->cl.of[i] != RAD_NONE || pl->rg.of[i] != RAD_NONE ||
            pl->pt.of[i] != RAD_NONE)
            continue;
        split sp = polygon_split(scene, pg, pl->opt_size, pl->def_size);
        /* a transmitting sheet has a back side of as many cells again */
        uint64_t sides = transmits(scene, pg) ? 2 : 1;
        tp = add_sat(tp, mul_sat(sides, sp.patches));
        tv = add_sat(tv, mul_sat(sides, sp.vertices));
    }
    const uint64_t part_cells = pl->pt.count ? pl->pt.first[pl->pt.count] : 0;
    pl->cells = pl->cl.count || pl->rg.count || pl->pt.count
                    ? add_sat(add_sat(add_sat(tp, pl->cl.first[pl->cl.count]), pl->rg.cells),
                              part_cells)
                    : 0;
    pl->patches = add_sat(add_sat(add_sat(tp, pl->cl.count), pl->rg.patches), pl->pt.count);
    if (estimate)
        pl->patches = add_sat(pl->patches, pl->rg.estimate >= 1.8e19 ? UINT64_MAX
                                                                     : (uint64_t)pl->rg.estimate);
    pl->vertices = add_sat(add_sat(add_sat(tv, pl->cl.vkeys), pl->rg.vertices), pl->pt.points);
    return RAD_OK;
}

static uint64_t plan_count(const rad_scene *scene, const rad_mesh_options *opt, int estimate)
{
    plan pl;
    int rc = make_plan(scene, opt, estimate, &pl, NULL);
    uint64_t n = rc == RAD_OK ? pl.patches : UINT64_MAX;
    plan_free(&pl);
    return n;
}

double rad_mesh_size_for(const rad_scene *scene, const rad_mesh_options *opt, uint64_t limit)
{
    rad_mesh_options o = opt ? *opt : (rad_mesh_options){0};
    double size = rad_mesh_patch_size(scene, &o);
    if (!(size > 0.0) || limit == 0)
        return size;
    /* counting stops past the limit (mesh_regions_build) */
    o.max_patches = limit < UINT32_MAX ? (uint32_t)limit : UINT32_MAX;
    /* Planar regions counted by their area first (cutting them at a size
     * far too small would cost what the limit guards against), then the
     * mesher's exact count; N falls about as 1/size²: start there, then grow
     * by 10 % until it agrees (clusters and whole polygons round
     * differently). */
    for (int exact = 0; exact < 2; exact++) {
        o.patch_size = size;
        uint64_t n = plan_count(scene, &o, !exact);
        for (int k = 0; k < 64 && n == UINT64_MAX; k++) { /* too many to count: coarser */
            size *= 4.0;
            o.patch_size = size;
            n = plan_count(scene, &o, !exact);
        }
        if (n > limit)
            size *= sqrt((double)n / (double)limit);
        for (int k = 0; k < 64; k++) {
            o.patch_size = size;
            n = plan_count(scene, &o, !exact);
            if (n <= limit)
                break;
            size *= n == UINT64_MAX ? 10.0 : 1.1;
        }
    }
    return size;
}

uint64_t rad_mesh_count(const rad_scene *scene, const rad_mesh_options *opt)
{
    if (!scene)
        return 0;
    return plan_count(scene, opt, 0);
}

/* ---------------------------------------------------------------- building */

typedef struct builder {
    rad_mesh *m;
    uint32_t nv, np, nc; /* filled so far: vertices, patches, cells */
    const rad_scene *s;
    uint32_t polygon;
} builder;

static uint32_t add_vertex(builder *b, rad_vec3 p, int boundary)
{
    uint32_t k = b->nv++;
    b->m->vertices[k] = p;
    b->m->vertex_boundary[k] = (uint8_t)(boundary != 0);
    return k;
}


/* Appends a patch; area and centre from its corners projected on the
 * polygon normal (so a polygon within the planarity tolerance still tiles
 * exactly its Newell area). */
static int add_patch(builder *b, uint32_t v0, uint32_t v1, uint32_t v2, uint32_t v3)
{
    const rad_polygon *pg = &b->s->polygons[b->polygon];
    rad_patch *p = &b->m->patches[b->np];
    p->v[0] = v0;
    p->v[1] = v1;
    p->v[2] = v2;
    p->v[3] = v3;
    p->polygon = b->polygon;
    p->object = pg->object;
    p->material = pg->material;
    p->normal = pg->normal;
    if (rad_cell_geometry(b->m->vertices, p->v, pg->normal, &p->center, &p->area) != 0)
        return -1;
    b->np++;
    return 0;
}

static void build_quad(builder *b, const rad_vec3 *q, uint32_t nu, uint32_t nv, int *bad)
{
    uint32_t base = b->nv;
    for (uint32_t j = 0; j <= nv; j++) {
        double t = (double)j / nv;
        for (uint32_t i = 0; i <= nu; i++) {
            double u = (double)i / nu;
            /* P(u,t): bilinear blend of the corners; u along p0->p1, t along p1->p2 */
            rad_vec3 p = rad_add(
                rad_add(rad_scale(q[0], (1 - u) * (1 - t)), rad_scale(q[1], u * (1 - t))),
                rad_add(rad_scale(q[2], u * t), rad_scale(q[3], (1 - u) * t)));
            add_vertex(b, p, i == 0 || i == nu || j == 0 || j == nv);
        }
    }
    uint32_t row = nu + 1;
    for (uint32_t j = 0; j < nv; j++)
        for (uint32_t i = 0; i < nu; i++) {
            uint32_t a = base + j * row + i;
            if (add_patch(b, a, a + 1, a + 1 + row, a + row) != 0)
                *bad = 1;
        }
}

/* Position of grid point (a, b), a + b <= k, in a triangle's list of its
 * (k+1)(k+2)/2 points, stored row by row in b. */
static size_t tri_index(uint32_t k, uint32_t a, uint32_t b)
{
    return (size_t)b * (k + 1) - (size_t)b * (b - (b > 0)) / 2 + a;
}

/* Emits the k² cells of a triangle whose grid points have the global
 * indices g[tri_index(k, a, b)]: "upward" cells keep the corner order of
 * (p0, p1, p2) and so does every "downward" one. */
static void tri_cells(builder *b, const uint32_t *g, uint32_t k, int *bad)
{
    for (uint32_t y = 0; y < k; y++)
        for (uint32_t x = 0; x + y < k; x++) {
            uint32_t p00 = g[tri_index(k, x, y)], p10 = g[tri_index(k, x + 1, y)],
                     p01 = g[tri_index(k, x, y + 1)];
            if (add_patch(b, p00, p10, p01, RAD_NONE) != 0)
                *bad = 1;
            if (x + y + 2 <= k) {
                uint32_t p11 = g[tri_index(k, x + 1, y + 1)];
                if (add_patch(b, p10, p11, p01, RAD_NONE) != 0)
                    *bad = 1;
            }
        }
}

/* Grid point p0 + a/k (p1 - p0) + b/k (p2 - p0). */
static rad_vec3 tri_point(rad_vec3 p0, rad_vec3 p1, rad_vec3 p2, uint32_t k, uint32_t a,
                          uint32_t b)
{
    return rad_add(p0, rad_add(rad_scale(rad_sub(p1, p0), (double)a / k),
                               rad_scale(rad_sub(p2, p0), (double)b / k)));
}

static void build_triangle(builder *b, const rad_vec3 *p, uint32_t k, uint32_t *g, int *bad)
{
    for (uint32_t y = 0; y <= k; y++)
        for (uint32_t x = 0; x + y <= k; x++) {
            rad_vec3 q = (x == k) ? p[1] : (y == k) ? p[2] : tri_point(p[0], p[1], p[2], k, x, y);
            g[tri_index(k, x, y)] = add_vertex(b, q, x == 0 || y == 0 || x + y == k);
        }
    tri_cells(b, g, k, bad);
}

/* Fan about the area centroid C: triangle j is (C, P_j, P_j+1).  The points
 * of spoke C->P_j are made once and used by triangles j-1 and j, so the fan
 * is conforming and their coordinates are identical by construction. */
static void build_fan(builder *b, const rad_vec3 *p, uint32_t n, uint32_t k, uint32_t *g,
                      rad_vec3 normal, int *bad)
{
    rad_vec3 C = area_centroid(p, n, normal);
    uint32_t centre = add_vertex(b, C, 0);
    uint32_t spokes = b->nv; /* spoke j point t (1..k) is spokes + j*k + t-1 */
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t t = 1; t <= k; t++)
            add_vertex(b, t == k ? p[j] : rad_lerp(C, p[j], (double)t / k), t == k);
    for (uint32_t j = 0; j < n; j++) {
        uint32_t j1 = (j + 1) % n;
        for (uint32_t y = 0; y <= k; y++)
            for (uint32_t x = 0; x + y <= k; x++) {
                uint32_t idx;
                if (x == 0 && y == 0)
                    idx = centre;
                else if (y == 0)
                    idx = spokes + j * k + (x - 1);
                else if (x == 0)
                    idx = spokes + j1 * k + (y - 1);
                else
                    idx = add_vertex(b, tri_point(C, p[j], p[j1], k, x, y), x + y == k);
                g[tri_index(k, x, y)] = idx;
            }
        tri_cells(b, g, k, bad);
    }
}

/* The back side of the cells [first_patch, b->np), made on copies of the
 * vertices [first_vertex, b->nv): each cell again, in the same order, with
 * its corners reversed so that they run counter-clockwise about -n. */
static void build_back_side(builder *b, uint32_t first_patch, uint32_t first_vertex, int *bad)
{
    const uint32_t cells = b->np - first_patch, nverts = b->nv - first_vertex;
    for (uint32_t k = 0; k < nverts; k++)
        add_vertex(b, b->m->vertices[first_vertex + k], b->m->vertex_boundary[first_vertex + k]);
    for (uint32_t c = 0; c < cells; c++) {
        const rad_patch *f = &b->m->patches[first_patch + c];
        uint32_t v[4], shift = nverts;
        int n = rad_patch_corners(f);
        for (int k = 0; k < n; k++)
            v[k] = f->v[(n - k) % n] + shift; /* v0, v(n-1), ..., v1 */
        rad_patch *p = &b->m->patches[b->np];
        *p = *f;
        memcpy(p->v, v, (size_t)n * sizeof *v);
        p->normal = rad_scale(f->normal, -1.0);
        if (rad_cell_geometry(b->m->vertices, p->v, p->normal, &p->center, &p->area) != 0)
            *bad = 1;
        b->np++;
    }
}

int rad_mesh_link_twins(rad_mesh *m, const rad_scene *scene, rad_error *err)
{
    const char *src = scene->source ? scene->source : "<memory>";
    free(m->twin);
    m->twin = NULL;
    int any = 0;
    for (uint32_t i = 0; i < m->patch_count && !any; i++)
        any = m->patches[i].material < scene->material_count &&
              rad_material_transmits(&scene->materials[m->patches[i].material], scene->band_count);
    if (!any)
        return RAD_OK;
    uint32_t *twin = malloc((size_t)m->patch_count * sizeof *twin);
    if (!twin)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: mesh: out of memory", src);
    for (uint32_t i = 0; i < m->patch_count; i++)
        twin[i] = RAD_NONE;
    /* Runs of consecutive patches of one polygon: a transmitting one holds
     * its front cells, then their back twins in the same order. */
    for (uint32_t a = 0, z; a < m->patch_count; a = z) {
        const rad_patch *p = &m->patches[a];
        for (z = a + 1; z < m->patch_count && m->patches[z].polygon == p->polygon; z++)
            ;
        if (p->material >= scene->material_count || p->polygon >= scene->polygon_count ||
            !rad_material_transmits(&scene->materials[p->material], scene->band_count))
            continue;
        const rad_polygon *pg = &scene->polygons[p->polygon];
        uint32_t half = (z - a) / 2;
        int ok = (z - a) % 2 == 0;
        for (uint32_t k = 0; k < half && ok; k++) {
            const rad_patch *f = &m->patches[a + k], *r = &m->patches[a + half + k];
            double size = sqrt(f->area);
            ok = f->material == r->material && f->object == r->object &&
                 rad_patch_corners(f) == rad_patch_corners(r) &&
                 rad_dot(f->normal, pg->normal) > 0.0 && rad_dot(r->normal, pg->normal) < 0.0 &&
                 rad_length(rad_sub(f->center, r->center)) <= 1e-9 * size &&
                 fabs(f->area - r->area) <= 1e-9 * f->area;
            twin[a + k] = a + half + k;
            twin[a + half + k] = a + k;
        }
        if (!ok) {
            free(twin);
            return rad_fail(err, RAD_ERR_CORRUPT,
                            "%s: mesh: polygon '%s' transmits but its patches are not front "
                            "cells followed by their back twins",
                            src, pg->name ? pg->name : "");
        }
    }
    m->twin = twin;
    return RAD_OK;
}

/* Polygons member[0..count) as one patch (appended) and its cells, one
 * cell each; the patch's area is the cells', its normal their
 * area-weighted mean, its centre their area centroid moved onto the
 * nearest cell (its home: the patch carries that cell's corners and
 * polygon).  With cl, the cells stand on the surface's shared vertices
 * (vmap: vertex key -> mesh vertex, made on first use): a cluster (a
 * cluster of one polygon is exactly that cell).  Without, each cell on
 * vertices of its own, all on the outline: a shared patch of small parts
 * (parts.c), whose faces never average together. */
static void build_grouped(builder *b, const uint32_t *member, uint32_t count,
                          const mesh_clusters *cl, uint32_t *vmap, int *bad)
{
    const rad_scene *s = b->s;
    rad_mesh *m = b->m;
    const uint32_t c0 = b->nc;
    m->cell_first[b->np] = c0;
    for (uint32_t q = 0; q < count; q++) {
        const uint32_t i = member[q];
        const rad_polygon *pg = &s->polygons[i];
        rad_patch *c = &m->cells[b->nc++];
        c->v[3] = RAD_NONE;
        for (uint32_t j = 0; j < pg->point_count; j++) {
            const rad_vec3 pt = s->points[pg->first_point + j];
            if (!cl) {
                c->v[j] = add_vertex(b, pt, 1);
                continue;
            }
            uint32_t key = cl->vkey[pg->first_point + j];
            if (vmap[key] == RAD_NONE)
                vmap[key] = add_vertex(b, pt, cl->vboundary[key]);
            c->v[j] = vmap[key];
        }
        c->polygon = i;
        c->object = pg->object;
        c->material = pg->material;
        c->normal = pg->normal;
        if (rad_cell_geometry(m->vertices, c->v, c->normal, &c->center, &c->area) != 0) {
            *bad = 1;
            return;
        }
    }
    if (mesh_patch_of_cells(m->vertices, &m->cells[c0], b->nc - c0, &m->patches[b->np++]) != 0)
        *bad = 1;
}

/* Polygon i on its own: a grid of quads, a subdivided triangle or a fan;
 * its back side when it transmits; each patch its own cell when the mesh
 * has a cell layer. */
static void build_polygon(builder *b, const plan *pl, uint32_t i, uint32_t *g, int *bad)
{
    const rad_scene *scene = b->s;
    rad_mesh *m = b->m;
    const rad_polygon *pg = &scene->polygons[i];
    const rad_vec3 *p = scene->points + pg->first_point;
    split sp = polygon_split(scene, pg, pl->opt_size, pl->def_size);
    uint32_t first_patch = b->np, first_vertex = b->nv;
    b->polygon = i;
    if (pg->point_count == 4)
        build_quad(b, p, (uint32_t)sp.nu, (uint32_t)sp.nv, bad);
    else if (pg->point_count == 3)
        build_triangle(b, p, (uint32_t)sp.nu, g, bad);
    else
        build_fan(b, p, pg->point_count, (uint32_t)sp.nu, g, pg->normal, bad);
    if (!*bad && transmits(scene, pg))
        build_back_side(b, first_patch, first_vertex, bad);
    for (uint32_t q = first_patch; m->cells && !*bad && q < b->np; q++) {
        m->cell_first[q] = b->nc;
        m->cells[b->nc++] = m->patches[q];
    }
}

/* Region r of the plan (region.c made it): its vertices, then its patches
 * and their cells, copied with the vertex indices moved to the mesh's. */
static void build_region(builder *b, const mesh_regions *rg, uint32_t r)
{
    rad_mesh *m = b->m;
    const uint32_t v0 = rg->vfirst[r], shift = b->nv;
    for (uint32_t v = v0; v < rg->vfirst[r + 1]; v++)
        add_vertex(b, rg->V[v], rg->Vb[v]);
    for (uint32_t p = rg->pfirst[r]; p < rg->pfirst[r + 1]; p++) {
        m->cell_first[b->np] = b->nc;
        for (uint32_t c = rg->cfirst[p]; c < rg->cfirst[p + 1]; c++) {
            rad_patch *q = &m->cells[b->nc++];
            *q = rg->cell[c];
            for (int k = 0; k < rad_patch_corners(q); k++)
                q->v[k] = q->v[k] - v0 + shift;
        }
        rad_patch *q = &m->patches[b->np++];
        *q = rg->patch[p];
        for (int k = 0; k < rad_patch_corners(q); k++)
            q->v[k] = q->v[k] - v0 + shift;
    }
}

int rad_mesh_build(const rad_scene *scene, const rad_mesh_options *opt, rad_mesh **out,
                   rad_error *err)
{
    if (out)
        *out = NULL;
    if (!scene || !out)
        return rad_fail(err, RAD_ERR_USAGE, "rad_mesh_build: no scene or no output");
    const char *src = scene->source ? scene->source : "<memory>";
    for (uint32_t i = 0; i < scene->polygon_count; i++) {
        const rad_polygon *pg = &scene->polygons[i];
        if (!polygon_ok(scene, pg) || pg->object >= scene->object_count ||
            pg->material >= scene->material_count)
            return rad_fail(err, RAD_ERR_INVALID,
                            "%s: polygon '%s': points, object or material out of range", src,
                            pg->name ? pg->name : "");
    }
    uint32_t limit = opt && opt->max_patches ? opt->max_patches : RAD_MESH_DEFAULT_MAX_PATCHES;
    plan pl;
    int rc = make_plan(scene, opt, 0, &pl, err);
    if (rc != RAD_OK) {
        plan_free(&pl);
        return rc;
    }
    const uint64_t np = pl.patches, nv = pl.vertices;
    double size = rad_mesh_patch_size(scene, opt);
    if (np > limit || nv >= UINT32_MAX || pl.cells > UINT32_MAX || np == 0) {
        plan_free(&pl);
        if (np == 0)
            return rad_fail(err, RAD_ERR_INVALID, "%s: mesh: the scene has no polygons", src);
        if (np <= limit)
            return rad_fail(err, RAD_ERR_LIMIT,
                            "%s: mesh: %llu vertices exceed %u; use a larger --patch-size (now %g)",
                            src, (unsigned long long)nv, UINT32_MAX - 1, size);
        char count[32];
        if (np == UINT64_MAX)
            snprintf(count, sizeof count, "more than 2^64");
        else
            snprintf(count, sizeof count, "%llu", (unsigned long long)np);
        return rad_fail(err, RAD_ERR_LIMIT,
                        "%s: mesh: %s patches exceed the limit of %u; use --patch-size %.3g or "
                        "larger (now %g)",
                        src, count, limit, rad_mesh_size_for(scene, opt, limit), size);
    }

    /* Scratch for one triangle's grid-point indices, sized for the largest
     * k; and the cluster path's vertex map. */
    uint64_t kmax = 0;
    for (uint32_t i = 0; i < scene->polygon_count; i++) {
        const rad_polygon *pg = &scene->polygons[i];
        if (pg->point_count != 4 && pl.cl.of[i] == RAD_NONE && pl.rg.of[i] == RAD_NONE &&
            pl.pt.of[i] == RAD_NONE) {
            split sp = polygon_split(scene, pg, pl.opt_size, pl.def_size);
            if (sp.nu > kmax)
                kmax = sp.nu;
        }
    }
    uint32_t *g = NULL, *vmap = NULL;
    rad_mesh *m = NULL;
    /* kmax² <= np: no overflow */
    if ((kmax > 0 && !(g = malloc((size_t)((kmax + 1) * (kmax + 2) / 2) * sizeof *g))) ||
        !(vmap = malloc(((size_t)pl.cl.vkeys + 1) * sizeof *vmap)) ||
        !(m = rad_mesh_alloc((uint32_t)nv, (uint32_t)np)) ||
        (pl.cells && rad_mesh_alloc_cells(m, (uint32_t)pl.cells) != 0)) {
        free(g);
        free(vmap);
        rad_mesh_destroy(m);
        plan_free(&pl);
        return rad_fail(err, RAD_ERR_NOMEM,
                        "%s: mesh: out of memory for %llu patches and %llu vertices", src,
                        (unsigned long long)np, (unsigned long long)nv);
    }
    for (uint32_t k = 0; k < pl.cl.vkeys; k++)
        vmap[k] = RAD_NONE;
    builder b = {m, 0, 0, 0, scene, 0};
    int bad = 0;
    for (uint32_t i = 0; i < scene->polygon_count && !bad; i++) {
        const rad_polygon *pg = &scene->polygons[i];
        const uint32_t k = pl.cl.of[i], r = pl.rg.of[i], t = pl.pt.of[i];
        if (t != RAD_NONE) { /* a shared patch of small parts, in its first polygon's place */
            if (pl.pt.member[pl.pt.first[t]] == i)
                build_grouped(&b, pl.pt.member + pl.pt.first[t], pl.pt.first[t + 1] - pl.pt.first[t],
                              NULL, NULL, &bad);
        } else if (r != RAD_NONE) { /* a planar region in its first polygon's place */
            if (pl.rg.lead[r] == i)
                build_region(&b, &pl.rg, r);
        } else if (k != RAD_NONE) { /* grouped: the cluster in its first polygon's place */
            if (pl.cl.member[pl.cl.first[k]] == i)
                build_grouped(&b, pl.cl.member + pl.cl.first[k], pl.cl.first[k + 1] - pl.cl.first[k],
                              &pl.cl, vmap, &bad);
        } else {
            build_polygon(&b, &pl, i, g, &bad);
        }
        if (bad) {
            free(g);
            free(vmap);
            rad_mesh_destroy(m);
            plan_free(&pl);
            return rad_fail(err, RAD_ERR_INVALID,
                            "%s: polygon '%s': a patch has no area at this subdivision "
                            "(the polygon is too thin); use a larger patch size",
                            src, pg->name ? pg->name : "");
        }
    }
    if (m->cell_first)
        m->cell_first[np] = b.nc;
    free(g);
    free(vmap);
    plan_free(&pl);
    RAD_ASSERT(b.nv == nv && b.np == np && b.nc == pl.cells);
    rc = rad_mesh_link_twins(m, scene, err);
    if (rc != RAD_OK) {
        rad_mesh_destroy(m);
        return rc;
    }
    *out = m;
    return RAD_OK;
}
