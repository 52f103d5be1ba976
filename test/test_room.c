/* test_room.c - issue 36's closed room with curved and faceted parts
 * (tools/room.c: a UV sphere, a round table of fanned 48-sided caps and
 * thin cylinder legs, a flat-shaded head-like mesh, lit by a lamp flush in
 * the ceiling), solved at the defaults, against the project's own path
 * tracer: test/data/room_reference.json, each object's area-mean radiance
 * with its standard error, made once by `pathtrace --objects` (the command
 * is in the file) and never recomputed here.
 *
 * What was wrong (issue 36): the elements of a curved cluster (a patch of
 * several facets of a sphere or a head) took their direct light with the
 * cluster's mean normal instead of their own facet's, and the pixels of
 * the neighbouring cluster of the same surface, or of a wall behind the
 * sphere's silhouette, counted as shadow (elements/direct.c,
 * hemicube/light_views.c).  The patches were right; the elements, which
 * are what is drawn and baked, were dark: in this room the sphere's mean
 * was 2.1 % low and the head's 1.7 % (band sums), and the sphere's 2.9 %
 * low under the lamp's direct light alone.
 *
 * Then (issue 36's mesher, radiosity/mesh/smooth.c) the sphere and the
 * head became patches across their facets, not planar: one hemi-cube at
 * a patch's centre about its mean normal made them dark (sphere -2.05 %,
 * head -1.94 %).  A bent patch's row is now the area-weighted mean of up
 * to 4 cubes, one per group of its cells within 12° of one normal
 * (hemicube/row_samples.c); its cells always split once into elements
 * (elements/refine.c's bent_cell); bent neighbours sharing a corner do
 * not shadow each other's elements (hemicube/light_views.c).  Measured
 * after: sphere -0.31 %, head -0.17 %; dark sphere +0.23 %, head +0.39 %.
 *
 * The solve at the defaults takes 40-45 s of CPU (release build, load
 * average 5-6 on 2 cores): 2,905 patches, 1,620 of them on the table,
 * whose legs' long thin triangles each mesh on their own (what issue 36's
 * mesher is to change).
 *
 *   test_room --write DIR   writes the room to DIR/room.gltf and exits
 *                           (the scene the reference was traced on)
 */
#include "../radiosity/pipeline/pipeline.h"
#include "../tools/room.h"
#include "test.h"

static rad_solution *solution;

/* ------------------------------------------------------------ reference */

enum { MAX_OBJ = 16 };

typedef struct reference {
    char name[MAX_OBJ][32];
    double mean[MAX_OBJ][3], se[MAX_OBJ][3];
    uint32_t count;
    double emitted, absorbed, absorbed_se;
} reference;

/* The numbers of `"key": [a, b, c]` at or after p into v (n of them). */
static int numbers_after(const char *p, const char *key, double *v, int n)
{
    const char *q = p ? strstr(p, key) : NULL;
    if (!q)
        return -1;
    q += strlen(key);
    for (int k = 0; k < n; k++) {
        while (*q == ' ' || *q == '[' || *q == ',' || *q == ':')
            q++;
        char *end;
        v[k] = strtod(q, &end);
        if (end == q)
            return -1;
        q = end;
    }
    return 0;
}

static int reference_load(reference *r)
{
    FILE *f = fopen("test/data/room_reference.json", "r");
    static char text[1 << 16];
    size_t len = f ? fread(text, 1, sizeof text - 1, f) : 0;
    if (f)
        fclose(f);
    text[len] = '\0';
    memset(r, 0, sizeof *r);
    const char *p = text;
    while ((p = strstr(p, "{\"name\": \"")) && r->count < MAX_OBJ) {
        p += strlen("{\"name\": \"");
        const char *q = strchr(p, '"');
        if (!q || q - p >= 32)
            return -1;
        memcpy(r->name[r->count], p, (size_t)(q - p));
        if (numbers_after(q, "\"mean\"", r->mean[r->count], 3) ||
            numbers_after(q, "\"stderr\"", r->se[r->count], 3))
            return -1;
        r->count++;
    }
    const char *tot = strstr(text, "\n \"emitted\"");
    if (!r->count || numbers_after(tot, "\"emitted\"", &r->emitted, 1) ||
        numbers_after(tot, "\"absorbed\"", &r->absorbed, 1) ||
        numbers_after(tot, "\"absorbed_stderr\"", &r->absorbed_se, 1))
        return -1;
    return 0;
}

/* ------------------------------------------------------------ the engine */

/* Area-mean radiance B/π per band of each object: over the elements (what
 * is drawn and baked) into el, over the patches into pa. */
static void object_means(const rad_solution *s, double (*el)[3], double (*pa)[3])
{
    const uint32_t no = s->scene->object_count, nb = s->band_count;
    double ae[MAX_OBJ] = {0}, ap[MAX_OBJ] = {0};
    memset(el, 0, MAX_OBJ * sizeof *el);
    memset(pa, 0, MAX_OBJ * sizeof *pa);
    const rad_mesh *m = s->elements ? s->elements->mesh : s->mesh;
    const double *B = s->elements ? s->elements->B : s->B;
    for (uint32_t e = 0; e < m->patch_count; e++) {
        const rad_patch *p = &m->patches[e];
        ae[p->object] += p->area;
        for (uint32_t b = 0; b < nb; b++)
            el[p->object][b] += p->area * B[(size_t)e * nb + b];
    }
    for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        ap[p->object] += p->area;
        for (uint32_t b = 0; b < nb; b++)
            pa[p->object][b] += p->area * s->B[(size_t)i * nb + b];
    }
    for (uint32_t o = 0; o < no && o < MAX_OBJ; o++)
        for (uint32_t b = 0; b < nb; b++) {
            el[o][b] /= M_PI * ae[o];
            pa[o][b] /= M_PI * ap[o];
        }
}

static int solve(const char *dir, int dark, rad_solution **out)
{
    room_stats rs;
    char path[512];
    if (room_write(dir, "room", dark, &rs))
        return -1;
    snprintf(path, sizeof path, "%s/room.gltf", dir);
    rad_solve_options opt = {0}; /* the defaults */
    rad_error err = {0};
    if (rad_solve_scene_file(path, &opt, out, &err)) {
        fprintf(stderr, "  solve: %s\n", err.message);
        return -1;
    }
    printf("  %s room: %llu triangles, %u objects, %u patches, %u elements\n",
           dark ? "dark" : "lit", (unsigned long long)rs.triangles, rs.objects,
           (*out)->mesh->patch_count, (*out)->elements ? (*out)->elements->mesh->patch_count : 0);
    return (*out)->scene->object_count <= MAX_OBJ && (*out)->band_count == 3 ? 0 : -1;
}

/* ------------------------------------------------------------ tests */

/* Each object's area-mean B against the path tracer's.  Measured (elements,
 * band sum; the reference's standard error of it 0.1 %; release build):
 *   floor +0.31 %, walls +0.00 %, ceiling -0.08 %, sphere -0.50 %,
 *   table +0.62 %, head -1.00 %;
 * before the fix, sphere -2.1 % and head -1.7 % (their patches, which
 * the fix leaves alone, -0.29 % and -0.55 %).  Bounds: the 2 % on each band, and on each
 * object's band sum its measured error plus 0.5 % (so that a 0.5 %
 * regression fails): */
static const struct {
    const char *name;
    double tol;
} band_sum_tol[] = {{"floor", 0.008}, {"walls", 0.005}, {"ceiling", 0.005}, {"lamp", 1e-6},
                    {"sphere", 0.010}, {"table", 0.011}, {"head", 0.015}};

TEST(object_means_match_path_tracer)
{
    reference r;
    CHECK(reference_load(&r) == 0);
    double el[MAX_OBJ][3], pa[MAX_OBJ][3];
    object_means(solution, el, pa);
    const rad_scene *sc = solution->scene;
    uint32_t matched = 0;
    for (uint32_t k = 0; k < r.count; k++)
        for (uint32_t o = 0; o < sc->object_count; o++) {
            if (strcmp(sc->objects[o].name, r.name[k]) != 0)
                continue;
            matched++;
            double se = 0.0, sr = 0.0, sp = 0.0, sx = 0.0;
            for (int b = 0; b < 3; b++) {
                CHECK_MSG(fabs(el[o][b] / r.mean[k][b] - 1.0) <= 0.02, "%s band %d: %.6f vs %.6f",
                          r.name[k], b, el[o][b], r.mean[k][b]);
                se += el[o][b];
                sr += r.mean[k][b];
                sp += pa[o][b];
                sx += r.se[k][b] * r.se[k][b];
            }
            printf("  %-8s elements %.6f, patches %.6f, reference %.6f ± %.2f %%: %+.2f %%\n",
                   r.name[k], se, sp, sr, 100.0 * sqrt(sx) / sr, 100.0 * (se / sr - 1.0));
            double tol = 0.0;
            for (size_t t = 0; t < sizeof band_sum_tol / sizeof band_sum_tol[0]; t++)
                if (!strcmp(band_sum_tol[t].name, r.name[k]))
                    tol = band_sum_tol[t].tol;
            CHECK_MSG(fabs(se / sr - 1.0) <= tol, "%s: band sum %.6f vs %.6f, bound %.1f %%",
                      r.name[k], se, sr, 100.0 * tol);
        }
    CHECK(matched == 7 && r.count == 7);
}

/* The room is closed: what its surfaces absorb, Σ A_i (1 − ρ_i) H_i, is
 * what the lamp emits, Σ A_i E_i.  Measured +0.017 % (the reference's own
 * balance: see its file, within its standard error); bound 0.1 %, the
 * issue's. */
TEST(closed_room_absorbs_what_it_emits)
{
    const uint32_t no = solution->scene->object_count;
    rad_object_stats st[MAX_OBJ];
    rad_error err = {0};
    CHECK(rad_solution_object_stats(solution, st, &err) == 0);
    double emitted = 0.0, absorbed = 0.0;
    for (uint32_t o = 0; o < no; o++)
        for (uint32_t b = 0; b < solution->band_count; b++) {
            emitted += st[o].emitted[b];
            absorbed += st[o].absorbed[b];
        }
    printf("  absorbed %.6f, emitted %.6f: %+.4f %%\n", absorbed, emitted,
           100.0 * (absorbed / emitted - 1.0));
    CHECK(emitted > 0.0);
    CHECK_MSG(fabs(absorbed / emitted - 1.0) <= 1e-3, "%.6f vs %.6f", absorbed, emitted);
    reference r;
    CHECK(reference_load(&r) == 0);
    CHECK_REL(r.emitted, emitted, 1e-6); /* the same lamp, the same area */
    CHECK_NEAR(r.absorbed, r.emitted, 4.0 * r.absorbed_se);
}

/* Under the lamp's direct light alone (everything else black), the mean
 * of a curved object's elements is its patches' mean (exact: the lamp's
 * entries of the patch rows are area averages over each facet).  Measured
 * sphere +0.19 %, head -0.28 %; before the fix the sphere's was -2.9 %.
 * Bound 0.6 %. */
TEST(curved_elements_keep_their_direct_light)
{
    char dir[] = "/tmp/test_room_dark_XXXXXX";
    rad_solution *dark = NULL;
    CHECK(mkdtemp(dir) != NULL);
    if (solve(dir, 1, &dark)) {
        CHECK(!"the dark room solves");
        return;
    }
    double el[MAX_OBJ][3], pa[MAX_OBJ][3];
    object_means(dark, el, pa);
    for (uint32_t o = 0; o < dark->scene->object_count; o++) {
        const char *name = dark->scene->objects[o].name;
        if (strcmp(name, "sphere") && strcmp(name, "head"))
            continue;
        double se = el[o][0] + el[o][1] + el[o][2], sp = pa[o][0] + pa[o][1] + pa[o][2];
        printf("  dark %-8s elements %.6f, patches %.6f: %+.2f %%\n", name, se, sp,
               100.0 * (se / sp - 1.0));
        CHECK(sp > 0.0);
        CHECK_MSG(fabs(se / sp - 1.0) <= 0.006, "%s: %.6f vs %.6f", name, se, sp);
    }
    rad_solution_destroy(dark);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    CHECK(system(cmd) == 0);
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--write")) {
        room_stats rs;
        if (room_write(argv[2], "room", 0, &rs))
            return 1;
        printf("%s/room.gltf: %llu triangles, %u objects\n", argv[2],
               (unsigned long long)rs.triangles, rs.objects);
        return 0;
    }
    char dir[] = "/tmp/test_room_XXXXXX";
    if (!mkdtemp(dir) || solve(dir, 0, &solution)) {
        printf("FAIL solve\n");
        return 1;
    }
    RUN(object_means_match_path_tracer);
    RUN(closed_room_absorbs_what_it_emits);
    rad_solution_destroy(solution);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        printf("  could not remove %s\n", dir);
    RUN(curved_elements_keep_their_direct_light);
    return test_finish("test_room");
}
