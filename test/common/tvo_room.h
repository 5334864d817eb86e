/* SPDX-License-Identifier: Apache-2.0 */
/* A tiny ray caster for tests: a pinhole camera inside a box room whose six walls carry value-noise
 * texture. Used by test_vo.c (VO end to end) and test_determinism.c (cross-target digests).
 *
 * Only + - * / and floor() are used, evaluated in double with -ffp-contract=off (the project's flags),
 * so a pose gives the same image bit for bit on every IEEE-754 target (x86-64, aarch64, armhf). */
#ifndef TVO_ROOM_H
#define TVO_ROOM_H

#include <math.h>
#include <stdint.h>

#include "tinyvo/se3.h"

static double tvo_room_hash2(int32_t x, int32_t y, uint32_t seed)
{
    uint32_t h = (uint32_t)x * 374761393u + (uint32_t)y * 668265263u + seed * 2246822519u;
    h = (h ^ (h >> 13)) * 1274126177u;
    h ^= h >> 16;
    return (double)(h & 0xffffu) / 65535.0;
}

static double tvo_room_value_noise(double u, double v, uint32_t seed)
{
    const double fu = floor(u), fv = floor(v);
    const int32_t iu = (int32_t)fu, iv = (int32_t)fv;
    const double a = u - fu, b = v - fv;
    const double sa = a * a * (3 - 2 * a), sb = b * b * (3 - 2 * b);
    const double h00 = tvo_room_hash2(iu, iv, seed), h10 = tvo_room_hash2(iu + 1, iv, seed);
    const double h01 = tvo_room_hash2(iu, iv + 1, seed), h11 = tvo_room_hash2(iu + 1, iv + 1, seed);
    return (h00 * (1 - sa) + h10 * sa) * (1 - sb) + (h01 * (1 - sa) + h11 * sa) * sb;
}

static double tvo_room_texture(double u, double v, uint32_t wall)
{
    double s = 0.0, amp = 0.5, freq = 3.0;
    for (int o = 0; o < 4; ++o) {
        s += amp * tvo_room_value_noise(u * freq, v * freq, wall * 17u + (uint32_t)o);
        amp *= 0.5;
        freq *= 2.0;
    }
    return s;
}

/* The wall the ray of camera direction dc (z = 1) of camera pose T_w_c hits: the ray in the world (d),
 * its length to the wall in units of d (returned), the wall's texture coordinates (u, v) and its index. */
static double tvo_room_cast(const tvo_pose *T_w_c, const double dc[3], double d[3], double *u, double *v,
                            uint32_t *wall)
{
    /* room: x in [-3, 3], y in [-1.5, 1.5], z in [-2, 6] (metres) */
    static const double lo[3] = {-3.0, -1.5, -2.0}, hi[3] = {3.0, 1.5, 6.0};
    double best = 1e30;
    *u = *v = 0;
    *wall = 0;
    for (int i = 0; i < 3; ++i)
        d[i] = T_w_c->R[3 * i] * dc[0] + T_w_c->R[3 * i + 1] * dc[1] + T_w_c->R[3 * i + 2] * dc[2];
    for (int ax = 0; ax < 3; ++ax) {
        for (int side = 0; side < 2; ++side) {
            const double plane = side ? hi[ax] : lo[ax];
            double tt;
            if (fabs(d[ax]) < 1e-12)
                continue;
            tt = (plane - T_w_c->t[ax]) / d[ax];
            if (tt > 0 && tt < best) {
                const int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
                best = tt;
                *u = T_w_c->t[a1] + tt * d[a1];
                *v = T_w_c->t[a2] + tt * d[a2];
                *wall = (uint32_t)(ax * 2 + side);
            }
        }
    }
    return best;
}

/* Render the room seen from camera pose T_w_c (camera -> world; camera looks along +z, x right,
 * y down) into img (w x h, stride w) with focal length `focal` px and the principal point at the
 * image centre. */
static void tvo_room_render(const tvo_pose *T_w_c, int w, int h, double focal, uint8_t *img)
{
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const double dc[3] = {(x - (w - 1) / 2.0) / focal, (y - (h - 1) / 2.0) / focal, 1.0};
            double d[3], u, v;
            uint32_t wall;
            (void)tvo_room_cast(T_w_c, dc, d, &u, &v, &wall);
            {
                const double g = 128.0 + 420.0 * (tvo_room_texture(u, v, wall) - 0.47);
                img[y * w + x] = (uint8_t)(g < 0.0 ? 0.0 : (g > 255.0 ? 255.0 : g));
            }
        }
    }
}

#endif /* TVO_ROOM_H */
