/* SPDX-License-Identifier: Apache-2.0 */
/* The documented limits of docs/limits.md: at and just beyond each one, the status each call returns. */
#include "tvo_guarantee.h"

/* Image views: sizes and strides. A stride above TVO_IMAGE_MAX_STRIDE used to be accepted and made
 * FAST's circle offsets (3 * stride, int32) overflow: UBSan reported it. */
static void test_image_view_limits(void **state)
{
    static uint8_t px[64];
    tvo_image ok = tvo_image_make(TVO_MAX_IMAGE_DIM, 1, TVO_MAX_IMAGE_DIM, px);
    tvo_image wide = tvo_image_make(TVO_MAX_IMAGE_DIM + 1, 1, TVO_MAX_IMAGE_DIM + 1, px);
    tvo_image tall = tvo_image_make(1, TVO_MAX_IMAGE_DIM + 1, 1, px);
    tvo_image zero = tvo_image_make(0, 1, 1, px);
    tvo_image neg = tvo_image_make(4, -1, 4, px);
    tvo_image short_stride = tvo_image_make(8, 1, 7, px);
    tvo_image max_stride = tvo_image_make(8, 1, TVO_IMAGE_MAX_STRIDE, px);
    tvo_image big_stride = tvo_image_make(8, 1, TVO_IMAGE_MAX_STRIDE + 1, px);
    tvo_image huge_stride = tvo_image_make(64, 7, INT32_MAX, px);
    tvo_image null_data = tvo_image_make(8, 8, 8, NULL);
    tvo_corner c[4];
    int32_t n = -1;
    static uint8_t scratch[1 << 16];
    (void)state;
    assert_int_equal(tvo_image_check(&ok), TVO_OK);
    assert_int_equal(tvo_image_check(&wide), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&tall), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&zero), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&neg), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&short_stride), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&max_stride), TVO_OK);
    assert_int_equal(tvo_image_check(&big_stride), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&huge_stride), TVO_ERR_SIZE);
    assert_int_equal(tvo_image_check(&null_data), TVO_ERR_NULL);
    assert_int_equal(tvo_image_check(NULL), TVO_ERR_NULL);
    /* the kernels refuse it before forming any offset (the UBSan build aborts if they do not) */
    assert_int_equal(tvo_fast9_detect(&huge_stride, 20, 1, c, 4, &n, scratch, sizeof scratch), TVO_ERR_SIZE);
    assert_int_equal(tvo_fast9_detect_rows(&huge_stride, 20, 1, 0, 16, c, 4, &n, scratch, sizeof scratch),
                     TVO_ERR_SIZE);
}

/* The VO configuration: camera size, track capacity. */
static void test_vo_config_limits(void **state)
{
    tvo_vo_config cfg;
    tvo_camera cam = tvo_g_camera(TVO_MAX_IMAGE_DIM, 16, 1000.0);
    uint8_t mem[64];
    tvo_vo *vo = NULL;
    (void)state;
    tvo_vo_config_default(&cfg, &cam);
    cfg.lk.max_level = 0;
    assert_true(tvo_vo_required_size(&cfg) > 0);
    /* memory too small: refused, nothing written beyond */
    assert_int_equal(tvo_vo_init(&vo, &cfg, mem, sizeof mem), TVO_ERR_NO_MEMORY);
    cam.width = TVO_MAX_IMAGE_DIM + 1;
    tvo_vo_config_default(&cfg, &cam);
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    assert_int_equal(tvo_vo_init(&vo, &cfg, mem, sizeof mem), TVO_ERR_ARG);
    cam = tvo_g_camera(320, 240, 250.0);
    tvo_vo_config_default(&cfg, &cam);
    cfg.max_tracks = 100000;
    cfg.min_tracks = 200;
    assert_true(tvo_vo_required_size(&cfg) > 0);
    cfg.max_tracks = 100001;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    cfg.max_tracks = 15;
    cfg.min_tracks = 10;
    cfg.min_pose_tracks = 8;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    tvo_vo_config_default(&cfg, &cam);
    cfg.lk.max_level = TVO_MAX_PYR_LEVELS; /* levels = max_level + 1 > TVO_MAX_PYR_LEVELS */
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
}

/* Weights files: the size limit is checked before the CRC pass (no buffer beyond the header is read
 * for a file that claims to be too large). */
static void test_nn_file_limits(void **state)
{
    const size_t big = (size_t)TVO_NN_MAX_FILE_SIZE + 16u;
    uint8_t *f = calloc(1, big); /* untouched pages: cheap */
    size_t need = 0;
    (void)state;
    assert_non_null(f);
    f[0] = 'T';
    f[1] = 'V';
    f[2] = 'N';
    f[3] = 'N';
    f[4] = (uint8_t)TVO_NN_VERSION_MAJOR;
    f[8] = (uint8_t)(big & 0xffu);
    f[9] = (uint8_t)((big >> 8) & 0xffu);
    f[10] = (uint8_t)((big >> 16) & 0xffu);
    f[11] = (uint8_t)((big >> 24) & 0xffu);
    assert_int_equal(tvo_nn_required_size(f, big, &need), TVO_ERR_SIZE);
    assert_int_equal(tvo_nn_required_size(f, TVO_NN_HEADER_SIZE - 1, &need), TVO_ERR_SIZE);
    free(f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_image_view_limits),
            cmocka_unit_test(test_vo_config_limits),
            cmocka_unit_test(test_nn_file_limits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
