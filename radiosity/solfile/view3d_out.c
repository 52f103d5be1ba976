/* view3d_out.c - View3D 4.0's text view-factor file (docs/view3d.md), so a
 * workflow that reads View3D's output can read the engine's:
 *
 *   line 1      "View3D 4.0 0 ENCL EMIT N", padded with blanks to 30 bytes
 *               (version, out = 0 for text, the controls, reported surfaces)
 *   line 2      the N areas
 *   lines 3..   the N rows of F_ij (script-F with emit = 1), 6 decimals
 *   last line   the N emittances, 3 decimals
 *
 * Invariant: the file is written to a temporary and renamed (rad_output),
 * so a failure leaves no partial file.
 */
#include "solfile.h"

#include <stdio.h>
#include <string.h>

/* Appends printf-formatted text; -1 once a write failed. */
static int put(rad_output *o, const char *fmt, double v)
{
    char b[64];
    int len = snprintf(b, sizeof b, fmt, v);
    if (len < 0 || (size_t)len >= sizeof b) /* no value here needs 64 bytes; never overrun */
        len = len < 0 ? 0 : (int)sizeof b - 1;
    return rad_output_write(o, b, (size_t)len);
}

static int put_values(rad_output *o, const double *v, uint32_t n, size_t stride, const char *fmt)
{
    int bad = 0;
    for (uint32_t i = 0; i < n; i++) {
        bad |= i ? rad_output_write(o, " ", 1) : 0;
        bad |= put(o, fmt, v[(size_t)i * stride]);
    }
    return bad | rad_output_write(o, "\n", 1);
}

int rad_view3d_write(const char *path, const rad_vs3 *m, const rad_vs3_factors *f,
                     rad_error *err)
{
    rad_output *o;
    int rc = rad_output_open(path, &o, err);
    if (rc)
        return rc;
    char head[64];
    int len = snprintf(head, sizeof head, "View3D 4.0 0 %d %d %u", m->encl, f->script, f->n);
    while (len < 30)
        head[len++] = ' ';
    head[len++] = '\n';
    int bad = rad_output_write(o, head, (size_t)len);
    bad |= put_values(o, f->area, f->n, 1, "%g");
    for (uint32_t i = 0; i < f->n; i++)
        bad |= put_values(o, f->F + (size_t)i * f->n, f->n, 1, "%.6f");
    bad |= put_values(o, f->emittance, f->n, 1, "%.3f");
    (void)bad; /* rad_output_commit reports the first failed write */
    return rad_output_commit(o, err);
}
