/* journal.c - a solve's output file while the solve runs (solfile.h,
 * rad_journal): PATH.partial, a version 7 solution file begun with its
 * header (index offset 0: unfinished) and the head of its MATRIX section,
 * to which every finished row is appended at once as a block of its own
 * (tag, 1 row, length, CRC-64 of the record, the record).  When the solve is
 * done the other sections and the index follow and the file is renamed
 * onto PATH: the matrix is never written a second time.
 *
 * Invariant: the file always holds a prefix of valid blocks, then at most
 * one torn block (a crash in the middle of a write); a later run keeps the
 * valid blocks (each checked against its CRC and the row rules) and cuts
 * the rest off.  Rows are reused only under the same rows key, i.e. the
 * same mesh, resolution, exact marks and options.
 */
#include "solfile_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* How often the rows are made durable (fdatasync): a power cut loses at
 * most this much work, and the syncs cost next to nothing. */
#define JOURNAL_SYNC_SECONDS 2.0

struct rad_journal {
    char *path;               /* PATH */
    char *partial;            /* PATH.partial, for messages */
    rad_output *out;          /* PATH.partial once attached */
    uint64_t existing;        /* its size when opened */
    sol_crc64_tables *tab;
    uint64_t crc;             /* CRC register of the MATRIX section so far */
    rad_matrix *F;            /* attached, or NULL */
    uint8_t *written;         /* F->n flags: row i has a block in the file */
    rad_journal_stats stats;
    double last_sync;
    int fresh;                /* resume nothing */
};

static void journal_free(rad_journal *j)
{
    free(j->path);
    free(j->partial);
    free(j->tab);
    free(j->written);
    free(j);
}

/* No file yet: a solve that fails before its first row (bad input, say)
 * leaves nothing behind. */
int rad_journal_open(const char *path, int fresh, rad_journal **out, rad_error *err)
{
    *out = NULL;
    if (!path || !*path)
        return rad_fail(err, RAD_ERR_USAGE, "rad_journal_open: no path");
    rad_journal *j = calloc(1, sizeof *j);
    size_t n = strlen(path) + sizeof ".partial";
    if (j) {
        j->tab = malloc(sizeof *j->tab);
        j->path = strdup(path);
        j->partial = malloc(n);
    }
    if (!j || !j->tab || !j->path || !j->partial) {
        if (j)
            journal_free(j);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", path);
    }
    snprintf(j->partial, n, "%s.partial", path);
    sol_crc64_init(j->tab);
    j->fresh = fresh;
    *out = j;
    return RAD_OK;
}

const char *rad_journal_path(const rad_journal *j) { return j->partial; }

rad_journal_stats rad_journal_stats_of(const rad_journal *j) { return j->stats; }

/* The rows key: the mesh as MESH encodes it, then the rest. */
uint64_t rad_rows_key(const rad_mesh *mesh, uint32_t resolution, const uint8_t *exact,
                      uint32_t flags)
{
    sol_sink k;
    if (sol_sink_init(&k, NULL) != 0)
        return 0; /* 0 matches no stored key: nothing is reused */
    uint64_t mesh_crc = sol_rows_crc(&k, mesh);
    sol_index_entry e;
    uint8_t b[16];
    sol_sink_begin(&k, &e, SEC_MATRIX);
    sol_put(&k, "radiosity rows " RAD_VERSION_STRING, sizeof("radiosity rows " RAD_VERSION_STRING));
    sol_store_le(b, mesh_crc, 8);
    sol_store_le(b + 8, resolution, 4);
    sol_store_le(b + 12, flags, 4);
    sol_put(&k, b, sizeof b);
    if (exact)
        sol_put(&k, exact, mesh->patch_count);
    sol_sink_end(&k, &e);
    sol_sink_free(&k);
    return e.crc ? e.crc : 1;
}

/* Makes durable what is written, at most every JOURNAL_SYNC_SECONDS. */
static void maybe_sync(rad_journal *j)
{
    double now = rad_seconds();
    if (now - j->last_sync >= JOURNAL_SYNC_SECONDS) {
        rad_output_sync(j->out);
        j->last_sync = now;
    }
}

/* F's sink: the new row as a block of its own.  A row already in the file
 * is not written again: rows are determined by the key, so a row the
 * progressive solver's bounded store dropped and computed again is the
 * same row, and the file holds each row once (the readers refuse twins). */
static int journal_row(void *user, uint32_t i, const uint8_t *record, size_t bytes, rad_error *err)
{
    rad_journal *j = user;
    if (j->written[i])
        return RAD_OK;
    j->written[i] = 1;
    uint8_t head[SOL_BLOCK_HEAD];
    memcpy(head, SOL_BLOCK_TAG, 4);
    sol_store_le(head + 4, 1, 4);
    sol_store_le(head + 8, bytes, 8);
    sol_store_le(head + 16, sol_crc64_update(j->tab, ~0ull, record, bytes) ^ ~0ull, 8);
    rad_output_write(j->out, head, sizeof head);
    rad_output_write(j->out, record, bytes);
    j->crc = sol_crc64_update(j->tab, j->crc, head, sizeof head);
    j->crc = sol_crc64_update(j->tab, j->crc, record, bytes);
    j->stats.kept++;
    maybe_sync(j);
    return rad_output_error(j->out, err);
}

/* The head of an unfinished file: a version 6 header and MATRIX's head. */
static void start_head(uint8_t *h, uint32_t n, uint64_t key)
{
    sol_header(h);
    sol_store_le(h + SOL_HEADER_BYTES, n, 4);
    sol_store_le(h + SOL_HEADER_BYTES + 4, 0, 4);
    sol_store_le(h + SOL_HEADER_BYTES + 8, key, 8);
}

/* The blocks of the existing file from byte `pos`.  With F: the valid
 * ones into F, each block's CRC and rows checked, the first bad one and
 * all after it being the torn tail.  Without: only counted (the rows of
 * another key, about to be dropped).  Returns where the blocks walked end;
 * *rows: how many rows they hold. */
static uint64_t walk_blocks(rad_journal *j, rad_matrix *F, uint64_t pos, uint64_t *rows)
{
    sol_reader r = {.name = rad_journal_path(j), .section = "MATRIX"};
    uint8_t head[SOL_BLOCK_HEAD];
    *rows = 0;
    while (pos + SOL_BLOCK_HEAD <= j->existing) {
        uint32_t nrows;
        uint64_t len, crc;
        if (rad_output_read_at(j->out, head, sizeof head, pos) != 0 ||
            sol_block_head(&r, head, pos, j->existing - pos, &nrows, &len, &crc) != RAD_OK)
            break;
        if (F) {
            uint8_t *p = rad_matrix_reserve(F, len, NULL);
            if (!p || rad_output_read_at(j->out, p, (size_t)len, pos + SOL_BLOCK_HEAD) != 0 ||
                (sol_crc64_update(j->tab, ~0ull, p, (size_t)len) ^ ~0ull) != crc ||
                rad_matrix_add_records(F, len, nrows, NULL, NULL) != RAD_OK)
                break;
            j->crc = sol_crc64_update(j->tab, j->crc, head, sizeof head);
            j->crc = sol_crc64_update(j->tab, j->crc, p, (size_t)len);
        }
        *rows += nrows;
        pos += SOL_BLOCK_HEAD + len;
    }
    return pos;
}

int rad_journal_attach(rad_journal *j, rad_matrix *F, uint64_t key, rad_error *err)
{
    if (!j || !F || F->rows_done || !F->entries_loaded || j->out)
        return rad_fail(err, RAD_ERR_USAGE, "rad_journal_attach: an empty matrix is required");
    j->written = calloc((size_t)F->n + 1, 1);
    if (!j->written)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", j->partial);
    int rc0 = rad_output_open_partial(j->path, &j->out, &j->existing, err);
    if (rc0)
        return rc0;
    const uint64_t start = SOL_HEADER_BYTES + SOL_MATRIX_HEAD;
    uint8_t want[SOL_HEADER_BYTES + SOL_MATRIX_HEAD], have[sizeof want];
    start_head(want, F->n, key);
    j->crc = sol_crc64_update(j->tab, ~0ull, want + SOL_HEADER_BYTES, SOL_MATRIX_HEAD);
    uint64_t keep = 0;
    /* The same file start (bytes 16..31, the index, may be set by a commit
     * that failed at its rename) means the same rows. */
    if (!j->fresh && j->existing >= start &&
        rad_output_read_at(j->out, have, sizeof have, 0) == 0 && memcmp(have, want, 16) == 0 &&
        memcmp(have + SOL_HEADER_BYTES, want + SOL_HEADER_BYTES, SOL_MATRIX_HEAD) == 0) {
        uint64_t rows;
        keep = walk_blocks(j, F, start, &rows);
        j->stats.resumed = F->rows_done;
        j->stats.torn_bytes = j->existing - keep;
    } else if (j->existing >= start && rad_output_read_at(j->out, have, sizeof have, 0) == 0 &&
               memcmp(have, want, 12) == 0) {
        uint64_t rows;
        walk_blocks(j, NULL, start, &rows);
        j->stats.discarded = rows > UINT32_MAX ? UINT32_MAX : (uint32_t)rows;
    }
    j->stats.kept = j->stats.resumed;
    if (keep == 0) {
        rad_output_truncate(j->out, 0);
        rad_output_write(j->out, want, sizeof want);
    } else {
        rad_output_truncate(j->out, keep);
        rad_output_write_at(j->out, want, SOL_HEADER_BYTES, 0); /* unfinished again */
    }
    int rc = rad_output_error(j->out, err);
    if (rc)
        return rc;
    for (uint32_t i = 0; i < F->n; i++)
        j->written[i] = F->row_done[i];
    F->key = key;
    F->sink = journal_row;
    F->sink_user = j;
    j->F = F;
    j->last_sync = rad_seconds();
    return RAD_OK;
}

void rad_journal_detach(rad_journal *j)
{
    if (j->F && j->F->sink_user == j) {
        j->F->sink = NULL;
        j->F->sink_user = NULL;
    }
    j->F = NULL;
}

/* Rows the file holds that F no longer does (the progressive solver's
 * bounded row store dropped them): the file's MATRIX would then disagree
 * with the ROWS and IRRADIANCE the writer makes from F. */
static int rows_dropped(const rad_journal *j)
{
    for (uint32_t i = 0; j->F && i < j->F->n; i++)
        if (j->written[i] && !j->F->row_done[i])
            return 1;
    return 0;
}

int rad_journal_holds(const rad_journal *j, const rad_matrix *F)
{
    if (!j || !F || !j->out || j->F != F || !F->entries_loaded)
        return 0;
    for (uint32_t i = 0; i < F->n; i++)
        if (j->written[i] != F->row_done[i])
            return 0;
    return 1;
}

int rad_journal_commit(rad_journal *j, const rad_solution *s, rad_error *err)
{
    const char *path = j->path;
    if (s && j->out && s->F == j->F && rows_dropped(j)) {
        /* Written whole from F instead (the rows present), the journal
         * dropped once that file is in place, kept if it is not. */
        rad_journal_detach(j);
        int rc = rad_solution_write(s, path, err);
        if (rc)
            rad_output_keep(j->out);
        else
            rad_output_drop(j->out);
        journal_free(j);
        return rc;
    }
    int rc = (!s || !j->out || s->F != j->F) ? rad_fail(err, RAD_ERR_USAGE,
                                             "%s: rad_journal_commit: not the attached matrix", path)
                                  : sol_validate_for_write(s, path, s->F->entries_loaded, err);
    sol_write_ctx w = {.s = s};
    if (!rc)
        rc = sol_irradiance_for_write(s, &w.H, err);
    rad_journal_detach(j);
    sol_sink k = {0};
    if (!rc && sol_sink_init(&k, j->out) != 0)
        rc = rad_fail(err, RAD_ERR_NOMEM, "%s: cannot write: out of memory", path);
    if (!rc) {
        sol_index_entry matrix = {.offset = SOL_HEADER_BYTES,
                                  .length = rad_output_size(j->out) - SOL_HEADER_BYTES,
                                  .crc = j->crc ^ ~0ull};
        memcpy(matrix.tag, sol_sec_tag[SEC_MATRIX], 4);
        rc = sol_write_rest(&k, &w, &matrix, err);
    }
    sol_sink_free(&k);
    free(w.H);
    if (rc)
        rad_output_keep(j->out); /* the rows stay for the next run */
    else if (j->out)
        rc = rad_output_commit(j->out, err);
    journal_free(j);
    return rc;
}

void rad_journal_close(rad_journal *j)
{
    if (!j)
        return;
    rad_journal_detach(j);
    if (j->out && j->stats.kept == 0) {
        rad_output_drop(j->out); /* no row to keep: no file */
    } else if (j->out) {
        rad_output_sync(j->out);
        rad_output_keep(j->out);
    }
    journal_free(j);
}
