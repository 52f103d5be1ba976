/* exr_read.c - the test-only OpenEXR reader of exr_read.h.
 *
 * Owns the reading side the library does not need: the file is opened
 * with the OpenEXR Core C API, its channel list mapped onto the bands of
 * one of the writers' layouts (channel_band), and each scanline chunk
 * decoded straight into the image, converted to float.  Errors are
 * values (a rad_error naming the file), never printed.
 * Invariant: on any failure the context is finished, the half-made image
 * freed and *out left NULL.
 */
#include "exr_read.h"

#include "../render/rn_internal.h"

#include <openexr.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* OpenEXR's own messages are dropped (its default handler prints them);
 * a failure is told by the code's default text, enough for a test. */
static void quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt, (void)code, (void)msg;
}

static const char *why(exr_result_t rv) { return exr_get_default_error_message(rv); }

/* The band that channel `name` holds in an image of `bands` bands, as the
 * writers name them (R, G, B for three; Y for one; B0, B1, ... otherwise);
 * -1 for a channel of no band. */
static int channel_band(uint32_t bands, const char *name)
{
    if (bands == 3) {
        const char *hit = strlen(name) == 1 ? strchr("RGB", name[0]) : NULL;
        return hit ? (int)(hit - "RGB") : -1;
    }
    if (bands == 1)
        return strcmp(name, "Y") == 0 ? 0 : -1;
    if (name[0] != 'B' || name[1] < '0' || name[1] > '9' || (name[1] == '0' && name[2]))
        return -1;
    char *end = NULL;
    unsigned long b = strtoul(name + 1, &end, 10);
    return *end == '\0' && b < bands ? (int)b : -1;
}

/* Is there a channel named `name`? */
static int has_channel(const exr_attr_chlist_t *chl, const char *name)
{
    for (int c = 0; c < chl->num_channels; c++)
        if (chl->entries[c].name.str && strcmp(chl->entries[c].name.str, name) == 0)
            return 1;
    return 0;
}

/* Which of the writers' layouts the channels make: 3 (R, G, B), 1 (Y), or
 * B0..Bk with k + 1 bands other than 1 and 3 (the writers use R,G,B and Y
 * for those); 0 for none. */
static uint32_t layout_bands(const exr_attr_chlist_t *chl)
{
    if (has_channel(chl, "R") && has_channel(chl, "G") && has_channel(chl, "B"))
        return 3;
    if (has_channel(chl, "Y"))
        return 1;
    uint32_t bands = 0;
    char name[16];
    while (bands < RAD_MAX_BANDS && (snprintf(name, sizeof name, "B%u", bands), has_channel(chl, name)))
        bands++;
    return bands == 3 || bands == 1 ? 0 : bands;
}

/* The data window and band count of part 0, checked: scanlines, a size
 * within 1..RN_MAX_SIDE, a known layout whose channels are full-resolution
 * half or float. */
static int read_header(exr_context_t ctx, const char *path, exr_attr_box2i_t *dw, uint32_t *bands,
                       rad_error *err)
{
    int count = 0;
    exr_storage_t storage;
    const exr_attr_chlist_t *chl = NULL;
    if (exr_get_count(ctx, &count) != EXR_ERR_SUCCESS || count < 1 ||
        exr_get_storage(ctx, 0, &storage) != EXR_ERR_SUCCESS || storage != EXR_STORAGE_SCANLINE ||
        exr_get_data_window(ctx, 0, dw) != EXR_ERR_SUCCESS ||
        exr_get_channels(ctx, 0, &chl) != EXR_ERR_SUCCESS || !chl)
        return rad_fail(err, RAD_ERR_PARSE, "%s: not a scanline OpenEXR image", path);
    int64_t w = (int64_t)dw->max.x - dw->min.x + 1, h = (int64_t)dw->max.y - dw->min.y + 1;
    if (w < 1 || h < 1 || w > RN_MAX_SIDE || h > RN_MAX_SIDE)
        return rad_fail(err, RAD_ERR_PARSE, "%s: image size %lldx%lld outside 1..%u", path,
                        (long long)w, (long long)h, RN_MAX_SIDE);
    *bands = layout_bands(chl);
    if (*bands == 0)
        return rad_fail(err, RAD_ERR_PARSE, "%s: no R,G,B, Y or B0.. channels", path);
    for (int c = 0; c < chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[c];
        if (e->name.str && channel_band(*bands, e->name.str) >= 0 &&
            ((e->pixel_type != EXR_PIXEL_FLOAT && e->pixel_type != EXR_PIXEL_HALF) ||
             e->x_sampling != 1 || e->y_sampling != 1))
            return rad_fail(err, RAD_ERR_PARSE,
                            "%s: channel '%s' is not full-resolution half or float", path,
                            e->name.str);
    }
    return RAD_OK;
}

/* Points each channel of a decoder set up for the chunk starting at image
 * row `row` at its band of img (float), or nowhere for a channel of no
 * band. */
static void aim_channels(exr_decode_pipeline_t *dec, rn_image *img, int64_t row)
{
    const uint32_t bands = img->channels;
    const size_t line_floats = (size_t)img->width * bands;
    for (int16_t c = 0; c < dec->channel_count; c++) {
        exr_coding_channel_info_t *ch = &dec->channels[c];
        int band = channel_band(bands, ch->channel_name);
        ch->decode_to_ptr = band < 0 ? NULL
                                     : (uint8_t *)(img->pixels + (size_t)row * line_floats +
                                                   (size_t)band);
        ch->user_pixel_stride = (int32_t)(bands * sizeof(float));
        ch->user_line_stride = (int32_t)(line_floats * sizeof(float));
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
    }
}

/* Decodes every scanline chunk of part 0 into img. */
static int read_pixels(exr_context_t ctx, const char *path, const exr_attr_box2i_t *dw,
                       rn_image *img, rad_error *err)
{
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    if (rv != EXR_ERR_SUCCESS || lines < 1)
        return rad_fail(err, RAD_ERR_PARSE, "%s: OpenEXR: %s", path, why(rv));
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int started = 0, rc = RAD_OK;
    for (int64_t y = dw->min.y; y <= dw->max.y && !rc; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_read_scanline_chunk_info(ctx, 0, (int)y, &cinfo);
        if (rv == EXR_ERR_SUCCESS)
            rv = started ? exr_decoding_update(ctx, 0, &cinfo, &dec)
                         : exr_decoding_initialize(ctx, 0, &cinfo, &dec);
        if (rv != EXR_ERR_SUCCESS) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: scanline %lld: %s", path, (long long)y, why(rv));
            break;
        }
        started = 1;
        int64_t row = (int64_t)cinfo.start_y - dw->min.y;
        if (row < 0 || row + cinfo.height > (int64_t)img->height || cinfo.width != (int)img->width) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: scanline %lld: chunk outside the image", path,
                          (long long)y);
            break;
        }
        aim_channels(&dec, img, row);
        rv = exr_decoding_choose_default_routines(ctx, 0, &dec);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_decoding_run(ctx, 0, &dec);
        if (rv != EXR_ERR_SUCCESS)
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: scanline %lld: %s", path, (long long)y, why(rv));
    }
    if (started)
        exr_decoding_destroy(ctx, &dec);
    return rc;
}

int test_read_exr(const char *path, rn_image **out, rad_error *err)
{
    if (!out)
        return rad_fail(err, RAD_ERR_USAGE, "%s: no output pointer", path ? path : "(no path)");
    *out = NULL;
    if (!path || !path[0])
        return rad_fail(err, RAD_ERR_USAGE, "(no path): empty input path");
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    init.flags = EXR_CONTEXT_FLAG_SILENT_HEADER_PARSE;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        int code = rv == EXR_ERR_FILE_ACCESS ? RAD_ERR_IO : RAD_ERR_PARSE;
        int rc = rad_fail(err, code, "%s: cannot read as OpenEXR: %s", path, why(rv));
        if (ctx)
            exr_finish(&ctx);
        return rc;
    }
    exr_attr_box2i_t dw;
    uint32_t bands = 0;
    rn_image *img = NULL;
    int rc = read_header(ctx, path, &dw, &bands, err);
    if (!rc) {
        uint32_t w = (uint32_t)((int64_t)dw.max.x - dw.min.x + 1);
        uint32_t h = (uint32_t)((int64_t)dw.max.y - dw.min.y + 1);
        img = rn_image_alloc(w, h, bands);
        if (!img)
            rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory for a %ux%u image", path, w, h);
    }
    if (!rc)
        rc = read_pixels(ctx, path, &dw, img, err);
    exr_finish(&ctx);
    if (rc) {
        rn_image_destroy(img);
        return rc;
    }
    *out = img;
    return RAD_OK;
}
