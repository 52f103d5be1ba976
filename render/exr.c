/* exr.c - OpenEXR output and input of rendered images (OpenEXR Core C API).
 *
 * The only file that includes OpenEXR.  Images are linear radiance, one float
 * channel per band: R,G,B for three bands, Y for one, B0..Bk otherwise;
 * scanline storage, uncompressed by default, ZIP, RLE or PIZ on request (rn_exr_compression).  Invariant: a write goes through a
 * rad_output, so it either renames a complete temporary onto path or leaves
 * path exactly as it was and no temporary file behind.  The library's own messages are caught by a
 * handler (library code never prints) and end up in the rad_error.
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

int rn_read_exr(const char *path, rn_image **out, rad_error *err)
{
    if (!out)
        return rad_fail(err, RAD_ERR_USAGE, "%s: no output pointer", path ? path : "(no path)");
    *out = NULL;
    if (!path || !path[0])
        return rad_fail(err, RAD_ERR_USAGE, "(no path): empty input path");

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet;
    init.flags = EXR_CONTEXT_FLAG_SILENT_HEADER_PARSE;
    exr_context_t ctx = NULL;
    exr_msg[0] = '\0';
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        int code = rv == EXR_ERR_FILE_ACCESS ? RAD_ERR_IO : RAD_ERR_PARSE;
        int rc = rad_fail(err, code, "%s: cannot read as OpenEXR: %s", path, exr_why(rv));
        if (ctx)
            exr_finish(&ctx);
        return rc;
    }

    int rc = RAD_OK, count = 0;
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    rn_image *img = NULL;
    if (exr_get_count(ctx, &count) != EXR_ERR_SUCCESS || count < 1 ||
        exr_get_storage(ctx, 0, &storage) != EXR_ERR_SUCCESS || storage != EXR_STORAGE_SCANLINE ||
        exr_get_data_window(ctx, 0, &dw) != EXR_ERR_SUCCESS ||
        exr_get_channels(ctx, 0, &chl) != EXR_ERR_SUCCESS || !chl) {
        rc = rad_fail(err, RAD_ERR_PARSE, "%s: not a scanline OpenEXR image", path);
        goto done;
    }
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, h = (int64_t)dw.max.y - dw.min.y + 1;
    if (w < 1 || h < 1 || w > RN_MAX_SIDE || h > RN_MAX_SIDE) {
        rc = rad_fail(err, RAD_ERR_PARSE, "%s: image size %lldx%lld outside 1..%u", path,
                      (long long)w, (long long)h, RN_MAX_SIDE);
        goto done;
    }
    /* Which of our layouts: R,G,B, else Y, else B0..Bk. */
    uint32_t bands = 0;
    int has_r = 0, has_g = 0, has_b = 0, has_y = 0;
    for (int c = 0; c < chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[c];
        const char *nm = e->name.str ? e->name.str : "";
        has_r |= !strcmp(nm, "R");
        has_g |= !strcmp(nm, "G");
        has_b |= !strcmp(nm, "B");
        has_y |= !strcmp(nm, "Y");
    }
    if (has_r && has_g && has_b)
        bands = 3;
    else if (has_y)
        bands = 1;
    else {
        while (bands < RAD_MAX_BANDS) {
            char name[16];
            int found = 0;
            band_name(RAD_MAX_BANDS, bands, name, sizeof name);
            for (int c = 0; c < chl->num_channels; c++)
                found |= chl->entries[c].name.str && !strcmp(chl->entries[c].name.str, name);
            if (!found)
                break;
            bands++;
        }
        if (bands == 3 || bands == 1)
            bands = 0; /* B0..B2 or B0 alone is not a layout we write */
    }
    if (bands == 0) {
        rc = rad_fail(err, RAD_ERR_PARSE, "%s: no R,G,B, Y or B0.. channels", path);
        goto done;
    }
    for (int c = 0; c < chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[c];
        if (e->name.str && band_of(bands, e->name.str) >= 0 &&
            ((e->pixel_type != EXR_PIXEL_FLOAT && e->pixel_type != EXR_PIXEL_HALF) ||
             e->x_sampling != 1 || e->y_sampling != 1)) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: channel '%s' is not full-resolution half or float",
                          path, e->name.str);
            goto done;
        }
    }
    img = rn_image_alloc((uint32_t)w, (uint32_t)h, bands);
    if (!img) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for a %lldx%lld image", path,
                      (long long)w, (long long)h);
        goto done;
    }

    int32_t lines = 0;
    rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    if (rv != EXR_ERR_SUCCESS || lines < 1) {
        rc = rad_fail(err, RAD_ERR_PARSE, "%s: OpenEXR: %s", path, exr_why(rv));
        goto done;
    }
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int started = 0;
    size_t line_floats = (size_t)w * bands;
    for (int64_t y = dw.min.y; y <= dw.max.y && !rc; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_read_scanline_chunk_info(ctx, 0, (int)y, &cinfo);
        if (rv == EXR_ERR_SUCCESS)
            rv = started ? exr_decoding_update(ctx, 0, &cinfo, &dec)
                         : exr_decoding_initialize(ctx, 0, &cinfo, &dec);
        if (rv != EXR_ERR_SUCCESS) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: scanline %lld: %s", path, (long long)y, exr_why(rv));
            break;
        }
        started = 1;
        int64_t row = (int64_t)cinfo.start_y - dw.min.y;
        if (row < 0 || row + cinfo.height > h || cinfo.width != w) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: scanline %lld: chunk outside the image", path,
                          (long long)y);
            break;
        }
        for (int16_t c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            int band = band_of(bands, ch->channel_name);
            ch->decode_to_ptr = band < 0 ? NULL
                                         : (uint8_t *)(img->pixels + (size_t)row * line_floats + (size_t)band);
            ch->user_pixel_stride = (int32_t)(bands * sizeof(float));
            ch->user_line_stride = (int32_t)(line_floats * sizeof(float));
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
        }
        rv = exr_decoding_choose_default_routines(ctx, 0, &dec);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_decoding_run(ctx, 0, &dec);
        if (rv != EXR_ERR_SUCCESS)
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: scanline %lld: %s", path, (long long)y, exr_why(rv));
    }
    if (started)
        exr_decoding_destroy(ctx, &dec);

done:
    exr_finish(&ctx);
    if (rc) {
        rn_image_destroy(img);
        return rc;
    }
    *out = img;
    return RAD_OK;
}
