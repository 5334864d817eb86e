/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: TVO_API, the mark of every function of the public API (the declarations in these headers and
 * in the port layer's, tinyvo/port/).
 *
 * A shared build of each library (libtinyvo, libtinyvo_port, libtinyvo_v4l2) compiles its sources with
 * hidden symbol visibility (CMake: C_VISIBILITY_PRESET hidden), so that it exports the marked functions
 * and nothing else: the internal functions shared between its sources stay inside it. With GCC and Clang
 * the mark is __attribute__((visibility("default"))); it changes nothing in a static library, and is
 * empty with other compilers. Defined before this header (e.g. on the command line), TVO_API is left as
 * it is. */
#ifndef TINYVO_EXPORT_H
#define TINYVO_EXPORT_H

#ifndef TVO_API
#if defined(__GNUC__) || defined(__clang__)
#define TVO_API __attribute__((visibility("default")))
#else
#define TVO_API
#endif
#endif

#endif /* TINYVO_EXPORT_H */
