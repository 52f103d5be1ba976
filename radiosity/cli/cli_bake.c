/* cli_bake.c - the bake command: a stored solution written as glTF 2.0
 * (rad_bake_write), the light in its vertices, for viewers that have no
 * light of their own.  The solution is read as render reads it (without F),
 * and the exposure used is printed so that `render --exposure EV` shows
 * the same picture.  Calls only the shared files (cli_args.c, cli_print.c).
 */
#include "cli.h"

#include "../bake/bake.h"

#include <stdio.h>
#include <string.h>

/* bake SOLUTION -o OUT.glb|OUT.gltf [--exposure EV] */
int cli_bake(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    rad_bake_options opt = {0};
    int rc;
    for (int i = 0; i < argc; i++) {
        const char *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(argv[i], "-o") && val) {
            out = val;
            i++;
        } else if (!strcmp(argv[i], "--exposure")) {
            if (cli_parse_double(argv[i], val, -64, 64, &opt.exposure))
                return 2;
            opt.exposure_given = 1;
            i++;
        } else if ((rc = cli_other_arg("bake", "solution", argv[i], &in)) != 0) {
            return rc;
        }
    }
    if (!in || !out)
        return cli_usage_error("usage: radiosity bake SOLUTION -o OUT.glb|OUT.gltf [--exposure EV]");
    if (cli_check_output_dir(out))
        return 2;
    rad_error err = {0};
    rad_solution *s = NULL;
    if (rad_solution_read_parts(in, 0, &s, &err))
        return cli_error(&err);
    rad_bake_stats st;
    double t0 = rad_seconds();
    rc = rad_bake_write(s, out, &opt, &st, &err);
    rad_solution_destroy(s);
    if (rc)
        return cli_error(&err);
    printf("%s: %llu vertices, %llu triangles, %u primitives, %u cameras, %llu bytes "
           "(%.1f per vertex + 12 per triangle), exposure %.2f EV%s, %.3f s\n",
           out, (unsigned long long)st.vertices, (unsigned long long)st.triangles, st.primitives,
           st.cameras, (unsigned long long)st.bytes,
           st.vertices ? (double)(st.bytes - 12 * st.triangles) / (double)st.vertices : 0.0,
           st.exposure, opt.exposure_given ? "" : " (automatic)", rad_seconds() - t0);
    return 0;
}
