/* The codec: encode, decode, range checks, error precedence, tables. */
#include <string.h>

#include "check.h"
#include "nurimc.h"

static int hex_to_bytes(const char *hex, uint8_t *out) {
    int n = 0;
    unsigned byte;
    while (*hex && sscanf(hex, "%2x", &byte) == 1) {
        out[n++] = (uint8_t)byte;
        hex += 2;
    }
    return n;
}

static void test_worked_example(void) {
    /* §1 of the document: ID 0, CCW to 180.00 deg at 100.0 RPM. */
    const uint8_t expected[] = {0xFF, 0xFE, 0x00, 0x07, 0x76, 0x01, 0x00, 0x46, 0x50, 0x03, 0xE8};
    nurimc_message msg = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, 0), back;
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0;
    int bad = 123;
    msg.u.position_speed.direction = 0;
    msg.u.position_speed.position = 18000;
    msg.u.position_speed.speed = 1000;
    CHECK_EQ(nurimc_encode(&msg, frame, sizeof frame, &length, &bad), NURIMC_OK);
    CHECK_EQ(bad, NURIMC_FIELD_NONE);
    CHECK_EQ(length, sizeof expected);
    CHECK(memcmp(frame, expected, sizeof expected) == 0);
    CHECK_EQ(nurimc_decode(expected, sizeof expected, &back), NURIMC_OK);
    CHECK_EQ(back.type, NURIMC_MSG_POSITION_SPEED);
    CHECK_EQ(back.id, 0);
    CHECK_EQ(back.u.position_speed.position, 18000);
    CHECK_EQ(back.u.position_speed.speed, 1000);
}

static void test_big_endian_fields(void) {
    nurimc_message msg = nurimc_message_init(NURIMC_MSG_SET_RATED_SPEED, 3);
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0;
    msg.u.set_rated_speed.rated_speed = 0x1234;
    CHECK_EQ(nurimc_encode(&msg, frame, sizeof frame, &length, NULL), NURIMC_OK);
    CHECK_EQ(length, 8);
    CHECK_EQ(frame[6], 0x12);
    CHECK_EQ(frame[7], 0x34);
    CHECK_EQ(frame[4], nurimc_checksum(frame, length));
    CHECK_EQ(frame[4], (uint8_t)~(3 + 4 + 0x09 + 0x12 + 0x34));
}

/* Every message at its minimum and maximum, every ID bound: encode then decode gives it back. */
static void test_round_trip_every_message(void) {
    int t, i, extreme;
    for (t = 0; t < (int)NURIMC_MESSAGE_COUNT; t++) {
        const nurimc_message_spec *spec = nurimc_spec((nurimc_message_type)t);
        for (extreme = 0; extreme < 2; extreme++) {
            nurimc_message msg = nurimc_message_init((nurimc_message_type)t, extreme ? spec->max_id : 0), back;
            uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
            size_t length = 0;
            for (i = 0; i < spec->field_count; i++) {
                CHECK_EQ(nurimc_set_field(&msg, i, extreme ? spec->fields[i].max : spec->fields[i].min), NURIMC_OK);
            }
            CHECK_EQ(nurimc_encode(&msg, frame, sizeof frame, &length, NULL), NURIMC_OK);
            CHECK_EQ(length, spec->size + 4u);
            CHECK_EQ(frame[5], spec->mode);
            CHECK_EQ(nurimc_decode(frame, length, &back), NURIMC_OK);
            CHECK_EQ(back.type, t);
            CHECK_EQ(back.id, msg.id);
            for (i = 0; i < spec->field_count; i++) CHECK_EQ(nurimc_get_field(&back, i), nurimc_get_field(&msg, i));
        }
    }
}

static void test_range_errors(void) {
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    int bad = 0;
    long values[3] = {0, 100, 1};
    nurimc_message msg = nurimc_message_init(NURIMC_MSG_REQUEST_PING, NURIMC_BROADCAST_ID);
    /* Requests are never broadcast. */
    CHECK_EQ(nurimc_encode(&msg, frame, sizeof frame, NULL, &bad), NURIMC_E_RANGE);
    CHECK_EQ(bad, NURIMC_FIELD_ID);
    /* Commands may be. */
    msg = nurimc_message_init(NURIMC_MSG_FACTORY_RESET, NURIMC_BROADCAST_ID);
    CHECK_EQ(nurimc_encode(&msg, frame, sizeof frame, NULL, &bad), NURIMC_OK);
    /* speed 0 is no valid command speed; the field's index is named. */
    msg = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, 1);
    msg.u.position_speed.position = 100;
    msg.u.position_speed.speed = 0;
    CHECK_EQ(nurimc_encode(&msg, frame, sizeof frame, NULL, &bad), NURIMC_E_RANGE);
    CHECK_EQ(bad, 2);
    msg.u.position_speed.speed = 10;
    msg.u.position_speed.position = 65534;
    CHECK_EQ(nurimc_encode(&msg, frame, sizeof frame, NULL, &bad), NURIMC_E_RANGE);
    CHECK_EQ(bad, 1);
    /* Wide values: negative and too large are range errors, not wrapped. */
    values[1] = -1;
    CHECK_EQ(nurimc_encode_values(NURIMC_MSG_POSITION_SPEED, 1, values, frame, sizeof frame, NULL, &bad),
             NURIMC_E_RANGE);
    CHECK_EQ(bad, 1);
    values[1] = 65536 + 100;
    CHECK_EQ(nurimc_encode_values(NURIMC_MSG_POSITION_SPEED, 1, values, frame, sizeof frame, NULL, &bad),
             NURIMC_E_RANGE);
    values[1] = 100;
    CHECK_EQ(nurimc_encode_values(NURIMC_MSG_POSITION_SPEED, 256, values, frame, sizeof frame, NULL, &bad),
             NURIMC_E_RANGE);
    CHECK_EQ(bad, NURIMC_FIELD_ID);
    CHECK_EQ(nurimc_encode_values(NURIMC_MSG_POSITION_SPEED, 1, values, frame, sizeof frame, NULL, &bad), NURIMC_OK);
    /* Too small a buffer, an unknown type. */
    CHECK_EQ(nurimc_encode_values(NURIMC_MSG_POSITION_SPEED, 1, values, frame, 10, NULL, &bad), NURIMC_E_BUFFER);
    msg.type = (nurimc_message_type)NURIMC_MESSAGE_COUNT;
    CHECK_EQ(nurimc_encode(&msg, frame, sizeof frame, NULL, &bad), NURIMC_E_UNKNOWN_MESSAGE);
    CHECK_EQ(nurimc_set_field(&msg, 0, 1), NURIMC_E_ARGUMENT);
    msg = nurimc_message_init(NURIMC_MSG_SET_ID, 1);
    CHECK_EQ(nurimc_set_field(&msg, 0, 256), NURIMC_E_RANGE);
}

static void expect_decode(const char *hex, nurimc_status expected) {
    uint8_t bytes[64];
    nurimc_message msg;
    int n = hex_to_bytes(hex, bytes);
    nurimc_status got = nurimc_decode(bytes, (size_t)n, &msg);
    if (got != expected) fprintf(stderr, "decode %s: got %s\n", hex, nurimc_status_name(got));
    CHECK_EQ(got, expected);
}

static void test_decode_errors_in_order(void) {
    nurimc_message msg;
    CHECK_EQ(nurimc_decode(NULL, 0, &msg), NURIMC_E_TRUNCATED);
    expect_decode("ff", NURIMC_E_TRUNCATED);
    expect_decode("00", NURIMC_E_HEADER);
    expect_decode("ffff00048c0b0064", NURIMC_E_HEADER);
    expect_decode("fffe00025d", NURIMC_E_TRUNCATED);
    expect_decode("fffe0007760100465003", NURIMC_E_TRUNCATED);
    expect_decode("fffe0007760100465003e800", NURIMC_E_TRAILING);
    expect_decode("fffe0007770100465003e8", NURIMC_E_CHECKSUM);
    expect_decode("fffe0002fd00", NURIMC_E_UNKNOWN_MODE);
    expect_decode("fffe0003ec0f01", NURIMC_E_SIZE);               /* erratum 2 as printed */
    expect_decode("fffe0003ed0e01", NURIMC_OK);                   /* as corrected */
    expect_decode("fffe0007760100465003e8ff", NURIMC_E_TRAILING); /* trailing before checksum */
    /* Out-of-range values decode as they are: direction 2. */
    expect_decode("fffe0007740102465003e8", NURIMC_OK);
}

static void test_tables(void) {
    const nurimc_message_spec *ping = nurimc_spec(NURIMC_MSG_REQUEST_PING);
    CHECK_EQ(NURIMC_MESSAGE_COUNT, 42);
    CHECK(nurimc_spec(NURIMC_MSG_NONE) == NULL);
    CHECK_EQ(nurimc_type_by_name("position_feedback"), NURIMC_MSG_POSITION_FEEDBACK);
    CHECK_EQ(nurimc_type_by_name("no_such"), NURIMC_MSG_NONE);
    CHECK_EQ(nurimc_type_by_mode(0xFD), NURIMC_MSG_FIRMWARE);
    CHECK_EQ(nurimc_type_by_mode(0x00), NURIMC_MSG_NONE);
    CHECK_EQ(ping->answer, NURIMC_MSG_PING);
    CHECK_EQ(nurimc_spec(NURIMC_MSG_PING)->request, NURIMC_MSG_REQUEST_PING);
    CHECK_EQ(nurimc_spec(NURIMC_MSG_REQUEST_FIRMWARE)->answer, NURIMC_MSG_FIRMWARE);
    CHECK_EQ(nurimc_field_index(NURIMC_MSG_SPEED_FEEDBACK, "position"), 2);
    CHECK_EQ(nurimc_spec(NURIMC_MSG_SPEED_FEEDBACK)->fields[2].scale_den, 10); /* erratum 6: 0.1 deg */
    CHECK_EQ(nurimc_baud_index(250000), 15);
    CHECK_EQ(nurimc_baud_index(9600), NURIMC_DEFAULT_BAUD_INDEX);
    CHECK_EQ(nurimc_baud_index(9601), -1);
    CHECK(strcmp(nurimc_status_name(NURIMC_E_UNKNOWN_MODE), "unknown_mode") == 0);
    CHECK(strcmp(nurimc_status_name((nurimc_status)99), "unknown_status") == 0);
    CHECK(strlen(nurimc_status_text(NURIMC_E_TIMEOUT)) > 0);
}

int main(void) {
    test_worked_example();
    test_big_endian_fields();
    test_round_trip_every_message();
    test_range_errors();
    test_decode_errors_in_order();
    test_tables();
    return check_report("test_codec");
}
