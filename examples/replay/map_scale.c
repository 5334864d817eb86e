/* SPDX-License-Identifier: Apache-2.0 */
/* The map's metric scale from a step-length source (map_scale.h). */
#include "map_scale.h"

#include <math.h>
#include <string.h>

void tvo_map_scale_reset(tvo_map_scale *ms)
{
    memset(ms, 0, sizeof(*ms));
}

double tvo_map_scale_frame(tvo_map_scale *ms, tvo_map_scale_rule rule, double alpha, double vo_len,
                           double src_len, int keyframe)
{
    const int have_vo = vo_len > 0.0 && isfinite(vo_len), have_src = src_len > 0.0 && isfinite(src_len);
    const double before = have_vo && have_src ? src_len / vo_len : 0.0;
    if (have_vo)
        ms->vo_int += vo_len;
    if (have_src)
        ms->src_int += src_len;
    if (!keyframe || !(ms->vo_int > 0.0) || !(ms->src_int > 0.0))
        return ms->set ? ms->s : before;
    if (rule == TVO_MAP_SCALE_ONCE) {
        if (!ms->set) {
            ms->s = ms->src_int / ms->vo_int;
            ms->set = 1;
        }
    } else if (rule == TVO_MAP_SCALE_FILTER && ms->set) {
        const double r = ms->src_int / ms->vo_int;
        ms->s = exp((1.0 - alpha) * log(ms->s) + alpha * log(r));
    } else {
        ms->src_sum += ms->src_int;
        ms->vo_sum += ms->vo_int;
        ms->s = ms->src_sum / ms->vo_sum;
        ms->set = 1;
    }
    ms->src_int = ms->vo_int = 0.0;
    return ms->s;
}
