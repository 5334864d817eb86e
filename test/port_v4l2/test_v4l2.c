/* SPDX-License-Identifier: Apache-2.0 */
/* V4L2 capture port against a scripted fake device (fake_v4l2.c): every path checks the status
 * and that everything opened/mapped was released. */
#include "tvo_test.h"
#include "fake_v4l2.h"

#include <errno.h>
#include <linux/videodev2.h>

static fake_dev g_dev;
static tvo_v4l2_sys g_sys;
static tvo_v4l2 g_cam;

static int setup(void **state)
{
    (void)state;
    fake_dev_init(&g_dev);
    g_sys = fake_dev_sys(&g_dev);
    memset(&g_cam, 0, sizeof g_cam);
    g_cam.fd = -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    fake_dev_free(&g_dev);
    return 0;
}

static tvo_v4l2_config cfg_default(void)
{
    tvo_v4l2_config c;
    tvo_v4l2_config_default(&c);
    c.device = "/dev/fake0";
    c.sys = &g_sys;
    c.width = 64;
    c.height = 48;
    c.timeout_ms = 100;
    return c;
}

/* Everything acquired was released. */
static void assert_released(void)
{
    assert_int_equal(g_dev.opens, g_dev.closes);
    assert_int_equal(g_dev.mmaps, g_dev.munmaps);
    assert_int_equal(g_dev.fd_open, 0);
    assert_int_equal(g_cam.fd, -1);
    assert_true(g_dev.streamoffs >= g_dev.streamons);
}

static void assert_frame_luma(const tvo_v4l2_frame *f)
{
    uint8_t img[64 * 48];
    int x, y;
    assert_int_equal(tvo_v4l2_frame_luma(f, img, 64), TVO_OK);
    for (y = 0; y < 48; y++) {
        for (x = 0; x < 64; x++) {
            if (img[y * 64 + x] != fake_luma(f->sequence, x, y)) {
                fail_msg("luma mismatch at %d,%d seq %u", x, y, (unsigned)f->sequence);
            }
        }
    }
    if (f->zero_copy) { /* the view in place is the same image */
        for (y = 0; y < 48; y++) {
            assert_memory_equal(f->data + (size_t)y * (size_t)f->stride, img + y * 64, 64);
        }
    }
}

static void test_stream_grey(void **state)
{
    tvo_v4l2_config c = cfg_default();
    const tvo_v4l2_format *fmt;
    int i;
    int64_t last = 0;
    (void)state;
    fake_dev_push(&g_dev, FAKE_FRAME, 10);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    fmt = tvo_v4l2_get_format(&g_cam);
    assert_int_equal(fmt->pixelformat, TVO_V4L2_PIX_GREY); /* preferred over YUYV */
    assert_int_equal(fmt->width, 64);
    assert_int_equal(fmt->height, 48);
    assert_int_equal(fmt->bytesperline, 64);
    assert_int_equal(fmt->fps_num, 30);
    assert_int_equal(fmt->fps_den, 1);
    assert_int_equal(fmt->buffer_count, 4);
    assert_int_equal(g_dev.mmaps, 4);
    assert_int_equal(g_dev.streamons, 1);
    assert_int_equal(g_dev.nonblocking, 1);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "64x48 GREY"));
    for (i = 0; i < 10; i++) {
        tvo_v4l2_frame f;
        assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
        assert_int_equal(f.sequence, (uint32_t)i);
        assert_int_equal(f.width, 64);
        assert_int_equal(f.height, 48);
        assert_int_equal(f.zero_copy, 1);
        assert_int_equal(f.skipped, 0);
        assert_int_equal(f.timestamp_from_driver, 1);
        assert_true(f.timestamp_ns == g_dev.last_ts_ns);
        assert_true(f.timestamp_ns > last);
        last = f.timestamp_ns;
        assert_frame_luma(&f);
        assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    }
    assert_int_equal((int)tvo_v4l2_get_stats(&g_cam)->frames, 10);
    assert_int_equal((int)tvo_v4l2_get_stats(&g_cam)->sequence_gaps, 0);
    tvo_v4l2_close(&g_cam);
    assert_released();
    assert_int_equal(g_dev.reqbufs_zero, 1);
    tvo_v4l2_close(&g_cam); /* twice: harmless */
    assert_int_equal(g_dev.closes, 1);
}

static void test_stream_yuyv_and_rate(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    g_dev.formats[0] = V4L2_PIX_FMT_MJPEG;
    g_dev.formats[1] = V4L2_PIX_FMT_YUYV;
    c.fps = 15;
    fake_dev_push(&g_dev, FAKE_FRAME, 2);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_get_format(&g_cam)->pixelformat, TVO_V4L2_PIX_YUYV);
    assert_int_equal(tvo_v4l2_get_format(&g_cam)->bytesperline, 128);
    assert_int_equal(tvo_v4l2_get_format(&g_cam)->fps_num, 15);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
    assert_int_equal(f.zero_copy, 0);
    assert_int_equal(f.pixelformat, TVO_V4L2_PIX_YUYV);
    assert_frame_luma(&f);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

/* Behaves like libcamera's v4l2-compat.so: mmap only, no read(), S_FMT substitutes, no G/S_PARM,
 * strict mmap arguments. */
static void test_libcamera_compat(void **state)
{
    tvo_v4l2_config c = cfg_default();
    int i;
    (void)state;
    g_dev.compat = 1;
    g_dev.caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_EXT_PIX_FORMAT;
    g_dev.formats[0] = V4L2_PIX_FMT_RGB24;
    g_dev.formats[1] = V4L2_PIX_FMT_YUYV;
    g_dev.formats[2] = V4L2_PIX_FMT_NV12;
    g_dev.nformats = 3;
    g_dev.min_buffers = 6; /* libcamera decides the count itself */
    c.buffer_count = 3;
    fake_dev_push(&g_dev, FAKE_FRAME, 5);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_get_format(&g_cam)->pixelformat, TVO_V4L2_PIX_NV12);
    assert_int_equal(tvo_v4l2_get_format(&g_cam)->fps_num, 0); /* rate unknown */
    assert_int_equal(tvo_v4l2_get_format(&g_cam)->buffer_count, 6);
    assert_int_equal(g_dev.mmaps, 6);
    for (i = 0; i < 5; i++) {
        tvo_v4l2_frame f;
        assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
        assert_int_equal(f.zero_copy, 1);
        assert_frame_luma(&f);
        assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    }
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_compat_substitutes_unwanted_format(void **state)
{
    tvo_v4l2_config c = cfg_default();
    (void)state;
    /* ENUM_FMT is not trusted alone: a layer that lists YUYV but substitutes RGB is refused. */
    g_dev.compat = 1;
    g_dev.formats[0] = V4L2_PIX_FMT_RGB24;
    g_dev.nformats = 1;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "RGB3"));
    assert_released();
}

static void test_eintr_storm(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    g_dev.eintr_per_call = 5; /* every call is interrupted 5 times */
    fake_dev_push(&g_dev, FAKE_POLL_EINTR, 3);
    fake_dev_push(&g_dev, FAKE_DQ_EINTR, 2);
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    if (tvo_v4l2_dequeue(&g_cam, &f) != TVO_OK) {
        fail_msg("%s retries %d polls %d", tvo_v4l2_message(&g_cam), (int)g_cam.stats.retries, g_dev.polls);
    }
    assert_frame_luma(&f);
    assert_true(tvo_v4l2_get_stats(&g_cam)->retries > 5);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_eintr_storm_beyond_bound(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    c.max_retries = 4;
    g_dev.eintr_per_call = 50;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_AGAIN);
    assert_int_equal(g_dev.opens, 0);
    assert_released();

    /* a storm in the stream: bounded, no hang */
    fake_dev_free(&g_dev);
    setup(NULL);
    c = cfg_default();
    c.max_retries = 4;
    fake_dev_push(&g_dev, FAKE_POLL_EINTR, 20);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_ERR_AGAIN);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_eagain(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    fake_dev_push(&g_dev, FAKE_DQ_EAGAIN, 3);
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK); /* non-blocking: retried */
    assert_int_equal((int)tvo_v4l2_get_stats(&g_cam)->retries, 3);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_eagain_blocking_not_retried(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    c.nonblocking = 0;
    fake_dev_push(&g_dev, FAKE_DQ_EAGAIN, 1);
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(g_dev.nonblocking, 0);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_ERR_AGAIN);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK); /* the stream goes on */
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_error_flag_skipped(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    fake_dev_push(&g_dev, FAKE_FRAME_ERROR, 1);
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
    assert_int_equal(f.sequence, 0);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
    assert_int_equal(f.sequence, 2);
    assert_int_equal(f.skipped, 1);
    assert_frame_luma(&f);
    assert_int_equal((int)tvo_v4l2_get_stats(&g_cam)->error_buffers, 1);
    assert_int_equal((int)tvo_v4l2_get_stats(&g_cam)->frames, 2);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    /* the bad buffer went back to the driver: all 4 are queued again */
    assert_int_equal((int)g_dev.qcount, 4);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_short_bytesused_skipped(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    fake_dev_push(&g_dev, FAKE_FRAME_SHORT, 2);
    fake_dev_push(&g_dev, FAKE_DROP, 1);
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
    assert_int_equal(f.skipped, 2);
    assert_int_equal(f.sequence, 3);
    assert_int_equal((int)tvo_v4l2_get_stats(&g_cam)->short_buffers, 2);
    assert_int_equal((int)tvo_v4l2_get_stats(&g_cam)->sequence_gaps, 1);
    assert_frame_luma(&f);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_only_bad_buffers(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    c.max_skips = 5;
    fake_dev_push(&g_dev, FAKE_FRAME_ERROR, 40);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_ERR_IO);
    assert_int_equal((int)tvo_v4l2_get_stats(&g_cam)->error_buffers, 6);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_unplug_poll_hup(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    fake_dev_push(&g_dev, FAKE_FRAME, 2);
    fake_dev_push(&g_dev, FAKE_UNPLUG_HUP, 1);
    fake_dev_push(&g_dev, FAKE_FRAME, 2);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK); /* held while the device goes */
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_ERR_DEVICE_LOST);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "disconnected"));
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_unplug_dqbuf_enodev(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    fake_dev_push(&g_dev, FAKE_UNPLUG_DQ, 1);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_ERR_DEVICE_LOST);
    /* requeue after loss fails cleanly too */
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_format_refused(void **state)
{
    tvo_v4l2_config c = cfg_default();
    (void)state;
    g_dev.sfmt_errno = EINVAL;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "refused"));
    assert_int_equal(g_dev.opens, 1);
    assert_int_equal(g_dev.mmaps, 0);
    assert_released();
}

static void test_format_unsupported(void **state)
{
    tvo_v4l2_config c = cfg_default();
    (void)state;
    g_dev.formats[0] = V4L2_PIX_FMT_MJPEG;
    g_dev.nformats = 1;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "MJPG"));
    assert_released();
}

static void test_fewer_buffers_granted(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f1, f2;
    (void)state;
    c.buffer_count = 8;
    g_dev.max_buffers = 3;
    fake_dev_push(&g_dev, FAKE_FRAME, 4);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_get_format(&g_cam)->buffer_count, 3);
    assert_int_equal(tvo_v4l2_get_format(&g_cam)->buffers_granted, 3);
    assert_int_equal(g_dev.mmaps, 3);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f1), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f2), TVO_OK);
    /* a third held frame would leave the driver nothing to fill */
    {
        tvo_v4l2_frame f3;
        assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f3), TVO_ERR_STATE);
    }
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f1), TVO_OK);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f1), TVO_ERR_STATE); /* twice */
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f2), TVO_OK);
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_one_buffer_refused(void **state)
{
    tvo_v4l2_config c = cfg_default();
    (void)state;
    g_dev.max_buffers = 1;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "granted 1 buffer"));
    assert_int_equal(g_dev.mmaps, 0);
    assert_int_equal(g_dev.reqbufs_zero, 1); /* the one buffer was given back */
    assert_released();
}

static void test_missing_device(void **state)
{
    tvo_v4l2_config c = cfg_default();
    (void)state;
    g_dev.open_errno = ENOENT;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "/dev/fake0"));
    assert_released();
    tvo_v4l2_close(&g_cam); /* close after a failed open: harmless */
    assert_int_equal(g_dev.closes, 0);
}

static void test_busy(void **state)
{
    tvo_v4l2_config c = cfg_default();
    (void)state;
    g_dev.open_errno = EBUSY;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_BUSY);
    assert_released();
    /* opens, but another program owns the buffers */
    g_dev.open_errno = 0;
    g_dev.reqbufs_errno = EBUSY;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_BUSY);
    assert_int_equal(g_dev.opens, 1);
    assert_released();
}

static void test_not_capture(void **state)
{
    tvo_v4l2_config c = cfg_default();
    (void)state;
    g_dev.caps = V4L2_CAP_VIDEO_OUTPUT | V4L2_CAP_STREAMING;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "not a video capture"));
    assert_released();
    g_dev.caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_READWRITE; /* read() only */
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "streaming"));
    assert_released();
}

static void test_stall_timeout(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    (void)state;
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    fake_dev_push(&g_dev, FAKE_POLL_TIMEOUT, 1);
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_ERR_TIMEOUT);
    assert_non_null(strstr(tvo_v4l2_message(&g_cam), "100 ms"));
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK); /* recovers */
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_ERR_TIMEOUT); /* script over: stalled */
    tvo_v4l2_close(&g_cam);
    assert_released();
}

static void test_bad_arguments(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f;
    uint8_t px[16];
    (void)state;
    assert_int_equal(tvo_v4l2_open(NULL, &c), TVO_ERR_NULL);
    assert_int_equal(tvo_v4l2_open(&g_cam, NULL), TVO_ERR_NULL);
    c.device = NULL;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_NULL);
    c = cfg_default();
    c.width = 0;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_SIZE);
    c = cfg_default();
    c.height = TVO_MAX_IMAGE_DIM + 1;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_SIZE);
    c = cfg_default();
    c.buffer_count = 1;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_ARG);
    c.buffer_count = TVO_V4L2_MAX_BUFFERS + 1;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_ARG);
    c = cfg_default();
    c.timeout_ms = 0;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_ARG);
    c = cfg_default();
    c.fps = -1;
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_ARG);
    c = cfg_default();
    c.device = "";
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_ARG);
    {
        tvo_v4l2_sys broken = g_sys;
        broken.poll = NULL;
        c = cfg_default();
        c.sys = &broken;
        assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_ERR_NULL);
    }
    assert_int_equal(g_dev.opens, 0);
    /* on a closed camera */
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_ERR_STATE);
    assert_int_equal(tvo_v4l2_dequeue(NULL, &f), TVO_ERR_NULL);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_ERR_STATE);
    assert_int_equal(tvo_v4l2_requeue(NULL, &f), TVO_ERR_NULL);
    tvo_v4l2_close(NULL);
    tvo_v4l2_config_default(NULL);
    assert_non_null(tvo_v4l2_message(NULL));
    assert_null(tvo_v4l2_get_format(NULL));
    assert_null(tvo_v4l2_get_stats(NULL));
    /* frame_luma checks */
    memset(&f, 0, sizeof f);
    assert_int_equal(tvo_v4l2_frame_luma(NULL, px, 4), TVO_ERR_NULL);
    assert_int_equal(tvo_v4l2_frame_luma(&f, px, 4), TVO_ERR_NULL);
    f.data = px;
    f.width = 4;
    f.height = 2;
    f.stride = 4;
    f.pixelformat = TVO_V4L2_PIX_GREY;
    f.bytesused = 8;
    assert_int_equal(tvo_v4l2_frame_luma(&f, NULL, 4), TVO_ERR_NULL);
    assert_int_equal(tvo_v4l2_frame_luma(&f, px + 8, 3), TVO_ERR_SIZE);
    f.bytesused = 7;
    assert_int_equal(tvo_v4l2_frame_luma(&f, px + 8, 4), TVO_ERR_SIZE);
    f.bytesused = 8;
    f.pixelformat = TVO_V4L2_PIX_YUYV; /* stride 4 < 2 * width */
    assert_int_equal(tvo_v4l2_frame_luma(&f, px + 8, 4), TVO_ERR_SIZE);
    f.pixelformat = TVO_V4L2_FOURCC('M', 'J', 'P', 'G');
    assert_int_equal(tvo_v4l2_frame_luma(&f, px + 8, 4), TVO_ERR_UNSUPPORTED);
    f.pixelformat = TVO_V4L2_PIX_GREY;
    assert_int_equal(tvo_v4l2_frame_luma(&f, px + 8, 4), TVO_OK);
}

static void test_foreign_frame_requeue(void **state)
{
    tvo_v4l2_config c = cfg_default();
    tvo_v4l2_frame f, forged;
    (void)state;
    fake_dev_push(&g_dev, FAKE_FRAME, 1);
    assert_int_equal(tvo_v4l2_open(&g_cam, &c), TVO_OK);
    assert_int_equal(tvo_v4l2_dequeue(&g_cam, &f), TVO_OK);
    forged = f;
    forged.index = 99;
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &forged), TVO_ERR_ARG);
    forged = f;
    forged.data = NULL;
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &forged), TVO_ERR_ARG);
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_OK);
    tvo_v4l2_close(&g_cam);
    assert_released();
    assert_int_equal(tvo_v4l2_requeue(&g_cam, &f), TVO_ERR_STATE); /* after close */
}

/* The default table: real system calls on paths that exist on every Linux machine. */
static void test_libc_table(void **state)
{
    tvo_v4l2_config c;
    tvo_v4l2 cam;
    (void)state;
    tvo_v4l2_config_default(&c);
    assert_null(c.sys);
    assert_non_null(tvo_v4l2_sys_libc());
    c.device = "/nonexistent/tinyvo-video99";
    assert_int_equal(tvo_v4l2_open(&cam, &c), TVO_ERR_NOT_FOUND);
    assert_int_equal(cam.fd, -1);
    c.device = "/dev/null"; /* opens, but VIDIOC_QUERYCAP fails: not a V4L2 device */
    assert_int_equal(tvo_v4l2_open(&cam, &c), TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(tvo_v4l2_message(&cam), "not a V4L2 device"));
    assert_int_equal(cam.fd, -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test_setup_teardown(test_stream_grey, setup, teardown),
            cmocka_unit_test_setup_teardown(test_stream_yuyv_and_rate, setup, teardown),
            cmocka_unit_test_setup_teardown(test_libcamera_compat, setup, teardown),
            cmocka_unit_test_setup_teardown(test_compat_substitutes_unwanted_format, setup, teardown),
            cmocka_unit_test_setup_teardown(test_eintr_storm, setup, teardown),
            cmocka_unit_test_setup_teardown(test_eintr_storm_beyond_bound, setup, teardown),
            cmocka_unit_test_setup_teardown(test_eagain, setup, teardown),
            cmocka_unit_test_setup_teardown(test_eagain_blocking_not_retried, setup, teardown),
            cmocka_unit_test_setup_teardown(test_error_flag_skipped, setup, teardown),
            cmocka_unit_test_setup_teardown(test_short_bytesused_skipped, setup, teardown),
            cmocka_unit_test_setup_teardown(test_only_bad_buffers, setup, teardown),
            cmocka_unit_test_setup_teardown(test_unplug_poll_hup, setup, teardown),
            cmocka_unit_test_setup_teardown(test_unplug_dqbuf_enodev, setup, teardown),
            cmocka_unit_test_setup_teardown(test_format_refused, setup, teardown),
            cmocka_unit_test_setup_teardown(test_format_unsupported, setup, teardown),
            cmocka_unit_test_setup_teardown(test_fewer_buffers_granted, setup, teardown),
            cmocka_unit_test_setup_teardown(test_one_buffer_refused, setup, teardown),
            cmocka_unit_test_setup_teardown(test_missing_device, setup, teardown),
            cmocka_unit_test_setup_teardown(test_busy, setup, teardown),
            cmocka_unit_test_setup_teardown(test_not_capture, setup, teardown),
            cmocka_unit_test_setup_teardown(test_stall_timeout, setup, teardown),
            cmocka_unit_test_setup_teardown(test_bad_arguments, setup, teardown),
            cmocka_unit_test_setup_teardown(test_foreign_frame_requeue, setup, teardown),
            cmocka_unit_test(test_libc_table),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
