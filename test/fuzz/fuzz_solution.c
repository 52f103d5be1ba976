/* fuzz_solution.c - libFuzzer target for the solution reader.
 *
 * Feeds arbitrary bytes to rad_solution_parse with the checksums off, so
 * that mutated inputs reach the section and structure checks instead of
 * stopping at "checksum mismatch", whole and without the matrix (what
 * render and report read).  Invariant under test: no input crashes, leaks
 * or trips a sanitizer, and anything accepted keeps solution.h's
 * invariants (F is n×n for the mesh's n patches, B finite and >= 0,
 * patch corners index existing vertices).
 * Seeds: test/fuzz/corpus/solution/ - files of versions 1 to 6 as those
 * wrote them (version 6: NAME-v6), and version 7 ones (NAME-v7,
 * `test_solution --write-seeds`; elements-room-v7 and interp-room-v7 hold
 * ELEMENTROWS).
 */
#include "../../radiosity/solfile/solfile.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void parse_one(const uint8_t *data, size_t size, unsigned parts)
{
    rad_solution *s = NULL;
    rad_error err;
    if (rad_solution_parse_parts(data, size, "fuzz", 0, parts, &s, &err) == RAD_OK) {
        /* An accepted solution must be usable: walk what a renderer reads. */
        if (!s || s->F->n != s->mesh->patch_count || s->band_count != s->scene->band_count)
            abort();
        size_t count = (size_t)s->mesh->patch_count * s->band_count;
        for (size_t k = 0; k < count; k++)
            if (!(s->B[k] >= 0.0) || !isfinite(s->B[k]) || !(s->rho[k] < 1.0))
                abort();
        for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
            const rad_patch *p = &s->mesh->patches[i];
            for (int c = 0; c < rad_patch_corners(p); c++)
                if (p->v[c] >= s->mesh->vertex_count)
                    abort();
        }
        if (s->F->entries_loaded && rad_matrix_check(s->F, NULL) != RAD_OK)
            abort();
        /* elements: whole, their row entries there exactly when asked for
         * (or inside a version 3-6 ELEMENTS) */
        if (s->elements && (rad_element_store_check(s->elements, s, "fuzz", NULL) != RAD_OK ||
                            (!s->elements->rows_loaded &&
                             ((parts & RAD_PART_ELEMENT_ROWS) || s->elements->col))))
            abort();
        /* stored light responses: their sizes are the solution's */
        if (s->basis && (s->basis->groups < 1 || s->basis->groups > RAD_BASIS_MAX_GROUPS ||
                         s->basis->patch_count != s->mesh->patch_count ||
                         !rad_basis_matches(s)))
            abort();
    } else if (s) {
        abort(); /* a failure must not hand back a solution */
    }
    rad_solution_destroy(s);
}

static uint64_t le(const uint8_t *p, int bytes)
{
    uint64_t v = 0;
    for (int k = bytes - 1; k >= 0; k--)
        v = (v << 8) | p[k];
    return v;
}

static void put_le(uint8_t *p, uint64_t v, int bytes)
{
    for (int k = 0; k < bytes; k++)
        p[k] = (uint8_t)(v >> (8 * k));
}

/* Version 6 keeps its index at the end: after bytes were inserted or
 * deleted, find an index of k entries that ends the input, point the header
 * at it, and lay its sections end to end from byte 32 again (the last one
 * taking what is left), so that the mutation reaches the sections. */
static int repair_v6(uint8_t *c, size_t size)
{
    for (uint32_t k = 1; k <= 16; k++) {
        if (size < 32 + 8 + 32 * (size_t)k)
            return 0;
        size_t at = size - 8 - 32 * (size_t)k;
        if (le(c + at, 4) != k)
            continue;
        put_le(c + 16, at, 8);
        uint64_t off = 32;
        for (uint32_t q = 0; q < k; q++) {
            uint8_t *e = c + at + 8 + 32 * (size_t)q;
            uint64_t len = le(e + 16, 8);
            if (q + 1 == k || len > at - off)
                len = at - off;
            put_le(e + 8, off, 8);
            put_le(e + 16, len, 8);
            off += len;
        }
        return off == at;
    }
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    parse_one(data, size, RAD_PARTS_ALL);
    parse_one(data, size, 0);
    /* Inserting or deleting bytes, the fuzzer's commonest mutation, breaks
     * the header's payload size (versions 1-5) or the index's place and the
     * sections' offsets (version 6) and stops the parse early.  A copy with
     * those made to agree lets such inputs reach the sections. */
    if (size >= 32 && size < ((size_t)1 << 26)) {
        uint8_t *copy = malloc(size);
        if (!copy)
            return 0;
        memcpy(copy, data, size);
        int fixed = 1;
        if (le(copy + 8, 4) >= 6)
            fixed = repair_v6(copy, size);
        else
            put_le(copy + 16, size - 32, 8);
        if (fixed) {
            parse_one(copy, size, RAD_PARTS_ALL);
            parse_one(copy, size, 0);
        }
        free(copy);
    }
    return 0;
}
