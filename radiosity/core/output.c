/* output.c - atomic output files (rad.h's rad_output): the one place where
 * the program creates, writes and renames files.
 *
 * Invariant: the target path is touched only by the final rename, after the
 * temporary's bytes are synced; on every failure path the temporary is
 * unlinked, so a crash or an error never leaves a half-written target
 * behind (at worst a stale "PATH.tmp.PID" from a killed process, which the
 * next writer with that pid replaces).
 */
#include "rad.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

struct rad_output {
    int fd;
    uint64_t size;     /* append position */
    int errnum;        /* first write error (0 = none) */
    const char *what;  /* the operation that failed ("write", "sync", ...) */
    char *path;
    char *tmp;
};

int rad_output_open(const char *path, rad_output **out, rad_error *err)
{
    *out = NULL;
    if (!path || !*path)
        return rad_fail(err, RAD_ERR_USAGE, "(no path): empty output path");
    rad_output *o = calloc(1, sizeof *o);
    size_t n = strlen(path) + 32;
    if (o) {
        o->path = strdup(path);
        o->tmp = malloc(n);
    }
    if (!o || !o->path || !o->tmp) {
        if (o) {
            free(o->path);
            free(o->tmp);
        }
        free(o);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: cannot write: out of memory", path);
    }
    snprintf(o->tmp, n, "%s.tmp.%ld", path, (long)getpid());
    o->fd = open(o->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (o->fd < 0 && errno == EEXIST) {
        /* A leftover from an earlier process with our pid: it is ours to replace. */
        unlink(o->tmp);
        o->fd = open(o->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    }
    if (o->fd < 0) {
        int rc = rad_fail(err, RAD_ERR_IO, "%s: cannot create temporary file %s: %s", path,
                          o->tmp, strerror(errno));
        free(o->path);
        free(o->tmp);
        free(o);
        return rc;
    }
    *out = o;
    return RAD_OK;
}

static int write_at(rad_output *o, const uint8_t *p, size_t n, uint64_t at)
{
    if (o->errnum)
        return -1;
    while (n) {
        ssize_t w = pwrite(o->fd, p, n, (off_t)at);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            o->errnum = w < 0 ? errno : ENOSPC;
            o->what = "write";
            return -1;
        }
        p += w;
        n -= (size_t)w;
        at += (uint64_t)w;
    }
    return 0;
}

int rad_output_write(rad_output *o, const void *p, size_t n)
{
    if (write_at(o, p, n, o->size) < 0)
        return -1;
    o->size += n;
    return 0;
}

int rad_output_write_at(rad_output *o, const void *p, size_t n, uint64_t at)
{
    return write_at(o, p, n, at);
}

uint64_t rad_output_size(const rad_output *o) { return o->size; }
const char *rad_output_path(const rad_output *o) { return o->path; }
const char *rad_output_temp(const rad_output *o) { return o->tmp; }

static void release(rad_output *o)
{
    if (o->fd >= 0)
        close(o->fd);
    free(o->path);
    free(o->tmp);
    free(o);
}

void rad_output_abort(rad_output *o)
{
    if (!o)
        return;
    unlink(o->tmp);
    release(o);
}

/* Makes the rename itself durable; a failure here loses nothing already
 * written, so it is not reported. */
static void sync_directory_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    char *dir = slash ? strndup(path, (size_t)(slash - path) + (slash == path)) : strdup(".");
    if (!dir)
        return;
    int fd = open(dir, O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
        fsync(fd);
        close(fd);
    }
    free(dir);
}

int rad_output_commit(rad_output *o, rad_error *err)
{
    if (!o->errnum && fsync(o->fd) < 0) {
        o->errnum = errno;
        o->what = "sync";
    }
    if (!o->errnum) {
        int rc = close(o->fd);
        o->fd = -1;
        if (rc < 0) {
            o->errnum = errno;
            o->what = "close";
        }
    }
    if (!o->errnum && rename(o->tmp, o->path) < 0) {
        int e = errno;
        int rc = rad_fail(err, RAD_ERR_IO, "%s: cannot rename %s to it: %s", o->path, o->tmp,
                          strerror(e));
        rad_output_abort(o);
        return rc;
    }
    if (o->errnum) {
        int rc = rad_fail(err, RAD_ERR_IO, "%s: cannot %s %s: %s", o->path, o->what, o->tmp,
                          strerror(o->errnum));
        rad_output_abort(o);
        return rc;
    }
    sync_directory_of(o->path);
    release(o);
    return RAD_OK;
}
