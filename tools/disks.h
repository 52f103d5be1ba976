/* disks.h - issue 36's coaxial disk pair, shared by test/test_regions.c
 * (patch counts, F_AB at defaults) and bench/bench_disks.c (the same
 * figures timed): two unit disks one apart, A at z = 0 facing +z and B at
 * z = 1 facing -z, each a regular DISKS_SIDES-gon, written as a polygon
 * file (one polygon each) or as glTF 2.0 (one fan of DISKS_SIDES - 2
 * triangles from its first point each, as exporters write a disk).
 */
#ifndef TOOLS_DISKS_H
#define TOOLS_DISKS_H

#include <stddef.h>

#define DISKS_SIDES 256

/* F_AB of coaxial unit disks one apart: (X - sqrt(X² - 4)) / 2, X = 3.
 * (The 256-gon's own factor is below it by about 1e-4 relative.) */
#define DISKS_CLOSED_FORM 0.38196601125010515

/* The pair as polygon-file text; emit != 0: A emits 1 in its one band
 * (a scene a whole solve accepts), else nothing emits.  Caller frees the
 * NUL-terminated text; NULL when out of memory. */
char *disks_polyfile(int emit);

/* The pair as one glTF document, its buffer embedded as a base64 data URI;
 * emit as for disks_polyfile (A's emissiveFactor 1).  *size: its length.
 * Caller frees it; NULL when out of memory. */
char *disks_gltf(int emit, size_t *size);

#endif /* TOOLS_DISKS_H */
