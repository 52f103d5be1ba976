/* gltf_vet.cpp - the glTF bridge's first pass: a document's raw bytes ->
 * the vetted_doc tinygltf is allowed to parse (gltf_bridge_internal.h).
 *
 * It owns everything done before tinygltf sees a byte: the .glb container's
 * header and chunk table, the JSON's nesting depth, the JSON itself (read
 * with nlohmann::json), the KHR_lights_punctual lights (read here, before the
 * top-level `extensions` member is dropped), the `images` and `textures`
 * entries (read here: tinygltf never sees them), what the notes of ignored
 * features need from dropped members (animations, skins, which materials
 * give metallicFactor), the choice of top-level members that reach
 * tinygltf, and the external buffer URIs.
 *
 * Invariant: what it hands on is nested at most kMaxDepth levels, holds only
 * kKeptMembers (so tinygltf never meets images, textures or animations, and
 * never decodes or reads unchecked what they point to), is at most
 * kMaxDocument bytes, and names no external file that is not a relative path
 * below base_dir; no input makes it read outside its buffer or recurse
 * without bound.
 */
#include "gltf_bridge_internal.h"
#include "tinygltf_uri.h"
#include "../core/rad.h"

#include <cstring>

#include <nlohmann/json.hpp>

namespace rad_gltf {
namespace {

/* A JSON nesting depth no glTF needs (materials with extensions reach ~6);
 * tinygltf and nlohmann's dump recurse once per level. */
const int kMaxDepth = 64;

/* Only these top-level members reach tinygltf; the rest (images, textures,
 * samplers, animations, skins, extensions such as lights) are read here or
 * carry nothing a diffuse radiosity scene uses, and leaving them out means
 * tinygltf can neither decode images nor read buffer views unchecked for
 * them (gltf_texture.cpp reads image bytes with its own checks). */
const char *const kKeptMembers[] = {"asset",     "scene",       "scenes",    "nodes",
                                    "meshes",    "accessors",   "bufferViews", "buffers",
                                    "materials", "cameras",     "extensionsUsed",
                                    "extensionsRequired"};

/* ------------------------------------------------------------ byte helpers */

void put_le32(std::vector<unsigned char> &v, uint32_t x)
{
    for (int k = 0; k < 4; k++)
        v.push_back((unsigned char)(x >> (8 * k)));
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

/* ------------------------------------------------------------------- JSON */

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

/* The JSON text as an object; its depth has been checked. */
nlohmann::json parse_json(const unsigned char *p, size_t n)
{
    nlohmann::json doc;
    try {
        doc = nlohmann::json::parse(p, p + n);
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
    return doc;
}

/* ----------------------------------------------------------------- buffers */

} /* namespace */

bool confined_path(const std::string &path)
{
    if (path.empty() || path[0] == '/' || path.find('\\') != std::string::npos ||
        path.find(':') != std::string::npos || path.find('\0') != std::string::npos)
        return false;
    size_t start = 0;
    while (start <= path.size()) {
        size_t slash = path.find('/', start);
        std::string part =
            path.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
        if (part == "..")
            return false;
        if (slash == std::string::npos)
            break;
        start = slash + 1;
    }
    return true;
}

namespace {

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
            if (!tinygltf_is_data_uri(uri))
                fail(RAD_ERR_PARSE,
                     where + ": unsupported data URI (only base64 "
                             "application/octet-stream or application/gltf-buffer)");
            continue;
        }
        std::string path = tinygltf_urldecode(uri);
        if (!fs.allow_external)
            fail(RAD_ERR_IO, where + ": external file " + q(path) +
                                 " not allowed (the document was not read from a file)");
        if (!confined_path(path))
            fail(RAD_ERR_IO, where + ": external file " + q(path) +
                                 " refused (only relative paths below the document's "
                                 "directory, without '..')");
        auto bl = b.find("byteLength");
        if (bl == b.end() || !bl->is_number_unsigned())
            fail(RAD_ERR_PARSE, where + ": byteLength missing or not a non-negative integer");
        fs.sizes[fs.prefix + path] = bl->get<size_t>();
    }
}

/* ------------------------------------------------------------------ lights */

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

/* One entry of KHR_lights_punctual.lights; `where` names it by index. */
light_def parse_light(const nlohmann::json &o, std::string where)
{
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
    d.has_range = o.find("range") != o.end();
    if (d.type == RAD_GLTF_LIGHT_SPOT) {
        auto sp = o.find("spot");
        if (sp == o.end() || !sp->is_object())
            fail(RAD_ERR_PARSE, where + ": a spot light needs a \"spot\" object");
        json_number(*sp, "innerConeAngle", where, &d.inner);
        json_number(*sp, "outerConeAngle", where, &d.outer);
    }
    return d;
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
    for (const auto &o : *arr)
        out.push_back(parse_light(o, format("KHR_lights_punctual light %zu", index++)));
    return out;
}

/* ------------------------------------------------------- images, textures */

/* doc's member `what` when it is an array, else nullptr (absent, or of
 * another type: these members are read for what they can give, and a
 * malformed one gives nothing). */
const nlohmann::json *array_member(const nlohmann::json &doc, const char *what)
{
    auto it = doc.find(what);
    return it != doc.end() && it->is_array() ? &*it : nullptr;
}

/* A non-negative integer member into *out (untouched when absent); false
 * when it is present but not one. */
bool json_index(const nlohmann::json &o, const char *what, int64_t *out)
{
    auto it = o.find(what);
    if (it == o.end())
        return true;
    if (!it->is_number_integer() || it->get<int64_t>() < 0)
        return false;
    *out = it->get<int64_t>();
    return true;
}

/* The `images` entries, each with what it points to or why it cannot be
 * used; `uri` and `bufferView` are exclusive (glTF: exactly one). */
std::vector<image_def> parse_images(const nlohmann::json &doc)
{
    std::vector<image_def> out;
    const nlohmann::json *arr = array_member(doc, "images");
    for (size_t k = 0; arr && k < arr->size(); k++) {
        const nlohmann::json &o = (*arr)[k];
        image_def d;
        if (!o.is_object()) {
            d.problem = "not a JSON object";
            out.push_back(d);
            continue;
        }
        auto nm = o.find("name");
        if (nm != o.end() && nm->is_string())
            d.name = nm->get<std::string>();
        auto uri = o.find("uri");
        bool has_view = o.find("bufferView") != o.end();
        if (uri != o.end() && has_view)
            d.problem = "gives both uri and bufferView";
        else if (uri != o.end() && !uri->is_string())
            d.problem = "uri is not a string";
        else if (uri != o.end())
            d.uri = uri->get<std::string>();
        else if (!json_index(o, "bufferView", &d.buffer_view))
            d.problem = "bufferView is not an index";
        else if (d.buffer_view < 0)
            d.problem = "neither uri nor bufferView";
        out.push_back(d);
    }
    return out;
}

/* The `textures` entries: the image each samples. */
std::vector<texture_def> parse_textures(const nlohmann::json &doc)
{
    std::vector<texture_def> out;
    const nlohmann::json *arr = array_member(doc, "textures");
    for (size_t k = 0; arr && k < arr->size(); k++) {
        const nlohmann::json &o = (*arr)[k];
        texture_def d;
        if (!o.is_object())
            d.problem = "not a JSON object";
        else if (!json_index(o, "source", &d.source))
            d.problem = "source is not an index";
        else if (!json_index(o, "sampler", &d.sampler))
            d.sampler = -1; /* a malformed sampler: the defaults */
        else if (d.source < 0)
            d.problem = "no PNG or JPEG source (only an extension's image format)";
        out.push_back(d);
    }
    return out;
}

/* An integer member, else 0. */
int json_int(const nlohmann::json &o, const char *what)
{
    auto it = o.find(what);
    return it != o.end() && it->is_number_integer() && it->get<int64_t>() > 0 &&
                   it->get<int64_t>() < 65536
               ? (int)it->get<int64_t>()
               : 0;
}

/* The `samplers` entries (only kept textures use them, for a bake). */
std::vector<sampler_def> parse_samplers(const nlohmann::json &doc)
{
    std::vector<sampler_def> out;
    const nlohmann::json *arr = array_member(doc, "samplers");
    for (size_t k = 0; arr && k < arr->size(); k++) {
        const nlohmann::json &o = (*arr)[k];
        sampler_def d;
        if (o.is_object()) {
            d.wrap_s = json_int(o, "wrapS");
            d.wrap_t = json_int(o, "wrapT");
            d.mag_filter = json_int(o, "magFilter");
            d.min_filter = json_int(o, "minFilter");
        }
        out.push_back(d);
    }
    return out;
}

/* Per material: pbrMetallicRoughness.metallicFactor given and > 0.  glTF's
 * default is 1 (metal), but a file that says nothing is taken as the usual
 * export of a diffuse surface, and only a stated metal is noted. */
std::vector<bool> parse_metallic(const nlohmann::json &doc)
{
    std::vector<bool> out;
    const nlohmann::json *arr = array_member(doc, "materials");
    for (size_t k = 0; arr && k < arr->size(); k++) {
        const nlohmann::json &o = (*arr)[k];
        bool metal = false;
        if (o.is_object()) {
            auto pbr = o.find("pbrMetallicRoughness");
            if (pbr != o.end() && pbr->is_object()) {
                auto mf = pbr->find("metallicFactor");
                metal = mf != pbr->end() && mf->is_number() && mf->get<double>() > 0.0;
            }
        }
        out.push_back(metal);
    }
    return out;
}

size_t array_size(const nlohmann::json &doc, const char *what)
{
    const nlohmann::json *arr = array_member(doc, what);
    return arr ? arr->size() : 0;
}

} /* namespace */

vetted_doc vet_document(const void *data, size_t size, fs_context &fs)
{
    if (!data && size)
        fail(RAD_ERR_USAGE, "no data");
    if (size > kMaxDocument)
        fail(RAD_ERR_LIMIT,
             format("document of %zu bytes is larger than the 2 GiB limit", size));
    const unsigned char *d = static_cast<const unsigned char *>(data);
    vetted_doc out;
    out.binary = size >= 4 && memcmp(d, "glTF", 4) == 0;
    glb_parts g;
    if (out.binary) {
        g = split_glb(d, size);
    } else {
        g.json = d;
        g.json_size = size;
    }
    if (g.json_size == 0)
        fail(RAD_ERR_PARSE, "malformed JSON: the document is empty");
    check_depth(g.json, g.json_size);

    nlohmann::json doc = parse_json(g.json, g.json_size);
    out.lights = parse_lights(doc);
    out.images = parse_images(doc);
    out.textures = parse_textures(doc);
    out.samplers = parse_samplers(doc);
    out.metallic = parse_metallic(doc);
    out.animations = array_size(doc, "animations");
    out.skins = array_size(doc, "skins");

    nlohmann::json kept = nlohmann::json::object();
    for (const char *key : kKeptMembers) {
        auto it = doc.find(key);
        if (it != doc.end())
            kept[key] = *it;
    }
    vet_buffers(kept, fs);

    out.json = kept.dump();
    if (out.json.size() > kMaxDocument)
        fail(RAD_ERR_LIMIT, "the document's JSON is larger than the 2 GiB limit");
    if (out.binary)
        out.glb = build_glb(out.json, g);
    return out;
}

} /* namespace rad_gltf */
