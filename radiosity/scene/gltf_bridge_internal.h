/* gltf_bridge_internal.h - private to the C++ files of the glTF bridge
 * (gltf_vet.cpp, gltf_bridge.cpp, gltf_texture.cpp); C never includes it.
 *
 * The bridge reads a document in two passes kept in separate files so that
 * neither recompiles the other's heavy headers: gltf_vet.cpp reads the raw
 * bytes with nlohmann::json and hands back a vetted document (vet_document
 * below); gltf_bridge.cpp lets tinygltf parse that and turns tinygltf's
 * Model into the plain-C rad_gltf_raw, and gltf_texture.cpp finds the
 * materials' texture images and has them averaged.  tinygltf's implementation is
 * compiled once, in tinygltf_impl.cpp, which does not include this header
 * (an edit here must not recompile it).  This header names neither library,
 * so including it costs nothing.
 *
 * Invariant: errors travel as bridge_error (thrown by fail) up to
 * rad_gltf_bridge_load, which turns them and every other exception into a
 * result code and message; nothing declared here lets an exception or a C++
 * type out of the bridge.
 */
#ifndef RAD_GLTF_BRIDGE_INTERNAL_H
#define RAD_GLTF_BRIDGE_INTERNAL_H

#ifndef __cplusplus
#error "gltf_bridge_internal.h is C++ only"
#endif

#include "gltf_bridge.h"

#include <cmath>
#include <cstdarg>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <new>
#include <string>
#include <vector>

namespace tinygltf {
class Model;
}

namespace rad_gltf {

/* ------------------------------------------------------------------ limits */

/* Inputs above 2 GiB are refused: tinygltf takes lengths as unsigned int. */
const size_t kMaxDocument = (size_t)1 << 31;

/* ------------------------------------------------------------------ errors */

struct bridge_error {
    int code; /* rad_result */
    std::string msg;
};

[[noreturn]] inline void fail(int code, const std::string &msg)
{
    throw bridge_error{code, msg};
}

inline std::string format(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
inline std::string format(const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    return std::string(buf);
}

/* Names quoted in messages are cut so that a hostile 1 MB name cannot push
 * the useful part of a message out of its 1024 bytes. */
inline std::string q(const std::string &name)
{
    std::string s = name.size() > 80 ? name.substr(0, 77) + "..." : name;
    return "'" + s + "'";
}

/* tinygltf's and nlohmann's messages may end with newlines and hold several
 * lines; the first says what went wrong. */
inline std::string first_line(const std::string &s)
{
    size_t a = s.find_first_not_of(" \n\r\t");
    if (a == std::string::npos)
        return std::string();
    size_t b = s.find_first_of("\n\r", a);
    std::string line = s.substr(a, b == std::string::npos ? std::string::npos : b - a);
    return line.size() > 300 ? line.substr(0, 297) + "..." : line;
}

/* A malloc'ed copy of s for the plain-C rad_gltf_raw (freed by
 * rad_gltf_raw_free); throws std::bad_alloc when memory runs out. */
inline char *dup_c(const std::string &s)
{
    char *p = static_cast<char *>(malloc(s.size() + 1));
    if (!p)
        throw std::bad_alloc();
    memcpy(p, s.c_str(), s.size() + 1);
    return p;
}

/* Little-endian 32-bit word, as .glb headers and glTF buffers store them. */
inline uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* ------------------------------------------------------ the vetted document */

/* One entry of extensions.KHR_lights_punctual.lights, glTF's defaults filled
 * in.  tinygltf 2.7 checks little of it, so gltf_vet.cpp reads it from the
 * JSON itself. */
struct light_def {
    std::string name;
    int type = RAD_GLTF_LIGHT_POINT;
    double color[3] = {1, 1, 1};
    double intensity = 1.0;
    double inner = 0.0, outer = M_PI / 4;
    bool has_range = false; /* given, and ignored: light falls off as 1/r² */
};

/* One entry of `images`, as far as the vet pass could read it: tinygltf
 * never sees images (it would read a buffer view's bytes unchecked), so
 * gltf_texture.cpp finds their bytes itself.  A malformed entry is not an
 * error of the document: it makes the textures using it unreadable. */
struct image_def {
    std::string name;
    std::string uri;        /* data URI or relative path; empty with a buffer view */
    int64_t buffer_view = -1;
    std::string problem;    /* non-empty: why the entry cannot be used */
};

/* One entry of `textures`: the image it samples (-1 = none, e.g. only an
 * EXT_texture_webp source). */
struct texture_def {
    int64_t source = -1;
    int64_t sampler = -1;   /* -1 = none (glTF's defaults) */
    std::string problem;    /* non-empty: why the entry cannot be used */
};

/* One entry of `samplers`, as far as it reads: glTF's numbers, 0 where a
 * member is absent or not an integer (a bake then writes none). */
struct sampler_def {
    int wrap_s = 0, wrap_t = 0, mag_filter = 0, min_filter = 0;
};

/* Which files tinygltf may open: gltf_vet.cpp fills `sizes` with the vetted
 * external buffers, gltf_bridge.cpp's file callbacks open only those. */
struct fs_context {
    bool allow_external = false;
    std::string prefix;                  /* base_dir with a trailing '/' */
    std::map<std::string, size_t> sizes; /* vetted path -> byteLength */
    std::string failure;                 /* first file problem, for the message */
};

/* The document as tinygltf is to see it. */
struct vetted_doc {
    bool binary = false;              /* .glb: parse `glb`; else parse `json` */
    std::string json;                 /* the kept members only, as JSON text */
    std::vector<unsigned char> glb;   /* a fresh .glb around `json` and the BIN chunk */
    std::vector<light_def> lights;    /* KHR_lights_punctual.lights, type-checked */
    std::vector<texture_def> textures;
    std::vector<image_def> images;
    std::vector<sampler_def> samplers;
    std::vector<bool> metallic;       /* per material: metallicFactor given and > 0 */
    size_t animations = 0, skins = 0; /* entries of the dropped arrays, for the notes */
};

/* Reads `size` bytes of .gltf or .glb (told apart by the "glTF" magic):
 * checks the container and the JSON nesting depth, reads the lights, keeps
 * only the top-level members a radiosity scene uses and vets the external
 * buffer URIs into fs.sizes (fs.allow_external and fs.prefix set by the
 * caller).  Throws bridge_error on bad input.  gltf_vet.cpp. */
vetted_doc vet_document(const void *data, size_t size, fs_context &fs);

/* A relative path below the document's directory: not empty, not absolute,
 * no backslash, colon or NUL, no ".." component.  gltf_vet.cpp. */
bool confined_path(const std::string &path);

/* Fills the textures of every used material of raw (raw->materials, after
 * the meshes have marked them used): the image each names, its bytes (a
 * buffer view of m, a data URI, or a file below fs.prefix) and their mean
 * colour (gltf_image.c).  A texture that cannot be read is marked so, with
 * the reason; only running out of memory throws.  gltf_texture.cpp. */
void convert_textures(const tinygltf::Model &m, const vetted_doc &doc, const fs_context &fs,
                      rad_gltf_raw *raw);

} /* namespace rad_gltf */

#endif /* RAD_GLTF_BRIDGE_INTERNAL_H */
