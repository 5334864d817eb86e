/* SPDX-License-Identifier: Apache-2.0 */
/* Scripted fake V4L2 device: see fake_v4l2.h. */
#include "fake_v4l2.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/time.h>
#include <linux/videodev2.h>

#define FAKE_OFFSET_STEP 0x100000u /* non-compat drivers: buffer i at offset i * 1 MiB */

void fake_dev_init(fake_dev *d)
{
    memset(d, 0, sizeof *d);
    d->caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_READWRITE;
    d->formats[0] = V4L2_PIX_FMT_YUYV;
    d->formats[1] = V4L2_PIX_FMT_GREY;
    d->nformats = 2;
    d->max_buffers = 8;
    d->min_buffers = 0;
    d->width = 64;
    d->height = 48;
    d->fps = 30;
    d->t0_ns = 1000000000LL * 5000; /* boot + 5000 s */
}

void fake_dev_push(fake_dev *d, fake_step s, int n)
{
    int i;
    for (i = 0; i < n && d->nscript < FAKE_MAX_STEPS; i++) {
        d->script[d->nscript++] = s;
    }
}

uint8_t fake_luma(uint32_t seq, int x, int y)
{
    return (uint8_t)((unsigned)x * 3u + (unsigned)y * 7u + seq * 11u);
}

static int fail(int e)
{
    errno = e;
    return -1;
}

/* Consumes one pending EINTR if a storm is configured. */
static int eintr_now(fake_dev *d, int kind)
{
    int *left = &d->eintr_left[kind]; /* one storm per kind of call (open, ioctl, poll) */
    if (d->eintr_per_call <= 0) {
        return 0;
    }
    if (*left == 0) {
        *left = d->eintr_per_call + 1; /* a new call starts a new storm */
    }
    if (*left > 1) {
        (*left)--;
        return 1;
    }
    *left = 0; /* the last one: this attempt goes through */
    return 0;
}

static void free_bufs(fake_dev *d)
{
    uint32_t i;
    for (i = 0; i < d->nbufs; i++) {
        free(d->mem[i]);
        d->mem[i] = NULL;
        d->queued[i] = 0;
    }
    d->nbufs = 0;
    d->qhead = d->qcount = 0;
}

void fake_dev_free(fake_dev *d)
{
    free_bufs(d);
}

static int f_open(void *ctx, const char *path, int flags)
{
    fake_dev *d = (fake_dev *)ctx;
    (void)path;
    if (eintr_now(d, 0)) {
        return fail(EINTR);
    }
    if (d->open_errno != 0) {
        return fail(d->open_errno);
    }
    if (d->fd_open) {
        return fail(EBUSY);
    }
    d->opens++;
    d->fd_open = 1;
    d->nonblocking = (flags & O_NONBLOCK) != 0;
    d->fmt = V4L2_PIX_FMT_YUYV;
    d->bpl = (uint32_t)d->width * 2u;
    d->sizeimage = d->bpl * (uint32_t)d->height;
    return FAKE_FD;
}

static int f_close(void *ctx, int fd)
{
    fake_dev *d = (fake_dev *)ctx;
    if (fd != FAKE_FD || !d->fd_open) {
        return fail(EBADF);
    }
    d->closes++;
    d->fd_open = 0;
    d->streaming = 0;
    return 0;
}

static int supported(const fake_dev *d, uint32_t f)
{
    int i;
    for (i = 0; i < d->nformats; i++) {
        if (d->formats[i] == f) {
            return 1;
        }
    }
    return 0;
}

static void set_fmt(fake_dev *d, uint32_t f)
{
    d->fmt = f;
    d->bpl = (uint32_t)d->width * (f == V4L2_PIX_FMT_YUYV ? 2u : 1u);
    if (!d->compat && f == V4L2_PIX_FMT_GREY) {
        d->bpl = ((uint32_t)d->width + 15u) & ~15u; /* padded rows, as many drivers do */
    }
    if (f == V4L2_PIX_FMT_NV12 || f == V4L2_PIX_FMT_YUV420) {
        d->sizeimage = d->bpl * (uint32_t)d->height * 3u / 2u;
    } else {
        d->sizeimage = d->bpl * (uint32_t)d->height;
    }
}

static void fill_frame(fake_dev *d, uint32_t idx)
{
    uint8_t *p = d->mem[idx];
    int x, y;
    memset(p, 0x80, d->sizeimage);
    for (y = 0; y < d->height; y++) {
        for (x = 0; x < d->width; x++) {
            if (d->fmt == V4L2_PIX_FMT_YUYV) {
                p[(size_t)y * d->bpl + 2u * (size_t)x] = fake_luma(d->seq, x, y);
            } else {
                p[(size_t)y * d->bpl + (size_t)x] = fake_luma(d->seq, x, y);
            }
        }
    }
}

static int current_step(const fake_dev *d)
{
    return d->pos < d->nscript ? (int)d->script[d->pos] : 0;
}

static int dqbuf(fake_dev *d, struct v4l2_buffer *b)
{
    int step;
    uint32_t idx;
    if (!d->streaming) {
        return fail(EINVAL);
    }
    for (;;) {
        step = current_step(d);
        if (step == FAKE_DROP) { /* a frame the driver lost: only the sequence moves on */
            d->seq++;
            d->pos++;
            continue;
        }
        break;
    }
    if (step == FAKE_DQ_EINTR) {
        d->pos++;
        return fail(EINTR);
    }
    if (step == FAKE_DQ_EAGAIN) {
        d->pos++;
        return fail(EAGAIN);
    }
    if (step == FAKE_UNPLUG_DQ) {
        d->pos++;
        d->lost = 1;
        return fail(ENODEV);
    }
    if (step != FAKE_FRAME && step != FAKE_FRAME_ERROR && step != FAKE_FRAME_SHORT) {
        return fail(EAGAIN); /* nothing ready (a real blocking driver would sleep) */
    }
    if (d->qcount == 0) {
        return fail(EAGAIN);
    }
    d->pos++;
    idx = d->qorder[d->qhead];
    d->qhead = (d->qhead + 1u) % FAKE_MAX_BUFS;
    d->qcount--;
    d->queued[idx] = 0;
    fill_frame(d, idx);
    memset(b, 0, sizeof *b);
    b->index = idx;
    b->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b->memory = V4L2_MEMORY_MMAP;
    b->length = d->sizeimage;
    b->bytesused = step == FAKE_FRAME_SHORT ? d->sizeimage / 2u : d->sizeimage;
    b->flags = V4L2_BUF_FLAG_DONE | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC |
            (step == FAKE_FRAME_ERROR ? V4L2_BUF_FLAG_ERROR : 0u);
    b->field = V4L2_FIELD_NONE;
    b->sequence = d->seq;
    d->last_ts_ns = d->t0_ns + (int64_t)d->seq * 33333000LL; /* whole microseconds */
    b->timestamp.tv_sec = (time_t)(d->last_ts_ns / 1000000000LL);
    b->timestamp.tv_usec = (suseconds_t)((d->last_ts_ns % 1000000000LL) / 1000LL);
    d->last_seq = d->seq;
    d->seq++;
    d->dqbufs++;
    return 0;
}

static int f_ioctl(void *ctx, int fd, unsigned long req, void *arg)
{
    fake_dev *d = (fake_dev *)ctx;
    if (fd != FAKE_FD || !d->fd_open) {
        return fail(EBADF);
    }
    if (eintr_now(d, 1)) {
        return fail(EINTR);
    }
    if (req == VIDIOC_STREAMOFF) {
        d->streamoffs++; /* counts attempts: on a lost device it fails, which is fine */
    }
    if (d->lost) {
        return fail(ENODEV);
    }
    switch (req) {
    case VIDIOC_QUERYCAP: {
        struct v4l2_capability *c = (struct v4l2_capability *)arg;
        memset(c, 0, sizeof *c);
        memcpy(c->driver, d->compat ? "libcamera" : "fake", d->compat ? 10 : 5);
        c->device_caps = d->caps;
        c->capabilities = d->caps | V4L2_CAP_DEVICE_CAPS;
        return 0;
    }
    case VIDIOC_ENUM_FMT: {
        struct v4l2_fmtdesc *f = (struct v4l2_fmtdesc *)arg;
        if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || f->index >= (uint32_t)d->nformats) {
            return fail(EINVAL);
        }
        f->pixelformat = d->formats[f->index];
        return 0;
    }
    case VIDIOC_S_FMT: {
        struct v4l2_format *f = (struct v4l2_format *)arg;
        uint32_t want = f->fmt.pix.pixelformat;
        if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) {
            return fail(EINVAL);
        }
        if (d->sfmt_errno != 0) {
            return fail(d->sfmt_errno);
        }
        if (d->nbufs > 0) {
            return fail(EBUSY);
        }
        set_fmt(d, supported(d, want) ? want : d->formats[0]); /* adjust, never refuse */
        f->fmt.pix.width = (uint32_t)d->width;
        f->fmt.pix.height = (uint32_t)d->height;
        f->fmt.pix.pixelformat = d->fmt;
        f->fmt.pix.field = V4L2_FIELD_NONE;
        f->fmt.pix.bytesperline = d->bpl;
        f->fmt.pix.sizeimage = d->sizeimage;
        return 0;
    }
    case VIDIOC_G_PARM:
    case VIDIOC_S_PARM: {
        struct v4l2_streamparm *p = (struct v4l2_streamparm *)arg;
        uint32_t fps = (uint32_t)d->fps;
        if (d->compat) {
            return fail(ENOTTY);
        }
        if (req == VIDIOC_S_PARM && p->parm.capture.timeperframe.numerator == 1 &&
            p->parm.capture.timeperframe.denominator > 0 && p->parm.capture.timeperframe.denominator < fps) {
            fps = p->parm.capture.timeperframe.denominator;
        }
        memset(&p->parm, 0, sizeof p->parm);
        p->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
        p->parm.capture.timeperframe.numerator = 1;
        p->parm.capture.timeperframe.denominator = fps;
        return 0;
    }
    case VIDIOC_REQBUFS: {
        struct v4l2_requestbuffers *r = (struct v4l2_requestbuffers *)arg;
        uint32_t n, i;
        if (r->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || r->memory != V4L2_MEMORY_MMAP) {
            return fail(EINVAL);
        }
        for (i = 0; i < d->nbufs; i++) {
            if (d->mapped[i]) {
                return fail(EBUSY); /* the kernel refuses to free mapped buffers */
            }
        }
        if (r->count == 0) {
            d->reqbufs_zero++;
            d->streaming = 0;
            free_bufs(d);
            return 0;
        }
        if (d->reqbufs_errno != 0) {
            return fail(d->reqbufs_errno);
        }
        free_bufs(d);
        n = r->count < d->max_buffers ? r->count : d->max_buffers;
        if (n < d->min_buffers) {
            n = d->min_buffers;
        }
        if (n > FAKE_MAX_BUFS) {
            n = FAKE_MAX_BUFS;
        }
        for (i = 0; i < n; i++) {
            d->mem[i] = (uint8_t *)calloc(1, d->sizeimage);
            if (d->mem[i] == NULL) {
                return fail(ENOMEM);
            }
        }
        d->nbufs = n;
        r->count = n;
        return 0;
    }
    case VIDIOC_QUERYBUF: {
        struct v4l2_buffer *b = (struct v4l2_buffer *)arg;
        uint32_t i = b->index;
        if (i >= d->nbufs) {
            return fail(EINVAL);
        }
        memset(b, 0, sizeof *b);
        b->index = i;
        b->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b->memory = V4L2_MEMORY_MMAP;
        b->length = d->sizeimage;
        b->m.offset = d->compat ? i * d->sizeimage : i * FAKE_OFFSET_STEP;
        b->flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
        return 0;
    }
    case VIDIOC_QBUF: {
        struct v4l2_buffer *b = (struct v4l2_buffer *)arg;
        if (b->index >= d->nbufs || b->memory != V4L2_MEMORY_MMAP || d->queued[b->index]) {
            return fail(EINVAL);
        }
        d->queued[b->index] = 1;
        d->qorder[(d->qhead + d->qcount) % FAKE_MAX_BUFS] = b->index;
        d->qcount++;
        return 0;
    }
    case VIDIOC_DQBUF:
        return dqbuf(d, (struct v4l2_buffer *)arg);
    case VIDIOC_STREAMON:
        if (d->nbufs == 0) {
            return fail(EINVAL);
        }
        d->streaming = 1;
        d->streamons++;
        return 0;
    case VIDIOC_STREAMOFF: {
        uint32_t i;
        d->streaming = 0;
        for (i = 0; i < d->nbufs; i++) {
            d->queued[i] = 0;
        }
        d->qhead = d->qcount = 0;
        return 0;
    }
    default:
        return fail(ENOTTY);
    }
}

static void *f_mmap(void *ctx, size_t length, int prot, int flags, int fd, int64_t offset)
{
    fake_dev *d = (fake_dev *)ctx;
    uint32_t i;
    (void)flags;
    if (fd != FAKE_FD || !d->fd_open) {
        errno = EBADF;
        return TVO_V4L2_MAP_FAILED;
    }
    if (d->lost) {
        errno = ENODEV;
        return TVO_V4L2_MAP_FAILED;
    }
    if (d->compat && prot != (PROT_READ | PROT_WRITE)) {
        errno = EINVAL;
        return TVO_V4L2_MAP_FAILED;
    }
    for (i = 0; i < d->nbufs; i++) {
        int64_t off = d->compat ? (int64_t)i * d->sizeimage : (int64_t)i * FAKE_OFFSET_STEP;
        if (off == offset) {
            if (length != d->sizeimage || d->mapped[i]) {
                errno = EINVAL;
                return TVO_V4L2_MAP_FAILED;
            }
            d->mapped[i] = 1;
            d->mmaps++;
            return d->mem[i];
        }
    }
    errno = EINVAL;
    return TVO_V4L2_MAP_FAILED;
}

static int f_munmap(void *ctx, void *addr, size_t length)
{
    fake_dev *d = (fake_dev *)ctx;
    uint32_t i;
    for (i = 0; i < d->nbufs; i++) {
        if (d->mem[i] == addr && d->mapped[i]) {
            if (length != d->sizeimage) {
                return fail(EINVAL);
            }
            d->mapped[i] = 0;
            d->munmaps++;
            return 0;
        }
    }
    return fail(EINVAL);
}

static int f_poll(void *ctx, int fd, short events, int timeout_ms, short *revents)
{
    fake_dev *d = (fake_dev *)ctx;
    int step;
    (void)events;
    (void)timeout_ms;
    *revents = 0;
    if (fd != FAKE_FD || !d->fd_open) {
        *revents = POLLNVAL;
        return 1;
    }
    if (eintr_now(d, 2)) {
        return fail(EINTR);
    }
    d->polls++;
    if (d->lost) {
        *revents = POLLERR | POLLHUP;
        return 1;
    }
    step = current_step(d);
    switch (step) {
    case FAKE_POLL_EINTR:
        d->pos++;
        return fail(EINTR);
    case FAKE_POLL_TIMEOUT:
        d->pos++;
        return 0;
    case FAKE_UNPLUG_HUP:
        d->pos++;
        d->lost = 1;
        *revents = POLLERR | POLLHUP;
        return 1;
    case 0:
        return 0; /* end of script: the stream stalls */
    default:
        if (!d->streaming) {
            *revents = POLLERR;
            return 1;
        }
        if ((step == FAKE_FRAME || step == FAKE_FRAME_ERROR || step == FAKE_FRAME_SHORT ||
             step == FAKE_DROP) &&
            d->qcount == 0) {
            return 0; /* no buffer queued: nothing can complete */
        }
        *revents = POLLIN;
        return 1;
    }
}

tvo_v4l2_sys fake_dev_sys(fake_dev *d)
{
    tvo_v4l2_sys s;
    s.ctx = d;
    s.open = f_open;
    s.close = f_close;
    s.ioctl = f_ioctl;
    s.mmap = f_mmap;
    s.munmap = f_munmap;
    s.poll = f_poll;
    return s;
}
