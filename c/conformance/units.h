/* Physical values <-> wire integers by the shared rule (docs/protocol.md, conformance/README.md
 * "units"). The C library speaks wire integers only; this is the rule as C code, header-only, for
 * the conformance program (a host application may copy it). */
#ifndef NURIMC_CONFORMANCE_UNITS_H
#define NURIMC_CONFORMANCE_UNITS_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* log10 of a power of ten, or -1. */
static int units_decimal_exponent(unsigned long n) {
    int e = 0;
    if (n == 0) return -1;
    while (n % 10u == 0) {
        n /= 10u;
        e++;
    }
    return n == 1 ? e : -1;
}

/* `value` at a step of num/den (each a power of ten: 1/100, 1/10, 100/1) -> the nearest
 * step, halves away from zero, computed exactly on the value's shortest decimal form.
 * Returns 0 and *steps, or -1 when value is not finite or beyond +-1e15 (past every range). */
static int units_to_wire(double value, unsigned long num, unsigned long den, long *steps) {
    char text[40];
    int digits, exponent, shift, i;
    uint64_t mantissa = 0, q, p;
    const char *c;
    int en = units_decimal_exponent(num), ed = units_decimal_exponent(den);
    double magnitude = value < 0 ? -value : value;
    if (!isfinite(value) || magnitude > 1e15 || en < 0 || ed < 0) return -1;
    /* the shortest decimal that reads back as the same double: what repr() and JS print */
    for (digits = 1; digits <= 17; digits++) {
        snprintf(text, sizeof text, "%.*e", digits - 1, magnitude);
        if (strtod(text, NULL) == magnitude) break;
    }
    for (c = text; *c != 'e'; c++) {
        if (*c >= '0' && *c <= '9') mantissa = mantissa * 10u + (uint64_t)(*c - '0');
    }
    exponent = atoi(c + 1) - (digits - 1);
    /* |value| / step = mantissa x 10^shift */
    shift = exponent + ed - en;
    if (shift >= 0) {
        for (i = 0; i < shift; i++) mantissa *= 10u; /* |value| <= 1e15 and the step >= 0.01: no overflow */
        q = mantissa;
    } else if (-shift > 19) {
        q = 0; /* mantissa < 1e17 < half of 10^20 */
    } else {
        for (p = 1, i = 0; i < -shift; i++) p *= 10u;
        q = mantissa / p;
        if ((mantissa % p) * 2u >= p) q++;
    }
    *steps = value < 0 ? -(long)q : (long)q;
    return 0;
}

/* The physical value of `raw` steps (negated when `negative`) of num/den, exact, as JSON number text in `out`. */
static void units_from_wire(long raw, unsigned long num, unsigned long den, int negative, char *out,
                            unsigned long size) {
    unsigned long magnitude = (unsigned long)(raw < 0 ? -raw : raw) * num;
    int decimals = units_decimal_exponent(den) % 10; /* steps of 0.1, 0.01 (never below 1e-9) */
    const char *sign = (negative != (raw < 0)) ? "-" : "";
    unsigned long divisor = 1;
    int i;
    for (i = 0; i < decimals; i++) divisor *= 10u;
    if (decimals <= 0) {
        snprintf(out, size, "%s%lu", sign, magnitude);
    } else {
        snprintf(out, size, "%s%lu.%0*lu", sign, magnitude / divisor, decimals, magnitude % divisor);
    }
}

#endif
