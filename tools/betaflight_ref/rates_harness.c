/* Drives the firmware's own rate-curve functions (extracted from fc/rc.c unchanged, compiled for
   the host) over stick deflections and prints the setpoints as JSON. Written for skyloop; it
   contains no firmware code, it only calls the five apply*Rates functions. */
#include <stdio.h>
#include "rates_stub.h"

float applyBetaflightRates(const int axis, float rcCommandf, const float rcCommandfAbs);
float applyRaceFlightRates(const int axis, float rcCommandf, const float rcCommandfAbs);
float applyKissRates(const int axis, float rcCommandf, const float rcCommandfAbs);
float applyActualRates(const int axis, float rcCommandf, const float rcCommandfAbs);
float applyQuickRates(const int axis, float rcCommandf, const float rcCommandfAbs);

static rateProfileStub_t profile;
const rateProfileStub_t *currentControlRateProfile = &profile;

int main(void) {
    typedef float (*fn)(const int, float, const float);
    fn fns[5] = {applyBetaflightRates, applyRaceFlightRates, applyKissRates, applyActualRates, applyQuickRates};
    const char *names[5] = {"betaflight", "raceflight", "kiss", "actual", "quick"};
    /* (rc_rate, expo, super rate) settings pilots use with each type, as the configurator stores them */
    int settings[][3] = {{100, 0, 70}, {120, 30, 75}, {180, 15, 80}, {230, 0, 0}, {70, 54, 67}, {20, 40, 80}, {37, 50, 0}};
    int first = 1;
    printf("[");
    for (int t = 0; t < 5; t++) {
        for (int q = 0; q < (t == 4 ? 2 : 1); q++) {
            for (unsigned s = 0; s < sizeof settings / sizeof *settings; s++) {
                profile.rcRates[0] = settings[s][0];
                profile.rcExpo[0] = settings[s][1];
                profile.rates[0] = settings[s][2];
                profile.quickRatesRcExpo = q;
                printf("%s\n{\"type\":\"%s\",\"quick_rc_expo\":%d,\"rc_rate\":%d,\"expo\":%d,\"super_rate\":%d,\"deflection\":[", first ? "" : ",", names[t], q, settings[s][0], settings[s][1], settings[s][2]);
                first = 0;
                for (int i = -100; i <= 100; i++) printf(i > -100 ? ",%.9g" : "%.9g", i / 100.0f);
                printf("],\"deg_s\":[");
                for (int i = -100; i <= 100; i++) {
                    float x = i / 100.0f;
                    printf(i > -100 ? ",%.9g" : "%.9g", fns[t](0, x, fabsf(x)));
                }
                printf("]}");
            }
        }
    }
    printf("\n]\n");
    return 0;
}
