/* solfile.h - the solution's file: everything a later command needs, in
 * one versioned, checksummed file (docs/solution-format.md), written in one
 * go or streamed by a solve as its rows finish (the journal), read whole or
 * in the parts a command needs; and the solution as open data (CSV, Matrix
 * Market).
 *
 * Invariants: files are written to a temporary name and renamed, so a
 * failed write never replaces a good file; the writer applies the reader's
 * rules first, so it never writes a file the reader would refuse; whatever
 * the bytes, a read fails with a message naming the file or returns a
 * solution that satisfies solution.h.  A solution read from a file carries
 * the reader's record of it (rad_solution.origin): where F's rows are, so
 * that they can be read later or shared by a solution written from it,
 * and which parts were left out, so that no write loses them.
 *
 * The files of radiosity/solfile/ implement this header: write.c and
 * read.c (the file), parse.c (its sections), format.c (what those share),
 * journal.c (a solve's file in progress), origin.c (the reader's record of
 * a solution), export.c (open data); solfile_internal.h holds the format's
 * private constants.
 */
#ifndef RAD_SOLFILE_H
#define RAD_SOLFILE_H

#include "../core/rad.h"
#include "../mesh/mesh.h"
#include "../solution/solution.h"

/* The solution file's format versions (docs/solution-format.md): every file
 * is written as RAD_SOLFILE_VERSION; files of RAD_SOLFILE_OLDEST_VERSION
 * up to RAD_SOLFILE_VERSION are read. */
#define RAD_SOLFILE_VERSION 8u
#define RAD_SOLFILE_OLDEST_VERSION 1u

/* Where a solution's F was read from: the MATRIX section of a version 6
 * file (the solution's own file, or the one its MATRIXREF names).  A
 * relight that computed no row writes a reference to it instead of the rows
 * (rad_write_options.share_matrix).  Part of the reader's record of a
 * solution (rad_solution_matrix_file). */
typedef struct rad_matrix_file {
    char *path;           /* absolute path of the file holding the section (owned) */
    uint64_t offset;      /* the section as that file's index lists it */
    uint64_t length;
    uint64_t crc;         /* CRC-64/XZ of the section */
    uint64_t bytes;       /* F->bytes when read (0 once its entries are released,
                           * rad_solution_release_matrix): a matrix that grew since is
                           * another one */
} rad_matrix_file;

/* ------------------------------------- what a solution read from a file knows */

/* Where s's F is in a file (version 6 on): NULL when F came from memory or
 * an older file, or that file could not be found (RAD_PART_MATRIX_PLACE).
 * Owned by s. */
const rad_matrix_file *rad_solution_matrix_file(const rad_solution *s);

/* 1 when s was read without RAD_PART_BASIS from a file that holds stored
 * light responses (a writer refuses it: they would be lost). */
int rad_solution_basis_skipped(const rad_solution *s);

/* -------------------------------------------- writing and reading (write.c, read.c) */

/* Writes the solution to path (format version 7, docs/solution-format.md)
 * through a temporary file and rename, F's rows included.  Elements whose
 * rows were not read (rows_loaded 0) are refused (RAD_ERR_USAGE): read
 * RAD_PART_ELEMENT_ROWS to write them. */
int rad_solution_write(const rad_solution *s, const char *path, rad_error *err);

/* {0} means defaults: the rows are written. */
typedef struct rad_write_options {
    /* 1: when F is still the MATRIX section it was read from
     * (rad_solution_matrix_file, no row added since), write a MATRIXREF to
     * it instead of the rows.  The file holding it gets a second name,
     * PATH.matrix (a hard link, no copy), which the reference names, so
     * that moving, replacing or deleting the original leaves this solution
     * whole; where the file system has no hard links the reference names
     * the original by its absolute path.  Either way the section's length
     * and CRC-64 are checked whenever it is read: a matrix removed or
     * changed is an error, never a silently different answer. */
    int share_matrix;
} rad_write_options;

/* What rad_solution_write_opts did with F. */
typedef struct rad_write_info {
    int matrix_shared;        /* 1: a MATRIXREF was written, no rows */
    int linked;               /* 1: through the hard link PATH.matrix */
    char matrix_path[4096];   /* the file the reference names */
} rad_write_info;

/* rad_solution_write with options; info (may be NULL) says what was done. */
int rad_solution_write_opts(const rad_solution *s, const char *path, const rad_write_options *opt,
                            rad_write_info *info, rad_error *err);

/* The size in bytes of s's file as a solve writes it now (rad_journal: each
 * row present in a block of its own; rad_solution_write groups rows into
 * larger blocks, a little smaller): a counting pass, nothing written, what
 * a solve's estimate builds on.  Elements whose rows were not read count
 * them at the least an entry takes (MIN_ENTRY bytes: a float and a column
 * gap of one byte). */
uint64_t rad_solution_file_bytes(const rad_solution *s);

/* The bytes row i of F adds to that file (0 for a missing row). */
uint64_t rad_solution_row_file_bytes(const rad_matrix *F, uint32_t i);

/* Reads and checks a solution file, everything in it.  Version 6: the
 * header, the index (its CRC) and each section (its own CRC, then every
 * index and count against the section's size before allocating); F comes
 * from the file's MATRIX or from the file its MATRIXREF names.  Versions
 * 1-5: the whole file and its one CRC.  Caller owns *out. */
int rad_solution_read(const char *path, rad_solution **out, rad_error *err);

/* Parts of a solution that a reader may leave out. */
#define RAD_PART_MATRIX 1u  /* F's entries: without it s->F has the rows present and their
                             * entry counts only (entries_loaded = 0), and s->irradiance */
#define RAD_PART_MATRIX_PLACE 2u /* without RAD_PART_MATRIX: still find where F's rows are
                                  * (rad_solution_matrix_file, F->key: MATRIX's place, or
                                  * the file a MATRIXREF names, its index checked) so that a
                                  * solution written from it can share them; left empty,
                                  * without an error, when that file is gone or changed */
#define RAD_PART_ELEMENT_ROWS 4u /* the elements' row entries F_ej (ELEMENTROWS, version 7):
                                  * without it rad_elements.rows_loaded = 0; what gathers
                                  * the elements again, exports or writes them needs it */
#define RAD_PART_BASIS 8u /* the stored light responses (BASIS): without it s->basis is NULL,
                           * and rad_solution_basis_skipped 1 when the file holds them; a
                           * relight by superposition and the writer need it */
#define RAD_PARTS_ALL (RAD_PART_MATRIX | RAD_PART_ELEMENT_ROWS | RAD_PART_BASIS)

/* rad_solution_read of the parts in `parts` only (everything else is always
 * read).  A version 6 or 7 file's sections that are not needed are neither
 * read nor checked: render and report read no byte of F, nor (version 7) of
 * the elements' rows.  Older files are read whole (a version 6 file's
 * element rows are inside ELEMENTS: always read). */
int rad_solution_read_parts(const char *path, unsigned parts, rad_solution **out,
                            rad_error *err);

/* Reads F's entries into a solution read without them, from the file it
 * was read from (which must not have changed since: its index's CRC is
 * compared). */
int rad_solution_load_matrix(rad_solution *s, rad_error *err);

/* Reads the elements' rows into a solution read without them
 * (RAD_PART_ELEMENT_ROWS), from its file as rad_solution_load_matrix does;
 * nothing to do when it has no elements or they are read.  A relight reads
 * them only once F's entries are released, so that the two are never in
 * memory together. */
int rad_solution_load_element_rows(rad_solution *s, rad_error *err);

/* Is F, as it is now, the MATRIX section rad_solution_matrix_file names:
 * read from it (or released since, below) and no row added?  What a writer
 * needs to share it (rad_write_options.share_matrix). */
int rad_solution_matrix_in_file(const rad_solution *s);

/* Frees F's entries (rad_matrix_release_entries), keeping which rows exist
 * and the reader's record of F in step: when F was that file's section it
 * still is, as for a solution read without RAD_PART_MATRIX, so a writer
 * still shares it and rad_solution_load_matrix reads it again.  For when nothing left
 * in memory reads the entries and a file holds them (this one, or the
 * solve's journal); the caller first puts the H of the current B in
 * s->irradiance (the writer needs it).  NULL does nothing. */
void rad_solution_release_matrix(rad_solution *s);

/* rad_solution_read from memory; `name` appears in messages.  check_sum = 0
 * skips the checksums (the fuzzer uses that to reach the structure checks).
 * A MATRIXREF cannot be followed from memory: with RAD_PART_MATRIX it is an
 * error. */
int rad_solution_parse(const void *data, size_t size, const char *name, int check_sum,
                       rad_solution **out, rad_error *err);
int rad_solution_parse_parts(const void *data, size_t size, const char *name, int check_sum,
                             unsigned parts, rad_solution **out, rad_error *err);

/* ----------------------------------------- a solve's file in progress (journal.c) */

/* What determines the form-factor rows of a solve: a CRC-64 of the mesh
 * (every vertex and patch as MESH stores them), the hemi-cube resolution,
 * the patches with exact factors (may be NULL), `flags` (the options that
 * change rows) and this program's version.  Rows kept from an earlier run
 * are reused only under the same key. */
uint64_t rad_rows_key(const rad_mesh *mesh, uint32_t resolution, const uint8_t *exact,
                      uint32_t flags);

/* A solve's output file while the solve runs: PATH.partial, a version 7
 * file whose MATRIX section grows by one block per finished row.  A crash,
 * a kill or Ctrl-C leaves the rows finished so far in it; the next solve
 * for the same PATH reads them back (a block cut short by the crash is
 * detected by its CRC and dropped) and computes only the others.  When the
 * solve is done, rad_journal_commit appends the other sections and the
 * index and renames the file onto PATH. */
typedef struct rad_journal rad_journal;

typedef struct rad_journal_stats {
    uint32_t kept;        /* rows the file holds now */
    uint32_t resumed;     /* rows taken from the file */
    uint32_t discarded;   /* rows of an earlier run with another key (scene, mesh, options) */
    uint64_t torn_bytes;  /* bytes of an unfinished block at the end, dropped */
} rad_journal_stats;

/* A journal for PATH; fresh = 1 throws away the rows PATH.partial holds
 * (they count as discarded).  The file is opened (or created), and locked
 * against other processes, by rad_journal_attach.  Caller owns *out: it
 * ends with rad_journal_commit or rad_journal_close. */
int rad_journal_open(const char *path, int fresh, rad_journal **out, rad_error *err);

/* Loads the rows the file holds under `key` into F (an empty matrix of the
 * mesh's n), starts the file afresh if it holds another key's rows, and
 * from then on appends every row F receives (F's sink; F must outlive the
 * journal or be detached by rad_journal_close). */
int rad_journal_attach(rad_journal *j, rad_matrix *F, uint64_t key, rad_error *err);

/* Does the file hold exactly the rows F holds, every one written since
 * attach (F attached, no row dropped by a bounded row store)?  Then F's
 * entries may be released (rad_matrix_release_entries) once nothing in
 * memory needs them: rad_journal_commit writes the file without them (its
 * MATRIX is already there, checked row by row as it was appended), the
 * irradiance then from s->irradiance or the basis. */
int rad_journal_holds(const rad_journal *j, const rad_matrix *F);

/* What rad_journal_attach found. */
rad_journal_stats rad_journal_stats_of(const rad_journal *j);

/* The partial file's name, for messages. */
const char *rad_journal_path(const rad_journal *j);

/* Writes s's other sections and the index after the rows, syncs, and
 * renames the file onto PATH.  s->F must be the attached matrix.  When F
 * has dropped rows the file holds (the progressive solver's bounded row
 * store), PATH is written whole from F instead and the partial file
 * removed; F's entries may have been released (rad_journal_holds).  Frees
 * j whatever happens; on failure the partial file stays. */
int rad_journal_commit(rad_journal *j, const rad_solution *s, rad_error *err);

/* Stops taking F's rows (before F is freed: a solve that failed). */
void rad_journal_detach(rad_journal *j);

/* Syncs and closes, keeping the file for the next run (removing it when it
 * holds no row); detaches F.  NULL does nothing. */
void rad_journal_close(rad_journal *j);

/* ------------------------------------------------------ open data (export.c) */

/* Writes s as open data into the existing directory dir (docs/export.md):
 *   patches.csv     patch, object, material, area, centroid, normal, F_row,
 *                   then ρ, E and B per band (rho_R, E_R, B_R, ...)
 *   F.mtx           F_ij, Matrix Market coordinate real general, row i =
 *                   patch i - 1 = line i of patches.csv; rows never
 *                   computed are absent (F_row 0), not zero
 *   elements.csv, elements-F.mtx   the same for elements, when s has them
 * Numbers read back exactly (doubles 15-17 digits, the float F_ij 9).  Files are renamed into
 * place only once all are written: a failure before that replaces none. */
int rad_solution_export(const rad_solution *s, const char *dir, rad_error *err);

/* Writes View3D 4.0's text view-factor file (view3d_out.c) for the factors
 * f of the .vs3 model m: through a temporary file and rename. */
int rad_view3d_write(const char *path, const rad_vs3 *m, const rad_vs3_factors *f,
                     rad_error *err);

#endif /* RAD_SOLFILE_H */
