/*
 * Throughput of the codec and the stream parser. Prints one JSON object.
 * Usage: nurimc_bench [FRAMES [ROUNDS]]   (run_bench.py runs it natively and under callgrind)
 * The library's parser runs against hand-written baselines in the same run (docs/performance.md).
 * Each phase is its own non-inlined function so callgrind can count its instructions alone.
 */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "nurimc.h"

#define NOINLINE __attribute__((noinline))

/* CPU time of this thread: on a shared machine, time spent preempted is not the code's. */
static double seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
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
    const uint8_t *bytes = s->bytes;
    size_t length = s->length, at, frames = 0;
    nurimc_parser_init(&parser);
    for (at = 0; at < length; at++) {
        if (nurimc_parser_push(&parser, bytes[at], &msg)) {
            frames++;
            sink += msg.id;
        }
    }
    return frames;
}

/* The same through the out-of-line nurimc_parser_push_checked: a call per byte. */
static NOINLINE size_t bench_push_checked(const stream *s) {
    nurimc_parser parser;
    nurimc_message msg;
    const uint8_t *bytes = s->bytes;
    size_t length = s->length, at, frames = 0;
    nurimc_parser_init(&parser);
    for (at = 0; at < length; at++) {
        if (nurimc_parser_push_checked(&parser, bytes[at], &msg)) {
            frames++;
            sink += msg.id;
        }
    }
    return frames;
}

/* ---- hand-written baselines: what a user would write without the library's parser ----------- */

/* A naive byte state machine: wait for FF FE, take the size byte, collect size + 4 bytes, then
   nurimc_decode them; on any failure start again at the next byte (it drops the whole candidate,
   so unlike the rule it may miss a frame hidden inside a broken one). Not inlined: like the
   library's push, a call per byte. */
typedef struct naive_parser {
    uint8_t buf[NURIMC_MAX_FRAME_LENGTH];
    unsigned length, need;
} naive_parser;

static NOINLINE int naive_push(naive_parser *p, uint8_t byte, nurimc_message *out) {
    switch (p->length) {
    case 0:
        if (byte == NURIMC_HEADER_0) p->buf[p->length++] = byte;
        return 0;
    case 1:
        if (byte == NURIMC_HEADER_1) {
            p->buf[p->length++] = byte;
        } else if (byte != NURIMC_HEADER_0) {
            p->length = 0;
        }
        return 0;
    case 3:
        if (byte < 2 || byte > NURIMC_MAX_SIZE) {
            p->length = 0;
            return 0;
        }
        p->need = (unsigned)byte + NURIMC_FRAME_OVERHEAD;
        p->buf[p->length++] = byte;
        return 0;
    default:
        p->buf[p->length++] = byte;
        if (p->length < 4 || p->length < p->need) return 0;
        p->length = 0;
        return nurimc_decode(p->buf, p->need, out) == NURIMC_OK;
    }
}

static NOINLINE size_t bench_naive_push(const stream *s) {
    naive_parser parser = {{0}, 0, 0};
    nurimc_message msg;
    const uint8_t *bytes = s->bytes;
    size_t length = s->length, at, frames = 0;
    for (at = 0; at < length; at++) {
        if (naive_push(&parser, bytes[at], &msg)) {
            frames++;
            sink += msg.id;
        }
    }
    return frames;
}

/* The floor of any byte-at-a-time parser: the same loop calling a function that only keeps the
   byte. It parses nothing; it shows what the loop and the call per byte cost by themselves. */
typedef struct floor_state {
    uint8_t last;
} floor_state;

static NOINLINE int floor_push(floor_state *f, uint8_t byte, nurimc_message *out) {
    (void)out;
    f->last = byte;
    return 0;
}

static NOINLINE size_t bench_push_floor(const stream *s) {
    floor_state state = {0};
    nurimc_message msg;
    const uint8_t *bytes = s->bytes;
    size_t length = s->length, at, frames = 0;
    memset(&msg, 0, sizeof msg);
    for (at = 0; at < length; at++) {
        if (floor_push(&state, bytes[at], &msg)) {
            frames++;
            sink += msg.id;
        }
    }
    sink += state.last;
    return s->frames; /* (it takes none) */
}

/* A memchr parser: the held tail and the new read in one buffer, memchr to the next FF, check
   FE and the size byte, nurimc_decode the candidate; on failure go on from the next byte. */
typedef struct memchr_parser {
    uint8_t buf[NURIMC_MAX_FRAME_LENGTH + 256];
    size_t length;
} memchr_parser;

static size_t memchr_feed(memchr_parser *p, const uint8_t *data, size_t length, nurimc_frame_callback callback,
                          void *context) {
    size_t pos = 0, count = 0;
    nurimc_message msg;
    memcpy(p->buf + p->length, data, length); /* length <= 256 */
    length += p->length;
    while (pos < length) {
        const uint8_t *ff = memchr(p->buf + pos, NURIMC_HEADER_0, length - pos);
        size_t frame;
        if (ff == NULL) {
            pos = length;
            break;
        }
        pos = (size_t)(ff - p->buf);
        if (length - pos < 4) break; /* hold: it may begin a frame */
        if (p->buf[pos + 1] != NURIMC_HEADER_1 || p->buf[pos + 3] < 2 || p->buf[pos + 3] > NURIMC_MAX_SIZE) {
            pos++;
            continue;
        }
        frame = (size_t)p->buf[pos + 3] + NURIMC_FRAME_OVERHEAD;
        if (length - pos < frame) break;
        if (nurimc_decode(p->buf + pos, frame, &msg) == NURIMC_OK) {
            count++;
            callback(context, &msg);
            pos += frame;
        } else {
            pos++;
        }
    }
    memmove(p->buf, p->buf + pos, length - pos);
    p->length = length - pos;
    return count;
}

static NOINLINE size_t bench_memchr_feed(const stream *s) {
    static memchr_parser parser;
    size_t at, frames = 0;
    parser.length = 0;
    for (at = 0; at < s->length; at += 256) {
        size_t n = s->length - at < 256 ? s->length - at : 256;
        frames += memchr_feed(&parser, s->bytes + at, n, on_frame, NULL);
    }
    return frames;
}

/* ---- the run ------------------------------------------------------------------------------------ */

typedef size_t (*phase_fn)(const stream *);

typedef struct phase {
    const char *name; /* the JSON key of its rate */
    phase_fn fn;
    double best; /* frames/s of the fastest round */
    size_t ok;   /* frames the last round returned */
} phase;

#define ROUNDS 21 /* default; run_bench.py runs one round under callgrind */

int main(int argc, char **argv) {
    size_t frames = argc > 1 ? (size_t)strtoul(argv[1], NULL, 10) : 1000000u;
    int rounds = argc > 2 && atoi(argv[2]) > 0 ? atoi(argv[2]) : ROUNDS;
    stream s = make_stream(frames);
    phase phases[] = {
        {"decode_frames_per_s", bench_decode, 0, 0},
        {"encode_frames_per_s", bench_encode, 0, 0},
        {"parse_feed_frames_per_s", bench_feed, 0, 0},
        {"baseline_memchr_feed_frames_per_s", bench_memchr_feed, 0, 0},
        {"parse_push_frames_per_s", bench_push, 0, 0},
        {"parse_push_checked_frames_per_s", bench_push_checked, 0, 0},
        {"baseline_naive_push_frames_per_s", bench_naive_push, 0, 0},
        {"push_loop_floor_frames_per_s", bench_push_floor, 0, 0},
    };
    size_t count = sizeof phases / sizeof phases[0], i;
    int round;
    /* Interleaved rounds, best of `rounds` per phase: a library phase and its baseline see the
       same machine conditions, and the best round is the least disturbed one. */
    for (round = 0; round < rounds; round++) {
        for (i = 0; i < count; i++) {
            double start = seconds(), elapsed;
            phases[i].ok = phases[i].fn(&s);
            elapsed = seconds() - start;
            if (elapsed > 0 && (double)frames / elapsed > phases[i].best) phases[i].best = (double)frames / elapsed;
        }
    }
    for (i = 0; i < count; i++) {
        if (phases[i].ok != frames) {
            fprintf(stderr, "bench: %s returned %zu of %zu frames\n", phases[i].name, phases[i].ok, frames);
            return 1;
        }
    }
    printf("{\"frames\": %zu, \"stream_bytes\": %zu, \"rounds\": %d", frames, s.length, rounds);
    for (i = 0; i < count; i++) printf(", \"%s\": %.0f", phases[i].name, phases[i].best);
    printf("}\n");
    free(s.bytes);
    free(s.offsets);
    free(s.messages);
    return 0;
}
