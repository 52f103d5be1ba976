/* pipeline.c - the stages in order, each one call and one comment:
 *
 *   load -> mesh -> form factors (hemi-cube rows) -> direct light of the
 *   punctual lights -> solve -> (store, render)
 *
 * rad_resolve is the qrad3-style heart: it decides which rows the solve
 * needs, computes only those that are missing, and solves.  A relight calls
 * it again on the same solution and computes no row that is already there.
 *
 * Which rows are needed: gathering solvers (Gauss-Seidel, Jacobi) need row i
 * for every patch that reflects (ρ_i > 0 in some band): a patch with ρ = 0
 * has B = E whatever it sees, so its row would be wasted work.  A sheet that
 * transmits diffusely (τ > 0) is two patches back to back (mesh twins), and
 * B_i = E_i + ρ_i H_i + τ_i H_twin(i): the twin's row is i's back hemi-cube,
 * computed only there (sv_row_needed).  The progressive solver asks for the
 * rows of the patches it shoots from, in batches computed on every worker,
 * within --max-memory (it drops rows and asks for them again), and for the
 * exact columns of emitters (hc_exact_column): the same factors their
 * receivers' rows hold, so that it solves the very system Gauss-Seidel
 * solves.
 *
 * Punctual lights have no patches: each is rendered once as an item-buffer
 * cube at the light (hc_light_power), which gives the power Φ_lj patch j
 * receives at unit strength.  The direct irradiance H_d,j = Σ_l I_l Φ_lj / A_j
 * is shot first, as the source term E_j + ρ_j H_d,j, and the solver carries
 * the interreflection from there.  Φ is stored, so a relight that scales or
 * switches a light renders nothing again.
 *
 * Once B and the elements are final, the stored light responses are made
 * (rad_basis_make, radiosity/relight/), whose per-group solves run on this
 * file's solver (make_basis).
 */
#include "pipeline.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One run of the pipeline on a solution: the hemi-cube engine (started on
 * first need and shared by the patch rows, the lights and the elements) and
 * what the run computed.  The progressive solver's row callback gets it. */
typedef struct run {
    rad_solution *s;
    const rad_solve_options *opt;
    hc_engine *hc;        /* created on first need, destroyed by run_end */
    uint8_t *exact;       /* patches with exact incoming factors (emitters), or NULL */
    uint64_t rows_computed;
    uint64_t lights_computed;
    uint64_t max_memory;
    double ff_seconds;    /* time inside the hemi-cube, counted apart from the solve */
    double t0;            /* when the run began */
    int quiet_rows;       /* 1 while the progressive solver asks for rows: its own
                           * progress, not the rows', is what the user follows */
    /* The progressive solve's previews: when, and how much was unshot. */
    rad_preview_info *previews;
    uint32_t preview_count, preview_slots;
    double solve_t0;      /* when the solve stage began */
    double *preview_B;    /* a grey solve's preview, widened to every band */
} run;

static void run_begin(run *c, rad_solution *s, const rad_solve_options *opt)
{
    uint64_t limit = opt->max_memory;
    if (!limit)
        limit = (uint64_t)(0.8 * (double)rad_available_memory());
    *c = (run){.s = s, .opt = opt, .max_memory = limit, .t0 = rad_seconds()};
}

static void run_end(run *c)
{
    if (c->hc)
        c->s->resolution = c->opt->hemicube.resolution ? c->opt->hemicube.resolution
                                                       : HC_DEFAULT_RESOLUTION;
    hc_destroy(c->hc);
    free(c->exact);
    free(c->previews);
    free(c->preview_B);
    c->hc = NULL;
    c->exact = NULL;
    c->previews = NULL;
    c->preview_B = NULL;
}

/* The hemi-cube's row progress, passed on unless the progressive solver is
 * the one asking (its batches would each show as a bar of their own). */
static void row_progress(void *user, uint32_t done, uint32_t total)
{
    run *c = user;
    if (!c->quiet_rows)
        c->opt->hemicube.progress(c->opt->hemicube.progress_user, done, total);
}

/* The patches whose incoming factors are exact, into c->exact (NULL when
 * none are: pixel_emitters, or the caller's own marks): emitters, whose few
 * pixels are where aliasing hurts. */
static int mark_exact(run *c, rad_error *err)
{
    if (c->exact || (c->opt->pixel_emitters && !c->opt->exact_all) || c->opt->hemicube.exact)
        return RAD_OK;
    uint32_t n = c->s->mesh->patch_count;
    c->exact = calloc((size_t)n + 1, 1);
    if (!c->exact)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", c->s->scene->source);
    for (uint32_t i = 0; i < n; i++)
        c->exact[i] = (uint8_t)(c->opt->exact_all ||
                                rad_any_positive(c->s->emission + (size_t)i * c->s->band_count,
                                                 c->s->band_count));
    return RAD_OK;
}

static int start_hemicube(run *c, rad_error *err)
{
    if (c->hc)
        return RAD_OK;
    hc_options ho = c->opt->hemicube;
    ho.exact_near = c->opt->exact_near >= 0; /* on unless asked off */
    ho.weak = c->opt->accuracy < 0   ? HC_WEAK_OFF
              : c->opt->accuracy > 0 ? HC_WEAK_HIGH
              : c->opt->surface_factors ? HC_WEAK_SURFACE
                                        : HC_WEAK_ON;
    ho.stop = c->opt->stop;
    if (ho.progress) {
        ho.progress = row_progress;
        ho.progress_user = c;
    }
    int rc = mark_exact(c, err);
    if (rc)
        return rc;
    if (c->exact)
        ho.exact = c->exact; /* lives as long as the engine */
    return hc_create(c->s->mesh, &ho, &c->hc, err);
}

/* The rows key of this run (rad_rows_key): mesh, R, exact marks and the
 * options that change rows. */
static int rows_key(run *c, uint64_t *key, rad_error *err)
{
    int rc = mark_exact(c, err);
    if (rc)
        return rc;
    const rad_solve_options *o = c->opt;
    uint32_t R = o->hemicube.resolution ? o->hemicube.resolution : HC_DEFAULT_RESOLUTION;
    uint32_t flags = (o->exact_near >= 0 ? 1u : 0u) | (o->pixel_emitters ? 2u : 0u) |
                     (o->accuracy < 0 ? 4u : o->accuracy > 0 ? 8u : 0u) |
                     (o->accuracy == 0 && o->surface_factors ? 16u : 0u);
    *key = rad_rows_key(c->s->mesh, R, c->exact ? c->exact : o->hemicube.exact, flags);
    return RAD_OK;
}

static int compute_rows(run *c, const uint32_t *rows, uint32_t count, rad_error *err)
{
    if (count == 0)
        return RAD_OK;
    double t0 = rad_seconds();
    int rc = start_hemicube(c, err);
    /* the engine stops at the flag, keeping every row its workers finished */
    if (!rc)
        rc = hc_compute_rows(c->hc, rows, count, c->s->F, err);
    if (rc == RAD_ERR_INTERRUPTED)
        rad_fail(err, rc, "%s: form factors: interrupted", c->s->scene->source);
    if (!rc)
        c->rows_computed += count;
    c->ff_seconds += rad_seconds() - t0;
    return rc;
}

/* sv_options.need_rows: a batch of the progressive solver's rows, on every
 * worker (the solver keeps the matrix within --max-memory). */
static int need_rows(void *user, const uint32_t *rows, uint32_t count, rad_error *err)
{
    return compute_rows(user, rows, count, err);
}

/* sv_options.need_column: an emitter's exact column (hc_exact_column), the
 * factors its receivers' rows hold for it (hc_options.exact); none for a
 * patch whose receivers count pixels for it. */
static int need_column(void *user, uint32_t i, uint32_t *col, float *val, uint32_t *count,
                       rad_error *err)
{
    run *c = user;
    *count = RAD_NONE;
    if (c->opt->pixel_emitters || c->opt->hemicube.exact ||
        !rad_any_positive(c->s->emission + (size_t)i * c->s->band_count, c->s->band_count))
        return RAD_OK;
    const double t0 = rad_seconds();
    int rc = start_hemicube(c, err);
    if (!rc)
        rc = hc_exact_column(c->hc, i, rad_light_resolution(c->opt), 1, col, val, count, err);
    c->ff_seconds += rad_seconds() - t0;
    return rc;
}

/* sv_options.on_preview: logs the preview (time since the run began, the
 * previews' own time left out: the solver's time excludes it) and hands it
 * on, widened to every band when the solve was grey. */
static int on_preview(void *user, const sv_progress *p)
{
    run *c = user;
    rad_solution *s = c->s;
    if (c->preview_count == c->preview_slots) {
        uint32_t slots = c->preview_slots ? 2 * c->preview_slots : 16;
        rad_preview_info *more = realloc(c->previews, slots * sizeof *more);
        if (!more)
            return 1; /* no memory for the log: stop rather than lose track */
        c->previews = more;
        c->preview_slots = slots;
    }
    c->previews[c->preview_count++] =
        (rad_preview_info){.shots = p->shots,
                           .rows = (uint32_t)c->rows_computed,
                           .seconds = c->solve_t0 - c->t0 + p->seconds,
                           .unshot = p->unshot};
    const double *B = p->B;
    if (c->preview_B) {
        const uint32_t n = s->mesh->patch_count, nb = s->band_count;
        for (uint32_t i = 0; i < n; i++)
            for (uint32_t b = 0; b < nb; b++)
                c->preview_B[(size_t)i * nb + b] = p->B[i];
        B = c->preview_B;
    }
    return c->opt->on_preview(c->opt->preview_user, s, p->shots, B);
}

/* τ_i of every patch from its material, n × bands, when the mesh has
 * two-sided sheets (else *out = NULL).  A transmitting patch without its
 * other side (a solution file from before transmission was simulated) is
 * refused: solving it would drop the light it passes on. */
static int patch_tau(const rad_solution *s, double **out, rad_error *err)
{
    *out = NULL;
    const uint32_t n = s->mesh->patch_count, nb = s->band_count;
    for (uint32_t i = 0; i < n; i++) {
        const rad_patch *p = &s->mesh->patches[i];
        const rad_material *m = &s->scene->materials[p->material];
        if (rad_material_transmits(m, nb) && (!s->mesh->twin || s->mesh->twin[i] == RAD_NONE))
            return rad_fail(err, RAD_ERR_INVALID,
                            "%s: object '%s': material '%s' transmits but its patches have no "
                            "back side (a solution from before diffuse transmission was "
                            "simulated); solve the scene again",
                            s->scene->source, s->scene->objects[p->object].name, m->name);
    }
    if (!s->mesh->twin)
        return RAD_OK;
    double *tau = malloc(((size_t)n * nb + 1) * sizeof *tau);
    if (!tau)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    for (uint32_t i = 0; i < n; i++)
        memcpy(tau + (size_t)i * nb, s->scene->materials[s->mesh->patches[i].material].transmit,
               nb * sizeof *tau);
    *out = tau;
    return RAD_OK;
}

/* The estimate once the sample rows are in F: `left` rows still to
 * compute, each taken to hold the samples' mean count of entries and to
 * take their mean bytes, in memory (F keeps its rows packed, as the file
 * stores them: rad.h) and in the file (rad_solution_row_file_bytes). */
static void estimate(const run *c, const uint32_t *sample, uint32_t k, uint32_t left,
                     rad_estimate *e)
{
    const rad_solution *s = c->s;
    const rad_matrix *F = s->F;
    const uint32_t n = s->mesh->patch_count, nb = s->band_count;
    uint64_t entries = 0, record = 0, file = 0;
    for (uint32_t q = 0; q < k; q++) {
        entries += F->row_count[sample[q]];
        record += rad_matrix_record_bytes(F, sample[q]);
        file += rad_solution_row_file_bytes(F, sample[q]);
    }
    const double mean = k ? (double)entries / k : 0.0, per_file = k ? (double)file / k : 8.0;
    const double more = k ? (double)left * (double)record / k : 0.0;
    *e = (rad_estimate){.patches = n,
                        .cells = s->mesh->cell_first ? s->mesh->cell_count : n,
                        .rows = F->rows_done + left,
                        .sample_rows = k,
                        .entries_per_row = mean,
                        .limit_bytes = c->max_memory};
    e->matrix_bytes = (uint64_t)((double)F->bytes + more) + rad_matrix_index_bytes(n);
    /* The process now (scene, mesh, solution arrays, F so far), the rest of
     * F, and the solve's own arrays (a few per patch and band). */
    e->peak_bytes = rad_process_memory(0) + (uint64_t)more + (uint64_t)n * (32u * nb + 16u);
    e->file_bytes = rad_solution_file_bytes(s) + (uint64_t)((double)left * per_file);
}

/* What the progressive solver's row store may hold: max_memory less F's
 * index, so that F in all (what rad_estimate.matrix_bytes counts) stays
 * within --max-memory; at least 1 byte (0 would mean no limit). */
static uint64_t row_store_bytes(const run *c)
{
    const uint64_t index = rad_matrix_index_bytes(c->s->mesh->patch_count);
    return c->max_memory > index + 1 ? c->max_memory - index : 1;
}

/* The least memory the progressive solver needs under a bounded store:
 * F's index and STORE_MIN_ROWS rows of the longest sampled length (a
 * shot's one or two rows, each reserved at twice the longest seen, and
 * the rows it keeps meanwhile, with a margin). */
#define STORE_MIN_ROWS 8u
static uint64_t progressive_floor(const run *c, uint32_t longest)
{
    return rad_matrix_index_bytes(c->s->mesh->patch_count) +
           STORE_MIN_ROWS * rad_matrix_row_bytes(longest);
}

/* A matrix that would not fit in c->max_memory, before computing the rows
 * that would fill it: the gathering solvers refuse it, with a patch size
 * that would fit: F grows about as N² (N rows, each seeing a share of the
 * N patches), so N' = N sqrt(0.7 L / F) patches fit with a margin, and
 * rad_mesh_size_for finds the size that meshes into at most N'.  The
 * message also names the memory that would do, when the machine has it,
 * and the progressive solver when its row store fits.  The progressive
 * solver keeps its rows within the limit instead (dropping and computing
 * them again) and is refused only below progressive_floor.  `longest`:
 * the longest sampled row's entries. */
static int check_memory(const run *c, const rad_estimate *e, uint32_t longest, rad_error *err)
{
    if (e->matrix_bytes <= c->max_memory)
        return RAD_OK;
    const int progressive = c->opt->solver.method == SV_PROGRESSIVE;
    const uint64_t floor = progressive_floor(c, longest);
    if (progressive && floor <= c->max_memory)
        return RAD_OK;
    const rad_solution *s = c->s;
    char need[32], have[32], mem[32], raise[96] = "", prog[160] = "";
    double fit = (double)e->patches * sqrt(0.7 * (double)c->max_memory / (double)e->matrix_bytes);
    uint64_t target = fit < 1.0 ? 1 : (uint64_t)fit;
    double size = rad_mesh_size_for(s->scene, &c->opt->mesh, target);
    uint64_t avail = rad_available_memory();
    if (e->peak_bytes < avail)
        snprintf(raise, sizeof raise, ", or --max-memory %s",
                 rad_human_bytes((double)e->matrix_bytes * 1.1, mem, sizeof mem));
    if (progressive)
        snprintf(prog, sizeof prog, " (the progressive solver's row store needs at least %s)",
                 rad_human_bytes((double)floor, mem, sizeof mem));
    else if (floor <= c->max_memory)
        snprintf(prog, sizeof prog, ", or --solver progressive (keeps its rows within the "
                                    "limit, computing again those it drops)");
    return rad_fail(err, RAD_ERR_LIMIT,
                    "%s: form factors for %u patches need about %s (%.0f entries a row, "
                    "measured on %u rows), more than the %s allowed%s; use --patch-size %.3g "
                    "(at most %llu patches)%s%s",
                    s->scene->source, e->patches,
                    rad_human_bytes((double)e->matrix_bytes, need, sizeof need), e->entries_per_row,
                    e->sample_rows, rad_human_bytes((double)c->max_memory, have, sizeof have),
                    progressive ? prog : "", size, (unsigned long long)target, raise,
                    progressive ? "" : prog);
}

int rad_solution_is_grey(const rad_solution *s)
{
    uint32_t nb = s->band_count;
    for (size_t i = 0; nb > 1 && i < s->mesh->patch_count; i++) {
        const double *rho = s->rho + i * nb, *e = s->emission + i * nb;
        const double *tau = s->scene->materials[s->mesh->patches[i].material].transmit;
        for (uint32_t b = 1; b < nb; b++)
            if (rho[b] != rho[0] || e[b] != e[0] || tau[b] != tau[0])
                return 0;
    }
    for (size_t l = 0; nb > 1 && s->light_intensity && l < s->scene->light_count; l++)
        for (uint32_t b = 1; b < nb; b++)
            if (s->light_intensity[l * nb + b] != s->light_intensity[l * nb])
                return 0;
    return nb > 1;
}

uint32_t rad_light_resolution(const rad_solve_options *opt)
{
    if (opt->light_resolution)
        return opt->light_resolution;
    const uint32_t R = opt->hemicube.resolution;
    return R > HC_DEFAULT_LIGHT_RESOLUTION ? R : HC_DEFAULT_LIGHT_RESOLUTION;
}

/* A scene light as the hemi-cube module takes it. */
static hc_light light_for_hemicube(const rad_light *L)
{
    hc_light hl = {.kind = L->kind == RAD_LIGHT_POINT  ? HC_LIGHT_POINT
                           : L->kind == RAD_LIGHT_SPOT ? HC_LIGHT_SPOT
                                                       : HC_LIGHT_DIRECTIONAL,
                   .position = L->position,
                   .direction = L->direction,
                   .inner_cone = L->inner_cone,
                   .outer_cone = L->outer_cone};
    return hl;
}

/* The estimate's sample rows, up to RAD_ESTIMATE_SAMPLES spread over
 * missing[0..count) (they stay: the solve needs them) into sample (room
 * for SAMPLE_ROOM), their number into *k.  Under the progressive row store
 * (store > 0) 8 first, and the rest only if the sample would take at most
 * a quarter of the store: sampling must not overrun a small --max-memory. */
#define SAMPLE_ROOM (RAD_ESTIMATE_SAMPLES + 8u)
static int sample_rows(run *c, const uint32_t *missing, uint32_t count, uint64_t store,
                       uint32_t *sample, uint32_t *k, rad_error *err)
{
    const rad_matrix *F = c->s->F;
    const uint32_t want = count < RAD_ESTIMATE_SAMPLES ? count : RAD_ESTIMATE_SAMPLES;
    *k = 0;
    if (store && want) {
        const uint32_t first = want < 8 ? want : 8;
        for (uint32_t q = 0; q < first; q++)
            sample[(*k)++] = missing[(uint64_t)q * count / first];
        int rc = compute_rows(c, sample, *k, err);
        if (rc || (double)rad_matrix_live_bytes(F) * want / *k > 0.25 * (double)store)
            return rc;
    }
    const uint32_t start = *k;
    for (uint32_t q = 0; q < want; q++) {
        const uint32_t i = missing[(uint64_t)q * count / want];
        if (!F->row_done[i])
            sample[(*k)++] = i;
    }
    return compute_rows(c, sample + start, *k - start, err);
}

/* The stage "form factors": the rows the gathering solvers need and do not
 * have (no row for a patch that neither reflects nor lets its twin's light
 * through; a back hemi-cube only behind a transmitting patch), after the
 * estimate from sample rows.  The progressive solver needs the same rows
 * but asks for them as it shoots: here it gets only the sample and the
 * estimate (and a refusal below its row store's least). */
static int compute_missing_rows(run *c, const sv_system *all, rad_error *err)
{
    const rad_solution *s = c->s;
    const rad_solve_options *opt = c->opt;
    const uint32_t n = s->mesh->patch_count;
    const int progressive = opt->solver.method == SV_PROGRESSIVE && !opt->all_rows;
    uint32_t *missing = malloc(((size_t)n + 1) * sizeof *missing);
    if (!missing)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    uint32_t count = 0;
    for (uint32_t i = 0; i < n; i++)
        if (!s->F->row_done[i] && (opt->all_rows || sv_row_needed(all, i)))
            missing[count++] = i;
    /* A few rows spread over the patches first, to measure what the rest
     * will take (they stay: the solve needs them; a journal keeps them like
     * any row, and a resumed run samples among the rows still missing, so
     * none is computed twice). */
    uint32_t sample[SAMPLE_ROOM], k = 0, longest = 0;
    if (opt->progress_stage && count && !progressive)
        opt->progress_stage(opt->hemicube.progress_user, "form factors");
    int rc = sample_rows(c, missing, count, progressive ? row_store_bytes(c) : 0, sample, &k, err);
    uint32_t left = 0;
    for (uint32_t q = 0; q < count; q++)
        if (!s->F->row_done[missing[q]])
            missing[left++] = missing[q];
    for (uint32_t q = 0; q < k; q++)
        longest = s->F->row_count[sample[q]] > longest ? s->F->row_count[sample[q]] : longest;
    rad_estimate e;
    if (!rc && count) {
        estimate(c, sample, k, left, &e);
        /* The progressive solver's row store holds F within the limit: the
         * part of F over it never adds to the peak. */
        if (progressive && e.matrix_bytes > c->max_memory) {
            const uint64_t over = e.matrix_bytes - c->max_memory;
            e.peak_bytes = e.peak_bytes > over ? e.peak_bytes - over : 0;
        }
        if (opt->on_estimate)
            opt->on_estimate(opt->estimate_user, &e);
        rc = check_memory(c, &e, longest, err);
    }
    if (!rc && !progressive)
        rc = compute_rows(c, missing, left, err);
    free(missing);
    return rc;
}

/* The stage "direct light": renders every punctual light whose per-patch
 * power the solution does not hold yet, on the same engine as the rows. */
static int shoot_lights(run *c, rad_error *err)
{
    rad_solution *s = c->s;
    const rad_scene *sc = s->scene;
    uint32_t n = s->mesh->patch_count;
    uint32_t R = rad_light_resolution(c->opt);
    double *power = NULL;
    int rc = RAD_OK;
    for (uint32_t l = 0; l < sc->light_count && !rc; l++) {
        if (s->light_power[l].present)
            continue;
        double t0 = rad_seconds();
        if (!power && !(power = malloc(((size_t)n + 1) * sizeof *power)))
            return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", sc->source);
        hc_light hl = light_for_hemicube(&sc->lights[l]);
        rc = start_hemicube(c, err);
        if (!rc)
            rc = hc_light_power(c->hc, &hl, R, power, err);
        if (!rc)
            rc = rad_solution_set_light_power(s, l, power, err);
        if (!rc)
            c->lights_computed++;
        c->ff_seconds += rad_seconds() - t0;
    }
    free(power);
    return rc;
}

/* The source term of the solve, E + ρ H_d (+ τ H_d of the twin, through a
 * sheet), n × bands into *out; NULL (use E) when the scene has no punctual
 * lights.  Caller owns *out. */
static int source_term(const rad_solution *s, const double *tau, double **out, rad_error *err)
{
    *out = NULL;
    if (!s->scene->light_count)
        return RAD_OK;
    const uint32_t n = s->mesh->patch_count, nb = s->band_count;
    const size_t count = (size_t)n * nb;
    double *Hd = malloc((count + 1) * sizeof *Hd);
    double *src = malloc((count + 1) * sizeof *src);
    int rc = (!src || !Hd) ? rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source)
                           : rad_solution_direct_irradiance(s, Hd, err);
    for (uint32_t i = 0; !rc && i < n; i++) {
        uint32_t t = tau ? s->mesh->twin[i] : RAD_NONE;
        for (uint32_t b = 0; b < nb; b++) {
            size_t k = (size_t)i * nb + b;
            src[k] = s->emission[k] + s->rho[k] * Hd[k] +
                     (t != RAD_NONE ? tau[k] * Hd[(size_t)t * nb + b] : 0.0);
        }
    }
    free(Hd);
    if (rc)
        free(src);
    else
        *out = src;
    return rc;
}

/* The progressive solve's record into s->progress (NULL for the other
 * solvers); RAD_ERR_NOMEM only. */
static int keep_progress(run *c, const sv_stats *st, rad_error *err)
{
    rad_solution *s = c->s;
    rad_progress_destroy(s->progress);
    s->progress = NULL;
    if (c->opt->solver.method != SV_PROGRESSIVE)
        return RAD_OK;
    rad_progress *p = rad_progress_create(c->preview_count);
    if (!p)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    if (c->preview_count)
        memcpy(p->previews, c->previews, c->preview_count * sizeof *p->previews);
    p->shots = st->iterations;
    p->unshot = st->estimated_error;
    p->converged = st->converged;
    p->rows_recomputed = st->rows_recomputed;
    p->rows_dropped = st->rows_dropped;
    p->preview_seconds = st->preview_seconds;
    s->progress = p;
    return RAD_OK;
}

/* One warning line when the iteration limit stopped the solve first (not
 * when the caller's on_preview did). */
static void warn_unconverged(const run *c, const sv_options *so, const sv_stats *st)
{
    const rad_solution *s = c->s;
    if (st->converged || st->stopped)
        return;
    const double tol = so->tolerance > 0 ? so->tolerance : SV_DEFAULT_TOLERANCE;
    if (so->method == SV_PROGRESSIVE)
        rad_warn(c->opt->warn, c->opt->warn_user,
                 "%s: solve: progressive: the shot limit (%u) stopped it with %.3g of the emitted "
                 "power unshot, above the tolerance %g; raise --max-iterations",
                 s->scene->source, st->iterations, st->estimated_error, tol);
    else
        rad_warn(c->opt->warn, c->opt->warn_user,
                 "%s: solve: %s: the sweep limit (%u) stopped it at an estimated error of %.3g, "
                 "above the tolerance %g; raise --max-iterations",
                 s->scene->source, sv_method_name(so->method), st->iterations,
                 st->estimated_error, tol);
}

/* The solver's options for this run: the caller's, with the pipeline's
 * callbacks (rows in batches, emitters' exact columns, logged previews) and
 * its memory budget. */
static sv_options solver_options(run *c)
{
    sv_options so = c->opt->solver;
    so.need_rows = need_rows;
    so.need_column = need_column;
    so.on_preview = c->opt->on_preview ? on_preview : NULL;
    so.user = c;
    so.max_matrix_bytes = row_store_bytes(c);
    return so;
}

/* B for every band with the source E into s->B, by the options `so` (one
 * band, copied, when the scene is grey).  The solver's messages are given
 * the scene's name. */
static int solve_bands(run *c, const sv_system *all, const double *E, const sv_options *so,
                       sv_stats *st, rad_error *err)
{
    rad_solution *s = c->s;
    const uint32_t n = s->mesh->patch_count, nbands = s->band_count;
    const uint32_t nb = rad_solution_is_grey(s) ? 1 : nbands;
    sv_system sys = *all;
    sys.bands = nb;
    sys.emission = E;
    double *area = malloc(((size_t)n + 1) * sizeof *area);
    uint32_t *group = malloc(((size_t)n + 1) * sizeof *group);
    double *grey = nb < nbands ? malloc(((size_t)n * 4 + 1) * sizeof *grey) : NULL;
    free(c->preview_B);
    c->preview_B = NULL;
    if (nb < nbands && so->on_preview)
        c->preview_B = malloc(((size_t)n * nbands + 1) * sizeof *c->preview_B);
    if (!area || !group || (nb < nbands && !grey) ||
        (nb < nbands && so->on_preview && !c->preview_B)) {
        free(area);
        free(group);
        free(grey);
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    }
    if (grey) { /* band 0 of each patch, packed: ρ, E, τ, then room for B */
        for (uint32_t i = 0; i < n; i++) {
            grey[i] = s->rho[(size_t)i * nbands];
            grey[n + i] = E[(size_t)i * nbands];
            grey[2 * (size_t)n + i] = all->tau ? all->tau[(size_t)i * nbands] : 0.0;
        }
        sys.rho = grey;
        sys.emission = grey + n;
        sys.tau = all->tau ? grey + 2 * (size_t)n : NULL;
    }
    for (uint32_t i = 0; i < n; i++) {
        area[i] = s->mesh->patches[i].area;
        group[i] = s->mesh->patches[i].polygon;
    }
    sys.area = area;
    sys.group = group;
    double *B = grey ? grey + 3 * (size_t)n : s->B;
    c->quiet_rows = so->method == SV_PROGRESSIVE;
    int rc = sv_solve(&sys, so, B, st, err);
    c->quiet_rows = 0;
    if (rc && err && strncmp(err->message, "solver: ", 8) == 0) {
        /* FILE: WHERE: WHAT */
        rad_error e = *err;
        rad_fail(err, rc, "%s: %s", s->scene->source, e.message);
    }
    for (uint32_t i = 0; grey && !rc && i < n; i++)
        for (uint32_t b = 0; b < nbands; b++)
            s->B[(size_t)i * nbands + b] = B[i];
    free(area);
    free(group);
    free(grey);
    return rc;
}

/* The stage "solve": B for every band with the source E; the progressive
 * solver pulls rows as it shoots, and the time it spends in the hemi-cube
 * meanwhile counts as form factors, its previews as neither. */
static int solve_patches(run *c, const sv_system *all, const double *E, rad_error *err)
{
    rad_solution *s = c->s;
    const sv_options so = solver_options(c);
    sv_stats st = {0};
    const double t0 = rad_seconds(), ff0 = c->ff_seconds;
    c->solve_t0 = t0;
    int rc = solve_bands(c, all, E, &so, &st, err);
    /* Rows and columns computed during the solve are form-factor time, the
     * previews' rendering nobody's; never below 0 (a finished solve must
     * stay saveable whatever the clock did). */
    const double solve_seconds = rad_seconds() - t0 - (c->ff_seconds - ff0) - st.preview_seconds;
    if (!rc)
        rc = keep_progress(c, &st, err);
    if (rc)
        return rc;
    warn_unconverged(c, &so, &st);
    snprintf(s->solver, sizeof s->solver, "%s", sv_method_name(so.method));
    s->tolerance = so.tolerance > 0 ? so.tolerance : SV_DEFAULT_TOLERANCE;
    s->iterations = st.iterations;
    s->residual = st.residual;
    s->stages[RAD_STAGE_SOLVE].seconds = solve_seconds > 0.0 ? solve_seconds : 0.0;
    s->stages[RAD_STAGE_SOLVE].reused = 0;
    return RAD_OK;
}

/* F's entries freed (rad_solution_release_matrix) when nothing left in the
 * run reads them: one light group at most, whose stored response is the
 * solution itself (more need F for their solves, which come after).  H of
 * the current B is taken first, into s->irradiance: the writer and that
 * response need it.  The caller knows that a file holds the entries.  A
 * failure only keeps F. */
static void release_entries(run *c)
{
    rad_solution *s = c->s;
    const uint32_t n = s->mesh->patch_count;
    uint32_t *pg = malloc(((size_t)n + 1) * sizeof *pg);
    uint32_t *lg = malloc(((size_t)s->scene->light_count + 1) * sizeof *lg);
    double *H = malloc(((size_t)n * s->band_count + 1) * sizeof *H);
    uint32_t K = 2;
    rad_error ignored; /* a failure only keeps F */
    if (pg && lg && H && rad_basis_groups(s, pg, lg, &K, &ignored) == RAD_OK && K <= 1 &&
        rad_solution_irradiance(s, H, &ignored) == RAD_OK) {
        free(s->irradiance);
        s->irradiance = H;
        H = NULL;
        rad_solution_release_matrix(s);
    }
    free(pg);
    free(lg);
    free(H);
}

/* A stored element mesh gathered again from the new patch solution through
 * its stored rows (no hemi-cube).  What the gather reads of F is taken
 * first; then F's entries go when the options allow it (release_matrix) and
 * the solution's file holds them, and only then are the elements' rows read
 * if they were left out (RAD_PART_ELEMENT_ROWS): F and the rows are never
 * in memory together.  Reading them counts as loading, the rest as
 * solving. */
static int gather_elements(run *c, rad_error *err)
{
    rad_solution *s = c->s;
    const double t0 = rad_seconds();
    double *Hi = NULL;
    int rc = rad_elements_patch_indirect(s, s->elements, &Hi, err);
    if (!rc && c->opt->release_matrix && rad_solution_matrix_in_file(s))
        release_entries(c);
    const double t1 = rad_seconds();
    if (!rc)
        rc = rad_solution_load_element_rows(s, err);
    const double t2 = rad_seconds();
    if (!rc)
        rc = rad_elements_gather_from(s, s->elements, Hi, err);
    free(Hi);
    s->elements->rows_computed = 0;
    s->stages[RAD_STAGE_LOAD].seconds += t2 - t1;
    s->stages[RAD_STAGE_SOLVE].seconds += rad_seconds() - t2 + t1 - t0;
    return rc;
}

/* rad_resolve on a run whose engine the caller may reuse afterwards. */
static int resolve(run *c, rad_error *err)
{
    rad_solution *s = c->s;
    const uint32_t n = s->mesh->patch_count;
    double *tau = NULL, *src = NULL;
    /* ρ or E may have changed: the stored light responses go now, before
     * anything can fail, and are made again once the solution is final. */
    rad_basis_destroy(s->basis);
    s->basis = NULL;
    if (!s->F->entries_loaded)
        return rad_fail(err, RAD_ERR_USAGE,
                        "%s: the form factors were not read (rad_solution_load_matrix)",
                        s->scene->source);
    int rc = patch_tau(s, &tau, err);
    if (rc)
        return rc;
    const sv_system all = {.n = n, .bands = s->band_count, .F = s->F, .rho = s->rho,
                           .emission = s->emission, .tau = tau, .twin = tau ? s->mesh->twin : NULL};

    /* Form factors: the missing rows the gathering solvers need. */
    rc = compute_missing_rows(c, &all, err);

    /* Direct light: the punctual lights' Φ not yet stored. */
    if (!rc)
        rc = shoot_lights(c, err);

    /* Solve: B for every band from the source E + ρ H_d (+ τ H_d of the twin). */
    if (!rc)
        rc = source_term(s, tau, &src, err);
    if (!rc)
        rc = solve_patches(c, &all, src ? src : s->emission, err);

    if (!rc && s->elements)
        rc = gather_elements(c, err);
    free(src);
    free(tau);

    s->rows_computed = c->rows_computed;
    s->lights_computed = c->lights_computed;
    s->stages[RAD_STAGE_FORM_FACTORS].seconds = c->ff_seconds;
    s->stages[RAD_STAGE_FORM_FACTORS].reused = (c->rows_computed == 0 && c->lights_computed == 0);
#if RAD_DEBUG
    if (!rc) {
        RAD_ASSERT(rad_matrix_check(s->F, NULL) == RAD_OK);
        for (size_t k = 0; k < (size_t)n * s->band_count; k++)
            RAD_ASSERT(isfinite(s->B[k]) && s->B[k] >= 0.0);
    }
#endif
    return rc;
}

/* ------------------------------------------------ stored light responses */

/* What rad_basis_make's solves share: the run, and τ and the system of
 * the solution's patches (prepare). */
typedef struct group_solve {
    run *c;
    double *tau;
    sv_system all;
} group_solve;

/* rad_group_solver.prepare: τ and the system, and whether F holds every
 * row a Gauss-Seidel solve of s needs. */
static int prepare_groups(void *user, const rad_solution *s, int *rows_ready, rad_error *err)
{
    group_solve *gs = user;
    int rc = patch_tau(s, &gs->tau, err);
    if (rc)
        return rc;
    gs->all = (sv_system){.n = s->mesh->patch_count, .bands = s->band_count, .F = s->F,
                          .rho = s->rho, .emission = s->emission, .tau = gs->tau,
                          .twin = gs->tau ? s->mesh->twin : NULL};
    *rows_ready = 1;
    for (uint32_t i = 0; i < s->mesh->patch_count; i++)
        if (!s->F->row_done[i] && sv_row_needed(&gs->all, i))
            *rows_ready = 0;
    return RAD_OK;
}

/* rad_group_solver.solve: the patches for s's current sources (one light
 * group's), by Gauss-Seidel on the stored rows with the solve's tolerance. */
static int solve_sources(void *user, rad_solution *s, double *residual, rad_error *err)
{
    group_solve *gs = user;
    double *src = NULL;
    int rc = source_term(s, gs->tau, &src, err);
    sv_options so = solver_options(gs->c);
    so.method = SV_GAUSS_SEIDEL;
    so.tolerance = s->tolerance;
    so.on_preview = NULL;
    sv_stats st = {0};
    if (!rc)
        rc = solve_bands(gs->c, &gs->all, src ? src : s->emission, &so, &st, err);
    free(src);
    *residual = st.residual;
    return rc;
}

/* The stored light responses of s's final B and elements (rad_basis_make,
 * relight.h), the groups solved on this run's solver.  The time counts as
 * solving. */
static int make_basis(run *c, rad_error *err)
{
    const double t0 = rad_seconds();
    group_solve gs = {.c = c};
    const rad_group_solver solver = {.prepare = prepare_groups, .solve = solve_sources,
                                     .user = &gs};
    int rc = rad_basis_make(c->s, &solver, err);
    free(gs.tau);
    c->s->stages[RAD_STAGE_SOLVE].seconds += rad_seconds() - t0;
    return rc;
}

int rad_resolve(rad_solution *s, const rad_solve_options *opt, rad_error *err)
{
    static const rad_solve_options defaults;
    run c;
    run_begin(&c, s, opt ? opt : &defaults);
    int rc = resolve(&c, err);
    if (!rc)
        rc = make_basis(&c, err);
    run_end(&c);
    return rc;
}

/* Do the options ask for elements (adaptive by default, or uniform)? */
static int refines(const rad_solve_options *opt)
{
    return !(opt->refine_threshold < 0.0) || opt->element_levels;
}

/* Refinement has read what it needs of F's entries (rad_refine_options.
 * entries_read).  When the solve's file holds every row (the journal), the
 * entries go as release_entries allows: the element rows are then computed
 * in the memory F held (8k patches: the solve's peak 205 -> 146 MiB, 1.54
 * -> 1.09 × F). */
static void release_rows(void *user)
{
    run *c = user;
    if (rad_journal_holds(c->opt->journal, c->s->F))
        release_entries(c);
}

/* Refinement on the run's engine (started if the solve reused every row):
 * the element hemi-cubes count as form-factor time. */
static int refine(run *c, rad_error *err)
{
    rad_solution *s = c->s;
    const rad_solve_options *opt = c->opt;
    const uint32_t nl = s->scene->light_count;
    const double t0 = rad_seconds();
    rad_basis_destroy(s->basis); /* the elements change: made again by the caller */
    s->basis = NULL;
    hc_light *lights = malloc(((size_t)nl + 1) * sizeof *lights);
    if (!lights)
        return rad_fail(err, RAD_ERR_NOMEM, "%s: out of memory", s->scene->source);
    for (uint32_t l = 0; l < nl; l++)
        lights[l] = light_for_hemicube(&s->scene->lights[l]);
    const rad_refine_options ro = {.threshold = opt->refine_threshold,
                                   .min_element_size = opt->min_element_size,
                                   .levels = opt->element_levels,
                                   .max_elements = opt->mesh.max_patches,
                                   .lights = lights,
                                   .light_resolution = rad_light_resolution(opt),
                                   .element_hemicubes = opt->element_hemicubes,
                                   .whole_contacts = opt->whole_contacts,
                                   .entries_read = release_rows,
                                   .entries_read_user = c};
    int rc = refines(opt) ? start_hemicube(c, err) : RAD_OK;
    if (!rc && refines(opt) && opt->progress_stage)
        opt->progress_stage(opt->hemicube.progress_user, "elements");
    if (!rc)
        rc = rad_elements_refine(s, c->hc, &ro, err);
    free(lights);
    s->stages[RAD_STAGE_FORM_FACTORS].seconds += rad_seconds() - t0;
    return rc;
}

int rad_refine_solution(rad_solution *s, const rad_solve_options *opt, rad_error *err)
{
    static const rad_solve_options defaults;
    run c;
    run_begin(&c, s, opt ? opt : &defaults);
    int rc = refine(&c, err);
    if (!rc)
        rc = make_basis(&c, err);
    run_end(&c);
    return rc;
}

int rad_solve_scene(rad_scene *scene, const rad_solve_options *opt, rad_solution **out,
                    rad_error *err)
{
    static const rad_solve_options defaults;
    if (!opt)
        opt = &defaults;
    *out = NULL;

    /* Mesh: polygons -> conforming patches (both sides of a transmitting sheet). */
    double t0 = rad_seconds();
    rad_mesh *mesh = NULL;
    int rc = rad_mesh_build(scene, &opt->mesh, &mesh, err);
    if (rc) {
        rad_scene_destroy(scene);
        return rc;
    }
    double mesh_seconds = rad_seconds() - t0;

    /* Solution: ρ and E per patch from the materials, an empty matrix. */
    rad_solution *s = NULL;
    rc = rad_solution_create(scene, mesh, &s, err);
    if (rc)
        return rc;
    /* The size the mesher used: the option, else the scene's default (a
     * polygon's own subdivision parameters aside), so `report` shows it. */
    s->patch_size = rad_mesh_patch_size(scene, &opt->mesh);
    s->stages[RAD_STAGE_MESH].seconds = mesh_seconds;

    run c;
    run_begin(&c, s, opt);
    /* Rows kept from an earlier run of the same mesh and options. */
    if (opt->journal) {
        uint64_t key = 0;
        rc = rows_key(&c, &key, err);
        if (!rc)
            rc = rad_journal_attach(opt->journal, s->F, key, err);
    }
    /* Form factors and solve. */
    if (!rc)
        rc = resolve(&c, err);

    /* Elements: split where what is drawn misses what finer elements
     * gather, from the patch solution (hemi-cubes at the elements' centres,
     * on the same engine as the rows). */
    if (!rc && refines(opt))
        rc = refine(&c, err);
    /* Stored light responses, for relights that only scale the lights. */
    if (!rc)
        rc = make_basis(&c, err);
    run_end(&c);
    if (rc) {
        if (opt->journal)
            rad_journal_detach(opt->journal); /* its rows stay in the file */
        rad_solution_destroy(s);
        return rc;
    }
    *out = s;
    return RAD_OK;
}

int rad_solve_scene_file(const char *path, const rad_solve_options *opt, rad_solution **out,
                         rad_error *err)
{
    static const rad_solve_options defaults;
    if (!opt)
        opt = &defaults;
    *out = NULL;

    /* Load: glTF or polygon file -> validated scene. */
    double t0 = rad_seconds();
    rad_scene *scene = NULL;
    int rc = rad_scene_load(path, &opt->load, &scene, err);
    if (rc)
        return rc;
    double load_seconds = rad_seconds() - t0;

    /* Mesh, form factors, solve. */
    rc = rad_solve_scene(scene, opt, out, err);
    if (!rc)
        (*out)->stages[RAD_STAGE_LOAD].seconds = load_seconds;
    return rc;
}

/* The renderer's camera for scene camera c (the size is the caller's). */
static void scene_camera(const rad_camera *c, rn_camera *cam)
{
    cam->eye = c->eye, cam->target = c->target, cam->up = c->up, cam->yfov_deg = c->yfov_deg;
    cam->orthographic = c->orthographic;
    cam->ymag = c->ymag;
}

int rad_camera_from_scene(const rad_scene *scene, const char *name, uint32_t width,
                          uint32_t height, rn_camera *cam, rad_error *err)
{
    memset(cam, 0, sizeof *cam);
    cam->width = width;
    cam->height = height;
    if (name && *name) {
        uint32_t k = rad_scene_find_camera(scene, name);
        if (k == RAD_NONE) {
            char list[512] = "";
            for (uint32_t c = 0; c < scene->camera_count; c++) {
                size_t used = strlen(list);
                snprintf(list + used, sizeof list - used, "%s'%s'", c ? ", " : "",
                         scene->cameras[c].name);
            }
            return rad_fail(err, RAD_ERR_NOTFOUND, "%s: camera '%s' not found (cameras: %s)",
                            scene->source, name, scene->camera_count ? list : "none");
        }
        scene_camera(&scene->cameras[k], cam);
        return RAD_OK;
    }
    if (scene->camera_count) {
        scene_camera(&scene->cameras[0], cam);
        return RAD_OK;
    }
    /* No camera: look at the bounds' centre from -z, far enough to see it all. */
    rad_vec3 lo, hi;
    if (!rad_scene_bounds(scene, &lo, &hi))
        return rad_fail(err, RAD_ERR_INVALID, "%s: empty scene", scene->source);
    rad_vec3 centre = rad_scale(rad_add(lo, hi), 0.5);
    double radius = 0.5 * rad_length(rad_sub(hi, lo));
    cam->yfov_deg = 45.0;
    cam->target = centre;
    cam->eye = rad_add(centre, rad_v3(0, 0, -radius / tan(22.5 * M_PI / 180.0) - radius));
    cam->up = rad_v3(0, 1, 0);
    return RAD_OK;
}
