/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: Linux V4L2 video capture (mmap streaming), Linux only.
 *
 * Opens a V4L2 capture device, negotiates an 8-bit luma format, maps several driver buffers and
 * streams them. Frames come out as views into the driver's buffers (zero copy for GREY, NV12 and
 * YU12) or copied to a caller buffer (any format, YUYV included).
 *
 *   tvo_v4l2_config cfg;
 *   tvo_v4l2 cam;
 *   tvo_v4l2_config_default(&cfg);
 *   cfg.device = "/dev/video0"; cfg.width = 640; cfg.height = 480; cfg.fps = 30;
 *   if (tvo_v4l2_open(&cam, &cfg) != TVO_OK) { puts(tvo_v4l2_message(&cam)); ... }
 *   for (;;) {
 *       tvo_v4l2_frame f;
 *       tvo_status s = tvo_v4l2_dequeue(&cam, &f);     (waits at most cfg.timeout_ms)
 *       if (s != TVO_OK) break;                         (TIMEOUT, DEVICE_LOST, IO, ...)
 *       ... tvo_v4l2_frame_luma(&f, grey, stride) or use f.data when f.zero_copy ...
 *       tvo_v4l2_requeue(&cam, &f);
 *   }
 *   tvo_v4l2_close(&cam);                               (always; safe after any failure)
 *
 * Formats, in order of preference: GREY; NV12 and YU12 (luma plane first, zero copy); YUYV (luma
 * is every other byte, copied out). The size and frame rate asked for are requests: the driver
 * may grant others, which tvo_v4l2_get_format() reports. Interlaced formats are refused.
 *
 * Errors: every function returns tvo_status; tvo_v4l2_message() gives a one-line English reason
 * ("open /dev/video0: No such file or directory"). errno mapping: ENOENT/ENODEV/ENXIO at open ->
 * TVO_ERR_NOT_FOUND; EBUSY -> TVO_ERR_BUSY; ENODEV during streaming, POLLHUP -> TVO_ERR_DEVICE_LOST;
 * a silent device -> TVO_ERR_TIMEOUT; a device that is not a streaming capture device or offers
 * no usable format -> TVO_ERR_UNSUPPORTED; anything else -> TVO_ERR_IO. Only EINTR (and EAGAIN
 * when opened non-blocking) is retried, at most cfg.max_retries times per call.
 *
 * Bad buffers: a buffer the driver flags V4L2_BUF_FLAG_ERROR, or whose bytesused is shorter than
 * one image, is counted (tvo_v4l2_stats), re-queued and skipped; dequeue then waits for the next.
 * More than cfg.max_skips bad buffers in a row -> TVO_ERR_IO.
 *
 * libcamera: cameras driven only by libcamera are reached with `libcamerify prog ...`, which
 * preloads v4l2-compat.so. This port calls the libc open/close/ioctl/mmap/munmap entry points
 * (through the default tvo_v4l2_sys table) so that works when the program is dynamically linked.
 *
 * Threads: one tvo_v4l2 per thread; no global state. No allocation: tvo_v4l2 is a plain struct
 * the caller owns (about 1 KB). */
#ifndef TINYVO_PORT_V4L2_H
#define TINYVO_PORT_V4L2_H

#include <stddef.h>
#include <stdint.h>
#include "tinyvo/export.h"
#include "tinyvo/types.h" /* tvo_status, TVO_MAX_IMAGE_DIM */

#ifdef __cplusplus
extern "C" {
#endif

/* Most driver buffers mapped (more granted ones are left unused). */
#define TVO_V4L2_MAX_BUFFERS 16

/* V4L2 four-character codes, same values as <linux/videodev2.h>. */
#define TVO_V4L2_FOURCC(a, b, c, d) \
    ((uint32_t)(a) | ((uint32_t)(b) << 8) | ((uint32_t)(c) << 16) | ((uint32_t)(d) << 24))
#define TVO_V4L2_PIX_GREY TVO_V4L2_FOURCC('G', 'R', 'E', 'Y')
#define TVO_V4L2_PIX_YUYV TVO_V4L2_FOURCC('Y', 'U', 'Y', 'V')
#define TVO_V4L2_PIX_NV12 TVO_V4L2_FOURCC('N', 'V', '1', '2')
#define TVO_V4L2_PIX_YU12 TVO_V4L2_FOURCC('Y', 'U', '1', '2')

/* The system calls the port makes, so tests can script a fake device. Each entry behaves like
 * its libc namesake: returns -1 (or TVO_V4L2_MAP_FAILED for mmap) and sets errno on failure.
 * ctx is passed through untouched. poll waits for one fd and writes the returned events.
 * tvo_v4l2_sys_libc() returns the default table (libc open/close/ioctl/mmap/munmap/poll). */
typedef struct tvo_v4l2_sys {
    void *ctx;
    int (*open)(void *ctx, const char *path, int flags);
    int (*close)(void *ctx, int fd);
    int (*ioctl)(void *ctx, int fd, unsigned long request, void *arg);
    void *(*mmap)(void *ctx, size_t length, int prot, int flags, int fd, int64_t offset);
    int (*munmap)(void *ctx, void *addr, size_t length);
    int (*poll)(void *ctx, int fd, short events, int timeout_ms, short *revents);
} tvo_v4l2_sys;

#define TVO_V4L2_MAP_FAILED ((void *)-1)

TVO_API const tvo_v4l2_sys *tvo_v4l2_sys_libc(void);

typedef struct tvo_v4l2_config {
    const char *device; /* device path, e.g. "/dev/video0"; must stay valid during open */
    int32_t width;      /* requested size in pixels, 1..TVO_MAX_IMAGE_DIM (default 640x480) */
    int32_t height;
    int32_t fps;             /* requested frames per second, 0 = driver default (default 30) */
    uint32_t buffer_count;   /* buffers asked for, 2..TVO_V4L2_MAX_BUFFERS (default 4); the driver
                                may grant fewer (>= 2 accepted) or more (extra ones unused) */
    int32_t timeout_ms;      /* longest wait for one frame in dequeue, 1..600000 (default 2000) */
    uint32_t max_retries;    /* EINTR/EAGAIN retries per call, bounded (default 64) */
    uint32_t max_skips;      /* bad buffers skipped in a row before TVO_ERR_IO (default 16) */
    int nonblocking;         /* open with O_NONBLOCK (default 1) */
    const tvo_v4l2_sys *sys; /* system call table; NULL = tvo_v4l2_sys_libc() */
} tvo_v4l2_config;

/* What the driver granted. */
typedef struct tvo_v4l2_format {
    int32_t width; /* pixels */
    int32_t height;
    int32_t bytesperline; /* bytes per row of the first plane */
    uint32_t sizeimage;   /* bytes of one full frame as the driver reports it */
    uint32_t pixelformat; /* TVO_V4L2_PIX_* */
    int32_t fps_num;      /* granted rate fps_num/fps_den frames per second; 0/1 = unknown */
    int32_t fps_den;
    uint32_t buffer_count;   /* buffers mapped and streaming, 2..TVO_V4L2_MAX_BUFFERS */
    int32_t buffers_granted; /* what VIDIOC_REQBUFS returned (may exceed buffer_count) */
} tvo_v4l2_format;

typedef struct tvo_v4l2_stats {
    uint64_t frames;        /* good frames delivered */
    uint64_t error_buffers; /* buffers flagged V4L2_BUF_FLAG_ERROR, skipped */
    uint64_t short_buffers; /* buffers with bytesused below one image, skipped */
    uint64_t sequence_gaps; /* frames the driver dropped, from gaps in buffer sequence numbers */
    uint64_t retries;       /* EINTR / EAGAIN retries */
} tvo_v4l2_stats;

typedef struct tvo_v4l2_frame {
    const uint8_t *data; /* first byte of the driver buffer (read-only; valid until requeue) */
    uint32_t bytesused;  /* bytes the driver filled */
    int32_t width;       /* pixels */
    int32_t height;
    int32_t stride;            /* bytes per row of the first plane */
    uint32_t pixelformat;      /* TVO_V4L2_PIX_* */
    int zero_copy;             /* 1: data is an 8-bit luma image (width, height, stride) as is */
    int64_t timestamp_ns;      /* capture time, CLOCK_MONOTONIC nanoseconds */
    int timestamp_from_driver; /* 1: driver's monotonic buffer stamp; 0: taken at dequeue */
    uint32_t sequence;         /* driver frame counter */
    uint32_t skipped;          /* bad buffers skipped just before this frame */
    uint32_t index;            /* driver buffer index (private to requeue) */
} tvo_v4l2_frame;

/* Capture state. Fields are private; the caller only owns the storage. */
typedef struct tvo_v4l2 {
    tvo_v4l2_sys sys;
    int fd;
    int streaming;
    int reqbufs_done;
    int nonblocking;
    int have_sequence;
    uint32_t last_sequence;
    int32_t timeout_ms;
    uint32_t max_retries;
    uint32_t max_skips;
    uint32_t nbufs;
    uint32_t held;
    struct {
        void *start;
        size_t length;
        int queued;
    } buf[TVO_V4L2_MAX_BUFFERS];
    tvo_v4l2_format format;
    tvo_v4l2_stats stats;
    char message[160];
} tvo_v4l2;

/* Fill cfg with the defaults above (device "/dev/video0"). */
TVO_API void tvo_v4l2_config_default(tvo_v4l2_config *cfg);

/* Open, check capabilities (capture + streaming), set the format and rate, request and map
 * buffers, queue them and start streaming. On failure everything acquired is released, cam is
 * left closed and tvo_v4l2_message(cam) tells why. TVO_ERR_NULL / TVO_ERR_ARG for bad arguments. */
TVO_API tvo_status tvo_v4l2_open(tvo_v4l2 *cam, const tvo_v4l2_config *cfg);

/* Wait (poll, at most timeout_ms per attempt) for the next good frame and hand its buffer to the
 * caller. At most buffer_count - 1 frames may be held at once (TVO_ERR_STATE beyond). */
TVO_API tvo_status tvo_v4l2_dequeue(tvo_v4l2 *cam, tvo_v4l2_frame *frame);

/* Give a dequeued buffer back to the driver. */
TVO_API tvo_status tvo_v4l2_requeue(tvo_v4l2 *cam, const tvo_v4l2_frame *frame);

/* Copy the luma of a frame to dst (width x height bytes, rows dst_stride >= width apart).
 * Cost: one pass over the image. */
TVO_API tvo_status tvo_v4l2_frame_luma(const tvo_v4l2_frame *frame, uint8_t *dst, int32_t dst_stride);

/* Stop streaming, unmap, close. Safe on a closed or failed camera and when called twice.
 * Errors while stopping a lost device are ignored; the fd is always closed. */
TVO_API void tvo_v4l2_close(tvo_v4l2 *cam);

/* Granted format (valid after a successful open), counters, last error message (never NULL). */
TVO_API const tvo_v4l2_format *tvo_v4l2_get_format(const tvo_v4l2 *cam);
TVO_API const tvo_v4l2_stats *tvo_v4l2_get_stats(const tvo_v4l2 *cam);
TVO_API const char *tvo_v4l2_message(const tvo_v4l2 *cam);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_PORT_V4L2_H */
