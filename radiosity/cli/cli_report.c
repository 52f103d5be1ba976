/* cli_report.c - the report command: a solution's numbers as text or JSON
 * (per-object radiosity and power balance, punctual lights, what the run
 * computed and skipped, stage times, the final gather's cache file beside
 * the solution).  Reads only; prints only here.  Calls only the shared
 * files (cli_args.c, cli_print.c).
 */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Writes s as a JSON string (quotes, escapes). */
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
    uint32_t rows_present, black_patches, black_without_row, reflecting_without_row;
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
        e.reflecting_without_row += !black && !s->F->row_done[i];
        e.sheet_patches += sheet;
        e.back_hemicubes += sheet && s->F->row_done[twin[i]] &&
                            rad_material_transmits(&s->scene->materials[s->mesh->patches[i].material],
                                                   s->band_count);
    }
    return e;
}

static const char *const kind_name[3] = {"point", "spot", "directional"};

/* Everything the report prints, computed once from the solution. */
typedef struct report {
    const char *in;           /* the solution's path */
    const rad_solution *s;
    const rad_scene *sc;
    uint32_t nb, no, nl;      /* bands, objects, punctual lights */
    rad_object_stats *st;     /* no entries (owned) */
    rad_light_stats *ls;      /* nl entries (owned) */
    double tot_e[RAD_MAX_BANDS], tot_a[RAD_MAX_BANDS], tot_l[RAD_MAX_BANDS];
    economy eco;
} report;

/* Per-object and per-light statistics and the totals of the power balance:
 * emitted and absorbed by the patches, and delivered to them by the
 * punctual lights (emitted by a light is 4πI or the spot's cone integral;
 * for a directional light the delivered power). */
static int report_gather(report *r, const char *in, const rad_solution *s, rad_error *err)
{
    memset(r, 0, sizeof *r);
    r->in = in, r->s = s, r->sc = s->scene;
    r->nb = s->band_count, r->no = s->scene->object_count, r->nl = s->scene->light_count;
    r->st = calloc(r->no ? r->no : 1, sizeof *r->st);
    r->ls = calloc(r->nl ? r->nl : 1, sizeof *r->ls);
    if (!r->st || !r->ls)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", in);
    int rc = rad_solution_object_stats(s, r->st, err);
    if (!rc)
        rc = rad_solution_light_stats(s, r->ls, err);
    if (rc)
        return rc;
    for (uint32_t o = 0; o < r->no; o++)
        for (uint32_t b = 0; b < r->nb; b++)
            r->tot_e[b] += r->st[o].emitted[b], r->tot_a[b] += r->st[o].absorbed[b];
    for (uint32_t l = 0; l < r->nl; l++)
        for (uint32_t b = 0; b < r->nb; b++)
            r->tot_l[b] += r->ls[l].delivered[b];
    r->eco = count_economy(s);
    return RAD_OK;
}

/* What report says of the final gather's cache file beside sol_path
 * (SOLUTION.icache): its numbers and whether it is current for this
 * solution, as a text line or as a JSON value (null when there is none). */
static void report_cache(FILE *f, const char *sol_path, const rad_solution *s, int json)
{
    char path[4096];
    rad_gather_cache_path(sol_path, path, sizeof path);
    rn_icache *c = NULL;
    rad_error err = {0};
    if (rn_icache_read(path, 0, &c, &err)) {
        if (json)
            fputs("null", f);
        else if (err.code != RAD_ERR_IO)
            fprintf(f, "gather cache: %s\n", err.message);
        return;
    }
    rn_icache_info in;
    rn_icache_info_get(c, &in);
    rn_icache_destroy(c);
    /* Current when this solution under the settings it was filled with
     * gives the key it carries. */
    const char *state = "unknown";
    rad_gather_scene *g = NULL;
    if (rad_gather_scene_create(s, &g, &err) == RAD_OK) {
        rn_gather_options o = {.epsilon = in.epsilon, .gather_rays = in.gather_rays,
                               .no_gradients = !in.gradients, .min_radius_px = in.min_radius_px};
        state = rn_gather_key(&g->scene, &o) == in.key ? "current" : "stale";
        rad_gather_scene_destroy(g);
    }
    if (json) {
        fputs("{\"file\": ", f);
        json_string(f, path);
        fprintf(f, ", \"state\": \"%s\", \"records\": %llu, \"gathers\": %llu, "
                   "\"runs\": %llu, \"epsilon\": %.6g, \"gather_rays\": %u, \"gradients\": %s, "
                   "\"min_radius_px\": %.6g, \"mean_radius\": %.6g}",
                state, (unsigned long long)in.records, (unsigned long long)in.gathers,
                (unsigned long long)in.runs, in.epsilon, in.gather_rays,
                in.gradients ? "true" : "false", in.min_radius_px, in.mean_radius);
        return;
    }
    fprintf(f, "gather cache: %s (%s): %llu records, mean valid radius %.4g; %llu gathers over "
               "%llu renders; epsilon %g, %u rays a gather, gradients %s, minimum radius %g px\n",
            path, state, (unsigned long long)in.records, in.mean_radius,
            (unsigned long long)in.gathers, (unsigned long long)in.runs, in.epsilon,
            in.gather_rays, in.gradients ? "on" : "off", in.min_radius_px);
}

static void report_json(FILE *f, const report *r)
{
    const rad_solution *s = r->s;
    const rad_scene *sc = r->sc;
    const char *in = r->in;
    fprintf(f, "{\"solution\": ");
    json_string(f, in);
    fprintf(f, ", \"bands\": %u, \"band_names\": [", r->nb);
    for (uint32_t b = 0; b < r->nb; b++) {
        fputs(b ? ", " : "", f);
        if (sc->band_names[b])
            json_string(f, sc->band_names[b]);
        else
            fprintf(f, "\"%u\"", b);
    }
    fprintf(f, "], \"patches\": %u, \"objects\": [", s->mesh->patch_count);
    for (uint32_t o = 0; o < r->no; o++) {
        fprintf(f, "%s\n  {\"name\": ", o ? "," : "");
        json_string(f, sc->objects[o].name);
        fprintf(f, ", \"material\": ");
        if (r->st[o].material != RAD_NONE)
            json_string(f, sc->materials[r->st[o].material].name);
        else
            fputs("null", f);
        fprintf(f, ", \"patches\": %u, \"area\": %.9g, \"radiosity\": ", r->st[o].patch_count,
                r->st[o].area);
        json_bands(f, r->st[o].B, r->nb);
        fputs(", \"emitted\": ", f);
        json_bands(f, r->st[o].emitted, r->nb);
        fputs(", \"absorbed\": ", f);
        json_bands(f, r->st[o].absorbed, r->nb);
        fputc('}', f);
    }
    fprintf(f, "],\n \"lights\": [");
    for (uint32_t l = 0; l < r->nl; l++) {
        fprintf(f, "%s\n  {\"name\": ", l ? "," : "");
        json_string(f, sc->lights[l].name);
        fprintf(f, ", \"kind\": \"%s\", \"intensity\": ", kind_name[sc->lights[l].kind]);
        json_bands(f, s->light_intensity + (size_t)l * r->nb, r->nb);
        fputs(", \"emitted\": ", f);
        json_bands(f, r->ls[l].emitted, r->nb);
        fputs(", \"delivered\": ", f);
        json_bands(f, r->ls[l].delivered, r->nb);
        fputc('}', f);
    }
    fprintf(f, "],\n \"total\": {\"emitted\": ");
    json_bands(f, r->tot_e, r->nb);
    fputs(", \"delivered_by_lights\": ", f);
    json_bands(f, r->tot_l, r->nb);
    fputs(", \"absorbed\": ", f);
    json_bands(f, r->tot_a, r->nb);
    fprintf(f, "},\n \"solver\": {\"name\": ");
    json_string(f, s->solver);
    fprintf(f, ", \"iterations\": %u, \"residual\": %.6g, \"residual_unchecked\": %u, "
               "\"tolerance\": %.6g", s->iterations, s->residual, r->eco.reflecting_without_row,
            s->tolerance);
    if (s->progress) {
        const rad_progress *p = s->progress;
        fprintf(f, ", \"progress\": {\"shots\": %u, \"unshot\": %.6g, \"converged\": %s, "
                   "\"rows_recomputed\": %llu, \"rows_dropped\": %llu, \"preview_seconds\": %.6f, "
                   "\"previews\": [",
                p->shots, p->unshot, p->converged ? "true" : "false",
                (unsigned long long)p->rows_recomputed, (unsigned long long)p->rows_dropped,
                p->preview_seconds);
        for (uint32_t k = 0; k < p->preview_count; k++)
            fprintf(f, "%s{\"shots\": %u, \"rows\": %u, \"seconds\": %.6f, \"unshot\": %.6g}",
                    k ? ", " : "", p->previews[k].shots, p->previews[k].rows,
                    p->previews[k].seconds, p->previews[k].unshot);
        fputs("]}", f);
    }
    fputs("},\n", f);
    fprintf(f, " \"resolution\": %u, \"patch_size\": %.9g, \"rows_computed\": %llu, \"rows_present\": %u,\n",
            s->resolution, s->patch_size, (unsigned long long)s->rows_computed, r->eco.rows_present);
    fprintf(f, " \"bands_solved\": %u, \"skipped\": {\"black_patch_rows\": %u, \"reason\": \"a patch with reflectance 0 in every band has B = E and needs no hemi-cube\", "
               "\"back_hemicubes\": %u, \"back_reason\": \"an opaque patch receives nothing through its back\"},\n",
            rad_solution_is_grey(s) ? 1 : r->nb, r->eco.black_without_row,
            s->mesh->patch_count - r->eco.sheet_patches);
    fprintf(f, " \"transmission\": {\"sheet_patches\": %u, \"back_hemicubes\": %u},\n",
            r->eco.sheet_patches, r->eco.back_hemicubes);
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
    fprintf(f, "},\n \"gather_cache\": ");
    report_cache(f, in, s, 1);
    fprintf(f, "}\n");
}

/* The solver's lines: what its tolerance bounds (Gauss-Seidel and Jacobi:
 * the estimated error; progressive: the unshot power), and the residual,
 * which means the same for every solver. */
static void report_solver(FILE *f, const report *r)
{
    const rad_solution *s = r->s;
    const rad_progress *p = s->progress;
    if (p)
        fprintf(f, "solver: %s, %u shots, unshot power %.3g of the emitted (tolerance %.3g)%s\n",
                s->solver, p->shots, p->unshot, s->tolerance,
                p->converged ? "" : ": stopped by the shot limit");
    else
        fprintf(f, "solver: %s, %u iterations, estimated error below the tolerance %.3g\n",
                s->solver, s->iterations, s->tolerance);
    fprintf(f, "residual: %.3g = max_i |E_i + ρ_i Σ_j F_ij B_j - B_i| / max B of the reflecting "
               "patches", s->residual);
    if (r->eco.reflecting_without_row)
        fprintf(f, ", over the patches whose rows are stored (%u reflecting ones have none)",
                r->eco.reflecting_without_row);
    fputc('\n', f);
    if (!p)
        return;
    if (p->rows_dropped)
        fprintf(f, "row store: %llu rows dropped to stay within --max-memory, %llu computed again\n",
                (unsigned long long)p->rows_dropped, (unsigned long long)p->rows_recomputed);
    if (p->preview_count)
        fprintf(f, "previews: %u (their rendering took %.3f s, left out of every time below)\n",
                p->preview_count, p->preview_seconds);
    for (uint32_t k = 0; k < p->preview_count; k++)
        fprintf(f, "  preview at %8.3f s: %8u shots, %7u rows, unshot %.3g\n",
                p->previews[k].seconds, p->previews[k].shots, p->previews[k].rows,
                p->previews[k].unshot);
}

static void report_text(FILE *f, const report *r)
{
    const rad_solution *s = r->s;
    const rad_scene *sc = r->sc;
    const char *in = r->in;
    fprintf(f, "solution %s: %u patches, %u objects, %u bands\n", in, s->mesh->patch_count, r->no, r->nb);
    fprintf(f, "%-20s %-12s %10s  %-30s %-30s %-30s\n", "object", "material", "area",
            "radiosity (mean B)", "emitted power", "absorbed power");
    for (uint32_t o = 0; o < r->no; o++) {
        char b[3][128];
        const double *v[3] = {r->st[o].B, r->st[o].emitted, r->st[o].absorbed};
        for (int c = 0; c < 3; c++) {
            size_t used = 0;
            b[c][0] = '\0';
            for (uint32_t k = 0; k < r->nb && used < sizeof b[c] - 16; k++)
                used += (size_t)snprintf(b[c] + used, sizeof b[c] - used, "%s%.4g", k ? " " : "", v[c][k]);
        }
        fprintf(f, "%-20s %-12s %10.5g  %-30s %-30s %-30s\n", sc->objects[o].name,
                r->st[o].material != RAD_NONE ? sc->materials[r->st[o].material].name : "(mixed)",
                r->st[o].area, b[0], b[1], b[2]);
    }
    for (uint32_t l = 0; l < r->nl; l++) {
        fprintf(f, "light %-14s %-11s emitted", sc->lights[l].name,
                kind_name[sc->lights[l].kind]);
        for (uint32_t b = 0; b < r->nb; b++)
            fprintf(f, " %.4g", r->ls[l].emitted[b]);
        fprintf(f, "   delivered to patches");
        for (uint32_t b = 0; b < r->nb; b++)
            fprintf(f, " %.4g", r->ls[l].delivered[b]);
        fputc('\n', f);
    }
    fprintf(f, "total emitted:");
    for (uint32_t b = 0; b < r->nb; b++)
        fprintf(f, " %.6g", r->tot_e[b]);
    if (r->nl) {
        fprintf(f, "   delivered by lights:");
        for (uint32_t b = 0; b < r->nb; b++)
            fprintf(f, " %.6g", r->tot_l[b]);
    }
    fprintf(f, "   total absorbed:");
    for (uint32_t b = 0; b < r->nb; b++)
        fprintf(f, " %.6g", r->tot_a[b]);
    fputc('\n', f);
    report_solver(f, r);
    if (s->patch_size > 0.0)
        fprintf(f, "patch size: %.6g scene units (%u patches)\n", s->patch_size,
                s->mesh->patch_count);
    fprintf(f, "form factors: %u of %u rows present, %llu computed in the last run, R = %u\n",
            r->eco.rows_present, s->mesh->patch_count, (unsigned long long)s->rows_computed,
            s->resolution);
    if (rad_solution_is_grey(s))
        fprintf(f, "bands: grey scene (equal ρ and E in all %u bands): solved as one band\n", r->nb);
    if (r->eco.black_without_row)
        fprintf(f, "skipped: %u rows of patches with reflectance 0 (B = E, no hemi-cube needed)\n",
                r->eco.black_without_row);
    if (r->eco.sheet_patches)
        fprintf(f, "transmission: %u patches on the two sides of transmitting sheets, %u back "
                "hemi-cubes (each side's row serves the other); none for the %u opaque patches\n",
                r->eco.sheet_patches, r->eco.back_hemicubes, s->mesh->patch_count - r->eco.sheet_patches);
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
    report_cache(f, in, s, 0);
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
    /* the power balance takes the irradiance stored beside B: F is not read */
    if (rad_solution_read_parts(in, 0, &s, &err))
        return cli_error(&err);
    report r;
    rc = report_gather(&r, in, s, &err);
    if (!rc) {
        if (json)
            report_json(stdout, &r);
        else
            report_text(stdout, &r);
    }
    free(r.ls);
    free(r.st);
    rad_solution_destroy(s);
    return rc ? cli_error(&err) : 0;
}
