#include "core/version.h"

#include "core/isa.h"

#include <hdf5.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>

#ifdef SPRAYCOAT_MPI
#include <mpi.h>
#endif

/* The libraries of the layers above core (SUNDIALS for coupling/, Cairo and OSMesa for render/) are recorded
 * from their headers' version macros: core calls nothing of them.  OSMesa is loaded at run time by render/gl.c
 * (dlopen), so its headers' version is the one there is at build time. */
#if defined(__has_include)
#if __has_include(<sundials/sundials_config.h>)
#include <sundials/sundials_config.h>
#endif
#if __has_include(<cairo.h>)
#include <cairo.h>
#endif
#if __has_include(<GL/osmesa.h>)
#include <GL/osmesa.h>
#endif
#endif

/* SPRAYCOAT_VERSION, SPRAYCOAT_FLAGS and SPRAYCOAT_FILE_FLAGS come from the Makefile, which rebuilds this file
 * whenever `git describe` or the flags change. */
#ifndef SPRAYCOAT_VERSION
#define SPRAYCOAT_VERSION "unknown"
#endif
/* The semantic version MAJOR.MINOR.PATCH, from the file VERSION (README, "The commands", says when each part
 * grows). */
/* The digest of the sources that compute results (the Makefile's RESULT_SRC): outputs and checkpoints of other
 * sources are computed again, not taken as up to date or resumed. */
#ifndef SPRAYCOAT_SOURCES_ID
#define SPRAYCOAT_SOURCES_ID "unknown"
#endif
#ifndef SPRAYCOAT_SEMVER
#define SPRAYCOAT_SEMVER "0.0.0 (not built by the Makefile)"
#endif
#ifndef SPRAYCOAT_FLAGS
#define SPRAYCOAT_FLAGS "unknown (not built by the Makefile)"
#endif
#ifndef SPRAYCOAT_FILE_FLAGS
#define SPRAYCOAT_FILE_FLAGS "unknown (not built by the Makefile)"
#endif

#define STRINGIFY_(x) #x
#define STRINGIFY(x)  STRINGIFY_(x)

const char *spraycoat_version(void)
{
    return SPRAYCOAT_VERSION;
}

const char *spraycoat_sources_id(void)
{
    return SPRAYCOAT_SOURCES_ID;
}

#if defined(__clang__)
#define COMPILER "clang " __VERSION__
#elif defined(__GNUC__)
#define COMPILER "gcc " __VERSION__
#elif defined(__VERSION__)
#define COMPILER __VERSION__
#else
#define COMPILER "unknown"
#endif

/* The instruction sets the compiler was allowed to use (-march), from its predefined macros. */
static const char target[] =
#if defined(__x86_64__)
    "x86_64"
#if defined(__SSE3__)
    " sse3"
#endif
#if defined(__SSSE3__)
    " ssse3"
#endif
#if defined(__SSE4_1__)
    " sse4.1"
#endif
#if defined(__SSE4_2__)
    " sse4.2"
#endif
#if defined(__POPCNT__)
    " popcnt"
#endif
#if defined(__AVX__)
    " avx"
#endif
#if defined(__AVX2__)
    " avx2"
#endif
#if defined(__FMA__)
    " fma"
#endif
#if defined(__BMI2__)
    " bmi2"
#endif
#if defined(__AVX512F__)
    " avx512f"
#endif
#if defined(__AVX512DQ__)
    " avx512dq"
#endif
#if defined(__AVX512BW__)
    " avx512bw"
#endif
#if defined(__AVX512VL__)
    " avx512vl"
#endif
#elif defined(__aarch64__)
    "aarch64"
#if defined(__ARM_NEON)
    " neon"
#endif
#if defined(__ARM_FEATURE_SVE)
    " sve"
#endif
#else
    "unknown"
#endif
    ;

/* _OPENMP is the date of the specification (yyyymm). */
#if !defined(_OPENMP)
#define OPENMP "none"
#elif _OPENMP >= 202111
#define OPENMP STRINGIFY(_OPENMP) " (OpenMP 5.2)"
#elif _OPENMP >= 202011
#define OPENMP STRINGIFY(_OPENMP) " (OpenMP 5.1)"
#elif _OPENMP >= 201811
#define OPENMP STRINGIFY(_OPENMP) " (OpenMP 5.0)"
#elif _OPENMP >= 201511
#define OPENMP STRINGIFY(_OPENMP) " (OpenMP 4.5)"
#elif _OPENMP >= 201307
#define OPENMP STRINGIFY(_OPENMP) " (OpenMP 4.0)"
#else
#define OPENMP STRINGIFY(_OPENMP)
#endif

#if defined(SUNDIALS_VERSION)
#define SUNDIALS SUNDIALS_VERSION
#else
#define SUNDIALS "unknown (no sundials/sundials_config.h at build time)"
#endif

#if defined(CAIRO_VERSION_STRING)
#define CAIRO CAIRO_VERSION_STRING
#else
#define CAIRO "unknown (no cairo.h at build time)"
#endif

#if defined(OSMESA_MAJOR_VERSION)
#define OSMESA                                                                                                         \
    STRINGIFY(OSMESA_MAJOR_VERSION)                                                                                    \
    "." STRINGIFY(OSMESA_MINOR_VERSION) "." STRINGIFY(                                                                 \
        OSMESA_PATCH_VERSION) " (headers; the library is loaded when rendering)"
#else
#define OSMESA "unknown (no GL/osmesa.h at build time)"
#endif

/* libinih's ini.h has no version macro. */
#define INIH "linked (ini.h carries no version)"

enum { ITEMS = 15 };
static struct spraycoat_build_item items[ITEMS + 1];
static char hdf5_text[64], mpi_text[256];
static pthread_once_t once = PTHREAD_ONCE_INIT;

static void fill_hdf5(void)
{
    unsigned major = 0, minor = 0, release = 0;
    if (H5get_libversion(&major, &minor, &release) < 0) {
        snprintf(hdf5_text, sizeof hdf5_text, "unknown (headers %s)", H5_VERSION);
        return;
    }
    if (major == H5_VERS_MAJOR && minor == H5_VERS_MINOR && release == H5_VERS_RELEASE)
        snprintf(hdf5_text, sizeof hdf5_text, "%u.%u.%u", major, minor, release);
    else
        snprintf(hdf5_text, sizeof hdf5_text, "%u.%u.%u (headers %s)", major, minor, release, H5_VERSION);
}

/* The MPI library's own description, first line (MPI_Get_library_version may be called before MPI_Init). */
static void fill_mpi(void)
{
#ifdef SPRAYCOAT_MPI
    char text[MPI_MAX_LIBRARY_VERSION_STRING];
    int length = 0;
    if (MPI_Get_library_version(text, &length) != MPI_SUCCESS || length <= 0) {
        snprintf(mpi_text, sizeof mpi_text, "MPI %d.%d, library unknown", MPI_VERSION, MPI_SUBVERSION);
        return;
    }
    text[length < MPI_MAX_LIBRARY_VERSION_STRING ? length : MPI_MAX_LIBRARY_VERSION_STRING - 1] = '\0';
    text[strcspn(text, "\r\n")] = '\0';
    snprintf(mpi_text, sizeof mpi_text, "MPI %d.%d, %.200s", MPI_VERSION, MPI_SUBVERSION, text);
#else
    snprintf(mpi_text, sizeof mpi_text, "none (built without MPI)");
#endif
}

static void fill_items(void)
{
    fill_hdf5();
    fill_mpi();
    const struct spraycoat_build_item list[] = {
        {"version", SPRAYCOAT_SEMVER},
        {"program_version", SPRAYCOAT_VERSION},
        {"sources_id", SPRAYCOAT_SOURCES_ID},
        {"compiler", COMPILER},
        {"flags", SPRAYCOAT_FLAGS},
        {"file_flags", SPRAYCOAT_FILE_FLAGS},
        {"target", target},
        {"isa", isa_name()},
        {"openmp", OPENMP},
        {"hdf5", hdf5_text},
        {"sundials", SUNDIALS},
        {"cairo", CAIRO},
        {"osmesa", OSMESA},
        {"inih", INIH},
        {"mpi", mpi_text},
    };
    _Static_assert(sizeof list / sizeof list[0] == ITEMS, "ITEMS is the length of the list");
    memcpy(items, list, sizeof list);
    items[ITEMS] = (struct spraycoat_build_item){NULL, NULL};
}

const struct spraycoat_build_item *spraycoat_build_info(void)
{
    pthread_once(&once, fill_items);
    return items;
}
