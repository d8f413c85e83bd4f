/* What 2 threads can gain over 1 on this machine, for reading the per-core columns of `make bench`:
 *   compute: independent multiply-add chains in registers (no memory traffic), per thread;
 *   memory:  the STREAM triad a[i] = b[i] + s c[i] over arrays far larger than the caches.
 * A solver whose steps stream particle or point arrays through memory cannot scale better than the triad.
 * Prints one Markdown table; best of several repetitions (the machine may be shared).
 *   usage: machine_ceiling [MAX_THREADS]   (default 2) */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#define CHAINS         64                /* enough independent chains to fill the FP pipes */
#define COMPUTE_ROUNDS 20000000L         /* per thread */
#define TRIAD_DOUBLES  ((size_t)1 << 25) /* 256 MB per array */
#define REPEATS        5

/* Multiply-adds per second on `threads` threads, all doing the same work. */
static double compute_rate(int threads)
{
    double best = 0.0, sink = 0.0;
    for (int r = 0; r < REPEATS; r++) {
        double start = omp_get_wtime();
#pragma omp parallel num_threads(threads) reduction(+ : sink)
        {
            double a[CHAINS];
            for (int i = 0; i < CHAINS; i++)
                a[i] = 1.0 + i * 1e-3 + omp_get_thread_num();
            for (long k = 0; k < COMPUTE_ROUNDS; k++)
                for (int i = 0; i < CHAINS; i++)
                    a[i] = a[i] * 0.9999999 + 1e-7;
            for (int i = 0; i < CHAINS; i++)
                sink += a[i];
        }
        double rate = (double)threads * COMPUTE_ROUNDS * CHAINS / (omp_get_wtime() - start);
        best = rate > best ? rate : best;
    }
    if (sink == 0.0) /* keeps the loops from being optimised away */
        printf("?\n");
    return best;
}

/* Bytes per second of the triad (3 arrays of 8-byte values per element) on `threads` threads. */
static double triad_rate(int threads, double *a, const double *b, const double *c)
{
    double best = 0.0;
    for (int r = 0; r < REPEATS; r++) {
        double start = omp_get_wtime();
#pragma omp parallel for num_threads(threads) schedule(static)
        for (size_t i = 0; i < TRIAD_DOUBLES; i++)
            a[i] = b[i] + 1.5 * c[i];
        double rate = 3.0 * sizeof(double) * TRIAD_DOUBLES / (omp_get_wtime() - start);
        best = rate > best ? rate : best;
    }
    return best;
}

int main(int argc, char **argv)
{
    int max_threads = argc > 1 ? atoi(argv[1]) : 2;
    double *a = malloc(TRIAD_DOUBLES * sizeof *a), *b = malloc(TRIAD_DOUBLES * sizeof *b);
    double *c = malloc(TRIAD_DOUBLES * sizeof *c);
    if (max_threads < 1 || !a || !b || !c) {
        fprintf(stderr, "machine_ceiling: bad thread count or out of memory\n");
        return 1;
    }
    /* first touch on every thread count's schedule: pages land where the threads run */
#pragma omp parallel for num_threads(max_threads) schedule(static)
    for (size_t i = 0; i < TRIAD_DOUBLES; i++) {
        a[i] = 0.0;
        b[i] = 1.0;
        c[i] = 2.0;
    }
    double compute_one = compute_rate(1), triad_one = triad_rate(1, a, b, c);
    printf("| threads | multiply-adds/s | vs 1 thread | triad GB/s | vs 1 thread |\n");
    printf("| ------- | --------------- | ----------- | ---------- | ----------- |\n");
    for (int t = 1; t <= max_threads; t++) {
        double compute = t == 1 ? compute_one : compute_rate(t), triad = t == 1 ? triad_one : triad_rate(t, a, b, c);
        printf("| %7d | %15.3g | %10.2fx | %10.1f | %10.2fx |\n", t, compute, compute / compute_one, triad / 1e9,
               triad / triad_one);
    }
    free(a);
    free(b);
    free(c);
    return 0;
}
