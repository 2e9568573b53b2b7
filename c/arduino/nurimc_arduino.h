// nurimc for Arduino: the protocol core on a HardwareSerial port, with an optional RS485
// direction pin. Header-only C++ on top of the C core (nurimc.h): one bus object per port,
// no allocation; every wait is bounded by the wire time of the exchange.
#ifndef NURIMC_ARDUINO_H
#define NURIMC_ARDUINO_H

#include <Arduino.h>

#include "nurimc.h"
#include "nurimc_host.h"

class NurimcBus {
  public:
    // port: the UART wired to the transceiver; dir_pin: its DE/RE pins (HIGH transmits), or -1
    // for an auto-direction transceiver.
    NurimcBus(HardwareSerial &port, int dir_pin = -1) : port_(port), dir_pin_(dir_pin), baud_(9600) {
        nurimc_parser_init(&parser_);
    }

    // Factory rate: 9600. response_us: the controllers' response time (largest by default).
    void begin(uint32_t baud, uint32_t response_us = NURIMC_HOST_MAX_RESPONSE_TIME_US) {
        baud_ = baud;
        response_us_ = response_us;
        if (dir_pin_ >= 0) {
            pinMode(dir_pin_, OUTPUT);
            digitalWrite(dir_pin_, LOW);
        }
        port_.begin(baud);
    }

    // A command (never answered). False if the message does not encode (a field out of range).
    bool send(const nurimc_message &msg) {
        uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
        size_t length = 0;
        if (nurimc_encode(&msg, frame, sizeof frame, &length, NULL) != NURIMC_OK) return false;
        if (dir_pin_ >= 0) digitalWrite(dir_pin_, HIGH);
        port_.write(frame, length);
        port_.flush(); // until the last stop bit is out, then release the line
        if (dir_pin_ >= 0) digitalWrite(dir_pin_, LOW);
        return true;
    }

    // A request and its answer (type request_*, answer of the same ID); false on timeout.
    bool request(nurimc_message_type type, uint8_t id, nurimc_message *answer) {
        nurimc_message_type want = nurimc_spec(type)->answer;
        while (port_.available() > 0) port_.read(); // an old answer is not this one
        nurimc_parser_clear(&parser_);
        if (!send(nurimc_message_init(type, id))) return false;
        const unsigned long limit = answer_timeout_ms(type);
        const unsigned long start = millis();
        while (millis() - start < limit) {
            while (port_.available() > 0) {
                if (nurimc_parser_push(&parser_, (uint8_t)port_.read(), answer) && answer->type == want &&
                    answer->id == id) {
                    return true;
                }
            }
        }
        return false;
    }

    bool ping(uint8_t id) {
        nurimc_message answer;
        return request(NURIMC_MSG_REQUEST_PING, id, &answer);
    }

    // Position in 0.01 degrees, signed (CCW positive); false on timeout.
    bool position(uint8_t id, long *centidegrees) {
        nurimc_message answer;
        if (!request(NURIMC_MSG_REQUEST_POSITION, id, &answer)) return false;
        long magnitude = (long)answer.u.position_feedback.position;
        *centidegrees = answer.u.position_feedback.direction ? -magnitude : magnitude;
        return true;
    }

    // Move to a signed position (0.01 degree, absolute mode) at a speed (0.1 rpm, 1..65533).
    bool move_to(uint8_t id, long centidegrees, uint16_t decirpm) {
        nurimc_message move = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, id);
        move.u.position_speed.direction = centidegrees < 0 ? 1 : 0;
        move.u.position_speed.position = (uint16_t)(centidegrees < 0 ? -centidegrees : centidegrees);
        move.u.position_speed.speed = decirpm;
        return send(move);
    }

    // Wire time of request and answer + response time + adapter latency both ways + margin.
    unsigned long answer_timeout_ms(nurimc_message_type type) const {
        uint32_t bytes = (uint32_t)nurimc_spec(type)->size + 4u;
        bytes += (uint32_t)nurimc_spec(nurimc_spec(type)->answer)->size + 4u;
        uint32_t wire_us = (uint32_t)((bytes * NURIMC_HOST_BITS_PER_BYTE * 1000000ull) / baud_);
        uint32_t us = wire_us + response_us_ + 2u * NURIMC_HOST_ADAPTER_LATENCY_US + NURIMC_HOST_MARGIN_US;
        return (unsigned long)(us / 1000u + 1u);
    }

    const nurimc_parser_stats &stats() const { return parser_.stats; }

  private:
    HardwareSerial &port_;
    int dir_pin_;
    uint32_t baud_;
    uint32_t response_us_ = NURIMC_HOST_MAX_RESPONSE_TIME_US;
    nurimc_parser parser_;
};

#endif
