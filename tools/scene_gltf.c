/* scene_gltf.c - the benchmarks' scene generators' shared part
 * (scene_gltf.h): objects of triangles and the glTF writer.  Vertices are
 * stored as float, as the file holds them; a triangle is turned to face
 * the side its caller names.
 */
#include "scene_gltf.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

double gs_jitter(gs_scene *h)
{
    h->seed = h->seed * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(h->seed >> 11) / 9007199254740992.0 - 0.5; /* [-0.5, 0.5) */
}

obj *gs_new_obj(gs_scene *h, const char *name, int material)
{
    if (h->n == h->cap) {
        uint32_t cap = h->cap ? 2 * h->cap : 32;
        obj *o = realloc(h->o, cap * sizeof *o);
        if (!o)
            return NULL;
        h->o = o;
        h->cap = cap;
    }
    obj *o = &h->o[h->n++];
    memset(o, 0, sizeof *o);
    snprintf(o->name, sizeof o->name, "%s", name);
    o->material = material;
    return o;
}

uint32_t gs_vert(obj *o, v3 p)
{
    if (o->nv == o->cv) {
        uint32_t cap = o->cv ? 2 * o->cv : 1024;
        float *v = realloc(o->v, (size_t)cap * 3 * sizeof *v);
        if (!v) {
            o->failed = 1;
            return 0;
        }
        o->v = v;
        o->cv = cap;
    }
    o->v[3 * o->nv] = (float)p.x;
    o->v[3 * o->nv + 1] = (float)p.y;
    o->v[3 * o->nv + 2] = (float)p.z;
    return o->nv++;
}

v3 gs_vat(const obj *o, uint32_t k)
{
    return mk(o->v[3 * k], o->v[3 * k + 1], o->v[3 * k + 2]);
}

/* Triangle a, b, c, turned to face `facing` (its front is where it runs
 * counter-clockwise). */
void gs_tri(obj *o, uint32_t a, uint32_t b, uint32_t c, v3 facing)
{
    if (o->nt == o->ct) {
        uint32_t cap = o->ct ? 2 * o->ct : 1024;
        uint32_t *t = realloc(o->t, (size_t)cap * 3 * sizeof *t);
        if (!t) {
            o->failed = 1;
            return;
        }
        o->t = t;
        o->ct = cap;
    }
    v3 n = cross(sub(gs_vat(o, b), gs_vat(o, a)), sub(gs_vat(o, c), gs_vat(o, a)));
    if (dot(n, facing) < 0.0) {
        uint32_t s = b;
        b = c;
        c = s;
    }
    o->t[3 * o->nt] = a;
    o->t[3 * o->nt + 1] = b;
    o->t[3 * o->nt + 2] = c;
    o->nt++;
}

/* ---------------------------------------------------------------- writing */

/* p + (q - p) · s, computed from the stored floats. */
static v3 along(const obj *o, uint32_t p, uint32_t q, double s)
{
    v3 a = gs_vat(o, p);
    return add(a, scl(sub(gs_vat(o, q), a), s));
}

/* Triangle a, b, c cut at its edges' midpoints; `own`: every small
 * triangle on its own copies of its points. */
static void split_mid(obj *o, uint32_t a, uint32_t b, uint32_t c, v3 n, int own)
{
    const v3 p[6] = {gs_vat(o, a), gs_vat(o, b), gs_vat(o, c), along(o, a, b, 0.5),
                     along(o, b, c, 0.5), along(o, c, a, 0.5)};
    static const int tri[4][3] = {{0, 3, 5}, {3, 1, 4}, {5, 4, 2}, {3, 4, 5}};
    uint32_t k[6] = {a, b, c, 0, 0, 0};
    for (int i = 3; !own && i < 6; i++)
        k[i] = gs_vert(o, p[i]);
    for (int t = 0; t < 4; t++) {
        uint32_t q[3];
        for (int i = 0; i < 3; i++)
            q[i] = own ? gs_vert(o, p[tri[t][i]]) : k[tri[t][i]];
        gs_tri(o, q[0], q[1], q[2], n);
    }
}

void gs_split4(obj *o)
{
    const uint32_t nt = o->nt;
    uint32_t *old = malloc((size_t)nt * 3 * sizeof *old);
    if (!old) {
        o->failed = 1;
        return;
    }
    memcpy(old, o->t, (size_t)nt * 3 * sizeof *old);
    o->nt = 0;
    for (uint32_t t = 0; t < nt && !o->failed; t++) {
        const uint32_t a = old[3 * t], b = old[3 * t + 1], c = old[3 * t + 2];
        const v3 n = cross(sub(gs_vat(o, b), gs_vat(o, a)), sub(gs_vat(o, c), gs_vat(o, a)));
        if (t % 3 == 0) { /* a fan from a onto b..c cut in four */
            uint32_t q[5] = {b, 0, 0, 0, c};
            for (int i = 1; i < 4; i++)
                q[i] = gs_vert(o, along(o, b, c, 0.25 * i));
            for (int i = 0; i < 4; i++)
                gs_tri(o, a, q[i], q[i + 1], n);
        } else {
            split_mid(o, a, b, c, n, t % 3 == 2);
        }
    }
    free(old);
}

int gs_split4_all(gs_scene *h)
{
    for (uint32_t k = 0; k < h->n; k++)
        gs_split4(&h->o[k]);
    return gs_failed(h) ? -1 : 0;
}

int gs_write(const gs_scene *h, const char *dir, const char *name)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.bin", dir, name);
    FILE *bin = fopen(path, "wb");
    if (!bin) {
        fprintf(stderr, "%s: cannot write %s\n", h->generator, path);
        return -1;
    }
    uint64_t *off = malloc(2 * (size_t)h->n * sizeof *off), at = 0;
    int ok = off != NULL;
    for (uint32_t k = 0; k < h->n && ok; k++) {
        const obj *o = &h->o[k];
        off[2 * k] = at;
        ok = fwrite(o->v, sizeof *o->v, 3 * (size_t)o->nv, bin) == 3 * (size_t)o->nv;
        at += 12 * (uint64_t)o->nv;
        off[2 * k + 1] = at;
        ok = ok && fwrite(o->t, sizeof *o->t, 3 * (size_t)o->nt, bin) == 3 * (size_t)o->nt;
        at += 12 * (uint64_t)o->nt;
    }
    ok = (fclose(bin) == 0) && ok;
    snprintf(path, sizeof path, "%s/%s.gltf", dir, name);
    FILE *f = ok ? fopen(path, "w") : NULL;
    if (!f) {
        free(off);
        fprintf(stderr, "%s: cannot write %s\n", h->generator, path);
        return -1;
    }
    int sun = dot(h->sun, h->sun) > 0.0;
    fprintf(f, "{\"asset\":{\"version\":\"2.0\",\"generator\":\"radiosity %s\"},\n",
            h->generator);
    if (sun)
        fprintf(f, "\"extensionsUsed\":[\"KHR_lights_punctual\"],\n"
                   "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"name\":\"sun\","
                   "\"type\":\"directional\",\"color\":[1.0,0.95,0.85],\"intensity\":100000}]}},\n");
    fprintf(f, "\"scene\":0,\"scenes\":[{\"nodes\":[");
    for (uint32_t k = 0; k < h->n + (uint32_t)sun; k++)
        fprintf(f, "%s%u", k ? "," : "", k);
    fprintf(f, "]}],\n\"nodes\":[");
    for (uint32_t k = 0; k < h->n; k++)
        fprintf(f, "%s{\"name\":\"%s\",\"mesh\":%u}", k ? ",\n" : "", h->o[k].name, k);
    if (sun) {
        /* The sun: light travels along d, a node's light shines along its
         * -Z: the rotation taking -Z to d, q = (a × d, 1 + a·d) normalised. */
        v3 d = scl(h->sun, 1.0 / sqrt(dot(h->sun, h->sun))), a = mk(0, 0, -1);
        v3 ax = cross(a, d);
        double qw = 1.0 + dot(a, d), ql = sqrt(dot(ax, ax) + qw * qw);
        fprintf(f, ",\n{\"name\":\"sun\",\"rotation\":[%.9f,%.9f,%.9f,%.9f],"
                   "\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}",
                ax.x / ql, ax.y / ql, ax.z / ql, qw / ql);
    }
    fprintf(f, "],\n");
    fprintf(f, "\"materials\":[");
    const gs_material *materials = h->materials;
    for (size_t m = 0; m < h->material_count; m++) {
        static const double none[3] = {0, 0, 0};
        const double *e = h->emit ? h->emit + 3 * m : none;
        fprintf(f, "%s{\"name\":\"%s\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[%g,%g,%g,1],"
                   "\"metallicFactor\":0}",
                m ? ",\n" : "", materials[m].name, materials[m].rgb[0], materials[m].rgb[1],
                materials[m].rgb[2]);
        if (e[0] > 0.0 || e[1] > 0.0 || e[2] > 0.0)
            fprintf(f, ",\"emissiveFactor\":[%g,%g,%g]", e[0], e[1], e[2]);
        fprintf(f, "}");
    }
    fprintf(f, "],\n\"meshes\":[");
    for (uint32_t k = 0; k < h->n; k++)
        fprintf(f, "%s{\"name\":\"%s\",\"primitives\":[{\"attributes\":{\"POSITION\":%u},"
                   "\"indices\":%u,\"material\":%d}]}",
                k ? ",\n" : "", h->o[k].name, 2 * k, 2 * k + 1, h->o[k].material);
    fprintf(f, "],\n\"accessors\":[");
    for (uint32_t k = 0; k < h->n; k++) {
        const obj *o = &h->o[k];
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (uint32_t v = 0; v < o->nv; v++)
            for (int c = 0; c < 3; c++) {
                lo[c] = fminf(lo[c], o->v[3 * v + c]);
                hi[c] = fmaxf(hi[c], o->v[3 * v + c]);
            }
        fprintf(f, "%s{\"bufferView\":%u,\"componentType\":5126,\"count\":%u,\"type\":\"VEC3\","
                   "\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]},\n"
                   "{\"bufferView\":%u,\"componentType\":5125,\"count\":%u,\"type\":\"SCALAR\"}",
                k ? ",\n" : "", 2 * k, o->nv, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], 2 * k + 1,
                3 * o->nt);
    }
    fprintf(f, "],\n\"bufferViews\":[");
    for (uint32_t k = 0; k < h->n; k++)
        fprintf(f, "%s{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu,\"target\":34962},\n"
                   "{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu,\"target\":34963}",
                k ? ",\n" : "", (unsigned long long)off[2 * k], 12ull * h->o[k].nv,
                (unsigned long long)off[2 * k + 1], 12ull * h->o[k].nt);
    fprintf(f, "],\n\"buffers\":[{\"uri\":\"%s.bin\",\"byteLength\":%llu}]}\n", name,
            (unsigned long long)at);
    free(off);
    if (fclose(f) != 0) {
        fprintf(stderr, "%s: cannot write %s\n", h->generator, path);
        return -1;
    }
    return 0;
}


int gs_make(gs_scene *h, int (*build)(gs_scene *, double), double fine, const char *dir,
            const char *name)
{
    int rc = build(h, fine > 0 ? fine : 1.0);
    if (rc != 0)
        fprintf(stderr, "%s: out of memory\n", h->generator);
    return rc == 0 ? gs_write(h, dir, name) : rc;
}

uint64_t gs_triangles(const gs_scene *h)
{
    uint64_t t = 0;
    for (uint32_t k = 0; k < h->n; k++)
        t += h->o[k].nt;
    return t;
}

int gs_failed(const gs_scene *h)
{
    for (uint32_t k = 0; k < h->n; k++)
        if (h->o[k].failed)
            return 1;
    return 0;
}

void gs_free(gs_scene *h)
{
    for (uint32_t k = 0; k < h->n; k++) {
        free(h->o[k].v);
        free(h->o[k].t);
    }
    free(h->o);
    h->o = NULL;
    h->n = h->cap = 0;
}
