/* png.c - 8-bit sRGB PNG previews of rendered images.
 *
 * The only file that uses libpng.  A pixel's byte is the sRGB transfer curve
 * of L·2^exposure clamped to [0, 1]; one band (or two: the first) is grey,
 * three or more bands are RGB from the first three.  Invariant: a write goes
 * through a rad_output, so it either renames a complete temporary onto path
 * or leaves path as it was and no temporary file behind.  libpng's errors come back through
 * longjmp into a rad_error; nothing is printed.
 */
#include "rn_internal.h"

#include <png.h>

#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct png_failure {
    jmp_buf jump;
    char message[256];
} png_failure;

static void png_quiet_error(png_structp png, png_const_charp msg)
{
    png_failure *f = png_get_error_ptr(png);
    snprintf(f->message, sizeof f->message, "%s", msg ? msg : "libpng error");
    longjmp(f->jump, 1);
}

static void png_quiet_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* IEC 61966-2-1 sRGB encoding of a linear value, as an 8-bit code. */
static png_byte srgb_byte(double x)
{
    if (!(x > 0.0))
        return 0; /* negative and NaN */
    if (x >= 1.0)
        return 255;
    double s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return (png_byte)(s * 255.0 + 0.5);
}

/* srgb_byte is non-decreasing, so it is fixed by the 255 linear values where
 * it steps: t[k - 1] is the least double x with srgb_byte(x) >= k.  Found by
 * bisection on srgb_byte itself, so coding through the table gives the same
 * byte for every x (a pow per channel made PNG writing a tenth of a view's
 * cost). */
typedef struct srgb_table {
    double t[255];
} srgb_table;

static void srgb_table_make(srgb_table *tab)
{
    for (int k = 1; k <= 255; k++) {
        double lo = 0.0, hi = 1.0; /* srgb_byte(lo) < k <= srgb_byte(hi) */
        for (;;) {
            double mid = lo + (hi - lo) / 2;
            if (mid <= lo || mid >= hi)
                break;
            if (srgb_byte(mid) >= k)
                hi = mid;
            else
                lo = mid;
        }
        tab->t[k - 1] = hi;
    }
}

static png_byte srgb_coded(const srgb_table *tab, double x)
{
    if (!(x >= tab->t[0]))
        return 0; /* also NaN */
    unsigned lo = 0, hi = 255; /* t[lo] <= x; x < t[hi] (t[255] = +inf) */
    while (hi - lo > 1) {
        unsigned mid = (lo + hi) / 2;
        if (x >= tab->t[mid])
            lo = mid;
        else
            hi = mid;
    }
    return (png_byte)(lo + 1);
}

/* Encodes img into the open file f; RAD_OK or RAD_ERR_IO/NOMEM. */
/* libpng's write callback: bytes go to the rad_output (its first failure
 * sticks and is reported at commit). */
static void png_to_output(png_structp png, png_bytep data, size_t n)
{
    rad_output_write(png_get_io_ptr(png), data, n);
}

static void png_no_flush(png_structp png) { (void)png; }

static int encode(rad_output *out, const rn_image *img, double scale, const char *path, rad_error *err)
{
    int grey = img->channels < 3;
    size_t row_bytes = (size_t)img->width * (grey ? 1 : 3);
    png_byte *volatile row = malloc(row_bytes);
    if (!row)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for a PNG row", path);
    png_failure fail;
    fail.message[0] = '\0';
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &fail, png_quiet_error,
                                              png_quiet_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        free(row);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: libpng could not start", path);
    }
    if (setjmp(fail.jump)) {
        png_destroy_write_struct(&png, &info);
        free(row);
        return rad_fail(err, RAD_ERR_IO, "%s: libpng: %s", path, fail.message);
    }
    png_set_write_fn(png, out, png_to_output, png_no_flush);
    png_set_IHDR(png, info, img->width, img->height, 8, grey ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    /* zlib's fastest level: a 1024² view's PNG in half the time (0.045
     * against 0.094 s of CPU, a tenth of a view's whole cost) for a file
     * half as large again (343 against 226 KB); it is a preview. */
    png_set_compression_level(png, 1);
    png_write_info(png, info);
    uint32_t used = grey ? 1 : 3;
    srgb_table tab;
    srgb_table_make(&tab);
    for (uint32_t y = 0; y < img->height; y++) {
        const float *src = img->pixels + (size_t)y * img->width * img->channels;
        for (uint32_t x = 0; x < img->width; x++)
            for (uint32_t c = 0; c < used; c++)
                row[(size_t)x * used + c] = srgb_coded(&tab, (double)src[(size_t)x * img->channels + c] * scale);
        png_write_row(png, row);
    }
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    free(row);
    return RAD_OK;
}

int rn_write_png(const rn_image *img, const char *path, double exposure, rad_error *err)
{
    return rn_write_png_later(img, path, exposure, NULL, err);
}

int rn_write_png_later(const rn_image *img, const char *path, double exposure,
                       rad_committer *committer, rad_error *err)
{
    int rc = rn_image_check(img, path, err);
    if (rc)
        return rc;
    double scale = exp2(exposure);
    if (!isfinite(scale))
        return rad_fail(err, RAD_ERR_USAGE, "%s: exposure %g unusable", path, exposure);
    rad_output *out = NULL;
    rc = rad_output_open(path, &out, err);
    if (rc)
        return rc;
    rc = encode(out, img, scale, path, err);
    if (rc) {
        rad_output_abort(out);
        return rc;
    }
    return rad_output_commit_later(out, committer, err);
}
