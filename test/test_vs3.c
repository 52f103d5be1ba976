/* test_vs3.c - the .vs3 reader (radiosity/scene/vs3.c) and View3D's
 * surface algebra (radiosity/solution/view3d.c) on what the command-line
 * test (test/cli/view3d.sh) does not reach: masks and null surfaces, the
 * model's records, subsurface pieces, script-F against black F when every
 * ε = 1, and errors the command line does not show.
 */
#include "../radiosity/pipeline/pipeline.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

/* A unit cube room (faces inward) with a mask on the floor (facing down,
 * into the floor) and a null surface in the ceiling. */
static const char room[] =
    "T room with a mask and a null\n"
    "C encl=0 emit=0\n"
    "F 3\n"
    "V 1 0 0 0\nV 2 1 0 0\nV 3 1 1 0\nV 4 0 1 0\n"
    "V 5 0 0 1\nV 6 1 0 1\nV 7 1 1 1\nV 8 0 1 1\n"
    "V 9 0.75 0.75 0\nV 10 0.75 0.25 0\nV 11 0.25 0.25 0\nV 12 0.25 0.75 0\n"
    "V 13 0.75 0.75 1\nV 14 0.75 0.25 1\nV 15 0.25 0.25 1\nV 16 0.25 0.75 1\n"
    "S 1 1 2 3 4 0 0 0.9 floor\n"
    "S 2 1 4 8 5 0 0 0.9 x0\n"
    "S 3 1 5 6 2 0 0 0.9 y0\n"
    "S 4 7 6 5 8 0 0 0.9 ceiling ! a comment\n"
    "S 5 7 3 2 6 0 0 0.9 x1\n"
    "S 6 7 8 4 3 0 0 0.9 y1\n"
    "M 7 9 10 11 12 1 0 0.9 rug\n"
    "N 8 13 14 15 16 4 0 0.9 hatch\n"
    "E\n"
    "S 9 this line is after the end and never read\n";

static double object_area(const rad_scene *s, uint32_t o, uint32_t *pieces)
{
    double a = 0;
    *pieces = 0;
    for (uint32_t p = 0; p < s->polygon_count; p++)
        if (s->polygons[p].object == o) {
            a += s->polygons[p].area;
            ++*pieces;
        }
    return a;
}

TEST(model_and_pieces)
{
    rad_scene *s = NULL;
    rad_vs3 *m = NULL;
    rad_error err = {0};
    CHECK_MSG(rad_vs3_parse(room, strlen(room), "room.vs3", NULL, &s, &m, &err) == RAD_OK, "%s",
              err.message);
    if (!s)
        return;
    CHECK(!strcmp(m->title, "room with a mask and a null"));
    CHECK(m->encl == 0 && m->emit == 0 && m->surface_count == 8 && s->object_count == 8);
    CHECK(m->surfaces[6].kind == RAD_VS3_MASK && m->surfaces[6].base == 0);
    CHECK(m->surfaces[7].kind == RAD_VS3_NULL && m->surfaces[7].base == 3);
    CHECK(!strcmp(s->objects[m->surfaces[3].object].name, "ceiling"));
    uint32_t pieces;
    /* the mask and the null are cut out of their bases: four pieces each */
    CHECK_NEAR(object_area(s, m->surfaces[0].object, &pieces), 0.75, 1e-12);
    CHECK(pieces == 4);
    CHECK_NEAR(object_area(s, m->surfaces[3].object, &pieces), 0.75, 1e-12);
    CHECK(pieces == 4);
    CHECK_NEAR(m->surfaces[0].area, 1.0, 1e-12);
    CHECK_NEAR(s->materials[s->polygons[0].material].rho[0], 0.1, 1e-12); /* ρ = 1 − ε */
    rad_vs3_destroy(m);
    rad_scene_destroy(s);
}

static rad_vs3_factors *factors_of(const char *text, rad_vs3 **model)
{
    rad_scene *s = NULL;
    rad_error err = {0};
    rad_solution *sol = NULL;
    rad_vs3_factors *f = NULL;
    rad_solve_options opt = {0};
    opt.all_rows = 1;
    opt.exact_all = 1;
    opt.mesh.patch_size = 0.5;
    opt.refine_threshold = RAD_REFINE_OFF;
    opt.load.allow_no_emitter = 1;
    if (rad_vs3_parse(text, strlen(text), "t.vs3", NULL, &s, model, &err) ||
        rad_solve_scene(s, &opt, &sol, &err) || rad_vs3_factors_compute(sol, *model, &f, &err))
        fprintf(stderr, "  %s\n", err.message);
    rad_solution_destroy(sol);
    return f;
}

/* View3D's mask: F_mask,base = 1 and nothing else; the base keeps its
 * whole area.  The null surface is not reported, its base loses its area. */
TEST(mask_and_null)
{
    rad_vs3 *m = NULL;
    rad_vs3_factors *f = factors_of(room, &m);
    CHECK(f != NULL);
    if (!f) {
        rad_vs3_destroy(m);
        return;
    }
    CHECK(f->n == 7);
    uint32_t floor = 0, ceiling = 3, rug = 6;
    CHECK(f->surface[rug] == 6);
    CHECK_NEAR(f->area[floor], 1.0, 1e-12);
    CHECK_NEAR(f->area[ceiling], 0.75, 1e-12);
    CHECK_NEAR(f->area[rug], 0.25, 1e-12);
    for (uint32_t j = 0; j < f->n; j++)
        CHECK_NEAR(f->F[rug * f->n + j], j == floor ? 1.0 : 0.0, 1e-12);
    CHECK_NEAR(f->F[floor * f->n + rug], 0.25, 1e-12);
    for (uint32_t i = 0; i < f->n; i++)
        for (uint32_t j = 0; j < f->n; j++)
            CHECK_NEAR(f->area[i] * f->F[i * f->n + j], f->area[j] * f->F[j * f->n + i], 1e-12);
    rad_vs3_factors_destroy(f);
    rad_vs3_destroy(m);
}

static const char cube_head[] = "T cube\nF 3\n"
    "V 1 0 0 0\nV 2 1 0 0\nV 3 1 1 0\nV 4 0 1 0\n"
    "V 5 0 0 1\nV 6 1 0 1\nV 7 1 1 1\nV 8 0 1 1\n";

static void cube_text(char *buf, size_t len, const char *controls, const char *eps)
{
    snprintf(buf, len, "%sC %s\n"
             "S 1 1 2 3 4 0 0 %s a\nS 2 1 4 8 5 0 0 %s b\nS 3 1 5 6 2 0 0 %s c\n"
             "S 4 7 6 5 8 0 0 %s d\nS 5 7 3 2 6 0 0 %s e\nS 6 7 8 4 3 0 0 %s f\n",
             cube_head, controls, eps, eps, eps, eps, eps, eps);
}

/* Script-F with every ε = 1 is F itself (no reflection); with ε = 0.5 in a
 * closed cube each row sums to ε (all emitted power is absorbed), and by
 * symmetry the opposite face's share is below the black factor's. */
TEST(script_f)
{
    char t[1024];
    rad_vs3 *m0 = NULL, *m1 = NULL, *m2 = NULL;
    cube_text(t, sizeof t, "encl=1 emit=0", "1");
    rad_vs3_factors *black = factors_of(t, &m0);
    cube_text(t, sizeof t, "encl=1 emit=1", "1");
    rad_vs3_factors *s1 = factors_of(t, &m1);
    cube_text(t, sizeof t, "encl=1 emit=1", "0.5");
    rad_vs3_factors *s2 = factors_of(t, &m2);
    CHECK(black && s1 && s2);
    if (black && s1 && s2) {
        CHECK(!black->script && s1->script && s2->script);
        for (uint32_t k = 0; k < 36; k++)
            CHECK_NEAR(s1->F[k], black->F[k], 1e-6); /* float rows in the solver */
        for (uint32_t i = 0; i < 6; i++) {
            double sum = 0;
            for (uint32_t j = 0; j < 6; j++)
                sum += s2->F[i * 6 + j];
            CHECK_NEAR(sum, 0.5, 1e-6);
        }
        /* opposite faces: the closed form 0.199824896 within 0.5 % */
        CHECK_REL(black->F[0 * 6 + 3], 0.199824896, 0.005);
        CHECK(s2->F[0] > 0.0); /* a grey face receives its own light back */
    }
    rad_vs3_factors_destroy(black);
    rad_vs3_factors_destroy(s1);
    rad_vs3_factors_destroy(s2);
    rad_vs3_destroy(m0);
    rad_vs3_destroy(m1);
    rad_vs3_destroy(m2);
}

/* Errors the command-line test leaves out: each one line naming the line. */
TEST(errors)
{
    static const struct {
        const char *tail; /* after the cube's vertices */
        const char *want;
    } cases[] = {
        {"S 1 1 2 3 4 0 0 0.5 a\nS 2 1 4 8 5 0 1 0.5 b\nS 3 1 5 6 2 0 2 0.5 c\n",
         "t.vs3: line 13: surface 3: surface 2 is itself combined with surface 1"},
        {"O 1 1 2 3 4 0 0 0.5 a\nM 2 1 4 8 5 1 0 0.5 b\n",
         "t.vs3: line 12: surface 2: a mask (M) surface needs a radiating (S) surface"},
        {"N 1 1 2 3 4 0 0 0.5 a\n", "t.vs3: line 11: surface 1: a null (N) surface needs"},
        {"S 1 1 2 3 4 0 0 0.5 a\nO 2 1 4 8 5 1 0 0.5 b\n",
         "t.vs3: line 12: surface 2: an obstruction (O) has no base"},
        {"S 1 1 2 3 4 2 0 0.5 a\n", "t.vs3: line 11: surface 1: its base 2 must be a surface"},
        {"C encl\n", "t.vs3: line 11: a control without a value"},
        {"S 1 1 2 3 0 0 0 0.5 a\nS 2 1 2 3 4 1 0 0.5 b\n",
         "t.vs3: line 12: surface 2 is not inside its base surface 1"},
        {"! nothing but a comment\n", "t.vs3: line 11: no surface"},
        {"S 1 1 2 2 4 0 0 0.5 a\n", "t.vs3: line 11: surface 1: vertex 2 used twice"},
        {"S 1 1 2 3 4 0 0 0.5 a b\n", "t.vs3: line 11: a surface is"},
        {"S 1 1 2 3 4 0 0 1e999 a\n", "t.vs3: line 11: emittance: '1e999' is not a finite"},
        {"S 1 1 2 3 4 0 0 0.5 a\nS 2 1 2 3 4 1 0 0.5 b\n",
         "t.vs3: line 12: surface 2 covers all that is left of its base surface 1"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char t[2048];
        snprintf(t, sizeof t, "%s%s", cube_head, cases[k].tail);
        rad_scene *s = NULL;
        rad_vs3 *m = NULL;
        rad_error err = {0};
        int rc = rad_vs3_parse(t, strlen(t), "t.vs3", NULL, &s, &m, &err);
        CHECK_MSG(rc != RAD_OK && !s && !m && strstr(err.message, cases[k].want) == err.message,
                  "case %zu: got '%s'", k, err.message);
    }
    rad_scene *e = NULL;
    rad_vs3 *em = NULL;
    rad_error eerr = {0};
    CHECK(rad_vs3_parse("", 0, "t.vs3", NULL, &e, &em, &eerr) == RAD_ERR_INVALID && !e && !em);
    CHECK(strstr(eerr.message, "t.vs3: line 1: no surface") == eerr.message);
    char nul[] = "T x\nV 1 0 0\0 0\n";
    rad_scene *s = NULL;
    rad_error err = {0};
    CHECK(rad_scene_parse_vs3(nul, sizeof nul - 1, "t.vs3", NULL, &s, &err) == RAD_ERR_PARSE);
    CHECK(strstr(err.message, "t.vs3: line 2: NUL byte") == err.message);
}

/* rad_scene_load picks the reader by the .vs3 extension. */
TEST(load_by_extension)
{
    char path[] = "/tmp/test_vs3.XXXXXX.vs3";
    int fd = mkstemps(path, 4);
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    FILE *f = fdopen(fd, "w");
    fputs(room, f);
    fclose(f);
    rad_load_options lo = {.allow_no_emitter = 1};
    rad_scene *s = NULL;
    rad_error err = {0};
    CHECK_MSG(rad_scene_load(path, &lo, &s, &err) == RAD_OK, "%s", err.message);
    CHECK(s && s->object_count == 8 && rad_scene_find_object(s, "hatch") == 7);
    rad_scene_destroy(s);
    unlink(path);
}

int main(void)
{
    RUN(model_and_pieces);
    RUN(mask_and_null);
    RUN(script_f);
    RUN(errors);
    RUN(load_by_extension);
    return test_finish("test_vs3");
}
