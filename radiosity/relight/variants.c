/* variants.c - the variations file of `radiosity relight --variations`
 * (relight.h, rad_variant; README.md): named variants, each a list
 * of edits in the command line's own syntax (rad_edit_parse), read from a
 * text held in memory line by line (rad_lines).
 *
 * Invariant: a file is taken whole or not at all: every failure is one
 * rad_error "FILE: line N: WHAT" (or "FILE: WHAT" for the whole), with all
 * memory freed and *out NULL.
 */
#include "relight.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void rad_variants_free(rad_variant *v, uint32_t count)
{
    if (!v)
        return;
    for (uint32_t i = 0; i < count; i++)
        free(v[i].edits);
    free(v);
}

/* The line's content (comment cut off) into buf, trimmed; 1 when it does
 * not fit (then cut to bufsize - 1 bytes, before trimming). */
static int line_text(const rad_line *ln, char *buf, size_t bufsize)
{
    size_t len = ln->content;
    const int too_long = len >= bufsize;
    if (too_long)
        len = bufsize - 1;
    memcpy(buf, ln->text, len);
    buf[len] = '\0';
    while (len && isspace((unsigned char)buf[len - 1]))
        buf[--len] = '\0';
    size_t lead = 0;
    while (buf[lead] && isspace((unsigned char)buf[lead]))
        lead++;
    memmove(buf, buf + lead, len - lead + 1);
    return too_long;
}

int rad_variants_parse(const char *text, size_t size, const char *name, rad_variant **out,
                       uint32_t *count, rad_error *err)
{
    *out = NULL;
    *count = 0;
    rad_variant *v = NULL;
    uint32_t nv = 0, cap = 0;
    int open = 0, rc = RAD_OK;
    rad_lines lines;
    rad_line ln;
    char buf[1024];
    rad_lines_start(&lines, text, size);
    while (!rc && rad_lines_next(&lines, &ln)) {
        const unsigned line = (unsigned)ln.number;
        if (line_text(&ln, buf, sizeof buf)) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: line too long", name, line);
            break;
        }
        if (!buf[0])
            continue;
        char word[32], arg[1024];
        int fields = sscanf(buf, "%31s %1023s", word, arg);
        char rest[8];
        if (fields == 2 && sscanf(buf, "%*s %*s %7s", rest) == 1) {
            rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: unexpected '%s'", name, line, rest);
            break;
        }
        if (strcmp(word, "variant") == 0) {
            if (open) {
                rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: 'variant' inside variant '%s' (missing 'end')",
                              name, line, v[nv - 1].name);
                break;
            }
            if (fields != 2 || strlen(arg) >= sizeof v->name) {
                rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: expected 'variant NAME'", name, line);
                break;
            }
            for (uint32_t k = 0; k < nv; k++)
                if (strcmp(v[k].name, arg) == 0)
                    rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: variant '%s' defined twice", name,
                                  line, arg);
            for (const char *c = arg; *c && !rc; c++)
                if (!isalnum((unsigned char)*c) && *c != '_' && *c != '-' && *c != '.')
                    rc = rad_fail(err, RAD_ERR_PARSE,
                                  "%s: line %u: variant name '%s' may hold only letters, digits, '_', '-', '.'",
                                  name, line, arg);
            if (rc)
                break;
            if (nv == cap) {
                uint32_t nc = cap ? cap * 2 : 8;
                rad_variant *nvp = nc > 100000 ? NULL : realloc(v, nc * sizeof *v);
                if (!nvp) {
                    rc = rad_fail(err, RAD_ERR_LIMIT, "%s: line %u: too many variants", name, line);
                    break;
                }
                v = nvp;
                cap = nc;
            }
            memset(&v[nv], 0, sizeof v[nv]);
            memcpy(v[nv].name, arg, strlen(arg) + 1); /* length checked above */
            nv++;
            open = 1;
        } else if (strcmp(word, "end") == 0 && fields == 1) {
            if (!open) {
                rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: 'end' without 'variant'", name, line);
                break;
            }
            open = 0;
        } else if (strcmp(word, "light") == 0 || strcmp(word, "emission") == 0 ||
                   strcmp(word, "reflectance") == 0) {
            if (!open || fields != 2) {
                rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: '%s' must stand inside a variant as '%s NAME=VALUE'",
                              name, line, word, word);
                break;
            }
            rad_variant *cur = &v[nv - 1];
            if (cur->edit_count >= 4096) {
                rc = rad_fail(err, RAD_ERR_LIMIT, "%s: line %u: too many edits", name, line);
                break;
            }
            rad_edit *ne = realloc(cur->edits, (cur->edit_count + 1) * sizeof *ne);
            if (!ne) {
                rc = rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", name);
                break;
            }
            cur->edits = ne;
            rad_edit_kind kind = word[0] == 'l' ? RAD_EDIT_LIGHT
                                 : word[0] == 'e' ? RAD_EDIT_EMISSION : RAD_EDIT_REFLECTANCE;
            rad_error e2;
            if (rad_edit_parse(kind, arg, &cur->edits[cur->edit_count], &e2)) {
                rc = rad_fail(err, RAD_ERR_PARSE, "%s: line %u: %s", name, line, e2.message);
                break;
            }
            cur->edit_count++;
        } else {
            rc = rad_fail(err, RAD_ERR_PARSE,
                          "%s: line %u: unknown statement '%s' (expected variant, light, emission, "
                          "reflectance or end)",
                          name, line, word);
        }
    }
    if (!rc && open)
        rc = rad_fail(err, RAD_ERR_PARSE, "%s: variant '%s' has no 'end'", name, v[nv - 1].name);
    if (!rc && nv == 0)
        rc = rad_fail(err, RAD_ERR_PARSE, "%s: no variants", name);
    if (rc) {
        rad_variants_free(v, nv);
        return rc;
    }
    *out = v;
    *count = nv;
    return RAD_OK;
}
