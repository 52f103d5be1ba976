/* gltf_bridge.h - private to the glTF loader: the plain-C view of a glTF
 * document that gltf_bridge.cpp (tinygltf, C++) hands to gltf.c (C).
 *
 * Invariant: everything in a rad_gltf_raw has been checked against the
 * document's own rules before gltf.c sees it -- every index is in range,
 * every vertex and matrix is finite, triangle index lists have a multiple of
 * 3 entries and every entry is below the primitive's vertex count.  Only the
 * radiosity-specific rules (ρ < 1, TRIANGLES only, supported extensions) are
 * left to gltf.c.  Textures arrive as their mean linear colour (decoded by
 * gltf_image.c, never as pixels); what the document holds that a diffuse
 * radiosity scene ignores arrives as notes, for gltf.c to warn about.  No
 * C++ type or exception crosses this header.
 */
#ifndef RAD_GLTF_BRIDGE_H
#define RAD_GLTF_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* glTF primitive modes (the numbers of the specification). */
#define RAD_GLTF_MODE_TRIANGLES 4

typedef struct rad_gltf_raw_primitive {
    int mode;              /* glTF mode number; data below is filled only for TRIANGLES */
    int32_t material;      /* glTF material index, -1 = none */
    uint32_t vertex_count;
    double *positions;     /* 3 × vertex_count, the mesh's own (model) space */
    uint32_t index_count;  /* multiple of 3; a non-indexed primitive gets 0,1,2,... */
    uint32_t *indices;     /* every entry < vertex_count */
    double *colors;        /* COLOR_0 as linear RGB (alpha dropped), 3 × vertex_count, each
                            * finite and >= 0; NULL = no vertex colours */
    double *uv[2];         /* TEXCOORD_0 and TEXCOORD_1 as (u, v) pairs, 2 × vertex_count,
                            * each finite; NULL = absent */
} rad_gltf_raw_primitive;

typedef struct rad_gltf_raw_mesh {
    char *name;                        /* glTF name, else "mesh<index>" */
    int used;                          /* instanced by a node of the scene; only then is it read */
    uint32_t primitive_count;          /* 0 when unused */
    rad_gltf_raw_primitive *primitives;
} rad_gltf_raw_mesh;

typedef struct rad_gltf_raw_node {
    char *name;        /* node name, else its mesh's name, else "node<index>" */
    int32_t mesh;      /* -1 = none */
    int in_scene;      /* reachable from the roots of the displayed scene */
    double world[16];  /* node-to-world matrix, column-major as glTF stores it */
} rad_gltf_raw_node;

/* What a material's baseColorTexture or emissiveTexture came to. */
#define RAD_GLTF_TEXTURE_NONE 0       /* the material names none */
#define RAD_GLTF_TEXTURE_READ 1       /* mean holds the image's mean linear colour */
#define RAD_GLTF_TEXTURE_UNREADABLE 2 /* problem says why ("image 2 'a.png': ...") */

typedef struct rad_gltf_raw_texture {
    int state;       /* RAD_GLTF_TEXTURE_* */
    double mean[3];  /* READ: mean over texels of the sRGB-decoded RGB, each in [0, 1] */
    char *problem;   /* UNREADABLE: one line; else NULL */
    /* READ, baseColorTexture only: what a bake needs to draw it */
    int32_t image;   /* index into rad_gltf_raw.images, -1 = not kept */
    uint32_t texcoord;          /* texCoord: the TEXCOORD_n set it samples */
    int transformed;            /* has KHR_texture_transform (not applied) */
    int wrap_s, wrap_t;         /* the sampler's, glTF numbers; 0 = none given */
    int mag_filter, min_filter;
} rad_gltf_raw_texture;

/* An image a kept texture samples: its bytes exactly as the document held
 * them (PNG or JPEG, as their signature says). */
typedef struct rad_gltf_raw_image {
    const char *mime;   /* "image/png" or "image/jpeg" (static) */
    unsigned char *data;
    size_t size;
} rad_gltf_raw_image;

typedef struct rad_gltf_raw_material {
    char *name;               /* glTF name, else "material<index>" */
    int used;                 /* by a primitive of the displayed scene; only then are its
                               * textures read */
    rad_gltf_raw_texture base_texture;     /* pbrMetallicRoughness.baseColorTexture */
    rad_gltf_raw_texture emissive_texture; /* emissiveTexture */
    double base_color[3];     /* pbrMetallicRoughness.baseColorFactor RGB (default 1) */
    double base_alpha;        /* and its alpha (default 1), kept for a bake */
    double emissive[3];       /* emissiveFactor (default 0) */
    double emissive_strength; /* KHR_materials_emissive_strength (default 1) */
    /* KHR_materials_diffuse_transmission: diffuseTransmissionFactor (default
     * 0) and diffuseTransmissionColorFactor (default 1); textures ignored */
    double diffuse_transmission;
    double diffuse_transmission_color[3];
    int double_sided;
    /* pbrMetallicRoughness.metallicFactor when the material states it, else
     * 0 (not glTF's default 1: see gltf.c), and roughnessFactor (default 1) */
    double metallic;
    double roughness;
} rad_gltf_raw_material;

/* One camera as placed by a node of the scene (a glTF camera used by two
 * nodes gives two entries). */
typedef struct rad_gltf_raw_camera {
    char *name;        /* camera name, else node name, else "camera<camera index>" */
    uint32_t node;     /* glTF node index */
    uint32_t camera;   /* glTF camera index */
    int perspective;   /* 0 = orthographic */
    double yfov;       /* radians (perspective only) */
    double aspect;     /* aspectRatio, 0 = absent */
    double xmag, ymag; /* orthographic only: half-width and half-height of the view */
    double world[16];  /* of the node, column-major */
} rad_gltf_raw_camera;

/* KHR_lights_punctual light types. */
#define RAD_GLTF_LIGHT_POINT 0
#define RAD_GLTF_LIGHT_SPOT 1
#define RAD_GLTF_LIGHT_DIRECTIONAL 2

/* One punctual light as placed by a node of the scene (a light used by two
 * nodes gives two entries).  Values as the document gives them (photometric,
 * glTF's defaults filled in); only their types have been checked, the
 * ranges are gltf.c's (through rad_scene_add_light). */
typedef struct rad_gltf_raw_light {
    char *name;          /* light name, else node name, else "light<light index>" */
    uint32_t node;       /* glTF node index */
    uint32_t light;      /* index into KHR_lights_punctual.lights */
    int type;            /* RAD_GLTF_LIGHT_* */
    double color[3];     /* linear RGB (default 1 1 1) */
    double intensity;    /* candela (point, spot) or lux (directional); default 1 */
    double inner_cone;   /* spot.innerConeAngle, radians (default 0) */
    double outer_cone;   /* spot.outerConeAngle, radians (default π/4) */
    double world[16];    /* of the node, column-major */
} rad_gltf_raw_light;

/* Something of the document a diffuse radiosity scene ignores, for one
 * warning line per kind (gltf.c words them); subject names the instance. */
typedef enum rad_gltf_note_kind {
    RAD_GLTF_NOTE_TEXTURES = 0,  /* subject: a material with normal, occlusion or
                                  * metallic-roughness textures */
    RAD_GLTF_NOTE_METALLIC,      /* subject: a material whose metallicFactor is given > 0 */
    RAD_GLTF_NOTE_ALPHA,         /* subject: a material whose alphaMode is not OPAQUE */
    RAD_GLTF_NOTE_ANIMATION,     /* subject: "N animations", "N skins", "mesh 'x' morph targets" */
    RAD_GLTF_NOTE_LIGHT_RANGE,   /* subject: a light with a range */
    RAD_GLTF_NOTE_COUNT
} rad_gltf_note_kind;

typedef struct rad_gltf_raw_note {
    int kind;      /* rad_gltf_note_kind */
    char *subject; /* e.g. "KHR_materials_specular", "'glass'" */
} rad_gltf_raw_note;

typedef struct rad_gltf_raw {
    rad_gltf_raw_node *nodes;
    uint32_t node_count;
    rad_gltf_raw_mesh *meshes;
    uint32_t mesh_count;
    rad_gltf_raw_material *materials;
    uint32_t material_count;
    rad_gltf_raw_camera *cameras;
    uint32_t camera_count;
    rad_gltf_raw_light *lights;
    uint32_t light_count;
    char **extensions_required;
    uint32_t extensions_required_count;
    char **extensions_used;            /* extensionsUsed, for gltf.c to name those it ignores */
    uint32_t extensions_used_count;
    rad_gltf_raw_note *notes;          /* in document order, each subject once per kind */
    uint32_t note_count;
    rad_gltf_raw_image *images;        /* those kept baseColorTextures sample, each once */
    uint32_t image_count;
} rad_gltf_raw;

/* Reads a glTF document (.gltf JSON or .glb, told apart by the "glTF" magic)
 * from memory.  base_dir is the directory external buffers and images are
 * resolved in; only relative URIs below it are opened, and with base_dir
 * NULL no external file is.  max_triangles bounds the triangles the scene would hold (counted
 * over node instances) before anything big is allocated.
 *
 * Returns RAD_OK and sets *out (caller owns it; free with rad_gltf_raw_free),
 * or a rad_result code with *out NULL and "WHERE: WHAT" in msg (the caller
 * puts the file name in front).  Never throws. */
int rad_gltf_bridge_load(const void *data, size_t size, const char *base_dir,
                         uint64_t max_triangles, rad_gltf_raw **out, char *msg,
                         size_t msg_size);

void rad_gltf_raw_free(rad_gltf_raw *raw); /* NULL does nothing */

#ifdef __cplusplus
}
#endif

#endif /* RAD_GLTF_BRIDGE_H */
