/* SPDX-License-Identifier: Apache-2.0 */
#include "tinyvo/status.h"

const char *tvo_status_str(tvo_status status)
{
    switch (status) {
    case TVO_OK:
        return "ok";
    case TVO_ERR_NULL:
        return "null pointer argument";
    case TVO_ERR_ARG:
        return "argument out of range";
    case TVO_ERR_SIZE:
        return "invalid size, stride or count";
    case TVO_ERR_NO_MEMORY:
        return "caller-provided memory or capacity too small";
    case TVO_ERR_DEGENERATE:
        return "degenerate input";
    case TVO_ERR_NOT_FINITE:
        return "non-finite value";
    case TVO_ERR_TOO_FEW:
        return "too few points";
    case TVO_ERR_NO_CONVERGENCE:
        return "no convergence";
    case TVO_ERR_FORMAT:
        return "malformed data";
    case TVO_ERR_VERSION:
        return "unsupported format version";
    case TVO_ERR_CRC:
        return "checksum mismatch";
    case TVO_ERR_RANGE:
        return "offset, index or value out of range";
    case TVO_ERR_UNSUPPORTED:
        return "unsupported";
    case TVO_ERR_STATE:
        return "wrong state";
    case TVO_ERR_IO:
        return "I/O error";
    case TVO_ERR_NOT_FOUND:
        return "not found";
    case TVO_ERR_BUSY:
        return "device busy";
    case TVO_ERR_TIMEOUT:
        return "timed out";
    case TVO_ERR_AGAIN:
        return "no data yet, try again";
    case TVO_ERR_DEVICE_LOST:
        return "device lost";
    case TVO_ERR_MISMATCH:
        return "inputs do not match";
    }
    return "unknown status";
}
