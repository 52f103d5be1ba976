/* test_parts.c - issue 36's small parts (radiosity/mesh/parts.c).
 *
 * A closed room 4 × 4 × 3 m (ρ = 0.5) at --patch-size 0.5, a point light,
 * a black board between the light and the wall x = 0, and in front of that
 * wall one layer of 1,000 cubes 2 cm across (0.035 diagonal: under 0.1 ×
 * the patch size), 40 across and 25 high, the 20 columns nearer the room's
 * y = 0 of one material (ρ = 0.6, object "partsA"), the others of another
 * (ρ = 0.3, "partsB").  The board shadows the A columns below y ≈ 1.53;
 * every B cube is lit.
 *   - rows: the parts share a patch per object, material and grid cube, so
 *     the rows (patch rows plus element hemi-cubes, as `radiosity report`
 *     counts them) grow by at most 5 % over the room without them;
 *   - each cube's face towards the light has its own B (its elements):
 *     B / ρ = I cos θ / d² + the indirect irradiance, the latter compared
 *     with the wall's behind it; a shadowed cube's B is far below a lit
 *     one's; the two materials' B differ by their ρ ratio;
 *   - the room absorbs what the light emits (4π I).
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <math.h>

enum { COLS = 40, ROWS = 25, PARTS = COLS * ROWS };

#define SIZE 0.5       /* patch size */
#define SIDE 0.02      /* a cube's edge */
#define PITCH 0.035    /* cube to cube */
#define X0 0.2         /* the cubes' back faces */
#define Y0 1.02        /* first cube's low corner */
#define Z0 1.02
#define RHO_A 0.6
#define RHO_B 0.3
#define INTENSITY 10.0

static const rad_vec3 LIGHT = {2.0, 2.0, 1.45};

static uint32_t object(rad_scene *s, const char *name)
{
    uint32_t o = RAD_NONE;
    rad_error e;
    CHECK(rad_scene_add_object(s, name, NULL, &o, &e) == RAD_OK);
    return o;
}

/* The six faces of the box [lo, hi], facing out (inward: facing in). */
static void box(rad_scene *s, uint32_t o, uint32_t mat, rad_vec3 lo, rad_vec3 hi, int inward)
{
    double c[2][3] = {{lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z}};
    rad_error e;
    for (int axis = 0; axis < 3; axis++)
        for (int side = 0; side < 2; side++) {
            int a = (axis + 1) % 3, b = (axis + 2) % 3;
            const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
            rad_vec3 p[4];
            for (int k = 0; k < 4; k++) {
                /* (a, b, axis) is right-handed: this order faces +axis */
                int kk = (side != inward) ? k : (4 - k) % 4;
                double q[3];
                q[axis] = c[side][axis];
                q[a] = c[uv[kk][0]][a];
                q[b] = c[uv[kk][1]][b];
                p[k] = rad_v3(q[0], q[1], q[2]);
            }
            int rc = rad_scene_add_polygon(s, "face", o, mat, p, 4, 0, 0, NULL, NULL, &e);
            CHECK_MSG(rc == RAD_OK, "%s", e.message);
        }
}

/* Cube (col, row)'s low corner. */
static rad_vec3 cube_lo(int col, int row)
{
    return rad_v3(X0, Y0 + col * PITCH, Z0 + row * PITCH);
}

static rad_scene *room(int with_parts)
{
    rad_scene *s = rad_scene_create(1, "parts-test");
    CHECK(s != NULL);
    uint32_t grey = test_material(s, "grey", 0.5), black = test_material(s, "black", 0.0);
    box(s, object(s, "room"), grey, rad_v3(0, 0, 0), rad_v3(4, 4, 3), 1);
    box(s, object(s, "board"), black, rad_v3(1.0, 1.0, 1.2), rad_v3(1.05, 1.75, 1.7), 0);
    if (with_parts) {
        uint32_t ma = test_material(s, "A", RHO_A), mb = test_material(s, "B", RHO_B);
        uint32_t oa = object(s, "partsA"), ob = object(s, "partsB");
        for (int col = 0; col < COLS; col++)
            for (int row = 0; row < ROWS; row++) {
                rad_vec3 lo = cube_lo(col, row);
                box(s, col < COLS / 2 ? oa : ob, col < COLS / 2 ? ma : mb, lo,
                    rad_add(lo, rad_v3(SIDE, SIDE, SIDE)), 0);
            }
    }
    rad_error e = {0};
    double I = INTENSITY;
    int rc = rad_scene_add_light(s, "bulb", RAD_LIGHT_POINT, &I, LIGHT, rad_v3(0, 0, -1), 0, 0,
                                 NULL, NULL, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    return s;
}

static rad_solution *solve(rad_scene *s)
{
    rad_solve_options opt = {0};
    opt.mesh.patch_size = SIZE;
    rad_solution *sol = NULL;
    rad_error e = {0};
    int rc = rad_solve_scene(s, &opt, &sol, &e);
    CHECK_MSG(rc == RAD_OK, "%s", e.message);
    return rc ? NULL : sol;
}

static uint64_t rows(const rad_solution *s)
{
    return s->rows_computed + (s->elements ? s->elements->rows_computed : 0);
}

static rad_solution *with, *without;

/* Measured 800 rows without the parts, 791 with (-1.1 %: the elements
 * refine a little differently; 18 shared patches for 6,000 faces: 3 grid
 * cubes of a material × 6 sides); bound 5 %, the issue's. */
TEST(parts_add_few_rows)
{
    CHECK(with && without);
    if (!with || !without)
        return;
    uint32_t shared = 0;
    const rad_scene *sc = with->scene;
    for (uint32_t i = 0; i < with->mesh->patch_count; i++)
        shared += !strncmp(sc->objects[with->mesh->patches[i].object].name, "parts", 5);
    printf("  rows %llu without the parts, %llu with (%+.2f %%); %u patches hold the %u parts\n",
           (unsigned long long)rows(without), (unsigned long long)rows(with),
           100.0 * ((double)rows(with) / (double)rows(without) - 1.0), shared, PARTS);
    CHECK(rows(with) <= 1.05 * (double)rows(without));
    CHECK(shared >= 1 && shared <= 18); /* 3 grid cubes of a material × 6 sides */
}

/* Per cube: area-weighted B of its face towards the light (+x), from the
 * elements. */
static void face_B(const rad_solution *s, double *B, double *A, uint32_t *patch_of)
{
    const rad_elements *el = s->elements;
    for (int k = 0; k < PARTS; k++)
        B[k] = A[k] = 0.0;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        const rad_patch *p = &el->mesh->patches[e];
        const char *name = s->scene->objects[s->mesh->patches[el->patch[e]].object].name;
        if (strncmp(name, "parts", 5) || !(p->normal.x > 0.99))
            continue;
        int col = (int)floor((p->center.y - Y0) / PITCH), row = (int)floor((p->center.z - Z0) / PITCH);
        CHECK(col >= 0 && col < COLS && row >= 0 && row < ROWS);
        if (col < 0 || col >= COLS || row < 0 || row >= ROWS)
            continue;
        B[col * ROWS + row] += p->area * el->B[e];
        A[col * ROWS + row] += p->area;
        patch_of[col * ROWS + row] = el->patch[e];
    }
    for (int k = 0; k < PARTS; k++)
        B[k] = A[k] > 0.0 ? B[k] / A[k] : -1.0;
}

/* The wall's indirect irradiance (patches: H - H_d) at the patch of the
 * wall x = 0 nearest (0, y, z). */
static double wall_indirect(const rad_solution *s, const double *H, const double *Hd, double y,
                            double z)
{
    double best = INFINITY, h = 0.0;
    for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        if (strcmp(s->scene->objects[p->object].name, "room") || !(p->normal.x > 0.99))
            continue;
        double d = hypot(p->center.y - y, p->center.z - z);
        if (d < best) {
            best = d;
            h = H[i] - Hd[i];
        }
    }
    return h;
}

/* A lit cube's +x face (its elements' area mean): B / ρ less its shared
 * patch's reflected irradiance is its own direct light, against I cos θ /
 * d² at its centre: measured 0.0032 %, bound 0.05 % (before the light views
 * judged a curved or shared patch's pixels by its own depth instead of its
 * mean plane, up to -8 %).  B / ρ - I cos θ / d² is its indirect
 * irradiance; the room's wall where the cube stands, solved without the
 * parts, sees nearly the same room: measured worst 8.8 % (the A cubes'
 * shared patch takes its row at one cube, in the board's shadow, -8.5 %;
 * mesh/parts.c), bound 20 %.  A shadowed face's B / ρ is its indirect
 * alone: 4.8 % off the wall's, bound 15 %; its B at most 0.342 × the lit
 * A cube's of its row, bound 0.5.  The materials: the lit A and B faces
 * either side of the middle, (B_A / ρ_A) / (B_B / ρ_B) against the ratio
 * of their irradiances computed as above: measured 2.8 % (the two shared
 * patches' rows differ), bound 6 %. */
TEST(each_part_has_its_own_B)
{
    if (!with)
        return;
    if (!without)
        return;
    const uint32_t n = without->mesh->patch_count, n2 = with->mesh->patch_count;
    double *B = malloc(PARTS * sizeof *B), *A = malloc(PARTS * sizeof *A);
    uint32_t *patch_of = calloc(PARTS, sizeof *patch_of);
    double *H = malloc(((size_t)n + 1) * sizeof *H), *Hd = malloc(((size_t)n + 1) * sizeof *Hd);
    double *H2 = malloc(((size_t)n2 + 1) * sizeof *H2), *Hd2 = malloc(((size_t)n2 + 1) * sizeof *Hd2);
    CHECK(B && A && patch_of && H && Hd && H2 && Hd2);
    if (!B || !A || !patch_of || !H || !Hd || !H2 || !Hd2)
        goto done;
    CHECK(rad_solution_irradiance(without, H, NULL) == RAD_OK);
    CHECK(rad_solution_direct_irradiance(without, Hd, NULL) == RAD_OK);
    CHECK(rad_solution_irradiance(with, H2, NULL) == RAD_OK);
    CHECK(rad_solution_direct_irradiance(with, Hd2, NULL) == RAD_OK);
    face_B(with, B, A, patch_of);
    double worst_lit = 0.0, worst_dark = 0.0, dark_ratio = 0.0, worst_mat = 0.0, worst_direct = 0.0;
    int lit = 0, dark = 0;
    for (int col = 0; col < COLS; col++)
        for (int row = 0; row < ROWS; row++) {
            const int k = col * ROWS + row;
            CHECK(B[k] >= 0.0);
            const rad_vec3 c = rad_add(cube_lo(col, row), rad_v3(SIDE, 0.5 * SIDE, 0.5 * SIDE));
            const double rho = col < COLS / 2 ? RHO_A : RHO_B;
            const rad_vec3 r = rad_sub(LIGHT, c);
            const double d = rad_length(r), direct = INTENSITY * (r.x / d) / (d * d);
            const double wall = wall_indirect(without, H, Hd, c.y, c.z);
            const double y_hi = c.y + 0.5 * SIDE, y_lo = c.y - 0.5 * SIDE;
            if (y_lo > 1.58) { /* clear of the board's shadow (edge at y ≈ 1.53-1.56) */
                lit++;
                worst_lit = fmax(worst_lit, fabs((B[k] / rho - direct) / wall - 1.0));
                const uint32_t p = patch_of[k]; /* its shared patch's reflected share */
                worst_direct = fmax(worst_direct,
                                    fabs((B[k] / rho - (H2[p] - Hd2[p])) / direct - 1.0));
            } else if (y_hi < 1.5) {
                dark++;
                worst_dark = fmax(worst_dark, fabs(B[k] / rho / wall - 1.0));
                /* the lit A cube of this row nearest the shadow's edge */
                dark_ratio = fmax(dark_ratio, B[k] / B[17 * ROWS + row]);
            }
            if (col == COLS / 2 - 1) { /* A beside B */
                const int kb = k + ROWS;
                const rad_vec3 cb = rad_add(c, rad_v3(0, PITCH, 0));
                const rad_vec3 rb = rad_sub(LIGHT, cb);
                const double db = rad_length(rb), directb = INTENSITY * (rb.x / db) / (db * db);
                const double want = (direct + wall) / (directb + wall_indirect(without, H, Hd, cb.y, cb.z));
                worst_mat = fmax(worst_mat, fabs((B[k] / RHO_A) / (B[kb] / RHO_B) / want - 1.0));
            }
        }
    printf("  %d lit faces: direct share worst %.4f %% off I cos / d², indirect worst %.2f %% "
           "off the wall's; %d shadowed: %.2f %%, B at most %.3f × a lit one's; materials: "
           "worst %.3f %%\n",
           lit, 100.0 * worst_direct, 100.0 * worst_lit, dark, 100.0 * worst_dark, dark_ratio,
           100.0 * worst_mat);
    CHECK(lit > 500 && dark > 250);
    CHECK(worst_direct <= 5e-4);
    CHECK(worst_lit <= 0.2);
    CHECK(worst_dark <= 0.15);
    CHECK(dark_ratio <= 0.5);
    CHECK(worst_mat <= 0.06);
done:
    free(B);
    free(A);
    free(patch_of);
    free(H);
    free(Hd);
    free(H2);
    free(Hd2);
}

/* The room is closed: its surfaces absorb what the light emits, 4π I.
 * Measured -0.066 % with the parts; bound 0.1 %, the issue's.  (The room
 * without them, printed only: +0.112 %, the hemi-cube's own error on this
 * room with its floating black board, not the parts'.) */
TEST(energy_balances)
{
    const rad_solution *sols[2] = {without, with};
    for (int k = 0; k < 2; k++) {
        const rad_solution *s = sols[k];
        if (!s)
            continue;
        rad_object_stats st[8];
        CHECK(s->scene->object_count <= 8);
        CHECK(rad_solution_object_stats(s, st, NULL) == RAD_OK);
        double absorbed = 0.0, emitted = 4.0 * M_PI * INTENSITY;
        for (uint32_t o = 0; o < s->scene->object_count; o++)
            absorbed += st[o].absorbed[0];
        printf("  %s the parts: absorbed %.6f, emitted %.6f: %+.4f %%\n", k ? "with" : "without",
               absorbed, emitted, 100.0 * (absorbed / emitted - 1.0));
        if (k) /* the room alone is the reference of the rows, not of this */
            CHECK_REL(absorbed, emitted, 1e-3);
    }
}

int main(void)
{
    rad_scene *a = room(0), *b = room(1); /* the solves take them */
    without = a ? solve(a) : NULL;
    with = b ? solve(b) : NULL;
    RUN(parts_add_few_rows);
    RUN(each_part_has_its_own_B);
    RUN(energy_balances);
    rad_solution_destroy(with);
    rad_solution_destroy(without);
    return test_finish("test_parts");
}
