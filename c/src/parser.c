/*
 * The stream parser. The rule (conformance/README.md): where a whole valid frame starts,
 * take it; otherwise drop one byte and look again from the next. Candidates are rejected
 * as soon as their mode byte arrives if their FE, size byte or mode is wrong, so the buffer
 * holds at most one frame.
 *
 * Two paths, one rule (docs/performance.md):
 * - the fast path: while buf[0] is one undecided candidate (state CANDIDATE), `next` says
 *   which byte next needs a look. Bytes before it (FE, ID, size, checksum, data) are only
 *   stored, by the static inline nurimc_parser_push in nurimc.h; the others come to
 *   nurimc_parser_push_boundary_ and get one check each: FF, the mode byte (which checks FE
 *   and the size byte with it: each mode has one size) and the candidate's last byte (the
 *   checksum over the held frame, then the unpack). O(1) per byte, no re-scan, no copy.
 *   nurimc_parser_feed judges whole candidates in place in the caller's bytes, no copy either.
 * - the re-scan (scan()): whenever a held candidate is rejected, or a call has taken a frame
 *   and kept bytes after it, the general scan judges the held bytes from the start, as the rule
 *   says; it is rare (noise, corruption) and bounded by the 12-byte buffer.
 * Checking FE and the size byte at the mode byte, not when they arrive, delays no frame: a
 * frame inside a rejected candidate starts at its second byte or later, so it ends after the
 * mode byte. Only the moment a missing FE or a bad size is counted (and its bytes dropped)
 * moves, by up to four bytes; frames, the byte that completes each, and the counters after
 * nurimc_parser_finish are the same.
 */
#include "nurimc.h"

#include <string.h>

enum verdict { WAIT, REJECT, VALID };

/* parser->state: buf[0..length) is one undecided candidate, a lone FF or nothing (the fast
   path may extend it), or it holds bytes the general scan has not judged yet. */
enum { CANDIDATE = 0, RESCAN = 1 };

enum { ID_OFFSET = 2, SIZE_OFFSET = 3, CHECKSUM_OFFSET = 4, MODE_OFFSET = 5, DATA_OFFSET = 6 };

#if NURIMC_MAX_FRAME_LENGTH != 12
#error "frame_checksum is unrolled for frames of at most 12 bytes"
#endif

/* The checksum of a whole frame of `length` (6..12) bytes; unrolled, as a loop over at most
   six data bytes costs more in set-up (or in vector code) than it saves. */
static uint8_t frame_checksum(const uint8_t *b, unsigned length) {
    unsigned sum = (unsigned)b[ID_OFFSET] + b[SIZE_OFFSET] + b[MODE_OFFSET];
    switch (length) {
    case 12: sum += b[11]; /* fall through */
    case 11: sum += b[10]; /* fall through */
    case 10: sum += b[9];  /* fall through */
    case 9: sum += b[8];   /* fall through */
    case 8: sum += b[7];   /* fall through */
    case 7: sum += b[6];   /* fall through */
    default: break;
    }
    return (uint8_t)~sum;
}

/* nurimc_unpack_valid (codec.c) again, here so that take() and judge() have it inline: a frame
   whose checks all passed -> *out. Fields are in wire order, big-endian, at their offsets. */
static void unpack(const uint8_t *frame, nurimc_message_type type, nurimc_message *out) {
    const nurimc_message_spec *spec = &nurimc_message_specs[type];
    const nurimc_field_spec *f = (const nurimc_field_spec *)NURIMC_TABLE_PTR(spec->fields); /* NULL if none */
    const uint8_t *at = frame + DATA_OFFSET;
    unsigned i, count = NURIMC_TABLE_U8(spec->field_count);
    memset(out, 0, sizeof *out);
    out->type = type;
    out->id = frame[ID_OFFSET];
    for (i = 0; i < count; i++, f++) {
        unsigned char *to = (unsigned char *)out + NURIMC_TABLE_U16(f->offset); /* a uint8_t or uint16_t member */
        if (NURIMC_TABLE_U8(f->width) == 2) {
            *(uint16_t *)(void *)to = (uint16_t)((at[0] << 8) | at[1]);
            at += 2;
        } else {
            *to = *at++;
        }
    }
}

/* Judge the candidate at b[0] (b[0..1] = FF FE, `avail` bytes present). Counts rejections. */
static enum verdict judge(nurimc_parser_stats *stats, const uint8_t *b, size_t avail, nurimc_message *out) {
    uint8_t size;
    uint8_t plus_one;
    if (avail < 4) return WAIT;
    size = b[SIZE_OFFSET];
    if (size < 2 || size > NURIMC_MAX_SIZE) {
        stats->bad_size++;
        return REJECT;
    }
    if (avail < 6) return WAIT;
    plus_one = NURIMC_TABLE_U8(nurimc_type_by_mode_plus_one[b[MODE_OFFSET]]);
    if (plus_one == 0) {
        stats->unknown_mode++;
        return REJECT;
    }
    if (NURIMC_TABLE_U8(nurimc_message_specs[plus_one - 1].size) != size) {
        stats->bad_size++;
        return REJECT;
    }
    if (avail < (size_t)size + NURIMC_FRAME_OVERHEAD) return WAIT;
    if (b[CHECKSUM_OFFSET] != frame_checksum(b, (unsigned)size + NURIMC_FRAME_OVERHEAD)) {
        stats->bad_checksum++;
        return REJECT;
    }
    unpack(b, (nurimc_message_type)(plus_one - 1), out);
    return VALID;
}

/* Resolve what the buffer allows; returns 1 with *out filled if a frame was taken. */
static int scan(nurimc_parser *p, int final, nurimc_message *out) {
    uint8_t *buf = p->buf;
    size_t n = p->length, pos = 0, start;
    int found = 0;
    while (pos < n) {
        for (start = pos; start + 1 < n; start++) {
            if (buf[start] == NURIMC_HEADER_0 && buf[start + 1] == NURIMC_HEADER_1) break;
        }
        if (start + 1 >= n) { /* no header: keep a last FF that may begin one */
            size_t keep = (!final && buf[n - 1] == NURIMC_HEADER_0) ? 1u : 0u;
            p->stats.dropped_bytes += (uint32_t)(n - keep - pos);
            pos = n - keep;
            break;
        }
        p->stats.dropped_bytes += (uint32_t)(start - pos);
        pos = start;
        if (found) break; /* at most one frame per call; the next call takes this one */
        switch (judge(&p->stats, buf + pos, n - pos, out)) {
        case VALID:
            found = 1;
            p->stats.frames++;
            pos += (size_t)buf[pos + 3] + NURIMC_FRAME_OVERHEAD;
            continue;
        case REJECT:
            p->stats.dropped_bytes++;
            pos++;
            continue;
        case WAIT: break;
        }
        if (!final) break; /* an incomplete candidate: wait for more bytes */
        p->stats.dropped_bytes++;
        pos++;
    }
    if (pos > 0) memmove(buf, buf + pos, n - pos);
    p->length = (uint8_t)(n - pos);
    /* Without a frame taken, what is left is one undecided candidate (or FF, or nothing): the
       fast path takes over, told which byte next needs a look. After a frame, the bytes behind
       it are unjudged: the next call scans again. */
    /* (With this protocol's 6..12-byte frames a scan never takes a frame and keeps two or more
       bytes after it: a frame inside a rejected candidate starts at index 6 or later. The state
       keeps the parser right should the sizes change.) A single byte left is a lone FF. */
    if (found && p->length > 1) {
        p->state = RESCAN;
        p->next = 0;
    } else {
        unsigned held = p->length;
        p->state = CANDIDATE;
        p->next = (uint8_t)(held < 2 ? 0u : held < 6 ? MODE_OFFSET : buf[SIZE_OFFSET] + NURIMC_FRAME_OVERHEAD - 1u);
    }
    return found;
}

void nurimc_parser_init(nurimc_parser *parser) {
    if (parser != NULL) memset(parser, 0, sizeof *parser);
}

/* Out of line, so the per-byte path of push needs no saved registers and tail-calls these. */
#if defined(__GNUC__)
#define NOINLINE __attribute__((noinline))
#else
#define NOINLINE
#endif

/* Add `byte` to the held bytes and judge them all again (after a rejection or a frame). */
static NOINLINE int push_and_scan(nurimc_parser *p, uint8_t byte, nurimc_message *out) {
    unsigned n = p->length;
    if (n >= sizeof p->buf) { /* cannot happen: a full frame is always decided */
        p->stats.dropped_bytes++;
        memmove(p->buf, p->buf + 1, sizeof p->buf - 1u);
        n--;
    }
    p->buf[n] = byte;
    p->length = (uint8_t)(n + 1);
    return scan(p, 0, out);
}

/* The candidate's last byte at index n (its FE, size and mode passed): take the frame or re-scan. */
static NOINLINE int take(nurimc_parser *p, unsigned n, uint8_t byte, nurimc_message *out) {
    p->buf[n] = byte;
    if (p->buf[CHECKSUM_OFFSET] != frame_checksum(p->buf, n + 1)) {
        p->length = (uint8_t)(n + 1);
        return scan(p, 0, out);
    }
    p->length = 0;
    p->next = 0;
    p->stats.frames++;
    unpack(p->buf, (nurimc_message_type)(NURIMC_TABLE_U8(nurimc_type_by_mode_plus_one[p->buf[MODE_OFFSET]]) - 1), out);
    return 1;
}

int nurimc_parser_push_checked(nurimc_parser *parser, uint8_t byte, nurimc_message *out) {
    return nurimc_parser_push(parser, byte, out);
}

int nurimc_parser_push_boundary_(nurimc_parser *parser, uint8_t byte, nurimc_message *out) {
    nurimc_parser *p = parser;
    unsigned n = p->length; /* n >= p->next: the inline part stored the bytes below it */
    if (n == p->next) {     /* state CANDIDATE (RESCAN holds two or more bytes, next 0): the byte to look at */
        if (n > MODE_OFFSET) return take(p, n, byte, out); /* the candidate's last byte */
        if (n == MODE_OFFSET) {
            uint8_t plus_one = NURIMC_TABLE_U8(nurimc_type_by_mode_plus_one[byte]);
            unsigned size = p->buf[SIZE_OFFSET];
            /* FE, the size byte (each mode has one size) and the mode together; the scan counts
               which check failed */
            if (p->buf[1] != NURIMC_HEADER_1 || plus_one == 0 ||
                NURIMC_TABLE_U8(nurimc_message_specs[plus_one - 1].size) != size) {
                return push_and_scan(p, byte, out);
            }
            if (size == 2) return take(p, n, byte, out); /* a frame without data ends with its mode byte */
            p->buf[MODE_OFFSET] = byte;
            p->length = DATA_OFFSET;
            p->next = (uint8_t)(size + NURIMC_FRAME_OVERHEAD - 1u); /* only the last data byte needs a look */
            return 0;
        }
        /* n == 0: nothing held */
        if (byte == NURIMC_HEADER_0) {
            p->buf[0] = byte;
            p->length = 1;
            p->next = MODE_OFFSET; /* FE, ID, size and checksum: stored, judged with the mode byte */
        } else {
            p->stats.dropped_bytes++;
        }
        return 0;
    }
    if (n == 1) { /* a lone FF left by a scan (next 0) */
        if (byte == NURIMC_HEADER_1) {
            p->buf[1] = byte;
            p->length = 2;
            p->next = MODE_OFFSET; /* the ID, size and checksum bytes need no look yet */
            p->state = CANDIDATE;
        } else if (byte == NURIMC_HEADER_0) { /* FF FF: the first is dropped, the second may begin one */
            p->stats.dropped_bytes++;
        } else {
            p->stats.dropped_bytes += 2;
            p->length = 0;
        }
        return 0;
    }
    return push_and_scan(p, byte, out); /* state RESCAN */
}

size_t nurimc_parser_feed(nurimc_parser *parser, const uint8_t *data, size_t length, nurimc_frame_callback callback,
                          void *context) {
    size_t i = 0, count = 0;
    nurimc_message msg;
    if (parser == NULL || (data == NULL && length > 0)) return 0;
    while (i < length) {
        if (parser->length == 0) { /* fast path: judge candidates in place, no copy */
            const uint8_t *b = data + i;
            size_t avail = length - i;
            if (b[0] != NURIMC_HEADER_0) { /* noise: skip to the next FF */
                const uint8_t *ff = memchr(b, NURIMC_HEADER_0, avail);
                size_t skip = ff != NULL ? (size_t)(ff - b) : avail;
                parser->stats.dropped_bytes += (uint32_t)skip;
                i += skip;
                continue;
            }
            if (avail >= 2) {
                enum verdict v;
                if (b[1] != NURIMC_HEADER_1) {
                    parser->stats.dropped_bytes++;
                    i++;
                    continue;
                }
                v = judge(&parser->stats, b, avail, &msg);
                if (v == VALID) {
                    parser->stats.frames++;
                    i += (size_t)b[SIZE_OFFSET] + NURIMC_FRAME_OVERHEAD;
                    count++;
                    if (callback != NULL) callback(context, &msg);
                    continue;
                }
                if (v == REJECT) {
                    parser->stats.dropped_bytes++;
                    i++;
                    continue;
                }
            }
            /* an undecided candidate at the end of the chunk: hold it, byte by byte */
        }
        if (nurimc_parser_push(parser, data[i++], &msg)) {
            count++;
            if (callback != NULL) callback(context, &msg);
        }
    }
    return count;
}

int nurimc_parser_finish(nurimc_parser *parser, nurimc_message *out) {
    if (parser == NULL || out == NULL || parser->length == 0) return 0;
    return scan(parser, 1, out);
}

void nurimc_parser_clear(nurimc_parser *parser) {
    if (parser == NULL) return;
    parser->stats.dropped_bytes += parser->length;
    parser->length = 0;
    parser->next = 0;
    parser->state = CANDIDATE;
}

size_t nurimc_parser_pending(const nurimc_parser *parser) {
    return parser ? parser->length : 0u;
}
