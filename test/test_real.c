/* test_real.c - glTF as tools export it: the files of test/data/real/ (made
 * by tools/make_real_gltf.py) through the loader, and one of them through
 * solve and render.
 *
 * What the images hold is known from the generator's formulas, repeated
 * here: the expected means are computed independently, in double, with the
 * sRGB transfer function written out, and compared with what the loader
 * decoded.  Warnings are caught through rad_load_options.warn and checked
 * line by line: one line per kind, naming what it concerns.
 * Cost: about 1 s in release (the one solve opens the hemi-cube engine),
 * 3 s under ASan.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "../radiosity/scene/gltf_image.h"
#include "test.h"
#include "util.h"

#include <stdint.h>
#include <stdlib.h>
#include <unistd.h>

#define REAL "test/data/real/"

/* ---------------------------------------------------------------- helpers */

/* The sRGB transfer function (IEC 61966-2-1), decoded: an 8-bit code to
 * linear, written out here rather than taken from the loader. */
static double lin(int code)
{
    double c = code / 255.0;
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* checker.png: R = 16x + 8, G = 16y + 8, B = 40 or 200 by 4 × 4 blocks
 * (alpha varies, and must not count). */
static void checker_mean(double mean[3])
{
    double s[3] = {0, 0, 0};
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 16; x++) {
            s[0] += lin(16 * x + 8);
            s[1] += lin(16 * y + 8);
            s[2] += lin((x / 4 + y / 4) % 2 == 0 ? 40 : 200);
        }
    for (int b = 0; b < 3; b++)
        mean[b] = s[b] / 256.0;
}

/* bricks.jpg before compression: R = 100 + 5x, G = 80 + 4y, B = 60 + 2(x + y). */
static void bricks_mean(double mean[3])
{
    double s[3] = {0, 0, 0};
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 16; x++) {
            s[0] += lin(100 + 5 * x);
            s[1] += lin(80 + 4 * y);
            s[2] += lin(60 + 2 * (x + y));
        }
    for (int b = 0; b < 3; b++)
        mean[b] = s[b] / 256.0;
}

typedef test_warnings caught;

/* The one caught line holding every needle (NULL-terminated), or NULL. */
static const char *find_line(const caught *c, const char *const *needles)
{
    for (int i = 0; i < c->count && i < 16; i++) {
        int all = 1;
        for (const char *const *n = needles; *n; n++)
            all &= strstr(c->line[i], *n) != NULL;
        if (all)
            return c->line[i];
    }
    return NULL;
}

#define CHECK_LINE(c, ...)                                                                   \
    do {                                                                                     \
        const char *const needles_[] = {__VA_ARGS__, NULL};                                  \
        CHECK_MSG(find_line((c), needles_) != NULL, "no warning holds '%s'", needles_[0]);  \
    } while (0)

static rad_scene *load(const char *path, int strict, caught *c, rad_error *err)
{
    memset(c, 0, sizeof *c);
    memset(err, 0, sizeof *err);
    rad_load_options opt = {.warn = test_catch_warning, .warn_user = c, .strict = strict};
    rad_scene *s = NULL;
    int rc = rad_scene_load(path, &opt, &s, err);
    CHECK_MSG(strict || rc == RAD_OK, "%s", err->message);
    return rc == RAD_OK ? s : NULL;
}

/* sol written to a temporary file and read back (NULL, a check failed,
 * when either step fails); the caller owns the result. */
static rad_solution *through_file(const rad_solution *sol)
{
    char path[] = "/tmp/test_real_XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd < 0)
        return NULL;
    close(fd);
    rad_error err = {0};
    rad_solution *back = NULL;
    CHECK_MSG(rad_solution_write(sol, path, &err) == RAD_OK, "%s", err.message);
    CHECK_MSG(rad_solution_read(path, &back, &err) == RAD_OK, "%s", err.message);
    unlink(path);
    return back;
}

static uint32_t material(const rad_scene *s, const char *name)
{
    uint32_t m = rad_scene_find_material(s, name);
    CHECK_MSG(m != RAD_NONE, "no material '%s'", name);
    return m;
}

/* ------------------------------------------------------------------ tests */

/* A floor material with only a baseColorTexture takes the PNG's mean; a
 * wall at factor 0.8 takes 0.8 × the JPEG's mean; a lamp's emissive
 * texture scales its emission. */
TEST(textures_average)
{
    caught c;
    rad_error err;
    rad_scene *s = load(REAL "textured.gltf", 0, &c, &err);
    if (!s)
        return;
    double png[3], jpg[3];
    checker_mean(png);
    bricks_mean(jpg);
    const rad_material *floor = &s->materials[material(s, "checker floor")];
    const rad_material *wall = &s->materials[material(s, "bricks")];
    const rad_material *lamp = &s->materials[material(s, "lamp")];
    for (int b = 0; b < 3; b++) {
        /* PNG is lossless: the same numbers summed in another order
         * (measured difference 2.2e-16, 2.2e-16, 4.4e-16). */
        CHECK_NEAR(floor->rho[b], png[b], 2e-15);
        /* JPEG (4:2:0, quantisers 2 and 3) loses a little: measured
         * |decoded − source| of the mean 3.6e-4, 2.8e-4, 1.8e-4 (R, G, B),
         * of means 0.26, 0.16 and 0.10. */
        CHECK_NEAR(wall->rho[b] / 0.8, jpg[b], 1e-3);
        CHECK_NEAR(lamp->rho[b], 0.0, 0.0);
    }
    /* E = π × emissiveFactor 1 × emissiveStrength 4 × mean of a flat
     * (255, 230, 200) image: exact but for the pow */
    static const int glow[3] = {255, 230, 200};
    for (int b = 0; b < 3; b++)
        CHECK_NEAR(lamp->emission[b], M_PI * 4.0 * lin(glow[b]), 1e-12);
    /* no polygon has a ρ of its own (no vertex colours) */
    CHECK(s->polygon_rho == NULL);

    CHECK_MSG(c.count == 4, "%d warning lines", c.count);
    CHECK_LINE(&c, "meshes 'floor', 'wall': primitives without the TEXCOORD set of their "
                   "baseColorTexture");
    CHECK_LINE(&c, REAL "textured.gltf: ", "extensions KHR_texture_transform, "
                                          "KHR_materials_specular: ignored");
    CHECK_LINE(&c, "materials 'checker floor', 'bricks', 'lamp': texture coordinates ignored");
    CHECK_LINE(&c, "material 'checker floor': normal, occlusion and metallic-roughness");
    rad_scene_destroy(s);

    /* --strict takes textures as they are: nothing here needs repair */
    s = load(REAL "textured.gltf", 1, &c, &err);
    CHECK_MSG(s != NULL, "%s", err.message);
    rad_scene_destroy(s);
}

/* COLOR_0: each polygon's ρ is the material's (glTF's white, 1) times the
 * mean of its triangles' vertex colours; the quad whose corners are all
 * white reaches 1 and is clamped.  The wall's texture sits in the .glb's
 * BIN chunk. */
TEST(vertex_colors_glb)
{
    caught c;
    rad_error err;
    rad_scene *s = load(REAL "vertex-colors.glb", 0, &c, &err);
    if (!s)
        return;
    static const int grid[9][3] = {{255, 255, 255}, {255, 255, 255}, {200, 40, 40},
                                   {255, 255, 255}, {255, 255, 255}, {40, 200, 40},
                                   {40, 40, 200},   {120, 120, 120}, {10, 10, 10}};
    uint32_t fl = rad_scene_find_object(s, "floor"), quads = 0;
    CHECK(fl != RAD_NONE && s->polygon_rho != NULL);
    for (uint32_t p = 0; fl != RAD_NONE && s->polygon_rho && p < s->polygon_count; p++) {
        const rad_polygon *pg = &s->polygons[p];
        if (pg->object != fl)
            continue;
        CHECK(pg->point_count == 4); /* each cell's two triangles merged */
        rad_vec3 ctr = rad_v3(0, 0, 0);
        for (uint32_t k = 0; k < pg->point_count; k++)
            ctr = rad_add(ctr, rad_scale(s->points[pg->first_point + k], 0.25));
        /* cell with corner a = 3z + x at (-1 + x, 0, 1 - z); its triangles
         * (a, a+1, a+4) and (a, a+4, a+3) as the generator wrote them */
        int x = (int)floor(ctr.x + 1.0), z = (int)floor(1.0 - ctr.z), a = 3 * z + x;
        const double *rho = rad_polygon_rho(s, p);
        for (int b = 0; b < 3; b++) {
            double t1 = (grid[a][b] + grid[a + 1][b] + grid[a + 4][b]) / (3.0 * 255.0);
            double t2 = (grid[a][b] + grid[a + 4][b] + grid[a + 3][b]) / (3.0 * 255.0);
            double want = 0.5 * (t1 + t2);
            if (want >= 1.0)
                want = 0.95;
            CHECK_NEAR(rho[b], want, 1e-12); /* arithmetic only */
        }
        quads++;
    }
    CHECK_MSG(quads == 4, "%u floor quads", quads);
    double png[3];
    checker_mean(png);
    const rad_material *label = &s->materials[material(s, "label")];
    for (int b = 0; b < 3; b++)
        CHECK_NEAR(label->rho[b], 0.5 * png[b], 2e-15); /* lossless, as above */
    CHECK_MSG(c.count == 3, "%d warning lines", c.count);
    CHECK_LINE(&c, "primitives without the TEXCOORD set of their baseColorTexture");
    CHECK_LINE(&c, "material 'painted': reflectance >= 1 clamped to 0.95");
    CHECK_LINE(&c, "material 'label': texture coordinates ignored");
    rad_scene_destroy(s);

    /* --strict: the plain white material is refused, as before textures */
    s = load(REAL "vertex-colors.glb", 1, &c, &err);
    CHECK(s == NULL);
    CHECK_MSG(strstr(err.message, "material 'painted': baseColorFactor 1 is not a reflectance "
                                  "below 1") != NULL,
              "%s", err.message);
    CHECK(c.count == 0); /* a failed load says only why */
}

/* The solution keeps what the solve uses: each patch takes its polygon's
 * ρ (vertex colours), PATCHDATA carries it through the file, and a relight
 * `--reflectance MATERIAL=v` sets every patch of the material to v,
 * replacing the colours (the scene keeps the nominal material). */
TEST(solution_keeps_polygon_rho)
{
    caught c;
    rad_error err;
    rad_scene *s = load(REAL "vertex-colors.glb", 0, &c, &err);
    if (!s)
        return;
    rad_mesh_options mo = {.patch_size = 0.5};
    rad_mesh *m = NULL;
    rad_solution *sol = NULL;
    if (rad_mesh_build(s, &mo, &m, &err) || rad_solution_create(s, m, &sol, &err)) {
        CHECK_MSG(0, "%s", err.message);
        return;
    }
    uint32_t painted = rad_scene_find_material(sol->scene, "painted"), n = 0;
    for (uint32_t i = 0; i < sol->mesh->patch_count; i++) {
        const rad_patch *pa = &sol->mesh->patches[i];
        const double *want = rad_polygon_rho(sol->scene, pa->polygon);
        for (int b = 0; b < 3; b++)
            CHECK(sol->rho[(size_t)i * 3 + b] == want[b]);
        n += pa->material == painted;
    }
    CHECK(n >= 4);
    rad_solution *back = through_file(sol);
    if (back) {
        CHECK(back->mesh->patch_count == sol->mesh->patch_count);
        for (size_t k = 0; k < (size_t)sol->mesh->patch_count * 3; k++)
            CHECK(back->rho[k] == sol->rho[k]);
        rad_edit e;
        CHECK(rad_edit_parse(RAD_EDIT_REFLECTANCE, "painted=0.4", &e, &err) == RAD_OK);
        CHECK_MSG(rad_solution_apply_edits(back, &e, 1, &err) == RAD_OK, "%s", err.message);
        for (uint32_t i = 0; i < back->mesh->patch_count; i++) {
            int mine = back->mesh->patches[i].material == painted;
            for (int b = 0; b < 3; b++)
                CHECK(back->rho[(size_t)i * 3 + b] ==
                      (mine ? 0.4 : sol->rho[(size_t)i * 3 + b]));
        }
    }
    rad_solution_destroy(back);
    rad_solution_destroy(sol);
}

/* A primitive without a material gets glTF's default (white, clamped to
 * 0.95); loose edges are skipped; what a diffuse scene ignores is named. */
TEST(defaults_and_ignored)
{
    caught c;
    rad_error err;
    rad_scene *s = load(REAL "no-material.gltf", 0, &c, &err);
    if (!s)
        return;
    const rad_material *def = &s->materials[material(s, "default")];
    for (int b = 0; b < 3; b++)
        CHECK_NEAR(def->rho[b], 0.95, 0.0);
    uint32_t fl = rad_scene_find_object(s, "floor");
    uint32_t n = 0;
    for (uint32_t p = 0; p < s->polygon_count; p++)
        n += s->polygons[p].object == fl;
    CHECK_MSG(n == 1, "floor has %u polygons (the quad; the LINES primitive adds none)", n);
    CHECK(rad_scene_find_light(s, "bulb") != RAD_NONE);
    CHECK_MSG(c.count == 5, "%d warning lines", c.count);
    CHECK_LINE(&c, "mesh 'floor': primitives without a material get glTF's default material");
    CHECK_LINE(&c, "mesh 'floor' (LINES): primitives without area (points, lines) skipped");
    CHECK_LINE(&c, "material 'gold': metallicFactor drawn by render --gather only");
    CHECK_LINE(&c, "material 'leaf' (MASK): alphaMode ignored");
    CHECK_LINE(&c, "light 'bulb': range ignored");
    rad_scene_destroy(s);

    s = load(REAL "no-material.gltf", 1, &c, &err);
    CHECK(s == NULL);
    CHECK_MSG(strstr(err.message, "mesh 'floor' primitive 0: no material") != NULL, "%s",
              err.message);
}

/* A JPEG whose Huffman table claims more than 256 symbols (16 counts of
 * 255) is refused with a reason before the decoder sees it: Debian's
 * stb_image would write past its table (the fuzz target found it; its input
 * is replayed from test/fuzz/regressions/gltf).  The same table with 16
 * symbols passes the check and fails later, as a truncated image. */
TEST(jpeg_huffman_overflow)
{
    unsigned char jpg[2 + 4 + 17 + 4];
    size_t k = 0;
    jpg[k++] = 0xFF, jpg[k++] = 0xD8;                         /* SOI */
    jpg[k++] = 0xFF, jpg[k++] = 0xC4, jpg[k++] = 0, jpg[k++] = 19; /* DHT, 17 bytes */
    jpg[k++] = 0x00;                                          /* DC table 0 */
    for (int i = 0; i < 16; i++)
        jpg[k++] = 255;
    jpg[k++] = 0xFF, jpg[k++] = 0xD9, jpg[k++] = 0, jpg[k++] = 0; /* EOI */
    double mean[3];
    char why[256] = "";
    CHECK(rad_gltf_image_mean(jpg, k, 1u << 20, mean, why, sizeof why) == -1);
    CHECK_MSG(strstr(why, "Huffman table of more than 256 symbols") != NULL, "%s", why);
    for (int i = 0; i < 16; i++)
        jpg[7 + i] = i == 0 ? 16 : 0;
    why[0] = '\0';
    CHECK(rad_gltf_image_mean(jpg, k, 1u << 20, mean, why, sizeof why) == -1);
    CHECK_MSG(strstr(why, "Huffman") == NULL && why[0] != '\0', "%s", why);
}

/* An orthographic camera from above: it survives the solution file, and
 * the image shows the floor where the projection puts it, at the radiance
 * of a floor under a sun of 1 W/m² per band. */
TEST(orthographic_render)
{
    caught c;
    rad_error err;
    rad_scene *s = load(REAL "ortho.gltf", 0, &c, &err);
    if (!s)
        return;
    CHECK(c.count == 1);
    CHECK_LINE(&c, "extensions KHR_materials_transmission, KHR_materials_volume: ignored");
    uint32_t k = rad_scene_find_camera(s, "plan");
    CHECK(k != RAD_NONE);
    if (k == RAD_NONE) {
        rad_scene_destroy(s);
        return;
    }
    const rad_camera *cam = &s->cameras[k];
    CHECK(cam->orthographic && cam->xmag == 1.5 && cam->ymag == 1.5);
    CHECK_NEAR(cam->eye.y, 5.0, 1e-12);
    CHECK_NEAR(cam->target.y, 4.0, 1e-12); /* one unit along the view, straight down */

    rad_solve_options opt = {.refine_threshold = RAD_REFINE_OFF}; /* patches only */
    opt.mesh.patch_size = 0.5;
    rad_solution *sol = NULL;
    if (rad_solve_scene(s, &opt, &sol, &err)) {
        CHECK_MSG(0, "%s", err.message);
        return;
    }
    /* through the file: the CAMS section keeps the projection */
    rad_solution *back = through_file(sol);
    rad_solution_destroy(sol);
    if (!back)
        return;
    const rad_camera *bc = &back->scene->cameras[0];
    CHECK(bc->orthographic && bc->xmag == 1.5 && bc->ymag == 1.5);

    /* 96 × 96 pixels over 3 × 3 units: 32 pixels per unit, the floor's
     * edges x = ±1 at columns 48 ∓ 32 = 16 and 80, its halves meeting at
     * column 48; rows alike (the camera's up is -z). */
    rn_camera rc;
    rn_image *img = NULL;
    CHECK(rad_camera_from_scene(back->scene, "plan", 96, 96, &rc, &err) == RAD_OK);
    CHECK(rc.orthographic == 1 && rc.ymag == 1.5);
    CHECK_MSG(rad_render_solution(back, &rc, &img, &err) == RAD_OK, "%s", err.message);
    if (img) {
        const float *px = img->pixels;
        uint32_t w = img->width;
#define PX(i, j) px[((size_t)(j) * w + (i)) * 3]
        CHECK(img->patch[48 * w + 15] == RAD_NONE && img->patch[48 * w + 16] != RAD_NONE);
        CHECK(img->patch[48 * w + 79] != RAD_NONE && img->patch[48 * w + 80] == RAD_NONE);
        CHECK(img->patch[15 * w + 48] == RAD_NONE && img->patch[16 * w + 48] != RAD_NONE);
        CHECK(img->patch[79 * w + 48] != RAD_NONE && img->patch[80 * w + 48] == RAD_NONE);
        /* L = ρ E⊥ / π on the coplanar halves (no light passes between
         * them), E⊥ = 683 lux / 683 lm/W = 1.  The sun's power reaches
         * each patch through the light's item buffer, whose pixel counts
         * err by a few tenths of a percent per patch (measured 0.44 % on
         * the pixel at column 30); their mean over a half is what the
         * method answers for: measured 5.2e-4 below ρ/π on both halves. */
        double sum[2] = {0, 0};
        uint32_t cnt[2] = {0, 0};
        for (uint32_t j = 17; j < 79; j++)
            for (uint32_t i = 17; i < 79; i++) {
                if (i == 47 || i == 48)
                    continue; /* where the halves meet, interpolation mixes nothing but
                               * rounding decides the owner */
                int h = i >= 48;
                sum[h] += PX(i, j);
                cnt[h]++;
            }
        CHECK_REL(sum[0] / cnt[0], 0.2 / M_PI, 1.5e-3);
        CHECK_REL(sum[1] / cnt[1], 0.8 / M_PI, 1.5e-3);
        CHECK(PX(47, 48) < PX(48, 48)); /* dark left of x = 0, light right */
#undef PX
    }
    rn_image_destroy(img);
    rad_solution_destroy(back);
}

int main(void)
{
    RUN(textures_average);
    RUN(vertex_colors_glb);
    RUN(solution_keeps_polygon_rho);
    RUN(defaults_and_ignored);
    RUN(orthographic_render);
    RUN(jpeg_huffman_overflow);
    return test_finish("test_real");
}
