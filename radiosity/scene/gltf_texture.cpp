/* gltf_texture.cpp - the glTF bridge's texture pass: a used material's
 * baseColorTexture and emissiveTexture -> the mean linear colour of the
 * image each samples (rad_gltf_raw_texture, gltf_bridge.h); for a
 * baseColorTexture also the image's bytes as they are (PNG or JPEG), its
 * coordinate set and sampler, which a bake draws.
 *
 * It owns the way from a material to image bytes: texture index -> the
 * `textures` entry -> its `source` image (both read by gltf_vet.cpp, since
 * tinygltf never sees them) -> the bytes, from a buffer view (bounds checked
 * here: tinygltf's own image path does not), a base64 data URI, or a file
 * below the document's directory -> gltf_image.c's mean.  Each image is
 * decoded at most once, however many materials share it.
 *
 * Invariant: a texture that cannot be read never fails the load: the
 * material is marked RAD_GLTF_TEXTURE_UNREADABLE with a one-line reason and
 * gltf.c decides (a warning and the factor alone, or an error under
 * --strict).  Only running out of memory throws.  No file outside base_dir
 * is opened, no file larger than kMaxImageFile is read, and no bytes outside
 * a buffer are touched.
 */
#include "gltf_bridge.h"
#include "gltf_bridge_internal.h"
#include "gltf_image.h"
#include "tinygltf_config.h"
#include "tinygltf_uri.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <new>
#include <string>
#include <vector>

namespace rad_gltf {
namespace {

/* An image file larger than this is not read (a 8192² PNG of 16-bit RGBA
 * barely compresses to this). */
const size_t kMaxImageFile = (size_t)640 << 20;

/* What one image came to: its mean, or why not; a PNG or JPEG also its
 * bytes, for a bake (kept = its index in raw->images once a
 * baseColorTexture samples it). */
struct image_result {
    bool ok = false;
    double mean[3] = {0, 0, 0};
    std::string problem;
    const char *mime = nullptr;
    std::vector<unsigned char> bytes;
    int32_t kept = -1;
};

/* The media type glTF allows that these bytes are, by their signature. */
const char *sniff_mime(const unsigned char *p, size_t n)
{
    if (n >= 8 && memcmp(p, "\x89PNG\r\n\x1a\n", 8) == 0)
        return "image/png";
    if (n >= 3 && memcmp(p, "\xff\xd8\xff", 3) == 0)
        return "image/jpeg";
    return nullptr;
}

/* "image 2 'wood.png'" for messages. */
std::string image_label(const vetted_doc &doc, size_t i)
{
    const image_def &d = doc.images[i];
    std::string label = format("image %zu", i);
    if (!d.name.empty())
        return label + " " + q(d.name);
    if (!d.uri.empty() && d.uri.compare(0, 5, "data:") != 0)
        return label + " " + q(d.uri);
    return label;
}

/* The bytes of buffer view `v`, checked against its buffer, or why not. */
bool view_bytes(const tinygltf::Model &m, int64_t v, const unsigned char **p, size_t *n,
                std::string &why)
{
    if (v < 0 || (size_t)v >= m.bufferViews.size()) {
        why = format("buffer view %lld does not exist (%zu buffer views)", (long long)v,
                     m.bufferViews.size());
        return false;
    }
    const tinygltf::BufferView &bv = m.bufferViews[(size_t)v];
    if (bv.buffer < 0 || (size_t)bv.buffer >= m.buffers.size()) {
        why = format("buffer view %lld names buffer %d, which does not exist", (long long)v,
                     bv.buffer);
        return false;
    }
    const std::vector<unsigned char> &b = m.buffers[(size_t)bv.buffer].data;
    if (bv.byteOffset > b.size() || bv.byteLength > b.size() - bv.byteOffset) {
        why = format("buffer view %lld (offset %zu, length %zu) runs beyond buffer %d (%zu "
                     "bytes)",
                     (long long)v, bv.byteOffset, bv.byteLength, bv.buffer, b.size());
        return false;
    }
    *p = b.data() + bv.byteOffset;
    *n = bv.byteLength;
    return true;
}

/* The whole of a file below the document's directory into out, or why not. */
bool file_bytes(const fs_context &fs, const std::string &uri, std::vector<unsigned char> &out,
                std::string &why)
{
    std::string path = tinygltf_urldecode(uri);
    if (!fs.allow_external) {
        why = "external file " + q(path) + " not allowed (the document was not read from a file)";
        return false;
    }
    if (!confined_path(path)) {
        why = "external file " + q(path) +
              " refused (only relative paths below the document's directory, without '..')";
        return false;
    }
    std::string full = fs.prefix + path;
    FILE *f = fopen(full.c_str(), "rb");
    if (!f) {
        why = "cannot open " + q(path) + ": " + strerror(errno);
        return false;
    }
    struct stat st;
    bool ok = fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode);
    if (!ok)
        why = q(path) + " is not a regular file";
    else if ((uint64_t)st.st_size > kMaxImageFile) {
        why = format("%s has %lld bytes, more than the limit of %zu", q(path).c_str(),
                     (long long)st.st_size, kMaxImageFile);
        ok = false;
    }
    if (ok) {
        out.resize((size_t)st.st_size);
        ok = out.empty() || fread(out.data(), 1, out.size(), f) == out.size();
        if (!ok)
            why = "cannot read " + q(path);
    }
    fclose(f);
    return ok;
}

/* Image i's bytes found and averaged. */
image_result read_image(const tinygltf::Model &m, const vetted_doc &doc, const fs_context &fs,
                        size_t i)
{
    image_result r;
    const image_def &d = doc.images[i];
    std::string why = d.problem;
    std::vector<unsigned char> held; /* data URI or file */
    const unsigned char *p = nullptr;
    size_t n = 0;
    bool found = false;
    if (why.empty()) {
        if (d.buffer_view >= 0) {
            found = view_bytes(m, d.buffer_view, &p, &n, why);
        } else if (d.uri.compare(0, 5, "data:") == 0) {
            std::string mime;
            found = tinygltf_is_data_uri(d.uri) &&
                    tinygltf::DecodeDataURI(&held, mime, d.uri, 0, false) && !held.empty();
            if (!found)
                why = "unsupported or empty data URI (only base64 PNG or JPEG)";
        } else {
            found = file_bytes(fs, d.uri, held, why);
        }
    }
    if (found && p == nullptr) {
        p = held.data();
        n = held.size();
    }
    char msg[300];
    if (found && rad_gltf_image_mean(p, n, RAD_GLTF_MAX_TEXELS, r.mean, msg, sizeof msg) == 0) {
        r.ok = true;
        r.mime = sniff_mime(p, n);
        if (r.mime)
            r.bytes.assign(p, p + n);
        return r;
    }
    if (found)
        why = msg;
    r.problem = image_label(doc, i) + ": " + why;
    return r;
}

/* Image r into raw->images (once), its index. */
int32_t keep_image(image_result &r, rad_gltf_raw *raw)
{
    if (r.kept >= 0 || !r.mime)
        return r.kept;
    rad_gltf_raw_image *grown = static_cast<rad_gltf_raw_image *>(
        realloc(raw->images, (raw->image_count + 1) * sizeof *raw->images));
    if (!grown)
        throw std::bad_alloc();
    raw->images = grown;
    rad_gltf_raw_image &im = raw->images[raw->image_count];
    im = rad_gltf_raw_image{r.mime, nullptr, r.bytes.size()};
    im.data = static_cast<unsigned char *>(malloc(r.bytes.size() ? r.bytes.size() : 1));
    if (!im.data)
        throw std::bad_alloc();
    memcpy(im.data, r.bytes.data(), r.bytes.size());
    r.kept = (int32_t)raw->image_count++;
    std::vector<unsigned char>().swap(r.bytes);
    return r.kept;
}

/* A read baseColorTexture's image, coordinate set, transform and sampler. */
void keep_base(const vetted_doc &doc, const tinygltf::TextureInfo &ti, image_result &r,
               rad_gltf_raw *raw, rad_gltf_raw_texture &dst)
{
    dst.image = keep_image(r, raw);
    dst.texcoord = ti.texCoord > 0 ? (uint32_t)ti.texCoord : 0;
    dst.transformed = ti.extensions.count("KHR_texture_transform") ? 1 : 0;
    int64_t smp = doc.textures[(size_t)ti.index].sampler;
    if (smp >= 0 && (size_t)smp < doc.samplers.size()) {
        const sampler_def &d = doc.samplers[(size_t)smp];
        dst.wrap_s = d.wrap_s;
        dst.wrap_t = d.wrap_t;
        dst.mag_filter = d.mag_filter;
        dst.min_filter = d.min_filter;
    }
}

/* One material texture slot: texture index `t` (-1: none) resolved through
 * the cache of images already averaged; a baseColorTexture (base != NULL)
 * also keeps its image and sampling for a bake. */
void fill_texture(const tinygltf::Model &m, const vetted_doc &doc, const fs_context &fs, int t,
                  std::map<size_t, image_result> &cache, const tinygltf::TextureInfo *base,
                  rad_gltf_raw *raw, rad_gltf_raw_texture &dst)
{
    dst.image = -1;
    if (t < 0) {
        dst.state = RAD_GLTF_TEXTURE_NONE;
        return;
    }
    std::string problem;
    if ((size_t)t >= doc.textures.size()) {
        problem = format("texture %d does not exist (%zu textures)", t, doc.textures.size());
    } else if (!doc.textures[(size_t)t].problem.empty()) {
        problem = format("texture %d: ", t) + doc.textures[(size_t)t].problem;
    } else if ((uint64_t)doc.textures[(size_t)t].source >= doc.images.size()) {
        problem = format("texture %d: image %lld does not exist (%zu images)", t,
                         (long long)doc.textures[(size_t)t].source, doc.images.size());
    } else {
        size_t img = (size_t)doc.textures[(size_t)t].source;
        auto it = cache.find(img);
        if (it == cache.end())
            it = cache.emplace(img, read_image(m, doc, fs, img)).first;
        if (it->second.ok) {
            dst.state = RAD_GLTF_TEXTURE_READ;
            memcpy(dst.mean, it->second.mean, sizeof dst.mean);
            if (base)
                keep_base(doc, *base, it->second, raw, dst);
            return;
        }
        problem = it->second.problem;
    }
    dst.state = RAD_GLTF_TEXTURE_UNREADABLE;
    dst.problem = dup_c(problem);
}

} /* namespace */

void convert_textures(const tinygltf::Model &m, const vetted_doc &doc, const fs_context &fs,
                      rad_gltf_raw *raw)
{
    std::map<size_t, image_result> cache;
    for (size_t i = 0; i < raw->material_count && i < m.materials.size(); i++) {
        rad_gltf_raw_material &dst = raw->materials[i];
        if (!dst.used)
            continue;
        const tinygltf::Material &src = m.materials[i];
        const tinygltf::TextureInfo &bt = src.pbrMetallicRoughness.baseColorTexture;
        fill_texture(m, doc, fs, bt.index, cache, &bt, raw, dst.base_texture);
        fill_texture(m, doc, fs, src.emissiveTexture.index, cache, nullptr, raw,
                     dst.emissive_texture);
    }
}

} /* namespace rad_gltf */
