/* Physical values <-> wire integers (nurimc_units.h). How the decimal rule is met without decimal
 * strings: let h be a half step, (2k+1) x step / 2. The value's shortest decimal d rounds up past
 * h exactly when the double v is at least H = the double nearest h (one correctly rounded
 * division of two exact integers):
 *   - v == H: h is a short decimal (a few digits, far fewer than 15) that reads back as v, so it
 *     is v's shortest form: d == h, and halves go away from zero;
 *   - v != H: every real between v and d reads back as v, H is the double of h, so h lies not
 *     between them: d is on v's side of h, and v's side is the side of H (rounding is monotonic).
 * So the steps are the count of half steps whose double is <= v. docs/c.md, "Units". */
#include "nurimc_units.h"

#include <math.h>
#include <string.h>

#include "nurimc_host.h"

/* The double nearest (2k+1) x num / (2 x den): both integers are exact (< 2^53). */
static double half_step(unsigned long k, uint32_t num, uint32_t den) {
    return (2.0 * (double)k + 1.0) * (double)num / (2.0 * (double)den);
}

nurimc_status nurimc_units_to_wire(double value, uint32_t scale_num, uint32_t scale_den, long min, long max,
                                   long *wire) {
    double magnitude, approx;
    unsigned long limit, steps;
    long signed_steps;
    if (wire == NULL || scale_num == 0 || scale_den == 0 || min > max) return NURIMC_E_ARGUMENT;
    if (!isfinite(value)) return NURIMC_E_NOT_FINITE;
    magnitude = value < 0 ? -value : value;
    /* the largest magnitude in range; beyond it + 2 steps, no exact rounding is needed */
    limit = (unsigned long)(max > 0 ? max : 0);
    if (min < 0 && (unsigned long)-(min + 1) + 1u > limit) limit = (unsigned long)-(min + 1) + 1u;
    approx = magnitude * (double)scale_den / (double)scale_num;
    if (approx > (double)limit + 2.0) return NURIMC_E_RANGE;
    steps = (unsigned long)approx;
    while (steps > 0 && half_step(steps - 1, scale_num, scale_den) > magnitude) steps--;
    while (half_step(steps, scale_num, scale_den) <= magnitude) steps++;
    if (steps > limit) return NURIMC_E_RANGE;
    signed_steps = value < 0 ? -(long)steps : (long)steps;
    if (signed_steps < min || signed_steps > max) return NURIMC_E_RANGE;
    *wire = signed_steps;
    return NURIMC_OK;
}

double nurimc_units_from_wire(long wire, uint32_t scale_num, uint32_t scale_den) {
    if (scale_den == 0) return 0.0;
    return (double)wire * (double)scale_num / (double)scale_den;
}

nurimc_status nurimc_units_format(long wire, uint32_t scale_num, uint32_t scale_den, int negative, char *out,
                                  size_t capacity, size_t *length) {
    char digits[12]; /* 2^32 - 1 has 10 digits; with decimals + 1 leading zeros at most 11 */
    size_t count = 0, n = 0, decimals = 0, needed, i;
    uint32_t den = scale_den, magnitude;
    unsigned long raw = wire < 0 ? (unsigned long)-(wire + 1) + 1u : (unsigned long)wire;
    int minus = (negative != 0) != (wire < 0);
    if (out == NULL || scale_den == 0) return NURIMC_E_ARGUMENT;
    while (den % 10u == 0) {
        den /= 10u;
        decimals++;
    }
    if (den != 1u) return NURIMC_E_ARGUMENT; /* at most 10^9: decimals <= 9 */
    if (scale_num != 0 && raw > 0xFFFFFFFFul / scale_num) return NURIMC_E_RANGE;
    magnitude = (uint32_t)(raw * scale_num);
    do { /* least significant first, at least decimals + 1 digits ("0.05") */
        digits[count++] = (char)('0' + magnitude % 10u);
        magnitude /= 10u;
    } while (magnitude != 0 || count <= decimals);
    needed = (minus ? 1u : 0u) + count + (decimals > 0 ? 1u : 0u);
    if (needed >= capacity) {
        if (capacity > 0) out[0] = '\0';
        return NURIMC_E_BUFFER;
    }
    if (minus) out[n++] = '-';
    for (i = count; i > 0; i--) {
        if (i == decimals) out[n++] = '.';
        out[n++] = digits[i - 1];
    }
    out[n] = '\0';
    if (length != NULL) *length = n;
    return NURIMC_OK;
}

/* ---- motion ------------------------------------------------------------------------------ */

/* The scale of a field of the generated message table. */
static const nurimc_field_spec *field(nurimc_message_type type, const char *name) {
    int index = nurimc_field_index(type, name);
    return index < 0 ? NULL : &((const nurimc_field_spec *)NURIMC_TABLE_PTR(nurimc_message_specs[type].fields))[index];
}

/* A physical limit in steps of `f` (the limits lie on the steps). */
static long limit_steps(const nurimc_field_spec *f, double limit) {
    long steps = 0;
    (void)nurimc_units_to_wire(limit, NURIMC_TABLE_U16(f->scale_num), NURIMC_TABLE_U16(f->scale_den), 0, 0xFFFF,
                               &steps);
    return steps;
}

/* A value in [low, high] of `f`'s steps, either way; the magnitude and the direction. */
static nurimc_status motion_to_wire(const nurimc_field_spec *f, double value, double low, double high, uint16_t *wire,
                                    uint8_t *direction) {
    long steps = 0;
    nurimc_status status;
    if (f == NULL || wire == NULL) return NURIMC_E_ARGUMENT;
    status = nurimc_units_to_wire(value < 0 ? -value : value, NURIMC_TABLE_U16(f->scale_num),
                                  NURIMC_TABLE_U16(f->scale_den), limit_steps(f, low), limit_steps(f, high), &steps);
    if (status != NURIMC_OK) return status;
    *wire = (uint16_t)steps;
    if (direction != NULL) *direction = value < 0 ? 1u : 0u;
    return NURIMC_OK;
}

static double motion_from_wire(const nurimc_field_spec *f, uint16_t wire, uint8_t direction) {
    double value =
        f == NULL ? 0.0
                  : nurimc_units_from_wire((long)wire, NURIMC_TABLE_U16(f->scale_num), NURIMC_TABLE_U16(f->scale_den));
    return direction != 0 ? -value : value;
}

nurimc_status nurimc_degrees_to_wire(double degrees, uint16_t *position, uint8_t *direction) {
    if (direction == NULL) return NURIMC_E_ARGUMENT;
    return motion_to_wire(field(NURIMC_MSG_POSITION_SPEED, "position"), degrees, 0.0, NURIMC_LIMIT_POSITION_DEG,
                          position, direction);
}

nurimc_status nurimc_rpm_to_wire(double rpm, uint16_t *speed, uint8_t *direction) {
    if (direction == NULL) return NURIMC_E_ARGUMENT;
    return motion_to_wire(field(NURIMC_MSG_ACCEL_SPEED, "speed"), rpm, NURIMC_LIMIT_SPEED_RPM_MIN,
                          NURIMC_LIMIT_SPEED_RPM_MAX, speed, direction);
}

nurimc_status nurimc_seconds_to_wire(double seconds, uint16_t *arrival_time) {
    const nurimc_field_spec *f = field(NURIMC_MSG_ACCEL_SPEED, "arrival_time");
    long steps = 0;
    nurimc_status status;
    if (f == NULL || arrival_time == NULL) return NURIMC_E_ARGUMENT;
    status = nurimc_units_to_wire(seconds, NURIMC_TABLE_U16(f->scale_num), NURIMC_TABLE_U16(f->scale_den),
                                  limit_steps(f, NURIMC_LIMIT_ARRIVAL_S_MIN),
                                  limit_steps(f, NURIMC_LIMIT_ARRIVAL_S_MAX), &steps);
    if (status == NURIMC_OK) *arrival_time = (uint16_t)steps;
    return status;
}

double nurimc_degrees_from_wire(uint16_t position, uint8_t direction) {
    return motion_from_wire(field(NURIMC_MSG_POSITION_SPEED, "position"), position, direction);
}

double nurimc_rpm_from_wire(uint16_t speed, uint8_t direction) {
    return motion_from_wire(field(NURIMC_MSG_ACCEL_SPEED, "speed"), speed, direction);
}

double nurimc_seconds_from_wire(uint16_t arrival_time) {
    return motion_from_wire(field(NURIMC_MSG_ACCEL_SPEED, "arrival_time"), arrival_time, 0);
}

/* ---- settings ---------------------------------------------------------------------------- */

nurimc_status nurimc_setting_to_wire(const nurimc_setting *setting, double value, uint16_t *wire) {
    long steps = 0;
    nurimc_status status;
    double magnitude = value < 0 ? -value : value;
    if (setting == NULL || wire == NULL) return NURIMC_E_ARGUMENT;
    if (!isfinite(value)) return NURIMC_E_NOT_FINITE;
    if (setting->input != NURIMC_INPUT_QUANTIZE) {
        /* a whole number of the unit; far beyond the range is a range error, not a fraction */
        if (magnitude * (double)setting->scale_den / (double)setting->scale_num > 65537.0) return NURIMC_E_RANGE;
        if ((double)(long)value != value) return NURIMC_E_FRACTION;
    }
    status = nurimc_units_to_wire(value, setting->scale_num, setting->scale_den, setting->min, setting->max, &steps);
    if (status == NURIMC_OK) *wire = (uint16_t)steps;
    return status;
}

nurimc_status nurimc_setting_choice_to_wire(const nurimc_setting *setting, const char *name, uint16_t *wire) {
    uint16_t i;
    if (setting == NULL || name == NULL || wire == NULL) return NURIMC_E_ARGUMENT;
    for (i = 0; i < sizeof setting->value_names / sizeof setting->value_names[0]; i++) {
        if (setting->value_names[i] != NULL && strcmp(setting->value_names[i], name) == 0) {
            *wire = i;
            return NURIMC_OK;
        }
    }
    return NURIMC_E_RANGE;
}

const char *nurimc_setting_choice_name(const nurimc_setting *setting, uint16_t wire) {
    if (setting == NULL || wire >= sizeof setting->value_names / sizeof setting->value_names[0]) return NULL;
    return setting->value_names[wire];
}

double nurimc_setting_from_wire(const nurimc_setting *setting, uint16_t wire) {
    return setting == NULL ? 0.0 : nurimc_units_from_wire((long)wire, setting->scale_num, setting->scale_den);
}
