/* coupling: from spray impacts to MPM seeds (the couple stage's sampling and placement, DESIGN.md "Coupling").
 *
 * Candidates are the first contacts of particles with the target or the deposit (one per particle: the impact a
 * particle makes when it arrives; its later bounces are not new arrivals).  N = runs * bodies_per_run seeds are
 * drawn by one of three rules:
 *   random      uniform over the candidates, without replacement;
 *   stratified  by diameter quantiles, then by speed quantiles inside each diameter stratum: seed k belongs to
 *               diameter stratum k mod n_d (n_d = ceil(sqrt(N)) strata of equal count), and inside it to one of
 *               the speed sub-strata of equal count, one per seed of that stratum; the seed is drawn uniformly
 *               from its sub-stratum;
 *   window      the candidates whose impact point lies in the square patch of side patch_size centred at
 *               (window_x, window_y) on the target, in order of arrival.
 * A drawn candidate whose flight through the gas layer does not reach the wall is replaced by the next one of its
 * stratum.  Seed k belongs to run k / bodies_per_run.
 *
 * Placement in the impact frame (substrate top z = 0, bodies above it moving towards -z): within a run, bodies in
 * order of arrival at the wall; lateral offsets are the wall positions relative to the patch centre (window) or to
 * the run's first arrival folded periodically into the patch (random, stratified: the draws come from anywhere on
 * the target, so only their spacing within the patch is kept); the first arrival touches the substrate and a later
 * one starts |v_z| (t - t_first) higher, at most max_gap, lifted further where it would overlap an earlier body. */
#ifndef SPRAYCOAT_COUPLING_COUPLE_H
#define SPRAYCOAT_COUPLING_COUPLE_H

#include <stddef.h>
#include <stdint.h>

#include "core/config.h"

enum couple_sample { COUPLE_RANDOM, COUPLE_STRATIFIED, COUPLE_WINDOW };

struct couple_config {
    enum couple_sample sample;
    long bodies_per_run, runs;
    double layer_thickness;          /* m */
    double stagnation_velocity;      /* m/s; NAN: from the jet at the layer's edge ("jet") */
    double rtol, atol;
    double patch_size, window_x, window_y, max_gap;   /* m */
    uint32_t seed;                   /* [run] seed */
};

extern const struct cfg_key couple_case_keys[];

int couple_config_load(const struct case_file *c, struct couple_config *cfg);

/* A candidate: the spray's impact (spray frame) and, once flown, its arrival at the wall. */
struct couple_candidate {
    int64_t impact_row, particle_id;
    double t, x[3], v[3], d, m;      /* the spray's first contact */
};

/* The strata of the sampling rule: every seed slot k (0 <= k < N) draws from stratum slot_stratum[k], whose
 * candidates (indices into the candidate array) are members[offset[s]] ... members[offset[s + 1] - 1] in the
 * order they are tried. */
struct couple_strata {
    size_t count;                    /* strata */
    size_t *offset;                  /* count + 1 */
    size_t *members;
    size_t *slot_stratum;            /* N */
};

/* Build the strata for `n` candidates and N = runs * bodies_per_run seeds.  SC_EINPUT (naming [couple] keys)
 * when the rule cannot give N seeds: fewer candidates than seeds, or fewer in the window. */
int couple_strata_build(const struct case_file *c, const struct couple_config *cfg,
                        const struct couple_candidate *candidates, size_t n, struct couple_strata *strata);
void couple_strata_free(struct couple_strata *strata);

/* One seed's arrival at the wall (spray frame) and, after placement, its body in the impact frame. */
struct couple_seed {
    size_t candidate;                /* index into the candidate array */
    size_t flight;                   /* row of its flight in couple.h5 /flight */
    double t_wall, x_wall[3], v_wall[3], d, m;
    int64_t run, body;
    double center[3], velocity[3];   /* impact frame */
};

/* Order the `count` seeds of one run by arrival and place them (the header's rules). */
void couple_place_run(const struct couple_config *cfg, struct couple_seed *seeds, size_t count);

/* The seeds of RUN_DIR/couple.h5 as bodies of the impact runs: run r has rows first[r] ... first[r + 1] - 1,
 * ordered by arrival.  SC_EIO when couple.h5 is missing or was made from another case. */
struct couple_bodies {
    size_t runs, count;
    size_t *first;                   /* runs + 1 */
    double *d, *center, *velocity;   /* count, 3 count, 3 count (impact frame) */
};
int couple_read_bodies(const char *run_dir, const struct case_file *c, struct couple_bodies *bodies);
void couple_bodies_free(struct couple_bodies *bodies);

#endif
