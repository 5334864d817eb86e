/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: EuRoC / ASL folder reader (see tinyvo/port/euroc.h). */
#include "tinyvo/port/euroc.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tinyvo/port/calib.h"
#include "tinyvo/port/dataset.h"
#include "tinyvo/port/png.h"

#define TVO_EUROC_PATH 4096
#define TVO_EUROC_MAX_FILE ((size_t)512 << 20)

/* A malformed frame row skipped by an open with TVO_EUROC_SKIP_BAD_ROWS. */
typedef struct tvo_bad_row {
    char msg[TVO_EUROC_BAD_ROW_MSG];
} tvo_bad_row;

struct tvo_euroc {
    char base[TVO_EUROC_PATH];           /* the mav0 folder (TUM, KITTI: the sequence folder) */
    char frame_dir[TVO_EUROC_PATH + 80]; /* frames are frame_dir/<file> */
    char cam[64];
    tvo_camera camera;
    tvo_pose T_BS;
    double rate_hz;
    tvo_euroc_frame *frames;
    int32_t nframes;
    tvo_euroc_gt_row *gt;
    int32_t ngt;
    tvo_bad_row *bad; /* the first TVO_EUROC_MAX_BAD_ROWS skipped rows */
    int32_t nbad;     /* all skipped rows */
};

/* ---- small helpers ------------------------------------------------------------------------------ */

static void tvo_set_err(char *err, size_t err_size, const char *fmt, ...)
{
    va_list ap;
    if (err == NULL || err_size == 0)
        return;
    va_start(ap, fmt);
    vsnprintf(err, err_size, fmt, ap);
    va_end(ap);
}

/* err := prefix + ": " + err (the parser's message). */
static void tvo_prefix_err(char *err, size_t err_size, const char *prefix)
{
    char tmp[512];
    if (err == NULL || err_size == 0)
        return;
    snprintf(tmp, sizeof tmp, "%s", err);
    snprintf(err, err_size, "%s: %s", prefix, tmp);
}

static int tvo_is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r';
}

/* One line of a buffer: [*beg, *end) without the newline (and without a trailing '\r'). */
typedef struct tvo_lines {
    const char *p, *stop;
    int line;
} tvo_lines;

static int tvo_next_line(tvo_lines *it, const char **beg, const char **end)
{
    const char *e;
    if (it->p >= it->stop)
        return 0;
    *beg = it->p;
    e = it->p;
    while (e < it->stop && *e != '\n')
        ++e;
    it->p = (e < it->stop) ? e + 1 : e;
    it->line++;
    while (e > *beg && e[-1] == '\r')
        --e;
    *end = e;
    return 1;
}

static void tvo_trim(const char **b, const char **e)
{
    while (*b < *e && tvo_is_blank(**b))
        ++*b;
    while (*e > *b && tvo_is_blank((*e)[-1]))
        --*e;
}

/* A finite double from exactly the text [b, e). */
static int tvo_parse_double(const char *b, const char *e, double *out)
{
    char buf[64];
    char *end = NULL;
    size_t n = (size_t)(e - b);
    double v;
    if (n == 0 || n >= sizeof buf)
        return 0;
    memcpy(buf, b, n);
    buf[n] = '\0';
    /* strtod accepts "inf", "nan", hex floats and leading blanks: allow only a plain decimal number. */
    {
        size_t i;
        for (i = 0; i < n; ++i) {
            char c = buf[i];
            if (!((c >= '0' && c <= '9') || c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E'))
                return 0;
        }
    }
    errno = 0;
    v = strtod(buf, &end);
    if (end != buf + n || !isfinite(v) || errno == ERANGE)
        return 0;
    *out = v;
    return 1;
}

/* A non-negative int64 timestamp: digits, optionally '.' digits (rounded half up). */
static int tvo_parse_time(const char *b, const char *e, int64_t *out)
{
    int64_t v = 0;
    const char *p = b;
    if (p == e)
        return 0;
    if (*p == '+')
        ++p;
    if (p == e || *p < '0' || *p > '9')
        return 0;
    for (; p < e && *p >= '0' && *p <= '9'; ++p) {
        int d = *p - '0';
        if (v > (INT64_MAX - d) / 10)
            return 0;
        v = v * 10 + d;
    }
    if (p < e && *p == '.') {
        const char *f = ++p;
        for (; p < e && *p >= '0' && *p <= '9'; ++p)
            ;
        if (p > f && *f >= '5') {
            if (v == INT64_MAX)
                return 0;
            ++v;
        }
    }
    if (p != e)
        return 0;
    *out = v;
    return 1;
}

static int tvo_span_eq(const char *b, const char *e, const char *s)
{
    size_t n = strlen(s);
    return (size_t)(e - b) == n && memcmp(b, s, n) == 0;
}

/* ---- sensor.yaml ------------------------------------------------------------------------------- */

tvo_status tvo_euroc_parse_sensor_yaml(const char *text, size_t len, tvo_camera *cam_out, tvo_pose *T_BS,
                                       double *rate_hz, char *err, size_t err_size)
{
    tvo_calib c;
    tvo_status st;
    if (err != NULL && err_size > 0)
        err[0] = '\0';
    if ((text == NULL && len > 0) || cam_out == NULL) {
        tvo_set_err(err, err_size, "NULL argument");
        return TVO_ERR_NULL;
    }
    st = tvo_calib_parse(text, len, TVO_CALIB_EUROC, NULL, &c, err, err_size);
    if (st != TVO_OK)
        return st;
    *cam_out = c.camera;
    if (T_BS != NULL)
        *T_BS = c.T_BS;
    if (rate_hz != NULL)
        *rate_hz = c.rate_hz;
    return TVO_OK;
}

/* ---- csv files ----------------------------------------------------------------------------------- */

/* The argument checks both csv parsers start with; sets up the line iterator over [text, text+len). */
static tvo_status tvo_csv_begin(const char *text, size_t len, int32_t capacity, int32_t *count, tvo_lines *it,
                                char *err, size_t err_size)
{
    if (err != NULL && err_size > 0)
        err[0] = '\0';
    if (count == NULL || (text == NULL && len > 0)) {
        tvo_set_err(err, err_size, "NULL argument");
        return TVO_ERR_NULL;
    }
    *count = 0;
    if (capacity < 0) {
        tvo_set_err(err, err_size, "negative capacity");
        return TVO_ERR_ARG;
    }
    it->p = text;
    it->stop = text + len;
    it->line = 0;
    return TVO_OK;
}

/* The next data line of a csv, trimmed, skipping blank and '#' lines: 1 with [*b, *e), 0 at the end,
 * -1 (message in err) for a line holding a NUL byte. */
static int tvo_csv_next_row(tvo_lines *it, const char **b, const char **e, char *err, size_t err_size)
{
    while (tvo_next_line(it, b, e)) {
        tvo_trim(b, e);
        if (*b == *e || **b == '#')
            continue;
        if (memchr(*b, '\0', (size_t)(*e - *b)) != NULL) {
            tvo_set_err(err, err_size, "line %d: NUL byte", it->line);
            return -1;
        }
        return 1;
    }
    return 0;
}

/* A time in seconds with an optional decimal fraction ("1305031102.175304") as ns, exactly (digits
 * beyond the ninth decimal round half up). */
static int tvo_parse_seconds(const char *b, const char *e, int64_t *out)
{
    int64_t sec = 0, frac = 0;
    const char *p = b;
    int k;
    if (p == e || *p < '0' || *p > '9')
        return 0;
    for (; p < e && *p >= '0' && *p <= '9'; ++p) {
        if (sec > (INT64_MAX / 1000000000 - 9) / 10)
            return 0;
        sec = sec * 10 + (*p - '0');
    }
    if (p < e && *p == '.') {
        ++p;
        for (k = 0; k < 9; ++k) {
            frac *= 10;
            if (p < e && *p >= '0' && *p <= '9')
                frac += *p++ - '0';
        }
        if (p < e && *p >= '5' && *p <= '9')
            ++frac;
        while (p < e && *p >= '0' && *p <= '9')
            ++p;
    }
    if (p != e)
        return 0;
    *out = sec * 1000000000 + frac;
    return 1;
}

/* One frame row [b, e) (trimmed, not a comment) of line `line`: EuRoC "timestamp_ns,filename" or, with
 * tum, TUM's "seconds filename" (the file name may then be a relative path without ".." parts).
 * 1 with *fr filled, 0 with a message in err. */
static int tvo_frame_row(const char *b, const char *e, int line, int tum, tvo_euroc_frame *fr, char *err,
                         size_t err_size)
{
    const char *c, *tb, *te, *fb, *fe;
    int64_t t;
    if (memchr(b, '\0', (size_t)(e - b)) != NULL) {
        tvo_set_err(err, err_size, "line %d: NUL byte", line);
        return 0;
    }
    if (tum) {
        for (c = b; c < e && !tvo_is_blank(*c); ++c)
            ;
        if (c == e) {
            tvo_set_err(err, err_size, "line %d: expected 'timestamp filename'", line);
            return 0;
        }
    } else {
        c = (const char *)memchr(b, ',', (size_t)(e - b));
        if (c == NULL) {
            tvo_set_err(err, err_size, "line %d: expected 'timestamp,filename'", line);
            return 0;
        }
    }
    tb = b;
    te = c;
    fb = c + 1;
    fe = e;
    tvo_trim(&tb, &te);
    tvo_trim(&fb, &fe);
    if (tum ? !tvo_parse_seconds(tb, te, &t)
            : (!tvo_parse_time(tb, te, &t) || memchr(tb, '.', (size_t)(te - tb)) != NULL)) {
        tvo_set_err(err, err_size, "line %d: bad timestamp '%.*s' (%s expected)", line,
                    (int)((te - tb) > 40 ? 40 : (te - tb)), tb, tum ? "seconds" : "integer nanoseconds");
        return 0;
    }
    if (tum) {
        /* a relative path: no leading '/', no '\\', no blank, no "." or ".." component */
        const char *p = fb;
        int bad = fb == fe || *fb == '/' || memchr(fb, '\\', (size_t)(fe - fb)) != NULL;
        while (!bad && p <= fe) {
            const char *q = p;
            while (q < fe && *q != '/')
                ++q;
            if (q == p || tvo_span_eq(p, q, ".") || tvo_span_eq(p, q, ".."))
                bad = 1;
            for (; p < q; ++p)
                if (tvo_is_blank(*p))
                    bad = 1;
            p = q + 1;
        }
        if (bad) {
            tvo_set_err(err, err_size, "line %d: bad file name (empty, absolute, extra field or '..')", line);
            return 0;
        }
    } else if (fb == fe || memchr(fb, ',', (size_t)(fe - fb)) != NULL ||
               memchr(fb, '/', (size_t)(fe - fb)) != NULL || memchr(fb, '\\', (size_t)(fe - fb)) != NULL ||
               tvo_span_eq(fb, fe, ".") || tvo_span_eq(fb, fe, "..")) {
        tvo_set_err(err, err_size, "line %d: bad file name (empty, extra field, or a path)", line);
        return 0;
    }
    if ((size_t)(fe - fb) >= TVO_EUROC_MAX_NAME) {
        tvo_set_err(err, err_size, "line %d: file name longer than %d bytes", line, TVO_EUROC_MAX_NAME - 1);
        return 0;
    }
    fr->t_ns = t;
    memcpy(fr->file, fb, (size_t)(fe - fb));
    fr->file[fe - fb] = '\0';
    return 1;
}

tvo_status tvo_euroc_parse_frames_csv(const char *text, size_t len, tvo_euroc_frame *frames, int32_t capacity,
                                      int32_t *count, char *err, size_t err_size)
{
    tvo_lines it;
    const char *b, *e;
    int32_t n = 0;
    tvo_status st;
    int row;
    st = tvo_csv_begin(text, len, capacity, count, &it, err, err_size);
    if (st != TVO_OK)
        return st;
    while ((row = tvo_csv_next_row(&it, &b, &e, err, err_size)) > 0) {
        tvo_euroc_frame fr;
        if (!tvo_frame_row(b, e, it.line, 0, &fr, err, err_size))
            return TVO_ERR_FORMAT;
        if (n == INT32_MAX) {
            tvo_set_err(err, err_size, "line %d: too many frames", it.line);
            return TVO_ERR_FORMAT;
        }
        if (frames != NULL && n < capacity)
            frames[n] = fr;
        ++n;
    }
    if (row < 0)
        return TVO_ERR_FORMAT;
    *count = n;
    if (frames != NULL && n > capacity) {
        tvo_set_err(err, err_size, "%d frames do not fit in a capacity of %d", (int)n, (int)capacity);
        return TVO_ERR_NO_MEMORY;
    }
    return TVO_OK;
}

/* Split a line into fields separated by ',' and/or blanks. Returns the field count (up to max), or
 * -1 for an empty field ("a,,b", a trailing ','). */
static int tvo_split_fields(const char *b, const char *e, const char **fb, const char **fe, int max)
{
    int n = 0;
    const char *p = b;
    while (p < e && tvo_is_blank(*p))
        ++p;
    while (p < e) {
        const char *s = p;
        if (*p == ',')
            return -1;
        while (p < e && *p != ',' && !tvo_is_blank(*p))
            ++p;
        if (n < max) {
            fb[n] = s;
            fe[n] = p;
        }
        ++n;
        while (p < e && tvo_is_blank(*p))
            ++p;
        if (p < e && *p == ',') {
            ++p;
            while (p < e && tvo_is_blank(*p))
                ++p;
            if (p == e || *p == ',')
                return -1;
        }
    }
    return n;
}

/* A ground-truth table: EuRoC (t_ns px py pz qw qx qy qz) or, with tum, TUM (t_s tx ty tz qx qy qz qw). */
static tvo_status tvo_parse_gt(const char *text, size_t len, tvo_euroc_gt_row *rows, int32_t capacity,
                               int32_t *count, int tum, char *err, size_t err_size)
{
    static const char *const euroc_names[8] = {"timestamp", "p_x", "p_y", "p_z", "q_w", "q_x", "q_y", "q_z"};
    static const char *const tum_names[8] = {"timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    const char *const *names = tum ? tum_names : euroc_names;
    tvo_lines it;
    const char *b, *e;
    int32_t n = 0;
    int64_t last = -1;
    tvo_status st;
    int row;
    st = tvo_csv_begin(text, len, capacity, count, &it, err, err_size);
    if (st != TVO_OK)
        return st;
    while ((row = tvo_csv_next_row(&it, &b, &e, err, err_size)) > 0) {
        const char *fb[8], *fe[8];
        tvo_euroc_gt_row r;
        double qn;
        int nf, i;
        nf = tvo_split_fields(b, e, fb, fe, 8);
        if (nf < 0) {
            tvo_set_err(err, err_size, "line %d: empty field", it.line);
            return TVO_ERR_FORMAT;
        }
        if (nf < 8) {
            tvo_set_err(err, err_size, "line %d: %d fields, need at least 8 (t px py pz qw qx qy qz)",
                        it.line, nf);
            return TVO_ERR_FORMAT;
        }
        if (tum ? !tvo_parse_seconds(fb[0], fe[0], &r.t_ns) : !tvo_parse_time(fb[0], fe[0], &r.t_ns)) {
            tvo_set_err(err, err_size, "line %d: bad timestamp '%.*s' (%s expected)", it.line,
                        (int)((fe[0] - fb[0]) > 40 ? 40 : (fe[0] - fb[0])), fb[0],
                        tum ? "seconds" : "nanoseconds");
            return TVO_ERR_FORMAT;
        }
        for (i = 1; i < 8; ++i) {
            double v;
            if (!tvo_parse_double(fb[i], fe[i], &v)) {
                tvo_set_err(err, err_size, "line %d: bad number in column %d (%s): '%.*s'", it.line, i + 1,
                            names[i], (int)((fe[i] - fb[i]) > 40 ? 40 : (fe[i] - fb[i])), fb[i]);
                return TVO_ERR_FORMAT;
            }
            if (i < 4 && !(fabs(v) <= TVO_EUROC_MAX_COORD)) {
                tvo_set_err(err, err_size, "line %d: position %s = %g m beyond +-%g m", it.line, names[i], v,
                            TVO_EUROC_MAX_COORD);
                return TVO_ERR_FORMAT;
            }
            if (i < 4)
                r.p[i - 1] = v;
            else
                r.q_wxyz[tum ? (i - 3) % 4 : i - 4] = v;
        }
        qn = sqrt(r.q_wxyz[0] * r.q_wxyz[0] + r.q_wxyz[1] * r.q_wxyz[1] + r.q_wxyz[2] * r.q_wxyz[2] +
                  r.q_wxyz[3] * r.q_wxyz[3]);
        if (!(fabs(qn - 1.0) <= 0.01)) {
            tvo_set_err(err, err_size, "line %d: quaternion norm %g is not 1", it.line, qn);
            return TVO_ERR_FORMAT;
        }
        for (i = 0; i < 4; ++i)
            r.q_wxyz[i] /= qn;
        if (r.t_ns <= last) {
            tvo_set_err(err, err_size, "line %d: timestamp not increasing", it.line);
            return TVO_ERR_FORMAT;
        }
        last = r.t_ns;
        if (n == INT32_MAX) {
            tvo_set_err(err, err_size, "line %d: too many rows", it.line);
            return TVO_ERR_FORMAT;
        }
        if (rows != NULL && n < capacity)
            rows[n] = r;
        ++n;
    }
    if (row < 0)
        return TVO_ERR_FORMAT;
    *count = n;
    if (rows != NULL && n > capacity) {
        tvo_set_err(err, err_size, "%d rows do not fit in a capacity of %d", (int)n, (int)capacity);
        return TVO_ERR_NO_MEMORY;
    }
    return TVO_OK;
}

tvo_status tvo_euroc_parse_groundtruth(const char *text, size_t len, tvo_euroc_gt_row *rows, int32_t capacity,
                                       int32_t *count, char *err, size_t err_size)
{
    return tvo_parse_gt(text, len, rows, capacity, count, 0, err, err_size);
}

tvo_status tvo_tum_parse_groundtruth(const char *text, size_t len, tvo_euroc_gt_row *rows, int32_t capacity,
                                     int32_t *count, char *err, size_t err_size)
{
    return tvo_parse_gt(text, len, rows, capacity, count, 1, err, err_size);
}

/* ---- files -------------------------------------------------------------------------------------- */

static tvo_status tvo_slurp(const char *path, char **data, size_t *size, char *err, size_t err_size)
{
    FILE *f;
    char *buf = NULL;
    size_t cap = 0, len = 0;
    errno = 0;
    f = fopen(path, "rb");
    if (f == NULL) {
        int e = errno;
        tvo_set_err(err, err_size, "%s: %s", path, strerror(e));
        return (e == ENOENT || e == ENOTDIR) ? TVO_ERR_NOT_FOUND : TVO_ERR_IO;
    }
    for (;;) {
        size_t got;
        if (len == cap) {
            size_t ncap = cap == 0 ? (size_t)65536 : cap * 2;
            char *nb;
            if (cap >= TVO_EUROC_MAX_FILE) {
                fclose(f);
                free(buf);
                tvo_set_err(err, err_size, "%s: file too large", path);
                return TVO_ERR_FORMAT;
            }
            nb = (char *)realloc(buf, ncap);
            if (nb == NULL) {
                fclose(f);
                free(buf);
                tvo_set_err(err, err_size, "%s: out of memory", path);
                return TVO_ERR_NO_MEMORY;
            }
            buf = nb;
            cap = ncap;
        }
        got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) {
            if (ferror(f)) {
                fclose(f);
                free(buf);
                tvo_set_err(err, err_size, "%s: read error", path);
                return TVO_ERR_IO;
            }
            break;
        }
    }
    fclose(f);
    *data = buf;
    *size = len;
    return TVO_OK;
}

static int tvo_file_exists(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return 0;
    fclose(f);
    return 1;
}

/* Parse a ground-truth file into a new malloc'ed array. */
static tvo_status tvo_load_gt_kind(const char *path, int tum, tvo_euroc_gt_row **rows, int32_t *count,
                                   char *err, size_t err_size)
{
    char *text = NULL;
    size_t len = 0;
    int32_t n = 0;
    tvo_euroc_gt_row *r = NULL;
    tvo_status st = tvo_slurp(path, &text, &len, err, err_size);
    if (st != TVO_OK)
        return st;
    st = tvo_parse_gt(text, len, NULL, 0, &n, tum, err, err_size);
    if (st == TVO_OK && n == 0) {
        tvo_set_err(err, err_size, "no rows");
        st = TVO_ERR_FORMAT;
    }
    if (st == TVO_OK) {
        r = (tvo_euroc_gt_row *)malloc((size_t)n * sizeof *r);
        if (r == NULL) {
            tvo_set_err(err, err_size, "out of memory");
            st = TVO_ERR_NO_MEMORY;
        }
    }
    if (st == TVO_OK)
        st = tvo_parse_gt(text, len, r, n, &n, tum, err, err_size);
    free(text);
    if (st != TVO_OK) {
        free(r);
        if (st == TVO_ERR_FORMAT)
            tvo_prefix_err(err, err_size, path);
        return st;
    }
    *rows = r;
    *count = n;
    return TVO_OK;
}

static tvo_status tvo_load_gt(const char *path, tvo_euroc_gt_row **rows, int32_t *count, char *err,
                              size_t err_size)
{
    return tvo_load_gt_kind(path, 0, rows, count, err, err_size);
}

/* Record a skipped row: "<path>:<line>: <what>" from the parser's "line N: what". */
static void tvo_add_bad_row(tvo_euroc *s, const char *path, int line, const char *msg)
{
    const char *what = msg;
    if (strncmp(msg, "line ", 5) == 0 && strstr(msg, ": ") != NULL)
        what = strstr(msg, ": ") + 2;
    if (s->bad == NULL)
        s->bad = (tvo_bad_row *)calloc(TVO_EUROC_MAX_BAD_ROWS, sizeof *s->bad);
    if (s->bad != NULL && s->nbad < TVO_EUROC_MAX_BAD_ROWS)
        tvo_set_err(s->bad[s->nbad].msg, sizeof s->bad[s->nbad].msg, "%s:%d: %s", path, line, what);
    if (s->nbad < INT32_MAX)
        s->nbad++;
}

/* The frame list at path (EuRoC data.csv, or TUM rgb.txt with tum) into s->frames. Without lenient
 * the first malformed row fails the call ("<path>: line N: what"); with it, malformed rows are
 * recorded and skipped. A list without any frame fails. */
static tvo_status tvo_load_frames(tvo_euroc *s, const char *path, int tum, int lenient, char *err,
                                  size_t err_size)
{
    char *text = NULL;
    size_t len = 0, lines = 1, k;
    tvo_lines it;
    const char *b, *e;
    tvo_status st = tvo_slurp(path, &text, &len, err, err_size);
    if (st != TVO_OK)
        return st;
    for (k = 0; k < len; ++k)
        lines += text[k] == '\n';
    if (lines > (size_t)INT32_MAX) {
        free(text);
        tvo_set_err(err, err_size, "%s: too many lines", path);
        return TVO_ERR_FORMAT;
    }
    s->frames = (tvo_euroc_frame *)malloc(lines * sizeof *s->frames);
    if (s->frames == NULL) {
        free(text);
        tvo_set_err(err, err_size, "%s: out of memory", path);
        return TVO_ERR_NO_MEMORY;
    }
    it.p = text;
    it.stop = text + len;
    it.line = 0;
    s->nframes = 0;
    while (tvo_next_line(&it, &b, &e)) {
        char msg[TVO_EUROC_BAD_ROW_MSG];
        tvo_trim(&b, &e);
        if (b == e || *b == '#')
            continue;
        if (tvo_frame_row(b, e, it.line, tum, &s->frames[s->nframes], msg, sizeof msg)) {
            s->nframes++;
        } else if (lenient) {
            tvo_add_bad_row(s, path, it.line, msg);
        } else {
            tvo_set_err(err, err_size, "%s: %s", path, msg);
            free(text);
            return TVO_ERR_FORMAT;
        }
    }
    free(text);
    if (s->nframes == 0) {
        tvo_set_err(err, err_size, "%s: no frames", path);
        return TVO_ERR_FORMAT;
    }
    return TVO_OK;
}

static tvo_euroc *tvo_seq_new(char *err, size_t err_size)
{
    tvo_euroc *s = (tvo_euroc *)calloc(1, sizeof *s);
    if (s == NULL)
        tvo_set_err(err, err_size, "out of memory");
    else
        s->T_BS = tvo_pose_identity();
    return s;
}

tvo_status tvo_euroc_open(tvo_euroc **out, const char *dir, const char *cam, char *err, size_t err_size)
{
    return tvo_euroc_open_ex(out, dir, cam, 0u, err, err_size);
}

tvo_status tvo_euroc_open_ex(tvo_euroc **out, const char *dir, const char *cam, unsigned flags, char *err,
                             size_t err_size)
{
    tvo_euroc *s;
    char path[TVO_EUROC_PATH + 128];
    char *text = NULL;
    size_t len = 0;
    tvo_status st;
    if (err != NULL && err_size > 0)
        err[0] = '\0';
    if (out == NULL || dir == NULL) {
        tvo_set_err(err, err_size, "NULL argument");
        return TVO_ERR_NULL;
    }
    *out = NULL;
    if (cam == NULL)
        cam = "cam0";
    if (cam[0] == '\0' || strlen(cam) >= sizeof s->cam || strchr(cam, '/') != NULL ||
        strcmp(cam, "..") == 0 || strcmp(cam, ".") == 0) {
        tvo_set_err(err, err_size, "bad camera name '%s'", cam);
        return TVO_ERR_ARG;
    }
    if (strlen(dir) + 16 >= TVO_EUROC_PATH) {
        tvo_set_err(err, err_size, "path too long");
        return TVO_ERR_ARG;
    }
    s = tvo_seq_new(err, err_size);
    if (s == NULL)
        return TVO_ERR_NO_MEMORY;
    /* NOLINTNEXTLINE(clang-analyzer-security.insecureAPI.strcpy): strlen(cam) < sizeof s->cam checked above */
    strcpy(s->cam, cam);
    /* DIR/mav0/<cam> or DIR/<cam> */
    snprintf(path, sizeof path, "%s/mav0/%s/data.csv", dir, cam);
    if (tvo_file_exists(path)) {
        snprintf(s->base, sizeof s->base, "%s/mav0", dir);
    } else {
        snprintf(path, sizeof path, "%s/%s/data.csv", dir, cam);
        if (!tvo_file_exists(path)) {
            tvo_set_err(err, err_size, "%s: no mav0/%s/data.csv (or %s/data.csv) there", dir, cam, cam);
            free(s);
            return TVO_ERR_NOT_FOUND;
        }
        snprintf(s->base, sizeof s->base, "%s", dir);
    }
    snprintf(s->frame_dir, sizeof s->frame_dir, "%s/%s/data", s->base, cam);

    snprintf(path, sizeof path, "%s/%s/sensor.yaml", s->base, cam);
    st = tvo_slurp(path, &text, &len, err, err_size);
    if (st == TVO_OK) {
        st = tvo_euroc_parse_sensor_yaml(text, len, &s->camera, &s->T_BS, &s->rate_hz, err, err_size);
        free(text);
        text = NULL;
        if (st != TVO_OK)
            tvo_prefix_err(err, err_size, path);
    }
    if (st != TVO_OK)
        goto fail;

    snprintf(path, sizeof path, "%s/%s/data.csv", s->base, cam);
    st = tvo_load_frames(s, path, 0, (flags & TVO_EUROC_SKIP_BAD_ROWS) != 0, err, err_size);
    if (st != TVO_OK)
        goto fail;

    snprintf(path, sizeof path, "%s/state_groundtruth_estimate0/data.csv", s->base);
    if (tvo_file_exists(path)) {
        st = tvo_load_gt(path, &s->gt, &s->ngt, err, err_size);
        if (st != TVO_OK)
            goto fail;
    }
    *out = s;
    return TVO_OK;
fail:
    tvo_euroc_close(s);
    return st;
}

void tvo_euroc_close(tvo_euroc *seq)
{
    if (seq == NULL)
        return;
    free(seq->frames);
    free(seq->gt);
    free(seq->bad);
    free(seq);
}

tvo_status tvo_euroc_load_groundtruth_file(tvo_euroc *seq, const char *path, char *err, size_t err_size)
{
    tvo_euroc_gt_row *rows = NULL;
    int32_t n = 0;
    tvo_status st;
    if (err != NULL && err_size > 0)
        err[0] = '\0';
    if (seq == NULL || path == NULL) {
        tvo_set_err(err, err_size, "NULL argument");
        return TVO_ERR_NULL;
    }
    st = tvo_load_gt(path, &rows, &n, err, err_size);
    if (st != TVO_OK)
        return st;
    free(seq->gt);
    seq->gt = rows;
    seq->ngt = n;
    return TVO_OK;
}

/* ---- queries ------------------------------------------------------------------------------------ */

int32_t tvo_euroc_frame_count(const tvo_euroc *seq)
{
    return seq == NULL ? 0 : seq->nframes;
}

int64_t tvo_euroc_frame_time(const tvo_euroc *seq, int32_t i)
{
    if (seq == NULL || i < 0 || i >= seq->nframes)
        return -1;
    return seq->frames[i].t_ns;
}

const char *tvo_euroc_frame_file(const tvo_euroc *seq, int32_t i)
{
    if (seq == NULL || i < 0 || i >= seq->nframes)
        return NULL;
    return seq->frames[i].file;
}

tvo_status tvo_euroc_frame_path(const tvo_euroc *seq, int32_t i, char *path, size_t size)
{
    int w;
    if (seq == NULL || path == NULL)
        return TVO_ERR_NULL;
    if (size == 0)
        return TVO_ERR_NO_MEMORY;
    path[0] = '\0';
    if (i < 0 || i >= seq->nframes)
        return TVO_ERR_RANGE;
    w = snprintf(path, size, "%s/%s", seq->frame_dir, seq->frames[i].file);
    if (w < 0 || (size_t)w >= size) {
        path[0] = '\0';
        return TVO_ERR_NO_MEMORY;
    }
    return TVO_OK;
}

tvo_status tvo_euroc_read_frame(const tvo_euroc *seq, int32_t i, uint8_t *buf, size_t capacity)
{
    char path[TVO_EUROC_PATH + 80 + 2 * TVO_EUROC_MAX_NAME];
    int32_t w = 0, h = 0;
    tvo_status st;
    if (seq == NULL || buf == NULL)
        return TVO_ERR_NULL;
    st = tvo_euroc_frame_path(seq, i, path, sizeof path);
    if (st != TVO_OK)
        return st;
    if (capacity < (size_t)seq->camera.width * (size_t)seq->camera.height)
        return TVO_ERR_NO_MEMORY;
    st = tvo_png_size(path, &w, &h);
    if (st != TVO_OK)
        return st;
    if (w != seq->camera.width || h != seq->camera.height)
        return TVO_ERR_MISMATCH;
    st = tvo_png_read_gray8(path, buf, capacity, &w, &h);
    if (st == TVO_OK && (w != seq->camera.width || h != seq->camera.height))
        return TVO_ERR_MISMATCH; /* the file changed between the two reads */
    return st;
}

const tvo_camera *tvo_euroc_camera(const tvo_euroc *seq)
{
    return seq == NULL ? NULL : &seq->camera;
}

tvo_pose tvo_euroc_T_BS(const tvo_euroc *seq)
{
    return seq == NULL ? tvo_pose_identity() : seq->T_BS;
}

double tvo_euroc_rate_hz(const tvo_euroc *seq)
{
    return seq == NULL ? 0.0 : seq->rate_hz;
}

const char *tvo_euroc_base_dir(const tvo_euroc *seq)
{
    return seq == NULL ? NULL : seq->base;
}

int32_t tvo_euroc_bad_row_count(const tvo_euroc *seq)
{
    return seq == NULL ? 0 : seq->nbad;
}

const char *tvo_euroc_bad_row(const tvo_euroc *seq, int32_t i)
{
    if (seq == NULL || seq->bad == NULL || i < 0 || i >= seq->nbad || i >= TVO_EUROC_MAX_BAD_ROWS)
        return NULL;
    return seq->bad[i].msg;
}

int tvo_euroc_has_groundtruth(const tvo_euroc *seq)
{
    return seq != NULL && seq->ngt > 0;
}

int32_t tvo_euroc_groundtruth_count(const tvo_euroc *seq)
{
    return seq == NULL ? 0 : seq->ngt;
}

tvo_status tvo_euroc_groundtruth_row(const tvo_euroc *seq, int32_t i, tvo_euroc_gt_row *row)
{
    if (seq == NULL || row == NULL)
        return TVO_ERR_NULL;
    if (i < 0 || i >= seq->ngt)
        return TVO_ERR_RANGE;
    *row = seq->gt[i];
    return TVO_OK;
}

/* First row with t >= t_ns (ngt if none). */
static int32_t tvo_gt_lower_bound(const tvo_euroc *seq, int64_t t_ns)
{
    int32_t lo = 0, hi = seq->ngt;
    while (lo < hi) {
        int32_t mid = lo + (hi - lo) / 2;
        if (seq->gt[mid].t_ns < t_ns)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* |a - b| without overflow, saturating. */
static uint64_t tvo_absdiff(int64_t a, int64_t b)
{
    return a > b ? (uint64_t)a - (uint64_t)b : (uint64_t)b - (uint64_t)a;
}

tvo_status tvo_euroc_groundtruth(const tvo_euroc *seq, int64_t t_ns, int64_t tol_ns, tvo_pose *T_w_b)
{
    int32_t i, best;
    if (seq == NULL || T_w_b == NULL)
        return TVO_ERR_NULL;
    if (tol_ns < 0)
        return TVO_ERR_ARG;
    if (seq->ngt == 0)
        return TVO_ERR_STATE;
    i = tvo_gt_lower_bound(seq, t_ns);
    if (i == seq->ngt)
        best = i - 1;
    else if (i == 0)
        best = 0;
    else
        best = tvo_absdiff(seq->gt[i].t_ns, t_ns) < tvo_absdiff(seq->gt[i - 1].t_ns, t_ns) ? i : i - 1;
    if (tvo_absdiff(seq->gt[best].t_ns, t_ns) > (uint64_t)tol_ns)
        return TVO_ERR_RANGE;
    *T_w_b = tvo_pose_from_quat(seq->gt[best].q_wxyz, seq->gt[best].p);
    return TVO_OK;
}

tvo_status tvo_euroc_groundtruth_interp(const tvo_euroc *seq, int64_t t_ns, int64_t max_gap_ns,
                                        tvo_pose *T_w_b)
{
    const tvo_euroc_gt_row *a, *b;
    double q[4], qb[4], p[3], s, dot, wa, wb;
    int32_t i;
    int k;
    if (seq == NULL || T_w_b == NULL)
        return TVO_ERR_NULL;
    if (max_gap_ns < 0)
        return TVO_ERR_ARG;
    if (seq->ngt == 0)
        return TVO_ERR_STATE;
    i = tvo_gt_lower_bound(seq, t_ns);
    if (i < seq->ngt && seq->gt[i].t_ns == t_ns) {
        *T_w_b = tvo_pose_from_quat(seq->gt[i].q_wxyz, seq->gt[i].p);
        return TVO_OK;
    }
    if (i == 0 || i == seq->ngt)
        return TVO_ERR_RANGE;
    a = &seq->gt[i - 1];
    b = &seq->gt[i];
    if (tvo_absdiff(b->t_ns, a->t_ns) > (uint64_t)max_gap_ns)
        return TVO_ERR_RANGE;
    s = (double)(t_ns - a->t_ns) / (double)(b->t_ns - a->t_ns);
    for (k = 0; k < 3; ++k)
        p[k] = a->p[k] + s * (b->p[k] - a->p[k]);
    dot = 0.0;
    for (k = 0; k < 4; ++k) {
        qb[k] = b->q_wxyz[k];
        dot += a->q_wxyz[k] * qb[k];
    }
    if (dot < 0.0) {
        dot = -dot;
        for (k = 0; k < 4; ++k)
            qb[k] = -qb[k];
    }
    if (dot > 0.9995) {
        wa = 1.0 - s;
        wb = s;
    } else {
        const double th = acos(dot), st = sin(th);
        wa = sin((1.0 - s) * th) / st;
        wb = sin(s * th) / st;
    }
    for (k = 0; k < 4; ++k)
        q[k] = wa * a->q_wxyz[k] + wb * qb[k]; /* tvo_pose_from_quat normalises */
    *T_w_b = tvo_pose_from_quat(q, p);
    return TVO_OK;
}

/* ---- TUM RGB-D and KITTI odometry folders (dataset.h) --------------------------------------------- */

static int cmp_i64(const void *a, const void *b)
{
    const int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

/* rate_hz := 1 / median frame interval (0 with fewer than 2 increasing frames). */
static void tvo_rate_from_frames(tvo_euroc *s)
{
    int64_t *d;
    int32_t i, n = 0;
    s->rate_hz = 0.0;
    if (s->nframes < 2)
        return;
    d = (int64_t *)malloc((size_t)(s->nframes - 1) * sizeof *d);
    if (d == NULL)
        return;
    for (i = 1; i < s->nframes; ++i)
        if (s->frames[i].t_ns > s->frames[i - 1].t_ns)
            d[n++] = s->frames[i].t_ns - s->frames[i - 1].t_ns;
    if (n > 0) {
        const int32_t mid = n / 2;
        qsort(d, (size_t)n, sizeof *d, cmp_i64);
        s->rate_hz = 1e9 / (double)d[mid];
    }
    free(d);
}

/* The first frame's PNG size must be cam's (a calibration for another size is refused up front). */
static tvo_status tvo_check_first_frame(const tvo_euroc *s, const tvo_camera *cam, int32_t *w, int32_t *h,
                                        char *err, size_t err_size)
{
    char path[TVO_EUROC_PATH + 80 + 2 * TVO_EUROC_MAX_NAME];
    tvo_status st = tvo_euroc_frame_path(s, 0, path, sizeof path);
    if (st == TVO_OK)
        st = tvo_png_size(path, w, h);
    if (st != TVO_OK) {
        tvo_set_err(err, err_size, "cannot read the first frame %s: %s", path, tvo_status_str(st));
        return st;
    }
    if (cam != NULL && (cam->width != *w || cam->height != *h)) {
        tvo_set_err(err, err_size, "the calibration is for %dx%d but the frames are %dx%d (%s)",
                    (int)cam->width, (int)cam->height, (int)*w, (int)*h, path);
        return TVO_ERR_MISMATCH;
    }
    return TVO_OK;
}

static tvo_status tvo_seq_begin(tvo_euroc **out, const char *dir, tvo_euroc **s, char *err, size_t err_size)
{
    size_t n;
    if (err != NULL && err_size > 0)
        err[0] = '\0';
    if (out == NULL || dir == NULL) {
        tvo_set_err(err, err_size, "NULL argument");
        return TVO_ERR_NULL;
    }
    *out = NULL;
    n = strlen(dir);
    if (n == 0 || n + 16 >= TVO_EUROC_PATH) {
        tvo_set_err(err, err_size, "bad or too long path");
        return TVO_ERR_ARG;
    }
    *s = tvo_seq_new(err, err_size);
    if (*s == NULL)
        return TVO_ERR_NO_MEMORY;
    snprintf((*s)->base, sizeof(*s)->base, "%s", dir);
    while (n > 1 && (*s)->base[n - 1] == '/')
        (*s)->base[--n] = '\0';
    return TVO_OK;
}

/* The last path component of dir (without trailing '/'). */
static const char *tvo_last_component(const char *dir, char *buf, size_t size)
{
    size_t n = strlen(dir);
    const char *p;
    while (n > 1 && dir[n - 1] == '/')
        --n;
    p = dir + n;
    while (p > dir && p[-1] != '/')
        --p;
    snprintf(buf, size, "%.*s", (int)(dir + n - p), p);
    return buf;
}

tvo_status tvo_tum_camera(const char *dir, tvo_camera *cam)
{
    /* the RGB cameras of https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats (ROS default
     * 640x480; freiburg3's images are already undistorted) */
    static const double k1[5] = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
    static const double k2[5] = {0.2312, -0.7849, -0.0033, -0.0001, 0.9172};
    char name[TVO_EUROC_PATH];
    if (dir == NULL || cam == NULL)
        return TVO_ERR_NULL;
    tvo_last_component(dir, name, sizeof name);
    if (strstr(name, "freiburg1") != NULL) {
        *cam = tvo_camera_make_pinhole(640, 480, 517.3, 516.5, 318.6, 255.3);
        cam->model = TVO_DIST_RADTAN;
        memcpy(cam->k, k1, sizeof k1);
    } else if (strstr(name, "freiburg2") != NULL) {
        *cam = tvo_camera_make_pinhole(640, 480, 520.9, 521.0, 325.1, 249.7);
        cam->model = TVO_DIST_RADTAN;
        memcpy(cam->k, k2, sizeof k2);
    } else if (strstr(name, "freiburg3") != NULL) {
        *cam = tvo_camera_make_pinhole(640, 480, 535.4, 539.2, 320.1, 247.6);
    } else {
        return TVO_ERR_NOT_FOUND;
    }
    return TVO_OK;
}

tvo_status tvo_tum_open(tvo_euroc **out, const char *dir, const tvo_camera *camera, unsigned flags, char *err,
                        size_t err_size)
{
    tvo_euroc *s = NULL;
    char path[TVO_EUROC_PATH + 128];
    int32_t w = 0, h = 0;
    tvo_status st = tvo_seq_begin(out, dir, &s, err, err_size);
    if (st != TVO_OK)
        return st;
    snprintf(s->frame_dir, sizeof s->frame_dir, "%s", s->base);
    snprintf(path, sizeof path, "%s/rgb.txt", s->base);
    if (!tvo_file_exists(path)) {
        tvo_set_err(err, err_size, "%s not found (the TUM RGB-D frame list 'timestamp filename')", path);
        st = TVO_ERR_NOT_FOUND;
        goto fail;
    }
    if (camera != NULL) {
        s->camera = *camera;
    } else if (tvo_tum_camera(s->base, &s->camera) != TVO_OK) {
        tvo_set_err(err, err_size,
                    "%s: a TUM RGB-D folder carries no calibration and its name names no "
                    "freiburg1/2/3 camera: give one",
                    s->base);
        st = TVO_ERR_NOT_FOUND;
        goto fail;
    }
    st = tvo_camera_check(&s->camera);
    if (st != TVO_OK) {
        tvo_set_err(err, err_size, "invalid camera (%s)", tvo_status_str(st));
        goto fail;
    }
    st = tvo_load_frames(s, path, 1, (flags & TVO_EUROC_SKIP_BAD_ROWS) != 0, err, err_size);
    if (st != TVO_OK)
        goto fail;
    st = tvo_check_first_frame(s, &s->camera, &w, &h, err, err_size);
    if (st != TVO_OK)
        goto fail;
    snprintf(path, sizeof path, "%s/groundtruth.txt", s->base);
    if (tvo_file_exists(path)) {
        st = tvo_load_gt_kind(path, 1, &s->gt, &s->ngt, err, err_size);
        if (st != TVO_OK)
            goto fail;
    }
    tvo_rate_from_frames(s);
    *out = s;
    return TVO_OK;
fail:
    tvo_euroc_close(s);
    return st;
}

tvo_status tvo_kitti_parse_calib(const char *text, size_t len, double P0[12], char *err, size_t err_size)
{
    tvo_lines it;
    const char *b, *e;
    if (err != NULL && err_size > 0)
        err[0] = '\0';
    if ((text == NULL && len > 0) || P0 == NULL) {
        tvo_set_err(err, err_size, "NULL argument");
        return TVO_ERR_NULL;
    }
    it.p = text;
    it.stop = text + len;
    it.line = 0;
    while (tvo_next_line(&it, &b, &e)) {
        const char *fb[13], *fe[13];
        double P[12];
        int nf, i;
        tvo_trim(&b, &e);
        if (e - b < 3 || memcmp(b, "P0:", 3) != 0)
            continue;
        if (memchr(b, '\0', (size_t)(e - b)) != NULL) {
            tvo_set_err(err, err_size, "line %d: NUL byte", it.line);
            return TVO_ERR_FORMAT;
        }
        nf = tvo_split_fields(b + 3, e, fb, fe, 13);
        if (nf != 12) {
            tvo_set_err(err, err_size, "line %d: P0: expected 12 numbers, got %d", it.line, nf < 0 ? 0 : nf);
            return TVO_ERR_FORMAT;
        }
        for (i = 0; i < 12; ++i)
            if (!tvo_parse_double(fb[i], fe[i], &P[i])) {
                tvo_set_err(err, err_size, "line %d: P0: bad number '%.*s'", it.line,
                            (int)((fe[i] - fb[i]) > 40 ? 40 : (fe[i] - fb[i])), fb[i]);
                return TVO_ERR_FORMAT;
            }
        if (!(P[0] > 0.0) || !(P[5] > 0.0) || P[1] != 0.0 || P[4] != 0.0 || P[8] != 0.0 || P[9] != 0.0 ||
            P[10] != 1.0 || P[11] != 0.0 || P[3] != 0.0 || P[7] != 0.0) {
            tvo_set_err(err, err_size,
                        "line %d: P0: expected [fx 0 cx 0; 0 fy cy 0; 0 0 1 0] with fx, fy > 0", it.line);
            return TVO_ERR_FORMAT;
        }
        memcpy(P0, P, sizeof P);
        return TVO_OK;
    }
    tvo_set_err(err, err_size, "no 'P0:' line");
    return TVO_ERR_FORMAT;
}

tvo_status tvo_kitti_parse_poses(const char *text, size_t len, tvo_pose *poses, int32_t capacity,
                                 int32_t *count, char *err, size_t err_size)
{
    tvo_lines it;
    const char *b, *e;
    int32_t n = 0;
    tvo_status st = tvo_csv_begin(text, len, capacity, count, &it, err, err_size);
    if (st != TVO_OK)
        return st;
    while (tvo_next_line(&it, &b, &e)) {
        const char *fb[13], *fe[13];
        double v[16];
        tvo_pose T;
        int nf, i;
        tvo_trim(&b, &e);
        if (b == e)
            continue;
        if (memchr(b, '\0', (size_t)(e - b)) != NULL) {
            tvo_set_err(err, err_size, "line %d: NUL byte", it.line);
            return TVO_ERR_FORMAT;
        }
        nf = tvo_split_fields(b, e, fb, fe, 13);
        if (nf != 12) {
            tvo_set_err(err, err_size, "line %d: expected 12 numbers (a 3x4 pose), got %d", it.line,
                        nf < 0 ? 0 : nf);
            return TVO_ERR_FORMAT;
        }
        for (i = 0; i < 12; ++i)
            if (!tvo_parse_double(fb[i], fe[i], &v[i])) {
                tvo_set_err(err, err_size, "line %d: bad number '%.*s'", it.line,
                            (int)((fe[i] - fb[i]) > 40 ? 40 : (fe[i] - fb[i])), fb[i]);
                return TVO_ERR_FORMAT;
            }
        v[12] = v[13] = v[14] = 0.0;
        v[15] = 1.0;
        if (!(fabs(v[3]) <= TVO_EUROC_MAX_COORD && fabs(v[7]) <= TVO_EUROC_MAX_COORD &&
              fabs(v[11]) <= TVO_EUROC_MAX_COORD)) {
            tvo_set_err(err, err_size, "line %d: translation beyond +-%g m", it.line, TVO_EUROC_MAX_COORD);
            return TVO_ERR_FORMAT;
        }
        T = tvo_pose_from_matrix(v);
        {
            double d = T.R[0] * (T.R[4] * T.R[8] - T.R[5] * T.R[7]) -
                    T.R[1] * (T.R[3] * T.R[8] - T.R[5] * T.R[6]) +
                    T.R[2] * (T.R[3] * T.R[7] - T.R[4] * T.R[6]);
            if (!(tvo_rot_orthogonality_error(T.R) < 1e-3) || !(d > 0.0)) {
                tvo_set_err(err, err_size, "line %d: the rotation block is not a rotation", it.line);
                return TVO_ERR_FORMAT;
            }
        }
        tvo_rot_orthonormalize(T.R);
        if (n == INT32_MAX) {
            tvo_set_err(err, err_size, "line %d: too many rows", it.line);
            return TVO_ERR_FORMAT;
        }
        if (poses != NULL && n < capacity)
            poses[n] = T;
        ++n;
    }
    *count = n;
    if (poses != NULL && n > capacity) {
        tvo_set_err(err, err_size, "%d poses do not fit in a capacity of %d", (int)n, (int)capacity);
        return TVO_ERR_NO_MEMORY;
    }
    return TVO_OK;
}

/* times.txt: frame i (the i-th non-blank line) is image_0/%06d.png at that time. *nlines: non-blank
 * lines (the frame count KITTI's poses file must match); *index[k]: the line index of frame k. */
static tvo_status tvo_kitti_load_times(tvo_euroc *s, const char *path, int lenient, int32_t **index,
                                       int32_t *nlines, char *err, size_t err_size)
{
    char *text = NULL;
    size_t len = 0, lines = 1, k;
    tvo_lines it;
    const char *b, *e;
    int32_t idx = 0;
    tvo_status st = tvo_slurp(path, &text, &len, err, err_size);
    if (st != TVO_OK)
        return st;
    for (k = 0; k < len; ++k)
        lines += text[k] == '\n';
    if (lines > 999999) {
        free(text);
        tvo_set_err(err, err_size, "%s: more than 999999 lines", path);
        return TVO_ERR_FORMAT;
    }
    s->frames = (tvo_euroc_frame *)malloc(lines * sizeof *s->frames);
    *index = (int32_t *)calloc(lines, sizeof **index);
    if (s->frames == NULL || *index == NULL) {
        free(text);
        tvo_set_err(err, err_size, "%s: out of memory", path);
        return TVO_ERR_NO_MEMORY;
    }
    it.p = text;
    it.stop = text + len;
    it.line = 0;
    s->nframes = 0;
    while (tvo_next_line(&it, &b, &e)) {
        double t;
        char msg[128];
        tvo_trim(&b, &e);
        if (b == e)
            continue;
        if (memchr(b, '\0', (size_t)(e - b)) != NULL || !tvo_parse_double(b, e, &t) || !(t >= 0.0) ||
            !(t < 9e9)) {
            tvo_set_err(msg, sizeof msg, "line %d: bad time '%.*s' (seconds expected)", it.line,
                        (int)((e - b) > 40 ? 40 : (e - b)),
                        memchr(b, '\0', (size_t)(e - b)) != NULL ? "" : b);
            if (!lenient) {
                tvo_set_err(err, err_size, "%s: %s", path, msg);
                free(text);
                return TVO_ERR_FORMAT;
            }
            tvo_add_bad_row(s, path, it.line, msg);
        } else {
            tvo_euroc_frame *f = &s->frames[s->nframes];
            f->t_ns = (int64_t)llround(t * 1e9);
            snprintf(f->file, sizeof f->file, "%06d.png", (int)idx);
            (*index)[s->nframes++] = idx;
        }
        ++idx;
    }
    free(text);
    *nlines = idx;
    if (s->nframes == 0) {
        tvo_set_err(err, err_size, "%s: no frames", path);
        return TVO_ERR_FORMAT;
    }
    return TVO_OK;
}

tvo_status tvo_kitti_open(tvo_euroc **out, const char *dir, const char *poses, unsigned flags, char *err,
                          size_t err_size)
{
    tvo_euroc *s = NULL;
    char path[2 * TVO_EUROC_PATH + 128], name[TVO_EUROC_PATH];
    char *text = NULL;
    size_t len = 0;
    double P0[12];
    int32_t *index = NULL, nlines = 0, np = 0, w = 0, h = 0, i;
    tvo_pose *T = NULL;
    tvo_status st = tvo_seq_begin(out, dir, &s, err, err_size);
    if (st != TVO_OK)
        return st;
    if (poses != NULL && strlen(poses) >= TVO_EUROC_PATH) {
        tvo_set_err(err, err_size, "poses path too long");
        st = TVO_ERR_ARG;
        goto fail;
    }
    snprintf(s->frame_dir, sizeof s->frame_dir, "%s/image_0", s->base);
    snprintf(path, sizeof path, "%s/times.txt", s->base);
    if (!tvo_file_exists(path)) {
        tvo_set_err(err, err_size, "%s not found (KITTI's frame times, one per line in seconds)", path);
        st = TVO_ERR_NOT_FOUND;
        goto fail;
    }
    st = tvo_kitti_load_times(s, path, (flags & TVO_EUROC_SKIP_BAD_ROWS) != 0, &index, &nlines, err,
                              err_size);
    if (st != TVO_OK)
        goto fail;

    snprintf(path, sizeof path, "%s/calib.txt", s->base);
    if (!tvo_file_exists(path)) {
        tvo_set_err(err, err_size, "%s not found (KITTI's projection matrices, P0 for image_0)", path);
        st = TVO_ERR_NOT_FOUND;
        goto fail;
    }
    st = tvo_slurp(path, &text, &len, err, err_size);
    if (st == TVO_OK) {
        st = tvo_kitti_parse_calib(text, len, P0, err, err_size);
        free(text);
        text = NULL;
        if (st != TVO_OK)
            tvo_prefix_err(err, err_size, path);
    }
    if (st != TVO_OK)
        goto fail;
    st = tvo_check_first_frame(s, NULL, &w, &h, err, err_size);
    if (st != TVO_OK)
        goto fail;
    s->camera = tvo_camera_make_pinhole(w, h, P0[0], P0[5], P0[2], P0[6]);
    st = tvo_camera_check(&s->camera);
    if (st != TVO_OK) {
        tvo_set_err(err, err_size, "%s: invalid camera (%s)", path, tvo_status_str(st));
        goto fail;
    }

    /* poses: given, or DIR/poses.txt, or DIR/../../poses/<name>.txt */
    if (poses != NULL) {
        snprintf(path, sizeof path, "%s", poses);
        if (!tvo_file_exists(path)) {
            tvo_set_err(err, err_size, "%s not found (the KITTI poses file given)", path);
            st = TVO_ERR_NOT_FOUND;
            goto fail;
        }
    } else {
        snprintf(path, sizeof path, "%s/poses.txt", s->base);
        if (!tvo_file_exists(path))
            snprintf(path, sizeof path, "%s/../../poses/%s.txt", s->base,
                     tvo_last_component(s->base, name, sizeof name));
        if (!tvo_file_exists(path))
            path[0] = '\0';
    }
    if (path[0] != '\0') {
        st = tvo_slurp(path, &text, &len, err, err_size);
        if (st == TVO_OK)
            st = tvo_kitti_parse_poses(text, len, NULL, 0, &np, err, err_size);
        if (st == TVO_OK && np != nlines) {
            tvo_set_err(err, err_size, "%d poses for the %d frames of times.txt", (int)np, (int)nlines);
            st = TVO_ERR_FORMAT;
        }
        if (st == TVO_OK) {
            T = (tvo_pose *)malloc((size_t)(np > 0 ? np : 1) * sizeof *T);
            s->gt = (tvo_euroc_gt_row *)malloc((size_t)(np > 0 ? np : 1) * sizeof *s->gt);
            st = (T != NULL && s->gt != NULL) ? tvo_kitti_parse_poses(text, len, T, np, &np, err, err_size)
                                              : TVO_ERR_NO_MEMORY;
        }
        free(text);
        text = NULL;
        if (st != TVO_OK) {
            tvo_prefix_err(err, err_size, path);
            goto fail;
        }
        for (i = 0; i < s->nframes; ++i) {
            tvo_euroc_gt_row *r = &s->gt[i];
            const tvo_pose *p = &T[index[i]];
            if (i > 0 && s->frames[i].t_ns <= s->frames[i - 1].t_ns) {
                tvo_set_err(err, err_size, "%s/times.txt: times not increasing at frame %d", s->base,
                            (int)index[i]);
                st = TVO_ERR_FORMAT;
                goto fail;
            }
            r->t_ns = s->frames[i].t_ns;
            memcpy(r->p, p->t, sizeof r->p);
            tvo_rot_to_quat(p->R, r->q_wxyz);
        }
        s->ngt = s->nframes;
    }
    tvo_rate_from_frames(s);
    free(T);
    free(index);
    *out = s;
    return TVO_OK;
fail:
    free(text);
    free(T);
    free(index);
    tvo_euroc_close(s);
    return st;
}
