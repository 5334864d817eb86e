/* SPDX-License-Identifier: Apache-2.0 */
/* Image pyramids: geometry, sizes, exact pyrDown values on small cases, bad inputs. */
#include "tvo_test.h"
#include "tinyvo/pyramid.h"

static void test_required_size_and_geometry(void **state)
{
    tvo_pyramid p;
    size_t need;
    void *mem;
    (void)state;
    need = tvo_pyramid_required_size(752, 480, 4);
    assert_true(need >= 752u * 480u + 376u * 240u + 188u * 120u + 94u * 60u);
    mem = malloc(need);
    assert_non_null(mem);
    assert_int_equal(tvo_pyramid_init(&p, 752, 480, 4, mem, need), TVO_OK);
    assert_int_equal(p.levels, 4);
    assert_int_equal(p.width[3], 94);
    assert_int_equal(p.height[3], 60);
    for (int l = 0; l < 4; ++l) {
        assert_true(p.stride[l] >= p.width[l]);
        assert_int_equal((uintptr_t)p.data[l] % 16, 0);
        assert_true(p.data[l] >= (uint8_t *)mem);
        assert_true(p.data[l] + (size_t)p.stride[l] * (size_t)p.height[l] <= (uint8_t *)mem + need);
    }
    /* odd sizes: (w + 1) / 2 */
    assert_int_equal(tvo_pyramid_init(&p, 101, 33, 3, mem, need), TVO_OK);
    assert_int_equal(p.width[1], 51);
    assert_int_equal(p.height[1], 17);
    assert_int_equal(p.width[2], 26);
    assert_int_equal(p.height[2], 9);
    /* misaligned block of exactly the required size still works */
    need = tvo_pyramid_required_size(64, 48, 3);
    assert_int_equal(tvo_pyramid_init(&p, 64, 48, 3, (uint8_t *)mem + 3, need), TVO_OK);
    free(mem);
}

static void test_bad_inputs(void **state)
{
    tvo_pyramid p;
    static uint8_t mem[1 << 16];
    static uint8_t pix[64 * 48];
    tvo_image img = tvo_image_make(64, 48, 64, pix);
    tvo_image wrong = tvo_image_make(63, 48, 64, pix);
    tvo_image bad_stride = tvo_image_make(64, 48, 10, pix);
    tvo_image nodata = tvo_image_make(64, 48, 64, NULL);
    size_t need = tvo_pyramid_required_size(64, 48, 3);
    (void)state;
    assert_true(need > 0 && need <= sizeof(mem));
    assert_int_equal(tvo_pyramid_required_size(0, 48, 3), 0);
    assert_int_equal(tvo_pyramid_required_size(64, -1, 3), 0);
    assert_int_equal(tvo_pyramid_required_size(64, 48, 0), 0);
    assert_int_equal(tvo_pyramid_required_size(64, 48, TVO_MAX_PYR_LEVELS + 1), 0);
    assert_int_equal(tvo_pyramid_required_size(TVO_MAX_IMAGE_DIM + 1, 48, 1), 0);
    /* deeper than the image allows: 64x48 -> 32x24 -> 16x12 -> 8x6 (< TVO_PYR_MIN_LEVEL_DIM) */
    assert_int_equal(tvo_pyramid_required_size(64, 48, 4), 0);
    assert_int_equal(tvo_pyramid_init(&p, 64, 48, 4, mem, sizeof(mem)), TVO_ERR_ARG);
    assert_int_equal(p.levels, 0);
    assert_int_equal(tvo_pyramid_init(NULL, 64, 48, 3, mem, sizeof(mem)), TVO_ERR_NULL);
    assert_int_equal(tvo_pyramid_init(&p, 64, 48, 3, NULL, sizeof(mem)), TVO_ERR_NULL);
    assert_int_equal(tvo_pyramid_init(&p, 0, 48, 3, mem, sizeof(mem)), TVO_ERR_SIZE);
    assert_int_equal(tvo_pyramid_init(&p, 64, 48, 0, mem, sizeof(mem)), TVO_ERR_ARG);
    assert_int_equal(tvo_pyramid_init(&p, 64, 48, 3, mem, need - 1), TVO_ERR_NO_MEMORY);
    /* a zeroed (failed) pyramid cannot be built or read */
    assert_int_equal(tvo_pyramid_build(&p, &img), TVO_ERR_STATE);
    assert_null(tvo_pyramid_level(&p, 0).data);
    assert_int_equal(tvo_pyramid_init(&p, 64, 48, 3, mem, need), TVO_OK);
    assert_int_equal(tvo_pyramid_build(NULL, &img), TVO_ERR_NULL);
    assert_int_equal(tvo_pyramid_build(&p, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_pyramid_build(&p, &nodata), TVO_ERR_NULL);
    assert_int_equal(tvo_pyramid_build(&p, &bad_stride), TVO_ERR_SIZE);
    assert_int_equal(tvo_pyramid_build(&p, &wrong), TVO_ERR_MISMATCH);
    assert_int_equal(tvo_pyramid_build(&p, &img), TVO_OK);
    assert_null(tvo_pyramid_level(&p, 3).data);
    assert_null(tvo_pyramid_level(&p, -1).data);
    assert_null(tvo_pyramid_level(NULL, 0).data);
    assert_int_equal(tvo_image_check(&(tvo_image){0, 0, 0, NULL}), TVO_ERR_NULL);
    {
        tvo_image l2 = tvo_pyramid_level(&p, 2);
        assert_int_equal(tvo_image_check(&l2), TVO_OK);
        assert_int_equal(l2.width, 16);
        assert_int_equal(l2.height, 12);
    }
}

/* Reference pyrDown written the slow obvious way (5x5 kernel, reflect-101 indices). */
static int ref_reflect(int i, int n)
{
    if (n == 1)
        return 0;
    while (i < 0 || i >= n)
        i = i < 0 ? -i : 2 * n - 2 - i;
    return i;
}

static void ref_pyr_down(const uint8_t *src, int w, int h, uint8_t *dst)
{
    static const int k[5] = {1, 4, 6, 4, 1};
    int dw = (w + 1) / 2, dh = (h + 1) / 2;
    for (int y = 0; y < dh; ++y)
        for (int x = 0; x < dw; ++x) {
            int s = 0;
            for (int j = 0; j < 5; ++j)
                for (int i = 0; i < 5; ++i)
                    s += k[j] * k[i] * src[ref_reflect(2 * y - 2 + j, h) * w + ref_reflect(2 * x - 2 + i, w)];
            dst[y * dw + x] = (uint8_t)((s + 128) >> 8);
        }
}

static void test_values_match_reference(void **state)
{
    static uint8_t src[97 * 61], ref1[49 * 31], ref2[25 * 16];
    static uint8_t mem[1 << 16];
    uint64_t seed = 12345;
    tvo_pyramid p;
    (void)state;
    for (size_t i = 0; i < sizeof(src); ++i)
        src[i] = (uint8_t)(tvo_test_rand(&seed) >> 56);
    {
        tvo_image img = tvo_image_make(97, 61, 97, src);
        assert_int_equal(tvo_pyramid_init(&p, 97, 61, 3, mem, sizeof(mem)), TVO_OK);
        assert_int_equal(tvo_pyramid_build(&p, &img), TVO_OK);
    }
    ref_pyr_down(src, 97, 61, ref1);
    ref_pyr_down(ref1, 49, 31, ref2);
    for (int y = 0; y < 61; ++y)
        assert_memory_equal(p.data[0] + y * p.stride[0], src + y * 97, 97);
    for (int y = 0; y < 31; ++y)
        assert_memory_equal(p.data[1] + y * p.stride[1], ref1 + y * 49, 49);
    for (int y = 0; y < 16; ++y)
        assert_memory_equal(p.data[2] + y * p.stride[2], ref2 + y * 25, 25);
}

/* A borrowed level 0: the same levels as a full pyramid, level 0 a view of the image until
 * tvo_pyramid_keep_level0 copies it; one width x height level less memory; wrong kinds refused. */
static void test_borrowed_level0(void **state)
{
    static uint8_t src[97 * 61], kept[100 * 61], mem_full[1 << 16], mem_b[1 << 16];
    uint64_t seed = 777;
    tvo_pyramid full, b, zero;
    const size_t need_full = tvo_pyramid_required_size(97, 61, 3);
    const size_t need_b = tvo_pyramid_required_size_borrowed(97, 61, 3);
    tvo_image img = tvo_image_make(97, 61, 97, src);
    (void)state;
    for (size_t i = 0; i < sizeof(src); ++i)
        src[i] = (uint8_t)(tvo_test_rand(&seed) >> 56);
    assert_true(need_b > 0 && need_b + 97 * 61 <= need_full && need_b + 112 * 61 >= need_full);
    assert_int_equal(tvo_pyramid_required_size_borrowed(97, 61, 0), 0);
    assert_int_equal(tvo_pyramid_init_borrowed(&b, 97, 61, 3, mem_b, need_b - 1), TVO_ERR_NO_MEMORY);
    assert_int_equal(tvo_pyramid_init_borrowed(&b, 97, 61, 3, mem_b + 3, need_b), TVO_OK);
    assert_int_equal(tvo_pyramid_keep_level0(&b, kept, 100), TVO_ERR_STATE); /* not built yet */
    assert_int_equal(tvo_pyramid_build(&b, &img), TVO_ERR_STATE);
    assert_int_equal(tvo_pyramid_init(&full, 97, 61, 3, mem_full, sizeof(mem_full)), TVO_OK);
    assert_int_equal(tvo_pyramid_build_borrowed(&full, &img), TVO_ERR_STATE);
    assert_int_equal(tvo_pyramid_keep_level0(&full, kept, 100), TVO_ERR_STATE);
    assert_int_equal(tvo_pyramid_build(&full, &img), TVO_OK);
    assert_int_equal(tvo_pyramid_build_borrowed(&b, &img), TVO_OK);
    assert_true(b.data[0] == src && b.stride[0] == 97);
    for (int l = 1; l < 3; ++l)
        for (int y = 0; y < full.height[l]; ++y)
            assert_memory_equal(b.data[l] + y * b.stride[l], full.data[l] + y * full.stride[l],
                                (size_t)full.width[l]);
    assert_int_equal(tvo_pyramid_keep_level0(&b, kept, 96), TVO_ERR_SIZE);
    assert_int_equal(tvo_pyramid_keep_level0(NULL, kept, 100), TVO_ERR_NULL);
    assert_int_equal(tvo_pyramid_keep_level0(&b, NULL, 100), TVO_ERR_NULL);
    assert_int_equal(tvo_pyramid_keep_level0(&b, kept, 100), TVO_OK);
    memset(src, 0, sizeof(src)); /* the pyramid no longer reads the image */
    assert_true(b.data[0] == kept && b.stride[0] == 100);
    for (int y = 0; y < 61; ++y)
        assert_memory_equal(kept + y * 100, full.data[0] + y * full.stride[0], 97);
    {
        const tvo_image l0 = tvo_pyramid_level(&b, 0);
        assert_int_equal(tvo_image_check(&l0), TVO_OK);
        assert_true(l0.data == kept && l0.stride == 100);
    }
    memset(&zero, 0, sizeof(zero));
    assert_int_equal(tvo_pyramid_build_borrowed(&zero, &img), TVO_ERR_STATE);
    assert_int_equal(tvo_pyramid_build_borrowed(NULL, &img), TVO_ERR_NULL);
}

static void test_pyr_down_tiny(void **state)
{
    uint8_t src[7 * 7], out[4 * 4], ref[4 * 4];
    uint16_t tmp[7];
    uint64_t seed = 99;
    (void)state;
    for (int h = 1; h <= 7; ++h)
        for (int w = 1; w <= 7; ++w) {
            for (int i = 0; i < w * h; ++i)
                src[i] = (uint8_t)(tvo_test_rand(&seed) >> 56);
            tvo_image s = tvo_image_make(w, h, w, src);
            tvo_image d = tvo_image_make((w + 1) / 2, (h + 1) / 2, (w + 1) / 2, out);
            assert_int_equal(tvo_pyr_down(&s, &d, tmp), TVO_OK);
            ref_pyr_down(src, w, h, ref);
            assert_memory_equal(out, ref, (size_t)(((w + 1) / 2) * ((h + 1) / 2)));
        }
    {
        tvo_image s = tvo_image_make(7, 7, 7, src);
        tvo_image d = tvo_image_make(3, 4, 3, out);
        assert_int_equal(tvo_pyr_down(&s, &d, tmp), TVO_ERR_MISMATCH);
        assert_int_equal(tvo_pyr_down(&s, &d, NULL), TVO_ERR_NULL);
        assert_int_equal(tvo_pyr_down(NULL, &d, tmp), TVO_ERR_NULL);
    }
}

static void test_constant_image_stays_constant(void **state)
{
    static uint8_t src[40 * 30], mem[1 << 14];
    tvo_pyramid p;
    (void)state;
    memset(src, 77, sizeof(src));
    tvo_image img = tvo_image_make(40, 30, 40, src);
    assert_int_equal(tvo_pyramid_init(&p, 40, 30, 3, mem, sizeof(mem)), TVO_OK);
    assert_int_equal(tvo_pyramid_build(&p, &img), TVO_OK);
    for (int l = 1; l < 3; ++l)
        for (int y = 0; y < p.height[l]; ++y)
            for (int x = 0; x < p.width[l]; ++x)
                assert_int_equal(p.data[l][y * p.stride[l] + x], 77);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_required_size_and_geometry),
            cmocka_unit_test(test_bad_inputs),
            cmocka_unit_test(test_values_match_reference),
            cmocka_unit_test(test_borrowed_level0),
            cmocka_unit_test(test_pyr_down_tiny),
            cmocka_unit_test(test_constant_image_stays_constant),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
