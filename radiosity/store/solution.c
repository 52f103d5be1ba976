/* solution.c - the solution store: creating and destroying a rad_solution,
 * and writing and reading the binary solution file that
 * docs/solution-format.md specifies (header, CRC-64/XZ of the payload, tagged
 * sections INFO, SCENE, MESH, MATRIX, PATCHDATA, LIGHTS when the scene has
 * punctual lights, ELEMENTS when the solution has elements, ELEMENTLIGHTS
 * when it has both).
 *
 * Invariant: whatever bytes rad_solution_parse is given, it either fails with
 * a message naming the file, the section and the element, or returns a
 * solution that satisfies solution.h: the scene is rebuilt through scene.c's
 * checked builders, the mesh passes rad_mesh_check, F passes
 * rad_matrix_check, and ρ ∈ [0,1), E >= 0, B >= 0 are finite.  Every count is
 * compared with the bytes left before anything is allocated.  The writer
 * applies the same rules before it creates a file, so it never writes a file
 * the reader would refuse, and it never replaces a good file with a bad one.
 */
#include "solution.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define SOL_MAGIC "RADSOL\r\n"  /* 8 bytes; the CR LF catches text-mode mangling */
/* Version 2 = version 1 + the LIGHTS section; version 3 = + the ELEMENTS
 * section; version 4 = + the ELEMENTLIGHTS section (each element's own
 * direct light); version 5 = MESH may hold two-sided sheets (a transmitting
 * polygon's front cells followed by their back twins), with the sections of
 * versions 1-4 as its content needs them.  A file is written with the lowest
 * version that holds what it has (1 without punctual lights or elements, 2
 * with lights, 3 with elements, 4 with elements that carry their own direct
 * light, 5 with sheets), so older programs still read what they understand,
 * and a file they would misread - skipping LIGHTS, ELEMENTS or ELEMENTLIGHTS
 * without a word, which for the last would relight the elements from their
 * patches' direct light, or taking a sheet's two sides for two unrelated
 * opaque surfaces - carries a version they refuse. */
#define SOL_VERSION 5u
#define SOL_VERSION_SHEETS 5u
#define SOL_HEADER_BYTES 32u
#define SOL_SECTION_HEADER 12u  /* u32 tag + u64 length */
#define SOL_MAX_STRING 4096u
#define SOL_MAX_FILE (64ull << 30)
#define SOL_MAX_STAGES 64u      /* a future version may time more stages */
#define SOL_SOLVER_MAX (sizeof(((rad_solution *)0)->solver) - 1)
/* Largest row sum rad_matrix_check accepts: Σ_j F_ij <= 1 plus the
 * hemi-cube's discretisation error. */
#define SOL_ROW_SUM_MAX (1.0 + 1e-3)

/* The first five sections appear in every file; LIGHTS only when the scene
 * has punctual lights, ELEMENTS only when the solution has elements. */
enum { SEC_INFO, SEC_SCENE, SEC_MESH, SEC_MATRIX, SEC_PATCHDATA, SEC_LIGHTS, SEC_ELEMENTS,
       SEC_ELEMENT_LIGHTS, SEC_COUNT };
static const char sec_tag[SEC_COUNT][4] = {
    {'I', 'N', 'F', 'O'}, {'S', 'C', 'E', 'N'}, {'M', 'E', 'S', 'H'}, {'M', 'T', 'R', 'X'},
    {'P', 'D', 'A', 'T'}, {'L', 'G', 'H', 'T'}, {'E', 'L', 'E', 'M'}, {'E', 'L', 'G', 'T'}};
static const char *const sec_name[SEC_COUNT] = {"INFO",      "SCENE",  "MESH",     "MATRIX",
                                                "PATCHDATA", "LIGHTS", "ELEMENTS", "ELEMENTLIGHTS"};
/* Sections each version may hold: 1 the first five, 2 + LIGHTS, 3 +
 * ELEMENTS (where LIGHTS is there exactly when the scene has lights), 4 +
 * ELEMENTLIGHTS (LIGHTS always), 5 any of them as the content needs. */
static const int version_sections[SOL_VERSION + 1] = {0, SEC_LIGHTS, SEC_ELEMENTS,
                                                      SEC_ELEMENT_LIGHTS, SEC_COUNT, SEC_COUNT};

/* Minimum encoded sizes of one element, used to bound counts before
 * allocating: a count of k elements needs at least k × this many bytes. */
#define MIN_STRING 4u
#define MIN_CAMERA (MIN_STRING + 11u * 8u)
#define MIN_POLYGON (MIN_STRING + 6u * 4u + 3u * 24u)
#define PATCH_BYTES (7u * 4u + 7u * 8u)
#define VERTEX_BYTES (3u * 8u + 1u)
#define MIN_ROW (2u * 4u)
#define MIN_ENTRY (1u + 4u) /* one varint byte + a float32 */
/* name, kind, position, direction, cones, present flag, count; + 16 per band */
#define MIN_LIGHT (MIN_STRING + 1u + 48u + 16u + 1u + 4u)
#define ELEMENT_VERTEX_BYTES (3u * 8u + 1u)
/* patch, level, four corners, row count; + 8 per band */
#define MIN_ELEMENT (4u + 1u + 16u + 4u)

const char *rad_stage_name(rad_stage s)
{
    switch (s) {
    case RAD_STAGE_LOAD: return "load";
    case RAD_STAGE_MESH: return "mesh";
    case RAD_STAGE_FORM_FACTORS: return "form_factors";
    case RAD_STAGE_SOLVE: return "solve";
    case RAD_STAGE_STORE: return "store";
    default: return "unknown";
    }
}

/* ------------------------------------------------------- create / destroy */

static double *alloc_band_array(uint32_t n, uint32_t bands);

void rad_solution_destroy(rad_solution *s)
{
    if (!s)
        return;
    rad_scene_destroy(s->scene);
    rad_mesh_destroy(s->mesh);
    rad_matrix_destroy(s->F);
    free(s->rho);
    free(s->emission);
    free(s->B);
    for (uint32_t l = 0; s->light_power && l < s->light_slots_; l++) {
        free(s->light_power[l].patch);
        free(s->light_power[l].power);
    }
    free(s->light_power);
    free(s->light_intensity);
    rad_elements_destroy(s->elements);
    free(s);
}

/* The light arrays for `count` lights (intensity from the scene's nominal
 * values, no power yet); 0, or -1 when memory runs out. */
static int alloc_lights(rad_solution *s, uint32_t count)
{
    if (count == 0)
        return 0;
    s->light_intensity = alloc_band_array(count, s->band_count);
    s->light_power = calloc(count, sizeof *s->light_power);
    if (!s->light_intensity || !s->light_power)
        return -1;
    s->light_slots_ = count;
    return 0;
}

/* n × bands doubles, or NULL when that does not fit in size_t or memory. */
static double *alloc_band_array(uint32_t n, uint32_t bands)
{
    uint64_t count = (uint64_t)n * bands;
    if (count > SIZE_MAX / sizeof(double))
        return NULL;
    return calloc(count ? (size_t)count : 1, sizeof(double));
}

int rad_solution_create(rad_scene *scene, rad_mesh *mesh, rad_solution **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!scene || !mesh || !out) {
        rad_scene_destroy(scene);
        rad_mesh_destroy(mesh);
        return rad_fail(err, RAD_ERR_USAGE,
                        "rad_solution_create: scene, mesh and out are required");
    }
    const char *src = scene->source ? scene->source : "<memory>";
    if (scene->band_count < 1 || scene->band_count > RAD_MAX_BANDS) {
        rad_fail(err, RAD_ERR_USAGE, "%s: %u bands (1..%d allowed)", src, scene->band_count,
                 RAD_MAX_BANDS);
        rad_scene_destroy(scene);
        rad_mesh_destroy(mesh);
        return RAD_ERR_USAGE;
    }
    for (uint32_t i = 0; i < mesh->patch_count; i++) {
        if (mesh->patches[i].material >= scene->material_count) {
            rad_fail(err, RAD_ERR_USAGE, "%s: patch %u: material %u out of range (%u materials)",
                     src, i, mesh->patches[i].material, scene->material_count);
            rad_scene_destroy(scene);
            rad_mesh_destroy(mesh);
            return RAD_ERR_USAGE;
        }
    }
    rad_solution *s = calloc(1, sizeof *s);
    if (!s) {
        rad_scene_destroy(scene);
        rad_mesh_destroy(mesh);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for the solution", src);
    }
    s->scene = scene;
    s->mesh = mesh;
    s->band_count = scene->band_count;
    uint32_t n = mesh->patch_count, nb = s->band_count;
    s->rho = alloc_band_array(n, nb);
    s->emission = alloc_band_array(n, nb);
    s->B = alloc_band_array(n, nb);
    s->F = rad_matrix_create(n);
    if (!s->rho || !s->emission || !s->B || !s->F || alloc_lights(s, scene->light_count) != 0) {
        rad_solution_destroy(s);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for %u patches × %u bands", src, n,
                        nb);
    }
    for (uint32_t i = 0; i < n; i++) {
        const rad_material *m = &scene->materials[mesh->patches[i].material];
        for (uint32_t b = 0; b < nb; b++) {
            s->rho[(size_t)i * nb + b] = m->rho[b];
            s->emission[(size_t)i * nb + b] = m->emission[b];
            s->B[(size_t)i * nb + b] = m->emission[b]; /* B = E before any bounce */
        }
    }
    for (uint32_t l = 0; l < scene->light_count; l++)
        memcpy(s->light_intensity + (size_t)l * nb, scene->lights[l].intensity,
               nb * sizeof(double));
    *out = s;
    return RAD_OK;
}

/* ------------------------------------------------------------- CRC-64/XZ */

/* CRC-64/XZ (ECMA-182 polynomial, reflected, init and final XOR all ones;
 * check value of "123456789" is 0x995DC9BBDF1939FA).  A CRC, unlike a hash,
 * is guaranteed to catch every error burst of up to 64 bits, so every
 * single-byte corruption is detected.  Slicing-by-8 tables: solution files
 * reach gigabytes. */
#define CRC64_POLY 0xC96C5795D7870F42ull

typedef struct crc64_tables {
    uint64_t t[8][256];
} crc64_tables;

static void crc64_init(crc64_tables *c)
{
    for (uint32_t i = 0; i < 256; i++) {
        uint64_t r = i;
        for (int k = 0; k < 8; k++)
            r = (r & 1) ? (r >> 1) ^ CRC64_POLY : r >> 1;
        c->t[0][i] = r;
    }
    for (int k = 1; k < 8; k++)
        for (uint32_t i = 0; i < 256; i++)
            c->t[k][i] = (c->t[k - 1][i] >> 8) ^ c->t[0][c->t[k - 1][i] & 0xff];
}

static uint64_t load_le64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int k = 7; k >= 0; k--)
        v = (v << 8) | p[k];
    return v;
}

/* Advances the CRC register (not yet inverted) over n bytes. */
static uint64_t crc64_update(const crc64_tables *c, uint64_t crc, const uint8_t *p, size_t n)
{
    while (n >= 8) {
        crc ^= load_le64(p);
        crc = c->t[7][crc & 0xff] ^ c->t[6][(crc >> 8) & 0xff] ^ c->t[5][(crc >> 16) & 0xff] ^
              c->t[4][(crc >> 24) & 0xff] ^ c->t[3][(crc >> 32) & 0xff] ^
              c->t[2][(crc >> 40) & 0xff] ^ c->t[1][(crc >> 48) & 0xff] ^ c->t[0][crc >> 56];
        p += 8;
        n -= 8;
    }
    while (n--)
        crc = c->t[0][(crc ^ *p++) & 0xff] ^ (crc >> 8);
    return crc;
}

static int crc64_of(const uint8_t *p, size_t n, uint64_t *out)
{
    crc64_tables *c = malloc(sizeof *c);
    if (!c)
        return 0;
    crc64_init(c);
    *out = crc64_update(c, ~0ull, p, n) ^ ~0ull;
    free(c);
    return 1;
}

/* ---------------------------------------------------------- shared checks */

static int bad_reflectance(double r) { return !(r >= 0.0 && r < 1.0); } /* also NaN */
static int bad_nonneg(double v) { return !(v >= 0.0) || !isfinite(v); }

/* The per-patch ρ, E and B rules; `where` is "section PATCHDATA" (reader) or
 * "cannot write" (writer). */
static int check_patch_values(const rad_solution *s, const char *file, const char *where,
                              int code, rad_error *err)
{
    uint32_t n = s->mesh->patch_count, nb = s->band_count;
    for (uint32_t i = 0; i < n; i++) {
        for (uint32_t b = 0; b < nb; b++) {
            size_t k = (size_t)i * nb + b;
            if (bad_reflectance(s->rho[k]))
                return rad_fail(err, code, "%s: %s: patch %u band %u: ρ = %g outside [0, 1)", file,
                                where, i, b, s->rho[k]);
            if (bad_nonneg(s->emission[k]))
                return rad_fail(err, code,
                                "%s: %s: patch %u band %u: E = %g is not finite and >= 0", file,
                                where, i, b, s->emission[k]);
            if (bad_nonneg(s->B[k]))
                return rad_fail(err, code,
                                "%s: %s: patch %u band %u: B = %g is not finite and >= 0", file,
                                where, i, b, s->B[k]);
        }
    }
    return RAD_OK;
}

/* The provenance rules: durations and sizes are finite and non-negative;
 * the residual may be +inf (no sweep done yet) but not NaN or negative. */
static int check_info(const rad_solution *s, const char *file, const char *where, int code,
                      rad_error *err)
{
    if (bad_nonneg(s->patch_size))
        return rad_fail(err, code, "%s: %s: patch size %g is not finite and >= 0", file, where,
                        s->patch_size);
    if (bad_nonneg(s->tolerance))
        return rad_fail(err, code, "%s: %s: tolerance %g is not finite and >= 0", file, where,
                        s->tolerance);
    if (!(s->residual >= 0.0))
        return rad_fail(err, code, "%s: %s: residual %g is negative or NaN", file, where,
                        s->residual);
    for (int k = 0; k < RAD_STAGE_COUNT; k++) {
        if (bad_nonneg(s->stages[k].seconds))
            return rad_fail(err, code, "%s: %s: stage %s: %g seconds is not finite and >= 0", file,
                            where, rad_stage_name((rad_stage)k), s->stages[k].seconds);
        if (s->stages[k].reused != 0 && s->stages[k].reused != 1)
            return rad_fail(err, code, "%s: %s: stage %s: reused flag %d is not 0 or 1", file,
                            where, rad_stage_name((rad_stage)k), s->stages[k].reused);
    }
    return RAD_OK;
}

/* ------------------------------------------------------------------ writer */

/* Where encoded bytes go: a counting pass (out NULL) only measures a
 * section, the writing pass buffers, checksums and writes.  A write failure
 * sticks in the rad_output, so the encoders need no error paths. */
typedef struct sink {
    rad_output *out;
    uint8_t *buf;
    size_t len, cap;
    uint64_t total; /* bytes put, including those still in buf */
    uint64_t crc;   /* CRC register over the bytes flushed so far */
    const crc64_tables *tab;
    int failed;
} sink;

static void sink_flush(sink *k)
{
    if (!k->out || k->failed || k->len == 0)
        return;
    k->crc = crc64_update(k->tab, k->crc, k->buf, k->len);
    if (rad_output_write(k->out, k->buf, k->len) < 0)
        k->failed = 1;
    k->len = 0;
}

static void put(sink *k, const void *p, size_t n)
{
    k->total += n;
    if (!k->out || k->failed)
        return;
    const uint8_t *b = p;
    while (n) {
        size_t room = k->cap - k->len, step = n < room ? n : room;
        memcpy(k->buf + k->len, b, step);
        k->len += step;
        b += step;
        n -= step;
        if (k->len == k->cap) {
            sink_flush(k);
            if (k->failed)
                return;
        }
    }
}

static void put_u8(sink *k, uint8_t v) { put(k, &v, 1); }

static void put_u32(sink *k, uint32_t v)
{
    uint8_t b[4];
    for (int i = 0; i < 4; i++)
        b[i] = (uint8_t)(v >> (8 * i));
    put(k, b, 4);
}

static void put_u64(sink *k, uint64_t v)
{
    uint8_t b[8];
    for (int i = 0; i < 8; i++)
        b[i] = (uint8_t)(v >> (8 * i));
    put(k, b, 8);
}

static void put_f64(sink *k, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    put_u64(k, bits);
}

static void put_f32(sink *k, float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    put_u32(k, bits);
}

static void put_vec3(sink *k, rad_vec3 v)
{
    put_f64(k, v.x);
    put_f64(k, v.y);
    put_f64(k, v.z);
}

/* LEB128: 7 bits a byte, low bits first, high bit = more follows. */
static void put_varint(sink *k, uint32_t v)
{
    uint8_t b[5];
    size_t n = 0;
    do {
        uint8_t byte = v & 0x7f;
        v >>= 7;
        b[n++] = v ? (uint8_t)(byte | 0x80) : byte;
    } while (v);
    put(k, b, n);
}

/* Lengths were checked against SOL_MAX_STRING before writing began. */
static void put_str(sink *k, const char *s)
{
    size_t n = s ? strlen(s) : 0;
    put_u32(k, (uint32_t)n);
    put(k, s, n);
}

static uint32_t version_of(const rad_solution *s);
static int section_written(const rad_solution *s, int i);

/* Version 5's INFO ends with the optional sections the file holds, one bit
 * each (LIGHTS 1, ELEMENTS 2, ELEMENTLIGHTS 4): the reader then knows what
 * must follow, and a file cut or stripped before one of them cannot pass
 * for a file without it. */
static uint8_t announced_sections(const rad_solution *s)
{
    uint8_t bits = 0;
    for (int i = SEC_LIGHTS; i < SEC_COUNT; i++)
        if (section_written(s, i))
            bits |= (uint8_t)(1u << (i - SEC_LIGHTS));
    return bits;
}

static void emit_info(sink *k, const rad_solution *s)
{
    put_f64(k, s->patch_size);
    put_u32(k, s->resolution);
    put_str(k, s->solver);
    put_f64(k, s->tolerance);
    put_u32(k, s->iterations);
    put_f64(k, s->residual);
    put_u64(k, s->rows_computed);
    put_u32(k, RAD_STAGE_COUNT);
    for (int i = 0; i < RAD_STAGE_COUNT; i++) {
        put_f64(k, s->stages[i].seconds);
        put_u8(k, (uint8_t)s->stages[i].reused);
    }
    if (version_of(s) >= SOL_VERSION_SHEETS)
        put_u8(k, announced_sections(s));
}

static void emit_scene(sink *k, const rad_solution *s)
{
    const rad_scene *sc = s->scene;
    uint32_t nb = sc->band_count;
    put_str(k, sc->source);
    put_u32(k, nb);
    for (uint32_t b = 0; b < nb; b++) {
        put_u8(k, sc->band_names[b] != NULL);
        if (sc->band_names[b])
            put_str(k, sc->band_names[b]);
    }
    put_u32(k, sc->material_count);
    for (uint32_t i = 0; i < sc->material_count; i++) {
        const rad_material *m = &sc->materials[i];
        put_str(k, m->name);
        for (uint32_t b = 0; b < nb; b++)
            put_f64(k, m->rho[b]);
        for (uint32_t b = 0; b < nb; b++)
            put_f64(k, m->emission[b]);
        for (uint32_t b = 0; b < nb; b++)
            put_f64(k, m->transmit[b]);
    }
    put_u32(k, sc->object_count);
    for (uint32_t i = 0; i < sc->object_count; i++)
        put_str(k, sc->objects[i].name);
    put_u32(k, sc->polygon_count);
    for (uint32_t i = 0; i < sc->polygon_count; i++) {
        const rad_polygon *p = &sc->polygons[i];
        put_str(k, p->name);
        put_u32(k, p->material);
        put_u32(k, p->object);
        put_u32(k, p->subdiv_u);
        put_u32(k, p->subdiv_v);
        put_u32(k, p->point_count);
        for (uint32_t j = 0; j < p->point_count; j++)
            put_vec3(k, sc->points[p->first_point + j]);
    }
    put_u32(k, sc->camera_count);
    for (uint32_t i = 0; i < sc->camera_count; i++) {
        const rad_camera *c = &sc->cameras[i];
        put_str(k, c->name);
        put_vec3(k, c->eye);
        put_vec3(k, c->target);
        put_vec3(k, c->up);
        put_f64(k, c->yfov_deg);
        put_f64(k, c->aspect);
    }
}

static void emit_mesh(sink *k, const rad_solution *s)
{
    const rad_mesh *m = s->mesh;
    put_u32(k, m->vertex_count);
    put_u32(k, m->patch_count);
    for (uint32_t i = 0; i < m->vertex_count; i++)
        put_vec3(k, m->vertices[i]);
    for (uint32_t i = 0; i < m->vertex_count; i++)
        put_u8(k, m->vertex_boundary[i]);
    for (uint32_t i = 0; i < m->patch_count; i++) {
        const rad_patch *p = &m->patches[i];
        for (int c = 0; c < 4; c++)
            put_u32(k, p->v[c]);
        put_u32(k, p->polygon);
        put_u32(k, p->object);
        put_u32(k, p->material);
        put_vec3(k, p->center);
        put_vec3(k, p->normal);
        put_f64(k, p->area);
    }
}

/* A row's entries: the columns as a first value then gaps (>= 1), then the
 * values. */
static void put_row(sink *k, uint32_t cnt, const uint32_t *col, const float *val)
{
    for (uint32_t j = 0; j < cnt; j++)
        put_varint(k, j ? col[j] - col[j - 1] : col[0]);
    for (uint32_t j = 0; j < cnt; j++)
        put_f32(k, val[j]);
}

/* Row i: index, count, the columns as a first value then gaps (each >= 1,
 * as columns strictly increase), then the values: gaps between visible
 * patches are small, so most columns take one byte instead of four. */
static void emit_matrix(sink *k, const rad_solution *s)
{
    const rad_matrix *F = s->F;
    put_u32(k, F->n);
    put_u32(k, F->rows_done);
    for (uint32_t i = 0; i < F->n; i++) {
        if (!F->row_done[i])
            continue;
        uint32_t cnt = F->row_count[i];
        put_u32(k, i);
        put_u32(k, cnt);
        if (cnt == 0)
            continue; /* the pool may not exist yet: no pointer into it */
        put_row(k, cnt, F->col + F->row_start[i], F->val + F->row_start[i]);
    }
}

/* Elements: provenance, vertices, then per element its patch, level,
 * corners, B and row (rows encoded like the matrix's). */
static void emit_elements(sink *k, const rad_solution *s)
{
    const rad_elements *el = s->elements;
    const rad_mesh *m = el->mesh;
    uint32_t nb = s->band_count;
    put_f64(k, el->threshold);
    put_f64(k, el->min_size);
    put_u64(k, el->rows_computed);
    put_u32(k, m->vertex_count);
    put_u32(k, m->patch_count);
    put_u32(k, nb);
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        put_vec3(k, m->vertices[v]);
        put_u8(k, m->vertex_boundary[v]);
    }
    for (uint32_t e = 0; e < m->patch_count; e++) {
        put_u32(k, el->patch[e]);
        put_u8(k, el->level[e]);
        for (int c = 0; c < 4; c++)
            put_u32(k, m->patches[e].v[c]);
        for (uint32_t b = 0; b < nb; b++)
            put_f64(k, el->B[(size_t)e * nb + b]);
        put_u32(k, el->row_count[e]);
        if (el->row_count[e])
            put_row(k, el->row_count[e], el->col + el->row_start[e], el->val + el->row_start[e]);
    }
}

/* Each element's h_le, element by element, dense: M × L floats. */
static void emit_element_lights(sink *k, const rad_solution *s)
{
    const rad_elements *el = s->elements;
    const size_t count = (size_t)el->mesh->patch_count * el->light_count;
    put_u32(k, el->mesh->patch_count);
    put_u32(k, el->light_count);
    for (size_t q = 0; q < count; q++)
        put_f32(k, el->light_h[q]);
}

static void emit_patchdata(sink *k, const rad_solution *s)
{
    uint32_t n = s->mesh->patch_count, nb = s->band_count;
    size_t count = (size_t)n * nb;
    put_u32(k, n);
    put_u32(k, nb);
    for (size_t i = 0; i < count; i++)
        put_f64(k, s->rho[i]);
    for (size_t i = 0; i < count; i++)
        put_f64(k, s->emission[i]);
    for (size_t i = 0; i < count; i++)
        put_f64(k, s->B[i]);
}

/* The lights with the intensity solved with and each one's Φ_j, patch
 * indices as a first value then gaps like the matrix's columns. */
static void emit_lights(sink *k, const rad_solution *s)
{
    const rad_scene *sc = s->scene;
    uint32_t nb = s->band_count;
    put_u32(k, sc->light_count);
    put_u32(k, nb);
    put_u64(k, s->lights_computed);
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const rad_light *L = &sc->lights[l];
        const rad_light_power *lp = &s->light_power[l];
        put_str(k, L->name);
        put_u8(k, (uint8_t)L->kind);
        put_vec3(k, L->position);
        put_vec3(k, L->direction);
        put_f64(k, L->inner_cone);
        put_f64(k, L->outer_cone);
        for (uint32_t b = 0; b < nb; b++)
            put_f64(k, L->intensity[b]);
        for (uint32_t b = 0; b < nb; b++)
            put_f64(k, s->light_intensity[(size_t)l * nb + b]);
        put_u8(k, lp->present ? 1 : 0);
        uint32_t cnt = lp->present ? lp->count : 0;
        put_u32(k, cnt);
        for (uint32_t j = 0; j < cnt; j++)
            put_varint(k, j ? lp->patch[j] - lp->patch[j - 1] : lp->patch[0]);
        for (uint32_t j = 0; j < cnt; j++)
            put_f32(k, lp->power[j]);
    }
}

typedef void (*emit_fn)(sink *, const rad_solution *);
static const emit_fn sec_emit[SEC_COUNT] = {emit_info,      emit_scene,  emit_mesh,    emit_matrix,
                                            emit_patchdata, emit_lights, emit_elements,
                                            emit_element_lights};

/* LIGHTS is written only when there are lights, ELEMENTS when there are
 * elements, ELEMENTLIGHTS when the elements carry their own direct light. */
static int section_written(const rad_solution *s, int i)
{
    if (i == SEC_LIGHTS)
        return s->scene->light_count > 0;
    if (i == SEC_ELEMENTS)
        return s->elements != NULL;
    if (i == SEC_ELEMENT_LIGHTS)
        return s->elements && s->elements->light_h;
    return 1;
}

static uint32_t version_of(const rad_solution *s)
{
    if (s->mesh->twin)
        return SOL_VERSION_SHEETS;
    if (s->elements)
        return s->elements->light_h ? 4u : 3u;
    return s->scene->light_count ? 2u : 1u;
}

/* The light rules; `where` as for check_patch_values. */
static int check_lights(const rad_solution *s, const char *file, const char *where, int code,
                        rad_error *err)
{
    const rad_scene *sc = s->scene;
    uint32_t nb = s->band_count, n = s->mesh->patch_count;
    if (sc->light_count == 0)
        return RAD_OK;
    if (!s->light_intensity || !s->light_power || s->light_slots_ < sc->light_count)
        return rad_fail(err, code, "%s: %s: %u lights but no light data", file, where,
                        sc->light_count);
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const rad_light_power *lp = &s->light_power[l];
        for (uint32_t b = 0; b < nb; b++)
            if (bad_nonneg(s->light_intensity[(size_t)l * nb + b]))
                return rad_fail(err, code,
                                "%s: %s: light '%s' band %u: intensity %g is not finite and >= 0",
                                file, where, sc->lights[l].name, b,
                                s->light_intensity[(size_t)l * nb + b]);
        if (!lp->present)
            continue;
        if (lp->count > n || (lp->count && (!lp->patch || !lp->power)))
            return rad_fail(err, code, "%s: %s: light '%s': %u patches lit but the mesh has %u",
                            file, where, sc->lights[l].name, lp->count, n);
        for (uint32_t k = 0; k < lp->count; k++) {
            if (lp->patch[k] >= n || (k && lp->patch[k] <= lp->patch[k - 1]))
                return rad_fail(err, code,
                                "%s: %s: light '%s': patch %u out of range or out of order", file,
                                where, sc->lights[l].name, lp->patch[k]);
            if (!(lp->power[k] > 0.0f) || !isfinite(lp->power[k]))
                return rad_fail(err, code,
                                "%s: %s: light '%s': patch %u: power %g is not positive and finite",
                                file, where, sc->lights[l].name, lp->patch[k],
                                (double)lp->power[k]);
        }
    }
    return RAD_OK;
}

static int check_string(const char *str, const char *file, const char *what, uint32_t i,
                        rad_error *err)
{
    if (str && strlen(str) > SOL_MAX_STRING)
        return rad_fail(err, RAD_ERR_LIMIT, "%s: cannot write: %s %u: name of %zu bytes exceeds %u",
                        file, what, i, strlen(str), SOL_MAX_STRING);
    return RAD_OK;
}

/* Everything the reader will check, checked before a file is created. */
static int validate_for_write(const rad_solution *s, const char *path, rad_error *err)
{
    if (!s || !s->scene || !s->mesh || !s->F || !s->rho || !s->emission || !s->B)
        return rad_fail(err, RAD_ERR_USAGE, "%s: cannot write: incomplete solution", path);
    const rad_scene *sc = s->scene;
    const rad_mesh *m = s->mesh;
    if (sc->band_count < 1 || sc->band_count > RAD_MAX_BANDS || s->band_count != sc->band_count)
        return rad_fail(err, RAD_ERR_USAGE,
                        "%s: cannot write: %u bands in the solution, %u in the scene", path,
                        s->band_count, sc->band_count);
    if (s->F->n != m->patch_count)
        return rad_fail(err, RAD_ERR_USAGE,
                        "%s: cannot write: form-factor matrix is %u×%u but the mesh has %u patches",
                        path, s->F->n, s->F->n, m->patch_count);
    if (memchr(s->solver, '\0', sizeof s->solver) == NULL)
        return rad_fail(err, RAD_ERR_USAGE, "%s: cannot write: solver name is not terminated",
                        path);
    int rc = check_info(s, path, "cannot write", RAD_ERR_INVALID, err);
    if (rc)
        return rc;
    if ((rc = check_string(sc->source, path, "scene source", 0, err)))
        return rc;
    for (uint32_t b = 0; b < sc->band_count; b++)
        if ((rc = check_string(sc->band_names[b], path, "band", b, err)))
            return rc;
    for (uint32_t i = 0; i < sc->material_count; i++)
        if ((rc = check_string(sc->materials[i].name, path, "material", i, err)))
            return rc;
    for (uint32_t i = 0; i < sc->object_count; i++)
        if ((rc = check_string(sc->objects[i].name, path, "object", i, err)))
            return rc;
    for (uint32_t i = 0; i < sc->camera_count; i++)
        if ((rc = check_string(sc->cameras[i].name, path, "camera", i, err)))
            return rc;
    for (uint32_t i = 0; i < sc->light_count; i++)
        if ((rc = check_string(sc->lights[i].name, path, "light", i, err)))
            return rc;
    if ((rc = check_lights(s, path, "cannot write", RAD_ERR_INVALID, err)))
        return rc;
    for (uint32_t i = 0; i < sc->polygon_count; i++) {
        const rad_polygon *p = &sc->polygons[i];
        if ((rc = check_string(p->name, path, "polygon", i, err)))
            return rc;
        if ((uint64_t)p->first_point + p->point_count > sc->point_count ||
            p->material >= sc->material_count || p->object >= sc->object_count)
            return rad_fail(err, RAD_ERR_USAGE, "%s: cannot write: polygon %u: index out of range",
                            path, i);
    }
    rad_error sub;
    if (rad_mesh_check(m, sc->polygon_count, sc->object_count, sc->material_count, &sub))
        return rad_fail(err, RAD_ERR_INVALID, "%s: cannot write: mesh: %s", path, sub.message);
    /* Without a pool every present row is empty and there is nothing to
     * check (rad_matrix_check would form NULL + 0). */
    if (s->F->col && rad_matrix_check(s->F, &sub))
        return rad_fail(err, RAD_ERR_INVALID, "%s: cannot write: %s", path, sub.message);
    if (s->elements && rad_elements_check(s->elements, s, "elements", &sub))
        return rad_fail(err, RAD_ERR_INVALID, "%s: cannot write: %s", path, sub.message);
    return check_patch_values(s, path, "cannot write", RAD_ERR_INVALID, err);
}

static void store_le(uint8_t *p, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

int rad_solution_write(const rad_solution *s, const char *path, rad_error *err)
{
    if (!path || !*path)
        return rad_fail(err, RAD_ERR_USAGE, "rad_solution_write: no path");
    int rc = validate_for_write(s, path, err);
    if (rc)
        return rc;

    /* Measure each section first: its length precedes it in the stream. */
    uint64_t len[SEC_COUNT], payload = 0;
    for (int i = 0; i < SEC_COUNT; i++) {
        len[i] = 0;
        if (!section_written(s, i))
            continue;
        sink count = {0};
        sec_emit[i](&count, s);
        len[i] = count.total;
        payload += SOL_SECTION_HEADER + len[i];
    }
    if (payload > SOL_MAX_FILE - SOL_HEADER_BYTES)
        return rad_fail(err, RAD_ERR_LIMIT,
                        "%s: cannot write: %llu bytes exceeds the 64 GiB limit of the reader", path,
                        (unsigned long long)(payload + SOL_HEADER_BYTES));

    crc64_tables *tab = malloc(sizeof *tab);
    sink k = {.cap = 1u << 20};
    k.buf = malloc(k.cap);
    if (!tab || !k.buf) {
        free(tab);
        free(k.buf);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: cannot write: out of memory", path);
    }
    rc = rad_output_open(path, &k.out, err);
    if (rc) {
        free(tab);
        free(k.buf);
        return rc;
    }
    crc64_init(tab);
    k.tab = tab;
    k.crc = ~0ull;

    uint8_t head[SOL_HEADER_BYTES] = {0};
    memcpy(head, SOL_MAGIC, 8);
    store_le(head + 8, version_of(s), 4);
    store_le(head + 12, 0, 4);
    store_le(head + 16, payload, 8);
    /* bytes 24..31, the checksum, are written once the payload is through */
    rad_output_write(k.out, head, sizeof head);
    for (int i = 0; i < SEC_COUNT; i++) {
        if (!section_written(s, i))
            continue;
        put(&k, sec_tag[i], 4);
        put_u64(&k, len[i]);
        uint64_t before = k.total;
        sec_emit[i](&k, s);
        RAD_ASSERT(k.total - before == len[i]);
        (void)before;
    }
    sink_flush(&k);
    RAD_ASSERT(k.failed || k.total == payload);
    store_le(head + 24, k.crc ^ ~0ull, 8);
    rad_output_write_at(k.out, head + 24, 8, 24);
    rc = rad_output_commit(k.out, err); /* reports any write's failure */
    free(tab);
    free(k.buf);
    return rc;
}

/* ------------------------------------------------------------------ reader */

/* A bounds-checked cursor: every get returns 0 instead of reading past the
 * end, and nothing advances on failure. */
typedef struct cursor {
    const uint8_t *p;
    size_t left;
} cursor;

static int get_bytes(cursor *c, void *out, size_t n)
{
    if (n > c->left)
        return 0;
    if (n)
        memcpy(out, c->p, n);
    c->p += n;
    c->left -= n;
    return 1;
}

static int get_u8(cursor *c, uint8_t *v) { return get_bytes(c, v, 1); }

static int get_u32(cursor *c, uint32_t *v)
{
    if (c->left < 4)
        return 0;
    *v = (uint32_t)c->p[0] | (uint32_t)c->p[1] << 8 | (uint32_t)c->p[2] << 16 |
         (uint32_t)c->p[3] << 24;
    c->p += 4;
    c->left -= 4;
    return 1;
}

static int get_u64(cursor *c, uint64_t *v)
{
    if (c->left < 8)
        return 0;
    *v = load_le64(c->p);
    c->p += 8;
    c->left -= 8;
    return 1;
}

static int get_f64(cursor *c, double *v)
{
    uint64_t bits;
    if (!get_u64(c, &bits))
        return 0;
    memcpy(v, &bits, sizeof *v);
    return 1;
}

static int get_f32(cursor *c, float *v)
{
    uint32_t bits;
    if (!get_u32(c, &bits))
        return 0;
    memcpy(v, &bits, sizeof *v);
    return 1;
}

static int get_vec3(cursor *c, rad_vec3 *v)
{
    return get_f64(c, &v->x) && get_f64(c, &v->y) && get_f64(c, &v->z);
}

/* LEB128 of a u32: at most 5 bytes, no bits above 32, no padding bytes
 * (one value, one encoding).  0 when truncated or malformed. */
static int get_varint(cursor *c, uint32_t *v)
{
    uint64_t r = 0;
    for (size_t k = 0; k < 5 && k < c->left; k++) {
        uint8_t b = c->p[k];
        r |= (uint64_t)(b & 0x7f) << (7 * k);
        if (!(b & 0x80)) {
            if ((k > 0 && b == 0) || r > UINT32_MAX)
                return 0;
            *v = (uint32_t)r;
            c->p += k + 1;
            c->left -= k + 1;
            return 1;
        }
    }
    return 0;
}

typedef struct reader {
    const char *name;    /* for messages */
    const char *section; /* for messages */
    uint32_t version;    /* of the file */
    uint8_t announced;   /* version 5: the optional sections INFO announces */
    rad_error *err;
    cursor c;
    char str[SOL_MAX_STRING + 1];
} reader;

/* Version 5: does INFO announce optional section k (LIGHTS and after)? */
static int announced(const reader *r, int k)
{
    return (r->announced >> (k - SEC_LIGHTS)) & 1u;
}

/* "NAME: section SECTION: WHAT" */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static int rfail(reader *r, int code, const char *fmt, ...)
{
    char what[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return rad_fail(r->err, code, "%s: section %s: %s", r->name, r->section, what);
}

/* A string into r->str: u32 length <= 4096, then bytes without NUL.
 * Returns RAD_OK or fails naming `what`. */
static int get_str(reader *r, const char *what, uint32_t i)
{
    uint32_t n;
    if (!get_u32(&r->c, &n))
        return rfail(r, RAD_ERR_CORRUPT, "%s %u: truncated", what, i);
    if (n > SOL_MAX_STRING)
        return rfail(r, RAD_ERR_CORRUPT, "%s %u: string length %u exceeds %u", what, i, n,
                     SOL_MAX_STRING);
    if (!get_bytes(&r->c, r->str, n))
        return rfail(r, RAD_ERR_CORRUPT, "%s %u: truncated", what, i);
    if (memchr(r->str, '\0', n))
        return rfail(r, RAD_ERR_CORRUPT, "%s %u: name contains a NUL byte", what, i);
    r->str[n] = '\0';
    return RAD_OK;
}

/* count elements of at least `min_bytes` each must fit in what is left. */
static int check_count(reader *r, uint64_t count, uint64_t min_bytes, const char *what)
{
    if (count > r->c.left / min_bytes)
        return rfail(r, RAD_ERR_CORRUPT, "%llu %s cannot fit in the %zu bytes left",
                     (unsigned long long)count, what, r->c.left);
    return RAD_OK;
}

#define TRUNC(...) rfail(r, RAD_ERR_CORRUPT, __VA_ARGS__)

static int parse_info(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    uint32_t stages;
    if (!get_f64(c, &s->patch_size) || !get_u32(c, &s->resolution))
        return TRUNC("truncated");
    int rc = get_str(r, "solver", 0);
    if (rc)
        return rc;
    if (strlen(r->str) > SOL_SOLVER_MAX)
        return TRUNC("solver name '%.40s' is longer than %zu bytes", r->str, SOL_SOLVER_MAX);
    memcpy(s->solver, r->str, strlen(r->str) + 1);
    if (!get_f64(c, &s->tolerance) || !get_u32(c, &s->iterations) || !get_f64(c, &s->residual) ||
        !get_u64(c, &s->rows_computed) || !get_u32(c, &stages))
        return TRUNC("truncated");
    if (stages > SOL_MAX_STAGES)
        return TRUNC("%u stages (at most %u)", stages, SOL_MAX_STAGES);
    for (uint32_t i = 0; i < stages; i++) {
        double sec;
        uint8_t reused;
        if (!get_f64(c, &sec) || !get_u8(c, &reused))
            return TRUNC("stage %u: truncated", i);
        if (i < RAD_STAGE_COUNT) {
            s->stages[i].seconds = sec;
            s->stages[i].reused = reused;
        } else if (bad_nonneg(sec) || reused > 1) {
            return TRUNC("stage %u: bad values", i);
        }
    }
    if (r->version >= SOL_VERSION_SHEETS) {
        if (!get_u8(c, &r->announced))
            return TRUNC("truncated");
        if (r->announced > 7)
            return TRUNC("announced sections 0x%x: only bits 0-2 exist", r->announced);
    }
    return check_info(s, r->name, "section INFO", RAD_ERR_CORRUPT, r->err);
}

/* scene.c reports failures as "SOURCE: WHERE: WHAT" with SOURCE = the
 * solution file's name while reading (see parse_scene); a bad value in a
 * checksummed file means corruption, whatever kind of rule it broke. */
static int scene_rc(reader *r, int rc)
{
    if (rc != RAD_ERR_NOMEM)
        rc = RAD_ERR_CORRUPT;
    if (r->err)
        r->err->code = rc;
    return rc;
}

static int parse_scene(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    /* scene.c names the element itself ("material 'red': ..."). */
    const char *where = "section SCENE";
    int rc = get_str(r, "source", 0);
    if (rc)
        return rc;
    char *source = strdup(r->str);
    if (!source)
        return rfail(r, RAD_ERR_NOMEM, "out of memory");
    rad_vec3 *pts = NULL;
    uint32_t pts_cap = 0;

    uint32_t nb, count;
    if (!get_u32(c, &nb)) {
        rc = TRUNC("truncated");
        goto done;
    }
    if (nb < 1 || nb > RAD_MAX_BANDS) {
        rc = TRUNC("%u bands (1..%d allowed)", nb, RAD_MAX_BANDS);
        goto done;
    }
    /* Built under the solution file's name so that scene.c's messages name
     * the file being read; the stored source is put back at the end. */
    rad_scene *sc = s->scene = rad_scene_create(nb, r->name);
    if (!sc) {
        rc = rfail(r, RAD_ERR_NOMEM, "out of memory");
        goto done;
    }
    s->band_count = nb;
    for (uint32_t b = 0; b < nb; b++) {
        uint8_t has;
        if (!get_u8(c, &has)) {
            rc = TRUNC("band %u: truncated", b);
            goto done;
        }
        if (has > 1) {
            rc = TRUNC("band %u: name flag %u is not 0 or 1", b, has);
            goto done;
        }
        if (has) {
            if ((rc = get_str(r, "band", b)))
                goto done;
            if (!(sc->band_names[b] = strdup(r->str))) {
                rc = rfail(r, RAD_ERR_NOMEM, "out of memory");
                goto done;
            }
        }
    }

    if (!get_u32(c, &count)) {
        rc = TRUNC("material count: truncated");
        goto done;
    }
    if ((rc = check_count(r, count, MIN_STRING + 24ull * nb, "materials")))
        goto done;
    for (uint32_t i = 0; i < count; i++) {
        double rho[RAD_MAX_BANDS], e[RAD_MAX_BANDS], t[RAD_MAX_BANDS];
        if ((rc = get_str(r, "material", i)))
            goto done;
        int ok = 1;
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && get_f64(c, &rho[b]);
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && get_f64(c, &e[b]);
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && get_f64(c, &t[b]);
        if (!ok) {
            rc = TRUNC("material %u: truncated", i);
            goto done;
        }
        if ((rc = rad_scene_add_material(sc, r->str, rho, e, t, where, NULL, r->err))) {
            rc = scene_rc(r, rc);
            goto done;
        }
    }

    if (!get_u32(c, &count)) {
        rc = TRUNC("object count: truncated");
        goto done;
    }
    if ((rc = check_count(r, count, MIN_STRING, "objects")))
        goto done;
    for (uint32_t i = 0; i < count; i++) {
        if ((rc = get_str(r, "object", i)))
            goto done;
        if ((rc = rad_scene_add_object(sc, r->str, where, NULL, r->err))) {
            rc = scene_rc(r, rc);
            goto done;
        }
    }

    if (!get_u32(c, &count)) {
        rc = TRUNC("polygon count: truncated");
        goto done;
    }
    if ((rc = check_count(r, count, MIN_POLYGON, "polygons")))
        goto done;
    for (uint32_t i = 0; i < count; i++) {
        uint32_t mat, obj, su, sv, np;
        if ((rc = get_str(r, "polygon", i)))
            goto done;
        if (!get_u32(c, &mat) || !get_u32(c, &obj) || !get_u32(c, &su) || !get_u32(c, &sv) ||
            !get_u32(c, &np)) {
            rc = TRUNC("polygon %u: truncated", i);
            goto done;
        }
        if (mat >= sc->material_count || obj >= sc->object_count) {
            rc = TRUNC("polygon %u: material %u or object %u out of range "
                       "(%u materials, %u objects)",
                       i, mat, obj, sc->material_count, sc->object_count);
            goto done;
        }
        if (np < 3) {
            rc = TRUNC("polygon %u: %u points (at least 3)", i, np);
            goto done;
        }
        if ((rc = check_count(r, np, 24, "points")))
            goto done;
        if (np > pts_cap) {
            rad_vec3 *grown = realloc(pts, (size_t)np * sizeof *grown);
            if (!grown) {
                rc = rfail(r, RAD_ERR_NOMEM, "polygon %u: out of memory for %u points", i, np);
                goto done;
            }
            pts = grown;
            pts_cap = np;
        }
        for (uint32_t j = 0; j < np; j++)
            get_vec3(c, &pts[j]); /* cannot fail: check_count above */
        if ((rc = rad_scene_add_polygon(sc, r->str, obj, mat, pts, np, su, sv, where, NULL,
                                        r->err))) {
            rc = scene_rc(r, rc);
            goto done;
        }
    }

    if (!get_u32(c, &count)) {
        rc = TRUNC("camera count: truncated");
        goto done;
    }
    if ((rc = check_count(r, count, MIN_CAMERA, "cameras")))
        goto done;
    for (uint32_t i = 0; i < count; i++) {
        rad_vec3 eye, target, up;
        double fov, aspect;
        if ((rc = get_str(r, "camera", i)))
            goto done;
        if (!get_vec3(c, &eye) || !get_vec3(c, &target) || !get_vec3(c, &up) ||
            !get_f64(c, &fov) || !get_f64(c, &aspect)) {
            rc = TRUNC("camera %u: truncated", i);
            goto done;
        }
        if ((rc = rad_scene_add_camera(sc, r->str, eye, target, up, fov, aspect, where, NULL,
                                       r->err))) {
            rc = scene_rc(r, rc);
            goto done;
        }
    }
    free(sc->source);
    sc->source = source;
    source = NULL;
done:
    free(source);
    free(pts);
    return rc;
}

static int parse_mesh(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    const rad_scene *sc = s->scene;
    uint32_t nv, np;
    if (!get_u32(c, &nv) || !get_u32(c, &np))
        return TRUNC("truncated");
    if ((uint64_t)nv * VERTEX_BYTES + (uint64_t)np * PATCH_BYTES > r->c.left)
        return TRUNC("%u vertices and %u patches cannot fit in the %zu bytes left", nv, np,
                     r->c.left);
    rad_mesh *m = s->mesh = rad_mesh_alloc(nv, np);
    if (!m)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for %u vertices and %u patches", nv, np);
    /* The sizes were checked above, so the reads below cannot run short. */
    for (uint32_t i = 0; i < nv; i++)
        get_vec3(c, &m->vertices[i]);
    for (uint32_t i = 0; i < nv; i++) {
        get_u8(c, &m->vertex_boundary[i]);
        if (m->vertex_boundary[i] > 1)
            return TRUNC("vertex %u: boundary flag %u is not 0 or 1", i, m->vertex_boundary[i]);
    }
    for (uint32_t i = 0; i < np; i++) {
        rad_patch *p = &m->patches[i];
        for (int k = 0; k < 4; k++)
            get_u32(c, &p->v[k]);
        get_u32(c, &p->polygon);
        get_u32(c, &p->object);
        get_u32(c, &p->material);
        get_vec3(c, &p->center);
        get_vec3(c, &p->normal);
        get_f64(c, &p->area);
        for (int k = 0; k < 4; k++)
            if (p->v[k] >= nv && !(k == 3 && p->v[k] == RAD_NONE))
                return TRUNC("patch %u: vertex %u out of range (%u vertices)", i, p->v[k], nv);
        if (p->polygon >= sc->polygon_count)
            return TRUNC("patch %u: polygon %u out of range (%u polygons)", i, p->polygon,
                         sc->polygon_count);
        if (p->object >= sc->object_count)
            return TRUNC("patch %u: object %u out of range (%u objects)", i, p->object,
                         sc->object_count);
        if (p->material >= sc->material_count)
            return TRUNC("patch %u: material %u out of range (%u materials)", i, p->material,
                         sc->material_count);
    }
    rad_error sub;
    if (rad_mesh_check(m, sc->polygon_count, sc->object_count, sc->material_count, &sub))
        return rfail(r, RAD_ERR_CORRUPT, "%s",
                     strncmp(sub.message, "mesh: ", 6) == 0 ? sub.message + 6 : sub.message);
    /* The two sides of transmitting polygons are paired by their layout,
     * not stored.  Before version 5 transmittance was stored but not
     * simulated: such a mesh is one-sided (rad_resolve refuses to solve
     * it again rather than drop the transmitted light). */
    if (r->version < SOL_VERSION_SHEETS)
        return RAD_OK;
    int rc = rad_mesh_link_twins(m, sc, &sub);
    if (rc != RAD_OK) {
        const char *msg = strstr(sub.message, "mesh: ");
        return rfail(r, rc, "%s", msg ? msg + 6 : sub.message);
    }
    return RAD_OK;
}

/* Sizes F's entry pool to the exact total before the rows are stored: the
 * pool would otherwise grow by 1.5× steps, copying as it goes and ending up
 * to half again larger than needed, which for a matrix of gigabytes matters.
 * A quick scan over a copy of the cursor; on anything odd it does nothing
 * and parse_matrix's checked pass reports the fault. */
static void presize_matrix(rad_matrix *F, cursor c, uint32_t rows)
{
    uint64_t total = 0;
    for (uint32_t k = 0; k < rows; k++) {
        uint32_t i, cnt;
        if (!get_u32(&c, &i) || !get_u32(&c, &cnt))
            return;
        for (uint32_t e = 0; e < cnt; e++) {
            uint32_t d;
            if (!get_varint(&c, &d))
                return;
        }
        if ((uint64_t)cnt * 4 > c.left)
            return;
        c.p += (size_t)cnt * 4;
        c.left -= (size_t)cnt * 4;
        total += cnt; /* <= bytes consumed / 5: bounded by the file */
    }
    if (total == 0 || total > SIZE_MAX / sizeof(uint32_t))
        return;
    uint32_t *col = malloc((size_t)total * sizeof *col);
    float *val = malloc((size_t)total * sizeof *val);
    if (!col || !val) {
        free(col);
        free(val);
        return; /* rad_matrix_set_row will report the shortage */
    }
    free(F->col);
    free(F->val);
    F->col = col;
    F->val = val;
    F->capacity = total;
}

/* A row's cnt entries (see put_row) into col/val, checked: columns
 * strictly increasing below n and never `self`, values positive and
 * finite, sum <= 1 + 1e-3.  `what` and `i` name the row in messages. */
static int get_row(reader *r, const char *what, uint32_t i, uint32_t cnt, uint32_t n, uint32_t self,
                   uint32_t *col, float *val)
{
    cursor *c = &r->c;
    uint64_t j = 0;
    for (uint32_t e = 0; e < cnt; e++) {
        uint32_t d;
        if (!get_varint(c, &d))
            return TRUNC("%s %u: entry %u: truncated or malformed column", what, i, e);
        if (e > 0 && d == 0)
            return TRUNC("%s %u: column %llu repeated", what, i, (unsigned long long)j);
        j = e ? j + d : d;
        if (j >= n)
            return TRUNC("%s %u: column %llu out of range (n = %u)", what, i, (unsigned long long)j, n);
        if (j == self)
            return TRUNC("%s %u: entry on its own patch (F of a planar patch to itself is 0)", what, i);
        col[e] = (uint32_t)j;
    }
    double sum = 0.0;
    for (uint32_t e = 0; e < cnt; e++) {
        if (!get_f32(c, &val[e]))
            return TRUNC("%s %u: values truncated", what, i);
        if (!(val[e] > 0.0f) || !isfinite(val[e]))
            return TRUNC("%s %u: F_%u,%u = %g is not positive and finite", what, i, i, col[e],
                         (double)val[e]);
        sum += val[e];
    }
    if (sum > SOL_ROW_SUM_MAX)
        return TRUNC("%s %u: Σ_j F_ij = %.6f exceeds 1", what, i, sum);
    return RAD_OK;
}

static int parse_matrix(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    uint32_t n, rows;
    if (!get_u32(c, &n) || !get_u32(c, &rows))
        return TRUNC("truncated");
    if (n != s->mesh->patch_count)
        return TRUNC("n = %u but the mesh has %u patches", n, s->mesh->patch_count);
    if (rows > n)
        return TRUNC("%u rows present but n = %u", rows, n);
    int rc = check_count(r, rows, MIN_ROW, "rows");
    if (rc)
        return rc;
    rad_matrix *F = s->F = rad_matrix_create(n);
    if (!F)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for n = %u", n);
    presize_matrix(F, r->c, rows);
    uint32_t *col = NULL;
    float *val = NULL;
    uint32_t cap = 0;
    int64_t prev = -1;
    for (uint32_t k = 0; k < rows; k++) {
        uint32_t i, cnt;
        if (!get_u32(c, &i) || !get_u32(c, &cnt)) {
            rc = TRUNC("row %u of %u: truncated", k, rows);
            goto done;
        }
        if (i >= n || (int64_t)i <= prev) {
            rc = TRUNC("row %u: index out of range or out of order (n = %u, previous row %lld)", i,
                       n, (long long)prev);
            goto done;
        }
        prev = i;
        if (cnt > n - 1) {
            rc = TRUNC("row %u: %u entries but n = %u", i, cnt, n);
            goto done;
        }
        if ((rc = check_count(r, cnt, MIN_ENTRY, "form factors")))
            goto done;
        if (cnt > cap) {
            uint32_t *nc = realloc(col, (size_t)cnt * sizeof *nc);
            if (nc)
                col = nc;
            float *nv = nc ? realloc(val, (size_t)cnt * sizeof *nv) : NULL;
            if (nv)
                val = nv;
            if (!nc || !nv) {
                rc = rfail(r, RAD_ERR_NOMEM, "row %u: out of memory for %u entries", i, cnt);
                goto done;
            }
            cap = cnt;
        }
        if ((rc = get_row(r, "row", i, cnt, n, i, col, val)))
            goto done;
        rad_error sub;
        if ((rc = rad_matrix_set_row(F, i, cnt, col, val, &sub))) {
            rc = rfail(r, rc, "row %u: %s", i, sub.message);
            goto done;
        }
    }
    /* A second opinion on the rows just checked one by one; skipped when
     * no row has entries (no pool: rad_matrix_check would form NULL + 0). */
    rad_error sub;
    if (F->col && rad_matrix_check(F, &sub))
        rc = rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
done:
    free(col);
    free(val);
    return rc;
}

static int parse_patchdata(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    uint32_t n, nb;
    if (!get_u32(c, &n) || !get_u32(c, &nb))
        return TRUNC("truncated");
    if (n != s->mesh->patch_count || nb != s->band_count)
        return TRUNC("%u patches × %u bands but the mesh has %u patches and the scene %u bands", n,
                     nb, s->mesh->patch_count, s->band_count);
    uint64_t count = (uint64_t)n * nb;
    if (count * 3 * 8 > r->c.left)
        return TRUNC("%u patches × %u bands cannot fit in the %zu bytes left", n, nb, r->c.left);
    s->rho = alloc_band_array(n, nb);
    s->emission = alloc_band_array(n, nb);
    s->B = alloc_band_array(n, nb);
    if (!s->rho || !s->emission || !s->B)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for %u patches × %u bands", n, nb);
    for (uint64_t i = 0; i < count; i++)
        get_f64(c, &s->rho[i]);
    for (uint64_t i = 0; i < count; i++)
        get_f64(c, &s->emission[i]);
    for (uint64_t i = 0; i < count; i++)
        get_f64(c, &s->B[i]);
    return check_patch_values(s, r->name, "section PATCHDATA", RAD_ERR_CORRUPT, r->err);
}

static int parse_lights(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    rad_scene *sc = s->scene;
    uint32_t nl, nb, n = s->mesh->patch_count;
    if (!get_u32(c, &nl) || !get_u32(c, &nb) || !get_u64(c, &s->lights_computed))
        return TRUNC("truncated");
    if (nb != s->band_count)
        return TRUNC("%u bands but the scene has %u", nb, s->band_count);
    if (nl == 0)
        return TRUNC("no lights (the section is written only when there are some)");
    int rc = check_count(r, nl, MIN_LIGHT + 16ull * nb, "lights");
    if (rc)
        return rc;
    if (alloc_lights(s, nl) != 0)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for %u lights", nl);
    /* scene.c names the file being read, as in parse_scene */
    char *stored_source = sc->source;
    sc->source = (char *)r->name;
    for (uint32_t l = 0; l < nl && !rc; l++) {
        uint8_t kind = 0, present = 0;
        rad_vec3 pos, dir;
        double inner, outer, I[RAD_MAX_BANDS];
        uint32_t cnt;
        if ((rc = get_str(r, "light", l)))
            break;
        int ok = get_u8(c, &kind) && get_vec3(c, &pos) && get_vec3(c, &dir) &&
                 get_f64(c, &inner) && get_f64(c, &outer);
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && get_f64(c, &I[b]);
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && get_f64(c, &s->light_intensity[(size_t)l * nb + b]);
        ok = ok && get_u8(c, &present) && get_u32(c, &cnt);
        if (!ok) {
            rc = TRUNC("light %u: truncated", l);
            break;
        }
        if (kind > RAD_LIGHT_DIRECTIONAL) {
            rc = TRUNC("light '%s': kind %u is not 0, 1 or 2", r->str, kind);
            break;
        }
        if ((rc = rad_scene_add_light(sc, r->str, (rad_light_kind)kind, I, pos, dir, inner, outer,
                                      "section LIGHTS", NULL, r->err))) {
            rc = scene_rc(r, rc);
            break;
        }
        if (present > 1 || (!present && cnt)) {
            rc = TRUNC("light '%s': present flag %u with %u patches", r->str, present, cnt);
            break;
        }
        if (cnt > n) {
            rc = TRUNC("light '%s': %u patches lit but the mesh has %u", r->str, cnt, n);
            break;
        }
        if ((rc = check_count(r, cnt, MIN_ENTRY, "lit patches")))
            break;
        rad_light_power *lp = &s->light_power[l];
        lp->present = present;
        lp->patch = malloc((cnt ? cnt : 1) * sizeof *lp->patch);
        lp->power = malloc((cnt ? cnt : 1) * sizeof *lp->power);
        if (!lp->patch || !lp->power) {
            rc = rfail(r, RAD_ERR_NOMEM, "light '%s': out of memory", r->str);
            break;
        }
        uint64_t j = 0;
        for (uint32_t e = 0; e < cnt && !rc; e++) {
            uint32_t d;
            if (!get_varint(c, &d))
                rc = TRUNC("light '%s': entry %u: truncated or malformed patch index", r->str, e);
            else if (e > 0 && d == 0)
                rc = TRUNC("light '%s': patch %llu repeated", r->str, (unsigned long long)j);
            else if ((j = e ? j + d : d) >= n)
                rc = TRUNC("light '%s': patch %llu out of range (%u patches)", r->str,
                           (unsigned long long)j, n);
            else
                lp->patch[e] = (uint32_t)j;
        }
        for (uint32_t e = 0; e < cnt && !rc; e++) {
            if (!get_f32(c, &lp->power[e]))
                rc = TRUNC("light '%s': values truncated", r->str);
            else if (!(lp->power[e] > 0.0f) || !isfinite(lp->power[e]))
                rc = TRUNC("light '%s': patch %u: power %g is not positive and finite", r->str,
                           lp->patch[e], (double)lp->power[e]);
        }
        lp->count = rc ? 0 : cnt;
    }
    sc->source = stored_source;
    if (rc)
        return rc;
    return check_lights(s, r->name, "section LIGHTS", RAD_ERR_CORRUPT, r->err);
}

/* ELEMENTS: every count is bounded by the bytes left before allocating;
 * rad_elements_complete then derives each cell from its patch and checks
 * the whole (solution.h). */
static int parse_elements(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    double threshold, min_size;
    uint64_t computed;
    uint32_t nv, ne, nb;
    if (!get_f64(c, &threshold) || !get_f64(c, &min_size) || !get_u64(c, &computed) ||
        !get_u32(c, &nv) || !get_u32(c, &ne) || !get_u32(c, &nb))
        return TRUNC("truncated");
    if (nb != s->band_count)
        return TRUNC("%u bands but the solution has %u", nb, s->band_count);
    int rc;
    /* The vertices and the elements' fixed parts must fit what is left;
     * the row entries get the rest, at MIN_ENTRY each. */
    uint64_t fixed = (uint64_t)nv * ELEMENT_VERTEX_BYTES + (uint64_t)ne * (MIN_ELEMENT + 8u * nb);
    if (fixed > c->left)
        return TRUNC("%u vertices and %u elements need %llu bytes, %zu left", nv, ne,
                     (unsigned long long)fixed, c->left);
    uint64_t max_entries = c->left > fixed ? (c->left - fixed) / MIN_ENTRY : 0;
    rad_elements *el = s->elements = rad_elements_alloc(nv, ne, nb, max_entries);
    if (!el)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for %u elements", ne);
    el->threshold = threshold;
    el->min_size = min_size;
    el->rows_computed = computed;
    rad_mesh *m = el->mesh;
    for (uint32_t v = 0; v < nv; v++)
        if (!get_vec3(c, &m->vertices[v]) || !get_u8(c, &m->vertex_boundary[v]))
            return TRUNC("vertex %u: truncated", v);
    for (uint32_t e = 0; e < ne; e++) {
        uint32_t cnt;
        if (!get_u32(c, &el->patch[e]) || !get_u8(c, &el->level[e]))
            return TRUNC("element %u: truncated", e);
        for (int k = 0; k < 4; k++)
            if (!get_u32(c, &m->patches[e].v[k]))
                return TRUNC("element %u: truncated", e);
        for (uint32_t b = 0; b < nb; b++)
            if (!get_f64(c, &el->B[(size_t)e * nb + b]))
                return TRUNC("element %u: truncated", e);
        if (!get_u32(c, &cnt))
            return TRUNC("element %u: truncated", e);
        if (el->patch[e] >= s->mesh->patch_count)
            return TRUNC("element %u: patch %u out of range (%u patches)", e, el->patch[e],
                          s->mesh->patch_count);
        if (cnt > max_entries - el->nnz)
            return TRUNC("element %u: %u entries: more than the section holds", e, cnt);
        el->row_start[e] = el->nnz;
        el->row_count[e] = cnt;
        if ((rc = get_row(r, "element", e, cnt, s->mesh->patch_count, el->patch[e],
                          el->col + el->nnz, el->val + el->nnz)))
            return rc;
        el->nnz += cnt;
    }
    rad_error sub;
    if (rad_elements_complete(el, s, "elements", &sub))
        return rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

/* ELEMENTLIGHTS: the counts must be the elements' and the lights', and the
 * values exactly fill the body, before anything is allocated; then
 * rad_elements_check applies the rules (finite, >= 0, 0 at level 0). */
static int parse_element_lights(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    rad_elements *el = s->elements;
    uint32_t ne, nl;
    if (!get_u32(c, &ne) || !get_u32(c, &nl))
        return TRUNC("truncated");
    if (ne != el->mesh->patch_count || nl != s->scene->light_count || nl == 0)
        return TRUNC("%u elements and %u lights, but the solution has %u and %u", ne, nl,
                     el->mesh->patch_count, s->scene->light_count);
    uint64_t count = (uint64_t)ne * nl;
    if (count != c->left / 4u || c->left % 4u)
        return TRUNC("%llu values need %llu bytes, %zu left", (unsigned long long)count,
                     (unsigned long long)count * 4u, c->left);
    el->light_h = malloc((size_t)(count ? count : 1) * sizeof *el->light_h);
    if (!el->light_h)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for %u elements × %u lights", ne, nl);
    el->light_count = nl;
    for (uint64_t q = 0; q < count; q++)
        if (!get_f32(c, &el->light_h[q]))
            return TRUNC("truncated");
    rad_error sub;
    if (rad_elements_check(el, s, "elements", &sub))
        return rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

typedef int (*parse_fn)(reader *, rad_solution *);
static const parse_fn sec_parse[SEC_COUNT] = {parse_info,      parse_scene,  parse_mesh,
                                              parse_matrix,    parse_patchdata, parse_lights,
                                              parse_elements,  parse_element_lights};

static int known_section(const uint8_t tag[4])
{
    for (int i = 0; i < SEC_COUNT; i++)
        if (memcmp(tag, sec_tag[i], 4) == 0)
            return i;
    return -1;
}

/* The header: magic, version, reserved, payload size, checksum. */
static int check_header(const uint8_t *d, size_t size, const char *name, int check_sum,
                        uint32_t *version_out, rad_error *err)
{
    size_t m = size < 8 ? size : 8;
    if (memcmp(d, SOL_MAGIC, m) != 0 || size == 0)
        return rad_fail(err, RAD_ERR_PARSE, "%s: not a radiosity solution file", name);
    if (size < SOL_HEADER_BYTES)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated: %zu of at least %u bytes", name, size,
                        SOL_HEADER_BYTES);
    uint32_t version = (uint32_t)load_le64(d + 8) & 0xffffffffu;
    uint32_t reserved = (uint32_t)(load_le64(d + 8) >> 32);
    uint64_t payload = load_le64(d + 16), sum = load_le64(d + 24);
    if (version > SOL_VERSION)
        return rad_fail(err, RAD_ERR_PARSE, "%s: format version %u is newer than this program (%u)",
                        name, version, SOL_VERSION);
    if (version == 0)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: format version 0 does not exist", name);
    if (reserved != 0)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: reserved header field is %u, not 0", name,
                        reserved);
    *version_out = version;
    uint64_t have = size - SOL_HEADER_BYTES;
    if (payload > have) {
        if (payload > UINT64_MAX - SOL_HEADER_BYTES)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated: %zu of %llu + %u bytes", name,
                            size, (unsigned long long)payload, SOL_HEADER_BYTES);
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated: %zu of %llu bytes", name, size,
                        (unsigned long long)(payload + SOL_HEADER_BYTES));
    }
    if (payload < have)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: %llu unexpected bytes after the payload", name,
                        (unsigned long long)(have - payload));
    if (check_sum) {
        uint64_t got;
        if (!crc64_of(d + SOL_HEADER_BYTES, (size_t)payload, &got))
            return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", name);
        if (got != sum)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: checksum mismatch: the file is corrupt",
                            name);
    }
    return RAD_OK;
}

int rad_solution_parse(const void *data, size_t size, const char *name, int check_sum,
                       rad_solution **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!name)
        name = "<memory>";
    if (!out || (!data && size))
        return rad_fail(err, RAD_ERR_USAGE, "%s: rad_solution_parse: bad arguments", name);
    static const uint8_t empty[1];
    const uint8_t *d = size ? data : empty;
    uint32_t version = 0;
    int rc = check_header(d, size, name, check_sum, &version, err);
    if (rc)
        return rc;
    /* Version 2 is exactly the files with lights: LIGHTS is required there
     * and has no place in version 1 (a cut at its start must not pass).
     * Version 3 is the files with elements: ELEMENTS is required, LIGHTS
     * there exactly when the scene has lights.  Version 4 is the files whose
     * elements carry their own direct light: LIGHTS, ELEMENTS and
     * ELEMENTLIGHTS are all required. */
    int required = version_sections[version];

    reader *r = malloc(sizeof *r);
    rad_solution *s = calloc(1, sizeof *s);
    if (!r || !s) {
        free(r);
        free(s);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", name);
    }
    r->name = name;
    r->err = err;
    r->version = version;
    cursor all = {d + SOL_HEADER_BYTES, size - SOL_HEADER_BYTES};
    int next = 0;
    while (all.left > 0) {
        size_t offset = size - all.left;
        uint8_t tag[4];
        uint64_t len;
        r->section = "header";
        if (!get_bytes(&all, tag, 4) || !get_u64(&all, &len)) {
            rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: byte %zu: section header truncated", name,
                          offset);
            goto fail;
        }
        int k = known_section(tag);
        if (len > all.left) {
            rc = rad_fail(err, RAD_ERR_CORRUPT,
                          "%s: byte %zu: section %s: length %llu exceeds the %zu bytes left", name,
                          offset, k >= 0 ? sec_name[k] : "(unknown)", (unsigned long long)len,
                          all.left);
            goto fail;
        }
        if (k >= required) {
            rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s in a version %u file",
                          name, offset, sec_name[k], version);
            goto fail;
        }
        if (k < 0) {
            /* A section from a later version of the format: skip it. */
            all.p += len;
            all.left -= (size_t)len;
            continue;
        }
        /* Version 3 without lights goes from PATCHDATA to ELEMENTS. */
        if (k == SEC_ELEMENTS && next == SEC_LIGHTS && version == 3 && s->scene &&
            s->scene->light_count == 0)
            next = SEC_ELEMENTS;
        /* Version 5 skips the optional sections INFO did not announce. */
        while (version >= SOL_VERSION_SHEETS && next >= SEC_LIGHTS && next < k &&
               !announced(r, next))
            next++;
        if (version >= SOL_VERSION_SHEETS && k >= SEC_LIGHTS && !announced(r, k)) {
            rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s not announced in INFO",
                          name, offset, sec_name[k]);
            goto fail;
        }
        if (k != next) {
            if (k < next)
                rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s appears twice", name,
                              offset, sec_name[k]);
            else
                rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s missing before %s",
                              name, offset, sec_name[next], sec_name[k]);
            goto fail;
        }
        r->section = sec_name[k];
        r->c.p = all.p;
        r->c.left = (size_t)len;
        if ((rc = sec_parse[k](r, s)))
            goto fail;
        if (r->c.left) {
            rc = rfail(r, RAD_ERR_CORRUPT, "%zu unexpected bytes at the end", r->c.left);
            goto fail;
        }
        all.p += len;
        all.left -= (size_t)len;
        next++;
    }
    while (version >= SOL_VERSION_SHEETS && next >= SEC_LIGHTS && next < SEC_COUNT &&
           !announced(r, next))
        next++;
    if (next < required) {
        rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: section %s missing", name, sec_name[next]);
        goto fail;
    }
    free(r);
    *out = s;
    return RAD_OK;
fail:
    free(r);
    rad_solution_destroy(s);
    return rc;
}

int rad_solution_read(const char *path, rad_solution **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!path || !out)
        return rad_fail(err, RAD_ERR_USAGE, "rad_solution_read: path and out are required");
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return rad_fail(err, RAD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) < 0) {
        int e = errno;
        close(fd);
        return rad_fail(err, RAD_ERR_IO, "%s: cannot stat: %s", path, strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        return rad_fail(err, RAD_ERR_IO, "%s: not a regular file", path);
    }
    uint64_t size = (uint64_t)st.st_size;
    uint64_t avail = rad_available_memory();
    if (size > SOL_MAX_FILE || size > SIZE_MAX) {
        close(fd);
        return rad_fail(err, RAD_ERR_LIMIT, "%s: %llu bytes exceeds the 64 GiB limit", path,
                        (unsigned long long)size);
    }
    if (avail && size > avail) {
        close(fd);
        return rad_fail(err, RAD_ERR_LIMIT,
                        "%s: %llu bytes is more than the %llu bytes of memory available", path,
                        (unsigned long long)size, (unsigned long long)avail);
    }
    uint8_t *buf = malloc(size ? (size_t)size : 1);
    if (!buf) {
        close(fd);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for %llu bytes", path,
                        (unsigned long long)size);
    }
    size_t got = 0;
    while (got < size) {
        size_t want = (size_t)size - got;
        if (want > (1u << 30))
            want = 1u << 30;
        ssize_t n = read(fd, buf + got, want);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            int e = errno;
            close(fd);
            free(buf);
            return rad_fail(err, RAD_ERR_IO, "%s: cannot read: %s", path, strerror(e));
        }
        if (n == 0)
            break; /* shrank while we read: the header check reports the truncation */
        got += (size_t)n;
    }
    close(fd);
    int rc = rad_solution_parse(buf, got, path, 1, out, err);
    free(buf);
    return rc;
}
