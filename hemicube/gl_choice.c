/* gl_choice.c - which GL back end draws the hemi-cubes: hc_gl_choose, and
 * the settling of hc_options.gl before hc_create forks its workers.
 *
 * The caller's process never loads a GL library (see gl.c), so whether EGL
 * starts, and on what, is asked of a child process forked for the purpose:
 * it starts the back end exactly as a worker would (hc_gl_probe), sends back
 * its GL_RENDERER or its error text over a pipe and exits.  A GPU is an
 * EGL device whose renderer is not Mesa's software rasteriser.
 *
 * Invariant: a settled choice is HC_GL_OSMESA or HC_GL_EGL, never
 * HC_GL_AUTO; the probe child is always reaped before a call returns.
 */
#include "hc_internal.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

/* What the probe child sends: 0 and the renderer, or -1 and the reason. */
typedef struct hc_probe_answer {
    int rc;
    char renderer[128];
    char msg[HC_MAX_MSG];
} hc_probe_answer;

/* Reads the whole answer (short when the child died first); the bytes read. */
static size_t read_answer(int fd, hc_probe_answer *a)
{
    size_t got = 0;
    while (got < sizeof *a) {
        ssize_t r = read(fd, (char *)a + got, sizeof *a - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            break;
        got += (size_t)r;
    }
    return got;
}

/* Starts EGL in a child process (gpu_only: a GPU device or fail); 0 with
 * a->renderer, or -1 with a->msg. */
static int probe_egl(int gpu_only, hc_probe_answer *a)
{
    *a = (hc_probe_answer){.rc = -1};
    int fd[2];
    if (pipe(fd) != 0) {
        snprintf(a->msg, sizeof a->msg, "hemi-cube: EGL probe: pipe: %s", strerror(errno));
        return -1;
    }
    fflush(NULL); /* nothing the caller printed may appear twice */
    pid_t pid = fork();
    if (pid == 0) {
        close(fd[0]);
        hc_probe_answer mine = {0};
        mine.rc = hc_gl_probe(&hc_gl_egl, gpu_only, mine.renderer, sizeof mine.renderer, mine.msg);
        ssize_t w = write(fd[1], &mine, sizeof mine);
        _exit(w == (ssize_t)sizeof mine ? 0 : 1);
    }
    close(fd[1]);
    if (pid < 0) {
        close(fd[0]);
        snprintf(a->msg, sizeof a->msg, "hemi-cube: EGL probe: fork: %s", strerror(errno));
        return -1;
    }
    size_t got = read_answer(fd[0], a);
    close(fd[0]);
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR)
        ;
    if (got != sizeof *a) {
        *a = (hc_probe_answer){.rc = -1};
        if (WIFSIGNALED(st))
            snprintf(a->msg, sizeof a->msg, "hemi-cube: EGL stopped the probe process with "
                     "signal %d while starting", WTERMSIG(st));
        else
            snprintf(a->msg, sizeof a->msg, "hemi-cube: the EGL probe process exited before "
                     "answering");
        return -1;
    }
    a->renderer[sizeof a->renderer - 1] = a->msg[sizeof a->msg - 1] = '\0';
    return a->rc == 0 ? 0 : -1;
}

static int software(const char *renderer)
{
    return strstr(renderer, "llvmpipe") || strstr(renderer, "softpipe") ||
           strstr(renderer, "swrast");
}

int hc_gl_choose(hc_gl_kind want, hc_gl_choice *out, rad_error *err)
{
    if (!out)
        return rad_fail(err, RAD_ERR_USAGE, "hc_gl_choose: out must not be NULL");
    *out = (hc_gl_choice){.kind = HC_GL_OSMESA};
    if (!hc_gl_name(want))
        return rad_fail(err, RAD_ERR_USAGE, "hc_gl_choose: GL back end %d: not osmesa, egl or auto",
                        (int)want);
    if (want == HC_GL_OSMESA)
        return RAD_OK;
    hc_probe_answer a;
    int rc = probe_egl(want == HC_GL_AUTO, &a);
    if (want == HC_GL_EGL) {
        if (rc != 0)
            return rad_fail(err, RAD_ERR_GL, "%s", a.msg);
        out->kind = HC_GL_EGL;
        snprintf(out->renderer, sizeof out->renderer, "%s", a.renderer);
        return RAD_OK;
    }
    if (rc == 0 && !software(a.renderer)) {
        out->kind = HC_GL_EGL;
        snprintf(out->renderer, sizeof out->renderer, "%s", a.renderer);
    } else if (rc == 0) {
        snprintf(out->reason, sizeof out->reason, "EGL's device renders with %s, not a GPU",
                 a.renderer);
    } else {
        snprintf(out->reason, sizeof out->reason, "%s", a.msg);
    }
    return RAD_OK;
}

int hc_gl_settle(hc_options *o, rad_error *err)
{
    if (o->gl != HC_GL_AUTO && hc_gl_name(o->gl))
        return RAD_OK;
    hc_gl_choice c;
    int rc = hc_gl_choose(o->gl, &c, err);
    o->gl = c.kind;
    return rc;
}

static const char *const hc_gl_names[] = {"osmesa", "egl", "auto"};

const char *hc_gl_name(hc_gl_kind kind)
{
    return (unsigned)kind < sizeof hc_gl_names / sizeof *hc_gl_names ? hc_gl_names[kind] : NULL;
}

int hc_gl_parse(const char *name, hc_gl_kind *out)
{
    for (unsigned k = 0; name && k < sizeof hc_gl_names / sizeof *hc_gl_names; k++)
        if (!strcmp(name, hc_gl_names[k])) {
            *out = (hc_gl_kind)k;
            return 0;
        }
    return -1;
}
