/* write.c - rad_solution_write: the solution file of
 * docs/solution-format.md, format version 7.  A header, the sections each
 * with its own CRC-64 (MATRIX or MATRIXREF, INFO, SCENE, MESH, ROWS,
 * PATCHDATA, IRRADIANCE, then the optional ones as the solution has them:
 * LIGHTS, ELEMENTS, ELEMENTLIGHTS, CAMERAS, SURFACE, CLUSTERS, ...,
 * BASIS, ELEMENTROWS), and at the
 * end the index that lists them, whose CRC the header holds.  The index
 * comes last so that a solve can stream its matrix first, one row block
 * per finished row (journal.c), and add the rest when it is done; this file
 * writes the same layout in one go.
 *
 * Invariant: the writer applies the reader's rules before it creates a
 * file, so it never writes a file the reader would refuse, and it never
 * replaces a good file with a bad one (rad_output: temporary and rename).
 */
#include "solfile_internal.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* -------------------------------------------------------------------- sink */

int sol_sink_init(sol_sink *k, rad_output *out)
{
    *k = (sol_sink){.out = out, .cap = 1u << 20, .crc = ~0ull};
    k->buf = malloc(k->cap);
    k->tab = malloc(sizeof *k->tab);
    if (!k->buf || !k->tab) {
        sol_sink_free(k);
        return -1;
    }
    sol_crc64_init(k->tab);
    k->total = out ? rad_output_size(out) : 0;
    return 0;
}

void sol_sink_free(sol_sink *k)
{
    free(k->buf);
    free(k->tab);
    k->buf = NULL;
    k->tab = NULL;
}

/* Brings the CRC up to the end of the buffer. */
static void sink_crc(sol_sink *k)
{
    if (k->len == k->crc_from)
        return; /* nothing new (always so in a counting sink) */
    k->crc = sol_crc64_update(k->tab, k->crc, k->buf + k->crc_from, k->len - k->crc_from);
    k->crc_from = k->len;
}

void sol_sink_flush(sol_sink *k)
{
    sink_crc(k);
    if (k->out && k->len)
        rad_output_write(k->out, k->buf, k->len); /* a failure sticks in the output */
    k->len = 0;
    k->crc_from = 0;
}

void sol_put(sol_sink *k, const void *p, size_t n)
{
    const uint8_t *b = p;
    k->total += n;
    if (!k->buf)
        return; /* a counting sink ({0}): only the total */
    while (n) {
        size_t room = k->cap - k->len, step = n < room ? n : room;
        memcpy(k->buf + k->len, b, step);
        k->len += step;
        b += step;
        n -= step;
        if (k->len == k->cap)
            sol_sink_flush(k);
    }
}

void sol_sink_begin(sol_sink *k, sol_index_entry *e, int sec)
{
    sink_crc(k);
    k->crc = ~0ull;
    memcpy(e->tag, sol_sec_tag[sec], 4);
    e->offset = k->total;
}

void sol_sink_end(sol_sink *k, sol_index_entry *e)
{
    sink_crc(k);
    e->length = k->total - e->offset;
    e->crc = k->crc ^ ~0ull;
}

static void put(sol_sink *k, const void *p, size_t n) { sol_put(k, p, n); }

static void put_u8(sol_sink *k, uint8_t v) { put(k, &v, 1); }

static void put_u32(sol_sink *k, uint32_t v)
{
    uint8_t b[4];
    sol_store_le(b, v, 4);
    put(k, b, 4);
}

static void put_u64(sol_sink *k, uint64_t v)
{
    uint8_t b[8];
    sol_store_le(b, v, 8);
    put(k, b, 8);
}

static void put_f64(sol_sink *k, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    put_u64(k, bits);
}

static void put_f32(sol_sink *k, float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    put_u32(k, bits);
}

static void put_vec3(sol_sink *k, rad_vec3 v)
{
    put_f64(k, v.x);
    put_f64(k, v.y);
    put_f64(k, v.z);
}

static void put_varint(sol_sink *k, uint32_t v)
{
    uint8_t b[5];
    put(k, b, rad_varint_put(b, v));
}

/* Lengths were checked against SOL_MAX_STRING before writing began. */
static void put_str(sol_sink *k, const char *s)
{
    size_t n = s ? strlen(s) : 0;
    put_u32(k, (uint32_t)n);
    put(k, s, n);
}

/* ---------------------------------------------------------------- sections */

static int section_written(const rad_solution *s, int i);

/* INFO (versions 5 and 6) ends with the optional sections the file holds,
 * one bit each in enum order (LIGHTS 1, ELEMENTS 2, ELEMENTLIGHTS 4,
 * CAMERAS 8, SURFACE 16, CLUSTERS 32, ELEMENTINDIRECT 64, PROGRESS 128): the reader then knows what must be
 * there, and a file stripped of one of them cannot pass for a file
 * without it. */
static uint8_t announced_sections(const rad_solution *s)
{
    uint8_t bits = 0;
    for (int i = SEC_LIGHTS; i <= SEC_LAST_ANNOUNCED; i++)
        if (section_written(s, i))
            bits |= (uint8_t)(1u << (i - SEC_LIGHTS));
    return bits;
}

static void emit_info(sol_sink *k, const sol_write_ctx *w)
{
    const rad_solution *s = w->s;
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
    put_u8(k, announced_sections(s));
}

static void emit_scene(sol_sink *k, const sol_write_ctx *w)
{
    const rad_solution *s = w->s;
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

static void emit_mesh(sol_sink *k, const sol_write_ctx *w)
{
    const rad_solution *s = w->s;
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
static void put_row(sol_sink *k, uint32_t cnt, const uint32_t *col, const float *val)
{
    for (uint32_t j = 0; j < cnt; j++)
        put_varint(k, j ? col[j] - col[j - 1] : col[0]);
    for (uint32_t j = 0; j < cnt; j++)
        put_f32(k, val[j]);
}

/* Elements: provenance, vertices, then per element its patch, level,
 * corners, B and row entry count; the entries are ELEMENTROWS'. */
static void emit_elements(sol_sink *k, const sol_write_ctx *w)
{
    const rad_solution *s = w->s;
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
    }
}

/* Σ_e of the elements' row entry counts: what ELEMENTROWS holds. */
static uint64_t element_entries(const rad_elements *el)
{
    uint64_t total = 0;
    for (uint32_t e = 0; el && e < el->mesh->patch_count; e++)
        total += el->row_count[e];
    return total;
}

/* The elements' row entries, element by element (rows encoded like the
 * matrix's), after their counts. */
static void emit_element_rows(sol_sink *k, const sol_write_ctx *w)
{
    const rad_elements *el = w->s->elements;
    RAD_ASSERT(el->rows_loaded); /* sol_validate_for_write refuses the others */
    put_u32(k, el->mesh->patch_count);
    put_u64(k, element_entries(el));
    for (uint32_t e = 0; e < el->mesh->patch_count; e++)
        if (el->row_count[e])
            put_row(k, el->row_count[e], el->col + el->row_start[e], el->val + el->row_start[e]);
}

/* The cell layer: per patch its number of cells, then the corners and
 * polygon of each cell of the patches that have several (a patch of one
 * cell is that cell; the rest of a cell follows from its polygon). */
static void emit_clusters(sol_sink *k, const sol_write_ctx *w)
{
    const rad_mesh *m = w->s->mesh;
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
static void emit_element_lights(sol_sink *k, const sol_write_ctx *w)
{
    const rad_solution *s = w->s;
    const rad_elements *el = s->elements;
    const size_t count = (size_t)el->mesh->patch_count * el->light_count;
    put_u32(k, el->mesh->patch_count);
    put_u32(k, el->light_count);
    for (size_t q = 0; q < count; q++)
        put_f32(k, el->light_h[q]);
}

/* Which elements interpolate their indirect light, then which patches are
 * direct sources: one byte each. */
static void emit_element_indirect(sol_sink *k, const sol_write_ctx *w)
{
    const rad_solution *s = w->s;
    const rad_elements *el = s->elements;
    put_u32(k, el->mesh->patch_count);
    put_u32(k, s->mesh->patch_count);
    put(k, el->interp, el->mesh->patch_count);
    put(k, el->direct, s->mesh->patch_count);
}

static void emit_patchdata(sol_sink *k, const sol_write_ctx *w)
{
    const rad_solution *s = w->s;
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
static void emit_lights(sol_sink *k, const sol_write_ctx *w)
{
    const rad_solution *s = w->s;
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
static void emit_cameras(sol_sink *k, const sol_write_ctx *w)
{
    const rad_scene *sc = w->s->scene;
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
static void emit_surface(sol_sink *k, const sol_write_ctx *w)
{
    const rad_scene *sc = w->s->scene;
    put_u32(k, sc->material_count);
    for (uint32_t i = 0; i < sc->material_count; i++) {
        put_f64(k, sc->materials[i].roughness);
        for (uint32_t b = 0; b < sc->band_count; b++)
            put_f64(k, sc->materials[i].specular[b]);
    }
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
int sol_validate_for_write(const rad_solution *s, const char *path, int check_matrix,
                           rad_error *err)
{
    if (!s || !s->scene || !s->mesh || !s->F || !s->rho || !s->emission || !s->B)
        return rad_fail(err, RAD_ERR_USAGE, "%s: cannot write: incomplete solution", path);
    if (!s->F->entries_loaded && check_matrix)
        return rad_fail(err, RAD_ERR_USAGE,
                        "%s: cannot write: the form factors were not read and cannot be shared "
                        "(read the solution whole)", path);
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
    if (check_matrix && rad_matrix_check(s->F, &sub))
        return rad_fail(err, RAD_ERR_INVALID, "%s: cannot write: %s", path, sub.message);
    /* Elements read without their rows, or a solution read without its
     * light responses, would lose them: the caller should have read
     * RAD_PART_ELEMENT_ROWS and RAD_PART_BASIS. */
    RAD_ASSERT(!rad_solution_basis_skipped(s));
    if (rad_solution_basis_skipped(s))
        return rad_fail(err, RAD_ERR_USAGE, "%s: cannot write: the stored light responses were "
                        "not read", path);
    RAD_ASSERT(!s->elements || s->elements->rows_loaded);
    if (s->elements && !s->elements->rows_loaded)
        return rad_fail(err, RAD_ERR_USAGE, "%s: cannot write: the elements' rows were not read",
                        path);
    if (s->elements && rad_element_store_check(s->elements, s, "elements", &sub))
        return rad_fail(err, RAD_ERR_INVALID, "%s: cannot write: %s", path, sub.message);
    if (rad_basis_matches(s) &&
        (rc = sol_check_basis(s, path, "cannot write: light responses", RAD_ERR_INVALID, err)))
        return rc;
    return sol_check_patch_values(s, path, "cannot write", RAD_ERR_INVALID, err);
}

/* ROWS: which rows F holds and their entry counts, one varint each (0:
 * absent, c + 1: present with c entries), so that a reader that skips the
 * matrix still knows which patches see nothing. */
static void emit_rows(sol_sink *k, const sol_write_ctx *w)
{
    const rad_matrix *F = w->s->F;
    put_u32(k, F->n);
    for (uint32_t i = 0; i < F->n; i++)
        put_varint(k, F->row_done[i] ? F->row_count[i] + 1 : 0);
}

/* IRRADIANCE: H_i per band of the B stored beside it, computed from F when
 * the file was written, for readers that skip the matrix. */
static void emit_irradiance(sol_sink *k, const sol_write_ctx *w)
{
    uint32_t n = w->s->mesh->patch_count, nb = w->s->band_count;
    put_u32(k, n);
    put_u32(k, nb);
    for (size_t q = 0; q < (size_t)n * nb; q++)
        put_f64(k, w->H ? w->H[q] : 0.0); /* a counting pass has no H */
}

/* MATRIXREF: the file holding the matrix and its MATRIX section. */
static void emit_matrixref(sol_sink *k, const sol_write_ctx *w)
{
    const rad_matrix_file *mf = rad_solution_matrix_file(w->s); /* shared: known */
    put_str(k, w->ref_name);
    put_str(k, mf->path);
    put_u64(k, mf->offset);
    put_u64(k, mf->length);
    put_u64(k, mf->crc);
    put_u64(k, w->s->F->key);
    put_u32(k, w->s->F->n);
}

/* A block of rows [first, last) of F in row order: the header (length and
 * CRC-64 of the records, measured first) and the records. */
static void put_block(sol_sink *k, const rad_matrix *F, uint32_t first, uint32_t last,
                      uint32_t rows, uint64_t bytes)
{
    uint64_t crc = ~0ull;
    for (uint32_t i = first; i < last; i++)
        if (F->row_done[i])
            crc = sol_crc64_update(k->tab, crc, F->data + F->row_start[i] - SOL_RECORD_HEAD,
                                   (size_t)rad_matrix_record_bytes(F, i));
    put(k, SOL_BLOCK_TAG, 4);
    put_u32(k, rows);
    put_u64(k, bytes);
    put_u64(k, crc ^ ~0ull);
    for (uint32_t i = first; i < last; i++)
        if (F->row_done[i])
            put(k, F->data + F->row_start[i] - SOL_RECORD_HEAD,
                (size_t)rad_matrix_record_bytes(F, i));
}

/* MATRIX: n, the rows key, then the rows present in row order, grouped in
 * blocks of about SOL_BLOCK_TARGET bytes. */
static void emit_matrix(sol_sink *k, const sol_write_ctx *w)
{
    const rad_matrix *F = w->s->F;
    sol_put_matrix_head(k, F->n, F->key);
    uint32_t first = 0, rows = 0;
    uint64_t bytes = 0;
    for (uint32_t i = 0; i < F->n; i++) {
        uint64_t b = rad_matrix_record_bytes(F, i);
        if (rows && bytes + b > SOL_BLOCK_TARGET) {
            put_block(k, F, first, i, rows, bytes);
            first = i;
            rows = 0;
            bytes = 0;
        }
        rows += F->row_done[i];
        bytes += b;
    }
    if (rows)
        put_block(k, F, first, F->n, rows, bytes);
}

void sol_put_matrix_head(sol_sink *k, uint32_t n, uint64_t key)
{
    put_u32(k, n);
    put_u32(k, 0);
    put_u64(k, key);
}

/* PROGRESS: the last progressive solve's shots, unshot fraction, converged
 * flag, rows recomputed and dropped, preview time, then each preview's
 * shots, rows computed, seconds and unshot fraction. */
static void emit_progress(sol_sink *k, const sol_write_ctx *w)
{
    const rad_progress *p = w->s->progress;
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

/* BASIS: the stored light responses (parse.c's parse_basis). */
static void emit_basis(sol_sink *k, const sol_write_ctx *w)
{
    const rad_basis *b = w->s->basis;
    const uint64_t nv = (uint64_t)b->patch_count * b->band_count;
    const uint64_t nev = (uint64_t)b->element_count * b->band_count;
    put_u32(k, b->groups);
    put_u32(k, b->patch_count);
    put_u32(k, b->band_count);
    put_u32(k, b->light_count);
    put_u32(k, b->element_count);
    for (uint64_t q = 0; q < nv; q++)
        put_f64(k, b->E_ref[q]);
    for (uint64_t q = 0; q < (uint64_t)b->light_count * b->band_count; q++)
        put_f64(k, b->I_ref[q]);
    for (uint32_t i = 0; i < b->patch_count; i++)
        put_u32(k, b->patch_group[i]);
    for (uint32_t l = 0; l < b->light_count; l++)
        put_u32(k, b->light_group[l]);
    for (uint32_t g = 0; g < b->groups; g++) {
        put_f64(k, b->residual[g]);
        for (uint64_t q = 0; q < nv; q++)
            put_f64(k, b->B[g * nv + q]);
        for (uint64_t q = 0; q < nv; q++)
            put_f64(k, b->H[g * nv + q]);
        for (uint64_t q = 0; q < nev; q++)
            put_f64(k, b->Be[g * nev + q]);
    }
}

/* TEXTURES (version 8): the images (media type, length, the bytes as the
 * input held them), the textures (material, image, texCoord set, the
 * sampler's wrap S and T, mag and min filter, baseColorFactor RGBA), then
 * the (u, v) of every point, polygon by polygon (point_count first). */
static void emit_textures(sol_sink *k, const sol_write_ctx *w)
{
    const rad_scene *sc = w->s->scene;
    put_u32(k, sc->image_count);
    for (uint32_t i = 0; i < sc->image_count; i++) {
        put_str(k, sc->images[i].mime);
        put_u64(k, sc->images[i].size);
        put(k, sc->images[i].data, (size_t)sc->images[i].size);
    }
    put_u32(k, sc->texture_count);
    for (uint32_t i = 0; i < sc->texture_count; i++) {
        const rad_texture *t = &sc->textures[i];
        put_u32(k, t->material);
        put_u32(k, t->image);
        put_u32(k, t->texcoord);
        put_u32(k, (uint32_t)t->wrap_s);
        put_u32(k, (uint32_t)t->wrap_t);
        put_u32(k, (uint32_t)t->mag_filter);
        put_u32(k, (uint32_t)t->min_filter);
        for (int c = 0; c < 4; c++)
            put_f64(k, t->factor[c]);
    }
    put_u32(k, sc->point_count);
    for (uint32_t p = 0; p < sc->point_count; p++) {
        put_f64(k, sc->point_uv ? sc->point_uv[2 * (size_t)p] : 0.0);
        put_f64(k, sc->point_uv ? sc->point_uv[2 * (size_t)p + 1] : 0.0);
    }
}

typedef void (*emit_fn)(sol_sink *, const sol_write_ctx *);
static const emit_fn sec_emit[SEC_COUNT] = {
    [SEC_INFO] = emit_info,
    [SEC_SCENE] = emit_scene,
    [SEC_MESH] = emit_mesh,
    [SEC_MATRIX] = emit_matrix,
    [SEC_PATCHDATA] = emit_patchdata,
    [SEC_LIGHTS] = emit_lights,
    [SEC_ELEMENTS] = emit_elements,
    [SEC_ELEMENT_LIGHTS] = emit_element_lights,
    [SEC_CAMERAS] = emit_cameras,
    [SEC_SURFACE] = emit_surface,
    [SEC_CLUSTERS] = emit_clusters,
    [SEC_ELEMENT_INDIRECT] = emit_element_indirect,
    [SEC_PROGRESS] = emit_progress,
    [SEC_ROWS] = emit_rows,
    [SEC_IRRADIANCE] = emit_irradiance,
    [SEC_MATRIXREF] = emit_matrixref,
    [SEC_BASIS] = emit_basis,
    [SEC_ELEMENT_ROWS] = emit_element_rows,
    [SEC_TEXTURES] = emit_textures,
};

/* Whether the file holds section i: the optional ones only when the
 * solution has what they hold (LIGHTS punctual lights, ELEMENTS elements,
 * ELEMENTLIGHTS elements with their own direct light, CAMERAS an
 * orthographic camera, SURFACE a glossy material, CLUSTERS patches of
 * several cells, ELEMENTINDIRECT elements that interpolate the light
 * reflected onto them, BASIS stored light responses that still describe the
 * solution); the others always (MATRIX and MATRIXREF are the
 * writer's choice, not asked here). */
static int section_written(const rad_solution *s, int i)
{
    switch (i) {
    case SEC_LIGHTS:
        return s->scene->light_count > 0;
    case SEC_ELEMENTS:
        return s->elements != NULL;
    case SEC_ELEMENT_LIGHTS:
        return s->elements && s->elements->light_h;
    case SEC_CAMERAS:
        return has_ortho_camera(s->scene);
    case SEC_SURFACE:
        return has_surface(s);
    case SEC_CLUSTERS:
        return s->mesh->cell_first != NULL;
    case SEC_ELEMENT_INDIRECT:
        return s->elements && s->elements->interp;
    case SEC_PROGRESS:
        return s->progress != NULL;
    case SEC_BASIS: /* a basis made for another ρ or other elements is stale: left out */
        return rad_basis_matches(s);
    case SEC_ELEMENT_ROWS:
        return element_entries(s->elements) > 0;
    case SEC_TEXTURES:
        return s->scene->texture_count > 0;
    default:
        return 1;
    }
}

/* ------------------------------------------------------------------- file */

uint64_t sol_rows_crc(sol_sink *k, const rad_mesh *m)
{
    rad_solution s = {.mesh = (rad_mesh *)m}; /* emit_mesh reads only the mesh */
    sol_write_ctx w = {.s = &s};
    sol_index_entry e;
    sol_sink_begin(k, &e, SEC_MESH);
    emit_mesh(k, &w);
    sol_sink_end(k, &e);
    return e.crc;
}

int sol_write_rest(sol_sink *k, const sol_write_ctx *w, const sol_index_entry *matrix,
                   rad_error *err)
{
    const rad_solution *s = w->s;
    sol_index_entry idx[SOL_MAX_SECTIONS];
    uint32_t count = 0;
    idx[count++] = *matrix;
    for (size_t q = 0; sol_section_order(q) >= 0; q++) { /* the reader's order */
        int sec = sol_section_order(q);
        if (!section_written(s, sec))
            continue;
        sol_sink_begin(k, &idx[count], sec);
        sec_emit[sec](k, w);
        sol_sink_end(k, &idx[count]);
        count++;
    }
    /* the index, and its CRC into the header */
    uint64_t at = k->total;
    uint8_t head[SOL_INDEX_HEAD], ent[SOL_INDEX_ENTRY];
    sol_store_le(head, count, 4);
    sol_store_le(head + 4, SOL_VERSION, 4); /* the header's version, under the index's CRC */
    sol_index_entry crc_of_index;
    sol_sink_begin(k, &crc_of_index, SEC_INFO);
    put(k, head, sizeof head);
    for (uint32_t q = 0; q < count; q++) {
        memcpy(ent, idx[q].tag, 4);
        sol_store_le(ent + 4, 0, 4);
        sol_store_le(ent + 8, idx[q].offset, 8);
        sol_store_le(ent + 16, idx[q].length, 8);
        sol_store_le(ent + 24, idx[q].crc, 8);
        put(k, ent, sizeof ent);
    }
    sol_sink_end(k, &crc_of_index);
    sol_sink_flush(k);
    uint8_t tail[16];
    sol_store_le(tail, at, 8);
    sol_store_le(tail + 8, crc_of_index.crc, 8);
    rad_output_write_at(k->out, tail, sizeof tail, 16);
    return rad_output_error(k->out, err);
}

void sol_header(uint8_t head[SOL_HEADER_BYTES])
{
    memset(head, 0, SOL_HEADER_BYTES);
    memcpy(head, SOL_MAGIC, 8);
    sol_store_le(head + 8, SOL_VERSION, 4);
    /* bytes 16..31, the index's offset and CRC, are written last: zero
     * means "being written" */
}

void sol_store_le(uint8_t *p, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

uint64_t rad_solution_row_file_bytes(const rad_matrix *F, uint32_t i)
{
    return F->row_done[i] ? SOL_BLOCK_HEAD + rad_matrix_record_bytes(F, i) : 0;
}

uint64_t rad_solution_file_bytes(const rad_solution *s)
{
    sol_sink count = {0}; /* counts, writes nothing */
    sol_write_ctx w = {.s = s};
    uint64_t total = SOL_HEADER_BYTES + SOL_MATRIX_HEAD;
    for (uint32_t i = 0; i < s->F->n; i++)
        total += rad_solution_row_file_bytes(s->F, i);
    uint32_t sections = 1; /* MATRIX */
    for (size_t q = 0; sol_section_order(q) >= 0; q++) {
        int sec = sol_section_order(q);
        if (!section_written(s, sec))
            continue;
        sections++;
        if (sec == SEC_ELEMENT_ROWS && !s->elements->rows_loaded) /* a relight reads them late */
            count.total += 4u + 8u + MIN_ENTRY * element_entries(s->elements);
        else
            sec_emit[sec](&count, &w);
    }
    return total + count.total + SOL_INDEX_HEAD + (uint64_t)sections * SOL_INDEX_ENTRY;
}

/* Is s's basis one group made from s's own sources and B?  Its H is then
 * the very H of s, computed by the same pass over F (rad_basis_make), and a
 * write need not make that pass again. */
static int basis_is_solution(const rad_solution *s)
{
    const rad_basis *b = s->basis;
    const size_t nv = (size_t)s->mesh->patch_count * s->band_count;
    const size_t nl = (size_t)b->light_count * b->band_count;
    return b->groups == 1 && memcmp(b->B, s->B, nv * sizeof *s->B) == 0 &&
           memcmp(b->E_ref, s->emission, nv * sizeof *s->emission) == 0 &&
           (!nl || memcmp(b->I_ref, s->light_intensity, nl * sizeof *b->I_ref) == 0);
}

int sol_irradiance_for_write(const rad_solution *s, double **H, rad_error *err)
{
    size_t count = (size_t)s->mesh->patch_count * s->band_count;
    *H = malloc((count + 1) * sizeof **H);
    if (!*H)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    if (rad_basis_matches(s) && basis_is_solution(s)) {
        memcpy(*H, s->basis->H, count * sizeof **H);
        return RAD_OK;
    }
    int rc = rad_solution_irradiance(s, *H, err);
    if (rc) {
        free(*H);
        *H = NULL;
    }
    return rc;
}

/* The name a MATRIXREF of a file at `path` gives the matrix: PATH.matrix, a
 * hard link to the file holding it, named relative to path's directory;
 * where no hard link can be made, that file's absolute path. */
static void share_matrix(const rad_solution *s, const char *path, sol_write_ctx *w,
                         rad_write_info *info)
{
    char link_path[sizeof info->matrix_path];
    int n = snprintf(link_path, sizeof link_path, "%s.matrix", path);
    const char *slash = strrchr(link_path, '/');
    const char *name = slash ? slash + 1 : link_path;
    const char *target = rad_solution_matrix_file(s)->path; /* shared: known */
    rad_error ignored;
    if (n > 0 && (size_t)n < sizeof link_path && strlen(name) <= SOL_MAX_STRING &&
        rad_output_link(target, link_path, &ignored) == 0) {
        memcpy(w->ref_name, name, strlen(name) + 1);
        memcpy(info->matrix_path, link_path, (size_t)n + 1);
        info->linked = 1;
    } else { /* the caller checked that it fits */
        memcpy(w->ref_name, target, strlen(target) + 1);
        if (strlen(target) < sizeof info->matrix_path)
            memcpy(info->matrix_path, target, strlen(target) + 1);
    }
    info->matrix_shared = 1;
}

int rad_solution_write_opts(const rad_solution *s, const char *path, const rad_write_options *opt,
                            rad_write_info *info, rad_error *err)
{
    rad_write_info local;
    static const rad_write_options defaults;
    if (!info)
        info = &local;
    if (!opt)
        opt = &defaults;
    memset(info, 0, sizeof *info);
    if (!path || !*path)
        return rad_fail(err, RAD_ERR_USAGE, "rad_solution_write: no path");
    /* A matrix shared, not written, was checked when it was read and has
     * not changed since. */
    int shared = opt->share_matrix && rad_solution_matrix_in_file(s) &&
                 strlen(rad_solution_matrix_file(s)->path) <= SOL_MAX_STRING;
    int rc = sol_validate_for_write(s, path, !shared, err);
    if (rc)
        return rc;
    sol_write_ctx w = {.s = s};
    if ((rc = sol_irradiance_for_write(s, &w.H, err)))
        return rc;
    if (shared)
        share_matrix(s, path, &w, info);

    rad_output *out = NULL;
    sol_sink k;
    if ((rc = rad_output_open(path, &out, err))) {
        free(w.H);
        return rc;
    }
    if (sol_sink_init(&k, out) != 0) {
        rad_output_abort(out);
        free(w.H);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: cannot write: out of memory", path);
    }
    uint8_t head[SOL_HEADER_BYTES];
    sol_header(head);
    put(&k, head, sizeof head);
    sol_index_entry matrix;
    int msec = shared ? SEC_MATRIXREF : SEC_MATRIX;
    sol_sink_begin(&k, &matrix, msec);
    sec_emit[msec](&k, &w);
    sol_sink_end(&k, &matrix);
    rc = sol_write_rest(&k, &w, &matrix, err);
    if (!rc && k.total > SOL_MAX_FILE)
        rc = rad_fail(err, RAD_ERR_LIMIT,
                      "%s: cannot write: %llu bytes exceeds the 64 GiB limit of the reader", path,
                      (unsigned long long)k.total);
    sol_sink_free(&k);
    free(w.H);
    if (rc) {
        rad_output_abort(out);
        return rc;
    }
    return rad_output_commit(out, err); /* reports any write's failure */
}

int rad_solution_write(const rad_solution *s, const char *path, rad_error *err)
{
    return rad_solution_write_opts(s, path, NULL, NULL, err);
}
