/* progressive.c - the progressive method of solver.h: shooting from the
 * patch with the most unshot power (Cohen, Chen, Wallace & Greenberg 1988),
 * rows computed in batches as it goes, within a memory budget.
 *
 * Same answer as the gathering methods.  Shooting needs column i of F (what
 * each receiver j gathers from i, F_ji) while the hemi-cube computes row i
 * (F_ij); reciprocity, F_ji = F_ij A_i / A_j, holds for hemi-cube rows only
 * to a few per cent, so shooting with it alone converges to another system
 * than Gauss-Seidel's (about 1 % in the Cornell box's object means).  Here
 * every shot is a gather first: the shooter i takes its exact Gauss-Seidel
 * update from its own rows,
 *     B_i <- E_i + ρ_i Σ_j F_ij B_j (+ τ_i Σ_j F_twin(i),j B_j),
 * and shoots only the change δ_i it made.  B then moves by Gauss-Seidel
 * steps in the order the shots choose - monotonely up from 0 towards the
 * solution, never past it - so it converges to exactly the system the
 * gathering methods solve, whatever the columns used to shoot.  The columns
 * only estimate who must shoot next: the unshot radiosity R_j is the
 * residual E_j + ρ_j (F B)_j - B_j as the shots since j's last gather
 * estimate it.  Its error is the columns' error times what arrived since
 * (a few per cent of R_j, which the stop keeps small), and a gather makes
 * it exact again (R_i = 0).  Gortler, Cohen & Slusallek (1993) analyse
 * progressive refinement as Southwell iteration; this is its Gauss-Seidel
 * form with estimated residuals.  What the previews show is B + R, the
 * classical progressive estimate (B + R = E + ρ F B when the columns are
 * exact).  The answer handed back is one Gauss-Seidel sweep over the rows
 * present from B + R: it removes what the estimates put where the rows say
 * nothing arrives (a patch buried under a block sees nothing and keeps B =
 * E exactly, whatever reciprocity from its neighbours' rows claimed), and
 * costs one pass over the rows, a fraction of one shot per patch.
 *
 * The columns: when every row the solve needs is present (a relight, a
 * stored solution) F_ji comes from j's own row through a transposed copy,
 * and the estimates are exact; otherwise an emitter's first shot uses
 * need_column's exact factors (the point-to-polygon factor from each
 * receiver's centre times its visibility: what the gathering rows compute
 * for emitters, as Wallace, Elmquist & Haines 1989 shoot from a source to
 * receiver vertices), and everything else reciprocity from row i.
 *
 * Stopping: when the unshot power Σ A_j R_j is below the tolerance times
 * the emitted power (every band) and every patch that gathers has gathered
 * at least once (the last few, whose power is tiny, in index order): so the
 * rows computed are exactly those Gauss-Seidel computes, and the residual
 * is measured over all of them.
 *
 * Rows: fetched in batches (need_rows) - the shooter's and the next
 * shooters' by unshot power - so that the caller can spread them over its
 * workers.  Under max_matrix_bytes, rows of the patches least likely to
 * shoot soon (least unshot power) are dropped to make room, a quarter of
 * the budget at a time (one compaction of the pool per quarter), and
 * computed again if they shoot again.
 *
 * Previews: the ambient term below gives a first estimate of what the
 * unshot power will add; a preview then improves it by SV_PREVIEW_SWEEPS
 * Gauss-Seidel sweeps of the system itself, where a patch without a row
 * keeps B + R (what the shots brought it, through the shooters' rows) and
 * gathers what is still to come, Σ_j F_ij (X_j - B_j), through the row of
 * the nearest patch of its surface that has one (F_ij ≈ F_rep,j: a
 * neighbour on the same plane sees nearly what it sees).  So the preview is
 * the answer of the rows present and borrowed, not of a uniform ambient:
 * on the glTF Cornell box the 10 % image comes after 15 % of the rows
 * instead of 27 %.  The prefetch gives every surface one row first, so that
 * every patch soon has a representative.
 *
 * The ambient term (Cohen et al. 1988) stands for what the unshot power U
 * will add once shot.  Their closed-scene form, U/(A_total (1 - ρ_avg))
 * spread evenly, is up to 3× too bright in an open scene.  Here it is
 * measured and split.  Of the power shot from reflecting patches, the
 * fraction r comes back as unshot power (landed times ρ); shooting U then
 * adds r U/(1 - r) in all.  Its first bounce is gathered where rows are
 * present (one Jacobi sweep from B + R) and received by reciprocity from
 * the rows present elsewhere, the unshot of patches without a row spread
 * evenly; the later bounces, U r²/(1 - r), are spread in proportion to
 * A_i ρ_i.  In a closed room of uniform ρ this is Cohen's term exactly.
 *
 * Invariants: B_i >= 0 only grows; R_j >= 0; B + R >= E; the running
 * totals (power, unshot) drift by rounding only and are summed afresh
 * before any decision to stop and for every preview.
 */
#include "sv_internal.h"

#include <stdlib.h>
#include <string.h>

#define SV_DEFAULT_SHOTS_PER_PATCH 100u
/* A shooter whose rows are present goes before the best one, whose rows are
 * missing, while it has at least 1/SV_READY_SHARE of its unshot power. */
#define SV_READY_SHARE 4.0
/* ... 1/SV_READY_SHARE_BOUNDED when the matrix does not fit in the row
 * store: a row computed again costs far more than a few more shots. */
#define SV_READY_SHARE_BOUNDED 64.0
/* Sweeps of a preview's estimate over the rows present and borrowed
 * (borrowed_sweeps).  On the glTF Cornell box the first sweep takes the
 * 10 % image from 700 rows to 510, a second brings the 2 % image from 85 %
 * of the rows to 73 %, six change the RMS by less than 1e-3. */
#define SV_PREVIEW_SWEEPS 2u
/* Progress callbacks at most this often (seconds). */
#define SV_PROGRESS_EVERY 0.25
/* An eviction frees this fraction of the budget beyond what the batch
 * needs, so that the pool is compacted once per that much new rows. */
#define SV_EVICT_FRACTION 0.25
/* An exact column whose Σ_j A_j F_ji exceeds A_i by more than this is
 * scaled back to A_i: a shot never delivers more than it sends. */
#define SV_COLUMN_SUM_MAX (1.0 + 1e-3)

/* Per-patch state bits. */
enum {
    ST_GATHERED = 1, /* has gathered at least once */
    ST_CHECKED = 2,  /* its row, as present now, passed sv_check_row */
    ST_COMPUTED = 4, /* its row has been present in this solve (a refetch is a recompute) */
    ST_COLUMN = 8    /* need_column was asked for it */
};

/* ------------------------------------------------------------- transpose */

/* Column access to F: for each i, the pairs (j, F_ji) of the rows present,
 * j increasing.  Built once per solve that has every row it needs. */
typedef struct transpose {
    uint64_t *start; /* n + 1 */
    uint32_t *col;   /* j */
    float *val;      /* F_ji */
} transpose;

static void transpose_free(transpose *T)
{
    free(T->start);
    free(T->col);
    free(T->val);
}

static int transpose_build(const rad_matrix *F, transpose *T, rad_error *err)
{
    const uint32_t n = F->n;
    uint64_t total = 0;
    T->start = calloc((size_t)n + 1, sizeof *T->start);
    if (!T->start)
        return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for the transposed matrix");
    for (uint32_t j = 0; j < n; j++) {
        const rad_row r = rad_matrix_row(F, j);
        const uint8_t *q = r.col;
        uint32_t c = 0;
        for (uint32_t k = 0; k < r.count; k++) {
            c = rad_row_next(&q, c);
            T->start[c + 1]++;
        }
        total += r.count;
    }
    for (uint32_t i = 0; i < n; i++)
        T->start[i + 1] += T->start[i];
    T->col = malloc((size_t)(total ? total : 1) * sizeof *T->col);
    T->val = malloc((size_t)(total ? total : 1) * sizeof *T->val);
    uint64_t *fill = malloc(((size_t)n + 1) * sizeof *fill);
    if (!T->col || !T->val || !fill) {
        free(fill);
        return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for the transposed matrix");
    }
    memcpy(fill, T->start, ((size_t)n + 1) * sizeof *fill);
    for (uint32_t j = 0; j < n; j++) { /* j increasing, so each column comes out sorted */
        const rad_row r = rad_matrix_row(F, j);
        const uint8_t *q = r.col;
        uint32_t c = 0;
        for (uint32_t k = 0; k < r.count; k++) {
            c = rad_row_next(&q, c);
            uint64_t at = fill[c]++;
            T->col[at] = j;
            T->val[at] = rad_row_value(&r, k);
        }
    }
    free(fill);
    return RAD_OK;
}

/* ----------------------------------------------------------------- state */

typedef struct prog {
    const sv_system *s;
    const sv_options *o;
    sv_stats *st;
    uint32_t n, nb;
    size_t len;
    double tol;
    uint32_t max_shots, batch_max;
    double *B;        /* gathered radiosity: B_i as i's last gather left it (0 before) */
    double *R;        /* unshot radiosity: the residual as the shots estimate it */
    double *power;    /* A_i Σ_b R_i,b: who shoots next */
    double *inv_area;
    uint8_t *state;   /* ST_ bits */
    uint8_t *refl;    /* 1: the patch reflects (ρ > 0 in some band) */
    float *rowsum;    /* Σ_j F_ij of row i as checked (ST_CHECKED) */
    double *display;  /* the preview's B, or NULL */
    double *sum;      /* the preview's B + R */
    double *first;    /* the preview's first bounce of R onto the patches not swept */
    uint32_t *rep;    /* the preview's representatives (whose row stands for a patch's) */
    uint8_t *swept;   /* the preview's patches swept */
    uint32_t *col;    /* need_column's answer, n entries */
    float *val;
    uint32_t *row_col; /* a shooter's row unpacked, n entries */
    float *row_val;
    uint32_t *batch;  /* rows of one need_rows call */
    uint32_t batch_count;
    uint32_t max_row; /* the most entries of a row seen */
    int fits;         /* the whole matrix looks like it fits in max_matrix_bytes */
    uint32_t *heap;   /* candidates of a batch */
    transpose T;
    int have_T;       /* columns from the transpose (every needed row was present) */
    int computing;    /* some needed row was missing at the start */
    uint32_t pending; /* patches that gather and have not gathered yet */
    uint32_t scan;    /* where the search for the next pending one resumes */
    uint32_t pscan;   /* ... and the prefetch of pending ones: patch pscan·stride mod n, */
    uint32_t stride;  /* coprime to n, so that every surface has a few rows early */
    uint32_t gscan;   /* where the prefetch of one row per surface resumes */
    uint32_t shots;
    /* power per band */
    double area_sum;
    double emitted[RAD_MAX_BANDS], unshot[RAD_MAX_BANDS], albedo[RAD_MAX_BANDS];
    /* what the shots sent, landed and re-emitted: [0] emitters' first shots
     * (exact columns), [1] the others */
    double sent[2][RAD_MAX_BANDS], landed[2][RAD_MAX_BANDS], returned[2][RAD_MAX_BANDS];
    /* time */
    double t0, cb_seconds, next_preview_t, next_progress_t; /* cb_seconds: previews' and
                                                               * progress's time */
} prog;

static int gathers(const prog *p, uint32_t i) { return sv_gathers(p->s, i); }

static double now_solving(const prog *p) { return rad_seconds() - p->t0 - p->cb_seconds; }

/* Unshot power relative to emitted power, the worst band.  A band that emits
 * nothing never holds unshot power and is left out. */
static double unshot_fraction(const prog *p)
{
    double e = 0.0;
    for (uint32_t b = 0; b < p->nb; b++)
        if (p->emitted[b] > 0.0 && p->unshot[b] / p->emitted[b] > e)
            e = p->unshot[b] / p->emitted[b];
    return e;
}

/* Σ_i A_i R_i,b per band and power[i], summed afresh. */
static double resum(prog *p)
{
    const uint32_t nb = p->nb;
    for (uint32_t b = 0; b < nb; b++)
        p->unshot[b] = 0.0;
    for (uint32_t i = 0; i < p->n; i++) {
        const double a = p->s->area[i], *r = p->R + (size_t)i * nb;
        double w = 0.0;
        for (uint32_t b = 0; b < nb; b++) {
            p->unshot[b] += a * r[b];
            w += r[b];
        }
        p->power[i] = a * w;
    }
    return unshot_fraction(p);
}

static void prog_free(prog *p)
{
    free(p->B);
    free(p->R);
    free(p->power);
    free(p->inv_area);
    free(p->state);
    free(p->refl);
    free(p->rowsum);
    free(p->display);
    free(p->sum);
    free(p->first);
    free(p->rep);
    free(p->swept);
    free(p->col);
    free(p->val);
    free(p->row_col);
    free(p->row_val);
    free(p->batch);
    free(p->heap);
    transpose_free(&p->T);
}

static uint32_t gcd(uint32_t a, uint32_t b)
{
    while (b) {
        uint32_t t = a % b;
        a = b;
        b = t;
    }
    return a;
}

/* Checks row r (present) once, keeping its sum. */
static int check(prog *p, uint32_t r, rad_error *err)
{
    if (p->state[r] & ST_CHECKED)
        return RAD_OK;
    double sum = 0.0;
    int rc = sv_check_row(p->s->F, r, &sum, err);
    if (rc)
        return rc;
    p->rowsum[r] = (float)sum;
    p->state[r] |= ST_CHECKED;
    return RAD_OK;
}

/* Does the matrix look like it fits in max_matrix_bytes, by the rows
 * present (p->fits, kept up to date by settle)? */
static void update_fits(prog *p)
{
    const rad_matrix *F = p->s->F;
    const uint64_t budget = p->o->max_matrix_bytes;
    p->fits = !budget || F->rows_done == 0 ||
              (double)rad_matrix_live_bytes(F) / F->rows_done * p->n <= (double)budget;
}

/* Every present row checked; whether the solve computes rows; the
 * transpose when it does not; B = 0, R = E and the totals. */
static int prog_init(prog *p, const sv_system *s, const sv_options *o, double tol, sv_stats *st,
                     rad_error *err)
{
    const uint32_t n = s->n, nb = s->bands;
    memset(p, 0, sizeof *p);
    p->s = s, p->o = o, p->st = st, p->n = n, p->nb = nb, p->tol = tol;
    p->len = (size_t)n * nb;
    uint64_t shots_default = (uint64_t)SV_DEFAULT_SHOTS_PER_PATCH * n;
    p->max_shots = o->max_iterations ? o->max_iterations
                   : shots_default > UINT32_MAX ? UINT32_MAX
                                                : (uint32_t)shots_default;
    p->batch_max = o->row_batch ? o->row_batch : SV_DEFAULT_ROW_BATCH;
    p->stride = (uint32_t)(0.618 * n) | 1u;
    while (gcd(p->stride, n) != 1)
        p->stride += 2;
    p->B = calloc(p->len, sizeof *p->B);
    p->R = malloc(p->len * sizeof *p->R);
    p->power = malloc((size_t)n * sizeof *p->power);
    p->inv_area = malloc((size_t)n * sizeof *p->inv_area);
    p->state = calloc(n, 1);
    p->refl = malloc((size_t)n + 1);
    p->rowsum = calloc(n, sizeof *p->rowsum);
    if (o->on_preview) {
        p->display = malloc(p->len * sizeof *p->display);
        p->sum = malloc(p->len * sizeof *p->sum);
        p->first = malloc(p->len * sizeof *p->first);
        p->rep = malloc((size_t)n * sizeof *p->rep);
        p->swept = malloc((size_t)n * sizeof *p->swept);
    }
    p->batch = malloc(((size_t)p->batch_max + 2) * sizeof *p->batch);
    p->heap = malloc(((size_t)p->batch_max + 2) * sizeof *p->heap);
    if (!p->B || !p->R || !p->power || !p->inv_area || !p->state || !p->refl || !p->rowsum ||
        !p->batch ||
        !p->heap ||
        (o->on_preview && (!p->display || !p->sum || !p->first || !p->rep || !p->swept)))
        return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for %u patches", n);
    const rad_matrix *F = s->F;
    for (uint32_t i = 0; i < n; i++) {
        if (!sv_row_present(F, i))
            continue;
        int rc = check(p, i, err);
        if (rc)
            return rc;
        p->state[i] |= ST_COMPUTED;
        p->max_row = F->row_count[i] > p->max_row ? F->row_count[i] : p->max_row;
    }
    for (uint32_t i = 0; i < n && !p->computing; i++)
        p->computing = !sv_row_present(F, i) && sv_row_needed(s, i);
    if (!p->computing) {
        int rc = transpose_build(F, &p->T, err);
        if (rc)
            return rc;
        p->have_T = 1;
    } else {
        p->row_col = malloc((size_t)n * sizeof *p->row_col);
        p->row_val = malloc((size_t)n * sizeof *p->row_val);
        if (!p->row_col || !p->row_val)
            return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for %u patches", n);
    }
    if (p->computing && o->need_column) {
        p->col = malloc((size_t)n * sizeof *p->col);
        p->val = malloc((size_t)n * sizeof *p->val);
        if (!p->col || !p->val)
            return rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for %u patches", n);
    }
    update_fits(p);
    memcpy(p->R, s->emission, p->len * sizeof *p->R);
    for (uint32_t i = 0; i < n; i++) {
        const double a = s->area[i];
        p->refl[i] = (uint8_t)rad_any_positive(s->rho + (size_t)i * nb, nb);
        p->inv_area[i] = 1.0 / a;
        p->area_sum += a;
        p->pending += gathers(p, i);
        for (uint32_t b = 0; b < nb; b++) {
            /* what a sheet passes on is re-emitted too, on its other side */
            const size_t k = (size_t)i * nb + b;
            p->emitted[b] += a * s->emission[k];
            p->albedo[b] += a * (s->rho[k] + (s->tau ? s->tau[k] : 0.0));
        }
    }
    for (uint32_t b = 0; b < nb; b++)
        p->albedo[b] /= p->area_sum;
    resum(p);
    p->t0 = rad_seconds();
    p->next_preview_t = o->preview_seconds > 0.0 ? o->preview_seconds : INFINITY;
    p->next_progress_t = SV_PROGRESS_EVERY;
    return RAD_OK;
}

/* ------------------------------------------------------------- row store */

/* The rows patch j needs for a shot, into r[0..2): its own row (to gather,
 * or to shoot by reciprocity when no exact column will be given) and its
 * twin's (to gather what passes through).  `column` 1: j's shot will use an
 * exact column. */
static uint32_t rows_for(const prog *p, uint32_t j, int column, uint32_t r[2])
{
    uint32_t k = 0;
    const int reflects = rad_any_positive(p->s->rho + (size_t)j * p->nb, p->nb);
    if (reflects || (!p->have_T && !column))
        r[k++] = j;
    const uint32_t t = sv_transmits_from(p->s, j);
    if (t != RAD_NONE)
        r[k++] = t;
    return k;
}

/* Will j's next shot use an exact column?  (A guess for prefetching: an
 * emitter not yet shot, when need_column may give one.) */
static int expects_column(const prog *p, uint32_t j)
{
    return p->col && !(p->state[j] & ST_COLUMN) &&
           rad_any_positive(p->s->emission + (size_t)j * p->nb, p->nb);
}

/* Adds the missing rows of j to the batch (no duplicates), while there is
 * room; returns 0 when the batch is full. */
static int batch_add(prog *p, uint32_t j, int column, uint32_t *count, uint32_t room)
{
    uint32_t r[2];
    const uint32_t k = rows_for(p, j, column, r);
    for (uint32_t q = 0; q < k; q++) {
        if (sv_row_present(p->s->F, r[q]))
            continue;
        int dup = 0;
        for (uint32_t m = 0; m < *count && !dup; m++)
            dup = p->batch[m] == r[q];
        if (dup)
            continue;
        if (*count >= room)
            return 0;
        p->batch[(*count)++] = r[q];
    }
    return 1;
}

/* Heap order: more power first, then the lower index. */
static int before(const prog *p, uint32_t a, uint32_t b)
{
    return p->power[a] > p->power[b] || (p->power[a] == p->power[b] && a < b);
}

static int missing_rows(const prog *p, uint32_t j)
{
    uint32_t r[2];
    const uint32_t k = rows_for(p, j, expects_column(p, j), r);
    for (uint32_t q = 0; q < k; q++)
        if (!sv_row_present(p->s->F, r[q]))
            return 1;
    return 0;
}

/* The next shooters after i by unshot power whose rows are missing, best
 * first, into p->heap (at most m of them); returns how many. */
static uint32_t next_shooters(prog *p, uint32_t i, uint32_t m)
{
    uint32_t *h = p->heap, size = 0;
    /* A heap of the m best so far with the worst at the root. */
    for (uint32_t j = 0; j < p->n && m; j++) {
        if (j == i || !(p->power[j] > 0.0) || (size == m && !before(p, j, h[0])) ||
            !missing_rows(p, j))
            continue;
        uint32_t at;
        if (size < m) {
            at = size++;
            while (at > 0 && before(p, h[(at - 1) / 2], j)) {
                h[at] = h[(at - 1) / 2];
                at = (at - 1) / 2;
            }
        } else {
            at = 0;
            for (;;) {
                uint32_t c = 2 * at + 1;
                if (c >= size)
                    break;
                if (c + 1 < size && before(p, h[c], h[c + 1]))
                    c++;
                if (!before(p, j, h[c]))
                    break;
                h[at] = h[c];
                at = c;
            }
        }
        h[at] = j;
    }
    /* Best first: insertion sort (m is small). */
    for (uint32_t a = 1; a < size; a++) {
        uint32_t v = h[a], b = a;
        for (; b > 0 && before(p, v, h[b - 1]); b--)
            h[b] = h[b - 1];
        h[b] = v;
    }
    return size;
}

/* Who keeps a row when room is needed: the unshot power of the patches that
 * read it (its own, and its twin's when the twin gathers through it). */
static double row_priority(const prog *p, uint32_t r)
{
    double w = p->power[r];
    if (p->s->twin && p->s->twin[r] != RAD_NONE) {
        uint32_t u = p->s->twin[r];
        if (sv_transmits_from(p->s, u) == r && p->power[u] > w)
            w = p->power[u];
    }
    return w;
}

typedef struct ranked {
    double w;
    uint32_t row;
} ranked;

static int by_priority(const void *a, const void *b)
{
    const ranked *x = a, *y = b;
    if (x->w != y->w)
        return x->w < y->w ? -1 : 1;
    return x->row > y->row ? -1 : x->row < y->row; /* higher index goes first */
}

/* The bytes a row coming in may take: twice the longest row seen so far
 * (rows of one scene differ by less), never more than n - 1 entries; n - 1
 * before any row.  A row longer than that is caught after the fact
 * (settle). */
static uint64_t row_estimate(const prog *p)
{
    const uint64_t worst = p->n > 1 ? p->n - 1 : 1;
    const uint64_t twice = 2 * (uint64_t)p->max_row;
    return rad_matrix_row_bytes((uint32_t)(p->max_row && twice < worst ? twice : worst));
}

/* Drops rows present, least priority first (row_priority), keeping those
 * in keep[0..nkeep), until the rows present take at most `target` bytes;
 * returns what they take then. */
static uint64_t evict(prog *p, double target, const uint32_t *keep, uint32_t nkeep, rad_error *err)
{
    rad_matrix *F = p->s->F;
    uint64_t live = rad_matrix_live_bytes(F);
    if ((double)live <= target)
        return live;
    ranked *order = malloc(((size_t)F->rows_done + 1) * sizeof *order);
    if (!order) {
        rad_fail(err, RAD_ERR_NOMEM, "solver: out of memory for the row store");
        return UINT64_MAX;
    }
    uint32_t m = 0;
    for (uint32_t r = 0; r < p->n; r++) {
        if (!sv_row_present(F, r))
            continue;
        int kept = 0;
        for (uint32_t q = 0; q < nkeep && !kept; q++)
            kept = keep[q] == r;
        if (!kept)
            order[m++] = (ranked){row_priority(p, r), r};
    }
    qsort(order, m, sizeof *order, by_priority);
    for (uint32_t k = 0; k < m && (double)live > target; k++) {
        const uint32_t r = order[k].row;
        live -= rad_matrix_record_bytes(F, r);
        rad_matrix_drop_row(F, r);
        p->state[r] &= (uint8_t)~ST_CHECKED;
        p->st->rows_dropped++;
    }
    free(order);
    return live;
}

/* Makes room in F's pool for `count` rows (row_estimate each) under
 * max_matrix_bytes, keeping the rows in keep[0..nkeep): grows the pool
 * within the budget while the rows fit, else drops the rows of least
 * priority down to the budget less the batch less SV_EVICT_FRACTION of the
 * budget (so that the pool is compacted once per that much new rows) and
 * compacts the pool to the budget.  RAD_ERR_LIMIT when even the rows kept
 * cannot fit. */
static int make_room(prog *p, uint32_t count, const uint32_t *keep, uint32_t nkeep, rad_error *err)
{
    const uint64_t budget = p->o->max_matrix_bytes;
    rad_matrix *F = p->s->F;
    if (!budget)
        return RAD_OK;
    const uint64_t incoming = (uint64_t)count * row_estimate(p);
    const uint64_t pool = rad_matrix_pool_bytes(F);
    if (rad_matrix_used_bytes(F) + incoming <= pool)
        return RAD_OK; /* room at the end of the pool already */
    uint64_t live = rad_matrix_live_bytes(F);
    if (live + incoming <= budget) {
        /* Grow (or only compact) within the budget, by half again at least. */
        uint64_t want = pool + pool / 2;
        want = want < live + incoming ? live + incoming : want;
        return rad_matrix_compact(F, want < budget ? want : budget, err);
    }
    live = evict(p, (double)budget - (double)incoming - SV_EVICT_FRACTION * (double)budget, keep,
                 nkeep, err);
    if (live == UINT64_MAX)
        return RAD_ERR_NOMEM;
    if (live + incoming > budget) {
        char need[32], have[32];
        return rad_fail(err, RAD_ERR_LIMIT,
                        "solver: the form-factor rows of one shot need up to %s, more than the "
                        "%s allowed; raise --max-memory",
                        rad_human_bytes((double)(live + incoming), need, sizeof need),
                        rad_human_bytes((double)budget, have, sizeof have));
    }
    return rad_matrix_compact(F, budget, err);
}

/* After need_rows: the longest row seen, whether the matrix fits, and the
 * pool back within the budget should a row longer than row_estimate have
 * grown it (dropping rows, the new ones and the shooter's last). */
static int settle(prog *p, const uint32_t *keep, uint32_t nkeep, rad_error *err)
{
    rad_matrix *F = p->s->F;
    for (uint32_t q = 0; q < p->batch_count; q++)
        if (F->row_count[p->batch[q]] > p->max_row)
            p->max_row = F->row_count[p->batch[q]];
    update_fits(p);
    const uint64_t budget = p->o->max_matrix_bytes;
    if (!budget || rad_matrix_pool_bytes(F) <= budget)
        return RAD_OK;
    const uint64_t live = evict(p, (double)budget, keep, nkeep, err);
    if (live == UINT64_MAX)
        return RAD_ERR_NOMEM;
    return rad_matrix_compact(F, budget, err);
}

/* Prefetch: one row on each surface (sv_system.group) that has none yet,
 * its middle patch that gathers, surfaces in index order, into the batch
 * up to `quota`; returns the batch's count.  Before it the previews drew a
 * surface without a row from B + R and the ambient alone: the short block's
 * faces 31 % too bright at 480 shots, and the 10 % image waited for 510
 * rows instead of 383 (glTF Cornell box). */
static uint32_t one_per_surface(prog *p, uint32_t i, uint32_t count, uint32_t quota)
{
    const uint32_t *g = p->s->group;
    while (p->gscan < p->n && count < quota) {
        const uint32_t a = p->gscan;
        uint32_t z = a + 1;
        while (z < p->n && g[z] == g[a])
            z++;
        uint32_t best = RAD_NONE, dist = UINT32_MAX;
        int have = 0;
        for (uint32_t j = a; j < z && !have; j++) {
            have = sv_row_present(p->s->F, j) || (p->state[j] & ST_COMPUTED);
            const uint32_t c = a + (z - a) / 2, d = j > c ? j - c : c - j;
            if (gathers(p, j) && d < dist) {
                best = j;
                dist = d;
            }
        }
        if (!have && best != RAD_NONE && best != i && missing_rows(p, best) &&
            !batch_add(p, best, expects_column(p, best), &count, quota))
            break;
        p->gscan = z;
    }
    return count;
}

/* Computes the rows shooter i lacks (need: its rows, those of its shot) and,
 * in the same call, those of the next shooters: by unshot power, or in the
 * last phase the next patches that have not gathered.  The batch shrinks
 * to what the budget holds. */
static int fetch(prog *p, uint32_t i, int column, int last_phase, rad_error *err)
{
    const sv_options *o = p->o;
    rad_matrix *F = p->s->F;
    uint32_t need[2], count = 0;
    const uint32_t k = rows_for(p, i, column, need);
    batch_add(p, i, column, &count, p->batch_max + 2);
    if (count == 0)
        return RAD_OK;
    if (!o->need_rows)
        return rad_fail(err, RAD_ERR_USAGE,
                        "solver: form-factor row %u is missing and no need_rows was given",
                        p->batch[0]);
    uint32_t room = p->batch_max;
    if (o->max_matrix_bytes) { /* a batch takes at most an eighth of the budget */
        uint64_t fit = o->max_matrix_bytes / row_estimate(p) / 8;
        room = fit < room ? (uint32_t)fit : room;
    }
    room = room < count ? count : room;
    if (last_phase) {
        for (uint32_t j = p->scan; j < p->n && count < room; j++)
            if (j != i && gathers(p, j) && !(p->state[j] & ST_GATHERED) &&
                !batch_add(p, j, expects_column(p, j), &count, room))
                break;
    } else {
        /* While the whole matrix looks like it fits, part of the batch goes
         * to patches that have not gathered, spread over the scene
         * (pscan·stride mod n): a preview then has rows on every surface to
         * gather with and to stand for their neighbours', and the dark and
         * buried patches get theirs before the last phase (a buried patch,
         * its row found empty, is drawn from its neighbours, as the end
         * will draw it).  Three quarters of each batch: measured on the
         * glTF Cornell box, the 10 % image after 27 % of the rows and the
         * 2 % image after 99 % (an eighth: 41 % and 95 %; three quarters
         * until a quarter of the rows, an eighth after: 27 % and 90 %, but
         * the previews then stay 0.7 % off until the last phase computes
         * the buried patches' rows). */
        const uint32_t quota = p->fits ? count + 3 * (room - count) / 4 : count;
        if (p->s->group)
            count = one_per_surface(p, i, count, quota);
        for (; p->pscan < p->n && count < quota; p->pscan++) {
            const uint32_t j = (uint32_t)(((uint64_t)p->pscan * p->stride) % p->n);
            if (j != i && gathers(p, j) && !(p->state[j] & ST_GATHERED) && missing_rows(p, j) &&
                !batch_add(p, j, expects_column(p, j), &count, quota))
                break;
        }
        uint32_t m = next_shooters(p, i, room - count);
        for (uint32_t q = 0; q < m; q++)
            if (!batch_add(p, p->heap[q], expects_column(p, p->heap[q]), &count, room))
                break;
    }
    int rc = make_room(p, count, need, k, err);
    if (rc)
        return rc;
    for (uint32_t q = 0; q < count; q++)
        if (p->state[p->batch[q]] & ST_COMPUTED)
            p->st->rows_recomputed++;
    p->st->rows_requested += count;
    rad_error cb = {0};
    rc = o->need_rows(o->user, p->batch, count, &cb);
    if (rc != RAD_OK) {
        if (!cb.message[0])
            rad_fail(&cb, rc, "solver: computing %u form-factor rows failed", count);
        if (err)
            *err = cb;
        return rc;
    }
    for (uint32_t q = 0; q < count; q++) {
        const uint32_t r = p->batch[q];
        if (!sv_row_present(F, r))
            return rad_fail(err, RAD_ERR_USAGE, "solver: need_rows did not fill row %u", r);
        p->state[r] = (uint8_t)((p->state[r] & ~ST_CHECKED) | ST_COMPUTED);
    }
    p->batch_count = count;
    return settle(p, need, k, err);
}

/* Checks the rows of i's shot that are present and not yet checked. */
static int check_rows(prog *p, uint32_t i, int column, rad_error *err)
{
    uint32_t r[2];
    const uint32_t k = rows_for(p, i, column, r);
    for (uint32_t q = 0; q < k; q++) {
        int rc = sv_row_present(p->s->F, r[q]) ? check(p, r[q], err) : RAD_OK;
        if (rc)
            return rc;
    }
    return RAD_OK;
}

/* ------------------------------------------------------------------ shot */

/* need_column for i's first shot, when it may have one; 1 when it gave one
 * (in p->col/p->val, *count entries), checked: columns strictly increasing,
 * below n, never i, F_ji > 0 and finite; Σ_j A_j F_ji scaled back to A_i
 * should it exceed it by more than rounding. */
static int exact_column(prog *p, uint32_t i, uint32_t *count, rad_error *err)
{
    *count = 0;
    if (!p->col || (p->state[i] & ST_COLUMN))
        return 0;
    p->state[i] |= ST_COLUMN;
    uint32_t c = RAD_NONE;
    rad_error cb = {0};
    int rc = p->o->need_column(p->o->user, i, p->col, p->val, &c, &cb);
    if (rc != RAD_OK) {
        if (!cb.message[0])
            rad_fail(&cb, rc, "solver: the exact column of patch %u failed", i);
        if (err)
            *err = cb;
        return -rc;
    }
    if (c == RAD_NONE)
        return 0;
    if (c > p->n)
        return -rad_fail(err, RAD_ERR_USAGE, "solver: column %u: %u entries", i, c);
    double sum = 0.0;
    for (uint32_t k = 0; k < c; k++) {
        const uint32_t j = p->col[k];
        if (j >= p->n || j == i || (k && j <= p->col[k - 1]) || !(p->val[k] > 0.0f) ||
            !isfinite(p->val[k]))
            return -rad_fail(err, RAD_ERR_USAGE, "solver: column %u: bad entry %u (row %u)", i, k, j);
        sum += p->s->area[j] * p->val[k];
    }
    const double limit = SV_COLUMN_SUM_MAX * p->s->area[i];
    if (sum > limit)
        for (uint32_t k = 0; k < c; k++)
            p->val[k] = (float)(p->val[k] * (p->s->area[i] / sum));
    *count = c;
    return 1;
}

/* The gather: B_i <- its Gauss-Seidel update, into delta the change (>= 0:
 * B only grows; a rounding below the old value keeps the old value). */
static void gather(prog *p, uint32_t i, double *delta)
{
    const uint32_t nb = p->nb;
    double g[RAD_MAX_BANDS];
    double *Bi = p->B + (size_t)i * nb;
    sv_update(p->s, i, p->B, g);
    for (uint32_t b = 0; b < nb; b++) {
        delta[b] = g[b] > Bi[b] ? g[b] - Bi[b] : 0.0;
        Bi[b] += delta[b];
    }
    if (!(p->state[i] & ST_GATHERED)) {
        p->state[i] |= ST_GATHERED;
        if (gathers(p, i))
            p->pending--;
    }
}

/* Shoots delta from i: receiver j gets the irradiance ΔH_j = F_ji δ_i and
 * re-emits ρ_j ΔH_j (and its twin t τ_t ΔH_j, through a sheet) as unshot
 * radiosity.  The column: c[0..count) with v = F_ji when `transposed`
 * (the transpose or an exact column), else row i, v = F_ij, and F_ji by
 * reciprocity. */
static void shoot(prog *p, uint32_t i, const double *delta, const uint32_t *c, const float *v,
                  uint32_t count, int transposed)
{
    const sv_system *s = p->s;
    const uint32_t nb = p->nb;
    const double Ai = s->area[i];
    double landed[RAD_MAX_BANDS] = {0}, returned[RAD_MAX_BANDS] = {0};
    /* The ambient's measure: shots of reflected light, not an emitter's
     * first shot (an exact column), once there are any. */
    const int kind = !(transposed && !p->have_T);
    for (uint32_t b = 0; b < nb; b++)
        p->sent[kind][b] += Ai * delta[b];
    for (uint32_t k = 0; k < count; k++) {
        const uint32_t j = c[k];
        const double fji = transposed ? v[k] : v[k] * Ai * p->inv_area[j];
        double dH[RAD_MAX_BANDS];
        for (uint32_t b = 0; b < nb; b++) {
            dH[b] = fji * delta[b];
            landed[b] += s->area[j] * dH[b];
        }
        const uint32_t t = s->tau && s->twin[j] != RAD_NONE ? s->twin[j] : RAD_NONE;
        for (int side = 0; side < (t == RAD_NONE ? 1 : 2); side++) {
            const uint32_t r = side ? t : j;
            const double *gain = (side ? s->tau : s->rho) + (size_t)r * nb;
            double *Rr = p->R + (size_t)r * nb, w = 0.0;
            for (uint32_t b = 0; b < nb; b++) {
                const double d = gain[b] * dH[b];
                Rr[b] += d;
                w += d;
                returned[b] += s->area[r] * d;
            }
            p->power[r] += s->area[r] * w;
        }
    }
    for (uint32_t b = 0; b < nb; b++) {
        p->landed[kind][b] += landed[b];
        p->returned[kind][b] += returned[b];
        p->unshot[b] += returned[b];
    }
}

/* One shot from i: its exact column if it has one, its rows fetched, the
 * gather, the shot of the change. */
static int shot(prog *p, uint32_t i, int last_phase, rad_error *err)
{
    uint32_t ncol = 0;
    const int column = exact_column(p, i, &ncol, err);
    if (column < 0)
        return -column;
    int rc = fetch(p, i, column, last_phase, err);
    if (!rc)
        rc = check_rows(p, i, column, err);
    if (rc)
        return rc;
    const uint32_t nb = p->nb;
    double delta[RAD_MAX_BANDS], *Ri = p->R + (size_t)i * nb;
    for (uint32_t b = 0; b < nb; b++) {
        p->unshot[b] -= p->s->area[i] * Ri[b];
        Ri[b] = 0.0;
    }
    p->power[i] = 0.0;
    gather(p, i, delta);
    /* need_rows may have moved F's pool: take the pointers only now. */
    const rad_matrix *F = p->s->F;
    if (column) {
        shoot(p, i, delta, p->col, p->val, ncol, 1);
        p->st->exact_columns++;
    } else if (p->have_T) {
        const uint64_t a = p->T.start[i], z = p->T.start[i + 1];
        shoot(p, i, delta, p->T.col + a, p->T.val + a, (uint32_t)(z - a), 1);
    } else if (F->row_count[i]) {
        /* F keeps its rows packed (rad.h): unpacked into the shot's arrays */
        const uint32_t c = rad_matrix_get_row(F, i, p->row_col, p->row_val);
        shoot(p, i, delta, p->row_col, p->row_val, c, 0);
    }
    p->shots++;
    return RAD_OK;
}

/* ------------------------------------------------------- what it shows */

/* One sweep from src into dst over the patches whose rows are present
 * (checked first when no shot has checked them): dst_i = E_i + ρ_i (F
 * src)_i (+ τ_i (F src)_twin(i)), in place (Gauss-Seidel) when src == dst,
 * else Jacobi; the other patches copy src.  swept (may be NULL) marks the
 * patches swept. */
static int sweep_present(prog *p, const double *src, double *dst, uint8_t *swept, rad_error *err)
{
    const sv_system *s = p->s;
    const uint32_t nb = p->nb;
    for (uint32_t i = 0; i < p->n; i++) {
        const uint32_t t = sv_transmits_from(s, i);
        const int reflects = rad_any_positive(s->rho + (size_t)i * nb, nb);
        const int ok = !((reflects && !sv_row_present(s->F, i)) ||
                         (t != RAD_NONE && !sv_row_present(s->F, t)));
        if (swept)
            swept[i] = (uint8_t)ok;
        if (!ok) { /* dropped or never computed: src stands */
            if (dst != src)
                memcpy(dst + (size_t)i * nb, src + (size_t)i * nb, nb * sizeof *dst);
            continue;
        }
        const uint32_t rows[2] = {i, t};
        for (int k = 0; k < 2; k++) {
            int rc = rows[k] != RAD_NONE && sv_row_present(s->F, rows[k]) ? check(p, rows[k], err)
                                                                           : RAD_OK;
            if (rc)
                return rc;
        }
        double g[RAD_MAX_BANDS];
        sv_update(s, i, src, g);
        memcpy(dst + (size_t)i * nb, g, nb * sizeof *g);
    }
    return RAD_OK;
}

/* The answer: B + R, then one Gauss-Seidel sweep over the rows present
 * (see the top of the file). */
static int finish(prog *p, double *out, rad_error *err)
{
    for (size_t x = 0; x < p->len; x++)
        out[x] = p->B[x] + p->R[x];
    return sweep_present(p, out, out, NULL, err);
}

/* The ambient's measures per band: of the power shot, the fraction c that
 * lands on patches and the fraction r that comes back as unshot power
 * (landed times ρ or τ), from the shots of reflected light once there are
 * any (the unshot power is reflected light), else from the emitters' first
 * shots, else Cohen's: c = 1, r = the area-weighted albedo. */
static void ambient(const prog *p, double *c, double *r)
{
    const int k = p->sent[1][0] > 0.0 || p->sent[1][p->nb - 1] > 0.0 ? 1 : 0;
    for (uint32_t b = 0; b < p->nb; b++) {
        double cb = 1.0, rb = p->albedo[b];
        if (p->sent[k][b] > 0.0) {
            cb = p->landed[k][b] / p->sent[k][b];
            rb = p->returned[k][b] / p->sent[k][b];
        }
        c[b] = cb;
        r[b] = rb < 0.999 ? rb : 0.999;
    }
}

static sv_progress progress_of(const prog *p, double unshot)
{
    return (sv_progress){.shots = p->shots,
                         .unshot = unshot,
                         .tolerance = p->tol,
                         .seconds = now_solving(p),
                         .rows_requested = p->st->rows_requested,
                         .rows_dropped = p->st->rows_dropped};
}

/* For each patch, the patch whose row stands for its own in a preview:
 * itself when its row is present, else the nearest patch by index of the
 * same surface (sv_system.group) with a row, else RAD_NONE. */
static void representatives(prog *p)
{
    const sv_system *s = p->s;
    const uint32_t n = p->n, *g = s->group;
    uint32_t last = RAD_NONE;
    for (uint32_t i = 0; i < n; i++) { /* the nearest before */
        if (sv_row_present(s->F, i))
            last = i;
        else if (last != RAD_NONE && (!g || g[last] != g[i]))
            last = RAD_NONE;
        p->rep[i] = g ? last : (sv_row_present(s->F, i) ? i : RAD_NONE);
    }
    if (!g)
        return;
    last = RAD_NONE;
    for (uint32_t i = n; i-- > 0;) { /* or after, if nearer */
        if (sv_row_present(s->F, i))
            last = i;
        else if (last != RAD_NONE && g[last] != g[i])
            last = RAD_NONE;
        if (last != RAD_NONE && (p->rep[i] == RAD_NONE || last - i < i - p->rep[i]))
            p->rep[i] = last;
    }
}

/* The first bounce of the unshot onto the patches not swept: p->first[j]
 * the irradiance from every shooter's unshot power A_k R_k sent along its
 * representative's row (its own when present); loose[b] the unshot power
 * of the patches without one.  Uses p->sum for the power per row. */
static void first_bounce(prog *p, double *loose)
{
    const sv_system *s = p->s;
    const rad_matrix *F = s->F;
    const uint32_t nb = p->nb;
    double *W = p->sum;
    memset(p->first, 0, p->len * sizeof *p->first);
    memset(W, 0, p->len * sizeof *W);
    for (uint32_t b = 0; b < nb; b++)
        loose[b] = 0.0;
    for (uint32_t k = 0; k < p->n; k++) {
        if (!(p->power[k] > 0.0))
            continue;
        const double *Rk = p->R + (size_t)k * nb;
        const uint32_t r = p->rep[k];
        for (uint32_t b = 0; b < nb; b++) {
            if (r == RAD_NONE)
                loose[b] += s->area[k] * Rk[b];
            else
                W[(size_t)r * nb + b] += s->area[k] * Rk[b];
        }
    }
    for (uint32_t k = 0; k < p->n; k++) {
        const double *Wk = W + (size_t)k * nb;
        if (!sv_row_present(F, k) || !rad_any_positive(Wk, nb))
            continue;
        const rad_row row = rad_matrix_row(F, k);
        const uint8_t *at = row.col;
        uint32_t j = 0;
        for (uint32_t q = 0; q < row.count; q++) {
            j = rad_row_next(&at, j);
            if (p->swept[j])
                continue;
            const double w = rad_row_value(&row, q) * p->inv_area[j];
            for (uint32_t b = 0; b < nb; b++)
                p->first[(size_t)j * nb + b] += w * Wk[b];
        }
    }
}

/* What is still to come at a patch whose representative is r, through r's
 * row standing for its own: Σ_j F_rj (X_j - B_j), the unshot R_j and the
 * correction X_j - (B_j + R_j) the sweeps have found so far. */
static void borrowed_gather(const prog *p, uint32_t r, const double *X, double *h)
{
    const uint32_t nb = p->nb;
    for (uint32_t b = 0; b < nb; b++)
        h[b] = 0.0;
    const rad_row row = rad_matrix_row(p->s->F, r);
    const uint8_t *at = row.col;
    uint32_t j = 0;
    for (uint32_t q = 0; q < row.count; q++) {
        j = rad_row_next(&at, j);
        const double f = rad_row_value(&row, q);
        const size_t o = (size_t)j * nb;
        for (uint32_t b = 0; b < nb; b++)
            h[b] += f * (X[o + b] - p->B[o + b]);
    }
}

/* SV_PREVIEW_SWEEPS Gauss-Seidel sweeps over the preview X in place (see
 * preview): a swept patch gathers all of X through its own row; a patch
 * without a row keeps B + R, the light the shots brought it through the
 * shooters' exact rows, and gathers what is still to come through its
 * representative's row (borrowed_gather); a patch without a representative
 * keeps X. */
static int borrowed_sweeps(prog *p, double *X, rad_error *err)
{
    const sv_system *s = p->s;
    const uint32_t nb = p->nb;
    for (uint32_t i = 0; i < p->n; i++)
        if (p->rep[i] != RAD_NONE) {
            int rc = check(p, p->rep[i], err);
            if (rc)
                return rc;
        }
    for (uint32_t k = 0; k < SV_PREVIEW_SWEEPS; k++)
        for (uint32_t i = 0; i < p->n; i++) {
            double g[RAD_MAX_BANDS], h[RAD_MAX_BANDS];
            const size_t o = (size_t)i * nb;
            if (p->swept[i]) {
                sv_update(s, i, X, g);
                memcpy(X + o, g, nb * sizeof *g);
                continue;
            }
            const uint32_t t = sv_transmits_from(s, i);
            if (p->rep[i] == RAD_NONE || (t != RAD_NONE && p->rep[t] == RAD_NONE))
                continue;
            borrowed_gather(p, p->rep[i], X, h);
            for (uint32_t b = 0; b < nb; b++)
                g[b] = p->B[o + b] + p->R[o + b] + s->rho[o + b] * h[b];
            if (t != RAD_NONE) {
                borrowed_gather(p, p->rep[t], X, h);
                for (uint32_t b = 0; b < nb; b++)
                    g[b] += s->tau[o + b] * h[b];
            }
            memcpy(X + o, g, nb * sizeof *g);
        }
    return RAD_OK;
}

/* Calls on_preview with the estimate (see the top of the file).  First
 * the ambient estimate: B + R, the unshot's first bounce - gathered exactly
 * where the rows are present (one Jacobi sweep from B + R), else received
 * from the rows present by reciprocity and from the rest evenly - and its
 * later bounces, U r²/(1 - r) in all, spread in proportion to A_i ρ_i and
 * to how much of the patch's view its row covers against the mean, Σ_j F_ij
 * / c (nothing on a patch buried under a block: it sees nothing and keeps
 * B = E exactly, as the renderer expects of it).  Then, from it,
 * borrowed_sweeps: the system solved on the rows present, each missing row
 * borrowed from the patch's representative for what is still to come.
 * Returns 1 when the callback asks to stop, or -code on an error (a bad
 * row). */
static int preview(prog *p, rad_error *err)
{
    const sv_system *s = p->s;
    const uint32_t nb = p->nb;
    const double t = rad_seconds();
    const double e = resum(p);
    for (size_t x = 0; x < p->len; x++)
        p->sum[x] = p->B[x] + p->R[x];
    int rc = sweep_present(p, p->sum, p->display, p->swept, err);
    if (rc)
        return -rc;
    double c[RAD_MAX_BANDS], r[RAD_MAX_BANDS], loose[RAD_MAX_BANDS];
    double later[RAD_MAX_BANDS], spread[RAD_MAX_BANDS];
    ambient(p, c, r);
    representatives(p);
    first_bounce(p, loose);
    for (uint32_t b = 0; b < nb; b++) {
        /* Σ_i A_i (ρ_i + τ_i): the irradiance that adds power P adds P / this */
        const double ra = p->albedo[b] * p->area_sum;
        later[b] = ra > 0.0 ? p->unshot[b] * r[b] * r[b] / ((1.0 - r[b]) * ra) : 0.0;
        spread[b] = ra > 0.0 ? r[b] * loose[b] / ra : 0.0;
    }
    for (uint32_t i = 0; i < p->n; i++) {
        const uint32_t t = sv_transmits_from(s, i);
        const int swept = p->swept[i];
        /* how much of the view the rows cover (a representative's: its
         * neighbour on the surface), against the mean c */
        const uint32_t ri = p->rep[i], rt = t != RAD_NONE ? p->rep[t] : RAD_NONE;
        const int known = swept || ri != RAD_NONE;
        const double own = ri != RAD_NONE && (p->state[ri] & ST_CHECKED) ? p->rowsum[ri] : 1.0;
        const double through = t == RAD_NONE ? 0.0
                               : rt != RAD_NONE && (p->state[rt] & ST_CHECKED) ? p->rowsum[rt]
                                                                               : 1.0;
        for (uint32_t b = 0; b < nb; b++) {
            const size_t x = (size_t)i * nb + b;
            const double tau = s->tau ? s->tau[x] : 0.0;
            const double cover = known ? (c[b] > 0.0 ? 1.0 / c[b] : 0.0) : 1.0;
            double add = (s->rho[x] * own + tau * through) * later[b] * cover;
            if (!swept) {
                add += s->rho[x] * (p->first[x] + spread[b]);
                if (t != RAD_NONE)
                    add += tau * (p->first[(size_t)t * nb + b] + spread[b]);
            }
            p->display[x] += add;
        }
    }
    rc = borrowed_sweeps(p, p->display, err);
    if (rc)
        return -rc;
    sv_progress pr = progress_of(p, e);
    pr.seconds = t - p->t0 - p->cb_seconds;
    pr.B = p->display;
    p->st->iterations = p->shots;
    const int stop = p->o->on_preview(p->o->user, &pr);
    p->cb_seconds += rad_seconds() - t; /* the estimate's making and the callback */
    return stop;
}

/* Previews and progress when their time or shot count has come; 1 when
 * the preview asks to stop, -code on an error. */
static int show(prog *p, rad_error *err)
{
    const sv_options *o = p->o;
    const double t = now_solving(p);
    if (o->progress && t >= p->next_progress_t) {
        sv_progress pr = progress_of(p, unshot_fraction(p));
        const double t1 = rad_seconds();
        o->progress(o->progress_user, &pr);
        p->cb_seconds += rad_seconds() - t1;
        p->next_progress_t = t + SV_PROGRESS_EVERY;
    }
    if (!p->display || p->shots == 0)
        return 0;
    int due = 0;
    if (o->preview_every)
        due = p->shots % o->preview_every == 0;
    if (t >= p->next_preview_t) {
        due = 1;
        p->next_preview_t = (floor(t / o->preview_seconds) + 1.0) * o->preview_seconds;
    }
    if (!o->preview_every && !(o->preview_seconds > 0.0))
        due = 1; /* a callback and no cadence: every shot */
    return due ? preview(p, err) : 0;
}

/* -------------------------------------------------------------- the loop */

/* The next shooter: the most unshot power (the lowest index on a tie); in
 * the last phase, the next patch that has not gathered yet.  RAD_NONE when
 * there is none. */
static uint32_t pick(prog *p, int last_phase)
{
    if (last_phase) {
        for (; p->scan < p->n; p->scan++)
            if (gathers(p, p->scan) && !(p->state[p->scan] & ST_GATHERED))
                return p->scan;
        return RAD_NONE;
    }
    /* One pass: the best, and the best whose rows are present. */
    uint32_t best = RAD_NONE, ready = RAD_NONE;
    double best_power = 0.0, ready_power = 0.0;
    const uint8_t *done = p->s->F->row_done;
    for (uint32_t i = 0; i < p->n; i++) {
        const double w = p->power[i];
        if (!(w > ready_power))
            continue;
        if (w > best_power) { /* strict: the lowest index wins a tie */
            best_power = w;
            best = i;
        }
        /* present: its own row, or none needed (no sheet), else ask */
        const int present = p->s->tau ? !missing_rows(p, i)
                                      : done[i] || (!p->refl[i] && (p->have_T || expects_column(p, i)));
        if (present) {
            ready_power = w;
            ready = i;
        }
    }
    if (best == ready || !p->o->need_rows)
        return best;
    /* Its rows are missing: shoot what the rows present allow first, while
     * it carries a fair share of the best's power (rows cost, shots not). */
    const double share = p->fits ? SV_READY_SHARE : SV_READY_SHARE_BOUNDED;
    return ready != RAD_NONE && ready_power * share >= best_power ? ready : best;
}

int sv_solve_progressive(const sv_system *s, const sv_options *o, double tol, double *B,
                         sv_stats *st, rad_error *err)
{
    prog p;
    int rc = prog_init(&p, s, o, tol, st, err);
    while (rc == RAD_OK) {
        const int stop = show(&p, err);
        if (stop < 0)
            rc = -stop;
        st->stopped = stop > 0;
        if (stop)
            break;
        double e = unshot_fraction(&p);
        if (e < tol)
            e = resum(&p); /* decide on fresh sums, not drifted ones */
        const int last_phase = e < tol;
        if (last_phase && p.pending == 0) {
            st->converged = 1;
            break;
        }
        if (p.shots >= p.max_shots)
            break;
        const uint32_t i = pick(&p, last_phase);
        if (i == RAD_NONE) { /* nothing left to shoot: exact */
            st->converged = p.pending == 0;
            break;
        }
        rc = shot(&p, i, last_phase, err);
    }
    st->iterations = p.shots;
    if (rc == RAD_OK) {
        st->estimated_error = resum(&p);
        rc = finish(&p, B, err);
    }
    st->preview_seconds = p.cb_seconds;
    if (rc == RAD_OK) {
        if (o->progress) {
            sv_progress pr = progress_of(&p, st->estimated_error);
            pr.done = 1;
            o->progress(o->progress_user, &pr);
        }
    }
    prog_free(&p);
    return rc;
}
