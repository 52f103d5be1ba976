/* gltf_bridge.cpp - the project's only C++: tinygltf behind one C function.
 *
 * It owns everything about reading a glTF 2.0 document (.gltf or .glb) and
 * turning it into the plain-C rad_gltf_raw of gltf_bridge.h: node
 * hierarchy to world matrices, accessors to double positions and uint32
 * triangle indices, materials, cameras and KHR_lights_punctual lights as
 * numbers.  The lights are read here from the JSON itself (tinygltf checks
 * little of them), before the top-level `extensions` member is dropped.
 *
 * Invariant: no exception and no C++ type leaves this file, and no input can
 * make it read outside a buffer, recurse without bound, allocate more than
 * the document's own data justifies, or open a file outside base_dir.  To
 * keep tinygltf's parser away from what it does not check (image buffer
 * views, deep recursion in extras), the JSON is first read here with
 * nlohmann::json, its nesting depth bounded, the parts of glTF a radiosity
 * scene never needs (images, textures, animations, skins, ...) removed and
 * external buffer URIs vetted; only then does tinygltf parse it.  Every index
 * and size tinygltf leaves unchecked is checked below before it is used.
 */
#include "gltf_bridge.h"
#include "../core/rad.h"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream> /* tinygltf 2.7 uses std::ofstream even with TINYGLTF_NO_FS */
#include <map>
#include <memory>
#include <new>
#include <string>
#include <vector>

/* We never decode images (a radiosity scene has no textures), never write
 * glTF, and give tinygltf our own vetted file callbacks instead of its own. */
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#define TINYGLTF_NO_FS
#include <tiny_gltf.h>

namespace {

/* ------------------------------------------------------------------ limits */

/* Inputs above 2 GiB are refused: tinygltf takes lengths as unsigned int. */
const size_t kMaxDocument = (size_t)1 << 31;
/* A JSON nesting depth no glTF needs (materials with extensions reach ~6);
 * tinygltf and nlohmann's dump recurse once per level. */
const int kMaxDepth = 64;
const uint64_t kMaxVertices = 100000000;  /* per primitive */
const uint64_t kMaxIndices = 300000000;   /* per primitive */

/* ------------------------------------------------------------------ errors */

struct bridge_error {
    int code;
    std::string msg;
};

std::string format(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    return std::string(buf);
}

[[noreturn]] void fail(int code, const std::string &msg)
{
    throw bridge_error{code, msg};
}

/* Names quoted in messages are cut so that a hostile 1 MB name cannot push
 * the useful part of a message out of its 1024 bytes. */
std::string q(const std::string &name)
{
    std::string s = name.size() > 80 ? name.substr(0, 77) + "..." : name;
    return "'" + s + "'";
}

/* tinygltf's messages end with newlines and may hold several lines; the
 * first says what went wrong. */
std::string first_line(const std::string &s)
{
    size_t a = s.find_first_not_of(" \n\r\t");
    if (a == std::string::npos)
        return std::string();
    size_t b = s.find_first_of("\n\r", a);
    std::string line = s.substr(a, b == std::string::npos ? std::string::npos : b - a);
    return line.size() > 300 ? line.substr(0, 297) + "..." : line;
}

/* ------------------------------------------------------------ byte helpers */

uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

void put_le32(std::vector<unsigned char> &v, uint32_t x)
{
    for (int k = 0; k < 4; k++)
        v.push_back((unsigned char)(x >> (8 * k)));
}

float le_float(const unsigned char *p)
{
    uint32_t u = le32(p);
    float f;
    static_assert(sizeof f == sizeof u, "float must be 32 bits");
    memcpy(&f, &u, sizeof f);
    return f;
}

/* --------------------------------------------------------------- .glb split */

struct glb_parts {
    const unsigned char *json = nullptr;
    size_t json_size = 0;
    const unsigned char *bin = nullptr; /* nullptr: no BIN chunk */
    size_t bin_size = 0;
};

/* Reads the binary container's header and chunk table; every length is
 * checked against the bytes actually present. */
glb_parts split_glb(const unsigned char *d, size_t size)
{
    glb_parts g;
    if (size < 12)
        fail(RAD_ERR_PARSE, format("truncated .glb: %zu bytes, the header alone needs 12", size));
    uint32_t version = le32(d + 4), length = le32(d + 8);
    if (version != 2)
        fail(RAD_ERR_PARSE, format(".glb container version %u (only 2 is supported)", version));
    if (length > size)
        fail(RAD_ERR_PARSE,
             format("truncated .glb: the header says %u bytes but only %zu are present", length,
                    size));
    size_t n = length;
    if (n < 20)
        fail(RAD_ERR_PARSE, format("truncated .glb: %zu bytes, no room for the JSON chunk", n));
    uint32_t c0len = le32(d + 12), c0type = le32(d + 16);
    if (c0type != 0x4E4F534Au)
        fail(RAD_ERR_PARSE, ".glb: the first chunk is not JSON");
    if (c0len > n - 20)
        fail(RAD_ERR_PARSE,
             format("truncated .glb: the JSON chunk of %u bytes runs past the end (%zu bytes "
                    "left)",
                    c0len, n - 20));
    g.json = d + 20;
    g.json_size = c0len;
    size_t off = 20 + (size_t)c0len;
    if (n - off >= 8) {
        uint32_t c1len = le32(d + off), c1type = le32(d + off + 4);
        if (c1type == 0x004E4942u) {
            if (c1len > n - off - 8)
                fail(RAD_ERR_PARSE,
                     format("truncated .glb: the BIN chunk of %u bytes runs past the end (%zu "
                            "bytes left)",
                            c1len, n - off - 8));
            g.bin = d + off + 8;
            g.bin_size = c1len;
        }
        /* Any other chunk type is an extension's: the specification says to
         * ignore it. */
    } else if (n - off > 0) {
        fail(RAD_ERR_PARSE,
             format("truncated .glb: %zu stray bytes after the JSON chunk", n - off));
    }
    return g;
}

/* A fresh, well-formed .glb around the filtered JSON and the original BIN
 * payload, in the exact layout tinygltf's reader expects. */
std::vector<unsigned char> build_glb(const std::string &json, const glb_parts &g)
{
    size_t jpad = (4 - json.size() % 4) % 4;
    size_t blen = g.bin ? g.bin_size : 0;
    size_t bpad = (4 - blen % 4) % 4;
    size_t total = 12 + 8 + json.size() + jpad + (blen ? 8 + blen + bpad : 0);
    if (total > kMaxDocument)
        fail(RAD_ERR_LIMIT, format(".glb of %zu bytes is larger than the 2 GiB limit", total));
    std::vector<unsigned char> v;
    v.reserve(total);
    v.insert(v.end(), {'g', 'l', 'T', 'F'});
    put_le32(v, 2);
    put_le32(v, (uint32_t)total);
    put_le32(v, (uint32_t)(json.size() + jpad));
    put_le32(v, 0x4E4F534Au);
    v.insert(v.end(), json.begin(), json.end());
    v.insert(v.end(), jpad, ' ');
    if (blen) {
        put_le32(v, (uint32_t)(blen + bpad));
        put_le32(v, 0x004E4942u);
        v.insert(v.end(), g.bin, g.bin + blen);
        v.insert(v.end(), bpad, 0);
    }
    return v;
}

/* ------------------------------------------------------------- JSON vetting */

/* Nesting depth of a JSON text, by a plain scan (strings skipped), so that
 * no recursive code ever sees a document nested deeper than kMaxDepth. */
void check_depth(const unsigned char *p, size_t n)
{
    int depth = 0;
    bool in_string = false;
    for (size_t k = 0; k < n; k++) {
        unsigned char c = p[k];
        if (in_string) {
            if (c == '\\')
                k++;
            else if (c == '"')
                in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxDepth)
                fail(RAD_ERR_PARSE,
                     format("JSON nested more than %d levels deep at byte %zu", kMaxDepth, k));
        } else if (c == ']' || c == '}') {
            depth--;
        }
    }
}

/* Only these top-level members reach tinygltf; the rest (images, textures,
 * samplers, animations, skins, extensions such as lights) carry nothing a
 * diffuse radiosity scene uses, and leaving them out means they can neither
 * trigger image decoding nor unchecked buffer reads. */
const char *const kKeptMembers[] = {"asset",     "scene",       "scenes",    "nodes",
                                    "meshes",    "accessors",   "bufferViews", "buffers",
                                    "materials", "cameras",     "extensionsUsed",
                                    "extensionsRequired"};

struct fs_context {
    bool allow_external = false;
    std::string prefix;                  /* base_dir with a trailing '/' */
    std::map<std::string, size_t> sizes; /* vetted path -> byteLength */
    std::string failure;                 /* first file problem, for the message */
};

/* External buffer URIs are relative paths inside base_dir: no scheme, no
 * absolute path, no '..' component (checked after the same percent-decoding
 * tinygltf applies, so "%2e%2e" cannot sneak through). */
void vet_buffers(const nlohmann::json &doc, fs_context &fs)
{
    auto it = doc.find("buffers");
    if (it == doc.end() || !it->is_array())
        return;
    size_t index = 0;
    for (const auto &b : *it) {
        std::string where = format("buffer %zu", index++);
        if (!b.is_object())
            fail(RAD_ERR_PARSE, where + ": not a JSON object");
        auto u = b.find("uri");
        if (u == b.end())
            continue; /* the .glb BIN chunk */
        if (!u->is_string())
            fail(RAD_ERR_PARSE, where + ": uri is not a string");
        const std::string &uri = u->get_ref<const std::string &>();
        if (uri.compare(0, 5, "data:") == 0) {
            if (!tinygltf::IsDataURI(uri))
                fail(RAD_ERR_PARSE,
                     where + ": unsupported data URI (only base64 "
                             "application/octet-stream or application/gltf-buffer)");
            continue;
        }
        std::string path = tinygltf::dlib::urldecode(uri);
        if (!fs.allow_external)
            fail(RAD_ERR_IO, where + ": external file " + q(path) +
                                 " not allowed (the document was not read from a file)");
        bool bad = path.empty() || path[0] == '/' || path.find('\\') != std::string::npos ||
                   path.find(':') != std::string::npos || path.find('\0') != std::string::npos;
        size_t start = 0;
        while (!bad && start <= path.size()) {
            size_t slash = path.find('/', start);
            std::string part = path.substr(start, slash == std::string::npos ? std::string::npos
                                                                             : slash - start);
            if (part == "..")
                bad = true;
            if (slash == std::string::npos)
                break;
            start = slash + 1;
        }
        if (bad)
            fail(RAD_ERR_IO, where + ": external file " + q(path) +
                                 " refused (only relative paths below the document's "
                                 "directory, without '..')");
        auto bl = b.find("byteLength");
        if (bl == b.end() || !bl->is_number_unsigned())
            fail(RAD_ERR_PARSE, where + ": byteLength missing or not a non-negative integer");
        fs.sizes[fs.prefix + path] = bl->get<size_t>();
    }
}

/* tinygltf's file callbacks, confined to the vetted paths. */
bool fs_exists(const std::string &path, void *user)
{
    fs_context *fs = static_cast<fs_context *>(user);
    if (fs->sizes.find(path) == fs->sizes.end())
        return false;
    struct stat st;
    if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
        if (fs->failure.empty())
            fs->failure = "cannot open buffer file " + q(path) + ": " +
                          (errno ? std::string(strerror(errno)) : "not a regular file");
        return false;
    }
    return true;
}

std::string fs_expand(const std::string &path, void *)
{
    return path;
}

bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &path,
             void *user)
{
    fs_context *fs = static_cast<fs_context *>(user);
    auto it = fs->sizes.find(path);
    if (it == fs->sizes.end())
        return false;
    FILE *f = fopen(path.c_str(), "rb");
    if (!f) {
        if (fs->failure.empty())
            fs->failure = "cannot open buffer file " + q(path) + ": " + strerror(errno);
        return false;
    }
    struct stat st;
    bool ok = fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode);
    /* Compare with the declared byteLength before reading, so a huge file
     * is never loaded only to be refused. */
    if (ok && (uint64_t)st.st_size != (uint64_t)it->second) {
        if (fs->failure.empty())
            fs->failure = format("buffer file %s has %lld bytes, the document declares %zu",
                                 q(path).c_str(), (long long)st.st_size, it->second);
        ok = false;
    }
    if (ok) {
        out->resize(it->second);
        ok = it->second == 0 || fread(out->data(), 1, it->second, f) == it->second;
        if (!ok && fs->failure.empty())
            fs->failure = "cannot read buffer file " + q(path);
    }
    fclose(f);
    if (!ok && err)
        *err = "read failed";
    return ok;
}

bool fs_write(std::string *, const std::string &, const std::vector<unsigned char> &, void *)
{
    return false;
}

bool no_image(tinygltf::Image *, const int, std::string *, std::string *, int, int,
              const unsigned char *, int, void *)
{
    return true;
}

/* ----------------------------------------------------------- raw ownership */

char *dup_c(const std::string &s)
{
    char *p = static_cast<char *>(malloc(s.size() + 1));
    if (!p)
        throw std::bad_alloc();
    memcpy(p, s.c_str(), s.size() + 1);
    return p;
}

template <typename T> T *calloc_n(size_t n)
{
    T *p = static_cast<T *>(calloc(n ? n : 1, sizeof(T)));
    if (!p)
        throw std::bad_alloc();
    return p;
}

uint32_t count32(size_t n, const char *what)
{
    if (n > UINT32_MAX)
        fail(RAD_ERR_LIMIT, format("%zu %s, more than 2^32", n, what));
    return (uint32_t)n;
}

/* -------------------------------------------------------------- transforms */

void mat_identity(double m[16])
{
    for (int k = 0; k < 16; k++)
        m[k] = (k % 5 == 0) ? 1.0 : 0.0;
}

/* c = a·b for column-major 4×4 matrices. */
void mat_mul(const double a[16], const double b[16], double c[16])
{
    double r[16];
    for (int col = 0; col < 4; col++)
        for (int row = 0; row < 4; row++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += a[k * 4 + row] * b[col * 4 + k];
            r[col * 4 + row] = s;
        }
    memcpy(c, r, sizeof r);
}

std::string node_label(const tinygltf::Model &m, size_t i)
{
    const std::string &n = m.nodes[i].name;
    return n.empty() ? format("node %zu", i) : "node " + q(n);
}

/* The node's local matrix: its `matrix`, else T·R·S (glTF's order). */
void local_matrix(const tinygltf::Model &m, size_t i, double out[16])
{
    const tinygltf::Node &n = m.nodes[i];
    std::string where = node_label(m, i);
    if (!n.matrix.empty()) {
        if (n.matrix.size() != 16)
            fail(RAD_ERR_PARSE,
                 format("%s: matrix has %zu numbers, expected 16", where.c_str(), n.matrix.size()));
        for (int k = 0; k < 16; k++)
            out[k] = n.matrix[k];
        /* glTF requires a matrix decomposable into T·R·S, so its last row is
         * (0 0 0 1); a projective one would bend planar polygons. */
        if (std::fabs(out[3]) > 1e-9 || std::fabs(out[7]) > 1e-9 || std::fabs(out[11]) > 1e-9 ||
            std::fabs(out[15] - 1.0) > 1e-9)
            fail(RAD_ERR_PARSE, where + ": matrix is not affine (last row is not 0 0 0 1)");
        out[3] = out[7] = out[11] = 0.0;
        out[15] = 1.0;
    } else {
        double t[3] = {0, 0, 0}, r[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
        if (!n.translation.empty()) {
            if (n.translation.size() != 3)
                fail(RAD_ERR_PARSE, format("%s: translation has %zu numbers, expected 3",
                                           where.c_str(), n.translation.size()));
            for (int k = 0; k < 3; k++)
                t[k] = n.translation[k];
        }
        if (!n.rotation.empty()) {
            if (n.rotation.size() != 4)
                fail(RAD_ERR_PARSE, format("%s: rotation has %zu numbers, expected 4",
                                           where.c_str(), n.rotation.size()));
            for (int k = 0; k < 4; k++)
                r[k] = n.rotation[k];
        }
        if (!n.scale.empty()) {
            if (n.scale.size() != 3)
                fail(RAD_ERR_PARSE, format("%s: scale has %zu numbers, expected 3",
                                           where.c_str(), n.scale.size()));
            for (int k = 0; k < 3; k++)
                s[k] = n.scale[k];
        }
        /* Exporters write unit quaternions to ~7 digits; normalising makes
         * the rotation exactly orthogonal instead of a slight scale. */
        double len = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
        if (!(len > 1e-12) || !std::isfinite(len))
            fail(RAD_ERR_PARSE, where + ": rotation quaternion is zero or not finite");
        double x = r[0] / len, y = r[1] / len, z = r[2] / len, w = r[3] / len;
        double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                          {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                          {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
        mat_identity(out);
        for (int col = 0; col < 3; col++)
            for (int row = 0; row < 3; row++)
                out[col * 4 + row] = R[row][col] * s[col];
        for (int row = 0; row < 3; row++)
            out[12 + row] = t[row];
    }
    for (int k = 0; k < 16; k++)
        if (!std::isfinite(out[k]))
            fail(RAD_ERR_PARSE, where + ": transform is not finite");
}

/* -------------------------------------------------------------- accessors */

struct data_span {
    const unsigned char *base = nullptr;
    size_t stride = 0;
    size_t count = 0;
    size_t component = 0; /* bytes per component */
};

const char *type_name(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return "unknown";
    }
}

/* Checks that accessor `idx` holds `what` (POSITION: float VEC3, indices:
 * unsigned SCALAR) and that every element lies inside its buffer view and the
 * view inside its buffer.  Allocates nothing. */
data_span check_accessor(const tinygltf::Model &m, int idx, const std::string &where,
                         const char *what, bool is_index)
{
    size_t na = m.accessors.size();
    if (idx < 0 || (size_t)idx >= na)
        fail(RAD_ERR_PARSE,
             format("%s: %s accessor %d does not exist (%zu accessors)", where.c_str(), what, idx,
                    na));
    const tinygltf::Accessor &a = m.accessors[(size_t)idx];
    std::string w = format("%s: %s accessor %d", where.c_str(), what, idx);
    if (a.sparse.isSparse)
        fail(RAD_ERR_PARSE, w + ": sparse accessors are not supported");
    data_span sp;
    if (is_index) {
        if (a.type != TINYGLTF_TYPE_SCALAR)
            fail(RAD_ERR_PARSE, w + ": type " + type_name(a.type) + ", expected SCALAR");
        switch (a.componentType) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: sp.component = 1; break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: sp.component = 2; break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: sp.component = 4; break;
        default:
            fail(RAD_ERR_PARSE,
                 format("%s: componentType %d, expected unsigned byte, short or int (5121, "
                        "5123, 5125)",
                        w.c_str(), a.componentType));
        }
        if (a.count > kMaxIndices)
            fail(RAD_ERR_LIMIT, format("%s: %zu indices, more than the limit of %llu", w.c_str(),
                                       a.count, (unsigned long long)kMaxIndices));
    } else {
        if (a.type != TINYGLTF_TYPE_VEC3)
            fail(RAD_ERR_PARSE, w + ": type " + type_name(a.type) + ", expected VEC3");
        if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
            fail(RAD_ERR_PARSE,
                 format("%s: componentType %d, expected float (5126)", w.c_str(),
                        a.componentType));
        sp.component = 4;
        if (a.count > kMaxVertices)
            fail(RAD_ERR_LIMIT, format("%s: %zu vertices, more than the limit of %llu",
                                       w.c_str(), a.count, (unsigned long long)kMaxVertices));
    }
    size_t elem = sp.component * (is_index ? 1 : 3);
    sp.count = a.count;
    /* An accessor without a buffer view is all zeros: legal glTF, but it
     * would let a few bytes of JSON demand gigabytes, and holds no surface. */
    if (a.bufferView < 0 || (size_t)a.bufferView >= m.bufferViews.size())
        fail(RAD_ERR_PARSE, format("%s: buffer view %d does not exist (%zu buffer views)",
                                   w.c_str(), a.bufferView, m.bufferViews.size()));
    const tinygltf::BufferView &v = m.bufferViews[(size_t)a.bufferView];
    if (v.buffer < 0 || (size_t)v.buffer >= m.buffers.size())
        fail(RAD_ERR_PARSE, format("%s: buffer view %d names buffer %d, which does not exist",
                                   w.c_str(), a.bufferView, v.buffer));
    size_t bsize = m.buffers[(size_t)v.buffer].data.size();
    if (v.byteOffset > bsize || v.byteLength > bsize - v.byteOffset)
        fail(RAD_ERR_PARSE,
             format("%s: buffer view %d (offset %zu, length %zu) runs beyond buffer %d (%zu "
                    "bytes)",
                    w.c_str(), a.bufferView, v.byteOffset, v.byteLength, v.buffer, bsize));
    sp.stride = v.byteStride ? v.byteStride : elem;
    if (sp.stride < elem)
        fail(RAD_ERR_PARSE, format("%s: byteStride %zu is smaller than an element (%zu bytes)",
                                   w.c_str(), sp.stride, elem));
    if (a.count > 0) {
        /* count <= 3e8 and stride <= 252 (tinygltf checks), so the product
         * fits easily in 64 bits. */
        uint64_t span = (uint64_t)(a.count - 1) * sp.stride + elem;
        if (a.byteOffset > v.byteLength || span > (uint64_t)(v.byteLength - a.byteOffset))
            fail(RAD_ERR_PARSE,
                 format("%s: %zu elements (offset %zu, stride %zu) run beyond buffer view %d "
                        "(%zu bytes)",
                        w.c_str(), a.count, a.byteOffset, sp.stride, a.bufferView,
                        v.byteLength));
        sp.base = m.buffers[(size_t)v.buffer].data.data() + v.byteOffset + a.byteOffset;
    }
    return sp;
}

/* --------------------------------------------------------------- converter */

struct raw_deleter {
    void operator()(rad_gltf_raw *r) const { rad_gltf_raw_free(r); }
};
using raw_ptr = std::unique_ptr<rad_gltf_raw, raw_deleter>;

/* One entry of extensions.KHR_lights_punctual.lights, glTF's defaults filled in. */
struct light_def {
    std::string name;
    int type = RAD_GLTF_LIGHT_POINT;
    double color[3] = {1, 1, 1};
    double intensity = 1.0;
    double inner = 0.0, outer = M_PI / 4;
};

/* A JSON number into *out, or a parse failure naming `where` and `what`. */
void json_number(const nlohmann::json &o, const char *what, const std::string &where, double *out)
{
    auto it = o.find(what);
    if (it == o.end())
        return;
    if (!it->is_number())
        fail(RAD_ERR_PARSE, where + ": " + what + " is not a number");
    *out = it->get<double>();
}

/* extensions.KHR_lights_punctual.lights of the document, type-checked. */
std::vector<light_def> parse_lights(const nlohmann::json &doc)
{
    std::vector<light_def> out;
    auto ext = doc.find("extensions");
    if (ext == doc.end() || !ext->is_object())
        return out;
    auto kh = ext->find("KHR_lights_punctual");
    if (kh == ext->end())
        return out;
    if (!kh->is_object())
        fail(RAD_ERR_PARSE, "extensions.KHR_lights_punctual is not a JSON object");
    auto arr = kh->find("lights");
    if (arr == kh->end())
        return out;
    if (!arr->is_array())
        fail(RAD_ERR_PARSE, "KHR_lights_punctual.lights is not an array");
    size_t index = 0;
    for (const auto &o : *arr) {
        std::string where = format("KHR_lights_punctual light %zu", index++);
        if (!o.is_object())
            fail(RAD_ERR_PARSE, where + ": not a JSON object");
        light_def d;
        auto nm = o.find("name");
        if (nm != o.end()) {
            if (!nm->is_string())
                fail(RAD_ERR_PARSE, where + ": name is not a string");
            d.name = nm->get<std::string>();
            where += " " + q(d.name);
        }
        auto ty = o.find("type");
        if (ty == o.end() || !ty->is_string())
            fail(RAD_ERR_PARSE, where + ": type missing or not a string");
        const std::string &t = ty->get_ref<const std::string &>();
        if (t == "point")
            d.type = RAD_GLTF_LIGHT_POINT;
        else if (t == "spot")
            d.type = RAD_GLTF_LIGHT_SPOT;
        else if (t == "directional")
            d.type = RAD_GLTF_LIGHT_DIRECTIONAL;
        else
            fail(RAD_ERR_PARSE, where + ": type " + q(t) + " is not point, spot or directional");
        auto co = o.find("color");
        if (co != o.end()) {
            if (!co->is_array() || co->size() != 3)
                fail(RAD_ERR_PARSE, where + ": color is not an array of 3 numbers");
            for (int c = 0; c < 3; c++) {
                if (!(*co)[c].is_number())
                    fail(RAD_ERR_PARSE, where + ": color is not an array of 3 numbers");
                d.color[c] = (*co)[c].get<double>();
            }
        }
        json_number(o, "intensity", where, &d.intensity);
        double range = 0.0; /* checked for type, then ignored: light falls off as 1/r² */
        json_number(o, "range", where, &range);
        if (d.type == RAD_GLTF_LIGHT_SPOT) {
            auto sp = o.find("spot");
            if (sp == o.end() || !sp->is_object())
                fail(RAD_ERR_PARSE, where + ": a spot light needs a \"spot\" object");
            json_number(*sp, "innerConeAngle", where, &d.inner);
            json_number(*sp, "outerConeAngle", where, &d.outer);
        }
        out.push_back(d);
    }
    return out;
}

/* The light index a node carries in extensions.KHR_lights_punctual.light,
 * or -1. */
int64_t node_light(const tinygltf::Model &m, size_t i, size_t light_count)
{
    const tinygltf::Node &n = m.nodes[i];
    auto it = n.extensions.find("KHR_lights_punctual");
    if (it == n.extensions.end())
        return -1;
    const tinygltf::Value &v = it->second;
    if (!v.IsObject() || !v.Has("light") || !v.Get("light").IsNumber())
        fail(RAD_ERR_PARSE, node_label(m, i) + ": KHR_lights_punctual has no light index");
    double x = v.Get("light").GetNumberAsDouble();
    if (!(x >= 0.0) || x != std::floor(x) || x >= (double)light_count)
        fail(RAD_ERR_PARSE, format("%s: light %g does not exist (%zu lights)",
                                   node_label(m, i).c_str(), x, light_count));
    return (int64_t)x;
}

struct prim_plan {
    data_span pos, idx;
    bool indexed = false;
    uint64_t triangles = 0;
};

void convert(const tinygltf::Model &m, const std::vector<light_def> &lights,
             uint64_t max_triangles, rad_gltf_raw *raw)
{
    /* extensionsRequired: passed on, judged by gltf.c. */
    raw->extensions_required_count = count32(m.extensionsRequired.size(), "extensions");
    raw->extensions_required = calloc_n<char *>(m.extensionsRequired.size());
    for (size_t k = 0; k < m.extensionsRequired.size(); k++)
        raw->extensions_required[k] = dup_c(m.extensionsRequired[k]);

    /* Materials: plain numbers; the ρ and E rules are gltf.c's. */
    size_t nm = m.materials.size();
    raw->material_count = count32(nm, "materials");
    raw->materials = calloc_n<rad_gltf_raw_material>(nm);
    for (size_t i = 0; i < nm; i++) {
        const tinygltf::Material &src = m.materials[i];
        rad_gltf_raw_material &dst = raw->materials[i];
        dst.name = dup_c(src.name.empty() ? format("material%zu", i) : src.name);
        std::string where = "material " + q(dst.name);
        const std::vector<double> &bc = src.pbrMetallicRoughness.baseColorFactor;
        if (bc.size() != 4)
            fail(RAD_ERR_PARSE, format("%s: baseColorFactor has %zu numbers, expected 4",
                                       where.c_str(), bc.size()));
        const std::vector<double> &ef = src.emissiveFactor;
        if (ef.size() != 3)
            fail(RAD_ERR_PARSE, format("%s: emissiveFactor has %zu numbers, expected 3",
                                       where.c_str(), ef.size()));
        for (int c = 0; c < 3; c++) {
            dst.base_color[c] = bc[c];
            dst.emissive[c] = ef[c];
        }
        dst.emissive_strength = 1.0;
        auto ext = src.extensions.find("KHR_materials_emissive_strength");
        if (ext != src.extensions.end() && ext->second.IsObject() &&
            ext->second.Has("emissiveStrength")) {
            const tinygltf::Value &s = ext->second.Get("emissiveStrength");
            if (!s.IsNumber())
                fail(RAD_ERR_PARSE, where + ": emissiveStrength is not a number");
            dst.emissive_strength = s.GetNumberAsDouble();
        }
        dst.diffuse_transmission = 0.0;
        for (int c = 0; c < 3; c++)
            dst.diffuse_transmission_color[c] = 1.0;
        ext = src.extensions.find("KHR_materials_diffuse_transmission");
        if (ext != src.extensions.end() && ext->second.IsObject()) {
            const tinygltf::Value &dt = ext->second;
            if (dt.Has("diffuseTransmissionFactor")) {
                const tinygltf::Value &f = dt.Get("diffuseTransmissionFactor");
                if (!f.IsNumber())
                    fail(RAD_ERR_PARSE, where + ": diffuseTransmissionFactor is not a number");
                dst.diffuse_transmission = f.GetNumberAsDouble();
            }
            if (dt.Has("diffuseTransmissionColorFactor")) {
                const tinygltf::Value &col = dt.Get("diffuseTransmissionColorFactor");
                if (!col.IsArray() || col.ArrayLen() != 3)
                    fail(RAD_ERR_PARSE,
                         where + ": diffuseTransmissionColorFactor is not an array of 3 numbers");
                for (int c = 0; c < 3; c++) {
                    if (!col.Get(c).IsNumber())
                        fail(RAD_ERR_PARSE,
                             where + ": diffuseTransmissionColorFactor is not an array of 3 numbers");
                    dst.diffuse_transmission_color[c] = col.Get(c).GetNumberAsDouble();
                }
            }
        }
        dst.double_sided = src.doubleSided ? 1 : 0;
        /* tinygltf fills pbrMetallicRoughness with glTF's defaults; `values`
         * holds only the keys the document wrote. */
        dst.metallic = src.values.count("metallicFactor") ? src.pbrMetallicRoughness.metallicFactor
                                                          : 0.0;
        dst.roughness = src.pbrMetallicRoughness.roughnessFactor;
    }

    /* Node hierarchy: each node has at most one parent and no cycles, as
     * glTF requires (a node with two parents would be placed twice). */
    size_t nn = m.nodes.size();
    raw->node_count = count32(nn, "nodes");
    std::vector<int64_t> parent(nn, -1);
    for (size_t i = 0; i < nn; i++) {
        const tinygltf::Node &n = m.nodes[i];
        if (n.mesh >= 0 && (size_t)n.mesh >= m.meshes.size())
            fail(RAD_ERR_PARSE, format("%s: mesh %d does not exist (%zu meshes)",
                                       node_label(m, i).c_str(), n.mesh, m.meshes.size()));
        if (n.mesh < -1)
            fail(RAD_ERR_PARSE, format("%s: mesh %d does not exist", node_label(m, i).c_str(),
                                       n.mesh));
        if (n.camera < -1 || (n.camera >= 0 && (size_t)n.camera >= m.cameras.size()))
            fail(RAD_ERR_PARSE, format("%s: camera %d does not exist (%zu cameras)",
                                       node_label(m, i).c_str(), n.camera, m.cameras.size()));
        for (int c : n.children) {
            if (c < 0 || (size_t)c >= nn)
                fail(RAD_ERR_PARSE, format("%s: child %d does not exist (%zu nodes)",
                                           node_label(m, i).c_str(), c, nn));
            if ((size_t)c == i)
                fail(RAD_ERR_PARSE, node_label(m, i) + " is its own child");
            if (parent[(size_t)c] >= 0)
                fail(RAD_ERR_PARSE, node_label(m, (size_t)c) + " has two parents (" +
                                        node_label(m, (size_t)parent[(size_t)c]) + " and " +
                                        node_label(m, i) + ")");
            parent[(size_t)c] = (int64_t)i;
        }
    }

    /* World matrices, parent first: walk up to the nearest finished ancestor
     * (iteratively: a chain of a million nodes must not exhaust the stack),
     * then compose back down.  A walk longer than the node count is a cycle. */
    raw->nodes = calloc_n<rad_gltf_raw_node>(nn);
    std::vector<char> done(nn, 0);
    std::vector<size_t> chain;
    for (size_t i = 0; i < nn; i++) {
        chain.clear();
        int64_t j = (int64_t)i;
        while (j >= 0 && !done[(size_t)j]) {
            chain.push_back((size_t)j);
            if (chain.size() > nn)
                fail(RAD_ERR_PARSE,
                     "the node hierarchy has a cycle through " + node_label(m, i));
            j = parent[(size_t)j];
        }
        while (!chain.empty()) {
            size_t k = chain.back();
            chain.pop_back();
            double local[16];
            local_matrix(m, k, local);
            if (parent[k] >= 0)
                mat_mul(raw->nodes[(size_t)parent[k]].world, local, raw->nodes[k].world);
            else
                memcpy(raw->nodes[k].world, local, sizeof local);
            for (int e = 0; e < 16; e++)
                if (!std::isfinite(raw->nodes[k].world[e]))
                    fail(RAD_ERR_PARSE, node_label(m, k) + ": world transform is not finite");
            done[k] = 1;
        }
    }

    /* The displayed scene: `scene`, else scene 0, else (no scenes at all)
     * every root node. */
    std::vector<size_t> roots;
    if (!m.scenes.empty()) {
        size_t s = m.defaultScene >= 0 ? (size_t)m.defaultScene : 0;
        if (s >= m.scenes.size())
            fail(RAD_ERR_PARSE, format("scene %d does not exist (%zu scenes)", m.defaultScene,
                                       m.scenes.size()));
        for (int r : m.scenes[s].nodes) {
            if (r < 0 || (size_t)r >= nn)
                fail(RAD_ERR_PARSE,
                     format("scene %zu: node %d does not exist (%zu nodes)", s, r, nn));
            if (parent[(size_t)r] >= 0)
                fail(RAD_ERR_PARSE, format("scene %zu: %s is not a root node (its parent is %s)",
                                           s, node_label(m, (size_t)r).c_str(),
                                           node_label(m, (size_t)parent[(size_t)r]).c_str()));
            roots.push_back((size_t)r);
        }
    } else {
        for (size_t i = 0; i < nn; i++)
            if (parent[i] < 0)
                roots.push_back(i);
    }
    std::vector<size_t> stack;
    for (size_t r : roots) {
        if (raw->nodes[r].in_scene)
            fail(RAD_ERR_PARSE, "the scene lists " + node_label(m, r) + " twice");
        stack.push_back(r);
        while (!stack.empty()) {
            size_t k = stack.back();
            stack.pop_back();
            raw->nodes[k].in_scene = 1;
            for (int c : m.nodes[k].children)
                stack.push_back((size_t)c);
        }
    }

    for (size_t i = 0; i < nn; i++) {
        const tinygltf::Node &n = m.nodes[i];
        rad_gltf_raw_node &dst = raw->nodes[i];
        dst.mesh = n.mesh;
        std::string name = n.name;
        if (name.empty() && n.mesh >= 0)
            name = m.meshes[(size_t)n.mesh].name;
        if (name.empty())
            name = format("node%zu", i);
        dst.name = dup_c(name);
    }

    /* Meshes: check every primitive of every instanced mesh and count the
     * triangles the scene would hold, all before any vertex is copied. */
    size_t nme = m.meshes.size();
    raw->mesh_count = count32(nme, "meshes");
    raw->meshes = calloc_n<rad_gltf_raw_mesh>(nme);
    std::vector<std::vector<prim_plan>> plans(nme);
    std::vector<uint64_t> mesh_triangles(nme, 0);
    for (size_t i = 0; i < nn; i++)
        if (raw->nodes[i].in_scene && raw->nodes[i].mesh >= 0)
            raw->meshes[(size_t)raw->nodes[i].mesh].used = 1;
    for (size_t i = 0; i < nme; i++) {
        const tinygltf::Mesh &src = m.meshes[i];
        rad_gltf_raw_mesh &dst = raw->meshes[i];
        dst.name = dup_c(src.name.empty() ? format("mesh%zu", i) : src.name);
        if (!dst.used)
            continue;
        plans[i].resize(src.primitives.size());
        for (size_t p = 0; p < src.primitives.size(); p++) {
            const tinygltf::Primitive &pr = src.primitives[p];
            std::string where = format("mesh %s primitive %zu", q(dst.name).c_str(), p);
            if (pr.material < -1 || (pr.material >= 0 && (size_t)pr.material >= nm))
                fail(RAD_ERR_PARSE, format("%s: material %d does not exist (%zu materials)",
                                           where.c_str(), pr.material, nm));
            if (pr.mode != TINYGLTF_MODE_TRIANGLES)
                continue; /* gltf.c refuses it with the mode's name */
            prim_plan &pl = plans[i][p];
            auto pos = pr.attributes.find("POSITION");
            if (pos == pr.attributes.end())
                fail(RAD_ERR_PARSE, where + ": no POSITION attribute");
            pl.pos = check_accessor(m, pos->second, where, "POSITION", false);
            if (pr.indices >= 0) {
                pl.indexed = true;
                pl.idx = check_accessor(m, pr.indices, where, "indices", true);
                if (pl.idx.count % 3 != 0)
                    fail(RAD_ERR_PARSE, format("%s: %zu indices, not a multiple of 3",
                                               where.c_str(), pl.idx.count));
                pl.triangles = pl.idx.count / 3;
            } else {
                if (pl.pos.count % 3 != 0)
                    fail(RAD_ERR_PARSE,
                         format("%s: %zu vertices without indices, not a multiple of 3",
                                where.c_str(), pl.pos.count));
                pl.triangles = pl.pos.count / 3;
            }
            mesh_triangles[i] += pl.triangles;
        }
    }
    uint64_t total = 0;
    for (size_t i = 0; i < nn; i++) {
        if (!raw->nodes[i].in_scene || raw->nodes[i].mesh < 0)
            continue;
        total += mesh_triangles[(size_t)raw->nodes[i].mesh];
        if (total > max_triangles) /* checked per step: the sum cannot overflow */
            fail(RAD_ERR_LIMIT,
                 format("the scene has more than %llu triangles (the limit)",
                        (unsigned long long)max_triangles));
    }

    for (size_t i = 0; i < nme; i++) {
        const tinygltf::Mesh &src = m.meshes[i];
        rad_gltf_raw_mesh &dst = raw->meshes[i];
        if (!dst.used)
            continue;
        dst.primitive_count = count32(src.primitives.size(), "primitives");
        dst.primitives = calloc_n<rad_gltf_raw_primitive>(src.primitives.size());
        for (size_t p = 0; p < src.primitives.size(); p++) {
            const tinygltf::Primitive &pr = src.primitives[p];
            rad_gltf_raw_primitive &out = dst.primitives[p];
            out.mode = pr.mode;
            out.material = pr.material;
            if (pr.mode != TINYGLTF_MODE_TRIANGLES)
                continue;
            std::string where = format("mesh %s primitive %zu", q(dst.name).c_str(), p);
            const prim_plan &pl = plans[i][p];
            size_t nv = pl.pos.count;
            out.vertex_count = (uint32_t)nv;
            out.positions = calloc_n<double>(3 * nv);
            for (size_t v = 0; v < nv; v++) {
                const unsigned char *e = pl.pos.base + v * pl.pos.stride;
                for (int c = 0; c < 3; c++) {
                    double x = le_float(e + 4 * c);
                    if (!std::isfinite(x))
                        fail(RAD_ERR_PARSE,
                             format("%s: vertex %zu is not finite", where.c_str(), v));
                    out.positions[3 * v + c] = x;
                }
            }
            size_t ni = pl.indexed ? pl.idx.count : nv;
            out.index_count = (uint32_t)ni;
            out.indices = calloc_n<uint32_t>(ni);
            for (size_t k = 0; k < ni; k++) {
                uint32_t ix = (uint32_t)k;
                if (pl.indexed) {
                    const unsigned char *e = pl.idx.base + k * pl.idx.stride;
                    ix = pl.idx.component == 1   ? e[0]
                         : pl.idx.component == 2 ? (uint32_t)(e[0] | e[1] << 8)
                                                 : le32(e);
                    if (ix >= nv)
                        fail(RAD_ERR_PARSE, format("%s: index %u out of range (%zu vertices)",
                                                   where.c_str(), ix, nv));
                }
                out.indices[k] = ix;
            }
        }
    }

    /* Cameras, one per in-scene node that carries one, in node order. */
    size_t ncam = 0;
    for (size_t i = 0; i < nn; i++)
        if (raw->nodes[i].in_scene && m.nodes[i].camera >= 0)
            ncam++;
    raw->cameras = calloc_n<rad_gltf_raw_camera>(ncam);
    for (size_t i = 0; i < nn; i++) {
        if (!raw->nodes[i].in_scene || m.nodes[i].camera < 0)
            continue;
        size_t ci = (size_t)m.nodes[i].camera;
        const tinygltf::Camera &c = m.cameras[ci];
        rad_gltf_raw_camera &dst = raw->cameras[raw->camera_count++];
        std::string name = !c.name.empty() ? c.name : m.nodes[i].name;
        if (name.empty())
            name = format("camera%zu", ci);
        dst.name = dup_c(name);
        dst.node = (uint32_t)i;
        dst.camera = (uint32_t)ci;
        dst.perspective = c.type == "perspective";
        dst.yfov = c.perspective.yfov;
        dst.aspect = c.perspective.aspectRatio;
        memcpy(dst.world, raw->nodes[i].world, sizeof dst.world);
    }

    /* Punctual lights, one per in-scene node that carries one, in node order
     * (every node's index is checked, shown or not). */
    std::vector<int64_t> light_of(nn, -1);
    size_t nlight = 0;
    for (size_t i = 0; i < nn; i++) {
        light_of[i] = node_light(m, i, lights.size());
        if (raw->nodes[i].in_scene && light_of[i] >= 0)
            nlight++;
    }
    raw->light_count = 0;
    raw->lights = calloc_n<rad_gltf_raw_light>(nlight);
    for (size_t i = 0; i < nn; i++) {
        if (!raw->nodes[i].in_scene || light_of[i] < 0)
            continue;
        const light_def &d = lights[(size_t)light_of[i]];
        rad_gltf_raw_light &dst = raw->lights[raw->light_count++];
        std::string name = !d.name.empty() ? d.name : m.nodes[i].name;
        if (name.empty())
            name = format("light%lld", (long long)light_of[i]);
        dst.name = dup_c(name);
        dst.node = (uint32_t)i;
        dst.light = (uint32_t)light_of[i];
        dst.type = d.type;
        for (int c = 0; c < 3; c++)
            dst.color[c] = d.color[c];
        dst.intensity = d.intensity;
        dst.inner_cone = d.inner;
        dst.outer_cone = d.outer;
        memcpy(dst.world, raw->nodes[i].world, sizeof dst.world);
    }
}

int load(const void *data, size_t size, const char *base_dir, uint64_t max_triangles,
         rad_gltf_raw **out)
{
    if (!data && size)
        fail(RAD_ERR_USAGE, "no data");
    if (size > kMaxDocument)
        fail(RAD_ERR_LIMIT,
             format("document of %zu bytes is larger than the 2 GiB limit", size));
    const unsigned char *d = static_cast<const unsigned char *>(data);
    bool binary = size >= 4 && memcmp(d, "glTF", 4) == 0;
    glb_parts g;
    if (binary) {
        g = split_glb(d, size);
    } else {
        g.json = d;
        g.json_size = size;
    }
    if (g.json_size == 0)
        fail(RAD_ERR_PARSE, "malformed JSON: the document is empty");
    check_depth(g.json, g.json_size);

    nlohmann::json doc;
    try {
        doc = nlohmann::json::parse(g.json, g.json + g.json_size);
    } catch (const nlohmann::json::parse_error &e) {
        /* what() reads "[json.exception.parse_error.101] parse error at line
         * 1, column 5: syntax error ..."; the part after "] " is the news. */
        std::string w = e.what();
        size_t b = w.find("] ");
        fail(RAD_ERR_PARSE, "malformed JSON: " + first_line(b == std::string::npos
                                                                 ? w
                                                                 : w.substr(b + 2)));
    }
    if (!doc.is_object())
        fail(RAD_ERR_PARSE, "malformed JSON: the document is not a JSON object");
    std::vector<light_def> lights = parse_lights(doc);

    nlohmann::json kept = nlohmann::json::object();
    for (const char *key : kKeptMembers) {
        auto it = doc.find(key);
        if (it != doc.end())
            kept[key] = *it;
    }

    fs_context fs;
    fs.allow_external = base_dir != nullptr;
    if (base_dir) {
        fs.prefix = *base_dir ? base_dir : ".";
        if (fs.prefix.back() != '/')
            fs.prefix += '/';
    }
    vet_buffers(kept, fs);

    std::string text = kept.dump();
    if (text.size() > kMaxDocument)
        fail(RAD_ERR_LIMIT, "the document's JSON is larger than the 2 GiB limit");

    tinygltf::TinyGLTF loader;
    tinygltf::FsCallbacks cb;
    cb.FileExists = fs_exists;
    cb.ExpandFilePath = fs_expand;
    cb.ReadWholeFile = fs_read;
    cb.WriteWholeFile = fs_write;
    cb.user_data = &fs;
    loader.SetFsCallbacks(cb);
    loader.SetImageLoader(no_image, nullptr);

    /* tinygltf joins base_dir and the URI itself; our prefix already ends in
     * '/', which it keeps as is. */
    std::string base = base_dir ? fs.prefix : std::string();
    tinygltf::Model model;
    std::string err, warn;
    bool ok;
    if (binary) {
        std::vector<unsigned char> glb = build_glb(text, g);
        ok = loader.LoadBinaryFromMemory(&model, &err, &warn, glb.data(),
                                         (unsigned int)glb.size(), base);
    } else {
        ok = loader.LoadASCIIFromString(&model, &err, &warn, text.data(),
                                        (unsigned int)text.size(), base);
    }
    if (!ok) {
        if (!fs.failure.empty())
            fail(RAD_ERR_IO, fs.failure);
        std::string e = first_line(err);
        fail(RAD_ERR_PARSE, "invalid glTF: " + (e.empty() ? std::string("unknown error") : e));
    }

    raw_ptr raw(calloc_n<rad_gltf_raw>(1));
    convert(model, lights, max_triangles, raw.get());
    *out = raw.release();
    return RAD_OK;
}

void set_msg(char *msg, size_t msg_size, const std::string &s)
{
    if (msg && msg_size)
        snprintf(msg, msg_size, "%s", s.c_str());
}

} /* namespace */

extern "C" int rad_gltf_bridge_load(const void *data, size_t size, const char *base_dir,
                                    uint64_t max_triangles, rad_gltf_raw **out, char *msg,
                                    size_t msg_size)
{
    if (msg && msg_size)
        msg[0] = '\0';
    if (!out) {
        set_msg(msg, msg_size, "no output pointer");
        return RAD_ERR_USAGE;
    }
    *out = nullptr;
    /* Everything is caught here: bad_alloc from any vector or string,
     * nlohmann's type and range errors, tinygltf's std::out_of_range. */
    try {
        return load(data, size, base_dir, max_triangles, out);
    } catch (const bridge_error &e) {
        set_msg(msg, msg_size, e.msg);
        return e.code;
    } catch (const std::bad_alloc &) {
        set_msg(msg, msg_size, "out of memory");
        return RAD_ERR_NOMEM;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, std::string("invalid glTF: ") + e.what());
        return RAD_ERR_PARSE;
    } catch (...) {
        set_msg(msg, msg_size, "invalid glTF: unexpected failure");
        return RAD_ERR_PARSE;
    }
}

extern "C" void rad_gltf_raw_free(rad_gltf_raw *raw)
{
    if (!raw)
        return;
    for (uint32_t i = 0; raw->nodes && i < raw->node_count; i++)
        free(raw->nodes[i].name);
    free(raw->nodes);
    for (uint32_t i = 0; raw->meshes && i < raw->mesh_count; i++) {
        rad_gltf_raw_mesh *me = &raw->meshes[i];
        for (uint32_t p = 0; me->primitives && p < me->primitive_count; p++) {
            free(me->primitives[p].positions);
            free(me->primitives[p].indices);
        }
        free(me->primitives);
        free(me->name);
    }
    free(raw->meshes);
    for (uint32_t i = 0; raw->materials && i < raw->material_count; i++)
        free(raw->materials[i].name);
    free(raw->materials);
    for (uint32_t i = 0; raw->cameras && i < raw->camera_count; i++)
        free(raw->cameras[i].name);
    free(raw->cameras);
    for (uint32_t i = 0; raw->lights && i < raw->light_count; i++)
        free(raw->lights[i].name);
    free(raw->lights);
    for (uint32_t i = 0; raw->extensions_required && i < raw->extensions_required_count; i++)
        free(raw->extensions_required[i]);
    free(raw->extensions_required);
    free(raw);
}
