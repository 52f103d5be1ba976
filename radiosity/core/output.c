/* output.c - atomic output files (rad.h's rad_output): the one place where
 * the program creates, writes and renames files.
 *
 * Invariant: the target path is touched only by the final rename, after the
 * temporary's bytes are synced; on every failure path the temporary is
 * unlinked, so a crash or an error never leaves a half-written target
 * behind (at worst a stale "PATH.tmp.PID" from a killed process, which the
 * next writer with that pid replaces).
 *
 * A partial output ("PATH.partial", rad_output_open_partial) is the one
 * exception to "nothing survives a failure": it holds work a later run can
 * continue (a solve's rows), so every failure keeps it, an exclusive lock
 * keeps two processes from appending to it at once, and only a successful
 * commit moves it onto PATH.
 */
#include "rad.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

struct rad_output {
    int fd;
    uint64_t size;     /* append position */
    int errnum;        /* first write error (0 = none) */
    const char *what;  /* the operation that failed ("write", "sync", ...) */
    char *path;
    char *tmp;
    int partial;       /* "PATH.partial": kept on every failure, for the next run */
};

static void release(rad_output *o);
static void sync_directory_of(const char *path);

/* A rad_output for path with its temporary's name made by `suffix`
 * ("%s.tmp.%ld" of path and pid, or "%s.partial"), no file yet. */
static int output_new(const char *path, int partial, rad_output **out, rad_error *err)
{
    *out = NULL;
    if (!path || !*path)
        return rad_fail(err, RAD_ERR_USAGE, "(no path): empty output path");
    rad_output *o = calloc(1, sizeof *o);
    size_t n = strlen(path) + 32;
    if (o) {
        o->path = strdup(path);
        o->tmp = malloc(n);
        o->fd = -1;
        o->partial = partial;
    }
    if (!o || !o->path || !o->tmp) {
        if (o) {
            free(o->path);
            free(o->tmp);
        }
        free(o);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: cannot write: out of memory", path);
    }
    if (partial)
        snprintf(o->tmp, n, "%s.partial", path);
    else
        snprintf(o->tmp, n, "%s.tmp.%ld", path, (long)getpid());
    *out = o;
    return RAD_OK;
}

int rad_output_open(const char *path, rad_output **out, rad_error *err)
{
    rad_output *o;
    int rc0 = output_new(path, 0, &o, err);
    *out = NULL;
    if (rc0)
        return rc0;
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

int rad_output_open_partial(const char *path, rad_output **out, uint64_t *size, rad_error *err)
{
    rad_output *o;
    int rc = output_new(path, 1, &o, err);
    *out = NULL;
    *size = 0;
    if (rc)
        return rc;
    o->fd = open(o->tmp, O_RDWR | O_CREAT | O_CLOEXEC, 0666);
    if (o->fd < 0) {
        rc = rad_fail(err, RAD_ERR_IO, "%s: cannot create %s: %s", path, o->tmp, strerror(errno));
        release(o);
        return rc;
    }
    /* Two runs appending to one file would interleave their rows. */
    if (flock(o->fd, LOCK_EX | LOCK_NB) < 0) {
        int e = errno;
        rc = e == EWOULDBLOCK
                 ? rad_fail(err, RAD_ERR_IO, "%s: %s is being written by another process", path,
                            o->tmp)
                 : rad_fail(err, RAD_ERR_IO, "%s: cannot lock %s: %s", path, o->tmp, strerror(e));
        release(o);
        return rc;
    }
    struct stat st;
    if (fstat(o->fd, &st) < 0 || !S_ISREG(st.st_mode)) {
        rc = rad_fail(err, RAD_ERR_IO, "%s: %s is not a regular file", path, o->tmp);
        release(o);
        return rc;
    }
    o->size = *size = (uint64_t)st.st_size;
    *out = o;
    return RAD_OK;
}

int rad_output_read_at(rad_output *o, void *p, size_t n, uint64_t at)
{
    uint8_t *b = p;
    while (n) {
        ssize_t r = pread(o->fd, b, n, (off_t)at);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            return -1;
        b += r;
        n -= (size_t)r;
        at += (uint64_t)r;
    }
    return 0;
}

int rad_output_truncate(rad_output *o, uint64_t size)
{
    if (o->errnum)
        return -1;
    if (ftruncate(o->fd, (off_t)size) < 0) {
        o->errnum = errno;
        o->what = "truncate";
        return -1;
    }
    o->size = size;
    return 0;
}

int rad_output_sync(rad_output *o)
{
    if (o->errnum)
        return -1;
    if (fdatasync(o->fd) < 0) {
        o->errnum = errno;
        o->what = "sync";
        return -1;
    }
    return 0;
}

int rad_output_error(const rad_output *o, rad_error *err)
{
    if (!o->errnum)
        return RAD_OK;
    return rad_fail(err, RAD_ERR_IO, "%s: cannot %s %s: %s", o->path, o->what, o->tmp,
                    strerror(o->errnum));
}

void rad_output_drop(rad_output *o)
{
    if (!o)
        return;
    unlink(o->tmp);
    release(o);
}

void rad_output_keep(rad_output *o)
{
    if (o)
        release(o);
}

int rad_output_link(const char *existing, const char *path, rad_error *err)
{
    rad_output *o;
    int rc = output_new(path, 0, &o, err);
    if (rc)
        return rc;
    unlink(o->tmp); /* a leftover of an earlier process with our pid */
    if (link(existing, o->tmp) < 0) {
        int e = errno;
        rc = rad_fail(err, RAD_ERR_IO, "%s: cannot link %s to it: %s", path, existing, strerror(e));
        release(o);
        return rc;
    }
    /* rename onto another name of the same file would do nothing and
     * leave the temporary: then the link is already there */
    struct stat a, b;
    if (stat(o->tmp, &a) == 0 && stat(path, &b) == 0 && a.st_dev == b.st_dev &&
        a.st_ino == b.st_ino) {
        unlink(o->tmp);
    } else if (rename(o->tmp, path) < 0) {
        int e = errno;
        rc = rad_fail(err, RAD_ERR_IO, "%s: cannot rename %s to it: %s", path, o->tmp, strerror(e));
        unlink(o->tmp);
        release(o);
        return rc;
    }
    sync_directory_of(path);
    release(o);
    return RAD_OK;
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
    if (!o->partial)
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

/* ------------------------------------------------------------ committer */

/* Invariant: outputs are committed in the order handed over; `rc`/`err`
 * hold the first failure; everything under `lock` but the commits. */
struct rad_committer {
    pthread_t thread;
    pthread_mutex_t lock;
    pthread_cond_t cond;
    rad_output **queue; /* [head, tail) waiting */
    size_t head, tail, cap;
    int closing;        /* finish called: drain and stop */
    int rc;
    rad_error err;
};

static void *committer_main(void *arg)
{
    rad_committer *c = arg;
    pthread_mutex_lock(&c->lock);
    for (;;) {
        while (c->head == c->tail && !c->closing)
            pthread_cond_wait(&c->cond, &c->lock);
        if (c->head == c->tail)
            break;
        rad_output *o = c->queue[c->head++];
        pthread_mutex_unlock(&c->lock);
        rad_error e = {0};
        int rc = rad_output_commit(o, &e);
        pthread_mutex_lock(&c->lock);
        if (rc && !c->rc) {
            c->rc = rc;
            c->err = e;
        }
    }
    pthread_mutex_unlock(&c->lock);
    return NULL;
}

int rad_committer_create(rad_committer **out, rad_error *err)
{
    *out = NULL;
    rad_committer *c = calloc(1, sizeof *c);
    if (!c)
        return rad_fail(err, RAD_ERR_NOMEM, "output: out of memory for a committer");
    pthread_mutex_init(&c->lock, NULL);
    pthread_cond_init(&c->cond, NULL);
    if (pthread_create(&c->thread, NULL, committer_main, c) != 0) {
        pthread_cond_destroy(&c->cond);
        pthread_mutex_destroy(&c->lock);
        free(c);
        return rad_fail(err, RAD_ERR_NOMEM, "output: cannot start a committer thread");
    }
    *out = c;
    return RAD_OK;
}

int rad_output_commit_later(rad_output *o, rad_committer *c, rad_error *err)
{
    if (!c)
        return rad_output_commit(o, err);
    pthread_mutex_lock(&c->lock);
    if (c->tail == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 16;
        rad_output **q = realloc(c->queue, cap * sizeof *q);
        if (!q) {
            pthread_mutex_unlock(&c->lock);
            return rad_output_commit(o, err);
        }
        c->queue = q;
        c->cap = cap;
    }
    c->queue[c->tail++] = o;
    pthread_cond_signal(&c->cond);
    pthread_mutex_unlock(&c->lock);
    return RAD_OK;
}

int rad_committer_finish(rad_committer *c, rad_error *err)
{
    if (!c)
        return RAD_OK;
    pthread_mutex_lock(&c->lock);
    c->closing = 1;
    pthread_cond_signal(&c->cond);
    pthread_mutex_unlock(&c->lock);
    pthread_join(c->thread, NULL);
    const int rc = c->rc;
    if (rc && err)
        *err = c->err;
    pthread_cond_destroy(&c->cond);
    pthread_mutex_destroy(&c->lock);
    free(c->queue);
    free(c);
    return rc;
}
