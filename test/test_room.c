/* test_room.c - draft */
#include "../radiosity/pipeline/pipeline.h"
#include "../tools/room.h"
#include "test.h"

static rad_solution *solution;

static void table_print(void)
{
    const rad_scene *sc = solution->scene;
    uint32_t no = sc->object_count, nb = solution->band_count;
    rad_object_stats *st = calloc(no, sizeof *st);
    rad_error err = {0};
    CHECK(rad_solution_object_stats(solution, st, &err) == 0);
    double em = 0, ab = 0;
    const rad_elements *el = solution->elements;
    double *eB = calloc((size_t)no * nb, sizeof *eB), *eA = calloc(no, sizeof *eA);
    if (el)
        for (uint32_t e = 0; e < el->mesh->patch_count; e++) {
            const rad_patch *p = &el->mesh->patches[e];
            eA[p->object] += p->area;
            for (uint32_t b = 0; b < nb; b++)
                eB[p->object * nb + b] += p->area * el->B[(size_t)e * nb + b];
        }
    for (uint32_t o = 0; o < no; o++) {
        printf("  %-10s A %.4f patches %5u  B/pi", sc->objects[o].name, st[o].area, st[o].patch_count);
        for (uint32_t b = 0; b < nb; b++)
            printf(" %.5f", st[o].B[b] / M_PI);
        printf("  elem");
        for (uint32_t b = 0; b < nb; b++)
            printf(" %.5f", eA[o] > 0 ? eB[o * nb + b] / eA[o] / M_PI : 0.0);
        double e = 0, a = 0;
        for (uint32_t b = 0; b < nb; b++) {
            e += st[o].emitted[b];
            a += st[o].absorbed[b];
        }
        printf("  emit %.4f abs %.4f\n", e, a);
        em += e;
        ab += a;
    }
    printf("  absorbed/emitted - 1 = %+.4f %%\n", 100 * (ab / em - 1));
    free(st);
    free(eB);
    free(eA);
}

int main(int argc, char **argv)
{
    char dir[] = "/tmp/test_room_XXXXXX";
    const char *d = argc > 2 && !strcmp(argv[1], "--write") ? argv[2] : mkdtemp(dir);
    room_stats rs;
    if (!d || room_write(d, "room", &rs)) {
        printf("FAIL write\n");
        return 1;
    }
    printf("  room: %llu triangles, %u objects in %s\n", (unsigned long long)rs.triangles, rs.objects, d);
    if (argc > 2)
        return 0;
    char path[256];
    snprintf(path, sizeof path, "%s/room.gltf", getenv("ROOM_DIR") ? getenv("ROOM_DIR") : d);
    rad_solve_options opt = {0};
    if (getenv("ROOM_ELHC"))
        opt.element_hemicubes = 1;
    if (getenv("ROOM_LEVELS"))
        opt.element_levels = (uint32_t)atoi(getenv("ROOM_LEVELS"));
    if (getenv("ROOM_PS"))
        opt.mesh.patch_size = atof(getenv("ROOM_PS"));
    rad_error err = {0};
    if (rad_solve_scene_file(path, &opt, &solution, &err)) {
        fprintf(stderr, "  solve: %s\n", err.message);
        return 1;
    }
    printf("  patches %u\n", solution->mesh->patch_count);
    RUN(table_print);
    rad_solution_destroy(solution);
    return test_finish("test_room");
}
