/* store_internal.h - what the files of radiosity/store/ share; private to
 * the folder (the public contract is solution.h): the solution file's
 * constants and section table (docs/solution-format.md), its checksum, and
 * the rules both the writer and the reader apply, so that the writer never
 * writes a file the reader would refuse.
 */
#ifndef RAD_STORE_INTERNAL_H
#define RAD_STORE_INTERNAL_H

#include "solution.h"

#define SOL_MAGIC "RADSOL\r\n"  /* 8 bytes; the CR LF catches text-mode mangling */
/* Version 2 = version 1 + the LIGHTS section; version 3 = + the ELEMENTS
 * section; version 4 = + the ELEMENTLIGHTS section (each element's own
 * direct light); version 5 = MESH may hold two-sided sheets (a transmitting
 * polygon's front cells followed by their back twins), with the sections of
 * versions 1-4 as its content needs them, and CAMERAS when the scene has
 * orthographic cameras.  A file is written with the lowest
 * version that holds what it has (1 without punctual lights or elements, 2
 * with lights, 3 with elements, 4 with elements that carry their own direct
 * light, 5 with sheets), so older programs still read what they understand,
 * and a file they would misread - skipping LIGHTS, ELEMENTS or ELEMENTLIGHTS
 * without a word, which for the last would relight the elements from their
 * patches' direct light, or taking a sheet's two sides for two unrelated
 * opaque surfaces - carries a version they refuse. */
#define SOL_VERSION 5u
#define SOL_VERSION_SHEETS 5u
#define SOL_HEADER_BYTES 32u
#define SOL_SECTION_HEADER 12u  /* u32 tag + u64 length */
#define SOL_MAX_STRING 4096u
#define SOL_MAX_FILE (64ull << 30)
#define SOL_MAX_STAGES 64u      /* a future version may time more stages */
#define SOL_SOLVER_MAX (sizeof(((rad_solution *)0)->solver) - 1)
/* Largest row sum rad_matrix_check accepts: Σ_j F_ij <= 1 plus the
 * hemi-cube's discretisation error. */
#define SOL_ROW_SUM_MAX (1.0 + 1e-3)

/* The first five sections appear in every file; LIGHTS only when the scene
 * has punctual lights, ELEMENTS only when the solution has elements,
 * CAMERAS (version 5 only) only when the scene has orthographic cameras,
 * SURFACE (version 5 only) only when a material has a glossy lobe
 * (rad_material's specular and roughness, which only the gather renderer
 * reads), CLUSTERS (version 5 only) only when the mesh has a cell layer
 * (patches of several cells, rad.h), PROGRESS (version 5 only) only when
 * the last solve was progressive (its shots, previews and row store). */
enum { SEC_INFO, SEC_SCENE, SEC_MESH, SEC_MATRIX, SEC_PATCHDATA, SEC_LIGHTS, SEC_ELEMENTS,
       SEC_ELEMENT_LIGHTS, SEC_CAMERAS, SEC_SURFACE, SEC_CLUSTERS, SEC_PROGRESS, SEC_COUNT };
extern const char sol_sec_tag[SEC_COUNT][4];
extern const char *const sol_sec_name[SEC_COUNT];
/* Version 5's INFO bit of each optional section (0 for the first five):
 * LIGHTS 1, ELEMENTS 2, ELEMENTLIGHTS 4, CAMERAS 8, SURFACE 16, CLUSTERS
 * 32, PROGRESS 128 (64 is issue 18's ELEMENT_INDIRECT). */
extern const uint8_t sol_sec_bit[SEC_COUNT];
/* Sections each version may hold: 1 the first five, 2 + LIGHTS, 3 +
 * ELEMENTS (where LIGHTS is there exactly when the scene has lights), 4 +
 * ELEMENTLIGHTS (LIGHTS always), 5 any of them (SURFACE, CLUSTERS and
 * PROGRESS included) as the content needs. */
extern const int sol_version_sections[SOL_VERSION + 1];

/* Minimum encoded sizes of one element, used to bound counts before
 * allocating: a count of k elements needs at least k × this many bytes. */
#define MIN_STRING 4u
#define MIN_CAMERA (MIN_STRING + 11u * 8u)
#define MIN_POLYGON (MIN_STRING + 5u * 4u + 3u * 24u) /* material, object, subdivisions, count */
#define PATCH_BYTES (7u * 4u + 7u * 8u)
#define VERTEX_BYTES (3u * 8u + 1u)
#define MIN_ROW (2u * 4u)
#define MIN_ENTRY (1u + 4u) /* one varint byte + a float32 */
/* one preview of PROGRESS: shots, rows, seconds, unshot */
#define PREVIEW_BYTES (4u + 4u + 8u + 8u)
/* name, kind, position, direction, cones, present flag, count; + 16 per band */
#define MIN_LIGHT (MIN_STRING + 1u + 48u + 16u + 1u + 4u)
#define ELEMENT_VERTEX_BYTES (3u * 8u + 1u)
/* patch, level, four corners, row count; + 8 per band */
#define MIN_ELEMENT (4u + 1u + 16u + 4u)
/* camera index, projection, xmag, ymag */
#define ORTHO_CAMERA_BYTES (4u + 1u + 16u)
/* four corners and a polygon */
#define CLUSTER_CELL_BYTES (5u * 4u)


/* ------------------------------------------------- checksum (format.c) */

/* CRC-64/XZ lookup tables (slicing by 8). */
typedef struct sol_crc64_tables {
    uint64_t t[8][256];
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
int sol_check_info(const rad_solution *s, const char *file, const char *where, int code,
                   rad_error *err);

/* The progress rules (PROGRESS): times and fractions finite and >= 0, the
 * converged flag 0 or 1, previews in order of shots and time. */
int sol_check_progress(const rad_solution *s, const char *file, const char *where, int code,
                       rad_error *err);

/* The light rules; `where` as for sol_check_patch_values. */
int sol_check_lights(const rad_solution *s, const char *file, const char *where, int code,
                     rad_error *err);

/* ------------------------------------------- allocation (solution.c) */

/* n × bands doubles, or NULL when that does not fit in size_t or memory. */
double *sol_alloc_band_array(uint32_t n, uint32_t bands);

/* The light arrays for `count` lights (intensity from the scene's nominal
 * values, no power yet); 0, or -1 when memory runs out. */
int sol_alloc_lights(rad_solution *s, uint32_t count);

#endif /* RAD_STORE_INTERNAL_H */
