/*
 * The slice of the Arduino API the sketch uses, declared only, so CI can compile the sketch
 * for Cortex-M without an Arduino core (PlatformIO's toolchains are not reachable from CI).
 * Any real core provides these with the same signatures.
 */
#ifndef NURIMC_CI_ARDUINO_H
#define NURIMC_CI_ARDUINO_H

#include <stddef.h>
#include <stdint.h>

#define HIGH 0x1
#define LOW 0x0
#define OUTPUT 0x1

class HardwareSerial {
 public:
  void begin(unsigned long baud);
  int available();
  int read();
  size_t write(const uint8_t *buffer, size_t size);
  void flush();
  size_t print(const char *text);
  size_t println(const char *text);
  size_t println(unsigned int value);
};

extern HardwareSerial Serial;
extern HardwareSerial Serial1;

void pinMode(uint8_t pin, uint8_t mode);
void digitalWrite(uint8_t pin, uint8_t value);
unsigned long millis();
void delay(unsigned long ms);

#endif
