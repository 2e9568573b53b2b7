// nurimc example: ping one controller and print its position, once a second.
// Wiring: a MAX485-style transceiver, DE and RE tied to DIR_PIN (HIGH transmits), RO/DI to the
// bus UART. Boards with a second UART (Mega, Leonardo) use Serial1 for the bus and Serial (USB)
// for messages; an Uno has one UART: it is the bus, and the LED says what happened (on: answer).
#include <nurimc_arduino.h>

#if defined(HAVE_HWSERIAL1)
#define BUS_PORT Serial1
#define LOG Serial
#else
#define BUS_PORT Serial
#endif

static const int DIR_PIN = 2;
static const uint8_t MOTOR_ID = 0;
static const uint32_t BAUD = 9600; // the controllers' factory rate

NurimcBus bus(BUS_PORT, DIR_PIN);

void setup() {
    pinMode(LED_BUILTIN, OUTPUT);
#ifdef LOG
    LOG.begin(115200);
#endif
    bus.begin(BAUD);
}

void loop() {
    long position = 0;
    bool answered = bus.ping(MOTOR_ID) && bus.position(MOTOR_ID, &position);
    digitalWrite(LED_BUILTIN, answered ? HIGH : LOW);
#ifdef LOG
    if (answered) {
        LOG.print(F("position (0.01 deg): "));
        LOG.println(position);
    } else {
        LOG.println(F("no answer: check ID, baud rate, A/B wiring and power"));
    }
#endif
    delay(1000);
}
