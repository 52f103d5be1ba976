/* test_journal.c - nothing computed is lost (issue 21): a solve streams
 * each finished row to OUT.partial (rad_journal).  A solve killed with
 * SIGKILL part-way and run again computes only the missing rows and gives
 * the same solution, bit for bit, as a run that was never interrupted; a
 * row block torn by the kill, or damaged, is dropped with what follows it;
 * rows of other inputs are not reused; a stop asked for (Ctrl-C) keeps what
 * is finished; two runs cannot write one file.  And what is safe in a file
 * need not stay in memory: F's entries are freed once read (refinement,
 * a relight of one change set), with the same answer bit for bit.
 * Cost: ~8 s on a loaded 2-core machine (a box of 97 patches at R = 32,
 * solved six times and relit eight; the relights ~2.3 s of it).
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <signal.h>
#include <stdint.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char tmpdir[256];

/* A closed box of 6 × 4 × 4 patches with a lamp under its top. */
static const char *box =
    "bands 3\n"
    "material wall reflectance 0.6 0.5 0.4\n"
    "material lamp reflectance 0 emission 8 8 8\n"
    "polygon bottom wall subdivide 4 4\n 0 0 0  0 0 1  1 0 1  1 0 0\nend\n"
    "polygon top wall subdivide 4 4\n 0 1 0  1 1 0  1 1 1  0 1 1\nend\n"
    "polygon left wall subdivide 4 4\n 0 0 0  0 1 0  0 1 1  0 0 1\nend\n"
    "polygon right wall subdivide 4 4\n 1 0 0  1 0 1  1 1 1  1 1 0\nend\n"
    "polygon back wall subdivide 4 4\n 0 0 1  0 1 1  1 1 1  1 0 1\nend\n"
    "polygon front wall subdivide 4 4\n 0 0 0  1 0 0  1 1 0  0 1 0\nend\n"
    "polygon lamp lamp\n 0.4 0.99 0.4  0.6 0.99 0.4  0.6 0.99 0.6  0.4 0.99 0.6\nend\n";

/* What the progress callback does at row `at`: kill the process, or raise
 * the stop flag. */
typedef struct stopper {
    uint32_t at;
    int kill;
    volatile sig_atomic_t flag;
} stopper;

static void on_progress(void *user, uint32_t done, uint32_t total)
{
    (void)total;
    stopper *st = user;
    if (done != st->at)
        return;
    if (st->kill)
        raise(SIGKILL); /* the row just stored is in the journal: nothing is flushed later */
    st->flag = 1;
}

static rad_solve_options options(stopper *st)
{
    rad_solve_options o = {0};
    o.hemicube.resolution = 32;
    o.hemicube.processes = 2;
    if (st) {
        o.hemicube.progress = on_progress;
        o.hemicube.progress_user = st;
        o.stop = &st->flag;
    }
    return o;
}

/* Solves the box into path through a journal (fresh or resuming); the
 * stats and the rows computed into *st_out / *rows. */
static int solve_to(const char *path, int fresh, rad_solve_options *o, rad_journal_stats *st_out,
                    uint64_t *rows, rad_error *err)
{
    rad_scene *sc = NULL;
    int rc = rad_scene_parse_polyfile(box, strlen(box), "box.rad", NULL, &sc, err);
    rad_journal *j = NULL;
    if (!rc)
        rc = rad_journal_open(path, fresh, &j, err);
    rad_solution *s = NULL;
    if (!rc) {
        o->journal = j;
        rc = rad_solve_scene(sc, o, &s, err);
        sc = NULL;
    }
    if (j && st_out)
        *st_out = rad_journal_stats_of(j);
    if (s && rows)
        *rows = s->rows_computed;
    if (!rc)
        rc = rad_journal_commit(j, s, err);
    else
        rad_journal_close(j);
    rad_scene_destroy(sc);
    rad_solution_destroy(s);
    return rc;
}

/* Rows a partial file holds, counted from its block heads. */
static uint32_t blocks_in(const char *partial, uint64_t *last_block_at, uint64_t *size)
{
    FILE *f = fopen(partial, "rb");
    if (!f)
        return 0;
    uint8_t head[24];
    uint64_t at = 48;
    uint32_t rows = 0;
    fseek(f, 0, SEEK_END);
    *size = (uint64_t)ftell(f);
    while (fseek(f, (long)at, SEEK_SET) == 0 && fread(head, 1, 24, f) == 24 &&
           memcmp(head, "RBLK", 4) == 0) {
        uint64_t len = 0;
        for (int k = 7; k >= 0; k--)
            len = (len << 8) | head[8 + k];
        if (at + 24 + len > *size)
            break;
        *last_block_at = at;
        rows += head[4] | head[5] << 8;
        at += 24 + len;
    }
    fclose(f);
    return rows;
}

static void same_solution(const char *a, const char *b)
{
    rad_solution *x = NULL, *y = NULL;
    rad_error e = {0};
    CHECK_MSG(rad_solution_read(a, &x, &e) == RAD_OK, "%s", e.message);
    CHECK_MSG(rad_solution_read(b, &y, &e) == RAD_OK, "%s", e.message);
    if (!x || !y) {
        rad_solution_destroy(x);
        rad_solution_destroy(y);
        return;
    }
    uint32_t n = x->mesh->patch_count;
    CHECK(y->mesh->patch_count == n && x->F->rows_done == y->F->rows_done);
    for (uint32_t i = 0; i < n && y->mesh->patch_count == n; i++) {
        const uint32_t *cx, *cy;
        const float *vx, *vy;
        uint32_t c = test_row(x->F, i, 0, &cx, &vx);
        CHECK(test_row(y->F, i, 1, &cy, &vy) == c);
        CHECK(memcmp(cx, cy, 4ull * c) == 0 && memcmp(vx, vy, 4ull * c) == 0);
    }
    /* the same rows solve to the same B, bit for bit */
    CHECK(y->mesh->patch_count == n && memcmp(x->B, y->B, 8ull * n * 3) == 0);
    CHECK(x->iterations == y->iterations);
    rad_solution_destroy(x);
    rad_solution_destroy(y);
}

/* The solutions of files a and b, read whole, hold the same elements (B
 * and rows), irradiance H and light response, bit for bit. */
static void same_elements(const char *a, const char *b)
{
    rad_error e = {0};
    rad_solution *x = NULL, *y = NULL;
    CHECK(rad_solution_read(a, &x, &e) == RAD_OK && rad_solution_read(b, &y, &e) == RAD_OK);
    if (x && y && x->elements && y->elements) {
        const size_t n = (size_t)x->mesh->patch_count * 3;
        const size_t m = (size_t)x->elements->mesh->patch_count * 3;
        CHECK(x->elements->mesh->patch_count == y->elements->mesh->patch_count);
        CHECK(memcmp(x->elements->B, y->elements->B, m * sizeof(double)) == 0);
        CHECK(x->elements->nnz == y->elements->nnz && x->elements->nnz > 0);
        if (x->elements->nnz == y->elements->nnz && x->elements->col && y->elements->col)
            CHECK(memcmp(x->elements->col, y->elements->col, 4 * x->elements->nnz) == 0 &&
                  memcmp(x->elements->val, y->elements->val, 4 * x->elements->nnz) == 0);
        CHECK(x->irradiance && y->irradiance &&
              memcmp(x->irradiance, y->irradiance, n * sizeof(double)) == 0);
        CHECK(x->basis && y->basis && x->basis->groups == y->basis->groups &&
              memcmp(x->basis->H, y->basis->H, x->basis->groups * n * sizeof(double)) == 0);
    } else {
        CHECK(!"both solutions read, with elements");
    }
    rad_solution_destroy(x);
    rad_solution_destroy(y);
}

static void path_in(char *out, size_t size, const char *name)
{
    snprintf(out, size, "%s/%s", tmpdir, name);
}

TEST(killed_solve_resumes_with_only_the_missing_rows)
{
    char ref[300], out[300], partial[320];
    path_in(ref, sizeof ref, "ref.sol");
    path_in(out, sizeof out, "out.sol");
    snprintf(partial, sizeof partial, "%s.partial", out);
    rad_error e = {0};
    rad_solve_options o = options(NULL);
    uint64_t total = 0;
    CHECK_MSG(solve_to(ref, 1, &o, NULL, &total, &e) == RAD_OK, "%s", e.message);
    CHECK(total > 60);

    /* A child solves into out.sol and is killed (SIGKILL) at row 40. */
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        stopper st = {.at = 40, .kill = 1};
        rad_solve_options ok = options(&st);
        solve_to(out, 1, &ok, NULL, NULL, &e);
        _exit(0); /* not reached: killed at row 40 */
    }
    int status = 0;
    CHECK(pid > 0 && waitpid(pid, &status, 0) == pid);
    CHECK(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
    struct stat sb;
    CHECK(stat(out, &sb) != 0); /* no output: the solve never finished */
    uint64_t last = 0, size = 0;
    uint32_t kept = blocks_in(partial, &last, &size);
    CHECK_MSG(kept >= 40 && kept < total, "%u rows kept of %llu", kept,
              (unsigned long long)total);

    /* Tear the last block as a crash in the middle of a write would. */
    CHECK(last > 0 && truncate(partial, (off_t)(last + 30)) == 0);
    rad_journal_stats st = {0};
    uint64_t rows = 0;
    o = options(NULL);
    CHECK_MSG(solve_to(out, 0, &o, &st, &rows, &e) == RAD_OK, "%s", e.message);
    CHECK(st.resumed == kept - 1 && st.torn_bytes == 30 && st.discarded == 0);
    CHECK_MSG(rows == total - st.resumed, "%llu rows computed, %u resumed, %llu in all",
              (unsigned long long)rows, st.resumed, (unsigned long long)total);
    CHECK(stat(partial, &sb) != 0); /* committed: renamed onto out.sol */
    same_solution(ref, out);
}

/* End of the k-th block (k = 0 is the file's head: 48 bytes) of a partial file. */
static uint64_t block_end(const char *partial, int k)
{
    FILE *f = fopen(partial, "rb");
    uint64_t at = 48;
    for (int q = 0; f && q < k; q++) {
        uint8_t head[24];
        if (fseek(f, (long)at, SEEK_SET) != 0 || fread(head, 1, 24, f) != 24)
            break;
        uint64_t len = 0;
        for (int b = 7; b >= 0; b--)
            len = (len << 8) | head[8 + b];
        at += 24 + len;
    }
    if (f)
        fclose(f);
    return at;
}

TEST(a_stop_keeps_the_finished_rows)
{
    char out[300], partial[320];
    path_in(out, sizeof out, "stop.sol");
    snprintf(partial, sizeof partial, "%s.partial", out);
    stopper s = {.at = 25};
    rad_solve_options o = options(&s);
    rad_error e = {0};
    rad_journal_stats st = {0};
    CHECK(solve_to(out, 1, &o, &st, NULL, &e) == RAD_ERR_INTERRUPTED);
    CHECK_MSG(strstr(e.message, "box.rad: form factors: interrupted"), "%s", e.message);
    uint64_t last = 0, size = 0;
    uint32_t kept = blocks_in(partial, &last, &size);
    CHECK(kept >= 25 && st.kept == kept);

    /* A damaged block (one flipped byte in the third row's values) ends
     * what is reused: the two rows before it stay, the rest is cut off. */
    uint64_t two = block_end(partial, 2);
    FILE *f = fopen(partial, "r+b");
    uint8_t b = 0;
    CHECK(f && fseek(f, (long)(two + 24 + 8), SEEK_SET) == 0 && fread(&b, 1, 1, f) == 1);
    b ^= 0x40;
    CHECK(f && fseek(f, (long)(two + 24 + 8), SEEK_SET) == 0 && fwrite(&b, 1, 1, f) == 1);
    if (f)
        fclose(f);
    o = options(NULL);
    uint64_t rows = 0, total = 0;
    CHECK_MSG(solve_to(out, 0, &o, &st, &rows, &e) == RAD_OK, "%s", e.message);
    CHECK_MSG(st.resumed == 2 && st.torn_bytes == size - two, "resumed %u, dropped %llu",
              st.resumed, (unsigned long long)st.torn_bytes);
    char ref[300];
    path_in(ref, sizeof ref, "ref.sol");
    rad_solution *r = NULL;
    CHECK(rad_solution_read(ref, &r, &e) == RAD_OK);
    total = r ? r->F->rows_done : 0;
    rad_solution_destroy(r);
    CHECK(rows == total - 2);
    same_solution(ref, out);
}

/* Rows kept for another mesh (here: another subdivision) are not reused,
 * and say so; --fresh (fresh = 1) reuses none either. */
TEST(other_inputs_start_afresh)
{
    char out[300], partial[320];
    path_in(out, sizeof out, "other.sol");
    snprintf(partial, sizeof partial, "%s.partial", out);
    stopper s = {.at = 20};
    rad_solve_options o = options(&s);
    rad_error e = {0};
    rad_journal_stats st = {0};
    CHECK(solve_to(out, 1, &o, &st, NULL, &e) == RAD_ERR_INTERRUPTED);
    uint32_t kept = st.kept;
    CHECK(kept >= 20);
    o = options(NULL);
    o.hemicube.resolution = 16; /* another R: another rows key */
    uint64_t rows = 0;
    CHECK_MSG(solve_to(out, 0, &o, &st, &rows, &e) == RAD_OK, "%s", e.message);
    CHECK(st.resumed == 0 && st.discarded == kept);
    stopper s2 = {.at = 20};
    o = options(&s2);
    CHECK(solve_to(out, 1, &o, &st, NULL, &e) == RAD_ERR_INTERRUPTED);
    o = options(NULL);
    CHECK(solve_to(out, 1, &o, &st, &rows, &e) == RAD_OK);
    CHECK(st.resumed == 0 && st.discarded >= 20 && rows > 60);
}

/* Two runs cannot append to one partial file: the second is refused. */
TEST(one_writer_at_a_time)
{
    char out[300];
    path_in(out, sizeof out, "locked.sol");
    rad_journal *a = NULL, *b = NULL;
    rad_error e = {0};
    rad_matrix *F = rad_matrix_create(4), *G = rad_matrix_create(4);
    CHECK(rad_journal_open(out, 0, &a, &e) == RAD_OK && rad_journal_open(out, 0, &b, &e) == RAD_OK);
    CHECK(rad_journal_attach(a, F, 7, &e) == RAD_OK);
    CHECK(rad_journal_attach(b, G, 7, &e) == RAD_ERR_IO);
    CHECK_MSG(strstr(e.message, "locked.sol.partial is being written by another process"), "%s",
              e.message);
    const uint32_t col[1] = {2};
    const float val[1] = {0.5f};
    CHECK(rad_matrix_set_row(F, 1, 1, col, val, &e) == RAD_OK);
    rad_journal_close(a);
    rad_journal_close(b);
    /* closed: the row stays for the next run */
    rad_matrix_destroy(G);
    G = rad_matrix_create(4);
    CHECK(rad_journal_open(out, 0, &b, &e) == RAD_OK && rad_journal_attach(b, G, 7, &e) == RAD_OK);
    CHECK(rad_journal_stats_of(b).resumed == 1 && G->row_done[1] && G->row_count[1] == 1);
    rad_journal_close(b);
    rad_matrix_destroy(F);
    rad_matrix_destroy(G);
}

/* With refinement (the default) and one light group, a journaled solve
 * frees F's entries once refinement has read what it needs of them
 * (pipeline.c, release_rows): the solution comes back without them, its H
 * kept, and its file is the one a solve that kept F in memory writes - the
 * same rows, B, elements, irradiance and light response, bit for bit. */
TEST(refinement_without_the_rows_in_memory)
{
    char jpath[300], ppath[300];
    path_in(jpath, sizeof jpath, "journaled.sol");
    path_in(ppath, sizeof ppath, "plain.sol");
    rad_error e = {0};
    rad_scene *sc = NULL, *sc2 = NULL;
    CHECK(rad_scene_parse_polyfile(box, strlen(box), "box.rad", NULL, &sc, &e) == RAD_OK);
    CHECK(rad_scene_parse_polyfile(box, strlen(box), "box.rad", NULL, &sc2, &e) == RAD_OK);
    rad_journal *j = NULL;
    CHECK(rad_journal_open(jpath, 1, &j, &e) == RAD_OK);
    rad_solve_options o = options(NULL);
    o.journal = j;
    rad_solution *s = NULL, *t = NULL;
    CHECK_MSG(rad_solve_scene(sc, &o, &s, &e) == RAD_OK, "%s", e.message);
    if (s) {
        CHECK(!s->F->entries_loaded && s->F->rows_done > 60 && !s->F->data);
        CHECK(s->irradiance && s->elements && s->elements->mesh->patch_count > 96);
        CHECK(s->basis && s->basis->groups == 1);
        CHECK_MSG(rad_journal_commit(j, s, &e) == RAD_OK, "%s", e.message);
    } else {
        rad_journal_close(j);
    }
    rad_solve_options p = options(NULL);
    CHECK_MSG(rad_solve_scene(sc2, &p, &t, &e) == RAD_OK, "%s", e.message);
    CHECK(t && t->F->entries_loaded && t->F->rows_done == (s ? s->F->rows_done : 0));
    CHECK_MSG(t && rad_solution_write(t, ppath, &e) == RAD_OK, "%s", e.message);
    rad_solution_destroy(s);
    rad_solution_destroy(t);
    same_solution(ppath, jpath);
    same_elements(ppath, jpath);
}

/* base relit with `edits` (";"-separated KIND:NAME=VALUE, KIND r
 * reflectance, e emission) and solved again as `radiosity relight` does
 * (its file read without F, then F read), written to out sharing F where
 * it can: with release = 0 every part read at once and F kept (the order
 * before the change), with release = 1 the element rows left out of the
 * read and F's entries freed before they are read (release_matrix).  The
 * solution after the write, for the caller to look at (caller owns). */
static rad_solution *relit(const char *base, const char *edits, int release, const char *out,
                           rad_write_info *info)
{
    rad_error e = {0};
    rad_edit ed[4];
    uint32_t ne = 0;
    char list[256];
    snprintf(list, sizeof list, "%s", edits);
    for (char *save = NULL, *one = strtok_r(list, ";", &save); one && ne < 4;
         one = strtok_r(NULL, ";", &save), ne++)
        CHECK(rad_edit_parse(one[0] == 'r' ? RAD_EDIT_REFLECTANCE : RAD_EDIT_EMISSION, one + 2,
                             &ed[ne], &e) == RAD_OK);
    const unsigned parts = release ? RAD_PART_MATRIX_PLACE | RAD_PART_BASIS
                                   : RAD_PART_MATRIX_PLACE | RAD_PART_BASIS | RAD_PART_ELEMENT_ROWS;
    rad_solution *s = NULL;
    CHECK_MSG(rad_solution_read_parts(base, parts, &s, &e) == RAD_OK, "%s", e.message);
    if (!s)
        return NULL;
    CHECK(s->elements && s->elements->rows_loaded == !release);
    rad_solve_options o = options(NULL);
    o.release_matrix = release;
    const rad_write_options wo = {.share_matrix = 1};
    CHECK_MSG(rad_solution_apply_edits(s, ed, ne, &e) == RAD_OK &&
                  rad_solution_load_matrix(s, &e) == RAD_OK && rad_resolve(s, &o, &e) == RAD_OK &&
                  rad_solution_write_opts(s, out, &wo, info, &e) == RAD_OK,
              "%s", e.message);
    return s;
}

/* A relight of one change set solved again frees F's entries once the
 * patches are solved and reads the elements' rows only then (pipeline.c,
 * gather_elements; the relight's peak at 8k patches 1.22 -> 1.09 × F):
 * the same file as the relight that held everything at once - B, elements,
 * H and light response bit for bit - still sharing F; and a relight of
 * that relight too.  Where F must stay it stays, with the same answer:
 * an edit that adds rows (the black lamp made reflective: F is no longer
 * the file's, written whole) and two light groups (the second group's
 * solve needs F). */
TEST(reflectance_relight_without_the_rows_in_memory)
{
    char base[300], a[300], b[300], a2[300], b2[300];
    path_in(base, sizeof base, "base.sol");
    rad_error e = {0};
    rad_scene *sc = NULL;
    rad_solution *s = NULL;
    rad_solve_options o = options(NULL);
    CHECK(rad_scene_parse_polyfile(box, strlen(box), "box.rad", NULL, &sc, &e) == RAD_OK);
    CHECK_MSG(rad_solve_scene(sc, &o, &s, &e) == RAD_OK && rad_solution_write(s, base, &e) == RAD_OK,
              "%s", e.message);
    CHECK(s && s->elements && s->elements->interp); /* the gather's F-reading part is used */
    rad_solution_destroy(s);
    static const struct {
        const char *edits;
        int released; /* F's entries freed */
        int shared;   /* the file refers to F, no rows added */
    } cases[] = {{"r:wall=0.3", 1, 1}, {"r:lamp=0.4", 0, 0}, {"r:wall=0.3;e:top=1", 0, 1}};
    for (size_t k = 0; k < sizeof cases / sizeof *cases; k++) {
        char name[32];
        snprintf(name, sizeof name, "keep%zu.sol", k);
        path_in(a, sizeof a, name);
        snprintf(name, sizeof name, "free%zu.sol", k);
        path_in(b, sizeof b, name);
        rad_write_info ia = {0}, ib = {0};
        rad_solution *x = relit(base, cases[k].edits, 0, a, &ia);
        rad_solution *y = relit(base, cases[k].edits, 1, b, &ib);
        CHECK_MSG(x && x->F->entries_loaded && ia.matrix_shared == cases[k].shared, "case %zu", k);
        CHECK_MSG(y && y->F->entries_loaded == !cases[k].released &&
                      ib.matrix_shared == cases[k].shared && y->elements->rows_loaded,
                  "case %zu: %s", k, cases[k].edits);
        CHECK_MSG(y && y->basis && y->basis->groups == (k == 2 ? 2u : 1u), "case %zu", k);
        rad_solution_destroy(x);
        rad_solution_destroy(y);
        same_solution(a, b);
        same_elements(a, b);
    }
    /* a relight of the first relight (its F a MATRIXREF) */
    path_in(a, sizeof a, "keep0.sol");
    path_in(b, sizeof b, "free0.sol");
    path_in(a2, sizeof a2, "keep0b.sol");
    path_in(b2, sizeof b2, "free0b.sol");
    rad_write_info ia = {0}, ib = {0};
    rad_solution *x = relit(a, "r:lamp=0;r:wall=0.7", 0, a2, &ia);
    rad_solution *y = relit(b, "r:lamp=0;r:wall=0.7", 1, b2, &ib);
    CHECK(x && y && !y->F->entries_loaded && ia.matrix_shared && ib.matrix_shared);
    rad_solution_destroy(x);
    rad_solution_destroy(y);
    same_solution(a2, b2);
    same_elements(a2, b2);
}

static void remove_dir(const char *dir)
{
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "cannot remove %s\n", dir);
}

int main(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/test_journal.XXXXXX");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    RUN(killed_solve_resumes_with_only_the_missing_rows);
    RUN(a_stop_keeps_the_finished_rows);
    RUN(other_inputs_start_afresh);
    RUN(one_writer_at_a_time);
    RUN(refinement_without_the_rows_in_memory);
    RUN(reflectance_relight_without_the_rows_in_memory);
    remove_dir(tmpdir);
    return test_finish("test_journal");
}
