/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: umbrella header. Include this, or only the module headers you need. */
#ifndef TINYVO_TINYVO_H
#define TINYVO_TINYVO_H

#include "tinyvo/version.h"
#include "tinyvo/status.h"
#include "tinyvo/options.h"
#include "tinyvo/types.h"
#include "tinyvo/image.h"
#include "tinyvo/pyramid.h"
#include "tinyvo/corners.h"
#include "tinyvo/lk.h"
#include "tinyvo/camera.h"
#include "tinyvo/se3.h"
#include "tinyvo/relpose.h"
#include "tinyvo/ba.h"
#include "tinyvo/nn.h"
#include "tinyvo/vo.h"

#endif
