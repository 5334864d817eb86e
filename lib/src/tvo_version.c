/* SPDX-License-Identifier: Apache-2.0 */
/* Library version at run time (version.h). */
#include "tinyvo/version.h"

const char *tvo_version(void)
{
    return TVO_VERSION_STRING;
}

long tvo_version_number(void)
{
    return TVO_VERSION_NUMBER;
}
