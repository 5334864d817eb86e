/* SPDX-License-Identifier: Apache-2.0 */
/* The FAST-9 detector of lib/src/tvo_fast.c compiled a second time, portable path only
 * (TVO_CORNERS_NO_SIMD) and under other names, and linked into test_corners: that test compares the
 * library's own build (SSE2 on x86-64, NEON on aarch64 and armhf with NEON) with it bit for bit. */
#define TVO_CORNERS_NO_SIMD 1
#define tvo_fast_kernel_name tvo_fast_kernel_name_portable
#define tvo_fast_scratch_size tvo_fast_scratch_size_portable
#define tvo_fast9_detect tvo_fast9_detect_portable
#define tvo_fast9_detect_rows tvo_fast9_detect_rows_portable
#define tvo_fast9_detect_rect tvo_fast9_detect_rect_portable
#define tvo_fast9_score_at tvo_fast9_score_at_portable
#include "../../lib/src/tvo_fast.c"
