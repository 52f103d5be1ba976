/* read.c - rad_solution_read and rad_solution_parse: the solution file of
 * docs/solution-format.md, back into a rad_solution.
 *
 * Invariant: whatever bytes rad_solution_parse is given, it either fails with
 * a message naming the file, the section and the element, or returns a
 * solution that satisfies solution.h: the scene is rebuilt through scene.c's
 * checked builders, the mesh passes rad_mesh_check, F passes
 * rad_matrix_check, and ρ ∈ [0,1), E >= 0, B >= 0 are finite.  Every count is
 * compared with the bytes left before anything is allocated.
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
    *v = sol_load_le64(c->p);
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
    return (r->announced & sol_sec_bit[k]) != 0;
}

/* Is the element check left to CLUSTERS (announced: it follows)? */
static int deferred(const reader *r)
{
    return r->version >= SOL_VERSION_SHEETS && announced(r, SEC_CLUSTERS);
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
        } else if (sol_bad_nonneg(sec) || reused > 1) {
            return TRUNC("stage %u: bad values", i);
        }
    }
    if (r->version >= SOL_VERSION_SHEETS) {
        if (!get_u8(c, &r->announced))
            return TRUNC("truncated");
        unsigned known = 0;
        for (int k = SEC_LIGHTS; k < SEC_COUNT; k++)
            known |= sol_sec_bit[k];
        if (r->announced & ~known)
            return TRUNC("announced sections 0x%x: only the bits 0x%x exist", r->announced,
                         known);
    }
    return sol_check_info(s, r->name, "section INFO", RAD_ERR_CORRUPT, r->err);
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
    s->rho = sol_alloc_band_array(n, nb);
    s->emission = sol_alloc_band_array(n, nb);
    s->B = sol_alloc_band_array(n, nb);
    if (!s->rho || !s->emission || !s->B)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for %u patches × %u bands", n, nb);
    for (uint64_t i = 0; i < count; i++)
        get_f64(c, &s->rho[i]);
    for (uint64_t i = 0; i < count; i++)
        get_f64(c, &s->emission[i]);
    for (uint64_t i = 0; i < count; i++)
        get_f64(c, &s->B[i]);
    return sol_check_patch_values(s, r->name, "section PATCHDATA", RAD_ERR_CORRUPT, r->err);
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
    if (sol_alloc_lights(s, nl) != 0)
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
    return sol_check_lights(s, r->name, "section LIGHTS", RAD_ERR_CORRUPT, r->err);
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
    /* Elements in clusters take their polygon and normal from the cell
     * they lie in: with CLUSTERS to come, they are completed there. */
    rad_error sub;
    if (!deferred(r) && rad_elements_complete(el, s, "elements", &sub))
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
    if (!deferred(r) && rad_elements_check(el, s, "elements", &sub))
        return rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

/* CLUSTERS: each patch's cell count, then the corners and polygon of the
 * cells of every patch that has several; the rest of a cell (object and
 * material its patch's, normal its polygon's, centre and area from its
 * corners) is derived, a patch of one cell is that cell, and the whole
 * layer must pass rad_mesh_check.  Elements read before are completed here
 * (they need the cells). */
static int parse_clusters(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    rad_mesh *m = s->mesh;
    const rad_scene *sc = s->scene;
    uint32_t n, nc;
    if (!get_u32(c, &n) || !get_u32(c, &nc))
        return TRUNC("truncated");
    if (n != m->patch_count)
        return TRUNC("%u patches but the mesh has %u", n, m->patch_count);
    /* every patch has a cell and takes at least one byte to count */
    if (nc < n || n > c->left || (uint64_t)(nc - n) * CLUSTER_CELL_BYTES > c->left)
        return TRUNC("%u cells for %u patches cannot fit in the %zu bytes left", nc, n, c->left);
    if (rad_mesh_alloc_cells(m, nc) != 0)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for %u cells", nc);
    uint64_t total = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t k;
        if (!get_varint(c, &k))
            return TRUNC("patch %u: cell count truncated or malformed", i);
        if (k == 0 || k > nc - total)
            return TRUNC("patch %u: %u cells (1..%llu left)", i, k,
                         (unsigned long long)(nc - total));
        m->cell_first[i] = (uint32_t)total;
        total += k;
    }
    if (total != nc)
        return TRUNC("the patches hold %llu cells, not %u", (unsigned long long)total, nc);
    m->cell_first[n] = nc;
    for (uint32_t i = 0; i < n; i++) {
        const rad_patch *p = &m->patches[i];
        uint32_t c0 = m->cell_first[i], c1 = m->cell_first[i + 1];
        if (c1 - c0 == 1) {
            m->cells[c0] = *p;
            continue;
        }
        for (uint32_t q = c0; q < c1; q++) {
            rad_patch *cell = &m->cells[q];
            int ok = 1;
            for (int k = 0; k < 4; k++)
                ok = ok && get_u32(c, &cell->v[k]);
            if (!ok || !get_u32(c, &cell->polygon))
                return TRUNC("cell %u: truncated", q);
            for (int k = 0; k < 4; k++)
                if (cell->v[k] >= m->vertex_count && !(k == 3 && cell->v[k] == RAD_NONE))
                    return TRUNC("cell %u: vertex %u out of range (%u vertices)", q, cell->v[k],
                                 m->vertex_count);
            if (cell->polygon >= sc->polygon_count)
                return TRUNC("cell %u: polygon %u out of range (%u polygons)", q, cell->polygon,
                             sc->polygon_count);
            cell->object = p->object;
            cell->material = p->material;
            cell->normal = sc->polygons[cell->polygon].normal;
            if (rad_cell_geometry(m->vertices, cell->v, cell->normal, &cell->center,
                                  &cell->area) != 0)
                return TRUNC("cell %u: area is not positive", q);
        }
    }
    rad_error sub;
    if (rad_mesh_check(m, sc->polygon_count, sc->object_count, sc->material_count, &sub))
        return rfail(r, RAD_ERR_CORRUPT, "%s",
                     strncmp(sub.message, "mesh: ", 6) == 0 ? sub.message + 6 : sub.message);
    if (s->elements && rad_elements_complete(s->elements, s, "elements", &sub))
        return rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

/* CAMERAS: which of SCENE's cameras are orthographic, in increasing order. */
static int parse_cameras(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    rad_scene *sc = s->scene;
    uint32_t n;
    if (!get_u32(c, &n))
        return TRUNC("truncated");
    int rc = check_count(r, n, ORTHO_CAMERA_BYTES, "orthographic cameras");
    if (rc)
        return rc;
    if (n == 0)
        return TRUNC("no orthographic camera (the section is written only for some)");
    for (uint32_t k = 0, last = 0; k < n; k++) {
        uint32_t i = 0;
        uint8_t projection = 0;
        double xmag = 0.0, ymag = 0.0;
        if (!get_u32(c, &i) || !get_u8(c, &projection) || !get_f64(c, &xmag) ||
            !get_f64(c, &ymag)) /* cannot fail after check_count, said for the compiler */
            return TRUNC("camera %u of %u: truncated", k, n);
        if (i >= sc->camera_count || (k > 0 && i <= last))
            return TRUNC("camera %u: out of range or out of order (%u cameras)", i,
                         sc->camera_count);
        if (projection != 1)
            return TRUNC("camera %u: projection %u is not 1 (orthographic)", i, projection);
        last = i;
        /* scene.c names the file being read, as in parse_scene */
        char *stored_source = sc->source;
        sc->source = (char *)r->name;
        rc = rad_scene_set_camera_ortho(sc, i, xmag, ymag, "section CAMERAS", r->err);
        sc->source = stored_source;
        if (rc)
            return scene_rc(r, rc);
    }
    return RAD_OK;
}

/* SURFACE: one lobe per material of the scene, checked by
 * rad_scene_set_material_lobe (the rules a loader meets). */
static int parse_surface(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    rad_scene *sc = s->scene;
    uint32_t n;
    if (!get_u32(c, &n))
        return TRUNC("truncated");
    if (n != sc->material_count)
        return TRUNC("%u materials, but the scene has %u", n, sc->material_count);
    for (uint32_t i = 0; i < n; i++) {
        double rough, spec[RAD_MAX_BANDS];
        if (!get_f64(c, &rough))
            return TRUNC("material %u: truncated", i);
        for (uint32_t b = 0; b < sc->band_count; b++)
            if (!get_f64(c, &spec[b]))
                return TRUNC("material %u: truncated", i);
        rad_error sub;
        if (rad_scene_set_material_lobe(sc, i, spec, rough, "section SURFACE", &sub))
            return rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    }
    return RAD_OK;
}

/* PROGRESS (write.c's emit_progress). */
static int parse_progress(reader *r, rad_solution *s)
{
    cursor *c = &r->c;
    uint32_t shots, count;
    double unshot, preview_seconds;
    uint8_t converged;
    uint64_t recomputed, dropped;
    if (!get_u32(c, &shots) || !get_f64(c, &unshot) || !get_u8(c, &converged) ||
        !get_u64(c, &recomputed) || !get_u64(c, &dropped) || !get_f64(c, &preview_seconds) ||
        !get_u32(c, &count))
        return TRUNC("truncated");
    int rc = check_count(r, count, PREVIEW_BYTES, "previews");
    if (rc)
        return rc;
    rad_progress *p = s->progress = rad_progress_create(count);
    if (!p)
        return rfail(r, RAD_ERR_NOMEM, "out of memory for %u previews", count);
    *p = (rad_progress){.shots = shots, .unshot = unshot, .converged = converged,
                        .rows_recomputed = recomputed, .rows_dropped = dropped,
                        .preview_seconds = preview_seconds, .preview_count = count,
                        .previews = p->previews};
    for (uint32_t i = 0; i < count; i++)
        if (!get_u32(c, &p->previews[i].shots) || !get_u32(c, &p->previews[i].rows) ||
            !get_f64(c, &p->previews[i].seconds) ||
            !get_f64(c, &p->previews[i].unshot))
            return TRUNC("preview %u: truncated", i);
    return sol_check_progress(s, r->name, "section PROGRESS", RAD_ERR_CORRUPT, r->err);
}

typedef int (*parse_fn)(reader *, rad_solution *);
static const parse_fn sec_parse[SEC_COUNT] = {parse_info,      parse_scene,  parse_mesh,
                                              parse_matrix,    parse_patchdata, parse_lights,
                                              parse_elements,  parse_element_lights,
                                              parse_cameras, parse_surface, parse_clusters,
                                              parse_progress};

static int known_section(const uint8_t tag[4])
{
    for (int i = 0; i < SEC_COUNT; i++)
        if (memcmp(tag, sol_sec_tag[i], 4) == 0)
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
    uint32_t version = (uint32_t)sol_load_le64(d + 8) & 0xffffffffu;
    uint32_t reserved = (uint32_t)(sol_load_le64(d + 8) >> 32);
    uint64_t payload = sol_load_le64(d + 16), sum = sol_load_le64(d + 24);
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
        if (!sol_crc64_of(d + SOL_HEADER_BYTES, (size_t)payload, &got))
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
    int required = sol_version_sections[version];

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
                          offset, k >= 0 ? sol_sec_name[k] : "(unknown)", (unsigned long long)len,
                          all.left);
            goto fail;
        }
        if (k >= required) {
            rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s in a version %u file",
                          name, offset, sol_sec_name[k], version);
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
                          name, offset, sol_sec_name[k]);
            goto fail;
        }
        if (k != next) {
            if (k < next)
                rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s appears twice", name,
                              offset, sol_sec_name[k]);
            else
                rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s missing before %s",
                              name, offset, sol_sec_name[next], sol_sec_name[k]);
            goto fail;
        }
        r->section = sol_sec_name[k];
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
        rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: section %s missing", name, sol_sec_name[next]);
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
