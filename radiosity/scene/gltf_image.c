/* gltf_image.c - the one file that decodes images: a texture's PNG or JPEG
 * bytes -> the mean linear colour of its texels (stb_image, Debian's
 * libstb-dev, compiled here alone, PNG and JPEG only: the two formats glTF
 * 2.0 allows without an extension).
 *
 * A diffuse radiosity patch has one ρ, so a texture counts by its mean
 * (gltf.c multiplies it into baseColorFactor).  glTF stores colour textures
 * sRGB-encoded; each 8-bit value v is decoded with the sRGB transfer
 * function before averaging, because reflectance is linear:
 *     c = v/255,  linear = c/12.92 (c <= 0.04045), ((c + 0.055)/1.055)^2.4 (else).
 * The mean is unweighted over every texel (the texture is averaged, not the
 * surface: texture coordinates are not read).  Alpha is ignored: it is
 * coverage or opacity, not reflectance, and a diffuse patch is opaque.
 * 16-bit PNGs are averaged from stb's 8-bit conversion (a mean over many
 * texels loses nothing that matters at 1/255).
 *
 * Invariant: pixels live only inside rad_gltf_image_mean and are freed
 * before it returns; no input makes it allocate beyond the caller's texel
 * limit (checked from the header before decoding) or, for a lying header or
 * a zlib bomb, beyond IMAGE_MAX_ALLOC in any one allocation; and no input
 * crashes it (the fuzz target test/fuzz/fuzz_gltf.c reaches it through data
 * URIs).
 */
#include "gltf_image.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The largest single allocation the decoder may make: an 8192 × 8192 RGBA
 * image of 16-bit channels with PNG's filter bytes (the largest the texel
 * limit lets through), plus slack.  A compressed stream that inflates beyond
 * it (a "zip bomb") fails with "out of memory" instead of taking the
 * machine's memory. */
#define IMAGE_MAX_ALLOC (((size_t)8192 * (8192 * 8 + 1)) + ((size_t)1 << 20))

static void *capped_malloc(size_t n) { return n <= IMAGE_MAX_ALLOC ? malloc(n) : NULL; }
static void *capped_realloc(void *p, size_t n) { return n <= IMAGE_MAX_ALLOC ? realloc(p, n) : NULL; }

#define STBI_MALLOC(n) capped_malloc(n)
#define STBI_REALLOC(p, n) capped_realloc(p, n)
#define STBI_FREE(p) free(p)
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#define STBI_NO_LINEAR
#define STBI_NO_HDR
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
/* stb_image is not ours and not written for -Wextra -Werror.  Unused
 * static functions are reported at the end of the file, so that warning
 * stays off for the whole file. */
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wtype-limits"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

/* The sRGB transfer function, decoded (IEC 61966-2-1). */
/* Debian's stb_image (git 2022-09) builds a JPEG Huffman table from its
 * 16 code-length counts without checking that they add up to at most 256
 * symbols, and writes past the table when they do not (found by the fuzz
 * target).  Every place a DHT marker (FF C4) could be taken from is checked
 * the way stb reads it (tables of 17 bytes plus their symbols while the
 * segment's length lasts; bytes past the end read as 0) before stb sees the
 * file.  Entropy-coded data never holds FF C4 (an FF there is stuffed as
 * FF 00), so a valid JPEG passes; a JPEG inside an EXIF block is checked
 * too, which can only refuse a damaged file.  0 when sane. */
static int jpeg_bad_huffman(const unsigned char *d, size_t size)
{
    if (size < 2 || d[0] != 0xFF || d[1] != 0xD8)
        return 0; /* not a JPEG */
    for (size_t m = 2; m + 4 <= size; m++) {
        if (d[m] != 0xFF || d[m + 1] != 0xC4)
            continue;
        long left = (long)((unsigned)d[m + 2] << 8 | d[m + 3]) - 2;
        size_t p = m + 4;
        while (left > 0) {
            unsigned n = 0;
            for (size_t i = 1; i <= 16; i++)
                n += p + i < size ? d[p + i] : 0;
            if (n > 256)
                return 1;
            p += 17 + n;
            left -= 17 + (long)n;
        }
    }
    return 0;
}

static double srgb_to_linear(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

int rad_gltf_image_mean(const unsigned char *data, size_t size, uint64_t max_texels,
                        double mean[3], char *why, size_t why_size)
{
    int w = 0, h = 0, comp = 0;
    if (!data || size == 0) {
        snprintf(why, why_size, "no image data");
        return -1;
    }
    if (size > INT_MAX) {
        snprintf(why, why_size, "%zu bytes, more than the decoder's 2 GiB", size);
        return -1;
    }
    if (jpeg_bad_huffman(data, size)) {
        snprintf(why, why_size, "a JPEG Huffman table of more than 256 symbols");
        return -1;
    }
    /* The header alone first: a huge image is refused before any pixel is
     * allocated. */
    if (!stbi_info_from_memory(data, (int)size, &w, &h, &comp)) {
        snprintf(why, why_size, "not a PNG or JPEG image the decoder reads (%s)",
                 stbi_failure_reason());
        return -1;
    }
    if (w <= 0 || h <= 0 || (uint64_t)w * (uint64_t)h > max_texels) {
        snprintf(why, why_size, "%d × %d texels, more than the limit of %llu", w, h,
                 (unsigned long long)max_texels);
        return -1;
    }
    unsigned char *px = stbi_load_from_memory(data, (int)size, &w, &h, &comp, 3);
    if (!px) {
        snprintf(why, why_size, "cannot decode the image (%s)", stbi_failure_reason());
        return -1;
    }
    double lut[256];
    for (int v = 0; v < 256; v++)
        lut[v] = srgb_to_linear(v / 255.0);
    /* Sums per row first: each row adds at most 8192 values of <= 1, so the
     * total keeps its precision over 2^26 texels. */
    double sum[3] = {0, 0, 0};
    for (int y = 0; y < h; y++) {
        double row[3] = {0, 0, 0};
        const unsigned char *p = px + (size_t)y * (size_t)w * 3;
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                row[c] += lut[p[3 * x + c]];
        for (int c = 0; c < 3; c++)
            sum[c] += row[c];
    }
    stbi_image_free(px);
    double n = (double)w * (double)h;
    for (int c = 0; c < 3; c++)
        mean[c] = sum[c] / n;
    return 0;
}
