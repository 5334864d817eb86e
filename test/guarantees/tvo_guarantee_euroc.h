/* SPDX-License-Identifier: Apache-2.0 */
/* The shared EuRoC sample folders as input to the guarantee tests that link the port layer
 * (test_no_alloc, test_repeat, test_stack): open $TVO_DATA_DIR/euroc/<name> (cam0) through the port's
 * reader and decode its first frames into one heap block, before anything is measured. */
#ifndef TVO_GUARANTEE_EUROC_H
#define TVO_GUARANTEE_EUROC_H

#include "tvo_test.h"

#include <stdlib.h>

#include "tinyvo/port/euroc.h"

typedef struct tvo_g_frames {
    tvo_euroc *seq;
    const tvo_camera *cam; /* owned by seq */
    uint8_t *pix;          /* n frames of fsz bytes, back to back */
    int64_t *t;            /* n timestamps, ns */
    size_t fsz;
    int32_t n;
} tvo_g_frames;

static inline void tvo_g_frames_free(tvo_g_frames *f)
{
    free(f->pix);
    free(f->t);
    if (f->seq != NULL)
        tvo_euroc_close(f->seq);
    f->pix = NULL;
    f->t = NULL;
    f->seq = NULL;
}

/* Loads at most max_frames frames of the folder euroc/<name> under TVO_DATA_DIR. Returns 1 when loaded; 0
 * after skipping the current test (cmocka skip with the reason) when TVO_DATA_DIR is unset or the folder
 * cannot be opened. A frame that opens but does not decode fails the test. */
static inline int tvo_g_frames_load(tvo_g_frames *f, const char *name, int32_t max_frames)
{
    char dir[1024], err[256];
    const char *data = tvo_test_data_dir();
    f->seq = NULL;
    f->pix = NULL;
    f->t = NULL;
    f->n = 0;
    if (data == NULL) {
        TVO_SKIP("TVO_DATA_DIR not set");
        return 0;
    }
    snprintf(dir, sizeof dir, "%s/euroc/%s", data, name);
    if (tvo_euroc_open(&f->seq, dir, "cam0", err, sizeof err) != TVO_OK) {
        fprintf(stderr, "SKIP %s: %s\n", name, err);
        f->seq = NULL;
        skip();
        return 0;
    }
    f->cam = tvo_euroc_camera(f->seq);
    f->n = tvo_euroc_frame_count(f->seq);
    if (f->n > max_frames)
        f->n = max_frames;
    assert_true(f->n > 0);
    f->fsz = (size_t)f->cam->width * (size_t)f->cam->height;
    f->pix = malloc(f->fsz * (size_t)f->n);
    f->t = malloc(sizeof(int64_t) * (size_t)f->n);
    assert_non_null(f->pix);
    assert_non_null(f->t);
    for (int32_t i = 0; i < f->n; ++i) {
        assert_int_equal(tvo_euroc_read_frame(f->seq, i, f->pix + (size_t)i * f->fsz, f->fsz), TVO_OK);
        f->t[i] = tvo_euroc_frame_time(f->seq, i);
    }
    return 1;
}

#endif
