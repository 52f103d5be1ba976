/* disks.c - the coaxial disk pair (disks.h) as polygon-file text and as a
 * glTF document.  Both forms put the same DISKS_SIDES points on each disk,
 * B's run the other way round so that it faces -z; the text is built in
 * memory (open_memstream), so tests parse it without a file.
 */
#include "disks.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Point k of disk d (0: A at z = 0, 1: B at z = 1, wound the other way). */
static void disk_point(uint32_t k, int d, double p[3])
{
    double a = 2.0 * M_PI * (d ? DISKS_SIDES - k : k) / DISKS_SIDES;
    p[0] = cos(a);
    p[1] = sin(a);
    p[2] = d;
}

char *disks_polyfile(int emit)
{
    char *s = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&s, &len);
    if (!f)
        return NULL;
    fprintf(f, "bands 1\nmaterial grey reflectance 0.5\n");
    if (emit)
        fprintf(f, "material lamp reflectance 0.5 emission 1\n");
    for (int d = 0; d < 2; d++) {
        fprintf(f, "polygon %s %s\n", d ? "B" : "A", emit && !d ? "lamp" : "grey");
        for (uint32_t k = 0; k < DISKS_SIDES; k++) {
            double p[3];
            disk_point(k, d, p);
            fprintf(f, "  %.17g %.17g %.17g\n", p[0], p[1], p[2]);
        }
        fprintf(f, "end\n");
    }
    return fclose(f) == 0 ? s : (free(s), NULL);
}

/* n bytes of d as base64 onto f. */
static void base64(FILE *f, const unsigned char *d, size_t n)
{
    static const char abc[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)d[i] << 16 | (i + 1 < n ? (uint32_t)d[i + 1] << 8 : 0) |
                     (i + 2 < n ? d[i + 2] : 0);
        fputc(abc[v >> 18 & 63], f);
        fputc(abc[v >> 12 & 63], f);
        fputc(i + 1 < n ? abc[v >> 6 & 63] : '=', f);
        fputc(i + 2 < n ? abc[v & 63] : '=', f);
    }
}

/* The binary buffer: both disks' points (float VEC3), then both fans. */
static unsigned char *fan_buffer(size_t *pos_bytes, size_t *idx_bytes)
{
    const uint32_t ntri = DISKS_SIDES - 2;
    *pos_bytes = 2 * DISKS_SIDES * 12;
    *idx_bytes = 2 * ntri * 3 * 4;
    unsigned char *b = malloc(*pos_bytes + *idx_bytes);
    size_t n = 0;
    for (int d = 0; b && d < 2; d++)
        for (uint32_t k = 0; k < DISKS_SIDES; k++) {
            double p[3];
            disk_point(k, d, p);
            float q[3] = {(float)p[0], (float)p[1], (float)p[2]};
            memcpy(b + n, q, sizeof q);
            n += sizeof q;
        }
    for (int d = 0; b && d < 2; d++)
        for (uint32_t k = 1; k + 1 < DISKS_SIDES; k++) {
            uint32_t tri[3] = {0, k, k + 1};
            memcpy(b + n, tri, sizeof tri);
            n += sizeof tri;
        }
    return b;
}

char *disks_gltf(int emit, size_t *size)
{
    size_t pos, idx;
    unsigned char *b = fan_buffer(&pos, &idx);
    char *s = NULL;
    FILE *f = b ? open_memstream(&s, size) : NULL;
    if (!f) {
        free(b);
        return NULL;
    }
    fprintf(f, "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0,1]}],"
               "\"nodes\":[{\"name\":\"A\",\"mesh\":0},{\"name\":\"B\",\"mesh\":1}],"
               "\"materials\":[{\"name\":\"grey\",\"pbrMetallicRoughness\":"
               "{\"baseColorFactor\":[0.5,0.5,0.5,1]}}");
    if (emit)
        fprintf(f, ",{\"name\":\"lamp\",\"emissiveFactor\":[1,1,1],\"pbrMetallicRoughness\":"
                   "{\"baseColorFactor\":[0.5,0.5,0.5,1]}}");
    fprintf(f, "],\"meshes\":[");
    for (int d = 0; d < 2; d++)
        fprintf(f, "%s{\"primitives\":[{\"attributes\":{\"POSITION\":%d},\"indices\":%d,"
                   "\"material\":%d}]}",
                d ? "," : "", 2 * d, 2 * d + 1, emit && !d);
    fprintf(f, "],\"accessors\":[");
    for (int d = 0; d < 2; d++)
        fprintf(f,
                "%s{\"bufferView\":%d,\"componentType\":5126,\"count\":%u,\"type\":\"VEC3\","
                "\"min\":[-1,-1,%d],\"max\":[1,1,%d]},"
                "{\"bufferView\":%d,\"componentType\":5125,\"count\":%u,\"type\":\"SCALAR\"}",
                d ? "," : "", 2 * d, DISKS_SIDES, d, d, 2 * d + 1, 3 * (DISKS_SIDES - 2));
    fprintf(f, "],\"bufferViews\":[");
    for (int d = 0; d < 2; d++)
        fprintf(f,
                "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
                "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}",
                d ? "," : "", d * pos / 2, pos / 2, pos + d * idx / 2, idx / 2);
    fprintf(f, "],\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,",
            pos + idx);
    base64(f, b, pos + idx);
    fprintf(f, "\"}]}");
    free(b);
    return fclose(f) == 0 ? s : (free(s), NULL);
}
