/* lines.c - a text held in memory, line by line (rad.h, rad_lines): what
 * the three small text formats (polygon file, variations file, camera path)
 * read their input with, each applying its own rules to the lines.
 *
 * Invariant: the lines returned cover text[0..size) in order, each without
 * its '\n', numbered from 1; a line's comment starts at its first '#'; no
 * byte outside the text is read.
 */
#include "rad.h"

void rad_lines_start(rad_lines *r, const char *text, size_t size)
{
    r->p = text;
    r->end = text ? text + size : text;
    r->number = 0;
}

int rad_lines_next(rad_lines *r, rad_line *line)
{
    if (r->p >= r->end)
        return 0;
    const size_t left = (size_t)(r->end - r->p);
    const char *nl = memchr(r->p, '\n', left);
    const size_t length = nl ? (size_t)(nl - r->p) : left;
    const char *hash = memchr(r->p, '#', length);
    *line = (rad_line){.text = r->p,
                       .length = length,
                       .content = hash ? (size_t)(hash - r->p) : length,
                       .number = ++r->number};
    r->p = nl ? nl + 1 : r->end;
    return 1;
}
