#include "core/version.h"

/* SPRAYCOAT_VERSION comes from the Makefile, which rebuilds this file whenever `git describe` changes. */
#ifndef SPRAYCOAT_VERSION
#define SPRAYCOAT_VERSION "unknown"
#endif

const char *spraycoat_version(void) { return SPRAYCOAT_VERSION; }
