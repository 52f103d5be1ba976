/* rn_internal.h - what render.c shares with the two image writers.
 *
 * Private to render/: the public contract stays render.h.  Both writers check
 * an image the same way and write through a rad_output (rad.h), so that a
 * failed write never touches the file already at `path`.
 */
#ifndef RN_INTERNAL_H
#define RN_INTERNAL_H

#include "render.h"

/* Largest width or height an image may have (rn_render, the writers, rn_read_exr). */
#define RN_MAX_SIDE 16384u

/* RAD_OK when img has 1..RN_MAX_SIDE pixels a side, 1..RAD_MAX_BANDS channels
 * and pixels; else RAD_ERR_USAGE naming `path`. */
int rn_image_check(const rn_image *img, const char *path, rad_error *err);

/* A zeroed image of the given size with every patch id RAD_NONE; NULL when
 * memory runs out.  Sizes must already be checked.  Caller owns. */
rn_image *rn_image_alloc(uint32_t width, uint32_t height, uint32_t channels);

#endif /* RN_INTERNAL_H */
