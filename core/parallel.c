/* Processes: MPI when built with SPRAYCOAT_MPI, else one process (core/parallel.h). */
#include "core/parallel.h"

#ifdef SPRAYCOAT_MPI
#include <mpi.h>

static MPI_Win task_window = MPI_WIN_NULL;
static int64_t *task_counter; /* on rank 0: the next task */

void parallel_init(int *argc, char ***argv)
{
    int provided;
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
}

void parallel_finalize(void)
{
    MPI_Finalize();
}

int parallel_rank(void)
{
    int rank;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    return rank;
}

int parallel_size(void)
{
    int size;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    return size;
}

int parallel_enabled(void)
{
    return 1;
}

void parallel_barrier(void)
{
    MPI_Barrier(MPI_COMM_WORLD);
}

int parallel_max_status(int status)
{
    int max;
    MPI_Allreduce(&status, &max, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return max;
}

int parallel_share_status(int status)
{
    MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
    return status;
}

void parallel_tasks_begin(void)
{
    MPI_Aint size = parallel_rank() == 0 ? (MPI_Aint)sizeof *task_counter : 0;
    MPI_Win_allocate(size, sizeof *task_counter, MPI_INFO_NULL, MPI_COMM_WORLD, &task_counter, &task_window);
    if (parallel_rank() == 0) {
        MPI_Win_lock(MPI_LOCK_EXCLUSIVE, 0, 0, task_window);
        *task_counter = 0;
        MPI_Win_unlock(0, task_window);
    }
    MPI_Barrier(MPI_COMM_WORLD);
}

int64_t parallel_task_next(void)
{
    const int64_t one = 1;
    int64_t task;
    MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, task_window);
    MPI_Fetch_and_op(&one, &task, MPI_INT64_T, 0, 0, MPI_SUM, task_window);
    MPI_Win_unlock(0, task_window);
    return task;
}

void parallel_tasks_end(void)
{
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Win_free(&task_window);
}

#else

static int64_t next_task;

void parallel_init(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
}
void parallel_finalize(void) {}
int parallel_rank(void)
{
    return 0;
}
int parallel_size(void)
{
    return 1;
}
int parallel_enabled(void)
{
    return 0;
}
void parallel_barrier(void) {}
int parallel_max_status(int status)
{
    return status;
}
int parallel_share_status(int status)
{
    return status;
}
void parallel_tasks_begin(void)
{
    next_task = 0;
}
int64_t parallel_task_next(void)
{
    return next_task++;
}
void parallel_tasks_end(void) {}

#endif
