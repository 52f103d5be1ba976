/* test_export.c - open data (issue 21): `export` writes patches.csv, F.mtx,
 * elements.csv and elements-F.mtx, and each reads back to the values of the
 * solution it came from.  The readers here are the test's own (an RFC 4180
 * CSV reader and a Matrix Market coordinate reader with strtod), written
 * from the formats, not from the writer's code.
 *   - every value of every patch and element, exactly (==, not a
 *     tolerance: the export promises numbers that read back exactly);
 *   - names with a comma, a quote and a leading space survive quoting;
 *   - F's rows: present exactly where the solution computed them (F_row),
 *     each entry equal to the stored float, nothing else in the file;
 *   - element rows likewise against the stored F_ej;
 *   - no directory: an error and no file.
 * Cost: one solve of 78 patches with one level of elements (309), ~0.3 s
 * (release; ~2 s with the sanitizers).
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ------------------------------------------------- the test's own readers */

/* A CSV file as records of fields (RFC 4180: "..." quotes, "" inside is
 * one quote; records end at \n outside quotes). */
typedef struct csv_table {
    uint32_t rows, cols;  /* rows include the header */
    char **field;         /* rows × cols, each malloc'd */
    int ragged;           /* a record with another field count */
} csv_table;

static void csv_free(csv_table *t)
{
    for (size_t k = 0; t->field && k < (size_t)t->rows * t->cols; k++)
        free(t->field[k]);
    free(t->field);
}

static int csv_read(const char *path, csv_table *t)
{
    memset(t, 0, sizeof *t);
    size_t size = 0;
    char *text = test_slurp(path, &size);
    if (!text)
        return -1;
    size_t cap = 0, n = 0;
    char **f = NULL;
    uint32_t in_row = 0;
    size_t at = 0;
    while (at < size) {
        /* one field */
        char *v = malloc(size - at + 1);
        size_t len = 0;
        if (text[at] == '"') {
            at++;
            while (at < size) {
                if (text[at] == '"' && at + 1 < size && text[at + 1] == '"') {
                    v[len++] = '"';
                    at += 2;
                } else if (text[at] == '"') {
                    at++;
                    break;
                } else {
                    v[len++] = text[at++];
                }
            }
        } else {
            while (at < size && text[at] != ',' && text[at] != '\n')
                v[len++] = text[at++];
        }
        v[len] = '\0';
        if (n == cap) {
            cap = cap ? 2 * cap : 1024;
            f = realloc(f, cap * sizeof *f);
        }
        f[n++] = v;
        in_row++;
        if (at >= size || text[at] == '\n') {
            if (t->rows == 0)
                t->cols = in_row;
            else if (in_row != t->cols)
                t->ragged = 1;
            t->rows++;
            in_row = 0;
        }
        at++; /* the ',' or '\n' */
    }
    free(text);
    t->field = f;
    if (t->ragged || (size_t)t->rows * t->cols != n)
        return -1;
    return 0;
}

static const char *cell(const csv_table *t, uint32_t row, uint32_t col)
{
    return t->field[(size_t)row * t->cols + col];
}

/* The whole field is one number, and it is exactly v. */
static int same_number(const char *s, double v)
{
    char *end;
    double x = strtod(s, &end);
    return end != s && *end == '\0' && x == v;
}

/* A Matrix Market "coordinate real general" file. */
typedef struct mtx {
    uint32_t rows, cols;
    uint64_t nnz;
    uint32_t *i, *j; /* 1-based, as in the file */
    double *v;
} mtx;

static void mtx_free(mtx *m)
{
    free(m->i);
    free(m->j);
    free(m->v);
}

static int mtx_read(const char *path, mtx *m)
{
    memset(m, 0, sizeof *m);
    size_t size = 0;
    char *text = test_slurp(path, &size);
    if (!text)
        return -1;
    int rc = -1;
    char *save = NULL, *line = strtok_r(text, "\n", &save);
    if (!line || strcmp(line, "%%MatrixMarket matrix coordinate real general"))
        goto done;
    while ((line = strtok_r(NULL, "\n", &save)) && line[0] == '%')
        ;
    unsigned long long nnz;
    if (!line || sscanf(line, "%u %u %llu", &m->rows, &m->cols, &nnz) != 3)
        goto done;
    m->nnz = nnz;
    m->i = malloc((nnz + 1) * sizeof *m->i);
    m->j = malloc((nnz + 1) * sizeof *m->j);
    m->v = malloc((nnz + 1) * sizeof *m->v);
    uint64_t k = 0;
    while ((line = strtok_r(NULL, "\n", &save))) {
        if (k == nnz || sscanf(line, "%u %u %lf", &m->i[k], &m->j[k], &m->v[k]) != 3)
            goto done;
        k++;
    }
    rc = k == nnz ? 0 : -1;
done:
    free(text);
    return rc;
}

/* Compares the matrix with stored rows: row r (1-based) present in the file
 * exactly when present[r-1], each entry (r, c, v) stored as F[r-1][c-1] ==
 * (float)v, and every stored entry of a present row in the file. */
static void check_rows(const mtx *m, uint32_t rows, uint32_t cols, const uint8_t *present,
                       const uint64_t *row_start, const uint32_t *row_count, const uint32_t *col,
                       const float *val)
{
    CHECK(m->rows == rows && m->cols == cols);
    uint32_t *seen = calloc((size_t)rows + 1, sizeof *seen);
    uint64_t expect = 0, bad = 0;
    for (uint32_t r = 0; r < rows; r++)
        expect += present[r] ? row_count[r] : 0;
    CHECK_MSG(m->nnz == expect, "%llu entries, expected %llu", (unsigned long long)m->nnz,
              (unsigned long long)expect);
    for (uint64_t k = 0; k < m->nnz; k++) {
        uint32_t r = m->i[k] - 1, c = m->j[k] - 1;
        if (m->i[k] < 1 || r >= rows || m->j[k] < 1 || c >= cols || !present[r]) {
            bad++;
            continue;
        }
        /* the row's columns increase: binary search */
        uint64_t lo = row_start[r], hi = row_start[r] + row_count[r];
        while (lo < hi) {
            uint64_t mid = (lo + hi) / 2;
            if (col[mid] < c)
                lo = mid + 1;
            else
                hi = mid;
        }
        /* 9 digits name one float: read as a double and rounded, it is F */
        if (lo == row_start[r] + row_count[r] || col[lo] != c || (float)m->v[k] != val[lo])
            bad++;
        else
            seen[r]++;
    }
    CHECK_MSG(bad == 0, "%llu entries not as stored", (unsigned long long)bad);
    uint32_t short_rows = 0;
    for (uint32_t r = 0; r < rows; r++)
        short_rows += present[r] && seen[r] != row_count[r];
    CHECK_MSG(short_rows == 0, "%u rows missing entries", short_rows);
    free(seen);
}

/* ---------------------------------------------------------------- scene */

/* A floor of 8×8 patches under a lamp, a grey wall, and a panel whose
 * object and material names need CSV quoting; two named bands. */
static rad_solution *export_scene(void)
{
    static const char text[] =
        "bands 2 names vis ir\n"
        "material white reflectance 0.5 0.4\n"
        "material lamp reflectance 0 emission 10 5\n"
        "polygon floor white subdivide 8 8\n 0 0 0\n 0 0 1\n 1 0 1\n 1 0 0\nend\n"
        "polygon wall white subdivide 3 3\n 0 0 0\n 0 1 0\n 0 1 1\n 0 0 1\nend\n"
        "polygon lamp lamp subdivide 1 1\n 0.4 1 0.4\n 0.6 1 0.4\n 0.6 1 0.6\n 0.4 1 0.6\nend\n";
    rad_scene *scene = NULL;
    rad_error err = {0};
    if (rad_scene_parse_polyfile(text, sizeof text - 1, "export.rad", NULL, &scene, &err)) {
        fprintf(stderr, "  parse: %s\n", err.message);
        return NULL;
    }
    const double rho[2] = {0.3, 0.2}, zero[2] = {0, 0};
    const rad_vec3 panel[4] = {{1, 0, 0.2}, {1, 0, 0.8}, {1, 0.6, 0.8}, {1, 0.6, 0.2}};
    uint32_t mat, obj;
    if (rad_scene_add_material(scene, "odd \"grey\", matte", rho, zero, NULL, "test", &mat, &err) ||
        rad_scene_add_object(scene, " panel, east", "test", &obj, &err) ||
        rad_scene_add_polygon(scene, "panel", obj, mat, panel, 4, 2, 2, "test", NULL, &err)) {
        fprintf(stderr, "  build: %s\n", err.message);
        rad_scene_destroy(scene);
        return NULL;
    }
    rad_solve_options opt = {0};
    opt.hemicube.resolution = 64;
    opt.element_levels = 1;
    rad_solution *s = NULL;
    if (rad_solve_scene(scene, &opt, &s, &err)) {
        fprintf(stderr, "  solve: %s\n", err.message);
        return NULL;
    }
    return s;
}

/* ----------------------------------------------------------------- tests */

static void remove_dir(const char *dir)
{
    const char *names[] = {"patches.csv", "F.mtx", "elements.csv", "elements-F.mtx", "s.sol"};
    char path[512];
    for (size_t k = 0; k < sizeof names / sizeof names[0]; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, names[k]);
        unlink(path);
    }
    rmdir(dir);
}

/* export_scene's solution, solved once for both tests (main owns it). */
static rad_solution *made;

/* The solution written to a file and read back (what `export` reads),
 * exported, and every file read back against it. */
TEST(export_round_trips)
{
    CHECK(made != NULL);
    if (!made)
        return;
    char dir[] = "/tmp/test_export_XXXXXX", path[512];
    CHECK(mkdtemp(dir) != NULL);
    rad_error err = {0};
    rad_solution *s = NULL;
    snprintf(path, sizeof path, "%s/s.sol", dir);
    CHECK(rad_solution_write(made, path, &err) == RAD_OK);
    CHECK(rad_solution_read(path, &s, &err) == RAD_OK);
    if (!s) {
        remove_dir(dir);
        return;
    }
    CHECK_MSG(rad_solution_export(s, dir, &err) == RAD_OK, "%s", err.message);
    const uint32_t n = s->mesh->patch_count, nb = s->band_count;
    CHECK(s->elements != NULL && s->F->rows_done < n); /* the lamp has no row */

    /* patches.csv */
    csv_table t;
    snprintf(path, sizeof path, "%s/patches.csv", dir);
    CHECK(csv_read(path, &t) == 0);
    const char *head[] = {"patch", "object", "material", "area", "centroid_x", "centroid_y",
                          "centroid_z", "normal_x", "normal_y", "normal_z", "F_row",
                          "rho_vis", "rho_ir", "E_vis", "E_ir", "B_vis", "B_ir"};
    const uint32_t nh = sizeof head / sizeof head[0];
    CHECK(t.rows == n + 1 && t.cols == nh);
    for (uint32_t c = 0; t.rows && c < nh && c < t.cols; c++)
        CHECK_MSG(!strcmp(cell(&t, 0, c), head[c]), "column %u is '%s'", c, cell(&t, 0, c));
    uint32_t bad = 0, quoted = 0;
    for (uint32_t i = 0; t.rows == n + 1 && t.cols == nh && i < n; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        const double geo[7] = {p->area,     p->center.x, p->center.y, p->center.z,
                               p->normal.x, p->normal.y, p->normal.z};
        int ok = same_number(cell(&t, i + 1, 0), i) &&
                 !strcmp(cell(&t, i + 1, 1), s->scene->objects[p->object].name) &&
                 !strcmp(cell(&t, i + 1, 2), s->scene->materials[p->material].name) &&
                 same_number(cell(&t, i + 1, 10), s->F->row_done[i] ? 1 : 0);
        for (int k = 0; k < 7; k++)
            ok &= same_number(cell(&t, i + 1, 3 + (uint32_t)k), geo[k]);
        for (uint32_t b = 0; b < nb; b++) {
            ok &= same_number(cell(&t, i + 1, 11 + b), s->rho[(size_t)i * nb + b]);
            ok &= same_number(cell(&t, i + 1, 11 + nb + b), s->emission[(size_t)i * nb + b]);
            ok &= same_number(cell(&t, i + 1, 11 + 2 * nb + b), s->B[(size_t)i * nb + b]);
        }
        bad += !ok;
        quoted += !strcmp(cell(&t, i + 1, 1), " panel, east") &&
                  !strcmp(cell(&t, i + 1, 2), "odd \"grey\", matte");
    }
    CHECK_MSG(bad == 0, "%u of %u patch rows differ from the solution", bad, n);
    CHECK(quoted == 4); /* the panel's 2×2 patches */
    csv_free(&t);

    /* F.mtx */
    mtx m;
    snprintf(path, sizeof path, "%s/F.mtx", dir);
    CHECK(mtx_read(path, &m) == 0);
    check_rows(&m, n, n, s->F->row_done, s->F->row_start, s->F->row_count, s->F->col, s->F->val);
    mtx_free(&m);

    /* elements.csv */
    const rad_elements *el = s->elements;
    const uint32_t ne = el ? el->mesh->patch_count : 0;
    snprintf(path, sizeof path, "%s/elements.csv", dir);
    CHECK(csv_read(path, &t) == 0);
    CHECK(t.rows == ne + 1 && t.cols == 10 + nb);
    CHECK(t.rows && !strcmp(cell(&t, 0, 0), "element") && !strcmp(cell(&t, 0, 10), "B_vis"));
    bad = 0;
    for (uint32_t e = 0; el && t.rows == ne + 1 && t.cols == 10 + nb && e < ne; e++) {
        const rad_patch *p = &el->mesh->patches[e];
        const double v[10] = {e,          el->patch[e], el->level[e], p->area,     p->center.x,
                              p->center.y, p->center.z, p->normal.x,  p->normal.y, p->normal.z};
        int ok = 1;
        for (uint32_t k = 0; k < 10; k++)
            ok &= same_number(cell(&t, e + 1, k), v[k]);
        for (uint32_t b = 0; b < nb; b++)
            ok &= same_number(cell(&t, e + 1, 10 + b), el->B[(size_t)e * nb + b]);
        bad += !ok;
    }
    CHECK_MSG(bad == 0, "%u of %u element rows differ from the solution", bad, ne);
    csv_free(&t);

    /* elements-F.mtx: rows exist from level 1 */
    snprintf(path, sizeof path, "%s/elements-F.mtx", dir);
    CHECK(mtx_read(path, &m) == 0);
    if (el)
        check_rows(&m, ne, n, el->level, el->row_start, el->row_count, el->col, el->val);
    mtx_free(&m);

    rad_solution_destroy(s);
    remove_dir(dir);
}

/* No such directory: an I/O error naming it, and no file appears. */
TEST(export_into_a_missing_directory_fails_cleanly)
{
    const rad_solution *s = made;
    CHECK(s != NULL);
    if (!s)
        return;
    char dir[] = "/tmp/test_export_XXXXXX", missing[600], path[700];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(missing, sizeof missing, "%s/none", dir);
    rad_error err = {0};
    CHECK(rad_solution_export(s, missing, &err) == RAD_ERR_IO);
    CHECK_MSG(strstr(err.message, "none/patches.csv") != NULL, "%s", err.message);
    struct stat st;
    snprintf(path, sizeof path, "%s/patches.csv", missing);
    CHECK(stat(path, &st) != 0);
    remove_dir(dir);
}

int main(void)
{
    made = export_scene();
    RUN(export_round_trips);
    RUN(export_into_a_missing_directory_fails_cleanly);
    rad_solution_destroy(made);
    return test_finish("test_export");
}
