/* The program version (git describe at build time). */
#ifndef SPRAYCOAT_CORE_VERSION_H
#define SPRAYCOAT_CORE_VERSION_H

const char *spraycoat_version(void);

#endif
