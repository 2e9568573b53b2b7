/*
 * A small command-line example of the POSIX host layer.
 *
 *   nurimc-cli PORT BAUD ping ID
 *   nurimc-cli PORT BAUD status ID
 *   nurimc-cli PORT BAUD move ID DEGREES RPM [cw|ccw]
 *   nurimc-cli PORT BAUD gains ID KP KI KD RATED_CURRENT   (position controller settings)
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nurimc_posix.h"

static int usage(void) {
    fputs("usage: nurimc-cli PORT BAUD ping ID\n"
          "       nurimc-cli PORT BAUD status ID\n"
          "       nurimc-cli PORT BAUD move ID DEGREES RPM [cw|ccw]\n"
          "       nurimc-cli PORT BAUD gains ID KP KI KD RATED_CURRENT\n",
          stderr);
    return 2;
}

static int parse_long(const char *text, const char *what, long min, long max, long *out) {
    char *end;
    errno = 0;
    *out = strtol(text, &end, 10);
    if (errno != 0 || end == text || *end != '\0' || *out < min || *out > max) {
        fprintf(stderr, "error: %s must be an integer %ld..%ld, got '%s'\n", what, min, max, text);
        return -1;
    }
    return 0;
}

/* Physical -> wire: the nearest step, halves away from zero (as nurimc.protocol.units). */
static int to_wire(const char *text, const char *what, double steps_per_unit, long min, long max, long *out) {
    char *end;
    double value = strtod(text, &end);
    if (end == text || *end != '\0' || !isfinite(value)) {
        fprintf(stderr, "error: %s must be a number, got '%s'\n", what, text);
        return -1;
    }
    *out = fabs(value * steps_per_unit) < 1e9 ? lround(value * steps_per_unit) : max + 1;
    if (*out < min || *out > max) {
        fprintf(stderr, "error: %s %s is out of range %.2f..%.2f\n", what, text, (double)min / steps_per_unit,
                (double)max / steps_per_unit);
        return -1;
    }
    return 0;
}

static int fail(const char *doing, nurimc_status status) {
    fprintf(stderr, "error: %s: %s%s%s\n", doing, nurimc_status_text(status), status == NURIMC_E_IO ? ": " : "",
            status == NURIMC_E_IO ? strerror(errno) : "");
    if (status == NURIMC_E_TIMEOUT) {
        fputs("  check the ID, the baud rate, the wiring (A/B) and that the controller is powered\n", stderr);
    }
    return 1;
}

static int query(nurimc_bus *bus, nurimc_message_type type, uint8_t id, nurimc_message *answer) {
    nurimc_status status = nurimc_bus_query(bus, type, id, answer);
    if (status != NURIMC_OK) return fail(nurimc_spec(type)->name, status);
    return 0;
}

static int status_of(nurimc_bus *bus, uint8_t id) {
    nurimc_message a;
    if (query(bus, NURIMC_MSG_REQUEST_POSITION, id, &a)) return 1;
    printf("position   %s %.2f deg, speed %.1f rpm, current %.1f A\n", a.u.position_feedback.direction ? "cw" : "ccw",
           a.u.position_feedback.position / 100.0, a.u.position_feedback.speed / 10.0,
           a.u.position_feedback.current / 10.0);
    if (query(bus, NURIMC_MSG_REQUEST_SPEED, id, &a)) return 1;
    printf("speed      %s %.1f rpm (position %.1f deg)\n", a.u.speed_feedback.direction ? "cw" : "ccw",
           a.u.speed_feedback.speed / 10.0, a.u.speed_feedback.position / 10.0);
    if (query(bus, NURIMC_MSG_REQUEST_POSITION_GAINS, id, &a)) return 1;
    printf("pos gains  kp %u ki %u kd %u, rated current %.1f A\n", a.u.position_gains.kp, a.u.position_gains.ki,
           a.u.position_gains.kd, a.u.position_gains.rated_current / 10.0);
    if (query(bus, NURIMC_MSG_REQUEST_RESPONSE_TIME, id, &a)) return 1;
    printf("response   %u us\n", a.u.response_time.response_time * 100u);
    if (query(bus, NURIMC_MSG_REQUEST_FIRMWARE, id, &a)) return 1;
    printf("firmware   %u\n", a.u.firmware.version);
    return 0;
}

int main(int argc, char **argv) {
    nurimc_bus bus;
    nurimc_status status;
    long baud, id;
    int rc = 0;
    if (argc < 5) return usage();
    if (parse_long(argv[2], "BAUD", 110, 1000000, &baud) || parse_long(argv[4], "ID", 0, 254, &id)) return 2;
    status = nurimc_bus_open(&bus, argv[1], (uint32_t)baud);
    if (status == NURIMC_E_BAUD) {
        fprintf(stderr, "error: %ld is not one of the protocol's baud rates:", baud);
        for (id = 0; id < (long)NURIMC_BAUD_RATE_COUNT; id++)
            fprintf(stderr, " %lu", (unsigned long)nurimc_baud_rates[id]);
        fputc('\n', stderr);
        return 2;
    }
    if (status != NURIMC_OK) return fail(argv[1], status);
    if (strcmp(argv[3], "ping") == 0 && argc == 5) {
        nurimc_message a;
        rc = query(&bus, NURIMC_MSG_REQUEST_PING, (uint8_t)id, &a);
        if (rc == 0) printf("ID %ld answered\n", id);
    } else if (strcmp(argv[3], "status") == 0 && argc == 5) {
        rc = status_of(&bus, (uint8_t)id);
    } else if (strcmp(argv[3], "move") == 0 && (argc == 7 || argc == 8)) {
        nurimc_message cmd = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, (uint8_t)id);
        long position, speed;
        int cw = argc == 8 && strcmp(argv[7], "cw") == 0;
        if (argc == 8 && !cw && strcmp(argv[7], "ccw") != 0) return usage();
        if (to_wire(argv[5], "DEGREES", 100.0, 0, 65533, &position) ||
            to_wire(argv[6], "RPM", 10.0, 1, 65533, &speed)) {
            rc = 2;
        } else {
            cmd.u.position_speed.direction = (uint8_t)cw;
            cmd.u.position_speed.position = (uint16_t)position;
            cmd.u.position_speed.speed = (uint16_t)speed;
            status = nurimc_bus_send(&bus, &cmd, NULL);
            rc = status == NURIMC_OK ? 0 : fail("move", status);
        }
    } else if (strcmp(argv[3], "gains") == 0 && argc == 9) {
        nurimc_message cmd = nurimc_message_init(NURIMC_MSG_SET_POSITION_GAINS, (uint8_t)id);
        long kp, ki, kd, rated;
        if (parse_long(argv[5], "KP", 1, 254, &kp) || parse_long(argv[6], "KI", 0, 254, &ki) ||
            parse_long(argv[7], "KD", 0, 254, &kd) || parse_long(argv[8], "RATED_CURRENT", 1, 254, &rated)) {
            rc = 2;
        } else {
            cmd.u.set_position_gains.kp = (uint8_t)kp;
            cmd.u.set_position_gains.ki = (uint8_t)ki;
            cmd.u.set_position_gains.kd = (uint8_t)kd;
            cmd.u.set_position_gains.rated_current = (uint8_t)rated;
            status = nurimc_bus_send(&bus, &cmd, NULL);
            rc = status == NURIMC_OK ? 0 : fail("gains", status);
        }
    } else {
        rc = usage();
    }
    nurimc_bus_close(&bus);
    return rc;
}
