/*
 * A bare-metal Cortex-M program that links the whole core (encode, decode, parser), so the
 * CI size figure is what firmware pays. The "UART" is a byte loop-back in RAM.
 */
#include "nurimc.h"

static uint8_t wire[NURIMC_MAX_FRAME_LENGTH];

int main(void) {
    nurimc_parser parser;
    nurimc_message msg = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, 1), got;
    size_t length = 0, i;
    int frames = 0;
    msg.u.position_speed.position = 9000;
    msg.u.position_speed.speed = 300;
    if (nurimc_encode(&msg, wire, sizeof wire, &length, NULL) != NURIMC_OK) return 1;
    if (nurimc_decode(wire, length, &got) != NURIMC_OK) return 2;
    nurimc_parser_init(&parser);
    for (i = 0; i < length; i++) frames += nurimc_parser_push(&parser, wire[i], &got);
    return frames == 1 ? 0 : 3;
}
