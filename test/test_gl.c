/* test_gl.c - the hemi-cube's GL back ends (issue 38): OSMesa and EGL draw
 * the same item buffers, so every number a solve computes from them is the
 * same bit for bit; EGL that cannot start is one clear error; auto takes a
 * GPU or says why it falls back to OSMesa.
 *
 * EGL is held to Mesa's surfaceless platform (RADIOSITY_EGL_PLATFORM, a
 * test hook) over llvmpipe, the rasteriser OSMesa uses, and the drawing
 * code is one (gl.c), so any difference (a framebuffer of another format,
 * another depth convention, a state left unset by one context) shows as a
 * changed bit.  Scenes: models/cornell.rad and models/cornell.gltf at
 * coarse patch sizes with elements (patch rows, element hemi-cubes), and
 * cornell.rad with a point light added (the light's item buffers and
 * visibility).  Cost: about 6 s on 2 cores under load (six small solves).
 */
#include "../hemicube/hemicube.h"
#include "test.h"
#include "util.h"

#include <stdlib.h>
#include <string.h>

/* Solves path (its text with `extra` appended, for a polygon file) with
 * the workers' GL `gl`; NULL (message on stderr) on failure. */
static rad_solution *solve_with(const char *path, const char *extra, double patch_size,
                                hc_gl_kind gl)
{
    rad_error err = {0};
    rad_solve_options opt = {0};
    opt.mesh.patch_size = patch_size;
    opt.hemicube.resolution = 64;
    opt.hemicube.processes = 2;
    opt.hemicube.gl = gl;
    rad_solution *s = NULL;
    if (!extra) {
        if (rad_solve_scene_file(path, &opt, &s, &err))
            fprintf(stderr, "  %s (%s): %s\n", path, hc_gl_name(gl), err.message);
        return s;
    }
    char *text = NULL;
    size_t size = 0;
    FILE *f = fopen(path, "rb");
    if (f && fseek(f, 0, SEEK_END) == 0 && (size = (size_t)ftell(f)) > 0 &&
        (text = malloc(size + strlen(extra) + 1)) != NULL) {
        rewind(f);
        size = fread(text, 1, size, f);
        strcpy(text + size, extra);
    }
    if (f)
        fclose(f);
    if (!text) {
        fprintf(stderr, "  cannot read %s\n", path);
        return NULL;
    }
    s = test_solve_text(text, path, &opt);
    free(text);
    return s;
}

/* Number of arrays of a and b that differ in any bit (0 = identical):
 * every row of F (entries and values), B, the elements' B, each light's
 * power. */
static int differences(const rad_solution *a, const rad_solution *b)
{
    uint32_t n = a->mesh->patch_count, diff = 0;
    if (n != b->mesh->patch_count || a->band_count != b->band_count)
        return 1;
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t *ca, *cb;
        const float *va, *vb;
        uint32_t ka = test_row(a->F, i, 0, &ca, &va), kb = test_row(b->F, i, 1, &cb, &vb);
        diff += ka != kb || memcmp(ca, cb, ka * sizeof *ca) || memcmp(va, vb, ka * sizeof *va);
    }
    diff += memcmp(a->B, b->B, (size_t)n * a->band_count * sizeof *a->B) != 0;
    if (!a->elements != !b->elements)
        return (int)diff + 1;
    if (a->elements) {
        uint32_t m = a->elements->mesh->patch_count;
        diff += m != b->elements->mesh->patch_count ||
                memcmp(a->elements->B, b->elements->B, (size_t)m * a->band_count * sizeof(double));
    }
    for (uint32_t l = 0; l < a->scene->light_count; l++) {
        const rad_light_power *pa = &a->light_power[l], *pb = &b->light_power[l];
        diff += pa->count != pb->count || memcmp(pa->patch, pb->patch, pa->count * sizeof(uint32_t)) ||
                memcmp(pa->power, pb->power, pa->count * sizeof(float));
    }
    return (int)diff;
}

/* One scene through both back ends: the same arrays, bit for bit.  EGL
 * is held to its surfaceless platform (the test hook), llvmpipe as OSMesa
 * is, on a machine with a GPU too: a GPU rasterises by rules of its own. */
static void same_bits(const char *path, const char *extra, double patch_size)
{
    setenv("RADIOSITY_EGL_PLATFORM", "surfaceless", 1);
    rad_solution *o = solve_with(path, extra, patch_size, HC_GL_OSMESA);
    rad_solution *e = solve_with(path, extra, patch_size, HC_GL_EGL);
    CHECK(o && e);
    if (o && e) {
        uint32_t rows = o->F->rows_done, elems = o->elements ? o->elements->mesh->patch_count : 0;
        CHECK(rows > 0 && elems > o->mesh->patch_count); /* rows and element hemi-cubes were drawn */
        CHECK(o->scene->light_count == (extra ? 1u : 0u));
        int d = differences(o, e);
        CHECK_MSG(d == 0, "%s: %d arrays differ between OSMesa and EGL", path, d);
        printf("  %s%s: %u patches, %u rows, %u elements: OSMesa and EGL %s\n", path,
               extra ? " + point light" : "", o->mesh->patch_count, rows, elems,
               d ? "differ" : "identical");
    }
    rad_solution_destroy(o);
    rad_solution_destroy(e);
    unsetenv("RADIOSITY_EGL_PLATFORM");
}

/* EGL starts here (surfaceless llvmpipe without a GPU) and names its renderer. */
TEST(egl_starts)
{
    rad_error err = {0};
    hc_gl_choice c;
    CHECK(hc_gl_choose(HC_GL_EGL, &c, &err) == RAD_OK);
    CHECK(c.kind == HC_GL_EGL && c.renderer[0] != '\0' && c.reason[0] == '\0');
    printf("  EGL renderer: %s\n", c.renderer);
    CHECK(hc_gl_choose(HC_GL_OSMESA, &c, &err) == RAD_OK && c.kind == HC_GL_OSMESA);
    /* auto: a GPU (not Mesa's software rasteriser), or OSMesa with a reason */
    CHECK(hc_gl_choose(HC_GL_AUTO, &c, &err) == RAD_OK);
    CHECK((c.kind == HC_GL_EGL && !strstr(c.renderer, "llvmpipe") && c.reason[0] == '\0') ||
          (c.kind == HC_GL_OSMESA && c.reason[0] != '\0'));
    printf("  auto: %s%s%s\n", hc_gl_name(c.kind), c.reason[0] ? ", " : "", c.reason);
    CHECK(hc_gl_choose((hc_gl_kind)7, &c, &err) == RAD_ERR_USAGE);
    hc_gl_kind k = HC_GL_OSMESA;
    CHECK(hc_gl_parse("egl", &k) == 0 && k == HC_GL_EGL && !strcmp(hc_gl_name(k), "egl"));
    CHECK(hc_gl_parse("opengl", &k) == -1 && hc_gl_name((hc_gl_kind)3) == NULL);
}

TEST(cornell_rad_same_bits) { same_bits("models/cornell.rad", NULL, 0.2); }
TEST(cornell_gltf_same_bits) { same_bits("models/cornell.gltf", NULL, 0.2); }
TEST(point_light_same_bits)
{
    same_bits("models/cornell.rad", "\nlight bulb point 0.28 0.45 0.28 intensity 1\n", 0.2);
}

/* With RADIOSITY_EGL_LIBRARY naming a missing file (the test hook), EGL
 * fails with the reason, in hc_gl_choose and in hc_create, and auto falls
 * back to OSMesa with that reason. */
TEST(egl_fails_cleanly)
{
    const char *missing = "/nonexistent/libEGL-test.so.1";
    setenv("RADIOSITY_EGL_LIBRARY", missing, 1);
    rad_error err = {0};
    hc_gl_choice c;
    CHECK(hc_gl_choose(HC_GL_EGL, &c, &err) == RAD_ERR_GL);
    CHECK_MSG(strstr(err.message, "cannot load /nonexistent/libEGL-test.so.1"), "%s", err.message);
    CHECK(hc_gl_choose(HC_GL_AUTO, &c, &err) == RAD_OK);
    CHECK(c.kind == HC_GL_OSMESA && strstr(c.reason, missing));

    rad_scene *scene = NULL;
    CHECK(rad_scene_load("models/cornell.rad", NULL, &scene, &err) == RAD_OK);
    rad_mesh *m = NULL;
    rad_mesh_options mo = {.patch_size = 1.0};
    CHECK(scene && rad_mesh_build(scene, &mo, &m, &err) == RAD_OK);
    hc_engine *e = NULL;
    hc_options o = {.resolution = 16, .processes = 1, .gl = HC_GL_EGL};
    err = (rad_error){0};
    CHECK(m && hc_create(m, &o, &e, &err) == RAD_ERR_GL && e == NULL);
    CHECK_MSG(strstr(err.message, missing), "%s", err.message);
    o.gl = HC_GL_AUTO; /* settled to OSMesa: the engine starts */
    CHECK(m && hc_create(m, &o, &e, &err) == RAD_OK && e != NULL);
    hc_destroy(e);
    rad_mesh_destroy(m);
    rad_scene_destroy(scene);
    unsetenv("RADIOSITY_EGL_LIBRARY");
}

int main(void)
{
    RUN(egl_starts);
    RUN(cornell_rad_same_bits);
    RUN(cornell_gltf_same_bits);
    RUN(point_light_same_bits);
    RUN(egl_fails_cleanly);
    return test_finish("test_gl");
}
