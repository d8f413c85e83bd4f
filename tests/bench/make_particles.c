/* make_particles: one deterministic particle set for the spraycoat / LAMMPS side-by-side benchmark
 * (scripts/bench_lammps.sh).
 *
 *   make_particles OUT_DIR [N]
 *
 * Places N non-overlapping spheres (diameter uniform in [D_MIN, D_MAX]) in a cylinder of radius
 * CLOUD_RADIUS around the z axis, Z_LO <= z <= Z_HI, all moving towards the target plane z = Z_WALL
 * (vz uniform in V_MEAN +- V_SPREAD, vx and vy uniform in +-V_LATERAL, no spin).  The target is above
 * the cloud, so particles fly in +z, as in spraycoat (nozzle at z = 0, target at z = standoff).
 *
 * Writes OUT_DIR/particles.csv (spraycoat, injection = file: header x,y,z,vx,vy,vz,wx,wy,wz,d) and
 * OUT_DIR/particles.data (LAMMPS read_data, atom_style sphere, units si), with exactly the same numbers,
 * and prints key=value lines on stdout for the driver script: the set's actual extremes and the Hertz
 * contact duration that sets LAMMPS's time step.
 *
 * The random numbers come from splitmix64 with a fixed seed, so the set is the same on every machine. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define SEED         20240611u
#define N_DEFAULT    20000
#define D_MIN        20e-6  /* m */
#define D_MAX        60e-6  /* m */
#define CLOUD_RADIUS 2.5e-3 /* m: the cloud is 5 mm wide */
#define Z_LO         4.5e-3 /* m: 8 mm of room behind the target, so rebounding particles stay at z > 0 */
#define Z_HI         7.5e-3 /* m */
#define Z_WALL       8.0e-3 /* m: target plane (spraycoat standoff) */
#define V_MEAN       50.0   /* m/s, towards the target */
#define V_SPREAD     5.0    /* m/s */
#define V_LATERAL    1.0    /* m/s */
#define MAX_ATTEMPTS 100000

/* Copper-like material, the same for both codes. */
#define RHO         8960.0 /* kg/m3 */
#define YOUNG       120e9  /* Pa */
#define POISSON     0.34
#define RESTITUTION 0.8

static uint64_t rng_state = SEED;

static double uniform(void)
{
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53; /* [0, 1) */
}

static double between(double lo, double hi)
{
    return lo + (hi - lo) * uniform();
}

/* Uniform grid of cells of size >= D_MAX over the cloud's bounding box; each cell lists its particles. */
struct grid {
    int nx, ny, nz;
    double cell, x0, y0, z0;
    int *head, *next;
};

static int cell_index(const struct grid *g, int i, int j, int k)
{
    return (k * g->ny + j) * g->nx + i;
}

static void cell_of(const struct grid *g, const double *x, int c[3])
{
    c[0] = (int)((x[0] - g->x0) / g->cell);
    c[1] = (int)((x[1] - g->y0) / g->cell);
    c[2] = (int)((x[2] - g->z0) / g->cell);
    if (c[0] >= g->nx)
        c[0] = g->nx - 1;
    if (c[1] >= g->ny)
        c[1] = g->ny - 1;
    if (c[2] >= g->nz)
        c[2] = g->nz - 1;
}

static int overlaps_any(const struct grid *g, const double *pos, const double *diam, const double *x, double d)
{
    int c[3];
    cell_of(g, x, c);
    for (int k = c[2] - 1; k <= c[2] + 1; k++)
        for (int j = c[1] - 1; j <= c[1] + 1; j++)
            for (int i = c[0] - 1; i <= c[0] + 1; i++) {
                if (i < 0 || j < 0 || k < 0 || i >= g->nx || j >= g->ny || k >= g->nz)
                    continue;
                for (int p = g->head[cell_index(g, i, j, k)]; p >= 0; p = g->next[p]) {
                    double dx = pos[3 * p] - x[0], dy = pos[3 * p + 1] - x[1], dz = pos[3 * p + 2] - x[2];
                    double contact = 0.5 * (diam[p] + d);
                    if (dx * dx + dy * dy + dz * dz < contact * contact)
                        return 1;
                }
            }
    return 0;
}

/* Hertz contact duration, tc = 2.87 (m*^2 / (R* E*^2 v))^(1/5) (Johnson 1985). */
static double hertz_tc(double m_eff, double r_eff, double e_eff, double v)
{
    return 2.87 * pow(m_eff * m_eff / (r_eff * e_eff * e_eff * v), 0.2);
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: %s OUT_DIR [N]\n", argv[0]);
        return 2;
    }
    long n = argc == 3 ? strtol(argv[2], NULL, 10) : N_DEFAULT;
    if (n < 1 || n > 10000000) {
        fprintf(stderr, "make_particles: N = %s out of range\n", argv[2]);
        return 2;
    }
    double *pos = malloc((size_t)n * 3 * sizeof *pos), *vel = malloc((size_t)n * 3 * sizeof *vel);
    double *diam = malloc((size_t)n * sizeof *diam);
    struct grid g = {.cell = D_MAX, .x0 = -CLOUD_RADIUS, .y0 = -CLOUD_RADIUS, .z0 = Z_LO};
    g.nx = g.ny = (int)ceil(2 * CLOUD_RADIUS / g.cell);
    g.nz = (int)ceil((Z_HI - Z_LO) / g.cell);
    size_t cells = (size_t)g.nx * g.ny * g.nz;
    g.head = malloc(cells * sizeof *g.head);
    g.next = malloc((size_t)n * sizeof *g.next);
    if (!pos || !vel || !diam || !g.head || !g.next) {
        fprintf(stderr, "make_particles: out of memory\n");
        return 1;
    }
    for (size_t c = 0; c < cells; c++)
        g.head[c] = -1;

    double d_lo = INFINITY, d_hi = 0, v_hi = 0, volume = 0;
    for (long p = 0; p < n; p++) {
        double d = between(D_MIN, D_MAX), r = 0.5 * d, x[3];
        long attempt = 0;
        do {
            if (++attempt > MAX_ATTEMPTS) {
                fprintf(stderr, "make_particles: no free place for particle %ld: the cloud is too dense\n", p);
                return 1;
            }
            double rr = (CLOUD_RADIUS - r) * sqrt(uniform()), phi = 2 * M_PI * uniform();
            x[0] = rr * cos(phi);
            x[1] = rr * sin(phi);
            x[2] = between(Z_LO + r, Z_HI - r);
        } while (overlaps_any(&g, pos, diam, x, d));
        memcpy(pos + 3 * p, x, sizeof x);
        diam[p] = d;
        vel[3 * p] = between(-V_LATERAL, V_LATERAL);
        vel[3 * p + 1] = between(-V_LATERAL, V_LATERAL);
        vel[3 * p + 2] = between(V_MEAN - V_SPREAD, V_MEAN + V_SPREAD);
        int c[3];
        cell_of(&g, x, c);
        int ci = cell_index(&g, c[0], c[1], c[2]);
        g.next[p] = g.head[ci];
        g.head[ci] = (int)p;
        double speed =
            sqrt(vel[3 * p] * vel[3 * p] + vel[3 * p + 1] * vel[3 * p + 1] + vel[3 * p + 2] * vel[3 * p + 2]);
        d_lo = fmin(d_lo, d);
        d_hi = fmax(d_hi, d);
        v_hi = fmax(v_hi, speed);
        volume += M_PI / 6 * d * d * d;
    }

    char path[4096];
    snprintf(path, sizeof path, "%s/particles.csv", argv[1]);
    FILE *csv = fopen(path, "w");
    snprintf(path, sizeof path, "%s/particles.data", argv[1]);
    FILE *data = fopen(path, "w");
    if (!csv || !data) {
        fprintf(stderr, "make_particles: cannot write into %s\n", argv[1]);
        return 1;
    }
    fprintf(csv, "x,y,z,vx,vy,vz,wx,wy,wz,d\n");
    for (long p = 0; p < n; p++)
        fprintf(csv, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,0,0,0,%.17g\n", pos[3 * p], pos[3 * p + 1], pos[3 * p + 2],
                vel[3 * p], vel[3 * p + 1], vel[3 * p + 2], diam[p]);
    /* LAMMPS box: the cloud plus a margin, up to the wall.  The input uses shrink-wrapped boundaries with
     * these bounds as the minimum (boundary m m m), so particles that scatter never get lost. */
    double margin = D_MAX;
    fprintf(data, "spraycoat/LAMMPS benchmark particles (tests/bench/make_particles.c, seed %u)\n\n", SEED);
    fprintf(data, "%ld atoms\n1 atom types\n\n", n);
    fprintf(data, "%.17g %.17g xlo xhi\n", -CLOUD_RADIUS - margin, CLOUD_RADIUS + margin);
    fprintf(data, "%.17g %.17g ylo yhi\n", -CLOUD_RADIUS - margin, CLOUD_RADIUS + margin);
    fprintf(data, "%.17g %.17g zlo zhi\n\n", 0.0, Z_WALL + margin);
    fprintf(data, "Atoms # sphere\n\n");
    for (long p = 0; p < n; p++)
        fprintf(data, "%ld 1 %.17g %.17g %.17g %.17g %.17g\n", p + 1, diam[p], RHO, pos[3 * p], pos[3 * p + 1],
                pos[3 * p + 2]);
    fprintf(data, "\nVelocities\n\n");
    for (long p = 0; p < n; p++)
        fprintf(data, "%ld %.17g %.17g %.17g 0 0 0\n", p + 1, vel[3 * p], vel[3 * p + 1], vel[3 * p + 2]);
    if (fclose(csv) != 0 || fclose(data) != 0) {
        fprintf(stderr, "make_particles: write error in %s\n", argv[1]);
        return 1;
    }

    /* The shortest Hertz contact: the smallest particle at the largest relative speed.  Particle-particle:
     * two smallest spheres meeting head-on at twice the largest speed (an incoming particle against a
     * rebounding one), E* = E / (2 (1 - nu^2)) (LAMMPS's mixing for equal materials).  Particle-wall: the
     * smallest sphere at the largest speed; this LAMMPS version gives the wall E / (2 (1 - nu)) (stiffer),
     * which is the value used here. */
    double m_min = RHO * M_PI / 6 * d_lo * d_lo * d_lo;
    double tc_pp = hertz_tc(0.5 * m_min, 0.25 * d_lo, YOUNG / (2 * (1 - POISSON * POISSON)), 2 * v_hi);
    double tc_pw = hertz_tc(m_min, 0.5 * d_lo, YOUNG / (2 * (1 - POISSON)), v_hi);
    double tc = fmin(tc_pp, tc_pw);
    double cloud_volume = M_PI * CLOUD_RADIUS * CLOUD_RADIUS * (Z_HI - Z_LO);
    printf("n=%ld\nd_min=%.6g\nd_max=%.6g\nv_max=%.6g\n", n, d_lo, d_hi, v_hi);
    printf("solid_fraction=%.4g\n", volume / cloud_volume);
    printf("cloud_radius=%.6g\nz_lo=%.6g\nz_hi=%.6g\nz_wall=%.6g\n", CLOUD_RADIUS, Z_LO, Z_HI, Z_WALL);
    printf("v_mean=%.6g\nv_spread=%.6g\nv_lateral=%.6g\n", V_MEAN, V_SPREAD, V_LATERAL);
    printf("rho=%.6g\nyoung=%.6g\npoisson=%.6g\nrestitution=%.6g\n", RHO, YOUNG, POISSON, RESTITUTION);
    printf("tc_pp=%.6g\ntc_pw=%.6g\ntc=%.6g\n", tc_pp, tc_pw, tc);
    /* The slowest particle starting farthest from the wall reaches it after this long. */
    printf("t_last_arrival=%.6g\n", (Z_WALL - Z_LO - 0.5 * D_MIN) / (V_MEAN - V_SPREAD));
    free(pos);
    free(vel);
    free(diam);
    free(g.head);
    free(g.next);
    return 0;
}
