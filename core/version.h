/* The program version (git describe at build time) and the build record: what every output's /code group and
 * `spraycoat --version` say about how this program was built. */
#ifndef SPRAYCOAT_CORE_VERSION_H
#define SPRAYCOAT_CORE_VERSION_H

const char *spraycoat_version(void);
/* The digest (16 hex digits) of the sources that compute results: every output's root attribute sources_id.  Two
 * builds from the same sources compute the same results (with any flags, instruction-set level, MPI or not);
 * git describe says which commit, not whether its files were edited since. */
const char *spraycoat_sources_id(void);

/* One entry of the build record: an attribute of /code, a line of `spraycoat --version`. */
struct spraycoat_build_item {
    const char *name;
    const char *value;
};

/* The build record, ended by an entry whose name is NULL: version (semantic, MAJOR.MINOR.PATCH, from the file
 * VERSION), program_version (git describe), sources_id, compiler, flags (the flags every
 * file is compiled with), file_flags (the per-file additions), target (the instruction sets compiled for),
 * isa (the instruction-set level the kernels run with, core/isa.h), openmp, then the libraries: hdf5, sundials, cairo,
 * osmesa, inih, mpi.  Never empty values; the same for the life of the process (filled on the first call, thread-safe).
 */
const struct spraycoat_build_item *spraycoat_build_info(void);

#endif
