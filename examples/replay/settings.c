/* SPDX-License-Identifier: Apache-2.0 */
#include "settings.h"

#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef enum { KIND_I32, KIND_F64, KIND_F32, KIND_U64 } setting_kind;

typedef struct setting {
    const char *name;
    size_t offset;
    setting_kind kind;
} setting;

#define S_I(f)                                   \
    {                                            \
#f, offsetof(tvo_vo_config, f), KIND_I32 \
    }
#define S_D(f)                                   \
    {                                            \
#f, offsetof(tvo_vo_config, f), KIND_F64 \
    }
#define S_F(f)                                   \
    {                                            \
#f, offsetof(tvo_vo_config, f), KIND_F32 \
    }
#define S_U(f)                                   \
    {                                            \
#f, offsetof(tvo_vo_config, f), KIND_U64 \
    }

/* Every scalar field a user tunes; the camera comes from the dataset or --calib, the clock from the
 * replay, and the enums (detect.score, relpose.method) keep their defaults. */
static const setting settings[] = {
        S_I(max_tracks),
        S_I(min_tracks),
        S_D(redetect_coverage),
        S_D(redetect_cell_kept),
        S_I(min_pose_tracks),
        S_I(gain_retry),
        S_I(pred_rescue),
        S_I(fast_min_threshold),
        S_I(fast_range_ref),
        S_D(pose_threshold_px),
        S_I(min_scale_points),
        S_D(scale_min_parallax_deg),
        S_I(keyframe),
        S_I(keyframe_min_tracks),
        S_D(keyframe_max_parallax_deg),
        S_D(keyframe_max_rot_deg),
        S_I(keyframe_translation),
        S_I(track_prediction),
        S_I(map_prediction),
        S_I(affine_win_size),
        S_I(affine_step),
        S_I(affine_at_keyframes),
        S_D(affine_end_share),
        S_I(map_refind),
        S_I(map_refind_rescue),
        S_I(map),
        S_I(map_window),
        S_I(map_max_landmarks),
        S_I(map_min_points),
        S_D(map_init_parallax_deg),
        S_D(map_init_wait_s),
        S_D(map_inlier_sigmas),
        S_D(map_lm_prior),
        S_D(map_lm_prior_gate),
        S_D(chain_scale_sigmas),
        S_D(map_tri_parallax_deg),
        S_D(map_kf_baseline),
        S_D(map_kf_points_ratio),
        S_I(map_kf_max_frames),
        S_I(map_ba_iterations),
        S_I(map_ba_fixed),
        S_D(map_ba_max_turn_deg),
        S_D(map_ba_huber_px),
        S_D(map_ba_rot_prior),
        S_D(map_rot_prior),
        S_I(map_rot_prior_obs),
        S_I(map_rot_prior_obs_frames),
        S_I(map_twin_dir),
        S_I(lens_refine),
        S_I(detect.fast_threshold),
        S_I(detect.block_size),
        S_F(detect.harris_k),
        S_I(detect.grid_cols),
        S_I(detect.grid_rows),
        S_I(detect.max_per_cell),
        S_F(detect.min_distance),
        S_I(detect.border),
        S_I(detect.candidates_per_cell),
        S_I(lk.win_size),
        S_I(lk.max_level),
        S_I(lk.max_iters),
        S_F(lk.epsilon),
        S_F(lk.min_eig_threshold),
        S_I(lk.fb_check),
        S_F(lk.fb_max_error),
        S_I(lk.force_portable),
        S_I(lk.fb_levels),
        S_I(lk.pred_levels),
        S_I(lk.pred_win_size),
        S_I(lk.pred_fb_levels),
        S_I(lk.pred_retry),
        S_D(relpose.confidence),
        S_I(relpose.max_iters),
        S_D(relpose.min_parallax_deg),
        S_I(relpose.min_inliers),
        S_I(relpose.use_homography),
        S_I(relpose.refine_iters),
        S_U(relpose.seed),
};

static const setting *setting_find(const char *name, size_t len)
{
    size_t i;
    for (i = 0; i < sizeof settings / sizeof settings[0]; ++i)
        if (strlen(settings[i].name) == len && strncmp(settings[i].name, name, len) == 0)
            return &settings[i];
    return NULL;
}

int tvo_replay_setting_apply(tvo_vo_config *cfg, const char *assignment)
{
    const char *eq = strchr(assignment, '=');
    const char *v;
    const setting *s;
    char *end = NULL;
    unsigned char *field;
    if (eq == NULL || eq == assignment || eq[1] == '\0') {
        fprintf(stderr, "tvo_replay: --set needs NAME=VALUE (got '%s'; --list-settings names them)\n",
                assignment);
        return -1;
    }
    s = setting_find(assignment, (size_t)(eq - assignment));
    if (s == NULL) {
        fprintf(stderr, "tvo_replay: --set: no setting '%.*s' (--list-settings names them)\n",
                (int)(eq - assignment), assignment);
        return -1;
    }
    v = eq + 1;
    field = (unsigned char *)cfg + s->offset;
    errno = 0;
    if (s->kind == KIND_I32) {
        long x = strtol(v, &end, 10);
        if (end == v || *end != '\0' || errno != 0 || x < INT32_MIN || x > INT32_MAX) {
            fprintf(stderr, "tvo_replay: --set %s needs an integer (got '%s')\n", s->name, v);
            return -1;
        }
        *(int32_t *)(void *)field = (int32_t)x;
    } else if (s->kind == KIND_U64) {
        unsigned long long x = strtoull(v, &end, 0);
        if (end == v || *end != '\0' || errno != 0 || v[0] == '-') {
            fprintf(stderr, "tvo_replay: --set %s needs an unsigned integer (got '%s')\n", s->name, v);
            return -1;
        }
        *(uint64_t *)(void *)field = (uint64_t)x;
    } else {
        double x = strtod(v, &end);
        if (end == v || *end != '\0' || errno != 0 || !isfinite(x) ||
            (s->kind == KIND_F32 && fabs(x) > FLT_MAX)) {
            fprintf(stderr, "tvo_replay: --set %s needs a finite number (got '%s')\n", s->name, v);
            return -1;
        }
        if (s->kind == KIND_F64)
            *(double *)(void *)field = x;
        else
            *(float *)(void *)field = (float)x;
    }
    return 0;
}

void tvo_replay_settings_print(FILE *f, const tvo_vo_config *cfg)
{
    size_t i;
    for (i = 0; i < sizeof settings / sizeof settings[0]; ++i) {
        const unsigned char *field = (const unsigned char *)cfg + settings[i].offset;
        if (settings[i].kind == KIND_I32)
            fprintf(f, "%-28s int     %ld\n", settings[i].name, (long)*(const int32_t *)(const void *)field);
        else if (settings[i].kind == KIND_U64)
            fprintf(f, "%-28s uint64  %llu\n", settings[i].name,
                    (unsigned long long)*(const uint64_t *)(const void *)field);
        else if (settings[i].kind == KIND_F64)
            fprintf(f, "%-28s double  %.17g\n", settings[i].name, *(const double *)(const void *)field);
        else
            fprintf(f, "%-28s float   %.9g\n", settings[i].name, (double)*(const float *)(const void *)field);
    }
}

int tvo_replay_preset_from_name(const char *name, tvo_vo_preset *preset)
{
    static const struct {
        const char *name;
        tvo_vo_preset preset;
    } names[] = {{"default", TVO_VO_PRESET_DEFAULT},
                 {"balanced", TVO_VO_PRESET_BALANCED},
                 {"accurate", TVO_VO_PRESET_ACCURATE},
                 {"basic", TVO_VO_PRESET_BASIC},
                 {"small", TVO_VO_PRESET_SMALL}};
    for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); ++i)
        if (strcmp(name, names[i].name) == 0) {
            *preset = names[i].preset;
            return 0;
        }
    return -1;
}
