// nurimc example: discover a controller, move it to 90 degrees, read its position until it is
// there. The LED lights when the motor has reached its target (within 1 degree).
// This is the sketch `make test-embedded` runs on simavr (an ATmega328P) against the simulator.
#include <nurimc_arduino.h>

#if defined(HAVE_HWSERIAL1)
#define BUS_PORT Serial1
#define LOG Serial
#else
#define BUS_PORT Serial
#endif

static const int DIR_PIN = 2;
static const uint32_t BAUD = 9600;
static const uint8_t LAST_ID = 15;     // discover among IDs 0..15
static const long TARGET = 9000;       // 90.00 degrees (wire unit 0.01 degree), CCW
static const long TOLERANCE = 100;     // 1.00 degree
static const uint16_t SPEED = 300;     // 30.0 rpm: slow and safe
static const unsigned long GIVE_UP_MS = 10000;

NurimcBus bus(BUS_PORT, DIR_PIN);

static int discover() {
    for (uint8_t id = 0; id <= LAST_ID; id++) {
        if (bus.ping(id)) return id;
    }
    return -1;
}

void setup() {
    pinMode(LED_BUILTIN, OUTPUT);
    digitalWrite(LED_BUILTIN, LOW);
#ifdef LOG
    LOG.begin(115200);
#endif
    bus.begin(BAUD);
}

void loop() {
    int id = discover();
    if (id < 0) {
#ifdef LOG
        LOG.println(F("no controller at IDs 0..15"));
#endif
        delay(500);
        return;
    }
    bus.move_to((uint8_t)id, TARGET, SPEED);
    const unsigned long start = millis();
    long position = 0;
    while (millis() - start < GIVE_UP_MS) {
        if (bus.position((uint8_t)id, &position) && labs(position - TARGET) <= TOLERANCE) {
            digitalWrite(LED_BUILTIN, HIGH);
#ifdef LOG
            LOG.print(F("ID "));
            LOG.print(id);
            LOG.print(F(" reached (0.01 deg): "));
            LOG.println(position);
#endif
            for (;;) {} // done: the LED stays on
        }
        delay(20);
    }
#ifdef LOG
    LOG.print(F("not at the target after 10 s; last position (0.01 deg): "));
    LOG.println(position);
#endif
}
