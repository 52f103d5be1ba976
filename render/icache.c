/* icache.c - Ward's irradiance cache (Ward, Rubinstein & Clear 1988): the
 * records of indirect irradiance, the octree that finds them, the weighted
 * average that reuses them, and the file that keeps them for the next view.
 *
 * A record i holds H_i at P_i on a surface of normal N_i, the harmonic mean
 * distance R_i its gather saw, Ward & Heckbert's (1992) gradients and
 * Zaninetti & Péroche's light vector direction D_i (rn_record).  At a
 * point P of normal N, record i weighs
 *     w_i(P) = 1 / (|P − P_i| / R_i + sqrt(1 − N·N_i))          (paper, eq. 5)
 * and takes part when w_i > 1/ε and P_i is not in front of P,
 *     d_i(P) = (P − P_i)·(N + N_i)/2 >= 0                       (eq. 6).
 * Its valid domain is a sphere of radius ε R_i, and it sits in the octree
 * node whose size s satisfies 2 ε R_i < s <= 4 ε R_i (the paper's rule), so
 * a search visits only the nodes within half their size of P.
 *
 * Invariants: every record has finite values, |N_i| = |D_i| = 1, R_i > 0,
 * H_i >= 0; next[] links each node's records; the octree, once prepared,
 * holds every record exactly once.  The file (RN_ICACHE_MAGIC, version 1)
 * ends with a 64-bit FNV-1a of everything before it and is written through
 * a rad_output.
 */
#include "rn_internal.h"

#include <errno.h>
#include <stdio.h>
#include <sys/stat.h>
#include <stdlib.h>
#include <string.h>

#define RN_ICACHE_MAGIC "RADICACH"
#define RN_ICACHE_VERSION 1u
#define RN_ICACHE_MAX_RECORDS 100000000ull
/* Deeper than any scene needs (a node of depth 40 is 1e-12 of the root). */
#define MAX_DEPTH 40

typedef struct onode {
    rad_vec3 c;          /* centre */
    double h;            /* half its side */
    uint32_t child[8];   /* node index, 0 = none (the root is node 0, never a child) */
    uint32_t first;      /* first record, RAD_NONE = none */
} onode;

struct rn_icache {
    uint64_t key;
    uint32_t bands;
    double epsilon;      /* the settings it was filled with (0 until settled) */
    uint32_t gather_rays;
    int gradients;
    double min_radius_px;
    uint64_t gathers, runs;
    rn_record *rec;
    uint32_t *next;      /* record -> next record of its node */
    uint64_t count, cap;
    onode *node;
    uint32_t nodes, node_cap; /* nodes == 0: not prepared */
    double tree_epsilon;
};

uint64_t rn_fnv(uint64_t h, const void *p, size_t n)
{
    const uint8_t *b = p;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

int rn_icache_create(uint64_t key, uint32_t bands, rn_icache **out, rad_error *err)
{
    *out = NULL;
    if (bands == 0 || bands > RAD_MAX_BANDS)
        return rad_fail(err, RAD_ERR_USAGE, "render: cache: %u bands, not 1..%d", bands,
                        RAD_MAX_BANDS);
    rn_icache *c = calloc(1, sizeof *c);
    if (!c)
        return rad_fail(err, RAD_ERR_NOMEM, "render: cache: out of memory");
    c->key = key;
    c->bands = bands;
    *out = c;
    return RAD_OK;
}

void rn_icache_destroy(rn_icache *c)
{
    if (!c)
        return;
    free(c->rec);
    free(c->next);
    free(c->node);
    free(c);
}

void rn_icache_settle(rn_icache *c, double epsilon, uint32_t gather_rays, int gradients,
                      double min_radius_px)
{
    c->epsilon = epsilon;
    c->gather_rays = gather_rays;
    c->gradients = gradients;
    c->min_radius_px = min_radius_px;
}

uint64_t rn_icache_key(const rn_icache *c) { return c->key; }
uint32_t rn_icache_bands(const rn_icache *c) { return c->bands; }
uint64_t rn_icache_size(const rn_icache *c) { return c->count; }

void rn_icache_count_run(rn_icache *c, uint64_t gathers)
{
    c->gathers += gathers;
    c->runs++;
}

void rn_icache_info_get(const rn_icache *c, rn_icache_info *out)
{
    memset(out, 0, sizeof *out);
    if (!c)
        return;
    out->key = c->key;
    out->bands = c->bands;
    out->epsilon = c->epsilon;
    out->gather_rays = c->gather_rays;
    out->gradients = c->gradients;
    out->min_radius_px = c->min_radius_px;
    out->records = c->count;
    out->gathers = c->gathers;
    out->runs = c->runs;
    double sum = 0;
    for (uint64_t i = 0; i < c->count; i++)
        sum += c->epsilon * c->rec[i].R;
    out->mean_radius = c->count ? sum / (double)c->count : 0.0;
}

/* ------------------------------------------------------------- octree */

static uint32_t new_node(rn_icache *c, rad_vec3 centre, double h)
{
    if (c->nodes == c->node_cap) {
        uint32_t cap = c->node_cap ? 2 * c->node_cap : 256;
        onode *n = realloc(c->node, (size_t)cap * sizeof *n);
        if (!n)
            return RAD_NONE;
        c->node = n;
        c->node_cap = cap;
    }
    onode *n = &c->node[c->nodes];
    memset(n, 0, sizeof *n);
    n->c = centre;
    n->h = h;
    n->first = RAD_NONE;
    return c->nodes++;
}

/* Links record i into the node of size in (2εR_i, 4εR_i] holding P_i
 * (the root when P_i lies outside it or the root is already that small). */
static int tree_add(rn_icache *c, uint32_t i)
{
    const rn_record *r = &c->rec[i];
    double radius = c->tree_epsilon * r->R;
    uint32_t at = 0;
    onode *n = &c->node[0];
    int inside = fabs(r->P.x - n->c.x) <= n->h && fabs(r->P.y - n->c.y) <= n->h &&
                 fabs(r->P.z - n->c.z) <= n->h;
    for (int depth = 0; inside && depth < MAX_DEPTH && c->node[at].h > 2.0 * radius; depth++) {
        n = &c->node[at];
        int k = (r->P.x > n->c.x) | (r->P.y > n->c.y) << 1 | (r->P.z > n->c.z) << 2;
        if (!n->child[k]) {
            double hh = 0.5 * n->h;
            rad_vec3 cc = rad_v3(n->c.x + (k & 1 ? hh : -hh), n->c.y + (k & 2 ? hh : -hh),
                                 n->c.z + (k & 4 ? hh : -hh));
            uint32_t made = new_node(c, cc, hh); /* may move c->node */
            if (made == RAD_NONE)
                return -1;
            c->node[at].child[k] = made;
        }
        at = c->node[at].child[k];
    }
    c->next[i] = c->node[at].first;
    c->node[at].first = i;
    return 0;
}

int rn_icache_prepare(rn_icache *c, rad_vec3 lo, rad_vec3 hi, double epsilon, rad_error *err)
{
    if (c->nodes)
        return RAD_OK;
    rad_vec3 centre = rad_scale(rad_add(lo, hi), 0.5);
    double h = 0.5 * fmax(hi.x - lo.x, fmax(hi.y - lo.y, hi.z - lo.z));
    h = h > 0.0 ? 1.01 * h : 1.0;
    c->tree_epsilon = epsilon;
    if (new_node(c, centre, h) == RAD_NONE)
        return rad_fail(err, RAD_ERR_NOMEM, "render: cache: out of memory");
    for (uint64_t i = 0; i < c->count; i++)
        if (tree_add(c, (uint32_t)i))
            return rad_fail(err, RAD_ERR_NOMEM, "render: cache: out of memory");
    return RAD_OK;
}

int rn_icache_insert(rn_icache *c, const rn_record *r, rad_error *err)
{
    RAD_ASSERT(c->nodes > 0);
    RAD_ASSERT(r->R > 0.0 && rad_finite3(r->P));
    if (c->count == c->cap) {
        uint64_t cap = c->cap ? 2 * c->cap : 1024;
        if (cap > RN_ICACHE_MAX_RECORDS)
            return rad_fail(err, RAD_ERR_LIMIT, "render: cache: more than %llu records",
                            (unsigned long long)RN_ICACHE_MAX_RECORDS);
        rn_record *rec = realloc(c->rec, (size_t)cap * sizeof *rec);
        if (rec)
            c->rec = rec;
        uint32_t *next = realloc(c->next, (size_t)cap * sizeof *next);
        if (next)
            c->next = next;
        if (!rec || !next)
            return rad_fail(err, RAD_ERR_NOMEM, "render: cache: out of memory");
        c->cap = cap;
    }
    c->rec[c->count] = *r;
    if (tree_add(c, (uint32_t)c->count))
        return rad_fail(err, RAD_ERR_NOMEM, "render: cache: out of memory");
    c->count++;
    return RAD_OK;
}

typedef struct lookup {
    const rn_icache *c;
    rad_vec3 P, N;
    double epsilon;
    int gradients;
    double wsum, H[RAD_MAX_BANDS];
    rad_vec3 D;
    uint32_t used;
} lookup;

static void look_node(lookup *q, uint32_t at)
{
    const onode *n = &q->c->node[at];
    for (uint32_t i = n->first; i != RAD_NONE; i = q->c->next[i]) {
        const rn_record *r = &q->c->rec[i];
        rad_vec3 d = rad_sub(q->P, r->P);
        double cn = rad_dot(q->N, r->N);
        double e = rad_length(d) / r->R + sqrt(fmax(0.0, 1.0 - cn));
        if (!(e < q->epsilon))
            continue;
        /* In front of P (eq. 6), beyond the rounding of points on one plane. */
        if (rad_dot(d, rad_add(q->N, r->N)) * 0.5 < -1e-6 * q->epsilon * r->R)
            continue;
        double w = e > 1e-12 ? 1.0 / e : 1e12;
        rad_vec3 rot = rad_cross(r->N, q->N);
        for (uint32_t b = 0; b < q->c->bands; b++) {
            double h = r->H[b];
            if (q->gradients)
                h += rad_dot(d, r->gt[b]) + rad_dot(rot, r->gr[b]);
            q->H[b] += w * h;
        }
        q->D = rad_add(q->D, rad_scale(r->D, w));
        q->wsum += w;
        q->used++;
    }
    for (int k = 0; k < 8; k++) {
        uint32_t ch = n->child[k];
        if (!ch)
            continue;
        const onode *m = &q->c->node[ch];
        /* Within half the child's size of its cube: 2h of its centre. */
        if (fabs(q->P.x - m->c.x) <= 2.0 * m->h && fabs(q->P.y - m->c.y) <= 2.0 * m->h &&
            fabs(q->P.z - m->c.z) <= 2.0 * m->h)
            look_node(q, ch);
    }
}

uint32_t rn_icache_lookup(const rn_icache *c, rad_vec3 P, rad_vec3 N, double epsilon,
                          int no_gradients, double *H, rad_vec3 *D)
{
    if (!c->nodes || !c->count)
        return 0;
    lookup q;
    memset(&q, 0, sizeof q);
    q.c = c;
    q.P = P;
    q.N = N;
    q.epsilon = epsilon;
    q.gradients = !no_gradients;
    look_node(&q, 0);
    if (!q.used)
        return 0;
    for (uint32_t b = 0; b < c->bands; b++) {
        double h = q.H[b] / q.wsum;
        H[b] = h > 0.0 ? h : 0.0; /* gradients may extrapolate below 0; NaN -> 0 too */
    }
    double l = rad_length(q.D);
    *D = l > 0.0 ? rad_scale(q.D, 1.0 / l) : N;
    return q.used;
}

/* --------------------------------------------------------------- file */

/* header: magic 8, version u32, bands u32, key u64, epsilon f64, gather
 * rays u32, gradients u32, gathers u64, runs u64, count u64, minimum
 * radius f64 = 72 bytes; then count records (P, N, D, R, then per band H,
 * gt, gr: f64 each); then the FNV-1a u64 of everything before. */
#define HEAD_BYTES 72u

static size_t record_bytes(uint32_t bands) { return 8u * (10u + 7u * bands); }

static uint8_t *put64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
    return p + 8;
}

static uint8_t *put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
    return p + 4;
}

static uint8_t *putd(uint8_t *p, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, 8);
    return put64(p, bits);
}

static uint8_t *putv(uint8_t *p, rad_vec3 v) { return putd(putd(putd(p, v.x), v.y), v.z); }

static uint64_t get64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = v << 8 | p[i];
    return v;
}

static uint32_t get32(const uint8_t *p) { return (uint32_t)(get64(p) & 0xffffffffu); }

static double getd(const uint8_t *p)
{
    uint64_t bits = get64(p);
    double v;
    memcpy(&v, &bits, 8);
    return v;
}

static rad_vec3 getv(const uint8_t *p) { return rad_v3(getd(p), getd(p + 8), getd(p + 16)); }

int rn_icache_write(const rn_icache *c, const char *path, rad_error *err)
{
    if (!c || !path)
        return rad_fail(err, RAD_ERR_USAGE, "render: cache: nothing to write");
    size_t rb = record_bytes(c->bands);
    uint8_t head[HEAD_BYTES], *p = head;
    memcpy(p, RN_ICACHE_MAGIC, 8);
    p = put32(p + 8, RN_ICACHE_VERSION);
    p = put32(p, c->bands);
    p = put64(p, c->key);
    p = putd(p, c->epsilon);
    p = put32(p, c->gather_rays);
    p = put32(p, (uint32_t)c->gradients);
    p = put64(p, c->gathers);
    p = put64(p, c->runs);
    p = put64(p, c->count);
    p = putd(p, c->min_radius_px);
    RAD_ASSERT(p == head + HEAD_BYTES);
    uint8_t *buf = malloc(rb);
    if (!buf)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", path);
    rad_output *o = NULL;
    int rc = rad_output_open(path, &o, err);
    if (rc) {
        free(buf);
        return rc;
    }
    uint64_t h = rn_fnv(RN_FNV_START, head, sizeof head);
    rad_output_write(o, head, sizeof head);
    for (uint64_t i = 0; i < c->count; i++) {
        const rn_record *r = &c->rec[i];
        uint8_t *q = putd(putv(putv(putv(buf, r->P), r->N), r->D), r->R);
        for (uint32_t b = 0; b < c->bands; b++)
            q = putv(putv(putd(q, r->H[b]), r->gt[b]), r->gr[b]);
        RAD_ASSERT(q == buf + rb);
        h = rn_fnv(h, buf, rb);
        rad_output_write(o, buf, rb);
    }
    uint8_t tail[8];
    put64(tail, h);
    rad_output_write(o, tail, 8);
    free(buf);
    return rad_output_commit(o, err);
}

static int unit(rad_vec3 v) { return rad_finite3(v) && fabs(rad_length(v) - 1.0) < 1e-6; }

/* Checks one decoded record; 0 when it obeys the invariants. */
static int record_bad(const rn_record *r, uint32_t bands)
{
    if (!rad_finite3(r->P) || !unit(r->N) || !unit(r->D) || !(r->R > 0.0) || !isfinite(r->R))
        return 1;
    for (uint32_t b = 0; b < bands; b++)
        if (!(r->H[b] >= 0.0) || !isfinite(r->H[b]) || !rad_finite3(r->gt[b]) ||
            !rad_finite3(r->gr[b]))
            return 1;
    return 0;
}

int rn_icache_read(const char *path, uint64_t key, rn_icache **out, rad_error *err)
{
    *out = NULL;
    FILE *f = fopen(path, "rb");
    if (!f)
        return rad_fail(err, RAD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    uint8_t head[HEAD_BYTES];
    if (fread(head, 1, sizeof head, f) != sizeof head || memcmp(head, RN_ICACHE_MAGIC, 8)) {
        fclose(f);
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: not an irradiance cache file", path);
    }
    uint32_t version = get32(head + 8), bands = get32(head + 12);
    uint64_t count = get64(head + 56);
    if (version != RN_ICACHE_VERSION || bands == 0 || bands > RAD_MAX_BANDS ||
        count > RN_ICACHE_MAX_RECORDS) {
        fclose(f);
        return rad_fail(err, RAD_ERR_CORRUPT,
                        "%s: cache version %u, %u bands, %llu records: not what this program "
                        "writes",
                        path, version, bands, (unsigned long long)count);
    }
    /* The records must fill the file exactly: checked before allocating, so
     * a damaged count cannot ask for more memory than the file holds. */
    uint64_t want = HEAD_BYTES + count * record_bytes(bands) + 8u;
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || (uint64_t)st.st_size != want) {
        fclose(f);
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: %llu records need %llu bytes, the file has %lld",
                        path, (unsigned long long)count, (unsigned long long)want,
                        (long long)st.st_size);
    }
    uint64_t file_key = get64(head + 16);
    if (key && file_key != key) {
        fclose(f);
        return rad_fail(err, RAD_ERR_INVALID,
                        "%s: made for another solution or other settings (key %016llx, these "
                        "need %016llx)",
                        path, (unsigned long long)file_key, (unsigned long long)key);
    }
    rn_icache *c = NULL;
    int rc = rn_icache_create(file_key, bands, &c, err);
    if (rc) {
        fclose(f);
        return rc;
    }
    c->epsilon = getd(head + 24);
    c->gather_rays = get32(head + 32);
    c->gradients = (int)get32(head + 36);
    c->gathers = get64(head + 40);
    c->runs = get64(head + 48);
    c->min_radius_px = getd(head + 64);
    size_t rb = record_bytes(bands);
    uint8_t buf[8u * (10u + 7u * RAD_MAX_BANDS)];
    c->cap = count ? count : 1;
    c->rec = malloc((size_t)c->cap * sizeof *c->rec);
    c->next = malloc((size_t)c->cap * sizeof *c->next);
    if (!c->rec || !c->next) {
        fclose(f);
        rn_icache_destroy(c);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for %llu records", path,
                        (unsigned long long)count);
    }
    uint64_t h = rn_fnv(RN_FNV_START, head, sizeof head);
    for (uint64_t i = 0; i < count; i++) {
        if (fread(buf, 1, rb, f) != rb) {
            fclose(f);
            rn_icache_destroy(c);
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated at record %llu of %llu", path,
                            (unsigned long long)i, (unsigned long long)count);
        }
        h = rn_fnv(h, buf, rb);
        rn_record *r = &c->rec[i];
        memset(r, 0, sizeof *r);
        r->P = getv(buf);
        r->N = getv(buf + 24);
        r->D = getv(buf + 48);
        r->R = getd(buf + 72);
        const uint8_t *q = buf + 80;
        for (uint32_t b = 0; b < bands; b++, q += 56) {
            r->H[b] = getd(q);
            r->gt[b] = getv(q + 8);
            r->gr[b] = getv(q + 32);
        }
    }
    uint8_t tail[8];
    size_t got = fread(tail, 1, sizeof tail, f);
    fclose(f);
    if (got != 8 || get64(tail) != h) {
        rn_icache_destroy(c);
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: %s", path,
                        got < 8 ? "truncated" : "checksum mismatch");
    }
    for (uint64_t i = 0; i < count; i++)
        if (record_bad(&c->rec[i], bands)) {
            rn_icache_destroy(c);
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: record %llu: bad values", path,
                            (unsigned long long)i);
        }
    if (!(c->epsilon > 0.0 && c->epsilon <= 1.0) && count) {
        double eps = c->epsilon;
        rn_icache_destroy(c);
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: epsilon %g outside (0, 1]", path, eps);
    }
    c->count = count;
    *out = c;
    return RAD_OK;
}
