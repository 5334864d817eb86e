/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: weights-file validation, loading into caller memory, and the per-frame run.
 * Format: docs/weights-format.md. Nothing in the file is trusted: tvo_nn_validate() checks every
 * field before tvo_nn_load() copies anything. */
#include <math.h>
#include <string.h>
#include "tinyvo/arena.h"
#include "tinyvo/dmath.h"
#include "tinyvo/nn.h"

typedef struct tvo_nn_layer_rt {
    int32_t n_in, n_out, act, out_kind, out_zp, cols; /* cols: weights stored column-major */
    int8_t *w;                                        /* n_out x n_in, row-major */
    int32_t *bias;                                    /* bias with the input zero point folded in */
    int32_t *mult;                                    /* S8 layers */
    int32_t *shift;                                   /* S8 layers */
    float *scale;                                     /* F32 layers */
    int8_t *lut;                                      /* NULL for TVO_NN_ACT_NONE */
} tvo_nn_layer_rt;

typedef struct tvo_nn_branch_rt {
    int32_t dof, n_in, n_layers, in_zp;
    float in_scale, out_scale, out_offset;
    uint8_t ids[TVO_FEAT_COUNT];
    float norm_scale[TVO_FEAT_COUNT];
    float norm_offset[TVO_FEAT_COUNT];
    tvo_nn_layer_rt layers[TVO_NN_MAX_LAYERS];
} tvo_nn_branch_rt;

struct tvo_nn {
    int32_t n_branches;
    int32_t mask;
    uint32_t macs;
    int32_t max_width;
    uint32_t feature_mask; /* features read by some branch */
    tvo_nn_branch_rt br[TVO_NN_DOF_COUNT];
    int8_t *scratch_a;
    int8_t *scratch_b;
};

/* ---- little-endian readers (no alignment needed) --------------------------------------------- */
static uint32_t rd_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static uint32_t rd_u16(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8);
}
static int32_t rd_i32(const uint8_t *p)
{
    uint32_t u = rd_u32(p);
    return u <= 0x7FFFFFFFu ? (int32_t)u : -(int32_t)(~u) - 1;
}
static float rd_f32(const uint8_t *p)
{
    uint32_t u = rd_u32(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}
static int is_finite_f(float f)
{
    return f == f && f - f == 0.0f;
}
static int is_pos_scale(float f)
{
    return is_finite_f(f) && f > 0.0f;
}

/* CRC-32, bitwise with a 16-entry table: small and fast enough for a one-off load check. */
uint32_t tvo_nn_crc32(uint32_t crc, const void *data, size_t size)
{
    static const uint32_t tab[16] = {0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu,
                                     0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
                                     0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
                                     0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
    const uint8_t *p = (const uint8_t *)data;
    size_t i;
    if (p == NULL)
        return crc;
    crc = ~crc;
    for (i = 0; i < size; ++i) {
        crc ^= p[i];
        crc = (crc >> 4) ^ tab[crc & 15u];
        crc = (crc >> 4) ^ tab[crc & 15u];
    }
    return ~crc;
}

/* [off, off + len) lies inside the payload area [header_size, file_size)? off 0 never does. */
static tvo_status check_span(uint32_t off, uint64_t len, uint32_t align, size_t file_size)
{
    if (off < TVO_NN_HEADER_SIZE || (uint64_t)off + len > (uint64_t)file_size)
        return TVO_ERR_RANGE;
    if (off % align != 0)
        return TVO_ERR_FORMAT;
    return TVO_OK;
}

#define TVO_TRY(expr)           \
    do {                        \
        tvo_status s_ = (expr); \
        if (s_ != TVO_OK)       \
            return s_;          \
    } while (0)

static size_t layer_bytes(uint32_t n_in, uint32_t n_out, uint32_t act)
{
    size_t b = tvo_arena_round((size_t)n_in * n_out);
    b += 3u * tvo_arena_round((size_t)n_out * 4u); /* bias, mult/scale, shift */
    if (act != TVO_NN_ACT_NONE)
        b += 256u;
    return b;
}

/* Checks one layer entry at `e` (index k of n_layers in its branch). prev_* describe its input. */
static tvo_status check_layer(const uint8_t *f, size_t size, const uint8_t *e, uint32_t k, uint32_t n_layers,
                              uint32_t prev_n, int32_t prev_zp, size_t *bytes, uint32_t *macs,
                              uint32_t *max_width, uint32_t *out_n, int32_t *out_zp)
{
    uint32_t n_in = rd_u32(e), n_out = rd_u32(e + 4), act = rd_u32(e + 8), kind = rd_u32(e + 12);
    int32_t in_zp = rd_i32(e + 16), o_zp = rd_i32(e + 20), a_zp = rd_i32(e + 24);
    uint32_t w_off = rd_u32(e + 40), b_off = rd_u32(e + 44), m_off = rd_u32(e + 48);
    uint32_t s_off = rd_u32(e + 52), l_off = rd_u32(e + 56);
    int last = (k + 1 == n_layers);
    uint32_t o, i;

    if (n_in == 0 || n_out == 0 || n_in > TVO_NN_MAX_WIDTH || n_out > TVO_NN_MAX_WIDTH)
        return TVO_ERR_SIZE;
    if (n_in != prev_n)
        return TVO_ERR_FORMAT; /* sizes do not chain */
    if (act >= TVO_NN_ACT_COUNT || kind > TVO_NN_OUT_F32)
        return TVO_ERR_UNSUPPORTED;
    if (last != (kind == TVO_NN_OUT_F32) || (last && (n_out != 1 || act != TVO_NN_ACT_NONE)))
        return TVO_ERR_FORMAT;
    if (rd_u32(e + 60) != 0)
        return TVO_ERR_FORMAT;
    if (in_zp < -128 || in_zp > 127 || o_zp < -128 || o_zp > 127 || a_zp < -128 || a_zp > 127)
        return TVO_ERR_RANGE;
    if (in_zp != prev_zp || (act == TVO_NN_ACT_NONE && a_zp != o_zp))
        return TVO_ERR_FORMAT; /* zero points do not chain */
    if (!is_pos_scale(rd_f32(e + 28)) || !is_pos_scale(rd_f32(e + 32)) || !is_pos_scale(rd_f32(e + 36)))
        return TVO_ERR_NOT_FINITE;
    TVO_TRY(check_span(w_off, (uint64_t)n_in * n_out, TVO_NN_PAYLOAD_ALIGN, size));
    TVO_TRY(check_span(b_off, (uint64_t)n_out * 4u, 4u, size));
    TVO_TRY(check_span(m_off, (uint64_t)n_out * 4u, 4u, size));
    if (kind == TVO_NN_OUT_S8)
        TVO_TRY(check_span(s_off, (uint64_t)n_out * 4u, 4u, size));
    else if (s_off != 0)
        return TVO_ERR_FORMAT;
    if (act == TVO_NN_ACT_NONE) {
        if (l_off != 0)
            return TVO_ERR_FORMAT;
    } else {
        if (l_off == 0)
            return TVO_ERR_FORMAT;
        TVO_TRY(check_span(l_off, 256u, TVO_NN_PAYLOAD_ALIGN, size));
    }
    for (o = 0; o < n_out; ++o) {
        const int8_t *w = (const int8_t *)(f + w_off + (size_t)o * n_in);
        int64_t bound = rd_i32(f + b_off + 4u * o), sabs = 0;
        if (bound < 0)
            bound = -bound;
        for (i = 0; i < n_in; ++i)
            sabs += w[i] < 0 ? -(int64_t)w[i] : (int64_t)w[i];
        /* |bias + sum w (x - zp)| <= |bias| + 255 sum |w|, and every partial sum of the kernel is smaller */
        if (bound + 255 * sabs > INT32_MAX)
            return TVO_ERR_RANGE;
        if (kind == TVO_NN_OUT_S8) {
            int32_t m = rd_i32(f + m_off + 4u * o), s = rd_i32(f + s_off + 4u * o);
            if (m < (INT32_C(1) << 30) || s < 1 || s > 62)
                return TVO_ERR_RANGE;
        } else if (!is_pos_scale(rd_f32(f + m_off + 4u * o))) {
            return TVO_ERR_NOT_FINITE;
        }
    }
    *bytes = tvo_size_add(*bytes, layer_bytes(n_in, n_out, act));
    *macs += n_in * n_out;
    if (n_out > *max_width)
        *max_width = n_out;
    *out_n = n_out;
    *out_zp = a_zp;
    return TVO_OK;
}

/* Validates everything; on success *bytes = memory tvo_nn_load needs. */
static tvo_status tvo_nn_validate(const uint8_t *f, size_t size, size_t *bytes)
{
    uint32_t minor, nb, bt_off, b, dof_seen = 0, macs = 0, max_width = 0;
    size_t need;
    if (size < TVO_NN_HEADER_SIZE)
        return TVO_ERR_SIZE;
    if (rd_u32(f) != TVO_NN_MAGIC)
        return TVO_ERR_FORMAT;
    if (rd_u16(f + 4) != TVO_NN_VERSION_MAJOR)
        return TVO_ERR_VERSION;
    minor = rd_u16(f + 6);
    if (size > TVO_NN_MAX_FILE_SIZE || rd_u32(f + 8) != size)
        return TVO_ERR_SIZE;
    if (tvo_nn_crc32(0, f + 16, size - 16u) != rd_u32(f + 12))
        return TVO_ERR_CRC;
    if (rd_u32(f + 16) != TVO_NN_HEADER_SIZE || rd_u32(f + 36) != TVO_NN_BRANCH_ENTRY_SIZE ||
        rd_u32(f + 40) != TVO_NN_LAYER_ENTRY_SIZE || rd_u32(f + 44) != TVO_NN_INPUT_ENTRY_SIZE)
        return TVO_ERR_SIZE;
    if (rd_u32(f + 20) != TVO_FEAT_LAYOUT_ID || rd_u32(f + 24) != TVO_FEAT_COUNT)
        return TVO_ERR_MISMATCH;
    if (minor <= TVO_NN_VERSION_MINOR) {
        uint32_t r;
        for (r = 48; r < TVO_NN_HEADER_SIZE; r += 4)
            if (rd_u32(f + r) != 0)
                return TVO_ERR_FORMAT;
    }
    nb = rd_u32(f + 28);
    if (nb == 0 || nb > TVO_NN_DOF_COUNT)
        return TVO_ERR_SIZE;
    bt_off = rd_u32(f + 32);
    TVO_TRY(check_span(bt_off, (uint64_t)nb * TVO_NN_BRANCH_ENTRY_SIZE, 4u, size));

    need = tvo_size_add(TVO_ARENA_ALIGN, tvo_arena_round(sizeof(tvo_nn)));
    for (b = 0; b < nb; ++b) {
        const uint8_t *e = f + bt_off + (size_t)b * TVO_NN_BRANCH_ENTRY_SIZE;
        uint32_t dof = rd_u32(e), n_in = rd_u32(e + 4), n_layers = rd_u32(e + 8);
        uint32_t in_off = rd_u32(e + 12), ly_off = rd_u32(e + 16), i, k, prev_n;
        int32_t prev_zp = rd_i32(e + 24);
        if (dof >= TVO_NN_CODE_COUNT)
            return TVO_ERR_RANGE;
        if (dof_seen & (1u << dof))
            return TVO_ERR_FORMAT;
        dof_seen |= 1u << dof;
        /* a step-length branch (1.1): not in a 1.0 file, one at most, never beside tx ty tz */
        if ((dof_seen & 0xC0u) != 0 && (minor < 1u || (dof_seen & 0xC0u) == 0xC0u || (dof_seen & 0x7u) != 0))
            return TVO_ERR_FORMAT;
        if (n_in == 0 || n_in > TVO_FEAT_COUNT || n_layers == 0 || n_layers > TVO_NN_MAX_LAYERS)
            return TVO_ERR_SIZE;
        if (rd_u32(e + 36) != 0 || rd_u32(e + 40) != 0 || rd_u32(e + 44) != 0)
            return TVO_ERR_FORMAT;
        if (prev_zp < -128 || prev_zp > 127)
            return TVO_ERR_RANGE;
        if (!is_pos_scale(rd_f32(e + 20)) || !is_finite_f(rd_f32(e + 28)) || rd_f32(e + 28) == 0.0f ||
            !is_finite_f(rd_f32(e + 32)))
            return TVO_ERR_NOT_FINITE;
        TVO_TRY(check_span(in_off, (uint64_t)n_in * TVO_NN_INPUT_ENTRY_SIZE, 4u, size));
        TVO_TRY(check_span(ly_off, (uint64_t)n_layers * TVO_NN_LAYER_ENTRY_SIZE, 4u, size));
        for (i = 0; i < n_in; ++i) {
            const uint8_t *ie = f + in_off + (size_t)i * TVO_NN_INPUT_ENTRY_SIZE;
            float sc = rd_f32(ie + 4);
            if (rd_u32(ie) >= TVO_FEAT_COUNT)
                return TVO_ERR_RANGE;
            if (!is_finite_f(sc) || sc == 0.0f || !is_finite_f(rd_f32(ie + 8)))
                return TVO_ERR_NOT_FINITE;
        }
        prev_n = n_in;
        for (k = 0; k < n_layers; ++k)
            TVO_TRY(check_layer(f, size, f + ly_off + (size_t)k * TVO_NN_LAYER_ENTRY_SIZE, k, n_layers,
                                prev_n, prev_zp, &need, &macs, &max_width, &prev_n, &prev_zp));
    }
    need = tvo_size_add(need, 2u * tvo_arena_round(max_width > TVO_FEAT_COUNT ? max_width : TVO_FEAT_COUNT));
    *bytes = need;
    return TVO_OK;
}

tvo_status tvo_nn_required_size(const void *file, size_t file_size, size_t *bytes)
{
    if (file == NULL || bytes == NULL)
        return TVO_ERR_NULL;
    return tvo_nn_validate((const uint8_t *)file, file_size, bytes);
}

/* one validated layer entry le into L: weights (column-major for small S8 layers), the bias with the
 * input zero point folded in, the requantisation (S8) or output scales (F32), the activation table;
 * the network's MAC count and widest layer (*width) grow with it */
static tvo_status load_layer(const uint8_t *f, const uint8_t *le, tvo_arena *arena, tvo_nn *nn,
                             tvo_nn_layer_rt *L, uint32_t *width)
{
    uint32_t n_in = rd_u32(le), n_out = rd_u32(le + 4), o, j;
    int32_t in_zp = rd_i32(le + 16);
    const uint8_t *wf = f + rd_u32(le + 40), *bf = f + rd_u32(le + 44), *mf = f + rd_u32(le + 48);
    L->n_in = (int32_t)n_in;
    L->n_out = (int32_t)n_out;
    L->act = (int32_t)rd_u32(le + 8);
    L->out_kind = (int32_t)rd_u32(le + 12);
    L->out_zp = rd_i32(le + 20);
    L->w = (int8_t *)tvo_arena_alloc(arena, tvo_arena_round((size_t)n_in * n_out));
    L->bias = (int32_t *)tvo_arena_alloc(arena, tvo_arena_round((size_t)n_out * 4u));
    if (L->w == NULL || L->bias == NULL)
        return TVO_ERR_NO_MEMORY;
    const int8_t *ws = (const int8_t *)wf; /* int8_t is two's complement: bytes read as-is */
    L->cols = L->out_kind == (int32_t)TVO_NN_OUT_S8 && n_in < TVO_NN_COLS_MAX_IN;
    for (o = 0; o < n_out; ++o)
        for (j = 0; j < n_in; ++j)
            L->w[L->cols ? (size_t)j * n_out + o : (size_t)o * n_in + j] = ws[(size_t)o * n_in + j];
    for (o = 0; o < n_out; ++o) {
        int32_t rowsum = 0;
        for (j = 0; j < n_in; ++j)
            rowsum += ws[(size_t)o * n_in + j];
        /* bias + sum w (x - zp) = (bias - zp sum w) + sum w x; bounded by the validation */
        L->bias[o] = rd_i32(bf + 4u * o) - in_zp * rowsum;
    }
    if (L->out_kind == (int32_t)TVO_NN_OUT_S8) {
        const uint8_t *sf = f + rd_u32(le + 52);
        L->mult = (int32_t *)tvo_arena_alloc(arena, tvo_arena_round((size_t)n_out * 4u));
        L->shift = (int32_t *)tvo_arena_alloc(arena, tvo_arena_round((size_t)n_out * 4u));
        if (L->mult == NULL || L->shift == NULL)
            return TVO_ERR_NO_MEMORY;
        for (o = 0; o < n_out; ++o) {
            L->mult[o] = rd_i32(mf + 4u * o);
            L->shift[o] = rd_i32(sf + 4u * o);
        }
    } else {
        L->scale = (float *)tvo_arena_alloc(arena, tvo_arena_round((size_t)n_out * 4u));
        if (L->scale == NULL)
            return TVO_ERR_NO_MEMORY;
        for (o = 0; o < n_out; ++o)
            L->scale[o] = rd_f32(mf + 4u * o);
    }
    if (L->act != TVO_NN_ACT_NONE) {
        L->lut = (int8_t *)tvo_arena_alloc(arena, 256u);
        if (L->lut == NULL)
            return TVO_ERR_NO_MEMORY;
        memcpy(L->lut, f + rd_u32(le + 56), 256u);
    }
    nn->macs += n_in * n_out;
    if (n_out > *width)
        *width = n_out;
    return TVO_OK;
}

/* one validated branch entry e into br: its header, input normalisation, then its layers */
static tvo_status load_branch(const uint8_t *f, const uint8_t *e, tvo_arena *arena, tvo_nn *nn,
                              tvo_nn_branch_rt *br, uint32_t *width)
{
    uint32_t in_off = rd_u32(e + 12), ly_off = rd_u32(e + 16), i, k;
    br->dof = (int32_t)rd_u32(e);
    br->n_in = (int32_t)rd_u32(e + 4);
    br->n_layers = (int32_t)rd_u32(e + 8);
    br->in_scale = rd_f32(e + 20);
    br->in_zp = rd_i32(e + 24);
    br->out_scale = rd_f32(e + 28);
    br->out_offset = rd_f32(e + 32);
    nn->mask |= (int32_t)1 << (br->dof < TVO_NN_STEP ? br->dof : TVO_NN_STEP);
    for (i = 0; i < (uint32_t)br->n_in; ++i) {
        const uint8_t *ie = f + in_off + (size_t)i * TVO_NN_INPUT_ENTRY_SIZE;
        br->ids[i] = (uint8_t)rd_u32(ie);
        br->norm_scale[i] = rd_f32(ie + 4);
        br->norm_offset[i] = rd_f32(ie + 8);
        nn->feature_mask |= 1u << br->ids[i];
    }
    for (k = 0; k < (uint32_t)br->n_layers; ++k)
        TVO_TRY(load_layer(f, f + ly_off + (size_t)k * TVO_NN_LAYER_ENTRY_SIZE, arena, nn, &br->layers[k],
                           width));
    return TVO_OK;
}

tvo_status tvo_nn_load(tvo_nn **out, const void *file, size_t file_size, void *mem, size_t mem_size)
{
    const uint8_t *f = (const uint8_t *)file;
    size_t need;
    tvo_arena arena;
    tvo_nn *nn;
    uint32_t nb, b, width = TVO_FEAT_COUNT;
    if (out == NULL)
        return TVO_ERR_NULL;
    *out = NULL;
    if (file == NULL || mem == NULL)
        return TVO_ERR_NULL;
    TVO_TRY(tvo_nn_validate(f, file_size, &need));
    if (mem_size < need)
        return TVO_ERR_NO_MEMORY;
    tvo_arena_init(&arena, mem, mem_size);
    nn = (tvo_nn *)tvo_arena_alloc(&arena, tvo_arena_round(sizeof(tvo_nn)));
    if (nn == NULL)
        return TVO_ERR_NO_MEMORY;
    memset(nn, 0, sizeof *nn);
    nb = rd_u32(f + 28);
    nn->n_branches = (int32_t)nb;
    for (b = 0; b < nb; ++b)
        TVO_TRY(load_branch(f, f + rd_u32(f + 32) + (size_t)b * TVO_NN_BRANCH_ENTRY_SIZE, &arena, nn,
                            &nn->br[b], &width));
    nn->max_width = (int32_t)width;
    nn->scratch_a = (int8_t *)tvo_arena_alloc(&arena, tvo_arena_round(width));
    nn->scratch_b = (int8_t *)tvo_arena_alloc(&arena, tvo_arena_round(width));
    if (nn->scratch_a == NULL || nn->scratch_b == NULL)
        return TVO_ERR_NO_MEMORY;
    *out = nn;
    return TVO_OK;
}

tvo_status tvo_nn_run(const tvo_nn *nn, const float features[TVO_FEAT_COUNT], float out[6])
{
    float all[TVO_NN_OUT_COUNT];
    tvo_status st;
    int32_t d;
    if (nn == NULL || features == NULL || out == NULL)
        return TVO_ERR_NULL;
    st = tvo_nn_run_all(nn, features, all);
    for (d = 0; d < TVO_NN_DOF_COUNT; ++d)
        out[d] = all[d];
    return st;
}

tvo_status tvo_nn_run_all(const tvo_nn *nn, const float features[TVO_FEAT_COUNT], float out[TVO_NN_OUT_COUNT])
{
    int32_t b, d;
    uint32_t i;
    if (nn == NULL || features == NULL || out == NULL)
        return TVO_ERR_NULL;
    for (d = 0; d < TVO_NN_OUT_COUNT; ++d)
        out[d] = NAN;
    for (i = 0; i < TVO_FEAT_COUNT; ++i)
        if (((nn->feature_mask >> i) & 1u) && !is_finite_f(features[i]))
            return TVO_ERR_NOT_FINITE;
    for (b = 0; b < nn->n_branches; ++b) {
        const tvo_nn_branch_rt *br = &nn->br[b];
        int8_t *x = nn->scratch_a, *y = nn->scratch_b, *t;
        float r = 0.0f, v;
        int32_t k;
        tvo_status s = tvo_nn_quantize_input_f32(features, br->ids, br->norm_scale, br->norm_offset,
                                                 br->in_scale, br->in_zp, br->n_in, x);
        if (s != TVO_OK)
            return s;
        for (k = 0; k < br->n_layers; ++k) {
            const tvo_nn_layer_rt *L = &br->layers[k];
            if (L->out_kind == (int32_t)TVO_NN_OUT_F32) {
                tvo_nn_fc_s8_f32(x, L->w, L->bias, L->scale, L->n_in, 1, &r);
                break;
            }
            if (L->cols)
                tvo_nn_fc_s8_cols(x, L->w, L->bias, L->mult, L->shift, L->out_zp, L->n_in, L->n_out, y);
            else
                tvo_nn_fc_s8(x, L->w, L->bias, L->mult, L->shift, L->out_zp, L->n_in, L->n_out, y);
            if (L->lut != NULL)
                tvo_nn_lut_s8(y, L->n_out, L->lut);
            t = x;
            x = y;
            y = t;
        }
        v = r * br->out_scale;
        v = v + br->out_offset;
        if (!is_finite_f(v)) {
            /* finite weights and scales can still overflow float (a huge out_scale): no output then */
            for (d = 0; d < TVO_NN_OUT_COUNT; ++d)
                out[d] = NAN;
            return TVO_ERR_NOT_FINITE;
        }
        if (br->dof == (int32_t)TVO_NN_CODE_LOG_STEP) {
            v = v < TVO_NN_LOG_STEP_MIN ? TVO_NN_LOG_STEP_MIN
                                        : (v > TVO_NN_LOG_STEP_MAX ? TVO_NN_LOG_STEP_MAX : v);
            /* tvo_dm_exp: + - * / floor ldexp only, the operations nnfmt.det_exp repeats in the same order,
               so the step is bit-exact with the NumPy reference on every IEEE-754 target */
            v = (float)tvo_dm_exp((double)v);
        }
        out[br->dof < TVO_NN_STEP ? br->dof : TVO_NN_STEP] = v;
    }
    return TVO_OK;
}

int32_t tvo_nn_output_mask(const tvo_nn *nn)
{
    return nn != NULL ? nn->mask : 0;
}
uint32_t tvo_nn_macs(const tvo_nn *nn)
{
    return nn != NULL ? nn->macs : 0u;
}
int32_t tvo_nn_branch_count(const tvo_nn *nn)
{
    return nn != NULL ? nn->n_branches : 0;
}

tvo_nn_act tvo_nn_branch_activation(const tvo_nn *nn, int32_t i)
{
    if (nn == NULL || i < 0 || i >= nn->n_branches)
        return TVO_NN_ACT_NONE;
    return (tvo_nn_act)nn->br[i].layers[0].act;
}
