/* SPDX-License-Identifier: Apache-2.0 */
/* The README's quickstart: the VO on a sequence of 8-bit grey frames, the camera's pose in the world.
 * Everything between the README markers is copied verbatim into README.md (a ctest test checks that
 * the two agree); below them, a stand-in frame source (a textured plane the camera approaches) so
 * that ctest can run the program: replace next_frame() with your camera or files. Exit status 0 when
 * the VO tracked the motion (most frames posed by the local map, the camera moving forward in them),
 * 1 otherwise. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "tinyvo/tinyvo.h"

#define W 640
#define H 480

/* Your frame source: fills pixels (W x H, stride W) and *t_ns; returns 0 after the last frame. */
static int next_frame(uint8_t *pixels, int64_t *t_ns);
/* The stand-in check: frames the map posed, and of them those in which the camera moved forward along
 * its optical axis (the stand-in's motion: the world's z, as the first camera is the world frame) */
static int g_mapped, g_forward;
static void count(const tvo_vo_result *res)
{
    static double z_last = 0.0;
    const int mapped = res->map_state == TVO_MAP_TRACKING || res->map_state == TVO_MAP_INITIALISED;
    g_mapped += mapped;
    g_forward += mapped && res->T_w_c.t[2] > z_last;
    z_last = res->T_w_c.t[2];
}
static int check(void)
{
    fprintf(stderr, "%d frames posed by the map, %d of them forward\n", g_mapped, g_forward);
    return g_mapped >= 30 && g_forward >= g_mapped * 9 / 10 ? 0 : 1;
}

/* README-BEGIN */
int main(void)
{
    tvo_camera cam = tvo_camera_make_pinhole(W, H, 460.0, 460.0, 319.5, 239.5); /* your calibration */
    tvo_vo_config cfg;
    tvo_vo_config_default(&cfg, &cam);
    size_t size = tvo_vo_required_size(&cfg);
    void *mem = malloc(size); /* all the VO's memory, from any allocator you like */
    uint8_t *pixels = malloc(W * H);
    tvo_vo *vo = NULL;
    if (size == 0 || mem == NULL || pixels == NULL || tvo_vo_init(&vo, &cfg, mem, size) != TVO_OK) {
        free(pixels);
        free(mem);
        return 1;
    }
    tvo_image frame = tvo_image_make(W, H, W, pixels);
    const double metres = 0.05; /* metres per unit of the VO's world: bring your own scale */
    int64_t t_ns;
    while (next_frame(pixels, &t_ns)) {
        tvo_vo_result res;
        if (tvo_vo_process(vo, &frame, t_ns, &res) != TVO_OK)
            continue; /* a refused frame (size, timestamp) leaves the VO unchanged */
        /* the camera's pose in the world (the first camera), from the local map once it tracks */
        const double *p = res.T_w_c.t;
        printf("%.3f s  map %d  position %.2f %.2f %.2f m\n", t_ns * 1e-9, (int)res.map_state, p[0] * metres,
               p[1] * metres, p[2] * metres);
        count(&res);
    }
    free(pixels);
    free(mem);
    return check();
}
/* README-END */

/* ---- the stand-in frame source: 40 frames at 20 Hz of a textured wall 4 m ahead, the camera moving
 * 5 cm towards it per frame (the image grows by the depth ratio about the principal point). The
 * texture is value noise: random grey levels on an 8-pixel grid, bilinearly interpolated. */
static double texture(double x, double y)
{
    long ix = (long)(x >= 0.0 ? x : x - 1.0), iy = (long)(y >= 0.0 ? y : y - 1.0);
    double fx = x - (double)ix, fy = y - (double)iy, v[4];
    for (int k = 0; k < 4; ++k) {
        uint32_t h = (uint32_t)(ix + (k & 1)) * 73856093u ^ (uint32_t)(iy + (k >> 1)) * 19349663u;
        h ^= h >> 13;
        h *= 0x5bd1e995u;
        h ^= h >> 15;
        v[k] = (double)(h & 255u);
    }
    return (v[0] * (1 - fx) + v[1] * fx) * (1 - fy) + (v[2] * (1 - fx) + v[3] * fx) * fy;
}

static int next_frame(uint8_t *pixels, int64_t *t_ns)
{
    static int k = 0;
    if (k == 40)
        return 0;
    const double depth = 4.0 - 0.05 * k, zoom = 4.0 / depth; /* wall point at ray (x, y): x * 4 / depth */
    for (int v = 0; v < H; ++v)
        for (int u = 0; u < W; ++u) {
            double x = (u - 319.5) / zoom + 319.5, y = (v - 239.5) / zoom + 239.5;
            pixels[v * W + u] = (uint8_t)texture(x / 8.0, y / 8.0);
        }
    *t_ns = 50000000LL * k++;
    return 1;
}
