/* main.c - the `radiosity` command: its usage text, and the dispatch of
 * COMMAND to the file of that command (cli_<command>.c; cli.h maps the
 * rest).  Only the program in radiosity/cli/ prints or exits; nothing
 * else in the project does.
 *
 *   radiosity solve    SCENE -o SOLUTION [options] [--fresh]
 *   radiosity render   SOLUTION -o IMAGE.exr [--png FILE] [camera options] [--gather ...]
 *   radiosity render   SOLUTION -o DIR --all-cameras | --camera A,B | --path FILE
 *   radiosity report   SOLUTION [--json]
 *   radiosity relight  SOLUTION -o OUT [--light N=off|on|S] [--emission N=v,..]
 *                      [--reflectance N=v,..] [--variations FILE [--render]]
 *   radiosity ff       SCENE_OR_SOLUTION --from A --to B [--json] [--matrix]
 *   radiosity validate [--json] [--quick]
 *   radiosity export   SOLUTION -o DIR
 *   radiosity bake     SOLUTION -o OUT.glb|OUT.gltf [--exposure EV]
 *
 * Errors print one line "radiosity: error: FILE: WHERE: WHAT" and exit 2 for
 * bad input or usage, 1 for failures of the machine (memory, GL).  Outputs
 * are written through temporary files, so an error never leaves a partial
 * file.  Invariant: main calls the commands and the shared files; nothing
 * calls back into main.c.
 */
#include "cli.h"

#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------------- help */

static const char usage[] =
    "usage: radiosity COMMAND [options]\n"
    "\n"
    "commands:\n"
    "  solve SCENE -o SOLUTION      load, mesh, form factors, solve, store\n"
    "      --patch-size S           target patch edge length (scene units)\n"
    "      --resolution R           hemi-cube resolution (default " CLI_STR(HC_DEFAULT_RESOLUTION) ")\n"
    "      --processes P            form-factor worker processes (default: CPUs)\n"
    "      --gl osmesa|egl|auto     the workers' GL: OSMesa (default), EGL (a GPU, else\n"
    "                               surfaceless llvmpipe), auto (a GPU, else OSMesa);\n"
    "                               also for relight, ff and validate\n"
    "      --solver NAME            gauss-seidel (default), jacobi, progressive\n"
    "      --tolerance T            solver tolerance (default " CLI_STR(SV_DEFAULT_TOLERANCE) ")\n"
    "      --max-iterations N       solver iteration limit\n"
    "      --max-patches N          refuse a mesh of more than N patches (default 2 million)\n"
    "      --max-memory SIZE        limit for the form-factor matrix (e.g. 4G); progressive\n"
    "                               keeps its rows within it, computing some again\n"
    "      --pixel-emitters         form factors to emitters by pixel counts, not exactly\n"
    "      --exact-near             near patches (closer than their size) exactly (default)\n"
    "      --pixel-near             near patches by pixel counts, like the others\n"
    "      --accuracy A             default: thin far surfaces and nearly touching pairs\n"
    "                               exactly; high: every patch within 20 patch diameters\n"
    "                               area-averaged (0.1 %, 1-3x the time); pixels:\n"
    "                               neither (docs/limits.md; ff's default area-averages\n"
    "                               more pairs than solve's, as F_AB is an area mean)\n"
    "      --strict                 glTF: refuse reflectance >= 1, primitives without a\n"
    "                               material or area, unreadable textures (default: clamp\n"
    "                               to 0.95, glTF's default material, skip, warn)\n"
    "      --refine-threshold T     elements: split where the drawn B misses the B of the\n"
    "                               element's four children by more than T × the brightest\n"
    "                               reflecting patch's B, weighted by area (default "
    CLI_STR(RAD_DEFAULT_REFINE_THRESHOLD) "; 0: no elements)\n"
    "      --element-hemicubes      every element's row from a hemi-cube of its own (slow)\n"
    "      --whole-contacts         elements where surfaces meet: a whole hemi-cube each,\n"
    "                               not a near view and the patch's far field (slower)\n"
    "      --min-element-size S     smallest element edge (default: 1/8 of its patch)\n"
    "      --element-levels L       uniform elements: split every patch L times\n"
    "      --preview-every K|Ts     progressive: write a preview image every K shots or\n"
    "                               every T seconds of solving (e.g. 2s); --camera NAME,\n"
    "                               --size WxH, --exposure EV as for render\n"
    "      --preview-dir DIR        where previews go (default: the solution's directory)\n"
    "      --fresh                  compute every row again: do not resume from the rows an\n"
    "                               interrupted run kept in SOLUTION.partial\n"
    "  render SOLUTION -o IMAGE.exr draw a view (radiance, linear OpenEXR)\n"
    "      --png FILE               also write an sRGB PNG preview\n"
    "      --exposure EV            PNG exposure in stops (default 0)\n"
    "      --ids FILE               the objects of the item buffer as a 16-bit PGM (0: none)\n"
    "      --exr-compression C      none (default), zip, rle or piz: zip: files\n"
    "                               15 % smaller, a 1024x1024 view 5x the CPU\n"
    "      --camera NAME            a camera of the scene (default: the first)\n"
    "      --eye X,Y,Z --target X,Y,Z --up X,Y,Z --fov DEG   an explicit camera\n"
    "      --ortho H                orthographic, a view 2H high (scene units)\n"
    "      --size WxH               image size (default 512x512)\n"
    "  render SOLUTION -o DIR VIEWS many views from one load, on every CPU: DIR/NAME.exr\n"
    "                               and DIR/NAME.png for each (DIR made if missing)\n"
    "      --all-cameras            every camera of the scene (NAME: the camera's)\n"
    "      --camera A,B,C           these cameras (or --camera repeated)\n"
    "      --path FILE              a fly-through, one view per line (NAME: frame-0001..):\n"
    "                               eye X,Y,Z target X,Y,Z [up X,Y,Z] [fov DEG]\n"
    "      --threads N              drawing threads (default: CPUs), or shading\n"
    "                               threads with --gather (default: CPUs)\n"
    "      --no-png                 EXR only\n"
    "      --gather                 ray-trace the view from the solution (final gather):\n"
    "                               direct light per pixel, indirect gathered from the\n"
    "                               stored B through Ward's irradiance cache, glossy lobes\n"
    "      --epsilon A              cache error bound a (default " CLI_STR(RN_DEFAULT_EPSILON) ")\n"
    "      --no-cache               gather at every pixel (the reference; slow)\n"
    "      --cache FILE             the cache file (default SOLUTION.icache)\n"
    "      --no-cache-file          neither read nor write a cache file\n"
    "      --no-gradients           cache without Ward & Heckbert's gradients\n"
    "      --gather-rays N          hemisphere rays per gather (default " CLI_STR(RN_DEFAULT_GATHER_RAYS) ")\n"
    "      --light-samples N        samples per area light and pixel (default " CLI_STR(RN_DEFAULT_LIGHT_SAMPLES) ")\n"
    "      --glossy-rays N          lobe samples per glossy pixel (default " CLI_STR(RN_DEFAULT_GLOSSY_RAYS) ")\n"
    "      --glossy MODE            auto, sample or light-vector (indirect light on lobes)\n"
    "      --max-depth D            mirror reflections followed (default " CLI_STR(RN_DEFAULT_MAX_DEPTH) ")\n"
    "      --min-radius PX          smallest valid radius of a cache record, pixels (default " CLI_STR(RN_DEFAULT_MIN_RADIUS_PX) ")\n"
    "  report SOLUTION [--json]     per-object power balance, solver and stage times\n"
    "  relight SOLUTION -o OUT      re-solve with changed lights or colours, no new hemi-cubes\n"
    "      --light NAME=off|on|S    switch or scale an emitting object, punctual light or material\n"
    "      --emission NAME=V[,V..]  set emission (one value per band, or one for all)\n"
    "      --reflectance NAME=V[,V..] set reflectance\n"
    "      --variations FILE        run each variant of FILE; OUT is a directory\n"
    "      --render                 with --variations: write NAME.exr/.png, not NAME.sol\n"
    "  ff SCENE_OR_SOLUTION --from A --to B [--json] | --matrix\n"
    "                               object-to-object form factors\n"
    "  ff FILE.vs3 [--matrix] [--view3d OUT] [--pixel-factors]\n"
    "                               View3D's surface factors (docs/view3d.md): the matrix\n"
    "                               (script-F when emit=1), View3D 4.0's output file\n"
    "  validate [--json] [--quick]  form factors against analytic catalog values\n"
    "      --catalog                the closed-form pairs of issue 39 (squares, strips,\n"
    "                               plates, disks, boxes, offset rectangles) as ff computes\n"
    "                               them; --accuracy default|high\n"
    "  export SOLUTION -o DIR       open data: DIR/patches.csv (ρ, E, B per patch), F.mtx\n"
    "                               (Matrix Market), elements.csv and elements-F.mtx\n"
    "                               (docs/export.md; DIR made if missing)\n"
    "  bake SOLUTION -o OUT.glb     the solved light as glTF 2.0 (.glb, or .gltf + .bin) for\n"
    "                               any viewer (docs/bake.md); --exposure EV (default: auto)\n"
    "\n"
    "  --help                       this text (man radiosity: the manual)\n"
    "  --version                    the program's version and the solution-file\n"
    "                               versions it writes and reads\n";

/* main itself is program.c's (radiosity) or program_mpi.c's (radiosity-mpi). */
int cli_main(int argc, char **argv)
{
    if (argc < 2)
        return cli_usage_error("no command given");
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
        fputs(usage, stdout);
        return 0;
    }
    if (!strcmp(cmd, "--version")) {
        printf("radiosity %s\n", RAD_VERSION_STRING);
        printf("solution files: writes version %u, reads versions %u to %u\n",
               RAD_SOLFILE_VERSION, RAD_SOLFILE_OLDEST_VERSION, RAD_SOLFILE_VERSION);
        return 0;
    }
    if (!strcmp(cmd, "solve"))
        return cli_solve(argc - 2, argv + 2);
    if (!strcmp(cmd, "render"))
        return cli_render(argc - 2, argv + 2);
    if (!strcmp(cmd, "report"))
        return cli_report(argc - 2, argv + 2);
    if (!strcmp(cmd, "relight"))
        return cli_relight(argc - 2, argv + 2);
    if (!strcmp(cmd, "ff"))
        return cli_ff(argc - 2, argv + 2);
    if (!strcmp(cmd, "validate"))
        return cli_validate(argc - 2, argv + 2);
    if (!strcmp(cmd, "export"))
        return cli_export(argc - 2, argv + 2);
    if (!strcmp(cmd, "bake"))
        return cli_bake(argc - 2, argv + 2);
    return cli_usage_error("unknown command '%s'", cmd);
}
