/* read.c - reading a solution file (docs/solution-format.md): the header,
 * then for versions 6 and 7 the index and only the sections asked for, each
 * checked against its own CRC, the matrix read straight into F's pool or
 * taken from the file a MATRIXREF names; for versions 1-5 the whole payload
 * under its one CRC.  parse.c parses the sections.
 *
 * Invariant: whatever the bytes, a read either fails with a message naming
 * the file (and the section and element where there is one) or returns a
 * solution that satisfies solution.h.  No section is trusted before its
 * CRC matched (unless the caller turned checksums off), and a matrix from
 * another file is used only if that file's MATRIX section is, byte for
 * byte by its CRC and length, the one the reference names.
 */
#include "solfile_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* --------------------------------------------------------------- header */

/* The header's fields (the meaning of the last two depends on the version). */
typedef struct sol_head {
    uint32_t version;
    uint64_t a;  /* versions 1-5: payload size; 6: the index's offset */
    uint64_t b;  /* versions 1-5: payload CRC; 6: the index's CRC */
} sol_head;

/* Magic, version, reserved field; `size` is the file's. */
static int check_header(const uint8_t *d, uint64_t size, const char *name, sol_head *h,
                        rad_error *err)
{
    size_t m = size < 8 ? (size_t)size : 8;
    if (size == 0 || memcmp(d, SOL_MAGIC, m) != 0)
        return rad_fail(err, RAD_ERR_PARSE, "%s: not a radiosity solution file", name);
    if (size < SOL_HEADER_BYTES)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated: %llu of at least %u bytes", name,
                        (unsigned long long)size, SOL_HEADER_BYTES);
    h->version = (uint32_t)sol_load_le64(d + 8);
    uint32_t reserved = (uint32_t)(sol_load_le64(d + 8) >> 32);
    h->a = sol_load_le64(d + 16);
    h->b = sol_load_le64(d + 24);
    if (h->version > SOL_VERSION)
        return rad_fail(err, RAD_ERR_PARSE, "%s: format version %u is newer than this program (%u)",
                        name, h->version, SOL_VERSION);
    if (h->version == 0)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: format version 0 does not exist", name);
    if (reserved != 0)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: reserved header field is %u, not 0", name,
                        reserved);
    return RAD_OK;
}

/* ------------------------------------------------------ versions 1 to 5 */

static int known_section(const uint8_t tag[4], int count)
{
    for (int i = 0; i < count; i++)
        if (memcmp(tag, sol_sec_tag[i], 4) == 0)
            return i;
    return -1;
}

/* The payload's size and CRC against the header's. */
static int check_payload(const uint8_t *d, size_t size, const char *name, const sol_head *h,
                         int check_sum, rad_error *err)
{
    uint64_t have = size - SOL_HEADER_BYTES, payload = h->a;
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
        if (got != h->b)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: checksum mismatch: the file is corrupt",
                            name);
    }
    return RAD_OK;
}

/* Version 5 skips the optional sections INFO did not announce; version 3
 * without lights goes from PATCHDATA to ELEMENTS. */
static int next_expected(const sol_reader *r, const rad_solution *s, int next, int k)
{
    if (k == SEC_ELEMENTS && next == SEC_LIGHTS && r->version == 3 && s->scene &&
        s->scene->light_count == 0)
        next = SEC_ELEMENTS;
    while (r->version >= SOL_VERSION_SHEETS && next >= SEC_LIGHTS && next < k &&
           !sol_announced(r, next))
        next++;
    return next;
}

/* One section of a version 1-5 payload at `all`, in its place in the order. */
static int payload_section(sol_reader *r, rad_solution *s, sol_cursor *all, size_t size,
                           int *next)
{
    const char *name = r->name;
    size_t offset = size - all->left;
    uint8_t tag[4];
    uint64_t len;
    r->section = "header";
    if (!sol_get_bytes(all, tag, 4) || !sol_get_u64(all, &len))
        return rad_fail(r->err, RAD_ERR_CORRUPT, "%s: byte %zu: section header truncated", name,
                        offset);
    int k = known_section(tag, SEC_COUNT);
    if (len > all->left)
        return rad_fail(r->err, RAD_ERR_CORRUPT,
                        "%s: byte %zu: section %s: length %llu exceeds the %zu bytes left", name,
                        offset, k >= 0 ? sol_sec_name[k] : "(unknown)", (unsigned long long)len,
                        all->left);
    if (k >= sol_version_sections[r->version])
        return rad_fail(r->err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s in a version %u file",
                        name, offset, sol_sec_name[k], r->version);
    if (k < 0) { /* a section from a later version of the format: skip it */
        all->p += len;
        all->left -= (size_t)len;
        return RAD_OK;
    }
    *next = next_expected(r, s, *next, k);
    if (r->version >= SOL_VERSION_SHEETS && k >= SEC_LIGHTS && !sol_announced(r, k))
        return rad_fail(r->err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s not announced in INFO",
                        name, offset, sol_sec_name[k]);
    if (k != *next) {
        if (k < *next)
            return rad_fail(r->err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s appears twice",
                            name, offset, sol_sec_name[k]);
        return rad_fail(r->err, RAD_ERR_CORRUPT, "%s: byte %zu: section %s missing before %s",
                        name, offset, sol_sec_name[*next], sol_sec_name[k]);
    }
    r->c.p = all->p;
    r->c.left = (size_t)len;
    int rc = sol_parse_section(r, k, s);
    all->p += len;
    all->left -= (size_t)len;
    (*next)++;
    return rc;
}

/* Versions 1-5: tagged sections one after another, in a fixed order.
 * Version 2 is exactly the files with lights: LIGHTS is required there and
 * has no place in version 1 (a cut at its start must not pass).  Version 3
 * is the files with elements: ELEMENTS is required, LIGHTS there exactly
 * when the scene has lights.  Version 4: LIGHTS, ELEMENTS and ELEMENTLIGHTS
 * all required.  Version 5: those INFO announces. */
static int parse_payload(sol_reader *r, rad_solution *s, const uint8_t *d, size_t size)
{
    sol_cursor all = {d + SOL_HEADER_BYTES, size - SOL_HEADER_BYTES};
    int next = 0, rc = RAD_OK;
    while (all.left > 0 && !rc)
        rc = payload_section(r, s, &all, size, &next);
    if (rc)
        return rc;
    const int required = sol_version_sections[r->version];
    while (r->version >= SOL_VERSION_SHEETS && next >= SEC_LIGHTS && next < SEC_COUNT_V5 &&
           !sol_announced(r, next))
        next++;
    if (next < required)
        return rad_fail(r->err, RAD_ERR_CORRUPT, "%s: section %s missing", r->name,
                        sol_sec_name[next]);
    return RAD_OK;
}

/* ----------------------------------------------------- version 6: index */

/* The index, checked: sections laid end to end from the header to the
 * index, known tags at most once, the required ones present. */
typedef struct sol_index {
    uint32_t count;
    sol_index_entry e[SOL_MAX_SECTIONS];
    int at[SEC_COUNT];   /* entry of each known section, -1 when absent */
    uint64_t id;         /* the index's CRC: the file's content */
} sol_index;

/* Where the index is and how long, from the header and the file's size. */
static int index_extent(const sol_head *h, uint64_t size, const char *name, uint64_t *len,
                        rad_error *err)
{
    if (h->a == 0)
        return rad_fail(err, RAD_ERR_CORRUPT,
                        "%s: unfinished: the solve writing it stopped before the end (run it "
                        "again to finish it)", name);
    if (h->a < SOL_HEADER_BYTES || h->a > size || size - h->a < SOL_INDEX_HEAD)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated: %llu bytes, the index starts at %llu",
                        name, (unsigned long long)size, (unsigned long long)h->a);
    *len = size - h->a;
    return RAD_OK;
}

/* The index of a file of header h.  Its second u32 is 0 in version 6 and
 * the version from 7 on: the header's version under the index's CRC, so
 * that no flip of it passes (a version 7 file without elements reads the
 * same as version 6). */
static int parse_index(const uint8_t *d, uint64_t len, const sol_head *h, const char *name,
                       int check_sum, sol_index *x, rad_error *err)
{
    const uint64_t at = h->a, crc = h->b;
    uint32_t count = (uint32_t)sol_load_le64(d), reserved = (uint32_t)(sol_load_le64(d) >> 32);
    uint32_t want = h->version >= SOL_VERSION_ELEMENT_ROWS ? h->version : 0;
    if (count < 1 || count > SOL_MAX_SECTIONS || reserved != want)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: index: %u sections (1..%u), version field %u "
                        "(%u)", name, count, SOL_MAX_SECTIONS, reserved, want);
    uint64_t need = SOL_INDEX_HEAD + (uint64_t)count * SOL_INDEX_ENTRY;
    if (len < need)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated: %llu of %llu bytes", name,
                        (unsigned long long)(at + len), (unsigned long long)(at + need));
    if (len > need)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: %llu unexpected bytes after the index", name,
                        (unsigned long long)(len - need));
    x->id = 0;
    if (!sol_crc64_of(d, (size_t)len, &x->id))
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", name);
    if (check_sum && x->id != crc)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: index: checksum mismatch: the file is corrupt",
                        name);
    x->count = count;
    for (int k = 0; k < SEC_COUNT; k++)
        x->at[k] = -1;
    uint64_t end = SOL_HEADER_BYTES;
    for (uint32_t q = 0; q < count; q++) {
        const uint8_t *p = d + SOL_INDEX_HEAD + (size_t)q * SOL_INDEX_ENTRY;
        sol_index_entry *e = &x->e[q];
        memcpy(e->tag, p, 4);
        e->offset = sol_load_le64(p + 8);
        e->length = sol_load_le64(p + 16);
        e->crc = sol_load_le64(p + 24);
        int k = known_section(p, SEC_COUNT);
        const char *what = k >= 0 ? sol_sec_name[k] : "(unknown)";
        if ((uint32_t)sol_load_le64(p + 4) != 0 || e->offset != end || e->length > at - end)
            return rad_fail(err, RAD_ERR_CORRUPT,
                            "%s: index: section %u (%s) at byte %llu, %llu bytes: not where the "
                            "previous one ends (%llu) or past the index", name, q, what,
                            (unsigned long long)e->offset, (unsigned long long)e->length,
                            (unsigned long long)end);
        end += e->length;
        if (k >= 0 && x->at[k] >= 0)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: index: section %s appears twice", name,
                            what);
        if (k >= 0)
            x->at[k] = (int)q;
    }
    if (end != at)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: index: %llu bytes between the last section and "
                        "the index", name, (unsigned long long)(at - end));
    static const int required[] = {SEC_INFO, SEC_SCENE, SEC_MESH, SEC_ROWS, SEC_PATCHDATA,
                                   SEC_IRRADIANCE};
    for (size_t q = 0; q < sizeof required / sizeof required[0]; q++)
        if (x->at[required[q]] < 0)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: section %s missing", name,
                            sol_sec_name[required[q]]);
    if (x->at[SEC_ELEMENT_ROWS] >= 0 && h->version < SOL_VERSION_ELEMENT_ROWS)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: section ELEMENTROWS in a version %u file", name,
                        h->version);
    if (x->at[SEC_TEXTURES] >= 0 && h->version < SOL_VERSION_TEXTURES)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: section TEXTURES in a version %u file", name,
                        h->version);
    if ((x->at[SEC_MATRIX] >= 0) == (x->at[SEC_MATRIXREF] >= 0))
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: %s", name,
                        x->at[SEC_MATRIX] >= 0 ? "both MATRIX and MATRIXREF"
                                               : "section MATRIX missing (nor a MATRIXREF)");
    return RAD_OK;
}

/* The optional sections must be exactly those INFO announces. */
static int check_announced(const sol_reader *r, const sol_index *x)
{
    for (int k = SEC_LIGHTS; k <= SEC_LAST_ANNOUNCED; k++)
        if ((x->at[k] >= 0) != sol_announced(r, k))
            return rad_fail(r->err, RAD_ERR_CORRUPT, "%s: section %s %s", r->name,
                            sol_sec_name[k],
                            sol_announced(r, k) ? "missing" : "not announced in INFO");
    return RAD_OK;
}

/* ELEMENTROWS is there exactly when a version 7 file's ELEMENTS counts
 * some row entry (parse_index refuses it in version 6, whose ELEMENTS
 * holds the entries), checked from the index whether the section is read
 * or not.  *read: it is there and `parts` asks for it. */
static int element_rows_wanted(const sol_reader *r, const sol_index *x, const rad_solution *s,
                               unsigned parts, int *read)
{
    const int present = x->at[SEC_ELEMENT_ROWS] >= 0;
    *read = 0;
    const int needed = s->elements && !s->elements->rows_loaded;
    if (present != needed)
        return rad_fail(r->err, RAD_ERR_CORRUPT, "%s: section ELEMENTROWS %s", r->name,
                        needed ? "missing" : "without element rows to hold");
    *read = present && (parts & RAD_PART_ELEMENT_ROWS);
    return RAD_OK;
}

/* Whether section sec (-1: none) of index x is read, into *read, as both
 * version 6 readers decide it: at LIGHTS' turn INFO's announcements are
 * checked against the index; ELEMENTROWS as element_rows_wanted says;
 * BASIS only with RAD_PART_BASIS (else origin's basis_skipped, so that no write
 * loses it); the others whenever they are there. */
static int section_read(const sol_reader *r, const sol_index *x, rad_solution *s,
                        unsigned parts, int sec, int *read)
{
    *read = sec >= 0 && x->at[sec] >= 0;
    int rc = sec == SEC_LIGHTS ? check_announced(r, x) : RAD_OK;
    if (!rc && sec == SEC_ELEMENT_ROWS)
        rc = element_rows_wanted(r, x, s, parts, read);
    if (!rc && sec == SEC_BASIS && *read && !(parts & RAD_PART_BASIS)) {
        *read = 0;
        s->origin->basis_skipped = 1;
    }
    return rc;
}

/* ------------------------------------------- version 6 from a file */

/* An open solution file. */
typedef struct sol_file {
    int fd;
    uint64_t size;
    const char *name;
    int errnum;  /* why open failed */
} sol_file;

static int file_open(sol_file *f, const char *path, rad_error *err)
{
    f->name = path;
    f->fd = open(path, O_RDONLY | O_CLOEXEC);
    f->errnum = f->fd < 0 ? errno : 0;
    if (f->fd < 0)
        return rad_fail(err, RAD_ERR_IO, "%s: cannot open: %s", path, strerror(f->errnum));
    struct stat st;
    if (fstat(f->fd, &st) < 0 || !S_ISREG(st.st_mode)) {
        int e = errno;
        close(f->fd);
        f->fd = -1;
        return rad_fail(err, RAD_ERR_IO, "%s: not a regular file%s%s", path, e ? ": " : "",
                        e ? strerror(e) : "");
    }
    f->size = (uint64_t)st.st_size;
    if (f->size > SOL_MAX_FILE) {
        close(f->fd);
        f->fd = -1;
        return rad_fail(err, RAD_ERR_LIMIT, "%s: %llu bytes exceeds the 64 GiB limit", path,
                        (unsigned long long)f->size);
    }
    return RAD_OK;
}

static void file_close(sol_file *f)
{
    if (f->fd >= 0)
        close(f->fd);
    f->fd = -1;
}

/* n bytes at `at`; a short read means the file shrank under us. */
static int file_read(const sol_file *f, void *p, size_t n, uint64_t at, rad_error *err)
{
    uint8_t *b = p;
    while (n) {
        ssize_t r = pread(f->fd, b, n > (1u << 30) ? (1u << 30) : n, (off_t)at);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0)
            return rad_fail(err, RAD_ERR_IO, "%s: cannot read: %s", f->name, strerror(errno));
        if (r == 0)
            return rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated while reading at byte %llu",
                            f->name, (unsigned long long)at);
        b += r;
        n -= (size_t)r;
        at += (uint64_t)r;
    }
    return RAD_OK;
}

/* Header and index of a version 6 file (the header read into head). */
static int file_index(const sol_file *f, const uint8_t head[SOL_HEADER_BYTES], int check_sum,
                      sol_index *x, rad_error *err)
{
    sol_head h;
    uint64_t len;
    int rc = check_header(head, f->size, f->name, &h, err);
    if (rc)
        return rc;
    if (h.version < SOL_VERSION_INDEX)
        return rad_fail(err, RAD_ERR_PARSE, "%s: format version %u has no index", f->name,
                        h.version);
    if ((rc = index_extent(&h, f->size, f->name, &len, err)))
        return rc;
    if (len > SOL_INDEX_HEAD + (uint64_t)SOL_MAX_SECTIONS * SOL_INDEX_ENTRY)
        return rad_fail(err, RAD_ERR_CORRUPT, "%s: index: %llu bytes from byte %llu to the end, "
                        "more than %u sections take", f->name, (unsigned long long)len,
                        (unsigned long long)h.a, SOL_MAX_SECTIONS);
    uint8_t *buf = malloc((size_t)len);
    if (!buf)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", f->name);
    rc = file_read(f, buf, (size_t)len, h.a, err);
    if (!rc)
        rc = parse_index(buf, len, &h, f->name, check_sum, x, err);
    free(buf);
    return rc;
}

/* A buffer that the sections of one read share: a fresh buffer for each
 * would fault in every page of every section anew (at 32k patches, 13 MB
 * for report; the largest section is 3.5 MB). */
typedef struct sol_scratch {
    uint8_t *p;
    size_t cap;
} sol_scratch;

/* Reads section entry e into memory (scratch, grown as needed, or a buffer
 * of its own with scratch NULL), checks its CRC and parses it. */
static int file_section(sol_reader *r, const sol_file *f, const sol_index_entry *e, int sec,
                        rad_solution *s, sol_scratch *scratch)
{
    if (e->length > SIZE_MAX)
        return rad_fail(r->err, RAD_ERR_LIMIT, "%s: section %s too large", f->name,
                        sol_sec_name[sec]);
    sol_scratch own = {0};
    sol_scratch *b = scratch ? scratch : &own;
    if (b->cap < e->length || !b->p) {
        size_t cap = e->length ? (size_t)e->length : 1;
        free(b->p);
        b->p = malloc(cap);
        b->cap = b->p ? cap : 0;
    }
    uint8_t *buf = b->p;
    if (!buf)
        return rad_fail(r->err, RAD_ERR_NOMEM, "%s: section %s: out of memory for %llu bytes",
                        f->name, sol_sec_name[sec], (unsigned long long)e->length);
    int rc = file_read(f, buf, (size_t)e->length, e->offset, r->err);
    uint64_t got = 0;
    if (!rc && r->check_sum &&
        (!sol_crc64_of(buf, (size_t)e->length, &got) || got != e->crc))
        rc = rad_fail(r->err, RAD_ERR_CORRUPT, "%s: section %s: checksum mismatch: the file is "
                      "corrupt", f->name, sol_sec_name[sec]);
    if (!rc) {
        r->c.p = buf;
        r->c.left = (size_t)e->length;
        rc = sol_parse_section(r, sec, s);
    }
    free(own.p);
    return rc;
}

/* The MATRIX section e of file f into a new matrix, straight into its pool
 * block by block (the section's bytes and nothing more in memory), then the
 * section's CRC compared before a single row is indexed.  `r` names the
 * file in messages. */
static int file_matrix(sol_reader *r, const sol_file *f, const sol_index_entry *e,
                       rad_solution *s)
{
    uint8_t head[SOL_BLOCK_HEAD];
    uint64_t key = 0;
    r->section = sol_sec_name[SEC_MATRIX];
    if (e->length < SOL_MATRIX_HEAD)
        return sol_rfail(r, RAD_ERR_CORRUPT, "truncated");
    int rc = file_read(f, head, SOL_MATRIX_HEAD, e->offset, r->err);
    if (rc)
        return rc;
    sol_crc64_tables *tab = malloc(sizeof *tab);
    rad_matrix *G = rad_matrix_create(s->mesh->patch_count);
    uint8_t *pool = G ? rad_matrix_reserve(G, e->length - SOL_MATRIX_HEAD, NULL) : NULL;
    if (!tab || !G || (!pool && e->length > SOL_MATRIX_HEAD)) {
        free(tab);
        rad_matrix_destroy(G);
        return sol_rfail(r, RAD_ERR_NOMEM, "out of memory for %llu bytes of rows",
                         (unsigned long long)e->length);
    }
    sol_crc64_init(tab);
    uint64_t crc = sol_crc64_update(tab, ~0ull, head, SOL_MATRIX_HEAD);
    uint64_t pos = SOL_MATRIX_HEAD, records = 0, rows = 0;
    rc = sol_matrix_head(r, head, s->mesh->patch_count, &key);
    G->key = key;
    while (!rc && pos < e->length) {
        uint32_t nrows;
        uint64_t len, bcrc, left = e->length - pos;
        if (left >= SOL_BLOCK_HEAD)
            rc = file_read(f, head, SOL_BLOCK_HEAD, e->offset + pos, r->err);
        if (!rc)
            rc = sol_block_head(r, head, pos, left, &nrows, &len, &bcrc);
        if (!rc)
            rc = file_read(f, pool + records, (size_t)len, e->offset + pos + SOL_BLOCK_HEAD,
                           r->err);
        if (rc)
            break;
        crc = sol_crc64_update(tab, crc, head, SOL_BLOCK_HEAD);
        crc = sol_crc64_update(tab, crc, pool + records, (size_t)len);
        records += len;
        rows += nrows;
        pos += SOL_BLOCK_HEAD + len;
    }
    free(tab);
    if (!rc && r->check_sum && (crc ^ ~0ull) != e->crc)
        rc = sol_rfail(r, RAD_ERR_CORRUPT, "checksum mismatch: the file is corrupt");
    if (rc) {
        rad_matrix_destroy(G);
        return rc;
    }
    return sol_matrix_install(r, s, G, records, rows);
}

/* The directory part of path ("." for a bare name) + "/" + name. */
static void beside(const char *path, const char *name, char *out, size_t size)
{
    const char *slash = strrchr(path, '/');
    if (name[0] == '/' || !slash)
        snprintf(out, size, "%s", name);
    else
        snprintf(out, size, "%.*s/%s", (int)(slash - path), path, name);
}

/* Opens the file a MATRIXREF names: its name beside the referring file,
 * else the absolute path it had when written. */
static int open_matrixref(sol_reader *r, const char *path, sol_file *f, char *where, size_t size)
{
    const sol_matrixref *m = &r->ref;
    beside(path, m->name, where, size);
    if (file_open(f, where, NULL) == RAD_OK)
        return RAD_OK;
    int first = f->errnum;
    int other = strcmp(where, m->abs) != 0;
    if (other && file_open(f, m->abs, NULL) == RAD_OK) {
        snprintf(where, size, "%s", m->abs);
        return RAD_OK;
    }
    return sol_rfail(r, RAD_ERR_NOTFOUND,
                     "the matrix it shares is gone: cannot open %s%s%s%s: %s; render and report "
                     "still work, a relight needs the scene solved again",
                     where, other ? " (nor " : "", other ? m->abs : "", other ? ")" : "",
                     strerror(first ? first : ENOENT));
}

/* Finds the MATRIX section s's MATRIXREF names: the named file (open in
 * *f on success) must list it in its index at the same place, length and
 * CRC.  Its bytes are not read here. */
static int find_matrixref(sol_reader *r, const char *path, sol_file *f, char *holder,
                          size_t size, sol_index_entry *found)
{
    r->section = sol_sec_name[SEC_MATRIXREF];
    int rc = open_matrixref(r, path, f, holder, size);
    if (rc)
        return rc;
    uint8_t head[SOL_HEADER_BYTES];
    sol_index x;
    const sol_matrixref *m = &r->ref;
    rc = f->size < SOL_HEADER_BYTES ? rad_fail(r->err, RAD_ERR_CORRUPT, "%s: truncated", holder)
                                    : file_read(f, head, sizeof head, 0, r->err);
    if (!rc)
        rc = file_index(f, head, 1, &x, r->err);
    const sol_index_entry *e = !rc && x.at[SEC_MATRIX] >= 0 ? &x.e[x.at[SEC_MATRIX]] : NULL;
    if (!rc && (!e || e->offset != m->offset || e->length != m->length || e->crc != m->crc))
        rc = sol_rfail(r, RAD_ERR_CORRUPT,
                       "%s has changed since this solution was written: its MATRIX section is not "
                       "the one referenced (%llu bytes, CRC %016llx); a relight needs the scene "
                       "solved again", holder, (unsigned long long)m->length,
                       (unsigned long long)m->crc);
    if (rc)
        file_close(f);
    else
        *found = *e;
    return rc;
}

/* Follows s's MATRIXREF: the named file's MATRIX section must be the one
 * referenced (same place, length and CRC in its index, same rows key), and
 * its bytes must still have that CRC. */
static int follow_matrixref(sol_reader *r, const char *path, rad_solution *s, char *holder,
                            size_t size, sol_index_entry *found)
{
    sol_file f = {.fd = -1};
    int rc = find_matrixref(r, path, &f, holder, size, found);
    if (rc)
        return rc;
    sol_reader h = *r;
    h.name = holder;
    rc = file_matrix(&h, &f, found, s);
    if (!rc && s->F->key != r->ref.key)
        rc = sol_rfail(r, RAD_ERR_CORRUPT, "%s: its rows key %016llx is not the one referenced",
                       holder, (unsigned long long)s->F->key);
    file_close(&f);
    return rc;
}

/* Where F's rows are, without reading them: origin's matrix_file and F->key
 * (from the MATRIX section's head, or from the MATRIXREF, whose file's
 * index must still list that section), so that a solution written from s
 * can refer to them.  Left empty when that file is gone or changed: render
 * and report need none of it, and a writer then refuses to share (relight
 * reads F instead, which says what is wrong).  The key read from MATRIX's
 * head is not under a checked CRC here: a reference that carries a wrong
 * one is refused when followed. */
static void locate_matrix(const sol_reader *r, const sol_file *f, const sol_index *x,
                          rad_solution *s)
{
    rad_error ignored;
    sol_reader *q = malloc(sizeof *q);
    char holder[PATH_MAX + SOL_MAX_STRING + 2];
    sol_index_entry e;
    uint64_t key = 0;
    int rc = q ? RAD_OK : RAD_ERR_NOMEM;
    if (!rc) {
        *q = *r;
        q->err = &ignored;
    }
    if (!rc && x->at[SEC_MATRIX] >= 0) {
        uint8_t head[SOL_MATRIX_HEAD];
        e = x->e[x->at[SEC_MATRIX]];
        q->section = sol_sec_name[SEC_MATRIX];
        rc = e.length < SOL_MATRIX_HEAD ? RAD_ERR_CORRUPT
                                        : file_read(f, head, sizeof head, e.offset, &ignored);
        if (!rc)
            rc = sol_matrix_head(q, head, s->mesh->patch_count, &key);
        snprintf(holder, sizeof holder, "%s", f->name);
    } else if (!rc) {
        sol_file h = {.fd = -1};
        rc = file_section(q, f, &x->e[x->at[SEC_MATRIXREF]], SEC_MATRIXREF, s, NULL);
        if (!rc)
            rc = find_matrixref(q, f->name, &h, holder, sizeof holder, &e);
        file_close(&h);
        key = q->ref.key;
    }
    free(q);
    char *abs = rc ? NULL : realpath(holder, NULL);
    if (!abs)
        return;
    free(s->origin->matrix_file.path);
    s->origin->matrix_file = (rad_matrix_file){.path = abs, .offset = e.offset,
                                               .length = e.length, .crc = e.crc,
                                               .bytes = s->F->bytes};
    s->F->key = key;
}

/* F's entries from the MATRIX of s's own file or from the file its
 * MATRIXREF names; records where they came from in origin's matrix_file. */
static int load_matrix(sol_reader *r, const sol_file *f, const sol_index *x, rad_solution *s)
{
    char holder[PATH_MAX + SOL_MAX_STRING + 2];
    sol_index_entry e;
    int rc;
    if (x->at[SEC_MATRIX] >= 0) {
        e = x->e[x->at[SEC_MATRIX]];
        snprintf(holder, sizeof holder, "%s", f->name);
        rc = file_matrix(r, f, &e, s);
    } else {
        rc = file_section(r, f, &x->e[x->at[SEC_MATRIXREF]], SEC_MATRIXREF, s, NULL);
        if (!rc)
            rc = follow_matrixref(r, f->name, s, holder, sizeof holder, &e);
    }
    if (rc)
        return rc;
    char *abs = realpath(holder, NULL);
    free(s->origin->matrix_file.path);
    s->origin->matrix_file = (rad_matrix_file){.path = abs, .offset = e.offset,
                                               .length = e.length, .crc = e.crc,
                                               .bytes = s->F->bytes};
    return RAD_OK;
}

/* A version 6 file: index, then the sections in parse order, the matrix
 * only when parts asks for it. */
static int read_v6(sol_reader *r, const sol_file *f, const uint8_t head[SOL_HEADER_BYTES],
                   unsigned parts, rad_solution *s)
{
    sol_index x;
    sol_scratch scratch = {0};
    int rc = file_index(f, head, r->check_sum, &x, r->err);
    /* the sections in the order they are parsed (each needs those before it) */
    for (size_t q = 0; !rc && sol_section_order(q) >= 0; q++) {
        int sec = sol_section_order(q), read;
        if ((rc = section_read(r, &x, s, parts, sec, &read)))
            break;
        if (read)
            rc = file_section(r, f, &x.e[x.at[sec]], sec, s, &scratch);
    }
    free(scratch.p);
    if (!rc && (parts & RAD_PART_MATRIX))
        rc = load_matrix(r, f, &x, s);
    else if (!rc && (parts & RAD_PART_MATRIX_PLACE))
        locate_matrix(r, f, &x, s);
    s->origin->file_id = x.id;
    return rc;
}

/* A version 1-5 file: read whole (it has one CRC), then parsed. */
static int read_old(sol_reader *r, const sol_file *f, rad_solution *s)
{
    uint64_t avail = rad_available_memory();
    if (f->size > SIZE_MAX || (avail && f->size > avail))
        return rad_fail(r->err, RAD_ERR_LIMIT,
                        "%s: %llu bytes is more than the %llu bytes of memory available", f->name,
                        (unsigned long long)f->size, (unsigned long long)avail);
    uint8_t *buf = malloc(f->size ? (size_t)f->size : 1);
    if (!buf)
        return rad_fail(r->err, RAD_ERR_NOMEM, "%s: out of memory for %llu bytes", f->name,
                        (unsigned long long)f->size);
    int rc = file_read(f, buf, (size_t)f->size, 0, r->err);
    sol_head h;
    if (!rc)
        rc = check_header(buf, f->size, f->name, &h, r->err);
    if (!rc)
        rc = check_payload(buf, (size_t)f->size, f->name, &h, 1, r->err);
    if (!rc)
        rc = parse_payload(r, s, buf, (size_t)f->size);
    free(buf);
    return rc;
}

static int new_reader(const char *name, int check_sum, sol_reader **r, rad_solution **s,
                      rad_error *err)
{
    *r = calloc(1, sizeof **r);
    *s = calloc(1, sizeof **s);
    if (!*r || !*s || sol_origin_attach(*s) != 0) {
        free(*r);
        rad_solution_destroy(*s);
        *r = NULL;
        *s = NULL;
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", name);
    }
    (*r)->name = name;
    (*r)->err = err;
    (*r)->check_sum = check_sum;
    return RAD_OK;
}

int rad_solution_read_parts(const char *path, unsigned parts, rad_solution **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!path || !out)
        return rad_fail(err, RAD_ERR_USAGE, "rad_solution_read: path and out are required");
    sol_file f = {.fd = -1};
    int rc = file_open(&f, path, err);
    if (rc)
        return rc;
    uint8_t head[SOL_HEADER_BYTES] = {0};
    size_t got = f.size < SOL_HEADER_BYTES ? (size_t)f.size : SOL_HEADER_BYTES;
    sol_head h;
    if (!(rc = file_read(&f, head, got, 0, err)))
        rc = check_header(head, f.size, path, &h, err);
    sol_reader *r = NULL;
    rad_solution *s = NULL;
    if (!rc)
        rc = new_reader(path, 1, &r, &s, err);
    if (!rc) {
        r->version = h.version;
        rc = h.version >= SOL_VERSION_INDEX ? read_v6(r, &f, head, parts, s) : read_old(r, &f, s);
    }
    if (!rc && !(s->origin->file = strdup(path)))
        rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", path);
    file_close(&f);
    free(r);
    if (rc) {
        rad_solution_destroy(s);
        return rc;
    }
    *out = s;
    return RAD_OK;
}

int rad_solution_read(const char *path, rad_solution **out, rad_error *err)
{
    return rad_solution_read_parts(path, RAD_PARTS_ALL, out, err);
}

/* A part of s left out when it was read (RAD_PART_MATRIX or
 * RAD_PART_ELEMENT_ROWS), read now from the file s was read from, which
 * must not have changed since (its index's CRC is origin's file_id). */
static int load_later(rad_solution *s, unsigned part, rad_error *err)
{
    const char *file = s->origin ? s->origin->file : NULL;
    if (!file)
        return rad_fail(err, RAD_ERR_USAGE, "%s: not read from a file",
                        part == RAD_PART_MATRIX ? "rad_solution_load_matrix"
                                                : "rad_solution_load_element_rows");
    sol_file f = {.fd = -1};
    int rc = file_open(&f, file, err);
    if (rc)
        return rc;
    uint8_t head[SOL_HEADER_BYTES];
    sol_index x;
    sol_reader *r = calloc(1, sizeof *r);
    if (!r)
        rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", file);
    if (!rc)
        rc = f.size < SOL_HEADER_BYTES ? rad_fail(err, RAD_ERR_CORRUPT, "%s: truncated", file)
                                       : file_read(&f, head, sizeof head, 0, err);
    if (!rc)
        rc = file_index(&f, head, 1, &x, err);
    if (!rc && x.id != s->origin->file_id)
        rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: changed since it was read", file);
    if (!rc) {
        *r = (sol_reader){.name = file, .err = err, .check_sum = 1,
                          .version = SOL_VERSION_INDEX};
        /* the index is the one read, which had ELEMENTROWS exactly when
         * the elements' rows were left out (element_rows_wanted) */
        const int rows_at = x.at[SEC_ELEMENT_ROWS];
        if (part == RAD_PART_MATRIX)
            rc = load_matrix(r, &f, &x, s);
        else if (rows_at < 0)
            rc = rad_fail(err, RAD_ERR_CORRUPT, "%s: section ELEMENTROWS missing", file);
        else
            rc = file_section(r, &f, &x.e[rows_at], SEC_ELEMENT_ROWS, s, NULL);
    }
    free(r);
    file_close(&f);
    return rc;
}

int rad_solution_load_matrix(rad_solution *s, rad_error *err)
{
    if (!s || !s->F)
        return rad_fail(err, RAD_ERR_USAGE, "rad_solution_load_matrix: no solution");
    return s->F->entries_loaded ? RAD_OK : load_later(s, RAD_PART_MATRIX, err);
}

int rad_solution_load_element_rows(rad_solution *s, rad_error *err)
{
    if (!s)
        return rad_fail(err, RAD_ERR_USAGE, "rad_solution_load_element_rows: no solution");
    if (!s->elements || s->elements->rows_loaded)
        return RAD_OK;
    return load_later(s, RAD_PART_ELEMENT_ROWS, err);
}

/* ------------------------------------------------------------- from memory */

/* A version 6 file held in memory: as read_v6, every section from d. */
static int parse_v6(sol_reader *r, const uint8_t *d, size_t size, const sol_head *h,
                    unsigned parts, rad_solution *s)
{
    uint64_t len;
    sol_index x;
    int rc = index_extent(h, size, r->name, &len, r->err);
    if (!rc)
        rc = parse_index(d + h->a, len, h, r->name, r->check_sum, &x, r->err);
    int matrix = (parts & RAD_PART_MATRIX) ? SEC_MATRIX : -1;
    if (!rc && matrix >= 0 && x.at[SEC_MATRIX] < 0)
        rc = rad_fail(r->err, RAD_ERR_USAGE,
                      "%s: its matrix is in another file (MATRIXREF), which memory cannot follow",
                      r->name);
    /* the sections in parse order, then the matrix when asked for */
    for (size_t q = 0, done = 0; !rc && !done; q++) {
        int sec = sol_section_order(q);
        if (sec < 0) {
            sec = matrix;
            done = 1;
        }
        int read;
        if ((rc = section_read(r, &x, s, parts, sec, &read)))
            break;
        if (!read)
            continue;
        const sol_index_entry *e = &x.e[x.at[sec]];
        uint64_t got = 0;
        if (r->check_sum && (!sol_crc64_of(d + e->offset, (size_t)e->length, &got) ||
                             got != e->crc)) {
            rc = rad_fail(r->err, RAD_ERR_CORRUPT,
                          "%s: section %s: checksum mismatch: the file is corrupt", r->name,
                          sol_sec_name[sec]);
            break;
        }
        r->c.p = d + e->offset;
        r->c.left = (size_t)e->length;
        rc = sol_parse_section(r, sec, s);
    }
    s->origin->file_id = rc ? 0 : x.id;
    return rc;
}

int rad_solution_parse_parts(const void *data, size_t size, const char *name, int check_sum,
                             unsigned parts, rad_solution **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!name)
        name = "<memory>";
    if (!out || (!data && size))
        return rad_fail(err, RAD_ERR_USAGE, "%s: rad_solution_parse: bad arguments", name);
    static const uint8_t empty[1];
    const uint8_t *d = size ? data : empty;
    sol_head h;
    int rc = check_header(d, size, name, &h, err);
    if (!rc && h.version < SOL_VERSION_INDEX)
        rc = check_payload(d, size, name, &h, check_sum, err);
    sol_reader *r = NULL;
    rad_solution *s = NULL;
    if (!rc)
        rc = new_reader(name, check_sum, &r, &s, err);
    if (!rc) {
        r->version = h.version;
        rc = h.version >= SOL_VERSION_INDEX ? parse_v6(r, d, size, &h, parts, s)
                                            : parse_payload(r, s, d, size);
    }
    free(r);
    if (rc) {
        rad_solution_destroy(s);
        return rc;
    }
    *out = s;
    return RAD_OK;
}

int rad_solution_parse(const void *data, size_t size, const char *name, int check_sum,
                       rad_solution **out, rad_error *err)
{
    return rad_solution_parse_parts(data, size, name, check_sum, RAD_PARTS_ALL, out, err);
}
