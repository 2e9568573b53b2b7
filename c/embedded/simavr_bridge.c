/*
 * Run an AVR firmware on simavr with its UART0 wired to a serial device (the nurimc
 * simulator's pseudo-terminal), in real time, until a pin goes high or a deadline passes.
 *
 *   simavr_bridge -d DEVICE -b BAUD [-m MCU] [-f HZ] [-p PORT:PIN] [-t SECONDS] [-l LOG] FIRMWARE.elf
 *
 * DEVICE is opened raw 8N1 at BAUD (the simulator reads the rate off its pty). The AVR's own
 * rate (from UBRR0 and U2X0, as the firmware set them) is printed with its error from BAUD, and
 * an error above 2.5 % is refused: a real controller would read garbage. The simulated clock is
 * held to the wall clock (never ahead of it), so the firmware's millis() timeouts see the
 * simulator's answers when a real bus would deliver them. Exit 0 when PORT:PIN (default B5,
 * the Uno's LED) goes high, 1 on the deadline or a crash, 2 on bad arguments.
 * LOG: the bus traffic as a nurimc traffic log (JSON lines {"t", "dir", "hex"}; "tx" is what
 * the AVR sent; t is the AVR's clock in seconds).
 *
 * Written for libsimavr 1.6 (Debian 12: libsimavr-dev, libsimavrparts1 are not needed).
 */
#define _DEFAULT_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_irq.h>

/* USART0 registers (data-space addresses) of the ATmega328P and ATmega2560 */
#define UCSR0A 0xC0
#define U2X0   1
#define UBRR0L 0xC4
#define UBRR0H 0xC5

static int device = -1;
static FILE *traffic = NULL;
static avr_t *avr = NULL;
static int pin_high = 0, tx_blocked = 0;
static unsigned char rx_queue[4096];
static size_t rx_head = 0, rx_tail = 0;
static unsigned char tx_line[64];
static size_t tx_len = 0;
static double tx_line_t = 0.0, tx_last_t = 0.0, byte_time = 0.0;

/* The lowest stack pointer seen (checked after every instruction): how much stack the firmware used. */
static uint16_t lowest_sp = 0xFFFF;
#define SPL          0x5D
#define SPH          0x5E
#define RAM_START    0x100 /* ATmega328P / 2560: registers and I/O below */
#define MIN_FREE_RAM 64    /* bytes never touched by data, bss or stack: less fails the run */

static double avr_seconds(void) {
    return (double)avr->cycle / (double)avr->frequency;
}

static void log_bytes(const char *dir, double t, const unsigned char *data, size_t n) {
    size_t i;
    if (traffic == NULL || n == 0) return;
    fprintf(traffic, "{\"t\": %.6f, \"dir\": \"%s\", \"hex\": \"", t, dir);
    for (i = 0; i < n; i++) fprintf(traffic, "%02x", data[i]);
    fprintf(traffic, "\"}\n");
}

static void flush_tx_line(void) {
    log_bytes("tx", tx_line_t, tx_line, tx_len);
    tx_len = 0;
}

/* A byte the firmware wrote to UDR0: onto the wire, and into the log (runs of bytes one line). */
static void uart_out(struct avr_irq_t *irq, uint32_t value, void *param) {
    unsigned char byte = (unsigned char)value;
    double now = avr_seconds();
    (void)irq;
    (void)param;
    if (write(device, &byte, 1) != 1) perror("simavr_bridge: write to the device");
    if (tx_len == sizeof tx_line || (tx_len > 0 && now - tx_last_t > 2.5 * byte_time)) flush_tx_line();
    if (tx_len == 0) tx_line_t = now;
    tx_line[tx_len++] = byte;
    tx_last_t = now;
}

static void uart_xon(struct avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)value, (void)param;
    tx_blocked = 0;
}

static void uart_xoff(struct avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)value, (void)param;
    tx_blocked = 1;
}

static void pin_changed(struct avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    if (value) pin_high = 1;
}

static speed_t termios_speed(long baud) {
    switch (baud) {
    case 1200: return B1200;
    case 2400: return B2400;
    case 4800: return B4800;
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 500000: return B500000;
    case 1000000: return B1000000;
    default: return 0;
    }
}

static int open_device(const char *path, long baud) {
    struct termios tio;
    speed_t speed = termios_speed(baud);
    int fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (fd < 0) {
        fprintf(stderr, "simavr_bridge: %s: %s\n", path, strerror(errno));
        return -1;
    }
    if (speed == 0 || tcgetattr(fd, &tio) != 0) {
        fprintf(stderr, "simavr_bridge: %s: cannot set %ld bps\n", path, baud);
        close(fd);
        return -1;
    }
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    cfsetispeed(&tio, speed);
    cfsetospeed(&tio, speed);
    if (tcsetattr(fd, TCSANOW, &tio) != 0) {
        fprintf(stderr, "simavr_bridge: %s: %s\n", path, strerror(errno));
        close(fd);
        return -1;
    }
    return fd;
}

static double wall_seconds(const struct timespec *start) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)(now.tv_sec - start->tv_sec) + (double)(now.tv_nsec - start->tv_nsec) / 1e9;
}

/* The rate the firmware programmed, once it has (0 before). */
static double avr_baud(void) {
    unsigned ubrr = (unsigned)avr->data[UBRR0L] | ((unsigned)(avr->data[UBRR0H] & 0x0F) << 8);
    unsigned divisor = (avr->data[UCSR0A] & (1u << U2X0)) ? 8u : 16u;
    if (ubrr == 0 && avr->data[UBRR0L] == 0) return 0.0;
    return (double)avr->frequency / (double)(divisor * (ubrr + 1u));
}

static void usage(void) {
    fprintf(
        stderr,
        "usage: simavr_bridge -d DEVICE -b BAUD [-m MCU] [-f HZ] [-p PORT:PIN] [-t SECONDS] [-l LOG] FIRMWARE.elf\n");
}

int main(int argc, char **argv) {
    const char *path = NULL, *mcu = "atmega328p", *log_path = NULL;
    long baud = 0, frequency = 16000000;
    double deadline = 60.0, reported_baud = 0.0;
    char port = 'B';
    int pin = 5, opt, result = 1;
    elf_firmware_t firmware;
    struct timespec start;
    uint32_t flags = 0;

    while ((opt = getopt(argc, argv, "d:b:m:f:p:t:l:")) != -1) {
        switch (opt) {
        case 'd': path = optarg; break;
        case 'b': baud = strtol(optarg, NULL, 10); break;
        case 'm': mcu = optarg; break;
        case 'f': frequency = strtol(optarg, NULL, 10); break;
        case 'p':
            if (sscanf(optarg, "%c:%d", &port, &pin) != 2 || pin < 0 || pin > 7) {
                usage();
                return 2;
            }
            break;
        case 't': deadline = strtod(optarg, NULL); break;
        case 'l': log_path = optarg; break;
        default: usage(); return 2;
        }
    }
    if (optind != argc - 1 || path == NULL || baud <= 0 || frequency <= 0 || !(deadline > 0)) {
        usage();
        return 2;
    }
    byte_time = 10.0 / (double)baud;
    memset(&firmware, 0, sizeof firmware);
    if (elf_read_firmware(argv[optind], &firmware) != 0) {
        fprintf(stderr, "simavr_bridge: %s: not an AVR ELF firmware\n", argv[optind]);
        return 2;
    }
    if (firmware.mmcu[0] == 0) snprintf(firmware.mmcu, sizeof firmware.mmcu, "%s", mcu);
    if (firmware.frequency == 0) firmware.frequency = (uint32_t)frequency;
    avr = avr_make_mcu_by_name(firmware.mmcu);
    if (avr == NULL) {
        fprintf(stderr, "simavr_bridge: unknown MCU %s\n", firmware.mmcu);
        return 2;
    }
    avr_init(avr);
    avr->log = 1; /* errors only */
    avr_load_firmware(avr, &firmware);

    device = open_device(path, baud);
    if (device < 0) return 2;
    if (log_path != NULL && (traffic = fopen(log_path, "w")) == NULL) {
        fprintf(stderr, "simavr_bridge: %s: %s\n", log_path, strerror(errno));
        return 2;
    }
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~(uint32_t)AVR_UART_FLAG_STDIO; /* the UART is the bus, not a console */
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port), pin), pin_changed, NULL);
    avr_irq_t *uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);

    clock_gettime(CLOCK_MONOTONIC, &start);
    for (;;) {
        int state = avr_run(avr);
        uint16_t sp = (uint16_t)(avr->data[SPL] | (avr->data[SPH] << 8));
        if (sp < lowest_sp && sp >= RAM_START) lowest_sp = sp;
        if (state == cpu_Sleeping && !avr->sreg[S_I]) state = cpu_Done; /* nothing can wake it */
        if (state == cpu_Done || state == cpu_Crashed) {
            fprintf(stderr, "simavr_bridge: the firmware %s at %.3f s\n", state == cpu_Done ? "stopped" : "crashed",
                    avr_seconds());
            break;
        }
        if ((avr->cycle & 0x3FF) > 0x10 && !pin_high) continue; /* the rest every ~1k cycles */
        if (reported_baud == 0.0 && avr_baud() > 0.0) {
            double error = (avr_baud() - (double)baud) / (double)baud * 100.0;
            reported_baud = avr_baud();
            printf("firmware UART0: %.0f bps (%+.2f %% from %ld)\n", reported_baud, error, baud);
            fflush(stdout);
            if (fabs(error) > 2.5) {
                fprintf(stderr, "simavr_bridge: %.2f %% off %ld bps: a receiver would read garbage\n", error, baud);
                break;
            }
        }
        if (pin_high) {
            printf("pin %c%d high at %.3f s (AVR clock)\n", port, pin, avr_seconds());
            result = 0;
            break;
        }
        if (rx_head == rx_tail) {
            ssize_t n = read(device, rx_queue, sizeof rx_queue);
            if (n > 0) {
                rx_head = 0;
                rx_tail = (size_t)n;
                log_bytes("rx", avr_seconds(), rx_queue, (size_t)n);
            }
        }
        while (rx_head < rx_tail && !tx_blocked) avr_raise_irq(uart_in, rx_queue[rx_head++]);
        {
            double ahead = avr_seconds() - wall_seconds(&start);
            if (ahead > 0.0005) usleep((useconds_t)(ahead * 1e6));
        }
        if (wall_seconds(&start) > deadline) {
            fprintf(stderr, "simavr_bridge: pin %c%d not high after %.0f s (AVR clock %.3f s)\n", port, pin, deadline,
                    avr_seconds());
            break;
        }
    }
    flush_tx_line();
    {
        long statics = (long)firmware.datasize + (long)firmware.bsssize;
        long stack = (long)avr->ramend - (long)lowest_sp;
        long free_ram = (long)lowest_sp - RAM_START - statics;
        printf("RAM: %ld bytes data+bss, %ld bytes of stack at most, %ld bytes never used\n", statics, stack, free_ram);
        if (free_ram < MIN_FREE_RAM) {
            fprintf(stderr, "simavr_bridge: only %ld bytes of RAM left free (at least %d wanted)\n", free_ram,
                    MIN_FREE_RAM);
            result = 1;
        }
    }
    if (traffic != NULL) fclose(traffic);
    close(device);
    return result;
}
