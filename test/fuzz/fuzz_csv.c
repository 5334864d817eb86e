/* SPDX-License-Identifier: Apache-2.0 */
/* Fuzz harness: the EuRoC csv readers (tinyvo/port/euroc.h): tvo_euroc_parse_frames_csv (cam data.csv)
 * and tvo_euroc_parse_groundtruth (state_groundtruth_estimate0/data.csv and the space-separated
 * trajectory text), both on the same input.
 *
 * Each parser runs three times: counting (rows NULL), with a capacity one short (must say
 * TVO_ERR_NO_MEMORY and the same count), and filling an exact-size heap array (ASan catches a write
 * past it) with a 6-byte error buffer (messages must be truncated and NUL-terminated). Parsed rows are
 * checked against the header's promises. Ground truth that parses is also written to a temporary file,
 * loaded into an open sequence with tvo_euroc_load_groundtruth_file, and queried with
 * tvo_euroc_groundtruth / tvo_euroc_groundtruth_interp at row times, between rows and at the int64
 * extremes: every returned pose must be finite with an orthonormal rotation. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "fuzz_common.h"
#include "tinyvo/port/euroc.h"

static tvo_euroc *g_seq;
static char g_gt_path[256];

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

/* A minimal valid sequence folder in a fresh temporary directory, opened once. */
static void setup(void)
{
    static const char yaml[] = "intrinsics: [458.654, 457.296, 367.215, 248.375]\n"
                               "resolution: [752, 480]\n"
                               "T_BS:\n  rows: 4\n  cols: 4\n"
                               "  data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n";
    static const char csv[] = "#timestamp [ns],filename\n1403715273262142976,1403715273262142976.png\n";
    char dir[] = "/tmp/tvo_fuzz_csv_XXXXXX";
    char p[400], err[256];
    TVO_FUZZ_CHECK(mkdtemp(dir) != NULL);
    snprintf(p, sizeof p, "%s/mav0", dir);
    TVO_FUZZ_CHECK(mkdir(p, 0700) == 0);
    snprintf(p, sizeof p, "%s/mav0/cam0", dir);
    TVO_FUZZ_CHECK(mkdir(p, 0700) == 0);
    snprintf(p, sizeof p, "%s/mav0/cam0/sensor.yaml", dir);
    write_file(p, yaml, sizeof yaml - 1);
    snprintf(p, sizeof p, "%s/mav0/cam0/data.csv", dir);
    write_file(p, csv, sizeof csv - 1);
    if (tvo_euroc_open(&g_seq, dir, "cam0", err, sizeof err) != TVO_OK) {
        fprintf(stderr, "fuzz_csv: cannot open the scratch sequence: %s\n", err);
        abort();
    }
    /* the sequence read everything at open: the folder can go (libFuzzer may exit without atexit) */
    snprintf(p, sizeof p, "%s/mav0/cam0/sensor.yaml", dir);
    remove(p);
    snprintf(p, sizeof p, "%s/mav0/cam0/data.csv", dir);
    remove(p);
    snprintf(p, sizeof p, "%s/mav0/cam0", dir);
    rmdir(p);
    snprintf(p, sizeof p, "%s/mav0", dir);
    rmdir(p);
    rmdir(dir);
    snprintf(g_gt_path, sizeof g_gt_path, "/tmp/tvo_fuzz_csv_gt_%ld.txt", (long)getpid());
}

static void check_pose(const tvo_pose *T)
{
    TVO_FUZZ_CHECK(tvo_pose_is_finite(T));
    TVO_FUZZ_CHECK(tvo_rot_orthogonality_error(T->R) < 1e-6);
}

static void query(int64_t t)
{
    static const int64_t tols[3] = {0, 1000000, INT64_MAX};
    for (int k = 0; k < 3; ++k) {
        tvo_pose T;
        tvo_status st = tvo_euroc_groundtruth(g_seq, t, tols[k], &T);
        TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_RANGE);
        if (st == TVO_OK)
            check_pose(&T);
        st = tvo_euroc_groundtruth_interp(g_seq, t, tols[k], &T);
        TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_RANGE);
        if (st == TVO_OK)
            check_pose(&T);
    }
}

static void fuzz_frames(const char *text, size_t len)
{
    char err[256], small[6];
    int32_t n = -1, m = -1;
    tvo_euroc_frame *fr;
    tvo_status st = tvo_euroc_parse_frames_csv(text, len, NULL, 0, &n, err, sizeof err);
    TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_FORMAT);
    TVO_FUZZ_CHECK(err_ok(err, sizeof err));
    if (st != TVO_OK) {
        TVO_FUZZ_CHECK(err[0] != '\0');
        return;
    }
    TVO_FUZZ_CHECK(n >= 0);
    if (n == 0)
        return;
    fr = (tvo_euroc_frame *)malloc((size_t)n * sizeof *fr);
    if (fr == NULL)
        return;
    st = tvo_euroc_parse_frames_csv(text, len, fr, n - 1, &m, small, sizeof small);
    TVO_FUZZ_CHECK(st == TVO_ERR_NO_MEMORY && m == n && err_ok(small, sizeof small));
    st = tvo_euroc_parse_frames_csv(text, len, fr, n, &m, small, sizeof small);
    TVO_FUZZ_CHECK(st == TVO_OK && m == n);
    for (int32_t i = 0; i < n; ++i) {
        const char *f = fr[i].file;
        size_t fl = strnlen(f, TVO_EUROC_MAX_NAME);
        TVO_FUZZ_CHECK(fr[i].t_ns >= 0);
        TVO_FUZZ_CHECK(fl > 0 && fl < TVO_EUROC_MAX_NAME);
        TVO_FUZZ_CHECK(strchr(f, '/') == NULL && strchr(f, '\\') == NULL && strchr(f, ',') == NULL);
        TVO_FUZZ_CHECK(strcmp(f, ".") != 0 && strcmp(f, "..") != 0);
    }
    free(fr);
}

static void fuzz_groundtruth(const char *text, size_t len)
{
    char err[256], small[6];
    int32_t n = -1, m = -1;
    tvo_euroc_gt_row *rows;
    tvo_status st = tvo_euroc_parse_groundtruth(text, len, NULL, 0, &n, err, sizeof err);
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
    st = tvo_euroc_parse_groundtruth(text, len, rows, n - 1, &m, small, sizeof small);
    TVO_FUZZ_CHECK(st == TVO_ERR_NO_MEMORY && m == n && err_ok(small, sizeof small));
    st = tvo_euroc_parse_groundtruth(text, len, rows, n, &m, small, sizeof small);
    TVO_FUZZ_CHECK(st == TVO_OK && m == n);
    for (int32_t i = 0; i < n; ++i) {
        const tvo_euroc_gt_row *r = &rows[i];
        double qn = 0.0;
        TVO_FUZZ_CHECK(r->t_ns >= 0 && (i == 0 || r->t_ns > rows[i - 1].t_ns));
        for (int k = 0; k < 3; ++k)
            TVO_FUZZ_CHECK(isfinite(r->p[k]));
        for (int k = 0; k < 4; ++k)
            qn += r->q_wxyz[k] * r->q_wxyz[k];
        TVO_FUZZ_CHECK(fabs(qn - 1.0) < 1e-9);
    }

    /* the same text through the file loader, then lookups */
    if (g_seq == NULL)
        setup();
    write_file(g_gt_path, text, len);
    st = tvo_euroc_load_groundtruth_file(g_seq, g_gt_path, err, sizeof err);
    remove(g_gt_path);
    TVO_FUZZ_CHECK(st == TVO_OK);
    TVO_FUZZ_CHECK(tvo_euroc_has_groundtruth(g_seq) && tvo_euroc_groundtruth_count(g_seq) == n);
    query(INT64_MIN);
    query(INT64_MAX);
    query(0);
    for (int32_t i = 0; i < n && i < 64; ++i) {
        tvo_euroc_gt_row r;
        TVO_FUZZ_CHECK(tvo_euroc_groundtruth_row(g_seq, i, &r) == TVO_OK);
        TVO_FUZZ_CHECK(r.t_ns == rows[i].t_ns);
        query(r.t_ns);
        query(r.t_ns - 1);
        if (i + 1 < n)
            query(r.t_ns + (rows[i + 1].t_ns - r.t_ns) / 2);
    }
    free(rows);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *text = (const char *)data;
    fuzz_frames(text, size);
    fuzz_groundtruth(text, size);
    return 0;
}
