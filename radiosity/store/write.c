/* write.c - rad_solution_write: the solution file of
 * docs/solution-format.md (header, CRC-64/XZ of the payload, tagged sections
 * INFO, SCENE, MESH, MATRIX, PATCHDATA, LIGHTS when the scene has punctual
 * lights, ELEMENTS when the solution has elements, ELEMENTLIGHTS when it has
 * both, CAMERAS when the scene has orthographic cameras, CLUSTERS when
 * patches span several cells), each section measured first and then
 * streamed through a buffer
 * into a rad_output.
 *
 * Invariant: the writer applies the reader's rules before it creates a
 * file, so it never writes a file the reader would refuse, and it never
 * replaces a good file with a bad one (rad_output: temporary and rename).
 */
#include "store_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

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
    const sol_crc64_tables *tab;
    int failed;
} sink;

static void sink_flush(sink *k)
{
    if (!k->out || k->failed || k->len == 0)
        return;
    k->crc = sol_crc64_update(k->tab, k->crc, k->buf, k->len);
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
 * each (LIGHTS 1, ELEMENTS 2, ELEMENTLIGHTS 4, CAMERAS 8, SURFACE 16, CLUSTERS 32, PROGRESS
 * 128: sol_sec_bit): the reader then knows what
 * must follow, and a file cut or stripped before one of them cannot pass
 * for a file without it. */
static uint8_t announced_sections(const rad_solution *s)
{
    uint8_t bits = 0;
    for (int i = SEC_LIGHTS; i < SEC_COUNT; i++)
        if (section_written(s, i))
            bits |= sol_sec_bit[i];
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

/* The cell layer: per patch its number of cells, then the corners and
 * polygon of each cell of the patches that have several (a patch of one
 * cell is that cell; the rest of a cell follows from its polygon). */
static void emit_clusters(sink *k, const rad_solution *s)
{
    const rad_mesh *m = s->mesh;
    put_u32(k, m->patch_count);
    put_u32(k, m->cell_count);
    for (uint32_t i = 0; i < m->patch_count; i++)
        put_varint(k, m->cell_first[i + 1] - m->cell_first[i]);
    for (uint32_t i = 0; i < m->patch_count; i++) {
        if (m->cell_first[i + 1] - m->cell_first[i] < 2)
            continue;
        for (uint32_t c = m->cell_first[i]; c < m->cell_first[i + 1]; c++) {
            for (int q = 0; q < 4; q++)
                put_u32(k, m->cells[c].v[q]);
            put_u32(k, m->cells[c].polygon);
        }
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

/* The orthographic cameras: SCENE holds every camera as a perspective one
 * (what a reader that knows no other takes), this says which are not. */
static void emit_cameras(sink *k, const rad_solution *s)
{
    const rad_scene *sc = s->scene;
    uint32_t n = 0;
    for (uint32_t i = 0; i < sc->camera_count; i++)
        n += sc->cameras[i].orthographic != 0;
    put_u32(k, n);
    for (uint32_t i = 0; i < sc->camera_count; i++) {
        const rad_camera *c = &sc->cameras[i];
        if (!c->orthographic)
            continue;
        put_u32(k, i);
        put_u8(k, 1); /* projection: 1 = orthographic, the only other one */
        put_f64(k, c->xmag);
        put_f64(k, c->ymag);
    }
}

static int has_ortho_camera(const rad_scene *sc)
{
    for (uint32_t i = 0; i < sc->camera_count; i++)
        if (sc->cameras[i].orthographic)
            return 1;
    return 0;
}

/* 1 when some material has a glossy lobe or a roughness of its own. */
static int has_surface(const rad_solution *s)
{
    const rad_scene *sc = s->scene;
    for (uint32_t i = 0; i < sc->material_count; i++)
        if (rad_material_glossy(&sc->materials[i], sc->band_count) ||
            sc->materials[i].roughness != 1.0)
            return 1;
    return 0;
}

/* SURFACE: the materials' glossy lobes, for the gather renderer (the
 * solve never reads them): material count, then per material the
 * roughness and ρ_s per band. */
static void emit_surface(sink *k, const rad_solution *s)
{
    const rad_scene *sc = s->scene;
    put_u32(k, sc->material_count);
    for (uint32_t i = 0; i < sc->material_count; i++) {
        put_f64(k, sc->materials[i].roughness);
        for (uint32_t b = 0; b < sc->band_count; b++)
            put_f64(k, sc->materials[i].specular[b]);
    }
}

/* PROGRESS: the last progressive solve's shots, unshot fraction, converged
 * flag, rows recomputed and dropped, preview time, then each preview's
 * shots, rows computed, seconds and unshot fraction. */
static void emit_progress(sink *k, const rad_solution *s)
{
    const rad_progress *p = s->progress;
    put_u32(k, p->shots);
    put_f64(k, p->unshot);
    put_u8(k, (uint8_t)p->converged);
    put_u64(k, p->rows_recomputed);
    put_u64(k, p->rows_dropped);
    put_f64(k, p->preview_seconds);
    put_u32(k, p->preview_count);
    for (uint32_t i = 0; i < p->preview_count; i++) {
        put_u32(k, p->previews[i].shots);
        put_u32(k, p->previews[i].rows);
        put_f64(k, p->previews[i].seconds);
        put_f64(k, p->previews[i].unshot);
    }
}

typedef void (*emit_fn)(sink *, const rad_solution *);
static const emit_fn sec_emit[SEC_COUNT] = {emit_info,      emit_scene,  emit_mesh,    emit_matrix,
                                            emit_patchdata, emit_lights, emit_elements,
                                            emit_element_lights, emit_cameras, emit_surface,
                                            emit_clusters, emit_progress};

/* LIGHTS is written only when there are lights, ELEMENTS when there are
 * elements, ELEMENTLIGHTS when the elements carry their own direct light,
 * CAMERAS when a camera is orthographic. */
static int section_written(const rad_solution *s, int i)
{
    if (i == SEC_CAMERAS)
        return has_ortho_camera(s->scene);
    if (i == SEC_LIGHTS)
        return s->scene->light_count > 0;
    if (i == SEC_ELEMENTS)
        return s->elements != NULL;
    if (i == SEC_ELEMENT_LIGHTS)
        return s->elements && s->elements->light_h;
    if (i == SEC_SURFACE)
        return has_surface(s);
    if (i == SEC_CLUSTERS)
        return s->mesh->cell_first != NULL;
    if (i == SEC_PROGRESS)
        return s->progress != NULL;
    return 1;
}

static uint32_t version_of(const rad_solution *s)
{
    /* CAMERAS, SURFACE, CLUSTERS and PROGRESS need version 5's
     * announcement: a reader of an older version would show an
     * orthographic camera in perspective, drop the glossy lobes, or draw
     * each cluster as its one home cell, without a word (PROGRESS follows
     * them). */
    if (s->mesh->twin || has_ortho_camera(s->scene) || has_surface(s) || s->mesh->cell_first ||
        s->progress)
        return SOL_VERSION_SHEETS;
    if (s->elements)
        return s->elements->light_h ? 4u : 3u;
    return s->scene->light_count ? 2u : 1u;
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
    int rc = sol_check_info(s, path, "cannot write", RAD_ERR_INVALID, err);
    if (!rc)
        rc = sol_check_progress(s, path, "cannot write", RAD_ERR_INVALID, err);
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
    if ((rc = sol_check_lights(s, path, "cannot write", RAD_ERR_INVALID, err)))
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
    return sol_check_patch_values(s, path, "cannot write", RAD_ERR_INVALID, err);
}

static void store_le(uint8_t *p, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

uint64_t rad_solution_file_bytes(const rad_solution *s)
{
    uint64_t total = SOL_HEADER_BYTES;
    for (int i = 0; i < SEC_COUNT; i++) {
        if (!section_written(s, i))
            continue;
        sink count = {0};
        sec_emit[i](&count, s);
        total += SOL_SECTION_HEADER + count.total;
    }
    return total;
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

    sol_crc64_tables *tab = malloc(sizeof *tab);
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
    sol_crc64_init(tab);
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
        put(&k, sol_sec_tag[i], 4);
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
