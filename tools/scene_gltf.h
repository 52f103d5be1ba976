/* scene_gltf.h - what the benchmarks' scene generators (tools/hall.c,
 * tools/atrium.c) share: objects of triangles made in code, a jitter
 * sequence, and the writer of glTF 2.0 (JSON and one external binary
 * buffer) with a sun (KHR_lights_punctual directional light) or, for a
 * closed room lit by its own lamp, none.  No engine
 * code: the files are read back by the loader as a user's export would be.
 */
#ifndef TOOLS_SCENE_GLTF_H
#define TOOLS_SCENE_GLTF_H

#include <math.h>
#include <stdint.h>

typedef struct v3 {
    double x, y, z;
} v3;

static inline v3 mk(double x, double y, double z) { v3 r = {x, y, z}; return r; }
static inline v3 add(v3 a, v3 b) { return mk(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline v3 sub(v3 a, v3 b) { return mk(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline v3 scl(v3 a, double s) { return mk(a.x * s, a.y * s, a.z * s); }
static inline double dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline v3 cross(v3 a, v3 b)
{
    return mk(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

/* One object: a node, a mesh, one primitive. */
typedef struct obj {
    char name[48];
    int material;
    float *v;
    uint32_t nv, cv;
    uint32_t *t;
    uint32_t nt, ct;
    int failed;
} obj;

typedef struct gs_material {
    const char *name;
    double rgb[3];
} gs_material;

/* A scene being made: its objects, materials and sun. */
typedef struct gs_scene {
    obj *o;
    uint32_t n, cap;
    uint64_t seed;               /* the jitter sequence's state */
    const gs_material *materials;
    uint32_t material_count;
    const double *emit;          /* material_count × 3 emissiveFactors (radiance: E = π·emit),
                                  * or NULL: nothing emits */
    v3 sun;                      /* direction the sunlight travels; zero: no sun */
    const char *generator;       /* "tools/hall.c": the asset's generator and messages */
} gs_scene;

/* A fixed linear congruential sequence in [-0.5, 0.5). */
double gs_jitter(gs_scene *h);
/* A new empty object (NULL when out of memory). */
obj *gs_new_obj(gs_scene *h, const char *name, int material);
/* Appends vertex p and returns its index (o->failed on out of memory). */
uint32_t gs_vert(obj *o, v3 p);
v3 gs_vat(const obj *o, uint32_t k);
/* Triangle a, b, c, turned to face `facing` (its front is where it runs
 * counter-clockwise). */
void gs_tri(obj *o, uint32_t a, uint32_t b, uint32_t c, v3 facing);
/* Re-tessellates every triangle of o into four as exporters write them,
 * the surface unchanged: in turn a fan from one corner onto its opposite
 * edge cut in four (slivers, T-junctions with the neighbour across it), the
 * midpoint split with shared points, and the midpoint split with every
 * small triangle on its own copies of its points (unwelded).  The points
 * on an edge are the same floats whichever triangle makes them. */
void gs_split4(obj *o);
/* Every object of h split so (gs_split4): 0, or -1 when h has failed. */
int gs_split4_all(gs_scene *h);
/* Writes DIR/NAME.gltf and DIR/NAME.bin; 0, or -1 with a message on stderr. */
int gs_write(const gs_scene *h, const char *dir, const char *name);
/* Builds h with build(h, fine) (fine <= 0: 1) and writes DIR/NAME.gltf
 * and .bin; 0, or -1 with a message on stderr.  h keeps the objects for
 * the caller's figures; free them with gs_free. */
int gs_make(gs_scene *h, int (*build)(gs_scene *, double), double fine, const char *dir,
            const char *name);
/* Triangles of every object. */
uint64_t gs_triangles(const gs_scene *h);
/* 1 when some object ran out of memory. */
int gs_failed(const gs_scene *h);
void gs_free(gs_scene *h);

#endif /* TOOLS_SCENE_GLTF_H */
