/* bench_util.h - what several benchmarks share: the patch size that meshes
 * a scene into about a target number of patches, and the machine's load
 * average printed beside the timings it stretches.  Static functions in a
 * header, like test/util.h: each benchmark is one translation unit.
 */
#ifndef BENCH_UTIL_H
#define BENCH_UTIL_H

#include "../radiosity/mesh/mesh.h"

#include <stdio.h>
#include <stdlib.h>

/* The patch size for about `target` patches, by bisection on rad_mesh_count,
 * so a table's sizes are the nearest the mesher makes. */
static inline double bench_patch_size_for(const rad_scene *scene, uint32_t target)
{
    double lo = 1e-4, hi = 1.0;
    for (int it = 0; it < 60; it++) {
        double mid = sqrt(lo * hi);
        rad_mesh_options mo = {.patch_size = mid};
        if (rad_mesh_count(scene, &mo) > target)
            lo = mid;
        else
            hi = mid;
    }
    return hi;
}

/* The 1-minute load average, or -1 where the system does not say. */
static inline double bench_load(void)
{
    double load[1] = {-1.0};
    return getloadavg(load, 1) == 1 ? load[0] : -1.0;
}

/* One line "load average WHEN: L" beside a table. */
static inline void bench_print_load(const char *when)
{
    printf("load average %s: %.2f\n", when, bench_load());
}

/* Marks in near[m->patch_count] the patches j within `reach` of c (from c
 * to j's centre, less √A_j: issue 36's near field of a contact element);
 * returns how many. */
static inline uint32_t bench_near_set(const rad_mesh *m, rad_vec3 c, double reach, uint8_t *near)
{
    uint32_t count = 0;
    for (uint32_t j = 0; j < m->patch_count; j++) {
        const rad_vec3 q = m->patches[j].center;
        const double dx = q.x - c.x, dy = q.y - c.y, dz = q.z - c.z;
        near[j] = sqrt(dx * dx + dy * dy + dz * dz) - sqrt(m->patches[j].area) <= reach;
        count += near[j];
    }
    return count;
}

#endif /* BENCH_UTIL_H */
