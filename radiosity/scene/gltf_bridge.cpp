/* gltf_bridge.cpp - tinygltf behind one C function: rad_gltf_bridge_load.
 *
 * The bridge is the project's only C++ (gltf_bridge_internal.h tells its
 * files apart).  This file owns the second pass: tinygltf parses the document
 * gltf_vet.cpp has vetted, through file callbacks confined to the vetted
 * buffers, and its Model becomes the plain-C rad_gltf_raw of gltf_bridge.h --
 * node hierarchy to world matrices, accessors to double positions, linear
 * vertex colours and uint32 triangle indices, materials (their textures
 * averaged by gltf_texture.cpp), cameras and KHR_lights_punctual lights as
 * numbers, and notes of what a diffuse scene ignores.  It includes tiny_gltf.h's declarations only (tinygltf_impl.cpp
 * compiles its code), so an edit here recompiles in seconds.
 *
 * Invariant: no exception and no C++ type leaves this file, and no input can
 * make it read outside a buffer, recurse without bound, allocate more than
 * the document's own data justifies, or open a file outside base_dir.  Every
 * index and size tinygltf leaves unchecked is checked below before it is
 * used, and the conversion checks everything (references, accessors, the
 * triangle budget) before it copies any vertex.
 */
#include "gltf_bridge.h"
#include "gltf_bridge_internal.h"
#include "tinygltf_config.h"
#include "../core/rad.h"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>
#include <vector>

namespace rad_gltf {
namespace {

const uint64_t kMaxVertices = 100000000;  /* per primitive */
const uint64_t kMaxIndices = 300000000;   /* per primitive */

/* ---------------------------------------------------------- tinygltf parse */

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

/* tinygltf's Model of the vetted document; its external buffers are read
 * through fs (only the vetted ones). */
tinygltf::Model parse_model(const vetted_doc &doc, fs_context &fs, const char *base_dir)
{
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
    if (doc.binary)
        ok = loader.LoadBinaryFromMemory(&model, &err, &warn, doc.glb.data(),
                                         (unsigned int)doc.glb.size(), base);
    else
        ok = loader.LoadASCIIFromString(&model, &err, &warn, doc.json.data(),
                                        (unsigned int)doc.json.size(), base);
    if (!ok) {
        if (!fs.failure.empty())
            fail(RAD_ERR_IO, fs.failure);
        std::string e = first_line(err);
        fail(RAD_ERR_PARSE, "invalid glTF: " + (e.empty() ? std::string("unknown error") : e));
    }
    return model;
}

/* ----------------------------------------------------------- raw ownership */

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

struct raw_deleter {
    void operator()(rad_gltf_raw *r) const { rad_gltf_raw_free(r); }
};
using raw_ptr = std::unique_ptr<rad_gltf_raw, raw_deleter>;

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

/* A node's `matrix`, which must be affine. */
void given_matrix(const tinygltf::Node &n, const std::string &where, double out[16])
{
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
}

/* `n` numbers of a node's translation, rotation or scale into out, unless the
 * node leaves it out (out keeps glTF's default). */
void trs_part(const std::vector<double> &v, size_t n, const char *what, const std::string &where,
              double *out)
{
    if (v.empty())
        return;
    if (v.size() != n)
        fail(RAD_ERR_PARSE, format("%s: %s has %zu numbers, expected %zu", where.c_str(), what,
                                   v.size(), n));
    for (size_t k = 0; k < n; k++)
        out[k] = v[k];
}

/* T·R·S (glTF's order) of a node's translation, rotation and scale. */
void trs_matrix(const tinygltf::Node &n, const std::string &where, double out[16])
{
    double t[3] = {0, 0, 0}, r[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    trs_part(n.translation, 3, "translation", where, t);
    trs_part(n.rotation, 4, "rotation", where, r);
    trs_part(n.scale, 3, "scale", where, s);
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

/* The node's local matrix: its `matrix`, else T·R·S. */
void local_matrix(const tinygltf::Model &m, size_t i, double out[16])
{
    const tinygltf::Node &n = m.nodes[i];
    std::string where = node_label(m, i);
    if (!n.matrix.empty())
        given_matrix(n, where, out);
    else
        trs_matrix(n, where, out);
    for (int k = 0; k < 16; k++)
        if (!std::isfinite(out[k]))
            fail(RAD_ERR_PARSE, where + ": transform is not finite");
}

/* -------------------------------------------------------------- accessors */

/* What an accessor must hold. */
enum accessor_role { ROLE_POSITION, ROLE_INDEX, ROLE_COLOR, ROLE_TEXCOORD };

struct data_span {
    const unsigned char *base = nullptr;
    size_t stride = 0;
    size_t count = 0;
    size_t component = 0; /* bytes per component */
    size_t width = 0;     /* components per element */
    int type = 0;         /* glTF componentType */
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

/* Indices: unsigned SCALAR, at most kMaxIndices; returns bytes per component. */
size_t check_index_element(const tinygltf::Accessor &a, const std::string &w)
{
    size_t component = 0;
    if (a.type != TINYGLTF_TYPE_SCALAR)
        fail(RAD_ERR_PARSE, w + ": type " + type_name(a.type) + ", expected SCALAR");
    switch (a.componentType) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: component = 1; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: component = 2; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: component = 4; break;
    default:
        fail(RAD_ERR_PARSE,
             format("%s: componentType %d, expected unsigned byte, short or int (5121, "
                    "5123, 5125)",
                    w.c_str(), a.componentType));
    }
    if (a.count > kMaxIndices)
        fail(RAD_ERR_LIMIT, format("%s: %zu indices, more than the limit of %llu", w.c_str(),
                                   a.count, (unsigned long long)kMaxIndices));
    return component;
}

/* COLOR_0: VEC3 or VEC4 of float, or of unsigned byte or short (normalised,
 * as glTF requires of colours); returns bytes per component. */
size_t check_color_element(const tinygltf::Accessor &a, const std::string &w)
{
    if (a.type != TINYGLTF_TYPE_VEC3 && a.type != TINYGLTF_TYPE_VEC4)
        fail(RAD_ERR_PARSE, w + ": type " + type_name(a.type) + ", expected VEC3 or VEC4");
    switch (a.componentType) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    default:
        fail(RAD_ERR_PARSE,
             format("%s: componentType %d, expected float, unsigned byte or unsigned short "
                    "(5126, 5121, 5123)",
                    w.c_str(), a.componentType));
    }
}

/* TEXCOORD_n: VEC2 of float, or of unsigned byte or short (normalised);
 * returns bytes per component. */
size_t check_texcoord_element(const tinygltf::Accessor &a, const std::string &w)
{
    if (a.type != TINYGLTF_TYPE_VEC2)
        fail(RAD_ERR_PARSE, w + ": type " + type_name(a.type) + ", expected VEC2");
    if (a.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT)
        return 4;
    if ((a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
         a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) && a.normalized)
        return a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ? 1 : 2;
    fail(RAD_ERR_PARSE, format("%s: componentType %d, expected float or normalized unsigned "
                               "byte or short (5126, 5121, 5123)",
                               w.c_str(), a.componentType));
}

/* Checks that accessor `a` (named by w) holds what `role` needs and
 * returns the bytes per component; elements per accessor are at most
 * kMaxVertices (POSITION, COLOR_0) or kMaxIndices. */
size_t check_element(const tinygltf::Accessor &a, const std::string &w, accessor_role role)
{
    if (role == ROLE_INDEX)
        return check_index_element(a, w);
    size_t component = 4;
    if (role == ROLE_COLOR) {
        component = check_color_element(a, w);
    } else if (role == ROLE_TEXCOORD) {
        component = check_texcoord_element(a, w);
    } else {
        if (a.type != TINYGLTF_TYPE_VEC3)
            fail(RAD_ERR_PARSE, w + ": type " + type_name(a.type) + ", expected VEC3");
        if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
            fail(RAD_ERR_PARSE,
                 format("%s: componentType %d, expected float (5126)", w.c_str(),
                        a.componentType));
    }
    if (a.count > kMaxVertices)
        fail(RAD_ERR_LIMIT, format("%s: %zu vertices, more than the limit of %llu", w.c_str(),
                                   a.count, (unsigned long long)kMaxVertices));
    return component;
}

/* Checks that accessor `idx` holds `what` (check_element) and that every
 * element lies inside its buffer view and the view inside its buffer.
 * Allocates nothing. */
data_span check_accessor(const tinygltf::Model &m, int idx, const std::string &where,
                         const char *what, accessor_role role)
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
    sp.component = check_element(a, w, role);
    sp.width = role == ROLE_INDEX ? 1 : a.type == TINYGLTF_TYPE_VEC4 ? 4
                                    : a.type == TINYGLTF_TYPE_VEC2 ? 2 : 3;
    sp.type = a.componentType;
    size_t elem = sp.component * sp.width;
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

float le_float(const unsigned char *p)
{
    uint32_t u = le32(p);
    float f;
    static_assert(sizeof f == sizeof u, "float must be 32 bits");
    memcpy(&f, &u, sizeof f);
    return f;
}

/* ---------------------------------------------------------------- materials */

/* KHR_materials_emissive_strength's emissiveStrength, default 1. */
double emissive_strength(const tinygltf::Material &src, const std::string &where)
{
    auto ext = src.extensions.find("KHR_materials_emissive_strength");
    if (ext == src.extensions.end() || !ext->second.IsObject() ||
        !ext->second.Has("emissiveStrength"))
        return 1.0;
    const tinygltf::Value &s = ext->second.Get("emissiveStrength");
    if (!s.IsNumber())
        fail(RAD_ERR_PARSE, where + ": emissiveStrength is not a number");
    return s.GetNumberAsDouble();
}

/* KHR_materials_diffuse_transmission: diffuseTransmissionFactor (default 0)
 * and diffuseTransmissionColorFactor (default 1); textures ignored. */
void diffuse_transmission(const tinygltf::Material &src, const std::string &where,
                          rad_gltf_raw_material &dst)
{
    dst.diffuse_transmission = 0.0;
    for (int c = 0; c < 3; c++)
        dst.diffuse_transmission_color[c] = 1.0;
    auto ext = src.extensions.find("KHR_materials_diffuse_transmission");
    if (ext == src.extensions.end() || !ext->second.IsObject())
        return;
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

/* Material i as plain numbers; the ρ and E rules are gltf.c's. */
void convert_material(const tinygltf::Material &src, size_t i, rad_gltf_raw_material &dst)
{
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
    dst.base_alpha = bc[3];
    dst.emissive_strength = emissive_strength(src, where);
    diffuse_transmission(src, where, dst);
    dst.double_sided = src.doubleSided ? 1 : 0;
    /* tinygltf fills pbrMetallicRoughness with glTF's defaults; `values`
     * holds only the keys the document wrote. */
    dst.metallic = src.values.count("metallicFactor") ? src.pbrMetallicRoughness.metallicFactor : 0.0;
    dst.roughness = src.pbrMetallicRoughness.roughnessFactor;
}

void convert_materials(const tinygltf::Model &m, rad_gltf_raw *raw)
{
    size_t nm = m.materials.size();
    raw->material_count = count32(nm, "materials");
    raw->materials = calloc_n<rad_gltf_raw_material>(nm);
    for (size_t i = 0; i < nm; i++)
        convert_material(m.materials[i], i, raw->materials[i]);
}

/* -------------------------------------------------------------------- nodes */

/* Checks every node's mesh, camera and child references and returns each
 * node's parent (-1: a root).  Each node has at most one parent and is not
 * its own child, as glTF requires (a node with two parents would be placed
 * twice); longer cycles are found by world_matrices. */
std::vector<int64_t> node_parents(const tinygltf::Model &m)
{
    size_t nn = m.nodes.size();
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
    return parent;
}

/* World matrices into raw->nodes[].world, parent first: walk up to the
 * nearest finished ancestor (iteratively: a chain of a million nodes must not
 * exhaust the stack), then compose back down.  A walk longer than the node
 * count is a cycle. */
void world_matrices(const tinygltf::Model &m, const std::vector<int64_t> &parent,
                    rad_gltf_raw *raw)
{
    size_t nn = m.nodes.size();
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
}

/* The root nodes of the displayed scene: `scene`, else scene 0, else (no
 * scenes at all) every node without a parent. */
std::vector<size_t> scene_roots(const tinygltf::Model &m, const std::vector<int64_t> &parent)
{
    size_t nn = m.nodes.size();
    std::vector<size_t> roots;
    if (m.scenes.empty()) {
        for (size_t i = 0; i < nn; i++)
            if (parent[i] < 0)
                roots.push_back(i);
        return roots;
    }
    size_t s = m.defaultScene >= 0 ? (size_t)m.defaultScene : 0;
    if (s >= m.scenes.size())
        fail(RAD_ERR_PARSE, format("scene %d does not exist (%zu scenes)", m.defaultScene,
                                   m.scenes.size()));
    for (int r : m.scenes[s].nodes) {
        if (r < 0 || (size_t)r >= nn)
            fail(RAD_ERR_PARSE, format("scene %zu: node %d does not exist (%zu nodes)", s, r, nn));
        if (parent[(size_t)r] >= 0)
            fail(RAD_ERR_PARSE, format("scene %zu: %s is not a root node (its parent is %s)", s,
                                       node_label(m, (size_t)r).c_str(),
                                       node_label(m, (size_t)parent[(size_t)r]).c_str()));
        roots.push_back((size_t)r);
    }
    return roots;
}

/* Sets in_scene on the roots and everything below them (iteratively). */
void mark_in_scene(const tinygltf::Model &m, const std::vector<size_t> &roots, rad_gltf_raw *raw)
{
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
}

/* Node hierarchy -> raw->nodes: references, world matrices, the displayed
 * scene, names and meshes. */
void convert_nodes(const tinygltf::Model &m, rad_gltf_raw *raw)
{
    size_t nn = m.nodes.size();
    raw->node_count = count32(nn, "nodes");
    std::vector<int64_t> parent = node_parents(m);
    raw->nodes = calloc_n<rad_gltf_raw_node>(nn);
    world_matrices(m, parent, raw);
    mark_in_scene(m, scene_roots(m, parent), raw);
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
}

/* ------------------------------------------------------------------- meshes */

/* What one primitive will copy, found before anything is allocated. */
struct prim_plan {
    data_span pos, idx, col;
    data_span uv[2];
    bool indexed = false;
    bool colored = false; /* COLOR_0 present */
    bool textured[2] = {false, false}; /* TEXCOORD_0, TEXCOORD_1 present */
    uint64_t triangles = 0;
};

std::string primitive_label(const char *mesh_name, size_t p)
{
    return format("mesh %s primitive %zu", q(mesh_name).c_str(), p);
}

/* The TEXCOORD set the primitive's material samples its baseColorTexture
 * with (0 or 1; only a bake reads it), when the material has one.  An
 * accessor that does not hold texture coordinates is left out rather than
 * refused: the solve does not need it, and gltf.c's warning names the
 * primitive that lacks them. */
void plan_texcoords(const tinygltf::Model &m, const tinygltf::Primitive &pr,
                    const std::string &where, prim_plan &pl)
{
    if (pr.material < 0)
        return;
    const tinygltf::TextureInfo &ti =
        m.materials[(size_t)pr.material].pbrMetallicRoughness.baseColorTexture;
    if (ti.index < 0 || ti.texCoord < 0 || ti.texCoord > 1)
        return;
    int n = ti.texCoord;
    const char *name = n ? "TEXCOORD_1" : "TEXCOORD_0";
    auto uv = pr.attributes.find(name);
    if (uv == pr.attributes.end())
        return;
    try {
        pl.uv[n] = check_accessor(m, uv->second, where, name, ROLE_TEXCOORD);
        pl.textured[n] = pl.uv[n].count == pl.pos.count;
    } catch (const bridge_error &) {
        pl.textured[n] = false;
    }
}

/* Checks one primitive: its material index, and for TRIANGLES its POSITION,
 * COLOR_0 and index accessors and a whole number of triangles.  Other modes get an
 * empty plan: gltf.c refuses them with the mode's name. */
prim_plan plan_primitive(const tinygltf::Model &m, const tinygltf::Primitive &pr,
                         const std::string &where)
{
    prim_plan pl;
    size_t nm = m.materials.size();
    if (pr.material < -1 || (pr.material >= 0 && (size_t)pr.material >= nm))
        fail(RAD_ERR_PARSE, format("%s: material %d does not exist (%zu materials)",
                                   where.c_str(), pr.material, nm));
    if (pr.mode != TINYGLTF_MODE_TRIANGLES)
        return pl;
    auto pos = pr.attributes.find("POSITION");
    if (pos == pr.attributes.end())
        fail(RAD_ERR_PARSE, where + ": no POSITION attribute");
    pl.pos = check_accessor(m, pos->second, where, "POSITION", ROLE_POSITION);
    auto col = pr.attributes.find("COLOR_0");
    if (col != pr.attributes.end()) {
        pl.colored = true;
        pl.col = check_accessor(m, col->second, where, "COLOR_0", ROLE_COLOR);
        if (pl.col.count != pl.pos.count)
            fail(RAD_ERR_PARSE, format("%s: COLOR_0 has %zu elements, POSITION %zu",
                                       where.c_str(), pl.col.count, pl.pos.count));
    }
    plan_texcoords(m, pr, where, pl);
    if (pr.indices >= 0) {
        pl.indexed = true;
        pl.idx = check_accessor(m, pr.indices, where, "indices", ROLE_INDEX);
        if (pl.idx.count % 3 != 0)
            fail(RAD_ERR_PARSE, format("%s: %zu indices, not a multiple of 3", where.c_str(),
                                       pl.idx.count));
        pl.triangles = pl.idx.count / 3;
    } else {
        if (pl.pos.count % 3 != 0)
            fail(RAD_ERR_PARSE, format("%s: %zu vertices without indices, not a multiple of 3",
                                       where.c_str(), pl.pos.count));
        pl.triangles = pl.pos.count / 3;
    }
    return pl;
}

/* The scene's triangles, counted over the in-scene node instances, must not
 * exceed max_triangles. */
void check_triangle_budget(const rad_gltf_raw *raw, const std::vector<uint64_t> &mesh_triangles,
                           uint64_t max_triangles)
{
    uint64_t total = 0;
    for (size_t i = 0; i < raw->node_count; i++) {
        if (!raw->nodes[i].in_scene || raw->nodes[i].mesh < 0)
            continue;
        total += mesh_triangles[(size_t)raw->nodes[i].mesh];
        if (total > max_triangles) /* checked per step: the sum cannot overflow */
            fail(RAD_ERR_LIMIT, format("the scene has more than %llu triangles (the limit)",
                                       (unsigned long long)max_triangles));
    }
}

/* The planned POSITION elements as doubles, each finite. */
void copy_positions(const prim_plan &pl, const std::string &where, rad_gltf_raw_primitive &out)
{
    size_t nv = pl.pos.count;
    out.vertex_count = (uint32_t)nv;
    out.positions = calloc_n<double>(3 * nv);
    for (size_t v = 0; v < nv; v++) {
        const unsigned char *e = pl.pos.base + v * pl.pos.stride;
        for (int c = 0; c < 3; c++) {
            double x = le_float(e + 4 * c);
            if (!std::isfinite(x))
                fail(RAD_ERR_PARSE, format("%s: vertex %zu is not finite", where.c_str(), v));
            out.positions[3 * v + c] = x;
        }
    }
}

/* The planned COLOR_0 elements as linear RGB doubles (alpha dropped:
 * coverage, not reflectance), each finite and >= 0.  Integer colours are
 * normalised, as glTF requires of them: v / 255 or v / 65535. */
void copy_colors(const prim_plan &pl, const std::string &where, rad_gltf_raw_primitive &out)
{
    if (!pl.colored)
        return;
    size_t nv = pl.col.count;
    out.colors = calloc_n<double>(3 * nv);
    for (size_t v = 0; v < nv; v++) {
        const unsigned char *e = pl.col.base + v * pl.col.stride;
        for (int c = 0; c < 3; c++) {
            double x;
            if (pl.col.type == TINYGLTF_COMPONENT_TYPE_FLOAT)
                x = le_float(e + 4 * c);
            else if (pl.col.type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT)
                x = (double)(e[2 * c] | e[2 * c + 1] << 8) / 65535.0;
            else
                x = (double)e[c] / 255.0;
            if (!std::isfinite(x) || x < 0.0)
                fail(RAD_ERR_PARSE, format("%s: COLOR_0 of vertex %zu is %g, not a colour",
                                           where.c_str(), v, x));
            out.colors[3 * v + c] = x;
        }
    }
}

/* The planned TEXCOORD_0 or _1 elements as (u, v) doubles, integer ones
 * normalised (v / 255 or v / 65535); a set with a value that is not finite
 * is left out (NULL), as an unusable accessor is. */
void copy_texcoords(const prim_plan &pl, rad_gltf_raw_primitive &out)
{
    for (int n = 0; n < 2; n++) {
        if (!pl.textured[n])
            continue;
        const data_span &sp = pl.uv[n];
        out.uv[n] = calloc_n<double>(2 * sp.count);
        for (size_t v = 0; v < sp.count; v++) {
            const unsigned char *e = sp.base + v * sp.stride;
            for (int c = 0; c < 2; c++) {
                double x = sp.type == TINYGLTF_COMPONENT_TYPE_FLOAT ? le_float(e + 4 * c)
                           : sp.type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT
                               ? (double)(e[2 * c] | e[2 * c + 1] << 8) / 65535.0
                               : (double)e[c] / 255.0;
                if (!std::isfinite(x)) {
                    free(out.uv[n]);
                    out.uv[n] = nullptr;
                    return;
                }
                out.uv[n][2 * v + c] = x;
            }
        }
    }
}

/* The planned indices as uint32, each below the vertex count; a primitive
 * without indices gets 0, 1, 2, ... */
void copy_indices(const prim_plan &pl, const std::string &where, rad_gltf_raw_primitive &out)
{
    size_t nv = pl.pos.count;
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

/* A used mesh's primitives, as planned. */
void fill_mesh(const tinygltf::Mesh &src, const std::vector<prim_plan> &plans,
               rad_gltf_raw_mesh &dst)
{
    dst.primitive_count = count32(src.primitives.size(), "primitives");
    dst.primitives = calloc_n<rad_gltf_raw_primitive>(src.primitives.size());
    for (size_t p = 0; p < src.primitives.size(); p++) {
        const tinygltf::Primitive &pr = src.primitives[p];
        rad_gltf_raw_primitive &out = dst.primitives[p];
        out.mode = pr.mode;
        out.material = pr.material;
        if (pr.mode != TINYGLTF_MODE_TRIANGLES)
            continue;
        std::string where = primitive_label(dst.name, p);
        copy_positions(plans[p], where, out);
        copy_indices(plans[p], where, out);
        copy_colors(plans[p], where, out);
        copy_texcoords(plans[p], out);
    }
}

/* Meshes -> raw->meshes: every primitive of every instanced mesh is checked
 * and the triangles the scene would hold are counted, all before any vertex
 * is copied; the materials their triangles use are marked used.  Needs
 * raw->nodes (convert_nodes) and raw->materials. */
void convert_meshes(const tinygltf::Model &m, uint64_t max_triangles, rad_gltf_raw *raw)
{
    size_t nme = m.meshes.size();
    raw->mesh_count = count32(nme, "meshes");
    raw->meshes = calloc_n<rad_gltf_raw_mesh>(nme);
    std::vector<std::vector<prim_plan>> plans(nme);
    std::vector<uint64_t> mesh_triangles(nme, 0);
    for (size_t i = 0; i < raw->node_count; i++)
        if (raw->nodes[i].in_scene && raw->nodes[i].mesh >= 0)
            raw->meshes[(size_t)raw->nodes[i].mesh].used = 1;
    for (size_t i = 0; i < nme; i++) {
        const tinygltf::Mesh &src = m.meshes[i];
        rad_gltf_raw_mesh &dst = raw->meshes[i];
        dst.name = dup_c(src.name.empty() ? format("mesh%zu", i) : src.name);
        if (!dst.used)
            continue;
        for (size_t p = 0; p < src.primitives.size(); p++) {
            plans[i].push_back(plan_primitive(m, src.primitives[p], primitive_label(dst.name, p)));
            mesh_triangles[i] += plans[i].back().triangles;
        }
    }
    check_triangle_budget(raw, mesh_triangles, max_triangles);
    for (size_t i = 0; i < nme; i++) {
        if (!raw->meshes[i].used)
            continue;
        fill_mesh(m.meshes[i], plans[i], raw->meshes[i]);
        for (const tinygltf::Primitive &pr : m.meshes[i].primitives)
            if (pr.mode == TINYGLTF_MODE_TRIANGLES && pr.material >= 0)
                raw->materials[(size_t)pr.material].used = 1;
    }
}

/* ------------------------------------------------------- cameras and lights */

/* The camera of in-scene node i. */
void convert_camera(const tinygltf::Model &m, size_t i, const rad_gltf_raw_node &node,
                    rad_gltf_raw_camera &dst)
{
    size_t ci = (size_t)m.nodes[i].camera;
    const tinygltf::Camera &c = m.cameras[ci];
    std::string name = !c.name.empty() ? c.name : m.nodes[i].name;
    if (name.empty())
        name = format("camera%zu", ci);
    dst.name = dup_c(name);
    dst.node = (uint32_t)i;
    dst.camera = (uint32_t)ci;
    dst.perspective = c.type == "perspective";
    dst.yfov = c.perspective.yfov;
    dst.aspect = c.perspective.aspectRatio;
    dst.xmag = c.orthographic.xmag;
    dst.ymag = c.orthographic.ymag;
    memcpy(dst.world, node.world, sizeof dst.world);
}

/* Cameras, one per in-scene node that carries one, in node order.  Needs
 * raw->nodes. */
void convert_cameras(const tinygltf::Model &m, rad_gltf_raw *raw)
{
    size_t nn = raw->node_count, ncam = 0;
    for (size_t i = 0; i < nn; i++)
        if (raw->nodes[i].in_scene && m.nodes[i].camera >= 0)
            ncam++;
    raw->cameras = calloc_n<rad_gltf_raw_camera>(ncam);
    for (size_t i = 0; i < nn; i++)
        if (raw->nodes[i].in_scene && m.nodes[i].camera >= 0)
            convert_camera(m, i, raw->nodes[i], raw->cameras[raw->camera_count++]);
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

/* Light `li` (d) as placed by in-scene node i. */
void convert_light(const tinygltf::Model &m, size_t i, size_t li, const light_def &d,
                   const rad_gltf_raw_node &node, rad_gltf_raw_light &dst)
{
    std::string name = !d.name.empty() ? d.name : m.nodes[i].name;
    if (name.empty())
        name = format("light%lld", (long long)li);
    dst.name = dup_c(name);
    dst.node = (uint32_t)i;
    dst.light = (uint32_t)li;
    dst.type = d.type;
    for (int c = 0; c < 3; c++)
        dst.color[c] = d.color[c];
    dst.intensity = d.intensity;
    dst.inner_cone = d.inner;
    dst.outer_cone = d.outer;
    memcpy(dst.world, node.world, sizeof dst.world);
}

/* Punctual lights, one per in-scene node that carries one, in node order
 * (every node's index is checked, shown or not).  Needs raw->nodes. */
void convert_lights(const tinygltf::Model &m, const std::vector<light_def> &lights,
                    rad_gltf_raw *raw)
{
    size_t nn = raw->node_count, nlight = 0;
    std::vector<int64_t> light_of(nn, -1);
    for (size_t i = 0; i < nn; i++) {
        light_of[i] = node_light(m, i, lights.size());
        if (raw->nodes[i].in_scene && light_of[i] >= 0)
            nlight++;
    }
    raw->light_count = 0;
    raw->lights = calloc_n<rad_gltf_raw_light>(nlight);
    for (size_t i = 0; i < nn; i++)
        if (raw->nodes[i].in_scene && light_of[i] >= 0)
            convert_light(m, i, (size_t)light_of[i], lights[(size_t)light_of[i]], raw->nodes[i],
                          raw->lights[raw->light_count++]);
}

/* ------------------------------------------------------------------- notes */

/* The notes of ignored features (gltf_bridge.h), each subject once per kind,
 * in the order first met. */
struct note_list {
    std::vector<std::pair<int, std::string>> items;
    std::vector<std::vector<std::string>> seen = std::vector<std::vector<std::string>>(
        RAD_GLTF_NOTE_COUNT);

    void add(int kind, const std::string &subject)
    {
        std::vector<std::string> &s = seen[(size_t)kind];
        for (const std::string &x : s)
            if (x == subject)
                return;
        s.push_back(subject);
        items.emplace_back(kind, subject);
    }
};

/* What the used materials carry that a diffuse surface ignores. */
void material_notes(const tinygltf::Model &m, const vetted_doc &doc, const rad_gltf_raw *raw,
                    note_list &notes)
{
    for (size_t i = 0; i < raw->material_count; i++) {
        if (!raw->materials[i].used)
            continue;
        const tinygltf::Material &src = m.materials[i];
        std::string name = q(raw->materials[i].name);
        if (src.normalTexture.index >= 0 || src.occlusionTexture.index >= 0 ||
            src.pbrMetallicRoughness.metallicRoughnessTexture.index >= 0)
            notes.add(RAD_GLTF_NOTE_TEXTURES, name);
        if (i < doc.metallic.size() && doc.metallic[i])
            notes.add(RAD_GLTF_NOTE_METALLIC, name);
        if (!src.alphaMode.empty() && src.alphaMode != "OPAQUE")
            notes.add(RAD_GLTF_NOTE_ALPHA, name + " (" + src.alphaMode.substr(0, 16) + ")");
    }
}

/* Every note of the document, after the conversion: only what the displayed
 * scene uses is named. */
void collect_notes(const tinygltf::Model &m, const vetted_doc &doc, rad_gltf_raw *raw)
{
    note_list notes;
    material_notes(m, doc, raw, notes);
    if (doc.animations)
        notes.add(RAD_GLTF_NOTE_ANIMATION, format("%zu animation%s", doc.animations,
                                                  doc.animations == 1 ? "" : "s"));
    if (doc.skins)
        notes.add(RAD_GLTF_NOTE_ANIMATION,
                  format("%zu skin%s", doc.skins, doc.skins == 1 ? "" : "s"));
    for (size_t i = 0; i < raw->mesh_count; i++) {
        if (!raw->meshes[i].used)
            continue;
        for (const tinygltf::Primitive &pr : m.meshes[i].primitives)
            if (!pr.targets.empty())
                notes.add(RAD_GLTF_NOTE_ANIMATION,
                          "morph targets of mesh " + q(raw->meshes[i].name));
    }
    for (size_t k = 0; k < raw->light_count; k++)
        if (doc.lights[raw->lights[k].light].has_range)
            notes.add(RAD_GLTF_NOTE_LIGHT_RANGE, q(raw->lights[k].name));
    raw->notes = calloc_n<rad_gltf_raw_note>(notes.items.size());
    for (const auto &it : notes.items) {
        rad_gltf_raw_note &n = raw->notes[raw->note_count];
        n.kind = it.first;
        n.subject = dup_c(it.second);
        raw->note_count++;
    }
}

/* --------------------------------------------------------------- converter */

char **string_array(const std::vector<std::string> &v, uint32_t *count, const char *what)
{
    *count = count32(v.size(), what);
    char **out = calloc_n<char *>(v.size());
    for (size_t k = 0; k < v.size(); k++)
        out[k] = dup_c(v[k]);
    return out;
}

/* tinygltf's Model -> raw, in an order where each part finds what it needs:
 * nodes before meshes (which are read only when instanced), meshes before
 * textures (read only for the materials they use), cameras and lights
 * (placed by nodes), and the notes last. */
void convert(const tinygltf::Model &m, const vetted_doc &doc, const fs_context &fs,
             uint64_t max_triangles, rad_gltf_raw *raw)
{
    /* extensionsRequired and extensionsUsed: passed on, judged by gltf.c. */
    raw->extensions_required =
        string_array(m.extensionsRequired, &raw->extensions_required_count, "extensions");
    raw->extensions_used =
        string_array(m.extensionsUsed, &raw->extensions_used_count, "extensions");

    convert_materials(m, raw);
    convert_nodes(m, raw);
    convert_meshes(m, max_triangles, raw);
    convert_textures(m, doc, fs, raw);
    convert_cameras(m, raw);
    convert_lights(m, doc.lights, raw);
    collect_notes(m, doc, raw);
}

int load(const void *data, size_t size, const char *base_dir, uint64_t max_triangles,
         rad_gltf_raw **out)
{
    fs_context fs;
    fs.allow_external = base_dir != nullptr;
    if (base_dir) {
        fs.prefix = *base_dir ? base_dir : ".";
        if (fs.prefix.back() != '/')
            fs.prefix += '/';
    }
    vetted_doc doc = vet_document(data, size, fs);
    tinygltf::Model model = parse_model(doc, fs, base_dir);
    raw_ptr raw(calloc_n<rad_gltf_raw>(1));
    convert(model, doc, fs, max_triangles, raw.get());
    *out = raw.release();
    return RAD_OK;
}

void set_msg(char *msg, size_t msg_size, const std::string &s)
{
    if (msg && msg_size)
        snprintf(msg, msg_size, "%s", s.c_str());
}

} /* namespace */
} /* namespace rad_gltf */

extern "C" int rad_gltf_bridge_load(const void *data, size_t size, const char *base_dir,
                                    uint64_t max_triangles, rad_gltf_raw **out, char *msg,
                                    size_t msg_size)
{
    using namespace rad_gltf;
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
            free(me->primitives[p].colors);
            free(me->primitives[p].uv[0]);
            free(me->primitives[p].uv[1]);
        }
        free(me->primitives);
        free(me->name);
    }
    free(raw->meshes);
    for (uint32_t i = 0; raw->materials && i < raw->material_count; i++) {
        free(raw->materials[i].name);
        free(raw->materials[i].base_texture.problem);
        free(raw->materials[i].emissive_texture.problem);
    }
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
    for (uint32_t i = 0; raw->extensions_used && i < raw->extensions_used_count; i++)
        free(raw->extensions_used[i]);
    free(raw->extensions_used);
    for (uint32_t i = 0; raw->notes && i < raw->note_count; i++)
        free(raw->notes[i].subject);
    free(raw->notes);
    for (uint32_t i = 0; raw->images && i < raw->image_count; i++)
        free(raw->images[i].data);
    free(raw->images);
    free(raw);
}
