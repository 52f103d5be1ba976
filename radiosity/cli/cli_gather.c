/* cli_gather.c - `radiosity render SOLUTION --gather`: the final gather's
 * options, its progress bar and summary line, and what `report` says of the
 * cache file beside a solution.
 */
#include "cli.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int cli_gather_option(int argc, char **argv, int *i, cli_gather *g)
{
    const char *a = argv[*i];
    const char *v = *i + 1 < argc ? argv[*i + 1] : NULL;
    rn_gather_options *o = &g->opt;
    int rc = 0, takes = 1;
    if (!strcmp(a, "--gather")) {
        g->on = 1;
        return 1;
    }
    if (!strcmp(a, "--epsilon"))
        rc = cli_parse_double(a, v, 1e-4, 1.0, &o->epsilon);
    else if (!strcmp(a, "--gather-rays"))
        rc = cli_parse_u32(a, v, 8, 1u << 20, &o->gather_rays);
    else if (!strcmp(a, "--light-samples"))
        rc = cli_parse_u32(a, v, 1, 1u << 16, &o->light_samples);
    else if (!strcmp(a, "--glossy-rays"))
        rc = cli_parse_u32(a, v, 1, 1u << 16, &o->glossy_rays);
    else if (!strcmp(a, "--max-depth"))
        rc = cli_parse_u32(a, v, 1, 64, &o->max_depth);
    else if (!strcmp(a, "--min-radius"))
        rc = cli_parse_double(a, v, 1e-3, 1e6, &o->min_radius_px);
    else if (!strcmp(a, "--cache")) {
        if (!v)
            return cli_usage_error("--cache needs a file name"), -1;
        g->cache = v;
    } else if (!strcmp(a, "--glossy")) {
        if (v && !strcmp(v, "auto"))
            o->glossy = RN_GLOSSY_AUTO;
        else if (v && !strcmp(v, "sample"))
            o->glossy = RN_GLOSSY_SAMPLE;
        else if (v && !strcmp(v, "light-vector"))
            o->glossy = RN_GLOSSY_LIGHT_VECTOR;
        else
            return cli_usage_error("--glossy: '%s' is not auto, sample or light-vector",
                                   v ? v : ""), -1;
    } else {
        takes = 0;
        if (!strcmp(a, "--no-cache"))
            o->no_cache = 1;
        else if (!strcmp(a, "--no-cache-file"))
            g->no_cache_file = 1;
        else if (!strcmp(a, "--no-gradients"))
            o->no_gradients = 1;
        else
            return 0;
    }
    if (rc)
        return -1;
    if (!g->given)
        g->given = a;
    *i += takes;
    return 1;
}

/* Progress on stderr, only when stderr is a terminal. */
static void gather_bar(void *user, uint64_t done, uint64_t total)
{
    int *last = user;
    int pct = total ? (int)(100.0 * (double)done / (double)total) : 100;
    if (pct == *last && done != total)
        return;
    *last = pct;
    int filled = pct * 30 / 100;
    fprintf(stderr, "\rgather [%.*s%*s] %3d%%", filled, "##############################",
            30 - filled, "", pct);
    if (done >= total)
        fputc('\n', stderr);
    fflush(stderr);
}

int cli_gather_to_files(const rad_solution *s, const char *sol_path, const cli_view *v,
                        const cli_gather *g, const char *exr_path)
{
    rad_error err = {0};
    rn_camera cam;
    int rc = cli_view_camera(s, v, &cam);
    if (rc)
        return rc;
    if (cli_check_output_dir(exr_path) || (v->png && cli_check_output_dir(v->png)))
        return 2;
    char path[4096];
    rad_gather_options opt = {.render = g->opt, .warn = cli_warn};
    if (!g->no_cache_file && !g->opt.no_cache) {
        if (g->cache)
            snprintf(path, sizeof path, "%s", g->cache);
        else
            rad_gather_cache_path(sol_path, path, sizeof path);
        opt.cache_path = path;
    }
    int last = -1;
    if (isatty(STDERR_FILENO)) {
        opt.render.progress = gather_bar;
        opt.render.progress_user = &last;
    }
    rn_image *img = NULL;
    rn_gather_stats st;
    rc = rad_render_gather(s, &cam, &opt, &img, &st, &err);
    if (!rc)
        rc = rn_write_exr_with(img, exr_path, v->exr_compression, &err);
    if (!rc && v->png)
        rc = rn_write_png(img, v->png, v->exposure, &err);
    rn_image_destroy(img);
    if (rc)
        return cli_error(&err);
    printf("gather: %llu pixels in %.2f s: %llu gathers (%.2f %% of pixels), %llu of %llu "
           "shading points from the cache, %llu records (%llu loaded)\n",
           (unsigned long long)st.pixels, st.seconds, (unsigned long long)st.gathers,
           st.pixels ? 100.0 * (double)st.gathers / (double)st.pixels : 0.0,
           (unsigned long long)st.cache_hits, (unsigned long long)st.shading_points,
           (unsigned long long)st.records, (unsigned long long)st.records_loaded);
    return 0;
}

void cli_report_cache(FILE *f, const char *sol_path, const rad_solution *s, int json)
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
        cli_json_string(f, path);
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
