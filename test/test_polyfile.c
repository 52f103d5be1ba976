/* test_polyfile.c - the polygon-file parser (polyfile.c), the file loader
 * (load.c) and the bundled Cornell box (models/cornell.rad). */
#include "../radiosity/scene/scene.h"
#include "test.h"

#include <stdint.h>
#include <unistd.h>

static int parse(const char *text, rad_scene **s, rad_error *e)
{
    return rad_scene_parse_polyfile(text, strlen(text), "room.rad", NULL, s, e);
}

/* Parses text that must fail; checks the code and that the message
 * contains want.  Returns 1 if both hold. */
static int refuses(const char *text, int code, const char *want)
{
    rad_scene *s = (rad_scene *)1;
    rad_error e = {0};
    int rc = parse(text, &s, &e);
    int ok = rc == code && s == NULL && strstr(e.message, want) != NULL;
    if (!ok)
        fprintf(stderr, "    got %d (%s) \"%s\", wanted %d \"%s\"\n", rc, rad_result_name(rc),
                e.message, code, want);
    if (rc == RAD_OK)
        rad_scene_destroy(s);
    return ok;
}

static const char *GOOD =
    "# a small lit room\n"
    "bands 3 names R G B   # three bands\n"
    "material wall reflectance 0.5 0.6 0.7\n"
    "material lamp emission 10 # one value: every band\n"
    "   reflectance 0.1\n"
    "material glass reflectance 0.1 transmittance 0.2 0.3 0.4\n"
    "polygon floor wall\n"
    "  0 0 0   0 0 1   1 0 1   1 0 0\n"
    "end\n"
    "polygon light lamp subdivide 3\n"
    "  0.4 0.99 0.4  0.6 0.99 0.4  0.6 0.99 0.6  0.4 0.99 0.6 end\n"
    "polygon pane glass subdivide 2 5 0 0 0  1 0 0  1 1 0 end\n"
    "group box\n"
    "  polygon top wall 0 0.5 0  0 0.5 0.2  0.2 0.5 0.2 end\n"
    "  polygon side wall 0 0 0  0.2 0 0  0.2 0.5 0 0 0.5 0 end\n"
    "end\n"
    "camera front eye 0.5 0.5 -1 target 0.5 0.5 0 up 0 1 0 fov 45\n"
    "camera side eye -1 0.5 0.5 target 0 0.5 0.5 up 0 1 0 fov 30.5\n"
    "camera plan eye 0.5 2 0.5 target 0.5 0 0.5 up 0 0 1 ortho 0.75\n";

TEST(good_file)
{
    rad_scene *s = NULL;
    rad_error e = {0};
    CHECK_MSG(parse(GOOD, &s, &e) == RAD_OK, "%s", e.message);
    if (!s)
        return;
    CHECK(strcmp(s->source, "room.rad") == 0);
    CHECK(s->band_count == 3);
    CHECK(s->band_names[0] && strcmp(s->band_names[0], "R") == 0);
    CHECK(s->band_names[2] && strcmp(s->band_names[2], "B") == 0);
    CHECK(s->material_count == 3);
    CHECK(s->polygon_count == 5);
    CHECK(s->object_count == 4); /* floor, light, pane, box */
    CHECK(s->camera_count == 3);
    CHECK(s->point_count == 4 + 4 + 3 + 3 + 4);

    uint32_t wall = rad_scene_find_material(s, "wall"), lamp = rad_scene_find_material(s, "lamp"),
             glass = rad_scene_find_material(s, "glass");
    CHECK(wall == 0 && lamp == 1 && glass == 2);
    /* values as typed: exact decimal-to-double conversions */
    CHECK(s->materials[wall].rho[0] == 0.5 && s->materials[wall].rho[1] == 0.6 &&
          s->materials[wall].rho[2] == 0.7);
    CHECK(s->materials[wall].emission[0] == 0 && s->materials[wall].transmit[2] == 0);
    CHECK(s->materials[lamp].emission[0] == 10 && s->materials[lamp].emission[1] == 10 &&
          s->materials[lamp].emission[2] == 10);
    CHECK(s->materials[lamp].rho[0] == 0.1 && s->materials[lamp].rho[2] == 0.1);
    CHECK(s->materials[glass].transmit[0] == 0.2 && s->materials[glass].transmit[2] == 0.4);

    /* a polygon outside a group is its own object, named after it */
    uint32_t floor_obj = rad_scene_find_object(s, "floor");
    CHECK(floor_obj != RAD_NONE && s->polygons[0].object == floor_obj);
    CHECK(strcmp(s->polygons[0].name, "floor") == 0);
    /* floor wound counter-clockwise seen from above: normal +y, area 1 */
    CHECK(s->polygons[0].normal.y == 1.0);
    CHECK(s->polygons[0].area == 1.0);
    CHECK(s->polygons[0].subdiv_u == 0 && s->polygons[0].subdiv_v == 0);
    /* subdivide with one value: both directions; with two: u then v */
    CHECK(s->polygons[1].subdiv_u == 3 && s->polygons[1].subdiv_v == 3);
    CHECK(s->polygons[1].material == lamp);
    CHECK(s->polygons[2].subdiv_u == 2 && s->polygons[2].subdiv_v == 5);
    CHECK(s->polygons[2].point_count == 3);
    CHECK(s->points[s->polygons[2].first_point + 1].x == 1.0);
    /* the group is one object of two polygons */
    uint32_t box = rad_scene_find_object(s, "box");
    CHECK(box != RAD_NONE && s->polygons[3].object == box && s->polygons[4].object == box);
    CHECK(rad_scene_find_object(s, "top") == RAD_NONE);
    CHECK(strcmp(s->polygons[4].name, "side") == 0);

    uint32_t cam = rad_scene_find_camera(s, "side");
    CHECK(cam == 1);
    CHECK(s->cameras[cam].eye.x == -1 && s->cameras[cam].target.z == 0.5 &&
          s->cameras[cam].up.y == 1 && s->cameras[cam].yfov_deg == 30.5);
    CHECK(s->cameras[0].aspect == 0.0 && !s->cameras[0].orthographic);
    uint32_t plan = rad_scene_find_camera(s, "plan");
    CHECK(plan == 2 && s->cameras[plan].orthographic && s->cameras[plan].ymag == 0.75 &&
          s->cameras[plan].xmag == 0.75);
    CHECK(rad_scene_validate(s, &e) == RAD_OK);
    rad_scene_destroy(s);
}

TEST(grey_file_and_crlf)
{
    rad_scene *s = NULL;
    rad_error e = {0};
    const char *t = "bands 1\r\nmaterial m emission 1\r\npolygon p m\r\n0 0 0 1 0 0 0 1 0\r\nend";
    CHECK_MSG(parse(t, &s, &e) == RAD_OK, "%s", e.message);
    CHECK(s && s->band_count == 1 && s->band_names[0] == NULL && s->polygon_count == 1);
    rad_scene_destroy(s);
    /* the line count survives CRLF: an error on line 3 */
    CHECK(refuses("bands 1\r\nmaterial m emission 1\r\nbogus", RAD_ERR_PARSE,
                  "room.rad: line 3: unknown statement 'bogus'"));
}

TEST(header_errors)
{
    CHECK(refuses("", RAD_ERR_PARSE, "room.rad: line 1: empty file: expected 'bands' first"));
    CHECK(refuses("# only a comment\n\n", RAD_ERR_PARSE, "room.rad: line 1: empty file"));
    CHECK(refuses("\nmaterial m reflectance 0.5", RAD_ERR_PARSE,
                  "room.rad: line 2: expected 'bands' first"));
    CHECK(refuses("bands 0", RAD_ERR_PARSE, "room.rad: line 1: bands 0: expected a whole number"));
    CHECK(refuses("bands 17", RAD_ERR_PARSE, "line 1: bands 17"));
    CHECK(refuses("bands 2.5", RAD_ERR_PARSE, "line 1: bands 2.5"));
    CHECK(refuses("bands\n\nx", RAD_ERR_PARSE, "room.rad: line 3: expected the number of bands"));
    CHECK(refuses("bands", RAD_ERR_PARSE, "line 1: expected the number of bands, found end"));
    CHECK(refuses("bands 3 names R G", RAD_ERR_PARSE, "expected the name of band 2"));
    CHECK(refuses("Bands 3", RAD_ERR_PARSE, "expected 'bands' first"));
}

/* A prefix common to many of the malformed inputs below (3 lines). */
#define HEAD "bands 3\nmaterial w reflectance 0.5\nmaterial l emission 1\n"

TEST(material_errors)
{
    CHECK(refuses(HEAD "material x reflectance 0.1 0.2\n", RAD_ERR_PARSE,
                  "room.rad: line 4: material 'x': reflectance: 2 values, give 1 (all bands) or 3"));
    CHECK(refuses(HEAD "material x\n  emission 1 2 3 4\n", RAD_ERR_PARSE,
                  "room.rad: line 5: material 'x': emission: more than 3 values"));
    CHECK(refuses(HEAD "material x reflectance\n polygon", RAD_ERR_PARSE,
                  "line 4: material 'x': reflectance: 0 values"));
    CHECK(refuses(HEAD "material x reflectance 0.5 nan 0.5\n", RAD_ERR_PARSE,
                  "line 4: material 'x': reflectance 'nan' is not a finite number"));
    CHECK(refuses(HEAD "material x emission 1e999\n", RAD_ERR_PARSE,
                  "line 4: material 'x': emission '1e999' is not a finite number"));
    CHECK(refuses(HEAD "material x\n\ncolour 1\n", RAD_ERR_PARSE,
                  "room.rad: line 6: material 'x': expected reflectance, emission, "
                  "transmittance, metallic or roughness, found 'colour'"));
    CHECK(refuses(HEAD "material x reflectance 0.5 metallic 2\n", RAD_ERR_INVALID,
                  "room.rad: line 4: material 'x': metallic 2 outside [0, 1]"));
    CHECK(refuses(HEAD "material x reflectance 0.1\n reflectance 0.2", RAD_ERR_PARSE,
                  "room.rad: line 5: material 'x': reflectance given twice"));
    CHECK(refuses(HEAD "material x reflectance 0.5 1.2 0.5\n", RAD_ERR_INVALID,
                  "room.rad: line 4: material 'x': reflectance 1.2 outside [0, 1) in band 1"));
    CHECK(refuses(HEAD "material w reflectance 0.2\n", RAD_ERR_INVALID,
                  "room.rad: line 4: material 'w': a material of this name already exists"));
    CHECK(refuses(HEAD "material", RAD_ERR_PARSE,
                  "line 4: expected a material name, found end of file"));
}

TEST(polygon_errors)
{
    CHECK(refuses(HEAD "\npolygon floor w 0 0 0 1 0 0 end\n", RAD_ERR_INVALID,
                  "room.rad: line 5: polygon 'floor': 2 points, a polygon needs at least 3"));
    CHECK(refuses(HEAD "polygon p nosuch 0 0 0 1 0 0 0 1 0 end\n", RAD_ERR_INVALID,
                  "room.rad: line 4: polygon 'p': unknown material 'nosuch'"));
    /* materials must come before their use */
    CHECK(refuses(HEAD "polygon p late 0 0 0 1 0 0 0 1 0 end\nmaterial late reflectance 0\n",
                  RAD_ERR_INVALID, "line 4: polygon 'p': unknown material 'late'"));
    CHECK(refuses(HEAD "polygon p w 0 0 0 1 0 0 0 1 end\n", RAD_ERR_PARSE,
                  "line 4: polygon 'p': 8 numbers do not make whole points"));
    CHECK(refuses(HEAD "polygon p w\n 0 0 0\n 1 0 x\n 0 1 0 end\n", RAD_ERR_PARSE,
                  "room.rad: line 6: polygon 'p' (line 4): expected a coordinate or 'end', "
                  "found 'x'"));
    CHECK(refuses(HEAD "polygon p w 0 0 0 1 0 inf 0 1 0 end\n", RAD_ERR_PARSE,
                  "line 4: polygon 'p': 'inf' is not a finite number"));
    CHECK(refuses(HEAD "polygon p w\n0 0 0 1 0 0 0 1 0\n\n", RAD_ERR_PARSE,
                  "room.rad: line 4: polygon 'p' is not terminated: 'end' missing"));
    /* a forgotten 'end' shows at the next statement */
    CHECK(refuses(HEAD "polygon p w 0 0 0 1 0 0 0 1 0\npolygon q w 0 0 0 1 0 0 0 1 0 end\n",
                  RAD_ERR_PARSE, "line 5: polygon 'p' (line 4): expected a coordinate or 'end', "
                                 "found 'polygon'"));
    CHECK(refuses(HEAD "polygon p w 0 0 0 1 0 0 0 1 0 end\npolygon p w 0 0 1 1 0 1 0 1 1 end\n",
                  RAD_ERR_INVALID,
                  "room.rad: line 5: polygon 'p': a polygon of this name already exists"));
    CHECK(refuses(HEAD "polygon p w subdivide 0 0 0 0 1 0 0 0 1 0 end\n", RAD_ERR_PARSE,
                  "line 4: polygon 'p': subdivide 0: expected a whole number"));
    CHECK(refuses(HEAD "polygon p w subdivide 2.5 0 0 0 1 0 0 0 1 0 end\n", RAD_ERR_PARSE,
                  "polygon 'p': subdivide 2.5"));
    CHECK(refuses(HEAD "polygon p w subdivide 0 0 0 1 0 0 0 1 0 end\n", RAD_ERR_PARSE,
                  "line 4: polygon 'p': 'subdivide' needs 1 or 2 whole numbers"));
    CHECK(refuses(HEAD "polygon p w 0 0 0 1 1 0 1 0 0 0 1 0 end\n", RAD_ERR_INVALID,
                  "room.rad: line 4: polygon 'p': not convex"));
    CHECK(refuses(HEAD "polygon p w 0 0 0 1 0 0 2 0 0 end\n", RAD_ERR_INVALID,
                  "room.rad: line 4: polygon 'p': zero area"));
    CHECK(refuses(HEAD "polygon p w 0 0 0 1 0 0 1 1 0.5 0 1 0 end\n", RAD_ERR_INVALID,
                  "room.rad: line 4: polygon 'p': not planar"));
    CHECK(refuses(HEAD "polygon", RAD_ERR_PARSE, "line 4: expected a polygon name"));
    CHECK(refuses(HEAD "polygon p", RAD_ERR_PARSE, "line 4: expected a material name"));
}

TEST(group_errors)
{
    CHECK(refuses(HEAD "group g\n polygon a w 0 0 0 1 0 0 0 1 0 end\n", RAD_ERR_PARSE,
                  "room.rad: line 4: group 'g' is not terminated: 'end' missing"));
    CHECK(refuses(HEAD "group g\nend\n", RAD_ERR_PARSE, "line 4: group 'g' has no polygons"));
    CHECK(refuses(HEAD "group g\n group h\n", RAD_ERR_PARSE,
                  "room.rad: line 5: group 'g' (line 4): expected 'polygon' or 'end', found "
                  "'group'"));
    /* polygon names are unique across groups too */
    CHECK(refuses(HEAD "group g polygon a w 0 0 0 1 0 0 0 1 0 end end\n"
                       "group h\n polygon a w 0 0 1 1 0 1 0 1 1 end end\n",
                  RAD_ERR_INVALID, "line 6: polygon 'a': a polygon of this name already exists"));
    /* a lone polygon is an object named after itself: it cannot share a group's name */
    CHECK(refuses(HEAD "group g polygon a w 0 0 0 1 0 0 0 1 0 end end\n"
                       "polygon g w 0 0 1 1 0 1 0 1 1 end\n",
                  RAD_ERR_INVALID, "line 5: object 'g': an object of this name already exists"));
    CHECK(refuses(HEAD "group g polygon a w 0 0 0 1 0 0 0 1 0 end end\ngroup g\n", RAD_ERR_INVALID,
                  "line 5: object 'g': an object of this name already exists"));
}

TEST(camera_errors)
{
    CHECK(refuses(HEAD "camera c eye 0 0 0 target 0 0 1 up 0 1 0\n", RAD_ERR_PARSE,
                  "line 4: camera 'c': expected 'fov', found end of file"));
    CHECK(refuses(HEAD "camera c eye 0 0 0 up 0 1 0 target 0 0 1 fov 40\n", RAD_ERR_PARSE,
                  "line 4: camera 'c': expected 'target', found 'up'"));
    CHECK(refuses(HEAD "camera c eye 0 0\n target", RAD_ERR_PARSE,
                  "room.rad: line 5: expected eye z, found 'target'"));
    CHECK(refuses(HEAD "camera c eye 0 0 0 target 0 0 0 up 0 1 0 fov 40\n", RAD_ERR_INVALID,
                  "room.rad: line 4: camera 'c': eye and target coincide"));
    CHECK(refuses(HEAD "camera c eye 0 0 0 target 0 0 1 up 0 1 0 fov 200\n", RAD_ERR_INVALID,
                  "line 4: camera 'c': fov 200 degrees outside (0, 180)"));
    CHECK(refuses(HEAD "camera c eye 0 0 0 target 0 0 1 up 0 1 0 fov 40\n"
                       "camera c eye 0 0 0 target 0 0 1 up 0 1 0 fov 40\n",
                  RAD_ERR_INVALID, "line 5: camera 'c': a camera of this name already exists"));
    CHECK(refuses(HEAD "camera c eye 0 0 0 target 0 0 1 up 0 1 0 ortho -2\n", RAD_ERR_INVALID,
                  "line 4: camera 'c': orthographic half-sizes -2 × -2 must be finite and > 0"));
    CHECK(refuses(HEAD "camera c eye 0 0 0 target 0 0 1 up 0 1 0 ortho\n", RAD_ERR_PARSE,
                  "expected ortho (half-height), found end of file"));
}

TEST(lexical_errors)
{
    static const char nul[] = "bands 1\nmaterial m\0 emission 1\n";
    rad_scene *s = NULL;
    rad_error e = {0};
    CHECK(rad_scene_parse_polyfile(nul, sizeof nul - 1, "room.rad", NULL, &s, &e) ==
          RAD_ERR_PARSE);
    CHECK_MSG(strstr(e.message, "room.rad: line 2: NUL byte") != NULL, "%s", e.message);
    CHECK(s == NULL);

    size_t n = 6000;
    char *big = malloc(n + 20);
    CHECK(big != NULL);
    if (!big)
        return;
    memcpy(big, "bands 1\n", 8);
    memset(big + 8, 'a', n);
    CHECK(rad_scene_parse_polyfile(big, n + 8, "room.rad", NULL, &s, &e) == RAD_ERR_PARSE);
    CHECK_MSG(strstr(e.message, "room.rad: line 2: a word longer than 4095 characters") != NULL,
              "%s", e.message);
    free(big);
    CHECK(refuses(HEAD "Polygon p w 0 0 0 1 0 0 0 1 0 end\n", RAD_ERR_PARSE,
                  "line 4: unknown statement 'Polygon' (expected material, polygon, group, "
                  "camera or light)"));
    /* a comment runs to the end of its line, even inside a word */
    rad_scene *t = NULL;
    CHECK(parse(HEAD "polygon p#comment\n w 0 0 0 1 0 0 0 1 0 end#x", &t, &e) == RAD_OK);
    CHECK(t && t->polygon_count == 1 && strcmp(t->polygons[0].name, "p") == 0);
    rad_scene_destroy(t);
}

TEST(polygon_limit)
{
    rad_load_options opt = {.max_polygons = 2};
    const char *t = HEAD "polygon a w 0 0 0 1 0 0 0 1 0 end\npolygon b w 0 0 1 1 0 1 0 1 1 end\n"
                         "polygon c w 0 0 2 1 0 2 0 1 2 end\n";
    rad_scene *s = NULL;
    rad_error e = {0};
    CHECK(rad_scene_parse_polyfile(t, strlen(t), "room.rad", &opt, &s, &e) == RAD_ERR_LIMIT);
    CHECK_MSG(strstr(e.message, "room.rad: line 6: polygon 'c': more than 2 polygons") != NULL,
              "%s", e.message);
    CHECK(s == NULL);
    opt.max_polygons = 3;
    CHECK(rad_scene_parse_polyfile(t, strlen(t), "room.rad", &opt, &s, &e) == RAD_OK);
    CHECK(s && s->polygon_count == 3);
    rad_scene_destroy(s);
}

/* Every prefix of a valid file, each in a buffer of exactly its length so
 * that AddressSanitizer sees any read past the end: OK or a clean error. */
TEST(truncated_at_every_byte)
{
    size_t n = strlen(GOOD);
    int bad = 0, ok_count = 0;
    for (size_t len = 0; len <= n; len++) {
        char *buf = malloc(len ? len : 1);
        if (!buf)
            return;
        memcpy(buf, GOOD, len);
        rad_scene *s = (rad_scene *)1;
        rad_error e = {0};
        int rc = rad_scene_parse_polyfile(buf, len, "cut.rad", NULL, &s, &e);
        if (rc == RAD_OK) {
            ok_count++;
            if (!s)
                bad++;
            rad_scene_destroy(s);
        } else if (s != NULL || strncmp(e.message, "cut.rad: line ", 14) != 0) {
            bad++;
            fprintf(stderr, "    prefix %zu: %d %s\n", len, rc, e.message);
        }
        free(buf);
    }
    CHECK(bad == 0);
    /* the whole file parses; so do the prefixes ending just after a statement */
    CHECK(ok_count >= 2);
}

/* Random byte changes to a valid file (fixed seed): no crash, no leak, and
 * every answer is OK or a message in the "FILE: line N: " form. */
TEST(mutated_files)
{
    size_t n = strlen(GOOD);
    char *buf = malloc(n);
    if (!buf)
        return;
    uint64_t x = 0x9E3779B97F4A7C15ull;
    int bad = 0;
    static const char alphabet[] = "0123456789 \n#.-+eE\0abcdefgnpolyrsu";
    for (int iter = 0; iter < 3000; iter++) {
        memcpy(buf, GOOD, n);
        int changes = 1 + iter % 4;
        for (int c = 0; c < changes; c++) {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            buf[x % n] = alphabet[(x >> 32) % (sizeof alphabet - 1)];
        }
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        size_t len = (iter % 3 == 0) ? (size_t)(x % (n + 1)) : n;
        rad_scene *s = NULL;
        rad_error e = {0};
        int rc = rad_scene_parse_polyfile(buf, len, "m.rad", NULL, &s, &e);
        if (rc == RAD_OK)
            rad_scene_destroy(s);
        else if (s != NULL || strncmp(e.message, "m.rad: line ", 12) != 0)
            bad++;
    }
    free(buf);
    CHECK(bad == 0);
}

TEST(api_misuse)
{
    rad_scene *s = NULL;
    rad_error e = {0};
    CHECK(rad_scene_parse_polyfile(NULL, 5, "x", NULL, &s, &e) == RAD_ERR_USAGE);
    CHECK(rad_scene_parse_polyfile("bands 1", 7, "x", NULL, NULL, &e) == RAD_ERR_USAGE);
    /* NULL text of size 0 is an empty file */
    CHECK(rad_scene_parse_polyfile(NULL, 0, "x", NULL, &s, &e) == RAD_ERR_PARSE);
    CHECK(s == NULL);
}

/* ------------------------------------------------------------- the loader */

static char tmpdir[64];

static const char *tmp_path(const char *name, char *buf, size_t size)
{
    snprintf(buf, size, "%s/%s", tmpdir, name);
    return buf;
}

static int write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    size_t n = strlen(text);
    int ok = fwrite(text, 1, n, f) == n;
    return (fclose(f) == 0 && ok) ? 0 : -1;
}

TEST(load_files)
{
    char p[200];
    rad_scene *s = NULL;
    rad_error e = {0};
    CHECK(rad_scene_load(tmp_path("missing.rad", p, sizeof p), NULL, &s, &e) == RAD_ERR_IO);
    CHECK_MSG(strstr(e.message, "missing.rad: cannot open: No such file or directory") != NULL,
              "%s", e.message);
    CHECK(s == NULL);
    CHECK(rad_scene_load(tmpdir, NULL, &s, &e) == RAD_ERR_IO);
    CHECK_MSG(strstr(e.message, "cannot open: Is a directory") != NULL, "%s", e.message);

    const char *lit = "bands 1\nmaterial m emission 1\npolygon p m 0 0 0 1 0 0 0 1 0 end\n";
    CHECK(write_file(tmp_path("lit.rad", p, sizeof p), lit) == 0);
    CHECK_MSG(rad_scene_load(p, NULL, &s, &e) == RAD_OK, "%s", e.message);
    CHECK(s && s->polygon_count == 1 && strcmp(s->source, p) == 0);
    rad_scene_destroy(s);
    s = NULL;

    /* parses but fails the whole-scene checks */
    CHECK(write_file(tmp_path("dark.rad", p, sizeof p),
                     "bands 1\nmaterial m reflectance 0.5\npolygon p m 0 0 0 1 0 0 0 1 0 end\n") ==
          0);
    CHECK(rad_scene_load(p, NULL, &s, &e) == RAD_ERR_INVALID);
    CHECK_MSG(strstr(e.message, "dark.rad: no emitter: no material has emission > 0") != NULL,
              "%s", e.message);
    CHECK(s == NULL);

    /* syntax errors carry the path and line */
    CHECK(write_file(tmp_path("bad.txt", p, sizeof p), "bands 1\n\nwhat\n") == 0);
    CHECK(rad_scene_load(p, NULL, &s, &e) == RAD_ERR_PARSE);
    CHECK_MSG(strstr(e.message, "bad.txt: line 3: unknown statement 'what'") != NULL, "%s",
              e.message);

    /* .GLB (any case) goes to the glTF reader, which does not take polygon text */
    CHECK(write_file(tmp_path("lit.GLB", p, sizeof p), lit) == 0);
    CHECK(rad_scene_load(p, NULL, &s, &e) != RAD_OK);
    CHECK(s == NULL);
    CHECK(write_file(tmp_path("lit.gltf", p, sizeof p), lit) == 0);
    CHECK(rad_scene_load(p, NULL, &s, &e) != RAD_OK);
    CHECK(s == NULL);
}

/* The example in docs/polygon-file.md parses, validates and faces inwards. */
TEST(documented_example)
{
    FILE *f = fopen("docs/polygon-file.md", "rb");
    CHECK_MSG(f != NULL, "docs/polygon-file.md (run from the repository root)");
    if (!f)
        return;
    static char doc[65536];
    size_t n = fread(doc, 1, sizeof doc - 1, f);
    fclose(f);
    doc[n] = '\0';
    char *start = strstr(doc, "```\n# room.rad");
    char *end = start ? strstr(start + 4, "\n```") : NULL;
    CHECK(start && end);
    if (!start || !end)
        return;
    start += 4;
    rad_scene *s = NULL;
    rad_error e = {0};
    CHECK_MSG(rad_scene_parse_polyfile(start, (size_t)(end - start + 1), "example", NULL, &s,
                                       &e) == RAD_OK,
              "%s", e.message);
    if (!s)
        return;
    CHECK(rad_scene_validate(s, &e) == RAD_OK);
    CHECK(s->polygon_count == 8 && s->object_count == 7 && s->camera_count == 1);
    CHECK(s->light_count == 1 && s->lights[0].kind == RAD_LIGHT_SPOT);
    /* the room is 4 x 2.5 x 3; every wall, the floor, the ceiling and the
     * lamp face its centre */
    rad_vec3 centre = rad_v3(2, 1.25, 1.5);
    for (uint32_t i = 0; i < s->polygon_count; i++) {
        const rad_polygon *p = &s->polygons[i];
        if (strncmp(p->name, "table", 5) == 0)
            continue;
        rad_vec3 c = rad_v3(0, 0, 0);
        for (uint32_t k = 0; k < p->point_count; k++)
            c = rad_add(c, s->points[p->first_point + k]);
        c = rad_scale(c, 1.0 / p->point_count);
        CHECK_MSG(rad_dot(rad_sub(centre, c), p->normal) > 0.0, "%s", p->name);
    }
    rad_scene_destroy(s);
}

/* ----------------------------------------------------------- Cornell box */

/* Published areas (mm² / 1e6) from the Cornell data, summed per object; the
 * ceiling loses the light's 0.01365 m² hole. */
static const struct {
    const char *object;
    double area;
    int block; /* 1: normals point out of the block, 0: into the room */
} CORNELL[] = {
    {"floor", 0.30823104, 0},
    {"ceiling", 0.3109152 - 0.01365, 0},
    {"light", 0.01365, 0},
    {"back_wall", 0.30337664, 0},
    {"left_wall_red", 0.3069019542, 0},
    {"right_wall_green", 0.30688896, 0},
    {"short_block", 0.027633 + 0.0273442389 + 0.0276102739 + 0.0275624092 + 0.0271989876, 1},
    {"tall_block", 0.0276265 + 0.0549050981 + 0.0546884778 + 0.0552205478 + 0.0545898205, 1},
};

static rad_vec3 polygon_centroid(const rad_scene *s, const rad_polygon *p)
{
    rad_vec3 c = rad_v3(0, 0, 0);
    for (uint32_t k = 0; k < p->point_count; k++)
        c = rad_add(c, s->points[p->first_point + k]);
    return rad_scale(c, 1.0 / p->point_count);
}

TEST(cornell_box)
{
    rad_scene *s = NULL;
    rad_error e = {0};
    CHECK_MSG(rad_scene_load("models/cornell.rad", NULL, &s, &e) == RAD_OK,
              "%s (run from the repository root)", e.message);
    if (!s)
        return;
    CHECK(rad_scene_validate(s, &e) == RAD_OK);
    CHECK(s->band_count == 3);
    CHECK(s->band_names[0] && strcmp(s->band_names[0], "R") == 0 && s->band_names[1] &&
          strcmp(s->band_names[1], "G") == 0 && s->band_names[2] &&
          strcmp(s->band_names[2], "B") == 0);
    CHECK(s->object_count == 8);
    CHECK(s->polygon_count == 19); /* 1+4+1+1+1+1+5+5 */

    uint32_t white = rad_scene_find_material(s, "white"), light = rad_scene_find_material(s, "light");
    CHECK(white != RAD_NONE && light != RAD_NONE);
    if (white != RAD_NONE) {
        CHECK(s->materials[white].rho[0] == 0.725 && s->materials[white].rho[1] == 0.71 &&
              s->materials[white].rho[2] == 0.68);
    }
    if (light != RAD_NONE) {
        /* E = π L with L = (17, 12, 4); 1e-12: the file carries 16 digits */
        CHECK_REL(s->materials[light].emission[0], M_PI * 17, 1e-12);
        CHECK_REL(s->materials[light].emission[1], M_PI * 12, 1e-12);
        CHECK_REL(s->materials[light].emission[2], M_PI * 4, 1e-12);
        CHECK(s->materials[light].rho[0] == 0.0);
    }
    uint32_t red = rad_scene_find_material(s, "red"), green = rad_scene_find_material(s, "green");
    CHECK(red != RAD_NONE && s->materials[red].rho[0] == 0.63 && s->materials[red].rho[2] == 0.05);
    CHECK(green != RAD_NONE && s->materials[green].rho[1] == 0.45);

    /* the room's centre: half the published extents (metres) */
    rad_vec3 room = rad_v3(0.278, 0.2744, 0.2796);
    for (size_t o = 0; o < sizeof CORNELL / sizeof CORNELL[0]; o++) {
        uint32_t obj = rad_scene_find_object(s, CORNELL[o].object);
        CHECK_MSG(obj != RAD_NONE, "object %s", CORNELL[o].object);
        if (obj == RAD_NONE)
            continue;
        double area = 0.0;
        rad_vec3 bc = rad_v3(0, 0, 0);
        uint32_t npts = 0;
        for (uint32_t i = 0; i < s->polygon_count; i++) {
            const rad_polygon *p = &s->polygons[i];
            if (p->object != obj)
                continue;
            area += p->area;
            for (uint32_t k = 0; k < p->point_count; k++, npts++)
                bc = rad_add(bc, s->points[p->first_point + k]);
        }
        bc = rad_scale(bc, 1.0 / (npts ? npts : 1));
        /* 1e-3: the brief's tolerance; the 0.8 mm red-wall projection and the
         * 0.1 mm light drop change areas far less */
        CHECK_REL(area, CORNELL[o].area, 1e-3);
        for (uint32_t i = 0; i < s->polygon_count; i++) {
            const rad_polygon *p = &s->polygons[i];
            if (p->object != obj)
                continue;
            rad_vec3 c = polygon_centroid(s, p);
            double d = CORNELL[o].block ? rad_dot(rad_sub(c, bc), p->normal)
                                        : rad_dot(rad_sub(room, c), p->normal);
            CHECK_MSG(d > 0.0, "polygon %s faces the wrong way (%g)", p->name, d);
        }
    }
    /* the light hangs below the ceiling, facing down */
    uint32_t lo = rad_scene_find_object(s, "light");
    for (uint32_t i = 0; i < s->polygon_count && lo != RAD_NONE; i++)
        if (s->polygons[i].object == lo) {
            CHECK(s->polygons[i].normal.y == -1.0);
            CHECK(s->points[s->polygons[i].first_point].y < 0.5488);
        }
    uint32_t cam = s->camera_count ? 0 : RAD_NONE;
    CHECK(cam == 0);
    if (cam == 0) {
        CHECK(s->cameras[0].eye.x == 0.278 && s->cameras[0].eye.z == -0.8 &&
              s->cameras[0].target.z == 0.0 && s->cameras[0].up.y == 1.0);
        CHECK_NEAR(s->cameras[0].yfov_deg, 39.307648, 1e-3); /* published 39.307648 */
    }
    rad_scene_destroy(s);
}

int main(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/test_polyfile.XXXXXX");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    RUN(good_file);
    RUN(grey_file_and_crlf);
    RUN(header_errors);
    RUN(material_errors);
    RUN(polygon_errors);
    RUN(group_errors);
    RUN(camera_errors);
    RUN(lexical_errors);
    RUN(polygon_limit);
    RUN(truncated_at_every_byte);
    RUN(mutated_files);
    RUN(api_misuse);
    RUN(load_files);
    RUN(documented_example);
    RUN(cornell_box);
    static const char *const names[] = {"lit.rad", "dark.rad", "bad.txt", "lit.GLB", "lit.gltf"};
    char p[200];
    for (size_t k = 0; k < sizeof names / sizeof names[0]; k++)
        unlink(tmp_path(names[k], p, sizeof p));
    rmdir(tmpdir);
    return test_finish("test_polyfile");
}
