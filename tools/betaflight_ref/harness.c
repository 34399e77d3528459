/* Drives the firmware's own filter functions (compiled from its source for the host, arithmetic
   untouched) with an impulse, a step and a chirp, and prints the coefficients and the outputs as
   JSON. Written for skyloop (tools/gen_betaflight_filters.sh builds and runs it); it contains no
   firmware code, it only calls the firmware's public filter API. */
#include <stdio.h>
#include <math.h>
#include <string.h>
#include "platform.h"
#include "common/filter.h"

#define N 240

static float input[3][N];
static const char *input_name[3] = {"impulse", "step", "chirp"};

static void make_inputs(float dt) {
    for (int i = 0; i < N; i++) {
        input[0][i] = i == 0 ? 1.0f : 0.0f;
        input[1][i] = 1.0f;
        /* 10 Hz to 0.45 of the sample rate, linear in time */
        double t = i * (double)dt, T = N * (double)dt;
        double f0 = 10.0, f1 = 0.45 / dt;
        input[2][i] = (float)sin(2.0 * M_PI * (f0 * t + 0.5 * (f1 - f0) * t * t / T));
    }
}

static void print_series(const char *name, const float *y) {
    printf("\"%s\":[", name);
    for (int i = 0; i < N; i++) printf(i ? ",%.9g" : "%.9g", y[i]);
    printf("]");
}

typedef float (*apply_fn)(void *f, float x);

static void run(const char *kind, double cutoff, double center, unsigned looptime_us, int first) {
    float dt = looptime_us * 1e-6f;
    make_inputs(dt);
    printf("%s{\"kind\":\"%s\",\"cutoff_hz\":%.9g,\"center_hz\":%.9g,\"looptime_us\":%u,", first ? "" : ",\n", kind, cutoff, center, looptime_us);
    float y[N];
    for (int s = 0; s < 3; s++) {
        if (!strcmp(kind, "pt1")) {
            pt1Filter_t f; pt1FilterInit(&f, pt1FilterGain(cutoff, dt));
            if (s == 0) printf("\"k\":%.9g,", f.k);
            for (int i = 0; i < N; i++) y[i] = pt1FilterApply(&f, input[s][i]);
#ifdef HAVE_PT2
        } else if (!strcmp(kind, "pt2")) {
            pt2Filter_t f; pt2FilterInit(&f, pt2FilterGain(cutoff, dt));
            if (s == 0) printf("\"k\":%.9g,", f.k);
            for (int i = 0; i < N; i++) y[i] = pt2FilterApply(&f, input[s][i]);
        } else if (!strcmp(kind, "pt3")) {
            pt3Filter_t f; pt3FilterInit(&f, pt3FilterGain(cutoff, dt));
            if (s == 0) printf("\"k\":%.9g,", f.k);
            for (int i = 0; i < N; i++) y[i] = pt3FilterApply(&f, input[s][i]);
#endif
        } else {
            biquadFilter_t f;
            if (!strcmp(kind, "biquad")) {
                biquadFilterInitLPF(&f, cutoff, looptime_us);
            } else {
                float q = filterGetNotchQ(center, cutoff);
                if (s == 0) printf("\"q\":%.9g,", q);
#ifdef BIQUAD_WEIGHT
                biquadFilterInit(&f, center, looptime_us, q, FILTER_NOTCH, 1.0f);
#else
                biquadFilterInit(&f, center, looptime_us, q, FILTER_NOTCH);
#endif
            }
            if (s == 0) printf("\"b\":[%.9g,%.9g,%.9g],\"a\":[%.9g,%.9g],", f.b0, f.b1, f.b2, f.a1, f.a2);
            for (int i = 0; i < N; i++) y[i] = biquadFilterApply(&f, input[s][i]);
        }
        print_series(input_name[s], y);
        printf(",");
    }
    /* The chirp itself as the harness computed it (its constants are single precision under the
       firmware's -fsingle-precision-constant), so a reader feeds the same samples. */
    print_series("chirp_input", input[2]);
    printf("}");
}

int main(void) {
    /* Loop times the firmware runs: 8 kHz, 4 kHz, 3.2 kHz (312 us: the integer microseconds the
       biquads are computed with), 2 kHz, 1 kHz. */
    unsigned loops[] = {125, 250, 312, 500, 1000};
    double cutoffs[] = {20, 90, 150, 300};
    int first = 1;
    printf("[\n");
    const char *lags[] = {"pt1", "pt2", "pt3", "biquad"};
    for (unsigned li = 0; li < sizeof loops / sizeof *loops; li++) {
        for (unsigned k = 0; k < 4; k++) {
#ifndef HAVE_PT2
            if (k == 1 || k == 2) continue;
#endif
            for (unsigned c = 0; c < 4; c++) {
                if (cutoffs[c] >= 0.45e6 / loops[li]) continue;
                run(lags[k], cutoffs[c], 0.0, loops[li], first);
                first = 0;
            }
        }
        /* notches: (centre, lower cutoff) as the firmware's gyro notch and D-term notch settings */
        double notch[][2] = {{115, 85}, {162, 142}, {260, 160}};
        for (unsigned n = 0; n < 3; n++) {
            if (notch[n][0] >= 0.45e6 / loops[li]) continue;
            run("notch", notch[n][1], notch[n][0], loops[li], first);
        }
    }
    printf("\n]\n");
    return 0;
}
