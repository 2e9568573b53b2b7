/* Product lines: one frame, a message per line; the vendor's RSA, RSAVW and SM layouts
   (nurimc_lines.h, spec/lines.json). */
#include <string.h>

#include "check.h"
#include "nurimc_lines.h"

static void test_one_frame_per_line(void) {
    const uint8_t frame[] = {0xFF, 0xFE, 0x00, 0x04, 0xE8, 0x09, 0x00, 0x0A}; /* 09, 10 */
    nurimc_line_message msg;
    nurimc_message mc;
    CHECK_EQ(nurimc_decode(frame, sizeof frame, &mc), NURIMC_OK);
    CHECK_EQ(mc.type, NURIMC_MSG_SET_RATED_SPEED);
    CHECK_EQ(nurimc_line_decode(NURIMC_LINE_RSA, frame, sizeof frame, &msg), NURIMC_OK);
    CHECK(strcmp(nurimc_line_message_spec(NURIMC_LINE_RSA, msg.index)->name, "set_ratio") == 0);
    CHECK_EQ(msg.values[0], 10);
    CHECK_EQ(nurimc_line_decode(NURIMC_LINE_SM, frame, sizeof frame, &msg), NURIMC_E_SIZE); /* SM 09: factory reset */
    CHECK_EQ(nurimc_line_decode(NURIMC_LINE_MC, frame, sizeof frame, &msg), NURIMC_OK);
    CHECK(strcmp(nurimc_line_message_spec(NURIMC_LINE_MC, msg.index)->name, "set_rated_speed") == 0);
}

static void test_vendor_layouts(void) {
    /* RSAVW absolute position: ID 2, CW, 360.00 deg (5 bytes after the size byte) */
    const uint8_t absolute[] = {0xFF, 0xFE, 0x02, 0x05, 0xF2, 0xD9, 0x01, 0x8C, 0xA0};
    const long run[] = {0, 1000, 1};
    uint8_t out[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0;
    int bad = 0, index;
    nurimc_line_message msg;
    CHECK_EQ(nurimc_line_decode(NURIMC_LINE_RSAVW, absolute, sizeof absolute, &msg), NURIMC_OK);
    CHECK(strcmp(nurimc_line_message_spec(NURIMC_LINE_RSAVW, msg.index)->name, "absolute_position") == 0);
    CHECK_EQ(msg.id, 2);
    CHECK_EQ(msg.values[0], 1);
    CHECK_EQ(msg.values[1], 36000);
    /* SM, C# table: ramped speed is 01 */
    index = nurimc_line_message_index(NURIMC_LINE_SM_CS, "accel_speed");
    CHECK(index >= 0);
    CHECK_EQ(nurimc_line_encode_values(NURIMC_LINE_SM_CS, index, 0, run, out, sizeof out, &length, &bad), NURIMC_OK);
    CHECK_EQ(length, 10);
    CHECK_EQ(out[5], 0x01);
    CHECK_EQ(out[4], 0x0C);
    /* the agreed SM table has no ramped speed: the codes are disputed */
    CHECK_EQ(nurimc_line_message_index(NURIMC_LINE_SM, "accel_speed"), -1);
    CHECK_EQ(nurimc_line_encode_values(NURIMC_LINE_SM, -1, 0, run, out, sizeof out, &length, &bad),
             NURIMC_E_UNKNOWN_MESSAGE);
    CHECK_EQ(nurimc_line_by_name("sm-readme"), NURIMC_LINE_SM_README);
    CHECK_EQ(nurimc_line_by_name("blmc-h"), -1);
}

static size_t seen;
static void count(void *context, const nurimc_line_message *msg) {
    (void)context;
    (void)msg;
    seen++;
}

static void test_scan(void) {
    /* noise, an SM ratio answer (D4, 4 bytes), a cut header */
    const uint8_t stream[] = {0x00, 0xFF, 0xFE, 0x09, 0x04, 0x14, 0xD4, 0x00, 0x0A, 0xFF, 0xFE, 0x00};
    size_t dropped = 0;
    CHECK_EQ(nurimc_line_scan(NURIMC_LINE_SM, stream, sizeof stream, count, NULL, &dropped), 1);
    CHECK_EQ(seen, 1);
    CHECK_EQ(dropped, 4);
}

int main(void) {
    test_one_frame_per_line();
    test_vendor_layouts();
    test_scan();
    return check_report("test_lines");
}
