/* core/interrupt: SIGINT and SIGTERM as a flag that long work polls between its steps (a stage's time loop, the
 * couple stage's seeds, the render stage's figures), so that it stops at a safe point, after a checkpoint where
 * it has one, with exit status 130 or 143 (docs/architecture.md "Errors and exit statuses"). */
#ifndef SPRAYCOAT_CORE_INTERRUPT_H
#define SPRAYCOAT_CORE_INTERRUPT_H

/* Catch SIGINT and SIGTERM from now on (they set the flag instead of ending the process). */
void interrupt_install(void);
/* SC_OK, or SC_EINT / SC_ETERM once SIGINT / SIGTERM arrived. */
int interrupt_status(void);

#endif
