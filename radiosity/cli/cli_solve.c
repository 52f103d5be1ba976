/* cli_solve.c - the solve, render and report commands: a scene becomes a
 * stored solution, a solution becomes images, and a solution's numbers are
 * printed as text or JSON.
 */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ views */

int cli_view_option(int argc, char **argv, int *i, cli_view *v)
{
    const char *a = argv[*i];
    const char *val = *i + 1 < argc ? argv[*i + 1] : NULL;
    int rc = 0;
    if (!strcmp(a, "--camera")) {
        if (!val)
            return cli_usage_error("--camera needs a name"), -1;
        v->camera = val;
    } else if (!strcmp(a, "--eye")) {
        rc = cli_parse_vec3(a, val, &v->eye), v->have_eye = 1;
    } else if (!strcmp(a, "--target")) {
        rc = cli_parse_vec3(a, val, &v->target), v->have_target = 1;
    } else if (!strcmp(a, "--up")) {
        rc = cli_parse_vec3(a, val, &v->up), v->have_up = 1;
    } else if (!strcmp(a, "--fov")) {
        rc = cli_parse_double(a, val, 0.01, 179.99, &v->fov), v->have_fov = 1;
    } else if (!strcmp(a, "--size")) {
        unsigned w, h;
        char tail;
        if (!val || sscanf(val, "%ux%u%c", &w, &h, &tail) != 2 || w < 1 || h < 1 || w > 16384 ||
            h > 16384)
            return cli_usage_error("--size: '%s' is not WxH (1..16384 each)", val ? val : ""), -1;
        v->width = w, v->height = h;
    } else if (!strcmp(a, "--png")) {
        if (!val)
            return cli_usage_error("--png needs a file name"), -1;
        v->png = val;
    } else if (!strcmp(a, "--exposure")) {
        rc = cli_parse_double(a, val, -64, 64, &v->exposure);
    } else {
        return 0;
    }
    if (rc)
        return -1;
    (*i)++;
    return 1;
}

int cli_render_to_files(const rad_solution *s, const cli_view *v, const char *exr_path,
                        const char *png_path)
{
    rad_error err = {0};
    rn_camera cam;
    uint32_t w = v->width ? v->width : 512, h = v->height ? v->height : 512;
    if (v->have_eye || v->have_target) {
        if (!v->have_eye || !v->have_target)
            return cli_usage_error("--eye and --target go together");
        if (v->camera)
            return cli_usage_error("--camera and --eye/--target exclude each other");
        cam = (rn_camera){.eye = v->eye, .target = v->target,
                          .up = v->have_up ? v->up : rad_v3(0, 1, 0),
                          .yfov_deg = v->have_fov ? v->fov : 45.0, .width = w, .height = h};
    } else {
        if (rad_camera_from_scene(s->scene, v->camera, w, h, &cam, &err))
            return cli_error(&err);
        if (v->have_up)
            cam.up = v->up;
        if (v->have_fov)
            cam.yfov_deg = v->fov;
    }
    if (cli_check_output_dir(exr_path) || (png_path && cli_check_output_dir(png_path)))
        return 2;
    rn_image *img = NULL;
    int rc = rad_render_solution(s, &cam, &img, &err);
    if (!rc)
        rc = rn_write_exr(img, exr_path, &err);
    if (!rc && png_path)
        rc = rn_write_png(img, png_path, v->exposure, &err);
    rn_image_destroy(img);
    return rc ? cli_error(&err) : 0;
}

/* ------------------------------------------------------------------ solve */

typedef struct preview_state {
    const char *dir;
    cli_view view;
    int failed;
} preview_state;

/* Writes DIR/preview-NNNNNN.png of the progressive estimate. */
static int write_preview(void *user, const rad_solution *s, uint32_t shots, const double *B)
{
    preview_state *ps = user;
    rad_solution view = *s; /* shallow: only B differs */
    view.B = (double *)B;
    char exr[4096], png[4096];
    snprintf(exr, sizeof exr, "%s/preview-%06u.exr", ps->dir, shots);
    snprintf(png, sizeof png, "%s/preview-%06u.png", ps->dir, shots);
    if (cli_render_to_files(&view, &ps->view, exr, png)) {
        ps->failed = 1;
        return 1; /* stop the solve */
    }
    return 0;
}

int cli_solve(int argc, char **argv)
{
    const char *scene = NULL, *out = NULL, *preview_dir = NULL;
    uint32_t preview_every = 0;
    int rc;
    rad_solve_options opt = {0};
    for (int i = 0; i < argc; i++) {
        int r = cli_solve_option(argc, argv, &i, &opt);
        if (r < 0)
            return 2;
        if (r > 0)
            continue;
        if (!strcmp(argv[i], "-o") && i + 1 < argc)
            out = argv[++i];
        else if (!strcmp(argv[i], "--preview-every") && i + 1 < argc) {
            if (cli_parse_u32(argv[i], argv[i + 1], 1, 100000000, &preview_every))
                return 2;
            i++;
        } else if (!strcmp(argv[i], "--preview-dir") && i + 1 < argc)
            preview_dir = argv[++i];
        else if ((rc = cli_other_arg("solve", "scene", argv[i], &scene)) != 0)
            return rc;
    }
    if (!scene || !out)
        return cli_usage_error("usage: radiosity solve SCENE -o SOLUTION [options]");
    if (cli_check_output_dir(out))
        return 2;
    preview_state ps = {0};
    char dirbuf[4096];
    if (preview_every) {
        if (opt.solver.method != SV_PROGRESSIVE)
            return cli_usage_error("--preview-every needs --solver progressive");
        if (!preview_dir) {
            snprintf(dirbuf, sizeof dirbuf, "%s", out);
            char *slash = strrchr(dirbuf, '/');
            if (slash)
                *slash = '\0';
            else
                snprintf(dirbuf, sizeof dirbuf, ".");
            preview_dir = dirbuf;
        }
        ps.dir = preview_dir;
        opt.solver.preview_every = preview_every;
        opt.on_preview = write_preview;
        opt.preview_user = &ps;
    }
    cli_enable_progress(&opt);

    rad_error err = {0};
    rad_solution *s = NULL;
    if (rad_solve_scene_file(scene, &opt, &s, &err))
        return cli_error(&err);
    if (ps.failed) {
        rad_solution_destroy(s);
        return 2;
    }
    double t0 = rad_seconds();
    rc = rad_solution_write(s, out, &err);
    double store = rad_seconds() - t0;
    if (rc) {
        rad_solution_destroy(s);
        return cli_error(&err);
    }
    printf("%s: %u patches, %u bands, %llu rows computed (R = %u), %s: %u iterations, residual %.3g\n",
           out, s->mesh->patch_count, s->band_count, (unsigned long long)s->rows_computed,
           s->resolution, s->solver, s->iterations, s->residual);
    if (s->elements)
        printf("elements: %u (from %u patches), %llu element hemi-cubes\n",
               s->elements->mesh->patch_count, s->mesh->patch_count,
               (unsigned long long)s->elements->rows_computed);
    printf("time: load %.3f s, mesh %.3f s, form factors %.3f s, solve %.3f s, store %.3f s\n",
           s->stages[RAD_STAGE_LOAD].seconds, s->stages[RAD_STAGE_MESH].seconds,
           s->stages[RAD_STAGE_FORM_FACTORS].seconds, s->stages[RAD_STAGE_SOLVE].seconds, store);
    rad_solution_destroy(s);
    return 0;
}

/* ----------------------------------------------------------------- render */

int cli_render(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    cli_view view = {0};
    int rc;
    for (int i = 0; i < argc; i++) {
        int r = cli_view_option(argc, argv, &i, &view);
        if (r < 0)
            return 2;
        if (r > 0)
            continue;
        if (!strcmp(argv[i], "-o") && i + 1 < argc)
            out = argv[++i];
        else if ((rc = cli_other_arg("render", "solution", argv[i], &in)) != 0)
            return rc;
    }
    if (!in || !out)
        return cli_usage_error("usage: radiosity render SOLUTION -o IMAGE.exr [options]");
    rad_error err = {0};
    rad_solution *s = NULL;
    if (rad_solution_read(in, &s, &err))
        return cli_error(&err);
    rc = cli_render_to_files(s, &view, out, view.png);
    rad_solution_destroy(s);
    return rc;
}

/* ----------------------------------------------------------------- report */

static void json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

static void json_bands(FILE *f, const double *v, uint32_t nb)
{
    fputc('[', f);
    for (uint32_t b = 0; b < nb; b++)
        fprintf(f, "%s%.9g", b ? ", " : "", v[b]);
    fputc(']', f);
}

/* Counts of what was skipped and why, for the report.  A patch on one side
 * of a transmitting sheet has its twin's row as its back hemi-cube; an
 * opaque patch has none. */
typedef struct economy {
    uint32_t rows_present, black_patches, black_without_row;
    uint32_t sheet_patches, back_hemicubes;
} economy;

static economy count_economy(const rad_solution *s)
{
    economy e = {0};
    const uint32_t *twin = s->mesh->twin;
    for (uint32_t i = 0; i < s->mesh->patch_count; i++) {
        int black = 1;
        for (uint32_t b = 0; b < s->band_count; b++)
            black &= s->rho[(size_t)i * s->band_count + b] == 0.0;
        int sheet = twin && twin[i] != RAD_NONE;
        e.rows_present += s->F->row_done[i] != 0;
        e.black_patches += black;
        e.black_without_row += black && !s->F->row_done[i];
        e.sheet_patches += sheet;
        e.back_hemicubes += sheet && s->F->row_done[twin[i]] &&
                            rad_material_transmits(&s->scene->materials[s->mesh->patches[i].material],
                                                   s->band_count);
    }
    return e;
}

int cli_report(int argc, char **argv)
{
    const char *in = NULL;
    int json = 0, rc;
    for (int i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "--json"))
            json = 1;
        else if ((rc = cli_other_arg("report", "solution", argv[i], &in)) != 0)
            return rc;
    }
    if (!in)
        return cli_usage_error("usage: radiosity report SOLUTION [--json]");
    rad_error err = {0};
    rad_solution *s = NULL;
    if (rad_solution_read(in, &s, &err))
        return cli_error(&err);
    const rad_scene *sc = s->scene;
    uint32_t nb = s->band_count, no = sc->object_count;
    rad_object_stats *st = calloc(no ? no : 1, sizeof *st);
    if (!st || rad_solution_object_stats(s, st, &err)) {
        free(st);
        rad_solution_destroy(s);
        return err.code ? cli_error(&err) : 1;
    }
    double tot_e[RAD_MAX_BANDS] = {0}, tot_a[RAD_MAX_BANDS] = {0}, tot_l[RAD_MAX_BANDS] = {0};
    for (uint32_t o = 0; o < no; o++)
        for (uint32_t b = 0; b < nb; b++)
            tot_e[b] += st[o].emitted[b], tot_a[b] += st[o].absorbed[b];
    /* Punctual lights: emitted (4πI, the spot's cone integral; for a
     * directional light the delivered power) and delivered to patches, which
     * is what enters the balance with the absorbed power. */
    uint32_t nl = sc->light_count;
    rad_light_stats *ls = calloc(nl ? nl : 1, sizeof *ls);
    if (!ls || rad_solution_light_stats(s, ls, &err)) {
        free(ls);
        free(st);
        rad_solution_destroy(s);
        return err.code ? cli_error(&err) : 1;
    }
    for (uint32_t l = 0; l < nl; l++)
        for (uint32_t b = 0; b < nb; b++)
            tot_l[b] += ls[l].delivered[b];
    static const char *const kind_name[3] = {"point", "spot", "directional"};
    economy eco = count_economy(s);
    FILE *f = stdout;
    if (json) {
        fprintf(f, "{\"solution\": ");
        json_string(f, in);
        fprintf(f, ", \"bands\": %u, \"band_names\": [", nb);
        for (uint32_t b = 0; b < nb; b++) {
            fputs(b ? ", " : "", f);
            if (sc->band_names[b])
                json_string(f, sc->band_names[b]);
            else
                fprintf(f, "\"%u\"", b);
        }
        fprintf(f, "], \"patches\": %u, \"objects\": [", s->mesh->patch_count);
        for (uint32_t o = 0; o < no; o++) {
            fprintf(f, "%s\n  {\"name\": ", o ? "," : "");
            json_string(f, sc->objects[o].name);
            fprintf(f, ", \"material\": ");
            if (st[o].material != RAD_NONE)
                json_string(f, sc->materials[st[o].material].name);
            else
                fputs("null", f);
            fprintf(f, ", \"patches\": %u, \"area\": %.9g, \"radiosity\": ", st[o].patch_count,
                    st[o].area);
            json_bands(f, st[o].B, nb);
            fputs(", \"emitted\": ", f);
            json_bands(f, st[o].emitted, nb);
            fputs(", \"absorbed\": ", f);
            json_bands(f, st[o].absorbed, nb);
            fputc('}', f);
        }
        fprintf(f, "],\n \"lights\": [");
        for (uint32_t l = 0; l < nl; l++) {
            fprintf(f, "%s\n  {\"name\": ", l ? "," : "");
            json_string(f, sc->lights[l].name);
            fprintf(f, ", \"kind\": \"%s\", \"intensity\": ", kind_name[sc->lights[l].kind]);
            json_bands(f, s->light_intensity + (size_t)l * nb, nb);
            fputs(", \"emitted\": ", f);
            json_bands(f, ls[l].emitted, nb);
            fputs(", \"delivered\": ", f);
            json_bands(f, ls[l].delivered, nb);
            fputc('}', f);
        }
        fprintf(f, "],\n \"total\": {\"emitted\": ");
        json_bands(f, tot_e, nb);
        fputs(", \"delivered_by_lights\": ", f);
        json_bands(f, tot_l, nb);
        fputs(", \"absorbed\": ", f);
        json_bands(f, tot_a, nb);
        fprintf(f, "},\n \"solver\": {\"name\": ");
        json_string(f, s->solver);
        fprintf(f, ", \"iterations\": %u, \"residual\": %.6g, \"tolerance\": %.6g},\n", s->iterations,
                s->residual, s->tolerance);
        fprintf(f, " \"resolution\": %u, \"patch_size\": %.9g, \"rows_computed\": %llu, \"rows_present\": %u,\n",
                s->resolution, s->patch_size, (unsigned long long)s->rows_computed, eco.rows_present);
        fprintf(f, " \"bands_solved\": %u, \"skipped\": {\"black_patch_rows\": %u, \"reason\": \"a patch with reflectance 0 in every band has B = E and needs no hemi-cube\", "
                   "\"back_hemicubes\": %u, \"back_reason\": \"an opaque patch receives nothing through its back\"},\n",
                rad_solution_is_grey(s) ? 1 : nb, eco.black_without_row,
                s->mesh->patch_count - eco.sheet_patches);
        fprintf(f, " \"transmission\": {\"sheet_patches\": %u, \"back_hemicubes\": %u},\n",
                eco.sheet_patches, eco.back_hemicubes);
        if (s->elements)
            fprintf(f, " \"elements\": {\"count\": %u, \"threshold\": %.6g, \"rows_computed\": %llu},\n",
                    s->elements->mesh->patch_count, s->elements->threshold,
                    (unsigned long long)s->elements->rows_computed);
        fprintf(f, " \"stages\": {");
        for (int k = 0; k < RAD_STAGE_COUNT; k++)
            fprintf(f, "%s\"%s\": %.6f", k ? ", " : "", rad_stage_name(k), s->stages[k].seconds);
        fprintf(f, "},\n \"reused\": {");
        for (int k = 0; k < RAD_STAGE_COUNT; k++)
            fprintf(f, "%s\"%s\": %s", k ? ", " : "", rad_stage_name(k),
                    s->stages[k].reused ? "true" : "false");
        fprintf(f, "}}\n");
    } else {
        fprintf(f, "solution %s: %u patches, %u objects, %u bands\n", in, s->mesh->patch_count, no, nb);
        fprintf(f, "%-20s %-12s %10s  %-30s %-30s %-30s\n", "object", "material", "area",
                "radiosity (mean B)", "emitted power", "absorbed power");
        for (uint32_t o = 0; o < no; o++) {
            char b[3][128];
            const double *v[3] = {st[o].B, st[o].emitted, st[o].absorbed};
            for (int c = 0; c < 3; c++) {
                size_t used = 0;
                b[c][0] = '\0';
                for (uint32_t k = 0; k < nb && used < sizeof b[c] - 16; k++)
                    used += (size_t)snprintf(b[c] + used, sizeof b[c] - used, "%s%.4g", k ? " " : "", v[c][k]);
            }
            fprintf(f, "%-20s %-12s %10.5g  %-30s %-30s %-30s\n", sc->objects[o].name,
                    st[o].material != RAD_NONE ? sc->materials[st[o].material].name : "(mixed)",
                    st[o].area, b[0], b[1], b[2]);
        }
        for (uint32_t l = 0; l < nl; l++) {
            fprintf(f, "light %-14s %-11s emitted", sc->lights[l].name,
                    kind_name[sc->lights[l].kind]);
            for (uint32_t b = 0; b < nb; b++)
                fprintf(f, " %.4g", ls[l].emitted[b]);
            fprintf(f, "   delivered to patches");
            for (uint32_t b = 0; b < nb; b++)
                fprintf(f, " %.4g", ls[l].delivered[b]);
            fputc('\n', f);
        }
        fprintf(f, "total emitted:");
        for (uint32_t b = 0; b < nb; b++)
            fprintf(f, " %.6g", tot_e[b]);
        if (nl) {
            fprintf(f, "   delivered by lights:");
            for (uint32_t b = 0; b < nb; b++)
                fprintf(f, " %.6g", tot_l[b]);
        }
        fprintf(f, "   total absorbed:");
        for (uint32_t b = 0; b < nb; b++)
            fprintf(f, " %.6g", tot_a[b]);
        fprintf(f, "\nsolver: %s, %u iterations, residual %.3g (tolerance %.3g)\n", s->solver,
                s->iterations, s->residual, s->tolerance);
        fprintf(f, "form factors: %u of %u rows present, %llu computed in the last run, R = %u\n",
                eco.rows_present, s->mesh->patch_count, (unsigned long long)s->rows_computed,
                s->resolution);
        if (rad_solution_is_grey(s))
            fprintf(f, "bands: grey scene (equal ρ and E in all %u bands): solved as one band\n", nb);
        if (eco.black_without_row)
            fprintf(f, "skipped: %u rows of patches with reflectance 0 (B = E, no hemi-cube needed)\n",
                    eco.black_without_row);
        if (eco.sheet_patches)
            fprintf(f, "transmission: %u patches on the two sides of transmitting sheets, %u back "
                    "hemi-cubes (each side's row serves the other); none for the %u opaque patches\n",
                    eco.sheet_patches, eco.back_hemicubes, s->mesh->patch_count - eco.sheet_patches);
        else
            fprintf(f, "skipped: back hemi-cubes of all %u patches (no material transmits diffusely)\n",
                    s->mesh->patch_count);
        if (s->elements)
            fprintf(f, "elements: %u receive from %u patches (refine threshold %g), %llu element "
                    "hemi-cubes in the last run\n", s->elements->mesh->patch_count,
                    s->mesh->patch_count, s->elements->threshold,
                    (unsigned long long)s->elements->rows_computed);
        fprintf(f, "stages:");
        for (int k = 0; k < RAD_STAGE_COUNT; k++)
            fprintf(f, "  %s %.3f s%s", rad_stage_name(k), s->stages[k].seconds,
                    s->stages[k].reused ? " (reused)" : "");
        fputc('\n', f);
    }
    free(ls);
    free(st);
    rad_solution_destroy(s);
    return 0;
}
