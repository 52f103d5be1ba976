/* gl_osmesa.c - the OSMesa back end of the hemi-cube's GL (hc_gl_context in
 * hc_internal.h): the only file that knows libOSMesa.
 *
 * Loads libOSMesa.so.8 at run time (dlopen, in a worker only: the process
 * that forks the workers holds F and never draws, and linking OSMesa with
 * the LLVM it pulls in would cost it ~48 MB resident for nothing) and makes
 * a GL 4.5 core context current on a 1×1 dummy buffer: gl.c draws every
 * view into framebuffer objects of its own, never into OSMesa's buffer.
 *
 * Invariant: the library and the context live until the worker's _exit
 * (no dlclose, no OSMesaDestroyContext: llvmpipe's threads live as long,
 * and _exit runs no leak checker); the entry points below are NULL in any
 * process that has not started this back end.
 */
#include "hc_internal.h"

#include <GL/osmesa.h>

#include <dlfcn.h>
#include <stdio.h>

/* The library a worker loads, and the Debian package that ships it. */
#define HC_OSMESA_LIB "libOSMesa.so.8"
#define HC_OSMESA_PACKAGE "libosmesa6"

/* The OSMesa calls, found by dlsym (OSMesaName), each typed by its
 * prototype in the header (__typeof__): no OSMesa symbol is referenced at
 * link time. */
#define HC_OSMESA_ENTRY_POINTS(X) X(CreateContextAttribs) X(MakeCurrent) X(GetProcAddress)
#define HC_OSMESA_POINTER(name) __typeof__(OSMesa##name) *name;
static struct {
    HC_OSMESA_ENTRY_POINTS(HC_OSMESA_POINTER)
} osmesa;

static OSMesaContext context;
static unsigned char dummy[16];

static const char *osmesa_library(void) { return HC_OSMESA_LIB; }

/* RTLD_NOW: a library that cannot bind its symbols fails here, as an
 * error value, rather than at a first call, as a crash. */
static int osmesa_load(char *msg)
{
    void *lib = dlopen(HC_OSMESA_LIB, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: cannot load %s (Debian package %s): %s",
                 HC_OSMESA_LIB, HC_OSMESA_PACKAGE, dlerror());
        return -1;
    }
    /* dlsym's void * to a function pointer: POSIX guarantees it works. */
#define HC_OSMESA_LOAD(name)                                                                   \
    if (!(osmesa.name = (__typeof__(osmesa.name))dlsym(lib, "OSMesa" #name))) {                \
        snprintf(msg, HC_MAX_MSG, "hemi-cube: %s has no OSMesa%s", HC_OSMESA_LIB, #name);      \
        return -1;                                                                             \
    }
    HC_OSMESA_ENTRY_POINTS(HC_OSMESA_LOAD)
#undef HC_OSMESA_LOAD
    return 0;
}

/* A GL 4.5 core context with no buffers of its own worth the name (RGBA,
 * no depth, stencil or accumulation: the framebuffer objects have theirs). */
static int osmesa_context(int gpu_only, char *msg)
{
    (void)gpu_only; /* OSMesa is llvmpipe, never a GPU: the chooser never asks */
    const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0,
                           OSMESA_STENCIL_BITS, 0, OSMESA_ACCUM_BITS, 0,
                           OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION, 4, OSMESA_CONTEXT_MINOR_VERSION, 5, 0};
    context = osmesa.CreateContextAttribs(attribs, NULL);
    if (!context) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: OSMesa could not create a GL 4.5 core context");
        return -1;
    }
    if (!osmesa.MakeCurrent(context, dummy, GL_UNSIGNED_BYTE, 1, 1)) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: OSMesaMakeCurrent failed");
        return -1;
    }
    return 0;
}

/* Mesa's OSMesaGetProcAddress answers for core entry points as well as
 * extensions, and is the only way to glClipControl, which the library does
 * not export.  Its generic void (*)() becomes void (*)(void), which
 * -Wcast-function-type lets convert to any function type. */
static hc_gl_proc osmesa_proc(const char *name)
{
    return (hc_gl_proc)osmesa.GetProcAddress(name);
}

const hc_gl_context hc_gl_osmesa = {osmesa_library, osmesa_load, osmesa_proc, osmesa_context};
