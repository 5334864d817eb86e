/* SPDX-License-Identifier: Apache-2.0 */
/* Fuzz harness: the weights-file loader and interpreter (tinyvo/nn.h).
 *
 * The input is a weights file. It is loaded twice: as given (exercises the size, magic, version and
 * CRC checks), and with the header's file_size and crc32 fields rewritten to match the buffer, so that
 * mutations get past the CRC into the structural checks. A file that loads is run on a few feature
 * vectors (typical, zero, extreme, NaN). Invariants: tvo_nn_required_size and tvo_nn_load agree; every
 * status is a documented one; a loaded model needs exactly the memory it asked for (ASan catches an
 * overrun of the exact-size block); outputs of the DoFs in the mask are finite or the run says
 * TVO_ERR_NOT_FINITE; the others are NaN. */
#include <math.h>
#include <string.h>

#include "fuzz_common.h"
#include "tinyvo/nn.h"

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static void run_model(const tvo_nn *nn)
{
    static const float typical[TVO_FEAT_COUNT] = {0.01f, -0.02f, 0.005f, 0.1f,  -0.2f, 0.97f,
                                                  0.8f,  0.5f,   0.3f,   0.05f, 0.0f};
    float feats[4][TVO_FEAT_COUNT];
    const int32_t mask = tvo_nn_output_mask(nn);
    TVO_FUZZ_CHECK(mask > 0 && mask < 64);
    TVO_FUZZ_CHECK(tvo_nn_branch_count(nn) >= 1 && tvo_nn_branch_count(nn) <= TVO_NN_DOF_COUNT);
    TVO_FUZZ_CHECK((int)tvo_nn_branch_activation(nn, 0) < (int)TVO_NN_ACT_COUNT);
    memcpy(feats[0], typical, sizeof typical);
    for (int i = 0; i < TVO_FEAT_COUNT; ++i) {
        feats[1][i] = 0.0f;
        feats[2][i] = (i & 1) ? -3.0e38f : 3.0e38f;
        feats[3][i] = typical[i];
    }
    feats[3][TVO_FEAT_DT] = NAN;
    for (int k = 0; k < 4; ++k) {
        float out[6];
        tvo_status st = tvo_nn_run(nn, feats[k], out);
        TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_NOT_FINITE);
        for (int d = 0; d < 6; ++d) {
            if (st == TVO_OK && ((mask >> d) & 1))
                TVO_FUZZ_CHECK(isfinite(out[d]));
            else
                TVO_FUZZ_CHECK(isnan(out[d]));
        }
    }
}

static void load_one(const uint8_t *file, size_t size)
{
    size_t need = 0;
    tvo_nn *nn = NULL;
    tvo_status st = tvo_nn_required_size(file, size, &need), st2;
    void *mem;
    TVO_FUZZ_CHECK(tvo_fuzz_status_valid(st));
    if (st != TVO_OK) {
        uint8_t small[64];
        st2 = tvo_nn_load(&nn, file, size, small, sizeof small);
        TVO_FUZZ_CHECK(st2 == st && nn == NULL);
        return;
    }
    TVO_FUZZ_CHECK(need > 0 && need < (size_t)1 << 30);
    mem = malloc(need);
    if (mem == NULL)
        return;
    /* one byte short: refused without touching anything */
    st2 = tvo_nn_load(&nn, file, size, mem, need - 1);
    TVO_FUZZ_CHECK(st2 == TVO_ERR_NO_MEMORY && nn == NULL);
    st2 = tvo_nn_load(&nn, file, size, mem, need);
    TVO_FUZZ_CHECK(st2 == TVO_OK && nn != NULL);
    run_model(nn);
    free(mem);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *copy;
    load_one(data, size);
    if (size < TVO_NN_HEADER_SIZE || size > TVO_NN_MAX_FILE_SIZE)
        return 0;
    copy = (uint8_t *)malloc(size);
    if (copy == NULL)
        return 0;
    memcpy(copy, data, size);
    put_u32(copy + 8, (uint32_t)size);
    put_u32(copy + 12, tvo_nn_crc32(0, copy + 16, size - 16));
    load_one(copy, size);
    free(copy);
    return 0;
}
