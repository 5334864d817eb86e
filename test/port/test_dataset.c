/* SPDX-License-Identifier: Apache-2.0 */
/* Dataset folders besides EuRoC (tinyvo/port/dataset.h) and the skipping of malformed frame rows.
 *
 * KITTI: a KITTI odometry folder (image_0/%06d.png, times.txt, calib.txt with P0, a poses file) is
 * built in a temporary directory from the shared KITTI 06 sample (real images, times and camera
 * poses, stored there in ASL layout; skipped when TVO_DATA_DIR lacks it), then read back and compared
 * with the ASL copy. TUM: the same real frames in a TUM RGB-D layout (rgb.txt with TUM's header
 * lines, rgb/<t>.png, groundtruth.txt in TUM's t tx ty tz qx qy qz qw order), and the TUM parsers on
 * malformed text. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <sys/stat.h>
#include <unistd.h>

#include "tvo_test.h"
#include "tinyvo/port/dataset.h"
#include "tinyvo/port/euroc.h"
#include "tinyvo/port/png.h"

static char g_dir[256];

static int setup(void **state)
{
    (void)state;
    snprintf(g_dir, sizeof g_dir, "/tmp/tvo_test_dataset_XXXXXX");
    return mkdtemp(g_dir) != NULL ? 0 : -1;
}

static int teardown(void **state)
{
    char cmd[300];
    (void)state;
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void path_of(char *p, size_t size, const char *rel)
{
    const int w = snprintf(p, size, "%s/%s", g_dir, rel);
    assert_true(w > 0 && (size_t)w < size);
}

static void write_text(const char *rel, const char *text)
{
    char p[600];
    FILE *f;
    path_of(p, sizeof p, rel);
    f = fopen(p, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void mkdir_rel(const char *rel)
{
    char p[600];
    path_of(p, sizeof p, rel);
    assert_int_equal(mkdir(p, 0755), 0);
}

static void remove_rel(const char *rel)
{
    char p[600];
    path_of(p, sizeof p, rel);
    assert_int_equal(remove(p), 0);
}

static void rename_rel(const char *from, const char *to)
{
    char a[600], b[600];
    path_of(a, sizeof a, from);
    path_of(b, sizeof b, to);
    assert_int_equal(rename(a, b), 0);
}

/* The shared KITTI 06 sample (ASL layout), or NULL. */
static tvo_euroc *open_kitti06(void)
{
    const char *d = tvo_test_data_dir();
    char p[600], err[600];
    tvo_euroc *seq = NULL;
    if (d == NULL)
        return NULL;
    snprintf(p, sizeof p, "%s/kitti/kitti06_51", d);
    if (tvo_euroc_open(&seq, p, "cam0", err, sizeof err) != TVO_OK)
        return NULL;
    return seq;
}

/* KITTI layout from the ASL copy: image_0 symlinks, times.txt (s from the first frame), calib.txt,
 * poses (12 numbers per line, the ASL ground truth at frame times). */
static void build_kitti(const tvo_euroc *src, const char *rel)
{
    char p[700], img[1200], buf[800];
    FILE *times, *poses;
    const tvo_camera *cam = tvo_euroc_camera(src);
    const int64_t t0 = tvo_euroc_frame_time(src, 0);
    int32_t i;
    snprintf(buf, sizeof buf, "%s", rel);
    mkdir_rel(buf);
    snprintf(buf, sizeof buf, "%s/image_0", rel);
    mkdir_rel(buf);
    snprintf(buf, sizeof buf, "%s/times.txt", rel);
    path_of(p, sizeof p, buf);
    times = fopen(p, "wb");
    snprintf(buf, sizeof buf, "%s/poses.txt", rel);
    path_of(p, sizeof p, buf);
    poses = fopen(p, "wb");
    assert_non_null(times);
    assert_non_null(poses);
    for (i = 0; i < tvo_euroc_frame_count(src); ++i) {
        tvo_pose T;
        const int64_t t = tvo_euroc_frame_time(src, i);
        assert_int_equal(tvo_euroc_frame_path(src, i, img, sizeof img), TVO_OK);
        snprintf(buf, sizeof buf, "%s/image_0/%06d.png", rel, (int)i);
        path_of(p, sizeof p, buf);
        assert_int_equal(symlink(img, p), 0);
        fprintf(times, "%.9e\n", (double)(t - t0) * 1e-9);
        assert_int_equal(tvo_euroc_groundtruth(src, t, 1000, &T), TVO_OK);
        fprintf(poses, "%.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e\n", T.R[0], T.R[1],
                T.R[2], T.t[0], T.R[3], T.R[4], T.R[5], T.t[1], T.R[6], T.R[7], T.R[8], T.t[2]);
    }
    fclose(times);
    fclose(poses);
    snprintf(buf, sizeof buf, "%s/calib.txt", rel);
    {
        char text[1200];
        snprintf(text, sizeof text,
                 "P0: %.12e 0.000000000000e+00 %.12e 0.000000000000e+00 0.000000000000e+00 %.12e %.12e "
                 "0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 "
                 "0.000000000000e+00\n"
                 "P1: %.12e 0.000000000000e+00 %.12e -3.798145000000e+02 0.000000000000e+00 %.12e %.12e "
                 "0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 "
                 "0.000000000000e+00\n",
                 cam->fx, cam->cx, cam->fy, cam->cy, cam->fx, cam->cx, cam->fy, cam->cy);
        write_text(buf, text);
    }
}

static void test_kitti_layout(void **state)
{
    tvo_euroc *src = open_kitti06(), *seq = NULL;
    char p[700], err[700];
    int32_t i;
    (void)state;
    if (src == NULL)
        TVO_SKIP("TVO_DATA_DIR/kitti/kitti06_51 not found");
    build_kitti(src, "06");
    path_of(p, sizeof p, "06");
    assert_int_equal(tvo_kitti_open(&seq, p, NULL, 0, err, sizeof err), TVO_OK);
    assert_int_equal(tvo_euroc_frame_count(seq), tvo_euroc_frame_count(src));
    {
        const tvo_camera *a = tvo_euroc_camera(seq), *b = tvo_euroc_camera(src);
        assert_int_equal(a->width, 1226);
        assert_int_equal(a->height, 370);
        assert_true(a->fx == b->fx && a->fy == b->fy && a->cx == b->cx && a->cy == b->cy);
        assert_int_equal(a->model, TVO_DIST_NONE);
    }
    assert_true(fabs(tvo_euroc_rate_hz(seq) - tvo_euroc_rate_hz(src)) < 0.5); /* ~10 Hz */
    assert_true(tvo_euroc_has_groundtruth(seq));
    assert_int_equal(tvo_euroc_groundtruth_count(seq), tvo_euroc_frame_count(src));
    for (i = 0; i < tvo_euroc_frame_count(seq); ++i) {
        const int64_t dt = tvo_euroc_frame_time(seq, i) -
                (tvo_euroc_frame_time(src, i) - tvo_euroc_frame_time(src, 0));
        tvo_pose A, B;
        int k;
        assert_true(dt >= -1 && dt <= 1); /* %.9e keeps the ns */
        assert_int_equal(tvo_euroc_groundtruth(seq, tvo_euroc_frame_time(seq, i), 0, &A), TVO_OK);
        assert_int_equal(tvo_euroc_groundtruth(src, tvo_euroc_frame_time(src, i), 1000, &B), TVO_OK);
        for (k = 0; k < 9; ++k)
            assert_true(fabs(A.R[k] - B.R[k]) < 1e-8);
        for (k = 0; k < 3; ++k)
            assert_true(fabs(A.t[k] - B.t[k]) < 1e-8 * (1.0 + fabs(B.t[k])));
    }
    {
        /* the same pixels through both readers */
        const size_t n = 1226 * 370;
        uint8_t *a = (uint8_t *)malloc(n), *b = (uint8_t *)malloc(n);
        assert_non_null(a);
        assert_non_null(b);
        assert_int_equal(tvo_euroc_read_frame(seq, 50, a, n), TVO_OK);
        assert_int_equal(tvo_euroc_read_frame(src, 50, b, n), TVO_OK);
        assert_memory_equal(a, b, n);
        free(a);
        free(b);
    }
    tvo_euroc_close(seq);

    /* poses given explicitly; KITTI's own place for them (../../poses/<seq>.txt) */
    {
        char given[700];
        path_of(given, sizeof given, "06/poses.txt");
        assert_int_equal(tvo_kitti_open(&seq, p, given, 0, err, sizeof err), TVO_OK);
    }
    assert_true(tvo_euroc_has_groundtruth(seq));
    tvo_euroc_close(seq);
    mkdir_rel("poses");
    rename_rel("06/poses.txt", "poses/06.txt");
    mkdir_rel("sequences");
    rename_rel("06", "sequences/06");
    path_of(p, sizeof p, "sequences/06");
    assert_int_equal(tvo_kitti_open(&seq, p, NULL, 0, err, sizeof err), TVO_OK);
    assert_int_equal(tvo_euroc_groundtruth_count(seq), 51);
    tvo_euroc_close(seq);
    /* no poses anywhere: no ground truth, not an error; a poses file given but missing: an error */
    rename_rel("poses/06.txt", "poses/06.bak");
    assert_int_equal(tvo_kitti_open(&seq, p, NULL, 0, err, sizeof err), TVO_OK);
    assert_false(tvo_euroc_has_groundtruth(seq));
    tvo_euroc_close(seq);
    {
        char given[700];
        path_of(given, sizeof given, "poses/06.txt");
        assert_int_equal(tvo_kitti_open(&seq, p, given, 0, err, sizeof err), TVO_ERR_NOT_FOUND);
        assert_non_null(strstr(err, "poses/06.txt not found"));
        assert_null(seq);
    }
    /* a poses file with a row missing */
    {
        char bak[700], text[4096 * 8];
        FILE *f;
        size_t n;
        path_of(bak, sizeof bak, "poses/06.bak");
        f = fopen(bak, "rb");
        assert_non_null(f);
        n = fread(text, 1, sizeof text - 1, f);
        fclose(f);
        text[n] = '\0';
        *strrchr(text, '\n') = '\0';
        *(strrchr(text, '\n') + 1) = '\0';
        write_text("poses/06.txt", text);
        assert_int_equal(tvo_kitti_open(&seq, p, NULL, 0, err, sizeof err), TVO_ERR_FORMAT);
        assert_non_null(strstr(err, "50 poses for the 51 frames of times.txt"));
    }
    /* required files: named when missing */
    rename_rel("sequences/06/calib.txt", "sequences/06/calib.bak");
    assert_int_equal(tvo_kitti_open(&seq, p, NULL, 0, err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "calib.txt not found"));
    rename_rel("sequences/06/calib.bak", "sequences/06/calib.txt");
    rename_rel("sequences/06/times.txt", "sequences/06/times.bak");
    assert_int_equal(tvo_kitti_open(&seq, p, NULL, 0, err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "times.txt not found"));
    /* a malformed line in times.txt: strict open fails naming it, a lenient one skips that frame */
    {
        char bak[700], text[4096];
        FILE *f;
        size_t n;
        char *third;
        remove_rel("poses/06.txt");
        path_of(bak, sizeof bak, "sequences/06/times.bak");
        f = fopen(bak, "rb");
        assert_non_null(f);
        n = fread(text, 1, sizeof text - 1, f);
        fclose(f);
        text[n] = '\0';
        third = strchr(strchr(text, '\n') + 1, '\n') + 1;
        third[0] = 'x';
        write_text("sequences/06/times.txt", text);
        assert_int_equal(tvo_kitti_open(&seq, p, NULL, 0, err, sizeof err), TVO_ERR_FORMAT);
        assert_non_null(strstr(err, "times.txt: line 3: bad time"));
        assert_int_equal(tvo_kitti_open(&seq, p, NULL, TVO_EUROC_SKIP_BAD_ROWS, err, sizeof err), TVO_OK);
        assert_int_equal(tvo_euroc_frame_count(seq), 50);
        assert_int_equal(tvo_euroc_bad_row_count(seq), 1);
        assert_non_null(strstr(tvo_euroc_bad_row(seq, 0), "times.txt:3: bad time"));
        assert_string_equal(tvo_euroc_frame_file(seq, 2), "000003.png"); /* frame 2 skipped */
        assert_null(tvo_euroc_bad_row(seq, 1));
        tvo_euroc_close(seq);
    }
    tvo_euroc_close(src);
}

static void test_kitti_parsers(void **state)
{
    double P[12];
    tvo_pose T[2];
    int32_t n = 0;
    char err[200];
    static const char calib[] =
            "P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 0.000000000000e+00 "
            "0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 "
            "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n";
    (void)state;
    assert_int_equal(tvo_kitti_parse_calib(calib, strlen(calib), P, err, sizeof err), TVO_OK);
    assert_true(P[0] == 718.856 && P[2] == 607.1928 && P[6] == 185.2157);
    assert_int_equal(tvo_kitti_parse_calib("P1: 1 2\n", 8, P, err, sizeof err), TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "no 'P0:' line"));
    assert_int_equal(tvo_kitti_parse_calib("P0: 1 0 2 0 0 1 3 0 0 0 1\n", 26, P, err, sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "expected 12 numbers, got 11"));
    assert_int_equal(tvo_kitti_parse_calib("P0: 1 0 2 5 0 1 3 0 0 0 1 0\n", 28, P, err, sizeof err),
                     TVO_ERR_FORMAT);
    {
        static const char two[] = "1 0 0 0 0 1 0 0 0 0 1 0\n\n0 -1 0 1 1 0 0 2 0 0 1 3\n";
        assert_int_equal(tvo_kitti_parse_poses(two, strlen(two), T, 2, &n, err, sizeof err), TVO_OK);
    }
    assert_int_equal(n, 2);
    assert_true(T[1].t[2] == 3.0 && T[1].R[1] == -1.0);
    assert_int_equal(tvo_kitti_parse_poses("1 0 0 0 0 2 0 0 0 0 1 0\n", 24, T, 2, &n, err, sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "line 1: the rotation block is not a rotation"));
    assert_int_equal(tvo_kitti_parse_poses("1 0 0 0 0 1 0 nan 0 0 1 0\n", 26, T, 2, &n, err, sizeof err),
                     TVO_ERR_FORMAT);
    assert_int_equal(tvo_kitti_parse_poses("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n", 48, T, 1, &n,
                                           err, sizeof err),
                     TVO_ERR_NO_MEMORY);
    assert_int_equal(n, 2);
}

/* TUM's groundtruth.txt (header lines as in the dataset) */
static const char TUM_GT[] = "# ground truth trajectory\n"
                             "# file: 'rgbd_dataset_freiburg1_xyz.bag'\n"
                             "# timestamp tx ty tz qx qy qz qw\n"
                             "1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986\n"
                             "1305031098.6758 1.3543 0.6306 1.6360 0.6129 0.5966 -0.3316 -0.3980\n";

static void test_tum_parsers(void **state)
{
    tvo_euroc_gt_row rows[2];
    int32_t n = 0;
    char err[200];
    tvo_camera cam;
    (void)state;
    assert_int_equal(tvo_tum_parse_groundtruth(TUM_GT, strlen(TUM_GT), rows, 2, &n, err, sizeof err), TVO_OK);
    assert_int_equal(n, 2);
    assert_true(rows[0].t_ns == 1305031098665900000LL && rows[1].t_ns == 1305031098675800000LL);
    assert_true(rows[0].p[2] == 1.6380);
    /* x y z w in the file, w x y z in the row (normalised: the file's norm is 0.99995) */
    assert_true(fabs(rows[0].q_wxyz[0] - -0.3986 / 0.99995) < 1e-3 &&
                fabs(rows[0].q_wxyz[1] - 0.6132) < 1e-3);
    {
        const double qn = sqrt(rows[0].q_wxyz[0] * rows[0].q_wxyz[0] + rows[0].q_wxyz[1] * rows[0].q_wxyz[1] +
                               rows[0].q_wxyz[2] * rows[0].q_wxyz[2] + rows[0].q_wxyz[3] * rows[0].q_wxyz[3]);
        assert_true(fabs(qn - 1.0) < 1e-12);
    }
    /* EuRoC's order read as TUM is caught by the quaternion norm only when it is not a unit vector;
     * a reordered unit quaternion is still unit: the parsers cannot tell, the file kind must be right */
    assert_int_equal(tvo_tum_parse_groundtruth("1.5 0 0 0 0 0 0\n", 16, rows, 2, &n, err, sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "7 fields, need at least 8"));
    assert_int_equal(tvo_tum_parse_groundtruth("1.5 0 0 0 0 0 0 2\n", 18, rows, 2, &n, err, sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "quaternion norm"));
    assert_int_equal(tvo_tum_parse_groundtruth("2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", 32, rows, 2, &n, err,
                                               sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "not increasing"));
    assert_int_equal(tvo_tum_parse_groundtruth("1305031098.6659e3 0 0 0 0 0 0 1\n", 32, rows, 2, &n, err,
                                               sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "seconds expected"));
    /* the published cameras by folder name */
    assert_int_equal(tvo_tum_camera("/data/rgbd_dataset_freiburg1_xyz", &cam), TVO_OK);
    assert_true(cam.fx == 517.3 && cam.model == TVO_DIST_RADTAN && cam.k[4] == 1.1633 && cam.width == 640);
    assert_int_equal(tvo_tum_camera("rgbd_dataset_freiburg3_long_office_household/", &cam), TVO_OK);
    assert_true(cam.fx == 535.4 && cam.model == TVO_DIST_NONE);
    assert_int_equal(tvo_tum_camera("/data/freiburg1/my_sequence", &cam), TVO_ERR_NOT_FOUND);
}

static void test_tum_layout(void **state)
{
    tvo_euroc *src = open_kitti06(), *seq = NULL;
    char p[700], err[700], buf[800], img[1200];
    FILE *rgb, *gt;
    int32_t i;
    tvo_camera cam;
    (void)state;
    if (src == NULL)
        TVO_SKIP("TVO_DATA_DIR/kitti/kitti06_51 not found");
    cam = *tvo_euroc_camera(src);
    mkdir_rel("tum");
    mkdir_rel("tum/rgb");
    path_of(p, sizeof p, "tum/rgb.txt");
    rgb = fopen(p, "wb");
    path_of(p, sizeof p, "tum/groundtruth.txt");
    gt = fopen(p, "wb");
    assert_non_null(rgb);
    assert_non_null(gt);
    fputs("# color images\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n# timestamp filename\n", rgb);
    fputs("# ground truth trajectory\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n# timestamp tx ty tz qx qy "
          "qz qw\n",
          gt);
    for (i = 0; i < 10; ++i) {
        const int64_t t = tvo_euroc_frame_time(src, i) - 1000000000000000000LL + 1305031102000000000LL;
        tvo_euroc_gt_row r;
        char stamp[64];
        snprintf(stamp, sizeof stamp, "%lld.%06lld", (long long)(t / 1000000000),
                 (long long)(t % 1000000000 / 1000));
        assert_int_equal(tvo_euroc_frame_path(src, i, img, sizeof img), TVO_OK);
        snprintf(buf, sizeof buf, "tum/rgb/%s.png", stamp);
        path_of(p, sizeof p, buf);
        assert_int_equal(symlink(img, p), 0);
        fprintf(rgb, "%s rgb/%s.png\n", stamp, stamp);
        if (i == 4)
            fputs("1305031102.9 rgb/../../etc/passwd\n", rgb); /* a malformed row */
        assert_int_equal(tvo_euroc_groundtruth_row(src, i, &r), TVO_OK);
        fprintf(gt, "%s %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", stamp, r.p[0], r.p[1], r.p[2], r.q_wxyz[1],
                r.q_wxyz[2], r.q_wxyz[3], r.q_wxyz[0]);
    }
    fclose(rgb);
    fclose(gt);
    path_of(p, sizeof p, "tum");
    /* no freiburg name and no camera given */
    assert_int_equal(tvo_tum_open(&seq, p, NULL, 0, err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "carries no calibration"));
    /* the malformed row: strict fails naming it, lenient skips it */
    assert_int_equal(tvo_tum_open(&seq, p, &cam, 0, err, sizeof err), TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "rgb.txt: line 9: bad file name"));
    assert_int_equal(tvo_tum_open(&seq, p, &cam, TVO_EUROC_SKIP_BAD_ROWS, err, sizeof err), TVO_OK);
    assert_int_equal(tvo_euroc_frame_count(seq), 10);
    assert_int_equal(tvo_euroc_bad_row_count(seq), 1);
    assert_non_null(strstr(tvo_euroc_bad_row(seq, 0), "rgb.txt:9:"));
    assert_true(tvo_euroc_has_groundtruth(seq));
    assert_int_equal(tvo_euroc_groundtruth_count(seq), 10);
    assert_true(tvo_euroc_frame_time(seq, 0) ==
                tvo_euroc_frame_time(src, 0) - 1000000000000000000LL + 1305031102000000000LL -
                        (tvo_euroc_frame_time(src, 0) % 1000));
    for (i = 0; i < 10; ++i) {
        tvo_pose A, B;
        assert_int_equal(tvo_euroc_groundtruth(seq, tvo_euroc_frame_time(seq, i), 0, &A), TVO_OK);
        assert_int_equal(tvo_euroc_groundtruth_row(src, i, NULL), TVO_ERR_NULL);
        assert_int_equal(tvo_euroc_groundtruth(src, tvo_euroc_frame_time(src, i), 1000, &B), TVO_OK);
        assert_true(fabs(A.t[0] - B.t[0]) < 1e-6 && fabs(A.R[1] - B.R[1]) < 1e-8);
    }
    {
        const size_t n = 1226 * 370;
        uint8_t *a = (uint8_t *)malloc(n), *b = (uint8_t *)malloc(n);
        assert_non_null(a);
        assert_non_null(b);
        assert_int_equal(tvo_euroc_read_frame(seq, 9, a, n), TVO_OK);
        assert_int_equal(tvo_euroc_read_frame(src, 9, b, n), TVO_OK);
        assert_memory_equal(a, b, n);
        free(a);
        free(b);
    }
    assert_true(fabs(tvo_euroc_rate_hz(seq) - 10.0) < 1.0);
    tvo_euroc_close(seq);
    /* a calibration for another size is refused before any frame is read */
    cam.width = 640;
    cam.height = 480;
    assert_int_equal(tvo_tum_open(&seq, p, &cam, TVO_EUROC_SKIP_BAD_ROWS, err, sizeof err), TVO_ERR_MISMATCH);
    assert_non_null(strstr(err, "the calibration is for 640x480 but the frames are 1226x370"));
    remove_rel("tum/rgb.txt");
    assert_int_equal(tvo_tum_open(&seq, p, &cam, 0, err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "rgb.txt not found"));
    tvo_euroc_close(src);
}

static void test_euroc_bad_rows(void **state)
{
    tvo_euroc *seq = NULL;
    char p[700], err[700];
    uint8_t px[4] = {1, 2, 3, 4};
    (void)state;
    mkdir_rel("eu");
    mkdir_rel("eu/cam0");
    mkdir_rel("eu/cam0/data");
    write_text("eu/cam0/sensor.yaml",
               "intrinsics: [2, 2, 1, 0.5]\nresolution: [2, 2]\n"
               "T_BS:\n  data: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n");
    path_of(p, sizeof p, "eu/cam0/data/a.png");
    assert_int_equal(tvo_png_write_gray8(p, px, 2, 2, 2), TVO_OK);
    write_text("eu/cam0/data.csv",
               "#timestamp [ns],filename\n100,a.png\n15x,a.png\n300,a.png\n400\n500,a.png\n");
    path_of(p, sizeof p, "eu");
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", err, sizeof err), TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "cam0/data.csv: line 3: bad timestamp '15x'"));
    assert_null(seq);
    assert_int_equal(tvo_euroc_open_ex(&seq, p, "cam0", TVO_EUROC_SKIP_BAD_ROWS, err, sizeof err), TVO_OK);
    assert_int_equal(tvo_euroc_frame_count(seq), 3);
    assert_true(tvo_euroc_frame_time(seq, 1) == 300);
    assert_int_equal(tvo_euroc_bad_row_count(seq), 2);
    assert_non_null(strstr(tvo_euroc_bad_row(seq, 0), "cam0/data.csv:3: bad timestamp"));
    assert_non_null(strstr(tvo_euroc_bad_row(seq, 1), "cam0/data.csv:5: expected 'timestamp,filename'"));
    assert_null(tvo_euroc_bad_row(seq, 2));
    tvo_euroc_close(seq);
    /* every row bad: still an error */
    write_text("eu/cam0/data.csv", "x,a.png\n");
    assert_int_equal(tvo_euroc_open_ex(&seq, p, "cam0", TVO_EUROC_SKIP_BAD_ROWS, err, sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "no frames"));
    assert_int_equal(tvo_euroc_bad_row_count(NULL), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_kitti_parsers),
            cmocka_unit_test(test_tum_parsers),
            cmocka_unit_test_setup_teardown(test_kitti_layout, setup, teardown),
            cmocka_unit_test_setup_teardown(test_tum_layout, setup, teardown),
            cmocka_unit_test_setup_teardown(test_euroc_bad_rows, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
