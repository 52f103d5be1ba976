/* tinygltf_config.h - private to the glTF bridge: the one way tinygltf is
 * configured and included.
 *
 * Invariant: every translation unit that includes tiny_gltf.h does so through
 * this header, so the TINYGLTF_* switches below are the same in all of them.
 * They must be: they change the default members of tinygltf's classes
 * (TinyGLTF's file and image callbacks), and two objects that disagree would
 * break C++'s one-definition rule without a diagnostic.  Only
 * tinygltf_impl.cpp defines TINYGLTF_IMPLEMENTATION before including it, so
 * tinygltf's code (and the nlohmann::json it parses with) is compiled once.
 *
 * tinygltf never decodes images (it never sees them: gltf_texture.cpp finds
 * a texture's bytes and gltf_image.c averages them), never writes glTF, and
 * gets our own vetted file callbacks instead of its own.
 */
#ifndef RAD_TINYGLTF_CONFIG_H
#define RAD_TINYGLTF_CONFIG_H

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#define TINYGLTF_NO_FS
#include <tiny_gltf.h>

#endif /* RAD_TINYGLTF_CONFIG_H */
