/* validate.h - proving the hemi-cube (issue 4): form factors and radiosities
 * of standard configurations, built in code, against closed forms.
 *
 * Each case builds its scene with rad_scene_add_*, meshes it with explicit
 * per-polygon subdivision, computes only the hemi-cube rows it needs and
 * compares one number with a reference that does not come from the
 * hemi-cube: a catalog closed form (Howell), Lambert's contour integral, the
 * exact B = E/(1 − ρ) of a closed enclosure, or a contour-integral solution
 * extrapolated to zero patch size.  Nothing here prints.
 *
 * Form factors between surfaces: F_AB = (1/A_A) Σ_{i∈A} Σ_{j∈B} A_i F_ij.
 */
#ifndef RAD_VALIDATE_H
#define RAD_VALIDATE_H

#include "../core/rad.h"
#include "../scene/scene.h"
#include "../../hemicube/hemicube.h"

typedef enum rad_val_config {
    /* F_AB of directly opposed parallel rectangles a×b, gap c (Howell C-11). */
    RAD_VAL_PARALLEL = 0,
    /* F_AB of perpendicular rectangles sharing an edge of length a; A is a×b,
     * B is a×c (Howell C-14). */
    RAD_VAL_PERPENDICULAR,
    /* F_AB of coaxial parallel disks of radius a (A) and b (B), gap c, built
     * as regular `sides`-gons; reference: the polygon pair's own exact value
     * (hc_ff_polygon_polygon), secondary: the true disks (Howell C-41). */
    RAD_VAL_DISKS,
    /* F from a tiny square patch (the element, 1e-3 of the smallest size
     * across) to a parallel rectangle a×b at distance c, the element under
     * one of its corners (Howell B-3). */
    RAD_VAL_ELEMENT,
    /* Row sums of every patch inside a closed icosahedron (circumradius 1):
     * the hemi-cube must see a wall through every pixel, Σ_j F_ij = 1.
     * value = the row sum farthest from 1. */
    RAD_VAL_ENCLOSURE,
    /* Radiosity in a closed unit cube with E = 1 and reflectance ρ on every
     * patch: B = E/(1 − ρ) exactly.  value = area-weighted mean B. */
    RAD_VAL_CLOSED_CUBE,
    /* Two directly opposed plates a×b, gap c: A emits E = 1 with reflectance
     * rho_a, B reflects rho.  Reference: the 2×2 system with the analytic F
     * solved exactly, B_B = ρ_B F E / (1 − ρ_A ρ_B F²) (exact for the mean
     * when rho_a = 0; otherwise the uniform-plate model, see validate.c).
     * value = area-weighted mean B over plate B. */
    RAD_VAL_PLATES,
    /* Unit cube, ceiling emits E = 1, every face reflects ρ.  value = mean B
     * of the floor.  Reference: collocation with exact point-to-patch factors
     * (Lambert contour integrals, no hemi-cube) at 4, 8 and 16 patches per
     * edge, extrapolated to zero patch size (Aitken); secondary: the same
     * collocation at this case's own subdivision, which is what the hemi-cube
     * tends to as R grows. */
    RAD_VAL_CUBE_LAMP,
    /* Parallel rectangles a×b, gap c, B shifted by (dx, dy) in its plane:
     * offset or partly overlapping (hc_ff_parallel_offset). */
    RAD_VAL_OFFSET,
    /* A closed box a×b×c (floor a×b, height c), every face black: F from
     * the floor to the ceiling (Howell C-11). */
    RAD_VAL_BOX,
    /* The same box: F from the floor to the a×c wall along its edge a
     * (Howell C-14, edge a, widths b and c). */
    RAD_VAL_BOX_WALL,
    RAD_VAL_CONFIG_COUNT
} rad_val_config;

/* One case.  {0} (apart from config) means the configuration's defaults,
 * which rad_validate_defaults fills in. */
typedef struct rad_val_case {
    rad_val_config config;
    char label[24];        /* "near", "unit", "far", "elongated", ... ("" = none) */
    double a, b, c;        /* sizes, see rad_val_config; 0 = unit squares/disks 1 apart */
    uint32_t resolution;   /* hemi-cube R; 0 = 128 */
    uint32_t subdiv;       /* patches per edge of each surface (per side of each fan
                            * triangle for disks and the icosahedron); 0 = the
                            * configuration's default, rad_validate_default_subdiv */
    uint32_t subdiv_long;  /* elongated shapes: patches along the long edge; 0 = subdiv
                            * scaled by the aspect ratio (square patches) */
    uint32_t sides;        /* disks: sides of each polygon; 0 = 32 */
    double rho;            /* reflectance of the receiving surfaces; 0 = 0.5 */
    double rho_a;          /* plates: reflectance of the emitter (0 = black, exact) */
    double tolerance;      /* solver tolerance; 0 = 1e-7 */
    uint32_t processes;    /* hemi-cube worker processes; 0 = all CPUs */
    hc_gl_kind gl;         /* the workers' GL (hc_options.gl); 0 = OSMesa */
    double dx, dy;         /* offset: B's shift in its plane */
    /* How F is computed: RAD_VAL_BARE (0) the hemi-cube's pixel counts
     * alone, at `subdiv`; RAD_VAL_DEFAULTS as `ff` computes F_AB and
     * `solve` its rows at their defaults (exact near entries,
     * hc_options.weak HC_WEAK_SURFACE for F_AB, HC_WEAK_ON for a solve or
     * the row sums; subdiv 0: the default patch size, the scene's
     * diagonal / 34); RAD_VAL_ACCURATE the
     * same with the accurate setting (HC_WEAK_HIGH, `--accuracy high`). */
    uint32_t engine;
} rad_val_case;

enum { RAD_VAL_BARE = 0, RAD_VAL_DEFAULTS = 1, RAD_VAL_ACCURATE = 2 };

typedef struct rad_val_result {
    rad_val_case c;            /* the case with every default filled in */
    char name[96];             /* e.g. "parallel 1x1, gap 1" */
    char quantity[16];         /* "F_AB", "max|rowsum-1|", "B mean", "B floor" */
    uint32_t patches;          /* patches in the mesh */
    uint32_t rows;             /* hemi-cube rows computed */
    double reference;          /* the exact value compared with */
    double value;              /* what the hemi-cube (and solver) gave */
    double rel_error;          /* value/reference − 1 */
    double secondary;          /* a second exact value, NAN when there is none: disks: the
                                * true disks' F; cube lamp: the collocation at this
                                * subdivision (the hemi-cube's limit as R grows);
                                * reflecting plates: the continuum */
    char secondary_what[32];   /* "true disks", "collocation, same mesh", "continuum" */
    double secondary_error;    /* reference/secondary − 1: the polygons' discretisation error,
                                * the mesh's, or the 2×2 model's; NAN if none */
    double worst;              /* closed cube: max_i |B_i/B* − 1|; enclosure: the row sum
                                * farthest from 1 minus 1; NAN otherwise */
    double promised;           /* |rel_error| bound the report promises at the default
                                * settings; 0 when this case is not at them */
    uint32_t iterations;       /* solver sweeps (radiosity cases) */
    double t_mesh, t_form_factors, t_solve, t_reference; /* seconds */
    double seconds;            /* mesh + form factors + solve (not the reference) */
} rad_val_result;

/* The default subdivision of a configuration (what subdiv = 0 means). */
uint32_t rad_validate_default_subdiv(rad_val_config config);

/* Fills every zero field of c with its default (label, config untouched). */
void rad_validate_defaults(rad_val_case *c);

/* Runs one case: builds, meshes, computes the rows, solves where needed, and
 * fills *out (promised = 0; rad_validate_run sets it).  RAD_ERR_USAGE for bad
 * sizes or counts, RAD_ERR_LIMIT beyond 200,000 patches, else whatever the
 * mesher, the hemi-cube or the solver returns. */
int rad_validate_case(const rad_val_case *c, rad_val_result *out, rad_error *err);

/* The case's scene, as rad_validate_case builds it (objects "A" and "B" for
 * the two-surface cases; "x0".."ceiling" for the cubes).  Caller owns *out. */
int rad_validate_build_scene(const rad_val_case *c, rad_scene **out, rad_error *err);

/* The case's reference value and secondary value (NAN if none) with what the
 * secondary is (secondary_what may be NULL), computed without the hemi-cube.
 * Any output pointer may be NULL. */
int rad_validate_reference(const rad_val_case *c, double *reference, double *secondary,
                           char *secondary_what, size_t what_len, rad_error *err);

/* Name of a configuration: "parallel", "perpendicular", "disks", "element",
 * "enclosure", "closed-cube", "plates", "cube-lamp". */
const char *rad_validate_config_name(rad_val_config config);

/* {0} means defaults. */
typedef struct rad_validate_options {
    int quick;                   /* 1 = only the default settings of each standard case */
    const uint32_t *resolutions; /* R values of the resolution sweep; NULL = 32, 64, 256 */
    uint32_t resolution_count;
    uint32_t processes;          /* hemi-cube worker processes; 0 = all CPUs */
    hc_gl_kind gl;               /* the workers' GL (hc_options.gl); 0 = OSMesa */
    /* Called after each case (may be NULL): done of total. */
    void (*progress)(void *user, uint32_t done, uint32_t total, const rad_val_result *last);
    void *progress_user;
    /* 1 = the catalog of issue 39 (rad_validate_catalog) instead of the
     * standard cases, at `engine` (RAD_VAL_DEFAULTS when 0). */
    int catalog;
    uint32_t engine;
} rad_validate_options;

/* The catalog of closed-form pairs (issue 39): parallel squares at gaps
 * 0.05-20 × side, 10:1 strips at 1-20 × width, perpendicular plates from
 * 0.2 × 3 to 5 × 0.5, coaxial disks r/h 0.5-2, boxes' floor to ceiling and
 * to a wall, offset and partly overlapping rectangles, each computed with
 * `engine` (RAD_VAL_DEFAULTS or RAD_VAL_ACCURATE) at the default mesh, with
 * the error promised there (1 % at defaults, 0.1 % accurate).  Writes at
 * most cap; returns how many there are. */
uint32_t rad_validate_catalog(uint32_t engine, rad_val_case *cases, double *promised, uint32_t cap);

/* The standard cases at their default settings, with the relative error the
 * report promises for each (|rel_error| <= promised[k]).  Writes at most cap
 * of them; returns how many there are. */
uint32_t rad_validate_standard(rad_val_case *cases, double *promised, uint32_t cap);

/* Runs the suite: every standard case at its default settings, and unless
 * quick, each again at the sweep's resolutions and at half and twice its
 * default subdivision.  Caller owns *out (free with free()). */
int rad_validate_run(const rad_validate_options *opt, rad_val_result **out, uint32_t *count,
                     rad_error *err);

#endif /* RAD_VALIDATE_H */
