/* scene.h - the scene: named materials, objects, planar convex polygons and
 * cameras, as loaded from a glTF 2.0 file or a plain-text polygon file.
 *
 * A scene is plain data (like cgltf_data): the structs are public so the
 * mesher, the solution store and tests can read them, but they are built only
 * through the functions here, which enforce the invariants:
 *   - every polygon has >= 3 points, finite coordinates, area > 0, is planar
 *     and convex, and its points run counter-clockwise about `normal`;
 *   - 0 <= ρ < 1 and E >= 0 in every band, ρ + τ < 1 (for a material, and
 *     for a polygon's own ρ when it has one);
 *   - names are unique within materials, within objects and within cameras.
 * Ownership: the scene owns every string and array it points to.
 */
#ifndef RAD_SCENE_H
#define RAD_SCENE_H

#include "../core/rad.h"

typedef struct rad_material {
    char *name;
    double rho[RAD_MAX_BANDS];      /* ρ: diffuse reflectance per band, [0, 1) */
    double emission[RAD_MAX_BANDS]; /* E: emitted exitance per band, >= 0 */
    double transmit[RAD_MAX_BANDS]; /* diffuse transmittance per band (0 = opaque) */
    /* A glossy lobe (Ward's isotropic Gaussian), seen only by the gather
     * renderer: the radiosity solve treats every surface as diffuse with ρ
     * and ignores these.  specular = ρ_s, the lobe's reflectance per band
     * (0 = none); roughness r in [0, 1], the lobe's α = r².  Defaults
     * ρ_s = 0, r = 1: pure diffuse (rad_scene_set_material_gloss maps glTF's
     * metallic and roughness here).  Invariant: ρ + ρ_s + τ < 1 per band. */
    double specular[RAD_MAX_BANDS];
    double roughness;
} rad_material;

/* 1 when the material has a glossy lobe in some band. */
static inline int rad_material_glossy(const rad_material *m, uint32_t bands)
{
    for (uint32_t b = 0; b < bands; b++)
        if (m->specular[b] > 0.0)
            return 1;
    return 0;
}

/* 1 when the material transmits in some of the scene's bands: its polygons
 * are thin sheets with two sides (rad_mesh twins). */
static inline int rad_material_transmits(const rad_material *m, uint32_t bands)
{
    for (uint32_t b = 0; b < bands; b++)
        if (m->transmit[b] > 0.0)
            return 1;
    return 0;
}

/* An image as the input held it: the encoded bytes (PNG or JPEG, never
 * re-encoded) and their media type. */
typedef struct rad_image {
    char *mime;          /* "image/png" or "image/jpeg" */
    unsigned char *data; /* size bytes, starting with the format's signature */
    uint64_t size;
} rad_image;

/* glTF sampler values (the specification's numbers), 0 = not given. */
#define RAD_WRAP_REPEAT 10497
#define RAD_WRAP_CLAMP 33071
#define RAD_WRAP_MIRROR 33648

/* Material `material`'s base-colour texture: image `image` sampled at the
 * input's TEXCOORD_<texcoord> set (kept in the scene's point_uv), with the
 * input's sampler and baseColorFactor.  The material's ρ stays the mean
 * reflectance the solve uses. */
typedef struct rad_texture {
    uint32_t material;
    uint32_t image;
    uint32_t texcoord;          /* the input's set number (informative) */
    int wrap_s, wrap_t;         /* RAD_WRAP_* or 0 */
    int mag_filter, min_filter; /* glTF filter numbers or 0 */
    double factor[4];           /* baseColorFactor RGBA as the input gave it */
} rad_texture;

typedef struct rad_object {
    char *name; /* glTF: node name, else mesh name, else "node<index>"; polygon file: polygon or group name */
} rad_object;

typedef struct rad_polygon {
    char *name;            /* for messages; the polygon file's polygon name, glTF "mesh/primitive/triangle" */
    uint32_t first_point;  /* into scene->points */
    uint32_t point_count;  /* >= 3 */
    uint32_t material;
    uint32_t object;
    uint32_t subdiv_u;     /* patches along the first edge; 0 = from the patch size */
    uint32_t subdiv_v;     /* patches along the second edge (quads); 0 = from the patch size */
    rad_vec3 normal;       /* unit */
    double area;
} rad_polygon;

/* A camera looks from eye towards target, up tilting the view.  A
 * perspective camera spans yfov_deg vertically; an orthographic one (glTF's
 * orthographic camera, the polygon file's `ortho`) projects along the view
 * direction onto a window 2·ymag high (and 2·xmag wide where the image's
 * shape agrees; the image's aspect decides, like yfov's), in scene units. */
typedef struct rad_camera {
    char *name;
    rad_vec3 eye, target, up;
    double yfov_deg; /* vertical field of view in degrees; orthographic: 45, unused */
    double aspect;   /* width / height, 0 = from the image size */
    /* appended for orthographic cameras */
    int orthographic;   /* 0 = perspective */
    double xmag, ymag;  /* orthographic: half-width and half-height of the view, > 0 */
} rad_camera;

/* A punctual light (glTF KHR_lights_punctual): no surface of its own, so it
 * is not a polygon; its direct light is shot onto the patches before the
 * solve (pipeline.c).  Radiometric, per band:
 *   point, spot:  intensity = radiant intensity I (power per steradian)
 *                 along the axis; a spot falls off as glTF's smooth t²
 *                 between inner_cone and outer_cone (half-angles);
 *   directional:  intensity = irradiance E⊥ (power per area) on a surface
 *                 facing the light; position is unused.
 * Invariants (rad_scene_add_light): finite values, intensity >= 0, |direction|
 * = 1 (the way light travels), for a spot 0 <= inner < outer <= π/2. */
typedef enum rad_light_kind {
    RAD_LIGHT_POINT = 0,
    RAD_LIGHT_SPOT,
    RAD_LIGHT_DIRECTIONAL
} rad_light_kind;

typedef struct rad_light {
    char *name;
    rad_light_kind kind;
    double intensity[RAD_MAX_BANDS]; /* W/sr (point, spot) or W/m² (directional) per band */
    rad_vec3 position;               /* point, spot */
    rad_vec3 direction;              /* spot, directional: unit, the way light travels */
    double inner_cone, outer_cone;   /* spot: half-angles in radians; others 0 and π/2 */
} rad_light;

typedef struct rad_scene {
    char *source;          /* the file it came from, for messages ("<memory>" if built in code) */
    uint32_t band_count;   /* 1..RAD_MAX_BANDS */
    char *band_names[RAD_MAX_BANDS]; /* optional ("R","G","B" for glTF); NULL = unnamed */
    rad_material *materials;
    uint32_t material_count;
    rad_object *objects;
    uint32_t object_count;
    rad_polygon *polygons;
    uint32_t polygon_count;
    rad_vec3 *points;
    uint32_t point_count;
    rad_camera *cameras;
    uint32_t camera_count;
    /* capacities (private to scene.c) */
    uint32_t material_cap_, object_cap_, polygon_cap_, point_cap_, camera_cap_;
    /* name index for the uniqueness checks and find functions (private to
     * scene.c; NULL is valid and means "scan the arrays") */
    void *names_;
    /* punctual lights (appended after the original fields) */
    rad_light *lights;
    uint32_t light_count;
    uint32_t light_cap_;   /* private to scene.c */
    /* Per-polygon reflectance (glTF vertex colours): NULL when every polygon
     * reflects as its material does, else polygon_count × band_count values
     * ρ of polygon p at
     * [p · band_count + b]; polygons never given one hold their material's.
     * Read it through rad_polygon_rho.  Set by rad_scene_set_polygon_rho. */
    double *polygon_rho;
    uint32_t polygon_rho_cap_; /* polygons polygon_rho has room for (private to scene.c) */
    /* Base-colour textures (glTF baseColorTexture), kept for the bake: the
     * solve reflects with the material's ρ (the texture's mean), a baked
     * file draws the texture under the solved light.  images and textures
     * are empty and point_uv is NULL in a scene without one. */
    rad_image *images;
    uint32_t image_count;
    rad_texture *textures;   /* at most one per material */
    uint32_t texture_count;
    /* Texture coordinates (u, v) of each point, 2 × point_count values at
     * [2k], [2k + 1], or NULL; points never given any hold 0.  Set per
     * polygon by rad_scene_set_polygon_uv. */
    double *point_uv;
    uint32_t image_cap_, texture_cap_, point_uv_cap_; /* private to scene.c */
} rad_scene;

/* ρ per band of polygon p: its own (polygon_rho) or its material's. */
static inline const double *rad_polygon_rho(const rad_scene *s, uint32_t p)
{
    return s->polygon_rho ? s->polygon_rho + (size_t)p * s->band_count
                          : s->materials[s->polygons[p].material].rho;
}

/* Material m's base-colour texture, or NULL. */
static inline const rad_texture *rad_material_texture(const rad_scene *s, uint32_t m)
{
    for (uint32_t k = 0; k < s->texture_count; k++)
        if (s->textures[k].material == m)
            return &s->textures[k];
    return NULL;
}

/* Options for loading; {0} means defaults. */
typedef struct rad_load_options {
    /* Largest number of polygons accepted before anything big is allocated;
     * 0 = 10 million. */
    uint64_t max_polygons;
    /* 1 = accept a scene without emitters (form-factor work needs none). */
    int allow_no_emitter;
    /* Warnings (rad.h): what a loader ignored, clamped or replaced, one
     * line per kind naming the materials, extensions or cameras concerned.
     * NULL drops them. */
    rad_warn_fn warn;
    void *warn_user;
    /* 1 = refuse instead of repairing: a glTF reflectance >= 1 (glTF's
     * default white included) is an error rather than clamped, a primitive
     * without a material is an error rather than given glTF's default
     * material, an unreadable texture or a primitive without area (points,
     * lines) is an error rather than skipped. */
    int strict;
} rad_load_options;

/* Loads a scene, choosing the format by extension (.gltf, .glb, else the
 * polygon file).  On success *out is a new scene the caller owns (free with
 * rad_scene_destroy).  On failure *out is NULL and err says "FILE: WHERE: WHAT". */
int rad_scene_load(const char *path, const rad_load_options *opt, rad_scene **out, rad_error *err);

/* Parses a polygon file held in memory; `name` is used in messages. */
int rad_scene_parse_polyfile(const char *text, size_t size, const char *name,
                             const rad_load_options *opt, rad_scene **out, rad_error *err);

/* Parses glTF (JSON .gltf or binary .glb) held in memory; `name` is used in
 * messages and its directory resolves external buffers (NULL: none allowed). */
int rad_scene_parse_gltf(const void *data, size_t size, const char *name,
                         const rad_load_options *opt, rad_scene **out, rad_error *err);

/* ---- View3D's input file (vs3.c, docs/view3d.md) ---- */

/* The four kinds of View3D surface. */
typedef enum rad_vs3_kind {
    RAD_VS3_SURFACE = 0, /* S: radiating */
    RAD_VS3_OBSTRUCTION, /* O: blocks views, not reported */
    RAD_VS3_MASK,        /* M: faces its base, covering part of it; F_mask,base = 1 */
    RAD_VS3_NULL         /* N: takes its area out of its base, not reported */
} rad_vs3_kind;

typedef struct rad_vs3_surface {
    char *name;               /* as in the file; also its object's and material's name */
    uint32_t number;          /* the file's number (surface i has number i + 1) */
    rad_vs3_kind kind;
    uint32_t base;            /* index of its base surface, RAD_NONE */
    uint32_t combine;         /* index of the surface it is reported with, RAD_NONE */
    double emittance;         /* ε in (0, 1]; its material has ρ = 1 − ε */
    double area;              /* the whole polygon's, before subsurfaces are cut out */
    uint32_t object;          /* its object in the scene */
    unsigned long long line;  /* where it was read */
} rad_vs3_surface;

/* What a .vs3 file says beyond its geometry.  Owned by the caller of
 * rad_vs3_parse / rad_vs3_load; free with rad_vs3_destroy. */
typedef struct rad_vs3 {
    char *title;              /* the last T line ("" when none) */
    int encl;                 /* control encl: 1 = the surfaces form an enclosure */
    int emit;                 /* control emit: 1 = report Hottel's script-F */
    rad_vs3_surface *surfaces;
    uint32_t surface_count;
} rad_vs3;

/* Parses a .vs3 file held in memory into a scene (one object per surface)
 * and, when model is not NULL, its surface records.  Ignored controls are
 * reported through opt->warn.  Errors: "FILE: line N: WHAT". */
int rad_vs3_parse(const char *text, size_t size, const char *name, const rad_load_options *opt,
                  rad_scene **scene, rad_vs3 **model, rad_error *err);
/* rad_vs3_parse without the model (what rad_scene_load calls for .vs3). */
int rad_scene_parse_vs3(const char *text, size_t size, const char *name,
                        const rad_load_options *opt, rad_scene **out, rad_error *err);
/* Reads and parses a .vs3 file, then runs the whole-scene checks (an
 * emitter is never required: the file has none).  Caller owns both. */
int rad_vs3_load(const char *path, const rad_load_options *opt, rad_scene **scene,
                 rad_vs3 **model, rad_error *err);
void rad_vs3_destroy(rad_vs3 *m); /* NULL does nothing */

/* ---- building a scene in code (loaders and tests use these) ---- */

/* New empty scene with band_count bands; NULL on bad band count or OOM.
 * source may be NULL ("<memory>"). Caller owns it. */
rad_scene *rad_scene_create(uint32_t band_count, const char *source);
void rad_scene_destroy(rad_scene *s); /* NULL does nothing */

/* Each add function returns RAD_OK and writes the new index to *index (may be
 * NULL), or fails with "SOURCE: WHERE: WHAT" where WHERE is the caller's
 * `where` (e.g. "line 12", "material 'red'"). Values are copied. */
int rad_scene_add_material(rad_scene *s, const char *name, const double *rho,
                           const double *emission, const double *transmit /* NULL = 0 */,
                           const char *where, uint32_t *index, rad_error *err);
int rad_scene_add_object(rad_scene *s, const char *name, const char *where, uint32_t *index,
                         rad_error *err);

/* The dielectric reflectance at normal incidence that glTF's
 * metallic-roughness model gives a non-metal (F0 = 0.04). */
#define RAD_DIELECTRIC_F0 0.04

/* Gives material `material` a glossy lobe from glTF's metallic-roughness
 * parameters, taking its current ρ as the base colour c (call it right
 * after rad_scene_add_material):
 *   roughness r < 1:  ρ_s = F0 (1 − m) + m c,  ρ = (1 − m)(1 − F0) c,  α = r²
 *   roughness r = 1:  no lobe, ρ = c (a fully rough surface is diffuse, so a
 *                     scene that never names metallic or roughness renders
 *                     exactly as before),
 * F0 = RAD_DIELECTRIC_F0.  0 <= m, r <= 1; fails when ρ + ρ_s + τ >= 1. */
int rad_scene_set_material_gloss(rad_scene *s, uint32_t material, double metallic,
                                 double roughness, const char *where, rad_error *err);

/* Sets the lobe directly (what a stored solution holds): ρ_s per band >= 0,
 * 0 <= roughness <= 1, ρ + ρ_s + τ < 1; nothing changes on failure. */
int rad_scene_set_material_lobe(rad_scene *s, uint32_t material, const double *specular,
                                double roughness, const char *where, rad_error *err);
/* Checks the polygon (count, finite, area, planarity, convexity) and stores
 * it with its normal and area.  Points must run counter-clockwise about the
 * front normal. */
int rad_scene_add_polygon(rad_scene *s, const char *name, uint32_t object, uint32_t material,
                          const rad_vec3 *points, uint32_t count, uint32_t subdiv_u,
                          uint32_t subdiv_v, const char *where, uint32_t *index, rad_error *err);
int rad_scene_add_camera(rad_scene *s, const char *name, rad_vec3 eye, rad_vec3 target,
                         rad_vec3 up, double yfov_deg, double aspect, const char *where,
                         uint32_t *index, rad_error *err);
/* An orthographic camera (see rad_camera): xmag and ymag finite and > 0. */
int rad_scene_add_ortho_camera(rad_scene *s, const char *name, rad_vec3 eye, rad_vec3 target,
                               rad_vec3 up, double xmag, double ymag, const char *where,
                               uint32_t *index, rad_error *err);

/* Makes camera i orthographic with these half-sizes (finite, > 0): what the
 * solution reader does for a camera its SCENE section stored as a
 * perspective placeholder. */
int rad_scene_set_camera_ortho(rad_scene *s, uint32_t camera, double xmag, double ymag,
                               const char *where, rad_error *err);

/* Gives polygon p a reflectance of its own (band_count values, copied),
 * overriding its material's: 0 <= ρ < 1 and ρ + τ < 1 with the material's
 * transmittance τ, in every band.  The first call allocates polygon_rho. */
int rad_scene_set_polygon_rho(rad_scene *s, uint32_t polygon, const double *rho,
                              const char *where, rad_error *err);

/* Adds a copy of an encoded image: mime "image/png" or "image/jpeg" and
 * data starting with that format's signature, size > 0.  *index may be NULL. */
int rad_scene_add_image(rad_scene *s, const char *mime, const unsigned char *data,
                        uint64_t size, const char *where, uint32_t *index, rad_error *err);
/* Gives t->material the texture *t (copied): existing material and image,
 * wrap modes RAD_WRAP_* or 0, finite factors in [0, 1], no texture yet. */
int rad_scene_add_texture(rad_scene *s, const rad_texture *t, const char *where, rad_error *err);
/* Sets the texture coordinates of polygon p's points: 2 × point_count
 * finite values (u0, v0, u1, v1, ...), copied.  The first call allocates
 * point_uv (0 elsewhere). */
int rad_scene_set_polygon_uv(rad_scene *s, uint32_t polygon, const double *uv,
                             const char *where, rad_error *err);

/* Checks and stores a punctual light (see rad_light).  direction is
 * normalised here (it must not be zero for a spot or directional light;
 * a point light ignores it).  Cone angles are ignored except for a spot.
 * Light names are unique among lights. */
int rad_scene_add_light(rad_scene *s, const char *name, rad_light_kind kind,
                        const double *intensity, rad_vec3 position, rad_vec3 direction,
                        double inner_cone, double outer_cone, const char *where,
                        uint32_t *index, rad_error *err);

/* Whole-scene checks after loading: at least one polygon, at least one
 * emitter (E > 0 in some band of a material some polygon uses, or a
 * punctual light with intensity > 0 in some band).  RAD_OK or RAD_ERR_INVALID. */
int rad_scene_validate(const rad_scene *s, rad_error *err);
/* The same checks; need_emitter = 0 leaves out the emitter requirement
 * (form-factor work needs none). */
int rad_scene_check(const rad_scene *s, int need_emitter, rad_error *err);

/* Index of the material/object/camera/light with this name, or RAD_NONE. */
uint32_t rad_scene_find_light(const rad_scene *s, const char *name);
uint32_t rad_scene_find_material(const rad_scene *s, const char *name);
uint32_t rad_scene_find_object(const rad_scene *s, const char *name);
uint32_t rad_scene_find_camera(const rad_scene *s, const char *name);

/* Axis-aligned bounds of all points; returns 0 for an empty scene. */
int rad_scene_bounds(const rad_scene *s, rad_vec3 *lo, rad_vec3 *hi);

#endif /* RAD_SCENE_H */
