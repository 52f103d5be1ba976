/* bake_json.c - the glTF 2.0 files of a bake, written by hand: the JSON
 * (names, materials, cameras, one node and mesh per object) and the binary
 * buffer of bk_geometry, as one .glb or as .gltf + .bin.
 *
 * Buffer layout (docs/bake.md): four buffer views, one per array, each
 * primitive's accessors a range of them: POSITION float VEC3 (stride 12),
 * COLOR_0 normalized unsigned short VEC4 (stride 8), _RADIANCE float VEC3
 * (stride 12), indices unsigned int.  Vertex views share accessors, so they
 * name their byteStride (the validator's MESH_PRIMITIVE_ACCESSOR_WITHOUT_
 * BYTESTRIDE).  32 bytes a vertex, 12 a triangle.  A scene with textures
 * adds, after these, a fifth view, TEXCOORD_0 float VEC2 (stride 8) of the
 * textured primitives' vertices, their accessors numbered after the four
 * of every primitive, and one view per image with its bytes as the input
 * held them; without textures the files are what they were before.
 *
 * Invariant: the JSON is valid UTF-8 with every name escaped, every
 * chunk and view 4-byte aligned; files appear only complete (rad_output).
 */
#include "bake_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

/* A growing text. */
typedef struct jbuf {
    char *p;
    size_t n, cap;
    int failed;
} jbuf;

static void jb_put(jbuf *j, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static void jb_put(jbuf *j, const char *fmt, ...)
{
    for (int tries = 0; tries < 2 && !j->failed; tries++) {
        va_list ap;
        va_start(ap, fmt);
        int n = vsnprintf(j->p ? j->p + j->n : NULL, j->p ? j->cap - j->n : 0, fmt, ap);
        va_end(ap);
        if (n < 0) {
            j->failed = 1;
            return;
        }
        if (j->p && j->n + (size_t)n < j->cap) {
            j->n += (size_t)n;
            return;
        }
        size_t cap = j->cap ? j->cap : 4096;
        while (cap <= j->n + (size_t)n)
            cap *= 2;
        char *q = realloc(j->p, cap);
        if (!q) {
            j->failed = 1;
            return;
        }
        j->p = q;
        j->cap = cap;
    }
}

/* A JSON string: quotes, backslashes and control bytes escaped; a byte
 * that does not start valid UTF-8 becomes U+FFFD. */
static void jb_string(jbuf *j, const char *s)
{
    jb_put(j, "\"");
    const unsigned char *u = (const unsigned char *)(s ? s : "");
    while (*u) {
        int len = *u < 0x80 ? 1 : (*u >> 5) == 6 ? 2 : (*u >> 4) == 14 ? 3 : (*u >> 3) == 30 ? 4 : 0;
        for (int k = 1; k < len; k++)
            if ((u[k] & 0xC0) != 0x80)
                len = 0;
        if (len == 0) {
            jb_put(j, "\\ufffd");
            u++;
        } else if (*u == '"' || *u == '\\') {
            jb_put(j, "\\%c", *u++);
        } else if (*u < 0x20) {
            jb_put(j, "\\u%04x", *u++);
        } else {
            jb_put(j, "%.*s", len, (const char *)u);
            u += len;
        }
    }
    jb_put(j, "\"");
}

/* ----------------------------------------------------------------- JSON */

/* (bake_internal.h; here so that bake.c -> bake_json.c stays one way) */
const rad_texture *bk_texture(const rad_scene *sc, uint32_t m)
{
    for (uint32_t b = 0; b < sc->band_count; b++)
        if (sc->materials[m].emission[b] > 0.0)
            return NULL;
    return rad_material_texture(sc, m);
}

/* Texture k of the scene is glTF texture k (and sampler k when it has one). */
static uint32_t texture_index(const rad_scene *sc, const rad_texture *t)
{
    return (uint32_t)(t - sc->textures);
}

static void put_materials(jbuf *j, const rad_scene *sc)
{
    jb_put(j, "\"materials\":[");
    for (uint32_t m = 0; m < sc->material_count; m++) {
        const rad_material *mat = &sc->materials[m];
        const rad_texture *t = bk_texture(sc, m);
        jb_put(j, "%s{\"name\":", m ? "," : "");
        jb_string(j, mat->name);
        /* The light already holds ρ (B = E + ρH): the base colour is white,
         * and the solve's ρ and E stay as extras.  A textured material
         * keeps its texture and factor: its COLOR_0 is L / ρ̄. */
        if (t)
            jb_put(j, ",\"pbrMetallicRoughness\":{\"baseColorFactor\":[%.9g,%.9g,%.9g,%.9g],"
                      "\"baseColorTexture\":{\"index\":%u},\"metallicFactor\":0,"
                      "\"roughnessFactor\":1}", t->factor[0], t->factor[1], t->factor[2],
                   t->factor[3], texture_index(sc, t));
        else
            jb_put(j, ",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1,1],"
                      "\"metallicFactor\":0,\"roughnessFactor\":1}");
        jb_put(j, ",\"doubleSided\":false,"
                  "\"extensions\":{\"KHR_materials_unlit\":{}},\"extras\":{\"reflectance\":[");
        for (uint32_t b = 0; b < sc->band_count; b++)
            jb_put(j, "%s%.9g", b ? "," : "", mat->rho[b]);
        jb_put(j, "],\"emission\":[");
        for (uint32_t b = 0; b < sc->band_count; b++)
            jb_put(j, "%s%.9g", b ? "," : "", mat->emission[b]);
        jb_put(j, "]}}");
    }
    jb_put(j, "]");
}

/* The rotation taking glTF's camera frame (looking down -Z, +Y up) to
 * the camera's: columns right, up, -forward; as a quaternion x, y, z, w. */
static void camera_rotation(const rad_camera *c, double q[4])
{
    rad_vec3 f = rad_normalize(rad_sub(c->target, c->eye));
    rad_vec3 r = rad_normalize(rad_cross(f, c->up));
    rad_vec3 u = rad_cross(r, f);
    double m[3][3] = {{r.x, u.x, -f.x}, {r.y, u.y, -f.y}, {r.z, u.z, -f.z}};
    double t = m[0][0] + m[1][1] + m[2][2];
    if (t > 0) {
        double s = 2.0 * sqrt(t + 1.0);
        q[3] = s / 4, q[0] = (m[2][1] - m[1][2]) / s, q[1] = (m[0][2] - m[2][0]) / s,
        q[2] = (m[1][0] - m[0][1]) / s;
    } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
        double s = 2.0 * sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);
        q[3] = (m[2][1] - m[1][2]) / s, q[0] = s / 4, q[1] = (m[0][1] + m[1][0]) / s,
        q[2] = (m[0][2] + m[2][0]) / s;
    } else if (m[1][1] > m[2][2]) {
        double s = 2.0 * sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]);
        q[3] = (m[0][2] - m[2][0]) / s, q[0] = (m[0][1] + m[1][0]) / s, q[1] = s / 4,
        q[2] = (m[1][2] + m[2][1]) / s;
    } else {
        double s = 2.0 * sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]);
        q[3] = (m[1][0] - m[0][1]) / s, q[0] = (m[0][2] + m[2][0]) / s,
        q[1] = (m[1][2] + m[2][1]) / s, q[2] = s / 4;
    }
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int k = 0; k < 4; k++)
        q[k] /= n;
}

/* The cameras' nodes (after the objects' first `base` nodes) and the
 * "cameras" array.  Near plane a thousandth of the scene's size. */
static void put_cameras(jbuf *j, const rad_scene *sc, double size)
{
    if (!sc->camera_count)
        return;
    jb_put(j, ",\"cameras\":[");
    for (uint32_t c = 0; c < sc->camera_count; c++) {
        const rad_camera *cam = &sc->cameras[c];
        jb_put(j, "%s{\"name\":", c ? "," : "");
        jb_string(j, cam->name);
        if (cam->orthographic)
            jb_put(j, ",\"type\":\"orthographic\",\"orthographic\":{\"xmag\":%.17g,\"ymag\":%.17g,"
                      "\"znear\":0,\"zfar\":%.17g}}", cam->xmag, cam->ymag, size * 100.0);
        else if (cam->aspect > 0)
            jb_put(j, ",\"type\":\"perspective\",\"perspective\":{\"yfov\":%.17g,\"znear\":%.17g,"
                      "\"aspectRatio\":%.17g}}", cam->yfov_deg * M_PI / 180.0, size * 1e-3,
                   cam->aspect);
        else
            jb_put(j, ",\"type\":\"perspective\",\"perspective\":{\"yfov\":%.17g,\"znear\":%.17g}}",
                   cam->yfov_deg * M_PI / 180.0, size * 1e-3);
    }
    jb_put(j, "]");
}

static void put_camera_nodes(jbuf *j, const rad_scene *sc)
{
    for (uint32_t c = 0; c < sc->camera_count; c++) {
        const rad_camera *cam = &sc->cameras[c];
        double q[4];
        camera_rotation(cam, q);
        jb_put(j, ",{\"name\":");
        jb_string(j, cam->name);
        jb_put(j, ",\"camera\":%u,\"translation\":[%.17g,%.17g,%.17g],"
                  "\"rotation\":[%.17g,%.17g,%.17g,%.17g]}",
               c, cam->eye.x, cam->eye.y, cam->eye.z, q[0], q[1], q[2], q[3]);
    }
}

/* Object k's mesh: its primitives (consecutive in g, objects in order). */
static void put_mesh(jbuf *j, const rad_scene *sc, const bk_geometry *g, uint32_t first,
                     uint32_t end)
{
    jb_put(j, "{\"name\":");
    jb_string(j, sc->objects[g->prims[first].object].name);
    jb_put(j, ",\"primitives\":[");
    uint32_t uv_accessor = 4 * g->prim_count; /* the textured ones' TEXCOORD_0 follow */
    for (uint32_t q = 0; q < first; q++)
        uv_accessor += (uint32_t)g->prims[q].textured;
    for (uint32_t p = first; p < end; p++) {
        jb_put(j, "%s{\"attributes\":{\"POSITION\":%u,\"COLOR_0\":%u,\"_RADIANCE\":%u",
               p > first ? "," : "", 4 * p, 4 * p + 1, 4 * p + 2);
        if (g->prims[p].textured)
            jb_put(j, ",\"TEXCOORD_0\":%u", uv_accessor++);
        jb_put(j, "},\"indices\":%u,\"material\":%u,\"mode\":4}", 4 * p + 3,
               g->prims[p].material);
    }
    jb_put(j, "]}");
}

/* Nodes (one per object, then the cameras) and meshes. */
static void put_nodes(jbuf *j, const rad_scene *sc, const bk_geometry *g)
{
    uint32_t total = sc->object_count + sc->camera_count;
    jb_put(j, "\"scene\":0,\"scenes\":[{\"nodes\":[");
    for (uint32_t n = 0; n < total; n++)
        jb_put(j, "%s%u", n ? "," : "", n);
    jb_put(j, "]}],\"nodes\":[");
    uint32_t p = 0, meshes = 0;
    for (uint32_t o = 0; o < sc->object_count; o++) {
        jb_put(j, "%s{\"name\":", o ? "," : "");
        jb_string(j, sc->objects[o].name);
        while (p < g->prim_count && g->prims[p].object < o)
            p++;
        if (p < g->prim_count && g->prims[p].object == o)
            jb_put(j, ",\"mesh\":%u", meshes++);
        jb_put(j, "}");
    }
    put_camera_nodes(j, sc);
    jb_put(j, "],\"meshes\":[");
    for (uint32_t first = 0, m = 0; first < g->prim_count; m++) {
        uint32_t end = first;
        while (end < g->prim_count && g->prims[end].object == g->prims[first].object)
            end++;
        if (m)
            jb_put(j, ",");
        put_mesh(j, sc, g, first, end);
        first = end;
    }
    jb_put(j, "]");
}

/* Byte offsets of the views in the buffer: the four of every bake, then
 * TEXCOORD_0 and the images (each padded to 4 bytes) of a textured one. */
typedef struct layout {
    uint64_t pos, color, radiance, index, uv, image, total;
} layout;

static uint64_t pad4(uint64_t n) { return (n + 3) & ~(uint64_t)3; }

static layout buffer_layout(const rad_scene *sc, const bk_geometry *g)
{
    layout l;
    l.pos = 0;
    l.color = l.pos + g->vertex_count * 12;
    l.radiance = l.color + g->vertex_count * 8;
    l.index = l.radiance + g->vertex_count * 12;
    l.uv = l.index + g->index_count * 4;
    l.image = l.uv + g->uv_count * 8;
    l.total = l.image;
    for (uint32_t k = 0; k < sc->image_count; k++)
        l.total += pad4(sc->images[k].size);
    return l;
}

/* The views, accessors and arrays only a textured bake has: TEXCOORD_0's
 * view (4) and one per image, then (after the accessors) the textures,
 * samplers and images. */
static void put_texture_views(jbuf *j, const rad_scene *sc, const bk_geometry *g, layout l)
{
    if (g->uv_count)
        jb_put(j, ",{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu,\"byteStride\":8,"
                  "\"target\":34962}", (unsigned long long)l.uv,
               (unsigned long long)(g->uv_count * 8));
    uint64_t at = l.image;
    for (uint32_t k = 0; k < sc->image_count; k++) {
        jb_put(j, ",{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu}",
               (unsigned long long)at, (unsigned long long)sc->images[k].size);
        at += pad4(sc->images[k].size);
    }
}

static void put_uv_accessors(jbuf *j, const bk_geometry *g)
{
    for (uint32_t p = 0; p < g->prim_count; p++)
        if (g->prims[p].textured)
            jb_put(j, ",{\"bufferView\":4,\"byteOffset\":%llu,\"componentType\":5126,"
                      "\"count\":%llu,\"type\":\"VEC2\"}",
                   (unsigned long long)g->prims[p].first_uv * 8,
                   (unsigned long long)g->prims[p].vertex_count);
}

static void put_sampler_value(jbuf *j, const char *name, int v, int *first)
{
    if (v) {
        jb_put(j, "%s\"%s\":%d", *first ? "" : ",", name, v);
        *first = 0;
    }
}

static void put_texture_arrays(jbuf *j, const rad_scene *sc, const bk_geometry *g)
{
    if (!sc->texture_count)
        return;
    jb_put(j, ",\"textures\":[");
    for (uint32_t k = 0; k < sc->texture_count; k++)
        jb_put(j, "%s{\"source\":%u,\"sampler\":%u}", k ? "," : "", sc->textures[k].image, k);
    jb_put(j, "],\"samplers\":[");
    for (uint32_t k = 0; k < sc->texture_count; k++) {
        const rad_texture *t = &sc->textures[k];
        int first = 1;
        jb_put(j, "%s{", k ? "," : "");
        put_sampler_value(j, "magFilter", t->mag_filter, &first);
        put_sampler_value(j, "minFilter", t->min_filter, &first);
        put_sampler_value(j, "wrapS", t->wrap_s, &first);
        put_sampler_value(j, "wrapT", t->wrap_t, &first);
        jb_put(j, "}");
    }
    jb_put(j, "],\"images\":[");
    uint32_t view = 4 + (g->uv_count ? 1u : 0u);
    for (uint32_t k = 0; k < sc->image_count; k++) {
        jb_put(j, "%s{\"bufferView\":%u,\"mimeType\":", k ? "," : "", view + k);
        jb_string(j, sc->images[k].mime);
        jb_put(j, "}");
    }
    jb_put(j, "]");
}

static void put_accessors(jbuf *j, const rad_scene *sc, const bk_geometry *g, layout l)
{
    jb_put(j, ",\"bufferViews\":["
              "{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu,\"byteStride\":12,\"target\":34962},"
              "{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu,\"byteStride\":8,\"target\":34962},"
              "{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu,\"byteStride\":12,\"target\":34962},"
              "{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu,\"target\":34963}",
           (unsigned long long)l.pos, (unsigned long long)(l.color - l.pos),
           (unsigned long long)l.color, (unsigned long long)(l.radiance - l.color),
           (unsigned long long)l.radiance, (unsigned long long)(l.index - l.radiance),
           (unsigned long long)l.index, (unsigned long long)(l.uv - l.index));
    put_texture_views(j, sc, g, l);
    jb_put(j, "],\"accessors\":[");
    for (uint32_t p = 0; p < g->prim_count; p++) {
        const bk_prim *pr = &g->prims[p];
        unsigned long long v0 = pr->first_vertex, nv = pr->vertex_count;
        jb_put(j, "%s{\"bufferView\":0,\"byteOffset\":%llu,\"componentType\":5126,\"count\":%llu,"
                  "\"type\":\"VEC3\",\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]},",
               p ? "," : "", v0 * 12, nv, pr->lo[0], pr->lo[1], pr->lo[2], pr->hi[0], pr->hi[1],
               pr->hi[2]);
        jb_put(j, "{\"bufferView\":1,\"byteOffset\":%llu,\"componentType\":5123,\"normalized\":true,"
                  "\"count\":%llu,\"type\":\"VEC4\"},", v0 * 8, nv);
        jb_put(j, "{\"bufferView\":2,\"byteOffset\":%llu,\"componentType\":5126,\"count\":%llu,"
                  "\"type\":\"VEC3\"},", v0 * 12, nv);
        jb_put(j, "{\"bufferView\":3,\"byteOffset\":%llu,\"componentType\":5125,\"count\":%llu,"
                  "\"type\":\"SCALAR\"}", (unsigned long long)pr->first_index * 4,
               (unsigned long long)pr->index_count);
    }
    put_uv_accessors(j, g);
    jb_put(j, "]");
    put_texture_arrays(j, sc, g);
}

/* The whole JSON; uri NULL for a .glb's own buffer. */
static int make_json(const rad_solution *s, const bk_geometry *g, const char *uri, jbuf *j,
                     rad_error *err)
{
    const rad_scene *sc = s->scene;
    layout l = buffer_layout(sc, g);
    rad_vec3 lo, hi;
    double size = rad_scene_bounds(sc, &lo, &hi) ? rad_length(rad_sub(hi, lo)) : 1.0;
    jb_put(j, "{\"asset\":{\"version\":\"2.0\",\"generator\":\"radiosity %s bake\"},"
              "\"extensionsUsed\":[\"KHR_materials_unlit\"],", RAD_VERSION_STRING);
    put_nodes(j, sc, g);
    jb_put(j, ",");
    put_materials(j, sc);
    put_cameras(j, sc, size > 0 ? size : 1.0);
    put_accessors(j, sc, g, l);
    jb_put(j, ",\"buffers\":[{\"byteLength\":%llu", (unsigned long long)l.total);
    if (uri) {
        jb_put(j, ",\"uri\":\"");
        /* A relative URI: bytes other than unreserved ones percent-encoded. */
        for (const unsigned char *u = (const unsigned char *)uri; *u; u++)
            if ((*u >= 'a' && *u <= 'z') || (*u >= 'A' && *u <= 'Z') || (*u >= '0' && *u <= '9') ||
                strchr("-._~", *u))
                jb_put(j, "%c", *u);
            else
                jb_put(j, "%%%02X", *u);
        jb_put(j, "\"");
    }
    jb_put(j, "}]}");
    if (j->failed)
        return rad_fail(err, RAD_ERR_NOMEM, "bake: out of memory for the glTF JSON");
    return RAD_OK;
}

/* ---------------------------------------------------------------- files */

static int write_buffer(rad_output *o, const rad_scene *sc, const bk_geometry *g)
{
    int rc = rad_output_write(o, g->position, g->vertex_count * 12);
    rc |= rad_output_write(o, g->color, g->vertex_count * 8);
    rc |= rad_output_write(o, g->radiance, g->vertex_count * 12);
    rc |= rad_output_write(o, g->index, g->index_count * 4);
    for (uint32_t p = 0; p < g->prim_count; p++) /* the textured primitives' TEXCOORD_0 */
        if (g->prims[p].textured)
            rc |= rad_output_write(o, g->uv + 2 * g->prims[p].first_vertex,
                                   g->prims[p].vertex_count * 8);
    for (uint32_t k = 0; k < sc->image_count; k++) {
        rc |= rad_output_write(o, sc->images[k].data, sc->images[k].size);
        rc |= rad_output_write(o, "\0\0\0", pad4(sc->images[k].size) - sc->images[k].size);
    }
    return rc;
}

static void put_u32(rad_output *o, uint32_t v)
{
    unsigned char b[4] = {(unsigned char)v, (unsigned char)(v >> 8), (unsigned char)(v >> 16),
                          (unsigned char)(v >> 24)};
    rad_output_write(o, b, 4);
}

static int write_glb(const rad_scene *sc, const char *path, const jbuf *j, const bk_geometry *g,
                     uint64_t *bytes, rad_error *err)
{
    uint64_t json_len = (j->n + 3) & ~(uint64_t)3, bin_len = buffer_layout(sc, g).total;
    uint64_t total = 12 + 8 + json_len + 8 + bin_len;
    if (total > UINT32_MAX)
        return rad_fail(err, RAD_ERR_LIMIT, "%s: %llu bytes: more than a .glb holds (4 GiB); "
                        "write .gltf", path, (unsigned long long)total);
    rad_output *o = NULL;
    int rc = rad_output_open(path, &o, err);
    if (rc)
        return rc;
    rad_output_write(o, "glTF", 4);
    put_u32(o, 2);
    put_u32(o, (uint32_t)total);
    put_u32(o, (uint32_t)json_len);
    rad_output_write(o, "JSON", 4);
    rad_output_write(o, j->p, j->n);
    rad_output_write(o, "   ", json_len - j->n);
    put_u32(o, (uint32_t)bin_len);
    rad_output_write(o, "BIN\0", 4);
    write_buffer(o, sc, g);
    *bytes = total;
    return rad_output_commit(o, err);
}

/* PATH.gltf -> PATH.bin (path with its extension replaced). */
static int bin_path(const char *path, char *out, size_t size)
{
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    size_t stem = dot && (!slash || dot > slash) ? (size_t)(dot - path) : strlen(path);
    return snprintf(out, size, "%.*s.bin", (int)stem, path) >= (int)size ? -1 : 0;
}

static int write_gltf(const rad_solution *s, const bk_geometry *g, const char *path,
                      uint64_t *bytes, rad_error *err)
{
    char bin[4096];
    if (bin_path(path, bin, sizeof bin))
        return rad_fail(err, RAD_ERR_USAGE, "%s: path too long", path);
    const char *base = strrchr(bin, '/') ? strrchr(bin, '/') + 1 : bin;
    jbuf j = {0};
    rad_output *ob = NULL, *oj = NULL;
    int rc = make_json(s, g, base, &j, err);
    if (!rc)
        rc = rad_output_open(bin, &ob, err);
    if (!rc)
        rc = rad_output_open(path, &oj, err);
    if (!rc) {
        write_buffer(ob, s->scene, g);
        rad_output_write(oj, j.p, j.n);
        *bytes = buffer_layout(s->scene, g).total + j.n;
        rc = rad_output_commit(ob, err);
        ob = NULL;
    }
    if (!rc) {
        rc = rad_output_commit(oj, err);
        oj = NULL;
        if (rc)
            unlink(bin); /* the JSON that names it is not there */
    }
    rad_output_abort(ob);
    rad_output_abort(oj);
    free(j.p);
    return rc;
}

int bk_write_files(const rad_solution *s, const bk_geometry *g, const char *path, uint64_t *bytes,
                   rad_error *err)
{
    size_t n = strlen(path);
    if (n >= 4 && !strcasecmp(path + n - 4, ".glb")) {
        jbuf j = {0};
        int rc = make_json(s, g, NULL, &j, err);
        if (!rc)
            rc = write_glb(s->scene, path, &j, g, bytes, err);
        free(j.p);
        return rc;
    }
    return write_gltf(s, g, path, bytes, err);
}
