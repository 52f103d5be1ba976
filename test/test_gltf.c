/* test_gltf.c - the glTF loader (radiosity/scene/gltf.c over the glTF bridge).
 *
 * Every document is built here, in memory: a small JSON writer takes the
 * arrays a test gives it and embeds them as a base64 data URI (or as the BIN
 * chunk of a .glb).  Expected coordinates, areas and exitances are worked out
 * by hand in the comments; tolerances are stated where they are used.
 * The last test holds models/cornell.gltf against models/cornell.rad.
 */
#include "../radiosity/mesh/mesh.h"
#include "../radiosity/scene/scene.h"
#include "test.h"
#include "util.h"

#include <stdarg.h>
#include <stdint.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ------------------------------------------------------------ text buffer */

typedef test_text text;
#define tx_add test_text_add
#define tx_base64 test_text_base64

/* ------------------------------------------------------------ binary blob */

typedef struct blob {
    unsigned char d[8192];
    size_t n;
} blob;

static void put32(blob *b, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        b->d[b->n++] = (unsigned char)(v >> (8 * k));
}

static void put_float(blob *b, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put32(b, u); /* glTF is little-endian whatever the host is */
}

/* ------------------------------------------------------- document builder */

/* One mesh (accessor 0 = POSITION, accessor 1 = indices) plus whatever
 * JSON the test overrides. */
/* The unit square in z = 0, counter-clockwise seen from +z, as two
 * triangles: every spec's default geometry. */
static const float unit_quad[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static const uint32_t quad_idx[] = {0, 1, 2, 0, 2, 3};

typedef struct spec {
    const float *pos;       /* xyz per vertex; NULL = unit_quad indexed by quad_idx */
    uint32_t nv;
    uint32_t pos_count;     /* POSITION accessor count; 0 = nv */
    uint32_t pos_stride;    /* byteStride of the positions' view; 0 = packed */
    const char *accessors;  /* more accessors (from index 2), with a leading comma */
    const uint32_t *idx;    /* NULL = non-indexed */
    uint32_t ni;
    int idx_type;           /* 5121, 5123 or 5125; 0 = 5123 */
    const char *prim;       /* extra primitive members; NULL = "\"material\":0" */
    const char *mesh_name;  /* NULL = unnamed */
    const char *meshes;     /* whole "meshes" array; NULL = built from the above */
    const char *materials;  /* whole "materials" array; NULL = one grey emitter */
    const char *nodes;      /* whole "nodes" array; NULL = one node "quad" */
    const char *extra;      /* more top-level members, without a trailing comma */
    int glb;                /* wrap as .glb, the buffer in the BIN chunk */
    int strict;             /* rad_load_options.strict */
    const unsigned char *tail; /* bytes appended to the buffer (an image), as buffer view 2 */
    size_t tail_size;
} spec;

static const char *default_materials =
    "[{\"name\":\"grey\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1]},"
    "\"emissiveFactor\":[1,1,1]}]";

/* Builds the document; caller frees the result, *size its length. */
static unsigned char *build(const spec *given, size_t *size)
{
    spec q = *given;
    if (!q.pos) {
        q.pos = unit_quad;
        q.nv = 4;
        q.idx = quad_idx;
        q.ni = 6;
    }
    const spec *sp = &q;
    blob b;
    b.n = 0;
    for (uint32_t v = 0; v < sp->nv; v++) {
        for (uint32_t k = 0; k < 3; k++)
            put_float(&b, sp->pos[3 * v + k]);
        for (uint32_t k = 12; k < sp->pos_stride; k += 4)
            put_float(&b, -99.0f); /* interleaved data that must not be read as positions */
    }
    size_t pos_bytes = b.n;
    int it = sp->idx_type ? sp->idx_type : 5123;
    size_t isz = it == 5121 ? 1 : it == 5123 ? 2 : 4;
    for (uint32_t k = 0; sp->idx && k < sp->ni; k++)
        for (size_t c = 0; c < isz; c++)
            b.d[b.n++] = (unsigned char)(sp->idx[k] >> (8 * c));
    size_t idx_bytes = b.n - pos_bytes;
    while (b.n % 4)
        b.d[b.n++] = 0;
    size_t tail_at = b.n;
    if (sp->tail_size > sizeof b.d - b.n)
        abort();
    if (sp->tail_size)
        memcpy(b.d + b.n, sp->tail, sp->tail_size);
    b.n += sp->tail_size;
    while (b.n % 4)
        b.d[b.n++] = 0;

    text t = {0};
    tx_add(&t, "{\"asset\":{\"version\":\"2.0\"},");
    if (sp->extra)
        tx_add(&t, "%s,", sp->extra);
    tx_add(&t, "\"nodes\":%s,", sp->nodes ? sp->nodes : "[{\"name\":\"quad\",\"mesh\":0}]");
    if (sp->meshes) {
        tx_add(&t, "\"meshes\":%s,", sp->meshes);
    } else {
        tx_add(&t, "\"meshes\":[{");
        if (sp->mesh_name)
            tx_add(&t, "\"name\":\"%s\",", sp->mesh_name);
        tx_add(&t, "\"primitives\":[{\"attributes\":{\"POSITION\":0}");
        if (sp->idx)
            tx_add(&t, ",\"indices\":1");
        tx_add(&t, ",%s}]}],", sp->prim ? sp->prim : "\"material\":0");
    }
    tx_add(&t, "\"materials\":%s,", sp->materials ? sp->materials : default_materials);
    tx_add(&t,
           "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%u,"
           "\"type\":\"VEC3\"}",
           sp->pos_count ? sp->pos_count : sp->nv);
    if (sp->idx)
        tx_add(&t, ",{\"bufferView\":1,\"componentType\":%d,\"count\":%u,\"type\":\"SCALAR\"}",
               it, sp->ni);
    if (sp->accessors)
        tx_add(&t, "%s", sp->accessors);
    tx_add(&t, "],\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":%zu",
           pos_bytes);
    if (sp->pos_stride)
        tx_add(&t, ",\"byteStride\":%u", sp->pos_stride);
    tx_add(&t, "}");
    if (sp->idx)
        tx_add(&t, ",{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", pos_bytes,
               idx_bytes);
    if (sp->tail)
        tx_add(&t, ",{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", tail_at,
               sp->tail_size);
    tx_add(&t, "],\"buffers\":[{\"byteLength\":%zu", b.n);
    if (!sp->glb) {
        tx_add(&t, ",\"uri\":\"data:application/octet-stream;base64,");
        tx_base64(&t, b.d, b.n);
        tx_add(&t, "\"");
    }
    tx_add(&t, "}]}");
    if (!sp->glb) {
        *size = t.len;
        return (unsigned char *)t.s;
    }
    /* .glb: 12-byte header, JSON chunk padded with spaces, BIN chunk. */
    while (t.len % 4)
        tx_add(&t, " ");
    size_t total = 12 + 8 + t.len + 8 + b.n;
    unsigned char *out = malloc(total);
    if (!out)
        abort();
    size_t n = 0;
    memcpy(out, "glTF", 4);
    n = 4;
    uint32_t hdr[5] = {2, (uint32_t)total, (uint32_t)t.len, 0x4E4F534Au, 0};
    for (int k = 0; k < 4; k++)
        for (int c = 0; c < 4; c++)
            out[n++] = (unsigned char)(hdr[k] >> (8 * c));
    memcpy(out + n, t.s, t.len);
    n += t.len;
    uint32_t bh[2] = {(uint32_t)b.n, 0x004E4942u};
    for (int k = 0; k < 2; k++)
        for (int c = 0; c < 4; c++)
            out[n++] = (unsigned char)(bh[k] >> (8 * c));
    memcpy(out + n, b.d, b.n);
    free(t.s);
    *size = total;
    return out;
}

typedef test_warnings caught;

/* Parses sp as "test.gltf" with the warnings into *c (may be NULL);
 * returns the result code, the scene in *out. */
static int parse_warn(const spec *sp, rad_scene **out, rad_error *err, caught *c)
{
    size_t n;
    unsigned char *d = build(sp, &n);
    memset(err, 0, sizeof *err);
    if (c)
        memset(c, 0, sizeof *c);
    rad_load_options opt = {.strict = sp->strict, .warn = c ? test_catch_warning : NULL,
                            .warn_user = c};
    int rc = rad_scene_parse_gltf(d, n, sp->glb ? "test.glb" : "test.gltf", &opt, out, err);
    free(d);
    return rc;
}

static int parse(const spec *sp, rad_scene **out, rad_error *err)
{
    return parse_warn(sp, out, err, NULL);
}

/* Parses and expects failure with `code` and `needle` in the message. */
static void expect_error(const spec *sp, int code, const char *needle)
{
    rad_scene *s = (rad_scene *)1;
    rad_error err;
    int rc = parse(sp, &s, &err);
    CHECK_MSG(rc == code, "code %d, expected %d: %s", rc, code, err.message);
    CHECK(s == NULL);
    CHECK_MSG(strstr(err.message, needle) != NULL, "message '%s' lacks '%s'", err.message,
              needle);
    CHECK_MSG(strncmp(err.message, "test.gl", 7) == 0, "message '%s' does not name the file",
              err.message);
}


static double object_area(const rad_scene *s, uint32_t o)
{
    double a = 0.0;
    for (uint32_t p = 0; p < s->polygon_count; p++)
        if (s->polygons[p].object == o)
            a += s->polygons[p].area;
    return a;
}

/* ------------------------------------------------------------------ tests */

/* Two triangles of a unit square become one quad, counter-clockwise about
 * +z (its normal), area 1.  Small integers are exact in float and double, so
 * 1e-12 only absorbs the area's arithmetic. */
TEST(unit_quad_merges)
{
    spec sp = {0};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->band_count == 3);
    CHECK(s->band_names[0] && strcmp(s->band_names[0], "R") == 0);
    CHECK(s->band_names[2] && strcmp(s->band_names[2], "B") == 0);
    CHECK(s->object_count == 1 && strcmp(s->objects[0].name, "quad") == 0);
    CHECK(s->polygon_count == 1);
    if (s->polygon_count == 1) {
        const rad_polygon *p = &s->polygons[0];
        CHECK(p->point_count == 4);
        CHECK_NEAR(p->area, 1.0, 1e-12);
        CHECK_NEAR(p->normal.z, 1.0, 1e-12);
        /* every corner of the square appears once */
        int seen = 0;
        for (uint32_t k = 0; k < p->point_count; k++) {
            rad_vec3 q = s->points[p->first_point + k];
            seen |= 1 << (int)(q.x * 2 + q.y);
        }
        CHECK(seen == 0xF);
        CHECK(strcmp(p->name, "mesh0/0/0") == 0);
    }
    rad_scene_destroy(s);

    /* the same square without indices (six vertices, nothing shared by
     * index) merges too: equal positions are welded */
    static const float flat[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0, 1, 0};
    spec sp2 = {.pos = flat, .nv = 6};
    rc = parse(&sp2, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->polygon_count == 1 && s->polygons[0].point_count == 4);
    rad_scene_destroy(s);
}

/* A 3×3 grid of unit squares, each cut along its diagonal, pairs into its
 * nine cells: two triangles across a grid line also form a (slanted)
 * parallelogram, and must not win.  Integer coordinates: exact. */
TEST(grid_pairs_cells)
{
    float pos[16 * 3];
    uint32_t idx[9 * 6];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            pos[3 * (4 * j + i)] = (float)i;
            pos[3 * (4 * j + i) + 1] = (float)j;
            pos[3 * (4 * j + i) + 2] = 0.0f;
        }
    for (int j = 0, n = 0; j < 3; j++)
        for (int i = 0; i < 3; i++) {
            uint32_t a = (uint32_t)(4 * j + i), b = a + 1, c = a + 5, d = a + 4;
            uint32_t q[6] = {a, b, c, a, c, d};
            memcpy(idx + 6 * n++, q, sizeof q);
        }
    spec sp = {.pos = pos, .nv = 16, .idx = idx, .ni = 54};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->polygon_count == 9);
    for (uint32_t p = 0; p < s->polygon_count; p++) {
        const rad_polygon *q = &s->polygons[p];
        CHECK(q->point_count == 4);
        double lo[2] = {1e9, 1e9}, hi[2] = {-1e9, -1e9};
        for (uint32_t k = 0; k < q->point_count; k++) {
            rad_vec3 v = s->points[q->first_point + k];
            lo[0] = fmin(lo[0], v.x), hi[0] = fmax(hi[0], v.x);
            lo[1] = fmin(lo[1], v.y), hi[1] = fmax(hi[1], v.y);
        }
        CHECK_MSG(hi[0] - lo[0] == 1 && hi[1] - lo[1] == 1, "polygon %u spans %g × %g", p,
                  hi[0] - lo[0], hi[1] - lo[1]);
        CHECK_NEAR(q->area, 1.0, 1e-12);
    }
    rad_scene_destroy(s);
}

/* A trapezoid (0,0) (1,0) (1.5,1) (0,1) is no parallelogram: it stays two
 * triangles, of areas 0.5 and 0.75 (half the cross products). */
TEST(non_parallelogram_stays_triangles)
{
    static const float trap[] = {0, 0, 0, 1, 0, 0, 1.5f, 1, 0, 0, 1, 0};
    spec sp = {.pos = trap, .nv = 4, .idx = quad_idx, .ni = 6, .idx_type = 5121};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->polygon_count == 2);
    if (s->polygon_count == 2) {
        CHECK(s->polygons[0].point_count == 3 && s->polygons[1].point_count == 3);
        CHECK_NEAR(s->polygons[0].area, 0.5, 1e-12);
        CHECK_NEAR(s->polygons[1].area, 0.75, 1e-12);
    }
    rad_scene_destroy(s);
}

/* Hierarchy: parent T(1,2,3) R(90° about z) S(2); child T(0,1,0)
 * R(90° about x) S(1,1,3); grandchild given as a matrix translating by
 * (5,0,0), holding the triangle (0,0,0) (1,0,0) (0,1,0).  By hand:
 *   (0,0,0) -> (5,0,0) -> S,R_x: (5,0,0) -> +T: (5,1,0) -> S: (10,2,0)
 *           -> R_z (x,y)->(-y,x): (-2,10,0) -> +T: (-1,12,3)
 *   (1,0,0) -> (6,0,0) -> (6,1,0) -> (12,2,0) -> (-2,12,0) -> (-1,14,3)
 *   (0,1,0) -> (5,1,0) -> R_x (y,z)->(-z,y): (5,0,1) -> (5,1,1)
 *           -> (10,2,2) -> (-2,10,2) -> (-1,12,5)
 * The quaternions hold sin 45° to 17 digits, so 1e-9 is generous. */
TEST(hierarchy_transforms)
{
    static const float tri[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    spec sp = {
        .pos = tri,
        .nv = 3,
        .nodes = "[{\"name\":\"parent\",\"children\":[1],\"translation\":[1,2,3],"
                 "\"rotation\":[0,0,0.7071067811865476,0.7071067811865476],\"scale\":[2,2,2]},"
                 "{\"name\":\"child\",\"children\":[2],\"translation\":[0,1,0],"
                 "\"rotation\":[0.7071067811865476,0,0,0.7071067811865476],\"scale\":[1,1,3]},"
                 "{\"name\":\"leaf\",\"mesh\":0,"
                 "\"matrix\":[1,0,0,0, 0,1,0,0, 0,0,1,0, 5,0,0,1]}]",
        .extra = "\"scene\":0,\"scenes\":[{\"nodes\":[0]}]",
    };
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->object_count == 1 && strcmp(s->objects[0].name, "leaf") == 0);
    CHECK(s->polygon_count == 1);
    if (s->polygon_count == 1 && s->polygons[0].point_count == 3) {
        const rad_vec3 *p = &s->points[s->polygons[0].first_point];
        const double want[3][3] = {{-1, 12, 3}, {-1, 14, 3}, {-1, 12, 5}};
        for (int k = 0; k < 3; k++) {
            CHECK_NEAR(p[k].x, want[k][0], 1e-9);
            CHECK_NEAR(p[k].y, want[k][1], 1e-9);
            CHECK_NEAR(p[k].z, want[k][2], 1e-9);
        }
        /* edges (0,2,0) and (0,0,2): cross (4,0,0), area 2, normal +x */
        CHECK_NEAR(s->polygons[0].area, 2.0, 1e-9);
        CHECK_NEAR(s->polygons[0].normal.x, 1.0, 1e-9);
    }
    rad_scene_destroy(s);

    /* A mirroring node (scale -1 in x) flips the winding, and glTF keeps the
     * front face: the triangle (0,0) (1,0) (0,1) facing +z stays facing +z. */
    spec sp2 = {.pos = tri, .nv = 3, .nodes = "[{\"mesh\":0,\"scale\":[-1,1,1]}]"};
    rc = parse(&sp2, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->polygon_count == 1);
    if (s->polygon_count == 1)
        CHECK_NEAR(s->polygons[0].normal.z, 1.0, 1e-12);
    rad_scene_destroy(s);
}

/* E = π · emissiveFactor · strength: (0.5, 0.25, 1) × 4 = (2, 1, 4) π;
 * ρ is baseColorFactor.  Relative 1e-12: one product each. */
TEST(emissive_strength)
{
    spec sp = {.materials = "[{\"name\":\"lamp\",\"pbrMetallicRoughness\":"
                            "{\"baseColorFactor\":[0.1,0.2,0.3,1]},"
                            "\"emissiveFactor\":[0.5,0.25,1],\"extensions\":"
                            "{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":4}}}]",
               .extra = "\"extensionsUsed\":[\"KHR_materials_emissive_strength\"],"
                        "\"extensionsRequired\":[\"KHR_materials_emissive_strength\"]"};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->material_count == 1 && strcmp(s->materials[0].name, "lamp") == 0);
    const double e[3] = {2, 1, 4}, r[3] = {0.1, 0.2, 0.3};
    for (int b = 0; b < 3; b++) {
        CHECK_REL(s->materials[0].emission[b], M_PI * e[b], 1e-12);
        CHECK_REL(s->materials[0].rho[b], r[b], 1e-12);
    }
    rad_scene_destroy(s);
}

/* Object names: node name, else mesh name, else node<index>; a repeated
 * name gets #2.  Unnamed materials become material<index>. */
TEST(name_fallbacks)
{
    spec sp = {
        .meshes = "[{\"name\":\"m0\",\"primitives\":[{\"attributes\":{\"POSITION\":0},"
                  "\"indices\":1,\"material\":0}]},"
                  "{\"name\":\"beta\",\"primitives\":[{\"attributes\":{\"POSITION\":0},"
                  "\"indices\":1,\"material\":0}]},"
                  "{\"primitives\":[{\"attributes\":{\"POSITION\":0},"
                  "\"indices\":1,\"material\":0}]}]",
        .nodes = "[{\"name\":\"alpha\",\"mesh\":0},{\"mesh\":1},{\"mesh\":2},"
                 "{\"name\":\"dup\",\"mesh\":0},{\"name\":\"dup\",\"mesh\":0}]",
        .materials = "[{\"emissiveFactor\":[1,0,0],"
                     "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1]}}]",
    };
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    const char *want[] = {"alpha", "beta", "node2", "dup", "dup#2"};
    CHECK(s->object_count == 5);
    for (uint32_t k = 0; k < 5 && k < s->object_count; k++)
        CHECK_MSG(strcmp(s->objects[k].name, want[k]) == 0, "object %u is '%s', want '%s'", k,
                  s->objects[k].name, want[k]);
    CHECK(s->material_count == 1 && strcmp(s->materials[0].name, "material0") == 0);
    /* each node's square became its own quad, in its own object */
    CHECK(s->polygon_count == 5);
    for (uint32_t p = 0; p < s->polygon_count; p++)
        CHECK(s->polygons[p].object == p);
    rad_scene_destroy(s);
}

/* Positions interleaved with other data (byteStride 24) are read at the
 * stride: the padding (-99) never shows up as a coordinate. */
TEST(strided_positions)
{
    spec sp = {.pos_stride = 24};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->polygon_count == 1);
    CHECK_NEAR(object_area(s, 0), 1.0, 1e-12);
    for (uint32_t k = 0; k < s->point_count; k++)
        CHECK(s->points[k].x >= 0 && s->points[k].y >= 0 && s->points[k].z == 0);
    rad_scene_destroy(s);
}

/* The unit square as .glb gives the same quad. */
TEST(glb_container)
{
    spec sp = {.glb = 1, .idx_type = 5125};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->polygon_count == 1 && s->polygons[0].point_count == 4);
    CHECK_NEAR(object_area(s, 0), 1.0, 1e-12);
    rad_scene_destroy(s);
}

/* A camera node at (1,2,3) turned 90° about y looks along the turned -z:
 * R_y(90°) takes (0,0,-1) to (-1,0,0), so the target is (0,2,3); up stays
 * +y; yfov 0.5 rad = 28.64788975654116°.  An orthographic camera keeps
 * xmag and ymag (here 2 and 1); an unnamed camera takes its node's name. */
TEST(camera_conversion)
{
    spec sp = {
        .nodes = "[{\"name\":\"quad\",\"mesh\":0},"
                 "{\"name\":\"n1\",\"camera\":0,\"translation\":[1,2,3],"
                 "\"rotation\":[0,0.7071067811865476,0,0.7071067811865476]},"
                 "{\"name\":\"n2\",\"camera\":1},"
                 "{\"name\":\"nodecam\",\"camera\":2,\"translation\":[0,0,5]}]",
        .extra = "\"cameras\":[{\"name\":\"cam\",\"type\":\"perspective\",\"perspective\":"
                 "{\"yfov\":0.5,\"aspectRatio\":1.5,\"znear\":0.1}},"
                 "{\"type\":\"orthographic\",\"orthographic\":"
                 "{\"xmag\":2,\"ymag\":1,\"znear\":0.1,\"zfar\":10}},"
                 "{\"type\":\"perspective\",\"perspective\":{\"yfov\":1,\"znear\":0.1}}]",
    };
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->camera_count == 3);
    if (s->camera_count == 3) {
        const rad_camera *c = &s->cameras[0];
        CHECK(strcmp(c->name, "cam") == 0);
        CHECK_NEAR(c->eye.x, 1, 1e-12);
        CHECK_NEAR(c->eye.y, 2, 1e-12);
        CHECK_NEAR(c->eye.z, 3, 1e-12);
        rad_vec3 d = rad_normalize(rad_sub(c->target, c->eye));
        CHECK_NEAR(d.x, -1, 1e-12);
        CHECK_NEAR(d.y, 0, 1e-12);
        CHECK_NEAR(d.z, 0, 1e-12);
        rad_vec3 u = rad_normalize(c->up);
        CHECK_NEAR(u.y, 1, 1e-12);
        CHECK_NEAR(c->yfov_deg, 0.5 * 180.0 / M_PI, 1e-12);
        CHECK_NEAR(c->aspect, 1.5, 0);
        CHECK(!c->orthographic);
        const rad_camera *o = &s->cameras[1];
        CHECK(strcmp(o->name, "n2") == 0 && o->orthographic && o->xmag == 2 && o->ymag == 1);
        CHECK_NEAR(o->aspect, 2, 0);
        CHECK_NEAR(rad_normalize(rad_sub(o->target, o->eye)).z, -1, 1e-12);
        const rad_camera *c2 = &s->cameras[2];
        CHECK(strcmp(c2->name, "nodecam") == 0);
        CHECK_NEAR(c2->aspect, 0, 0);
        CHECK_NEAR(rad_normalize(rad_sub(c2->target, c2->eye)).z, -1, 1e-12);
    }
    rad_scene_destroy(s);
}

/* doubleSided: the quad and a reversed copy (opposite normal, same object). */
TEST(double_sided)
{
    spec sp = {.materials = "[{\"doubleSided\":true,\"emissiveFactor\":[1,1,1],"
                            "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1]}}]"};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->polygon_count == 2);
    if (s->polygon_count == 2) {
        CHECK_NEAR(s->polygons[0].normal.z, 1, 1e-12);
        CHECK_NEAR(s->polygons[1].normal.z, -1, 1e-12);
        CHECK(s->polygons[0].object == s->polygons[1].object);
        CHECK_NEAR(s->polygons[1].area, 1.0, 1e-12);
    }
    rad_scene_destroy(s);
}

/* KHR_materials_diffuse_transmission splits the diffuse lobe: factor t =
 * 0.4 of it is transmitted with colour (1, 0.5, 0.25), the rest reflected:
 * ρ = 0.6 × 0.5 = 0.3, τ = (0.4, 0.2, 0.1).  doubleSided adds no reversed
 * copy (the sheet's back side is a mesh twin), and the mesh has one.
 * Relative 1e-12: one product each. */
TEST(diffuse_transmission)
{
    spec sp = {.materials = "[{\"name\":\"paper\",\"doubleSided\":true,\"emissiveFactor\":[1,1,1],"
                            "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1]},"
                            "\"extensions\":{\"KHR_materials_diffuse_transmission\":"
                            "{\"diffuseTransmissionFactor\":0.4,"
                            "\"diffuseTransmissionColorFactor\":[1,0.5,0.25]}}}]",
               .extra = "\"extensionsUsed\":[\"KHR_materials_diffuse_transmission\"],"
                        "\"extensionsRequired\":[\"KHR_materials_diffuse_transmission\"]"};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    const double tau[3] = {0.4, 0.2, 0.1};
    for (int b = 0; b < 3; b++) {
        CHECK_REL(s->materials[0].rho[b], 0.3, 1e-12);
        CHECK_REL(s->materials[0].transmit[b], tau[b], 1e-12);
    }
    CHECK(s->polygon_count == 1);
    rad_mesh_options mo = {.patch_size = 0.5};
    rad_mesh *m = NULL;
    CHECK(rad_mesh_build(s, &mo, &m, &err) == RAD_OK);
    if (m) {
        CHECK(m->patch_count == 8 && m->twin != NULL);
        for (uint32_t i = 0; m->twin && i < m->patch_count; i++)
            CHECK(m->twin[i] == (i + 4) % 8);
    }
    rad_mesh_destroy(m);
    rad_scene_destroy(s);

    /* Without the extension nothing transmits and doubleSided copies. */
    spec plain = sp;
    plain.extra = NULL;
    plain.materials = "[{\"doubleSided\":true,\"emissiveFactor\":[1,1,1],"
                      "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1]}}]";
    rc = parse(&plain, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc == RAD_OK) {
        CHECK(s->polygon_count == 2 && s->materials[0].transmit[0] == 0.0);
        rad_scene_destroy(s);
    }
}

TEST(error_diffuse_transmission)
{
    spec sp = {.materials = "[{\"name\":\"X\",\"pbrMetallicRoughness\":"
                            "{\"baseColorFactor\":[0.5,0.5,0.5,1]},\"extensions\":"
                            "{\"KHR_materials_diffuse_transmission\":{\"diffuseTransmissionFactor\":1.5}}}]"};
    expect_error(&sp, RAD_ERR_INVALID, "material 'X': diffuseTransmissionFactor 1.5 is not in [0, 1]");
    sp.materials = "[{\"name\":\"X\",\"pbrMetallicRoughness\":"
                   "{\"baseColorFactor\":[0.5,0.5,0.5,1]},\"extensions\":"
                   "{\"KHR_materials_diffuse_transmission\":{\"diffuseTransmissionFactor\":\"a\"}}}]";
    expect_error(&sp, RAD_ERR_PARSE, "material 'X': diffuseTransmissionFactor is not a number");
    sp.materials = "[{\"name\":\"X\",\"pbrMetallicRoughness\":"
                   "{\"baseColorFactor\":[0.5,0.5,0.5,1]},\"extensions\":"
                   "{\"KHR_materials_diffuse_transmission\":{\"diffuseTransmissionColorFactor\":[1,1]}}}]";
    expect_error(&sp, RAD_ERR_PARSE, "diffuseTransmissionColorFactor is not an array of 3 numbers");
    /* All of a white diffuse lobe transmitted: τ = 1 has no steady state. */
    sp.materials = "[{\"name\":\"X\",\"pbrMetallicRoughness\":"
                   "{\"baseColorFactor\":[0.5,0.5,0.5,1]},\"extensions\":"
                   "{\"KHR_materials_diffuse_transmission\":{\"diffuseTransmissionFactor\":1}}}]";
    expect_error(&sp, RAD_ERR_INVALID, "material 'X': transmittance 1 outside [0, 1)");
}

/* Zero-area triangles (a repeated index; a sliver of area 3.5e-21 in a
 * scene 1.4 across) are dropped without failing; the square still merges. */
TEST(degenerate_triangles_dropped)
{
    static const float pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5f, 0.5f, 0, 0.5f, 0.5f,
                                1e-20f};
    static const uint32_t idx[] = {0, 1, 1, 0, 1, 2, 0, 2, 3, 0, 4, 5, 2, 2, 2};
    spec sp = {.pos = pos, .nv = 6, .idx = idx, .ni = 15};
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc)
        return;
    CHECK(s->polygon_count == 1 && s->polygons[0].point_count == 4);
    rad_scene_destroy(s);

    /* nothing but degenerate triangles: an error that says so */
    static const uint32_t bad[] = {0, 1, 1, 2, 2, 2};
    spec sp2 = {.pos = pos, .nv = 6, .idx = bad, .ni = 6};
    expect_error(&sp2, RAD_ERR_INVALID, "zero area");
}

/* Extensions only used (Blender's KHR_materials_specular, ior) are ignored. */
TEST(ignored_extension)
{
    spec sp = {.materials = "[{\"name\":\"m\",\"emissiveFactor\":[1,1,1],"
                            "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1]},"
                            "\"extensions\":{\"KHR_materials_specular\":"
                            "{\"specularFactor\":0.5},\"KHR_materials_ior\":{\"ior\":1.45}}}]",
               .extra = "\"extensionsUsed\":[\"KHR_materials_specular\",\"KHR_materials_ior\"]"};
    rad_scene *s;
    rad_error err;
    caught c;
    int rc = parse_warn(&sp, &s, &err, &c);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc == RAD_OK)
        CHECK(s->polygon_count == 1);
    /* named, in one line */
    CHECK_MSG(c.count == 1 && strcmp(c.line[0], "test.gltf: extensions KHR_materials_specular, "
                                                "KHR_materials_ior: ignored") == 0,
              "%d: %s", c.count, c.line[0]);
    rad_scene_destroy(s);
}

/* ---------------------------------------------------------------- textures */

static uint32_t crc32_of(const unsigned char *p, size_t n)
{
    uint32_t c = 0xffffffffu;
    for (size_t k = 0; k < n; k++) {
        c ^= p[k];
        for (int b = 0; b < 8; b++)
            c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return c ^ 0xffffffffu;
}

/* The signature and IHDR of a w × h RGB PNG, no pixel data: enough for a
 * decoder to know the size. */
static size_t png_header(unsigned char *out, uint32_t w, uint32_t h)
{
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    unsigned char ihdr[17] = {'I', 'H', 'D', 'R'};
    for (int k = 0; k < 4; k++) {
        ihdr[4 + k] = (unsigned char)(w >> (24 - 8 * k));
        ihdr[8 + k] = (unsigned char)(h >> (24 - 8 * k));
    }
    ihdr[12] = 8; /* bit depth */
    ihdr[13] = 2; /* RGB */
    size_t n = 0;
    memcpy(out, sig, 8);
    n = 8;
    out[n++] = 0, out[n++] = 0, out[n++] = 0, out[n++] = 13;
    memcpy(out + n, ihdr, 17);
    n += 17;
    uint32_t crc = crc32_of(ihdr, 17);
    for (int k = 0; k < 4; k++)
        out[n++] = (unsigned char)(crc >> (24 - 8 * k));
    return n;
}

/* A texture that cannot be read costs a warning and leaves the factor
 * alone (--strict refuses it instead): undecodable bytes, a texture or
 * buffer view that does not exist, a file with no directory to look in,
 * and an image too large to average, refused from its header. */
TEST(unreadable_textures)
{
    unsigned char huge[64];
    /* 10^8 texels: within what stb_image itself decodes (w·h·3 < 2^30),
     * beyond the loader's limit of 8192² */
    size_t huge_n = png_header(huge, 10000, 10000);
    static const char *const mats =
        "[{\"name\":\"junk\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1],"
        "\"baseColorTexture\":{\"index\":0}},\"emissiveFactor\":[1,1,1]}]";
    struct {
        const char *extra, *needle;
    } cases[] = {
        {"\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"data:image/png;base64,AAAAAAAA\"}]",
         "image 0: not a PNG or JPEG image the decoder reads"},
        {"\"textures\":[],\"images\":[]", "texture 0 does not exist (0 textures)"},
        {"\"textures\":[{\"source\":0}],\"images\":[{\"bufferView\":9,\"mimeType\":\"image/png\"}]",
         "image 0: buffer view 9 does not exist"},
        {"\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"no%20such.png\"}]",
         "image 0 'no%20such.png': cannot open 'no such.png'"},
        {"\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"../up.png\"}]",
         "external file '../up.png' refused"},
        {"\"textures\":[{\"source\":0}],\"images\":[{\"bufferView\":2,\"mimeType\":\"image/png\","
         "\"name\":\"big\"}]",
         "image 0 'big': 10000 × 10000 texels, more than the limit of 67108864"},
        {"\"textures\":[{\"extensions\":{\"EXT_texture_webp\":{\"source\":0}}}],"
         "\"images\":[{\"uri\":\"a.webp\"}]",
         "texture 0: no PNG or JPEG source"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        for (int glb = 0; glb < 2; glb++) {
            spec sp = {.materials = mats, .extra = cases[k].extra, .glb = glb,
                       .tail = huge, .tail_size = huge_n};
            rad_scene *s;
            rad_error err;
            caught c;
            int rc = parse_warn(&sp, &s, &err, &c);
            CHECK_MSG(rc == RAD_OK, "case %zu: %s", k, err.message);
            if (rc == RAD_OK) {
                CHECK(s->materials[0].rho[0] == 0.5); /* the factor alone */
                CHECK_MSG(c.count == 1 && strstr(c.line[0], "texture 'junk' baseColorTexture (") &&
                              strstr(c.line[0], cases[k].needle) &&
                              strstr(c.line[0], "not read: the factor alone is used"),
                          "case %zu: %d lines: %s", k, c.count, c.line[0]);
            }
            rad_scene_destroy(s);
            sp.strict = 1;
            expect_error(&sp, RAD_ERR_INVALID, cases[k].needle);
        }
    }
}

/* COLOR_0 must match POSITION and hold colours; float colours are taken as
 * they are (linear), normalised integers divided by their maximum. */
TEST(vertex_color_accessors)
{
    /* accessor 2: 4 float RGB colours in buffer view 2 */
    static const float col[12] = {0.2f, 0.4f, 0.6f, 0.2f, 0.4f, 0.6f,
                                  0.2f, 0.4f, 0.6f, 0.2f, 0.4f, 0.6f};
    unsigned char bytes[48];
    memcpy(bytes, col, sizeof bytes); /* little-endian hosts only, like the rest */
    spec sp = {.tail = bytes, .tail_size = sizeof bytes,
               .accessors = ",{\"bufferView\":2,\"componentType\":5126,\"count\":4,"
                            "\"type\":\"VEC3\"}",
               .prim = "\"material\":0,\"attributes\":{\"POSITION\":0,\"COLOR_0\":2}"};
    /* the builder writes its own attributes first; give the primitive whole */
    sp.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"COLOR_0\":2},"
                "\"indices\":1,\"material\":0}]}]";
    rad_scene *s;
    rad_error err;
    int rc = parse(&sp, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc == RAD_OK && s->polygon_count == 1) {
        const double *rho = rad_polygon_rho(s, 0);
        /* grey 0.5 × colour; float32 0.2 etc. carried exactly to double */
        CHECK_NEAR(rho[0], 0.5 * (double)0.2f, 1e-15);
        CHECK_NEAR(rho[1], 0.5 * (double)0.4f, 1e-15);
        CHECK_NEAR(rho[2], 0.5 * (double)0.6f, 1e-15);
        CHECK(s->materials[0].rho[0] == 0.5); /* the material keeps its own */
    }
    rad_scene_destroy(s);

    spec three = sp;
    three.accessors = ",{\"bufferView\":2,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}";
    expect_error(&three, RAD_ERR_PARSE, "COLOR_0 has 3 elements, POSITION 4");
    spec vec2 = sp;
    vec2.accessors = ",{\"bufferView\":2,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"}";
    expect_error(&vec2, RAD_ERR_PARSE, "COLOR_0 accessor 2: type VEC2, expected VEC3 or VEC4");
    static const float neg[12] = {0.2f, -0.4f, 0.6f};
    unsigned char nb[48];
    memcpy(nb, neg, sizeof nb);
    spec negative = sp;
    negative.tail = nb;
    expect_error(&negative, RAD_ERR_PARSE, "COLOR_0 of vertex 0 is -0.4");
}

/* A read baseColorTexture is kept for a bake: the image's bytes as they
 * were, its sampler and factor, and each polygon corner's TEXCOORD_0.  Two
 * triangles whose coordinates are affine over their square merge into one
 * quad; moved off the affine map at one corner (or split by a seam) they
 * stay two triangles, each with its corners' own coordinates. */
TEST(texture_kept_with_coordinates)
{
    size_t png_n = 0;
    unsigned char *png = (unsigned char *)test_slurp("test/data/real/checker.png", &png_n);
    CHECK(png && png_n > 8);
    if (!png)
        return;
    text extra = {0};
    tx_add(&extra, "\"textures\":[{\"source\":0,\"sampler\":0}],\"samplers\":[{\"wrapS\":33071,"
                   "\"magFilter\":9728}],\"images\":[{\"uri\":\"data:image/png;base64,");
    tx_base64(&extra, png, png_n);
    tx_add(&extra, "\"}]");
    /* unit_quad's corners (0,0) (1,0) (1,1) (0,1): u = 0.5 x + 0.25, v = 0.75 y */
    float uv[8] = {0.25f, 0, 0.75f, 0, 0.75f, 0.75f, 0.25f, 0.75f};
    for (int bent = 0; bent < 2; bent++) {
        if (bent)
            uv[5] = 0.5f; /* corner 2 off the affine map */
        spec sp = {.tail = (const unsigned char *)uv, .tail_size = sizeof uv, .extra = extra.s,
                   .accessors = ",{\"bufferView\":2,\"componentType\":5126,\"count\":4,"
                                "\"type\":\"VEC2\"}",
                   .meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":2},"
                             "\"indices\":1,\"material\":0}]}]",
                   .materials = "[{\"name\":\"tex\",\"pbrMetallicRoughness\":{\"baseColorFactor\":"
                                "[0.5,0.6,0.7,0.9],\"baseColorTexture\":{\"index\":0}},"
                                "\"emissiveFactor\":[1,1,1]}]"};
        rad_scene *s;
        rad_error err;
        int rc = parse(&sp, &s, &err);
        CHECK_MSG(rc == RAD_OK, "%s", err.message);
        if (rc)
            continue;
        CHECK(s->image_count == 1 && s->texture_count == 1 && s->point_uv);
        if (s->image_count == 1 && s->texture_count == 1 && s->point_uv) {
            CHECK(s->images[0].size == png_n && !memcmp(s->images[0].data, png, png_n));
            CHECK(!strcmp(s->images[0].mime, "image/png"));
            const rad_texture *t = rad_material_texture(s, 0);
            CHECK(t && t->image == 0 && t->texcoord == 0 && t->wrap_s == RAD_WRAP_CLAMP &&
                  t->wrap_t == 0 && t->mag_filter == 9728 && t->min_filter == 0);
            CHECK(t && t->factor[0] == 0.5 && t->factor[1] == 0.6 && t->factor[3] == 0.9);
        }
        CHECK_MSG(s->polygon_count == (bent ? 2u : 1u), "%u polygons", s->polygon_count);
        for (uint32_t p = 0; p < s->polygon_count && s->point_uv; p++)
            for (uint32_t k = 0; k < s->polygons[p].point_count; k++) {
                uint32_t at = s->polygons[p].first_point + k;
                rad_vec3 q = s->points[at];
                int corner = q.y == 0 ? (q.x == 0 ? 0 : 1) : (q.x == 0 ? 3 : 2);
                CHECK(s->point_uv[2 * at] == uv[2 * corner] &&
                      s->point_uv[2 * at + 1] == uv[2 * corner + 1]);
            }
        rad_scene_destroy(s);
    }
    /* TEXCOORD_0 that holds no coordinates (VEC3): the solve does not need
     * it, so the load goes on, and the warning names the mesh */
    spec odd = {.tail = (const unsigned char *)uv, .tail_size = sizeof uv, .extra = extra.s,
                .accessors = ",{\"bufferView\":2,\"componentType\":5126,\"count\":2,"
                             "\"type\":\"VEC3\"}",
                .meshes = "[{\"name\":\"odd\",\"primitives\":[{\"attributes\":{\"POSITION\":0,"
                          "\"TEXCOORD_0\":2},\"indices\":1,\"material\":0}]}]",
                .materials = "[{\"name\":\"tex\",\"pbrMetallicRoughness\":{\"baseColorTexture\":"
                             "{\"index\":0}},\"emissiveFactor\":[1,1,1]}]"};
    rad_scene *s;
    rad_error err;
    caught c;
    int rc = parse_warn(&odd, &s, &err, &c);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc == RAD_OK) {
        CHECK(s->texture_count == 1 && s->point_uv == NULL);
        int named = 0;
        for (int k = 0; k < c.count && k < 16; k++)
            named |= strstr(c.line[k], "mesh 'odd': primitives without the TEXCOORD set") != NULL;
        CHECK_MSG(named, "%d lines: %s", c.count, c.line[0]);
        rad_scene_destroy(s);
    }
    free(extra.s);
    free(png);
}

/* ----------------------------------------------------------------- errors */

TEST(error_malformed_json)
{
    const char *bad = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[";
    rad_scene *s = (rad_scene *)1;
    rad_error err;
    int rc = rad_scene_parse_gltf(bad, strlen(bad), "bad.gltf", NULL, &s, &err);
    CHECK(rc == RAD_ERR_PARSE);
    CHECK(s == NULL);
    CHECK_MSG(strstr(err.message, "bad.gltf: malformed JSON") != NULL, "%s", err.message);

    /* nesting far deeper than any glTF: refused before anything recurses */
    text t = {0};
    tx_add(&t, "{\"asset\":{\"version\":\"2.0\"},\"extras\":");
    for (int k = 0; k < 100000; k++)
        tx_add(&t, "[");
    rc = rad_scene_parse_gltf(t.s, t.len, "deep.gltf", NULL, &s, &err);
    free(t.s);
    CHECK(rc == RAD_ERR_PARSE);
    CHECK_MSG(strstr(err.message, "nested") != NULL, "%s", err.message);

    rc = rad_scene_parse_gltf("", 0, "empty.gltf", NULL, &s, &err);
    CHECK(rc == RAD_ERR_PARSE);
}

TEST(error_mode_lines)
{
    /* --strict refuses a primitive without area */
    spec sp = {.mesh_name = "M", .strict = 1, .prim = "\"material\":0,\"mode\":1"};
    expect_error(&sp, RAD_ERR_INVALID, "mesh 'M' primitive 0: mode LINES not supported");
    /* a strip is refused either way */
    spec strip = {.mesh_name = "M", .prim = "\"material\":0,\"mode\":5"};
    expect_error(&strip, RAD_ERR_INVALID, "mesh 'M' primitive 0: mode TRIANGLE_STRIP not supported");
}

TEST(error_index_out_of_range)
{
    static const uint32_t idx[] = {0, 1, 2, 0, 2, 7};
    spec sp = {.pos = unit_quad, .nv = 4, .idx = idx, .ni = 6, .mesh_name = "Cube"};
    expect_error(&sp, RAD_ERR_PARSE, "mesh 'Cube' primitive 0: index 7 out of range (4 vertices)");

    spec sp2 = {.pos = unit_quad, .nv = 4, .idx = quad_idx, .ni = 5};
    expect_error(&sp2, RAD_ERR_PARSE, "not a multiple of 3");
}

TEST(error_accessor_beyond_view)
{
    /* 8 vertices claimed, 4 (48 bytes) present */
    spec sp = {.pos = unit_quad, .nv = 4, .pos_count = 8, .idx = quad_idx, .ni = 6};
    expect_error(&sp, RAD_ERR_PARSE, "POSITION accessor 0: 8 elements");
    expect_error(&sp, RAD_ERR_PARSE, "beyond buffer view 0");
}

TEST(error_required_extension)
{
    spec sp = {.extra = "\"extensionsUsed\":[\"KHR_draco_mesh_compression\"],"
                        "\"extensionsRequired\":[\"KHR_draco_mesh_compression\"]"};
    expect_error(&sp, RAD_ERR_INVALID,
                 "extension 'KHR_draco_mesh_compression' is required but not supported");
}

TEST(error_base_color_one)
{
    spec sp = {.strict = 1,
               .materials = "[{\"name\":\"X\",\"pbrMetallicRoughness\":"
                            "{\"baseColorFactor\":[0.5,1.0,0.5,1]}}]"};
    expect_error(&sp, RAD_ERR_INVALID, "material 'X': baseColorFactor 1 is not a reflectance below 1");
    /* no pbrMetallicRoughness at all: glTF's default white 1.0 */
    spec sp2 = {.strict = 1, .materials = "[{\"name\":\"plain\"}]"};
    expect_error(&sp2, RAD_ERR_INVALID, "material 'plain': baseColorFactor 1");
}

TEST(error_no_material)
{
    spec sp = {.mesh_name = "M", .strict = 1, .prim = "\"mode\":4"};
    expect_error(&sp, RAD_ERR_INVALID, "mesh 'M' primitive 0: no material");
}

/* Without --strict: a factor of 1 is clamped to 0.95 per band (the others
 * kept), a primitive without a material gets glTF's white, clamped the
 * same way; each named once in its line. */
TEST(clamp_and_default_material)
{
    spec sp = {.materials = "[{\"name\":\"X\",\"emissiveFactor\":[1,1,1],"
                            "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,1.0,0.5,1]}}]"};
    rad_scene *s;
    rad_error err;
    caught c;
    int rc = parse_warn(&sp, &s, &err, &c);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc == RAD_OK) {
        CHECK(s->materials[0].rho[0] == 0.5 && s->materials[0].rho[1] == 0.95 &&
              s->materials[0].rho[2] == 0.5);
        CHECK_MSG(c.count == 1 && strstr(c.line[0], "test.gltf: material 'X': reflectance >= 1 "
                                                    "clamped to 0.95") != NULL,
                  "%d: %s", c.count, c.line[0]);
    }
    rad_scene_destroy(s);

    /* two primitives without a material, one with: one default material */
    spec nm = {.mesh_name = "M",
               .meshes = "[{\"name\":\"M\",\"primitives\":["
                         "{\"attributes\":{\"POSITION\":0},\"indices\":1},"
                         "{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0},"
                         "{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":1}]}]"};
    rc = parse_warn(&nm, &s, &err, &c);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc == RAD_OK) {
        uint32_t d = rad_scene_find_material(s, "default");
        CHECK(d != RAD_NONE && s->material_count == 2);
        if (d != RAD_NONE)
            CHECK(s->materials[d].rho[0] == 0.95 && s->materials[d].emission[0] == 0.0);
        CHECK(s->polygon_count == 2);
        CHECK_MSG(c.count == 2, "%d warning lines", c.count);
        CHECK(strstr(c.line[0], "mesh 'M': primitives without a material") != NULL);
        CHECK(strstr(c.line[1], "mesh 'M' (LINES): primitives without area") != NULL);
    }
    rad_scene_destroy(s);
}

TEST(error_truncated_glb)
{
    spec sp = {.glb = 1};
    size_t n;
    unsigned char *d = build(&sp, &n);
    /* every prefix fails cleanly; the header and chunk cuts say "truncated" */
    for (size_t cut = 0; cut < n; cut++) {
        rad_scene *s = (rad_scene *)1;
        rad_error err;
        int rc = rad_scene_parse_gltf(d, cut, "cut.glb", NULL, &s, &err);
        CHECK_MSG(rc != RAD_OK && s == NULL, "prefix %zu accepted", cut);
        if (cut >= 4 && cut < n)
            CHECK_MSG(strstr(err.message, "truncated .glb") != NULL, "prefix %zu: %s", cut,
                      err.message);
    }
    free(d);
}

/* Structural faults in the node graph and accessors. */
TEST(error_structure)
{
    spec cyc = {.nodes = "[{\"name\":\"a\",\"mesh\":0},{\"name\":\"b\",\"children\":[2]},"
                         "{\"name\":\"c\",\"children\":[1]}]"};
    expect_error(&cyc, RAD_ERR_PARSE, "cycle");
    spec two = {.nodes = "[{\"name\":\"a\",\"children\":[2]},{\"name\":\"b\",\"children\":[2]},"
                         "{\"name\":\"c\",\"mesh\":0}]"};
    expect_error(&two, RAD_ERR_PARSE, "node 'c' has two parents");
    spec nomesh = {.nodes = "[{\"name\":\"a\",\"mesh\":3}]"};
    expect_error(&nomesh, RAD_ERR_PARSE, "node 'a': mesh 3 does not exist");
    spec badtype = {.idx_type = 5122};
    expect_error(&badtype, RAD_ERR_PARSE, "componentType 5122");
    /* accessor 2 reads the positions as VEC2; accessor 3 is sparse */
    const char *more = ",{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"}"
                       ",{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
                       "\"sparse\":{\"count\":1,\"indices\":{\"bufferView\":1,"
                       "\"componentType\":5123},\"values\":{\"bufferView\":0}}}";
    spec vec2 = {.accessors = more,
                 .meshes = "[{\"name\":\"M\",\"primitives\":[{\"attributes\":{\"POSITION\":2},"
                           "\"indices\":1,\"material\":0}]}]"};
    expect_error(&vec2, RAD_ERR_PARSE, "mesh 'M' primitive 0: POSITION accessor 2: type VEC2");
    spec sparse = vec2;
    sparse.meshes = "[{\"name\":\"M\",\"primitives\":[{\"attributes\":{\"POSITION\":3},"
                    "\"indices\":1,\"material\":0}]}]";
    expect_error(&sparse, RAD_ERR_PARSE, "accessor 3: sparse accessors are not supported");
    spec absent = vec2;
    absent.meshes = "[{\"name\":\"M\",\"primitives\":[{\"attributes\":{\"POSITION\":9},"
                    "\"indices\":1,\"material\":0}]}]";
    expect_error(&absent, RAD_ERR_PARSE, "POSITION accessor 9 does not exist");
    spec limit = {.nodes = "[{\"mesh\":0},{\"mesh\":0}]"};
    size_t n;
    unsigned char *d = build(&limit, &n);
    rad_load_options opt = {.max_polygons = 3};
    rad_scene *s;
    rad_error err;
    int rc = rad_scene_parse_gltf(d, n, "lim.gltf", &opt, &s, &err);
    free(d);
    CHECK_MSG(rc == RAD_ERR_LIMIT && strstr(err.message, "limit"), "%d %s", rc, err.message);
}

/* External buffers: a relative file beside the document loads; '..', an
 * absolute path, a missing file and a document without a file name are
 * refused. */
TEST(external_buffers)
{
    char dir[] = "/tmp/test_gltf_XXXXXX";
    if (!mkdtemp(dir)) {
        CHECK(!"mkdtemp failed");
        return;
    }
    blob b;
    b.n = 0;
    for (int k = 0; k < 12; k++)
        put_float(&b, unit_quad[k]);
    char path[256];
    snprintf(path, sizeof path, "%s/q.bin", dir);
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f)
        return;
    fwrite(b.d, 1, b.n, f);
    fclose(f);
    static const char fmt[] =
        "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"name\":\"q\",\"mesh\":0}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0}]}],"
        "\"materials\":[{\"emissiveFactor\":[1,1,1],"
        "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1]}}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
        "\"buffers\":[{\"byteLength\":%d,\"uri\":\"%s\"}]}";
    char doc[2048], name[300];
    snprintf(name, sizeof name, "%s/scene.gltf", dir);
    rad_scene *s;
    rad_error err;

    snprintf(doc, sizeof doc, fmt, 48, "q.bin");
    int rc = rad_scene_parse_gltf(doc, strlen(doc), name, NULL, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc == RAD_OK) {
        CHECK(s->polygon_count == 1);
        CHECK_NEAR(s->polygons[0].area, 0.5, 1e-12);
        rad_scene_destroy(s);
    }
    /* percent-encoded name of the same file */
    snprintf(doc, sizeof doc, fmt, 48, "%71.bin");
    rc = rad_scene_parse_gltf(doc, strlen(doc), name, NULL, &s, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (rc == RAD_OK)
        rad_scene_destroy(s);

    const char *refused[] = {"../q.bin", "%2e%2e/q.bin", "/etc/passwd", "x/../q.bin"};
    for (int k = 0; k < 4; k++) {
        snprintf(doc, sizeof doc, fmt, 48, refused[k]);
        rc = rad_scene_parse_gltf(doc, strlen(doc), name, NULL, &s, &err);
        CHECK_MSG(rc == RAD_ERR_IO && strstr(err.message, "buffer 0: external file"),
                  "%s: %d %s", refused[k], rc, err.message);
    }
    snprintf(doc, sizeof doc, fmt, 48, "missing.bin");
    rc = rad_scene_parse_gltf(doc, strlen(doc), name, NULL, &s, &err);
    CHECK_MSG(rc == RAD_ERR_IO && strstr(err.message, "missing.bin"), "%d %s", rc, err.message);
    snprintf(doc, sizeof doc, fmt, 48, "q.bin");
    rc = rad_scene_parse_gltf(doc, strlen(doc), NULL, NULL, &s, &err);
    CHECK_MSG(rc == RAD_ERR_IO && strstr(err.message, "<memory>: buffer 0: external file"),
              "%d %s", rc, err.message);
    /* a file whose size differs from the declared byteLength is refused
     * before it is read */
    snprintf(doc, sizeof doc, fmt, 60, "q.bin");
    rc = rad_scene_parse_gltf(doc, strlen(doc), name, NULL, &s, &err);
    CHECK_MSG(rc == RAD_ERR_IO && strstr(err.message, "has 48 bytes, the document declares 60"),
              "%d %s", rc, err.message);
    unlink(path);
    rmdir(dir);
}

/* ------------------------------------------------------------ Cornell box */

/* models/cornell.gltf against models/cornell.rad: the same object names,
 * the same per-object areas (relative 1e-6: the glTF stores float32
 * positions, 6e-8 relative each, and the blocks' local coordinates pass
 * through a rotation), the same materials and the same camera view. */
TEST(cornell_matches_polygon_model)
{
    const char *gl = "models/cornell.gltf", *pf = "models/cornell.rad";
    struct stat st;
    if (stat(gl, &st) != 0) {
        gl = "../models/cornell.gltf";
        pf = "../models/cornell.rad";
    }
    rad_scene *g = NULL, *p = NULL;
    rad_error err;
    int rc = rad_scene_load(gl, NULL, &g, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    rc = rad_scene_load(pf, NULL, &p, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (!g || !p) {
        rad_scene_destroy(g);
        rad_scene_destroy(p);
        return;
    }
    CHECK(g->object_count == 8 && g->object_count == p->object_count);
    for (uint32_t o = 0; o < p->object_count; o++) {
        uint32_t k = rad_scene_find_object(g, p->objects[o].name);
        CHECK_MSG(k != RAD_NONE, "object '%s' missing from the glTF", p->objects[o].name);
        if (k != RAD_NONE)
            CHECK_REL(object_area(g, k), object_area(p, o), 1e-6);
    }
    CHECK(g->material_count == p->material_count);
    for (uint32_t m = 0; m < p->material_count; m++) {
        uint32_t k = rad_scene_find_material(g, p->materials[m].name);
        CHECK_MSG(k != RAD_NONE, "material '%s' missing", p->materials[m].name);
        if (k == RAD_NONE)
            continue;
        for (uint32_t b = 0; b < 3; b++) {
            /* both files write these to 15+ digits */
            CHECK_NEAR(g->materials[k].rho[b], p->materials[m].rho[b], 1e-12);
            CHECK_REL(g->materials[k].emission[b], p->materials[m].emission[b], 1e-12);
        }
    }
    /* the light's exitance is π × radiance (17, 12, 4) */
    uint32_t light = rad_scene_find_material(g, "light");
    if (light != RAD_NONE) {
        CHECK_REL(g->materials[light].emission[0], 17 * M_PI, 1e-12);
        CHECK_REL(g->materials[light].emission[1], 12 * M_PI, 1e-12);
        CHECK_REL(g->materials[light].emission[2], 4 * M_PI, 1e-12);
    }
    /* the ceiling is four quads, the tall block's sides merged into quads
     * (its top is no parallelogram: two triangles) */
    uint32_t ceil = rad_scene_find_object(g, "ceiling"), tall = rad_scene_find_object(g, "tall_block");
    int ceil_quads = 0, tall_quads = 0, tall_tris = 0;
    for (uint32_t k = 0; k < g->polygon_count; k++) {
        const rad_polygon *q = &g->polygons[k];
        ceil_quads += q->object == ceil && q->point_count == 4;
        tall_quads += q->object == tall && q->point_count == 4;
        tall_tris += q->object == tall && q->point_count == 3;
    }
    CHECK(ceil_quads == 4);
    CHECK(tall_quads == 4 && tall_tris == 2);
    CHECK(g->camera_count == 1 && p->camera_count == 1);
    if (g->camera_count == 1 && p->camera_count == 1) {
        const rad_camera *a = &g->cameras[0], *c = &p->cameras[0];
        CHECK(strcmp(a->name, c->name) == 0);
        CHECK_NEAR(rad_length(rad_sub(a->eye, c->eye)), 0, 1e-12);
        rad_vec3 da = rad_normalize(rad_sub(a->target, a->eye));
        rad_vec3 dc = rad_normalize(rad_sub(c->target, c->eye));
        CHECK_NEAR(rad_dot(da, dc), 1, 1e-12);
        CHECK_NEAR(rad_dot(rad_normalize(a->up), rad_normalize(c->up)), 1, 1e-12);
        /* cornell.rad rounds the published 39.307648° to 39.3077 */
        CHECK_NEAR(a->yfov_deg, c->yfov_deg, 1e-4);
    }
    rad_scene_destroy(g);
    rad_scene_destroy(p);
}

/* test/data/gltf/cornell.glb (written by the same tool) holds the same
 * float32 data in a BIN chunk: it must give exactly the same scene. */
TEST(cornell_glb_equals_gltf)
{
    const char *gl = "models/cornell.gltf", *gb = "test/data/gltf/cornell.glb";
    struct stat st;
    if (stat(gl, &st) != 0) {
        gl = "../models/cornell.gltf";
        gb = "../test/data/gltf/cornell.glb";
    }
    rad_scene *a = NULL, *b = NULL;
    rad_error err;
    int rc = rad_scene_load(gl, NULL, &a, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    rc = rad_scene_load(gb, NULL, &b, &err);
    CHECK_MSG(rc == RAD_OK, "%s", err.message);
    if (a && b) {
        CHECK(a->object_count == b->object_count && a->polygon_count == b->polygon_count &&
              a->point_count == b->point_count && a->camera_count == b->camera_count);
        for (uint32_t o = 0; o < a->object_count && o < b->object_count; o++)
            CHECK(strcmp(a->objects[o].name, b->objects[o].name) == 0);
        /* identical inputs, identical arithmetic: equal to the last bit */
        for (uint32_t k = 0; k < a->point_count && k < b->point_count; k++)
            CHECK(a->points[k].x == b->points[k].x && a->points[k].y == b->points[k].y &&
                  a->points[k].z == b->points[k].z);
    }
    rad_scene_destroy(a);
    rad_scene_destroy(b);
}

int main(void)
{
    RUN(unit_quad_merges);
    RUN(non_parallelogram_stays_triangles);
    RUN(grid_pairs_cells);
    RUN(hierarchy_transforms);
    RUN(emissive_strength);
    RUN(name_fallbacks);
    RUN(strided_positions);
    RUN(glb_container);
    RUN(camera_conversion);
    RUN(double_sided);
    RUN(diffuse_transmission);
    RUN(error_diffuse_transmission);
    RUN(degenerate_triangles_dropped);
    RUN(ignored_extension);
    RUN(error_malformed_json);
    RUN(error_mode_lines);
    RUN(error_index_out_of_range);
    RUN(error_accessor_beyond_view);
    RUN(error_required_extension);
    RUN(error_base_color_one);
    RUN(error_no_material);
    RUN(clamp_and_default_material);
    RUN(unreadable_textures);
    RUN(vertex_color_accessors);
    RUN(texture_kept_with_coordinates);
    RUN(error_truncated_glb);
    RUN(error_structure);
    RUN(external_buffers);
    RUN(cornell_matches_polygon_model);
    RUN(cornell_glb_equals_gltf);
    return test_finish("test_gltf");
}
