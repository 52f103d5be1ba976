/* exr_read.h - a test-only OpenEXR reader: reads back the images
 * rn_write_exr writes, so the tests can compare them value by value.
 *
 * Not part of the library (no command reads an EXR): compiled into the
 * tests that use it (Makefile).  Invariant: on success the image holds
 * every pixel of the file's data window, band b of a pixel from the
 * channel the writers name for band b, and every patch id RAD_NONE.
 */
#ifndef TEST_EXR_READ_H
#define TEST_EXR_READ_H

#include "../render/render.h"

/* Reads an EXR of rn_write_exr's layouts (R,G,B, Y, or B0..Bk; scanlines,
 * half or float channels, any compression the library decodes).  RAD_OK
 * with *out set (caller owns; rn_image_destroy), else an error naming
 * path: RAD_ERR_IO when the file cannot be opened, RAD_ERR_PARSE for
 * anything else it cannot read, and *out NULL. */
int test_read_exr(const char *path, rn_image **out, rad_error *err);

#endif /* TEST_EXR_READ_H */
