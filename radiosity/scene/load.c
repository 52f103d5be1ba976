/* load.c - rad_scene_load: a scene file on disk -> a checked scene.
 *
 * Reads the whole file into memory (refusing more than 1 GiB before
 * allocating it), picks the parser by extension (.gltf/.glb -> glTF, .vs3 ->
 * View3D's input, anything else -> the polygon file), then runs the whole-scene checks.  Invariant: on
 * success the scene has passed rad_scene_validate; on failure *out is NULL
 * and nothing is leaked.
 */
#include "scene.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define MAX_SCENE_FILE (1ull << 30)

static int has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

/* Reads path whole; caller frees *data.  One extra NUL byte is appended for
 * convenience, never counted in *size (the parsers do not rely on it). */
static int read_file(const char *path, char **data, size_t *size, rad_error *err)
{
    *data = NULL;
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return rad_fail(err, RAD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) == 0) {
        if (S_ISDIR(st.st_mode)) {
            fclose(f);
            return rad_fail(err, RAD_ERR_IO, "%s: cannot open: %s", path, strerror(EISDIR));
        }
        if (S_ISREG(st.st_mode) && (unsigned long long)st.st_size > MAX_SCENE_FILE) {
            fclose(f);
            return rad_fail(err, RAD_ERR_LIMIT, "%s: %llu bytes, larger than 1 GiB", path,
                            (unsigned long long)st.st_size);
        }
    }
    /* Read in chunks rather than trusting a seek to the end: the path may be
     * a pipe, and the size may change under us. */
    size_t cap = 0, len = 0;
    char *buf = NULL;
    for (;;) {
        if (len == cap) {
            if (cap >= MAX_SCENE_FILE + 1) {
                free(buf);
                fclose(f);
                return rad_fail(err, RAD_ERR_LIMIT, "%s: larger than %llu bytes (1 GiB)", path,
                                (unsigned long long)MAX_SCENE_FILE);
            }
            size_t nc = cap ? cap * 2 : 65536;
            if (nc > MAX_SCENE_FILE + 1)
                nc = MAX_SCENE_FILE + 1;
            char *nb = realloc(buf, nc + 1);
            if (!nb) {
                free(buf);
                fclose(f);
                return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory reading the file", path);
            }
            buf = nb;
            cap = nc;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) {
            if (ferror(f)) {
                int e = errno;
                free(buf);
                fclose(f);
                return rad_fail(err, RAD_ERR_IO, "%s: cannot read: %s", path,
                                e ? strerror(e) : "read error");
            }
            break;
        }
    }
    fclose(f);
    if (len > MAX_SCENE_FILE) {
        free(buf);
        return rad_fail(err, RAD_ERR_LIMIT, "%s: larger than %llu bytes (1 GiB)", path,
                        (unsigned long long)MAX_SCENE_FILE);
    }
    if (!buf) { /* unreachable: the first pass always allocates */
        buf = malloc(1);
        if (!buf)
            return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", path);
    }
    buf[len] = '\0';
    *data = buf;
    *size = len;
    return RAD_OK;
}

int rad_scene_load(const char *path, const rad_load_options *opt, rad_scene **out,
                   rad_error *err)
{
    if (out)
        *out = NULL;
    if (!path || !out)
        return rad_fail(err, RAD_ERR_USAGE, "rad_scene_load: no path or no output");
    char *data;
    size_t size;
    int rc = read_file(path, &data, &size, err);
    if (rc)
        return rc;
    rad_scene *s = NULL;
    if (has_extension(path, ".gltf") || has_extension(path, ".glb"))
        rc = rad_scene_parse_gltf(data, size, path, opt, &s, err);
    else if (has_extension(path, ".vs3"))
        rc = rad_scene_parse_vs3(data, size, path, opt, &s, err);
    else
        rc = rad_scene_parse_polyfile(data, size, path, opt, &s, err);
    free(data);
    if (rc) {
        rad_scene_destroy(s);
        return rc;
    }
    if ((rc = rad_scene_check(s, !(opt && opt->allow_no_emitter), err))) {
        rad_scene_destroy(s);
        return rc;
    }
    *out = s;
    return RAD_OK;
}

int rad_vs3_load(const char *path, const rad_load_options *opt, rad_scene **scene,
                 rad_vs3 **model, rad_error *err)
{
    *scene = NULL;
    *model = NULL;
    char *data;
    size_t size;
    int rc = read_file(path, &data, &size, err);
    if (rc)
        return rc;
    rc = rad_vs3_parse(data, size, path, opt, scene, model, err);
    free(data);
    if (!rc && (rc = rad_scene_check(*scene, 0, err)) != 0) {
        rad_scene_destroy(*scene);
        rad_vs3_destroy(*model);
        *scene = NULL;
        *model = NULL;
    }
    return rc;
}
