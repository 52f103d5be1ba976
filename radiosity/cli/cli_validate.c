/* cli_validate.c - the validate command: runs the validation suite
 * (validate.h) and prints it as a table or as JSON.
 *
 *   radiosity validate [--json] [--quick] [--resolution R[,R...]] [--processes P]
 *                      [--gl osmesa|egl|auto]
 *   radiosity validate --catalog [--accuracy default|high] [--json] [--processes P]
 *
 * Exit status 0 when every case at the default settings is within the error
 * the report promises for it, 1 when one is not (the line says which), 2 for
 * a bad command line.  The library computes; only this file prints.
 */
#include "cli.h"
#include "../validate/validate.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void progress(void *user, uint32_t done, uint32_t total, const rad_val_result *last)
{
    (void)user;
    fprintf(stderr, "\rvalidate: %u/%u %-48.48s", done, total, last->name);
    if (done == total)
        fprintf(stderr, "\r%*s\r", 70, "");
    fflush(stderr);
}

/* Parses "32,64,256" into out[]; 0 or the exit status (message printed). */
static int parse_resolutions(const char *s, uint32_t *out, uint32_t cap, uint32_t *count)
{
    char buf[512];
    if (!s || strlen(s) >= sizeof buf)
        return cli_usage_error("--resolution: '%s' is not a list like 32,64,256", s ? s : "");
    snprintf(buf, sizeof buf, "%s", s);
    uint32_t n = 0;
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        if (n == cap)
            return cli_usage_error("--resolution: at most %u values", cap);
        int rc = cli_parse_u32("--resolution", tok, 8, 4096, &out[n]);
        if (rc)
            return rc;
        if (out[n] % 2)
            return cli_usage_error("--resolution: %u: the hemi-cube needs an even resolution", out[n]);
        n++;
    }
    if (n == 0)
        return cli_usage_error("--resolution: '%s' is not a list like 32,64,256", s);
    *count = n;
    return 0;
}

/* A JSON number, or null for NaN/inf. */
static void json_num(const char *key, double v, int comma)
{
    if (isfinite(v))
        printf("\"%s\": %.9g%s", key, v, comma ? ", " : "");
    else
        printf("\"%s\": null%s", key, comma ? ", " : "");
}

static int within(const rad_val_result *r)
{
    return !(r->promised > 0) || fabs(r->rel_error) <= r->promised;
}

static void print_json(const rad_val_result *res, uint32_t n, int all_ok)
{
    printf("{\"resolution_default\": %d, \"all_within_promise\": %s, \"results\": [\n",
           HC_DEFAULT_RESOLUTION,
           all_ok ? "true" : "false");
    for (uint32_t k = 0; k < n; k++) {
        const rad_val_result *r = &res[k];
        /* Names and labels come from the library's own table: plain ASCII,
         * nothing to escape. */
        printf("  {\"config\": \"%s\", \"label\": \"%s\", \"name\": \"%s\", \"quantity\": \"%s\", ",
               rad_validate_config_name(r->c.config), r->c.label, r->name, r->quantity);
        printf("\"default\": %s, \"resolution\": %u, \"subdiv\": %u, \"subdiv_long\": %u, "
               "\"patches\": %u, \"rows\": %u, ",
               r->promised > 0 ? "true" : "false", r->c.resolution, r->c.subdiv, r->c.subdiv_long,
               r->patches, r->rows);
        json_num("reference", r->reference, 1);
        json_num("value", r->value, 1);
        json_num("rel_error", r->rel_error, 1);
        json_num("secondary", r->secondary, 1);
        printf("\"secondary_what\": \"%s\", ", r->secondary_what);
        json_num("secondary_error", r->secondary_error, 1);
        json_num("worst", r->worst, 1);
        json_num("promised", r->promised > 0 ? r->promised : NAN, 1);
        printf("\"within_promise\": %s, \"iterations\": %u, ", within(r) ? "true" : "false",
               r->iterations);
        json_num("t_mesh", r->t_mesh, 1);
        json_num("t_form_factors", r->t_form_factors, 1);
        json_num("t_solve", r->t_solve, 1);
        json_num("t_reference", r->t_reference, 1);
        json_num("seconds", r->seconds, 0);
        printf("}%s\n", k + 1 < n ? "," : "");
    }
    printf("]}\n");
}

static void print_table(const rad_val_result *res, uint32_t n)
{
    printf("Hemi-cube against exact values.  '*' marks the default settings (R = " CLI_STR(HC_DEFAULT_RESOLUTION) ") and the\n"
           "error promised for them; other rows vary R or the subdivision (patches per edge).\n\n");
    printf("  %-40s %-10s %5s %6s %7s %13s %13s %10s %9s %7s\n", "case", "quantity", "R", "subdiv",
           "patches", "exact", "hemi-cube", "rel.error", "promise", "time s");
    for (uint32_t k = 0; k < n; k++) {
        const rad_val_result *r = &res[k];
        char name[64], promise[16] = "";
        if (r->c.label[0])
            snprintf(name, sizeof name, "%s (%s)", r->name, r->c.label);
        else
            snprintf(name, sizeof name, "%s", r->name);
        if (r->promised > 0)
            snprintf(promise, sizeof promise, "%.1e%s", r->promised, within(r) ? "" : "!");
        printf("%c %-40.40s %-10s %5u %6u %7u %13.8g %13.8g %+10.2e %9s %7.2f\n",
               r->promised > 0 ? '*' : ' ', name, r->quantity, r->c.resolution, r->c.subdiv,
               r->patches, r->reference, r->value, r->rel_error, promise, r->seconds);
        if (r->promised > 0 && isfinite(r->secondary))
            printf("  %-40s %s %.8g: exact value vs it %+.2e\n", "", r->secondary_what, r->secondary,
                   r->secondary_error);
        if (r->promised > 0 && isfinite(r->worst) && r->c.config != RAD_VAL_ENCLOSURE)
            printf("  %-40s worst patch %+.2e\n", "", r->worst);
    }
}

int cli_validate(int argc, char **argv)
{
    int json = 0;
    rad_validate_options opt = {0};
    uint32_t res[64], nres = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--quick")) {
            opt.quick = 1;
        } else if (!strcmp(a, "--catalog")) {
            opt.catalog = 1;
        } else if (!strcmp(a, "--accuracy")) {
            const char *v = i + 1 < argc ? argv[++i] : "";
            if (strcmp(v, "default") && strcmp(v, "high"))
                return cli_usage_error("validate: --accuracy '%s': default or high", v);
            opt.engine = strcmp(v, "high") ? RAD_VAL_DEFAULTS : RAD_VAL_ACCURATE;
        } else if (!strcmp(a, "--resolution") || !strcmp(a, "--resolutions")) {
            int rc = parse_resolutions(i + 1 < argc ? argv[i + 1] : NULL, res, 64, &nres);
            if (rc)
                return rc;
            i++;
        } else if (!strcmp(a, "--gl")) {
            int rc = cli_gl_option(a, i + 1 < argc ? argv[i + 1] : NULL, &opt.gl);
            if (rc)
                return rc;
            i++;
        } else if (!strcmp(a, "--processes")) {
            int rc = cli_parse_u32(a, i + 1 < argc ? argv[i + 1] : NULL, 1, 256, &opt.processes);
            if (rc)
                return rc;
            i++;
        } else {
            return cli_usage_error("validate: unknown argument '%s' (options: --json, --quick, "
                                   "--resolution R[,R...], --processes P, --gl G, --catalog, "
                                   "--accuracy default|high)", a);
        }
    }
    if (nres) {
        opt.resolutions = res;
        opt.resolution_count = nres;
    }
    if (isatty(STDERR_FILENO))
        opt.progress = progress;

    rad_val_result *r = NULL;
    uint32_t n = 0;
    rad_error err = {0};
    if (rad_validate_run(&opt, &r, &n, &err))
        return cli_error(&err);
    int all_ok = 1;
    uint32_t bad = 0;
    for (uint32_t k = 0; k < n; k++)
        if (!within(&r[k])) {
            all_ok = 0;
            bad = bad ? bad : k + 1;
        }
    if (json)
        print_json(r, n, all_ok);
    else
        print_table(r, n);
    int rc = 0;
    if (!all_ok) {
        const rad_val_result *b = &r[bad - 1];
        fprintf(stderr, "radiosity: error: validate: %s: relative error %.3g exceeds the promised %.3g\n",
                b->name, b->rel_error, b->promised);
        rc = 1;
    }
    free(r);
    return rc;
}
