/* exr.c - OpenEXR output of rendered images (OpenEXR Core C API).
 *
 * The only file of the library that includes OpenEXR (the tests read
 * images back with their own reader, test/exr_read.c).  Images are linear
 * radiance, one float channel per band: R,G,B for three bands, Y for one,
 * B0..Bk otherwise; scanline storage, uncompressed by default, ZIP, RLE or
 * PIZ on request (rn_exr_compression).  Invariant: a write goes through a
 * rad_output, so it either renames a complete temporary onto path or
 * leaves path exactly as it was and no temporary file behind.  The
 * library's own messages are caught by a handler (library code never
 * prints) and end up in the rad_error.
 */
#include "rn_internal.h"

#include <openexr.h>

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Last message OpenEXR reported on this thread; cleared before each call. */
static _Thread_local char exr_msg[256];

static void exr_quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(exr_msg, sizeof exr_msg, "%s", msg ? msg : exr_get_default_error_message(code));
}

static const char *exr_why(exr_result_t rv)
{
    return exr_msg[0] ? exr_msg : exr_get_default_error_message(rv);
}

/* Channel name of band c of an image with n bands. */
static void band_name(uint32_t n, uint32_t c, char *name, size_t size)
{
    static const char *rgb[3] = {"R", "G", "B"};
    if (n == 3)
        snprintf(name, size, "%s", rgb[c]);
    else if (n == 1)
        snprintf(name, size, "Y");
    else
        snprintf(name, size, "B%u", c);
}

/* Which band of an n-band image a channel name holds; -1 when none. */
static int band_of(uint32_t n, const char *name)
{
    char buf[16];
    for (uint32_t c = 0; c < n; c++) {
        band_name(n, c, buf, sizeof buf);
        if (strcmp(buf, name) == 0)
            return (int)c;
    }
    return -1;
}

/* Writes every scanline chunk of img into the started context. */
static int write_pixels(exr_context_t ctx, int part, const rn_image *img, const char *path,
                        rad_error *err)
{
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctx, part, &lines);
    if (rv != EXR_ERR_SUCCESS || lines < 1)
        return rad_fail(err, RAD_ERR_IO, "%s: OpenEXR: %s", path, exr_why(rv));
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int started = 0, rc = RAD_OK;
    size_t line_floats = (size_t)img->width * img->channels;
    for (int32_t y = 0; y < (int32_t)img->height; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctx, part, y, &cinfo);
        if (rv == EXR_ERR_SUCCESS)
            rv = started ? exr_encoding_update(ctx, part, &cinfo, &enc)
                         : exr_encoding_initialize(ctx, part, &cinfo, &enc);
        if (rv != EXR_ERR_SUCCESS) {
            rc = rad_fail(err, RAD_ERR_IO, "%s: OpenEXR: scanline %d: %s", path, y, exr_why(rv));
            break;
        }
        started = 1;
        for (int16_t c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            int band = band_of(img->channels, ch->channel_name);
            if (band < 0) {
                rc = rad_fail(err, RAD_ERR_IO, "%s: OpenEXR: unexpected channel '%s'", path,
                              ch->channel_name);
                break;
            }
            ch->user_pixel_stride = (int32_t)(img->channels * sizeof(float));
            ch->user_line_stride = (int32_t)(line_floats * sizeof(float));
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->encode_from_ptr =
                (const uint8_t *)(img->pixels + (size_t)cinfo.start_y * line_floats + (size_t)band);
        }
        if (rc)
            break;
        rv = exr_encoding_choose_default_routines(ctx, part, &enc);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctx, part, &enc);
        if (rv != EXR_ERR_SUCCESS) {
            rc = rad_fail(err, RAD_ERR_IO, "%s: OpenEXR: scanline %d: %s", path, y, exr_why(rv));
            break;
        }
    }
    if (started)
        exr_encoding_destroy(ctx, &enc);
    return rc;
}

/* OpenEXR's writer hands us its bytes with their offsets: they go to the
 * rad_output, whose first failure sticks and is reported at commit. */
static int64_t exr_to_output(exr_const_context_t ctxt, void *user, const void *buffer, uint64_t sz,
                             uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    rad_output *o = user;
    if (rad_output_write_at(o, buffer, (size_t)sz, offset) < 0) {
        error_cb(ctxt, EXR_ERR_WRITE_IO, "cannot write %s", rad_output_temp(o));
        return -1;
    }
    return (int64_t)sz;
}

int rn_exr_compression_parse(const char *word, rn_exr_compression *out)
{
    static const char *const names[] = {"none", "zip", "rle", "piz"};
    for (int k = 0; k < 4; k++)
        if (word && strcmp(word, names[k]) == 0) {
            *out = (rn_exr_compression)k;
            return 0;
        }
    return -1;
}

int rn_write_exr(const rn_image *img, const char *path, rad_error *err)
{
    return rn_write_exr_with(img, path, RN_EXR_NONE, err);
}

int rn_write_exr_with(const rn_image *img, const char *path, rn_exr_compression compression,
                      rad_error *err)
{
    return rn_write_exr_later(img, path, compression, NULL, err);
}

int rn_write_exr_later(const rn_image *img, const char *path, rn_exr_compression compression,
                       rad_committer *committer, rad_error *err)
{
    static const exr_compression_t codec[] = {EXR_COMPRESSION_NONE, EXR_COMPRESSION_ZIP,
                                              EXR_COMPRESSION_RLE, EXR_COMPRESSION_PIZ};
    if ((unsigned)compression > RN_EXR_PIZ)
        return rad_fail(err, RAD_ERR_USAGE, "%s: unknown EXR compression %d", path ? path : "",
                        (int)compression);
    int rc = rn_image_check(img, path, err);
    if (rc)
        return rc;
    rad_output *out = NULL;
    rc = rad_output_open(path, &out, err);
    if (rc)
        return rc;

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet;
    init.write_fn = exr_to_output;
    init.user_data = out;
    exr_context_t ctx = NULL;
    int part = 0;
    exr_msg[0] = '\0';
    exr_result_t rv = exr_start_write(&ctx, rad_output_temp(out), EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS) {
        rc = rad_fail(err, RAD_ERR_IO, "%s: cannot create '%s': %s", path, rad_output_temp(out),
                      exr_why(rv));
        if (ctx)
            exr_finish(&ctx);
        rad_output_abort(out);
        return rc;
    }
    rv = exr_add_part(ctx, "radiance", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctx, part, (int32_t)img->width, (int32_t)img->height,
                                                 codec[compression]);
    for (uint32_t c = 0; c < img->channels && rv == EXR_ERR_SUCCESS; c++) {
        char name[16];
        band_name(img->channels, c, name, sizeof name);
        rv = exr_add_channel(ctx, part, name, EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1);
    }
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctx);
    if (rv != EXR_ERR_SUCCESS)
        rc = rad_fail(err, RAD_ERR_IO, "%s: OpenEXR header: %s", path, exr_why(rv));
    else
        rc = write_pixels(ctx, part, img, path, err);
    rv = exr_finish(&ctx);
    if (!rc && rv != EXR_ERR_SUCCESS)
        rc = rad_fail(err, RAD_ERR_IO, "%s: OpenEXR: finishing '%s': %s", path,
                      rad_output_temp(out), exr_why(rv));
    if (rc) {
        rad_output_abort(out);
        return rc;
    }
    return rad_output_commit_later(out, committer, err);
}
