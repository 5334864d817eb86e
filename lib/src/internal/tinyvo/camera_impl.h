/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the camera model's pieces that other modules of the core use (internal). */
#ifndef TINYVO_CAMERA_IMPL_H
#define TINYVO_CAMERA_IMPL_H

/* RADTAN's distortion of normalised (x, y) with k = {k1, k2, p1, p2, k3}; J (when not NULL) receives
 * d(xd, yd)/d(x, y), row-major 2x2 (camera.h gives the model). */
void tvo_camera_radtan(const double *k, double x, double y, double *xd, double *yd, double *J);

#endif /* TINYVO_CAMERA_IMPL_H */
