/* Host stub of the firmware's platform.h for tools/gen_betaflight_filters.sh: the filter and maths
   sources include it only for placement attributes (FAST_CODE, ...), which are empty on the host.
   Written for skyloop; no firmware code. */
#pragma once
#include <stdint.h>
#include <stdbool.h>
#define FAST_CODE
#define FAST_CODE_NOINLINE
#define FAST_CODE_PREF
#define NOINLINE
#define UNUSED(x) (void)(x)
