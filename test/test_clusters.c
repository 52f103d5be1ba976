/* test_clusters.c - small polygons grouped into patches (mesh/cluster.c):
 * the patch size sets the patch count, and a grid cell's pieces of one look
 * are joined into few cells (mesh/region.c); clustered rows keep their sums
 * and reciprocity in a closed box of small triangles against the catalog's
 * factors, the cells survive the solution file, and elements refine them.
 * The tests that need patches of many cells use two-tone tilings, whose
 * pieces region.c never joins.
 * Cost: about 8 s (release) and 25 s (ASan) on the 2-core machine under a
 * load of 12-16. */
#include "../hemicube/hc_internal.h"
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <unistd.h>

static rad_vec3 grid_point(rad_vec3 o, rad_vec3 U, rad_vec3 V, uint32_t n, uint32_t i, uint32_t j)
{
    return rad_add(o, rad_add(rad_scale(U, (double)i / n), rad_scale(V, (double)j / n)));
}

/* Adds the parallelogram o + s·U + t·V as an n × n grid of right
 * triangles facing U × V, to `object` with `material`.  tone > 0 makes it
 * a two-tone tiling: the second triangle of each grid square gets a ρ of
 * its own, the material's × (1 + tone) (as glTF vertex colours would give
 * it).  Region.c joins the pieces of a grid cell into one cell only when
 * they all look alike (same_look: the same own ρ), so then every grid cell
 * keeps its pieces, and each patch is a cluster of many cells. */
static int add_tessellated(rad_scene *s, uint32_t object, uint32_t material, rad_vec3 o,
                           rad_vec3 U, rad_vec3 V, uint32_t n, double tone)
{
    const double rho2 = s->materials[material].rho[0] * (1.0 + tone);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            /* each grid point computed one way, so neighbours share it exactly */
            rad_vec3 p00 = grid_point(o, U, V, n, i, j), p10 = grid_point(o, U, V, n, i + 1, j);
            rad_vec3 p01 = grid_point(o, U, V, n, i, j + 1), p11 = grid_point(o, U, V, n, i + 1, j + 1);
            /* alternate diagonals: no two triangles form a parallelogram
             * the way a quad would be cut, as in an export */
            rad_vec3 t1[3] = {p00, p10, p11}, t2[3] = {p00, p11, p01};
            rad_vec3 t3[3] = {p00, p10, p01}, t4[3] = {p10, p11, p01};
            const int alt = (i + j) % 2;
            uint32_t second;
            if (rad_scene_add_polygon(s, "t", object, material, alt ? t1 : t3, 3, 0, 0, NULL, NULL,
                                      NULL) ||
                rad_scene_add_polygon(s, "t", object, material, alt ? t2 : t4, 3, 0, 0, NULL,
                                      &second, NULL) ||
                (tone > 0.0 && rad_scene_set_polygon_rho(s, second, &rho2, NULL, NULL)))
                return -1;
        }
    return 0;
}

/* A unit square at z = 0 facing +z, 24 × 24 × 2 triangles. */
static rad_scene *plane(void)
{
    rad_scene *s = rad_scene_create(1, "plane");
    double rho = 0.5, e = 1.0;
    uint32_t m, o;
    if (!s || rad_scene_add_material(s, "m", &rho, &e, NULL, NULL, &m, NULL) ||
        rad_scene_add_object(s, "plane", NULL, &o, NULL) ||
        add_tessellated(s, o, m, rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(0, 1, 0), 24, 0.0)) {
        rad_scene_destroy(s);
        return NULL;
    }
    return s;
}

/* Cells of grid cell (ix, iy) of a g × g grid over the plane's square,
 * once region.c has joined its pieces (the plane has one ρ).  The union of
 * a grid cell's m × m × 2 triangles (m = 24·size) is its square; its loop
 * keeps the four grid corners and every triangle corner on the square's
 * outline (no grid cell across to drop it with), and drops those on the
 * inner grid lines (both sides drop them).  A grid cell with b sides on
 * the outline has a convex loop of L = 4 + b (m - 1) corners, in line
 * along each side: one quad when L = 4 (an inner grid cell), else a fan
 * of L - 2 triangles. */
static uint32_t joined_cells(uint32_t g, uint32_t m, uint32_t ix, uint32_t iy)
{
    const uint32_t b = (ix == 0) + (ix == g - 1) + (iy == 0) + (iy == g - 1);
    return b ? 4 + b * (m - 1) - 2 : 1;
}

TEST(patch_size_sets_the_count)
{
    rad_scene *s = plane();
    CHECK(s != NULL);
    if (!s)
        return;
    /* Triangles of 1/24: patches are the squares of a g × g grid, g =
     * 1/size, whatever the triangles; their pieces joined (joined_cells):
     * 96, 108 and 156 cells at g = 2, 4, 8, not 1152. */
    const double sizes[3] = {0.5, 0.25, 0.125};
    const uint32_t grid[3] = {2, 4, 8}, cells[3] = {96, 108, 156};
    for (int k = 0; k < 3; k++) {
        const uint32_t g = grid[k], want = g * g;
        rad_mesh_options opt = {.patch_size = sizes[k]};
        rad_mesh *m = NULL;
        rad_error err = {0};
        CHECK_MSG(rad_mesh_build(s, &opt, &m, &err) == RAD_OK, "%s", err.message);
        if (!m)
            continue;
        CHECK_MSG(m->patch_count == want, "size %g: %u patches", sizes[k], m->patch_count);
        CHECK(rad_mesh_count(s, &opt) == m->patch_count);
        CHECK_MSG(m->cell_first && m->cell_count == cells[k], "size %g: %u cells", sizes[k],
                  m->cell_count);
        CHECK(rad_mesh_check(m, s->polygon_count, s->object_count, s->material_count, &err) == RAD_OK);
        /* one surface: the 96 triangle corners of the square's edge (its
         * outline) and the (g - 1)² inner grid crossings; the other
         * triangle corners are gone with the joined pieces */
        uint32_t outline = 0;
        for (uint32_t v = 0; v < m->vertex_count; v++)
            outline += m->vertex_boundary[v];
        CHECK_MSG(m->vertex_count == 96 + (g - 1) * (g - 1) && outline == 96,
                  "size %g: %u vertices, %u on the outline", sizes[k], m->vertex_count, outline);
        for (uint32_t i = 0; m->cell_first && i < m->patch_count; i++) {
            const rad_patch *p = &m->patches[i];
            /* each a square of side `size`: exact sums of exact areas */
            if (fabs(p->area - sizes[k] * sizes[k]) > 1e-12) {
                CHECK_NEAR(p->area, sizes[k] * sizes[k], 1e-12);
                break;
            }
            CHECK_NEAR(p->normal.z, 1.0, 1e-15);
            CHECK_NEAR(p->center.z, 0.0, 1e-15);
            const uint32_t ix = (uint32_t)(p->center.x * g), iy = (uint32_t)(p->center.y * g);
            const uint32_t nc = m->cell_first[i + 1] - m->cell_first[i];
            CHECK_MSG(ix < g && iy < g && nc == joined_cells(g, 24 / g, ix, iy),
                      "size %g: patch %u at (%u, %u) has %u cells", sizes[k], i, ix, iy, nc);
            /* an inner grid cell is one quad */
            if (nc == 1)
                CHECK(rad_patch_corners(&m->cells[m->cell_first[i]]) == 4);
        }
        rad_mesh_destroy(m);
    }
    /* Without clusters, one patch per triangle whatever the size. */
    rad_mesh_options one = {.patch_size = 0.25, .no_clusters = 1};
    CHECK(rad_mesh_count(s, &one) == 1152);
    /* Triangles larger than the patch size: since issue 36 the coplanar
     * triangles are one planar region (mesh/region.c) meshed on a grid of
     * the patch size, ceil(1 / 0.03)² patches, no longer k² = 4 per
     * triangle (4,608). */
    rad_mesh_options fine = {.patch_size = 0.03};
    CHECK(rad_mesh_count(s, &fine) == 34 * 34);
    rad_scene_destroy(s);
}

/* A closed unit cube of small triangles facing in, one object per face,
 * the ceiling (y = 1) emitting; n × n × 2 triangles a face, of one ρ
 * (tone 0) or two-tone (add_tessellated). */
static rad_scene *box(uint32_t n, double tone)
{
    rad_scene *s = rad_scene_create(1, "box");
    double rho = 0.5, e0 = 0.0, e1 = 1.0, r1 = 0.3;
    uint32_t white, lamp;
    if (!s || rad_scene_add_material(s, "white", &rho, &e0, NULL, NULL, &white, NULL) ||
        rad_scene_add_material(s, "lamp", &r1, &e1, NULL, NULL, &lamp, NULL)) {
        rad_scene_destroy(s);
        return NULL;
    }
    /* origin, U, V with U × V pointing into the cube */
    static const double f[6][9] = {
        {0, 0, 0, 0, 0, 1, 1, 0, 0}, /* floor, +y */
        {0, 1, 0, 1, 0, 0, 0, 0, 1}, /* ceiling, -y */
        {0, 0, 0, 1, 0, 0, 0, 1, 0}, /* z = 0, +z */
        {0, 0, 1, 0, 1, 0, 1, 0, 0}, /* z = 1, -z */
        {0, 0, 0, 0, 1, 0, 0, 0, 1}, /* x = 0, +x */
        {1, 0, 0, 0, 0, 1, 0, 1, 0}, /* x = 1, -x */
    };
    static const char *names[6] = {"floor", "ceiling", "south", "north", "west", "east"};
    for (int k = 0; k < 6; k++) {
        uint32_t o;
        if (rad_scene_add_object(s, names[k], NULL, &o, NULL) ||
            add_tessellated(s, o, k == 1 ? lamp : white, rad_v3(f[k][0], f[k][1], f[k][2]),
                            rad_v3(f[k][3], f[k][4], f[k][5]), rad_v3(f[k][6], f[k][7], f[k][8]),
                            n, tone)) {
            rad_scene_destroy(s);
            return NULL;
        }
    }
    return s;
}

/* The two-tone tilings' second ρ, 1 % above the first: enough that no
 * grid cell's pieces are joined, little enough to leave B about the same. */
#define TONE 0.01

static rad_solution *solve_box(uint32_t n, double size, int no_clusters)
{
    rad_scene *s = box(n, TONE);
    if (!s)
        return NULL;
    rad_solve_options opt = {0};
    opt.mesh.patch_size = size;
    opt.mesh.no_clusters = no_clusters;
    opt.all_rows = 1;
    opt.refine_threshold = RAD_REFINE_OFF; /* the patches' factors and B */
    rad_solution *sol = NULL;
    rad_error err = {0};
    if (rad_solve_scene(s, &opt, &sol, &err)) {
        fprintf(stderr, "  solve: %s\n", err.message);
        return NULL;
    }
    return sol;
}

/* s written to a temporary file and read back (NULL on failure). */
static rad_solution *round_trip(const rad_solution *s)
{
    char path[] = "/tmp/test_clusters.XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd < 0)
        return NULL;
    close(fd);
    rad_solution *r = NULL;
    rad_error err = {0};
    CHECK_MSG(rad_solution_write(s, path, &err) == RAD_OK, "%s", err.message);
    CHECK_MSG(rad_solution_read(path, &r, &err) == RAD_OK, "%s", err.message);
    unlink(path);
    return r;
}

/* The box of one ρ a face meshed at `size`: its patch and cell counts. */
static void box_counts(uint32_t n, double size, uint32_t *patches, uint32_t *cells)
{
    rad_scene *sc = box(n, 0.0);
    rad_mesh_options mo = {.patch_size = size};
    rad_mesh *m = NULL;
    rad_error err = {0};
    *patches = *cells = 0;
    CHECK_MSG(sc && rad_mesh_build(sc, &mo, &m, &err) == RAD_OK, "%s", err.message);
    if (m) {
        CHECK(m->cell_first &&
              rad_mesh_check(m, sc->polygon_count, sc->object_count, sc->material_count, &err) ==
                  RAD_OK);
        *patches = m->patch_count;
        *cells = m->cell_count;
    }
    rad_mesh_destroy(m);
    rad_scene_destroy(sc);
}

TEST(closed_box_of_triangles)
{
    /* 8 × 8 × 2 triangles a face at size 0.25: a 4 × 4 grid a face, N =
     * 96 patches.  Of one ρ, each grid cell's 2 × 2 × 2 triangles are
     * joined (joined_cells with m = 2: 4 corner grid cells of 4 cells, 8
     * edge ones of 3, 4 inner quads: 44 a face, 264).  Two-tone, nothing
     * is joined: 768 cells, 8 a patch, so the rows below are clusters'. */
    uint32_t np = 0, nc = 0, face = 0;
    for (uint32_t iy = 0; iy < 4; iy++)
        for (uint32_t ix = 0; ix < 4; ix++)
            face += joined_cells(4, 2, ix, iy);
    box_counts(8, 0.25, &np, &nc);
    CHECK_MSG(face == 44 && np == 96 && nc == 6 * face, "one ρ: %u patches, %u cells", np, nc);
    rad_solution *s = solve_box(8, 0.25, 0);
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->mesh->patch_count == 96 && s->mesh->cell_count == 768);
    /* A closed room covers every pixel of every hemi-cube: Σ_j F_ij = 1
     * (the delta form factors are normalised; the lamp's exact entries
     * keep the cube's total).  Measured: |Σ - 1| <= 1.8e-8 (float rows). */
    double worst = 0.0;
    for (uint32_t i = 0; i < s->F->n; i++)
        worst = fmax(worst, fabs(rad_matrix_row_sum(s->F, i) - 1.0));
    CHECK_NEAR(worst, 0.0, 1e-7);
    /* Face to face against the catalog (Howell C-11, C-14), and
     * reciprocity between faces of equal area: F_AB = F_BA. */
    double M[36];
    rad_error err = {0};
    CHECK(rad_object_form_factors(s, M, &err) == RAD_OK);
    const double opposite = hc_ff_parallel_rectangles(1, 1, 1),
                 adjacent = hc_ff_perpendicular_rectangles(1, 1, 1);
    double e_opp = 0.0, e_adj = 0.0, e_rec = 0.0, e_lamp = 0.0;
    for (int a = 0; a < 6; a++)
        for (int b = 0; b < 6; b++) {
            if (a == b)
                continue;
            double want = a / 2 == b / 2 ? opposite : adjacent;
            double e = fabs(M[a * 6 + b] - want) / want;
            if (a / 2 == b / 2)
                e_opp = fmax(e_opp, e);
            else
                e_adj = fmax(e_adj, e);
            if (a != 1 && b != 1)
                e_rec = fmax(e_rec, fabs(M[a * 6 + b] - M[b * 6 + a]) / want);
            else
                e_lamp = fmax(e_lamp, fabs(M[a * 6 + b] - M[b * 6 + a]) / want);
        }
    /* Measured at R = 128 (two-tone box): opposite 0.26 %, adjacent
     * 0.26 %, reciprocity 0.32 % (hemi-cubes at the 16 cluster centres of
     * a face: the midpoint rule of the area average).  The emitting
     * ceiling's column is an exact area average (issue 18: what the energy
     * balance rests on), so its pairs are as far from reciprocal as the
     * other side's midpoint rule is from the truth: 0.25 %. */
    CHECK_NEAR(e_opp, 0.0, 0.008);
    CHECK_NEAR(e_adj, 0.0, 0.008);
    CHECK_NEAR(e_rec, 0.0, 0.005);
    CHECK_NEAR(e_lamp, 0.0, 0.008);
    /* Energy: what the lamp emits is absorbed (closed room). */
    rad_object_stats st[6];
    CHECK(rad_solution_object_stats(s, st, &err) == RAD_OK);
    double emitted = 0.0, absorbed = 0.0;
    for (int k = 0; k < 6; k++) {
        emitted += st[k].emitted[0];
        absorbed += st[k].absorbed[0];
    }
    /* Measured: 2.4e-4 relative (1.4e-4 for the joined box of one ρ).
     * Not the solver's stopping point (2.8e-4 with a tolerance of 1e-7
     * instead of 1e-4): the lamp's exact column and its hemi-cube row are
     * 0.25 % apart (e_lamp), so A_i F_ij = A_j F_ji holds only that well. */
    CHECK_REL(absorbed, emitted, 6e-4);

    /* The same box one patch per triangle at the same resolution: the
     * clusters' face factors agree with it (measured 0.26 % of F). */
    rad_solution *t = solve_box(8, 0.25, 1);
    CHECK(t && t->mesh->patch_count == 768 && !t->mesh->cell_first);
    double N[36], diff = 0.0;
    if (t && rad_object_form_factors(t, N, &err) == RAD_OK)
        for (int k = 0; k < 36; k++)
            if (k % 7)
                diff = fmax(diff, fabs(M[k] - N[k]) / adjacent);
    CHECK_NEAR(diff, 0.0, 0.008);
    rad_solution_destroy(t);

    /* The solution file keeps the cells, and draws the same image. */
    rad_solution *r = round_trip(s);
    if (r) {
        CHECK(r->mesh->cell_first && r->mesh->cell_count == s->mesh->cell_count);
        int same = r->mesh->cell_first != NULL;
        for (uint32_t c = 0; same && c < s->mesh->cell_count; c++)
            same = rad_patch_same(&r->mesh->cells[c], &s->mesh->cells[c]);
        for (uint32_t i = 0; same && i <= s->mesh->patch_count; i++)
            same = r->mesh->cell_first[i] == s->mesh->cell_first[i];
        CHECK(same);
        rn_camera cam = {.eye = {0.5, 0.5, 0.05}, .target = {0.5, 0.4, 1}, .up = {0, 1, 0},
                         .yfov_deg = 80, .width = 48, .height = 48};
        rn_image *a = NULL, *b = NULL;
        CHECK(rad_render_solution(s, &cam, &a, &err) == RAD_OK);
        CHECK(rad_render_solution(r, &cam, &b, &err) == RAD_OK);
        if (a && b) {
            CHECK(memcmp(a->pixels, b->pixels, (size_t)48 * 48 * sizeof *a->pixels) == 0);
            /* the image names patches (not cells), every pixel one of them */
            int named = 1;
            for (size_t q = 0; q < (size_t)48 * 48; q++)
                named &= a->patch[q] < s->mesh->patch_count;
            CHECK(named);
        }
        rn_image_destroy(a);
        rn_image_destroy(b);
    }
    rad_solution_destroy(r);
    rad_solution_destroy(s);
}

TEST(elements_in_clusters)
{
    /* 3 × 3 × 2 triangles a face, two-tone (so no grid cell's pieces are
     * joined), 4 patches a face at size 0.5: 24 patches; one uniform split
     * makes 4 elements a cell, each with a row. */
    rad_solution *s = solve_box(3, 0.5, 0);
    CHECK(s != NULL);
    if (!s)
        return;
    rad_solve_options opt = {.element_levels = 1};
    rad_error err = {0};
    CHECK_MSG(rad_refine_solution(s, &opt, &err) == RAD_OK, "%s", err.message);
    const rad_elements *el = s->elements;
    CHECK(el != NULL);
    if (!el) {
        rad_solution_destroy(s);
        return;
    }
    /* the lamp does not reflect much, but reflects: every cell splits */
    /* Each face is a planar region: its 18 triangles are cut at the grid
     * lines x, y = 1.5 (in triangle steps).  The 4 corner squares' 8
     * triangles stay whole; the 4 squares one line crosses give 2 pieces a
     * triangle, 16; the centre square, both lines through its diagonal's
     * middle, gives 6 pieces, one (the quarter at the grid crossing) cut
     * as a fan of 2 triangles, so 7: 31 cells a face, 186. */
    CHECK_MSG(s->mesh->patch_count == 24 && s->mesh->cell_count == 6 * 31 &&
                  el->mesh->patch_count == 4 * s->mesh->cell_count,
              "%u patches, %u cells, %u elements", s->mesh->patch_count, s->mesh->cell_count,
              el->mesh->patch_count);
    /* The elements of a cluster cover it: their areas sum to its area
     * (measured 5.6e-16), and their area-weighted mean B is its B
     * (measured 0.20 % at most: the elements gather at their own centres,
     * the patch at one point). */
    const uint32_t np = s->mesh->patch_count;
    double *a = calloc(np, sizeof *a), *b = calloc(np, sizeof *b), worst_a = 0, worst_b = 0;
    for (uint32_t e = 0; a && b && e < el->mesh->patch_count; e++) {
        a[el->patch[e]] += el->mesh->patches[e].area;
        b[el->patch[e]] += el->mesh->patches[e].area * el->B[e];
    }
    for (uint32_t i = 0; a && b && i < np; i++) {
        worst_a = fmax(worst_a, fabs(a[i] - s->mesh->patches[i].area) / s->mesh->patches[i].area);
        double reflected = s->B[i] - s->emission[i];
        if (reflected > 0.0)
            worst_b = fmax(worst_b, fabs(b[i] / a[i] - s->emission[i] - reflected) / s->B[i]);
    }
    CHECK_NEAR(worst_a, 0.0, 1e-12);
    CHECK_NEAR(worst_b, 0.0, 0.006);
    free(a);
    free(b);
    /* Elements of a cluster lie in its cells: polygon and normal the cell's. */
    CHECK(rad_element_store_check(el, s, "elements", &err) == RAD_OK);
    /* and they survive the file */
    rad_solution *r = round_trip(s);
    CHECK(r && r->elements && r->elements->mesh->patch_count == el->mesh->patch_count);
    int same = r && r->elements;
    for (uint32_t e = 0; same && e < el->mesh->patch_count; e++)
        same = rad_patch_same(&r->elements->mesh->patches[e], &el->mesh->patches[e]);
    CHECK(same);
    rad_solution_destroy(r);
    rad_solution_destroy(s);
}

/* Progressive refinement on clusters (issue 20): the same face means as
 * Gauss-Seidel, and an emitting cluster's exact column (what its first
 * shot uses, hc_exact_column summing the point-to-polygon factor over its
 * cells) equal to the exact entries its receivers' rows hold for it
 * (nothing stands in between in an empty box).  6 × 6 × 2 triangles a
 * face, two-tone (nothing joined), at size 0.5: 24 patches of 432 cells,
 * each a 3 × 3 square's 18 triangles.  Measured: faces within 7.0e-5 of
 * max B, the column equal to the rows' entries (0).  Cost: about 0.5 s
 * (release), 2 s (ASan). */
TEST(progressive_on_clusters)
{
    rad_solution *sol[2] = {NULL, NULL};
    rad_error err = {0};
    for (int k = 0; k < 2; k++) {
        rad_scene *sc = box(6, TONE);
        rad_solve_options opt = {0};
        opt.mesh.patch_size = 0.5;
        opt.hemicube.processes = 1;
        opt.solver.method = k ? SV_PROGRESSIVE : SV_GAUSS_SEIDEL;
        CHECK_MSG(sc && rad_solve_scene(sc, &opt, &sol[k], &err) == RAD_OK, "%s", err.message);
    }
    rad_solution *g = sol[0], *p = sol[1];
    if (!g || !p) {
        rad_solution_destroy(g);
        rad_solution_destroy(p);
        return;
    }
    CHECK(p->mesh->patch_count == 24 && p->mesh->cell_count == 432 && p->progress &&
          p->progress->converged);
    /* Face means within 3 × the tolerance (1e-4) of the brightest
     * reflecting patch (the lamp reflects too: max B over all). */
    rad_object_stats a[6], b[6];
    double maxB = 0.0, diff = 0.0;
    for (uint32_t i = 0; i < g->mesh->patch_count; i++)
        maxB = fmax(maxB, g->B[i]);
    CHECK(rad_solution_object_stats(g, a, &err) == RAD_OK &&
          rad_solution_object_stats(p, b, &err) == RAD_OK);
    for (int o = 0; o < 6; o++)
        diff = fmax(diff, fabs(a[o].B[0] - b[o].B[0]) / maxB);
    printf("  progressive against Gauss-Seidel on 24 clusters: faces within %.2e of max B, "
           "%u shots\n", diff, p->progress->shots);
    CHECK_NEAR(diff, 0.0, 3e-4);

    /* The column of the first ceiling cluster against the rows' entries. */
    const uint32_t n = g->mesh->patch_count;
    uint8_t *exact = calloc(n + 1, 1);
    uint32_t *col = calloc(n, sizeof *col), lamp = RAD_NONE, count = 0;
    float *val = calloc(n, sizeof *val);
    for (uint32_t i = 0; exact && i < n; i++) {
        exact[i] = g->emission[i] > 0.0;
        lamp = exact[i] && lamp == RAD_NONE ? i : lamp;
    }
    hc_options ho = {.processes = 1, .exact = exact};
    hc_engine *e = NULL;
    CHECK(exact && col && val && lamp != RAD_NONE &&
          g->mesh->cell_first[lamp + 1] - g->mesh->cell_first[lamp] > 1 &&
          hc_create(g->mesh, &ho, &e, &err) == RAD_OK &&
          hc_exact_column(e, lamp, 0, 1, col, val, &count, &err) == RAD_OK);
    double worst = 0.0;
    uint32_t in_rows = 0;
    for (uint32_t j = 0; e && j < n; j++) {
        const rad_matrix *F = g->F;
        double fji = 0.0;
        const uint32_t *rc;
        const float *rv;
        uint32_t cnt = test_row(F, j, 0, &rc, &rv);
        for (uint32_t q = 0; q < cnt; q++)
            if (rc[q] == lamp)
                fji = rv[q];
        double fc = 0.0;
        for (uint32_t q = 0; q < count; q++)
            if (col[q] == j)
                fc = val[q];
        in_rows += fji > 0.0;
        if (fji > 0.0 || fc > 0.0)
            worst = fmax(worst, fabs(fc - fji) / fmax(fc, fji));
    }
    printf("  lamp cluster %u: %u receivers in its column, %u rows hold it, worst %.2e\n", lamp,
           count, in_rows, worst);
    CHECK(count > 0 && count == in_rows);
    CHECK_NEAR(worst, 0.0, 0.005);
    hc_destroy(e);
    free(exact);
    free(col);
    free(val);
    rad_solution_destroy(g);
    rad_solution_destroy(p);
}

/* Exact factors to a cluster sum its outline's edges (hemicube/pool.c's
 * e->oedge, rad_point_edges_factor) instead of every cell's, where nothing
 * is clipped: the inner edges cancel term for term.  Checked against the
 * cells one by one (hc_ff_point_polygon, hc_ff_polygon_polygon with the
 * subdivision hc_area_factor documents), for every pair of the box's 24
 * clusters of 18 triangles: the point factor from each centre and the area
 * factor, near and far; the box two-tone, so that its clusters stay 18
 * triangles each (one ρ, region.c would join them into a few cells).
 * Within 1e-9 relative (measured: 8.2e-16 point, 1.9e-15 area: rounding
 * of the summation order).  Cost: about 0.3 s. */
TEST(cluster_outline_factors)
{
    rad_scene *sc = box(6, TONE);
    rad_mesh *m = NULL;
    rad_error err = {0};
    rad_mesh_options mo = {.patch_size = 0.5};
    CHECK_MSG(sc && rad_mesh_build(sc, &mo, &m, &err) == RAD_OK, "%s", err.message);
    hc_options ho = {.processes = 1};
    hc_engine *e = NULL;
    CHECK_MSG(m && hc_create(m, &ho, &e, &err) == RAD_OK, "%s", err.message);
    if (!e) {
        rad_mesh_destroy(m);
        rad_scene_destroy(sc);
        return;
    }
    const uint32_t n = m->patch_count;
    uint32_t cell_edges = 0;
    for (uint32_t c = 0; c < m->cell_count; c++)
        cell_edges += (uint32_t)rad_patch_corners(&m->cells[c]);
    /* 18 triangles a cluster, 54 edges; its outline on a 3 × 3 grid of
     * squares is 12 edges */
    printf("  %u clusters, %u cell edges, %u outline edges\n", n, cell_edges, e->ofirst[n]);
    CHECK(n == 24 && e->ofirst[n] == 12 * n);
    double worst_pt = 0.0, worst_area = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        const rad_patch *pi = &m->patches[i], *ci, *cj;
        const uint32_t ki = rad_patch_cells(m, i, &ci);
        double ri = 0.0;
        for (uint32_t a = 0; a < ki; a++)
            for (int q = 0; q < rad_patch_corners(&ci[a]); q++)
                ri = fmax(ri, rad_length(rad_sub(m->vertices[ci[a].v[q]], pi->center)));
        for (uint32_t j = 0; j < n; j++) {
            const uint32_t kj = rad_patch_cells(m, j, &cj);
            if (m->patches[j].object == pi->object)
                continue;
            double pt = 0.0;
            for (uint32_t b = 0; b < kj; b++) {
                rad_vec3 q[4];
                for (int k = 0; k < rad_patch_corners(&cj[b]); k++)
                    q[k] = m->vertices[cj[b].v[k]];
                pt += hc_ff_point_polygon(pi->center, pi->normal, q, (uint32_t)rad_patch_corners(&cj[b]));
            }
            double got = hc_point_to_patch(e, rad_sub(pi->center, e->origin), pi->normal, j);
            worst_pt = fmax(worst_pt, fabs(got - pt) / pt);
            for (int near = 0; near < 2; near++) {
                double dist = rad_length(rad_sub(m->patches[j].center, pi->center));
                double sub = fmin(16.0, fmax(near ? 2.0 : 1.0, ceil(4.0 * ri / dist)));
                double area = 0.0;
                for (uint32_t a = 0; a < ki; a++) {
                    rad_vec3 p[4];
                    for (int k = 0; k < rad_patch_corners(&ci[a]); k++)
                        p[k] = m->vertices[ci[a].v[k]];
                    for (uint32_t b = 0; b < kj; b++) {
                        rad_vec3 q[4];
                        for (int k = 0; k < rad_patch_corners(&cj[b]); k++)
                            q[k] = m->vertices[cj[b].v[k]];
                        area += ci[a].area / pi->area *
                                hc_ff_polygon_polygon(p, (uint32_t)rad_patch_corners(&ci[a]), q,
                                                      (uint32_t)rad_patch_corners(&cj[b]),
                                                      (uint32_t)sub);
                    }
                }
                worst_area = fmax(worst_area, fabs(hc_area_factor(e, i, j, near) - area) / area);
            }
        }
    }
    printf("  against the cells one by one: point factors within %.2e, area factors %.2e\n",
           worst_pt, worst_area);
    CHECK(worst_pt <= 1e-9);
    CHECK(worst_area <= 1e-9);
    hc_destroy(e);
    rad_mesh_destroy(m);
    rad_scene_destroy(sc);
}

int main(void)
{
    RUN(patch_size_sets_the_count);
    RUN(closed_box_of_triangles);
    RUN(cluster_outline_factors);
    RUN(elements_in_clusters);
    RUN(progressive_on_clusters);
    return test_finish("test_clusters");
}
