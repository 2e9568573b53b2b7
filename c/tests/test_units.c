/* Units: the decimal rounding rule, range edges, error codes, exact formatting (nurimc_units.h). */
#include <math.h>
#include <string.h>

#include "check.h"
#include "nurimc_units.h"

static long degrees_wire(double degrees, int *direction) {
    uint16_t wire = 0xBEEF;
    uint8_t dir = 7;
    nurimc_status status = nurimc_degrees_to_wire(degrees, &wire, &dir);
    *direction = dir;
    return status == NURIMC_OK ? (long)wire : -(long)status;
}

static void test_decimal_halves(void) {
    int direction = 0;
    /* halves that are just below the half in binary still round away from zero */
    CHECK_EQ(degrees_wire(180.005, &direction), 18001);
    CHECK_EQ(direction, 0);
    CHECK_EQ(degrees_wire(-180.005, &direction), 18001);
    CHECK_EQ(direction, 1);
    CHECK_EQ(degrees_wire(2.675, &direction), 268);
    CHECK_EQ(degrees_wire(1.005, &direction), 101);
    CHECK_EQ(degrees_wire(0.285, &direction), 29);
    /* just off the half either way */
    CHECK_EQ(degrees_wire(0.0049, &direction), 0);
    CHECK_EQ(degrees_wire(0.0051, &direction), 1);
    CHECK_EQ(degrees_wire(2.67499, &direction), 267);
    /* -0.0 is direction 0 */
    CHECK_EQ(degrees_wire(-0.0, &direction), 0);
    CHECK_EQ(direction, 0);
}

static void test_range_edges(void) {
    int direction = 0;
    uint16_t wire = 0;
    uint8_t dir = 0;
    CHECK_EQ(degrees_wire(655.33, &direction), 65533);
    CHECK_EQ(degrees_wire(655.334, &direction), 65533);
    CHECK_EQ(degrees_wire(655.335, &direction), -(long)NURIMC_E_RANGE);
    CHECK_EQ(degrees_wire(-655.335, &direction), -(long)NURIMC_E_RANGE);
    CHECK_EQ(degrees_wire(1e30, &direction), -(long)NURIMC_E_RANGE);
    CHECK_EQ(degrees_wire(HUGE_VAL, &direction), -(long)NURIMC_E_NOT_FINITE);
    CHECK_EQ(degrees_wire(-HUGE_VAL, &direction), -(long)NURIMC_E_NOT_FINITE);
    CHECK_EQ(degrees_wire(NAN, &direction), -(long)NURIMC_E_NOT_FINITE);
    /* rpm: 0 refused, 0.05 rounds up to the smallest step, 0.0499 down to 0 */
    CHECK_EQ(nurimc_rpm_to_wire(0.0, &wire, &dir), NURIMC_E_RANGE);
    CHECK_EQ(nurimc_rpm_to_wire(0.0499, &wire, &dir), NURIMC_E_RANGE);
    CHECK_EQ(nurimc_rpm_to_wire(-0.05, &wire, &dir), NURIMC_OK);
    CHECK_EQ(wire, 1);
    CHECK_EQ(dir, 1);
    CHECK_EQ(nurimc_rpm_to_wire(6553.34, &wire, &dir), NURIMC_OK);
    CHECK_EQ(wire, 65533);
    CHECK_EQ(nurimc_rpm_to_wire(6553.35, &wire, &dir), NURIMC_E_RANGE);
    /* seconds: unsigned, 0.1 .. 25.5 */
    CHECK_EQ(nurimc_seconds_to_wire(25.549, &wire), NURIMC_OK);
    CHECK_EQ(wire, 255);
    CHECK_EQ(nurimc_seconds_to_wire(25.55, &wire), NURIMC_E_RANGE);
    CHECK_EQ(nurimc_seconds_to_wire(-0.15, &wire), NURIMC_E_RANGE);
    CHECK_EQ(nurimc_degrees_to_wire(1.0, NULL, &dir), NURIMC_E_ARGUMENT);
}

static void test_generic(void) {
    long wire = 0;
    /* signed steps: a value below zero that rounds to 0 is 0, one that rounds to -1 is -1 */
    CHECK_EQ(nurimc_units_to_wire(-40.0, 100u, 1u, 0, 254, &wire), NURIMC_OK);
    CHECK_EQ(wire, 0);
    CHECK_EQ(nurimc_units_to_wire(-50.0, 100u, 1u, 0, 254, &wire), NURIMC_E_RANGE);
    CHECK_EQ(nurimc_units_to_wire(-50.0, 100u, 1u, -5, 254, &wire), NURIMC_OK);
    CHECK_EQ(wire, -1);
    CHECK_EQ(nurimc_units_to_wire(25449.0, 100u, 1u, 0, 254, &wire), NURIMC_OK);
    CHECK_EQ(wire, 254);
    CHECK_EQ(nurimc_units_to_wire(25450.0, 100u, 1u, 0, 254, &wire), NURIMC_E_RANGE);
    CHECK_EQ(nurimc_units_to_wire(1.0, 0u, 1u, 0, 254, &wire), NURIMC_E_ARGUMENT);
    CHECK_EQ(nurimc_units_to_wire(1.0, 1u, 1u, 0, 254, NULL), NURIMC_E_ARGUMENT);
}

static void test_settings(void) {
    uint16_t wire = 0;
    const nurimc_setting *kp = nurimc_setting_by_name("position-kp");
    const nurimc_setting *ratio = nurimc_setting_by_name("ratio");
    const nurimc_setting *control = nurimc_setting_by_name("control");
    CHECK(kp != NULL && ratio != NULL && control != NULL);
    if (kp == NULL || ratio == NULL || control == NULL) return;
    CHECK_EQ(nurimc_setting_to_wire(kp, 2.0, &wire), NURIMC_OK);
    CHECK_EQ(wire, 2);
    CHECK_EQ(nurimc_setting_to_wire(kp, 1e1, &wire), NURIMC_OK);
    CHECK_EQ(wire, 10);
    CHECK_EQ(nurimc_setting_to_wire(kp, 2.5, &wire), NURIMC_E_FRACTION);
    CHECK_EQ(nurimc_setting_to_wire(kp, 0.0, &wire), NURIMC_E_RANGE); /* kp is 1..254 */
    CHECK_EQ(nurimc_setting_to_wire(kp, 1e300, &wire), NURIMC_E_RANGE);
    CHECK_EQ(nurimc_setting_to_wire(kp, NAN, &wire), NURIMC_E_NOT_FINITE);
    CHECK_EQ(nurimc_setting_to_wire(ratio, 12.34, &wire), NURIMC_OK);
    CHECK_EQ(wire, 123);
    CHECK_EQ(nurimc_setting_to_wire(ratio, 12.35, &wire), NURIMC_OK);
    CHECK_EQ(wire, 124);
    CHECK_EQ(nurimc_setting_choice_to_wire(control, "off", &wire), NURIMC_OK);
    CHECK_EQ(wire, 1);
    CHECK_EQ(nurimc_setting_choice_to_wire(control, "OFF", &wire), NURIMC_E_RANGE);
    CHECK_EQ(nurimc_setting_to_wire(control, 1.0, &wire), NURIMC_OK);
    CHECK_EQ(wire, 1);
    CHECK_EQ(nurimc_setting_to_wire(control, 2.0, &wire), NURIMC_E_RANGE);
    CHECK(strcmp(nurimc_setting_choice_name(control, 0) ? nurimc_setting_choice_name(control, 0) : "", "on") == 0);
    CHECK(nurimc_setting_choice_name(control, 2) == NULL);
    CHECK(nurimc_setting_choice_name(kp, 0) == NULL);
    CHECK(nurimc_setting_from_wire(ratio, 125) == 12.5);
    CHECK(nurimc_setting_from_wire(nurimc_setting_by_name("response-time"), 3) == 300.0);
}

static void test_from_wire(void) {
    char text[16];
    size_t length = 0;
    CHECK(nurimc_degrees_from_wire(18001, 1) == -180.01);
    CHECK(nurimc_rpm_from_wire(3, 0) == 0.3); /* not 0.30000000000000004 */
    CHECK(nurimc_seconds_from_wire(255) == 25.5);
    CHECK(signbit(nurimc_rpm_from_wire(0, 1)));
    CHECK_EQ(nurimc_units_format(5, 1u, 100u, 0, text, sizeof text, &length), NURIMC_OK);
    CHECK(strcmp(text, "0.05") == 0);
    CHECK_EQ(length, 4);
    CHECK_EQ(nurimc_units_format(65533, 1u, 100u, 1, text, sizeof text, NULL), NURIMC_OK);
    CHECK(strcmp(text, "-655.33") == 0);
    CHECK_EQ(nurimc_units_format(0, 1u, 10u, 1, text, sizeof text, NULL), NURIMC_OK);
    CHECK(strcmp(text, "-0.0") == 0);
    CHECK_EQ(nurimc_units_format(254, 100u, 1u, 0, text, sizeof text, NULL), NURIMC_OK);
    CHECK(strcmp(text, "25400") == 0);
    CHECK_EQ(nurimc_units_format(-3, 1u, 10u, 0, text, sizeof text, NULL), NURIMC_OK);
    CHECK(strcmp(text, "-0.3") == 0);
    /* "-655.33" needs 8 bytes with its NUL */
    CHECK_EQ(nurimc_units_format(65533, 1u, 100u, 1, text, 7, NULL), NURIMC_E_BUFFER);
    CHECK_EQ(text[0], '\0');
    CHECK_EQ(nurimc_units_format(65533, 1u, 100u, 1, text, 8, NULL), NURIMC_OK);
    CHECK_EQ(nurimc_units_format(1, 1u, 3u, 0, text, sizeof text, NULL), NURIMC_E_ARGUMENT);
    CHECK_EQ(nurimc_units_format(1, 1u, 1u, 0, text, 0, NULL), NURIMC_E_BUFFER);
    CHECK(strcmp(nurimc_status_name(NURIMC_E_FRACTION), "fraction") == 0);
    CHECK(strcmp(nurimc_status_name(NURIMC_E_NOT_FINITE), "not_finite") == 0);
}

int main(void) {
    test_decimal_halves();
    test_range_edges();
    test_generic();
    test_settings();
    test_from_wire();
    return check_report("test_units");
}
