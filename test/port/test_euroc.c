/* SPDX-License-Identifier: Apache-2.0 */
/* EuRoC / ASL reader: the real sample folders (skipped without TVO_DATA_DIR), the parsers on malformed
 * buffers (missing keys, bad numbers, truncation at every length, ...), and malformed folders written
 * to a temporary directory. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <sys/stat.h>
#include <unistd.h>

#include "tvo_test.h"
#include "tinyvo/port/euroc.h"
#include "tinyvo/port/png.h"

static const char YAML_OK[] =
        "%YAML:1.0\n"
        "# General sensor definitions.\n"
        "sensor_type: camera\n"
        "comment: VI-Sensor cam0 (MT9M034)\n"
        "\n"
        "# Sensor extrinsics wrt. the body-frame.\n"
        "T_BS:\n"
        "  cols: 4\n"
        "  rows: 4\n"
        "  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,\n"
        "         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,\n"
        "        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,\n"
        "         0.0, 0.0, 0.0, 1.0]\n"
        "\n"
        "# Camera specific definitions.\n"
        "rate_hz: 20\n"
        "resolution: [752, 480]\n"
        "camera_model: pinhole\n"
        "intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv\n"
        "distortion_model: radial-tangential\n"
        "distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n";

static const char GT_OK[] = "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
                            "q_RS_y [], q_RS_z [], v_x, v_y, v_z\n"
                            "1000,0.0,0.0,0.0,1.0,0.0,0.0,0.0,0.1,0.2,0.3\n"
                            "2000,1.0,2.0,3.0,0.0,0.0,0.0,1.0,0.1,0.2,0.3\n"
                            "3000,2.0,2.0,2.0,0.0,0.0,0.0,1.0,0.1,0.2,0.3\n";

/* Replace the first occurrence of `from` in YAML_OK by `to`. */
static char *yaml_with(const char *from, const char *to)
{
    static char buf[4096];
    const char *p = strstr(YAML_OK, from);
    size_t a;
    assert_non_null(p);
    a = (size_t)(p - YAML_OK);
    memcpy(buf, YAML_OK, a);
    strcpy(buf + a, to);
    strcat(buf, p + strlen(from));
    return buf;
}

static tvo_status parse_yaml(const char *text, tvo_camera *cam, char *err, size_t err_size)
{
    tvo_pose T;
    double rate;
    return tvo_euroc_parse_sensor_yaml(text, strlen(text), cam, &T, &rate, err, err_size);
}

static void expect_yaml_error(const char *text, tvo_status expect, const char *msg_part)
{
    tvo_camera cam;
    char err[256] = "";
    tvo_status st = parse_yaml(text, &cam, err, sizeof err);
    if (st != expect || strstr(err, msg_part) == NULL)
        fprintf(stderr, "got %d '%s', expected %d with '%s'\n", st, err, expect, msg_part);
    assert_int_equal(st, expect);
    assert_non_null(strstr(err, msg_part));
}

static void test_yaml_ok(void **state)
{
    tvo_camera cam;
    tvo_pose T;
    double rate = 0;
    char err[256];
    (void)state;
    assert_int_equal(tvo_euroc_parse_sensor_yaml(YAML_OK, strlen(YAML_OK), &cam, &T, &rate, err, sizeof err),
                     TVO_OK);
    assert_string_equal(err, "");
    assert_int_equal(cam.width, 752);
    assert_int_equal(cam.height, 480);
    assert_true(cam.fx == 458.654 && cam.fy == 457.296 && cam.cx == 367.215 && cam.cy == 248.375);
    assert_int_equal(cam.model, TVO_DIST_RADTAN);
    assert_true(cam.k[0] == -0.28340811 && cam.k[3] == 1.76187114e-05 && cam.k[4] == 0.0);
    assert_true(rate == 20.0);
    assert_true(fabs(T.R[1] - -0.999880929698) < 1e-9 && fabs(T.t[1] - -0.064676986768) < 1e-15);
    assert_true(tvo_rot_orthogonality_error(T.R) < 1e-14);
    /* NULL T_BS / rate are fine; NULL cam is not */
    assert_int_equal(tvo_euroc_parse_sensor_yaml(YAML_OK, strlen(YAML_OK), &cam, NULL, NULL, NULL, 0),
                     TVO_OK);
    assert_int_equal(tvo_euroc_parse_sensor_yaml(YAML_OK, strlen(YAML_OK), NULL, NULL, NULL, err, sizeof err),
                     TVO_ERR_NULL);
    /* 5 coefficients; CRLF line ends; quoted model; equidistant */
    assert_int_equal(parse_yaml(yaml_with("1.76187114e-05]", "1.76187114e-05, 0.0123]"), &cam, err,
                                sizeof err),
                     TVO_OK);
    assert_true(cam.k[4] == 0.0123);
    {
        char crlf[4096];
        size_t i, j = 0;
        for (i = 0; YAML_OK[i]; ++i) {
            if (YAML_OK[i] == '\n')
                crlf[j++] = '\r';
            crlf[j++] = YAML_OK[i];
        }
        crlf[j] = '\0';
        assert_int_equal(parse_yaml(crlf, &cam, err, sizeof err), TVO_OK);
        assert_true(cam.k[3] == 1.76187114e-05);
    }
    assert_int_equal(parse_yaml(yaml_with("radial-tangential", "\"radtan\""), &cam, err, sizeof err), TVO_OK);
    assert_int_equal(cam.model, TVO_DIST_RADTAN);
    assert_int_equal(parse_yaml(yaml_with("radial-tangential", "equidistant"), &cam, err, sizeof err),
                     TVO_OK);
    assert_int_equal(cam.model, TVO_DIST_EQUIDISTANT);
    assert_true(cam.k[0] == -0.28340811 && cam.k[4] == 0.0);
    /* no rate: 0 */
    assert_int_equal(tvo_euroc_parse_sensor_yaml(yaml_with("rate_hz: 20\n", ""),
                                                 strlen(yaml_with("rate_hz: 20\n", "")), &cam, &T, &rate, err,
                                                 sizeof err),
                     TVO_OK);
    assert_true(rate == 0.0);
    /* no distortion at all */
    {
        char *y =
                yaml_with("distortion_model: radial-tangential\n"
                          "distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n",
                          "");
        assert_int_equal(parse_yaml(y, &cam, err, sizeof err), TVO_OK);
        assert_int_equal(cam.model, TVO_DIST_NONE);
    }
}

static void test_yaml_malformed(void **state)
{
    (void)state;
    expect_yaml_error(yaml_with("intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv\n", ""),
                      TVO_ERR_FORMAT, "missing key 'intrinsics'");
    expect_yaml_error(yaml_with("[458.654, 457.296, 367.215, 248.375]", "[458.654, 457.296, 367.215]"),
                      TVO_ERR_FORMAT, "line 19: intrinsics: expected 4 numbers");
    expect_yaml_error(yaml_with("458.654", "4x8.654"), TVO_ERR_FORMAT,
                      "line 19: intrinsics: bad number '4x8.654'");
    expect_yaml_error(yaml_with("458.654", "nan"), TVO_ERR_FORMAT, "bad number");
    expect_yaml_error(yaml_with("458.654", "1e999"), TVO_ERR_FORMAT, "bad number");
    expect_yaml_error(yaml_with("458.654", "-458.654"), TVO_ERR_FORMAT, "invalid camera");
    expect_yaml_error(yaml_with("458.654", "0"), TVO_ERR_FORMAT, "invalid camera");
    expect_yaml_error(yaml_with("[752, 480]", "[752.5, 480]"), TVO_ERR_FORMAT, "line 17: resolution");
    expect_yaml_error(yaml_with("[752, 480]", "[752]"), TVO_ERR_FORMAT, "resolution");
    expect_yaml_error(yaml_with("[752, 480]", "[0, 480]"), TVO_ERR_FORMAT, "resolution");
    expect_yaml_error(yaml_with("resolution: [752, 480]\n", ""), TVO_ERR_FORMAT, "missing key 'resolution'");
    expect_yaml_error(yaml_with(", 1.76187114e-05]", "]"), TVO_ERR_FORMAT,
                      "4 or 5 distortion_coefficients, got 3");
    expect_yaml_error(yaml_with("1.76187114e-05]", "1.76187114e-05, 0.1, 0.2]"), TVO_ERR_FORMAT, "got 6");
    expect_yaml_error(
            yaml_with("radial-tangential\ndistortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, "
                      "1.76187114e-05]",
                      "equidistant\ndistortion_coefficients: [-0.28340811, 0.07395907, 0.00019359]"),
            TVO_ERR_FORMAT, "equidistant needs 4");
    expect_yaml_error(yaml_with("radial-tangential", "omnidirectional"), TVO_ERR_UNSUPPORTED,
                      "line 20: distortion_model");
    expect_yaml_error(yaml_with("camera_model: pinhole", "camera_model: omni"), TVO_ERR_UNSUPPORTED,
                      "camera_model 'omni'");
    expect_yaml_error(yaml_with("rate_hz: 20", "rate_hz: fast"), TVO_ERR_FORMAT, "line 16: rate_hz");
    expect_yaml_error(yaml_with("rate_hz: 20", "rate_hz: -20"), TVO_ERR_FORMAT, "rate_hz");
    /* T_BS */
    expect_yaml_error(yaml_with("T_BS:", "T_XX:"), TVO_ERR_FORMAT, "missing key 'T_BS'");
    expect_yaml_error(yaml_with("         0.0, 0.0, 0.0, 1.0]", "         0.0, 0.0, 0.0]"), TVO_ERR_FORMAT,
                      "line 10: T_BS data: expected 16 numbers, got 15");
    expect_yaml_error(yaml_with("         0.0, 0.0, 0.0, 1.0]", "         0.0, 0.0, 0.0, 2.0]"),
                      TVO_ERR_FORMAT, "last row");
    expect_yaml_error(yaml_with("0.0148655429818, -0.999880929698", "0.5148655429818, -0.999880929698"),
                      TVO_ERR_FORMAT, "not a rotation");
    expect_yaml_error(yaml_with("  rows: 4", "  rows: 3"), TVO_ERR_FORMAT, "line 9: T_BS rows must be 4");
    expect_yaml_error(yaml_with("         0.0, 0.0, 0.0, 1.0]", "         0.0, 0.0, 0.0, 1.0\n"),
                      TVO_ERR_FORMAT, "line 10: '[' of 'data' never closed");
    expect_yaml_error(yaml_with("         0.0, 0.0, 0.0, 1.0]", "         0.0, 0.0, 0.0, 1.0] extra"),
                      TVO_ERR_FORMAT, "line 13: text after ']'");
    /* syntax */
    expect_yaml_error(yaml_with("sensor_type: camera", "sensor_type camera"), TVO_ERR_FORMAT,
                      "line 3: expected 'key: value'");
    expect_yaml_error(yaml_with("  cols: 4", "\tcols: 4"), TVO_ERR_FORMAT, "line 8: tab");
    expect_yaml_error(yaml_with("rate_hz: 20", "rate_hz: 20\nrate_hz: 30"), TVO_ERR_FORMAT,
                      "duplicate key 'rate_hz'");
    expect_yaml_error(yaml_with("sensor_type: camera\n", "sensor_type: camera\n  x: 1\n"), TVO_ERR_FORMAT,
                      "line 4: indented key outside a mapping");
    expect_yaml_error("", TVO_ERR_FORMAT, "missing key");
    {
        tvo_camera cam;
        char err[64];
        char withnul[] = "intrinsics: [1, 2, 3, 4]\nresolution: [10,\0 10]\n";
        assert_int_equal(tvo_euroc_parse_sensor_yaml(withnul, sizeof withnul - 1, &cam, NULL, NULL, err,
                                                     sizeof err),
                         TVO_ERR_FORMAT);
        /* tiny err buffers are fine, NULL err too */
        assert_int_equal(parse_yaml("", &cam, err, 4), TVO_ERR_FORMAT);
        assert_int_equal(strlen(err), 3);
        assert_int_equal(parse_yaml("", &cam, NULL, 0), TVO_ERR_FORMAT);
    }
}

/* Every prefix of the file (a truncated download) and random byte flips: never a crash, and never
 * OK unless all required keys were complete. */
static void test_yaml_truncated_and_fuzzed(void **state)
{
    const size_t n = strlen(YAML_OK);
    char buf[4096];
    tvo_camera cam;
    char err[128];
    size_t cut;
    const size_t req = (size_t)(strstr(YAML_OK, "248.375]") - YAML_OK) + 8;
    uint64_t s = 2024;
    int k;
    (void)state;
    for (cut = 0; cut < n; ++cut) {
        tvo_status st = tvo_euroc_parse_sensor_yaml(YAML_OK, cut, &cam, NULL, NULL, err, sizeof err);
        /* the last required value (intrinsics) ends at `req`; a cut at a line boundary after it can
         * leave a valid file (e.g. without distortion), which no parser can tell from a real one */
        if (cut < req)
            assert_int_not_equal(st, TVO_OK);
        assert_true(st == TVO_OK || st == TVO_ERR_FORMAT || st == TVO_ERR_UNSUPPORTED);
        if (st != TVO_OK)
            assert_true(strlen(err) > 0);
    }
    for (k = 0; k < 3000; ++k) {
        int flips = 1 + (int)(tvo_test_rand(&s) % 4), f;
        memcpy(buf, YAML_OK, n);
        for (f = 0; f < flips; ++f)
            buf[tvo_test_rand(&s) % n] = (char)(tvo_test_rand(&s) & 0xFF);
        (void)tvo_euroc_parse_sensor_yaml(buf, n, &cam, NULL, NULL, err, sizeof err);
    }
}

static void test_frames_csv(void **state)
{
    static const char ok[] = "#timestamp [ns],filename\r\n"
                             "1403715273262142976,1403715273262142976.png\r\n"
                             "\n"
                             " 1403715273312143104 , 1403715273312143104.png\n"
                             "1403715273362142976,a b.png"; /* no final newline */
    tvo_euroc_frame fr[4];
    int32_t n = -1;
    char err[200];
    (void)state;
    assert_int_equal(tvo_euroc_parse_frames_csv(ok, strlen(ok), NULL, 0, &n, err, sizeof err), TVO_OK);
    assert_int_equal(n, 3);
    assert_int_equal(tvo_euroc_parse_frames_csv(ok, strlen(ok), fr, 4, &n, err, sizeof err), TVO_OK);
    assert_int_equal(n, 3);
    assert_true(fr[0].t_ns == 1403715273262142976LL);
    assert_string_equal(fr[1].file, "1403715273312143104.png");
    assert_string_equal(fr[2].file, "a b.png");
    assert_int_equal(tvo_euroc_parse_frames_csv(ok, strlen(ok), fr, 2, &n, err, sizeof err),
                     TVO_ERR_NO_MEMORY);
    assert_int_equal(n, 3);
    assert_int_equal(tvo_euroc_parse_frames_csv("", 0, fr, 4, &n, err, sizeof err), TVO_OK);
    assert_int_equal(n, 0);
    assert_int_equal(tvo_euroc_parse_frames_csv(ok, strlen(ok), fr, 4, NULL, err, sizeof err), TVO_ERR_NULL);
    assert_int_equal(tvo_euroc_parse_frames_csv(ok, strlen(ok), fr, -1, &n, err, sizeof err), TVO_ERR_ARG);
#define BAD_CSV(text, part)                                                                          \
    do {                                                                                             \
        err[0] = '\0';                                                                               \
        assert_int_equal(tvo_euroc_parse_frames_csv(text, strlen(text), fr, 4, &n, err, sizeof err), \
                         TVO_ERR_FORMAT);                                                            \
        if (strstr(err, part) == NULL)                                                               \
            fprintf(stderr, "message '%s' lacks '%s'\n", err, part);                                 \
        assert_non_null(strstr(err, part));                                                          \
    } while (0)
    BAD_CSV("#h\n1403715273262142976\n", "line 2: expected 'timestamp,filename'");
    BAD_CSV("1,a.png\n1403715273262142976,\n", "line 2: bad file name");
    BAD_CSV("12a,x.png\n", "line 1: bad timestamp '12a'");
    BAD_CSV("-5,x.png\n", "bad timestamp");
    BAD_CSV("1.5,x.png\n", "bad timestamp");
    BAD_CSV("99999999999999999999,x.png\n", "bad timestamp");
    BAD_CSV(",x.png\n", "bad timestamp");
    BAD_CSV("1,../x.png\n", "bad file name");
    { /* a NUL byte inside a row (strlen would stop at it: explicit length) */
        static const char nul[] = "1,a.png\n2,b\0.png\n";
        err[0] = '\0';
        assert_int_equal(tvo_euroc_parse_frames_csv(nul, sizeof nul - 1, fr, 4, &n, err, sizeof err),
                         TVO_ERR_FORMAT);
        assert_non_null(strstr(err, "line 2: NUL byte"));
        assert_int_equal(n, 0);
    }
    BAD_CSV("1,sub/x.png\n", "bad file name");
    BAD_CSV("1,..\n", "bad file name");
    BAD_CSV("1,x.png,extra\n", "bad file name");
    {
        char longname[400];
        memset(longname, 'a', sizeof longname);
        memcpy(longname, "1,", 2);
        longname[sizeof longname - 1] = '\0';
        BAD_CSV(longname, "longer than");
    }
#undef BAD_CSV
    {
        const size_t len = strlen(ok);
        size_t cut;
        for (cut = 0; cut <= len; ++cut) {
            tvo_status st = tvo_euroc_parse_frames_csv(ok, cut, fr, 4, &n, err, sizeof err);
            assert_true(st == TVO_OK || st == TVO_ERR_FORMAT);
        }
    }
}

static void test_groundtruth_parse(void **state)
{
    tvo_euroc_gt_row rows[4];
    int32_t n = -1;
    char err[200];
    (void)state;
    assert_int_equal(tvo_euroc_parse_groundtruth(GT_OK, strlen(GT_OK), rows, 4, &n, err, sizeof err), TVO_OK);
    assert_int_equal(n, 3);
    assert_true(rows[1].t_ns == 2000 && rows[1].p[2] == 3.0 && rows[1].q_wxyz[3] == 1.0);
    /* 8 columns only, space separated, fractional timestamps (rounded), unnormalised quaternion */
    {
        static const char txt[] = "#timestamp [ns] p_x p_y p_z q_w q_x q_y q_z\n"
                                  "1403715274312143104.0000000000 0.8687393558 2.2070275302 0.9257726725 "
                                  "0.4259596512 0.6262011737 -0.5441421096 0.361026079545\n"
                                  "1403715274362142976.6  1 2 3   0 0 0 1.001\n"
                                  "1403715274362142978,\t1, 2 ,3,0,0,1,0\n";
        assert_int_equal(tvo_euroc_parse_groundtruth(txt, strlen(txt), rows, 4, &n, err, sizeof err), TVO_OK);
        assert_int_equal(n, 3);
        assert_true(rows[0].t_ns == 1403715274312143104LL);
        assert_true(rows[0].p[0] == 0.8687393558);
        assert_true(rows[1].t_ns == 1403715274362142977LL);
        assert_true(rows[1].q_wxyz[3] == 1.0);
        assert_true(rows[2].q_wxyz[2] == 1.0);
    }
    assert_int_equal(tvo_euroc_parse_groundtruth(GT_OK, strlen(GT_OK), rows, 2, &n, err, sizeof err),
                     TVO_ERR_NO_MEMORY);
    assert_int_equal(n, 3);
    assert_int_equal(tvo_euroc_parse_groundtruth(GT_OK, strlen(GT_OK), NULL, 0, &n, err, sizeof err), TVO_OK);
    assert_int_equal(n, 3);
#define BAD_GT(text, part)                                                                              \
    do {                                                                                                \
        err[0] = '\0';                                                                                  \
        assert_int_equal(tvo_euroc_parse_groundtruth(text, strlen(text), rows, 4, &n, err, sizeof err), \
                         TVO_ERR_FORMAT);                                                               \
        if (strstr(err, part) == NULL)                                                                  \
            fprintf(stderr, "message '%s' lacks '%s'\n", err, part);                                    \
        assert_non_null(strstr(err, part));                                                             \
    } while (0)
    BAD_GT("#h\n1000,0,0,0,1,0,0\n", "line 2: 7 fields, need at least 8");
    BAD_GT("1000,0,0,0,1,0,0,0\n2000,0,0\n", "line 2: 3 fields"); /* truncated csv */
    BAD_GT("1000,0,0,x,1,0,0,0\n", "line 1: bad number in column 4 (p_z): 'x'");
    BAD_GT("1000,0,0,0,1,0,0,nan\n", "column 8 (q_z)");
    BAD_GT("1000,0,0,0,1,0,0,0x1\n", "column 8");
    BAD_GT("1000,0,0,0,0,0,0,0\n", "quaternion norm 0");
    BAD_GT("1000,0,0,0,2,0,0,0\n", "quaternion norm 2");
    BAD_GT("1000,0,0,0,1,0,0,0\n1000,0,0,0,1,0,0,0\n", "line 2: timestamp not increasing");
    BAD_GT("2000,0,0,0,1,0,0,0\n1000,0,0,0,1,0,0,0\n", "line 2: timestamp not increasing");
    BAD_GT("1000,0,,0,1,0,0,0\n", "line 1: empty field");
    BAD_GT("1000,0,0,0,1,0,0,0,\n", "empty field");
    {
        static const char nul[] = "#h\n1000,0,0,0,1,0,0,0\0\n";
        err[0] = '\0';
        assert_int_equal(tvo_euroc_parse_groundtruth(nul, sizeof nul - 1, rows, 4, &n, err, sizeof err),
                         TVO_ERR_FORMAT);
        assert_non_null(strstr(err, "line 2: NUL byte"));
        assert_int_equal(n, 0);
    }
    BAD_GT("t,0,0,0,1,0,0,0\n", "bad timestamp");
#undef BAD_GT
    {
        const size_t len = strlen(GT_OK);
        size_t cut;
        int ok_count = 0;
        for (cut = 0; cut <= len; ++cut) {
            tvo_status st = tvo_euroc_parse_groundtruth(GT_OK, cut, rows, 4, &n, err, sizeof err);
            assert_true(st == TVO_OK || st == TVO_ERR_FORMAT);
            ok_count += st == TVO_OK;
        }
        assert_true(ok_count > 0);
    }
}

/* ---- real data ----------------------------------------------------------------------------------- */

static int have_dir(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 && S_ISDIR(sb.st_mode);
}

static const char *euroc_dir(const char *name)
{
    static char p[600];
    const char *d = tvo_test_data_dir();
    if (d == NULL)
        return NULL;
    snprintf(p, sizeof p, "%s/euroc/%s", d, name);
    return have_dir(p) ? p : NULL;
}

static void test_real_head(void **state)
{
    const char *dir = euroc_dir("V1_01_easy_head");
    tvo_euroc *seq = NULL;
    char err[512] = "", path[1024];
    const tvo_camera *cam;
    tvo_pose T, Tw;
    tvo_euroc_gt_row row;
    uint8_t *img;
    (void)state;
    if (dir == NULL)
        TVO_SKIP("TVO_DATA_DIR/euroc/V1_01_easy_head not found");
    if (tvo_euroc_open(&seq, dir, "cam0", err, sizeof err) != TVO_OK)
        fprintf(stderr, "open: %s\n", err);
    assert_non_null(seq);
    assert_int_equal(tvo_euroc_frame_count(seq), 95);
    assert_true(tvo_euroc_frame_time(seq, 0) == 1403715273262142976LL);
    assert_true(tvo_euroc_frame_time(seq, 95) == -1 && tvo_euroc_frame_time(seq, -1) == -1);
    assert_string_equal(tvo_euroc_frame_file(seq, 1), "1403715273312143104.png");
    assert_null(tvo_euroc_frame_file(seq, 95));
    cam = tvo_euroc_camera(seq);
    assert_non_null(cam);
    assert_int_equal(cam->width, 752);
    assert_int_equal(cam->height, 480);
    assert_int_equal(cam->model, TVO_DIST_RADTAN);
    assert_true(cam->fx == 458.654 && cam->cy == 248.375 && cam->k[0] == -0.28340811 && cam->k[4] == 0.0);
    assert_true(tvo_euroc_rate_hz(seq) == 20.0);
    T = tvo_euroc_T_BS(seq);
    assert_true(fabs(T.t[0] - -0.0216401454975) < 1e-15);
    assert_int_equal(tvo_euroc_frame_path(seq, 0, path, sizeof path), TVO_OK);
    assert_int_equal(access(path, R_OK), 0);
    assert_int_equal(tvo_euroc_frame_path(seq, 0, path, 10), TVO_ERR_NO_MEMORY);
    assert_string_equal(path, "");
    assert_int_equal(tvo_euroc_frame_path(seq, 95, path, sizeof path), TVO_ERR_RANGE);
    img = (uint8_t *)malloc(752 * 480);
    assert_non_null(img);
    assert_int_equal(tvo_euroc_read_frame(seq, 94, img, 752 * 480), TVO_OK);
    assert_int_equal(tvo_euroc_read_frame(seq, 0, img, 752 * 480 - 1), TVO_ERR_NO_MEMORY);
    assert_int_equal(tvo_euroc_read_frame(seq, 95, img, 752 * 480), TVO_ERR_RANGE);
    free(img);
    /* ground truth */
    assert_true(tvo_euroc_has_groundtruth(seq));
    assert_int_equal(tvo_euroc_groundtruth_count(seq), 2895);
    assert_int_equal(tvo_euroc_groundtruth_row(seq, 0, &row), TVO_OK);
    assert_true(row.t_ns == 1403715273262142976LL && row.p[0] == 0.878895);
    assert_int_equal(tvo_euroc_groundtruth_row(seq, 2895, &row), TVO_ERR_RANGE);
    assert_int_equal(tvo_euroc_groundtruth(seq, tvo_euroc_frame_time(seq, 0) + 300, 1000000, &Tw), TVO_OK);
    assert_true(fabs(Tw.t[0] - 0.878895) < 1e-12);
    {
        /* the body's rotation: q = (0.069433, -0.824237, -0.106942, -0.551702) */
        double q[4];
        tvo_rot_to_quat(Tw.R, q);
        assert_true(fabs(fabs(q[1]) - 0.824237) < 1e-5);
    }
    assert_int_equal(tvo_euroc_groundtruth(seq, 1, 1000000, &Tw), TVO_ERR_RANGE);
    assert_int_equal(tvo_euroc_groundtruth(seq, tvo_euroc_frame_time(seq, 0), -1, &Tw), TVO_ERR_ARG);
    /* every frame has ground truth within 1 ms */
    {
        int32_t i;
        for (i = 0; i < 95; ++i)
            assert_int_equal(tvo_euroc_groundtruth(seq, tvo_euroc_frame_time(seq, i), 1000000, &Tw), TVO_OK);
    }
    tvo_euroc_close(seq);
    /* the mav0 folder itself works too; cam1: the stereo baseline is 11 cm */
    {
        char mav0[700];
        tvo_euroc *s1 = NULL;
        tvo_pose T0, T1, T10;
        snprintf(mav0, sizeof mav0, "%s/mav0", dir);
        assert_int_equal(tvo_euroc_open(&seq, mav0, "cam0", err, sizeof err), TVO_OK);
        assert_int_equal(tvo_euroc_open(&s1, dir, "cam1", err, sizeof err), TVO_OK);
        T0 = tvo_euroc_T_BS(seq);
        T1 = tvo_euroc_T_BS(s1);
        {
            tvo_pose T1i = tvo_pose_inverse(&T1);
            T10 = tvo_pose_compose(&T1i, &T0); /* T_cam1_cam0 */
        }
        assert_true(fabs(sqrt(T10.t[0] * T10.t[0] + T10.t[1] * T10.t[1] + T10.t[2] * T10.t[2]) - 0.110) <
                    0.002);
        assert_true(tvo_rot_angle(T10.R) < 0.05);
        tvo_euroc_close(seq);
        tvo_euroc_close(s1);
    }
    assert_int_equal(tvo_euroc_open(&seq, dir, "cam7", err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_null(seq);
    assert_non_null(strstr(err, "cam7"));
}

static void test_real_keyframes_and_groundtruth_file(void **state)
{
    const char *dir = euroc_dir("V1_01_easy_keyframes");
    tvo_euroc *seq = NULL;
    char err[512] = "", txt[700];
    int32_t i, n;
    (void)state;
    if (dir == NULL)
        TVO_SKIP("TVO_DATA_DIR/euroc/V1_01_easy_keyframes not found");
    assert_int_equal(tvo_euroc_open(&seq, dir, "cam0", err, sizeof err), TVO_OK);
    n = tvo_euroc_frame_count(seq);
    assert_int_equal(n, 100);
    /* consecutive keyframes: a camera-frame relative pose from body ground truth and T_BS */
    {
        tvo_pose Tbs = tvo_euroc_T_BS(seq);
        int found = 0;
        for (i = 0; i + 1 < n; ++i) {
            tvo_pose A, B, rel;
            if (tvo_euroc_groundtruth(seq, tvo_euroc_frame_time(seq, i), 1000000, &A) != TVO_OK ||
                tvo_euroc_groundtruth(seq, tvo_euroc_frame_time(seq, i + 1), 1000000, &B) != TVO_OK)
                continue;
            rel = tvo_pose_body_to_camera_relative(&A, &B, &Tbs);
            assert_true(tvo_pose_is_finite(&rel));
            assert_true(sqrt(rel.t[0] * rel.t[0] + rel.t[1] * rel.t[1] + rel.t[2] * rel.t[2]) < 10.0);
            ++found;
        }
        assert_true(found > 80);
    }
    /* the whole flight's ground truth beside the samples (EuRoC's csv; the space-separated form is
       tested on a file of its own below) */
    snprintf(txt, sizeof txt, "%s/../groundtruth/V1_01_easy.csv", dir);
    assert_int_equal(access(txt, R_OK), 0);
    {
        tvo_euroc_gt_row row;
        tvo_pose T, Ti;
        assert_int_equal(tvo_euroc_load_groundtruth_file(seq, txt, err, sizeof err), TVO_OK);
        assert_int_equal(tvo_euroc_groundtruth_count(seq), 2895);
        assert_int_equal(tvo_euroc_groundtruth_row(seq, 0, &row), TVO_OK);
        assert_true(row.t_ns == 1403715273262142976LL && row.p[1] == 2.1834);
        /* interpolation halfway between rows 0 and 1 */
        {
            tvo_euroc_gt_row r1;
            assert_int_equal(tvo_euroc_groundtruth_row(seq, 1, &r1), TVO_OK);
            assert_int_equal(tvo_euroc_groundtruth_interp(seq, (row.t_ns + r1.t_ns) / 2, 100000000, &Ti),
                             TVO_OK);
            assert_true(fabs(Ti.t[0] - 0.5 * (row.p[0] + r1.p[0])) < 1e-6);
            assert_int_equal(tvo_euroc_groundtruth_interp(seq, row.t_ns, 0, &T), TVO_OK);
            assert_true(T.t[0] == row.p[0]);
            assert_int_equal(tvo_euroc_groundtruth_interp(seq, (row.t_ns + r1.t_ns) / 2, 1000, &Ti),
                             TVO_ERR_RANGE);
            assert_int_equal(tvo_euroc_groundtruth_interp(seq, row.t_ns - 1, 100000000, &Ti), TVO_ERR_RANGE);
        }
        /* a failing load keeps the previous ground truth */
        assert_int_equal(tvo_euroc_load_groundtruth_file(seq, "/nonexistent_tvo/gt.txt", err, sizeof err),
                         TVO_ERR_NOT_FOUND);
        assert_int_equal(tvo_euroc_groundtruth_count(seq), 2895);
    }
    tvo_euroc_close(seq);
}

/* ---- malformed folders on disk --------------------------------------------------------------------- */

static char g_dir[256];

static int setup(void **state)
{
    (void)state;
    strcpy(g_dir, "/tmp/tvo_test_euroc_XXXXXX");
    return mkdtemp(g_dir) == NULL ? -1 : 0;
}

static int teardown(void **state)
{
    char cmd[300];
    (void)state;
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void write_text(const char *rel, const char *text)
{
    char p[600];
    FILE *f;
    snprintf(p, sizeof p, "%s/%s", g_dir, rel);
    f = fopen(p, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void mkdir_rel(const char *rel)
{
    char p[600];
    snprintf(p, sizeof p, "%s/%s", g_dir, rel);
    assert_int_equal(mkdir(p, 0755), 0);
}

static void test_fake_folder(void **state)
{
    tvo_euroc *seq = NULL;
    char err[600], p[700];
    uint8_t img[8 * 6], big[10 * 6];
    tvo_pose T;
    int i;
    (void)state;
    for (i = 0; i < 48; ++i)
        img[i] = (uint8_t)(i * 5);
    memset(big, 9, sizeof big);
    mkdir_rel("seq");
    mkdir_rel("seq/mav0");
    /* nothing there yet */
    snprintf(p, sizeof p, "%s/seq", g_dir);
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "data.csv"));
    mkdir_rel("seq/mav0/cam0");
    mkdir_rel("seq/mav0/cam0/data");
    write_text("seq/mav0/cam0/data.csv",
               "#timestamp [ns],filename\n100,a.png\n200,b.png\n300,c.png\n400,d.png\n");
    /* data.csv but no sensor.yaml */
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "sensor.yaml"));
    /* a sensor.yaml without intrinsics */
    write_text("seq/mav0/cam0/sensor.yaml",
               "T_BS:\n  data: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\nresolution: [8, 6]\n");
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", err, sizeof err), TVO_ERR_FORMAT);
    assert_null(seq);
    assert_non_null(strstr(err, "sensor.yaml: missing key 'intrinsics'"));
    /* a valid 5-coefficient sensor.yaml */
    write_text("seq/mav0/cam0/sensor.yaml",
               "T_BS:\n  data: [1,0,0,0.1, 0,1,0,0, 0,0,1,0, 0,0,0,1]\nresolution: [8, 6]\nrate_hz: 30\n"
               "intrinsics: [10, 10, 4, 3]\ndistortion_model: radial-tangential\n"
               "distortion_coefficients: [0.01, 0.002, 0.0, 0.0, 0.0005]\n");
    /* frames: a, right size; b, wrong size; c, corrupt; d missing */
    snprintf(p, sizeof p, "%s/seq/mav0/cam0/data/a.png", g_dir);
    assert_int_equal(tvo_png_write_gray8(p, img, 8, 6, 8), TVO_OK);
    snprintf(p, sizeof p, "%s/seq/mav0/cam0/data/b.png", g_dir);
    assert_int_equal(tvo_png_write_gray8(p, big, 10, 6, 10), TVO_OK);
    write_text("seq/mav0/cam0/data/c.png", "\x89PNG\r\n\x1a\nnot really");
    snprintf(p, sizeof p, "%s/seq", g_dir);
    assert_int_equal(tvo_euroc_open(&seq, p, NULL, err, sizeof err), TVO_OK);
    assert_int_equal(tvo_euroc_frame_count(seq), 4);
    assert_int_equal(tvo_euroc_camera(seq)->model, TVO_DIST_RADTAN);
    assert_true(tvo_euroc_camera(seq)->k[4] == 0.0005);
    assert_true(tvo_euroc_rate_hz(seq) == 30.0);
    T = tvo_euroc_T_BS(seq);
    assert_true(T.t[0] == 0.1);
    assert_false(tvo_euroc_has_groundtruth(seq));
    assert_int_equal(tvo_euroc_groundtruth(seq, 100, 10, &T), TVO_ERR_STATE);
    assert_int_equal(tvo_euroc_groundtruth_interp(seq, 100, 10, &T), TVO_ERR_STATE);
    {
        uint8_t out[48];
        assert_int_equal(tvo_euroc_read_frame(seq, 0, out, sizeof out), TVO_OK);
        assert_memory_equal(out, img, 48);
        assert_int_equal(tvo_euroc_read_frame(seq, 1, out, sizeof out), TVO_ERR_MISMATCH);
        assert_int_equal(tvo_euroc_read_frame(seq, 2, out, sizeof out), TVO_ERR_FORMAT);
        assert_int_equal(tvo_euroc_read_frame(seq, 3, out, sizeof out), TVO_ERR_NOT_FOUND);
        assert_int_equal(tvo_euroc_read_frame(NULL, 0, out, sizeof out), TVO_ERR_NULL);
        assert_int_equal(tvo_euroc_read_frame(seq, 0, NULL, sizeof out), TVO_ERR_NULL);
    }
    /* ground truth files: a good one, then a truncated one (the good one stays) */
    write_text("gt.txt", "# t px py pz qw qx qy qz\n100 0 0 0 1 0 0 0\n300 2 0 0 1 0 0 0\n");
    snprintf(p, sizeof p, "%s/gt.txt", g_dir);
    assert_int_equal(tvo_euroc_load_groundtruth_file(seq, p, err, sizeof err), TVO_OK);
    assert_int_equal(tvo_euroc_groundtruth(seq, 190, 100, &T), TVO_OK); /* nearest: 100 */
    assert_true(T.t[0] == 0.0);
    assert_int_equal(tvo_euroc_groundtruth(seq, 210, 100, &T), TVO_OK); /* nearest: 300 */
    assert_true(T.t[0] == 2.0);
    assert_int_equal(tvo_euroc_groundtruth(seq, 200, 50, &T), TVO_ERR_RANGE);
    assert_int_equal(tvo_euroc_groundtruth_interp(seq, 150, 1000, &T), TVO_OK);
    assert_true(fabs(T.t[0] - 0.5) < 1e-15);
    assert_int_equal(tvo_euroc_groundtruth(seq, INT64_MAX, 0, &T), TVO_ERR_RANGE);
    write_text("gt_bad.txt", "100 0 0 0 1 0 0 0\n300 2 0 0 1 0");
    snprintf(p, sizeof p, "%s/gt_bad.txt", g_dir);
    assert_int_equal(tvo_euroc_load_groundtruth_file(seq, p, err, sizeof err), TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "gt_bad.txt: line 2: 6 fields"));
    assert_int_equal(tvo_euroc_groundtruth_count(seq), 2);
    write_text("gt_empty.txt", "# nothing\n");
    snprintf(p, sizeof p, "%s/gt_empty.txt", g_dir);
    assert_int_equal(tvo_euroc_load_groundtruth_file(seq, p, err, sizeof err), TVO_ERR_FORMAT);
    tvo_euroc_close(seq);
    seq = NULL;
    /* a malformed ground-truth csv in the folder makes open fail with its line */
    mkdir_rel("seq/mav0/state_groundtruth_estimate0");
    write_text("seq/mav0/state_groundtruth_estimate0/data.csv",
               "#t,...\n100,0,0,0,1,0,0,0\n200,0,0,0,1,0,zero,0\n");
    snprintf(p, sizeof p, "%s/seq", g_dir);
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", err, sizeof err), TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "state_groundtruth_estimate0/data.csv: line 3: bad number in column 7"));
    write_text("seq/mav0/state_groundtruth_estimate0/data.csv",
               "#t,...\n100,0,0,0,1,0,0,0\n200,0,0,0,1,0,0,0\n");
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", err, sizeof err), TVO_OK);
    assert_true(tvo_euroc_has_groundtruth(seq));
    tvo_euroc_close(seq);
    /* a truncated data.csv */
    write_text("seq/mav0/cam0/data.csv", "#timestamp [ns],filename\n100,a.png\n200,b.png\n30");
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", err, sizeof err), TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "cam0/data.csv: line 4: expected 'timestamp,filename'"));
    write_text("seq/mav0/cam0/data.csv", "#timestamp [ns],filename\n");
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", err, sizeof err), TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "no frames"));
    /* bad arguments */
    assert_int_equal(tvo_euroc_open(NULL, p, "cam0", err, sizeof err), TVO_ERR_NULL);
    assert_int_equal(tvo_euroc_open(&seq, NULL, "cam0", err, sizeof err), TVO_ERR_NULL);
    assert_int_equal(tvo_euroc_open(&seq, p, "../cam0", err, sizeof err), TVO_ERR_ARG);
    assert_int_equal(tvo_euroc_open(&seq, p, "", err, sizeof err), TVO_ERR_ARG);
    assert_int_equal(tvo_euroc_open(&seq, p, "cam0", NULL, 0), TVO_ERR_FORMAT);
    /* queries on NULL */
    assert_int_equal(tvo_euroc_frame_count(NULL), 0);
    assert_null(tvo_euroc_camera(NULL));
    assert_false(tvo_euroc_has_groundtruth(NULL));
    assert_int_equal(tvo_euroc_frame_path(NULL, 0, p, sizeof p), TVO_ERR_NULL);
    assert_int_equal(tvo_euroc_groundtruth(NULL, 0, 0, &T), TVO_ERR_NULL);
    assert_int_equal(tvo_euroc_load_groundtruth_file(NULL, p, err, sizeof err), TVO_ERR_NULL);
    tvo_euroc_close(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_yaml_ok),
            cmocka_unit_test(test_yaml_malformed),
            cmocka_unit_test(test_yaml_truncated_and_fuzzed),
            cmocka_unit_test(test_frames_csv),
            cmocka_unit_test(test_groundtruth_parse),
            cmocka_unit_test(test_real_head),
            cmocka_unit_test(test_real_keyframes_and_groundtruth_file),
            cmocka_unit_test(test_fake_folder),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
