/* hemicube.c - form factors F_ij by the hemi-cube, rendered with OSMesa.
 *
 * Owns the worker processes and everything GL.  The caller's process never
 * creates a GL context: hc_create forks `processes` workers, each of which
 * makes its own OSMesa (llvmpipe) context, uploads every patch once and then
 * answers requests "compute rows r0, r1, ..." over a socketpair.  Protocol
 * (native-endian uint32 words, floats for F_ij):
 *   caller -> worker: count, i[count]            (count <= HC_MAX_CHUNK)
 *   worker -> caller: HC_MSG_BATCH, count, then per row i, m, j[m], F_ij[m]
 *   caller -> worker: HC_REQ_POINTS, count, hc_point_req[count]
 *   worker -> caller: HC_MSG_BATCH, count, then per point: index, m, j[m], F_ej[m]
 *   caller -> worker: HC_REQ_LIGHT, hc_light_req (one part of a light)
 *   worker -> caller: HC_MSG_LIGHT, m, j[m], Φ_j[m] (doubles)
 *   caller -> worker: HC_REQ_VIS, hc_light_req, m, hc_point_req[m] (m <= HC_VIS_CHUNK)
 *   worker -> caller: HC_MSG_VIS, m, V[m] (doubles in [0, 1], in the order asked)
 *   on failure:       HC_MSG_ERROR, length, text (then the worker exits)
 *   at start:         0, 0 (ready) or HC_MSG_ERROR, length, text
 * The caller hands out small chunks, at most about two per worker at a time,
 * so faster workers take more; a worker stops when its socket closes.
 *
 * Invariants of every row sent: j strictly increasing, j != i, F_ij > 0,
 * no j lying wholly on or behind i's plane, and Σ_j F_ij <= 1 because the
 * delta form factors ΔF_q are normalised to sum to exactly 1 over the cube
 * (and rows with exact entries are renormalised).  A row depends only on
 * the mesh, R, the exact options and i (fixed basis, fixed draw order, fixed
 * accumulation order), so it is bit-identical whichever worker computes it
 * and however the rows are split.
 *
 * Item-buffer atlas, R wide and 3R tall, GL's bottom-up rows, pixel q at
 * index y·R + x: rows [0, R) are the top face (looking along n_i); then the
 * four half faces (+u, -u, +v, -v), R/2 rows each, their bottom row at the
 * horizon and their top row towards n_i.  hc_delta_form_factors uses the
 * same order.
 *
 * Exact entries (hc_options.exact, .exact_near).  For a candidate j of row
 * i the pixel sum S_ij (ΔF over the pixels showing j) is replaced by
 *   F_ij = F_exact · v_ij,   v_ij = S_ij / S°_ij,
 * where F_exact is hc_ff_point_polygon from (c_i, n_i) to j, or for a j
 * nearer to c_i than its own diameter (exact_near; marked or not) the area
 * average hc_ff_polygon_polygon from i to j: near a patch, the point c_i is
 * what is wrong with the hemi-cube, not the pixel count.  S°_ij is the same sum in a
 * second rendering of only the candidates with the depth test off and
 * GL_OR logic: candidate j writes bit (j mod 32), so a pixel lists every
 * candidate covering it and S°_ij is j's whole unoccluded projection even
 * where candidates overlap (more than one pass when 32 residues do not
 * suffice).  Both sums cover the same rasterisation, so an unoccluded j gets
 * v_ij = 1 exactly.  A candidate with no pixel (sub-pixel, or wholly hidden)
 * is probed instead: v_ij is 1 or 0 as c_j is visible or hidden at the one
 * pixel holding the direction to it (probe_visible).  A far candidate's
 * v_ij is then measured again in a focused view (focused_visibility): an
 * R×R item buffer aimed at its polygon's candidates, which fill it, so a
 * shadow's edge moves v_ij in steps of about 1/R of the source's width
 * rather than one hemi-cube pixel (a twelfth to a fifteenth of the
 * Cornell light at R = 128).  Only candidates small on the hemi-cube get
 * one, at most HC_FOCUS_VIEWS a row, and the view is rendered only when
 * some patch inside it lies between c_i and the source, else v_ij = 1.
 * With far exact
 * entries only, the pixel entries are then rescaled so that the row keeps
 * the cube's own total Σ_j F_ij (1 in a closed room): exact entries
 * redistribute the row and never open a closed room; with near entries the
 * row is only kept from exceeding 1 (renormalisation, see compute_row).
 *
 * Lights (hc_light_power) are a second request type served by the same
 * workers: one request per cube face (the directional light's single view
 * is part 0), answered with Φ_j of that part; the caller adds the parts in
 * part order, so the result never depends on which worker drew what.
 * Visibility of points (hc_light_visibility) is a third: points are grouped
 * by the part their direction falls in, and a worker renders a part's item
 * buffer once (light_render keeps the last part drawn: same request, same
 * pixels) and looks each point up in it (point_visibility).  Both read the
 * one rendering code, so a point and the patch power agree on what the light
 * sees.
 */
#define GL_GLEXT_PROTOTYPES 1
#include "hemicube.h"

#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <errno.h>
#include <malloc.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define HC_NO_PATCH 0xFFFFFFFFu   /* item-buffer clear value */
#define HC_MSG_ERROR 0xFFFFFFFFu  /* row field of a worker's error message */
#define HC_MSG_BATCH 0xFFFFFFFEu  /* header of the answer to one request */
#define HC_MSG_LIGHT 0xFFFFFFFDu  /* header of the answer to one light part */
#define HC_REQ_LIGHT 0xFFFFFFF0u  /* request word of a light part (else: a row count) */
#define HC_REQ_POINTS 0xFFFFFFF1u /* request word of a chunk of point receivers */
#define HC_REQ_VIS 0xFFFFFFF2u    /* request word of a chunk of points seen from a light part */
#define HC_MSG_VIS 0xFFFFFFFCu    /* header of the answer to one visibility chunk */
#define HC_VIS_CHUNK 4096u        /* points per visibility request */
#define HC_LIGHT_DEFAULT_R 512u   /* hc_light_power's resolution 0 */
/* A candidate shows nothing nearer than this relative depth margin: a
 * coplanar neighbour (a light flush with its ceiling) never hides it. */
#define HC_PROBE_MARGIN 1e-4
/* Bound of the area-average subdivision of exact_near entries: 16² sub-
 * triangles per fan triangle give ~1e-4 at a gap of 1 % of the size. */
#define HC_NEAR_MAX_SUBDIV 16u
/* Focused views (focused_visibility) are for candidates covering fewer
 * hemi-cube pixels than this (1/16 of the view: a quarter of its width),
 * and a candidate covering fewer of its polygon's view gets one of its own. */
#define HC_FOCUS_PIXELS(R) ((R) * (R) / 16u)
#define HC_FOCUS_VIEWS 8u  /* focused views a row may render at most */
#define HC_FLUSH (1u << 20)       /* a worker sends when this much is buffered */
#define HC_MAX_PROCESSES 1024u
#define HC_MAX_CHUNK 32u
#define HC_MAX_MSG 900u
/* Consecutive patches culled together against i's plane by a bounding
 * sphere: half the scene is usually behind the plane. */
#define HC_BLOCK 16u
/* Six vertices per quad must fit GLint `first`. */
#define HC_MAX_PATCHES (UINT32_C(1) << 28)

/* One point receiver of a HC_REQ_POINTS chunk: the cube sits at `at`
 * (relative to the scene origin) on patch `patch`; `index` is the caller's
 * receiver number, echoed in the answer. */
typedef struct hc_point_req {
    uint32_t index, patch;
    double at[3];
} hc_point_req;

/* One part of a light request.  pos is relative to the scene origin. */
typedef struct hc_light_req {
    uint32_t resolution, kind, part, pad;
    double pos[3], dir[3];
    double cos_inner, cos_outer;
} hc_light_req;

typedef struct hc_worker {
    pid_t pid;
    int fd;
    uint32_t in_flight; /* rows sent and not yet answered */
} hc_worker;

struct hc_engine {
    const rad_mesh *mesh;
    uint32_t n;       /* patches */
    uint32_t R;       /* resolution */
    uint32_t nproc;
    uint32_t lp_threads; /* llvmpipe threads per worker (0: none) */
    hc_options opt;
    double *dff;      /* normalised ΔF_q, 3R² (atlas order) */
    /* Geometry relative to the bounding-box centre, in double, prepared before
     * the fork so every worker shares it copy-on-write. */
    rad_vec3 origin;
    double tol;        /* "strictly in front" margin, scene-relative */
    double *corner;    /* n × 4 × 3: patch corners - origin */
    rad_vec3 *center;  /* n: patch centre - origin */
    uint8_t *ncorner;  /* n: 3 or 4 */
    double *bsphere;   /* per HC_BLOCK consecutive patches: centre - origin, radius */
    double *radius;    /* n: largest distance from patch centre to a corner */
    double bradius;    /* every corner lies within this distance of the origin */
    uint8_t *exact;    /* n: copy of opt->exact, or NULL */
    int any_exact;     /* rows have candidates: exact marks or exact_near */
    hc_worker *w;
    int broken;        /* a worker is gone: every later call fails */
    char broken_msg[HC_MAX_MSG + 64];
    uint32_t *rx_col;  /* receive buffers in the caller */
    float *rx_val;
};

/* ------------------------------------------------------------ socket I/O */

/* 0 on success, -1 on error or EOF.  MSG_NOSIGNAL: a dead peer must not
 * SIGPIPE us. */
static int send_all(int fd, const void *p, size_t len)
{
    const char *c = p;
    while (len) {
        ssize_t k = send(fd, c, len, MSG_NOSIGNAL);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        c += k;
        len -= (size_t)k;
    }
    return 0;
}

static int recv_all(int fd, void *p, size_t len)
{
    char *c = p;
    while (len) {
        ssize_t k = recv(fd, c, len, 0);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        if (k == 0)
            return -1;
        c += k;
        len -= (size_t)k;
    }
    return 0;
}

/* -------------------------------------------------------- delta form factors */

static int resolution_ok(uint32_t R) { return R >= 8 && R <= 4096 && R % 2 == 0; }

double hc_delta_form_factors(uint32_t resolution, double *out)
{
    uint32_t R = resolution;
    if (!out || !resolution_ok(R))
        return 0.0;
    /* Cube of half-width 1: pixels are 2/R wide, ΔA = (2/R)², sampled at the
     * pixel centre (paper, Fig. 7). */
    double d = 2.0 / R, dA = d * d, sum = 0.0;
    size_t k = 0;
    for (uint32_t y = 0; y < R; y++)
        for (uint32_t x = 0; x < R; x++) {
            double px = -1.0 + (x + 0.5) * d, py = -1.0 + (y + 0.5) * d;
            double r2 = px * px + py * py + 1.0;
            out[k] = dA / (M_PI * r2 * r2);
            sum += out[k++];
        }
    for (int f = 0; f < 4; f++)
        for (uint32_t z = 0; z < R / 2; z++)
            for (uint32_t x = 0; x < R; x++) {
                double py = -1.0 + (x + 0.5) * d, pz = (z + 0.5) * d;
                double r2 = py * py + pz * pz + 1.0;
                out[k] = pz * dA / (M_PI * r2 * r2);
                sum += out[k++];
            }
    /* The pixel-centre rule misses the exact 1 by O(1/R²); normalising makes
     * a fully covered cube give Σ_j F_ij = 1 exactly, which the solver's
     * energy balance relies on. */
    for (size_t q = 0; q < k; q++)
        out[q] /= sum;
    return sum;
}

/* ------------------------------------------------------------ worker: GL */

/* A candidate for an exact entry in the current row. */
typedef struct hc_cand {
    uint32_t j;
    uint32_t pass;     /* OR pass that measures S°_ij: earlier candidates with j's residue */
    double occ;        /* S_ij: ΔF of the pixels showing j in the occluded item buffer */
    double free;       /* S°_ij: the same with only the candidates drawn;
                        * for a candidate without pixels, the probe's 1 or 0 */
    double exact;      /* F_exact */
    double vis;        /* v_ij */
    uint32_t px;       /* pixels of S°_ij */
    uint8_t focus;     /* 1: its focused view is still to be measured */
    uint8_t faces;     /* bit f: drawn on hemi-cube face f */
    uint8_t near;      /* nearer to c_i than its own diameter */
} hc_cand;

typedef struct hc_gl {
    OSMesaContext ctx;
    unsigned char dummy[16];
    GLuint fbo, rb[2], prog, vao, vbo;
    GLint loc_m, loc_eye, loc_mode;
    uint32_t nvert;    /* vertices in the VBO */
    hc_cand *cand;     /* n when any_exact, else NULL */
    uint32_t *order;   /* n when any_exact: candidates of one OR pass, then the
                        * patches of one focused view */
    uint8_t *mark;     /* n when any_exact: 1 for the current row's candidates, else 0 */
    uint32_t *fslot;   /* 2n when any_exact: a focused view's candidates (indices into cand),
                        * then their pixel counts */
    double *fsum;      /* 3n when any_exact: a focused view's sums S, S° and visibilities */
    /* Light target, R×R, made on the first light request of that size. */
    GLuint lfbo, lrb[2];
    uint32_t lR;
    hc_light_req lkey; /* the part whose item buffer lpixels holds, when lkey_valid */
    int lkey_valid;
    uint32_t *lpixels; /* lR² */
    double *lweight;   /* lR²: pixel solid angle of a cube face, 6 faces sum to 4π */
    double *lval;      /* n: Φ_j of one answer */
    hc_point_req *vpts; /* HC_VIS_CHUNK: the points of a visibility request */
    double *vis;       /* HC_VIS_CHUNK: their visibilities */
    GLint *vfirst;     /* n: first vertex of patch j in the VBO */
    GLsizei *vcount;   /* n: 3 or 6 */
    uint32_t *pixels;  /* 3R² */
    double *acc;       /* n: F_ij accumulators, zero between rows */
    uint32_t *front;   /* patches in front of the current plane, ascending */
    GLint *first[5];   /* per face: merged vertex ranges */
    GLsizei *count[5];
    uint32_t *col;     /* one row's entries */
    float *val;
    unsigned char *out; /* replies not yet sent */
    size_t out_len, out_cap;
} hc_gl;

static const char *vs_src =
    "#version 450 core\n"
    "layout(location = 0) in vec3 pos;\n"
    "layout(location = 1) in uint id;\n"
    "uniform mat4 m;\n"
    "uniform vec3 eye;\n"
    "flat out uint vid;\n"
    "void main() { vid = id; gl_Position = m * vec4(pos - eye, 1.0); }\n";

/* A patch seen from behind still hides what lies beyond it, but its back
 * side is no patch: it neither sends nor receives (one-sided patches), so its
 * pixels keep "no patch" and reciprocity A_i F_ij = A_j F_ji holds.  A back
 * side also gives up depth ties: it is pushed 1e-5 (relative) farther, so
 * the front of a coincident surface (a glTF double-sided copy, back to back
 * with its original) wins whatever the drawing order.  depth_less: the
 * written depth is never nearer (reversed-Z), so early depth tests stay valid.
 * mode 1 is the candidates' OR pass: a front side sets bit (id mod 32). */
static const char *fs_src =
    "#version 450 core\n"
    "flat in uint vid;\n"
    "uniform uint mode;\n"
    "layout(location = 0) out uint item;\n"
    "layout(depth_less) out float gl_FragDepth;\n"
    "void main() {\n"
    "    gl_FragDepth = gl_FrontFacing ? gl_FragCoord.z : gl_FragCoord.z * 0.99999;\n"
    "    if (mode == 0u) item = gl_FrontFacing ? vid : 0xFFFFFFFFu;\n"
    "    else item = gl_FrontFacing ? (1u << (vid & 31u)) : 0u;\n"
    "}\n";

static int gl_check(const char *where, char *msg)
{
    GLenum e = glGetError();
    if (e == GL_NO_ERROR)
        return 0;
    snprintf(msg, HC_MAX_MSG, "hemi-cube: %s: GL error 0x%04x", where, (unsigned)e);
    return -1;
}

static GLuint compile(GLenum type, const char *src, char *msg)
{
    GLuint s = glCreateShader(type);
    glShaderSource(s, 1, &src, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[512] = "";
        glGetShaderInfoLog(s, sizeof log, NULL, log);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: shader compile failed: %s", log);
        glDeleteShader(s);
        return 0;
    }
    return s;
}

/* Context, atlas FBO, shader and the one VBO holding every patch (patch j's
 * triangles contiguous, positions relative to the bounding-box centre). */
static int gl_setup(const hc_engine *e, hc_gl *g, char *msg)
{
    const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0,
                           OSMESA_STENCIL_BITS, 0, OSMESA_ACCUM_BITS, 0,
                           OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION, 4, OSMESA_CONTEXT_MINOR_VERSION, 5, 0};
    g->ctx = OSMesaCreateContextAttribs(attribs, NULL);
    if (!g->ctx) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: OSMesa could not create a GL 4.5 core context");
        return -1;
    }
    if (!OSMesaMakeCurrent(g->ctx, g->dummy, GL_UNSIGNED_BYTE, 1, 1)) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: OSMesaMakeCurrent failed");
        return -1;
    }
    GLsizei R = (GLsizei)e->R;
    GLint max_rb = 0;
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
    if (max_rb < 3 * R) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: resolution %d needs a %d-pixel render buffer, GL allows %d",
                 (int)R, (int)(3 * R), (int)max_rb);
        return -1;
    }
    glGenFramebuffers(1, &g->fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, g->fbo);
    glGenRenderbuffers(2, g->rb);
    glBindRenderbuffer(GL_RENDERBUFFER, g->rb[0]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_R32UI, R, 3 * R);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g->rb[0]);
    glBindRenderbuffer(GL_RENDERBUFFER, g->rb[1]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, R, 3 * R);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, g->rb[1]);
    GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: item-buffer framebuffer incomplete (0x%04x)",
                 (unsigned)status);
        return -1;
    }
    const GLenum draw = GL_COLOR_ATTACHMENT0;
    glDrawBuffers(1, &draw);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);

    /* Reversed Z with an infinite far plane: depth = near/distance in a
     * float buffer keeps ~24 bits of relative precision at every distance,
     * so surfaces a hundredth of a patch apart still resolve.  (libOSMesa
     * exports every GL entry point but glClipControl.) */
    PFNGLCLIPCONTROLPROC clip_control = (PFNGLCLIPCONTROLPROC)OSMesaGetProcAddress("glClipControl");
    if (!clip_control) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: glClipControl is not available");
        return -1;
    }
    clip_control(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GREATER);
    glEnable(GL_SCISSOR_TEST);
    glDisable(GL_CULL_FACE);
    glDisable(GL_DITHER);
    glDisable(GL_BLEND);
    if (gl_check("framebuffer set-up", msg))
        return -1;

    GLuint vs = compile(GL_VERTEX_SHADER, vs_src, msg);
    if (!vs)
        return -1;
    GLuint fs = compile(GL_FRAGMENT_SHADER, fs_src, msg);
    if (!fs)
        return -1;
    g->prog = glCreateProgram();
    glAttachShader(g->prog, vs);
    glAttachShader(g->prog, fs);
    glLinkProgram(g->prog);
    GLint ok = 0;
    glGetProgramiv(g->prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[512] = "";
        glGetProgramInfoLog(g->prog, sizeof log, NULL, log);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: shader link failed: %s", log);
        return -1;
    }
    glDeleteShader(vs);
    glDeleteShader(fs);
    glUseProgram(g->prog);
    g->loc_m = glGetUniformLocation(g->prog, "m");
    g->loc_eye = glGetUniformLocation(g->prog, "eye");
    g->loc_mode = glGetUniformLocation(g->prog, "mode");
    glUniform1ui(g->loc_mode, 0u);

    /* Vertex: float x, y, z relative to the origin, then uint32 patch id. */
    uint32_t n = e->n;
    size_t nv = 0;
    for (uint32_t j = 0; j < n; j++) {
        g->vfirst[j] = (GLint)nv;
        g->vcount[j] = e->ncorner[j] == 4 ? 6 : 3;
        nv += (size_t)g->vcount[j];
    }
    g->nvert = (uint32_t)nv;
    glGenVertexArrays(1, &g->vao);
    glBindVertexArray(g->vao);
    glGenBuffers(1, &g->vbo);
    glBindBuffer(GL_ARRAY_BUFFER, g->vbo);
    if (nv) {
        struct vtx { float p[3]; uint32_t id; } *buf = malloc(nv * sizeof *buf);
        if (!buf) {
            snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for %zu vertices", nv);
            return -1;
        }
        static const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
        size_t k = 0;
        for (uint32_t j = 0; j < n; j++) {
            const double *c = e->corner + (size_t)j * 12;
            for (int t = 0; t < (e->ncorner[j] == 4 ? 2 : 1); t++)
                for (int s = 0; s < 3; s++) {
                    const double *p = c + 3 * tri[t][s];
                    buf[k].p[0] = (float)p[0];
                    buf[k].p[1] = (float)p[1];
                    buf[k].p[2] = (float)p[2];
                    buf[k].id = j;
                    k++;
                }
        }
        glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(nv * sizeof *buf), buf, GL_STATIC_DRAW);
        free(buf);
    }
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 16, (const void *)0);
    glVertexAttribIPointer(1, 1, GL_UNSIGNED_INT, 16, (const void *)12);
    glEnableVertexAttribArray(0);
    glEnableVertexAttribArray(1);
    return gl_check("geometry upload", msg);
}

/* Deterministic orthonormal basis (u, v, n) with u × v = n. */
static void basis(rad_vec3 n, rad_vec3 *u, rad_vec3 *v)
{
    double ax = fabs(n.x), ay = fabs(n.y), az = fabs(n.z);
    rad_vec3 a = ax <= ay && ax <= az ? rad_v3(1, 0, 0) : ay <= az ? rad_v3(0, 1, 0) : rad_v3(0, 0, 1);
    *u = rad_normalize(rad_cross(n, a));
    *v = rad_cross(n, *u);
}

/* Frustum planes through the eye, as bits of a mask; a patch is skipped for
 * a face when every corner lies outside one of the face's four planes.  With
 * a = p·u, b = p·v, h = p·n (p relative to the eye):  */
enum {
    PL_H_MA = 1 << 0,  /* h - a */
    PL_H_PA = 1 << 1,  /* h + a */
    PL_H_MB = 1 << 2,  /* h - b */
    PL_H_PB = 1 << 3,  /* h + b */
    PL_A_MB = 1 << 4,  /* a - b */
    PL_A_PB = 1 << 5,  /* a + b */
    PL_NA_MB = 1 << 6, /* -a - b */
    PL_B_MA = 1 << 7,  /* b - a */
    PL_H = 1 << 8,     /* h: above the horizon */
    PL_A_MH = 1 << 9,  /* a - h */
    PL_NA_MH = 1 << 10,/* -a - h */
    PL_B_MH = 1 << 11, /* b - h */
    PL_NB_MH = 1 << 12 /* -b - h */
};
static const unsigned face_planes[5] = {
    PL_H_MA | PL_H_PA | PL_H_MB | PL_H_PB, /* top: |a| <= h, |b| <= h */
    PL_A_MB | PL_A_PB | PL_H | PL_A_MH,    /* +u: |b| <= a, 0 <= h <= a */
    PL_NA_MB | PL_B_MA | PL_H | PL_NA_MH,  /* -u: |b| <= -a, 0 <= h <= -a */
    PL_B_MA | PL_A_PB | PL_H | PL_B_MH,    /* +v: |a| <= b, 0 <= h <= b */
    PL_NA_MB | PL_A_MB | PL_H | PL_NB_MH,  /* -v: |a| <= -b, 0 <= h <= -b */
};

static void set_mat(double m[16], rad_vec3 right, rad_vec3 up, rad_vec3 d, int side, double near)
{
    /* Row-major P·V for a camera looking along d (eye space: x right, y up,
     * -z forward).  Top face: x, y in [-1, 1] at distance 1; side faces:
     * x in [-1, 1], "up" in [0, 1].  Reversed-Z infinite projection:
     * clip z = near, clip w = distance along d. */
    double ys = side ? 2.0 : 1.0;
    double r0[4] = {right.x, right.y, right.z, 0};
    double r1[4] = {ys * up.x - (side ? d.x : 0), ys * up.y - (side ? d.y : 0),
                    ys * up.z - (side ? d.z : 0), 0};
    double r2[4] = {0, 0, 0, near};
    double r3[4] = {d.x, d.y, d.z, 0};
    memcpy(m, r0, sizeof r0);
    memcpy(m + 4, r1, sizeof r1);
    memcpy(m + 8, r2, sizeof r2);
    memcpy(m + 12, r3, sizeof r3);
}

/* Per-face matrix (float, row-major), viewport row and height of the atlas. */
typedef struct hc_faces {
    float m[5][16];
    GLint y0[5];
    GLsizei h[5];
} hc_faces;

static void face_setup(hc_faces *fs, const rad_vec3 fr[5][3], uint32_t R, double near)
{
    for (int f = 0; f < 5; f++) {
        double m[16];
        set_mat(m, fr[f][0], fr[f][1], fr[f][2], f != 0, near);
        for (int k = 0; k < 16; k++)
            fs->m[f][k] = (float)m[k];
        fs->y0[f] = f == 0 ? 0 : (GLint)(R + (uint32_t)(f - 1) * (R / 2));
        fs->h[f] = f == 0 ? (GLsizei)R : (GLsizei)(R / 2);
    }
}

static void draw_face(const hc_faces *fs, hc_gl *g, int f, uint32_t R, const GLint *first,
                      const GLsizei *count, GLsizei nr)
{
    glViewport(0, fs->y0[f], (GLsizei)R, fs->h[f]);
    glScissor(0, fs->y0[f], (GLsizei)R, fs->h[f]);
    glUniformMatrix4fv(g->loc_m, 1, GL_TRUE, fs->m[f]);
    glMultiDrawArrays(GL_TRIANGLES, first, count, nr);
}

/* Appends patch j's vertices to a draw list of merged ranges (first[],
 * count[], *nr of them), extending the last range when j follows *last. */
static void push_range(const hc_gl *g, GLint *first, GLsizei *count, GLsizei *nr, uint32_t *last,
                       uint32_t j)
{
    if (*nr > 0 && *last + 1 == j) {
        count[*nr - 1] += g->vcount[j];
    } else {
        first[*nr] = g->vfirst[j];
        count[*nr] = g->vcount[j];
        (*nr)++;
    }
    *last = j;
}

/* Makes an R×R view at row y0 of the atlas current with the row-major
 * projection m, and clears its item and depth buffers. */
static void square_view(const hc_gl *g, const double m[16], uint32_t R, uint32_t y0)
{
    float mf[16];
    for (int k = 0; k < 16; k++)
        mf[k] = (float)m[k];
    const GLuint clear_id[4] = {HC_NO_PATCH, 0, 0, 0};
    const GLfloat clear_depth = 0.0f;
    glViewport(0, (GLint)y0, (GLsizei)R, (GLsizei)R);
    glScissor(0, (GLint)y0, (GLsizei)R, (GLsizei)R);
    glClearBufferuiv(GL_COLOR, 0, clear_id);
    glClearBufferfv(GL_DEPTH, 0, &clear_depth);
    glUniformMatrix4fv(g->loc_m, 1, GL_TRUE, mf);
}

static void load_corners(const hc_engine *e, uint32_t j, rad_vec3 p[4])
{
    const double *q = e->corner + (size_t)j * 12;
    for (int k = 0; k < 4; k++)
        p[k] = rad_v3(q[3 * k], q[3 * k + 1], q[3 * k + 2]);
}

/* The probe of a candidate without pixels: is c_j hidden at the pixel q
 * holding the direction to it?  When q shows a patch k (never j, which has
 * no pixel), j is hidden when c_j lies behind k's plane as seen from c_i: a
 * surface flush with j, like the ceiling around a small light, or one
 * beyond it never hides it.  When q shows a back side (no patch), the depth buffer decides: hidden
 * when it holds something nearer than c_j.  An empty q hides nothing. */
static int probe_visible(const hc_engine *e, const hc_gl *g, uint32_t j, rad_vec3 c,
                         const rad_vec3 fr[5][3], double near)
{
    const uint32_t R = e->R;
    const rad_vec3 d = rad_sub(e->center[j], c), nj = e->mesh->patches[j].normal;
    if (!(rad_dot(d, nj) < 0.0))
        return 0; /* c_i sees j's back, or lies in j's plane */
    double h = rad_dot(d, fr[0][2]), a = rad_dot(d, fr[1][2]), b = rad_dot(d, fr[3][2]);
    if (!(h > 0.0))
        return 0; /* centre on or below the horizon: left to the pixel sum (0) */
    int f = fabs(a) <= h && fabs(b) <= h ? 0 : fabs(a) >= fabs(b) ? (a > 0 ? 1 : 2) : (b > 0 ? 3 : 4);
    const rad_vec3 rt = fr[f][0], up = fr[f][1], fw = fr[f][2];
    double w = rad_dot(d, fw), x = rad_dot(d, rt) / w, y = rad_dot(d, up) / w;
    long rows = f == 0 ? (long)R : (long)R / 2;
    long px = (long)floor((x + 1.0) * 0.5 * R);
    long py = (long)floor(f == 0 ? (y + 1.0) * 0.5 * R : y * (R / 2));
    px = px < 0 ? 0 : px >= (long)R ? (long)R - 1 : px;
    py = py < 0 ? 0 : py >= rows ? rows - 1 : py;
    long row = f == 0 ? py : (long)R + (f - 1) * ((long)R / 2) + py;
    uint32_t k = g->pixels[(size_t)row * R + (size_t)px];
    double dl = rad_length(d);
    if (k < e->n) {
        const rad_vec3 nk = e->mesh->patches[k].normal;
        return rad_dot(rad_sub(e->center[j], e->center[k]), nk) >= -HC_PROBE_MARGIN * dl;
    }
    GLfloat D = 0.0f;
    glReadPixels((GLint)px, (GLint)row, 1, 1, GL_DEPTH_COMPONENT, GL_FLOAT, &D);
    return !((double)D > near / w * (1.0 + HC_PROBE_MARGIN));
}

/* The visibilities v_ij of far exact candidates js[0..nj) (ascending, all
 * patches of one polygon, so that none can hide another), measured in a
 * view of their own: an R×R item buffer from c_i aimed at their centre and
 * just wide enough to hold them, so that they cover most of it instead of
 * the few hundred pixels they cover on the hemi-cube (at R = 128 the
 * Cornell light, 0.13 × 0.105 m seen from the middle of the floor 0.55 m
 * below, is about 15 × 12 pixels, and a block's edge sweeping across it
 * changed v in steps of 1/15 to 1/12).  Two
 * renderings: every patch in front of i inside the view (S_j), and the
 * candidates alone (S°_j); both sum the weight cosθ_i dω of the pixels
 * showing j (in the view's tangent plane at (x, y), dω ∝ (1 + x² + y²)^{-3/2}
 * and cosθ_i ∝ the direction's dot n_i over its length), so v_ij = S_j / S°_j
 * is the cosine-weighted fraction of j that c_i sees, as F_exact weighs it.
 * cover[k] counts the pixels of js[k] in the second rendering, and vis[k]
 * is -1 for a candidate without any (sub-pixel in this view).  Sets
 * vis[k] = 1 without rendering when no other patch lies inside the view
 * between c_i and the polygon's plane (nothing can hide them: the light's
 * own patches, the ceiling around it; cover[k] is then R²), and returns -1
 * (vis untouched) when the candidates are too wide for one view (a corner
 * 76° or more off the view's axis). */
static int focused_visibility(const hc_engine *e, hc_gl *g, const uint32_t *js, uint32_t nj,
                              rad_vec3 c, rad_vec3 ni, uint32_t nfront, double near, double *vis,
                              uint32_t *cover)
{
    const uint32_t R = e->R;
    const rad_vec3 pn = e->mesh->patches[js[0]].normal;
    rad_vec3 mid = rad_v3(0, 0, 0), p0[4];
    for (uint32_t k = 0; k < nj; k++)
        mid = rad_add(mid, e->center[js[k]]);
    const rad_vec3 d = rad_normalize(rad_sub(rad_scale(mid, 1.0 / nj), c));
    rad_vec3 bu, up;
    basis(d, &bu, &up);
    const rad_vec3 rt = rad_cross(d, up); /* right = forward × up: unmirrored, as the faces */
    double span = 0.0;
    for (uint32_t k = 0; k < nj; k++) {
        rad_vec3 pj[4];
        load_corners(e, js[k], pj);
        if (k == 0)
            memcpy(p0, pj, sizeof p0);
        for (int q = 0; q < e->ncorner[js[k]]; q++) {
            rad_vec3 r = rad_sub(pj[q], c);
            double w = rad_dot(r, d);
            if (!(w > 0.25 * rad_length(r)))
                return -1;
            span = fmax(span, fmax(fabs(rad_dot(r, rt)), fabs(rad_dot(r, up))) / w);
        }
    }
    span *= 1.02; /* a margin: the edge pixels stay inside the view */
    if (!(span > 0.0))
        return -1;
    /* The patches to draw: those with a corner inside the view's four planes
     * (conservative, as the faces' culling).  A patch can hide a candidate
     * only if some of it lies inside the view between c_i and the polygon's
     * plane: it is clipped to those five planes (the polygon's moved a margin
     * towards c_i, so that what is flush with it never counts). */
    const double margin = 1e-6 * e->radius[js[0]];
    const double jd = rad_dot(rad_sub(p0[0], c), pn); /* < 0: c_i sees the front */
    const rad_vec3 pa[5] = {rad_sub(rad_scale(d, span), rt), rad_add(rad_scale(d, span), rt),
                            rad_sub(rad_scale(d, span), up), rad_add(rad_scale(d, span), up), pn};
    const double po[5] = {0, 0, 0, 0, -jd - margin};
    GLsizei nr = 0;
    uint32_t last = 0, next = 0;
    int hider = 0;
    for (uint32_t k = 0; k < nfront; k++) {
        uint32_t m = g->front[k];
        const double *p = e->corner + (size_t)m * 12;
        rad_vec3 poly[2][16];
        int np = e->ncorner[m];
        unsigned in = 0;
        for (int q = 0; q < np; q++) {
            rad_vec3 r = rad_v3(p[3 * q] - c.x, p[3 * q + 1] - c.y, p[3 * q + 2] - c.z);
            for (int pl = 0; pl < 4; pl++)
                in |= (unsigned)(rad_dot(pa[pl], r) >= 0) << pl;
            poly[0][q] = r;
        }
        if (in != 15u)
            continue;
        push_range(g, g->first[0], g->count[0], &nr, &last, m);
        while (next < nj && js[next] < m)
            next++;
        if (hider || (next < nj && js[next] == m))
            continue;
        int cur = 0;
        for (int pl = 0; pl < 5 && np > 0; pl++) {
            int nn = 0;
            for (int q = 0; q < np; q++) {
                rad_vec3 a = poly[cur][q], b = poly[cur][(q + 1) % np];
                double da = rad_dot(pa[pl], a) + po[pl], db = rad_dot(pa[pl], b) + po[pl];
                if (da >= 0)
                    poly[!cur][nn++] = a;
                if ((da >= 0) != (db >= 0))
                    poly[!cur][nn++] = rad_add(a, rad_scale(rad_sub(b, a), da / (da - db)));
            }
            np = nn;
            cur = !cur;
        }
        hider = np > 0;
    }
    if (!hider) {
        for (uint32_t k = 0; k < nj; k++) {
            vis[k] = 1.0;
            cover[k] = R * R;
        }
        return 0;
    }
    double mat[16];
    set_mat(mat, rad_scale(rt, 1.0 / span), rad_scale(up, 1.0 / span), d, 0, near);
    /* Weight of pixel (x, y): (d + a·rt + b·up)·n_i / (1 + a² + b²)². */
    const double dn = rad_dot(d, ni), rn = rad_dot(rt, ni), un = rad_dot(up, ni);
    double *sum = g->fsum; /* S_j, then S°_j */
    memset(sum, 0, 2 * (size_t)nj * sizeof *sum);
    memset(cover, 0, (size_t)nj * sizeof *cover);
    /* Both renderings side by side in the atlas (rows [0, R) and [R, 2R)),
     * read back at once: one wait for the rasteriser instead of two. */
    for (int pass = 0; pass < 2; pass++) {
        square_view(g, mat, R, pass ? R : 0);
        if (pass == 1) {
            nr = 0;
            for (uint32_t k = 0; k < nj; k++)
                push_range(g, g->first[0], g->count[0], &nr, &last, js[k]);
        }
        glMultiDrawArrays(GL_TRIANGLES, g->first[0], g->count[0], nr);
    }
    glReadPixels(0, 0, (GLsizei)R, (GLsizei)(2 * R), GL_RED_INTEGER, GL_UNSIGNED_INT, g->pixels);
    for (uint32_t pass = 0; pass < 2; pass++) {
        for (uint32_t y = 0; y < R; y++) {
            const double b = ((y + 0.5) * 2.0 / R - 1.0) * span;
            for (uint32_t x = 0; x < R; x++) {
                uint32_t id = g->pixels[((size_t)pass * R + y) * R + x];
                if (id < js[0] || id > js[nj - 1])
                    continue;
                uint32_t lo = 0, hi = nj; /* id's slot, if it is a candidate */
                while (hi - lo > 1) {
                    uint32_t md = (lo + hi) / 2;
                    if (js[md] <= id)
                        lo = md;
                    else
                        hi = md;
                }
                if (js[lo] != id)
                    continue;
                const double a = ((x + 0.5) * 2.0 / R - 1.0) * span, l2 = 1.0 + a * a + b * b;
                const double w = dn + a * rn + b * un;
                if (w > 0.0)
                    sum[(size_t)pass * nj + lo] += w / (l2 * l2);
                cover[lo] += pass;
            }
        }
    }
    for (uint32_t k = 0; k < nj; k++)
        vis[k] = cover[k] > 0 && sum[nj + k] > 0.0 ? fmin(1.0, sum[k] / sum[nj + k]) : -1.0;
    return 0;
}

/* Replaces the pixel sums g->acc[j] of the ncand candidates in g->cand by
 * their exact entries F_exact · v_ij (see the top of the file).  Needs the
 * occluded pass's depth buffer; leaves the item buffer overwritten. */
static void exact_entries(const hc_engine *e, hc_gl *g, uint32_t i, rad_vec3 c, uint32_t ncand,
                          uint32_t nfront, const rad_vec3 fr[5][3], const hc_faces *fs, double near)
{
    const uint32_t R = e->R;
    const rad_vec3 nn = e->mesh->patches[i].normal;
    rad_vec3 pi[4], pj[4];
    load_corners(e, i, pi);
    uint32_t per_residue[32] = {0}, passes = 0;
    for (uint32_t k = 0; k < ncand; k++) {
        hc_cand *cd = &g->cand[k];
        uint32_t j = cd->j;
        cd->occ = g->acc[j];
        cd->free = 0.0;
        cd->px = 0;
        load_corners(e, j, pj);
        double ex;
        if (cd->near) {
            /* Sub-triangles about half the distance across: the 7-point
             * rule then resolves F_{dA→j}, which varies on that scale. */
            double dist = rad_length(rad_sub(e->center[j], c));
            double sub = ceil(4.0 * e->radius[i] / fmax(dist, 1e-300));
            sub = sub < 2.0 ? 2.0 : sub > HC_NEAR_MAX_SUBDIV ? HC_NEAR_MAX_SUBDIV : sub;
            ex = hc_ff_polygon_polygon(pi, e->ncorner[i], pj, e->ncorner[j], (uint32_t)sub);
        } else {
            ex = hc_ff_point_polygon(c, nn, pj, e->ncorner[j]);
        }
        cd->exact = ex > 0.0 && isfinite(ex) ? ex : 0.0;
        cd->pass = UINT32_MAX;
        if (cd->exact > 0.0 && cd->occ > 0.0) {
            cd->pass = per_residue[j & 31u]++;
            passes = cd->pass + 1 > passes ? cd->pass + 1 : passes;
        }
    }
    /* Probes read the occluded pass's depth, which the OR passes keep (no
     * depth test, so no depth writes). */
    for (uint32_t k = 0; k < ncand; k++) {
        hc_cand *cd = &g->cand[k];
        if (cd->exact > 0.0 && cd->occ == 0.0)
            cd->free = probe_visible(e, g, cd->j, c, fr, near) ? 1.0 : 0.0;
    }
    if (passes) {
        const size_t npix = (size_t)3 * R * R;
        const GLuint zero[4] = {0, 0, 0, 0};
        glUniform1ui(g->loc_mode, 1u);
        glDisable(GL_DEPTH_TEST);
        glEnable(GL_COLOR_LOGIC_OP);
        glLogicOp(GL_OR);
        for (uint32_t p = 0; p < passes; p++) {
            uint32_t slot[32], nin = 0;
            for (uint32_t k = 0; k < ncand; k++)
                if (g->cand[k].pass == p) {
                    slot[g->cand[k].j & 31u] = k;
                    g->order[nin++] = k;
                }
            glScissor(0, 0, (GLsizei)R, (GLsizei)(3 * R));
            glClearBufferuiv(GL_COLOR, 0, zero);
            for (int f = 0; f < 5; f++) {
                GLsizei nr = 0;
                uint32_t last = 0;
                for (uint32_t t = 0; t < nin; t++) {
                    const hc_cand *cd = &g->cand[g->order[t]];
                    if (!(cd->faces & (1u << f)))
                        continue;
                    push_range(g, g->first[0], g->count[0], &nr, &last, cd->j);
                }
                if (nr)
                    draw_face(fs, g, f, R, g->first[0], g->count[0], nr);
            }
            glReadPixels(0, 0, (GLsizei)R, (GLsizei)(3 * R), GL_RED_INTEGER, GL_UNSIGNED_INT,
                         g->pixels);
            /* In pixel order, as the occluded sums: deterministic. */
            for (size_t q = 0; q < npix; q++) {
                uint32_t bits = g->pixels[q];
                while (bits) {
                    uint32_t r = (uint32_t)__builtin_ctz(bits);
                    bits &= bits - 1;
                    g->cand[slot[r]].free += e->dff[q];
                    g->cand[slot[r]].px++;
                }
            }
        }
        glUniform1ui(g->loc_mode, 0u);
        glDisable(GL_COLOR_LOGIC_OP);
        glEnable(GL_DEPTH_TEST);
    }
    /* The hemi-cube's v_ij, then the focused views' where they apply: to
     * far candidates that cover fewer hemi-cube pixels than a focused view
     * would give them, one view per polygon (its such candidates, ascending
     * as the row found them), and one per patch when the polygon is too
     * wide for one view or a patch too small in it.  At most
     * HC_FOCUS_VIEWS views a row, taken in candidate order, a polygon's
     * per-patch views all or none: a room whose every wall glows keeps the
     * hemi-cube's ratios (its walls are large and near; what the views are
     * for is a few small bright sources). */
    for (uint32_t k = 0; k < ncand; k++) {
        hc_cand *cd = &g->cand[k];
        cd->vis = cd->occ > 0.0 ? fmin(1.0, cd->occ / cd->free) : cd->free;
        cd->focus = cd->exact > 0.0 && !cd->near && cd->px < HC_FOCUS_PIXELS(R);
    }
    uint32_t views = 0;
    for (uint32_t k = 0; k < ncand && views < HC_FOCUS_VIEWS; k++) {
        if (!g->cand[k].focus)
            continue;
        uint32_t ng = 0, poly = e->mesh->patches[g->cand[k].j].polygon;
        for (uint32_t q = k; q < ncand; q++)
            if (g->cand[q].focus && e->mesh->patches[g->cand[q].j].polygon == poly) {
                g->order[ng] = g->cand[q].j;
                g->cand[q].focus = 0;
                g->fslot[ng++] = q;
            }
        double *vis = g->fsum + 2 * (size_t)e->n;
        uint32_t *cover = g->fslot + e->n, singles = 0;
        views++;
        const int whole = focused_visibility(e, g, g->order, ng, c, nn, nfront, near, vis, cover) == 0;
        for (uint32_t q = 0; q < ng; q++)
            singles += ng > 1 && (!whole || cover[q] < HC_FOCUS_PIXELS(R));
        const int alone = singles > 0 && views + singles <= HC_FOCUS_VIEWS;
        views += alone ? singles : 0;
        for (uint32_t q = 0; q < ng; q++) {
            hc_cand *cd = &g->cand[g->fslot[q]];
            double v1 = -1.0;
            uint32_t c1;
            if (alone && (!whole || cover[q] < HC_FOCUS_PIXELS(R)) &&
                focused_visibility(e, g, &cd->j, 1, c, nn, nfront, near, &v1, &c1) == 0 && v1 >= 0.0)
                cd->vis = v1;
            else if (whole && vis[q] >= 0.0)
                cd->vis = vis[q];
        }
    }
    for (uint32_t k = 0; k < ncand; k++) {
        const hc_cand *cd = &g->cand[k];
        g->acc[cd->j] = cd->exact > 0.0 ? cd->exact * cd->vis : 0.0;
    }
}

/* Computes row i into g->col/g->val; returns the entry count, or -1 with msg
 * set on a GL error.  `at` (relative to the origin) moves the cube from i's
 * centre to a point of i: an element's row F_ej (hc_compute_points).  Such a
 * receiver is a point, so exact entries are the point-to-polygon factor
 * only (no near area averages over i). */
static long compute_row(const hc_engine *e, hc_gl *g, uint32_t i, const rad_vec3 *at, char *msg)
{
    const uint32_t n = e->n, R = e->R;
    const rad_patch *pi = &e->mesh->patches[i];
    rad_vec3 nn = pi->normal, u, v;
    basis(nn, &u, &v);
    const rad_vec3 c = at ? *at : e->center[i];
    const int near_ok = e->opt.exact_near && !at;
    const double tol = e->tol;
    uint32_t nfront = 0, ncand = 0;
    GLsizei nr[5] = {0, 0, 0, 0, 0};
    uint32_t last[5] = {0, 0, 0, 0, 0};

    for (uint32_t j = 0; j < n; j++) {
        if (j % HC_BLOCK == 0) {
            const double *sp = e->bsphere + 4 * (size_t)(j / HC_BLOCK);
            double hb = (sp[0] - c.x) * nn.x + (sp[1] - c.y) * nn.y + (sp[2] - c.z) * nn.z;
            if (hb + sp[3] <= tol) {
                j += HC_BLOCK - 1;
                continue;
            }
        }
        if (j == i)
            continue;
        /* Ranges of a = p·u, b = p·v, h = p·n over the corners (triangles
         * repeat corner 0).  max(h - a) <= max h - min a etc. bound each
         * plane from above: cheap, and conservative (a patch is only ever
         * drawn needlessly, never skipped wrongly). */
        const double *p = e->corner + (size_t)j * 12;
        double amin = INFINITY, amax = -INFINITY, bmin = INFINITY, bmax = -INFINITY;
        double hmax = -INFINITY, hmin = INFINITY;
        for (int k = 0; k < 4; k++, p += 3) {
            double x = p[0] - c.x, y = p[1] - c.y, z = p[2] - c.z;
            double a = x * u.x + y * u.y + z * u.z;
            double b = x * v.x + y * v.y + z * v.z;
            double h = x * nn.x + y * nn.y + z * nn.z;
            amin = a < amin ? a : amin;
            amax = a > amax ? a : amax;
            bmin = b < bmin ? b : bmin;
            bmax = b > bmax ? b : bmax;
            hmin = h < hmin ? h : hmin;
            hmax = h > hmax ? h : hmax;
        }
        /* Only patches with a corner strictly in front of i's plane can be
         * seen; this also drops every patch coplanar with i. */
        if (!(hmax > tol))
            continue;
        const double t = -tol;
        unsigned inside = (hmax - amin >= t) * PL_H_MA | (hmax + amax >= t) * PL_H_PA |
                          (hmax - bmin >= t) * PL_H_MB | (hmax + bmax >= t) * PL_H_PB |
                          (amax - bmin >= t) * PL_A_MB | (amax + bmax >= t) * PL_A_PB |
                          (-amin - bmin >= t) * PL_NA_MB | (bmax - amin >= t) * PL_B_MA |
                          PL_H | (amax - hmin >= t) * PL_A_MH | (-amin - hmin >= t) * PL_NA_MH |
                          (bmax - hmin >= t) * PL_B_MH | (-bmin - hmin >= t) * PL_NB_MH;
        g->front[nfront++] = j;
        unsigned faces = 0;
        for (int f = 0; f < 5; f++) {
            if ((inside & face_planes[f]) != face_planes[f])
                continue;
            faces |= 1u << f;
            push_range(g, g->first[f], g->count[f], &nr[f], &last[f], j);
        }
        if (e->any_exact) {
            int is_near = 0;
            if (near_ok) {
                rad_vec3 d = rad_sub(e->center[j], c);
                double size = 2.0 * e->radius[j];
                is_near = rad_dot(d, d) < size * size;
            }
            if (is_near || (e->exact && e->exact[j])) {
                hc_cand *cd = &g->cand[ncand++];
                cd->j = j;
                cd->faces = (uint8_t)faces;
                cd->near = (uint8_t)is_near;
            }
        }
    }

    const GLuint clear_id[4] = {HC_NO_PATCH, 0, 0, 0};
    const GLfloat clear_depth = 0.0f;
    glBindFramebuffer(GL_FRAMEBUFFER, g->fbo);
    glScissor(0, 0, (GLsizei)R, (GLsizei)(3 * R));
    glClearBufferuiv(GL_COLOR, 0, clear_id);
    glClearBufferfv(GL_DEPTH, 0, &clear_depth);
    glUniform3f(g->loc_eye, (float)c.x, (float)c.y, (float)c.z);

    const double near = 1e-4 * sqrt(pi->area);
    const rad_vec3 mu = rad_scale(u, -1), mv = rad_scale(v, -1);
    /* (right, up, forward) per face; right = forward × up keeps every face
     * unmirrored. */
    const rad_vec3 fr[5][3] = {{mu, v, nn}, {mv, nn, u}, {v, nn, mu}, {u, nn, v}, {mu, nn, mv}};
    hc_faces fs;
    face_setup(&fs, fr, R, near);
    for (int f = 0; f < 5; f++)
        if (nr[f])
            draw_face(&fs, g, f, R, g->first[f], g->count[f], nr[f]);
    glReadPixels(0, 0, (GLsizei)R, (GLsizei)(3 * R), GL_RED_INTEGER, GL_UNSIGNED_INT, g->pixels);
    if (gl_check("rendering a hemi-cube", msg))
        return -1;

    /* F_ij = Σ ΔF_q over the pixels q showing j (paper, eq. 7), summed in
     * pixel order so the result never depends on scheduling. */
    const size_t npix = (size_t)3 * R * R;
    const uint32_t *px = g->pixels;
    const double *dff = e->dff;
    double *acc = g->acc;
    for (size_t q = 0; q < npix; q++) {
        uint32_t id = px[q];
        if (id < n)
            acc[id] += dff[q];
    }
    double scale_px = 1.0, scale_ex = 1.0;
    if (ncand) {
        /* The row's pixel total T = Σ_j F_ij is what the cube saw covered:
         * exact to the pixel in a closed room (T = 1).  Exact entries fix
         * how T is shared between patches, not T itself. */
        double total = 0.0;
        for (uint32_t k = 0; k < nfront; k++)
            total += acc[g->front[k]];
        total = total < 1.0 ? total : 1.0;
        exact_entries(e, g, i, c, ncand, nfront, fr, &fs, near);
        if (gl_check("measuring exact form factors", msg))
            return -1;
        /* Renormalisation.  With far exact entries only (emitters), the
         * pixel entries, the less accurate ones, are scaled to fill T - Σ
         * exact: the row keeps the cube's total and a closed room stays
         * closed (energy is conserved).  A near entry is different: there
         * T itself carries the error of sampling i at its centre (two plates
         * 0.01 apart cover 99.8 % of the centre's view, 98.0 % on average
         * over the plate), so the exact entries stand and the row is only
         * scaled down should it exceed 1. */
        double sum_ex = 0.0, sum_px = 0.0;
        int any_near = 0;
        for (uint32_t k = 0; k < ncand; k++) {
            sum_ex += acc[g->cand[k].j];
            g->mark[g->cand[k].j] = 1;
            any_near |= g->cand[k].near;
        }
        for (uint32_t k = 0; k < nfront; k++)
            if (!g->mark[g->front[k]])
                sum_px += acc[g->front[k]];
        if (!any_near && sum_ex <= total) {
            if (sum_px > 0.0)
                scale_px = (total - sum_ex) / sum_px;
        } else if (sum_ex + sum_px > 1.0) {
            scale_px = sum_ex < 1.0 ? (1.0 - sum_ex) / sum_px : 1.0 / (sum_ex + sum_px);
            scale_ex = sum_ex < 1.0 ? 1.0 : scale_px;
        }
    }
    long cnt = 0;
    for (uint32_t k = 0; k < nfront; k++) {
        uint32_t j = g->front[k];
        double scale = scale_px;
        if (ncand && g->mark[j]) {
            scale = scale_ex;
            g->mark[j] = 0;
        }
        if (acc[j] > 0.0) {
            float f = (float)(acc[j] * scale);
            if (f > 0.0f) {
                g->col[cnt] = j;
                g->val[cnt] = f;
                cnt++;
            }
        }
        acc[j] = 0.0;
    }
    return cnt;
}

/* ------------------------------------------------------- worker: lights */


/* Makes (or keeps) the R×R light target current, with its table of pixel
 * solid angles: a cube-face pixel at (x, y) on the face at distance 1
 * subtends ΔA/(x² + y² + 1)^{3/2}, ΔA = (2/R)², scaled so that six faces
 * give exactly 4π (the midpoint rule is off by O(1/R²)). */
static int light_target(hc_gl *g, uint32_t R, char *msg)
{
    if (g->lR == R) {
        glBindFramebuffer(GL_FRAMEBUFFER, g->lfbo);
        return 0;
    }
    GLint max_rb = 0;
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
    if (max_rb < (GLint)R) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: light resolution %u exceeds GL's %d", R, (int)max_rb);
        return -1;
    }
    free(g->lpixels);
    free(g->lweight);
    g->lR = 0;
    g->lpixels = malloc((size_t)R * R * sizeof *g->lpixels);
    g->lweight = malloc((size_t)R * R * sizeof *g->lweight);
    if (!g->lpixels || !g->lweight) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: worker out of memory for a %u² light view", R);
        return -1;
    }
    if (!g->lfbo) {
        glGenFramebuffers(1, &g->lfbo);
        glGenRenderbuffers(2, g->lrb);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, g->lfbo);
    glBindRenderbuffer(GL_RENDERBUFFER, g->lrb[0]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_R32UI, (GLsizei)R, (GLsizei)R);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g->lrb[0]);
    glBindRenderbuffer(GL_RENDERBUFFER, g->lrb[1]);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, (GLsizei)R, (GLsizei)R);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, g->lrb[1]);
    const GLenum draw = GL_COLOR_ATTACHMENT0;
    glDrawBuffers(1, &draw);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: light framebuffer incomplete (0x%04x)", (unsigned)status);
        return -1;
    }
    double d = 2.0 / R, sum = 0.0;
    for (uint32_t y = 0; y < R; y++)
        for (uint32_t x = 0; x < R; x++) {
            double px = -1.0 + (x + 0.5) * d, py = -1.0 + (y + 0.5) * d;
            double r2 = px * px + py * py + 1.0;
            double w = d * d / (r2 * sqrt(r2));
            g->lweight[(size_t)y * R + x] = w;
            sum += w;
        }
    double s = 4.0 * M_PI / (6.0 * sum);
    for (size_t q = 0; q < (size_t)R * R; q++)
        g->lweight[q] *= s;
    g->lR = R;
    return gl_check("light framebuffer set-up", msg);
}

/* Cube face f of a point light: forward ±x, ±y, ±z; right = forward × up
 * so that front faces stay front faces. */
static void cube_face(uint32_t f, rad_vec3 *right, rad_vec3 *up, rad_vec3 *fwd)
{
    static const double ax[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    *fwd = rad_v3(ax[f][0], ax[f][1], ax[f][2]);
    *up = f < 4 ? rad_v3(0, 0, 1) : rad_v3(0, 1, 0);
    *right = rad_cross(*fwd, *up);
}

/* glTF KHR_lights_punctual spot falloff for a direction whose cosine to the
 * axis is cos_axis: t² with t = clamp(cos_axis·scale + offset, 0, 1),
 * scale = 1/max(0.001, cos_inner − cos_outer), offset = −cos_outer·scale. */
static double spot_falloff(double cos_axis, double cos_inner, double cos_outer)
{
    double scale = 1.0 / fmax(0.001, cos_inner - cos_outer);
    double t = cos_axis * scale - cos_outer * scale;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    return t * t;
}

/* The camera of one light part: a cube face (perspective, x and y in
 * [-1, 1] at distance 1 along fwd) or the directional light's orthographic
 * view (x and y in [-rw, rw] around the scene origin). */
typedef struct hc_view {
    rad_vec3 pos, right, up, fwd; /* pos relative to the scene origin */
    double rw;                    /* orthographic half width (directional only) */
    int ortho;
} hc_view;

static hc_view light_view(const hc_engine *e, const hc_light_req *q)
{
    hc_view v = {.pos = rad_v3(q->pos[0], q->pos[1], q->pos[2])};
    if (q->kind == HC_LIGHT_DIRECTIONAL) {
        rad_vec3 u, w;
        v.fwd = rad_v3(q->dir[0], q->dir[1], q->dir[2]);
        basis(v.fwd, &u, &w);
        v.up = w;
        v.right = rad_cross(v.fwd, v.up);
        v.rw = e->bradius * (1.0 + 1e-9);
        v.ortho = 1;
    } else {
        cube_face(q->part, &v.right, &v.up, &v.fwd);
    }
    return v;
}

/* Renders part q->part of a light into g->lpixels (R×R item buffer, pixel
 * (x, y) at y·R + x), unless the last rendering was of the very same part:
 * the pixels are then still there (hc_light_visibility sends a part's
 * points in several chunks).  0, or -1 with msg set. */
static int light_render(const hc_engine *e, hc_gl *g, const hc_light_req *q, const hc_view *v,
                        char *msg)
{
    const uint32_t n = e->n, R = q->resolution;
    if (g->lkey_valid && g->lR == R && memcmp(&g->lkey, q, sizeof *q) == 0)
        return 0;
    g->lkey_valid = 0;
    if (light_target(g, R, msg) != 0)
        return -1;
    const rad_vec3 pos = v->pos, right = v->right, up = v->up, fwd = v->fwd;
    double m[16];
    GLsizei nr = 0;
    if (v->ortho) {
        /* Orthographic along the light, x, y in [-rw, rw] around the origin,
         * reversed depth (r_z - p·fwd)/(2 r_z) in (0, 1) for every corner. */
        double rw = v->rw, rz = e->bradius * 1.01 + 1e-300;
        const double mm[16] = {right.x / rw, right.y / rw, right.z / rw, 0,
                               up.x / rw, up.y / rw, up.z / rw, 0,
                               -fwd.x / (2 * rz), -fwd.y / (2 * rz), -fwd.z / (2 * rz), 0.5,
                               0, 0, 0, 1};
        memcpy(m, mm, sizeof m);
        g->first[0][0] = 0;
        g->count[0][0] = (GLsizei)g->nvert;
        nr = g->nvert ? 1 : 0;
    } else {
        /* Geometry nearer than this to the light is clipped; far below any
         * real distance, and reversed Z keeps full precision beyond. */
        double near = 1e-6 * (e->bradius + rad_length(pos)) + 1e-300;
        set_mat(m, right, up, fwd, 0, near);
        /* Draw only the patches that may reach the face's frustum
         * |p·right| <= p·fwd, |p·up| <= p·fwd; a patch is skipped when all
         * its corners lie outside one of the four planes. */
        uint32_t last = 0;
        for (uint32_t j = 0; j < n; j++) {
            const double *p = e->corner + (size_t)j * 12;
            unsigned reach = 0; /* bit: some corner inside that plane */
            for (int k = 0; k < 4; k++, p += 3) {
                rad_vec3 r = rad_v3(p[0] - pos.x, p[1] - pos.y, p[2] - pos.z);
                double a = rad_dot(r, right), b = rad_dot(r, up), h = rad_dot(r, fwd);
                double t = -e->tol;
                reach |= (h - a >= t) | (h + a >= t) << 1 | (h - b >= t) << 2 | (h + b >= t) << 3;
            }
            if (reach != 15u)
                continue;
            push_range(g, g->first[0], g->count[0], &nr, &last, j);
        }
    }
    square_view(g, m, R, 0);
    glUniform3f(g->loc_eye, (float)(v->ortho ? 0.0 : pos.x), (float)(v->ortho ? 0.0 : pos.y),
                (float)(v->ortho ? 0.0 : pos.z));
    if (nr)
        glMultiDrawArrays(GL_TRIANGLES, g->first[0], g->count[0], nr);
    glReadPixels(0, 0, (GLsizei)R, (GLsizei)R, GL_RED_INTEGER, GL_UNSIGNED_INT, g->lpixels);
    if (gl_check("rendering a light view", msg))
        return -1;
    g->lkey = *q;
    g->lkey_valid = 1;
    return 0;
}

/* Renders part q->part of a light and leaves Φ_j > 0 in g->col/g->lval;
 * returns the entry count or -1 with msg set. */
static long light_part(const hc_engine *e, hc_gl *g, const hc_light_req *q, char *msg)
{
    const uint32_t n = e->n, R = q->resolution;
    const hc_view v = light_view(e, q);
    if (light_render(e, g, q, &v, msg) != 0)
        return -1;
    const rad_vec3 sd = rad_v3(q->dir[0], q->dir[1], q->dir[2]);
    double *acc = g->acc;
    if (v.ortho) {
        double pa = 2.0 * v.rw / R;
        pa *= pa;
        for (size_t k = 0; k < (size_t)R * R; k++)
            if (g->lpixels[k] < n)
                acc[g->lpixels[k]] += pa;
    } else {
        const int spot = q->kind == HC_LIGHT_SPOT;
        double d = 2.0 / R;
        for (uint32_t y = 0; y < R; y++)
            for (uint32_t x = 0; x < R; x++) {
                size_t k = (size_t)y * R + x;
                uint32_t id = g->lpixels[k];
                if (id >= n)
                    continue;
                double w = g->lweight[k];
                if (spot) {
                    double px = -1.0 + (x + 0.5) * d, py = -1.0 + (y + 0.5) * d;
                    rad_vec3 dir = rad_add(v.fwd, rad_add(rad_scale(v.right, px), rad_scale(v.up, py)));
                    w *= spot_falloff(rad_dot(dir, sd) / rad_length(dir), q->cos_inner, q->cos_outer);
                }
                acc[id] += w;
            }
    }
    long cnt = 0;
    for (uint32_t j = 0; j < n; j++)
        if (acc[j] != 0.0) {
            if (acc[j] > 0.0) {
                g->col[cnt] = j;
                g->lval[cnt] = acc[j];
                cnt++;
            }
            acc[j] = 0.0;
        }
    return cnt;
}

/* Does pixel id show the receiving surface of a point on patch p: p itself
 * or, across a patch seam, a front side in p's plane (a coplanar neighbour
 * of the same or another polygon)?  Anything else in front of the plane is
 * an occluder; a back side or nothing is no light reaching the plane. */
static int shows_plane(const hc_engine *e, uint32_t id, uint32_t p)
{
    if (id == p)
        return 1;
    if (id >= e->n)
        return 0;
    const rad_vec3 np = e->mesh->patches[p].normal, nk = e->mesh->patches[id].normal;
    return rad_dot(np, nk) > 1.0 - 1e-6 &&
           fabs(rad_dot(np, rad_sub(e->center[id], e->center[p]))) <= 1e-6 * e->bradius + e->tol;
}

/* Visibility of point `at` (relative to the origin) on patch p in the item
 * buffer of view v: the bilinear weight of the four pixel centres around its
 * projection that show p's plane (clamped at the face's border). */
static double point_visibility(const hc_engine *e, const hc_gl *g, const hc_view *v, uint32_t R,
                               rad_vec3 at, uint32_t p)
{
    double x, y;
    if (v->ortho) {
        x = rad_dot(at, v->right) / v->rw;
        y = rad_dot(at, v->up) / v->rw;
    } else {
        rad_vec3 r = rad_sub(at, v->pos);
        double w = rad_dot(r, v->fwd);
        if (!(w > 0.0))
            return 0.0;
        x = rad_dot(r, v->right) / w;
        y = rad_dot(r, v->up) / w;
    }
    /* Continuous pixel coordinates: pixel k's centre is at k. */
    double X = (x + 1.0) * 0.5 * R - 0.5, Y = (y + 1.0) * 0.5 * R - 0.5;
    if (!(X > -1.0 && X < (double)R && Y > -1.0 && Y < (double)R))
        return 0.0; /* outside the view (an orthographic view covers the whole scene) */
    double fx0 = floor(X), fy0 = floor(Y), fx = X - fx0, fy = Y - fy0;
    long x0 = (long)fx0, y0 = (long)fy0;
    double vis = 0.0;
    for (int dy = 0; dy < 2; dy++)
        for (int dx = 0; dx < 2; dx++) {
            long px = x0 + dx, py = y0 + dy;
            px = px < 0 ? 0 : px >= (long)R ? (long)R - 1 : px;
            py = py < 0 ? 0 : py >= (long)R ? (long)R - 1 : py;
            double w = (dx ? fx : 1.0 - fx) * (dy ? fy : 1.0 - fy);
            if (w > 0.0 && shows_plane(e, g->lpixels[(size_t)py * R + (size_t)px], p))
                vis += w;
        }
    return vis > 1.0 ? 1.0 : vis;
}

static void send_msg(int fd, uint32_t tag, const char *text)
{
    size_t len = strlen(text);
    if (len > HC_MAX_MSG)
        len = HC_MAX_MSG;
    uint32_t hdr[2] = {tag, (uint32_t)len};
    if (send_all(fd, hdr, sizeof hdr) == 0)
        send_all(fd, text, len);
}

static void *worker_alloc(size_t count, size_t size, char *msg)
{
    void *p = calloc(count ? count : 1, size);
    if (!p)
        snprintf(msg, HC_MAX_MSG, "hemi-cube: worker out of memory (%zu × %zu bytes)", count, size);
    return p;
}

/* Never returns into the caller's code: every path ends in _exit, which
 * also keeps atexit handlers, stdio buffers and leak checkers of the
 * caller's image from running twice. */
static void worker_main(const hc_engine *e, int fd) __attribute__((noreturn));
static void worker_main(const hc_engine *e, int fd)
{
    signal(SIGPIPE, SIG_IGN);
    /* Ctrl-C goes to the whole process group; the caller decides when its
     * workers stop (by closing the socket). */
    signal(SIGINT, SIG_IGN);
    signal(SIGQUIT, SIG_IGN);
    /* llvmpipe allocates and frees large scene bins every frame; keeping them
     * on the heap spares an mmap/munmap pair each time (reported to save up
     * to 17 % with llvmpipe threads; within noise when this thread
     * rasterises, as it does by default below). */
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 64 << 20);
    /* With a worker per core, llvmpipe's own rasteriser threads only add
     * synchronisation (measured: 2.2 s of CPU with LP_NUM_THREADS=0 against
     * 3.0 s with 1 or 2 threads for the same rows), so rasterise in this
     * thread; with fewer workers than cores, lend the spare cores to
     * llvmpipe.  A user's own LP_NUM_THREADS wins. */
    char threads[16];
    snprintf(threads, sizeof threads, "%u", e->lp_threads);
    setenv("LP_NUM_THREADS", threads, 0);

    char msg[HC_MAX_MSG + 1] = "";
    hc_gl g;
    memset(&g, 0, sizeof g);
    uint32_t n = e->n, R = e->R;
    int ok = (g.vfirst = worker_alloc(n, sizeof *g.vfirst, msg)) &&
             (g.vcount = worker_alloc(n, sizeof *g.vcount, msg)) &&
             (g.pixels = worker_alloc((size_t)3 * R * R, sizeof *g.pixels, msg)) &&
             (g.acc = worker_alloc(n, sizeof *g.acc, msg)) &&
             (g.front = worker_alloc(n, sizeof *g.front, msg)) &&
             (g.col = worker_alloc(n, sizeof *g.col, msg)) &&
             (g.val = worker_alloc(n, sizeof *g.val, msg));
    for (int f = 0; ok && f < 5; f++)
        ok = (g.first[f] = worker_alloc(n, sizeof *g.first[f], msg)) &&
             (g.count[f] = worker_alloc(n, sizeof *g.count[f], msg));
    if (ok && e->any_exact)
        ok = (g.cand = worker_alloc(n, sizeof *g.cand, msg)) &&
             (g.order = worker_alloc(n, sizeof *g.order, msg)) &&
             (g.mark = worker_alloc(n, sizeof *g.mark, msg)) &&
             (g.fslot = worker_alloc((size_t)2 * n, sizeof *g.fslot, msg)) &&
             (g.fsum = worker_alloc((size_t)3 * n, sizeof *g.fsum, msg));
    if (!ok || gl_setup(e, &g, msg) != 0) {
        send_msg(fd, HC_MSG_ERROR, msg);
        _exit(1);
    }
    send_msg(fd, 0, "");

    /* The answer to a request goes out in one piece (or in pieces of about
     * HC_FLUSH bytes), so the caller wakes once per request, not per row. */
    g.out_cap = HC_FLUSH + 16 + (size_t)8 * n;
    g.out = malloc(g.out_cap);
    if (!g.out) {
        send_msg(fd, HC_MSG_ERROR, "hemi-cube: worker out of memory for its reply buffer");
        _exit(1);
    }
    uint32_t rows[HC_MAX_CHUNK];
    for (;;) {
        uint32_t count;
        if (recv_all(fd, &count, sizeof count) != 0)
            _exit(0); /* the caller closed the socket: hc_destroy */
        if (count == HC_REQ_LIGHT) {
            hc_light_req q;
            if (recv_all(fd, &q, sizeof q) != 0 || !resolution_ok(q.resolution) ||
                q.kind > HC_LIGHT_DIRECTIONAL || q.part >= 6)
                _exit(1);
            if (!g.lval && !(g.lval = worker_alloc(n, sizeof *g.lval, msg))) {
                send_msg(fd, HC_MSG_ERROR, msg);
                _exit(1);
            }
            long cnt = light_part(e, &g, &q, msg);
            if (cnt < 0) {
                send_msg(fd, HC_MSG_ERROR, msg);
                _exit(1);
            }
            uint32_t hdr[2] = {HC_MSG_LIGHT, (uint32_t)cnt};
            if (send_all(fd, hdr, sizeof hdr) != 0 ||
                send_all(fd, g.col, (size_t)cnt * sizeof *g.col) != 0 ||
                send_all(fd, g.lval, (size_t)cnt * sizeof *g.lval) != 0)
                _exit(1);
            continue;
        }
        if (count == HC_REQ_VIS) {
            hc_light_req q;
            uint32_t m;
            if (recv_all(fd, &q, sizeof q) != 0 || !resolution_ok(q.resolution) ||
                q.kind > HC_LIGHT_DIRECTIONAL || q.part >= 6 || recv_all(fd, &m, sizeof m) != 0 ||
                m == 0 || m > HC_VIS_CHUNK)
                _exit(1);
            if (!g.vpts && (!(g.vpts = worker_alloc(HC_VIS_CHUNK, sizeof *g.vpts, msg)) ||
                            !(g.vis = worker_alloc(HC_VIS_CHUNK, sizeof *g.vis, msg)))) {
                send_msg(fd, HC_MSG_ERROR, msg);
                _exit(1);
            }
            if (recv_all(fd, g.vpts, m * sizeof *g.vpts) != 0)
                _exit(1);
            const hc_view v = light_view(e, &q);
            if (light_render(e, &g, &q, &v, msg) != 0) {
                send_msg(fd, HC_MSG_ERROR, msg);
                _exit(1);
            }
            for (uint32_t k = 0; k < m; k++) {
                const hc_point_req *pt = &g.vpts[k];
                if (pt->patch >= n)
                    _exit(1);
                g.vis[k] = point_visibility(e, &g, &v, q.resolution,
                                            rad_v3(pt->at[0], pt->at[1], pt->at[2]), pt->patch);
            }
            uint32_t hdr[2] = {HC_MSG_VIS, m};
            if (send_all(fd, hdr, sizeof hdr) != 0 || send_all(fd, g.vis, m * sizeof *g.vis) != 0)
                _exit(1);
            continue;
        }
        /* Rows of patches, or rows of points on patches (elements). */
        hc_point_req pts[HC_MAX_CHUNK];
        int points = count == HC_REQ_POINTS;
        if (points && recv_all(fd, &count, sizeof count) != 0)
            _exit(1);
        if (count == 0 || count > HC_MAX_CHUNK ||
            (points ? recv_all(fd, pts, count * sizeof *pts) : recv_all(fd, rows, count * sizeof *rows)) != 0)
            _exit(1);
        uint32_t batch[2] = {HC_MSG_BATCH, count};
        memcpy(g.out, batch, sizeof batch);
        g.out_len = sizeof batch;
        for (uint32_t k = 0; k < count; k++) {
            uint32_t i = points ? pts[k].patch : rows[k];
            if (i >= n)
                _exit(1);
            rad_vec3 at = points ? rad_v3(pts[k].at[0], pts[k].at[1], pts[k].at[2]) : rad_v3(0, 0, 0);
            long cnt = compute_row(e, &g, i, points ? &at : NULL, msg);
            if (cnt < 0) {
                if (send_all(fd, g.out, g.out_len) == 0)
                    send_msg(fd, HC_MSG_ERROR, msg);
                _exit(1);
            }
            size_t bytes = sizeof(uint32_t) * (2 + 2 * (size_t)cnt);
            if (g.out_len + bytes > g.out_cap) {
                if (send_all(fd, g.out, g.out_len) != 0)
                    _exit(1);
                g.out_len = 0;
            }
            uint32_t hdr[2] = {points ? pts[k].index : i, (uint32_t)cnt};
            unsigned char *o = g.out + g.out_len;
            memcpy(o, hdr, sizeof hdr);
            memcpy(o + sizeof hdr, g.col, (size_t)cnt * sizeof *g.col);
            memcpy(o + sizeof hdr + (size_t)cnt * sizeof *g.col, g.val, (size_t)cnt * sizeof *g.val);
            g.out_len += bytes;
            if (g.out_len >= HC_FLUSH) {
                if (send_all(fd, g.out, g.out_len) != 0)
                    _exit(1);
                g.out_len = 0;
            }
        }
        if (g.out_len && send_all(fd, g.out, g.out_len) != 0)
            _exit(1);
    }
}

/* ---------------------------------------------------------------- caller */

static void stop_workers(hc_engine *e)
{
    if (!e->w)
        return;
    for (uint32_t k = 0; k < e->nproc; k++)
        if (e->w[k].fd >= 0) {
            close(e->w[k].fd);
            e->w[k].fd = -1;
        }
    /* A worker blocked in recv sees EOF at once and _exits; one that does not
     * within ~2 s (e.g. another process still holds its socket) is killed. */
    for (uint32_t k = 0; k < e->nproc; k++) {
        pid_t pid = e->w[k].pid;
        if (pid <= 0)
            continue;
        int st;
        for (int t = 0;; t++) {
            pid_t r = waitpid(pid, &st, WNOHANG);
            if (r == pid || (r < 0 && errno != EINTR))
                break;
            if (t == 2000) {
                kill(pid, SIGKILL);
                while (waitpid(pid, &st, 0) < 0 && errno == EINTR)
                    ;
                break;
            }
            struct timespec ts = {0, 1000000};
            nanosleep(&ts, NULL);
        }
        e->w[k].pid = -1;
    }
}

void hc_destroy(hc_engine *e)
{
    if (!e)
        return;
    stop_workers(e);
    free(e->w);
    free(e->dff);
    free(e->corner);
    free(e->center);
    free(e->ncorner);
    free(e->bsphere);
    free(e->radius);
    free(e->exact);
    free(e->rx_col);
    free(e->rx_val);
    free(e);
}

/* Closes every descriptor but `keep` (and stdio) in a fresh worker, so that
 * no worker holds another worker's or another engine's socket: otherwise a
 * closed socket would never reach EOF and hc_destroy would wait. */
static void close_other_fds(int keep)
{
    long max = sysconf(_SC_OPEN_MAX);
    if (max < 0 || max > 65536)
        max = 65536;
#ifdef SYS_close_range
    if (keep > 3)
        syscall(SYS_close_range, 3u, (unsigned)keep - 1, 0u);
    if (syscall(SYS_close_range, (unsigned)keep + 1, ~0u, 0u) == 0)
        return;
#endif
    for (int fd = 3; fd < max; fd++)
        if (fd != keep)
            close(fd);
}

static int read_status(hc_engine *e, uint32_t k, rad_error *err)
{
    uint32_t hdr[2];
    if (recv_all(e->w[k].fd, hdr, sizeof hdr) != 0)
        return rad_fail(err, RAD_ERR_GL, "hemi-cube: worker %u stopped while starting", k);
    if (hdr[0] == 0 && hdr[1] == 0)
        return RAD_OK;
    char text[HC_MAX_MSG + 1] = "";
    uint32_t len = hdr[1] > HC_MAX_MSG ? HC_MAX_MSG : hdr[1];
    if (recv_all(e->w[k].fd, text, len) != 0)
        return rad_fail(err, RAD_ERR_GL, "hemi-cube: worker %u stopped while starting", k);
    text[len] = '\0';
    return rad_fail(err, RAD_ERR_GL, "%s (worker %u)", text, k);
}

int hc_create(const rad_mesh *mesh, const hc_options *opt, hc_engine **out, rad_error *err)
{
    if (out)
        *out = NULL;
    if (!mesh || !out)
        return rad_fail(err, RAD_ERR_USAGE, "hc_create: mesh and out must not be NULL");
    hc_options o = {0};
    if (opt)
        o = *opt;
    if (o.resolution == 0)
        o.resolution = 128;
    if (!resolution_ok(o.resolution))
        return rad_fail(err, RAD_ERR_USAGE,
                        "hc_create: hemi-cube resolution %u: must be even and within 8..4096",
                        o.resolution);
    if (o.processes > HC_MAX_PROCESSES)
        return rad_fail(err, RAD_ERR_USAGE, "hc_create: %u worker processes: at most %u",
                        o.processes, HC_MAX_PROCESSES);
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    cpus = cpus < 1 ? 1 : cpus > 64 ? 64 : cpus;
    if (o.processes == 0)
        o.processes = (uint32_t)cpus;
    uint32_t n = mesh->patch_count;
    if (n > HC_MAX_PATCHES)
        return rad_fail(err, RAD_ERR_LIMIT, "hc_create: %u patches: the hemi-cube handles at most %u",
                        n, HC_MAX_PATCHES);
    if (n && (!mesh->patches || !mesh->vertices))
        return rad_fail(err, RAD_ERR_USAGE, "hc_create: mesh has %u patches but no arrays", n);

    /* Check every index before any of it is used; find the bounding box. */
    rad_vec3 lo = rad_v3(INFINITY, INFINITY, INFINITY), hi = rad_scale(lo, -1);
    for (uint32_t j = 0; j < n; j++) {
        const rad_patch *p = &mesh->patches[j];
        int nc = rad_patch_corners(p);
        for (int k = 0; k < nc; k++) {
            if (p->v[k] >= mesh->vertex_count)
                return rad_fail(err, RAD_ERR_USAGE, "hc_create: patch %u: vertex index %u out of range",
                                j, p->v[k]);
            rad_vec3 q = mesh->vertices[p->v[k]];
            if (!rad_finite3(q))
                return rad_fail(err, RAD_ERR_USAGE, "hc_create: patch %u: vertex %u is not finite",
                                j, p->v[k]);
            lo = rad_v3(fmin(lo.x, q.x), fmin(lo.y, q.y), fmin(lo.z, q.z));
            hi = rad_v3(fmax(hi.x, q.x), fmax(hi.y, q.y), fmax(hi.z, q.z));
        }
        double nl = rad_length(p->normal);
        if (!rad_finite3(p->center) || !(fabs(nl - 1.0) < 1e-6) || !(p->area > 0.0) ||
            !isfinite(p->area))
            return rad_fail(err, RAD_ERR_USAGE,
                            "hc_create: patch %u: needs a finite centre, a unit normal and area > 0", j);
    }

    hc_engine *e = calloc(1, sizeof *e);
    if (!e)
        return rad_fail(err, RAD_ERR_NOMEM, "hc_create: out of memory");
    e->mesh = mesh;
    e->n = n;
    e->R = o.resolution;
    e->nproc = o.processes;
    e->lp_threads = (uint32_t)cpus / o.processes >= 2 ? (uint32_t)cpus / o.processes : 0;
    e->opt = o;
    size_t npix = (size_t)3 * e->R * e->R;
    e->dff = malloc(npix * sizeof *e->dff);
    e->corner = malloc((n ? n : 1) * 12 * sizeof *e->corner);
    e->center = malloc((n ? n : 1) * sizeof *e->center);
    e->ncorner = malloc(n ? n : 1);
    e->bsphere = malloc(((size_t)n / HC_BLOCK + 1) * 4 * sizeof *e->bsphere);
    e->radius = malloc((n ? n : 1) * sizeof *e->radius);
    e->rx_col = malloc((n ? n : 1) * sizeof *e->rx_col);
    e->rx_val = malloc((n ? n : 1) * sizeof *e->rx_val);
    e->w = calloc(e->nproc, sizeof *e->w);
    if (o.exact && n) {
        /* Read once here: later changes to the caller's array never reach
         * workers that already forked, so none may reach the caller either. */
        e->exact = malloc(n);
        if (e->exact) {
            memcpy(e->exact, o.exact, n);
            for (uint32_t j = 0; j < n && !e->any_exact; j++)
                e->any_exact = e->exact[j] != 0;
        }
    }
    e->any_exact |= o.exact_near != 0 && n > 1;
    e->opt.exact = e->exact;
    if (!e->dff || !e->corner || !e->center || !e->ncorner || !e->bsphere || !e->radius ||
        !e->rx_col || !e->rx_val || !e->w || (o.exact && n && !e->exact)) {
        hc_destroy(e);
        return rad_fail(err, RAD_ERR_NOMEM, "hc_create: out of memory for %u patches at resolution %u",
                        n, o.resolution);
    }
    for (uint32_t k = 0; k < e->nproc; k++) {
        e->w[k].fd = -1;
        e->w[k].pid = -1;
    }
    hc_delta_form_factors(e->R, e->dff);

    if (n) {
        e->origin = rad_scale(rad_add(lo, hi), 0.5);
        double diag = rad_length(rad_sub(hi, lo));
        double far = fmax(fmax(fabs(lo.x), fabs(hi.x)), fmax(fmax(fabs(lo.y), fabs(hi.y)),
                                                              fmax(fabs(lo.z), fabs(hi.z))));
        /* Above the rounding noise of coordinates this far from 0, far below
         * any real gap between surfaces. */
        e->tol = 1e-9 * diag + 1e-12 * far;
    }
    for (uint32_t j = 0; j < n; j++) {
        const rad_patch *p = &mesh->patches[j];
        int nc = rad_patch_corners(p);
        e->ncorner[j] = (uint8_t)nc;
        for (int k = 0; k < 4; k++) {
            rad_vec3 q = rad_sub(mesh->vertices[p->v[k < nc ? k : 0]], e->origin);
            e->corner[(size_t)j * 12 + 3 * k + 0] = q.x;
            e->corner[(size_t)j * 12 + 3 * k + 1] = q.y;
            e->corner[(size_t)j * 12 + 3 * k + 2] = q.z;
        }
        e->center[j] = rad_sub(p->center, e->origin);
        double r2 = 0.0, b2 = 0.0;
        for (int k = 0; k < nc; k++) {
            const double *q = e->corner + (size_t)j * 12 + 3 * k;
            rad_vec3 d = rad_sub(rad_v3(q[0], q[1], q[2]), e->center[j]);
            r2 = fmax(r2, rad_dot(d, d));
            b2 = fmax(b2, q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        }
        e->radius[j] = sqrt(r2);
        e->bradius = fmax(e->bradius, sqrt(b2));
    }
    for (uint32_t b0 = 0; b0 < n; b0 += HC_BLOCK) {
        uint32_t b1 = n - b0 < HC_BLOCK ? n : b0 + HC_BLOCK;
        double lo3[3] = {INFINITY, INFINITY, INFINITY}, hi3[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (uint32_t j = b0; j < b1; j++)
            for (int k = 0; k < 12; k++) {
                double q = e->corner[(size_t)j * 12 + k];
                lo3[k % 3] = fmin(lo3[k % 3], q);
                hi3[k % 3] = fmax(hi3[k % 3], q);
            }
        double *sp = e->bsphere + 4 * (size_t)(b0 / HC_BLOCK), r2 = 0.0;
        for (int a = 0; a < 3; a++)
            sp[a] = 0.5 * (lo3[a] + hi3[a]);
        for (uint32_t j = b0; j < b1; j++)
            for (int k = 0; k < 4; k++) {
                const double *q = e->corner + (size_t)j * 12 + 3 * k;
                double d2 = (q[0] - sp[0]) * (q[0] - sp[0]) + (q[1] - sp[1]) * (q[1] - sp[1]) +
                            (q[2] - sp[2]) * (q[2] - sp[2]);
                r2 = fmax(r2, d2);
            }
        /* A hair larger than exact so rounding can never cull a corner. */
        sp[3] = sqrt(r2) * (1.0 + 1e-12) + e->tol;
    }

    /* Stdio buffers are copied into each child; empty them so nothing the
     * caller printed can appear twice. */
    fflush(NULL);
    for (uint32_t k = 0; k < e->nproc; k++) {
        int sv[2];
        if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) {
            int rc = rad_fail(err, RAD_ERR_GL, "hc_create: socketpair: %s", strerror(errno));
            hc_destroy(e);
            return rc;
        }
        pid_t pid = fork();
        if (pid < 0) {
            int rc = rad_fail(err, RAD_ERR_GL, "hc_create: fork: %s", strerror(errno));
            close(sv[0]);
            close(sv[1]);
            hc_destroy(e);
            return rc;
        }
        if (pid == 0) {
            close_other_fds(sv[1]);
            worker_main(e, sv[1]);
        }
        close(sv[1]);
        e->w[k].pid = pid;
        e->w[k].fd = sv[0];
    }
    /* The workers set up in parallel; collect their reports. */
    for (uint32_t k = 0; k < e->nproc; k++) {
        int rc = read_status(e, k, err);
        if (rc) {
            hc_destroy(e);
            return rc;
        }
    }
    *out = e;
    return RAD_OK;
}

/* One call's work and where its answers go: rows of patches into F, or
 * rows of point receivers handed to the caller's store. */
typedef struct hc_job {
    const uint32_t *rows;       /* rows: patch indices */
    rad_matrix *F;
    const hc_receiver *recv;    /* points */
    hc_row_store store;
    void *user;
    uint32_t count;
} hc_job;

static int send_chunk(hc_engine *e, uint32_t k, const hc_job *job, uint32_t first, uint32_t count)
{
    int rc;
    if (job->recv) {
        uint32_t head[2] = {HC_REQ_POINTS, count};
        hc_point_req pts[HC_MAX_CHUNK];
        for (uint32_t q = 0; q < count; q++) {
            const hc_receiver *r = &job->recv[first + q];
            rad_vec3 at = rad_sub(r->center, e->origin);
            pts[q] = (hc_point_req){first + q, r->patch, {at.x, at.y, at.z}};
        }
        rc = send_all(e->w[k].fd, head, sizeof head) ||
             send_all(e->w[k].fd, pts, count * sizeof *pts);
    } else {
        uint32_t buf[1 + HC_MAX_CHUNK];
        buf[0] = count;
        memcpy(buf + 1, job->rows + first, count * sizeof *buf);
        rc = send_all(e->w[k].fd, buf, (1 + count) * sizeof *buf);
    }
    if (rc != 0)
        return -1;
    e->w[k].in_flight += count;
    return 0;
}

static int worker_gone(hc_engine *e, uint32_t k, rad_error *err)
{
    e->broken = 1;
    snprintf(e->broken_msg, sizeof e->broken_msg, "hemi-cube worker %u stopped", k);
    e->w[k].in_flight = 0;
    return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
}

/* Reads the text of a worker's error message; the engine is broken after it
 * (the worker has exited). */
static int worker_error(hc_engine *e, uint32_t k, uint32_t len, rad_error *err)
{
    char text[HC_MAX_MSG + 1] = "";
    if (len > HC_MAX_MSG || recv_all(e->w[k].fd, text, len) != 0)
        return worker_gone(e, k, err);
    text[len] = '\0';
    e->broken = 1;
    snprintf(e->broken_msg, sizeof e->broken_msg, "%s (worker %u)", text, k);
    e->w[k].in_flight = 0;
    return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
}

static void keep_first(int *rc, int code)
{
    if (*rc == RAD_OK)
        *rc = code;
}

/* Reads one answer of worker k (a batch of rows) and stores its rows in F
 * while *rc is RAD_OK; the first failure lands in *rc and err.  After a
 * failure to store, the rest is still read so the stream stays in step. */
static void receive_batch(hc_engine *e, uint32_t k, const hc_job *job, int *rc, uint32_t *done,
                          rad_error *err)
{
    int fd = e->w[k].fd;
    rad_error *first = *rc == RAD_OK ? err : NULL;
    uint32_t hdr[2];
    if (recv_all(fd, hdr, sizeof hdr) != 0) {
        keep_first(rc, worker_gone(e, k, first));
        return;
    }
    if (hdr[0] == HC_MSG_ERROR) {
        keep_first(rc, worker_error(e, k, hdr[1], first));
        return;
    }
    if (hdr[0] != HC_MSG_BATCH || hdr[1] == 0 || hdr[1] > e->w[k].in_flight) {
        keep_first(rc, worker_gone(e, k, first));
        return;
    }
    for (uint32_t r = 0; r < hdr[1]; r++) {
        first = *rc == RAD_OK ? err : NULL;
        uint32_t rh[2];
        if (recv_all(fd, rh, sizeof rh) != 0) {
            keep_first(rc, worker_gone(e, k, first));
            return;
        }
        if (rh[0] == HC_MSG_ERROR) {
            keep_first(rc, worker_error(e, k, rh[1], first));
            return;
        }
        /* i: the patch of a row, or the receiver number of a point. */
        uint32_t i = rh[0], cnt = rh[1];
        if (i >= (job->recv ? job->count : e->n) || cnt > e->n ||
            recv_all(fd, e->rx_col, (size_t)cnt * sizeof *e->rx_col) != 0 ||
            recv_all(fd, e->rx_val, (size_t)cnt * sizeof *e->rx_val) != 0) {
            keep_first(rc, worker_gone(e, k, first));
            return;
        }
        e->w[k].in_flight--;
        if (*rc != RAD_OK)
            continue;
        uint32_t self = job->recv ? job->recv[i].patch : i;
        for (uint32_t q = 0; q < cnt; q++)
            if (e->rx_col[q] >= e->n || e->rx_col[q] == self ||
                (q && e->rx_col[q] <= e->rx_col[q - 1]) || !(e->rx_val[q] > 0.0f) ||
                !isfinite(e->rx_val[q])) {
                keep_first(rc, worker_gone(e, k, err));
                return;
            }
        int s = job->recv ? job->store(job->user, i, cnt, e->rx_col, e->rx_val, err)
                          : rad_matrix_set_row(job->F, i, cnt, e->rx_col, e->rx_val, err);
        if (s != RAD_OK) {
            keep_first(rc, s);
            continue;
        }
        (*done)++;
        if (e->opt.progress)
            e->opt.progress(e->opt.progress_user, *done, job->count);
    }
}

static int run_job(hc_engine *e, const hc_job *job, rad_error *err);

int hc_compute_rows(hc_engine *e, const uint32_t *rows, uint32_t count, rad_matrix *F,
                    rad_error *err)
{
    if (!e || !F || (count && !rows))
        return rad_fail(err, RAD_ERR_USAGE, "hc_compute_rows: engine, matrix and rows must be given");
    if (F->n != e->n)
        return rad_fail(err, RAD_ERR_USAGE, "hc_compute_rows: matrix has %u rows, the mesh %u patches",
                        F->n, e->n);
    for (uint32_t k = 0; k < count; k++)
        if (rows[k] >= e->n)
            return rad_fail(err, RAD_ERR_USAGE, "hc_compute_rows: row %u: no such patch (%u patches)",
                            rows[k], e->n);
    hc_job job = {.rows = rows, .F = F, .count = count};
    return run_job(e, &job, err);
}

int hc_compute_points(hc_engine *e, const hc_receiver *recv, uint32_t count, hc_row_store store,
                      void *user, rad_error *err)
{
    if (!e || !store || (count && !recv))
        return rad_fail(err, RAD_ERR_USAGE, "hc_compute_points: engine, receivers and store must be given");
    for (uint32_t k = 0; k < count; k++)
        if (recv[k].patch >= e->n || !rad_finite3(recv[k].center))
            return rad_fail(err, RAD_ERR_USAGE, "hc_compute_points: receiver %u: patch %u of %u, or a "
                            "non-finite point", k, recv[k].patch, e->n);
    hc_job job = {.recv = recv, .store = store, .user = user, .count = count};
    return run_job(e, &job, err);
}

/* Hands the job out in chunks and collects every answer. */
static int run_job(hc_engine *e, const hc_job *job, rad_error *err)
{
    const uint32_t count = job->count;
    if (e->broken)
        return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
    if (count == 0)
        return RAD_OK;

    /* Modest chunks, at most two in flight per worker: a fast worker comes
     * back for more, and the tail stays short. */
    uint32_t chunk = count / (e->nproc * 8);
    chunk = chunk < 1 ? 1 : chunk > HC_MAX_CHUNK ? HC_MAX_CHUNK : chunk;
    uint32_t next = 0, done = 0;
    int rc = RAD_OK;
    struct pollfd *pf = malloc(e->nproc * sizeof *pf);
    uint32_t *who = malloc(e->nproc * sizeof *who);
    if (!pf || !who) {
        free(pf);
        free(who);
        return rad_fail(err, RAD_ERR_NOMEM, "hemi-cube: out of memory");
    }
    for (;;) {
        for (uint32_t k = 0; rc == RAD_OK && k < e->nproc; k++)
            while (rc == RAD_OK && next < count && e->w[k].in_flight <= chunk) {
                uint32_t c = count - next < chunk ? count - next : chunk;
                if (send_chunk(e, k, job, next, c) != 0)
                    rc = worker_gone(e, k, err);
                else
                    next += c;
            }
        nfds_t np = 0;
        for (uint32_t k = 0; k < e->nproc; k++)
            if (e->w[k].in_flight) {
                pf[np].fd = e->w[k].fd;
                pf[np].events = POLLIN;
                pf[np].revents = 0;
                who[np++] = k;
            }
        if (np == 0)
            break;
        if (poll(pf, np, -1) < 0) {
            if (errno == EINTR)
                continue;
            if (rc == RAD_OK)
                rc = rad_fail(err, RAD_ERR_GL, "hemi-cube: poll: %s", strerror(errno));
            /* Replies cannot be drained: the protocol is out of step. */
            e->broken = 1;
            snprintf(e->broken_msg, sizeof e->broken_msg, "hemi-cube: workers out of step");
            break;
        }
        /* After a failure the remaining answers are read and dropped, so the
         * workers stay in step for the next call. */
        for (nfds_t q = 0; q < np; q++)
            if (pf[q].revents)
                receive_batch(e, who[q], job, &rc, &done, err);
    }
    free(pf);
    free(who);
    return rc;
}

/* Reads the header of worker k's answer to a light request: RAD_OK with
 * its count in *m when the header is `tag`; else the engine is broken (a
 * worker's error message, or a stream out of step). */
static int receive_light_header(hc_engine *e, uint32_t k, uint32_t tag, uint32_t *m,
                                rad_error *err)
{
    uint32_t hdr[2];
    if (recv_all(e->w[k].fd, hdr, sizeof hdr) != 0)
        return worker_gone(e, k, err);
    if (hdr[0] == HC_MSG_ERROR)
        return worker_error(e, k, hdr[1], err);
    if (hdr[0] != tag)
        return worker_gone(e, k, err);
    *m = hdr[1];
    return RAD_OK;
}

/* Reads worker k's answer to one light part and adds it to power (when
 * add); RAD_OK, or the engine is broken and the error is in err. */
static int receive_light(hc_engine *e, uint32_t k, double *power, double *rx, int add,
                         rad_error *err)
{
    int fd = e->w[k].fd;
    uint32_t m;
    int rc = receive_light_header(e, k, HC_MSG_LIGHT, &m, err);
    if (rc != RAD_OK)
        return rc;
    if (m > e->n ||
        recv_all(fd, e->rx_col, (size_t)m * sizeof *e->rx_col) != 0 ||
        recv_all(fd, rx, (size_t)m * sizeof *rx) != 0)
        return worker_gone(e, k, err);
    for (uint32_t q = 0; q < m; q++)
        if (e->rx_col[q] >= e->n || (q && e->rx_col[q] <= e->rx_col[q - 1]) || !(rx[q] > 0.0) ||
            !isfinite(rx[q]))
            return worker_gone(e, k, err);
    if (add)
        for (uint32_t q = 0; q < m; q++)
            power[e->rx_col[q]] += rx[q];
    return RAD_OK;
}

/* Checks a light and fills the request of its parts (all but q->part);
 * fn names the public function in messages. */
static int light_request(const hc_engine *e, const hc_light *light, uint32_t resolution,
                         const char *fn, hc_light_req *q, rad_error *err)
{
    uint32_t R = resolution ? resolution : HC_LIGHT_DEFAULT_R;
    if (!resolution_ok(R))
        return rad_fail(err, RAD_ERR_USAGE, "%s: resolution %u: must be even and within 8..4096",
                        fn, R);
    memset(q, 0, sizeof *q);
    q->resolution = R;
    q->kind = (uint32_t)light->kind;
    rad_vec3 dir = rad_v3(0, 0, 0);
    switch (light->kind) {
    case HC_LIGHT_SPOT:
        if (!isfinite(light->inner_cone) || !isfinite(light->outer_cone) || light->inner_cone < 0.0 ||
            light->inner_cone > light->outer_cone || light->outer_cone > M_PI / 2)
            return rad_fail(err, RAD_ERR_USAGE,
                            "%s: spot cones %g, %g: need 0 <= inner <= outer <= pi/2", fn,
                            light->inner_cone, light->outer_cone);
        /* fall through */
    case HC_LIGHT_DIRECTIONAL:
        dir = light->direction;
        if (!rad_finite3(dir) || !(rad_length(dir) > 0.0))
            return rad_fail(err, RAD_ERR_USAGE, "%s: light direction must be finite and non-zero", fn);
        dir = rad_normalize(dir);
        if (light->kind == HC_LIGHT_DIRECTIONAL)
            break;
        /* fall through */
    case HC_LIGHT_POINT:
        if (!rad_finite3(light->position))
            return rad_fail(err, RAD_ERR_USAGE, "%s: light position must be finite", fn);
        break;
    default:
        return rad_fail(err, RAD_ERR_USAGE, "%s: unknown light kind %d", fn, (int)light->kind);
    }
    if (e->broken)
        return rad_fail(err, RAD_ERR_GL, "%s", e->broken_msg);
    rad_vec3 pos = light->kind == HC_LIGHT_DIRECTIONAL ? rad_v3(0, 0, 0) : rad_sub(light->position, e->origin);
    q->pos[0] = pos.x, q->pos[1] = pos.y, q->pos[2] = pos.z;
    q->dir[0] = dir.x, q->dir[1] = dir.y, q->dir[2] = dir.z;
    q->cos_inner = cos(light->inner_cone);
    q->cos_outer = cos(light->outer_cone);
    return RAD_OK;
}

int hc_light_power(hc_engine *e, const hc_light *light, uint32_t resolution, double *power,
                   rad_error *err)
{
    if (!e || !light || (!power && e->n))
        return rad_fail(err, RAD_ERR_USAGE, "hc_light_power: engine, light and power must be given");
    hc_light_req q;
    int rc = light_request(e, light, resolution, "hc_light_power", &q, err);
    if (rc != RAD_OK)
        return rc;
    for (uint32_t j = 0; j < e->n; j++)
        power[j] = 0.0;
    if (e->n == 0)
        return RAD_OK;
    const rad_vec3 dir = rad_v3(q.dir[0], q.dir[1], q.dir[2]);

    /* Parts: the cube faces (a spot's faces that its outer cone reaches: the
     * face's directions lie within acos(1/√3) of its axis), or the single
     * orthographic view. */
    uint32_t parts[6], np = 0;
    if (light->kind == HC_LIGHT_DIRECTIONAL) {
        parts[np++] = 0;
    } else {
        for (uint32_t f = 0; f < 6; f++) {
            rad_vec3 right, up, fwd;
            cube_face(f, &right, &up, &fwd);
            double ang = acos(fmax(-1.0, fmin(1.0, rad_dot(fwd, dir))));
            if (light->kind == HC_LIGHT_SPOT && ang > light->outer_cone + acos(1.0 / sqrt(3.0)) + 1e-9)
                continue;
            parts[np++] = f;
        }
    }
    double *rx = malloc((size_t)e->n * sizeof *rx);
    if (!rx)
        return rad_fail(err, RAD_ERR_NOMEM, "hc_light_power: out of memory for %u patches", e->n);
    /* Part k goes to worker k mod nproc; each worker answers in the order
     * asked, so reading the parts in order reads every stream in order. */
    uint32_t sent = 0;
    for (; sent < np; sent++) {
        uint32_t k = sent % e->nproc;
        q.part = parts[sent];
        uint32_t word = HC_REQ_LIGHT;
        if (send_all(e->w[k].fd, &word, sizeof word) != 0 || send_all(e->w[k].fd, &q, sizeof q) != 0) {
            rc = worker_gone(e, k, err);
            break;
        }
    }
    /* Answers of parts already sent are read even after a failure, while
     * their workers live, so a later call finds the streams in step. */
    for (uint32_t p = 0; p < sent; p++) {
        uint32_t k = p % e->nproc;
        if (e->w[k].fd < 0)
            continue;
        int s = receive_light(e, k, power, rx, rc == RAD_OK, rc == RAD_OK ? err : NULL);
        if (s != RAD_OK && rc == RAD_OK)
            rc = s;
        if (s != RAD_OK) {
            /* That stream is lost: no more reads from it. */
            close(e->w[k].fd);
            e->w[k].fd = -1;
        }
    }
    free(rx);
    if (rc != RAD_OK)
        for (uint32_t j = 0; j < e->n; j++)
            power[j] = 0.0;
    return rc;
}

double hc_light_direct(const hc_light *light, rad_vec3 p, rad_vec3 n)
{
    if (light->kind == HC_LIGHT_DIRECTIONAL) {
        double c = -rad_dot(n, rad_normalize(light->direction));
        return c > 0.0 ? c : 0.0;
    }
    rad_vec3 r = rad_sub(light->position, p);
    double r2 = rad_dot(r, r);
    if (!(r2 > 0.0))
        return 0.0;
    double len = sqrt(r2), c = rad_dot(n, r) / len;
    if (!(c > 0.0))
        return 0.0;
    double f = 1.0;
    if (light->kind == HC_LIGHT_SPOT)
        f = spot_falloff(-rad_dot(r, rad_normalize(light->direction)) / len, cos(light->inner_cone),
                         cos(light->outer_cone));
    return f * c / r2;
}

/* The part (cube face, or the orthographic view) holding the direction from
 * the light to `at` (relative to the origin): the face of the dominant axis,
 * which projects it into [-1, 1]²; -1 for a point at the light. */
static int vis_part(const hc_light_req *q, rad_vec3 at)
{
    if (q->kind == HC_LIGHT_DIRECTIONAL)
        return 0;
    double r[3] = {at.x - q->pos[0], at.y - q->pos[1], at.z - q->pos[2]};
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (fabs(r[a]) > fabs(r[axis]))
            axis = a;
    if (!(fabs(r[axis]) > 0.0))
        return -1;
    return 2 * axis + (r[axis] < 0.0); /* cube_face's order: +x, -x, +y, -y, +z, -z */
}

/* Reads worker k's answer to one visibility chunk of m points into
 * vis[idx[0..m)] (when store).  RAD_OK, or the engine is broken. */
static int receive_vis(hc_engine *e, uint32_t k, const uint32_t *idx, uint32_t m, double *vis,
                       double *rx, int store, rad_error *err)
{
    uint32_t got;
    int rc = receive_light_header(e, k, HC_MSG_VIS, &got, err);
    if (rc != RAD_OK)
        return rc;
    if (got != m || recv_all(e->w[k].fd, rx, (size_t)m * sizeof *rx) != 0)
        return worker_gone(e, k, err);
    for (uint32_t q = 0; q < m; q++)
        if (!(rx[q] >= 0.0 && rx[q] <= 1.0))
            return worker_gone(e, k, err);
    if (store)
        for (uint32_t q = 0; q < m; q++)
            vis[idx[q]] = rx[q];
    return RAD_OK;
}

int hc_light_visibility(hc_engine *e, const hc_light *light, uint32_t resolution,
                        const hc_receiver *points, uint32_t count, double *vis, rad_error *err)
{
    if (!e || !light || (count && (!points || !vis)))
        return rad_fail(err, RAD_ERR_USAGE,
                        "hc_light_visibility: engine, light, points and vis must be given");
    for (uint32_t k = 0; k < count; k++)
        if (points[k].patch >= e->n || !rad_finite3(points[k].center))
            return rad_fail(err, RAD_ERR_USAGE, "hc_light_visibility: point %u: patch %u of %u, or "
                            "a non-finite point", k, points[k].patch, e->n);
    hc_light_req q;
    int rc = light_request(e, light, resolution, "hc_light_visibility", &q, err);
    if (rc != RAD_OK)
        return rc;
    for (uint32_t k = 0; k < count; k++)
        vis[k] = 0.0;
    if (count == 0)
        return RAD_OK;
    /* The points by part (a counting sort, stable: each part's points in
     * their given order), so a worker renders a part once for all of its
     * chunks (light_render keeps the last part's pixels). */
    uint32_t *part = malloc((size_t)count * sizeof *part), *order = malloc((size_t)count * sizeof *order);
    double *rx = malloc(HC_VIS_CHUNK * sizeof *rx);
    hc_point_req *buf = malloc(HC_VIS_CHUNK * sizeof *buf);
    uint32_t start[8] = {0};
    if (!part || !order || !rx || !buf) {
        free(part), free(order), free(rx), free(buf);
        return rad_fail(err, RAD_ERR_NOMEM, "hc_light_visibility: out of memory for %u points", count);
    }
    for (uint32_t k = 0; k < count; k++) {
        int f = vis_part(&q, rad_sub(points[k].center, e->origin));
        part[k] = f < 0 ? 6u : (uint32_t)f; /* 6: at the light, left at 0 */
        start[part[k] + 1]++;
    }
    for (int f = 0; f < 7; f++)
        start[f + 1] += start[f];
    uint32_t fill[7];
    memcpy(fill, start, sizeof fill);
    for (uint32_t k = 0; k < count; k++)
        order[fill[part[k]]++] = k;
    /* Worker k takes the parts k, k + nproc, ... in turn; per round each
     * worker has one chunk in flight, and every answer of a round is read
     * before the next round is sent, so no socket fills in both directions.
     * Results depend only on the part's pixels and the point, never on
     * which worker drew them. */
    uint32_t *wpart = calloc(e->nproc, sizeof *wpart), *wnext = calloc(e->nproc, sizeof *wnext);
    uint32_t *wsent = calloc(e->nproc, sizeof *wsent), *wcnt = calloc(e->nproc, sizeof *wcnt);
    if (!wpart || !wnext || !wsent || !wcnt) {
        rc = rad_fail(err, RAD_ERR_NOMEM, "hc_light_visibility: out of memory");
        goto done;
    }
    for (uint32_t k = 0; k < e->nproc; k++) {
        wpart[k] = k;
        wnext[k] = k < 6 ? start[k] : 0;
    }
    for (;;) {
        int any = 0;
        memset(wcnt, 0, e->nproc * sizeof *wcnt);
        for (uint32_t k = 0; k < e->nproc; k++) {
            while (rc == RAD_OK && wpart[k] < 6 && wnext[k] >= start[wpart[k] + 1]) {
                wpart[k] += e->nproc;
                if (wpart[k] < 6)
                    wnext[k] = start[wpart[k]];
            }
            if (rc != RAD_OK || wpart[k] >= 6 || e->w[k].fd < 0)
                continue;
            uint32_t f = wpart[k], m = start[f + 1] - wnext[k];
            m = m > HC_VIS_CHUNK ? HC_VIS_CHUNK : m;
            for (uint32_t i = 0; i < m; i++) {
                const hc_receiver *pt = &points[order[wnext[k] + i]];
                rad_vec3 at = rad_sub(pt->center, e->origin);
                buf[i] = (hc_point_req){order[wnext[k] + i], pt->patch, {at.x, at.y, at.z}};
            }
            q.part = f;
            uint32_t word = HC_REQ_VIS;
            if (send_all(e->w[k].fd, &word, sizeof word) != 0 || send_all(e->w[k].fd, &q, sizeof q) != 0 ||
                send_all(e->w[k].fd, &m, sizeof m) != 0 ||
                send_all(e->w[k].fd, buf, m * sizeof *buf) != 0) {
                rc = worker_gone(e, k, err);
                break;
            }
            wsent[k] = wnext[k];
            wcnt[k] = m;
            wnext[k] += m;
            any = 1;
        }
        /* Answers already asked for are read even after a failure, while
         * their workers live, so a later call finds the streams in step. */
        for (uint32_t k = 0; k < e->nproc; k++) {
            if (!wcnt[k] || e->w[k].fd < 0)
                continue;
            int s = receive_vis(e, k, order + wsent[k], wcnt[k], vis, rx, rc == RAD_OK,
                                rc == RAD_OK ? err : NULL);
            if (s != RAD_OK) {
                if (rc == RAD_OK)
                    rc = s;
                close(e->w[k].fd);
                e->w[k].fd = -1;
            }
        }
        if (!any || rc != RAD_OK)
            break;
    }
done:
    if (rc != RAD_OK)
        for (uint32_t k = 0; k < count; k++)
            vis[k] = 0.0;
    free(part), free(order), free(rx), free(buf);
    free(wpart), free(wnext), free(wsent), free(wcnt);
    return rc;
}
