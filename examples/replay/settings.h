/* SPDX-License-Identifier: Apache-2.0 */
/* tvo_replay's --set NAME=VALUE: any scalar field of tvo_vo_config (vo.h), including the nested
 * detector, tracker and RANSAC settings (detect.*, lk.*, relpose.*), set by name from the command line.
 * The values are not range-checked here: tvo_vo_required_size / tvo_vo_init refuse a configuration
 * out of range with a status, as they would in a program that set the field itself. */
#ifndef TVO_REPLAY_SETTINGS_H
#define TVO_REPLAY_SETTINGS_H

#include <stdio.h>

#include "tinyvo/vo.h"

/* Applies one "NAME=VALUE" to cfg. Returns 0, or -1 after one line on stderr naming the problem (no '=',
 * an unknown name, a value that is not a number of the field's type). */
int tvo_replay_setting_apply(tvo_vo_config *cfg, const char *assignment);

/* The preset called `name` (default, balanced, accurate, basic, small) in *preset. Returns 0, or -1 for
 * another name (nothing printed). */
int tvo_replay_preset_from_name(const char *name, tvo_vo_preset *preset);

/* Prints every settable name with its type and its value in cfg, one per line. */
void tvo_replay_settings_print(FILE *f, const tvo_vo_config *cfg);

#endif
