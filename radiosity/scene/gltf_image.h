/* gltf_image.h - private to the glTF loader: the image decoder
 * (gltf_image.c, the only user of stb_image), callable from the C++ bridge.
 */
#ifndef RAD_GLTF_IMAGE_H
#define RAD_GLTF_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The largest image averaged, in texels: 8192 × 8192. */
#define RAD_GLTF_MAX_TEXELS ((uint64_t)8192 * 8192)

/* Decodes size bytes of PNG or JPEG and writes the mean linear RGB of its
 * texels (sRGB-decoded, alpha ignored) into mean.  An image of more than
 * max_texels texels is refused from its header, before decoding.  Returns
 * 0, or -1 with a one-line reason in why (caller's buffer). */
int rad_gltf_image_mean(const unsigned char *data, size_t size, uint64_t max_texels,
                        double mean[3], char *why, size_t why_size);

#ifdef __cplusplus
}
#endif

#endif /* RAD_GLTF_IMAGE_H */
