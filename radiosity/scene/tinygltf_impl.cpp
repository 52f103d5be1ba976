/* tinygltf_impl.cpp - tinygltf's implementation, compiled once.
 *
 * tinygltf is a single header whose code is instantiated where
 * TINYGLTF_IMPLEMENTATION is defined; that code (with nlohmann::json under
 * it) takes most of the bridge's compile time, so it lives alone here and an
 * edit to the bridge does not recompile it.  Invariant: this is the only file
 * that defines TINYGLTF_IMPLEMENTATION, and it configures tinygltf through
 * tinygltf_config.h like every other user.  Besides the library it defines
 * only the two wrappers of tinygltf_uri.h over tinygltf's URI handling, which
 * the rest of the bridge cannot reach (the decoder is static).  Of our
 * headers it includes only those two, so that an edit elsewhere in the bridge
 * (gltf_bridge.h, gltf_bridge_internal.h, ../core/rad.h) never recompiles it.
 */
#include <fstream> /* tinygltf 2.7 uses std::ofstream even with TINYGLTF_NO_FS */

#define TINYGLTF_IMPLEMENTATION
#include "tinygltf_config.h"

#include "tinygltf_uri.h"

bool rad_gltf::tinygltf_is_data_uri(const std::string &uri)
{
    return tinygltf::IsDataURI(uri);
}

std::string rad_gltf::tinygltf_urldecode(const std::string &uri)
{
    return tinygltf::dlib::urldecode(uri);
}
