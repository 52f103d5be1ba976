/* test_bake.c - radiosity/bake/: the baked geometry has no T-junction (no
 * vertex of a primitive inside an edge of its triangles) and covers each
 * surface exactly once per side; the automatic exposure keeps its 1 %
 * rule; the .glb's header, chunks and sizes are what the layout says; a
 * .gltf brings its .bin; an output that cannot be written leaves nothing;
 * a texture goes through the solution file and into the bake's TEXCOORD_0
 * and COLOR_0 = L / ρ̄ (test/cli/bake_texture.sh checks the files).
 * The scene: a floor under a lamp with a small shelf between them, whose
 * shadow makes refinement split some floor elements and not their
 * neighbours (the T-junctions), solved at R = 64 in about a second.
 */
#include "../radiosity/bake/bake_internal.h"
#include "test.h"
#include "util.h"

#include <sys/stat.h>
#include <unistd.h>

static const char scene_text[] =
    "bands 3\n"
    "material white reflectance 0.5 0.5 0.5\n"
    "material lamp reflectance 0 emission 10 10 10\n"
    "polygon floor white\n  0 0 0   0 0 1   1 0 1   1 0 0\nend\n"
    "polygon shelf white\n  0.3 0.5 0.3   0.6 0.5 0.3   0.6 0.5 0.6   0.3 0.5 0.6\nend\n"
    "polygon lamp lamp\n  0.4 1 0.4   0.6 1 0.4   0.6 1 0.6   0.4 1 0.6\nend\n";

static rad_solution *solved(void)
{
    static rad_solution *s;
    if (!s) {
        rad_solve_options opt = {0};
        opt.mesh.patch_size = 0.25;
        opt.hemicube.resolution = 64;
        s = test_solve_text(scene_text, "shelf.rad", &opt);
    }
    return s;
}

/* 1 when p lies strictly inside segment a-b (within 1e-9 of the line). */
static int inside_edge(const float *a, const float *b, const float *p)
{
    double ab[3], ap[3], t = 0, len2 = 0, d2 = 0;
    for (int c = 0; c < 3; c++) {
        ab[c] = (double)b[c] - a[c];
        ap[c] = (double)p[c] - a[c];
        t += ab[c] * ap[c];
        len2 += ab[c] * ab[c];
    }
    t /= len2;
    for (int c = 0; c < 3; c++)
        d2 += (ap[c] - t * ab[c]) * (ap[c] - t * ab[c]);
    return t > 1e-6 && t < 1 - 1e-6 && d2 < 1e-18;
}

/* Hanging vertices of primitive p: vertices inside one of its edges. */
static uint64_t hanging(const bk_geometry *g, const bk_prim *p)
{
    uint64_t n = 0;
    const float *V = g->position + 3 * p->first_vertex;
    for (uint64_t t = p->first_index; t < p->first_index + p->index_count; t += 3)
        for (int e = 0; e < 3; e++) {
            const float *a = V + 3 * g->index[t + e], *b = V + 3 * g->index[t + (e + 1) % 3];
            for (uint64_t v = 0; v < p->vertex_count; v++)
                n += inside_edge(a, b, V + 3 * v);
        }
    return n;
}

/* Area of primitive p's triangles facing +y and -y. */
static void facing_area(const bk_geometry *g, const bk_prim *p, double area[2])
{
    const float *V = g->position + 3 * p->first_vertex;
    area[0] = area[1] = 0;
    for (uint64_t t = p->first_index; t < p->first_index + p->index_count; t += 3) {
        const float *a = V + 3 * g->index[t], *b = V + 3 * g->index[t + 1], *c = V + 3 * g->index[t + 2];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double ny = u[2] * w[0] - u[0] * w[2];
        area[ny < 0] += fabs(ny) / 2;
    }
}

TEST(crack_free_one_sided)
{
    rad_solution *s = solved();
    CHECK(s && s->elements);
    if (!s || !s->elements)
        return;
    /* The test means something only when neighbours differ in level. */
    int lo = 99, hi = 0;
    for (uint32_t e = 0; e < s->elements->mesh->patch_count; e++)
        if (s->elements->mesh->patches[e].object == 0) {
            lo = s->elements->level[e] < lo ? s->elements->level[e] : lo;
            hi = s->elements->level[e] > hi ? s->elements->level[e] : hi;
        }
    CHECK_MSG(hi > lo, "floor levels %d..%d", lo, hi);
    /* ... so the floor's elements, as cells, have T-junctions to mend. */
    const rad_mesh *em = s->elements->mesh;
    uint64_t t_junctions = 0;
    for (uint32_t e = 0; e < em->patch_count; e++)
        for (int k = 0; k < rad_patch_corners(&em->patches[e]) && em->patches[e].object == 0; k++) {
            const rad_patch *c = &em->patches[e];
            const int n = rad_patch_corners(c);
            rad_vec3 a = em->vertices[c->v[k]], b = em->vertices[c->v[(k + 1) % n]];
            float fa[3] = {(float)a.x, (float)a.y, (float)a.z}, fb[3] = {(float)b.x, (float)b.y, (float)b.z};
            for (uint32_t v = 0; v < em->vertex_count; v++) {
                rad_vec3 p = em->vertices[v];
                float fp[3] = {(float)p.x, (float)p.y, (float)p.z};
                t_junctions += inside_edge(fa, fb, fp);
            }
        }
    CHECK_MSG(t_junctions > 0, "no T-junction among the floor's elements");
    bk_geometry g;
    rad_error err = {0};
    rad_drawing *d = NULL;
    CHECK(rad_drawing_create(s, &d, &err) == RAD_OK);
    CHECK(bk_geometry_build(s, d, 0.0, &g, &err) == RAD_OK);
    rad_drawing_destroy(d);
    CHECK(g.prim_count == 3);
    for (uint32_t k = 0; k < g.prim_count; k++) {
        const bk_prim *p = &g.prims[k];
        CHECK_MSG(hanging(&g, p) == 0, "object %u: %llu hanging vertices", p->object,
                  (unsigned long long)hanging(&g, p));
        double area[2];
        facing_area(&g, p, area);
        /* floor (1 m², facing +y), shelf (0.09 m², facing -y: its front
         * normal is (p1 - p0) × (p2 - p0), down), lamp (0.04 m², down);
         * float positions: 1e-6 */
        const double want = p->object == 0 ? 1.0 : p->object == 1 ? 0.09 : 0.04;
        CHECK_NEAR(area[p->object == 0 ? 0 : 1], want, 1e-6);
        CHECK_NEAR(area[p->object == 0 ? 1 : 0], 0.0, 1e-12);
    }
    bk_geometry_free(&g);
}

/* The rule of rad_bake_auto_exposure, checked on the drawing's cells: at
 * most 1 % of the reflecting area above 1 at EV, more than 1 % at EV +
 * 0.01 (the rounding step). */
TEST(auto_exposure_rule)
{
    rad_solution *s = solved();
    if (!s)
        return;
    double ev = 0;
    rad_error err = {0};
    CHECK(rad_bake_auto_exposure(s, &ev, &err) == RAD_OK);
    rad_drawing *d = NULL;
    CHECK(rad_drawing_create(s, &d, &err) == RAD_OK);
    const rad_mesh *rm;
    const double *vB;
    const uint32_t *patch_of;
    rad_drawing_parts(d, &rm, &vB, &patch_of);
    double total = 0, over[2] = {0, 0};
    for (uint32_t c = 0; c < rm->patch_count; c++) {
        const rad_patch *cell = &rm->patches[c];
        uint32_t p = patch_of ? patch_of[c] : c;
        if (s->emission[(size_t)p * 3] > 0)
            continue;
        double L = 0;
        for (int b = 0; b < 3; b++) {
            double sum = 0;
            for (int k = 0; k < rad_patch_corners(cell); k++)
                sum += vB[(size_t)cell->v[k] * 3 + b];
            L = fmax(L, sum / rad_patch_corners(cell) / M_PI);
        }
        total += cell->area;
        over[0] += L * exp2(ev) > 1 ? cell->area : 0;
        over[1] += L * exp2(ev + 0.01) > 1 ? cell->area : 0;
    }
    CHECK_MSG(over[0] <= 0.01 * total && over[1] > 0.01 * total, "EV %.2f: %.4f, %.4f of %.4f",
              ev, over[0], over[1], total);
    rad_drawing_destroy(d);
}

static uint32_t u32_at(const unsigned char *b) { return b[0] | b[1] << 8 | b[2] << 16 | (uint32_t)b[3] << 24; }

TEST(glb_layout)
{
    rad_solution *s = solved();
    if (!s)
        return;
    char dir[] = "/tmp/test_bake.XXXXXX", path[256], gltf[256], bin[256];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(path, sizeof path, "%s/shelf.glb", dir);
    rad_bake_stats st;
    rad_error err = {0};
    rad_bake_options opt = {.exposure_given = 1, .exposure = 1.5};
    CHECK(rad_bake_write(s, path, &opt, &st, &err) == RAD_OK);
    CHECK(st.exposure == 1.5 && st.primitives == 3);
    size_t n = 0;
    unsigned char *b = (unsigned char *)test_slurp(path, &n);
    CHECK(b && n == st.bytes && n > 28);
    if (b && n > 28) {
        uint32_t json = u32_at(b + 12);
        CHECK(!memcmp(b, "glTF", 4) && u32_at(b + 4) == 2 && u32_at(b + 8) == n);
        CHECK(json % 4 == 0 && !memcmp(b + 16, "JSON", 4) && 20 + json + 8 <= n);
        char *text = strndup((const char *)b + 20, json);
        CHECK(text && strstr(text, "\"KHR_materials_unlit\"") && strstr(text, "\"name\":\"shelf\""));
        free(text);
        /* the layout: 32 bytes a vertex, 12 a triangle */
        CHECK(u32_at(b + 20 + json) == 32 * st.vertices + 12 * st.triangles);
        CHECK(!memcmp(b + 24 + json, "BIN\0", 4));
    }
    free(b);
    unlink(path);
    snprintf(gltf, sizeof gltf, "%s/shelf.gltf", dir);
    snprintf(bin, sizeof bin, "%s/shelf.bin", dir);
    CHECK(rad_bake_write(s, gltf, &opt, &st, &err) == RAD_OK);
    struct stat sb;
    CHECK(stat(bin, &sb) == 0 && (uint64_t)sb.st_size == 32 * st.vertices + 12 * st.triangles);
    unlink(gltf);
    unlink(bin);
    CHECK(rmdir(dir) == 0); /* nothing else left: no temporaries */
}

TEST(unwritable_leaves_nothing)
{
    rad_solution *s = solved();
    if (!s)
        return;
    char dir[] = "/tmp/test_bake.XXXXXX", path[256];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(path, sizeof path, "%s/taken.gltf", dir);
    CHECK(mkdir(path, 0755) == 0); /* the JSON cannot replace a directory */
    rad_error err = {0};
    CHECK(rad_bake_write(s, path, NULL, NULL, &err) != RAD_OK);
    CHECK_MSG(strstr(err.message, path) == err.message, "%s", err.message);
    CHECK(rmdir(path) == 0);
    CHECK(rmdir(dir) == 0); /* neither taken.bin nor a temporary */
}

/* The scene's floor and shelf (both 'white') with a texture: u, v an
 * affine function of the position on each.  NULL on failure. */
static rad_solution *solved_textured(unsigned char **png, size_t *png_n)
{
    rad_scene *sc = NULL;
    rad_error err = {0};
    *png = (unsigned char *)test_slurp("test/data/real/checker.png", png_n);
    if (!*png || rad_scene_parse_polyfile(scene_text, strlen(scene_text), "shelf.rad", NULL, &sc,
                                          &err))
        return NULL;
    rad_texture t = {.material = rad_scene_find_material(sc, "white"), .image = 0,
                     .wrap_s = RAD_WRAP_CLAMP, .factor = {0.5, 0.5, 0.5, 1}};
    int rc = rad_scene_add_image(sc, "image/png", *png, *png_n, "test", NULL, &err);
    rc = rc ? rc : rad_scene_add_texture(sc, &t, "test", &err);
    for (uint32_t p = 0; p < 2 && !rc; p++) { /* floor: u = 0.5 x + 0.25, v = 0.75 z; shelf: x, z */
        double uv[8];
        for (uint32_t k = 0; k < 4; k++) {
            rad_vec3 q = sc->points[sc->polygons[p].first_point + k];
            uv[2 * k] = p ? q.x : 0.5 * q.x + 0.25;
            uv[2 * k + 1] = p ? q.z : 0.75 * q.z;
        }
        rc = rad_scene_set_polygon_uv(sc, p, uv, "test", &err);
    }
    rad_solve_options opt = {0};
    opt.mesh.patch_size = 0.25;
    opt.hemicube.resolution = 64;
    rad_solution *s = NULL;
    if (rc || rad_solve_scene(sc, &opt, &s, &err)) {
        fprintf(stderr, "  %s\n", err.message);
        return NULL;
    }
    return s;
}

/* A textured material through the solution file and into a bake: the
 * image, texture and every corner's (u, v) read back as written; every
 * vertex of the textured primitives (the elements' and fans' too) has
 * the (u, v) of its polygon's affine function, within float rounding
 * (measured 0: the functions are exact in binary); COLOR_0 = L / ρ̄ · 2^EV
 * within 1/65535 (measured 0.50/65535: the short's rounding);
 * a TEXTURES section naming an image that does not exist is refused. */
TEST(textures_through_the_file)
{
    unsigned char *png = NULL;
    size_t png_n = 0;
    rad_solution *s = solved_textured(&png, &png_n);
    CHECK(s != NULL);
    if (!s) {
        free(png);
        return;
    }
    char dir[] = "/tmp/test_bake.XXXXXX", path[256];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(path, sizeof path, "%s/tex.sol", dir);
    rad_error err = {0};
    rad_solution *r = NULL;
    CHECK_MSG(rad_solution_write(s, path, &err) == RAD_OK, "%s", err.message);
    CHECK_MSG(rad_solution_read(path, &r, &err) == RAD_OK, "%s", err.message);
    const rad_scene *a = s->scene, *b = r ? r->scene : NULL;
    CHECK(b && b->image_count == 1 && b->texture_count == 1 && b->point_uv);
    if (b && b->image_count == 1 && b->texture_count == 1 && b->point_uv) {
        CHECK(b->images[0].size == png_n && !memcmp(b->images[0].data, png, png_n));
        const rad_texture *x = &a->textures[0], *y = &b->textures[0];
        CHECK(x->material == y->material && x->image == y->image && x->texcoord == y->texcoord &&
              x->wrap_s == y->wrap_s && x->wrap_t == y->wrap_t && x->mag_filter == y->mag_filter &&
              x->min_filter == y->min_filter && !memcmp(x->factor, y->factor, sizeof x->factor));
        CHECK(!memcmp(a->point_uv, b->point_uv, 2 * sizeof(double) * a->point_count));
    }
    rad_drawing *d = NULL;
    bk_geometry g = {0};
    CHECK(r && rad_drawing_create(r, &d, &err) == RAD_OK && bk_geometry_build(r, d, 1.0, &g, &err) == RAD_OK);
    double worst = 0, cworst = 0;
    uint64_t checked = 0;
    for (uint32_t p = 0; p < g.prim_count; p++) {
        const bk_prim *pr = &g.prims[p];
        CHECK(pr->textured == (pr->material == rad_scene_find_material(b, "white")));
        for (uint64_t v = pr->first_vertex; pr->textured && v < pr->first_vertex + pr->vertex_count; v++) {
            const float *x = g.position + 3 * v, *uv = g.uv + 2 * v;
            int floor = x[1] == 0.0f;
            worst = fmax(worst, fabs(uv[0] - (floor ? 0.5 * x[0] + 0.25 : x[0])));
            worst = fmax(worst, fabs(uv[1] - (floor ? 0.75 * x[2] : x[2])));
            for (int c = 0; c < 3; c++) {
                double want = fmin(1.0, g.radiance[3 * v + c] * 2.0 / b->materials[pr->material].rho[c]);
                cworst = fmax(cworst, fabs(g.color[4 * v + c] / 65535.0 - want));
            }
            checked++;
        }
    }
    printf("  %llu textured vertices: (u, v) within %g, COLOR_0 within %.2f/65535\n",
           (unsigned long long)checked, worst, cworst * 65535);
    CHECK_MSG(checked > 50 && worst <= 1e-6 && cworst <= 1.0 / 65535,
              "%llu vertices, (u, v) off by %g, COLOR_0 by %g", (unsigned long long)checked, worst,
              cworst * 65535);
    bk_geometry_free(&g);
    rad_drawing_destroy(d);
    rad_solution_destroy(r);
    /* image index 7 in the texture record, checksums off: refused by name */
    size_t n = 0;
    unsigned char *f = (unsigned char *)test_slurp(path, &n);
    uint64_t len = 0;
    size_t at = f ? test_v6_section(f, n, "TEXR", &len) : 0;
    CHECK(at > 0 && len > png_n);
    if (at > 0 && len > png_n) {
        f[at + 4 + 4 + strlen("image/png") + 8 + png_n + 4 + 4] = 7;
        r = NULL;
        CHECK(rad_solution_parse(f, n, "bad.sol", 0, &r, &err) != RAD_OK && r == NULL);
        printf("  %s\n", err.message);
        CHECK_MSG(strstr(err.message, "bad.sol: section TEXTURES: ") == err.message &&
                      strstr(err.message, "image 7 does not exist"), "%s", err.message);
    }
    free(f);
    unlink(path);
    CHECK(rmdir(dir) == 0);
    rad_solution_destroy(s);
    free(png);
}

int main(void)
{
    RUN(crack_free_one_sided);
    RUN(auto_exposure_rule);
    RUN(glb_layout);
    RUN(unwritable_leaves_nothing);
    RUN(textures_through_the_file);
    rad_solution_destroy(solved());
    return test_finish("test_bake");
}
