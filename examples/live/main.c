/* tvo_live: visual odometry on a live V4L2 camera.
 *
 *   tvo_live [--device /dev/video0] [--calib sensor.yaml] [--model FILE] [--size WxH] [--fps N]
 *            [--frames N] [--timeout-ms N]
 *
 * Prints one line per frame on stdout, at the camera rate:
 *   t_s state tracked inliers tx ty tz qx qy qz qw
 * (t in seconds of CLOCK_MONOTONIC, the camera pose in the world frame of the first frame, TUM order;
 * translation in unit steps, or metres from the per-DoF networks with --model). Status and errors
 * go to stderr. Without --calib a distortion-free pinhole with a 60 degree horizontal field of
 * view is assumed. Cameras driven only by libcamera: `libcamerify tvo_live ...` (docs/ports.md).
 * Exit codes: 0 done (--frames reached or Ctrl-C), 1 usage, 2 no device, 3 device busy,
 * 4 device unusable (not a capture device, no grey/YUV format), 5 stream failed (lost, stalled). */
#include "tinyvo/port/clock.h"
#include "tinyvo/port/euroc.h"
#include "tinyvo/port/v4l2.h"
#include "tinyvo/tinyvo.h"
#include "tinyvo/vo.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static volatile sig_atomic_t g_stop = 0;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

static void usage(void)
{
    fprintf(stderr,
            "usage: tvo_live [--device PATH] [--calib sensor.yaml] [--model FILE] [--size WxH]\n"
            "                [--fps N] [--frames N] [--timeout-ms N]\n"
            "  --device PATH     V4L2 capture device (default /dev/video0)\n"
            "  --calib FILE      EuRoC/Kalibr-style sensor.yaml with intrinsics and distortion\n"
            "  --model FILE      tinyvo weights file: metric steps from the per-DoF networks\n"
            "  --size WxH        requested size (default: the calibration's, else 640x480)\n"
            "  --fps N           requested frame rate (default 30)\n"
            "  --frames N        stop after N frames (default: until Ctrl-C)\n"
            "  --timeout-ms N    give up when no frame arrives for N ms (default 2000)\n");
}

/* Whole-string decimal integer in [lo, hi] (atoi/sscanf accept "5x" and overflow is undefined). */
static int parse_long(const char *s, long lo, long hi, long *out)
{
    char *end = NULL;
    long v;
    errno = 0;
    v = strtol(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi)
        return 0;
    *out = v;
    return 1;
}

static char *read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    char *buf = NULL;
    long n;
    if (f == NULL)
        return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0) {
        buf = (char *)malloc((size_t)n + 1);
        if (buf != NULL && fread(buf, 1, (size_t)n, f) == (size_t)n) {
            buf[n] = '\0';
            *size = (size_t)n;
        } else {
            free(buf);
            buf = NULL;
        }
    }
    fclose(f);
    return buf;
}

static int64_t clock_cb(void *user)
{
    (void)user;
    return tvo_clock_now_ns();
}

int main(int argc, char **argv)
{
    const char *device = "/dev/video0", *calib = NULL, *model = NULL;
    int32_t width = 0, height = 0, fps = 30, timeout_ms = 2000;
    long frames_max = -1;
    tvo_camera cam;
    int have_calib = 0;
    tvo_v4l2_config vcfg;
    tvo_v4l2 v4l2;
    const tvo_v4l2_format *fmt;
    tvo_vo_config cfg;
    tvo_vo *vo = NULL;
    void *vo_mem = NULL, *nn_mem = NULL;
    char *nn_file = NULL;
    tvo_nn *nn = NULL;
    uint8_t *grey = NULL;
    tvo_traj traj;
    tvo_pose I = tvo_pose_identity();
    tvo_status st;
    long n = 0;
    int rc = 0, i;
    struct sigaction sa;

    for (i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage();
            return 0;
        }
        if (v == NULL) {
            fprintf(stderr, "tvo_live: %s needs a value\n", a);
            usage();
            return 1;
        }
        i++;
        if (!strcmp(a, "--device")) {
            device = v;
        } else if (!strcmp(a, "--calib")) {
            calib = v;
        } else if (!strcmp(a, "--model")) {
            model = v;
        } else if (!strcmp(a, "--size")) {
            char wbuf[16];
            const char *x = strchr(v, 'x');
            long w = 0, h = 0;
            if (x == NULL || (size_t)(x - v) >= sizeof wbuf) {
                fprintf(stderr, "tvo_live: --size must be WxH (got '%s')\n", v);
                return 1;
            }
            memcpy(wbuf, v, (size_t)(x - v));
            wbuf[x - v] = '\0';
            if (!parse_long(wbuf, 1, TVO_MAX_IMAGE_DIM, &w) || !parse_long(x + 1, 1, TVO_MAX_IMAGE_DIM, &h)) {
                fprintf(stderr, "tvo_live: --size must be WxH (got '%s')\n", v);
                return 1;
            }
            width = (int32_t)w;
            height = (int32_t)h;
        } else if (!strcmp(a, "--fps")) {
            long l = 0;
            if (!parse_long(v, 1, 1000, &l)) {
                fprintf(stderr, "tvo_live: --fps must be 1..1000\n");
                return 1;
            }
            fps = (int32_t)l;
        } else if (!strcmp(a, "--frames")) {
            if (!parse_long(v, 1, LONG_MAX, &frames_max)) {
                fprintf(stderr, "tvo_live: --frames must be >= 1\n");
                return 1;
            }
        } else if (!strcmp(a, "--timeout-ms")) {
            long l = 0;
            if (!parse_long(v, 1, 600000, &l)) {
                fprintf(stderr, "tvo_live: --timeout-ms must be 1..600000\n");
                return 1;
            }
            timeout_ms = (int32_t)l;
        } else {
            fprintf(stderr, "tvo_live: unknown option %s\n", a);
            usage();
            return 1;
        }
    }

    if (calib != NULL) {
        size_t len = 0;
        char err[160];
        char *text = read_file(calib, &len);
        if (text == NULL) {
            fprintf(stderr, "tvo_live: cannot read %s\n", calib);
            return 1;
        }
        err[0] = '\0';
        st = tvo_euroc_parse_sensor_yaml(text, len, &cam, NULL, NULL, err, sizeof err);
        free(text);
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_live: %s: %s (%s)\n", calib, err, tvo_status_str(st));
            return 1;
        }
        have_calib = 1;
        if (width == 0) {
            width = cam.width;
            height = cam.height;
        }
    }
    if (width == 0) {
        width = 640;
        height = 480;
    }

    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);

    tvo_v4l2_config_default(&vcfg);
    vcfg.device = device;
    vcfg.width = width;
    vcfg.height = height;
    vcfg.fps = fps;
    vcfg.timeout_ms = timeout_ms;
    st = tvo_v4l2_open(&v4l2, &vcfg);
    if (st != TVO_OK) {
        fprintf(stderr, "tvo_live: %s\n", tvo_v4l2_message(&v4l2));
        switch (st) {
        case TVO_ERR_NOT_FOUND:
            fprintf(stderr, "tvo_live: no camera at %s (list cameras with `v4l2-ctl --list-devices`)\n",
                    device);
            return 2;
        case TVO_ERR_BUSY:
            fprintf(stderr, "tvo_live: %s is in use by another program\n", device);
            return 3;
        default:
            return 4;
        }
    }
    fmt = tvo_v4l2_get_format(&v4l2);
    fprintf(stderr, "tvo_live: %s\n", tvo_v4l2_message(&v4l2));

    if (have_calib && (cam.width != fmt->width || cam.height != fmt->height)) {
        fprintf(stderr, "tvo_live: the camera gives %dx%d but %s is for %dx%d\n", (int)fmt->width,
                (int)fmt->height, calib, (int)cam.width, (int)cam.height);
        rc = 4;
        goto done;
    }
    if (!have_calib) {
        double f = 0.5 * (double)fmt->width / tan(30.0 * 3.14159265358979323846 / 180.0);
        cam = tvo_camera_make_pinhole(fmt->width, fmt->height, f, f, 0.5 * (fmt->width - 1),
                                      0.5 * (fmt->height - 1));
        fprintf(stderr, "tvo_live: no --calib: assuming a pinhole camera, f = %.1f px\n", f);
    }

    tvo_vo_config_default(&cfg, &cam);
    cfg.clock = clock_cb;
    {
        size_t need = tvo_vo_required_size(&cfg);
        vo_mem = need > 0 ? malloc(need) : NULL;
        st = vo_mem != NULL ? tvo_vo_init(&vo, &cfg, vo_mem, need) : TVO_ERR_NO_MEMORY;
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_live: VO initialisation failed: %s\n", tvo_status_str(st));
            rc = 4;
            goto done;
        }
    }
    if (model != NULL) {
        size_t fsize = 0, need = 0;
        nn_file = read_file(model, &fsize);
        if (nn_file == NULL) {
            fprintf(stderr, "tvo_live: cannot read model %s\n", model);
            rc = 1;
            goto done;
        }
        st = tvo_nn_required_size(nn_file, fsize, &need);
        if (st == TVO_OK) {
            nn_mem = need > 0 ? malloc(need) : NULL;
            st = nn_mem != NULL ? tvo_nn_load(&nn, nn_file, fsize, nn_mem, need) : TVO_ERR_NO_MEMORY;
        }
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_live: model %s refused: %s\n", model, tvo_status_str(st));
            rc = 1;
            goto done;
        }
    }
    grey = fmt->width > 0 && fmt->height > 0 ? (uint8_t *)malloc((size_t)fmt->width * (size_t)fmt->height) : NULL;
    if (grey == NULL) {
        fprintf(stderr, "tvo_live: out of memory\n");
        rc = 4;
        goto done;
    }
    tvo_traj_init(&traj, &I);

    while (!g_stop && (frames_max < 0 || n < frames_max)) {
        tvo_v4l2_frame f;
        tvo_vo_result res;
        double q[4];
        st = tvo_v4l2_dequeue(&v4l2, &f);
        if (st != TVO_OK) {
            if (g_stop)
                break;
            fprintf(stderr, "tvo_live: %s (%s)\n", tvo_v4l2_message(&v4l2), tvo_status_str(st));
            rc = 5;
            break;
        }
        {
            /* Zero copy when the driver's buffer is already an 8-bit luma image. */
            tvo_image img = f.zero_copy ? tvo_image_make(f.width, f.height, f.stride, (uint8_t *)(uintptr_t)f.data)
                                        : tvo_image_make(f.width, f.height, f.width, grey);
            if (!f.zero_copy)
                (void)tvo_v4l2_frame_luma(&f, grey, f.width);
            st = tvo_vo_process(vo, &img, f.timestamp_ns, &res);
        }
        (void)tvo_v4l2_requeue(&v4l2, &f);
        n++;
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_live: frame %u: %s\n", (unsigned)f.sequence, tvo_status_str(st));
            continue;
        }
        if (res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY) {
            tvo_pose step = res.T_prev_cur;
            double scale = 1.0;
            if (nn != NULL && tvo_vo_refine(nn, &res, &step) != TVO_OK)
                scale = 0.0;
            (void)tvo_traj_step(&traj, &step, scale);
        }
        tvo_rot_to_quat(traj.T_w_c.R, q);
        printf("%.6f %d %d %d %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n", (double)f.timestamp_ns * 1e-9,
               (int)res.state, (int)res.tracked, (int)res.inliers, traj.T_w_c.t[0], traj.T_w_c.t[1],
               traj.T_w_c.t[2], q[1], q[2], q[3], q[0]);
        fflush(stdout);
    }
    {
        const tvo_v4l2_stats *s = tvo_v4l2_get_stats(&v4l2);
        fprintf(stderr, "tvo_live: %ld frames; driver: %llu good, %llu error-flagged, %llu short, %llu dropped\n",
                n, (unsigned long long)s->frames, (unsigned long long)s->error_buffers,
                (unsigned long long)s->short_buffers, (unsigned long long)s->sequence_gaps);
    }
done:
    tvo_v4l2_close(&v4l2);
    free(grey);
    free(nn_mem);
    free(nn_file);
    free(vo_mem);
    return rc;
}
