/* SPDX-License-Identifier: Apache-2.0 */
/* The int8 network interpreter: golden vectors (test/data/nn, written by tinyvo_tools.nngolden) bit for
 * bit, and every kind of bad weights file refused with its precise status, one corruption at a time
 * (with the CRC recomputed so that the check behind it is reached). */
#include <math.h>
#include "tvo_test.h"
#include "tinyvo/nn.h"

typedef struct blob {
    uint8_t *data;
    size_t size;
} blob;

static blob read_file(const char *name)
{
    blob b;
    b.data = tvo_test_read_nn_file(name, 64u, &b.size);
    return b;
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}
static void putf(uint8_t *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put32(p, u);
}
static void fix_crc(uint8_t *f, size_t size)
{
    put32(f + 12, tvo_nn_crc32(0, f + 16, size - 16));
}

/* offsets of branch b's entry, its input table and its layer k entry */
static uint8_t *branch_entry(uint8_t *f, uint32_t b)
{
    return f + get32(f + 32) + 48u * b;
}
static uint8_t *input_entry(uint8_t *f, uint32_t b, uint32_t i)
{
    return f + get32(branch_entry(f, b) + 12) + 12u * i;
}
static uint8_t *layer_entry(uint8_t *f, uint32_t b, uint32_t k)
{
    return f + get32(branch_entry(f, b) + 16) + 64u * k;
}

static tvo_status status_of(const uint8_t *f, size_t size)
{
    size_t need = 0;
    return tvo_nn_required_size(f, size, &need);
}

/* Golden file version 1: 6 outputs per record (tvo_nn_run); version 2: 7 (tvo_nn_run_all, the step). */
static void check_golden(const char *model_name, const char *golden_name, int32_t want_mask,
                         int32_t want_branches, tvo_nn_act act0, tvo_nn_act act_last)
{
    blob m = read_file(model_name), g = read_file(golden_name);
    size_t need = 0;
    void *mem;
    tvo_nn *nn = NULL;
    uint32_t n, nf, i, ver, no;
    if (m.data == NULL || m.size == 0 || g.data == NULL || g.size < 48) {
        free(m.data);
        free(g.data);
        fail_msg("test/data/nn/%s or %s missing (TVO_SOURCE_DIR?)", model_name, golden_name);
        return;
    }
    assert_memory_equal(g.data, "TVNG", 4);
    ver = get32(g.data + 4);
    assert_true(ver == 1 || ver == 2);
    no = ver == 1 ? 6u : (uint32_t)TVO_NN_OUT_COUNT;
    n = get32(g.data + 8);
    nf = get32(g.data + 12);
    assert_int_equal(nf, TVO_FEAT_COUNT);
    assert_int_equal(g.size, 48u + (size_t)n * (nf + no) * 4u);
    assert_int_equal(tvo_nn_required_size(m.data, m.size, &need), TVO_OK);
    mem = malloc(need + 1);
    assert_non_null(mem);
    /* deliberately misaligned memory and exactly the required size */
    assert_int_equal(tvo_nn_load(&nn, m.data, m.size, (uint8_t *)mem + 1, need), TVO_OK);
    assert_non_null(nn);
    memset(m.data, 0xA5, m.size); /* the model must not reference the file */
    assert_int_equal(tvo_nn_output_mask(nn), want_mask);
    assert_int_equal(tvo_nn_branch_count(nn), want_branches);
    assert_int_equal(tvo_nn_branch_activation(nn, 0), act0);
    assert_int_equal(tvo_nn_branch_activation(nn, want_branches - 1), act_last);
    assert_true(tvo_nn_macs(nn) > 0);
    for (i = 0; i < n; ++i) {
        float feat[TVO_FEAT_COUNT], want[TVO_NN_OUT_COUNT], out[TVO_NN_OUT_COUNT], out6[6];
        const uint8_t *rec = g.data + 48 + (size_t)i * (nf + no) * 4;
        memcpy(feat, rec, sizeof feat);
        memcpy(want, rec + nf * 4, no * 4u);
        assert_int_equal(tvo_nn_run(nn, feat, out6), TVO_OK);
        assert_memory_equal(out6, want, sizeof out6); /* bit for bit */
        assert_int_equal(tvo_nn_run_all(nn, feat, out), TVO_OK);
        assert_memory_equal(out, want, sizeof out6);
        if (no == 7u)
            assert_memory_equal(&out[TVO_NN_STEP], &want[TVO_NN_STEP], sizeof(float));
        else
            assert_true(isnan(out[TVO_NN_STEP]));
    }
    free(mem);
    free(m.data);
    free(g.data);
}

static void test_golden_tiny(void **state)
{
    (void)state;
    check_golden("tiny.tvonn", "tiny.golden", 0x3F, 6, TVO_NN_ACT_RELU, TVO_NN_ACT_SIGMOID);
}

static void test_golden_paper(void **state)
{
    (void)state;
    check_golden("paper.tvonn", "paper.golden", 0x3F, 6, TVO_NN_ACT_RELU, TVO_NN_ACT_SIGMOID);
}

/* Format 1.1: a log-step branch (code 7) with rx ry rz, and a linear step branch (code 6) alone. The
 * golden step values include both ends of the log clamp (1.1e-7 and 2981 m) and negative linear steps. */
static void test_golden_step(void **state)
{
    (void)state;
    check_golden("step.tvonn", "step.golden", 0x78, 4, TVO_NN_ACT_ELU, TVO_NN_ACT_SIGMOID);
    check_golden("steplin.tvonn", "steplin.golden", 0x40, 1, TVO_NN_ACT_SELU, TVO_NN_ACT_SELU);
}

static void test_null_and_memory(void **state)
{
    blob m = read_file("tiny.tvonn");
    size_t need = 0;
    tvo_nn *nn = (tvo_nn *)&need;
    uint8_t *mem;
    float feat[TVO_FEAT_COUNT] = {0}, out[6];
    (void)state;
    assert_non_null(m.data);
    assert_int_equal(tvo_nn_required_size(NULL, m.size, &need), TVO_ERR_NULL);
    assert_int_equal(tvo_nn_required_size(m.data, m.size, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_nn_required_size(m.data, m.size, &need), TVO_OK);
    mem = (uint8_t *)malloc(need);
    assert_non_null(mem);
    assert_int_equal(tvo_nn_load(NULL, m.data, m.size, mem, need), TVO_ERR_NULL);
    assert_int_equal(tvo_nn_load(&nn, NULL, m.size, mem, need), TVO_ERR_NULL);
    assert_null(nn);
    assert_int_equal(tvo_nn_load(&nn, m.data, m.size, NULL, need), TVO_ERR_NULL);
    assert_int_equal(tvo_nn_load(&nn, m.data, m.size, mem, need - 1), TVO_ERR_NO_MEMORY);
    assert_null(nn);
    assert_int_equal(tvo_nn_load(&nn, m.data, m.size, mem, 0), TVO_ERR_NO_MEMORY);
    assert_int_equal(tvo_nn_load(&nn, m.data, m.size, mem, need), TVO_OK);
    assert_int_equal(tvo_nn_run(NULL, feat, out), TVO_ERR_NULL);
    assert_int_equal(tvo_nn_run(nn, NULL, out), TVO_ERR_NULL);
    assert_int_equal(tvo_nn_run(nn, feat, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_nn_run(nn, feat, out), TVO_OK);
    feat[TVO_FEAT_DT] = NAN;
    assert_int_equal(tvo_nn_run(nn, feat, out), TVO_ERR_NOT_FINITE);
    assert_true(isnan(out[0]) && isnan(out[5]));
    feat[TVO_FEAT_DT] = -INFINITY;
    assert_int_equal(tvo_nn_run(nn, feat, out), TVO_ERR_NOT_FINITE);
    feat[TVO_FEAT_DT] = 1e38f; /* finite but huge: saturates */
    assert_int_equal(tvo_nn_run(nn, feat, out), TVO_OK);
    assert_true(isfinite(out[0]));
    assert_int_equal(tvo_nn_output_mask(NULL), 0);
    assert_int_equal(tvo_nn_macs(NULL), 0);
    assert_int_equal(tvo_nn_branch_count(NULL), 0);
    assert_int_equal(tvo_nn_branch_activation(nn, 6), TVO_NN_ACT_NONE);
    assert_int_equal(tvo_nn_branch_activation(nn, -1), TVO_NN_ACT_NONE);
    free(mem);
    free(m.data);
}

/* One corruption: a copy of the tiny model, mutated by `edit`, CRC fixed unless keep_crc. */
typedef void (*edit_fn)(uint8_t *f, size_t *size);

static void expect(const blob *good, edit_fn edit, int fix, tvo_status want, const char *what)
{
    uint8_t *f = (uint8_t *)malloc(good->size + 64);
    size_t size = good->size;
    tvo_status got;
    assert_non_null(f);
    memcpy(f, good->data, good->size);
    memset(f + good->size, 0, 64);
    edit(f, &size);
    if (fix && size >= 64)
        fix_crc(f, size);
    got = status_of(f, size);
    if (got != want)
        fail_msg("%s: got %d (%s), want %d (%s)", what, (int)got, tvo_status_str(got), (int)want,
                 tvo_status_str(want));
    free(f);
}

static void e_short(uint8_t *f, size_t *s)
{
    (void)f;
    *s = 63;
}
static void e_trunc(uint8_t *f, size_t *s)
{
    (void)f;
    *s -= 1;
}
static void e_empty(uint8_t *f, size_t *s)
{
    (void)f;
    *s = 0;
}
static void e_oversize(uint8_t *f, size_t *s)
{
    (void)f;
    *s += 16;
}
static void e_oversize_hdr(uint8_t *f, size_t *s)
{
    *s += 16;
    put32(f + 8, (uint32_t)*s);
}
static void e_magic(uint8_t *f, size_t *s)
{
    (void)s;
    f[0] = 'X';
}
static void e_major(uint8_t *f, size_t *s)
{
    (void)s;
    f[4] = 2;
}
static void e_minor_newer(uint8_t *f, size_t *s)
{
    (void)s;
    f[6] = 7;
    put32(f + 60, 123);
}
static void e_crc(uint8_t *f, size_t *s)
{
    f[*s - 1] ^= 1;
}
static void e_header_size(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + 16, 128);
}
static void e_layer_entry_size(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + 40, 32);
}
static void e_layout(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + 20, TVO_FEAT_LAYOUT_ID + 1);
}
static void e_nfeat(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + 24, TVO_FEAT_COUNT + 1);
}
static void e_reserved_hdr(uint8_t *f, size_t *s)
{
    (void)s;
    f[50] = 1;
}
static void e_nb0(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + 28, 0);
}
static void e_nb7(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + 28, 7);
}
static void e_bt_past(uint8_t *f, size_t *s)
{
    put32(f + 32, (uint32_t)*s - 40);
}
static void e_bt_in_header(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + 32, 16);
}
static void e_bt_misaligned(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + 32, get32(f + 32) + 2);
}
static void e_dof_range(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 2), TVO_NN_CODE_COUNT);
}
static void e_step_in_1_0(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 3), TVO_NN_CODE_STEP);
}
static void e_log_step_in_1_0(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 3), TVO_NN_CODE_LOG_STEP);
}
/* on tiny (1.0, tx..rz) declared 1.1: a step branch replacing rx, beside tx ty tz */
static void e_step_with_t(uint8_t *f, size_t *s)
{
    (void)s;
    f[6] = 1;
    put32(branch_entry(f, 3), TVO_NN_CODE_STEP);
}
/* on step.tvonn (log step, rx, ry, rz): */
static void e_step_both(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 1), TVO_NN_CODE_STEP);
}
static void e_step_dup(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 1), TVO_NN_CODE_LOG_STEP);
}
static void e_step_plus_tz(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 3), TVO_NN_TZ);
}
static void e_step_plus_tx_first(uint8_t *f, size_t *s)
{
    (void)s; /* tx before the step branch: refused whatever the order */
    put32(branch_entry(f, 0), TVO_NN_TX);
    put32(branch_entry(f, 1), TVO_NN_CODE_LOG_STEP);
}
static void e_step_minor0(uint8_t *f, size_t *s)
{
    (void)s;
    f[6] = 0;
}
static void e_step_code8(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 0), 8);
}
static void e_step_linear(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 0), TVO_NN_CODE_STEP);
}
static void e_dof_dup(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 2), 1);
}
static void e_n_inputs0(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 0) + 4, 0);
}
static void e_n_inputs_big(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 0) + 4, TVO_FEAT_COUNT + 1);
}
static void e_n_layers0(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 0) + 8, 0);
}
static void e_n_layers_big(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 0) + 8, TVO_NN_MAX_LAYERS + 1);
}
static void e_inputs_past(uint8_t *f, size_t *s)
{
    put32(branch_entry(f, 1) + 12, (uint32_t)*s - 8);
}
static void e_layers_huge(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 1) + 16, 0xFFFFFFFCu);
}
static void e_branch_reserved(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 0) + 40, 1);
}
static void e_in_scale0(uint8_t *f, size_t *s)
{
    (void)s;
    putf(branch_entry(f, 0) + 20, 0.0f);
}
static void e_in_scale_neg(uint8_t *f, size_t *s)
{
    (void)s;
    putf(branch_entry(f, 0) + 20, -1.0f);
}
static void e_in_zp(uint8_t *f, size_t *s)
{
    (void)s;
    put32(branch_entry(f, 0) + 24, 128);
}
static void e_out_scale_nan(uint8_t *f, size_t *s)
{
    (void)s;
    putf(branch_entry(f, 3) + 28, NAN);
}
static void e_out_offset_inf(uint8_t *f, size_t *s)
{
    (void)s;
    putf(branch_entry(f, 3) + 32, INFINITY);
}
static void e_feat_id(uint8_t *f, size_t *s)
{
    (void)s;
    put32(input_entry(f, 0, 3), TVO_FEAT_COUNT);
}
static void e_norm_nan(uint8_t *f, size_t *s)
{
    (void)s;
    putf(input_entry(f, 0, 3) + 4, NAN);
}
static void e_norm_zero(uint8_t *f, size_t *s)
{
    (void)s;
    putf(input_entry(f, 0, 3) + 4, 0.0f);
}
static void e_norm_off_inf(uint8_t *f, size_t *s)
{
    (void)s;
    putf(input_entry(f, 0, 3) + 8, -INFINITY);
}
static void e_chain(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 1), get32(layer_entry(f, 0, 1)) + 1);
}
static void e_first_chain(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0), 10);
}
static void e_n_out0(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0) + 4, 0);
}
static void e_n_out_huge(uint8_t *f, size_t *s)
{
    (void)s; /* n_in * n_out would overflow 32 bits */
    put32(layer_entry(f, 0, 0) + 4, 0x80000001u);
}
static void e_act(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0) + 8, TVO_NN_ACT_COUNT);
}
static void e_kind(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0) + 12, 2);
}
static void e_kind_f32_hidden(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0) + 12, TVO_NN_OUT_F32);
}
static void e_kind_s8_last(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 2) + 12, TVO_NN_OUT_S8);
}
static void e_zp_range(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 1) + 20, (uint32_t)-129);
}
static void e_zp_chain(uint8_t *f, size_t *s)
{
    uint8_t *e = layer_entry(f, 0, 1);
    (void)s;
    put32(e + 16, get32(e + 16) == 5 ? 6 : 5);
}
static void e_layer_scale0(uint8_t *f, size_t *s)
{
    (void)s;
    putf(layer_entry(f, 0, 0) + 32, 0.0f);
}
static void e_layer_scale_inf(uint8_t *f, size_t *s)
{
    (void)s;
    putf(layer_entry(f, 0, 1) + 36, INFINITY);
}
static void e_w_past(uint8_t *f, size_t *s)
{
    put32(layer_entry(f, 0, 0) + 40, ((uint32_t)*s - 32) & ~15u);
}
static void e_w_misaligned(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0) + 40, get32(layer_entry(f, 0, 0) + 40) + 4);
}
static void e_w_zero(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0) + 40, 0);
}
static void e_bias_past(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 1, 1) + 44, 0xFFFFFFF0u);
}
static void e_shift_f32(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 2) + 52, 64);
}
static void e_lut_missing(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0) + 56, 0);
}
static void e_lut_for_none(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 2) + 56, 64);
}
static void e_layer_reserved(uint8_t *f, size_t *s)
{
    (void)s;
    put32(layer_entry(f, 0, 0) + 60, 9);
}
static void e_mult_small(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + get32(layer_entry(f, 0, 0) + 48) + 4, 0x3FFFFFFFu);
}
static void e_mult_neg(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + get32(layer_entry(f, 0, 0) + 48), 0x80000000u);
}
static void e_shift0(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + get32(layer_entry(f, 0, 1) + 52), 0);
}
static void e_shift63(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + get32(layer_entry(f, 0, 1) + 52) + 8, 63);
}
static void e_bias_overflow(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + get32(layer_entry(f, 0, 0) + 44), 0x7FFFFF00u);
}
static void e_bias_overflow_neg(uint8_t *f, size_t *s)
{
    (void)s;
    put32(f + get32(layer_entry(f, 2, 1) + 44), 0x80000000u);
}
static void e_dq_zero(uint8_t *f, size_t *s)
{
    (void)s;
    putf(f + get32(layer_entry(f, 4, 2) + 48), 0.0f);
}
static void e_dq_nan(uint8_t *f, size_t *s)
{
    (void)s;
    putf(f + get32(layer_entry(f, 4, 2) + 48), NAN);
}

static void test_bad_files(void **state)
{
    blob g = read_file("tiny.tvonn");
    uint8_t *copy;
    (void)state;
    assert_non_null(g.data);
    assert_int_equal(status_of(g.data, g.size), TVO_OK);
    /* the layout this test assumes: 6 branches, 3 layers each, a LUT on the hidden layers */
    assert_int_equal(get32(g.data + 28), 6);
    assert_int_equal(get32(branch_entry(g.data, 0) + 8), 3);
    assert_int_equal(get32(branch_entry(g.data, 0) + 4), TVO_FEAT_COUNT);
    assert_true(get32(layer_entry(g.data, 0, 0) + 56) != 0);

    expect(&g, e_short, 0, TVO_ERR_SIZE, "shorter than header");
    expect(&g, e_empty, 0, TVO_ERR_SIZE, "empty");
    expect(&g, e_trunc, 0, TVO_ERR_SIZE, "truncated");
    expect(&g, e_oversize, 0, TVO_ERR_SIZE, "trailing bytes");
    expect(&g, e_oversize_hdr, 1, TVO_OK, "trailing zero bytes declared in the header");
    expect(&g, e_magic, 0, TVO_ERR_FORMAT, "magic");
    expect(&g, e_major, 0, TVO_ERR_VERSION, "major version");
    expect(&g, e_minor_newer, 1, TVO_OK, "newer minor version with reserved bytes used");
    expect(&g, e_crc, 0, TVO_ERR_CRC, "crc");
    expect(&g, e_header_size, 1, TVO_ERR_SIZE, "header size");
    expect(&g, e_layer_entry_size, 1, TVO_ERR_SIZE, "layer entry size");
    expect(&g, e_layout, 1, TVO_ERR_MISMATCH, "layout id");
    expect(&g, e_nfeat, 1, TVO_ERR_MISMATCH, "feature count");
    expect(&g, e_reserved_hdr, 1, TVO_ERR_FORMAT, "reserved header bytes");
    expect(&g, e_nb0, 1, TVO_ERR_SIZE, "no branch");
    expect(&g, e_nb7, 1, TVO_ERR_SIZE, "7 branches");
    expect(&g, e_bt_past, 1, TVO_ERR_RANGE, "branch table past the end");
    expect(&g, e_bt_in_header, 1, TVO_ERR_RANGE, "branch table inside the header");
    expect(&g, e_bt_misaligned, 1, TVO_ERR_FORMAT, "branch table misaligned");
    expect(&g, e_dof_range, 1, TVO_ERR_RANGE, "dof code 8");
    expect(&g, e_step_in_1_0, 1, TVO_ERR_FORMAT, "step-length code in a 1.0 file");
    expect(&g, e_log_step_in_1_0, 1, TVO_ERR_FORMAT, "log-step code in a 1.0 file");
    expect(&g, e_step_with_t, 1, TVO_ERR_FORMAT, "step-length branch beside tx ty tz (1.1)");
    expect(&g, e_dof_dup, 1, TVO_ERR_FORMAT, "duplicated dof");
    expect(&g, e_n_inputs0, 1, TVO_ERR_SIZE, "0 inputs");
    expect(&g, e_n_inputs_big, 1, TVO_ERR_SIZE, "too many inputs");
    expect(&g, e_n_layers0, 1, TVO_ERR_SIZE, "0 layers");
    expect(&g, e_n_layers_big, 1, TVO_ERR_SIZE, "too many layers");
    expect(&g, e_inputs_past, 1, TVO_ERR_RANGE, "input table past the end");
    expect(&g, e_layers_huge, 1, TVO_ERR_RANGE, "layer table offset near 2^32");
    expect(&g, e_branch_reserved, 1, TVO_ERR_FORMAT, "branch reserved");
    expect(&g, e_in_scale0, 1, TVO_ERR_NOT_FINITE, "input scale 0");
    expect(&g, e_in_scale_neg, 1, TVO_ERR_NOT_FINITE, "input scale < 0");
    expect(&g, e_in_zp, 1, TVO_ERR_RANGE, "input zero point 128");
    expect(&g, e_out_scale_nan, 1, TVO_ERR_NOT_FINITE, "output scale NaN");
    expect(&g, e_out_offset_inf, 1, TVO_ERR_NOT_FINITE, "output offset inf");
    expect(&g, e_feat_id, 1, TVO_ERR_RANGE, "feature id out of range");
    expect(&g, e_norm_nan, 1, TVO_ERR_NOT_FINITE, "normalisation scale NaN");
    expect(&g, e_norm_zero, 1, TVO_ERR_NOT_FINITE, "normalisation scale 0");
    expect(&g, e_norm_off_inf, 1, TVO_ERR_NOT_FINITE, "normalisation offset inf");
    expect(&g, e_chain, 1, TVO_ERR_FORMAT, "layer sizes do not chain");
    expect(&g, e_first_chain, 1, TVO_ERR_FORMAT, "first layer does not match the inputs");
    expect(&g, e_n_out0, 1, TVO_ERR_SIZE, "0 outputs");
    expect(&g, e_n_out_huge, 1, TVO_ERR_SIZE, "huge layer (overflowing product)");
    expect(&g, e_act, 1, TVO_ERR_UNSUPPORTED, "unknown activation");
    expect(&g, e_kind, 1, TVO_ERR_UNSUPPORTED, "unknown output kind");
    expect(&g, e_kind_f32_hidden, 1, TVO_ERR_FORMAT, "float output on a hidden layer");
    expect(&g, e_kind_s8_last, 1, TVO_ERR_FORMAT, "int8 output on the last layer");
    expect(&g, e_zp_range, 1, TVO_ERR_RANGE, "zero point -129");
    expect(&g, e_zp_chain, 1, TVO_ERR_FORMAT, "zero points do not chain");
    expect(&g, e_layer_scale0, 1, TVO_ERR_NOT_FINITE, "layer scale 0");
    expect(&g, e_layer_scale_inf, 1, TVO_ERR_NOT_FINITE, "layer scale inf");
    expect(&g, e_w_past, 1, TVO_ERR_RANGE, "weights past the end");
    expect(&g, e_w_misaligned, 1, TVO_ERR_FORMAT, "weights misaligned");
    expect(&g, e_w_zero, 1, TVO_ERR_RANGE, "weights offset 0");
    expect(&g, e_bias_past, 1, TVO_ERR_RANGE, "bias offset near 2^32");
    expect(&g, e_shift_f32, 1, TVO_ERR_FORMAT, "shift table on the float layer");
    expect(&g, e_lut_missing, 1, TVO_ERR_FORMAT, "LUT missing");
    expect(&g, e_lut_for_none, 1, TVO_ERR_FORMAT, "LUT on a layer without activation");
    expect(&g, e_layer_reserved, 1, TVO_ERR_FORMAT, "layer reserved");
    expect(&g, e_mult_small, 1, TVO_ERR_RANGE, "multiplier < 2^30");
    expect(&g, e_mult_neg, 1, TVO_ERR_RANGE, "multiplier negative");
    expect(&g, e_shift0, 1, TVO_ERR_RANGE, "shift 0");
    expect(&g, e_shift63, 1, TVO_ERR_RANGE, "shift 63");
    expect(&g, e_bias_overflow, 1, TVO_ERR_RANGE, "bias + worst-case sum overflows int32");
    expect(&g, e_bias_overflow_neg, 1, TVO_ERR_RANGE, "bias INT32_MIN");
    expect(&g, e_dq_zero, 1, TVO_ERR_NOT_FINITE, "dequantisation scale 0");
    expect(&g, e_dq_nan, 1, TVO_ERR_NOT_FINITE, "dequantisation scale NaN");

    /* every truncation is refused, with or without the header's size patched */
    copy = (uint8_t *)malloc(g.size);
    assert_non_null(copy);
    {
        size_t n;
        for (n = 0; n < g.size; n += 7) {
            memcpy(copy, g.data, g.size);
            assert_true(status_of(copy, n) != TVO_OK);
            if (n >= 64) {
                put32(copy + 8, (uint32_t)n);
                fix_crc(copy, n);
                assert_true(status_of(copy, n) != TVO_OK);
            }
        }
    }
    free(copy);
    free(g.data);
}

/* Step-length models (format 1.1): inconsistent combinations refused, the valid ones loaded; a 1.0
 * reader's view (minor 0) of a step file refused. */
static void test_bad_step_files(void **state)
{
    blob g = read_file("step.tvonn");
    (void)state;
    assert_non_null(g.data);
    assert_int_equal(status_of(g.data, g.size), TVO_OK);
    assert_int_equal(g.data[6], 1); /* minor version 1 */
    assert_int_equal(get32(branch_entry(g.data, 0)), TVO_NN_CODE_LOG_STEP);
    expect(&g, e_step_both, 1, TVO_ERR_FORMAT, "step and log step in one model");
    expect(&g, e_step_dup, 1, TVO_ERR_FORMAT, "two log-step branches");
    expect(&g, e_step_plus_tz, 1, TVO_ERR_FORMAT, "log step beside tz");
    expect(&g, e_step_plus_tx_first, 1, TVO_ERR_FORMAT, "tx then log step");
    expect(&g, e_step_minor0, 1, TVO_ERR_FORMAT, "step file declared 1.0");
    expect(&g, e_step_code8, 1, TVO_ERR_RANGE, "code 8");
    expect(&g, e_step_linear, 1, TVO_OK, "linear step with rx ry rz");
    free(g.data);
}

static void test_kernels(void **state)
{
    int8_t x[5] = {-128, -1, 0, 1, 127}, y[3];
    int8_t lut[256];
    const int8_t w[15] = {1, 1, 1, 1, 1, -1, 0, 0, 0, 0, 127, 127, 127, 127, 127};
    const int32_t bias[3] = {0, 10, -5}, mult[3] = {1 << 30, 1 << 30, 1 << 30}, shift[3] = {31, 30, 40};
    float fy[3];
    const float sc[3] = {0.5f, 1.0f, 2.0f};
    int i;
    (void)state;
    /* ties toward +infinity: 0.5 * 3 = 1.5 -> 2, 0.5 * -3 = -1.5 -> -1, 0.5 * -1 = -0.5 -> 0 */
    assert_int_equal(tvo_nn_requantize(3, 1 << 30, 31), 2);
    assert_int_equal(tvo_nn_requantize(-3, 1 << 30, 31), -1);
    assert_int_equal(tvo_nn_requantize(-1, 1 << 30, 31), 0);
    assert_int_equal(tvo_nn_requantize(-2, 1 << 30, 31), -1);
    assert_int_equal(tvo_nn_requantize(INT32_MAX, INT32_MAX, 62), 1);
    assert_int_equal(tvo_nn_requantize(INT32_MIN, INT32_MAX, 31), -2147483647);
    assert_int_equal(tvo_nn_requantize(1, 1 << 30, 1), 1 << 29);
    /* fc: row 0 sum = -1, row 1 = 128 + 10, row 2 = 127 * -1 - 5 */
    tvo_nn_fc_s8(x, w, bias, mult, shift, 3, 5, 3, y);
    assert_int_equal(y[0], 3 + 0); /* -1 * 0.5 = -0.5 -> 0 */
    assert_int_equal(y[1], 127);   /* 138 + 3 clamps */
    assert_int_equal(y[2], 3 + 0); /* -132 * 2^-11 -> 0 */
    tvo_nn_fc_s8_f32(x, w, bias, sc, 5, 3, fy);
    assert_true(fy[0] == -0.5f && fy[1] == 138.0f && fy[2] == -264.0f);
    for (i = 0; i < 256; ++i)
        lut[i] = (int8_t)(127 - i);
    tvo_nn_lut_s8(x, 5, lut);
    assert_int_equal(x[0], 127);
    assert_int_equal(x[4], -128);
    assert_int_equal(tvo_nn_crc32(0, "123456789", 9), 0xCBF43926u);
}

/* Finite but extreme de-normalisation (out_scale, out_offset at +-FLT_MAX) passes validation, but the
 * output overflows float: the run must say TVO_ERR_NOT_FINITE with all outputs NaN, never return inf
 * (found by test/fuzz/fuzz_nn). With +FLT_MAX and -FLT_MAX scales one of the two overflows unless the
 * branch's raw output is exactly 0. */
static void test_output_overflow(void **state)
{
    static const float sign[2] = {1.0f, -1.0f};
    blob m = read_file("tiny.tvonn");
    int overflowed = 0;
    (void)state;
    assert_non_null(m.data);
    for (int k = 0; k < 2; ++k) {
        float feat[TVO_FEAT_COUNT], out[6];
        size_t need = 0;
        void *mem;
        tvo_nn *nn = NULL;
        tvo_status st;
        for (int i = 0; i < TVO_FEAT_COUNT; ++i)
            feat[i] = 0.5f;
        putf(branch_entry(m.data, 0) + 28, sign[k] * 3.4028235e38f);
        putf(branch_entry(m.data, 0) + 32, 3.4028235e38f);
        fix_crc(m.data, m.size);
        assert_int_equal(tvo_nn_required_size(m.data, m.size, &need), TVO_OK);
        mem = malloc(need);
        assert_non_null(mem);
        assert_int_equal(tvo_nn_load(&nn, m.data, m.size, mem, need), TVO_OK);
        st = tvo_nn_run(nn, feat, out);
        if (st == TVO_OK) {
            for (int d = 0; d < 6; ++d)
                assert_true(isfinite(out[d]));
        } else {
            assert_int_equal(st, TVO_ERR_NOT_FINITE);
            for (int d = 0; d < 6; ++d)
                assert_true(isnan(out[d]));
            ++overflowed;
        }
        free(mem);
    }
    assert_true(overflowed >= 1);
    free(m.data);
}

static void test_input_quantisation(void **state)
{
    const float feat[TVO_FEAT_COUNT] = {0.25f, -0.25f, 1.0f, 1e30f, -1e30f, 0.75f, 0, 0, 0, 0, 0};
    const uint8_t ids[6] = {0, 1, 2, 3, 4, 5};
    const float ns[6] = {2, 2, 1, 1, 1, 2}, no[6] = {0, 0, 0.5f, 0, 0, 0};
    int8_t x[6];
    (void)state;
    /* t = 0.5, -0.5, 1.5, big, -big, 1.5 over scale 1: ties to even -> 0, -0, 2, clamp, clamp, 2 */
    assert_int_equal(tvo_nn_quantize_input_f32(feat, ids, ns, no, 1.0f, 10, 6, x), TVO_OK);
    assert_int_equal(x[0], 10);
    assert_int_equal(x[1], 10);
    assert_int_equal(x[2], 12);
    assert_int_equal(x[3], 127);
    assert_int_equal(x[4], -128);
    assert_int_equal(x[5], 12);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_golden_tiny),     cmocka_unit_test(test_golden_paper),
            cmocka_unit_test(test_golden_step),     cmocka_unit_test(test_bad_step_files),
            cmocka_unit_test(test_null_and_memory), cmocka_unit_test(test_bad_files),
            cmocka_unit_test(test_kernels),         cmocka_unit_test(test_input_quantisation),
            cmocka_unit_test(test_output_overflow),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
