/* polyfile.c - the plain-text polygon file (docs/polygon-file.md): the
 * hemi-cube paper's input, polygons with per-band reflectance ρ and emission
 * E and a subdivision parameter, plus named groups, cameras and punctual
 * lights (radiometric: W/sr or W/m², no photometric conversion).
 *
 * Invariant: the parser reads only text[0 .. size), never assumes a NUL, and
 * every failure is a rad_error "FILE: line N: WHAT" with all memory freed;
 * the scene it returns has passed the scene.c checks element by element
 * (rad_scene_load runs the whole-scene checks afterwards).
 */
#include "scene.h"
#include "scene_internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_TOKEN 4095          /* longer tokens are refused, not truncated */
#define MAX_POLY_POINTS 1000000 /* points per polygon */
#define MAX_SUBDIV 1000000      /* a subdivision parameter; the mesher's limit catches the product */

typedef struct lexer {
    rad_lines lines;             /* the text, line by line (comments cut off) */
    const char *p, *end;         /* the current line's content not yet read */
    unsigned long long line;     /* the current line */
    char tok[MAX_TOKEN + 1];     /* the current token, NUL-terminated */
    size_t len;
    unsigned long long tok_line; /* line the current token is on (at the end of the file:
                                    the last token's line, where the reader looks) */
    unsigned long long last_line; /* line of the last token taken */
    int state;                   /* 0 = no token read yet, 1 = token ready, 2 = end of file */
} lexer;

typedef struct parser {
    lexer lx;
    const char *name;
    rad_scene *s;
    rad_error *err;
    uint64_t max_polygons;
    rad_names polygon_names;     /* polygon names seen, keys owned by the scene */
    double *nums;                /* a polygon's numbers, reused */
    size_t nums_cap;
    rad_vec3 *pts;               /* a polygon's points, reused */
    size_t pts_cap;
} parser;

static int perr(parser *P, unsigned long long line, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
static int perr(parser *P, unsigned long long line, int code, const char *fmt, ...)
{
    char what[900];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return rad_fail(P->err, code, "%s: line %llu: %s", P->name, line, what);
}

/* ------------------------------------------------------------------- lexer */

static int is_space(unsigned char c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/* Makes the next token current (state 1) or notes the end (state 2).
 * Returns RAD_OK or an error. */
static int lex_fill(parser *P)
{
    lexer *L = &P->lx;
    if (L->state != 0)
        return RAD_OK;
    for (;;) {
        while (L->p < L->end && is_space((unsigned char)*L->p))
            L->p++;
        if (L->p < L->end)
            break;
        rad_line ln;
        if (!rad_lines_next(&L->lines, &ln)) {
            L->state = 2;
            L->tok[0] = '\0';
            L->len = 0;
            L->tok_line = L->last_line;
            return RAD_OK;
        }
        L->p = ln.text;
        L->end = ln.text + ln.content;
        L->line = ln.number;
    }
    L->tok_line = L->line;
    size_t n = 0;
    while (L->p < L->end && !is_space((unsigned char)*L->p)) {
        if (*L->p == '\0')
            return perr(P, L->line, RAD_ERR_PARSE, "NUL byte in the text");
        if (n >= MAX_TOKEN)
            return perr(P, L->line, RAD_ERR_PARSE, "a word longer than %d characters",
                        MAX_TOKEN);
        L->tok[n++] = *L->p++;
    }
    L->tok[n] = '\0';
    L->len = n;
    L->state = 1;
    return RAD_OK;
}

/* Peeks: 1 when a token is current, 0 at the end of the file, or an error
 * code through *rc. */
static int lex_peek(parser *P, int *rc)
{
    *rc = lex_fill(P);
    if (*rc)
        return 0;
    return P->lx.state == 1;
}

static void lex_take(parser *P)
{
    if (P->lx.state == 1) {
        P->lx.state = 0;
        P->lx.last_line = P->lx.tok_line;
    }
}

static int tok_is(const parser *P, const char *word)
{
    return P->lx.state == 1 && strcmp(P->lx.tok, word) == 0;
}

/* A short, printable rendering of the current token for messages. */
static const char *tok_show(parser *P, char *buf, size_t size)
{
    if (P->lx.state != 1)
        return "end of file";
    size_t n = 0;
    for (size_t k = 0; k < P->lx.len && n + 4 < size; k++) {
        unsigned char c = (unsigned char)P->lx.tok[k];
        buf[n++] = (c >= 0x20 && c != 0x7f) ? (char)c : '?';
        if (k == 40 && P->lx.len > 44) {
            buf[n++] = '.';
            buf[n++] = '.';
            buf[n++] = '.';
            break;
        }
    }
    buf[n] = '\0';
    return buf;
}

/* Is the current token a number in strtod's syntax?  (inf and nan count, so
 * that they are refused as non-finite rather than as unknown words.) */
static int tok_number(parser *P, double *v)
{
    if (P->lx.state != 1 || P->lx.len == 0)
        return 0;
    char c = P->lx.tok[0];
    if (!((c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.' || c == 'i' || c == 'I' ||
          c == 'n' || c == 'N'))
        return 0;
    char *end;
    errno = 0;
    double x = strtod(P->lx.tok, &end);
    if (end != P->lx.tok + P->lx.len)
        return 0;
    *v = x;
    return 1;
}

/* Reads a name (any word).  what: "a material name" for the message. */
static int need_name(parser *P, const char *what, char **out)
{
    int rc;
    if (!lex_peek(P, &rc)) {
        if (rc)
            return rc;
        return perr(P, P->lx.tok_line, RAD_ERR_PARSE, "expected %s, found end of file", what);
    }
    char *d = malloc(P->lx.len + 1);
    if (!d)
        return perr(P, P->lx.tok_line, RAD_ERR_NOMEM, "out of memory");
    memcpy(d, P->lx.tok, P->lx.len + 1);
    lex_take(P);
    *out = d;
    return RAD_OK;
}

static int need_number(parser *P, const char *what, double *v)
{
    int rc;
    char b[64];
    if (!lex_peek(P, &rc)) {
        if (rc)
            return rc;
        return perr(P, P->lx.tok_line, RAD_ERR_PARSE, "expected %s, found end of file", what);
    }
    if (!tok_number(P, v))
        return perr(P, P->lx.tok_line, RAD_ERR_PARSE, "expected %s, found '%s'", what,
                    tok_show(P, b, sizeof b));
    if (!isfinite(*v))
        return perr(P, P->lx.tok_line, RAD_ERR_PARSE, "%s '%s' is not a finite number", what,
                    tok_show(P, b, sizeof b));
    lex_take(P);
    return RAD_OK;
}

static int need_keyword(parser *P, const char *word, const char *context)
{
    int rc;
    char b[64];
    if (!lex_peek(P, &rc)) {
        if (rc)
            return rc;
        return perr(P, P->lx.tok_line, RAD_ERR_PARSE, "%s: expected '%s', found end of file",
                    context, word);
    }
    if (!tok_is(P, word))
        return perr(P, P->lx.tok_line, RAD_ERR_PARSE, "%s: expected '%s', found '%s'", context,
                    word, tok_show(P, b, sizeof b));
    lex_take(P);
    return RAD_OK;
}

/* A positive whole number no larger than max. */
static int whole(double v, double max)
{
    return v >= 1.0 && v <= max && v == floor(v);
}

/* -------------------------------------------------------------- statements */

static int parse_header(parser *P)
{
    int rc;
    char b[64];
    if (!lex_peek(P, &rc)) {
        if (rc)
            return rc;
        return perr(P, P->lx.tok_line, RAD_ERR_PARSE, "empty file: expected 'bands' first");
    }
    if (!tok_is(P, "bands"))
        return perr(P, P->lx.tok_line, RAD_ERR_PARSE,
                    "expected 'bands' first (the number of colour bands), found '%s'",
                    tok_show(P, b, sizeof b));
    lex_take(P);
    double v;
    unsigned long long line = P->lx.tok_line;
    if ((rc = need_number(P, "the number of bands", &v)))
        return rc;
    if (!whole(v, RAD_MAX_BANDS))
        return perr(P, line, RAD_ERR_PARSE, "bands %g: expected a whole number from 1 to %d", v,
                    RAD_MAX_BANDS);
    P->s = rad_scene_create((uint32_t)v, P->name);
    if (!P->s)
        return perr(P, line, RAD_ERR_NOMEM, "out of memory");
    if (lex_peek(P, &rc) && tok_is(P, "names")) {
        lex_take(P);
        for (uint32_t k = 0; k < P->s->band_count; k++) {
            char what[40];
            snprintf(what, sizeof what, "the name of band %u", k);
            if ((rc = need_name(P, what, &P->s->band_names[k])))
                return rc;
        }
    }
    return rc;
}

/* VALUES: one number (every band) or exactly band_count numbers. */
static int parse_values(parser *P, const char *what, unsigned long long line, double *out)
{
    uint32_t nb = P->s->band_count, n = 0;
    double v[RAD_MAX_BANDS];
    int rc;
    char b[64];
    double x;
    while (lex_peek(P, &rc) && tok_number(P, &x)) {
        if (!isfinite(x))
            return perr(P, P->lx.tok_line, RAD_ERR_PARSE, "%s '%s' is not a finite number", what,
                        tok_show(P, b, sizeof b));
        if (n >= nb)
            return perr(P, P->lx.tok_line, RAD_ERR_PARSE,
                        "%s: more than %u values, give 1 (all bands) or %u", what, nb, nb);
        v[n++] = x;
        lex_take(P);
    }
    if (rc)
        return rc;
    if (n != 1 && n != nb)
        return perr(P, line, RAD_ERR_PARSE, "%s: %u values, give 1 (all bands) or %u", what, n,
                    nb);
    for (uint32_t k = 0; k < nb; k++)
        out[k] = v[n == 1 ? 0 : k];
    return RAD_OK;
}

static int parse_material(parser *P, unsigned long long line)
{
    char *name = NULL;
    int rc = need_name(P, "a material name", &name);
    if (rc)
        return rc;
    double rho[RAD_MAX_BANDS] = {0}, em[RAD_MAX_BANDS] = {0}, tr[RAD_MAX_BANDS] = {0};
    /* metallic and roughness: one number each, glTF's meaning (scene.h). */
    double metal = 0.0, rough = 1.0;
    enum { NPROP = 5 };
    int seen[NPROP] = {0}, any = 0;
    static const char *const props[NPROP] = {"reflectance", "emission", "transmittance",
                                             "metallic", "roughness"};
    double *dst[NPROP] = {rho, em, tr, &metal, &rough};
    for (;;) {
        int k = -1;
        if (lex_peek(P, &rc)) {
            for (int i = 0; i < NPROP; i++)
                if (tok_is(P, props[i]))
                    k = i;
        }
        if (rc) {
            free(name);
            return rc;
        }
        if (k < 0)
            break;
        unsigned long long pl = P->lx.tok_line;
        if (seen[k]) {
            rc = perr(P, pl, RAD_ERR_PARSE, "material '%s': %s given twice", name, props[k]);
            free(name);
            return rc;
        }
        lex_take(P);
        char what[300];
        snprintf(what, sizeof what, "material '%s': %s", name, props[k]);
        if ((rc = k < 3 ? parse_values(P, what, pl, dst[k]) : need_number(P, what, dst[k]))) {
            free(name);
            return rc;
        }
        seen[k] = any = 1;
    }
    if (!any) {
        char b[64];
        rc = perr(P, P->lx.tok_line, RAD_ERR_PARSE,
                  "material '%s': expected reflectance, emission, transmittance, metallic or "
                  "roughness, found '%s'",
                  name, tok_show(P, b, sizeof b));
        free(name);
        return rc;
    }
    char where[40];
    snprintf(where, sizeof where, "line %llu", line);
    uint32_t index;
    rc = rad_scene_add_material(P->s, name, rho, em, tr, where, &index, P->err);
    if (!rc && (seen[3] || seen[4]))
        rc = rad_scene_set_material_gloss(P->s, index, metal, rough, where, P->err);
    free(name);
    return rc;
}

static int grow_buf(void **buf, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return 0;
    size_t c = *cap ? *cap : 64;
    while (c < need)
        c *= 2;
    void *p = realloc(*buf, c * elem);
    if (!p)
        return -1;
    *buf = p;
    *cap = c;
    return 0;
}

/* 'polygon' has been read on `line`; object is the group's, or RAD_NONE for
 * a polygon that is its own object. */
static int parse_polygon(parser *P, unsigned long long line, uint32_t object)
{
    char *name = NULL, *mat = NULL;
    char b[64], where[40];
    int rc = need_name(P, "a polygon name", &name);
    if (rc)
        return rc;
    if ((rc = need_name(P, "a material name", &mat)))
        goto done;
    snprintf(where, sizeof where, "line %llu", line);
    if (P->s->polygon_count >= P->max_polygons) {
        rc = perr(P, line, RAD_ERR_LIMIT, "polygon '%s': more than %llu polygons (the limit)",
                  name, (unsigned long long)P->max_polygons);
        goto done;
    }
    if (rad_names_find(&P->polygon_names, name) != RAD_NONE) {
        rc = perr(P, line, RAD_ERR_INVALID, "polygon '%s': a polygon of this name already exists",
                  name);
        goto done;
    }
    uint32_t material = rad_scene_find_material(P->s, mat);
    if (material == RAD_NONE) {
        rc = perr(P, line, RAD_ERR_INVALID, "polygon '%s': unknown material '%s'", name, mat);
        goto done;
    }

    /* The numbers up to 'end'.  After 'subdivide' one or two of them are the
     * subdivision, told apart by the count: the points come in threes. */
    int subdivide = 0;
    if (lex_peek(P, &rc) && tok_is(P, "subdivide")) {
        subdivide = 1;
        lex_take(P);
    }
    if (rc)
        goto done;
    size_t n = 0, limit = 3 * (size_t)MAX_POLY_POINTS + 2;
    double v;
    for (;;) {
        if (!lex_peek(P, &rc)) {
            if (!rc)
                rc = perr(P, line, RAD_ERR_PARSE,
                          "polygon '%s' is not terminated: 'end' missing", name);
            goto done;
        }
        if (tok_is(P, "end")) {
            lex_take(P);
            break;
        }
        if (!tok_number(P, &v)) {
            rc = perr(P, P->lx.tok_line, RAD_ERR_PARSE,
                      "polygon '%s' (line %llu): expected a coordinate or 'end', found '%s'",
                      name, line, tok_show(P, b, sizeof b));
            goto done;
        }
        if (!isfinite(v)) {
            rc = perr(P, P->lx.tok_line, RAD_ERR_PARSE,
                      "polygon '%s': '%s' is not a finite number", name, tok_show(P, b, sizeof b));
            goto done;
        }
        if (n >= limit) {
            rc = perr(P, P->lx.tok_line, RAD_ERR_LIMIT,
                      "polygon '%s': more than %d points", name, MAX_POLY_POINTS);
            goto done;
        }
        if (grow_buf((void **)&P->nums, &P->nums_cap, n + 1, sizeof *P->nums)) {
            rc = perr(P, line, RAD_ERR_NOMEM, "out of memory");
            goto done;
        }
        P->nums[n++] = v;
        lex_take(P);
    }
    size_t ns = 0;
    uint32_t su = 0, sv = 0;
    if (subdivide) {
        ns = n % 3;
        if (ns == 0) {
            rc = perr(P, line, RAD_ERR_PARSE,
                      "polygon '%s': 'subdivide' needs 1 or 2 whole numbers before the points",
                      name);
            goto done;
        }
        for (size_t k = 0; k < ns; k++)
            if (!whole(P->nums[k], MAX_SUBDIV)) {
                rc = perr(P, line, RAD_ERR_PARSE,
                          "polygon '%s': subdivide %g: expected a whole number from 1 to %d",
                          name, P->nums[k], MAX_SUBDIV);
                goto done;
            }
        su = (uint32_t)P->nums[0];
        sv = ns == 2 ? (uint32_t)P->nums[1] : su;
    } else if (n % 3 != 0) {
        rc = perr(P, line, RAD_ERR_PARSE,
                  "polygon '%s': %zu numbers do not make whole points (x y z each)", name, n);
        goto done;
    }
    size_t np = (n - ns) / 3;
    if (np > 0 && grow_buf((void **)&P->pts, &P->pts_cap, np, sizeof *P->pts)) {
        rc = perr(P, line, RAD_ERR_NOMEM, "out of memory");
        goto done;
    }
    for (size_t k = 0; k < np; k++)
        P->pts[k] = rad_v3(P->nums[ns + 3 * k], P->nums[ns + 3 * k + 1], P->nums[ns + 3 * k + 2]);

    if (object == RAD_NONE &&
        (rc = rad_scene_add_object(P->s, name, where, &object, P->err)))
        goto done;
    uint32_t index;
    if ((rc = rad_scene_add_polygon(P->s, name, object, material, np ? P->pts : NULL,
                                    (uint32_t)np, su, sv, where, &index, P->err)))
        goto done;
    if (rad_names_insert(&P->polygon_names, P->s->polygons[index].name, index))
        rc = perr(P, line, RAD_ERR_NOMEM, "out of memory");
done:
    free(name);
    free(mat);
    return rc;
}

static int parse_group(parser *P, unsigned long long line)
{
    char *name = NULL, b[64], where[40];
    int rc = need_name(P, "a group name", &name);
    if (rc)
        return rc;
    snprintf(where, sizeof where, "line %llu", line);
    uint32_t object, count = 0;
    if ((rc = rad_scene_add_object(P->s, name, where, &object, P->err)))
        goto done;
    for (;;) {
        if (!lex_peek(P, &rc)) {
            if (!rc)
                rc = perr(P, line, RAD_ERR_PARSE, "group '%s' is not terminated: 'end' missing",
                          name);
            goto done;
        }
        if (tok_is(P, "end")) {
            lex_take(P);
            break;
        }
        if (!tok_is(P, "polygon")) {
            rc = perr(P, P->lx.tok_line, RAD_ERR_PARSE,
                      "group '%s' (line %llu): expected 'polygon' or 'end', found '%s'", name,
                      line, tok_show(P, b, sizeof b));
            goto done;
        }
        unsigned long long pl = P->lx.tok_line;
        lex_take(P);
        if ((rc = parse_polygon(P, pl, object)))
            goto done;
        count++;
    }
    if (count == 0)
        rc = perr(P, line, RAD_ERR_PARSE, "group '%s' has no polygons", name);
done:
    free(name);
    return rc;
}

/* camera NAME eye X Y Z target X Y Z up X Y Z fov DEGREES
 * camera NAME eye X Y Z target X Y Z up X Y Z ortho HALF_HEIGHT */
static int parse_camera(parser *P, unsigned long long line)
{
    char *name = NULL, ctx[300], where[40];
    int rc = need_name(P, "a camera name", &name);
    if (rc)
        return rc;
    snprintf(ctx, sizeof ctx, "camera '%s'", name);
    double v[10];
    static const char *const keys[3] = {"eye", "target", "up"};
    static const char *const what[9] = {"eye x",    "eye y", "eye z", "target x", "target y",
                                        "target z", "up x",  "up y",  "up z"};
    for (int key = 0, k = 0; key < 3; key++) {
        if ((rc = need_keyword(P, keys[key], ctx)))
            goto done;
        for (int c = 0; c < 3; c++, k++)
            if ((rc = need_number(P, what[k], &v[k])))
                goto done;
    }
    /* the last keyword says the projection */
    int ortho = lex_peek(P, &rc) && tok_is(P, "ortho");
    if (rc)
        goto done;
    if (ortho)
        lex_take(P);
    else if ((rc = need_keyword(P, "fov", ctx)))
        goto done;
    if ((rc = need_number(P, ortho ? "ortho (half-height)" : "fov (degrees)", &v[9])))
        goto done;
    snprintf(where, sizeof where, "line %llu", line);
    rad_vec3 eye = rad_v3(v[0], v[1], v[2]), target = rad_v3(v[3], v[4], v[5]),
             up = rad_v3(v[6], v[7], v[8]);
    rc = ortho ? rad_scene_add_ortho_camera(P->s, name, eye, target, up, v[9], v[9], where,
                                            NULL, P->err)
               : rad_scene_add_camera(P->s, name, eye, target, up, v[9], 0.0, where, NULL,
                                      P->err);
done:
    free(name);
    return rc;
}

/* light NAME point X Y Z intensity VALUES
 * light NAME spot X Y Z direction X Y Z inner DEG outer DEG intensity VALUES
 * light NAME directional direction X Y Z irradiance VALUES */
static int parse_light(parser *P, unsigned long long line)
{
    char *name = NULL, ctx[300], where[40], b[64];
    int rc = need_name(P, "a light name", &name);
    if (rc)
        return rc;
    snprintf(ctx, sizeof ctx, "light '%s'", name);
    rad_light_kind kind;
    double pos[3] = {0, 0, 0}, dir[3] = {0, 0, -1}, inner = 0, outer = 90, I[RAD_MAX_BANDS];
    static const char *const axis[3] = {"x", "y", "z"};
    char what[64];
    if (!lex_peek(P, &rc)) {
        if (!rc)
            rc = perr(P, P->lx.tok_line, RAD_ERR_PARSE,
                      "%s: expected point, spot or directional, found end of file", ctx);
        goto done;
    }
    if (tok_is(P, "point"))
        kind = RAD_LIGHT_POINT;
    else if (tok_is(P, "spot"))
        kind = RAD_LIGHT_SPOT;
    else if (tok_is(P, "directional"))
        kind = RAD_LIGHT_DIRECTIONAL;
    else {
        rc = perr(P, P->lx.tok_line, RAD_ERR_PARSE,
                  "%s: expected point, spot or directional, found '%s'", ctx,
                  tok_show(P, b, sizeof b));
        goto done;
    }
    lex_take(P);
    for (int c = 0; kind != RAD_LIGHT_DIRECTIONAL && c < 3; c++) {
        snprintf(what, sizeof what, "position %s", axis[c]);
        if ((rc = need_number(P, what, &pos[c])))
            goto done;
    }
    if (kind != RAD_LIGHT_POINT) {
        if ((rc = need_keyword(P, "direction", ctx)))
            goto done;
        for (int c = 0; c < 3; c++) {
            snprintf(what, sizeof what, "direction %s", axis[c]);
            if ((rc = need_number(P, what, &dir[c])))
                goto done;
        }
    }
    if (kind == RAD_LIGHT_SPOT) {
        if ((rc = need_keyword(P, "inner", ctx)) ||
            (rc = need_number(P, "inner cone angle (degrees)", &inner)) ||
            (rc = need_keyword(P, "outer", ctx)) ||
            (rc = need_number(P, "outer cone angle (degrees)", &outer)))
            goto done;
    }
    const char *unit = kind == RAD_LIGHT_DIRECTIONAL ? "irradiance" : "intensity";
    if ((rc = need_keyword(P, unit, ctx)) || (rc = parse_values(P, unit, line, I)))
        goto done;
    snprintf(where, sizeof where, "line %llu", line);
    rc = rad_scene_add_light(P->s, name, kind, I, rad_v3(pos[0], pos[1], pos[2]),
                             rad_v3(dir[0], dir[1], dir[2]), inner * (M_PI / 180.0),
                             outer * (M_PI / 180.0), where, NULL, P->err);
done:
    free(name);
    return rc;
}

static int parse_all(parser *P)
{
    int rc = parse_header(P);
    if (rc)
        return rc;
    char b[64];
    while (lex_peek(P, &rc)) {
        unsigned long long line = P->lx.tok_line;
        if (tok_is(P, "material")) {
            lex_take(P);
            rc = parse_material(P, line);
        } else if (tok_is(P, "polygon")) {
            lex_take(P);
            rc = parse_polygon(P, line, RAD_NONE);
        } else if (tok_is(P, "group")) {
            lex_take(P);
            rc = parse_group(P, line);
        } else if (tok_is(P, "camera")) {
            lex_take(P);
            rc = parse_camera(P, line);
        } else if (tok_is(P, "light")) {
            lex_take(P);
            rc = parse_light(P, line);
        } else {
            rc = perr(P, line, RAD_ERR_PARSE,
                      "unknown statement '%s' (expected material, polygon, group, camera or "
                      "light)",
                      tok_show(P, b, sizeof b));
        }
        if (rc)
            return rc;
    }
    return rc;
}

int rad_scene_parse_polyfile(const char *text, size_t size, const char *name,
                             const rad_load_options *opt, rad_scene **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!name)
        name = "<memory>";
    if (!out || (!text && size))
        return rad_fail(err, RAD_ERR_USAGE, "%s: no text or no output", name);
    parser *P = calloc(1, sizeof *P);
    if (!P)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", name);
    rad_lines_start(&P->lx.lines, text, size);
    P->lx.line = 1;
    P->lx.tok_line = 1;
    P->lx.last_line = 1;
    P->name = name;
    P->err = err;
    P->max_polygons = opt && opt->max_polygons ? opt->max_polygons : 10000000u;
    int rc = parse_all(P);
    rad_names_free(&P->polygon_names);
    free(P->nums);
    free(P->pts);
    if (rc) {
        rad_scene_destroy(P->s);
    } else {
        *out = P->s;
    }
    free(P);
    return rc;
}
