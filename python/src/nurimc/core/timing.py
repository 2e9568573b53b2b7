"""How long an answer may take: derived from the wire, never guessed.

deadline (from the end of our write) = request wire time + the controller's response time
+ answer wire time + adapter latency (both ways) + a small margin. Wire time of n bytes at
b bps is n * 10 / b (8N1: start + 8 data + stop bits).
"""

from __future__ import annotations

from dataclasses import dataclass

BITS_PER_BYTE = 10
MAX_RESPONSE_TIME = 254 * 100e-6  # the largest response-time setting, 25.4 ms


@dataclass(frozen=True, slots=True)
class Timing:
    latency: float = 0.002  # adapter latency each way (USB adapters: 1-16 ms; see docs/troubleshooting.md)
    margin: float = 0.003  # scheduling slack of a busy host
    #: response time assumed for a controller whose setting is unknown (the largest possible)
    assumed_response_time: float = MAX_RESPONSE_TIME

    @staticmethod
    def wire_time(nbytes: int, baud: int) -> float:
        return nbytes * BITS_PER_BYTE / baud

    def answer_deadline(self, request_len: int, answer_len: int, baud: int, response_time: float | None) -> float:
        response = self.assumed_response_time if response_time is None else response_time
        return self.wire_time(request_len + answer_len, baud) + response + 2 * self.latency + self.margin
