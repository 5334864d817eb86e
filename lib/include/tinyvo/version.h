/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: library version, at compile time (macros) and at run time (tvo_version()).
 *
 * The numbers follow project(VERSION) of the top CMakeLists.txt; a CMake configure step refuses to
 * build when they differ, so that a tree compiled without CMake (bare-metal builds that list the
 * sources themselves) carries the same numbers. Semantic versioning: a MINOR change may add to the
 * API, only a MAJOR change (or any change while MAJOR is 0) may break it. */
#ifndef TINYVO_VERSION_H
#define TINYVO_VERSION_H

#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

#define TVO_VERSION_MAJOR 0
#define TVO_VERSION_MINOR 2
#define TVO_VERSION_PATCH 0
/* "MAJOR.MINOR.PATCH" */
#define TVO_VERSION_STRING "0.2.0"
/* MAJOR * 10000 + MINOR * 100 + PATCH, for #if comparisons (MINOR and PATCH stay below 100). */
#define TVO_VERSION_NUMBER (TVO_VERSION_MAJOR * 10000L + TVO_VERSION_MINOR * 100L + TVO_VERSION_PATCH)

/* The version of the library linked in, "MAJOR.MINOR.PATCH" (a static string, never NULL). Compare it
 * with TVO_VERSION_STRING to detect a header/library mismatch, e.g. with a shared library. */
TVO_API const char *tvo_version(void);

/* The same as TVO_VERSION_NUMBER, of the library linked in. */
TVO_API long tvo_version_number(void);

#ifdef __cplusplus
}
#endif

#endif
