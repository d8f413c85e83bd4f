/* coupling: the stages of a run and the run directory (DESIGN.md "Run directory"). */
#ifndef SPRAYCOAT_COUPLING_STAGES_H
#define SPRAYCOAT_COUPLING_STAGES_H

#include "core/config.h"

/* The registry of every case key the program accepts (NULL-terminated list of tables). */
extern const struct cfg_key *const spraycoat_registry[];

/* Create the run directory (and parents), lock it for this process (SC_EIO if another process holds it)
 * and write RUN_DIR/case.ini, the resolved case.  SC_EIO on failure. */
int run_dir_prepare(const char *run_dir, const struct case_file *c);

/* Check the spray stage's configuration (cross-key checks, input files) and, when run_dir is not NULL,
 * that its checkpoints there (if any) belong to this case, without writing anything. */
int spray_stage_validate(const struct case_file *c, const char *run_dir);

/* The spray stage: resume from the newest valid checkpoint of this case if there is one, run to t_end
 * with checkpoints, write RUN_DIR/spray.h5.  Skips the work when spray.h5 exists for the same case.
 * Returns SC_EINT/SC_ETERM after writing a checkpoint when interrupted by SIGINT/SIGTERM. */
int spray_stage_run(const struct case_file *c, const char *run_dir);

/* SIGINT/SIGTERM: set a flag the stages poll between steps. */
void stages_install_signal_handlers(void);
/* 0, or SC_EINT / SC_ETERM once a signal arrived. */
int stages_interrupt_status(void);

#endif
