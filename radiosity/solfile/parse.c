/* parse.c - the sections of a solution file (docs/solution-format.md),
 * each from a bounds-checked cursor over its body into a rad_solution: what
 * every format version shares (read.c walks the file and calls these).
 *
 * Invariant: whatever bytes a parser is given, it either fails with a
 * message naming the file, the section and the element, or leaves what it
 * built satisfying solution.h: the scene is rebuilt through scene.c's
 * checked builders, the mesh passes rad_mesh_check, F's rows pass
 * rad_matrix_add_records (or rad_matrix_check), and ρ ∈ [0,1), E >= 0,
 * B >= 0 are finite.  Every count is compared with the bytes left before
 * anything is allocated.
 */
#include "solfile_internal.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ cursor */

int sol_get_bytes(sol_cursor *c, void *out, size_t n)
{
    if (n > c->left)
        return 0;
    if (n)
        memcpy(out, c->p, n);
    c->p += n;
    c->left -= n;
    return 1;
}

int sol_get_u8(sol_cursor *c, uint8_t *v) { return sol_get_bytes(c, v, 1); }

int sol_get_u32(sol_cursor *c, uint32_t *v)
{
    if (c->left < 4)
        return 0;
    *v = (uint32_t)c->p[0] | (uint32_t)c->p[1] << 8 | (uint32_t)c->p[2] << 16 |
         (uint32_t)c->p[3] << 24;
    c->p += 4;
    c->left -= 4;
    return 1;
}

int sol_get_u64(sol_cursor *c, uint64_t *v)
{
    if (c->left < 8)
        return 0;
    *v = sol_load_le64(c->p);
    c->p += 8;
    c->left -= 8;
    return 1;
}

int sol_get_f64(sol_cursor *c, double *v)
{
    uint64_t bits;
    if (!sol_get_u64(c, &bits))
        return 0;
    memcpy(v, &bits, sizeof *v);
    return 1;
}

int sol_get_f32(sol_cursor *c, float *v)
{
    uint32_t bits;
    if (!sol_get_u32(c, &bits))
        return 0;
    memcpy(v, &bits, sizeof *v);
    return 1;
}

int sol_get_vec3(sol_cursor *c, rad_vec3 *v)
{
    return sol_get_f64(c, &v->x) && sol_get_f64(c, &v->y) && sol_get_f64(c, &v->z);
}

/* LEB128 of a u32: at most 5 bytes, no bits above 32, no padding bytes
 * (one value, one encoding).  0 when truncated or malformed. */
int sol_get_varint(sol_cursor *c, uint32_t *v)
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

/* "NAME: section SECTION: WHAT" */
int sol_rfail(sol_reader *r, int code, const char *fmt, ...)
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
static int get_str(sol_reader *r, const char *what, uint32_t i)
{
    uint32_t n;
    if (!sol_get_u32(&r->c, &n))
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s %u: truncated", what, i);
    if (n > SOL_MAX_STRING)
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s %u: string length %u exceeds %u", what, i, n,
                     SOL_MAX_STRING);
    if (!sol_get_bytes(&r->c, r->str, n))
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s %u: truncated", what, i);
    if (memchr(r->str, '\0', n))
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s %u: name contains a NUL byte", what, i);
    r->str[n] = '\0';
    return RAD_OK;
}

/* count elements of at least `min_bytes` each must fit in what is left. */
static int check_count(sol_reader *r, uint64_t count, uint64_t min_bytes, const char *what)
{
    if (count > r->c.left / min_bytes)
        return sol_rfail(r, RAD_ERR_CORRUPT, "%llu %s cannot fit in the %zu bytes left",
                     (unsigned long long)count, what, r->c.left);
    return RAD_OK;
}

#define TRUNC(...) sol_rfail(r, RAD_ERR_CORRUPT, __VA_ARGS__)

int sol_announced(const sol_reader *r, int k)
{
    return r->version >= SOL_VERSION_SHEETS && k >= SEC_LIGHTS && k <= SEC_LAST_ANNOUNCED &&
           ((r->announced >> (k - SEC_LIGHTS)) & 1u);
}

/* Is the elements' completion left to CLUSTERS (announced: it follows)? */
static int deferred(const sol_reader *r) { return sol_announced(r, SEC_CLUSTERS); }

static int parse_info(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    uint32_t stages;
    if (!sol_get_f64(c, &s->patch_size) || !sol_get_u32(c, &s->resolution))
        return TRUNC("truncated");
    int rc = get_str(r, "solver", 0);
    if (rc)
        return rc;
    if (strlen(r->str) > SOL_SOLVER_MAX)
        return TRUNC("solver name '%.40s' is longer than %zu bytes", r->str, SOL_SOLVER_MAX);
    memcpy(s->solver, r->str, strlen(r->str) + 1);
    if (!sol_get_f64(c, &s->tolerance) || !sol_get_u32(c, &s->iterations) || !sol_get_f64(c, &s->residual) ||
        !sol_get_u64(c, &s->rows_computed) || !sol_get_u32(c, &stages))
        return TRUNC("truncated");
    if (stages > SOL_MAX_STAGES)
        return TRUNC("%u stages (at most %u)", stages, SOL_MAX_STAGES);
    for (uint32_t i = 0; i < stages; i++) {
        double sec;
        uint8_t reused;
        if (!sol_get_f64(c, &sec) || !sol_get_u8(c, &reused))
            return TRUNC("stage %u: truncated", i);
        if (i < RAD_STAGE_COUNT) {
            s->stages[i].seconds = sec;
            s->stages[i].reused = reused;
        } else if (sol_bad_nonneg(sec) || reused > 1) {
            return TRUNC("stage %u: bad values", i);
        }
    }
    if (r->version >= SOL_VERSION_SHEETS) {
        if (!sol_get_u8(c, &r->announced))
            return TRUNC("truncated");
        if (r->announced >> SOL_ANNOUNCED_BITS)
            return TRUNC("announced sections 0x%x: only bits 0-%d exist", r->announced,
                         SOL_ANNOUNCED_BITS - 1);
    }
    return sol_check_info(s, r->name, "section INFO", RAD_ERR_CORRUPT, r->err);
}

/* scene.c reports failures as "SOURCE: WHERE: WHAT" with SOURCE = the
 * solution file's name while reading (see parse_scene); a bad value in a
 * checksummed file means corruption, whatever kind of rule it broke. */
static int scene_rc(sol_reader *r, int rc)
{
    if (rc != RAD_ERR_NOMEM)
        rc = RAD_ERR_CORRUPT;
    if (r->err)
        r->err->code = rc;
    return rc;
}

/* Band count and names; creates the scene, built under the solution file's
 * name so that scene.c's messages name the file being read (parse_scene
 * puts the stored source back at the end). */
static int parse_bands(sol_reader *r, rad_solution *s)
{
    uint32_t nb;
    if (!sol_get_u32(&r->c, &nb))
        return TRUNC("truncated");
    if (nb < 1 || nb > RAD_MAX_BANDS)
        return TRUNC("%u bands (1..%d allowed)", nb, RAD_MAX_BANDS);
    rad_scene *sc = s->scene = rad_scene_create(nb, r->name);
    if (!sc)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory");
    s->band_count = nb;
    for (uint32_t b = 0; b < nb; b++) {
        uint8_t has;
        int rc;
        if (!sol_get_u8(&r->c, &has))
            return TRUNC("band %u: truncated", b);
        if (has > 1)
            return TRUNC("band %u: name flag %u is not 0 or 1", b, has);
        if (has && (rc = get_str(r, "band", b)))
            return rc;
        if (has && !(sc->band_names[b] = strdup(r->str)))
            return sol_rfail(r, RAD_ERR_NOMEM, "out of memory");
    }
    return RAD_OK;
}

/* A count of things of at least min_bytes each: read and bounded. */
static int get_count(sol_reader *r, uint32_t *count, uint64_t min_bytes, const char *one,
                     const char *many)
{
    if (!sol_get_u32(&r->c, count))
        return TRUNC("%s count: truncated", one);
    return check_count(r, *count, min_bytes, many);
}

/* scene.c names the element itself ("material 'red': ..."). */
#define SCENE_WHERE "section SCENE"

static int parse_materials(sol_reader *r, rad_scene *sc)
{
    uint32_t nb = sc->band_count, count = 0;
    int rc = get_count(r, &count, MIN_STRING + 24ull * nb, "material", "materials");
    for (uint32_t i = 0; i < count && !rc; i++) {
        double rho[RAD_MAX_BANDS], e[RAD_MAX_BANDS], t[RAD_MAX_BANDS];
        if ((rc = get_str(r, "material", i)))
            break;
        int ok = 1;
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && sol_get_f64(&r->c, &rho[b]);
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && sol_get_f64(&r->c, &e[b]);
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && sol_get_f64(&r->c, &t[b]);
        if (!ok)
            rc = TRUNC("material %u: truncated", i);
        else if ((rc = rad_scene_add_material(sc, r->str, rho, e, t, SCENE_WHERE, NULL, r->err)))
            rc = scene_rc(r, rc);
    }
    return rc;
}

static int parse_objects(sol_reader *r, rad_scene *sc)
{
    uint32_t count;
    int rc = get_count(r, &count, MIN_STRING, "object", "objects");
    for (uint32_t i = 0; i < count && !rc; i++)
        if (!(rc = get_str(r, "object", i)) &&
            (rc = rad_scene_add_object(sc, r->str, SCENE_WHERE, NULL, r->err)))
            rc = scene_rc(r, rc);
    return rc;
}

/* One polygon: indices checked, points into *pts (grown as needed). */
static int parse_polygon(sol_reader *r, rad_scene *sc, uint32_t i, rad_vec3 **pts,
                         uint32_t *pts_cap)
{
    sol_cursor *c = &r->c;
    uint32_t mat, obj, su, sv, np;
    int rc = get_str(r, "polygon", i);
    if (rc)
        return rc;
    if (!sol_get_u32(c, &mat) || !sol_get_u32(c, &obj) || !sol_get_u32(c, &su) ||
        !sol_get_u32(c, &sv) || !sol_get_u32(c, &np))
        return TRUNC("polygon %u: truncated", i);
    if (mat >= sc->material_count || obj >= sc->object_count)
        return TRUNC("polygon %u: material %u or object %u out of range "
                     "(%u materials, %u objects)",
                     i, mat, obj, sc->material_count, sc->object_count);
    if (np < 3)
        return TRUNC("polygon %u: %u points (at least 3)", i, np);
    if ((rc = check_count(r, np, 24, "points")))
        return rc;
    if (np > *pts_cap) {
        rad_vec3 *grown = realloc(*pts, (size_t)np * sizeof *grown);
        if (!grown)
            return sol_rfail(r, RAD_ERR_NOMEM, "polygon %u: out of memory for %u points", i, np);
        *pts = grown;
        *pts_cap = np;
    }
    for (uint32_t j = 0; j < np; j++)
        sol_get_vec3(c, &(*pts)[j]); /* cannot fail: check_count above */
    if ((rc = rad_scene_add_polygon(sc, r->str, obj, mat, *pts, np, su, sv, SCENE_WHERE, NULL,
                                    r->err)))
        rc = scene_rc(r, rc);
    return rc;
}

static int parse_polygons(sol_reader *r, rad_scene *sc)
{
    rad_vec3 *pts = NULL;
    uint32_t pts_cap = 0, count;
    int rc = get_count(r, &count, MIN_POLYGON, "polygon", "polygons");
    for (uint32_t i = 0; i < count && !rc; i++)
        rc = parse_polygon(r, sc, i, &pts, &pts_cap);
    free(pts);
    return rc;
}

static int parse_scene_cameras(sol_reader *r, rad_scene *sc)
{
    sol_cursor *c = &r->c;
    uint32_t count = 0;
    int rc = get_count(r, &count, MIN_CAMERA, "camera", "cameras");
    for (uint32_t i = 0; i < count && !rc; i++) {
        rad_vec3 eye, target, up;
        double fov, aspect;
        if ((rc = get_str(r, "camera", i)))
            break;
        if (!sol_get_vec3(c, &eye) || !sol_get_vec3(c, &target) || !sol_get_vec3(c, &up) ||
            !sol_get_f64(c, &fov) || !sol_get_f64(c, &aspect))
            rc = TRUNC("camera %u: truncated", i);
        else if ((rc = rad_scene_add_camera(sc, r->str, eye, target, up, fov, aspect, SCENE_WHERE,
                                            NULL, r->err)))
            rc = scene_rc(r, rc);
    }
    return rc;
}

/* SCENE: source, bands, then materials, objects, polygons and cameras, each
 * rebuilt through scene.c's checked builders. */
static int parse_scene(sol_reader *r, rad_solution *s)
{
    int rc = get_str(r, "source", 0);
    if (rc)
        return rc;
    char *source = strdup(r->str);
    if (!source)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory");
    if (!(rc = parse_bands(r, s)) && !(rc = parse_materials(r, s->scene)) &&
        !(rc = parse_objects(r, s->scene)) && !(rc = parse_polygons(r, s->scene)) &&
        !(rc = parse_scene_cameras(r, s->scene))) {
        free(s->scene->source);
        s->scene->source = source;
        source = NULL;
    }
    free(source);
    return rc;
}

static int parse_mesh(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    const rad_scene *sc = s->scene;
    uint32_t nv, np;
    if (!sol_get_u32(c, &nv) || !sol_get_u32(c, &np))
        return TRUNC("truncated");
    if ((uint64_t)nv * VERTEX_BYTES + (uint64_t)np * PATCH_BYTES > r->c.left)
        return TRUNC("%u vertices and %u patches cannot fit in the %zu bytes left", nv, np,
                     r->c.left);
    rad_mesh *m = s->mesh = rad_mesh_alloc(nv, np);
    if (!m)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u vertices and %u patches", nv, np);
    /* The sizes were checked above, so the reads below cannot run short. */
    for (uint32_t i = 0; i < nv; i++)
        sol_get_vec3(c, &m->vertices[i]);
    for (uint32_t i = 0; i < nv; i++) {
        sol_get_u8(c, &m->vertex_boundary[i]);
        if (m->vertex_boundary[i] > 1)
            return TRUNC("vertex %u: boundary flag %u is not 0 or 1", i, m->vertex_boundary[i]);
    }
    for (uint32_t i = 0; i < np; i++) {
        rad_patch *p = &m->patches[i];
        for (int k = 0; k < 4; k++)
            sol_get_u32(c, &p->v[k]);
        sol_get_u32(c, &p->polygon);
        sol_get_u32(c, &p->object);
        sol_get_u32(c, &p->material);
        sol_get_vec3(c, &p->center);
        sol_get_vec3(c, &p->normal);
        sol_get_f64(c, &p->area);
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
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s",
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
        return sol_rfail(r, rc, "%s", msg ? msg + 6 : sub.message);
    }
    return RAD_OK;
}

/* Sizes F's pool to the exact total before the rows are stored: the pool
 * would otherwise grow by 1.5× steps and end up to half again larger than
 * needed, which for a matrix of gigabytes matters.  A version 1-5 row is
 * the same bytes as a record in another order (varints before values), so
 * the total is the rows' bytes plus a record head each.  A quick scan over
 * a copy of the cursor; on anything odd it does nothing and parse_matrix's
 * checked pass reports the fault. */
static void presize_matrix(rad_matrix *F, sol_cursor c, uint32_t rows)
{
    size_t start = c.left;
    for (uint32_t k = 0; k < rows; k++) {
        uint32_t i, cnt;
        if (!sol_get_u32(&c, &i) || !sol_get_u32(&c, &cnt))
            return;
        for (uint32_t e = 0; e < cnt; e++) {
            uint32_t d;
            if (!sol_get_varint(&c, &d))
                return;
        }
        if ((uint64_t)cnt * 4 > c.left)
            return;
        c.p += (size_t)cnt * 4;
        c.left -= (size_t)cnt * 4;
    }
    rad_matrix_reserve(F, start - c.left, NULL); /* NULL: set_row reports a shortage */
}

/* A row's cnt entries (see put_row) into col/val, checked: columns
 * strictly increasing below n and never `self`, values positive and
 * finite, sum <= 1 + 1e-3.  `what` and `i` name the row in messages. */
static int get_row(sol_reader *r, const char *what, uint32_t i, uint32_t cnt, uint32_t n, uint32_t self,
                   uint32_t *col, float *val)
{
    sol_cursor *c = &r->c;
    uint64_t j = 0;
    for (uint32_t e = 0; e < cnt; e++) {
        uint32_t d;
        if (!sol_get_varint(c, &d))
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
        if (!sol_get_f32(c, &val[e]))
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

/* MATRIX of versions 1-5: rows in increasing order, each u32 i, u32 c,
 * the varint columns, then the values; stored through rad_matrix_set_row. */
static int parse_matrix(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    uint32_t n, rows;
    if (!sol_get_u32(c, &n) || !sol_get_u32(c, &rows))
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
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for n = %u", n);
    presize_matrix(F, r->c, rows);
    uint32_t *col = NULL;
    float *val = NULL;
    uint32_t cap = 0;
    int64_t prev = -1;
    for (uint32_t k = 0; k < rows; k++) {
        uint32_t i, cnt;
        if (!sol_get_u32(c, &i) || !sol_get_u32(c, &cnt)) {
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
                rc = sol_rfail(r, RAD_ERR_NOMEM, "row %u: out of memory for %u entries", i, cnt);
                goto done;
            }
            cap = cnt;
        }
        if ((rc = get_row(r, "row", i, cnt, n, i, col, val)))
            goto done;
        rad_error sub;
        if ((rc = rad_matrix_set_row(F, i, cnt, col, val, &sub))) {
            rc = sol_rfail(r, rc, "row %u: %s", i, sub.message);
            goto done;
        }
    }
    /* A second opinion on the rows just checked one by one. */
    rad_error sub;
    if (rad_matrix_check(F, &sub))
        rc = sol_rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
done:
    free(col);
    free(val);
    return rc;
}

static int parse_patchdata(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    uint32_t n, nb;
    if (!sol_get_u32(c, &n) || !sol_get_u32(c, &nb))
        return TRUNC("truncated");
    if (n != s->mesh->patch_count || nb != s->band_count)
        return TRUNC("%u patches × %u bands but the mesh has %u patches and the scene %u bands", n,
                     nb, s->mesh->patch_count, s->band_count);
    uint64_t count = (uint64_t)n * nb;
    if (count * 3 * 8 > r->c.left)
        return TRUNC("%u patches × %u bands cannot fit in the %zu bytes left", n, nb, r->c.left);
    s->rho = rad_solution_band_array(n, nb);
    s->emission = rad_solution_band_array(n, nb);
    s->B = rad_solution_band_array(n, nb);
    if (!s->rho || !s->emission || !s->B)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u patches × %u bands", n, nb);
    for (uint64_t i = 0; i < count; i++)
        sol_get_f64(c, &s->rho[i]);
    for (uint64_t i = 0; i < count; i++)
        sol_get_f64(c, &s->emission[i]);
    for (uint64_t i = 0; i < count; i++)
        sol_get_f64(c, &s->B[i]);
    return sol_check_patch_values(s, r->name, "section PATCHDATA", RAD_ERR_CORRUPT, r->err);
}

static int parse_lights(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    rad_scene *sc = s->scene;
    uint32_t nl, nb, n = s->mesh->patch_count;
    if (!sol_get_u32(c, &nl) || !sol_get_u32(c, &nb) || !sol_get_u64(c, &s->lights_computed))
        return TRUNC("truncated");
    if (nb != s->band_count)
        return TRUNC("%u bands but the scene has %u", nb, s->band_count);
    if (nl == 0)
        return TRUNC("no lights (the section is written only when there are some)");
    int rc = check_count(r, nl, MIN_LIGHT + 16ull * nb, "lights");
    if (rc)
        return rc;
    if (rad_solution_alloc_lights(s, nl) != 0)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u lights", nl);
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
        int ok = sol_get_u8(c, &kind) && sol_get_vec3(c, &pos) && sol_get_vec3(c, &dir) &&
                 sol_get_f64(c, &inner) && sol_get_f64(c, &outer);
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && sol_get_f64(c, &I[b]);
        for (uint32_t b = 0; b < nb; b++)
            ok = ok && sol_get_f64(c, &s->light_intensity[(size_t)l * nb + b]);
        ok = ok && sol_get_u8(c, &present) && sol_get_u32(c, &cnt);
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
            rc = sol_rfail(r, RAD_ERR_NOMEM, "light '%s': out of memory", r->str);
            break;
        }
        uint64_t j = 0;
        for (uint32_t e = 0; e < cnt && !rc; e++) {
            uint32_t d;
            if (!sol_get_varint(c, &d))
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
            if (!sol_get_f32(c, &lp->power[e]))
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
 * rad_element_store_complete then derives each cell from its patch and checks
 * the whole (solution.h).  Up to version 6 each element's row entries
 * follow its count; from version 7 on they are ELEMENTROWS', and the
 * elements stay without them (rows_loaded 0) until that is read. */
static int parse_elements(sol_reader *r, rad_solution *s)
{
    const int inline_rows = r->version < SOL_VERSION_ELEMENT_ROWS;
    sol_cursor *c = &r->c;
    double threshold, min_size;
    uint64_t computed;
    uint32_t nv, ne, nb;
    if (!sol_get_f64(c, &threshold) || !sol_get_f64(c, &min_size) || !sol_get_u64(c, &computed) ||
        !sol_get_u32(c, &nv) || !sol_get_u32(c, &ne) || !sol_get_u32(c, &nb))
        return TRUNC("truncated");
    if (nb != s->band_count)
        return TRUNC("%u bands but the solution has %u", nb, s->band_count);
    int rc;
    /* The vertices and the elements' fixed parts must fit what is left;
     * the row entries (up to version 6) get the rest, at MIN_ENTRY each. */
    uint64_t fixed = (uint64_t)nv * ELEMENT_VERTEX_BYTES + (uint64_t)ne * (MIN_ELEMENT + 8u * nb);
    if (fixed > c->left)
        return TRUNC("%u vertices and %u elements need %llu bytes, %zu left", nv, ne,
                     (unsigned long long)fixed, c->left);
    uint64_t max_entries = c->left > fixed && inline_rows ? (c->left - fixed) / MIN_ENTRY : 0;
    rad_elements *el = s->elements = rad_element_store_alloc(nv, ne, nb, max_entries);
    if (!el)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u elements", ne);
    el->threshold = threshold;
    el->min_size = min_size;
    el->rows_computed = computed;
    rad_mesh *m = el->mesh;
    for (uint32_t v = 0; v < nv; v++)
        if (!sol_get_vec3(c, &m->vertices[v]) || !sol_get_u8(c, &m->vertex_boundary[v]))
            return TRUNC("vertex %u: truncated", v);
    for (uint32_t e = 0; e < ne; e++) {
        uint32_t cnt;
        if (!sol_get_u32(c, &el->patch[e]) || !sol_get_u8(c, &el->level[e]))
            return TRUNC("element %u: truncated", e);
        for (int k = 0; k < 4; k++)
            if (!sol_get_u32(c, &m->patches[e].v[k]))
                return TRUNC("element %u: truncated", e);
        for (uint32_t b = 0; b < nb; b++)
            if (!sol_get_f64(c, &el->B[(size_t)e * nb + b]))
                return TRUNC("element %u: truncated", e);
        if (!sol_get_u32(c, &cnt))
            return TRUNC("element %u: truncated", e);
        if (el->patch[e] >= s->mesh->patch_count)
            return TRUNC("element %u: patch %u out of range (%u patches)", e, el->patch[e],
                          s->mesh->patch_count);
        if (inline_rows ? cnt > max_entries - el->nnz : cnt >= s->mesh->patch_count)
            return TRUNC("element %u: %u entries: more than the %s", e, cnt,
                         inline_rows ? "section holds" : "patches but itself");
        el->row_start[e] = el->nnz;
        el->row_count[e] = cnt;
        if (inline_rows && (rc = get_row(r, "element", e, cnt, s->mesh->patch_count,
                                         el->patch[e], el->col + el->nnz, el->val + el->nnz)))
            return rc;
        el->nnz += cnt;
    }
    if (!inline_rows && el->nnz) { /* ELEMENTROWS holds them */
        free(el->col);
        free(el->val);
        el->col = NULL;
        el->val = NULL;
        el->rows_loaded = 0;
    }
    /* Elements in clusters take their polygon and normal from the cell
     * they lie in: with CLUSTERS to come, they are completed there. */
    rad_error sub;
    if (!deferred(r) && rad_element_store_complete(el, s, "elements", &sub))
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

/* ELEMENTLIGHTS: the counts must be the elements' and the lights', and the
 * values exactly fill the body, before anything is allocated; then
 * rad_element_store_check applies the rules (finite, >= 0, 0 at level 0). */
static int parse_element_lights(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    rad_elements *el = s->elements;
    uint32_t ne, nl;
    if (!sol_get_u32(c, &ne) || !sol_get_u32(c, &nl))
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
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u elements × %u lights", ne, nl);
    el->light_count = nl;
    for (uint64_t q = 0; q < count; q++)
        if (!sol_get_f32(c, &el->light_h[q]))
            return TRUNC("truncated");
    rad_error sub;
    if (!deferred(r) && rad_element_store_check(el, s, "elements", &sub))
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

/* ROWS (version 6): the rows F holds and their entry counts, one varint
 * each, 0 for a missing row and c + 1 for a row of c entries.  Gives F its
 * row counts without entries; MATRIX, when read, must agree. */
static int parse_rows(sol_reader *r, rad_solution *s)
{
    uint32_t n, v;
    if (!sol_get_u32(&r->c, &n))
        return TRUNC("truncated");
    if (n != s->mesh->patch_count)
        return TRUNC("n = %u but the mesh has %u patches", n, s->mesh->patch_count);
    int rc = check_count(r, n, 1, "rows");
    if (rc)
        return rc;
    rad_matrix *F = s->F = rad_matrix_create(n);
    if (!F)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for n = %u", n);
    F->entries_loaded = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (!sol_get_varint(&r->c, &v))
            return TRUNC("row %u: truncated or malformed count", i);
        if (v > n) /* c <= n - 1 */
            return TRUNC("row %u: %u entries but n = %u", i, v - 1, n);
        if (v) {
            F->row_done[i] = 1;
            F->row_count[i] = v - 1;
            F->rows_done++;
            F->nnz += v - 1;
        }
    }
    return RAD_OK;
}

/* IRRADIANCE (version 6): H per patch and band, finite and >= 0. */
static int parse_irradiance(sol_reader *r, rad_solution *s)
{
    uint32_t n, nb;
    if (!sol_get_u32(&r->c, &n) || !sol_get_u32(&r->c, &nb))
        return TRUNC("truncated");
    if (n != s->mesh->patch_count || nb != s->band_count)
        return TRUNC("%u patches × %u bands but the mesh has %u patches and the scene %u bands", n,
                     nb, s->mesh->patch_count, s->band_count);
    uint64_t count = (uint64_t)n * nb;
    if (count * 8 != r->c.left)
        return TRUNC("%llu values need %llu bytes, %zu left", (unsigned long long)count,
                     (unsigned long long)count * 8, r->c.left);
    if (!(s->irradiance = rad_solution_band_array(n, nb)))
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u patches × %u bands", n, nb);
    for (uint64_t q = 0; q < count; q++) {
        sol_get_f64(&r->c, &s->irradiance[q]);
        if (sol_bad_nonneg(s->irradiance[q]))
            return TRUNC("patch %llu band %llu: H = %g is not finite and >= 0",
                         (unsigned long long)(q / nb), (unsigned long long)(q % nb),
                         s->irradiance[q]);
    }
    return RAD_OK;
}

/* MATRIXREF (version 6): where another file holds this solution's MATRIX.
 * Only read here; read.c follows it. */
static int parse_matrixref(sol_reader *r, rad_solution *s)
{
    sol_matrixref *m = &r->ref;
    int rc = get_str(r, "file", 0);
    if (rc)
        return rc;
    if (!r->str[0])
        return TRUNC("no file named");
    memcpy(m->name, r->str, strlen(r->str) + 1);
    if ((rc = get_str(r, "absolute path", 0)))
        return rc;
    memcpy(m->abs, r->str, strlen(r->str) + 1);
    if (!sol_get_u64(&r->c, &m->offset) || !sol_get_u64(&r->c, &m->length) ||
        !sol_get_u64(&r->c, &m->crc) || !sol_get_u64(&r->c, &m->key) ||
        !sol_get_u32(&r->c, &m->n))
        return TRUNC("truncated");
    if (m->n != s->mesh->patch_count)
        return TRUNC("n = %u but the mesh has %u patches", m->n, s->mesh->patch_count);
    if (m->length < SOL_MATRIX_HEAD || m->offset < SOL_HEADER_BYTES)
        return TRUNC("section at byte %llu of %llu bytes cannot be a MATRIX",
                     (unsigned long long)m->offset, (unsigned long long)m->length);
    m->present = 1;
    return RAD_OK;
}

/* ------------------------------------------------------ version 6 MATRIX */

int sol_matrix_head(sol_reader *r, const uint8_t *h, uint32_t n, uint64_t *key)
{
    uint32_t got = (uint32_t)sol_load_le64(h), reserved = (uint32_t)(sol_load_le64(h) >> 32);
    if (got != n)
        return TRUNC("n = %u but the mesh has %u patches", got, n);
    if (reserved != 0)
        return TRUNC("reserved field is %u, not 0", reserved);
    *key = sol_load_le64(h + 8);
    return RAD_OK;
}

int sol_block_head(sol_reader *r, const uint8_t *h, uint64_t at, uint64_t left, uint32_t *rows,
                   uint64_t *len, uint64_t *crc)
{
    if (left < SOL_BLOCK_HEAD)
        return TRUNC("byte %llu: row block truncated", (unsigned long long)at);
    if (memcmp(h, SOL_BLOCK_TAG, 4) != 0)
        return TRUNC("byte %llu: not a row block", (unsigned long long)at);
    *rows = (uint32_t)(sol_load_le64(h) >> 32);
    *len = sol_load_le64(h + 8);
    *crc = sol_load_le64(h + 16);
    if (*rows == 0 || *len > left - SOL_BLOCK_HEAD || *len / (SOL_RECORD_HEAD) < *rows)
        return TRUNC("byte %llu: row block of %u rows in %llu bytes, %llu left",
                     (unsigned long long)at, *rows, (unsigned long long)*len,
                     (unsigned long long)(left - SOL_BLOCK_HEAD));
    return RAD_OK;
}

int sol_matrix_install(sol_reader *r, rad_solution *s, rad_matrix *G, uint64_t records,
                       uint64_t rows)
{
    rad_error sub;
    uint64_t at = 0;
    if (rad_matrix_add_records(G, records, rows, &at, &sub) != RAD_OK) {
        rad_matrix_destroy(G);
        return sol_rfail(r, sub.code, "%s", sub.message);
    }
    const rad_matrix *F = s->F; /* the counts ROWS gave */
    int rc = RAD_OK;
    for (uint32_t i = 0; i < G->n && !rc; i++)
        if (G->row_done[i] != F->row_done[i] || G->row_count[i] != F->row_count[i])
            rc = TRUNC("row %u: %s%u entries, but ROWS says %s%u", i,
                       G->row_done[i] ? "" : "absent, ", G->row_count[i],
                       F->row_done[i] ? "" : "absent, ", F->row_count[i]);
    if (rc) {
        rad_matrix_destroy(G);
        return rc;
    }
    rad_matrix_destroy(s->F);
    s->F = G;
    return RAD_OK;
}

/* MATRIX (version 6) from memory: n and the rows key, then row blocks,
 * each checked against its own CRC when checksums are on (the section's
 * CRC was checked by the caller). */
static int parse_matrix_blocks(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    uint64_t key = 0, body = c->left;
    if (c->left < SOL_MATRIX_HEAD)
        return TRUNC("truncated");
    int rc = sol_matrix_head(r, c->p, s->mesh->patch_count, &key);
    if (rc)
        return rc;
    c->p += SOL_MATRIX_HEAD;
    c->left -= SOL_MATRIX_HEAD;
    rad_matrix *G = rad_matrix_create(s->mesh->patch_count);
    uint8_t *pool = G ? rad_matrix_reserve(G, c->left, NULL) : NULL;
    if (!G || (!pool && c->left)) {
        rad_matrix_destroy(G);
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %zu bytes of rows", c->left);
    }
    G->key = key;
    uint64_t records = 0, rows = 0;
    while (c->left && !rc) {
        uint32_t nrows;
        uint64_t len, crc, got;
        rc = sol_block_head(r, c->p, body - c->left, c->left, &nrows, &len, &crc);
        if (!rc && r->check_sum && sol_crc64_of(c->p + SOL_BLOCK_HEAD, (size_t)len, &got) &&
            got != crc)
            rc = TRUNC("byte %llu: row block checksum mismatch: the file is corrupt",
                       (unsigned long long)(body - c->left));
        if (rc)
            break;
        memcpy(pool + records, c->p + SOL_BLOCK_HEAD, (size_t)len);
        records += len;
        rows += nrows;
        c->p += SOL_BLOCK_HEAD + len;
        c->left -= SOL_BLOCK_HEAD + (size_t)len;
    }
    if (rc) {
        rad_matrix_destroy(G);
        return rc;
    }
    return sol_matrix_install(r, s, G, records, rows);
}

/* CAMERAS: which of SCENE's cameras are orthographic, in increasing order. */
static int parse_ortho_cameras(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    rad_scene *sc = s->scene;
    uint32_t n;
    if (!sol_get_u32(c, &n))
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
        if (!sol_get_u32(c, &i) || !sol_get_u8(c, &projection) || !sol_get_f64(c, &xmag) ||
            !sol_get_f64(c, &ymag)) /* cannot fail after check_count, said for the compiler */
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

/* CLUSTERS: each patch's cell count, then the corners and polygon of the
 * cells of every patch that has several; the rest of a cell (object and
 * material its patch's, normal its polygon's, centre and area from its
 * corners) is derived, a patch of one cell is that cell, and the whole
 * layer must pass rad_mesh_check.  Elements read before are completed here
 * (they need the cells). */
static int parse_clusters(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    rad_mesh *m = s->mesh;
    const rad_scene *sc = s->scene;
    uint32_t n, nc;
    if (!sol_get_u32(c, &n) || !sol_get_u32(c, &nc))
        return TRUNC("truncated");
    if (n != m->patch_count)
        return TRUNC("%u patches but the mesh has %u", n, m->patch_count);
    /* every patch has a cell and takes at least one byte to count */
    if (nc < n || n > c->left || (uint64_t)(nc - n) * CLUSTER_CELL_BYTES > c->left)
        return TRUNC("%u cells for %u patches cannot fit in the %zu bytes left", nc, n, c->left);
    if (rad_mesh_alloc_cells(m, nc) != 0)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u cells", nc);
    uint64_t total = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t k;
        if (!sol_get_varint(c, &k))
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
                ok = ok && sol_get_u32(c, &cell->v[k]);
            if (!ok || !sol_get_u32(c, &cell->polygon))
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
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s",
                     strncmp(sub.message, "mesh: ", 6) == 0 ? sub.message + 6 : sub.message);
    if (s->elements && rad_element_store_complete(s->elements, s, "elements", &sub))
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

/* SURFACE: one lobe per material of the scene, checked by
 * rad_scene_set_material_lobe (the rules a loader meets). */
static int parse_surface(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    rad_scene *sc = s->scene;
    uint32_t n;
    if (!sol_get_u32(c, &n))
        return TRUNC("truncated");
    if (n != sc->material_count)
        return TRUNC("%u materials, but the scene has %u", n, sc->material_count);
    for (uint32_t i = 0; i < n; i++) {
        double rough, spec[RAD_MAX_BANDS];
        if (!sol_get_f64(c, &rough))
            return TRUNC("material %u: truncated", i);
        for (uint32_t b = 0; b < sc->band_count; b++)
            if (!sol_get_f64(c, &spec[b]))
                return TRUNC("material %u: truncated", i);
        rad_error sub;
        if (rad_scene_set_material_lobe(sc, i, spec, rough, "section SURFACE", &sub))
            return sol_rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    }
    return RAD_OK;
}

/* ELEMENTINDIRECT: the counts must be the elements' and the patches', and
 * the flags exactly fill the body; rad_element_store_check applies the rules.
 * It follows ELEMENTS and CLUSTERS, so the elements are complete. */
static int parse_element_indirect(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    rad_elements *el = s->elements;
    uint32_t ne, np;
    if (!el)
        return TRUNC("no elements");
    if (!sol_get_u32(c, &ne) || !sol_get_u32(c, &np))
        return TRUNC("truncated");
    if (ne != el->mesh->patch_count || np != s->mesh->patch_count)
        return TRUNC("%u elements and %u patches, but the solution has %u and %u", ne, np,
                     el->mesh->patch_count, s->mesh->patch_count);
    if ((uint64_t)ne + np != c->left)
        return TRUNC("%u flags need as many bytes, %zu left", ne + np, c->left);
    el->interp = malloc(ne ? ne : 1);
    el->direct = malloc(np ? np : 1);
    if (!el->interp || !el->direct)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u elements' flags", ne);
    if (!sol_get_bytes(c, el->interp, ne) || !sol_get_bytes(c, el->direct, np))
        return TRUNC("truncated");
    rad_error sub;
    if (rad_element_store_check(el, s, "elements", &sub))
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

/* ELEMENTROWS (version 7): the row entries of the elements ELEMENTS
 * counted, element by element, encoded as version 6 had them inside
 * ELEMENTS.  The counts must be ELEMENTS' and the entries must fit what is
 * left before anything is allocated; each row is checked as it is read
 * (get_row), then the whole against the complete elements
 * (rad_element_store_check: interpolated rows hold direct sources only). */
static int parse_element_rows(sol_reader *r, rad_solution *s)
{
    rad_elements *el = s->elements;
    uint32_t ne;
    uint64_t nnz;
    if (!el || el->rows_loaded)
        return TRUNC("no elements whose rows it would hold");
    if (!sol_get_u32(&r->c, &ne) || !sol_get_u64(&r->c, &nnz))
        return TRUNC("truncated");
    if (ne != el->mesh->patch_count || nnz != el->nnz)
        return TRUNC("%u elements and %llu entries, but ELEMENTS has %u and %llu", ne,
                     (unsigned long long)nnz, el->mesh->patch_count,
                     (unsigned long long)el->nnz);
    int rc = check_count(r, nnz, MIN_ENTRY, "entries");
    if (rc)
        return rc;
    el->col = malloc((size_t)(nnz ? nnz : 1) * sizeof *el->col);
    el->val = malloc((size_t)(nnz ? nnz : 1) * sizeof *el->val);
    if (!el->col || !el->val)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %llu entries",
                         (unsigned long long)nnz);
    el->capacity = nnz;
    el->rows_loaded = 1;
    for (uint32_t e = 0; e < ne; e++)
        if ((rc = get_row(r, "element", e, el->row_count[e], s->mesh->patch_count, el->patch[e],
                          el->col + el->row_start[e], el->val + el->row_start[e])))
            return rc;
    rad_error sub;
    if (rad_element_store_check(el, s, "elements", &sub))
        return sol_rfail(r, RAD_ERR_CORRUPT, "%s", sub.message);
    return RAD_OK;
}

/* ---------------------------------------------------------------- dispatch */

/* PROGRESS (write.c's emit_progress). */
static int parse_progress(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    uint32_t shots, count;
    double unshot, preview_seconds;
    uint8_t converged;
    uint64_t recomputed, dropped;
    if (!sol_get_u32(c, &shots) || !sol_get_f64(c, &unshot) || !sol_get_u8(c, &converged) ||
        !sol_get_u64(c, &recomputed) || !sol_get_u64(c, &dropped) ||
        !sol_get_f64(c, &preview_seconds) || !sol_get_u32(c, &count))
        return TRUNC("truncated");
    int rc = check_count(r, count, PREVIEW_BYTES, "previews");
    if (rc)
        return rc;
    rad_progress *p = s->progress = rad_progress_create(count);
    if (!p)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u previews", count);
    *p = (rad_progress){.shots = shots, .unshot = unshot, .converged = converged,
                        .rows_recomputed = recomputed, .rows_dropped = dropped,
                        .preview_seconds = preview_seconds, .preview_count = count,
                        .previews = p->previews};
    for (uint32_t i = 0; i < count; i++)
        if (!sol_get_u32(c, &p->previews[i].shots) || !sol_get_u32(c, &p->previews[i].rows) ||
            !sol_get_f64(c, &p->previews[i].seconds) || !sol_get_f64(c, &p->previews[i].unshot))
            return TRUNC("preview %u: truncated", i);
    return sol_check_progress(s, r->name, "section PROGRESS", RAD_ERR_CORRUPT, r->err);
}

/* BASIS (version 6): the stored light responses.  The sizes must be the
 * solution's and fill the body exactly before anything is allocated. */
static int parse_basis(sol_reader *r, rad_solution *s)
{
    sol_cursor *c = &r->c;
    uint32_t K, n, nb, nl, ne;
    if (!sol_get_u32(c, &K) || !sol_get_u32(c, &n) || !sol_get_u32(c, &nb) ||
        !sol_get_u32(c, &nl) || !sol_get_u32(c, &ne))
        return TRUNC("truncated");
    const uint32_t lights = s->light_intensity ? s->scene->light_count : 0;
    const uint32_t elements = s->elements ? s->elements->mesh->patch_count : 0;
    if (n != s->mesh->patch_count || nb != s->band_count || nl != lights || ne != elements)
        return TRUNC("%u patches, %u bands, %u lights, %u elements, but the solution has %u, %u, "
                     "%u, %u", n, nb, nl, ne, s->mesh->patch_count, s->band_count, lights,
                     elements);
    if (K < 1 || K > RAD_BASIS_MAX_GROUPS)
        return TRUNC("%u light groups (1..%u)", K, RAD_BASIS_MAX_GROUPS);
    const uint64_t per_group = 8 + 8ull * nb * (2ull * n + ne);
    const uint64_t need = 8ull * nb * ((uint64_t)n + nl) + 4ull * ((uint64_t)n + nl) +
                          K * per_group;
    if (need != c->left)
        return TRUNC("%u groups of %u patches, %u lights and %u elements need %llu bytes, %zu "
                     "left", K, n, nl, ne, (unsigned long long)need, c->left);
    rad_basis *b = s->basis = rad_basis_create(s, K);
    if (!b)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %u light groups", K);
    const uint64_t nv = (uint64_t)n * nb, nev = (uint64_t)ne * nb;
    for (uint64_t q = 0; q < nv; q++)
        sol_get_f64(c, &b->E_ref[q]);
    for (uint64_t q = 0; q < (uint64_t)nl * nb; q++)
        sol_get_f64(c, &b->I_ref[q]);
    for (uint32_t i = 0; i < n; i++)
        sol_get_u32(c, &b->patch_group[i]);
    for (uint32_t l = 0; l < nl; l++)
        sol_get_u32(c, &b->light_group[l]);
    for (uint32_t g = 0; g < K; g++) {
        sol_get_f64(c, &b->residual[g]);
        for (uint64_t q = 0; q < nv; q++)
            sol_get_f64(c, &b->B[g * nv + q]);
        for (uint64_t q = 0; q < nv; q++)
            sol_get_f64(c, &b->H[g * nv + q]);
        for (uint64_t q = 0; q < nev; q++)
            sol_get_f64(c, &b->Be[g * nev + q]);
    }
    return sol_check_basis(s, r->name, "section BASIS", RAD_ERR_CORRUPT, r->err);
}

/* A failure of scene.c's checks, sub, as this section's: scene.c named the
 * scene's source file, which is not the file being read. */
static int scene_fail(sol_reader *r, const rad_scene *sc, const rad_error *sub)
{
    const char *what = sub->message;
    size_t n = strlen(sc->source);
    if (!strncmp(what, sc->source, n) && !strncmp(what + n, ": ", 2))
        what += n + 2;
    if (!strncmp(what, "section TEXTURES: ", 18))
        what += 18;
    return sol_rfail(r, sub->code == RAD_ERR_NOMEM ? RAD_ERR_NOMEM : RAD_ERR_CORRUPT, "%s", what);
}

/* TEXTURES (version 8, write.c's emit_textures): every image, texture and
 * coordinate through scene.c's checks; the points must be the scene's. */
static int parse_images(sol_reader *r, rad_scene *sc)
{
    uint32_t n;
    int rc = get_count(r, &n, MIN_STRING + 8u, "image", "images");
    for (uint32_t i = 0; i < n && !rc; i++) {
        uint64_t size;
        if ((rc = get_str(r, "image", i)))
            break;
        if (!sol_get_u64(&r->c, &size) || size > r->c.left)
            return TRUNC("image %u: truncated", i);
        rad_error sub;
        if (rad_scene_add_image(sc, r->str, r->c.p, size, "section TEXTURES", NULL, &sub))
            return scene_fail(r, sc, &sub);
        r->c.p += size;
        r->c.left -= (size_t)size;
    }
    return rc;
}

/* The points' (u, v), polygon by polygon (the count checked by the caller). */
static int parse_point_uv(sol_reader *r, rad_scene *sc)
{
    uint32_t most = 0;
    for (uint32_t p = 0; p < sc->polygon_count; p++)
        most = sc->polygons[p].point_count > most ? sc->polygons[p].point_count : most;
    double *uv = malloc(2 * ((size_t)most + 1) * sizeof *uv);
    if (!uv)
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory");
    int rc = RAD_OK;
    for (uint32_t p = 0; p < sc->polygon_count && !rc; p++) {
        for (uint32_t k = 0; k < 2 * sc->polygons[p].point_count; k++)
            sol_get_f64(&r->c, &uv[k]); /* the length was checked */
        rad_error sub;
        if (rad_scene_set_polygon_uv(sc, p, uv, "section TEXTURES", &sub))
            rc = scene_fail(r, sc, &sub);
    }
    free(uv);
    return rc;
}

static int parse_textures(sol_reader *r, rad_solution *s)
{
    rad_scene *sc = s->scene;
    uint32_t n = 0, np = 0;
    int rc = parse_images(r, sc);
    if (!rc)
        rc = get_count(r, &n, 7u * 4u + 4u * 8u, "texture", "textures");
    for (uint32_t i = 0; i < n && !rc; i++) {
        uint32_t v[7];
        rad_texture t;
        int ok = 1;
        for (int k = 0; k < 7; k++)
            ok = ok && sol_get_u32(&r->c, &v[k]);
        for (int k = 0; k < 4; k++)
            ok = ok && sol_get_f64(&r->c, &t.factor[k]);
        if (!ok)
            return TRUNC("texture %u: truncated", i);
        t.material = v[0], t.image = v[1], t.texcoord = v[2];
        t.wrap_s = (int)(v[3] & 0xffff), t.wrap_t = (int)(v[4] & 0xffff);
        t.mag_filter = (int)(v[5] & 0xffff), t.min_filter = (int)(v[6] & 0xffff);
        rad_error sub;
        if (v[3] > 0xffff || v[4] > 0xffff || v[5] > 0xffff || v[6] > 0xffff)
            return TRUNC("texture %u: sampler values %u %u %u %u", i, v[3], v[4], v[5], v[6]);
        if (rad_scene_add_texture(sc, &t, "section TEXTURES", &sub))
            return scene_fail(r, sc, &sub);
    }
    if (!rc && !sol_get_u32(&r->c, &np))
        return TRUNC("point count: truncated");
    if (!rc && (np != sc->point_count || (uint64_t)np * 16u != r->c.left))
        return TRUNC("%u points in %zu bytes, but the scene has %u points", np, r->c.left,
                     sc->point_count);
    return rc ? rc : parse_point_uv(r, sc);
}

typedef int (*parse_fn)(sol_reader *, rad_solution *);
static const parse_fn sec_parse[SEC_COUNT] = {
    [SEC_INFO] = parse_info,
    [SEC_SCENE] = parse_scene,
    [SEC_MESH] = parse_mesh,
    [SEC_MATRIX] = parse_matrix,
    [SEC_PATCHDATA] = parse_patchdata,
    [SEC_LIGHTS] = parse_lights,
    [SEC_ELEMENTS] = parse_elements,
    [SEC_ELEMENT_LIGHTS] = parse_element_lights,
    [SEC_CAMERAS] = parse_ortho_cameras,
    [SEC_SURFACE] = parse_surface,
    [SEC_CLUSTERS] = parse_clusters,
    [SEC_ELEMENT_INDIRECT] = parse_element_indirect,
    [SEC_PROGRESS] = parse_progress,
    [SEC_ROWS] = parse_rows,
    [SEC_IRRADIANCE] = parse_irradiance,
    [SEC_MATRIXREF] = parse_matrixref,
    [SEC_BASIS] = parse_basis,
    [SEC_ELEMENT_ROWS] = parse_element_rows,
    [SEC_TEXTURES] = parse_textures,
};

int sol_parse_section(sol_reader *r, int sec, rad_solution *s)
{
    r->section = sol_sec_name[sec];
    int rc = (sec == SEC_MATRIX && r->version >= SOL_VERSION_INDEX)
                 ? parse_matrix_blocks(r, s)
                 : sec_parse[sec](r, s);
    if (!rc && r->c.left)
        rc = sol_rfail(r, RAD_ERR_CORRUPT, "%zu unexpected bytes at the end", r->c.left);
    return rc;
}
