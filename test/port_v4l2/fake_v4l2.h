/* SPDX-License-Identifier: Apache-2.0 */
/* A scripted fake V4L2 capture device for the port's tests (no camera on CI machines).
 *
 * fake_dev_sys() returns a tvo_v4l2_sys table whose calls act on one fake_dev: it answers the
 * ioctls a capture device answers, hands out heap memory as "mapped" buffers, and follows a
 * script of streaming events (frames, bad buffers, EINTR, EAGAIN, stalls, unplug). It counts
 * every open/close/mmap/munmap so tests can check that nothing leaks on any path.
 *
 * compat = 1 mimics libcamera's V4L2 compatibility layer (v4l2-compat.so): mmap streaming only
 * (no READWRITE capability), S_FMT substitutes the first supported format instead of failing,
 * G_PARM/S_PARM answer ENOTTY, mmap insists on PROT_READ|PROT_WRITE, length == sizeimage and
 * offset == index * sizeimage, munmap insists on the mapped length. */
#ifndef FAKE_V4L2_H
#define FAKE_V4L2_H

#include <stdint.h>
#include <stddef.h>
#include "tinyvo/port/v4l2.h"

#define FAKE_FD 42
#define FAKE_MAX_BUFS 32
#define FAKE_MAX_STEPS 128

typedef enum fake_step {
    FAKE_FRAME = 1,    /* a good frame */
    FAKE_FRAME_ERROR,  /* a frame flagged V4L2_BUF_FLAG_ERROR */
    FAKE_FRAME_SHORT,  /* a frame with half the bytes */
    FAKE_DROP,         /* the driver drops a frame (sequence number jumps) */
    FAKE_POLL_EINTR,   /* poll fails with EINTR */
    FAKE_POLL_TIMEOUT, /* poll times out once */
    FAKE_DQ_EINTR,     /* poll ok, DQBUF fails with EINTR */
    FAKE_DQ_EAGAIN,    /* poll ok, DQBUF fails with EAGAIN */
    FAKE_UNPLUG_HUP,   /* device removed: poll reports POLLERR|POLLHUP, ioctls ENODEV */
    FAKE_UNPLUG_DQ     /* device removed between poll and DQBUF: DQBUF fails with ENODEV */
} fake_step;

typedef struct fake_dev {
    /* ---- behaviour (set by the test before open) */
    int open_errno;      /* open fails with this errno (0 = opens) */
    uint32_t caps;       /* device_caps reported by QUERYCAP */
    uint32_t formats[8]; /* formats listed by ENUM_FMT */
    int nformats;
    int sfmt_errno;       /* S_FMT fails with this errno (0 = works) */
    int reqbufs_errno;    /* REQBUFS (count > 0) fails with this errno */
    uint32_t max_buffers; /* REQBUFS grants min(asked, max_buffers) */
    uint32_t min_buffers; /* ... and at least this many (drivers may grant more) */
    int width, height;    /* the only size the sensor has */
    int fps;              /* the highest rate it can do */
    int compat;           /* behave like libcamera's v4l2-compat layer */
    int eintr_per_call;   /* every call fails with EINTR this many times before working */
    fake_step script[FAKE_MAX_STEPS];
    int nscript;
    /* ---- state */
    int fd_open, streaming, lost, nonblocking;
    int eintr_left[3];
    int pos;
    uint32_t fmt, bpl, sizeimage;
    uint32_t nbufs;
    uint8_t *mem[FAKE_MAX_BUFS];
    int mapped[FAKE_MAX_BUFS];
    int queued[FAKE_MAX_BUFS];
    uint32_t qorder[FAKE_MAX_BUFS]; /* FIFO of queued indices */
    uint32_t qhead, qcount;
    uint32_t seq;
    int64_t t0_ns;
    /* ---- counters */
    int opens, closes, mmaps, munmaps, streamons, streamoffs, reqbufs_zero, dqbufs, polls;
    int64_t last_ts_ns; /* timestamp of the last frame handed out */
    uint32_t last_seq;
} fake_dev;

/* A healthy GREY+YUYV 64x48 device at 30 fps granting up to 8 buffers, empty script. */
void fake_dev_init(fake_dev *d);
/* Append n copies of a step. */
void fake_dev_push(fake_dev *d, fake_step s, int n);
/* A system call table acting on d. */
tvo_v4l2_sys fake_dev_sys(fake_dev *d);
/* Free what the fake allocated (buffers). */
void fake_dev_free(fake_dev *d);
/* Luma value the fake writes at (x, y) of frame number seq. */
uint8_t fake_luma(uint32_t seq, int x, int y);

#endif
