/* validate.c - the hemi-cube against exact answers (validate.h, issue 4).
 *
 * Owns the standard validation cases: it builds each configuration as a
 * scene in code, meshes it with explicit per-polygon subdivision, asks the
 * hemi-cube for only the rows the quantity needs (the "from" surface's
 * patches for a form factor, every patch for a radiosity), and compares with
 * a reference computed without the hemi-cube.  Invariant: a reference never
 * depends on the hemi-cube or on the solver under test; library code only,
 * nothing prints.
 *
 * Where no closed form exists (the cube with a lit ceiling; the continuum
 * behind the 2×2 model of two reflecting plates) the reference is the
 * collocation system B_i = E_i + ρ_i Σ_j K_ij B_j with K_ij Lambert's exact
 * factor from the centre of patch i to patch j (hc_ff_point_polygon), solved
 * by our own dense Gauss-Seidel in double at 4, 8 and 16 patches per edge and
 * extrapolated to zero patch size by Aitken's Δ² (the cube's floor converges
 * as h^1.9).  That is the continuum answer the hemi-cube approaches as both
 * R and the subdivision grow.
 */
#include "validate.h"

#include "../../hemicube/hemicube.h"
#include "../../solver/solver.h"
#include "../mesh/mesh.h"
#include "../scene/scene.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define VAL_MAX_PATCHES 200000u
#define VAL_MAX_SIDES 1024u

/* --------------------------------------------------------------- defaults */

const char *rad_validate_config_name(rad_val_config config)
{
    static const char *names[RAD_VAL_CONFIG_COUNT] = {
        "parallel", "perpendicular", "disks", "element", "enclosure", "closed-cube", "plates",
        "cube-lamp", "offset", "box", "box-wall"};
    return (unsigned)config < RAD_VAL_CONFIG_COUNT ? names[config] : "unknown";
}

uint32_t rad_validate_default_subdiv(rad_val_config config)
{
    switch (config) {
    /* Patch edge = 1/16 of the side: the collocation error of F_AB is
     * ~0.15/n² at unit gap, 0.06 % here. */
    case RAD_VAL_PARALLEL: return 16;
    case RAD_VAL_PERPENDICULAR: return 16;
    case RAD_VAL_DISKS: return 4;   /* 32 fan triangles × 16 */
    case RAD_VAL_ELEMENT: return 4; /* the receiver's split changes nothing measured */
    case RAD_VAL_ENCLOSURE: return 4;
    case RAD_VAL_CLOSED_CUBE: return 4;
    case RAD_VAL_PLATES: return 16;
    case RAD_VAL_CUBE_LAMP: return 8;
    case RAD_VAL_OFFSET: return 16;
    case RAD_VAL_BOX: return 8;
    case RAD_VAL_BOX_WALL: return 8;
    default: return 1;
    }
}

void rad_validate_defaults(rad_val_case *c)
{
    if (c->a == 0) c->a = 1;
    if (c->b == 0) c->b = 1;
    if (c->c == 0) c->c = 1;
    if (c->resolution == 0) c->resolution = HC_DEFAULT_RESOLUTION;
    /* Engine cases keep subdiv 0: the mesher's default patch size. */
    if (c->subdiv == 0 && c->engine == RAD_VAL_BARE)
        c->subdiv = rad_validate_default_subdiv(c->config);
    if (c->sides == 0) c->sides = 32;
    if (c->rho == 0) c->rho = 0.5;
    if (c->tolerance == 0) c->tolerance = 1e-7;
    if (c->subdiv_long == 0 && c->subdiv > 0) {
        /* Square-ish patches on an elongated rectangle: scale the count along
         * the long edge by the aspect ratio. */
        double lo = fmin(c->a, c->b), hi = fmax(c->a, c->b);
        double aspect = lo > 0 ? hi / lo : 1.0;
        if (c->config == RAD_VAL_PERPENDICULAR)
            aspect = fmax(c->a / fmin(c->b, c->c), 1.0);
        double n = ceil(c->subdiv * aspect - 1e-9);
        c->subdiv_long = n < 1 ? 1 : n > 65535 ? 65535 : (uint32_t)n;
    }
}

/* ------------------------------------------------------ building the scene */

typedef struct builder {
    rad_scene *s;
    const char *name; /* case name, for messages */
    rad_error *err;
} builder;

static int add_material(builder *b, const char *name, double rho, double e, uint32_t *idx)
{
    double r[RAD_MAX_BANDS] = {rho}, em[RAD_MAX_BANDS] = {e};
    return rad_scene_add_material(b->s, name, r, em, NULL, b->name, idx, b->err);
}

static int add_object(builder *b, const char *name, uint32_t *idx)
{
    return rad_scene_add_object(b->s, name, b->name, idx, b->err);
}

/* A quad p0..p3, counter-clockwise about its front normal, split nu along
 * p0->p1 and nv along p1->p2. */
static int add_quad(builder *b, const char *name, uint32_t obj, uint32_t mat, rad_vec3 p0,
                    rad_vec3 p1, rad_vec3 p2, rad_vec3 p3, uint32_t nu, uint32_t nv)
{
    rad_vec3 q[4] = {p0, p1, p2, p3};
    return rad_scene_add_polygon(b->s, name, obj, mat, q, 4, nu, nv, b->name, NULL, b->err);
}

/* The six faces of the axis-aligned box [0,s.x]×[0,s.y]×[0,s.z], normals
 * inward, each split n×n; face 2 is the wall y = 0, face 4 the floor (z =
 * 0), face 5 the ceiling (z = s.z). */
static int add_box(builder *b, rad_vec3 size, uint32_t n, const uint32_t obj[6],
                   const uint32_t mat[6])
{
    const double s3[3] = {size.x, size.y, size.z};
    static const char *names[6] = {"x0", "x1", "y0", "y1", "floor", "ceiling"};
    for (int f = 0; f < 6; f++) {
        int ax = f / 2, side = f % 2;
        /* (u, v) run along axes ax+1, ax+2, whose cross product is +ax: that
         * winding faces inward on the side at 0, reversed on the side at s. */
        double uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        if (side) {
            uv[1][0] = 0, uv[1][1] = 1;
            uv[3][0] = 1, uv[3][1] = 0;
        }
        rad_vec3 q[4];
        for (int k = 0; k < 4; k++) {
            double co[3];
            co[ax] = side ? s3[ax] : 0;
            co[(ax + 1) % 3] = uv[k][0] * s3[(ax + 1) % 3];
            co[(ax + 2) % 3] = uv[k][1] * s3[(ax + 2) % 3];
            q[k] = rad_v3(co[0], co[1], co[2]);
        }
        int rc = add_quad(b, names[f], obj[f], mat[f], q[0], q[1], q[2], q[3], n, n);
        if (rc)
            return rc;
    }
    return RAD_OK;
}

/* Regular `sides`-gon of radius r about the z axis at height z, facing +z
 * (up) or -z. */
static void ngon(rad_vec3 *out, uint32_t sides, double r, double z, int up)
{
    for (uint32_t k = 0; k < sides; k++) {
        double t = 2.0 * M_PI * (up ? k : sides - k) / sides;
        out[k] = rad_v3(r * cos(t), r * sin(t), z);
    }
}

/* The 20 faces of an icosahedron with circumradius 1 about the origin,
 * normals inward. */
static int add_icosahedron(builder *b, uint32_t k, uint32_t obj, uint32_t mat)
{
    const double phi = (1.0 + sqrt(5.0)) / 2.0, s = 1.0 / sqrt(1.0 + phi * phi);
    rad_vec3 v[12];
    int nv = 0;
    for (int i = 0; i < 4; i++) {
        double p = (i & 1) ? -1.0 : 1.0, q = (i & 2) ? -phi : phi;
        v[nv++] = rad_scale(rad_v3(0, p, q), s);
        v[nv++] = rad_scale(rad_v3(p, q, 0), s);
        v[nv++] = rad_scale(rad_v3(q, 0, p), s);
    }
    /* Faces are the triples of mutually adjacent vertices (edge 2s). */
    const double edge = 2.0 * s;
    int faces = 0;
    for (int i = 0; i < 12; i++)
        for (int j = i + 1; j < 12; j++)
            for (int l = j + 1; l < 12; l++) {
                if (fabs(rad_length(rad_sub(v[i], v[j])) - edge) > 1e-9 ||
                    fabs(rad_length(rad_sub(v[j], v[l])) - edge) > 1e-9 ||
                    fabs(rad_length(rad_sub(v[i], v[l])) - edge) > 1e-9)
                    continue;
                rad_vec3 t[3] = {v[i], v[j], v[l]};
                rad_vec3 n = rad_cross(rad_sub(t[1], t[0]), rad_sub(t[2], t[0]));
                if (rad_dot(n, rad_add(rad_add(t[0], t[1]), t[2])) > 0) { /* faces outward */
                    t[1] = v[l];
                    t[2] = v[j];
                }
                char name[16];
                snprintf(name, sizeof name, "face%d", faces++);
                int rc = rad_scene_add_polygon(b->s, name, obj, mat, t, 3, k, 0, b->name, NULL,
                                               b->err);
                if (rc)
                    return rc;
            }
    RAD_ASSERT(faces == 20);
    return RAD_OK;
}

/* ----------------------------------------------------------------- the case */

/* A closed black box a×b×c: object "A" the floor, "B" the ceiling (box) or
 * the wall y = 0 (box-wall), "walls" the rest. */
static int box_scene(builder *b, const rad_val_case *c, uint32_t dark, uint32_t *A, uint32_t *B)
{
    uint32_t walls, objs[6], mats[6];
    int rc = add_object(b, "A", A);
    if (!rc) rc = add_object(b, "B", B);
    if (!rc) rc = add_object(b, "walls", &walls);
    if (rc)
        return rc;
    for (int f = 0; f < 6; f++) {
        objs[f] = walls;
        mats[f] = dark;
    }
    objs[4] = *A;
    objs[c->config == RAD_VAL_BOX ? 5 : 2] = *B;
    return add_box(b, rad_v3(c->a, c->b, c->c), c->subdiv, objs, mats);
}

static int finite_pos(double x) { return isfinite(x) && x > 0; }

/* Builds the case's scene.  *from / *to: the objects between which F_AB is
 * measured; for a radiosity case *to is the object whose mean B is the
 * quantity (RAD_NONE: all patches). */
static int build_scene(const rad_val_case *c, const char *name, rad_scene **out, uint32_t *from,
                       uint32_t *to, rad_error *err)
{
    rad_scene *s = rad_scene_create(1, "validate");
    if (!s)
        return rad_fail(err, RAD_ERR_NOMEM, "validate: %s: out of memory", name);
    builder b = {s, name, err};
    uint32_t A = RAD_NONE, B = RAD_NONE, white, lamp, dark;
    int rc = add_material(&b, "white", c->rho, 0, &white);
    if (!rc) rc = add_material(&b, "lamp", c->config == RAD_VAL_PLATES ? c->rho_a : c->rho, 1, &lamp);
    if (!rc) rc = add_material(&b, "black", 0, 0, &dark);
    if (!rc && c->config != RAD_VAL_ENCLOSURE && c->config != RAD_VAL_CLOSED_CUBE &&
        c->config != RAD_VAL_CUBE_LAMP && c->config != RAD_VAL_BOX && c->config != RAD_VAL_BOX_WALL) {
        rc = add_object(&b, "A", &A);
        if (!rc) rc = add_object(&b, "B", &B);
    }
    const double a = c->a, bb = c->b, cc = c->c;
    const uint32_t n = c->subdiv, nl = c->subdiv_long;
    /* Along a side of length x: nl if it is the long one, else n. */
#define COUNT(x, other) ((x) > (other) * (1 + 1e-9) ? nl : n)
    switch (rc ? RAD_VAL_CONFIG_COUNT : c->config) {
    case RAD_VAL_PARALLEL:
    case RAD_VAL_PLATES: {
        uint32_t ma = c->config == RAD_VAL_PLATES ? lamp : dark;
        uint32_t mb = c->config == RAD_VAL_PLATES ? white : dark;
        uint32_t na = COUNT(a, bb), nb = COUNT(bb, a);
        rc = add_quad(&b, "A", A, ma, rad_v3(0, 0, 0), rad_v3(a, 0, 0), rad_v3(a, bb, 0),
                      rad_v3(0, bb, 0), na, nb);
        if (!rc)
            rc = add_quad(&b, "B", B, mb, rad_v3(0, 0, cc), rad_v3(0, bb, cc), rad_v3(a, bb, cc),
                          rad_v3(a, 0, cc), nb, na);
        break;
    }
    case RAD_VAL_OFFSET: {
        const double dx = c->dx, dy = c->dy;
        rc = add_quad(&b, "A", A, dark, rad_v3(0, 0, 0), rad_v3(a, 0, 0), rad_v3(a, bb, 0),
                      rad_v3(0, bb, 0), COUNT(a, bb), COUNT(bb, a));
        if (!rc)
            rc = add_quad(&b, "B", B, dark, rad_v3(dx, dy, cc), rad_v3(dx, dy + bb, cc),
                          rad_v3(dx + a, dy + bb, cc), rad_v3(dx + a, dy, cc), COUNT(bb, a),
                          COUNT(a, bb));
        break;
    }
    case RAD_VAL_BOX:
    case RAD_VAL_BOX_WALL:
        rc = box_scene(&b, c, dark, &A, &B);
        break;
    case RAD_VAL_PERPENDICULAR: {
        /* Common edge along x from 0 to a; A in z = 0 (y in [0, b], normal
         * +z), B in y = 0 (z in [0, c], normal +y). */
        uint32_t ne = (a > fmin(bb, cc) * (1 + 1e-9)) ? nl : n;
        uint32_t nwa = bb > a * (1 + 1e-9) ? (uint32_t)fmin(65535, ceil(n * bb / a - 1e-9)) : n;
        uint32_t nwb = cc > a * (1 + 1e-9) ? (uint32_t)fmin(65535, ceil(n * cc / a - 1e-9)) : n;
        rc = add_quad(&b, "A", A, dark, rad_v3(0, 0, 0), rad_v3(a, 0, 0), rad_v3(a, bb, 0),
                      rad_v3(0, bb, 0), ne, nwa);
        if (!rc)
            rc = add_quad(&b, "B", B, dark, rad_v3(0, 0, 0), rad_v3(0, 0, cc), rad_v3(a, 0, cc),
                          rad_v3(a, 0, 0), nwb, ne);
        break;
    }
    case RAD_VAL_DISKS: {
        rad_vec3 *p = malloc(c->sides * sizeof *p);
        if (!p) {
            rc = rad_fail(err, RAD_ERR_NOMEM, "validate: %s: out of memory", name);
            break;
        }
        ngon(p, c->sides, a, 0, 1);
        rc = rad_scene_add_polygon(s, "A", A, dark, p, c->sides, n, 0, name, NULL, err);
        ngon(p, c->sides, bb, cc, 0);
        if (!rc)
            rc = rad_scene_add_polygon(s, "B", B, dark, p, c->sides, n, 0, name, NULL, err);
        free(p);
        break;
    }
    case RAD_VAL_ELEMENT: {
        /* The element: a square 1e-3 of the smallest size across, centred on
         * the normal through the rectangle's corner (0, 0, c), so the
         * hemi-cube sits exactly where the catalog's element does. */
        double e = 0.5e-3 * fmin(fmin(a, bb), cc);
        rc = add_quad(&b, "A", A, dark, rad_v3(-e, -e, 0), rad_v3(e, -e, 0), rad_v3(e, e, 0),
                      rad_v3(-e, e, 0), 1, 1);
        if (!rc)
            rc = add_quad(&b, "B", B, dark, rad_v3(0, 0, cc), rad_v3(0, bb, cc), rad_v3(a, bb, cc),
                          rad_v3(a, 0, cc), COUNT(bb, a), COUNT(a, bb));
        break;
    }
    case RAD_VAL_ENCLOSURE: {
        uint32_t o;
        rc = add_object(&b, "icosahedron", &o);
        if (!rc)
            rc = add_icosahedron(&b, n, o, dark);
        break;
    }
    case RAD_VAL_CLOSED_CUBE:
    case RAD_VAL_CUBE_LAMP: {
        uint32_t objs[6], mats[6];
        static const char *names[6] = {"x0", "x1", "y0", "y1", "floor", "ceiling"};
        for (int f = 0; f < 6 && !rc; f++) {
            rc = add_object(&b, names[f], &objs[f]);
            mats[f] = c->config == RAD_VAL_CLOSED_CUBE || f == 5 ? lamp : white;
        }
        if (!rc)
            rc = add_box(&b, rad_v3(1, 1, 1), n, objs, mats);
        if (!rc && c->config == RAD_VAL_CUBE_LAMP)
            B = objs[4]; /* the floor: its mean B is the quantity */
        break;
    }
    default:
        break;
    }
#undef COUNT
    if (rc) {
        rad_scene_destroy(s);
        return rc;
    }
    *out = s;
    *from = A;
    *to = B;
    return RAD_OK;
}

static void case_name(const rad_val_case *c, char *out, size_t len)
{
    switch (c->config) {
    case RAD_VAL_PARALLEL:
        snprintf(out, len, "parallel %gx%g, gap %g", c->a, c->b, c->c);
        break;
    case RAD_VAL_PERPENDICULAR:
        snprintf(out, len, "perpendicular, edge %g, widths %g and %g", c->a, c->b, c->c);
        break;
    case RAD_VAL_DISKS:
        snprintf(out, len, "coaxial %u-gons r %g and %g, gap %g", c->sides, c->a, c->b, c->c);
        break;
    case RAD_VAL_ELEMENT:
        snprintf(out, len, "element to %gx%g at %g", c->a, c->b, c->c);
        break;
    case RAD_VAL_ENCLOSURE:
        snprintf(out, len, "inside an icosahedron");
        break;
    case RAD_VAL_CLOSED_CUBE:
        snprintf(out, len, "closed cube, rho %g", c->rho);
        break;
    case RAD_VAL_PLATES:
        snprintf(out, len, "plates %gx%g, gap %g, rho %g/%g", c->a, c->b, c->c, c->rho_a, c->rho);
        break;
    case RAD_VAL_CUBE_LAMP:
        snprintf(out, len, "cube, lit ceiling, rho %g", c->rho);
        break;
    case RAD_VAL_OFFSET:
        snprintf(out, len, "parallel %gx%g, gap %g, offset %g,%g", c->a, c->b, c->c, c->dx, c->dy);
        break;
    case RAD_VAL_BOX:
    case RAD_VAL_BOX_WALL:
        snprintf(out, len, "box %gx%gx%g, floor to %s", c->a, c->b, c->c,
                 c->config == RAD_VAL_BOX ? "ceiling" : "wall");
        break;
    default:
        snprintf(out, len, "unknown");
    }
}

static int check_case(const rad_val_case *c, const char *name, rad_error *err)
{
    if ((unsigned)c->config >= RAD_VAL_CONFIG_COUNT)
        return rad_fail(err, RAD_ERR_USAGE, "validate: configuration %d does not exist", (int)c->config);
    if (!finite_pos(c->a) || !finite_pos(c->b) || !finite_pos(c->c) || c->a > 1e6 || c->b > 1e6 ||
        c->c > 1e6)
        return rad_fail(err, RAD_ERR_USAGE, "validate: %s: sizes must be positive and finite", name);
    if (!(fabs(c->dx) <= 1e6) || !(fabs(c->dy) <= 1e6))
        return rad_fail(err, RAD_ERR_USAGE, "validate: %s: offsets must be finite", name);
    if (c->engine > RAD_VAL_ACCURATE)
        return rad_fail(err, RAD_ERR_USAGE, "validate: %s: engine %u: must be 0, 1 or 2", name,
                        c->engine);
    if (!(c->rho >= 0 && c->rho < 1) || !(c->rho_a >= 0 && c->rho_a < 1))
        return rad_fail(err, RAD_ERR_USAGE, "validate: %s: reflectance must be in [0, 1)", name);
    if (c->sides < 3 || c->sides > VAL_MAX_SIDES)
        return rad_fail(err, RAD_ERR_USAGE, "validate: %s: %u sides: need 3..%u", name, c->sides,
                        VAL_MAX_SIDES);
    if (c->subdiv > 4096 || c->subdiv_long > 65535)
        return rad_fail(err, RAD_ERR_USAGE, "validate: %s: subdivision %u/%u is too fine", name,
                        c->subdiv, c->subdiv_long);
    if (!(c->tolerance > 0 && c->tolerance < 0.5))
        return rad_fail(err, RAD_ERR_USAGE, "validate: %s: tolerance must be in (0, 0.5)", name);
    /* The hemi-cube's own rule, checked before any reference is computed. */
    if (c->resolution < 8 || c->resolution > 4096 || c->resolution % 2)
        return rad_fail(err, RAD_ERR_USAGE,
                        "validate: %s: resolution %u: must be even and within 8..4096", name,
                        c->resolution);
    return RAD_OK;
}

/* Σ over patches i of object A of A_i Σ_{j∈B} F_ij, divided by A_A. */
static double object_ff(const rad_mesh *m, const rad_matrix *F, uint32_t A, uint32_t B)
{
    double num = 0, area = 0;
    for (uint32_t i = 0; i < m->patch_count; i++) {
        if (m->patches[i].object != A)
            continue;
        double s = 0;
        const rad_row r = rad_matrix_row(F, i);
        const uint8_t *q = r.col;
        uint32_t j = 0;
        for (uint32_t k = 0; k < r.count; k++) {
            j = rad_row_next(&q, j);
            if (m->patches[j].object == B)
                s += rad_row_value(&r, k);
        }
        num += m->patches[i].area * s;
        area += m->patches[i].area;
    }
    return area > 0 ? num / area : 0;
}

/* Area-weighted mean of B over the patches of object `obj` (all if RAD_NONE). */
static double mean_B(const rad_mesh *m, const double *B, uint32_t obj)
{
    double num = 0, area = 0;
    for (uint32_t i = 0; i < m->patch_count; i++) {
        if (obj != RAD_NONE && m->patches[i].object != obj)
            continue;
        num += m->patches[i].area * B[i];
        area += m->patches[i].area;
    }
    return area > 0 ? num / area : 0;
}

/* ------------------------------------------- the collocation reference */

/* Mean B of the case's measured object (build_scene's *to) by collocation
 * with exact point-to-patch factors at n patches per edge: B_i = E_i + ρ_i Σ_j K_ij B_j, K_ij Lambert's
 * factor from the centre of patch i to patch j (no occlusion: the cases that
 * use this are convex or two facing plates).  Independent of the hemi-cube
 * and of the solver module: dense Gauss-Seidel here, to 1e-14 of max B. */
static int collocation(const rad_val_case *cin, uint32_t n, double *mean, rad_error *err)
{
    rad_val_case c = *cin;
    c.subdiv = n;
    c.subdiv_long = 0;
    rad_validate_defaults(&c);
    rad_scene *s = NULL;
    uint32_t A, B;
    int rc = build_scene(&c, "collocation reference", &s, &A, &B, err);
    if (rc)
        return rc;
    rad_mesh *m = NULL;
    if (rad_mesh_count(s, NULL) > 4096)
        rc = rad_fail(err, RAD_ERR_LIMIT, "validate: collocation reference: over 4096 patches");
    if (!rc)
        rc = rad_mesh_build(s, NULL, &m, err);
    if (rc) {
        rad_scene_destroy(s);
        return rc;
    }
    uint32_t N = m->patch_count;
    double *K = malloc((size_t)N * N * sizeof *K);
    double *Bv = malloc(N * sizeof *Bv), *E = malloc(N * sizeof *E), *r = malloc(N * sizeof *r);
    if (!K || !Bv || !E || !r) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "validate: collocation reference: out of memory for %u patches", N);
        goto done;
    }
    for (uint32_t i = 0; i < N; i++) {
        const rad_patch *pi = &m->patches[i];
        const rad_material *mt = &s->materials[pi->material];
        E[i] = mt->emission[0];
        r[i] = mt->rho[0];
        Bv[i] = E[i];
        for (uint32_t j = 0; j < N; j++) {
            const rad_patch *pj = &m->patches[j];
            double f = 0;
            if (pj->polygon != pi->polygon) {
                rad_vec3 q[4];
                int nc = rad_patch_corners(pj);
                for (int k = 0; k < nc; k++)
                    q[k] = m->vertices[pj->v[k]];
                f = hc_ff_point_polygon(pi->center, pi->normal, q, (uint32_t)nc);
            }
            K[(size_t)i * N + j] = f;
        }
    }
    for (int it = 0; it < 100000; it++) {
        double change = 0, top = 0;
        for (uint32_t i = 0; i < N; i++) {
            const double *row = K + (size_t)i * N;
            double g = 0;
            for (uint32_t j = 0; j < N; j++)
                g += row[j] * Bv[j];
            double nb = E[i] + r[i] * g;
            change = fmax(change, fabs(nb - Bv[i]));
            top = fmax(top, nb);
            Bv[i] = nb;
        }
        /* The error left is about change·q/(1−q) with q <= max ρ: stop far
         * below anything the comparison can see. */
        if (change <= 1e-14 * top)
            break;
    }
    *mean = mean_B(m, Bv, B);
done:
    free(K);
    free(Bv);
    free(E);
    free(r);
    rad_mesh_destroy(m);
    rad_scene_destroy(s);
    return rc;
}

/* The continuum value: collocation at 4, 8 and 16 patches per edge,
 * extrapolated to zero patch size by Aitken's Δ² when the differences shrink
 * steadily (ratio 2..8), else by Richardson with order 2. */
static int continuum(const rad_val_case *c, double *out, rad_error *err)
{
    double x[3];
    for (int k = 0; k < 3; k++) {
        int rc = collocation(c, 4u << k, &x[k], err);
        if (rc)
            return rc;
    }
    double d1 = x[1] - x[0], d2 = x[2] - x[1];
    double ratio = d2 != 0 ? d1 / d2 : 0;
    if (ratio > 2.0 && ratio < 8.0)
        *out = x[2] + d2 / (ratio - 1.0);
    else
        *out = x[2] + d2 / 3.0;
    return RAD_OK;
}

/* ------------------------------------------------------------ running a case */

static int prepare(const rad_val_case *cin, rad_val_case *c, char *name, size_t len, rad_error *err)
{
    if (!cin)
        return rad_fail(err, RAD_ERR_USAGE, "validate: no case given");
    *c = *cin;
    c->label[sizeof c->label - 1] = '\0';
    rad_validate_defaults(c);
    case_name(c, name, len);
    return check_case(c, name, err);
}

int rad_validate_build_scene(const rad_val_case *cin, rad_scene **out, rad_error *err)
{
    if (!out)
        return rad_fail(err, RAD_ERR_USAGE, "validate: out must not be NULL");
    *out = NULL;
    rad_val_case c;
    char name[96];
    uint32_t A, B;
    int rc = prepare(cin, &c, name, sizeof name, err);
    return rc ? rc : build_scene(&c, name, out, &A, &B, err);
}

int rad_validate_reference(const rad_val_case *cin, double *reference, double *secondary,
                           char *secondary_what, size_t what_len, rad_error *err)
{
    rad_val_case c;
    char name[96];
    int rc = prepare(cin, &c, name, sizeof name, err);
    if (rc)
        return rc;
    double ref = NAN, sec = NAN;
    const char *what = "";
    switch (c.config) {
    case RAD_VAL_PARALLEL:
        ref = hc_ff_parallel_rectangles(c.a, c.b, c.c);
        break;
    case RAD_VAL_PERPENDICULAR:
        ref = hc_ff_perpendicular_rectangles(c.a, c.b, c.c);
        break;
    case RAD_VAL_ELEMENT:
        ref = hc_ff_element_parallel_rectangle(c.a, c.b, c.c);
        break;
    case RAD_VAL_OFFSET:
        ref = hc_ff_parallel_offset(0, c.a, 0, c.b, c.dx, c.dx + c.a, c.dy, c.dy + c.b, c.c);
        break;
    case RAD_VAL_BOX:
        ref = hc_ff_parallel_rectangles(c.a, c.b, c.c);
        break;
    case RAD_VAL_BOX_WALL:
        ref = hc_ff_perpendicular_rectangles(c.a, c.b, c.c);
        break;
    case RAD_VAL_DISKS: {
        rad_vec3 *pa = malloc(c.sides * sizeof *pa), *pb = malloc(c.sides * sizeof *pb);
        if (!pa || !pb) {
            free(pa);
            free(pb);
            return rad_fail(err, RAD_ERR_NOMEM, "validate: %s: out of memory", name);
        }
        ngon(pa, c.sides, c.a, 0, 1);
        ngon(pb, c.sides, c.b, c.c, 0);
        /* 24² sub-triangles per fan triangle agree with 64² to 1e-9
         * relative even at a gap of a tenth of the diameter. */
        ref = hc_ff_polygon_polygon(pa, c.sides, pb, c.sides, 24);
        free(pa);
        free(pb);
        sec = hc_ff_coaxial_disks(c.a, c.b, c.c);
        what = "true disks";
        break;
    }
    case RAD_VAL_ENCLOSURE:
        ref = 1.0;
        break;
    case RAD_VAL_CLOSED_CUBE:
        ref = 1.0 / (1.0 - c.rho); /* E = 1 */
        break;
    case RAD_VAL_PLATES: {
        /* The 2×2 system B_A = E + ρ_A F B_B, B_B = ρ_B F B_A with E = 1.
         * Exact for the mean of plate B when ρ_A = 0 (B_A = E then is
         * uniform); otherwise it assumes uniform plates, and the secondary
         * value, the continuum, shows what that assumption costs. */
        double f = hc_ff_parallel_rectangles(c.a, c.b, c.c);
        ref = c.rho * f / (1.0 - c.rho_a * c.rho * f * f);
        if (c.rho_a > 0) {
            rc = continuum(&c, &sec, err);
            what = "continuum";
        }
        break;
    }
    case RAD_VAL_CUBE_LAMP:
        rc = continuum(&c, &ref, err);
        /* What the hemi-cube tends to as R grows at this subdivision, while
         * the dense collocation stays small. */
        if (!rc && c.subdiv <= 16) {
            rc = collocation(&c, c.subdiv, &sec, err);
            what = "collocation, same mesh";
        }
        break;
    default:
        break;
    }
    if (rc)
        return rc;
    if (reference)
        *reference = ref;
    if (secondary)
        *secondary = sec;
    if (secondary_what && what_len)
        snprintf(secondary_what, what_len, "%s", what);
    return RAD_OK;
}

/* The radiosity cases: solve the single band with Gauss-Seidel from the
 * rows in F and record the mean B of object B (and, for the closed cube,
 * the worst patch against the reference).  t2: when the solve started. */
static int solve_case(const rad_val_case *c, const rad_scene *s, const rad_mesh *m,
                      rad_matrix *F, uint32_t B, double t2, rad_val_result *out,
                      rad_error *err)
{
    const uint32_t n = m->patch_count;
    double *area = malloc((n ? n : 1) * sizeof *area), *rho = malloc((n ? n : 1) * sizeof *rho);
    double *E = malloc((n ? n : 1) * sizeof *E), *Bv = malloc((n ? n : 1) * sizeof *Bv);
    int rc = RAD_OK;
    if (!area || !rho || !E || !Bv) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "validate: %s: out of memory", out->name);
        goto done;
    }
    for (uint32_t i = 0; i < n; i++) {
        const rad_material *mt = &s->materials[m->patches[i].material];
        area[i] = m->patches[i].area;
        rho[i] = mt->rho[0];
        E[i] = mt->emission[0];
    }
    sv_system sys = {.n = n, .bands = 1, .F = F, .area = area, .rho = rho, .emission = E};
    sv_options so = {.method = SV_GAUSS_SEIDEL, .tolerance = c->tolerance};
    sv_stats st;
    rc = sv_solve(&sys, &so, Bv, &st, err);
    if (rc)
        goto done;
    out->iterations = st.iterations;
    out->t_solve = rad_seconds() - t2;
    out->value = mean_B(m, Bv, B);
    if (c->config == RAD_VAL_CLOSED_CUBE) {
        double w = 0;
        for (uint32_t i = 0; i < n; i++)
            w = fmax(w, fabs(Bv[i] / out->reference - 1));
        out->worst = w;
    }
    snprintf(out->quantity, sizeof out->quantity, "%s",
             c->config == RAD_VAL_CLOSED_CUBE ? "B mean" :
             c->config == RAD_VAL_PLATES ? "B plate B" : "B floor");
done:
    free(area);
    free(rho);
    free(E);
    free(Bv);
    return rc;
}

int rad_validate_case(const rad_val_case *cin, rad_val_result *out, rad_error *err)
{
    if (!out)
        return rad_fail(err, RAD_ERR_USAGE, "validate: result must not be NULL");
    memset(out, 0, sizeof *out);
    out->secondary = out->secondary_error = out->worst = NAN;
    rad_val_case c;
    int rc = prepare(cin, &c, out->name, sizeof out->name, err);
    if (rc)
        return rc;
    out->c = c;

    double tr = rad_seconds();
    rc = rad_validate_reference(&c, &out->reference, &out->secondary, out->secondary_what,
                                sizeof out->secondary_what, err);
    if (rc)
        return rc;
    if (isfinite(out->secondary))
        out->secondary_error = out->reference / out->secondary - 1.0;
    out->t_reference = rad_seconds() - tr;

    rad_scene *s = NULL;
    uint32_t A, B;
    double t0 = rad_seconds();
    rc = build_scene(&c, out->name, &s, &A, &B, err);
    if (rc)
        return rc;
    const int solve = c.config == RAD_VAL_CLOSED_CUBE || c.config == RAD_VAL_PLATES ||
                      c.config == RAD_VAL_CUBE_LAMP;
    /* F_AB as `ff` computes it (surface_factors), a solve's rows as
     * `solve` does: the factor query's default patch edge (mesh.h), its
     * near-surface rule (below) */
    const int surface = !solve && c.config != RAD_VAL_ENCLOSURE && c.config != RAD_VAL_ELEMENT;
    const rad_mesh_options mo = {.divisions = surface ? RAD_MESH_FACTOR_DIVISIONS : 0.0};
    uint64_t count = rad_mesh_count(s, &mo);
    if (count > VAL_MAX_PATCHES) {
        rad_scene_destroy(s);
        return rad_fail(err, RAD_ERR_LIMIT, "validate: %s: %llu patches (more than %u)", out->name,
                        (unsigned long long)count, VAL_MAX_PATCHES);
    }
    rad_mesh *m = NULL;
    rc = rad_mesh_build(s, &mo, &m, err);
    if (rc) {
        rad_scene_destroy(s);
        return rc;
    }
    double t1 = rad_seconds();
    out->t_mesh = t1 - t0;
    out->patches = m->patch_count;
    const uint32_t n = m->patch_count;

    /* Which rows: the "from" surface's for a form factor, all for a solve
     * or for the row sums of the enclosure. */
    uint32_t *rows = malloc((n ? n : 1) * sizeof *rows);
    rad_matrix *F = rad_matrix_create(n);
    hc_engine *hc = NULL;
    if (!rows || !F) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "validate: %s: out of memory", out->name);
        goto done;
    }
    uint32_t nrows = 0;
    for (uint32_t i = 0; i < n; i++)
        if (solve || c.config == RAD_VAL_ENCLOSURE || m->patches[i].object == A)
            rows[nrows++] = i;
    hc_options ho = {.resolution = c.resolution, .processes = c.processes, .gl = c.gl};
    if (c.engine != RAD_VAL_BARE) { /* as the pipeline sets them (pipeline.c) */
        ho.exact_near = 1;
        ho.weak = c.engine == RAD_VAL_ACCURATE ? HC_WEAK_HIGH
                  : surface                    ? HC_WEAK_SURFACE
                                               : HC_WEAK_ON;
    }
    rc = hc_create(m, &ho, &hc, err);
    if (!rc)
        rc = hc_compute_rows(hc, rows, nrows, F, err);
    hc_destroy(hc);
    if (rc)
        goto done;
    double t2 = rad_seconds();
    out->t_form_factors = t2 - t1;
    out->rows = nrows;

    if (c.config == RAD_VAL_ENCLOSURE) {
        /* The row sum farthest from 1. */
        double worst = 0;
        for (uint32_t i = 0; i < n; i++) {
            double d = rad_matrix_row_sum(F, i) - 1.0;
            if (fabs(d) >= fabs(worst))
                worst = d;
        }
        out->value = 1.0 + worst;
        out->worst = worst;
        snprintf(out->quantity, sizeof out->quantity, "row sum");
    } else if (!solve) {
        out->value = object_ff(m, F, A, B);
        snprintf(out->quantity, sizeof out->quantity, "%s",
                 c.config == RAD_VAL_ELEMENT ? "F_dA-B" : "F_AB");
    } else {
        rc = solve_case(&c, s, m, F, B, t2, out, err);
        if (rc)
            goto done;
    }
    out->rel_error = out->reference != 0 ? out->value / out->reference - 1.0 : NAN;
    out->seconds = out->t_mesh + out->t_form_factors + out->t_solve;
done:
    free(rows);
    rad_matrix_destroy(F);
    rad_mesh_destroy(m);
    rad_scene_destroy(s);
    return rc;
}

/* ------------------------------------------------------------ the suite */

typedef struct standard_case {
    rad_val_config config;
    const char *label;
    double a, b, c, rho, rho_a;
    uint32_t subdiv;   /* 0 = the configuration's default */
    double promised;   /* |rel_error| at these settings, see report/accuracy.md */
} standard_case;

/* The promises are the errors measured at these settings (R = 128) with a
 * margin of about 1.5×, rounded up; `radiosity validate` prints the
 * measurements.  Elongated shapes keep 8 patches across the short side (80
 * along the long one) so that the suite stays quick. */
static const standard_case standard[] = {
    {RAD_VAL_PARALLEL, "near", 1, 1, 0.1, 0, 0, 0, 0.005},
    {RAD_VAL_PARALLEL, "unit", 1, 1, 1, 0, 0, 0, 0.001},
    {RAD_VAL_PARALLEL, "far", 1, 1, 10, 0, 0, 0, 0.012},
    {RAD_VAL_PARALLEL, "elongated", 10, 1, 1, 0, 0, 8, 0.002},
    {RAD_VAL_PERPENDICULAR, "unit", 1, 1, 1, 0, 0, 0, 0.0005},
    {RAD_VAL_PERPENDICULAR, "elongated", 10, 1, 1, 0, 0, 8, 0.0015},
    {RAD_VAL_DISKS, "near", 0.5, 0.5, 0.1, 0, 0, 0, 0.015},
    {RAD_VAL_DISKS, "unit", 0.5, 0.5, 1, 0, 0, 0, 0.0015},
    {RAD_VAL_DISKS, "far", 0.5, 0.5, 10, 0, 0, 0, 0.0015},
    {RAD_VAL_ELEMENT, "near", 1, 1, 0.1, 0, 0, 0, 0.0015},
    {RAD_VAL_ELEMENT, "unit", 1, 1, 1, 0, 0, 0, 0.0001},
    {RAD_VAL_ELEMENT, "far", 1, 1, 10, 0, 0, 0, 0.15},
    {RAD_VAL_ELEMENT, "elongated", 10, 1, 1, 0, 0, 0, 0.0035},
    {RAD_VAL_ENCLOSURE, "", 1, 1, 1, 0, 0, 0, 1e-6},
    {RAD_VAL_CLOSED_CUBE, "", 1, 1, 1, 0.5, 0, 0, 1e-5},
    {RAD_VAL_CLOSED_CUBE, "", 1, 1, 1, 0.9, 0, 0, 1e-5},
    {RAD_VAL_PLATES, "black emitter", 1, 1, 1, 0.5, 0, 0, 0.001},
    {RAD_VAL_PLATES, "both reflect", 1, 1, 1, 0.5, 0.5, 0, 0.0015},
    {RAD_VAL_CUBE_LAMP, "", 1, 1, 1, 0.5, 0, 0, 0.005},
};

uint32_t rad_validate_standard(rad_val_case *cases, double *promised, uint32_t cap)
{
    uint32_t total = (uint32_t)(sizeof standard / sizeof standard[0]);
    for (uint32_t k = 0; k < total && k < cap; k++) {
        rad_val_case c = {0};
        c.config = standard[k].config;
        snprintf(c.label, sizeof c.label, "%s", standard[k].label);
        c.a = standard[k].a;
        c.b = standard[k].b;
        c.c = standard[k].c;
        c.rho = standard[k].rho;
        c.rho_a = standard[k].rho_a;
        c.subdiv = standard[k].subdiv;
        rad_validate_defaults(&c);
        if (cases)
            cases[k] = c;
        if (promised)
            promised[k] = standard[k].promised;
    }
    return total;
}

/* The catalog of issue 39: closed-form pairs where pixel counts were weak
 * (thin, far, nearly touching), at the default mesh.  a, b, c, dx, dy as
 * in rad_val_case. */
static const struct catalog_case {
    rad_val_config config;
    const char *label;
    double a, b, c, dx, dy;
    uint32_t subdiv; /* 0: the default patch size */
} catalog[] = {
    {RAD_VAL_PARALLEL, "squares", 1, 1, 0.05, 0, 0, 0},
    {RAD_VAL_PARALLEL, "squares", 1, 1, 0.1, 0, 0, 0},
    {RAD_VAL_PARALLEL, "squares", 1, 1, 0.2, 0, 0, 0},
    {RAD_VAL_PARALLEL, "squares", 1, 1, 0.5, 0, 0, 0},
    {RAD_VAL_PARALLEL, "squares", 1, 1, 1, 0, 0, 0},
    {RAD_VAL_PARALLEL, "squares", 1, 1, 2, 0, 0, 0},
    {RAD_VAL_PARALLEL, "squares", 1, 1, 5, 0, 0, 0},
    {RAD_VAL_PARALLEL, "squares", 1, 1, 10, 0, 0, 0},
    {RAD_VAL_PARALLEL, "squares", 1, 1, 20, 0, 0, 0},
    {RAD_VAL_PARALLEL, "strips", 10, 1, 1, 0, 0, 0},
    {RAD_VAL_PARALLEL, "strips", 10, 1, 2, 0, 0, 0},
    {RAD_VAL_PARALLEL, "strips", 10, 1, 5, 0, 0, 0},
    {RAD_VAL_PARALLEL, "strips", 10, 1, 10, 0, 0, 0},
    {RAD_VAL_PARALLEL, "strips", 10, 1, 20, 0, 0, 0},
    {RAD_VAL_PERPENDICULAR, "plates", 1, 0.2, 3, 0, 0, 0},
    {RAD_VAL_PERPENDICULAR, "plates", 1, 0.5, 2, 0, 0, 0},
    {RAD_VAL_PERPENDICULAR, "plates", 1, 1, 1, 0, 0, 0},
    {RAD_VAL_PERPENDICULAR, "plates", 1, 3, 0.2, 0, 0, 0},
    {RAD_VAL_PERPENDICULAR, "plates", 1, 5, 0.5, 0, 0, 0},
    {RAD_VAL_DISKS, "disks", 0.5, 0.5, 1, 0, 0, 4},
    {RAD_VAL_DISKS, "disks", 0.5, 0.5, 0.5, 0, 0, 4},
    {RAD_VAL_DISKS, "disks", 0.5, 0.5, 0.25, 0, 0, 4},
    {RAD_VAL_DISKS, "disks", 0.5, 1, 0.5, 0, 0, 4},
    {RAD_VAL_BOX, "box", 1, 2, 3, 0, 0, 0},
    {RAD_VAL_BOX, "box", 1, 1, 1, 0, 0, 0},
    {RAD_VAL_BOX, "box", 3, 2, 1, 0, 0, 0},
    {RAD_VAL_BOX_WALL, "box", 1, 2, 3, 0, 0, 0},
    {RAD_VAL_BOX_WALL, "box", 3, 1, 0.5, 0, 0, 0},
    {RAD_VAL_OFFSET, "overlap", 1, 1, 1, 0.5, 0, 0},
    {RAD_VAL_OFFSET, "overlap", 1, 1, 0.2, 0.5, 0.5, 0},
    {RAD_VAL_OFFSET, "corner", 1, 1, 1, 1, 1, 0},
    {RAD_VAL_OFFSET, "beside", 2, 1, 0.5, 2.5, 0, 0},
};

uint32_t rad_validate_catalog(uint32_t engine, rad_val_case *cases, double *promised, uint32_t cap)
{
    uint32_t total = (uint32_t)(sizeof catalog / sizeof catalog[0]);
    for (uint32_t k = 0; k < total && k < cap; k++) {
        rad_val_case c = {0};
        c.config = catalog[k].config;
        snprintf(c.label, sizeof c.label, "%s", catalog[k].label);
        c.a = catalog[k].a;
        c.b = catalog[k].b;
        c.c = catalog[k].c;
        c.dx = catalog[k].dx;
        c.dy = catalog[k].dy;
        /* Disks: 4 per side of each fan triangle (512 patches a disk); the
         * default patch size makes 1600-2600, five times slower. */
        c.subdiv = catalog[k].subdiv;
        c.engine = engine == RAD_VAL_ACCURATE ? RAD_VAL_ACCURATE : RAD_VAL_DEFAULTS;
        rad_validate_defaults(&c);
        if (cases)
            cases[k] = c;
        if (promised)
            promised[k] = c.engine == RAD_VAL_ACCURATE ? 0.001 : 0.01;
    }
    return total;
}

/* Runs cases[0..n) with their promises into a new array. */
static int run_list(const rad_validate_options *o, const rad_val_case *todo, const double *prom,
                    uint32_t nt, rad_val_result **out, uint32_t *count, rad_error *err)
{
    rad_val_result *res = calloc(nt ? nt : 1, sizeof *res);
    if (!res)
        return rad_fail(err, RAD_ERR_NOMEM, "validate: out of memory");
    int rc = RAD_OK;
    for (uint32_t k = 0; k < nt && !rc; k++) {
        rad_val_case c = todo[k];
        c.processes = o->processes;
        c.gl = o->gl;
        rc = rad_validate_case(&c, &res[k], err);
        if (rc)
            break;
        res[k].promised = prom[k];
        if (o->progress)
            o->progress(o->progress_user, k + 1, nt, &res[k]);
    }
    if (rc) {
        free(res);
        return rc;
    }
    *out = res;
    *count = nt;
    return RAD_OK;
}

int rad_validate_run(const rad_validate_options *opt, rad_val_result **out, uint32_t *count,
                     rad_error *err)
{
    if (!out || !count)
        return rad_fail(err, RAD_ERR_USAGE, "validate: out and count must not be NULL");
    *out = NULL;
    *count = 0;
    rad_validate_options o = {0};
    if (opt)
        o = *opt;
    static const uint32_t default_res[] = {32, 64, 256};
    if (!o.resolutions || o.resolution_count == 0) {
        o.resolutions = default_res;
        o.resolution_count = 3;
    }
    if (o.resolution_count > 64)
        return rad_fail(err, RAD_ERR_USAGE, "validate: at most 64 resolutions");
    for (uint32_t k = 0; k < o.resolution_count; k++)
        if (o.resolutions[k] < 8 || o.resolutions[k] > 4096 || o.resolutions[k] % 2)
            return rad_fail(err, RAD_ERR_USAGE,
                            "validate: resolution %u: must be even and within 8..4096",
                            o.resolutions[k]);

    if (o.catalog) {
        rad_val_case cat[64];
        double pc[64];
        uint32_t nc = rad_validate_catalog(o.engine, cat, pc, 64);
        return run_list(&o, cat, pc, nc, out, count, err);
    }
    rad_val_case std[64];
    double promised[64];
    uint32_t ns = rad_validate_standard(std, promised, 64);
    /* Per standard case: the default, the other resolutions, half and twice
     * the subdivision (the enclosure's only change is R). */
    uint32_t per = o.quick ? 1 : 1 + o.resolution_count + 2;
    rad_val_case *todo = calloc((size_t)ns * per, sizeof *todo);
    double *prom = calloc((size_t)ns * per, sizeof *prom);
    uint32_t nt = 0;
    if (!todo || !prom) {
        free(todo);
        free(prom);
        return rad_fail(err, RAD_ERR_NOMEM, "validate: out of memory");
    }
    for (uint32_t k = 0; k < ns; k++) {
        rad_val_case c = std[k];
        c.processes = o.processes;
        c.gl = o.gl;
        prom[nt] = promised[k];
        todo[nt++] = c;
        if (o.quick)
            continue;
        for (uint32_t r = 0; r < o.resolution_count; r++) {
            if (o.resolutions[r] == c.resolution)
                continue;
            todo[nt] = c;
            todo[nt++].resolution = o.resolutions[r];
        }
        if (c.config == RAD_VAL_ENCLOSURE || c.config == RAD_VAL_ELEMENT)
            continue; /* subdivision changes nothing that is measured */
        for (int h = 0; h < 2; h++) {
            rad_val_case d = c;
            d.subdiv = h ? c.subdiv * 2 : (c.subdiv + 1) / 2;
            d.subdiv_long = 0; /* rescaled from the new subdiv */
            rad_validate_defaults(&d);
            if (d.subdiv == c.subdiv)
                continue;
            todo[nt++] = d;
        }
    }
    int rc = run_list(&o, todo, prom, nt, out, count, err);
    free(todo);
    free(prom);
    return rc;
}
