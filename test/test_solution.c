/* test_solution.c - the solution store: round trip, the file layout of
 * docs/solution-format.md (version 7, checked with this file's own
 * CRC-64/XZ), refusal of truncated, corrupted, newer and foreign files,
 * reading without the matrix or the elements' rows, every older version
 * still read (the frozen files of test/fuzz/corpus/solution/, versions 1
 * to 6, and their damage refused), and writes that fail without leaving a
 * temporary file or harming the file already there.
 *
 * Run as `test_solution --write-seeds DIR` it writes the fuzzer's version 7
 * seeds (small valid solution files, NAME-v7) into DIR instead.
 */
#include "../radiosity/mesh/mesh.h"
#include "../radiosity/pipeline/pipeline.h"
#include "../radiosity/scene/scene.h"
#include "../radiosity/solfile/solfile.h"
#include "test.h"
#include "util.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

/* ------------------------------------------------- an independent CRC-64 */

/* CRC-64/XZ written from its definition (bit by bit, reflected polynomial
 * 0xC96C5795D7870F42, init and final XOR all ones), independent of
 * solfile/format.c's table-driven code.  crc_step advances the raw register. */
static uint64_t crc_step(uint64_t reg, uint8_t byte)
{
    reg ^= byte;
    for (int k = 0; k < 8; k++)
        reg = (reg & 1) ? (reg >> 1) ^ 0xC96C5795D7870F42ull : reg >> 1;
    return reg;
}

/* A byte at a time through a table made by crc_step (the byte tests below
 * recompute CRCs of thousands of images). */
static uint64_t crc64_xz(const uint8_t *p, size_t n)
{
    static uint64_t table[256];
    static int ready;
    if (!ready) {
        for (uint32_t b = 0; b < 256; b++)
            table[b] = crc_step(0, (uint8_t)b);
        ready = 1;
    }
    uint64_t reg = ~0ull;
    for (size_t i = 0; i < n; i++)
        reg = table[(reg ^ p[i]) & 0xff] ^ (reg >> 8);
    return reg ^ ~0ull;
}

static uint64_t rd64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int k = 7; k >= 0; k--)
        v = (v << 8) | p[k];
    return v;
}

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void wr64(uint8_t *p, uint64_t v)
{
    for (int k = 0; k < 8; k++)
        p[k] = (uint8_t)(v >> (8 * k));
}

static void wr32(uint8_t *p, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        p[k] = (uint8_t)(v >> (8 * k));
}

/* ------------------------------------------- versions 1-5: tagged sections */

/* Makes the header's payload size and checksum agree with the bytes, so a
 * deliberate edit reaches the structure checks. */
static void fix_header(uint8_t *buf, size_t size)
{
    wr64(buf + 16, size - 32);
    wr64(buf + 24, crc64_xz(buf + 32, size - 32));
}

/* Offset of the body of the section with this tag (its length in *len), or 0. */
static size_t find_section(const uint8_t *buf, size_t size, const char *tag, uint64_t *len)
{
    size_t off = 32;
    while (off + 12 <= size) {
        uint64_t l = rd64(buf + off + 4);
        if (memcmp(buf + off, tag, 4) == 0) {
            *len = l;
            return off + 12;
        }
        off += 12 + (size_t)l;
    }
    return 0;
}

/* ------------------------------------------------- version 6: the index */

/* The index of a version 6 image: count, and per section tag, offset,
 * length, CRC (at 32-byte entries after an 8-byte head). */
static size_t v6_index_at(const uint8_t *b) { return (size_t)rd64(b + 16); }
static uint32_t v6_count(const uint8_t *b) { return rd32(b + v6_index_at(b)); }
static const uint8_t *v6_entry(const uint8_t *b, uint32_t q)
{
    return b + v6_index_at(b) + 8 + 32 * (size_t)q;
}

/* Offset of the body of the section with this tag (its length in *len), or 0. */
static size_t v6_find(const uint8_t *b, size_t size, const char *tag, uint64_t *len)
{
    return test_v6_section(b, size, tag, len);
}

/* Makes every CRC agree with the bytes - each row block's in MATRIX, each
 * section's in the index, the index's in the header - so that a deliberate
 * edit reaches the structure checks. */
static void v6_fix(uint8_t *b, size_t size)
{
    uint64_t len;
    size_t m = v6_find(b, size, "MTRX", &len);
    for (size_t at = m ? m + 16 : 0; m && at + 24 <= m + len;) {
        uint64_t bl = rd64(b + at + 8);
        if (memcmp(b + at, "RBLK", 4) != 0 || at + 24 + bl > m + len)
            break;
        wr64(b + at + 16, crc64_xz(b + at + 24, (size_t)bl));
        at += 24 + (size_t)bl;
    }
    size_t x = v6_index_at(b);
    for (uint32_t q = 0; q < v6_count(b); q++) {
        uint8_t *e = b + x + 8 + 32 * (size_t)q;
        size_t off = (size_t)rd64(e + 8), l = (size_t)rd64(e + 16);
        if (off + l <= size)
            wr64(e + 24, crc64_xz(b + off, l));
    }
    wr64(b + 24, crc64_xz(b + x, size - x));
}

/* ------------------------------------------------------------ fixtures */

static const double rho_white[3] = {0.7, 0.65, 0.6};
static const double rho_red[3] = {0.6, 0.1, 0.1};
static const double tr_red[3] = {0.1, 0.0, 0.05};
static const double e_lamp[3] = {10.0, 9.0, 8.5};
static const double rho_lamp[3] = {0.2, 0.2, 0.2};

/* Fills F with a deterministic pattern: rows i % 3 == 1 missing, row 0
 * present but empty, other rows hold columns where `pick` says so, with
 * F_ij < 0.9 / n so that every row sum stays below 0.9. */
static int fill_rows(rad_solution *s, int (*pick)(uint32_t i, uint32_t j, uint32_t n))
{
    uint32_t n = s->mesh->patch_count;
    uint32_t *col = malloc((n ? n : 1) * sizeof *col);
    float *val = malloc((n ? n : 1) * sizeof *val);
    int rc = (col && val) ? RAD_OK : RAD_ERR_NOMEM;
    for (uint32_t i = 0; i < n && rc == RAD_OK; i++) {
        if (i % 3 == 1)
            continue;
        uint32_t c = 0;
        for (uint32_t j = 0; j < n && i != 0; j++) {
            if (j != i && pick(i, j, n)) {
                col[c] = j;
                /* odd float bit patterns test bit exactness */
                val[c] = (float)(0.9 / n * ((1 + (i + j) % 3) / 3.0)) * 0.999999f;
                c++;
            }
        }
        rc = rad_matrix_set_row(s->F, i, c, col, val, NULL);
    }
    free(col);
    free(val);
    return rc;
}

static int pick_some(uint32_t i, uint32_t j, uint32_t n)
{
    (void)n;
    return (i * 31 + j * 17) % 5 == 0;
}

/* Far-apart columns: their gaps need two-byte varints. */
static int pick_wide(uint32_t i, uint32_t j, uint32_t n)
{
    (void)i;
    return j == 0 || j == n - 1 || j % 50 == 7;
}

static void set_provenance(rad_solution *s, const char *solver)
{
    s->patch_size = 0.25;
    s->resolution = 128;
    snprintf(s->solver, sizeof s->solver, "%s", solver);
    s->tolerance = 1e-6;
    s->iterations = 17;
    s->residual = 3.5e-7 / 3.0;
    s->rows_computed = 12345678901ull;
    for (int k = 0; k < RAD_STAGE_COUNT; k++) {
        s->stages[k].seconds = 0.1 * (k + 1) / 7.0;
        s->stages[k].reused = k % 2;
    }
}

static void set_B(rad_solution *s)
{
    size_t count = (size_t)s->mesh->patch_count * s->band_count;
    for (size_t k = 0; k < count; k++)
        s->B[k] = s->emission[k] + 0.01 * (double)(k % 7) + 1.0 / 3.0;
}

static int add_poly(rad_scene *sc, const char *name, uint32_t obj, uint32_t mat, const rad_vec3 *p,
                    uint32_t n, uint32_t su, uint32_t sv)
{
    rad_error e;
    int rc = rad_scene_add_polygon(sc, name, obj, mat, p, n, su, sv, NULL, NULL, &e);
    if (rc)
        fprintf(stderr, "fixture: %s\n", e.message);
    return rc;
}

/* Three bands with names; quads, a triangle, a pentagon (fan), two cameras,
 * meshed by rad_mesh_build from the polygons' subdivisions. */
static rad_solution *make_rgb_with(int sheets);
static rad_solution *make_rgb(void) { return make_rgb_with(0); }
/* The same room with the red paint transmitting: its wall and its window
 * are two-sided sheets (mesh twins, format version 5). */
static rad_solution *make_sheets(void) { return make_rgb_with(1); }

static rad_solution *make_rgb_with(int sheets)
{
    rad_scene *sc = rad_scene_create(3, "fixtures/rgb-room.rad");
    if (!sc)
        return NULL;
    const char *bn[3] = {"R", "G", "B"};
    for (int b = 0; b < 3; b++)
        sc->band_names[b] = strdup(bn[b]); /* no builder exists for band names */
    uint32_t white, red, lamp, room, light;
    int rc = rad_scene_add_material(sc, "white", rho_white, NULL, NULL, NULL, &white, NULL);
    rc |= rad_scene_add_material(sc, "red paint", rho_red, NULL, sheets ? tr_red : NULL, NULL,
                                 &red, NULL);
    /* transmittance is stored with the materials; no polygon uses this one,
     * so the mesh stays one-sided (sheets have their own fixture) */
    rc |= rad_scene_add_material(sc, "glass", rho_red, NULL, tr_red, NULL, NULL, NULL);
    rc |= rad_scene_add_material(sc, "lamp", rho_lamp, e_lamp, NULL, NULL, &lamp, NULL);
    rc |= rad_scene_add_object(sc, "room", NULL, &room, NULL);
    rc |= rad_scene_add_object(sc, "light", NULL, &light, NULL);
    const rad_vec3 floor[4] = {{0, 0, 0}, {3, 0, 0}, {3, 2, 0}, {0, 2, 0}};
    const rad_vec3 wall[4] = {{0, 0, 0}, {0, 2, 0}, {0, 2, 2}, {0, 0, 2}};
    const rad_vec3 tri[3] = {{3, 0, 0}, {3, 0, 2}, {3, 2, 0}};
    rad_vec3 pent[5];
    for (int k = 0; k < 5; k++) {
        double a = 2.0 * M_PI * k / 5.0;
        pent[k] = rad_v3(1.5 + 0.5 * cos(a), 2.0, 1.0 + 0.5 * sin(a));
    }
    const rad_vec3 lampq[4] = {{1, 0.5, 1.9}, {1, 1.5, 1.9}, {2, 1.5, 1.9}, {2, 0.5, 1.9}};
    rc |= add_poly(sc, "floor", room, white, floor, 4, 3, 2);
    rc |= add_poly(sc, "left wall", room, red, wall, 4, 2, 2);
    rc |= add_poly(sc, "corner", room, white, tri, 3, 2, 0);
    rc |= add_poly(sc, "window", room, red, pent, 5, 1, 0);
    rc |= add_poly(sc, "lamp", light, lamp, lampq, 4, 1, 1);
    rc |= rad_scene_add_camera(sc, "main", rad_v3(1.5, -3, 1), rad_v3(1.5, 1, 1), rad_v3(0, 0, 1),
                               45.0, 4.0 / 3.0, NULL, NULL, NULL);
    rc |= rad_scene_add_camera(sc, "top", rad_v3(1.5, 1, 5), rad_v3(1.5, 1, 0), rad_v3(0, 1, 0),
                               60.0, 0.0, NULL, NULL, NULL);
    /* punctual lights: a spot whose per-patch power is stored, a
     * directional one whose power is not computed yet */
    const double i_spot[3] = {1.5, 1.25, 1.0 / 3.0}, e_sun[3] = {100.0, 90.0, 0.0};
    rc |= rad_scene_add_light(sc, "desk lamp", RAD_LIGHT_SPOT, i_spot, rad_v3(0.5, 1.0, 1.8),
                              rad_v3(0.3, -0.2, -1.0), 0.25, 0.7, NULL, NULL, NULL);
    rc |= rad_scene_add_light(sc, "sun", RAD_LIGHT_DIRECTIONAL, e_sun, rad_v3(0, 0, 0),
                              rad_v3(-1, -2, -3), 0, 0, NULL, NULL, NULL);
    rad_mesh *m = NULL;
    rad_error e;
    if (rc || rad_mesh_build(sc, NULL, &m, &e)) {
        rad_scene_destroy(sc);
        return NULL;
    }
    rad_solution *s = NULL;
    if (rad_solution_create(sc, m, &s, &e))
        return NULL;
    set_provenance(s, "gauss-seidel");
    set_B(s);
    s->light_intensity[1] *= 0.5; /* a relight's scaled value, apart from the nominal */
    s->lights_computed = 1;
    uint32_t n = s->mesh->patch_count;
    double *phi = calloc(n, sizeof *phi);
    for (uint32_t j = 0; phi && j < n; j++)
        phi[j] = (j % 4 == 1) ? 0.0 : 1e-3 * (j + 1) / 7.0; /* gaps of 1 and 2 */
    if (!phi || fill_rows(s, pick_some) || rad_solution_set_light_power(s, 0, phi, NULL)) {
        free(phi);
        rad_solution_destroy(s);
        return NULL;
    }
    free(phi);
    return s;
}

/* One grey band, unnamed; a mesh built by hand with rad_mesh_alloc: a
 * floor quad and a ceiling split into two triangle patches; no cameras. */
static rad_solution *make_grey(void)
{
    rad_scene *sc = rad_scene_create(1, NULL);
    if (!sc)
        return NULL;
    double grey = 0.5, zero = 0.0, five = 5.0;
    int rc = rad_scene_add_material(sc, "grey", &grey, &zero, NULL, NULL, NULL, NULL);
    rc |= rad_scene_add_material(sc, "emitter", &zero, &five, NULL, NULL, NULL, NULL);
    rc |= rad_scene_add_object(sc, "box", NULL, NULL, NULL);
    const rad_vec3 fl[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    const rad_vec3 ce[4] = {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}};
    rc |= add_poly(sc, "floor", 0, 0, fl, 4, 1, 1);
    rc |= add_poly(sc, "ceiling", 0, 1, ce, 4, 1, 1);
    rad_mesh *m = rc ? NULL : rad_mesh_alloc(8, 3);
    if (!m) {
        rad_scene_destroy(sc);
        return NULL;
    }
    for (int k = 0; k < 4; k++) {
        m->vertices[k] = fl[k];
        m->vertices[4 + k] = ce[k];
        m->vertex_boundary[k] = m->vertex_boundary[4 + k] = 1;
    }
    rad_patch p0 = {{0, 1, 2, 3}, 0, 0, 0, {0.5, 0.5, 0}, {0, 0, 1}, 1.0};
    rad_patch p1 = {{4, 5, 6, RAD_NONE}, 1, 0, 1, {1 / 3.0, 2 / 3.0, 1}, {0, 0, -1}, 0.5};
    rad_patch p2 = {{4, 6, 7, RAD_NONE}, 1, 0, 1, {2 / 3.0, 1 / 3.0, 1}, {0, 0, -1}, 0.5};
    m->patches[0] = p0;
    m->patches[1] = p1;
    m->patches[2] = p2;
    rad_solution *s = NULL;
    if (rad_solution_create(sc, m, &s, NULL))
        return NULL;
    set_provenance(s, "jacobi");
    set_B(s);
    /* F from a unit square to the parallel unit square one unit away is
     * 0.1998 (Hottel); each ceiling triangle takes half by symmetry. */
    const uint32_t c0[2] = {1, 2};
    const float v0[2] = {0.0999f, 0.0999f};
    const uint32_t c2[1] = {0};
    const float v2[1] = {0.1998f};
    if (rad_matrix_set_row(s->F, 0, 2, c0, v0, NULL) ||
        rad_matrix_set_row(s->F, 2, 1, c2, v2, NULL)) {
        rad_solution_destroy(s);
        return NULL;
    }
    return s;
}

/* One band, 16×10 floor (160 patches) and a lamp: columns beyond 127. */
static rad_solution *make_wide(void)
{
    rad_scene *sc = rad_scene_create(1, "wide.gltf");
    if (!sc)
        return NULL;
    double w = 0.8, l = 0.0, e = 0.0, le = 100.0;
    int rc = rad_scene_add_material(sc, "floor", &w, &e, NULL, NULL, NULL, NULL);
    rc |= rad_scene_add_material(sc, "lamp", &l, &le, NULL, NULL, NULL, NULL);
    rc |= rad_scene_add_object(sc, "floor", NULL, NULL, NULL);
    rc |= rad_scene_add_object(sc, "lamp", NULL, NULL, NULL);
    const rad_vec3 fl[4] = {{0, 0, 0}, {16, 0, 0}, {16, 10, 0}, {0, 10, 0}};
    const rad_vec3 la[4] = {{7, 4, 3}, {7, 6, 3}, {9, 6, 3}, {9, 4, 3}};
    rc |= add_poly(sc, "floor/0/0", 0, 0, fl, 4, 16, 10);
    rc |= add_poly(sc, "lamp/0/0", 1, 1, la, 4, 1, 1);
    rc |= rad_scene_add_camera(sc, "cam", rad_v3(8, -10, 5), rad_v3(8, 5, 0), rad_v3(0, 0, 1),
                               50.0, 1.5, NULL, NULL, NULL);
    rad_mesh *m = NULL;
    if (rc || rad_mesh_build(sc, NULL, &m, NULL)) {
        rad_scene_destroy(sc);
        return NULL;
    }
    rad_solution *s = NULL;
    if (rad_solution_create(sc, m, &s, NULL))
        return NULL;
    set_provenance(s, "progressive");
    s->residual = INFINITY; /* allowed: no sweep measured */
    set_B(s);
    if (fill_rows(s, pick_wide)) {
        rad_solution_destroy(s);
        return NULL;
    }
    return s;
}

/* ----------------------------------------------------------- comparison */

static int same_bits(const void *a, const void *b, size_t n)
{
    return n == 0 || memcmp(a, b, n) == 0;
}

static int same_str(const char *a, const char *b)
{
    return (a == NULL && b == NULL) || (a && b && strcmp(a, b) == 0);
}

/* Every field of b equals a's, doubles and floats bit for bit. */
static void check_same(const rad_solution *a, const rad_solution *b)
{
    CHECK(a && b);
    if (!a || !b)
        return;
    const rad_scene *x = a->scene, *y = b->scene;
    CHECK(same_str(x->source, y->source));
    CHECK(x->band_count == y->band_count && a->band_count == b->band_count);
    for (uint32_t k = 0; k < RAD_MAX_BANDS; k++)
        CHECK(same_str(x->band_names[k], y->band_names[k]));
    uint32_t nb = x->band_count;
    CHECK(x->material_count == y->material_count);
    for (uint32_t i = 0; i < x->material_count && i < y->material_count; i++) {
        const rad_material *p = &x->materials[i], *q = &y->materials[i];
        CHECK(same_str(p->name, q->name));
        CHECK(same_bits(p->rho, q->rho, nb * sizeof(double)));
        CHECK(same_bits(p->emission, q->emission, nb * sizeof(double)));
        CHECK(same_bits(p->transmit, q->transmit, nb * sizeof(double)));
    }
    CHECK(x->object_count == y->object_count);
    for (uint32_t i = 0; i < x->object_count && i < y->object_count; i++)
        CHECK(same_str(x->objects[i].name, y->objects[i].name));
    CHECK(x->polygon_count == y->polygon_count && x->point_count == y->point_count);
    for (uint32_t i = 0; i < x->polygon_count && i < y->polygon_count; i++) {
        const rad_polygon *p = &x->polygons[i], *q = &y->polygons[i];
        CHECK(same_str(p->name, q->name));
        CHECK(p->first_point == q->first_point && p->point_count == q->point_count);
        CHECK(p->material == q->material && p->object == q->object);
        CHECK(p->subdiv_u == q->subdiv_u && p->subdiv_v == q->subdiv_v);
        CHECK(same_bits(&p->normal, &q->normal, sizeof p->normal));
        CHECK(same_bits(&p->area, &q->area, sizeof p->area));
    }
    if (x->point_count == y->point_count)
        CHECK(same_bits(x->points, y->points, x->point_count * sizeof *x->points));
    CHECK(x->camera_count == y->camera_count);
    for (uint32_t i = 0; i < x->camera_count && i < y->camera_count; i++) {
        const rad_camera *p = &x->cameras[i], *q = &y->cameras[i];
        CHECK(same_str(p->name, q->name));
        CHECK(same_bits(&p->eye, &q->eye, sizeof p->eye));
        CHECK(same_bits(&p->target, &q->target, sizeof p->target));
        CHECK(same_bits(&p->up, &q->up, sizeof p->up));
        CHECK(same_bits(&p->yfov_deg, &q->yfov_deg, sizeof(double)));
        CHECK(same_bits(&p->aspect, &q->aspect, sizeof(double)));
    }

    const rad_mesh *m = a->mesh, *n = b->mesh;
    CHECK(m->vertex_count == n->vertex_count && m->patch_count == n->patch_count);
    if (m->vertex_count == n->vertex_count) {
        CHECK(same_bits(m->vertices, n->vertices, m->vertex_count * sizeof *m->vertices));
        CHECK(same_bits(m->vertex_boundary, n->vertex_boundary, m->vertex_count));
    }
    for (uint32_t i = 0; i < m->patch_count && i < n->patch_count; i++) {
        const rad_patch *p = &m->patches[i], *q = &n->patches[i];
        CHECK(same_bits(p->v, q->v, sizeof p->v));
        CHECK(p->polygon == q->polygon && p->object == q->object && p->material == q->material);
        CHECK(same_bits(&p->center, &q->center, sizeof p->center));
        CHECK(same_bits(&p->normal, &q->normal, sizeof p->normal));
        CHECK(same_bits(&p->area, &q->area, sizeof p->area));
        /* the two sides of sheets are paired again from the layout */
        CHECK(!m->twin == !n->twin);
        if (m->twin && n->twin)
            CHECK(m->twin[i] == n->twin[i]);
    }

    const rad_matrix *F = a->F, *G = b->F;
    CHECK(F->n == G->n && F->rows_done == G->rows_done);
    for (uint32_t i = 0; i < F->n && i < G->n; i++) {
        CHECK(F->row_done[i] == G->row_done[i]);
        if (!F->row_done[i] || !G->row_done[i])
            continue;
        CHECK(F->row_count[i] == G->row_count[i]);
        if (F->row_count[i] != G->row_count[i] || !F->entries_loaded || !G->entries_loaded)
            continue;
        const uint32_t *fc, *gc;
        const float *fv, *gv;
        uint32_t c = test_row(F, i, 0, &fc, &fv);
        test_row(G, i, 1, &gc, &gv);
        CHECK(same_bits(fc, gc, c * sizeof(uint32_t)));
        CHECK(same_bits(fv, gv, c * sizeof(float)));
    }

    if (m->patch_count == n->patch_count && a->band_count == b->band_count) {
        size_t bytes = (size_t)m->patch_count * a->band_count * sizeof(double);
        CHECK(same_bits(a->rho, b->rho, bytes));
        CHECK(same_bits(a->emission, b->emission, bytes));
        CHECK(same_bits(a->B, b->B, bytes));
    }
    CHECK(same_bits(&a->patch_size, &b->patch_size, sizeof(double)));
    CHECK(a->resolution == b->resolution);
    CHECK(strcmp(a->solver, b->solver) == 0);
    CHECK(same_bits(&a->tolerance, &b->tolerance, sizeof(double)));
    CHECK(a->iterations == b->iterations);
    CHECK(same_bits(&a->residual, &b->residual, sizeof(double)));
    CHECK(a->rows_computed == b->rows_computed);
    CHECK(a->lights_computed == b->lights_computed);
    CHECK(x->light_count == y->light_count);
    for (uint32_t l = 0; l < x->light_count && l < y->light_count; l++) {
        const rad_light *p = &x->lights[l], *q = &y->lights[l];
        CHECK(same_str(p->name, q->name) && p->kind == q->kind);
        CHECK(same_bits(&p->position, &q->position, sizeof p->position));
        CHECK(same_bits(&p->direction, &q->direction, sizeof p->direction));
        CHECK(same_bits(&p->inner_cone, &q->inner_cone, sizeof(double)));
        CHECK(same_bits(&p->outer_cone, &q->outer_cone, sizeof(double)));
        CHECK(same_bits(p->intensity, q->intensity, nb * sizeof(double)));
        CHECK(same_bits(a->light_intensity + l * nb, b->light_intensity + l * nb,
                        nb * sizeof(double)));
        const rad_light_power *u = &a->light_power[l], *v = &b->light_power[l];
        CHECK(u->present == v->present && u->count == v->count);
        if (u->count == v->count && u->count) {
            CHECK(same_bits(u->patch, v->patch, u->count * sizeof(uint32_t)));
            CHECK(same_bits(u->power, v->power, u->count * sizeof(float)));
        }
    }
    for (int k = 0; k < RAD_STAGE_COUNT; k++) {
        CHECK(same_bits(&a->stages[k].seconds, &b->stages[k].seconds, sizeof(double)));
        CHECK(a->stages[k].reused == b->stages[k].reused);
    }
}

/* The invariants solution.h promises of anything the reader returns. */
static int invariants_hold(const rad_solution *s)
{
    const rad_scene *sc = s->scene;
    if (!sc || !s->mesh || !s->F || s->F->n != s->mesh->patch_count ||
        s->band_count != sc->band_count)
        return 0;
    if (rad_mesh_check(s->mesh, sc->polygon_count, sc->object_count, sc->material_count, NULL) ||
        rad_matrix_check(s->F, NULL))
        return 0;
    uint32_t rows = 0;
    for (uint32_t i = 0; i < s->F->n; i++)
        rows += s->F->row_done[i];
    if (rows != s->F->rows_done)
        return 0;
    size_t count = (size_t)s->mesh->patch_count * s->band_count;
    for (size_t k = 0; k < count; k++)
        if (!(s->rho[k] >= 0 && s->rho[k] < 1) || !(s->emission[k] >= 0) ||
            !isfinite(s->emission[k]) || !(s->B[k] >= 0) || !isfinite(s->B[k]))
            return 0;
    /* punctual lights: scene.h's rules, and sparse power in range */
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const rad_light *L = &sc->lights[l];
        const rad_light_power *lp = &s->light_power[l];
        if (fabs(rad_length(L->direction) - 1.0) > 1e-9 || !rad_finite3(L->position) ||
            (L->kind == RAD_LIGHT_SPOT &&
             !(L->inner_cone >= 0 && L->inner_cone < L->outer_cone && L->outer_cone <= M_PI / 2)))
            return 0;
        for (uint32_t b = 0; b < s->band_count; b++) {
            double I = s->light_intensity[(size_t)l * s->band_count + b];
            if (!(L->intensity[b] >= 0) || !isfinite(L->intensity[b]) || !(I >= 0) || !isfinite(I))
                return 0;
        }
        if (lp->count > s->mesh->patch_count || (!lp->present && lp->count))
            return 0;
        for (uint32_t k = 0; k < lp->count; k++)
            if (lp->patch[k] >= s->mesh->patch_count || (k && lp->patch[k] <= lp->patch[k - 1]) ||
                !(lp->power[k] > 0) || !isfinite(lp->power[k]))
                return 0;
    }
    return 1;
}

/* ------------------------------------------------------------ file helpers */

static char tmpdir[256];

static void path_in(char *out, size_t size, const char *name)
{
    snprintf(out, size, "%s/%s", tmpdir, name);
}

static uint8_t *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *buf = malloc(n > 0 ? (size_t)n : 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *size = (size_t)n;
    return buf;
}

/* s written to `name` in the test directory (its path into path[600]) and
 * read back as bytes, a version 7 image (NULL on failure). */
static uint8_t *written_image(const rad_solution *s, const char *name, char path[600],
                              size_t *size)
{
    rad_error e = {0};
    path_in(path, 600, name);
    CHECK_MSG(rad_solution_write(s, path, &e) == RAD_OK, "%s", e.message);
    uint8_t *buf = slurp(path, size);
    CHECK(buf && rd32(buf + 8) == 8);
    return buf;
}

static int spit(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    size_t w = fwrite(data, 1, size, f);
    return fclose(f) == 0 && w == size ? 0 : -1;
}

/* Entries of dir whose name contains ".tmp.": left-over temporary files. */
static int temp_files_in(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strstr(e->d_name, ".tmp."))
            n++;
    closedir(d);
    return n;
}

static void remove_tree(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    char p[512];
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        struct stat st;
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode))
            remove_tree(p);
        else
            unlink(p);
    }
    closedir(d);
    rmdir(dir);
}

/* The rgb fixture serialised once (version 6), shared by the byte-level
 * tests; and the same fixture as version 2 wrote it, frozen in the corpus. */
static uint8_t *golden, *old_golden;
static size_t golden_size, old_golden_size;
#define CORPUS "test/fuzz/corpus/solution/"

static int load_golden(void)
{
    if (golden)
        return 1;
    rad_solution *s = make_rgb();
    char p[300];
    path_in(p, sizeof p, "golden.sol");
    rad_error e;
    if (!s || rad_solution_write(s, p, &e)) {
        rad_solution_destroy(s);
        return 0;
    }
    rad_solution_destroy(s);
    golden = slurp(p, &golden_size);
    return golden != NULL;
}

static int load_old_golden(void)
{
    if (!old_golden)
        old_golden = slurp(CORPUS "rgb-room", &old_golden_size);
    return old_golden != NULL;
}

/* A copy of img (a version 6 image) with `cut` bytes removed at `at` and n
 * bytes inserted there, inside the section whose body starts at `body`; the
 * lengths, offsets and CRCs fixed up. */
static uint8_t *v6_splice(const uint8_t *img, size_t size, size_t body, size_t at, size_t cut,
                          const void *bytes, size_t n, size_t *out_size)
{
    uint8_t *b = malloc(size - cut + n + 1);
    memcpy(b, img, at);
    if (n)
        memcpy(b + at, bytes, n);
    memcpy(b + at + n, img + at + cut, size - at - cut);
    *out_size = size - cut + n;
    size_t x = v6_index_at(img) - cut + n;
    wr64(b + 16, x);
    for (uint32_t q = 0; q < v6_count(b); q++) {
        uint8_t *e = b + x + 8 + 32 * (size_t)q;
        uint64_t off = rd64(e + 8);
        if (off == body)
            wr64(e + 16, rd64(e + 16) - cut + n);
        else if (off > body)
            wr64(e + 8, off - cut + n);
    }
    v6_fix(b, *out_size);
    return b;
}

/* A copy of img without the section `tag`: its body and its index entry
 * gone, the offsets and CRCs made to agree. */
static uint8_t *v6_drop_section(const uint8_t *img, size_t size, const char *tag,
                                size_t *out_size)
{
    uint64_t len = 0;
    size_t at = v6_find(img, size, tag, &len);
    CHECK(at > 0);
    uint8_t *b = v6_splice(img, size, at, at, (size_t)len, NULL, 0, out_size);
    size_t x = v6_index_at(b);
    uint32_t count = v6_count(b), q = 0;
    while (q < count && memcmp(b + x + 8 + 32 * (size_t)q, tag, 4) != 0)
        q++;
    CHECK(q < count);
    memmove(b + x + 8 + 32 * (size_t)q, b + x + 8 + 32 * (size_t)(q + 1),
            *out_size - (x + 8 + 32 * (size_t)(q + 1)));
    wr32(b + x, count - 1);
    *out_size -= 32;
    v6_fix(b, *out_size);
    return b;
}

/* Every cut of an image, with checksums on and off: refused
 * (RAD_ERR_CORRUPT or RAD_ERR_PARSE, no solution).  How many were not, and
 * the first such length in *first. */
static size_t cuts_accepted(const uint8_t *img, size_t size, size_t *first)
{
    size_t bad = 0;
    *first = SIZE_MAX;
    for (size_t k = 0; k < size; k++) {
        for (int sum = 0; sum < 2; sum++) {
            rad_solution *s = NULL;
            rad_error e = {0};
            int rc = rad_solution_parse(img, k, "cut", sum, &s, &e);
            if (!((rc == RAD_ERR_CORRUPT || rc == RAD_ERR_PARSE) && s == NULL)) {
                bad++;
                *first = *first == SIZE_MAX ? k : *first;
            }
            rad_solution_destroy(s);
        }
    }
    return bad;
}

/* What byte flips did: with the checksums, accepted (must not be) or
 * refused uncleanly (no message naming the file, or a solution handed
 * back); without, accepted (a changed value still in range may be) and
 * then breaking an invariant (must not). */
typedef struct flip_tally {
    size_t accepted, unclean, accepted_nosum, bad_nosum, first;
} flip_tally;

static void tally_flip(const uint8_t *buf, size_t size, size_t k, flip_tally *t)
{
    rad_solution *s = NULL;
    rad_error e = {0};
    int rc = rad_solution_parse(buf, size, "flip", 1, &s, &e);
    if (rc == RAD_OK) {
        t->accepted++;
        t->first = t->first == SIZE_MAX ? k : t->first;
    } else if (s || (rc != RAD_ERR_CORRUPT && rc != RAD_ERR_PARSE) ||
               strncmp(e.message, "flip: ", 6) != 0) {
        t->unclean++;
    }
    rad_solution_destroy(s);
    /* Without the checksums the structure checks must hold alone. */
    s = NULL;
    rc = rad_solution_parse(buf, size, "flip", 0, &s, &e);
    if (rc == RAD_OK) {
        t->accepted_nosum++;
        if (!s || !invariants_hold(s))
            t->bad_nosum++;
    } else if (s || rc == RAD_ERR_USAGE) {
        t->bad_nosum++;
    }
    rad_solution_destroy(s);
}

/* ------------------------------------------------------------------- tests */

TEST(crc_matches_published_check_value)
{
    /* The catalogue check value of CRC-64/XZ: validates this file's CRC,
     * which the layout tests below use to judge solfile/read.c's. */
    CHECK(crc64_xz((const uint8_t *)"123456789", 9) == 0x995DC9BBDF1939FAull);
    CHECK(crc64_xz(NULL, 0) == 0);
}

TEST(stage_names)
{
    CHECK(strcmp(rad_stage_name(RAD_STAGE_LOAD), "load") == 0);
    CHECK(strcmp(rad_stage_name(RAD_STAGE_MESH), "mesh") == 0);
    CHECK(strcmp(rad_stage_name(RAD_STAGE_FORM_FACTORS), "form_factors") == 0);
    CHECK(strcmp(rad_stage_name(RAD_STAGE_SOLVE), "solve") == 0);
    CHECK(strcmp(rad_stage_name(RAD_STAGE_STORE), "store") == 0);
}

TEST(create_copies_materials)
{
    rad_solution *s = make_rgb();
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->band_count == 3);
    CHECK(s->F->n == s->mesh->patch_count);
    /* floor 3×2 + wall 2×2 + triangle 2² + pentagon fan 5 + lamp 1 */
    CHECK(s->mesh->patch_count == 6 + 4 + 4 + 5 + 1);
    CHECK(s->mesh->twin == NULL);
    rad_solution_destroy(s);

    /* Fresh: ρ and E from each patch's material, B = E, no rows. */
    rad_scene *sc = rad_scene_create(3, NULL);
    uint32_t w, l;
    CHECK(rad_scene_add_material(sc, "w", rho_white, NULL, NULL, NULL, &w, NULL) == RAD_OK);
    CHECK(rad_scene_add_material(sc, "l", rho_lamp, e_lamp, NULL, NULL, &l, NULL) == RAD_OK);
    CHECK(rad_scene_add_object(sc, "o", NULL, NULL, NULL) == RAD_OK);
    const rad_vec3 q[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    const rad_vec3 t[4] = {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}};
    CHECK(add_poly(sc, "a", 0, w, q, 4, 2, 1) == RAD_OK);
    CHECK(add_poly(sc, "b", 0, l, t, 4, 1, 1) == RAD_OK);
    rad_mesh *m = NULL;
    CHECK(rad_mesh_build(sc, NULL, &m, NULL) == RAD_OK);
    rad_error e;
    CHECK(rad_solution_create(sc, m, &s, &e) == RAD_OK);
    if (!s)
        return;
    CHECK(s->F->rows_done == 0);
    for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
        const rad_material *mat = &s->scene->materials[s->mesh->patches[i].material];
        for (uint32_t b = 0; b < 3; b++) {
            CHECK(s->rho[i * 3 + b] == mat->rho[b]);
            CHECK(s->emission[i * 3 + b] == mat->emission[b]);
            CHECK(s->B[i * 3 + b] == mat->emission[b]);
        }
    }
    rad_solution_destroy(s);
    rad_solution_destroy(NULL);

    /* Misuse: both inputs are consumed and the error says so. */
    s = (rad_solution *)&e;
    CHECK(rad_solution_create(rad_scene_create(1, NULL), NULL, &s, &e) == RAD_ERR_USAGE);
    CHECK(s == NULL);
}

TEST(round_trip_is_bit_exact)
{
    rad_solution *(*make[3])(void) = {make_rgb, make_grey, make_wide};
    for (int v = 0; v < 3; v++) {
        rad_solution *s = make[v]();
        CHECK(s != NULL);
        if (!s)
            continue;
        if (v == 2) { /* a gap of 150 columns: a two-byte varint */
            const uint32_t col[2] = {0, 150};
            const float val[2] = {0.001f, 0.002f};
            CHECK(rad_matrix_set_row(s->F, 5, 2, col, val, NULL) == RAD_OK);
        }
        char p[300];
        path_in(p, sizeof p, "round.sol");
        rad_error e;
        int rc = rad_solution_write(s, p, &e);
        CHECK_MSG(rc == RAD_OK, "%s", e.message);
        rad_solution *r = NULL;
        rc = rad_solution_read(p, &r, &e);
        CHECK_MSG(rc == RAD_OK, "%s", e.message);
        check_same(s, r);
        CHECK(r && invariants_hold(r));
        /* rows missing in the fixture stay missing */
        if (r && r->mesh->patch_count > 1)
            CHECK(r->F->row_done[1] == 0);
        /* writing the read solution gives the same bytes */
        char p2[300];
        path_in(p2, sizeof p2, "round2.sol");
        CHECK(r && rad_solution_write(r, p2, &e) == RAD_OK);
        size_t n1 = 0, n2 = 0;
        uint8_t *b1 = slurp(p, &n1), *b2 = slurp(p2, &n2);
        CHECK(b1 && b2 && n1 == n2 && memcmp(b1, b2, n1) == 0);
        if (v == 2 && r) {
            /* the wide fixture must exercise multi-byte column gaps */
            int multi = 0;
            for (uint32_t i = 0; i < r->F->n; i++) {
                const uint32_t *c;
                const float *f;
                uint32_t cnt = test_row(r->F, i, 0, &c, &f);
                for (uint32_t k = 0; k < cnt; k++)
                    multi |= (k ? c[k] - c[k - 1] : c[0]) >= 128;
            }
            CHECK(multi);
        }
        free(b1);
        free(b2);
        rad_solution_destroy(r);
        rad_solution_destroy(s);
    }
    char p[300];
    path_in(p, sizeof p, "");
    CHECK(temp_files_in(p) == 0);
}

/* F with no rows, and F whose present rows are all empty: both legal, and
 * distinct (an empty row was computed and sees nothing; a missing row was
 * never computed). */
TEST(matrix_without_entries_round_trips)
{
    for (int variant = 0; variant < 2; variant++) {
        rad_solution *s = make_grey();
        CHECK(s != NULL);
        if (!s)
            return;
        rad_matrix_destroy(s->F);
        s->F = rad_matrix_create(s->mesh->patch_count);
        if (variant == 1)
            for (uint32_t i = 0; i < s->mesh->patch_count; i++)
                CHECK(rad_matrix_set_row(s->F, i, 0, NULL, NULL, NULL) == RAD_OK);
        char p[300];
        path_in(p, sizeof p, "empty.sol");
        rad_error e;
        CHECK_MSG(rad_solution_write(s, p, &e) == RAD_OK, "%s", e.message);
        rad_solution *r = NULL;
        CHECK_MSG(rad_solution_read(p, &r, &e) == RAD_OK, "%s", e.message);
        check_same(s, r);
        CHECK(r && r->F->rows_done == (variant ? r->mesh->patch_count : 0));
        rad_solution_destroy(r);
        rad_solution_destroy(s);
    }
}

/* Version 6: the header, the index at the end (entries tiling the file
 * from byte 32 to the index, each CRC right by this file's own CRC), the
 * sections in the writer's order, MATRIX as row blocks of row records. */
TEST(layout_follows_the_format)
{
    CHECK(load_golden());
    if (!golden)
        return;
    const uint8_t *b = golden;
    CHECK(memcmp(b, "RADSOL\r\n", 8) == 0);
    CHECK(rd32(b + 8) == 8);
    CHECK(rd32(b + 12) == 0);
    size_t x = v6_index_at(b);
    uint32_t count = rd32(b + x);
    CHECK(rd32(b + x + 4) == 8); /* the version again, under the index's CRC */
    CHECK(x + 8 + 32ull * count == golden_size);
    CHECK(rd64(b + 24) == crc64_xz(b + x, golden_size - x));
    const char *order[8] = {"MTRX", "INFO", "SCEN", "MESH", "ROWS", "PDAT", "IRRD", "LGHT"};
    CHECK(count == 8);
    size_t off = 32;
    for (uint32_t q = 0; q < count && q < 8; q++) {
        const uint8_t *e = v6_entry(b, q);
        CHECK(memcmp(e, order[q], 4) == 0 && rd32(e + 4) == 0);
        CHECK(rd64(e + 8) == off);
        size_t len = (size_t)rd64(e + 16);
        CHECK(off + len <= x && rd64(e + 24) == crc64_xz(b + off, len));
        off += len;
    }
    CHECK(off == x);
    rad_solution *s = make_rgb();
    if (!s)
        return;
    uint32_t n = s->mesh->patch_count;
    /* MATRIX: n, reserved, rows key; then blocks of records in row order */
    uint64_t len;
    size_t m = v6_find(b, golden_size, "MTRX", &len);
    CHECK(m == 32 && rd32(b + m) == n && rd32(b + m + 4) == 0 && rd64(b + m + 8) == s->F->key);
    uint32_t rows = 0;
    for (size_t at = m + 16; at < m + len;) {
        CHECK(memcmp(b + at, "RBLK", 4) == 0);
        uint64_t bl = rd64(b + at + 8);
        CHECK(rd64(b + at + 16) == crc64_xz(b + at + 24, (size_t)bl));
        uint32_t in_block = rd32(b + at + 4);
        size_t r = at + 24;
        int64_t prev = -1;
        for (uint32_t k = 0; k < in_block; k++) {
            uint32_t i = rd32(b + r), c = rd32(b + r + 4);
            CHECK((int64_t)i > prev && s->F->row_done[i] && c == s->F->row_count[i]);
            prev = i;
            /* the values as float32, then the varint gaps */
            const uint32_t *fc;
            const float *fv;
            test_row(s->F, i, 0, &fc, &fv);
            CHECK(same_bits(b + r + 8, fv, 4ull * c));
            r += 8 + 4ull * c;
            for (uint32_t q = 0; q < c; q++) {
                uint32_t g = 0;
                for (int shift = 0;; shift += 7) {
                    g |= (uint32_t)(b[r] & 0x7f) << shift;
                    if (!(b[r++] & 0x80))
                        break;
                }
                CHECK(g == (q ? fc[q] - fc[q - 1] : fc[0]));
            }
        }
        CHECK(r == at + 24 + bl);
        rows += in_block;
        at += 24 + (size_t)bl;
    }
    CHECK(rows == s->F->rows_done);
    /* ROWS: n, then per row 0 (absent) or count + 1 */
    size_t ro = v6_find(b, golden_size, "ROWS", &len);
    CHECK(ro && rd32(b + ro) == n && len == 4 + n); /* every count below 127: one byte each */
    for (uint32_t i = 0; ro && i < n && len == 4 + n; i++)
        CHECK(b[ro + 4 + i] == (s->F->row_done[i] ? s->F->row_count[i] + 1 : 0));
    /* PATCHDATA: n, bands, then ρ, E and B as float64 */
    size_t pd = v6_find(b, golden_size, "PDAT", &len);
    if (pd) {
        CHECK(len == 8 + 3ull * 8 * n * 3);
        double b0;
        uint64_t bits = rd64(b + pd + 8 + 2ull * 8 * n * 3);
        memcpy(&b0, &bits, 8);
        CHECK(same_bits(&b0, &s->B[0], 8));
    }
    /* IRRADIANCE: n, bands, then H as float64, what the solution's rows give */
    size_t ir = v6_find(b, golden_size, "IRRD", &len);
    double *H = malloc((size_t)n * 3 * sizeof *H);
    CHECK(ir && len == 8 + 8ull * n * 3 && rad_solution_irradiance(s, H, NULL) == RAD_OK);
    for (uint32_t k = 0; ir && k < n * 3; k++) {
        double h;
        uint64_t bits = rd64(b + ir + 8 + 8ull * k);
        memcpy(&h, &bits, 8);
        CHECK(same_bits(&h, &H[k], 8));
    }
    free(H);
    /* LIGHTS: light count, bands, renders computed, then the first light's name */
    size_t lg = v6_find(b, golden_size, "LGHT", &len);
    CHECK(lg && rd32(b + lg) == 2 && rd32(b + lg + 4) == 3 && rd64(b + lg + 8) == 1);
    CHECK(lg && rd32(b + lg + 16) == 9 && memcmp(b + lg + 20, "desk lamp", 9) == 0);
    /* INFO ends with the announced optional sections: LIGHTS only */
    size_t in = v6_find(b, golden_size, "INFO", &len);
    CHECK(in && b[in + len - 1] == 1);
    rad_solution_destroy(s);
}

/* The corpus's rgb-room, as version 2 wrote it (before the index): its
 * layout, and it reads back as the fixture it was written from. */
TEST(version_2_file_reads_as_written)
{
    CHECK(load_old_golden());
    if (!old_golden)
        return;
    const uint8_t *b = old_golden;
    size_t golden_size = old_golden_size;
    CHECK(memcmp(b, "RADSOL\r\n", 8) == 0);
    CHECK(rd32(b + 8) == 2); /* the fixture has punctual lights */
    CHECK(rd32(b + 12) == 0);
    CHECK(rd64(b + 16) == golden_size - 32);
    CHECK(rd64(b + 24) == crc64_xz(b + 32, golden_size - 32));
    /* sections in the fixed order, lengths tiling the payload exactly */
    const char *order[6] = {"INFO", "SCEN", "MESH", "MTRX", "PDAT", "LGHT"};
    size_t off = 32;
    for (int k = 0; k < 6; k++) {
        CHECK(off + 12 <= golden_size);
        if (off + 12 > golden_size)
            return;
        CHECK(memcmp(b + off, order[k], 4) == 0);
        off += 12 + (size_t)rd64(b + off + 4);
    }
    CHECK(off == golden_size);
    /* MATRIX starts with n, then the number of rows present */
    rad_solution *s = make_rgb();
    uint64_t len;
    rad_solution *r = NULL;
    rad_error e;
    CHECK_MSG(rad_solution_read(CORPUS "rgb-room", &r, &e) == RAD_OK, "%s", e.message);
    check_same(s, r);
    CHECK(r && invariants_hold(r) && r->irradiance == NULL && !rad_solution_matrix_file(r));
    rad_solution_destroy(r);
    size_t m = find_section(b, golden_size, "MTRX", &len);
    CHECK(m && s && rd32(b + m) == s->mesh->patch_count);
    CHECK(m && s && rd32(b + m + 4) == s->F->rows_done);
    /* PATCHDATA: n, bands, then ρ, E and B as float64 */
    size_t pd = find_section(b, golden_size, "PDAT", &len);
    if (pd && s) {
        uint32_t n = s->mesh->patch_count;
        CHECK(len == 8 + 3ull * 8 * n * 3);
        double b0;
        uint64_t bits = rd64(b + pd + 8 + 2ull * 8 * n * 3);
        memcpy(&b0, &bits, 8);
        CHECK(same_bits(&b0, &s->B[0], 8));
    }
    /* LIGHTS: light count, bands, renders computed, then the first light's name */
    size_t lg = find_section(b, golden_size, "LGHT", &len);
    CHECK(lg && rd32(b + lg) == 2 && rd32(b + lg + 4) == 3 && rd64(b + lg + 8) == 1);
    CHECK(lg && rd32(b + lg + 16) == 9 && memcmp(b + lg + 20, "desk lamp", 9) == 0);
    rad_solution_destroy(s);

}

/* Versions 1-5: every cut of a file image refused, with and without a
 * header made to agree (the shared body of the truncation tests). */
static void old_cuts_refused(const uint8_t *golden, size_t golden_size)
{
    size_t first, bad = cuts_accepted(golden, golden_size, &first);
    CHECK_MSG(bad == 0, "%zu truncations accepted, first at %zu", bad, first);

    /* The same cuts with the header made to agree (size and CRC recomputed):
     * now only the section structure can notice, at every byte. */
    uint8_t *buf = malloc(golden_size);
    memcpy(buf, golden, golden_size);
    uint64_t reg = ~0ull;
    bad = 0;
    first = SIZE_MAX;
    for (size_t k = 32; k < golden_size; k++) {
        wr64(buf + 16, k - 32);
        wr64(buf + 24, reg ^ ~0ull);
        rad_solution *s = NULL;
        rad_error e = {0};
        int rc = rad_solution_parse(buf, k, "cut", 1, &s, &e);
        if (rc != RAD_ERR_CORRUPT || s || strncmp(e.message, "cut: ", 5) != 0) {
            bad++;
            if (first == SIZE_MAX)
                first = k;
        }
        rad_solution_destroy(s);
        reg = crc_step(reg, golden[k]);
    }
    CHECK_MSG(bad == 0, "%zu consistent truncations accepted, first at %zu", bad, first);
    /* and the untruncated file still parses through the same path */
    fix_header(buf, golden_size);
    rad_solution *s = NULL;
    CHECK(rad_solution_parse(buf, golden_size, "whole", 1, &s, NULL) == RAD_OK);
    rad_solution_destroy(s);
    free(buf);

    /* a message of the required shape */
    rad_error e;
    CHECK(rad_solution_parse(golden, 1000, "x.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    char want[96];
    snprintf(want, sizeof want, "x.sol: truncated: 1000 of %zu bytes", golden_size);
    CHECK_MSG(strcmp(e.message, want) == 0, "%s", e.message);
}

/* Versions 1-5: every byte flip of a file image refused by the checksum,
 * and what the structure checks alone let through keeps every invariant. */
static void old_flips_refused(const uint8_t *golden, size_t golden_size)
{
    uint8_t *buf = malloc(golden_size);
    memcpy(buf, golden, golden_size);
    flip_tally t = {.first = SIZE_MAX};
    for (size_t k = 0; k < golden_size; k++) {
        /* each byte inverted, and one bit of each byte (bit k mod 8) */
        const uint8_t masks[2] = {0xFF, (uint8_t)(1u << (k % 8))};
        for (int f = 0; f < 2; f++) {
            buf[k] ^= masks[f];
            tally_flip(buf, golden_size, k, &t);
            buf[k] ^= masks[f];
        }
    }
    size_t accepted = t.accepted, first = t.first, accepted_nosum = t.accepted_nosum;
    size_t unclean = t.unclean, bad_nosum = t.bad_nosum;
    CHECK_MSG(accepted == 0, "%zu flips accepted, first at byte %zu", accepted, first);
    CHECK(unclean == 0);
    CHECK(bad_nosum == 0);
    /* Sanity: without the checksum some flips (in values) do get through,
     * and most (in structure) do not; both branches were exercised. */
    CHECK(accepted_nosum > 0 && accepted_nosum < 2 * golden_size);
    printf("     %zu bytes, 2 flips each: %zu accepted without the checksum\n", golden_size,
           accepted_nosum);
    rad_error e;
    buf[golden_size / 2] ^= 0x10;
    rad_solution *s = NULL;
    CHECK(rad_solution_parse(buf, golden_size, "c.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strcmp(e.message, "c.sol: checksum mismatch: the file is corrupt") == 0, "%s",
              e.message);
    free(buf);
}

TEST(version_2_cuts_and_flips_refused)
{
    CHECK(load_old_golden());
    if (old_golden) {
        old_cuts_refused(old_golden, old_golden_size);
        old_flips_refused(old_golden, old_golden_size);
    }
}

/* Every cut of the version 6 image refused; and every section cut short at
 * every byte, the offsets and CRCs made to agree: then only its structure
 * can notice, and it does. */
TEST(every_truncation_is_refused)
{
    CHECK(load_golden());
    if (!golden)
        return;
    size_t first, bad = cuts_accepted(golden, golden_size, &first);
    CHECK_MSG(bad == 0, "%zu truncations accepted, first at %zu", bad, first);
    bad = 0;
    first = SIZE_MAX;
    size_t x = v6_index_at(golden);
    for (uint32_t q = 0; q < v6_count(golden); q++) {
        const uint8_t *e = v6_entry(golden, q);
        size_t body = (size_t)rd64(e + 8), len = (size_t)rd64(e + 16);
        for (size_t k = body; k < body + len; k++) {
            size_t n = 0;
            uint8_t *c = v6_splice(golden, golden_size, body, k, body + len - k, NULL, 0, &n);
            rad_solution *s = NULL;
            rad_error err = {0};
            int rc = rad_solution_parse(c, n, "cut", 1, &s, &err);
            if (rc != RAD_ERR_CORRUPT || s || strncmp(err.message, "cut: ", 5) != 0) {
                bad++;
                first = first == SIZE_MAX ? k : first;
            }
            rad_solution_destroy(s);
            free(c);
        }
    }
    CHECK_MSG(bad == 0, "%zu consistent truncations accepted, first at %zu", bad, first);
    (void)x;
    /* messages of the required shape: a cut inside the index, a cut before it */
    rad_solution *s = NULL;
    rad_error e;
    CHECK(rad_solution_parse(golden, golden_size - 1, "x.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    char want[96];
    snprintf(want, sizeof want, "x.sol: truncated: %zu of %zu bytes", golden_size - 1, golden_size);
    CHECK_MSG(strcmp(e.message, want) == 0, "%s", e.message);
    CHECK(rad_solution_parse(golden, 1000, "x.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    snprintf(want, sizeof want, "x.sol: truncated: 1000 bytes, the index starts at %zu",
             v6_index_at(golden));
    CHECK_MSG(strcmp(e.message, want) == 0, "%s", e.message);
}

/* Every byte flip refused by a checksum (the section's, the index's or a
 * row block's), and what the structure checks alone let through keeps
 * every invariant.  A flip inside MATRIX spares a read without the
 * matrix: it reads back the same B, rows and counts. */
TEST(every_byte_flip_is_refused)
{
    CHECK(load_golden());
    if (!golden)
        return;
    uint8_t *buf = malloc(golden_size);
    memcpy(buf, golden, golden_size);
    uint64_t mlen;
    size_t m = v6_find(golden, golden_size, "MTRX", &mlen);
    rad_solution *view0 = NULL;
    CHECK(rad_solution_parse_parts(golden, golden_size, "v", 1, 0, &view0, NULL) == RAD_OK);
    flip_tally t = {.first = SIZE_MAX};
    size_t view_bad = 0;
    for (size_t k = 0; k < golden_size; k++) {
        const uint8_t masks[2] = {0xFF, (uint8_t)(1u << (k % 8))};
        for (int f = 0; f < 2; f++) {
            buf[k] ^= masks[f];
            tally_flip(buf, golden_size, k, &t);
            if (k >= m && k < m + mlen) {
                rad_solution *s = NULL;
                int rc = rad_solution_parse_parts(buf, golden_size, "view", 1, 0, &s, NULL);
                if (rc != RAD_OK || !s || !view0 || s->F->entries_loaded ||
                    !same_bits(s->B, view0->B, (size_t)s->mesh->patch_count * 3 * 8) ||
                    !same_bits(s->F->row_count, view0->F->row_count, 4ull * s->F->n))
                    view_bad++;
                rad_solution_destroy(s);
            }
            buf[k] ^= masks[f];
        }
    }
    CHECK_MSG(t.accepted == 0, "%zu flips accepted, first at byte %zu", t.accepted, t.first);
    CHECK(t.unclean == 0);
    CHECK(t.bad_nosum == 0);
    CHECK(view_bad == 0);
    CHECK(t.accepted_nosum > 0 && t.accepted_nosum < 2 * golden_size);
    printf("     %zu bytes, 2 flips each: %zu accepted without the checksums\n", golden_size,
           t.accepted_nosum);
    rad_error e;
    rad_solution *s = NULL;
    buf[m + mlen / 2] ^= 0x10;
    CHECK(rad_solution_parse(buf, golden_size, "c.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strcmp(e.message, "c.sol: section MATRIX: checksum mismatch: the file is corrupt") ==
                  0, "%s", e.message);
    rad_solution_destroy(view0);
    free(buf);
}



/* Sheets: a mesh with two-sided transmitting polygons round-trips, its
 * sides paired again on reading.  The corpus keeps the same room as
 * version 5 wrote it (INFO's announced sections, sheets): it reads as the
 * fixture, every cut and flip of it is refused, and the same bytes
 * labelled as version 2 read as a one-sided mesh that rad_resolve refuses
 * to solve again rather than drop the transmitted light. */
TEST(sheets_round_trip_and_version_5)
{
    rad_solution *s = make_sheets();
    CHECK(s && s->mesh->twin);
    if (!s)
        return;
    /* wall 2×2 and window fan 5, each twice */
    CHECK(s->mesh->patch_count == 6 + 2 * 4 + 4 + 2 * 5 + 1);
    CHECK(s->mesh->twin && s->mesh->twin[6] == 10 && s->mesh->twin[10] == 6);
    char p[300];
    path_in(p, sizeof p, "sheets.sol");
    rad_error e;
    CHECK_MSG(rad_solution_write(s, p, &e) == RAD_OK, "%s", e.message);
    rad_solution *r = NULL;
    CHECK_MSG(rad_solution_read(p, &r, &e) == RAD_OK, "%s", e.message);
    check_same(s, r);
    rad_solution_destroy(r);
    r = NULL;
    CHECK_MSG(rad_solution_read(CORPUS "sheets-room", &r, &e) == RAD_OK, "%s", e.message);
    check_same(s, r);
    rad_solution_destroy(r);
    size_t n = 0;
    uint8_t *img = slurp(CORPUS "sheets-room", &n);
    CHECK(img && n > 32 && rd32(img + 8) == 5);
    if (img) {
        old_cuts_refused(img, n);
        old_flips_refused(img, n);
        /* as version 2 (its sections without version 5's INFO byte): one-
         * sided, readable, not solvable again */
        uint64_t len;
        size_t info = find_section(img, n, "INFO", &len);
        CHECK(info && img[info + len - 1] == 1); /* announces LIGHTS only */
        memmove(img + info + len - 1, img + info + len, n - (info + len));
        n--;
        wr64(img + info - 8, len - 1);
        wr32(img + 8, 2);
        fix_header(img, n);
        r = NULL;
        CHECK_MSG(rad_solution_parse(img, n, "old.sol", 1, &r, &e) == RAD_OK, "%s", e.message);
        if (r) {
            CHECK(r->mesh->twin == NULL);
            rad_solve_options opt = {0};
            CHECK(rad_resolve(r, &opt, &e) == RAD_ERR_INVALID);
            CHECK_MSG(strstr(e.message, "object 'room': material 'red paint' transmits but its "
                                        "patches have no back side") != NULL,
                      "%s", e.message);
        }
        rad_solution_destroy(r);
    }
    free(img);
    rad_solution_destroy(s);
}

TEST(newer_version_and_foreign_files)
{
    CHECK(load_golden());
    if (!golden)
        return;
    uint8_t *buf = malloc(golden_size);
    memcpy(buf, golden, golden_size);
    wr32(buf + 8, 9);
    rad_solution *s = NULL;
    rad_error e;
    CHECK(rad_solution_parse(buf, golden_size, "new.sol", 1, &s, &e) == RAD_ERR_PARSE);
    CHECK_MSG(strcmp(e.message, "new.sol: format version 9 is newer than this program (8)") == 0,
              "%s", e.message);
    CHECK(s == NULL);
    free(buf);

    /* Garbage: random bytes, text, an empty file, a PNG signature. */
    uint8_t junk[4096];
    uint32_t x = 12345;
    for (size_t k = 0; k < sizeof junk; k++) {
        x = x * 1664525u + 1013904223u;
        junk[k] = (uint8_t)(x >> 24);
    }
    char p[300];
    path_in(p, sizeof p, "junk.sol");
    CHECK(spit(p, junk, sizeof junk) == 0);
    CHECK(rad_solution_read(p, &s, &e) == RAD_ERR_PARSE);
    char want[400];
    snprintf(want, sizeof want, "%s: not a radiosity solution file", p);
    CHECK_MSG(strcmp(e.message, want) == 0, "%s", e.message);
    const char *text = "polygon floor white\n  0 0 0\n";
    CHECK(rad_solution_parse(text, strlen(text), "t", 1, &s, &e) == RAD_ERR_PARSE);
    CHECK(rad_solution_parse("", 0, "t", 1, &s, &e) == RAD_ERR_PARSE);
    CHECK(rad_solution_parse(NULL, 0, "t", 0, &s, &e) == RAD_ERR_PARSE);
    CHECK(rad_solution_parse("\x89PNG\r\n\x1a\n", 8, "t", 1, &s, &e) == RAD_ERR_PARSE);
    /* a prefix of the magic is a truncated solution, not a foreign file */
    CHECK(rad_solution_parse("RADS", 4, "t", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK(s == NULL);

    path_in(p, sizeof p, "does-not-exist.sol");
    CHECK(rad_solution_read(p, &s, &e) == RAD_ERR_IO);
    CHECK(strstr(e.message, "does-not-exist.sol: cannot open") != NULL);
    path_in(p, sizeof p, "");
    CHECK(rad_solution_read(p, &s, &e) == RAD_ERR_IO); /* a directory */

    /* An index offset far from the end: refused before the index is read */
    uint8_t *early = malloc(golden_size);
    memcpy(early, golden, golden_size);
    wr64(early + 16, 32);
    path_in(p, sizeof p, "early.sol");
    CHECK(spit(p, early, golden_size) == 0);
    CHECK(rad_solution_read_parts(p, 0, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "more than 64 sections take"), "%s", e.message);
    free(early);

    /* > 64 GiB refused before reading: a sparse file costs no disk. */
    path_in(p, sizeof p, "huge.sol");
    int fd = open(p, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    CHECK(fd >= 0);
    if (fd >= 0) {
        CHECK(write(fd, golden, 32) == 32);
        CHECK(ftruncate(fd, (off_t)(64ll << 30) + 1) == 0);
        close(fd);
        CHECK(rad_solution_read(p, &s, &e) == RAD_ERR_LIMIT);
        CHECK_MSG(strstr(e.message, "64 GiB") != NULL, "%s", e.message);
        unlink(p);
    }
}

/* A copy of golden, changed by the caller, then made consistent (v6_fix). */
static uint8_t *golden_copy(void)
{
    uint8_t *b = malloc(golden_size);
    memcpy(b, golden, golden_size);
    return b;
}

/* The two layouts: where a section's body is, and how to make an image
 * consistent again after an edit (CRCs, sizes). */
typedef struct layout {
    size_t (*find)(const uint8_t *b, size_t size, const char *tag, uint64_t *len);
    void (*fix)(uint8_t *b, size_t size);
} layout;
static const layout v2_layout = {find_section, fix_header}, v6_layout = {v6_find, v6_fix};

/* Parses b (made consistent by L first) and expects RAD_ERR_CORRUPT with
 * `want` in the message (at its start when at_start). */
static void refused_as(const layout *L, uint8_t *b, size_t size, const char *name,
                       const char *want, int at_start)
{
    L->fix(b, size);
    rad_solution *s = NULL;
    rad_error e = {0};
    CHECK(rad_solution_parse(b, size, name, 1, &s, &e) == RAD_ERR_CORRUPT && !s);
    const char *hit = strstr(e.message, want);
    CHECK_MSG(hit && (!at_start || hit == e.message), "%s (wanted '%s')", e.message, want);
    rad_solution_destroy(s);
}

/* Offset of the material count in the SCENE body at sc (the rgb room:
 * three bands, all named), and of material 0's first ρ. */
static size_t material_count_at(const uint8_t *b, size_t sc)
{
    size_t q = sc + 4 + rd32(b + sc) + 4; /* past source, band count */
    for (int k = 0; k < 3; k++)
        q += 1 + 4 + rd32(b + q + 1);       /* band names */
    return q;
}

static size_t material0_rho(const uint8_t *b, size_t sc)
{
    size_t q = material_count_at(b, sc) + 4;
    return q + 4 + rd32(b + q);             /* past material 0's name */
}

/* Bad values in the sections both layouts share, named alike: ρ = 1 and
 * B < 0 in PATCHDATA; a vertex count no section could hold (refused before
 * any allocation: under ASan a huge malloc would abort the test) and a
 * patch naming a vertex past the end in MESH; a material's ρ < 0 (refused
 * by the scene builder, named by name) and a material count too large for
 * SCENE.  img is the rgb room of n patches. */
static void value_errors(const layout *L, const uint8_t *img, size_t size, uint32_t n)
{
    uint8_t *buf = malloc(size);
    uint64_t len, one, neg;
    double d1 = 1.0, dn = -0.5;
    memcpy(&one, &d1, 8);
    memcpy(&neg, &dn, 8);
    memcpy(buf, img, size);
    size_t pd = L->find(buf, size, "PDAT", &len);
    wr64(buf + pd + 8 + 8 * 4, one); /* patch 1, band 1 */
    refused_as(L, buf, size, "p.sol", "p.sol: section PATCHDATA: patch 1 band 1: ρ = 1", 1);
    memcpy(buf, img, size);
    wr64(buf + pd + 8 + 2ull * 8 * n * 3, neg);
    refused_as(L, buf, size, "b.sol", "section PATCHDATA: patch 0 band 0: B = -0.5", 0);
    memcpy(buf, img, size);
    size_t me = L->find(buf, size, "MESH", &len);
    uint32_t nv = rd32(buf + me);
    wr32(buf + me, 0xFFFFFFF0u);
    refused_as(L, buf, size, "v.sol", "v.sol: section MESH: 4294967280 vertices", 1);
    memcpy(buf, img, size);
    wr32(buf + me + 8 + 25ull * nv + 4, nv + 5); /* patch 0, corner 1 */
    refused_as(L, buf, size, "v.sol", "section MESH: patch 0: vertex", 0);
    memcpy(buf, img, size);
    size_t sc = L->find(buf, size, "SCEN", &len), q = material0_rho(buf, sc);
    wr64(buf + q, neg); /* ρ_R = -0.5 */
    refused_as(L, buf, size, "s.sol", "s.sol: section SCENE: material 'white'", 1);
    memcpy(buf, img, size);
    wr32(buf + material_count_at(buf, sc), 0xFFFFFFFFu);
    refused_as(L, buf, size, "c.sol", "c.sol: section SCENE: 4294967295 materials cannot fit", 1);
    free(buf);
}

/* A reserved header field that is not 0, and one byte more at the end:
 * both refused, the second as `trailing` says. */
static void header_rules(const uint8_t *img, size_t size, const char *trailing)
{
    uint8_t *buf = malloc(size + 1);
    rad_solution *s = NULL;
    rad_error e = {0};
    memcpy(buf, img, size);
    buf[13] = 1;
    CHECK(rad_solution_parse(buf, size, "c.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strcmp(e.message, "c.sol: reserved header field is 256, not 0") == 0, "%s",
              e.message);
    buf[13] = 0;
    buf[size] = 0;
    CHECK(rad_solution_parse(buf, size + 1, "c.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strcmp(e.message, trailing) == 0, "%s (wanted '%s')", e.message, trailing);
    CHECK(s == NULL);
    free(buf);
}

/* Parses b (made consistent first) and expects RAD_ERR_CORRUPT with `want`
 * in the message (at its start when at_start). */
static void refused_with(uint8_t *b, size_t size, const char *name, const char *want,
                         int at_start)
{
    refused_as(&v6_layout, b, size, name, want, at_start);
}

TEST(structure_errors_name_section_and_element)
{
    CHECK(load_golden());
    if (!golden)
        return;
    rad_solution *ref = make_rgb();
    if (!ref)
        return;
    uint32_t n = ref->mesh->patch_count;
    uint64_t len;
    char want[200];
    /* A column out of range: row 0 is present and empty, row 1 missing, so
     * the first block's second record is row 2; its first gap is one byte. */
    uint8_t *buf = golden_copy();
    size_t m = v6_find(buf, golden_size, "MTRX", &len);
    size_t r = m + 16 + 24;
    CHECK(rd32(buf + r) == 0 && rd32(buf + r + 4) == 0);
    r += 8;
    uint32_t c2 = rd32(buf + r + 4);
    CHECK(rd32(buf + r) == 2 && c2 > 0 && n < 127);
    buf[r + 8 + 4 * c2] = 127;
    snprintf(want, sizeof want, "m.sol: section MATRIX: row 2: column 127 out of range (n = %u)",
             n);
    refused_with(buf, golden_size, "m.sol", want, 1);
    /* a value that is not positive */
    memcpy(buf, golden, golden_size);
    float neg = -0.25f;
    memcpy(buf + r + 8, &neg, 4);
    refused_with(buf, golden_size, "m.sol", "section MATRIX: row 2: F_2,", 0);
    /* a row the ROWS section does not list */
    memcpy(buf, golden, golden_size);
    size_t ro = v6_find(buf, golden_size, "ROWS", &len);
    buf[ro + 4 + 2] = 0;
    refused_with(buf, golden_size, "m.sol", "section MATRIX: row 2: ", 0);
    /* the bad values both layouts name alike, and IRRADIANCE's */
    value_errors(&v6_layout, golden, golden_size, n);
    memcpy(buf, golden, golden_size);
    size_t ir = v6_find(buf, golden_size, "IRRD", &len);
    double half = -0.5;
    uint64_t bits;
    memcpy(&bits, &half, 8);
    wr64(buf + ir + 8 + 8 * 4, bits);
    refused_with(buf, golden_size, "h.sol", "section IRRADIANCE: patch 1 band 1: H = -0.5", 0);
    /* The index: a section listed twice, one missing, one not where the
     * previous ends, both MATRIX and MATRIXREF absent. */
    size_t x = v6_index_at(golden);
    memcpy(buf, golden, golden_size);
    memcpy(buf + x + 8 + 32 * 2, "INFO", 4); /* SCENE's entry named INFO */
    refused_with(buf, golden_size, "d.sol", "section INFO appears twice", 0);
    memcpy(buf, golden, golden_size);
    memcpy(buf + x + 8 + 32 * 2, "XXXX", 4); /* SCENE's entry unknown: skipped */
    refused_with(buf, golden_size, "d.sol", "d.sol: section SCENE missing", 1);
    memcpy(buf, golden, golden_size);
    memcpy(buf + x + 8, "XXXX", 4);
    refused_with(buf, golden_size, "d.sol", "section MATRIX missing", 0);
    memcpy(buf, golden, golden_size);
    wr64(buf + x + 8 + 32 * 3 + 8, rd64(buf + x + 8 + 32 * 3 + 8) + 1);
    refused_with(buf, golden_size, "d.sol", "not where the previous one ends", 0);
    /* A file still being written (a solve stopped before the index) */
    memcpy(buf, golden, golden_size);
    wr64(buf + 16, 0);
    rad_solution *s = NULL;
    rad_error e;
    CHECK(rad_solution_parse(buf, golden_size, "u.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "u.sol: unfinished") == e.message, "%s", e.message);
    free(buf);
    rad_solution_destroy(ref);
}

TEST(encoding_rules_are_enforced)
{
    CHECK(load_golden());
    if (!golden)
        return;
    rad_solution *s = NULL;
    rad_error e;
    uint64_t len;
    size_t size;
    /* Bytes left over at the end of a known section */
    size_t info = v6_find(golden, golden_size, "INFO", &len);
    uint8_t *buf = v6_splice(golden, golden_size, info, info + (size_t)len, 0, "\0", 1, &size);
    CHECK(rad_solution_parse(buf, size, "l.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strcmp(e.message, "l.sol: section INFO: 1 unexpected bytes at the end") == 0, "%s",
              e.message);
    free(buf);
    /* A column written as a padded varint (0x80|c, 0x00): one value has one
     * encoding.  Row 2's first gap follows its values; its block grows. */
    size_t m = v6_find(golden, golden_size, "MTRX", &len);
    size_t r = m + 16 + 24 + 8, c2 = rd32(golden + r + 4), g = r + 8 + 4 * c2;
    CHECK(rd32(golden + r) == 2 && golden[g] < 0x80);
    buf = v6_splice(golden, golden_size, m, g + 1, 0, "\0", 1, &size);
    buf[g] |= 0x80;
    wr64(buf + m + 16 + 8, rd64(buf + m + 16 + 8) + 1); /* the block's length */
    v6_fix(buf, size);
    CHECK(rad_solution_parse(buf, size, "v.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "v.sol: section MATRIX: row 2: entry 0: truncated or malformed") ==
                  e.message, "%s", e.message);
    free(buf);
    /* a row block longer than the section; one announcing more rows */
    buf = golden_copy();
    wr64(buf + m + 16 + 8, len);
    refused_with(buf, golden_size, "c.sol", "section MATRIX: byte 16: row block of", 0);
    memcpy(buf, golden, golden_size);
    wr32(buf + m + 16 + 4, rd32(buf + m + 16 + 4) + 1);
    refused_with(buf, golden_size, "c.sol", "rows announced", 0);
    /* a reserved header or index field that is not 0; bytes after the index */
    memcpy(buf, golden, golden_size);
    buf[v6_index_at(golden) + 4] = 1;
    refused_with(buf, golden_size, "c.sol", "index", 0);
    header_rules(golden, golden_size, "c.sol: 1 unexpected bytes after the index");
    free(buf);
}

/* A future writer's section, with its index entry, between the last section
 * and the index: skipped. */
TEST(unknown_sections_are_skipped)
{
    CHECK(load_golden());
    if (!golden)
        return;
    size_t x = v6_index_at(golden), size = golden_size + 5 + 32;
    uint8_t *buf = malloc(size);
    memcpy(buf, golden, x);
    memcpy(buf + x, "hello", 5);
    memcpy(buf + x + 5, golden + x, golden_size - x);
    wr64(buf + 16, x + 5);
    uint32_t count = v6_count(golden);
    wr32(buf + x + 5, count + 1);
    uint8_t *e = buf + x + 5 + 8 + 32 * (size_t)count;
    memcpy(e, "XTRA", 4);
    wr32(e + 4, 0);
    wr64(e + 8, x);
    wr64(e + 16, 5);
    v6_fix(buf, size);
    rad_solution *s = NULL, *ref = make_rgb();
    rad_error err;
    CHECK_MSG(rad_solution_parse(buf, size, "future.sol", 1, &s, &err) == RAD_OK, "%s",
              err.message);
    check_same(ref, s);
    rad_solution_destroy(s);
    rad_solution_destroy(ref);
    free(buf);
}

/* What render and report read: no byte of F, which stays as row counts;
 * the irradiance stored beside B gives the report's power balance, the
 * same as F gives; F can still be loaded later, from the same file. */
TEST(read_without_matrix)
{
    rad_solution *s = make_rgb();
    if (!s)
        return;
    char p[300];
    path_in(p, sizeof p, "view.sol");
    rad_error e = {0};
    CHECK_MSG(rad_solution_write(s, p, &e) == RAD_OK, "%s", e.message);
    rad_solution *v = NULL, *w = NULL;
    CHECK_MSG(rad_solution_read_parts(p, 0, &v, &e) == RAD_OK, "%s", e.message);
    CHECK(rad_solution_read(p, &w, &e) == RAD_OK);
    if (v && w) {
        CHECK(!v->F->entries_loaded && v->F->data == NULL && v->F->rows_done == s->F->rows_done);
        CHECK(same_bits(v->F->row_count, s->F->row_count, 4ull * s->F->n));
        CHECK(same_bits(v->B, s->B, 8ull * s->mesh->patch_count * 3));
        uint32_t no = s->scene->object_count;
        rad_object_stats *a = calloc(no, sizeof *a), *b = calloc(no, sizeof *b);
        CHECK(rad_solution_object_stats(v, a, &e) == RAD_OK);
        CHECK(rad_solution_object_stats(w, b, &e) == RAD_OK);
        CHECK(same_bits(a, b, no * sizeof *a));
        free(a);
        free(b);
        /* nothing that needs F's entries works on it, and says so */
        double *M = calloc((size_t)no * no, sizeof *M);
        CHECK(rad_object_form_factors(v, M, &e) == RAD_ERR_USAGE);
        free(M);
        char q[300];
        path_in(q, sizeof q, "view2.sol");
        CHECK(rad_solution_write(v, q, &e) == RAD_ERR_USAGE);
        CHECK_MSG(strstr(e.message, "form factors were not read"), "%s", e.message);
        rad_solve_options opt = {0};
        CHECK(rad_resolve(v, &opt, &e) == RAD_ERR_USAGE);
        /* loaded afterwards, it is the whole matrix */
        CHECK_MSG(rad_solution_load_matrix(v, &e) == RAD_OK, "%s", e.message);
        check_same(w, v);
        CHECK(rad_solution_matrix_file(v) && rad_solution_matrix_file(v)->offset == 32);
    }
    rad_solution_destroy(v);
    rad_solution_destroy(w);
    /* a file changed between the two reads is not mixed with the first */
    v = NULL;
    CHECK(rad_solution_read_parts(p, 0, &v, &e) == RAD_OK);
    s->B[0] += 1.0;
    CHECK(rad_solution_write(s, p, &e) == RAD_OK);
    CHECK(v && rad_solution_load_matrix(v, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "changed since it was read"), "%s", e.message);
    rad_solution_destroy(v);
    rad_solution_destroy(s);
}

/* Every older version is still read: the corpus keeps a file of each, as
 * those versions wrote them, and the ones made from today's fixtures read
 * back as those fixtures; with or without the matrix (and, version 6, with
 * the elements' rows whatever the parts: they are inside ELEMENTS). */
TEST(older_versions_still_read)
{
    static const struct {
        const char *name;
        uint32_t version;
        rad_solution *(*make)(void);
    } files[] = {{"grey-box", 1, make_grey},         {"wide-floor", 1, make_wide},
                 {"rgb-room", 2, make_rgb},          {"elements-room-v3", 3, NULL},
                 {"elements-room", 4, NULL},         {"sheets-room", 5, make_sheets},
                 {"ortho-camera", 5, NULL},          {"glossy-room", 5, NULL},
                 {"clusters-floor", 5, NULL},        {"rgb-room-v6", 6, NULL},
                 {"elements-room-v6", 6, NULL},      {"interp-room-v6", 6, NULL},
                 {"basis-room-v6", 6, NULL}};
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
        char p[300];
        snprintf(p, sizeof p, CORPUS "%s", files[k].name);
        size_t n = 0;
        uint8_t *img = slurp(p, &n);
        CHECK_MSG(img && n > 12 && rd32(img + 8) == files[k].version, "%s", p);
        free(img);
        rad_solution *ref = files[k].make ? files[k].make() : NULL;
        for (unsigned parts = 0; parts <= RAD_PARTS_ALL; parts++) {
            rad_solution *s = NULL;
            rad_error e = {0};
            CHECK_MSG(rad_solution_read_parts(p, parts, &s, &e) == RAD_OK, "%s", e.message);
            CHECK(s && invariants_hold(s) &&
                  s->F->entries_loaded == (files[k].version < 6 || (parts & RAD_PART_MATRIX)));
            CHECK(s && (!s->elements || s->elements->rows_loaded));
            int ortho = 0; /* version 5's CAMERAS section, read */
            for (uint32_t c = 0; s && c < s->scene->camera_count; c++)
                ortho += s->scene->cameras[c].orthographic != 0;
            CHECK(ortho == (strcmp(files[k].name, "ortho-camera") == 0));
            int glossy = 0; /* version 5's SURFACE: the mirror's lobe (metallic 0.5,
                             * roughness 0.3 in the scene it was solved from) */
            for (uint32_t m = 0; s && m < s->scene->material_count; m++)
                glossy += s->scene->materials[m].specular[0] > 0.0 &&
                          s->scene->materials[m].roughness == 0.3;
            CHECK(glossy == (strcmp(files[k].name, "glossy-room") == 0));
            /* version 5's CLUSTERS: 32 triangles in 4 clusters and a lamp */
            int clustered = s && s->mesh->cell_first != NULL;
            CHECK(clustered == (strcmp(files[k].name, "clusters-floor") == 0));
            CHECK(!clustered || (s->mesh->cell_count == 33 && s->elements != NULL));
            if (s && files[k].make)
                check_same(ref, s);
            rad_solution_destroy(s);
        }
        rad_solution_destroy(ref);
    }
}

TEST(version_2_structure_errors_name_section_and_element)
{
    CHECK(load_old_golden());
    if (!old_golden)
        return;
    rad_solution *ref = make_rgb();
    CHECK(ref != NULL);
    if (!ref)
        return;
    uint32_t n = ref->mesh->patch_count;
    uint8_t *buf = malloc(old_golden_size);
    rad_solution *s = NULL;
    rad_error e;
    uint64_t len;

    /* A column out of range: the first present non-empty row is row 2
     * (row 0 empty, row 1 missing); its first column is one varint byte. */
    memcpy(buf, old_golden, old_golden_size);
    size_t m = find_section(buf, old_golden_size, "MTRX", &len);
    size_t r = m + 8;              /* row 0: index, count 0 */
    CHECK(rd32(buf + r) == 0 && rd32(buf + r + 4) == 0);
    r += 8;                        /* row 2 */
    CHECK(rd32(buf + r) == 2 && rd32(buf + r + 4) > 0);
    CHECK(n < 127);
    buf[r + 8] = 127;
    fix_header(buf, old_golden_size);
    CHECK(rad_solution_parse(buf, old_golden_size, "m.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    char want[200];
    snprintf(want, sizeof want, "m.sol: section MATRIX: row 2: column 127 out of range (n = %u)",
             n);
    CHECK_MSG(strcmp(e.message, want) == 0, "%s", e.message);

    /* the bad values both layouts name alike */
    value_errors(&v2_layout, old_golden, old_golden_size, n);

    /* A section repeated, and one missing. */
    uint64_t ilen;
    CHECK(find_section(old_golden, old_golden_size, "INFO", &ilen) == 32 + 12);
    size_t ilen_all = 12 + (size_t)ilen;
    size_t dup_size = old_golden_size + ilen_all;
    uint8_t *big = malloc(dup_size);
    memcpy(big, old_golden, 32);
    memcpy(big + 32, old_golden + 32, ilen_all);
    memcpy(big + 32 + ilen_all, old_golden + 32, old_golden_size - 32);
    fix_header(big, dup_size);
    CHECK(rad_solution_parse(big, dup_size, "d.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "section INFO appears twice") != NULL, "%s", e.message);
    memcpy(big, old_golden, 32);
    memcpy(big + 32, old_golden + 32 + ilen_all, old_golden_size - 32 - ilen_all);
    fix_header(big, old_golden_size - ilen_all);
    CHECK(rad_solution_parse(big, old_golden_size - ilen_all, "d.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "section INFO missing") != NULL, "%s", e.message);
    free(big);
    CHECK(s == NULL);
    free(buf);
    rad_solution_destroy(ref);
}

/* A copy of the version 2 file with n bytes inserted at `at`, inside the section whose
 * body starts at `body`; the section length and the header are fixed up. */
static uint8_t *old_insert_bytes(size_t body, size_t at, const void *bytes, size_t n, size_t *size)
{
    uint8_t *buf = malloc(old_golden_size + n);
    memcpy(buf, old_golden, at);
    memcpy(buf + at, bytes, n);
    memcpy(buf + at + n, old_golden + at, old_golden_size - at);
    wr64(buf + body - 8, rd64(old_golden + body - 8) + n);
    *size = old_golden_size + n;
    fix_header(buf, *size);
    return buf;
}

TEST(version_2_encoding_rules_are_enforced)
{
    CHECK(load_old_golden());
    if (!old_golden)
        return;
    rad_solution *s = NULL;
    rad_error e;
    uint64_t len;
    size_t size;

    /* Bytes left over at the end of a known section */
    size_t info = find_section(old_golden, old_golden_size, "INFO", &len);
    uint8_t *buf = old_insert_bytes(info, info + (size_t)len, "\0", 1, &size);
    CHECK(rad_solution_parse(buf, size, "l.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strcmp(e.message, "l.sol: section INFO: 1 unexpected bytes at the end") == 0, "%s",
              e.message);
    free(buf);

    /* A column written as a padded varint (0x80|c, 0x00): one value has one
     * encoding, so this is corruption. Row 2's first column is at m + 24. */
    size_t m = find_section(old_golden, old_golden_size, "MTRX", &len);
    CHECK(rd32(old_golden + m + 16) == 2 && old_golden[m + 24] < 0x80);
    buf = old_insert_bytes(m, m + 25, "\0", 1, &size);
    buf[m + 24] |= 0x80;
    fix_header(buf, size);
    CHECK(rad_solution_parse(buf, size, "v.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "v.sol: section MATRIX: row 2: entry 0: truncated or malformed") ==
                  e.message, "%s", e.message);
    free(buf);

    /* rows present > n */
    buf = malloc(old_golden_size);
    memcpy(buf, old_golden, old_golden_size);
    wr32(buf + m + 4, rd32(buf + m) + 1);
    fix_header(buf, old_golden_size);
    CHECK(rad_solution_parse(buf, old_golden_size, "c.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "rows present but n =") != NULL, "%s", e.message);
    /* a section length running past the end */
    memcpy(buf, old_golden, old_golden_size);
    wr64(buf + m - 8, old_golden_size);
    fix_header(buf, old_golden_size);
    CHECK(rad_solution_parse(buf, old_golden_size, "c.sol", 1, &s, &e) == RAD_ERR_CORRUPT);
    CHECK_MSG(strstr(e.message, "section MATRIX: length") != NULL, "%s", e.message);
    /* a reserved header field that is not 0 */
    header_rules(old_golden, old_golden_size, "c.sol: 1 unexpected bytes after the payload");
    free(buf);
}

TEST(version_2_unknown_sections_are_skipped)
{
    CHECK(load_old_golden());
    if (!old_golden)
        return;
    /* A future writer's section between INFO and SCENE and one at the end. */
    uint64_t ilen;
    size_t info = find_section(old_golden, old_golden_size, "INFO", &ilen);
    size_t cut = info + (size_t)ilen;
    const char extra[] = "XTRA\x05\0\0\0\0\0\0\0hello";
    size_t ex = sizeof extra - 1;
    size_t size = old_golden_size + 2 * ex;
    uint8_t *buf = malloc(size);
    memcpy(buf, old_golden, cut);
    memcpy(buf + cut, extra, ex);
    memcpy(buf + cut + ex, old_golden + cut, old_golden_size - cut);
    memcpy(buf + old_golden_size + ex, extra, ex);
    fix_header(buf, size);
    rad_solution *s = NULL, *ref = make_rgb();
    rad_error e;
    int rc = rad_solution_parse(buf, size, "future.sol", 1, &s, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    check_same(ref, s);
    rad_solution_destroy(s);
    rad_solution_destroy(ref);
    free(buf);
}

static int dir_exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

TEST(failed_writes_leave_no_trace)
{
    rad_solution *s = make_grey(), *other = make_rgb();
    CHECK(s && other);
    if (!s || !other)
        return;
    rad_error e;
    char dir[300], p[400];
    path_in(dir, sizeof dir, "w");
    CHECK(mkdir(dir, 0755) == 0);

    /* Missing directory */
    snprintf(p, sizeof p, "%s/no/such/dir/x.sol", dir);
    CHECK(rad_solution_write(s, p, &e) == RAD_ERR_IO);
    CHECK_MSG(strstr(e.message, "no/such/dir/x.sol: cannot create temporary file") != NULL, "%s",
              e.message);
    CHECK(temp_files_in(dir) == 0);

    /* The target is a directory: the rename fails, the temporary goes. */
    snprintf(p, sizeof p, "%s/adir", dir);
    CHECK(mkdir(p, 0755) == 0);
    char inner[500];
    snprintf(inner, sizeof inner, "%s/keep", p);
    CHECK(spit(inner, "k", 1) == 0);
    CHECK(rad_solution_write(s, p, &e) == RAD_ERR_IO);
    CHECK_MSG(strstr(e.message, "cannot rename") != NULL, "%s", e.message);
    CHECK(dir_exists(p));
    size_t kn = 0;
    uint8_t *kb = slurp(inner, &kn);
    CHECK(kb && kn == 1 && kb[0] == 'k');
    free(kb);
    CHECK(temp_files_in(dir) == 0);

    /* A good file, then writes that fail at different points. */
    snprintf(p, sizeof p, "%s/good.sol", dir);
    CHECK(rad_solution_write(s, p, &e) == RAD_OK);
    size_t n0 = 0;
    uint8_t *before = slurp(p, &n0);
    CHECK(before != NULL);

    /* (1) refused by validation before any file exists: B < 0 */
    double keep = other->B[5];
    other->B[5] = -1e-9;
    CHECK(rad_solution_write(other, p, &e) == RAD_ERR_INVALID);
    CHECK_MSG(strstr(e.message, "patch 1 band 2: B = ") != NULL, "%s", e.message);
    other->B[5] = keep;

    /* (2) failing in the middle of the data: a file-size limit below the
     * file's size makes write() fail with EFBIG after a partial write. */
    struct rlimit old, lim;
    CHECK(getrlimit(RLIMIT_FSIZE, &old) == 0);
    lim = old;
    lim.rlim_cur = 2048;
    void (*prev)(int) = signal(SIGXFSZ, SIG_IGN);
    CHECK(setrlimit(RLIMIT_FSIZE, &lim) == 0);
    int rc = rad_solution_write(other, p, &e);
    setrlimit(RLIMIT_FSIZE, &old);
    signal(SIGXFSZ, prev);
    CHECK(rc == RAD_ERR_IO);
    CHECK_MSG(strstr(e.message, "cannot write") != NULL, "%s", e.message);

    size_t n1 = 0;
    uint8_t *after = slurp(p, &n1);
    CHECK(after && n1 == n0 && memcmp(before, after, n0) == 0);
    CHECK(temp_files_in(dir) == 0);
    free(after);

    /* (3) a successful write replaces it */
    CHECK(rad_solution_write(other, p, &e) == RAD_OK);
    rad_solution *r = NULL;
    CHECK(rad_solution_read(p, &r, &e) == RAD_OK);
    check_same(other, r);
    CHECK(temp_files_in(dir) == 0);

    /* (4) a stale temporary file of our own pid is replaced, not an obstacle */
    char stale[600];
    snprintf(stale, sizeof stale, "%s.tmp.%ld", p, (long)getpid());
    CHECK(spit(stale, "stale", 5) == 0);
    CHECK(rad_solution_write(s, p, &e) == RAD_OK);
    CHECK(temp_files_in(dir) == 0);

    free(before);
    rad_solution_destroy(r);
    rad_solution_destroy(s);
    rad_solution_destroy(other);
}

TEST(writer_refuses_what_reader_would)
{
    rad_solution *s = make_grey();
    CHECK(s != NULL);
    if (!s)
        return;
    char p[300];
    path_in(p, sizeof p, "refused.sol");
    rad_error e;
    s->rho[0] = 1.0;
    CHECK(rad_solution_write(s, p, &e) == RAD_ERR_INVALID);
    s->rho[0] = 0.5;
    s->residual = NAN;
    CHECK(rad_solution_write(s, p, &e) == RAD_ERR_INVALID);
    s->residual = 0.0;
    memset(s->solver, 'x', sizeof s->solver); /* no terminator */
    CHECK(rad_solution_write(s, p, &e) == RAD_ERR_USAGE);
    strcpy(s->solver, "jacobi");
    char *longname = malloc(5000);
    memset(longname, 'n', 4999);
    longname[4999] = '\0';
    char *old = s->scene->objects[0].name;
    s->scene->objects[0].name = longname;
    CHECK(rad_solution_write(s, p, &e) == RAD_ERR_LIMIT);
    s->scene->objects[0].name = old;
    free(longname);
    CHECK(rad_solution_write(NULL, p, &e) == RAD_ERR_USAGE);
    struct stat st;
    CHECK(stat(p, &st) != 0); /* nothing was created */
    char d[300];
    path_in(d, sizeof d, "");
    CHECK(temp_files_in(d) == 0);
    rad_solution_destroy(s);
}

/* The rgb room refined with `levels` uniform splits (hemi-cubes at the
 * elements' centres), or with 0 adaptively at the default threshold (most
 * elements interpolated, issue 18). */
static rad_solution *make_refined(uint32_t levels)
{
    rad_solution *s = make_rgb();
    rad_solve_options opt = {0};
    opt.element_levels = levels;
    opt.hemicube.resolution = 32;
    rad_error e;
    if (s && rad_refine_solution(s, &opt, &e) != RAD_OK) {
        fprintf(stderr, "  refine: %s\n", e.message);
        rad_solution_destroy(s);
        return NULL;
    }
    return s;
}

/* The rgb room with elements one split deep. */
static rad_solution *make_elements(void) { return make_refined(1); }
/* The rgb room with adaptive elements, ELEMENTINDIRECT in its file. */
static rad_solution *make_interp(void) { return make_refined(0); }

/* Every element of y equals x's, bit for bit. */
static void check_same_elements(const rad_elements *x, const rad_elements *y, uint32_t nb)
{
    CHECK(y != NULL);
    if (!y)
        return;
    uint32_t ne = x->mesh->patch_count;
    CHECK(y->mesh->patch_count == ne && y->mesh->vertex_count == x->mesh->vertex_count &&
          y->nnz == x->nnz);
    if (y->mesh->patch_count != ne || y->mesh->vertex_count != x->mesh->vertex_count ||
        y->nnz != x->nnz)
        return;
    CHECK(same_bits(x->mesh->vertices, y->mesh->vertices,
                    x->mesh->vertex_count * sizeof *x->mesh->vertices));
    CHECK(same_bits(x->mesh->patches, y->mesh->patches, ne * sizeof *x->mesh->patches));
    CHECK(same_bits(x->patch, y->patch, ne * sizeof *x->patch));
    CHECK(same_bits(x->level, y->level, ne));
    CHECK(same_bits(x->B, y->B, (size_t)ne * nb * sizeof *x->B));
    CHECK(same_bits(x->row_count, y->row_count, ne * sizeof *x->row_count));
    CHECK(same_bits(x->col, y->col, x->nnz * sizeof *x->col));
    CHECK(same_bits(x->val, y->val, x->nnz * sizeof *x->val));
    CHECK(y->light_count == x->light_count && !y->light_h == !x->light_h);
    if (x->light_h && y->light_h)
        CHECK(same_bits(x->light_h, y->light_h, (size_t)ne * x->light_count * sizeof *x->light_h));
}

/* Cuts and flips of the bytes from `at` on of a version 6 or 7 image:
 * every cut from `at` on refused (a cut anywhere takes the index at the
 * end with it: every_truncation_is_refused tries them all on the rgb
 * image), with and without the offsets and CRCs made to agree (the section
 * cut short inside); every flip refused by the checksums, and without them
 * refused or read back with every invariant.  Returns the count of bad
 * outcomes. */
static size_t v6_damage_from(uint8_t *buf, size_t size, size_t at, size_t body, size_t len)
{
    size_t bad = 0;
    rad_error e;
    for (size_t k = at; k < size; k++) {
        rad_solution *s = NULL;
        if (rad_solution_parse(buf, k, "cut", 1, &s, &e) == RAD_OK || s)
            bad++;
        rad_solution_destroy(s);
    }
    for (size_t k = at; body && k < body + len; k++) {
        size_t n = 0;
        uint8_t *c = v6_splice(buf, size, body, k, body + len - k, NULL, 0, &n);
        rad_solution *s = NULL;
        if (rad_solution_parse(c, n, "cut", 1, &s, &e) != RAD_ERR_CORRUPT || s)
            bad++;
        rad_solution_destroy(s);
        free(c);
    }
    for (size_t k = at; k < size; k++) {
        buf[k] ^= 0xFF;
        rad_solution *s = NULL;
        if (rad_solution_parse(buf, size, "flip", 1, &s, &e) == RAD_OK || s)
            bad++;
        rad_solution_destroy(s);
        s = NULL;
        int rc = rad_solution_parse(buf, size, "flip", 0, &s, &e);
        if ((rc == RAD_OK && (!s || !invariants_hold(s) ||
                              (s->elements &&
                               rad_element_store_check(s->elements, s, "x", NULL) != RAD_OK))) ||
            (rc != RAD_OK && s))
            bad++;
        rad_solution_destroy(s);
        buf[k] ^= 0xFF;
    }
    return bad;
}

/* ELEMENTS and ELEMENTLIGHTS (the fixture has punctual lights, so its
 * elements carry their own direct light): a round trip keeps every element
 * bit for bit, h_le included; every cut and flip of the two sections is
 * refused (or, without checksums, read back with every invariant); bad
 * values are named. */
TEST(elements_round_trip_and_damage)
{
    rad_solution *a = make_elements();
    CHECK(a && a->elements);
    if (!a || !a->elements) {
        rad_solution_destroy(a);
        return;
    }
    char path[600];
    rad_error e = {0};
    size_t size = 0;
    uint8_t *buf = written_image(a, "elements.sol", path, &size);
    CHECK(a->elements->light_h && a->elements->light_count == 2);
    rad_solution *b = NULL;
    CHECK(rad_solution_read(path, &b, &e) == RAD_OK);
    if (b)
        check_same_elements(a->elements, b->elements, a->band_count);
    rad_solution_destroy(b);
    uint64_t len = 0, llen = 0;
    size_t at = buf ? v6_find(buf, size, "ELEM", &len) : 0;
    size_t lat = buf ? v6_find(buf, size, "ELGT", &llen) : 0;
    CHECK(at > 0 && len > 0);
    CHECK(lat == at + len && llen == 8 + 4ull * a->elements->mesh->patch_count * 2);
    if (buf && at) {
        size_t bad = v6_damage_from(buf, size, at, at, len);
        bad += v6_damage_from(buf, size, lat, lat, llen);
        printf("     %zu bytes (ELEMENTS %llu, ELEMENTLIGHTS %llu): %zu cuts or flips accepted\n",
               size, (unsigned long long)len, (unsigned long long)llen, bad);
        CHECK(bad == 0);
    }
    /* An element on a patch that does not exist is named. */
    if (buf && at) {
        /* the first element's patch: after the provenance (24 bytes), the
         * counts (12) and the vertices (25 each) */
        uint8_t *c = malloc(size);
        memcpy(c, buf, size);
        wr32(c + at + 24 + 12 + (size_t)a->elements->mesh->vertex_count * 25, 1000000);
        v6_fix(c, size);
        rad_solution *s = NULL;
        CHECK(rad_solution_parse(c, size, "bad.sol", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
        CHECK_MSG(strstr(e.message, "ELEMENTS") && strstr(e.message, "element 0: patch 1000000"),
                  "%s", e.message);
        /* a negative h_le; an element count that is not the elements' */
        float neg = -1.0f;
        memcpy(c, buf, size);
        memcpy(c + lat + 8 + 4, &neg, 4); /* element 0, light 1 */
        v6_fix(c, size);
        CHECK(rad_solution_parse(c, size, "bad.sol", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
        CHECK_MSG(strstr(e.message, "ELEMENTLIGHTS") &&
                      strstr(e.message, "element 0: direct light -1 from light 1"),
                  "%s", e.message);
        memcpy(c, buf, size);
        wr32(c + lat, a->elements->mesh->patch_count + 1);
        v6_fix(c, size);
        CHECK(rad_solution_parse(c, size, "bad.sol", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
        CHECK_MSG(strstr(e.message, "ELEMENTLIGHTS") && strstr(e.message, "elements and 2 lights"),
                  "%s", e.message);
        /* INFO announces it: a file without it is refused */
        size_t n = 0;
        uint8_t *cut = v6_drop_section(buf, size, "ELGT", &n);
        CHECK(rad_solution_parse(cut, n, "v.sol", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
        CHECK_MSG(strstr(e.message, "section ELEMENTLIGHTS missing"), "%s", e.message);
        free(cut);
        free(c);
    }
    /* Without their own direct light (as version 3 wrote elements) they take
     * their patch's H_d,p, and INFO does not announce ELEMENTLIGHTS. */
    float *h = a->elements->light_h;
    a->elements->light_h = NULL;
    a->elements->light_count = 0;
    path_in(path, sizeof path, "elements-v3.sol");
    CHECK_MSG(rad_solution_write(a, path, &e) == RAD_OK, "%s", e.message);
    a->elements->light_h = h;
    a->elements->light_count = 2;
    size_t size3 = 0;
    uint64_t l3 = 0;
    uint8_t *buf3 = slurp(path, &size3);
    CHECK(buf3 && v6_find(buf3, size3, "ELGT", &l3) == 0 && v6_find(buf3, size3, "ELEM", &l3));
    rad_solution *v3 = NULL;
    CHECK_MSG(rad_solution_read(path, &v3, &e) == RAD_OK, "%s", e.message);
    if (v3) {
        CHECK(v3->elements && !v3->elements->light_h);
        uint32_t ne = v3->elements->mesh->patch_count, nb = v3->band_count, n = v3->mesh->patch_count;
        double *He = malloc((size_t)ne * nb * sizeof *He), *Hp = malloc((size_t)n * nb * sizeof *Hp);
        CHECK(rad_elements_direct_irradiance(v3, v3->elements, He, NULL) == RAD_OK);
        CHECK(rad_solution_direct_irradiance(v3, Hp, NULL) == RAD_OK);
        for (uint32_t q = 0; q < ne; q++)
            for (uint32_t c = 0; c < nb; c++)
                CHECK(He[(size_t)q * nb + c] == Hp[(size_t)v3->elements->patch[q] * nb + c]);
        free(He);
        free(Hp);
    }
    rad_solution_destroy(v3);
    free(buf3);
    free(buf);
    rad_solution_destroy(a);
}

/* The corpus's elements-room as version 4 wrote it: read, and its damage
 * named by the same rules. */
TEST(version_4_elements_file)
{
    size_t size = 0;
    uint8_t *buf = slurp(CORPUS "elements-room", &size);
    CHECK(buf && rd32(buf + 8) == 4);
    if (!buf)
        return;
    rad_solution *s = NULL;
    rad_error e = {0};
    CHECK_MSG(rad_solution_parse(buf, size, "v4.sol", 1, &s, &e) == RAD_OK, "%s", e.message);
    CHECK(s && s->elements && s->elements->light_h && invariants_hold(s));
    uint32_t ne = s && s->elements ? s->elements->mesh->patch_count : 0;
    uint32_t nv = s && s->elements ? s->elements->mesh->vertex_count : 0;
    rad_solution_destroy(s);
    s = NULL;
    uint64_t len = 0, llen = 0;
    size_t at = find_section(buf, size, "ELEM", &len), lat = find_section(buf, size, "ELGT", &llen);
    CHECK(at && lat && llen == 8 + 4ull * ne * 2);
    uint8_t *c = malloc(size);
    memcpy(c, buf, size);
    wr32(c + at + 24 + 12 + (size_t)nv * 25, 1000000);
    fix_header(c, size);
    CHECK(rad_solution_parse(c, size, "bad.sol", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
    CHECK_MSG(strstr(e.message, "ELEMENTS") && strstr(e.message, "element 0: patch 1000000"),
              "%s", e.message);
    /* ELEMENTLIGHTS has no place in a version 3 file, and a version 4 file
     * needs it */
    memcpy(c, buf, size);
    wr32(c + 8, 3);
    fix_header(c, size);
    CHECK(rad_solution_parse(c, size, "v3.sol", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
    CHECK_MSG(strstr(e.message, "section ELEMENTLIGHTS in a version 3 file"), "%s", e.message);
    memcpy(c, buf, size);
    fix_header(c, lat - 12);
    CHECK(rad_solution_parse(c, lat - 12, "v4.sol", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
    CHECK_MSG(strstr(e.message, "section ELEMENTLIGHTS missing"), "%s", e.message);
    free(c);
    free(buf);
}

/* The fuzz corpus keeps the elements fixture as version 3 wrote it (before
 * elements had their own direct light): this program still reads it. */
TEST(version_3_elements_file_still_reads)
{
    rad_solution *s = NULL;
    rad_error e = {0};
    int rc = rad_solution_read("test/fuzz/corpus/solution/elements-room-v3", &s, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    if (s) {
        CHECK(s->elements && !s->elements->light_h && s->scene->light_count == 2);
        CHECK(s->elements && rad_elements_gather(s, s->elements, &e) == RAD_OK);
        /* its red paint has a transmittance, which version 3 stored but did
         * not simulate: solving again is refused, not done without it */
        CHECK(s->mesh->twin == NULL);
        CHECK(rad_resolve(s, NULL, &e) == RAD_ERR_INVALID);
        CHECK_MSG(strstr(e.message, "material 'red paint' transmits") != NULL, "%s", e.message);
    }
    rad_solution_destroy(s);
}

/* ELEMENTINDIRECT (interpolated elements, issue 18): the section is in the
 * file, announced (INFO bit 64); a round trip keeps the flags and every
 * element's B bit for bit, and gathering again from the read solution
 * gives the same B to rounding (the interpolation is recomputed from the
 * stored rows and patches, nothing is rendered); every cut and flip of the
 * section is refused (or, without checksums, read back with every
 * invariant), and so is a flag that is not 0 or 1 or an interpolated
 * element whose row holds a patch that is not a direct source. */
TEST(interpolated_elements_round_trip)
{
    rad_solution *a = make_interp();
    CHECK(a && a->elements && a->elements->interp && a->elements->direct);
    if (!a || !a->elements || !a->elements->interp) {
        rad_solution_destroy(a);
        return;
    }
    const rad_elements *x = a->elements;
    uint32_t ne = x->mesh->patch_count, interp = 0, nb = a->band_count;
    for (uint32_t k = 0; k < ne; k++)
        interp += x->interp[k];
    char path[600];
    rad_error e = {0};
    size_t size = 0;
    uint8_t *buf = written_image(a, "interp.sol", path, &size);
    uint64_t len = 0;
    size_t at = buf ? v6_find(buf, size, "ELIN", &len) : 0;
    CHECK(at > 0 && len == 8 + (uint64_t)ne + a->mesh->patch_count);
    printf("  %u elements, %u interpolated; ELEMENTINDIRECT %llu bytes\n", ne, interp,
           (unsigned long long)len);
    CHECK(interp > 0 && interp < ne);
    rad_solution *b = NULL;
    CHECK(rad_solution_read(path, &b, &e) == RAD_OK);
    const rad_elements *y = b ? b->elements : NULL;
    CHECK(y && y->interp && y->direct);
    if (y && y->interp && y->direct && y->mesh->patch_count == ne) {
        CHECK(same_bits(x->interp, y->interp, ne));
        CHECK(same_bits(x->direct, y->direct, a->mesh->patch_count));
        CHECK(same_bits(x->B, y->B, (size_t)ne * nb * sizeof *x->B));
        double *B0 = malloc((size_t)ne * nb * sizeof *B0);
        if (B0) {
            memcpy(B0, y->B, (size_t)ne * nb * sizeof *B0);
            CHECK(rad_elements_gather(b, b->elements, &e) == RAD_OK);
            double worst = 0.0;
            for (size_t q = 0; q < (size_t)ne * nb; q++)
                worst = fmax(worst, fabs(y->B[q] - B0[q]) / fmax(B0[q], 1e-300));
            printf("  gathered again: worst |ΔB|/B = %.1e\n", worst);
            CHECK(worst <= 1e-12);
            free(B0);
        }
    }
    rad_solution_destroy(b);
    if (buf && at) {
        size_t bad = v6_damage_from(buf, size, at, at, len);
        printf("  %zu cuts or flips accepted\n", bad);
        CHECK(bad == 0);
    }
    /* a bad flag, and an interpolated element that did not interpolate a
     * patch it holds: both refused by the rules, the checksums made to
     * agree */
    size_t flags = at + 8; /* the two counts */
    uint32_t first = UINT32_MAX, holder = UINT32_MAX;
    for (uint32_t k = 0; k < ne && (first == UINT32_MAX || holder == UINT32_MAX); k++) {
        if (x->interp[k] && first == UINT32_MAX)
            first = k;
        if (!x->interp[k] && x->level[k] > 0 && x->row_count[k] > 0 && holder == UINT32_MAX)
            for (uint32_t q = 0; q < x->row_count[k]; q++)
                holder = !x->direct[x->col[x->row_start[k] + q]] ? k : holder;
    }
    if (buf && first != UINT32_MAX) {
        rad_solution *s = NULL;
        buf[flags + first] = 2;
        v6_fix(buf, size);
        CHECK(rad_solution_parse(buf, size, "flag", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
        buf[flags + first] = 1;
    }
    if (buf && holder != UINT32_MAX) {
        rad_solution *s = NULL;
        buf[flags + holder] = 1;
        v6_fix(buf, size);
        CHECK(rad_solution_parse(buf, size, "holder", 1, &s, &e) == RAD_ERR_CORRUPT && !s);
        CHECK(strstr(e.message, "not a direct source") != NULL);
    }
    CHECK(holder != UINT32_MAX);
    free(buf);
    rad_solution_destroy(a);
}

/* ELEMENTROWS (version 7, issue 21): the elements' row entries in a
 * section of their own, ELEMENTS holding each row's count only.  Read
 * without RAD_PART_ELEMENT_ROWS the elements are whole but for their
 * entries (rows_loaded 0, col and val NULL, the counts - so the buried
 * elements - and B bit for bit), and a damaged ELEMENTROWS goes unnoticed;
 * with it, the rows come back bit for bit, the damage is refused naming
 * the section, and so is every cut and flip of it.  The section is there
 * exactly when ELEMENTS counts an entry and has no place in a version 6
 * file.  The fixture is the room with elements one split deep (the
 * interpolated room's rows, checked against the direct sources once
 * ELEMENTROWS is read, are interpolated_elements_round_trip's).  Cost:
 * ~1 s, most of it the flips. */
TEST(element_rows_section)
{
    rad_solution *a = make_elements();
    CHECK(a && a->elements && a->elements->nnz > 0);
    if (!a || !a->elements) {
        rad_solution_destroy(a);
        return;
    }
    const rad_elements *x = a->elements;
    const uint32_t ne = x->mesh->patch_count, nb = a->band_count;
    char path[600];
    size_t size = 0;
    uint8_t *buf = written_image(a, "erows.sol", path, &size);
    uint64_t len = 0, rlen = 0;
    size_t at = buf ? v6_find(buf, size, "ELEM", &len) : 0;
    size_t rat = buf ? v6_find(buf, size, "ELRW", &rlen) : 0;
    /* ELEMENTS: provenance, counts, vertices and the elements' fixed parts,
     * not one entry; ELEMENTROWS: its head and at least 5 bytes an entry */
    CHECK(at && len == 24 + 12 + 25ull * x->mesh->vertex_count + (25ull + 8 * nb) * ne);
    CHECK(rat && rlen >= 12 + 5 * x->nnz && rd32(buf + rat) == ne && rd64(buf + rat + 4) == x->nnz);
    if (!buf || !at || !rat) {
        free(buf);
        rad_solution_destroy(a);
        return;
    }
    static const unsigned parts[3] = {0, RAD_PART_ELEMENT_ROWS, RAD_PARTS_ALL};
    for (int q = 0; q < 3; q++) {
        rad_solution *r = NULL;
        rad_error e = {0};
        CHECK_MSG(rad_solution_parse_parts(buf, size, "p.sol", 1, parts[q], &r, &e) == RAD_OK,
                  "%s", e.message);
        const rad_elements *y = r ? r->elements : NULL;
        const int rows = (parts[q] & RAD_PART_ELEMENT_ROWS) != 0;
        CHECK(y && y->rows_loaded == rows && !y->col == !rows && !y->val == !rows);
        if (!y) {
            rad_solution_destroy(r);
            continue;
        }
        CHECK(y->nnz == x->nnz && same_bits(y->row_count, x->row_count, 4ull * ne) &&
              same_bits(y->row_start, x->row_start, 8ull * ne) &&
              same_bits(y->B, x->B, 8ull * ne * nb));
        CHECK(rad_element_store_check(y, r, "p", NULL) == RAD_OK);
        if (rows)
            check_same_elements(x, y, nb);
        rad_solution_destroy(r);
    }
    uint8_t *c = malloc(size);
    rad_solution *r = NULL;
    rad_error e = {0};
    /* damaged: unnoticed without the part, named with it */
    memcpy(c, buf, size);
    c[rat + rlen / 2] ^= 0x10;
    CHECK(rad_solution_parse_parts(c, size, "d.sol", 1, 0, &r, &e) == RAD_OK && r &&
          same_bits(r->elements->B, x->B, 8ull * ne * nb));
    rad_solution_destroy(r);
    r = NULL;
    CHECK(rad_solution_parse_parts(c, size, "d.sol", 1, RAD_PART_ELEMENT_ROWS, &r, &e) ==
              RAD_ERR_CORRUPT && !r);
    CHECK_MSG(strcmp(e.message, "d.sol: section ELEMENTROWS: checksum mismatch: the file is "
                                "corrupt") == 0, "%s", e.message);
    /* the entry count not ELEMENTS' */
    memcpy(c, buf, size);
    wr64(c + rat + 4, x->nnz + 1);
    v6_fix(c, size);
    char want[200];
    snprintf(want, sizeof want, "section ELEMENTROWS: %u elements and %llu entries, but ELEMENTS "
             "has %u and %llu", ne, (unsigned long long)x->nnz + 1, ne,
             (unsigned long long)x->nnz);
    refused_with(c, size, "d.sol", want, 0);
    free(c);
    /* missing, though ELEMENTS counts entries (refused without the part too) */
    size_t n = 0;
    c = v6_drop_section(buf, size, "ELRW", &n);
    CHECK(rad_solution_parse_parts(c, n, "m.sol", 1, 0, &r, &e) == RAD_ERR_CORRUPT && !r);
    CHECK_MSG(strcmp(e.message, "m.sol: section ELEMENTROWS missing") == 0, "%s", e.message);
    free(c);
    /* in a version 6 file (the index's version field 0 as version 6 has it) */
    c = malloc(size);
    memcpy(c, buf, size);
    wr32(c + 8, 6);
    wr32(c + v6_index_at(c) + 4, 0);
    v6_fix(c, size);
    CHECK(rad_solution_parse_parts(c, size, "v6.sol", 1, 0, &r, &e) == RAD_ERR_CORRUPT && !r);
    CHECK_MSG(strstr(e.message, "section ELEMENTROWS in a version 6 file"), "%s", e.message);
    /* the header's version under the index's CRC: 7 -> 6 alone is refused */
    memcpy(c, buf, size);
    wr32(c + 8, 6);
    CHECK(rad_solution_parse_parts(c, size, "v6.sol", 1, 0, &r, &e) == RAD_ERR_CORRUPT && !r);
    free(c);
    size_t bad = v6_damage_from(buf, size, rat, rat, (size_t)rlen);
    printf("     %zu bytes (ELEMENTS %llu, ELEMENTROWS %llu): %zu cuts or flips accepted\n", size,
           (unsigned long long)len, (unsigned long long)rlen, bad);
    CHECK(bad == 0);
    free(buf);
    rad_solution_destroy(a);
}

/* A version 6 file with elements (the corpus's, as version 6 wrote them,
 * their rows inside ELEMENTS) reads as it did: written again (version 7)
 * and read back, every element is the same bit for bit, and the two files
 * hold the same bytes in another place - version 6's ELEMENTS is version
 * 7's ELEMENTS with each element's row entries, which are ELEMENTROWS'
 * after its 12-byte head, in element order. */
TEST(version_6_elements_read_identically)
{
    static const char *const names[2] = {"elements-room-v6", "interp-room-v6"};
    for (int k = 0; k < 2; k++) {
        char p[300], out[600];
        snprintf(p, sizeof p, CORPUS "%s", names[k]);
        size_t n6 = 0, n7 = 0;
        uint8_t *b6 = slurp(p, &n6);
        rad_solution *s = NULL, *r = NULL;
        rad_error e = {0};
        CHECK_MSG(rad_solution_read(p, &s, &e) == RAD_OK, "%s", e.message);
        CHECK(b6 && rd32(b6 + 8) == 6 && s && s->elements && s->elements->rows_loaded &&
              s->elements->nnz > 0);
        uint8_t *b7 = s && b6 ? written_image(s, "v6again.sol", out, &n7) : NULL;
        CHECK_MSG(b7 && rad_solution_read(out, &r, &e) == RAD_OK, "%s", e.message);
        if (r && s) {
            check_same(s, r);
            check_same_elements(s->elements, r->elements, s->band_count);
        }
        uint64_t l6 = 0, l7 = 0, lr = 0;
        size_t a6 = b7 ? v6_find(b6, n6, "ELEM", &l6) : 0, a7 = b7 ? v6_find(b7, n7, "ELEM", &l7) : 0;
        size_t ar = b7 ? v6_find(b7, n7, "ELRW", &lr) : 0;
        CHECK(a6 && a7 && ar && l6 + 12 == l7 + lr);
        if (a6 && a7 && ar && l6 + 12 == l7 + lr && s) {
            /* walk version 6's ELEMENTS: its head and vertices, then per
             * element its fixed part (ending with the count c) and c
             * varints and c floats */
            const uint32_t nb = s->band_count, ne = s->elements->mesh->patch_count;
            size_t head = 36 + 25ull * s->elements->mesh->vertex_count, p6 = a6 + head,
                   p7 = a7 + head, pr = ar + 12, fixed = 25 + 8ull * nb;
            int same = memcmp(b6 + a6, b7 + a7, head) == 0;
            for (uint32_t q = 0; q < ne && same; q++) {
                uint32_t cnt = rd32(b6 + p6 + fixed - 4);
                same = memcmp(b6 + p6, b7 + p7, fixed) == 0;
                p6 += fixed;
                p7 += fixed;
                size_t row = 0;
                for (uint32_t v = 0; v < cnt; v++)
                    while (b6[p6 + row++] & 0x80)
                        ;
                row += 4ull * cnt;
                same = same && memcmp(b6 + p6, b7 + pr, row) == 0;
                p6 += row;
                pr += row;
            }
            CHECK(same && p6 == a6 + l6 && p7 == a7 + l7 && pr == ar + lr);
        }
        rad_solution_destroy(r);
        rad_solution_destroy(s);
        free(b6);
        free(b7);
    }
}

/* ------------------------------------------------------------- BASIS */

/* The rgb room with stored light responses made by hand (its F lacks rows,
 * so the pipeline would make none for its three groups): odd bit patterns,
 * every value finite and >= 0.  The format is what is tested here; that
 * the responses superpose to the solution is test/cli/basis.sh's. */
static rad_solution *make_basis(void)
{
    rad_solution *s = make_rgb();
    if (!s)
        return NULL;
    const uint32_t n = s->mesh->patch_count, nb = s->band_count, nl = s->scene->light_count;
    uint32_t *pg = malloc((n + 1) * sizeof *pg), *lg = malloc((nl + 1) * sizeof *lg), K = 0;
    if (!pg || !lg || rad_basis_groups(s, pg, lg, &K, NULL) || K != 3 ||
        !(s->basis = rad_basis_create(s, K))) {
        free(pg);
        free(lg);
        rad_solution_destroy(s);
        return NULL;
    }
    rad_basis *b = s->basis;
    memcpy(b->patch_group, pg, n * sizeof *pg);
    memcpy(b->light_group, lg, nl * sizeof *lg);
    const size_t nv = (size_t)n * nb;
    for (uint32_t g = 0; g < K; g++) {
        b->residual[g] = 1e-5 * (g + 1) / 3.0;
        for (size_t q = 0; q < nv; q++) {
            b->B[g * nv + q] = s->B[q] * (g + 1) / 6.0;
            b->H[g * nv + q] = s->B[q] * (g + 2) / 7.0;
        }
    }
    free(pg);
    free(lg);
    return s;
}

/* BASIS (issue 21): a round trip is bit exact, and written again gives
 * the same bytes; a stale basis (ρ changed since) is not written; the
 * structure checks refuse bad counts and values, naming the section. */
TEST(basis_round_trip_and_damage)
{
    rad_solution *s = make_basis();
    CHECK(s != NULL);
    if (!s)
        return;
    char p[600], p2[600];
    size_t size = 0, size2 = 0;
    uint8_t *img = written_image(s, "basis.sol", p, &size);
    rad_solution *r = NULL;
    rad_error e = {0};
    CHECK_MSG(img && rad_solution_read(p, &r, &e) == RAD_OK, "%s", e.message);
    if (!img || !r) {
        free(img);
        rad_solution_destroy(s);
        return;
    }
    const rad_basis *a = s->basis, *b = r->basis;
    const size_t nv = (size_t)a->patch_count * a->band_count;
    CHECK(b && b->groups == a->groups && b->light_count == a->light_count &&
          rad_basis_matches(r));
    if (b) {
        CHECK(same_bits(a->E_ref, b->E_ref, nv * 8) && same_bits(a->B, b->B, a->groups * nv * 8) &&
              same_bits(a->H, b->H, a->groups * nv * 8) &&
              same_bits(a->I_ref, b->I_ref, (size_t)a->light_count * a->band_count * 8) &&
              same_bits(a->patch_group, b->patch_group, a->patch_count * 4) &&
              same_bits(a->light_group, b->light_group, a->light_count * 4) &&
              same_bits(a->residual, b->residual, a->groups * 8));
    }
    uint8_t *img2 = written_image(r, "basis2.sol", p2, &size2);
    CHECK(img2 && size2 == size && memcmp(img, img2, size) == 0);
    free(img2);
    /* read without F (relight's way) it is there too; without the part
     * (render's and report's way) it is not read, and that is known */
    rad_solution *parts = NULL;
    CHECK(rad_solution_read_parts(p, RAD_PART_BASIS, &parts, &e) == RAD_OK && parts &&
          parts->basis && parts->basis->groups == 3 && !rad_solution_basis_skipped(parts));
    rad_solution_destroy(parts);
    parts = NULL;
    CHECK(rad_solution_read_parts(p, 0, &parts, &e) == RAD_OK && parts && !parts->basis &&
          rad_solution_basis_skipped(parts));
    rad_solution_destroy(parts);

    /* the sizes in BASIS's head, then a group, then a value */
    uint64_t len;
    size_t at = v6_find(img, size, "BASI", &len);
    CHECK(at > 0 && rd32(img + at) == 3);
    struct {
        size_t off;
        uint32_t value;
        const char *want;
    } heads[] = {
        {0, 0, "section BASIS: 0 light groups (1..32)"},
        {0, 33, "section BASIS: 33 light groups (1..32)"},
        {0, 4, "section BASIS: 4 groups of"},
        {0, 0xFFFFFFFFu, "light groups (1..32)"},
        {4, 1, "section BASIS: 1 patches, 3 bands"},
        {8, 2, "section BASIS: "},
        {12, 0, "section BASIS: "},
        {16, 7, "section BASIS: "},
    };
    for (size_t q = 0; at && q < sizeof heads / sizeof heads[0]; q++) {
        uint8_t *d = malloc(size);
        memcpy(d, img, size);
        wr32(d + at + heads[q].off, heads[q].value);
        refused_with(d, size, "m.sol", heads[q].want, 0);
        free(d);
    }
    const uint32_t n = a->patch_count, nb = a->band_count, nl = a->light_count;
    const size_t groups_at = at + 20 + 8 * ((size_t)n + nl) * nb;
    uint32_t lamp = RAD_NONE, dark = RAD_NONE;
    for (uint32_t i = 0; i < n; i++) {
        if (a->patch_group[i] != RAD_NONE && lamp == RAD_NONE)
            lamp = i;
        if (a->patch_group[i] == RAD_NONE && dark == RAD_NONE)
            dark = i;
    }
    CHECK(lamp != RAD_NONE && dark != RAD_NONE);
    if (at && lamp != RAD_NONE && dark != RAD_NONE) {
        uint8_t *d = malloc(size);
        char want[160];
        memcpy(d, img, size);
        wr32(d + groups_at + 4 * lamp, 3); /* past the groups */
        snprintf(want, sizeof want, "section BASIS: patch %u: group 3 does not agree", lamp);
        refused_with(d, size, "m.sol", want, 0);
        memcpy(d, img, size);
        wr32(d + groups_at + 4 * dark, 0); /* a group for a patch that emitted nothing */
        snprintf(want, sizeof want, "section BASIS: patch %u: group 0 does not agree", dark);
        refused_with(d, size, "m.sol", want, 0);
        memcpy(d, img, size);
        const double nan = NAN;
        memcpy(d + groups_at + 4 * ((size_t)n + nl) + 8 + 8 * 5, &nan, 8); /* B^(0) of patch 1 */
        refused_with(d, size, "m.sol", "section BASIS: light group 0: a residual, B, H", 0);
        memcpy(d, img, size);
        memcpy(d + at + 20, &nan, 8); /* E_ref of patch 0 */
        refused_with(d, size, "m.sol", "section BASIS: patch 0: reference E = nan", 0);
        free(d);
    }
    /* a stale basis is left out: ρ changed after it was made */
    r->rho[0] = r->rho[0] * 0.5;
    uint8_t *img3 = written_image(r, "stale.sol", p2, &size2);
    CHECK(img3 && !v6_find(img3, size2, "BASI", &len) && size2 < size);
    free(img3);
    rad_solution_destroy(r);
    rad_solution_destroy(s);
    free(img);
}

/* The fuzzer's version 7 seeds, NAME-v7 (the corpus keeps the files older
 * versions wrote: NAME-v6 for version 6, the names without a suffix for
 * versions 1 to 5). */
static int write_seeds(const char *dir)
{
    rad_solution *(*make[7])(void) = {make_rgb, make_grey, make_wide, make_elements, make_sheets,
                                      make_interp, make_basis};
    const char *names[7] = {"rgb-room-v7", "grey-box-v7", "wide-floor-v7", "elements-room-v7",
                            "sheets-room-v7", "interp-room-v7", "basis-room-v7"};
    for (int v = 0; v < 7; v++) {
        rad_solution *s = make[v]();
        char p[600];
        snprintf(p, sizeof p, "%s/%s", dir, names[v]);
        rad_error e;
        if (!s || rad_solution_write(s, p, &e)) {
            fprintf(stderr, "%s: %s\n", p, s ? e.message : "fixture failed");
            rad_solution_destroy(s);
            return 1;
        }
        rad_solution_destroy(s);
    }
    /* and the frozen version 5 files whose sections no fixture here makes
     * (CAMERAS, SURFACE, CLUSTERS), read and written again */
    const char *frozen[3] = {"ortho-camera", "glossy-room", "clusters-floor"};
    for (int v = 0; v < 3; v++) {
        char from[300], p[600];
        snprintf(from, sizeof from, CORPUS "%s", frozen[v]);
        snprintf(p, sizeof p, "%s/%s-v7", dir, frozen[v]);
        rad_solution *s = NULL;
        rad_error e;
        if (rad_solution_read(from, &s, &e) || rad_solution_write(s, p, &e)) {
            fprintf(stderr, "%s: %s\n", p, e.message);
            rad_solution_destroy(s);
            return 1;
        }
        rad_solution_destroy(s);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--write-seeds") == 0)
        return write_seeds(argv[2]);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/test_solution.XXXXXX");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    RUN(crc_matches_published_check_value);
    RUN(stage_names);
    RUN(create_copies_materials);
    RUN(round_trip_is_bit_exact);
    RUN(matrix_without_entries_round_trips);
    RUN(layout_follows_the_format);
    RUN(every_truncation_is_refused);
    RUN(every_byte_flip_is_refused);
    RUN(structure_errors_name_section_and_element);
    RUN(encoding_rules_are_enforced);
    RUN(unknown_sections_are_skipped);
    RUN(read_without_matrix);
    RUN(elements_round_trip_and_damage);
    RUN(interpolated_elements_round_trip);
    RUN(element_rows_section);
    RUN(version_6_elements_read_identically);
    RUN(basis_round_trip_and_damage);
    RUN(sheets_round_trip_and_version_5);
    RUN(newer_version_and_foreign_files);
    RUN(failed_writes_leave_no_trace);
    RUN(writer_refuses_what_reader_would);
    RUN(older_versions_still_read);
    RUN(version_2_file_reads_as_written);
    RUN(version_2_cuts_and_flips_refused);
    RUN(version_2_structure_errors_name_section_and_element);
    RUN(version_2_encoding_rules_are_enforced);
    RUN(version_2_unknown_sections_are_skipped);
    RUN(version_3_elements_file_still_reads);
    RUN(version_4_elements_file);
    free(golden);
    free(old_golden);
    remove_tree(tmpdir);
    return test_finish("test_solution");
}
