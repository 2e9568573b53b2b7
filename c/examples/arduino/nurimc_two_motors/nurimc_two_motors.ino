// nurimc example: two controllers on one bus (IDs 1 and 2) move to mirrored positions, back
// and forth, and report where they are. The LED is on while both answer.
#include <nurimc_arduino.h>

#if defined(HAVE_HWSERIAL1)
#define BUS_PORT Serial1
#define LOG Serial
#else
#define BUS_PORT Serial
#endif

static const int DIR_PIN = 2;
static const uint32_t BAUD = 9600;
static const uint8_t LEFT = 1, RIGHT = 2;
static const uint16_t SPEED = 300; // 30.0 rpm

NurimcBus bus(BUS_PORT, DIR_PIN);

void setup() {
    pinMode(LED_BUILTIN, OUTPUT);
#ifdef LOG
    LOG.begin(115200);
#endif
    bus.begin(BAUD);
}

void loop() {
    static bool out = false;
    out = !out;
    const long target = out ? 4500 : 0; // 45.00 degrees and back
    bus.move_to(LEFT, target, SPEED);
    bus.move_to(RIGHT, -target, SPEED);
    delay(2000);
    long left = 0, right = 0;
    bool ok = bus.position(LEFT, &left) && bus.position(RIGHT, &right);
    digitalWrite(LED_BUILTIN, ok ? HIGH : LOW);
#ifdef LOG
    LOG.print(F("left "));
    LOG.print(left);
    LOG.print(F(", right "));
    LOG.println(right);
#endif
}
