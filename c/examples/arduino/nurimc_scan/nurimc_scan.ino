// nurimc example: find every controller on the bus (IDs 0..253) at one baud rate.
// Prints the IDs that answer a ping (boards with Serial1); on an Uno the LED blinks once per
// controller found, then stays on. A scan at 9600 bps takes about 12 s (an empty ID waits out
// its answer time: wire time + the largest response time + margins).
#include <nurimc_arduino.h>

#if defined(HAVE_HWSERIAL1)
#define BUS_PORT Serial1
#define LOG Serial
#else
#define BUS_PORT Serial
#endif

static const int DIR_PIN = 2;
static const uint32_t BAUD = 9600;
static const uint8_t LAST_ID = 253; // 254 is the setting-only ID, 255 broadcast

NurimcBus bus(BUS_PORT, DIR_PIN);

void setup() {
    pinMode(LED_BUILTIN, OUTPUT);
#ifdef LOG
    LOG.begin(115200);
    LOG.println(F("scanning..."));
#endif
    bus.begin(BAUD);
    uint8_t found = 0;
    for (uint16_t id = 0; id <= LAST_ID; id++) {
        if (bus.ping((uint8_t)id)) {
            found++;
#ifdef LOG
            LOG.print(F("controller at ID "));
            LOG.println(id);
#endif
        }
    }
#ifdef LOG
    LOG.print(found);
    LOG.println(F(" controller(s) found"));
#endif
    for (uint8_t i = 0; i < found; i++) {
        digitalWrite(LED_BUILTIN, HIGH);
        delay(300);
        digitalWrite(LED_BUILTIN, LOW);
        delay(300);
    }
    digitalWrite(LED_BUILTIN, HIGH);
}

void loop() {}
