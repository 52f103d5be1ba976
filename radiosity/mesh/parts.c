/* parts.c - small parts share patches (mesh_internal.h, docs/surfaces.md).
 *
 * A part is a connected set of polygons of one object: polygons that share
 * a welded point (weld.c).  A baluster, a screw or a fillet is a part much
 * smaller than a patch; meshed on its own, each of its faces would be a
 * patch with a hemi-cube row and a row of N² memory of its own (a baluster
 * several: its long narrow faces are cut for shape).  A part is small when
 * each of its polygons would be one cell (so it has at most four corners,
 * does not transmit and has no subdivision of its own), no other polygon
 * shares a point with it, and it is small in one of two ways:
 *   - its bounding box's diagonal is under MESH_PART_SMALL (0.1) × the
 *     patch size (a screw), or
 *   - it is thin: measured along its own principal axes (the eigenvectors
 *     of its surface's area-weighted covariance, so the rule does not
 *     depend on how the part is turned), its box's diagonal is at most
 *     MESH_PART_FIT (1) × the patch size, so that it fits within a patch,
 *     and the box's second-largest extent is under MESH_PART_SMALL × the
 *     size: under 0.1 × the size across, up to a patch long (a baluster, a
 *     rail, a cable).
 * The first is a case of the second, kept apart only against rounding.
 * Longer than a patch, a thin part is meshed as before: its light changes
 * along it as a patch's would, and one shared row taken at one point of
 * it would miss that.
 *
 * The polygons of the small parts of one object and material whose parts'
 * centres lie in one cube of a grid over the scene's bounds, of side
 * MESH_PART_GRID × the patch size (a patch's longest extent), and whose
 * normals lie within 30° of the first one's, are the cells of one shared
 * patch (so a closed part's faces go to up to six of them, one per side:
 * its row, one hemi-cube about that side's normal, sees what those faces
 * see).  Its ρ and E are the material's, its area the sum of its cells',
 * its normal their area-weighted mean and its centre on the cell nearest
 * their area centroid (mesh_patch_of_cells), as a non-planar patch's.
 * Each cell keeps its polygon and
 * its own vertices (a part's faces never average together), and is drawn
 * with the shared patch's id, so the parts still occlude.  A part's own B
 * comes from the elements (elements/refine.c: the cells of a shared patch
 * are leaves with their own direct light).
 *
 * A group of one polygon is left to be meshed as before (a patch of its
 * own; a scene of nothing else keeps no cell layer).
 *
 * Invariant: every other polygon of a small part is in exactly one shared
 * patch of two or more cells;
 * a shared patch's cells have one object, one material, their parts'
 * centres in one grid cube and normals within 30° of its first cell's.
 */
#include "mesh_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct part_key {
    uint32_t object, material;
    int64_t cube[3];
    uint32_t polygon;
} part_key;

static int part_key_cmp(const void *a, const void *b)
{
    const part_key *x = a, *y = b;
    if (x->object != y->object)
        return x->object < y->object ? -1 : 1;
    if (x->material != y->material)
        return x->material < y->material ? -1 : 1;
    for (int k = 0; k < 3; k++)
        if (x->cube[k] != y->cube[k])
            return x->cube[k] < y->cube[k] ? -1 : 1;
    return x->polygon < y->polygon ? -1 : x->polygon > y->polygon;
}

/* (shared patch, polygon) pairs, ordered by patch then polygon. */
static int pair_cmp(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    if (x[0] != y[0])
        return x[0] < y[0] ? -1 : 1;
    return x[1] < y[1] ? -1 : x[1] > y[1];
}

void mesh_parts_free(mesh_parts *p)
{
    free(p->of);
    free(p->first);
    free(p->member);
    memset(p, 0, sizeof *p);
}

/* Union-find of the candidate polygons into parts (up[i] = i for the
 * others); bad[root] = 1 where a part shares a point with a polygon that
 * is not a candidate. */
static void join_parts(const rad_scene *s, const uint32_t *pos, uint32_t npos,
                       const uint8_t *small, uint32_t *up, uint32_t *owner, uint8_t *bad)
{
    const uint32_t np = s->polygon_count;
    for (uint32_t w = 0; w < npos; w++)
        owner[w] = RAD_NONE;
    for (uint32_t i = 0; i < np; i++) {
        up[i] = i;
        bad[i] = 0;
    }
    for (uint32_t i = 0; i < np; i++) {
        const rad_polygon *pg = &s->polygons[i];
        for (uint32_t k = 0; k < pg->point_count; k++) {
            const uint32_t w = pos[pg->first_point + k];
            if (!small[i]) {
                owner[w] = RAD_NONE - 1; /* a point of a polygon that is not a candidate */
                continue;
            }
            if (owner[w] == RAD_NONE)
                owner[w] = i;
            else if (owner[w] != RAD_NONE - 1 && s->polygons[owner[w]].object == pg->object) {
                uint32_t a = mesh_uf_find(up, owner[w]), b = mesh_uf_find(up, i);
                if (a != b)
                    up[a > b ? a : b] = a > b ? b : a;
            }
        }
    }
    for (uint32_t i = 0; i < np; i++) {
        const rad_polygon *pg = &s->polygons[i];
        for (uint32_t k = 0; small[i] && k < pg->point_count; k++)
            if (owner[pos[pg->first_point + k]] == RAD_NONE - 1)
                bad[mesh_uf_find(up, i)] = 1;
    }
}

/* A part's surface moments about its box's centre o, summed over its
 * polygons' fan triangles signed by the polygon's normal (so any simple
 * polygon counts once): area a, first moment m1 = ∫ x dA, second moment
 * m2 = ∫ x xᵀ dA (xx yy zz xy xz yz); then its principal axes, and its
 * points' extent along each from o. */
typedef struct part_shape {
    double a, m1[3], m2[6];
    rad_vec3 axis[3];
    double lo[3], hi[3];
} part_shape;

/* Adds triangle (p, q, r) of signed area a, relative to o: ∫ x dA =
 * a t / 3 and ∫ x xᵀ dA = a / 12 (p pᵀ + q qᵀ + r rᵀ + t tᵀ), t = p + q + r. */
static void add_triangle(part_shape *sh, rad_vec3 o, const rad_vec3 *p, uint32_t k, double a)
{
    rad_vec3 v[4] = {rad_sub(p[0], o), rad_sub(p[k + 1], o), rad_sub(p[k + 2], o)};
    v[3] = rad_add(rad_add(v[0], v[1]), v[2]);
    sh->a += a;
    sh->m1[0] += a * v[3].x / 3.0;
    sh->m1[1] += a * v[3].y / 3.0;
    sh->m1[2] += a * v[3].z / 3.0;
    for (int j = 0; j < 4; j++) {
        const double c[6] = {v[j].x * v[j].x, v[j].y * v[j].y, v[j].z * v[j].z,
                             v[j].x * v[j].y, v[j].x * v[j].z, v[j].y * v[j].z};
        for (int m = 0; m < 6; m++)
            sh->m2[m] += a / 12.0 * c[m];
    }
}

/* The eigenvectors of the symmetric 3 × 3 matrix a (overwritten) into the
 * columns of v, by cyclic Jacobi rotations: v is a product of rotations,
 * orthonormal whatever a is, so a box along its columns always bounds. */
static void jacobi3(double a[3][3], double v[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            v[i][j] = i == j;
    for (int sweep = 0; sweep < 16; sweep++) {
        const double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
        if (!(off > 1e-14 * (fabs(a[0][0]) + fabs(a[1][1]) + fabs(a[2][2]))))
            return;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (a[p][q] == 0.0)
                    continue;
                const double th = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                const double t = (th >= 0.0 ? 1.0 : -1.0) / (fabs(th) + sqrt(th * th + 1.0));
                const double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 3; k++) { /* a J */
                    const double kp = a[k][p], kq = a[k][q];
                    a[k][p] = c * kp - s * kq;
                    a[k][q] = s * kp + c * kq;
                }
                for (int k = 0; k < 3; k++) { /* Jᵀ (a J) */
                    const double pk = a[p][k], qk = a[q][k];
                    a[p][k] = c * pk - s * qk;
                    a[q][k] = s * pk + c * qk;
                }
                for (int k = 0; k < 3; k++) { /* v J */
                    const double kp = v[k][p], kq = v[k][q];
                    v[k][p] = c * kp - s * kq;
                    v[k][q] = s * kp + c * kq;
                }
            }
    }
}

/* sh's principal axes: the eigenvectors of its covariance m2 / a - g gᵀ,
 * g = m1 / a; its extents emptied. */
static void principal_axes(part_shape *sh)
{
    const double a = sh->a > 0.0 ? sh->a : 1.0;
    const double g[3] = {sh->m1[0] / a, sh->m1[1] / a, sh->m1[2] / a};
    const int at[3][3] = {{0, 3, 4}, {3, 1, 5}, {4, 5, 2}};
    double c[3][3], v[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            c[i][j] = sh->m2[at[i][j]] / a - g[i] * g[j];
    jacobi3(c, v);
    for (int k = 0; k < 3; k++) {
        sh->axis[k] = rad_v3(v[0][k], v[1][k], v[2][k]);
        sh->lo[k] = INFINITY;
        sh->hi[k] = -INFINITY;
    }
}

/* Each candidate part's shape into sh[its root]; lo, hi: its
 * axis-aligned box (o its centre). */
static void part_shapes(const rad_scene *s, uint32_t *up, const uint8_t *small,
                        const rad_vec3 *lo, const rad_vec3 *hi, part_shape *sh)
{
    const uint32_t np = s->polygon_count;
    memset(sh, 0, (size_t)np * sizeof *sh);
    for (uint32_t i = 0; i < np; i++) {
        if (!small[i])
            continue;
        const uint32_t r = mesh_uf_find(up, i);
        const rad_polygon *pg = &s->polygons[i];
        const rad_vec3 *p = s->points + pg->first_point, o = rad_scale(rad_add(lo[r], hi[r]), 0.5);
        for (uint32_t k = 0; k + 2 < pg->point_count; k++)
            add_triangle(&sh[r], o, p, k,
                         0.5 * rad_dot(rad_cross(rad_sub(p[k + 1], p[0]), rad_sub(p[k + 2], p[0])),
                                       pg->normal));
    }
    for (uint32_t i = 0; i < np; i++)
        if (small[i] && mesh_uf_find(up, i) == i)
            principal_axes(&sh[i]);
    for (uint32_t i = 0; i < np; i++) {
        if (!small[i])
            continue;
        const uint32_t r = mesh_uf_find(up, i);
        const rad_polygon *pg = &s->polygons[i];
        const rad_vec3 o = rad_scale(rad_add(lo[r], hi[r]), 0.5);
        for (uint32_t k = 0; k < pg->point_count; k++)
            for (int j = 0; j < 3; j++) {
                const double t = rad_dot(rad_sub(s->points[pg->first_point + k], o), sh[r].axis[j]);
                sh[r].lo[j] = fmin(sh[r].lo[j], t);
                sh[r].hi[j] = fmax(sh[r].hi[j], t);
            }
    }
}

/* A part is small when its axis-aligned box's diagonal is under
 * MESH_PART_SMALL × size (a screw), or when, along its principal axes,
 * its box's diagonal is at most MESH_PART_FIT × size and its
 * second-largest extent under MESH_PART_SMALL × size: thin across, up to
 * a patch long (a baluster).  The first is a case of the second (every
 * extent is at most the diagonal, and that box's diagonal at most √3 × it),
 * kept apart so that it holds whatever the axes' rounding. */
static int part_is_small(const part_shape *sh, double diagonal, double size)
{
    if (diagonal < MESH_PART_SMALL * size)
        return 1;
    double sum = 0.0, sq = 0.0, most = 0.0, least = INFINITY;
    for (int k = 0; k < 3; k++) {
        const double e = sh->hi[k] - sh->lo[k];
        sum += e;
        sq += e * e;
        most = fmax(most, e);
        least = fmin(least, e);
    }
    return sqrt(sq) <= MESH_PART_FIT * size && sum - most - least < MESH_PART_SMALL * size;
}

/* Marks in keep[i] the candidate polygons of small parts, and fills key[]
 * for them; returns how many. */
static uint32_t small_parts(const rad_scene *s, uint32_t *up, const uint8_t *small,
                            const uint8_t *bad, double size, rad_vec3 *lo, rad_vec3 *hi,
                            part_shape *sh, part_key *key)
{
    const uint32_t np = s->polygon_count;
    rad_vec3 slo, shi;
    rad_scene_bounds(s, &slo, &shi);
    for (uint32_t i = 0; i < np; i++) {
        lo[i] = rad_v3(INFINITY, INFINITY, INFINITY);
        hi[i] = rad_v3(-INFINITY, -INFINITY, -INFINITY);
    }
    for (uint32_t i = 0; i < np; i++) {
        if (!small[i])
            continue;
        const uint32_t r = mesh_uf_find(up, i);
        const rad_polygon *pg = &s->polygons[i];
        for (uint32_t k = 0; k < pg->point_count; k++) {
            const rad_vec3 p = s->points[pg->first_point + k];
            lo[r] = rad_v3(fmin(lo[r].x, p.x), fmin(lo[r].y, p.y), fmin(lo[r].z, p.z));
            hi[r] = rad_v3(fmax(hi[r].x, p.x), fmax(hi[r].y, p.y), fmax(hi[r].z, p.z));
        }
    }
    part_shapes(s, up, small, lo, hi, sh);
    uint32_t n = 0;
    for (uint32_t i = 0; i < np; i++) {
        if (!small[i])
            continue;
        const uint32_t r = mesh_uf_find(up, i);
        if (bad[r] || !part_is_small(&sh[r], rad_length(rad_sub(hi[r], lo[r])), size))
            continue;
        const rad_vec3 c = rad_sub(rad_scale(rad_add(lo[r], hi[r]), 0.5), slo);
        part_key *k = &key[n++];
        k->object = s->polygons[i].object;
        k->material = s->polygons[i].material;
        const double g = MESH_PART_GRID * size;
        k->cube[0] = (int64_t)floor(c.x / g);
        k->cube[1] = (int64_t)floor(c.y / g);
        k->cube[2] = (int64_t)floor(c.z / g);
        k->polygon = i;
    }
    return n;
}

/* The shared patches of the n sorted keys: runs of one object, material and
 * cube, split by normal (within 30° of a patch's first cell's); (patch,
 * polygon) pairs into pair, the count returned. */
static uint32_t group_by_normal(const rad_scene *s, const part_key *key, uint32_t n,
                                uint32_t *lead, uint32_t *pair)
{
    uint32_t patches = 0;
    for (uint32_t a = 0, z; a < n; a = z) {
        for (z = a + 1; z < n && key[z].object == key[a].object &&
                        key[z].material == key[a].material &&
                        !memcmp(key[z].cube, key[a].cube, sizeof key[a].cube);)
            z++;
        const uint32_t first = patches;
        for (uint32_t q = a; q < z; q++) {
            const rad_vec3 nq = s->polygons[key[q].polygon].normal;
            uint32_t p = first;
            while (p < patches && rad_dot(s->polygons[lead[p]].normal, nq) < RAD_MESH_SURFACE_COS)
                p++;
            if (p == patches)
                lead[patches++] = key[q].polygon;
            pair[2 * (size_t)q] = p;
            pair[2 * (size_t)q + 1] = key[q].polygon;
        }
    }
    return patches;
}

/* Drops the groups of one polygon from the n sorted pairs (that polygon is
 * meshed as before: a patch of its own, and a mesh of nothing else keeps
 * no cell layer), numbering the others anew in order; num: scratch of
 * `groups` entries.  Returns the pairs kept; their groups into *count. */
static uint32_t drop_singles(uint32_t *pair, uint32_t n, uint32_t groups, uint32_t *num,
                             uint32_t *count)
{
    for (uint32_t g = 0; g < groups; g++)
        num[g] = 0;
    for (uint32_t q = 0; q < n; q++)
        num[pair[2 * (size_t)q]]++;
    uint32_t kept = 0;
    for (uint32_t g = 0; g < groups; g++)
        num[g] = num[g] > 1 ? kept++ : RAD_NONE;
    uint32_t m = 0;
    for (uint32_t q = 0; q < n; q++) {
        const uint32_t g = num[pair[2 * (size_t)q]];
        if (g == RAD_NONE)
            continue;
        pair[2 * (size_t)m] = g;
        pair[2 * (size_t)m + 1] = pair[2 * (size_t)q + 1];
        m++;
    }
    *count = kept;
    return m;
}

int mesh_parts_find(const rad_scene *s, const uint32_t *pos, uint32_t npos, const uint8_t *small,
                    double size, mesh_parts *out)
{
    memset(out, 0, sizeof *out);
    const uint32_t np = s->polygon_count;
    uint32_t *up = malloc(((size_t)np + 1) * sizeof *up);
    uint32_t *owner = malloc(((size_t)npos + 1) * sizeof *owner);
    uint8_t *bad = malloc((size_t)np + 1);
    rad_vec3 *lo = malloc(((size_t)np + 1) * sizeof *lo), *hi = malloc(((size_t)np + 1) * sizeof *hi);
    part_key *key = malloc(((size_t)np + 1) * sizeof *key);
    part_shape *sh = malloc(((size_t)np + 1) * sizeof *sh);
    uint32_t *lead = malloc(((size_t)np + 1) * sizeof *lead);
    uint32_t *pair = malloc(((size_t)np + 1) * 2 * sizeof *pair);
    out->of = malloc(((size_t)np + 1) * sizeof *out->of);
    int rc = up && owner && bad && lo && hi && key && sh && pair && lead && out->of ? 0 : -1;
    if (rc == 0) {
        join_parts(s, pos, npos, small, up, owner, bad);
        uint32_t n = small_parts(s, up, small, bad, size, lo, hi, sh, key);
        qsort(key, n, sizeof *key, part_key_cmp);
        uint32_t groups = group_by_normal(s, key, n, lead, pair);
        qsort(pair, n, 2 * sizeof *pair, pair_cmp);
        n = drop_singles(pair, n, groups, lead, &out->count);
        out->first = calloc((size_t)out->count + 1, sizeof *out->first);
        out->member = malloc(((size_t)n + 1) * sizeof *out->member);
        if (!out->first || !out->member)
            rc = -1;
        for (uint32_t i = 0; rc == 0 && i < np; i++)
            out->of[i] = RAD_NONE;
        for (uint32_t q = 0; rc == 0 && q < n; q++) {
            out->member[q] = pair[2 * (size_t)q + 1];
            out->of[out->member[q]] = pair[2 * (size_t)q];
            out->first[pair[2 * (size_t)q] + 1]++;
            out->points += s->polygons[out->member[q]].point_count;
        }
        for (uint32_t p = 0; rc == 0 && p < out->count; p++)
            out->first[p + 1] += out->first[p];
    }
    free(up);
    free(owner);
    free(bad);
    free(lo);
    free(hi);
    free(key);
    free(sh);
    free(lead);
    free(pair);
    if (rc != 0)
        mesh_parts_free(out);
    return rc;
}
