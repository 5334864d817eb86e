/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: monotonic clock. */
#include "tinyvo/port/clock.h"

#include <time.h>

int64_t tvo_clock_now_ns(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0)
        return 0;
    return (int64_t)ts.tv_sec * 1000000000 + (int64_t)ts.tv_nsec;
}
