/* SPDX-License-Identifier: Apache-2.0 */
/* Fuzz harness: the TUM RGB-D and KITTI odometry readers (tinyvo/port/dataset.h).
 *
 * The input is split at its first "\n---\n" into a frame list A and a pose file B (without the
 * separator both are the whole input). The buffer parsers run on A and on B: tvo_tum_parse_groundtruth
 * and tvo_kitti_parse_poses three times each (counting, a capacity one short: TVO_ERR_NO_MEMORY with
 * the same count, an exact heap array: ASan catches a write past it) and tvo_kitti_parse_calib. Then
 * the folder readers: A is written as a TUM folder's rgb.txt and a KITTI folder's times.txt, B as its
 * groundtruth.txt and poses.txt, next to a fixed calib.txt and one 4x2 PNG (rgb/a.png,
 * image_0/000000.png), and both folders are opened strictly and with TVO_EUROC_SKIP_BAD_ROWS.
 * Invariants: documented statuses with a NUL-terminated, non-empty message on error; parsed rows
 * finite, strictly increasing in time, unit quaternions, rigid poses, P0 with fx, fy > 0; an opened
 * sequence has frames with valid names, bad-row messages within bounds, ground truth whose queries
 * give finite rigid poses. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "fuzz_common.h"
#include "tinyvo/port/dataset.h"
#include "tinyvo/port/euroc.h"
#include "tinyvo/port/png.h"

static char g_tum[96], g_kitti[96];

static int err_ok(const char *err, size_t err_size)
{
    return memchr(err, '\0', err_size) != NULL;
}

static void write_file(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    TVO_FUZZ_CHECK(f != NULL);
    TVO_FUZZ_CHECK(size == 0 || fwrite(data, 1, size, f) == size);
    TVO_FUZZ_CHECK(fclose(f) == 0);
}

/* The scratch folders go at exit (the ctest replay; a libFuzzer run may leave them in /tmp). */
static void cleanup(void)
{
    static const char *const tum[] = {"rgb.txt", "groundtruth.txt", "rgb/a.png", "rgb"};
    static const char *const kitti[] = {"times.txt", "poses.txt", "calib.txt", "image_0/000000.png",
                                        "image_0"};
    char p[200];
    for (size_t i = 0; i < sizeof tum / sizeof tum[0]; ++i) {
        snprintf(p, sizeof p, "%s/%s", g_tum, tum[i]);
        (void)remove(p);
    }
    for (size_t i = 0; i < sizeof kitti / sizeof kitti[0]; ++i) {
        snprintf(p, sizeof p, "%s/%s", g_kitti, kitti[i]);
        (void)remove(p);
    }
    (void)rmdir(g_tum);
    (void)rmdir(g_kitti);
}

static void setup(void)
{
    static const uint8_t px[8] = {10, 20, 30, 40, 50, 60, 70, 80};
    static const char calib[] = "P0: 2 0 1.5 0 0 2 0.5 0 0 0 1 0\nP1: 2 0 1.5 -1 0 2 0.5 0 0 0 1 0\n";
    char p[200];
    snprintf(g_tum, sizeof g_tum, "/tmp/tvo_fuzz_tum_%ld", (long)getpid());
    snprintf(g_kitti, sizeof g_kitti, "/tmp/tvo_fuzz_kitti_%ld", (long)getpid());
    (void)mkdir(g_tum, 0700);
    (void)mkdir(g_kitti, 0700);
    snprintf(p, sizeof p, "%s/rgb", g_tum);
    (void)mkdir(p, 0700);
    snprintf(p, sizeof p, "%s/image_0", g_kitti);
    (void)mkdir(p, 0700);
    snprintf(p, sizeof p, "%s/rgb/a.png", g_tum);
    TVO_FUZZ_CHECK(tvo_png_write_gray8(p, px, 4, 2, 4) == TVO_OK);
    snprintf(p, sizeof p, "%s/image_0/000000.png", g_kitti);
    TVO_FUZZ_CHECK(tvo_png_write_gray8(p, px, 4, 2, 4) == TVO_OK);
    snprintf(p, sizeof p, "%s/calib.txt", g_kitti);
    write_file(p, calib, sizeof calib - 1);
    (void)atexit(cleanup);
}

static void check_pose(const tvo_pose *T)
{
    TVO_FUZZ_CHECK(tvo_pose_is_finite(T));
    TVO_FUZZ_CHECK(tvo_rot_orthogonality_error(T->R) < 1e-6);
}

static void fuzz_tum_gt(const char *text, size_t len)
{
    char err[256], small[6];
    int32_t n = -1, m = -1;
    tvo_euroc_gt_row *rows;
    tvo_status st = tvo_tum_parse_groundtruth(text, len, NULL, 0, &n, err, sizeof err);
    TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_FORMAT);
    TVO_FUZZ_CHECK(err_ok(err, sizeof err));
    if (st != TVO_OK) {
        TVO_FUZZ_CHECK(err[0] != '\0');
        return;
    }
    if (n == 0)
        return;
    rows = (tvo_euroc_gt_row *)malloc((size_t)n * sizeof *rows);
    if (rows == NULL)
        return;
    st = tvo_tum_parse_groundtruth(text, len, rows, n - 1, &m, small, sizeof small);
    TVO_FUZZ_CHECK(st == TVO_ERR_NO_MEMORY && m == n && err_ok(small, sizeof small));
    st = tvo_tum_parse_groundtruth(text, len, rows, n, &m, small, sizeof small);
    TVO_FUZZ_CHECK(st == TVO_OK && m == n);
    for (int32_t i = 0; i < n; ++i) {
        const double *q = rows[i].q_wxyz;
        TVO_FUZZ_CHECK(rows[i].t_ns >= 0 && (i == 0 || rows[i].t_ns > rows[i - 1].t_ns));
        for (int k = 0; k < 3; ++k)
            TVO_FUZZ_CHECK(isfinite(rows[i].p[k]) && fabs(rows[i].p[k]) <= TVO_EUROC_MAX_COORD);
        TVO_FUZZ_CHECK(fabs(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0) < 1e-9);
    }
    free(rows);
}

static void fuzz_kitti_poses(const char *text, size_t len)
{
    char err[256], small[6];
    int32_t n = -1, m = -1;
    tvo_pose *T;
    tvo_status st = tvo_kitti_parse_poses(text, len, NULL, 0, &n, err, sizeof err);
    TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_FORMAT);
    TVO_FUZZ_CHECK(err_ok(err, sizeof err));
    if (st != TVO_OK) {
        TVO_FUZZ_CHECK(err[0] != '\0');
        return;
    }
    if (n == 0)
        return;
    T = (tvo_pose *)malloc((size_t)n * sizeof *T);
    if (T == NULL)
        return;
    st = tvo_kitti_parse_poses(text, len, T, n - 1, &m, small, sizeof small);
    TVO_FUZZ_CHECK(st == TVO_ERR_NO_MEMORY && m == n && err_ok(small, sizeof small));
    st = tvo_kitti_parse_poses(text, len, T, n, &m, small, sizeof small);
    TVO_FUZZ_CHECK(st == TVO_OK && m == n);
    for (int32_t i = 0; i < n; ++i) {
        check_pose(&T[i]);
        for (int k = 0; k < 3; ++k)
            TVO_FUZZ_CHECK(fabs(T[i].t[k]) <= TVO_EUROC_MAX_COORD);
    }
    free(T);
}

static void fuzz_kitti_calib(const char *text, size_t len)
{
    double P[12];
    char err[256];
    tvo_status st = tvo_kitti_parse_calib(text, len, P, err, sizeof err);
    TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_FORMAT);
    TVO_FUZZ_CHECK(err_ok(err, sizeof err));
    if (st != TVO_OK) {
        TVO_FUZZ_CHECK(err[0] != '\0');
        return;
    }
    for (int k = 0; k < 12; ++k)
        TVO_FUZZ_CHECK(isfinite(P[k]));
    TVO_FUZZ_CHECK(P[0] > 0.0 && P[5] > 0.0 && P[10] == 1.0);
}

/* 1 when the relative path f has no "." or ".." component. */
static int no_dot_parts(const char *f)
{
    const char *p = f;
    while (*p) {
        const char *q = strchr(p, '/');
        size_t n = q != NULL ? (size_t)(q - p) : strlen(p);
        if ((n == 1 && p[0] == '.') || (n == 2 && p[0] == '.' && p[1] == '.'))
            return 0;
        if (q == NULL)
            break;
        p = q + 1;
    }
    return 1;
}

/* An opened sequence: its frames, bad rows and ground truth. */
static void check_seq(const tvo_euroc *seq, int tum)
{
    const int32_t n = tvo_euroc_frame_count(seq), nb = tvo_euroc_bad_row_count(seq);
    char path[1024];
    TVO_FUZZ_CHECK(n > 0 && nb >= 0);
    for (int32_t i = 0; i < n; ++i) {
        const char *f = tvo_euroc_frame_file(seq, i);
        TVO_FUZZ_CHECK(f != NULL && f[0] != '\0' && f[0] != '/' && no_dot_parts(f));
        TVO_FUZZ_CHECK(strnlen(f, TVO_EUROC_MAX_NAME) < TVO_EUROC_MAX_NAME);
        TVO_FUZZ_CHECK(tvo_euroc_frame_time(seq, i) >= 0);
        TVO_FUZZ_CHECK(tvo_euroc_frame_path(seq, i, path, sizeof path) == TVO_OK);
        if (!tum)
            TVO_FUZZ_CHECK(strlen(f) == 10 && strcmp(f + 6, ".png") == 0);
    }
    for (int32_t i = 0; i < nb && i < TVO_EUROC_MAX_BAD_ROWS; ++i) {
        const char *msg = tvo_euroc_bad_row(seq, i);
        TVO_FUZZ_CHECK(msg != NULL && err_ok(msg, TVO_EUROC_BAD_ROW_MSG) && msg[0] != '\0');
    }
    TVO_FUZZ_CHECK(tvo_euroc_bad_row(seq, nb) == NULL);
    TVO_FUZZ_CHECK(tvo_euroc_rate_hz(seq) >= 0.0 && isfinite(tvo_euroc_rate_hz(seq)));
    TVO_FUZZ_CHECK(tvo_camera_check(tvo_euroc_camera(seq)) == TVO_OK);
    if (tvo_euroc_has_groundtruth(seq)) {
        const int64_t ts[4] = {0, tvo_euroc_frame_time(seq, 0), tvo_euroc_frame_time(seq, n - 1) + 1,
                               INT64_MAX};
        for (int k = 0; k < 4; ++k) {
            tvo_pose T;
            tvo_status st = tvo_euroc_groundtruth_interp(seq, ts[k], INT64_MAX, &T);
            TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_RANGE);
            if (st == TVO_OK)
                check_pose(&T);
            st = tvo_euroc_groundtruth(seq, ts[k], INT64_MAX, &T);
            TVO_FUZZ_CHECK(st == TVO_OK);
            check_pose(&T);
        }
    }
}

static void fuzz_folders(const char *a, size_t na, const char *b, size_t nb)
{
    static const unsigned flags[2] = {0u, TVO_EUROC_SKIP_BAD_ROWS};
    tvo_camera cam = tvo_camera_make_pinhole(4, 2, 2.0, 2.0, 1.5, 0.5);
    char p[200], err[320];
    snprintf(p, sizeof p, "%s/rgb.txt", g_tum);
    write_file(p, a, na);
    snprintf(p, sizeof p, "%s/groundtruth.txt", g_tum);
    write_file(p, b, nb);
    snprintf(p, sizeof p, "%s/times.txt", g_kitti);
    write_file(p, a, na);
    snprintf(p, sizeof p, "%s/poses.txt", g_kitti);
    write_file(p, b, nb);
    for (int k = 0; k < 2; ++k) {
        tvo_euroc *seq = NULL;
        tvo_status st = tvo_tum_open(&seq, g_tum, &cam, flags[k], err, sizeof err);
        TVO_FUZZ_CHECK(tvo_fuzz_status_valid(st) && err_ok(err, sizeof err));
        if (st == TVO_OK)
            check_seq(seq, 1);
        else
            TVO_FUZZ_CHECK(seq == NULL && err[0] != '\0');
        tvo_euroc_close(seq);
        seq = NULL;
        st = tvo_kitti_open(&seq, g_kitti, NULL, flags[k], err, sizeof err);
        TVO_FUZZ_CHECK(tvo_fuzz_status_valid(st) && err_ok(err, sizeof err));
        if (st == TVO_OK)
            check_seq(seq, 0);
        else
            TVO_FUZZ_CHECK(seq == NULL && err[0] != '\0');
        tvo_euroc_close(seq);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int ready = 0;
    const char *text = (const char *)data, *sep = NULL, *a = text, *b = text;
    size_t na = size, nb = size, i;
    if (!ready) {
        setup();
        ready = 1;
    }
    for (i = 0; i + 5 <= size; ++i)
        if (memcmp(text + i, "\n---\n", 5) == 0) {
            sep = text + i;
            break;
        }
    if (sep != NULL) {
        na = (size_t)(sep - text) + 1;
        b = sep + 5;
        nb = size - (size_t)(b - text);
    }
    fuzz_tum_gt(a, na);
    fuzz_kitti_poses(a, na);
    fuzz_kitti_calib(a, na);
    if (sep != NULL) {
        fuzz_tum_gt(b, nb);
        fuzz_kitti_poses(b, nb);
        fuzz_kitti_calib(b, nb);
    }
    fuzz_folders(a, na, b, nb);
    return 0;
}
