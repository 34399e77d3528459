/* Host stub (skyloop tools) for the firmware's rate-curve functions extracted from fc/rc.c by
   tools/gen_betaflight_rates.sh: the rate profile they read, with the field types of the firmware's
   controlRateConfig_t (uint8_t), and nothing else. No firmware code. */
#pragma once
#include <stdint.h>
#include <math.h>
#include "common/maths.h"
typedef struct {
    uint8_t rcRates[3];
    uint8_t rcExpo[3];
    uint8_t rates[3];
    uint8_t quickRatesRcExpo;
} rateProfileStub_t;
extern const rateProfileStub_t *currentControlRateProfile;
