/* bench_elements.c - what adaptive elements save (issue 6).
 *
 * The bundled Cornell box is solved once on coarse patches (patch size
 * 0.08 m, 368 patches; BENCH_PATCH_SIZE changes it): the patch solution that
 * every element set below gathers from.  Scores look at the floor and the
 * three walls only.
 *
 * Reference: uniform elements REF_LEVELS = 6 splits deep (BENCH_REF_LEVELS)
 * on those four surfaces, 4096 elements a patch, 1.3 mm.  The other patches
 * stay unsplit while it is made (their ρ is set to 0 for the call: only a
 * reflecting patch splits, and an element's gather reads the ρ of its own
 * patch only, so the floor's and walls' elements are exactly those of a
 * uniform set), because no score looks at them.
 *
 * Candidates: uniform at 0..REF_LEVELS-2 splits (every reflecting patch),
 * and adaptive at several thresholds T, never deeper than the finest
 * uniform set: every candidate stays two levels coarser than the reference.
 * Uniform REF_LEVELS-1 on the four surfaces is scored too: how far the
 * reference itself may be from converged.
 *
 * Three mean absolute errors over the floor and the walls, all bands,
 * relative to the reference's mean there:
 *   element MAE - the piecewise-constant B of the candidate element holding
 *                 each reference element's centre, area-weighted: the
 *                 solution itself, not what is drawn;
 *   area MAE    - what the renderer draws (vertex interpolation), each
 *                 surface drawn alone and head-on from far away (1024², as
 *                 good as orthographic: every square metre of every surface
 *                 weighs the same; the floor under the blocks, which nothing
 *                 sees, is hidden by the blocks' tops);
 *   image MAE   - what the renderer draws from the scene's camera, 512²,
 *                 the pixels of those surfaces (the camera weighs the back
 *                 wall about twice as much per square metre as the floor).
 * Each uniform error falls as a power of the element count; for each
 * adaptive set the tables give the uniform count that reaches the same MAE
 * (log-log interpolation between the uniform sets) and the ratio, counting
 * every element and counting only those on the scored surfaces (an
 * adaptive set spends fewer on the blocks and the ceiling, which no score
 * looks at: the second ratio is the fair one).
 *
 * Environment: BENCH_PATCH_SIZE, BENCH_REF_LEVELS; BENCH_THRESHOLDS, the
 * adaptive sets' T as a comma-separated list (default 1e-3,3e-4,1e-4,3e-5,
 * 1e-5, at most 16); BENCH_REF_R and BENCH_R,
 * the hemi-cube resolution of the reference's and the candidates' element
 * rows (default 128); BENCH_REF_FILE, a solution file the reference is read
 * from when it exists and written to when not (same scene and settings:
 * the file does not record them); BENCH_MAPS, a directory that gets each
 * set's error maps (write_maps) and whose area MAE is printed per surface;
 * BENCH_ONLY_ADAPTIVE, no uniform sets (to try a rule against a uniform
 * curve measured before); BENCH_INTERP=1, the adaptive sets with
 * interpolated elements (the default since issue 18) instead of a
 * hemi-cube per element (what this study measured).
 * Hemi-cubes are the element rows rendered (adaptive refinement renders
 * four per leaf it tests).  Times are wall-clock, one run each; nothing here
 * asserts anything.
 */
#include "../radiosity/pipeline/pipeline.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint32_t REF_LEVELS = 6;
static double PATCH_SIZE = 0.08;
static uint32_t REF_R = 0, SET_R = 0; /* element hemi-cube resolutions, 0 = 128 */
enum { SURFACES = 4, SIDE = 1024 };
static const char *const surface_name[SURFACES] = {"floor", "back_wall", "left_wall_red",
                                                   "right_wall_green"};

static void die(const char *what, const rad_error *err)
{
    fprintf(stderr, "bench_elements: %s: %s\n", what, err ? err->message : "");
    exit(1);
}

/* The scored surface object o is, or -1. */
static int surface_of(const rad_scene *sc, uint32_t object)
{
    for (int k = 0; k < SURFACES; k++)
        if (!strcmp(sc->objects[object].name, surface_name[k]))
            return k;
    return -1;
}

/* Is p inside convex cell c (projected on its normal)? */
static int cell_contains(const rad_mesh *m, const rad_patch *c, rad_vec3 p)
{
    int n = rad_patch_corners(c);
    for (int k = 0; k < n; k++) {
        rad_vec3 a = m->vertices[c->v[k]], b = m->vertices[c->v[(k + 1) % n]];
        if (rad_dot(rad_cross(rad_sub(b, a), rad_sub(p, a)), c->normal) < -1e-12)
            return 0;
    }
    return 1;
}

/* Element MAE of el against ref (see the top of the file). */
static double element_score(const rad_solution *s, const rad_elements *el, const rad_elements *ref)
{
    const uint32_t nb = s->band_count, np = s->mesh->patch_count, ne = el->mesh->patch_count;
    /* Leaves of each patch, compressed rows. */
    uint32_t *start = calloc((size_t)np + 1, sizeof *start), *list = malloc((size_t)ne * sizeof *list);
    uint32_t *fill = malloc(((size_t)np + 1) * sizeof *fill);
    if (!start || !list || !fill)
        die("out of memory", NULL);
    for (uint32_t e = 0; e < ne; e++)
        start[el->patch[e] + 1]++;
    for (uint32_t p = 0; p < np; p++)
        start[p + 1] += start[p];
    memcpy(fill, start, ((size_t)np + 1) * sizeof *fill);
    for (uint32_t e = 0; e < ne; e++)
        list[fill[el->patch[e]]++] = e;
    double err = 0, mean = 0;
    for (uint32_t r = 0; r < ref->mesh->patch_count; r++) {
        const rad_patch *rc = &ref->mesh->patches[r];
        if (surface_of(s->scene, rc->object) < 0)
            continue;
        uint32_t p = ref->patch[r], hit = RAD_NONE;
        for (uint32_t k = start[p]; k < start[p + 1] && hit == RAD_NONE; k++)
            if (cell_contains(el->mesh, &el->mesh->patches[list[k]], rc->center))
                hit = list[k];
        if (hit == RAD_NONE)
            die("a reference element lies in no candidate element", NULL);
        for (uint32_t b = 0; b < nb; b++) {
            err += rc->area * fabs(el->B[(size_t)hit * nb + b] - ref->B[(size_t)r * nb + b]);
            mean += rc->area * ref->B[(size_t)r * nb + b];
        }
    }
    free(start);
    free(list);
    free(fill);
    return err / mean;
}

/* Each scored surface drawn alone, head-on from 100 m (see the top of the
 * file): the cells of that surface, and for the floor the cells of
 * everything but the walls (the blocks' tops hide the floor under them).
 * A pixel's patch is the element drawn there; pixels of other objects are
 * marked RAD_NONE.  out[k] are the caller's. */
static void draw_surfaces(rad_solution *s, rad_elements *el, rn_image *out[SURFACES])
{
    rad_error err = {0};
    const uint32_t nb = s->band_count;
    rad_mesh *rm = NULL;
    uint32_t *of = NULL;
    if (rad_elements_render_mesh(el, &rm, &of, &err))
        die("render mesh", &err);
    double *vB = malloc(((size_t)rm->vertex_count * nb + 1) * sizeof *vB);
    rad_patch *sub = malloc(((size_t)rm->patch_count + 1) * sizeof *sub);
    uint32_t *sub_object = malloc(((size_t)rm->patch_count + 1) * sizeof *sub_object);
    uint32_t *sub_element = malloc(((size_t)rm->patch_count + 1) * sizeof *sub_element);
    if (!vB || !sub || !sub_object || !sub_element)
        die("out of memory", NULL);
    if (rad_elements_vertex_radiosity(s, el, rm, of, NULL, vB, &err))
        die("vertex radiosity", &err);
    for (int w = 0; w < SURFACES; w++) {
        uint32_t n = 0;
        rad_vec3 lo = {INFINITY, INFINITY, INFINITY}, hi = {-INFINITY, -INFINITY, -INFINITY}, normal = {0, 0, 0};
        for (uint32_t k = 0; k < rm->patch_count; k++) {
            const rad_patch *c = &rm->patches[k];
            int mine = surface_of(s->scene, c->object);
            if (mine != w && !(w == 0 && mine < 0))
                continue;
            sub_object[n] = c->object;
            sub_element[n] = of[k];
            sub[n++] = *c;
            if (mine != w)
                continue;
            normal = c->normal;
            for (int q = 0; q < rad_patch_corners(c); q++) {
                rad_vec3 v = rm->vertices[c->v[q]];
                lo = rad_v3(fmin(lo.x, v.x), fmin(lo.y, v.y), fmin(lo.z, v.z));
                hi = rad_v3(fmax(hi.x, v.x), fmax(hi.y, v.y), fmax(hi.z, v.z));
            }
        }
        rad_mesh m = *rm;
        m.patches = sub;
        m.patch_count = n;
        rad_vec3 centre = rad_scale(rad_add(lo, hi), 0.5);
        const double D = 100.0, half = 0.3; /* every surface fits in 0.6 m */
        rn_camera cam = {.eye = rad_add(centre, rad_scale(normal, D)), .target = centre,
                         .up = fabs(normal.y) > 0.5 ? rad_v3(0, 0, 1) : rad_v3(0, 1, 0),
                         .yfov_deg = 2.0 * atan(half / D) * 180.0 / M_PI, .width = SIDE, .height = SIDE};
        if (rn_render(&m, nb, vB, &cam, &out[w], &err))
            die("render a surface", &err);
        for (size_t q = 0; q < (size_t)SIDE * SIDE; q++) {
            uint32_t id = out[w]->patch[q];
            out[w]->patch[q] = id == RAD_NONE || surface_of(s->scene, sub_object[id]) != w
                                   ? RAD_NONE
                                   : sub_element[id];
        }
    }
    free(vB);
    free(sub);
    free(sub_object);
    free(sub_element);
    free(of);
    rad_mesh_destroy(rm);
}

/* Σ|a − ref| / Σ ref over the pixels ref marks (all channels, n images). */
static double pixel_score(rn_image *const *a, rn_image *const *ref, int n)
{
    double err = 0, sum = 0;
    for (int k = 0; k < n; k++) {
        size_t npx = (size_t)ref[k]->width * ref[k]->height;
        uint32_t ch = ref[k]->channels;
        for (size_t q = 0; q < npx; q++) {
            if (ref[k]->patch[q] == RAD_NONE)
                continue;
            for (uint32_t c = 0; c < ch; c++) {
                err += fabs(a[k]->pixels[q * ch + c] - ref[k]->pixels[q * ch + c]);
                sum += ref[k]->pixels[q * ch + c];
            }
        }
    }
    return err / sum;
}

static rn_camera cam;

/* The scene camera's view; pixels not on a scored surface marked RAD_NONE. */
static rn_image *draw_view(rad_solution *s, rad_elements *el)
{
    rad_error err = {0};
    rn_image *img = NULL;
    s->elements = el;
    if (rad_render_solution(s, &cam, &img, &err))
        die("render", &err);
    s->elements = NULL;
    for (size_t q = 0; q < (size_t)img->width * img->height; q++)
        if (img->patch[q] != RAD_NONE && surface_of(s->scene, s->mesh->patches[img->patch[q]].object) < 0)
            img->patch[q] = RAD_NONE;
    return img;
}

enum { ELEMENT, AREA, IMAGE, METRICS };

typedef struct run {
    char name[64];
    uint32_t elements, scored; /* all, and on the floor and walls */
    uint64_t hemicubes;
    double seconds, mae[METRICS];
} run;

/* Refines s as asked; the elements go to *keep (s keeps none).  With
 * scored_only, patches off the scored surfaces do not split. */
static run refine(rad_solution *s, const char *name, double threshold, uint32_t levels,
                  double min_size, int scored_only, rad_elements **keep)
{
    rad_solve_options o = {0};
    o.hemicube.resolution = scored_only && levels == REF_LEVELS ? REF_R : SET_R;
    /* threshold 0 and no levels: the patches (0 would be the default) */
    o.refine_threshold = threshold > 0.0 || levels ? threshold : RAD_REFINE_OFF;
    o.element_levels = levels;
    /* The study is of the rule and the drawing, with a hemi-cube per
     * element as when it was measured; BENCH_INTERP=1 uses the default
     * interpolated elements instead (issue 18). */
    o.element_hemicubes = !(getenv("BENCH_INTERP") && atoi(getenv("BENCH_INTERP")));
    o.min_element_size = min_size;
    o.mesh.max_patches = 20000000u; /* a reference 7 splits deep counts 4.3 million nodes */
    const size_t n = (size_t)s->mesh->patch_count * s->band_count;
    double *rho = NULL;
    if (scored_only) {
        rho = malloc(n * sizeof *rho);
        if (!rho)
            die("out of memory", NULL);
        memcpy(rho, s->rho, n * sizeof *rho);
        for (uint32_t p = 0; p < s->mesh->patch_count; p++)
            if (surface_of(s->scene, s->mesh->patches[p].object) < 0)
                for (uint32_t b = 0; b < s->band_count; b++)
                    s->rho[(size_t)p * s->band_count + b] = 0.0;
    }
    rad_error err = {0};
    double t0 = rad_seconds();
    int rc = rad_refine_solution(s, &o, &err);
    if (rho) {
        memcpy(s->rho, rho, n * sizeof *rho);
        free(rho);
    }
    if (rc)
        die(name, &err);
    const rad_mesh *em = s->elements->mesh;
    run r = {{0}, em->patch_count, 0, s->elements->rows_computed, rad_seconds() - t0, {0}};
    for (uint32_t e = 0; e < em->patch_count; e++)
        r.scored += surface_of(s->scene, em->patches[e].object) >= 0;
    snprintf(r.name, sizeof r.name, "%s", name);
    *keep = s->elements;
    s->elements = NULL;
    return r;
}

/* BENCH_MAPS=dir: for each set, its area MAE per surface on stdout and,
 * per surface, dir/<set>_<surface>.png: the reference dimmed to grey, the
 * error |drawn − reference| in red (full red at 5 % of the reference's mean
 * over the scored surfaces), element edges in blue. */
static void write_maps(const char *dir, const run *r, rn_image *const *a, rn_image *const *ref)
{
    double mean = 0, area = 0;
    for (int k = 0; k < SURFACES; k++) {
        uint32_t ch = ref[k]->channels;
        for (size_t q = 0; q < (size_t)SIDE * SIDE; q++)
            if (ref[k]->patch[q] != RAD_NONE) {
                for (uint32_t c = 0; c < ch; c++)
                    mean += ref[k]->pixels[q * ch + c] / ch;
                area++;
            }
    }
    mean /= area;
    printf("%s: area MAE by surface:", r->name);
    for (int k = 0; k < SURFACES; k++) {
        printf(" %s %.5f", surface_name[k], pixel_score(&a[k], &ref[k], 1));
        uint32_t ch = ref[k]->channels, W = SIDE;
        rn_image map = {W, W, 3, malloc((size_t)W * W * 3 * sizeof(float)), a[k]->patch};
        if (!map.pixels)
            die("out of memory", NULL);
        for (size_t q = 0; q < (size_t)W * W; q++) {
            float *o = map.pixels + q * 3;
            o[0] = o[1] = o[2] = 0.0f;
            if (ref[k]->patch[q] == RAD_NONE)
                continue;
            double e = 0, g = 0;
            for (uint32_t c = 0; c < ch; c++) {
                e += fabs(a[k]->pixels[q * ch + c] - ref[k]->pixels[q * ch + c]) / ch;
                g += ref[k]->pixels[q * ch + c] / ch;
            }
            size_t x = q % W, y = q / W;
            int edge = (x + 1 < W && a[k]->patch[q + 1] != a[k]->patch[q]) ||
                       (y + 1 < W && a[k]->patch[q + W] != a[k]->patch[q]);
            o[0] = o[1] = o[2] = (float)(0.25 * g / mean);
            o[0] = (float)fmin(1.0, o[0] + e / (0.05 * mean));
            if (edge)
                o[2] = 1.0f;
        }
        char path[512];
        snprintf(path, sizeof path, "%s/%s_%s.png", dir, r->name, surface_name[k]);
        for (char *c = path + strlen(dir) + 1; *c; c++)
            if (*c == ' ' || *c == ',' || *c == '=')
                *c = '_';
        rad_error err = {0};
        if (rn_write_png(&map, path, 0.0, &err))
            die("write a map", &err);
        free(map.pixels);
    }
    printf("\n");
}

/* Scores el on the three metrics against the reference's images. */
static void score(rad_solution *s, rad_elements *el, const rad_elements *ref, rn_image *ref_view,
                  rn_image *const *ref_surf, run *r)
{
    r->mae[ELEMENT] = element_score(s, el, ref);
    rn_image *surf[SURFACES];
    draw_surfaces(s, el, surf);
    r->mae[AREA] = pixel_score(surf, ref_surf, SURFACES);
    if (getenv("BENCH_MAPS"))
        write_maps(getenv("BENCH_MAPS"), r, surf, ref_surf);
    for (int k = 0; k < SURFACES; k++)
        rn_image_destroy(surf[k]);
    rn_image *view = draw_view(s, el);
    r->mae[IMAGE] = pixel_score(&view, &ref_view, 1);
    rn_image_destroy(view);
}

int main(void)
{
    rad_error err = {0};
    rad_solve_options opt = {0};
    if (getenv("BENCH_PATCH_SIZE"))
        PATCH_SIZE = atof(getenv("BENCH_PATCH_SIZE"));
    if (getenv("BENCH_REF_LEVELS"))
        REF_LEVELS = (uint32_t)atoi(getenv("BENCH_REF_LEVELS"));
    if (getenv("BENCH_REF_R"))
        REF_R = (uint32_t)atoi(getenv("BENCH_REF_R"));
    if (getenv("BENCH_R"))
        SET_R = (uint32_t)atoi(getenv("BENCH_R"));
    if (REF_LEVELS < 3 || REF_LEVELS > RAD_MAX_ELEMENT_LEVEL)
        die("BENCH_REF_LEVELS must be 3..12", NULL);
    opt.mesh.patch_size = PATCH_SIZE;
    rad_solution *s = NULL;
    double t0 = rad_seconds();
    if (rad_solve_scene_file("models/cornell.rad", &opt, &s, &err))
        die("solve", &err);
    printf("Cornell box, patch size %.2f m: %u patches, patch solution %.2f s (R = 128)\n",
           PATCH_SIZE, s->mesh->patch_count, rad_seconds() - t0);
    if (rad_camera_from_scene(s->scene, NULL, 512, 512, &cam, &err))
        die("camera", &err);

    rad_elements *ref = NULL;
    run rr = {{0}, 0, 0, 0, 0, {0}};
    /* BENCH_REF_FILE: the reference is read from that solution file when it
     * exists (the same scene and patch size), and written there when not. */
    const char *ref_file = getenv("BENCH_REF_FILE");
    rad_solution *stored = NULL;
    if (ref_file && rad_solution_read(ref_file, &stored, &err) == RAD_OK && stored->elements &&
        stored->mesh->patch_count == s->mesh->patch_count) {
        ref = stored->elements;
        stored->elements = NULL;
        rr.elements = ref->mesh->patch_count;
    } else {
        rr = refine(s, "reference", 0, REF_LEVELS, 0, 1, &ref);
        if (ref_file) {
            s->elements = ref;
            if (rad_solution_write(s, ref_file, &err))
                die("write the reference", &err);
            s->elements = NULL;
        }
    }
    rad_solution_destroy(stored);
    rn_image *ref_view = draw_view(s, ref), *ref_surf[SURFACES];
    draw_surfaces(s, ref, ref_surf);
    /* Adaptive sets stop at the depth of the finest uniform candidate: no
     * element edge below four times the reference's. */
    double min_size = INFINITY;
    for (uint32_t e = 0; e < ref->mesh->patch_count; e++) {
        const rad_patch *c = &ref->mesh->patches[e];
        if (ref->level[e] != REF_LEVELS)
            continue;
        for (int k = 0; k < rad_patch_corners(c); k++)
            min_size = fmin(min_size, rad_length(rad_sub(ref->mesh->vertices[c->v[(k + 1) % rad_patch_corners(c)]],
                                                         ref->mesh->vertices[c->v[k]])));
    }
    min_size *= 4.0;
    printf("reference: uniform, %u splits on the floor and walls: %u elements, %.1f s\n\n", REF_LEVELS,
           rr.elements, rr.seconds);

    enum { MAX_THRESHOLDS = 16 };
    /* BENCH_ONLY_ADAPTIVE: no uniform sets (for trying adaptive rules
     * against a uniform curve measured before). */
    const int uniform_sets = !getenv("BENCH_ONLY_ADAPTIVE");
    const uint32_t NU = uniform_sets ? REF_LEVELS - 1 : 0; /* uniform 0..REF_LEVELS-2 */
    double thresholds[MAX_THRESHOLDS] = {1e-3, 3e-4, 1e-4, 3e-5, 1e-5};
    int threshold_count = 5;
    if (getenv("BENCH_THRESHOLDS")) {
        threshold_count = 0;
        for (char *p = getenv("BENCH_THRESHOLDS"), *end; *p && threshold_count < MAX_THRESHOLDS;
             p = *end ? end + 1 : end) {
            thresholds[threshold_count] = strtod(p, &end);
            if (end == p || !(thresholds[threshold_count] > 0))
                die("BENCH_THRESHOLDS: a comma-separated list of positive numbers", NULL);
            threshold_count++;
        }
    }
    run uni[RAD_MAX_ELEMENT_LEVEL], ada[MAX_THRESHOLDS], conv = {{0}, 0, 0, 0, 0, {0}};
    for (uint32_t l = 0; l < NU; l++) {
        char name[64];
        snprintf(name, sizeof name, "uniform, %u splits", l);
        rad_elements *el = NULL;
        /* 0 splits: a size floor nothing passes keeps the patches as elements. */
        uni[l] = l ? refine(s, name, 0, l, 0, 0, &el) : refine(s, name, 1.0, 0, 1e300, 0, &el);
        score(s, el, ref, ref_view, ref_surf, &uni[l]);
        rad_element_store_destroy(el);
    }
    if (uniform_sets) {
        char name[64];
        snprintf(name, sizeof name, "uniform, %u splits, floor and walls only", REF_LEVELS - 1);
        rad_elements *el = NULL;
        conv = refine(s, name, 0, REF_LEVELS - 1, 0, 1, &el);
        score(s, el, ref, ref_view, ref_surf, &conv);
        rad_element_store_destroy(el);
    }
    for (int a = 0; a < threshold_count; a++) {
        char name[64];
        snprintf(name, sizeof name, "adaptive, T = %g", thresholds[a]);
        rad_elements *el = NULL;
        ada[a] = refine(s, name, thresholds[a], 0, min_size, 0, &el);
        score(s, el, ref, ref_view, ref_surf, &ada[a]);
        rad_element_store_destroy(el);
    }
    static const char *const title[METRICS] = {
        "Element MAE (piecewise-constant B at the reference element centres)",
        "Area MAE (what is drawn, interpolated; each surface head-on, every square metre alike)",
        "Image MAE (what is drawn, interpolated, 512² from the scene's camera)"};
    for (int m = 0; m < METRICS; m++) {
        printf("%s\n\n", title[m]);
        printf("| set | elements | on floor and walls | hemi-cubes | time s | MAE | uniform for it | ratio "
               "| uniform on floor and walls for it | ratio |\n");
        printf("|:--|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n");
        for (uint32_t l = 0; l < NU; l++)
            printf("| %s | %u | %u | %llu | %.2f | %.5f | | | | |\n", uni[l].name, uni[l].elements,
                   uni[l].scored, (unsigned long long)uni[l].hemicubes, uni[l].seconds, uni[l].mae[m]);
        if (uniform_sets)
            printf("| %s | %u | %u | %llu | %.2f | %.5f | | | | |\n", conv.name, conv.elements,
                   conv.scored, (unsigned long long)conv.hemicubes, conv.seconds, conv.mae[m]);
        for (int a = 0; a < threshold_count; a++) {
            double e = ada[a].mae[m], need = -1, need_scored = -1;
            /* log-log interpolation of the uniform curve at this MAE */
            for (uint32_t l = 0; l + 1 < NU; l++) {
                double e0 = uni[l].mae[m], e1 = uni[l + 1].mae[m];
                if (e <= e0 && e >= e1 && e1 > 0) {
                    double t = log(e / e0) / log(e1 / e0);
                    need = exp(log(uni[l].elements) + t * (log(uni[l + 1].elements) - log(uni[l].elements)));
                    need_scored = exp(log(uni[l].scored) + t * (log(uni[l + 1].scored) - log(uni[l].scored)));
                }
            }
            if (need > 0)
                printf("| %s | %u | %u | %llu | %.2f | %.5f | %.0f | %.2f | %.0f | %.2f |\n", ada[a].name,
                       ada[a].elements, ada[a].scored, (unsigned long long)ada[a].hemicubes, ada[a].seconds, e,
                       need, ada[a].elements / need, need_scored, ada[a].scored / need_scored);
            else
                printf("| %s | %u | %u | %llu | %.2f | %.5f | outside the uniform sets | | | |\n", ada[a].name,
                       ada[a].elements, ada[a].scored, (unsigned long long)ada[a].hemicubes, ada[a].seconds, e);
        }
        printf("\n");
    }
    for (int k = 0; k < SURFACES; k++)
        rn_image_destroy(ref_surf[k]);
    rn_image_destroy(ref_view);
    rad_element_store_destroy(ref);
    rad_solution_destroy(s);
    return 0;
}
