/* rad.h - the vocabulary every module shares.
 *
 * Result codes and error values, 3-vectors, the patch mesh and the sparse
 * form-factor matrix.  Every other header includes this one and nothing here
 * depends on GL, files or any third-party library, so the solver, the
 * hemi-cube and the renderer can all speak about patches without seeing each
 * other.
 *
 * Symbols follow Cohen & Greenberg (1985): B radiosity, E emission, ρ (rho)
 * reflectance, F_ij form factor from patch i to patch j, A_i patch area.
 * Units: E and B are radiant exitance per band (power per unit area, in the
 * scene's own unit of power); images hold radiance L = B/π.
 */
#ifndef RAD_H
#define RAD_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define RAD_VERSION_STRING "0.1.0"

/* Bands are declared once per scene; three for RGB, one for grey. */
#define RAD_MAX_BANDS 16

/* "No index": a triangle patch's fourth vertex, an absent camera, ... */
#define RAD_NONE UINT32_MAX

/* ------------------------------------------------------------------ errors */

/* Errors are values.  A function that can fail returns one of these codes and,
 * when given a non-NULL rad_error, fills its message as "FILE: WHERE: WHAT"
 * (the caller prints it; only main prints or exits). */
typedef enum rad_result {
    RAD_OK = 0,
    RAD_ERR_IO,       /* a file could not be opened, read, written or renamed */
    RAD_ERR_PARSE,    /* malformed input: syntax, truncation, wrong types */
    RAD_ERR_INVALID,  /* well-formed input that breaks a rule (ρ >= 1, zero area, no emitter) */
    RAD_ERR_LIMIT,    /* the work would exceed a memory or size limit */
    RAD_ERR_NOMEM,    /* an allocation failed */
    RAD_ERR_GL,       /* OSMesa or GL failed */
    RAD_ERR_CORRUPT,  /* a solution file failed its checksum or structure checks */
    RAD_ERR_USAGE,    /* a caller passed bad arguments (API misuse or command line) */
    RAD_ERR_NOTFOUND, /* a named object, material or camera does not exist */
    RAD_ERR_INTERRUPTED /* the caller asked the work to stop (Ctrl-C); what was done is kept */
} rad_result;

typedef struct rad_error {
    int code;          /* a rad_result */
    char message[1024];
} rad_error;

/* Fills err (if not NULL) with code and a printf-formatted message; returns
 * code, so that `return rad_fail(err, RAD_ERR_IO, "%s: cannot open", p);` reads
 * naturally. */
int rad_fail(rad_error *err, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Warnings: something was ignored, clamped or stopped early that the user
 * should know about, while the work goes on.  The library never prints:
 * a function that may warn takes a rad_warn_fn (with its user pointer) in
 * its options struct, NULL dropping the warnings.  A message has an error's
 * form, "FILE: WHERE: WHAT", one line, no trailing newline; the program
 * prints it as "radiosity: warning: MESSAGE". */
typedef void (*rad_warn_fn)(void *user, const char *message);

/* Formats a warning and hands it to fn (nothing when fn is NULL). */
void rad_warn(rad_warn_fn fn, void *user, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Short English name of a result code ("I/O error", ...). */
const char *rad_result_name(int code);

/* RAD_ASSERT is for bugs, never for input: input errors are rad_result values.
 * Active in debug builds (no NDEBUG); the test build keeps it on. */
#ifndef NDEBUG
void rad_assert_fail(const char *expr, const char *file, int line);
#define RAD_ASSERT(e) ((e) ? (void)0 : rad_assert_fail(#e, __FILE__, __LINE__))
#define RAD_DEBUG 1
#else
#define RAD_ASSERT(e) ((void)0)
#define RAD_DEBUG 0
#endif

/* ----------------------------------------------------------------- vectors */

typedef struct rad_vec3 {
    double x, y, z;
} rad_vec3;

static inline rad_vec3 rad_v3(double x, double y, double z) { rad_vec3 r = {x, y, z}; return r; }
static inline rad_vec3 rad_add(rad_vec3 a, rad_vec3 b) { return rad_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline rad_vec3 rad_sub(rad_vec3 a, rad_vec3 b) { return rad_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline rad_vec3 rad_scale(rad_vec3 a, double s) { return rad_v3(a.x * s, a.y * s, a.z * s); }
static inline double rad_dot(rad_vec3 a, rad_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline rad_vec3 rad_cross(rad_vec3 a, rad_vec3 b)
{
    return rad_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double rad_length(rad_vec3 a) { return sqrt(rad_dot(a, a)); }
/* Unit vector; the zero vector stays zero (callers reject degenerate input first). */
static inline rad_vec3 rad_normalize(rad_vec3 a)
{
    double l = rad_length(a);
    return l > 0.0 ? rad_scale(a, 1.0 / l) : a;
}
static inline rad_vec3 rad_lerp(rad_vec3 a, rad_vec3 b, double t)
{
    return rad_v3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t);
}
static inline int rad_finite3(rad_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
/* Point ap (relative to a line's start) on the line along ab, l2 = |ab|²:
 * its parameter u (ab·u is its foot), and into *d2 its squared distance
 * from the line.  The mesher's and the drawing's T-junction tests. */
static inline double rad_line_foot(rad_vec3 ap, rad_vec3 ab, double l2, double *d2)
{
    const double u = rad_dot(ap, ab) / l2;
    const rad_vec3 off = rad_sub(ap, rad_scale(ab, u));
    *d2 = rad_dot(off, off);
    return u;
}

/* ------------------------------------------------------------------- bands */

/* Is some band of v[0..bands) > 0?  An emitter's E, a light's I: what makes
 * a source. */
static inline int rad_any_positive(const double *v, uint32_t bands)
{
    for (uint32_t b = 0; b < bands; b++)
        if (v[b] > 0.0)
            return 1;
    return 0;
}

/* -------------------------------------------------------------------- mesh */

/* A patch: the unit of the radiosity solution.  It is a planar convex quad
 * (bilinear cell of a polygon's n×m grid) or a triangle (cell of a regular
 * triangle subdivision), with vertices counter-clockwise seen from the side
 * its normal points to.  Invariants: area > 0, |normal| = 1, centre inside. */
typedef struct rad_patch {
    uint32_t v[4];     /* vertex indices; v[3] == RAD_NONE for a triangle */
    uint32_t polygon;  /* owning scene polygon */
    uint32_t object;   /* owning scene object */
    uint32_t material; /* scene material (ρ, E per band) */
    rad_vec3 center;   /* area centroid: where the hemi-cube sits */
    rad_vec3 normal;   /* unit normal of the polygon's plane */
    double area;       /* A_i */
} rad_patch;

/* The conforming patch mesh.  Vertices are shared by the patches of one
 * side of one polygon and never across polygons, because a vertex's
 * radiosity is an average within its polygon.  vertex_boundary[k] is 1 when
 * vertex k lies on its polygon's outline (its radiosity is extrapolated, not
 * averaged).
 *
 * Two-sided cells: a polygon whose material transmits diffusely is a thin
 * sheet with two surfaces.  Its front cells are followed by their back
 * twins, the same cells in the same order facing the other way (reversed
 * corners, normal -n, vertices of their own).  twin[i] is the patch on the
 * other side of patch i, RAD_NONE for a one-sided patch; twin is NULL when
 * no patch has one.  Invariant: twin[twin[i]] == i, same centre and area,
 * opposite normals. */
typedef struct rad_mesh {
    rad_vec3 *vertices;
    uint8_t *vertex_boundary;
    uint32_t vertex_count;
    rad_patch *patches;
    uint32_t patch_count;
    uint32_t *twin;          /* patch_count entries or NULL (owned) */
    /* Clusters: a patch may span several cells, the small polygons of one
     * object and material that the mesher grouped (mesh.h).  cell_first is
     * NULL when every patch is a single cell, itself.  Otherwise patch i
     * covers cells[cell_first[i] .. cell_first[i + 1]) (cells of one patch
     * consecutive, in patch order): planar convex cells with their own
     * corners, polygon, normal, centre and area, as a patch has.  A patch
     * of one cell is that cell; a patch of several has their object and
     * material, A_i = Σ cell areas, the unit area-weighted mean of their
     * normals, its centre on one of them (its `home` cell, whose corners
     * and polygon it carries in v[] and polygon).  The cells of one surface
     * (neighbouring small polygons whose normals agree) share vertices
     * across polygons, so their radiosities average together as a
     * polygon's do. */
    rad_patch *cells;        /* cell_count entries or NULL (owned) */
    uint32_t cell_count;
    uint32_t *cell_first;    /* patch_count + 1 entries or NULL (owned) */
} rad_mesh;

/* Number of corners of a patch: 3 or 4. */
static inline int rad_patch_corners(const rad_patch *p) { return p->v[3] == RAD_NONE ? 3 : 4; }

/* The cells of patch i: a pointer to the first and their number (the patch
 * itself, one cell, when the mesh has no clusters). */
static inline uint32_t rad_patch_cells(const rad_mesh *m, uint32_t i, const rad_patch **first)
{
    if (!m->cell_first) {
        *first = &m->patches[i];
        return 1;
    }
    *first = m->cells + m->cell_first[i];
    return m->cell_first[i + 1] - m->cell_first[i];
}

/* Marks the shared patches of small parts (mesh/parts.c): patches of two or
 * more cells of which no two share a vertex, since each part's faces keep
 * vertices of their own, where the cells of a region, cluster or curved
 * patch are joined through theirs.  shared: patch_count bytes (the
 * caller's), each set to 1 or 0.  RAD_OK, or RAD_ERR_NOMEM. */
int rad_mesh_shared_parts(const rad_mesh *m, uint8_t *shared);

/* ------------------------------------------------------- form-factor matrix */

/* The form-factor matrix F, stored by rows with the null entries compressed
 * (the paper's suggestion).  Rows can be filled in any order and some may be
 * missing: the progressive solver computes rows on demand and a relight
 * reuses whichever rows exist.  Row i holds (j, F_ij) pairs with strictly
 * increasing j, j != i, F_ij > 0.
 *
 * The rows are kept packed, in the very form a solution file stores them
 * (docs/solution-format.md, "Row records"), so that a matrix read from a file
 * is its file's bytes and nothing more, and a matrix being computed can be
 * streamed to a file row by row.  Each row is a record appended to one pool,
 *   u32 i, u32 c, c × f32 F_ij (little-endian), c × varint column gaps
 * (the first column, then j_k - j_{k-1} >= 1: unsigned LEB128, most gaps
 * between the patches a patch sees take one byte).  About 5 bytes an entry
 * instead of 8 for (u32, f32) pairs.  row_start[i] is the offset of row i's
 * values in the pool; a row set again is appended and the old copy
 * abandoned.  Read rows with rad_matrix_row / rad_row_next (or
 * rad_matrix_get_row into arrays).
 *
 * A matrix may also hold only which rows exist and their entry counts
 * (entries_loaded = 0): what a command that never reads F gets from a
 * solution file (the renderer needs to know which rows are empty, not
 * what is in them).
 *
 * Invariants (checked by rad_matrix_check in debug builds):
 *   0 < F_ij, Σ_j F_ij <= 1 + 1e-3 for every row, no NaN, j < n, j != i. */
typedef struct rad_matrix rad_matrix;

/* Called with each row record as rad_matrix_set_row stores it (the bytes
 * above, starting at u32 i): how a solve streams its rows to a file.  A
 * non-zero return (with err filled) fails the rad_matrix_set_row call; the
 * row stays stored. */
typedef int (*rad_row_sink)(void *user, uint32_t i, const uint8_t *record, size_t bytes,
                            rad_error *err);

struct rad_matrix {
    uint32_t n;          /* patches: rows = columns */
    uint32_t rows_done;  /* rows present */
    uint8_t *row_done;   /* row_done[i] = 1 when row i is present */
    uint64_t *row_start; /* offset in data of row i's values (its record + 8) */
    uint32_t *row_count; /* entries of row i */
    uint8_t *data;       /* the pool of row records (NULL until the first) */
    uint64_t bytes;      /* bytes of data used */
    uint64_t capacity;   /* bytes of data allocated */
    uint64_t nnz;        /* entries of the rows present */
    int entries_loaded;  /* 0: row_done and row_count only, no entries (see above) */
    uint64_t key;        /* what determined the rows (rad_rows_key in solution.h), 0 unknown */
    rad_row_sink sink;   /* NULL, or where new rows are also sent */
    void *sink_user;
};

/* Creates an empty n×n matrix (no rows present).  Caller owns the result and
 * frees it with rad_matrix_destroy.  Returns NULL when memory runs out. */
rad_matrix *rad_matrix_create(uint32_t n);
void rad_matrix_destroy(rad_matrix *m); /* NULL does nothing */

/* Frees the entries and keeps which rows exist and their counts
 * (entries_loaded = 0, as a matrix read without its entries): for when
 * the rows are safe in a file (rad_journal_holds) and nothing left to do
 * in memory reads them.  NULL does nothing. */
void rad_matrix_release_entries(rad_matrix *m);

/* Stores row i (replacing any earlier copy).  col must be strictly increasing.
 * Encodes the data; returns RAD_OK or RAD_ERR_NOMEM / RAD_ERR_USAGE, or what
 * the sink returns. */
int rad_matrix_set_row(rad_matrix *m, uint32_t i, uint32_t count, const uint32_t *col,
                       const float *val, rad_error *err);

/* Row i for reading: its entry count and where its packed values and
 * columns start.  A missing row reads as empty. */
typedef struct rad_row {
    uint32_t count;
    const uint8_t *val; /* count × f32 */
    const uint8_t *col; /* count varints: the first column, then the gaps */
} rad_row;

static inline rad_row rad_matrix_row(const rad_matrix *m, uint32_t i)
{
    rad_row r = {0, NULL, NULL};
    if (m->row_done[i] && m->row_count[i] && m->data) {
        r.count = m->row_count[i];
        r.val = m->data + m->row_start[i];
        r.col = r.val + 4 * (size_t)r.count;
    }
    return r;
}

/* F of entry k of a row. */
static inline float rad_row_value(const rad_row *r, uint32_t k)
{
    float f;
    memcpy(&f, r->val + 4 * (size_t)k, sizeof f);
    return f;
}

/* The next column of a row being walked: *p moves past one varint gap,
 * returned as prev + gap (pass prev = 0 for the first entry, whose varint
 * is the column itself).  Only for rows of a matrix (checked on the way in). */
static inline uint32_t rad_row_next(const uint8_t **p, uint32_t prev)
{
    const uint8_t *q = *p;
    uint32_t v = q[0];
    if (v < 0x80) {
        *p = q + 1;
        return prev + v;
    }
    v &= 0x7f;
    for (int s = 7;; s += 7) {
        uint32_t b = *++q;
        v |= (b & 0x7f) << s;
        if (b < 0x80)
            break;
    }
    *p = q + 1;
    return prev + v;
}

/* Writes v as an unsigned LEB128 varint (7 bits a byte, low bits first,
 * the high bit set on every byte but the last) into out; returns its 1 to 5
 * bytes.  The one encoder of the format's varints. */
size_t rad_varint_put(uint8_t out[5], uint32_t v);

/* Decodes row i into col[] and val[] (caller's buffers of row_count[i]
 * entries each; either may be NULL); returns its entry count (0 for a
 * missing row). */
uint32_t rad_matrix_get_row(const rad_matrix *m, uint32_t i, uint32_t *col, float *val);

/* Σ_j F_ij of a present row (0 for a missing one). */
double rad_matrix_row_sum(const rad_matrix *m, uint32_t i);

/* Bytes of row i's record (0 for a missing row): 8 + 4c + its varints. */
uint64_t rad_matrix_record_bytes(const rad_matrix *m, uint32_t i);

/* Room for `more` bytes past the pool's end; returns where they go (the
 * caller writes records there and then calls rad_matrix_add_records), or
 * NULL with err filled (RAD_ERR_NOMEM / RAD_ERR_LIMIT). */
uint8_t *rad_matrix_reserve(rad_matrix *m, uint64_t more, rad_error *err);

/* Indexes the row records the caller wrote in data[bytes, bytes + len)
 * (after rad_matrix_reserve): every record is checked - bounds, row index
 * below n and not already present, columns strictly increasing below n and
 * never i, values finite and > 0, Σ_j F_ij <= 1 + 1e-3 - and that they are
 * exactly `rows` records, and only then are the rows made present.
 * Nothing is indexed on failure: RAD_ERR_CORRUPT with "row I: WHAT", and
 * *at (when not NULL) the offset within the len bytes of the record at
 * fault. */
int rad_matrix_add_records(rad_matrix *m, uint64_t len, uint64_t rows, uint64_t *at,
                           rad_error *err);

/* A bounded row store (the progressive solver under --max-memory): rows
 * are dropped and the pool compacted, so that the matrix never holds more
 * than its budget.  Bytes are the pool's, the one part of the matrix that
 * grows with the rows (the per-row index is n-sized and fixed). */

/* Bytes the pool has allocated. */
uint64_t rad_matrix_pool_bytes(const rad_matrix *m);
/* Bytes of the pool in use: the rows present and abandoned copies. */
uint64_t rad_matrix_used_bytes(const rad_matrix *m);
/* Bytes the rows present take in the pool (what compaction keeps). */
uint64_t rad_matrix_live_bytes(const rad_matrix *m);
/* Bytes a row of `count` entries may take in the pool, at most. */
uint64_t rad_matrix_row_bytes(uint32_t count);
/* Bytes of the per-row index of n rows (row_start, row_count, row_done):
 * the part of a matrix that does not grow with its entries. */
uint64_t rad_matrix_index_bytes(uint32_t n);
/* Removes row i: it reads as missing again (row_done 0).  Its record stays
 * in the pool, abandoned, until rad_matrix_compact. */
void rad_matrix_drop_row(rad_matrix *m, uint32_t i);
/* Moves the records present to the front of the pool, in pool order, dropping
 * abandoned copies, and sizes the pool to hold exactly max(bytes, what the
 * rows present take): a row store under a budget reserves the budget once
 * and never grows past it.  RAD_OK, or RAD_ERR_NOMEM with the matrix
 * compacted but its pool's size unchanged. */
int rad_matrix_compact(rad_matrix *m, uint64_t bytes, rad_error *err);

/* Bytes a matrix of n patches needs when a fraction `fill` of entries is
 * non-zero: what the memory checks use before allocating. */
uint64_t rad_matrix_estimate_bytes(uint32_t n, double fill);

/* Checks the invariants above; RAD_OK or RAD_ERR_CORRUPT with the first
 * offending row in the message. */
int rad_matrix_check(const rad_matrix *m, rad_error *err);

/* --------------------------------------------------------------- geometry */

/* F from the differential element at p with unit normal n to the planar
 * polygon poly[0..count) (either winding), by Lambert's contour integral
 * over the part of the polygon in front of the element:
 *   F = 1/(2π) |Σ_k β_k n·unit(r_k × r_{k+1})|,  r_k = P_k − p.
 * E·F is the irradiance at p from a Lambertian polygon of exitance E with
 * nothing in between.  In [0, 1]; NAN for non-finite input or n = 0; 0
 * for fewer than 3 corners. */
double rad_point_polygon_factor(rad_vec3 p, rad_vec3 n, const rad_vec3 *poly, uint32_t count);

/* The same factor to a surface given as directed edges edges[0..count)
 * (x0 y0 z0 x1 y1 z1 each): the outline of cells sharing their inner edges,
 * each inner edge once each way, or those alone (they cancel).  No
 * clipping: every end point must lie strictly in front of p (r·n > 0) and p
 * in front of every cell the edges bound; the caller checks.  In [0, 1];
 * NAN for non-finite p or n, or n = 0. */
double rad_point_edges_factor(rad_vec3 p, rad_vec3 n, const double *edges, uint32_t count);

/* -------------------------------------------------------------- text lines */

/* The small text formats (the polygon file, a variations file, a camera
 * path) are read from memory line by line (lines.c): a line ends at '\n'
 * or at the text's end (a final '\n' starts no further line), and '#'
 * starts a comment that runs to the line's end.  Nothing is copied: a line
 * points into the caller's text, NUL bytes included (each format says what
 * it makes of them). */
typedef struct rad_line {
    const char *text;          /* its first byte, in the caller's text */
    size_t length;             /* bytes before its '\n' */
    size_t content;            /* bytes before its comment (its first '#'), <= length */
    unsigned long long number; /* 1 for the first line */
} rad_line;

typedef struct rad_lines {
    const char *p, *end;       /* the text not yet read */
    unsigned long long number; /* lines returned so far */
} rad_lines;

/* A reader of text[0..size) (text may be NULL when size is 0). */
void rad_lines_start(rad_lines *r, const char *text, size_t size);

/* The next line into *line: 1, or 0 at the end of the text. */
int rad_lines_next(rad_lines *r, rad_line *line);

/* ------------------------------------------------------------------ memory */

/* Physical memory the system reports as available, in bytes (0 if unknown). */
uint64_t rad_available_memory(void);

/* This process's resident memory in bytes: now (peak 0) or the most it has
 * had (peak 1, the high-water mark); 0 if unknown. */
uint64_t rad_process_memory(int peak);

/* "12.3 MiB", "4.5 GiB": a size for messages, in a unit that shows digits;
 * returns buf. */
const char *rad_human_bytes(double bytes, char *buf, size_t size);

/* Wall-clock seconds from a monotonic clock, for stage timings. */
double rad_seconds(void);

/* ------------------------------------------------------------ output files */

/* Every file the program writes goes through a rad_output: the bytes go to
 * a temporary file beside the target ("PATH.tmp.PID"), and only
 * rad_output_commit, once everything is written and synced, renames it onto
 * PATH.  A failure at any point leaves PATH exactly as it was and no
 * temporary behind, so no command ever loses a good file.  Writes record
 * their first error; commit reports it ("PATH: cannot write TMP: why"). */
typedef struct rad_output rad_output;

/* Creates the temporary file for path.  Caller owns *out: it must end with
 * rad_output_commit or rad_output_abort. */
int rad_output_open(const char *path, rad_output **out, rad_error *err);

/* Appends n bytes (0 on success, -1 once any write has failed). */
int rad_output_write(rad_output *o, const void *p, size_t n);

/* Writes n bytes at offset `at` without moving the append position (a
 * header patched once the payload is through). */
int rad_output_write_at(rad_output *o, const void *p, size_t n, uint64_t at);

/* Bytes appended so far. */
uint64_t rad_output_size(const rad_output *o);

/* The target and temporary paths, for messages. */
const char *rad_output_path(const rad_output *o);
const char *rad_output_temp(const rad_output *o);

/* Syncs, closes and renames the temporary onto the target, then syncs the
 * directory.  On any failure (including an earlier write's) removes the
 * temporary and reports why.  Frees o either way. */
int rad_output_commit(rad_output *o, rad_error *err);

/* Removes the temporary and frees o (a partial output is kept).  NULL does
 * nothing. */
void rad_output_abort(rad_output *o);

/* A committer syncs and renames outputs on a thread of its own, in the
 * order given, while the caller goes on: a view's files reach the disk
 * while the next view is drawn (a 12 MB EXR's sync takes 15-30 ms that
 * cost no CPU).  rad_committer_finish waits for every output handed over
 * and reports the first that failed, as rad_output_commit would have. */
typedef struct rad_committer rad_committer;

/* Starts a committer (its thread).  Caller owns *out: it must end with
 * rad_committer_finish. */
int rad_committer_create(rad_committer **out, rad_error *err);

/* Hands o, its bytes written, to c to be committed; takes o either way.
 * c NULL, or a committer that cannot take it (out of memory), commits now:
 * the result is rad_output_commit's.  Else RAD_OK: a later failure comes
 * from rad_committer_finish. */
int rad_output_commit_later(rad_output *o, rad_committer *c, rad_error *err);

/* Waits until every output handed to c is committed, stops its thread and
 * frees it; RAD_OK, or the first commit that failed (the others went on).
 * NULL: RAD_OK. */
int rad_committer_finish(rad_committer *c, rad_error *err);

/* A partial output: work that must survive this process (a solve's rows,
 * kept for the next run if this one is killed) goes to "PATH.partial",
 * which no failure removes and only rad_output_commit renames onto PATH.
 * Opens it (creating it when absent) under an exclusive lock - another
 * process writing it is an error - with the append position at its end;
 * *size receives its current size. */
int rad_output_open_partial(const char *path, rad_output **out, uint64_t *size, rad_error *err);

/* Reads n bytes at offset `at` of the output's file (a partial's earlier
 * contents): 0, or -1 when they are not all there. */
int rad_output_read_at(rad_output *o, void *p, size_t n, uint64_t at);

/* Cuts the file to `size` bytes and moves the append position there. */
int rad_output_truncate(rad_output *o, uint64_t size);

/* Makes what is written so far durable (fdatasync). */
int rad_output_sync(rad_output *o);

/* RAD_OK, or the first failed operation as rad_output_commit would report it. */
int rad_output_error(const rad_output *o, rad_error *err);

/* Closes a partial output and frees o, keeping its file.  NULL does nothing. */
void rad_output_keep(rad_output *o);

/* Removes the output's file, a partial one too, and frees o (a partial
 * that holds nothing worth keeping).  NULL does nothing. */
void rad_output_drop(rad_output *o);

/* Makes `path` a new name (hard link) of the existing file `existing`,
 * atomically replacing whatever path named (a temporary link renamed onto
 * it).  RAD_ERR_IO when the file system refuses (another device, no hard
 * links, permissions). */
int rad_output_link(const char *existing, const char *path, rad_error *err);

#endif /* RAD_H */
