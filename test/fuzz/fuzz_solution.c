/* fuzz_solution.c - libFuzzer target for the solution reader.
 *
 * Feeds arbitrary bytes to rad_solution_parse with the checksum check off,
 * so that mutated inputs reach the section and structure checks instead of
 * stopping at "checksum mismatch".  Invariant under test: no input crashes,
 * leaks or trips a sanitizer, and anything accepted keeps solution.h's
 * invariants (F is n×n for the mesh's n patches, B finite and >= 0,
 * patch corners index existing vertices).
 * Seeds: test/fuzz/corpus/solution/ (written by `test_solution --write-seeds`).
 */
#include "../../radiosity/store/solution.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void parse_one(const uint8_t *data, size_t size)
{
    rad_solution *s = NULL;
    rad_error err;
    if (rad_solution_parse(data, size, "fuzz", 0, &s, &err) == RAD_OK) {
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
    } else if (s) {
        abort(); /* a failure must not hand back a solution */
    }
    rad_solution_destroy(s);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    parse_one(data, size);
    /* Inserting or deleting bytes, the fuzzer's commonest mutation, breaks
     * the header's payload size and stops the parse at "truncated".  A copy
     * with the size made to agree lets those inputs reach the sections. */
    if (size >= 32 && size < ((size_t)1 << 26)) {
        uint8_t *copy = malloc(size);
        if (!copy)
            return 0;
        memcpy(copy, data, size);
        uint64_t payload = size - 32;
        for (int k = 0; k < 8; k++)
            copy[16 + k] = (uint8_t)(payload >> (8 * k));
        parse_one(copy, size);
        free(copy);
    }
    return 0;
}
