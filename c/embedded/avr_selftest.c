/*
 * The core on an ATmega328P with its tables in program memory (the Arduino package's copy:
 * NURIMC_TABLES_IN_FLASH), every message type once: fields set to in-range values read from
 * the flash tables, encoded, decoded, parsed byte by byte, each result compared; the frames go
 * out on UART0 so the harness can compare them with the Python library's encoding. PB5 (the
 * Uno's LED) goes high when every check passed; then the CPU sleeps with interrupts off, which
 * stops simavr. Run by `make test-embedded` (run_embedded.py avr-selftest).
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <util/delay.h>
#include <string.h>

#include "nurimc.h"

static void uart_init(void) {
    UBRR0H = 0;
    UBRR0L = 103; /* 16 MHz / 16 / (103 + 1) = 9615 bps */
    UCSR0A = 0;
    UCSR0B = (uint8_t)(1u << TXEN0);
    UCSR0C = (uint8_t)((1u << UCSZ01) | (1u << UCSZ00)); /* 8N1 */
}

static void uart_put(uint8_t byte) {
    while (!(UCSR0A & (1u << UDRE0))) {}
    UDR0 = byte;
}

/* The value the harness expects for field i of type t: inside the field's range. */
static uint16_t pattern(unsigned t, unsigned i, uint16_t lo, uint16_t hi) {
    uint32_t span = (uint32_t)hi - lo + 1u;
    return (uint16_t)(lo + (uint16_t)(((uint32_t)t * 7u + (uint32_t)i * 13u) % span));
}

static int check_type(unsigned t) {
    const nurimc_message_spec *spec = nurimc_spec((nurimc_message_type)t);
    const nurimc_field_spec *fields = spec->fields; /* in flash: read with NURIMC_TABLE_* */
    uint8_t count = spec->field_count, mode = spec->mode, size = spec->size;
    nurimc_message msg = nurimc_message_init((nurimc_message_type)t, (uint8_t)(t % 200u)), back, parsed;
    nurimc_parser parser;
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0, k;
    int ok = 1, frames = 0;
    unsigned i;
    for (i = 0; i < count; i++) {
        uint16_t lo = NURIMC_TABLE_U16(fields[i].min), hi = NURIMC_TABLE_U16(fields[i].max);
        if (nurimc_set_field(&msg, (int)i, pattern(t, i, lo, hi)) != NURIMC_OK) ok = 0;
    }
    if (nurimc_encode(&msg, frame, sizeof frame, &length, NULL) != NURIMC_OK) return 0;
    if (length != (size_t)size + 4u || frame[5] != mode) ok = 0;
    if (nurimc_type_by_mode(mode) != (nurimc_message_type)t) ok = 0;
    if (nurimc_decode(frame, length, &back) != NURIMC_OK || back.type != msg.type || back.id != msg.id) ok = 0;
    nurimc_parser_init(&parser);
    for (k = 0; k < length; k++) {
        if (nurimc_parser_push(&parser, frame[k], &parsed)) {
            frames++;
            if (k != length - 1u || parsed.type != msg.type || parsed.id != msg.id) ok = 0;
        }
    }
    if (frames != 1) ok = 0;
    for (i = 0; i < count; i++) {
        uint16_t want = nurimc_get_field(&msg, (int)i);
        if (nurimc_get_field(&back, (int)i) != want || nurimc_get_field(&parsed, (int)i) != want) ok = 0;
    }
    for (k = 0; k < length; k++) uart_put(frame[k]);
    return ok;
}

int main(void) {
    unsigned t;
    int ok = 1;
    uart_init();
    DDRB |= (uint8_t)(1u << DDB5);
    for (t = 0; t < (unsigned)NURIMC_MESSAGE_COUNT; t++) ok &= check_type(t);
    if (nurimc_spec(NURIMC_MSG_NONE) != NULL || nurimc_type_by_mode(0x00) != NURIMC_MSG_NONE) ok = 0;
    _delay_ms(3); /* the last byte's stop bit is out (UCSR0A is left alone: simavr's flags differ) */
    if (ok) PORTB |= (uint8_t)(1u << PORTB5);
    cli();
    sleep_enable();
    sleep_cpu(); /* interrupts off: simavr ends the run */
    return 0;
}
