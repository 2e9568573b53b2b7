/*
 * nurimc units — physical values <-> wire integers, by the rule every nurimc library follows
 * (docs/protocol.md, conformance/README.md "units"):
 *
 *   to wire:   the value's shortest decimal form (what Python's repr and JavaScript's String
 *              print) divided by the step exactly, rounded to the nearest integer, halves away
 *              from zero (180.005 deg -> 18001 although the double is 180.00499...), then
 *              range-checked (655.334 deg -> 65533 allowed, 655.335 deg -> 65534 refused).
 *   from wire: wire x step, the double nearest the exact decimal (3 x 0.1 gives 0.3).
 *
 * No allocation, no globals, no printf: exact without any decimal string work (docs/c.md, "Units").
 * Scales are the generated tables' num/den with den a power of ten; limits come from
 * nurimc_host.h (NURIMC_LIMIT_*) and nurimc_settings.h.
 */
#ifndef NURIMC_UNITS_H
#define NURIMC_UNITS_H

#include <stddef.h>
#include <stdint.h>

#include "nurimc.h"
#include "nurimc_settings.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * `value` in units of the step scale_num/scale_den -> *wire in [min, max].
 * NURIMC_E_NOT_FINITE (NaN, +-inf), NURIMC_E_RANGE (outside [min, max] after rounding),
 * NURIMC_E_ARGUMENT (wire NULL, a zero scale). -0.0 and negatives that round to 0 give 0.
 * Exact for |min|, |max| < 2^31 and scale_num <= 1000.
 */
nurimc_status nurimc_units_to_wire(double value, uint32_t scale_num, uint32_t scale_den, long min, long max,
                                   long *wire);

/** wire x scale_num / scale_den as the nearest double (0.0 for a zero scale_den). */
double nurimc_units_from_wire(long wire, uint32_t scale_num, uint32_t scale_den);

/**
 * The exact decimal text of wire x scale_num / scale_den, with a '-' when `negative` is nonzero
 * (also for 0: "-0", as the vectors spell a direction-1 zero) or wire < 0 (not both), and a
 * NUL, into out[capacity]; *length (if not NULL) is the text's length. 40 bytes always fit.
 * NURIMC_E_BUFFER if it does not fit, NURIMC_E_ARGUMENT for a scale_den that is not a power of
 * ten, NURIMC_E_RANGE if |wire| x scale_num exceeds 2^32 - 1.
 */
nurimc_status nurimc_units_format(long wire, uint32_t scale_num, uint32_t scale_den, int negative, char *out,
                                  size_t capacity, size_t *length);

/* ---- motion: signed quantities give a magnitude and a direction (1: negative, CW) ------ */

/** Degrees (CCW +, at most NURIMC_LIMIT_POSITION_DEG either way, steps of 0.01) -> position. */
nurimc_status nurimc_degrees_to_wire(double degrees, uint16_t *position, uint8_t *direction);
/** RPM (NURIMC_LIMIT_SPEED_RPM_MIN..MAX either way, 0 refused, steps of 0.1) -> speed. */
nurimc_status nurimc_rpm_to_wire(double rpm, uint16_t *speed, uint8_t *direction);
/** Seconds of arrival or ramp time (NURIMC_LIMIT_ARRIVAL_S_MIN..MAX, steps of 0.1) -> wire. */
nurimc_status nurimc_seconds_to_wire(double seconds, uint16_t *arrival_time);

double nurimc_degrees_from_wire(uint16_t position, uint8_t direction);
double nurimc_rpm_from_wire(uint16_t speed, uint8_t direction);
double nurimc_seconds_from_wire(uint16_t arrival_time);

/* ---- settings (nurimc_settings.h) ------------------------------------------------------ */

/**
 * A setting's physical value -> its wire value, by the setting's input rule:
 * NURIMC_INPUT_QUANTIZE rounds as above; NURIMC_INPUT_INTEGER and NURIMC_INPUT_CHOICE take a
 * whole number (2.0 and 1e1 are whole; 2.5 is NURIMC_E_FRACTION). Then [min, max] of the table.
 */
nurimc_status nurimc_setting_to_wire(const nurimc_setting *setting, double value, uint16_t *wire);
/** A choice setting's value name ("on", exact) -> wire; NURIMC_E_RANGE for any other name. */
nurimc_status nurimc_setting_choice_to_wire(const nurimc_setting *setting, const char *name, uint16_t *wire);
/** The name of a choice setting's wire value, or NULL (not a choice, or no such value). */
const char *nurimc_setting_choice_name(const nurimc_setting *setting, uint16_t wire);
/** A setting's wire value -> physical value (out-of-range values convert as they are). */
double nurimc_setting_from_wire(const nurimc_setting *setting, uint16_t wire);

#ifdef __cplusplus
}
#endif

#endif
