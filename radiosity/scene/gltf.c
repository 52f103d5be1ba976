/* gltf.c - rad_scene_parse_gltf: a glTF 2.0 document -> a rad_scene.
 *
 * The glTF bridge (gltf_bridge.cpp, gltf_vet.cpp, gltf_texture.cpp:
 * tinygltf; gltf_image.c: stb_image) reads and checks the document; this
 * file applies the radiosity rules to what it returns.  Invariant: the
 * scene holds exactly the surfaces of the displayed glTF scene, in world
 * space, obeying scene.h, or the call fails with "FILE: WHERE: WHAT" and
 * leaves nothing behind (and says nothing else: warnings go out only on
 * success).  Everything repaired or ignored on the way is named in one
 * warning line per kind (rad_load_options.warn), never dropped silently.
 *
 * The rules, for files as Blender, three.js and the Khronos samples write
 * them:
 *   - Three bands named R, G, B.
 *   - ρ = baseColorFactor RGB × the mean linear colour of baseColorTexture
 *     (gltf_image.c: every texel sRGB-decoded, alpha ignored; a patch has
 *     one ρ, so the solve reads no texture coordinates, and the warning
 *     says so) × COLOR_0 (below).  A texture the engine cannot read counts
 *     as white (the factor alone), with a warning.
 *   - For a bake, a read baseColorTexture of PNG or JPEG is also kept in
 *     the scene (rad_texture: the image's bytes as they were, its sampler,
 *     texCoord set and baseColorFactor) with each polygon's corners'
 *     texture coordinates of that set (rad_scene_set_polygon_uv).  Two
 *     triangles become a quad only where their coordinates agree on the
 *     shared edge and are affine over the quad, so that interpolating on
 *     the quad gives what the triangles gave; a UV seam (vertices split by
 *     their coordinates) stays two polygons.  KHR_texture_transform is not
 *     applied (its extension line names it ignored).
 *   - ρ must lie in [0, 1): a surface that reflects all it receives has no
 *     place in an energy balance.  glTF's default base colour is 1, and
 *     exporters leave it on every textured material and on plain white
 *     ones, so a value >= 1 is clamped to MAX_REFLECTANCE (0.95), per band,
 *     with a warning naming the material.  A primitive without a material
 *     gets glTF's default material (white, so 0.95; not emitting;
 *     single-sided), named "default", with a warning naming the mesh.
 *   - COLOR_0 (vertex colours, linear, alpha dropped) multiplies the base
 *     colour per polygon: a triangle takes the mean of its three corners'
 *     colours (the mean of the colour glTF interpolates over it), a merged
 *     quad the mean of its two triangles'; the polygon's ρ is set on it
 *     (rad_scene_set_polygon_rho) and clamped like a material's.  A
 *     polygon the mesher subdivides gives every patch that mean.
 *   - --strict (rad_load_options.strict) refuses instead of repairing: ρ >=
 *     1 anywhere, a primitive without a material, an unreadable texture,
 *     points and lines.
 *   - E = π · emissiveFactor · emissiveStrength (KHR_materials_emissive_
 *     strength, default 1) · the mean of emissiveTexture (as for ρ).
 *     glTF's emissive value is a radiance L_e; a Lambertian emitter's
 *     exitance is π L_e, so an emitter seen directly renders with pixel
 *     value emissiveFactor × strength.
 *   - KHR_materials_diffuse_transmission (factor t, colour c, default 0
 *     and white; textures ignored) splits the diffuse lobe as the extension
 *     does: ρ = (1 − t)·baseColor, τ = t·c per band.  A transmitting
 *     material makes thin two-sided sheets (mesh twins), whatever
 *     doubleSided says; ρ + τ must stay below 1 in every band.
 *   - TRIANGLES primitives become polygons; POINTS and LINES (Blender's
 *     loose edges) have no area and are skipped with a warning; strips and
 *     fans are refused.  extensionsRequired may only name
 *     KHR_materials_emissive_strength, KHR_materials_diffuse_transmission
 *     and KHR_lights_punctual.  Other extensions in extensionsUsed (Blender
 *     writes KHR_materials_specular, KHR_materials_ior) are ignored and
 *     named; so are normal, occlusion and metallic-roughness textures, a
 *     stated metallicFactor > 0 (its lobe is drawn by the gather renderer
 *     only; glTF's default metal, 1, is what exporters leave on diffuse
 *     surfaces, so only a stated one is named and counts), alphaMode
 *     other than OPAQUE, animations, skins and morph targets, and a light's
 *     range (the bridge's notes).
 *   - KHR_lights_punctual lights placed by nodes of the scene become scene
 *     lights: position = the node's world origin, direction (spot,
 *     directional) = the node's world -Z, normalised.  Units: glTF gives a
 *     point or spot light's intensity in candela (lm/sr) and a directional
 *     light's in lux (lm/m²); we convert photometric to radiometric with the
 *     luminous efficacy K = 683 lm/W, per band
 *         I_b = color_b × intensity / 683
 *     in W/sr (point, spot) or W/m² (directional), so a white light of 683 cd
 *     has a radiant intensity of 1 W/sr in each band.  (683 lm/W holds
 *     exactly only at 555 nm; applied to all three bands it is the usual
 *     renderer convention, not a spectral conversion.)  glTF's `range` is
 *     ignored: the light falls off physically, as 1/r², everywhere.  Spot
 *     cones keep glTF's smooth falloff between inner and outer angle.  Name:
 *     light name, else node name, else "light<index>", made unique with #k.
 *   - One object per node of the scene that has a mesh and at least one
 *     surviving polygon, named after the node, else its mesh, else
 *     "node<index>"; a name used twice gets "#2", "#3", ... in node order so
 *     that object names stay unique as scene.h requires.
 *   - Triangles go to world space in double precision.  glTF says a node
 *     whose world matrix has a negative determinant mirrors the geometry and
 *     thereby flips the front face; the winding is reversed there so that the
 *     front keeps facing where the author meant.
 *   - A triangle whose area is below 1e-14 × (scene bounding-box diagonal)²,
 *     or below 2e-12 × (its own bounding-box diagonal)² (a needle scene.c
 *     would refuse as zero-area), is dropped: it carries no energy, and
 *     exporters leave such slivers behind.  Drops are counted; a document
 *     whose every triangle drops is refused with the count.
 *   - Two triangles of one primitive that share an edge and together form a
 *     planar parallelogram become one quad polygon (counter-clockwise about
 *     their common normal), so that a box face exported as two triangles is
 *     meshed into bilinear patches like a quad of the polygon file.  Matching
 *     is greedy in triangle order, first across edges that are the longest
 *     of both triangles (the diagonal a quad was cut along), then across any
 *     edge, longest first, partner with the lowest index first: the result
 *     is deterministic.
 *   - A doubleSided opaque material gives each polygon a second, reversed
 *     copy in the same object, right after it, so that both faces take part
 *     in the exchange; a single-sided polygon has only its front face.
 *   - Cameras become scene cameras (eye at the node's world origin, looking
 *     along its -Z, up its +Y): perspective ones with yfov in degrees and
 *     aspectRatio or 0, orthographic ones with xmag and ymag (the renderer
 *     draws them; znear and zfar are not used).  Name: camera name, else
 *     node name, else "camera<index>".
 *   - Polygons are named "mesh/primitive/triangle" for messages.
 */
#include "gltf_bridge.h"
#include "scene.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_MAX_POLYGONS 10000000ull

/* Relative tolerances of the quad merge: float32 positions carry ~6e-8 of
 * relative rounding, so 1e-6 accepts a true parallelogram after export and
 * transform while refusing any visible shear. */
#define QUAD_TOL 1e-6

/* The largest reflectance a glTF colour becomes: a value >= 1 (glTF's
 * default white, an untextured factor of 1, a bright vertex colour) is
 * clamped to it unless --strict.  0.95 is the reflectance of the whitest
 * real paints and papers, and keeps ρ F well below 1 so an enclosure's
 * solve converges in a few dozen sweeps. */
#define MAX_REFLECTANCE 0.95

/* The kinds of warning, one line each, in the order printed.  The first
 * RAD_GLTF_NOTE_COUNT are the bridge's notes (gltf_bridge.h). */
enum {
    W_TEXTURES = RAD_GLTF_NOTE_TEXTURES,
    W_METALLIC = RAD_GLTF_NOTE_METALLIC,
    W_ALPHA = RAD_GLTF_NOTE_ALPHA,
    W_ANIMATION = RAD_GLTF_NOTE_ANIMATION,
    W_LIGHT_RANGE = RAD_GLTF_NOTE_LIGHT_RANGE,
    W_EXTENSION = RAD_GLTF_NOTE_COUNT,
    W_TEXCOORD,
    W_NO_TEXCOORD,
    W_UNREADABLE,
    W_NO_MATERIAL,
    W_CLAMPED,
    W_SKIPPED,
    W_COUNT
};

/* Each kind's line, "FILE: WHERE SUBJECTS: WHAT", WHERE in the singular
 * or the plural as the subjects are one or more ("" when the subjects say
 * what they are). */
static const struct {
    const char *one, *many, *what;
} warn_text[W_COUNT] = {
    [W_TEXTURES] = {"material", "materials",
                    "normal, occlusion and metallic-roughness textures ignored (surfaces are "
                    "diffuse)"},
    [W_METALLIC] = {"material", "materials", "metallicFactor drawn by render --gather only (the solve treats them as diffuse)"},
    [W_ALPHA] = {"material", "materials", "alphaMode ignored (surfaces are opaque)"},
    [W_ANIMATION] = {"", "", "ignored (the scene as its nodes place it)"},
    [W_LIGHT_RANGE] = {"light", "lights", "range ignored (light falls off as 1/r² everywhere)"},
    [W_EXTENSION] = {"extension", "extensions", "ignored"},
    [W_TEXCOORD] = {"material", "materials",
                    "texture coordinates ignored by the solve: a texture counts by the mean "
                    "colour of all its texels (bake keeps a baseColorTexture)"},
    [W_NO_TEXCOORD] = {"mesh", "meshes",
                       "primitives without the TEXCOORD set of their baseColorTexture: baked "
                       "with texture coordinate (0, 0)"},
    [W_UNREADABLE] = {"texture", "textures", "not read: the factor alone is used"},
    [W_NO_MATERIAL] = {"mesh", "meshes",
                       "primitives without a material get glTF's default material (white: "
                       "reflectance 0.95 unless vertex colours make it less)"},
    [W_CLAMPED] = {"material", "materials",
                   "reflectance >= 1 clamped to 0.95 (--strict refuses it)"},
    [W_SKIPPED] = {"mesh", "meshes", "primitives without area (points, lines) skipped"},
};

/* Subjects named in one warning line before "and N more". */
#define WARN_LIST_MAX 8

typedef struct warn_list {
    char *subject[WARN_LIST_MAX];
    uint32_t count; /* all subjects, named or not */
} warn_list;

/* What the polygons of one used material need of it. */
typedef struct mat_info {
    uint32_t index;     /* scene material; RAD_NONE until added */
    int two_sided;      /* a doubleSided opaque material: each polygon gets a back copy */
    double base[3];     /* baseColorFactor × texture mean, before clamping */
    double t;           /* diffuse transmission factor */
    int clamped;        /* its own ρ was clamped */
    int clamp_noted;    /* named in the W_CLAMPED line already */
    int textured;       /* a baseColorTexture kept in the scene (rad_texture) */
    uint32_t uv_set;    /* textured: the TEXCOORD set it samples */
    const char *name;   /* the scene's name for it (owned by the scene) */
} mat_info;

typedef struct gltf_ctx {
    const char *src;
    rad_scene *s;
    rad_error *err;
    uint64_t max_polygons;
    double min_area;          /* 1e-14 × scene diagonal² */
    uint64_t triangles_dropped;
    int strict;               /* rad_load_options.strict */
    warn_list warn[W_COUNT];
} gltf_ctx;

/* "LINES", or the number of a mode glTF does not define. */
static const char *mode_name(int mode, char *buf, size_t size)
{
    static const char *const names[7] = {"POINTS",    "LINES",          "LINE_LOOP",
                                         "LINE_STRIP", "TRIANGLES",     "TRIANGLE_STRIP",
                                         "TRIANGLE_FAN"};
    if (mode >= 0 && mode < 7)
        return names[mode];
    snprintf(buf, size, "%d", mode);
    return buf;
}

static rad_vec3 xform_point(const double *m, const double *p)
{
    return rad_v3(m[0] * p[0] + m[4] * p[1] + m[8] * p[2] + m[12],
                  m[1] * p[0] + m[5] * p[1] + m[9] * p[2] + m[13],
                  m[2] * p[0] + m[6] * p[1] + m[10] * p[2] + m[14]);
}

static double det3(const double *m)
{
    return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
           m[8] * (m[1] * m[6] - m[5] * m[2]);
}

/* --------------------------------------------------------------- warnings */

/* Adds a subject to a warning line (named while there is room, counted
 * always); the caller sees to it that a subject comes once.  0, or -1 when
 * memory runs out. */
static int warn_add(gltf_ctx *c, int kind, const char *subject)
{
    warn_list *w = &c->warn[kind];
    if (w->count < WARN_LIST_MAX && !(w->subject[w->count] = strdup(subject)))
        return -1;
    w->count++;
    return 0;
}

/* warn_add for a quoted name, "'name'", cut like the bridge's names. */
static int warn_name(gltf_ctx *c, int kind, const char *name)
{
    char q[100];
    snprintf(q, sizeof q, strlen(name) > 80 ? "'%.77s...'" : "'%s'", name);
    return warn_add(c, kind, q);
}

/* One line per kind that has subjects, through opt->warn. */
static void warn_flush(const gltf_ctx *c, const rad_load_options *opt)
{
    if (!opt || !opt->warn)
        return;
    for (int k = 0; k < W_COUNT; k++) {
        const warn_list *w = &c->warn[k];
        if (w->count == 0)
            continue;
        char list[700] = "";
        size_t used = 0;
        uint32_t named = w->count < WARN_LIST_MAX ? w->count : WARN_LIST_MAX;
        for (uint32_t i = 0; i < named && used < sizeof list; i++)
            used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", i ? ", " : "",
                                     w->subject[i]);
        if (w->count > named && used < sizeof list)
            snprintf(list + used, sizeof list - used, " and %u more", w->count - named);
        const char *where = w->count == 1 ? warn_text[k].one : warn_text[k].many;
        rad_warn(opt->warn, opt->warn_user, "%s: %s%s%s: %s", c->src, where, *where ? " " : "",
                 list, warn_text[k].what);
    }
}

static void warn_free(gltf_ctx *c)
{
    for (int k = 0; k < W_COUNT; k++)
        for (uint32_t i = 0; i < c->warn[k].count && i < WARN_LIST_MAX; i++)
            free(c->warn[k].subject[i]);
}

/* ----------------------------------------------------------------- naming */

typedef struct name_rank {
    const char *name;
    uint32_t node;
} name_rank;

static int cmp_name_rank(const void *a, const void *b)
{
    const name_rank *x = a, *y = b;
    int c = strcmp(x->name, y->name);
    if (c)
        return c;
    return (x->node > y->node) - (x->node < y->node);
}

/* base, or base#k when k > 1, in a new string (NULL when memory runs out). */
static char *suffixed(const char *base, uint32_t k)
{
    size_t n = strlen(base) + 16;
    char *s = malloc(n);
    if (!s)
        return NULL;
    if (k <= 1)
        snprintf(s, n, "%s", base);
    else
        snprintf(s, n, "%s#%u", base, k);
    return s;
}

/* The first of base, base#k, base#k+1, ... that `taken` does not know, in a
 * new string; NULL when memory runs out. */
static char *unique_name(const rad_scene *s, uint32_t (*taken)(const rad_scene *, const char *),
                         const char *base, uint32_t k)
{
    for (;; k++) {
        char *n = suffixed(base, k);
        if (!n || taken(s, n) == RAD_NONE)
            return n;
        free(n);
    }
}

/* ------------------------------------------------------------- primitives */

typedef struct weld_key {
    rad_vec3 p;
    uint32_t v;
} weld_key;

static int cmp_weld(const void *a, const void *b)
{
    const weld_key *x = a, *y = b;
    if (x->p.x != y->p.x)
        return x->p.x < y->p.x ? -1 : 1;
    if (x->p.y != y->p.y)
        return x->p.y < y->p.y ? -1 : 1;
    if (x->p.z != y->p.z)
        return x->p.z < y->p.z ? -1 : 1;
    return (x->v > y->v) - (x->v < y->v);
}

/* The corner slots of triangle T ordered by the length of the edge that
 * starts there, longest first (ties keep slot order: deterministic). */
static void edge_order(const rad_vec3 *W, const uint32_t *T, uint32_t order[3])
{
    double len[3];
    for (uint32_t s = 0; s < 3; s++) {
        rad_vec3 d = rad_sub(W[T[(s + 1) % 3]], W[T[s]]);
        len[s] = rad_dot(d, d);
        order[s] = s;
    }
    for (int a = 0; a < 2; a++)
        for (int b = 0; b < 2 - a; b++)
            if (len[order[b + 1]] > len[order[b]]) {
                uint32_t x = order[b];
                order[b] = order[b + 1];
                order[b + 1] = x;
            }
}

typedef struct dir_edge {
    uint32_t from, to; /* welded vertex ids */
    uint32_t tri;      /* index into the surviving-triangle list */
    uint32_t slot;     /* the edge runs from corner slot to corner slot+1 */
} dir_edge;

static int cmp_edge(const void *a, const void *b)
{
    const dir_edge *x = a, *y = b;
    if (x->from != y->from)
        return x->from < y->from ? -1 : 1;
    if (x->to != y->to)
        return x->to < y->to ? -1 : 1;
    return (x->tri > y->tri) - (x->tri < y->tri);
}

/* First edge (from, to) in the sorted array, or n. */
static size_t find_edge(const dir_edge *e, size_t n, uint32_t from, uint32_t to)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (e[mid].from < from || (e[mid].from == from && e[mid].to < to))
            lo = mid + 1;
        else
            hi = mid;
    }
    return (lo < n && e[lo].from == from && e[lo].to == to) ? lo : n;
}

static rad_vec3 tri_normal(rad_vec3 a, rad_vec3 b, rad_vec3 c)
{
    return rad_normalize(rad_cross(rad_sub(b, a), rad_sub(c, a)));
}

/* q0 q1 r q2 is a planar parallelogram: its diagonals bisect each other
 * (q0 + r = q1 + q2) and both triangles face the same way. */
static int is_parallelogram(rad_vec3 q0, rad_vec3 q1, rad_vec3 r, rad_vec3 q2)
{
    double size = fmax(fmax(rad_length(rad_sub(q1, q0)), rad_length(rad_sub(q2, q0))),
                       fmax(rad_length(rad_sub(r, q1)), rad_length(rad_sub(r, q2))));
    rad_vec3 gap = rad_sub(rad_add(q0, r), rad_add(q1, q2));
    if (!(rad_length(gap) <= QUAD_TOL * size))
        return 0;
    rad_vec3 n1 = tri_normal(q0, q1, q2), n2 = tri_normal(r, q2, q1);
    return rad_length(rad_sub(n1, n2)) <= QUAD_TOL;
}

/* Adds one polygon (and its reversed twin for double-sided materials),
 * with its corners' texture coordinates uv (2 × n, or NULL). */
static int emit(gltf_ctx *c, const char *pname, uint32_t object, uint32_t material,
                int double_sided, const rad_vec3 *pts, const double *uv, uint32_t n,
                const char *where)
{
    for (int side = 0; side < (double_sided ? 2 : 1); side++) {
        if ((uint64_t)c->s->polygon_count >= c->max_polygons)
            return rad_fail(c->err, RAD_ERR_LIMIT, "%s: %s: more than %llu polygons (the limit)",
                            c->src, where, (unsigned long long)c->max_polygons);
        rad_vec3 rev[4];
        double ruv[8];
        const rad_vec3 *p = pts;
        const double *t = uv;
        char back[300];
        const char *name = pname;
        if (side) {
            for (uint32_t k = 0; k < n; k++) {
                rev[k] = pts[n - 1 - k];
                if (uv)
                    ruv[2 * k] = uv[2 * (n - 1 - k)], ruv[2 * k + 1] = uv[2 * (n - 1 - k) + 1];
            }
            p = rev;
            t = uv ? ruv : NULL;
            snprintf(back, sizeof back, "%s/back", pname);
            name = back;
        }
        uint32_t index;
        int rc = rad_scene_add_polygon(c->s, name, object, material, p, n, 0, 0, where, &index,
                                       c->err);
        if (rc == RAD_OK && t)
            rc = rad_scene_set_polygon_uv(c->s, index, t, where, c->err);
        if (rc)
            return rc;
    }
    return RAD_OK;
}

/* ρ of a polygon whose mean vertex colour is C: the material's base times
 * C, clamped (or refused under --strict) at 1 like a material's, then split
 * by the material's diffuse transmission.  Set on the polygons added since
 * `from` (the polygon and its back copy). */
static int color_polygons(gltf_ctx *c, uint32_t from, const double *C, mat_info *mi,
                          const char *where)
{
    double rho[3];
    for (int b = 0; b < 3; b++) {
        double r = mi->base[b] * C[b];
        if (r >= 1.0) {
            if (c->strict)
                return rad_fail(c->err, RAD_ERR_INVALID,
                                "%s: %s: material '%s' × vertex colour = %g is not a "
                                "reflectance below 1 (band %s)",
                                c->src, where, mi->name, r, c->s->band_names[b]);
            if (!mi->clamp_noted && warn_name(c, W_CLAMPED, mi->name) != 0)
                return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
            mi->clamp_noted = 1;
            r = MAX_REFLECTANCE;
        }
        rho[b] = (1.0 - mi->t) * r;
    }
    for (uint32_t p = from; p < c->s->polygon_count; p++) {
        int rc = rad_scene_set_polygon_rho(c->s, p, rho, where, c->err);
        if (rc)
            return rc;
    }
    return RAD_OK;
}

/* Mean colour of triangle T (three vertex indices) into C. */
static void triangle_color(const double *colors, const uint32_t *T, double *C)
{
    for (int b = 0; b < 3; b++)
        C[b] = (colors[3 * (size_t)T[0] + b] + colors[3 * (size_t)T[1] + b] +
                colors[3 * (size_t)T[2] + b]) /
               3.0;
}

/* emit, then the polygons' own ρ when the primitive has vertex colours
 * (C, else NULL). */
static int emit_colored(gltf_ctx *c, const char *pname, uint32_t object, mat_info *mi,
                        const rad_vec3 *pts, const double *uv, uint32_t n, const char *where,
                        const double *C)
{
    uint32_t before = c->s->polygon_count;
    int rc = emit(c, pname, object, mi->index, mi->two_sided, pts, uv, n, where);
    if (rc == RAD_OK && C)
        rc = color_polygons(c, before, C, mi, where);
    return rc;
}

/* One primitive on its way through convert_primitive's phases: weld_vertices
 * fills W, canon and keys; keep_triangles tri and edges (and kept, ne);
 * pair_triangles partner and pslot; emit_primitive reads them all. */
typedef struct prim_work {
    rad_vec3 *W;       /* [nv] the vertices in world space */
    uint32_t *canon;   /* [nv] vertex -> id of its welded position */
    weld_key *keys;    /* [nv] the vertices sorted by position */
    uint32_t *tri;     /* [4 kept] the kept triangles: 3 corners + original index */
    dir_edge *edges;   /* [ne] their edges, sorted by (from, to) */
    uint32_t *partner; /* [kept] the triangle paired with, or RAD_NONE */
    uint32_t *pslot;   /* [kept] the corner slot where the shared edge starts */
    uint32_t kept;
    size_t ne;
} prim_work;

/* Transforms the vertices to world space (a non-finite one is an error)
 * and welds equal positions, so that triangles exported with split
 * vertices (per-face normals or UVs) or without indices still find their
 * neighbours. */
static int weld_vertices(gltf_ctx *c, const rad_gltf_raw_mesh *mesh, uint32_t pi,
                         const double *world, prim_work *pw)
{
    const rad_gltf_raw_primitive *pr = &mesh->primitives[pi];
    uint32_t nv = pr->vertex_count;
    for (uint32_t v = 0; v < nv; v++) {
        pw->W[v] = xform_point(world, pr->positions + 3 * (size_t)v);
        if (!rad_finite3(pw->W[v])) /* a huge scale overflowed; the sort below needs order */
            return rad_fail(c->err, RAD_ERR_INVALID,
                            "%s: mesh '%s' primitive %u: vertex %u is too large in world space",
                            c->src, mesh->name, pi, v);
        pw->keys[v].p = pw->W[v];
        pw->keys[v].v = v;
    }
    qsort(pw->keys, nv, sizeof *pw->keys, cmp_weld);
    for (uint32_t k = 0, id = 0; k < nv; k++) {
        rad_vec3 a = pw->keys[k].p, b = k ? pw->keys[k - 1].p : a;
        if (a.x != b.x || a.y != b.y || a.z != b.z)
            id++;
        pw->canon[pw->keys[k].v] = id;
    }
    return RAD_OK;
}

/* Keeps the triangles that are no slivers (area below the scene's floor or
 * tiny for their size) and have three distinct welded corners, wound
 * counter-clockwise in world space (a mirroring transform flips them), and
 * lists their directed edges sorted; the others count as dropped. */
static void keep_triangles(gltf_ctx *c, const rad_gltf_raw_primitive *pr, const double *world,
                           prim_work *pw)
{
    const rad_vec3 *W = pw->W;
    const uint32_t *canon = pw->canon;
    uint32_t nt = pr->index_count / 3;
    int flip = det3(world) < 0.0;
    uint32_t kept = 0;
    for (uint32_t t = 0; t < nt; t++) {
        uint32_t a = pr->indices[3 * (size_t)t], b = pr->indices[3 * (size_t)t + 1],
                 d = pr->indices[3 * (size_t)t + 2];
        if (flip) {
            uint32_t x = b;
            b = d;
            d = x;
        }
        rad_vec3 lo = W[a], hi = W[a];
        rad_vec3 corner[2] = {W[b], W[d]};
        for (int k = 0; k < 2; k++) {
            lo = rad_v3(fmin(lo.x, corner[k].x), fmin(lo.y, corner[k].y), fmin(lo.z, corner[k].z));
            hi = rad_v3(fmax(hi.x, corner[k].x), fmax(hi.y, corner[k].y), fmax(hi.z, corner[k].z));
        }
        double size = rad_length(rad_sub(hi, lo));
        double area = 0.5 * rad_length(rad_cross(rad_sub(W[b], W[a]), rad_sub(W[d], W[a])));
        if (!(area >= c->min_area) || !(area >= 2e-12 * size * size) ||
            canon[a] == canon[b] || canon[b] == canon[d] || canon[a] == canon[d]) {
            c->triangles_dropped++;
            continue;
        }
        uint32_t *T = &pw->tri[4 * (size_t)kept];
        T[0] = a;
        T[1] = b;
        T[2] = d;
        T[3] = t;
        for (uint32_t s = 0; s < 3; s++) {
            dir_edge *e = &pw->edges[3 * (size_t)kept + s];
            e->from = canon[T[s]];
            e->to = canon[T[(s + 1) % 3]];
            e->tri = kept;
            e->slot = s;
        }
        pw->partner[kept] = RAD_NONE;
        kept++;
    }
    pw->kept = kept;
    pw->ne = 3 * (size_t)kept;
    qsort(pw->edges, pw->ne, sizeof *pw->edges, cmp_edge);
}

/* Greedy pairing: triangle t, corner slot s: edge q1 -> q2 with q0
 * opposite; a neighbour u holding q2 -> q1 with r opposite makes the quad
 * q0 q1 r q2, counter-clockwise like t.  The first pass pairs only across
 * an edge that is the longest of both triangles -- the diagonal an
 * exporter cut a quad along -- so that a grid of squares is not paired
 * into slanted parallelograms across its cells; the second pass pairs what
 * is left across any edge, longest first. */
static void pair_triangles(prim_work *pw)
{
    const rad_vec3 *W = pw->W;
    const uint32_t *canon = pw->canon;
    const dir_edge *edges = pw->edges;
    uint32_t *partner = pw->partner;
    size_t ne = pw->ne;
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t t = 0; t < pw->kept; t++) {
            if (partner[t] != RAD_NONE)
                continue;
            const uint32_t *T = &pw->tri[4 * (size_t)t];
            uint32_t order[3];
            edge_order(W, T, order);
            for (uint32_t o = 0; o < (pass ? 3u : 1u) && partner[t] == RAD_NONE; o++) {
                uint32_t s = order[o];
                uint32_t i1 = T[s], i2 = T[(s + 1) % 3], i0 = T[(s + 2) % 3];
                size_t k = find_edge(edges, ne, canon[i2], canon[i1]);
                for (; k < ne && edges[k].from == canon[i2] && edges[k].to == canon[i1]; k++) {
                    uint32_t u = edges[k].tri;
                    if (u == t || partner[u] != RAD_NONE)
                        continue;
                    const uint32_t *U = &pw->tri[4 * (size_t)u];
                    if (pass == 0) {
                        uint32_t uo[3];
                        edge_order(W, U, uo);
                        if (uo[0] != edges[k].slot)
                            continue;
                    }
                    uint32_t r = U[(edges[k].slot + 2) % 3];
                    if (canon[r] == canon[i0] || !is_parallelogram(W[i0], W[i1], W[r], W[i2]))
                        continue;
                    partner[t] = u;
                    partner[u] = t;
                    pw->pslot[t] = s;
                    pw->pslot[u] = edges[k].slot;
                    break;
                }
            }
        }
    }
}

/* The texture coordinates of vertices v[0..n) into out (2 × n); NULL
 * (out untouched) when the primitive has none for the material. */
static const double *corner_uv(const double *uv, const uint32_t *v, uint32_t n, double *out)
{
    if (!uv)
        return NULL;
    for (uint32_t k = 0; k < n; k++)
        out[2 * k] = uv[2 * (size_t)v[k]], out[2 * k + 1] = uv[2 * (size_t)v[k] + 1];
    return out;
}

/* Texture coordinates allow the pair t, u to be the quad q0 q1 r q2: they
 * agree on the shared edge (no seam along it) and are affine over the
 * parallelogram (uv(q0) + uv(r) = uv(q1) + uv(q2)), so that interpolating
 * on the quad gives what the two triangles gave. */
static int quad_uv_ok(const double *uv, const prim_work *pw, uint32_t t, uint32_t u)
{
    if (!uv)
        return 1;
    const uint32_t *T = &pw->tri[4 * (size_t)t], *U = &pw->tri[4 * (size_t)u];
    uint32_t s = pw->pslot[t], su = pw->pslot[u];
    uint32_t i1 = T[s], i2 = T[(s + 1) % 3], i0 = T[(s + 2) % 3];
    uint32_t j2 = U[su], j1 = U[(su + 1) % 3], r = U[(su + 2) % 3]; /* u runs q2 -> q1 */
    for (int c = 0; c < 2; c++) {
        double a0 = uv[2 * i0 + c], a1 = uv[2 * i1 + c], a2 = uv[2 * i2 + c], ar = uv[2 * r + c];
        double tol = QUAD_TOL * (1.0 + fmax(fmax(fabs(a0), fabs(a1)), fmax(fabs(a2), fabs(ar))));
        if (uv[2 * j1 + c] != a1 || uv[2 * j2 + c] != a2 || fabs(a0 + ar - a1 - a2) > tol)
            return 0;
    }
    return 1;
}

/* Adds the kept triangles, each pair as one quad where scene.c takes it,
 * with each polygon's mean vertex colour when the primitive has COLOR_0
 * and its corners' texture coordinates when its material keeps a texture.
 * *object is created on the first polygon. */
static int emit_primitive(gltf_ctx *c, const rad_gltf_raw_mesh *mesh, uint32_t pi,
                          const char *object_name, uint32_t *object, mat_info *mi,
                          const prim_work *pw)
{
    const rad_vec3 *W = pw->W;
    const double *col = mesh->primitives[pi].colors;
    const double *uv = mi->textured && mi->uv_set < 2 ? mesh->primitives[pi].uv[mi->uv_set] : NULL;
    double cuv[8];
    char where[300], pname[300];
    snprintf(where, sizeof where, "object '%.200s'", object_name);
    for (uint32_t t = 0; t < pw->kept; t++) {
        uint32_t u = pw->partner[t];
        if (u != RAD_NONE && u < t)
            continue; /* emitted with its partner */
        int rc;
        if (*object == RAD_NONE) {
            rc = rad_scene_add_object(c->s, object_name, where, object, c->err);
            if (rc)
                return rc;
        }
        const uint32_t *T = &pw->tri[4 * (size_t)t];
        snprintf(pname, sizeof pname, "%.200s/%u/%u", mesh->name, pi, T[3]);
        /* Vertex colours: a triangle's mean is the mean of its corners'
         * (exact for the linear interpolation glTF draws); a quad's, of
         * its two triangles of equal area. */
        double Ct[3], Cu[3], Cq[3];
        if (col)
            triangle_color(col, T, Ct);
        if (col && u != RAD_NONE)
            triangle_color(col, &pw->tri[4 * (size_t)u], Cu);
        if (u != RAD_NONE && quad_uv_ok(uv, pw, t, u)) {
            uint32_t s = pw->pslot[t];
            uint32_t i1 = T[s], i2 = T[(s + 1) % 3], i0 = T[(s + 2) % 3];
            uint32_t r = pw->tri[4 * (size_t)u + (pw->pslot[u] + 2) % 3];
            rad_vec3 quad[4] = {W[i0], W[i1], W[r], W[i2]};
            const uint32_t qv[4] = {i0, i1, r, i2};
            if (col)
                for (int b = 0; b < 3; b++)
                    Cq[b] = 0.5 * (Ct[b] + Cu[b]);
            /* A pair that passes the test above but not scene.c's own
             * planarity or convexity check stays two triangles; any other
             * failure is the caller's. */
            rad_error scratch;
            memset(&scratch, 0, sizeof scratch);
            uint32_t before = c->s->polygon_count;
            gltf_ctx probe = *c;
            probe.err = &scratch;
            rc = emit_colored(&probe, pname, *object, mi, quad, corner_uv(uv, qv, 4, cuv), 4,
                              where, col ? Cq : NULL);
            memcpy(c->warn, probe.warn, sizeof c->warn); /* what the probe noted */
            if (rc == RAD_OK)
                continue;
            if (rc != RAD_ERR_INVALID || c->s->polygon_count != before) {
                if (c->err)
                    *c->err = scratch;
                return rc;
            }
        }
        rad_vec3 p3[3] = {W[T[0]], W[T[1]], W[T[2]]};
        rc = emit_colored(c, pname, *object, mi, p3, corner_uv(uv, T, 3, cuv), 3, where,
                          col ? Ct : NULL);
        if (rc == RAD_OK && u != RAD_NONE) {
            const uint32_t *U = &pw->tri[4 * (size_t)u];
            rad_vec3 q3[3] = {W[U[0]], W[U[1]], W[U[2]]};
            snprintf(pname, sizeof pname, "%.200s/%u/%u", mesh->name, pi, U[3]);
            rc = emit_colored(c, pname, *object, mi, q3, corner_uv(uv, U, 3, cuv), 3, where,
                              col ? Cu : NULL);
        }
        if (rc)
            return rc;
    }
    return RAD_OK;
}

/* Converts one primitive of one node: transform and weld, drop slivers,
 * merge parallelogram pairs, add (with each polygon's mean vertex colour
 * when the primitive has COLOR_0).  *object is created on the first
 * polygon. */
static int convert_primitive(gltf_ctx *c, const rad_gltf_raw_mesh *mesh, uint32_t pi,
                             const double *world, const char *object_name, uint32_t *object,
                             mat_info *mi)
{
    const rad_gltf_raw_primitive *pr = &mesh->primitives[pi];
    uint32_t nv = pr->vertex_count, nt = pr->index_count / 3;
    if (nt == 0)
        return RAD_OK;
    int rc = RAD_OK;
    prim_work pw = {
        .W = malloc((size_t)(nv ? nv : 1) * sizeof *pw.W),
        .canon = malloc((size_t)(nv ? nv : 1) * sizeof *pw.canon),
        .keys = malloc((size_t)(nv ? nv : 1) * sizeof *pw.keys),
        .tri = malloc((size_t)nt * 4 * sizeof *pw.tri),
        .edges = malloc((size_t)nt * 3 * sizeof *pw.edges),
        .partner = malloc((size_t)nt * sizeof *pw.partner),
        .pslot = malloc((size_t)nt * sizeof *pw.pslot),
    };
    if (!pw.W || !pw.canon || !pw.keys || !pw.tri || !pw.edges || !pw.partner || !pw.pslot)
        rc = rad_fail(c->err, RAD_ERR_NOMEM, "%s: mesh '%s' primitive %u: out of memory", c->src,
                      mesh->name, pi);
    if (rc == RAD_OK)
        rc = weld_vertices(c, mesh, pi, world, &pw);
    if (rc == RAD_OK) {
        keep_triangles(c, pr, world, &pw);
        pair_triangles(&pw);
        rc = emit_primitive(c, mesh, pi, object_name, object, mi, &pw);
    }
    free(pw.W);
    free(pw.canon);
    free(pw.keys);
    free(pw.tri);
    free(pw.edges);
    free(pw.partner);
    free(pw.pslot);
    return rc;
}

/* -------------------------------------------------------------- materials */

/* A texture's mean (1 in every band when there is none); an unreadable one
 * is named in a warning and counts as none, or is an error under --strict.
 * Sets *read when the mean came from an image. */
static int texture_mean(gltf_ctx *c, const rad_gltf_raw_material *m,
                        const rad_gltf_raw_texture *tx, const char *slot, double mean[3],
                        int *read)
{
    mean[0] = mean[1] = mean[2] = 1.0;
    if (tx->state == RAD_GLTF_TEXTURE_READ) {
        memcpy(mean, tx->mean, sizeof tx->mean);
        *read = 1;
    } else if (tx->state == RAD_GLTF_TEXTURE_UNREADABLE) {
        if (c->strict)
            return rad_fail(c->err, RAD_ERR_INVALID, "%s: material '%s': %s: %s", c->src,
                            m->name, slot, tx->problem);
        char subject[500];
        snprintf(subject, sizeof subject, "'%.80s' %s (%s)", m->name, slot, tx->problem);
        if (warn_add(c, W_UNREADABLE, subject) != 0)
            return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
    }
    return RAD_OK;
}

/* The checks of the document's own numbers (before any texture or clamp). */
static int check_material(gltf_ctx *c, const rad_gltf_raw_material *m)
{
    const char *band[3] = {"R", "G", "B"};
    double st = m->emissive_strength, t = m->diffuse_transmission;
    if (!isfinite(st) || st < 0.0)
        return rad_fail(c->err, RAD_ERR_INVALID,
                        "%s: material '%s': emissiveStrength %g must be finite and >= 0", c->src,
                        m->name, st);
    if (!(t >= 0.0 && t <= 1.0))
        return rad_fail(c->err, RAD_ERR_INVALID,
                        "%s: material '%s': diffuseTransmissionFactor %g is not in [0, 1]", c->src,
                        m->name, t);
    for (int b = 0; b < 3; b++) {
        double r = m->base_color[b], f = m->emissive[b], tc = m->diffuse_transmission_color[b];
        if (!isfinite(r) || r < 0.0)
            return rad_fail(c->err, RAD_ERR_INVALID,
                            "%s: material '%s': baseColorFactor %g is not a reflectance "
                            "(band %s)",
                            c->src, m->name, r, band[b]);
        if (!isfinite(f) || f < 0.0)
            return rad_fail(c->err, RAD_ERR_INVALID,
                            "%s: material '%s': emissiveFactor %g must be finite and >= 0 "
                            "(band %s)",
                            c->src, m->name, f, band[b]);
        if (!(tc >= 0.0 && tc <= 1.0))
            return rad_fail(c->err, RAD_ERR_INVALID,
                            "%s: material '%s': diffuseTransmissionColorFactor %g is not in "
                            "[0, 1] (band %s)",
                            c->src, m->name, tc, band[b]);
    }
    return RAD_OK;
}

/* A read baseColorTexture whose image the bridge kept (a PNG or JPEG)
 * becomes the scene's texture of material mi (scene image k = the raw
 * image k, convert adds them all first), for a bake; the solve still
 * reflects its mean. */
static int keep_texture(gltf_ctx *c, const rad_gltf_raw_material *m, mat_info *mi,
                        const char *where)
{
    const rad_gltf_raw_texture *tx = &m->base_texture;
    if (tx->state != RAD_GLTF_TEXTURE_READ || tx->image < 0)
        return RAD_OK;
    rad_texture t = {.material = mi->index, .image = (uint32_t)tx->image,
                     .texcoord = tx->texcoord, .wrap_s = tx->wrap_s, .wrap_t = tx->wrap_t,
                     .mag_filter = tx->mag_filter, .min_filter = tx->min_filter};
    /* glTF keeps the factor in [0, 1]; a larger one is clamped as shown */
    for (int k = 0; k < 4; k++)
        t.factor[k] = fmin(1.0, k < 3 ? m->base_color[k] : m->base_alpha);
    int rc = rad_scene_add_texture(c->s, &t, where, c->err);
    if (rc)
        return rc;
    mi->textured = 1;
    mi->uv_set = tx->texcoord;
    return RAD_OK;
}

/* Adds material m to the scene and fills *mi (whether its own ρ was
 * clamped: it is named in the warning once a polygon without vertex colours
 * uses it, see convert). */
static int add_material(gltf_ctx *c, const rad_gltf_raw_material *m, mat_info *mi)
{
    int rc = check_material(c, m);
    if (rc)
        return rc;
    double base_tex[3], emit_tex[3], rho[3], e[3], tau[3];
    int read = 0, clamped = 0;
    if ((rc = texture_mean(c, m, &m->base_texture, "baseColorTexture", base_tex, &read)) ||
        (rc = texture_mean(c, m, &m->emissive_texture, "emissiveTexture", emit_tex, &read)))
        return rc;
    double t = m->diffuse_transmission;
    for (int b = 0; b < 3; b++) {
        double r = m->base_color[b] * base_tex[b];
        mi->base[b] = r;
        if (r >= 1.0) {
            if (c->strict)
                return rad_fail(c->err, RAD_ERR_INVALID,
                                m->base_texture.state == RAD_GLTF_TEXTURE_READ
                                    ? "%s: material '%s': baseColorFactor × texture mean %g is "
                                      "not a reflectance below 1 (band %s)"
                                    : "%s: material '%s': baseColorFactor %g is not a "
                                      "reflectance below 1 (band %s)",
                                c->src, m->name, r, c->s->band_names[b]);
            r = MAX_REFLECTANCE;
            clamped = 1;
        }
        /* KHR_materials_diffuse_transmission mixes the diffuse lobe: a share
         * t of it is transmitted (colour tc), the rest reflected. */
        rho[b] = (1.0 - t) * r;
        tau[b] = t * m->diffuse_transmission_color[b];
        e[b] = M_PI * m->emissive[b] * m->emissive_strength * emit_tex[b];
    }
    /* glTF names need not be unique; ours must be. */
    char *name = unique_name(c->s, rad_scene_find_material, m->name, 1), where[340];
    if (!name)
        return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
    snprintf(where, sizeof where, "material '%.200s'", name);
    rc = rad_scene_add_material(c->s, name, rho, e, tau, where, &mi->index, c->err);
    /* pbrMetallicRoughness: the glossy lobe of the gather renderer (scene.h
     * gives the mapping).  An unstated metallicFactor counts as 0, not
     * glTF's 1: this engine has always read baseColorFactor as a diffuse ρ,
     * and a document that says nothing of metals keeps that meaning. */
    if (!rc && (m->metallic != 0.0 || m->roughness != 1.0))
        rc = rad_scene_set_material_gloss(c->s, mi->index, m->metallic, m->roughness, where,
                                          c->err);
    free(name);
    if (rc)
        return rc;
    mi->t = t;
    mi->name = c->s->materials[mi->index].name;
    /* a transmitting sheet has both sides already (mesh twins) */
    mi->two_sided = m->double_sided &&
                    !rad_material_transmits(&c->s->materials[mi->index], c->s->band_count);
    mi->clamped = clamped;
    if (read && warn_name(c, W_TEXCOORD, mi->name) != 0)
        return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
    return keep_texture(c, m, mi, where);
}

/* ----------------------------------------------------------------- lights */

/* Lumens per watt: photometric glTF values -> radiometric ones. */
#define LUMINOUS_EFFICACY 683.0

static int add_light(gltf_ctx *c, const rad_gltf_raw_light *L)
{
    const double *w = L->world;
    double I[3];
    for (int b = 0; b < 3; b++)
        I[b] = L->color[b] * L->intensity / LUMINOUS_EFFICACY;
    rad_light_kind kind = L->type == RAD_GLTF_LIGHT_SPOT          ? RAD_LIGHT_SPOT
                          : L->type == RAD_GLTF_LIGHT_DIRECTIONAL ? RAD_LIGHT_DIRECTIONAL
                                                                  : RAD_LIGHT_POINT;
    rad_vec3 pos = rad_v3(w[12], w[13], w[14]);
    rad_vec3 dir = rad_v3(-w[8], -w[9], -w[10]); /* rad_scene_add_light normalises */
    char *name = unique_name(c->s, rad_scene_find_light, L->name, 1), where[340];
    if (!name)
        return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
    snprintf(where, sizeof where, "light '%.200s' (node %u)", name, L->node);
    int rc = rad_scene_add_light(c->s, name, kind, I, pos, dir, L->inner_cone, L->outer_cone,
                                 where, NULL, c->err);
    free(name);
    return rc;
}

/* ----------------------------------------------------------------- entry */

/* Directory part of a path ("." when there is none): where external
 * buffers are looked up. */
static char *dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return strdup(".");
    size_t n = slash == path ? 1 : (size_t)(slash - path);
    char *d = malloc(n + 1);
    if (d) {
        memcpy(d, path, n);
        d[n] = '\0';
    }
    return d;
}

/* The extensions this loader reads; a required one outside this list is
 * refused, a used one is named in a warning. */
static int supported_extension(const char *name)
{
    return strcmp(name, "KHR_materials_emissive_strength") == 0 ||
           strcmp(name, "KHR_materials_diffuse_transmission") == 0 ||
           strcmp(name, "KHR_lights_punctual") == 0;
}

/* extensionsRequired we cannot honour fail; the rest of extensionsUsed
 * and the bridge's notes go to the warnings. */
static int check_extensions(gltf_ctx *c, const rad_gltf_raw *raw)
{
    for (uint32_t k = 0; k < raw->extensions_required_count; k++)
        if (!supported_extension(raw->extensions_required[k]))
            return rad_fail(c->err, RAD_ERR_INVALID,
                            "%s: extension '%s' is required but not supported", c->src,
                            raw->extensions_required[k]);
    for (uint32_t k = 0; k < raw->extensions_used_count; k++) {
        const char *e = raw->extensions_used[k];
        int again = 0;
        for (uint32_t j = 0; j < k; j++)
            again |= strcmp(raw->extensions_used[j], e) == 0;
        if (!again && !supported_extension(e) && warn_add(c, W_EXTENSION, e) != 0)
            return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
    }
    for (uint32_t k = 0; k < raw->note_count; k++)
        if (raw->notes[k].kind >= 0 && raw->notes[k].kind < RAD_GLTF_NOTE_COUNT &&
            warn_add(c, raw->notes[k].kind, raw->notes[k].subject) != 0)
            return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
    return RAD_OK;
}

/* What pass 1 learns for pass 2: the materials in use (mats[material_count]
 * is glTF's default material, for primitives without one), and per mesh
 * which warnings named it already. */
typedef struct plan {
    mat_info *mats;
    uint8_t *mesh_noted; /* bit 1: W_SKIPPED, bit 2: W_NO_MATERIAL, bit 4: W_NO_TEXCOORD */
} plan;

/* glTF's default material: white, not emitting, single-sided, diffuse
 * (roughness 1; metallic 0 as for every material that states none). */
static const rad_gltf_raw_material default_material = {
    .name = "default",
    .base_color = {1, 1, 1},
    .roughness = 1,
    .emissive_strength = 1,
    .diffuse_transmission_color = {1, 1, 1},
};

/* The mat_info of primitive p of mesh me (node instancing meets it again:
 * the material is added once), or NULL with rc set. */
static mat_info *primitive_material(gltf_ctx *c, const rad_gltf_raw *raw, plan *pl,
                                    int32_t mesh, uint32_t p, int *rc)
{
    const rad_gltf_raw_mesh *me = &raw->meshes[mesh];
    const rad_gltf_raw_primitive *pr = &me->primitives[p];
    const rad_gltf_raw_material *m = &default_material;
    mat_info *mi = &pl->mats[raw->material_count];
    if (pr->material >= 0) {
        m = &raw->materials[pr->material];
        mi = &pl->mats[pr->material];
    } else if (c->strict) {
        *rc = rad_fail(c->err, RAD_ERR_INVALID,
                       "%s: mesh '%s' primitive %u: no material (glTF's default material is "
                       "white 1.0, not a physical reflectance)",
                       c->src, me->name, p);
        return NULL;
    } else if (!(pl->mesh_noted[mesh] & 2)) {
        pl->mesh_noted[mesh] |= 2;
        if (warn_name(c, W_NO_MATERIAL, me->name) != 0)
            goto nomem;
    }
    if (mi->index == RAD_NONE && (*rc = add_material(c, m, mi)))
        return NULL;
    /* Its own ρ is what a primitive without vertex colours gets. */
    if (!pr->colors && mi->clamped && !mi->clamp_noted) {
        mi->clamp_noted = 1;
        if (warn_name(c, W_CLAMPED, mi->name) != 0)
            goto nomem;
    }
    return mi;
nomem:
    *rc = rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
    return NULL;
}

/* A primitive mode without area (points, lines): skipped with a warning, or
 * refused under --strict; any mode but TRIANGLES is refused.  1 = skip it,
 * 0 = convert it, -1 = refused (rc set). */
static int skip_mode(gltf_ctx *c, const rad_gltf_raw *raw, plan *pl, int32_t mesh, uint32_t p,
                     int *rc)
{
    const rad_gltf_raw_mesh *me = &raw->meshes[mesh];
    int mode = me->primitives[p].mode;
    if (mode == RAD_GLTF_MODE_TRIANGLES)
        return 0;
    char mb[16];
    if (mode >= 0 && mode <= 3 && !c->strict) { /* POINTS, LINES, LINE_LOOP, LINE_STRIP */
        if (!(pl->mesh_noted[mesh] & 1)) {
            pl->mesh_noted[mesh] |= 1;
            char subject[200];
            snprintf(subject, sizeof subject, "'%.80s' (%s)", me->name,
                     mode_name(mode, mb, sizeof mb));
            if (warn_add(c, W_SKIPPED, subject) != 0) {
                *rc = rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
                return -1;
            }
        }
        return 1;
    }
    *rc = rad_fail(c->err, RAD_ERR_INVALID,
                   "%s: mesh '%s' primitive %u: mode %s not supported (only TRIANGLES)", c->src,
                   me->name, p, mode_name(mode, mb, sizeof mb));
    return -1;
}

/* Pass 1: mode and material of every primitive the scene shows, the
 * materials they use, and the scene's extent for the sliver threshold. */
static int plan_primitives(gltf_ctx *c, const rad_gltf_raw *raw, plan *pl)
{
    int rc = RAD_OK, have_box = 0;
    rad_vec3 lo = rad_v3(0, 0, 0), hi = lo;
    for (uint32_t i = 0; i < raw->node_count; i++) {
        const rad_gltf_raw_node *nd = &raw->nodes[i];
        if (!nd->in_scene || nd->mesh < 0)
            continue;
        const rad_gltf_raw_mesh *me = &raw->meshes[nd->mesh];
        for (uint32_t p = 0; p < me->primitive_count; p++) {
            const rad_gltf_raw_primitive *pr = &me->primitives[p];
            int skip = skip_mode(c, raw, pl, nd->mesh, p, &rc);
            if (skip < 0 || (!skip && !primitive_material(c, raw, pl, nd->mesh, p, &rc)))
                return rc;
            for (uint32_t k = 0; !skip && k < pr->index_count; k++) {
                rad_vec3 w = xform_point(nd->world, pr->positions + 3 * (size_t)pr->indices[k]);
                if (!have_box) {
                    lo = hi = w;
                    have_box = 1;
                }
                lo = rad_v3(fmin(lo.x, w.x), fmin(lo.y, w.y), fmin(lo.z, w.z));
                hi = rad_v3(fmax(hi.x, w.x), fmax(hi.y, w.y), fmax(hi.z, w.z));
            }
        }
    }
    double diag = rad_length(rad_sub(hi, lo));
    c->min_area = 1e-14 * diag * diag;
    if (!isfinite(c->min_area))
        return rad_fail(c->err, RAD_ERR_INVALID, "%s: coordinates too large to compute with",
                        c->src);
    return RAD_OK;
}

/* Object names: rank equal base names in node order, so the k-th node
 * called "floor" becomes "floor#k" without a quadratic search. */
static void rank_names(const rad_gltf_raw *raw, name_rank *ranks, uint32_t *rank_of)
{
    uint32_t nr = 0;
    for (uint32_t i = 0; i < raw->node_count; i++) {
        if (raw->nodes[i].in_scene && raw->nodes[i].mesh >= 0) {
            ranks[nr].name = raw->nodes[i].name;
            ranks[nr].node = i;
            nr++;
        }
    }
    qsort(ranks, nr, sizeof *ranks, cmp_name_rank);
    for (uint32_t k = 0; k < nr; k++)
        rank_of[ranks[k].node] =
            (k > 0 && strcmp(ranks[k].name, ranks[k - 1].name) == 0) ? rank_of[ranks[k - 1].node] + 1
                                                                      : 1;
}

/* Pass 2: the polygons, node by node. */
static int add_polygons(gltf_ctx *c, const rad_gltf_raw *raw, plan *pl, const uint32_t *rank_of)
{
    int rc = RAD_OK;
    for (uint32_t i = 0; i < raw->node_count && rc == RAD_OK; i++) {
        const rad_gltf_raw_node *nd = &raw->nodes[i];
        if (!nd->in_scene || nd->mesh < 0)
            continue;
        /* A literal "floor#2" elsewhere could still collide: step on. */
        char *oname = unique_name(c->s, rad_scene_find_object, nd->name, rank_of[i]);
        if (!oname)
            return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
        uint32_t object = RAD_NONE;
        const rad_gltf_raw_mesh *me = &raw->meshes[nd->mesh];
        for (uint32_t p = 0; p < me->primitive_count && rc == RAD_OK; p++) {
            const rad_gltf_raw_primitive *pr = &me->primitives[p];
            if (pr->mode != RAD_GLTF_MODE_TRIANGLES)
                continue; /* pass 1 refused or skipped it */
            mat_info *mi = &pl->mats[pr->material >= 0 ? (uint32_t)pr->material
                                                       : raw->material_count];
            if (mi->textured && (mi->uv_set > 1 || !pr->uv[mi->uv_set]) &&
                !(pl->mesh_noted[nd->mesh] & 4)) {
                pl->mesh_noted[nd->mesh] |= 4;
                if (warn_name(c, W_NO_TEXCOORD, me->name) != 0)
                    rc = rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
            }
            if (rc == RAD_OK)
                rc = convert_primitive(c, me, p, nd->world, oname, &object, mi);
        }
        free(oname);
    }
    if (rc == RAD_OK && c->s->polygon_count == 0 && c->triangles_dropped > 0)
        rc = rad_fail(c->err, RAD_ERR_INVALID,
                      "%s: all %llu triangles have zero area (nothing to light)", c->src,
                      (unsigned long long)c->triangles_dropped);
    return rc;
}

/* Cameras: eye at the node's world origin, looking along its -Z, up its +Y;
 * perspective with yfov in degrees, orthographic with xmag and ymag. */
static int add_camera(gltf_ctx *c, const rad_gltf_raw_camera *cam)
{
    const double *w = cam->world;
    rad_vec3 eye = rad_v3(w[12], w[13], w[14]);
    rad_vec3 dir = rad_normalize(rad_v3(-w[8], -w[9], -w[10]));
    rad_vec3 up = rad_normalize(rad_v3(w[4], w[5], w[6]));
    char *cname = unique_name(c->s, rad_scene_find_camera, cam->name, 1), where[340];
    if (!cname)
        return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
    snprintf(where, sizeof where, "camera '%.200s'", cname);
    int rc = cam->perspective
                 ? rad_scene_add_camera(c->s, cname, eye, rad_add(eye, dir), up,
                                        cam->yfov * (180.0 / M_PI), cam->aspect, where, NULL,
                                        c->err)
                 : rad_scene_add_ortho_camera(c->s, cname, eye, rad_add(eye, dir), up,
                                              cam->xmag, cam->ymag, where, NULL, c->err);
    free(cname);
    return rc;
}

static int convert(gltf_ctx *c, const rad_gltf_raw *raw)
{
    int rc = check_extensions(c, raw);
    if (rc)
        return rc;
    static const char *const bands[3] = {"R", "G", "B"};
    for (int b = 0; b < 3; b++)
        if (!(c->s->band_names[b] = strdup(bands[b])))
            return rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);

    for (uint32_t k = 0; k < raw->image_count; k++) {
        char where[40];
        snprintf(where, sizeof where, "image %u", k);
        rc = rad_scene_add_image(c->s, raw->images[k].mime, raw->images[k].data,
                                 raw->images[k].size, where, NULL, c->err);
        if (rc)
            return rc;
    }
    plan pl;
    pl.mats = calloc((size_t)raw->material_count + 1, sizeof *pl.mats);
    pl.mesh_noted = calloc(raw->mesh_count ? raw->mesh_count : 1, 1);
    name_rank *ranks = malloc((size_t)(raw->node_count ? raw->node_count : 1) * sizeof *ranks);
    uint32_t *rank_of = malloc((size_t)(raw->node_count ? raw->node_count : 1) * sizeof *rank_of);
    if (!pl.mats || !pl.mesh_noted || !ranks || !rank_of) {
        rc = rad_fail(c->err, RAD_ERR_NOMEM, "%s: out of memory", c->src);
        goto done;
    }
    for (uint32_t m = 0; m <= raw->material_count; m++)
        pl.mats[m].index = RAD_NONE;
    /* glTF's default material is clamped by definition: W_NO_MATERIAL says so */
    pl.mats[raw->material_count].clamp_noted = 1;
    if ((rc = plan_primitives(c, raw, &pl)))
        goto done;
    rank_names(raw, ranks, rank_of);
    if ((rc = add_polygons(c, raw, &pl, rank_of)))
        goto done;
    for (uint32_t k = 0; k < raw->camera_count && rc == RAD_OK; k++)
        rc = add_camera(c, &raw->cameras[k]);
    for (uint32_t k = 0; k < raw->light_count && rc == RAD_OK; k++)
        rc = add_light(c, &raw->lights[k]);

done:
    free(pl.mats);
    free(pl.mesh_noted);
    free(ranks);
    free(rank_of);
    return rc;
}

int rad_scene_parse_gltf(const void *data, size_t size, const char *name,
                         const rad_load_options *opt, rad_scene **out, rad_error *err)
{
    if (out)
        *out = NULL;
    const char *src = name ? name : "<memory>";
    if (!out || (!data && size))
        return rad_fail(err, RAD_ERR_USAGE, "%s: rad_scene_parse_gltf: no data or no output",
                        src);
    gltf_ctx c;
    memset(&c, 0, sizeof c);
    c.src = src;
    c.err = err;
    c.max_polygons = opt && opt->max_polygons ? opt->max_polygons : DEFAULT_MAX_POLYGONS;
    c.strict = opt && opt->strict;

    char *base = NULL;
    if (name && !(base = dir_of(name)))
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", src);
    char msg[900];
    rad_gltf_raw *raw = NULL;
    int rc = rad_gltf_bridge_load(data, size, base, c.max_polygons, &raw, msg, sizeof msg);
    free(base);
    if (rc)
        return rad_fail(err, rc, "%s: %s", src, msg);

    c.s = rad_scene_create(3, src);
    if (!c.s) {
        rad_gltf_raw_free(raw);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", src);
    }
    rc = convert(&c, raw);
    rad_gltf_raw_free(raw);
    if (rc == RAD_OK)
        warn_flush(&c, opt); /* a failed load says only why it failed */
    warn_free(&c);
    if (rc) {
        rad_scene_destroy(c.s);
        return rc;
    }
    *out = c.s;
    return RAD_OK;
}
