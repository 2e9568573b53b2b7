// nurimc on an Arduino: ping a controller, read its position, move it back and forth.
// Wiring: a MAX485-style transceiver on Serial1, its DE/RE pins tied to DIR_PIN.
// The protocol core allocates nothing and keeps no global state: one parser per bus.
#include <Arduino.h>
#include <nurimc.h>

static const uint8_t DIR_PIN = 2;          // HIGH: transmit, LOW: receive
static const uint8_t MOTOR_ID = 0;
static const uint32_t BAUD = 9600;         // the controllers' factory rate
static const unsigned long ANSWER_MS = 60; // wire time + response time + margin at 9600 bps

static nurimc_parser parser;

static void send(const nurimc_message &msg) {
  uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
  size_t length = 0;
  if (nurimc_encode(&msg, frame, sizeof frame, &length, NULL) != NURIMC_OK) return;
  digitalWrite(DIR_PIN, HIGH);
  Serial1.write(frame, length);
  Serial1.flush();  // wait until the last bit is out before releasing the bus
  digitalWrite(DIR_PIN, LOW);
}

// Send a request and wait for its answer; false on timeout.
static bool ask(nurimc_message_type type, uint8_t id, nurimc_message *answer) {
  nurimc_message request = nurimc_message_init(type, id);
  nurimc_parser_clear(&parser);
  send(request);
  unsigned long start = millis();
  while (millis() - start < ANSWER_MS) {
    while (Serial1.available() > 0) {
      if (nurimc_parser_push(&parser, (uint8_t)Serial1.read(), answer) &&
          answer->type == nurimc_spec(type)->answer && answer->id == id) {
        return true;
      }
    }
  }
  return false;
}

void setup() {
  pinMode(DIR_PIN, OUTPUT);
  digitalWrite(DIR_PIN, LOW);
  Serial.begin(115200);
  Serial1.begin(BAUD);
  nurimc_parser_init(&parser);
}

void loop() {
  nurimc_message answer;
  if (!ask(NURIMC_MSG_REQUEST_PING, MOTOR_ID, &answer)) {
    Serial.println("no answer: check ID, baud rate, A/B wiring and power");
    delay(1000);
    return;
  }
  if (ask(NURIMC_MSG_REQUEST_POSITION, MOTOR_ID, &answer)) {
    Serial.print("position (0.01 deg): ");
    Serial.println(answer.u.position_feedback.position);
  }
  static bool forward = false;
  forward = !forward;
  nurimc_message move = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, MOTOR_ID);
  move.u.position_speed.direction = forward ? 1 : 0;
  move.u.position_speed.position = 9000;  // 90.00 degrees
  move.u.position_speed.speed = 300;      // 30.0 rpm: slow and safe
  send(move);
  delay(2000);
}
