/* gl_egl.c - the EGL back end of the hemi-cube's GL (hc_gl_context in
 * hc_internal.h): the only file that knows libEGL.
 *
 * Loads libEGL.so.1 at run time (dlopen, never linked, in a worker or the
 * chooser's probe process only, as gl_osmesa.c loads OSMesa) and makes a
 * desktop GL 4.5 core context current with no surface at all: gl.c draws
 * every view into framebuffer objects of its own, the same targets and
 * the same shaders whatever made the context, so through Mesa's llvmpipe
 * the item buffers are those OSMesa gives, bit for bit.  The display is,
 * in this order:
 *   - a GPU: the first device of EGL_EXT_device_enumeration that is not
 *     Mesa's software device (EGL_MESA_device_software), on the device
 *     platform (EGL_PLATFORM_DEVICE_EXT), where a context can be made;
 *   - else, unless the caller wants a GPU or nothing, Mesa's surfaceless
 *     platform (EGL_PLATFORM_SURFACELESS_MESA: llvmpipe on a machine with
 *     no GPU).
 * Test hooks: RADIOSITY_EGL_LIBRARY names another file to load in place of
 * libEGL.so.1 (a missing file makes EGL fail to start, deterministically);
 * RADIOSITY_EGL_PLATFORM=surfaceless passes over every device, so that a
 * test compares llvmpipe through EGL with OSMesa even beside a GPU.
 *
 * Invariant: the library, display and context live until the process's
 * _exit (no eglTerminate once a context is current, no dlclose); the entry
 * points are NULL in any process that has not started this back end.
 */
#include "hc_internal.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define HC_EGL_LIB "libEGL.so.1"
#define HC_EGL_PACKAGES "libegl1 and libegl-mesa0"
#define HC_EGL_MAX_DEVICES 16

/* The EGL 1.4 calls, found by dlsym (eglName), each typed by its prototype
 * in the header (__typeof__): no EGL symbol is referenced at link time. */
#define HC_EGL_ENTRY_POINTS(X)                                                                 \
    X(GetProcAddress) X(GetError) X(QueryString) X(Initialize) X(Terminate) X(BindAPI)         \
    X(ChooseConfig) X(CreateContext) X(MakeCurrent)
#define HC_EGL_POINTER(name) __typeof__(egl##name) *name;
static struct {
    HC_EGL_ENTRY_POINTS(HC_EGL_POINTER)
    /* extensions, through eglGetProcAddress (NULL where not offered) */
    PFNEGLGETPLATFORMDISPLAYEXTPROC GetPlatformDisplayEXT;
    PFNEGLQUERYDEVICESEXTPROC QueryDevicesEXT;
    PFNEGLQUERYDEVICESTRINGEXTPROC QueryDeviceStringEXT;
} egl;

static const char *egl_library(void)
{
    const char *path = getenv("RADIOSITY_EGL_LIBRARY");
    return path && *path ? path : HC_EGL_LIB;
}

/* 1 when the space-separated list `exts` holds `name` as a whole word. */
static int has_ext(const char *exts, const char *name)
{
    size_t len = strlen(name);
    for (const char *p = exts; p && (p = strstr(p, name)) != NULL; p += len)
        if ((p == exts || p[-1] == ' ') && (p[len] == ' ' || p[len] == '\0'))
            return 1;
    return 0;
}

static int egl_load(char *msg)
{
    const char *path = egl_library();
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: cannot load %s (Debian packages %s): %s", path,
                 HC_EGL_PACKAGES, dlerror());
        return -1;
    }
#define HC_EGL_LOAD(name)                                                                      \
    if (!(egl.name = (__typeof__(egl.name))dlsym(lib, "egl" #name))) {                         \
        snprintf(msg, HC_MAX_MSG, "hemi-cube: %s has no egl%s", path, #name);                  \
        return -1;                                                                             \
    }
    HC_EGL_ENTRY_POINTS(HC_EGL_LOAD)
#undef HC_EGL_LOAD
    const char *client = egl.QueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (has_ext(client, "EGL_EXT_platform_base"))
        egl.GetPlatformDisplayEXT =
            (PFNEGLGETPLATFORMDISPLAYEXTPROC)egl.GetProcAddress("eglGetPlatformDisplayEXT");
    if (has_ext(client, "EGL_EXT_device_enumeration") || has_ext(client, "EGL_EXT_device_base")) {
        egl.QueryDevicesEXT = (PFNEGLQUERYDEVICESEXTPROC)egl.GetProcAddress("eglQueryDevicesEXT");
        egl.QueryDeviceStringEXT =
            (PFNEGLQUERYDEVICESTRINGEXTPROC)egl.GetProcAddress("eglQueryDeviceStringEXT");
    }
    if (!egl.GetPlatformDisplayEXT) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: %s offers no EGL_EXT_platform_base", path);
        return -1;
    }
    return 0;
}

/* Initialises dpy and makes a desktop GL 4.5 core context current on it
 * with no surface; 0, or -1 with msg set (the display is then terminated). */
static int egl_context(EGLDisplay dpy, const char *what, char *msg)
{
    EGLint major = 0, minor = 0;
    if (dpy == EGL_NO_DISPLAY || !egl.Initialize(dpy, &major, &minor)) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: %s: no display (error 0x%04x)", what,
                 (unsigned)egl.GetError());
        return -1;
    }
    const char *exts = egl.QueryString(dpy, EGL_EXTENSIONS);
    EGLConfig config = EGL_NO_CONFIG_KHR;
    EGLint nconfig = 0;
    const EGLint want[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
    const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                              EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                              EGL_NONE};
    EGLContext ctx = EGL_NO_CONTEXT;
    if (!has_ext(exts, "EGL_KHR_surfaceless_context"))
        snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: %s offers no EGL_KHR_surfaceless_context", what);
    else if (!egl.BindAPI(EGL_OPENGL_API))
        snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: %s has no desktop OpenGL", what);
    else if (!has_ext(exts, "EGL_KHR_no_config_context") &&
             (!egl.ChooseConfig(dpy, want, &config, 1, &nconfig) || nconfig < 1))
        snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: %s has no OpenGL configuration", what);
    else if ((ctx = egl.CreateContext(dpy, config, EGL_NO_CONTEXT, attribs)) == EGL_NO_CONTEXT)
        snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: %s could not create a GL 4.5 core context "
                 "(error 0x%04x)", what, (unsigned)egl.GetError());
    else if (!egl.MakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx))
        snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: %s: eglMakeCurrent failed (error 0x%04x)", what,
                 (unsigned)egl.GetError());
    else
        return 0;
    egl.Terminate(dpy);
    return -1;
}

/* The first GPU device (not Mesa's software one) a context can be made on;
 * 0, or -1 with msg set. */
static int egl_gpu(char *msg)
{
    const char *client = egl.QueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    EGLDeviceEXT dev[HC_EGL_MAX_DEVICES];
    EGLint ndev = 0;
    if (!egl.QueryDevicesEXT || !egl.QueryDeviceStringEXT ||
        !has_ext(client, "EGL_EXT_platform_device")) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: no device platform "
                 "(EGL_EXT_device_enumeration, EGL_EXT_platform_device)");
        return -1;
    }
    if (!egl.QueryDevicesEXT(HC_EGL_MAX_DEVICES, dev, &ndev))
        ndev = 0;
    snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: no GPU device (%d device%s, none but software)",
             (int)ndev, ndev == 1 ? "" : "s");
    for (EGLint k = 0; k < ndev; k++) {
        const char *exts = egl.QueryDeviceStringEXT(dev[k], EGL_EXTENSIONS);
        if (has_ext(exts, "EGL_MESA_device_software"))
            continue;
        char what[32];
        snprintf(what, sizeof what, "device %d", (int)k);
        EGLDisplay dpy = egl.GetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, dev[k], NULL);
        if (egl_context(dpy, what, msg) == 0)
            return 0;
    }
    return -1;
}

static int egl_start(int gpu_only, char *msg)
{
    char why[HC_MAX_MSG] = "hemi-cube: EGL: devices passed over (RADIOSITY_EGL_PLATFORM=surfaceless)";
    const char *platform = getenv("RADIOSITY_EGL_PLATFORM");
    if (!(platform && !strcmp(platform, "surfaceless")) && egl_gpu(why) == 0)
        return 0;
    if (gpu_only) {
        snprintf(msg, HC_MAX_MSG, "%s", why);
        return -1;
    }
    if (!has_ext(egl.QueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS), "EGL_MESA_platform_surfaceless")) {
        snprintf(msg, HC_MAX_MSG, "hemi-cube: EGL: no GPU device and no surfaceless platform "
                 "(EGL_MESA_platform_surfaceless)");
        return -1;
    }
    EGLDisplay dpy = egl.GetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
    return egl_context(dpy, "surfaceless platform", msg);
}

/* EGL 1.5 (and EGL_KHR_get_all_proc_addresses, which Mesa and glvnd offer)
 * answers for core GL entry points as well as extensions. */
static hc_gl_proc egl_proc(const char *name)
{
    return (hc_gl_proc)egl.GetProcAddress(name);
}

const hc_gl_context hc_gl_egl = {egl_library, egl_load, egl_proc, egl_start};
