/* refine.c - adaptive refinement: which elements a solution needs.
 *
 * Refinement splits where the drawn radiosity misses what a finer element
 * gathers: each leaf is probed (its four children gathered) and split when
 * the children's B differ from what the renderer draws at their centres by
 * more than the threshold, weighted by the leaf's area, or when it lies
 * across the foot of a block, part seen and part buried (see estimate).  An
 * element is its patch split `level` times as a quadtree.  The hemi-cube
 * engine is the caller's (the pipeline's, shared with the patch rows).
 *
 * How a new element (probe or leaf) gets its row (issue 18):
 *   - adaptive, by default: an interpolated element (solution.h) - its row
 *     is the emitters' strata entries (direct.c: one item buffer per
 *     stratum and pass, for every element of the pass), and its reflected
 *     light is read from the patches' field (element_gather.c's el_interp);
 *   - where another surface meets it (contact.c), a hemi-cube at its
 *     centre, whose entries for the emitters are replaced by the strata's
 *     so that both kinds agree on the direct light;
 *   - a child that nothing meets, holding the centre of a parent that sees
 *     nothing, is buried: no row, B = E;
 *   - uniform levels, element_hemicubes, or more strata than EL_MAX_STRATA:
 *     a hemi-cube for every element, as before issue 18.
 *
 * Invariant: a leaf element of level k > 0 has its own row (and, when the
 * scene has punctual lights, its own h_le), computed before its B_e is
 * gathered, so the refinement rule sees shadow edges finer than the patches.
 */
#include "el_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------- refinement */

/* Every element made so far while refining: the leaves, the parents they
 * were split from, and probes (the four children of a leaf, gathered to
 * test whether the leaf should split; kept only if it does, and then they
 * reuse their rows: a kept split costs no hemi-cube beyond its probes). */
enum { NODE_LEAF = 0, NODE_SPLIT, NODE_PROBE };

typedef struct enode {
    uint32_t v[4];     /* corners; v[3] == RAD_NONE for a triangle */
    uint32_t patch;
    uint32_t cell;     /* the patch's cell it lies in (index in the mesh's cells, or the patch) */
    uint32_t kids;     /* first of its four children (probes or split), RAD_NONE: none */
    uint32_t parent;   /* RAD_NONE at level 0 */
    uint8_t level;
    uint8_t state;     /* NODE_* */
    uint8_t settled;   /* 1: not worth probing (see refine_adaptive) */
    uint8_t interp;    /* 1: an interpolated element (solution.h), no hemi-cube of its own */
    uint32_t cnt;      /* row entries */
    uint64_t start;    /* first row entry */
} enode;

typedef struct builder {
    rad_solution *s;
    const double *Tr;  /* el_transmitted (τ_p H_twin(p)), or NULL */
    uint32_t bands;
    /* punctual lights: h_le of every element, ne × nl (level 0: 0) */
    uint32_t nl;
    uint32_t light_R;  /* item-buffer resolution at the lights */
    const hc_light *lights; /* the scene's lights as the hemi-cube takes them */
    float *h;
    uint64_t lights_rendered;
    /* vertices */
    rad_vec3 *V;
    uint8_t *Vb;
    uint32_t *Vsurf;
    uint8_t *outline;  /* per cell of the patch mesh: its edges on its surface's outline, one bit each */
    uint8_t *bent;     /* per patch: 1 when its cells bend (hc_row_cubes > 1), found once */
    uint32_t nv, cap_v;
    el_vtable t;
    /* elements */
    enode *E;
    double *B;         /* ne × bands */
    uint32_t ne, cap_e;
    /* rows */
    uint32_t *col;
    float *val;
    uint64_t nnz, cap_r;
    /* the elements of the rows being computed (receiver k -> which[k]) */
    const uint32_t *which;
    uint64_t rows_computed;
    /* Interpolated elements (cheap): the direct sources, the patches'
     * indirect irradiance as elements draw it, the patches whose elements
     * get hemi-cubes all the same (contact), the direct rows of the batch
     * being computed and, for a hemi-cube receiver k, its row there. */
    int cheap;
    el_sources src;
    el_interp ip;
    el_contacts contact;
    uint32_t direct_R;
    el_rows drow;
    const uint32_t *drow_of;
    /* Near views (see near_reach): the contact patches' rows F_pj, for the
     * batch being stored its receivers (by k) and the items whose patch
     * cannot stand for their far field (computed again whole), and a
     * scratch row. */
    el_rows far;
    const hc_receiver *recv;
    const uint32_t *far_node; /* per receiver: the element whose row is its far field, or RAD_NONE: the patch's */
    uint8_t *redo;     /* per item of the batch (base + k): 1 to compute again whole */
    uint32_t base;
    uint32_t *mcol;
    float *mval;
    uint64_t near_views, near_redone;
} builder;

/* A contact element's near view reaches this many times its patch's size
 * √A_p: what lies nearer is drawn from the element, the rest taken from
 * the patch's row (near_far). */
#define EL_NEAR_REACH 4.0
/* A near view whose patch sees less than this share of the open part the
 * element sees is computed again whole (near_far). */
#define EL_FAR_SHARE 0.5
/* Whole items of one patch kept as far fields for the batch's others
 * (batch_add). */
#define EL_BATCH_REPS 4

/* The cell of the patch mesh an element lies in. */
static const rad_patch *cell_of(const builder *b, const enode *n)
{
    const rad_mesh *m = b->s->mesh;
    return m->cell_first ? &m->cells[n->cell] : &m->patches[n->cell];
}

/* Is p on an edge of the patch mesh's cell `cell` that lies on its
 * surface's outline (no other cell runs that edge the other way)?  A cell
 * of a planar region need not follow its polygon's edges, so the cell's
 * own edges are tested.  Decides the boundary flag of a new vertex (the
 * renderer extrapolates outline vertices). */
static int on_outline(const builder *b, uint32_t cell, rad_vec3 p)
{
    const rad_mesh *m = b->s->mesh;
    const rad_patch *c = m->cell_first ? &m->cells[cell] : &m->patches[cell];
    const int n = rad_patch_corners(c);
    for (int k = 0; k < n; k++) {
        if (!((b->outline[cell] >> k) & 1u))
            continue;
        rad_vec3 a = m->vertices[c->v[k]], ab = rad_sub(m->vertices[c->v[(k + 1) % n]], a);
        double len2 = rad_dot(ab, ab);
        if (!(len2 > 0.0))
            continue;
        double u = rad_dot(rad_sub(p, a), ab) / len2;
        if (u < -1e-9 || u > 1.0 + 1e-9)
            continue;
        rad_vec3 d = rad_sub(p, rad_add(a, rad_scale(ab, u)));
        if (rad_dot(d, d) <= 1e-18 * len2)
            return 1;
    }
    return 0;
}

/* The vertex at p on surface surf, made when missing; RAD_NONE on OOM.
 * cell: the patch mesh's cell on whose outline it may lie, RAD_NONE when it
 * cannot. */
static uint32_t vertex_at(builder *b, uint32_t surf, rad_vec3 p, uint32_t cell)
{
    uint32_t v = b->nv ? el_vt_find(&b->t, surf, p) : RAD_NONE;
    if (v != RAD_NONE)
        return v;
    if (b->nv == b->cap_v) {
        uint32_t cap = b->cap_v ? 2 * b->cap_v : 1024;
        rad_vec3 *V = realloc(b->V, (size_t)cap * sizeof *V);
        if (V)
            b->V = V;
        uint8_t *Vb = realloc(b->Vb, cap);
        if (Vb)
            b->Vb = Vb;
        uint32_t *Vp = realloc(b->Vsurf, (size_t)cap * sizeof *Vp);
        if (Vp)
            b->Vsurf = Vp;
        if (!V || !Vb || !Vp)
            return RAD_NONE;
        b->cap_v = cap;
        b->t.V = b->V;
        b->t.Vsurf = b->Vsurf;
    }
    v = b->nv++;
    b->V[v] = p;
    b->Vsurf[v] = surf;
    b->Vb[v] = cell != RAD_NONE && on_outline(b, cell, p);
    if (el_vt_insert(&b->t, v) != 0)
        return RAD_NONE;
    return v;
}

static int add_element(builder *b, const uint32_t v[4], uint32_t patch, uint32_t cell,
                       uint32_t level, int state)
{
    if (b->ne == b->cap_e) {
        uint32_t cap = b->cap_e ? 2 * b->cap_e : 1024;
        enode *E = realloc(b->E, (size_t)cap * sizeof *E);
        if (E)
            b->E = E;
        double *B = realloc(b->B, (size_t)cap * b->bands * sizeof *B);
        if (B)
            b->B = B;
        float *h = b->nl ? realloc(b->h, (size_t)cap * b->nl * sizeof *h) : NULL;
        if (h)
            b->h = h;
        if (!E || !B || (b->nl && !h))
            return -1;
        b->cap_e = cap;
    }
    enode *n = &b->E[b->ne];
    memcpy(n->v, v, sizeof n->v);
    n->patch = patch;
    n->cell = cell;
    n->kids = RAD_NONE;
    n->parent = RAD_NONE;
    n->level = (uint8_t)level;
    n->state = (uint8_t)state;
    n->settled = 0;
    n->interp = 0;
    n->cnt = 0;
    n->start = 0;
    memcpy(b->B + (size_t)b->ne * b->bands, b->s->B + (size_t)patch * b->bands,
           b->bands * sizeof *b->B);
    for (uint32_t l = 0; l < b->nl; l++)
        b->h[(size_t)b->ne * b->nl + l] = 0.0f; /* set before a row is gathered (level > 0) */
    b->ne++;
    return 0;
}

/* Makes the four children of leaf e (appended): leaves that replace it
 * (kid_state NODE_LEAF), or probes beside it (NODE_PROBE).  -1 on OOM. */
static int split(builder *b, uint32_t e, int kid_state)
{
    enode n = b->E[e];
    const uint32_t surf = b->Vsurf[n.v[0]];
    uint32_t c[4];
    memcpy(c, n.v, sizeof c);
    int corners = c[3] == RAD_NONE ? 3 : 4;
    uint32_t m[4];
    for (int k = 0; k < corners; k++) {
        uint32_t a = c[k], z = c[(k + 1) % corners];
        /* Only a el_midpoint between two outline vertices can be on the outline. */
        m[k] = vertex_at(b, surf, el_midpoint(b->V[a], b->V[z]),
                         b->Vb[a] && b->Vb[z] ? n.cell : RAD_NONE);
        if (m[k] == RAD_NONE)
            return -1;
    }
    uint32_t kids[4][4];
    if (corners == 4) {
        rad_vec3 mid = rad_scale(rad_add(rad_add(b->V[c[0]], b->V[c[1]]), rad_add(b->V[c[2]], b->V[c[3]])), 0.25);
        uint32_t ctr = vertex_at(b, surf, mid, RAD_NONE);
        if (ctr == RAD_NONE)
            return -1;
        uint32_t q[4][4] = {{c[0], m[0], ctr, m[3]}, {m[0], c[1], m[1], ctr},
                            {ctr, m[1], c[2], m[2]}, {m[3], ctr, m[2], c[3]}};
        memcpy(kids, q, sizeof kids);
    } else {
        uint32_t q[4][4] = {{c[0], m[0], m[2], RAD_NONE}, {m[0], c[1], m[1], RAD_NONE},
                            {m[2], m[1], c[2], RAD_NONE}, {m[0], m[1], m[2], RAD_NONE}};
        memcpy(kids, q, sizeof kids);
    }
    uint32_t first = b->ne;
    for (int k = 0; k < 4; k++) {
        if (add_element(b, kids[k], n.patch, n.cell, n.level + 1u, kid_state) != 0)
            return -1;
        b->E[b->ne - 1].parent = e;
    }
    b->E[e].kids = first;
    if (kid_state == NODE_LEAF)
        b->E[e].state = NODE_SPLIT;
    return 0;
}

/* Leaf e takes its probes as its children. */
static void promote(builder *b, uint32_t e)
{
    enode *n = &b->E[e];
    RAD_ASSERT(n->state == NODE_LEAF && n->kids != RAD_NONE);
    n->state = NODE_SPLIT;
    for (uint32_t k = 0; k < 4; k++)
        b->E[n->kids + k].state = NODE_LEAF;
}

/* Where the centre of child k of a cell stands in the cell, as weights of
 * the cell's corners (split's order): bilinear (u, v) = (¼ or ¾, ¼ or ¾)
 * for a quad, barycentric for a triangle. */
static void child_weights(int corners, uint32_t k, double w[4])
{
    if (corners == 4) {
        static const double uv[4][2] = {{0.25, 0.25}, {0.75, 0.25}, {0.75, 0.75}, {0.25, 0.75}};
        double u = uv[k][0], v = uv[k][1];
        w[0] = (1 - u) * (1 - v);
        w[1] = u * (1 - v);
        w[2] = u * v;
        w[3] = (1 - u) * v;
        return;
    }
    static const double bw[4][3] = {{4 / 6., 1 / 6., 1 / 6.}, {1 / 6., 4 / 6., 1 / 6.},
                                    {1 / 6., 1 / 6., 4 / 6.}, {1 / 3., 1 / 3., 1 / 3.}};
    for (int c = 0; c < 3; c++)
        w[c] = bw[k][c];
    w[3] = 0.0;
}

/* Room for `more` row entries; RAD_OK or out of memory. */
static int reserve_row(builder *b, uint64_t more, rad_error *err)
{
    if (b->nnz + more <= b->cap_r)
        return RAD_OK;
    uint64_t cap = b->cap_r ? b->cap_r : 4096;
    while (cap < b->nnz + more)
        cap *= 2;
    uint32_t *c = realloc(b->col, cap * sizeof *c);
    if (c)
        b->col = c;
    float *v = realloc(b->val, cap * sizeof *v);
    if (v)
        b->val = v;
    if (!c || !v)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory for element rows");
    b->cap_r = cap;
    return RAD_OK;
}

/* Element e's row is the last `count` entries appended: gathers its B
 * (with the interpolated indirect light when it is an interpolated one). */
static void finish_row(builder *b, uint32_t e, uint32_t count, const hc_receiver *at)
{
    enode *n = &b->E[e];
    n->start = b->nnz;
    n->cnt = count;
    b->nnz += count;
    double hd[RAD_MAX_BANDS], ind[RAD_MAX_BANDS];
    el_element_direct(b->s, NULL, b->nl ? b->h + (size_t)e * b->nl : NULL, n->patch, n->level, hd);
    if (n->interp)
        el_interp_at(&b->ip, b->s, n->patch, at->center, ind);
    el_gather_one(b->s, hd, n->interp ? ind : NULL, b->Tr, n->patch, n->level, b->col + n->start,
                  b->val + n->start, count, b->B + (size_t)e * b->bands);
}

/* A whole row (a hemi-cube's, or a near view's made whole) for receiver
 * k of the batch, element which[k].  With direct sources, the row's entries for them are replaced by the
 * direct rows' (strata and item buffers, as an interpolated neighbour
 * gets them: no seam between the two kinds), and should that lift the
 * row's sum above 1 the other entries are scaled down to make it 1. */
static int store_whole(builder *b, uint32_t k, uint32_t count, const uint32_t *col,
                       const float *val, rad_error *err)
{
    const uint32_t e = b->which[k];
    const el_rows *d = b->cheap ? &b->drow : NULL;
    const uint64_t d0 = d ? d->start[b->drow_of[k]] : 0, d1 = d ? d->start[b->drow_of[k] + 1] : 0;
    int rc = reserve_row(b, (uint64_t)count + (d1 - d0), err);
    if (rc != RAD_OK)
        return rc;
    uint32_t *oc = b->col + b->nnz;
    float *ov = b->val + b->nnz;
    uint32_t m = 0;
    double own = 0.0, direct = 0.0;
    for (uint32_t q = 0; q < count; q++) { /* count 0: an element that sees nothing */
        if (d && b->src.direct[col[q]])
            continue;
        oc[m] = col[q];
        ov[m++] = val[q];
        own += val[q];
    }
    if (d && d1 > d0) {
        /* Merge the direct entries into the kept ones, both ascending. */
        uint32_t kept = m, total = kept + (uint32_t)(d1 - d0);
        for (uint64_t q = d0; q < d1; q++)
            direct += d->val[q];
        uint32_t i = kept, w = total;
        uint64_t q = d1;
        while (w > 0) {
            if (q > d0 && (i == 0 || d->col[q - 1] > oc[i - 1])) {
                q--;
                oc[--w] = d->col[q];
                ov[w] = d->val[q];
            } else {
                i--;
                --w;
                oc[w] = oc[i];
                ov[w] = ov[i];
            }
        }
        m = total;
        if (own + direct > 1.0 && own > 0.0) {
            double f = direct < 1.0 ? (1.0 - direct) / own : 0.0;
            for (uint32_t q = 0; q < m; q++)
                if (!b->src.direct[oc[q]])
                    ov[q] = (float)(ov[q] * f);
            uint32_t w2 = 0; /* entries scaled to nothing go */
            for (uint32_t q = 0; q < m; q++)
                if (ov[q] > 0.0f) {
                    oc[w2] = oc[q];
                    ov[w2++] = ov[q];
                }
            m = w2;
        }
    }
    finish_row(b, e, m, NULL);
    return RAD_OK;
}

/* A near view's row (near_reach) made whole with the far field of a row
 * seen from nearby, p's: the element's parent's, or its patch's.  Every j
 * beyond the reach gets
 *   F_ej = s · F_pj,   s = (1 − Σ_near F_ej) / (1 − Σ_{j within reach} F_pj),
 * the share of the hemisphere the near patches leave open at e, handed out
 * as p sees what lies beyond them (its open sky included).  Near a contact
 * the near patches are what changes over less than a patch: the other
 * surface, a block's foot; what lies farther is seen from e much as from
 * p.  Into b->mcol/mval; returns the entry count, or -1 when p sees less
 * than EL_FAR_SHARE of the open share e sees (p's centre under a block
 * that e is beside): then e needs a whole hemi-cube. */
static long near_far(builder *b, uint32_t k, uint32_t count, const uint32_t *col,
                     const float *val)
{
    const rad_mesh *m = b->s->mesh;
    const hc_receiver *r = &b->recv[k];
    const uint32_t *fcol = b->far.col;
    const float *fval = b->far.val;
    uint64_t f0 = b->far.start[r->patch], f1 = b->far.start[r->patch + 1];
    if (b->far_node[k] != RAD_NONE) {
        const enode *pa = &b->E[b->far_node[k]];
        fcol = b->col;
        fval = b->val;
        f0 = pa->start;
        f1 = pa->start + pa->cnt;
    }
    double near = 0.0, within = 0.0;
    for (uint32_t q = 0; q < count; q++)
        near += val[q];
    for (uint64_t t = f0; t < f1; t++)
        if (hc_within_reach(m, fcol[t], r->center, r->reach))
            within += fval[t];
    const double open = fmax(0.0, 1.0 - near), far = 1.0 - within;
    if (open > 0.0 && !(far >= EL_FAR_SHARE * open))
        return -1;
    const double scale = open > 0.0 ? open / far : 0.0;
    long w = 0;
    uint32_t q = 0;
    for (uint64_t t = f0; t < f1; t++) {
        const uint32_t j = fcol[t];
        const float f = (float)(scale * fval[t]);
        if (!(f > 0.0f) || hc_within_reach(m, j, r->center, r->reach))
            continue;
        for (; q < count && col[q] < j; q++) {
            b->mcol[w] = col[q];
            b->mval[w++] = val[q];
        }
        if (q < count && col[q] == j)
            continue; /* drawn as near after all (rounding at the reach): the view's */
        b->mcol[w] = j;
        b->mval[w++] = f;
    }
    for (; q < count; q++) {
        b->mcol[w] = col[q];
        b->mval[w++] = val[q];
    }
    return w;
}

/* A hemi-cube row arrives, whole or a near view's (made whole here, or
 * left for a whole hemi-cube in b->redo). */
static int store_row(void *user, uint32_t k, uint32_t count, const uint32_t *col, const float *val,
                     rad_error *err)
{
    builder *b = user;
    if (b->recv && b->recv[k].reach > 0.0) {
        const long m = near_far(b, k, count, col, val);
        if (m < 0) {
            b->redo[b->base + k] = 1;
            return RAD_OK;
        }
        return store_whole(b, k, (uint32_t)m, b->mcol, b->mval, err);
    }
    return store_whole(b, k, count, col, val, err);
}

/* Is element e buried: a child that nothing meets, holding its parent's
 * centre (a corner of each quad child, inside a triangle's middle child),
 * of a parent that sees nothing?  Then all of it lies on the buried side of
 * every contact, like that centre. */
static int buried_child(const builder *b, uint32_t e)
{
    const enode *n = &b->E[e];
    if (n->parent == RAD_NONE)
        return 0;
    const enode *p = &b->E[n->parent];
    if (p->v[3] == RAD_NONE && e - p->kids != 3)
        return 0;
    const size_t pb = (size_t)n->patch * b->bands;
    return p->level == 0 ? el_sees_nothing(b->s, n->patch, 0, 0, 0, b->s->B + pb)
                         : el_sees_nothing(b->s, n->patch, p->level, p->interp, p->cnt,
                                           b->B + (size_t)n->parent * b->bands);
}

/* A buried element's row: none, and B = E (it sees nothing). */
static void store_buried(builder *b, uint32_t e)
{
    enode *n = &b->E[e];
    n->start = b->nnz;
    n->cnt = 0;
    for (uint32_t l = 0; l < b->nl; l++)
        b->h[(size_t)e * b->nl + l] = 0.0f;
    memcpy(b->B + (size_t)e * b->bands, b->s->emission + (size_t)n->patch * b->bands,
           b->bands * sizeof *b->B);
}

/* An interpolated element's row: its direct row, receiver k of the batch. */
static int store_direct(builder *b, uint32_t e, uint32_t k, const hc_receiver *at, rad_error *err)
{
    const uint64_t d0 = b->drow.start[k], d1 = b->drow.start[k + 1];
    int rc = reserve_row(b, d1 - d0, err);
    if (rc != RAD_OK)
        return rc;
    if (d1 > d0) {
        memcpy(b->col + b->nnz, b->drow.col + d0, (size_t)(d1 - d0) * sizeof *b->col);
        memcpy(b->val + b->nnz, b->drow.val + d0, (size_t)(d1 - d0) * sizeof *b->val);
    }
    b->E[e].interp = 1;
    finish_row(b, e, (uint32_t)(d1 - d0), at);
    return RAD_OK;
}

/* Points per side where an element's visibility is sampled when a shadow
 * edge crosses it (issue 39). */
#define EL_VIS_SAMPLES 4u

/* Element n's corners into p; returns their count. */
static int element_corners(const builder *b, const enode *n, rad_vec3 p[4])
{
    const int corners = n->v[3] == RAD_NONE ? 3 : 4;
    for (int c = 0; c < corners; c++)
        p[c] = b->V[n->v[c]];
    return corners;
}

/* Point (s, t) in [0, 1]² of polygon p (a quad bilinearly, a triangle as
 * the square folded onto it: s along 0-1, t towards 2) and its area weight. */
static rad_vec3 element_point(const rad_vec3 *p, int corners, double s, double t, double *w)
{
    if (corners == 4) {
        *w = 1.0;
        return rad_add(rad_scale(rad_add(rad_scale(p[0], 1 - s), rad_scale(p[1], s)), 1 - t),
                       rad_scale(rad_add(rad_scale(p[3], 1 - s), rad_scale(p[2], s)), t));
    }
    *w = 1.0 - t;
    return rad_add(rad_add(rad_scale(p[0], (1 - s) * (1 - t)), rad_scale(p[1], s * (1 - t))),
                   rad_scale(p[2], t));
}

/* Where mixed[k] (some of an element's probe points lit, some not: a shadow
 * edge crosses it or passes within a pixel), replaces vis[k] by the mean
 * over EL_VIS_SAMPLES² points of the element, weighted by the unoccluded
 * irradiance there.  lit[k] and at[k] as in element_lights. */
static int edge_visibility(builder *b, hc_engine *hc, const hc_light *hl, const hc_receiver *lit,
                           const uint32_t *at, const uint8_t *mixed_k, uint32_t m, double *vis,
                           rad_error *err)
{
    const uint32_t S = EL_VIS_SAMPLES * EL_VIS_SAMPLES;
    uint32_t mixed = 0;
    for (uint32_t k = 0; k < m; k++)
        mixed += mixed_k[k];
    if (!mixed)
        return RAD_OK;
    hc_receiver *pt = malloc((size_t)mixed * S * sizeof *pt);
    double *w = malloc((size_t)mixed * S * sizeof *w), *v = malloc((size_t)mixed * S * sizeof *v);
    int rc = pt && w && v ? RAD_OK : rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t k = 0, q = 0; k < m && rc == RAD_OK; k++) {
        if (!mixed_k[k])
            continue;
        rad_vec3 p[4];
        const int corners = element_corners(b, &b->E[at[k]], p);
        const rad_vec3 nx = cell_of(b, &b->E[at[k]])->normal; /* its own cell's plane */
        for (uint32_t a = 0; a < EL_VIS_SAMPLES; a++)
            for (uint32_t c = 0; c < EL_VIS_SAMPLES; c++, q++) {
                double jac;
                pt[q].center = element_point(p, corners, (a + 0.5) / EL_VIS_SAMPLES,
                                             (c + 0.5) / EL_VIS_SAMPLES, &jac);
                pt[q].patch = lit[k].patch;
                w[q] = jac * hc_light_direct(hl, pt[q].center, nx);
            }
    }
    if (rc == RAD_OK)
        rc = hc_light_visibility(hc, hl, b->light_R, pt, mixed * S, v, err);
    for (uint32_t k = 0, q = 0; k < m && rc == RAD_OK; k++) {
        if (!mixed_k[k])
            continue;
        double sw = 0.0, sv = 0.0;
        for (uint32_t t = 0; t < S; t++, q++) {
            sw += w[q];
            sv += w[q] * v[q];
        }
        if (sw > 0.0)
            vis[k] = sv / sw;
    }
    free(pt);
    free(w);
    free(v);
    return rc;
}

/* The visibility of the elements lit[0..m) (at[k] their index): at their
 * centres, and where the centre and EL_PROBES - 1 points of the element
 * (the centres of its quarters, and points 2 % in from its corners, so an
 * edge crossing near a side is seen) disagree, edge_visibility's mean. */
#define EL_PROBES 9u
static int element_visibility(builder *b, hc_engine *hc, const hc_light *hl, const hc_receiver *lit,
                              const uint32_t *at, uint32_t m, double *vis, rad_error *err)
{
    hc_receiver *pt = malloc((size_t)m * EL_PROBES * sizeof *pt);
    double *v = malloc((size_t)m * EL_PROBES * sizeof *v);
    uint8_t *mixed = malloc(m);
    int rc = pt && v && mixed ? RAD_OK : rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t k = 0; k < m && rc == RAD_OK; k++) {
        rad_vec3 p[4];
        const int corners = element_corners(b, &b->E[at[k]], p);
        pt[k * EL_PROBES] = lit[k];
        for (uint32_t q = 1; q < EL_PROBES; q++) {
            static const double at_s[2][2] = {{0.25, 0.75}, {0.02, 0.98}};
            const double *u = at_s[q > 4];
            double jac;
            pt[k * EL_PROBES + q].center =
                element_point(p, corners, u[(q - 1) & 1], u[((q - 1) >> 1) & 1], &jac);
            pt[k * EL_PROBES + q].patch = lit[k].patch;
        }
    }
    if (rc == RAD_OK)
        rc = hc_light_visibility(hc, hl, b->light_R, pt, m * EL_PROBES, v, err);
    for (uint32_t k = 0; k < m && rc == RAD_OK; k++) {
        int some_lit = 0, some_dark = 0;
        for (uint32_t q = 0; q < EL_PROBES; q++) {
            some_lit |= v[k * EL_PROBES + q] > 0.0;
            some_dark |= v[k * EL_PROBES + q] < 1.0;
        }
        vis[k] = v[k * EL_PROBES];
        mixed[k] = (uint8_t)(some_lit && some_dark);
    }
    if (rc == RAD_OK)
        rc = edge_visibility(b, hc, hl, lit, at, mixed, m, vis, err);
    free(pt);
    free(v);
    free(mixed);
    return rc;
}

/* h_le of the elements which[k] (centres r[k]) for every light: the mean
 * unoccluded unit-strength irradiance over the element in closed form
 * (hc_light_polygon / A_e: exact where hc_light_direct at the centre was
 * off by the irradiance's curvature over the element) times its visibility
 * from the light's item buffer, at its centre or, where a shadow edge
 * crosses it, its mean over points of the element (element_visibility).  Only elements that face the light (and reach into a
 * spot's cone) are looked up. */
static int element_lights(builder *b, hc_engine *hc, const hc_receiver *r, const uint32_t *which,
                          uint32_t count, rad_error *err)
{
    const uint32_t nl = b->nl;
    if (!nl || !count)
        return RAD_OK;
    hc_receiver *lit = malloc((size_t)count * sizeof *lit);
    uint32_t *at = malloc((size_t)count * sizeof *at);
    double *direct = malloc((size_t)count * sizeof *direct), *vis = malloc((size_t)count * sizeof *vis);
    int rc = RAD_OK;
    if (!lit || !at || !direct || !vis)
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t l = 0; l < nl && rc == RAD_OK; l++) {
        const hc_light hl = b->lights[l];
        uint32_t m = 0;
        for (uint32_t k = 0; k < count; k++) {
            const enode *n = &b->E[which[k]];
            /* its cell's plane: a curved patch's or a shared patch's
             * cells face their own ways */
            const rad_vec3 nx = cell_of(b, n)->normal;
            rad_vec3 p[4], c;
            double area = 0.0, d = 0.0;
            const int corners = element_corners(b, n, p);
            if (rad_cell_geometry(b->V, n->v, nx, &c, &area) == 0 && area > 0.0)
                d = hc_light_polygon(&hl, p, (uint32_t)corners, nx) / area;
            b->h[(size_t)which[k] * nl + l] = 0.0f;
            if (d > 0.0 && isfinite(d)) {
                lit[m] = r[k];
                at[m] = which[k];
                direct[m++] = d;
            }
        }
        if (!m)
            continue;
        rc = element_visibility(b, hc, &hl, lit, at, m, vis, err);
        for (uint32_t k = 0; k < m && rc == RAD_OK; k++)
            b->h[(size_t)at[k] * nl + l] = (float)(direct[k] * vis[k]);
        b->lights_rendered++;
    }
    free(lit);
    free(at);
    free(direct);
    free(vis);
    return rc;
}

/* Does the segment from c to x cross a polygon that meets element n's
 * patch (el_segment_crosses)? */
static int crosses(const builder *b, const enode *n, rad_vec3 c, rad_vec3 x)
{
    for (uint32_t k = b->contact.start[n->patch]; k < b->contact.start[n->patch + 1]; k++)
        if (el_segment_crosses(b->s->scene, b->contact.poly[k], c, x, b->contact.tol))
            return 1;
    return 0;
}

/* The reach of a near view for element n at c (hc_receiver.reach), or 0
 * for a whole hemi-cube, and in *far_node the element whose row is to be
 * its far field (RAD_NONE: the patch's).  A contact element's hemi-cube
 * drew the whole scene to learn what changes near it; a near view draws
 * only the patches within EL_NEAR_REACH times the patch's size and takes
 * the rest from a row seen from nearby (near_far), a small part of the
 * triangles.  That row is its parent's when the parent has a hemi-cube
 * row of its own (level 2 and finer: a quarter as far away as the patch's
 * centre), else the patch's.  Whole instead: without such a row (no near
 * views asked, an empty row), and where the segment from c to where that
 * row was seen crosses a polygon that meets the patch: a vault springing
 * from a wall, a wall standing on a floor patch, put c in another space. */
static double near_reach(const builder *b, const enode *n, rad_vec3 c, uint32_t *far_node)
{
    const uint32_t p = n->patch;
    const double reach = EL_NEAR_REACH * sqrt(b->s->mesh->patches[p].area);
    *far_node = RAD_NONE;
    if (!b->far.start)
        return 0.0;
    if (n->parent != RAD_NONE) {
        const enode *pa = &b->E[n->parent];
        rad_vec3 pc;
        double area;
        if (pa->level > 0 && !pa->interp && pa->cnt > 0 &&
            rad_cell_geometry(b->V, pa->v, cell_of(b, pa)->normal, &pc, &area) == 0 &&
            !crosses(b, n, c, pc)) {
            *far_node = n->parent;
            return reach;
        }
    }
    if (b->far.start[p + 1] == b->far.start[p])
        return 0.0;
    /* where the patch is: its centre, or on a curved patch (whose centre
     * lies off its surface) the centre of its cell nearest to that */
    rad_vec3 pc = b->s->mesh->patches[p].center;
    if (b->bent[p]) {
        const rad_patch *cells;
        const uint32_t nc = rad_patch_cells(b->s->mesh, p, &cells);
        double best = INFINITY;
        rad_vec3 at = pc;
        for (uint32_t q = 0; q < nc; q++) {
            const rad_vec3 d = rad_sub(cells[q].center, pc);
            if (rad_dot(d, d) < best) {
                best = rad_dot(d, d);
                at = cells[q].center;
            }
        }
        pc = at;
    }
    return crosses(b, n, c, pc) ? 0.0 : reach;
}

/* Does another surface meet element n (el_contact_patches)? */
static int touched(const builder *b, const enode *n)
{
    const rad_patch *pp = cell_of(b, n); /* its plane and polygon */
    const int corners = n->v[3] == RAD_NONE ? 3 : 4;
    for (uint32_t k = b->contact.start[n->patch]; k < b->contact.start[n->patch + 1]; k++)
        if (el_cell_touches(b->s->scene, b->V, n->v, corners, pp->normal, pp->polygon,
                            b->contact.poly[k], b->contact.tol))
            return 1;
    return 0;
}

/* The hemi-cube items of a batch: element w[t] (receiver k[t] of the
 * batch's direct rows) at r[t], its near view's far field f[t]
 * (near_reach); late[t]: a near view whose far field is the whole
 * hemi-cube of a sibling in the same batch (batch_add), computed after it. */
typedef struct batch {
    uint32_t *w, *k, *f;
    hc_receiver *r;
    uint8_t *late;
    uint32_t m;
    uint32_t patch, reps, rep[EL_BATCH_REPS]; /* the last whole items of one patch */
} batch;

static int batch_make(batch *h, uint32_t count)
{
    const size_t n = (size_t)count + 1;
    h->w = malloc(n * sizeof *h->w);
    h->k = malloc(n * sizeof *h->k);
    h->f = malloc(n * sizeof *h->f);
    h->r = malloc(n * sizeof *h->r);
    h->late = malloc(n);
    h->patch = RAD_NONE;
    h->reps = 0;
    return h->w && h->k && h->f && h->r && h->late ? 0 : -1;
}

static void batch_free(batch *h)
{
    free(h->w);
    free(h->k);
    free(h->f);
    free(h->r);
    free(h->late);
}

/* Adds element e (receiver k at *r) to the batch.  An element that needs
 * a whole hemi-cube (near_reach 0: it lies across a polygon that meets
 * its patch from where the patch's row was seen) takes instead a near
 * view whose far field is the row of one of the last EL_BATCH_REPS whole
 * items of its patch, the first with no polygon that meets the patch
 * between them: the elements of a wall patch below a vault's springing
 * cost one whole hemi-cube, not one each. */
static void batch_add(builder *b, batch *h, uint32_t e, uint32_t k, const hc_receiver *r)
{
    const enode *n = &b->E[e];
    const uint32_t t = h->m++;
    h->w[t] = e;
    h->k[t] = k;
    h->r[t] = *r;
    h->f[t] = RAD_NONE;
    h->late[t] = 0;
    h->r[t].reach = b->cheap ? near_reach(b, n, r->center, &h->f[t]) : 0.0;
    if (h->r[t].reach > 0.0 || !b->far.start)
        return;
    if (h->patch != n->patch) {
        h->patch = n->patch;
        h->reps = 0;
    }
    for (uint32_t q = 0; q < h->reps; q++)
        if (!crosses(b, n, r->center, h->r[h->rep[q]].center)) {
            h->f[t] = h->w[h->rep[q]];
            h->r[t].reach = EL_NEAR_REACH * sqrt(b->s->mesh->patches[n->patch].area);
            h->late[t] = 1;
            return;
        }
    if (h->reps == EL_BATCH_REPS)
        memmove(h->rep, h->rep + 1, (EL_BATCH_REPS - 1) * sizeof *h->rep);
    h->rep[h->reps < EL_BATCH_REPS ? h->reps++ : EL_BATCH_REPS - 1] = t;
}

/* Hemi-cube rows of the batch's items [base, base + count) (store_row). */
static int batch_run(builder *b, hc_engine *hc, batch *h, uint32_t base, uint32_t count,
                     rad_error *err)
{
    if (!count)
        return RAD_OK;
    b->which = h->w + base;
    b->drow_of = h->k + base;
    b->recv = h->r + base;
    b->far_node = h->f + base;
    b->base = base;
    for (uint32_t t = base; t < base + count; t++)
        b->near_views += h->r[t].reach > 0.0;
    b->rows_computed += count;
    return hc_compute_points(hc, h->r + base, count, store_row, b, err);
}

/* Rows of the batch's items: the others, then the late ones (their
 * sibling's rows stored by then: one that saw nothing leaves its late
 * siblings whole), then again whole those whose far field could not stand
 * for their own (near_far: b->redo). */
static int batch_rows(builder *b, hc_engine *hc, batch *h, rad_error *err)
{
    const uint32_t m = h->m;
    /* the late items last, each kind in its order */
    batch tmp = {0};
    if (batch_make(&tmp, m) != 0)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    uint32_t early = 0;
    for (uint8_t late = 0; late < 2; late++) {
        for (uint32_t t = 0; t < m; t++)
            if (h->late[t] == late) {
                tmp.w[tmp.m] = h->w[t];
                tmp.k[tmp.m] = h->k[t];
                tmp.f[tmp.m] = h->f[t];
                tmp.r[tmp.m++] = h->r[t];
            }
        if (!late)
            early = tmp.m;
    }
    batch_free(h);
    *h = tmp;
    /* the late flags, no longer needed, mark the items to redo */
    memset(h->late, 0, m);
    b->redo = h->late;
    int rc = batch_run(b, hc, h, 0, early, err);
    for (uint32_t t = early; t < m; t++)
        if (b->E[h->f[t]].cnt == 0) {
            h->r[t].reach = 0.0;
            h->f[t] = RAD_NONE;
        }
    if (rc == RAD_OK)
        rc = batch_run(b, hc, h, early, m - early, err);
    /* in place, in order: the first `again` items become those */
    uint32_t again = 0;
    for (uint32_t k = 0; k < m; k++)
        if (b->redo[k]) {
            h->w[again] = h->w[k];
            h->k[again] = h->k[k];
            h->r[again] = h->r[k];
            h->r[again++].reach = 0.0;
        }
    b->near_redone += again;
    if (rc == RAD_OK)
        rc = batch_run(b, hc, h, 0, again, err);
    b->recv = NULL;
    b->far_node = NULL;
    b->redo = NULL;
    return rc;
}

/* Rows and radiosities of the elements which[0..count). */
static int compute_rows_of(builder *b, hc_engine *hc, const uint32_t *which, uint32_t count,
                           rad_error *err)
{
    if (!count)
        return RAD_OK;
    hc_receiver *r = malloc((size_t)count * sizeof *r);
    rad_vec3 *nr = malloc((size_t)count * sizeof *nr); /* each element's own plane */
    if (!r || !nr) {
        free(r);
        free(nr);
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    for (uint32_t k = 0; k < count; k++) {
        const enode *n = &b->E[which[k]];
        double area;
        nr[k] = cell_of(b, n)->normal;
        if (rad_cell_geometry(b->V, n->v, nr[k], &r[k].center, &area) != 0) {
            free(r);
            free(nr);
            return rad_fail(err, RAD_ERR_INVALID, "elements: element %u has no area", which[k]);
        }
        r[k].patch = n->patch;
        r[k].reach = 0.0;
    }
    /* The lights' and the sources' direct light first: rows gather B_e as
     * they are stored. */
    int rc = element_lights(b, hc, r, which, count, err);
    if (rc == RAD_OK && b->cheap)
        rc = el_direct_rows(&b->src, hc, b->direct_R, r, nr, count, &b->drow,
                            &b->lights_rendered, err);
    free(nr);
    /* Interpolated elements are done; the others (all of them when not
     * cheap, else those on contact patches) get their hemi-cubes. */
    batch h = {0};
    if (rc == RAD_OK && batch_make(&h, count) != 0)
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t k = 0; k < count && rc == RAD_OK; k++) {
        if (b->cheap && !touched(b, &b->E[which[k]])) {
            if (buried_child(b, which[k]))
                store_buried(b, which[k]);
            else
                rc = store_direct(b, which[k], k, &r[k], err);
            continue;
        }
        batch_add(b, &h, which[k], k, &r[k]);
    }
    if (rc == RAD_OK)
        rc = batch_rows(b, hc, &h, err);
    batch_free(&h);
    el_rows_free(&b->drow);
    free(r);
    return rc;
}

/* Rows of the elements [first, b->ne), made by the last splits (uniform:
 * only the leaves below level 0). */
static int compute_from(builder *b, hc_engine *hc, uint32_t first, int leaves_only, rad_error *err)
{
    uint32_t *which = malloc(((size_t)b->ne - first + 1) * sizeof *which), count = 0;
    if (!which)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t e = first; e < b->ne; e++)
        if (!leaves_only || (b->E[e].state == NODE_LEAF && b->E[e].level > 0))
            which[count++] = e;
    int rc = compute_rows_of(b, hc, which, count, err);
    free(which);
    return rc;
}

/* Longest edge of element n. */
static double longest_edge(const builder *b, const enode *n)
{
    int corners = n->v[3] == RAD_NONE ? 3 : 4;
    double l = 0.0;
    for (int k = 0; k < corners; k++)
        l = fmax(l, rad_length(rad_sub(b->V[n->v[(k + 1) % corners]], b->V[n->v[k]])));
    return l;
}

/* Is n a level-0 element, one cell, of a patch whose cells bend
 * (hc_row_cubes)?  Such a cell, left whole, would show its patch's B, the
 * mean over cells that face up to 60° apart: where the light falls off
 * across the patch the bright cells kept the mean while the dark ones,
 * probed and split, went below it (test_room's sphere: its elements'
 * direct light 1.9 % under its patches').  It may split whatever its
 * size, and its probes, gathered already, become its leaves whatever the
 * estimate. */
static int bent_cell(const builder *b, const enode *n)
{
    return n->level == 0 && b->bent[n->patch];
}

/* b->bent for every patch: grouping a patch's cells by normal costs a pass
 * over them, so it is done once here, not at each may_split. */
static int find_bent(builder *b, rad_error *err)
{
    const rad_mesh *pm = b->s->mesh;
    b->bent = calloc((size_t)pm->patch_count + 1, 1);
    if (!b->bent)
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    for (uint32_t i = 0; pm->cell_first && i < pm->patch_count; i++)
        b->bent[i] = pm->cell_first[i + 1] - pm->cell_first[i] > 1 && hc_row_cubes(pm, i) > 1;
    return RAD_OK;
}

/* May leaf n split: a reflecting patch (a black one's B is its emission
 * whatever it receives), children not below the size floor. */
static int may_split(const builder *b, const enode *n, const double *min_edge)
{
    if (n->state != NODE_LEAF || n->level >= RAD_MAX_ELEMENT_LEVEL)
        return 0;
    int reflects = 0;
    for (uint32_t c = 0; c < b->bands; c++)
        reflects |= b->s->rho[(size_t)n->patch * b->bands + c] > 0.0;
    return reflects && (!min_edge || bent_cell(b, n) ||
                        0.5 * longest_edge(b, n) >= min_edge[n->patch] * (1.0 - 1e-9));
}

/* What rad_element_store_complete fills in (each element's cell: its
 * polygon and normal; its centre and area), for a borrowed set made at
 * every round of refinement: the builder knows each element's cell, where
 * the store finds it again as the patch's cell nearest to the element (a
 * search over the cells of a curved patch, for every leaf, every round:
 * a third of the refinement's time in the main process on the atrium).
 * Not checked (rad_element_store_check): the check finds an element's
 * cell again by that search, which may pick a neighbour of the cell an
 * element on a seam of a curved patch lies in; the set refinement ends
 * with is made by rad_element_store_complete and checked. */
static int borrowed_cells(const builder *b, rad_elements *el, const uint32_t *of, rad_error *err)
{
    for (uint32_t k = 0; k < el->mesh->patch_count; k++) {
        const enode *n = &b->E[of[k]];
        if (rad_element_place(el, k, cell_of(b, n), &b->s->mesh->patches[n->patch]) != 0)
            return rad_fail(err, RAD_ERR_INVALID, "elements: element %u has no area", of[k]);
    }
    return RAD_OK;
}

/* Frees a rad_elements of leaves_to_elements (below) made with `borrow`:
 * borrowed rows stay the builder's. */
static void drop_elements(rad_elements *el, int borrow)
{
    if (el && borrow) {
        el->col = NULL;
        el->val = NULL;
    }
    rad_element_store_destroy(el);
}

/* The builder's leaves as a rad_elements, with their rows and only the
 * vertices they use (a probe that was not kept leaves vertices no leaf
 * uses); node_of[k] = the node of element k when node_of is not NULL.
 * borrow: the rows are not copied but point into the builder's (every
 * probe's included), for a rad_elements that lives only while the builder
 * does and is freed with drop_elements; a copy would add the leaves' rows
 * to the memory at every round of refinement (8k patches: the solve's
 * peak 212 -> 205 MiB, report/store.md). */
static int leaves_to_elements(const builder *b, int borrow, rad_elements **out,
                              uint32_t **node_of, rad_error *err)
{
    *out = NULL;
    uint32_t leaves = 0, used = 0;
    uint64_t entries = 0;
    uint32_t *remap = malloc(((size_t)b->nv + 1) * sizeof *remap);
    uint32_t *of = malloc(((size_t)b->ne + 1) * sizeof *of);
    if (!remap || !of) {
        free(remap);
        free(of);
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    for (uint32_t v = 0; v < b->nv; v++)
        remap[v] = RAD_NONE;
    for (uint32_t e = 0; e < b->ne; e++) {
        const enode *n = &b->E[e];
        if (n->state != NODE_LEAF)
            continue;
        of[leaves++] = e;
        entries += n->cnt;
        for (int k = 0; k < 4 && n->v[k] != RAD_NONE; k++)
            if (remap[n->v[k]] == RAD_NONE)
                remap[n->v[k]] = used++;
    }
    rad_elements *el = rad_element_store_alloc(used, leaves, b->bands, borrow ? 0 : entries);
    if (el && borrow) {
        free(el->col);
        free(el->val);
        el->col = b->col;
        el->val = b->val;
        el->nnz = el->capacity = b->nnz;
    }
    if (el && b->nl) {
        el->light_count = b->nl;
        el->light_h = malloc((size_t)(leaves ? leaves : 1) * b->nl * sizeof *el->light_h);
        if (!el->light_h) {
            drop_elements(el, borrow);
            el = NULL;
        }
    }
    if (el && b->cheap) {
        const uint32_t np = b->s->mesh->patch_count;
        el->interp = malloc(leaves ? leaves : 1);
        el->direct = malloc(np ? np : 1);
        if (!el->interp || !el->direct) {
            drop_elements(el, borrow);
            el = NULL;
        } else {
            memcpy(el->direct, b->src.direct, np);
        }
    }
    if (!el) {
        free(remap);
        free(of);
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    for (uint32_t v = 0; v < b->nv; v++)
        if (remap[v] != RAD_NONE) {
            el->mesh->vertices[remap[v]] = b->V[v];
            el->mesh->vertex_boundary[remap[v]] = b->Vb[v];
        }
    for (uint32_t k = 0; k < leaves; k++) {
        const enode *n = &b->E[of[k]];
        for (int c = 0; c < 4; c++)
            el->mesh->patches[k].v[c] = n->v[c] == RAD_NONE ? RAD_NONE : remap[n->v[c]];
        el->patch[k] = n->patch;
        el->level[k] = n->level;
        el->row_count[k] = n->cnt;
        if (borrow) {
            el->row_start[k] = n->start;
        } else {
            el->row_start[k] = el->nnz;
            if (n->cnt) {
                memcpy(el->col + el->nnz, b->col + n->start, (size_t)n->cnt * sizeof *el->col);
                memcpy(el->val + el->nnz, b->val + n->start, (size_t)n->cnt * sizeof *el->val);
            }
            el->nnz += n->cnt;
        }
        memcpy(el->B + (size_t)k * b->bands, b->B + (size_t)of[k] * b->bands,
               b->bands * sizeof *el->B);
        if (b->nl)
            memcpy(el->light_h + (size_t)k * b->nl, b->h + (size_t)of[k] * b->nl,
                   b->nl * sizeof *b->h);
        if (el->interp)
            el->interp[k] = n->interp;
    }
    free(remap);
    int rc = borrow ? borrowed_cells(b, el, of, err)
                    : rad_element_store_complete(el, b->s, "elements", err);
    if (rc != RAD_OK) {
        drop_elements(el, borrow);
        free(of);
        return rc;
    }
    *out = el;
    if (node_of)
        *node_of = of;
    else
        free(of);
    return RAD_OK;
}

/* The share of a leaf across a block's foot counted as missing its B (see
 * estimate), chosen on bench_elements: 1/4 and 1/12 spent elements along
 * the blocks' feet that the rest of the floor needed more (ratios up to
 * 0.08 and 0.03 worse at T >= 1e-4); 1/32 is within 0.01 of no rule at
 * T >= 1e-4 and better at T <= 3e-5. */
#define CONTACT_SHARE (1.0 / 32.0)

/* The estimated error of each probed leaf (eps[node], 0 for the others):
 * the mean difference, over its four probes, between the probe's gathered
 * B and what the renderer draws there from the current leaves, relative to
 * scale[] (the largest band), times the leaf's share of its patch's area.
 * That is the leaf's share of the integrated error |drawn − B|: splitting
 * the leaves of largest share first is what lowers the mean error most per
 * element added, and a linear gradient, which the renderer's interpolation
 * draws exactly, costs nothing.  contact[node] marks a leaf at the foot of
 * a block: 1 across it (below), 2 seen but touching a buried leaf. */
static int estimate(builder *b, const double *scale, double *eps, uint8_t *contact, rad_error *err)
{
    const uint32_t bands = b->bands;
    rad_elements *el = NULL;
    rad_mesh *rm = NULL;
    uint32_t *node_of = NULL, *cells_of = NULL;
    double *vB = NULL, *drawn = NULL;
    uint8_t *buried_leaf = NULL, *vertex_side = NULL;
    int rc = leaves_to_elements(b, 1, &el, &node_of, err);
    if (rc != RAD_OK)
        return rc;
    rc = el_fan_mesh(el->mesh, &rm, &cells_of, err);
    if (rc != RAD_OK)
        goto done;
    vB = malloc(((size_t)rm->vertex_count * bands + 1) * sizeof *vB);
    drawn = malloc(((size_t)el->mesh->patch_count * bands + 1) * sizeof *drawn);
    if (!vB || !drawn) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
        goto done;
    }
    rc = rad_elements_vertex_radiosity(b->s, el, rm, cells_of, drawn, vB, err);
    if (rc != RAD_OK)
        goto done;
    /* Buried leaves; per drawing vertex, bit 0: a seen leaf's cells use it,
     * bit 1: a buried leaf's. */
    const uint32_t nel = el->mesh->patch_count;
    buried_leaf = calloc(nel ? nel : 1, 1);
    vertex_side = calloc(rm->vertex_count ? rm->vertex_count : 1, 1);
    if (!buried_leaf || !vertex_side) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
        goto done;
    }
    for (uint32_t e = 0; e < nel; e++)
        buried_leaf[e] = (uint8_t)el_sees_nothing(b->s, el->patch[e], el->level[e],
                                                  el->interp ? el->interp[e] : 0, el->row_count[e],
                                               el->B + (size_t)e * bands);
    for (uint32_t k = 0; k < rm->patch_count; k++)
        for (int c = 0; c < rad_patch_corners(&rm->patches[k]); c++)
            vertex_side[rm->patches[k].v[c]] |= (uint8_t)(buried_leaf[cells_of[k]] ? 2 : 1);
    for (uint32_t e = 0; e < b->ne; e++) {
        eps[e] = 0.0;
        contact[e] = 0;
    }
    for (uint32_t first = 0, next; first < rm->patch_count; first = next) {
        uint32_t k = cells_of[first];
        for (next = first + 1; next < rm->patch_count && cells_of[next] == k;)
            next++;
        const enode *n = &b->E[node_of[k]];
        if (n->kids == RAD_NONE)
            continue;
        const rad_patch *ec = &el->mesh->patches[k];
        int corners = rad_patch_corners(ec);
        double d[RAD_MAX_BANDS] = {0}, seen_B[RAD_MAX_BANDS] = {0};
        uint32_t seen = 0, buried = buried_leaf[k];
        /* touches: a vertex of the other kind (seen for a buried leaf,
         * buried for a seen one) */
        int touches = 0;
        for (uint32_t f = first; f < next && !touches; f++)
            for (int c = 0; c < rad_patch_corners(&rm->patches[f]); c++)
                touches |= (vertex_side[rm->patches[f].v[c]] >> (buried ? 0 : 1)) & 1;
        for (uint32_t q = 0; q < 4; q++) {
            const enode *kid = &b->E[n->kids + q];
            const double *Bk = b->B + (size_t)(n->kids + q) * bands;
            /* A probe that sees nothing is never seen either: its error
             * costs nothing. */
            if (el_sees_nothing(b->s, kid->patch, kid->level, kid->interp, kid->cnt, Bk)) {
                buried++;
                continue;
            }
            seen++;
            for (uint32_t c = 0; c < bands; c++)
                seen_B[c] += Bk[c];
            double w[4], at[RAD_MAX_BANDS];
            child_weights(corners, q, w);
            rad_vec3 p = rad_v3(0, 0, 0);
            for (int c = 0; c < corners; c++)
                p = rad_add(p, rad_scale(el->mesh->vertices[ec->v[c]], w[c]));
            el_drawn_at(rm, vB, bands, first, next - first, ec->normal, p, at);
            for (uint32_t c = 0; c < bands; c++)
                d[c] += 0.25 * fabs(Bk[c] - at[c]);
        }
        /* A leaf across the foot of a block - seen, with buried probes, or
         * buried itself (with buried probes) beside a seen leaf - draws its
         * seen part from values that belong to neither side of the contact
         * line, and no probe may land in that part: count CONTACT_SHARE of
         * the leaf as missing its B entirely (the seen probes' B, or what is
         * drawn for the buried leaf, extrapolated from its seen
         * neighbours).  Without this, a sliver of floor beside a block,
         * inside a patch whose centre and probes lie under the block, kept
         * the patch's wrong value: the largest single error of the adaptive
         * sets in bench_elements. */
        contact[node_of[k]] = (seen && buried) || (!seen && touches) ? 1 : touches ? 2 : 0;
        for (uint32_t c = 0; c < bands && contact[node_of[k]] == 1; c++)
            d[c] = fmax(d[c], CONTACT_SHARE * (seen ? seen_B[c] / seen : drawn[(size_t)k * bands + c]));
        double worst = 0.0;
        for (uint32_t c = 0; c < bands; c++)
            if (scale[c] > 0.0)
                worst = fmax(worst, d[c] / scale[c]);
        eps[node_of[k]] = worst * ec->area / b->s->mesh->patches[n->patch].area;
    }
done:
    drop_elements(el, 1);
    rad_mesh_destroy(rm);
    free(drawn);
    free(buried_leaf);
    free(vertex_side);
    free(node_of);
    free(cells_of);
    free(vB);
    return rc;
}

static int too_many(const builder *b, const rad_refine_options *opt, uint64_t adding, rad_error *err)
{
    uint64_t after = (uint64_t)b->ne + adding;
    uint32_t limit = opt->max_elements ? opt->max_elements : RAD_MESH_DEFAULT_MAX_PATCHES;
    if (after <= limit)
        return RAD_OK;
    return rad_fail(err, RAD_ERR_LIMIT,
                    "elements: refinement would make %llu elements, above the limit of %u "
                    "(raise --min-element-size or --refine-threshold)",
                    (unsigned long long)after, limit);
}

/* Uniform levels: every leaf that may split does, opt->levels
 * times; only the final leaves get hemi-cubes. */
static int refine_uniform(builder *b, const rad_refine_options *opt, hc_engine *hc, rad_error *err)
{
    for (uint32_t level = 0; level < opt->levels; level++) {
        uint32_t ne = b->ne, marked = 0;
        for (uint32_t e = 0; e < ne; e++)
            marked += may_split(b, &b->E[e], NULL) && b->E[e].level == level;
        int rc = too_many(b, opt, 4ull * marked, err);
        if (rc != RAD_OK)
            return rc;
        for (uint32_t e = 0; e < ne; e++)
            if (may_split(b, &b->E[e], NULL) && b->E[e].level == level &&
                split(b, e, NODE_LEAF) != 0)
                return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    return compute_from(b, hc, 0, 1, err);
}

/* A leaf to probe: it may split, has no probes yet and is not settled. */
static int wants_probe(const builder *b, const enode *n, const double *min_edge)
{
    return n->kids == RAD_NONE && !n->settled && may_split(b, n, min_edge);
}

/* Adaptive: probe every leaf that may split (gather its four children),
 * estimate each probed leaf's error from its probes (estimate), split those
 * above the threshold - their probes become leaves, to be probed in turn -
 * and again until no leaf splits.  Splitting changes what is drawn next to
 * it, so every probed leaf is estimated again each pass.
 *
 * A child's share of the error is at most about a quarter of its parent's
 * whenever the error density does not grow at the finer scale (a sixteenth
 * for a smooth field, a quarter at a step): the children of a leaf that
 * split with an estimate of at most 4 T cannot reach T, and are not probed
 * (settled).  On the Cornell box that saves half the hemi-cubes for a few
 * per cent of error. */
static int refine_adaptive(builder *b, const rad_refine_options *opt, const double *scale,
                           const double *min_edge, hc_engine *hc, rad_error *err)
{
    const double T = opt->threshold;
    double *eps = NULL;
    uint8_t *contact = NULL;
    int rc = RAD_OK;
    for (;;) {
        uint32_t ne = b->ne, probing = 0;
        for (uint32_t e = 0; e < ne; e++)
            probing += wants_probe(b, &b->E[e], min_edge);
        if ((rc = too_many(b, opt, 4ull * probing, err)) != RAD_OK)
            break;
        for (uint32_t e = 0; e < ne; e++)
            if (wants_probe(b, &b->E[e], min_edge) && split(b, e, NODE_PROBE) != 0) {
                rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
                goto done;
            }
        if ((rc = compute_from(b, hc, ne, 0, err)) != RAD_OK)
            break;
        free(eps);
        free(contact);
        eps = malloc(((size_t)b->ne + 1) * sizeof *eps);
        contact = malloc((size_t)b->ne + 1);
        if (!eps || !contact) {
            rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
            break;
        }
        if ((rc = estimate(b, scale, eps, contact, err)) != RAD_OK)
            break;
        uint32_t splits = 0;
        for (uint32_t e = 0; e < b->ne; e++) {
            enode *n = &b->E[e];
            if (n->state != NODE_LEAF || n->kids == RAD_NONE || !(eps[e] > T || bent_cell(b, n)))
                continue;
            promote(b, e);
            /* Across or beside a contact line the error is a line's, and
             * may sit in a child that no probe of the leaf saw: no child
             * is settled. */
            for (uint32_t k = 0; k < 4; k++)
                b->E[n->kids + k].settled = eps[e] <= 4.0 * T && !contact[e];
            splits++;
        }
        if (!splits)
            break;
    }
done:
    free(eps);
    free(contact);
    return rc;
}

/* b->outline: per cell of the patch mesh (its patches when it has no cell
 * layer), bit k set when the cell's edge k lies on its surface's outline:
 * no other cell runs the same two mesh vertices the other way (cells of a
 * clustered surface or a planar region share their vertices; a polygon
 * meshed alone shares its own).  -1 on OOM. */
static int outline_masks(builder *b)
{
    const rad_mesh *m = b->s->mesh;
    const uint32_t nc = m->cell_first ? m->cell_count : m->patch_count;
    const rad_patch *cells = m->cell_first ? m->cells : m->patches;
    b->outline = malloc((size_t)nc + 1);
    if (!b->outline)
        return -1;
    memset(b->outline, 0xff, (size_t)nc + 1);
    size_t cap = 16;
    while (cap < 8 * (size_t)nc + 2)
        cap *= 2;
    uint64_t *key = malloc(cap * sizeof *key);
    if (!key)
        return -1;
    for (size_t h = 0; h < cap; h++)
        key[h] = UINT64_MAX;
    /* pass 0 enters every directed edge, pass 1 looks for each one's reverse */
    for (int pass = 0; pass < 2; pass++)
        for (uint32_t c = 0; c < nc; c++) {
            const rad_patch *cell = &cells[c];
            const int n = rad_patch_corners(cell);
            for (int k = 0; k < n; k++) {
                uint64_t a = cell->v[k], z = cell->v[(k + 1) % n];
                uint64_t want = pass ? z << 32 | a : a << 32 | z;
                size_t h = (size_t)((want * 0x9E3779B97F4A7C15ull) >> 20) & (cap - 1);
                while (key[h] != UINT64_MAX && key[h] != want)
                    h = (h + 1) & (cap - 1);
                if (!pass)
                    key[h] = want;
                else if (key[h] == want)
                    b->outline[c] &= (uint8_t)~(1u << k);
            }
        }
    free(key);
    return 0;
}

/* Interpolated elements (refine_adaptive without element hemi-cubes): the
 * direct sources into b->src, and unless they need more item buffers than
 * hemi-cubes would cost (b->cheap), the patches' indirect field as
 * elements draw it (b->ip) and the patches in contact (b->contact). */
static int prepare_interpolation(builder *b, const rad_refine_options *opt, rad_error *err)
{
    const rad_solution *s = b->s;
    const uint32_t np = s->mesh->patch_count, bands = b->bands;
    double *Hi = NULL;
    int rc = el_sources_make(s, &b->src, err);
    if (rc != RAD_OK)
        return rc;
    b->cheap = b->src.count <= EL_MAX_STRATA;
    b->direct_R = opt->light_resolution ? opt->light_resolution : EL_DIRECT_RESOLUTION;
    if (b->cheap) {
        Hi = malloc(((size_t)np * bands + 1) * sizeof *Hi);
        if (!Hi)
            rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    if (b->cheap && rc == RAD_OK) {
        el_patch_indirect(s, b->src.direct, Hi);
        rc = el_interp_make(s, Hi, &b->ip, err);
    }
    free(Hi);
    if (b->cheap && rc == RAD_OK)
        rc = el_contact_patches(s, &b->contact, err);
    if (b->cheap && rc == RAD_OK && !opt->whole_contacts) {
        rc = el_contact_rows(s, &b->contact, &b->far, err);
        b->mcol = malloc((2 * (size_t)np + 1) * sizeof *b->mcol);
        b->mval = malloc((2 * (size_t)np + 1) * sizeof *b->mval);
        if (rc == RAD_OK && (!b->mcol || !b->mval))
            rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    return rc;
}

/* Level 0: one element per cell of each patch (the patch itself unless it
 * is a cluster), on the mesh's own corners: the cells of a surface share
 * vertices as its patches do.  Each patch's smallest element edge into
 * min_edge. */
static int level_zero(builder *b, const rad_refine_options *opt, double *min_edge,
                      rad_error *err)
{
    const rad_mesh *pm = b->s->mesh;
    uint32_t *label = malloc(((size_t)pm->vertex_count + 1) * sizeof *label);
    if (!label || outline_masks(b) != 0) {
        free(label);
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    el_vertex_surfaces(pm, label);
    int rc = RAD_OK;
    for (uint32_t i = 0; i < pm->patch_count && rc == RAD_OK; i++) {
        const rad_patch *cells;
        const uint32_t count = rad_patch_cells(pm, i, &cells);
        double own = 0.0;
        for (uint32_t q = 0; q < count && rc == RAD_OK; q++) {
            const rad_patch *p = &cells[q];
            const uint32_t cell = (uint32_t)(p - (pm->cell_first ? pm->cells : pm->patches));
            uint32_t v[4] = {RAD_NONE, RAD_NONE, RAD_NONE, RAD_NONE};
            for (int k = 0; k < rad_patch_corners(p) && rc == RAD_OK; k++) {
                v[k] = vertex_at(b, label[p->v[k]], pm->vertices[p->v[k]], RAD_NONE);
                if (v[k] == RAD_NONE)
                    rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
                else
                    b->Vb[v[k]] = pm->vertex_boundary[p->v[k]];
            }
            if (rc == RAD_OK && add_element(b, v, i, cell, 0, NODE_LEAF) != 0)
                rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
            if (rc == RAD_OK)
                own = count == 1 ? longest_edge(b, &b->E[b->ne - 1]) : sqrt(pm->patches[i].area);
        }
        /* Default floor: three splits below the patch (1/8 of its size; a
         * cluster's size is the side of a square of its area). */
        min_edge[i] = opt->min_element_size > 0.0 ? opt->min_element_size : own / 8.0;
    }
    free(label);
    return rc;
}

/* The cells of a shared patch of small parts are the parts' own faces: each
 * level-0 element of one is split at once, and its children (settled: not
 * probed further) get rows as any element does - their own direct light
 * and, when interpolated, the patch's indirect light - so that each part
 * shows its own B, lit or in shadow, without a hemi-cube of its own (unless
 * another surface touches it).  Adaptive: their rows now; uniform: with the
 * other leaves'. */
static int split_parts(builder *b, hc_engine *hc, int uniform, rad_error *err)
{
    const rad_mesh *pm = b->s->mesh;
    const uint32_t ne = b->ne;
    uint8_t *shared = malloc((size_t)pm->patch_count + 1);
    if (!shared || rad_mesh_shared_parts(pm, shared) != RAD_OK) {
        free(shared);
        return rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
    }
    int rc = RAD_OK;
    for (uint32_t e = 0; e < ne && rc == RAD_OK; e++) {
        if (!shared[b->E[e].patch] || !may_split(b, &b->E[e], NULL))
            continue;
        if (split(b, e, NODE_LEAF) != 0)
            rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
        for (uint32_t k = 0; k < 4 && rc == RAD_OK; k++)
            b->E[b->E[e].kids + k].settled = 1;
    }
    free(shared);
    if (rc == RAD_OK && !uniform && b->ne > ne)
        rc = compute_from(b, hc, ne, 0, err);
    return rc;
}

int rad_elements_refine(rad_solution *s, hc_engine *hc, const rad_refine_options *options,
                        rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_elements_refine: no solution");
    rad_refine_options opt = {0};
    if (options)
        opt = *options;
    if (!isfinite(opt.threshold) ||
        !(opt.min_element_size >= 0.0) || !isfinite(opt.min_element_size) ||
        opt.levels > RAD_MAX_ELEMENT_LEVEL)
        return rad_fail(err, RAD_ERR_USAGE,
                        "refine: threshold must be finite, minimum element size finite and >= 0, "
                        "levels at most %u", RAD_MAX_ELEMENT_LEVEL);
    if (s->scene->light_count && (!opt.lights || !opt.light_resolution))
        return rad_fail(err, RAD_ERR_USAGE, "rad_elements_refine: the scene's lights are missing");
    rad_element_store_destroy(s->elements);
    s->elements = NULL;
    if (opt.threshold == 0.0)
        opt.threshold = RAD_DEFAULT_REFINE_THRESHOLD;
    if (opt.levels)
        opt.threshold = RAD_REFINE_OFF;
    if (!(opt.threshold > 0.0) && opt.levels == 0)
        return RAD_OK;
    if (!hc)
        return rad_fail(err, RAD_ERR_USAGE, "rad_elements_refine: no hemi-cube engine");

    const rad_mesh *pm = s->mesh;
    const uint32_t np = pm->patch_count, bands = s->band_count;
    const int uniform = opt.levels && !(opt.threshold > 0.0);
    builder b = {.s = s, .bands = bands, .nl = s->scene->light_count,
                 .light_R = opt.light_resolution, .lights = opt.lights};
    double *Tr = NULL, *min_edge = NULL;
    int rc = el_transmitted(s, &Tr, err);
    if (rc != RAD_OK)
        return rc;
    b.Tr = Tr;
    if (!uniform && !opt.element_hemicubes && (rc = prepare_interpolation(&b, &opt, err)))
        goto done;
    if (opt.entries_read)
        opt.entries_read(opt.entries_read_user);
    min_edge = malloc((np ? np : 1) * sizeof *min_edge);
    if (!min_edge) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "elements: out of memory");
        goto done;
    }
    if ((rc = find_bent(&b, err)) != RAD_OK || (rc = level_zero(&b, &opt, min_edge, err)) != RAD_OK ||
        (rc = split_parts(&b, hc, uniform, err)) != RAD_OK)
        goto done;
    /* Errors are relative to the brightest reflecting (non-emitting) patch
     * per band: emitters would make any threshold meaningless. */
    double scale[RAD_MAX_BANDS] = {0};
    for (uint32_t i = 0; i < np; i++)
        for (uint32_t c = 0; c < bands; c++)
            if (s->emission[(size_t)i * bands + c] == 0.0)
                scale[c] = fmax(scale[c], s->B[(size_t)i * bands + c]);
    rc = uniform ? refine_uniform(&b, &opt, hc, err)
                 : refine_adaptive(&b, &opt, scale, min_edge, hc, err);
    if (rc == RAD_OK) {
        rad_elements *el = NULL;
        rc = leaves_to_elements(&b, 0, &el, NULL, err);
        if (rc == RAD_OK) {
            el->threshold = opt.threshold > 0.0 ? opt.threshold : 0.0;
            el->min_size = opt.min_element_size;
            el->rows_computed = b.rows_computed;
            el->near_views = b.near_views;
            s->elements = el;
            s->lights_computed += b.lights_rendered;
        }
    }
done:
    el_sources_free(&b.src);
    el_interp_free(&b.ip);
    el_contacts_free(&b.contact);
    el_rows_free(&b.far);
    free(b.mcol);
    free(b.mval);
    free(min_edge);
    free(Tr);
    free(b.h);
    free(b.V);
    free(b.Vb);
    free(b.Vsurf);
    free(b.outline);
    free(b.bent);
    free(b.t.slot);
    free(b.E);
    free(b.B);
    free(b.col);
    free(b.val);
    return rc;
}
