/* Processes: one, or several under MPI (a build with `make MPI=1`, SPRAYCOAT_MPI defined).
 *
 * spraycoat distributes whole tasks, not domains: the impact runs of a pipeline and the diameters of a vcrit
 * search.  Rank 0 does everything else (spray, couple, render, the run directory and the gathered output files);
 * the ranks share the run directory (a shared file system on a cluster).  Tasks are handed out dynamically: a
 * rank that finishes a task takes the next one from a counter held by rank 0 (one-sided MPI_Fetch_and_op), so
 * long and short tasks balance.  Every task's result is a file of its own, computed the same way whichever rank
 * runs it, so the outputs are the same bits as a single process's.  In a build without MPI these functions are
 * the one-process case: rank 0 of 1. */
#ifndef SPRAYCOAT_CORE_PARALLEL_H
#define SPRAYCOAT_CORE_PARALLEL_H

#include <stdint.h>

/* MPI_Init (with MPI_THREAD_FUNNELED: OpenMP threads inside a rank, MPI calls from the main thread). */
void parallel_init(int *argc, char ***argv);
void parallel_finalize(void);
int parallel_rank(void);
int parallel_size(void);
/* 1 when built with MPI. */
int parallel_enabled(void);
void parallel_barrier(void);
/* The largest status over the ranks (every rank returns it: an error or interruption on one rank ends all). */
int parallel_max_status(int status);
/* Rank 0's status, on every rank (after rank-0-only work). */
int parallel_share_status(int status);

/* A dynamic task counter: parallel_tasks_begin() by every rank (collective), then parallel_task_next() returns
 * 0, 1, 2, ... across all ranks, each value to exactly one rank, until it returns >= count; then
 * parallel_tasks_end() (collective). */
void parallel_tasks_begin(void);
int64_t parallel_task_next(void);
void parallel_tasks_end(void);

#endif
