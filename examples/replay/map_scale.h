/* SPDX-License-Identifier: Apache-2.0 */
/* The map's metric scale from a step-length source, for tvo_replay (--scale gt|model|const|propagate)
 * and tvo_live (--model). The VO's world has one unknown scale for the whole run; the program's
 * trajectory integrates the VO's motion times a factor s (metres per map unit) that the source sets at
 * keyframes: the source's path length (ground-truth steps, the networks' step lengths, a constant step)
 * over the VO's, keyframe interval by keyframe interval. Before a keyframe has set s (the frames before
 * the first map, which on a car can be seconds, and after a reset) each step takes the source's own
 * length, so the trajectory moves as the source says from the first frame. */
#ifndef TVO_REPLAY_MAP_SCALE_H
#define TVO_REPLAY_MAP_SCALE_H

typedef struct tvo_map_scale {
    double s; /* metres per map unit, once set */
    int set;
    double src_sum, vo_sum; /* path lengths over the keyframe intervals used so far */
    double src_int, vo_int; /* path lengths since the last keyframe */
} tvo_map_scale;

/* How a keyframe updates s: the ratio of the whole path so far; the last interval's ratio through a
 * log-space filter (weight alpha, after the first keyframe); or once, at the first keyframe. */
typedef enum { TVO_MAP_SCALE_WHOLE_PATH, TVO_MAP_SCALE_FILTER, TVO_MAP_SCALE_ONCE } tvo_map_scale_rule;

/* No factor yet (also after the VO was reset: a new map has a unit of its own). */
void tvo_map_scale_reset(tvo_map_scale *ms);

/* One frame: vo_len the VO's step length (map units), src_len the source's (metres; <= 0 or not finite:
 * none this frame), keyframe nonzero on a keyframe. Returns the factor for this frame's step: s once a
 * keyframe has set it, before that src_len / vo_len (0 when the frame has no length of either). */
double tvo_map_scale_frame(tvo_map_scale *ms, tvo_map_scale_rule rule, double alpha, double vo_len,
                           double src_len, int keyframe);

#endif
