#include "tinyvo/image.h"

tvo_image tvo_image_make(int32_t width, int32_t height, int32_t stride, uint8_t *data)
{
    tvo_image img = { width, height, stride, data };
    return img;
}

tvo_status tvo_image_check(const tvo_image *img)
{
    if (img == NULL || img->data == NULL)
        return TVO_ERR_NULL;
    if (img->width < 1 || img->height < 1 || img->width > TVO_MAX_IMAGE_DIM ||
        img->height > TVO_MAX_IMAGE_DIM || img->stride < img->width)
        return TVO_ERR_SIZE;
    return TVO_OK;
}
