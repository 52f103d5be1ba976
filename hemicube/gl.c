/* gl.c - GL for the hemi-cube workers, whatever made the context: the
 * only file that draws.
 *
 * Owns the shaders, the one vertex buffer holding every patch (patch j's
 * triangles contiguous, positions relative to the bounding-box centre,
 * each vertex carrying its patch id), the render targets (the hemi-cube's
 * item-buffer atlas, R wide and 3R tall, and an R×R light view, framebuffer
 * objects both) and the calls rows.c and light_views.c draw and read with
 * (hc_gl_* in hc_internal.h).  Only a worker process (or the chooser's
 * short-lived probe) ever makes a context, so the caller can fork freely.
 *
 * The context comes from a back end (hc_gl_context): gl_osmesa.c
 * (libOSMesa, the default) or gl_egl.c (libEGL: a GPU, or Mesa's
 * surfaceless llvmpipe), each loaded at run time, never linked: the process
 * that forks the workers holds F and never draws, and linking a GL library
 * (and the LLVM llvmpipe pulls in) would cost it ~48 MB resident for
 * nothing.  GL is called through a table of entry points (gl.Name) the
 * back end's proc fills; since every view draws into this file's
 * framebuffer objects, never into a window or the back end's buffer, the
 * same drawing gives the same item buffers through either back end on the
 * same renderer.
 *
 * Invariants: depth is reversed Z with an infinite far plane (depth =
 * near/distance, the target cleared to 0, GL_GREATER); the item target
 * holds patch ids, HC_NO_PATCH where nothing or only a back side shows;
 * between calls the program is in item mode (mode 0) with the depth test on.
 * No function of this file but hc_gl_create, hc_gl_probe and
 * hc_gl_projection runs before the table is filled.
 */
#define GL_GLEXT_PROTOTYPES 1 /* the prototypes give the table its types (__typeof__) */
#include "hc_internal.h"

#include <GL/gl.h>
#include <GL/glext.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Every GL entry point this file calls, each named once (without its "gl").
 * A call is gl.Name(...); the header's prototype of glName gives the
 * pointer its type (__typeof__, the GCC and Clang extension: C11 has no
 * typeof, and GL 1.x entry points have no PFN typedef), and no GL symbol
 * is referenced at link time. */
#define HC_GL_ENTRY_POINTS(X)                                                                  \
    X(AttachShader) X(BindBuffer) X(BindFramebuffer) X(BindRenderbuffer) X(BindVertexArray)     \
    X(BufferData) X(CheckFramebufferStatus) X(ClearBufferfv) X(ClearBufferuiv) X(ClipControl)   \
    X(CompileShader) X(CreateProgram) X(CreateShader) X(DeleteShader) X(DepthFunc) X(Disable)   \
    X(DrawBuffers) X(Enable) X(EnableVertexAttribArray) X(FramebufferRenderbuffer)              \
    X(GenBuffers) X(GenFramebuffers) X(GenRenderbuffers) X(GenVertexArrays) X(GetError)         \
    X(GetIntegerv) X(GetProgramInfoLog) X(GetProgramiv) X(GetShaderInfoLog) X(GetShaderiv)      \
    X(GetUniformLocation) X(LinkProgram) X(LogicOp) X(MultiDrawElements) X(PixelStorei)         \
    X(ReadBuffer) X(ReadPixels) X(RenderbufferStorage) X(Scissor) X(ShaderSource)               \
    X(Uniform1ui) X(Uniform3f) X(UniformMatrix4fv) X(UseProgram) X(VertexAttribIPointer)        \
    X(VertexAttribPointer) X(Viewport)

#define HC_GL_POINTER(name) __typeof__(gl##name) *name;
/* Per process: filled in a worker by load_gl, all NULL in the caller. */
static struct {
    HC_GL_ENTRY_POINTS(HC_GL_POINTER)
    __typeof__(glGetString) *GetString; /* the chooser's probe only */
} gl;

/* hc_internal.h keeps GL types out: draw lists are int, as GLint and GLsizei. */
_Static_assert(_Generic((GLint)0, int: 1, default: 0) && _Generic((GLsizei)0, int: 1, default: 0),
               "GLint and GLsizei must be int");

struct hc_gl {
    GLuint fbo, rb[2], prog, vao, vbo, ibo;
    const void **offsets; /* a draw list's byte offsets into the index buffer */
    GLint loc_m, loc_eye, loc_mode;
    /* Light target, R×R, made on the first light request of that size. */
    GLuint lfbo, lrb[2];
    uint32_t lR;
};

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

int hc_gl_check(const char *where, char *msg)
{
    GLenum e = gl.GetError();
    if (e == GL_NO_ERROR)
        return 0;
    snprintf(msg, HC_MAX_MSG, "hemi-cube: %s: GL error 0x%04x", where, (unsigned)e);
    return -1;
}

/* --------------------------------------------------- the context (back end) */

/* Loads back end c's library and fills the gl table from it, then makes
 * its context current; 0, or -1 with msg set.  The entry points are looked
 * up before the context is made, so a library without them fails by name
 * before any of its context calls runs.  The answer is a generic
 * void (*)(void), which -Wcast-function-type lets convert to the entry
 * point's own type. */
static int load_gl(const hc_gl_context *c, int gpu_only, char *msg)
{
    if (c->load(msg) != 0)
        return -1;
#define HC_GL_LOAD(name)                                                                       \
    if (!(gl.name = (__typeof__(gl.name))c->proc("gl" #name))) {                               \
        snprintf(msg, HC_MAX_MSG, "hemi-cube: %s has no gl%s", c->library(), #name);          \
        return -1;                                                                             \
    }
    HC_GL_ENTRY_POINTS(HC_GL_LOAD)
    HC_GL_LOAD(GetString)
#undef HC_GL_LOAD
    return c->context(gpu_only, msg);
}

int hc_gl_probe(const hc_gl_context *c, int gpu_only, char *renderer, size_t size, char *msg)
{
    if (load_gl(c, gpu_only, msg) != 0)
        return -1;
    const GLubyte *name = gl.GetString(GL_RENDERER);
    snprintf(renderer, size, "%s", name ? (const char *)name : "(unnamed)");
    return 0;
}

/* ------------------------------------------------------------ GL set-up */

/* The atlas FBO (R wide, 3R tall: item buffer and depth), with the fixed
 * state every view uses, in the current context. */
static int atlas(hc_gl *g, uint32_t Ru, char *msg)
{
    GLsizei R = (GLsizei)Ru;
    GLint max_rb = 0;
    gl.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
    if (max_rb < 3 * R) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: resolution %d needs a %d-pixel render buffer, GL allows %d",
                 (int)R, (int)(3 * R), (int)max_rb);
        return -1;
    }
    gl.GenFramebuffers(1, &g->fbo);
    gl.BindFramebuffer(GL_FRAMEBUFFER, g->fbo);
    gl.GenRenderbuffers(2, g->rb);
    gl.BindRenderbuffer(GL_RENDERBUFFER, g->rb[0]);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_R32UI, R, 3 * R);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g->rb[0]);
    gl.BindRenderbuffer(GL_RENDERBUFFER, g->rb[1]);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, R, 3 * R);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, g->rb[1]);
    GLenum status = gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: item-buffer framebuffer incomplete (0x%04x)",
                 (unsigned)status);
        return -1;
    }
    const GLenum draw = GL_COLOR_ATTACHMENT0;
    gl.DrawBuffers(1, &draw);
    gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
    gl.PixelStorei(GL_PACK_ALIGNMENT, 4);
    /* Reversed Z with an infinite far plane: depth = near/distance in a
     * float buffer keeps ~24 bits of relative precision at every distance,
     * so surfaces a hundredth of a patch apart still resolve. */
    gl.ClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    gl.Enable(GL_DEPTH_TEST);
    gl.DepthFunc(GL_GREATER);
    gl.Enable(GL_SCISSOR_TEST);
    gl.Disable(GL_CULL_FACE);
    gl.Disable(GL_DITHER);
    gl.Disable(GL_BLEND);
    return hc_gl_check("framebuffer set-up", msg);
}

static GLuint compile(GLenum type, const char *src, char *msg)
{
    GLuint s = gl.CreateShader(type);
    gl.ShaderSource(s, 1, &src, NULL);
    gl.CompileShader(s);
    GLint ok = 0;
    gl.GetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[512] = "";
        gl.GetShaderInfoLog(s, sizeof log, NULL, log);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: shader compile failed: %s", log);
        gl.DeleteShader(s);
        return 0;
    }
    return s;
}

/* Compiles, links and binds the item-buffer program, in mode 0. */
static int program(hc_gl *g, char *msg)
{
    GLuint vs = compile(GL_VERTEX_SHADER, vs_src, msg);
    if (!vs)
        return -1;
    GLuint fs = compile(GL_FRAGMENT_SHADER, fs_src, msg);
    if (!fs)
        return -1;
    g->prog = gl.CreateProgram();
    gl.AttachShader(g->prog, vs);
    gl.AttachShader(g->prog, fs);
    gl.LinkProgram(g->prog);
    GLint ok = 0;
    gl.GetProgramiv(g->prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[512] = "";
        gl.GetProgramInfoLog(g->prog, sizeof log, NULL, log);
        snprintf(msg, HC_MAX_MSG, "hemi-cube: shader link failed: %s", log);
        return -1;
    }
    gl.DeleteShader(vs);
    gl.DeleteShader(fs);
    gl.UseProgram(g->prog);
    g->loc_m = gl.GetUniformLocation(g->prog, "m");
    g->loc_eye = gl.GetUniformLocation(g->prog, "eye");
    g->loc_mode = gl.GetUniformLocation(g->prog, "mode");
    gl.Uniform1ui(g->loc_mode, 0u);
    return 0;
}

/* The one VBO holding every patch's triangles as draw_geometry.c builds
 * them (a cell as itself, a cluster by its simplified outline), each
 * vertex with its patch id, and the index buffer, patch j's indices
 * contiguous (w's layout: vfirst[j] is the first index, vcount[j] their
 * number). */
static int upload(const hc_engine *e, hc_gl *g, hc_work *w, char *msg)
{
    hc_draw d;
    if (hc_draw_build(e, &d, w->vfirst, w->vcount, msg) != 0)
        return -1;
    w->nvert = (uint32_t)d.nidx;
    gl.GenVertexArrays(1, &g->vao);
    gl.BindVertexArray(g->vao);
    gl.GenBuffers(1, &g->vbo);
    gl.BindBuffer(GL_ARRAY_BUFFER, g->vbo);
    gl.GenBuffers(1, &g->ibo);
    gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, g->ibo);
    if (d.nidx) {
        gl.BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(d.nvtx * sizeof *d.vtx), d.vtx, GL_STATIC_DRAW);
        gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)(d.nidx * sizeof *d.idx), d.idx,
                      GL_STATIC_DRAW);
    }
    hc_draw_free(&d);
    uint32_t n = e->n;
    g->offsets = malloc(((size_t)n + 1) * sizeof *g->offsets);
    if (!g->offsets) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: out of memory for %u draw ranges", n);
        return -1;
    }
    gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(hc_draw_vtx), (const void *)0);
    gl.VertexAttribIPointer(1, 1, GL_UNSIGNED_INT, sizeof(hc_draw_vtx), (const void *)12);
    gl.EnableVertexAttribArray(0);
    gl.EnableVertexAttribArray(1);
    return hc_gl_check("geometry upload", msg);
}

/* The context lives until the worker's _exit, which frees it with the
 * process: a worker never destroys it. */
int hc_gl_create(const hc_engine *e, hc_work *w, char *msg)
{
    hc_gl *g = hc_alloc(1, sizeof *g, msg);
    if (!g)
        return -1;
    w->gl = g;
    if (!(w->vfirst = hc_alloc(e->n, sizeof *w->vfirst, msg)) ||
        !(w->vcount = hc_alloc(e->n, sizeof *w->vcount, msg)))
        return -1;
    const hc_gl_context *c = e->opt.gl == HC_GL_EGL ? &hc_gl_egl : &hc_gl_osmesa;
    if (load_gl(c, 0, msg) != 0 || atlas(g, e->R, msg) != 0 || program(g, msg) != 0)
        return -1;
    return upload(e, g, w, msg);
}

int hc_gl_light_target(hc_gl *g, uint32_t R, char *msg)
{
    if (g->lR == R) {
        gl.BindFramebuffer(GL_FRAMEBUFFER, g->lfbo);
        return 0;
    }
    GLint max_rb = 0;
    gl.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
    if (max_rb < (GLint)R) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: light resolution %u exceeds GL's %d", R, (int)max_rb);
        return -1;
    }
    g->lR = 0;
    if (!g->lfbo) {
        gl.GenFramebuffers(1, &g->lfbo);
        gl.GenRenderbuffers(2, g->lrb);
    }
    gl.BindFramebuffer(GL_FRAMEBUFFER, g->lfbo);
    gl.BindRenderbuffer(GL_RENDERBUFFER, g->lrb[0]);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_R32UI, (GLsizei)R, (GLsizei)R);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g->lrb[0]);
    gl.BindRenderbuffer(GL_RENDERBUFFER, g->lrb[1]);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, (GLsizei)R, (GLsizei)R);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, g->lrb[1]);
    const GLenum draw = GL_COLOR_ATTACHMENT0;
    gl.DrawBuffers(1, &draw);
    gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
    GLenum status = gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: light framebuffer incomplete (0x%04x)", (unsigned)status);
        return -1;
    }
    if (hc_gl_check("light framebuffer set-up", msg) != 0)
        return -1;
    g->lR = R;
    return 0;
}

/* ------------------------------------------------------------------ views */

void hc_gl_projection(double m[16], rad_vec3 right, rad_vec3 up, rad_vec3 d, int side, double near)
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

void hc_gl_eye(hc_gl *g, rad_vec3 eye)
{
    gl.Uniform3f(g->loc_eye, (float)eye.x, (float)eye.y, (float)eye.z);
}

void hc_gl_atlas_begin(hc_gl *g, uint32_t R, rad_vec3 eye)
{
    const GLuint clear_id[4] = {HC_NO_PATCH, 0, 0, 0};
    const GLfloat clear_depth = 0.0f;
    gl.BindFramebuffer(GL_FRAMEBUFFER, g->fbo);
    gl.Scissor(0, 0, (GLsizei)R, (GLsizei)(3 * R));
    gl.ClearBufferuiv(GL_COLOR, 0, clear_id);
    gl.ClearBufferfv(GL_DEPTH, 0, &clear_depth);
    hc_gl_eye(g, eye);
}

void hc_gl_clear_items(hc_gl *g, uint32_t w, uint32_t h, uint32_t value)
{
    (void)g;
    const GLuint clear_id[4] = {value, 0, 0, 0};
    gl.Scissor(0, 0, (GLsizei)w, (GLsizei)h);
    gl.ClearBufferuiv(GL_COLOR, 0, clear_id);
}

void hc_gl_view(hc_gl *g, uint32_t y0, uint32_t w, uint32_t h, const float m[16])
{
    gl.Viewport(0, (GLint)y0, (GLsizei)w, (GLsizei)h);
    gl.Scissor(0, (GLint)y0, (GLsizei)w, (GLsizei)h);
    gl.UniformMatrix4fv(g->loc_m, 1, GL_TRUE, m);
}

void hc_gl_square_view(hc_gl *g, const double m[16], uint32_t R, uint32_t y0)
{
    float mf[16];
    for (int k = 0; k < 16; k++)
        mf[k] = (float)m[k];
    const GLuint clear_id[4] = {HC_NO_PATCH, 0, 0, 0};
    const GLfloat clear_depth = 0.0f;
    gl.Viewport(0, (GLint)y0, (GLsizei)R, (GLsizei)R);
    gl.Scissor(0, (GLint)y0, (GLsizei)R, (GLsizei)R);
    gl.ClearBufferuiv(GL_COLOR, 0, clear_id);
    gl.ClearBufferfv(GL_DEPTH, 0, &clear_depth);
    gl.UniformMatrix4fv(g->loc_m, 1, GL_TRUE, mf);
}

void hc_gl_or_mode(hc_gl *g, int on)
{
    if (on) {
        gl.Uniform1ui(g->loc_mode, 1u);
        gl.Disable(GL_DEPTH_TEST);
        gl.Enable(GL_COLOR_LOGIC_OP);
        gl.LogicOp(GL_OR);
    } else {
        gl.Uniform1ui(g->loc_mode, 0u);
        gl.Disable(GL_COLOR_LOGIC_OP);
        gl.Enable(GL_DEPTH_TEST);
    }
}

/* ---------------------------------------------------------- draw and read */

void hc_gl_draw(hc_gl *g, const int *first, const int *count, int nr)
{
    for (int k = 0; k < nr; k++)
        g->offsets[k] = (const void *)((size_t)first[k] * sizeof(uint32_t));
    gl.MultiDrawElements(GL_TRIANGLES, count, GL_UNSIGNED_INT, g->offsets, nr);
}

void hc_gl_read_items(hc_gl *g, uint32_t w, uint32_t h, uint32_t *dst)
{
    (void)g;
    gl.ReadPixels(0, 0, (GLsizei)w, (GLsizei)h, GL_RED_INTEGER, GL_UNSIGNED_INT, dst);
}

float hc_gl_read_depth(hc_gl *g, uint32_t x, uint32_t y)
{
    (void)g;
    GLfloat D = 0.0f;
    gl.ReadPixels((GLint)x, (GLint)y, 1, 1, GL_DEPTH_COMPONENT, GL_FLOAT, &D);
    return D;
}
