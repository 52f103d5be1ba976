/* tinygltf_uri.h - private to the glTF bridge: tinygltf's own URI handling,
 * reachable without including tiny_gltf.h.
 *
 * gltf_vet.cpp vets buffer URIs exactly as tinygltf will read them, so it
 * must use tinygltf's data-URI test and percent-decoding rather than a copy
 * (the decoder is static inside tinygltf's implementation).  Both are
 * defined in tinygltf_impl.cpp.  This header stays apart from
 * gltf_bridge_internal.h so that tinygltf_impl.cpp, the bridge's slow object,
 * depends on nothing that changes when the bridge grows.
 */
#ifndef RAD_TINYGLTF_URI_H
#define RAD_TINYGLTF_URI_H

#ifndef __cplusplus
#error "tinygltf_uri.h is C++ only"
#endif

#include <string>

namespace rad_gltf {

/* tinygltf::IsDataURI: a base64 data URI of a type tinygltf decodes. */
bool tinygltf_is_data_uri(const std::string &uri);

/* tinygltf's percent-decoding of a URI into the path it opens. */
std::string tinygltf_urldecode(const std::string &uri);

} /* namespace rad_gltf */

#endif /* RAD_TINYGLTF_URI_H */
