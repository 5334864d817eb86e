/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: V4L2 mmap-streaming capture. See tinyvo/port/v4l2.h. */
#define _POSIX_C_SOURCE 200809L

#include "tinyvo/port/v4l2.h"
#include "tinyvo/options.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>
#include <linux/videodev2.h>

/* ---- default system call table: the libc entry points (so LD_PRELOAD shims such as libcamera's
 * v4l2-compat.so see every call) ------------------------------------------------------------- */

static int libc_open(void *ctx, const char *path, int flags)
{
    (void)ctx;
    return open(path, flags);
}

static int libc_close(void *ctx, int fd)
{
    (void)ctx;
    return close(fd);
}

static int libc_ioctl(void *ctx, int fd, unsigned long request, void *arg)
{
    (void)ctx;
    return ioctl(fd, request, arg);
}

static void *libc_mmap(void *ctx, size_t length, int prot, int flags, int fd, int64_t offset)
{
    void *p;
    (void)ctx;
    p = mmap(NULL, length, prot, flags, fd, (off_t)offset);
    return p == MAP_FAILED ? TVO_V4L2_MAP_FAILED : p;
}

static int libc_munmap(void *ctx, void *addr, size_t length)
{
    (void)ctx;
    return munmap(addr, length);
}

static int libc_poll(void *ctx, int fd, short events, int timeout_ms, short *revents)
{
    struct pollfd p;
    int r;
    (void)ctx;
    p.fd = fd;
    p.events = events;
    p.revents = 0;
    r = poll(&p, 1, timeout_ms);
    *revents = p.revents;
    return r;
}

static const tvo_v4l2_sys tvo_v4l2_libc_table = {NULL,      libc_open,   libc_close, libc_ioctl,
                                                 libc_mmap, libc_munmap, libc_poll};

const tvo_v4l2_sys *tvo_v4l2_sys_libc(void)
{
    return &tvo_v4l2_libc_table;
}

/* ---- helpers ------------------------------------------------------------------------------ */

static void set_msg(tvo_v4l2 *cam, const char *what, int err)
{
    if (err != 0) {
        snprintf(cam->message, sizeof cam->message, "%s: %s", what, strerror(err));
    } else {
        snprintf(cam->message, sizeof cam->message, "%s", what);
    }
}

static void fourcc_str(uint32_t f, char out[5])
{
    int i;
    for (i = 0; i < 4; i++) {
        char c = (char)((f >> (8 * i)) & 0xffu);
        out[i] = (c >= 32 && c < 127) ? c : '?';
    }
    out[4] = '\0';
}

/* errno of a failed call, never 0. */
static int last_errno(void)
{
    return errno != 0 ? errno : EIO;
}

/* errno -> status for calls made on an open, configured device. */
static tvo_status map_errno(int err)
{
    switch (err) {
    case ENODEV:
    case ENXIO:
        return TVO_ERR_DEVICE_LOST;
    case EBUSY:
        return TVO_ERR_BUSY;
    case EINTR:
    case EAGAIN:
        return TVO_ERR_AGAIN;
    default:
        return TVO_ERR_IO;
    }
}

/* ioctl, retrying EINTR at most max_retries times. Returns 0 or the errno. */
static int xioctl(tvo_v4l2 *cam, unsigned long request, void *arg)
{
    uint32_t tries = 0;
    for (;;) {
        int r;
        errno = 0;
        r = cam->sys.ioctl(cam->sys.ctx, cam->fd, request, arg);
        if (r != -1) {
            return 0;
        }
        if (errno == EINTR && tries < cam->max_retries) {
            tries++;
            cam->stats.retries++;
            continue;
        }
        return last_errno();
    }
}

static tvo_status fail(tvo_v4l2 *cam, const char *what, int err)
{
    char buf[96];
    snprintf(buf, sizeof buf, "%s", what);
    set_msg(cam, buf, err);
    if (err == EINTR) {
        snprintf(cam->message + strlen(cam->message), sizeof cam->message - strlen(cam->message),
                 " (after %u retries)", (unsigned)cam->max_retries);
    }
    return map_errno(err);
}

/* Bytes per pixel of the first plane. */
static int32_t luma_step(uint32_t pixelformat)
{
    return pixelformat == TVO_V4L2_PIX_YUYV ? 2 : 1;
}

/* Smallest bytesused holding the whole luma image. */
static uint64_t luma_bytes(int32_t width, int32_t height, int32_t bpl, uint32_t pixelformat)
{
    return (uint64_t)bpl * (uint64_t)(height - 1) + (uint64_t)width * (uint64_t)luma_step(pixelformat);
}

static int64_t now_ns(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return 0;
    }
    return (int64_t)ts.tv_sec * 1000000000 + (int64_t)ts.tv_nsec;
}

/* ---- open steps ---------------------------------------------------------------------------- */

static tvo_status check_caps(tvo_v4l2 *cam, const char *dev)
{
    struct v4l2_capability cap;
    uint32_t caps;
    int e;
    char buf[96];
    memset(&cap, 0, sizeof cap);
    e = xioctl(cam, VIDIOC_QUERYCAP, &cap);
    /* ENOSYS: an emulator (qemu-user) that does not forward V4L2 ioctls */
    if (e == ENOTTY || e == EINVAL || e == ENOSYS) {
        snprintf(buf, sizeof buf, "%s is not a V4L2 device (VIDIOC_QUERYCAP)", dev);
        set_msg(cam, buf, e);
        return TVO_ERR_UNSUPPORTED;
    }
    if (e != 0) {
        return fail(cam, "VIDIOC_QUERYCAP", e);
    }
    caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) {
        snprintf(buf, sizeof buf, "%s is not a video capture device", dev);
        set_msg(cam, buf, 0);
        return TVO_ERR_UNSUPPORTED;
    }
    if (!(caps & V4L2_CAP_STREAMING)) {
        snprintf(buf, sizeof buf, "%s does not support streaming I/O", dev);
        set_msg(cam, buf, 0);
        return TVO_ERR_UNSUPPORTED;
    }
    return TVO_OK;
}

/* Preference order: luma-first formats (zero copy), then packed YUYV. */
static const uint32_t tvo_v4l2_wanted[4] = {TVO_V4L2_PIX_GREY, TVO_V4L2_PIX_NV12, TVO_V4L2_PIX_YU12,
                                            TVO_V4L2_PIX_YUYV};

static tvo_status set_format(tvo_v4l2 *cam, const tvo_v4l2_config *cfg)
{
    int offered[4] = {0, 0, 0, 0};
    int enum_ok = 0;
    uint32_t i;
    int k;
    char seen[64];
    size_t seen_len = 0;
    int refused = 0;

    seen[0] = '\0';
    /* Which of our formats does the driver list? (If it cannot enumerate, try them all.) */
    for (i = 0; i < 64; i++) {
        struct v4l2_fmtdesc d;
        int e;
        memset(&d, 0, sizeof d);
        d.index = i;
        d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        e = xioctl(cam, VIDIOC_ENUM_FMT, &d);
        if (e == EINVAL) {
            break; /* end of list */
        }
        if (e == ENOTTY) {
            break;
        }
        if (e != 0) {
            return fail(cam, "VIDIOC_ENUM_FMT", e);
        }
        enum_ok = 1;
        for (k = 0; k < 4; k++) {
            if (d.pixelformat == tvo_v4l2_wanted[k]) {
                offered[k] = 1;
            }
        }
        if (seen_len + 6 < sizeof seen) {
            char f[5];
            fourcc_str(d.pixelformat, f);
            memcpy(seen + seen_len, f, 4);
            seen[seen_len + 4] = ' ';
            seen[seen_len + 5] = '\0';
            seen_len += 5;
        }
    }
    if (!enum_ok) {
        for (k = 0; k < 4; k++) {
            offered[k] = 1;
        }
    }

    for (k = 0; k < 4; k++) {
        struct v4l2_format f;
        int e;
        uint32_t want = tvo_v4l2_wanted[k];
        int32_t w, h, bpl;
        if (!offered[k]) {
            continue;
        }
        memset(&f, 0, sizeof f);
        f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        f.fmt.pix.width = (uint32_t)cfg->width;
        f.fmt.pix.height = (uint32_t)cfg->height;
        f.fmt.pix.pixelformat = want;
        f.fmt.pix.field = V4L2_FIELD_NONE;
        e = xioctl(cam, VIDIOC_S_FMT, &f);
        if (e == EINVAL) {
            refused = 1;
            continue; /* format refused: try the next one */
        }
        if (e != 0) {
            return fail(cam, "VIDIOC_S_FMT", e);
        }
        /* Drivers adjust rather than refuse: check what was granted. */
        if (f.fmt.pix.pixelformat != want) {
            refused = 1;
            continue;
        }
        if (f.fmt.pix.field != V4L2_FIELD_NONE && f.fmt.pix.field != V4L2_FIELD_ANY) {
            refused = 1;
            continue; /* interlaced */
        }
        if (f.fmt.pix.width < 1 || f.fmt.pix.width > TVO_MAX_IMAGE_DIM || f.fmt.pix.height < 1 ||
            f.fmt.pix.height > TVO_MAX_IMAGE_DIM) {
            set_msg(cam, "driver granted an image size out of range", 0);
            return TVO_ERR_SIZE;
        }
        w = (int32_t)f.fmt.pix.width;
        h = (int32_t)f.fmt.pix.height;
        if (f.fmt.pix.bytesperline > (uint32_t)(4 * TVO_MAX_IMAGE_DIM)) {
            set_msg(cam, "driver granted a row stride out of range", 0);
            return TVO_ERR_SIZE;
        }
        bpl = (int32_t)f.fmt.pix.bytesperline;
        if (bpl < w * luma_step(want)) {
            bpl = w * luma_step(want); /* 0 or too small: the packed stride */
        }
        cam->format.width = w;
        cam->format.height = h;
        cam->format.bytesperline = bpl;
        cam->format.pixelformat = want;
        cam->format.sizeimage = f.fmt.pix.sizeimage;
        if ((uint64_t)cam->format.sizeimage < luma_bytes(w, h, bpl, want)) {
            cam->format.sizeimage = (uint32_t)luma_bytes(w, h, bpl, want);
        }
        return TVO_OK;
    }
    {
        char buf[160]; /* the longest message is 155 bytes; cam->message holds 160 */
        snprintf(buf, sizeof buf, "no usable pixel format (want GREY, NV12, YU12 or YUYV%s%s%s)",
                 refused ? "; driver refused them" : "", seen_len ? "; driver offers " : "", seen);
        set_msg(cam, buf, 0);
    }
    return TVO_ERR_UNSUPPORTED;
}

static tvo_status set_rate(tvo_v4l2 *cam, const tvo_v4l2_config *cfg)
{
    struct v4l2_streamparm p;
    int e;
    cam->format.fps_num = 0;
    cam->format.fps_den = 1;
    memset(&p, 0, sizeof p);
    p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    e = xioctl(cam, VIDIOC_G_PARM, &p);
    if (e == EBUSY) {
        return fail(cam, "VIDIOC_G_PARM", e);
    }
    if (e != 0) {
        return TVO_OK; /* rate control not supported (libcamera's compat layer, some UVC): unknown */
    }
    if (cfg->fps > 0 && (p.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
        memset(&p, 0, sizeof p);
        p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        p.parm.capture.timeperframe.numerator = 1;
        p.parm.capture.timeperframe.denominator = (uint32_t)cfg->fps;
        e = xioctl(cam, VIDIOC_S_PARM, &p);
        if (e == EBUSY) {
            return fail(cam, "VIDIOC_S_PARM", e);
        }
        if (e != 0) {
            memset(&p, 0, sizeof p);
            p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
            if (xioctl(cam, VIDIOC_G_PARM, &p) != 0) {
                return TVO_OK;
            }
        }
    }
    if (p.parm.capture.timeperframe.numerator > 0 && p.parm.capture.timeperframe.denominator > 0 &&
        p.parm.capture.timeperframe.numerator <= 0x7fffffffu &&
        p.parm.capture.timeperframe.denominator <= 0x7fffffffu) {
        cam->format.fps_num = (int32_t)p.parm.capture.timeperframe.denominator;
        cam->format.fps_den = (int32_t)p.parm.capture.timeperframe.numerator;
    }
    return TVO_OK;
}

static tvo_status setup_buffers(tvo_v4l2 *cam, const tvo_v4l2_config *cfg)
{
    struct v4l2_requestbuffers rb;
    uint32_t i, n;
    int e;
    uint64_t need = luma_bytes(cam->format.width, cam->format.height, cam->format.bytesperline,
                               cam->format.pixelformat);
    memset(&rb, 0, sizeof rb);
    rb.count = cfg->buffer_count;
    rb.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    rb.memory = V4L2_MEMORY_MMAP;
    e = xioctl(cam, VIDIOC_REQBUFS, &rb);
    if (e == EINVAL) {
        set_msg(cam, "device does not support mmap streaming (VIDIOC_REQBUFS)", e);
        return TVO_ERR_UNSUPPORTED;
    }
    if (e != 0) {
        return fail(cam, "VIDIOC_REQBUFS", e);
    }
    cam->reqbufs_done = 1;
    cam->format.buffers_granted = rb.count > 0x7fffffffu ? 0x7fffffff : (int32_t)rb.count;
    if (rb.count < 2) {
        char buf[96];
        snprintf(buf, sizeof buf, "driver granted %u buffer(s), at least 2 are needed", (unsigned)rb.count);
        set_msg(cam, buf, 0);
        return TVO_ERR_UNSUPPORTED;
    }
    n = rb.count < TVO_V4L2_MAX_BUFFERS ? rb.count : TVO_V4L2_MAX_BUFFERS;
    for (i = 0; i < n; i++) {
        struct v4l2_buffer b;
        void *p;
        memset(&b, 0, sizeof b);
        b.index = i;
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        e = xioctl(cam, VIDIOC_QUERYBUF, &b);
        if (e != 0) {
            return fail(cam, "VIDIOC_QUERYBUF", e);
        }
        if ((uint64_t)b.length < need) {
            set_msg(cam, "driver buffer smaller than one image", 0);
            return TVO_ERR_IO;
        }
        errno = 0;
        p = cam->sys.mmap(cam->sys.ctx, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, cam->fd,
                          (int64_t)b.m.offset);
        if (p == TVO_V4L2_MAP_FAILED || p == NULL) {
            return fail(cam, "mmap", last_errno());
        }
        cam->buf[i].start = p;
        cam->buf[i].length = b.length;
        cam->buf[i].queued = 0;
        cam->nbufs = i + 1;
    }
    cam->format.buffer_count = n;
    return TVO_OK;
}

static tvo_status queue_buffer(tvo_v4l2 *cam, uint32_t index)
{
    struct v4l2_buffer b;
    int e;
    memset(&b, 0, sizeof b);
    b.index = index;
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    e = xioctl(cam, VIDIOC_QBUF, &b);
    if (e != 0) {
        return fail(cam, "VIDIOC_QBUF", e);
    }
    cam->buf[index].queued = 1;
    return TVO_OK;
}

static tvo_status start_stream(tvo_v4l2 *cam)
{
    uint32_t i;
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    int e;
    for (i = 0; i < cam->nbufs; i++) {
        tvo_status s = queue_buffer(cam, i);
        if (s != TVO_OK) {
            return s;
        }
    }
    e = xioctl(cam, VIDIOC_STREAMON, &type);
    if (e != 0) {
        return fail(cam, "VIDIOC_STREAMON", e);
    }
    cam->streaming = 1;
    return TVO_OK;
}

/* ---- public API ---------------------------------------------------------------------------- */

void tvo_v4l2_config_default(tvo_v4l2_config *cfg)
{
    if (cfg == NULL) {
        return;
    }
    memset(cfg, 0, sizeof *cfg);
    cfg->device = "/dev/video0";
    cfg->width = 640;
    cfg->height = 480;
    cfg->fps = 30;
    cfg->buffer_count = 4;
    cfg->timeout_ms = 2000;
    cfg->max_retries = 64;
    cfg->max_skips = 16;
    cfg->nonblocking = 1;
    cfg->sys = NULL;
}

tvo_status tvo_v4l2_open(tvo_v4l2 *cam, const tvo_v4l2_config *cfg)
{
    const tvo_v4l2_sys *sys;
    tvo_status s;
    int flags;
    uint32_t tries = 0;

    if (cam == NULL) {
        return TVO_ERR_NULL;
    }
    memset(cam, 0, sizeof *cam);
    cam->fd = -1;
    if (cfg == NULL || cfg->device == NULL) {
        set_msg(cam, "no configuration or device path", 0);
        return TVO_ERR_NULL;
    }
    sys = cfg->sys != NULL ? cfg->sys : tvo_v4l2_sys_libc();
    if (sys->open == NULL || sys->close == NULL || sys->ioctl == NULL || sys->mmap == NULL ||
        sys->munmap == NULL || sys->poll == NULL) {
        set_msg(cam, "incomplete system call table", 0);
        return TVO_ERR_NULL;
    }
    if (cfg->width < 1 || cfg->width > TVO_MAX_IMAGE_DIM || cfg->height < 1 ||
        cfg->height > TVO_MAX_IMAGE_DIM) {
        set_msg(cam, "requested size out of range", 0);
        return TVO_ERR_SIZE;
    }
    if (cfg->fps < 0 || cfg->fps > 10000 || cfg->buffer_count < 2 ||
        cfg->buffer_count > TVO_V4L2_MAX_BUFFERS || cfg->timeout_ms < 1 || cfg->timeout_ms > 600000 ||
        cfg->max_retries > 1000000 || cfg->device[0] == '\0') {
        set_msg(cam, "configuration value out of range", 0);
        return TVO_ERR_ARG;
    }
    cam->sys = *sys;
    cam->timeout_ms = cfg->timeout_ms;
    cam->max_retries = cfg->max_retries;
    cam->max_skips = cfg->max_skips;
    cam->nonblocking = cfg->nonblocking != 0;

    flags = O_RDWR | O_CLOEXEC | (cam->nonblocking ? O_NONBLOCK : 0);
    for (;;) {
        errno = 0;
        cam->fd = cam->sys.open(cam->sys.ctx, cfg->device, flags);
        if (cam->fd >= 0) {
            break;
        }
        cam->fd = -1;
        {
            int e = last_errno();
            char buf[96];
            if (e == EINTR && tries < cam->max_retries) {
                tries++;
                cam->stats.retries++;
                continue;
            }
            snprintf(buf, sizeof buf, "open %s", cfg->device);
            set_msg(cam, buf, e);
            switch (e) {
            case ENOENT:
            case ENODEV:
            case ENXIO:
                return TVO_ERR_NOT_FOUND;
            case EBUSY:
                return TVO_ERR_BUSY;
            case EINTR:
                return TVO_ERR_AGAIN;
            default:
                return TVO_ERR_IO;
            }
        }
    }

    s = check_caps(cam, cfg->device);
    if (s == TVO_OK) {
        s = set_format(cam, cfg);
    }
    if (s == TVO_OK) {
        s = set_rate(cam, cfg);
    }
    if (s == TVO_OK) {
        s = setup_buffers(cam, cfg);
    }
    if (s == TVO_OK) {
        s = start_stream(cam);
    }
    if (s != TVO_OK) {
        tvo_v4l2_close(cam);
        return s;
    }
    {
        char f[5];
        char buf[150];
        fourcc_str(cam->format.pixelformat, f);
        snprintf(buf, sizeof buf, "%s: %dx%d %s, %d/%d fps, %u buffers", cfg->device, (int)cam->format.width,
                 (int)cam->format.height, f, (int)cam->format.fps_num, (int)cam->format.fps_den,
                 (unsigned)cam->format.buffer_count);
        set_msg(cam, buf, 0);
    }
    return TVO_OK;
}

tvo_status tvo_v4l2_dequeue(tvo_v4l2 *cam, tvo_v4l2_frame *frame)
{
    uint32_t tries = 0;
    uint32_t skipped = 0;
    uint64_t need;

    if (cam == NULL || frame == NULL) {
        return TVO_ERR_NULL;
    }
    memset(frame, 0, sizeof *frame);
    if (cam->fd < 0 || !cam->streaming) {
        set_msg(cam, "camera is not streaming", 0);
        return TVO_ERR_STATE;
    }
    if (cam->held + 1 >= cam->nbufs) {
        set_msg(cam, "too many frames held: requeue one first", 0);
        return TVO_ERR_STATE;
    }
    need = luma_bytes(cam->format.width, cam->format.height, cam->format.bytesperline,
                      cam->format.pixelformat);
    for (;;) {
        short rev = 0;
        int r;
        struct v4l2_buffer b;
        uint32_t idx;

        errno = 0;
        r = cam->sys.poll(cam->sys.ctx, cam->fd, POLLIN, cam->timeout_ms, &rev);
        if (r < 0) {
            int e = last_errno();
            if (e == EINTR && tries < cam->max_retries) {
                tries++;
                cam->stats.retries++;
                continue;
            }
            return fail(cam, "poll", e);
        }
        if (r == 0) {
            char buf[96];
            snprintf(buf, sizeof buf, "no frame within %d ms (stream stalled)", (int)cam->timeout_ms);
            set_msg(cam, buf, 0);
            return TVO_ERR_TIMEOUT;
        }
        if (rev & (POLLHUP | POLLNVAL)) {
            set_msg(cam, "device disconnected", 0);
            return TVO_ERR_DEVICE_LOST;
        }
        if (!(rev & (POLLIN | POLLERR))) {
            if (tries < cam->max_retries) { /* spurious wake-up */
                tries++;
                cam->stats.retries++;
                continue;
            }
            set_msg(cam, "poll keeps returning without data", 0);
            return TVO_ERR_IO;
        }

        memset(&b, 0, sizeof b);
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        for (;;) { /* EINTR: retry the ioctl itself */
            errno = 0;
            r = cam->sys.ioctl(cam->sys.ctx, cam->fd, VIDIOC_DQBUF, &b);
            if (r != -1 || errno != EINTR || tries >= cam->max_retries) {
                break;
            }
            tries++;
            cam->stats.retries++;
        }
        if (r == -1) {
            int e = last_errno();
            if (e == EAGAIN && cam->nonblocking && tries < cam->max_retries) {
                tries++; /* woken but nothing ready: wait again */
                cam->stats.retries++;
                continue;
            }
            if (e == ENODEV || e == ENXIO) {
                set_msg(cam, "device disconnected (VIDIOC_DQBUF)", e);
                return TVO_ERR_DEVICE_LOST;
            }
            return fail(cam, "VIDIOC_DQBUF", e);
        }
        idx = b.index;
        if (idx >= cam->nbufs || !cam->buf[idx].queued) {
            set_msg(cam, "driver returned an unknown buffer", 0);
            return TVO_ERR_IO;
        }
        cam->buf[idx].queued = 0;
        if (cam->have_sequence && b.sequence > cam->last_sequence + 1u) {
            cam->stats.sequence_gaps += (uint64_t)(b.sequence - cam->last_sequence - 1u);
        }
        cam->have_sequence = 1;
        cam->last_sequence = b.sequence;

        if ((b.flags & V4L2_BUF_FLAG_ERROR) || (uint64_t)b.bytesused < need ||
            b.bytesused > cam->buf[idx].length) {
            tvo_status s;
            if (b.flags & V4L2_BUF_FLAG_ERROR) {
                cam->stats.error_buffers++;
                set_msg(cam, "skipped a buffer flagged V4L2_BUF_FLAG_ERROR", 0);
            } else {
                cam->stats.short_buffers++;
                set_msg(cam, "skipped a buffer with bytesused shorter than one image", 0);
            }
            skipped++;
            s = queue_buffer(cam, idx);
            if (s != TVO_OK) {
                return s;
            }
            if (skipped > cam->max_skips) {
                set_msg(cam, "too many bad buffers in a row", 0);
                return TVO_ERR_IO;
            }
            continue;
        }

        frame->data = (const uint8_t *)cam->buf[idx].start;
        frame->bytesused = b.bytesused;
        frame->width = cam->format.width;
        frame->height = cam->format.height;
        frame->stride = cam->format.bytesperline;
        frame->pixelformat = cam->format.pixelformat;
        frame->zero_copy = cam->format.pixelformat != TVO_V4L2_PIX_YUYV;
        if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC &&
            (b.timestamp.tv_sec != 0 || b.timestamp.tv_usec != 0)) {
            frame->timestamp_ns = (int64_t)b.timestamp.tv_sec * 1000000000 +
                    (int64_t)b.timestamp.tv_usec * 1000;
            frame->timestamp_from_driver = 1;
        } else {
            frame->timestamp_ns = now_ns();
            frame->timestamp_from_driver = 0;
        }
        frame->sequence = b.sequence;
        frame->skipped = skipped;
        frame->index = idx;
        cam->held++;
        cam->stats.frames++;
        return TVO_OK;
    }
}

tvo_status tvo_v4l2_requeue(tvo_v4l2 *cam, const tvo_v4l2_frame *frame)
{
    tvo_status s;
    if (cam == NULL || frame == NULL) {
        return TVO_ERR_NULL;
    }
    if (cam->fd < 0 || !cam->streaming) {
        set_msg(cam, "camera is not streaming", 0);
        return TVO_ERR_STATE;
    }
    if (frame->index >= cam->nbufs || frame->data != cam->buf[frame->index].start) {
        set_msg(cam, "not a frame of this camera", 0);
        return TVO_ERR_ARG;
    }
    if (cam->buf[frame->index].queued) {
        set_msg(cam, "frame already requeued", 0);
        return TVO_ERR_STATE;
    }
    s = queue_buffer(cam, frame->index);
    if (s == TVO_OK && cam->held > 0) {
        cam->held--;
    }
    return s;
}

tvo_status tvo_v4l2_frame_luma(const tvo_v4l2_frame *frame, uint8_t *dst, int32_t dst_stride)
{
    int32_t x, y;
    if (frame == NULL || dst == NULL || frame->data == NULL) {
        return TVO_ERR_NULL;
    }
    if (frame->width < 1 || frame->height < 1 || dst_stride < frame->width ||
        frame->stride < frame->width * luma_step(frame->pixelformat)) {
        return TVO_ERR_SIZE;
    }
    if ((uint64_t)frame->bytesused <
        luma_bytes(frame->width, frame->height, frame->stride, frame->pixelformat)) {
        return TVO_ERR_SIZE;
    }
    if (frame->pixelformat == TVO_V4L2_PIX_YUYV) {
        for (y = 0; y < frame->height; y++) {
            const uint8_t *s = frame->data + (size_t)y * (size_t)frame->stride;
            uint8_t *d = dst + (size_t)y * (size_t)dst_stride;
            for (x = 0; x < frame->width; x++) {
                d[x] = s[2 * x];
            }
        }
        return TVO_OK;
    }
    if (frame->pixelformat != TVO_V4L2_PIX_GREY && frame->pixelformat != TVO_V4L2_PIX_NV12 &&
        frame->pixelformat != TVO_V4L2_PIX_YU12) {
        return TVO_ERR_UNSUPPORTED;
    }
    for (y = 0; y < frame->height; y++) {
        memcpy(dst + (size_t)y * (size_t)dst_stride, frame->data + (size_t)y * (size_t)frame->stride,
               (size_t)frame->width);
    }
    return TVO_OK;
}

void tvo_v4l2_close(tvo_v4l2 *cam)
{
    uint32_t i;
    if (cam == NULL || cam->fd < 0) {
        return;
    }
    if (cam->streaming) {
        int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        (void)xioctl(cam, VIDIOC_STREAMOFF, &type); /* fails with ENODEV on a lost device: fine */
        cam->streaming = 0;
    }
    for (i = 0; i < cam->nbufs; i++) {
        if (cam->buf[i].start != NULL) {
            (void)cam->sys.munmap(cam->sys.ctx, cam->buf[i].start, cam->buf[i].length);
            cam->buf[i].start = NULL;
            cam->buf[i].length = 0;
            cam->buf[i].queued = 0;
        }
    }
    cam->nbufs = 0;
    cam->held = 0;
    if (cam->reqbufs_done) {
        struct v4l2_requestbuffers rb;
        memset(&rb, 0, sizeof rb);
        rb.count = 0;
        rb.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        rb.memory = V4L2_MEMORY_MMAP;
        (void)xioctl(cam, VIDIOC_REQBUFS, &rb);
        cam->reqbufs_done = 0;
    }
    /* Never retry close: on Linux the descriptor is released even when close reports EINTR. */
    (void)cam->sys.close(cam->sys.ctx, cam->fd);
    cam->fd = -1;
}

const tvo_v4l2_format *tvo_v4l2_get_format(const tvo_v4l2 *cam)
{
    return cam != NULL ? &cam->format : NULL;
}

const tvo_v4l2_stats *tvo_v4l2_get_stats(const tvo_v4l2 *cam)
{
    return cam != NULL ? &cam->stats : NULL;
}

const char *tvo_v4l2_message(const tvo_v4l2 *cam)
{
    if (cam == NULL) {
        return "no camera";
    }
    return cam->message[0] != '\0' ? cam->message : "ok";
}
