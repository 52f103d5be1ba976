/* bench_elements.c - what adaptive elements save (issue 6).
 *
 * The bundled Cornell box is solved once on coarse patches (patch size
 * 0.1 m: the patch solution, which every element set below shares).  A
 * reference is gathered from it on uniform elements REF_LEVELS splits deep
 * (every patch 4^REF_LEVELS elements).  Each candidate element set - uniform
 * at 0..REF_LEVELS-1 splits, adaptive at several refinement thresholds with
 * the same depth limit as the finest uniform set - is scored by the mean
 * absolute error of its piecewise-constant B over the floor and the walls:
 *   MAE = Σ_r A_r |B_leaf(r) − B_r| / Σ_r A_r   (over reference elements r,
 *         all bands, relative to the area-weighted mean B of those surfaces)
 * where leaf(r) is the candidate element containing r's centre.  The
 * uniform error falls as a power of the element count; for each adaptive
 * set the table gives the uniform count that reaches the same MAE (log-log
 * interpolation between the uniform sets) and the ratio.  Times are
 * wall-clock, one run each; nothing here asserts anything.
 */
#include "../radiosity/pipeline.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint32_t REF_LEVELS = 3;
static double PATCH_SIZE = 0.0; /* 0: the scene's own (the default mesh) */

static void die(const char *what, const rad_error *err)
{
    fprintf(stderr, "bench_elements: %s: %s\n", what, err ? err->message : "");
    exit(1);
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

static int surface_counts(const rad_scene *sc, uint32_t object)
{
    const char *name = sc->objects[object].name;
    return !strcmp(name, "floor") || !strcmp(name, "back_wall") || !strcmp(name, "left_wall_red") ||
           !strcmp(name, "right_wall_green");
}

/* MAE of el against ref (see the top of the file), relative. */
static double score(const rad_solution *s, const rad_elements *el, const rad_elements *ref)
{
    const uint32_t nb = s->band_count, np = s->mesh->patch_count;
    /* Leaves of each patch, compressed rows. */
    uint32_t *start = calloc((size_t)np + 1, sizeof *start), *list = malloc(el->mesh->patch_count * sizeof *list);
    uint32_t *fill = malloc(((size_t)np + 1) * sizeof *fill);
    if (!start || !list || !fill)
        die("out of memory", NULL);
    for (uint32_t e = 0; e < el->mesh->patch_count; e++)
        start[el->patch[e] + 1]++;
    for (uint32_t p = 0; p < np; p++)
        start[p + 1] += start[p];
    memcpy(fill, start, ((size_t)np + 1) * sizeof *fill);
    for (uint32_t e = 0; e < el->mesh->patch_count; e++)
        list[fill[el->patch[e]]++] = e;
    double err = 0, area = 0, mean = 0;
    for (uint32_t r = 0; r < ref->mesh->patch_count; r++) {
        const rad_patch *rc = &ref->mesh->patches[r];
        if (!surface_counts(s->scene, rc->object))
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
        area += rc->area;
    }
    free(start);
    free(list);
    free(fill);
    (void)area;
    return err / mean;
}

typedef struct run {
    char name[48];
    uint32_t elements;
    uint64_t hemicubes;
    double seconds, mae, img;
} run;

static rn_camera cam;

static rn_image *draw(rad_solution *s, rad_elements *el)
{
    rad_error err = {0};
    rn_image *img = NULL;
    s->elements = el;
    if (rad_render_solution(s, &cam, &img, &err))
        die("render", &err);
    s->elements = NULL;
    return img;
}

/* Image MAE over the pixels showing the floor or a wall (relative). */
static double image_score(const rad_solution *s, const rn_image *a, const rn_image *ref)
{
    double err = 0, sum = 0;
    size_t npx = (size_t)ref->width * ref->height;
    for (size_t q = 0; q < npx; q++) {
        uint32_t id = ref->patch[q];
        if (id == RAD_NONE || !surface_counts(s->scene, s->mesh->patches[id].object))
            continue;
        for (uint32_t c = 0; c < ref->channels; c++) {
            err += fabs(a->pixels[q * ref->channels + c] - ref->pixels[q * ref->channels + c]);
            sum += ref->pixels[q * ref->channels + c];
        }
    }
    return err / sum;
}

static run refine(rad_solution *s, const char *name, double threshold, uint32_t levels,
                  double min_size, rad_elements **keep)
{
    rad_solve_options o = {0};
    o.refine_threshold = threshold;
    o.element_levels = levels;
    o.min_element_size = min_size;
    rad_error err = {0};
    double t0 = rad_seconds();
    if (rad_solution_refine(s, &o, &err))
        die(name, &err);
    run r = {{0}, s->elements->mesh->patch_count, s->elements->rows_computed, rad_seconds() - t0, 0, 0};
    snprintf(r.name, sizeof r.name, "%s", name);
    *keep = s->elements;
    s->elements = NULL;
    return r;
}

int main(void)
{
    rad_error err = {0};
    rad_solve_options opt = {0};
    if (getenv("BENCH_PATCH_SIZE"))
        PATCH_SIZE = atof(getenv("BENCH_PATCH_SIZE"));
    if (getenv("BENCH_REF_LEVELS"))
        REF_LEVELS = (uint32_t)atoi(getenv("BENCH_REF_LEVELS"));
    opt.mesh.patch_size = PATCH_SIZE;
    rad_solution *s = NULL;
    double t0 = rad_seconds();
    if (rad_solve_scene_file("models/cornell.rad", &opt, &s, &err))
        die("solve", &err);
    double t_solve = rad_seconds() - t0;
    printf("Cornell box, patch size %.2f m: %u patches, patch solution %.2f s (R = 128)\n",
           PATCH_SIZE, s->mesh->patch_count, t_solve);

    if (rad_camera_from_scene(s->scene, NULL, 512, 512, &cam, &err))
        die("camera", &err);
    rad_elements *ref = NULL;
    run rr = refine(s, "reference", 0, REF_LEVELS, 0, &ref);
    rn_image *ref_img = draw(s, ref);
    /* Adaptive sets stop at the depth of the finest uniform candidate. */
    double min_size = 1e300;
    for (uint32_t e = 0; e < ref->mesh->patch_count; e++) {
        const rad_patch *c = &ref->mesh->patches[e];
        for (int k = 0; k < rad_patch_corners(c); k++)
            min_size = fmin(min_size, 2.0 * rad_length(rad_sub(ref->mesh->vertices[c->v[(k + 1) % rad_patch_corners(c)]],
                                                                 ref->mesh->vertices[c->v[k]])));
    }
    printf("reference: uniform, %u splits: %u elements, %.1f s\n\n", REF_LEVELS, rr.elements,
           rr.seconds);

    enum { NA = 6 };
    const uint32_t NU = REF_LEVELS;
    static const double thresholds[NA] = {0.2, 0.1, 0.05, 0.025, 0.0125, 0.006};
    run uni[RAD_MAX_ELEMENT_LEVEL], ada[NA];
    for (uint32_t l = 0; l < NU; l++) {
        char name[48];
        snprintf(name, sizeof name, "uniform, %u splits", l);
        rad_elements *el = NULL;
        /* 0 splits: a threshold nothing exceeds keeps the patches as elements. */
        uni[l] = l ? refine(s, name, 0, l, 0, &el) : refine(s, name, 1e9, 0, 0, &el);
        uni[l].mae = score(s, el, ref);
        rn_image *img = draw(s, el);
        uni[l].img = image_score(s, img, ref_img);
        rn_image_destroy(img);
        rad_elements_destroy(el);
    }
    for (int a = 0; a < NA; a++) {
        char name[48];
        snprintf(name, sizeof name, "adaptive, T = %g", thresholds[a]);
        rad_elements *el = NULL;
        ada[a] = refine(s, name, thresholds[a], 0, min_size, &el);
        ada[a].mae = score(s, el, ref);
        rn_image *img = draw(s, el);
        ada[a].img = image_score(s, img, ref_img);
        rn_image_destroy(img);
        rad_elements_destroy(el);
    }
    for (int metric = 0; metric < 2; metric++) {
        printf("%s\n\n", metric ? "Image MAE (the rendered, interpolated radiance, 512² from the scene's camera)"
                                 : "Element MAE (piecewise-constant B at the reference element centres)");
        printf("| set | elements | hemi-cubes | time s | MAE | uniform elements for this MAE | ratio |\n");
        printf("|:--|--:|--:|--:|--:|--:|--:|\n");
        for (uint32_t l = 0; l < NU; l++)
            printf("| %s | %u | %llu | %.2f | %.4f | | |\n", uni[l].name, uni[l].elements,
                   (unsigned long long)uni[l].hemicubes, uni[l].seconds, metric ? uni[l].img : uni[l].mae);
        for (int a = 0; a < NA; a++) {
            double e = metric ? ada[a].img : ada[a].mae, need = -1;
            /* log-log interpolation of the uniform curve at this MAE */
            for (uint32_t l = 0; l + 1 < NU; l++) {
                double e0 = metric ? uni[l].img : uni[l].mae, e1 = metric ? uni[l + 1].img : uni[l + 1].mae;
                if (e <= e0 && e >= e1 && e1 > 0) {
                    double t = log(e / e0) / log(e1 / e0);
                    need = exp(log(uni[l].elements) + t * (log(uni[l + 1].elements) - log(uni[l].elements)));
                }
            }
            if (need > 0)
                printf("| %s | %u | %llu | %.2f | %.4f | %.0f | %.2f |\n", ada[a].name, ada[a].elements,
                       (unsigned long long)ada[a].hemicubes, ada[a].seconds, e, need, ada[a].elements / need);
            else
                printf("| %s | %u | %llu | %.2f | %.4f | beyond the finest uniform set | |\n", ada[a].name,
                       ada[a].elements, (unsigned long long)ada[a].hemicubes, ada[a].seconds, e);
        }
        printf("\n");
    }
    rn_image_destroy(ref_img);
    rad_elements_destroy(ref);
    rad_solution_destroy(s);
    return 0;
}
