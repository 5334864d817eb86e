/* SPDX-License-Identifier: Apache-2.0 */
/* Core helpers: status strings, image views, arena. */
#include "tvo_test.h"
#include "tinyvo/arena.h"
#include "tinyvo/image.h"
#include "tinyvo/status.h"

static void test_status_strings(void **state)
{
    (void)state;
    assert_string_equal(tvo_status_str(TVO_OK), "ok");
    for (int s = TVO_ERR_MISMATCH; s < 0; ++s)
        assert_string_not_equal(tvo_status_str((tvo_status)s), "unknown status");
    assert_string_equal(tvo_status_str((tvo_status)-999), "unknown status");
}

static void test_image_check(void **state)
{
    uint8_t buf[64];
    (void)state;
    tvo_image ok = tvo_image_make(8, 8, 8, buf);
    tvo_image bad_stride = tvo_image_make(8, 8, 7, buf);
    tvo_image zero = tvo_image_make(0, 8, 8, buf);
    tvo_image neg = tvo_image_make(8, -1, 8, buf);
    tvo_image huge = tvo_image_make(TVO_MAX_IMAGE_DIM + 1, 1, TVO_MAX_IMAGE_DIM + 1, buf);
    tvo_image nodata = tvo_image_make(8, 8, 8, NULL);
    assert_int_equal(tvo_image_check(&ok), TVO_OK);
    assert_int_equal(tvo_image_check(&bad_stride), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&zero), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&neg), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&huge), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&nodata), TVO_ERR_NULL);
    assert_int_equal(tvo_image_check(NULL), TVO_ERR_NULL);
}

static void test_arena(void **state)
{
    unsigned char mem[100];
    tvo_arena a;
    (void)state;
    tvo_arena_init(&a, mem + 1, 99); /* deliberately misaligned */
    void *p = tvo_arena_alloc(&a, 10);
    assert_non_null(p);
    assert_int_equal((uintptr_t)p % TVO_ARENA_ALIGN, 0);
    void *q = tvo_arena_alloc(&a, 10);
    assert_non_null(q);
    assert_true((unsigned char *)q >= (unsigned char *)p + 10);
    size_t used = a.used;
    assert_null(tvo_arena_alloc(&a, 1000));
    assert_int_equal(a.used, used);
    assert_null(tvo_arena_alloc(&a, SIZE_MAX));
    assert_int_equal(tvo_size_mul(SIZE_MAX / 2, 3), SIZE_MAX);
    assert_int_equal(tvo_size_add(SIZE_MAX, 1), SIZE_MAX);
    assert_int_equal(tvo_arena_round(17), 32);
    tvo_arena_init(&a, NULL, 50);
    assert_null(tvo_arena_alloc(&a, 1));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_status_strings),
            cmocka_unit_test(test_image_check),
            cmocka_unit_test(test_arena),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
