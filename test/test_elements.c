/* test_elements.c - elements (substructuring, issue 6): patches shoot,
 * elements receive.
 *   - an element's gathered B against the catalog's element-to-rectangle
 *     factor (Howell B-3, four corner rectangles), independently of the
 *     hemi-cube;
 *   - adaptive refinement happens at the shadow's penumbra, which geometry
 *     gives, and only there;
 *   - a refined plane lit uniformly renders without cracks (no pixel off
 *     the uniform value by more than 1e-4 relative, none missing);
 *   - on that refined plane a linear field is drawn exactly, T-vertices
 *     included (the vertex fits);
 *   - elements buried under a box resting on the floor do not darken the
 *     visible floor beside it;
 *   - a relight gathers the elements again without a hemi-cube;
 *   - at the defaults, a block's shadow under a small lamp is drawn within
 *     0.5 % of the exact visible part of the lamp (issue 18).
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"
#include "util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A floor [f0,f1]² in z = 0 (normal +z) split n×n, a square lamp of side
 * 2·lh centred over (0.5, 0.5) at height 1 facing down (E = 1), and, if
 * occ > 0, a black square occluder of half side occ at height 0.5 facing
 * down, centred likewise. */
static rad_solution *floor_scene(double f0, double f1, unsigned n, double lh, double occ,
                                 const rad_solve_options *opt)
{
    const double lamp_x = 0.5;
    char text[2048];
    double a = lamp_x - lh, b = lamp_x + lh, c = 0.5 - lh, d = 0.5 + lh;
    int used = snprintf(text, sizeof text,
                        "bands 1\n"
                        "material white reflectance 0.5\n"
                        "material lamp reflectance 0 emission 1\n"
                        "material black reflectance 0\n"
                        "polygon floor white subdivide %u %u\n %g %g 0\n %g %g 0\n %g %g 0\n %g %g 0\nend\n"
                        "polygon lamp lamp subdivide 1 1\n %.17g %.17g 1\n %.17g %.17g 1\n"
                        " %.17g %.17g 1\n %.17g %.17g 1\nend\n",
                        n, n, f0, f0, f1, f0, f1, f1, f0, f1, a, c, a, d, b, d, b, c);
    if (occ > 0)
        snprintf(text + used, sizeof text - (size_t)used,
                 "polygon occluder black subdivide 1 1\n %g %g 0.5\n %g %g 0.5\n %g %g 0.5\n"
                 " %g %g 0.5\nend\n",
                 0.5 - occ, 0.5 - occ, 0.5 - occ, 0.5 + occ, 0.5 + occ, 0.5 + occ, 0.5 + occ,
                 0.5 - occ);
    return test_solve_text(text, "elements.rad", opt);
}

/* Howell B-3 for a rectangle [x0,x1]×[y0,y1] at height h over the point
 * (0,0), parallel to it: corner rectangles added with signs. */
static double corner(double x, double y, double h)
{
    if (x == 0.0 || y == 0.0)
        return 0.0;
    double s = (x > 0) == (y > 0) ? 1.0 : -1.0;
    return s * hc_ff_element_parallel_rectangle(fabs(x), fabs(y), h);
}

static double point_to_rectangle(double x0, double x1, double y0, double y1, double h)
{
    return corner(x1, y1, h) - corner(x0, y1, h) - corner(x1, y0, h) + corner(x0, y0, h);
}

static uint32_t object_named(const rad_solution *s, const char *name)
{
    for (uint32_t o = 0; o < s->scene->object_count; o++)
        if (!strcmp(s->scene->objects[o].name, name))
            return o;
    return RAD_NONE;
}

/* Uniform elements two splits deep under a lamp, nothing else in view: a
 * floor element sees only the lamp, so B_e = ρ E F_e,lamp with F from the
 * catalog.  Tolerance 1e-5 relative: the exact emitter factor is the
 * contour integral (float-stored), visibility 1 exactly. */
TEST(gather_matches_catalog)
{
    rad_solve_options opt = {0};
    opt.element_levels = 2;
    rad_solution *s = floor_scene(0, 1, 4, 0.1, 0, &opt);
    CHECK(s && s->elements);
    if (!s || !s->elements)
        return;
    const rad_elements *el = s->elements;
    uint32_t floor = object_named(s, "floor"), checked = 0;
    double worst = 0;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        const rad_patch *c = &el->mesh->patches[e];
        if (c->object != floor)
            continue;
        CHECK(el->level[e] == 2);
        double F = point_to_rectangle(0.4 - c->center.x, 0.6 - c->center.x, 0.4 - c->center.y,
                                      0.6 - c->center.y, 1.0);
        worst = fmax(worst, fabs(el->B[e] - 0.5 * F) / (0.5 * F));
        checked++;
    }
    printf("  %u floor elements (16 per patch): worst |B_e/(ρ E F_catalog) − 1| = %.2e\n", checked,
           worst);
    CHECK(checked == 16 * 16);
    CHECK(worst < 1e-5);
    /* Level-0 elements would be the patches themselves; level 2 has rows. */
    CHECK(el->rows_computed == 256);
    rad_solution_destroy(s);
}

/* The occluder's shadow on the floor, per axis: the union of its shadows
 * from every lamp point is the penumbra's outer box, their intersection the
 * umbra (separable, as lamp and occluder are squares parallel to the floor). */
typedef struct box1 {
    double outer0, outer1, inner0, inner1;
} box1;

static box1 shadow_axis(double l0, double l1, double a0, double a1, double hl, double ho)
{
    double k = hl / (hl - ho); /* floor point = l + (a − l)·k */
    box1 b;
    b.outer0 = fmin(l0 + (a0 - l0) * k, l1 + (a0 - l1) * k);
    b.outer1 = fmax(l0 + (a1 - l0) * k, l1 + (a1 - l1) * k);
    b.inner0 = fmax(l0 + (a0 - l0) * k, l1 + (a0 - l1) * k);
    b.inner1 = fmin(l0 + (a1 - l0) * k, l1 + (a1 - l1) * k);
    return b;
}

/* The refinement threshold of the shadow scene (see rad_solve_options):
 * low enough that the penumbra's elements reach the size floor (three
 * splits) under the quadratic vertex fits, which draw a smooth field well
 * enough that 0.003 stops at two. */
#define SHADOW_THRESHOLD 0.002

/* Distance from p to the penumbra (0 inside it). */
static double penumbra_distance(box1 x, box1 y, rad_vec3 p)
{
    double dx = fmax(x.outer0 - p.x, p.x - x.outer1), dy = fmax(y.outer0 - p.y, p.y - y.outer1);
    double out = fmax(dx, dy); /* > 0: outside the outer box (Chebyshev distance) */
    if (out > 0)
        return out;
    double in = fmin(fmin(p.x - x.inner0, x.inner1 - p.x), fmin(p.y - y.inner0, y.inner1 - p.y));
    return in > 0 ? in : 0.0; /* inside the umbra: distance to its edge */
}

static rad_solution *shadow_solution(void)
{
    rad_solve_options opt = {0};
    opt.refine_threshold = SHADOW_THRESHOLD;
    return floor_scene(-0.5, 1.5, 16, 0.05, 0.1, &opt);
}

/* Refinement goes where the light changes fast: at the penumbra (a band
 * 0.1 wide on a floor 2 wide, patches 1/8).  Every element split to the
 * deepest level lies within one patch width of the penumbra that geometry
 * gives, and elements farther than two patch widths from it are not split. */
TEST(refinement_follows_the_shadow)
{
    rad_solution *s = shadow_solution();
    CHECK(s && s->elements);
    if (!s || !s->elements)
        return;
    const rad_elements *el = s->elements;
    box1 bx = shadow_axis(0.45, 0.55, 0.4, 0.6, 1.0, 0.5), by = bx;
    uint32_t floor = object_named(s, "floor");
    uint32_t deepest = 0, count[RAD_MAX_ELEMENT_LEVEL + 1] = {0};
    for (uint32_t e = 0; e < el->mesh->patch_count; e++)
        if (el->mesh->patches[e].object == floor) {
            deepest = el->level[e] > deepest ? el->level[e] : deepest;
            count[el->level[e]]++;
        }
    double worst_deep = 0, worst_far_level = 0;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        if (el->mesh->patches[e].object != floor)
            continue;
        double d = penumbra_distance(bx, by, el->mesh->patches[e].center);
        if (el->level[e] == deepest)
            worst_deep = fmax(worst_deep, d);
        if (d > 2.0 / 8)
            worst_far_level = fmax(worst_far_level, el->level[e]);
    }
    printf("  floor elements by level:");
    for (uint32_t l = 0; l <= deepest; l++)
        printf(" %u", count[l]);
    printf("; deepest level %u, farthest deepest element %.3f from the penumbra; far from it at "
           "most level %.0f\n", deepest, worst_deep, worst_far_level);
    CHECK(deepest == 3); /* the default floor: 1/8 of the patch */
    CHECK(worst_deep <= 1.0 / 8);
    CHECK(worst_far_level == 0);
    rad_solution_destroy(s);
}

/* Cracks: the refined floor (T-vertices wherever a finer element meets a
 * coarser one) with every B set to 1, seen from straight above with the
 * lamp and occluder out of the way: every pixel inside the floor's image
 * (one pixel in from its outline) shows it, at L = 1/π within 1e-4. */
TEST(refined_plane_has_no_cracks)
{
    rad_solution *s = shadow_solution();
    CHECK(s && s->elements);
    if (!s || !s->elements)
        return;
    rad_elements *el = s->elements;
    rad_mesh *rm = NULL;
    uint32_t *of = NULL;
    rad_error err = {0};
    CHECK(rad_elements_render_mesh(el, &rm, &of, &err) == RAD_OK);
    /* T-vertices exist: some elements are drawn as fans. */
    CHECK(rm && rm->patch_count > el->mesh->patch_count);
    printf("  %u elements drawn as %u cells\n", el->mesh->patch_count, rm ? rm->patch_count : 0);
    rad_mesh_destroy(rm);
    free(of);
    for (size_t k = 0; k < (size_t)el->mesh->patch_count * s->band_count; k++)
        el->B[k] = 1.0;
    /* Move the lamp and the occluder out of the picture (below the floor,
     * facing away): only the floor is drawn. */
    uint32_t floor = object_named(s, "floor");
    for (uint32_t e = 0; e < el->mesh->patch_count; e++)
        if (el->mesh->patches[e].object != floor)
            for (int k = 0; k < rad_patch_corners(&el->mesh->patches[e]); k++)
                el->mesh->vertices[el->mesh->patches[e].v[k]].z = -5.0;
    rn_camera cam = {.eye = {0.5, 0.5, 6.0}, .target = {0.5, 0.5, 0.0}, .up = {0, 1, 0},
                     .yfov_deg = 30.0, .width = 256, .height = 256};
    rn_image *img = NULL;
    CHECK(rad_render_solution(s, &cam, &img, &err) == RAD_OK);
    if (!img) {
        rad_solution_destroy(s);
        return;
    }
    /* The floor spans ±1 around the axis at distance 6: half-width in
     * pixels = (1/6) / tan(15°) × 128. */
    double half = 1.0 / 6.0 / tan(15.0 * M_PI / 180.0) * 128.0;
    uint32_t inside = 0, missing = 0;
    double worst = 0;
    for (uint32_t y = 0; y < img->height; y++)
        for (uint32_t x = 0; x < img->width; x++) {
            double px = x + 0.5 - 128.0, py = y + 0.5 - 128.0;
            if (fabs(px) > half - 1.0 || fabs(py) > half - 1.0)
                continue;
            inside++;
            size_t q = (size_t)y * img->width + x;
            if (img->patch[q] == RAD_NONE) {
                missing++;
                continue;
            }
            worst = fmax(worst, fabs(img->pixels[q * img->channels] * M_PI - 1.0));
        }
    printf("  %u pixels inside the floor: %u missing, worst |L·π − 1| = %.2e\n", inside, missing,
           worst);
    CHECK(inside > 20000);
    CHECK(missing == 0);
    CHECK(worst <= 1e-4);
    rn_image_destroy(img);
    rad_solution_destroy(s);
}

/* Graded meshes: the refined floor of the shadow scene (elements of four
 * levels, T-vertices wherever a finer element meets a coarser one) with
 * each element's B set to a linear function of its centre, seen from
 * straight above like the crack test.  Every pixel inside the floor shows
 * that function at the point it sees, within 1e-5 relative: vertex values
 * are least-squares fits of the cells around them, exact for a linear field
 * whatever the cells' sizes (a plain average of the cells is off by about
 * half a cell times the gradient at a T-vertex, 1e-2 here), and the fans
 * of coarse elements pass through their centres' B. */
TEST(graded_mesh_draws_a_linear_field_exactly)
{
    rad_solution *s = shadow_solution();
    CHECK(s && s->elements);
    if (!s || !s->elements)
        return;
    rad_elements *el = s->elements;
    uint32_t floor = object_named(s, "floor"), levels = 0;
    const double a = 2.0, gx = 0.5, gy = -0.25; /* B = a + gx x + gy y > 0 on [-0.5, 1.5]² */
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        rad_patch *c = &el->mesh->patches[e];
        el->B[e] = a + gx * c->center.x + gy * c->center.y;
        if (c->object != floor)
            for (int k = 0; k < rad_patch_corners(c); k++)
                el->mesh->vertices[c->v[k]].z = -5.0;
        else
            levels |= 1u << el->level[e];
    }
    CHECK(levels == 0xF); /* levels 0 to 3 all present */
    rn_camera cam = {.eye = {0.5, 0.5, 6.0}, .target = {0.5, 0.5, 0.0}, .up = {0, 1, 0},
                     .yfov_deg = 30.0, .width = 256, .height = 256};
    rn_image *img = NULL;
    rad_error err = {0};
    CHECK(rad_render_solution(s, &cam, &img, &err) == RAD_OK);
    if (!img) {
        rad_solution_destroy(s);
        return;
    }
    /* Pixel (x, y) looks along (a, b, −1) with a = (x + ½ − 128)/k, b =
     * (128 − y − ½)/k, k = 128 / tan 15°, and meets z = 0 at 6·(a, b). */
    const double k = 128.0 / tan(15.0 * M_PI / 180.0), half = 1.0 / 6.0 * k;
    uint32_t inside = 0;
    double worst = 0;
    for (uint32_t y = 0; y < img->height; y++)
        for (uint32_t x = 0; x < img->width; x++) {
            double px = x + 0.5 - 128.0, py = 128.0 - y - 0.5;
            if (fabs(px) > half - 1.0 || fabs(py) > half - 1.0)
                continue;
            size_t q = (size_t)y * img->width + x;
            if (img->patch[q] == RAD_NONE)
                continue;
            inside++;
            double fx = 0.5 + 6.0 * px / k, fy = 0.5 + 6.0 * py / k, B = a + gx * fx + gy * fy;
            worst = fmax(worst, fabs(img->pixels[q * img->channels] * M_PI / B - 1.0));
        }
    printf("  %u pixels inside the floor: worst |drawn / linear − 1| = %.2e\n", inside, worst);
    CHECK(inside > 20000);
    CHECK(worst <= 1e-5);
    rn_image_destroy(img);
    rad_solution_destroy(s);
}

/* A white box (sides and top, no bottom, like the Cornell box's blocks),
 * footprint [lo, hi]², 0.25 high, resting on a floor of 8 × 8 patches under
 * a large lamp; refined as opt says (NULL: no elements).  With lo = .375,
 * hi = .625 the floor's patches line up with the footprint: 4 patches lie
 * wholly under the box. */
static rad_solution *box_solution(double lo, double hi, const rad_solve_options *opt)
{
    char text[2048];
    snprintf(text, sizeof text,
             "bands 1\n"
             "material white reflectance 0.5\n"
             "material lamp reflectance 0 emission 1\n"
             "polygon floor white subdivide 8 8\n 0 0 0\n 1 0 0\n 1 1 0\n 0 1 0\nend\n"
             "polygon lamp lamp subdivide 2 2\n 0 0 1\n 0 1 1\n 1 1 1\n 1 0 1\nend\n"
             "polygon top white subdivide 2 2\n %g %g .25\n %g %g .25\n %g %g .25\n %g %g .25\nend\n"
             "polygon south white subdivide 2 1\n %g %g 0\n %g %g 0\n %g %g .25\n %g %g .25\nend\n"
             "polygon east white subdivide 2 1\n %g %g 0\n %g %g 0\n %g %g .25\n %g %g .25\nend\n"
             "polygon north white subdivide 2 1\n %g %g 0\n %g %g 0\n %g %g .25\n %g %g .25\nend\n"
             "polygon west white subdivide 2 1\n %g %g 0\n %g %g 0\n %g %g .25\n %g %g .25\nend\n",
             lo, lo, hi, lo, hi, hi, lo, hi,   /* top */
             lo, lo, hi, lo, hi, lo, lo, lo,   /* south */
             hi, lo, hi, hi, hi, hi, hi, lo,   /* east */
             hi, hi, lo, hi, lo, hi, hi, hi,   /* north */
             lo, hi, lo, lo, lo, lo, lo, hi);  /* west */
    rad_scene *scene = NULL;
    rad_error err = {0};
    if (rad_scene_parse_polyfile(text, strlen(text), "box.rad", NULL, &scene, &err)) {
        fprintf(stderr, "  parse: %s\n", err.message);
        return NULL;
    }
    rad_solve_options none = {.refine_threshold = RAD_REFINE_OFF};
    rad_solution *s = NULL;
    if (rad_solve_scene(scene, opt ? opt : &none, &s, &err)) {
        fprintf(stderr, "  solve: %s\n", err.message);
        return NULL;
    }
    return s;
}

/* The box scene's floor seen from straight above with elements `levels`
 * splits deep (the box's top hides the floor under it). */
static rn_image *box_floor_view(rad_solution *s, uint32_t levels)
{
    rad_solve_options opt = {0};
    opt.element_levels = levels;
    rad_error err = {0};
    if (rad_refine_solution(s, &opt, &err) != RAD_OK)
        return NULL;
    rn_camera cam = {.eye = {0.5, 0.5, 50.0}, .target = {0.5, 0.5, 0.0}, .up = {0, 1, 0},
                     .yfov_deg = 2.0 * atan(0.5 / 50.0) * 180.0 / M_PI, .width = 512, .height = 512};
    rn_image *img = NULL;
    if (rad_render_solution(s, &cam, &img, &err) != RAD_OK)
        return NULL;
    return img;
}

/* Buried elements: the floor under the box sees only the box's back faces
 * (an empty row, B = 0).  Drawn as they are, those zeros would be averaged
 * into the vertices of the contact lines and darken the visible floor
 * beside the box over an element's width.  (1) Exactly the 4 patches under
 * the box are drawn with another value than their B, a positive one.  (2)
 * The visible floor within a patch width of the box, drawn from elements
 * two splits deep, is within 1.5 % (mean absolute difference over its
 * pixels, relative to their mean) of the floor drawn from elements three
 * splits deep; with the buried zeros averaged in, it is 1.9 % off. */
TEST(buried_elements_do_not_darken_their_neighbours)
{
    rad_solution *s = box_solution(.375, .625, NULL);
    CHECK(s != NULL);
    if (!s)
        return;
    const uint32_t np = s->mesh->patch_count, floor = object_named(s, "floor");
    double *drawn = malloc(np * sizeof *drawn);
    rad_error err = {0};
    CHECK(drawn && rad_elements_drawn_radiosity(s, NULL, s->mesh, NULL, drawn, &err) == RAD_OK);
    uint32_t changed = 0, positive = 0;
    for (uint32_t p = 0; drawn && p < np; p++)
        if (drawn[p] != s->B[p]) {
            changed++;
            positive += s->mesh->patches[p].object == floor && s->B[p] == 0.0 && drawn[p] > 0.0;
        }
    printf("  patches drawn with another value than their B: %u (%u buried floor patches, > 0)\n",
           changed, positive);
    CHECK(changed == 4 && positive == 4);
    free(drawn);
    rn_image *ref = box_floor_view(s, 3), *img = box_floor_view(s, 2);
    CHECK(ref && img);
    double diff = 0, sum = 0;
    uint32_t pixels = 0;
    for (size_t q = 0; ref && img && q < (size_t)512 * 512; q++) {
        uint32_t id = ref->patch[q];
        double fx = ((double)(q % 512) + 0.5) / 512.0, fy = 1.0 - ((double)(q / 512) + 0.5) / 512.0;
        double d = fmax(fabs(fx - 0.5), fabs(fy - 0.5)) - 0.125; /* Chebyshev distance to the box */
        if (id == RAD_NONE || s->mesh->patches[id].object != floor || !(d > 0.0 && d < 0.125))
            continue;
        pixels++;
        diff += fabs(img->pixels[q] - ref->pixels[q]);
        sum += ref->pixels[q];
    }
    printf("  %u floor pixels beside the box: two splits vs three, MAE %.4f of the mean\n", pixels,
           sum > 0 ? diff / sum : -1.0);
    CHECK(pixels > 45000);
    CHECK(sum > 0 && diff / sum < 0.015);
    rn_image_destroy(ref);
    rn_image_destroy(img);
    rad_solution_destroy(s);
}

/* The foot of a block: with the box's footprint [0.3, 0.7]² cutting through
 * floor patches (1/8 wide), a patch whose centre and four probes lie under
 * the box still has a sliver of visible floor beside it, which nothing
 * probes.  Refinement treats a leaf across the contact line (seen with
 * buried probes, or buried beside a seen leaf) as missing its B on 1/32
 * of its area, so at T = 2e-4 every floor element across the
 * footprint's outline is split to the size floor (level 3), and the
 * patches that no part of the footprint's outline crosses are not split
 * by this rule alone: those wholly under the box stay whole. */
TEST(refinement_splits_across_the_foot_of_a_block)
{
    const double lo = 0.3, hi = 0.7;
    rad_solve_options opt = {0};
    opt.refine_threshold = 2e-4;
    rad_solution *s = box_solution(lo, hi, &opt);
    CHECK(s && s->elements);
    if (!s || !s->elements)
        return;
    const rad_elements *el = s->elements;
    const uint32_t floor = object_named(s, "floor");
    uint32_t across = 0, coarse = 0, under = 0, under_split = 0;
    for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
        const rad_patch *c = &el->mesh->patches[e];
        if (c->object != floor)
            continue;
        double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
        for (int k = 0; k < rad_patch_corners(c); k++) {
            rad_vec3 v = el->mesh->vertices[c->v[k]];
            x0 = fmin(x0, v.x), x1 = fmax(x1, v.x), y0 = fmin(y0, v.y), y1 = fmax(y1, v.y);
        }
        int overlaps = x0 < hi && x1 > lo && y0 < hi && y1 > lo;
        int inside = x0 >= lo && x1 <= hi && y0 >= lo && y1 <= hi;
        if (overlaps && !inside) {
            across++;
            coarse += el->level[e] != 3;
        }
        /* the patches [.375, .625]² lie wholly under the box, 1/16 from its outline */
        if (x0 >= 0.375 - 1e-12 && x1 <= 0.625 + 1e-12 && y0 >= 0.375 - 1e-12 && y1 <= 0.625 + 1e-12) {
            under++;
            under_split += el->level[e] != 0;
        }
    }
    printf("  %u floor elements across the footprint's outline, %u of them coarser than the floor;"
           " %u elements under the box's inner patches, %u split\n", across, coarse, under, under_split);
    CHECK(across > 0);
    CHECK(coarse == 0);
    CHECK(under == 4 && under_split == 0);
    rad_solution_destroy(s);
}

/* A relight: the lamp ×2 doubles every element's B (within 1e-6 relative:
 * the gather is linear in B and E) with no hemi-cube for patches or
 * elements and no item buffer (the refinement's elements are interpolated
 * ones: their lamp entries, strata × visibility, are stored). */
TEST(relight_gathers_elements_again)
{
    rad_solution *s = shadow_solution();
    CHECK(s && s->elements);
    if (!s || !s->elements)
        return;
    uint32_t ne = s->elements->mesh->patch_count;
    double *before = malloc(ne * sizeof *before);
    CHECK(before != NULL);
    if (!before) {
        rad_solution_destroy(s);
        return;
    }
    memcpy(before, s->elements->B, ne * sizeof *before);
    rad_edit e;
    rad_error err = {0};
    CHECK(rad_edit_parse(RAD_EDIT_LIGHT, "lamp=2", &e, &err) == RAD_OK);
    CHECK(rad_solution_apply_edits(s, &e, 1, &err) == RAD_OK);
    rad_solve_options opt = {0};
    opt.solver.tolerance = 1e-10;
    CHECK(rad_resolve(s, &opt, &err) == RAD_OK);
    double worst = 0;
    for (uint32_t k = 0; k < ne; k++)
        if (before[k] > 0)
            worst = fmax(worst, fabs(s->elements->B[k] / (2.0 * before[k]) - 1.0));
    printf("  %u elements: worst |B'/2B − 1| = %.2e; rows computed: %llu patch, %llu element\n", ne,
           worst, (unsigned long long)s->rows_computed,
           (unsigned long long)s->elements->rows_computed);
    CHECK(worst < 1e-6);
    CHECK(s->rows_computed == 0);
    CHECK(s->elements->rows_computed == 0);
    CHECK(s->lights_computed == 0); /* no item buffer either: the strata's are stored */
    free(before);
    rad_solution_destroy(s);
}


/* ----------------------------------------------- a block's shadow at defaults */

/* The floating block's scene: a 2×2 floor (ρ = 0.5) in z = 0, a lamp of
 * side 0.3 at z = 1.2 over (1, 1) facing down (radiance 1: E = π, ρ = 0),
 * and a black block [0.3,0.6]×[0.4,0.7]×[0.1,0.4] between them.  Nothing
 * but the floor reflects and the floor does not see itself, so its B is
 * ρ E F(x → the part of the lamp x sees), which geometry gives exactly. */
#define BLOCK_LAMP_Z 1.2
static const double block_lo[3] = {0.3, 0.4, 0.1}, block_hi[3] = {0.6, 0.7, 0.4};

static const char *block_scene_text(void)
{
    return "bands 1\n"
           "material white reflectance 0.5\n"
           "material lamp emission 3.141592653589793\n"
           "material black reflectance 0\n"
           "polygon floor white 0 0 0  2 0 0  2 2 0  0 2 0 end\n"
           "polygon lamp lamp 0.85 0.85 1.2  0.85 1.15 1.2  1.15 1.15 1.2  1.15 0.85 1.2 end\n"
           "group block\n"
           " polygon bottom black 0.3 0.4 0.1  0.3 0.7 0.1  0.6 0.7 0.1  0.6 0.4 0.1 end\n"
           " polygon top black 0.3 0.4 0.4  0.6 0.4 0.4  0.6 0.7 0.4  0.3 0.7 0.4 end\n"
           " polygon south black 0.3 0.4 0.1  0.6 0.4 0.1  0.6 0.4 0.4  0.3 0.4 0.4 end\n"
           " polygon north black 0.3 0.7 0.1  0.3 0.7 0.4  0.6 0.7 0.4  0.6 0.7 0.1 end\n"
           " polygon west black 0.3 0.4 0.1  0.3 0.4 0.4  0.3 0.7 0.4  0.3 0.7 0.1 end\n"
           " polygon east black 0.6 0.4 0.1  0.6 0.7 0.1  0.6 0.7 0.4  0.6 0.4 0.4 end\n"
           "end\n";
}

/* Clips the convex polygon P (n points, in the plane z = const) to the
 * half-plane left of a→b; returns the new count. */
static int clip_left(rad_vec3 *P, int n, rad_vec3 a, rad_vec3 b)
{
    rad_vec3 out[32];
    int m = 0;
    for (int k = 0; k < n && m < 30; k++) {
        rad_vec3 p = P[k], q = P[(k + 1) % n];
        double sp = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
        double sq = (b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x);
        if (sp >= 0)
            out[m++] = p;
        if ((sp >= 0) != (sq >= 0))
            out[m++] = rad_add(p, rad_scale(rad_sub(q, p), sp / (sp - sq)));
    }
    memcpy(P, out, (size_t)m * sizeof *P);
    return m;
}

/* The form factor from floor point x (normal +z) to the part of the lamp
 * that the block does not hide: the lamp's factor minus that of its
 * intersection with the block's shadow on the lamp's plane, the convex hull
 * of the block's corners projected from x (every corner lies above x). */
static double lamp_seen(rad_vec3 x, double *whole)
{
    const rad_vec3 up = rad_v3(0, 0, 1);
    rad_vec3 lamp[4] = {{0.85, 0.85, BLOCK_LAMP_Z}, {1.15, 0.85, BLOCK_LAMP_Z},
                        {1.15, 1.15, BLOCK_LAMP_Z}, {0.85, 1.15, BLOCK_LAMP_Z}};
    *whole = hc_ff_point_polygon(x, up, lamp, 4);
    rad_vec3 c[8];
    for (int k = 0; k < 8; k++) {
        rad_vec3 v = rad_v3((k & 1) ? block_hi[0] : block_lo[0], (k & 2) ? block_hi[1] : block_lo[1],
                            (k & 4) ? block_hi[2] : block_lo[2]);
        c[k] = rad_add(x, rad_scale(rad_sub(v, x), (BLOCK_LAMP_Z - x.z) / (v.z - x.z)));
    }
    /* convex hull (gift wrapping, counter-clockwise) of the 8 points */
    rad_vec3 hull[8];
    int nh = 0, start = 0;
    for (int k = 1; k < 8; k++)
        if (c[k].x < c[start].x || (c[k].x == c[start].x && c[k].y < c[start].y))
            start = k;
    int p = start;
    do {
        hull[nh++] = c[p];
        int q = (p + 1) % 8;
        for (int k = 0; k < 8; k++) {
            double cr = (c[q].x - c[p].x) * (c[k].y - c[p].y) - (c[q].y - c[p].y) * (c[k].x - c[p].x);
            if (cr < 0)
                q = k;
        }
        p = q;
    } while (p != start && nh < 8);
    rad_vec3 P[32];
    memcpy(P, lamp, sizeof lamp);
    int n = 4;
    for (int k = 0; k < nh && n > 0; k++)
        n = clip_left(P, n, hull[k], hull[(k + 1) % nh]);
    double hidden = n >= 3 ? hc_ff_point_polygon(x, up, P, (uint32_t)n) : 0.0;
    return *whole - hidden;
}

/* The shadow of a block under a small lamp, drawn at the defaults (elements
 * by the default refinement): seen from straight above, the mean radiance
 * over the floor pixels in the block's shadow (some of the lamp hidden),
 * over its penumbra alone and over the lit floor, against ρ E F/π with the
 * exact visible part of the lamp at each pixel's point.  The issue asks for
 * 2 %.  At the default edge (diagonal / 34) measured +0.72 % (shadow),
 * +0.30 % (penumbra), -0.04 % (lit).  The shadow's figure moves with where
 * the element edges fall against it: +0.04, +1.60, -1.53, +0.54, +0.02,
 * +0.72, -0.38, +1.16 % at diagonal / 24, 26, 28, 30, 32, 34, 36, 38 (the
 * penumbra and the lit floor stay within 0.5 %), so its bound is the
 * issue's 2 % and the other two keep 0.5 %.  Patches alone (no elements):
 * shadow +40 %, penumbra +12 %, lit -1.1 % (at / 24).  Cost: about 1 s of
 * CPU. */
TEST(block_shadow_at_defaults)
{
    rad_solution *s = test_solve_text(block_scene_text(), "block.rad",
                                      &(rad_solve_options){0}); /* the defaults */
    CHECK(s && s->elements);
    if (!s)
        return;
    const uint32_t W = 256;
    const double dist = 20.0, half = 1.0;
    rn_camera cam = {.eye = {1.0, 1.0, dist}, .target = {1.0, 1.0, 0.0}, .up = {0, 1, 0},
                     .yfov_deg = 2.0 * atan(half / dist) * 180.0 / M_PI, .width = W, .height = W};
    rn_image *img = NULL;
    rad_error err = {0};
    CHECK(rad_render_solution(s, &cam, &img, &err) == RAD_OK);
    const uint32_t floor = object_named(s, "floor");
    double got[3] = {0}, want[3] = {0};
    uint32_t count[3] = {0};
    /* the renderer's pinhole: pixel (i, j) looks along f + a r + b u */
    const double k = 0.5 * W / (half / dist);
    for (uint32_t j = 0; img && j < W; j++)
        for (uint32_t i = 0; i < W; i++) {
            uint32_t id = img->patch[(size_t)j * W + i];
            if (id == RAD_NONE)
                continue;
            if (s->mesh->patches[id].object != floor) /* the image names patches */
                continue;
            /* camera right = f × up = (0,0,-1) × (0,1,0) = (1,0,0); up = (0,1,0) */
            double a = (i + 0.5 - 0.5 * W) / k, b = (0.5 * W - j - 0.5) / k;
            rad_vec3 x = rad_v3(1.0 + a * dist, 1.0 + b * dist, 0.0);
            if (x.x < 0.02 || x.x > 1.98 || x.y < 0.02 || x.y > 1.98)
                continue; /* the floor's outline pixels are extrapolated */
            double whole, seen = lamp_seen(x, &whole);
            /* 0: the shadow (some of the lamp hidden), 1: its penumbra (some
             * of the lamp seen too), 2: the lit floor */
            const int lit = seen >= whole * (1 - 1e-12), penumbra = !lit && seen > 0.0;
            const double L = 0.5 * seen; /* ρ E F / π, E = π */
            const float px = img->pixels[(size_t)j * W + i];
            for (int c = 0; c < 3; c++)
                if (c == 0 ? !lit : c == 1 ? penumbra : lit) {
                    got[c] += px;
                    want[c] += L;
                    count[c]++;
                }
        }
    const char *what[3] = {"shadow", "penumbra", "lit floor"};
    for (int c = 0; c < 3; c++) {
        CHECK(count[c] > 500);
        printf("  %-9s %6u pixels: mean L %.6f, exact %.6f (%+.2f %%)\n", what[c], count[c],
               got[c] / count[c], want[c] / count[c], 100 * (got[c] / want[c] - 1));
        CHECK_REL(got[c], want[c], c == 0 ? 2e-2 : 5e-3);
    }
    rn_image_destroy(img);
    rad_solution_destroy(s);
}

int main(void)
{
    RUN(gather_matches_catalog);
    RUN(refinement_follows_the_shadow);
    RUN(refined_plane_has_no_cracks);
    RUN(graded_mesh_draws_a_linear_field_exactly);
    RUN(buried_elements_do_not_darken_their_neighbours);
    RUN(refinement_splits_across_the_foot_of_a_block);
    RUN(relight_gathers_elements_again);
    RUN(block_shadow_at_defaults);
    return test_finish("test_elements");
}
