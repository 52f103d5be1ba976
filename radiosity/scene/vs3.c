/* vs3.c - View3D's input file (F 3 geometry, docs/view3d.md) as a scene:
 * title, controls, numbered vertices, and numbered surfaces of four kinds
 * (S radiating, O obstruction only, M mask, N null) with base surface,
 * combination, emittance ε and name.
 *
 * Each surface becomes one object named as in the file, with a material of
 * its own (ρ = 1 − ε, no emission) and the convex polygons that are left of
 * it once the surfaces based on it are cut out: a window takes its area out
 * of its wall, as View3D does, so the wall object holds up to four convex
 * pieces around it.  The surface-level bookkeeping (kinds, bases,
 * combinations, controls) is kept in a rad_vs3 for the factor algebra.
 *
 * Invariant: every failure is one rad_error "FILE: line N: WHAT" with all
 * memory freed; the scene returned has passed the scene.c checks.
 */
#include "scene.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define MAX_TOK 16        /* tokens on one line that the format can use */
#define MAX_PIECE 16      /* points of a clipped piece (a convex quad cut by convex quads) */
#define MAX_ITEMS 1000000 /* vertices or surfaces in one file */

typedef struct piece {
    rad_vec3 p[MAX_PIECE];
    uint32_t n;
} piece;

typedef struct vs3_surf {
    rad_vs3_surface s;
    rad_vec3 corner[4];
    uint32_t corners;
    rad_vec3 normal;
    piece *pieces;
    uint32_t piece_count, piece_cap;
} vs3_surf;

typedef struct vs3_parser {
    const char *name;
    rad_error *err;
    const rad_load_options *opt;
    rad_vec3 *vert;
    uint32_t vert_count, vert_cap;
    vs3_surf *surf;
    uint32_t surf_count, surf_cap;
    rad_vs3 *model;
    unsigned long long line;
    char buf[4096];
    char *tok[MAX_TOK];
    uint32_t ntok;
} vs3_parser;

static int verr(vs3_parser *P, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static int verr(vs3_parser *P, int code, const char *fmt, ...)
{
    char what[900];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return rad_fail(P->err, code, "%s: line %llu: %s", P->name, P->line, what);
}

/* ---------------------------------------------------------------- tokens */

/* Splits the line (its comment, from '!' or '/', cut off) into P->tok;
 * `equals` also splits at '=' (the control line).  Fails on more tokens
 * than the format has room for, or on a NUL byte. */
static int tokenize(vs3_parser *P, const char *text, size_t len, int equals)
{
    if (len >= sizeof P->buf)
        return verr(P, RAD_ERR_PARSE, "line longer than %zu bytes", sizeof P->buf - 1);
    memcpy(P->buf, text, len);
    P->buf[len] = '\0';
    if (strlen(P->buf) != len)
        return verr(P, RAD_ERR_PARSE, "NUL byte in the line");
    char *cut = strpbrk(P->buf, "!/");
    if (cut)
        *cut = '\0';
    P->ntok = 0;
    for (char *c = P->buf; *c;) {
        if (*c == ' ' || *c == '\t' || *c == '\r' || *c == '\v' || *c == '\f' ||
            (equals && *c == '=')) {
            *c++ = '\0';
            continue;
        }
        if (P->ntok == MAX_TOK)
            return verr(P, RAD_ERR_PARSE, "more than %d fields", MAX_TOK);
        P->tok[P->ntok++] = c;
        while (*c && !strchr(" \t\r\v\f", *c) && !(equals && *c == '='))
            c++;
    }
    return RAD_OK;
}

static int parse_real(vs3_parser *P, const char *t, const char *what, double *out)
{
    char *end;
    *out = strtod(t, &end);
    if (end == t || *end || !isfinite(*out))
        return verr(P, RAD_ERR_PARSE, "%s: '%s' is not a finite number", what, t);
    return RAD_OK;
}

static int parse_count(vs3_parser *P, const char *t, const char *what, uint32_t *out)
{
    char *end;
    unsigned long v = strtoul(t, &end, 10);
    if (end == t || *end || t[0] == '-' || t[0] == '+' || v > MAX_ITEMS)
        return verr(P, RAD_ERR_PARSE, "%s: '%s' is not a whole number from 0 to %d", what, t,
                    MAX_ITEMS);
    *out = (uint32_t)v;
    return RAD_OK;
}

/* --------------------------------------------------------------- controls */

/* The controls View3D knows; only encl and emit change what is computed
 * (docs/view3d.md says why each other one is ignored). */
static const struct {
    const char *name;
    const char *why; /* NULL: honoured */
} controls[] = {
    {"encl", NULL},
    {"emit", NULL},
    {"eps", "the hemi-cube's accuracy is set by --resolution and the patch size"},
    {"maxU", "no adaptive integration to bound"},
    {"maxO", "no adaptive integration to bound"},
    {"minO", "no adaptive integration to bound"},
    {"maxV", "no adaptive integration to bound"},
    {"row", "every row is computed and reported"},
    {"col", "every column is computed and reported"},
    {"list", "no log file is written"},
    {"out", "the output is always the text layout"},
    {"prtp", "no log file is written"},
};

static int parse_controls(vs3_parser *P)
{
    if ((P->ntok - 1) % 2)
        return verr(P, RAD_ERR_PARSE, "a control without a value (expected name=value pairs)");
    for (uint32_t t = 1; t < P->ntok; t += 2) {
        const char *key = P->tok[t];
        double v;
        size_t c = 0, nc = sizeof controls / sizeof controls[0];
        while (c < nc && strcasecmp(controls[c].name, key))
            c++;
        if (c == nc)
            return verr(P, RAD_ERR_PARSE, "unknown control '%s' (View3D's are encl, emit, eps, "
                        "maxU, maxO, minO, maxV, row, col, list, out, prtp)", key);
        if (parse_real(P, P->tok[t + 1], key, &v))
            return P->err->code;
        if (controls[c].why) {
            rad_warn(P->opt ? P->opt->warn : NULL, P->opt ? P->opt->warn_user : NULL,
                     "%s: line %llu: control %s=%s ignored: %s", P->name, P->line,
                     controls[c].name, P->tok[t + 1], controls[c].why);
            continue;
        }
        if (v != 0.0 && v != 1.0)
            return verr(P, RAD_ERR_INVALID, "%s=%s: must be 0 or 1", key, P->tok[t + 1]);
        if (c == 0)
            P->model->encl = (int)v;
        else
            P->model->emit = (int)v;
    }
    return RAD_OK;
}

/* ------------------------------------------------------ vertices, surfaces */

static int grow(void **p, uint32_t *cap, uint32_t need, size_t size)
{
    if (need <= *cap)
        return 0;
    uint32_t nc = *cap ? *cap * 2 : 16;
    void *np = realloc(*p, (size_t)nc * size);
    if (!np)
        return -1;
    *p = np;
    *cap = nc;
    return 0;
}

static int parse_vertex(vs3_parser *P)
{
    uint32_t num;
    double x[3];
    if (P->ntok != 5)
        return verr(P, RAD_ERR_PARSE, "a vertex is 'V number x y z' (%u fields found)", P->ntok);
    if (parse_count(P, P->tok[1], "vertex number", &num))
        return P->err->code;
    if (num != P->vert_count + 1)
        return verr(P, RAD_ERR_INVALID, num <= P->vert_count
                    ? "vertex %u is defined twice (vertices run 1, 2, 3, ... in order)"
                    : "vertex %u out of order: vertex %u is missing", num, P->vert_count + 1);
    for (int k = 0; k < 3; k++)
        if (parse_real(P, P->tok[2 + k], "vertex coordinate", &x[k]))
            return P->err->code;
    if (grow((void **)&P->vert, &P->vert_cap, P->vert_count + 1, sizeof *P->vert))
        return verr(P, RAD_ERR_NOMEM, "out of memory");
    P->vert[P->vert_count++] = rad_v3(x[0], x[1], x[2]);
    return RAD_OK;
}

static rad_vs3_kind kind_of(char c)
{
    switch (c) {
    case 'O': case 'o': return RAD_VS3_OBSTRUCTION;
    case 'M': case 'm': return RAD_VS3_MASK;
    case 'N': case 'n': return RAD_VS3_NULL;
    default: return RAD_VS3_SURFACE;
    }
}

/* base and cmb: 0 or an earlier surface's number, as the kinds allow. */
static int check_links(vs3_parser *P, vs3_surf *S, uint32_t base, uint32_t cmb)
{
    uint32_t me = S->s.number;
    rad_vs3_kind k = S->s.kind;
    if (base >= me || cmb >= me)
        return verr(P, RAD_ERR_INVALID, "surface %u: its %s %u must be a surface numbered "
                    "before it", me, base >= me ? "base" : "combination", base >= me ? base : cmb);
    if ((k == RAD_VS3_MASK || k == RAD_VS3_NULL) &&
        (!base || P->surf[base - 1].s.kind != RAD_VS3_SURFACE))
        return verr(P, RAD_ERR_INVALID, "surface %u: a %s surface needs a radiating (S) surface "
                    "as its base", me, k == RAD_VS3_MASK ? "mask (M)" : "null (N)");
    if (k == RAD_VS3_OBSTRUCTION && base)
        return verr(P, RAD_ERR_INVALID, "surface %u: an obstruction (O) has no base", me);
    if (cmb && (k != RAD_VS3_SURFACE || P->surf[cmb - 1].s.kind != RAD_VS3_SURFACE))
        return verr(P, RAD_ERR_INVALID, "surface %u: only radiating (S) surfaces combine", me);
    if (cmb && P->surf[cmb - 1].s.combine != RAD_NONE)
        return verr(P, RAD_ERR_INVALID, "surface %u: surface %u is itself combined with surface "
                    "%u; combine with that one (no chains)", me, cmb,
                    P->surf[P->surf[cmb - 1].s.combine].s.number);
    S->s.base = base ? base - 1 : RAD_NONE;
    S->s.combine = cmb ? cmb - 1 : RAD_NONE;
    return RAD_OK;
}

static int surface_corners(vs3_parser *P, vs3_surf *S)
{
    uint32_t v[4];
    for (int k = 0; k < 4; k++)
        if (parse_count(P, P->tok[2 + k], "vertex", &v[k]))
            return P->err->code;
    S->corners = v[3] ? 4 : 3;
    for (uint32_t k = 0; k < S->corners; k++) {
        if (v[k] == 0 || v[k] > P->vert_count)
            return verr(P, RAD_ERR_INVALID, "surface %u: vertex %u is not defined (vertices "
                        "come before the surfaces that use them)", S->s.number, v[k]);
        for (uint32_t j = 0; j < k; j++)
            if (v[j] == v[k])
                return verr(P, RAD_ERR_INVALID, "surface %u: vertex %u used twice",
                            S->s.number, v[k]);
        S->corner[k] = P->vert[v[k] - 1];
    }
    return RAD_OK;
}

static int parse_surface(vs3_parser *P, char kind)
{
    if (P->ntok != 10)
        return verr(P, RAD_ERR_PARSE, "a surface is '%c number v1 v2 v3 v4 base cmb emit name' "
                    "(%u fields found)", kind, P->ntok);
    if (grow((void **)&P->surf, &P->surf_cap, P->surf_count + 1, sizeof *P->surf))
        return verr(P, RAD_ERR_NOMEM, "out of memory");
    vs3_surf *S = &P->surf[P->surf_count];
    memset(S, 0, sizeof *S);
    S->s.kind = kind_of(kind);
    S->s.line = P->line;
    uint32_t base, cmb;
    if (parse_count(P, P->tok[1], "surface number", &S->s.number) ||
        parse_count(P, P->tok[6], "base surface", &base) ||
        parse_count(P, P->tok[7], "combination surface", &cmb) ||
        parse_real(P, P->tok[8], "emittance", &S->s.emittance))
        return P->err->code;
    if (S->s.number != P->surf_count + 1)
        return verr(P, RAD_ERR_INVALID, S->s.number <= P->surf_count
                    ? "surface %u is defined twice (surfaces run 1, 2, 3, ... in order)"
                    : "surface %u out of order: surface %u is missing", S->s.number,
                    P->surf_count + 1);
    if (!(S->s.emittance > 0.0 && S->s.emittance <= 1.0))
        return verr(P, RAD_ERR_INVALID, "surface %u: emittance %s outside (0, 1]", S->s.number,
                    P->tok[8]);
    for (uint32_t i = 0; i < P->surf_count; i++)
        if (!strcmp(P->surf[i].s.name, P->tok[9]))
            return verr(P, RAD_ERR_INVALID, "surface %u: name '%s' already names surface %u "
                        "(line %llu)", S->s.number, P->tok[9], i + 1, P->surf[i].s.line);
    if (check_links(P, S, base, cmb) || surface_corners(P, S))
        return P->err->code;
    if (!(S->s.name = strdup(P->tok[9])))
        return verr(P, RAD_ERR_NOMEM, "out of memory");
    P->surf_count++;
    return RAD_OK;
}

/* ---------------------------------------------------------------- geometry */

/* Newell's normal (unnormalised: its length is twice the area). */
static rad_vec3 newell(const rad_vec3 *p, uint32_t n)
{
    rad_vec3 s = {0, 0, 0};
    for (uint32_t i = 0; i < n; i++)
        s = rad_add(s, rad_cross(p[i], p[(i + 1) % n]));
    return s;
}

/* The part of `in` where side·d(x) >= 0, d(x) = ((b − a) × (x − a))·n
 * (Sutherland–Hodgman against one plane). */
static int clip_half(const piece *in, rad_vec3 a, rad_vec3 b, rad_vec3 n, double side,
                     piece *out)
{
    out->n = 0;
    rad_vec3 e = rad_sub(b, a);
    for (uint32_t i = 0; i < in->n; i++) {
        rad_vec3 p = in->p[i], q = in->p[(i + 1) % in->n];
        double dp = side * rad_dot(rad_cross(e, rad_sub(p, a)), n);
        double dq = side * rad_dot(rad_cross(e, rad_sub(q, a)), n);
        int cross = (dp > 0 && dq < 0) || (dp < 0 && dq > 0);
        if (out->n + (dp >= 0) + cross > MAX_PIECE)
            return -1;
        if (dp >= 0)
            out->p[out->n++] = p;
        if (cross)
            out->p[out->n++] = rad_lerp(p, q, dp / (dp - dq));
    }
    return 0;
}

/* Drops points that repeat or lie on the line through their neighbours,
 * so that the scene's convexity check sees a clean outline. */
static void tidy(piece *c, double tol)
{
    for (int changed = 1; changed && c->n >= 3;) {
        changed = 0;
        for (uint32_t i = 0; i < c->n && c->n >= 3; i++) {
            rad_vec3 a = c->p[(i + c->n - 1) % c->n], p = c->p[i], b = c->p[(i + 1) % c->n];
            double ab = rad_length(rad_sub(b, a));
            double off = ab > 0 ? rad_length(rad_cross(rad_sub(p, a), rad_sub(b, a))) / ab : 0;
            if (rad_length(rad_sub(p, a)) <= tol || off <= tol) {
                memmove(&c->p[i], &c->p[i + 1], (c->n - i - 1) * sizeof c->p[0]);
                c->n--;
                changed = 1;
            }
        }
    }
}

static int add_piece(vs3_surf *S, const piece *c)
{
    if (grow((void **)&S->pieces, &S->piece_cap, S->piece_count + 1, sizeof *S->pieces))
        return -1;
    S->pieces[S->piece_count++] = *c;
    return 0;
}

/* Cuts subsurface `sub` (in the plane of base, inside it) out of base's
 * pieces: each piece leaves the parts outside each of sub's edges in turn.
 * -1 when out of memory, -2 when a piece would have too many points. */
static int cut_out(vs3_surf *base, const vs3_surf *sub, double tol)
{
    rad_vec3 n = base->normal;
    int flip = rad_dot(sub->normal, n) < 0; /* a mask runs the other way round */
    uint32_t count = base->piece_count;
    piece *old = base->pieces;
    base->pieces = NULL;
    base->piece_count = base->piece_cap = 0;
    int rc = 0;
    for (uint32_t k = 0; k < count && !rc; k++) {
        piece rest = old[k], out, in;
        for (uint32_t e = 0; e < sub->corners && rest.n >= 3; e++) {
            rad_vec3 a = sub->corner[flip ? (sub->corners - e) % sub->corners : e];
            rad_vec3 b = sub->corner[flip ? sub->corners - 1 - e : (e + 1) % sub->corners];
            if (clip_half(&rest, a, b, n, -1.0, &out) || clip_half(&rest, a, b, n, 1.0, &in)) {
                rc = -2;
                break;
            }
            tidy(&out, tol);
            if (out.n >= 3 && rad_length(newell(out.p, out.n)) > tol * tol &&
                (rc = add_piece(base, &out)) != 0)
                break;
            rest = in;
        }
    }
    free(old);
    return rc;
}

/* A subsurface lies in its base's plane, inside it, facing the same way
 * (a mask: the opposite way). */
static int check_inside(vs3_parser *P, const vs3_surf *S, const vs3_surf *B, double tol)
{
    P->line = S->s.line;
    double d = rad_dot(S->normal, B->normal);
    int mask = S->s.kind == RAD_VS3_MASK;
    if (mask ? d > -0.999999 : d < 0.999999)
        return verr(P, RAD_ERR_INVALID, "surface %u must face %s its base surface %u",
                    S->s.number, mask ? "opposite to" : "the same way as", B->s.number);
    for (uint32_t k = 0; k < S->corners; k++) {
        rad_vec3 x = S->corner[k];
        if (fabs(rad_dot(rad_sub(x, B->corner[0]), B->normal)) > tol)
            return verr(P, RAD_ERR_INVALID, "surface %u is not in the plane of its base "
                        "surface %u", S->s.number, B->s.number);
        for (uint32_t e = 0; e < B->corners; e++) {
            rad_vec3 a = B->corner[e], b = B->corner[(e + 1) % B->corners];
            double side = rad_dot(rad_cross(rad_sub(b, a), rad_sub(x, a)), B->normal);
            if (side < -tol * rad_length(rad_sub(b, a)))
                return verr(P, RAD_ERR_INVALID, "surface %u is not inside its base surface %u",
                            S->s.number, B->s.number);
        }
    }
    return RAD_OK;
}

static double extent(const vs3_parser *P)
{
    double m = 0;
    for (uint32_t i = 0; i < P->vert_count; i++)
        m = fmax(m, fmax(fabs(P->vert[i].x), fmax(fabs(P->vert[i].y), fabs(P->vert[i].z))));
    return m > 0 ? m : 1.0;
}

/* Normals, areas, then every subsurface cut out of its base. */
static int shape_surfaces(vs3_parser *P)
{
    double tol = 1e-7 * extent(P);
    for (uint32_t i = 0; i < P->surf_count; i++) {
        vs3_surf *S = &P->surf[i];
        rad_vec3 nn = newell(S->corner, S->corners);
        S->s.area = 0.5 * rad_length(nn);
        S->normal = rad_normalize(nn);
        piece whole = {.n = S->corners};
        memcpy(whole.p, S->corner, S->corners * sizeof whole.p[0]);
        if (add_piece(S, &whole))
            return rad_fail(P->err, RAD_ERR_NOMEM, "%s: out of memory", P->name);
    }
    for (uint32_t i = 0; i < P->surf_count; i++) {
        vs3_surf *S = &P->surf[i];
        if (S->s.base == RAD_NONE || S->s.area <= 0)
            continue; /* a degenerate surface is refused with its line below */
        vs3_surf *B = &P->surf[S->s.base];
        if (check_inside(P, S, B, 1e-6 * extent(P)))
            return P->err->code;
        int rc = cut_out(B, S, tol);
        if (rc == -2)
            return verr(P, RAD_ERR_LIMIT, "surface %u: cutting it out leaves its base surface "
                        "%u in pieces of more than %d points", S->s.number, B->s.number,
                        MAX_PIECE);
        if (rc)
            return rad_fail(P->err, RAD_ERR_NOMEM, "%s: out of memory", P->name);
        if (B->piece_count == 0)
            return verr(P, RAD_ERR_INVALID, "surface %u covers all that is left of its base "
                        "surface %u (a surface of no area)", S->s.number, B->s.number);
    }
    return RAD_OK;
}

/* One object and one material per surface, one polygon per piece. */
static int build_scene(vs3_parser *P, rad_scene *sc)
{
    char where[64], pname[600];
    for (uint32_t i = 0; i < P->surf_count; i++) {
        vs3_surf *S = &P->surf[i];
        double rho = 1.0 - S->s.emittance, e = 0.0;
        uint32_t mat, obj;
        snprintf(where, sizeof where, "line %llu", S->s.line);
        if (rad_scene_add_material(sc, S->s.name, &rho, &e, NULL, where, &mat, P->err) ||
            rad_scene_add_object(sc, S->s.name, where, &obj, P->err))
            return P->err->code;
        S->s.object = obj;
        for (uint32_t k = 0; k < S->piece_count; k++) {
            snprintf(pname, sizeof pname, S->piece_count > 1 ? "%s#%u" : "%s", S->s.name, k + 1);
            if (rad_scene_add_polygon(sc, pname, obj, mat, S->pieces[k].p, S->pieces[k].n, 0, 0,
                                      where, NULL, P->err))
                return P->err->code;
        }
    }
    return RAD_OK;
}

/* ------------------------------------------------------------------ lines */

static int parse_line(vs3_parser *P, const rad_line *ln, int *done)
{
    const char *t = ln->text, *end = ln->text + ln->length;
    while (t < end && (*t == ' ' || *t == '\t' || *t == '\r'))
        t++;
    if (t == end || *t == '!' || *t == '/')
        return RAD_OK;
    char c = *t;
    if (c == 'T' || c == 't') { /* the title: the rest of the line, trimmed */
        const char *a = t + 1, *b = end;
        while (a < b && (*a == ' ' || *a == '\t'))
            a++;
        while (b > a && (b[-1] == ' ' || b[-1] == '\t' || b[-1] == '\r'))
            b--;
        free(P->model->title);
        if (!(P->model->title = strndup(a, (size_t)(b - a))))
            return verr(P, RAD_ERR_NOMEM, "out of memory");
        return RAD_OK;
    }
    if (c == '*' || c == 'E' || c == 'e') {
        *done = 1;
        return RAD_OK;
    }
    if (tokenize(P, t, (size_t)(end - t), c == 'C' || c == 'c'))
        return P->err->code;
    if (strlen(P->tok[0]) != 1)
        return verr(P, RAD_ERR_PARSE, "'%s': a line starts with one letter (T, C, F, V, S, O, "
                    "M, N, E) or a comment (!, /)", P->tok[0]);
    switch (c) {
    case 'C': case 'c': return parse_controls(P);
    case 'V': case 'v': return parse_vertex(P);
    case 'S': case 's': case 'O': case 'o': case 'M': case 'm': case 'N': case 'n':
        return parse_surface(P, c);
    case 'F': case 'f':
        if (P->ntok != 2 || strcmp(P->tok[1], "3"))
            return verr(P, RAD_ERR_PARSE, "geometry '%s': only 'F 3' (vertices and surfaces) is "
                        "read", P->ntok > 1 ? P->tok[1] : "");
        return RAD_OK;
    default:
        return verr(P, RAD_ERR_PARSE, "unknown line kind '%c' (T, C, F, V, S, O, M, N, E or a "
                    "comment)", c);
    }
}

static void free_parser(vs3_parser *P)
{
    for (uint32_t i = 0; i < P->surf_count; i++) {
        free(P->surf[i].s.name);
        free(P->surf[i].pieces);
    }
    free(P->surf);
    free(P->vert);
}

void rad_vs3_destroy(rad_vs3 *m)
{
    if (!m)
        return;
    for (uint32_t i = 0; i < m->surface_count; i++)
        free(m->surfaces[i].name);
    free(m->surfaces);
    free(m->title);
    free(m);
}

/* Moves the surfaces' records into the model (names change hands). */
static int finish_model(vs3_parser *P)
{
    rad_vs3 *m = P->model;
    if (!(m->surfaces = calloc(P->surf_count, sizeof *m->surfaces)))
        return rad_fail(P->err, RAD_ERR_NOMEM, "%s: out of memory", P->name);
    for (uint32_t i = 0; i < P->surf_count; i++) {
        m->surfaces[i] = P->surf[i].s;
        P->surf[i].s.name = NULL;
    }
    m->surface_count = P->surf_count;
    if (!m->title && !(m->title = strdup("")))
        return rad_fail(P->err, RAD_ERR_NOMEM, "%s: out of memory", P->name);
    return RAD_OK;
}

static int parse_all(vs3_parser *P, const char *text, size_t size, rad_scene *sc)
{
    rad_lines lines;
    rad_line ln;
    int done = 0;
    rad_lines_start(&lines, text, size);
    while (!done && rad_lines_next(&lines, &ln)) {
        P->line = ln.number;
        if (parse_line(P, &ln, &done))
            return P->err->code;
    }
    if (P->surf_count == 0) {
        P->line = P->line ? P->line : 1; /* an empty file: its first line */
        return verr(P, RAD_ERR_INVALID, "no surface (S, O, M or N line) before the end");
    }
    uint32_t radiating = 0;
    for (uint32_t i = 0; i < P->surf_count; i++)
        radiating += P->surf[i].s.kind == RAD_VS3_SURFACE || P->surf[i].s.kind == RAD_VS3_MASK;
    if (radiating == 0)
        return verr(P, RAD_ERR_INVALID, "no radiating surface (S or M line) before the end: "
                    "nothing to report");
    uint64_t max = P->opt && P->opt->max_polygons ? P->opt->max_polygons : 10000000u;
    if ((uint64_t)P->surf_count * 5 > max)
        return verr(P, RAD_ERR_LIMIT, "%u surfaces: more than the %llu polygons allowed",
                    P->surf_count, (unsigned long long)max);
    if (shape_surfaces(P) || build_scene(P, sc))
        return P->err->code;
    return finish_model(P);
}

int rad_vs3_parse(const char *text, size_t size, const char *name, const rad_load_options *opt,
                  rad_scene **scene, rad_vs3 **model, rad_error *err)
{
    *scene = NULL;
    if (model)
        *model = NULL;
    vs3_parser P = {.name = name ? name : "<memory>", .err = err, .opt = opt};
    rad_scene *sc = rad_scene_create(1, P.name);
    P.model = calloc(1, sizeof *P.model);
    int rc = (!sc || !P.model) ? rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", P.name)
                               : parse_all(&P, text, size, sc);
    free_parser(&P);
    if (rc) {
        rad_scene_destroy(sc);
        rad_vs3_destroy(P.model);
        return rc;
    }
    *scene = sc;
    if (model)
        *model = P.model;
    else
        rad_vs3_destroy(P.model);
    return RAD_OK;
}

int rad_scene_parse_vs3(const char *text, size_t size, const char *name,
                        const rad_load_options *opt, rad_scene **out, rad_error *err)
{
    return rad_vs3_parse(text, size, name, opt, out, NULL, err);
}
