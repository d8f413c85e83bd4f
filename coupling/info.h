/* `spraycoat info`: what a run directory or an HDF5 file of spraycoat holds. */
#ifndef SPRAYCOAT_COUPLING_INFO_H
#define SPRAYCOAT_COUPLING_INFO_H

#include <stdio.h>

/* target: a run directory or a .h5 file.  SC_EIO when it cannot be read. */
int info_print(const char *target, FILE *out);

/* A few lines on what a finished run says: deposit fraction, bonded fraction and PBCP, where the report is. */
void info_headline(const char *run_dir, FILE *out);

#endif
