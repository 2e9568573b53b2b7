/*
 * Throughput of the codec and the stream parser. Prints one JSON object.
 * Usage: nurimc_bench [FRAMES]   (run_bench.py runs it natively and under callgrind)
 * Each phase is its own non-inlined function so callgrind can count its instructions alone.
 */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "nurimc.h"

#define NOINLINE __attribute__((noinline))

static double seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

typedef struct stream {
    uint8_t *bytes;
    size_t length, frames;
    size_t *offsets;          /* start of each frame */
    nurimc_message *messages; /* what each frame holds */
} stream;

/* Every message type in turn, with typical (mid-range) values, back to back. */
static stream make_stream(size_t frames) {
    stream s;
    size_t i;
    s.bytes = malloc(frames * NURIMC_MAX_FRAME_LENGTH);
    s.offsets = malloc(frames * sizeof *s.offsets);
    s.messages = malloc(frames * sizeof *s.messages);
    s.length = 0;
    s.frames = frames;
    if (s.bytes == NULL || s.offsets == NULL || s.messages == NULL) exit(1);
    for (i = 0; i < frames; i++) {
        nurimc_message msg = nurimc_message_init((nurimc_message_type)(i % NURIMC_MESSAGE_COUNT), (uint8_t)(i % 200u));
        const nurimc_message_spec *spec = nurimc_spec(msg.type);
        size_t length = 0;
        int f;
        for (f = 0; f < spec->field_count; f++) {
            nurimc_set_field(&msg, f, (uint16_t)((spec->fields[f].min + spec->fields[f].max) / 2u));
        }
        nurimc_encode(&msg, s.bytes + s.length, NURIMC_MAX_FRAME_LENGTH, &length, NULL);
        s.offsets[i] = s.length;
        s.messages[i] = msg;
        s.length += length;
    }
    return s;
}

static volatile unsigned long sink;

static NOINLINE size_t bench_decode(const stream *s) {
    size_t i, ok = 0;
    nurimc_message msg;
    for (i = 0; i < s->frames; i++) {
        size_t end = i + 1 < s->frames ? s->offsets[i + 1] : s->length;
        ok += nurimc_decode(s->bytes + s->offsets[i], end - s->offsets[i], &msg) == NURIMC_OK;
        sink += msg.id;
    }
    return ok;
}

static NOINLINE size_t bench_encode(const stream *s) {
    size_t i, ok = 0;
    uint8_t out[NURIMC_MAX_FRAME_LENGTH];
    for (i = 0; i < s->frames; i++) {
        size_t length = 0;
        ok += nurimc_encode(&s->messages[i], out, sizeof out, &length, NULL) == NURIMC_OK;
        sink += out[4];
    }
    return ok;
}

static void on_frame(void *context, const nurimc_message *msg) {
    (void)context;
    sink += msg->id;
}

static NOINLINE size_t bench_feed(const stream *s) {
    nurimc_parser parser;
    size_t at, frames = 0;
    nurimc_parser_init(&parser);
    for (at = 0; at < s->length; at += 256) { /* 256-byte reads, as from a serial driver */
        size_t n = s->length - at < 256 ? s->length - at : 256;
        frames += nurimc_parser_feed(&parser, s->bytes + at, n, on_frame, NULL);
    }
    return frames;
}

static NOINLINE size_t bench_push(const stream *s) {
    nurimc_parser parser;
    nurimc_message msg;
    size_t at, frames = 0;
    nurimc_parser_init(&parser);
    for (at = 0; at < s->length; at++) {
        if (nurimc_parser_push(&parser, s->bytes[at], &msg)) {
            frames++;
            sink += msg.id;
        }
    }
    return frames;
}

typedef size_t (*phase_fn)(const stream *);

static double rate(phase_fn fn, const stream *s, size_t *ok) {
    double best = 0;
    int round;
    for (round = 0; round < 5; round++) { /* best of five: the least disturbed run */
        double start = seconds(), elapsed;
        *ok = fn(s);
        elapsed = seconds() - start;
        if (elapsed > 0 && (double)s->frames / elapsed > best) best = (double)s->frames / elapsed;
    }
    return best;
}

int main(int argc, char **argv) {
    size_t frames = argc > 1 ? (size_t)strtoul(argv[1], NULL, 10) : 1000000u;
    stream s = make_stream(frames);
    size_t ok_decode, ok_encode, ok_feed, ok_push;
    double decode = rate(bench_decode, &s, &ok_decode);
    double encode = rate(bench_encode, &s, &ok_encode);
    double feed = rate(bench_feed, &s, &ok_feed);
    double push = rate(bench_push, &s, &ok_push);
    if (ok_decode != frames || ok_feed != frames || ok_push != frames || ok_encode != frames) {
        fprintf(stderr, "bench: not every frame came back (decode %zu, feed %zu, push %zu of %zu)\n", ok_decode,
                ok_feed, ok_push, frames);
        return 1;
    }
    printf("{\"frames\": %zu, \"stream_bytes\": %zu, \"decode_frames_per_s\": %.0f, \"encode_frames_per_s\": %.0f, "
           "\"parse_feed_frames_per_s\": %.0f, \"parse_push_frames_per_s\": %.0f}\n",
           frames, s.length, decode, encode, feed, push);
    free(s.bytes);
    free(s.offsets);
    free(s.messages);
    return 0;
}
