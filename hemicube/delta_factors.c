/* delta_factors.c - hc_delta_form_factors: the delta form factors ΔF_q of
 * every pixel of a hemi-cube of resolution R, in the item-buffer atlas's
 * order (rows.c describes the atlas: the top face's R² pixels, then the
 * four half faces' R/2 × R each, bottom row at the horizon).
 *
 * Owns the one table a row's pixel sums weigh with; the caller computes it
 * once in hc_create, before the fork, and every worker reads the engine's
 * copy.  Invariant: the table written sums to 1 (normalised; the raw
 * pixel-centre sum is returned), so a fully covered cube gives Σ_j F_ij = 1.
 */
#include "hc_internal.h"

double hc_delta_form_factors(uint32_t resolution, double *out)
{
    uint32_t R = resolution;
    if (!out || !hc_resolution_ok(R))
        return 0.0;
    /* Cube of half-width 1: pixels are 2/R wide, ΔA = (2/R)², sampled at the
     * pixel centre (paper, Fig. 7). */
    double d = 2.0 / R, dA = d * d, sum = 0.0;
    size_t k = 0;
    for (uint32_t y = 0; y < R; y++)
        for (uint32_t x = 0; x < R; x++) {
            double px = -1.0 + (x + 0.5) * d, py = -1.0 + (y + 0.5) * d;
            double r2 = px * px + py * py + 1.0;
            out[k] = dA / (M_PI * r2 * r2);
            sum += out[k++];
        }
    for (int f = 0; f < 4; f++)
        for (uint32_t z = 0; z < R / 2; z++)
            for (uint32_t x = 0; x < R; x++) {
                double py = -1.0 + (x + 0.5) * d, pz = (z + 0.5) * d;
                double r2 = py * py + pz * pz + 1.0;
                out[k] = pz * dA / (M_PI * r2 * r2);
                sum += out[k++];
            }
    /* The pixel-centre rule misses the exact 1 by O(1/R²); normalising makes
     * a fully covered cube give Σ_j F_ij = 1 exactly, which the solver's
     * energy balance relies on. */
    for (size_t q = 0; q < k; q++)
        out[q] /= sum;
    return sum;
}
