/* solfile_internal.h - what the files of radiosity/solfile/ share; private
 * to the folder (the public contract is solfile.h): the solution file's
 * constants and section table (docs/solution-format.md), its checksum, the
 * rules both the writer and the reader apply, so that the writer never
 * writes a file the reader would refuse, and the reader's record of a
 * solution (origin.c).
 */
#ifndef RAD_SOLFILE_INTERNAL_H
#define RAD_SOLFILE_INTERNAL_H

#include "solfile.h"

#define SOL_MAGIC "RADSOL\r\n"  /* 8 bytes; the CR LF catches text-mode mangling */
/* Version 2 = version 1 + the LIGHTS section; version 3 = + the ELEMENTS
 * section; version 4 = + the ELEMENTLIGHTS section (each element's own
 * direct light); version 5 = MESH may hold two-sided sheets (a transmitting
 * polygon's front cells followed by their back twins), with the sections of
 * versions 1-4 as its content needs them, and CAMERAS, SURFACE and
 * CLUSTERS when the scene has orthographic cameras, glossy materials or
 * clustered patches.  Programs before version 6 wrote a file with the lowest
 * version that holds what it has (1 without punctual lights or elements, 2
 * with lights, 3 with elements, 4 with elements that carry their own direct
 * light, 5 with sheets), so older programs still read what they understand,
 * and a file they would misread - skipping LIGHTS, ELEMENTS or ELEMENTLIGHTS
 * without a word, which for the last would relight the elements from their
 * patches' direct light, or taking a sheet's two sides for two unrelated
 * opaque surfaces - carries a version they refuse. */
#define SOL_VERSION RAD_SOLFILE_VERSION /* 8 (solfile.h) */
#define SOL_VERSION_SHEETS 5u
/* Version 6: the sections' table and checksums in an index at the end of
 * the file (any command reads only the sections it needs, each checked on
 * its own), the matrix in row blocks that a solve streams as rows finish,
 * or a reference to another file's matrix.  Versions 1-6 are still read. */
#define SOL_VERSION_INDEX 6u
/* Version 7 = version 6 with the elements' row entries (F_ej) out of
 * ELEMENTS, in ELEMENTROWS: ELEMENTS keeps each row's entry count, so
 * render and report read the elements without a byte of their rows. */
#define SOL_VERSION_ELEMENT_ROWS 7u
/* Version 8 = version 7 + the TEXTURES section (the scene's base-colour
 * textures and texture coordinates, for a bake).  Every file is written as
 * version 8. */
#define SOL_VERSION_TEXTURES 8u
#define SOL_HEADER_BYTES 32u
#define SOL_INDEX_HEAD 8u        /* u32 count, u32 version (7 on; 0 in version 6) */
#define SOL_INDEX_ENTRY 32u      /* tag, u32 reserved, u64 offset, u64 length, u64 CRC */
#define SOL_MAX_SECTIONS 64u
#define SOL_MATRIX_HEAD 16u      /* MATRIX body: u32 n, u32 reserved, u64 rows key */
#define SOL_BLOCK_HEAD 24u       /* row block: tag, u32 rows, u64 length, u64 CRC */
#define SOL_BLOCK_TAG "RBLK"
#define SOL_BLOCK_TARGET (1u << 20) /* rows per block the writer groups, in bytes */
#define SOL_SECTION_HEADER 12u  /* u32 tag + u64 length */
#define SOL_MAX_STRING 4096u
#define SOL_MAX_FILE (64ull << 30)
#define SOL_MAX_STAGES 64u      /* a future version may time more stages */
#define SOL_SOLVER_MAX (sizeof(((rad_solution *)0)->solver) - 1)
/* Largest row sum rad_matrix_check accepts: Σ_j F_ij <= 1 plus the
 * hemi-cube's discretisation error. */
#define SOL_ROW_SUM_MAX (1.0 + 1e-3)

/* The first five sections appear in every file of versions 1-5; LIGHTS
 * only when the scene has punctual lights, ELEMENTS only when the solution
 * has elements, and the others from CAMERAS on (versions 5 and 6) only when
 * the content needs them: CAMERAS when the scene has orthographic cameras,
 * SURFACE when a material has a glossy lobe (rad_material's specular and
 * roughness, which only the gather renderer reads), CLUSTERS when the mesh
 * has a cell layer (patches of several cells, rad.h), ELEMENTINDIRECT when
 * some elements interpolate the light reflected onto them (issue 18),
 * PROGRESS when the last solve was progressive (its shots, previews and
 * row store).  ROWS, IRRADIANCE
 * and MATRIXREF exist from version 6 on (which holds MATRIXREF or MATRIX,
 * never both).  BASIS (version 6, the stored light responses, issue 21) is
 * optional and not announced: a reader that skips it still reads the
 * solution right (it only loses the fast relight), INFO's byte of
 * announcements is full, and version 6's index with its CRC already tells
 * a missing section from a file without it.  It is parsed after the
 * announced ones (it is checked against PATCHDATA, LIGHTS and ELEMENTS).
 * ELEMENTROWS (version 7) is not announced either: it is there exactly
 * when ELEMENTS counts some row entry, which the reader checks against the
 * index whether it reads the section or not (RAD_PART_ELEMENT_ROWS).  It
 * is parsed after BASIS (its rows are checked against the complete
 * elements, ELEMENTINDIRECT's flags included).  TEXTURES (version 8) is
 * not announced either: it is there exactly when the scene has a texture
 * (a reader that skipped it would bake without it, nothing else), and is
 * parsed last.
 *
 * Adding an optional section (docs/solution-format.md, "Adding a
 * section"): its enum entry just before SEC_ROWS (its INFO bit follows
 * from its place), its tag and name in format.c, its parse function in
 * parse.c's table, its emit function and when it is written in write.c's.
 * The readers of both versions and the writer take it from there. */
enum { SEC_INFO, SEC_SCENE, SEC_MESH, SEC_MATRIX, SEC_PATCHDATA, SEC_LIGHTS, SEC_ELEMENTS,
       SEC_ELEMENT_LIGHTS, SEC_CAMERAS, SEC_SURFACE, SEC_CLUSTERS, SEC_ELEMENT_INDIRECT,
       SEC_PROGRESS,
       SEC_ROWS, SEC_IRRADIANCE, SEC_MATRIXREF, SEC_BASIS, SEC_ELEMENT_ROWS, SEC_TEXTURES,
       SEC_COUNT };
/* Sections of versions 1-5 (the others are refused there). */
_Static_assert(SEC_BASIS > SEC_ROWS, "BASIS is a version 6 section");
_Static_assert(SEC_ELEMENT_ROWS > SEC_ROWS, "ELEMENTROWS is a version 7 section");
_Static_assert(SEC_TEXTURES > SEC_ROWS, "TEXTURES is a version 8 section");
#define SEC_COUNT_V5 SEC_ROWS
/* The optional sections INFO announces (versions 5 and 6), one bit each
 * from LIGHTS on, in enum order: LIGHTS 1, ELEMENTS 2, ELEMENTLIGHTS 4,
 * CAMERAS 8, SURFACE 16, CLUSTERS 32, ELEMENT_INDIRECT 64, PROGRESS 128.
 * INFO's announcement is one byte. */
#define SEC_LAST_ANNOUNCED (SEC_ROWS - 1)
#define SOL_ANNOUNCED_BITS (SEC_LAST_ANNOUNCED - SEC_LIGHTS + 1)
_Static_assert(SOL_ANNOUNCED_BITS <= 8, "INFO announces the optional sections in one byte");
extern const char sol_sec_tag[SEC_COUNT][4];
extern const char *const sol_sec_name[SEC_COUNT];
/* Sections each version may hold: 1 the first five, 2 + LIGHTS, 3 +
 * ELEMENTS (where LIGHTS is there exactly when the scene has lights), 4 +
 * ELEMENTLIGHTS (LIGHTS always), 5 any of them (the optional sections
 * from CAMERAS on, ELEMENTINDIRECT included) as the content needs. */
extern const int sol_version_sections[SOL_VERSION_SHEETS + 1];

/* The order of the sections after the matrix, for the writer and the
 * reader of versions 6 and 7 (each needs those before it): INFO, SCENE,
 * MESH, ROWS, PATCHDATA, IRRADIANCE, then the optional sections in enum
 * order, then BASIS, then ELEMENTROWS.  Entry q, or -1 past the end. */
int sol_section_order(size_t q);

/* Minimum encoded sizes of one element, used to bound counts before
 * allocating: a count of k elements needs at least k × this many bytes. */
#define MIN_STRING 4u
#define MIN_CAMERA (MIN_STRING + 11u * 8u)
#define MIN_POLYGON (MIN_STRING + 5u * 4u + 3u * 24u) /* material, object, subdivisions, count */
#define PATCH_BYTES (7u * 4u + 7u * 8u)
#define VERTEX_BYTES (3u * 8u + 1u)
#define MIN_ROW (2u * 4u)
#define MIN_ENTRY (1u + 4u) /* one varint byte + a float32 */
/* name, kind, position, direction, cones, present flag, count; + 16 per band */
#define MIN_LIGHT (MIN_STRING + 1u + 48u + 16u + 1u + 4u)
#define ELEMENT_VERTEX_BYTES (3u * 8u + 1u)
/* patch, level, four corners, row count; + 8 per band */
#define MIN_ELEMENT (4u + 1u + 16u + 4u)
#define BASIS_HEAD (5u * 4u)  /* groups, n, bands, lights, elements */
/* camera index, projection, xmag, ymag */
#define PREVIEW_BYTES (4u + 4u + 8u + 8u) /* one preview of PROGRESS */
#define ORTHO_CAMERA_BYTES (4u + 1u + 16u)
/* four corners and a polygon */
#define CLUSTER_CELL_BYTES (5u * 4u)


/* ------------------------------------------------- checksum (format.c) */

/* CRC-64/XZ lookup tables (slicing by 16). */
typedef struct sol_crc64_tables {
    uint64_t t[16][256];
} sol_crc64_tables;

void sol_crc64_init(sol_crc64_tables *c);

/* Advances the CRC register (not yet inverted) over n bytes. */
uint64_t sol_crc64_update(const sol_crc64_tables *c, uint64_t crc, const uint8_t *p, size_t n);

/* The CRC-64/XZ of n bytes into *out; 0 when memory for the tables runs out. */
int sol_crc64_of(const uint8_t *p, size_t n, uint64_t *out);

/* The little-endian u64 at p. */
uint64_t sol_load_le64(const uint8_t *p);

/* ---------------------------------------------- shared rules (format.c) */

int sol_bad_reflectance(double r); /* not in [0, 1) (NaN included) */
int sol_bad_nonneg(double v);      /* not finite and >= 0 */

/* The per-patch ρ, E and B rules; `where` is "section PATCHDATA" (reader)
 * or "cannot write" (writer), `code` the result code to fail with. */
int sol_check_patch_values(const rad_solution *s, const char *file, const char *where, int code,
                           rad_error *err);

/* The provenance rules (stage times, solver name, tolerance, ...). */
/* The progress record's rules (PROGRESS): times and fractions finite and
 * >= 0, previews in order of shots, time and rows. */
int sol_check_progress(const rad_solution *s, const char *file, const char *where, int code,
                       rad_error *err);
int sol_check_info(const rad_solution *s, const char *file, const char *where, int code,
                   rad_error *err);

/* The light rules; `where` as for sol_check_patch_values. */
int sol_check_lights(const rad_solution *s, const char *file, const char *where, int code,
                     rad_error *err);

/* The stored light responses' rules (solution.h, rad_basis): groups in
 * range and agreeing with the reference sources, each with a member, every
 * value finite and >= 0.  The sizes are the caller's to check. */
int sol_check_basis(const rad_solution *s, const char *file, const char *where, int code,
                    rad_error *err);

/* ---------------------------------------------- reading (parse.c, read.c) */

/* A bounds-checked cursor: every get returns 0 instead of reading past the
 * end, and nothing advances on failure. */
typedef struct sol_cursor {
    const uint8_t *p;
    size_t left;
} sol_cursor;

int sol_get_bytes(sol_cursor *c, void *out, size_t n);
int sol_get_u8(sol_cursor *c, uint8_t *v);
int sol_get_u32(sol_cursor *c, uint32_t *v);
int sol_get_u64(sol_cursor *c, uint64_t *v);
int sol_get_f64(sol_cursor *c, double *v);
int sol_get_f32(sol_cursor *c, float *v);
int sol_get_vec3(sol_cursor *c, rad_vec3 *v);
/* LEB128 of a u32: at most 5 bytes, no bits above 32, no padding bytes. */
int sol_get_varint(sol_cursor *c, uint32_t *v);

/* A MATRIXREF as read. */
typedef struct sol_matrixref {
    int present;
    char name[SOL_MAX_STRING + 1];  /* relative to the referring file's directory, or absolute */
    char abs[SOL_MAX_STRING + 1];   /* absolute path when written */
    uint64_t offset, length, crc, key;
    uint32_t n;
} sol_matrixref;

typedef struct sol_reader {
    const char *name;    /* for messages */
    const char *section; /* for messages */
    uint32_t version;    /* of the file */
    uint8_t announced;   /* version 5 and 6: the optional sections INFO announces */
    int check_sum;       /* 0: checksums are not compared (the fuzzer) */
    rad_error *err;
    sol_cursor c;        /* over the section being parsed */
    char str[SOL_MAX_STRING + 1];
    sol_matrixref ref;
} sol_reader;

/* "NAME: section SECTION: WHAT"; returns code. */
int sol_rfail(sol_reader *r, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Versions 5 and 6: does INFO announce optional section k? (0 for any
 * other section or version.) */
int sol_announced(const sol_reader *r, int k);

/* Parses section `sec` from r->c (which must hold exactly its body) into s. */
int sol_parse_section(sol_reader *r, int sec, rad_solution *s);

/* A version 6 MATRIX body's head (SOL_MATRIX_HEAD bytes at h): n must be
 * the mesh's; the rows key into *key. */
int sol_matrix_head(sol_reader *r, const uint8_t *h, uint32_t n, uint64_t *key);

/* A row block's head at h (byte `at` of the section, `left` bytes from h
 * to the section's end): its rows, body length and CRC, checked. */
int sol_block_head(sol_reader *r, const uint8_t *h, uint64_t at, uint64_t left, uint32_t *rows,
                   uint64_t *len, uint64_t *crc);

/* Indexes the `records` bytes placed in G's pool (rad_matrix_add_records),
 * checks that they are `rows` rows and agree with the counts ROWS gave s->F,
 * and makes G s->F.  G is consumed either way. */
int sol_matrix_install(sol_reader *r, rad_solution *s, rad_matrix *G, uint64_t records,
                       uint64_t rows);

/* ------------------------------------------------- writing (write.c) */

#define SOL_RECORD_HEAD 8u  /* a row record's u32 i, u32 c (rad.h) */

/* One entry of a version 6 file's index. */
typedef struct sol_index_entry {
    char tag[4];
    uint64_t offset, length, crc;
} sol_index_entry;

/* Where encoded bytes go: buffered, checksummed per section, and written
 * to a rad_output (or, with out NULL, only checksummed: the rows key).  A
 * write failure sticks in the rad_output, so encoders need no error paths.
 * total is the file offset of the next byte. */
typedef struct sol_sink {
    rad_output *out;
    uint8_t *buf;
    size_t len, cap;
    size_t crc_from;   /* buf[crc_from, len) is not in crc yet */
    uint64_t total;
    uint64_t crc;      /* CRC register of the current section */
    sol_crc64_tables *tab;
} sol_sink;

/* 0, or -1 when memory runs out.  total starts at out's size. */
int sol_sink_init(sol_sink *k, rad_output *out);
void sol_sink_free(sol_sink *k);
void sol_sink_flush(sol_sink *k);
void sol_put(sol_sink *k, const void *p, size_t n);
/* Starts section `sec` at the current offset (its CRC afresh) / ends it,
 * filling e. */
void sol_sink_begin(sol_sink *k, sol_index_entry *e, int sec);
void sol_sink_end(sol_sink *k, sol_index_entry *e);

/* What the emitters read: the solution, its irradiance H (n × bands) and,
 * for a MATRIXREF, the name it gives the file holding the matrix. */
typedef struct sol_write_ctx {
    const rad_solution *s;
    double *H;
    char ref_name[SOL_MAX_STRING + 1];
} sol_write_ctx;

/* The reader's rules, applied before a file is created (F's rows only when
 * check_matrix: a matrix that is referenced, not written, was checked when
 * it was read). */
int sol_validate_for_write(const rad_solution *s, const char *path, int check_matrix,
                           rad_error *err);

/* H of s for IRRADIANCE into a new array (caller frees). */
int sol_irradiance_for_write(const rad_solution *s, double **H, rad_error *err);

/* A version 7 header with the index not yet written (offset 0). */
void sol_header(uint8_t head[SOL_HEADER_BYTES]);

/* The start of a MATRIX body: n, reserved, the rows key. */
void sol_put_matrix_head(sol_sink *k, uint32_t n, uint64_t key);

/* Writes every section but the matrix, then the index (matrix first in it),
 * and patches the header's index offset and CRC.  k->out must hold the
 * header at offset 0. */
int sol_write_rest(sol_sink *k, const sol_write_ctx *w, const sol_index_entry *matrix,
                   rad_error *err);

/* The CRC-64 of m encoded as MESH is (the rows key's main ingredient). */
uint64_t sol_rows_crc(sol_sink *k, const rad_mesh *m);

void sol_store_le(uint8_t *p, uint64_t v, int bytes);

/* ------------------------------------- the reader's record (origin.c) */

/* What a solution read from a file (or from memory) remembers of it
 * (rad_solution.origin): the reader attaches it before the first section
 * is parsed, and only this folder looks inside. */
struct rad_solution_origin {
    char *file;                  /* the file it was read from (owned), NULL from memory */
    uint64_t file_id;            /* CRC-64 of that file's index (version 6): its content */
    rad_matrix_file matrix_file; /* where F's rows are (version 6); path NULL when F came
                                  * from memory or an older file, or was not found */
    int basis_skipped;           /* 1: the file holds BASIS, read without RAD_PART_BASIS */
};

/* Attaches an empty record to s (which has none); 0, or -1 when memory
 * runs out. */
int sol_origin_attach(rad_solution *s);

#endif /* RAD_SOLFILE_INTERNAL_H */
