/* SPDX-License-Identifier: Apache-2.0 */
/* tvo_track_pair: detect corners in image A and track them into image B with pyramidal Lucas-Kanade.
 *
 *   tvo_track_pair A.png B.png [--max N] [--out tracks.csv] [--fb] [--win W] [--levels L] [--quiet]
 *
 * Reads two PNGs of the same size (any colour type; converted to 8-bit grey by the port layer),
 * detects up to N corners in A (FAST-9 + Shi-Tomasi ranking + grid bucketing, tvo_detect defaults),
 * tracks them into B (tvo_lk_track) and prints one line per corner:
 *     id x_a y_a x_b y_b status err
 * (pixels, status 1 = tracked, 0 = lost; err = mean abs grey difference over the window). With --out
 * the same goes to a csv file instead (header x_a,y_a,x_b,y_b,status,err). A summary (counts, median
 * flow, time per stage) goes to stderr. All memory is allocated once, up front, from the sizes the
 * library reports. Exit status 0 on success, 1 on an input or library error (one line on stderr), 2 on a
 * bad command line (one line naming the option). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>

#include "tinyvo/corners.h"
#include "tinyvo/image.h"
#include "tinyvo/lk.h"
#include "tinyvo/pyramid.h"
#include "tinyvo/status.h"
#include "tinyvo/version.h"
#include "tinyvo/port/clock.h"
#include "tinyvo/port/png.h"

static void usage(FILE *f)
{
    fprintf(f,
            "usage: tvo_track_pair A.png B.png [--max N] [--out tracks.csv] [--fb] [--win W] [--levels L] "
            "[--quiet]\n"
            "  --max N      corners to detect in A (1..100000, default 300)\n"
            "  --out FILE   write the tracks as csv to FILE instead of stdout\n"
            "  --fb         forward-backward check (points that do not track back within 1 px are lost)\n"
            "  --win W      LK window side, odd (default 21)\n"
            "  --levels L   pyramid levels including full resolution (default 4; reduced for small images)\n"
            "  --quiet      no summary on stderr\n"
            "  --version    print the version and exit\n"
            "  --help       this text\n"
            "Exit codes: 0 done, 1 runtime error, 2 usage error.\n");
}

static int parse_int(const char *s, long lo, long hi, int32_t *out)
{
    char *end = NULL;
    long v;
    if (s == NULL || *s == '\0')
        return 0;
    v = strtol(s, &end, 10);
    if (*end != '\0' || v < lo || v > hi)
        return 0;
    *out = (int32_t)v;
    return 1;
}

/* A hint for the usual ways an input file is wrong. */
static const char *hint(tvo_status st)
{
    switch (st) {
    case TVO_ERR_FORMAT:
        return " (not a PNG, or a corrupt / truncated one)";
    case TVO_ERR_SIZE:
        return " (image larger than TVO_MAX_IMAGE_DIM)";
    case TVO_ERR_NOT_FOUND:
        return " (no such file)";
    default:
        return "";
    }
}

static int cmp_float(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    const char *path_a = NULL, *path_b = NULL, *out_path = NULL;
    int32_t max_corners = 300, win = 21, levels = 4, fb = 0, quiet = 0;
    int32_t wa = 0, ha = 0, wb = 0, hb = 0, n = 0, i, tracked = 0;
    uint8_t *img_a = NULL, *img_b = NULL, *status = NULL;
    void *det_scratch = NULL, *lk_scratch = NULL, *pyr_mem_a = NULL, *pyr_mem_b = NULL;
    tvo_corner *corners = NULL;
    tvo_point2f *pts_a = NULL, *pts_b = NULL;
    float *err = NULL, *flow = NULL;
    size_t det_size, lk_size, pyr_size = 0;
    tvo_detect_config dcfg;
    tvo_lk_config lcfg;
    tvo_pyramid pyr_a, pyr_b;
    tvo_status st;
    FILE *out = stdout;
    int rc = 1;
    int64_t t0, t_detect, t_pyr, t_lk;

    for (i = 1; i < argc; ++i) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            return 0;
        } else if (strcmp(a, "--version") == 0) {
            printf("tvo_track_pair %s\n", tvo_version());
            return 0;
        } else if (strcmp(a, "--max") == 0) {
            if (!parse_int(i + 1 < argc ? argv[++i] : NULL, 1, 100000, &max_corners)) {
                fprintf(stderr, "tvo_track_pair: --max needs an integer in 1..100000\n");
                return 2;
            }
        } else if (strcmp(a, "--win") == 0) {
            if (!parse_int(i + 1 < argc ? argv[++i] : NULL, TVO_LK_MIN_WIN_SIZE, TVO_LK_MAX_WIN_SIZE, &win) ||
                win % 2 == 0) {
                fprintf(stderr, "tvo_track_pair: --win needs an odd integer in %d..%d\n", TVO_LK_MIN_WIN_SIZE,
                        TVO_LK_MAX_WIN_SIZE);
                return 2;
            }
        } else if (strcmp(a, "--levels") == 0) {
            if (!parse_int(i + 1 < argc ? argv[++i] : NULL, 1, TVO_MAX_PYR_LEVELS, &levels)) {
                fprintf(stderr, "tvo_track_pair: --levels needs an integer in 1..%d\n", TVO_MAX_PYR_LEVELS);
                return 2;
            }
        } else if (strcmp(a, "--out") == 0) {
            if (i + 1 >= argc) {
                fprintf(stderr, "tvo_track_pair: --out needs a file name\n");
                return 2;
            }
            out_path = argv[++i];
        } else if (strcmp(a, "--fb") == 0) {
            fb = 1;
        } else if (strcmp(a, "--quiet") == 0) {
            quiet = 1;
        } else if (a[0] == '-' && a[1] != '\0') {
            fprintf(stderr, "tvo_track_pair: unknown option '%s' (see --help)\n", a);
            return 2;
        } else if (path_a == NULL) {
            path_a = a;
        } else if (path_b == NULL) {
            path_b = a;
        } else {
            fprintf(stderr, "tvo_track_pair: too many arguments ('%s'; see --help)\n", a);
            return 2;
        }
    }
    if (path_a == NULL || path_b == NULL) {
        fprintf(stderr, "tvo_track_pair: two images A.png B.png are required (see --help)\n");
        return 2;
    }

    /* ---- sizes, then every allocation, once --------------------------------------------------- */
    st = tvo_png_size(path_a, &wa, &ha);
    if (st != TVO_OK) {
        fprintf(stderr, "tvo_track_pair: cannot read %s: %s%s\n", path_a, tvo_status_str(st), hint(st));
        return 1;
    }
    st = tvo_png_size(path_b, &wb, &hb);
    if (st != TVO_OK) {
        fprintf(stderr, "tvo_track_pair: cannot read %s: %s%s\n", path_b, tvo_status_str(st), hint(st));
        return 1;
    }
    if (wa != wb || ha != hb) {
        fprintf(stderr, "tvo_track_pair: the images differ in size: %s is %dx%d, %s is %dx%d\n", path_a,
                (int)wa, (int)ha, path_b, (int)wb, (int)hb);
        return 1;
    }
    tvo_detect_config_default(&dcfg);
    dcfg.max_corners = max_corners;
    tvo_lk_config_default(&lcfg);
    lcfg.win_size = win;
    lcfg.fb_check = fb;
    /* the deepest pyramid the image allows, up to the requested depth */
    while (levels > 1 && tvo_pyramid_required_size(wa, ha, levels) == 0)
        --levels;
    pyr_size = tvo_pyramid_required_size(wa, ha, levels);
    lcfg.max_level = levels - 1;
    det_size = tvo_detect_scratch_size(&dcfg, wa, ha);
    lk_size = tvo_lk_scratch_size(&lcfg);
    if (pyr_size == 0 || det_size == 0 || lk_size == 0) {
        fprintf(stderr, "tvo_track_pair: unsupported image size %dx%d or configuration\n", (int)wa, (int)ha);
        return 1;
    }
    img_a = (uint8_t *)malloc((size_t)wa * (size_t)ha);
    img_b = (uint8_t *)malloc((size_t)wa * (size_t)ha);
    det_scratch = malloc(det_size);
    lk_scratch = malloc(lk_size);
    pyr_mem_a = malloc(pyr_size);
    pyr_mem_b = malloc(pyr_size);
    corners = (tvo_corner *)malloc((size_t)max_corners * sizeof *corners);
    pts_a = (tvo_point2f *)malloc((size_t)max_corners * sizeof *pts_a);
    pts_b = (tvo_point2f *)malloc((size_t)max_corners * sizeof *pts_b);
    status = (uint8_t *)malloc((size_t)max_corners);
    err = (float *)malloc((size_t)max_corners * sizeof *err);
    flow = (float *)malloc((size_t)max_corners * sizeof *flow);
    if (!img_a || !img_b || !det_scratch || !lk_scratch || !pyr_mem_a || !pyr_mem_b || !corners || !pts_a ||
        !pts_b || !status || !err || !flow) {
        fprintf(stderr, "tvo_track_pair: out of memory\n");
        goto done;
    }

    /* ---- load ------------------------------------------------------------------------------------ */
    st = tvo_png_read_gray8(path_a, img_a, (size_t)wa * (size_t)ha, &wa, &ha);
    if (st == TVO_OK)
        st = tvo_png_read_gray8(path_b, img_b, (size_t)wa * (size_t)ha, &wb, &hb);
    if (st == TVO_OK && (wa != wb || ha != hb))
        st = TVO_ERR_MISMATCH; /* a file changed since its size was read */
    if (st != TVO_OK) {
        fprintf(stderr, "tvo_track_pair: cannot decode the images: %s%s\n", tvo_status_str(st), hint(st));
        goto done;
    }

    {
        const tvo_image va = tvo_image_make(wa, ha, wa, img_a);
        const tvo_image vb = tvo_image_make(wa, ha, wa, img_b);
        /* ---- detect ---------------------------------------------------------------------------- */
        t0 = tvo_clock_now_ns();
        st = tvo_detect(&dcfg, &va, NULL, 0, corners, max_corners, &n, det_scratch, det_size);
        t_detect = tvo_clock_now_ns() - t0;
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_track_pair: corner detection failed: %s\n", tvo_status_str(st));
            goto done;
        }
        /* ---- pyramids -------------------------------------------------------------------------- */
        t0 = tvo_clock_now_ns();
        st = tvo_pyramid_init(&pyr_a, wa, ha, levels, pyr_mem_a, pyr_size);
        if (st == TVO_OK)
            st = tvo_pyramid_init(&pyr_b, wa, ha, levels, pyr_mem_b, pyr_size);
        if (st == TVO_OK)
            st = tvo_pyramid_build(&pyr_a, &va);
        if (st == TVO_OK)
            st = tvo_pyramid_build(&pyr_b, &vb);
        t_pyr = tvo_clock_now_ns() - t0;
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_track_pair: pyramid failed: %s\n", tvo_status_str(st));
            goto done;
        }
    }
    /* ---- track ----------------------------------------------------------------------------------- */
    for (i = 0; i < n; ++i) {
        pts_a[i].x = corners[i].x;
        pts_a[i].y = corners[i].y;
    }
    t0 = tvo_clock_now_ns();
    st = tvo_lk_track(&lcfg, &pyr_a, &pyr_b, pts_a, pts_b, status, err, n, lk_scratch, lk_size);
    t_lk = tvo_clock_now_ns() - t0;
    if (st != TVO_OK) {
        fprintf(stderr, "tvo_track_pair: tracking failed: %s\n", tvo_status_str(st));
        goto done;
    }

    /* ---- output ---------------------------------------------------------------------------------- */
    if (out_path != NULL) {
        out = fopen(out_path, "w");
        if (out == NULL) {
            fprintf(stderr, "tvo_track_pair: cannot create %s\n", out_path);
            out = stdout;
            goto done;
        }
        fprintf(out, "x_a,y_a,x_b,y_b,status,err\n");
    } else {
        fprintf(out, "# id x_a y_a x_b y_b status err   (%s -> %s, %dx%d)\n", path_a, path_b, (int)wa,
                (int)ha);
    }
    for (i = 0; i < n; ++i) {
        if (out_path != NULL)
            fprintf(out, "%.3f,%.3f,%.3f,%.3f,%d,%.3f\n", pts_a[i].x, pts_a[i].y, pts_b[i].x, pts_b[i].y,
                    status[i], err[i]);
        else
            fprintf(out, "%d %.3f %.3f %.3f %.3f %d %.3f\n", (int)i, pts_a[i].x, pts_a[i].y, pts_b[i].x,
                    pts_b[i].y, status[i], err[i]);
        if (status[i] == TVO_LK_TRACKED) {
            const float dx = pts_b[i].x - pts_a[i].x, dy = pts_b[i].y - pts_a[i].y;
            flow[tracked++] = sqrtf(dx * dx + dy * dy);
        }
    }
    if (fflush(out) != 0 || ferror(out)) {
        fprintf(stderr, "tvo_track_pair: write error on %s\n", out_path ? out_path : "stdout");
        goto done;
    }
    if (!quiet) {
        float med = 0.0f;
        if (tracked > 0) {
            qsort(flow, (size_t)tracked, sizeof *flow, cmp_float);
            med = flow[tracked / 2];
        }
        fprintf(stderr,
                "tvo_track_pair: %dx%d, %d corners, %d tracked (%.1f%%), median flow %.2f px; "
                "detect %.3f ms, pyramids %.3f ms, LK %.3f ms (win %d, %d levels%s)\n",
                (int)wa, (int)ha, (int)n, (int)tracked, n > 0 ? 100.0 * tracked / n : 0.0, med,
                t_detect / 1e6, t_pyr / 1e6, t_lk / 1e6, (int)win, (int)levels, fb ? ", fb check" : "");
    }
    rc = 0;
done:
    if (out != stdout && out != NULL && fclose(out) != 0 && rc == 0) {
        fprintf(stderr, "tvo_track_pair: write error on %s\n", out_path);
        rc = 1;
    }
    free(img_a);
    free(img_b);
    free(det_scratch);
    free(lk_scratch);
    free(pyr_mem_a);
    free(pyr_mem_b);
    free(corners);
    free(pts_a);
    free(pts_b);
    free(status);
    free(err);
    free(flow);
    return rc;
}
