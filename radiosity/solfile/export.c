/* export.c - a solution as open data: per-patch (and per-element) results
 * as CSV, the form factors as Matrix Market, for numpy/scipy, Julia,
 * MATLAB or a spreadsheet (docs/export.md says what each column means and
 * how to load each file in one line).
 *
 * Invariants: every number reads back exactly - doubles with 15 to 17
 * significant digits (the fewest that do), the float F_ij with 9 - so a
 * reader holds the values the solution holds;
 * row r of a CSV (after its header) is row r of the matching matrix, the
 * same order as the solution's patches (elements); a row of F that was
 * never computed is absent from the matrix (and F_row is 0 in the CSV),
 * never written as zeros.  Every file goes through a rad_output and all
 * are committed only once all are written, so a failure leaves every
 * earlier file in the directory as it was.
 */
#include "solfile.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Text into a rad_output through a buffer: one write per 64 KiB, not per
 * number.  Write errors stick in the rad_output and surface at commit. */
typedef struct text_out {
    rad_output *o;
    size_t n;
    char buf[1 << 16];
} text_out;

static void t_flush(text_out *t)
{
    rad_output_write(t->o, t->buf, t->n);
    t->n = 0;
}

static void t_putc(text_out *t, char c)
{
    if (t->n == sizeof t->buf)
        t_flush(t);
    t->buf[t->n++] = c;
}

/* Short formatted pieces (numbers, indices): under 256 bytes each. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static void t_printf(text_out *t, const char *fmt, ...)
{
    if (sizeof t->buf - t->n < 256)
        t_flush(t);
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(t->buf + t->n, sizeof t->buf - t->n, fmt, ap);
    va_end(ap);
    if (k > 0)
        t->n += (size_t)k < sizeof t->buf - t->n ? (size_t)k : sizeof t->buf - t->n - 1;
}

/* One CSV field (RFC 4180): quoted, with quotes doubled, only when it
 * holds a comma, a quote, a line break or spaces at either end; the
 * pieces of a name column (prefix + name) are joined. */
static void t_field(text_out *t, const char *prefix, const char *s)
{
    size_t len = strlen(s);
    int quote = len && (s[0] == ' ' || s[len - 1] == ' ');
    for (const char *p = s; *p && !quote; p++)
        quote = *p == ',' || *p == '"' || *p == '\n' || *p == '\r';
    if (quote)
        t_putc(t, '"');
    for (const char *p = prefix; *p; p++)
        t_putc(t, *p);
    for (const char *p = s; *p; p++) {
        if (*p == '"')
            t_putc(t, '"');
        t_putc(t, *p);
    }
    if (quote)
        t_putc(t, '"');
}

/* Band b's label in column names: the scene's band name, else R, G, B for
 * three bands and Y for one (the EXR's channels), else its index. */
static const char *band_label(const rad_scene *sc, uint32_t b, char *buf, size_t size)
{
    static const char *rgb[3] = {"R", "G", "B"};
    if (sc->band_names[b] && sc->band_names[b][0])
        return sc->band_names[b];
    if (sc->band_count == 3)
        return rgb[b];
    if (sc->band_count == 1)
        return "Y";
    snprintf(buf, size, "%u", b);
    return buf;
}

/* ",PREFIX_band" for every band. */
static void band_columns(text_out *t, const rad_scene *sc, const char *prefix)
{
    char buf[16];
    for (uint32_t b = 0; b < sc->band_count; b++) {
        t_putc(t, ',');
        t_field(t, prefix, band_label(sc, b, buf, sizeof buf));
    }
}

/* ",v" with the fewest significant digits (15 to 17) that read back as v
 * exactly: 0.725, not 0.72499999999999998. */
static void t_double(text_out *t, double v)
{
    char buf[40];
    for (int digits = 15; digits <= 17; digits++) {
        snprintf(buf, sizeof buf, "%.*g", digits, v);
        if (digits == 17 || strtod(buf, NULL) == v)
            break;
    }
    t_printf(t, ",%s", buf);
}

/* ",v" for the bands' values of one row. */
static void band_values(text_out *t, const double *v, uint32_t bands)
{
    for (uint32_t b = 0; b < bands; b++)
        t_double(t, v[b]);
}

/* area, centroid and normal of one cell. */
static void geometry(text_out *t, const rad_patch *p)
{
    const double g[7] = {p->area,     p->center.x, p->center.y, p->center.z,
                         p->normal.x, p->normal.y, p->normal.z};
    for (int k = 0; k < 7; k++)
        t_double(t, g[k]);
}

static const char geometry_columns[] =
    "area,centroid_x,centroid_y,centroid_z,normal_x,normal_y,normal_z";

static void patches_csv(text_out *t, const rad_solution *s)
{
    const rad_scene *sc = s->scene;
    const uint32_t nb = s->band_count;
    t_printf(t, "patch,object,material,%s,F_row", geometry_columns);
    band_columns(t, sc, "rho_");
    band_columns(t, sc, "E_");
    band_columns(t, sc, "B_");
    t_putc(t, '\n');
    for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        t_printf(t, "%u,", i);
        t_field(t, "", sc->objects[p->object].name);
        t_putc(t, ',');
        t_field(t, "", sc->materials[p->material].name);
        geometry(t, p);
        t_printf(t, ",%d", s->F->row_done[i] ? 1 : 0);
        band_values(t, s->rho + (size_t)i * nb, nb);
        band_values(t, s->emission + (size_t)i * nb, nb);
        band_values(t, s->B + (size_t)i * nb, nb);
        t_putc(t, '\n');
    }
}

static void elements_csv(text_out *t, const rad_solution *s)
{
    const rad_elements *el = s->elements;
    const uint32_t nb = s->band_count;
    t_printf(t, "element,patch,level,%s", geometry_columns);
    band_columns(t, s->scene, "B_");
    t_putc(t, '\n');
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        t_printf(t, "%u,%u,%u", e, el->patch[e], el->level[e]);
        geometry(t, &el->mesh->patches[e]);
        band_values(t, el->B + (size_t)e * nb, nb);
        t_putc(t, '\n');
    }
}

/* Row i of a matrix into col[] and val[] (room for `cols` entries each);
 * its entry count. */
typedef uint32_t (*row_get)(const void *src, uint32_t i, uint32_t *col, float *val);

/* F's rows, packed (rad.h): decoded. */
static uint32_t patch_row(const void *src, uint32_t i, uint32_t *col, float *val)
{
    return rad_matrix_get_row(src, i, col, val);
}

/* The elements' rows, in (row_start, row_count, col, val). */
static uint32_t element_row(const void *src, uint32_t e, uint32_t *col, float *val)
{
    const rad_elements *el = src;
    uint32_t c = el->row_count[e];
    memcpy(col, el->col + el->row_start[e], (size_t)c * sizeof *col);
    memcpy(val, el->val + el->row_start[e], (size_t)c * sizeof *val);
    return c;
}

/* Rows present where present[i] != 0 (a present row may be empty: a row of
 * zeros), row_count[i] entries each, read by get from src, as a Matrix
 * Market coordinate file of rows × cols, 1-based.  `what` is the comment
 * block's text.  0, or -1 when memory for a row runs out. */
static int matrix_mtx(text_out *t, const char *what, uint32_t rows, uint32_t cols,
                      const uint8_t *present, const uint32_t *row_count, row_get get,
                      const void *src)
{
    uint64_t nnz = 0;
    uint32_t done = 0;
    for (uint32_t i = 0; i < rows; i++)
        if (present[i]) {
            nnz += row_count[i];
            done++;
        }
    t_printf(t, "%%%%MatrixMarket matrix coordinate real general\n");
    for (const char *p = what; *p; p++) { /* each line of `what` a comment */
        if (p == what || p[-1] == '\n')
            t_printf(t, "%% ");
        t_putc(t, *p);
    }
    t_printf(t, "\n%% rows present: %u of %u\n", done, rows);
    t_printf(t, "%u %u %llu\n", rows, cols, (unsigned long long)nnz);
    uint32_t *col = malloc(((size_t)cols + 1) * sizeof *col);
    float *val = malloc(((size_t)cols + 1) * sizeof *val);
    int rc = col && val ? 0 : -1;
    for (uint32_t i = 0; i < rows && !rc; i++) {
        if (!present[i])
            continue;
        uint32_t c = get(src, i, col, val);
        for (uint32_t k = 0; k < c; k++)
            t_printf(t, "%u %u %.9g\n", i + 1, col[k] + 1, (double)val[k]);
    }
    free(col);
    free(val);
    return rc;
}

/* The files, in the order they are written and committed. */
enum { OUT_PATCHES, OUT_F, OUT_ELEMENTS, OUT_ELEMENTS_F, OUT_COUNT };
static const char *const out_name[OUT_COUNT] = {"patches.csv", "F.mtx", "elements.csv",
                                                "elements-F.mtx"};

int rad_solution_export(const rad_solution *s, const char *dir, rad_error *err)
{
    if (!s || !dir || !*dir)
        return rad_fail(err, RAD_ERR_USAGE, "export: no solution or no directory");
    if (!s->F->entries_loaded)
        return rad_fail(err, RAD_ERR_USAGE, "export: the form factors were not read");
    RAD_ASSERT(!s->elements || s->elements->rows_loaded); /* read with RAD_PART_ELEMENT_ROWS */
    if (s->elements && !s->elements->rows_loaded)
        return rad_fail(err, RAD_ERR_USAGE, "export: the elements' rows were not read");
    int files = s->elements ? OUT_COUNT : OUT_ELEMENTS;
    rad_output *out[OUT_COUNT] = {0};
    text_out *t = malloc(sizeof *t);
    if (!t)
        return rad_fail(err, RAD_ERR_NOMEM, "export: out of memory");
    int rc = RAD_OK;
    for (int f = 0; f < files && !rc; f++) {
        char path[4096];
        if ((size_t)snprintf(path, sizeof path, "%s/%s", dir, out_name[f]) >= sizeof path)
            rc = rad_fail(err, RAD_ERR_USAGE, "%s: directory name too long", dir);
        else
            rc = rad_output_open(path, &out[f], err);
    }
    char what[1024];
    for (int f = 0; f < files && !rc; f++) {
        t->o = out[f];
        t->n = 0;
        if (f == OUT_PATCHES)
            patches_csv(t, s);
        else if (f == OUT_ELEMENTS)
            elements_csv(t, s);
        else if (f == OUT_F) {
            snprintf(what, sizeof what,
                     "F_ij, the form factors of the patches of %s\n"
                     "row i, column j: patches i-1, j-1 (row i is line i of patches.csv after its header)\n"
                     "rows absent here were not computed (F_row = 0 in patches.csv): unknown, not zero",
                     s->scene->source);
            if (matrix_mtx(t, what, s->F->n, s->F->n, s->F->row_done, s->F->row_count,
                           patch_row, s->F))
                rc = rad_fail(err, RAD_ERR_NOMEM, "export: out of memory");
        } else {
            snprintf(what, sizeof what,
                     "F_ej, form factors from the elements to the patches of %s\n"
                     "row e: element e-1 (line e of elements.csv after its header); column j: patch j-1\n"
                     "elements of level 0 are their patch and have no row here (see F.mtx)",
                     s->scene->source);
            const rad_elements *el = s->elements;
            /* an element's row exists from level 1 (solution.h) */
            if (matrix_mtx(t, what, el->mesh->patch_count, s->mesh->patch_count, el->level,
                           el->row_count, element_row, el))
                rc = rad_fail(err, RAD_ERR_NOMEM, "export: out of memory");
        }
        t_flush(t);
    }
    free(t);
    /* All written: commit them all (each commit frees its output). */
    for (int f = 0; f < files; f++) {
        if (!rc)
            rc = rad_output_commit(out[f], err);
        else
            rad_output_abort(out[f]);
        out[f] = NULL;
    }
    return rc;
}
