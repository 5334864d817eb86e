/* SPDX-License-Identifier: Apache-2.0 */
/* tvo_live: visual odometry on a live V4L2 camera.
 *
 *   tvo_live [--device /dev/video0] [--calib FILE [--calib-cam NAME]] [--model FILE] [--preset NAME]
 *            [--size WxH] [--fps N] [--frames N] [--timeout-ms N] [--out TRAJ.txt] [--quiet]
 *
 * Prints one line per frame on stdout, at the camera rate:
 *   t_s state tracked inliers tx ty tz qx qy qz qw
 * (t in seconds of CLOCK_MONOTONIC, the camera pose from the VO's local map in the world frame of the
 * first frame, TUM order; translation in the map's unit, one unknown factor for the whole run, or in
 * metres with --model: the map's motion times the networks' path length over the map's, updated at each
 * keyframe, and before the first keyframe each step the networks' length, as tvo_replay --scale model;
 * examples/replay/map_scale.h). --out also writes the
 * trajectory in TUM format (t tx ty tz qx qy qz qw). Status and errors go to stderr. --calib takes any
 * calibration of tinyvo/port/calib.h (EuRoC sensor.yaml, Kalibr camchain, OpenCV, ROS camera_info);
 * without it a distortion-free pinhole with a 60 degree horizontal field of view is assumed. The
 * calibration, the model and the --out file are checked before the camera is opened. Cameras driven
 * only by libcamera: `libcamerify tvo_live ...` (docs/ports.md).
 * Exit codes: 0 done (--frames reached or Ctrl-C), 1 a runtime error (a bad calibration or model, no
 * device, device busy or unusable, size mismatch, stream lost or stalled: one line on stderr says
 * which), 2 a usage error (one line naming the option). */
#include "map_scale.h"
#include "settings.h"
#include "tinyvo/port/calib.h"
#include "tinyvo/port/clock.h"
#include "tinyvo/port/v4l2.h"
#include "tinyvo/tinyvo.h"
#include "tinyvo/version.h"
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

static void usage(FILE *f)
{
    fprintf(f,
            "usage: tvo_live [--device PATH] [--calib FILE] [--model FILE] [--preset NAME]\n"
            "                [--size WxH] [--fps N] [--frames N] [--timeout-ms N] [--out TRAJ.txt]\n"
            "                [--quiet]\n"
            "  --device PATH     V4L2 capture device (default /dev/video0)\n"
            "  --calib FILE      camera calibration: EuRoC sensor.yaml, Kalibr camchain, OpenCV or\n"
            "                    ROS camera_info YAML (docs/calibration.md)\n"
            "  --calib-cam NAME  camera of a Kalibr camchain (default cam0)\n"
            "  --model FILE      tinyvo weights file: the map's scale in metres from the per-DoF\n"
            "                    networks' step lengths, set at every keyframe\n"
            "  --preset NAME     default, balanced, accurate, basic or small (vo.h, docs/camera.md)\n"
            "  --size WxH        requested size (default: the calibration's, else 640x480)\n"
            "  --fps N           requested frame rate (default 30)\n"
            "  --frames N        stop after N frames (default: until Ctrl-C)\n"
            "  --timeout-ms N    give up when no frame arrives for N ms (default 2000)\n"
            "  --out FILE        also write the trajectory in TUM format (t tx ty tz qx qy qz qw)\n"
            "  --quiet           no status lines on stderr (errors are still reported)\n"
            "  --version         print the version and exit\n"
            "  --help            this text\n"
            "Exit codes: 0 done, 1 runtime error, 2 usage error.\n");
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
    const char *device = "/dev/video0", *calib = NULL, *calib_cam = NULL, *model = NULL, *out_path = NULL;
    FILE *out = NULL;
    int quiet = 0;
    tvo_vo_preset preset = TVO_VO_PRESET_DEFAULT;
    double unit_m = 1.0; /* metres per map unit: 1 (the map's own unit), or from the networks (--model) */
    tvo_map_scale msc;   /* --model: the networks' path length over the map's (map_scale.h) */
    tvo_pose T_w_c_prev;
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
        static const char *const with_value[] = {"--device", "--calib", "--calib-cam", "--model",
                                                 "--size",   "--fps",   "--frames",    "--timeout-ms",
                                                 "--out",    "--preset"};
        size_t k;
        int known = 0;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return 0;
        }
        if (!strcmp(a, "--version")) {
            printf("tvo_live %s\n", tvo_version());
            return 0;
        }
        if (!strcmp(a, "--quiet")) {
            quiet = 1;
            continue;
        }
        for (k = 0; k < sizeof with_value / sizeof with_value[0]; ++k)
            known |= !strcmp(a, with_value[k]);
        if (!known) {
            fprintf(stderr, "tvo_live: unknown option '%s' (see --help)\n", a);
            return 2;
        }
        if (v == NULL) {
            fprintf(stderr, "tvo_live: %s needs a value\n", a);
            return 2;
        }
        i++;
        if (!strcmp(a, "--device")) {
            device = v;
        } else if (!strcmp(a, "--calib")) {
            calib = v;
        } else if (!strcmp(a, "--calib-cam")) {
            calib_cam = v;
        } else if (!strcmp(a, "--model")) {
            model = v;
        } else if (!strcmp(a, "--out")) {
            out_path = v;
        } else if (!strcmp(a, "--preset")) {
            tvo_vo_config check;
            if (tvo_replay_preset_from_name(v, &preset) != 0) {
                fprintf(stderr,
                        "tvo_live: --preset must be default, balanced, accurate, basic or small (got '%s')\n",
                        v);
                return 2;
            }
            if (tvo_vo_config_preset(&check, NULL, preset) == TVO_ERR_UNSUPPORTED) {
                fprintf(stderr,
                        "tvo_live: --preset %s needs the affine refinement, which this build leaves out\n",
                        v);
                return 2;
            }
        } else if (!strcmp(a, "--size")) {
            char wbuf[16];
            const char *x = strchr(v, 'x');
            long w = 0, h = 0;
            if (x == NULL || (size_t)(x - v) >= sizeof wbuf) {
                fprintf(stderr, "tvo_live: --size must be WxH (got '%s')\n", v);
                return 2;
            }
            memcpy(wbuf, v, (size_t)(x - v));
            wbuf[x - v] = '\0';
            if (!parse_long(wbuf, 1, TVO_MAX_IMAGE_DIM, &w) || !parse_long(x + 1, 1, TVO_MAX_IMAGE_DIM, &h)) {
                fprintf(stderr, "tvo_live: --size must be WxH (got '%s')\n", v);
                return 2;
            }
            width = (int32_t)w;
            height = (int32_t)h;
        } else if (!strcmp(a, "--fps")) {
            long l = 0;
            if (!parse_long(v, 1, 1000, &l)) {
                fprintf(stderr, "tvo_live: --fps must be 1..1000 (got '%s')\n", v);
                return 2;
            }
            fps = (int32_t)l;
        } else if (!strcmp(a, "--frames")) {
            if (!parse_long(v, 1, LONG_MAX, &frames_max)) {
                fprintf(stderr, "tvo_live: --frames must be >= 1 (got '%s')\n", v);
                return 2;
            }
        } else { /* --timeout-ms */
            long l = 0;
            if (!parse_long(v, 1, 600000, &l)) {
                fprintf(stderr, "tvo_live: --timeout-ms must be 1..600000 (got '%s')\n", v);
                return 2;
            }
            timeout_ms = (int32_t)l;
        }
    }
    if (calib_cam != NULL && calib == NULL) {
        fprintf(stderr, "tvo_live: --calib-cam goes with --calib\n");
        return 2;
    }

    /* everything that can be checked without the camera, before opening it */
    if (calib != NULL) {
        char err[512];
        tvo_calib c;
        st = tvo_calib_load(calib, calib_cam, &c, err, sizeof err);
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_live: calibration refused (%s): %s\n", tvo_status_str(st), err);
            return 1;
        }
        cam = c.camera;
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
    if (model != NULL) {
        size_t fsize = 0, need = 0;
        nn_file = read_file(model, &fsize);
        if (nn_file == NULL) {
            fprintf(stderr, "tvo_live: cannot read model %s\n", model);
            return 1;
        }
        st = tvo_nn_required_size(nn_file, fsize, &need);
        if (st == TVO_OK) {
            nn_mem = need > 0 ? malloc(need) : NULL;
            st = nn_mem != NULL ? tvo_nn_load(&nn, nn_file, fsize, nn_mem, need) : TVO_ERR_NO_MEMORY;
        }
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_live: model %s refused: %s\n", model, tvo_status_str(st));
            free(nn_mem);
            free(nn_file);
            return 1;
        }
    }
    if (out_path != NULL) {
        out = fopen(out_path, "w");
        if (out == NULL) {
            fprintf(stderr, "tvo_live: cannot write %s: %s\n", out_path, strerror(errno));
            free(nn_mem);
            free(nn_file);
            return 1;
        }
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
        if (st == TVO_ERR_NOT_FOUND)
            fprintf(stderr, "tvo_live: no camera at %s (list cameras with `v4l2-ctl --list-devices`)\n",
                    device);
        else if (st == TVO_ERR_BUSY)
            fprintf(stderr, "tvo_live: %s is in use by another program\n", device);
        else
            fprintf(stderr, "tvo_live: %s\n", tvo_v4l2_message(&v4l2));
        rc = 1;
        goto early;
    }
    fmt = tvo_v4l2_get_format(&v4l2);
    if (!quiet)
        fprintf(stderr, "tvo_live: %s\n", tvo_v4l2_message(&v4l2));

    if (have_calib && (cam.width != fmt->width || cam.height != fmt->height)) {
        fprintf(stderr, "tvo_live: the camera gives %dx%d but %s is for %dx%d\n", (int)fmt->width,
                (int)fmt->height, calib, (int)cam.width, (int)cam.height);
        rc = 1;
        goto done;
    }
    if (!have_calib) {
        double f = 0.5 * (double)fmt->width / tan(30.0 * 3.14159265358979323846 / 180.0);
        cam = tvo_camera_make_pinhole(fmt->width, fmt->height, f, f, 0.5 * (fmt->width - 1),
                                      0.5 * (fmt->height - 1));
        if (!quiet)
            fprintf(stderr, "tvo_live: no --calib: assuming a pinhole camera, f = %.1f px\n", f);
    }

    (void)tvo_vo_config_preset(&cfg, &cam, preset); /* checked with the options */
    cfg.clock = clock_cb;
    {
        size_t need = tvo_vo_required_size(&cfg);
        vo_mem = need > 0 ? malloc(need) : NULL;
        st = vo_mem != NULL ? tvo_vo_init(&vo, &cfg, vo_mem, need) : TVO_ERR_NO_MEMORY;
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_live: VO initialisation failed: %s\n", tvo_status_str(st));
            rc = 1;
            goto done;
        }
    }
    grey = fmt->width > 0 && fmt->height > 0 ? (uint8_t *)malloc((size_t)fmt->width * (size_t)fmt->height)
                                             : NULL;
    if (grey == NULL) {
        fprintf(stderr, "tvo_live: out of memory\n");
        rc = 1;
        goto done;
    }
    tvo_traj_init(&traj, &I);
    T_w_c_prev = I;
    tvo_map_scale_reset(&msc);

    while (!g_stop && (frames_max < 0 || n < frames_max)) {
        tvo_v4l2_frame f;
        tvo_vo_result res;
        double q[4];
        st = tvo_v4l2_dequeue(&v4l2, &f);
        if (st != TVO_OK) {
            if (g_stop)
                break;
            fprintf(stderr, "tvo_live: %s (%s)\n", tvo_v4l2_message(&v4l2), tvo_status_str(st));
            rc = 1;
            break;
        }
        {
            /* Zero copy when the driver's buffer is already an 8-bit luma image. */
            tvo_image img = f.zero_copy
                    ? tvo_image_make(f.width, f.height, f.stride, (uint8_t *)(uintptr_t)f.data)
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
        {
            /* the map's motion since the last frame, times metres per map unit (1 without --model) */
            const tvo_pose rel = tvo_pose_relative(&T_w_c_prev, &res.T_w_c);
            const double vo_len = sqrt(rel.t[0] * rel.t[0] + rel.t[1] * rel.t[1] + rel.t[2] * rel.t[2]);
            tvo_pose step;
            T_w_c_prev = res.T_w_c;
            if (nn != NULL) {
                double len = -1.0;
                if (res.state == TVO_VO_OK && tvo_vo_refine(nn, &res, &step) == TVO_OK)
                    len = sqrt(step.t[0] * step.t[0] + step.t[1] * step.t[1] + step.t[2] * step.t[2]);
                unit_m = tvo_map_scale_frame(&msc, TVO_MAP_SCALE_WHOLE_PATH, 0.0, vo_len, len, res.keyframe);
            }
            (void)tvo_traj_step(&traj, &rel, unit_m);
        }
        tvo_rot_to_quat(traj.T_w_c.R, q);
        printf("%.6f %d %d %d %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n", (double)f.timestamp_ns * 1e-9,
               (int)res.state, (int)res.tracked, (int)res.inliers, traj.T_w_c.t[0], traj.T_w_c.t[1],
               traj.T_w_c.t[2], q[1], q[2], q[3], q[0]);
        fflush(stdout);
        if (out != NULL)
            fprintf(out, "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", (double)f.timestamp_ns * 1e-9,
                    traj.T_w_c.t[0], traj.T_w_c.t[1], traj.T_w_c.t[2], q[1], q[2], q[3], q[0]);
    }
    if (!quiet) {
        const tvo_v4l2_stats *s = tvo_v4l2_get_stats(&v4l2);
        fprintf(stderr,
                "tvo_live: %ld frames; driver: %llu good, %llu error-flagged, %llu short, %llu dropped\n", n,
                (unsigned long long)s->frames, (unsigned long long)s->error_buffers,
                (unsigned long long)s->short_buffers, (unsigned long long)s->sequence_gaps);
    }
done:
    tvo_v4l2_close(&v4l2);
early:
    if (out != NULL && fclose(out) != 0 && rc == 0) {
        fprintf(stderr, "tvo_live: error writing %s\n", out_path);
        rc = 1;
    }
    free(grey);
    free(nn_mem);
    free(nn_file);
    free(vo_mem);
    return rc;
}
