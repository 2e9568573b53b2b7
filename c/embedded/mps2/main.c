/*
 * nurimc on a Cortex-M, bare metal: discover a controller, move it to 90 degrees, read its
 * position until it is there. Built for ARMv6-M (-mcpu=cortex-m0plus: the instruction set of
 * the smallest Cortex-M parts) and run by `make test-embedded` on QEMU's ARM MPS2 AN385 board
 * (a Cortex-M3, which executes every ARMv6-M instruction), UART0 connected to the simulator.
 * The result leaves through semihosting: a line of text and the exit status (0: reached).
 */
#include <stdint.h>

#include "nurimc.h"
#include "nurimc_host.h"

#define CPU_HZ     25000000u /* the AN385's system clock */
#define BAUD       9600u
#define LAST_ID    15u
#define TARGET     9000L /* 90.00 degrees */
#define TOLERANCE  100L  /* 1.00 degree */
#define SPEED      300u  /* 30.0 rpm */
#define GIVE_UP_MS 10000u
/* The adapter latency of this link, each way (the host layer's NURIMC_HOST_ADAPTER_LATENCY_US is
   2 ms for a pty or a tuned USB adapter): QEMU's CMSDK UART holds one received byte and takes the
   next on a later turn of QEMU's event loop, so on a loaded machine an answer arrives byte by
   byte, far slower than the wire, while SysTick keeps real time. */
#define LINK_LATENCY_US 100000u

/* CMSDK APB UART0 */
#define UART0_DATA    (*(volatile uint32_t *)0x40004000u)
#define UART0_STATE   (*(volatile uint32_t *)0x40004004u)
#define UART0_CTRL    (*(volatile uint32_t *)0x40004008u)
#define UART0_BAUDDIV (*(volatile uint32_t *)0x40004010u)
#define STATE_TX_FULL 1u
#define STATE_RX_FULL 2u
/* SysTick */
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)

static volatile uint32_t ticks_ms;

/* --- semihosting: text and exit status to the host running QEMU ------------------------------ */
static int semihost(int op, const void *arg) {
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

static void say(const char *text) {
    semihost(0x04, text); /* SYS_WRITE0 */
}

static void say_number(long value) {
    char buf[12];
    int at = (int)sizeof buf - 1;
    unsigned long magnitude = value < 0 ? (unsigned long)-value : (unsigned long)value;
    buf[at] = 0;
    do {
        buf[--at] = (char)('0' + magnitude % 10u);
        magnitude /= 10u;
    } while (magnitude != 0u && at > 1);
    if (value < 0) buf[--at] = '-';
    say(&buf[at]);
}

static void finish(int ok) {
    semihost(0x18, (const void *)(uintptr_t)(ok ? 0x20026u : 0x20023u)); /* SYS_EXIT: exited / runtime error */
    for (;;) {}
}

/* --- the board --------------------------------------------------------------------------------- */
void systick_handler(void) {
    ticks_ms++;
}

static void board_init(void) {
    UART0_BAUDDIV = CPU_HZ / BAUD;
    UART0_CTRL = 3u; /* TX and RX enabled */
    SYST_RVR = CPU_HZ / 1000u - 1u;
    SYST_CVR = 0u;
    SYST_CSR = 7u; /* processor clock, interrupt, enabled */
}

static void uart_write(const uint8_t *data, size_t length) {
    size_t i;
    for (i = 0; i < length; i++) {
        while (UART0_STATE & STATE_TX_FULL) {}
        UART0_DATA = data[i];
    }
}

static int uart_read(uint8_t *byte) {
    if (!(UART0_STATE & STATE_RX_FULL)) return 0;
    *byte = (uint8_t)UART0_DATA;
    return 1;
}

/* --- the protocol ------------------------------------------------------------------------------ */
static nurimc_parser parser;

static int send(const nurimc_message *msg) {
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0;
    if (nurimc_encode(msg, frame, sizeof frame, &length, NULL) != NURIMC_OK) return 0;
    uart_write(frame, length);
    return 1;
}

/* wire time of request and answer + the largest response time + the link's latency + margin */
static uint32_t answer_timeout_ms(nurimc_message_type type) {
    uint32_t bytes = nurimc_spec(type)->size + 4u + nurimc_spec(nurimc_spec(type)->answer)->size + 4u;
    uint32_t us = bytes * NURIMC_HOST_BITS_PER_BYTE * 1000000u / BAUD + NURIMC_HOST_MAX_RESPONSE_TIME_US +
                  2u * LINK_LATENCY_US + NURIMC_HOST_MARGIN_US;
    return us / 1000u + 1u;
}

static int request(nurimc_message_type type, uint8_t id, nurimc_message *answer) {
    nurimc_message ask = nurimc_message_init(type, id);
    uint32_t start, limit = answer_timeout_ms(type);
    uint8_t byte;
    while (uart_read(&byte)) {}
    nurimc_parser_clear(&parser);
    if (!send(&ask)) return 0;
    start = ticks_ms;
    while (ticks_ms - start < limit) {
        if (uart_read(&byte) && nurimc_parser_push(&parser, byte, answer) &&
            answer->type == nurimc_spec(type)->answer && answer->id == id) {
            return 1;
        }
    }
    return 0;
}

static void wait_ms(uint32_t ms) {
    uint32_t start = ticks_ms;
    while (ticks_ms - start < ms) {}
}

int main(void) {
    nurimc_message answer, move;
    uint32_t start;
    long position = 0;
    int id = -1;
    unsigned candidate, round;

    board_init();
    nurimc_parser_init(&parser);
    for (round = 0; round < 5 && id < 0; round++) { /* a busy or slow bus: look again */
        for (candidate = 0; candidate <= LAST_ID && id < 0; candidate++) {
            if (request(NURIMC_MSG_REQUEST_PING, (uint8_t)candidate, &answer)) id = (int)candidate;
        }
    }
    if (id < 0) {
        say("no controller at IDs 0..15 (5 rounds)\n");
        finish(0);
    }
    say("found a controller at ID ");
    say_number(id);
    say("\n");
    move = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, (uint8_t)id);
    move.u.position_speed.direction = 0;
    move.u.position_speed.position = (uint16_t)TARGET;
    move.u.position_speed.speed = SPEED;
    send(&move);
    start = ticks_ms;
    while (ticks_ms - start < GIVE_UP_MS) {
        if (request(NURIMC_MSG_REQUEST_POSITION, (uint8_t)id, &answer)) {
            position = (long)answer.u.position_feedback.position;
            if (answer.u.position_feedback.direction) position = -position;
            if (position - TARGET <= TOLERANCE && TARGET - position <= TOLERANCE) {
                say("reached (0.01 deg): ");
                say_number(position);
                say("\n");
                finish(1);
            }
        }
        wait_ms(20);
    }
    say("not at the target after 10 s; last position (0.01 deg): ");
    say_number(position);
    say("\n");
    finish(0);
    return 1;
}

/* --- start-up: vector table, .data and .bss ---------------------------------------------------- */
extern uint32_t __data_load, __data_start, __data_end, __bss_start, __bss_end, __stack_top;

void reset_handler(void) {
    uint32_t *src = &__data_load, *dst = &__data_start;
    while (dst < &__data_end) *dst++ = *src++;
    for (dst = &__bss_start; dst < &__bss_end;) *dst++ = 0;
    finish(main() == 0);
}

static void fault_handler(void) {
    say("fault\n");
    finish(0);
}

#define VECTOR(f) ((uintptr_t)(f))
__attribute__((section(".vectors"), used)) static const uintptr_t vectors[16] = {
    (uintptr_t)&__stack_top,
    VECTOR(reset_handler),
    VECTOR(fault_handler),
    VECTOR(fault_handler),
    VECTOR(fault_handler),
    VECTOR(fault_handler),
    VECTOR(fault_handler),
    0u,
    0u,
    0u,
    0u,
    VECTOR(fault_handler),
    VECTOR(fault_handler),
    0u,
    VECTOR(fault_handler),
    VECTOR(systick_handler),
};
