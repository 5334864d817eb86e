/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo on a microcontroller: a short replay of QVGA frames with the VO and the per-DoF networks in one
 * fixed block of TVO_MCU_MEM bytes (no heap for the library), the same program on the host and on the
 * Cortex-M7 model (qemu-system-arm -M mps2-an500, file I/O through semihosting).
 *
 *     mcu_replay FRAMES.bin MODEL.tvonn OUT.tum RESULTS.txt   (host; on the target the names are fixed:
 *                                          frames.bin, model.tvonn, traj.tum, results.txt in qemu's cwd)
 *
 * FRAMES.bin (written by test/mcu/make_frames.py): "TVOFRM1\0", int32 width, height, count, 0, double fx, fy,
 * cx, cy (pinhole, no distortion), then per frame int64 t_ns and width*height grey bytes, little endian.
 * Output: the TUM trajectory (the map's T_w_c, %.17g), every result's fields per frame in hexadecimal
 * floating point (RESULTS.txt: where a difference starts), and on stdout lines "mcu: key value" with the
 * memory figures, the frames processed and an FNV-1a digest over every result (state, counts, raw pose,
 * rel_scale, the map's state, counts and world pose, network outputs). The host and target digests must be equal (tools/run-mcu.sh compares them).
 * Before the replay it checks two refusals at init: a camera too large for the block (TVO_ERR_NO_MEMORY
 * from tvo_vo_init, before any frame) and a frame of the wrong size (TVO_ERR_SIZE, VO unchanged). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tinyvo/tinyvo.h"

#ifndef TVO_MCU_MEM
#define TVO_MCU_MEM (256u * 1024u) /* the whole working memory: VO (pyramids, tracks, scratch) + networks */
#endif
#define MCU_MAX_W 320
#define MCU_MAX_H 240
#define MCU_MAX_MODEL (64u * 1024u)

static uint8_t g_mem[TVO_MCU_MEM] __attribute__((aligned(16)));
static uint8_t g_frame[MCU_MAX_W * MCU_MAX_H];
static uint8_t g_model[MCU_MAX_MODEL];

static uint64_t g_digest = 1469598103934665603ull;

static void digest(const void *p, size_t n)
{
    const uint8_t *b = (const uint8_t *)p;
    for (size_t i = 0; i < n; ++i) {
        g_digest ^= b[i];
        g_digest *= 1099511628211ull;
    }
}

/* The bits of a double / float in hexadecimal (newlib's printf has no %a). */
static void put_f64(FILE *fp, double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    fprintf(fp, " %08lx%08lx", (unsigned long)(u >> 32), (unsigned long)(u & 0xFFFFFFFFu));
}

static void put_f32(FILE *fp, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    fprintf(fp, " %08lx", (unsigned long)u);
}

static int read_exact(FILE *fp, void *dst, size_t n)
{
    return fread(dst, 1, n, fp) == n;
}

static int32_t rd_i32(const uint8_t *p)
{
    return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
}

static double rd_f64(const uint8_t *p)
{
    uint64_t u = 0;
    double d;
    for (int i = 7; i >= 0; --i)
        u = u << 8 | p[i];
    memcpy(&d, &u, sizeof d);
    return d;
}

/* The QVGA configuration: the library's preset for a microcontroller (vo.h, TVO_VO_PRESET_SMALL: a
 * track list, detection, pyramid and map sized for 320x240 and the 256 KiB block; docs/budget.md). */
static void mcu_config(tvo_vo_config *cfg, const tvo_camera *cam)
{
    (void)tvo_vo_config_preset(cfg, cam, TVO_VO_PRESET_SMALL);
}

/* A pinhole camera without distortion, checked. */
static tvo_status mcu_camera(tvo_camera *cam, int32_t w, int32_t h, double fx, double fy, double cx,
                             double cy)
{
    *cam = tvo_camera_make_pinhole(w, h, fx, fy, cx, cy);
    return tvo_camera_check(cam);
}

static int fail(const char *what, tvo_status st)
{
    printf("mcu: FAIL %s (%s)\n", what, tvo_status_str(st));
    return 1;
}

int main(int argc, char **argv)
{
    const char *frames_path = argc > 1 ? argv[1] : "frames.bin";
    const char *model_path = argc > 2 ? argv[2] : "model.tvonn";
    const char *out_path = argc > 3 ? argv[3] : "traj.tum";
    const char *res_path = argc > 4 ? argv[4] : "results.txt";
    uint8_t hdr[56];
    int32_t w, h, count;
    tvo_camera cam;
    tvo_vo_config cfg, big;
    tvo_vo *vo = NULL;
    tvo_nn *nn = NULL;
    size_t vo_size, nn_size = 0, model_size;
    FILE *fp, *fm, *fo, *fr;
    tvo_status st;
    int32_t processed = 0;

    fp = fopen(frames_path, "rb");
    if (fp == NULL || !read_exact(fp, hdr, sizeof hdr) || memcmp(hdr, "TVOFRM1", 8) != 0) {
        printf("mcu: FAIL cannot read %s\n", frames_path);
        return 1;
    }
    w = rd_i32(hdr + 8);
    h = rd_i32(hdr + 12);
    count = rd_i32(hdr + 16);
    if (w < 1 || h < 1 || w > MCU_MAX_W || h > MCU_MAX_H || count < 0) {
        printf("mcu: FAIL frame size %dx%d\n", (int)w, (int)h);
        return 1;
    }
    st = mcu_camera(&cam, w, h, rd_f64(hdr + 24), rd_f64(hdr + 32), rd_f64(hdr + 40), rd_f64(hdr + 48));
    if (st != TVO_OK)
        return fail("camera", st);
    mcu_config(&cfg, &cam);

    /* refusal at init: a VGA camera does not fit the block meant for QVGA */
    {
        tvo_camera vga;
        (void)mcu_camera(&vga, 640, 480, 500.0, 500.0, 320.0, 240.0);
        mcu_config(&big, &vga);
        st = tvo_vo_init(&vo, &big, g_mem, sizeof g_mem);
        printf("mcu: vga_init %s required %lu\n", tvo_status_str(st),
               (unsigned long)tvo_vo_required_size(&big));
        if (tvo_vo_required_size(&big) > sizeof g_mem && (st != TVO_ERR_NO_MEMORY || vo != NULL))
            return fail("a VGA camera in the QVGA block is not refused at init", st);
    }

    vo_size = tvo_vo_required_size(&cfg);
    st = tvo_vo_init(&vo, &cfg, g_mem, sizeof g_mem);
    if (st != TVO_OK)
        return fail("tvo_vo_init", st);
    fm = fopen(model_path, "rb");
    model_size = fm != NULL ? fread(g_model, 1, sizeof g_model, fm) : 0;
    if (fm != NULL)
        fclose(fm);
    if (model_size == 0 || model_size == sizeof g_model)
        return fail("model file", TVO_ERR_IO);
    st = tvo_nn_required_size(g_model, model_size, &nn_size);
    if (st != TVO_OK)
        return fail("tvo_nn_required_size", st);
    {
        const size_t at = (vo_size + 15u) & ~(size_t)15u;
        if (at > sizeof g_mem || nn_size > sizeof g_mem - at)
            return fail("VO + networks exceed the block", TVO_ERR_NO_MEMORY);
        st = tvo_nn_load(&nn, g_model, model_size, g_mem + at, sizeof g_mem - at);
        if (st != TVO_OK)
            return fail("tvo_nn_load", st);
    }
    printf("mcu: frame %dx%d frames %d\n", (int)w, (int)h, (int)count);
    printf("mcu: vo_bytes %lu nn_bytes %lu total_bytes %lu block %lu\n", (unsigned long)vo_size,
           (unsigned long)nn_size, (unsigned long)(((vo_size + 15u) & ~(size_t)15u) + nn_size),
           (unsigned long)sizeof g_mem);

    fo = fopen(out_path, "w");
    fr = fopen(res_path, "w");
    if (fo == NULL || fr == NULL)
        return fail("output file", TVO_ERR_IO);
    for (int32_t k = 0; k < count; ++k) {
        uint8_t tb[8];
        int64_t t_ns = 0;
        tvo_vo_result res;
        float out[TVO_NN_OUT_COUNT];
        double q[4];
        if (!read_exact(fp, tb, 8) || !read_exact(fp, g_frame, (size_t)w * (size_t)h))
            break;
        for (int i = 7; i >= 0; --i)
            t_ns = (int64_t)((uint64_t)t_ns << 8 | tb[i]);
        const tvo_image img = tvo_image_make(w, h, w, g_frame);
        if (k == 1) { /* a frame of the wrong size is refused and leaves the VO unchanged */
            tvo_image bad = tvo_image_make(w - 1, h, w, g_frame);
            st = tvo_vo_process(vo, &bad, t_ns, &res);
            if (st != TVO_ERR_SIZE || res.state != TVO_VO_LOST)
                return fail("a frame of the wrong size is not refused", st);
        }
        st = tvo_vo_process(vo, &img, t_ns, &res);
        if (st != TVO_OK)
            return fail("tvo_vo_process", st);
        ++processed;
        memset(out, 0, sizeof out);
        (void)tvo_nn_run_all(nn, res.features, out);
        {
            const int32_t state =
                    (int32_t)res.state; /* the enum's size is the ABI's (1 byte on arm-none-eabi) */
            digest(&state, sizeof state);
        }
        digest(&res.tracked, sizeof res.tracked);
        digest(&res.inliers, sizeof res.inliers);
        digest(&res.new_corners, sizeof res.new_corners);
        digest(&res.tracks, sizeof res.tracks);
        digest(res.T_prev_cur.R, sizeof res.T_prev_cur.R);
        digest(res.T_prev_cur.t, sizeof res.T_prev_cur.t);
        digest(&res.rel_scale, sizeof res.rel_scale);
        digest(res.features, sizeof res.features);
        digest(out, sizeof out);
        {
            /* the local map: the world pose (the trajectory written below) and what the map did */
            const int32_t mi[5] = {(int32_t)res.map_state, res.keyframe, res.map_points, res.map_landmarks,
                                   res.map_losses};
            digest(mi, sizeof mi);
            digest(res.T_w_c.R, sizeof res.T_w_c.R);
            digest(res.T_w_c.t, sizeof res.T_w_c.t);
        }
        fprintf(fr, "%d %d %d %d %d %d", (int)k, (int)res.state, (int)res.tracked, (int)res.inliers,
                (int)res.new_corners, (int)res.tracks);
        for (int i = 0; i < 9; ++i)
            put_f64(fr, res.T_prev_cur.R[i]);
        for (int i = 0; i < 3; ++i)
            put_f64(fr, res.T_prev_cur.t[i]);
        put_f64(fr, res.rel_scale);
        fprintf(fr, " | %d %d %d %d", (int)res.map_state, (int)res.keyframe, (int)res.map_points,
                (int)res.map_landmarks);
        for (int i = 0; i < 9; ++i)
            put_f64(fr, res.T_w_c.R[i]);
        for (int i = 0; i < 3; ++i)
            put_f64(fr, res.T_w_c.t[i]);
        fprintf(fr, " |");
        for (int i = 0; i < TVO_FEAT_COUNT; ++i)
            put_f32(fr, res.features[i]);
        fprintf(fr, " |");
        for (int i = 0; i < TVO_NN_OUT_COUNT; ++i)
            put_f32(fr, out[i]);
        fprintf(fr, "\n");
        tvo_rot_to_quat(res.T_w_c.R, q); /* the map's trajectory (its own unit) */
        fprintf(fo, "%.9f %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", (double)t_ns * 1e-9, res.T_w_c.t[0],
                res.T_w_c.t[1], res.T_w_c.t[2], q[1], q[2], q[3], q[0]);
    }
    fclose(fo);
    fclose(fr);
    fclose(fp);
    printf("mcu: processed %d digest %08lx%08lx\n", (int)processed, (unsigned long)(g_digest >> 32),
           (unsigned long)(g_digest & 0xFFFFFFFFu));
    printf("mcu: %s\n", processed == count ? "PASS" : "FAIL short read");
    return processed == count ? 0 : 1;
}
