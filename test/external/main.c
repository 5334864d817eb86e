/* SPDX-License-Identifier: Apache-2.0 */
/* A program outside the tinyvo tree, built against an installed tinyvo (test/external/run.sh): once with
 * find_package(tinyvo COMPONENTS port) and once with pkg-config. It uses the core and the port layer as a
 * user would:
 *   1. tvo_version() equals the header's TVO_VERSION_STRING (header and library of the same release);
 *   2. writes a textured grey frame as PNG (tinyvo::port), reads it back, compares the pixels;
 *   3. runs the VO on 8 frames of that texture moving 2 px per frame: every call returns TVO_OK and the
 *      last frame is tracked (neither lost nor initialising) with at least 50 tracks;
 *   4. loads the installed weights file MODEL (share/tinyvo/models) with tvo_nn_load.
 * Usage: tvo_external PNG_PATH MODEL.tvonn. Exit 0 when all hold, 1 otherwise (one line on stderr). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tinyvo/tinyvo.h"
#include "tinyvo/port/png.h"

#define W 320
#define H 240
#define TW (W + 64) /* texture wider than the frame: frames are windows moving over it */

static int fail(const char *what, tvo_status st)
{
    fprintf(stderr, "tvo_external: %s: %s\n", what, tvo_status_str(st));
    return 1;
}

/* 3 x 3 dots on a grey background, one per 10 x 10 cell at a random place in it (xorshift32), with a
 * random grey level at the centre and half-way to the background around it: FAST corners everywhere */
static void make_texture(uint8_t *tex)
{
    uint32_t s = 2463534242u;
    memset(tex, 110, (size_t)TW * H);
    for (int cy = 0; cy + 10 <= H; cy += 10)
        for (int cx = 0; cx + 10 <= TW; cx += 10) {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            int x0 = cx + 1 + (int)(s % 6u), y0 = cy + 1 + (int)((s >> 8) % 6u);
            uint8_t v = (uint8_t)((s >> 16) & 1u ? 180 + (s >> 20) % 70 : 10 + (s >> 20) % 60);
            for (int y = y0; y < y0 + 3; ++y)
                for (int x = x0; x < x0 + 3; ++x)
                    tex[y * TW + x] = (uint8_t)((v + 110) / 2);
            tex[(y0 + 1) * TW + x0 + 1] = v; /* one peak: no plateau for the non-max suppression */
        }
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: tvo_external PNG_PATH MODEL.tvonn\n");
        return 2;
    }
    printf("tinyvo %s (header %s)\n", tvo_version(), TVO_VERSION_STRING);
    if (strcmp(tvo_version(), TVO_VERSION_STRING) != 0 || tvo_version_number() != TVO_VERSION_NUMBER) {
        fprintf(stderr, "tvo_external: library %s but header %s\n", tvo_version(), TVO_VERSION_STRING);
        return 1;
    }

    static uint8_t tex[TW * H], frame[W * H], back[W * H];
    make_texture(tex);
    for (int y = 0; y < H; ++y)
        memcpy(frame + y * W, tex + y * TW, W);
    tvo_status st = tvo_png_write_gray8(argv[1], frame, W, H, W);
    if (st != TVO_OK)
        return fail("tvo_png_write_gray8", st);
    int32_t w = 0, h = 0;
    st = tvo_png_read_gray8(argv[1], back, sizeof back, &w, &h);
    if (st != TVO_OK)
        return fail("tvo_png_read_gray8", st);
    if (w != W || h != H || memcmp(frame, back, sizeof frame) != 0) {
        fprintf(stderr, "tvo_external: %s read back as %dx%d with other pixels\n", argv[1], (int)w, (int)h);
        return 1;
    }
    printf("png: %s %dx%d, read back identical\n", argv[1], (int)w, (int)h);

    tvo_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.width = W;
    cam.height = H;
    cam.fx = cam.fy = 300.0;
    cam.cx = W / 2.0;
    cam.cy = H / 2.0;
    cam.model = TVO_DIST_NONE;
    tvo_vo_config cfg;
    tvo_vo_config_default(&cfg, &cam);
    size_t bytes = tvo_vo_required_size(&cfg);
    void *mem = malloc(bytes);
    if (bytes == 0 || mem == NULL) {
        fprintf(stderr, "tvo_external: tvo_vo_required_size gave %zu bytes\n", bytes);
        return 1;
    }
    tvo_vo *vo = NULL;
    st = tvo_vo_init(&vo, &cfg, mem, bytes);
    if (st != TVO_OK)
        return fail("tvo_vo_init", st);
    tvo_vo_result res;
    for (int k = 0; k < 8; ++k) {
        for (int y = 0; y < H; ++y)
            memcpy(frame + y * W, tex + y * TW + 2 * k, W);
        tvo_image img = tvo_image_make(W, H, W, frame);
        st = tvo_vo_process(vo, &img, (int64_t)k * 50000000, &res);
        if (st != TVO_OK)
            return fail("tvo_vo_process", st);
        if (getenv("TVO_EXTERNAL_VERBOSE") != NULL)
            printf("  frame %d: state %d, %d tracked, %d inliers, %d new, %d tracks\n", k, (int)res.state,
                   (int)res.tracked, (int)res.inliers, (int)res.new_corners, (int)res.tracks);
    }
    printf("vo: 8 frames, last: state %d, %d tracked, %d inliers, %d tracks\n", (int)res.state,
           (int)res.tracked, (int)res.inliers, (int)res.tracks);
    free(mem);
    if (res.tracked < 50 || res.state == TVO_VO_LOST || res.state == TVO_VO_INITIALISING) {
        fprintf(stderr, "tvo_external: last frame: state %d, %d tracks\n", (int)res.state, (int)res.tracked);
        return 1;
    }

    FILE *f = fopen(argv[2], "rb");
    if (f == NULL) {
        fprintf(stderr, "tvo_external: cannot open %s\n", argv[2]);
        return 1;
    }
    static uint8_t file[1 << 20];
    size_t n = fread(file, 1, sizeof file, f);
    fclose(f);
    size_t nn_bytes = 0;
    st = tvo_nn_required_size(file, n, &nn_bytes);
    if (st != TVO_OK)
        return fail("tvo_nn_required_size", st);
    void *nn_mem = malloc(nn_bytes);
    tvo_nn *nn = NULL;
    st = nn_mem != NULL ? tvo_nn_load(&nn, file, n, nn_mem, nn_bytes) : TVO_ERR_NO_MEMORY;
    free(nn_mem);
    if (st != TVO_OK)
        return fail("tvo_nn_load", st);
    printf("model: %s, %zu bytes, loaded\n", argv[2], n);
    return 0;
}
