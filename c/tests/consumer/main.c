/* Uses both installed libraries: exits 0 if a frame round-trips and the timeout is computed. */
#include <nurimc_posix.h>

int main(void) {
    nurimc_message ping = nurimc_message_init(NURIMC_MSG_REQUEST_PING, 1), back;
    nurimc_bus bus;
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0;
    if (nurimc_encode(&ping, frame, sizeof frame, &length, NULL) != NURIMC_OK) return 1;
    if (nurimc_decode(frame, length, &back) != NURIMC_OK || back.type != NURIMC_MSG_REQUEST_PING) return 2;
    bus.port.baud = 9600;
    bus.adapter_latency_us = bus.margin_us = bus.response_time_us = 0;
    return nurimc_bus_answer_timeout_us(&bus, NURIMC_MSG_REQUEST_PING) == 12500u ? 0 : 3;
}
