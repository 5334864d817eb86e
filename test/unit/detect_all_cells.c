/* SPDX-License-Identifier: Apache-2.0 */
/* The corner detector of lib/src/tvo_detect.c compiled a second time with FAST in every cell of its grid,
 * the full ones too (TVO_DETECT_FAST_IN_FULL_CELLS), under other names, and linked into test_corners:
 * that test checks that skipping the full cells changes no result. */
#define TVO_DETECT_FAST_IN_FULL_CELLS 1
#define tvo_detect_config_default tvo_detect_config_default_all_cells
#define tvo_detect_config_check tvo_detect_config_check_all_cells
#define tvo_detect_scratch_size tvo_detect_scratch_size_all_cells
#define tvo_detect tvo_detect_all_cells
#include "../../lib/src/tvo_detect.c"
